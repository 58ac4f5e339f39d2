//! Report section: the FCLIB problems (frictional contact from Siconos' test data, read as
//! box-friction LCPs: per contact one normal row and two friction rows bounded by `±mu f_n`).
//!
//! For each problem and matrix solver, budget [`FCLIB_BUDGET`](crate::report::suite::FCLIB_BUDGET):
//! the solve time when the shared relative residual met 1e-6, else the status and the residual
//! reached (the status alone for `unsupported`); the last row names the fastest solver. One table, `tables/fclib.csv`; empty when the
//! suite has no FCLIB runs.

use crate::harness::{Case, RunRecord, RunStatus};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::suite::{all_solvers, fclib_budget};
use crate::report::table::{fmt_sci, fmt_time, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct Fclib;

impl Section for Fclib {
    fn title(&self) -> &'static str {
        "FCLIB problems"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let cases = &ctx.suite.fclib_cases;
        if cases.is_empty() {
            return Ok(Vec::new());
        }
        let mut header = vec!["solver".to_owned()];
        header.extend(cases.iter().map(|c| column(ctx, c)));
        let mut t = Table::with_header("fclib", header);
        let budget = fclib_budget().name;
        for solver in all_solvers() {
            let mut row = vec![super::findings::solver_cell(&solver)];
            row.extend(cases.iter().map(|c| cell(ctx.get(c, &solver, &budget))));
            t.rows.push(row);
        }
        let mut fastest = vec!["fastest".to_owned()];
        fastest.extend(cases.iter().map(|c| {
            ctx.runs_of(c, &all_solvers(), &budget)
                .into_iter()
                .filter(|r| r.converged)
                .filter_map(|r| r.solve_time_s.map(|t| (r.solver.to_string(), t)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(s, t)| format!("**{s}**, {}", fmt_time(Some(t))))
                .unwrap_or_else(|| "none".to_owned())
        }));
        t.rows.push(fastest);
        let _ = writeln!(
            md,
            "## FCLIB problems\n\nThe FCLIB frictional-contact problems of Siconos' test data \
             (`bench_scenes/fclib/`), each read as a box-friction LCP (per contact a normal row \
             and two friction rows bounded by ±mu·f_n). Every matrix solver, cold start, budget \
             `{budget}`: the solve time when the shared relative residual reached 1e-6, \
             otherwise the status and the residual it ended at.\n\n{}\n{}",
            ctx.table(&t)?,
            super::findings::relaxation_footnote(&all_solvers())
        );
        Ok(Vec::new())
    }
}

/// `name (rows)`, the row count from any run of the case.
fn column(ctx: &ReportContext, case: &Case) -> String {
    let name = case.short_name();
    let budget = fclib_budget().name;
    let n = all_solvers()
        .iter()
        .find_map(|s| ctx.get(case, s, &budget).and_then(|r| r.n));
    match n {
        Some(n) => format!("{name} ({n} rows)"),
        None => name,
    }
}

fn cell(r: Option<&RunRecord>) -> String {
    match r {
        None => "–".to_owned(),
        Some(r) if r.converged => fmt_time(r.solve_time_s),
        // The residual of an unsupported run is that of `f = 0`: nothing was solved.
        Some(r) if r.status == RunStatus::Unsupported => r.status.to_string(),
        Some(r) => match r.residual_rel {
            Some(res) => format!("{} ({})", r.status, fmt_sci(Some(res))),
            None => r.status.to_string(),
        },
    }
}

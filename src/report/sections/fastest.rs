//! The fastest matrix solver per feasible problem: the solver whose residual history (budget
//! `tight`) first reached the relative residual 1e-4, and 1e-8, and when.

use crate::harness::{BudgetName, Case, ProblemClass};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::suite::all_solvers;
use crate::report::table::{fmt_time, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct Fastest;

/// The budget of the runs compared: `tight`, whose residual histories reach 1e-10.
const BUDGET: BudgetName = BudgetName::Tight;

impl Section for Fastest {
    fn title(&self) -> &'static str {
        "Fastest solver per problem"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let mut fastest = Table::new(
            "fastest",
            &[
                "case",
                "n",
                "fastest to 1e-4",
                "time",
                "fastest to 1e-8",
                "time",
            ],
        );
        for case in &ctx.lcp_cases {
            if case.class() != ProblemClass::Infeasible {
                fastest.rows.push(row(ctx, case));
            }
        }
        let _ = writeln!(
            md,
            "## Fastest solver per problem\n\nSolver time until the shared relative residual first \
             reached 1e-4 and 1e-8 (from the residual history of each solve under budget `{BUDGET}`): \
             the rule of [Findings](#findings) on one problem.\n\n{}",
            ctx.table(&fastest)?
        );
        Ok(Vec::new())
    }
}

fn row(ctx: &ReportContext, case: &Case) -> Vec<String> {
    let mut row = vec![format!("`{case}`")];
    let n = all_solvers()
        .iter()
        .find_map(|s| ctx.get(case, s, &BUDGET).and_then(|r| r.n));
    row.push(n.map(|n| n.to_string()).unwrap_or_default());
    for level in [1e-4, 1e-8] {
        let best = all_solvers()
            .iter()
            .filter_map(|s| ctx.get(case, s, &BUDGET))
            .filter_map(|r| r.tta(level).map(|t| (r.solver.to_string(), t)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((s, t)) => {
                row.push(s);
                row.push(fmt_time(Some(t)));
            }
            None => {
                row.push("none".into());
                row.push("–".into());
            }
        }
    }
    row
}

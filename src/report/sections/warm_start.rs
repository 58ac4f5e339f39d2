//! Warm start against cold start: iterations, solver time and status of every iterative matrix
//! solver, cold and `+warm`, on the suite's warm cases (budget `default`).

use super::per_case::{time_cell, warm_cell};
use crate::harness::{BudgetName, Case, RunRecord, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::table::Table;
use anyhow::Result;
use lcpbench_solvers::SolverKind;
use std::fmt::Write as _;

pub(super) struct WarmStart;

/// The budget of the warm and cold runs.
const BUDGET: BudgetName = BudgetName::Default;

impl Section for WarmStart {
    fn title(&self) -> &'static str {
        "Warm start versus cold start"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let mut warm = Table::new(
            "warm_vs_cold",
            &[
                "case",
                "solver",
                "iterations cold",
                "iterations warm",
                "time cold",
                "time warm",
                "warm start (source, cost)",
                "status cold / warm",
            ],
        );
        for case in &ctx.suite.warm_cases {
            for kind in SolverKind::all().into_iter().filter(|k| k.is_iterative()) {
                let spec = SolverSpec::plain(kind);
                let cold = ctx.get(case, &spec, &BUDGET);
                let hot = ctx.get(case, &spec.clone().with_warm(), &BUDGET);
                if cold.is_some() || hot.is_some() {
                    warm.rows.push(row(case, kind.name(), cold, hot));
                }
            }
        }
        let _ = writeln!(
            md,
            "## Warm start versus cold start\n\nIterative solvers, budget `{BUDGET}`. The warm start \
             of a generated problem is its planted solution perturbed by 1 % (as from the previous \
             step of a slowly changing scene); of a problem file, 20 cold PGS sweeps. Times are medians of \
             the timed solves with their fastest and slowest; the warm start's source and the time \
             to compute it are beside them, not part of the warm time.\n\n{}",
            ctx.table(&warm)?
        );
        Ok(Vec::new())
    }
}

fn row(
    case: &Case,
    solver: &str,
    cold: Option<&RunRecord>,
    hot: Option<&RunRecord>,
) -> Vec<String> {
    let it = |r: Option<&RunRecord>| {
        r.and_then(|r| r.iterations)
            .map(|i| i.to_string())
            .unwrap_or("–".into())
    };
    let st = |r: Option<&RunRecord>| r.map(|r| r.status.to_string()).unwrap_or("–".into());
    vec![
        format!("`{case}`"),
        solver.to_owned(),
        it(cold),
        it(hot),
        cold.map_or("–".into(), time_cell),
        hot.map_or("–".into(), time_cell),
        hot.map_or("–".into(), warm_cell),
        format!("{} / {}", st(cold), st(hot)),
    ]
}

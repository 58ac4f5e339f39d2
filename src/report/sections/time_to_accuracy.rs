//! Time to accuracy: on how many feasible problems (the matrix and the exported scene LCPs,
//! budget `tight`) each matrix solver reached the relative residuals 1e-4 … 1e-10, and the
//! geometric mean of the time it took; per problem in `tables/time_to_accuracy.csv`.

use super::findings::solver_cell;
use crate::harness::{BudgetName, RunRecord, SolverSpec, TTA_LEVELS};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::suite::all_solvers;
use crate::report::summary::{rank, Candidate};
use crate::report::table::{fmt_time, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct TimeToAccuracy;

/// The budget of the runs measured: `tight`, whose residual histories reach 1e-10.
const BUDGET: BudgetName = BudgetName::Tight;

impl Section for TimeToAccuracy {
    fn title(&self) -> &'static str {
        "Time to accuracy"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let mut tta = Table::new(
            "time_to_accuracy_summary",
            &["solver", "≤1e-4", "≤1e-6", "≤1e-8", "≤1e-10"],
        );
        let mut tta_full = Table::new(
            "time_to_accuracy",
            &[
                "case", "solver", "t_1e-4", "t_1e-6", "t_1e-8", "t_1e-10", "status",
            ],
        );
        let every: Vec<&RunRecord> = all_solvers()
            .iter()
            .flat_map(|s| {
                ctx.feasible_cases
                    .iter()
                    .filter_map(|c| ctx.get(c, s, &BUDGET))
            })
            .collect();
        let ranked: Vec<Vec<Candidate>> = TTA_LEVELS.iter().map(|&l| rank(&every, l)).collect();
        for solver in all_solvers() {
            let runs: Vec<&RunRecord> = every
                .iter()
                .copied()
                .filter(|r| r.solver == solver)
                .collect();
            if runs.is_empty() {
                continue;
            }
            tta.rows.push(summary_row(&solver, &ranked));
            tta_full.rows.extend(runs.iter().map(|r| full_row(r)));
        }
        let summary = ctx.table(&tta)?;
        tta_full.write_csv(&ctx.tables_dir)?;
        let _ = writeln!(
            md,
            "## Time to accuracy\n\nProblems (feasible ones of the matrix{}) on which each solver \
             reached the relative residual, and the shifted geometric mean (shift 10 µs) of its \
             time over every problem of the set, a problem not reached counted at the budget's \
             seconds, so every solver's mean is over the same problems (the rule of \
             [Findings](#findings)); per problem in \
             [`tables/time_to_accuracy.csv`](tables/time_to_accuracy.csv).\n\n{}",
            if ctx.suite.exported_cases.is_empty() {
                ""
            } else {
                " and the exported scene LCPs"
            },
            summary
        );
        Ok(Vec::new())
    }
}

fn summary_row(solver: &SolverSpec, ranked: &[Vec<Candidate>]) -> Vec<String> {
    let mut row = vec![solver_cell(solver)];
    for level in ranked {
        row.push(match level.iter().find(|c| c.solver == *solver) {
            Some(c) => format!(
                "{}/{} (shifted geo. mean {})",
                c.solved,
                c.total,
                fmt_time(Some(c.mean_s))
            ),
            None => "–".into(),
        });
    }
    row
}

fn full_row(r: &RunRecord) -> Vec<String> {
    let mut row = vec![r.case.clone(), r.solver.to_string()];
    row.extend(
        TTA_LEVELS
            .iter()
            .map(|&l| r.tta(l).map(|t| format!("{t:e}")).unwrap_or_default()),
    );
    row.push(r.status.to_string());
    row
}

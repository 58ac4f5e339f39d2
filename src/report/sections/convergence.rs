//! Convergence histories: for each of the suite's history cases, the relative residual of
//! every matrix solver against iterations and against solver time (budget `tight`, whose
//! histories reach 1e-10): figures only.

use crate::harness::{BudgetName, Case, HistoryRow};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::plots::{plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::table::slug;
use anyhow::Result;
use std::collections::BTreeMap;

pub(super) struct Convergence;

/// The budget whose histories are plotted: `tight`, whose histories reach 1e-10.
const BUDGET: BudgetName = BudgetName::Tight;

/// The two x axes: name, label.
const AXES: [(&str, &str); 2] = [
    ("iter", "iterations (sweeps, pivots, interior-point steps)"),
    ("time", "solver time (s)"),
];

impl Section for Convergence {
    fn title(&self) -> &'static str {
        "Convergence histories"
    }

    fn render(&self, ctx: &ReportContext, _md: &mut String) -> Result<Vec<Figure>> {
        let mut figures = Vec::new();
        for case in &ctx.suite.history_cases {
            let by_solver = histories(ctx, case);
            for (axis, x_label) in AXES {
                let path = ctx.plots_dir.join(format!(
                    "convergence_{}_{axis}.svg",
                    // The case's name, not its path (a file case's key holds the path).
                    slug(&case.short_name())
                ));
                plot(
                    &path,
                    &PlotSpec {
                        title: format!("Convergence on {case}"),
                        x_label: x_label.into(),
                        y_label: "relative natural-map residual".into(),
                        log_x: true,
                        log_y: true,
                        y_range: None,
                        legend: LegendAt::UpperRight,
                    },
                    &series(&by_solver, axis),
                )?;
                figures.push(Figure::new(
                    format!("Residual against {axis} on `{case}` (budget {BUDGET})"),
                    path,
                ));
            }
        }
        Ok(figures)
    }
}

/// The case's history rows under budget `tight`, per matrix solver.
fn histories<'a>(ctx: &ReportContext<'a>, case: &Case) -> BTreeMap<String, Vec<&'a HistoryRow>> {
    let key = case.to_string();
    let mut by_solver: BTreeMap<String, Vec<&HistoryRow>> = BTreeMap::new();
    for h in ctx
        .histories
        .iter()
        .filter(|h| h.case == key && h.budget == BUDGET)
    {
        if h.solver.plain_kind().is_some() {
            by_solver.entry(h.solver.to_string()).or_default().push(h);
        }
    }
    by_solver
}

fn series(by_solver: &BTreeMap<String, Vec<&HistoryRow>>, axis: &str) -> Vec<Series> {
    by_solver
        .iter()
        .map(|(s, pts)| Series {
            name: s.clone(),
            color_key: s.clone(),
            points: pts
                .iter()
                .map(|h| {
                    let x = if axis == "iter" {
                        h.iteration as f64
                    } else {
                        h.time_s
                    };
                    (x, h.residual.max(1e-17))
                })
                .collect(),
            mark: Mark::Line,
        })
        .collect()
}

//! Dolan–Moré performance profiles of the matrix solvers on the feasible problems (budget
//! `tight`), at the relative residuals 1e-4 and 1e-8: figures only. The profile computation
//! and its figure are shared with the cone solvers' section.
//!
//! Reference: E. D. Dolan and J. J. Moré, "Benchmarking optimization software with
//! performance profiles", Math. Program. 91 (2002).

use crate::harness::{BudgetName, Case, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::plots::{plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::suite::all_solvers;
use anyhow::Result;
use std::path::Path;

pub(super) struct Profiles;

/// The budget of the runs profiled: `tight`, whose residual histories reach 1e-10.
const BUDGET: BudgetName = BudgetName::Tight;

impl Section for Profiles {
    fn title(&self) -> &'static str {
        "Performance profiles of the matrix solvers"
    }

    fn render(&self, ctx: &ReportContext, _md: &mut String) -> Result<Vec<Figure>> {
        let solvers = all_solvers();
        let mut figures = Vec::new();
        for (level, label) in [(1e-4, "1e-4"), (1e-8, "1e-8")] {
            let path = ctx.plots_dir.join(format!("profile_{label}.svg"));
            let series = performance_profile(ctx, &ctx.feasible_cases, &solvers, &BUDGET, level);
            profile_plot(
                &path,
                format!("Performance profile, time to relative residual {label}"),
                &series,
            )?;
            figures.push(Figure::new(
                format!("Dolan–Moré performance profile at {label}"),
                path,
            ));
        }
        Ok(figures)
    }
}

/// Dolan–Moré profile: for each solver, the fraction of problems it solves within `τ` times the
/// best solver's time, over the problems at least one solver solved (runs of `budget`).
pub(super) fn performance_profile(
    ctx: &ReportContext,
    cases: &[&Case],
    solvers: &[SolverSpec],
    budget: &BudgetName,
    level: f64,
) -> Vec<Series> {
    let mut ratios: Vec<Vec<f64>> = vec![Vec::new(); solvers.len()];
    let mut problems = 0usize;
    for case in cases {
        let times: Vec<Option<f64>> = solvers
            .iter()
            .map(|s| ctx.get(case, s, budget).and_then(|r| r.tta(level)))
            .collect();
        let Some(best) = times.iter().flatten().copied().reduce(f64::min) else {
            continue;
        };
        problems += 1;
        let best = best.max(1e-9);
        for (solver_ratios, t) in ratios.iter_mut().zip(&times) {
            if let Some(t) = t {
                solver_ratios.push(t.max(1e-9) / best);
            }
        }
    }
    solvers
        .iter()
        .zip(ratios)
        .map(|(s, r)| profile_series(&s.to_string(), r, problems))
        .collect()
}

/// One solver's staircase from its time ratios.
fn profile_series(solver: &str, mut ratios: Vec<f64>, problems: usize) -> Series {
    ratios.sort_by(f64::total_cmp);
    let points: Vec<(f64, f64)> = ratios
        .iter()
        .enumerate()
        .map(|(i, &tau)| (tau.max(1.0), (i + 1) as f64 / problems.max(1) as f64))
        .collect();
    let reached = ratios.len();
    Series {
        name: format!("{solver} ({reached}/{problems})"),
        color_key: solver.to_owned(),
        points,
        mark: Mark::Step,
    }
}

/// A Dolan–Moré profile figure (log τ, fraction solved).
pub(super) fn profile_plot(path: &Path, title: String, series: &[Series]) -> Result<()> {
    plot(
        path,
        &PlotSpec {
            title,
            x_label: "τ (time / best time)".into(),
            y_label: "fraction of problems solved within τ × best".into(),
            log_x: true,
            log_y: false,
            y_range: Some((0.0, 1.02)),
            legend: LegendAt::LowerRight,
        },
        series,
    )
}

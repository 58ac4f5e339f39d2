//! Scaling: least-squares slopes of log time against log size, for the matrix solvers on the
//! SPD scaling family (solver time against rows, converged runs) and for every scene solver on
//! the scene scaling family, or on every scene when that family did not run (solver time per
//! step against mean contacts, runs in which every step taken converged, without blow-up,
//! isolation failure or fallback steps: a run stopped by its time limit counts with the steps it
//! finished, but a step cut short by the limit or by the iteration cap would bend the line); a
//! table of the slopes and a log–log figure of each with the fitted lines.

use crate::harness::BudgetName;
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::plots::{loglog_fit, plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::suite::{all_solvers, scene_solvers};
use crate::report::table::Table;
use anyhow::Result;
use std::collections::HashMap;
use std::fmt::Write as _;

pub(super) struct Scaling;

/// Fitted slope per solver, formatted.
type Slopes = HashMap<String, String>;

impl Section for Scaling {
    fn title(&self) -> &'static str {
        "Scaling"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let mut figures = Vec::new();
        let mut scene_slope = Slopes::new();
        figures.extend(scene_scaling(ctx, &mut scene_slope)?);
        let mut lcp_slope = Slopes::new();
        figures.push(lcp_scaling(ctx, &mut lcp_slope)?);
        let mut slopes = Table::new(
            "scaling_slopes",
            &[
                "solver",
                "time ∝ n^k (SPD LCPs, budget default)",
                "time/step ∝ contacts^k (scene scaling family)",
            ],
        );
        for solver in scene_solvers() {
            let name = solver.to_string();
            slopes.rows.push(vec![
                name.clone(),
                lcp_slope.get(&name).cloned().unwrap_or("–".into()),
                scene_slope.get(&name).cloned().unwrap_or("–".into()),
            ]);
        }
        let _ = writeln!(
            md,
            "## Scaling\n\nLeast-squares slopes of log time against log size: converged LCP runs; scene runs in which every step taken converged (a run stopped by its time limit counts with the steps it finished).\n\n{}",
            ctx.table(&slopes)?
        );
        Ok(figures)
    }
}

/// Solver time per step against contacts on the scene scaling family (every scene when it did
/// not run); no figure when there are no scenes.
fn scene_scaling(ctx: &ReportContext, slopes: &mut Slopes) -> Result<Option<Figure>> {
    let suite = ctx.suite;
    let scaling_scenes = if suite.scene_scaling_cases.is_empty() {
        &suite.scene_cases
    } else {
        &suite.scene_scaling_cases
    };
    if scaling_scenes.is_empty() {
        return Ok(None);
    }
    let mut series = Vec::new();
    for solver in scene_solvers() {
        let pts: Vec<(f64, f64)> = scaling_scenes
            .iter()
            .filter_map(|c| ctx.get(c, &solver, &BudgetName::Default))
            .filter(|r| {
                r.blow_up != Some(true)
                    && !r.is_isolation_failure()
                    && r.fallback_steps == Some(0)
                    && r.nonconverged_steps == Some(0)
            })
            .filter_map(|r| Some((r.contacts_mean?, r.time_per_step_s?)))
            .filter(|(c, t)| *c > 0.0 && *t > 0.0)
            .collect();
        push_fit(&mut series, &solver.to_string(), pts, slopes);
    }
    let path = ctx.plots_dir.join("scaling_scenes.svg");
    plot(
        &path,
        &PlotSpec {
            title: "Scenes: solver time per step against contacts".into(),
            x_label: "mean contacts per step".into(),
            y_label: "solver time per step (s)".into(),
            log_x: true,
            log_y: true,
            y_range: None,
            legend: LegendAt::LowerRight,
        },
        &series,
    )?;
    Ok(Some(Figure::new(
        "Solver time per step against contacts (log–log, fitted slopes)",
        path,
    )))
}

/// Solver time against rows on the SPD scaling family (converged runs).
fn lcp_scaling(ctx: &ReportContext, slopes: &mut Slopes) -> Result<Figure> {
    let mut series = Vec::new();
    for solver in all_solvers() {
        let pts: Vec<(f64, f64)> = ctx
            .suite
            .scaling_cases
            .iter()
            .filter_map(|c| ctx.get(c, &solver, &BudgetName::Default))
            .filter(|r| r.converged)
            .filter_map(|r| Some((r.n? as f64, r.solve_time_s?)))
            .collect();
        push_fit(&mut series, &solver.to_string(), pts, slopes);
    }
    let path = ctx.plots_dir.join("scaling_lcp.svg");
    plot(
        &path,
        &PlotSpec {
            title: "SPD LCPs (cond 1e3): solver time against rows".into(),
            x_label: "rows n".into(),
            y_label: "solver time to 1e-8 (s)".into(),
            log_x: true,
            log_y: true,
            y_range: None,
            legend: LegendAt::LowerRight,
        },
        &series,
    )?;
    Ok(Figure::new(
        "Solver time against problem size (log–log, fitted slopes)",
        path,
    ))
}

/// The solver's points (sorted by size) and, when they fit, the fitted line; records the slope.
fn push_fit(series: &mut Vec<Series>, solver: &str, mut pts: Vec<(f64, f64)>, slopes: &mut Slopes) {
    if pts.is_empty() {
        return;
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let fit = loglog_fit(&pts);
    let name = match fit {
        Some((k, _)) => {
            slopes.insert(solver.to_owned(), format!("{k:.2}"));
            format!("{solver} (slope {k:.2})")
        }
        None => solver.to_owned(),
    };
    if let Some((k, c)) = fit {
        let (x0, x1) = (pts[0].0, pts[pts.len() - 1].0);
        series.push(Series {
            name: String::new(),
            color_key: solver.to_owned(),
            points: vec![
                (x0, 10f64.powf(c) * x0.powf(k)),
                (x1, 10f64.powf(c) * x1.powf(k)),
            ],
            mark: Mark::Line,
        });
    }
    series.push(Series {
        name,
        color_key: solver.to_owned(),
        points: pts,
        mark: Mark::Points,
    });
}

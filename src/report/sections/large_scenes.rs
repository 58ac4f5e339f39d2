//! The large scenes (more than [`LARGE_SCENE_BODIES`] dynamic bodies), where solvers differ
//! most: the best solver at each budget with its time per step and converged steps, what the
//! suite leaves out on them, and per scene the speed–accuracy figure against the worst step
//! residual (the one against the median is in the scenes section).

use super::scenes::{converged_steps, speed_accuracy_figure};
use crate::harness::{BudgetName, Case, RunRecord};
use crate::report::context::{scene_solvers_cold_and_warm, Figure, ReportContext, Section};
use crate::report::suite::{
    scene_solvers, LARGE_SCENE_BODIES, LARGE_SCENE_STEPS, LARGE_SCENE_STEP_EXCEPTIONS,
    SCENE_BUDGETS,
};
use crate::report::table::{fmt_time, slug, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct LargeScenes;

impl Section for LargeScenes {
    fn title(&self) -> &'static str {
        "Large scenes"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let cases = &ctx.suite.large_scene_cases;
        if cases.is_empty() {
            return Ok(Vec::new());
        }
        let exceptions: Vec<String> = LARGE_SCENE_STEP_EXCEPTIONS
            .iter()
            .map(|(name, steps)| format!("{name} {steps}"))
            .collect();
        let _ = writeln!(
            md,
            "## Large scenes\n\nThe scenes with more than {LARGE_SCENE_BODIES} dynamic bodies, \
             under every budget of the scene runs ({}), each solver cold and the iterative ones \
             warm-started. Per budget, the best solver by the rule of [Findings](#findings) \
             restricted to that budget: the fastest whose every step converged (time per step, \
             converged steps / steps); where none converged on every step, the one with the \
             most converged steps. What the suite leaves out here: the runs take \
             {LARGE_SCENE_STEPS} steps ({}; the sphere piles fall for their first 17 steps); \
             budget `tight` is not run; a run stops after three consecutive steps over the \
             per-step budget (`cut` in the tables).\n",
            SCENE_BUDGETS
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            exceptions.join(", ")
        );
        let mut header = vec![
            "scene".to_owned(),
            "rows (max)".to_owned(),
            "contacts (mean)".to_owned(),
        ];
        header.extend(SCENE_BUDGETS.iter().map(|b| format!("best at {b}")));
        let mut best = Table::with_header("large_scenes_best", header);
        let mut figures = Vec::new();
        for case in cases {
            let any = SCENE_BUDGETS
                .iter()
                .flat_map(|b| ctx.runs_of(case, &scene_solvers(), b))
                .next();
            let mut row = vec![
                case.short_name(),
                any.and_then(|r| r.n).map_or("–".into(), |n| n.to_string()),
                any.and_then(|r| r.contacts_mean)
                    .map_or("–".into(), |c| format!("{c:.0}")),
            ];
            for budget in &SCENE_BUDGETS {
                row.push(best_cell(ctx, case, budget));
            }
            best.rows.push(row);
            let name = case.short_name();
            let path = ctx
                .plots_dir
                .join(format!("large_worst_{}.svg", slug(&name)));
            speed_accuracy_figure(ctx, case, &path, &super::scenes::scene_budgets())?;
            figures.push(Figure::new(
                format!("Speed–accuracy on large scene {name} (worst step residual)"),
                path,
            ));
        }
        let _ = writeln!(md, "{}", ctx.table(&best)?);
        Ok(figures)
    }
}

/// The best run on `case` under `budget` among every solver, cold and warm.
fn best_cell(ctx: &ReportContext, case: &Case, budget: &BudgetName) -> String {
    let runs: Vec<&RunRecord> = ctx
        .runs_of(case, &scene_solvers_cold_and_warm(), budget)
        .into_iter()
        .filter(|r| !r.is_isolation_failure() && r.blow_up != Some(true))
        .collect();
    let every_step = runs
        .iter()
        .filter(|r| r.converged)
        .filter_map(|r| Some((*r, r.time_per_step_s?)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((r, t)) = every_step {
        return format!("{} {} ({})", r.solver, fmt_time(Some(t)), fraction(r));
    }
    let most = runs
        .iter()
        .filter_map(|r| Some((*r, converged_steps(r)?, r.time_per_step_s?)))
        .filter(|&(_, converged, _)| converged > 0)
        .max_by(|a, b| a.1.cmp(&b.1).then(b.2.total_cmp(&a.2)));
    match most {
        Some((r, _, t)) => format!(
            "none on every step; most: {} {} ({})",
            r.solver,
            fmt_time(Some(t)),
            fraction(r)
        ),
        None if runs.is_empty() => "–".into(),
        None => "no step converged".into(),
    }
}

/// Converged steps / planned steps.
fn fraction(r: &RunRecord) -> String {
    let planned = r.steps_planned.or(r.steps).unwrap_or(0);
    super::scenes::converged_fraction(r, planned)
}

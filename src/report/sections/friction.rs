//! The friction-model comparison of the report: the scenes of
//! [`FRICTION_SCENES`](crate::report::suite::FRICTION_SCENES) under the box, pyramid and cone
//! models, one row per model × solver, with each scene's own measure (a tower's sag and drift,
//! an incline's acceleration error, the creep of boxes that must stick, the sliding-direction
//! error of the diagonal push: the box model's anisotropy) and the number of converged steps
//! (`tables/friction_models.csv`), then the solver time per step of the same runs
//! (`tables/friction_models_time.csv`). Empty when the suite has no friction-model runs.

use crate::harness::{Case, RunRecord, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::status;
use crate::report::suite::{friction_budget, Suite, FRICTION_BUDGET, FRICTION_MODELS};
use crate::report::table::{fmt_sci, fmt_time, Table};
use anyhow::Result;
use lcpbench_contact::FrictionModel;
use std::fmt::Write as _;

pub(super) struct FrictionModels;

impl Section for FrictionModels {
    fn title(&self) -> &'static str {
        "Friction models"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        if !ctx.suite.friction_cases.is_empty() {
            friction_section(md, ctx)?;
        }
        Ok(Vec::new())
    }
}

/// The scenes of the comparison in order, each with its case per model.
fn scenes(suite: &Suite) -> Vec<(String, Vec<&Case>)> {
    let mut out: Vec<(String, Vec<&Case>)> = Vec::new();
    for case in &suite.friction_cases {
        let name = case.short_name();
        match out.iter_mut().find(|(n, _)| *n == name) {
            Some((_, cases)) => cases.push(case),
            None => out.push((name, vec![case])),
        }
    }
    out
}

fn model_of(case: &Case) -> Option<FrictionModel> {
    match case {
        Case::Scene { friction, .. } => *friction,
        _ => None,
    }
}

/// The scene's own measure in a run: sag and drift of a stack, else the analytic error, else
/// the creep speed of bodies that must stick.
fn measure(r: &RunRecord) -> String {
    if status::unsupported(r) && r.steps.unwrap_or(0) == 0 {
        return "unsupported".into();
    }
    let value = if let (Some(sag), Some(drift)) = (r.sag, r.lateral_drift) {
        format!("{} / {} m", fmt_sci(Some(sag)), fmt_sci(Some(drift)))
    } else if let Some(e) = r.analytic_error {
        fmt_sci(Some(e))
    } else if let Some(c) = r.creep_speed {
        format!("{} m/s", fmt_sci(Some(c)))
    } else {
        "–".into()
    };
    if r.blow_up == Some(true) {
        format!("{value} (blow-up)")
    } else {
        value
    }
}

/// What [`measure`] shows for a scene, for the column header.
fn measure_name(rows: &[&RunRecord]) -> String {
    let Some(r) = rows.first() else {
        return "–".into();
    };
    if r.sag.is_some() {
        "sag / drift".into()
    } else if !r.analytic_metric.is_empty() {
        r.analytic_metric.clone()
    } else if r.creep_speed.is_some() {
        "creep".into()
    } else {
        "–".into()
    }
}

/// The scenes of the comparison, each with its case per model.
type FrictionScenes<'a> = [(String, Vec<&'a Case>)];

/// The run of `solver` on the scene's case under `model`.
fn run<'a>(
    ctx: &ReportContext<'a>,
    cases: &[&Case],
    model: FrictionModel,
    solver: &SolverSpec,
) -> Option<&'a RunRecord> {
    cases
        .iter()
        .find(|c| model_of(c) == Some(model))
        .and_then(|c| ctx.get(c, solver, &friction_budget().name))
}

/// Write the section and its two tables (`friction_models`, `friction_models_time`).
fn friction_section(md: &mut String, ctx: &ReportContext) -> Result<()> {
    let scenes = scenes(ctx.suite);
    let (table, times) = tables(ctx, &scenes);
    let _ = writeln!(
        md,
        "## Friction models\n\nThe same scenes under the box model (two tangent rows bounded by \
         `±mu f_n` each), the Stewart–Trinkle pyramid (4 directions) and the exact Coulomb cone \
         (`friction_model = \"cone\"`, solved by the cone solvers), budget `{FRICTION_BUDGET}` \
         (tolerance, sweeps or iterations per step, seconds). Each scene's measure: a tower's sag and lateral drift of the top box; \
         the incline's acceleration error against g (sin θ − mu cos θ); the creep speed of the \
         boxes of `friction_ramp` that must stick; for `diagonal_push`, the angle between the \
         box's displacement and the push (30° off the x axis): the cone slides along the push, \
         the box model bounds x and y friction separately and slides the box along x. \
         Converged steps count the steps that met the tolerance, over all four scenes.\n\n{}",
        ctx.table(&table)?
    );
    let solvers: Vec<SolverSpec> = FRICTION_MODELS
        .iter()
        .flat_map(|(_, specs)| specs.iter().cloned())
        .collect();
    let _ = writeln!(
        md,
        "Solver time per step of the same runs:\n\n{}\n{}",
        ctx.table(&times)?,
        super::findings::relaxation_footnote(&solvers)
    );
    Ok(())
}

/// The column headers of the measure table and of the time table.
fn headers(ctx: &ReportContext, scenes: &FrictionScenes) -> (Vec<String>, Vec<String>) {
    let mut header = vec!["model".to_owned(), "solver".to_owned()];
    let mut time_header = header.clone();
    for (name, cases) in scenes {
        let rows: Vec<&RunRecord> = FRICTION_MODELS
            .iter()
            .flat_map(|(m, solvers)| solvers.iter().filter_map(|s| run(ctx, cases, *m, s)))
            .filter(|r| r.steps.unwrap_or(0) > 0)
            .collect();
        header.push(format!("{name}: {}", measure_name(&rows)));
        time_header.push(name.clone());
    }
    header.push("converged steps".into());
    (header, time_header)
}

/// The measure table and the time table: one row per model × solver.
fn tables(ctx: &ReportContext, scenes: &FrictionScenes) -> (Table, Table) {
    let (header, time_header) = headers(ctx, scenes);
    let mut table = Table::with_header("friction_models", header);
    let mut times = Table::with_header("friction_models_time", time_header);
    for (model, solvers) in FRICTION_MODELS {
        for solver in solvers {
            let mut row = vec![model.name(), super::findings::solver_cell(solver)];
            let mut time_row = row.clone();
            let (mut done, mut converged) = (0, 0);
            for (_, cases) in scenes {
                match run(ctx, cases, model, solver) {
                    Some(r) => {
                        row.push(measure(r));
                        time_row.push(fmt_time(r.time_per_step_s));
                        // Of the measured steps (every step unless a residual schedule left
                        // some out).
                        let steps = r.measured_steps().unwrap_or(0);
                        done += steps;
                        converged += r.converged_steps().unwrap_or(0);
                    }
                    None => {
                        row.push("–".into());
                        time_row.push("–".into());
                    }
                }
            }
            row.push(format!("{converged} / {done}"));
            table.rows.push(row);
            times.rows.push(time_row);
        }
    }
    (table, times)
}

//! The friction-model comparison of the report: the scenes of
//! [`FRICTION_SCENES`](super::suite::FRICTION_SCENES) under the box, pyramid and cone models, one
//! row per model × solver, with each scene's own measure (a tower's sag and drift, an incline's
//! acceleration error, the creep of boxes that must stick, the sliding-direction error of the
//! diagonal push: the box model's anisotropy) and the solver time per step.

use super::suite::{Suite, FRICTION_BUDGET, FRICTION_MODELS};
use super::tables::{fmt_sci, fmt_time, Data, Table};
use crate::harness::{Case, RunRecord, RunStatus};
use anyhow::Result;
use lcpbench_contact::FrictionModel;
use std::fmt::Write as _;
use std::path::Path;

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
    if r.status == RunStatus::Unsupported && r.steps.unwrap_or(0) == 0 {
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

/// Write the section and its two tables (`friction_models`, `friction_models_time`).
pub(super) fn friction_section(
    md: &mut String,
    data: &Data,
    suite: &Suite,
    tables_dir: &Path,
) -> Result<()> {
    let scenes = scenes(suite);
    let run = |cases: &[&Case], model: FrictionModel, solver: &str| {
        cases
            .iter()
            .find(|c| model_of(c) == Some(model))
            .and_then(|c| data.get(c, solver, FRICTION_BUDGET))
    };
    let mut header = vec!["model".to_owned(), "solver".to_owned()];
    let mut time_header = header.clone();
    for (name, cases) in &scenes {
        let rows: Vec<&RunRecord> = FRICTION_MODELS
            .iter()
            .flat_map(|(m, solvers)| solvers.iter().filter_map(|s| run(cases, *m, s)))
            .filter(|r| r.steps.unwrap_or(0) > 0)
            .collect();
        header.push(format!("{name}: {}", measure_name(&rows)));
        time_header.push(name.clone());
    }
    header.push("converged steps".into());
    let mut table = Table::new("friction_models", &[]);
    table.header = header;
    let mut times = Table::new("friction_models_time", &[]);
    times.header = time_header;
    for (model, solvers) in FRICTION_MODELS {
        for solver in solvers {
            let mut row = vec![model.name(), (*solver).to_owned()];
            let mut time_row = row.clone();
            let (mut done, mut converged) = (0, 0);
            for (_, cases) in &scenes {
                match run(cases, model, solver) {
                    Some(r) => {
                        row.push(measure(r));
                        time_row.push(fmt_time(r.time_per_step_s));
                        let steps = r.steps.unwrap_or(0);
                        done += steps;
                        converged += steps.saturating_sub(r.nonconverged_steps.unwrap_or(0));
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
    table.write_csv(tables_dir)?;
    times.write_csv(tables_dir)?;
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
        table.markdown()
    );
    let _ = writeln!(
        md,
        "Solver time per step of the same runs:\n\n{}",
        times.markdown()
    );
    Ok(())
}

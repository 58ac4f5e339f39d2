//! Report section: engine scaling, the step time of three solvers engines use against the
//! number of boxes of the pyramids `scaling/pyramid_3d_*.toml` (91 to 14,910 boxes).
//!
//! The runs are those of [`engine_scaling_runs`](crate::report::suite::engine_scaling_runs)
//! (`pgs+warm` at 20 sweeps, `si+warm` at 8, `soft-step` at its defaults) on each case of
//! [`Suite::engine_scaling_cases`](crate::report::suite::Suite::engine_scaling_cases), whose
//! residual schedule measures the shared residual on a sample of the steps
//! ([`ENGINE_SCALING_RESIDUAL`](crate::report::suite::ENGINE_SCALING_RESIDUAL)). Two times per
//! run: **without the residual**, the mean over every step of the step's wall time less its
//! residual phase (`step_time_no_residual_s`: what the step costs a simulation that does not
//! measure it), and **with the residual**, the mean wall time of the measured steps
//! (`measured_step_time_s`). Matrix solvers measure every step inside their solve, so for
//! `pgs+warm` the second is its every step. Each is also given per 1,000 contacts (the run's
//! mean contacts). Rapier's rows of the same pyramids stand beside them, quoted from
//! [`RAPIER_FILE`] with their date. One table (`tables/engine_scaling.csv`) and one log–log
//! figure of time per step against boxes (`plots/engine_scaling.svg`). Empty when the suite has
//! no engine scaling cases.

use crate::harness::{Case, RunRecord};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::peers::{parse_peers, PeerRow, RAPIER_FILE, RAPIER_NAME, RAPIER_TEXT};
use crate::report::plots::{plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::sections::findings::solver_cell;
use crate::report::status;
use crate::report::suite::pyramid_boxes;
use crate::report::table::{fmt_time, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct EngineScaling;

const HEADER: [&str; 9] = [
    "boxes",
    "solver",
    "budget",
    "contacts",
    "time/step without residual",
    "per 1,000 contacts",
    "time/step with residual",
    "per 1,000 contacts (with)",
    "steps",
];

impl Section for EngineScaling {
    fn title(&self) -> &'static str {
        "Engine scaling"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let suite = ctx.suite;
        if suite.engine_scaling_cases.is_empty() {
            return Ok(Vec::new());
        }
        let peers: Vec<PeerRow> = parse_peers(RAPIER_TEXT, RAPIER_FILE)?
            .into_iter()
            .filter(|p| pyramid_boxes(std::path::Path::new(&p.scene)).is_some())
            .filter(|p| {
                suite
                    .engine_scaling_cases
                    .iter()
                    .any(|c| c.short_name() == p.scene)
            })
            .collect();
        let schedule = schedule_text(&suite.engine_scaling_cases);
        let sizes: Vec<String> = suite
            .engine_scaling_cases
            .iter()
            .filter_map(|c| match c {
                Case::Scene { path, .. } => pyramid_boxes(path).map(|b| b.to_string()),
                _ => None,
            })
            .collect();
        let dates: Vec<&str> = {
            let mut d: Vec<&str> = peers.iter().map(|p| p.measured.as_str()).collect();
            d.sort_unstable();
            d.dedup();
            d
        };
        let _ = writeln!(
            md,
            "## Engine scaling\n\nThe step time of `pgs+warm` (20 sweeps per step), `si+warm` \
             (8) and `soft-step` (its defaults: 4 substeps) on the square pyramids of {} boxes \
             (`bench_scenes/scaling/pyramid_3d_*.toml`), tolerance 1e-6, {schedule}. \
             **Without residual**: the mean over every step of the step's wall time less its \
             residual phase (the shared residual, the contact records and the step's figures, \
             which a simulation does not pay). **With residual**: the mean wall time of the steps \
             whose shared residual was measured (one pass over every entry of `A`; `pgs+warm` \
             measures every step inside its solve, so its every step is one); a body-level \
             solver's step past the stepper's limit on the entries of `A` is solved and left \
             unmeasured, a matrix solver's is refused. Per 1,000 contacts: the time over the \
             run's mean contacts per step. Steps: converged of the measured steps (an \
             unmeasured step is neither). \
             Rows named {RAPIER_NAME} are quoted from `{RAPIER_FILE}` ({}): Rapier's whole \
             step on the machine of that date; compare ratios measured in the same minutes, \
             not times from different days.\n",
            sizes.join(", "),
            if dates.is_empty() {
                "no pyramid of this family measured".to_owned()
            } else {
                format!("measured {}", dates.join(", "))
            }
        );
        let mut t = Table::new("engine_scaling", &HEADER);
        let runs = runs(ctx);
        for (boxes, r) in &runs {
            t.rows.push(run_row(*boxes, r));
        }
        for p in &peers {
            let boxes = pyramid_boxes(std::path::Path::new(&p.scene)).unwrap_or(0);
            t.rows.push(vec![
                boxes.to_string(),
                match p.substeps {
                    Some(k) => format!("{RAPIER_NAME} ({k} substeps)"),
                    None => RAPIER_NAME.to_owned(),
                },
                format!("measured {}", p.measured),
                "–".into(),
                p.step_time_s.map_or("–".into(), |v| {
                    format!(
                        "{}{}",
                        if v.bound { "≤ " } else { "" },
                        fmt_time(Some(v.value))
                    )
                }),
                "–".into(),
                "–".into(),
                "–".into(),
                "not measured by lcpbench".into(),
            ]);
        }
        t.rows
            .sort_by_key(|row| row[0].parse::<usize>().unwrap_or(usize::MAX));
        let _ = writeln!(md, "{}", ctx.table(&t)?);
        Ok(figure(ctx, &runs, &peers)?.into_iter().collect())
    }
}

/// The schedule of the family's cases, in words (`the shared residual measured on steps 0, 5
/// and 9 of 10`).
fn schedule_text(cases: &[Case]) -> String {
    let Some(Case::Scene {
        steps: Some(steps),
        residual,
        ..
    }) = cases.first()
    else {
        return "each scene's own steps".into();
    };
    let schedule = residual.unwrap_or_default();
    let measured: Vec<String> = (0..*steps)
        .filter(|&k| schedule.measures(k, *steps))
        .map(|k| k.to_string())
        .collect();
    let list = match measured.split_last() {
        None => "no step".to_owned(),
        Some((last, [])) => format!("step {last}"),
        Some((last, rest)) => format!("steps {} and {last}", rest.join(", ")),
    };
    format!("{steps} steps, the shared residual measured on {list} (`residual = {schedule}`)")
}

/// Each run of the family with its pyramid's box count, by boxes then solver.
fn runs<'a>(ctx: &ReportContext<'a>) -> Vec<(usize, &'a RunRecord)> {
    let suite = ctx.suite;
    let mut out = Vec::new();
    for case in &suite.engine_scaling_cases {
        let Case::Scene { path, .. } = case else {
            continue;
        };
        let Some(boxes) = pyramid_boxes(path) else {
            continue;
        };
        for (solver, budget) in &suite.engine_scaling_runs {
            if let Some(r) = ctx.get(case, solver, &budget.name) {
                out.push((boxes, r));
            }
        }
    }
    out
}

/// A time over the run's mean contacts, per 1,000 contacts.
fn per_thousand(time: Option<f64>, contacts: Option<f64>) -> Option<f64> {
    match (time, contacts) {
        (Some(t), Some(c)) if c > 0.0 => Some(t * 1e3 / c),
        _ => None,
    }
}

/// The time a run spent on its measured steps, or why there is none.
fn with_residual(r: &RunRecord) -> Result<f64, &'static str> {
    match (r.measured_step_time_s, r.steps_measured) {
        (Some(t), _) => Ok(t),
        (None, Some(0)) => Err("no step measured"),
        _ => Err("–"),
    }
}

/// The table's row of one run: no times for a run that did not solve its steps (refused by
/// the solver or the stepper's limits, or lost with its worker process).
fn run_row(boxes: usize, r: &RunRecord) -> Vec<String> {
    let solved = !(r.is_isolation_failure() || status::unsupported(r));
    let without = r.step_time_no_residual_s.filter(|_| solved);
    let with = with_residual(r).ok().filter(|_| solved);
    let with_cell = match with_residual(r) {
        _ if !solved => "–".to_owned(),
        Ok(_) => fmt_time(with),
        Err(why) => why.to_owned(),
    };
    vec![
        boxes.to_string(),
        solver_cell(&r.solver),
        r.budget.to_string(),
        r.contacts_mean.map_or("–".into(), |c| format!("{c:.0}")),
        fmt_time(without),
        fmt_time(per_thousand(without, r.contacts_mean)),
        with_cell,
        fmt_time(per_thousand(with, r.contacts_mean)),
        steps_cell(r),
    ]
}

/// Converged of the measured steps, the steps taken, and what else happened.
fn steps_cell(r: &RunRecord) -> String {
    if r.is_isolation_failure() {
        return r.status.to_string();
    }
    if status::unsupported(r) {
        let why = if r.reason.is_empty() {
            String::new()
        } else {
            format!(": {}", r.reason.chars().take(120).collect::<String>())
        };
        return format!("refused{why}");
    }
    let steps = r.steps.unwrap_or(0);
    let measured = r.measured_steps().unwrap_or(steps);
    let mut text = format!(
        "{} of {measured} measured converged ({steps} taken)",
        r.converged_steps().unwrap_or(0)
    );
    if let Some(k) = r.fallback_steps.filter(|&k| k > 0) {
        let _ = write!(text, ", {k} gave up");
    }
    if status::blew_up(r) {
        text.push_str(", blow-up");
    }
    if status::cut_short(r) {
        let _ = write!(
            text,
            ", cut short at {steps} of {}",
            r.steps_planned.unwrap_or(steps)
        );
    }
    text
}

/// Time per step against boxes, log–log: each solver without the residual (line) and with it
/// (its measured steps, markers), Rapier's quoted points; `None` without any point.
fn figure(
    ctx: &ReportContext,
    runs: &[(usize, &RunRecord)],
    peers: &[PeerRow],
) -> Result<Option<Figure>> {
    let mut series = Vec::new();
    for (solver, _) in &ctx.suite.engine_scaling_runs {
        let name = solver.to_string();
        let mine: Vec<(usize, &RunRecord)> = runs
            .iter()
            .filter(|(_, r)| r.solver == *solver && !status::unsupported(r))
            .map(|(b, r)| (*b, *r))
            .collect();
        let without: Vec<(f64, f64)> = mine
            .iter()
            .filter_map(|(b, r)| Some((*b as f64, r.step_time_no_residual_s?)))
            .collect();
        let with: Vec<(f64, f64)> = mine
            .iter()
            .filter_map(|(b, r)| Some((*b as f64, r.measured_step_time_s?)))
            .collect();
        if !without.is_empty() {
            series.push(Series {
                name: format!("{name}, without residual"),
                color_key: name.clone(),
                points: without,
                mark: Mark::LinePoints,
            });
        }
        if !with.is_empty() {
            series.push(Series {
                name: format!("{name}, with residual (measured steps)"),
                color_key: name.clone(),
                points: with,
                mark: Mark::Points,
            });
        }
    }
    let quoted: Vec<(f64, f64)> = peers
        .iter()
        .filter_map(|p| {
            let boxes = pyramid_boxes(std::path::Path::new(&p.scene))?;
            Some((boxes as f64, p.step_time_s?.value))
        })
        .collect();
    if !quoted.is_empty() {
        series.push(Series {
            name: format!("{RAPIER_NAME} (quoted, see table)"),
            color_key: RAPIER_NAME.to_owned(),
            points: quoted,
            mark: Mark::Points,
        });
    }
    if series.is_empty() {
        return Ok(None);
    }
    let path = ctx.plots_dir.join("engine_scaling.svg");
    plot(
        &path,
        &PlotSpec {
            title: "Pyramids: time per step against boxes".into(),
            x_label: "boxes".into(),
            y_label: "wall time per step (s)".into(),
            log_x: true,
            log_y: true,
            y_range: None,
            legend: LegendAt::LowerRight,
        },
        &series,
    )?;
    Ok(Some(Figure::new(
        "Engine scaling: time per step against the pyramid's boxes, without the residual phase \
         (lines) and on the steps whose residual was measured (markers), log–log",
        path,
    )))
}

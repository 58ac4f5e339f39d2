//! Report section: the engine (substepping) solvers at equal cost.
//!
//! The scenes of [`ENGINE_SCENES`](crate::report::suite::ENGINE_SCENES) (after Solver2D's set,
//! Catto's comparison of the solvers shipping engines use; each as the suite's own case of it)
//! with every substepping solver at its
//! defaults and two more costs, and the Gauss–Seidel baselines `pgs+warm` and `si+warm` at
//! iteration caps of about the same work ([`engine_runs`](crate::report::suite::engine_runs)).
//! Work is counted as Catto counts it: constraint-row updates and body passes per step (the
//! `row_updates_per_step` and `body_passes_per_step` columns). One table per scene
//! (`tables/engine_<scene>.csv`), its runs sorted by row updates per step so runs of equal cost
//! stand together, with the step time without the residual phase, the scene's errors (sag,
//! lateral drift, penetration, energy change, joint drift, creep), the worst and median
//! residual of the LCP named in the `LCP` column, and the steps' statuses. Rows of a peer
//! engine (Rapier, [`crate::report::peers`]) stand below lcpbench's on the scenes it was
//! measured on, with their date. One figure per scene that has a sag or a joint drift among
//! the first two: time per step against that error, log axes. Empty when the suite has no
//! engine scenes.

use crate::harness::{Case, RunRecord};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::peers::{
    parse_peers, peer_source, PeerRow, PeerValue, RAPIER_FILE, RAPIER_NAME, RAPIER_TEXT,
};
use crate::report::plots::{plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::status;
use crate::report::table::{fmt_sci, fmt_time, slug, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct EngineSolvers;

/// Scenes whose figure the section draws, and the error it plots: (file stem, error).
const FIGURES: [(&str, Error); 2] = [
    ("tower_40_60hz", Error::Sag),
    ("chain_20_1e3", Error::JointDrift),
];

/// An error a figure plots against the time per step.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Error {
    /// The sag body's largest drop, else the top body's sag.
    Sag,
    /// The largest joint error.
    JointDrift,
}

impl Error {
    fn of(self, r: &RunRecord) -> Option<f64> {
        match self {
            Error::Sag => sag(r),
            Error::JointDrift => r.joint_drift_max,
        }
    }

    fn of_peer(self, p: &PeerRow) -> Option<PeerValue> {
        match self {
            Error::Sag => p.sag_m,
            Error::JointDrift => p.joint_drift_m,
        }
    }

    fn label(self) -> &'static str {
        match self {
            Error::Sag => "sag (m)",
            Error::JointDrift => "largest joint drift (m)",
        }
    }
}

/// The scene's sag: the drop of its `sag_body` when it names one, else the top body's sag.
fn sag(r: &RunRecord) -> Option<f64> {
    r.sag_body.or(r.sag)
}

impl Section for EngineSolvers {
    fn title(&self) -> &'static str {
        "Engine solvers"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let suite = ctx.suite;
        if suite.engine_cases.is_empty() {
            return Ok(Vec::new());
        }
        let peers = parse_peers(RAPIER_TEXT, RAPIER_FILE)?;
        let (runs, worker_s) = sweep_cost(ctx);
        let _ = writeln!(
            md,
            "## Engine solvers\n\nThe substepping solvers engines ship (each `lcpbench \
             solvers` entry whose kind substeps) on the scenes of Catto's Solver2D comparison \
             (`bench_scenes/README.md` maps them), each scene as the suite's own case of it (the \
             tower and the joint scenes their whole runs, the others the steps of the scene \
             runs, listed under [Scenes](#scenes)), so the engine runs join cases every scene \
             solver ran; each solver at its defaults and at two more costs \
             (its `substeps`, or `iterations`, set to the first two of 4, 8, 20, 2 that differ \
             from the default), warm-started when it iterates, tolerance 1e-6 and a cap of 500 \
             sweeps per step (above the sweeps their parameters ask for here, so the parameters \
             set the work); beside them `pgs+warm` and \
             `si+warm` capped at 8, 16 and 40 sweeps per step, the sweeps of one solve and one \
             relax pass per substep at 4, 8 and 20 substeps. Work is counted as Catto counts it: \
             **row updates per step** (a substepping solver counts each update of a row in any \
             pass of any substep; for the others sweeps × rows) and **body passes per step** \
             (velocity and position integration, Jacobi applies; 1 for the others). Each table \
             lists the runs by increasing row updates, so runs of about equal cost stand \
             together; `× cheapest` is the cost over the scene's cheapest run.\n\n\
             Time: the whole step's wall time less the residual phase (the shared residual \
             and the step's figures, which a simulation does not pay), mean over the steps. \
             Sag: the drop of the scene's `sag_body` (a chain's end mass, the bridge's load), \
             else of the top body below its resting height; drift: the top body's horizontal \
             displacement; penetration: the deepest over the run; energy: the change of total \
             energy over the run relative to its scale; joint drift: the largest joint error; \
             creep: the largest speed in the last tenth of a scene that should rest. Residual: \
             the worst and the median over steps of the shared relative residual of the LCP in \
             the `LCP` column: `step` is the step's LCP; for a substepping solver it is its last \
             solve's (the stepper measures the impulse of that solve on the LCP with the step's \
             `A` and that solve's `b`, the velocity its rows saw plus its bias), so a small \
             value says the last pass solved its problem, not that the step's LCP was solved. \
             A step counts converged only when that residual meets the tolerance; † marks a \
             solver that solves a soft (relaxed) model, not the rigid LCP (`lcpbench solvers` \
             says which). These {runs} runs took {worker_s:.0} s of worker time in this sweep \
             (the substepping solvers present: {}).\n\n\
             **Peers.** Rows named {RAPIER_NAME} are quoted from `{RAPIER_FILE}`: {} Their \
             time is Rapier's whole step on the machine and date given; compare ratios measured \
             in the same minutes, not times from different days.\n",
            substepping_names(),
            sentence(&peer_source(RAPIER_TEXT))
        );
        let mut figures = Vec::new();
        for case in &suite.engine_cases {
            let name = case.short_name();
            let scene_peers: Vec<&PeerRow> = peers.iter().filter(|p| p.scene == name).collect();
            let t = scene_table(ctx, case, &name, &scene_peers);
            if t.rows.is_empty() {
                continue;
            }
            let _ = writeln!(md, "### {name}\n\n{}", ctx.table(&t)?);
            if let Some((_, error)) = FIGURES.iter().find(|(n, _)| *n == name) {
                if let Some(f) = figure(ctx, case, &name, *error, &scene_peers)? {
                    figures.push(f);
                }
            }
        }
        Ok(figures)
    }
}

/// `text` ending with a full stop.
fn sentence(text: &str) -> String {
    let t = text.trim_end();
    if t.ends_with('.') {
        t.to_owned()
    } else {
        format!("{t}.")
    }
}

/// The names of the substepping solvers of this lcpbench.
fn substepping_names() -> String {
    let names: Vec<&str> = lcpbench_contact::body_solvers::BodySolverKind::all()
        .into_iter()
        .filter(|k| k.substeps())
        .map(|k| k.name())
        .collect();
    if names.is_empty() {
        "none in this build".to_owned()
    } else {
        names.join(", ")
    }
}

/// The engine runs the sweep has and their summed wall time (each child's, seconds).
fn sweep_cost(ctx: &ReportContext) -> (usize, f64) {
    let mut runs = 0;
    let mut seconds = 0.0;
    for case in &ctx.suite.engine_cases {
        for (solver, budget) in &ctx.suite.engine_runs {
            if let Some(r) = ctx.get_any_machine(case, solver, &budget.name) {
                runs += 1;
                seconds += r.wall_time_s;
            }
        }
    }
    (runs, seconds)
}

/// The runs of `case`, by increasing row updates per step (runs without the count last).
fn runs_by_cost<'a>(ctx: &ReportContext<'a>, case: &Case) -> Vec<&'a RunRecord> {
    let mut runs: Vec<&RunRecord> = ctx
        .suite
        .engine_runs
        .iter()
        .filter_map(|(s, b)| ctx.get(case, s, &b.name))
        .collect();
    runs.sort_by(|a, b| {
        let key = |r: &RunRecord| r.row_updates_per_step.unwrap_or(f64::INFINITY);
        key(a)
            .total_cmp(&key(b))
            .then_with(|| {
                let t = |r: &RunRecord| r.step_time_no_residual_s.unwrap_or(f64::INFINITY);
                t(a).total_cmp(&t(b))
            })
            .then_with(|| a.solver.to_string().cmp(&b.solver.to_string()))
    });
    runs
}

const HEADER: [&str; 18] = [
    "solver",
    "budget",
    "substeps",
    "row updates/step",
    "× cheapest",
    "body passes/step",
    "time/step",
    "sag (m)",
    "drift (m)",
    "penetration (m)",
    "energy",
    "joint drift (m)",
    "creep (m/s)",
    "residual worst",
    "residual median",
    "LCP",
    "steps",
    "source",
];

/// The scene's table: lcpbench's runs by cost, then the peers' rows.
fn scene_table(ctx: &ReportContext, case: &Case, name: &str, peers: &[&PeerRow]) -> Table {
    let mut t = Table::new(format!("engine_{}", slug(name)), &HEADER);
    let runs = runs_by_cost(ctx, case);
    let cheapest = runs
        .iter()
        .filter_map(|r| r.row_updates_per_step)
        .find(|&u| u > 0.0);
    for r in &runs {
        let ratio = match (r.row_updates_per_step, cheapest) {
            (Some(u), Some(c)) => format!("{:.1}×", u / c),
            _ => "–".into(),
        };
        t.rows.push(vec![
            crate::report::sections::findings::solver_cell(&r.solver),
            r.budget.to_string(),
            fmt_mean(r.substeps_per_step),
            fmt_count(r.row_updates_per_step),
            ratio,
            fmt_mean(r.body_passes_per_step),
            fmt_time(r.step_time_no_residual_s),
            fmt_sci(sag(r)),
            fmt_sci(r.lateral_drift),
            fmt_sci(r.penetration_max),
            fmt_sci(r.energy_drift),
            fmt_sci(r.joint_drift_max),
            fmt_sci(r.creep_speed),
            fmt_sci(r.residual_rel),
            fmt_sci(r.residual_rel_median),
            if r.residual_of.is_empty() {
                "step".to_owned()
            } else {
                r.residual_of.clone()
            },
            steps_cell(r),
            format!("lcpbench, {}", r.host.as_deref().unwrap_or("this sweep")),
        ]);
    }
    for p in peers {
        let displacement = p
            .max_displacement_m
            .map(|v| format!("; largest displacement {}", fmt_peer(Some(v))))
            .unwrap_or_default();
        t.rows.push(vec![
            RAPIER_NAME.to_owned(),
            p.iterations
                .map_or("–".into(), |i| format!("{i} it./substep")),
            p.substeps.map_or("–".into(), |s| s.to_string()),
            "–".into(),
            "–".into(),
            "–".into(),
            match p.step_time_s {
                Some(PeerValue { value, bound }) => {
                    format!("{}{}", if bound { "≤ " } else { "" }, fmt_time(Some(value)))
                }
                None => "–".into(),
            },
            fmt_peer(p.sag_m),
            fmt_peer(p.drift_m),
            "–".into(),
            "–".into(),
            fmt_peer(p.joint_drift_m),
            "–".into(),
            "–".into(),
            "–".into(),
            "–".into(),
            format!("not measured by lcpbench{displacement}"),
            format!("{RAPIER_NAME}, measured {} (`{}`)", p.measured, p.command),
        ]);
    }
    t
}

/// Steps converged of those taken, and what else happened.
fn steps_cell(r: &RunRecord) -> String {
    if status::unsupported(r) && r.steps.unwrap_or(0) == 0 {
        return "unsupported".into();
    }
    let (Some(steps), Some(short)) = (r.steps, r.nonconverged_steps) else {
        return r.status.to_string();
    };
    let measured = r.measured_steps().unwrap_or(steps);
    let mut parts = vec![if measured < steps {
        format!(
            "{} of {measured} measured steps converged ({steps} taken)",
            measured.saturating_sub(short)
        )
    } else {
        format!("{}/{steps} converged", steps.saturating_sub(short))
    }];
    if let Some(k) = r.time_limit_steps.filter(|&k| k > 0) {
        parts.push(format!("{k} time limit"));
    }
    if let Some(k) = r.fallback_steps.filter(|&k| k > 0) {
        parts.push(format!("{k} gave up"));
    }
    if status::blew_up(r) {
        parts.push("blow-up".into());
    }
    if status::cut_short(r) {
        parts.push(format!(
            "cut short at {steps} of {}",
            r.steps_planned.unwrap_or(steps)
        ));
    }
    if r.is_isolation_failure() {
        parts.push(r.status.to_string());
    }
    parts.join(", ")
}

/// A mean count with one decimal, or a whole number when it is one.
fn fmt_mean(v: Option<f64>) -> String {
    match v {
        None => "–".into(),
        Some(v) if v.fract() == 0.0 => format!("{v:.0}"),
        Some(v) => format!("{v:.1}"),
    }
}

/// A count per step: whole numbers below ten thousand, then `k` and `M`.
fn fmt_count(v: Option<f64>) -> String {
    match v {
        None => "–".into(),
        Some(v) if v >= 1e6 => format!("{:.2} M", v / 1e6),
        Some(v) if v >= 1e4 => format!("{:.1} k", v / 1e3),
        Some(v) => format!("{v:.0}"),
    }
}

/// A peer's value, `≤ x` for a bound.
fn fmt_peer(v: Option<PeerValue>) -> String {
    match v {
        None => "–".into(),
        Some(PeerValue { value, bound }) => {
            format!("{}{}", if bound { "≤ " } else { "" }, fmt_sci(Some(value)))
        }
    }
}

/// Time per step against `error`, one series per solver (its costs joined by a line), the
/// peer's points as their own series; `None` when no run has both figures.
fn figure(
    ctx: &ReportContext,
    case: &Case,
    name: &str,
    error: Error,
    peers: &[&PeerRow],
) -> Result<Option<Figure>> {
    let runs = runs_by_cost(ctx, case);
    // One series per solver kind (warm and cold apart), its runs in order of cost.
    let mut keys: Vec<String> = Vec::new();
    for r in &runs {
        let key = series_key(r);
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let mut series: Vec<Series> = keys
        .iter()
        .map(|key| Series {
            name: key.clone(),
            color_key: key.clone(),
            points: runs
                .iter()
                .filter(|r| series_key(r) == *key)
                .filter_map(|r| Some((r.step_time_no_residual_s?, error.of(r)?)))
                .collect(),
            mark: Mark::LinePoints,
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    if series.is_empty() {
        return Ok(None);
    }
    let peer_points: Vec<(f64, f64)> = peers
        .iter()
        .filter_map(|p| Some((p.step_time_s?.value, error.of_peer(p)?.value)))
        .collect();
    if !peer_points.is_empty() {
        series.push(Series {
            name: format!("{RAPIER_NAME} (quoted, see table)"),
            color_key: RAPIER_NAME.to_owned(),
            points: peer_points,
            mark: Mark::Points,
        });
    }
    let path = ctx.plots_dir.join(format!("engine_{}.svg", slug(name)));
    plot(
        &path,
        &PlotSpec {
            title: format!("{name}: {} against time per step", error.label()),
            x_label: "step time without the residual phase (s)".into(),
            y_label: error.label().into(),
            log_x: true,
            log_y: true,
            y_range: None,
            legend: LegendAt::UpperRight,
        },
        &series,
    )?;
    Ok(Some(Figure::new(
        format!(
            "Engine solvers on {name}: {} against the step time without the residual phase, \
             each solver's costs joined (points at zero error are not drawn on the log axis; \
             the CSV keeps them)",
            error.label()
        ),
        path,
    )))
}

/// The series a run belongs to: its solver without parameters, with `+warm` when warm.
fn series_key(r: &RunRecord) -> String {
    if r.warm {
        format!("{}+warm", r.solver_base)
    } else {
        r.solver_base.clone()
    }
}

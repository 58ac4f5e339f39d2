//! The report's time-of-impact runs: scenes of `bench_scenes/impact/` stepped by each stepping
//! mode (fixed steps at a given rate, fixed steps with bisection or conservative-advancement
//! backtracking, Timewarp), measured by the discontinuity metrics
//! ([`lcpbench_contact::discontinuity`]). They run one after another in this process, after
//! the sweep, one row each in `data/impact.csv`; a resumed report keeps the rows it has.

use anyhow::{anyhow, Context, Result};
use lcpbench_contact::collision::toi::ToiMethod;
use lcpbench_contact::discontinuity::DiscontinuityMeter;
use lcpbench_contact::scene::Scene;
use lcpbench_contact::timewarp::{Stepper, Stepping};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A stepping mode of the comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImpactMode {
    /// Fixed steps at this many per second, no continuous collision detection.
    Fixed {
        /// Steps per second.
        hz: u32,
    },
    /// Fixed steps of the scene's `dt`, motion cut at the first time of impact (bisection).
    Bisection,
    /// The same with conservative advancement.
    Conservative,
    /// Timewarp, frames of the scene's `dt`.
    Timewarp,
}

impl ImpactMode {
    /// The modes of the comparison, in the report's order.
    pub const ALL: [ImpactMode; 6] = [
        ImpactMode::Fixed { hz: 60 },
        ImpactMode::Fixed { hz: 240 },
        ImpactMode::Fixed { hz: 1000 },
        ImpactMode::Bisection,
        ImpactMode::Conservative,
        ImpactMode::Timewarp,
    ];

    /// `fixed-60hz`, `bisection`, `conservative`, `timewarp`.
    pub fn name(&self) -> String {
        match self {
            ImpactMode::Fixed { hz } => format!("fixed-{hz}hz"),
            ImpactMode::Bisection => "bisection".into(),
            ImpactMode::Conservative => "conservative".into(),
            ImpactMode::Timewarp => "timewarp".into(),
        }
    }
}

/// One run: a scene under a mode.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactCase {
    /// The scene file.
    pub scene: PathBuf,
    /// The stepping mode.
    pub mode: ImpactMode,
}

/// The row of one run (`data/impact.csv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImpactRow {
    /// Scene name.
    pub scene: String,
    /// Mode ([`ImpactMode::name`]).
    pub mode: String,
    /// Bodies of the scene.
    pub bodies: usize,
    /// Steps (frames for Timewarp).
    pub steps: usize,
    /// Step, s.
    pub dt: f64,
    /// Analytic impacts in the run.
    pub analytic_impacts: usize,
    /// Impacts found on the spheres with analytic impacts.
    pub detected_impacts: usize,
    /// Analytic impacts with no counterpart.
    pub missed_impacts: usize,
    /// Largest impact-time error, s.
    pub impact_time_error_max: Option<f64>,
    /// Mean impact-time error, s.
    pub impact_time_error_mean: Option<f64>,
    /// Largest relative energy error after an impact.
    pub energy_error_max: Option<f64>,
    /// Impacts Timewarp resolved in free flight.
    pub recorded_impacts: Option<usize>,
    /// Deepest penetration, m.
    pub max_penetration: f64,
    /// Steps in which a body passed through another.
    pub tunnelling: usize,
    /// Narrow-phase pair queries.
    pub collision_queries: u64,
    /// Time-of-impact pair searches.
    pub toi_queries: u64,
    /// Body-steps undone by rollbacks.
    pub rolled_back_steps: u64,
    /// Wall time of the steps, s.
    pub wall_time_s: f64,
    /// Queries per impact.
    pub queries_per_impact: Option<f64>,
    /// Wall time per impact, s.
    pub wall_time_per_impact_s: Option<f64>,
    /// Steps whose contact solve did not converge.
    pub nonconverged_steps: usize,
    /// Why the run did not happen, if it did not.
    pub error: Option<String>,
}

/// Step `case` and measure it.
pub fn run_case(case: &ImpactCase) -> Result<ImpactRow> {
    let scene = Scene::load(&case.scene)?;
    let mut world = scene.world();
    let duration = scene.settings.dt * scene.settings.steps as f64;
    let (stepping, ccd, dt) = match case.mode {
        ImpactMode::Fixed { hz } => (Stepping::Fixed, None, 1.0 / f64::from(hz)),
        ImpactMode::Bisection => (
            Stepping::Fixed,
            Some(ToiMethod::Bisection),
            scene.settings.dt,
        ),
        ImpactMode::Conservative => (
            Stepping::Fixed,
            Some(ToiMethod::ConservativeAdvancement),
            scene.settings.dt,
        ),
        ImpactMode::Timewarp => (Stepping::Timewarp, None, scene.settings.dt),
    };
    world.settings.dt = dt;
    world.settings.ccd = ccd;
    let steps = (duration / dt).round().max(1.0) as usize;
    let mut row = ImpactRow {
        scene: scene.name.clone(),
        mode: case.mode.name(),
        bodies: scene.bodies.len(),
        steps,
        dt,
        analytic_impacts: 0,
        detected_impacts: 0,
        missed_impacts: 0,
        impact_time_error_max: None,
        impact_time_error_mean: None,
        energy_error_max: None,
        recorded_impacts: None,
        max_penetration: 0.0,
        tunnelling: 0,
        collision_queries: 0,
        toi_queries: 0,
        rolled_back_steps: 0,
        wall_time_s: 0.0,
        queries_per_impact: None,
        wall_time_per_impact_s: None,
        nonconverged_steps: 0,
        error: None,
    };
    let mut stepper = match Stepper::new(world, stepping) {
        Ok(s) => s,
        Err(e) => {
            row.error = Some(e);
            return Ok(row);
        }
    };
    let analytic = scene.metrics.analytic_impacts == Some(true);
    let mut meter = DiscontinuityMeter::new(&stepper, analytic, duration);
    for _ in 0..steps {
        meter.before_step(&stepper);
        let report = stepper.step();
        if !report.status.is_converged() && report.rows > 0 {
            row.nonconverged_steps += 1;
        }
        meter.after_step(&stepper, &report);
    }
    let m = meter.finish(&stepper);
    row.analytic_impacts = m.analytic_impacts;
    row.detected_impacts = m.detected_impacts;
    row.missed_impacts = m.missed_impacts;
    row.impact_time_error_max = m.impact_time_error_max;
    row.impact_time_error_mean = m.impact_time_error_mean;
    row.energy_error_max = m.energy_error_max;
    row.recorded_impacts = m.recorded_impacts;
    row.max_penetration = m.max_penetration;
    row.tunnelling = m.tunnelling;
    row.collision_queries = m.collision_queries;
    row.toi_queries = m.toi_queries;
    row.rolled_back_steps = m.rolled_back_steps;
    row.wall_time_s = m.wall_time_s;
    row.queries_per_impact = m.queries_per_impact;
    row.wall_time_per_impact_s = m.wall_time_per_impact_s;
    Ok(row)
}

/// Run `cases` in order into the CSV at `path`; with `resume`, the runs whose (scene, mode)
/// the file already has are kept and not run again. Returns every row.
pub fn run_cases(cases: &[ImpactCase], path: &Path, resume: bool) -> Result<Vec<ImpactRow>> {
    let mut rows = if resume && path.exists() {
        read_rows(path)?
    } else {
        Vec::new()
    };
    for case in cases {
        let mode = case.mode.name();
        let stem = case
            .scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if rows.iter().any(|r| r.scene == stem && r.mode == mode) {
            continue;
        }
        let row = run_case(case)
            .with_context(|| format!("time-of-impact run {} under {mode}", case.scene.display()))?;
        rows.push(row);
        write_rows(path, &rows)?;
    }
    Ok(rows)
}

/// Write `rows` to `path` (replacing it).
pub fn write_rows(path: &Path, rows: &[ImpactRow]) -> Result<()> {
    let mut w = csv::Writer::from_path(path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    for r in rows {
        w.serialize(r)?;
    }
    w.flush()?;
    Ok(())
}

/// The rows of `path`.
pub fn read_rows(path: &Path) -> Result<Vec<ImpactRow>> {
    let mut r =
        csv::Reader::from_path(path).with_context(|| format!("cannot read {}", path.display()))?;
    r.deserialize()
        .enumerate()
        .map(|(k, row)| row.map_err(|e| anyhow!("{}: row {}: {e}", path.display(), k + 1)))
        .collect()
}

//! Scene runs: step a scene with the chosen solver and turn the per-step [`StepReport`]s into
//! one row through a [`SceneMetricsAccumulator`] (the metrics, the blow-up test and the
//! analytic checks are documented in [`crate::harness::metrics`]).
//!
//! The budget's tolerance and iteration cap replace the scene's per-step solver settings, and
//! its seconds bound each step's solve: a step whose solve runs out of them ends `time_limit`
//! with the solver's best point (it counts as not converged) and the run goes on. The run as a
//! whole stops stepping after
//! [`Budget::scene_run_limit`](crate::harness::Budget::scene_run_limit) of wall time and is then
//! recorded as `time_limit` with the steps it took (the solve under way then ends at that limit
//! too), and after [`SLOW_STEPS_STOP`] consecutive steps over their per-step budget, which say
//! the solver cannot keep up with the scene at this budget. A plain solver
//! steps cold (no warm start across steps); `NAME+warm` warm-starts from the previous step's
//! impulses, as real-time engines do. A case key `scene:PATH?friction=MODEL` replaces the
//! scene's friction model (`cone` needs a cone solver, `nsgs-cone`, `newton-ac` or
//! `clarabel-socp`); a solver that does not take the model is recorded `unsupported` without
//! stepping. A case key `scene:PATH?residual=sample=K` (or `none`, `every`) replaces the
//! scene's residual schedule: a body-level or substepping solver's steps off the schedule are
//! not measured, never counted converged or not (`steps_measured` says how many were).
//!
//! [`StepReport`]: lcpbench_contact::step::StepReport

use crate::harness::case::Case;
use crate::harness::metrics::{SceneMetricsAccumulator, TimeStop};
use crate::harness::record::{base_record, RunOutput, RunRecord, RunStatus, WarmSource};
use crate::harness::{NamedBudget, SolverSpec};
use lcpbench_contact::scene::{check_solver, Scene};
use lcpbench_contact::step::World;
use lcpbench_solvers::Status;
use std::time::{Duration, Instant};

/// Run a scene case in this process.
pub fn run_scene(case: &Case, spec: &SolverSpec, budget: &NamedBudget) -> RunOutput {
    let mut record = base_record(case, spec, budget);
    let Case::Scene {
        path,
        steps,
        friction,
        residual,
    } = case
    else {
        return RunOutput::failed(record, RunStatus::Error, "not a scene case");
    };
    let mut scene = match Scene::load(path) {
        Ok(s) => s,
        Err(e) => return RunOutput::failed(record, RunStatus::Error, e.to_string()),
    };
    if let Some(model) = friction {
        scene.settings.builder.friction_model = *model;
    }
    let Some(choice) = spec.contact_solver(&scene) else {
        return RunOutput::failed(record, RunStatus::Error, "no solver");
    };
    if let Err(reason) = check_solver(&choice, scene.settings.builder.friction_model) {
        return RunOutput::failed(record, RunStatus::Unsupported, reason);
    }
    let b = &budget.budget;
    scene.settings.solver = choice;
    scene.settings.tolerance = b.tolerance;
    scene.settings.max_iterations = b.max_iterations;
    scene.settings.warm_start = spec.warm();
    if spec.warm() {
        record.warm_source = WarmSource::PreviousStep.name().to_owned();
    }
    let n_steps = steps.map_or(scene.settings.steps, |s| s.min(scene.settings.steps));
    if let Some(schedule) = residual {
        scene.settings.residual = *schedule;
    }
    // The run's length: a residual schedule's `sample=K` measures its last step too.
    scene.settings.steps = n_steps;
    let mut world = scene.world();
    world.settings.step_time_budget = crate::harness::budget::time_budget(b.time_s).ok();
    measure(
        &scene,
        &mut world,
        n_steps,
        b.scene_run_limit(n_steps),
        &mut record,
    );
    RunOutput::row(record)
}

/// Consecutive steps whose solves run out of their per-step budget after which a scene run
/// stops: the solver cannot keep up with the scene at this budget, and further steps would
/// measure the budget, not the solver.
pub const SLOW_STEPS_STOP: usize = 3;

/// Step `world` up to `n_steps` times (or until `time_limit` seconds, [`SLOW_STEPS_STOP`]
/// consecutive steps over their budget, or a blow-up) and fill the row.
fn measure(scene: &Scene, world: &mut World, n_steps: usize, time_limit: f64, r: &mut RunRecord) {
    let mut metrics = SceneMetricsAccumulator::new(world, scene.metrics.clone(), n_steps);
    let start = Instant::now();
    world.settings.deadline = Some(start + Duration::from_secs_f64(time_limit));
    let mut last = None;
    let mut stop = TimeStop::No;
    let per_step = world
        .settings
        .step_time_budget
        .map_or(0.0, |d| d.as_secs_f64());
    let mut rules = StopRules::new(time_limit, per_step);
    for k in 0..n_steps {
        if let Some(s) = rules.before_step(start.elapsed().as_secs_f64()) {
            stop = s;
            break;
        }
        let report = world.step();
        let slow_stop = rules.after_step(&report.status, k + 1 < n_steps);
        let go_on = metrics.observe(&report, world);
        last = Some(report);
        if !go_on {
            break;
        }
        if let Some(s) = slow_stop {
            stop = s;
            break;
        }
    }
    metrics.finish(world, last.as_ref(), stop, r);
}

/// The two rules that stop a scene run early, fed the run's clock and each step's status (so
/// they are tested with a made-up clock, not the machine's): the run's wall time past
/// `time_limit` before a step, or [`SLOW_STEPS_STOP`] consecutive steps ending `time_limit`
/// with steps still to go.
struct StopRules {
    time_limit: f64,
    per_step: f64,
    slow: usize,
}

impl StopRules {
    fn new(time_limit: f64, per_step: f64) -> Self {
        Self {
            time_limit,
            per_step,
            slow: 0,
        }
    }

    /// Before a step, `elapsed` seconds into the run.
    fn before_step(&self, elapsed: f64) -> Option<TimeStop> {
        (elapsed > self.time_limit).then_some(TimeStop::RunLimit(self.time_limit))
    }

    /// After a step that ended with `status`; `more` when steps remain.
    fn after_step(&mut self, status: &Status, more: bool) -> Option<TimeStop> {
        self.slow = if *status == Status::TimeLimit {
            self.slow + 1
        } else {
            0
        };
        (self.slow >= SLOW_STEPS_STOP && more)
            .then_some(TimeStop::SlowSteps(self.slow, self.per_step))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The run limit, on a made-up clock: a run stops before the first step that starts past
    /// the limit, never mid-step.
    #[test]
    fn the_run_limit_stops_before_the_first_step_past_it() {
        let rules = StopRules::new(0.6, 0.05);
        let clock = [0.0, 0.2, 0.45, 0.6, 0.61, 5.0];
        let stops: Vec<bool> = clock
            .iter()
            .map(|&t| rules.before_step(t).is_some())
            .collect();
        assert_eq!(stops, [false, false, false, false, true, true]);
        assert_eq!(rules.before_step(0.61), Some(TimeStop::RunLimit(0.6)));
    }

    /// Three consecutive steps over their budget stop the run when steps remain; a step within
    /// it resets the count, and the last step never stops the run (it has taken every step).
    #[test]
    fn three_consecutive_slow_steps_stop_the_run() {
        let mut rules = StopRules::new(100.0, 0.05);
        let over = Status::TimeLimit;
        let ok = Status::Converged;
        assert_eq!(rules.after_step(&over, true), None);
        assert_eq!(rules.after_step(&over, true), None);
        assert_eq!(rules.after_step(&ok, true), None);
        assert_eq!(rules.after_step(&over, true), None);
        assert_eq!(rules.after_step(&over, true), None);
        assert_eq!(
            rules.after_step(&over, true),
            Some(TimeStop::SlowSteps(3, 0.05))
        );
        let mut last = StopRules::new(100.0, 0.05);
        for more in [true, true, false] {
            assert_eq!(last.after_step(&over, more), None);
        }
    }
}

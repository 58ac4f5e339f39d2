//! The simulation settings of a world: time step, gravity, the contact solver and its limits,
//! the builder's parameters, continuous collision detection, what each step keeps and measures.

use super::ContactSolver;
use crate::builder::BuilderParams;
use crate::collision::toi::ToiMethod;
use lcpbench_solvers::SolverKind;
use nalgebra::Vector3;
use std::time::{Duration, Instant};

/// Simulation settings. Scene-file defaults in brackets (see `docs/scenes.md`).
#[derive(Debug, Clone)]
pub struct SimSettings {
    /// Time step `h`, s \[`0.01`\].
    pub dt: f64,
    /// Number of steps a run takes \[`100`\].
    pub steps: usize,
    /// Gravity, m/s² \[`[0, 0, -9.81]`\].
    pub gravity: Vector3<f64>,
    /// Contact solver, the instance every step solves with (a clone per island)
    /// \[`pgs`\].
    pub solver: ContactSolver,
    /// Solver tolerance on the relative natural-map residual \[`1e-6`\] (for body-level
    /// solvers also their own stopping scale).
    pub tolerance: f64,
    /// Solver iteration / pivot / sweep cap of a step's solve \[`1000`\]. Islands solved
    /// apart ([`SimSettings::islands`]) run in parallel and each gets the whole cap; a solver
    /// that splits one problem itself shares it
    /// ([`Settings::max_iterations`](lcpbench_solvers::Settings::max_iterations)).
    pub max_iterations: usize,
    /// Warm-start iterative solvers from the previous step's impulses \[`true`\].
    pub warm_start: bool,
    /// Contacts closer than this are in the problem, m \[`0.01`\].
    pub prediction_distance: f64,
    /// Keep a body pair's contact manifolds from step to step while the pair's relative pose
    /// moves less than a small threshold, updating the kept points' gaps instead of running
    /// the narrow phase on it again
    /// ([`NarrowPhase::persistent_manifolds`](crate::collision::narrow_phase::NarrowPhase::persistent_manifolds)).
    /// The contact points then differ slightly from those of a fresh detection \[`false`\].
    pub persistent_manifolds: bool,
    /// Friction model, restitution threshold and position correction.
    pub builder: BuilderParams,
    /// Continuous collision detection: `None` \[default\], or a time-of-impact method. With
    /// one, every step moves the bodies only up to the first time of impact among pairs not yet
    /// touching (backtracking, Baraff–Witkin), so fast bodies cannot tunnel; the rest of that
    /// step's motion is dropped and the new contact enters the next step's problem.
    pub ccd: Option<ToiMethod>,
    /// Keep each step's [`Problem`](lcpbench_solvers::Problem) in its report (for export)
    /// \[`false`\].
    pub keep_problem: bool,
    /// Which steps have their shared residual measured \[`every`\]: for a body-level or
    /// substepping solver, on the step's LCP with `A` held as its factors
    /// ([`DelassusForm::Factored`](crate::builder::DelassusForm::Factored): one pass over the
    /// entries of `A`, formed row by row and not stored); for a matrix or cone solver, the
    /// solver's final measurement of its returned impulse
    /// ([`Settings::measure_result`](lcpbench_solvers::Settings::measure_result)), which it
    /// skips off the schedule (it still measures what its own stopping rule needs).
    pub residual: ResidualSchedule,
    /// Ask matrix solvers for their convergence history (residual per iteration or pivot) and
    /// keep it in each [`StepReport`](super::StepReport) \[`false`\]. The measuring time is
    /// excluded from the solver's reported time but not from the step's.
    pub record_history: bool,
    /// Solve each island (contacts sharing no dynamic body) on its own, in parallel when there
    /// are several \[`true`\]. Off: one problem for the whole step.
    pub islands: bool,
    /// Wall-time budget of each step's solve: the solves of one step (every island, in
    /// parallel or not) end by the time this has passed since the solve phase began, each
    /// ending `time_limit` with the best point it has when it runs out, and the next step
    /// starts as usual \[none\].
    pub step_time_budget: Option<Duration>,
    /// Wall-clock deadline of the solves of every step: a solve ends `time_limit` at the
    /// deadline (or at the end of its [`SimSettings::step_time_budget`], if earlier), so a run
    /// cannot be held past it by one long step \[none\].
    pub deadline: Option<Instant>,
}

/// Which steps have the shared residual measured (for every solver: a body-level or substepping
/// solver does not need it to solve, a matrix or cone solver measures only what its own
/// stopping rule needs off the schedule): scene files write it `residual = "every"`, `"none"` or
/// `"sample=K"`, the command line `--residual every|none|sample=K`.
///
/// A step that is not measured has no residual and its status is never `converged`: the
/// status is what the solver's own loop can say without the shared residual (`iteration_limit`,
/// `stalled` with a reason saying the residual was not measured, `time_limit`, a failure), and
/// [`StepReport::residual_measured`](super::StepReport::residual_measured) is `false`. The
/// definition of the residual is the same on every measured step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ResidualSchedule {
    /// Every step \[default\].
    #[default]
    Every,
    /// Steps `0, K, 2K, …` and the run's last step ([`SimSettings::steps`]` − 1`), `K >= 1`.
    Sample(usize),
    /// No step.
    None,
}

/// Largest `K` of `sample=K`: [`crate::scene::MAX_STEPS`], a run's longest.
pub const MAX_RESIDUAL_SAMPLE: usize = crate::scene::MAX_STEPS;

impl ResidualSchedule {
    /// True when step `step` (0-based) of a run of `steps` steps is measured.
    pub fn measures(self, step: usize, steps: usize) -> bool {
        match self {
            ResidualSchedule::Every => true,
            ResidualSchedule::None => false,
            ResidualSchedule::Sample(k) => step.is_multiple_of(k.max(1)) || step + 1 == steps,
        }
    }

    /// How many of the steps `0 .. steps` are measured.
    pub fn measured_steps(self, steps: usize) -> usize {
        (0..steps).filter(|&k| self.measures(k, steps)).count()
    }
}

impl std::fmt::Display for ResidualSchedule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ResidualSchedule::Every => f.write_str("every"),
            ResidualSchedule::None => f.write_str("none"),
            ResidualSchedule::Sample(k) => write!(f, "sample={k}"),
        }
    }
}

impl std::str::FromStr for ResidualSchedule {
    type Err = String;

    /// `every`, `none` or `sample=K` with `1 <= K <=` [`MAX_RESIDUAL_SAMPLE`] (`sample=1` is
    /// `every`, kept as written).
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim() {
            "every" => Ok(ResidualSchedule::Every),
            "none" => Ok(ResidualSchedule::None),
            t => {
                let k = t.strip_prefix("sample=").ok_or_else(|| {
                    format!("`{t}` is not a residual schedule (every, none or sample=K)")
                })?;
                match k.parse::<usize>() {
                    Ok(k) if (1..=MAX_RESIDUAL_SAMPLE).contains(&k) => {
                        Ok(ResidualSchedule::Sample(k))
                    }
                    _ => Err(format!(
                        "sample=K needs a whole number K from 1 to {MAX_RESIDUAL_SAMPLE}, got `{k}`"
                    )),
                }
            }
        }
    }
}

impl SimSettings {
    /// The unit vector against gravity (`z` without gravity): the "up" that heights, sag and
    /// lateral drift are measured along.
    pub fn up(&self) -> Vector3<f64> {
        let g = self.gravity.norm();
        if g > 0.0 {
            -self.gravity / g
        } else {
            Vector3::z()
        }
    }
}

impl Default for SimSettings {
    fn default() -> Self {
        Self {
            dt: 0.01,
            steps: 100,
            gravity: Vector3::new(0.0, 0.0, -9.81),
            solver: ContactSolver::from(SolverKind::Pgs),
            tolerance: 1e-6,
            max_iterations: 1000,
            warm_start: true,
            prediction_distance: 0.01,
            persistent_manifolds: false,
            builder: BuilderParams::default(),
            ccd: None,
            keep_problem: false,
            residual: ResidualSchedule::Every,
            record_history: false,
            islands: true,
            step_time_budget: None,
            deadline: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::ResidualSchedule;

    /// `sample=K` measures steps 0, K, 2K, … and the last; the text form reads back.
    #[test]
    fn a_sample_measures_the_multiples_and_the_last_step() {
        let s: ResidualSchedule = "sample=4".parse().unwrap();
        let measured: Vec<usize> = (0..10).filter(|&k| s.measures(k, 10)).collect();
        assert_eq!(measured, [0, 4, 8, 9]);
        assert_eq!(s.measured_steps(10), 4);
        assert_eq!(s.measured_steps(9), 3);
        assert_eq!(ResidualSchedule::Every.measured_steps(7), 7);
        assert_eq!(ResidualSchedule::None.measured_steps(7), 0);
        for text in ["every", "none", "sample=4"] {
            assert_eq!(text.parse::<ResidualSchedule>().unwrap().to_string(), text);
        }
        for bad in ["sample=0", "sample=", "sample=-2", "some", "sample=2.5"] {
            assert!(bad.parse::<ResidualSchedule>().is_err(), "{bad}");
        }
    }
}

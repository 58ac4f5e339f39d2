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
    /// Measure the shared residual for body-level solvers too (on the step's LCP with `A` held
    /// as its factors, [`DelassusForm::Factored`](crate::builder::DelassusForm::Factored): one
    /// pass over the entries of `A`, formed row by row and not stored) \[`true`\].
    pub residuals: bool,
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
            residuals: true,
            record_history: false,
            islands: true,
            step_time_budget: None,
            deadline: None,
        }
    }
}

//! Velocity-level time stepping (Stewart–Trinkle 1996, Anitescu–Potra 1997).
//!
//! One step of size `h`, in [`World::step`]:
//!
//! 1. **detect** contacts at the current positions (with a prediction distance, so resting and
//!    approaching contacts are in the problem before they touch);
//! 2. **build** the contact system at the free velocity `u* = u + h M⁻¹ f_ext`
//!    ([`builder::build`]);
//! 3. **solve** it for the impulse `f` with the chosen solver (a matrix solver on
//!    `A = J M⁻¹ Jᵀ`, a body-level solver on the matrix-free operator, or, for the friction
//!    model `cone`, a cone solver on the FC3D problem `W = A`, `q = b`); islands are solved
//!    separately, in parallel;
//! 4. **apply** the impulses to the momenta and **integrate** the positions
//!    ([`integrate`]: symplectic Euler for bodies that received an impulse, RK4 for free
//!    flight), moving by the split-impulse pseudo-velocity too when that correction is chosen;
//! 5. **measure**: a [`StepReport`] with contacts, rows, solver status and residuals,
//!    penetration, energy, momenta and friction-cone violation.
//!
//! ```
//! use lcpbench_contact::{ContactSolver, Scene};
//! use std::path::Path;
//!
//! let scene = Scene::parse(
//!     r#"
//!     [settings]
//!     dt = 0.01
//!     [[bodies]]
//!     name = "ground"
//!     shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
//!     static = true
//!     [[bodies]]
//!     name = "box"
//!     shape = { type = "box", half_extents = [0.5, 0.5, 0.5] }
//!     position = [0.0, 0.0, 0.5]
//!     "#,
//!     Path::new("example.toml"),
//! )
//! .unwrap();
//! let mut world = scene.world();
//! world.set_solver(ContactSolver::from_name("si").unwrap());
//! let report = world.step();
//! assert_eq!(report.contacts, 4); // one face on the ground: four contact points
//! assert!(report.status.is_converged());
//! assert!((world.bodies[1].position.z - 0.5).abs() < 1e-9); // it rests
//! ```

use crate::body::RigidBody;
use crate::body_solvers::{BodySolver, BodySolverKind, Measure};
use crate::builder::FrictionModel;
use crate::builder::PositionCorrection;
use crate::builder::{
    self, BodyVelocity, BuilderParams, ContactSystem, DelassusForm, Material, Partition,
    WarmStartCache,
};
use crate::collision::broad_phase::TooManyPairs;
use crate::collision::toi::{first_impact, ToiMethod, ToiSettings};
use crate::collision::CollisionPipeline;
use crate::integrate;
use lcpbench_solvers::{
    ConeProblem, ConeSolver, ConeSolverKind, HistoryPoint, Problem, ProjectedSor, Residuals,
    Settings, SolveResult, Solver, SolverKind, Status,
};
use nalgebra::Vector3;
use serde::Serialize;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The contact solver of a scene, as an owned, configured instance: a matrix solver of
/// `lcpbench-solvers`, a body-level one, or a solver of the exact Coulomb cone. Every parameter
/// of the instance (SOR's `omega`, Newton's settings, the penalty spring) reaches the steps.
/// Cloning clones the instance (`dyn_clone::DynClone`, which every solver trait requires);
/// islands solved in parallel each get a clone of the instance the world was given.
#[derive(Clone)]
pub enum ContactSolver {
    /// A solver on the assembled LCP (friction models `none`, `box`, `pyramid`).
    Matrix(Box<dyn Solver + Send>),
    /// A solver on bodies (matrix-free; friction models `none`, `box`).
    Body(Box<dyn BodySolver + Send>),
    /// A solver of the FC3D cone problem (friction model `cone` only).
    Cone(Box<dyn ConeSolver + Send>),
}

impl std::fmt::Debug for ContactSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ContactSolver({})", self.name())
    }
}

impl From<SolverKind> for ContactSolver {
    fn from(kind: SolverKind) -> Self {
        ContactSolver::Matrix(kind.create())
    }
}

impl From<BodySolverKind> for ContactSolver {
    fn from(kind: BodySolverKind) -> Self {
        ContactSolver::Body(kind.create())
    }
}

impl From<ConeSolverKind> for ContactSolver {
    fn from(kind: ConeSolverKind) -> Self {
        ContactSolver::Cone(kind.create())
    }
}

impl ContactSolver {
    /// The solver of this name with default parameters: the matrix solvers' names, then `si`,
    /// `body-micro`, `penalty`, then the cone solvers `nsgs-cone`, `newton-ac`, `clarabel-socp`.
    pub fn from_name(name: &str) -> Option<Self> {
        SolverKind::from_name(name)
            .map(Self::from)
            .or_else(|| BodySolverKind::from_name(name).map(Self::from))
            .or_else(|| ConeSolverKind::from_name(name).map(Self::from))
    }

    /// The solver's name.
    pub fn name(&self) -> &'static str {
        match self {
            ContactSolver::Matrix(s) => s.name(),
            ContactSolver::Body(s) => s.name(),
            ContactSolver::Cone(s) => s.name(),
        }
    }

    /// True for a cone solver.
    pub fn is_cone(&self) -> bool {
        matches!(self, ContactSolver::Cone(_))
    }

    /// True when the stepper passes this solver the previous step's impulses: the iterative
    /// matrix solvers ([`SolverKind::is_iterative`]), every cone solver and every body-level
    /// solver. Pivoting and interior-point solvers start cold.
    pub fn takes_warm_start(&self) -> bool {
        match self {
            ContactSolver::Matrix(s) => {
                SolverKind::from_name(s.name()).is_some_and(|k| k.is_iterative())
            }
            ContactSolver::Body(_) | ContactSolver::Cone(_) => true,
        }
    }

    /// `Ok` when this solver takes the problems of `model`; otherwise why not. A step whose
    /// solver does not take the friction model is `Unsupported` with this reason (and applies
    /// no impulse); scene files and the command line refuse the pair up front
    /// ([`crate::scene::check_solver`]).
    pub fn supports(&self, model: FrictionModel) -> Result<(), String> {
        match (self, model) {
            (ContactSolver::Body(s), FrictionModel::Pyramid { .. }) => Err(format!(
                "body-level solver `{}` supports friction_model \"none\" or \"box\", not \"pyramid\"",
                s.name()
            )),
            (ContactSolver::Matrix(_) | ContactSolver::Body(_), FrictionModel::Cone) => Err(format!(
                "solver `{}` solves the LCP models (friction_model \"none\", \"box\", \"pyramid\"), \
                 not the exact Coulomb cone of friction_model \"cone\": use a cone solver ({})",
                self.name(),
                Self::cone_names()
            )),
            (ContactSolver::Cone(s), m) if m != FrictionModel::Cone => Err(format!(
                "cone solver `{}` solves friction_model \"cone\" only, not \"{}\" (use a matrix or \
                 body-level solver, or friction_model \"cone\")",
                s.name(),
                m.name()
            )),
            _ => Ok(()),
        }
    }

    /// Comma-separated names of the cone solvers.
    pub fn cone_names() -> String {
        ConeSolverKind::ALL
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The name of every solver a scene can use: matrix, body-level, cone.
    pub fn all_names() -> String {
        let matrix = SolverKind::ALL.iter().map(|k| k.name());
        let body = BodySolverKind::ALL.iter().map(|k| k.name());
        let cone = ConeSolverKind::ALL.iter().map(|k| k.name());
        matrix
            .chain(body)
            .chain(cone)
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The form of `A` this solver's problems take: factored for a matrix solver that sweeps on
    /// the factors ([`Solver::works_on_factors`]), so that `A` is not assembled for it;
    /// assembled otherwise.
    fn delassus_form(&self) -> DelassusForm {
        match self {
            ContactSolver::Matrix(s) if s.works_on_factors() => DelassusForm::Factored,
            _ => DelassusForm::Assembled,
        }
    }

    /// Solve one island's problem with this (matrix or cone) solver.
    fn solve_island(
        &mut self,
        problem: &IslandProblem,
        settings: &Settings,
    ) -> Result<SolveResult, String> {
        match (self, problem) {
            (ContactSolver::Matrix(s), IslandProblem::Lcp(p)) => Ok(s.solve(p, settings)),
            (ContactSolver::Cone(s), IslandProblem::Cone(p)) => Ok(s.solve_cone(p, settings)),
            (s, _) => Err(format!(
                "solver `{}` does not take this island's problem",
                s.name()
            )),
        }
    }

    /// Solve the whole step as one problem with this (matrix or cone) solver.
    fn solve_whole(&mut self, system: &ContactSystem, settings: &Settings) -> Solved {
        let n = system.n();
        let t0 = Instant::now();
        let form = self.delassus_form();
        let (result, problem, cone_problem, assembly_s) = match self {
            ContactSolver::Matrix(s) => match system.problem_in(form) {
                Ok(p) => {
                    let assembly_s = t0.elapsed().as_secs_f64();
                    (s.solve(&p, settings), Some(p), None, assembly_s)
                }
                Err(e) => return Solved::invalid(n, &e),
            },
            ContactSolver::Cone(s) => match system.cone_problem() {
                Ok(p) => {
                    let assembly_s = t0.elapsed().as_secs_f64();
                    (s.solve_cone(&p, settings), None, Some(p), assembly_s)
                }
                Err(e) => return Solved::invalid(n, &e),
            },
            ContactSolver::Body(s) => {
                let reason = format!("body-level solver `{}` solves on bodies", s.name());
                return Solved::unsupported(n, reason);
            }
        };
        let call_s = t0.elapsed().as_secs_f64() - assembly_s;
        Solved {
            f: usable_impulse(&result, n),
            status: result.status,
            iterations: result.iterations,
            time_s: result.time.as_secs_f64(),
            wall_s: 0.0,
            assembly_s,
            measure_s: (call_s - result.time.as_secs_f64()).max(0.0),
            residuals: Some(result.residuals),
            problem,
            cone_problem,
            history: result.history,
            warm_start: None,
        }
    }
}

/// One island's problem, in the form its solver takes.
enum IslandProblem {
    Lcp(Problem),
    Cone(ConeProblem),
}

impl IslandProblem {
    /// The problem of island `k` of `partition`: the cone problem when `cone`, else the LCP
    /// with `A` in `form`.
    fn of(
        system: &ContactSystem,
        partition: &Partition,
        k: usize,
        cone: bool,
        form: DelassusForm,
    ) -> Result<Self, String> {
        if cone {
            system
                .island_cone_problem(partition, k)
                .map(IslandProblem::Cone)
                .map_err(|e| e.to_string())
        } else {
            system
                .island_problem_in(partition, k, form)
                .map(IslandProblem::Lcp)
                .map_err(|e| e.to_string())
        }
    }
}

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
    /// that splits one problem itself shares it ([`Settings::max_iterations`]).
    pub max_iterations: usize,
    /// Warm-start iterative solvers from the previous step's impulses \[`true`\].
    pub warm_start: bool,
    /// Contacts closer than this are in the problem, m \[`0.01`\].
    pub prediction_distance: f64,
    /// Friction model, restitution threshold and position correction.
    pub builder: BuilderParams,
    /// Continuous collision detection: `None` \[default\], or a time-of-impact method. With
    /// one, every step moves the bodies only up to the first time of impact among pairs not yet
    /// touching (backtracking, Baraff–Witkin), so fast bodies cannot tunnel; the rest of that
    /// step's motion is dropped and the new contact enters the next step's problem.
    pub ccd: Option<ToiMethod>,
    /// Keep each step's [`Problem`] in its report (for export) \[`false`\].
    pub keep_problem: bool,
    /// Measure the shared residual for body-level solvers too (on the step's LCP with `A` held
    /// as its factors, [`DelassusForm::Factored`]: one pass over the entries of `A`, formed
    /// row by row and not stored) \[`true`\].
    pub residuals: bool,
    /// Ask matrix solvers for their convergence history (residual per iteration or pivot) and
    /// keep it in each [`StepReport`] \[`false`\]. The measuring time is excluded from the
    /// solver's reported time but not from the step's.
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

/// A scheduled change to the scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Event {
    /// Applied before step `at_step` (0-based).
    pub at_step: usize,
    /// Remove the body of this name (or every copy of a repeated body of this name).
    pub remove: String,
}

/// A contact and its impulse, for recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactRecord {
    /// Names of the two bodies.
    pub bodies: [Arc<str>; 2],
    /// Indices of the two bodies in [`World::bodies`] at the step's end.
    #[serde(skip)]
    pub body_indices: [usize; 2],
    /// World contact point.
    pub point: [f64; 3],
    /// Unit normal from the first body to the second.
    pub normal: [f64; 3],
    /// Signed gap at detection (negative: penetration).
    pub dist: f64,
    /// Total impulse on the second body (normal plus friction), world frame.
    pub impulse: [f64; 3],
    /// Normal impulse `f_n`.
    pub normal_impulse: f64,
    /// Tangential (friction) impulse on the second body, world frame.
    pub tangent_impulse: [f64; 3],
    /// Velocity of the second body's material point relative to the first's at the contact
    /// point after the step, world frame (its normal part is positive when separating).
    pub relative_velocity: [f64; 3],
    /// Friction coefficient of the contact.
    pub mu: f64,
    /// `w_n`: the normal row of `w = A f + b` at the solved impulse (separation rate the
    /// solver aimed for, bias terms included).
    pub normal_rate: f64,
    /// Complementarity of the normal row, `min(f_n, w_n / A_nn)` in impulse units: zero when
    /// `0 <= f_n ⟂ w_n >= 0` holds, non-zero when it is violated.
    pub complementarity: f64,
}

/// Wall time of the phases of one step, seconds. The phases follow one another and are read off
/// one clock, so they add up to [`StepReport::step_time_s`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct PhaseTimes {
    /// Scheduled events and collision detection: broad plus narrow phase.
    pub collision: f64,
    /// Of `collision`: the broad phase (candidate pairs).
    pub broad_phase: f64,
    /// Of `collision`: the narrow phase (contact manifolds).
    pub narrow_phase: f64,
    /// Free velocities, the contact system (`J`'s rows, `b`, bounds) and the problems the
    /// solver is given (`A = J M⁻¹ Jᵀ` of each island, or of the whole step).
    pub assembly: f64,
    /// The partition of the contacts into islands.
    pub islands: f64,
    /// The solver calls, their own residual measurements excluded.
    pub solve: f64,
    /// Measuring the solved impulse: the shared residual (the solvers' final measurement, and
    /// the assembled `A` body-level solvers are measured on), the contact records and the
    /// step's energy, momentum and penetration figures.
    pub residual: f64,
    /// Split-impulse correction, impulses applied, positions integrated (time of impact
    /// included), warm-start cache updated.
    pub integration: f64,
}

impl PhaseTimes {
    /// The phases' names, as the JSON keys and the report's columns give them.
    pub const NAMES: [&'static str; 6] = [
        "collision",
        "assembly",
        "islands",
        "solve",
        "residual",
        "integration",
    ];

    /// The top-level phases in the order of [`PhaseTimes::NAMES`].
    pub fn values(&self) -> [f64; 6] {
        [
            self.collision,
            self.assembly,
            self.islands,
            self.solve,
            self.residual,
            self.integration,
        ]
    }

    /// Sum of the top-level phases: the step's wall time.
    pub fn total(&self) -> f64 {
        self.values().iter().sum()
    }

    /// Add `other` phase by phase.
    pub fn add(&mut self, other: &PhaseTimes) {
        self.collision += other.collision;
        self.broad_phase += other.broad_phase;
        self.narrow_phase += other.narrow_phase;
        self.assembly += other.assembly;
        self.islands += other.islands;
        self.solve += other.solve;
        self.residual += other.residual;
        self.integration += other.integration;
    }

    /// Every phase multiplied by `k` (a mean from a sum).
    pub fn scaled(&self, k: f64) -> PhaseTimes {
        PhaseTimes {
            collision: self.collision * k,
            broad_phase: self.broad_phase * k,
            narrow_phase: self.narrow_phase * k,
            assembly: self.assembly * k,
            islands: self.islands * k,
            solve: self.solve * k,
            residual: self.residual * k,
            integration: self.integration * k,
        }
    }
}

/// A clock read once per phase boundary: each lap is the time since the previous one, so the
/// laps add up to the time since the start.
struct PhaseClock {
    start: Instant,
    last: Instant,
}

impl PhaseClock {
    fn start() -> Self {
        let now = Instant::now();
        Self {
            start: now,
            last: now,
        }
    }

    fn lap(&mut self) -> f64 {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        dt
    }

    fn total(&self) -> f64 {
        self.last.duration_since(self.start).as_secs_f64()
    }
}

/// What one step did and measured.
#[derive(Debug, Clone, Serialize)]
pub struct StepReport {
    /// Step index (0-based).
    pub step: usize,
    /// Simulated time at the end of the step, s.
    pub time: f64,
    /// Contacts detected.
    pub contacts: usize,
    /// Rows of the contact system.
    pub rows: usize,
    /// Solver name.
    pub solver: &'static str,
    /// Solver outcome (decided by the shared residual when one was measured).
    pub status: Status,
    /// Iterations, pivots or sweeps.
    pub iterations: usize,
    /// Solver time, s: the sum over islands of each solver call's own time (the work; islands
    /// solved in parallel take less wall time, see `solve_wall_s`).
    pub solve_time_s: f64,
    /// Wall time of the solve phase, s: island extraction and assembly of the sub-problems
    /// plus the (parallel) solver calls.
    pub solve_wall_s: f64,
    /// Independent islands of the step's contacts (contacts sharing no dynamic body).
    pub islands: usize,
    /// Rows of each island, in the order of their first contact.
    pub island_rows: Vec<usize>,
    /// Whole step wall time, s (the sum of [`StepReport::phases`]).
    pub step_time_s: f64,
    /// Wall time of each phase of the step.
    pub phases: PhaseTimes,
    /// Shared residuals of the impulse for the step's LCP (when measured).
    pub residuals: Option<Residuals>,
    /// Deepest penetration at detection, m (`>= 0`).
    pub max_penetration: f64,
    /// Mean penetration over contacts, m.
    pub mean_penetration: f64,
    /// Kinetic energy after the step, J.
    pub kinetic_energy: f64,
    /// Potential energy after the step, J.
    pub potential_energy: f64,
    /// Total linear momentum after the step.
    pub linear_momentum: [f64; 3],
    /// Total angular momentum about the origin after the step.
    pub angular_momentum: [f64; 3],
    /// Largest `‖f_t‖ − mu f_n` over contacts (`>= 0`), impulse units.
    pub friction_cone_violation: f64,
    /// With continuous collision detection: the time of impact the step was cut to, s.
    pub time_of_impact: Option<f64>,
    /// Contacts with their impulses.
    pub contact_records: Vec<ContactRecord>,
    /// The solver's convergence history, when [`SimSettings::record_history`] is set and the
    /// solver records one (matrix solvers).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub history: Vec<HistoryPoint>,
    /// The step's LCP, when [`SimSettings::keep_problem`] is set (and the solver is not a cone
    /// solver).
    #[serde(skip)]
    pub problem: Option<Problem>,
    /// The step's cone problem, when [`SimSettings::keep_problem`] is set and a cone solver
    /// solved the step (friction model `cone`).
    #[serde(skip)]
    pub cone_problem: Option<ConeProblem>,
    /// The warm start the step's matrix or cone solver was given, when
    /// [`SimSettings::keep_problem`] is set and the solver was warm-started.
    #[serde(skip)]
    pub warm_start: Option<Vec<f64>>,
}

/// The solved impulse of one step.
struct Solved {
    f: Vec<f64>,
    status: Status,
    iterations: usize,
    time_s: f64,
    wall_s: f64,
    /// Of the solve phase's wall time: the share spent assembling the solvers' problems.
    assembly_s: f64,
    /// Of the solve phase's wall time: the share spent measuring residuals (the solvers' final
    /// measurement and recorded histories, the assembled `A` of body-level solvers).
    measure_s: f64,
    residuals: Option<Residuals>,
    problem: Option<Problem>,
    cone_problem: Option<ConeProblem>,
    history: Vec<HistoryPoint>,
    /// The warm start given to a matrix or cone solver, kept with the problem.
    warm_start: Option<Vec<f64>>,
}

/// Solve each island of `partition` on its own (one clone of `solver` per island, in parallel
/// with rayon) and scatter the impulses back. The islands' problems are assembled first, then
/// solved; each solve's settings carry its part of the warm start and the time left before
/// `deadline`. The step's residuals are those of the whole: every measure is a maximum over rows
/// (or contacts, for the cone residual) except the complementarity gap, a sum, and `A` has no
/// entry between islands. The status is the worst island's.
fn solve_islands(
    system: &ContactSystem,
    partition: &Partition,
    settings: &Settings,
    solver: &ContactSolver,
    deadline: Option<Instant>,
) -> Solved {
    use rayon::prelude::*;
    let n = system.n();
    let t0 = Instant::now();
    let cone = solver.is_cone();
    let form = solver.delassus_form();
    let problems: Vec<Result<IslandProblem, String>> = (0..partition.len())
        .into_par_iter()
        .map(|k| IslandProblem::of(system, partition, k, cone, form))
        .collect();
    let assembly_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let solvers: Vec<ContactSolver> = (0..partition.len()).map(|_| solver.clone()).collect();
    // Each result with the wall time of its call.
    let results: Vec<Result<(SolveResult, f64), String>> = solvers
        .into_par_iter()
        .zip(problems)
        .enumerate()
        .map(|(k, (mut solver, problem))| {
            let rows = &partition.islands[k].rows;
            let island_settings = Settings {
                warm_start: settings
                    .warm_start
                    .as_ref()
                    .map(|ws| rows.iter().map(|&i| ws[i]).collect()),
                time_budget: deadline.map(|d| d.saturating_duration_since(Instant::now())),
                ..settings.clone()
            };
            let call = Instant::now();
            let result = solver.solve_island(&problem?, &island_settings)?;
            Ok((result, call.elapsed().as_secs_f64()))
        })
        .collect();
    let solve_wall_s = t1.elapsed().as_secs_f64();
    let mut f = vec![0.0; n];
    let mut status = Status::Converged;
    let (mut iterations, mut time_s) = (0, 0.0);
    let (mut calls_s, mut measured_s) = (0.0, 0.0);
    // The history shown for the step: the largest island's.
    let (mut history, mut history_rows) = (Vec::new(), 0);
    let mut res = Residuals {
        natural_map: 0.0,
        natural_map_rel: 0.0,
        complementarity_gap: 0.0,
        bound_violation: 0.0,
    };
    for (island, result) in partition.islands.iter().zip(results) {
        let (result, call_s) = match result {
            Ok(r) => r,
            Err(e) => return Solved::invalid(n, &e),
        };
        for (&i, v) in island
            .rows
            .iter()
            .zip(usable_impulse(&result, island.rows.len()))
        {
            f[i] = v;
        }
        if status_rank(&result.status) > status_rank(&status) {
            status = result.status;
        }
        iterations = iterations.max(result.iterations);
        let own_s = result.time.as_secs_f64();
        time_s += own_s;
        calls_s += call_s;
        measured_s += (call_s - own_s).max(0.0);
        if island.rows.len() > history_rows {
            history_rows = island.rows.len();
            history = result.history;
        }
        let r = result.residuals;
        res.natural_map = res.natural_map.max(r.natural_map);
        res.natural_map_rel = res.natural_map_rel.max(r.natural_map_rel);
        res.complementarity_gap += r.complementarity_gap;
        res.bound_violation = res.bound_violation.max(r.bound_violation);
    }
    // The calls ran in parallel: their measuring share of the phase's wall time is their
    // share of the summed call times.
    let measure_s = if calls_s > 0.0 {
        solve_wall_s * measured_s / calls_s
    } else {
        0.0
    };
    Solved {
        f,
        status,
        iterations,
        time_s,
        wall_s: 0.0,
        assembly_s,
        measure_s,
        residuals: Some(res),
        problem: None,
        cone_problem: None,
        history,
        warm_start: None,
    }
}

/// How bad a status is, for reporting the worst island: converged < stalled < limits <
/// failures < unsupported.
fn status_rank(status: &Status) -> u8 {
    match status {
        Status::Converged => 0,
        Status::Stalled { .. } => 1,
        Status::IterationLimit | Status::TimeLimit => 2,
        Status::NoSolution { .. } | Status::Diverged { .. } | Status::NumericalFailure { .. } => 3,
        Status::Unsupported { .. } => 4,
    }
}

/// Every finite answer is applied (its status is reported); an unsupported problem or a
/// non-finite answer applies no impulse.
fn usable_impulse(result: &SolveResult, n: usize) -> Vec<f64> {
    let usable = !matches!(result.status, Status::Unsupported { .. })
        && result.f.len() == n
        && result.f.iter().all(|v| v.is_finite());
    if usable {
        result.f.clone()
    } else {
        vec![0.0; n]
    }
}

impl Solved {
    /// A step without contact rows: nothing to solve.
    fn empty() -> Self {
        Solved {
            f: Vec::new(),
            status: Status::Converged,
            iterations: 0,
            time_s: 0.0,
            wall_s: 0.0,
            assembly_s: 0.0,
            measure_s: 0.0,
            residuals: None,
            problem: None,
            cone_problem: None,
            history: Vec::new(),
            warm_start: None,
        }
    }

    /// No impulse: the contact system could not be made into a problem.
    fn invalid(n: usize, e: &dyn std::fmt::Display) -> Self {
        Solved {
            f: vec![0.0; n],
            status: Status::NumericalFailure {
                reason: format!("contact system is invalid: {e}"),
            },
            iterations: 0,
            time_s: 0.0,
            wall_s: 0.0,
            assembly_s: 0.0,
            measure_s: 0.0,
            residuals: None,
            problem: None,
            cone_problem: None,
            history: Vec::new(),
            warm_start: None,
        }
    }

    /// No impulse: the solver does not take the step's friction model.
    fn unsupported(n: usize, reason: String) -> Self {
        Solved {
            status: Status::Unsupported { reason },
            ..Self::invalid(n, &"")
        }
    }
}

/// Bodies, materials, settings and the state carried between steps.
pub struct World {
    /// The bodies.
    pub bodies: Vec<RigidBody>,
    /// For each body, the scene entry it came from (the name events refer to).
    pub groups: Vec<String>,
    /// Materials, indexed by [`RigidBody::material`].
    pub materials: Vec<Material>,
    /// Settings.
    pub settings: SimSettings,
    /// Scheduled events.
    pub events: Vec<Event>,
    /// Collision detection with its manifold cache.
    pub pipeline: CollisionPipeline,
    /// Impulses of the last step, by contact key.
    pub warm: WarmStartCache,
    /// Steps taken.
    pub step_index: usize,
    /// Simulated time, s.
    pub time: f64,
    /// The working copy of `settings.solver` for whole-step solves (it keeps its workspace
    /// from step to step); islands get fresh clones of `settings.solver` itself.
    whole: ContactSolver,
}

impl World {
    /// A world at time 0.
    pub fn new(bodies: Vec<RigidBody>, materials: Vec<Material>, settings: SimSettings) -> Self {
        let groups = bodies.iter().map(|b| b.name.clone()).collect();
        let whole = settings.solver.clone();
        Self {
            bodies,
            groups,
            materials,
            settings,
            events: Vec::new(),
            pipeline: CollisionPipeline::new(),
            warm: WarmStartCache::default(),
            step_index: 0,
            time: 0.0,
            whole,
        }
    }

    /// Switch the contact solver (keeps the warm-start cache).
    pub fn set_solver(&mut self, solver: impl Into<ContactSolver>) {
        self.settings.solver = solver.into();
        self.whole = self.settings.solver.clone();
    }

    /// Index of the body named `name`.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// One time step: detect, build, solve, apply and integrate, measure.
    ///
    /// A step past one of the stated limits (candidate pairs, contacts, entries of `A`: see
    /// [`broad_phase::MAX_PAIRS`](crate::collision::broad_phase::MAX_PAIRS),
    /// [`narrow_phase::MAX_CONTACTS`](crate::collision::narrow_phase::MAX_CONTACTS),
    /// [`builder::MAX_DELASSUS_ENTRIES`]) is not solved: it applies no contact impulse and
    /// reports `Unsupported` with the limit as the reason.
    pub fn step(&mut self) -> StepReport {
        let mut clock = PhaseClock::start();
        let mut phases = PhaseTimes::default();
        self.apply_events();
        let (h, gravity) = (self.settings.dt, self.settings.gravity);
        let (contacts, detection_refused) = match self
            .pipeline
            .detect(&self.bodies, self.settings.prediction_distance)
        {
            Ok(contacts) => (contacts, None),
            Err(e) => (Vec::new(), Some(format!("collision detection: {e}"))),
        };
        phases.collision = clock.lap();
        let timings = self.pipeline.timings();
        (phases.broad_phase, phases.narrow_phase) = (timings.broad_phase, timings.narrow_phase);
        let free = builder::free_velocities(&self.bodies, &gravity, h);
        let system = builder::build(
            &self.bodies,
            &self.materials,
            &contacts,
            free,
            &self.settings.builder,
            h,
        );
        phases.assembly = clock.lap();
        let partition = system.islands();
        phases.islands = clock.lap();
        let refused = detection_refused.or_else(|| self.size_refusal(&system));
        let mut solved = match &refused {
            Some(reason) => {
                self.warm.clear();
                Solved::unsupported(system.n(), reason.clone())
            }
            None => self.solve(&system, &partition),
        };
        let solve_wall = clock.lap();
        // The solve phase's shares of assembly and measurement go to those phases.
        let assembly = solved.assembly_s.min(solve_wall);
        let measure = solved.measure_s.min(solve_wall - assembly);
        phases.assembly += assembly;
        phases.residual += measure;
        phases.solve = solve_wall - assembly - measure;
        let pseudo = if refused.is_none() {
            self.split_impulse_velocities(&system)
        } else {
            None
        };
        let toi = match self.integrate(&system, &solved.f, pseudo.as_deref()) {
            Ok(toi) => toi,
            Err(e) => {
                solved.status = Status::Unsupported {
                    reason: format!("continuous collision detection: {e}"),
                };
                None
            }
        };
        self.step_index += 1;
        self.time += h;
        phases.integration = clock.lap();
        self.report(&system, &partition, solved, toi, clock, phases)
    }

    /// Run `n` steps, returning their reports.
    pub fn run(&mut self, n: usize) -> Vec<StepReport> {
        (0..n).map(|_| self.step()).collect()
    }

    fn apply_events(&mut self) {
        let now = self.step_index;
        let due: Vec<String> = self
            .events
            .iter()
            .filter(|e| e.at_step == now)
            .map(|e| e.remove.clone())
            .collect();
        if due.is_empty() {
            return;
        }
        for name in due {
            let keep: Vec<bool> = (0..self.bodies.len())
                .map(|i| self.bodies[i].name != name && self.groups[i] != name)
                .collect();
            let mut it = keep.iter();
            self.bodies.retain(|_| *it.next().unwrap_or(&true));
            let mut it = keep.iter();
            self.groups.retain(|_| *it.next().unwrap_or(&true));
        }
        // Body indices changed: cached manifolds and contact keys no longer match.
        self.pipeline.clear();
        self.warm.clear();
    }

    /// Why the step's contact problem is too large, when it is: the matrix and cone solvers, a
    /// kept problem and split impulses assemble (part of) `A`, and the shared residual, where
    /// `A` is held as its factors, visits each of its entries (time, not memory); a body-level
    /// solver without them works on the bodies alone.
    fn size_refusal(&self, system: &ContactSystem) -> Option<String> {
        let assembles = !matches!(self.settings.solver, ContactSolver::Body(_))
            || self.settings.residuals
            || self.settings.keep_problem
            || self.settings.builder.position_correction == PositionCorrection::Split;
        if !assembles {
            return None;
        }
        system.check_delassus_size(&self.bodies).err()
    }

    /// The deadline of a solve starting now: the step's time budget from now, or the run's
    /// deadline if earlier.
    fn solve_deadline(&self) -> Option<Instant> {
        let step = self
            .settings
            .step_time_budget
            .and_then(|b| Instant::now().checked_add(b));
        match (step, self.settings.deadline) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The solver settings of a solve that must end by `deadline`.
    fn solver_settings(&self, deadline: Option<Instant>) -> Settings {
        Settings {
            tolerance: self.settings.tolerance,
            max_iterations: self.settings.max_iterations,
            time_budget: deadline.map(|d| d.saturating_duration_since(Instant::now())),
            ..Settings::default()
        }
    }

    /// Solve the step's system with the world's solver: nothing for no rows, `Unsupported`
    /// when the solver does not take the friction model, else the body-level or the matrix /
    /// cone path, within the step's time budget. Stores the warm start for the next step.
    fn solve(&mut self, system: &ContactSystem, partition: &Partition) -> Solved {
        let n = system.n();
        let wall = Instant::now();
        let deadline = self.solve_deadline();
        if n == 0 {
            self.warm.clear();
            return Solved::empty();
        }
        let model = self.settings.builder.friction_model;
        let mut solved = if let Err(reason) = self.settings.solver.supports(model) {
            self.warm.clear();
            Solved::unsupported(n, reason)
        } else {
            let warm_start = self
                .settings
                .warm_start
                .then(|| system.warm_start(&self.warm));
            if matches!(self.settings.solver, ContactSolver::Body(_)) {
                self.solve_on_bodies(system, warm_start, deadline)
            } else {
                self.solve_problem(system, partition, warm_start, deadline)
            }
        };
        solved.wall_s = wall.elapsed().as_secs_f64();
        solved
    }

    /// The matrix and cone path: the assembled problem (per island when there are several)
    /// solved with the instance; the problem kept on request.
    fn solve_problem(
        &mut self,
        system: &ContactSystem,
        partition: &Partition,
        warm_start: Option<Vec<f64>>,
        deadline: Option<Instant>,
    ) -> Solved {
        let mut settings = self.solver_settings(deadline);
        settings.record_history = self.settings.record_history;
        if self.settings.solver.takes_warm_start() {
            settings.warm_start = warm_start;
        }
        let kept_warm_start = if self.settings.keep_problem {
            settings.warm_start.clone()
        } else {
            None
        };
        if self.whole.name() != self.settings.solver.name() {
            self.whole = self.settings.solver.clone();
        }
        let mut solved = if self.settings.islands && partition.len() > 1 {
            solve_islands(
                system,
                partition,
                &settings,
                &self.settings.solver,
                deadline,
            )
        } else {
            self.whole.solve_whole(system, &settings)
        };
        if self.settings.keep_problem {
            if self.settings.solver.is_cone() {
                if solved.cone_problem.is_none() {
                    solved.cone_problem = system.cone_problem().ok();
                }
            } else if solved.problem.is_none() {
                solved.problem = system.problem().ok();
            }
        }
        self.warm.store(system, &solved.f);
        solved.warm_start = kept_warm_start;
        solved
    }

    /// The body-level path: the solver works on `system`, and the status is decided from the
    /// shared residual of the step's LCP (`A` held as its factors) when residuals (or the
    /// problem) are wanted.
    fn solve_on_bodies(
        &mut self,
        system: &ContactSystem,
        warm_start: Option<Vec<f64>>,
        deadline: Option<Instant>,
    ) -> Solved {
        let t0 = Instant::now();
        let measured = (self.settings.residuals || self.settings.keep_problem).then(|| {
            system
                .problem_in(DelassusForm::Factored)
                .map_err(|e| e.to_string())
        });
        let assembly_s = t0.elapsed().as_secs_f64();
        let settings = Settings {
            warm_start,
            ..self.solver_settings(deadline)
        };
        let call = Instant::now();
        let measure = match &measured {
            Some(Ok(p)) => Measure::Lcp(p),
            Some(Err(e)) => Measure::Invalid(e),
            None => Measure::Skip,
        };
        let out = match &mut self.settings.solver {
            ContactSolver::Body(s) => s.solve(system, &settings, measure),
            _ => return Solved::unsupported(system.n(), "not a body-level solver".into()),
        };
        let call_s = call.elapsed().as_secs_f64();
        self.warm.store(system, &out.warm);
        let problem = measured.and_then(Result::ok);
        let r = out.result;
        let own_s = r.time.as_secs_f64();
        Solved {
            f: r.f,
            status: r.status,
            iterations: r.iterations,
            time_s: own_s,
            wall_s: 0.0,
            // The measured problem serves only the measurement.
            assembly_s: 0.0,
            measure_s: assembly_s + (call_s - own_s).max(0.0),
            residuals: problem.is_some().then_some(r.residuals),
            problem,
            cone_problem: None,
            history: Vec::new(),
            warm_start: None,
        }
    }

    /// Split impulses: pseudo-velocities from a projected Gauss–Seidel solve of the normal rows
    /// with `b = position error term`, the same for every contact solver.
    fn split_impulse_velocities(&self, system: &ContactSystem) -> Option<Vec<BodyVelocity>> {
        if self.settings.builder.position_correction != PositionCorrection::Split {
            return None;
        }
        let zero = vec![BodyVelocity::default(); system.inv_mass.len()];
        let (problem, normals) = system.position_problem(&zero)?;
        let settings = self.solver_settings(self.solve_deadline());
        let result = ProjectedSor::pgs().solve(&problem, &settings);
        let mut f = vec![0.0; system.n()];
        for (&row, &v) in normals.iter().zip(&result.f) {
            if v.is_finite() {
                f[row] = v;
            }
        }
        Some(system.velocity_change(&f))
    }

    /// Apply the impulses and move the bodies; returns the time of impact the motion was cut to
    /// when continuous collision detection found one. When its broad phase is past its limit,
    /// the bodies move the whole step and the error says so.
    fn integrate(
        &mut self,
        system: &ContactSystem,
        f: &[f64],
        pseudo: Option<&[BodyVelocity]>,
    ) -> Result<Option<f64>, TooManyPairs> {
        let (h, gravity) = (self.settings.dt, self.settings.gravity);
        let dp = system.momentum_change(f);
        if let Some(method) = self.settings.ccd {
            for (body, (dl_lin, dl_ang)) in self.bodies.iter_mut().zip(&dp) {
                integrate::apply_momentum(body, h, &gravity, dl_lin, dl_ang);
            }
            let impact = first_impact(&self.bodies, h, method, &ToiSettings::default());
            let h_pose = impact.map_or(h, |i| i.map_or(h, |i| i.toi.time));
            for (k, body) in self.bodies.iter_mut().enumerate() {
                integrate::advance_pose(body, h_pose, pseudo.map(|p| &p[k]));
            }
            return impact.map(|i| i.map(|i| i.toi.time));
        }
        for (k, body) in self.bodies.iter_mut().enumerate() {
            let (dl_lin, dl_ang) = &dp[k];
            let moved = pseudo
                .is_some_and(|p| p[k].linear.norm_squared() + p[k].angular.norm_squared() > 0.0);
            if dl_lin.norm_squared() + dl_ang.norm_squared() > 0.0 || moved {
                integrate::symplectic_euler(
                    body,
                    h,
                    &gravity,
                    dl_lin,
                    dl_ang,
                    pseudo.map(|p| &p[k]),
                );
            } else {
                integrate::rk4_free_flight(body, h, &gravity);
            }
        }
        Ok(None)
    }

    /// Per contact: impulses, post-step relative velocity and normal-row complementarity.
    fn contact_records(&self, system: &ContactSystem, f: &[f64]) -> Vec<ContactRecord> {
        if f.len() != system.n() {
            return Vec::new();
        }
        let op = system.operator();
        // Velocity the solve produced: u = u* + M⁻¹ Jᵀ f, so w = J u + bias.
        let mut u = system.free_velocity.clone();
        op.add_response(f, &mut u);
        // One shared name per body, not one copy per contact.
        let names: Vec<Arc<str>> = self
            .bodies
            .iter()
            .map(|b| Arc::from(b.name.as_str()))
            .collect();
        let name = |i: usize| names.get(i).cloned().unwrap_or_else(|| Arc::from(""));
        let velocity = |i: usize, p| {
            self.bodies
                .get(i)
                .map_or(Vector3::zeros(), |b| b.velocity_at(p))
        };
        system
            .contacts
            .iter()
            .enumerate()
            .map(|(c, ct)| {
                let imp = system.contact_impulse(c, f);
                let info = &system.info[c];
                let row = info.normal_row;
                let w_n = op.row_dot(row, &u) + system.bias[row];
                let a_nn = op.diagonal(row);
                let scaled = if a_nn > 0.0 { w_n / a_nn } else { w_n };
                let rel = velocity(ct.body_b, &ct.point) - velocity(ct.body_a, &ct.point);
                ContactRecord {
                    bodies: [name(ct.body_a), name(ct.body_b)],
                    body_indices: [ct.body_a, ct.body_b],
                    point: ct.point.coords.into(),
                    normal: ct.normal.into(),
                    dist: ct.dist,
                    impulse: (ct.normal * imp.normal + imp.tangent).into(),
                    normal_impulse: imp.normal,
                    tangent_impulse: imp.tangent.into(),
                    relative_velocity: rel.into(),
                    mu: info.mu,
                    normal_rate: w_n,
                    complementarity: imp.normal.min(scaled),
                }
            })
            .collect()
    }

    fn report(
        &self,
        system: &ContactSystem,
        partition: &Partition,
        solved: Solved,
        time_of_impact: Option<f64>,
        mut clock: PhaseClock,
        mut phases: PhaseTimes,
    ) -> StepReport {
        let gravity = self.settings.gravity;
        let pen: Vec<f64> = system.contacts.iter().map(|c| (-c.dist).max(0.0)).collect();
        let max_penetration = pen.iter().copied().fold(0.0, f64::max);
        let mean_penetration = if pen.is_empty() {
            0.0
        } else {
            pen.iter().sum::<f64>() / pen.len() as f64
        };
        let mut lin = Vector3::zeros();
        let mut ang = Vector3::zeros();
        let (mut ke, mut pe) = (0.0, 0.0);
        for b in self.bodies.iter().filter(|b| !b.is_static) {
            lin += b.linear_momentum;
            ang += b.position.coords.cross(&b.linear_momentum) + b.angular_momentum;
            ke += integrate::kinetic_energy(b);
            pe += integrate::potential_energy(b, &gravity);
        }
        let f = &solved.f;
        let contact_records = self.contact_records(system, f);
        let friction_cone_violation = if f.len() == system.n() {
            system.friction_cone_violation(f)
        } else {
            0.0
        };
        phases.residual += clock.lap();
        StepReport {
            step: self.step_index - 1,
            time: self.time,
            contacts: system.contacts.len(),
            rows: system.n(),
            solver: self.settings.solver.name(),
            status: solved.status,
            iterations: solved.iterations,
            solve_time_s: solved.time_s,
            solve_wall_s: solved.wall_s,
            islands: partition.len(),
            island_rows: partition.islands.iter().map(|i| i.rows.len()).collect(),
            step_time_s: clock.total(),
            phases,
            residuals: solved.residuals,
            max_penetration,
            mean_penetration,
            kinetic_energy: ke,
            potential_energy: pe,
            linear_momentum: lin.into(),
            angular_momentum: ang.into(),
            friction_cone_violation,
            contact_records,
            history: solved.history,
            time_of_impact,
            problem: if self.settings.keep_problem {
                solved.problem
            } else {
                None
            },
            cone_problem: if self.settings.keep_problem {
                solved.cone_problem
            } else {
                None
            },
            warm_start: solved.warm_start,
        }
    }
}

//! Substepping solvers: the methods shipping engines use, which split a step into substeps,
//! make constraints soft springs and move the bodies themselves.
//!
//! The stepper detects contacts and builds the step's [`ContactSystem`] once; a substepping
//! solver then advances the bodies over the whole step with the contact points, normals and
//! anchors of the step's start (no collision per substep), updating each row's position error
//! from the bodies' motion since the start ([`state`]). What it returns
//! ([`SubstepOutcome`]) is the bodies' pose change and final velocities, the impulse each row
//! applied over the step, and its **last solve**: the impulse and the `b` of the LCP that
//! solve worked on (`A` is the step's: the rows are held). The stepper measures the shared
//! residual of that last solve on that LCP, and the step report says it did
//! ([`crate::StepReport::residual_of`]).
//!
//! The solvers (one file each; their parameters in [`params`], soft constraints in
//! [`softness`]):
//!
//! * `soft-step` ([`soft_step`]): substeps with soft contacts and joints, a relax pass and a
//!   restitution pass (Box2D v3's soft step; Rapier's TGS-soft);
//! * `tgs` ([`tgs`]): substeps with Baumgarte bias, rigid constraints, no relax;
//! * `pgs-ngs` ([`pgs_ngs`]): one step of projected Gauss–Seidel on velocities, then nonlinear
//!   Gauss–Seidel on positions (Box2D 2.x);
//! * `xpbd` ([`xpbd`]): extended position-based dynamics with small steps (Macklin et al.
//!   2019);
//! * `jacobi` ([`jacobi`]): every row solved from the same velocities, then applied (the
//!   parallel baseline).
//!
//! `soft-step`, `tgs` and `pgs-ngs` take `colour=1` for coloured sweeps: the constraints
//! coloured so that no two of a colour share a dynamic body ([`colouring`], Box2D v3's
//! constraint graph) and each colour's swept in parallel: `soft-step` and `tgs` on their
//! compact row layout, writing the bodies in place ([`constraint_rows`]), `pgs-ngs` on
//! per-constraint blocks with body copies ([`coloured_sweep`]).
//!
//! Without a world (a [`crate::BodySolver::sweep`] on a system alone) a substepping solver
//! starts from the system's free velocities, gravity already in them, and returns the impulse
//! of the whole step; the stepper always takes [`crate::BodySolver::advance`].

pub mod bias;
pub mod coloured_sweep;
pub mod colouring;
pub mod constraint_rows;
pub mod jacobi;
pub mod params;
pub mod pgs_ngs;
pub mod soft_step;
pub mod softness;
pub mod state;
pub mod tgs;
pub mod xpbd;

pub use jacobi::Jacobi;
pub use params::{ParamSpec, Params};
pub use pgs_ngs::PgsNgs;
pub use soft_step::SoftStep;
pub use softness::Softness;
pub use state::{RowRole, SolverBody, SolverRow, SolverState, StepCost};
pub use tgs::Tgs;
pub use xpbd::Xpbd;

use crate::builder::ContactSystem;
use lcpbench_solvers::Settings;
use nalgebra::Vector3;

/// What a substepping solver needs besides the system: gravity and the shared settings
/// (`max_iterations` caps the total of sweeps over the step's substeps; `time_budget` is
/// checked between substeps; `warm_start` is the previous step's last-substep impulses).
#[derive(Debug, Clone, Copy)]
pub struct SubstepInput<'a> {
    /// The step's system (rows, anchors and position errors at the step's start).
    pub system: &'a ContactSystem,
    /// Gravity, m/s².
    pub gravity: Vector3<f64>,
    /// Shared settings.
    pub settings: &'a Settings,
}

/// The LCP a substepping solver's last solve worked on, and its answer.
#[derive(Debug, Clone, PartialEq)]
pub struct LastSolve {
    /// The impulse of that solve, per row of the system.
    pub f: Vec<f64>,
    /// Its `b` (`w = A f + b`, `A` the step's): `J v` at the solve's start plus its bias.
    pub b: Vec<f64>,
    /// Which solve it was, for the step report (`"relax pass of substep 4 of 4"`).
    pub what: String,
}

/// What a substepping solver returns for one step.
#[derive(Debug, Clone, PartialEq)]
pub struct SubstepOutcome {
    /// The bodies at the step's end: velocities and pose changes since its start.
    pub state: SolverState,
    /// Total impulse each row applied over the step (every substep and pass).
    pub f_step: Vec<f64>,
    /// The impulses to warm-start the next step with.
    pub warm: Vec<f64>,
    /// The last solve and its LCP.
    pub last: LastSolve,
    /// Sweeps over the rows, summed over the substeps and passes.
    pub iterations: usize,
    /// Substeps taken.
    pub substeps: usize,
    /// Row updates and body passes.
    pub cost: StepCost,
    /// True when the time budget ended the step's substeps early (the remaining substeps then
    /// only integrate, without constraint solves).
    pub timed_out: bool,
}

/// A step's outcome as what [`crate::BodySolver::sweep`] returns on a system alone: the step's
/// total impulse, the impulses to warm-start with, the sweeps; never `stopped` (a set number of
/// sweeps is not a stopping rule, so the shared rule says `iteration_limit` unless the residual
/// meets the tolerance).
impl From<SubstepOutcome> for crate::body_solvers::BodySweep {
    fn from(out: SubstepOutcome) -> Self {
        Self {
            f: out.f_step,
            warm: out.warm,
            iterations: out.iterations,
            stopped: false,
            stalled: None,
            timed_out: out.timed_out,
        }
    }
}

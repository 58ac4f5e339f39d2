//! Contact solvers that work on bodies directly (matrix-free), selectable by name like the
//! matrix solvers of `lcpbench-solvers`.
//!
//! All four read the step's [`ContactSystem`] through its [`DelassusOperator`] (apply `J`,
//! `M⁻¹`, `Jᵀ` per body; cost per contact visit `O(1)`), never forming `A`. They support the
//! frictionless and box friction models (the pyramid model is an LCP formulation for the matrix
//! solvers) and return one impulse per row of the system, so the shared residual of the step's
//! LCP can be measured for them too.
//!
//! * **`si`, sequential impulses** (Catto 2005, as in Box2D and Bullet): a *restitution phase*
//!   first resolves each bouncing contact in turn with Newton's law on the current relative
//!   velocity, repeating sweeps until no contact closes faster than the bounce threshold (the
//!   sequential collision model of Guendelman et al. 2003, which propagates impulses through a
//!   chain: Newton's cradle ends at `(0, …, 0, v)`, Smith et al. 2012); then a *contact phase*
//!   of projected Gauss–Seidel sweeps on the accumulated impulse (accumulated clamping: the total
//!   normal impulse stays `>= 0`, the friction impulse within `±mu f_n`), warm-started from the
//!   previous step's contact-phase impulses. Joint rows are swept first in each sweep, as
//!   engines do (Box2D, Bullet), with no clamp (they are equalities) and warm-started from the
//!   joint's impulses of the previous step; the other body-level solvers resolve contacts only
//!   and are `Unsupported` on a step with joints. Failure mode: slow convergence on stiff
//!   stacks, mass ratios and long chains of joints (it is Gauss–Seidel).
//! * **`body-micro`, micro-impulses** (Mirtich 1996): every closing contact is a collision,
//!   resolved alone with a non-negative impulse (Newton's law above the bounce threshold, else
//!   the velocity target of the bias) and Coulomb friction clamped to the circular cone of that
//!   impulse; sweeps repeat until nothing closes. No impulse is ever taken back, so resting
//!   contacts are a stream of small collisions and friction acts only during them (boxes creep on
//!   slopes; stacks jitter). Failure mode: many sweeps for resting stacks.
//! * **`penalty`, spring–damper** (the baseline): a penetrating contact gets the force
//!   `f_n = max(0, k · (−dist) − c · v_n)` over the step, with `k = m_eff ω²`,
//!   `c = 2 ζ m_eff ω`, `m_eff = 1/A_nn`, `ω = penalty_omega_h / h` (or a given stiffness), and a
//!   friction impulse that stops sliding up to `mu f_n h` (regularised Coulomb). All contacts
//!   use the velocities at the start of the step (one Jacobi pass). It ignores restitution and
//!   position correction (its spring does both) and does not solve the LCP: its shared residual
//!   is reported honestly and is large.
//! * **`avg`, averaged impulses** (module [`averaged_impulse`]): each body pair's contacts
//!   replaced by one contact at their averaged point along their averaged normal, solved by
//!   `si`'s sweeps, the pair impulse returned as equal shares on the pair's contacts. Exact
//!   only for a convex contact region with one normal whose averaged point is where the
//!   support is: a box on two separated supports or under an off-centre load tilts, a body in a
//!   non-convex mesh is pushed along a normal no face has.
//!
//! Each is a type implementing [`BodySolver`] ([`SequentialImpulses`], [`MicroImpulses`],
//! [`Penalty`], [`AveragedImpulse`]). They take the shared [`Settings`] of `lcpbench-solvers`
//! (`tolerance` is both their own stopping scale, a sweep's largest impulse change against
//! `tolerance` times the impulse scale, and the shared residual's tolerance; `max_iterations`
//! caps sweeps; `time_budget` ends the sweeps `time_limit` when it is spent, checked after each
//! sweep; the warm start is `Settings::warm_start`), and [`BodySolver::solve`] decides the
//! status with the same rule as every matrix solver ([`lcpbench_solvers::decide`]) from the
//! shared residual of the step's LCP, when that LCP is given to measure on. The bounce
//! threshold is the builder's ([`ContactSystem::restitution_threshold`]). `si`, `body-micro`
//! and `avg` never spin: when a sweep's largest impulse change, relative to the impulse scale,
//! has made no new low (1 % below the best) in [`FIRST_ORDER_STAGNATION_WINDOW`] sweeps, they
//! stop `Stalled` ([`lcpbench_solvers::Stagnation`]).

use crate::builder::{bounces, BodyVelocity, ContactSystem, DelassusOperator};
use crate::substep::{Params, SubstepInput, SubstepOutcome};
use lcpbench_solvers::registry::{Make, SolverEntry};
use lcpbench_solvers::{
    decide, judge, non_finite_reason, residuals_and_velocity, Outcome, Problem, Residuals,
    Settings, SolveResult, Stagnation, Status, FIRST_ORDER_STAGNATION_WINDOW,
};
use nalgebra::{Matrix2, Vector2};
use std::time::Instant;

pub mod averaged_impulse;

pub use averaged_impulse::AveragedImpulse;

/// How a body-level entry of the [registry](lcpbench_solvers::registry) makes its solver, and
/// what the stepper needs to know of it. Held type-erased in the entry's
/// [`Make::Body`](lcpbench_solvers::registry::Make::Body) (`lcpbench-solvers` cannot name
/// [`BodySolver`]); [`body_make`] and [`BodySolverKind`] read it back.
#[derive(Clone, Copy)]
pub struct BodyMake {
    /// The solver with parameters (checked against the entry's `params`).
    pub make: fn(&Params) -> Box<dyn BodySolver + Send>,
    /// True when it applies joint (equality) rows with the contacts.
    pub takes_joints: bool,
    /// True for a substepping solver ([`crate::substep`]), which moves the bodies itself
    /// ([`BodySolver::advance`]).
    pub substeps: bool,
}

/// The [`BodyMake`] of a body-level entry (`None` for an entry of another level, or whose
/// constructor is not a [`BodyMake`]).
pub fn body_make(entry: &SolverEntry) -> Option<&'static BodyMake> {
    match entry.make {
        Make::Body(any) => any.downcast_ref::<BodyMake>(),
        _ => None,
    }
}

/// The body-level solvers of this crate, in report order (the registry's list of them).
pub static BODY_SOLVERS: &[&SolverEntry] = &[
    &SI,
    &BODY_MICRO,
    &PENALTY,
    &averaged_impulse::AVG,
    &crate::substep::soft_step::SOFT_STEP,
    &crate::substep::tgs::TGS,
    &crate::substep::pgs_ngs::PGS_NGS,
    &crate::substep::jacobi::JACOBI,
    &crate::substep::xpbd::XPBD,
];

/// A body-level solver of the registry: a `Copy` handle to its [`SolverEntry`], as
/// `lcpbench_solvers::SolverKind` (the built-in ones have associated constants;
/// [`BodySolverKind::all`] lists them and the ones registered at run time).
#[derive(Clone, Copy)]
pub struct BodySolverKind(&'static SolverEntry);

lcpbench_solvers::kind_handle!(
    BodySolverKind,
    lcpbench_solvers::registry::Level::Body,
    || crate::registry::entries_at(lcpbench_solvers::registry::Level::Body)
);

#[allow(non_upper_case_globals)]
impl BodySolverKind {
    /// Sequential impulses with accumulated clamping and warm starting.
    pub const SequentialImpulses: Self = Self(&SI);
    /// Mirtich micro-impulses.
    pub const MicroImpulses: Self = Self(&BODY_MICRO);
    /// Spring–damper penalty forces.
    pub const Penalty: Self = Self(&PENALTY);
    /// One averaged impulse per body pair.
    pub const AveragedImpulse: Self = Self(&averaged_impulse::AVG);
    /// Substeps with soft contacts and joints, relax and restitution passes (Box2D v3).
    pub const SoftStep: Self = Self(&crate::substep::soft_step::SOFT_STEP);
    /// Temporal Gauss–Seidel: substeps with Baumgarte bias, rigid rows, no relax.
    pub const Tgs: Self = Self(&crate::substep::tgs::TGS);
    /// Box2D 2.x: sequential impulses on velocities, nonlinear Gauss–Seidel on positions.
    pub const PgsNgs: Self = Self(&crate::substep::pgs_ngs::PGS_NGS);
    /// Projected Jacobi with mass splitting: every row from the same velocities.
    pub const Jacobi: Self = Self(&crate::substep::jacobi::JACOBI);
    /// Extended position-based dynamics with small steps ([`crate::substep::xpbd`]).
    pub const Xpbd: Self = Self(&crate::substep::xpbd::XPBD);

    /// The handle of `entry`, for a body-level solver's own [`BodySolver::kind`] (a solver
    /// registered at run time names itself by its entry this way). `entry` should be a
    /// registered body-level entry; for any other, the handle makes a solver whose every
    /// sweep stalls, saying why.
    pub const fn for_entry(entry: &'static SolverEntry) -> Self {
        Self(entry)
    }

    /// One line saying what the solver is (for solver listings).
    pub fn description(self) -> &'static str {
        self.0.summary
    }

    fn make(self) -> &'static BodyMake {
        // Every body-level entry of the registry holds a `BodyMake` (`registry::register`
        // checks it).
        body_make(self.0).unwrap_or(&NO_BODY_MAKE)
    }

    /// True for the solvers that apply joint (equality) rows with the contacts: `si` sweeps
    /// them as engines do, and the substepping solvers; the others resolve contacts only.
    pub fn takes_joints(self) -> bool {
        self.make().takes_joints
    }

    /// True for the substepping solvers, which move the bodies themselves
    /// ([`BodySolver::advance`]).
    pub fn substeps(self) -> bool {
        self.make().substeps
    }

    /// The solver with the parameters `params` (which follow [`BodySolverKind::param_specs`]).
    pub fn create_with(self, params: Params) -> Box<dyn BodySolver + Send> {
        (self.make().make)(&params)
    }

    /// The solver of a specification `name` or `name@key=value,…`, its parameters checked
    /// against the kind's table; `Ok(None)` when no body-level solver has that name.
    pub fn parse_spec(spec: &str) -> Result<Option<(Self, Params)>, String> {
        let (name, text) = spec.split_once('@').unwrap_or((spec, ""));
        let Some(kind) = Self::from_name(name) else {
            return Ok(None);
        };
        if spec.contains('@') && kind.param_specs().is_empty() {
            return Err(format!("solver `{name}` takes no parameters"));
        }
        let params = kind.0.parse_params(text)?;
        Ok(Some((kind, params)))
    }

    /// The solver with default parameters.
    pub fn create(self) -> Box<dyn BodySolver + Send> {
        self.create_with(self.0.defaults())
    }
}

/// What a handle to an entry without a [`BodyMake`] makes ([`BodySolverKind::for_entry`] of a
/// matrix or cone entry): a solver whose every sweep stalls, applying no impulse. Such an entry
/// is never a body-level solver of the registry ([`crate::registry::register`] refuses it);
/// this keeps the handle total.
static NO_BODY_MAKE: BodyMake = BodyMake {
    make: |_| Box::new(Unregistrable),
    takes_joints: false,
    substeps: false,
};

/// The stand-in of [`NO_BODY_MAKE`]: no impulse, a stall that says why.
#[derive(Debug, Clone, Copy)]
struct Unregistrable;

/// The entry [`Unregistrable`] names itself by (not in the registry).
static UNREGISTRABLE: SolverEntry = SolverEntry {
    name: "no-body-constructor",
    summary: "stand-in for a handle whose entry has no body-level constructor",
    problem_classes: "none",
    iteration_unit: "none",
    iterative: false,
    relaxation: None,
    params: &[],
    make: Make::Body(&NO_BODY_MAKE),
};

impl BodySolver for Unregistrable {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind(&UNREGISTRABLE)
    }
    fn sweep(&mut self, system: &ContactSystem, _settings: &Settings) -> BodySweep {
        let f = vec![0.0; system.n()];
        BodySweep {
            warm: f.clone(),
            f,
            iterations: 0,
            stopped: false,
            stalled: Some("the solver's registry entry has no body-level constructor".into()),
            timed_out: false,
        }
    }
}

/// The registry's entry of `si`.
pub static SI: SolverEntry = SolverEntry {
    name: "si",
    summary: "sequential impulses (Catto 2005): restitution sweeps, then projected Gauss-Seidel \
              on accumulated impulses, warm-started",
    problem_classes: "scenes only; frictionless and box friction (no pyramid, no cone), joints; \
                      sequential restitution then projected Gauss-Seidel on accumulated impulses (joint \
                      rows first, unclamped), warm-startable; slow on stiff stacks, mass ratios and \
                      long chains",
    iteration_unit: "sweeps over the contacts",
    iterative: true,
    relaxation: None,
    params: &[],
    make: Make::Body(&BodyMake {
        make: |_| Box::new(SequentialImpulses),
        takes_joints: true,
        substeps: false,
    }),
};

/// The registry's entry of `body-micro`.
pub static BODY_MICRO: SolverEntry = SolverEntry {
    name: "body-micro",
    summary: "micro-impulses (Mirtich 1996): every closing contact a collision, no impulse \
              taken back",
    problem_classes: "scenes only; frictionless and box friction (no pyramid, no cone), no joints; \
                      Mirtich micro-impulses, never takes an impulse back: resting contacts creep and jitter",
    iteration_unit: "sweeps over the contacts",
    iterative: true,
    relaxation: None,
    params: &[],
    make: Make::Body(&BodyMake {
        make: |_| Box::new(MicroImpulses),
        takes_joints: false,
        substeps: false,
    }),
};

/// The registry's entry of `penalty` (its spring is set in the scene's `[penalty]` table,
/// which [`crate::scene::Scene`] applies; the entry makes the default spring).
pub static PENALTY: SolverEntry = SolverEntry {
    name: "penalty",
    summary: "spring-damper penalty forces: one Jacobi pass, does not solve the LCP",
    problem_classes: "scenes only; frictionless and box friction (no pyramid, no cone), no joints; \
                      spring-damper baseline, one Jacobi pass: does not solve the LCP (large residual), no restitution",
    iteration_unit: "passes (always 1)",
    iterative: false,
    relaxation: Some(
        "a soft spring-damper penalty model (forces from penetration depth and closing \
         speed, one Jacobi pass), not the rigid LCP",
    ),
    params: &[],
    make: Make::Body(&BodyMake {
        make: |_| Box::new(Penalty::default()),
        takes_joints: false,
        substeps: false,
    }),
};

/// What a body-level solver's own loop returns, before the status is decided.
#[derive(Debug, Clone, PartialEq)]
pub struct BodySweep {
    /// Total impulse per row of the system.
    pub f: Vec<f64>,
    /// The part of `f` to keep for warm starting the next step.
    pub warm: Vec<f64>,
    /// Sweeps used.
    pub iterations: usize,
    /// True when the solver's own stopping rule was met.
    pub stopped: bool,
    /// Why the sweeps stopped short of that rule, when they made no progress
    /// ([`Stagnation`]).
    pub stalled: Option<String>,
    /// True when the sweeps stopped at the end of `settings.time_budget`.
    pub timed_out: bool,
}

/// What [`BodySolver::solve`] returns: the shared [`SolveResult`] and the warm-start part.
#[derive(Debug, Clone, PartialEq)]
pub struct BodySolveResult {
    /// Impulse, status, sweeps and time. `residuals` and `w` are those of the LCP the result
    /// was measured on; when none was given, `residuals` is [`Residuals::INFINITE`] and `w`
    /// is empty.
    pub result: SolveResult,
    /// The part of `f` to keep for warm starting the next step.
    pub warm: Vec<f64>,
}

/// The LCP a body-level result is measured on.
#[derive(Debug, Clone, Copy)]
pub enum Measure<'a> {
    /// The step's assembled LCP: the shared residual decides the status.
    Lcp(&'a Problem),
    /// Not measured: convergence cannot be claimed.
    Skip,
    /// The contact system could not be assembled (why): a numerical failure.
    Invalid(&'a str),
}

/// A contact solver that works on bodies through the [`DelassusOperator`] (matrix-free).
///
/// Every body-level solver is `Clone` (through [`dyn_clone::DynClone`]). None keeps a workspace
/// but the substepping solvers with `colour=1`, which remember the previous step's constraint
/// colours ([`crate::substep::colouring`]); otherwise a clone answers exactly as a fresh solver
/// of the same parameters.
pub trait BodySolver: dyn_clone::DynClone {
    /// Which solver of the catalogue this is.
    fn kind(&self) -> BodySolverKind;

    /// The solver's own loop on the step's system; `settings.warm_start` is the warm start.
    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep;

    /// Short name (`si`, `body-micro`, `penalty`, `avg`, …).
    fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// The solver's parameters (empty for a solver that takes none).
    fn params(&self) -> Params {
        Params::defaults(self.kind().param_specs())
    }

    /// For a substepping solver ([`crate::substep`]), which moves the bodies itself: the
    /// whole step, from the system at the step's start. `None` for the solvers that return
    /// impulses only (the stepper then applies them and integrates once).
    fn advance(&mut self, _input: &SubstepInput<'_>) -> Option<SubstepOutcome> {
        None
    }

    /// Solve and decide the status from the shared residual of `measure` ([`body_status`]),
    /// then, for a converged result, by the matrix solvers' data-resolution test
    /// ([`judge`]).
    fn solve(
        &mut self,
        system: &ContactSystem,
        settings: &Settings,
        measure: Measure<'_>,
    ) -> BodySolveResult {
        let start = Instant::now();
        let out = self.sweep(system, settings);
        let time = start.elapsed();
        let (w, residuals) = match measure {
            Measure::Lcp(p) => {
                let mut w = vec![0.0; p.n()];
                let r = residuals_and_velocity(p, &out.f, &mut w);
                (w, Some(r))
            }
            Measure::Skip | Measure::Invalid(_) => (Vec::new(), None),
        };
        let (invalid, problem) = match measure {
            Measure::Invalid(e) => (Some(e), None),
            Measure::Lcp(p) => (None, Some(p)),
            Measure::Skip => (None, None),
        };
        let status = body_status(self.name(), &out, residuals.as_ref(), invalid, settings);
        // A converged result faces the data-resolution test of the matrix solvers too.
        let (status, certificate) = match (status, problem, residuals.as_ref()) {
            (Status::Converged, Some(p), Some(r)) => {
                judge(p, &out.f, &w, r, Outcome::Stopped, settings.tolerance)
            }
            (status, ..) => (status, None),
        };
        BodySolveResult {
            result: SolveResult {
                f: out.f,
                w,
                status,
                iterations: out.iterations,
                time,
                residuals: residuals.unwrap_or(Residuals::INFINITE),
                history: Vec::new(),
                active_sets: Vec::new(),
                certificate,
            },
            warm: out.warm,
        }
    }
}

dyn_clone::clone_trait_object!(BodySolver);

impl std::fmt::Debug for dyn BodySolver + Send {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The status of a body-level result: a system that could not be assembled, a non-finite
/// impulse or a non-finite residual are numerical failures; otherwise the shared rule
/// ([`decide`]) on the relative residual (NaN when not measured, so never `Converged`), with
/// the solver's own stop as a stall that says at which residual it stopped.
pub fn body_status(
    name: &str,
    out: &BodySweep,
    residuals: Option<&Residuals>,
    invalid: Option<&str>,
    settings: &Settings,
) -> Status {
    if let Some(e) = invalid {
        return Status::NumericalFailure {
            reason: format!("contact system is invalid: {e}"),
        };
    }
    if let Some(reason) = non_finite_reason(&out.f, "impulse", "f") {
        return Status::NumericalFailure { reason };
    }
    let rel = residuals.map_or(f64::NAN, |r| r.natural_map_rel);
    if residuals.is_some() && !rel.is_finite() {
        return Status::NumericalFailure {
            reason: format!("the residual of the step's LCP is not finite ({rel})"),
        };
    }
    let soft = BodySolverKind::from_name(name).and_then(BodySolverKind::relaxation);
    let outcome = match (out.stopped, residuals) {
        (false, _) if out.timed_out => Outcome::TimeLimit,
        // A soft model is a different problem: the reason names it and its residual on the
        // step's LCP (the status stays `Stalled` unless that residual meets the tolerance).
        (true, None) if soft.is_some() => Outcome::Stalled(format!(
            "{name} solved {}, not the step's LCP; the shared residual was not measured",
            soft.unwrap_or_default()
        )),
        (true, Some(_)) if soft.is_some() => Outcome::Stalled(format!(
            "{name} solved {}, not the step's LCP: relative residual on the step's LCP {rel:.3e} \
             > tolerance {:.1e}",
            soft.unwrap_or_default(),
            settings.tolerance
        )),
        (false, _) if out.stalled.is_some() => {
            Outcome::Stalled(out.stalled.clone().unwrap_or_default())
        }
        (false, _) => Outcome::IterationLimit,
        (true, None) => Outcome::Stalled(format!(
            "{name} met its own stopping rule; the shared residual was not measured"
        )),
        (true, Some(_)) => Outcome::Stalled(format!(
            "{name} stopped at relative residual {rel:.3e} of the step's LCP"
        )),
    };
    decide(outcome, rel, settings.tolerance)
}

/// Sequential impulses (`si`). No parameters beyond the shared [`Settings`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SequentialImpulses;

impl BodySolver for SequentialImpulses {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::SequentialImpulses
    }
    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
        let warm = settings.warm_start.as_deref().unwrap_or(&[]);
        sequential_impulses(system, warm, settings)
    }
}

/// Micro-impulses (`body-micro`). No parameters beyond the shared [`Settings`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MicroImpulses;

impl BodySolver for MicroImpulses {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::MicroImpulses
    }
    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
        micro_impulses(system, settings)
    }
}

/// Spring–damper penalty (`penalty`). Defaults in brackets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Penalty {
    /// `ω h`, the spring's natural frequency times the step \[`0.3`\].
    pub omega_h: f64,
    /// Fixed stiffness in N/m instead of `m_eff ω²` \[`None`\].
    pub stiffness: Option<f64>,
    /// Damping ratio `ζ` \[`0.7`\].
    pub damping_ratio: f64,
}

impl Default for Penalty {
    fn default() -> Self {
        Self {
            omega_h: 0.3,
            stiffness: None,
            damping_ratio: 0.7,
        }
    }
}

impl BodySolver for Penalty {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::Penalty
    }
    fn sweep(&mut self, system: &ContactSystem, _settings: &Settings) -> BodySweep {
        let f = penalty(system, self);
        BodySweep {
            warm: f.clone(),
            f,
            iterations: 1,
            stopped: true,
            stalled: None,
            timed_out: false,
        }
    }
}

/// Solve the step's contact system with the body-level solver `kind` (default parameters),
/// without measuring the shared residual; `warm` is the warm start (empty for none).
pub fn solve(
    kind: BodySolverKind,
    system: &ContactSystem,
    warm: &[f64],
    settings: &Settings,
) -> BodySweep {
    let settings = Settings {
        warm_start: (!warm.is_empty()).then(|| warm.to_vec()),
        ..settings.clone()
    };
    kind.create().sweep(system, &settings)
}

fn diagonals(op: &DelassusOperator<'_>, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let d = op.diagonal(i);
            if d > 0.0 {
                d
            } else {
                f64::INFINITY
            }
        })
        .collect()
}

/// The restitution phase shared by `si`: sequential Newton collisions until nothing bounces.
/// Returns the number of sweeps.
fn restitution_phase(
    system: &ContactSystem,
    op: &DelassusOperator<'_>,
    k: &[f64],
    u: &mut [BodyVelocity],
    f: &mut [f64],
    settings: &Settings,
) -> usize {
    let bouncy: Vec<usize> = (0..system.contacts.len())
        .filter(|&c| system.info[c].restitution > 0.0)
        .collect();
    if bouncy.is_empty() {
        return 0;
    }
    let h = system.h;
    for sweep in 1..=settings.max_iterations.max(1) {
        let mut any = false;
        for &c in &bouncy {
            let i = system.info[c].normal_row;
            let vn = op.row_dot(i, u);
            let dist = system.contacts[c].dist;
            let e = system.info[c].restitution;
            if bounces(dist, vn, e, system.restitution_threshold, h) {
                let d = -(1.0 + e) * vn / k[i];
                op.apply_row(i, d, u);
                f[i] += d;
                any = true;
            }
        }
        if !any {
            return sweep;
        }
    }
    settings.max_iterations
}

fn sequential_impulses(system: &ContactSystem, warm: &[f64], settings: &Settings) -> BodySweep {
    let deadline = settings.time_budget.map(|b| Instant::now() + b);
    let n = system.n();
    let op = system.operator();
    let k = diagonals(&op, n);
    let mut u = system.free_velocity.clone();
    let mut f_rest = vec![0.0; n];
    let mut sweeps = restitution_phase(system, &op, &k, &mut u, &mut f_rest, settings);

    // Contact-phase bias: the builder's bias without the restitution term.
    let mut bias = system.bias.clone();
    for info in &system.info {
        if info.bouncing {
            bias[info.normal_row] = 0.0;
        }
    }
    // Warm start, projected onto the bounds.
    let mut lambda = vec![0.0; n];
    if warm.len() == n {
        for info in &system.info {
            let i = info.normal_row;
            lambda[i] = warm[i].max(0.0);
            for r in info.friction_rows.clone() {
                let c = info.mu * lambda[i];
                lambda[r] = warm[r].clamp(-c, c);
            }
        }
        for j in &system.joints {
            for r in j.rows.clone() {
                lambda[r] = warm[r];
            }
        }
        op.add_response(&lambda, &mut u);
    }
    let scale_b = (0..n)
        .map(|i| ((system.free_rate[i] + bias[i]) / k[i]).abs())
        .fold(0.0, f64::max);
    let mut stopped = false;
    let mut stalled = None;
    let mut timed_out = false;
    let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
    let mut iterations = 0;
    while iterations < settings.max_iterations {
        iterations += 1;
        let mut max_change: f64 = 0.0;
        // Joints first, as engines order them: equality rows, no clamping.
        for r in system.joint_rows_start()..n {
            let w = op.row_dot(r, &u) + bias[r];
            let d = -w / k[r];
            if d.is_finite() && d != 0.0 {
                op.apply_row(r, d, &mut u);
                lambda[r] += d;
                max_change = max_change.max(d.abs());
            }
        }
        for info in &system.info {
            let i = info.normal_row;
            let w = op.row_dot(i, &u) + bias[i];
            let new = (lambda[i] - w / k[i]).max(0.0);
            let d = new - lambda[i];
            if d != 0.0 {
                op.apply_row(i, d, &mut u);
                lambda[i] = new;
            }
            max_change = max_change.max(d.abs());
            let bound = info.mu * lambda[i];
            for r in info.friction_rows.clone() {
                let w = op.row_dot(r, &u);
                let new = (lambda[r] - w / k[r]).clamp(-bound, bound);
                let d = new - lambda[r];
                if d != 0.0 {
                    op.apply_row(r, d, &mut u);
                    lambda[r] = new;
                }
                max_change = max_change.max(d.abs());
            }
        }
        let scale = lambda
            .iter()
            .fold(scale_b, |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        if max_change <= settings.tolerance * scale {
            stopped = true;
            break;
        }
        if stagnation.stagnated(iterations, max_change / scale) {
            stalled = Some(stagnation.reason("relative impulse change of a sweep"));
            break;
        }
        if deadline.is_some_and(|d| Instant::now() >= d) {
            timed_out = true;
            break;
        }
    }
    sweeps += iterations;
    BodySweep {
        f: f_rest.iter().zip(&lambda).map(|(a, b)| a + b).collect(),
        warm: lambda,
        iterations: sweeps,
        stopped,
        stalled,
        timed_out,
    }
}

fn micro_impulses(system: &ContactSystem, settings: &Settings) -> BodySweep {
    let deadline = settings.time_budget.map(|b| Instant::now() + b);
    let n = system.n();
    let op = system.operator();
    let k = diagonals(&op, n);
    let mut u = system.free_velocity.clone();
    let mut f = vec![0.0; n];
    let h = system.h;
    // Inverse tangent blocks for the sticking impulse of each contact.
    let tangent_inv: Vec<Option<Matrix2<f64>>> = system
        .info
        .iter()
        .map(|info| {
            let r = info.friction_rows.clone();
            if r.len() != 2 {
                return None;
            }
            let (a, b) = (r.start, r.start + 1);
            Matrix2::new(
                op.entry(a, a),
                op.entry(a, b),
                op.entry(b, a),
                op.entry(b, b),
            )
            .try_inverse()
        })
        .collect();
    let scale_b = (0..n)
        .map(|i| ((system.free_rate[i] + system.bias[i]) / k[i]).abs())
        .fold(0.0, f64::max);
    let mut iterations = 0;
    let mut stopped = false;
    let mut stalled = None;
    let mut timed_out = false;
    let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
    while iterations < settings.max_iterations {
        iterations += 1;
        let mut max_impulse: f64 = 0.0;
        for (c, info) in system.info.iter().enumerate() {
            let i = info.normal_row;
            let vn = op.row_dot(i, &u);
            let dist = system.contacts[c].dist;
            let target = if bounces(dist, vn, info.restitution, system.restitution_threshold, h) {
                -info.restitution * vn
            } else if info.bouncing {
                0.0
            } else {
                -system.bias[i]
            };
            if vn >= target {
                continue;
            }
            let jn = (target - vn) / k[i];
            op.apply_row(i, jn, &mut u);
            f[i] += jn;
            max_impulse = max_impulse.max(jn);
            if let Some(kinv) = tangent_inv[c] {
                let (a, b) = (info.friction_rows.start, info.friction_rows.start + 1);
                let vt = Vector2::new(op.row_dot(a, &u), op.row_dot(b, &u));
                let mut jt = -(kinv * vt);
                let cap = info.mu * jn;
                let norm = jt.norm();
                if norm > cap {
                    jt *= cap / norm;
                }
                op.apply_row(a, jt.x, &mut u);
                op.apply_row(b, jt.y, &mut u);
                f[a] += jt.x;
                f[b] += jt.y;
            }
        }
        let scale = f
            .iter()
            .fold(scale_b, |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        if max_impulse <= settings.tolerance * scale {
            stopped = true;
            break;
        }
        if stagnation.stagnated(iterations, max_impulse / scale) {
            stalled = Some(stagnation.reason("relative impulse of a sweep"));
            break;
        }
        if deadline.is_some_and(|d| Instant::now() >= d) {
            timed_out = true;
            break;
        }
    }
    BodySweep {
        f: f.clone(),
        warm: f,
        iterations,
        stopped,
        stalled,
        timed_out,
    }
}

fn penalty(system: &ContactSystem, params: &Penalty) -> Vec<f64> {
    let n = system.n();
    let op = system.operator();
    let u = &system.free_velocity;
    let h = system.h;
    let mut f = vec![0.0; n];
    let omega = params.omega_h / h;
    for (c, info) in system.info.iter().enumerate() {
        let dist = system.contacts[c].dist;
        if dist >= 0.0 {
            continue;
        }
        let i = info.normal_row;
        let knn = op.diagonal(i);
        if knn <= 0.0 {
            continue;
        }
        let m_eff = 1.0 / knn;
        let (stiffness, damping) = match params.stiffness {
            Some(s) => (s, 2.0 * params.damping_ratio * (s * m_eff).sqrt()),
            None => (
                m_eff * omega * omega,
                2.0 * params.damping_ratio * m_eff * omega,
            ),
        };
        let vn = op.row_dot(i, u);
        let jn = h * (stiffness * -dist - damping * vn).max(0.0);
        f[i] = jn;
        let rows: Vec<usize> = info.friction_rows.clone().collect();
        if rows.is_empty() {
            continue;
        }
        let mut jt: Vec<f64> = rows
            .iter()
            .map(|&r| -op.row_dot(r, u) / op.diagonal(r).max(f64::MIN_POSITIVE))
            .collect();
        let norm = jt.iter().map(|x| x * x).sum::<f64>().sqrt();
        let cap = info.mu * jn;
        if norm > cap {
            jt.iter_mut().for_each(|x| *x *= cap / norm);
        }
        for (&r, v) in rows.iter().zip(jt) {
            f[r] = v;
        }
    }
    f
}

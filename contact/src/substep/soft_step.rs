//! `soft-step`: substeps with soft contacts and joints, a relax pass and a restitution pass
//! (Box2D v3's soft step, Catto, "Solver2D", 2024; Rapier's TGS-soft is the same scheme).
//!
//! Source: Box2D v3.1 (`src/solver.c`: `b2SolverTask` and its stages
//! `b2_stageIntegrateVelocities`, `b2_stageWarmStart`, `b2_stageSolve`,
//! `b2_stageIntegratePositions`, `b2_stageRelax`, `b2_stageRestitution`,
//! `b2_stageStoreImpulses`; `src/contact_solver.c`: `b2PrepareOverflowContacts`,
//! `b2WarmStartOverflowContacts`, `b2SolveOverflowContacts`, `b2ApplyOverflowRestitution`;
//! `src/world.c`: `b2World_Step`, which makes the softness of the substep; joints in
//! `src/joint.c`, `b2SolveJoint`, with `useBias`). The code here is lcpbench's own, on the rows
//! of [`SolverState`].
//!
//! # The loop
//!
//! With `h = dt / substeps`, for each substep:
//!
//! 1. integrate velocities: `v += h g` (dynamic bodies);
//! 2. warm start: apply every row's accumulated impulse `λ` (from the previous substep; the
//!    first substep from the previous step's stored impulses, `settings.warm_start`);
//! 3. solve with bias, `iterations` sweeps, joint rows first, then each contact's normal row
//!    and its friction rows. A row's position error `s = C₀ + J Δx` (its gap for a normal
//!    row) gives the velocity bias:
//!    * normal row, `s > 0` (a speculative contact, still apart): `bias = s / h`, rigid
//!      (`mass_scale = 1`, `impulse_scale = 0`): the contact may close the gap in the
//!      substep, no more;
//!    * normal row, `s ≤ 0`: the soft contact of [`Softness::new`]`(hertz, zeta, h)`,
//!      `bias = max(bias_rate · s, −push_out)`; a contact with a static body takes
//!      `static_scale · hertz`;
//!    * joint row: the soft joint of `(joint_hertz, joint_zeta)`, `bias = bias_rate · C`;
//!    * friction row: rigid, the accumulated impulse clamped to `±μ λ_n` of its normal row;
//!      no bias (Box2D), or with `friction_anchor = a > 0` the bias `a · s / h`, `s` the
//!      tangential slip of the contact points since the step's start (Rapier 0.36,
//!      `ContactWithCoulombFrictionBuilder::update`: the tangent `rhs` is
//!      `rhs_wo_bias + (p1 − p2)·t / dt`, the anchors `p1`, `p2` fixed on each body).
//!
//!    The rows are swept joint rows first, then contact by contact (normal row, then its
//!    friction rows: Box2D's `b2SolveContact`); `normals_first = 1` takes each manifold
//!    (consecutive contacts between the same two bodies) normal rows first, then its friction
//!    rows (Rapier's `ContactWithCoulombFriction::solve`), and `block_pairs = 1` solves a
//!    manifold's normal rows two by two as a compliant 2×2 LCP (Rapier's `block-solver`
//!    feature, `ContactConstraintNormalPart::solve_mlcp_two_constraints`; see [`solve_pair`]).
//!    `colour = 1` sweeps the constraints (a joint's rows, the contacts between two bodies)
//!    colour by colour instead, the overflow set first and each colour's constraints in
//!    parallel, each constraint's rows in the order above (Box2D v3's `b2_stageSolve` over
//!    its graph colours; [`super::constraint_rows`]): a different Gauss–Seidel order, with
//!    results that do not depend on the number of threads. The warm start goes colour by
//!    colour too; the restitution pass stays serial (in the order above).
//!
//!    The impulse of a row is `Δλ = −m · mass_scale · (J v + bias) − impulse_scale · λ`
//!    (`m = 1 / (J M⁻¹ Jᵀ)`), clamped on the accumulated impulse (`λ ≥ 0` for normal rows);
//! 4. integrate positions: `Δx += h v`;
//! 5. relax, `relax_iterations` sweeps in the same order with the rigid rows
//!    ([`Softness::RIGID`]) and no position bias but the speculative `s / h` of an open
//!    contact: it takes out the velocity the soft bias added (Box2D's `useBias = false`).
//!
//! After the substeps, one restitution pass: a normal row with restitution `e > 0` whose
//! normal velocity at the step's start (before gravity) was `approach < −threshold`
//! ([`crate::builder::ContactSystem::restitution_threshold`]) and that carried a positive
//! accumulated impulse in some solve of the step gets `Δλ = −m (J v + e · approach)`, the
//! accumulated impulse clamped `≥ 0` (`b2ApplyOverflowRestitution`). The impulses then stored
//! for the next step's warm start are the accumulated ones of the last substep, restitution
//! included (`b2_stageStoreImpulses`).
//!
//! Box2D lowers the stiffness for large substeps (`b2World_Step`): the contact hertz is at
//! most a quarter of the substep rate and the joint hertz at most an eighth. This solver caps
//! the contact hertz likewise (`hertz ≤ 0.25 / h`, before `static_scale`) and the joint hertz
//! at `joint_cap / h`.
//!
//! # Joints: the default and Box2D's
//!
//! The default joints are Rapier's near-rigid ones (`SpringCoefficients::joint_defaults`:
//! 1e6 Hz) held to a quarter of the substep rate (`joint_cap = 0.25`), with Box2D's damping
//! ratio 2: at 4 substeps of a 60 Hz step that is 60 Hz, at 20 substeps 300 Hz, so a loaded
//! joint stretches less as the substeps grow (`F / (m ω²)`, `ω ∝ 1 / h`). Box2D's joints are
//! `joint_hertz=60,joint_cap=0.125`. Rapier's own rows (erp ≈ 1, cfm ≈ 0: a full `C / h`
//! bias on a rigid row) are `joint_cap=0` with the default `joint_hertz`; with one sweep per
//! substep they blow up on `chain_20_1e3` (below). Measured on `chain_20_1e3` (20 links of
//! 1 kg, 1000 kg end mass, 60 Hz steps, warm started, largest joint drift over the run):
//!
//! | joints | 4 substeps | 8 | 20 | 40 |
//! | --- | --- | --- | --- | --- |
//! | default (cap 0.25 / h, ζ = 2) | 0.275 m | 6.9 cm | 1.1 cm | 2.7 mm |
//! | Box2D (60 Hz, cap 0.125 / h) | 0.71 m | | 0.27 m | |
//! | 1e6 Hz, no cap (Rapier's rows) | 273 m (unstable) | | 1e8 m (unstable) | |
//! | Rapier 0.36 itself (reported) | 0.68 m | | 2.7 cm | |
//!
//! Without a cap, at 4 substeps (`h = 1/240`) 120 Hz drifts 2–4 m and 240 Hz blows up; at 20
//! substeps (`h = 1/1200`) 240 Hz holds (1.7 cm), 480 Hz holds with ζ = 2 (5.8 mm) and not
//! with ζ = 1, 1000 Hz blows up: one Gauss–Seidel sweep per substep keeps a joint path with a
//! 1000 : 1 mass ratio only up to about a quarter to a half of the substep rate.
//!
//! # Parameters (`soft-step@key=value,…`)
//!
//! | key | default | source |
//! | --- | --- | --- |
//! | `substeps` | 4 | Box2D v3: `b2World_Step(world, dt, subStepCount)`, 4 in its samples |
//! | `iterations` | 1 | Box2D v3: one biased sweep per substep (`ITERATIONS`) |
//! | `relax_iterations` | 1 | Box2D v3: one relax sweep per substep (`RELAX_ITERATIONS`) |
//! | `hertz` | 30 | `b2DefaultWorldDef`: `contactHertz` |
//! | `zeta` | 10 | `b2DefaultWorldDef`: `contactDampingRatio` |
//! | `static_scale` | 2 | `b2World_Step`: `staticSoftness = b2MakeSoft(2 · contactHertz, …)` |
//! | `joint_hertz` | 1e6 | Rapier: `SpringCoefficients::joint_defaults` (Box2D: 60, `jointHertz`) |
//! | `joint_zeta` | 2 | `b2DefaultWorldDef`: `jointDampingRatio` (v3.0, v3.1; Rapier: 1) |
//! | `push_out` | 3 m/s | `b2DefaultWorldDef`: `maxContactPushSpeed` (v3.1; `contactPushoutVelocity` in v3.0) |
//! | `joint_cap` | 0.25 | joint hertz at most `joint_cap / h` (Box2D `b2World_Step`: 0.125; 0: none) |
//! | `friction_anchor` | 0 | friction rows' slip bias factor (Box2D: none; Rapier builds it but, with `friction_in_bias_pass` off by default, does not use it) |
//! | `normals_first` | 0 | 1: a manifold's normal rows before its friction rows (Rapier) |
//! | `block_pairs` | 0 | 1: normal rows two by two as 2×2 blocks (Rapier's `block-solver`) |
//! | `colour` | 0 | 1: coloured sweeps, each colour's constraints in parallel (Box2D v3's graph colouring; [`super::constraint_rows`]) |
//!
//! `hertz = 0` makes the contacts rigid with no position feedback (only the speculative bias);
//! `joint_hertz = 0` the joints likewise.
//!
//! # What it does not solve
//!
//! It does not solve the step's LCP: its contacts and joints are damped springs (a soft joint
//! of stiffness `m ω²` carrying a load `F` stretches by `F / (m ω²)` at rest, a soft contact
//! sinks likewise until the push-out bias holds it), its friction is the box model swept once
//! per pass, and one relax sweep per substep leaves whatever Gauss–Seidel residual one sweep
//! leaves. [`crate::BodySolverKind::relaxation`] says so, and the stepper measures the shared
//! residual of the **last solve**: the relax pass of the last substep, a rigid pass on the
//! LCP `w = A λ + b`, `b = J v` (the velocities after that substep's velocity integration,
//! before its warm start) `+` the speculative bias `max(s, 0) / h`, `λ` the substep's
//! accumulated impulse after the pass (the pass sweeps on `λ`, so its LCP is the substep's
//! whole impulse, not the pass's increment). `w` is then the post-relax normal velocity plus
//! the speculative bias. The restitution pass after it is not part of that LCP.
//!
//! # Failure modes (observed)
//!
//! * Soft joints stretch under load by `F / (m ω²)`: the table above.
//! * Soft contacts make a stack a column of rotational springs, which buckles when the weight
//!   above a contact times its height exceeds the springs' rotational stiffness
//!   (`Σ m ω² y²` over its points): `tower_40_60hz` sags 0.44 m in its first 2 s at 30 Hz
//!   (the static deflection; Rapier 0.36 with the same softness: 0.434 m), then leans and
//!   falls after about 4 s (lateral drift of the top 0.049 m at 2 s, 0.79 m at 4 s); with
//!   `substeps=20,hertz=300` it stands. Rapier's tower stands at 4 substeps; its friction
//!   anchors and block pairs (`friction_anchor=1,block_pairs=1`) slow the lean here (0.027 m
//!   at 2 s, 0.30 m at 4 s) but the tower still falls, so they are not the default. More
//!   sweeps do not save it either (`iterations=4,relax_iterations=4` falls; rigid contacts,
//!   `hertz=0`, fall). `tower_10` stands, leaning about 1 cm in 2 s.
//!
//!   The springs' figures put `tower_40_60hz` past the static limit: a corner row of two
//!   unit boxes of 1000 kg has `m = 125 kg` (`1/m = 2 (1/1000 + 0.5 / 166.7)`), a stiffness
//!   `m ω² = 4.4e6 N/m` at 30 Hz; four of them hold 1.8e7 N/m vertically (the 0.434 m sag of
//!   the tower is `Σ_k k · 9810 / 1.8e7` over its 39 box-box contacts) and resist a tilt with
//!   `Σ k x² = 4.4e6 N·m/rad`, while the 38 boxes above the second contact (3.7e5 N, centre
//!   of mass 19 m above it) overturn it with 7.1e6 N·m/rad. That is not the whole story: a
//!   20-box tower at 60 Hz steps (1.6e6 N·m/rad against the same 4.4e6) also leans and falls
//!   under the defaults (top 0.02 m off at 2 s, 0.16 m at 6 s, 2 m at 10 s), and at
//!   `hertz=60` it stands (1.3 cm at 10 s); none of `relax_iterations=0`, `zeta` 1 or 30,
//!   `static_scale=1`, `push_out=0.1`, `normals_first`, `friction_anchor=1`, `block_pairs=1`
//!   keeps it up (0.95–3.7 m at 10 s; the last two lean least).
//!
//!   What differs in Rapier (read in dimforge/rapier 0.35, where it first appears; not yet
//!   measured here): with `contact_recycling` (on by default) a pair whose relative pose moved
//!   less than 0.05 m and whose bodies turned less than about 11.5° skips the narrow phase,
//!   and its world normal and lever arms (`solver_dp1`, `solver_dp2`) stay those of the last
//!   full update; only the gap is recomputed from body-fixed anchors. The rows here are
//!   rebuilt from the current poses every step, so the weight carried through a face adds an
//!   overturning torque of about `W · (h/2) · θ` per face as the boxes tilt (the P-Δ term of
//!   a column), which a frozen Jacobian leaves out. A linear-tilt estimate of that term
//!   against the springs' rotational stiffness puts the 20- and 40-box towers past the limit
//!   at 30 Hz and the 10-box tower inside it, as observed, and it does not depend on the
//!   substeps, sweeps, `zeta` or the step. Frozen lever arms are a modelling choice (the
//!   contact forces then do not do the work the true motion implies), not a better solve.
//! * One sweep per pass leaves an order-dependent distribution of impulses over the four
//!   coplanar points of a face: a small torque that leans stacks (above).
//!
//! # Cost
//!
//! Per substep: two body passes (velocity and position integration) and, per sweep, one row
//! update for each swept row; the warm start counts one row update per row it applies. The
//! swept rows are laid out once per step in sweep order, compact, into buffers the solver
//! keeps between steps ([`super::constraint_rows`]); each row's bias and softness are
//! computed in the sweep from its position error. The per-row results in the system's order
//! (impulses, saved velocities) are allocated once per step; the substep loop allocates
//! nothing. With `colour = 1` the step also colours its constraints and lays the rows out
//! colour by colour (linear in the rows, once per step); a sweep writes the bodies in place
//! and counts the same row updates as the serial one.

use super::coloured_sweep::ColouredSweep;
use super::colouring::ConstraintGraph;
use super::constraint_rows::{
    ConstraintRow, ConstraintRows, Kind, RowCoefficients, SweepRule, RIGID_ROW,
};
use super::params::{ParamSpec, Params};
use super::softness::{self, Softness};
use super::state::{RowRole, SolverBody, SolverRow, SolverState, StepCost};
use super::{LastSolve, SubstepInput, SubstepOutcome};
use crate::body_solvers::{BodySolver, BodySolverKind, BodySweep};
use crate::builder::ContactSystem;
use lcpbench_solvers::Settings;
use nalgebra::Vector3;
use std::time::Instant;

/// The parameters of `soft-step`, with Box2D v3's defaults.
pub const SOFT_STEP_PARAMS: &[ParamSpec] = &[
    ParamSpec::count("substeps", 4, 1, 1024, "substeps per step"),
    ParamSpec::count("iterations", 1, 1, 1000, "biased (soft) sweeps per substep"),
    ParamSpec::count(
        "relax_iterations",
        1,
        0,
        1000,
        "rigid sweeps without position bias per substep, after the position update",
    ),
    ParamSpec::real(
        "hertz",
        softness::CONTACT_HERTZ,
        0.0,
        1e6,
        "contact stiffness, Hz (0: rigid, no position feedback)",
    ),
    ParamSpec::real(
        "zeta",
        softness::CONTACT_ZETA,
        0.0,
        1e6,
        "contact damping ratio",
    ),
    ParamSpec::real(
        "static_scale",
        2.0,
        0.0,
        1e3,
        "stiffness factor of contacts with a static body",
    ),
    ParamSpec::real(
        "joint_hertz",
        JOINT_HERTZ,
        0.0,
        1e6,
        "joint stiffness, Hz, before the joint_cap (0: rigid, no position feedback)",
    ),
    ParamSpec::real(
        "joint_zeta",
        softness::JOINT_ZETA,
        0.0,
        1e6,
        "joint damping ratio",
    ),
    ParamSpec::real(
        "push_out",
        softness::PUSH_OUT,
        0.0,
        1e6,
        "largest separating speed the contact position bias asks for, m/s",
    ),
    ParamSpec::real(
        "joint_cap",
        JOINT_CAP,
        0.0,
        1e6,
        "joint hertz at most joint_cap / h (Box2D: 0.125; 0: no cap)",
    ),
    ParamSpec::real(
        "friction_anchor",
        FRICTION_ANCHOR,
        0.0,
        1e3,
        "friction rows' position bias: factor on (tangential slip since the step's start) / h (0: none)",
    ),
    ParamSpec::count(
        "normals_first",
        0,
        0,
        1,
        "1: each manifold's normal rows before its friction rows (0: contact by contact)",
    ),
    ParamSpec::count(
        "block_pairs",
        0,
        0,
        1,
        "1: a manifold's normal rows solved two by two as 2x2 blocks (implies normals_first)",
    ),
    COLOUR_PARAM,
];

/// The `colour` key of `soft-step`, `tgs` and `pgs-ngs` (see [`super::constraint_rows`] and
/// [`super::coloured_sweep`]).
pub const COLOUR_PARAM: ParamSpec = ParamSpec::count(
    "colour",
    0,
    0,
    1,
    "1: sweep the constraints colour by colour, each colour's in parallel (0: serial order)",
);

/// Default of `joint_hertz`: Rapier's `SpringCoefficients::joint_defaults` (1e6 Hz, near
/// rigid); with [`JOINT_CAP`] the joints run at a quarter of the substep rate.
pub const JOINT_HERTZ: f64 = 1e6;
/// Default of `joint_cap`: a quarter of the substep rate, the largest joint stiffness that
/// held `chain_20_1e3` at one sweep per substep (Box2D caps its joints at 0.125).
pub const JOINT_CAP: f64 = 0.25;
/// Default of `friction_anchor`.
pub const FRICTION_ANCHOR: f64 = 0.0;

/// The `soft-step` solver: its parameters ([`SOFT_STEP_PARAMS`]) and its workspace (the
/// rows' layout, for `colour=1` the colouring of the previous step's constraints).
#[derive(Debug, Clone, PartialEq)]
pub struct SoftStep {
    params: Params,
    workspace: Workspace,
}

/// What a substepping solver keeps between steps: the buffers of the rows' layout
/// ([`ConstraintRows`]) and the colouring's memory of the previous step.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Workspace {
    graph: ConstraintGraph,
    rows: ConstraintRows,
}

impl SoftStep {
    /// The solver with `params` (which follow [`SOFT_STEP_PARAMS`]).
    pub fn new(params: Params) -> Self {
        Self {
            params,
            workspace: Workspace::default(),
        }
    }

    /// The scheme the parameters describe over a step of `dt`.
    fn scheme(&self) -> Scheme {
        let p = &self.params;
        Scheme {
            substeps: p.count("substeps"),
            iterations: p.count("iterations"),
            relax_iterations: p.count("relax_iterations"),
            bias: BiasRule::Soft {
                hertz: p.get("hertz"),
                zeta: p.get("zeta"),
                static_scale: p.get("static_scale"),
                joint_hertz: p.get("joint_hertz"),
                joint_zeta: p.get("joint_zeta"),
                push_out: p.get("push_out"),
                box2d_caps: true,
                joint_cap: p.get("joint_cap"),
                friction_anchor: p.get("friction_anchor"),
            },
            normals_first: p.count("normals_first") > 0,
            block_pairs: p.count("block_pairs") > 0,
            colour: p.count("colour") > 0,
        }
    }
}

impl Default for SoftStep {
    fn default() -> Self {
        Self::new(Params::defaults(SOFT_STEP_PARAMS))
    }
}

/// The registry's entry of `soft-step`.
pub static SOFT_STEP: lcpbench_solvers::registry::SolverEntry =
    lcpbench_solvers::registry::SolverEntry {
        name: "soft-step",
        summary:
            "soft step (Box2D v3): substeps with soft contacts and joints, a rigid relax pass \
                 and a restitution pass",
        problem_classes:
            "scenes only; frictionless and box friction (no pyramid, no cone), joints; \
                 substeps of one soft sweep and one rigid relax sweep, warm-started from substep \
                 to substep: a soft model (contacts sink, joints stretch under load)",
        iteration_unit: "sweeps over the rows, summed over the substeps and passes",
        iterative: true,
        relaxation: Some(
            "soft contacts and joints: damped springs of `hertz`, `zeta` (contacts) and \
                 `joint_hertz`, `joint_zeta` (joints) per substep, which stretch under load and \
                 let contacts sink, not the rigid LCP (its last solve, the relax pass, is rigid)",
        ),
        params: SOFT_STEP_PARAMS,
        make: lcpbench_solvers::registry::Make::Body(&crate::body_solvers::BodyMake {
            make: |params| Box::new(SoftStep::new(*params)),
            takes_joints: true,
            substeps: true,
        }),
    };

impl BodySolver for SoftStep {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::SoftStep
    }

    fn params(&self) -> Params {
        self.params
    }

    fn advance(&mut self, input: &SubstepInput<'_>) -> Option<SubstepOutcome> {
        let scheme = self.scheme();
        Some(run(input, &scheme, &mut self.workspace))
    }

    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
        let scheme = self.scheme();
        sweep_alone(system, settings, &scheme, &mut self.workspace)
    }
}

/// How the biased solve turns a row's position error into a velocity bias.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum BiasRule {
    /// Soft contacts and joints ([`Softness::new`] per substep).
    Soft {
        /// Contact stiffness, Hz.
        hertz: f64,
        /// Contact damping ratio.
        zeta: f64,
        /// Stiffness factor of a contact with a static body.
        static_scale: f64,
        /// Joint stiffness, Hz.
        joint_hertz: f64,
        /// Joint damping ratio.
        joint_zeta: f64,
        /// Largest push-out speed of the contact bias, m/s.
        push_out: f64,
        /// Lower the contact stiffness as Box2D's `b2World_Step` does for large substeps
        /// (contacts ≤ 0.25 / h).
        box2d_caps: bool,
        /// Joint stiffness at most `joint_cap / h` (Box2D: 0.125); 0: no cap.
        joint_cap: f64,
        /// Friction rows' position bias `friction_anchor · s / h`, `s` the tangential slip of
        /// the contact points since the step's start (Rapier's friction anchors); 0: none.
        friction_anchor: f64,
    },
    /// Baumgarte stabilisation on rigid rows: `bias = (β / h) min(0, s + slop)` on a normal
    /// row in contact, `(β / h) C` on a joint row.
    Baumgarte {
        /// `β`.
        beta: f64,
        /// Penetration left uncorrected, m.
        slop: f64,
        /// `> 0`: joint rows soft of this stiffness (at most [`JOINT_CAP`]` / h`) instead of
        /// the Baumgarte bias on rigid rows.
        joint_hertz: f64,
        /// Damping ratio of the soft joint rows.
        joint_zeta: f64,
    },
}

/// One substepping scheme: the loop of this module with a bias rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Scheme {
    /// Substeps per step.
    pub(crate) substeps: usize,
    /// Biased sweeps per substep.
    pub(crate) iterations: usize,
    /// Relax sweeps per substep (0: none).
    pub(crate) relax_iterations: usize,
    /// The biased solve's rule.
    pub(crate) bias: BiasRule,
    /// Each manifold's normal rows before its friction rows (else contact by contact).
    pub(crate) normals_first: bool,
    /// A manifold's normal rows solved two by two as 2×2 blocks (implies `normals_first`).
    pub(crate) block_pairs: bool,
    /// Sweep colour by colour, each colour's constraints in parallel
    /// ([`super::constraint_rows`]); else the serial order.
    pub(crate) colour: bool,
}

/// The softness of each kind of row over a substep `h` (rigid for Baumgarte).
#[derive(Debug, Clone, Copy)]
struct Coefficients {
    contact: Softness,
    static_contact: Softness,
    joint: Softness,
    /// Lower bound of a contact's position bias (−push-out speed).
    min_bias: f64,
    /// Baumgarte `(β / h, slop)` instead of the soft contact rule.
    baumgarte: Option<(f64, f64)>,
    /// Friction rows' bias rate (`friction_anchor / h`; 0: none).
    friction_rate: f64,
}

impl Coefficients {
    fn new(rule: &BiasRule, h: f64) -> Self {
        match *rule {
            BiasRule::Soft {
                hertz,
                zeta,
                static_scale,
                joint_hertz,
                joint_zeta,
                push_out,
                box2d_caps,
                joint_cap,
                friction_anchor,
            } => {
                let hertz = if box2d_caps {
                    hertz.min(0.25 / h)
                } else {
                    hertz
                };
                let joint_hertz = if joint_cap > 0.0 {
                    joint_hertz.min(joint_cap / h)
                } else {
                    joint_hertz
                };
                Coefficients {
                    contact: Softness::new(hertz, zeta, h),
                    static_contact: Softness::new(static_scale * hertz, zeta, h),
                    joint: Softness::new(joint_hertz, joint_zeta, h),
                    min_bias: -push_out,
                    baumgarte: None,
                    friction_rate: if h > 0.0 { friction_anchor / h } else { 0.0 },
                }
            }
            BiasRule::Baumgarte {
                beta,
                slop,
                joint_hertz,
                joint_zeta,
            } => {
                let b = Softness::baumgarte(beta, h);
                Coefficients {
                    contact: b,
                    static_contact: b,
                    joint: if joint_hertz > 0.0 {
                        Softness::new(joint_hertz.min(JOINT_CAP / h), joint_zeta, h)
                    } else {
                        b
                    },
                    min_bias: f64::NEG_INFINITY,
                    baumgarte: Some((b.bias_rate, slop)),
                    friction_rate: 0.0,
                }
            }
        }
    }
}

/// True when the row's only dynamic body is on one side (the other is static or the world).
fn touches_static(row: &SolverRow, bodies: &[SolverBody]) -> bool {
    row.sides < 2
        || row.blocks[..row.sides as usize]
            .iter()
            .any(|b| bodies[b.body].is_static())
}

/// The biased pass's coefficients of a row of `kind` (`None`: a row the sweep skips) whose
/// position error is `s()`.
#[inline]
fn biased_rule(
    c: &Coefficients,
    inv_h: f64,
    kind: Option<Kind>,
    touches_static: bool,
    s: impl FnOnce() -> f64,
) -> RowCoefficients {
    match kind {
        Some(Kind::Normal) => {
            let s = s();
            if s > 0.0 {
                RowCoefficients {
                    bias: s * inv_h,
                    ..RIGID_ROW
                }
            } else if let Some((rate, slop)) = c.baumgarte {
                RowCoefficients {
                    bias: rate * (s + slop).min(0.0),
                    ..RIGID_ROW
                }
            } else {
                let soft = if touches_static {
                    c.static_contact
                } else {
                    c.contact
                };
                RowCoefficients {
                    bias: (soft.bias_rate * s).max(c.min_bias),
                    mass_scale: soft.mass_scale,
                    impulse_scale: soft.impulse_scale,
                }
            }
        }
        Some(Kind::Joint) => RowCoefficients {
            bias: c.joint.bias_rate * s(),
            mass_scale: c.joint.mass_scale,
            impulse_scale: c.joint.impulse_scale,
        },
        // A friction row's position error is the tangential slip of its contact points since
        // the step's start (its `c0` is 0): the bias asks the sticking points back to where
        // they touched (Rapier's tangent `rhs`, `(p1 − p2)·t / dt`).
        Some(Kind::Friction) if c.friction_rate > 0.0 => RowCoefficients {
            bias: c.friction_rate * s(),
            ..RIGID_ROW
        },
        Some(Kind::Friction) | None => RIGID_ROW,
    }
}

/// The relax pass's coefficients: rigid rows, only the speculative bias of an open contact.
#[inline]
fn relax_rule(inv_h: f64, kind: Option<Kind>, s: impl FnOnce() -> f64) -> RowCoefficients {
    match kind {
        Some(Kind::Normal) => RowCoefficients {
            bias: s().max(0.0) * inv_h,
            ..RIGID_ROW
        },
        _ => RIGID_ROW,
    }
}

/// The kind of a row of [`SolverState`] as the rules see it.
fn kind_of(role: RowRole) -> Option<Kind> {
    match role {
        RowRole::Normal(_) => Some(Kind::Normal),
        RowRole::Friction { .. } => Some(Kind::Friction),
        RowRole::Joint => Some(Kind::Joint),
        RowRole::Other => None,
    }
}

/// The biased pass ([`biased_rule`]).
struct Biased<'a> {
    c: &'a Coefficients,
    inv_h: f64,
}

impl SweepRule for Biased<'_> {
    #[inline]
    fn coefficients(&self, row: &ConstraintRow, s: impl FnOnce() -> f64) -> RowCoefficients {
        biased_rule(self.c, self.inv_h, Some(row.kind), row.touches_static, s)
    }
}

/// The relax pass ([`relax_rule`]).
struct Relax {
    inv_h: f64,
}

impl SweepRule for Relax {
    #[inline]
    fn coefficients(&self, row: &ConstraintRow, s: impl FnOnce() -> f64) -> RowCoefficients {
        relax_rule(self.inv_h, Some(row.kind), s)
    }
}

/// The coefficients of the rows the sweep skips (`passive`, system indices), for the last
/// solve's `b`: the biased rule with `biased`, else the relax rule.
fn passive_coefficients(
    state: &SolverState,
    passive: &[usize],
    biased: Option<&Coefficients>,
    inv_h: f64,
    out: &mut [RowCoefficients],
) {
    for &i in passive {
        let row = &state.rows[i];
        let s = || row.position_error(&state.bodies);
        out[i] = match biased {
            Some(c) => biased_rule(
                c,
                inv_h,
                kind_of(row.role),
                touches_static(row, &state.bodies),
                s,
            ),
            None => relax_rule(inv_h, kind_of(row.role), s),
        };
    }
}

/// The rows a sweep visits, in order: joint rows first, then the contacts. With
/// `normals_first` false, each contact's normal row and its friction rows (the system's
/// order, Box2D's `b2SolveContact`); with it true, the contacts are taken in runs of
/// consecutive contacts between the same two bodies (a manifold) and each run's normal rows
/// come before its friction rows (Rapier's `ContactWithCoulombFriction::solve`: normal parts,
/// then tangent parts). Rows no dynamic body moves and pyramid rows are skipped.
///
/// With `block_pairs` (which implies `normals_first`), consecutive normal rows of a manifold
/// are taken two by two as blocks (Rapier's `block-solver` feature): `pairs[p]` is true when
/// `order[p]` and `order[p + 1]` are solved together by [`solve_pair`].
fn sweep_order(
    system: &ContactSystem,
    state: &SolverState,
    normals_first: bool,
    block_pairs: bool,
) -> (Vec<usize>, Vec<bool>) {
    let normals_first = normals_first || block_pairs;
    let joints = system.joint_rows_start().min(state.rows.len());
    let keep = |i: &usize| {
        let r = &state.rows[*i];
        r.mass > 0.0 && r.role != RowRole::Other
    };
    let mut order: Vec<usize> = (joints..state.rows.len()).filter(keep).collect();
    let mut pairs = vec![false; order.len()];
    if normals_first {
        // The contact rows (0..joints) in runs of one body pair.
        let pair = |i: usize| {
            let r = &state.rows[i];
            let mut p = [usize::MAX; 2];
            for (k, b) in r.blocks[..r.sides as usize].iter().enumerate() {
                p[k] = b.body;
            }
            p
        };
        let contact_of = |i: usize| match state.rows[i].role {
            RowRole::Normal(_) => i,
            RowRole::Friction { normal } => normal,
            _ => i,
        };
        let mut start = 0;
        while start < joints {
            let key = pair(contact_of(start));
            let mut end = start + 1;
            while end < joints && pair(contact_of(end)) == key {
                end += 1;
            }
            let first = order.len();
            order.extend(
                (start..end)
                    .filter(|&i| matches!(state.rows[i].role, RowRole::Normal(_)))
                    .filter(keep),
            );
            pairs.resize(order.len(), false);
            if block_pairs {
                let mut p = first;
                while p + 1 < order.len() {
                    pairs[p] = true;
                    p += 2;
                }
            }
            order.extend(
                (start..end)
                    .filter(|&i| !matches!(state.rows[i].role, RowRole::Normal(_)))
                    .filter(keep),
            );
            pairs.resize(order.len(), false);
            start = end;
        }
    } else {
        order.extend((0..joints).filter(keep));
        pairs.resize(order.len(), false);
    }
    (order, pairs)
}

/// The warm start of the step: the stored impulses projected onto the rows' bounds (normal
/// `≥ 0`, friction within `±μ λ_n`), zero where none is stored.
fn initial_impulses(state: &SolverState, warm: Option<&[f64]>, lambda: &mut [f64]) {
    let warm = warm.unwrap_or(&[]);
    for (i, row) in state.rows.iter().enumerate() {
        let w = warm
            .get(i)
            .copied()
            .filter(|v| v.is_finite())
            .unwrap_or(0.0);
        lambda[i] = match row.role {
            _ if row.mass <= 0.0 => 0.0,
            RowRole::Normal(_) => w.max(0.0),
            RowRole::Joint => w,
            RowRole::Friction { .. } | RowRole::Other => 0.0,
        };
    }
    for (i, row) in state.rows.iter().enumerate() {
        if let RowRole::Friction { normal } = row.role {
            if row.mass > 0.0 {
                let w = warm
                    .get(i)
                    .copied()
                    .filter(|v| v.is_finite())
                    .unwrap_or(0.0);
                let bound = row.mu * lambda[normal];
                lambda[i] = w.clamp(-bound, bound);
            }
        }
    }
}

/// Run the scheme over the step of `input`; `workspace` keeps the rows' layout buffers and
/// the colouring's memory of the previous step (used with `scheme.colour`).
pub(crate) fn run(
    input: &SubstepInput<'_>,
    scheme: &Scheme,
    workspace: &mut Workspace,
) -> SubstepOutcome {
    let system = input.system;
    let settings = input.settings;
    let deadline = settings.time_budget.map(|b| Instant::now() + b);
    let mut state = SolverState::new(system, &input.gravity);
    let n = state.rows.len();
    let substeps = scheme.substeps.max(1);
    let h = system.h / substeps as f64;
    let inv_h = if h > 0.0 { 1.0 / h } else { 0.0 };
    let coefficients = Coefficients::new(&scheme.bias, h);

    // The step's workspace: the rows laid out for the sweep (buffers kept between steps), the
    // per-row results in the system's order allocated once.
    let (order, pairs) = sweep_order(system, &state, scheme.normals_first, scheme.block_pairs);
    let mut lambda = vec![0.0; n];
    initial_impulses(&state, settings.warm_start.as_deref(), &mut lambda);
    let layout = &mut workspace.rows;
    layout.build(
        system,
        &state,
        (&order, &pairs),
        scheme.colour.then_some(&mut workspace.graph),
        &lambda,
    );
    // The rows the sweep skips keep their impulse (0); their coefficients still enter the
    // last solve's `b`.
    let mut swept = vec![false; n];
    for &g in &layout.global {
        swept[g as usize] = true;
    }
    let passive: Vec<usize> = (0..n).filter(|&i| !swept[i]).collect();
    let mut f_swept = vec![0.0; layout.rows.len()];
    let mut k = vec![RowCoefficients::default(); n];
    // Velocities at the start of the last substep that solved (after its velocity
    // integration, before its warm start): the last solve's `b` is `J` of them plus its bias.
    let mut saved: Vec<(Vector3<f64>, Vector3<f64>)> =
        state.bodies.iter().map(|b| (b.v, b.w)).collect();
    let mut last_solve: Option<(usize, &'static str)> = None;

    let mut cost = StepCost::default();
    let mut sweeps = 0usize;
    let mut timed_out = false;
    let mut solving = true;
    let per_pass = order.len() as u64;

    for step in 0..substeps {
        state.integrate_velocities(&input.gravity, h);
        cost.body_passes += 1;
        if solving && sweeps >= settings.max_iterations {
            solving = false;
        }
        if solving {
            for (s, b) in saved.iter_mut().zip(&state.bodies) {
                *s = (b.v, b.w);
            }
            // Warm start: the accumulated impulses of the previous substep.
            layout.warm_start(&mut state.bodies);
            cost.row_updates += per_pass;
            // Biased solve.
            let passes = scheme
                .iterations
                .min(settings.max_iterations.saturating_sub(sweeps));
            let rule = Biased {
                c: &coefficients,
                inv_h,
            };
            for _ in 0..passes {
                layout.sweep(&mut state.bodies, &rule);
            }
            sweeps += passes;
            cost.row_updates += per_pass * passes as u64;
            if passes > 0 {
                passive_coefficients(&state, &passive, Some(&coefficients), inv_h, &mut k);
                last_solve = Some((step, "biased solve"));
            }
        }
        state.integrate_positions(h);
        cost.body_passes += 1;
        if solving && scheme.relax_iterations > 0 && sweeps < settings.max_iterations {
            let passes = scheme
                .relax_iterations
                .min(settings.max_iterations.saturating_sub(sweeps));
            for _ in 0..passes {
                layout.sweep(&mut state.bodies, &Relax { inv_h });
            }
            sweeps += passes;
            cost.row_updates += per_pass * passes as u64;
            if passes > 0 {
                passive_coefficients(&state, &passive, None, inv_h, &mut k);
                last_solve = Some((step, "relax pass"));
            }
        }
        if solving {
            for (f, l) in f_swept.iter_mut().zip(&layout.lambda) {
                *f += l;
            }
        }
        if solving && step + 1 < substeps && deadline.is_some_and(|d| Instant::now() >= d) {
            timed_out = true;
            solving = false;
        }
    }

    // Back to the system's order.
    let mut f_step = vec![0.0; n];
    let mut hit = vec![false; n];
    for (p, &g) in layout.global.iter().enumerate() {
        let g = g as usize;
        lambda[g] = layout.lambda[p];
        f_step[g] = f_swept[p];
        hit[g] = layout.hit[p];
        k[g] = layout.coefficients[p];
    }

    // The last solve's LCP, before the restitution pass changes the impulses.
    let last = match last_solve {
        Some((step, pass)) => {
            let b = state
                .rows
                .iter()
                .zip(&k)
                .map(|(row, c)| {
                    let mut r = 0.0;
                    for blk in &row.blocks[..row.sides as usize] {
                        let (v, w) = &saved[blk.body];
                        r += blk.linear.dot(v) + blk.angular.dot(w);
                    }
                    r + c.bias
                })
                .collect();
            let soft = pass == "biased solve"
                && match scheme.bias {
                    BiasRule::Soft { .. } => true,
                    BiasRule::Baumgarte { joint_hertz, .. } => joint_hertz > 0.0,
                };
            LastSolve {
                f: lambda.clone(),
                b,
                what: format!(
                    "{pass}{} of substep {} of {substeps}{}",
                    if soft { " (soft rows)" } else { "" },
                    step + 1,
                    if layout.coloured {
                        colour_note(
                            layout.constraint_count(),
                            layout.colour_count(),
                            layout.overflow_count(),
                        )
                    } else {
                        String::new()
                    }
                ),
            }
        }
        None => LastSolve {
            f: vec![0.0; n],
            b: state.rates(),
            what: "no solve: the step's final velocities with zero impulse".to_owned(),
        },
    };

    // Restitution: Newton's law on the contacts that closed fast and were hit this step.
    let threshold = system.restitution_threshold;
    let mut bounced = false;
    if last_solve.is_some() {
        for &i in &order {
            let row = &state.rows[i];
            if !matches!(row.role, RowRole::Normal(_))
                || row.restitution <= 0.0
                || row.approach >= -threshold
                || !hit[i]
            {
                continue;
            }
            let vn = row.rate(&state.bodies);
            let d = -row.mass * (vn + row.restitution * row.approach);
            let new = (lambda[i] + d).max(0.0);
            let applied = new - lambda[i];
            if applied != 0.0 && applied.is_finite() {
                row.apply(applied, &mut state.bodies);
                lambda[i] = new;
                f_step[i] += applied;
            }
            cost.row_updates += 1;
            bounced = true;
        }
    }
    if bounced {
        sweeps += 1;
    }

    SubstepOutcome {
        state,
        f_step,
        warm: lambda,
        last,
        iterations: sweeps,
        substeps,
        cost,
        timed_out,
    }
}

/// What the step report's `residual_of` adds for a coloured sweep: the colours and the
/// overflow set it visited.
pub(crate) fn coloured_note<C>(blocks: &ColouredSweep<C>) -> String {
    colour_note(
        blocks.constraint_count(),
        blocks.colour_count(),
        blocks.overflow_count(),
    )
}

/// The note of [`coloured_note`] from the counts.
fn colour_note(constraints: usize, colours: usize, overflow: usize) -> String {
    format!(
        ", coloured sweeps ({constraints} constraints in {colours} colour{}, {overflow} in overflow)",
        if colours == 1 { "" } else { "s" },
    )
}

/// A substepping scheme on a system alone (no world): the system's free velocities already
/// hold gravity, so the scheme runs with none; the impulse is the whole step's.
pub(crate) fn sweep_alone(
    system: &ContactSystem,
    settings: &Settings,
    scheme: &Scheme,
    workspace: &mut Workspace,
) -> BodySweep {
    let input = SubstepInput {
        system,
        gravity: Vector3::zeros(),
        settings,
    };
    let out = run(&input, scheme, workspace);
    BodySweep::from(out)
}

//! `tgs`: temporal Gauss–Seidel, substeps with rigid rows and Baumgarte bias, no relax pass.
//!
//! Source: the TGS solver of PhysX 4 (NVIDIA PhysX 4.0 SDK guide, "Rigid Body Dynamics:
//! Temporal Gauss-Seidel"; Macklin et al., "Small Steps in Physics Simulation", SCA 2019, for
//! why many substeps of one sweep beat one step of many sweeps) and Rapier's substepping
//! velocity solver (`dynamics/solver/velocity_solver.rs`, `solve_constraints` with
//! `num_substeps`). It is the loop of [`super::soft_step`] (same stages, same row order, same
//! warm start from substep to substep, same restitution pass) with a different bias and
//! without the relax pass:
//!
//! With `h = dt / substeps`, for each substep: integrate velocities (`v += h g`), warm start
//! (apply the accumulated impulses), `iterations` projected Gauss–Seidel sweeps (joint rows
//! first, then each contact's normal and friction rows) with the bias
//!
//! * normal row, gap `s > 0` (speculative): `bias = s / h`;
//! * normal row, `s ≤ 0`: `bias = (β / h) · min(0, s + slop)` (Baumgarte with a slop);
//! * joint row: `bias = (β / h) · C`;
//! * friction row: none, the impulse within `±μ λ_n`;
//!
//! every row rigid (`Δλ = −m (J v + bias)`, accumulated impulse clamped), then integrate
//! positions (`Δx += h v`). After the substeps, the restitution pass of `soft-step` (Newton's
//! law `J v = −e · approach` on the contacts that closed faster than the threshold and were
//! hit in the step; Box2D's `b2ApplyOverflowRestitution`), not a restitution term in the bias.
//!
//! `relax_iterations` (default 0, none) adds `soft-step`'s relax sweeps after the position
//! update (rigid rows, no position bias), as Rapier's stabilisation iterations do.
//!
//! `hertz > 0` makes the rows soft instead (the soft contact and joint rule of `soft-step`
//! with `hertz`, `zeta` for contacts and joints alike, push-out 3 m/s, no static scale and no
//! cap on the hertz): soft constraints as an option of any substepping solver.
//!
//! # Parameters (`tgs@key=value,…`)
//!
//! | key | default | source |
//! | --- | --- | --- |
//! | `substeps` | 4 | PhysX's and Rapier's usual 4 position iterations / substeps |
//! | `iterations` | 1 | one sweep per substep (Macklin et al. 2019) |
//! | `relax_iterations` | 0 | no relax pass (PhysX TGS; Rapier runs 1) |
//! | `baumgarte` | 0.2 | `β`, as lcpbench's step-level Baumgarte correction |
//! | `slop` | 0.005 m | allowed penetration (Rapier's `allowed_linear_error`, 5 mm) |
//! | `hertz` | 0 | 0: rigid rows with Baumgarte; `> 0`: soft rows |
//! | `zeta` | 1 | damping ratio of the soft rows |
//! | `joint_hertz` | 0 | with `hertz = 0`: 0 for Baumgarte joint rows; `> 0`: soft joint rows of this stiffness, at most `0.25 / h` (`soft-step`'s joints) |
//! | `joint_zeta` | 2 | damping ratio of those soft joint rows (Box2D's `jointDampingRatio`) |
//! | `colour` | 0 | 1: coloured sweeps, each colour's constraints in parallel, as `soft-step@colour=1` ([`super::constraint_rows`]) |
//!
//! # What it solves
//!
//! With `hertz = 0` every sweep is a projected Gauss–Seidel sweep on a rigid LCP: the last
//! solve (the last sweep of the last substep) works on `w = A λ + b`, `b = J v` (the
//! velocities after that substep's velocity integration, before its warm start) `+` the bias
//! above, `λ` the substep's accumulated impulse. The stepper measures the shared residual on
//! that LCP; one sweep per substep rarely meets a tight tolerance, and the status then says
//! `iteration_limit`. The Baumgarte bias adds velocity that no relax pass takes out, so
//! penetrating contacts are pushed out with some energy gain (a box dropped into the ground
//! pops out), and resting contacts stay within the slop depth. With `hertz > 0` the biased
//! sweeps are those of a soft model (the step report's `residual_of` says `soft rows`).
//!
//! # Failure modes
//!
//! The Baumgarte bias acts as a stiff undamped spring: with too few sweeps to resolve a chain
//! of coupled rows the bias velocities of neighbouring rows feed each other and grow. A
//! 5-link chain of 1 kg links holding a 20 kg end mass, at 0.01 s and 4 substeps, oscillates
//! with growing amplitude at 1 or 2 sweeps per substep (with or without one relax sweep) and
//! hangs still at 30 (`tgs@iterations=30`); `chain_20_1e3` blows up at 20 substeps of one
//! sweep. Tall stacks (`tower_40_60hz`) fall at one sweep per substep and stand at 20.
//! `soft-step`, whose soft rows damp, holds both chains.
//!
//! The cause on `chain_20_1e3` (20 links of 1 kg, 1000 kg end mass, 60 Hz steps), from the
//! largest joint drift over the run: it is the joint rows' Baumgarte bias on rigid rows, made
//! worse by the warm start, not the restitution pass (the scene has no contacts):
//!
//! | `tgs@…` | 4 substeps | 20 substeps |
//! | --- | --- | --- |
//! | defaults (`baumgarte=0.2`), warm started | 484 m (unstable) | 6031 m (unstable) |
//! | defaults, cold (no warm start) | 0.59 m | 521 m (unstable) |
//! | `baumgarte=0.05`, warm | 2.8 m | 22 m |
//! | `baumgarte=0`, warm (no position feedback) | 0.34 m | |
//! | `iterations=30`, warm | 5.0 m | |
//! | `joint_hertz=1e6` (soft joints at `0.25 / h`, ζ = 2), warm | 0.28 m | 2.8 cm |
//!
//! One sweep on a joint path with a 1000 : 1 mass ratio leaves most of each row's error, the
//! bias asks for it again at every substep, and the accumulated impulse carried by the warm
//! start adds the previous substeps' bias impulses: the loop gains energy. A soft row's
//! `impulse_scale · λ` term lets the accumulated impulse leak and its `mass_scale < 1` damps
//! the feedback, which is why soft joints hold; `joint_hertz > 0` gives `tgs` those joints
//! while its contacts keep the Baumgarte rule.

use super::params::{ParamSpec, Params};
use super::soft_step::{run, sweep_alone, BiasRule, Scheme, Workspace, COLOUR_PARAM};
use super::softness::PUSH_OUT;
use super::{SubstepInput, SubstepOutcome};
use crate::body_solvers::{BodySolver, BodySolverKind, BodySweep};
use crate::builder::ContactSystem;
use lcpbench_solvers::Settings;

/// The parameters of `tgs`.
pub const TGS_PARAMS: &[ParamSpec] = &[
    ParamSpec::count("substeps", 4, 1, 1024, "substeps per step"),
    ParamSpec::count("iterations", 1, 1, 1000, "sweeps per substep"),
    ParamSpec::count(
        "relax_iterations",
        0,
        0,
        1000,
        "rigid sweeps without position bias per substep, after the position update",
    ),
    ParamSpec::real(
        "baumgarte",
        0.2,
        0.0,
        1.0,
        "Baumgarte factor: share of the position error corrected per substep",
    ),
    ParamSpec::real("slop", 0.005, 0.0, 1.0, "penetration left uncorrected, m"),
    ParamSpec::real(
        "hertz",
        0.0,
        0.0,
        1e6,
        "0: rigid rows with Baumgarte bias; > 0: soft rows of this stiffness, Hz",
    ),
    ParamSpec::real("zeta", 1.0, 0.0, 1e6, "damping ratio of the soft rows"),
    ParamSpec::real(
        "joint_hertz",
        0.0,
        0.0,
        1e6,
        "with hertz = 0: 0 for Baumgarte joints; > 0 for soft joint rows, Hz (at most 0.25 / h)",
    ),
    ParamSpec::real(
        "joint_zeta",
        2.0,
        0.0,
        1e6,
        "damping ratio of the soft joint rows",
    ),
    COLOUR_PARAM,
];

/// The `tgs` solver: its parameters ([`TGS_PARAMS`]) and its workspace (the rows' layout,
/// for `colour=1` the colouring of the previous step's constraints).
#[derive(Debug, Clone, PartialEq)]
pub struct Tgs {
    params: Params,
    workspace: Workspace,
}

impl Tgs {
    /// The solver with `params` (which follow [`TGS_PARAMS`]).
    pub fn new(params: Params) -> Self {
        Self {
            params,
            workspace: Workspace::default(),
        }
    }

    fn scheme(&self) -> Scheme {
        let p = &self.params;
        let hertz = p.get("hertz");
        let bias = if hertz > 0.0 {
            BiasRule::Soft {
                hertz,
                zeta: p.get("zeta"),
                static_scale: 1.0,
                joint_hertz: hertz,
                joint_zeta: p.get("zeta"),
                push_out: PUSH_OUT,
                box2d_caps: false,
                joint_cap: 0.0,
                friction_anchor: 0.0,
            }
        } else {
            BiasRule::Baumgarte {
                beta: p.get("baumgarte"),
                slop: p.get("slop"),
                joint_hertz: p.get("joint_hertz"),
                joint_zeta: p.get("joint_zeta"),
            }
        };
        Scheme {
            substeps: p.count("substeps"),
            iterations: p.count("iterations"),
            relax_iterations: p.count("relax_iterations"),
            bias,
            normals_first: false,
            block_pairs: false,
            colour: p.count("colour") > 0,
        }
    }
}

impl Default for Tgs {
    fn default() -> Self {
        Self::new(Params::defaults(TGS_PARAMS))
    }
}

/// The registry's entry of `tgs`.
pub static TGS: lcpbench_solvers::registry::SolverEntry = lcpbench_solvers::registry::SolverEntry {
    name: "tgs",
    summary: "temporal Gauss-Seidel (PhysX TGS, Rapier): substeps of rigid sweeps with \
                 Baumgarte bias, no relax",
    problem_classes: "scenes only; frictionless and box friction (no pyramid, no cone), joints; \
                 substeps of rigid Gauss-Seidel sweeps with Baumgarte bias, warm-started from \
                 substep to substep; pushes out of penetration with some energy gain",
    iteration_unit: "sweeps over the rows, summed over the substeps and passes",
    iterative: true,
    relaxation: None,
    params: TGS_PARAMS,
    make: lcpbench_solvers::registry::Make::Body(&crate::body_solvers::BodyMake {
        make: |params| Box::new(Tgs::new(*params)),
        takes_joints: true,
        substeps: true,
    }),
};

impl BodySolver for Tgs {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::Tgs
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

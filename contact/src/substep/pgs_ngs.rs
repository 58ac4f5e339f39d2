//! `pgs-ngs`: sequential impulses on velocities, then nonlinear Gauss–Seidel on positions, the
//! step of Box2D 2.x (Box2D v2.4.1, `src/dynamics/b2_island.cpp` `b2Island::Solve`,
//! `src/dynamics/b2_contact_solver.cpp` `b2ContactSolver::WarmStart`,
//! `SolveVelocityConstraints`, `SolvePositionConstraints`).
//!
//! Each of `substeps` substeps of `h = dt / substeps` (Box2D 2.x takes one) runs, in order:
//!
//! 1. **integrate velocities**: `v += h g`;
//! 2. **warm start**: apply the accumulated impulses `λ` (the previous substep's, or the
//!    previous step's for the first substep, projected onto the bounds);
//! 3. **`iterations` velocity sweeps** (Gauss–Seidel on accumulated impulses): the joint rows
//!    first (equalities, no bias), then per contact its friction rows (bounded by `±μ λ_n` of
//!    the contact's current normal impulse; Box2D solves them first "because non-penetration is
//!    more important than friction") and its normal row (`λ_n ≥ 0`). A normal row's velocity
//!    target has no position term: `w = J v + bias ≥ 0` with `bias = e v⁻` for a bouncing
//!    contact (`v⁻ < −restitution_threshold`, Box2D's `velocityBias = −e vRel`), `C/h` for an
//!    open contact (speculative: Box2D 2.x has none, but the stepper's contacts include gaps up
//!    to `prediction_distance`), 0 otherwise ([`super::bias`]); with `hertz > 0` a penetrating
//!    contact is a soft spring instead (`bias = max(bias_rate C, −3 m/s)`, mass and impulse
//!    scales of [`super::Softness`]: Box2D v3's soft contact);
//! 4. **integrate positions**: `Δx += h v`;
//! 5. **`position_iterations` nonlinear Gauss–Seidel position sweeps**: per normal row (in the
//!    contacts' order) its separation `C` at the current pose, the correction
//!    `clamp(β (C + slop), −max_correction, 0)` and the position impulse `δ = −correction / k`
//!    applied to the poses only (`Δx += M⁻¹ Jᵀ δ`; velocities untouched); then per joint row
//!    `δ = −clamp(C, −max_correction, max_correction) / k` (no slop, no `β`, as Box2D's joints'
//!    `SolvePositionConstraints`). The passes stop early once the smallest separation seen in a
//!    pass is `≥ −3 slop` and every joint row's error is within `slop` (Box2D's test: "we can't
//!    expect minSeparation ≥ −linearSlop because we don't push the separation above
//!    −linearSlop").
//!
//! Defaults are Box2D 2.x's: 8 velocity and 3 position iterations (`b2World::Step` in the
//! testbed), `b2_baumgarte = 0.2`, `b2_linearSlop = 0.005` m, `b2_maxLinearCorrection = 0.2` m.
//!
//! **Coloured sweeps.** `colour = 1` takes the velocity sweeps and the position sweeps colour
//! by colour ([`super::coloured_sweep`]): the constraints (a joint's rows, the contacts between
//! two bodies) are coloured so that no two of a colour move a common dynamic body, and each
//! sweep runs the overflow set serially, then each colour's constraints in parallel, each
//! constraint's rows in the order above (a position sweep: its contacts, then its joint rows).
//! It is a different Gauss–Seidel order from the serial one (joints, then contacts), with
//! results that do not depend on the number of threads; the warm start stays serial.
//!
//! **What it solves.** The velocity sweeps aim at the step's rigid LCP with the bias above; the
//! reported last solve ([`SubstepOutcome::last`]) is the velocity solve of the last substep
//! that solved: `f` = its accumulated impulses (warm start included), `b` = `J v` after gravity
//! and before the warm start, plus its bias, so `w = A f + b` is the velocity after the sweeps
//! plus the bias. Eight sweeps rarely meet a tight tolerance: the status is then
//! `iteration_limit`, never `converged` unless the shared residual of that LCP meets it. The
//! position pass is positional (it moves the bodies, applies no impulse and is not part of any
//! LCP): penetration is corrected there, not by the velocity solve. With `hertz > 0` the
//! velocity solve is that of a soft (regularised) problem, measured against the rigid LCP
//! (the report's `residual_of` says `soft`).
//!
//! Friction rows are swept before their normal row, as Box2D does: a later normal update can
//! leave a friction impulse above `μ λ_n` of the final normal impulse until the next sweep
//! (the shared residual of the last solve sees what is left at the end).
//!
//! **Failure modes** (those of Gauss–Seidel at a fixed sweep count): tall stacks and long
//! chains with mass ratios are under-solved each step, so they sag and sway (the position pass
//! hides the sag of contacts beyond the slop, not the velocity error); a deep initial overlap is
//! removed at most `max_correction` per row and sweep, without adding velocity.
//!
//! **Not done**: Box2D's block solver of two-point manifolds (each row is swept alone), its
//! clamp of the translation and rotation per step (`b2_maxTranslation`, `b2_maxRotation`), and
//! the update of contact points and normals within the position pass (the rows keep the
//! step's anchors and normals; the separation is `C₀ + J Δx`, exact for a translation and to
//! first order in the rotation). Pyramid friction rows are not swept (the pyramid model is
//! refused for body solvers).
//!
//! **Budgets.** `settings.max_iterations` caps the velocity and position sweeps of the whole
//! step; once spent, the remaining substeps apply their warm start and integrate, without
//! sweeps. `settings.time_budget` is checked between substeps: once spent, the remaining
//! substeps only integrate (no constraint work) and the outcome says `timed_out`.

use super::bias::{is_swept, projected_update, row_targets, warm_impulses, Feedback, RowTarget};
use super::coloured_sweep::ColouredSweep;
use super::colouring::ConstraintGraph;
use super::params::{ParamSpec, Params};
use super::soft_step::{coloured_note, COLOUR_PARAM};
use super::state::{RowRole, SolverBody, SolverRow, SolverState, StepCost};
use super::{LastSolve, SubstepInput, SubstepOutcome};
use crate::body_solvers::{BodySolver, BodySolverKind, BodySweep};
use crate::builder::ContactSystem;
use lcpbench_solvers::Settings;
use nalgebra::Vector3;
use std::time::Instant;

/// The parameters of `pgs-ngs`, with Box2D 2.x's defaults.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::count("substeps", 1, 1, 64, "substeps per step (Box2D 2.x: 1)"),
    ParamSpec::count(
        "iterations",
        8,
        1,
        10_000,
        "velocity sweeps per substep (Box2D 2.x: 8)",
    ),
    ParamSpec::count(
        "position_iterations",
        3,
        0,
        10_000,
        "nonlinear Gauss-Seidel position sweeps per substep (Box2D 2.x: 3)",
    ),
    ParamSpec::real(
        "baumgarte",
        0.2,
        0.0,
        1.0,
        "share of a contact's penetration corrected per position sweep (b2_baumgarte)",
    ),
    ParamSpec::real(
        "slop",
        0.005,
        0.0,
        1.0,
        "penetration left uncorrected, m (b2_linearSlop)",
    ),
    ParamSpec::real(
        "max_correction",
        0.2,
        0.0,
        100.0,
        "largest position correction of one row per sweep, m (b2_maxLinearCorrection)",
    ),
    ParamSpec::real(
        "hertz",
        0.0,
        0.0,
        1e4,
        "soft contact stiffness in the velocity sweeps, Hz (0: rigid)",
    ),
    ParamSpec::real("zeta", 1.0, 0.0, 1e3, "soft contact damping ratio"),
    COLOUR_PARAM,
];

/// The `pgs-ngs` solver with its parameters ([`PARAMS`]) and, for `colour=1`, the colouring
/// of the previous step's constraints.
#[derive(Debug, Clone, PartialEq)]
pub struct PgsNgs {
    params: Params,
    graph: ConstraintGraph,
}

impl Default for PgsNgs {
    fn default() -> Self {
        Self::new(Params::defaults(PARAMS))
    }
}

impl PgsNgs {
    /// The solver with `params` (which follow [`PARAMS`]).
    pub fn new(params: Params) -> Self {
        Self {
            params,
            graph: ConstraintGraph::new(),
        }
    }

    /// Advance the bodies over the step of `system` (see the module doc).
    pub fn step(
        &mut self,
        system: &ContactSystem,
        gravity: Vector3<f64>,
        settings: &Settings,
    ) -> SubstepOutcome {
        let p = &self.params;
        let substeps = p.count("substeps").max(1);
        let iterations = p.count("iterations");
        let position_iterations = p.count("position_iterations");
        let ngs = NgsParams {
            beta: p.get("baumgarte"),
            slop: p.get("slop"),
            max_correction: p.get("max_correction"),
        };
        let h = system.h / substeps as f64;
        let feedback = Feedback::soft_or(p.get("hertz"), p.get("zeta"), h, Feedback::None);
        let deadline = settings.time_budget.map(|b| Instant::now() + b);

        let mut state = SolverState::new(system, &gravity);
        let n = state.rows.len();
        let order = velocity_order(&state);
        let mut coloured = (p.count("colour") > 0)
            .then(|| ColouredSweep::<RowTarget>::new(system, &state, &order, &[], &mut self.graph));
        let mut lambda = warm_impulses(&state, settings.warm_start.as_deref());
        let mut f_step = vec![0.0; n];
        let mut cost = StepCost::default();
        let mut budget = settings.max_iterations;
        let mut sweeps_done = 0;
        let mut last = None;
        let mut timed_out = false;

        for s in 0..substeps {
            if s > 0 && deadline.is_some_and(|d| Instant::now() >= d) {
                timed_out = true;
            }
            state.integrate_velocities(&gravity, h);
            cost.body_passes += 1;
            if !timed_out {
                let targets = row_targets(&state, feedback, h, system.restitution_threshold);
                let b: Vec<f64> = state
                    .rates()
                    .iter()
                    .zip(&targets)
                    .map(|(r, t)| r + t.bias)
                    .collect();
                // Warm start.
                for &i in &order {
                    if lambda[i] != 0.0 {
                        state.rows[i].apply(lambda[i], &mut state.bodies);
                    }
                }
                cost.row_updates += order.len() as u64;
                let sweeps = iterations.min(budget);
                match coloured.as_mut() {
                    None => {
                        for _ in 0..sweeps {
                            velocity_sweep(
                                &state.rows,
                                &mut state.bodies,
                                &order,
                                &targets,
                                &mut lambda,
                            );
                        }
                    }
                    Some(blocks) if sweeps > 0 => {
                        blocks.load(&lambda, &targets);
                        for _ in 0..sweeps {
                            blocks.sweep(
                                &mut state.bodies,
                                |b| {
                                    velocity_sweep(
                                        &b.rows,
                                        &mut b.local,
                                        &b.order,
                                        &b.coefficients,
                                        &mut b.lambda,
                                    )
                                },
                                |()| {},
                            );
                        }
                        blocks.store(&mut lambda, None);
                    }
                    Some(_) => {}
                }
                cost.row_updates += order.len() as u64 * sweeps as u64;
                budget -= sweeps;
                sweeps_done += sweeps;
                for (total, l) in f_step.iter_mut().zip(&lambda) {
                    *total += l;
                }
                let soft = matches!(feedback, Feedback::Soft(_));
                last = Some(LastSolve {
                    f: lambda.clone(),
                    b,
                    what: format!(
                        "{}velocity sweeps of substep {} of {substeps} ({sweeps} sweeps){}",
                        if soft { "soft " } else { "" },
                        s + 1,
                        coloured.as_ref().map_or(String::new(), coloured_note)
                    ),
                });
            }
            state.integrate_positions(h);
            cost.body_passes += 1;
            if !timed_out {
                let passes = position_iterations.min(budget);
                let mut used = 0;
                for _ in 0..passes {
                    used += 1;
                    let (ok, updates) = match coloured.as_mut() {
                        None => position_pass(&mut state, &ngs),
                        Some(blocks) => coloured_position_pass(&mut state, blocks, &ngs),
                    };
                    cost.row_updates += updates;
                    if ok {
                        break;
                    }
                }
                budget -= used;
                sweeps_done += used;
            }
        }
        // The first substep always solves (the deadline is checked from the second on).
        let last = last.unwrap_or_else(|| LastSolve {
            f: vec![0.0; n],
            b: state.rates(),
            what: "no solve".into(),
        });
        SubstepOutcome {
            state,
            f_step,
            warm: lambda,
            last,
            iterations: sweeps_done,
            substeps,
            cost,
            timed_out,
        }
    }
}

/// The order of the velocity sweeps: joint rows, then per contact its friction rows and its
/// normal row (rows without a dynamic body and pyramid rows left out).
fn velocity_order(state: &SolverState) -> Vec<usize> {
    let rows = &state.rows;
    let mut friction: Vec<Vec<usize>> = vec![Vec::new(); rows.len()];
    for (i, row) in rows.iter().enumerate() {
        if let (true, RowRole::Friction { normal }) = (is_swept(row), row.role) {
            friction[normal].push(i);
        }
    }
    let mut order: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].role == RowRole::Joint && is_swept(&rows[i]))
        .collect();
    for (i, row) in rows.iter().enumerate() {
        if let RowRole::Normal(_) = row.role {
            order.extend_from_slice(&friction[i]);
            if is_swept(row) {
                order.push(i);
            }
        }
    }
    order
}

/// One velocity sweep over `order`: per row the projected update of its accumulated impulse
/// towards its target (a friction row bounded by `μ λ_n` of its normal row's current impulse),
/// applied at once.
fn velocity_sweep(
    rows: &[SolverRow],
    bodies: &mut [SolverBody],
    order: &[usize],
    targets: &[RowTarget],
    lambda: &mut [f64],
) {
    for &i in order {
        let row = &rows[i];
        let bound = match row.role {
            RowRole::Friction { normal } => row.mu * lambda[normal],
            _ => 0.0,
        };
        let rate = row.rate(bodies);
        let new = projected_update(row.role, lambda[i], rate, &targets[i], row.mass, bound);
        let d = new - lambda[i];
        if d != 0.0 {
            row.apply(d, bodies);
            lambda[i] = new;
        }
    }
}

/// The nonlinear Gauss–Seidel pass's constants.
struct NgsParams {
    beta: f64,
    slop: f64,
    max_correction: f64,
}

/// One position pass: contacts, then joints (Box2D 2.x's order). Returns whether the pass
/// found the positions good enough to stop (smallest separation `≥ −3 slop`, every joint
/// error within `slop`) and the rows it visited.
fn position_pass(state: &mut SolverState, p: &NgsParams) -> (bool, u64) {
    let SolverState { bodies, rows } = state;
    let (min_separation, joints_ok, visited) = position_rows(rows, bodies, p);
    (min_separation >= -3.0 * p.slop && joints_ok, visited)
}

/// The position pass colour by colour ([`super::coloured_sweep`]): each constraint's
/// contacts, then its joint rows; the smallest separation, the joints' test and the count of
/// rows combined over the constraints in their fixed order.
fn coloured_position_pass(
    state: &mut SolverState,
    blocks: &mut ColouredSweep<RowTarget>,
    p: &NgsParams,
) -> (bool, u64) {
    let (mut min_separation, mut joints_ok, mut visited) = (0.0f64, true, 0);
    blocks.sweep(
        &mut state.bodies,
        |b| position_rows(&b.rows, &mut b.local, p),
        |(m, ok, v)| {
            min_separation = min_separation.min(m);
            joints_ok &= ok;
            visited += v;
        },
    );
    (min_separation >= -3.0 * p.slop && joints_ok, visited)
}

/// The position pass over `rows`: their swept normal rows in order, then their joint rows.
/// Returns the smallest separation seen (0 when none is negative), whether every joint row's
/// error was within `slop`, and the rows visited.
fn position_rows(rows: &[SolverRow], bodies: &mut [SolverBody], p: &NgsParams) -> (f64, bool, u64) {
    let mut min_separation: f64 = 0.0;
    let mut joints_ok = true;
    let mut visited = 0;
    for row in rows.iter().filter(|r| is_swept(r)) {
        if let RowRole::Normal(_) = row.role {
            visited += 1;
            let c = row.position_error(bodies);
            min_separation = min_separation.min(c);
            let correction = (p.beta * (c + p.slop)).clamp(-p.max_correction, 0.0);
            if correction != 0.0 {
                row.apply_position(-correction * row.mass, bodies);
            }
        }
    }
    for row in rows.iter().filter(|r| is_swept(r)) {
        if row.role == RowRole::Joint {
            visited += 1;
            let c = row.position_error(bodies);
            joints_ok &= c.abs() <= p.slop;
            let correction = c.clamp(-p.max_correction, p.max_correction);
            if correction != 0.0 {
                row.apply_position(-correction * row.mass, bodies);
            }
        }
    }
    (min_separation, joints_ok, visited)
}

/// The registry's entry of `pgs-ngs`.
pub static PGS_NGS: lcpbench_solvers::registry::SolverEntry =
    lcpbench_solvers::registry::SolverEntry {
        name: "pgs-ngs",
        summary: "Box2D 2.x step: velocity sweeps of sequential impulses (no position bias), then \
                 nonlinear Gauss-Seidel position sweeps",
        problem_classes:
            "scenes only; frictionless and box friction (no pyramid, no cone), joints; moves \
                 the bodies (substeps); a fixed number of velocity sweeps (rarely converged), \
                 penetration corrected by position sweeps that keep a slop; warm-startable",
        iteration_unit: "velocity and position sweeps, summed over the substeps",
        iterative: true,
        relaxation: None,
        params: PARAMS,
        make: lcpbench_solvers::registry::Make::Body(&crate::body_solvers::BodyMake {
            make: |params| Box::new(PgsNgs::new(*params)),
            takes_joints: true,
            substeps: true,
        }),
    };

impl BodySolver for PgsNgs {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::PgsNgs
    }

    fn params(&self) -> Params {
        self.params
    }

    /// The step on the system alone: its free velocities already hold gravity, so gravity is
    /// zero here; the impulse is the step's total.
    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
        let out = self.step(system, Vector3::zeros(), settings);
        BodySweep::from(out)
    }

    fn advance(&mut self, input: &SubstepInput<'_>) -> Option<SubstepOutcome> {
        Some(self.step(input.system, input.gravity, input.settings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builder::JacobianBlock;
    use crate::substep::state::{SolverBody, SolverRow};
    use nalgebra::{Matrix3, UnitQuaternion};

    /// One dynamic body (unit mass, unit inertia) and one row along `z` at the body's centre.
    fn one_row(role: RowRole, c0: f64) -> SolverState {
        let body = SolverBody {
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            inv_mass: 1.0,
            inv_inertia: Matrix3::identity(),
            dp: Vector3::zeros(),
            dtheta: Vector3::zeros(),
            dq: UnitQuaternion::identity(),
        };
        let row = SolverRow {
            role,
            blocks: [
                JacobianBlock {
                    body: 0,
                    linear: Vector3::z(),
                    angular: Vector3::zeros(),
                },
                JacobianBlock::default(),
            ],
            response: [
                (Vector3::z(), Vector3::zeros()),
                (Vector3::zeros(), Vector3::zeros()),
            ],
            sides: 1,
            k: 1.0,
            mass: 1.0,
            c0,
            mu: 0.0,
            restitution: 0.0,
            approach: 0.0,
        };
        SolverState {
            bodies: vec![body],
            rows: vec![row],
        }
    }

    const BOX2D: NgsParams = NgsParams {
        beta: 0.2,
        slop: 0.005,
        max_correction: 0.2,
    };

    /// Box2D's contact correction: `C = −0.05` moves by `−clamp(0.2 (C + slop), −0.2, 0) / k =
    /// 0.009`, the pass is not good enough (`C < −3 slop`); a deep `C = −2` is clamped to 0.2.
    #[test]
    fn contact_correction_is_box2d_s() {
        let mut s = one_row(RowRole::Normal(0), -0.05);
        let (ok, visited) = position_pass(&mut s, &BOX2D);
        assert_eq!((ok, visited), (false, 1));
        assert!((s.bodies[0].dp.z - 0.009).abs() < 1e-15);
        let mut s = one_row(RowRole::Normal(0), -2.0);
        position_pass(&mut s, &BOX2D);
        assert!((s.bodies[0].dp.z - 0.2).abs() < 1e-15);
        // Within 3 slop: good enough, and within the slop nothing moves.
        let mut s = one_row(RowRole::Normal(0), -0.012);
        assert!(position_pass(&mut s, &BOX2D).0);
        let mut s = one_row(RowRole::Normal(0), -0.004);
        position_pass(&mut s, &BOX2D);
        assert_eq!(s.bodies[0].dp.z, 0.0);
    }

    /// A joint row is corrected fully (no slop, no β) up to `max_correction`.
    #[test]
    fn joint_correction_is_full_and_clamped() {
        let mut s = one_row(RowRole::Joint, 0.03);
        let (ok, _) = position_pass(&mut s, &BOX2D);
        assert!(!ok);
        assert!((s.bodies[0].dp.z + 0.03).abs() < 1e-15);
        assert!(position_pass(&mut s, &BOX2D).0);
        let mut s = one_row(RowRole::Joint, -0.5);
        position_pass(&mut s, &BOX2D);
        assert!((s.bodies[0].dp.z - 0.2).abs() < 1e-15);
    }
}

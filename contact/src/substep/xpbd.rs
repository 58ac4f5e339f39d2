//! `xpbd`: extended position-based dynamics with small steps.
//!
//! Sources: Macklin, Storey, Lu, Terdiman, Chentanez, Jeschke, Müller, "Small Steps in Physics
//! Simulation", SCA 2019 (many substeps, one constraint iteration each); Müller, Macklin,
//! Chentanez, Jeschke, Kim, "Detailed Rigid Body Simulation with Extended Position Based
//! Dynamics", SCA 2020 (rigid bodies, contacts, friction, restitution: its Algorithm 2 and §3.5,
//! §3.6); Macklin, Müller, Chentanez, "XPBD: Position-Based Simulation of Compliant Constrained
//! Dynamics", MIG 2016 (compliance `α` and damping `γ`, eq. 26).
//!
//! # The loop
//! The step `dt` is split into `substeps` substeps of `h = dt / substeps`. Each substep:
//!
//! 1. save every body's pose change `Δx_prev = (Δp, Δθ)` and every row's position error
//!    `C_prev` (both at the substep's start);
//! 2. integrate velocities: `v += h g`;
//! 3. predict positions: `Δx += h v` ([`SolverState::integrate_positions`]);
//! 4. the multipliers start at `λ = 0` (the papers'); with `warm = 1` instead, the multipliers
//!    of the previous substep (of the previous step for the first substep, `λ = h f_warm`) are
//!    applied first as position corrections `Δx += M⁻¹Jᵀ λ` (Box2D v3's warm start, carried
//!    over to positions; see "Warm starting" below for why it is not the default);
//! 5. `iterations` position passes, each a Gauss–Seidel sweep on the accumulated multipliers
//!    over the normal and joint rows in the system's order, then over the friction rows, each
//!    against its normal multiplier of this pass (sweeping a contact's friction right after
//!    its normal lets the first of a box's four contacts, which takes most of the correction
//!    in a pass from zero, push the box sideways: a resting box then drifts 2.4 mm in 5 s,
//!    against 4e-7 m with friction last):
//!    * normal row: `C = C₀ + J Δx`;
//!      `Δλ = (−C − α̃ λ − γ (C − C_prev)) / ((1 + γ) k + α̃)`, `λ ← max(0, λ + Δλ)`, with
//!      `k = J M⁻¹ Jᵀ`, `α̃ = α / h²` (`α` the contact compliance) and `γ` the damping (0 unless
//!      `hertz > 0`). From `λ = 0` this is the paper's "if `C < 0`" rule: a row with `C ≥ 0`
//!      gets `Δλ ≤ 0`, clamped to nothing; the accumulated form lets a warm-started row let go;
//!    * friction row (static friction by position, Müller 2020 §3.5): the tangential
//!      displacement over the substep `d = J_t (Δx − Δx_prev) = C − C_prev`, corrected to zero
//!      by `Δλ_t = −d / k_t`, the accumulated `λ_t` clamped to `±μ λ_n` (the box friction
//!      bound on the multiplier of the same substep: a contact that would need more slides,
//!      and the clamped multiplier is the kinetic friction `μ f_n`; Müller 2020 applies the
//!      static correction whole or not at all and leaves sliding to the velocity pass);
//!    * joint row: `Δλ = (−C − α̃_j λ) / (k + α̃_j)`, `λ += Δλ` (no clamp), `α̃_j =
//!      joint_compliance / h²`;
//!
//!    each update applied at once: `Δx += M⁻¹ Jᵀ Δλ` ([`SolverRow::apply_position`]);
//! 6. velocities from positions: `v = (Δp − Δp_prev) / h`, `ω = (Δθ − Δθ_prev) / h`;
//! 7. the velocity pass (only for contacts whose normal multiplier is positive, Müller 2020
//!    §3.6): restitution, `v_n ← −e · approach` when the contact approached (at the step's
//!    start, [`SolverRow::approach`]) faster than both the builder's restitution threshold and
//!    `2 |g| h` (eq. 34/35), else `v_n ← 0` (the paper's `e = 0`, which also removes the
//!    separating speed that pushing out an overlap produced; rigid contacts only: a soft
//!    contact's spring and damping set its normal velocity, and zeroing it every substep would
//!    turn the spring into a slow creep); then dynamic friction on each friction row: the
//!    friction impulse of the substep (`λ_t / h` from the position pass plus this pass's)
//!    brought towards stopping the tangential velocity and kept within `±μ p_n`, with `p_n`
//!    the substep's normal impulse, `λ_n / h` plus this pass's normal update (eq. 30 with the
//!    bound on the impulse — the paper's `h μ_d |f_n|` is an impulse, divided by `k_t` to give
//!    a velocity change — counting what the position pass already applied, so friction is not
//!    applied twice, and the normal impulse of the whole substep: without the normal update in
//!    the bound, a box sliding on an incline accelerates 2 % too fast). With the clamped
//!    position pass it acts on the tangential velocity left within the cone, e.g. by the
//!    normal update.
//!
//! There is one friction coefficient per contact, used as both `μ_s` and `μ_d`. Joints get no
//! velocity pass (no joint damping).
//!
//! # Rows linearised at the step's start
//! The rows are those of the step's [`ContactSystem`]: contact points, normals, tangents and
//! joint anchors found at the step's start, held over the step, and `C = C₀ + J Δx` is the
//! first-order change of the constraint with the bodies' motion since then ([`super::state`]).
//! This is what makes collision detection per substep unnecessary (the paper re-evaluates the
//! exact constraint functions at every iteration, and runs collision detection once per step
//! with a widened margin); the price is that the constraints are linear over the step: a
//! pendulum's rod keeps its direction of the step's start, and a body that rotates a lot in
//! one step sees its contacts at their old lever arms.
//!
//! # Warm starting
//! Box2D v3 warm-starts each substep with the previous substep's impulses; in a position-level
//! method that is a position correction the bodies' velocity (read back from their motion)
//! already carries once, so it acts as momentum on the solver's error. On one row with a pass
//! that removes a share `ω` of the error (one Gauss–Seidel pass on coupled rows removes less
//! than all of it), the error `(C, h v, λ)` of a substep maps to the next by
//! `[[1−ω, 1−ω, 1−ω], [−ω, 1−ω, 1−ω], [−ω, −ω, 1−ω]]`, whose spectral radius exceeds 1 for
//! `ω < 1/2` (1.10 at `ω = 0.3`): warm-started, a hanging chain of two links blows up within
//! a few steps. Started from `λ = 0` the map is `[[1−ω, 1−ω], [−ω, 1−ω]]`, of spectral radius
//! `√(1−ω) < 1` for `0 < ω ≤ 1`. So `warm = 0` is the default: the step ignores
//! `settings.warm_start` and each substep starts from zero multipliers, as in Macklin et al.
//! 2019 and Müller et al. 2020. `warm = 1` is there to compare, for scenes where one pass
//! resolves each row (a single contact, a single joint). Either way the step returns its last
//! substep's multipliers as impulses for the stepper to store. The kind is not listed as
//! warm-startable ([`crate::BodySolverKind::is_iterative`] is false: a `+warm` run of the
//! default would repeat the cold one); with `warm = 1` the stored impulses reach the first
//! substep whenever the world's warm start is on ([`crate::SimSettings::warm_start`]).
//!
//! # Soft contacts
//! `compliance` (`α`, m/N; 0: rigid) makes every contact a spring of stiffness `1/α`: at rest a
//! contact carrying a force `F` overlaps by `α F`. `hertz > 0` instead sets each contact's
//! spring from a natural frequency `ω = 2π hertz` and damping ratio `zeta`, as the soft step
//! does (Catto 2011): stiffness `k_s = m_eff ω²` with `m_eff = 1/k` the row's effective mass,
//! so `α = k / ω²`, and damping `c = 2 ζ m_eff ω`, which XPBD's damping term takes as
//! `γ = α c / h = 2 ζ / (ω h)`; a body of mass `m` on one contact then rests `g / ω²` deep
//! (`compliance` is not used when `hertz > 0`).
//!
//! # Its last solve as an LCP
//! The stepper measures the shared residual of the last substep's position pass, written as
//! the velocity-level LCP it is equivalent to. The position pass moves the bodies by
//! `M⁻¹ Jᵀ λ`, and the velocity from positions is `v_end = v_pred + M⁻¹ Jᵀ λ / h`, with `v_pred`
//! the velocity after gravity at the substep's start. With `f = λ / h` (the multipliers as
//! impulses over the substep) and `b = J v_pred + C_prev / h` on normal and joint rows,
//! `b = J v_pred` on friction rows:
//!
//! `w = A f + b = J v_end + C_prev / h = (C_prev + h J v_end) / h = C_end / h`
//!
//! on normal and joint rows (`C_end` the position error at the substep's end, before the
//! velocity pass), and `w = J_t v_end` (the tangential displacement over the substep divided by
//! `h`) on friction rows: the speculative velocity LCP whose `w ≥ 0` on a normal row is
//! non-penetration at the substep's end, with `f ≥ 0`, `f_t` within `±μ f_n` and
//! complementarity. Rigid (`compliance = 0`, `hertz = 0`) and converged, the position pass
//! solves it; one Gauss–Seidel pass on coupled rows (a box's four contacts, a chain) or a
//! compliant contact (`C_end = −α̃ λ`, which the LCP calls a violation) leaves a residual. The
//! velocity pass is not part of that LCP.
//!
//! What this does NOT solve: the step's velocity LCP (a position-level problem per substep, its
//! answer read back as velocities), the exact nonlinear constraints (rows are linearised at the
//! step's start), Coulomb's cone (box friction per tangent row), and with `compliance > 0` or
//! `hertz > 0` the rigid contact at all (bodies overlap by design):
//! [`crate::BodySolverKind::relaxation`] says so and the status stays `stalled` unless the
//! residual meets the tolerance.
//!
//! # Parameters
//! [`XPBD_PARAMS`]: `substeps` (20), `iterations` (1: Macklin et al. 2019 trade iterations
//! for substeps, one iteration each), `compliance` (0), `joint_compliance`
//! (0), `hertz` (0: the contact spring from `compliance`), `zeta` (10, Box2D v3's contact
//! damping ratio, used with `hertz`), `restitution` (1: the velocity pass's normal update on;
//! 0: off, normal velocities stay as the position pass left them), `warm` (0: each substep
//! from zero multipliers; 1: Box2D's warm start, see above).
//!
//! # Cost and limits
//! Per substep: three body passes (velocities, positions, velocities from positions), one row
//! update per row in each position pass (and per row warm-started with `warm = 1`), one per
//! contact row in the velocity pass. Sweeps (`iterations` in the step report) count the position passes and the
//! velocity passes, so the default takes `2 × 20 = 40` sweeps a step; `max_iterations` caps
//! them (the remaining substeps only integrate), and the time budget is checked between
//! substeps. Failure modes: Gauss–Seidel with one pass per substep converges slowly on large
//! mass ratios and long chains, which then stretch (at rest the multipliers still balance the
//! weights: a body that does not move over a substep has its gravity displacement undone
//! exactly), and large rotations within one step break the linearisation. Large mass ratios
//! crush the light bodies (in the 1e6:1 heavy-on-light stack the heavy box sinks 0.35 m into
//! them within 0.3 s). Overlaps no
//! position can resolve (the `confined` scene: a block pressed from every side by a box 1 mm
//! too small) blow apart: each substep's corrections, which cannot all be met, are read back
//! as velocities, and the bodies leave at hundreds of m/s within 0.15 s; there is no cap on
//! the push-out speed (Box2D's `contactPushMaxVelocity`, PhysX's maximum depenetration
//! velocity).
//!
//! # Accuracy (defaults, `dt = 0.01`; `contact/tests/substep_xpbd.rs`)
//! A box resting on the ground: drift 4e-7 m and 8e-7 rad over 5 s. A box on a 30° incline
//! with `μ = 0.7`: a creep of first order in the substep (1.6e-4 m in 2 s; 5.3e-5 m with 60
//! substeps); with `μ = 0.3` the sliding acceleration `g (sin α − μ cos α)` to 1e-8. A
//! simple pendulum's period to 2.5e-4. A hanging 20:1 chain: joint impulses equal to the
//! weights below them to 1e-12 once its start-up oscillation has died (3 s), stretched by
//! 6e-5 m. A compliant contact's overlap `α m g` to 1.5e-4, a `hertz` contact's `g / ω²` to
//! 1e-15. A ball dropped with `e = 0.8` rebounds to `e²` of its height within 2.3e-3 at
//! `dt = 1 ms` (6.8e-3 at 10 ms: the approach speed is that of the step's start).

use super::{softness, SubstepOutcome};
use super::{LastSolve, ParamSpec, Params, RowRole, SolverState, StepCost, SubstepInput};
use crate::body_solvers::{BodySolver, BodySolverKind, BodySweep};
use crate::builder::ContactSystem;
use lcpbench_solvers::Settings;
use nalgebra::Vector3;
use std::time::Instant;

/// The parameters of `xpbd`, with their defaults (module doc for their sources).
pub const XPBD_PARAMS: &[ParamSpec] = &[
    ParamSpec::count("substeps", 20, 1, 1000, "substeps per step"),
    ParamSpec::count(
        "iterations",
        1,
        1,
        100,
        "position passes per substep (Macklin et al. 2019: 1)",
    ),
    ParamSpec::real(
        "compliance",
        0.0,
        0.0,
        1.0,
        "contact compliance alpha, m/N (0: rigid); unused when hertz > 0",
    ),
    ParamSpec::real(
        "joint_compliance",
        0.0,
        0.0,
        1.0,
        "joint compliance alpha (0: rigid joints)",
    ),
    ParamSpec::real(
        "hertz",
        0.0,
        0.0,
        1.0e4,
        "contact spring frequency, Hz (0: contact spring from compliance)",
    ),
    ParamSpec::real(
        "zeta",
        softness::CONTACT_ZETA,
        0.0,
        1.0e3,
        "contact damping ratio with hertz > 0 (Box2D v3: 10)",
    ),
    ParamSpec::count(
        "restitution",
        1,
        0,
        1,
        "1: velocity pass sets normal velocities (Mueller 2020 eq. 34); 0: off",
    ),
    ParamSpec::count(
        "warm",
        0,
        0,
        1,
        "1: warm-start each substep with the previous one's multipliers (unstable on chains)",
    ),
];

/// Extended position-based dynamics with small steps (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xpbd {
    params: Params,
    /// Substeps per step \[20\].
    pub substeps: usize,
    /// Position passes per substep \[1\].
    pub iterations: usize,
    /// Contact compliance `α`, m/N \[0\].
    pub compliance: f64,
    /// Joint compliance \[0\].
    pub joint_compliance: f64,
    /// Contact spring frequency, Hz; 0 for the spring of `compliance` \[0\].
    pub hertz: f64,
    /// Contact damping ratio with `hertz > 0` \[10\].
    pub zeta: f64,
    /// The velocity pass's normal update (restitution) \[true\].
    pub restitution: bool,
    /// Warm-start each substep with the previous substep's multipliers \[false\].
    pub warm: bool,
}

impl Default for Xpbd {
    fn default() -> Self {
        Self::new(Params::defaults(XPBD_PARAMS))
    }
}

impl Xpbd {
    /// The solver with `params` (which follow [`XPBD_PARAMS`]).
    pub fn new(params: Params) -> Self {
        Self {
            params,
            substeps: params.count("substeps").max(1),
            iterations: params.count("iterations").max(1),
            compliance: params.get("compliance"),
            joint_compliance: params.get("joint_compliance"),
            hertz: params.get("hertz"),
            zeta: params.get("zeta"),
            restitution: params.count("restitution") == 1,
            warm: params.count("warm") == 1,
        }
    }

    /// True when contacts are springs (`compliance > 0` or `hertz > 0`).
    pub fn soft_contacts(&self) -> bool {
        self.compliance > 0.0 || self.hertz > 0.0
    }

    /// Each row's `(α̃, γ)` over a substep of `h`: the contact spring on normal rows, the joint
    /// compliance on joint rows, rigid elsewhere.
    fn softness(&self, state: &SolverState, h: f64) -> Vec<(f64, f64)> {
        let omega = 2.0 * std::f64::consts::PI * self.hertz;
        state
            .rows
            .iter()
            .map(|row| match row.role {
                RowRole::Normal(_) if self.hertz > 0.0 => (
                    row.k / (omega * omega) / (h * h),
                    2.0 * self.zeta / (omega * h),
                ),
                RowRole::Normal(_) => (self.compliance / (h * h), 0.0),
                RowRole::Joint => (self.joint_compliance / (h * h), 0.0),
                RowRole::Friction { .. } | RowRole::Other => (0.0, 0.0),
            })
            .collect()
    }

    /// The whole step (module doc).
    pub fn step(&self, input: &SubstepInput<'_>) -> SubstepOutcome {
        let system = input.system;
        let settings = input.settings;
        let deadline = settings.time_budget.map(|b| Instant::now() + b);
        let substeps = self.substeps;
        let h = system.h / substeps as f64;
        let gravity = input.gravity;
        let bounce_floor = system.restitution_threshold.max(2.0 * gravity.norm() * h);
        let mut state = SolverState::new(system, &gravity);
        let n = state.rows.len();
        let soft = self.softness(&state, h);

        // With `warm`: the previous step's impulses as this step's first multipliers,
        // projected onto the bounds (normal ≥ 0, friction within ±μ λ_n, nothing on rows not
        // swept).
        let mut lambda = vec![0.0; n];
        if let Some(warm) = settings.warm_start.as_deref().filter(|_| self.warm) {
            for (l, &w) in lambda.iter_mut().zip(warm) {
                if w.is_finite() {
                    *l = w * h;
                }
            }
        }
        project(&state, &mut lambda);

        let mut f_step = vec![0.0; n];
        let mut f_vel = vec![0.0; n];
        let mut c_prev = vec![0.0; n];
        let mut rate_pred = vec![0.0; n];
        let mut prev = vec![(Vector3::zeros(), Vector3::zeros()); state.bodies.len()];
        let mut sweeps_left = settings.max_iterations;
        let mut iterations = 0;
        let mut cost = StepCost::default();
        let mut timed_out = false;
        let mut last: Option<LastSolve> = None;

        for s in 0..substeps {
            if s > 0 && !timed_out && deadline.is_some_and(|d| Instant::now() >= d) {
                timed_out = true;
            }
            let solving = !timed_out && sweeps_left > 0;
            // 1. Pose changes and position errors at the substep's start.
            for (p, b) in prev.iter_mut().zip(&state.bodies) {
                *p = (b.dp, b.dtheta);
            }
            for (c, row) in c_prev.iter_mut().zip(&state.rows) {
                *c = row.position_error(&state.bodies);
            }
            // 2, 3. Velocities after gravity, predicted positions.
            state.integrate_velocities(&gravity, h);
            if solving {
                for (r, row) in rate_pred.iter_mut().zip(&state.rows) {
                    *r = row.rate(&state.bodies);
                }
            }
            state.integrate_positions(h);
            cost.body_passes += 2;

            if solving {
                // 4. Zero multipliers, or with `warm` the previous substep's (or step's)
                // applied first.
                if self.warm {
                    let (rows, bodies) = (&state.rows, &mut state.bodies);
                    for (row, &l) in rows.iter().zip(&lambda) {
                        if l != 0.0 {
                            row.apply_position(l, bodies);
                            cost.row_updates += 1;
                        }
                    }
                } else {
                    lambda.iter_mut().for_each(|l| *l = 0.0);
                }
                // 5. Position passes.
                for _ in 0..self.iterations {
                    if sweeps_left == 0 {
                        break;
                    }
                    sweeps_left -= 1;
                    iterations += 1;
                    cost.row_updates += position_pass(&mut state, &mut lambda, &c_prev, &soft);
                }
            }

            // 6. Velocities from positions.
            for (b, (dp, dth)) in state.bodies.iter_mut().zip(&prev) {
                if !b.is_static() {
                    b.v = (b.dp - dp) / h;
                    b.w = (b.dtheta - dth) / h;
                }
            }
            cost.body_passes += 1;

            if !solving {
                continue;
            }
            // The LCP of this substep's position pass (module doc), before the velocity pass
            // changes the velocities.
            let b: Vec<f64> = state
                .rows
                .iter()
                .zip(rate_pred.iter().zip(&c_prev))
                .map(|(row, (&r, &c))| match row.role {
                    RowRole::Normal(_) | RowRole::Joint => r + c / h,
                    RowRole::Friction { .. } | RowRole::Other => r,
                })
                .collect();
            last = Some(LastSolve {
                f: lambda.iter().map(|l| l / h).collect(),
                b,
                what: format!("position pass of substep {} of {substeps}", s + 1),
            });

            // 7. Velocity pass.
            f_vel.iter_mut().for_each(|f| *f = 0.0);
            if !system.info.is_empty() && sweeps_left > 0 {
                sweeps_left -= 1;
                iterations += 1;
                cost.row_updates +=
                    self.velocity_pass(system, &mut state, &lambda, &mut f_vel, h, bounce_floor);
            }
            for ((f, l), v) in f_step.iter_mut().zip(&lambda).zip(&f_vel) {
                *f += l / h + v;
            }
        }

        let last = last.unwrap_or_else(|| LastSolve {
            f: vec![0.0; n],
            b: rate_pred
                .iter()
                .zip(&c_prev)
                .zip(&state.rows)
                .map(|((&r, &c), row)| match row.role {
                    RowRole::Normal(_) | RowRole::Joint => r + c / h,
                    RowRole::Friction { .. } | RowRole::Other => r,
                })
                .collect(),
            what: "no position pass (the sweep cap or the time budget came first)".into(),
        });
        SubstepOutcome {
            state,
            f_step,
            warm: lambda.iter().map(|l| l / h).collect(),
            last,
            iterations,
            substeps,
            cost,
            timed_out,
        }
    }

    /// The velocity pass over the contacts whose normal multiplier is positive (module doc,
    /// step 7); returns the row updates.
    fn velocity_pass(
        &self,
        system: &ContactSystem,
        state: &mut SolverState,
        lambda: &[f64],
        f_vel: &mut [f64],
        h: f64,
        bounce_floor: f64,
    ) -> u64 {
        let (rows, bodies) = (&state.rows, &mut state.bodies);
        let mut updates = 0;
        for info in &system.info {
            let i = info.normal_row;
            let normal = &rows[i];
            if lambda[i] <= 0.0 || normal.k == 0.0 || !matches!(normal.role, RowRole::Normal(_)) {
                continue;
            }
            if self.restitution && !self.soft_contacts() {
                let e = if normal.approach < -bounce_floor {
                    normal.restitution
                } else {
                    0.0
                };
                let target = -e * normal.approach;
                let d = (target - normal.rate(bodies)) * normal.mass;
                normal.apply(d, bodies);
                f_vel[i] += d;
                updates += 1;
            }
            // The substep's normal impulse: `λ_n / h` and this pass's normal update.
            let bound = (lambda[i] / h + f_vel[i]).max(0.0);
            for r in info.friction_rows.clone() {
                let row = &rows[r];
                if row.k == 0.0 || !matches!(row.role, RowRole::Friction { .. }) {
                    continue;
                }
                let c = row.mu * bound;
                let p = lambda[r] / h + f_vel[r];
                let new = (p - row.rate(bodies) * row.mass).clamp(-c, c);
                let d = new - p;
                if d != 0.0 {
                    row.apply(d, bodies);
                    f_vel[r] += d;
                }
                updates += 1;
            }
        }
        updates
    }
}

/// Project multipliers onto the rows' bounds: normal rows `≥ 0`, friction rows within
/// `±μ λ_n`, rows not swept (pyramid slack) zero, joint rows free.
fn project(state: &SolverState, lambda: &mut [f64]) {
    for (i, row) in state.rows.iter().enumerate() {
        match row.role {
            RowRole::Normal(_) => lambda[i] = lambda[i].max(0.0),
            RowRole::Other => lambda[i] = 0.0,
            RowRole::Friction { .. } | RowRole::Joint => {}
        }
    }
    for (i, row) in state.rows.iter().enumerate() {
        if let RowRole::Friction { normal } = row.role {
            let c = row.mu * lambda[normal];
            lambda[i] = lambda[i].clamp(-c, c);
        }
    }
}

/// One Gauss–Seidel position pass over the rows in order (module doc, step 5); returns the
/// row updates.
fn position_pass(
    state: &mut SolverState,
    lambda: &mut [f64],
    c_prev: &[f64],
    soft: &[(f64, f64)],
) -> u64 {
    let (rows, bodies) = (&state.rows, &mut state.bodies);
    let mut updates = 0;
    // Normal and joint rows first, then the friction rows against this pass's normal
    // multipliers.
    let order = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| !matches!(r.role, RowRole::Friction { .. }))
        .chain(
            rows.iter()
                .enumerate()
                .filter(|(_, r)| matches!(r.role, RowRole::Friction { .. })),
        );
    for (i, row) in order {
        if row.k == 0.0 {
            continue;
        }
        let new = match row.role {
            RowRole::Normal(_) => {
                let c = row.position_error(bodies);
                let (alpha, gamma) = soft[i];
                let d = (-c - alpha * lambda[i] - gamma * (c - c_prev[i]))
                    / ((1.0 + gamma) * row.k + alpha);
                (lambda[i] + d).max(0.0)
            }
            RowRole::Friction { normal } => {
                let slip = row.position_error(bodies) - c_prev[i];
                let c = row.mu * lambda[normal];
                (lambda[i] - slip / row.k).clamp(-c, c)
            }
            RowRole::Joint => {
                let c = row.position_error(bodies);
                let (alpha, _) = soft[i];
                lambda[i] + (-c - alpha * lambda[i]) / (row.k + alpha)
            }
            RowRole::Other => continue,
        };
        let d = new - lambda[i];
        if d != 0.0 {
            row.apply_position(d, bodies);
        }
        lambda[i] = new;
        updates += 1;
    }
    updates
}

/// The registry's entry of `xpbd`.
pub static XPBD: lcpbench_solvers::registry::SolverEntry = lcpbench_solvers::registry::SolverEntry {
    name: "xpbd",
    summary: "extended position-based dynamics with small steps (Macklin et al. 2019, Mueller \
                 et al. 2020): position corrections per substep, velocities from positions",
    problem_classes: "scenes only; frictionless and box friction (no pyramid, no cone), joints; \
                 substeps of Gauss-Seidel position corrections on rows linearised at the step's \
                 start, each substep from zero multipliers (warm=1: from the previous substep's and \
                 step's); rigid or compliant contacts (compliance, hertz); solves a position-level \
                 problem per substep, not the step's LCP; slow on mass ratios and long chains; \
                 overlaps it cannot resolve blow apart",
    iteration_unit: "position and velocity passes, summed over the substeps",
    iterative: false,
    relaxation: Some(
        "position-level constraints over small substeps (XPBD), compliant when \
                 compliance > 0; not the step's velocity LCP",
    ),
    params: XPBD_PARAMS,
    make: lcpbench_solvers::registry::Make::Body(&crate::body_solvers::BodyMake {
        make: |params| Box::new(Xpbd::new(*params)),
        takes_joints: true,
        substeps: true,
    }),
};

impl BodySolver for Xpbd {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::Xpbd
    }

    fn params(&self) -> Params {
        self.params
    }

    fn advance(&mut self, input: &SubstepInput<'_>) -> Option<SubstepOutcome> {
        Some(self.step(input))
    }

    /// On a system alone: the step from the system's free velocities (gravity already in
    /// them, so no gravity is added), its total impulse as `f`.
    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
        let out = self.step(&SubstepInput {
            system,
            gravity: Vector3::zeros(),
            settings,
        });
        BodySweep::from(out)
    }
}

//! The data the substepping solvers sweep over, laid out once per step: solver bodies (velocity,
//! inverse mass, pose change since the step's start) and constraint rows (the Jacobian blocks,
//! `M⁻¹ Jᵀ` per side, the effective mass, the position error at the step's start, bounds and the
//! friction coupling).
//!
//! Contact points, normals and anchors are those found at the step's start (no collision per
//! substep, as in Box2D v3 and Rapier): a row's position error during the step is
//! `C = C₀ + J Δx`, with `Δx = (Δp, Δθ)` the body's translation and rotation since the step's
//! start (the first-order change of the separation along the fixed normal with anchors moved
//! rigidly with the body: Box2D v3 computes it the same way from its bodies' delta positions).

use crate::builder::{BodyVelocity, ContactSystem, JacobianBlock, RowKind};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// One body as the substepping solvers see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverBody {
    /// Linear velocity of the centre of mass.
    pub v: Vector3<f64>,
    /// Angular velocity, world frame.
    pub w: Vector3<f64>,
    /// `1/m` (0 for a static body).
    pub inv_mass: f64,
    /// World-frame inverse inertia at the step's start (held over the step).
    pub inv_inertia: Matrix3<f64>,
    /// Translation since the step's start.
    pub dp: Vector3<f64>,
    /// Rotation since the step's start, as a rotation vector to first order (`Σ h ω`).
    pub dtheta: Vector3<f64>,
    /// Rotation since the step's start (exact composition of the substeps' rotations).
    pub dq: UnitQuaternion<f64>,
}

impl SolverBody {
    /// True for a body that no impulse moves (static).
    pub fn is_static(&self) -> bool {
        self.inv_mass == 0.0
    }

    /// Its velocity as the builder's type.
    pub fn velocity(&self) -> BodyVelocity {
        BodyVelocity {
            linear: self.v,
            angular: self.w,
        }
    }

    /// Move by `h` at the current velocity: `Δp += h v`, `Δθ += h ω`, `Δq ← normalise(Δq + h/2
    /// ω ⊗ Δq)` (the same update as the stepper's [`crate::integrate::advance_pose`]).
    pub fn integrate_position(&mut self, h: f64) {
        if self.is_static() {
            return;
        }
        self.dp += self.v * h;
        self.dtheta += self.w * h;
        let w = Quaternion::new(0.0, self.w.x, self.w.y, self.w.z);
        let q = self.dq.quaternion() + (w * self.dq.quaternion()) * (0.5 * h);
        self.dq = UnitQuaternion::from_quaternion(q);
    }
}

/// What a row stands for, as the substepping solvers treat it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowRole {
    /// A contact's normal row (`λ ≥ 0`), contact index.
    Normal(usize),
    /// A friction row bounded by `±μ λ_n` of row `normal`.
    Friction {
        /// The normal row.
        normal: usize,
    },
    /// A joint's equality row.
    Joint,
    /// A row the substepping solvers do not sweep (a pyramid slack row).
    Other,
}

/// One constraint row laid out for the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverRow {
    /// What the row stands for.
    pub role: RowRole,
    /// Its (at most two) Jacobian blocks; `sides` of them are used.
    pub blocks: [JacobianBlock; 2],
    /// `M⁻¹ Jᵀ` of each block: (linear, angular) velocity change per unit impulse.
    pub response: [(Vector3<f64>, Vector3<f64>); 2],
    /// Number of blocks used (0, 1 or 2).
    pub sides: u8,
    /// `J M⁻¹ Jᵀ` (the row's diagonal of `A`).
    pub k: f64,
    /// `1 / k` (0 for a row without dynamic bodies).
    pub mass: f64,
    /// Position error at the step's start: the gap of a normal row, the constraint error of a
    /// joint row, 0 on friction rows.
    pub c0: f64,
    /// Friction coefficient (friction rows; 0 elsewhere).
    pub mu: f64,
    /// Restitution coefficient (normal rows; 0 elsewhere).
    pub restitution: f64,
    /// Normal velocity at the step's start, before gravity (normal rows): what restitution
    /// reverses.
    pub approach: f64,
}

impl SolverRow {
    /// `J v` on the current velocities.
    #[inline]
    pub fn rate(&self, bodies: &[SolverBody]) -> f64 {
        let mut r = 0.0;
        for b in &self.blocks[..self.sides as usize] {
            let body = &bodies[b.body];
            r += b.linear.dot(&body.v) + b.angular.dot(&body.w);
        }
        r
    }

    /// Apply an impulse `λ` along the row: `v += M⁻¹ Jᵀ λ`.
    #[inline]
    pub fn apply(&self, impulse: f64, bodies: &mut [SolverBody]) {
        for (b, (lin, ang)) in self.blocks[..self.sides as usize]
            .iter()
            .zip(&self.response)
        {
            let body = &mut bodies[b.body];
            body.v += lin * impulse;
            body.w += ang * impulse;
        }
    }

    /// The position error now: `C₀ + J Δx`.
    #[inline]
    pub fn position_error(&self, bodies: &[SolverBody]) -> f64 {
        let mut c = self.c0;
        for b in &self.blocks[..self.sides as usize] {
            let body = &bodies[b.body];
            c += b.linear.dot(&body.dp) + b.angular.dot(&body.dtheta);
        }
        c
    }

    /// Move the bodies by a position correction `δ` along the row (`Δx += M⁻¹ Jᵀ δ`), for the
    /// position-level passes (nonlinear Gauss–Seidel, XPBD).
    #[inline]
    pub fn apply_position(&self, delta: f64, bodies: &mut [SolverBody]) {
        for (b, (lin, ang)) in self.blocks[..self.sides as usize]
            .iter()
            .zip(&self.response)
        {
            let body = &mut bodies[b.body];
            body.dp += lin * delta;
            let dth = ang * delta;
            body.dtheta += dth;
            let w = Quaternion::new(0.0, dth.x, dth.y, dth.z);
            let q = body.dq.quaternion() + (w * body.dq.quaternion()) * 0.5;
            body.dq = UnitQuaternion::from_quaternion(q);
        }
    }

    /// True when the row joins a body to a static one (or the world).
    pub fn is_static_pair(&self) -> bool {
        self.sides < 2
    }
}

/// The bodies and rows of one step.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverState {
    /// Every body of the world, in the world's order.
    pub bodies: Vec<SolverBody>,
    /// Every row of the step's system, in the system's order.
    pub rows: Vec<SolverRow>,
}

impl SolverState {
    /// The state at the step's start: velocities before gravity (`u = u* − h g` for dynamic
    /// bodies), no pose change, rows from `system` with their position errors
    /// ([`ContactSystem::position_error`]).
    pub fn new(system: &ContactSystem, gravity: &Vector3<f64>) -> Self {
        let h = system.h;
        let bodies: Vec<SolverBody> = system
            .inv_mass
            .iter()
            .zip(&system.free_velocity)
            .map(|(m, u)| {
                let dynamic = m.inv_mass > 0.0;
                SolverBody {
                    v: if dynamic {
                        u.linear - gravity * h
                    } else {
                        u.linear
                    },
                    w: u.angular,
                    inv_mass: m.inv_mass,
                    inv_inertia: m.inv_inertia,
                    dp: Vector3::zeros(),
                    dtheta: Vector3::zeros(),
                    dq: UnitQuaternion::identity(),
                }
            })
            .collect();
        let mut role = vec![RowRole::Other; system.n()];
        let mut mu = vec![0.0; system.n()];
        let mut restitution = vec![0.0; system.n()];
        for (c, info) in system.info.iter().enumerate() {
            role[info.normal_row] = RowRole::Normal(c);
            restitution[info.normal_row] = info.restitution;
            if info.slack_row.is_none() {
                for r in info.friction_rows.clone() {
                    role[r] = RowRole::Friction {
                        normal: info.normal_row,
                    };
                    mu[r] = info.mu;
                }
            }
        }
        for j in &system.joints {
            for r in j.rows.clone() {
                role[r] = RowRole::Joint;
            }
        }
        let rows = system
            .rows
            .iter()
            .enumerate()
            .map(|(i, row)| {
                let mut blocks = [JacobianBlock::default(); 2];
                let mut response = [(Vector3::zeros(), Vector3::zeros()); 2];
                let mut k = 0.0;
                for (s, b) in row.blocks.iter().enumerate() {
                    let m = &system.inv_mass[b.body];
                    blocks[s] = *b;
                    response[s] = (b.linear * m.inv_mass, m.inv_inertia * b.angular);
                    k += b.linear.dot(&response[s].0) + b.angular.dot(&response[s].1);
                }
                let role = if matches!(row.kind, RowKind::Slack { .. }) {
                    RowRole::Other
                } else {
                    role[i]
                };
                let mut out = SolverRow {
                    role,
                    blocks,
                    response,
                    sides: row.blocks.len() as u8,
                    k,
                    mass: if k > 0.0 { 1.0 / k } else { 0.0 },
                    c0: system.position_error[i],
                    mu: mu[i],
                    restitution: restitution[i],
                    approach: 0.0,
                };
                if matches!(role, RowRole::Normal(_)) {
                    out.approach = out.rate(&bodies);
                }
                out
            })
            .collect();
        Self { bodies, rows }
    }

    /// Add `h g` to every dynamic body's velocity.
    pub fn integrate_velocities(&mut self, gravity: &Vector3<f64>, h: f64) {
        for b in self.bodies.iter_mut().filter(|b| !b.is_static()) {
            b.v += gravity * h;
        }
    }

    /// Move every dynamic body by `h` at its velocity.
    pub fn integrate_positions(&mut self, h: f64) {
        for b in &mut self.bodies {
            b.integrate_position(h);
        }
    }

    /// `J v` of every row on the current velocities.
    pub fn rates(&self) -> Vec<f64> {
        self.rows.iter().map(|r| r.rate(&self.bodies)).collect()
    }

    /// Apply the impulses `f` (one per row): `v += M⁻¹ Jᵀ f`.
    pub fn apply_all(&mut self, f: &[f64]) {
        for (row, &l) in self.rows.iter().zip(f) {
            if l != 0.0 {
                row.apply(l, &mut self.bodies);
            }
        }
    }
}

/// The work a step took, counted as Catto's solver comparison counts it: constraint-row updates
/// (one row's impulse computed and applied, in any pass) and body passes (one pass over the
/// bodies: integrating velocities or positions, or applying a Jacobi pass's impulses).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct StepCost {
    /// Constraint-row updates.
    pub row_updates: u64,
    /// Passes over the bodies.
    pub body_passes: u64,
}

impl StepCost {
    /// Add another count.
    pub fn add(&mut self, other: StepCost) {
        self.row_updates += other.row_updates;
        self.body_passes += other.body_passes;
    }
}

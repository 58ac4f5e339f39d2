//! Time integration of rigid-body states (Baraff–Witkin state `x, q, P, L`).
//!
//! * Bodies with contact rows take a **semi-implicit (symplectic) Euler** step: momenta first,
//!   `P⁺ = P + h m g + ΔP_contact`, `L⁺ = L + ΔL_contact`, then positions with the new velocities,
//!   `x⁺ = x + h v⁺` and `q⁺ = normalise(q + h/2 · ω⁺ ⊗ q)` with `ω⁺ = R I_body⁻¹ Rᵀ L⁺`.
//! * Bodies in free flight take a classical **RK4** step of
//!   `ẋ = P/m, Ṗ = m g, q̇ = ½ ω(q, L) ⊗ q, L̇ = 0`, which is exact for the translation under
//!   constant gravity and keeps the kinetic energy of torque-free tumbling to `O(h⁴)` per unit
//!   time; `L` is constant in the world frame by construction.
//!
//! The quaternion is renormalised after every step.

use crate::body::RigidBody;
use crate::builder::BodyVelocity;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// `q + s · (ω ⊗ q)` for a pure-vector quaternion `ω`.
fn add_spin(q: &Quaternion<f64>, omega: &Vector3<f64>, s: f64) -> Quaternion<f64> {
    let w = Quaternion::new(0.0, omega.x, omega.y, omega.z);
    q + (w * q) * s
}

/// Angular velocity `R(q) I_body⁻¹ R(q)ᵀ L` at a (not necessarily unit) quaternion.
fn omega_at(body: &RigidBody, q: &Quaternion<f64>, l: &Vector3<f64>) -> Vector3<f64> {
    let r = UnitQuaternion::from_quaternion(*q).to_rotation_matrix();
    r.matrix() * (body.inv_inertia_body * (r.matrix().transpose() * l))
}

/// Momentum half of the semi-implicit Euler step: `P += h m g + dp`, `L += dl`.
pub fn apply_momentum(
    body: &mut RigidBody,
    h: f64,
    gravity: &Vector3<f64>,
    dp: &Vector3<f64>,
    dl: &Vector3<f64>,
) {
    if body.is_static {
        return;
    }
    body.linear_momentum += gravity * (body.mass * h) + dp;
    body.angular_momentum += dl;
}

/// Pose half of the semi-implicit Euler step over a time `h` with the current velocities (plus
/// a split-impulse pseudo-velocity): `x += h v`, `q ← normalise(q + h/2 ω ⊗ q)`.
pub fn advance_pose(body: &mut RigidBody, h: f64, pseudo: Option<&BodyVelocity>) {
    if body.is_static {
        return;
    }
    let mut v = body.velocity();
    let mut w = body.angular_velocity();
    if let Some(p) = pseudo {
        v += p.linear;
        w += p.angular;
    }
    body.position += v * h;
    let q = add_spin(body.orientation.quaternion(), &w, 0.5 * h);
    body.orientation = UnitQuaternion::from_quaternion(q);
}

/// Semi-implicit Euler step of a body in contact. `dp`/`dl` are the contact impulses (linear and
/// angular about the centre of mass); `pseudo` a split-impulse velocity that moves the body
/// without adding momentum.
pub fn symplectic_euler(
    body: &mut RigidBody,
    h: f64,
    gravity: &Vector3<f64>,
    dp: &Vector3<f64>,
    dl: &Vector3<f64>,
    pseudo: Option<&BodyVelocity>,
) {
    apply_momentum(body, h, gravity, dp, dl);
    advance_pose(body, h, pseudo);
}

/// RK4 step of a body in free flight under gravity.
pub fn rk4_free_flight(body: &mut RigidBody, h: f64, gravity: &Vector3<f64>) {
    if body.is_static {
        return;
    }
    let l = body.angular_momentum;
    let q0 = *body.orientation.quaternion();
    let dq = |q: &Quaternion<f64>| {
        let w = omega_at(body, q, &l);
        Quaternion::new(0.0, w.x, w.y, w.z) * q * 0.5
    };
    let k1 = dq(&q0);
    let k2 = dq(&(q0 + k1 * (0.5 * h)));
    let k3 = dq(&(q0 + k2 * (0.5 * h)));
    let k4 = dq(&(q0 + k3 * h));
    let q = q0 + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
    // Translation: RK4 is exact for constant acceleration.
    let v0 = body.velocity();
    body.position += v0 * h + gravity * (0.5 * h * h);
    body.linear_momentum += gravity * (body.mass * h);
    body.orientation = UnitQuaternion::from_quaternion(q);
}

/// Kinetic energy `½ m |v|² + ½ ω·L`.
pub fn kinetic_energy(body: &RigidBody) -> f64 {
    if body.is_static {
        return 0.0;
    }
    0.5 * body.mass * body.velocity().norm_squared()
        + 0.5 * body.angular_velocity().dot(&body.angular_momentum)
}

/// Potential energy `−m g·x` in the gravity field.
pub fn potential_energy(body: &RigidBody, gravity: &Vector3<f64>) -> f64 {
    if body.is_static {
        return 0.0;
    }
    -body.mass * gravity.dot(&body.position.coords)
}

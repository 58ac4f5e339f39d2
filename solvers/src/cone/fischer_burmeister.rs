//! The Fischer–Burmeister function of one contact on the second-order cone, and an element of
//! its generalised Jacobian (the kernel of [`crate::ConeNewton`] with
//! [`crate::ConeFunction::FischerBurmeister`], Siconos' `FC3D_NSN_FB`).
//!
//! The friction cone `K = {‖r_T‖ <= mu r_N}` and its dual `K* = {mu ‖v_T‖ <= v_N}` are mapped
//! onto the Lorentz cone `L = {x_0 >= ‖x̄‖}` by `x = (mu r_N, r_T)` and
//! `y = ρ (û_N, mu û_T)` (`û` De Saxcé's modified velocity), which keeps complementarity:
//! `xᵀy = mu ρ rᵀû`. With the Jordan product of `L`, `x ∘ y = (xᵀy, x_0 ȳ + y_0 x̄)`, and the
//! square root of an element of `L` by its spectral decomposition:
//!
//! ```text
//! Φ = x + y − (x ∘ x + y ∘ y)^½
//! ```
//!
//! `Φ = 0` if and only if `L ∋ x ⟂ y ∈ L`, which is Coulomb's law (Fukushima, Luo, Tseng,
//! SIAM J. Optim. 12, 2002). With `s = (x² + y²)^½` and `L_a` the matrix of `v ↦ a ∘ v`,
//! `dΦ = (I − L_s⁻¹ L_x) dx + (I − L_s⁻¹ L_y) dy` where `s` is interior to `L`; on its boundary
//! the smaller eigenvalue of `x² + y²` is floored at [`EIGENVALUE_FLOOR`] of the larger one,
//! and at `x = y = 0` the element `(1 − 1/√2) (dx + dy)` of the scalar function is taken. A
//! frictionless contact (`mu = 0`) takes the scalar function on its normal row and `Φ_T = r_T`.
//!
//! References: M. Fukushima, Z.-Q. Luo, P. Tseng, *Smoothing functions for second-order-cone
//! complementarity problems*, SIAM J. Optim. 12, 2002; V. Acary, M. Brémond, O. Huber, 2018;
//! Siconos numerics, `fc3d_FischerBurmeister_functions.c`.

use crate::cone::natural_map::de_saxce_with_jacobian;
use crate::cone::newton::Linearisation;

/// Floor of the smaller eigenvalue of `x² + y²`, as a fraction of the larger, where the
/// Jacobian is evaluated (the derivative of the square root is unbounded on the boundary of the
/// cone; the floor takes a nearby interior element). At a contact that sticks on the boundary
/// of its cone (`x` on the boundary, `y = 0`: the incline at exactly the friction angle) a floor
/// of `1e-20` leaves the Newton direction so inaccurate that the solve stalls at a relative
/// residual of `2.5e-10`; `1e-12` converges there in 6 to 9 iterations, and on FCLIB
/// `Capsules-i125-1213` at `1e-8` in 26 iterations where `1e-20` took 7,381.
const EIGENVALUE_FLOOR: f64 = 1e-12;

/// `φ(a, b) = a + b − √(a² + b²)` and its partial derivatives (`1 − 1/√2` each at the origin).
fn scalar_fb(a: f64, b: f64) -> (f64, f64, f64) {
    let h = a.hypot(b);
    if h == 0.0 {
        let c = 1.0 - std::f64::consts::FRAC_1_SQRT_2;
        (0.0, c, c)
    } else {
        (a + b - h, 1.0 - a / h, 1.0 - b / h)
    }
}

/// The arrow matrix `L_a` of `v ↦ a ∘ v`.
fn arrow(a: [f64; 3]) -> [[f64; 3]; 3] {
    [[a[0], a[1], a[2]], [a[1], a[0], 0.0], [a[2], 0.0, a[0]]]
}

/// `L_s⁻¹` for `s` interior to the Lorentz cone (`s_0 > ‖s̄‖`).
fn arrow_inverse(s: [f64; 3]) -> [[f64; 3]; 3] {
    let det = s[0] * s[0] - s[1] * s[1] - s[2] * s[2];
    let mut m = [[0.0; 3]; 3];
    m[0][0] = s[0] / det;
    for k in 0..2 {
        m[0][1 + k] = -s[1 + k] / det;
        m[1 + k][0] = -s[1 + k] / det;
        for l in 0..2 {
            let id = if k == l { det } else { 0.0 };
            m[1 + k][1 + l] = (id + s[1 + k] * s[1 + l]) / (s[0] * det);
        }
    }
    m
}

fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

/// The square root of `z` in the Lorentz cone, by its spectral values `λ_1 <= λ_2` (the smaller
/// floored at zero against round-off), with the floored value of `λ_1` used for the Jacobian.
fn sqrt_lorentz(z: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let nz = z[1].hypot(z[2]);
    let w = if nz > 0.0 {
        [z[1] / nz, z[2] / nz]
    } else {
        [1.0, 0.0]
    };
    let l2 = (z[0] + nz).max(0.0);
    let l1 = (z[0] - nz).max(0.0);
    let of = |l1: f64| {
        let (a, b) = (l1.sqrt(), l2.sqrt());
        [0.5 * (a + b), 0.5 * (b - a) * w[0], 0.5 * (b - a) * w[1]]
    };
    (of(l1), of(l1.max(EIGENVALUE_FLOOR * l2)))
}

/// The Fischer–Burmeister function of one contact and an element of its generalised Jacobian.
pub(crate) fn linearise(mu: f64, rho: f64, r: [f64; 3], u: [f64; 3]) -> Linearisation {
    let mut lin = Linearisation {
        phi: [0.0; 3],
        p: [[0.0; 3]; 3],
        q: [[0.0; 3]; 3],
    };
    if mu == 0.0 {
        let (phi, da, db) = scalar_fb(r[0], rho * u[0]);
        lin.phi = [phi, r[1], r[2]];
        lin.p[0][0] = da;
        lin.p[1][1] = 1.0;
        lin.p[2][2] = 1.0;
        lin.q[0][0] = rho * db;
        return lin;
    }
    let (uh, d) = de_saxce_with_jacobian(mu, u);
    let x = [mu * r[0], r[1], r[2]];
    let y = [rho * uh[0], rho * mu * uh[1], rho * mu * uh[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let z = [
        dot(x, x) + dot(y, y),
        2.0 * (x[0] * x[1] + y[0] * y[1]),
        2.0 * (x[0] * x[2] + y[0] * y[2]),
    ];
    let (s, s_jac) = sqrt_lorentz(z);
    for k in 0..3 {
        lin.phi[k] = x[k] + y[k] - s[k];
    }
    // ∂x/∂r and ∂y/∂u.
    let sx = [[mu, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let sy_d = mul(
        &[[rho, 0.0, 0.0], [0.0, rho * mu, 0.0], [0.0, 0.0, rho * mu]],
        &d,
    );
    let (gx, gy) = if s_jac[0] > 0.0 {
        let inv = arrow_inverse(s_jac);
        let (ax, ay) = (mul(&inv, &arrow(x)), mul(&inv, &arrow(y)));
        let mut gx = [[0.0; 3]; 3];
        let mut gy = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                let id = if a == b { 1.0 } else { 0.0 };
                gx[a][b] = id - ax[a][b];
                gy[a][b] = id - ay[a][b];
            }
        }
        (gx, gy)
    } else {
        let c = 1.0 - std::f64::consts::FRAC_1_SQRT_2;
        let g = [[c, 0.0, 0.0], [0.0, c, 0.0], [0.0, 0.0, c]];
        (g, g)
    };
    lin.p = mul(&gx, &sx);
    lin.q = mul(&gy, &sy_d);
    lin
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cone::newton::tests::assert_jacobian_matches_finite_differences;

    #[test]
    fn jacobian_matches_finite_differences() {
        assert_jacobian_matches_finite_differences(linearise);
    }

    /// `Φ` vanishes at the three kinds of solution (take-off, stick, slide) and not off them.
    #[test]
    fn zero_exactly_at_coulombs_law() {
        let (mu, rho) = (0.5, 0.8);
        let norm = |l: Linearisation| l.phi.iter().map(|v| v * v).sum::<f64>().sqrt();
        // Take-off, stick, slide (r_T = −mu r_N u_T / ‖u_T‖, u_N = 0).
        assert!(norm(linearise(mu, rho, [0.0; 3], [1.0, 0.3, -0.2])) <= 1e-15);
        assert!(norm(linearise(mu, rho, [1.0, 0.2, 0.1], [0.0; 3])) <= 1e-15);
        let slide = norm(linearise(mu, rho, [2.0, -0.6, -0.8], [0.0, 0.3, 0.4]));
        assert!(slide <= 1e-15, "{slide}");
        // Outside the cone, and a contact that slides with the wrong friction direction.
        assert!(norm(linearise(mu, rho, [1.0, 1.0, 0.0], [0.0; 3])) > 1e-3);
        assert!(norm(linearise(mu, rho, [2.0, 0.6, 0.8], [0.0, 0.3, 0.4])) > 1e-3);
        // Frictionless.
        assert!(norm(linearise(0.0, rho, [1.0, 0.0, 0.0], [0.0, 0.5, 0.2])) <= 1e-15);
    }
}

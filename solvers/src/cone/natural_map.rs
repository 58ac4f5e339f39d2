//! The natural map of one contact and an element of its generalised Jacobian (the kernel of
//! [`crate::ConeNewton`] with [`crate::ConeFunction::NaturalMap`], Siconos' `FC3D_NSN_NM`).
//!
//! For a contact with reaction `r`, velocity `u`, coefficient `mu` and `ρ > 0`, with De Saxcé's
//! modified velocity `û = u + mu ‖u_T‖ e_N` and the projection `P_K` onto the friction cone:
//!
//! ```text
//! Φ = r − P_K(r − ρ û)
//! ```
//!
//! `Φ = 0` is Coulomb's law; `‖Φ‖` with `ρ = 1 / d_c` is the cone residual's numerator `e_c`
//! ([`crate::cone`]). With `x = r − ρ û`, `J_K` an element of the generalised Jacobian of
//! `P_K` at `x` and `D = ∂û/∂u`: `dΦ = (I − J_K) dr + ρ J_K D du`.
//!
//! Reference: V. Acary, M. Brémond, O. Huber, 2018, §3 (the natural map of the FC3D problem);
//! Siconos numerics, `fc3d_NaturalMap_functions.c`.

use crate::cone::newton::Linearisation;
use crate::cone::project_onto_cone;

/// `P_K(x)` for the cone `‖x_T‖ <= mu x_N` and an element of its generalised Jacobian
/// (row-major): the identity inside, zero in the polar cone, and on the boundary the derivative
/// of `a (1, mu x̂_T)`, `a = (x_N + mu ‖x_T‖) / (1 + mu²)`.
pub(crate) fn projection_with_jacobian(mu: f64, x: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let t = x[1].hypot(x[2]);
    let p = project_onto_cone(mu, x);
    let mut j = [[0.0; 3]; 3];
    if t <= mu * x[0] {
        for (k, row) in j.iter_mut().enumerate() {
            row[k] = 1.0;
        }
    } else if mu * t > -x[0] {
        // On the boundary; t > 0 here (t = 0 falls in one of the other two cases).
        let xh = [x[1] / t, x[2] / t];
        let c = 1.0 / (1.0 + mu * mu);
        let a = (x[0] + mu * t) * c;
        j[0][0] = c;
        for k in 0..2 {
            j[0][1 + k] = mu * c * xh[k];
            j[1 + k][0] = mu * c * xh[k];
            for l in 0..2 {
                let id = if k == l { 1.0 } else { 0.0 };
                j[1 + k][1 + l] = mu * mu * c * xh[k] * xh[l] + mu * a / t * (id - xh[k] * xh[l]);
            }
        }
    }
    (p, j)
}

/// De Saxcé's `û(u)` and an element of its Jacobian `D = ∂û/∂u` (the tangential gradient of
/// `mu ‖u_T‖` taken as zero at `u_T = 0`).
pub(crate) fn de_saxce_with_jacobian(mu: f64, u: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let ut = u[1].hypot(u[2]);
    let mut d = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if ut > 0.0 {
        d[0][1] = mu * u[1] / ut;
        d[0][2] = mu * u[2] / ut;
    }
    ([u[0] + mu * ut, u[1], u[2]], d)
}

/// The natural map of one contact and an element of its generalised Jacobian.
pub(crate) fn linearise(mu: f64, rho: f64, r: [f64; 3], u: [f64; 3]) -> Linearisation {
    let (uh, d) = de_saxce_with_jacobian(mu, u);
    let x = [r[0] - rho * uh[0], r[1] - rho * uh[1], r[2] - rho * uh[2]];
    let (p, jk) = projection_with_jacobian(mu, x);
    let mut lin = Linearisation {
        phi: [r[0] - p[0], r[1] - p[1], r[2] - p[2]],
        p: [[0.0; 3]; 3],
        q: [[0.0; 3]; 3],
    };
    for (a, jrow) in jk.iter().enumerate() {
        for b in 0..3 {
            let id = if a == b { 1.0 } else { 0.0 };
            lin.p[a][b] = id - jrow[b];
            lin.q[a][b] = rho * (0..3).map(|k| jrow[k] * d[k][b]).sum::<f64>();
        }
    }
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

    #[test]
    fn the_map_is_the_cone_residual_numerator() {
        let (mu, rho) = (0.4, 0.7);
        for (r, u) in [
            ([0.7, -0.1, 0.05], [-0.2, 0.3, 0.1]),
            ([0.0, 0.0, 0.0], [1.0, 0.1, 0.0]),
            ([1.0, 0.2, -0.1], [0.0, 0.0, 0.0]),
        ] {
            let l = linearise(mu, rho, r, u);
            let norm = l.phi.iter().map(|v| v * v).sum::<f64>().sqrt();
            let e = crate::cone::residual::contact_natural_map(mu, rho, r, u);
            assert!((norm - e).abs() <= 1e-15, "{norm} vs {e}");
        }
    }
}

//! The cone residual, the only status decider for cone solves (see [`crate::cone`]): the
//! projection onto the second-order cone, De Saxcé's modified velocity and the per-contact
//! natural map.

use super::ConeProblem;
use crate::problem::metrics::Residuals;

/// The projection of `x = (x_N, x_T)` onto the cone `‖x_T‖ <= mu x_N` (Euclidean).
pub fn project_onto_cone(mu: f64, x: [f64; 3]) -> [f64; 3] {
    let t = x[1].hypot(x[2]);
    if t <= mu * x[0] {
        x
    } else if mu * t <= -x[0] {
        [0.0; 3]
    } else {
        let a = (x[0] + mu * t) / (1.0 + mu * mu);
        [a, mu * a * x[1] / t, mu * a * x[2] / t]
    }
}

/// De Saxcé's modified velocity `û = u + mu ‖u_T‖ e_N`.
#[inline]
pub fn de_saxce(mu: f64, u: [f64; 3]) -> [f64; 3] {
    [u[0] + mu * u[1].hypot(u[2]), u[1], u[2]]
}

#[inline]
fn norm3(x: [f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// `‖r − P_K(r − ρ û(u))‖` for one contact.
#[inline]
pub(crate) fn contact_natural_map(mu: f64, rho: f64, r: [f64; 3], u: [f64; 3]) -> f64 {
    let uh = de_saxce(mu, u);
    let p = project_onto_cone(
        mu,
        [r[0] - rho * uh[0], r[1] - rho * uh[1], r[2] - rho * uh[2]],
    );
    norm3([r[0] - p[0], r[1] - p[1], r[2] - p[2]])
}

#[inline]
fn relative(e: f64, s: f64) -> f64 {
    if e == 0.0 {
        0.0
    } else if s > 0.0 {
        e / s
    } else {
        f64::INFINITY
    }
}

/// The relative cone residual `e_c / s_c` of one contact (see [`crate::cone`]) from its
/// reaction `r_c`, velocity `u_c`, the magnitudes `t` of the terms of `u_c`
/// (`|q_i| + Σ_j |W_ij r_j|`) and its diagonal scale `d_c`.
#[inline]
pub(crate) fn contact_relative_error(
    mu: f64,
    d: f64,
    rc: [f64; 3],
    uc: [f64; 3],
    t: [f64; 3],
) -> f64 {
    let e = contact_natural_map(mu, 1.0 / d, rc, uc);
    let s = norm3([t[0] + mu * t[1].hypot(t[2]), t[1], t[2]]) / d;
    relative(e, s)
}

/// The cone residuals of `r` (see the module doc), computing `u = W r + q`.
pub fn cone_residuals(problem: &ConeProblem, r: &[f64]) -> Residuals {
    let mut u = vec![0.0; problem.n()];
    cone_residuals_and_velocity(problem, r, &mut u)
}

/// The cone residuals of `r`, writing `u = W r + q` into `u` in the same pass over `W`.
pub fn cone_residuals_and_velocity(problem: &ConeProblem, r: &[f64], u: &mut [f64]) -> Residuals {
    let n = problem.n();
    if r.len() != n || u.len() != n || r.iter().any(|v| !v.is_finite()) {
        u.iter_mut().for_each(|v| *v = f64::NAN);
        return Residuals::INFINITE;
    }
    let mut res = Residuals::ZERO;
    for c in 0..problem.contacts() {
        let one = contact_residuals(problem, c, r, u);
        res.natural_map = res.natural_map.max(one.natural_map);
        res.natural_map_rel = res.natural_map_rel.max(one.natural_map_rel);
        res.complementarity_gap += one.complementarity_gap;
        res.bound_violation = res.bound_violation.max(one.bound_violation);
    }
    if !u.iter().all(|v| v.is_finite()) {
        return Residuals::INFINITE;
    }
    res
}

/// The relative cone residual `e_c / s_c` of each contact (see the module doc) at a finite `r`
/// of the right length.
pub(crate) fn contact_relative_residuals(problem: &ConeProblem, r: &[f64]) -> Vec<f64> {
    let mut u = vec![0.0; problem.n()];
    (0..problem.contacts())
        .map(|c| contact_residuals(problem, c, r, &mut u).natural_map_rel)
        .collect()
}

/// The four measures of the module doc for contact `c` alone, writing its rows of `u = W r + q`.
fn contact_residuals(problem: &ConeProblem, c: usize, r: &[f64], u: &mut [f64]) -> Residuals {
    let (w, q, mu) = (problem.delassus(), problem.q(), problem.mu()[c]);
    let mut uc = [0.0; 3];
    let mut t = [0.0; 3];
    for a in 0..3 {
        let i = 3 * c + a;
        let (wr, m) = w.row(i).dot_and_magnitude(r);
        uc[a] = wr + q[i];
        t[a] = q[i].abs() + m;
        u[i] = uc[a];
    }
    let rc = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
    let uh = de_saxce(mu, uc);
    let p = project_onto_cone(mu, rc);
    Residuals {
        natural_map: contact_natural_map(mu, 1.0, rc, uc),
        natural_map_rel: contact_relative_error(mu, problem.scale_of(c), rc, uc, t),
        complementarity_gap: (rc[0] * uh[0] + rc[1] * uh[1] + rc[2] * uh[2]).abs(),
        bound_violation: norm3([rc[0] - p[0], rc[1] - p[1], rc[2] - p[2]]),
    }
}

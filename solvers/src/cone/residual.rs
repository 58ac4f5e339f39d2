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

/// Whether every contact's relative cone residual `e_c / s_c` (the `natural_map_rel` of
/// [`cone_residuals`], the same value bit for bit) is within `tol`, visiting the contacts from
/// `*first` on (cyclically) and stopping at the first one above it, whose index is left in
/// `*first` so that the next test starts there. A non-finite `r` or `u` is not within. The
/// test a solver needs between sweeps while its residual is above tolerance: the contact that
/// failed last time usually fails again, so a failed test costs about one contact's rows
/// instead of a pass over `W`.
pub(crate) fn within_tolerance(
    problem: &ConeProblem,
    r: &[f64],
    tol: f64,
    first: &mut usize,
) -> bool {
    let contacts = problem.contacts();
    if r.len() != problem.n() || r.iter().any(|v| !v.is_finite()) {
        return false;
    }
    let (w, q, mu) = (problem.delassus(), problem.q(), problem.mu());
    let start = if *first < contacts { *first } else { 0 };
    for c in (start..contacts).chain(0..start) {
        let (mut uc, mut t) = ([0.0; 3], [0.0; 3]);
        for a in 0..3 {
            let i = 3 * c + a;
            let (wr, m) = w.row(i).dot_and_magnitude(r);
            uc[a] = wr + q[i];
            t[a] = q[i].abs() + m;
        }
        let rc = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
        let term = contact_relative_error(mu[c], problem.scale_of(c), rc, uc, t);
        if !(uc.iter().all(|v| v.is_finite()) && term <= tol) {
            *first = c;
            return false;
        }
    }
    true
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

/// The contact whose normal complementarity `0 <= r_N ⟂ u_N >= 0` a cone result leaves
/// unresolved: its normal step (the LCP natural-map step of the normal row, in velocity units,
/// `e_N = d · |r_N − max(0, r_N − u_N / d)|`: `|u_N|` for a contact pressed into the obstacle,
/// `d r_N` for one that pushes while separating), the scale it is held to and the contact's
/// `r_N`, `u_N`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalUnresolved {
    /// Contact index.
    pub contact: usize,
    /// `e_N`.
    pub step: f64,
    /// `m_c`, the scale `e_N` is compared with (see [`normal_unresolved`]).
    pub scale: f64,
    /// `r_N`.
    pub r_n: f64,
    /// `u_N = (W r + q)_N`.
    pub u_n: f64,
}

/// The second half of a converged cone result, the counterpart of the LCP's data-resolution
/// test ([`crate::problem::metrics::unresolved_row`]): every contact's normal complementarity
/// resolved to the tolerance against the normal row's own terms, so a large `mu` cannot hide a
/// penetrating normal velocity.
///
/// The cone residual scales contact `c` by `s_c = ‖(t_N + mu ‖(t_1, t_2)‖, t_1, t_2)‖ / d_c`
/// (see [`crate::cone`]); as `mu` grows, `mu ‖u_T‖` dominates De Saxcé's velocity and the
/// residual is blind to `u_N` (at `mu = 1e5`, `r = 0` under `u = (-0.16, 0.08, 0)` meets
/// `1e-9`). At every Coulomb solution `0 <= r_N ⟂ u_N >= 0` holds, whichever of take-off,
/// sticking or sliding the contact does, so the normal row is tested alone, against the cone
/// residual's scale with `mu` capped at 1 (`m = min(mu, 1)`):
///
/// ```text
/// e_N <= max(tol · m_c, 4 (nnz_N + 1) ε t_N),
/// m_c = √(1 + m²) ‖(t_N + m ‖(t_1, t_2)‖, t_1, t_2)‖
/// ```
///
/// Why `√(1 + m²)`: with `δ = r − P_K(r − û / d)` the natural map, `û / d − δ` lies in the dual
/// cone, so `u_N / d >= δ_N − mu ‖δ_T‖ >= −√(1 + mu²) ‖δ‖`; a contact whose cone residual
/// meets the tolerance (`d ‖δ‖ <= tol · d s_c`) has a normal step within `tol · m_c` when
/// `mu <= 1`. So for `mu <= 1` the test adds nothing beyond the cone residual's own bound, and
/// above 1 it stops the `mu` amplification at 1. Returns the contact with the largest
/// `e_N / m_c` among those that fail, `None` when all pass (or `r`/`u` have the wrong length).
/// `O(nnz)`.
pub fn normal_unresolved(
    problem: &ConeProblem,
    r: &[f64],
    u: &[f64],
    tol: f64,
) -> Option<NormalUnresolved> {
    let n = problem.n();
    if r.len() != n || u.len() != n {
        return None;
    }
    let (w, q) = (problem.delassus(), problem.q());
    let mut worst: Option<(f64, NormalUnresolved)> = None;
    for (c, &mu) in problem.mu().iter().enumerate() {
        let mut t = [0.0; 3];
        let mut len = 0;
        for (a, ta) in t.iter_mut().enumerate() {
            let row = w.row(3 * c + a);
            *ta = q[3 * c + a].abs() + row.dot_and_magnitude(r).1;
            if a == 0 {
                len = row.len();
            }
        }
        let d = problem.scale_of(c);
        let (r_n, u_n) = (r[3 * c], u[3 * c]);
        let step = d * (r_n - (r_n - u_n / d).max(0.0)).abs();
        let m = mu.min(1.0);
        let scale = m.hypot(1.0) * norm3([t[0] + m * t[1].hypot(t[2]), t[1], t[2]]);
        let round_off = 4.0 * (len as f64 + 1.0) * f64::EPSILON * t[0];
        let resolved = step <= (tol * scale).max(round_off);
        if !resolved {
            let ratio = if scale > 0.0 {
                step / scale
            } else {
                f64::INFINITY
            };
            if worst.as_ref().is_none_or(|(m, _)| ratio > *m) {
                let one = NormalUnresolved {
                    contact: c,
                    step,
                    scale,
                    r_n,
                    u_n,
                };
                worst = Some((ratio, one));
            }
        }
    }
    worst.map(|(_, u)| u)
}

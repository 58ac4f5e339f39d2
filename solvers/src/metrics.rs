//! The one residual module shared by every solver, the command line, the tests and the reports.
//!
//! For an impulse `f` with `w = A f + b` and bounds `[lo_i, hi_i]` evaluated at `f` (friction rows
//! take `±mu · max(f_k, 0)`):
//!
//! * **natural-map residual** `r = ‖f − mid(lo, hi, f − w)‖∞`. It is zero exactly at a solution of
//!   the boxed LCP (for the standard LCP it is `‖min(f, w)‖∞`).
//! * **relative natural-map residual** `r_rel = ‖f − mid(lo, hi, f − D⁻¹ w)‖∞ / s` with
//!   `D = diag(d)` the [diagonal scale](crate::Problem::diagonal_scale) (`d_i = A_ii`, guarded
//!   away from zero) and `s = max(‖D⁻¹ b‖∞, β)`, where `β` is the largest finite magnitude among
//!   the fixed bounds (`s = 1` when both are zero). `D⁻¹ b` is an impulse scale: the impulse that
//!   would zero each row's velocity alone. Scaling `(A, b)` to `(σA, σb)` leaves `f`, `D⁻¹w` and
//!   `D⁻¹b` unchanged, so `r_rel` is unchanged; scaling `b` alone by `σ` (with bounds `0`/`±∞`)
//!   scales the solution, the numerator and `s` together, so `r_rel` is unchanged again. The scale
//!   deliberately does not include `‖f‖`: a blown-up impulse must not make its own residual look
//!   small. This is the number every tolerance refers to.
//! * **complementarity gap** `Σ_i (f_i − lo_i)⁺ w_i⁺ + (hi_i − f_i)⁺ w_i⁻` over finite bounds
//!   (`fᵀw` for the standard LCP). A wrong-signed `w_i` at an infinite bound is not a gap but a
//!   dual violation, which the natural-map residual measures.
//! * **bound violation** `max_i max(lo_i − f_i, f_i − hi_i, 0)`.
//!
//! Any non-finite entry in `f` makes every measure `+∞`.

use crate::problem::Problem;
use serde::Serialize;

/// The shared accuracy measures of an impulse `f` for a problem.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Residuals {
    /// `‖f − mid(lo, hi, f − w)‖∞`.
    pub natural_map: f64,
    /// The scale-invariant relative natural-map residual (see the module doc).
    pub natural_map_rel: f64,
    /// `Σ (f − lo)⁺ w⁺ + (hi − f)⁺ w⁻` over finite bounds.
    pub complementarity_gap: f64,
    /// Largest violation of a bound, `>= 0`.
    pub bound_violation: f64,
}

impl Residuals {
    /// All measures infinite: the value for a non-finite `f`.
    pub const INFINITE: Self = Self {
        natural_map: f64::INFINITY,
        natural_map_rel: f64::INFINITY,
        complementarity_gap: f64::INFINITY,
        bound_violation: f64::INFINITY,
    };
}

#[inline]
fn mid(lo: f64, hi: f64, x: f64) -> f64 {
    x.max(lo).min(hi)
}

/// Residuals of `f`, computing `w = A f + b` internally.
pub fn residuals(problem: &Problem, f: &[f64]) -> Residuals {
    if f.len() != problem.n() || f.iter().any(|v| !v.is_finite()) {
        return Residuals::INFINITE;
    }
    let w = problem.velocity(f);
    residuals_with_velocity(problem, f, &w, &problem.diagonal_scale())
}

/// The normalisation `s = max(‖D⁻¹ b‖∞, β)` of the relative residual (see the module doc), or 1
/// when it is zero. `d` is the problem's [diagonal scale](Problem::diagonal_scale). Iterative
/// solvers use it for their own stopping rules so that they stop where the shared residual agrees.
pub fn residual_scale(problem: &Problem, d: &[f64]) -> f64 {
    let b = problem.b();
    let s = (0..problem.n()).fold(problem.bound_scale(), |m, i| m.max((b[i] / d[i]).abs()));
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

/// Residuals of `f` given `w = A f + b` and the problem's diagonal scale (both precomputed).
pub fn residuals_with_velocity(problem: &Problem, f: &[f64], w: &[f64], d: &[f64]) -> Residuals {
    if f.iter().chain(w).any(|v| !v.is_finite()) {
        return Residuals::INFINITE;
    }
    let mut r = Residuals {
        natural_map: 0.0,
        natural_map_rel: 0.0,
        complementarity_gap: 0.0,
        bound_violation: 0.0,
    };
    for i in 0..problem.n() {
        let (lo, hi) = problem.bounds_at(i, f);
        let fi = f[i];
        r.natural_map = r.natural_map.max((fi - mid(lo, hi, fi - w[i])).abs());
        r.natural_map_rel = r
            .natural_map_rel
            .max((fi - mid(lo, hi, fi - w[i] / d[i])).abs());
        if lo.is_finite() {
            r.complementarity_gap += (fi - lo).max(0.0) * w[i].max(0.0);
        }
        if hi.is_finite() {
            r.complementarity_gap += (hi - fi).max(0.0) * (-w[i]).max(0.0);
        }
        r.bound_violation = r.bound_violation.max(lo - fi).max(fi - hi);
    }
    r.natural_map_rel /= residual_scale(problem, d);
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    fn two_by_two(s: f64) -> Problem {
        let a = Mat::from_fn(2, 2, |i, j| s * [[2.0, 1.0], [1.0, 2.0]][i][j]);
        Problem::lcp(a, vec![-s, s]).unwrap()
    }

    #[test]
    fn solution_has_zero_residual() {
        // f = (0.5, 0): w = (0, 1.5).
        let p = two_by_two(1.0);
        let r = residuals(&p, &[0.5, 0.0]);
        assert_eq!(r.natural_map, 0.0);
        assert_eq!(r.natural_map_rel, 0.0);
        assert_eq!(r.complementarity_gap, 0.0);
        assert_eq!(r.bound_violation, 0.0);
    }

    #[test]
    fn relative_residual_is_scale_invariant() {
        let f = [0.4, 0.1];
        let r1 = residuals(&two_by_two(1.0), &f);
        for s in [1e-9, 1e9] {
            let rs = residuals(&two_by_two(s), &f);
            assert!((rs.natural_map_rel - r1.natural_map_rel).abs() <= 1e-12 * r1.natural_map_rel);
        }
        assert!(r1.natural_map_rel > 0.0);
    }

    #[test]
    fn non_finite_impulse_is_infinitely_wrong() {
        let r = residuals(&two_by_two(1.0), &[f64::NAN, 0.0]);
        assert_eq!(r, Residuals::INFINITE);
    }

    #[test]
    fn bound_violation_and_gap() {
        let p = two_by_two(1.0);
        // f = (-1, 1): w = (-2, 2).
        let r = residuals(&p, &[-1.0, 1.0]);
        assert_eq!(r.bound_violation, 1.0);
        assert_eq!(r.complementarity_gap, 2.0);
        assert_eq!(r.natural_map, 2.0);
    }
}

//! Farkas-type certificates that a boxed LCP has no solution (or none below a size), read off a
//! diverging impulse and checked from the problem data alone.
//!
//! Whatever `f` solves the boxed LCP (module doc of [`crate::Problem`]), the sign of each row's
//! velocity `w_i = (A f + b)_i` is known in advance for rows with at most one finite bound:
//!
//! ```text
//! lo_i finite, hi_i = +∞:      w_i >= 0     (f_i > lo_i forces w_i = 0)
//! lo_i = −∞,   hi_i finite:    w_i <= 0
//! lo_i = −∞,   hi_i = +∞:      w_i  = 0
//! both finite, friction rows:  no sign      (either end of the interval may be active)
//! ```
//!
//! So for multipliers `y` with matching signs (`y_i >= 0`, `y_i <= 0`, free, `y_i = 0`), every
//! solution has `yᵀ w >= 0`. With `c = Aᵀ y`, `yᵀ w = cᵀ f + bᵀ y`, and over the bounds
//! `cᵀ f <= U + S ‖f‖∞`: `U` collects the finite ends of each column's interval, `S` the slopes
//! along unbounded directions in which `cᵀ f` grows (a friction row `t` on normal `k`, with
//! `f_t ∈ [−mu f_k, mu f_k]`, adds `mu |c_t|` to the slope of column `k` for `f_k > 0`). Hence
//! every solution has
//!
//! ```text
//! ‖f‖∞ >= −(bᵀ y + U) / S,
//! ```
//!
//! and when `S = 0` and `bᵀ y + U < 0` there is no solution at all: for the standard LCP this is
//! Farkas' lemma, `y >= 0`, `Aᵀ y <= 0`, `bᵀ y < 0` (Cottle, Pang, Stone, *The Linear
//! Complementarity Problem*, 1992; Murty, *Linear Complementarity, Linear and Nonlinear
//! Programming*, 1988). It needs no property of `A`. For a symmetric positive semidefinite `A`
//! a boxed LCP has a solution exactly when its QP is bounded below, so when it has none a
//! recession direction `z` of the bounds with `A z = 0` and `bᵀ z < 0` exists, and `y = z` is
//! such a certificate: the direction along which iterative solvers' impulses grow.
//!
//! [`check`] verifies given multipliers with rounding accounted for: `c = Aᵀ y` and `bᵀ y` carry
//! a priori error bounds of recursive summation (Higham, *Accuracy and Stability of Numerical
//! Algorithms*, 2002, §3.1), and a slope whose bound straddles zero has its sign decided
//! exactly, by summing the products in floating-point expansions (Shewchuk, *Adaptive precision
//! floating-point arithmetic and fast robust geometric predicates*, 1997). A certificate that
//! `check` accepts as a proof is one in exact arithmetic on the stored data.
//! [`certificate_from`] reads `y` off an impulse: the part of `f` beyond its finite bound on
//! rows that may carry a multiplier, also moved towards a ray of `A` (accelerated projected
//! gradient on `½ ‖Aᵀ y‖²` with `bᵀ y` held, which matters when the impulse grows on friction
//! rows too: the wedged box's normals and friction grow together, and the normals alone are no
//! ray until moved).

use crate::problem::Problem;
use serde::Serialize;

/// Multipliers `y` and what they prove about the solutions of a problem (module doc).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Certificate {
    /// The multipliers, scaled by a power of two so that `max |y_i|` is in `[1, 2)`.
    pub y: Vec<f64>,
    /// `bᵀ y`, rounded up.
    pub b_dot_y: f64,
    /// `U`: bound on `cᵀ f` from the finite ends of the columns' intervals, rounded up.
    pub bounded_part: f64,
    /// `S`: sum of the slopes of `cᵀ f` along unbounded directions in which it grows, rounded up;
    /// `0` when there is none.
    pub slope: f64,
    /// `S` relative to `Σ_j Σ_i |A_ij y_i|`: how far `y` is from a ray (`Aᵀ y <= 0` where it
    /// must be).
    pub slope_rel: f64,
    /// True when `S = 0` and `bᵀ y + U < 0`: the problem has no solution.
    pub proves_no_solution: bool,
    /// Every solution has `‖f‖∞` at least this (`∞` when [`proves_no_solution`](Self::proves_no_solution)).
    pub min_solution_norm: f64,
}

/// The sign condition a row's multiplier must meet.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Sign {
    NonNegative,
    NonPositive,
    Free,
    Zero,
}

fn sign_of_row(problem: &Problem, i: usize) -> Sign {
    if problem.friction_of(i).is_some() {
        return Sign::Zero;
    }
    match (problem.lo()[i].is_finite(), problem.hi()[i].is_finite()) {
        (true, false) => Sign::NonNegative,
        (false, true) => Sign::NonPositive,
        (false, false) => Sign::Free,
        (true, true) => Sign::Zero,
    }
}

/// Multipliers read off the impulse `f`: on each row that may carry one, the part of `f_i`
/// beyond its finite bound (`f_i − lo_i >= 0`, `f_i − hi_i <= 0`, or `f_i` on a free row). The
/// best of three candidates is kept: these, the same with entries below `1e-6` of the largest
/// set to zero (the bounded part of a diverging impulse), and these moved towards a ray
/// ([`toward_ray`]: a diverging impulse that also grows on rows that carry no multiplier,
/// friction rows, is no ray itself). `None` when no candidate gives a positive lower bound on
/// the size of a solution.
pub fn certificate_from(problem: &Problem, f: &[f64]) -> Option<Certificate> {
    let n = problem.n();
    if f.len() != n || f.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let y: Vec<f64> = (0..n)
        .map(|i| match sign_of_row(problem, i) {
            Sign::NonNegative => (f[i] - problem.lo()[i]).max(0.0),
            Sign::NonPositive => (f[i] - problem.hi()[i]).min(0.0),
            Sign::Free => f[i],
            Sign::Zero => 0.0,
        })
        .collect();
    let largest = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if largest.is_nan() || largest <= 0.0 || largest.is_infinite() {
        return None;
    }
    let trimmed: Vec<f64> = y
        .iter()
        .map(|&v| if v.abs() < 1e-6 * largest { 0.0 } else { v })
        .collect();
    // At most 3 000 steps, and about 3e7 operations in all (two passes over the entries and
    // about sixty over the rows, for the projection, per step).
    let steps = (3e7 / (2 * problem.nnz() + 60 * n).max(1) as f64).clamp(50.0, 3000.0) as usize;
    let ray = toward_ray(problem, &y, steps);
    [
        check(problem, &y),
        check(problem, &trimmed),
        check(problem, &ray),
    ]
    .into_iter()
    .flatten()
    .filter(|c| c.min_solution_norm > 0.0)
    .max_by(|a, b| a.min_solution_norm.total_cmp(&b.min_solution_norm))
}

/// `y0` moved towards a ray of `A`: `steps` accelerated projected-gradient steps (Nesterov,
/// step `1 / (‖A‖₁ ‖A‖∞)`) on `½ ‖Aᵀ y‖²` over the multipliers that meet the rows' sign
/// conditions and keep `bᵀ y = bᵀ y0`. `O(nnz + n)` per step. Returns `y0` when `bᵀ y0 >= 0` or
/// `A = 0`. The result is only a candidate: [`check`] decides what it proves.
fn toward_ray(problem: &Problem, y0: &[f64], steps: usize) -> Vec<f64> {
    let n = problem.n();
    let b = problem.b();
    let target: f64 = b.iter().zip(y0).map(|(b, y)| b * y).sum();
    let mut column_sums = vec![0.0f64; n];
    let mut widest_row = 0.0f64;
    for i in 0..n {
        let mut r = 0.0;
        for (j, a) in problem.row(i).iter() {
            r += a.abs();
            column_sums[j] += a.abs();
        }
        widest_row = widest_row.max(r);
    }
    let lipschitz = widest_row * column_sums.iter().fold(0.0f64, |m, &v| m.max(v));
    if target.is_nan() || target >= 0.0 || lipschitz.is_nan() || lipschitz <= 0.0 {
        return y0.to_vec();
    }
    let signs: Vec<Sign> = (0..n).map(|i| sign_of_row(problem, i)).collect();
    let (mut y, mut x, mut v) = (y0.to_vec(), y0.to_vec(), vec![0.0; n]);
    let mut next = vec![0.0; n];
    let mut c = vec![0.0; n];
    let mut lambda = 0.0;
    for k in 0..steps {
        c.iter_mut().for_each(|v| *v = 0.0);
        for (i, &xi) in x.iter().enumerate() {
            if xi != 0.0 {
                for (j, a) in problem.row(i).iter() {
                    c[j] += a * xi;
                }
            }
        }
        for i in 0..n {
            v[i] = x[i] - problem.row(i).dot(&c) / lipschitz;
        }
        lambda = project(&v, &signs, b, target, lambda, &mut next);
        let momentum = k as f64 / (k as f64 + 3.0);
        for i in 0..n {
            x[i] = next[i] + momentum * (next[i] - y[i]);
        }
        std::mem::swap(&mut y, &mut next);
    }
    y
}

/// The point nearest `v` whose entries meet `signs` and whose `bᵀ y` is `target`, written into
/// `out`: `y_i = P_i(v_i − λ b_i)`, with `λ` found by bisection from the bracket around `guess`
/// (`bᵀ y(λ)` does not increase in `λ`). Returns `λ`.
fn project(v: &[f64], signs: &[Sign], b: &[f64], target: f64, guess: f64, out: &mut [f64]) -> f64 {
    let entry = |i: usize, lambda: f64| {
        let t = v[i] - lambda * b[i];
        match signs[i] {
            Sign::NonNegative => t.max(0.0),
            Sign::NonPositive => t.min(0.0),
            Sign::Free => t,
            Sign::Zero => 0.0,
        }
    };
    let value = |lambda: f64| -> f64 { (0..v.len()).map(|i| b[i] * entry(i, lambda)).sum() };
    let mut width = guess.abs().max(1.0) * 1e-3;
    let (mut lo, mut hi) = (guess - width, guess + width);
    for _ in 0..200 {
        if value(lo) >= target {
            break;
        }
        width *= 2.0;
        lo = guess - width;
    }
    for _ in 0..200 {
        if value(hi) <= target {
            break;
        }
        width *= 2.0;
        hi = guess + width;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if value(mid) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let lambda = 0.5 * (lo + hi);
    for (i, o) in out.iter_mut().enumerate() {
        *o = entry(i, lambda);
    }
    lambda
}

/// Check the multipliers `y` against `problem` (module doc): `None` when `y` has the wrong
/// length, a non-finite entry, is zero, or breaks a row's sign condition; otherwise what it
/// proves. `y` is first scaled by a power of two (exactly) so that `max |y_i|` is in `[1, 2)`.
pub fn check(problem: &Problem, y: &[f64]) -> Option<Certificate> {
    let n = problem.n();
    if y.len() != n || y.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let sign_ok = (0..n).all(|i| match sign_of_row(problem, i) {
        Sign::NonNegative => y[i] >= 0.0,
        Sign::NonPositive => y[i] <= 0.0,
        Sign::Free => true,
        Sign::Zero => y[i] == 0.0,
    });
    let largest = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !sign_ok || largest == 0.0 {
        return None;
    }
    let scale = 2f64.powi(-largest.log2().floor() as i32);
    let y: Vec<f64> = y.iter().map(|v| v * scale).collect();
    let columns = ColumnSums::of(problem, &y);
    let b = problem.b();
    let (bty, bty_err) = sum_with_bound(b.iter().zip(&y).map(|(bi, yi)| bi * yi));
    let b_dot_y = bty + bty_err;
    // Slopes of the friction rows' columns gathered on their normals: M_k = Σ mu |c_t|.
    let mut friction_slope = vec![Interval::ZERO; n];
    for fr in problem.friction() {
        let c = columns.interval(problem, &y, fr.row);
        let abs_hi = c.lo.abs().max(c.hi.abs());
        let abs_lo = if c.lo > 0.0 {
            c.lo
        } else if c.hi < 0.0 {
            -c.hi
        } else {
            0.0
        };
        let m = &mut friction_slope[fr.normal];
        m.lo += fr.mu * abs_lo * (1.0 - 4.0 * f64::EPSILON);
        m.hi += fr.mu * abs_hi * (1.0 + 4.0 * f64::EPSILON);
    }
    let (mut bounded, mut slope, mut magnitude) = (0.0f64, 0.0f64, 0.0f64);
    for (j, &friction) in friction_slope.iter().enumerate() {
        magnitude += columns.magnitude[j];
        if problem.friction_of(j).is_some() {
            continue;
        }
        let left = columns.interval(problem, &y, j);
        let right = left.add(friction);
        let (lo, hi) = (problem.lo()[j], problem.hi()[j]);
        let mut top = 0.0f64;
        for (end, upward_slope) in [(lo, -left.lo), (hi, right.hi)] {
            if end.is_finite() {
                let a = if end >= 0.0 { right } else { left };
                top = top.max(a.lo * end).max(a.hi * end);
            } else if upward_slope > 0.0 {
                slope += upward_slope;
            }
        }
        bounded += top;
    }
    // The final sums of non-negative terms, rounded up.
    let bounded = bounded * (1.0 + 2.0 * (n as f64 + 1.0) * f64::EPSILON);
    let slope = slope * (1.0 + 2.0 * (n as f64 + 1.0) * f64::EPSILON);
    let total = b_dot_y + bounded;
    let total = total + 2.0 * f64::EPSILON * (b_dot_y.abs() + bounded);
    let proves_no_solution = slope == 0.0 && total < 0.0;
    let min_solution_norm = if proves_no_solution {
        f64::INFINITY
    } else if total < 0.0 {
        // A lower bound: round the quotient down.
        (-total / slope) * (1.0 - 4.0 * f64::EPSILON)
    } else {
        0.0
    };
    Some(Certificate {
        y,
        b_dot_y,
        bounded_part: bounded,
        slope,
        slope_rel: if magnitude > 0.0 {
            slope / magnitude
        } else {
            0.0
        },
        proves_no_solution,
        min_solution_norm,
    })
}

/// A closed interval `[lo, hi]` holding an exact value.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Interval {
    lo: f64,
    hi: f64,
}

impl Interval {
    const ZERO: Self = Self { lo: 0.0, hi: 0.0 };

    /// The sum, rounded outward.
    fn add(self, other: Self) -> Self {
        let (lo, hi) = (self.lo + other.lo, self.hi + other.hi);
        Self {
            lo: lo - 2.0 * f64::EPSILON * lo.abs(),
            hi: hi + 2.0 * f64::EPSILON * hi.abs(),
        }
    }
}

/// The columns of `Aᵀ y` as computed sums with their error bounds.
struct ColumnSums {
    value: Vec<f64>,
    error: Vec<f64>,
    magnitude: Vec<f64>,
}

impl ColumnSums {
    /// One pass over the rows with `y_i ≠ 0`.
    fn of(problem: &Problem, y: &[f64]) -> Self {
        let n = problem.n();
        let mut value = vec![0.0; n];
        let mut magnitude = vec![0.0; n];
        let mut terms = vec![0usize; n];
        for (i, &yi) in y.iter().enumerate() {
            if yi == 0.0 {
                continue;
            }
            for (j, a) in problem.row(i).iter() {
                if a != 0.0 {
                    let p = a * yi;
                    value[j] += p;
                    magnitude[j] += p.abs();
                    terms[j] += 1;
                }
            }
        }
        let error = (0..n)
            .map(|j| summation_error(terms[j], magnitude[j]))
            .collect();
        Self {
            value,
            error,
            magnitude,
        }
    }

    /// An interval holding the exact `(Aᵀ y)_j`; when the bound straddles zero, the exact sign
    /// of the sum narrows it.
    fn interval(&self, problem: &Problem, y: &[f64], j: usize) -> Interval {
        let (v, e) = (self.value[j], self.error[j]);
        let rounded = Interval {
            lo: v - e,
            hi: v + e,
        };
        if rounded.lo > 0.0 || rounded.hi < 0.0 {
            return rounded;
        }
        let products = y
            .iter()
            .enumerate()
            .filter(|(_, &yi)| yi != 0.0)
            .map(|(i, &yi)| (problem.entry(i, j), yi));
        match exact_sign(products) {
            Some(std::cmp::Ordering::Equal) => Interval::ZERO,
            Some(std::cmp::Ordering::Less) => Interval {
                lo: rounded.lo,
                hi: 0.0,
            },
            Some(std::cmp::Ordering::Greater) => Interval {
                lo: 0.0,
                hi: rounded.hi,
            },
            None => rounded,
        }
    }
}

/// `γ_{k+1} · magnitude` plus the underflow allowance of `k` products: a bound on the error of
/// a recursively summed dot product of `k` terms whose magnitudes sum to `magnitude`.
fn summation_error(k: usize, magnitude: f64) -> f64 {
    if k == 0 {
        return 0.0;
    }
    let ku = (k as f64 + 1.0) * f64::EPSILON;
    ku / (1.0 - ku) * magnitude * (1.0 + f64::EPSILON) + k as f64 * f64::from_bits(1)
}

/// A recursive sum and its error bound ([`summation_error`]).
fn sum_with_bound(terms: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut s, mut m, mut k) = (0.0, 0.0, 0);
    for t in terms {
        if t != 0.0 {
            s += t;
            m += t.abs();
            k += 1;
        }
    }
    (s, summation_error(k, m))
}

/// The exact sign of `Σ a_k b_k`, from the products' error-free transformations summed in a
/// floating-point expansion (Shewchuk 1997). `None` when a product or a partial sum leaves the
/// range in which the transformations are exact (overflow, or a product below `2^-960`).
fn exact_sign(products: impl Iterator<Item = (f64, f64)>) -> Option<std::cmp::Ordering> {
    let mut expansion: Vec<f64> = Vec::new();
    for (a, b) in products {
        let p = a * b;
        if p == 0.0 && a != 0.0 && b != 0.0 {
            return None;
        }
        if p == 0.0 {
            continue;
        }
        if !p.is_finite() || p.abs() < 2f64.powi(-960) {
            return None;
        }
        let e = a.mul_add(b, -p);
        grow_expansion(&mut expansion, p);
        if e != 0.0 {
            grow_expansion(&mut expansion, e);
        }
        if expansion.iter().any(|v| !v.is_finite()) {
            return None;
        }
    }
    Some(
        expansion
            .iter()
            .rev()
            .find(|&&v| v != 0.0)
            .map_or(std::cmp::Ordering::Equal, |v| {
                v.partial_cmp(&0.0).unwrap_or(std::cmp::Ordering::Equal)
            }),
    )
}

/// `a + b = s + e` exactly (Knuth's two-sum).
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// Add `b` to the nonoverlapping expansion `e` (components in increasing magnitude), keeping it
/// nonoverlapping and dropping zero components (Shewchuk's GROW-EXPANSION with zero
/// elimination).
fn grow_expansion(e: &mut Vec<f64>, b: f64) {
    let mut q = b;
    let mut out = Vec::with_capacity(e.len() + 1);
    for &component in e.iter() {
        let (s, h) = two_sum(q, component);
        q = s;
        if h != 0.0 {
            out.push(h);
        }
    }
    if q != 0.0 {
        out.push(q);
    }
    *e = out;
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    fn lcp(a: &[&[f64]], b: &[f64]) -> Problem {
        let n = b.len();
        Problem::lcp(Mat::from_fn(n, n, |i, j| a[i][j]), b.to_vec()).unwrap()
    }

    #[test]
    fn the_two_by_two_without_solution_is_proved() {
        let p = lcp(&[&[1.0, -1.0], &[-1.0, 1.0]], &[-1.0, -1.0]);
        let c = certificate_from(&p, &[5.2e7, 5.2e7]).unwrap();
        assert!(c.proves_no_solution, "{c:?}");
        assert_eq!(c.slope, 0.0);
        assert!(c.b_dot_y < 0.0);
        // An unequal impulse is an approximate ray: read off directly, a bound, not a proof;
        // moved towards the ray, (1, 1), a proof or a bound at round-off.
        let y = [19_999.0, 20_000.0];
        let c = check(&p, &y).unwrap();
        assert!(!c.proves_no_solution);
        assert!(
            c.min_solution_norm > 1e4 && c.min_solution_norm < 1e5,
            "{c:?}"
        );
        let ray = toward_ray(&p, &y, 50);
        assert!((ray[0] - ray[1]).abs() <= 1e-12 * ray[0], "{ray:?}");
        assert!(certificate_from(&p, &y).unwrap().min_solution_norm > 1e12);
    }

    #[test]
    fn a_solvable_problem_is_never_proved_infeasible() {
        // SPD: every y >= 0 has (Aᵀ y)_j > 0 somewhere.
        let p = lcp(&[&[2.0, 1.0], &[1.0, 2.0]], &[-1.0, -1.0]);
        for y in [[1.0, 1.0], [1.0, 0.0], [3.0, 7.0]] {
            let c = check(&p, &y).unwrap();
            assert!(!c.proves_no_solution);
            // The solution (1/3, 1/3) respects the bound.
            assert!(c.min_solution_norm <= 1.0 / 3.0 + 1e-15, "{c:?}");
            // Nor when moved towards a ray.
            if let Some(c) = certificate_from(&p, &y) {
                assert!(c.min_solution_norm <= 1.0 / 3.0 + 1e-15, "{c:?}");
            }
        }
    }

    #[test]
    fn sign_conditions_are_enforced() {
        let p = lcp(&[&[1.0, -1.0], &[-1.0, 1.0]], &[-1.0, -1.0]);
        assert!(check(&p, &[-1.0, -1.0]).is_none());
        assert!(check(&p, &[0.0, 0.0]).is_none());
        assert!(check(&p, &[1.0]).is_none());
        // A row with two finite bounds carries no multiplier.
        let boxed = Problem::boxed(
            Mat::from_fn(2, 2, |i, j| [[1.0, -1.0], [-1.0, 1.0]][i][j]),
            vec![-1.0, -1.0],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 5.0],
            vec![],
        )
        .unwrap();
        assert!(check(&boxed, &[1.0, 1.0]).is_none());
        // y = e_0: c = (1, −1); column 1 is bounded by [0, 5], so U = 0 and S = 1 (column 0).
        let c = check(&boxed, &[1.0, 0.0]).unwrap();
        assert!(!c.proves_no_solution);
        // The boxed problem's solution f = (6, 5) (w = (0, −2)) respects the bound.
        assert!(c.min_solution_norm <= 6.0);
    }

    #[test]
    fn friction_rows_add_their_slope_to_the_normal() {
        // Row 0 normal, row 1 its friction row (mu = 0.5). A = [[1, 0], [0, 1]] - the normal's
        // column has c_0 = y_0; a certificate must not count friction columns as free.
        let p = Problem::boxed(
            Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.0 }),
            vec![-1.0, 0.3],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![crate::FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        // y on the friction row is refused; on the normal, c_0 = 1 > 0: no proof.
        assert!(check(&p, &[1.0, 1.0]).is_none());
        let c = check(&p, &[1.0, 0.0]).unwrap();
        assert!(!c.proves_no_solution);
    }

    #[test]
    fn exact_signs_of_cancelling_sums() {
        use std::cmp::Ordering::*;
        let s = |v: &[(f64, f64)]| exact_sign(v.iter().copied());
        assert_eq!(s(&[(1.0, 1e16), (1.0, 1.0), (-1.0, 1e16)]), Some(Greater));
        assert_eq!(s(&[(0.1, 3.0), (-0.3, 1.0)]), Some(Greater)); // 0.1·3 > 0.3 in binary
        assert_eq!(s(&[(1.0, -1.0), (-1.0, -1.0)]), Some(Equal));
        assert_eq!(s(&[(1e300, 1e300)]), None);
    }
}

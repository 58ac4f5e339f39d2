//! The one residual module shared by every solver, the command line, the tests and the reports.
//!
//! For an impulse `f` with `w = A f + b` and bounds `[lo_i, hi_i]` evaluated at `f` (friction rows
//! take `±mu · max(f_k, 0)`):
//!
//! * **natural-map residual** `r = ‖f − mid(lo, hi, f − w)‖∞`. It is zero exactly at a solution of
//!   the boxed LCP (for the standard LCP it is `‖min(f, w)‖∞`).
//! * **relative natural-map residual**, the number every tolerance refers to:
//!
//!   ```text
//!   r_rel = max_i  |f_i − mid(lo_i, hi_i, f_i − w_i / d_i)|  /  s_i,
//!   s_i   = (|b_i| + Σ_j |A_ij f_j|) / d_i,
//!   ```
//!
//!   with `d_i` the [diagonal scale](crate::Problem::diagonal_scale) (`A_ii` when positive, else the
//!   row's largest magnitude), `0/0 = 0` and `x/0 = ∞` for `x > 0`. Each row is measured against *its own* scale:
//!   `s_i` is built from the magnitudes of the terms that make up that row's `w_i / d_i`
//!   (`b_i / d_i` and each `A_ij f_j / d_i`, the row's own `f_i` included), the componentwise
//!   backward-error scale of Oettli and Prager. So:
//!   - no other row can hide a row's error: a weak row (tiny `A_ii`), a huge finite bound or a
//!     huge `b_k` elsewhere changes only that row's own scale (one global scale such as
//!     `max(‖D⁻¹b‖∞, largest bound)` is fooled by exactly these);
//!   - bounds do not enter `s_i`, so a huge finite bound cannot hide the error of its own row
//!     either (an active bound enters through `|A_ii f_i| / d_i = |f_i|`);
//!   - it is invariant under every positive diagonal scaling of rows and of columns
//!     (`A → R A C`, `b → R b`, `f → C⁻¹ f`: row `i`'s numerator and `s_i` both scale by
//!     `1 / c_i`), so under symmetric scaling over any number of decades, under `(A, b) → (σA, σb)`
//!     and under `b → σb` for the standard LCP;
//!   - when `r_rel <= tol`, each row's natural-map step is at most `tol` times the magnitude of
//!     the data that row's velocity is made of, the level of a relative perturbation `tol` of
//!     that row of `A` and of `b_i` (the row's rounding error in computing `w_i` is about
//!     `nnz_i · ε` in these units, so tolerances down to about `1e-13` are reachable; the command
//!     line refuses tolerances below [`MIN_TOLERANCE`]);
//!   - a row whose data all vanish at `f` (`b_i = 0` and every `A_ij f_j = 0`) has `s_i = 0`
//!     and must be solved exactly (`f_i` inside its bounds), which every solver here does;
//!   - what it cannot see: `s_i` grows with `f`. On a problem without a solution, an impulse
//!     growing along a direction that `A` cancels keeps every step bounded while the scales
//!     grow, so `r_rel` falls like `1/‖f‖` and passes any tolerance. `A = [[1, −1], [−1, 1]]`,
//!     `b = (−1, −1)` has none (`z = (1, 1) >= 0`, `A z = 0`, `zᵀ b < 0`: Farkas), yet
//!     `f = t z` leaves `w = b` and `r_rel = 1 / (2t + 1)`. The data-resolution test below
//!     catches it.
//!
//!   The step is computed without forming `f_i − w_i / d_i` as a value: that point is only
//!   compared with the bounds; inside them the step is `|w_i| / d_i`, at a bound `|f_i − bound|`.
//!   So a huge `f_i` cannot absorb `w_i`, and a tiny, huge or subnormal `d_i` cannot make the step
//!   or its ratio to `s_i` round to 0 (`step / s_i` is formed as `|w_i| / t_i` or
//!   `|f_i − bound| · d_i / t_i`, through logarithms when the product leaves the normal range).
//!   A row whose term magnitude `t_i = |b_i| + Σ_j |A_ij f_j|` overflows, or whose ratio is NaN,
//!   counts as `∞`: never as 0.
//! * **data resolution**, the second half of `converged`. With `e_i = d_i · step_i` (velocity
//!   units), `t_i = d_i s_i`, `u_i = 4 (nnz_i + 1) ε` and the row's *data scale*
//!   `D_i = √d_i · max_j |b_j| / √d_j` over the row's island ([`data_scale`]: the largest data
//!   velocity of the island, in the row's units), a row is resolved when
//!
//!   ```text
//!   max(e_i, u_i t_i) <= RESOLUTION · D_i,      RESOLUTION = 0.05
//!   ```
//!
//!   (a row without data, `D_i = 0`, when `e_i <= u_i t_i`): its velocity error is at most 5 %
//!   of the largest velocity the problem's data ask for, and so is the round-off of its terms.
//!   A result with `r_rel <= tol` and an unresolved row ([`unresolved_row`]) met the tolerance
//!   only because the row's terms are far larger than the data and cancel: a diverging impulse
//!   (the example: `e = 1 = D`), or one so large (terms beyond `RESOLUTION / u_i ≈ 1e13` times
//!   the data) that the data are lost in rounding. `D_i` follows every symmetric positive
//!   diagonal scaling (`A → S A S`, `b → S b`: units, equilibration) as `w_i` does, so the test
//!   is invariant under it; independent row and column scalings, which the residual above
//!   survives, change it (it compares rows through the diagonal). A row whose own data are 0
//!   or round-off (a resting contact's friction rows, the inner contacts of a stack) takes its
//!   island's. What it cannot tell apart: a problem with a solution whose rows cancel by
//!   `κ = t_i / D_i` (a mass ratio `κ`; about four times the height of a stack), solved to a
//!   tolerance with `tol · κ > RESOLUTION`, may leave steps that reach the data scale too, and
//!   is reported the same way (its velocities are not known to 5 % of the data; a tighter
//!   tolerance resolves it); and an impulse diverging on a problem infeasible by less than
//!   `RESOLUTION` of the island's largest data, or in an island with one much larger datum
//!   (it raises every `D_i`), passes.
//! * **complementarity gap** `Σ_i (f_i − lo_i)⁺ w_i⁺ + (hi_i − f_i)⁺ w_i⁻` over finite bounds
//!   (`fᵀw` for the standard LCP). A wrong-signed `w_i` at an infinite bound is not a gap but a
//!   dual violation, which the natural-map residual measures.
//! * **bound violation** `max_i max(lo_i − f_i, f_i − hi_i, 0)`.
//!
//! Every measure costs one pass over the stored entries of `A` (`O(nnz)`), dense or sparse (for
//! an `A` held as its factors `J`, `M⁻¹` and not assembled, one pass over the same entries
//! formed from the factors body by body, without storing them, the rows split among threads
//! on large problems: [`DelassusFactors::row_terms`]), and
//! any non-finite entry in `f` makes every measure `+∞`; the data scales cost a few more passes,
//! taken only for a result that meets its tolerance and only when some row is not resolved
//! against its own data alone ([`unresolved_row`] tries that `O(n)` bound first).
//!
//! Reference: W. Oettli, W. Prager, *Compatibility of approximate solution of linear equations
//! with given error bounds for coefficients and right-hand sides*, Numer. Math. 6 (1964).

use crate::delassus::DelassusFactors;
use crate::problem::Problem;
use serde::Serialize;

/// The shared accuracy measures of an impulse `f` for a problem.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Residuals {
    /// `‖f − mid(lo, hi, f − w)‖∞`.
    pub natural_map: f64,
    /// The relative natural-map residual with per-row scales (see the module doc).
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

    /// Every measure NaN: the value of a result whose residual was not measured
    /// ([`Settings::measure_result`](crate::Settings::measure_result)).
    pub const NOT_MEASURED: Self = Self {
        natural_map: f64::NAN,
        natural_map_rel: f64::NAN,
        complementarity_gap: f64::NAN,
        bound_violation: f64::NAN,
    };

    /// True unless this is [`Residuals::NOT_MEASURED`] (every measure NaN).
    pub fn is_measured(&self) -> bool {
        !(self.natural_map.is_nan()
            && self.natural_map_rel.is_nan()
            && self.complementarity_gap.is_nan()
            && self.bound_violation.is_nan())
    }

    pub(crate) const ZERO: Self = Self {
        natural_map: 0.0,
        natural_map_rel: 0.0,
        complementarity_gap: 0.0,
        bound_violation: 0.0,
    };
}

/// Row `i`'s natural-map step in velocity units, `d_i · |f_i − mid(lo_i, hi_i, f_i − w_i / d_i)|`,
/// and the same step divided by `t_i`, computed without forming `f_i − w_i / d_i` as a value: the
/// point `f_i − w_i / d_i` is only compared with the bounds. A row inside its bounds has step
/// `|w_i|` (no division by `d_i`, no cancellation of `w_i` against a large `f_i`); a row clamped
/// at a bound has step `|f_i − bound| · d_i`. So a tiny, huge or subnormal `d_i` or a huge `f_i`
/// cannot round the step to 0, and the ratio `step / t_i` is formed without overflow or
/// underflow to 0 ([`ratio`]).
#[inline]
fn row_step(f_i: f64, lo: f64, hi: f64, w_i: f64, d: f64, t: f64) -> (f64, f64) {
    let x = f_i - w_i / d;
    let gap = if x < lo {
        Some(f_i - lo)
    } else if x > hi {
        Some(f_i - hi)
    } else {
        None
    };
    match gap {
        Some(g) => (g.abs() * d, ratio(g.abs(), d, t)),
        None => (w_i.abs(), ratio(w_i.abs(), 1.0, t)),
    }
}

/// `a · b / c` for `a, b >= 0` and `c >= 0`, with `0/0 = 0` and `x/0 = ∞` for `x > 0`, and
/// without overflow or underflow of the intermediate product: when `a · b` leaves the normal
/// range, the product is formed in logarithms.
#[inline]
fn ratio(a: f64, b: f64, c: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        return 0.0;
    }
    if c.is_nan() || c <= 0.0 {
        return f64::INFINITY;
    }
    let p = a * b;
    if p.is_normal() {
        p / c
    } else {
        (a.ln() + b.ln() - c.ln()).exp()
    }
}

/// Row `i`'s relative natural-map error `|f_i − mid(lo_i, hi_i, f_i − w_i/d_i)| / s_i` given
/// `w_i` and the magnitude `t_i = |b_i| + Σ_j |A_ij f_j|` of the terms that make it up (see the
/// module doc; [`crate::Row::dot_and_magnitude`] gives both). Sweeping solvers use it for their
/// own stopping rules, so that they stop where the shared residual agrees. A non-finite `t_i`
/// (terms beyond the range of `f64`) gives `∞`: such a row cannot be measured.
#[inline]
pub fn relative_row_error(problem: &Problem, i: usize, f: &[f64], w_i: f64, t_i: f64) -> f64 {
    let (lo, hi) = problem.bounds_at(i, f);
    relative_row_error_at(f[i], lo, hi, w_i, problem.diagonal_scale_of(i), t_i)
}

/// [`relative_row_error`] of a row whose impulse `f_i`, bounds `lo`, `hi` (at the current normal
/// impulse, for a friction row) and diagonal scale `d_i` ([`Problem::diagonal_scale_of`]) the
/// caller has at hand: a sweep that has just computed them for its update passes them instead
/// of looking them up again. The same value, bit for bit.
#[inline]
pub(crate) fn relative_row_error_at(
    f_i: f64,
    lo: f64,
    hi: f64,
    w_i: f64,
    d_i: f64,
    t_i: f64,
) -> f64 {
    let rel = row_step(f_i, lo, hi, w_i, d_i, t_i).1;
    if t_i.is_finite() && !rel.is_nan() {
        rel
    } else {
        f64::INFINITY
    }
}

/// Rows from which the terms of a factored `A` are formed on several threads.
const PARALLEL_TERMS_ROWS: usize = 20_000;

/// `A_i · f` into `af` and `Σ_j |A_ij f_j|` (returned) of every row of a factored `A`, with
/// each row's number of entries when `with_len` ([`DelassusFactors::row_terms`]), on one
/// thread per available core (at most eight) from [`PARALLEL_TERMS_ROWS`] rows.
fn factored_row_terms(
    factors: &DelassusFactors,
    f: &[f64],
    af: &mut [f64],
    with_len: bool,
) -> (Vec<f64>, Vec<usize>) {
    let n = af.len();
    let mut magnitude = vec![0.0; n];
    let mut len = vec![0; if with_len { n } else { 0 }];
    let threads = if n >= PARALLEL_TERMS_ROWS {
        std::thread::available_parallelism().map_or(1, |t| t.get().min(8))
    } else {
        1
    };
    let len_out = with_len.then_some(len.as_mut_slice());
    factors.row_terms(f, af, &mut magnitude, len_out, threads);
    (magnitude, len)
}

/// Residuals of `f`, computing `w = A f + b` internally.
pub fn residuals(problem: &Problem, f: &[f64]) -> Residuals {
    let mut w = vec![0.0; problem.n()];
    residuals_and_velocity(problem, f, &mut w)
}

/// Residuals of `f`, writing `w = A f + b` into `w` in the same pass over `A`.
pub fn residuals_and_velocity(problem: &Problem, f: &[f64], w: &mut [f64]) -> Residuals {
    let n = problem.n();
    if f.len() != n || w.len() != n || f.iter().any(|v| !v.is_finite()) {
        w.iter_mut().for_each(|v| *v = f64::NAN);
        return Residuals::INFINITE;
    }
    let b = problem.b();
    let mut r = Residuals::ZERO;
    let factors = problem.unassembled_factors();
    // A factored A: every row's terms first, in one pass over its factors.
    let magnitudes = factors.map(|factors| factored_row_terms(factors, f, w, false).0);
    for i in 0..n {
        let (af, magnitude) = match &magnitudes {
            Some(m) => (w[i], m[i]),
            None => problem.row(i).dot_and_magnitude(f),
        };
        let wi = af + b[i];
        w[i] = wi;
        let d = problem.diagonal_scale_of(i);
        let (lo, hi) = problem.bounds_at(i, f);
        let fi = f[i];
        let t = b[i].abs() + magnitude;
        let absolute = row_step(fi, lo, hi, wi, 1.0, 1.0).0;
        let rel = row_step(fi, lo, hi, wi, d, t).1;
        // A row whose terms overflow cannot be measured; a NaN never passes as 0.
        let rel = if t.is_finite() && !rel.is_nan() {
            rel
        } else {
            f64::INFINITY
        };
        r.natural_map = r.natural_map.max(absolute);
        r.natural_map_rel = r.natural_map_rel.max(rel);
        if lo.is_finite() {
            r.complementarity_gap += (fi - lo).max(0.0) * wi.max(0.0);
        }
        if hi.is_finite() {
            r.complementarity_gap += (hi - fi).max(0.0) * (-wi).max(0.0);
        }
        r.bound_violation = r.bound_violation.max(lo - fi).max(fi - hi);
    }
    if !w.iter().all(|v| v.is_finite()) {
        return Residuals::INFINITE;
    }
    r
}

/// The smallest tolerance the command line, bench budgets and scene files accept. Rounding in
/// `w_i` leaves a correctly rounded solution a relative residual of up to about
/// `4 (nnz_i + 1) ε` in row `i` (`4e-15` for a row of a few entries, `1e-13` at a hundred), so
/// a smaller tolerance is met only by chance, and its failure says nothing about the problem.
pub const MIN_TOLERANCE: f64 = 1e-14;

/// The largest natural-map step a converged result may leave in a row, as a share of the row's
/// [data scale](data_scale) (the data-resolution test of the module doc).
pub const RESOLUTION: f64 = 0.05;

/// The row that a result resolves worst against the problem's data: its natural-map step
/// `e_i = d_i · |f_i − mid(lo_i, hi_i, f_i − w_i / d_i)|` (velocity units), the row's
/// [data scale](data_scale) `D_i`, the magnitude `t_i = |b_i| + Σ_j |A_ij f_j|` of its terms and
/// their round-off `u_i t_i`, `u_i = 4 (nnz_i + 1) ε`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Unresolved {
    /// Row index.
    pub row: usize,
    /// `e_i`.
    pub step: f64,
    /// `D_i`.
    pub data_scale: f64,
    /// `t_i`.
    pub magnitude: f64,
    /// `u_i t_i`.
    pub round_off: f64,
}

impl Unresolved {
    /// `max(e_i, u_i t_i) / D_i`: how much of the data scale the step, or the round-off of the
    /// row's terms, reaches. A row without data (`D_i = 0`) gives `∞` when its step exceeds
    /// round-off and `0` otherwise.
    pub fn ratio(&self) -> f64 {
        if self.data_scale > 0.0 {
            self.step.max(self.round_off) / self.data_scale
        } else if self.step > self.round_off {
            f64::INFINITY
        } else {
            0.0
        }
    }
}

/// The relative round-off `4 (nnz + 1) ε` of a velocity summed from `nnz` products and `b_i`.
fn round_off(nnz: usize) -> f64 {
    4.0 * (nnz as f64 + 1.0) * f64::EPSILON
}

/// Each row's data scale `D_i`, in the row's velocity units: the largest data velocity of the
/// row's island ([`Problem::islands`]), carried into the row's units through the diagonal,
///
/// ```text
/// D_i = √d_i · max_{j in i's island} |b_j| / √d_j.
/// ```
///
/// `|b_j| / √d_j` is row `j`'s data in the units of the symmetrically equilibrated problem
/// `S A S` (`s_j = 1/√d_j`), where every row of a contact problem measures a velocity alike, so
/// `D_i` follows every symmetric positive diagonal scaling (`A → S A S`, `b → S b`) as `w_i`
/// does. A row whose own data are 0 or round-off (a resting contact's friction rows, the inner
/// contacts of a stack, which fall with the boxes they join) gets its island's: a legitimate
/// impulse carries the data of its whole load path (the bottom contact of a 40-box tower holds
/// the weight of all the boxes above, from the one datum at the ground), so a scale that
/// decays with the distance from the data would call it unresolved. `O(nnz)`.
pub fn data_scale(problem: &Problem) -> Vec<f64> {
    let n = problem.n();
    let b = problem.b();
    let root: Vec<f64> = problem.diagonal_scale().iter().map(|d| d.sqrt()).collect();
    let mut scale = vec![0.0; n];
    for island in problem.islands() {
        let largest = island
            .iter()
            .fold(0.0f64, |m, &j| m.max(ratio(b[j].abs(), 1.0, root[j])));
        for &i in island {
            scale[i] = ratio(root[i], largest, 1.0);
        }
    }
    scale
}

/// The row with the largest [`Unresolved::ratio`] at `f` (with `w = A f + b` given), when that
/// ratio exceeds [`RESOLUTION`]: a row whose natural-map step is a sizeable share of the
/// velocities the problem's data produce, so that its relative residual is small only because
/// its terms are much larger than its data and cancel, or whose terms are so large that their
/// round-off alone is (the data are lost in it). `None` when every row is resolved (or the
/// lengths do not match).
pub fn unresolved_row(problem: &Problem, f: &[f64], w: &[f64]) -> Option<Unresolved> {
    let n = problem.n();
    if f.len() != n || w.len() != n || resolved_by_own_data(problem, f, w) {
        return None;
    }
    worst_unresolved(problem, f, w)
}

/// Relative margin on the bound of a row's term magnitude in [`resolved_by_own_data`]: far
/// above the relative rounding of a sum of `nnz_i` products (`(nnz_i + 2) ε`, below `1e-6` for
/// any row of fewer than `4e9` entries).
const MAGNITUDE_MARGIN: f64 = 1e-6;

/// True when every row passes the data-resolution test with room to spare on bounds that need
/// neither the islands nor a pass over `A`, so that [`worst_unresolved`] would report no row:
///
/// * the row's own data `√d_i · |b_i| / √d_i` (formed as [`data_scale`] forms it) is a lower
///   bound of its data scale `D_i`, the largest over its island;
/// * `|b_i| + nnz_i · max|A| · max|f|` (with the margin [`MAGNITUDE_MARGIN`] and one smallest
///   normal for the absolute rounding of subnormal products) is an upper bound of its term
///   magnitude `t_i`, hence of its round-off `u_i t_i`;
/// * the step `e_i` is the full test's own (it does not depend on `t_i`);
///
/// and a row passes when `max(e_i, u_i t_i)` is within half of `RESOLUTION` times that lower
/// bound (the factor 2 covers the rounding of `D_i`, also where [`ratio`] forms it through
/// logarithms). A row without own data (`b_i = 0`) never passes here, nor does any row of an `A`
/// held as its factors (its largest entry is bounded by its largest diagonal only in exact
/// arithmetic): the full test decides them. `O(n)`; on a problem whose every row has data, as
/// a converged answer usually does, it spares the union–find of [`Problem::islands`] and a
/// pass over the stored entries.
fn resolved_by_own_data(problem: &Problem, f: &[f64], w: &[f64]) -> bool {
    if problem.is_factored() {
        return false;
    }
    let b = problem.b();
    let largest_f = f.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let largest_a = problem.max_abs_entry();
    (0..problem.n()).all(|i| {
        let len = problem.row(i).len();
        let d = problem.diagonal_scale_of(i);
        let root = d.sqrt();
        let own = ratio(root, ratio(b[i].abs(), 1.0, root), 1.0);
        let magnitude = (b[i].abs() + len as f64 * largest_a * largest_f)
            * (1.0 + MAGNITUDE_MARGIN)
            + f64::MIN_POSITIVE;
        let (lo, hi) = problem.bounds_at(i, f);
        let step = row_step(f[i], lo, hi, w[i], d, magnitude).0;
        let reach = step.max(round_off(len) * magnitude);
        step.is_finite() && magnitude.is_finite() && reach <= 0.5 * RESOLUTION * own
    })
}

/// [`unresolved_row`] in full: every row's data scale from its island, and its term
/// magnitude from a pass over `A`.
fn worst_unresolved(problem: &Problem, f: &[f64], w: &[f64]) -> Option<Unresolved> {
    let n = problem.n();
    let b = problem.b();
    let scales = data_scale(problem);
    let mut worst: Option<(f64, Unresolved)> = None;
    let factored = problem.unassembled_factors().map(|factors| {
        let mut af = vec![0.0; n];
        factored_row_terms(factors, f, &mut af, true)
    });
    for i in 0..n {
        let (magnitude, len) = match &factored {
            Some((magnitude, len)) => (magnitude[i], len[i]),
            None => {
                let row = problem.row(i);
                (row.dot_and_magnitude(f).1, row.len())
            }
        };
        let t = b[i].abs() + magnitude;
        let (lo, hi) = problem.bounds_at(i, f);
        let step = row_step(f[i], lo, hi, w[i], problem.diagonal_scale_of(i), t).0;
        let u = Unresolved {
            row: i,
            step,
            data_scale: scales[i],
            magnitude: t,
            round_off: round_off(len) * t,
        };
        let r = u.ratio();
        let r = if r.is_nan() { f64::INFINITY } else { r };
        if r > RESOLUTION && worst.as_ref().is_none_or(|(m, _)| r > *m) {
            worst = Some((r, u));
        }
    }
    worst.map(|(_, u)| u)
}

/// A global impulse scale `max(‖D⁻¹ b‖∞, largest finite fixed bound)` (1 when zero): the size
/// of impulse the problem's data call for. The residual is per row and does not use it; the
/// pivoting, Newton and enumeration solvers size their internal round-off tolerances by it.
pub(crate) fn impulse_scale(problem: &Problem) -> f64 {
    let b = problem.b();
    let (lo, hi) = (problem.lo(), problem.hi());
    let s = (0..problem.n()).fold(0.0f64, |m, i| {
        let mut m = m.max((b[i] / problem.diagonal_scale_of(i)).abs());
        if problem.friction_of(i).is_none() {
            for v in [lo[i], hi[i]] {
                if v.is_finite() {
                    m = m.max(v.abs());
                }
            }
        }
        m
    });
    if s > 0.0 {
        s
    } else {
        1.0
    }
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

    /// The attacks the per-row scale guards against: a weak row (tiny `A_ii`) and a huge finite
    /// bound on an unrelated row must not hide the error of the other rows.
    #[test]
    fn no_row_hides_another_rows_error() {
        let weak = Problem::lcp(
            Mat::from_fn(3, 3, |i, j| {
                [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1e-9]][i][j]
            }),
            vec![-1.0, -1.0, 1.0],
        )
        .unwrap();
        // f = 0 leaves rows 0 and 1 at w = -1: 100 % wrong.
        assert!(residuals(&weak, &[0.0; 3]).natural_map_rel >= 0.5);
        // f = (0.5, 0.25, 0): row 1 off by w_1 = 0.0 - ..., row 0's w_0 = 0.25.
        assert!(residuals(&weak, &[0.5, 0.25, 0.0]).natural_map_rel > 0.1);
        // The exact solution f = (1/3, 1/3, 0).
        assert!(residuals(&weak, &[1.0 / 3.0, 1.0 / 3.0, 0.0]).natural_map_rel < 1e-15);

        let huge_bound = Problem::boxed(
            Mat::from_fn(3, 3, |i, j| {
                [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]][i][j]
            }),
            vec![-1.0, -1.0, 1.0],
            vec![0.0, 0.0, -1e12],
            vec![f64::INFINITY, f64::INFINITY, 1e12],
            vec![],
        )
        .unwrap();
        assert!(residuals(&huge_bound, &[0.0; 3]).natural_map_rel >= 0.5);
        // Row 2's own error is not hidden by its own huge bound either (solution f_2 = -1).
        let r = residuals(&huge_bound, &[1.0 / 3.0, 1.0 / 3.0, 0.0]).natural_map_rel;
        assert!(r >= 0.5, "{r}");
    }

    /// Invariance under independent positive row and column scalings `A → R A C`, `b → R b`,
    /// `f → C⁻¹ f`, over 24 decades.
    #[test]
    fn relative_residual_is_invariant_under_row_and_column_scaling() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, -1.0], [0.5, -1.0, 2.0]];
        let b = [-1.0, 0.5, -2.0];
        let f = [0.3, 0.0, 1.1];
        let p = Problem::lcp(Mat::from_fn(3, 3, |i, j| a[i][j]), b.to_vec()).unwrap();
        let r0 = residuals(&p, &f).natural_map_rel;
        assert!(r0 > 0.0);
        let (rs, cs) = ([1e12, 1e-12, 3.0], [1e-9, 7.0, 1e11]);
        let q = Problem::lcp(
            Mat::from_fn(3, 3, |i, j| rs[i] * a[i][j] * cs[j]),
            (0..3).map(|i| rs[i] * b[i]).collect(),
        )
        .unwrap();
        let g: Vec<f64> = (0..3).map(|j| f[j] / cs[j]).collect();
        let r1 = residuals(&q, &g).natural_map_rel;
        assert!((r1 - r0).abs() <= 1e-12 * r0, "{r0} vs {r1}");
    }

    #[test]
    fn sparse_and_dense_residuals_agree() {
        let a = [[4.0, 1.0, 0.0], [1.0, 3.0, 0.0], [0.0, 0.0, 2.0]];
        let dense =
            Problem::lcp(Mat::from_fn(3, 3, |i, j| a[i][j]), vec![-1.0, 0.5, -2.0]).unwrap();
        let triplets: Vec<_> = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j, a[i][j])))
            .filter(|t| t.2 != 0.0)
            .collect();
        let sparse = Problem::lcp_sparse(
            crate::problem::sparse_from_triplets(3, &triplets).unwrap(),
            vec![-1.0, 0.5, -2.0],
        )
        .unwrap();
        let f = [0.2, 0.1, 0.7];
        assert_eq!(residuals(&dense, &f), residuals(&sparse, &f));
    }

    fn diagonal(d: f64, b: &[f64]) -> Problem {
        let n = b.len();
        Problem::lcp(
            Mat::from_fn(n, n, |i, j| if i == j { d } else { 0.0 }),
            b.to_vec(),
        )
        .unwrap()
    }

    /// A row scale that overflows, underflows or is subnormal cannot round a row's residual to
    /// 0: at `f = 0` with `b < 0` every row is 100 % wrong, whatever `A_ii`.
    #[test]
    fn extreme_row_scales_cannot_zero_the_residual() {
        for (d, b) in [
            (1e-300, -1e10),
            (5e-324, -1.0),
            (1e300, -1e-300),
            (1.0, -1.0),
        ] {
            let p = diagonal(d, &[b, b]);
            assert_eq!(residuals(&p, &[0.0, 0.0]).natural_map_rel, 1.0, "d = {d:e}");
        }
        // A finite impulse far short of the (unrepresentable) solution 1/5e-324.
        let p = diagonal(5e-324, &[-1.0, -1.0]);
        let r = residuals(&p, &[1e300, 1e300]).natural_map_rel;
        assert!(r > 0.9, "{r}");
    }

    /// A huge impulse cannot absorb the velocity in `f − (f − w)`: with `A = 0`, `b = −1` no `f`
    /// solves the problem, and `f = 9e15` is as wrong as `f = 0`.
    #[test]
    fn a_huge_impulse_does_not_absorb_its_velocity() {
        let p = diagonal(0.0, &[-1.0, -2.0]);
        for f in [0.0, 9e15, 1e300] {
            let r = residuals(&p, &[f, f]);
            assert_eq!(r.natural_map_rel, 1.0, "f = {f:e}");
            assert_eq!(r.natural_map, 2.0, "f = {f:e}");
        }
    }

    /// Terms whose magnitudes overflow leave a row unmeasurable: `∞`, never 0 or NaN.
    #[test]
    fn overflowing_magnitudes_are_infinitely_wrong() {
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, -1.0], [-1.0, 1.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        let r = residuals(&p, &[1.7e308, 1.7e308]);
        assert_eq!(r.natural_map_rel, f64::INFINITY);
        assert_eq!(
            relative_row_error(&p, 0, &[1.7e308, 1.7e308], -1.0, f64::INFINITY),
            f64::INFINITY
        );
    }

    /// The data-resolution test: an impulse growing along the null direction of the 2×2 problem
    /// without a solution meets any tolerance but leaves its rows unresolved; the solution of a
    /// solvable problem, a resting contact's friction row with `b = 0`, and a row solved to
    /// round-off are resolved.
    #[test]
    fn a_diverging_impulse_is_unresolved() {
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, -1.0], [-1.0, 1.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        for t in [1e4, 1e8, 1e12] {
            let f = [t, t];
            let w = p.velocity(&f);
            assert!(residuals(&p, &f).natural_map_rel < 1.0 / t);
            let u = unresolved_row(&p, &f, &w).expect("unresolved");
            assert_eq!((u.step, u.data_scale), (1.0, 1.0));
        }
        // Solvable: A = [[2, 1], [1, 2]], b = (−1, −1), f = (1/3, 1/3).
        let a = Mat::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 2.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        let f = [1.0 / 3.0, 1.0 / 3.0];
        assert!(unresolved_row(&p, &f, &p.velocity(&f)).is_none());
        // A friction row with b = 0 whose velocity is 1e-9 of its terms: its neighbours' data
        // give it a scale, and the step is far inside it.
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, 0.5], [0.5, 1.0]][i][j]);
        let p = Problem::boxed(
            a,
            vec![-1.0, 0.0],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![crate::FrictionRow {
                row: 1,
                normal: 0,
                mu: 1.0,
            }],
        )
        .unwrap();
        let f = [4.0 / 3.0, -2.0 / 3.0 + 1e-9];
        let w = p.velocity(&f);
        assert!(w[1].abs() > 1e-10);
        assert!(unresolved_row(&p, &f, &w).is_none());
        assert_eq!(data_scale(&p), vec![1.0, 1.0]);
    }

    /// The shortcut of [`unresolved_row`] (rows resolved against their own data and a bound
    /// of their terms) never changes its answer: against the full test on planted
    /// near-solutions (taken by the shortcut), diverging impulses (unresolved rows) and rows
    /// without data, dense and sparse, with a fixed seed.
    #[test]
    fn the_own_data_shortcut_agrees_with_the_full_test() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xda7a);
        let (mut shortcut, mut unresolved) = (0, 0);
        for case in 0..400 {
            let n = 1 + case % 7;
            let x: Vec<f64> = (0..n * n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let a = Mat::from_fn(n, n, |i, j| {
                let v: f64 = (0..n).map(|k| x[k * n + i] * x[k * n + j]).sum();
                let v = if i != j && v.abs() < 0.3 { 0.0 } else { v };
                v + if i == j { 0.1 * n as f64 } else { 0.0 }
            });
            let scale = [1e-3, 1.0, 1e6][case % 3];
            let (f, b): (Vec<f64>, Vec<f64>) = match case % 4 {
                // A planted near-solution: w = A f + b small where f > 0, positive where f = 0.
                0 | 1 => {
                    let f: Vec<f64> = (0..n)
                        .map(|_| {
                            if rng.random_bool(0.6) {
                                scale * rng.random_range(0.1..1.0)
                            } else {
                                0.0
                            }
                        })
                        .collect();
                    let noise = [0.0, 1e-12, 1e-3][(case / 4) % 3];
                    let b = (0..n)
                        .map(|i| {
                            let w = if f[i] > 0.0 {
                                noise * scale * rng.random_range(-1.0..1.0)
                            } else {
                                scale * rng.random_range(0.0..1.0)
                            };
                            w - (0..n).map(|j| a[(i, j)] * f[j]).sum::<f64>()
                        })
                        .collect();
                    (f, b)
                }
                // Large impulses against small data, some rows without data.
                _ => {
                    let f = (0..n).map(|_| scale * rng.random_range(0.0..1.0)).collect();
                    let b = (0..n)
                        .map(|_| {
                            if rng.random_bool(0.2) {
                                0.0
                            } else {
                                rng.random_range(-1.0..1.0)
                            }
                        })
                        .collect();
                    (f, b)
                }
            };
            let dense = Problem::lcp(a.clone(), b.clone()).unwrap();
            let triplets: Vec<_> = (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .filter(|&(i, j)| a[(i, j)] != 0.0)
                .map(|(i, j)| (i, j, a[(i, j)]))
                .collect();
            let sparse = Problem::lcp_sparse(
                crate::problem::sparse_from_triplets(n, &triplets).unwrap(),
                b,
            )
            .unwrap();
            for p in [&dense, &sparse] {
                let w = p.velocity(&f);
                let full = worst_unresolved(p, &f, &w);
                assert_eq!(unresolved_row(p, &f, &w), full, "case {case}");
                if resolved_by_own_data(p, &f, &w) {
                    assert!(full.is_none(), "case {case}");
                    shortcut += 1;
                }
                unresolved += usize::from(full.is_some());
            }
        }
        // Both branches are exercised.
        assert!(shortcut >= 100, "{shortcut}");
        assert!(unresolved >= 100, "{unresolved}");
    }

    /// Data scales follow every symmetric positive diagonal scaling as velocities do, so the
    /// test's verdict is invariant: `D → S D` under `A → S A S`, `b → S b`, over 24 decades; and
    /// every row of an island gets the island's data, however far from it.
    #[test]
    fn data_scales_follow_symmetric_scaling() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, -1.0], [0.5, -1.0, 2.0]];
        let b = [-1.0, 0.0, -2.0];
        let p = Problem::lcp(Mat::from_fn(3, 3, |i, j| a[i][j]), b.to_vec()).unwrap();
        let s = [1e12, 1e-12, 3.0];
        let q = Problem::lcp(
            Mat::from_fn(3, 3, |i, j| s[i] * a[i][j] * s[j]),
            (0..3).map(|i| s[i] * b[i]).collect(),
        )
        .unwrap();
        let (dp, dq) = (data_scale(&p), data_scale(&q));
        for i in 0..3 {
            assert!(
                (dq[i] / s[i] - dp[i]).abs() <= 1e-12 * dp[i],
                "{dp:?} {dq:?}"
            );
        }
        // A chain 0 – 1 – 2 – 3 with data only at its end: every row gets it.
        let chain = Mat::from_fn(4, 4, |i, j| match i.abs_diff(j) {
            0 => 2.0,
            1 => -1.0,
            _ => 0.0,
        });
        let p = Problem::lcp(chain, vec![-1.0, 0.0, 0.0, 0.0]).unwrap();
        assert_eq!(data_scale(&p), vec![1.0; 4]);
    }
}

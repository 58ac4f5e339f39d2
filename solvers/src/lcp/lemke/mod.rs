//! Lemke's complementary pivoting method with a covering vector.
//!
//! Lemke pivots on the standard LCP `w = M z + q`, `0 <= z ⟂ w >= 0`, augmented by an artificial
//! variable `z0 >= 0` and a covering vector `d > 0`:
//!
//! ```text
//! w = q + M z + d z0,   w, z, z0 >= 0,   w_i z_i = 0.
//! ```
//!
//! It starts from `z = 0`, `z0 = max_i(−q_i / d_i)`, and follows the path of almost
//! complementary basic solutions: after each pivot, the complement of the variable that just
//! left the basis enters, until `z0` leaves (a solution) or the entering column has no positive
//! entry (ray termination). The leaving row comes from a lexicographic minimum-ratio test on
//! `[x_B | B⁻¹]`, so degenerate problems (`q = 0`, duplicated rows) do not cycle; on a tie with
//! `z0`'s row, `z0` leaves.
//!
//! * **Problem class**: the standard LCP; boxed problems with fixed bounds through the reduction
//!   below; mixed problems with free (equality) rows through their elimination (below). Lemke
//!   *processes* copositive-plus matrices (symmetric positive semidefinite, positive
//!   definite, non-symmetric P-matrices…): it either finds a solution or ends in a ray, and for
//!   a copositive-plus `M` a ray proves that no solution exists (Cottle–Pang–Stone, Thm 4.4.13).
//!   On other matrices a ray proves nothing: it is reported as `NoSolution` only when the reduced
//!   `M` passes the sufficient test `M + Mᵀ` positive semidefinite (an eigenvalue decomposition,
//!   done only after a ray), and as `Stalled` ("not a proof of infeasibility for this matrix
//!   class") otherwise; [`crate::Enumeration`] settles such small problems. Friction rows
//!   (box friction, `|f_i| <= mu f_k`) go through the sliding reduction below; their normal row
//!   must have bounds `[0, ∞)`, or the problem is `Unsupported` with the reason.
//! * **Boxed reduction** (row `i`, with `w = A f + b`):
//!   `lo_i` finite, `hi_i = ∞`: `f_i = lo_i + x`, `x ⟂ w_i`;
//!   `lo_i = −∞`, `hi_i` finite: `f_i = hi_i − x`, `x ⟂ −w_i`;
//!   both finite: `f_i = lo_i + x` and a slack `y`, with `x ⟂ w_i + y` and
//!   `y ⟂ (hi_i − lo_i) − x` (the `[[A, I], [−I, 0]]` augmentation);
//!   both infinite (free): `f_i = x⁺ − x⁻` with `x⁺ ⟂ w_i` and `x⁻ ⟂ −w_i`, which together force
//!   `w_i = 0` (only for the free rows the elimination below leaves). Every block keeps `M`
//!   positive semidefinite when `A` is, so the guarantee above carries over. The standard LCP
//!   maps to itself (`M = A`, `q = b`).
//! * **Free (equality) rows** (a joint's `lo = −∞`, `hi = +∞`, `w_i = 0`) are *eliminated* before
//!   the reduction ([`crate::lcp::free_rows`]): with `F` the free rows and `C` the others,
//!   `f_F = −A_FF⁻¹ (b_F + A_FC f_C)`, and Lemke pivots on the reduction of
//!   `M = A_CC − A_CF A_FF⁻¹ A_FC`, `q = b_C − A_CF A_FF⁻¹ b_F`, the Schur complement of the
//!   equilibrated `A_FF` (LU with diagonal pivoting and a relative pivot test, `1e-8`); `f_F` is
//!   recovered after, and refined. When the
//!   impulse misses the tolerance, the basis it suggests is re-solved on `A` itself (islands of at
//!   most 600 rows), so that the complement's round-off, a sizeable share of the small entries of
//!   contacts held by joints with large mass ratios, does not stay in the answer. A Schur
//!   complement of a positive semidefinite `A` is positive semidefinite (of a P-matrix, a
//!   P-matrix), and the mixed and the reduced problems have the same solutions, so the ray
//!   reasoning above holds for the reduced `M` (the test after a ray runs on that `M`). When `A_FF`
//!   is singular (redundant joints: a closed loop, a repeated joint, a weld beside a hinge), a
//!   regular block of the free rows is eliminated and the dependent rows, whose rows of `M` then
//!   vanish, are dropped with `f_i = 0` when their `q_i` is 0 (consistent joints); a dependent row
//!   that does not vanish, or has `q_i ≠ 0` (inconsistent joints), stays in the reduced problem and
//!   is split into `x⁺ − x⁻`, as is every free row when no pivot of `A_FF` passes the test.
//!   Splitting every free row instead would double them in the tableau and pivot on the dependent
//!   rows of a singular `A_FF` (measured: on a welded chain with a `1e6` mass ratio it ends in a
//!   round-off ray, which the test above takes for a proof that the solvable problem has no
//!   solution). The reason of a status other than `converged` ends with what was done (rows
//!   eliminated, dropped, kept free). A free row that friction rows name as their normal is neither
//!   eliminated nor accepted (its friction rows need a normal on `[0, ∞)`).
//! * **Sliding reduction** (friction row `i` on normal row `k`, bounds `±mu f_k`): `f_i = x⁺ − x⁻`
//!   and a sliding speed `λ >= 0`, with `x⁺ ⟂ w_i + λ`, `x⁻ ⟂ −w_i + λ` and
//!   `λ ⟂ mu f_k − x⁺ − x⁻`: the per-row form of the Anitescu–Potra LCP (for each friction row
//!   the interval `[−mu f_k, mu f_k]` is the hull of its two ends, and maximal dissipation over it
//!   is exactly the box condition: `w_i = 0` inside, `w_i <= 0` at `+mu f_k`, `w_i >= 0` at
//!   `−mu f_k`). Three LCP variables per friction row. The reduced `M` is copositive
//!   (`zᵀ M z = gᵀ A g + Σ mu λ f_k` for `z >= 0`) but not copositive-plus, so a ray is reported
//!   as `Stalled`, never as a proof. Lemke still ends at a solution whenever `qᵀz >= 0` on
//!   `SOL(0, M)` (Cottle–Pang–Stone §4.4; Anitescu and Potra, *Formulating dynamic
//!   multi-rigid-body contact problems with friction as solvable linear complementarity
//!   problems*, Nonlinear Dynamics 14, 1997), which holds when `A` is positive definite, and
//!   when `A` is only semidefinite but no nonzero impulse `g` in the friction boxes has `A g = 0`
//!   (the jammed 200-sphere pile: 183 null directions of `A`, none of them in the boxes).
//!   Friction rows whose data are round-off beside their island's (a resting sphere's
//!   `b_t ≈ 1e-18`) can come out wrong in their own row's scale; when the impulse misses the
//!   tolerance, up to five projected Gauss–Seidel sweeps polish it, kept only if the shared
//!   residual falls.
//! * **Cost**: the elimination of free rows, once: `O(|F|³ + |F|² |C| + |F| |C|²)`. Revised form
//!   with an explicit `B⁻¹`: `O(m²)` per pivot (`m` the size of the reduced LCP), plus an `O(m³)`
//!   refactorisation of the basis every `max(50, m)` pivots and at the end (followed by iterative
//!   refinement; skipped at the end when the basic solution already meets the tolerance in the
//!   shared residual, one `O(m²)` pass). The number of pivots is usually a small multiple of `m`,
//!   but is `2ⁿ` on Murty's example (below).
//! * **Failure modes**: ray termination (`NoSolution` or `Stalled` as above, reason
//!   `ray termination at pivot k …`);
//!   pivot cap ([`Settings::max_iterations`] counts pivots, the first `z0` pivot included) gives
//!   `IterationLimit`; the time budget gives `TimeLimit`; a singular basis at a refactorisation
//!   or a non-finite column gives `NumericalFailure`.
//! * **Degenerate, nearly singular problems** (the pyramid LCPs of resting stacks: four
//!   contacts per face, opposite friction directions, and a `1e-9` drift of the boxes that
//!   makes coplanar contacts almost dependent, so entries of `y` of `1e-9` are data, not
//!   round-off, and pivoting on them gives bases with `cond(B) ≈ 1e9`). Four rules, each from a
//!   failure of the 10-box tower (`contact/tests/analytic.rs`):
//!   - entries below `1e-8 · max(1, max|y|)` in the entering column `y` are never pivoted on
//!     (at `1e-11`, step 265 pivoted on a round-off `4.9e-11` against `max|y| = 4.5`; at `1e-9`,
//!     step 462 pivoted on a genuine `1.8e-9` and lost nine digits);
//!   - the ratio test reads round-off negative basic values as zero, *and the step uses that
//!     zero*: `θ = max(x_B_r, 0) / y_r`. Before, the step took the negative value, so a
//!     degenerate pivot on a small `y_r` moved the entering variable to `−4.7e-3` (scaled) and
//!     every basic value with it; the "solution" of step 462 left a face without normal force
//!     (residual 1.0) and the tower fell;
//!   - a refactorisation refines `x_B` while the residual of `B x = q` shrinks (at most three
//!     steps), since one step is not enough at `cond(B) ≈ 1e9`;
//!   - the final basic values below `1e-12 … 1e-6 · max z` are tried as exact zeros (degenerate
//!     pivots computed with round-off) when the raw impulse misses the tolerance, and the
//!     impulse with the smaller shared residual is kept: a friction impulse of `1e-10` of the
//!     normal ones on a contact without normal force is 100 % wrong in its cone row's own
//!     scale.
//!
//!   In every case the returned impulse is the current basic solution's `z` mapped back to
//!   `f`, and the shared residual decides the status.
//! * **It never spins**: the path of almost complementary bases visits each basis at most once
//!   (the lexicographic rule keeps degenerate pivots from cycling), so a solve ends after
//!   finitely many pivots, or at the pivot cap. What it can do is *stall* short of a tight tolerance on
//!   degenerate problems, and the 10-box tower at 60 Hz under the pyramid model shows where
//!   that is unavoidable in double precision (`lcpbench simulate
//!   bench_scenes/tower_10_60hz.toml --friction-model pyramid -s lemke --tol 1e-8 --max-iter
//!   1000`: 551 of 600 steps converge, 49 end `stalled` after at most 192 pivots):
//!   - on 22 of the 49 (steps 157–328) the basic solution misses `1e-8` by a factor of 1 to
//!     250. A basis of these LCPs has `cond(B) ≈ 1e9` (coplanar contacts, opposite friction
//!     directions), so its basic values carry a relative error near `ε · cond(B) ≈ 1e-7`, and
//!     the ratio test can meet an unblocked column at such a point (the rays of those steps):
//!     for this solvable LCP (Stewart and Trinkle 1996, Anitescu and Potra 1997) that ray is
//!     round-off. Min-map Newton from Lemke's impulse does not mend it in a few steps (it
//!     needs 67 iterations on step 157, as many as from zero), so it is not used as a polish;
//!   - from step 329 on, the tower rocks onto edges and the steps are harder than the
//!     tolerance for every method here: on step 336 Lemke ends at `1.3e-4`, min-map Newton at
//!     `1.3e-5`, Fischer–Burmeister Newton at `1.2e-4`, and Dantzig meets a singular pivot.
//!
//!   The tower stands through all of them (sag `1e-5` m, lateral drift `1.7e-4` m): the
//!   impulses of the stalled steps are accurate to what double precision allows there, and the
//!   status says they are not certified to the tolerance.
//! * **Trivial case**: `q >= 0` returns `z = 0` after zero pivots.
//! * **Warm start**: ignored; Lemke always starts from `z = 0`.
//!
//! * **Scaling**: each island is first equilibrated symmetrically (`A' = S A S`, `b' = S b`,
//!   `s_i = 1/√d_i` with `d_i` the diagonal scale), so rows and columns scaled over many decades
//!   do not decide the pivots; then the reduced data are scaled (`M / max|M|`, `q / max|q|`,
//!   `d / max d`) so the pivot and tie tolerances are relative; the solution is scaled back.
//!   (Scaling by the nearest power of two instead, exact and cheaper, changes the round-off of
//!   every later pivot: on the resting 10-box tower's pyramid LCPs that was enough for the tower
//!   to fall. The degenerate steps of that test are that sensitive.)
//! * **Per-solve cost on tiny problems** (where it is all overhead): `B⁻¹` is stored
//!   column-major, and only the columns a pivot has changed are stored at all: the unit
//!   columns of the starting basis are neither written nor zero-filled, a pivot in row `r`
//!   skips every column with a zero in row `r` (all unit columns but `e_r`), and the entering
//!   column and the ratio test take a unit column's single nonzero as it is. A solve of `p`
//!   pivots thus costs `O(p² k)` rather than `O(p k²)` in its updates. The buffers of the pivot
//!   loop (entering column, ratio-test candidates and their ratios, each computed once) are
//!   allocated once per solve, a standard LCP's `M` is written without a zero fill, and the
//!   impulse measured for the stopping test is the one returned.
//! * **Sparse and large problems**: the problem is split into independent islands
//!   ([`Problem::islands`]); each is densified and solved on its own. An island above
//!   [`DENSE_LIMIT`] rows gives `Unsupported` with the reason.
//!
//! Measured on Murty's example ([`crate::problem::generate::Family::Murty`]: `M` lower triangular, 1 on
//! the diagonal and 2 below, `q = −e`, `d = e`): exactly `2ⁿ` pivots, the first `z0` pivot and
//! the last included, for every `n = 2..=10` (4, 8, 16, …, 1024; the unit tests check it). The
//! first pivot is a tie between all rows, which the lexicographic rule breaks towards the last
//! row; the transposed matrix (upper triangular) is solved in 2 pivots by the same rule.
//!
//! References: C. E. Lemke, *Bimatrix equilibrium points and mathematical programming*,
//! Management Science 11, 1965; R. W. Cottle, J.-S. Pang, R. E. Stone, *The Linear
//! Complementarity Problem*, 1992, §4.4 (and the mixed LCP); K. G. Murty, *Linear
//! Complementarity, Linear and Nonlinear Programming*, 1988, ch. 2 (and ch. 6 for the
//! exponential example); Siconos numerics, the MLCP solvers (`mlcp_enum`, `mlcp_simplex`), for
//! the mixed problem with a free part.

mod reduction;

use crate::lcp::free_rows::polish_on_basis;
use crate::lcp::ray::{is_psd, ray_outcome};
use crate::problem::metrics::residuals;
use crate::problem::Problem;
use crate::solver::{solve_by_islands, Monitor, Outcome, Settings, SolveResult, Solver};
use reduction::Reduction;
use std::fmt;

/// Largest island Lemke densifies (the reduced tableau is at most `3n × 3n`, for friction rows).
pub const DENSE_LIMIT: usize = 1500;

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "LCP, boxed LCP with fixed bounds and box-friction rows (reduced to an LCP; friction rows by the sliding reduction, on normals with bounds [0, inf)); free (equality) rows eliminated through the Schur complement of A_FF (redundant ones dropped, split into x+ - x- only when A_FF has no regular block); processes PSD and P-matrix A; dense per island up to 1500 rows";

/// The registry's entry of `lemke`.
pub static LEMKE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "lemke",
    summary: "Lemke's complementary pivoting",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "pivots",
    iterative: false,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(Lemke::default())),
};

/// Lemke's complementary pivoting method. See the module documentation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lemke {
    /// Covering vector `d > 0` of the standard LCP that Lemke pivots on. Its length must be that
    /// LCP's size: `n` for a standard problem; for a boxed problem the rows left after the
    /// elimination of free rows, plus one per row with both bounds finite, one per free row
    /// left and two per friction row (see the reductions in the module doc). Default `None`:
    /// all ones.
    pub covering: Option<Vec<f64>>,
}

impl Lemke {
    /// Lemke with the covering vector `d` (all entries finite and `> 0`).
    pub fn with_covering(d: Vec<f64>) -> Self {
        Self { covering: Some(d) }
    }
}

impl Solver for Lemke {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &LEMKE
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let covering = self.covering.clone();
        solve_by_islands(problem, settings, DENSE_LIMIT, |island, settings| {
            solve_island(island, settings, covering.as_deref())
        })
    }
}

/// Lemke on one island: eliminate the free rows, equilibrate, reduce, pivot, map back.
fn solve_island(problem: &Problem, settings: &Settings, covering: Option<&[f64]>) -> SolveResult {
    let mut monitor = Monitor::new(problem, settings);
    let reduction = match Reduction::new(problem) {
        Ok(r) => r,
        Err(reason) => return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason)),
    };
    let m = reduction.q.len();
    let d = match covering {
        None => vec![1.0; m],
        Some(d) if d.len() != m => {
            let reason = format!(
                "covering vector has length {}, but the reduced LCP has {m} rows",
                d.len()
            );
            return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
        }
        Some(d) => match d.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            Some(i) => {
                let reason = format!("covering vector entry d[{i}] = {} is not > 0", d[i]);
                return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
            }
            None => d.to_vec(),
        },
    };
    let (z, pivots, outcome, f) = pivot(&reduction, d, settings, &mut monitor);
    let mut f = match f {
        Some(f) => f,
        None => degenerate_zeros(problem, &reduction, z, settings.tolerance),
    };
    if outcome == Outcome::Stopped && !problem.friction().is_empty() {
        polish_friction_rows(problem, &mut f, settings.tolerance, &mut monitor);
    }
    if outcome == Outcome::Stopped && reduction.free.eliminated() {
        polish_on_basis(problem, &mut f, settings.tolerance, &mut monitor);
    }
    let outcome = reduction.free.annotate(outcome);
    monitor.finish(f, pivots, outcome)
}

/// Most projected Gauss–Seidel sweeps that [`polish_friction_rows`] tries.
const POLISH_SWEEPS: usize = 5;

/// A few projected Gauss–Seidel sweeps from Lemke's impulse when it misses `tol`, kept only if
/// they lower the shared residual. The reduced LCP's pivot tolerances are relative to the whole
/// island, so a friction row whose data are round-off beside the island's (a resting sphere's
/// `b_t ≈ 1e-18` next to normals near 1) comes out at `1e-12` instead of `1e-18`: 100 % wrong in
/// its own row's scale. One or two sweeps put such rows right and leave solved rows as they are.
fn polish_friction_rows(problem: &Problem, f: &mut [f64], tol: f64, monitor: &mut Monitor<'_>) {
    let mut best = monitor.residual_of(f);
    if best <= tol {
        return;
    }
    let skip = crate::problem::diagonal::skipped_rows(problem);
    let d = problem.diagonal_scale();
    let mut g = f.to_vec();
    // Whether the monitor's last measurement is of `f` (then `finish` reuses it).
    let mut last_is_f = true;
    for _ in 0..POLISH_SWEEPS {
        crate::lcp::pgs::sweep_assembled(problem, &mut g, &skip, &d, 1.0);
        let r = monitor.residual_of(&g);
        last_is_f = r < best;
        if last_is_f {
            best = r;
            f.copy_from_slice(&g);
        }
        if r <= tol {
            break;
        }
    }
    if !last_is_f {
        monitor.residual_of(f);
    }
}

/// Relative levels (of `max z`) below which basic values are tried as degenerate zeros.
/// From round-off level (about `10⁴ ε`) to `1e-6`: a level is tried only while the shared
/// residual is above tolerance, and its candidate kept only when it lowers the residual, so a
/// level too coarse for a problem costs one residual evaluation and nothing else.
const DEGENERATE_LEVELS: [f64; 4] = [1e-12, 1e-10, 1e-8, 1e-6];

/// The impulse of the final basic solution `z`, with its degenerate zeros made exact when that
/// is what the shared residual needs. A basic variable that is zero in exact arithmetic (a
/// degenerate pivot) comes out of `B⁻¹ q` as `±ε · cond(B) · max z`, and the bases of the
/// pyramid LCPs of resting stacks reach `cond(B) ≈ 1e9`: a friction direction left at `1e-10`
/// of the impulses on a contact without normal force violates its cone row `μ f_n − Σ β >= 0`
/// by 100 % of that row's own scale (all its other terms vanish). When the raw impulse misses
/// `tol`, the values below each level of [`DEGENERATE_LEVELS`] in turn are set to zero and the
/// impulse with the smallest shared residual is kept, so a genuine small value is never lost.
fn degenerate_zeros(problem: &Problem, red: &Reduction, z: Vec<f64>, tol: f64) -> Vec<f64> {
    let f = red.impulse(&z);
    let zmax = z.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let top = DEGENERATE_LEVELS[DEGENERATE_LEVELS.len() - 1] * zmax;
    if !z.iter().any(|&v| v != 0.0 && v.abs() <= top) {
        return f;
    }
    let rel = |f: &[f64]| residuals(problem, f).natural_map_rel;
    let mut best = (rel(&f), f);
    for level in DEGENERATE_LEVELS {
        if best.0 <= tol {
            break;
        }
        let cut = level * zmax;
        let cleaned: Vec<f64> = z
            .iter()
            .map(|&v| if v.abs() <= cut { 0.0 } else { v })
            .collect();
        let g = red.impulse(&cleaned);
        let r = rel(&g);
        if r < best.0 {
            best = (r, g);
        }
    }
    best.1
}

/// A variable of the augmented system `I w − M z − d z0 = q`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Var {
    W(usize),
    Z(usize),
    Z0,
}

impl fmt::Display for Var {
    fn fmt(&self, fmt: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Var::W(j) => write!(fmt, "w[{j}]"),
            Var::Z(j) => write!(fmt, "z[{j}]"),
            Var::Z0 => write!(fmt, "z0"),
        }
    }
}

/// Entries of the entering column below `PIVOT_TOL · max(1, max|y|)` are never pivoted on.
/// `√ε ≈ 1.5e-8` (`ε` the machine epsilon), the usual pivot threshold of a product-form
/// simplex tableau: a smaller pivot would amplify the tableau's accumulated round-off past half
/// the digits of the `M` scaled to `max|M| = 1`.
const PIVOT_TOL: f64 = 1e-8;
/// Most steps of iterative refinement of `x_B` at a refactorisation.
const REFINEMENT_STEPS: usize = 3;
/// Two ratios within `TIE_TOL · max(1, |min|)` are a tie for the lexicographic test: above the
/// round-off of the ratios of a scaled tableau (a few hundred `ε`), below any difference between
/// genuinely different ratios of a problem scaled to `max|M| = max|q| = 1`.
const TIE_TOL: f64 = 1e-10;

/// The revised tableau: the basis, `B⁻¹` and the basic values `x_B = B⁻¹ q`, all on the scaled
/// data. `B⁻¹` is stored column-major, so that both `B⁻¹ a` (a sum of its columns) and the
/// pivot's rank-one update run down contiguous columns.
struct Tableau<'a> {
    k: usize,
    /// `M`, row-major.
    mat: &'a [f64],
    q: &'a [f64],
    d: &'a [f64],
    basis: Vec<Var>,
    /// The columns of `B⁻¹` that are no longer the unit vectors `e_c` of the starting basis,
    /// each stored once it first changes (column-major, `k` entries each, in the order they
    /// changed; after a refactorisation all `k`, in column order). A pivot in row `r` changes
    /// only the columns with a nonzero in row `r`, so a solve of `p` pivots stores at most `p`
    /// columns: the unit columns are neither stored nor zero-filled, and the entering column,
    /// the pivot and the ratio test take their one nonzero as it is.
    binv: Vec<f64>,
    /// Where column `c` of `B⁻¹` is in `binv` (in columns), or [`UNIT`] while it is `e_c`.
    slot: Vec<usize>,
    xb: Vec<f64>,
}

/// [`Tableau::slot`] of a column of `B⁻¹` that is still a unit vector.
const UNIT: usize = usize::MAX;

impl Tableau<'_> {
    /// Column `c` of `B⁻¹`, or `None` while it is the unit vector `e_c`.
    #[inline]
    fn binv_column(&self, c: usize) -> Option<&[f64]> {
        match self.slot[c] {
            UNIT => None,
            s => Some(&self.binv[s * self.k..(s + 1) * self.k]),
        }
    }

    /// Column of `var` in the augmented system, written into `out`.
    fn column_into(&self, var: Var, out: &mut [f64]) {
        let k = self.k;
        match var {
            Var::W(j) => {
                out.fill(0.0);
                out[j] = 1.0;
            }
            Var::Z(j) => {
                for (o, row) in out.iter_mut().zip(self.mat.chunks_exact(k)) {
                    *o = -row[j];
                }
            }
            Var::Z0 => {
                for (o, d) in out.iter_mut().zip(self.d) {
                    *o = -d;
                }
            }
        }
    }

    /// `y = B⁻¹ a` for the column `a` given entry by entry.
    #[inline]
    fn combine(&self, y: &mut [f64], a: impl Iterator<Item = f64>) {
        // The sums of row-by-row dot products, term by term (`-0.0 + t = t` exactly); a unit
        // column adds only its one nonzero term.
        y.fill(-0.0);
        for (c, ac) in a.enumerate() {
            match self.binv_column(c) {
                None => y[c] += ac,
                Some(col) => {
                    for (yr, b) in y.iter_mut().zip(col) {
                        *yr += b * ac;
                    }
                }
            }
        }
    }

    /// `y = B⁻¹ a` for the column `a` of `var`.
    fn entering_column(&self, var: Var, y: &mut [f64]) {
        let k = self.k;
        match var {
            Var::W(j) => match self.binv_column(j) {
                Some(col) => y.copy_from_slice(col),
                None => {
                    y.fill(0.0);
                    y[j] = 1.0;
                }
            },
            Var::Z(j) => self.combine(y, self.mat.chunks_exact(k).map(|row| -row[j])),
            Var::Z0 => self.combine(y, self.d.iter().map(|d| -d)),
        }
    }

    /// Pivot `entering` (with column `y = B⁻¹ a`) into row `r`.
    fn pivot(&mut self, r: usize, y: &[f64], entering: Var) {
        let k = self.k;
        let p = y[r];
        let theta = self.xb[r] / p;
        // Stored columns (unit columns `e_c`, `c != r`, have a zero in row `r` and do not
        // change).
        for col in self.binv.chunks_exact_mut(k) {
            if col[r] == 0.0 {
                // The new row `r` is zero here: the column does not change.
                continue;
            }
            let pr = col[r] / p;
            // Row `r` is overwritten below; every other row loses `y_i` times the new row `r`.
            for (x, yi) in col.iter_mut().zip(y) {
                *x -= yi * pr;
            }
            col[r] = pr;
        }
        if self.slot[r] == UNIT {
            // `e_r` becomes `e_r − y / p` with `1 / p` in row `r`, stored from now on.
            let pr = 1.0 / p;
            self.slot[r] = self.binv.len() / k;
            self.binv.extend(y.iter().map(|yi| 0.0 - yi * pr));
            self.binv[self.slot[r] * k + r] = pr;
        }
        for (x, yi) in self.xb.iter_mut().zip(y) {
            *x -= yi * theta;
        }
        self.xb[r] = theta;
        self.basis[r] = entering;
    }

    /// Rebuild `B⁻¹` from the basis and `x_B = B⁻¹ q`, with iterative refinement. `stop` is
    /// asked between columns of the inversion (`O(k³)`, seconds on the largest islands).
    fn refactor(&mut self, stop: &dyn Fn() -> bool) -> Result<(), Breakdown> {
        let k = self.k;
        // `B`, row-major, for the inversion and the refinement's residuals.
        let mut b = vec![0.0; k * k];
        let mut column = vec![0.0; k];
        for (r, &var) in self.basis.iter().enumerate() {
            self.column_into(var, &mut column);
            for (i, &v) in column.iter().enumerate() {
                b[i * k + r] = v;
            }
        }
        let inv = invert(&b, k, stop)?;
        self.binv.resize(k * k, 0.0);
        for r in 0..k {
            for c in 0..k {
                self.binv[c * k + r] = inv[r * k + c];
            }
        }
        for (c, slot) in self.slot.iter_mut().enumerate() {
            *slot = c;
        }
        // `B⁻¹ v`, every column now stored.
        let apply = |v: &[f64]| -> Vec<f64> {
            let mut out = vec![0.0; k];
            self.combine(&mut out, v.iter().copied());
            out
        };
        let mut x = apply(self.q);
        // Iterative refinement while the residual of `B x = q` shrinks (at most
        // `REFINEMENT_STEPS`): the bases of degenerate problems reach `cond(B) ≈ 1e9`, where
        // one step leaves basic values wrong by far more than round-off of the data.
        let residual = |x: &[f64]| -> Vec<f64> {
            (0..k)
                .map(|i| self.q[i] - (0..k).map(|c| b[i * k + c] * x[c]).sum::<f64>())
                .collect()
        };
        let norm = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let mut resid = residual(&x);
        for _ in 0..REFINEMENT_STEPS {
            let rnorm = norm(&resid);
            if rnorm == 0.0 {
                break;
            }
            let mut next = x.clone();
            for (xi, dx) in next.iter_mut().zip(apply(&resid)) {
                *xi += dx;
            }
            let next_resid = residual(&next);
            if norm(&next_resid) >= rnorm {
                break;
            }
            x = next;
            resid = next_resid;
        }
        self.xb = x;
        Ok(())
    }

    /// The `z` part of the current basic solution (negative round-off clipped to 0).
    fn z(&self) -> Vec<f64> {
        let mut z = vec![0.0; self.k];
        for (r, &var) in self.basis.iter().enumerate() {
            if let Var::Z(j) = var {
                z[j] = self.xb[r].max(0.0);
            }
        }
        z
    }

    /// Lexicographic minimum of the rows `(x_B_r, B⁻¹_r) / y_r` over `cands` (which it
    /// narrows); `z0`'s row wins a tie in the first (ratio) level. With `feasible`, the basic
    /// values are taken as `max(x_B_r, 0)`: they are non-negative in exact arithmetic, and a
    /// degenerate zero that round-off made slightly negative must tie with the other zeros
    /// instead of winning with a negative ratio (which would pivot on a round-off entry of `y`
    /// and wreck the basis). `vals` is scratch space for one level's ratios.
    fn lexicographic_min(
        &self,
        cands: &mut Vec<usize>,
        vals: &mut Vec<f64>,
        y: &[f64],
        feasible: bool,
    ) -> usize {
        let k = self.k;
        if feasible {
            keep_min(cands, vals, |r| self.xb[r].max(0.0) / y[r]);
        } else {
            keep_min(cands, vals, |r| self.xb[r] / y[r]);
        }
        if let Some(&r) = cands.iter().find(|&&r| self.basis[r] == Var::Z0) {
            return r;
        }
        for c in 0..k {
            if cands.len() <= 1 {
                break;
            }
            match self.binv_column(c) {
                Some(col) => keep_min(cands, vals, |r| col[r] / y[r]),
                // `e_c`: `1 / y_c` in row `c`, zero elsewhere.
                None => keep_min(cands, vals, |r| if r == c { 1.0 } else { 0.0 } / y[r]),
            }
        }
        // Still tied only through round-off: take the largest pivot.
        cands
            .iter()
            .copied()
            .max_by(|&a, &b| y[a].abs().total_cmp(&y[b].abs()))
            .expect("at least one candidate")
    }
}

/// Narrow `cands` to the rows whose `value` is within the tie tolerance of the smallest (`vals`
/// holds the values, each computed once).
#[inline]
fn keep_min(cands: &mut Vec<usize>, vals: &mut Vec<f64>, value: impl Fn(usize) -> f64) {
    vals.clear();
    vals.extend(cands.iter().map(|&r| value(r)));
    let min = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let tol = TIE_TOL * min.abs().max(1.0);
    // Non-finite values (a breakdown the caller reports) must not empty the set.
    if min.is_finite() {
        let mut kept = 0;
        for (i, &v) in vals.iter().enumerate() {
            if v <= min + tol {
                cands[kept] = cands[i];
                kept += 1;
            }
        }
        cands.truncate(kept);
    }
}

/// Run Lemke on the reduced LCP with covering vector `d`. Returns the unscaled `z`, the pivot
/// count, the outcome and, when the final basic solution met the tolerance as it stood, its
/// impulse (already measured).
fn pivot(
    red: &Reduction,
    mut dn: Vec<f64>,
    settings: &Settings,
    monitor: &mut Monitor<'_>,
) -> (Vec<f64>, usize, Outcome, Option<Vec<f64>>) {
    let k = red.q.len();
    if red.q.iter().all(|&v| v >= 0.0) {
        return (vec![0.0; k], 0, Outcome::Stopped, None);
    }
    let sd = dn.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    dn.iter_mut().for_each(|v| *v /= sd);
    // z = z_scaled · max|q| / max|M|.
    let unscale = |mut z: Vec<f64>| -> Vec<f64> {
        z.iter_mut()
            .for_each(|v| *v = *v * red.q_scale / red.m_scale);
        z
    };
    let mut tab = Tableau {
        k,
        mat: &red.m,
        q: &red.q,
        d: &dn,
        basis: (0..k).map(Var::W).collect(),
        // Reserved, not filled: a solve stores as many columns as it changes.
        binv: Vec::with_capacity(k * k),
        slot: vec![UNIT; k],
        xb: red.q.clone(),
    };
    let refactor_every = k.max(50);
    let record = |tab: &Tableau<'_>, monitor: &mut Monitor<'_>, pivots: usize| {
        if settings.record_history {
            monitor.record(pivots, &red.impulse(&unscale(tab.z())));
            monitor.record_active_set(pivots, || red.active_rows(&tab.basis));
        }
    };
    // Buffers reused by every pivot: the entering column and the ratio test's candidates.
    let mut y = vec![0.0; k];
    let mut cands: Vec<usize> = Vec::with_capacity(k);
    let mut vals: Vec<f64> = Vec::with_capacity(k);

    // First pivot: z0 enters, the row with the lexicographically smallest (q_r, e_r) / d_r leaves.
    tab.entering_column(Var::Z0, &mut y);
    let r = {
        // Minimising x_B / (−y) picks the most negative q_r / d_r; the lexicographic levels
        // then use the same denominators (`y` is negated for them, and back: both exact).
        // Every row is a candidate (`−y = d > 0`); the first level keeps the minimal ratios.
        y.iter_mut().for_each(|v| *v = -*v);
        cands.extend(0..k);
        let r = tab.lexicographic_min(&mut cands, &mut vals, &y, false);
        y.iter_mut().for_each(|v| *v = -*v);
        r
    };
    let mut leaving = tab.basis[r];
    tab.pivot(r, &y, Var::Z0);
    let mut pivots = 1;
    record(&tab, monitor, pivots);

    let outcome = loop {
        let entering = match leaving {
            Var::W(j) => Var::Z(j),
            Var::Z(j) => Var::W(j),
            Var::Z0 => break Outcome::Stopped,
        };
        if pivots >= settings.max_iterations {
            break Outcome::IterationLimit;
        }
        if monitor.out_of_time() {
            break Outcome::TimeLimit;
        }
        tab.entering_column(entering, &mut y);
        if y.iter().chain(&tab.xb).any(|v| !v.is_finite()) {
            break Outcome::NumericalFailure(format!(
                "non-finite entering column or basic values for {entering} at pivot {}",
                pivots + 1
            ));
        }
        let ymax = y.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let tol = PIVOT_TOL * ymax.max(1.0);
        cands.clear();
        cands.extend((0..k).filter(|&r| y[r] > tol));
        if cands.is_empty() {
            break ray_termination(red, pivots + 1, entering);
        }
        let r = tab.lexicographic_min(&mut cands, &mut vals, &y, true);
        leaving = tab.basis[r];
        // The ratio test read a round-off negative x_B_r as the zero it stands for; the step
        // must use that value too, or θ = x_B_r / y_r < 0 moves the entering variable below
        // zero (by a lot when y_r is small) and every other basic value with it.
        tab.xb[r] = tab.xb[r].max(0.0);
        tab.pivot(r, &y, entering);
        pivots += 1;
        if pivots % refactor_every == 0 && leaving != Var::Z0 {
            match tab.refactor(&|| monitor.out_of_time()) {
                Ok(()) => {}
                Err(Breakdown::Singular) => {
                    break Outcome::NumericalFailure(format!(
                        "singular basis at refactorisation after pivot {pivots}"
                    ))
                }
                Err(Breakdown::OutOfTime) => break Outcome::TimeLimit,
            }
        }
        record(&tab, monitor, pivots);
    };
    // The final refactorisation (`O(k³)`, half the cost of a tiny solve) is skipped when the
    // product-form basic solution already meets the tolerance in the shared residual.
    if outcome == Outcome::Stopped {
        let z = unscale(tab.z());
        let f = red.impulse(&z);
        if monitor.residual_of(&f) <= settings.tolerance {
            return (z, pivots, outcome, Some(f));
        }
    }
    let outcome = {
        // Out of time here, the product-form solution stands and the residual decides.
        match (outcome, tab.refactor(&|| monitor.out_of_time())) {
            (Outcome::Stopped, Err(Breakdown::Singular)) => Outcome::NumericalFailure(
                "singular basis at refactorisation at the final basis".to_string(),
            ),
            (outcome, _) => outcome,
        }
    };
    (unscale(tab.z()), pivots, outcome, None)
}

/// The outcome of a ray at `pivot`: a proof of infeasibility only when the reduced `M` is known
/// to be copositive-plus, which is checked through its sufficient condition `M + Mᵀ` positive
/// semidefinite (then `M` is positive semidefinite, hence copositive-plus). Otherwise the ray
/// proves nothing and the solve has stalled.
fn ray_termination(red: &Reduction, pivot: usize, entering: Var) -> Outcome {
    if red.sliding_rows > 0 {
        // `M + Mᵀ` keeps the `mu` entries of the sliding rows with a zero diagonal: indefinite.
        return Outcome::Stalled(format!(
            "ray termination at pivot {pivot}: entering {entering} is not blocked; not a proof \
             of infeasibility (the sliding reduction of {} friction rows is copositive, not \
             copositive-plus)",
            red.sliding_rows
        ));
    }
    let k = red.q.len();
    let mmax = red.m.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    let sym = faer::Mat::from_fn(k, k, |i, j| 0.5 * (red.m[i * k + j] + red.m[j * k + i]));
    ray_outcome(
        &format!("ray termination at pivot {pivot}: entering {entering} is not blocked"),
        is_psd(sym.as_ref(), mmax),
        "M + Mᵀ is positive semidefinite (M is copositive-plus), so there is no solution",
        "not a proof of infeasibility for this matrix class (M + Mᵀ is not positive \
         semidefinite, so M is not known to be copositive-plus)",
    )
}

/// Why a refactorisation gave no new `B⁻¹`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Breakdown {
    /// A pivot of the inversion fell below `1e-13` times the largest entry.
    Singular,
    /// The time budget ran out during the inversion.
    OutOfTime,
}

/// Inverse of the row-major `k × k` matrix `b` by Gauss–Jordan elimination with partial
/// pivoting. `stop` is asked every 16 columns of a matrix above 64 rows.
fn invert(b: &[f64], k: usize, stop: &dyn Fn() -> bool) -> Result<Vec<f64>, Breakdown> {
    let mut a = b.to_vec();
    let mut inv = vec![0.0; k * k];
    for i in 0..k {
        inv[i * k + i] = 1.0;
    }
    let amax = a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let tol = crate::lcp::local::SINGULAR_PIVOT * amax.max(f64::MIN_POSITIVE);
    for col in 0..k {
        if k > 64 && col % 16 == 0 && stop() {
            return Err(Breakdown::OutOfTime);
        }
        let p = (col..k)
            .max_by(|&x, &y| a[x * k + col].abs().total_cmp(&a[y * k + col].abs()))
            .ok_or(Breakdown::Singular)?;
        // `<=` and not `>`: a NaN pivot must fail too.
        if a[p * k + col].abs().is_nan() || a[p * k + col].abs() <= tol {
            return Err(Breakdown::Singular);
        }
        if p != col {
            for c in 0..k {
                a.swap(p * k + c, col * k + c);
                inv.swap(p * k + c, col * k + c);
            }
        }
        let piv = a[col * k + col];
        for c in 0..k {
            a[col * k + c] /= piv;
            inv[col * k + c] /= piv;
        }
        for r in 0..k {
            if r == col {
                continue;
            }
            let factor = a[r * k + col];
            if factor != 0.0 {
                for c in 0..k {
                    a[r * k + c] -= factor * a[col * k + c];
                    inv[r * k + c] -= factor * inv[col * k + c];
                }
            }
        }
    }
    Ok(inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::generate::{generate, Family};
    use crate::test_util::lcp;
    use crate::Status;
    use faer::Mat;

    #[test]
    fn solves_a_two_by_two_lcp() {
        let p = lcp(&[&[2.0, 1.0], &[1.0, 2.0]], &[-1.0, 1.0]);
        let r = Lemke::default().solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert!((r.f[0] - 0.5).abs() < 1e-12 && r.f[1] == 0.0, "{:?}", r.f);
    }

    #[test]
    fn planted_families_converge() {
        for (family, n) in [
            (Family::Spd { cond: 1e3 }, 50),
            (Family::PMatrix, 40),
            (Family::PsdRankDeficient { rank: 15 }, 30),
        ] {
            let g = generate(family, n, 11);
            let r = Lemke::default().solve(&g.problem, &Settings::default());
            assert_eq!(r.status, Status::Converged, "{family:?}");
            assert!(r.residuals.natural_map_rel <= 1e-8, "{family:?}");
            assert!(r.iterations <= 4 * n, "{family:?}: {} pivots", r.iterations);
        }
    }

    #[test]
    fn solves_a_three_by_three_lcp() {
        // f = (1, 0, 0.5): w = (0, 1.5, 0).
        let a: [&[f64]; 3] = [&[2.0, 1.0, 0.0], &[1.0, 2.0, 1.0], &[0.0, 1.0, 2.0]];
        let b = [-2.0, 0.0, -1.0];
        let r = Lemke::default().solve(&lcp(&a, &b), &Settings::default());
        assert_eq!(r.status, Status::Converged);
        for (x, y) in r.f.iter().zip([1.0, 0.0, 0.5]) {
            assert!((x - y).abs() < 1e-12, "{:?}", r.f);
        }
    }

    #[test]
    fn trivial_and_degenerate_problems_do_not_cycle() {
        // b = 0: f = 0 without a pivot.
        let a: [&[f64]; 2] = [&[1.0, -1.0], &[-1.0, 1.0]];
        let r = Lemke::default().solve(&lcp(&a, &[0.0, 0.0]), &Settings::default());
        assert_eq!((r.status.clone(), r.iterations), (Status::Converged, 0));
        // Duplicated rows (PSD, rank 2) and ties in every ratio test.
        let a: [&[f64]; 4] = [
            &[2.0, 1.0, 1.0, 2.0],
            &[1.0, 2.0, 2.0, 1.0],
            &[1.0, 2.0, 2.0, 1.0],
            &[2.0, 1.0, 1.0, 2.0],
        ];
        for b in [[-1.0; 4], [-1.0, 0.0, -1.0, 0.0], [0.0, -1.0, -1.0, 0.0]] {
            let r = Lemke::default().solve(&lcp(&a, &b), &Settings::default());
            assert_eq!(r.status, Status::Converged, "b = {b:?}");
            assert!(r.iterations <= 8, "b = {b:?}: {} pivots", r.iterations);
        }
        // A degenerate zero block with a strictly negative row.
        let a: [&[f64]; 3] = [&[1.0, 0.0, 0.0], &[0.0, 0.0, 0.0], &[0.0, 0.0, 1.0]];
        let r = Lemke::default().solve(&lcp(&a, &[-1.0, 0.0, -1.0]), &Settings::default());
        assert_eq!(r.status, Status::Converged);
    }

    #[test]
    fn infeasible_problems_end_in_a_ray() {
        let g = generate(Family::Infeasible, 20, 5);
        let r = Lemke::default().solve(&g.problem, &Settings::default());
        match &r.status {
            Status::NoSolution { reason } => {
                assert!(reason.starts_with("ray termination at pivot"), "{reason}")
            }
            s => panic!("expected no_solution, got {s}"),
        }
        // A zero row with a negative constant: ray at the second pivot.
        let a: [&[f64]; 2] = [&[0.0, 0.0], &[0.0, 1.0]];
        let r = Lemke::default().solve(&lcp(&a, &[-1.0, 1.0]), &Settings::default());
        assert_eq!(r.status.name(), "no_solution");
        assert_eq!(r.iterations, 1);
    }

    #[test]
    fn ray_on_a_matrix_not_copositive_plus_is_not_a_proof() {
        let p = crate::test_util::three_solution_lcp();
        let r = Lemke::default().solve(&p, &Settings::default());
        match &r.status {
            Status::Stalled { reason } => {
                assert!(reason.starts_with("ray termination at pivot"), "{reason}");
                assert!(reason.contains("not a proof of infeasibility"), "{reason}");
            }
            s => panic!("expected stalled, got {s}"),
        }
        // The problem has a solution: enumeration finds it.
        let r = crate::Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
    }

    #[test]
    fn murty_takes_two_to_the_n_pivots() {
        for n in 2..=10 {
            let g = generate(Family::Murty, n, 0);
            let r = Lemke::default().solve(&g.problem, &Settings::default());
            assert_eq!(r.status, Status::Converged, "n = {n}");
            assert_eq!(r.iterations, 1 << n, "n = {n}");
            assert_eq!(&r.f, g.solution.as_ref().unwrap());
        }
        let g = generate(Family::Murty, 10, 0);
        let capped = Settings {
            max_iterations: 100,
            ..Settings::default()
        };
        let r = Lemke::default().solve(&g.problem, &capped);
        assert_eq!((r.status, r.iterations), (Status::IterationLimit, 100));
        let timed = Settings {
            time_budget: Some(std::time::Duration::ZERO),
            ..Settings::default()
        };
        let r = Lemke::default().solve(&g.problem, &timed);
        assert_eq!(r.status, Status::TimeLimit);
    }

    #[test]
    fn boxed_problems_match_pgs() {
        // SPD A with every kind of bound: [0, ∞), (−∞, 0.3], [−0.2, 0.4], free, fixed.
        let n = 10;
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
        let a = crate::problem::generate::spd_matrix(n, 10.0, &mut rng);
        let b: Vec<f64> = (0..n).map(|i| ((i * 7 % 5) as f64 - 2.0) * 0.3).collect();
        let inf = f64::INFINITY;
        let lo = vec![0.0, -inf, -0.2, -inf, 0.1, 0.0, -inf, -0.2, -inf, 0.0];
        let hi = vec![inf, 0.3, 0.4, inf, 0.1, inf, 0.3, 0.4, inf, inf];
        let p = Problem::boxed(a, b, lo, hi, vec![]).unwrap();
        let tight = Settings {
            tolerance: 1e-12,
            max_iterations: 100_000,
            ..Settings::default()
        };
        let reference = crate::ProjectedSor::pgs().solve(&p, &tight);
        assert_eq!(reference.status, Status::Converged);
        let r = Lemke::default().solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        for (x, y) in r.f.iter().zip(&reference.f) {
            assert!((x - y).abs() < 1e-8, "{:?} vs {:?}", r.f, reference.f);
        }
    }

    #[test]
    fn friction_rows_on_a_bounded_normal_and_bad_covering_vectors_are_unsupported() {
        let friction = |normal_hi: f64| {
            Problem::boxed(
                Mat::identity(2, 2),
                vec![-1.0, -0.8],
                vec![0.0, 0.0],
                vec![normal_hi, 0.0],
                vec![crate::FrictionRow {
                    row: 1,
                    normal: 0,
                    mu: 0.5,
                }],
            )
            .unwrap()
        };
        let r = Lemke::default().solve(&friction(2.0), &Settings::default());
        assert_eq!(r.status.name(), "unsupported");
        assert!(r.status.reason().unwrap().contains("bounds [0, ∞)"));
        // On a normal row with bounds [0, ∞): f_n = 1, and the friction impulse sticks at the
        // bound mu·f_n = 0.5 (its velocity −0.8 + 0.5 < 0 pushes on).
        let r = Lemke::default().solve(&friction(f64::INFINITY), &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert!(
            (r.f[0] - 1.0).abs() < 1e-12 && (r.f[1] - 0.5).abs() < 1e-12,
            "{:?}",
            r.f
        );
        let p = lcp(&[&[2.0, 1.0], &[1.0, 2.0]], &[-1.0, 1.0]);
        for d in [vec![1.0], vec![1.0, 0.0]] {
            let r = Lemke::with_covering(d).solve(&p, &Settings::default());
            assert_eq!(r.status.name(), "unsupported");
        }
        let r = Lemke::with_covering(vec![0.5, 3.0]).solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
    }

    #[test]
    fn scale_invariant() {
        // A and b scaled independently by 1e-9 and 1e9: the solution scales by sb / sa.
        let g = generate(Family::Spd { cond: 1e3 }, 20, 4);
        let (a0, b0) = (&g.problem.to_dense(), g.problem.b());
        for (sa, sb) in [(1e-9, 1e9), (1e9, 1e-9), (1e-9, 1e-9)] {
            let a = Mat::from_fn(20, 20, |i, j| sa * a0[(i, j)]);
            let b = b0.iter().map(|v| sb * v).collect();
            let r = Lemke::default().solve(&Problem::lcp(a, b).unwrap(), &Settings::default());
            assert_eq!(r.status, Status::Converged, "sa = {sa}, sb = {sb}");
            for (x, y) in r.f.iter().zip(g.solution.as_ref().unwrap()) {
                assert!((x * sa / sb - y).abs() < 1e-9, "sa = {sa}, sb = {sb}");
            }
        }
    }

    /// Pyramid LCPs (48 rows) of a resting two-box tower (`bench_scenes/tower_10.toml` with two
    /// boxes, `--friction-model pyramid`, exported at steps 483 and 958 of a Lemke run). Step 483
    /// needs the ratio test's zero to be the step too: with `θ = x_B_r / y_r` taken from a
    /// round-off negative `x_B_r`, the residual was 1.0. Step 958 needs the degenerate zeros of
    /// the final basis made exact: a friction impulse of `1e-11` of the normal ones was left on
    /// a contact without normal force (its cone row wrong by 100 % of its own scale).
    #[test]
    fn resting_stack_pyramid_lcps_converge() {
        for step in [483, 958] {
            let path = format!(
                "{}/tests/data/lemke_tower2_step{step}_pyramid.json",
                env!("CARGO_MANIFEST_DIR")
            );
            let p = crate::io::read_problem(std::path::Path::new(&path)).expect("test file");
            assert_eq!(p.n(), 48);
            let r = Lemke::default().solve(&p, &Settings::default());
            assert_eq!(r.status, Status::Converged, "step {step}");
            assert!(r.residuals.natural_map_rel <= 1e-8, "step {step}");
            assert_eq!(r.residuals.bound_violation, 0.0, "step {step}");
        }
    }
}

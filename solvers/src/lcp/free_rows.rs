//! The free (equality) rows of a mixed LCP, eliminated before a pivoting method runs: the
//! classic reduction of the mixed LCP (Cottle–Pang–Stone 1992; Siconos' MLCP, whose free part
//! `u` has `w₁ = 0`) to a boxed LCP on the other rows. Used by the pivoting methods,
//! [`crate::Lemke`], [`crate::Dantzig`] and [`crate::Enumeration`].
//!
//! A free row has `lo = −∞`, `hi = +∞` and so `w_i = 0` with `f_i` of either sign: a joint's
//! equality constraint. With `F` the free rows and `C` the others,
//!
//! ```text
//! f_F = −A_FF⁻¹ (b_F + A_FC f_C),
//! M = A_CC − A_CF A_FF⁻¹ A_FC,    q = b_C − A_CF A_FF⁻¹ b_F,
//! ```
//!
//! and `f_C` solves the boxed problem `(M, q)` on the rows `C` with their own bounds and
//! friction rows. When `A_FF` is regular the two problems have the same solutions, so a proof
//! that the reduced problem has none is a proof for the mixed one. `M` is the Schur complement
//! of `A_FF`: positive semidefinite when `A` is, a P-matrix when `A` is one.
//!
//! * **Rank**: the computation is on the equilibrated `Ã = S A S` (`s_i = 1/√d_i`), and
//!   `Ã_FF` is factorised with diagonal pivoting ([`PivotedLu`]), which stops at the first
//!   pivot below [`ELIMINATION_PIVOT`] of the first one. Redundant joints (a closed loop, a
//!   joint repeated, a weld next to a hinge) make `A_FF` singular; then only the free rows
//!   pivoted on (`F₁`, a regular principal block) are eliminated, and the others (`F₂`) stay in
//!   the reduced problem as free rows. For positive semidefinite `A` a row of `F₂` has a zero
//!   Schur complement, so its whole row and column of `M` vanish and its `q_i` is constant:
//!   `0` when the joints are consistent, and then the row is dropped with `f_i = 0` (its impulse
//!   is carried by the rows of `F₁` it depends on); a nonzero `q_i` (inconsistent joints, no
//!   solution) or a row that does not vanish (an `A` that is not semidefinite) stays, and the
//!   pivoting method meets it as a free row (Lemke splits it, `f_i = x⁺ − x⁻`; Dantzig clamps
//!   it first). When no free row passes the test ([`FreeRows::NotEliminated`]) nothing is
//!   eliminated.
//! * **Round-off**: entries of `M` and `q` within their round-off bound, `4 (|F| + 1) ε` times
//!   the magnitudes of their terms and of `|Y|ᵀ |Ã_FF| |Y|` (the factorisation's backward error
//!   seen through `Y = Ã_FF⁻¹ Ã_FC`), are set to zero. A contact that the joints hold completely
//!   (on a body welded to the world) has `M = 0` and `q = 0` in exact arithmetic; its
//!   round-off, scaled up by a pivoting method's normalisation, would otherwise be pivoted on as
//!   data.
//! * **Recovery**: `f_F` comes from `f_C` through the factorisation and is refined against the
//!   original rows (at most [`REFINEMENT_STEPS`] steps, while `|w_F|` falls), so that `w_F = 0`
//!   holds to the round-off of the rows themselves. The contact rows keep the round-off of `M`,
//!   which is a sizeable share of their small entries when joints with large mass ratios hold
//!   them; [`polish_on_basis`] re-solves the basis a pivoting method found on `A` itself.
//! * **Cost**: `O(|F|³)` for the factorisation and `O(|F|² |C| + |F| |C|²)` for `M`, once per
//!   solve; `O(|F| n)` per recovered impulse.

use crate::lcp::local::{dense_matrix, problem_bounds, LocalLcp, Workspace};
use crate::linalg::pivoted_lu::PivotedLu;
use crate::problem::{FrictionRow, Problem};
use crate::solver::{Monitor, Outcome};
use faer::Mat;

/// A pivot of the equilibrated `A_FF` below this fraction of the first (largest) one marks the
/// rest singular: `√ε`-level, where a Schur complement computed in double precision keeps fewer
/// than half its digits (Lemke's own pivot threshold, for the same reason).
pub(crate) const ELIMINATION_PIVOT: f64 = 1e-8;

/// Most steps of iterative refinement of the recovered free impulses.
const REFINEMENT_STEPS: usize = 2;

/// How a solve treats the free rows of a problem.
pub(crate) enum FreeRows {
    /// No free row that may be eliminated.
    None,
    /// Free rows eliminated through the Schur complement.
    Eliminated(Box<Elimination>),
    /// Nothing eliminated: no pivot of `A_FF` passed the test.
    NotEliminated {
        /// Free rows.
        rows: usize,
        /// `|u₁₁|`-relative size of the pivot that failed.
        pivot_ratio: f64,
    },
}

impl FreeRows {
    /// The treatment of `problem`'s free rows. A free row that is the normal of a friction row
    /// is never eliminated (its friction rows' bounds read its impulse).
    pub(crate) fn of(problem: &Problem) -> Self {
        let n = problem.n();
        let mut is_normal = vec![false; n];
        for fr in problem.friction() {
            is_normal[fr.normal] = true;
        }
        let free: Vec<usize> = (0..n)
            .filter(|&i| {
                problem.friction_of(i).is_none()
                    && !is_normal[i]
                    && problem.lo()[i] == f64::NEG_INFINITY
                    && problem.hi()[i] == f64::INFINITY
            })
            .collect();
        if free.is_empty() {
            return FreeRows::None;
        }
        match Elimination::new(problem, free) {
            Ok(e) => FreeRows::Eliminated(Box::new(e)),
            Err((rows, pivot_ratio)) => FreeRows::NotEliminated { rows, pivot_ratio },
        }
    }

    /// The problem the pivoting method solves: the reduced one, or `problem` itself.
    pub(crate) fn rows<'a>(&'a self, problem: &'a Problem) -> &'a Problem {
        match self {
            FreeRows::Eliminated(e) => &e.reduced,
            FreeRows::None | FreeRows::NotEliminated { .. } => problem,
        }
    }

    /// The whole impulse from an impulse `f` of [`FreeRows::rows`] (an `f` of another length is
    /// returned as it is, for the caller's monitor to report).
    pub(crate) fn expand(&self, f: Vec<f64>) -> Vec<f64> {
        match self {
            FreeRows::Eliminated(e) if f.len() == e.kept.len() => e.expand(&f),
            _ => f,
        }
    }

    /// The entries of a whole impulse `f` on the rows of [`FreeRows::rows`] (a warm start).
    pub(crate) fn restrict(&self, f: &[f64]) -> Vec<f64> {
        match self {
            FreeRows::Eliminated(e) => e.kept.iter().map(|&i| f[i]).collect(),
            FreeRows::None | FreeRows::NotEliminated { .. } => f.to_vec(),
        }
    }

    /// Rows of [`FreeRows::rows`] as rows of the whole problem, with every eliminated row
    /// (the active set of a pivoting method, whose eliminated rows are always solved).
    pub(crate) fn original_rows(&self, mut rows: Vec<usize>) -> Vec<usize> {
        if let FreeRows::Eliminated(e) = self {
            rows.iter_mut().for_each(|i| *i = e.kept[*i]);
            rows.extend_from_slice(&e.free);
            rows.sort_unstable();
        }
        rows
    }

    /// `outcome` with its reason ending in how the free rows were treated ([`Self::describe`]),
    /// for the outcomes that carry a reason of the solver's own.
    pub(crate) fn annotate(&self, outcome: Outcome) -> Outcome {
        let Some(how) = self.describe() else {
            return outcome;
        };
        match outcome {
            Outcome::Stalled(r) => Outcome::Stalled(format!("{r} ({how})")),
            Outcome::NoSolution(r) => Outcome::NoSolution(format!("{r} ({how})")),
            Outcome::NumericalFailure(r) => Outcome::NumericalFailure(format!("{r} ({how})")),
            other => other,
        }
    }

    /// True when free rows were eliminated.
    pub(crate) fn eliminated(&self) -> bool {
        matches!(self, FreeRows::Eliminated(_))
    }

    /// How the free rows were treated, in words for a status reason (`None` without free rows).
    pub(crate) fn describe(&self) -> Option<String> {
        match self {
            FreeRows::None => None,
            FreeRows::Eliminated(e) => {
                let mut s = format!(
                    "{} free rows eliminated through the Schur complement of A_FF",
                    e.free.len()
                );
                let (dropped, split) = (e.dropped.len(), e.split);
                if dropped + split > 0 {
                    s += &format!(
                        "; A_FF is singular (pivot ratio {:.1e} below {ELIMINATION_PIVOT:.0e}): \
                         {dropped} redundant free rows dropped with f = 0, {split} kept free",
                        e.pivot_ratio
                    );
                }
                Some(s)
            }
            FreeRows::NotEliminated { rows, pivot_ratio } => Some(format!(
                "{rows} free rows kept free, none eliminated: no pivot of A_FF passed the test \
                 (ratio {pivot_ratio:.1e} below {ELIMINATION_PIVOT:.0e})"
            )),
        }
    }
}

/// The impulse that solves, on the whole problem's own data, the complementary basis that `f`
/// suggests (each row's state read off `f_i − w_i / d_i` against its bounds, free rows at
/// `w_i = 0`: [`LocalLcp::residual_and_guess`]), by one dense Gaussian elimination of the
/// whole basis system; `None` when that system is singular (redundant joints) or `problem`
/// is not dense. A solve through the Schur complement carries the complement's round-off, which
/// joints with large mass ratios (a contact on a light link between links `1e6` times heavier)
/// make a sizeable share of the contact rows' small entries; re-solving the basis the reduced
/// problem found, on `A` itself, leaves only the round-off of that one solve. `O(n³)`.
pub(crate) fn solve_basis_of(problem: &Problem, f: &[f64]) -> Option<Vec<f64>> {
    let n = problem.n();
    if problem.is_sparse() || f.len() != n {
        return None;
    }
    let mat = dense_matrix(problem);
    let bounds = problem_bounds(problem);
    let d = problem.diagonal_scale();
    let lcp = LocalLcp {
        m: n,
        mat: &mat,
        q: problem.b(),
        bounds: &bounds,
        d: &d,
    };
    let mut ws = Workspace::default();
    lcp.residual_and_guess(f, &mut ws);
    let states = std::mem::take(&mut ws.guess);
    lcp.solve_basis(&states, &mut ws)
        .then(|| ws.basis_solution().to_vec())
}

/// Largest problem [`polish_on_basis`] re-solves (a dense elimination of `⅔ n³` operations,
/// about 0.1 s at this size).
pub(crate) const POLISH_ROWS: usize = 600;

/// Most rounds of [`polish_on_basis`].
const POLISH_ROUNDS: usize = 3;

/// When `f` misses `tol` on `problem` (whose free rows a pivoting method eliminated), the
/// impulse of the basis `f` suggests, re-solved on the whole problem ([`solve_basis_of`]),
/// replaces it if its shared residual is smaller, and the basis the new impulse suggests is
/// tried in turn (a row within round-off of a bound can be read in the wrong state the first
/// time), for at most [`POLISH_ROUNDS`] rounds while the residual falls. Skipped above
/// [`POLISH_ROWS`] rows and when the time budget is spent.
pub(crate) fn polish_on_basis(
    problem: &Problem,
    f: &mut Vec<f64>,
    tol: f64,
    monitor: &mut Monitor<'_>,
) {
    if problem.n() > POLISH_ROWS {
        return;
    }
    let mut r = monitor.residual_of(f);
    for _ in 0..POLISH_ROUNDS {
        if r <= tol || monitor.out_of_time() {
            return;
        }
        let Some(g) = solve_basis_of(problem, f) else {
            return;
        };
        let rg = monitor.residual_of(&g);
        if rg >= r {
            return;
        }
        (*f, r) = (g, rg);
    }
}

/// The reduced problem and what recovers the free impulses from its solution.
pub(crate) struct Elimination {
    /// The eliminated rows `F₁`, in pivot order, and their positions among all free rows.
    free: Vec<usize>,
    positions: Vec<usize>,
    /// All free rows (the order of the factorisation's vectors).
    all_free: usize,
    /// The rows of the reduced problem, increasing.
    kept: Vec<usize>,
    /// Redundant free rows dropped with `f = 0`.
    dropped: Vec<usize>,
    /// Dependent free rows left free in the reduced problem.
    split: usize,
    /// `s_i = 1/√d_i` of every row.
    s: Vec<f64>,
    /// The factorisation of `Ã_FF` over all free rows; its pivot rows are `F₁`.
    lu: PivotedLu,
    /// The `|u₁₁|`-relative size of the first pivot refused, or of the smallest taken.
    pivot_ratio: f64,
    /// `Y = Ã_F₁F₁⁻¹ Ã_F₁C`, `|F₁| × |C|` row-major (`C` the reduced problem's rows), and
    /// `z = Ã_F₁F₁⁻¹ S_F₁ b_F₁`.
    y: Vec<f64>,
    z: Vec<f64>,
    /// The rows `F₁` of `A` (dense, `|F₁| × n` row-major) and of `b`, for the refinement.
    a_free: Vec<f64>,
    b_free: Vec<f64>,
    /// `(M, q)` on the rows `C`, in the units of `f_C`, with their bounds and friction rows.
    reduced: Problem,
}

impl Elimination {
    /// The elimination of the rows `all_free`; `Err((|F|, pivot ratio))` when no pivot passes
    /// the test or the reduced data are not finite.
    fn new(problem: &Problem, all_free: Vec<usize>) -> Result<Self, (usize, f64)> {
        let n = problem.n();
        let nf = all_free.len();
        let s: Vec<f64> = (0..n)
            .map(|i| 1.0 / problem.diagonal_scale_of(i).sqrt())
            .collect();
        let mut aff = vec![0.0; nf * nf];
        let mut position = vec![usize::MAX; n];
        all_free
            .iter()
            .enumerate()
            .for_each(|(k, &i)| position[i] = k);
        for (k, &i) in all_free.iter().enumerate() {
            for (j, v) in problem.row(i).iter() {
                if position[j] != usize::MAX {
                    aff[k * nf + position[j]] = s[i] * v * s[j];
                }
            }
        }
        let lu = PivotedLu::new(&aff, nf, ELIMINATION_PIVOT);
        if lu.rank() == 0 {
            return Err((nf, lu.pivot_ratio()));
        }
        let positions = lu.pivot_rows().to_vec();
        let free: Vec<usize> = positions.iter().map(|&k| all_free[k]).collect();
        let mut eliminated = vec![false; n];
        free.iter().for_each(|&i| eliminated[i] = true);
        let others: Vec<usize> = (0..n).filter(|&i| !eliminated[i]).collect();
        let (y, z) = solves(problem, &s, &lu, &positions, &all_free, &others);
        let (m, q) = schur_complement(problem, &s, &free, &others, &y, &z);
        // Dependent free rows whose row and column of M vanish and whose q is 0 are dropped.
        let nc = others.len();
        let vanishes =
            |r: usize| q[r] == 0.0 && (0..nc).all(|c| m[r * nc + c] == 0.0 && m[c * nc + r] == 0.0);
        let (mut kept_at, mut dropped, mut split) = (Vec::new(), Vec::new(), 0);
        for (r, &i) in others.iter().enumerate() {
            let dependent = position[i] != usize::MAX;
            if dependent && vanishes(r) {
                dropped.push(i);
            } else {
                split += usize::from(dependent);
                kept_at.push(r);
            }
        }
        let kept: Vec<usize> = kept_at.iter().map(|&r| others[r]).collect();
        let reduced = reduced_problem(problem, &kept, &kept_at, &s, &m, &q)
            .map_err(|()| (nf, lu.pivot_ratio()))?;
        let nk = kept.len();
        let y: Vec<f64> = (0..free.len())
            .flat_map(|k| kept_at.iter().map(move |&r| (k, r)))
            .map(|(k, r)| y[k * nc + r])
            .collect();
        debug_assert_eq!(y.len(), free.len() * nk);
        let mut a_free = vec![0.0; free.len() * n];
        for (k, &i) in free.iter().enumerate() {
            for (j, v) in problem.row(i).iter() {
                a_free[k * n + j] = v;
            }
        }
        Ok(Self {
            pivot_ratio: lu.pivot_ratio(),
            b_free: free.iter().map(|&i| problem.b()[i]).collect(),
            free,
            positions,
            all_free: nf,
            kept,
            dropped,
            split,
            s,
            lu,
            y,
            z,
            a_free,
            reduced,
        })
    }

    /// The whole impulse from the reduced problem's `f_C`: `f_F₁ = −S_F₁ (z + Y S_C⁻¹ f_C)`,
    /// refined against the rows `F₁` of `A`; dropped rows at 0.
    fn expand(&self, f_kept: &[f64]) -> Vec<f64> {
        let n = self.s.len();
        let nk = self.kept.len();
        let mut f = vec![0.0; n];
        let mut x_kept = vec![0.0; nk];
        for (r, &i) in self.kept.iter().enumerate() {
            f[i] = f_kept[r];
            x_kept[r] = f_kept[r] / self.s[i];
        }
        for (k, &i) in self.free.iter().enumerate() {
            let row = &self.y[k * nk..(k + 1) * nk];
            let yx: f64 = row.iter().zip(&x_kept).map(|(a, x)| a * x).sum();
            f[i] = -self.s[i] * (self.z[k] + yx);
        }
        self.refine(&mut f);
        f
    }

    /// `S_F₁ w_F₁` at `f`, placed at the rows' positions among all free rows, and its largest
    /// magnitude.
    fn scaled_free_velocity(&self, f: &[f64]) -> (Vec<f64>, f64) {
        let n = f.len();
        let mut r = vec![0.0; self.all_free];
        let mut size: f64 = 0.0;
        for (k, &i) in self.free.iter().enumerate() {
            let row = &self.a_free[k * n..(k + 1) * n];
            let w: f64 = row.iter().zip(f).map(|(a, x)| a * x).sum::<f64>() + self.b_free[k];
            let v = self.s[i] * w;
            r[self.positions[k]] = v;
            size = size.max(v.abs());
        }
        (r, size)
    }

    /// Iterative refinement of `f_F₁` (`f_C` fixed) while `|S_F₁ w_F₁|` falls.
    fn refine(&self, f: &mut [f64]) {
        let (mut r, mut size) = self.scaled_free_velocity(f);
        let mut g = f.to_vec();
        for _ in 0..REFINEMENT_STEPS {
            // A zero residual needs no step, a NaN one allows none.
            if size == 0.0 || size.is_nan() {
                return;
            }
            self.lu.solve(&mut r);
            for (k, &i) in self.free.iter().enumerate() {
                g[i] = f[i] - self.s[i] * r[self.positions[k]];
            }
            let (next, next_size) = self.scaled_free_velocity(&g);
            if next_size >= size || next_size.is_nan() {
                return;
            }
            f.copy_from_slice(&g);
            (r, size) = (next, next_size);
        }
    }
}

/// `Y = Ã_F₁F₁⁻¹ Ã_F₁C` (`|F₁| × |C|` row-major, `C = others`) and `z = Ã_F₁F₁⁻¹ S_F₁ b_F₁`,
/// through the factorisation over all free rows (whose solves read and write only `F₁`).
fn solves(
    problem: &Problem,
    s: &[f64],
    lu: &PivotedLu,
    positions: &[usize],
    all_free: &[usize],
    others: &[usize],
) -> (Vec<f64>, Vec<f64>) {
    let (nf, n1, nc) = (all_free.len(), positions.len(), others.len());
    let mut column_of = vec![usize::MAX; problem.n()];
    others
        .iter()
        .enumerate()
        .for_each(|(r, &c)| column_of[c] = r);
    // Ã_FC over all free rows, column-major (one solve per column).
    let mut afc = vec![0.0; nc * nf];
    let mut bf = vec![0.0; nf];
    for (k, &i) in all_free.iter().enumerate() {
        for (j, v) in problem.row(i).iter() {
            if column_of[j] != usize::MAX {
                afc[column_of[j] * nf + k] = s[i] * v * s[j];
            }
        }
        bf[k] = s[i] * problem.b()[i];
    }
    let mut y = vec![0.0; n1 * nc];
    for (r, column) in afc.chunks_exact_mut(nf).enumerate() {
        lu.solve(column);
        for (k, &p) in positions.iter().enumerate() {
            y[k * nc + r] = column[p];
        }
    }
    lu.solve(&mut bf);
    let z = positions.iter().map(|&p| bf[p]).collect();
    (y, z)
}

/// `M̃ = Ã_CC − Ã_CF₁ Y` and `q̃ = S_C b_C − Ã_CF₁ z` (equilibrated, `C = others`), with
/// entries within their round-off bound set to zero (see the module documentation) and `M̃`
/// symmetrised when `A` is symmetric.
fn schur_complement(
    problem: &Problem,
    s: &[f64],
    free: &[usize],
    others: &[usize],
    y: &[f64],
    z: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let (n1, nc, n) = (free.len(), others.len(), problem.n());
    let b = problem.b();
    let u = 4.0 * (n1 + 1) as f64 * f64::EPSILON;
    let mut slot = vec![(usize::MAX, usize::MAX); n];
    free.iter().enumerate().for_each(|(k, &i)| slot[i].0 = k);
    others.iter().enumerate().for_each(|(r, &i)| slot[i].1 = r);
    // |Ã_F₁F₁| |Y| and |Ã_F₁F₁| |z|, for the factorisation's backward error.
    let mut ay = vec![0.0; n1 * nc];
    let mut az = vec![0.0; n1];
    for (k, &i) in free.iter().enumerate() {
        for (j, v) in problem.row(i).iter() {
            let l = slot[j].0;
            if l == usize::MAX || v == 0.0 {
                continue;
            }
            let a = (s[i] * v * s[j]).abs();
            for r in 0..nc {
                ay[k * nc + r] += a * y[l * nc + r].abs();
            }
            az[k] += a * z[l].abs();
        }
    }
    let mut m = vec![0.0; nc * nc];
    let mut bound = vec![0.0; nc * nc];
    let mut q = vec![0.0; nc];
    let mut a_cf = vec![0.0; n1];
    for (i, &ci) in others.iter().enumerate() {
        a_cf.iter_mut().for_each(|v| *v = 0.0);
        let row_m = &mut m[i * nc..(i + 1) * nc];
        for (j, v) in problem.row(ci).iter() {
            let v = s[ci] * v * s[j];
            match slot[j] {
                (k, _) if k != usize::MAX => a_cf[k] = v,
                (_, r) if r != usize::MAX => row_m[r] = v,
                _ => {}
            }
        }
        let row_bound = &mut bound[i * nc..(i + 1) * nc];
        for r in 0..nc {
            let (mut sum, mut mag) = (row_m[r], row_m[r].abs());
            for k in 0..n1 {
                let t = a_cf[k] * y[k * nc + r];
                sum -= t;
                mag += t.abs();
            }
            row_m[r] = sum;
            row_bound[r] = mag;
        }
        let sb = s[ci] * b[ci];
        let (mut sum, mut mag) = (sb, sb.abs());
        for k in 0..n1 {
            let t = a_cf[k] * z[k];
            sum -= t;
            mag += t.abs() + y[k * nc + i].abs() * az[k];
        }
        q[i] = if sum.abs() <= u * mag { 0.0 } else { sum };
    }
    // |Y|ᵀ |Ã_F₁F₁| |Y|: the backward error of the factorisation seen through the solves.
    for i in 0..nc {
        for r in 0..nc {
            let e: f64 = (0..n1).map(|k| y[k * nc + i].abs() * ay[k * nc + r]).sum();
            bound[i * nc + r] += e;
        }
    }
    if problem.is_symmetric(1e-12) {
        for i in 0..nc {
            for r in i + 1..nc {
                let avg = 0.5 * (m[i * nc + r] + m[r * nc + i]);
                let e = bound[i * nc + r].max(bound[r * nc + i]);
                (m[i * nc + r], m[r * nc + i]) = (avg, avg);
                (bound[i * nc + r], bound[r * nc + i]) = (e, e);
            }
        }
    }
    for (v, e) in m.iter_mut().zip(&bound) {
        if v.abs() <= u * e {
            *v = 0.0;
        }
    }
    (m, q)
}

/// The boxed problem on the rows `kept` (at positions `kept_at` of `(M̃, q̃)`), in the units of
/// `f_C` (`A' = S_C⁻¹ M̃ S_C⁻¹`, `b' = S_C⁻¹ q̃`), with their bounds and friction rows. `Err`
/// when an entry is not finite.
fn reduced_problem(
    problem: &Problem,
    kept: &[usize],
    kept_at: &[usize],
    s: &[f64],
    m: &[f64],
    q: &[f64],
) -> Result<Problem, ()> {
    let nk = kept.len();
    let nc = q.len();
    let mut position = vec![usize::MAX; problem.n()];
    kept.iter().enumerate().for_each(|(r, &i)| position[i] = r);
    let a = Mat::from_fn(nk, nk, |i, j| {
        m[kept_at[i] * nc + kept_at[j]] / (s[kept[i]] * s[kept[j]])
    });
    let b = kept_at
        .iter()
        .zip(kept)
        .map(|(&r, &i)| q[r] / s[i])
        .collect();
    let pick = |v: &[f64]| kept.iter().map(|&i| v[i]).collect::<Vec<_>>();
    let friction = problem
        .friction()
        .iter()
        .map(|fr| FrictionRow {
            row: position[fr.row],
            normal: position[fr.normal],
            mu: fr.mu,
        })
        .collect();
    Problem::boxed(a, b, pick(problem.lo()), pick(problem.hi()), friction).map_err(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::mat;

    fn problem(a: &[&[f64]], b: &[f64], free: &[usize]) -> Problem {
        let n = b.len();
        let lo = (0..n)
            .map(|i| {
                if free.contains(&i) {
                    f64::NEG_INFINITY
                } else {
                    0.0
                }
            })
            .collect();
        Problem::boxed(mat(a), b.to_vec(), lo, vec![f64::INFINITY; n], vec![]).unwrap()
    }

    /// One free row: `M = A_CC − A_CF A_FF⁻¹ A_FC` and `q = b_C − A_CF A_FF⁻¹ b_F` by hand, and
    /// the free impulse recovered with `w_F = 0`.
    #[test]
    fn eliminates_a_free_row_and_recovers_it() {
        let a: [&[f64]; 3] = [&[4.0, 2.0, 0.0], &[2.0, 3.0, 1.0], &[0.0, 1.0, 2.0]];
        let p = problem(&a, &[4.0, -1.0, -2.0], &[0]);
        let free = FreeRows::of(&p);
        let reduced = free.rows(&p);
        assert_eq!(reduced.n(), 2);
        // A_FF = 4, A_CF = (2, 0): M = [[3 − 1, 1], [1, 2]], q = (−1 − 2, −2).
        let expect = [[2.0, 1.0], [1.0, 2.0]];
        for (i, row) in expect.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((reduced.entry(i, j) - v).abs() < 1e-15, "M[{i}][{j}]");
            }
        }
        assert!((reduced.b()[0] + 3.0).abs() < 1e-15 && (reduced.b()[1] + 2.0).abs() < 1e-15);
        // The reduced LCP's solution f_C = (4/3, 1/3) (w_C = 0) gives f_0 = −(4 + 2·4/3)/4.
        let f = free.expand(vec![4.0 / 3.0, 1.0 / 3.0]);
        assert!((f[0] + 5.0 / 3.0).abs() < 1e-15, "{f:?}");
        assert!(p.velocity(&f).iter().all(|w| w.abs() < 1e-14));
        assert_eq!(free.original_rows(vec![1]), vec![0, 2]);
        assert_eq!(free.restrict(&[7.0, 8.0, 9.0]), vec![8.0, 9.0]);
    }

    /// A joint row repeated (a singular `A_FF`): one copy is eliminated and the other dropped
    /// with `f = 0` when the two agree; when their velocities disagree, the copy stays free and
    /// its row of `M` vanishes, with `q ≠ 0` (no solution).
    #[test]
    fn a_repeated_joint_row_is_dropped_or_kept_free() {
        let a: [&[f64]; 3] = [&[2.0, 2.0, 1.0], &[2.0, 2.0, 1.0], &[1.0, 1.0, 3.0]];
        let p = problem(&a, &[1.0, 1.0, -2.0], &[0, 1]);
        let free = FreeRows::of(&p);
        let reduced = free.rows(&p);
        assert_eq!(reduced.n(), 1);
        let how = free.describe().unwrap();
        assert!(how.contains("1 redundant free rows dropped"), "{how}");
        // M = 3 − 1/2 = 5/2, q = −2 − 1/2; f_C = 1 solves it, and then w = 0 on the free rows.
        assert!((reduced.entry(0, 0) - 2.5).abs() < 1e-15);
        let f = free.expand(vec![1.0]);
        let w = p.velocity(&f);
        assert!(w[0].abs() < 1e-15 && w[1].abs() < 1e-15, "{w:?}");
        assert!(f[0] == 0.0 || f[1] == 0.0, "{f:?}");

        let p = problem(&a, &[1.0, 1.5, -2.0], &[0, 1]);
        let free = FreeRows::of(&p);
        let reduced = free.rows(&p);
        assert_eq!(reduced.n(), 2);
        assert!(free.describe().unwrap().contains("1 kept free"));
        let kept_free = (0..2)
            .find(|&i| reduced.lo()[i] == f64::NEG_INFINITY)
            .unwrap();
        assert!((0..2).all(|j| reduced.entry(kept_free, j) == 0.0));
        assert!(reduced.b()[kept_free].abs() > 0.1);
    }

    #[test]
    fn without_a_regular_block_nothing_is_eliminated() {
        let a: [&[f64]; 2] = [&[0.0, 1.0], &[1.0, 2.0]];
        let p = problem(&a, &[1.0, -1.0], &[0]);
        let free = FreeRows::of(&p);
        assert!(matches!(free, FreeRows::NotEliminated { rows: 1, .. }));
        assert_eq!(free.rows(&p).n(), 2);
        let p = problem(&a, &[1.0, -1.0], &[]);
        assert!(matches!(FreeRows::of(&p), FreeRows::None));
        assert!(FreeRows::of(&p).describe().is_none());
    }
}

//! The LCP as a convex quadratic program, solved by Clarabel's interior-point method.
//!
//! For symmetric positive semidefinite `A` the boxed LCP is the KKT system of
//!
//! ```text
//! minimise ½ fᵀ A f + bᵀ f   subject to   lo <= f <= hi,
//! ```
//!
//! since stationarity reads `A f + b = λ_lo − λ_hi` with `λ_lo ⟂ f − lo`, `λ_hi ⟂ hi − f`, both
//! `>= 0`, which is exactly `w = A f + b >= 0` at the lower bound, `<= 0` at the upper bound and
//! `= 0` in between. The QP is handed to Clarabel with each finite bound as one row of the
//! nonnegative cone and each fixed row (`lo = hi`) as one row of the zero cone.
//!
//! * **Problem class**: symmetric (to a relative `symmetry_tolerance`, default `1e-10`) positive
//!   semidefinite `A`: SPD, and PSD rank-deficient (redundant contacts); standard and boxed LCP.
//!   A free (equality) row (`lo = −∞`, `hi = +∞`) has no constraint row at all: its impulse is an
//!   unconstrained variable of the QP, whose stationarity is `w_i = 0`. Redundant joints (a
//!   singular `A_FF`) leave the QP's minimisers non-unique, which the interior point handles as it
//!   handles redundant contacts; inconsistent ones make the QP unbounded below, a proof that
//!   there is no solution. A problem of free rows only has no constraint and is handed to
//!   Clarabel as it is.
//!   Non-symmetric `A` and indefinite `A` are refused as `Unsupported` before Clarabel runs. The
//!   semidefiniteness check is one sparse Cholesky factorisation (faer) of the diagonally scaled matrix
//!   `Â = E A E` (`E` below) shifted by `psd_tolerance · ‖Â‖_F`; it accepts `A` whose smallest
//!   eigenvalue is above about `−psd_tolerance · ‖Â‖_F` in the scaled variables.
//! * **Friction rows are a convex relaxation.** A friction row `t` with normal row `k` becomes the
//!   two linear constraints `f_t − mu f_k <= 0` and `−f_t − mu f_k <= 0`. The KKT point of this QP
//!   is *not* the boxed LCP's solution: the constraint gradients add `−mu (λ₊ + λ₋)` to the normal
//!   row's stationarity condition, and stationarity of the friction row gives `λ₊ + λ₋ = |w_t|`,
//!   so a sliding contact ends with `w_k = mu Σ_t |w_t| > 0` (summed over its friction rows)
//!   while `f_k > 0`: the contact pushes harder than the LCP's and separates, the "boundary
//!   layer" of Anitescu's relaxation. The shared residual measures the difference, so such results
//!   come back `Stalled`, not `Converged`; sticking contacts (strictly inside the cone) are
//!   unaffected. The relaxation also forces `f_k >= 0` on a normal row that carries friction even
//!   when its own `lo_k < 0`. When the normal row cannot be positive (`hi_k <= 0`) or `mu = 0`, the
//!   LCP's friction bounds are identically zero and the row is fixed at `f_t = 0` exactly.
//! * **Scaling**: Clarabel's tolerances are partly absolute, so the problem is first made
//!   dimensionless: `f = τ E h` with `E = diag(1/√d)` (`d` the
//!   [diagonal scale](crate::Problem::diagonal_scale)) and `τ = max_i |b_i| / √d_i` (or the
//!   largest finite bound magnitude when `b = 0`), and the objective is divided by `τ²`. The QP in
//!   `h` has a unit diagonal and a linear term of size one, and is the same QP for `(A, b)` and
//!   `(σA, σb)`, so problems with entries of size `1e-9` or `1e9` behave as those of size one.
//! * **Tolerances**: Clarabel's `tol_gap_abs`, `tol_gap_rel`, `tol_feas`, `tol_infeas_abs` and
//!   `tol_infeas_rel` are set to `tolerance_factor · Settings::tolerance` (default factor `1e-2`),
//!   floored at `min_ipm_tolerance` (default `1e-13`). The status is then decided, as for every
//!   solver, by the shared residual of the returned `f`.
//! * **Output**: an interior-point iterate can sit a rounding error outside a bound; the returned
//!   `f` is projected onto the bounds (stored bounds first, then the friction bounds at the
//!   projected normal impulses). An interior point also leaves every inactive row a little off
//!   its bound (`f_i w_i ≈ μ`), which the relative residual sees when the solution is small (for
//!   `b = 0` the solution is `f = 0` and any `f ≠ 0` is wrong by 100%). Problems without friction
//!   rows are therefore polished once, like OSQP's *solution polishing* (Stellato et al., 2020):
//!   the active set is read off the natural map, `f` is fixed at its bounds there, and the free
//!   rows solve `A_FF f_F = −(b + A_FC f_C)_F` by `polish_refinements` (default 3) steps of
//!   iterative refinement from `f_F = 0`, with one Cholesky factorisation of the scaled
//!   `Â_FF + 10⁻¹² max|Â| I` (which also converges for singular, consistent `A_FF`). The polished
//!   `f` is kept only if its shared residual is smaller; the cost is one extra sparse Cholesky
//!   factorisation, and the reported iterations do not count it.
//! * **Cost**: one sparse `LDLᵀ` factorisation of the quasi-definite KKT matrix per
//!   interior-point iteration. `P = Â` is handed over sparse (the stored entries of `A`), so the
//!   cost follows the fill of that factorisation: `O(n³)` for a dense `A`, far less for the
//!   block-sparse Delassus matrices of contact scenes; Clarabel
//!   needs 7 to 20 iterations on the generated families. `Settings::max_iterations` counts
//!   interior-point iterations and is capped at `max_ipm_iterations` (default 200).
//!   `Settings::warm_start` is ignored (interior-point methods start from the central path), and
//!   the history holds one point, the final iterate, because Clarabel does not expose its
//!   iterates.
//! * **Failure modes**: for PSD `A` (no friction rows) the LCP has a solution if and only if the QP
//!   is bounded below (a convex QP bounded below on a nonempty polyhedron attains its minimum, and
//!   its minimisers are exactly the KKT points). Clarabel's certificate of dual infeasibility (a
//!   direction of unbounded descent) is therefore a proof that the LCP has *no* solution and is
//!   reported as `NoSolution`; a primal infeasibility certificate (the relaxation has no feasible
//!   point, which the constructions above rule out except through rounding) is reported the same
//!   way. With friction rows a certificate concerns the relaxation, which may have none where the
//!   boxed LCP has a solution: it is reported as `Stalled`, with the reason. Clarabel's
//!   own iteration and time limits map to `IterationLimit` and `TimeLimit`; its numerical error and
//!   insufficient progress to `NumericalFailure`; a panic inside Clarabel is caught and reported as
//!   `NumericalFailure`.
//!
//! References: P. J. Goulart and Y. Chen, *Clarabel: An interior-point solver for conic programs
//! with quadratic objectives*, arXiv:2405.12762, 2024. M. Anitescu, *Optimization-based simulation
//! of nonsmooth rigid multibody dynamics*, Math. Program. 105, 2006 (the convex relaxation of
//! Coulomb friction and its KKT point). Cottle–Pang–Stone 1992, §1.2 (LCP as the KKT system of a
//! QP). B. Stellato et al., *OSQP: an operator splitting solver for quadratic programs*, Math.
//! Prog. Comp. 12, 2020, §5.2 (solution polishing).

use crate::linalg::cholesky_fill;
use crate::problem::metrics::residuals;
use crate::problem::Problem;
use crate::solver::{Monitor, Outcome, Settings, SolveResult, Solver};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use faer::Mat;

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "LCP and boxed LCP with symmetric PSD A (convex QP, interior point, sparse P); free (equality) rows as unconstrained variables; friction rows as a convex relaxation";

/// The registry's entry of `clarabel`.
pub static CLARABEL: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "clarabel",
    summary: "convex QP through Clarabel's interior-point method",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "interior-point iterations",
    iterative: false,
    relaxation: Some(
        "on friction rows, Anitescu's convex relaxation (a QP whose sliding contacts \
         may lift off), not the friction LCP",
    ),
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(ClarabelQp::default())),
};

/// The LCP as a convex QP, solved by Clarabel. See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct ClarabelQp {
    /// The acceptance tests on `A` and the limits of the interior-point run.
    /// Default [`InteriorPoint::default`].
    pub ipm: InteriorPoint,
    /// Make the problem dimensionless before handing it to Clarabel (see the module doc).
    /// Default `true`.
    pub scale: bool,
    /// Refinement steps of the active-set polish after the interior-point solve (see the module
    /// doc); `0` turns polishing off. Default `3`.
    pub polish_refinements: usize,
}

impl Default for ClarabelQp {
    fn default() -> Self {
        Self {
            ipm: InteriorPoint::default(),
            scale: true,
            polish_refinements: 3,
        }
    }
}

/// The QP in the scaled variables `h` (`f_i = tau · e_i · h_i`), in Clarabel's form
/// `min ½ hᵀ P h + qᵀ h` s.t. `G h + s = c`, `s ∈ {0}^zero × R₊^nonneg`.
struct ScaledQp {
    e: Vec<f64>,
    tau: f64,
    /// `Â = E A E` symmetrised, both triangles, sparse.
    a_hat: SparseColMat<usize, f64>,
    q: Vec<f64>,
    /// Constraint rows as `(column, value)` lists with right-hand sides; zero-cone rows first.
    rows: Vec<(Vec<(usize, f64)>, f64)>,
    zero: usize,
}

impl ScaledQp {
    fn new(problem: &Problem, scale: bool) -> Self {
        let n = problem.n();
        let b = problem.b();
        let e: Vec<f64> = if scale {
            problem
                .diagonal_scale()
                .iter()
                .map(|d| 1.0 / d.sqrt())
                .collect()
        } else {
            vec![1.0; n]
        };
        let mut tau = (0..n).fold(0.0_f64, |m, i| m.max((b[i] * e[i]).abs()));
        if !scale {
            tau = 1.0;
        } else if !(tau > 0.0 && tau.is_finite()) {
            // b = 0: take the size of the finite bounds, or 1.
            tau = (0..n)
                .filter(|&i| problem.friction_of(i).is_none())
                .flat_map(|i| [problem.lo()[i], problem.hi()[i]].map(|v| (v, i)))
                .filter(|(v, _)| v.is_finite())
                .fold(0.0_f64, |m, (v, i)| m.max(v.abs() / e[i]));
            if !(tau > 0.0 && tau.is_finite()) {
                tau = 1.0;
            }
        }
        let a_hat = scaled_symmetric_part(problem, &e);
        let q = (0..n).map(|i| e[i] * b[i] / tau).collect();

        let mut zero_rows = Vec::new();
        let mut nonneg_rows = Vec::new();
        for i in 0..n {
            let to_h = |v: f64| v / (tau * e[i]);
            match problem.friction_of(i) {
                Some((k, mu)) => {
                    if mu == 0.0 || problem.hi()[k] <= 0.0 {
                        zero_rows.push((vec![(i, 1.0)], 0.0));
                    } else {
                        let c = mu * e[k] / e[i];
                        nonneg_rows.push((vec![(i, 1.0), (k, -c)], 0.0));
                        nonneg_rows.push((vec![(i, -1.0), (k, -c)], 0.0));
                    }
                }
                None => {
                    let (lo, hi) = (problem.lo()[i], problem.hi()[i]);
                    if lo == hi {
                        zero_rows.push((vec![(i, 1.0)], to_h(lo)));
                        continue;
                    }
                    if lo.is_finite() {
                        nonneg_rows.push((vec![(i, -1.0)], -to_h(lo)));
                    }
                    if hi.is_finite() {
                        nonneg_rows.push((vec![(i, 1.0)], to_h(hi)));
                    }
                }
            }
        }
        let zero = zero_rows.len();
        zero_rows.append(&mut nonneg_rows);
        Self {
            e,
            tau,
            a_hat,
            q,
            rows: zero_rows,
            zero,
        }
    }

    /// Clarabel's constraint matrix and right-hand side.
    fn constraints(&self) -> (CscMatrix<f64>, Vec<f64>) {
        let n = self.a_hat.nrows();
        let m = self.rows.len();
        let mut ii = Vec::new();
        let mut jj = Vec::new();
        let mut vv = Vec::new();
        for (r, (entries, _)) in self.rows.iter().enumerate() {
            for &(j, v) in entries {
                ii.push(r);
                jj.push(j);
                vv.push(v);
            }
        }
        let rhs = self.rows.iter().map(|(_, c)| *c).collect();
        (CscMatrix::new_from_triplets(m, n, ii, jj, vv), rhs)
    }

    fn cones(&self) -> Vec<SupportedConeT<f64>> {
        let mut cones = Vec::new();
        if self.zero > 0 {
            cones.push(SupportedConeT::ZeroConeT(self.zero));
        }
        if self.rows.len() > self.zero {
            cones.push(SupportedConeT::NonnegativeConeT(
                self.rows.len() - self.zero,
            ));
        }
        cones
    }

    fn unscale(&self, h: &[f64]) -> Vec<f64> {
        h.iter()
            .zip(&self.e)
            .map(|(hi, ei)| self.tau * ei * hi)
            .collect()
    }

    /// Active-set polish of an interior-point answer `f` (no friction rows): rows whose
    /// natural-map step `f_i − w_i / d_i` leaves `[lo_i, hi_i]` are fixed at that bound, and the
    /// free rows solve `A_FF f_F = −(b + A_{·C} f_C)_F` from `f_F = 0` by iterative refinement
    /// with the factorisation of the scaled `Â_FF + εI` (proximal-point steps, which also converge
    /// on consistent singular systems, to the solution nearest zero in the scaled norm).
    /// `None` when the factorisation fails.
    fn polish(&self, problem: &Problem, f: &[f64], refinements: usize) -> Option<Vec<f64>> {
        let n = problem.n();
        let d = problem.diagonal_scale();
        let w = problem.velocity(f);
        let mut g = f.to_vec();
        let mut free = Vec::new();
        for i in 0..n {
            let (lo, hi) = (problem.lo()[i], problem.hi()[i]);
            let t = f[i] - w[i] / d[i];
            if t <= lo {
                g[i] = lo;
            } else if t >= hi {
                g[i] = hi;
            } else {
                free.push(i);
                g[i] = 0.0;
            }
        }
        if free.is_empty() {
            return Some(g);
        }
        let k = free.len();
        let amax = self.a_hat.val().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let eps = 1e-12 * amax.max(f64::MIN_POSITIVE);
        let llt = shifted_block(&self.a_hat, &free, eps)
            .sp_cholesky(faer::Side::Lower)
            .ok()?;
        for _ in 0..refinements {
            let w = problem.velocity(&g);
            // Â δy = −E w_F, δf = E δy.
            let rhs = Mat::from_fn(k, 1, |r, _| -self.e[free[r]] * w[free[r]]);
            let dy = llt.solve(&rhs);
            for (r, &i) in free.iter().enumerate() {
                g[i] += self.e[i] * dy[(r, 0)];
            }
        }
        problem.project_onto_bounds(&mut g);
        Some(g)
    }
}

/// `Â = ½ (E A E + (E A E)ᵀ)`, `E = diag(e)`, both triangles, from the stored entries of `A`
/// (sparse in, sparse out).
pub(crate) fn scaled_symmetric_part(problem: &Problem, e: &[f64]) -> SparseColMat<usize, f64> {
    let n = problem.n();
    let mut triplets = Vec::with_capacity(2 * problem.nnz());
    for i in 0..n {
        for (j, v) in problem.row(i).iter() {
            if v != 0.0 {
                let x = 0.5 * e[i] * v * e[j];
                triplets.push(Triplet::new(i, j, x));
                triplets.push(Triplet::new(j, i, x));
            }
        }
    }
    SparseColMat::try_new_from_triplets(n, n, &triplets)
        .expect("indices of a valid problem are in range")
}

/// True when `Â + δ I` has a sparse Cholesky factorisation, `δ = psd_tolerance · ‖Â‖_F`.
pub(crate) fn is_psd(a_hat: &SparseColMat<usize, f64>, psd_tolerance: f64) -> bool {
    let norm = a_hat.val().iter().map(|v| v * v).sum::<f64>().sqrt();
    let delta = psd_tolerance * norm.max(f64::MIN_POSITIVE);
    let all: Vec<usize> = (0..a_hat.nrows()).collect();
    shifted_block(a_hat, &all, delta)
        .sp_cholesky(faer::Side::Lower)
        .is_ok()
}

/// The principal block of `Â` on `rows` (increasing), plus `shift · I`.
fn shifted_block(
    a_hat: &SparseColMat<usize, f64>,
    rows: &[usize],
    shift: f64,
) -> SparseColMat<usize, f64> {
    let n = a_hat.nrows();
    let mut local = vec![usize::MAX; n];
    for (k, &i) in rows.iter().enumerate() {
        local[i] = k;
    }
    let sym = a_hat.symbolic();
    let (ptr, idx, val) = (sym.col_ptr(), sym.row_idx(), a_hat.val());
    let mut triplets: Vec<Triplet<usize, usize, f64>> =
        (0..rows.len()).map(|k| Triplet::new(k, k, shift)).collect();
    for (c, &j) in rows.iter().enumerate() {
        for p in ptr[j]..ptr[j + 1] {
            if local[idx[p]] != usize::MAX {
                triplets.push(Triplet::new(local[idx[p]], c, val[p]));
            }
        }
    }
    SparseColMat::try_new_from_triplets(rows.len(), rows.len(), &triplets)
        .expect("local indices are in range")
}

/// Clarabel's `P`: the upper triangle of the symmetric `Â` in CSC.
pub(crate) fn upper_triangle(a_hat: &SparseColMat<usize, f64>) -> CscMatrix<f64> {
    let n = a_hat.nrows();
    let sym = a_hat.symbolic();
    let (ptr, idx, val) = (sym.col_ptr(), sym.row_idx(), a_hat.val());
    let mut colptr = Vec::with_capacity(n + 1);
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    colptr.push(0);
    for j in 0..n {
        for p in ptr[j]..ptr[j + 1] {
            if idx[p] <= j && val[p] != 0.0 {
                rowval.push(idx[p]);
                nzval.push(val[p]);
            }
        }
        colptr.push(rowval.len());
    }
    CscMatrix::new(n, n, colptr, rowval, nzval)
}

/// The parameters both Clarabel solvers ([`ClarabelQp`], [`crate::ClarabelSocp`]) share: when
/// the matrix counts as symmetric positive semidefinite, and how tightly and how long Clarabel
/// runs.
#[derive(Debug, Clone, PartialEq)]
pub struct InteriorPoint {
    /// Relative tolerance (of the matrix's largest entry) under which `A` counts as symmetric
    /// for [`crate::ClarabelQp`]. Default `1e-10`. ([`crate::ClarabelSocp`] accepts `W` within
    /// [`crate::SYMMETRISE_WITHIN`] instead and solves its symmetric part.)
    pub symmetry_tolerance: f64,
    /// The matrix counts as positive semidefinite when its scaled form `Â` shifted by
    /// `psd_tolerance · ‖Â‖_F` has a Cholesky factorisation. Default `1e-10`.
    pub psd_tolerance: f64,
    /// Clarabel's gap and feasibility tolerances are `tolerance_factor · Settings::tolerance`,
    /// so that the interior point stops a little inside the shared residual's tolerance.
    /// Default `1e-2`.
    pub tolerance_factor: f64,
    /// Floor on Clarabel's gap and feasibility tolerances (a few hundred machine epsilons,
    /// near the accuracy Clarabel's double-precision KKT solves reach). Default `1e-13`.
    pub min_ipm_tolerance: f64,
    /// Cap on interior-point iterations, whatever `Settings::max_iterations` says (Clarabel's
    /// own default). Default `200`.
    pub max_ipm_iterations: u32,
    /// Largest Cholesky factor of the scaled matrix, in entries
    /// ([`crate::linalg::cholesky_fill`], a symbolic analysis before any numerical work), for which [`crate::ClarabelQp`] and [`crate::ClarabelSocp`] run. Every
    /// interior-point iteration factorises a KKT matrix whose factor holds at least as many, and
    /// neither that factorisation nor the semidefiniteness test can be interrupted, so above it
    /// a solve would overrun any time budget. Default `5·10⁶` (40 MB of factor; the step of
    /// `pyramid_20`, 1,600 contacts, has a factor of 6·10⁵ entries and solves in 1.7 s).
    pub max_factor_entries: usize,
}

impl Default for InteriorPoint {
    fn default() -> Self {
        Self {
            symmetry_tolerance: 1e-10,
            psd_tolerance: 1e-10,
            tolerance_factor: 1e-2,
            min_ipm_tolerance: 1e-13,
            max_ipm_iterations: 200,
            max_factor_entries: 5_000_000,
        }
    }
}

/// Limits of one interior-point run.
pub(crate) struct IpmLimits {
    /// Clarabel's gap, feasibility and infeasibility tolerances.
    pub(crate) tol: f64,
    /// Interior-point iterations, at least 1.
    pub(crate) max_iter: u32,
    /// Seconds; `f64::INFINITY` for none.
    pub(crate) time_limit: f64,
}

impl IpmLimits {
    /// The limits of a run that may take the time left of `settings.time_budget` after
    /// `elapsed`, at most `ipm.max_ipm_iterations` interior-point iterations, to Clarabel's
    /// tolerance `ipm.tolerance_factor · settings.tolerance` (not below
    /// `ipm.min_ipm_tolerance`). `Err` when the time or the iterations are already spent.
    pub(crate) fn new(
        settings: &Settings,
        elapsed: std::time::Duration,
        ipm: &InteriorPoint,
    ) -> Result<Self, Outcome> {
        let time_limit = match settings.time_budget {
            Some(budget) => {
                let left = budget.saturating_sub(elapsed);
                if left.is_zero() {
                    return Err(Outcome::TimeLimit);
                }
                left.as_secs_f64()
            }
            None => f64::INFINITY,
        };
        let max_iter = settings
            .max_iterations
            .min(ipm.max_ipm_iterations as usize)
            .min(u32::MAX as usize) as u32;
        if max_iter == 0 {
            return Err(Outcome::IterationLimit);
        }
        Ok(Self {
            tol: (ipm.tolerance_factor * settings.tolerance).max(ipm.min_ipm_tolerance),
            max_iter,
            time_limit,
        })
    }
}

/// What one interior-point run returned.
pub(crate) struct IpmRun {
    pub(crate) x: Vec<f64>,
    pub(crate) status: SolverStatus,
    pub(crate) iterations: usize,
}

/// Run Clarabel on `min ½ xᵀ P x + qᵀ x` s.t. `A x + s = b`, `s ∈ cones`, quietly. A rejected
/// setting or problem and a panic inside Clarabel come back as the reason of a numerical failure.
pub(crate) fn run_clarabel(
    p: &CscMatrix<f64>,
    q: &[f64],
    a: &CscMatrix<f64>,
    b: &[f64],
    cones: &[SupportedConeT<f64>],
    limits: &IpmLimits,
) -> Result<IpmRun, String> {
    let tol = limits.tol;
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .max_iter(limits.max_iter)
        .time_limit(limits.time_limit)
        .tol_gap_abs(tol)
        .tol_gap_rel(tol)
        .tol_feas(tol)
        .tol_infeas_abs(tol)
        .tol_infeas_rel(tol)
        .build()
        .map_err(|e| format!("Clarabel rejected the settings: {e}"))?;
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut solver = DefaultSolver::new(p, q, a, b, cones, settings)
            .map_err(|e| format!("Clarabel rejected the problem: {e}"))?;
        solver.solve();
        let s = &solver.solution;
        Ok(IpmRun {
            x: s.x.clone(),
            status: s.status,
            iterations: s.iterations as usize,
        })
    }));
    run.unwrap_or_else(|_| Err("Clarabel panicked".into()))
}

impl Solver for ClarabelQp {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &CLARABEL
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let monitor = Monitor::new(problem, settings);
        if problem.n() == 0 {
            return monitor.finish(Vec::new(), 0, Outcome::Stopped);
        }
        let qp = match self.formulate(problem) {
            Ok(qp) => qp,
            Err(outcome) => return monitor.finish(Vec::new(), 0, outcome),
        };
        let mut fallback = vec![0.0; problem.n()];
        problem.project_onto_bounds(&mut fallback);
        let limits = match IpmLimits::new(settings, monitor.elapsed(), &self.ipm) {
            Ok(limits) => limits,
            Err(outcome) => return monitor.finish(fallback, 0, outcome),
        };
        let (g, c) = qp.constraints();
        let run = run_clarabel(
            &upper_triangle(&qp.a_hat),
            &qp.q,
            &g,
            &c,
            &qp.cones(),
            &limits,
        );
        let IpmRun {
            x: h,
            status,
            iterations,
        } = match run {
            Ok(r) => r,
            Err(reason) => return monitor.finish(fallback, 0, Outcome::NumericalFailure(reason)),
        };
        let infeasible = matches!(
            status,
            SolverStatus::DualInfeasible
                | SolverStatus::AlmostDualInfeasible
                | SolverStatus::PrimalInfeasible
                | SolverStatus::AlmostPrimalInfeasible
        );
        let (mut f, outcome) = interpret(problem, &qp, status, &h, fallback);
        if f.iter().all(|v| v.is_finite()) {
            problem.project_onto_bounds(&mut f);
            if !infeasible {
                self.polish_if_better(problem, &qp, &mut f);
            }
        }
        let outcome = relaxation_outcome(problem, &f, settings.tolerance, outcome);
        let mut monitor = monitor;
        monitor.record(iterations, &f);
        monitor.finish(f, iterations, outcome)
    }
}

/// With friction rows, Clarabel's `Solved` means it solved Anitescu's convex relaxation (the QP
/// whose friction constraints are `|f_t| <= mu f_k`), not the boxed LCP. When `f` misses the
/// tolerance on the boxed LCP's shared residual, the reason names the relaxed problem and gives
/// that residual, instead of the generic "stopping rule met". The status stays `Stalled`: the
/// boxed LCP is not solved. Other outcomes, and problems without friction rows, pass through.
fn relaxation_outcome(problem: &Problem, f: &[f64], tol: f64, outcome: Outcome) -> Outcome {
    if problem.friction().is_empty() || !matches!(outcome, Outcome::Stopped) {
        return outcome;
    }
    let rel = residuals(problem, f).natural_map_rel;
    if rel <= tol {
        return outcome;
    }
    Outcome::Stalled(format!(
        "solved Anitescu's convex relaxation of the friction rows (QP with |f_t| <= mu f_n, where \
         sliding contacts separate), not the boxed LCP: relative residual on the boxed LCP \
         {rel:.3e} > tolerance {tol:.1e}"
    ))
}

impl ClarabelQp {
    /// The scaled QP of a symmetric PSD problem; otherwise why the LCP is not a convex QP.
    fn formulate(&self, problem: &Problem) -> Result<ScaledQp, Outcome> {
        if !problem.is_symmetric(self.ipm.symmetry_tolerance) {
            return Err(Outcome::Unsupported(format!(
                "A is not symmetric (relative tolerance {:.0e}); the LCP is not the KKT system of a QP",
                self.ipm.symmetry_tolerance
            )));
        }
        let qp = ScaledQp::new(problem, self.scale);
        // The same bound as the SOCP relaxation's: the semidefiniteness test and every
        // interior-point iteration factorise a matrix whose factor holds at least this many
        // entries, and a factorisation can be neither interrupted nor allocated piecemeal, so
        // above the cap the solve would overrun its time budget and its memory (a step of 8,000
        // fixed joints once took 3.2 GB and 50 s under a 10 s budget).
        let fill = cholesky_fill(qp.a_hat.symbolic());
        if fill.is_none_or(|f| f > self.ipm.max_factor_entries) {
            return Err(Outcome::Unsupported(format!(
                "the Cholesky factor of A would hold {} entries (symbolic analysis, AMD \
                 ordering), above the {} an interior-point iteration is allowed to factorise \
                 (InteriorPoint::max_factor_entries): a factorisation cannot be interrupted, so \
                 the solve would overrun its time budget and memory",
                fill.map_or("too many".to_owned(), |f| f.to_string()),
                self.ipm.max_factor_entries
            )));
        }
        if !is_psd(&qp.a_hat, self.ipm.psd_tolerance) {
            return Err(Outcome::Unsupported(format!(
                "A is indefinite (Cholesky of the scaled A + {:.0e}·‖A‖_F·I failed); the QP is not convex",
                self.ipm.psd_tolerance
            )));
        }
        Ok(qp)
    }

    /// Replace `f` by its polished version when that lowers the shared residual (frictionless
    /// problems only).
    fn polish_if_better(&self, problem: &Problem, qp: &ScaledQp, f: &mut Vec<f64>) {
        if self.polish_refinements == 0 || !problem.friction().is_empty() {
            return;
        }
        if let Some(g) = qp.polish(problem, f, self.polish_refinements) {
            if residuals(problem, &g).natural_map_rel < residuals(problem, f).natural_map_rel {
                *f = g;
            }
        }
    }
}

/// The impulse and outcome of Clarabel's `status`: its unscaled iterate `h`, or `fallback` (the
/// bound projection of zero) when Clarabel proved infeasibility.
fn interpret(
    problem: &Problem,
    qp: &ScaledQp,
    status: SolverStatus,
    h: &[f64],
    fallback: Vec<f64>,
) -> (Vec<f64>, Outcome) {
    // With friction rows a certificate concerns the convex relaxation, not the boxed LCP: it
    // proves nothing about the problem, so the solve has stalled.
    let relaxed = !problem.friction().is_empty();
    match status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => (qp.unscale(h), Outcome::Stopped),
        SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible if relaxed => (
            fallback,
            Outcome::Stalled(format!(
                "Clarabel: {status:?}, the QP of the friction relaxation is unbounded below; not \
                 a proof for the boxed LCP"
            )),
        ),
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible if relaxed => (
            fallback,
            Outcome::Stalled(format!(
                "Clarabel: {status:?}, the friction relaxation admits no feasible point; not a \
                 proof for the boxed LCP"
            )),
        ),
        SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => (
            fallback,
            Outcome::NoSolution(format!(
                "Clarabel: {status:?}, the QP is unbounded below; for PSD A the LCP has no solution"
            )),
        ),
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => (
            fallback,
            Outcome::NoSolution(format!(
                "Clarabel: {status:?}, the bounds admit no feasible point"
            )),
        ),
        SolverStatus::MaxIterations => (qp.unscale(h), Outcome::IterationLimit),
        SolverStatus::MaxTime => (qp.unscale(h), Outcome::TimeLimit),
        SolverStatus::NumericalError
        | SolverStatus::InsufficientProgress
        | SolverStatus::Unsolved
        | SolverStatus::CallbackTerminated => (
            qp.unscale(h),
            Outcome::NumericalFailure(format!("Clarabel: {status:?}")),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::generate::{generate, Family};
    use crate::problem::FrictionRow;
    use crate::Status;

    fn solve(p: &Problem) -> SolveResult {
        ClarabelQp::default().solve(p, &Settings::default())
    }

    fn max_diff(x: &[f64], y: &[f64]) -> f64 {
        x.iter().zip(y).fold(0.0, |m, (a, b)| m.max((a - b).abs()))
    }

    #[test]
    fn solves_a_two_by_two_lcp() {
        // f = (0.5, 0), w = (0, 1.5).
        let a = Mat::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 2.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, 1.0]).unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert!(r.residuals.natural_map_rel <= 1e-8);
        assert!(max_diff(&r.f, &[0.5, 0.0]) < 1e-8, "{:?}", r.f);
        assert!(r.iterations > 0 && r.iterations < 50);
    }

    #[test]
    fn boxed_rows_take_their_bounds() {
        // Decoupled rows: f = mid(lo, hi, -b).
        let p = Problem::boxed(
            Mat::identity(3, 3),
            vec![-2.0, 3.0, -0.5],
            vec![-1.0, -1.0, f64::NEG_INFINITY],
            vec![1.0, 1.0, f64::INFINITY],
            vec![],
        )
        .unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert!(max_diff(&r.f, &[1.0, -1.0, 0.5]) < 1e-8, "{:?}", r.f);
    }

    #[test]
    fn planted_spd_is_solved_to_the_planted_impulse() {
        let g = generate(Family::Spd { cond: 1e3 }, 50, 11);
        let r = solve(&g.problem);
        assert_eq!(r.status, Status::Converged, "{:?}", r.residuals);
        assert!(r.residuals.natural_map_rel <= 1e-8);
        let planted = g.solution.unwrap();
        assert!(
            max_diff(&r.f, &planted) < 1e-5,
            "{}",
            max_diff(&r.f, &planted)
        );
    }

    #[test]
    fn rank_deficient_psd_converges() {
        let g = generate(Family::PsdRankDeficient { rank: 10 }, 30, 5);
        let r = solve(&g.problem);
        assert_eq!(r.status, Status::Converged, "{:?}", r.residuals);
    }

    #[test]
    fn tiny_and_huge_magnitudes_converge() {
        let g = generate(Family::Spd { cond: 1e3 }, 20, 3);
        let p = &g.problem;
        for s in [1e-9, 1e9] {
            let a = Mat::from_fn(20, 20, |i, j| s * p.entry(i, j));
            let b = p.b().iter().map(|v| s * v).collect();
            let scaled = Problem::lcp(a, b).unwrap();
            // With and without the polish: the interior-point answer alone must be good.
            for polish_refinements in [3, 0] {
                let mut solver = ClarabelQp {
                    polish_refinements,
                    ..ClarabelQp::default()
                };
                let r = solver.solve(&scaled, &Settings::default());
                assert_eq!(r.status, Status::Converged, "scale {s}: {:?}", r.residuals);
                let planted = g.solution.as_ref().unwrap();
                assert!(max_diff(&r.f, planted) < 1e-5, "scale {s}");
            }
        }
    }

    #[test]
    fn polishing_makes_the_interior_point_exact() {
        // b = 0: the solution is f = 0, and any f != 0 has a relative residual of order one. The
        // interior point stops near, not at, zero; the active-set polish lands on it exactly.
        let g = generate(Family::Spd { cond: 1e2 }, 15, 8);
        let p = Problem::lcp(g.problem.to_dense(), vec![0.0; 15]).unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert!(r.f.iter().all(|&v| v == 0.0), "{:?}", r.f);
        let mut unpolished = ClarabelQp {
            polish_refinements: 0,
            ..ClarabelQp::default()
        };
        let r = unpolished.solve(&p, &Settings::default());
        assert!(!r.status.is_converged());
        // Boxed rows, planted SPD: polished to rounding level.
        let p = Problem::boxed(
            g.problem.to_dense(),
            g.problem.b().to_vec(),
            vec![-0.3; 15],
            vec![0.7; 15],
            vec![],
        )
        .unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert!(r.residuals.natural_map_rel < 1e-13, "{:?}", r.residuals);
    }

    #[test]
    fn infeasible_family_has_no_solution() {
        for seed in 0..3 {
            let g = generate(Family::Infeasible, 20, seed);
            let r = solve(&g.problem);
            assert!(
                matches!(r.status, Status::NoSolution { .. }),
                "seed {seed}: {}",
                r.status
            );
        }
    }

    /// A problem whose Cholesky factor exceeds the cap is refused before any numerical work,
    /// naming the cap; the same problem under the default cap is solved.
    #[test]
    fn a_factor_above_the_cap_is_unsupported_before_any_factorisation() {
        let g = generate(Family::Spd { cond: 1e3 }, 30, 1);
        let mut small = ClarabelQp::default();
        small.ipm.max_factor_entries = 10;
        let r = small.solve(&g.problem, &Settings::default());
        assert!(
            matches!(&r.status, Status::Unsupported { reason }
                if reason.contains("max_factor_entries") && reason.contains("above the 10 ")),
            "{}",
            r.status
        );
        assert_eq!(r.iterations, 0);
        assert!(solve(&g.problem).status.is_converged());
    }

    #[test]
    fn non_symmetric_and_indefinite_are_unsupported() {
        let g = generate(Family::PMatrix, 10, 1);
        let r = solve(&g.problem);
        assert!(
            matches!(&r.status, Status::Unsupported { reason } if reason.contains("symmetric")),
            "{}",
            r.status
        );
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, 2.0], [2.0, 1.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        let r = solve(&p);
        assert!(
            matches!(&r.status, Status::Unsupported { reason } if reason.contains("indefinite")),
            "{}",
            r.status
        );
    }

    #[test]
    fn friction_relaxation_lifts_a_sliding_contact() {
        // One contact, unit masses: pushed in with b_n = -1, dragged with b_t = -2, mu = 0.5.
        // The boxed LCP slides: f_n = 1, f_t = mu f_n = 0.5, w_n = 0, w_t = -1.5.
        // The QP relaxation minimises ½f_n² + ½f_t² − f_n − 2 f_t on |f_t| <= mu f_n; on the
        // active edge f_t = mu f_n it gives f_n = (1 + 2 mu) / (1 + mu²) = 1.6, f_t = 0.8, so the
        // normal row separates (w_n = 0.6 > 0 with f_n > 0): not the LCP's answer, and the shared
        // residual says so.
        let p = Problem::boxed(
            Mat::identity(2, 2),
            vec![-1.0, -2.0],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        let r = solve(&p);
        assert!((r.f[0] - 1.6).abs() < 1e-6, "{:?}", r.f);
        assert!((r.f[1] - 0.8).abs() < 1e-6, "{:?}", r.f);
        assert!(
            matches!(&r.status, Status::Stalled { reason }
                if reason.contains("Anitescu's convex relaxation") && reason.contains("not the boxed LCP")
                    && reason.contains(&format!("{:.3e}", r.residuals.natural_map_rel))),
            "{}",
            r.status
        );
        assert!(r.residuals.natural_map_rel > 0.1);
        // The separating velocity is mu times the sliding speed: 0.6 = 0.5 · 1.2.
        assert!((r.w[0] - 0.5 * r.w[1].abs()).abs() < 1e-6, "{:?}", r.w);
        // A sticking contact is inside the cone: no multiplier, the relaxation is exact.
        let p = Problem::boxed(
            Mat::identity(2, 2),
            vec![-1.0, -0.1],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert!(max_diff(&r.f, &[1.0, 0.1]) < 1e-8);
    }

    #[test]
    fn iteration_cap_time_budget_and_empty_problem() {
        let g = generate(Family::Spd { cond: 1e3 }, 20, 2);
        let settings = Settings {
            max_iterations: 2,
            ..Settings::default()
        };
        let r = ClarabelQp::default().solve(&g.problem, &settings);
        assert_eq!(r.status, Status::IterationLimit);
        assert!(r.iterations <= 2);
        let settings = Settings {
            time_budget: Some(std::time::Duration::ZERO),
            ..Settings::default()
        };
        let r = ClarabelQp::default().solve(&g.problem, &settings);
        assert_eq!(r.status, Status::TimeLimit);
        let p = Problem::lcp(Mat::zeros(0, 0), vec![]).unwrap();
        assert_eq!(solve(&p).status, Status::Converged);
        assert_eq!(
            ClarabelQp::default().name(),
            crate::SolverKind::Clarabel.name()
        );
    }
}

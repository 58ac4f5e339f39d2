//! The linear systems of the semismooth Newton method ([`crate::Newton`]): each iteration solves
//! `(H + μI) d = −Φ` with `H = diag(α) + diag(β) D⁻¹A` plus a coupling entry per friction row.
//!
//! Four forms, chosen per island by [`crate::LinearSystem`] and [`crate::SparseForm`]: dense
//! (partial-pivoting LU), sparse on the pattern of `A` (COLAMD ordering, supernodal LU, the
//! symbolic analysis kept between solves), the augmented body-space form for problems that carry
//! their factors `A = J M⁻¹ Jᵀ`, and the reduced system of the rows left after the rows with
//! `β_i = 0` are eliminated ([`Elimination`]). A fifth, [`KrylovSystem`], forms nothing: GMRES
//! with products through `A`'s factors (or its stored rows) and a per-contact block-Jacobi
//! preconditioner.

use crate::linalg::krylov::{gmres, BlockJacobi, Forcing, GmresParams, KrylovResult};
use crate::linalg::sparse_lu::SparseLu;
use crate::problem::{DelassusFactors, Problem};
use crate::solver::Outcome;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::solvers::Solve;
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuSymbolicParams, NumericLu, SymbolicLu};
use faer::sparse::linalg::qr;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{Argsort, Pair, SparseColMat, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::Mat;
use faer::{Conj, Par};

/// What the sparse reduced systems ([`reduced_direction`]) keep: the last large reduced
/// system's symbolic analysis and numeric factors' storage, and the island's ordering for the
/// small ones.
#[derive(Debug, Clone, Default)]
pub(crate) struct ReducedCache {
    pub(crate) symbolic: Option<SymbolicCache>,
    pub(crate) numeric: NumericLu<usize, f64>,
    /// The island's fill-reducing ordering, as each row's rank ([`island_rank`]); emptied at
    /// the start of each island solve.
    pub(crate) rank: Vec<usize>,
    /// The small reduced systems' LU storage.
    pub(crate) lu: SparseLu,
}

/// A sparse pattern with its column ordering and symbolic LU.
#[derive(Clone)]
pub(crate) struct SymbolicCache {
    pub(crate) size: usize,
    pub(crate) pairs: Vec<Pair<usize, usize>>,
    pub(crate) symbolic: SymbolicSparseColMat<usize>,
    pub(crate) argsort: Argsort<usize>,
    pub(crate) lu: SymbolicLu<usize>,
}

impl std::fmt::Debug for SymbolicCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SymbolicCache")
            .field("size", &self.size)
            .field("entries", &self.pairs.len())
            .finish()
    }
}

/// Density (stored entries over `n²`) below which [`LinearSystem::Auto`] factorises sparse.
pub(crate) const SPARSE_BELOW_DENSITY: f64 = 0.1;
/// Largest sparse reduced system solved by [`sparse_reduced_solve`] (no ordering or symbolic
/// analysis of its own); larger ones get faer's COLAMD ordering and supernodal LU, their
/// symbolic analysis reused while the kept rows stay the same. Up to a few hundred rows (FCLIB
/// spheres-in-a-box keeps 303–368) skipping the analysis is cheaper than the fill it saves;
/// reduced systems of thousands of rows (`pyramid_20`) factorise about twice as fast with the
/// ordering and the supernodal LU.
pub(crate) const SIMPLICIAL_UP_TO: usize = 400;
/// Fraction of an island's rows with `β_i = 0` from which the Newton system is solved through
/// their [`Elimination`]. From a tenth of the rows the smaller system pays for the elimination:
/// on scenes where contacts separate and slide (sphere piles, `confined`, pyramids, FCLIB
/// spheres-in-a-box) the solve takes a fraction of the time of the full system, and where
/// contacts stick (towers, arches, walls) no row is eliminated after the first iteration, so
/// nothing is lost.
pub(crate) const REDUCE_FROM: f64 = 0.1;
/// Rows from which [`LinearSystem::Auto`] considers the sparse factorisation.
pub(crate) const SPARSE_FROM_ROWS: usize = 100;

/// Why no sparse Newton system was formed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum PatternRefusal {
    /// Its LU is estimated above the entry limit ([`lu_entries_estimate`]); the reason names
    /// the estimate and the limit.
    TooMuchFill(String),
    /// The pattern or its symbolic analysis failed.
    Failed(String),
}

impl PatternRefusal {
    /// How a solve that needed the system ends: `Unsupported` above the entry limit (the
    /// report's `factor_cap`), `NumericalFailure` when the analysis failed.
    pub(crate) fn outcome(self) -> Outcome {
        match self {
            Self::TooMuchFill(reason) => Outcome::Unsupported(reason),
            Self::Failed(reason) => Outcome::NumericalFailure(reason),
        }
    }
}

/// Entries of `L` and `U` of the sparse LU of the pattern `a` under the column ordering of its
/// symbolic LU, estimated before any numerical work from the column counts of the Cholesky
/// factor `R` of `(AQ)ᵀ(AQ)` (faer's symbolic analysis of the same ordering): with partial
/// pivoting `U`'s pattern lies within `R`'s and `L`'s within the Householder vectors' (George
/// and Ng, *Symbolic factorization for sparse Gaussian elimination with partial pivoting*,
/// SIAM J. Sci. Stat. Comput. 8, 1987), counted here as `R`'s again: `2·nnz(R) − n`.
/// faer's symbolic LU computes the same column counts but does not expose them, hence this
/// second pass (linear in the pattern, after the ordering it reuses). `usize::MAX` when the
/// analysis fails.
pub(crate) fn lu_entries_estimate(
    a: SymbolicSparseColMatRef<'_, usize>,
    col_perm: PermRef<'_, usize>,
) -> usize {
    let (m, n) = (a.nrows(), a.ncols());
    let Ok(at) = a.transpose().to_col_major() else {
        return usize::MAX;
    };
    let Ok(mut mem) = MemBuffer::try_new(StackReq::new::<usize>(6 * (m + n) + 8)) else {
        return usize::MAX;
    };
    let stack = MemStack::new(&mut mem);
    let mut etree = vec![0usize; n];
    let mut post = vec![0usize; n];
    let mut col_counts = vec![0usize; n];
    let mut min_col = vec![0usize; m];
    let etree = qr::col_etree(a, Some(col_perm), &mut etree, stack);
    qr::postorder(&mut post, etree, stack);
    qr::column_counts_ata(
        &mut col_counts,
        &mut min_col,
        at.as_ref(),
        Some(col_perm),
        etree,
        &post,
        stack,
    );
    let r: usize = col_counts.iter().sum();
    (2 * r).saturating_sub(n)
}

/// One Newton system `H + μI` of an island, with its storage.
pub(crate) enum Jacobian {
    /// Dense `A`; `H` formed dense and factorised by partial-pivoting LU.
    Dense(Mat<f64>),
    /// Sparse: the fixed pattern of `H` (the pattern of `A`, the diagonal, and a coupling entry
    /// per friction row), its column ordering and symbolic LU (computed once, or taken from the workspace); each
    /// iteration refills the values and factorises numerically.
    Sparse(Box<SparseJacobian>),
}

/// What a stored entry of the sparse `H` holds.
#[derive(Clone, Copy)]
pub(crate) enum EntryKind {
    /// `β_i A_ij`.
    A(f64),
    /// `α_i` (plus the regularisation).
    Diagonal,
    /// `γ_i`, the friction row's coupling to its normal.
    Coupling,
    /// `β_i J_ic` (augmented form: row `i`'s Jacobian entry at body velocity `c`).
    Jacobian(f64),
    /// A fixed value (augmented form: `−1` and the entries of `M⁻¹ Jᵀ`).
    Fixed(f64),
}

pub(crate) struct SparseJacobian {
    /// `(row, column, kind)` per stored entry, in the order of `values`.
    pub(crate) entries: Vec<(usize, usize, EntryKind)>,
    /// Unknowns of the system: `n`, plus six body velocities per body of the island in the
    /// augmented form.
    pub(crate) size: usize,
    /// The pattern (`pairs` in the order of `entries`), its ordering and symbolic LU.
    pub(crate) pattern: SymbolicCache,
    pub(crate) values: Vec<f64>,
    /// Numeric LU factors (storage taken from the workspace and given back) and the scratch
    /// memory of factorisation and solve.
    pub(crate) numeric: NumericLu<usize, f64>,
    pub(crate) scratch: MemBuffer,
}

impl SparseJacobian {
    pub(crate) fn new(
        problem: &Problem,
        cache: Option<SymbolicCache>,
        max_entries: usize,
    ) -> Result<Self, PatternRefusal> {
        let n = problem.n();
        let mut entries = Vec::with_capacity(problem.nnz() + 2 * n);
        for i in 0..n {
            // Stored entries enter the pattern even when zero, so it depends on the storage only.
            for (j, v) in problem.row(i).iter() {
                entries.push((i, j, EntryKind::A(v)));
            }
            // Duplicated positions are summed when the matrix is assembled.
            entries.push((i, i, EntryKind::Diagonal));
            if let Some((k, _)) = problem.friction_of(i) {
                entries.push((i, k, EntryKind::Coupling));
            }
        }
        Self::factor_pattern(entries, n, cache, max_entries)
    }

    /// The augmented (body-space) form of `H + μI` for `A = J M⁻¹ Jᵀ`, with the body
    /// velocities `u = M⁻¹ Jᵀ d` as extra unknowns:
    ///
    /// ```text
    /// [ diag(α) + μI + Γ   diag(β) J ] [d]   [−Φ]
    /// [ M⁻¹ Jᵀ             −I        ] [u] = [ 0]
    /// ```
    ///
    /// It has `O(nnz(J))` entries where `A` has one per pair of rows sharing a body, so its LU
    /// fills far less on stacks and piles (the system MuJoCo's Newton solver factorises in
    /// joint space, here kept unsymmetric for the friction coupling).
    pub(crate) fn augmented(
        problem: &Problem,
        factors: &DelassusFactors,
        cache: Option<SymbolicCache>,
        max_entries: usize,
    ) -> Result<Self, PatternRefusal> {
        let n = problem.n();
        let jac = factors.jacobian();
        let sym = jac.symbolic();
        let (ptr, idx, val) = (sym.row_ptr(), sym.col_idx(), jac.val());
        // Bodies the island's rows touch, numbered locally.
        let mut local = vec![usize::MAX; factors.inverse_mass().len()];
        let mut bodies = Vec::new();
        for &c in idx.iter().take(ptr[n]) {
            let body = c / 6;
            if local[body] == usize::MAX {
                local[body] = bodies.len();
                bodies.push(body);
            }
        }
        let size = n + 6 * bodies.len();
        // Every (row, body) block enters whole, zeros included, so the pattern depends only on
        // which bodies each row touches and stays the same while the contacts do (a lever arm
        // component that drifts off exactly zero does not change it, and the symbolic analysis
        // in the workspace is reused).
        let mut entries = Vec::with_capacity(24 * n + 6 * bodies.len());
        let minv = factors.inverse_mass();
        let mut m_jt = Vec::new();
        for i in 0..n {
            let mut k = ptr[i];
            while k < ptr[i + 1] {
                let body = idx[k] / 6;
                let mut jb = [0.0; 6];
                while k < ptr[i + 1] && idx[k] / 6 == body {
                    jb[idx[k] % 6] = val[k];
                    k += 1;
                }
                let first = n + 6 * local[body];
                for (c, &v) in jb.iter().enumerate() {
                    entries.push((i, first + c, EntryKind::Jacobian(v)));
                }
                // Column i of M⁻¹ Jᵀ (row i of J gives column i).
                for (r, row) in minv[body].iter().enumerate() {
                    let v: f64 = row.iter().zip(&jb).map(|(a, b)| a * b).sum();
                    m_jt.push((first + r, i, EntryKind::Fixed(v)));
                }
            }
            entries.push((i, i, EntryKind::Diagonal));
            if let Some((k, _)) = problem.friction_of(i) {
                entries.push((i, k, EntryKind::Coupling));
            }
        }
        entries.append(&mut m_jt);
        for r in n..size {
            entries.push((r, r, EntryKind::Fixed(-1.0)));
        }
        Self::factor_pattern(entries, size, cache, max_entries)
    }

    /// The pattern, its column ordering and the symbolic LU; those of `cache` when its pattern
    /// is the same. A new pattern whose LU is estimated above `max_entries` entries
    /// ([`lu_entries_estimate`]; skipped when even a dense LU would fit) is refused before
    /// any numerical work: a factorisation cannot be interrupted, so one that takes longer than
    /// the time budget would overrun it (a 41,664-row box-pyramid island took 5–38 s per
    /// factorisation against a 1 s budget).
    pub(crate) fn factor_pattern(
        entries: Vec<(usize, usize, EntryKind)>,
        size: usize,
        cache: Option<SymbolicCache>,
        max_entries: usize,
    ) -> Result<Self, PatternRefusal> {
        let pairs: Vec<Pair<usize, usize>> = entries
            .iter()
            .map(|&(row, col, _)| Pair { row, col })
            .collect();
        let pattern = match cache {
            Some(c) if c.size == size && c.pairs == pairs => c,
            _ => {
                let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(
                    size, size, &pairs,
                )
                .map_err(|e| {
                    PatternRefusal::Failed(format!(
                        "the sparse Newton pattern could not be built: {e:?}"
                    ))
                })?;
                // Supernodal always: the contact blocks (three rows per contact point, six
                // columns per body) make dense supernodes, and faer's flop-ratio rule chose the
                // simplicial LU on towers, where it took 2.6× the instructions.
                let params = LuSymbolicParams {
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    ..Default::default()
                };
                let lu = factorize_symbolic_lu(symbolic.as_ref(), params).map_err(|e| {
                    PatternRefusal::Failed(format!("the symbolic sparse LU failed: {e:?}"))
                })?;
                // A dense LU of `size` rows holds `size²` entries: below the cap, no estimate.
                if size.saturating_mul(size) > max_entries {
                    let estimate = lu_entries_estimate(symbolic.as_ref(), lu.col_perm());
                    if estimate > max_entries {
                        return Err(PatternRefusal::TooMuchFill(format!(
                            "the sparse LU of the Newton system ({size} unknowns) would hold \
                             about {estimate} entries (column counts of the Cholesky factor of \
                             AᵀA under its COLAMD ordering), above Newton::max_factor_entries = \
                             {max_entries}: a factorisation cannot be interrupted, so the solve \
                             would overrun its time budget"
                        )));
                    }
                }
                SymbolicCache {
                    size,
                    pairs,
                    symbolic,
                    argsort,
                    lu,
                }
            }
        };
        // Fixed entries hold their values from the start; the others are set per iteration.
        let values = entries
            .iter()
            .map(|&(_, _, kind)| match kind {
                EntryKind::Fixed(v) => v,
                _ => 0.0,
            })
            .collect();
        let scratch = StackReq::any_of(&[
            pattern
                .lu
                .factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
            pattern.lu.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let scratch = MemBuffer::try_new(scratch).map_err(|_| {
            PatternRefusal::Failed("no memory for the sparse LU's scratch space".to_string())
        })?;
        Ok(Self {
            entries,
            size,
            pattern,
            values,
            numeric: NumericLu::new(),
            scratch,
        })
    }
}

/// Whether the augmented body-space system is worth its extra unknowns: when `A` has more
/// than twice its entries (about `2·nnz(J) + n + 6·bodies`). Below that the Delassus form is
/// faster (a 40-box tower, whose `A` has 1.4× the augmented entries); above it the augmented
/// form is (the 4,800-row `pyramid_20` island, 3.5×).
pub(crate) fn augmented_pays(problem: &Problem, factors: &DelassusFactors) -> bool {
    let jac = factors.jacobian();
    let augmented = 2 * jac.compute_nnz() + problem.n() + jac.ncols();
    problem.nnz() > 2 * augmented
}

/// The Newton direction `(H + μI)⁻¹(−Φ)`, dense.
pub(crate) fn dense_direction(problem: &Problem, a: &Mat<f64>, system: &System<'_>) -> Vec<f64> {
    let &System {
        alpha,
        beta,
        gamma,
        phi,
        mu_reg,
    } = system;
    let n = phi.len();
    let mut h = Mat::from_fn(n, n, |i, j| beta[i] * a[(i, j)]);
    for i in 0..n {
        h[(i, i)] += alpha[i] + mu_reg;
        if gamma[i] != 0.0 {
            if let Some((k, _)) = problem.friction_of(i) {
                h[(i, k)] += gamma[i];
            }
        }
    }
    let mut dir = Mat::from_fn(n, 1, |i, _| -phi[i]);
    h.partial_piv_lu().solve_in_place(&mut dir);
    (0..n).map(|i| dir[(i, 0)]).collect()
}

/// The Newton direction `(H + μI)⁻¹(−Φ)` with the sparse LU. A failed numeric factorisation
/// gives a non-finite direction (the gradient step is then taken).
pub(crate) fn sparse_direction(j: &mut SparseJacobian, system: &System<'_>) -> Vec<f64> {
    let &System {
        alpha,
        beta,
        gamma,
        phi,
        mu_reg,
    } = system;
    for (v, &(i, _, kind)) in j.values.iter_mut().zip(&j.entries) {
        *v = match kind {
            EntryKind::A(a) | EntryKind::Jacobian(a) => beta[i] * a,
            EntryKind::Diagonal => alpha[i] + mu_reg,
            EntryKind::Coupling => gamma[i],
            EntryKind::Fixed(v) => v,
        };
    }
    let rhs: Vec<f64> = phi.iter().map(|v| -v).collect();
    factor_and_solve(j, &rhs)
}

/// Factorises `j` with its current values and solves for `rhs` (padded with zeros up to the
/// system's size); the first `rhs.len()` unknowns. A failed factorisation gives NaN.
pub(crate) fn factor_and_solve(j: &mut SparseJacobian, rhs: &[f64]) -> Vec<f64> {
    let n = rhs.len();
    let failed = || vec![f64::NAN; n];
    let p = &j.pattern;
    let Ok(h) = SparseColMat::new_from_argsort(p.symbolic.clone(), &p.argsort, &j.values) else {
        return failed();
    };
    let stack = MemStack::new(&mut j.scratch);
    let Ok(lu) = p.lu.factorize_numeric_lu(
        &mut j.numeric,
        h.as_ref(),
        Par::Seq,
        stack,
        Default::default(),
    ) else {
        return failed();
    };
    let mut dir = Mat::from_fn(j.size, 1, |i, _| if i < n { rhs[i] } else { 0.0 });
    lu.solve_in_place_with_conj(
        Conj::No,
        dir.as_mut(),
        Par::Seq,
        MemStack::new(&mut j.scratch),
    );
    (0..n).map(|i| dir[(i, 0)]).collect()
}

/// One Newton system `(H + μI) d = −Φ`: `H`'s coefficients as [`Newton::linearise`] gives them
/// (`beta` holding `β_i / d_i`), `Φ` and the regularisation `μ`.
pub(crate) struct System<'a> {
    pub(crate) alpha: &'a [f64],
    pub(crate) beta: &'a [f64],
    pub(crate) gamma: &'a [f64],
    pub(crate) phi: &'a [f64],
    pub(crate) mu_reg: f64,
}

/// The rows of `H + μI` that [`reduced_direction`] eliminates, and how: a row with `β_i = 0`
/// (min-map: a row clamped at a bound; FB: a row exactly at its bound with a separating
/// velocity) reads `(α_i + μ) d_i + γ_i d_k = −Φ_i`, so `d_i = c_i + g_i d_k` with `g_i ≠ 0`
/// only for a friction row whose normal `k` is kept.
pub(crate) struct Elimination {
    /// Position of each kept row in the reduced system, `usize::MAX` for an eliminated one.
    pub(crate) position: Vec<usize>,
    /// The kept rows, increasing.
    pub(crate) kept: Vec<usize>,
    /// `c_i` for eliminated rows.
    pub(crate) offset: Vec<f64>,
    /// `(g_i, k)` for eliminated friction rows whose normal is kept.
    pub(crate) slope: Vec<Option<(f64, usize)>>,
}

impl Elimination {
    /// `None` when fewer than [`REDUCE_FROM`] of the rows can be eliminated (the full system
    /// is then cheaper to refactorise on its cached pattern) or a pivot `α_i + μ` is not
    /// positive.
    pub(crate) fn of(problem: &Problem, system: &System<'_>) -> Option<Self> {
        let &System {
            alpha,
            beta,
            gamma,
            phi,
            mu_reg,
        } = system;
        let n = phi.len();
        let eliminated = beta.iter().filter(|&&b| b == 0.0).count();
        if eliminated == 0 || (eliminated as f64) < REDUCE_FROM * n as f64 {
            return None;
        }
        let mut position = vec![usize::MAX; n];
        let mut kept = Vec::with_capacity(n - eliminated);
        for i in 0..n {
            if beta[i] != 0.0 {
                position[i] = kept.len();
                kept.push(i);
            }
        }
        let mut offset = vec![0.0; n];
        let mut slope = vec![None; n];
        // Normal rows first (they carry no coupling), then the friction rows that hang on them.
        for pass in 0..2 {
            for i in 0..n {
                if beta[i] != 0.0 || (pass == 0) == problem.friction_of(i).is_some() {
                    continue;
                }
                let pivot = alpha[i] + mu_reg;
                if !(pivot > 0.0 && pivot.is_finite()) {
                    return None;
                }
                offset[i] = -phi[i] / pivot;
                if gamma[i] != 0.0 {
                    let (k, _) = problem.friction_of(i)?;
                    let g = -gamma[i] / pivot;
                    if position[k] == usize::MAX {
                        offset[i] += g * offset[k];
                    } else {
                        slope[i] = Some((g, position[k]));
                    }
                }
            }
        }
        Some(Self {
            position,
            kept,
            offset,
            slope,
        })
    }

    /// The reduced system `R d_K = r` over the kept rows, entry by entry (duplicated positions
    /// add up), and its right-hand side: row `i` of `H + μI` with every eliminated `d_c`
    /// replaced by `c_c + g_c d_k`.
    pub(crate) fn reduced_system(
        &self,
        problem: &Problem,
        system: &System<'_>,
        mut entry: impl FnMut(usize, usize, f64),
    ) -> Vec<f64> {
        let System {
            beta, gamma, phi, ..
        } = system;
        let mut rhs = vec![0.0; self.kept.len()];
        let mut add = |r: usize, c: usize, v: f64, rhs: &mut [f64]| {
            let p = self.position[c];
            if p != usize::MAX {
                entry(r, p, v);
            } else {
                rhs[r] -= v * self.offset[c];
                if let Some((g, k)) = self.slope[c] {
                    entry(r, k, v * g);
                }
            }
        };
        for (r, &i) in self.kept.iter().enumerate() {
            rhs[r] -= phi[i];
            for (c, a) in problem.row(i).iter() {
                add(r, c, beta[i] * a, &mut rhs);
            }
            add(r, i, system.alpha[i] + system.mu_reg, &mut rhs);
            if gamma[i] != 0.0 {
                if let Some((k, _)) = problem.friction_of(i) {
                    add(r, k, gamma[i], &mut rhs);
                }
            }
        }
        rhs
    }

    /// The full direction from the kept rows' part `x`.
    pub(crate) fn expand(&self, x: &[f64]) -> Vec<f64> {
        (0..self.position.len())
            .map(|i| match self.position[i] {
                usize::MAX => self.offset[i] + self.slope[i].map_or(0.0, |(g, k)| g * x[k]),
                p => x[p],
            })
            .collect()
    }
}

/// The Newton direction `(H + μI)⁻¹(−Φ)` through the [`Elimination`] of the rows with
/// `β_i = 0`: dense LU of the reduced matrix when `dense`; else, up to `simplicial_up_to`
/// ([`SIMPLICIAL_UP_TO`]) kept rows, [`sparse_reduced_solve`], and above, faer's sparse LU on
/// the reduced pattern (the symbolic analysis in `cache` reused while the kept rows, and so the
/// pattern, stay the same), refused when its LU is estimated above `max_entries` entries
/// (`Err` with the reason). A failed factorisation gives a non-finite direction.
pub(crate) fn reduced_direction(
    problem: &Problem,
    elimination: &Elimination,
    system: &System<'_>,
    dense: bool,
    simplicial_up_to: usize,
    cache: &mut ReducedCache,
    max_entries: usize,
) -> Result<Vec<f64>, String> {
    let m = elimination.kept.len();
    let x = if dense {
        let mut r = Mat::<f64>::zeros(m, m);
        let rhs = elimination.reduced_system(problem, system, |i, j, v| r[(i, j)] += v);
        let mut x = Mat::from_fn(m, 1, |i, _| rhs[i]);
        r.partial_piv_lu().solve_in_place(&mut x);
        (0..m).map(|i| x[(i, 0)]).collect::<Vec<f64>>()
    } else {
        let mut rows = RowAssembly::new(m, problem.nnz());
        let rhs = elimination.reduced_system(problem, system, |i, j, v| rows.add(i, j, v));
        let rt = rows.transpose();
        if m <= simplicial_up_to {
            sparse_reduced_solve(problem, elimination, rt, &rhs, cache)
        } else {
            let mut entries = Vec::with_capacity(rt.val().len());
            for r in 0..m {
                for (c, &v) in rt.row_idx_of_col(r).zip(rt.val_of_col(r)) {
                    entries.push((r, c, EntryKind::Fixed(v)));
                }
            }
            match SparseJacobian::factor_pattern(entries, m, cache.symbolic.take(), max_entries) {
                Ok(mut j) => {
                    j.numeric = std::mem::take(&mut cache.numeric);
                    let x = factor_and_solve(&mut j, &rhs);
                    cache.symbolic = Some(j.pattern);
                    cache.numeric = j.numeric;
                    x
                }
                Err(PatternRefusal::TooMuchFill(reason)) => return Err(reason),
                Err(PatternRefusal::Failed(_)) => vec![f64::NAN; m],
            }
        }
    };
    Ok(elimination.expand(&x))
}

/// A sparse matrix `R` assembled row by row into the compressed columns of `Rᵀ`: the entries of
/// a row arrive together and rows in increasing order, as [`Elimination::reduced_system`] gives
/// them, so no sort of the entries is needed; duplicated positions add up.
pub(crate) struct RowAssembly {
    pub(crate) size: usize,
    /// Start of each row begun so far (the column pointers of `Rᵀ`).
    pub(crate) start: Vec<usize>,
    pub(crate) col: Vec<usize>,
    pub(crate) val: Vec<f64>,
    /// Per column, where its entry of the current row is (an older position: none yet).
    pub(crate) slot: Vec<usize>,
}

impl RowAssembly {
    pub(crate) fn new(size: usize, capacity: usize) -> Self {
        let mut start = Vec::with_capacity(size + 1);
        start.push(0);
        Self {
            size,
            start,
            col: Vec::with_capacity(capacity),
            val: Vec::with_capacity(capacity),
            slot: vec![usize::MAX; size],
        }
    }

    pub(crate) fn add(&mut self, r: usize, c: usize, v: f64) {
        while self.start.len() <= r {
            self.start.push(self.col.len());
        }
        let s = self.slot[c];
        if s != usize::MAX && s >= self.start[r] {
            self.val[s] += v;
        } else {
            self.slot[c] = self.col.len();
            self.col.push(c);
            self.val.push(v);
        }
    }

    /// `Rᵀ`, each column's row indices sorted.
    pub(crate) fn transpose(mut self) -> SparseColMat<usize, f64> {
        while self.start.len() <= self.size {
            self.start.push(self.col.len());
        }
        let mut pairs = Vec::new();
        for r in 0..self.size {
            let (a, b) = (self.start[r], self.start[r + 1]);
            pairs.clear();
            pairs.extend((a..b).map(|k| (self.col[k], self.val[k])));
            pairs.sort_unstable_by_key(|&(c, _)| c);
            for (k, &(c, v)) in (a..b).zip(&pairs) {
                self.col[k] = c;
                self.val[k] = v;
            }
        }
        let symbolic =
            SymbolicSparseColMat::new_checked(self.size, self.size, self.start, None, self.col);
        SparseColMat::new(symbolic, self.val)
    }
}

/// The solution of the reduced system `R x = rhs`, given `Rᵀ`, by the sparse LU of `Rᵀ`
/// ([`SparseLu`]: left-looking, threshold partial pivoting, no symbolic analysis) and a
/// transposed solve. The column order is the island's fill-reducing ordering ([`island_rank`],
/// computed once per island solve) restricted to the kept rows, so an iteration does no
/// ordering or symbolic analysis of its own; the kept rows change at almost every iteration
/// where contacts separate and slide, so an ordering per iteration would be the largest
/// single cost of such a solve (COLAMD takes 17 % of it on FCLIB spheres-in-a-box), and a
/// left-looking LU without symbolic analysis beats faer's supernodal and simplicial LUs on
/// systems of this size. `NaN` when the factorisation fails.
pub(crate) fn sparse_reduced_solve(
    problem: &Problem,
    elimination: &Elimination,
    rt: SparseColMat<usize, f64>,
    rhs: &[f64],
    cache: &mut ReducedCache,
) -> Vec<f64> {
    let m = rhs.len();
    if cache.rank.len() != problem.n() {
        cache.rank = island_rank(problem);
    }
    let mut fwd: Vec<usize> = (0..m).collect();
    fwd.sort_unstable_by_key(|&p| cache.rank[elimination.kept[p]]);
    let (symbolic, val) = (rt.symbolic(), rt.val());
    if cache
        .lu
        .factorize(symbolic.col_ptr(), symbolic.row_idx(), val, &fwd)
        .is_err()
    {
        return vec![f64::NAN; m];
    }
    let mut x = rhs.to_vec();
    cache.lu.solve_transpose(&mut x);
    x
}

/// A fill-reducing ordering of an island, as each row's rank: approximate minimum degree
/// (faer's AMD) on the pattern of `A` and the friction coupling (symmetrised). The identity
/// when AMD fails (any order gives the same direction, only with more fill).
pub(crate) fn island_rank(problem: &Problem) -> Vec<usize> {
    let n = problem.n();
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(problem.nnz() + n);
    col_ptr.push(0);
    let mut col = Vec::new();
    for i in 0..n {
        col.clear();
        col.extend(problem.row(i).iter().map(|(j, _)| j));
        col.push(i);
        if let Some((k, _)) = problem.friction_of(i) {
            col.push(k);
        }
        col.sort_unstable();
        col.dedup();
        row_idx.extend_from_slice(&col);
        col_ptr.push(row_idx.len());
    }
    let nnz = row_idx.len();
    let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    let mut fwd = vec![0usize; n];
    let mut inv = vec![0usize; n];
    let Ok(mut mem) = MemBuffer::try_new(amd::order_scratch::<usize>(n, nnz)) else {
        return (0..n).collect();
    };
    match amd::order(
        &mut fwd,
        &mut inv,
        pattern.as_ref(),
        Default::default(),
        MemStack::new(&mut mem),
    ) {
        Ok(_) => inv,
        Err(_) => (0..n).collect(),
    }
}

/// The Newton systems of an island solved matrix-free ([`crate::LinearSystem::Krylov`]):
/// `(H + μI) x = (α + μ) ∘ x + β ∘ (A x) + γ ∘ x_k` (`x_k` the normal of each friction row), with
/// `A x = J (M⁻¹ (Jᵀ x))` through the problem's [`DelassusFactors`] when it carries them (no
/// `A` formed for the product), else through its stored rows; right-preconditioned GMRES with
/// the inverses of the diagonal blocks of `H + μI` per contact (a normal row and its friction
/// rows; 1×1 for every other row), and the relative tolerance of the Eisenstat–Walker forcing
/// sequence.
pub(crate) struct KrylovSystem {
    preconditioner: BlockJacobi,
    /// `A_ij` of each block, in the preconditioner's layout (constant over a solve).
    a_block: Vec<f64>,
    forcing: Forcing,
    params: GmresParams,
    ax: Vec<f64>,
}

impl KrylovSystem {
    /// The groups of `problem`'s rows and their blocks of `A`; `restart`, `max_iterations` and
    /// the largest forcing term `eta_max` from the solver's settings.
    pub(crate) fn new(
        problem: &Problem,
        restart: usize,
        max_iterations: usize,
        eta_max: f64,
    ) -> Self {
        let n = problem.n();
        let mut friction_rows: Vec<Vec<usize>> = vec![Vec::new(); n];
        for i in 0..n {
            if let Some((k, _)) = problem.friction_of(i) {
                friction_rows[k].push(i);
            }
        }
        let mut rows = Vec::with_capacity(n);
        let mut ptr = vec![0];
        for (i, hanging) in friction_rows.iter().enumerate() {
            if problem.friction_of(i).is_some() {
                continue;
            }
            rows.push(i);
            rows.extend_from_slice(hanging);
            ptr.push(rows.len());
        }
        let mut preconditioner = BlockJacobi::new(rows, ptr);
        let mut a_block = vec![0.0; preconditioner.len()];
        preconditioner.update(|k, i, j| {
            a_block[k] = problem.entry(i, j);
            f64::from(i == j)
        });
        Self {
            preconditioner,
            a_block,
            forcing: Forcing::new(eta_max, KRYLOV_ETA_MIN),
            params: GmresParams {
                restart,
                max_iterations,
                tolerance: eta_max,
            },
            ax: vec![0.0; n],
        }
    }

    /// The inexact Newton direction of `system`: GMRES on `(H + μI) d = −Φ` to the relative
    /// tolerance of the next forcing term, `stop` asked between Krylov iterations.
    pub(crate) fn direction(
        &mut self,
        problem: &Problem,
        system: &System<'_>,
        stop: impl FnMut() -> bool,
    ) -> KrylovResult {
        let &System {
            alpha,
            beta,
            gamma,
            phi,
            mu_reg,
        } = system;
        let phi_norm = phi.iter().map(|v| v * v).sum::<f64>().sqrt();
        self.params.tolerance = self.forcing.next(phi_norm);
        let coupling = |i: usize| {
            if gamma[i] != 0.0 {
                problem.friction_of(i).map(|(k, _)| (k, gamma[i]))
            } else {
                None
            }
        };
        let a_block = &self.a_block;
        self.preconditioner.update(|k, i, j| {
            let mut h = beta[i] * a_block[k];
            if i == j {
                h += alpha[i] + mu_reg;
            }
            if coupling(i).is_some_and(|(c, _)| c == j) {
                h += gamma[i];
            }
            h
        });
        let ax = &mut self.ax;
        let apply = |x: &[f64], out: &mut [f64]| {
            delassus_product(problem, x, ax);
            for i in 0..x.len() {
                let mut h = (alpha[i] + mu_reg) * x[i] + beta[i] * ax[i];
                if let Some((k, g)) = coupling(i) {
                    h += g * x[k];
                }
                out[i] = h;
            }
        };
        let rhs: Vec<f64> = phi.iter().map(|v| -v).collect();
        let preconditioner = &self.preconditioner;
        gmres(
            apply,
            |x, out| preconditioner.apply(x, out),
            &rhs,
            &self.params,
            stop,
        )
    }
}

/// The smallest forcing term of [`KrylovSystem`]: near working precision relative to `‖Φ‖`, so
/// the last Newton steps are as accurate as a factorisation's without asking GMRES for digits it
/// cannot give.
pub(crate) const KRYLOV_ETA_MIN: f64 = 1e-11;

/// `out = A x`: through the factors `J M⁻¹ Jᵀ` when the problem carries them, else through its
/// stored rows.
pub(crate) fn delassus_product(problem: &Problem, x: &[f64], out: &mut [f64]) {
    match problem.factors() {
        Some(factors) => {
            let u = factors.body_velocity(x);
            for (i, o) in out.iter_mut().enumerate() {
                *o = factors.row_dot(i, &u);
            }
        }
        None => {
            for (i, o) in out.iter_mut().enumerate() {
                *o = problem.row(i).dot(x);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The symbolic LU of the pattern made of `pairs` and its estimate.
    fn estimate(size: usize, pairs: &[(usize, usize)]) -> usize {
        let pairs: Vec<Pair<usize, usize>> =
            pairs.iter().map(|&(row, col)| Pair { row, col }).collect();
        let (symbolic, _) = SymbolicSparseColMat::try_new_from_indices(size, size, &pairs).unwrap();
        let lu = factorize_symbolic_lu(symbolic.as_ref(), Default::default()).unwrap();
        lu_entries_estimate(symbolic.as_ref(), lu.col_perm())
    }

    /// A diagonal pattern factors without fill (`n` entries); a full one into a full `L` and
    /// `U` (`n²` entries with the diagonal counted once). An arrow (full last row and column)
    /// is the bound's worst case: its dense row makes `AᵀA` full, so the estimate is `n²`
    /// where elimination without pivoting in the arrow's order needs `3n − 2` (partial
    /// pivoting may move the dense row up, and faer's supernodal LU plans for that).
    #[test]
    fn lu_estimate_is_exact_for_diagonal_full_and_arrow_patterns() {
        let n = 9;
        let diagonal: Vec<_> = (0..n).map(|i| (i, i)).collect();
        assert_eq!(estimate(n, &diagonal), n);
        let full: Vec<_> = (0..n).flat_map(|i| (0..n).map(move |j| (i, j))).collect();
        assert_eq!(estimate(n, &full), n * n);
        let mut arrow = diagonal.clone();
        arrow.extend((0..n - 1).flat_map(|i| [(i, n - 1), (n - 1, i)]));
        assert_eq!(estimate(n, &arrow), n * n);
    }

    /// A pattern whose estimate is above the cap is refused before any numerical work, with
    /// the estimate and the cap in the reason; at the estimate itself it is factorised.
    #[test]
    fn a_pattern_above_the_entry_cap_is_refused() {
        let n = 40;
        let entries: Vec<_> = (0..n)
            .flat_map(|i| {
                (0..n).map(move |j| (i, j, EntryKind::Fixed(if i == j { 4.0 } else { 0.01 })))
            })
            .collect();
        match SparseJacobian::factor_pattern(entries.clone(), n, None, n * n - 1) {
            Err(PatternRefusal::TooMuchFill(reason)) => {
                assert!(reason.contains("about 1600 entries"), "{reason}");
                assert!(reason.contains("max_factor_entries = 1599"), "{reason}");
            }
            Err(other) => panic!("{other:?}"),
            Ok(_) => panic!("factorised above the cap"),
        }
        let mut j = SparseJacobian::factor_pattern(entries, n, None, n * n).unwrap();
        let x = factor_and_solve(&mut j, &vec![1.0; n]);
        // Every row sums to 4 + 0.39: x = 1 / 4.39 throughout.
        assert!(x.iter().all(|v| (v - 1.0 / 4.39).abs() < 1e-12), "{x:?}");
    }
}

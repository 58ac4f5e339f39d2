//! Problem classes: the standard LCP and the boxed (mixed) LCP with friction rows.
//!
//! Every problem is stated as
//!
//! ```text
//! w = A f + b,   lo_i <= f_i <= hi_i,
//! f_i = lo_i  =>  w_i >= 0,   f_i = hi_i  =>  w_i <= 0,   lo_i < f_i < hi_i  =>  w_i = 0,
//! ```
//!
//! where `A` is the Delassus matrix of the contact problem. The standard LCP
//! (`0 <= f ⟂ w >= 0`) is the case `lo = 0`, `hi = +∞`. A *friction row* `i` names a
//! normal row `k` and a coefficient `mu`; its bounds are `[-mu f_k, mu f_k]`, evaluated at the
//! current `f` (ODE's and Bullet's `findex`). Its stored `lo`/`hi` are ignored.

pub use crate::delassus::DelassusFactors;
mod compressed;
mod islands;
mod scaling;

use faer::sparse::{SparseColMat, SparseRowMat, Triplet};
use faer::Mat;
use std::sync::{Arc, OnceLock};
use thiserror::Error;

/// A friction row: row `row` is bounded by `±mu · f[normal]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionRow {
    /// The friction (tangential) row.
    pub row: usize,
    /// The normal row whose impulse scales the bounds.
    pub normal: usize,
    /// Coulomb friction coefficient, `>= 0`.
    pub mu: f64,
}

/// Invalid problem data. Solver outcomes (no solution, non-convergence) are not errors; see
/// [`crate::Status`].
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ProblemError {
    /// `A` is not square.
    #[error("A must be square, but it is {rows}×{cols}")]
    NotSquare {
        /// Rows of `A`.
        rows: usize,
        /// Columns of `A`.
        cols: usize,
    },
    /// A vector has the wrong length.
    #[error("{what} has length {found}, but A is {expected}×{expected}")]
    DimensionMismatch {
        /// Which vector (`b`, `lo`, `hi`, ...).
        what: &'static str,
        /// Size of `A`.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// A NaN or infinite entry where a finite number is required.
    #[error("{what} is not finite ({value})")]
    NonFinite {
        /// Where, e.g. `A[3][4]` or `b[2]`.
        what: String,
        /// The offending value.
        value: f64,
    },
    /// `lo_i > hi_i`, or a bound is NaN, or `lo_i = +∞` / `hi_i = -∞`.
    #[error("row {row}: bounds [{lo}, {hi}] are empty or invalid")]
    InvalidBounds {
        /// Row index.
        row: usize,
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
    /// A friction row that names a row outside the problem.
    #[error("friction entry {entry}: row {row} or normal row {normal} is out of range (n = {n})")]
    FrictionOutOfRange {
        /// Index of the entry in the friction list.
        entry: usize,
        /// Friction row.
        row: usize,
        /// Normal row.
        normal: usize,
        /// Problem size.
        n: usize,
    },
    /// A friction row that names itself as its normal row.
    #[error("friction entry {entry}: row {row} names itself as its normal row")]
    FrictionSelf {
        /// Index of the entry in the friction list.
        entry: usize,
        /// Row index.
        row: usize,
    },
    /// A friction row whose normal row is itself a friction row.
    #[error("friction entry {entry}: normal row {normal} of row {row} is itself a friction row")]
    FrictionChain {
        /// Index of the entry in the friction list.
        entry: usize,
        /// Friction row.
        row: usize,
        /// Normal row.
        normal: usize,
    },
    /// A row listed twice as a friction row.
    #[error("friction entry {entry}: row {row} is listed as a friction row more than once")]
    FrictionDuplicate {
        /// Index of the entry in the friction list.
        entry: usize,
        /// Row index.
        row: usize,
    },
    /// A sparse row whose column indices are not strictly increasing.
    #[error("sparse row {row}: column indices must be strictly increasing")]
    UnsortedSparseRow {
        /// Row index.
        row: usize,
    },
    /// Compressed sparse parts (scipy's `indptr`, `indices`, `data`) that do not describe a
    /// square matrix: wrong lengths, offsets that do not start at 0, decrease or overrun the
    /// stored entries, an index that is negative or outside the matrix
    /// ([`Problem::boxed_csr`]).
    #[error("{message}")]
    InvalidCompressed {
        /// The part at fault: `indptr` or `indices`.
        field: &'static str,
        /// What is wrong, naming the part, the entry and the limit.
        message: String,
    },
    /// A sparse triplet outside the matrix.
    #[error("triplet {entry}: ({row}, {col}) is outside the {n}×{n} matrix")]
    TripletOutOfRange {
        /// Index of the triplet.
        entry: usize,
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// Matrix size.
        n: usize,
    },
    /// A dense form was asked of a problem above the stated size limit.
    #[error("{n} rows exceed the dense limit of {limit} rows (a dense A would need {} MB)", (*n as f64).powi(2) * 8.0 / 1e6)]
    TooLarge {
        /// Rows.
        n: usize,
        /// The limit.
        limit: usize,
    },
    /// A negative or non-finite friction coefficient.
    #[error("friction entry {entry}: mu = {mu} must be finite and >= 0")]
    FrictionCoefficient {
        /// Index of the entry in the friction list.
        entry: usize,
        /// The coefficient.
        mu: f64,
    },
}

/// How `A` is stored. Dense storage keeps a row-major copy for row dot products; sparse storage
/// is faer's compressed sparse row form (column indices sorted within each row, no duplicates).
/// Factored storage keeps `A = J M⁻¹ Jᵀ` as its factors: the shared residual and products with
/// `A` go through them, and the compressed rows are assembled from them on the first call that
/// needs a row of `A` (and kept).
#[derive(Debug, Clone)]
enum Storage {
    Dense {
        a: Mat<f64>,
        rows: Vec<f64>,
    },
    Sparse(SparseRowMat<usize, f64>),
    Factored {
        factors: Arc<DelassusFactors>,
        assembled: OnceLock<SparseRowMat<usize, f64>>,
        nnz: OnceLock<usize>,
    },
}

/// One row of `A`: a dense slice, or the column indices and values of its nonzeros.
#[derive(Debug, Clone, Copy)]
pub enum Row<'a> {
    /// All `n` entries.
    Dense(&'a [f64]),
    /// The nonzeros: `values[k]` sits in column `cols[k]`, columns increasing.
    Sparse {
        /// Column indices, increasing.
        cols: &'a [usize],
        /// Values.
        values: &'a [f64],
    },
}

impl<'a> Row<'a> {
    /// `A_i · x`.
    #[inline]
    pub fn dot(&self, x: &[f64]) -> f64 {
        match *self {
            Row::Dense(row) => dot(row, x),
            // The sum of `dot_and_magnitude`, term for term (a fold from `+0.0`).
            Row::Sparse { cols, values } => {
                cols.iter().zip(values).fold(0.0, |s, (&j, v)| s + v * x[j])
            }
        }
    }

    /// `(A_i · x, Σ_j |A_ij x_j|)` in one pass: the row's velocity term and the magnitude of the
    /// terms that make it up (the per-row scale of the relative residual).
    #[inline]
    pub fn dot_and_magnitude(&self, x: &[f64]) -> (f64, f64) {
        let (mut s, mut m) = (0.0, 0.0);
        match *self {
            Row::Dense(row) => return dot_and_magnitude(row, x, true),
            Row::Sparse { cols, values } => {
                for (&j, a) in cols.iter().zip(values) {
                    let t = a * x[j];
                    s += t;
                    m += t.abs();
                }
            }
        }
        (s, m)
    }

    /// The stored entries as `(column, value)`; a dense row yields every column, zeros included.
    pub fn iter(&self) -> impl Iterator<Item = (usize, f64)> + 'a {
        let (dense, cols, values): (&'a [f64], &'a [usize], &'a [f64]) = match *self {
            Row::Dense(row) => (row, &[], &[]),
            Row::Sparse { cols, values } => (&[], cols, values),
        };
        dense
            .iter()
            .copied()
            .enumerate()
            .chain(cols.iter().copied().zip(values.iter().copied()))
    }

    /// Number of stored entries.
    pub fn len(&self) -> usize {
        match *self {
            Row::Dense(row) => row.len(),
            Row::Sparse { cols, .. } => cols.len(),
        }
    }

    /// True when the row stores no entry.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A validated LCP or boxed LCP. Construct with [`Problem::lcp`] or [`Problem::boxed`] (dense
/// `A`) or [`Problem::lcp_sparse`] / [`Problem::boxed_sparse`] (sparse `A`), or from scipy's
/// compressed parts with [`Problem::boxed_csr`] / [`Problem::boxed_csc`]. Every solver accepts
/// both forms; see [`Problem::row`] for row access and [`Problem::islands`] for the independent
/// sub-problems.
#[derive(Debug, Clone)]
pub struct Problem {
    name: Option<String>,
    storage: Storage,
    /// `A_ii`.
    diag: Vec<f64>,
    max_abs: f64,
    b: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    friction: Vec<FrictionRow>,
    /// Per row: `Some((normal, mu))` for a friction row.
    friction_of: Vec<Option<(usize, f64)>>,
    factors: Option<Arc<DelassusFactors>>,
    /// [`Problem::islands`], computed on first use (a problem is immutable, so a solver called
    /// again on it, or the residual's data scales after a solve, reuse the partition).
    islands: OnceLock<Vec<Vec<usize>>>,
}

/// Below this many rows, [`Problem::restrict`] stores a sub-problem densely.
const DENSE_SUBPROBLEM_ROWS: usize = 48;

impl Problem {
    /// A standard LCP `0 <= f ⟂ A f + b >= 0`.
    pub fn lcp(a: Mat<f64>, b: Vec<f64>) -> Result<Self, ProblemError> {
        let n = b.len();
        Self::boxed(a, b, vec![0.0; n], vec![f64::INFINITY; n], Vec::new())
    }

    /// A boxed LCP with bounds `lo <= f <= hi` (infinite bounds allowed) and friction rows.
    pub fn boxed(
        a: Mat<f64>,
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        friction: Vec<FrictionRow>,
    ) -> Result<Self, ProblemError> {
        let (rows, cols) = (a.nrows(), a.ncols());
        if rows != cols {
            return Err(ProblemError::NotSquare { rows, cols });
        }
        let n = rows;
        let mut row_major = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                let v = a[(i, j)];
                if !v.is_finite() {
                    return Err(ProblemError::NonFinite {
                        what: format!("A[{i}][{j}]"),
                        value: v,
                    });
                }
                row_major[i * n + j] = v;
            }
        }
        let diag = (0..n).map(|i| row_major[i * n + i]).collect();
        let max_abs = row_major.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
        let storage = Storage::Dense { a, rows: row_major };
        Self::assemble(storage, diag, max_abs, b, lo, hi, friction)
    }

    /// A standard LCP with sparse `A`.
    pub fn lcp_sparse(a: SparseRowMat<usize, f64>, b: Vec<f64>) -> Result<Self, ProblemError> {
        let n = b.len();
        Self::boxed_sparse(a, b, vec![0.0; n], vec![f64::INFINITY; n], Vec::new())
    }

    /// A boxed LCP with sparse `A` (faer's compressed sparse rows, column indices strictly
    /// increasing in each row; build one from triplets with [`sparse_from_triplets`], or take
    /// scipy's compressed parts with [`Problem::boxed_csr`] / [`Problem::boxed_csc`]). Checked
    /// in one pass over the stored entries, which also reads off the diagonal and `max |A_ij|`.
    pub fn boxed_sparse(
        a: SparseRowMat<usize, f64>,
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        friction: Vec<FrictionRow>,
    ) -> Result<Self, ProblemError> {
        let (rows, cols) = (a.nrows(), a.ncols());
        if rows != cols {
            return Err(ProblemError::NotSquare { rows, cols });
        }
        // One pass over the stored entries, row by row: the column order, the finiteness, the
        // largest magnitude and the diagonal together (`compressed::row_summary`).
        let mut diag = vec![0.0; rows];
        let mut largest = 0u64;
        {
            let sym = a.symbolic();
            let (ptr, idx, val) = (sym.row_ptr(), sym.col_idx(), a.val());
            for (i, d) in diag.iter_mut().enumerate() {
                let (cols, vals) = (&idx[ptr[i]..ptr[i + 1]], &val[ptr[i]..ptr[i + 1]]);
                if !compressed::strictly_increasing(cols) {
                    return Err(ProblemError::UnsortedSparseRow { row: i });
                }
                let (bits, diagonal) = compressed::row_summary(i, cols, vals).map_err(|k| {
                    ProblemError::NonFinite {
                        what: format!("A[{i}][{}]", cols[k]),
                        value: vals[k],
                    }
                })?;
                largest = largest.max(bits);
                *d = diagonal;
            }
        }
        let max_abs = f64::from_bits(largest);
        Self::assemble(Storage::Sparse(a), diag, max_abs, b, lo, hi, friction)
    }

    /// A boxed LCP whose `A = J M⁻¹ Jᵀ` is held as its factors (the inverse-mass blocks
    /// symmetric positive semidefinite, as inverse masses are), not assembled: products with
    /// `A`, its diagonal and the shared residual are computed from `J` and `M⁻¹`
    /// ([`crate::delassus`]), and the compressed rows of `A` are assembled from the same entries
    /// on the first call that needs a row ([`Problem::row`], [`Problem::to_sparse`], …), so a
    /// solver that sweeps on the factors ([`crate::ProjectedSor`]) never pays for them. Every
    /// number the problem gives equals, bit for bit, that of the problem with the assembled `A`,
    /// except the shared residual's row sums, which the factored form adds in its own order
    /// ([`DelassusFactors::row_terms`]): equal to round-off.
    /// The largest entry is taken as the largest diagonal entry, which bounds every entry of a
    /// positive semidefinite matrix (`|A_ij| <= √(A_ii A_jj)`). Errors as
    /// [`Problem::boxed_sparse`]; a non-finite entry of `J` or `M⁻¹`, or a diagonal entry of `A`
    /// that overflows, is [`ProblemError::NonFinite`] naming it.
    pub fn boxed_factored(
        factors: DelassusFactors,
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        friction: Vec<FrictionRow>,
    ) -> Result<Self, ProblemError> {
        for i in 0..factors.rows() {
            for blk in factors.row_blocks(i) {
                if let Some(c) = blk.j.iter().position(|v| !v.is_finite()) {
                    return Err(ProblemError::NonFinite {
                        what: format!("J[{i}][{}]", 6 * blk.body + c),
                        value: blk.j[c],
                    });
                }
            }
        }
        for (body, block) in factors.inverse_mass().iter().enumerate() {
            if let Some(&v) = block.iter().flatten().find(|v| !v.is_finite()) {
                return Err(ProblemError::NonFinite {
                    what: format!("the inverse-mass block of body {body}"),
                    value: v,
                });
            }
        }
        let n = factors.rows();
        let diag: Vec<f64> = (0..n).map(|i| factors.diagonal(i)).collect();
        if let Some(i) = diag.iter().position(|v| !v.is_finite()) {
            return Err(ProblemError::NonFinite {
                what: format!("A[{i}][{i}]"),
                value: diag[i],
            });
        }
        let max_abs = diag.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
        let factors = Arc::new(factors);
        let storage = Storage::Factored {
            factors: Arc::clone(&factors),
            assembled: OnceLock::new(),
            nnz: OnceLock::new(),
        };
        let mut p = Self::assemble(storage, diag, max_abs, b, lo, hi, friction)?;
        p.factors = Some(factors);
        Ok(p)
    }

    /// The compressed rows of a sparse or factored `A` (assembled from the factors on first
    /// use), `None` for a dense one.
    fn sparse_rows(&self) -> Option<&SparseRowMat<usize, f64>> {
        match &self.storage {
            Storage::Dense { .. } => None,
            Storage::Sparse(a) => Some(a),
            Storage::Factored {
                factors, assembled, ..
            } => Some(assembled.get_or_init(|| factors.assemble())),
        }
    }

    /// The factors of a factored `A` whose rows have not been assembled: the form in which
    /// products and residuals go through `J` and `M⁻¹`.
    pub(crate) fn unassembled_factors(&self) -> Option<&DelassusFactors> {
        match &self.storage {
            Storage::Factored {
                factors, assembled, ..
            } if assembled.get().is_none() => Some(factors),
            _ => None,
        }
    }

    /// True when `A` is held as its factors ([`Problem::boxed_factored`]).
    pub fn is_factored(&self) -> bool {
        matches!(self.storage, Storage::Factored { .. })
    }

    /// True when the rows of `A` are stored: always for a dense or sparse `A`, for a factored
    /// one once a call has needed them.
    pub fn is_assembled(&self) -> bool {
        self.unassembled_factors().is_none()
    }

    /// Validation shared by the dense and sparse constructors (`A` itself is already checked).
    fn assemble(
        storage: Storage,
        diag: Vec<f64>,
        max_abs: f64,
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        mut friction: Vec<FrictionRow>,
    ) -> Result<Self, ProblemError> {
        let n = diag.len();
        for (what, len) in [("b", b.len()), ("lo", lo.len()), ("hi", hi.len())] {
            if len != n {
                return Err(ProblemError::DimensionMismatch {
                    what,
                    expected: n,
                    found: len,
                });
            }
        }
        if let Some(i) = b.iter().position(|v| !v.is_finite()) {
            return Err(ProblemError::NonFinite {
                what: format!("b[{i}]"),
                value: b[i],
            });
        }
        let friction_of = validate_friction(&friction, n)?;
        for i in 0..n {
            if friction_of[i].is_some() {
                continue;
            }
            let (l, h) = (lo[i], hi[i]);
            if l.is_nan() || h.is_nan() || l > h || l == f64::INFINITY || h == f64::NEG_INFINITY {
                return Err(ProblemError::InvalidBounds {
                    row: i,
                    lo: l,
                    hi: h,
                });
            }
        }
        if !friction.is_sorted_by_key(|fr| fr.row) {
            friction.sort_by_key(|fr| fr.row);
        }
        Ok(Self {
            name: None,
            storage,
            diag,
            max_abs,
            b,
            lo,
            hi,
            friction,
            friction_of,
            factors: None,
            islands: OnceLock::new(),
        })
    }

    /// Attach a name (carried into reports).
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = Some(name.into());
        self
    }

    /// Attach the factors `A = J M⁻¹ Jᵀ` for solvers that work matrix-free. They must describe
    /// the same `A` (the builder guarantees it; the dimensions are checked here). A factored
    /// problem ([`Problem::boxed_factored`]) has them already and is returned unchanged.
    pub fn with_factors(mut self, factors: DelassusFactors) -> Result<Self, ProblemError> {
        if self.is_factored() {
            return Ok(self);
        }
        if factors.rows() != self.n() {
            return Err(ProblemError::DimensionMismatch {
                what: "the Jacobian's rows",
                expected: self.n(),
                found: factors.rows(),
            });
        }
        self.factors = Some(Arc::new(factors));
        // The islands of a problem with factors are taken over its bodies.
        self.islands = OnceLock::new();
        Ok(self)
    }

    /// The factors `J`, `M⁻¹` of `A`, when the problem came from a contact scene.
    pub fn factors(&self) -> Option<&DelassusFactors> {
        self.factors.as_deref()
    }

    /// The problem's name, if any.
    pub fn name(&self) -> Option<&str> {
        self.name.as_deref()
    }

    /// Number of rows (unknowns).
    #[inline]
    pub fn n(&self) -> usize {
        self.b.len()
    }

    /// True when `A` is stored sparse or held as its factors (not dense).
    pub fn is_sparse(&self) -> bool {
        !matches!(self.storage, Storage::Dense { .. })
    }

    /// Stored entries of `A` (`n²` when dense).
    pub fn nnz(&self) -> usize {
        match &self.storage {
            Storage::Dense { rows, .. } => rows.len(),
            Storage::Sparse(a) => a.val().len(),
            Storage::Factored {
                factors,
                assembled,
                nnz,
            } => *nnz.get_or_init(|| match assembled.get() {
                Some(a) => a.val().len(),
                None => factors.nnz(),
            }),
        }
    }

    /// Row `i` of `A` (a factored `A` is assembled on the first call).
    #[inline]
    pub fn row(&self, i: usize) -> Row<'_> {
        match (&self.storage, self.sparse_rows()) {
            (Storage::Dense { rows, .. }, _) => {
                let n = self.n();
                Row::Dense(&rows[i * n..(i + 1) * n])
            }
            (_, None) => Row::Sparse {
                cols: &[],
                values: &[],
            },
            (_, Some(a)) => {
                let sym = a.symbolic();
                let range = sym.row_ptr()[i]..sym.row_ptr()[i + 1];
                Row::Sparse {
                    cols: &sym.col_idx()[range.clone()],
                    values: &a.val()[range],
                }
            }
        }
    }

    /// `A_ij` (a binary search in the row when sparse; from the factors, without assembling,
    /// when factored and not yet assembled).
    pub fn entry(&self, i: usize, j: usize) -> f64 {
        if let Some(factors) = self.unassembled_factors() {
            let mut a = 0.0;
            factors.for_each_entry(i, |c, v| {
                if c == j {
                    a = v;
                }
            });
            return a;
        }
        match self.row(i) {
            Row::Dense(row) => row[j],
            Row::Sparse { cols, values } => cols.binary_search(&j).map_or(0.0, |k| values[k]),
        }
    }

    /// `A_ii`.
    #[inline]
    pub fn diagonal(&self, i: usize) -> f64 {
        self.diag[i]
    }

    /// The dense `A`, when it is stored dense.
    pub fn dense(&self) -> Option<&Mat<f64>> {
        match &self.storage {
            Storage::Dense { a, .. } => Some(a),
            Storage::Sparse(_) | Storage::Factored { .. } => None,
        }
    }

    /// `A` as a dense matrix (a copy; sparse storage is expanded). Check the size first with
    /// [`Problem::dense_within`] where `n` may be large.
    pub fn to_dense(&self) -> Mat<f64> {
        match (&self.storage, self.sparse_rows()) {
            (Storage::Dense { a, .. }, _) => a.clone(),
            (_, Some(a)) => a.to_dense(),
            (_, None) => Mat::zeros(self.n(), self.n()),
        }
    }

    /// `A` as a dense matrix if `n <= limit`, otherwise an error that states the limit: the
    /// guard every densifying solver uses instead of an out-of-memory abort.
    pub fn dense_within(
        &self,
        limit: usize,
    ) -> Result<std::borrow::Cow<'_, Mat<f64>>, ProblemError> {
        if self.n() > limit {
            return Err(ProblemError::TooLarge { n: self.n(), limit });
        }
        Ok(match &self.storage {
            Storage::Dense { a, .. } => std::borrow::Cow::Borrowed(a),
            _ => std::borrow::Cow::Owned(self.to_dense()),
        })
    }

    /// `A` in compressed sparse columns (faer), for sparse factorisations.
    pub fn to_csc(&self) -> SparseColMat<usize, f64> {
        let n = self.n();
        let mut triplets = Vec::with_capacity(self.nnz());
        for i in 0..n {
            for (j, v) in self.row(i).iter() {
                if v != 0.0 || i == j {
                    triplets.push(Triplet::new(i, j, v));
                }
            }
        }
        SparseColMat::try_new_from_triplets(n, n, &triplets)
            .expect("indices of a valid problem are in range")
    }

    /// `A` in compressed sparse rows: the stored matrix when sparse, the nonzeros (and the
    /// diagonal) of the dense one otherwise.
    pub fn to_sparse(&self) -> SparseRowMat<usize, f64> {
        match self.sparse_rows() {
            Some(a) => a.clone(),
            None => {
                let n = self.n();
                let mut triplets = Vec::new();
                for i in 0..n {
                    for (j, v) in self.row(i).iter() {
                        if v != 0.0 || i == j {
                            triplets.push(Triplet::new(i, j, v));
                        }
                    }
                }
                SparseRowMat::try_new_from_triplets(n, n, &triplets)
                    .expect("indices of a valid problem are in range")
            }
        }
    }

    /// The constant term `b`.
    pub fn b(&self) -> &[f64] {
        &self.b
    }

    /// Stored lower bounds (ignored on friction rows).
    pub fn lo(&self) -> &[f64] {
        &self.lo
    }

    /// Stored upper bounds (ignored on friction rows).
    pub fn hi(&self) -> &[f64] {
        &self.hi
    }

    /// Friction rows, sorted by row.
    pub fn friction(&self) -> &[FrictionRow] {
        &self.friction
    }

    /// `Some((normal, mu))` when row `i` is a friction row.
    #[inline]
    pub fn friction_of(&self, i: usize) -> Option<(usize, f64)> {
        self.friction_of[i]
    }

    /// True for a standard LCP: `lo = 0`, `hi = +∞`, no friction rows.
    pub fn is_standard(&self) -> bool {
        self.friction.is_empty()
            && self.lo.iter().all(|&l| l == 0.0)
            && self.hi.iter().all(|&h| h == f64::INFINITY)
    }

    /// True when `A` is symmetric to a relative tolerance `rel_tol` of its largest entry.
    pub fn is_symmetric(&self, rel_tol: f64) -> bool {
        let tol = rel_tol * self.max_abs.max(f64::MIN_POSITIVE);
        // Every stored entry against its mirror (a missing mirror reads 0), so an entry of a
        // sparse A without a partner counts too.
        (0..self.n()).all(|i| {
            self.row(i)
                .iter()
                .all(|(j, v)| j == i || (v - self.entry(j, i)).abs() <= tol)
        })
    }

    /// Largest absolute entry of `A` (of a factored `A`, its largest diagonal entry, which
    /// bounds the others: [`Problem::boxed_factored`]).
    pub fn max_abs_entry(&self) -> f64 {
        self.max_abs
    }

    /// Bounds of row `i` at the impulse `f`: the stored bounds, or `±mu · max(f[normal], 0)` for a
    /// friction row.
    #[inline]
    pub fn bounds_at(&self, i: usize, f: &[f64]) -> (f64, f64) {
        match self.friction_of[i] {
            Some((k, mu)) => {
                let c = mu * f[k].max(0.0);
                (-c, c)
            }
            None => (self.lo[i], self.hi[i]),
        }
    }

    /// Project `f` onto the bounds in place: rows that are not friction rows clamped to their
    /// stored `[lo, hi]`, then each friction row to `±mu · max(f_k, 0)` at the projected normal
    /// impulse `f_k`. The projection PGS applies row by row, applied to the whole vector; the
    /// iterative solvers use it for warm starts, trial points and Clarabel's answer.
    pub fn project_onto_bounds(&self, f: &mut [f64]) {
        for (i, fi) in f.iter_mut().enumerate() {
            if self.friction_of[i].is_none() {
                *fi = fi.max(self.lo[i]).min(self.hi[i]);
            }
        }
        for fr in &self.friction {
            let (lo, hi) = self.bounds_at(fr.row, f);
            f[fr.row] = f[fr.row].max(lo).min(hi);
        }
    }

    /// `w = A f + b`.
    pub fn velocity(&self, f: &[f64]) -> Vec<f64> {
        let mut w = vec![0.0; self.n()];
        self.velocity_into(f, &mut w);
        w
    }

    /// `w = A f + b` into a caller's buffer (no allocation; a factored `A` that is not
    /// assembled is applied row by row from its factors, with the same sums).
    pub fn velocity_into(&self, f: &[f64], w: &mut [f64]) {
        if let Some(factors) = self.unassembled_factors() {
            for (i, wi) in w.iter_mut().enumerate() {
                *wi = factors.row_dot_and_magnitude(i, f).0 + self.b[i];
            }
            return;
        }
        for (i, wi) in w.iter_mut().enumerate() {
            *wi = self.row(i).dot(f) + self.b[i];
        }
    }

    /// Row `i` of a dense `A` as a slice. Only for solvers that work on dense islands
    /// ([`crate::solver::solve_by_islands`] hands them dense problems).
    #[inline]
    pub(crate) fn dense_row(&self, i: usize) -> &[f64] {
        match self.row(i) {
            Row::Dense(row) => row,
            Row::Sparse { .. } => unreachable!("dense_row on a sparse problem"),
        }
    }
}

/// Check the friction list against `n` rows; returns the per-row lookup.
fn validate_friction(
    friction: &[FrictionRow],
    n: usize,
) -> Result<Vec<Option<(usize, f64)>>, ProblemError> {
    let mut friction_of = vec![None; n];
    for (entry, fr) in friction.iter().enumerate() {
        if fr.row >= n || fr.normal >= n {
            return Err(ProblemError::FrictionOutOfRange {
                entry,
                row: fr.row,
                normal: fr.normal,
                n,
            });
        }
        if fr.row == fr.normal {
            return Err(ProblemError::FrictionSelf { entry, row: fr.row });
        }
        if !(fr.mu.is_finite() && fr.mu >= 0.0) {
            return Err(ProblemError::FrictionCoefficient { entry, mu: fr.mu });
        }
        if friction_of[fr.row].is_some() {
            return Err(ProblemError::FrictionDuplicate { entry, row: fr.row });
        }
        friction_of[fr.row] = Some((fr.normal, fr.mu));
    }
    for (entry, fr) in friction.iter().enumerate() {
        if friction_of[fr.normal].is_some() {
            return Err(ProblemError::FrictionChain {
                entry,
                row: fr.row,
                normal: fr.normal,
            });
        }
    }
    Ok(friction_of)
}

/// A sparse `n × n` matrix from `(row, column, value)` triplets; duplicates are summed. Errors
/// name the first triplet out of range or not finite.
pub fn sparse_from_triplets(
    n: usize,
    triplets: &[(usize, usize, f64)],
) -> Result<SparseRowMat<usize, f64>, ProblemError> {
    for (k, &(i, j, v)) in triplets.iter().enumerate() {
        if i >= n || j >= n {
            return Err(ProblemError::TripletOutOfRange {
                entry: k,
                row: i,
                col: j,
                n,
            });
        }
        if !v.is_finite() {
            return Err(ProblemError::NonFinite {
                what: format!("A[{i}][{j}] (triplet {k})"),
                value: v,
            });
        }
    }
    let t: Vec<_> = triplets
        .iter()
        .map(|&(i, j, v)| Triplet::new(i, j, v))
        .collect();
    SparseRowMat::try_new_from_triplets(n, n, &t).map_err(|_| ProblemError::TripletOutOfRange {
        entry: 0,
        row: n,
        col: n,
        n,
    })
}

/// Dot product of two equally long slices.
#[inline]
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    dot_and_magnitude(x, y, false).0
}

/// `(x · y, Σ |x_j y_j|)` (the second only with `magnitude`), over four interleaved partial
/// sums: one running sum is a chain of dependent additions, each waiting out the adder's
/// latency, where four independent chains keep it busy (and pair up in SIMD registers).
#[inline]
fn dot_and_magnitude(x: &[f64], y: &[f64], magnitude: bool) -> (f64, f64) {
    let n = x.len().min(y.len());
    let split = n - n % 4;
    let (mut s, mut m) = ([0.0f64; 4], [0.0f64; 4]);
    for (a, b) in x[..split].chunks_exact(4).zip(y[..split].chunks_exact(4)) {
        for l in 0..4 {
            let t = a[l] * b[l];
            s[l] += t;
            if magnitude {
                m[l] += t.abs();
            }
        }
    }
    let (mut s, mut m) = ((s[0] + s[2]) + (s[1] + s[3]), (m[0] + m[2]) + (m[1] + m[3]));
    for (a, b) in x[split..n].iter().zip(&y[split..n]) {
        let t = a * b;
        s += t;
        m += t.abs();
    }
    (s, m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eye(n: usize) -> Mat<f64> {
        Mat::identity(n, n)
    }

    #[test]
    fn rejects_bad_input() {
        assert!(matches!(
            Problem::lcp(Mat::zeros(2, 3), vec![0.0; 2]),
            Err(ProblemError::NotSquare { .. })
        ));
        assert!(matches!(
            Problem::lcp(eye(2), vec![0.0; 3]),
            Err(ProblemError::DimensionMismatch { what: "b", .. })
        ));
        let mut a = eye(2);
        a[(1, 0)] = f64::NAN;
        let e = Problem::lcp(a, vec![0.0; 2]).unwrap_err();
        assert_eq!(e.to_string(), "A[1][0] is not finite (NaN)");
        // The sparse constructor names the same entry (row found from the row pointers).
        let t: Vec<Triplet<usize, usize, f64>> =
            [(0, 0, 1.0), (1, 0, f64::NAN), (1, 1, 1.0), (2, 2, 1.0)]
                .iter()
                .map(|&(i, j, v)| Triplet::new(i, j, v))
                .collect();
        let a = SparseRowMat::try_new_from_triplets(3, 3, &t).unwrap();
        let e = Problem::lcp_sparse(a, vec![0.0; 3]).unwrap_err();
        assert_eq!(e.to_string(), "A[1][0] is not finite (NaN)");
        assert!(matches!(
            Problem::lcp(eye(2), vec![f64::INFINITY, 0.0]),
            Err(ProblemError::NonFinite { .. })
        ));
        assert!(matches!(
            Problem::boxed(eye(2), vec![0.0; 2], vec![1.0, 0.0], vec![0.0, 1.0], vec![]),
            Err(ProblemError::InvalidBounds { row: 0, .. })
        ));
        let fr = |row, normal, mu| FrictionRow { row, normal, mu };
        let boxed = |f| Problem::boxed(eye(3), vec![0.0; 3], vec![0.0; 3], vec![1.0; 3], f);
        assert!(matches!(
            boxed(vec![fr(1, 1, 0.5)]),
            Err(ProblemError::FrictionSelf { .. })
        ));
        assert!(matches!(
            boxed(vec![fr(1, 3, 0.5)]),
            Err(ProblemError::FrictionOutOfRange { .. })
        ));
        assert!(matches!(
            boxed(vec![fr(1, 0, -0.5)]),
            Err(ProblemError::FrictionCoefficient { .. })
        ));
        assert!(matches!(
            boxed(vec![fr(1, 0, 0.5), fr(2, 1, 0.5)]),
            Err(ProblemError::FrictionChain { .. })
        ));
        assert!(matches!(
            boxed(vec![fr(1, 0, 0.5), fr(1, 2, 0.5)]),
            Err(ProblemError::FrictionDuplicate { .. })
        ));
        assert!(boxed(vec![fr(1, 0, 0.5), fr(2, 0, 0.5)]).is_ok());
    }

    #[test]
    fn friction_bounds_follow_the_normal_impulse() {
        let p = Problem::boxed(
            eye(2),
            vec![0.0; 2],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        assert_eq!(p.bounds_at(1, &[2.0, 0.0]), (-1.0, 1.0));
        assert_eq!(p.bounds_at(1, &[-2.0, 0.0]), (-0.0, 0.0));
        assert!(!p.is_standard());
    }

    fn two_blocks_sparse() -> Problem {
        // Rows {0, 2} and {1, 3} are coupled; a friction row 4 hangs on normal row 1.
        let t = [
            (0, 0, 2.0),
            (0, 2, 1.0),
            (2, 0, 1.0),
            (2, 2, 2.0),
            (1, 1, 3.0),
            (1, 3, -1.0),
            (3, 1, -1.0),
            (3, 3, 3.0),
            (4, 4, 1.0),
            // A duplicate, summed: A[4][4] = 1.5.
            (4, 4, 0.5),
        ];
        let a = sparse_from_triplets(5, &t).unwrap();
        Problem::boxed_sparse(
            a,
            vec![-1.0, -2.0, 0.5, -0.5, 0.1],
            vec![0.0, 0.0, 0.0, 0.0, 0.0],
            vec![f64::INFINITY; 5],
            vec![FrictionRow {
                row: 4,
                normal: 1,
                mu: 0.5,
            }],
        )
        .unwrap()
    }

    #[test]
    fn sparse_storage_row_access_and_duplicates() {
        let p = two_blocks_sparse();
        assert!(p.is_sparse());
        assert_eq!(p.nnz(), 9);
        assert_eq!(p.entry(4, 4), 1.5);
        assert_eq!(p.entry(0, 1), 0.0);
        assert_eq!(p.row(0).dot(&[1.0, 10.0, 2.0, 10.0, 10.0]), 4.0);
        assert!(p.is_symmetric(0.0));
        let d = p.to_dense();
        assert_eq!(d[(2, 0)], 1.0);
        let back = Problem::boxed(
            d,
            p.b().to_vec(),
            p.lo().to_vec(),
            p.hi().to_vec(),
            p.friction().to_vec(),
        )
        .unwrap();
        let f = [0.3, 0.2, 0.1, 0.4, -0.05];
        assert_eq!(back.velocity(&f), p.velocity(&f));
        assert!(matches!(
            sparse_from_triplets(2, &[(0, 2, 1.0)]),
            Err(ProblemError::TripletOutOfRange { .. })
        ));
    }

    #[test]
    fn islands_follow_nonzeros_and_friction_rows() {
        let p = two_blocks_sparse();
        assert_eq!(p.islands(), vec![vec![0, 2], vec![1, 3, 4]]);
        let sub = p.restrict(&[1, 3, 4]).unwrap();
        assert_eq!(sub.n(), 3);
        assert_eq!(sub.entry(0, 1), -1.0);
        assert_eq!(sub.friction_of(2), Some((0, 0.5)));
        assert_eq!(sub.b(), &[-2.0, -0.5, 0.1]);
    }

    /// The block of a block Gauss–Seidel step: the outside rows' impulses move into `b`, and a
    /// friction row whose normal stays outside gets that normal's fixed bounds.
    #[test]
    fn restrict_at_holds_the_other_rows_at_f() {
        let p = two_blocks_sparse();
        let f = [0.5, 2.0, 0.25, 0.0, 0.1];
        // Rows 0 and 4 (friction row 4 on normal 1, which stays outside).
        let sub = p.restrict_at(&[0, 4], &f).unwrap();
        assert_eq!(sub.n(), 2);
        assert!(sub.friction().is_empty());
        let mu = p.friction_of(4).unwrap().1;
        assert_eq!((sub.lo()[1], sub.hi()[1]), (-mu * 2.0, mu * 2.0));
        for (r, i) in [(0, 0), (1, 4)] {
            let outside: f64 = (0..5)
                .filter(|&j| j != 0 && j != 4)
                .map(|j| p.entry(i, j) * f[j])
                .sum();
            assert_eq!(sub.b()[r], p.b()[i] + outside);
        }
        // The velocities agree with the whole problem's at f.
        let w = p.velocity(&f);
        let ws = sub.velocity(&[f[0], f[4]]);
        assert!((ws[0] - w[0]).abs() < 1e-15 && (ws[1] - w[4]).abs() < 1e-15);
        // With its normal inside, the friction row keeps its moving bounds.
        let sub = p.restrict_at(&[1, 3, 4], &f).unwrap();
        assert_eq!(sub.friction_of(2), Some((0, mu)));
    }

    /// With factors, islands come from the bodies of `J` and match those of `A`'s nonzeros.
    #[test]
    fn islands_from_the_bodies_of_j_match_those_of_a() {
        // Rows 0 and 1 on body 0; row 2 on bodies 1 and 2; row 3 on body 2; row 4 on body 3.
        let touches: [&[usize]; 5] = [&[0], &[0], &[1, 2], &[2], &[3]];
        let triplets: Vec<Triplet<usize, usize, f64>> = touches
            .iter()
            .enumerate()
            .flat_map(|(i, bodies)| {
                bodies.iter().flat_map(move |&b| {
                    (0..6).map(move |c| Triplet::new(i, 6 * b + c, 1.0 + c as f64))
                })
            })
            .collect();
        let jac = SparseRowMat::try_new_from_triplets(5, 24, &triplets).unwrap();
        let dense_j = jac.to_dense();
        let a = &dense_j * dense_j.transpose();
        let mut identity = [[0.0; 6]; 6];
        for (k, row) in identity.iter_mut().enumerate() {
            row[k] = 1.0;
        }
        let factors = DelassusFactors::new(jac, vec![identity; 4]).unwrap();
        let plain = Problem::lcp(a.clone(), vec![-1.0; 5]).unwrap();
        let with = Problem::lcp(a, vec![-1.0; 5])
            .unwrap()
            .with_factors(factors)
            .unwrap();
        let expected = vec![vec![0, 1], vec![2, 3], vec![4]];
        assert_eq!(plain.islands(), expected);
        assert_eq!(with.islands(), expected);
    }

    #[test]
    fn symmetric_scaling_keeps_friction_meaning() {
        let p = two_blocks_sparse();
        let s = [2.0, 0.5, 4.0, 1.0, 8.0];
        let q = p.scaled_symmetric(&s);
        assert_eq!(q.entry(0, 2), 2.0 * 1.0 * 4.0);
        // Friction row 4 on normal 1: mu' = mu · s_1 / s_4.
        assert_eq!(q.friction_of(4), Some((1, 0.5 * 0.5 / 8.0)));
        // f' = S⁻¹ f has the same bounds meaning: |f'_4| <= mu' f'_1 ⇔ |f_4| <= mu f_1.
        let f = [0.0, 1.0, 0.0, 0.0, 0.5];
        let g: Vec<f64> = f.iter().zip(&s).map(|(v, si)| v / si).collect();
        assert_eq!(q.bounds_at(4, &g).1 * s[4], p.bounds_at(4, &f).1);
    }
}

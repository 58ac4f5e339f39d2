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

use faer::Mat;
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
    /// A negative or non-finite friction coefficient.
    #[error("friction entry {entry}: mu = {mu} must be finite and >= 0")]
    FrictionCoefficient {
        /// Index of the entry in the friction list.
        entry: usize,
        /// The coefficient.
        mu: f64,
    },
}

/// A validated LCP or boxed LCP. Construct with [`Problem::lcp`] or [`Problem::boxed`].
#[derive(Debug, Clone)]
pub struct Problem {
    name: Option<String>,
    a: Mat<f64>,
    /// Row-major copy of `A` for row dot products in sweeping solvers.
    a_rows: Vec<f64>,
    b: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    friction: Vec<FrictionRow>,
    /// Per row: `Some((normal, mu))` for a friction row.
    friction_of: Vec<Option<(usize, f64)>>,
}

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
        for (what, len) in [("b", b.len()), ("lo", lo.len()), ("hi", hi.len())] {
            if len != n {
                return Err(ProblemError::DimensionMismatch {
                    what,
                    expected: n,
                    found: len,
                });
            }
        }
        for j in 0..n {
            for i in 0..n {
                let v = a[(i, j)];
                if !v.is_finite() {
                    return Err(ProblemError::NonFinite {
                        what: format!("A[{i}][{j}]"),
                        value: v,
                    });
                }
            }
        }
        for (i, &v) in b.iter().enumerate() {
            if !v.is_finite() {
                return Err(ProblemError::NonFinite {
                    what: format!("b[{i}]"),
                    value: v,
                });
            }
        }
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
        let mut friction = friction;
        friction.sort_by_key(|fr| fr.row);
        let mut a_rows = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a_rows[i * n + j] = a[(i, j)];
            }
        }
        Ok(Self {
            name: None,
            a,
            a_rows,
            b,
            lo,
            hi,
            friction,
            friction_of,
        })
    }

    /// Attach a name (carried into reports).
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = Some(name.into());
        self
    }

    /// The problem's name, if any.
    pub fn name(&self) -> Option<&str> {
        self.name.as_deref()
    }

    /// Number of rows (unknowns).
    pub fn n(&self) -> usize {
        self.b.len()
    }

    /// The Delassus matrix `A`.
    pub fn a(&self) -> &Mat<f64> {
        &self.a
    }

    /// Row `i` of `A`, contiguous.
    pub fn a_row(&self, i: usize) -> &[f64] {
        let n = self.n();
        &self.a_rows[i * n..(i + 1) * n]
    }

    /// Row `i` of `A` as `(column, value)` pairs (every stored entry of the row).
    pub fn row(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.a_row(i).iter().copied().enumerate()
    }

    /// `A` as a dense matrix (a copy).
    pub fn to_dense(&self) -> Mat<f64> {
        self.a.clone()
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
        let n = self.n();
        let tol = rel_tol * self.max_abs_entry().max(f64::MIN_POSITIVE);
        (0..n).all(|i| (0..i).all(|j| (self.a[(i, j)] - self.a[(j, i)]).abs() <= tol))
    }

    /// Largest absolute entry of `A`.
    pub fn max_abs_entry(&self) -> f64 {
        self.a_rows.iter().fold(0.0, |m, v| m.max(v.abs()))
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

    /// Largest finite magnitude among the stored bounds of non-friction rows (0 if none): the
    /// impulse scale that fixed bounds impose, used by the relative residual.
    pub fn bound_scale(&self) -> f64 {
        (0..self.n())
            .filter(|&i| self.friction_of[i].is_none())
            .flat_map(|i| [self.lo[i], self.hi[i]])
            .filter(|v| v.is_finite())
            .fold(0.0, |m, v| m.max(v.abs()))
    }

    /// `w = A f + b`.
    pub fn velocity(&self, f: &[f64]) -> Vec<f64> {
        (0..self.n())
            .map(|i| dot(self.a_row(i), f) + self.b[i])
            .collect()
    }

    /// Diagonal scaling used by the relative residual and by sweeping solvers: `d_i = A_ii` when
    /// `A_ii > 1e-12 · max|A|`, otherwise `max|A|` (or 1 when `A = 0`). Never zero.
    pub fn diagonal_scale(&self) -> Vec<f64> {
        let amax = self.max_abs_entry();
        let floor = 1e-12 * amax;
        (0..self.n())
            .map(|i| {
                let d = self.a[(i, i)];
                if d > floor && d > 0.0 {
                    d
                } else if amax > 0.0 {
                    amax
                } else {
                    1.0
                }
            })
            .collect()
    }

    /// A copy with rows and columns permuted: new row `k` is old row `perm[k]`.
    pub fn permuted(&self, perm: &[usize]) -> Self {
        let n = self.n();
        assert_eq!(perm.len(), n, "permutation length");
        let mut inv = vec![0; n];
        for (k, &p) in perm.iter().enumerate() {
            inv[p] = k;
        }
        let a = Mat::from_fn(n, n, |i, j| self.a[(perm[i], perm[j])]);
        let pick = |v: &[f64]| perm.iter().map(|&p| v[p]).collect::<Vec<_>>();
        let friction = self
            .friction
            .iter()
            .map(|fr| FrictionRow {
                row: inv[fr.row],
                normal: inv[fr.normal],
                mu: fr.mu,
            })
            .collect();
        let mut p = Self::boxed(a, pick(&self.b), pick(&self.lo), pick(&self.hi), friction)
            .expect("a permutation of a valid problem is valid");
        p.name = self.name.clone();
        p
    }
}

/// Dot product of two equally long slices.
#[inline]
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
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
}

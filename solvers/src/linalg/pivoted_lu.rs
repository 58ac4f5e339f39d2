//! Dense LU with diagonal (symmetric) pivoting, `P A Pᵀ = L U`, that stops at the first pivot
//! below a relative threshold: it reveals the numerical rank of a positive semidefinite matrix
//! and a regular principal block of that size. The factorisation behind the elimination of
//! free (equality) rows ([`crate::lcp::free_rows`]).
//!
//! Each step pivots on the largest remaining diagonal entry of the Schur complement, the rule of
//! pivoted Cholesky (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., 2002,
//! §10.3): for a symmetric positive semidefinite matrix the diagonal dominates every entry of
//! its row (`|a_ij| <= √(a_ii a_jj)`), so the pivots decrease and the first one below
//! `rel_tol · u₁₁` leaves a remaining block that is zero to that tolerance. The rank is the
//! number of pivots taken, and the rows pivoted on index a regular principal block. No symmetry
//! is needed (the same rule runs on a non-symmetric matrix, which is then not guaranteed to reveal
//! its rank; a zero diagonal stops it). `O(n³)`.

/// The factorisation of a square row-major matrix (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct PivotedLu {
    n: usize,
    /// `L` (unit diagonal, not stored) below the diagonal and `U` on and above it, in pivot
    /// order, row-major; only the leading `rank × rank` block is a factorisation.
    lu: Vec<f64>,
    /// Position `k` of the pivot order is row and column `order[k]` of `A`.
    order: Vec<usize>,
    rank: usize,
    /// `|u_kk| / |u₁₁|` of the first pivot refused (0 when the remaining diagonal is 0), or the
    /// smallest of the pivots taken when none was refused.
    pivot_ratio: f64,
}

impl PivotedLu {
    /// Factorise the `n × n` row-major `a`, taking pivots while their magnitude is above
    /// `rel_tol` times the first one (a NaN pivot stops the elimination too).
    pub(crate) fn new(a: &[f64], n: usize, rel_tol: f64) -> Self {
        debug_assert_eq!(a.len(), n * n);
        let mut lu = a.to_vec();
        let mut order: Vec<usize> = (0..n).collect();
        let mut first = 0.0;
        let mut rank = 0;
        let mut pivot_ratio = 1.0_f64;
        for k in 0..n {
            let (mut p, mut big) = (k, -1.0_f64);
            for r in k..n {
                let v = lu[r * n + r].abs();
                if v > big {
                    (p, big) = (r, v);
                }
            }
            if k == 0 {
                first = big;
            }
            let ratio = if first > 0.0 { big / first } else { 0.0 };
            // `!(… > …)` and not `<=`: a NaN pivot must stop the elimination too.
            if !(big > 0.0 && ratio > rel_tol) {
                pivot_ratio = if ratio.is_nan() { 0.0 } else { ratio };
                break;
            }
            pivot_ratio = pivot_ratio.min(ratio);
            if p != k {
                for c in 0..n {
                    lu.swap(p * n + c, k * n + c);
                }
                for r in 0..n {
                    lu.swap(r * n + p, r * n + k);
                }
                order.swap(p, k);
            }
            let pivot = lu[k * n + k];
            for r in k + 1..n {
                let m = lu[r * n + k] / pivot;
                lu[r * n + k] = m;
                if m != 0.0 {
                    for c in k + 1..n {
                        lu[r * n + c] -= m * lu[k * n + c];
                    }
                }
            }
            rank += 1;
        }
        Self {
            n,
            lu,
            order,
            rank,
            pivot_ratio,
        }
    }

    /// The number of pivots taken.
    pub(crate) fn rank(&self) -> usize {
        self.rank
    }

    /// The rows (and columns) of `A` pivoted on, in pivot order: a regular principal block.
    pub(crate) fn pivot_rows(&self) -> &[usize] {
        &self.order[..self.rank]
    }

    /// `|u_kk| / |u₁₁|` of the first pivot refused, or the smallest of those taken when every
    /// pivot was: how far from singular the test found the matrix.
    pub(crate) fn pivot_ratio(&self) -> f64 {
        self.pivot_ratio
    }

    /// Solve `A_PP x_P = b_P` on the principal block `P` of the pivot rows, in place: `b` has
    /// `n` entries, those outside `P` are ignored, and `x` is zero there (for a regular `A`,
    /// `x = A⁻¹ b`).
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let (n, r) = (self.n, self.rank);
        let lu = &self.lu;
        let mut y: Vec<f64> = self.order[..r].iter().map(|&i| b[i]).collect();
        for k in 0..r {
            let yk = y[k];
            if yk != 0.0 {
                for i in k + 1..r {
                    y[i] -= lu[i * n + k] * yk;
                }
            }
        }
        for k in (0..r).rev() {
            let s: f64 = (k + 1..r).map(|c| lu[k * n + c] * y[c]).sum();
            y[k] = (y[k] - s) / lu[k * n + k];
        }
        b.iter_mut().for_each(|v| *v = 0.0);
        for (k, &i) in self.order[..r].iter().enumerate() {
            b[i] = y[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn product(a: &[f64], x: &[f64]) -> Vec<f64> {
        let n = x.len();
        (0..n)
            .map(|i| (0..n).map(|j| a[i * n + j] * x[j]).sum())
            .collect()
    }

    #[test]
    fn solves_a_regular_system() {
        // Symmetric positive definite, and a non-symmetric P-matrix.
        for a in [
            [4.0, 1.0, 2.0, 1.0, 3.0, 0.0, 2.0, 0.0, 5.0],
            [2.0, 1.0, 0.0, -1.0, 3.0, 1.0, 0.5, -2.0, 4.0],
        ] {
            let lu = PivotedLu::new(&a, 3, 1e-12);
            assert_eq!(lu.rank(), 3);
            let x = [1.0, -2.0, 0.5];
            let mut b = product(&a, &x);
            lu.solve(&mut b);
            for (u, v) in b.iter().zip(x) {
                assert!((u - v).abs() < 1e-14, "{b:?}");
            }
        }
    }

    /// A rank-2 PSD matrix (`J Jᵀ` with row 2 of `J` the sum of rows 0 and 1): the rank and a
    /// regular principal block are found, and a consistent right-hand side is solved exactly.
    #[test]
    fn finds_the_rank_of_a_semidefinite_matrix() {
        let j = [[1.0, 0.0, 2.0], [0.0, 1.0, 1.0], [1.0, 1.0, 3.0]];
        let a: Vec<f64> = (0..9)
            .map(|e| (0..3).map(|k| j[e / 3][k] * j[e % 3][k]).sum())
            .collect();
        let lu = PivotedLu::new(&a, 3, 1e-12);
        assert_eq!(lu.rank(), 2);
        assert!(lu.pivot_ratio() < 1e-12);
        // Rows 2 and 0 are the regular block (the Schur complements of rows 0 and 1 tie, and
        // the first is taken); row 1's unknown is set to 0.
        assert_eq!(lu.pivot_rows(), &[2, 0]);
        let mut b = product(&a, &[1.0, 2.0, 3.0]);
        let rhs = b.clone();
        lu.solve(&mut b);
        assert_eq!(b[1], 0.0);
        for (u, v) in product(&a, &b).iter().zip(&rhs) {
            assert!((u - v).abs() < 1e-12, "{b:?}");
        }
        // The zero matrix has rank 0, and the solution 0.
        let lu = PivotedLu::new(&[0.0; 4], 2, 1e-12);
        assert_eq!(lu.rank(), 0);
        let mut b = [1.0, 2.0];
        lu.solve(&mut b);
        assert_eq!(b, [0.0, 0.0]);
    }
}

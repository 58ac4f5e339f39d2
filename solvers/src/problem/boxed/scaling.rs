//! Diagonal scaling of a problem: the diagonal scale the residual and the sweeps use, symmetric
//! rescaling and row permutation.

use super::*;

impl Problem {
    /// Diagonal scaling used by the relative residual, by sweeping solvers and for
    /// equilibration: `d_i = A_ii` when `A_ii > 0`; otherwise the largest magnitude in row `i`
    /// (or 1 when the row is zero). Never zero. A positive diagonal is used as it is, however
    /// small, so that `d` follows every diagonal scaling of the problem.
    pub fn diagonal_scale(&self) -> Vec<f64> {
        (0..self.n()).map(|i| self.diagonal_scale_of(i)).collect()
    }

    /// Row `i`'s entry of [`Problem::diagonal_scale`].
    #[inline]
    pub fn diagonal_scale_of(&self, i: usize) -> f64 {
        let d = self.diag[i];
        if d > 0.0 {
            return d;
        }
        let row_max = match self.unassembled_factors() {
            Some(factors) => {
                let mut m = 0.0f64;
                factors.for_each_entry(i, |_, v| m = m.max(v.abs()));
                m
            }
            None => self.row(i).iter().fold(0.0f64, |m, (_, v)| m.max(v.abs())),
        };
        if row_max > 0.0 {
            row_max
        } else {
            1.0
        }
    }

    /// A copy with rows and columns permuted: new row `k` is old row `perm[k]`.
    pub fn permuted(&self, perm: &[usize]) -> Self {
        let n = self.n();
        assert_eq!(perm.len(), n, "permutation length");
        let mut inv = vec![0; n];
        for (k, &p) in perm.iter().enumerate() {
            inv[p] = k;
        }
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
        let (b, lo, hi) = (pick(&self.b), pick(&self.lo), pick(&self.hi));
        let mut p = match &self.storage {
            Storage::Dense { a, .. } => {
                let a = Mat::from_fn(n, n, |i, j| a[(perm[i], perm[j])]);
                Self::boxed(a, b, lo, hi, friction)
            }
            Storage::Sparse(_) | Storage::Factored { .. } => {
                let mut triplets = Vec::with_capacity(self.nnz());
                for (k, &p) in perm.iter().enumerate() {
                    for (j, v) in self.row(p).iter() {
                        triplets.push(Triplet::new(k, inv[j], v));
                    }
                }
                let a = SparseRowMat::try_new_from_triplets(n, n, &triplets)
                    .expect("a permutation of valid indices is valid");
                Self::boxed_sparse(a, b, lo, hi, friction)
            }
        }
        .expect("a permutation of a valid problem is valid");
        p.name = self.name.clone();
        p
    }

    /// The symmetrically scaled problem `A' = S A S`, `b' = S b` with `S = diag(s)`, `s_i > 0`,
    /// whose solutions are `f' = S⁻¹ f`: bounds become `lo_i / s_i`, `hi_i / s_i`, and a friction
    /// row `t` of normal `k` keeps its meaning with `mu' = mu · s_k / s_t`. Pivoting solvers use
    /// it with `s_i = 1/√d_i` (equilibration), so that data scaled over many decades does not
    /// decide their pivots.
    pub fn scaled_symmetric(&self, s: &[f64]) -> Self {
        let n = self.n();
        assert_eq!(s.len(), n, "scaling length");
        let b = (0..n).map(|i| s[i] * self.b[i]).collect();
        let lo = (0..n).map(|i| self.lo[i] / s[i]).collect();
        let hi = (0..n).map(|i| self.hi[i] / s[i]).collect();
        let friction = self
            .friction
            .iter()
            .map(|fr| FrictionRow {
                mu: fr.mu * s[fr.normal] / s[fr.row],
                ..*fr
            })
            .collect();
        let mut p = match &self.storage {
            Storage::Dense { a, .. } => {
                let a = Mat::from_fn(n, n, |i, j| s[i] * a[(i, j)] * s[j]);
                Self::boxed(a, b, lo, hi, friction)
            }
            Storage::Sparse(_) | Storage::Factored { .. } => {
                let mut a = self.to_sparse();
                let ptr: Vec<usize> = a.symbolic().row_ptr().to_vec();
                let idx: Vec<usize> = a.symbolic().col_idx().to_vec();
                let val = a.val_mut();
                for i in 0..n {
                    for k in ptr[i]..ptr[i + 1] {
                        val[k] *= s[i] * s[idx[k]];
                    }
                }
                Self::boxed_sparse(a, b, lo, hi, friction)
            }
        }
        .expect("a positive scaling of a valid problem is valid");
        p.name = self.name.clone();
        p
    }
}

//! The independent sub-problems of a problem (its islands) and the restriction of a problem to
//! a set of rows.

use super::*;

impl Problem {
    /// The independent sub-problems: rows grouped so that no nonzero of `A` and no friction row
    /// links two groups (union–find over the nonzeros, `O(nnz)`; over the bodies of `J`,
    /// `O(nnz(J))`, when the problem carries its factors: rows that share a body are joined,
    /// which joins every pair with `A_ij ≠ 0`). Each group's rows are increasing; groups are
    /// ordered by their first row. A dense `A` with no zero off-diagonal entries is one group.
    pub fn islands(&self) -> &[Vec<usize>] {
        self.islands.get_or_init(|| self.partition())
    }

    /// The partition of [`Problem::islands`], computed.
    fn partition(&self) -> Vec<Vec<usize>> {
        let n = self.n();
        let mut parent: Vec<usize> = (0..n).collect();
        fn find(parent: &mut [usize], mut x: usize) -> usize {
            while parent[x] != x {
                parent[x] = parent[parent[x]];
                x = parent[x];
            }
            x
        }
        let union = |parent: &mut Vec<usize>, a: usize, b: usize| {
            let (ra, rb) = (find(parent, a), find(parent, b));
            if ra != rb {
                parent[ra.max(rb)] = ra.min(rb);
            }
        };
        if let Some(factors) = self.factors() {
            // The first row seen on each body; later rows on it join that row's group.
            let mut first = vec![usize::MAX; factors.inverse_mass().len()];
            for i in 0..n {
                for body in factors.row_blocks(i).iter().map(|blk| blk.body) {
                    if first[body] == usize::MAX {
                        first[body] = i;
                    } else if first[body] != i {
                        union(&mut parent, i, first[body]);
                    }
                }
            }
        } else {
            for i in 0..n {
                for (j, v) in self.row(i).iter() {
                    if v != 0.0 && j != i {
                        union(&mut parent, i, j);
                    }
                }
            }
        }
        for i in 0..n {
            if let Some((k, _)) = self.friction_of[i] {
                union(&mut parent, i, k);
            }
        }
        let mut group_of = vec![usize::MAX; n];
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for i in 0..n {
            let r = find(&mut parent, i);
            if group_of[r] == usize::MAX {
                group_of[r] = groups.len();
                groups.push(Vec::new());
            }
            groups[group_of[r]].push(i);
        }
        groups
    }

    /// The sub-problem on `rows` (increasing, and holding the normal row of every friction row
    /// among them, as each island of [`Problem::islands`] does). Small sub-problems are stored
    /// dense, larger ones keep the storage of `self`.
    pub fn restrict(&self, rows: &[usize]) -> Result<Self, ProblemError> {
        self.restrict_holding(rows, None)
    }

    /// The sub-problem on `rows` with every other row's impulse held at `f` (the block of a
    /// block Gauss–Seidel step): `b'_r = b_i + Σ_{j ∉ rows} A_ij f_j`, and a friction row whose
    /// normal is outside `rows` gets the fixed bounds `±mu · max(f_normal, 0)`. `rows` increasing.
    pub(crate) fn restrict_at(&self, rows: &[usize], f: &[f64]) -> Result<Self, ProblemError> {
        self.restrict_holding(rows, Some(f))
    }

    /// [`Problem::restrict`], and with `held` [`Problem::restrict_at`]: the entries outside
    /// `rows` are dropped, or moved into `b` at the held impulses, in the same pass.
    fn restrict_holding(&self, rows: &[usize], held: Option<&[f64]>) -> Result<Self, ProblemError> {
        let n = self.n();
        let m = rows.len();
        let mut local = vec![usize::MAX; n];
        for (k, &i) in rows.iter().enumerate() {
            if i >= n {
                return Err(ProblemError::DimensionMismatch {
                    what: "a restricted row index",
                    expected: n,
                    found: i,
                });
            }
            local[i] = k;
        }
        let pick = |v: &[f64]| rows.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let (mut b, mut lo, mut hi) = (pick(&self.b), pick(&self.lo), pick(&self.hi));
        let mut friction = Vec::new();
        for (r, &i) in rows.iter().enumerate() {
            if let Some((k, mu)) = self.friction_of[i] {
                match held {
                    // Its normal is held: the bounds are fixed at the held normal.
                    Some(f) if local[k] == usize::MAX => (lo[r], hi[r]) = self.bounds_at(i, f),
                    _ => friction.push(FrictionRow {
                        row: r,
                        normal: local[k],
                        mu,
                    }),
                }
            }
        }
        let mut triplets = Vec::new();
        for (r, &i) in rows.iter().enumerate() {
            let mut outside = 0.0;
            for (j, v) in self.row(i).iter() {
                if local[j] != usize::MAX {
                    if v != 0.0 || i == j {
                        triplets.push(Triplet::new(r, local[j], v));
                    }
                } else if let Some(f) = held {
                    outside += v * f[j];
                }
            }
            b[r] += outside;
        }
        let mut p = if m <= DENSE_SUBPROBLEM_ROWS || !self.is_sparse() {
            let mut a = Mat::zeros(m, m);
            for t in &triplets {
                a[(t.row, t.col)] = t.val;
            }
            Self::boxed(a, b, lo, hi, friction)?
        } else {
            let a = SparseRowMat::try_new_from_triplets(m, m, &triplets)
                .map_err(|_| ProblemError::UnsortedSparseRow { row: 0 })?;
            Self::boxed_sparse(a, b, lo, hi, friction)?
        };
        p.name = self.name.clone();
        Ok(p)
    }

    /// The sub-problem on `rows` stored dense (for solvers that factorise; the caller bounds
    /// the size).
    pub(crate) fn restrict_dense(&self, rows: &[usize]) -> Result<Self, ProblemError> {
        let p = self.restrict(rows)?;
        if !p.is_sparse() {
            return Ok(p);
        }
        let mut dense = Self::boxed(
            p.to_dense(),
            p.b.clone(),
            p.lo.clone(),
            p.hi.clone(),
            p.friction.clone(),
        )?;
        dense.name = p.name;
        Ok(dense)
    }
}

//! Left-looking sparse LU with threshold partial pivoting, for the small reduced Newton systems
//! (a few hundred rows, little fill) that change their pattern at every iteration.
//!
//! Column by column, in a given column order `q`: the nonzero pattern of column `j` of `L⁻¹ M`
//! is the set of rows reachable from the column's rows in the graph of the `L` computed so far
//! (a depth-first search, which also gives the order of the sparse triangular solve), so the
//! work is proportional to the arithmetic (Gilbert and Peierls, *Sparse partial pivoting in time
//! proportional to arithmetic operations*, SIAM J. Sci. Stat. Comput. 9, 1988; the search as in
//! T. Davis, *Direct methods for sparse linear systems*, SIAM 2006, `cs_reach`/`cs_lu`). The
//! pivot of column `q[j]` is its diagonal row `q[j]` when that entry is at least
//! [`DIAGONAL_PREFERENCE`] times the largest candidate, else the largest candidate (KLU's rule:
//! T. Davis and E. Palamadai Natarajan, *Algorithm 907: KLU*, ACM TOMS 37, 2010), so a
//! symmetric fill-reducing order keeps its effect on matrices with a symmetric pattern and a
//! strong diagonal, as the Newton systems of contact problems have.
//!
//! There is no symbolic analysis, so a new pattern costs nothing beyond its arithmetic and the
//! search; the factor storage is kept between factorisations. faer's simplicial LU is the same
//! algorithm without the diagonal preference, which on the reduced Newton systems of contact
//! problems (symmetric pattern, strong diagonal) takes about twice the multiply-adds.

/// The diagonal is the pivot when its magnitude is at least this fraction of the column's
/// largest candidate. KLU's default is `0.001`, UMFPACK's `0.1`; the Newton systems near a
/// solution are regularised by a tiny `μ` and ill-conditioned, and there a stricter threshold
/// keeps the directions accurate enough for the line search (on sphere piles `0.5` leaves fewer
/// steps at the iteration limit than `0.1`, as many as pure partial pivoting) at little cost in
/// fill.
const DIAGONAL_PREFERENCE: f64 = 0.5;

const NONE: usize = usize::MAX;

/// The factorisation `P M Q = L U` of a square sparse matrix `M` (compressed columns), `L` unit
/// lower triangular, `U` upper triangular, `P` from the pivoting and `Q` the given column order.
#[derive(Debug, Clone, Default)]
pub(crate) struct SparseLu {
    n: usize,
    /// `L` by columns (pivot positions), the unit diagonal left out; row indices are rows of `M`
    /// during the factorisation and pivot positions after it.
    l_ptr: Vec<usize>,
    l_idx: Vec<usize>,
    l_val: Vec<f64>,
    /// `U` by columns, the diagonal in `diag`; row indices are pivot positions.
    u_ptr: Vec<usize>,
    u_idx: Vec<usize>,
    u_val: Vec<f64>,
    diag: Vec<f64>,
    /// Pivot position of each row of `M`.
    pinv: Vec<usize>,
    /// Column order: position `j` holds column `q[j]` of `M`.
    q: Vec<usize>,
    // Work space.
    x: Vec<f64>,
    mark: Vec<usize>,
    reach: Vec<usize>,
    stack: Vec<usize>,
    next: Vec<usize>,
}

/// The matrix is singular to working precision: the column at this position has no nonzero
/// pivot candidate left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Singular(pub usize);

impl SparseLu {
    /// Factorises the `n × n` matrix with compressed columns `(col_ptr, row_idx, val)` (row
    /// indices within a column in any order, no duplicates) in the column order `q`.
    pub(crate) fn factorize(
        &mut self,
        col_ptr: &[usize],
        row_idx: &[usize],
        val: &[f64],
        q: &[usize],
    ) -> Result<(), Singular> {
        let n = q.len();
        debug_assert_eq!(col_ptr.len(), n + 1);
        self.n = n;
        self.q.clear();
        self.q.extend_from_slice(q);
        for v in [&mut self.l_ptr, &mut self.u_ptr] {
            v.clear();
            v.push(0);
        }
        for v in [&mut self.l_idx, &mut self.u_idx] {
            v.clear();
        }
        self.l_val.clear();
        self.u_val.clear();
        self.diag.clear();
        self.pinv.clear();
        self.pinv.resize(n, NONE);
        self.x.clear();
        self.x.resize(n, 0.0);
        self.mark.clear();
        self.mark.resize(n, 0);
        self.next.clear();
        self.next.resize(n, 0);
        self.reach.clear();
        self.reach.resize(n, 0);
        for (j, &c) in q.iter().enumerate() {
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            let top = self.search(rows, j + 1);
            for (&i, &v) in rows.iter().zip(&val[col_ptr[c]..col_ptr[c + 1]]) {
                self.x[i] = v;
            }
            // Sparse triangular solve with the columns of L so far, in topological order.
            for t in top..n {
                let i = self.reach[t];
                let k = self.pinv[i];
                if k == NONE {
                    continue;
                }
                let xi = self.x[i];
                if xi != 0.0 {
                    let (a, b) = (self.l_ptr[k], self.l_ptr[k + 1]);
                    axpy_scattered(&mut self.x, &self.l_idx[a..b], &self.l_val[a..b], xi);
                }
            }
            // U's column: the pivotal rows; the pivot among the others.
            let (mut best, mut best_abs, mut diag_abs) = (NONE, -1.0_f64, -1.0_f64);
            for t in top..n {
                let i = self.reach[t];
                match self.pinv[i] {
                    NONE => {
                        let a = self.x[i].abs();
                        if a > best_abs {
                            best = i;
                            best_abs = a;
                        }
                        if i == c {
                            diag_abs = a;
                        }
                    }
                    k => {
                        self.u_idx.push(k);
                        self.u_val.push(self.x[i]);
                    }
                }
            }
            if best == NONE || best_abs <= 0.0 || !best_abs.is_finite() {
                return Err(Singular(j));
            }
            let pivot_row = if diag_abs >= DIAGONAL_PREFERENCE * best_abs {
                c
            } else {
                best
            };
            let pivot = self.x[pivot_row];
            self.diag.push(pivot);
            self.pinv[pivot_row] = j;
            self.u_ptr.push(self.u_idx.len());
            for t in top..n {
                let i = self.reach[t];
                if self.pinv[i] == NONE {
                    self.l_idx.push(i);
                    self.l_val.push(self.x[i] / pivot);
                }
                self.x[i] = 0.0;
            }
            self.l_ptr.push(self.l_idx.len());
        }
        for i in self.l_idx.iter_mut() {
            *i = self.pinv[*i];
        }
        Ok(())
    }

    /// The rows reachable from `rows` in the graph of `L` (an edge from a pivotal row to each row
    /// of its column of `L`), into `reach[top..]` in topological order; returns `top`. A row is
    /// visited when `mark[row] == stamp`.
    fn search(&mut self, rows: &[usize], stamp: usize) -> usize {
        let mut top = self.n;
        for &start in rows {
            if self.mark[start] == stamp {
                continue;
            }
            self.stack.clear();
            self.stack.push(start);
            self.mark[start] = stamp;
            self.next[start] = match self.pinv[start] {
                NONE => 0,
                k => self.l_ptr[k],
            };
            while let Some(&i) = self.stack.last() {
                let k = self.pinv[i];
                let mut descended = false;
                if k != NONE {
                    let (from, end) = (self.next[i], self.l_ptr[k + 1]);
                    let (r, at) = first_unmarked(&self.l_idx[from..end], &self.mark, stamp);
                    self.next[i] = from + at;
                    if let Some(r) = r {
                        self.mark[r] = stamp;
                        self.next[r] = match self.pinv[r] {
                            NONE => 0,
                            kr => self.l_ptr[kr],
                        };
                        self.stack.push(r);
                        descended = true;
                    }
                }
                if !descended {
                    self.stack.pop();
                    top -= 1;
                    self.reach[top] = i;
                }
            }
        }
        top
    }

    /// Solves `Mᵀ x = b` in place: with `Mᵀ = Q Uᵀ Lᵀ P`, a forward solve with `Uᵀ` and a
    /// backward one with `Lᵀ`, both as dot products with the stored columns.
    pub(crate) fn solve_transpose(&self, b: &mut [f64]) {
        let n = self.n;
        let mut z: Vec<f64> = (0..n).map(|j| b[self.q[j]]).collect();
        for j in 0..n {
            let mut s = z[j];
            for p in self.u_ptr[j]..self.u_ptr[j + 1] {
                s -= self.u_val[p] * z[self.u_idx[p]];
            }
            z[j] = s / self.diag[j];
        }
        for j in (0..n).rev() {
            let mut s = z[j];
            for p in self.l_ptr[j]..self.l_ptr[j + 1] {
                s -= self.l_val[p] * z[self.l_idx[p]];
            }
            z[j] = s;
        }
        for (i, v) in b.iter_mut().enumerate() {
            *v = z[self.pinv[i]];
        }
    }

    /// Stored entries of `L` and `U`, `U`'s diagonal included (`L`'s unit one is not stored).
    #[cfg(test)]
    fn fill(&self) -> usize {
        self.l_idx.len() + self.u_idx.len() + self.n
    }
}

/// `x[idx[p]] -= val[p] · s` for every `p`.
#[inline]
fn axpy_scattered(x: &mut [f64], idx: &[usize], val: &[f64], s: f64) {
    for (&i, &v) in idx.iter().zip(val) {
        x[i] -= v * s;
    }
}

/// The first row of `rows` not marked with `stamp`, and how many entries were read (through
/// that row).
#[inline]
fn first_unmarked(rows: &[usize], mark: &[usize], stamp: usize) -> (Option<usize>, usize) {
    for (p, &r) in rows.iter().enumerate() {
        if mark[r] != stamp {
            return (Some(r), p + 1);
        }
    }
    (None, rows.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::linalg::solvers::Solve;
    use faer::Mat;
    use rand::{Rng, SeedableRng};

    /// A random sparse matrix with a symmetric pattern (`per_row` off-diagonal entries per row
    /// before symmetrising) and diagonal `diag_scale` times the row's largest entry; compressed
    /// columns and the dense copy.
    fn random(
        n: usize,
        per_row: usize,
        diag_scale: f64,
        seed: u64,
    ) -> (Vec<usize>, Vec<usize>, Vec<f64>, Mat<f64>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut dense = Mat::<f64>::zeros(n, n);
        for i in 0..n {
            for _ in 0..per_row {
                let j = rng.random_range(0..n);
                if j != i {
                    dense[(i, j)] = rng.random_range(-1.0..1.0);
                    dense[(j, i)] = rng.random_range(-1.0..1.0);
                }
            }
        }
        for i in 0..n {
            dense[(i, i)] = diag_scale * rng.random_range(0.5..1.5);
        }
        let (mut ptr, mut idx, mut val) = (vec![0], Vec::new(), Vec::new());
        for j in 0..n {
            // Rows in decreasing order: the factorisation must not rely on sorted columns.
            for i in (0..n).rev() {
                if dense[(i, j)] != 0.0 {
                    idx.push(i);
                    val.push(dense[(i, j)]);
                }
            }
            ptr.push(idx.len());
        }
        (ptr, idx, val, dense)
    }

    fn shuffled(n: usize, seed: u64) -> Vec<usize> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut q: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            q.swap(i, rng.random_range(0..=i));
        }
        q
    }

    /// `Mᵀ x = b` agrees with faer's dense LU on random matrices, with strong and with weak
    /// diagonals (the latter pivot off the diagonal), in shuffled column orders, and one
    /// factorisation object reused for matrices of different sizes.
    #[test]
    fn transposed_solves_match_the_dense_lu() {
        let mut lu = SparseLu::default();
        let mut off_diagonal_pivots = 0;
        for (seed, (n, per_row, diag_scale)) in [
            (60, 3, 4.0),
            (200, 4, 0.05),
            (15, 2, 1.0),
            (120, 6, 0.01),
            (1, 0, 2.0),
        ]
        .into_iter()
        .enumerate()
        {
            let seed = seed as u64;
            let (ptr, idx, val, dense) = random(n, per_row, diag_scale, seed);
            let q = shuffled(n, 10 + seed);
            lu.factorize(&ptr, &idx, &val, &q).unwrap();
            off_diagonal_pivots += (0..n).filter(|&j| lu.pinv[q[j]] != j).count();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20 + seed);
            let b: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let mut x = b.clone();
            lu.solve_transpose(&mut x);
            let mut reference = Mat::from_fn(n, 1, |i, _| b[i]);
            dense
                .transpose()
                .to_owned()
                .partial_piv_lu()
                .solve_in_place(&mut reference);
            let scale = (0..n).fold(1.0_f64, |m, i| m.max(reference[(i, 0)].abs()));
            for i in 0..n {
                assert!(
                    (x[i] - reference[(i, 0)]).abs() <= 1e-10 * scale,
                    "n = {n}, row {i}: {} against {}",
                    x[i],
                    reference[(i, 0)]
                );
            }
            // The residual of the transposed system itself.
            for j in 0..n {
                let r: f64 = (0..n).map(|i| dense[(i, j)] * x[i]).sum::<f64>() - b[j];
                assert!(r.abs() <= 1e-10 * scale, "n = {n}, residual {r} at {j}");
            }
        }
        assert!(off_diagonal_pivots > 0, "no case pivoted off the diagonal");
    }

    /// With a dominant diagonal and a fill-reducing order the diagonal pivots keep the fill of
    /// the order: an arrow matrix (dense last row and column) ordered hub-last factorises
    /// without fill, hub-first it fills completely.
    #[test]
    fn diagonal_pivots_keep_the_fill_of_the_order() {
        let n = 40;
        let (mut ptr, mut idx, mut val) = (vec![0], Vec::new(), Vec::new());
        for j in 0..n {
            if j == n - 1 {
                for i in 0..n {
                    idx.push(i);
                    val.push(if i == j { 100.0 } else { 1.0 });
                }
            } else {
                idx.extend([j, n - 1]);
                val.extend([10.0, 1.0]);
            }
            ptr.push(idx.len());
        }
        let mut lu = SparseLu::default();
        let hub_last: Vec<usize> = (0..n).collect();
        lu.factorize(&ptr, &idx, &val, &hub_last).unwrap();
        assert_eq!(lu.fill(), idx.len());
        let hub_first: Vec<usize> = std::iter::once(n - 1).chain(0..n - 1).collect();
        lu.factorize(&ptr, &idx, &val, &hub_first).unwrap();
        assert!(lu.fill() > n * n / 3, "fill {}", lu.fill());
    }

    /// A tridiagonal matrix whose eliminated diagonal (0.6, then about 0.52) stays within the
    /// preference of the larger subdiagonal (0.8): every pivot stays on the diagonal and
    /// nothing fills, where pure partial pivoting would swap rows.
    #[test]
    fn a_diagonal_within_the_threshold_is_the_pivot() {
        let n: usize = 30;
        let (mut ptr, mut idx, mut val) = (vec![0], Vec::new(), Vec::new());
        for j in 0..n {
            for i in j.saturating_sub(1)..(j + 2).min(n) {
                idx.push(i);
                val.push(match i.cmp(&j) {
                    std::cmp::Ordering::Less => 0.05,
                    std::cmp::Ordering::Equal => 0.6,
                    std::cmp::Ordering::Greater => 0.8,
                });
            }
            ptr.push(idx.len());
        }
        let q: Vec<usize> = (0..n).collect();
        let mut lu = SparseLu::default();
        lu.factorize(&ptr, &idx, &val, &q).unwrap();
        assert!((0..n).all(|j| lu.pinv[j] == j), "an off-diagonal pivot");
        assert_eq!(lu.fill(), idx.len());
    }

    #[test]
    fn a_singular_matrix_is_reported() {
        // Two equal columns.
        let ptr = vec![0, 2, 4, 5];
        let idx = vec![0, 1, 0, 1, 2];
        let val = vec![1.0, 2.0, 1.0, 2.0, 3.0];
        let mut lu = SparseLu::default();
        assert_eq!(lu.factorize(&ptr, &idx, &val, &[0, 1, 2]), Err(Singular(1)));
        // An empty column.
        let ptr = vec![0, 1, 1];
        assert_eq!(lu.factorize(&ptr, &[0], &[1.0], &[0, 1]), Err(Singular(1)));
    }

    /// A matrix in compressed columns with its dense copy, a column order and a right-hand side.
    #[derive(Debug, Clone)]
    struct Case {
        ptr: Vec<usize>,
        idx: Vec<usize>,
        val: Vec<f64>,
        dense: Mat<f64>,
        q: Vec<usize>,
        rhs: Vec<f64>,
    }

    /// A sparse nonsingular matrix: a strictly diagonally dominant `B` (each diagonal entry
    /// twice its row's off-diagonal magnitude, plus one) with rows permuted, so that zero
    /// diagonals force off-diagonal pivots. Compressed columns, the dense copy and a right-hand
    /// side.
    fn dominant_permuted() -> impl proptest::strategy::Strategy<Value = Case> {
        use proptest::prelude::*;
        (1usize..40, 0usize..5, any::<u64>()).prop_map(|(n, per_row, seed)| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut b = Mat::<f64>::zeros(n, n);
            for i in 0..n {
                for _ in 0..per_row {
                    let j = rng.random_range(0..n);
                    if j != i {
                        b[(i, j)] = rng.random_range(-1.0..1.0);
                    }
                }
                let off: f64 = (0..n).filter(|&j| j != i).map(|j| b[(i, j)].abs()).sum();
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                b[(i, i)] = sign * (2.0 * off + 1.0);
            }
            let rows = shuffled(n, seed ^ 0x5eed);
            let dense = Mat::from_fn(n, n, |i, j| b[(rows[i], j)]);
            let (mut ptr, mut idx, mut val) = (vec![0], Vec::new(), Vec::new());
            for j in 0..n {
                for i in 0..n {
                    if dense[(i, j)] != 0.0 {
                        idx.push(i);
                        val.push(dense[(i, j)]);
                    }
                }
                ptr.push(idx.len());
            }
            let q = shuffled(n, seed.wrapping_add(1));
            let rhs = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            Case {
                ptr,
                idx,
                val,
                dense,
                q,
                rhs,
            }
        })
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config {
            cases: 48,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x005b_a5e1),
            failure_persistence: None,
            ..proptest::test_runner::Config::default()
        })]

        /// On random sparse nonsingular matrices in random column orders, `Mᵀ x = b` agrees with
        /// faer's dense partial-pivoting LU.
        #[test]
        fn agrees_with_the_dense_lu(case in dominant_permuted()) {
            let Case { ptr, idx, val, dense, q, rhs } = case;
            let n = q.len();
            let mut lu = SparseLu::default();
            proptest::prop_assert!(lu.factorize(&ptr, &idx, &val, &q).is_ok());
            let mut x = rhs.clone();
            lu.solve_transpose(&mut x);
            let mut reference = Mat::from_fn(n, 1, |i, _| rhs[i]);
            dense
                .transpose()
                .to_owned()
                .partial_piv_lu()
                .solve_in_place(&mut reference);
            let scale = (0..n).fold(1.0_f64, |m, i| m.max(reference[(i, 0)].abs()));
            for i in 0..n {
                proptest::prop_assert!(
                    (x[i] - reference[(i, 0)]).abs() <= 1e-10 * scale,
                    "n = {}, row {}: {} against {}", n, i, x[i], reference[(i, 0)]
                );
            }
        }
    }
}

//! The Delassus operator `A = J M⁻¹ Jᵀ` in factored form.
//!
//! A contact problem's `A` couples every pair of rows that share a body, so it stores
//! `Σ_bodies rows(body)²` entries (about 8 million for the 41,664 rows of a 1,015-box
//! pyramid) while `J` stores twelve per row. [`DelassusFactors`] keeps `J` (compressed rows, six
//! columns per body) and the 6×6 inverse-mass block of each body, and gives
//!
//! * products `A f = J (M⁻¹ (Jᵀ f))` and body velocities `u = M⁻¹ Jᵀ f` in `O(nnz(J))`
//!   ([`DelassusFactors::apply`], [`DelassusFactors::body_velocity`]);
//! * the diagonal `A_ii = J_i M⁻¹ J_iᵀ` in `O(nnz(J_i))` ([`DelassusFactors::diagonal`]);
//! * the entries of one row of `A`, column by column, without storing any other row
//!   ([`DelassusFactors::for_each_entry`]): the rows sharing one of row `i`'s bodies, merged
//!   over its (at most a few) bodies, each entry `Σ_bodies J_i,body · (M⁻¹ J_j,bodyᵀ)`. The
//!   shared residual's per-row term magnitudes `Σ_j |A_ij f_j|` need exactly these;
//! * the assembled compressed rows when a solver needs `A` itself
//!   ([`DelassusFactors::assemble`]), built from the same entries, so that both forms give the
//!   same numbers bit for bit.
//!
//! A [`crate::Problem`] built with [`crate::Problem::boxed_factored`] holds only the factors and
//! assembles `A` on the first call that needs its rows.

use crate::problem::ProblemError;
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};

/// One body's part of a Jacobian row: the body, its six entries `[linear; angular]` and the
/// body's velocity change `M⁻¹ J_row,bodyᵀ` per unit impulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Block {
    pub(crate) body: usize,
    pub(crate) j: [f64; 6],
    pub(crate) resp: [f64; 6],
}

/// The factored form `A = J M⁻¹ Jᵀ` of a contact problem: a sparse Jacobian `J` (one row per
/// constraint row, six columns per body: linear then angular velocity) and a symmetric positive
/// semidefinite 6×6 inverse-mass block per body (zero for static bodies). Solvers that need only
/// products with `A`, or one row of `A` at a time, can use it without assembling `A`.
#[derive(Debug, Clone)]
pub struct DelassusFactors {
    jacobian: SparseRowMat<usize, f64>,
    inverse_mass: Vec<[[f64; 6]; 6]>,
    /// Row `i`'s blocks are `blocks[block_ptr[i]..block_ptr[i + 1]]`, bodies increasing.
    block_ptr: Vec<usize>,
    blocks: Vec<Block>,
    /// The rows touching body `k` are `touching[body_ptr[k]..body_ptr[k + 1]]`, increasing,
    /// each with its response `M⁻¹ J_row,kᵀ` to a unit impulse.
    body_ptr: Vec<usize>,
    touching: Vec<(usize, [f64; 6])>,
}

/// `Σ_k a_k b_k` over six entries, summed in order.
#[inline]
fn dot6(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    (0..6).map(|k| a[k] * b[k]).sum()
}

impl DelassusFactors {
    /// `J` (`rows × 6·bodies`) and the per-body inverse-mass blocks.
    pub fn new(
        jacobian: SparseRowMat<usize, f64>,
        inverse_mass: Vec<[[f64; 6]; 6]>,
    ) -> Result<Self, ProblemError> {
        if jacobian.ncols() != 6 * inverse_mass.len() {
            return Err(ProblemError::DimensionMismatch {
                what: "the Jacobian's columns (6 per body)",
                expected: 6 * inverse_mass.len(),
                found: jacobian.ncols(),
            });
        }
        let (block_ptr, mut blocks) = row_blocks(&jacobian);
        let bodies = inverse_mass.len();
        let mut body_ptr = vec![0usize; bodies + 1];
        for blk in &blocks {
            body_ptr[blk.body + 1] += 1;
        }
        for k in 0..bodies {
            body_ptr[k + 1] += body_ptr[k];
        }
        let mut next = body_ptr.clone();
        let mut touching = vec![(0, [0.0; 6]); blocks.len()];
        for i in 0..jacobian.nrows() {
            for blk in &mut blocks[block_ptr[i]..block_ptr[i + 1]] {
                let m = &inverse_mass[blk.body];
                for (r, mrow) in m.iter().enumerate() {
                    blk.resp[r] = mrow.iter().zip(&blk.j).map(|(a, b)| a * b).sum();
                }
                touching[next[blk.body]] = (i, blk.resp);
                next[blk.body] += 1;
            }
        }
        Ok(Self {
            jacobian,
            inverse_mass,
            block_ptr,
            blocks,
            body_ptr,
            touching,
        })
    }

    /// Constraint rows.
    pub fn rows(&self) -> usize {
        self.jacobian.nrows()
    }

    /// The sparse Jacobian `J`.
    pub fn jacobian(&self) -> &SparseRowMat<usize, f64> {
        &self.jacobian
    }

    /// The inverse-mass block of each body.
    pub fn inverse_mass(&self) -> &[[[f64; 6]; 6]] {
        &self.inverse_mass
    }

    /// Body velocities `u = M⁻¹ Jᵀ f` (six per body).
    pub fn body_velocity(&self, f: &[f64]) -> Vec<f64> {
        let mut p = vec![0.0; self.jacobian.ncols()];
        let sym = self.jacobian.symbolic();
        let (ptr, idx, val) = (sym.row_ptr(), sym.col_idx(), self.jacobian.val());
        for (i, &fi) in f.iter().enumerate() {
            if fi != 0.0 {
                for k in ptr[i]..ptr[i + 1] {
                    p[idx[k]] += val[k] * fi;
                }
            }
        }
        let mut u = vec![0.0; p.len()];
        for (body, m) in self.inverse_mass.iter().enumerate() {
            let (pb, ub) = (&p[6 * body..6 * body + 6], &mut u[6 * body..6 * body + 6]);
            for r in 0..6 {
                ub[r] = (0..6).map(|c| m[r][c] * pb[c]).sum();
            }
        }
        u
    }

    /// `J_i · u`.
    pub fn row_dot(&self, i: usize, u: &[f64]) -> f64 {
        let sym = self.jacobian.symbolic();
        let range = sym.row_ptr()[i]..sym.row_ptr()[i + 1];
        sym.col_idx()[range.clone()]
            .iter()
            .zip(&self.jacobian.val()[range])
            .map(|(&c, v)| v * u[c])
            .sum()
    }

    /// `A f = J (M⁻¹ (Jᵀ f))` in `O(nnz(J))`.
    pub fn apply(&self, f: &[f64]) -> Vec<f64> {
        let u = self.body_velocity(f);
        (0..self.rows()).map(|i| self.row_dot(i, &u)).collect()
    }

    /// `A_ii = J_i M⁻¹ J_iᵀ`, the same number as row `i`'s diagonal entry in
    /// [`DelassusFactors::for_each_entry`].
    pub fn diagonal(&self, i: usize) -> f64 {
        let mut a = 0.0;
        for blk in self.row_blocks(i) {
            a += dot6(&blk.j, &blk.resp);
        }
        a
    }

    /// Row `i`'s blocks, bodies increasing.
    pub(crate) fn row_blocks(&self, i: usize) -> &[Block] {
        &self.blocks[self.block_ptr[i]..self.block_ptr[i + 1]]
    }

    /// The rows touching body `k` with their unit responses.
    fn touching_of(&self, k: usize) -> &[(usize, [f64; 6])] {
        &self.touching[self.body_ptr[k]..self.body_ptr[k + 1]]
    }

    /// Calls `visit(j, A_ij)` for every column `j` of row `i` of `A` that shares a body with row
    /// `i`, columns increasing (the diagonal included; an entry whose products cancel is visited
    /// with its value 0, as the assembled rows store it). Each entry is the sum over the shared
    /// bodies, in increasing body order, of `J_i,body · (M⁻¹ J_j,bodyᵀ)`. `O(Σ_bodies
    /// rows(body))`, no allocation for rows on at most two bodies (contact rows).
    #[inline]
    pub fn for_each_entry(&self, i: usize, mut visit: impl FnMut(usize, f64)) {
        match self.row_blocks(i) {
            [] => {}
            [b1] => {
                for (c, resp) in self.touching_of(b1.body) {
                    visit(*c, dot6(&b1.j, resp));
                }
            }
            [b1, b2] => {
                let (l1, l2) = (self.touching_of(b1.body), self.touching_of(b2.body));
                let (mut p, mut q) = (0, 0);
                while p < l1.len() || q < l2.len() {
                    let c1 = l1.get(p).map_or(usize::MAX, |e| e.0);
                    let c2 = l2.get(q).map_or(usize::MAX, |e| e.0);
                    let c = c1.min(c2);
                    let mut v = 0.0;
                    if c1 == c {
                        v += dot6(&b1.j, &l1[p].1);
                        p += 1;
                    }
                    if c2 == c {
                        v += dot6(&b2.j, &l2[q].1);
                        q += 1;
                    }
                    visit(c, v);
                }
            }
            many => {
                let mut cursor: Vec<usize> = many.iter().map(|b| self.body_ptr[b.body]).collect();
                loop {
                    let mut c = usize::MAX;
                    for (b, &k) in many.iter().zip(&cursor) {
                        if k < self.body_ptr[b.body + 1] {
                            c = c.min(self.touching[k].0);
                        }
                    }
                    if c == usize::MAX {
                        break;
                    }
                    let mut v = 0.0;
                    for (b, k) in many.iter().zip(cursor.iter_mut()) {
                        if *k < self.body_ptr[b.body + 1] && self.touching[*k].0 == c {
                            v += dot6(&b.j, &self.touching[*k].1);
                            *k += 1;
                        }
                    }
                    visit(c, v);
                }
            }
        }
    }

    /// Number of entries of row `i` that [`DelassusFactors::for_each_entry`] visits, counted
    /// on the row indices alone.
    pub fn row_len(&self, i: usize) -> usize {
        match self.row_blocks(i) {
            [] => 0,
            [b1] => self.touching_of(b1.body).len(),
            [b1, b2] => {
                let (l1, l2) = (self.touching_of(b1.body), self.touching_of(b2.body));
                let (mut p, mut q, mut shared) = (0, 0, 0);
                while p < l1.len() && q < l2.len() {
                    match l1[p].0.cmp(&l2[q].0) {
                        std::cmp::Ordering::Less => p += 1,
                        std::cmp::Ordering::Greater => q += 1,
                        std::cmp::Ordering::Equal => {
                            shared += 1;
                            p += 1;
                            q += 1;
                        }
                    }
                }
                l1.len() + l2.len() - shared
            }
            _ => {
                let mut n = 0;
                self.for_each_entry(i, |_, _| n += 1);
                n
            }
        }
    }

    /// Stored entries of the assembled `A` ([`DelassusFactors::assemble`]), counted without
    /// visiting them when no row has more than two bodies: every row on body `k` meets the
    /// `rows(k)` rows there, `Σ_k rows(k)²`, less one for each pair of rows that share both of
    /// their two bodies (met twice), `Σ_pairs rows(pair)²`. `O(nnz(J) + n log n)`.
    pub fn nnz(&self) -> usize {
        let mut pairs = Vec::with_capacity(self.rows());
        for i in 0..self.rows() {
            match self.row_blocks(i) {
                [_, _, _, ..] => return (0..self.rows()).map(|i| self.row_len(i)).sum(),
                [b1, b2] => pairs.push((b1.body, b2.body)),
                _ => {}
            }
        }
        pairs.sort_unstable();
        let met: usize = (0..self.inverse_mass.len())
            .map(|k| (self.body_ptr[k + 1] - self.body_ptr[k]).pow(2))
            .sum();
        let twice: usize = pairs
            .chunk_by(|a, b| a == b)
            .map(|run| run.len().pow(2))
            .sum();
        met - twice
    }

    /// `A` in compressed sparse rows: every entry [`DelassusFactors::for_each_entry`] visits.
    pub fn assemble(&self) -> SparseRowMat<usize, f64> {
        let n = self.rows();
        let nnz = self.nnz();
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col_idx = Vec::with_capacity(nnz);
        let mut val = Vec::with_capacity(nnz);
        row_ptr.push(0);
        for i in 0..n {
            self.for_each_entry(i, |j, v| {
                col_idx.push(j);
                val.push(v);
            });
            row_ptr.push(col_idx.len());
        }
        let symbolic = SymbolicSparseRowMat::new_checked(n, n, row_ptr, None, col_idx);
        SparseRowMat::new(symbolic, val)
    }

    /// `(A_i · f, Σ_j |A_ij f_j|, stored entries of row i)` in one pass over row `i`'s entries,
    /// summed in column order as [`crate::Row::dot_and_magnitude`] sums an assembled row.
    #[inline]
    pub fn row_dot_and_magnitude(&self, i: usize, f: &[f64]) -> (f64, f64, usize) {
        let (mut s, mut m, mut len) = (0.0, 0.0, 0);
        self.for_each_entry(i, |j, a| {
            let t = a * f[j];
            s += t;
            m += t.abs();
            len += 1;
        });
        (s, m, len)
    }
}

/// Each row's blocks (one per body, bodies increasing), gathered from the compressed rows of
/// `J` (entries of one body's six columns summed into its block).
fn row_blocks(jacobian: &SparseRowMat<usize, f64>) -> (Vec<usize>, Vec<Block>) {
    let sym = jacobian.symbolic();
    let (jptr, jidx, jval) = (sym.row_ptr(), sym.col_idx(), jacobian.val());
    let n = jacobian.nrows();
    let mut ptr = Vec::with_capacity(n + 1);
    let mut blocks = Vec::with_capacity(jidx.len() / 6 + 1);
    ptr.push(0);
    for i in 0..n {
        let mut k = jptr[i];
        while k < jptr[i + 1] {
            let body = jidx[k] / 6;
            let first = 6 * body;
            let mut j = [0.0; 6];
            while k < jptr[i + 1] && jidx[k] < first + 6 {
                j[jidx[k] - first] += jval[k];
                k += 1;
            }
            blocks.push(Block {
                body,
                j,
                resp: [0.0; 6],
            });
        }
        ptr.push(blocks.len());
    }
    (ptr, blocks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::Triplet;
    use faer::Mat;

    /// Rows on one, two and three bodies (and one on none), with two rows sharing both bodies
    /// of a pair, and full symmetric inverse-mass blocks.
    fn factors() -> DelassusFactors {
        let touches: [&[usize]; 6] = [&[0], &[0, 1], &[0, 1], &[1, 2, 3], &[], &[3]];
        let mut triplets = Vec::new();
        for (i, bodies) in touches.iter().enumerate() {
            for &b in bodies.iter() {
                for c in 0..6 {
                    let v = ((i * 5 + b * 3 + c * 7) % 9) as f64 - 4.0;
                    triplets.push(Triplet::new(i, 6 * b + c, v));
                }
            }
        }
        let jac = SparseRowMat::try_new_from_triplets(6, 24, &triplets).unwrap();
        let blocks = (0..4)
            .map(|b| {
                let mut m = [[0.0; 6]; 6];
                for (r, row) in m.iter_mut().enumerate() {
                    for (c, v) in row.iter_mut().enumerate() {
                        *v = if r == c {
                            2.0 + b as f64
                        } else {
                            0.1 * (r + c) as f64 / 6.0
                        };
                    }
                }
                m
            })
            .collect();
        DelassusFactors::new(jac, blocks).unwrap()
    }

    #[test]
    fn rows_of_a_match_the_product_of_the_factors() {
        let fac = factors();
        let j = fac.jacobian().to_dense();
        let mut minv = Mat::<f64>::zeros(24, 24);
        for (b, m) in fac.inverse_mass().iter().enumerate() {
            for r in 0..6 {
                for c in 0..6 {
                    minv[(6 * b + r, 6 * b + c)] = m[r][c];
                }
            }
        }
        let a = &j * &minv * j.transpose();
        let assembled = fac.assemble();
        assert_eq!(assembled.val().len(), fac.nnz());
        let dense = assembled.to_dense();
        let f = [0.5, -1.0, 2.0, 0.25, 3.0, -0.75];
        let product = fac.apply(&f);
        for i in 0..6 {
            let mut seen = Vec::new();
            fac.for_each_entry(i, |c, v| seen.push((c, v)));
            assert_eq!(seen.len(), fac.row_len(i), "row {i}");
            assert!(seen.windows(2).all(|w| w[0].0 < w[1].0), "columns increase");
            for c in 0..6 {
                assert!((dense[(i, c)] - a[(i, c)]).abs() <= 1e-12 * (1.0 + a[(i, c)].abs()));
            }
            let (s, m, len) = fac.row_dot_and_magnitude(i, &f);
            assert_eq!(len, seen.len());
            let by_row: f64 = (0..6).map(|c| a[(i, c)] * f[c]).sum();
            assert!((s - by_row).abs() <= 1e-11 * (1.0 + m));
            assert!((product[i] - by_row).abs() <= 1e-11 * (1.0 + m));
            if !seen.is_empty() {
                assert_eq!(fac.diagonal(i).to_bits(), dense[(i, i)].to_bits());
            }
        }
        // Row 4 touches no body; rows 1 and 2 share both bodies, so row 1 meets rows 0..=3.
        assert_eq!(fac.row_len(4), 0);
        assert_eq!(fac.row_len(1), 4);
    }

    #[test]
    fn counting_by_body_pairs_matches_visiting_every_row() {
        // Without the three-body row, the count takes the pair formula.
        let touches: [&[usize]; 5] = [&[0, 1], &[0, 1], &[1, 2], &[2], &[0, 2]];
        let mut triplets = Vec::new();
        for (i, bodies) in touches.iter().enumerate() {
            for &b in bodies.iter() {
                triplets.push(Triplet::new(i, 6 * b + i % 6, 1.0 + i as f64));
            }
        }
        let jac = SparseRowMat::try_new_from_triplets(5, 18, &triplets).unwrap();
        let mut eye = [[0.0; 6]; 6];
        for (k, row) in eye.iter_mut().enumerate() {
            row[k] = 1.0;
        }
        let fac = DelassusFactors::new(jac, vec![eye; 3]).unwrap();
        let visited: usize = (0..5).map(|i| fac.row_len(i)).sum();
        assert_eq!(fac.nnz(), visited);
        assert_eq!(fac.assemble().val().len(), visited);
    }
}

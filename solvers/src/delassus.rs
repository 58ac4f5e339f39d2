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
use std::sync::OnceLock;

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
    inverse_mass: Vec<[[f64; 6]; 6]>,
    /// Row `i`'s blocks are `blocks[block_ptr[i]..block_ptr[i + 1]]`, bodies increasing.
    block_ptr: Vec<usize>,
    blocks: Vec<Block>,
    /// `J` in compressed rows, formed from the blocks on first use (or the matrix given).
    jacobian: OnceLock<SparseRowMat<usize, f64>>,
    /// The rows touching each body, formed on first use.
    touching: OnceLock<Touching>,
    /// The layout of [`DelassusFactors::row_terms`], formed on first use.
    pair_runs: OnceLock<Option<PairRuns>>,
}

/// The rows touching body `k` are `touching[body_ptr[k]..body_ptr[k + 1]]`, increasing, each
/// with its response `M⁻¹ J_row,kᵀ` to a unit impulse.
#[derive(Debug, Clone)]
struct Touching {
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
        let (block_ptr, blocks) = row_blocks(&jacobian);
        let factors = Self::with_blocks(block_ptr, blocks, inverse_mass);
        let _ = factors.jacobian.set(jacobian);
        Ok(factors)
    }

    /// `J` given as each row's blocks: row `i`'s are `blocks[block_ptr[i]..block_ptr[i + 1]]`,
    /// each a body and its six entries `[linear; angular]`, bodies increasing within a row
    /// (a contact row has one block per dynamic body), and the per-body inverse-mass blocks.
    /// Nothing is copied into compressed rows unless asked for ([`DelassusFactors::jacobian`]).
    pub fn from_row_blocks(
        block_ptr: Vec<usize>,
        blocks: Vec<(usize, [f64; 6])>,
        inverse_mass: Vec<[[f64; 6]; 6]>,
    ) -> Result<Self, ProblemError> {
        let bodies = inverse_mass.len();
        let well_formed = block_ptr.first() == Some(&0)
            && block_ptr.last() == Some(&blocks.len())
            && block_ptr.windows(2).all(|w| w[0] <= w[1]);
        if !well_formed {
            return Err(ProblemError::DimensionMismatch {
                what: "the row pointers of the Jacobian's blocks",
                expected: blocks.len(),
                found: block_ptr.last().copied().unwrap_or(0),
            });
        }
        for w in block_ptr.windows(2) {
            let row = &blocks[w[0]..w[1]];
            if let Some(&(body, _)) = row.iter().find(|(body, _)| *body >= bodies) {
                return Err(ProblemError::DimensionMismatch {
                    what: "a Jacobian block's body (below the number of bodies)",
                    expected: bodies,
                    found: body,
                });
            }
            if row.windows(2).any(|p| p[0].0 >= p[1].0) {
                return Err(ProblemError::DimensionMismatch {
                    what: "a Jacobian row's blocks (bodies increasing)",
                    expected: row.len(),
                    found: row.len(),
                });
            }
        }
        let blocks = blocks
            .into_iter()
            .map(|(body, j)| Block {
                body,
                j,
                resp: [0.0; 6],
            })
            .collect();
        Ok(Self::with_blocks(block_ptr, blocks, inverse_mass))
    }

    /// The factors of checked blocks, each block's response computed.
    fn with_blocks(
        block_ptr: Vec<usize>,
        mut blocks: Vec<Block>,
        inverse_mass: Vec<[[f64; 6]; 6]>,
    ) -> Self {
        let block_diagonal: Vec<bool> = inverse_mass.iter().map(is_block_diagonal).collect();
        for blk in &mut blocks {
            let m = &inverse_mass[blk.body];
            blk.resp = if block_diagonal[blk.body] {
                block_diagonal_response(m, &blk.j)
            } else {
                response(m, &blk.j)
            };
        }
        Self {
            inverse_mass,
            block_ptr,
            blocks,
            jacobian: OnceLock::new(),
            touching: OnceLock::new(),
            pair_runs: OnceLock::new(),
        }
    }

    /// Constraint rows.
    pub fn rows(&self) -> usize {
        self.block_ptr.len() - 1
    }

    /// Bodies (columns of `J` over six).
    pub fn bodies(&self) -> usize {
        self.inverse_mass.len()
    }

    /// The sparse Jacobian `J` (formed from the blocks on first use: six entries per block).
    pub fn jacobian(&self) -> &SparseRowMat<usize, f64> {
        self.jacobian.get_or_init(|| {
            let n = self.rows();
            let mut row_ptr = Vec::with_capacity(n + 1);
            let mut col_idx = Vec::with_capacity(6 * self.blocks.len());
            let mut val = Vec::with_capacity(6 * self.blocks.len());
            row_ptr.push(0);
            for i in 0..n {
                for blk in self.row_blocks(i) {
                    col_idx.extend(6 * blk.body..6 * blk.body + 6);
                    val.extend(blk.j);
                }
                row_ptr.push(col_idx.len());
            }
            let symbolic =
                SymbolicSparseRowMat::new_checked(n, 6 * self.bodies(), row_ptr, None, col_idx);
            SparseRowMat::new(symbolic, val)
        })
    }

    /// Stored entries of `J`: those of the matrix given, or six per block.
    pub fn jacobian_nnz(&self) -> usize {
        self.jacobian
            .get()
            .map_or(6 * self.blocks.len(), |j| j.val().len())
    }

    /// The inverse-mass block of each body.
    pub fn inverse_mass(&self) -> &[[[f64; 6]; 6]] {
        &self.inverse_mass
    }

    /// Body velocities `u = M⁻¹ Jᵀ f` (six per body).
    pub fn body_velocity(&self, f: &[f64]) -> Vec<f64> {
        let mut p = vec![0.0; 6 * self.bodies()];
        for (i, &fi) in f.iter().enumerate() {
            if fi != 0.0 {
                for blk in self.row_blocks(i) {
                    let pb = &mut p[6 * blk.body..6 * blk.body + 6];
                    for (x, v) in pb.iter_mut().zip(&blk.j) {
                        *x += v * fi;
                    }
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
        self.row_blocks(i)
            .iter()
            .flat_map(|blk| blk.j.iter().zip(&u[6 * blk.body..6 * blk.body + 6]))
            .map(|(v, x)| v * x)
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
        let t = self.touching();
        &t.touching[t.body_ptr[k]..t.body_ptr[k + 1]]
    }

    /// Each body's rows, in row order (formed on first use).
    fn touching(&self) -> &Touching {
        self.touching.get_or_init(|| {
            let body_ptr = self.rows_per_body();
            let mut next = body_ptr.clone();
            let mut touching = vec![(0, [0.0; 6]); self.blocks.len()];
            for i in 0..self.rows() {
                for blk in self.row_blocks(i) {
                    touching[next[blk.body]] = (i, blk.resp);
                    next[blk.body] += 1;
                }
            }
            Touching { body_ptr, touching }
        })
    }

    /// The prefix sums of the number of rows touching each body.
    fn rows_per_body(&self) -> Vec<usize> {
        let bodies = self.bodies();
        let mut body_ptr = vec![0usize; bodies + 1];
        for blk in &self.blocks {
            body_ptr[blk.body + 1] += 1;
        }
        for k in 0..bodies {
            body_ptr[k + 1] += body_ptr[k];
        }
        body_ptr
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
                let Touching { body_ptr, touching } = self.touching();
                let mut cursor: Vec<usize> = many.iter().map(|b| body_ptr[b.body]).collect();
                loop {
                    let mut c = usize::MAX;
                    for (b, &k) in many.iter().zip(&cursor) {
                        if k < body_ptr[b.body + 1] {
                            c = c.min(touching[k].0);
                        }
                    }
                    if c == usize::MAX {
                        break;
                    }
                    let mut v = 0.0;
                    for (b, k) in many.iter().zip(cursor.iter_mut()) {
                        if *k < body_ptr[b.body + 1] && touching[*k].0 == c {
                            v += dot6(&b.j, &touching[*k].1);
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
        let body_ptr = self.rows_per_body();
        let met: usize = (0..self.bodies())
            .map(|k| (body_ptr[k + 1] - body_ptr[k]).pow(2))
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

    /// `A f` into `af`, `Σ_j |A_ij f_j|` into `magnitude` and the number of stored entries of
    /// each row into `len` (when given), for every row at once: the quantities of
    /// [`DelassusFactors::row_dot_and_magnitude`], the same entries summed in another order
    /// (so equal to round-off), at a fraction of its cost on contact rows (see [`PairRuns`]).
    /// Rows are split among `threads` threads. Falls back to the row-by-row pass when a row
    /// has more than two bodies.
    pub fn row_terms(
        &self,
        f: &[f64],
        af: &mut [f64],
        magnitude: &mut [f64],
        mut len: Option<&mut [usize]>,
        threads: usize,
    ) {
        let n = self.rows();
        assert!(f.len() == n && af.len() == n && magnitude.len() == n);
        let Some(runs) = self.pair_runs.get_or_init(|| PairRuns::new(self)) else {
            for i in 0..n {
                let (s, m, l) = self.row_dot_and_magnitude(i, f);
                (af[i], magnitude[i]) = (s, m);
                if let Some(len) = len.as_deref_mut() {
                    len[i] = l;
                }
            }
            return;
        };
        let q = runs.scaled_responses(f);
        let chunk = n.div_ceil(threads.max(1)).max(1);
        let work = |first: usize, af: &mut [f64], mag: &mut [f64], len: Option<&mut [usize]>| {
            runs.rows(self, &q, first, af, mag, len)
        };
        if threads <= 1 || n <= chunk {
            work(0, af, magnitude, len);
            return;
        }
        std::thread::scope(|scope| {
            let mut len_chunks = len.map(|l| l.chunks_mut(chunk));
            for (k, (a, m)) in af
                .chunks_mut(chunk)
                .zip(magnitude.chunks_mut(chunk))
                .enumerate()
            {
                let l = len_chunks.as_mut().and_then(|c| c.next());
                let work = &work;
                scope.spawn(move || work(k * chunk, a, m, l));
            }
        });
    }
}

/// The rows touching each body, ordered by the row's other body and then by row, with the six
/// components of each row's response `M⁻¹ J_row,bodyᵀ` in six contiguous columns.
///
/// Row `i` on bodies `b1`, `b2` meets every row touching `b1` or `b2`; the rows touching
/// both are the rows of the pair `(b1, b2)`, which this order puts in one run in each body's
/// list, in the same order. So `A_ij f_j` for all `j` is two dense products (`J_i,b1` against
/// the columns of `b1`, `J_i,b2` against those of `b2`) and `Σ_j |A_ij f_j|` adds the two
/// runs entry by entry and every other entry on its own: no merge, no branch per entry, and the
/// products vectorise. Only for rows on at most two bodies (contact rows).
#[derive(Debug, Clone)]
struct PairRuns {
    /// Body `k`'s entries are `ptr[k]..ptr[k + 1]`.
    ptr: Vec<usize>,
    /// Each entry's row.
    row: Vec<usize>,
    /// Body `k`'s responses in six columns: component `c` of its `t`-th entry at
    /// `resp[6 ptr[k] + c m_k + t]`, `m_k = ptr[k + 1] - ptr[k]`.
    resp: Vec<f64>,
    /// For each block of [`DelassusFactors::blocks`]: the first entry and the length of the
    /// pair's run in the block's body list (empty for a row on one body).
    run: Vec<(usize, usize)>,
}

impl PairRuns {
    /// The layout of `factors`, or `None` when a row has more than two bodies.
    fn new(factors: &DelassusFactors) -> Option<Self> {
        const NONE: usize = usize::MAX;
        if (0..factors.rows()).any(|i| factors.row_blocks(i).len() > 2) {
            return None;
        }
        let bodies = factors.bodies();
        let entries = factors.blocks.len();
        let ptr = factors.rows_per_body();
        // Each body's entries as (other body, row, block), in row order, then sorted.
        let mut keyed = vec![(0, 0, 0); entries];
        let mut next = ptr.clone();
        for i in 0..factors.rows() {
            let first = factors.block_ptr[i];
            let blocks = factors.row_blocks(i);
            for (slot, blk) in blocks.iter().enumerate() {
                let other = match blocks {
                    [a, b] => [b.body, a.body][slot],
                    _ => NONE,
                };
                keyed[next[blk.body]] = (other, i, first + slot);
                next[blk.body] += 1;
            }
        }
        // A pair's rows are usually consecutive (one manifold's contacts), so each body's list
        // in row order already holds each other body's rows in one run; a body where one does
        // not is sorted by (other body, row).
        let mut last_run_of = vec![NONE; bodies];
        for k in 0..bodies {
            let list = &mut keyed[ptr[k]..ptr[k + 1]];
            let mut contiguous = true;
            for (t, e) in list.iter().enumerate() {
                let other = e.0;
                if other == NONE || (t > 0 && list[t - 1].0 == other) {
                    continue;
                }
                if last_run_of[other] == k {
                    contiguous = false;
                    break;
                }
                last_run_of[other] = k;
            }
            if !contiguous {
                list.sort_unstable();
            }
        }
        let mut row = vec![0; entries];
        let mut resp = vec![0.0; 6 * entries];
        let mut run = vec![(0, 0); entries];
        for k in 0..bodies {
            let list = &keyed[ptr[k]..ptr[k + 1]];
            let mut start = 0;
            while start < list.len() {
                let other = list[start].0;
                let end = start + list[start..].iter().take_while(|e| e.0 == other).count();
                for (t, &(_, i, blk)) in list[start..end].iter().enumerate() {
                    let at = ptr[k] + start + t;
                    row[at] = i;
                    let r = &factors.blocks[blk].resp;
                    let m = ptr[k + 1] - ptr[k];
                    for c in 0..6 {
                        resp[6 * ptr[k] + c * m + start + t] = r[c];
                    }
                    if other != NONE {
                        run[blk] = (ptr[k] + start, end - start);
                    }
                }
                start = end;
            }
        }
        Some(Self {
            ptr,
            row,
            resp,
            run,
        })
    }

    /// The responses scaled by their row's impulse: component `c` of entry `e` is
    /// `M⁻¹ J_row,bodyᵀ[c] · f_row`, so a row's dot product with them is `A_ij f_j`.
    fn scaled_responses(&self, f: &[f64]) -> Vec<f64> {
        let mut q = vec![0.0; self.resp.len()];
        for k in 0..self.ptr.len() - 1 {
            let (a, m) = (self.ptr[k], self.ptr[k + 1] - self.ptr[k]);
            let rows = &self.row[a..a + m];
            for c in 0..6 {
                let at = 6 * a + c * m..6 * a + (c + 1) * m;
                for ((x, v), &i) in q[at.clone()].iter_mut().zip(&self.resp[at]).zip(rows) {
                    *x = v * f[i];
                }
            }
        }
        q
    }

    /// Rows `first..first + af.len()`: their `A_i f`, `Σ_j |A_ij f_j|` and entry counts.
    fn rows(
        &self,
        factors: &DelassusFactors,
        q: &[f64],
        first: usize,
        af: &mut [f64],
        magnitude: &mut [f64],
        mut len: Option<&mut [usize]>,
    ) {
        let longest = (0..self.ptr.len() - 1)
            .map(|k| self.ptr[k + 1] - self.ptr[k])
            .max()
            .unwrap_or(0);
        let (mut v1, mut v2) = (vec![0.0; longest], vec![0.0; longest]);
        let columns = |k: usize| -> [&[f64]; 6] {
            let (a, m) = (6 * self.ptr[k], self.ptr[k + 1] - self.ptr[k]);
            std::array::from_fn(|c| &q[a + c * m..a + (c + 1) * m])
        };
        for (r, (a, m)) in af.iter_mut().zip(magnitude.iter_mut()).enumerate() {
            let i = first + r;
            let blocks = factors.row_blocks(i);
            let (s, t, l) = match blocks {
                [] => (0.0, 0.0, 0),
                [b1] => {
                    let v1 = &mut v1[..self.ptr[b1.body + 1] - self.ptr[b1.body]];
                    products(&b1.j, columns(b1.body), v1);
                    let (s, t) = sum_and_abs(v1);
                    (s, t, v1.len())
                }
                [b1, b2, ..] => {
                    let k = factors.block_ptr[i];
                    let ((s1, n1), (s2, _)) = (self.run[k], self.run[k + 1]);
                    let (s1, s2) = (s1 - self.ptr[b1.body], s2 - self.ptr[b2.body]);
                    let v1 = &mut v1[..self.ptr[b1.body + 1] - self.ptr[b1.body]];
                    let v2 = &mut v2[..self.ptr[b2.body + 1] - self.ptr[b2.body]];
                    products(&b1.j, columns(b1.body), v1);
                    products(&b2.j, columns(b2.body), v2);
                    let parts = [
                        sum_and_abs(&v1[..s1]),
                        sum_and_abs(&v1[s1 + n1..]),
                        sum_and_abs(&v2[..s2]),
                        sum_and_abs(&v2[s2 + n1..]),
                        sum_and_abs_of_sum(&v1[s1..s1 + n1], &v2[s2..s2 + n1]),
                    ];
                    let (s, t) = parts
                        .iter()
                        .fold((0.0, 0.0), |(s, t), p| (s + p.0, t + p.1));
                    (s, t, v1.len() + v2.len() - n1)
                }
            };
            (*a, *m) = (s, t);
            if let Some(len) = len.as_deref_mut() {
                len[r] = l;
            }
        }
    }
}

/// `out[t] = Σ_c j[c] · columns[c][t]`, dispatched to AVX2 where the processor has it (the
/// same operations in the same order either way: no fused multiply–add, no reassociation).
fn products(j: &[f64; 6], columns: [&[f64]; 6], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2 (checked just above).
            unsafe { products_avx2(j, columns, out) };
            return;
        }
    }
    products_generic(j, columns, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn products_avx2(j: &[f64; 6], columns: [&[f64]; 6], out: &mut [f64]) {
    products_generic(j, columns, out);
}

#[inline(always)]
fn products_generic(j: &[f64; 6], columns: [&[f64]; 6], out: &mut [f64]) {
    let n = out.len();
    let [c0, c1, c2, c3, c4, c5] = columns.map(|c| &c[..n]);
    for t in 0..n {
        out[t] =
            j[0] * c0[t] + j[1] * c1[t] + j[2] * c2[t] + j[3] * c3[t] + j[4] * c4[t] + j[5] * c5[t];
    }
}

/// `(Σ_t x_t, Σ_t |x_t|)`, each in four interleaved partial sums (a fixed order, whatever the
/// vector width).
fn sum_and_abs(x: &[f64]) -> (f64, f64) {
    let (mut s, mut m) = ([0.0; 4], [0.0; 4]);
    let chunks = x.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..4 {
            s[l] += c[l];
            m[l] += c[l].abs();
        }
    }
    finish(s, m, rest.iter().copied())
}

/// [`sum_and_abs`] of `x + y`, entry by entry.
fn sum_and_abs_of_sum(x: &[f64], y: &[f64]) -> (f64, f64) {
    let y = &y[..x.len()];
    let (mut s, mut m) = ([0.0; 4], [0.0; 4]);
    let (cx, cy) = (x.chunks_exact(4), y.chunks_exact(4));
    let rest = cx
        .remainder()
        .iter()
        .zip(cy.remainder())
        .map(|(a, b)| a + b);
    for (a, b) in cx.zip(cy) {
        for l in 0..4 {
            let v = a[l] + b[l];
            s[l] += v;
            m[l] += v.abs();
        }
    }
    finish(s, m, rest)
}

/// The partial sums combined, then the remaining terms added in order.
fn finish(s: [f64; 4], m: [f64; 4], rest: impl Iterator<Item = f64>) -> (f64, f64) {
    let mut total = ((s[0] + s[1]) + (s[2] + s[3]), (m[0] + m[1]) + (m[2] + m[3]));
    for v in rest {
        total.0 += v;
        total.1 += v.abs();
    }
    total
}

/// `M⁻¹ J_blockᵀ` for a 6×6 inverse-mass block, each component summed over the six columns in
/// order.
fn response(m: &[[f64; 6]; 6], j: &[f64; 6]) -> [f64; 6] {
    std::array::from_fn(|r| m[r].iter().zip(j).map(|(a, b)| a * b).sum())
}

/// True when the inverse-mass block is `[m I, 0; 0, I⁻¹]` (a rigid body's, about its centre of
/// mass): a scalar linear part and no linear–angular coupling.
fn is_block_diagonal(m: &[[f64; 6]; 6]) -> bool {
    (0..6).all(|r| {
        (0..6).all(|c| {
            let linear = r < 3 || c < 3;
            !linear || r == c || m[r][c] == 0.0
        })
    }) && m[1][1] == m[0][0]
        && m[2][2] == m[0][0]
}

/// [`response`] of a block-diagonal inverse mass ([`is_block_diagonal`]), skipping the zero
/// products (the same values: adding a zero product leaves a sum unchanged).
fn block_diagonal_response(m: &[[f64; 6]; 6], j: &[f64; 6]) -> [f64; 6] {
    let angular = |r: usize| m[r][3] * j[3] + m[r][4] * j[4] + m[r][5] * j[5];
    [
        m[0][0] * j[0],
        m[1][1] * j[1],
        m[2][2] * j[2],
        angular(3),
        angular(4),
        angular(5),
    ]
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

    /// A random contact-like Jacobian: rows on one or two of `bodies` bodies, pairs' rows
    /// consecutive or (with `shuffle`) interleaved with other pairs', rigid-body inverse masses.
    fn contact_factors(bodies: usize, rows: usize, shuffle: bool, seed: u64) -> DelassusFactors {
        let mut state = seed;
        let mut next = move |m: usize| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) as usize) % m
        };
        let mut row_bodies: Vec<Vec<usize>> = Vec::new();
        while row_bodies.len() < rows {
            let a = next(bodies);
            let b = next(bodies);
            let pair = if a == b || next(4) == 0 {
                vec![a]
            } else {
                vec![a.min(b), a.max(b)]
            };
            for _ in 0..1 + next(6) {
                row_bodies.push(pair.clone());
            }
        }
        row_bodies.truncate(rows);
        if shuffle {
            for i in (1..rows).rev() {
                row_bodies.swap(i, next(i + 1));
            }
        }
        let mut block_ptr = vec![0];
        let mut blocks = Vec::new();
        for pair in &row_bodies {
            for &b in pair {
                let j = std::array::from_fn(|_| next(2001) as f64 / 1000.0 - 1.0);
                blocks.push((b, j));
            }
            block_ptr.push(blocks.len());
        }
        let minv = (0..bodies)
            .map(|b| {
                let mut m = [[0.0; 6]; 6];
                let inv_mass = 1.0 / (1.0 + b as f64);
                for (r, row) in m.iter_mut().enumerate().take(3) {
                    row[r] = inv_mass;
                }
                for (r, row) in m.iter_mut().enumerate().skip(3) {
                    for (c, v) in row.iter_mut().enumerate().skip(3) {
                        *v = if r == c {
                            2.0 * inv_mass
                        } else {
                            0.1 * inv_mass
                        };
                    }
                }
                m
            })
            .collect();
        DelassusFactors::from_row_blocks(block_ptr, blocks, minv).unwrap()
    }

    #[test]
    fn all_rows_at_once_match_row_by_row() {
        for (shuffle, threads) in [(false, 1), (true, 1), (false, 3), (true, 2)] {
            let fac = contact_factors(12, 150, shuffle, 7 + threads as u64);
            let n = fac.rows();
            let f: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 3.0).collect();
            let (mut af, mut mag, mut len) = (vec![0.0; n], vec![0.0; n], vec![0; n]);
            fac.row_terms(&f, &mut af, &mut mag, Some(&mut len), threads);
            for i in 0..n {
                let (s, m, l) = fac.row_dot_and_magnitude(i, &f);
                assert_eq!(len[i], l, "row {i}");
                assert!(
                    (mag[i] - m).abs() <= 1e-13 * m,
                    "row {i}: {} vs {m}",
                    mag[i]
                );
                assert!((af[i] - s).abs() <= 1e-13 * m, "row {i}: {} vs {s}", af[i]);
            }
        }
        // A three-body row takes the row-by-row pass: the same numbers exactly.
        let fac = factors();
        let f = [0.5, -1.0, 2.0, 0.25, 3.0, -0.75];
        let (mut af, mut mag) = (vec![0.0; 6], vec![0.0; 6]);
        fac.row_terms(&f, &mut af, &mut mag, None, 2);
        for i in 0..6 {
            let (s, m, _) = fac.row_dot_and_magnitude(i, &f);
            assert_eq!((af[i], mag[i]), (s, m));
        }
    }

    #[test]
    fn row_terms_do_not_depend_on_the_thread_count() {
        // Each row's sums run in a fixed order whatever the chunk it falls in, so the shared
        // residual is the same to the bit on one thread or several.
        let fac = contact_factors(12, 150, true, 11);
        let n = fac.rows();
        let f: Vec<f64> = (0..n)
            .map(|i| ((i * 29) % 13) as f64 * 0.37 - 2.0)
            .collect();
        let terms = |threads: usize| {
            let (mut af, mut mag) = (vec![0.0; n], vec![0.0; n]);
            fac.row_terms(&f, &mut af, &mut mag, None, threads);
            (af, mag)
        };
        let one = terms(1);
        for threads in [2, 3, 8] {
            assert_eq!(terms(threads), one, "{threads} threads");
        }
    }

    #[test]
    fn blocks_and_compressed_rows_give_the_same_factors() {
        let fac = contact_factors(9, 60, true, 3);
        let again =
            DelassusFactors::new(fac.jacobian().clone(), fac.inverse_mass().to_vec()).unwrap();
        let f: Vec<f64> = (0..fac.rows()).map(|i| (i % 5) as f64 - 1.5).collect();
        assert_eq!(fac.apply(&f), again.apply(&f));
        assert_eq!(fac.nnz(), again.nnz());
        for i in 0..fac.rows() {
            assert_eq!(fac.diagonal(i), again.diagonal(i));
            assert_eq!(
                fac.row_dot_and_magnitude(i, &f),
                again.row_dot_and_magnitude(i, &f)
            );
        }
    }
}

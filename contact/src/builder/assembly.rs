//! Assembly of the step's matrices from the Jacobian rows: the dense `J`, the Delassus matrix
//! `A = J M⁻¹ Jᵀ` in compressed sparse rows (with the pyramid coupling entries), the factors
//! `J`, `M⁻¹` of a subset of rows, and the size limit checked before `A` is assembled.

use super::problem::Subset;
use super::{ContactSystem, JacobianBlock, RowKind};
use crate::body::RigidBody;
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};
use faer::Mat;
use lcpbench_solvers::{DelassusFactors, ProblemError};

/// Problems of at most this many rows are stored dense: for them a dense row is faster than
/// a sparse one and the pivoting solvers need the dense form anyway.
pub const DENSE_ROWS: usize = 24;

/// Most stored entries of one step's assembled Delassus matrix `A` (about 16 bytes each in
/// compressed rows: 800 MB). Every pair of rows on one body couples, so the entries grow with
/// the square of a body's rows: a mesh whose flat bottom touches the ground at 10,201 points
/// asks for 30,603² ≈ 9.4e8 of them, while a pile of 10,000 spheres needs a few million.
pub const MAX_DELASSUS_ENTRIES: usize = 50_000_000;

impl ContactSystem {
    /// An upper bound on the stored entries of `A` as [`ContactSystem::delassus_sparse`]
    /// assembles it (`Σ` over rows of the rows sharing each of its bodies, plus the pyramid
    /// coupling), counted in one pass over the rows before anything is allocated.
    pub fn delassus_entries(&self) -> u128 {
        let mut rows_on = vec![0u128; self.inv_mass.len()];
        for row in &self.rows {
            for blk in &row.blocks {
                rows_on[blk.body] += 1;
            }
        }
        let coupling = self
            .info
            .iter()
            .filter(|c| c.slack_row.is_some())
            .map(|c| 2 * c.friction_rows.len() as u128 + 1)
            .sum::<u128>();
        rows_on.iter().map(|&r| r * r).sum::<u128>() + coupling + self.n() as u128
    }

    /// `Err` with the reason when assembling `A` would store more than
    /// [`MAX_DELASSUS_ENTRIES`] entries, naming the body with the most rows (`bodies` are the
    /// bodies the system was built from).
    pub fn check_delassus_size(&self, bodies: &[RigidBody]) -> Result<(), String> {
        let entries = self.delassus_entries();
        if entries <= MAX_DELASSUS_ENTRIES as u128 {
            return Ok(());
        }
        let mut rows_on = vec![0usize; self.inv_mass.len()];
        for row in &self.rows {
            for blk in &row.blocks {
                rows_on[blk.body] += 1;
            }
        }
        let (body, most) = rows_on
            .iter()
            .enumerate()
            .max_by_key(|(_, &r)| r)
            .map_or((0, 0), |(b, &r)| (b, r));
        let name = bodies.get(body).map_or("?", |b| b.name.as_str());
        Err(format!(
            "the step's Delassus matrix would store {entries} entries ({} rows, {most} of them on \
             body \"{name}\"), beyond the limit of {MAX_DELASSUS_ENTRIES}: every pair of rows on \
             one body couples, so a body touching at thousands of points (a finely meshed flat \
             face on the ground) needs fewer contacts (a coarser mesh, a convex hull) or fewer \
             rows per contact (friction_model = \"none\")",
            self.n()
        ))
    }

    /// The dense Jacobian, `rows × 6·bodies`, columns `[v_k; ω_k]` per body `k`.
    pub fn jacobian(&self) -> Mat<f64> {
        let mut j = Mat::zeros(self.n(), 6 * self.inv_mass.len());
        for (i, row) in self.rows.iter().enumerate() {
            for blk in &row.blocks {
                for d in 0..3 {
                    j[(i, 6 * blk.body + d)] += blk.linear[d];
                    j[(i, 6 * blk.body + 3 + d)] += blk.angular[d];
                }
            }
        }
        j
    }

    /// The dense LCP matrix `A` (a copy of [`ContactSystem::delassus_sparse`]; for tests and
    /// small systems).
    pub fn delassus(&self) -> Mat<f64> {
        self.delassus_sparse().to_dense()
    }

    /// The LCP matrix `A = J M⁻¹ Jᵀ` in compressed sparse rows, plus the pyramid coupling
    /// entries. The slack row and column of a pyramid contact are scaled by `s = A_nn`
    /// (entries `s`, `s mu`, `−s`): the variable is `γ / s` and its row `s (mu f_n − Σ β)`, the
    /// same complementarity problem with entries of one magnitude, which pivoting solvers need.
    /// Assembled body by body in `O(Σ_bodies rows(body)²)`, that is contacts × neighbours.
    pub fn delassus_sparse(&self) -> SparseRowMat<usize, f64> {
        let (rows, bodies) = self.identity();
        self.assemble_delassus(&Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &rows,
            local_body: &bodies,
        })
    }

    /// `(0..rows, 0..bodies)`: the numbering of the whole system.
    pub(super) fn identity(&self) -> (Vec<usize>, Vec<usize>) {
        ((0..self.n()).collect(), (0..self.inv_mass.len()).collect())
    }

    /// `J` (sparse, local numbering) and the 6×6 inverse-mass blocks of the subset's bodies.
    pub(super) fn factors(&self, subset: &Subset) -> Result<DelassusFactors, ProblemError> {
        // Each row's (at most two) blocks in the order of their local bodies.
        let m = subset.rows.len();
        let mut block_ptr = Vec::with_capacity(m + 1);
        let mut row_blocks = Vec::with_capacity(2 * m);
        block_ptr.push(0);
        for &i in subset.rows {
            let blocks = &self.rows[i].blocks;
            let mut order = [0, 1];
            if blocks.len() == 2
                && subset.local_body[blocks[1].body] < subset.local_body[blocks[0].body]
            {
                order = [1, 0];
            }
            for blk in order.iter().filter_map(|&k| blocks.get(k)) {
                row_blocks.push((
                    subset.local_body[blk.body],
                    [
                        blk.linear.x,
                        blk.linear.y,
                        blk.linear.z,
                        blk.angular.x,
                        blk.angular.y,
                        blk.angular.z,
                    ],
                ));
            }
            block_ptr.push(row_blocks.len());
        }
        let blocks = subset
            .bodies
            .iter()
            .map(|&k| {
                let m = &self.inv_mass[k];
                let mut blk = [[0.0; 6]; 6];
                for a in 0..3 {
                    blk[a][a] = m.inv_mass;
                    for c in 0..3 {
                        blk[3 + a][3 + c] = m.inv_inertia[(a, c)];
                    }
                }
                blk
            })
            .collect();
        DelassusFactors::from_row_blocks(block_ptr, row_blocks, blocks)
    }

    /// `A` of the subset's rows in compressed sparse rows. Each row's nonzeros are the rows
    /// that share one of its (at most two) bodies: the two bodies' sorted row lists are merged
    /// and each entry is `J_i,body · (M⁻¹ J_j,bodyᵀ)`, summed over shared bodies.
    pub(super) fn assemble_delassus(&self, subset: &Subset) -> SparseRowMat<usize, f64> {
        let m = subset.rows.len();
        // Per local body: (local row, M⁻¹ J_blockᵀ as [linear; angular]), rows increasing.
        let mut touching: Vec<Vec<(usize, [f64; 6])>> = vec![Vec::new(); subset.bodies.len()];
        for (r, &i) in subset.rows.iter().enumerate() {
            for blk in &self.rows[i].blocks {
                let resp = self.inv_mass[blk.body].response(blk, 1.0);
                let v = [
                    resp.linear.x,
                    resp.linear.y,
                    resp.linear.z,
                    resp.angular.x,
                    resp.angular.y,
                    resp.angular.z,
                ];
                touching[subset.local_body[blk.body]].push((r, v));
            }
        }
        let nnz: usize = subset
            .rows
            .iter()
            .map(|&i| {
                self.rows[i]
                    .blocks
                    .iter()
                    .map(|b| touching[subset.local_body[b.body]].len())
                    .sum::<usize>()
                    + 1
            })
            .sum();
        let mut row_ptr = Vec::with_capacity(m + 1);
        let mut col_idx = Vec::with_capacity(nnz);
        let mut val = Vec::with_capacity(nnz);
        row_ptr.push(0);
        let six = |b: &JacobianBlock| {
            [
                b.linear.x,
                b.linear.y,
                b.linear.z,
                b.angular.x,
                b.angular.y,
                b.angular.z,
            ]
        };
        let dot6 = |a: &[f64; 6], b: &[f64; 6]| -> f64 { (0..6).map(|k| a[k] * b[k]).sum() };
        for &i in subset.rows {
            let start = col_idx.len();
            let blocks = &self.rows[i].blocks;
            match &blocks[..] {
                [] => {}
                [b1] => {
                    let j1 = six(b1);
                    for (c, resp) in &touching[subset.local_body[b1.body]] {
                        col_idx.push(*c);
                        val.push(dot6(&j1, resp));
                    }
                }
                [b1, b2, ..] => {
                    let (j1, j2) = (six(b1), six(b2));
                    let l1 = &touching[subset.local_body[b1.body]];
                    let l2 = &touching[subset.local_body[b2.body]];
                    let (mut p, mut q) = (0, 0);
                    while p < l1.len() || q < l2.len() {
                        let c1 = l1.get(p).map_or(usize::MAX, |e| e.0);
                        let c2 = l2.get(q).map_or(usize::MAX, |e| e.0);
                        let c = c1.min(c2);
                        let mut v = 0.0;
                        if c1 == c {
                            v += dot6(&j1, &l1[p].1);
                            p += 1;
                        }
                        if c2 == c {
                            v += dot6(&j2, &l2[q].1);
                            q += 1;
                        }
                        col_idx.push(c);
                        val.push(v);
                    }
                }
            }
            if let Some(extra) = self.pyramid_coupling(i, subset) {
                for (c, v) in extra {
                    col_idx.push(c);
                    val.push(v);
                }
                let mut entries: Vec<(usize, f64)> = col_idx[start..]
                    .iter()
                    .copied()
                    .zip(val[start..].iter().copied())
                    .collect();
                entries.sort_by_key(|e| e.0);
                for (k, (c, v)) in entries.into_iter().enumerate() {
                    col_idx[start + k] = c;
                    val[start + k] = v;
                }
            }
            row_ptr.push(col_idx.len());
        }
        let symbolic = SymbolicSparseRowMat::new_checked(m, m, row_ptr, None, col_idx);
        SparseRowMat::new(symbolic, val)
    }

    /// The pyramid coupling entries of row `i` (local columns), if it is a direction or slack
    /// row whose partner rows are in the subset.
    fn pyramid_coupling(&self, i: usize, subset: &Subset) -> Option<Vec<(usize, f64)>> {
        let local = |r: usize| Some(subset.local_row[r]).filter(|&l| l != usize::MAX);
        match self.rows[i].kind {
            RowKind::Direction { contact, .. } => {
                let info = &self.info[contact];
                let s = local(info.slack_row?)?;
                Some(vec![(s, info.slack_scale)])
            }
            RowKind::Slack { contact } => {
                let info = &self.info[contact];
                let scale = info.slack_scale;
                let mut v = Vec::with_capacity(1 + info.friction_rows.len());
                if let Some(n) = local(info.normal_row) {
                    v.push((n, scale * info.mu));
                }
                v.extend(
                    info.friction_rows
                        .clone()
                        .filter_map(|d| Some((local(d)?, -scale))),
                );
                Some(v)
            }
            _ => None,
        }
    }
}

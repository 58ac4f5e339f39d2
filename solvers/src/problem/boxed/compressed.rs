//! `A` from compressed sparse parts as scipy stores them, `(indptr, indices, data)` over rows
//! (CSR) or over columns (CSC), checked and brought to the canonical compressed rows a
//! [`Problem`] stores (column indices strictly increasing in each row, repeated entries
//! summed), with the diagonal and the largest magnitude read off in the same pass.
//!
//! * **CSR** (the common case): one pass over the stored entries. Each row's indices are widened
//!   to `usize` and its values copied into the problem's own vectors, then checked while they
//!   are in cache: indices in range and strictly increasing, values finite, `max |A_ij|`, the
//!   diagonal (a binary search). The largest magnitude and the finiteness test are one integer
//!   maximum per entry over the bit patterns of `|A_ij|` ([`row_summary`]). Allocations: the
//!   indices and the values (`nnz` each) and the row offsets and the diagonal (`n` each), each
//!   at its final size. A row whose indices are unsorted or repeated is sorted in place (stably,
//!   so repeats are summed in stored order) before its values are checked, so a sum that
//!   overflows is refused like a stored infinity.
//! * **CSC**: the parts of `Aᵀ` in compressed rows. Transposed by counting: one pass counts each
//!   row's entries (checking every row index), one places them. Columns are visited in order,
//!   so each row's column indices come out increasing whatever the order inside a column;
//!   repeats sit side by side and are summed in one more pass, only when there are any.
//!
//! The offsets are checked first (`O(n)`: start at 0, never decrease, end within the stored
//! entries), so nothing of the declared size is allocated before the parts are known to hold
//! it. Every error names the part (`A.indptr`, `A.indices`, `A.data`), the entry and the limit.

use super::*;
use faer::sparse::SymbolicSparseRowMat;
use std::ops::Range;

/// The bits of `|x|` (all but the sign).
const MAGNITUDE_BITS: u64 = !(1 << 63);

/// The bits of `+∞`. A magnitude's bits are below it exactly when the value is finite: every
/// NaN's magnitude bits exceed it.
const INFINITY_BITS: u64 = 0x7ff0_0000_0000_0000;

/// `A` in canonical compressed rows, with its diagonal and largest magnitude.
struct CheckedRows {
    a: SparseRowMat<usize, f64>,
    diag: Vec<f64>,
    max_abs: f64,
}

impl Problem {
    /// A boxed LCP whose sparse `A` is given as compressed sparse rows in scipy's CSR parts
    /// `(indptr, indices, data)` (`int32` or `int64` indices, as numpy stores them): `n` from
    /// the `n + 1` offsets, row `i`'s entries at `indptr[i]..indptr[i + 1]`. Unsorted and
    /// repeated column indices are allowed (each row sorted, repeats summed); the parts are
    /// read once, into the problem's own vectors (see the module doc of
    /// `problem/boxed/compressed.rs`). Errors as [`Problem::boxed_sparse`], and
    /// [`ProblemError::InvalidCompressed`] naming the part, the entry and the limit.
    pub fn boxed_csr<P, J>(
        a: (&[P], &[J], &[f64]),
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        friction: Vec<FrictionRow>,
    ) -> Result<Self, ProblemError>
    where
        P: Copy + Into<i64>,
        J: Copy + Into<i64>,
    {
        let rows = rows_of_csr(a)?;
        Self::assemble(
            Storage::Sparse(rows.a),
            rows.diag,
            rows.max_abs,
            b,
            lo,
            hi,
            friction,
        )
    }

    /// [`Problem::boxed_csr`] for `A` given as compressed sparse columns, scipy's CSC parts
    /// `(indptr, indices, data)`: column `j`'s row indices and values at
    /// `indptr[j]..indptr[j + 1]`, in any order, repeats summed.
    pub fn boxed_csc<P, J>(
        a: (&[P], &[J], &[f64]),
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        friction: Vec<FrictionRow>,
    ) -> Result<Self, ProblemError>
    where
        P: Copy + Into<i64>,
        J: Copy + Into<i64>,
    {
        let rows = rows_of_csc(a)?;
        Self::assemble(
            Storage::Sparse(rows.a),
            rows.diag,
            rows.max_abs,
            b,
            lo,
            hi,
            friction,
        )
    }

    /// The square matrix of scipy's CSR parts `(indptr, indices, data)` in the canonical
    /// compressed rows [`Problem::boxed_sparse`] takes, checked as by [`Problem::boxed_csr`]:
    /// for a caller that needs the matrix alone (a cone problem's `W`).
    pub fn sparse_from_csr<P, J>(
        a: (&[P], &[J], &[f64]),
    ) -> Result<SparseRowMat<usize, f64>, ProblemError>
    where
        P: Copy + Into<i64>,
        J: Copy + Into<i64>,
    {
        rows_of_csr(a).map(|rows| rows.a)
    }

    /// [`Problem::sparse_from_csr`] for scipy's CSC parts.
    pub fn sparse_from_csc<P, J>(
        a: (&[P], &[J], &[f64]),
    ) -> Result<SparseRowMat<usize, f64>, ProblemError>
    where
        P: Copy + Into<i64>,
        J: Copy + Into<i64>,
    {
        rows_of_csc(a).map(|rows| rows.a)
    }
}

/// An index or offset as stored, widened to `i64`.
#[inline]
fn int<T: Copy + Into<i64>>(v: T) -> i64 {
    v.into()
}

/// An index as `usize`; a negative one (or one beyond `usize`) becomes `usize::MAX`, outside
/// every matrix, so it fails the range test with the others.
#[inline]
fn widen<T: Copy + Into<i64>>(v: T) -> usize {
    usize::try_from(int(v)).unwrap_or(usize::MAX)
}

/// An offset of `indptr`, once [`check_offsets`] has found them all in `0..=stored`.
#[inline]
fn offset<T: Copy + Into<i64>>(v: T) -> usize {
    widen(v)
}

/// The entries of major line (row or column) `k`, once the offsets are checked.
#[inline]
fn line<P: Copy + Into<i64>>(indptr: &[P], k: usize) -> Range<usize> {
    offset(indptr[k])..offset(indptr[k + 1])
}

fn invalid(field: &'static str, message: String) -> ProblemError {
    ProblemError::InvalidCompressed { field, message }
}

/// The lengths of the parts and the offsets, checked before anything of their declared size is
/// allocated: `indices` and `data` equally long, `n + 1` offsets starting at 0, never
/// decreasing, ending within the stored entries (entries past the last offset are ignored).
/// Returns `n`.
fn check_offsets<P, J>(
    (indptr, indices, data): (&[P], &[J], &[f64]),
    major: &str,
) -> Result<usize, ProblemError>
where
    P: Copy + Into<i64>,
{
    if indices.len() != data.len() {
        return Err(invalid(
            "indices",
            format!(
                "A.indices has {} entries but A.data has {}",
                indices.len(),
                data.len()
            ),
        ));
    }
    let Some(n) = indptr.len().checked_sub(1) else {
        return Err(invalid(
            "indptr",
            format!("A.indptr is empty: it holds one offset per {major} and one more"),
        ));
    };
    let first = int(indptr[0]);
    if first != 0 {
        return Err(invalid("indptr", format!("A.indptr[0] is {first}, not 0")));
    }
    if let Some(k) = (0..n).find(|&k| int(indptr[k + 1]) < int(indptr[k])) {
        return Err(invalid(
            "indptr",
            format!(
                "A.indptr decreases at {major} {k} ({} then {})",
                int(indptr[k]),
                int(indptr[k + 1])
            ),
        ));
    }
    // From 0, never decreasing: every offset is at least 0 and at most the last.
    let last = int(indptr[n]);
    match usize::try_from(last) {
        Ok(last) if last <= indices.len() => Ok(n),
        _ => Err(invalid(
            "indptr",
            format!(
                "A.indptr[{n}] = {last} exceeds the {} stored entries",
                indices.len()
            ),
        )),
    }
}

/// The error for entry `entry` of `indices` (in major line `k`), which is negative or `>= n`.
fn index_error(
    major: &str,
    minor: &str,
    k: usize,
    entry: usize,
    value: i64,
    n: usize,
) -> ProblemError {
    let message = if value < 0 {
        format!("A.indices[{entry}] = {value} ({major} {k}) is negative")
    } else {
        format!(
            "A.indices[{entry}] = {value} ({major} {k}) names a {minor} outside the {n}×{n} \
             matrix"
        )
    };
    invalid("indices", message)
}

/// Whether every index is below `n` (no early exit, so the loop is a branch-free reduction).
#[inline]
fn all_below(cols: &[usize], n: usize) -> bool {
    cols.iter().fold(true, |ok, &j| ok & (j < n))
}

/// Whether the indices strictly increase (sorted, no repeats).
#[inline]
pub(super) fn strictly_increasing(cols: &[usize]) -> bool {
    let next = cols.get(1..).unwrap_or(&[]);
    cols.iter().zip(next).fold(true, |ok, (a, b)| ok & (a < b))
}

/// The bit pattern of row `i`'s largest magnitude and its diagonal entry, or `Err(k)` for its
/// first entry that is not finite. For non-negative values (NaN aside) the order of the bit
/// patterns is the order of the values, and every NaN's magnitude bits exceed `+∞`'s, so one
/// integer maximum per entry gives both `max |A_ij|` and the finiteness test.
#[inline]
pub(super) fn row_summary(i: usize, cols: &[usize], vals: &[f64]) -> Result<(u64, f64), usize> {
    let bits = vals
        .iter()
        .fold(0u64, |m, v| m.max(v.to_bits() & MAGNITUDE_BITS));
    if bits >= INFINITY_BITS {
        return Err(vals.iter().position(|v| !v.is_finite()).unwrap_or(0));
    }
    let diagonal = cols.binary_search(&i).map_or(0.0, |k| vals[k]);
    Ok((bits, diagonal))
}

/// The non-finite entry `A[i][j] = value`, stored at `data[entry]` when known.
fn non_finite(i: usize, j: usize, value: f64, entry: Option<usize>) -> ProblemError {
    let what = match entry {
        Some(e) => format!("A[{i}][{j}] (A.data[{e}])"),
        None => format!("A[{i}][{j}]"),
    };
    ProblemError::NonFinite { what, value }
}

/// The entries of one row from `start` on, sorted by column (stably) with repeats summed in
/// stored order, in place. `scratch` is reused between rows.
fn sort_and_sum(
    col_idx: &mut Vec<usize>,
    values: &mut Vec<f64>,
    start: usize,
    scratch: &mut Vec<(usize, f64)>,
) {
    scratch.clear();
    scratch.extend(
        col_idx[start..]
            .iter()
            .copied()
            .zip(values[start..].iter().copied()),
    );
    scratch.sort_by_key(|&(j, _)| j);
    col_idx.truncate(start);
    values.truncate(start);
    for &(j, v) in scratch.iter() {
        let repeat = col_idx.len() > start && col_idx.last() == Some(&j);
        match values.last_mut() {
            Some(sum) if repeat => *sum += v,
            _ => {
                col_idx.push(j);
                values.push(v);
            }
        }
    }
}

/// The checked rows as faer's compressed sparse rows.
fn checked_rows(
    n: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
    diag: Vec<f64>,
    largest: u64,
) -> CheckedRows {
    // SAFETY: faer's invariants of compressed rows, established by the caller's pass: `row_ptr`
    // holds `n + 1` non-decreasing offsets from 0 to `col_idx.len()`, and each row's column
    // indices are strictly increasing and below `n` (checked row by row, or produced so by
    // sorting or by the transposition). `faer` checks the lengths again.
    let symbolic = unsafe { SymbolicSparseRowMat::new_unchecked(n, n, row_ptr, None, col_idx) };
    CheckedRows {
        a: SparseRowMat::new(symbolic, values),
        diag,
        max_abs: f64::from_bits(largest),
    }
}

/// CSR parts to canonical rows in one pass (see the module doc).
fn rows_of_csr<P, J>(parts: (&[P], &[J], &[f64])) -> Result<CheckedRows, ProblemError>
where
    P: Copy + Into<i64>,
    J: Copy + Into<i64>,
{
    let n = check_offsets(parts, "row")?;
    let (indptr, indices, data) = parts;
    let nnz = offset(indptr[n]);
    let mut row_ptr = Vec::with_capacity(n + 1);
    let mut col_idx: Vec<usize> = Vec::with_capacity(nnz);
    let mut values: Vec<f64> = Vec::with_capacity(nnz);
    let mut diag = vec![0.0; n];
    let mut largest = 0u64;
    let mut scratch = Vec::new();
    row_ptr.push(0);
    for (i, d) in diag.iter_mut().enumerate() {
        let stored = line(indptr, i);
        let start = col_idx.len();
        col_idx.extend(indices[stored.clone()].iter().map(|&j| widen(j)));
        values.extend_from_slice(&data[stored.clone()]);
        if !all_below(&col_idx[start..], n) {
            let k = col_idx[start..].iter().position(|&j| j >= n).unwrap_or(0);
            let e = stored.start + k;
            return Err(index_error("row", "column", i, e, int(indices[e]), n));
        }
        let canonical = strictly_increasing(&col_idx[start..]);
        if !canonical {
            sort_and_sum(&mut col_idx, &mut values, start, &mut scratch);
        }
        let (cols, vals) = (&col_idx[start..], &values[start..]);
        let (bits, diagonal) = row_summary(i, cols, vals)
            .map_err(|k| non_finite(i, cols[k], vals[k], canonical.then_some(stored.start + k)))?;
        largest = largest.max(bits);
        *d = diagonal;
        row_ptr.push(col_idx.len());
    }
    Ok(checked_rows(n, row_ptr, col_idx, values, diag, largest))
}

/// CSC parts (the compressed rows of `Aᵀ`) to the canonical rows of `A`, by counting (see the
/// module doc).
fn rows_of_csc<P, J>(parts: (&[P], &[J], &[f64])) -> Result<CheckedRows, ProblemError>
where
    P: Copy + Into<i64>,
    J: Copy + Into<i64>,
{
    let n = check_offsets(parts, "column")?;
    let (indptr, indices, data) = parts;
    let nnz = offset(indptr[n]);
    // Each row's entries counted (every row index checked), then offsets by a running sum.
    let mut row_ptr = vec![0usize; n + 1];
    for k in 0..n {
        for e in line(indptr, k) {
            let i = widen(indices[e]);
            if i >= n {
                return Err(index_error("column", "row", k, e, int(indices[e]), n));
            }
            row_ptr[i + 1] += 1;
        }
    }
    for i in 0..n {
        row_ptr[i + 1] += row_ptr[i];
    }
    // Placed column by column: each row's columns come out non-decreasing, a repeat of an
    // entry right after it.
    let mut next = row_ptr[..n].to_vec();
    let mut col_idx = vec![0usize; nnz];
    let mut values = vec![0.0f64; nnz];
    let mut repeats = false;
    for k in 0..n {
        for e in line(indptr, k) {
            let i = widen(indices[e]);
            let p = next[i];
            repeats |= p > row_ptr[i] && col_idx[p - 1] == k;
            col_idx[p] = k;
            values[p] = data[e];
            next[i] = p + 1;
        }
    }
    if repeats {
        sum_adjacent(&mut row_ptr, &mut col_idx, &mut values);
    }
    let mut diag = vec![0.0; n];
    let mut largest = 0u64;
    for (i, d) in diag.iter_mut().enumerate() {
        let (cols, vals) = (
            &col_idx[row_ptr[i]..row_ptr[i + 1]],
            &values[row_ptr[i]..row_ptr[i + 1]],
        );
        let (bits, diagonal) =
            row_summary(i, cols, vals).map_err(|k| non_finite(i, cols[k], vals[k], None))?;
        largest = largest.max(bits);
        *d = diagonal;
    }
    Ok(checked_rows(n, row_ptr, col_idx, values, diag, largest))
}

/// Rows whose columns are non-decreasing, with each run of equal columns summed into one entry
/// (in stored order), compacted in place; `row_ptr` updated.
fn sum_adjacent(row_ptr: &mut [usize], col_idx: &mut Vec<usize>, values: &mut Vec<f64>) {
    let mut out = 0;
    let mut start = 0;
    for i in 0..row_ptr.len() - 1 {
        let end = row_ptr[i + 1];
        let first = out;
        for e in start..end {
            if out > first && col_idx[out - 1] == col_idx[e] {
                values[out - 1] += values[e];
            } else {
                col_idx[out] = col_idx[e];
                values[out] = values[e];
                out += 1;
            }
        }
        row_ptr[i + 1] = out;
        start = end;
    }
    col_idx.truncate(out);
    values.truncate(out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `A` entry by entry, from its stored rows.
    fn dense_of(p: &Problem) -> Vec<Vec<f64>> {
        let n = p.n();
        (0..n)
            .map(|i| (0..n).map(|j| p.entry(i, j)).collect())
            .collect()
    }

    fn lcp_csr(parts: (&[i32], &[i32], &[f64])) -> Result<Problem, ProblemError> {
        let n = parts.0.len().saturating_sub(1);
        Problem::boxed_csr(
            parts,
            vec![-1.0; n],
            vec![0.0; n],
            vec![f64::INFINITY; n],
            vec![],
        )
    }

    fn lcp_csc(parts: (&[i64], &[i64], &[f64])) -> Result<Problem, ProblemError> {
        let n = parts.0.len().saturating_sub(1);
        Problem::boxed_csc(
            parts,
            vec![-1.0; n],
            vec![0.0; n],
            vec![f64::INFINITY; n],
            vec![],
        )
    }

    /// Random triplets with repeats, in random order, of small dyadic values (so that every sum
    /// is exact whatever its order), as CSR and CSC parts in stored (unsorted) order.
    #[allow(clippy::type_complexity)]
    fn random_parts(
        rng: &mut ChaCha8Rng,
        n: usize,
    ) -> (
        Vec<(usize, usize, f64)>,
        (Vec<i32>, Vec<i32>, Vec<f64>),
        (Vec<i64>, Vec<i64>, Vec<f64>),
    ) {
        let count = rng.random_range(0..4 * n);
        let triplets: Vec<(usize, usize, f64)> = (0..count)
            .map(|_| {
                let v = rng.random_range(-64i32..64) as f64 / 8.0;
                (rng.random_range(0..n), rng.random_range(0..n), v)
            })
            .collect();
        let pack = |major: &dyn Fn(&(usize, usize, f64)) -> (usize, usize)| {
            let mut ptr = vec![0usize; n + 1];
            for t in &triplets {
                ptr[major(t).0 + 1] += 1;
            }
            for k in 0..n {
                ptr[k + 1] += ptr[k];
            }
            let mut next = ptr.clone();
            let mut idx = vec![0usize; triplets.len()];
            let mut val = vec![0.0; triplets.len()];
            for t in &triplets {
                let (k, minor) = major(t);
                idx[next[k]] = minor;
                val[next[k]] = t.2;
                next[k] += 1;
            }
            (ptr, idx, val)
        };
        let (p, i, v) = pack(&|t| (t.0, t.1));
        let csr = (
            p.iter().map(|&x| x as i32).collect(),
            i.iter().map(|&x| x as i32).collect(),
            v,
        );
        let (p, i, v) = pack(&|t| (t.1, t.0));
        let csc = (
            p.iter().map(|&x| x as i64).collect(),
            i.iter().map(|&x| x as i64).collect(),
            v,
        );
        (triplets, csr, csc)
    }

    /// CSR and CSC parts with repeats and unsorted indices give the problem that the triplets
    /// give: the same entries, stored pattern, diagonal and largest magnitude (checked against
    /// sums formed here, entry by entry).
    #[test]
    fn csr_and_csc_parts_match_the_triplets() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x05ee_dc5a);
        for case in 0..60 {
            let n = 1 + case % 9;
            let (triplets, csr, csc) = random_parts(&mut rng, n);
            let mut expected = vec![vec![0.0; n]; n];
            let mut stored = vec![vec![false; n]; n];
            for &(i, j, v) in &triplets {
                expected[i][j] += v;
                stored[i][j] = true;
            }
            let from_triplets =
                Problem::lcp_sparse(sparse_from_triplets(n, &triplets).unwrap(), vec![-1.0; n])
                    .unwrap();
            let a = lcp_csr((&csr.0, &csr.1, &csr.2)).unwrap();
            let b = lcp_csc((&csc.0, &csc.1, &csc.2)).unwrap();
            let largest = expected
                .iter()
                .flatten()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            for p in [&a, &b] {
                assert_eq!(dense_of(p), expected, "case {case}");
                assert_eq!(p.nnz(), stored.iter().flatten().filter(|&&s| s).count());
                assert_eq!(p.max_abs_entry(), largest);
                for (i, row) in expected.iter().enumerate() {
                    assert_eq!(p.diagonal(i), row[i]);
                    let cols: Vec<usize> = p.row(i).iter().map(|(j, _)| j).collect();
                    let want: Vec<usize> = (0..n).filter(|&j| stored[i][j]).collect();
                    assert_eq!(cols, want, "case {case}, row {i}");
                }
                let f: Vec<f64> = (0..n).map(|k| k as f64 * 0.5 - 1.0).collect();
                assert_eq!(p.velocity(&f), from_triplets.velocity(&f));
            }
        }
    }

    /// A canonical CSR is taken as stored, and the problem equals the one `boxed_sparse` builds
    /// from faer's compressed rows, in both index widths.
    #[test]
    fn canonical_csr_is_taken_as_stored() {
        // [[4, -1, 0], [-1, 4, 2], [0, 2, 5]]
        let ptr = [0i64, 2, 5, 7];
        let idx = [0i64, 1, 0, 1, 2, 1, 2];
        let val = [4.0, -1.0, -1.0, 4.0, 2.0, 2.0, 5.0];
        let p = Problem::boxed_csr(
            (&ptr[..], &idx[..], &val[..]),
            vec![-1.0, 0.5, -2.0],
            vec![0.0; 3],
            vec![f64::INFINITY; 3],
            vec![],
        )
        .unwrap();
        let narrow: Vec<i32> = idx.iter().map(|&j| j as i32).collect();
        let q = lcp_csr((&[0, 2, 5, 7], &narrow, &val)).unwrap();
        let rows = [0, 0, 1, 1, 1, 2, 2];
        let t: Vec<_> = (0..7).map(|e| (rows[e], idx[e] as usize, val[e])).collect();
        let r = Problem::lcp_sparse(sparse_from_triplets(3, &t).unwrap(), vec![-1.0; 3]).unwrap();
        for x in [&p, &q] {
            assert_eq!(dense_of(x), dense_of(&r));
            assert_eq!(x.max_abs_entry(), 5.0);
            assert_eq!(
                (0..3).map(|i| x.diagonal(i)).collect::<Vec<_>>(),
                [4.0, 4.0, 5.0]
            );
        }
        assert_eq!(p.b(), &[-1.0, 0.5, -2.0]);
        let m = Problem::sparse_from_csr((&ptr[..], &idx[..], &val[..])).unwrap();
        assert_eq!(m.val(), &val[..]);
        // The CSC parts of a symmetric matrix are its CSR parts.
        let c = Problem::sparse_from_csc((&ptr[..], &idx[..], &val[..])).unwrap();
        assert_eq!(c.to_dense(), m.to_dense());
    }

    /// Repeats are summed in stored order before the finiteness test: two finite entries whose
    /// sum overflows are refused, and two infinite ones that would cancel are refused too.
    #[test]
    fn summed_repeats_are_checked() {
        let e = lcp_csr((&[0, 2], &[0, 0], &[1e308, 1e308])).unwrap_err();
        assert_eq!(e.to_string(), "A[0][0] is not finite (inf)");
        let e = lcp_csc((&[0, 2], &[0, 0], &[1e308, 1e308])).unwrap_err();
        assert_eq!(e.to_string(), "A[0][0] is not finite (inf)");
        let e = lcp_csr((&[0, 2], &[0, 0], &[f64::INFINITY, f64::NEG_INFINITY])).unwrap_err();
        assert!(matches!(e, ProblemError::NonFinite { .. }), "{e}");
        // 1 + 2^-53 + 2^-53 in stored order rounds to 1; summed the other way round it would not.
        let tiny = f64::EPSILON / 2.0;
        let p = lcp_csr((&[0, 3], &[0, 0, 0], &[1.0, tiny, tiny])).unwrap();
        assert_eq!(p.entry(0, 0), 1.0);
        let p = lcp_csr((&[0, 3], &[0, 0, 0], &[tiny, tiny, 1.0])).unwrap();
        assert_eq!(p.entry(0, 0), 1.0 + f64::EPSILON);
    }

    /// CSR parts in int32 and the message they are refused with.
    type Malformed<'a> = (&'a [i32], &'a [i32], &'a [f64], &'a str);

    /// Every malformed part is refused with the part, the entry and the limit named.
    #[test]
    fn malformed_parts_are_refused_naming_the_part() {
        let val = [1.0, 1.0];
        let cases: [Malformed; 8] = [
            (
                &[],
                &[],
                &[],
                "A.indptr is empty: it holds one offset per row and one more",
            ),
            (
                &[0, 1, 2],
                &[0, 1],
                &[1.0],
                "A.indices has 2 entries but A.data has 1",
            ),
            (&[1, 1, 2], &[0, 1], &val, "A.indptr[0] is 1, not 0"),
            (
                &[0, 2, 1],
                &[0, 1],
                &val,
                "A.indptr decreases at row 1 (2 then 1)",
            ),
            (
                &[0, 1, 3],
                &[0, 1],
                &val,
                "A.indptr[2] = 3 exceeds the 2 stored entries",
            ),
            (
                &[0, 1, 2],
                &[0, 2],
                &val,
                "A.indices[1] = 2 (row 1) names a column outside the 2×2 matrix",
            ),
            (
                &[0, 1, 2],
                &[0, -1],
                &val,
                "A.indices[1] = -1 (row 1) is negative",
            ),
            (
                &[0, 1, 2],
                &[0, 1],
                &[1.0, f64::NAN],
                "A[1][1] (A.data[1]) is not finite (NaN)",
            ),
        ];
        for (ptr, idx, data, message) in cases {
            let e = lcp_csr((ptr, idx, data)).unwrap_err();
            assert_eq!(e.to_string(), message);
            let m = Problem::sparse_from_csr((ptr, idx, data)).unwrap_err();
            assert_eq!(m.to_string(), message);
        }
        let e = lcp_csc((&[0, 1, 2], &[0, 5], &val)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "A.indices[1] = 5 (column 1) names a row outside the 2×2 matrix"
        );
        let e = lcp_csc((&[0, 1, 2], &[1, 0], &[1.0, f64::NAN])).unwrap_err();
        assert_eq!(e.to_string(), "A[0][1] is not finite (NaN)");
        // Entries past the last offset are not part of the matrix.
        let p = lcp_csr((&[0, 1, 2], &[0, 1, 7], &[2.0, 3.0, f64::NAN])).unwrap();
        assert_eq!((p.nnz(), p.entry(1, 1)), (2, 3.0));
        // The vectors are checked against n as for every other constructor.
        let e = Problem::boxed_csr(
            (&[0i32, 1], &[0i32], &[1.0]),
            vec![0.0; 2],
            vec![0.0; 2],
            vec![1.0; 2],
            vec![],
        )
        .unwrap_err();
        assert!(matches!(
            e,
            ProblemError::DimensionMismatch { what: "b", .. }
        ));
    }

    #[test]
    fn row_summary_reads_magnitudes_from_bits() {
        let cols = [0, 2, 5];
        assert_eq!(
            row_summary(2, &cols, &[-3.0, 0.5, -0.0]),
            Ok(((3.0f64).to_bits(), 0.5))
        );
        assert_eq!(row_summary(1, &cols, &[-0.0, 0.0, 0.0]), Ok((0, 0.0)));
        assert_eq!(
            row_summary(0, &cols, &[1.0, f64::NAN, f64::INFINITY]),
            Err(1)
        );
        assert_eq!(row_summary(0, &cols, &[-f64::INFINITY, 1.0, 1.0]), Err(0));
        assert_eq!(
            row_summary(0, &cols, &[f64::MAX, -f64::MIN_POSITIVE, 5e-324]),
            Ok((f64::MAX.to_bits(), f64::MAX))
        );
        assert!(strictly_increasing(&[]) && strictly_increasing(&[3]));
        assert!(strictly_increasing(&[0, 1, 9]) && !strictly_increasing(&[0, 1, 1]));
        assert!(!strictly_increasing(&[2, 1]));
    }
}

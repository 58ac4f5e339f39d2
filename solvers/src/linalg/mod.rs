//! Linear algebra the solvers share: a sparse LU with a reusable symbolic analysis, a dense LU
//! with diagonal pivoting that reveals the rank, and the fill estimate that guards the
//! factorisations no budget can interrupt.

pub(crate) mod krylov;
pub(crate) mod newton_system;
pub(crate) mod pivoted_lu;
pub(crate) mod sparse_lu;

use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, SymmetricOrdering};
use faer::sparse::{Pair, SymbolicSparseColMat, SymbolicSparseColMatRef};

/// Entries of the Cholesky factor of a symmetric `pattern` (its lower triangle under faer's
/// approximate-minimum-degree ordering), from the symbolic analysis alone: `O(nnz)` work, no
/// arithmetic. It bounds the cost of a factorisation before it starts (none can be
/// interrupted). `None` when the analysis fails (out of memory).
pub(crate) fn cholesky_fill(pattern: SymbolicSparseColMatRef<'_, usize>) -> Option<usize> {
    factorize_symbolic_cholesky(
        pattern,
        faer::Side::Lower,
        SymmetricOrdering::Amd,
        Default::default(),
    )
    .ok()
    .map(|symbolic| symbolic.len_val())
}

/// [`cholesky_fill`] of the `size × size` pattern made of `pairs`, their transposes and the
/// diagonal.
pub(crate) fn symmetric_fill(size: usize, pairs: &[(usize, usize)]) -> Option<usize> {
    let mut all: Vec<Pair<usize, usize>> = Vec::with_capacity(2 * pairs.len() + size);
    for &(row, col) in pairs {
        all.push(Pair { row, col });
        all.push(Pair { row: col, col: row });
    }
    all.extend((0..size).map(|i| Pair { row: i, col: i }));
    let (pattern, _) = SymbolicSparseColMat::try_new_from_indices(size, size, &all).ok()?;
    cholesky_fill(pattern.as_ref())
}

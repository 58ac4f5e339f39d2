//! Linear algebra the solvers share: a sparse LU with a reusable symbolic analysis.

pub(crate) mod newton_system;
pub(crate) mod sparse_lu;

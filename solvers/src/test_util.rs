//! Helpers shared by the solvers' unit tests.

use crate::problem::Problem;
use faer::Mat;

/// A square matrix from its rows.
pub(crate) fn mat(rows: &[&[f64]]) -> Mat<f64> {
    Mat::from_fn(rows.len(), rows.len(), |i, j| rows[i][j])
}

/// A standard LCP from the rows of `A` and `b`.
pub(crate) fn lcp(rows: &[&[f64]], b: &[f64]) -> Problem {
    Problem::lcp(mat(rows), b.to_vec()).unwrap()
}

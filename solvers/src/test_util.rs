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

/// An `n = 4` LCP with exactly three solutions whose matrix is not copositive-plus (its diagonal
/// has negative entries), on which Lemke's method with covering vector `e` ends in a ray — the
/// kind of example Cottle–Pang–Stone (1992, §4.4) use to show that a ray proves nothing outside
/// the copositive-plus class. The solutions, checked over all 16 complementary bases in exact
/// arithmetic: `(0, 7/5, 0, 11/5)`, `(12/13, 23/13, 0, 31/13)` and `(6, 0, 6, 10)`.
pub(crate) fn three_solution_lcp() -> Problem {
    lcp(
        &[
            &[-3.0, 0.0, 0.0, 2.0],
            &[0.0, -1.0, 2.0, 2.0],
            &[-1.0, 2.0, 1.0, 0.0],
            &[-1.0, 3.0, 3.0, -1.0],
        ],
        &[-2.0, -3.0, 0.0, -2.0],
    )
}

/// The three solutions of [`three_solution_lcp`].
pub(crate) const THREE_SOLUTIONS: [[f64; 4]; 3] = [
    [0.0, 7.0 / 5.0, 0.0, 11.0 / 5.0],
    [12.0 / 13.0, 23.0 / 13.0, 0.0, 31.0 / 13.0],
    [6.0, 0.0, 6.0, 10.0],
];

//! The rule every Gauss–Seidel style update uses to decide which rows it may divide by.

use super::Problem;

/// A diagonal entry at most this fraction of `A`'s largest absolute entry is treated as zero: a
/// sweep leaves the row alone rather than divide by it. `1e-12` is about `10⁴` machine epsilons
/// (`ε ≈ 2.2e-16`), well below any diagonal a contact row of a physical Delassus matrix has and
/// well above the round-off left on a diagonal that is zero in exact arithmetic.
pub(crate) const TINY_DIAGONAL: f64 = 1e-12;

/// Whether row `i`'s diagonal is too small to divide by ([`TINY_DIAGONAL`]).
fn is_tiny(problem: &Problem, i: usize) -> bool {
    problem.diagonal(i) <= TINY_DIAGONAL * problem.max_abs_entry()
}

/// The rows a sweep leaves alone: those whose diagonal is tiny ([`TINY_DIAGONAL`]).
pub(crate) fn skipped_rows(problem: &Problem) -> Vec<bool> {
    (0..problem.n()).map(|i| is_tiny(problem, i)).collect()
}

/// The diagonal of `A` with the tiny entries ([`TINY_DIAGONAL`]) set to zero, so that a sweep
/// can test `d_i > 0` before dividing.
pub(crate) fn usable_diagonal(problem: &Problem) -> Vec<f64> {
    (0..problem.n())
        .map(|i| {
            if is_tiny(problem, i) {
                0.0
            } else {
                problem.diagonal(i)
            }
        })
        .collect()
}

//! Ray termination of the pivoting methods ([`crate::Lemke`], [`crate::Dantzig`]): what an
//! unblocked pivot says about the problem.
//!
//! A drive that no ratio test blocks ends the method. When the matrix the method pivots on is
//! positive semidefinite (for Lemke, `M + Mᵀ` PSD, which makes `M` copositive-plus) the ray
//! proves that no solution exists (Cottle–Pang–Stone 1992, Thm 4.4.13; for Dantzig's principal
//! pivoting on a symmetric PSD `A`, §4.2). On any other matrix it proves nothing, and both
//! methods report the same verdict: `Stalled`, the method met its own stopping rule without a
//! solution. The verdict is not `Unsupported`: the problem was inside what the method attempts
//! (neither method can tell the matrix class before it pivots), and a ray on it says only that
//! this run ended without an answer, which is what `Stalled` names.

use crate::solver::Outcome;
use faer::MatRef;

/// An eigenvalue of the symmetric matrix down to `−PSD_EIGENVALUE_TOLERANCE · n · scale` counts
/// as zero (`scale` the matrix's largest entry): the backward error of a symmetric eigenvalue
/// decomposition is a modest multiple of `n · ε · ‖M‖` (`ε ≈ 2.2e-16`), and `1e-10` leaves room
/// for the round-off already in a Delassus matrix assembled from `J M⁻¹ Jᵀ`.
pub(crate) const PSD_EIGENVALUE_TOLERANCE: f64 = 1e-10;

/// True when the symmetric `sym` is positive semidefinite to within round-off
/// ([`PSD_EIGENVALUE_TOLERANCE`] of `scale`). A failed decomposition counts as not PSD.
pub(crate) fn is_psd(sym: MatRef<'_, f64>, scale: f64) -> bool {
    let n = sym.nrows() as f64;
    sym.self_adjoint_eigenvalues(faer::Side::Lower)
        .is_ok_and(|ev| {
            ev.iter()
                .all(|&l| l >= -PSD_EIGENVALUE_TOLERANCE * scale * n)
        })
}

/// The outcome of a ray described by `what`: `NoSolution` with `proof` when `psd`, otherwise
/// `Stalled` with `no_proof` (see the module documentation).
pub(crate) fn ray_outcome(what: &str, psd: bool, proof: &str, no_proof: &str) -> Outcome {
    if psd {
        Outcome::NoSolution(format!("{what}; {proof}"))
    } else {
        Outcome::Stalled(format!("{what}; {no_proof}"))
    }
}

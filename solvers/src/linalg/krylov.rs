//! Krylov solvers for the Newton systems, applied matrix-free: restarted GMRES with right
//! preconditioning, generic over the operator (a closure `x ↦ H x`) and the preconditioner
//! (`x ↦ M⁻¹ x`), and the per-contact block-Jacobi preconditioner.
//!
//! GMRES(m) (Saad and Schultz, SIAM J. Sci. Stat. Comput. 7, 1986; Saad, *Iterative Methods for
//! Sparse Linear Systems*, 2nd ed. 2003, §6.5 and §9.3.2) builds an orthonormal basis of the
//! Krylov space of `H M⁻¹` by modified Gram–Schmidt, keeps the Hessenberg matrix reduced to
//! triangular form by Givens rotations (so the residual norm of the current iterate is known at
//! every step without forming it), and restarts from the current iterate after `m` steps.
//! With the preconditioner on the right the residual it minimises is the residual of the
//! system itself, `‖b − H x‖`, so its tolerance means the same with and without `M`.
//!
//! * **Cost**: per iteration one product with `H`, one with `M⁻¹`, and `O(j n)` for the
//!   orthogonalisation against the `j` basis vectors of the cycle; `(m + 1) n` storage.
//! * **Stopping rule**: `‖b − H x‖ <= tolerance · ‖b‖` ([`KrylovStatus::Converged`]).
//! * **Failure modes**, each reported with the best iterate found (GMRES' residual never
//!   grows): the iteration cap, the time check between iterations, a *breakdown* (an
//!   invariant Krylov space whose least-squares residual is not zero, as for a singular `H`
//!   with `b` outside its range, or a non-finite product) and *stagnation* (a restart cycle
//!   that lowers the residual by less than [`STAGNATION_FACTOR`]: GMRES(m) can stall on an
//!   indefinite `H`).

/// A restart cycle that leaves the residual above this fraction of its value at the start of
/// the cycle counts as stagnation.
pub(crate) const STAGNATION_FACTOR: f64 = 0.999;

/// Settings of [`gmres`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GmresParams {
    /// Basis vectors per cycle, `m` (at least 1).
    pub(crate) restart: usize,
    /// Products with `H` in all, over every cycle.
    pub(crate) max_iterations: usize,
    /// Relative residual `‖b − H x‖ / ‖b‖` to reach.
    pub(crate) tolerance: f64,
}

/// How a Krylov solve ended.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum KrylovStatus {
    /// The relative residual is within the tolerance.
    Converged,
    /// [`GmresParams::max_iterations`] products with `H` were taken.
    IterationLimit,
    /// The time check between iterations said stop.
    TimeLimit,
    /// The Krylov space became invariant short of the tolerance, or a product was not finite.
    Breakdown(String),
    /// A restart cycle did not lower the residual by the factor [`STAGNATION_FACTOR`].
    Stagnation,
}

/// The result of a Krylov solve: the best iterate and its relative residual.
#[derive(Debug, Clone)]
pub(crate) struct KrylovResult {
    pub(crate) x: Vec<f64>,
    /// Products with `H`.
    pub(crate) iterations: usize,
    /// `‖b − H x‖ / ‖b‖` of `x` (the Givens estimate within a cycle, recomputed at each
    /// restart).
    pub(crate) rel_residual: f64,
    pub(crate) status: KrylovStatus,
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// Restarted GMRES with right preconditioning from `x = 0`: `H x = b` with `apply(x, out)`
/// writing `H x` and `precondition(x, out)` writing `M⁻¹ x`; `stop()` is asked before each
/// iteration whether time is up. See the module documentation.
pub(crate) fn gmres(
    mut apply: impl FnMut(&[f64], &mut [f64]),
    mut precondition: impl FnMut(&[f64], &mut [f64]),
    b: &[f64],
    params: &GmresParams,
    mut stop: impl FnMut() -> bool,
) -> KrylovResult {
    let n = b.len();
    let m = params.restart.max(1);
    let mut x = vec![0.0; n];
    let bnorm = norm(b);
    if bnorm == 0.0 {
        return KrylovResult {
            x,
            iterations: 0,
            rel_residual: 0.0,
            status: KrylovStatus::Converged,
        };
    }
    if !bnorm.is_finite() {
        return KrylovResult {
            x,
            iterations: 0,
            rel_residual: f64::NAN,
            status: KrylovStatus::Breakdown("the right-hand side is not finite".into()),
        };
    }
    let target = params.tolerance * bnorm;
    let mut r = b.to_vec();
    let mut beta = bnorm;
    let mut iterations = 0;
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
    // Column j of the Hessenberg matrix, rotated: `hess[j][0..=j+1]`.
    let mut hess: Vec<Vec<f64>> = Vec::with_capacity(m);
    let (mut cs, mut sn) = (vec![0.0; m], vec![0.0; m]);
    let mut z = vec![0.0; n];
    let mut w = vec![0.0; n];
    loop {
        let cycle_start = beta;
        basis.clear();
        hess.clear();
        basis.push(r.iter().map(|v| v / beta).collect());
        let mut g = vec![0.0; m + 1];
        g[0] = beta;
        let mut status = None;
        let mut resid = beta;
        for j in 0..m {
            if resid <= target {
                status = Some(KrylovStatus::Converged);
                break;
            }
            if iterations >= params.max_iterations {
                status = Some(KrylovStatus::IterationLimit);
                break;
            }
            if stop() {
                status = Some(KrylovStatus::TimeLimit);
                break;
            }
            precondition(&basis[j], &mut z);
            apply(&z, &mut w);
            iterations += 1;
            if w.iter().any(|v| !v.is_finite()) {
                status = Some(KrylovStatus::Breakdown(format!(
                    "a product with the operator was not finite at Krylov iteration {iterations}"
                )));
                break;
            }
            let wnorm0 = norm(&w);
            let mut h = vec![0.0; j + 2];
            for (i, v) in basis.iter().enumerate() {
                let hij = dot(&w, v);
                h[i] = hij;
                for (wk, vk) in w.iter_mut().zip(v) {
                    *wk -= hij * vk;
                }
            }
            let hnext = norm(&w);
            h[j + 1] = hnext;
            for i in 0..j {
                let t = cs[i] * h[i] + sn[i] * h[i + 1];
                h[i + 1] = -sn[i] * h[i] + cs[i] * h[i + 1];
                h[i] = t;
            }
            let rho = h[j].hypot(h[j + 1]);
            // A zero pivot of the rotated Hessenberg matrix: the new direction adds nothing
            // (singular `H M⁻¹`); the column is left out of the least-squares solve.
            if rho.is_nan() || rho <= 1e-13 * wnorm0 {
                status = Some(KrylovStatus::Breakdown(format!(
                    "the preconditioned operator maps a basis vector to zero at Krylov \
                     iteration {iterations} (singular system)"
                )));
                break;
            }
            cs[j] = h[j] / rho;
            sn[j] = h[j + 1] / rho;
            h[j] = rho;
            h[j + 1] = 0.0;
            g[j + 1] = -sn[j] * g[j];
            g[j] *= cs[j];
            hess.push(h);
            resid = g[j + 1].abs();
            // An invariant Krylov space: the least-squares solution in it is final.
            if hnext <= 1e-14 * wnorm0 {
                status = Some(if resid <= target {
                    KrylovStatus::Converged
                } else {
                    KrylovStatus::Breakdown(format!(
                        "the Krylov space became invariant at iteration {iterations} with the \
                         relative residual at {:.2e} (singular system)",
                        resid / bnorm
                    ))
                });
                break;
            }
            basis.push(w.iter().map(|v| v / hnext).collect());
        }
        // x += M⁻¹ V y with the triangular solve of the rotated Hessenberg columns.
        let k = hess.len();
        if k > 0 {
            let mut y = g[..k].to_vec();
            for i in (0..k).rev() {
                let mut s = y[i];
                for (c, col) in hess.iter().enumerate().skip(i + 1) {
                    s -= col[i] * y[c];
                }
                y[i] = s / hess[i][i];
            }
            let mut v = vec![0.0; n];
            for (c, yc) in y.iter().enumerate() {
                for (vk, bk) in v.iter_mut().zip(&basis[c]) {
                    *vk += yc * bk;
                }
            }
            precondition(&v, &mut z);
            for (xk, zk) in x.iter_mut().zip(&z) {
                *xk += zk;
            }
        }
        // The true residual, for the next cycle and the report.
        apply(&x, &mut w);
        for i in 0..n {
            r[i] = b[i] - w[i];
        }
        beta = norm(&r);
        let status = match status {
            Some(s) => Some(s),
            None if beta <= target => Some(KrylovStatus::Converged),
            None if beta.is_nan() || beta >= STAGNATION_FACTOR * cycle_start => {
                Some(KrylovStatus::Stagnation)
            }
            None => None,
        };
        if let Some(status) = status {
            // The Givens estimate can say converged where the recomputed residual does not
            // (round-off in the basis); the recomputed one decides.
            let status = match status {
                KrylovStatus::Converged if beta > target => {
                    if beta < STAGNATION_FACTOR * cycle_start {
                        continue;
                    }
                    KrylovStatus::Stagnation
                }
                s => s,
            };
            return KrylovResult {
                x,
                iterations,
                rel_residual: beta / bnorm,
                status,
            };
        }
    }
}

/// The block-Jacobi preconditioner: the inverses of diagonal blocks of `H`, one per group of
/// rows (a contact's normal and friction rows; 1×1 for any other row).
#[derive(Debug, Clone, Default)]
pub(crate) struct BlockJacobi {
    /// Row `rows[ptr[g] + a]` is the `a`-th row of group `g`.
    rows: Vec<usize>,
    ptr: Vec<usize>,
    /// The inverse of group `g`'s block, row-major, from `inv_ptr[g]`.
    inv: Vec<f64>,
    inv_ptr: Vec<usize>,
}

impl BlockJacobi {
    /// The groups given as `(rows, ptr)`, with no inverse yet (the identity).
    pub(crate) fn new(rows: Vec<usize>, ptr: Vec<usize>) -> Self {
        let mut inv_ptr = Vec::with_capacity(ptr.len());
        let mut total = 0;
        for g in 0..ptr.len() - 1 {
            inv_ptr.push(total);
            let s = ptr[g + 1] - ptr[g];
            total += s * s;
        }
        let mut inv = vec![0.0; total];
        for g in 0..ptr.len() - 1 {
            let s = ptr[g + 1] - ptr[g];
            for a in 0..s {
                inv[inv_ptr[g] + a * s + a] = 1.0;
            }
        }
        Self {
            rows,
            ptr,
            inv,
            inv_ptr,
        }
    }

    /// Entries over all blocks, in the layout `update`'s `entry` is given (group by group,
    /// each block row-major).
    pub(crate) fn len(&self) -> usize {
        self.inv.len()
    }

    /// Inverts each group's block: `entry(k, i, j)` is its entry at rows `i`, `j` of the group,
    /// `k` the entry's position in the layout of [`BlockJacobi::len`]. A block that is
    /// singular to working precision is replaced by the inverse of its diagonal (entries that
    /// are zero taken as one).
    pub(crate) fn update(&mut self, mut entry: impl FnMut(usize, usize, usize) -> f64) {
        let mut block = Vec::new();
        for g in 0..self.ptr.len() - 1 {
            let rows = &self.rows[self.ptr[g]..self.ptr[g + 1]];
            let s = rows.len();
            let first = self.inv_ptr[g];
            block.clear();
            for (a, &i) in rows.iter().enumerate() {
                for (c, &j) in rows.iter().enumerate() {
                    block.push(entry(first + a * s + c, i, j));
                }
            }
            let out = &mut self.inv[first..first + s * s];
            if !invert(&mut block, s, out) {
                out.iter_mut().for_each(|v| *v = 0.0);
                for (a, &i) in rows.iter().enumerate() {
                    let d = entry(first + a * s + a, i, i);
                    out[a * s + a] = if d != 0.0 && d.is_finite() {
                        1.0 / d
                    } else {
                        1.0
                    };
                }
            }
        }
    }

    /// `out = M⁻¹ x`.
    pub(crate) fn apply(&self, x: &[f64], out: &mut [f64]) {
        for g in 0..self.ptr.len() - 1 {
            let rows = &self.rows[self.ptr[g]..self.ptr[g + 1]];
            let s = rows.len();
            let inv = &self.inv[self.inv_ptr[g]..self.inv_ptr[g] + s * s];
            for (a, &i) in rows.iter().enumerate() {
                out[i] = rows
                    .iter()
                    .enumerate()
                    .map(|(c, &j)| inv[a * s + c] * x[j])
                    .sum();
            }
        }
    }
}

/// The inverse of the `s × s` row-major `a` into `out` by Gauss–Jordan elimination with partial
/// pivoting; false when a pivot is below `1e-13` of the block's largest entry (singular to
/// working precision) or not finite.
fn invert(a: &mut [f64], s: usize, out: &mut [f64]) -> bool {
    let scale = a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return false;
    }
    out.iter_mut().for_each(|v| *v = 0.0);
    for i in 0..s {
        out[i * s + i] = 1.0;
    }
    for c in 0..s {
        let p = (c..s)
            .max_by(|&x, &y| a[x * s + c].abs().total_cmp(&a[y * s + c].abs()))
            .unwrap_or(c);
        let pivot = a[p * s + c];
        if pivot.abs() <= 1e-13 * scale {
            return false;
        }
        if p != c {
            for k in 0..s {
                a.swap(p * s + k, c * s + k);
                out.swap(p * s + k, c * s + k);
            }
        }
        for k in 0..s {
            a[c * s + k] /= pivot;
            out[c * s + k] /= pivot;
        }
        for r in 0..s {
            if r != c {
                let f = a[r * s + c];
                if f != 0.0 {
                    for k in 0..s {
                        a[r * s + k] -= f * a[c * s + k];
                        out[r * s + k] -= f * out[c * s + k];
                    }
                }
            }
        }
    }
    true
}

/// Eisenstat and Walker's forcing term, choice 2 with its safeguards (S. C. Eisenstat,
/// H. F. Walker, *Choosing the forcing terms in an inexact Newton method*, SIAM J. Sci.
/// Comput. 17, 1996, §2.3): `η_k = γ (‖Φ_k‖ / ‖Φ_{k−1}‖)^α` with `γ = 0.9`, `α = 2`, kept at
/// least `γ η_{k−1}^α` when that is above `0.1` (so that `η` does not drop by accident after a
/// lucky step), at most `eta_max`, and at least `eta_min` (so that a Krylov solve is never asked
/// for more than working precision).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Forcing {
    pub(crate) eta_max: f64,
    pub(crate) eta_min: f64,
    last_eta: Option<f64>,
    last_norm: Option<f64>,
}

const EW_GAMMA: f64 = 0.9;
const EW_ALPHA: f64 = 2.0;

impl Forcing {
    /// A fresh sequence; the first `η` is `eta_max`.
    pub(crate) fn new(eta_max: f64, eta_min: f64) -> Self {
        Self {
            eta_max,
            eta_min,
            last_eta: None,
            last_norm: None,
        }
    }

    /// `η_k` for the residual norm `phi_norm` of the current Newton iterate.
    pub(crate) fn next(&mut self, phi_norm: f64) -> f64 {
        let eta = match (self.last_eta, self.last_norm) {
            (Some(prev_eta), Some(prev)) if prev > 0.0 => {
                let mut eta = EW_GAMMA * (phi_norm / prev).powf(EW_ALPHA);
                let safeguard = EW_GAMMA * prev_eta.powf(EW_ALPHA);
                if safeguard > 0.1 {
                    eta = eta.max(safeguard);
                }
                eta
            }
            _ => self.eta_max,
        };
        let eta = if eta.is_finite() { eta } else { self.eta_max };
        let eta = eta.min(self.eta_max).max(self.eta_min);
        self.last_eta = Some(eta);
        self.last_norm = Some(phi_norm);
        eta
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn dense_apply(a: &[Vec<f64>]) -> impl FnMut(&[f64], &mut [f64]) + '_ {
        move |x, out| {
            for (o, row) in out.iter_mut().zip(a) {
                *o = dot(row, x);
            }
        }
    }

    fn params(tolerance: f64) -> GmresParams {
        GmresParams {
            restart: 30,
            max_iterations: 1000,
            tolerance,
        }
    }

    fn random(n: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| (0..n).map(|_| rng.random_range(-1.0..1.0)).collect())
            .collect()
    }

    /// `XᵀX + I` (SPD) and `X + n I` (nonsymmetric, diagonally dominant): planted `x*`, GMRES
    /// recovers it to the tolerance's accuracy.
    #[test]
    fn solves_spd_and_nonsymmetric_systems_with_planted_solutions() {
        let n = 40;
        let x = random(n, 1);
        let spd: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).map(|k| x[k][i] * x[k][j]).sum::<f64>() + f64::from(i == j))
                    .collect()
            })
            .collect();
        let nonsym: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| x[i][j] + if i == j { 5.0 } else { 0.0 })
                    .collect()
            })
            .collect();
        let truth: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        for a in [&spd, &nonsym] {
            let mut b = vec![0.0; n];
            dense_apply(a)(&truth, &mut b);
            for restart in [5, 40] {
                let p = GmresParams {
                    restart,
                    ..params(1e-12)
                };
                let r = gmres(
                    dense_apply(a),
                    |x, o| o.copy_from_slice(x),
                    &b,
                    &p,
                    || false,
                );
                assert_eq!(r.status, KrylovStatus::Converged, "restart {restart}");
                assert!(r.rel_residual <= 1e-12);
                let err =
                    r.x.iter()
                        .zip(&truth)
                        .fold(0.0_f64, |m, (u, v)| m.max((u - v).abs()));
                assert!(err < 1e-8, "restart {restart}: error {err:.2e}");
            }
            // Full GMRES ends within a few cycles of n (n in exact arithmetic).
            let r = gmres(
                dense_apply(a),
                |x, o| o.copy_from_slice(x),
                &b,
                &params(1e-12),
                || false,
            );
            assert!(r.iterations <= 3 * n, "{}", r.iterations);
        }
    }

    /// A badly scaled block-diagonal system (blocks of 3 with entries from 1e-4 to 1e4):
    /// the block-Jacobi preconditioner is its exact inverse, so right-preconditioned GMRES
    /// converges in one iteration, where the plain one needs many.
    #[test]
    fn block_jacobi_inverts_block_diagonal_systems() {
        let nb = 20;
        let n = 3 * nb;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut a = vec![vec![0.0; n]; n];
        for blk in 0..nb {
            let s = 10f64.powi(rng.random_range(-4..5));
            for i in 0..3 {
                for j in 0..3 {
                    a[3 * blk + i][3 * blk + j] =
                        s * (rng.random_range(-1.0..1.0) + if i == j { 3.0 } else { 0.0 });
                }
            }
        }
        let b: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let rows: Vec<usize> = (0..n).collect();
        let ptr: Vec<usize> = (0..=nb).map(|g| 3 * g).collect();
        let mut m = BlockJacobi::new(rows, ptr);
        m.update(|_, i, j| a[i][j]);
        let pre = gmres(
            dense_apply(&a),
            |x, o| m.apply(x, o),
            &b,
            &params(1e-12),
            || false,
        );
        assert_eq!(pre.status, KrylovStatus::Converged);
        assert!(pre.iterations <= 2, "{}", pre.iterations);
        let plain = gmres(
            dense_apply(&a),
            |x, o| o.copy_from_slice(x),
            &b,
            &params(1e-12),
            || false,
        );
        assert!(
            plain.iterations > 10 * pre.iterations,
            "{}",
            plain.iterations
        );
        let mut check = vec![0.0; n];
        dense_apply(&a)(&pre.x, &mut check);
        let res = norm(&check.iter().zip(&b).map(|(u, v)| u - v).collect::<Vec<_>>());
        assert!(res <= 1e-10 * norm(&b), "{res:.2e}");
        // A singular block falls back on its diagonal's inverse.
        let mut single = BlockJacobi::new(vec![0, 1], vec![0, 2]);
        single.update(|_, i, _| [2.0, 4.0][i]);
        let mut out = [0.0; 2];
        single.apply(&[1.0, 1.0], &mut out);
        assert_eq!(out, [0.5, 0.25]);
    }

    /// A singular system with `b` outside the range (`diag(1, 0)`, `b = (1, 1)`): GMRES finds
    /// a least-squares point (`x_0 = 1`, residual `1`) and reports a breakdown instead of
    /// converging.
    #[test]
    fn a_singular_system_breaks_down_with_its_least_squares_point() {
        let a = vec![vec![1.0, 0.0], vec![0.0, 0.0]];
        let r = gmres(
            dense_apply(&a),
            |x, o| o.copy_from_slice(x),
            &[1.0, 1.0],
            &params(1e-10),
            || false,
        );
        assert!(
            matches!(r.status, KrylovStatus::Breakdown(_)),
            "{:?}",
            r.status
        );
        assert!((r.x[0] - 1.0).abs() < 1e-12, "{:?}", r.x);
        assert!((r.rel_residual - 0.5_f64.sqrt()).abs() < 1e-12);
        // A non-finite product is a breakdown too.
        let r = gmres(
            |_, o: &mut [f64]| o.fill(f64::NAN),
            |x, o| o.copy_from_slice(x),
            &[1.0],
            &params(1e-10),
            || false,
        );
        assert!(matches!(r.status, KrylovStatus::Breakdown(_)));
    }

    /// Stagnation (a rotation with restart 1: each cycle's one-dimensional space is orthogonal
    /// to its image), the iteration cap and the time check each end the solve with their own
    /// status.
    #[test]
    fn stagnation_iteration_cap_and_time_are_reported() {
        let rot = vec![vec![0.0, -1.0], vec![1.0, 0.0]];
        let p = GmresParams {
            restart: 1,
            ..params(1e-10)
        };
        let r = gmres(
            dense_apply(&rot),
            |x, o| o.copy_from_slice(x),
            &[1.0, 0.0],
            &p,
            || false,
        );
        assert_eq!(r.status, KrylovStatus::Stagnation);
        assert_eq!(r.iterations, 1);
        let a = random(30, 3);
        let b = vec![1.0; 30];
        let p = GmresParams {
            max_iterations: 4,
            ..params(1e-14)
        };
        let r = gmres(
            dense_apply(&a),
            |x, o| o.copy_from_slice(x),
            &b,
            &p,
            || false,
        );
        assert_eq!(r.status, KrylovStatus::IterationLimit);
        assert_eq!(r.iterations, 4);
        assert!(r.rel_residual < 1.0);
        let mut calls = 0;
        let r = gmres(
            dense_apply(&a),
            |x, o| o.copy_from_slice(x),
            &b,
            &params(1e-14),
            || {
                calls += 1;
                calls > 3
            },
        );
        assert_eq!(r.status, KrylovStatus::TimeLimit);
        assert_eq!(r.iterations, 3);
    }

    /// Choice 2: `η_1 = η_max`, then `0.9 (‖Φ_k‖/‖Φ_{k−1}‖)²`, with the safeguard and the bounds.
    #[test]
    fn forcing_follows_eisenstat_walker_choice_two() {
        let mut f = Forcing::new(0.5, 1e-12);
        assert_eq!(f.next(1.0), 0.5);
        // 0.9·(0.1)² = 0.009, but the safeguard 0.9·0.5² = 0.225 > 0.1 keeps it up.
        assert!((f.next(0.1) - 0.225).abs() < 1e-15);
        // 0.9·(1e-3)² = 9e-7; safeguard 0.9·0.225² = 0.0456 < 0.1 does not apply.
        assert!((f.next(1e-4) - 9e-7).abs() < 1e-18);
        // Quadratic convergence would ask below eta_min.
        assert_eq!(f.next(1e-12), 1e-12);
        // A residual that grows is capped at eta_max.
        assert_eq!(f.next(1.0), 0.5);
    }
}

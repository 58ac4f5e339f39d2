//! The factorisation of the clamped block `A_CC` that Dantzig's drives solve with, grown by
//! one bordered row and column when a row joins `C` and updated by a rank-one (Bennett) update
//! when a row leaves.

use crate::problem::Problem;

/// `A_CC = L U` (unit lower `L`, no row exchanges) for the clamped rows in factor order, stored
/// row-major with stride `cap`.
#[derive(Clone)]
pub(super) struct ClampedLu {
    pub(super) cap: usize,
    pub(super) rows: Vec<usize>,
    pub(super) l: Vec<f64>,
    pub(super) u: Vec<f64>,
}

impl ClampedLu {
    pub(super) fn new(cap: usize) -> Self {
        Self {
            cap,
            rows: Vec::with_capacity(cap),
            l: vec![0.0; cap * cap],
            u: vec![0.0; cap * cap],
        }
    }

    /// Solve `A_CC v = rhs` in place.
    pub(super) fn solve(&self, rhs: &mut [f64]) {
        let (m, cap) = (self.rows.len(), self.cap);
        for r in 0..m {
            let s: f64 = (0..r).map(|c| self.l[r * cap + c] * rhs[c]).sum();
            rhs[r] -= s;
        }
        for r in (0..m).rev() {
            let s: f64 = (r + 1..m).map(|c| self.u[r * cap + c] * rhs[c]).sum();
            rhs[r] = (rhs[r] - s) / self.u[r * cap + r];
        }
    }

    /// Border the factorisation with row and column `i`. Fails, leaving it unchanged, with the
    /// pivot `A_ii − A_iC A_CC⁻¹ A_Ci` when that is not above `tol`.
    pub(super) fn try_add(&mut self, problem: &Problem, i: usize, tol: f64) -> Result<(), f64> {
        let (m, cap) = (self.rows.len(), self.cap);
        let row_i = problem.dense_row(i);
        // l: Uᵀ l = A_iC; u: L u = A_Ci.
        let mut l: Vec<f64> = self.rows.iter().map(|&c| row_i[c]).collect();
        let mut u: Vec<f64> = self.rows.iter().map(|&c| problem.dense_row(c)[i]).collect();
        for k in 0..m {
            let s: f64 = (0..k).map(|j| l[j] * self.u[j * cap + k]).sum();
            l[k] = (l[k] - s) / self.u[k * cap + k];
            let s: f64 = (0..k).map(|j| self.l[k * cap + j] * u[j]).sum();
            u[k] -= s;
        }
        let pivot = row_i[i] - l.iter().zip(&u).map(|(a, b)| a * b).sum::<f64>();
        if pivot.is_nan() || pivot <= tol {
            return Err(pivot);
        }
        for k in 0..m {
            self.l[m * cap + k] = l[k];
            self.u[k * cap + m] = u[k];
        }
        self.u[m * cap + m] = pivot;
        self.rows.push(i);
        Ok(())
    }

    /// Remove the row and column at factor position `p`: the trailing block takes the rank-one
    /// update `L₃₃U₃₃ + l₃ₚ uₚ₃ᵀ` (Bennett), then position `p` is deleted.
    pub(super) fn remove(&mut self, p: usize) -> Result<(), String> {
        let (m, cap) = (self.rows.len(), self.cap);
        let mut x: Vec<f64> = (0..m)
            .map(|r| if r > p { self.l[r * cap + p] } else { 0.0 })
            .collect();
        let mut y: Vec<f64> = (0..m)
            .map(|c| if c > p { self.u[p * cap + c] } else { 0.0 })
            .collect();
        for j in p + 1..m {
            let ujj = self.u[j * cap + j];
            let new = ujj + x[j] * y[j];
            if new.is_nan() || new.abs() <= 1e-14 * ujj.abs() {
                return Err(format!(
                    "singular pivot {new:.3e} in the factorisation update"
                ));
            }
            for c in j + 1..m {
                let ujc = self.u[j * cap + c];
                self.u[j * cap + c] = ujc + x[j] * y[c];
                y[c] = (ujj * y[c] - y[j] * ujc) / new;
            }
            for r in j + 1..m {
                let lrj = self.l[r * cap + j];
                let xr = x[r];
                x[r] = xr - x[j] * lrj;
                self.l[r * cap + j] = (lrj * ujj + xr * y[j]) / new;
            }
            self.u[j * cap + j] = new;
        }
        // Delete row and column p from both factors.
        for r in 0..m {
            for c in 0..m {
                if r == p || c == p {
                    continue;
                }
                let (r2, c2) = (r - usize::from(r > p), c - usize::from(c > p));
                self.l[r2 * cap + c2] = self.l[r * cap + c];
                self.u[r2 * cap + c2] = self.u[r * cap + c];
            }
        }
        self.rows.remove(p);
        Ok(())
    }
}

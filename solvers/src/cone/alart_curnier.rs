//! The Alart–Curnier function of one contact and an element of its generalised Jacobian, and
//! the exact solve of one contact's cone problem (the kernels of [`crate::NsgsCone`] and of
//! [`crate::ConeNewton`] with [`crate::ConeFunction::AlartCurnier`], `newton-ac`).
//!
//! For a contact with reaction `r = (r_N, r_T)`, velocity `u`, coefficient `mu` and `ρ > 0`:
//!
//! ```text
//! Φ_N = r_N − max(0, r_N − ρ u_N)
//! Φ_T = r_T − P_D(mu · max(0, r_N − ρ u_N)) (r_T − ρ u_T)
//! ```
//!
//! with `P_D(s)` the projection onto the disk of radius `s`. `Φ = 0` is Coulomb's law. Its
//! generalised Jacobian is written `dΦ = P dr + Q du` (so `P + Q W` with `u = W r + q`).
//!
//! Reference: P. Alart, A. Curnier, CMAME 92, 1991; V. Acary, M. Brémond, O. Huber, 2018, §3.

use crate::cone::newton::Linearisation;
use crate::cone::{contact_natural_map, project_onto_cone};

/// The Alart–Curnier function of one contact and an element of its generalised Jacobian.
pub(crate) fn linearise(mu: f64, rho: f64, r: [f64; 3], u: [f64; 3]) -> Linearisation {
    let mut p = [[0.0; 3]; 3];
    let mut q = [[0.0; 3]; 3];
    let mut phi = [0.0; 3];
    let a = r[0] - rho * u[0];
    if a > 0.0 {
        phi[0] = rho * u[0];
        q[0][0] = rho;
    } else {
        phi[0] = r[0];
        p[0][0] = 1.0;
    }
    let radius = mu * a.max(0.0);
    let x = [r[1] - rho * u[1], r[2] - rho * u[2]];
    let nx = x[0].hypot(x[1]);
    if nx <= radius {
        phi[1] = rho * u[1];
        phi[2] = rho * u[2];
        q[1][1] = rho;
        q[2][2] = rho;
    } else {
        let xh = [x[0] / nx, x[1] / nx];
        phi[1] = r[1] - radius * xh[0];
        phi[2] = r[2] - radius * xh[1];
        let s = radius / nx;
        // M = s (I − x̂ x̂ᵀ).
        let m = [
            [s * (1.0 - xh[0] * xh[0]), -s * xh[0] * xh[1]],
            [-s * xh[1] * xh[0], s * (1.0 - xh[1] * xh[1])],
        ];
        let da = if a > 0.0 { mu } else { 0.0 };
        for k in 0..2 {
            p[1 + k][0] = -xh[k] * da;
            q[1 + k][0] = xh[k] * da * rho;
            for l in 0..2 {
                let id = if k == l { 1.0 } else { 0.0 };
                p[1 + k][1 + l] = id - m[k][l];
                q[1 + k][1 + l] = rho * m[k][l];
            }
        }
    }
    Linearisation { phi, p, q }
}

/// The LU factors of a 3×3 matrix with partial pivoting (Gaussian elimination, row-major):
/// `U` on and above the diagonal, the multipliers of `L` below it, and the row order.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lu3 {
    m: [[f64; 3]; 3],
    perm: [usize; 3],
}

impl Lu3 {
    /// Factor `m`; `None` when singular (a pivot below `1e-14` of the largest entry) or not
    /// finite.
    pub(crate) fn new(mut m: [[f64; 3]; 3]) -> Option<Self> {
        let big = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
        if !(big.is_finite() && big > 0.0) {
            return None;
        }
        let mut perm = [0, 1, 2];
        for k in 0..3 {
            let piv = (k..3)
                .max_by(|&i, &j| m[i][k].abs().total_cmp(&m[j][k].abs()))
                .unwrap_or(k);
            if m[piv][k].abs() <= 1e-14 * big {
                return None;
            }
            m.swap(k, piv);
            perm.swap(k, piv);
            let pivot_row = m[k];
            for row in m.iter_mut().skip(k + 1) {
                let f = row[k] / pivot_row[k];
                for (x, p) in row.iter_mut().zip(pivot_row).skip(k + 1) {
                    *x -= f * p;
                }
                row[k] = f;
            }
        }
        Some(Self { m, perm })
    }

    /// `x` with `m x = b`; `None` when not finite.
    pub(crate) fn solve(&self, b: [f64; 3]) -> Option<[f64; 3]> {
        let m = &self.m;
        let mut y = [b[self.perm[0]], b[self.perm[1]], b[self.perm[2]]];
        for k in 0..3 {
            for i in k + 1..3 {
                y[i] -= m[i][k] * y[k];
            }
        }
        let mut x = [0.0; 3];
        for k in (0..3).rev() {
            let s: f64 = (k + 1..3).map(|j| m[k][j] * x[j]).sum();
            x[k] = (y[k] - s) / m[k][k];
        }
        x.iter().all(|v| v.is_finite()).then_some(x)
    }
}

/// Solve the 3×3 system `m x = b` by Gaussian elimination with partial pivoting; `None` when
/// singular (a pivot below `1e-14` of the largest entry).
pub(crate) fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    Lu3::new(m)?.solve(b)
}

#[inline]
fn apply(w: &[[f64; 3]; 3], r: [f64; 3], q: [f64; 3]) -> [f64; 3] {
    let mut u = q;
    for (a, ua) in u.iter_mut().enumerate() {
        *ua += w[a][0] * r[0] + w[a][1] * r[1] + w[a][2] * r[2];
    }
    u
}

#[inline]
fn sq(x: [f64; 3]) -> f64 {
    x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
}

/// Local Newton iterations per contact solve.
const LOCAL_ITERATIONS: usize = 30;

/// Backtracking halvings of one local Newton step.
const LINE_SEARCH_HALVINGS: usize = 30;

/// A Newton step shorter than this share of `‖r‖` is a step in the round-off of `r`: the
/// local solve has converged as far as the arithmetic allows.
const ROUND_OFF_STEP: f64 = 1e-13;

/// One contact's diagonal block `W_cc` with what every local solve of it reuses: its LU
/// factors (the stick solution `W_cc r = −q`) and the Alart–Curnier parameter `ρ = 1 / W_NN`.
/// Built once per solve ([`crate::NsgsCone`] keeps one per contact).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ContactBlock {
    w: [[f64; 3]; 3],
    lu: Option<Lu3>,
    rho: f64,
}

impl ContactBlock {
    pub(crate) fn new(w: [[f64; 3]; 3]) -> Self {
        let rho = if w[0][0] > 0.0 {
            1.0 / w[0][0]
        } else {
            let m = w.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
            if m > 0.0 {
                1.0 / m
            } else {
                1.0
            }
        };
        Self {
            w,
            lu: Lu3::new(w),
            rho,
        }
    }

    /// `W_cc`, row-major.
    pub(crate) fn w(&self) -> &[[f64; 3]; 3] {
        &self.w
    }

    /// Solve the contact's problem `u = W_cc r + q`, `K ∋ r ⟂ û ∈ K*` from the start `r0`:
    /// take-off (`r = 0` when `q_N >= 0`) and sticking (`W_cc r = −q` inside the cone) in closed
    /// form, else sliding by a damped Alart–Curnier Newton (Armijo backtracking on `½‖Φ‖²`,
    /// projected fixed-point steps where the Newton step fails) from `r0`, or, when `r0 = 0`,
    /// from the stick solution projected onto the cone. Stops when `Φ` vanishes to round-off or
    /// the Newton step is within the round-off of `r`. Returns the reaction reached, or `r0`
    /// when that has the smaller natural map (with `ρ = 1 / W_NN`).
    pub(crate) fn solve(&self, mu: f64, q: [f64; 3], r0: [f64; 3]) -> [f64; 3] {
        if q[0] >= 0.0 {
            return [0.0; 3];
        }
        let (w, rho) = (&self.w, self.rho);
        let stick = self.lu.and_then(|lu| lu.solve([-q[0], -q[1], -q[2]]));
        if let Some(r) = stick {
            if r[0] >= 0.0 && r[1].hypot(r[2]) <= mu * r[0] {
                return r;
            }
        }
        let mut r = match stick {
            _ if r0 != [0.0; 3] => r0,
            Some(s) if s[0] > 0.0 => project_onto_cone(mu, s),
            _ => {
                let rn = if w[0][0] > 0.0 { -q[0] / w[0][0] } else { 0.0 };
                [rn.max(0.0), 0.0, 0.0]
            }
        };
        let exact = 1e-15 * (rho * sq(q).sqrt()).max(f64::MIN_POSITIVE);
        let mut l = linearise(mu, rho, r, apply(w, r, q));
        let mut theta = 0.5 * sq(l.phi);
        for _ in 0..LOCAL_ITERATIONS {
            if (2.0 * theta).sqrt() <= exact {
                break;
            }
            let mut jac = l.p;
            for (row, qa) in jac.iter_mut().zip(&l.q) {
                for (b, x) in row.iter_mut().enumerate() {
                    *x += qa[0] * w[0][b] + qa[1] * w[1][b] + qa[2] * w[2][b];
                }
            }
            let mut stepped = false;
            if let Some(d) = solve3(jac, [-l.phi[0], -l.phi[1], -l.phi[2]]) {
                if sq(d) <= ROUND_OFF_STEP * ROUND_OFF_STEP * sq(r) {
                    break;
                }
                let mut t = 1.0;
                for _ in 0..LINE_SEARCH_HALVINGS {
                    let trial = [r[0] + t * d[0], r[1] + t * d[1], r[2] + t * d[2]];
                    let lt = linearise(mu, rho, trial, apply(w, trial, q));
                    let theta_t = 0.5 * sq(lt.phi);
                    if theta_t <= (1.0 - 2e-4 * t) * theta {
                        (r, l, theta) = (trial, lt, theta_t);
                        stepped = true;
                        break;
                    }
                    t *= 0.5;
                }
            }
            if !stepped {
                // Projected fixed point on De Saxcé's map.
                let uh = crate::cone::de_saxce(mu, apply(w, r, q));
                r = project_onto_cone(
                    mu,
                    [r[0] - rho * uh[0], r[1] - rho * uh[1], r[2] - rho * uh[2]],
                );
                l = linearise(mu, rho, r, apply(w, r, q));
                theta = 0.5 * sq(l.phi);
            }
        }
        if r == r0 {
            return r;
        }
        let err = |r: [f64; 3]| contact_natural_map(mu, rho, r, apply(w, r, q));
        if err(r) <= err(r0) {
            r
        } else {
            r0
        }
    }
}

/// Solve one contact's problem `u = w r + q`, `K ∋ r ⟂ û ∈ K*` from the start `r0`
/// ([`ContactBlock::solve`], factoring `w` for this one solve).
#[cfg(test)]
pub(crate) fn solve_contact(mu: f64, w: &[[f64; 3]; 3], q: [f64; 3], r0: [f64; 3]) -> [f64; 3] {
    ContactBlock::new(*w).solve(mu, q, r0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Jacobian element matches finite differences where `Φ` is smooth (sliding).
    #[test]
    fn jacobian_matches_finite_differences() {
        let w = [[2.0, 0.3, -0.1], [0.3, 1.5, 0.2], [-0.1, 0.2, 1.2]];
        let q = [-1.0, 0.8, -0.6];
        let (mu, rho) = (0.4, 0.5);
        let r = [0.7, -0.1, 0.05];
        let l = linearise(mu, rho, r, apply(&w, r, q));
        let h = 1e-7;
        for b in 0..3 {
            let mut rp = r;
            rp[b] += h;
            let lp = linearise(mu, rho, rp, apply(&w, rp, q));
            for a in 0..3 {
                let fd = (lp.phi[a] - l.phi[a]) / h;
                let jab = l.p[a][b] + (0..3).map(|k| l.q[a][k] * w[k][b]).sum::<f64>();
                assert!((fd - jab).abs() < 1e-5, "({a},{b}): {fd} vs {jab}");
            }
        }
    }

    #[test]
    fn local_solve_meets_coulombs_law() {
        let w = [[2.0, 0.3, -0.1], [0.3, 1.5, 0.2], [-0.1, 0.2, 1.2]];
        for q in [
            [-1.0, 0.8, -0.6],
            [-1.0, 0.01, 0.0],
            [0.5, 1.0, 1.0],
            [-0.2, -3.0, 2.0],
        ] {
            let r = solve_contact(0.4, &w, q, [0.0; 3]);
            let e = contact_natural_map(0.4, 0.5, r, apply(&w, r, q));
            assert!(e < 1e-13, "q = {q:?}: r = {r:?}, error {e}");
        }
    }
}

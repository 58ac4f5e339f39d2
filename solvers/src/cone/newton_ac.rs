//! Global semismooth Newton on the Alart–Curnier function of every contact, for the exact
//! Coulomb cone.
//!
//! With `Φ_c` the Alart–Curnier function of contact `c` ([`crate::alart_curnier`], `ρ_c = 1 / d_c`,
//! `d_c` the diagonal scale of its normal row) and `dΦ_c = P_c dr_c + Q_c du_c`, one iteration
//! solves
//!
//! ```text
//! (P + Q W + λ I) d = −Φ,     λ = min(10⁻², ‖Φ‖∞ / s)   (s the largest ρ_c ‖q_c‖; 1 if zero)
//! ```
//!
//! by a dense LU (faer, partial pivoting) — the Levenberg term keeps the system regular where
//! contacts are degenerate and vanishes at the solution — and takes an Armijo step on the merit
//! `θ = ½‖Φ‖²` (`σ = 10⁻⁴`, halving, at most 40 times), falling back to the steepest-descent
//! direction `−(P + Q W)ᵀ Φ` when the Newton direction is not a descent direction.
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]) with `3 n_c <=` [`NewtonAc::max_dense`]
//!   (default 1500 rows; above it the solve is `Unsupported`). Locally quadratically convergent
//!   near a non-degenerate solution; the line search on `θ` is not globally convergent for
//!   Coulomb friction (Acary, Brémond, Huber 2018 measure it as fast and less robust than NSGS),
//!   so a solve may end `Stalled` at a stationary point of `θ`.
//! * **Cost**: one dense `n × n` LU per iteration (`⅔ n³`) and `O(n²)` for `Q W`.
//! * **Stopping rule**: the cone residual ([`crate::cone`]) is at most the tolerance; the
//!   iterate, with each contact projected onto its cone when that lowers the residual, is
//!   returned.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones.
//!
//! References: P. Alart, A. Curnier, CMAME 92, 1991; V. Acary, M. Brémond, O. Huber, 2018
//! (Siconos' `FC3D_NSN_AC`).

use crate::cone::alart_curnier::linearise;
use crate::cone::{
    cone_residuals, initial_reaction, project_onto_cone, ConeMonitor, ConeProblem, ConeSolver,
};
use crate::lcp::newton::MAX_REGULARISATION;
use crate::solver::line_search::{is_descent, Backtracking};
use crate::solver::{Outcome, Settings, SolveResult};
use faer::linalg::solvers::Solve;
use faer::{Col, Mat};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone (exact Coulomb); global Alart–Curnier Newton, dense LU, n <= 1500 rows";

/// Global Alart–Curnier Newton. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonAc {
    /// Largest number of rows for which the dense Jacobian is formed. Default `1500`.
    pub max_dense: usize,
}

impl Default for NewtonAc {
    fn default() -> Self {
        Self { max_dense: 1500 }
    }
}

/// `Φ(r)` into `phi` given `u`; returns `θ = ½‖Φ‖²`.
fn merit(problem: &ConeProblem, rho: &[f64], r: &[f64], u: &[f64], phi: &mut [f64]) -> f64 {
    let mut theta = 0.0;
    for (c, &mu) in problem.mu().iter().enumerate() {
        let s = 3 * c..3 * c + 3;
        let l = linearise(mu, rho[c], take(&r[s.clone()]), take(&u[s.clone()]));
        phi[s].copy_from_slice(&l.phi);
        theta += 0.5 * l.phi.iter().map(|v| v * v).sum::<f64>();
    }
    if theta.is_finite() {
        theta
    } else {
        f64::INFINITY
    }
}

#[inline]
fn take(x: &[f64]) -> [f64; 3] {
    [x[0], x[1], x[2]]
}

/// Each contact projected onto its cone.
fn projected(problem: &ConeProblem, r: &[f64]) -> Vec<f64> {
    let mut p = r.to_vec();
    for (c, &mu) in problem.mu().iter().enumerate() {
        let v = project_onto_cone(mu, take(&r[3 * c..3 * c + 3]));
        p[3 * c..3 * c + 3].copy_from_slice(&v);
    }
    p
}

impl ConeSolver for NewtonAc {
    fn name(&self) -> &'static str {
        "newton-ac"
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let n = problem.n();
        if n > self.max_dense {
            let reason = format!(
                "n = {n} rows: the dense Newton system is formed only up to n = {}",
                self.max_dense
            );
            return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
        }
        let w = problem.delassus().to_dense();
        let q = problem.q();
        let nc = problem.contacts();
        let rho: Vec<f64> = (0..nc).map(|c| 1.0 / problem.scale_of(c)).collect();
        let scale = (0..nc)
            .map(|c| rho[c] * take(&q[3 * c..]).iter().map(|v| v * v).sum::<f64>().sqrt())
            .fold(0.0f64, f64::max);
        let scale = if scale > 0.0 { scale } else { 1.0 };
        let velocity = |r: &[f64]| -> Vec<f64> {
            let rc = Col::from_fn(n, |i| r[i]);
            let u = &w * &rc;
            (0..n).map(|i| u[i] + q[i]).collect()
        };
        let mut r = initial_reaction(problem, settings);
        let mut u = velocity(&r);
        let mut phi = vec![0.0; n];
        let mut theta = merit(problem, &rho, &r, &u, &mut phi);
        let mut trial_phi = vec![0.0; n];
        let mut iterations = 0;
        let tol = settings.tolerance;
        let line_search = Backtracking::newton();
        let outcome = loop {
            let rp = projected(problem, &r);
            if cone_residuals(problem, &rp).natural_map_rel <= tol {
                r = rp;
                break Outcome::Stopped;
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            // J = P + Q W, block rows per contact.
            let mut jac = Mat::<f64>::zeros(n, n);
            for (c, &mu) in problem.mu().iter().enumerate() {
                let s = 3 * c;
                let l = linearise(mu, rho[c], take(&r[s..]), take(&u[s..]));
                for a in 0..3 {
                    for b in 0..3 {
                        jac[(s + a, s + b)] += l.p[a][b];
                    }
                    for j in 0..n {
                        let v: f64 = (0..3).map(|k| l.q[a][k] * w[(s + k, j)]).sum();
                        jac[(s + a, j)] += v;
                    }
                }
            }
            let phi_col = Col::from_fn(n, |i| phi[i]);
            let grad = jac.transpose() * &phi_col;
            let phi_inf = phi.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let lambda = (phi_inf / scale).min(MAX_REGULARISATION);
            let mut h = jac.clone();
            for i in 0..n {
                h[(i, i)] += lambda;
            }
            let mut dir = Mat::from_fn(n, 1, |i, _| -phi[i]);
            h.partial_piv_lu().solve_in_place(&mut dir);
            let newton_dir: Vec<f64> = (0..n).map(|i| dir[(i, 0)]).collect();
            let dnorm = newton_dir.iter().map(|v| v * v).sum::<f64>().sqrt();
            let slope: f64 = (0..n).map(|i| grad[i] * newton_dir[i]).sum();
            let gnorm = grad.norm_l2();
            let newton_ok = is_descent(&newton_dir, slope, gnorm, dnorm);
            let gradient_dir: Vec<f64> = (0..n).map(|i| -grad[i]).collect();
            let gslope = -gnorm * gnorm;
            let mut candidates: Vec<(&[f64], f64)> = Vec::with_capacity(2);
            if newton_ok {
                candidates.push((&newton_dir, slope));
            }
            candidates.push((&gradient_dir, gslope));
            let mut accepted = false;
            for (direction, slope) in candidates {
                if slope.is_nan() || slope >= 0.0 {
                    continue;
                }
                let wd = {
                    let dc = Col::from_fn(n, |i| direction[i]);
                    &w * &dc
                };
                let mut trial_r = Vec::new();
                let step = line_search.armijo(theta, slope, |t| {
                    trial_r = (0..n).map(|i| r[i] + t * direction[i]).collect();
                    let trial_u: Vec<f64> = (0..n).map(|i| u[i] + t * wd[i]).collect();
                    merit(problem, &rho, &trial_r, &trial_u, &mut trial_phi)
                });
                if step.is_some() {
                    r = trial_r;
                    accepted = true;
                    break;
                }
            }
            iterations += 1;
            if !accepted {
                monitor.record(iterations, &r);
                break Outcome::Stalled(format!(
                    "the line search found no decrease of the Alart–Curnier merit at iteration \
                     {iterations} (a stationary point that is not a solution)"
                ));
            }
            u = velocity(&r);
            theta = merit(problem, &rho, &r, &u, &mut phi);
            monitor.record(iterations, &r);
            if r.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite iterate at iteration {iterations}"
                ));
            }
        };
        let rp = projected(problem, &r);
        if cone_residuals(problem, &rp).natural_map_rel
            <= cone_residuals(problem, &r).natural_map_rel
        {
            r = rp;
        }
        monitor.finish(r, iterations, outcome)
    }
}

//! ADMM on the exact Coulomb cone (Siconos' `FC3D_ADMM`): the alternating direction method of
//! multipliers on the convex problem of a fixed De Saxcé term, the term refreshed every
//! iteration, with Nesterov acceleration and restart.
//!
//! With `s_c = mu_c ‖u_{c,T}‖` frozen, the cone problem is the optimality condition of
//! `min ½ rᵀ W r + (q + s e_N)ᵀ r` over `r ∈ K`. ADMM splits `r = z`, `z ∈ K`, with the penalty
//! `P = ρ D` (`D = diag(d_c I₃)`, the contacts' diagonal scales, so that the method is invariant
//! under positive scalings of each contact's rows and columns):
//!
//! ```text
//! (W + P) r = −q_s + P (ẑ − ξ̂),          q_s = q + mu ‖u_T(z)‖ e_N,
//! z  = P_K(r + ξ̂),
//! ξ  = ξ̂ + r − z,
//! ```
//!
//! then, with `e = ‖r − z‖²_D + ρ² ‖ẑ − z‖²_D` (primal and dual residuals), Goldstein et al.'s
//! restart rule: while `e < η e_prev` the next `ẑ, ξ̂` extrapolate along the last step with
//! Nesterov's weights, otherwise they restart from the previous iterate (`η = 0.999`, Siconos'
//! `ADMM_RESTART_ETA`). `W + P` is factored once per value of `ρ`: a dense LU with partial pivoting
//! (faer) when `W` is stored dense, faer's sparse LU otherwise (LU, not Cholesky: `W` from FCLIB
//! is symmetric only up to round-off). The De Saxcé term is refreshed from the velocity at the
//! last `z` every iteration (Siconos' default `ADMM_UPDATE_S_YES`; Siconos takes it at `r`, which
//! equals `z` at convergence; `z` is the iterate whose velocity the cone residual already
//! computes).
//!
//! `ρ` is constant by default, as in Siconos 4.4 (`ADMM_RHO_STRATEGY_CONSTANT`, `rho = 1` in
//! absolute units; here `ρ = 1` in units of `d_c`, so the penalty is `W`'s own diagonal). With
//! [`AdmmCone::residual_balancing`] set, `ρ` is multiplied (divided) by 2 when the primal residual
//! exceeds 10 times the dual one (the dual 10 times the primal), Siconos'
//! `ADMM_RHO_STRATEGY_RESIDUAL_BALANCING` with Boyd et al.'s `τ = 2`, `μ = 10`, and `W + P`
//! refactored.
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]), dense or sparse `W` with `W + ρ D`
//!   nonsingular (any `W` positive semidefinite up to round-off). A fixed point of the
//!   convex-problem iteration and the De Saxcé update, without a convergence proof for Coulomb
//!   friction; Acary, Brémond, Huber (2018) find it robust and slow to reach tight tolerances.
//! * **Cost**: one factorisation of `W + ρ D` per value of `ρ` (dense: `⅔ n³`); per iteration
//!   one solve with the factors and one pass over `W` (the velocity and cone residual at `z`). No
//!   allocation per iteration.
//! * **Stopping rule**: the cone residual ([`crate::cone`]) of `z` is at most the tolerance.
//!   `Stalled` when it has not reached a new low by 1 % in
//!   [`crate::FIRST_ORDER_STAGNATION_WINDOW`] iterations; `NumericalFailure` when the
//!   factorisation fails or an iterate is not finite; the time budget is checked every
//!   iteration, and a refactorisation is not started when the first one's length would carry
//!   the solve past it. A sparse LU estimated above [`AdmmCone::max_factor_entries`] entries
//!   (symbolic Cholesky analysis of `W`'s pattern) is refused before any numerical work, as
//!   `Unsupported`: it cannot be interrupted by the budget.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones, as `z`, with the
//!   multiplier `ξ = −P⁻¹ û(z)` that makes a solution a fixed point of the iteration.
//!
//! References: V. Acary, M. Brémond, O. Huber, *On solving contact problems with Coulomb
//! friction: formulations and numerical comparisons*, 2018; Siconos' `fc3d_admm.c`
//! (`fc3d_admm_symmetric`); T. Goldstein, B. O'Donoghue, S. Setzer, R. Baraniuk, *Fast
//! alternating direction optimization methods*, SIAM J. Imaging Sci. 7, 2014; S. Boyd et al.,
//! *Distributed optimization and statistical learning via ADMM*, 2011 (§3.4.1).

use crate::cone::newton::MAX_FACTOR_ENTRIES;
use crate::cone::projected_step::Point;
use crate::cone::{initial_reaction, project_onto_cone, ConeMonitor, ConeProblem, ConeSolver};
use crate::linalg::cholesky_fill;
use crate::solver::{Outcome, Settings, SolveResult, Stagnation, FIRST_ORDER_STAGNATION_WINDOW};
use faer::linalg::solvers::{PartialPivLu, SolveCore};
use faer::sparse::linalg::solvers::Lu;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, Mat};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone (exact Coulomb); accelerated ADMM with the De Saxcé term refreshed, W + ρD factored once (dense, or sparse LU up to an estimated 20 million entries)";

/// The registry's entry of `admm-cone`.
pub static ADMM_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "admm-cone",
    summary: "accelerated ADMM with the De Saxcé term refreshed every iteration",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "ADMM iterations",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(AdmmCone::default())),
};

/// ADMM on the cone. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdmmCone {
    /// Penalty `ρ`, in units of each contact's diagonal scale `d_c`. Default `1`.
    pub penalty: f64,
    /// Restart threshold `η` of the acceleration. Default `0.999` (Siconos).
    pub restart_eta: f64,
    /// Adapt `ρ` by residual balancing (refactoring `W + ρ D` at each change). Default `false`
    /// (Siconos' default is a constant `ρ`).
    pub residual_balancing: bool,
    /// Largest sparse LU of `W + ρD`, in entries of `L` and `U` as estimated before any
    /// numerical work; a larger one makes the solve `Unsupported`. Default
    /// [`crate::cone::newton::MAX_FACTOR_ENTRIES`].
    pub max_factor_entries: usize,
}

impl Default for AdmmCone {
    fn default() -> Self {
        Self {
            penalty: 1.0,
            restart_eta: 0.999,
            residual_balancing: false,
            max_factor_entries: MAX_FACTOR_ENTRIES,
        }
    }
}

/// Residual balancing: change `ρ` when one residual exceeds the other by this factor.
const BALANCING_RATIO: f64 = 10.0;
/// Residual balancing: the factor `ρ` changes by.
const BALANCING_STEP: f64 = 2.0;

/// The factors of `W + P`.
enum Factors {
    Dense(PartialPivLu<f64>),
    Sparse(Lu<usize, f64>),
}

/// Why `W + P` was not factored.
enum Refusal {
    /// Its sparse LU would exceed the entry limit.
    TooMuchFill(String),
    /// The assembly or the factorisation failed.
    Failed(String),
}

impl Factors {
    /// Factor `W + diag(p)`, refusing a sparse LU estimated above `max_entries` entries
    /// (about twice the entries of the Cholesky factor of `W`'s pattern, less the diagonal);
    /// `None` skips the estimate (a refactorisation on a pattern already accepted).
    fn new(problem: &ConeProblem, p: &[f64], max_entries: Option<usize>) -> Result<Self, Refusal> {
        let w = problem.delassus();
        if let Some(dense) = w.dense() {
            let mut a = dense.clone();
            for (i, &pi) in p.iter().enumerate() {
                a[(i, i)] += pi;
            }
            return Ok(Factors::Dense(a.partial_piv_lu()));
        }
        let n = problem.n();
        let mut triplets = Vec::with_capacity(w.nnz() + n);
        for (i, &pi) in p.iter().enumerate() {
            triplets.extend(w.row(i).iter().map(|(j, v)| Triplet::new(i, j, v)));
            triplets.push(Triplet::new(i, i, pi));
        }
        let a = SparseColMat::try_new_from_triplets(n, n, &triplets)
            .map_err(|e| Refusal::Failed(format!("assembling W + ρD: {e:?}")))?;
        if let Some(max_entries) = max_entries {
            let estimate =
                cholesky_fill(a.symbolic()).map_or(usize::MAX, |f| (2 * f).saturating_sub(n));
            if estimate > max_entries {
                return Err(Refusal::TooMuchFill(format!(
                    "the sparse LU of W + ρD ({n} rows) would hold about {estimate} entries \
                     (symbolic analysis, AMD ordering), above the {max_entries} allowed: a \
                     factorisation cannot be interrupted, so the solve would overrun its time \
                     budget"
                )));
            }
        }
        a.sp_lu()
            .map(Factors::Sparse)
            .map_err(|e| Refusal::Failed(format!("the sparse LU of W + ρD failed: {e:?}")))
    }

    fn solve_in_place(&self, x: &mut Mat<f64>) {
        match self {
            Factors::Dense(lu) => lu.solve_in_place_with_conj(Conj::No, x.as_mut()),
            Factors::Sparse(lu) => lu.solve_in_place_with_conj(Conj::No, x.as_mut()),
        }
    }
}

/// `sqrt(Σ_i d_i (a_i − b_i)²)`.
fn weighted_distance(d: &[f64], a: &[f64], b: &[f64]) -> f64 {
    d.iter()
        .zip(a.iter().zip(b))
        .map(|(di, (x, y))| di * (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

impl ConeSolver for AdmmCone {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &ADMM_CONE
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let (n, tol, q, mu) = (problem.n(), settings.tolerance, problem.q(), problem.mu());
        if !(self.penalty.is_finite() && self.penalty > 0.0) {
            let reason = format!("penalty ρ = {} must be finite and positive", self.penalty);
            return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
        }
        let d: Vec<f64> = (0..n).map(|i| problem.scale_of(i / 3)).collect();
        let mut rho = self.penalty;
        let mut penalty: Vec<f64> = d.iter().map(|di| rho * di).collect();
        let factor_start = monitor.elapsed();
        let mut factors = match Factors::new(problem, &penalty, Some(self.max_factor_entries)) {
            Ok(f) => f,
            Err(Refusal::TooMuchFill(reason)) => {
                return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason))
            }
            Err(Refusal::Failed(reason)) => {
                return monitor.finish(Vec::new(), 0, Outcome::NumericalFailure(reason))
            }
        };
        let factor_time = monitor.elapsed().saturating_sub(factor_start);
        // z and its velocity, De Saxcé velocity and cone residual.
        let mut x = Point::zeros(n);
        x.r = initial_reaction(problem, settings);
        x.evaluate(problem);
        let mut xi: Vec<f64> = (0..n).map(|i| -x.u_hat[i] / penalty[i]).collect();
        let (mut z_hat, mut xi_hat) = (x.r.clone(), xi.clone());
        let (mut z_prev, mut xi_prev) = (x.r.clone(), xi.clone());
        let mut rhs = Mat::<f64>::zeros(n, 1);
        let (mut tau_prev, mut e_prev) = (1.0f64, f64::INFINITY);
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let mut iterations = 0;
        let outcome = loop {
            if x.residual() <= tol {
                break Outcome::Stopped;
            }
            if !(x.r.iter().chain(&x.u).all(|v| v.is_finite())) {
                break Outcome::NumericalFailure(format!(
                    "non-finite reaction or velocity after iteration {iterations}"
                ));
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            // r-update: (W + P) r = −q_s + P (ẑ − ξ̂).
            for i in 0..n {
                let s = if i % 3 == 0 {
                    mu[i / 3] * x.u[i + 1].hypot(x.u[i + 2])
                } else {
                    0.0
                };
                rhs[(i, 0)] = -(q[i] + s) + penalty[i] * (z_hat[i] - xi_hat[i]);
            }
            factors.solve_in_place(&mut rhs);
            // z-update and multiplier, keeping the previous z in z_hat for the dual residual.
            for (c, &m) in mu.iter().enumerate() {
                let s = 3 * c;
                let v = [0, 1, 2].map(|a| rhs[(s + a, 0)] + xi_hat[s + a]);
                x.r[s..s + 3].copy_from_slice(&project_onto_cone(m, v));
            }
            for i in 0..n {
                xi[i] = xi_hat[i] + rhs[(i, 0)] - x.r[i];
            }
            let primal = (0..n)
                .map(|i| d[i] * (rhs[(i, 0)] - x.r[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            let dual = rho * weighted_distance(&d, &z_hat, &x.r);
            let e = primal * primal + dual * dual;
            if e < self.restart_eta * e_prev {
                let tau = 0.5 * (1.0 + (1.0 + 4.0 * tau_prev * tau_prev).sqrt());
                let alpha = (tau_prev - 1.0) / tau;
                for i in 0..n {
                    z_hat[i] = x.r[i] + alpha * (x.r[i] - z_prev[i]);
                    xi_hat[i] = xi[i] + alpha * (xi[i] - xi_prev[i]);
                }
                (tau_prev, e_prev) = (tau, e);
            } else {
                tau_prev = 1.0;
                e_prev /= self.restart_eta;
                z_hat.copy_from_slice(&z_prev);
                xi_hat.copy_from_slice(&xi_prev);
            }
            if self.residual_balancing {
                let next = if primal > BALANCING_RATIO * dual {
                    rho * BALANCING_STEP
                } else if dual > BALANCING_RATIO * primal {
                    rho / BALANCING_STEP
                } else {
                    rho
                };
                if next != rho {
                    let ratio = rho / next;
                    xi.iter_mut().for_each(|v| *v *= ratio);
                    xi_hat.iter_mut().for_each(|v| *v *= ratio);
                    rho = next;
                    for (p, di) in penalty.iter_mut().zip(&d) {
                        *p = rho * di;
                    }
                    // A refactorisation cannot be interrupted: it is not started when the first
                    // one says it would end past the budget.
                    if monitor.cannot_fit(factor_time) {
                        break Outcome::TimeLimit;
                    }
                    factors = match Factors::new(problem, &penalty, None) {
                        Ok(f) => f,
                        Err(Refusal::TooMuchFill(reason)) => break Outcome::Unsupported(reason),
                        Err(Refusal::Failed(reason)) => break Outcome::NumericalFailure(reason),
                    };
                }
            }
            z_prev.copy_from_slice(&x.r);
            xi_prev.copy_from_slice(&xi);
            x.evaluate(problem);
            iterations += 1;
            monitor.record(iterations, &x.r);
            if stagnation.stagnated(iterations, x.residual()) {
                break Outcome::Stalled(stagnation.reason("relative cone residual"));
            }
        };
        monitor.finish(x.r, iterations, outcome)
    }
}

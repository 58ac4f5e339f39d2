//! Nonsmooth nonlinear conjugate gradient (NNCG): projected Gauss–Seidel sweeps accelerated by
//! Fletcher–Reeves conjugate directions, after Silcowitz, Niebe and Erleben (2010).
//!
//! A PGS sweep `x ↦ PGS(x)` is read as a step along the negative "gradient" `∇ = x − PGS(x)`.
//! One iteration:
//!
//! ```text
//! x⁺ = PGS(x),   ∇⁺ = x − x⁺,   β = ‖∇⁺‖² / ‖∇‖²
//! β > 1:  restart, p = 0
//! else:   x⁺ ← Π(x⁺ + β p),   p ← β p − ∇⁺
//! ```
//!
//! with `Π` PGS's projection (non-friction rows clamped, then friction rows to `±mu f_k`), so the
//! iterate stays feasible. The sweep is the one of [`crate::ProjectedSor`] with `ω = 1`.
//!
//! * **Problem class**: standard and boxed LCP with friction rows, as PGS (converges for SPD `A`
//!   in practice, with fewer sweeps than PGS on ill-conditioned problems; no proof — the method
//!   restarts to plain PGS whenever `β > 1`). Free (equality) rows are swept unclamped, as in
//!   PGS, and `Π` leaves them as they are.
//! * **Cost**: one PGS sweep (`O(n²)` on the dense `A`) plus `O(n)` per iteration, and the shared
//!   residual for the stopping rule.
//! * **Returns** the iterate with the smallest shared residual seen.
//! * **Never spins**: when the shared residual has not reached a new low (1 % below the best) in
//!   [`FIRST_ORDER_STAGNATION_WINDOW`] iterations, the solve stops `Stalled`
//!   ([`crate::solver`]'s stagnation rule).
//! * **Warm start**: uses [`Settings::warm_start`], projected.
//!
//! Reference: M. Silcowitz, S. Niebe, K. Erleben, *A nonsmooth nonlinear conjugate gradient method
//! for interactive contact force problems*, The Visual Computer 26, 2010.

use crate::problem::diagonal::usable_diagonal;
use crate::problem::metrics::residuals;
use crate::problem::Problem;
use crate::solver::{
    initial_impulse, Monitor, Outcome, Settings, SolveResult, Solver, Stagnation,
    FIRST_ORDER_STAGNATION_WINDOW,
};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "LCP, boxed LCP, friction rows, free (equality) rows unclamped (PGS sweeps with conjugate directions); SPD A in practice";

/// The registry's entry of `nncg`.
pub static NNCG: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "nncg",
    summary: "nonsmooth nonlinear conjugate gradient (PGS with Fletcher-Reeves directions)",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "sweeps (PGS sweeps with conjugate directions)",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(Nncg)),
};

/// One projected Gauss–Seidel sweep in place. Rows with a zero entry in `diag` (tiny diagonals,
/// [`usable_diagonal`]) are left alone, as in PGS.
pub(crate) fn pgs_sweep(problem: &Problem, diag: &[f64], f: &mut [f64]) {
    let b = problem.b();
    for i in 0..f.len() {
        if diag[i] <= 0.0 {
            continue;
        }
        let wi: f64 = problem.row(i).dot(f) + b[i];
        let (lo, hi) = problem.bounds_at(i, f);
        f[i] = (f[i] - wi / diag[i]).max(lo).min(hi);
    }
}

/// NNCG. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Nncg;

impl Solver for Nncg {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &NNCG
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        let n = problem.n();
        let diag = usable_diagonal(problem);
        let mut x = initial_impulse(problem, settings);
        let mut best = x.clone();
        let mut best_res = residuals(problem, &x).natural_map_rel;
        let mut p = vec![0.0; n];
        let mut grad_norm2 = f64::INFINITY;
        let mut previous = vec![0.0; n];
        let tol = settings.tolerance;
        let mut iterations = 0;
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let outcome = loop {
            if best_res <= tol {
                break Outcome::Stopped;
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            previous.copy_from_slice(&x);
            pgs_sweep(problem, &diag, &mut x);
            // ∇⁺ = previous − x (the sweep's step, negated).
            let g2: f64 = previous.iter().zip(&x).map(|(a, b)| (a - b).powi(2)).sum();
            let beta = g2 / grad_norm2;
            if iterations == 0 {
                // p₁ = −∇₁.
                for i in 0..n {
                    p[i] = x[i] - previous[i];
                }
            } else if beta.is_nan() || beta > 1.0 {
                p.fill(0.0);
            } else {
                // p ← β p − ∇⁺, then x ← Π(x + β p_old).
                for i in 0..n {
                    let step = x[i] - previous[i];
                    x[i] += beta * p[i];
                    p[i] = beta * p[i] + step;
                }
                problem.project_onto_bounds(&mut x);
            }
            grad_norm2 = g2;
            iterations += 1;
            monitor.record(iterations, &x);
            if x.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite iterate at iteration {iterations}"
                ));
            }
            let res = residuals(problem, &x).natural_map_rel;
            if res < best_res {
                best_res = res;
                best.copy_from_slice(&x);
            }
            if g2 == 0.0 {
                // A PGS fixed point that is not a solution (only with skipped rows).
                break Outcome::Stopped;
            }
            if stagnation.stagnated(iterations, best_res) {
                break Outcome::Stalled(stagnation.reason("relative residual"));
            }
        };
        monitor.finish(best, iterations, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::generate::{generate, Family};
    use crate::{Lemke, ProjectedSor, Status};

    #[test]
    fn agrees_with_lemke_on_spd_in_fewer_sweeps_than_pgs() {
        for seed in 0..3 {
            let g = generate(Family::Spd { cond: 1e3 }, 40, seed);
            let reference = Lemke::default().solve(&g.problem, &Settings::default());
            assert_eq!(reference.status, Status::Converged);
            let r = Nncg.solve(&g.problem, &Settings::default());
            assert_eq!(r.status, Status::Converged, "seed {seed}");
            for (x, y) in r.f.iter().zip(&reference.f) {
                assert!((x - y).abs() < 1e-5, "seed {seed}");
            }
            let pgs = ProjectedSor::pgs().solve(&g.problem, &Settings::default());
            assert!(
                r.iterations < pgs.iterations,
                "seed {seed}: nncg {} sweeps, pgs {}",
                r.iterations,
                pgs.iterations
            );
        }
    }
}

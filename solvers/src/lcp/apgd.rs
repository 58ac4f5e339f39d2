//! Accelerated projected gradient descent (APGD): Nesterov's method with adaptive restart on the
//! quadratic program of the contact problem, as Mazhar et al. (2015) use it for cone-complementarity
//! problems in Chrono.
//!
//! For symmetric `A` the LCP is the optimality condition of `min ½ fᵀA f + bᵀf` over the bounds.
//! One iteration, from the extrapolated point `y`:
//!
//! ```text
//! g = A y + b,   f⁺ = Π(y − g / L)        (L doubled until the quadratic upper bound holds)
//! θ⁺ = (θ √(θ² + 4) − θ²) / 2,   β = θ (1 − θ) / (θ² + θ⁺),   y⁺ = f⁺ + β (f⁺ − f)
//! restart (y⁺ = f⁺, θ⁺ = 1) when gᵀ(f⁺ − f) > 0;   L ← 0.9 L
//! ```
//!
//! `Π` is PGS's projection: every non-friction row clamped to `[lo, hi]`, then every friction row
//! to `±mu f_k` at the projected normal (for box friction a non-Euclidean projection onto the
//! friction pyramid, as Mazhar et al.'s approximate cone projection). The initial `L` is
//! `‖A (f₀ − f̂)‖ / ‖f₀ − f̂‖` with `f̂ = f₀ + e`.
//!
//! * **Problem class**: standard and boxed LCP with friction rows for symmetric `A` (checked;
//!   non-symmetric `A` has no objective and is `Unsupported`). `O(1/k²)` convergence of the
//!   objective for SPD and PSD `A` with fixed bounds; with friction rows a heuristic fixed point.
//!   Free (equality) rows are unconstrained variables of the objective (`Π` leaves them as they
//!   are); the step `1/L` is set by the stiffest direction, so joints with large mass ratios
//!   (ill-conditioned `A`) slow the method down, and it then ends at the cap or stalls.
//! * **Cost**: two to three products with `A` per iteration (the gradient, the objective at the
//!   trial point, and the shared residual), `O(n²)` each on the dense `A`.
//! * **Returns** the iterate with the smallest shared residual seen (the method is not monotone).
//! * **Stopping rule**: shared relative residual at most the tolerance.
//! * **Never spins**: when the shared residual has not reached a new low (1 % below the best) in
//!   [`FIRST_ORDER_STAGNATION_WINDOW`] iterations, the solve stops `Stalled`
//!   ([`crate::solver`]'s stagnation rule).
//! * **Warm start**: uses [`Settings::warm_start`], projected.
//!
//! References: H. Mazhar, T. Heyn, D. Negrut, A. Tasora, *Using Nesterov's method to accelerate
//! multibody dynamics with friction and contact*, ACM TOG 34(3), 2015; B. O'Donoghue, E. Candès,
//! *Adaptive restart for accelerated gradient schemes*, Found. Comput. Math. 15, 2015.

use crate::problem::metrics::residuals;
use crate::problem::Problem;
use crate::solver::line_search::{Backtracking, ARMIJO_SIGMA, HALVING};
use crate::solver::{
    initial_impulse, Monitor, Outcome, Settings, SolveResult, Solver, Stagnation,
    FIRST_ORDER_STAGNATION_WINDOW,
};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "LCP, boxed LCP, friction rows (PGS projection), free (equality) rows unprojected; symmetric A only; O(1/k^2) for SPD/PSD";

/// The registry's entry of `apgd`.
pub static APGD: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "apgd",
    summary: "accelerated projected gradient descent (Nesterov with adaptive restart)",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "projected gradient steps",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(Apgd)),
};

/// Doublings of the Lipschitz estimate in one iteration before the step is taken as it is: `2⁶⁰`
/// (about `10¹⁸`) covers any estimate from a unit trial step to the stiffest Delassus matrix in
/// double precision.
const LIPSCHITZ_DOUBLINGS: usize = 60;

/// Relative slack in the quadratic upper-bound test (of `|objective|`): a few hundred machine
/// epsilons, so that a bound met up to round-off is accepted instead of doubling `L` for nothing.
const BOUND_SLACK: f64 = 1e-14;

fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// APGD. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Apgd;

impl Solver for Apgd {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &APGD
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        if !problem.is_symmetric(1e-10) {
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(
                    "A is not symmetric: APGD needs the quadratic objective ½fᵀAf + bᵀf".into(),
                ),
            );
        }
        let n = problem.n();
        let b = problem.b();
        // Objective from f and w = A f + b: ½ fᵀ(w + b).
        let objective = |f: &[f64], w: &[f64]| -> f64 {
            0.5 * f
                .iter()
                .zip(w)
                .zip(b)
                .map(|((x, y), z)| x * (y + z))
                .sum::<f64>()
        };
        let mut f = initial_impulse(problem, settings);
        let mut lipschitz = {
            let fh: Vec<f64> = f.iter().map(|v| v + 1.0).collect();
            let (w0, w1) = (problem.velocity(&f), problem.velocity(&fh));
            let num = w0
                .iter()
                .zip(&w1)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>();
            let l = (num / n.max(1) as f64).sqrt();
            if l.is_finite() && l > 0.0 {
                l
            } else {
                1.0
            }
        };
        let mut y = f.clone();
        let mut theta: f64 = 1.0;
        let mut best = f.clone();
        let mut best_res = residuals(problem, &f).natural_map_rel;
        let tol = settings.tolerance;
        let mut iterations = 0;
        let mut trial = vec![0.0; n];
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        // `search` applies the upper-bound test below, so `σ` plays no part here.
        let lipschitz_search = Backtracking::new(ARMIJO_SIGMA, HALVING, LIPSCHITZ_DOUBLINGS + 1)
            .expect("valid constants");
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
            let g = problem.velocity(&y);
            let obj_y = objective(&y, &g);
            // Backtracking on the Lipschitz estimate: the step `s / L₀` is tried for
            // `s = 1, ½, ¼, …`, i.e. `L = L₀ / s` doubles, until the quadratic upper bound holds.
            // When no step passes, the last one tried stands.
            let l0 = lipschitz;
            let s = lipschitz_search
                .search(|s| {
                    let l = l0 / s;
                    let t = 1.0 / l;
                    for i in 0..n {
                        trial[i] = y[i] - t * g[i];
                    }
                    problem.project_onto_bounds(&mut trial);
                    let w = problem.velocity(&trial);
                    let step: Vec<f64> = trial.iter().zip(&y).map(|(x, z)| x - z).collect();
                    let bound = obj_y + dot(&g, &step) + 0.5 * l * dot(&step, &step);
                    objective(&trial, &w) <= bound + BOUND_SLACK * obj_y.abs().max(1e-300)
                })
                .unwrap_or_else(|last| last);
            lipschitz = l0 / s;
            let theta_next = 0.5 * (theta * (theta * theta + 4.0).sqrt() - theta * theta);
            let beta = theta * (1.0 - theta) / (theta * theta + theta_next);
            let restart = (0..n).map(|i| g[i] * (trial[i] - f[i])).sum::<f64>() > 0.0;
            for i in 0..n {
                y[i] = if restart {
                    trial[i]
                } else {
                    trial[i] + beta * (trial[i] - f[i])
                };
            }
            theta = if restart { 1.0 } else { theta_next };
            std::mem::swap(&mut f, &mut trial);
            lipschitz *= 0.9;
            iterations += 1;
            monitor.record(iterations, &f);
            if f.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite iterate at iteration {iterations}"
                ));
            }
            let res = residuals(problem, &f).natural_map_rel;
            if res < best_res {
                best_res = res;
                best.copy_from_slice(&f);
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
    use crate::{Lemke, Status};

    #[test]
    fn agrees_with_lemke_on_spd() {
        for seed in 0..3 {
            let g = generate(Family::Spd { cond: 1e2 }, 30, seed);
            let reference = Lemke::default().solve(&g.problem, &Settings::default());
            assert_eq!(reference.status, Status::Converged);
            let r = Apgd.solve(&g.problem, &Settings::default());
            assert_eq!(r.status, Status::Converged, "seed {seed}");
            for (x, y) in r.f.iter().zip(&reference.f) {
                assert!((x - y).abs() < 1e-6, "seed {seed}");
            }
        }
    }

    #[test]
    fn non_symmetric_is_unsupported() {
        let g = generate(Family::PMatrix, 5, 0);
        let r = Apgd.solve(&g.problem, &Settings::default());
        assert_eq!(r.status.name(), "unsupported");
    }
}

//! The extragradient (projection) method on De Saxcé's map with a self-adaptive step, for the
//! exact Coulomb cone.
//!
//! Khobotov's extragradient iteration with the step of [`crate::cone::projected_step`]: a
//! predictor step, then a corrector from the same point along the predictor's map,
//!
//! ```text
//! r̄_c  = P_{K_c}(r_c − (ρ / d_c) û_c(r)),
//! r⁺_c = P_{K_c}(r_c − (ρ / d_c) û_c(r̄)),      û = u + mu ‖u_T‖ e_N,  u = W r + q,
//! ```
//!
//! `ρ` shrinking (×0.6, at most 10 times) until the predictor passes
//! `ρ ‖û(r̄) − û(r)‖ <= 0.9 ‖r̄ − r‖` (norms weighted by `1/d_c` and `d_c`), and growing (÷0.7)
//! after an iteration whose predictor was well inside that test (`< 0.3 ‖r̄ − r‖`) and whose
//! corrector lowered the residual. (Siconos' `FC3D_ExtraGradient` takes its corrector from `r̄`
//! instead of `r`; this is the textbook form, for which the test is the one of the convergence
//! proof on monotone maps.)
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]), dense or sparse `W`, with positive
//!   diagonal scales. De Saxcé's map is not monotone, so the monotone-VI convergence proof does
//!   not apply; in practice it behaves like the fixed-point projection with a longer stable step.
//! * **Cost**: two passes over `W` per iteration (predictor and corrector, each giving the
//!   velocity and the cone residual together), one more per rejected trial; `O(n)` projections.
//!   No allocation per iteration.
//! * **Stopping rule**: the cone residual ([`crate::cone`]) of the iterate, or of a predictor,
//!   is at most the tolerance. `Stalled` when the residual has not reached a new low by 1 % in
//!   [`crate::FIRST_ORDER_STAGNATION_WINDOW`] iterations or the step falls below `10⁻¹²`;
//!   `NumericalFailure` on a non-finite iterate; the time budget is checked before every trial.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones.
//!
//! References: G. M. Korpelevich, *The extragradient method for finding saddle points and other
//! problems*, Matecon 12, 1976; E. N. Khobotov, USSR Comput. Math. Math. Phys. 27, 1987;
//! V. Acary, M. Brémond, O. Huber, 2018; Siconos' `FC3D_ExtraGradient`
//! (`fc3d_ExtraGradient.c`, its variable-step rule).

use crate::cone::projected_step::{
    backtracked_projection, check, inverse_scales, projected_step, AdaptiveStep, Point,
};
use crate::cone::{ConeMonitor, ConeProblem, ConeSolver};
use crate::solver::{Outcome, Settings, SolveResult, Stagnation, FIRST_ORDER_STAGNATION_WINDOW};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone (exact Coulomb); extragradient on De Saxcé's map, self-adaptive step, dense or sparse W";

/// The registry's entry of `eg-cone`.
pub static EG_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "eg-cone",
    summary: "extragradient (Khobotov) projection method on De Saxcé's map, self-adaptive step",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "extragradient steps",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(ExtragradientCone)),
};

/// The extragradient method on the cone. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ExtragradientCone;

impl ConeSolver for ExtragradientCone {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &EG_CONE
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let (n, tol) = (problem.n(), settings.tolerance);
        let inv_d = inverse_scales(problem);
        let mut x = Point::start(problem, settings);
        let (mut predictor, mut corrector) = (Point::zeros(n), Point::zeros(n));
        let mut step = AdaptiveStep::new();
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let mut iterations = 0;
        let outcome = loop {
            if let Some(outcome) = check(&x, tol, iterations, settings, &monitor, &step) {
                break outcome;
            }
            let Some(used) =
                backtracked_projection(problem, &inv_d, &x, &step, tol, &monitor, &mut predictor)
            else {
                break Outcome::TimeLimit;
            };
            iterations += 1;
            if predictor.residual() <= tol {
                std::mem::swap(&mut x, &mut predictor);
                monitor.record(iterations, &x.r);
                continue;
            }
            let (rho, sides) = used;
            projected_step(
                problem,
                &inv_d,
                rho,
                &x.r,
                &predictor.u_hat,
                &mut corrector.r,
            );
            corrector.evaluate(problem);
            step.update(rho, sides, corrector.residual() < x.residual());
            std::mem::swap(&mut x, &mut corrector);
            monitor.record(iterations, &x.r);
            if stagnation.stagnated(iterations, x.residual()) {
                break Outcome::Stalled(stagnation.reason("relative cone residual"));
            }
        };
        monitor.finish(x.r, iterations, outcome)
    }
}

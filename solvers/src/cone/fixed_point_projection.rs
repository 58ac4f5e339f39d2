//! Fixed-point projection on De Saxcé's map (FPP) with a self-adaptive step, for the exact
//! Coulomb cone.
//!
//! One iteration is one projected step from the current reaction, its length chosen by the
//! self-adaptive rule of [`crate::cone::projected_step`]:
//!
//! ```text
//! r⁺_c = P_{K_c}(r_c − (ρ / d_c) û_c(r)),   û = u + mu ‖u_T‖ e_N,  u = W r + q,
//! ```
//!
//! `ρ` shrinking (×0.6, at most 10 times) until `ρ ‖û(r⁺) − û(r)‖ <= 0.9 ‖r⁺ − r‖` (norms weighted
//! by `1/d_c` and `d_c`) and growing (÷0.7) after a step well inside that test (`< 0.3 ‖r⁺ − r‖`)
//! that lowered the residual. A fixed point is a solution: `r = P_K(r − ρ D⁻¹ û)` is the natural
//! map of the cone problem.
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]), dense or sparse `W`, with positive
//!   diagonal scales. De Saxcé's map is not monotone, so there is no convergence proof; with a
//!   small enough step the iteration contracts where `W` is well conditioned, and slows to a crawl
//!   where it is not (the slowest of the solvers in Acary, Brémond, Huber's comparison).
//! * **Cost**: per trial step one pass over `W` (the velocity and the cone residual together),
//!   `O(n)` projections; most iterations take one trial. No allocation per iteration.
//! * **Stopping rule**: the cone residual ([`crate::cone`]) of the iterate (or of a trial step)
//!   is at most the tolerance. `Stalled` when the residual has not reached a new low by 1 % in
//!   [`crate::FIRST_ORDER_STAGNATION_WINDOW`] iterations or the step falls below `10⁻¹²`;
//!   `NumericalFailure` on a non-finite iterate; the time budget is checked before every trial.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones.
//!
//! References: V. Acary, M. Brémond, O. Huber, *On solving contact problems with Coulomb
//! friction: formulations and numerical comparisons*, 2018 (§ on projection methods); Siconos'
//! `FC3D_FixedPointProjection` (`fc3d_FixedPointProjection.c`, its variable-step rule);
//! E. N. Khobotov, *Modification of the extra-gradient method for solving variational
//! inequalities and certain optimization problems*, USSR Comput. Math. Math. Phys. 27, 1987.

use crate::cone::projected_step::{
    backtracked_projection, check, inverse_scales, AdaptiveStep, Point,
};
use crate::cone::{ConeMonitor, ConeProblem, ConeSolver};
use crate::solver::{Outcome, Settings, SolveResult, Stagnation, FIRST_ORDER_STAGNATION_WINDOW};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone (exact Coulomb); projected fixed point on De Saxcé's map, self-adaptive step, dense or sparse W";

/// The registry's entry of `fpp-cone`.
pub static FPP_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "fpp-cone",
    summary: "fixed-point projection on De Saxcé's map, self-adaptive step",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "projection steps",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(FixedPointProjectionCone)),
};

/// Fixed-point projection on the cone. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FixedPointProjectionCone;

impl ConeSolver for FixedPointProjectionCone {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &FPP_CONE
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let (n, tol) = (problem.n(), settings.tolerance);
        let inv_d = inverse_scales(problem);
        let mut x = Point::start(problem, settings);
        let mut trial = Point::zeros(n);
        let mut step = AdaptiveStep::new();
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let mut iterations = 0;
        let outcome = loop {
            if let Some(outcome) = check(&x, tol, iterations, settings, &monitor, &step) {
                break outcome;
            }
            let Some(used) =
                backtracked_projection(problem, &inv_d, &x, &step, tol, &monitor, &mut trial)
            else {
                break Outcome::TimeLimit;
            };
            step.update(used.0, used.1, trial.residual() < x.residual());
            std::mem::swap(&mut x, &mut trial);
            iterations += 1;
            monitor.record(iterations, &x.r);
            if stagnation.stagnated(iterations, x.residual()) {
                break Outcome::Stalled(stagnation.reason("relative cone residual"));
            }
        };
        monitor.finish(x.r, iterations, outcome)
    }
}

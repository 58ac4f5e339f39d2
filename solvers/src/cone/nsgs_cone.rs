//! Nonsmooth Gauss–Seidel over contacts (NSGS) on the exact Coulomb cone.
//!
//! A sweep visits the contacts in order and solves each contact's problem exactly with the other
//! reactions fixed:
//!
//! ```text
//! u_c = W_cc r_c + q_c',   q_c' = q_c + Σ_{d ≠ c} W_cd r_d,   K_c ∋ r_c ⟂ û_c ∈ K_c*,
//! ```
//!
//! taking off (`q_c'_N >= 0`) and sticking (`W_cc r_c = −q_c'` inside the cone) in closed form
//! and sliding by a local Alart–Curnier Newton with Armijo backtracking (at most 30 iterations,
//! projected fixed-point steps where Newton fails).
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]) with `W_cc` positive definite per contact.
//!   A fixed point without a general convergence proof (Coulomb friction is not a convex
//!   problem); it is the default solver of Siconos' FC3D and converges on the contact problems
//!   of rigid-body scenes in Acary, Brémond, Huber's comparison.
//! * **Cost**: per sweep one pass over `W` for the `q_c'`, plus `O(1)` 3×3 solves per contact.
//! * **Stopping rule**: the cone residual ([`crate::cone`]) is at most the tolerance.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones.
//!
//! References: M. Jean, *The non-smooth contact dynamics method*, CMAME 177, 1999; V. Acary,
//! M. Brémond, O. Huber, 2018 (NSGS with the local Alart–Curnier Newton, Siconos'
//! `NSGS` + `ONECONTACT_NSN`).

use crate::cone::alart_curnier::solve_contact;
use crate::cone::{cone_residuals, initial_reaction, ConeMonitor, ConeProblem, ConeSolver};
use crate::solver::{Outcome, Settings, SolveResult};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone (exact Coulomb); each contact solved exactly per sweep (closed-form take-off/stick, local Alart–Curnier Newton for sliding)";

/// NSGS on the cone. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NsgsCone;

impl ConeSolver for NsgsCone {
    fn name(&self) -> &'static str {
        "nsgs-cone"
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let w = problem.delassus();
        let q = problem.q();
        let blocks: Vec<[[f64; 3]; 3]> =
            (0..problem.contacts()).map(|c| problem.block(c)).collect();
        let mut r = initial_reaction(problem, settings);
        let mut previous = r.clone();
        let mut iterations = 0;
        let outcome = loop {
            if cone_residuals(problem, &r).natural_map_rel <= settings.tolerance {
                break Outcome::Stopped;
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            previous.copy_from_slice(&r);
            for (c, (&mu, wcc)) in problem.mu().iter().zip(&blocks).enumerate() {
                let rc = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
                let mut qc = [0.0; 3];
                for (a, qa) in qc.iter_mut().enumerate() {
                    let i = 3 * c + a;
                    let own: f64 = (0..3).map(|b| wcc[a][b] * rc[b]).sum();
                    *qa = w.row(i).dot(&r) + q[i] - own;
                }
                let next = solve_contact(mu, wcc, qc, rc);
                r[3 * c..3 * c + 3].copy_from_slice(&next);
            }
            iterations += 1;
            monitor.record(iterations, &r);
            if r.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite reaction in sweep {iterations}"
                ));
            }
            if previous == r {
                break Outcome::Stalled(format!(
                    "sweep {iterations} left every reaction unchanged (a fixed point of the \
                     contact sweep that is not a solution)"
                ));
            }
        };
        monitor.finish(r, iterations, outcome)
    }
}

//! The result row of one run (one line of `results.csv`) and the convergence-history rows.
//!
//! Every column is documented on its field; empty cells mean "does not apply" (scene columns on
//! an LCP case, an analytic error on a scene without one, a time-to-accuracy never reached).

use serde::{Deserialize, Serialize};

/// The relative residuals at which time-to-accuracy is recorded.
pub const TTA_LEVELS: [f64; 4] = [1e-4, 1e-6, 1e-8, 1e-10];

/// One run: (case, solver, budget) and everything measured.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Case key (see [`crate::harness::case`]).
    pub case: String,
    /// Problem class (`spd`, `rank_deficient`, `non_symmetric`, `degenerate`, `infeasible`,
    /// `friction`, `scene`).
    pub class: String,
    /// Family label (`spd`, `psd`, ..., `file`, `scene`).
    pub family: String,
    /// Rows of the LCP; for a scene, the largest number of LCP rows in a step.
    pub n: Option<usize>,
    /// Solver specification (`pgs`, `sor@1.7`, `pgs+warm`, ...).
    pub solver: String,
    /// Solver name without variant.
    pub solver_base: String,
    /// SOR relaxation, when set.
    pub omega: Option<f64>,
    /// Warm start.
    pub warm: bool,
    /// Budget name.
    pub budget: String,
    /// Tolerance of the budget.
    pub tolerance: f64,
    /// Iteration cap of the budget.
    pub max_iterations: usize,
    /// Time budget in seconds.
    pub time_budget_s: f64,
    /// Outcome: a solver [`Status`](lcpbench_solvers::Status) name for an LCP; for a scene
    /// `converged` when every step converged, otherwise the worst step status or `blow_up`; for
    /// isolation failures `panic`, `crash`, `timeout` or `error`.
    pub status: String,
    /// Why, when there is a reason.
    pub reason: String,
    /// True when the run met its tolerance (every step, for a scene).
    pub converged: bool,
    /// Iterations or pivots (a scene: summed over steps).
    pub iterations: Option<usize>,
    /// Solver wall time in seconds (a scene: summed over steps), measurement excluded.
    pub solve_time_s: Option<f64>,
    /// Wall time of the whole child process, seen from the parent.
    pub wall_time_s: f64,
    /// Shared relative natural-map residual of the returned impulse (a scene: largest over steps).
    pub residual_rel: Option<f64>,
    /// Absolute natural-map residual (a scene: largest over steps).
    pub residual_abs: Option<f64>,
    /// Complementarity gap (a scene: largest over steps).
    pub complementarity_gap: Option<f64>,
    /// Bound violation (a scene: largest over steps).
    pub bound_violation: Option<f64>,
    /// `‖f − f*‖∞ / max(‖f*‖∞, 1)` against a planted solution known to be unique.
    pub solution_error: Option<f64>,
    /// Solver time in seconds until the relative residual first reached `1e-4`.
    pub tta_1e4: Option<f64>,
    /// Same, `1e-6`.
    pub tta_1e6: Option<f64>,
    /// Same, `1e-8`.
    pub tta_1e8: Option<f64>,
    /// Same, `1e-10`.
    pub tta_1e10: Option<f64>,
    /// Scene: steps taken.
    pub steps: Option<usize>,
    /// Scene: mean contacts per step.
    pub contacts_mean: Option<f64>,
    /// Scene: largest contact count in a step.
    pub contacts_max: Option<usize>,
    /// Scene: mean solver time per step, seconds.
    pub time_per_step_s: Option<f64>,
    /// Scene: mean wall time per step (detection, build, solve, integrate), seconds.
    pub step_time_s: Option<f64>,
    /// Scene: mean iterations per step.
    pub iterations_per_step: Option<f64>,
    /// Scene: mean relative residual over steps.
    pub residual_rel_mean: Option<f64>,
    /// Scene: steps whose solve did not converge.
    pub nonconverged_steps: Option<usize>,
    /// Scene: steps with a non-finite impulse or state.
    pub nan_steps: Option<usize>,
    /// Scene: steps where the stepper fell back to another solver.
    pub fallback_steps: Option<usize>,
    /// Scene: the state blew up (non-finite, or speeds or energy far beyond the initial ones).
    pub blow_up: Option<bool>,
    /// Scene: largest penetration depth over the run, metres.
    pub penetration_max: Option<f64>,
    /// Scene: mean over steps of the largest penetration, metres.
    pub penetration_mean: Option<f64>,
    /// Scene: total energy change over the run relative to the initial energy scale.
    pub energy_drift: Option<f64>,
    /// Scene: linear-momentum change relative to its scale (scenes that conserve it).
    pub momentum_drift: Option<f64>,
    /// Scene: drop of the top body below its rest height, metres (stacks).
    pub sag: Option<f64>,
    /// Scene: horizontal displacement of the top body, metres (stacks).
    pub lateral_drift: Option<f64>,
    /// Scene: name of the analytic quantity compared (from the scene's `[metrics]` table).
    pub analytic_metric: String,
    /// Scene: error against the analytic answer.
    pub analytic_error: Option<f64>,
    /// Scene: V-groove symmetry error `|F_left − F_right| / F_expected` at the last step.
    pub symmetry_error: Option<f64>,
    /// Scene (resting scenes): `|Σ support force − total weight| / total weight` at the last
    /// step, from the impulses on contacts with static bodies.
    pub support_error: Option<f64>,
    /// Scene: largest body speed over the run, m/s.
    pub max_speed: Option<f64>,
    /// Scene: largest contact slip speed over bodies that should stick, m/s.
    pub creep_speed: Option<f64>,
    /// Scene: kinetic energy in the final second (scenes that should come to rest), J.
    pub ke_rest: Option<f64>,
    /// Scene: largest friction-cone violation `max(|f_t| − mu f_n, 0)` over steps.
    pub cone_violation: Option<f64>,
    /// Scene: largest separating normal speed at sliding contacts right after a solve, m/s
    /// (the lift-off that a convex relaxation of friction causes).
    pub liftoff_speed: Option<f64>,
}

impl RunRecord {
    /// The resume key: (case, solver, budget).
    pub fn key(&self) -> (String, String, String) {
        (self.case.clone(), self.solver.clone(), self.budget.clone())
    }

    /// Time to reach relative residual `level` (one of [`TTA_LEVELS`]).
    pub fn tta(&self, level: f64) -> Option<f64> {
        if level >= 1e-4 {
            self.tta_1e4
        } else if level >= 1e-6 {
            self.tta_1e6
        } else if level >= 1e-8 {
            self.tta_1e8
        } else {
            self.tta_1e10
        }
    }

    /// Set the time-to-accuracy columns from a list aligned with [`TTA_LEVELS`].
    pub fn set_tta(&mut self, values: [Option<f64>; 4]) {
        [self.tta_1e4, self.tta_1e6, self.tta_1e8, self.tta_1e10] = values;
    }

    /// True for failures of the isolation layer (`panic`, `crash`, `timeout`, `error`).
    pub fn is_isolation_failure(&self) -> bool {
        matches!(
            self.status.as_str(),
            "panic" | "crash" | "timeout" | "error"
        )
    }
}

/// One point of a convergence history, as stored in `histories.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryRow {
    /// Case key.
    pub case: String,
    /// Solver specification.
    pub solver: String,
    /// Budget name.
    pub budget: String,
    /// Iteration or pivot count.
    pub iteration: usize,
    /// Solver time so far, seconds.
    pub time_s: f64,
    /// Relative natural-map residual.
    pub residual: f64,
}

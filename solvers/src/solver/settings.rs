//! The settings every solver shares, and the checks they must pass.

use std::time::Duration;
use thiserror::Error;

/// Settings shared by every solver. Solver-specific parameters (SOR's `omega`, ...) live on the
/// solver value itself.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Tolerance on the relative natural-map residual
    /// ([`Residuals::natural_map_rel`](crate::Residuals::natural_map_rel)). Default `1e-8`.
    pub tolerance: f64,
    /// Cap on iterations, in the unit of each solver's iteration count (its registry entry's
    /// `iteration_unit`, which `lcpbench solvers` prints: sweeps, pivots, Newton steps,
    /// interior-point iterations, …). It is a total for one solve: a solver that splits the problem into independent islands
    /// gives each island what the islands before it left, and ends `iteration_limit` when
    /// nothing is left. Default `10_000`.
    pub max_iterations: usize,
    /// Wall-time budget; `None` (the default) means none.
    pub time_budget: Option<Duration>,
    /// Initial impulse for solvers that can use one: used, projected onto the bounds (onto the
    /// cones for a cone solver), by the solvers whose registry entry is `iterative` (marked
    /// `+warm` by `lcpbench solvers`); enumeration uses it only to order its first guesses of
    /// the active set; the pivoting and interior-point solvers start from their own initial
    /// point and ignore it. The time stepper of `lcpbench-contact` passes it to iterative and
    /// cone solvers only. Default `None` (zero).
    pub warm_start: Option<Vec<f64>>,
    /// Record the shared residual after every iteration (time spent measuring it is excluded from
    /// the reported wall time). Default `false`.
    pub record_history: bool,
    /// Measure the shared residual of the returned impulse when the solve has not measured that
    /// impulse already (for its own stopping rule). Default `true`. With `false`, such a result
    /// carries [`Residuals::NOT_MEASURED`](crate::Residuals::NOT_MEASURED) and an empty `w`, and
    /// its status is what the solver's own loop says without the residual: never `Converged`
    /// (a stopping rule met is `Stalled`, with a reason saying the residual was not measured),
    /// else the iteration or time limit, stall or failure it ended on. A solve that did measure
    /// the returned impulse decides as usual. The time stepper of `lcpbench-contact` sets it
    /// from its residual schedule.
    pub measure_result: bool,
}

/// Why [`Settings`] were refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SettingsError {
    /// The tolerance must be a finite number in `(0, 1)`: a relative residual of 1 is met by a
    /// zero impulse on most problems, so a tolerance of 1 or more claims convergence for
    /// nothing, and zero, negative or NaN tolerances can never be met.
    #[error(
        "settings.tolerance must be a finite number in (0, 1) on the relative residual, got {0}"
    )]
    Tolerance(f64),
    /// At least one iteration must be allowed.
    #[error("settings.max_iterations must be at least 1, got 0")]
    MaxIterations,
}

impl Settings {
    /// Default settings with the given tolerance and iteration cap, checked
    /// ([`Settings::validate`]).
    pub fn new(tolerance: f64, max_iterations: usize) -> Result<Self, SettingsError> {
        let settings = Self {
            tolerance,
            max_iterations,
            ..Self::default()
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Check the settings: [`Settings::tolerance`] finite and in `(0, 1)`,
    /// [`Settings::max_iterations`] at least 1. Any time budget is valid (a zero one is spent
    /// before the first iteration), and a warm start of the wrong length or with non-finite
    /// entries is ignored rather than refused. A solve given settings that fail this check
    /// returns [`crate::Status::Unsupported`] with the reason.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let tol = self.tolerance;
        if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
            return Err(SettingsError::Tolerance(tol));
        }
        if self.max_iterations == 0 {
            return Err(SettingsError::MaxIterations);
        }
        Ok(())
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: 10_000,
            time_budget: None,
            warm_start: None,
            record_history: false,
            measure_result: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_checked() {
        assert!(Settings::default().validate().is_ok());
        assert!(Settings::new(1e-300, 1).is_ok());
        for tol in [0.0, -1e-8, 1.0, 2.0, f64::NAN, f64::INFINITY] {
            assert!(
                matches!(Settings::new(tol, 10), Err(SettingsError::Tolerance(_))),
                "{tol}"
            );
        }
        assert_eq!(Settings::new(1e-8, 0), Err(SettingsError::MaxIterations));
        let msg = SettingsError::Tolerance(2.0).to_string();
        assert!(msg.contains("(0, 1)") && msg.contains('2'), "{msg}");
    }

    /// Without the final measurement no solver claims convergence on a residual it did not
    /// measure, and a result that does carry residuals carries the true ones (recomputed here
    /// independently); an iteration-capped PGS solve returns unmeasured.
    #[test]
    fn an_unmeasured_result_is_never_converged() {
        use crate::{residuals, Problem, Residuals, SolverKind, Status};
        let a = faer::Mat::from_fn(3, 3, |i, j| if i == j { 4.0 } else { 1.0 });
        let p = Problem::lcp(a, vec![-1.0, 2.0, -3.0]).unwrap();
        let unmeasured = Settings {
            measure_result: false,
            ..Settings::default()
        };
        for kind in SolverKind::all() {
            let r = kind.create().solve(&p, &unmeasured);
            let name = kind.name();
            if r.residuals.is_measured() {
                assert_eq!(r.residuals, residuals(&p, &r.f), "{name}");
            } else {
                assert!(!r.status.is_converged(), "{name}: {}", r.status);
                assert!(r.w.is_empty(), "{name}");
            }
        }
        let capped = Settings {
            max_iterations: 1,
            ..unmeasured
        };
        let r = SolverKind::Pgs.create().solve(&p, &capped);
        assert_eq!(r.status, Status::IterationLimit);
        assert!(!r.residuals.is_measured());
        assert!(r.residuals.natural_map_rel.is_nan());
        assert!(!Residuals::NOT_MEASURED.is_measured());
        let measured = SolverKind::Pgs.create().solve(
            &p,
            &Settings {
                measure_result: true,
                ..capped
            },
        );
        assert_eq!(
            measured.f, r.f,
            "the measurement does not change the iterate"
        );
        assert_eq!(measured.residuals, residuals(&p, &r.f));
    }

    /// A solve given a tolerance of 1 or more does not claim convergence.
    #[test]
    fn a_solve_with_invalid_settings_is_refused() {
        use crate::{Problem, SolverKind, Status};
        let p = Problem::lcp(faer::Mat::from_fn(1, 1, |_, _| 2.0), vec![-1.0]).unwrap();
        let bad = Settings {
            tolerance: 2.0,
            ..Settings::default()
        };
        for kind in SolverKind::all() {
            let r = kind.create().solve(&p, &bad);
            match r.status {
                Status::Unsupported { reason } => assert!(reason.contains("tolerance"), "{reason}"),
                other => panic!("{}: {other}", kind.name()),
            }
        }
    }
}

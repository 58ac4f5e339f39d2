//! Budgets: the tolerance, iteration cap and time budget of a run, the presets, and the name a
//! budget carries in CSV rows ([`BudgetName`]: a preset, or a custom `TOL:ITER:SECONDS`).

use crate::harness::text::serde_as_text;
use lcpbench_solvers::Settings;
use std::fmt;
use std::time::Duration;
use thiserror::Error;

/// A malformed budget.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BudgetError {
    /// A budget that is neither a preset nor `TOL:ITER:SECONDS`.
    #[error("budget `{0}`: expected a preset (loose, default, tight, realtime) or TOL:ITER:SECONDS such as 1e-6:500:2")]
    Budget(String),
    /// A budget of the right shape whose tolerance, iteration cap or time is out of range.
    #[error("budget `{spec}`: {message}")]
    BudgetValue {
        /// The budget as given.
        spec: String,
        /// What is wrong.
        message: String,
    },
}

/// Largest time budget accepted, seconds (about 31 years). Larger values, and values whose
/// derived kill time cannot be represented as a [`Duration`], are refused up front.
pub const MAX_TIME_BUDGET_S: f64 = 1e9;

/// Smallest time budget accepted, seconds: a microsecond, about the cost of reading the clock a
/// few times. A budget below it would end every solve before its first iteration.
pub const MIN_TIME_BUDGET_S: f64 = 1e-6;

/// Check a time budget in seconds: finite, at least [`MIN_TIME_BUDGET_S`], at most
/// [`MAX_TIME_BUDGET_S`], and representable as a [`Duration`]. The error says what is wrong.
pub fn time_budget(seconds: f64) -> Result<Duration, String> {
    if !(seconds.is_finite() && seconds > 0.0) {
        return Err(format!(
            "time budget must be a positive number of seconds, got {seconds}"
        ));
    }
    if seconds < MIN_TIME_BUDGET_S {
        return Err(format!(
            "time budget {seconds:e} s is below the minimum of {MIN_TIME_BUDGET_S:e} s"
        ));
    }
    if seconds > MAX_TIME_BUDGET_S {
        return Err(format!(
            "time budget {seconds:e} s is beyond the limit of {MAX_TIME_BUDGET_S:e} s"
        ));
    }
    Duration::try_from_secs_f64(seconds)
        .map_err(|e| format!("time budget {seconds:e} s cannot be represented: {e}"))
}

/// Check a tolerance on the relative residual: a number in `(0, 1)`, and at least
/// [`MIN_TOLERANCE`](lcpbench_solvers::metrics::MIN_TOLERANCE). A relative residual of 1 or
/// more is met by `f = 0` on most problems, so such a tolerance would claim convergence for
/// nothing; one below round-off would be met only by chance.
pub fn tolerance(tol: f64) -> Result<f64, String> {
    lcpbench_contact::scene::tolerance(tol).map_err(|m| format!("tolerance {m}"))
}

/// Tolerance, iteration cap and time budget of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// Tolerance on the relative natural-map residual.
    pub tolerance: f64,
    /// Iteration or pivot cap (per step for scenes).
    pub max_iterations: usize,
    /// Time budget in seconds: per solve for LCP cases; for scenes, per step's solve (a step
    /// whose solve runs out of it ends `time_limit` with the best point the solver has, and the
    /// run goes on), with the whole run capped at [`Budget::scene_run_limit`]. The child
    /// process is killed (and the run recorded as `timeout`) when it exceeds
    /// [`Budget::kill_after`].
    pub time_s: f64,
}

impl Budget {
    /// The presets with their names, in the order the report lists them.
    pub const PRESETS: [(BudgetName, Budget); 4] = [
        (
            BudgetName::Loose,
            Budget {
                tolerance: 1e-4,
                max_iterations: 1_000,
                time_s: 1.0,
            },
        ),
        (
            BudgetName::Default,
            Budget {
                tolerance: 1e-8,
                max_iterations: 10_000,
                time_s: 1.0,
            },
        ),
        (
            BudgetName::Tight,
            Budget {
                tolerance: 1e-10,
                max_iterations: 100_000,
                time_s: 10.0,
            },
        ),
        (
            BudgetName::Realtime,
            Budget {
                tolerance: 1e-6,
                max_iterations: 20,
                time_s: 1.0,
            },
        ),
    ];

    /// The preset called `name` (`None` for a custom name).
    pub fn preset(name: &BudgetName) -> Option<Budget> {
        Self::PRESETS
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| b.clone())
    }

    /// Read `TOL:ITER:SECONDS` (`SECONDS` may end in `s`) and check the values.
    pub fn parse_custom(spec: &str) -> Result<Budget, BudgetError> {
        let parts: Vec<&str> = spec.split(':').collect();
        let bad = || BudgetError::Budget(spec.to_owned());
        if parts.len() != 3 {
            return Err(bad());
        }
        let tolerance: f64 = parts[0].parse().map_err(|_| bad())?;
        let max_iterations: usize = parts[1].parse().map_err(|_| bad())?;
        let time_s: f64 = parts[2].trim_end_matches('s').parse().map_err(|_| bad())?;
        let budget = Budget {
            tolerance,
            max_iterations,
            time_s,
        };
        budget
            .validate()
            .map_err(|message| BudgetError::BudgetValue {
                spec: spec.to_owned(),
                message,
            })?;
        Ok(budget)
    }

    /// Solver settings for this budget.
    pub fn settings(&self) -> Settings {
        Settings {
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            time_budget: time_budget(self.time_s).ok(),
            warm_start: None,
            record_history: false,
            measure_result: true,
        }
    }

    /// Wall time after which the isolated child is killed: for an LCP three times the budget plus
    /// five seconds (process start, problem generation and the residual measurements of the
    /// convergence history are outside the solver's clock); for a scene of `steps` steps, which
    /// stops stepping by itself at [`Budget::scene_run_limit`] (the solve of the step running
    /// then ends at that limit too), that limit plus a quarter of it plus ten seconds: the margin
    /// covers loading the scene and the step under way when the limit passes.
    /// Saturates at [`Duration::MAX`] for a budget that was not validated.
    pub fn kill_after(&self, scene_steps: Option<usize>) -> Duration {
        let seconds = match scene_steps {
            Some(steps) => 1.25 * self.scene_run_limit(steps) + 10.0,
            None => 3.0 * self.time_s + 5.0,
        };
        Duration::try_from_secs_f64(seconds).unwrap_or(Duration::MAX)
    }

    /// Check the tolerance (in `(0, 1)`) and the time (see [`time_budget`]).
    pub fn validate(&self) -> Result<(), String> {
        tolerance(self.tolerance)?;
        time_budget(self.time_s)?;
        if self.max_iterations == 0 {
            return Err("the iteration cap must be at least 1".into());
        }
        Ok(())
    }

    /// Wall time after which a scene run of `steps` steps stops stepping and records
    /// `time_limit` with the steps it took: twice `steps` times the per-step seconds, the
    /// solves' share plus as much again for collision detection, assembly, measurement and
    /// integration. A run whose steps each stay within their budget is cut short only when
    /// everything outside the solver costs more than the solve budget per step.
    pub fn scene_run_limit(&self, steps: usize) -> f64 {
        2.0 * steps.max(1) as f64 * self.time_s
    }
}

/// The name of a budget, as written in the `budget` column: one of the presets, or a custom
/// budget named by its `TOL:ITER:SECONDS` text. Parsed from a preset name or a valid custom
/// text; anything else is a [`BudgetError`].
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BudgetName {
    /// `loose`: tolerance 1e-4, 1,000 iterations, 1 s.
    Loose,
    /// `default`: tolerance 1e-8, 10,000 iterations, 1 s; also the value of a
    /// [`RunRecord`](crate::harness::RunRecord) not yet filled.
    #[default]
    Default,
    /// `tight`: tolerance 1e-10, 100,000 iterations, 10 s.
    Tight,
    /// `realtime`: tolerance 1e-6, 20 iterations, 1 s.
    Realtime,
    /// A custom budget, named by its `TOL:ITER:SECONDS` text as given.
    Custom(CustomBudget),
}

/// The text of a custom budget, `TOL:ITER:SECONDS` as given (`1e-6:20:1`). Made only by
/// parsing a [`BudgetName`], so it always names a valid budget.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CustomBudget(String);

impl CustomBudget {
    /// The text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl BudgetName {
    /// The CSV text: the preset's name, or the custom budget's text.
    pub fn as_str(&self) -> &str {
        match self {
            BudgetName::Loose => "loose",
            BudgetName::Default => "default",
            BudgetName::Tight => "tight",
            BudgetName::Realtime => "realtime",
            BudgetName::Custom(spec) => spec.as_str(),
        }
    }

    /// The budget this name stands for, with its name.
    pub fn named(&self) -> Result<NamedBudget, BudgetError> {
        let budget = match Budget::preset(self) {
            Some(budget) => budget,
            None => Budget::parse_custom(self.as_str())?,
        };
        Ok(NamedBudget {
            name: self.clone(),
            budget,
        })
    }
}

impl fmt::Display for BudgetName {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.pad(self.as_str())
    }
}

impl std::str::FromStr for BudgetName {
    type Err = BudgetError;

    fn from_str(s: &str) -> Result<Self, BudgetError> {
        if let Some((name, _)) = Budget::PRESETS.iter().find(|(n, _)| n.as_str() == s) {
            return Ok(name.clone());
        }
        Budget::parse_custom(s)?;
        Ok(BudgetName::Custom(CustomBudget(s.to_owned())))
    }
}

serde_as_text!(BudgetName);

/// A budget with its name: a preset's, or for a custom budget its text.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedBudget {
    /// The name written to CSV rows.
    pub name: BudgetName,
    /// The budget.
    pub budget: Budget,
}

impl std::str::FromStr for NamedBudget {
    type Err = BudgetError;

    fn from_str(s: &str) -> Result<Self, BudgetError> {
        s.parse::<BudgetName>()?.named()
    }
}

impl fmt::Display for NamedBudget {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.name, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn budgets_parse() {
        let b: NamedBudget = "default".parse().unwrap();
        assert_eq!(b.budget.tolerance, 1e-8);
        let b: NamedBudget = "1e-6:500:2s".parse().unwrap();
        assert_eq!(b.budget.max_iterations, 500);
        assert_eq!(b.budget.time_s, 2.0);
        assert!("fast".parse::<NamedBudget>().is_err());
        assert!("1e-6:500".parse::<NamedBudget>().is_err());
        assert!(matches!(&b.name, BudgetName::Custom(c) if c.as_str() == "1e-6:500:2s"));
    }

    #[test]
    fn budget_names_round_trip_through_their_csv_text() {
        for (name, _) in Budget::PRESETS {
            assert_eq!(name.as_str().parse::<BudgetName>(), Ok(name.clone()));
        }
        let custom: BudgetName = "1e-6:20:1".parse().unwrap();
        assert_eq!(custom.to_string(), "1e-6:20:1");
        assert_eq!(custom.named().unwrap().budget.max_iterations, 20);
        assert!("tigth".parse::<BudgetName>().is_err());
    }

    #[test]
    fn unrepresentable_budget_seconds_are_refused() {
        for spec in [
            "1e-8:100:1e19",
            "1e-8:100:1e20",
            "1e-8:100:inf",
            "1e-8:100:NaN",
            "1e-8:100:-1",
            "1e-8:100:0",
            "1e300:100:1",
            "1:100:1",
            "1e-8:0:1",
        ] {
            let err = spec.parse::<NamedBudget>().unwrap_err();
            assert!(
                matches!(err, BudgetError::BudgetValue { .. }),
                "{spec}: {err}"
            );
        }
        for (name, b) in Budget::PRESETS {
            assert!(b.validate().is_ok(), "{name}");
        }
        let huge = Budget {
            tolerance: 1e-8,
            max_iterations: 1,
            time_s: 1e300,
        };
        assert_eq!(huge.kill_after(None), Duration::MAX);
        assert_eq!(huge.kill_after(Some(100)), Duration::MAX);
        assert_eq!(huge.settings().time_budget, None);
    }

    /// A scene's seconds are per step: the run limit is twice the steps times the seconds, and
    /// the child's kill time a quarter more plus ten seconds.
    #[test]
    fn scene_limits_scale_with_the_steps() {
        let b: NamedBudget = "1e-8:100:0.5".parse().unwrap();
        assert_eq!(b.budget.scene_run_limit(40), 40.0);
        assert_eq!(b.budget.kill_after(Some(40)), Duration::from_secs(60));
        assert_eq!(b.budget.kill_after(None), Duration::from_secs_f64(6.5));
    }
}

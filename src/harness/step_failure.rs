//! Why a scene step did not converge: a [`StepFailure`] category per step, read from the step
//! solve's [`Status`] and its reason, kept in the row's `failed_steps` column as
//! `STEP:CATEGORY:RESIDUAL:ROWS:CONTACTS` entries separated by spaces (see
//! [`crate::harness::RunRecord::failed_steps`]).
//!
//! The categories follow the solver statuses, with the factorisation cap told apart from other
//! refusals (a Newton or interior-point solver declines a system whose factor would exceed its
//! entry cap with an `unsupported` status whose reason names the factor's entries):
//!
//! | category        | status                                  |
//! |-----------------|-----------------------------------------|
//! | `stall`         | `stalled`                               |
//! | `iteration_cap` | `iteration_limit`                       |
//! | `time_budget`   | `time_limit`                            |
//! | `factor_cap`    | `unsupported`, reason about the factor's entries |
//! | `unsupported`   | any other `unsupported`                 |
//! | `no_solution`   | `no_solution` (a certificate: ray termination, infeasibility) |
//! | `diverged`      | `diverged` (an impulse growing along a direction `A` cancels; no proof) |
//! | `breakdown`     | `numerical_failure`                     |

use lcpbench_solvers::Status;
use std::fmt::Write as _;

/// At most this many failed steps are kept in a row's `failed_steps` column.
pub const FAILED_STEPS_KEPT: usize = 200;

/// Why one step's solve did not converge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum StepFailure {
    /// The solver met its own stopping rule (or could make no progress) above tolerance.
    Stall,
    /// The iteration, sweep or pivot cap was reached above tolerance.
    IterationCap,
    /// The step's time budget ran out above tolerance.
    TimeBudget,
    /// The solver declined a system whose factor would exceed its entry cap.
    FactorCap,
    /// The solver does not handle the step's problem class.
    Unsupported,
    /// The solver proved the step's problem has no solution.
    NoSolution,
    /// The impulse grew along a direction that `A` cancels (no solution suspected, no proof).
    Diverged,
    /// Breakdown: singular pivot, non-finite values, a failed factorisation.
    Breakdown,
}

impl StepFailure {
    /// Every category, in the order the report lists them.
    pub const ALL: [StepFailure; 8] = [
        StepFailure::Stall,
        StepFailure::IterationCap,
        StepFailure::TimeBudget,
        StepFailure::FactorCap,
        StepFailure::Unsupported,
        StepFailure::NoSolution,
        StepFailure::Diverged,
        StepFailure::Breakdown,
    ];

    /// The category of a step solve's status; `None` for `converged`.
    pub fn of(status: &Status) -> Option<Self> {
        Some(match status {
            Status::Converged => return None,
            Status::Stalled { .. } => StepFailure::Stall,
            Status::IterationLimit => StepFailure::IterationCap,
            Status::TimeLimit => StepFailure::TimeBudget,
            Status::Unsupported { reason } if is_factor_cap(reason) => StepFailure::FactorCap,
            Status::Unsupported { .. } => StepFailure::Unsupported,
            Status::NoSolution { .. } => StepFailure::NoSolution,
            Status::Diverged { .. } => StepFailure::Diverged,
            Status::NumericalFailure { .. } => StepFailure::Breakdown,
        })
    }

    /// `snake_case` name, as kept in the `failed_steps` column.
    pub fn name(self) -> &'static str {
        match self {
            StepFailure::Stall => "stall",
            StepFailure::IterationCap => "iteration_cap",
            StepFailure::TimeBudget => "time_budget",
            StepFailure::FactorCap => "factor_cap",
            StepFailure::Unsupported => "unsupported",
            StepFailure::NoSolution => "no_solution",
            StepFailure::Diverged => "diverged",
            StepFailure::Breakdown => "breakdown",
        }
    }

    /// Words for the report.
    pub fn label(self) -> &'static str {
        match self {
            StepFailure::Stall => "stall",
            StepFailure::IterationCap => "iteration cap",
            StepFailure::TimeBudget => "time budget",
            StepFailure::FactorCap => "factorisation cap",
            StepFailure::Unsupported => "unsupported",
            StepFailure::NoSolution => "no solution (certificate)",
            StepFailure::Diverged => "diverged",
            StepFailure::Breakdown => "breakdown",
        }
    }

    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// An `unsupported` reason that is the factorisation cap: it names the factor's entries
/// (`the Cholesky factor of W would hold … entries`, `max_factor_entries`).
fn is_factor_cap(reason: &str) -> bool {
    let r = reason.to_ascii_lowercase();
    r.contains("max_factor_entries") || (r.contains("factor") && r.contains("entries"))
}

/// One failed step of a scene run.
#[derive(Debug, Clone, PartialEq)]
pub struct FailedStep {
    /// Step index, from 0.
    pub step: usize,
    /// Why it failed.
    pub failure: StepFailure,
    /// Shared relative residual of the step's answer, when measured.
    pub residual: Option<f64>,
    /// Contact rows of the step.
    pub rows: usize,
    /// Contacts of the step.
    pub contacts: usize,
}

impl FailedStep {
    /// The column entry, `STEP:CATEGORY:RESIDUAL:ROWS:CONTACTS`.
    pub fn entry(&self) -> String {
        let residual = self.residual.map_or(String::new(), |r| format!("{r:.3e}"));
        format!(
            "{}:{}:{residual}:{}:{}",
            self.step,
            self.failure.name(),
            self.rows,
            self.contacts
        )
    }

    fn parse(entry: &str) -> Option<Self> {
        let mut it = entry.split(':');
        let step = it.next()?.parse().ok()?;
        let failure = StepFailure::from_name(it.next()?)?;
        let residual = match it.next()? {
            "" => None,
            r => Some(r.parse().ok()?),
        };
        let rows = it.next()?.parse().ok()?;
        let contacts = it.next()?.parse().ok()?;
        it.next().is_none().then_some(FailedStep {
            step,
            failure,
            residual,
            rows,
            contacts,
        })
    }
}

/// The `failed_steps` column of `steps` (the first [`FAILED_STEPS_KEPT`]).
pub fn format_failed_steps(steps: &[FailedStep]) -> String {
    let mut out = String::new();
    for (i, s) in steps.iter().take(FAILED_STEPS_KEPT).enumerate() {
        if i > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{}", s.entry());
    }
    out
}

/// Read a `failed_steps` column; entries that do not parse are skipped (a row edited by hand,
/// a category of a later lcpbench).
pub fn parse_failed_steps(column: &str) -> Vec<FailedStep> {
    column
        .split_whitespace()
        .filter_map(FailedStep::parse)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_map_to_categories_and_the_factor_cap_is_told_apart() {
        assert_eq!(StepFailure::of(&Status::Converged), None);
        assert_eq!(
            StepFailure::of(&Status::IterationLimit),
            Some(StepFailure::IterationCap)
        );
        let cap = Status::Unsupported {
            reason: "the Cholesky factor of W would hold 123456789 entries (symbolic analysis)"
                .into(),
        };
        assert_eq!(StepFailure::of(&cap), Some(StepFailure::FactorCap));
        let class = Status::Unsupported {
            reason: "bounded rows are not supported".into(),
        };
        assert_eq!(StepFailure::of(&class), Some(StepFailure::Unsupported));
        let no = Status::NoSolution {
            reason: "ray termination".into(),
        };
        assert_eq!(StepFailure::of(&no), Some(StepFailure::NoSolution));
    }

    #[test]
    fn the_column_round_trips_and_skips_what_it_cannot_read() {
        let steps = vec![
            FailedStep {
                step: 26,
                failure: StepFailure::Stall,
                residual: Some(3.4e-3),
                rows: 1200,
                contacts: 400,
            },
            FailedStep {
                step: 31,
                failure: StepFailure::TimeBudget,
                residual: None,
                rows: 8000,
                contacts: 2700,
            },
        ];
        let column = format_failed_steps(&steps);
        assert_eq!(
            column,
            "26:stall:3.400e-3:1200:400 31:time_budget::8000:2700"
        );
        assert_eq!(parse_failed_steps(&column), steps);
        let odd = format!("{column} 40:later_category:1e-3:1:1 garbage");
        assert_eq!(parse_failed_steps(&odd), steps);
        assert!(parse_failed_steps("").is_empty());
    }
}

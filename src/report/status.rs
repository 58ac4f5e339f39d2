//! The run statuses the report tests for, in one place. `RunRecord::status` is a [`RunStatus`] (the
//! solver's status or one of the harness's own outcomes); the report's tests of it go through
//! these predicates.

use crate::harness::{RunRecord, RunStatus};

/// The solver reported that the problem has no solution.
pub(super) fn reported_no_solution(r: &RunRecord) -> bool {
    r.status == RunStatus::NoSolution
}

/// The solver declined the problem (or a step of the scene).
pub(super) fn unsupported(r: &RunRecord) -> bool {
    r.status == RunStatus::Unsupported
}

/// The harness stopped the scene run because it blew up.
pub(super) fn blew_up(r: &RunRecord) -> bool {
    r.status == RunStatus::BlowUp
}

/// A scene run whose steps had nothing to solve: no contact and no joint row in any step (a
/// ball still falling), so no time per step worth printing and no solver to rank.
pub(crate) fn no_work(r: &RunRecord) -> bool {
    r.steps.unwrap_or(0) > 0 && r.contacts_mean == Some(0.0) && r.n.unwrap_or(0) == 0
}

/// The scene run stopped before its last step for lack of time: at its run limit, or after
/// consecutive steps over their per-step budget (fewer steps than it was to take).
pub(super) fn cut_short(r: &RunRecord) -> bool {
    r.status == RunStatus::TimeLimit && r.steps.zip(r.steps_planned).is_some_and(|(s, p)| s < p)
}

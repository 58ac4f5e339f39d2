//! The run statuses the report tests for, in one place. `RunRecord::status` is a string (the
//! solver's status name or one of the harness's own outcomes); every comparison of it the
//! report makes goes through these predicates.

use crate::harness::RunRecord;

/// The solver reported that the problem has no solution.
pub(super) fn reported_no_solution(r: &RunRecord) -> bool {
    r.status == "no_solution"
}

/// The solver declined the problem (or a step of the scene).
pub(super) fn unsupported(r: &RunRecord) -> bool {
    r.status == "unsupported"
}

/// The harness stopped the scene run because it blew up.
pub(super) fn blew_up(r: &RunRecord) -> bool {
    r.status == "blow_up"
}

/// The scene run stopped after half its budget's time.
pub(super) fn hit_time_limit(r: &RunRecord) -> bool {
    r.status == "time_limit"
}

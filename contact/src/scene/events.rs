//! The `[[events]]` table: scheduled removals of bodies, each at a step a run can reach and
//! of a body still there when it fires.

use super::file::EventFile;
use super::{Event, FieldError, MAX_STEPS};
use crate::body::RigidBody;

/// The `[[events]]` tables; each fires at a step a run can reach (below [`MAX_STEPS`]) and
/// removes a body (or repeated entry) that exists and that no earlier event has removed.
pub(super) fn convert_events(
    files: &[EventFile],
    bodies: &[RigidBody],
    groups: &[String],
) -> Result<Vec<Event>, FieldError> {
    let mut events = Vec::new();
    for (i, e) in files.iter().enumerate() {
        if e.at_step >= MAX_STEPS {
            return Err((
                format!("events[{i}].at_step"),
                format!(
                    "must be below {MAX_STEPS} (the most steps a run takes), got {}",
                    e.at_step
                ),
            ));
        }
        if !bodies
            .iter()
            .zip(groups)
            .any(|(b, g)| b.name == e.remove || *g == e.remove)
        {
            return Err((
                format!("events[{i}].remove"),
                format!("no body named \"{}\"", e.remove),
            ));
        }
        events.push(Event {
            at_step: e.at_step,
            remove: e.remove.clone(),
        });
    }
    check_removed_once(&events, bodies, groups)?;
    Ok(events)
}

/// Every event removes at least one body still there when it fires (events fire in step
/// order; at one step, in file order): removing a body twice is a mistake in the file.
pub(super) fn check_removed_once(
    events: &[Event],
    bodies: &[RigidBody],
    groups: &[String],
) -> Result<(), FieldError> {
    let mut order: Vec<usize> = (0..events.len()).collect();
    order.sort_by_key(|&i| events[i].at_step);
    // For each body, the event that removed it.
    let mut removed_by: Vec<Option<usize>> = vec![None; bodies.len()];
    for i in order {
        let e = &events[i];
        let targets: Vec<usize> = (0..bodies.len())
            .filter(|&k| bodies[k].name == e.remove || groups[k] == e.remove)
            .collect();
        if let Some(earlier) = targets
            .iter()
            .map(|&k| removed_by[k])
            .collect::<Option<Vec<_>>>()
            .and_then(|by| by.first().copied())
        {
            return Err((
                format!("events[{i}].remove"),
                format!(
                    "\"{}\" is already removed at step {} by events[{earlier}]; a body is \
                     removed once",
                    e.remove, events[earlier].at_step
                ),
            ));
        }
        for k in targets {
            removed_by[k].get_or_insert(i);
        }
    }
    Ok(())
}

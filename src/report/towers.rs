//! Report section: towers at 60 Hz under low iteration budgets.
//!
//! The stacks engines must hold at game budgets: every warm-started iterative solver on the
//! 60 Hz towers of the scene library (their full ten seconds), at a few warm-started iterations
//! per step ([`TOWER_BUDGETS`](super::suite::TOWER_BUDGETS)). For each solver and budget: the
//! top box's sag and lateral drift after the run, the solver time per step, and how many steps
//! ended short of the tolerance.

use super::suite::Suite;
use super::tables::{fmt_sci, fmt_time, Data, Table};
use crate::harness::RunStatus;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// The section's markdown (empty when the suite has no tower runs); writes one CSV table per
/// tower into `tables_dir`.
pub(super) fn section(data: &Data, suite: &Suite, tables_dir: &Path) -> Result<String> {
    let mut md = String::new();
    if suite.tower_cases.is_empty() {
        return Ok(md);
    }
    let _ = writeln!(
        md,
        "## Towers at 60 Hz, low budgets\n\nEach tower stepped for its whole run (10 s at \
         dt = 1/60) by every warm-started iterative solver, at tolerance 1e-6 with the iteration \
         cap per step of each budget. Sag: how far the top box's centre ended below its resting \
         height; drift: its horizontal distance from where it started; time: solver time per \
         step; steps short: steps that ended short of the tolerance (of the steps taken). A run \
         that collapses shows a sag of metres.\n"
    );
    let mut header = vec!["solver".to_owned()];
    for b in &suite.tower_budgets {
        let cap = b.budget.max_iterations;
        header.extend([
            format!("sag ({cap} it, m)"),
            format!("drift ({cap} it, m)"),
            format!("time/step ({cap} it)"),
            format!("steps short ({cap} it)"),
        ]);
    }
    for case in &suite.tower_cases {
        let name = case.short_name();
        let mut t = Table {
            name: "towers",
            header: header.clone(),
            rows: Vec::new(),
        };
        for solver in &suite.tower_solvers {
            let solver = solver.to_string();
            let mut row = vec![solver.clone()];
            for b in &suite.tower_budgets {
                match data.get(case, &solver, &b.name) {
                    Some(r) => row.extend([
                        fmt_sci(r.sag),
                        fmt_sci(r.lateral_drift),
                        fmt_time(r.time_per_step_s),
                        match (r.nonconverged_steps, r.steps) {
                            (Some(nc), Some(steps)) if r.status == RunStatus::TimeLimit => {
                                format!("{nc} of {steps} (time limit)")
                            }
                            (Some(nc), Some(steps)) => format!("{nc} of {steps}"),
                            _ => r.status.to_string(),
                        },
                    ]),
                    None => row.extend(std::iter::repeat_n("–".to_owned(), 4)),
                }
            }
            t.rows.push(row);
        }
        let csv = t.write_csv(tables_dir)?;
        let csv_name = format!("towers_{name}.csv");
        std::fs::rename(&csv, tables_dir.join(&csv_name))?;
        let _ = writeln!(md, "### {name}\n\n{}", t.markdown());
    }
    Ok(md)
}

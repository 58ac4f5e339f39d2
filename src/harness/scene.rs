//! Scene runs: step a scene with the chosen solver and aggregate per-step metrics into one row.

use crate::harness::budget::{NamedBudget, SolverSpec};
use crate::harness::case::Case;
use crate::harness::run::{base_record, RunOutput};

/// Run a scene case. Needs the stepping loop of `lcpbench-contact`.
pub fn run_scene(case: &Case, spec: &SolverSpec, budget: &NamedBudget) -> RunOutput {
    let mut record = base_record(case, spec, budget);
    record.status = "error".into();
    record.reason =
        "scene runs need the contact crate's stepping loop, which is not available yet".into();
    RunOutput {
        record,
        history: Vec::new(),
    }
}

/// Export the LCPs of the suite's scenes (one step each) into `dir`, returning the files
/// written. Needs the contact crate's exporter; returns no files until it is available.
pub fn export_suite_lcps(
    _scenes: &[std::path::PathBuf],
    _dir: &std::path::Path,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    Ok(Vec::new())
}

//! `lcpbench.simulate`: step a scene file.

use crate::errors::bad;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Step the scene at `scene_path`.
#[pyfunction]
#[pyo3(signature = (scene_path, solver=None, steps=None))]
pub fn simulate(scene_path: PathBuf, solver: Option<String>, steps: Option<usize>) -> PyResult<()> {
    let _ = (scene_path, solver, steps);
    Err(bad("simulate: not built yet"))
}

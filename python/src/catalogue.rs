//! `lcpbench.solvers()`: the solver catalogue of `lcpbench solvers`, as dicts.

use lcpbench::harness::catalogue::catalogue;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Every solver of the catalogue, in its order: `name`, `level` (`matrix`, `body`, `cone`),
/// `summary` (one line), `warm` (whether it starts from a warm start), `iterations_count` (what
/// its iteration count counts), `problem_classes` and `parameters` (`key`, `default`, `min`,
/// `max`, `integer`, `doc`).
#[pyfunction]
pub fn solvers(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for e in catalogue() {
        let d = PyDict::new(py);
        d.set_item("name", e.name)?;
        d.set_item("level", e.level().name())?;
        d.set_item("summary", e.summary)?;
        d.set_item("warm", e.iterative)?;
        d.set_item("iterations_count", e.iteration_unit)?;
        d.set_item("problem_classes", e.problem_classes)?;
        let params = PyList::empty(py);
        for p in e.params {
            let pd = PyDict::new(py);
            pd.set_item("key", p.key)?;
            pd.set_item("default", p.default)?;
            pd.set_item("min", p.min)?;
            pd.set_item("max", p.max)?;
            pd.set_item("integer", p.integer)?;
            pd.set_item("doc", p.doc)?;
            params.append(pd)?;
        }
        d.set_item("parameters", params)?;
        list.append(d)?;
    }
    Ok(list)
}

//! `lcpbench._lcpbench`: the compiled core of the `lcpbench` Python package.
//!
//! Problems are built from numpy arrays and compressed sparse matrices (scipy's `data`,
//! `indices`, `indptr`) straight into the [`lcpbench_solvers::Problem`] the command line
//! builds, solved by the same solvers with the GIL released, and judged by the same shared
//! residual and status rule ([`lcpbench_solvers::judge`], [`lcpbench_solvers::judge_cone`]).
//! The Python layer (`lcpbench/__init__.py`) converts other scipy formats and pandas output;
//! everything numerical happens here.

use pyo3::prelude::*;

mod arrays;
mod catalogue;
mod errors;
mod problem;
mod simulate;
mod solve;

/// The extension module.
#[pymodule]
fn _lcpbench(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LcpbenchError", m.py().get_type::<errors::LcpbenchError>())?;
    m.add_class::<problem::PyProblem>()?;
    m.add_class::<solve::PySolveResult>()?;
    m.add_class::<solve::PyJudgement>()?;
    m.add_function(wrap_pyfunction!(problem::lcp_problem, m)?)?;
    m.add_function(wrap_pyfunction!(problem::cone_problem, m)?)?;
    m.add_function(wrap_pyfunction!(problem::read, m)?)?;
    m.add_function(wrap_pyfunction!(problem::write, m)?)?;
    m.add_function(wrap_pyfunction!(solve::solve, m)?)?;
    m.add_function(wrap_pyfunction!(solve::judge, m)?)?;
    m.add_function(wrap_pyfunction!(catalogue::solvers, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    Ok(())
}

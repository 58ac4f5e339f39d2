//! Solving and judging: the solvers of `lcpbench solve`, run with the GIL released, and the
//! status rule every solver applies, for any answer.

use crate::errors::bad;
use crate::problem::{Inner, PyProblem};
use lcpbench::harness::budget;
use lcpbench::harness::SolverSpec;
use lcpbench_solvers::metrics::unresolved_row;
use lcpbench_solvers::{
    cone_residuals, cone_residuals_and_velocity, judge as judge_lcp, judge_cone, non_finite_reason,
    normal_unresolved, residuals_and_velocity, Certificate, ConeProblem, ConeSolverKind, Outcome,
    Residuals, Settings, SolveResult, Status,
};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::time::Duration;

/// Iteration cap when none is given (as `lcpbench solve`).
const DEFAULT_MAX_ITERATIONS: usize = 10_000;

/// The result of a solve: the answer, its velocity, the status decided by the shared
/// residual, and the solver's cost.
#[pyclass(name = "SolveResult", module = "lcpbench", frozen, get_all)]
pub struct PySolveResult {
    /// The solver that ran.
    solver: String,
    /// The impulse `f` (LCP) or reaction `r` (cone).
    f: Py<PyArray1<f64>>,
    /// The velocity `w = A f + b` (or `u = W r + q`) at `f`.
    w: Py<PyArray1<f64>>,
    /// `converged`, `iteration_limit`, `time_limit`, `stalled`, `no_solution`, `diverged`,
    /// `unsupported` or `numerical_failure`.
    status: String,
    /// Why, for the statuses that carry a reason.
    reason: Option<String>,
    /// Shared natural-map residual, max over rows.
    residual: f64,
    /// The residual relative to the problem's data; `converged` means at most `tol`.
    residual_rel: f64,
    /// Complementarity gap, summed over rows.
    complementarity_gap: f64,
    /// Bound violation, max over rows.
    bound_violation: f64,
    /// Iterations or pivots used.
    iterations: usize,
    /// Solver wall time in seconds (one solve, history measurement excluded).
    time_s: f64,
    /// The relaxed problem the solver solves instead, when it does (else `None`).
    relaxation: Option<String>,
    /// Farkas certificate read off `f` for `diverged`/`no_solution`, as a dict, or `None`.
    certificate: Option<Py<PyDict>>,
    /// `(iteration, time_s, residual)` after each iteration when `history=True`, else empty.
    history: Vec<(usize, f64, f64)>,
}

#[pymethods]
impl PySolveResult {
    /// True when `status == "converged"`.
    #[getter]
    fn converged(&self) -> bool {
        self.status == "converged"
    }

    fn __repr__(&self) -> String {
        format!(
            "SolveResult(solver={:?}, status={:?}, residual_rel={:.3e}, iterations={}, \
             time_s={:.3e})",
            self.solver, self.status, self.residual_rel, self.iterations, self.time_s
        )
    }
}

/// The verdict on an answer: the shared residual, the data-resolution test and the status.
#[pyclass(name = "Judgement", module = "lcpbench", frozen, get_all)]
pub struct PyJudgement {
    /// `converged`, `stalled` (above tolerance, or a cone contact's normal complementarity
    /// unresolved), `diverged`/`no_solution` (within tolerance only through cancellation) or
    /// `numerical_failure` (a non-finite entry).
    status: String,
    /// Why, for the statuses that carry a reason.
    reason: Option<String>,
    /// Shared natural-map residual, max over rows.
    residual: f64,
    /// The residual relative to the problem's data.
    residual_rel: f64,
    /// Complementarity gap, summed over rows.
    complementarity_gap: f64,
    /// Bound violation, max over rows.
    bound_violation: f64,
    /// The velocity at the answer.
    w: Py<PyArray1<f64>>,
    /// The row (LCP) or contact (cone) that fails the data-resolution test, or `None` when
    /// every one is resolved.
    unresolved: Option<usize>,
    /// Farkas certificate read off the answer, as a dict, or `None`.
    certificate: Option<Py<PyDict>>,
}

#[pymethods]
impl PyJudgement {
    /// True when `status == "converged"`.
    #[getter]
    fn converged(&self) -> bool {
        self.status == "converged"
    }

    fn __repr__(&self) -> String {
        format!(
            "Judgement(status={:?}, residual_rel={:.3e}, unresolved={:?})",
            self.status, self.residual_rel, self.unresolved
        )
    }
}

/// Settings from the keyword arguments, checked as `lcpbench solve` checks its options.
fn settings(
    n: usize,
    tol: f64,
    max_iter: Option<usize>,
    time_budget: Option<f64>,
    warm: Option<&Bound<'_, PyAny>>,
    history: bool,
) -> PyResult<Settings> {
    budget::tolerance(tol).map_err(|m| bad(format!("tol: {m}")))?;
    let max_iterations = max_iter.unwrap_or(DEFAULT_MAX_ITERATIONS);
    if max_iterations == 0 {
        return Err(bad("max_iter must be at least 1"));
    }
    let time_budget = match time_budget {
        Some(t) => Some(budget::time_budget(t).map_err(|m| bad(format!("time_budget: {m}")))?),
        None => None,
    };
    let warm_start = match warm {
        Some(w) => {
            let w = crate::arrays::vector("warm", w)?;
            if w.len() != n {
                return Err(bad(format!("warm has {} values for {n} rows", w.len())));
            }
            if let Some(reason) = non_finite_reason(&w, "warm start", "warm") {
                return Err(bad(reason));
            }
            Some(w)
        }
        None => None,
    };
    Ok(Settings {
        tolerance: tol,
        max_iterations,
        time_budget,
        warm_start,
        record_history: history,
        measure_result: true,
    })
}

/// Solve `problem` with the solver named `solver` (a name of `lcpbench.solvers()` at level
/// matrix or cone, `NAME@key=value,…` for its parameters, `sor@omega=1.5`). A cone solver given an LCP solves the
/// cone problem its (normal, tangent, tangent) rows make, as `lcpbench solve` does; a matrix
/// solver given a cone problem ends `unsupported`.
#[pyfunction]
#[pyo3(signature = (problem, solver, tol=1e-8, max_iter=None, time_budget=None, warm=None, history=false))]
#[allow(clippy::too_many_arguments)]
pub fn solve(
    py: Python<'_>,
    problem: &PyProblem,
    solver: &str,
    tol: f64,
    max_iter: Option<usize>,
    time_budget: Option<f64>,
    warm: Option<&Bound<'_, PyAny>>,
    history: bool,
) -> PyResult<PySolveResult> {
    let spec: SolverSpec = solver.parse().map_err(|e| bad(format!("solver: {e}")))?;
    if spec.warm() {
        return Err(bad(format!(
            "solver `{solver}`: `+warm` is a sweep option; pass the starting point as warm="
        )));
    }
    let n = match &problem.inner {
        Inner::Lcp(p) => p.n(),
        Inner::Cone(c) => c.n(),
    };
    let settings = settings(n, tol, max_iter, time_budget, warm, history)?;
    if let Some(lcp_solver) = spec.create() {
        let name = lcp_solver.name().to_owned();
        let relaxation = spec.relaxation().map(str::to_owned);
        return match &problem.inner {
            Inner::Lcp(p) => {
                let mut s = lcp_solver;
                let r = py.detach(|| s.solve(p, &settings));
                result(py, name, relaxation, r)
            }
            Inner::Cone(c) => {
                let reason = format!(
                    "{name} solves LCPs; this is a Coulomb cone (FC3D) problem: use a cone \
                     solver ({})",
                    ConeSolverKind::names()
                );
                let f = vec![0.0; c.n()];
                let r = SolveResult {
                    w: c.velocity(&f),
                    residuals: cone_residuals(c, &f),
                    f,
                    status: Status::Unsupported { reason },
                    iterations: 0,
                    time: Duration::ZERO,
                    history: Vec::new(),
                    active_sets: Vec::new(),
                    certificate: None,
                };
                result(py, name, None, r)
            }
        };
    }
    let Some(mut cone_solver) = spec.create_cone() else {
        return Err(bad(format!(
            "solver `{solver}` is not a matrix or cone solver (body-level solvers run in \
             scenes: use lcpbench.simulate)"
        )));
    };
    let relaxation = spec.relaxation().map(str::to_owned);
    let name = cone_solver.name().to_owned();
    let converted;
    let cone: &ConeProblem = match &problem.inner {
        Inner::Cone(c) => c,
        Inner::Lcp(p) => {
            converted = ConeProblem::from_box(p).map_err(|e| {
                bad(format!(
                    "solver `{solver}` needs rows in (normal, tangent, tangent) triples: {e}"
                ))
            })?;
            &converted
        }
    };
    let r = py.detach(|| cone_solver.solve_cone(cone, &settings));
    result(py, name, relaxation, r)
}

fn certificate_dict<'py>(py: Python<'py>, c: &Certificate) -> PyResult<Py<PyDict>> {
    let d = PyDict::new(py);
    d.set_item("proves_no_solution", c.proves_no_solution)?;
    d.set_item(
        "min_solution_norm",
        c.min_solution_norm
            .is_finite()
            .then_some(c.min_solution_norm),
    )?;
    d.set_item("b_dot_y", c.b_dot_y)?;
    d.set_item("bounded_part", c.bounded_part)?;
    d.set_item("slope", c.slope)?;
    d.set_item("slope_rel", c.slope_rel)?;
    d.set_item("y", PyArray1::from_slice(py, &c.y))?;
    Ok(d.unbind())
}

fn result(
    py: Python<'_>,
    solver: String,
    relaxation: Option<String>,
    r: SolveResult,
) -> PyResult<PySolveResult> {
    let certificate = r
        .certificate
        .as_ref()
        .map(|c| certificate_dict(py, c))
        .transpose()?;
    Ok(PySolveResult {
        solver,
        status: r.status.name().to_owned(),
        reason: r.status.reason().map(str::to_owned),
        residual: r.residuals.natural_map,
        residual_rel: r.residuals.natural_map_rel,
        complementarity_gap: r.residuals.complementarity_gap,
        bound_violation: r.residuals.bound_violation,
        iterations: r.iterations,
        time_s: r.time.as_secs_f64(),
        relaxation,
        certificate,
        history: r
            .history
            .iter()
            .map(|h| (h.iteration, h.time_s, h.residual))
            .collect(),
        f: PyArray1::from_vec(py, r.f).unbind(),
        w: PyArray1::from_vec(py, r.w).unbind(),
    })
}

/// Judge the answer `f` to `problem` at tolerance `tol` by the rule every solver's status
/// follows: a non-finite entry is `numerical_failure`; otherwise the shared residual decides
/// (`converged` at most `tol`, else `stalled`), and a `converged` answer must pass the
/// data-resolution test (LCP: every row resolved against the data, else `diverged` or
/// `no_solution` with the Farkas certificate; cone: every contact's normal complementarity
/// resolved, else `stalled`).
#[pyfunction]
#[pyo3(signature = (problem, f, tol=1e-8))]
pub fn judge(
    py: Python<'_>,
    problem: &PyProblem,
    f: &Bound<'_, PyAny>,
    tol: f64,
) -> PyResult<PyJudgement> {
    budget::tolerance(tol).map_err(|m| bad(format!("tol: {m}")))?;
    let f = crate::arrays::vector("f", f)?;
    let n = match &problem.inner {
        Inner::Lcp(p) => p.n(),
        Inner::Cone(c) => c.n(),
    };
    if f.len() != n {
        return Err(bad(format!("f has {} values for {n} rows", f.len())));
    }
    let (symbol, noun) = match problem.inner {
        Inner::Lcp(_) => ("f", "impulse"),
        Inner::Cone(_) => ("r", "reaction"),
    };
    let mut w = vec![0.0; n];
    let (status, residuals, unresolved, certificate) = if let Some(reason) =
        non_finite_reason(&f, noun, symbol)
    {
        let status = Status::NumericalFailure { reason };
        (status, Residuals::INFINITE, None, None)
    } else {
        let residuals = match &problem.inner {
            Inner::Lcp(p) => residuals_and_velocity(p, &f, &mut w),
            Inner::Cone(c) => cone_residuals_and_velocity(c, &f, &mut w),
        };
        if w.iter().any(|v| !v.is_finite()) {
            let reason = format!("the velocity overflows at the given {noun}");
            (Status::NumericalFailure { reason }, residuals, None, None)
        } else {
            match &problem.inner {
                Inner::Lcp(p) => {
                    let (status, cert) = judge_lcp(p, &f, &w, &residuals, Outcome::Stopped, tol);
                    let row = unresolved_row(p, &f, &w).map(|u| u.row);
                    (status, residuals, row, cert)
                }
                Inner::Cone(c) => {
                    let status = judge_cone(c, &f, &w, &residuals, Outcome::Stopped, tol);
                    let contact = normal_unresolved(c, &f, &w, tol).map(|u| u.contact);
                    (status, residuals, contact, None)
                }
            }
        }
    };
    let certificate = certificate
        .as_ref()
        .map(|c| certificate_dict(py, c))
        .transpose()?;
    Ok(PyJudgement {
        status: status.name().to_owned(),
        reason: status.reason().map(str::to_owned),
        residual: residuals.natural_map,
        residual_rel: residuals.natural_map_rel,
        complementarity_gap: residuals.complementarity_gap,
        bound_violation: residuals.bound_violation,
        w: PyArray1::from_vec(py, w).unbind(),
        unresolved,
        certificate,
    })
}

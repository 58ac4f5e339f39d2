//! `lcpbench.simulate`: step a scene file as `lcpbench simulate` does and return per-step
//! arrays.

use crate::errors::{bad, os_error};
use lcpbench::harness::{budget, SolverSpec};
use lcpbench_contact::scene::{check_solver, LoadOptions, Scene, SceneError, MAX_STEPS};
use lcpbench_contact::timewarp::Stepper;
use lcpbench_contact::ContactSolver;
use numpy::{PyArray1, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Step the scene at `scene_path` with its own stepping mode, `steps` steps (the scene's count
/// by default), with `solver` in place of the scene's (`NAME` cold, `NAME+warm` from the
/// previous step's impulses) and optionally its tolerance and iteration cap. Returns a dict of
/// per-step values: `status` and `solver` (lists of strings), `residual_rel`, `iterations`,
/// `contacts`, `rows`, `solve_time_s`, `step_time_s`, `time` (numpy arrays; `residual_rel` is
/// NaN where no residual was measured), and the body poses after each step: `positions`
/// (steps × bodies × 3), `orientations` (steps × bodies × 4, quaternions as `w, x, y, z`), with
/// `bodies` the body names.
#[pyfunction]
#[pyo3(signature = (scene_path, solver=None, steps=None, tol=None, max_iter=None))]
pub fn simulate<'py>(
    py: Python<'py>,
    scene_path: PathBuf,
    solver: Option<String>,
    steps: Option<usize>,
    tol: Option<f64>,
    max_iter: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut scene =
        Scene::load_with(&scene_path, &LoadOptions::default()).map_err(|e| match &e {
            SceneError::Io { error, .. } => os_error(error.kind(), e.to_string()),
            _ => bad(e.to_string()),
        })?;
    if let Some(name) = &solver {
        let spec: SolverSpec = name.parse().map_err(|e| bad(format!("solver: {e}")))?;
        let choice = spec.contact_solver(&scene).ok_or_else(|| {
            bad(format!(
                "solver: unknown solver `{name}` (known: {})",
                ContactSolver::all_names()
            ))
        })?;
        scene.settings.solver = choice;
        scene.settings.warm_start = spec.warm();
    }
    check_solver(
        &scene.settings.solver,
        scene.settings.builder.friction_model,
    )
    .map_err(|m| {
        bad(format!(
            "{}: unsupported solver for this friction model: {m}",
            scene_path.display()
        ))
    })?;
    let steps = steps.unwrap_or(scene.settings.steps);
    if steps == 0 || steps > MAX_STEPS {
        return Err(bad(format!(
            "steps must be between 1 and {MAX_STEPS}, got {steps}"
        )));
    }
    let mut world = scene.world();
    if let Some(tol) = tol {
        world.settings.tolerance = budget::tolerance(tol).map_err(|m| bad(format!("tol: {m}")))?;
    }
    if let Some(max_iter) = max_iter {
        if max_iter == 0 {
            return Err(bad("max_iter must be at least 1"));
        }
        world.settings.max_iterations = max_iter;
    }
    let mut stepper = Stepper::new(world, scene.stepping)
        .map_err(|m| bad(format!("{}: {m}", scene_path.display())))?;
    let nb = stepper.world().bodies.len();
    let bodies: Vec<String> = stepper
        .world()
        .bodies
        .iter()
        .map(|b| b.name.clone())
        .collect();
    let run = py.detach(move || {
        let mut out = Run::default();
        for _ in 0..steps {
            let r = stepper.step();
            out.status.push(r.status.name());
            out.solver.push(r.solver);
            out.residual_rel
                .push(r.residuals.map_or(f64::NAN, |x| x.natural_map_rel));
            out.iterations.push(r.iterations as u64);
            out.contacts.push(r.contacts as u64);
            out.rows.push(r.rows as u64);
            out.solve_time_s.push(r.solve_time_s);
            out.step_time_s.push(r.step_time_s);
            out.time.push(r.time);
            for b in &stepper.world().bodies {
                out.positions.extend(b.position.coords.iter());
                let q = b.orientation.quaternion();
                out.orientations.extend([q.w, q.i, q.j, q.k]);
            }
        }
        out
    });
    let d = PyDict::new(py);
    d.set_item("scene", &scene.name)?;
    d.set_item("bodies", bodies)?;
    d.set_item("status", run.status)?;
    d.set_item("solver", run.solver)?;
    d.set_item("residual_rel", PyArray1::from_vec(py, run.residual_rel))?;
    d.set_item("iterations", PyArray1::from_vec(py, run.iterations))?;
    d.set_item("contacts", PyArray1::from_vec(py, run.contacts))?;
    d.set_item("rows", PyArray1::from_vec(py, run.rows))?;
    d.set_item("solve_time_s", PyArray1::from_vec(py, run.solve_time_s))?;
    d.set_item("step_time_s", PyArray1::from_vec(py, run.step_time_s))?;
    d.set_item("time", PyArray1::from_vec(py, run.time))?;
    let poses = |v: Vec<f64>, k: usize| -> PyResult<Bound<'py, PyArray3<f64>>> {
        let a = numpy::ndarray::Array3::from_shape_vec((steps, nb, k), v)
            .map_err(|e| bad(format!("body poses: {e}")))?;
        Ok(PyArray3::from_owned_array(py, a))
    };
    d.set_item("positions", poses(run.positions, 3)?)?;
    d.set_item("orientations", poses(run.orientations, 4)?)?;
    Ok(d)
}

/// What a run collects, step by step.
#[derive(Default)]
struct Run {
    status: Vec<&'static str>,
    solver: Vec<&'static str>,
    residual_rel: Vec<f64>,
    iterations: Vec<u64>,
    contacts: Vec<u64>,
    rows: Vec<u64>,
    solve_time_s: Vec<f64>,
    step_time_s: Vec<f64>,
    time: Vec<f64>,
    positions: Vec<f64>,
    orientations: Vec<f64>,
}

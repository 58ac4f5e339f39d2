//! The solve view: every solver on one problem (the cone solvers too on a problem of contact
//! triples), with convergence histories and the final
//! `f` and `w` per row.

use super::recording::history_json;
use lcpbench_solvers::{ConeProblem, ConeSolverKind, Problem, Settings, SolverKind};
use serde_json::{json, Value};

/// One run of the solve page: a matrix solver on the (boxed) LCP or a cone solver on the
/// Coulomb-cone form of the same rows.
enum PageSolver<'a> {
    Lcp(SolverKind),
    Cone(ConeSolverKind, &'a ConeProblem),
}

/// Page data for `problem`: the rows (`b`, bounds, friction rows) and, per solver, the problem
/// it solved (`boxed LCP`, or `Coulomb cone` for the cone solvers), status, iterations (and what
/// they count), time, relative residual, thinned history, `f` and `w`. Every matrix solver
/// ([`SolverKind`]) runs on `problem`; when its rows come in (normal, tangent, tangent) triples
/// ([`ConeProblem::from_box`]) every cone solver ([`ConeSolverKind`]) runs on the cone form as
/// well, its residual the cone residual. Each solver runs with `settings` and its history
/// recorded; a `time_budget` in `settings` is shared by the solvers, each getting an equal
/// share of what the ones before it left.
pub fn problem_data(problem: &Problem, name: &str, settings: &Settings) -> Value {
    let settings = Settings {
        record_history: true,
        ..settings.clone()
    };
    let finite =
        |v: &[f64]| -> Vec<Option<f64>> { v.iter().map(|&x| x.is_finite().then_some(x)).collect() };
    let start = std::time::Instant::now();
    let cone = ConeProblem::from_box(problem).ok();
    let runs: Vec<PageSolver> = SolverKind::all()
        .into_iter()
        .map(PageSolver::Lcp)
        .chain(cone.iter().flat_map(|c| {
            ConeSolverKind::all()
                .into_iter()
                .map(|k| PageSolver::Cone(k, c))
        }))
        .collect();
    let count = runs.len();
    let solvers: Vec<Value> = runs
        .into_iter()
        .enumerate()
        .map(|(k, run)| {
            let share = settings.time_budget.map(|total| {
                let left = total.saturating_sub(start.elapsed());
                // At least a microsecond, the smallest budget a solve takes.
                (left / (count - k) as u32).max(std::time::Duration::from_micros(1))
            });
            let settings = Settings {
                time_budget: share,
                ..settings.clone()
            };
            let (name, solved, r) = match &run {
                PageSolver::Lcp(kind) => (
                    kind.name(),
                    "boxed LCP",
                    kind.create().solve(problem, &settings),
                ),
                PageSolver::Cone(kind, cone) => (
                    kind.name(),
                    "Coulomb cone",
                    kind.create().solve_cone(cone, &settings),
                ),
            };
            let history: Vec<Value> = r
                .history
                .iter()
                .map(|p| serde_json::to_value(p).unwrap_or(Value::Null))
                .collect();
            json!({
                "name": name,
                "problem": solved,
                "status": r.status.name(),
                "reason": r.status.reason(),
                "iterations": r.iterations,
                "iteration_unit": iteration_unit(name).unwrap_or("iterations"),
                "time_s": r.time.as_secs_f64(),
                "residual_rel": r.residuals.natural_map_rel,
                "history": history_json(&history),
                "f": finite(&r.f),
                "w": finite(&r.w),
            })
        })
        .collect();
    let friction: Vec<Value> = problem
        .friction()
        .iter()
        .map(|fr| json!([fr.row, fr.normal, fr.mu]))
        .collect();
    json!({
        "kind": "problem",
        "name": name,
        "n": problem.n(),
        "b": finite(problem.b()),
        "lo": finite(problem.lo()),
        "hi": finite(problem.hi()),
        "friction": friction,
        "tolerance": settings.tolerance,
        "solvers": solvers,
    })
}

/// What one iteration of the solver named `name` is, the unit of its `iterations` count
/// (sweeps, pivots, Newton steps, interior-point iterations, …), from its registry entry;
/// `None` for an unknown name.
pub fn iteration_unit(name: &str) -> Option<&'static str> {
    lcpbench_contact::registry::find(name).map(|e| e.iteration_unit)
}

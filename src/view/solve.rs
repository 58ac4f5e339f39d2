//! The solve view: every solver on one problem, with convergence histories and the final
//! `f` and `w` per row.

use super::recording::history_json;
use lcpbench_solvers::{Problem, Settings, SolverKind};
use serde_json::{json, Value};

/// Page data for `problem`: the rows (`b`, bounds, friction rows) and, per solver (every
/// [`SolverKind`]), the status, iterations, time, relative residual, thinned history, `f` and
/// `w`. Each solver runs with `settings` and its history recorded; a `time_budget` in
/// `settings` is shared by the solvers, each getting an equal share of what the ones before it
/// left.
pub fn problem_data(problem: &Problem, name: &str, settings: &Settings) -> Value {
    let settings = Settings {
        record_history: true,
        ..settings.clone()
    };
    let finite =
        |v: &[f64]| -> Vec<Option<f64>> { v.iter().map(|&x| x.is_finite().then_some(x)).collect() };
    let start = std::time::Instant::now();
    let kinds = SolverKind::ALL;
    let solvers: Vec<Value> = kinds
        .into_iter()
        .enumerate()
        .map(|(k, kind)| {
            let share = settings.time_budget.map(|total| {
                let left = total.saturating_sub(start.elapsed());
                // At least a microsecond, the smallest budget a solve takes.
                (left / (kinds.len() - k) as u32).max(std::time::Duration::from_micros(1))
            });
            let settings = Settings {
                time_budget: share,
                ..settings.clone()
            };
            let r = kind.create().solve(problem, &settings);
            let history: Vec<Value> = r
                .history
                .iter()
                .map(|p| serde_json::to_value(p).unwrap_or(Value::Null))
                .collect();
            json!({
                "name": kind.name(),
                "status": r.status.name(),
                "reason": r.status.reason(),
                "iterations": r.iterations,
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

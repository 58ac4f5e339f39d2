//! One run, in process: load the case, solve (or step the scene), measure. This is what the
//! isolated child (`lcpbench bench-one`) executes; [`crate::harness::isolate`] runs it in a child
//! process so a panic, an abort or a hang cannot take the sweep down.

use crate::harness::case::{Case, GenFamily, LoadedLcp};
use crate::harness::record::{base_record, RunOutput, RunRecord, RunStatus, TTA_LEVELS};
use crate::harness::scene;
use crate::harness::{NamedBudget, SolverSpec};
use lcpbench_solvers::{
    ConeProblem, ConeSolver, HistoryPoint, ProjectedSor, Settings, SolveResult, Solver,
};
use std::time::Instant;

/// Largest number of history points kept per run (log-spaced in iteration).
pub const HISTORY_POINTS: usize = 120;

/// Execute one run in this process.
pub fn run_in_process(case: &Case, spec: &SolverSpec, budget: &NamedBudget) -> RunOutput {
    let start = Instant::now();
    if let Some(fault) = spec.fault() {
        fault.trigger();
    }
    let mut output = if case.is_scene() {
        scene::run_scene(case, spec, budget)
    } else {
        run_lcp(case, spec, budget)
    };
    output.record.wall_time_s = start.elapsed().as_secs_f64();
    output
}

fn run_lcp(case: &Case, spec: &SolverSpec, budget: &NamedBudget) -> RunOutput {
    let mut record = base_record(case, spec, budget);
    let lcp = match case.load_lcp() {
        Ok(lcp) => lcp,
        Err(e) => return RunOutput::failed(record, RunStatus::Error, e),
    };
    record.n = Some(lcp.problem.n());
    if let Case::File(_) | Case::SceneStep { .. } = case {
        record.class = Case::class_of_problem(&lcp.problem);
    }
    if let Some(solver) = spec.create_cone() {
        return run_cone_lcp(solver, &lcp, spec, budget, record);
    }
    let Some(mut solver) = spec.create() else {
        return RunOutput::failed(record, RunStatus::Error, "no solver");
    };
    let mut settings = budget.budget.settings();
    settings.record_history = true;
    if spec.warm() {
        settings.warm_start = Some(warm_start_for(&lcp));
    }
    crate::harness::isolate::signal_ready();
    let result = solver.solve(&lcp.problem, &settings);
    fill_from_result(&mut record, &result);
    if let (Some(star), Case::Generated { family, .. }) = (&lcp.solution, case) {
        let unique = matches!(
            family,
            GenFamily::Spd { .. } | GenFamily::PMatrix | GenFamily::Murty | GenFamily::Weak
        );
        if unique && result.f.len() == star.len() {
            let scale = star.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            let err = result
                .f
                .iter()
                .zip(star)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            record.solution_error = Some(err / scale);
        }
    }
    RunOutput {
        record,
        history: thin_history(&result.history, HISTORY_POINTS),
    }
}

/// A cone solver on an LCP case: the box-friction problem read as the cone of its
/// (normal, tangent, tangent) triples; any other problem is `unsupported`.
fn run_cone_lcp(
    mut solver: Box<dyn ConeSolver + Send>,
    lcp: &LoadedLcp,
    spec: &SolverSpec,
    budget: &NamedBudget,
    mut record: RunRecord,
) -> RunOutput {
    let problem = match ConeProblem::from_box(&lcp.problem) {
        Ok(p) => p,
        Err(e) => {
            let reason = format!(
                "{} takes the exact Coulomb cone: the problem is not one of contact triples ({e})",
                solver.name()
            );
            return RunOutput::failed(record, RunStatus::Unsupported, reason);
        }
    };
    let mut settings = budget.budget.settings();
    settings.record_history = true;
    if spec.warm() {
        settings.warm_start = Some(warm_start_for(lcp));
    }
    crate::harness::isolate::signal_ready();
    let result = solver.solve_cone(&problem, &settings);
    fill_from_result(&mut record, &result);
    RunOutput {
        record,
        history: thin_history(&result.history, HISTORY_POINTS),
    }
}

/// Copy a solve's outcome into the row: status, iterations, time, residuals, time-to-accuracy.
pub fn fill_from_result(record: &mut RunRecord, result: &SolveResult) {
    record.status = RunStatus::from(&result.status);
    record.reason = result.status.reason().unwrap_or_default().to_owned();
    record.converged = result.status.is_converged();
    record.iterations = Some(result.iterations);
    record.solve_time_s = Some(result.time.as_secs_f64());
    record.residual_rel = Some(result.residuals.natural_map_rel);
    record.residual_abs = Some(result.residuals.natural_map);
    record.complementarity_gap = Some(result.residuals.complementarity_gap);
    record.bound_violation = Some(result.residuals.bound_violation);
    record.set_tta(time_to_accuracy(result));
    record.certificate_bound = result.certificate.as_ref().map(|c| c.min_solution_norm);
}

/// Solver time until the relative residual first reached each of [`TTA_LEVELS`]: the first
/// history point at or below the level, or the total time when only the final residual is
/// (solvers that record no history). Nothing for a solver that declined the problem
/// (`unsupported`), whatever the residual of its zero impulse.
pub fn time_to_accuracy(result: &SolveResult) -> [Option<f64>; 4] {
    if matches!(result.status, lcpbench_solvers::Status::Unsupported { .. }) {
        return [None; 4];
    }
    TTA_LEVELS.map(|level| {
        result
            .history
            .iter()
            .find(|h| h.residual <= level)
            .map(|h| h.time_s)
            .or_else(|| {
                (result.residuals.natural_map_rel <= level).then_some(result.time.as_secs_f64())
            })
    })
}

/// Keep at most `max` points, log-spaced in iteration, always keeping the first and last.
pub fn thin_history(history: &[HistoryPoint], max: usize) -> Vec<HistoryPoint> {
    if history.len() <= max {
        return history.to_vec();
    }
    let last = history.len() - 1;
    let mut keep: Vec<usize> = (0..max)
        .map(|k| {
            let t = k as f64 / (max - 1) as f64;
            (((last + 1) as f64).powf(t) - 1.0).round() as usize
        })
        .collect();
    keep.push(last);
    keep.sort_unstable();
    keep.dedup();
    keep.into_iter().map(|i| history[i]).collect()
}

/// The warm start of an LCP case: the planted solution with a deterministic 1% perturbation
/// (as if it came from the previous step of a slowly changing scene), or, without a known
/// solution, the impulse after 20 cold PGS sweeps.
pub fn warm_start_for(lcp: &LoadedLcp) -> Vec<f64> {
    match &lcp.solution {
        Some(star) => {
            let scale = star.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-12);
            star.iter()
                .enumerate()
                .map(|(i, v)| {
                    // A fixed pseudo-random sign pattern in [-1, 1].
                    let s = ((i as f64 * 12.9898).sin() * 43758.5453).fract();
                    (v + 0.01 * scale * s).max(0.0)
                })
                .collect()
        }
        None => {
            let settings = Settings {
                max_iterations: 20,
                tolerance: 1e-300,
                ..Settings::default()
            };
            ProjectedSor::pgs().solve(&lcp.problem, &settings).f
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lcp_run_fills_the_row() {
        let case: Case = "spd:n=12:cond=1e2:seed=1".parse().unwrap();
        let spec: SolverSpec = "pgs".parse().unwrap();
        let budget: NamedBudget = "default".parse().unwrap();
        let out = run_in_process(&case, &spec, &budget);
        let r = &out.record;
        assert_eq!(r.status, RunStatus::Converged);
        assert!(r.converged);
        assert!(r.residual_rel.unwrap() <= 1e-8);
        assert!(r.tta_1e4.unwrap() <= r.tta_1e8.unwrap());
        assert!(r.solution_error.unwrap() < 1e-6);
        assert!(!out.history.is_empty());
    }

    /// On a problem without a solution an iterative solver's impulse meets a loose tolerance by
    /// diverging: the row says `diverged` and records the bound its certificate proves.
    #[test]
    fn a_diverging_run_records_its_certificate_bound() {
        let case: Case = "infeasible:n=6:seed=1".parse().unwrap();
        let budget: NamedBudget = "1e-4:10000:5".parse().unwrap();
        let out = run_in_process(&case, &"apgd".parse().unwrap(), &budget);
        let r = &out.record;
        assert_eq!(r.status, RunStatus::Diverged, "{}", r.reason);
        assert!(!r.converged && r.residual_rel.unwrap() <= 1e-4);
        assert!(r.certificate_bound.unwrap() > 1e3, "{r:?}");
        let solvable: Case = "spd:n=12:cond=1e2:seed=1".parse().unwrap();
        let out = run_in_process(&solvable, &"apgd".parse().unwrap(), &budget);
        assert_eq!(out.record.certificate_bound, None);
    }

    #[test]
    fn warm_start_helps_pgs() {
        let case: Case = "spd:n=40:cond=1e4:seed=1".parse().unwrap();
        let budget: NamedBudget = "default".parse().unwrap();
        let cold = run_in_process(&case, &"pgs".parse().unwrap(), &budget);
        let warm = run_in_process(&case, &"pgs+warm".parse().unwrap(), &budget);
        assert!(warm.record.iterations.unwrap() <= cold.record.iterations.unwrap());
    }

    #[test]
    fn thinning_keeps_ends() {
        let h: Vec<HistoryPoint> = (1..=1000)
            .map(|i| HistoryPoint {
                iteration: i,
                residual: 1.0 / i as f64,
                time_s: i as f64,
            })
            .collect();
        let t = thin_history(&h, 50);
        assert!(t.len() <= 51);
        assert_eq!(t[0].iteration, 1);
        assert_eq!(t.last().unwrap().iteration, 1000);
    }
}

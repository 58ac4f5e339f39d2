//! One run, in process: load the case, solve (or step the scene), measure. This is what the
//! isolated child (`lcpbench bench-one`) executes; [`crate::harness::isolate`] runs it in a child
//! process so a panic, an abort or a hang cannot take the sweep down.
//!
//! An LCP or cone solve is timed by [`crate::harness::timing`]: an untimed first solve, then
//! repeats from the same start (the same settings and warm start, a fresh copy of the solver),
//! the median recorded. A `+warm` run's start is computed first ([`warm_start_for`]), outside
//! the solve's time; the row says where it came from and what it cost.

use crate::harness::case::{file_warm_start, Case, GenFamily, LoadedLcp};
use crate::harness::record::{
    base_record, RunOutput, RunRecord, RunStatus, WarmSource, TTA_LEVELS, WARM_PGS_SWEEPS,
};
use crate::harness::scene;
use crate::harness::timing::{measure, Timed, TimingRule, WallClock};
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
    let mut settings = budget.budget.settings();
    settings.record_history = true;
    if spec.warm() {
        match warm_start_for(case, &lcp) {
            Ok(warm) => {
                record.warm_source = warm.source.name().to_owned();
                record.warm_time_s = warm.time_s;
                settings.warm_start = Some(warm.start);
            }
            Err(e) => return RunOutput::failed(record, RunStatus::Error, e),
        }
    }
    if let Some(solver) = spec.create_cone() {
        return run_cone_lcp(solver, &lcp, &settings, record);
    }
    let Some(solver) = spec.create() else {
        return RunOutput::failed(record, RunStatus::Error, "no solver");
    };
    crate::harness::isolate::signal_ready();
    // Each solve gets a fresh copy of the solver, so no repeat starts from state a previous
    // one left behind.
    let (timed, first) = measure_with_history(&settings, |s| solver.clone().solve(&lcp.problem, s));
    fill_from_timed(&mut record, &timed, &first);
    let result = &timed.result;
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
        history: thin_history(&first.history, HISTORY_POINTS),
    }
}

/// A cone solver on an LCP case: the box-friction problem read as the cone of its
/// (normal, tangent, tangent) triples; any other problem is `unsupported`.
fn run_cone_lcp(
    solver: Box<dyn ConeSolver + Send>,
    lcp: &LoadedLcp,
    settings: &Settings,
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
    crate::harness::isolate::signal_ready();
    let (timed, first) = measure_with_history(settings, |s| solver.clone().solve_cone(&problem, s));
    fill_from_timed(&mut record, &timed, &first);
    RunOutput {
        history: thin_history(&first.history, HISTORY_POINTS),
        record,
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

/// Time a solve by the method of [`crate::harness::timing`] and keep its convergence history.
/// Recording a history measures the residual at every iteration, which costs as much as an
/// iteration of the cheaper solvers and disturbs the caches, although the solver's clock leaves
/// the measurements out. So only the untimed first solve records its history (`settings` as
/// given, `record_history` on); the timed repeats run with `record_history` off. When the first
/// solve is itself the measurement (a slow solve), its time is the one with its history.
/// Returns the timing and the first solve, whose history the run keeps.
pub fn measure_with_history(
    settings: &Settings,
    solve: impl Fn(&Settings) -> SolveResult,
) -> (Timed<SolveResult>, SolveResult) {
    let mut quiet = settings.clone();
    quiet.record_history = false;
    let first: std::cell::RefCell<Option<SolveResult>> = std::cell::RefCell::new(None);
    let timed = measure(
        &TimingRule::default(),
        &WallClock::new(),
        || {
            if first.borrow().is_none() {
                let r = solve(settings);
                *first.borrow_mut() = Some(r.clone());
                r
            } else {
                solve(&quiet)
            }
        },
        |_| (),
    );
    let first = first
        .into_inner()
        .expect("the timing method makes at least one solve");
    (timed, first)
}

/// Copy a timed solve into the row ([`crate::harness::timing`]): the outcome of the last timed
/// solve ([`fill_from_result`]), with `solve_time_s` the median of the timed solves,
/// `solve_time_min_s` and `solve_time_max_s` their spread and `timed_solves` their count. The
/// time-to-accuracy columns come from the history of the `first` solve (the one that recorded
/// it, [`measure_with_history`]): the time at which it first reached each level, scaled by the
/// ratio of the median to that solve's own time, so they are on the median's footing (a
/// deterministic solver reaches a level at the same iteration in every repeat); a level reached
/// only by the final answer is the median itself.
pub fn fill_from_timed(record: &mut RunRecord, timed: &Timed<SolveResult>, first: &SolveResult) {
    fill_from_result(record, &timed.result);
    let median_s = timed.median_s();
    record.solve_time_s = Some(median_s);
    record.solve_time_min_s = Some(timed.min_s());
    record.solve_time_max_s = Some(timed.max_s());
    record.timed_solves = Some(timed.count());
    let first_s = first.time.as_secs_f64();
    let scale = if first_s > 0.0 {
        median_s / first_s
    } else {
        1.0
    };
    let tta = time_to_accuracy(first).map(|t| t.map(|t| (t * scale).min(median_s)));
    record.set_tta(tta);
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

/// The warm start of a `+warm` run on an LCP case, where it came from and what it cost.
#[derive(Debug, Clone, PartialEq)]
pub struct WarmStart {
    /// The starting impulse, one value per row.
    pub start: Vec<f64>,
    /// Where it came from.
    pub source: WarmSource,
    /// Median time to compute it, seconds, timed as solves are ([`crate::harness::timing`]);
    /// `None` when it costs the solver nothing (read from the file, or the perturbed planted
    /// solution).
    pub time_s: Option<f64>,
}

/// The warm start of an LCP case, in this order: the problem file's own `warm_start` (as
/// `lcpbench export` writes it for a warm-started step); for a generated case, the planted
/// solution with a deterministic perturbation of 1% of its largest entry (as if it came from
/// the previous step of a slowly changing scene); otherwise the impulse after
/// [`WARM_PGS_SWEEPS`] cold PGS sweeps, whose cost is timed by the method of the solves. An
/// error names the file and field of a `warm_start` that is malformed or of the wrong length.
pub fn warm_start_for(case: &Case, lcp: &LoadedLcp) -> Result<WarmStart, String> {
    let n = lcp.problem.n();
    if let Case::File(path) = case {
        if let Some(start) = file_warm_start(path)? {
            if start.len() != n {
                return Err(format!(
                    "{}: field `warm_start` has {} values for {n} rows",
                    path.display(),
                    start.len()
                ));
            }
            return Ok(WarmStart {
                start,
                source: WarmSource::File,
                time_s: None,
            });
        }
    }
    if let Some(star) = &lcp.solution {
        let scale = star.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-12);
        let start = star
            .iter()
            .enumerate()
            .map(|(i, v)| {
                // A fixed pseudo-random sign pattern in [-1, 1].
                let s = ((i as f64 * 12.9898).sin() * 43758.5453).fract();
                (v + 0.01 * scale * s).max(0.0)
            })
            .collect();
        return Ok(WarmStart {
            start,
            source: WarmSource::PerturbedPlanted,
            time_s: None,
        });
    }
    let settings = Settings {
        max_iterations: WARM_PGS_SWEEPS,
        tolerance: 1e-300,
        ..Settings::default()
    };
    let pgs = ProjectedSor::pgs();
    let timed = measure(
        &TimingRule::default(),
        &WallClock::new(),
        || pgs.clone().solve(&lcp.problem, &settings),
        |_| (),
    );
    Ok(WarmStart {
        time_s: Some(timed.median_s()),
        start: timed.result.f,
        source: WarmSource::PgsSweeps,
    })
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

    /// An LCP row records the spread of its timed solves, and a cold one no warm start.
    #[test]
    fn an_lcp_run_records_its_timed_solves() {
        let generated: Case = "spd:n=12:cond=1e2:seed=1".parse().unwrap();
        let step: Case = "step:bench_scenes/tower_5.toml?step=2".parse().unwrap();
        let budget: NamedBudget = "default".parse().unwrap();
        for (case, solver) in [
            (&generated, "pgs"),
            (&generated, "lemke"),
            (&step, "nsgs-cone"),
        ] {
            let out = run_in_process(case, &solver.parse().unwrap(), &budget);
            let r = &out.record;
            let count = r.timed_solves.unwrap();
            assert!(
                (1..=crate::harness::timing::MAX_SOLVES).contains(&count),
                "{r:?}"
            );
            let (min, median, max) = (
                r.solve_time_min_s.unwrap(),
                r.solve_time_s.unwrap(),
                r.solve_time_max_s.unwrap(),
            );
            assert!(min <= median && median <= max, "{solver}: {r:?}");
            assert!(r.warm_source.is_empty() && r.warm_time_s.is_none());
        }
        // A solver that declines the problem is not timed.
        let out = run_in_process(&generated, &"nsgs-cone".parse().unwrap(), &budget);
        assert_eq!(out.record.status, RunStatus::Unsupported);
        assert_eq!(out.record.timed_solves, None);
    }

    /// The sources of a warm start, in order: the file's own, the perturbed planted solution,
    /// PGS sweeps (timed); a malformed file start is an error naming the file and field.
    #[test]
    fn warm_starts_say_where_they_came_from() {
        assert_eq!(
            WarmSource::PgsSweeps.name(),
            format!("{WARM_PGS_SWEEPS} PGS sweeps")
        );
        let budget: NamedBudget = "default".parse().unwrap();
        let pgs_warm: SolverSpec = "pgs+warm".parse().unwrap();
        let generated: Case = "spd:n=12:cond=1e2:seed=1".parse().unwrap();
        let r = run_in_process(&generated, &pgs_warm, &budget).record;
        assert_eq!(r.warm_source, "perturbed planted solution");
        assert_eq!(r.warm_time_s, None);

        let dir = tempfile::tempdir().unwrap();
        let problem = r#""A": [[2, 1], [1, 2]], "b": [-1, -1]"#;
        let file = |name: &str, text: String| {
            let path = dir.path().join(name);
            std::fs::write(&path, text).unwrap();
            Case::File(path)
        };
        let plain = file("plain.json", format!("{{{problem}}}"));
        let r = run_in_process(&plain, &pgs_warm, &budget).record;
        assert_eq!(r.status, RunStatus::Converged, "{r:?}");
        assert_eq!(r.warm_source, "20 PGS sweeps");
        assert!(r.warm_time_s.unwrap() > 0.0);
        let cold = run_in_process(&plain, &"pgs".parse().unwrap(), &budget).record;
        assert!(cold.warm_source.is_empty() && cold.warm_time_s.is_none());

        // The solution of this problem is f = (1/3, 1/3): a file starting there needs no sweep.
        let exported = file(
            "exported.json",
            format!(r#"{{{problem}, "warm_start": [0.3333333333333333, 0.3333333333333333]}}"#),
        );
        let r = run_in_process(&exported, &pgs_warm, &budget).record;
        assert_eq!(r.warm_source, "file");
        assert_eq!(r.warm_time_s, None);
        assert!(r.iterations.unwrap() <= 2, "{r:?}");

        let short = file("short.json", format!(r#"{{{problem}, "warm_start": [1]}}"#));
        let r = run_in_process(&short, &pgs_warm, &budget).record;
        assert_eq!(r.status, RunStatus::Error);
        assert!(
            r.reason.contains("short.json") && r.reason.contains("`warm_start` has 1 values"),
            "{}",
            r.reason
        );
        let text = file(
            "text.json",
            format!(r#"{{{problem}, "warm_start": ["x", 1]}}"#),
        );
        let r = run_in_process(&text, &pgs_warm, &budget).record;
        assert_eq!(r.status, RunStatus::Error);
        assert!(
            r.reason.contains("text.json: field `warm_start`"),
            "{}",
            r.reason
        );
    }

    /// Scenes keep their in-loop timing; a `+warm` scene run starts each step from the last.
    #[test]
    fn a_warm_scene_run_names_the_previous_step() {
        let case: Case = "scene:bench_scenes/tower_5.toml?steps=2".parse().unwrap();
        let budget: NamedBudget = "default".parse().unwrap();
        let warm = run_in_process(&case, &"pgs+warm".parse().unwrap(), &budget).record;
        assert_eq!(warm.warm_source, "previous step");
        assert_eq!((warm.warm_time_s, warm.timed_solves), (None, None));
        let cold = run_in_process(&case, &"pgs".parse().unwrap(), &budget).record;
        assert!(cold.warm_source.is_empty());
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

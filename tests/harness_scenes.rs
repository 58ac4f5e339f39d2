//! Scene runs through the sweep: per-step metrics aggregated into one row per run.

use lcpbench::harness::sweep::read_results;
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_lcpbench");

#[test]
fn scene_rows_carry_step_metrics_and_analytic_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/bench_scenes/v_groove.toml");
    let status = Command::new(EXE)
        .args(["bench", "--no-progress", "--solvers", "pgs,si,pgs+warm"])
        .args(["--budgets", "default", "--out"])
        .arg(&out)
        .arg("--lcps")
        .arg(format!("scene:{scene}?steps=30"))
        .status()
        .unwrap();
    assert!(status.success());
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert_eq!(r.class, "scene");
        assert_eq!(r.steps, Some(30), "{r:?}");
        assert!(r.time_per_step_s.unwrap() > 0.0);
        assert_eq!(r.analytic_metric, "wall force (relative)");
        assert!(r.analytic_error.unwrap() < 1e-3, "{r:?}");
        assert!(r.symmetry_error.unwrap() < 1e-6, "{r:?}");
        assert_eq!(r.blow_up, Some(false));
        assert_eq!(r.no_solution_steps, Some(0), "{r:?}");
    }
}

/// A solver that declines every step (enumeration on 120-row steps) is `unsupported` even when
/// the run then stops on its time limit: collision and assembly used the time, not the solver.
#[test]
fn a_run_unsupported_on_every_step_is_unsupported_not_time_limit() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/bench_scenes/tower_10.toml");
    // A 1 ms run limit (half the budget's 2 ms): a few steps of the 1,000 at most.
    let status = Command::new(EXE)
        .args(["bench", "--no-progress", "--solvers", "enum,pgs"])
        .args(["--budgets", "1e-8:10000:0.002", "--out"])
        .arg(&out)
        .arg("--lcps")
        .arg(format!("scene:{scene}"))
        .status()
        .unwrap();
    assert!(status.success());
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 2);
    for r in &rows {
        let steps = r.steps.unwrap();
        assert!((1..1000).contains(&steps), "{r:?}");
        let stopped = format!("stopped after {steps} of 1000 steps (0.001 s)");
        assert!(r.reason.contains(&stopped), "{r:?}");
        match r.solver.as_str() {
            "enum" => {
                assert_eq!(r.status.as_str(), "unsupported", "{r:?}");
                assert!(r.reason.contains("all "), "{r:?}");
            }
            _ => assert_eq!(r.status.as_str(), "time_limit", "{r:?}"),
        }
    }
}

/// A scene whose steps have no solution (`wedged`: Baumgarte asks a box to leave two static
/// boxes on opposite sides at once) counts them in `no_solution_steps`, and its status is the
/// steps' `diverged`.
#[test]
fn steps_without_a_solution_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/bench_scenes/wedged.toml");
    let status = Command::new(EXE)
        .args(["bench", "--no-progress", "--solvers", "apgd"])
        .args(["--budgets", "loose", "--out"])
        .arg(&out)
        .arg("--lcps")
        .arg(format!("scene:{scene}?steps=5"))
        .status()
        .unwrap();
    assert!(status.success());
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].status.as_str(), "diverged", "{:?}", rows[0]);
    assert_eq!(rows[0].no_solution_steps, Some(5));
    assert_eq!(rows[0].nonconverged_steps, Some(5));
}

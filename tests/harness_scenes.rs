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
    }
}

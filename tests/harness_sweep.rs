//! The sweep seen from outside: rows are written as runs finish, an interrupted sweep resumes,
//! and runs that panic, abort or hang are recorded while the sweep carries on.

use lcpbench::harness::sweep::read_results;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const EXE: &str = env!("CARGO_BIN_EXE_lcpbench");

fn bench(out: &Path, lcps: &str, solvers: &str, budget: &str, jobs: usize) -> Command {
    let mut cmd = Command::new(EXE);
    cmd.args(["bench", "--no-progress", "--lcps", lcps])
        .args(["--jobs", &jobs.to_string()])
        .args(["--solvers", solvers, "--budgets", budget, "--out"])
        .arg(out);
    cmd
}

#[test]
fn faults_are_recorded_and_the_sweep_continues() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let status = bench(
        &out,
        "spd:n=10:cond=1e2:seed=1",
        "pgs,fault-panic,fault-abort,fault-hang,sor",
        "1e-8:1000:0.2",
        2,
    )
    .status()
    .unwrap();
    assert!(status.success());
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 5);
    let status_of = |solver: &str| {
        rows.iter()
            .find(|r| r.solver == solver)
            .map(|r| r.status.clone())
            .unwrap()
    };
    assert_eq!(status_of("pgs"), "converged");
    assert_eq!(status_of("sor"), "converged");
    assert_eq!(status_of("fault-panic"), "panic");
    assert_eq!(status_of("fault-abort"), "crash");
    assert_eq!(status_of("fault-hang"), "timeout");
    let panic_row = rows.iter().find(|r| r.solver == "fault-panic").unwrap();
    assert!(panic_row.reason.contains("injected fault"), "{panic_row:?}");
}

#[test]
fn rows_are_written_as_runs_finish_and_a_rerun_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let results = out.join("results.csv");
    // One worker: pgs finishes at once, then the hanging run holds the sweep for ~2.4 s.
    let mut child = bench(
        &out,
        "spd:n=10:cond=1e2:seed=1",
        "pgs,fault-hang,sor",
        "1e-8:1000:0.2",
        1,
    )
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let start = Instant::now();
    let mut seen_early = false;
    while child.try_wait().unwrap().is_none() {
        if let Ok(rows) = read_results(&results) {
            if rows.iter().any(|r| r.solver == "pgs") {
                assert!(rows.iter().all(|r| r.solver != "sor"));
                seen_early = true;
                break;
            }
        }
        assert!(start.elapsed() < Duration::from_secs(30), "no row appeared");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        seen_early,
        "the first row was not on disk while the sweep ran"
    );
    assert!(child.wait().unwrap().success());
    assert_eq!(read_results(&results).unwrap().len(), 3);

    // Interrupt: keep the header and the first row, then a torn line.
    let text = std::fs::read_to_string(&results).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.truncate(2);
    let torn = format!("{}\nspd:n=10:cond=1e2:seed=1,spd,sp", lines.join("\n"));
    std::fs::write(&results, torn).unwrap();

    let output = bench(
        &out,
        "spd:n=10:cond=1e2:seed=1,psd:n=8:seed=1",
        "pgs,sor",
        "1e-8:1000:0.2",
        2,
    )
    .output()
    .unwrap();
    assert!(output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("ran 3, skipped 1"), "{stderr}");
    let rows = read_results(&results).unwrap();
    assert_eq!(rows.len(), 4);
    let mut keys: Vec<_> = rows.iter().map(|r| r.key()).collect();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), 4);
    // Every line of the file parses: the torn line is gone.
    let text = std::fs::read_to_string(&results).unwrap();
    assert_eq!(text.lines().count(), 5);
}

#[test]
fn the_hidden_child_reports_injected_faults_as_failures() {
    let out = Command::new(EXE)
        .args(["bench-one", "--case", "spd:n=4:seed=1", "--solver", "pgs"])
        .args(["--budget", "default", "--fault", "panic"])
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("injected fault"));
    let out = Command::new(EXE)
        .args(["bench-one", "--case", "spd:n=4:seed=1", "--solver", "pgs"])
        .args(["--budget", "default"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let parsed = lcpbench::harness::isolate::parse_protocol(&text).unwrap();
    assert_eq!(parsed.record.status, "converged");
}

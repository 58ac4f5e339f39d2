//! The sweep seen from outside: rows are written as runs finish, an interrupted sweep resumes,
//! and runs that panic, abort or hang are recorded while the sweep carries on.

use lcpbench::harness::sweep::read_results;
use lcpbench::harness::RunStatus;
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
            .find(|r| r.solver.to_string() == solver)
            .map(|r| r.status)
            .unwrap()
    };
    assert_eq!(status_of("pgs"), RunStatus::Converged);
    assert_eq!(status_of("sor"), RunStatus::Converged);
    assert_eq!(status_of("fault-panic"), RunStatus::Panic);
    assert_eq!(status_of("fault-abort"), RunStatus::Crash);
    assert_eq!(status_of("fault-hang"), RunStatus::Timeout);
    let panic_row = rows
        .iter()
        .find(|r| r.solver.to_string() == "fault-panic")
        .unwrap();
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
            if rows.iter().any(|r| r.solver.to_string() == "pgs") {
                assert!(rows.iter().all(|r| r.solver.to_string() != "sor"));
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
    assert_eq!(parsed.record.status, RunStatus::Converged);
}

fn stderr_of(output: &std::process::Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn an_unrepresentable_budget_is_refused_before_any_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let output = bench(
        &out,
        "spd:n=5:seed=1",
        "pgs,sor",
        "1e-8:100:1,1e-8:100:1e19",
        2,
    )
    .output()
    .unwrap();
    let stderr = stderr_of(&output);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("1e-8:100:1e19"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.join("results.csv").exists());
}

#[test]
fn a_second_sweep_on_the_same_directory_refuses_and_no_row_is_lost_or_doubled() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    // The hanging run holds the first sweep for several seconds.
    let mut first = bench(
        &out,
        "spd:n=10:cond=1e2:seed=1",
        "pgs,fault-hang,sor",
        "1e-8:1000:0.2",
        1,
    )
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let lock = out.join(".lcpbench.lock");
    let start = Instant::now();
    while std::fs::read_to_string(&lock).map_or(true, |s| s.trim().is_empty()) {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no lock appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let second = bench(
        &out,
        "spd:n=10:cond=1e2:seed=1,psd:n=8:seed=1",
        "pgs,sor",
        "1e-8:1000:0.2",
        2,
    )
    .output()
    .unwrap();
    let stderr = stderr_of(&second);
    assert_eq!(second.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(&out.display().to_string()), "{stderr}");
    assert!(
        stderr.contains("in use by another lcpbench sweep"),
        "{stderr}"
    );
    assert!(first.wait().unwrap().success());
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 3);
    // Once the first is done the directory is free again, and a resume adds only new runs.
    let third = bench(
        &out,
        "spd:n=10:cond=1e2:seed=1,psd:n=8:seed=1",
        "pgs,sor",
        "1e-8:1000:0.2",
        2,
    )
    .output()
    .unwrap();
    assert!(third.status.success(), "{}", stderr_of(&third));
    let rows = read_results(&out.join("results.csv")).unwrap();
    let mut keys: Vec<_> = rows.iter().map(|r| r.key()).collect();
    keys.sort();
    let n = keys.len();
    keys.dedup();
    assert_eq!(n, keys.len(), "duplicate rows");
    assert_eq!(n, 5);
}

#[test]
fn a_torn_last_row_is_dropped_and_rerun_not_padded() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let results = out.join("results.csv");
    let run = || {
        bench(
            &out,
            "spd:n=10:cond=1e2:seed=1",
            "pgs,sor",
            "1e-8:1000:1",
            1,
        )
        .output()
        .unwrap()
    };
    assert!(run().status.success());
    let full = read_results(&results).unwrap();
    assert_eq!(full.len(), 2);
    let text = std::fs::read_to_string(&results).unwrap();
    let last = full[1].clone();
    // Cut the last row inside its relative residual: `1.85e-15` would read as `1.85`.
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let column = header.iter().position(|h| *h == "residual_rel").unwrap();
    let line_start = text.trim_end().rfind('\n').unwrap() + 1;
    let line = &text[line_start..];
    let field_start: usize = line.split(',').take(column).map(|f| f.len() + 1).sum();
    let value = line.split(',').nth(column).unwrap();
    assert!(value.len() > 3, "{value}");
    let cut = line_start + field_start + 3;
    // A complete line that is not a row (ended by a newline, or with more cells than a row)
    // is no torn write: the resume refuses, naming the line, and leaves the file as it is.
    for damaged in [
        format!("{}\n", &text[..cut]),       // newline, columns missing
        format!("{}9,9\n", text.trim_end()), // extra columns
        format!("{}9,9", text.trim_end()),   // extra columns, no newline
    ] {
        std::fs::write(&results, &damaged).unwrap();
        let output = run();
        let stderr = stderr_of(&output);
        assert!(!output.status.success(), "{stderr}");
        assert!(stderr.contains("line 3"), "{stderr}");
        assert_eq!(std::fs::read_to_string(&results).unwrap(), damaged);
    }
    // Only the start of a row, without its newline, is a torn write: dropped and run again.
    {
        let torn = text[..cut].to_owned();
        std::fs::write(&results, &torn).unwrap();
        let output = run();
        let stderr = stderr_of(&output);
        assert!(output.status.success(), "{stderr}");
        assert!(stderr.contains("ran 1, skipped 1"), "{stderr}");
        assert!(stderr.contains("dropped 1 rows"), "{stderr}");
        let rows = read_results(&results).unwrap();
        assert_eq!(rows.len(), 2);
        let again = rows.iter().find(|r| r.key() == last.key()).unwrap();
        assert_eq!(again.residual_rel, last.residual_rel);
        assert_eq!(again.status, last.status);
        let text = std::fs::read_to_string(&results).unwrap();
        assert_eq!(text.lines().count(), 3);
    }
}

/// A results file written without the last columns of the row (the joint columns, and before
/// them `host`, `cpu_model`, `cores`) is an older lcpbench's: its rows still read, with those
/// columns empty,
/// but a sweep does not append rows of this version to it: it refuses, naming the file, and
/// leaves it byte for byte as it was.
#[test]
fn results_without_the_last_columns_read_but_are_not_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let results = out.join("results.csv");
    let run = |solvers: &str| {
        bench(&out, "spd:n=10:cond=1e2:seed=1", solvers, "1e-8:1000:1", 1)
            .output()
            .unwrap()
    };
    assert!(run("pgs").status.success());
    let text = std::fs::read_to_string(&results).unwrap();
    let header = text.lines().next().unwrap();
    assert!(
        header.ends_with(
            ",no_solution_steps,host,cpu_model,cores,joint_drift_max,joint_drift_mean,\
             joint_angle_max,sag_body,timed_solves,solve_time_min_s,solve_time_max_s,\
             warm_source,warm_time_s,substeps_per_step,row_updates_per_step,\
             body_passes_per_step,step_time_no_residual_s,residual_of,steps_measured,\
             measured_step_time_s,failed_steps"
        ),
        "{header}"
    );
    let older: String = text
        .lines()
        .map(|line| {
            let cells: Vec<&str> = line.split(',').collect();
            format!("{}\n", cells[..cells.len() - 20].join(","))
        })
        .collect();
    std::fs::write(&results, &older).unwrap();
    let rows = read_results(&results).unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].host, None);
    assert_eq!(rows[0].cores, None);
    assert_eq!((rows[0].timed_solves, rows[0].warm_time_s), (None, None));
    assert!(rows[0].warm_source.is_empty());
    let output = run("pgs,sor");
    assert!(!output.status.success());
    assert!(
        stderr_of(&output).contains("written by an older lcpbench"),
        "{}",
        stderr_of(&output)
    );
    assert_eq!(std::fs::read_to_string(&results).unwrap(), older);
}

#[test]
fn duplicate_rows_in_results_are_dropped_and_rerun_once() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let results = out.join("results.csv");
    let run = || {
        bench(&out, "spd:n=10:cond=1e2:seed=1", "pgs", "1e-8:1000:1", 1)
            .output()
            .unwrap()
    };
    assert!(run().status.success());
    let text = std::fs::read_to_string(&results).unwrap();
    let row = text.lines().nth(1).unwrap();
    std::fs::write(&results, format!("{text}{row}\n")).unwrap();
    let output = run();
    assert!(output.status.success());
    assert!(stderr_of(&output).contains("ran 1, skipped 0"));
    assert_eq!(read_results(&results).unwrap().len(), 1);
}

#[test]
fn stale_runner_copies_of_a_killed_sweep_are_removed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    std::fs::create_dir_all(&out).unwrap();
    // What a killed sweep leaves behind.
    let stale = out.join(".lcpbench-runner-4000000");
    std::fs::write(&stale, b"old binary").unwrap();
    let output = bench(&out, "spd:n=10:cond=1e2:seed=1", "pgs", "1e-8:1000:1", 1)
        .output()
        .unwrap();
    let stderr = stderr_of(&output);
    assert!(output.status.success(), "{stderr}");
    assert!(!stale.exists());
    assert!(stderr.contains("removed 1 executable copies"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with(".lcpbench-runner-")
        })
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn a_case_listed_twice_is_run_once_and_said_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let output = bench(
        &out,
        "spd:n=10:cond=1e2:seed=1,spd:n=10:cond=100:seed=1",
        "pgs",
        "1e-8:1000:1",
        1,
    )
    .output()
    .unwrap();
    let stderr = stderr_of(&output);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("case spd:n=10:cond=1e2:seed=1 listed more than once, running it once"),
        "{stderr}"
    );
    assert!(stderr.contains("ran 1, skipped 0"), "{stderr}");
    assert_eq!(read_results(&out.join("results.csv")).unwrap().len(), 1);
}

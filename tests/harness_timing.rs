//! How solves are timed, seen from outside: `bench` rows of LCP cases carry the count and
//! spread of their timed solves, `+warm` rows say where the start came from and what it cost,
//! and `solve` times a problem the same way. No speed is asserted.

use lcpbench::harness::sweep::read_results;
use lcpbench::harness::RunStatus;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_lcpbench");

/// The two-row problem `A = [[2, 1], [1, 2]]`, `b = (-1, -1)`, solution `f = (1/3, 1/3)`.
const TWO_ROWS: &str = r#"{"A": [[2, 1], [1, 2]], "b": [-1, -1]}"#;

fn bench(out: &Path, lcps: &str, solvers: &str) {
    let o = Command::new(EXE)
        .args([
            "bench",
            "--no-progress",
            "--lcps",
            lcps,
            "--solvers",
            solvers,
        ])
        .args(["--budgets", "default", "--jobs", "1", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn a_sweep_over_a_tiny_lcp_records_repeated_timed_solves() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    bench(&out, "spd:n=10:cond=1e2:seed=1", "pgs,lemke,newton-fb");
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert_eq!(r.status, RunStatus::Converged, "{r:?}");
        // A solve of ten rows takes far less than 20 ms: it is repeated, at least 3 times.
        let count = r.timed_solves.unwrap();
        assert!(count >= 3, "{}: {count} timed solves", r.solver);
        let (min, median, max) = (
            r.solve_time_min_s.unwrap(),
            r.solve_time_s.unwrap(),
            r.solve_time_max_s.unwrap(),
        );
        assert!(
            0.0 < min && min <= median && median <= max,
            "{}: {min} {median} {max}",
            r.solver
        );
        assert!(r.warm_source.is_empty() && r.warm_time_s.is_none());
    }
}

#[test]
fn warm_file_cases_say_where_the_start_came_from() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.json");
    std::fs::write(&plain, TWO_ROWS).unwrap();
    let exported = dir.path().join("exported.json");
    std::fs::write(
        &exported,
        r#"{"A": [[2, 1], [1, 2]], "b": [-1, -1], "warm_start": [0.3, 0.3]}"#,
    )
    .unwrap();
    let out = dir.path().join("sweep");
    let lcps = format!("file:{},file:{}", plain.display(), exported.display());
    bench(&out, &lcps, "pgs,pgs+warm");
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 4);
    let row = |file: &Path, solver: &str| {
        rows.iter()
            .find(|r| {
                r.case == format!("file:{}", file.display()) && r.solver.to_string() == solver
            })
            .unwrap_or_else(|| panic!("no row for {} {solver}", file.display()))
    };
    // Without a warm start in the file, the harness computes one by PGS sweeps and times them.
    let r = row(&plain, "pgs+warm");
    assert_eq!(r.warm_source, "20 PGS sweeps");
    assert!(r.warm_time_s.unwrap() > 0.0, "{r:?}");
    assert!(r.timed_solves.unwrap() >= 1);
    // The file's own warm start costs nothing.
    let r = row(&exported, "pgs+warm");
    assert_eq!(r.warm_source, "file");
    assert_eq!(r.warm_time_s, None);
    // Cold runs have neither.
    for file in [&plain, &exported] {
        let r = row(file, "pgs");
        assert!(r.warm_source.is_empty() && r.warm_time_s.is_none(), "{r:?}");
    }
}

#[test]
fn solve_times_by_the_same_method() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("p.json");
    std::fs::write(&file, TWO_ROWS).unwrap();
    let solve = |extra: &[&str]| -> Value {
        let o = Command::new(EXE)
            .arg("solve")
            .arg(&file)
            .args(["--solver", "lemke", "--json"])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let spread = |v: &Value| {
        let get = |k: &str| v[k].as_f64().unwrap();
        (get("time_min_s"), get("time_s"), get("time_max_s"))
    };
    let v = solve(&[]);
    assert!(v["timed_solves"].as_u64().unwrap() >= 3, "{v}");
    let (min, median, max) = spread(&v);
    assert!(min <= median && median <= max, "{v}");
    let v = solve(&["--repeat", "5"]);
    assert_eq!(v["timed_solves"], 5, "{v}");
    let (min, median, max) = spread(&v);
    assert!(min <= median && median <= max, "{v}");
    assert_eq!(v["status"], "converged");
}

#[test]
fn bench_help_states_the_timing_method_and_the_warm_start_rule() {
    let o = Command::new(EXE)
        .args(["bench", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&o.stdout);
    assert!(help.contains(lcpbench::harness::timing::HELP), "{help}");
}

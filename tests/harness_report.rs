//! `lcpbench report --quick` writes the README, the tables, the figures and parsable CSV.

use lcpbench::harness::sweep::{read_histories, read_results};
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_lcpbench");

#[test]
fn quick_report_writes_tables_figures_and_csv() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("reports");
    let scenes = dir.path().join("no_scenes/*.toml");
    let status = Command::new(EXE)
        .args(["report", "--quick", "--no-progress", "--out"])
        .arg(&out)
        .arg("--scenes")
        .arg(&scenes)
        .status()
        .unwrap();
    assert!(status.success());
    let readme = std::fs::read_to_string(out.join("README.md")).unwrap();
    for heading in [
        "## Robustness matrix",
        "## Fastest solver per problem",
        "## Time to accuracy",
        "## Warm start versus cold start",
        "## SOR relaxation sweep",
        "## Scaling",
        "cargo run --release -- report",
    ] {
        assert!(readme.contains(heading), "missing {heading}");
    }
    let rows = read_results(&out.join("data/results.csv")).unwrap();
    assert!(rows.len() > 50);
    assert!(
        rows.iter().all(|r| !r.is_isolation_failure()),
        "a run failed"
    );
    assert!(!read_histories(&out.join("data/histories.csv"))
        .unwrap()
        .is_empty());
    for table in [
        "robustness",
        "fastest",
        "time_to_accuracy",
        "warm_vs_cold",
        "sor_omega",
    ] {
        let path = out.join(format!("tables/{table}.csv"));
        let mut reader = csv::Reader::from_path(&path).unwrap();
        let width = reader.headers().unwrap().len();
        let n = reader
            .records()
            .map(|r| {
                assert_eq!(r.unwrap().len(), width);
            })
            .count();
        assert!(n > 0, "{table} is empty");
    }
    for plot in ["profile_1e-4", "profile_1e-8", "scaling_lcp", "sor_omega"] {
        let svg = std::fs::read_to_string(out.join(format!("plots/{plot}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") || svg.contains("<svg"), "{plot}");
        assert!(out.join(format!("plots/{plot}.csv")).exists());
        assert!(readme.contains(&format!("plots/{plot}.svg")));
    }
}

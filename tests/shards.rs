//! Sharded sweeps seen from outside: three `bench --shard K/3` processes and `merge` give the
//! rows of the unsharded sweep, and `merge` refuses shards that do not make up one sweep.

use lcpbench::harness::shard::read_manifest;
use lcpbench::harness::sweep::read_results;
use lcpbench::harness::RunRecord;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const EXE: &str = env!("CARGO_BIN_EXE_lcpbench");

/// Three generated LCPs and a five-step scene, three solvers, one budget: twelve runs.
const LCPS: &str = "spd:n=10:cond=1e2:seed=1,psd:n=12:rank=6:seed=2,pmatrix:n=8:seed=3,\
                    scene:bench_scenes/box_on_ground.toml?steps=5";
const SOLVERS: &str = "pgs,lemke,newton-fb";

fn bench(out: &Path, solvers: &str, shard: Option<&str>) -> Command {
    let mut cmd = Command::new(EXE);
    cmd.args(["bench", "--no-progress", "--jobs", "1", "--lcps", LCPS])
        .args(["--solvers", solvers, "--budgets", "default", "--out"])
        .arg(out);
    if let Some(s) = shard {
        cmd.args(["--shard", s]);
    }
    cmd
}

fn succeed(mut cmd: Command) -> Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn merge(dirs: &[&Path], out: &Path) -> Output {
    let mut cmd = Command::new(EXE);
    cmd.arg("merge").args(dirs).arg("--out").arg(out);
    cmd.output().unwrap()
}

/// The message of a refused command (and that it was refused).
fn refused(out: Output) -> String {
    assert!(!out.status.success(), "expected a refusal");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Columns that depend on the machine and the moment: times, the count of timed solves (which
/// depends on them) and the machine itself.
fn is_measured(column: &str) -> bool {
    column.ends_with("time_s")
        || column.starts_with("tta_")
        || column.starts_with("phase_")
        || column == "time_per_step_s"
        || column == "step_time_no_residual_s"
        || column == "solve_wall_max_s"
        || column.starts_with("solve_time_")
        || column == "timed_solves"
        || ["host", "cpu_model", "cores"].contains(&column)
}

/// Each row's key and its deterministic cells (every column but the measured ones).
fn deterministic(rows: &[RunRecord]) -> BTreeMap<String, Vec<(String, String)>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).unwrap();
    }
    let bytes = w.into_inner().unwrap();
    let mut reader = csv::Reader::from_reader(&bytes[..]);
    let header = reader.headers().unwrap().clone();
    let mut out = BTreeMap::new();
    for (r, record) in rows.iter().zip(reader.records()) {
        let cells = header
            .iter()
            .zip(record.unwrap().iter())
            .filter(|(name, _)| !is_measured(name))
            .map(|(name, cell)| (name.to_owned(), cell.to_owned()))
            .collect();
        assert!(
            out.insert(r.key().to_string(), cells).is_none(),
            "repeated {}",
            r.key()
        );
    }
    out
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        if entry.file_type().unwrap().is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
        }
    }
}

#[test]
fn three_shards_merge_into_the_rows_of_the_unsharded_sweep() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = |name: &str| tmp.path().join(name);
    // The three shards run as separate processes, at the same time; the unsharded sweep alone.
    let shards: Vec<PathBuf> = (1..=3).map(|k| dir(&format!("shard{k}"))).collect();
    let children: Vec<_> = shards
        .iter()
        .enumerate()
        .map(|(k, out)| {
            bench(out, SOLVERS, Some(&format!("{}/3", k + 1)))
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for child in children {
        let out = child.wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    succeed(bench(&dir("full"), SOLVERS, None));

    // Each shard says what it is; together they list the twelve runs once.
    let manifests: Vec<_> = shards
        .iter()
        .map(|s| read_manifest(s).unwrap().expect("shard.json"))
        .collect();
    let mut positions: Vec<usize> = manifests
        .iter()
        .flat_map(|m| m.keys.iter().map(|k| k.index))
        .collect();
    positions.sort();
    assert_eq!(positions, (0..12).collect::<Vec<_>>());
    assert!(manifests.iter().all(|m| m.sweep == manifests[0].sweep));
    for (m, s) in manifests.iter().zip(&shards) {
        let rows = read_results(&s.join("results.csv")).unwrap();
        assert_eq!(rows.len(), m.keys.len(), "{}", s.display());
    }

    let merged = dir("merged");
    let shard_refs: Vec<&Path> = shards.iter().map(PathBuf::as_path).collect();
    let out = merge(&shard_refs, &merged);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let merged_rows = read_results(&merged.join("results.csv")).unwrap();
    let full_rows = read_results(&dir("full").join("results.csv")).unwrap();
    assert_eq!(merged_rows.len(), 12);
    assert_eq!(deterministic(&merged_rows), deterministic(&full_rows));
    // The cost columns survive the merge: each merged scene row carries its shard row's cost,
    // the measured step time without the residual phase included.
    let shard_rows: Vec<RunRecord> = shards
        .iter()
        .flat_map(|s| read_results(&s.join("results.csv")).unwrap())
        .collect();
    let cost = |r: &RunRecord| {
        (
            r.substeps_per_step,
            r.row_updates_per_step,
            r.body_passes_per_step,
            r.step_time_no_residual_s,
            r.residual_of.clone(),
        )
    };
    let scene_rows: Vec<&RunRecord> = merged_rows.iter().filter(|r| r.steps.is_some()).collect();
    assert_eq!(scene_rows.len(), 3);
    for r in scene_rows {
        let from = shard_rows.iter().find(|s| s.key() == r.key()).unwrap();
        assert_eq!(cost(r), cost(from), "{}", r.key());
        assert_eq!(r.substeps_per_step, Some(1.0), "{r:?}");
        assert!(
            r.row_updates_per_step.is_some() && r.step_time_no_residual_s.is_some(),
            "{r:?}"
        );
    }
    // Merged rows come in the sweep's order and say where they ran.
    let keys: Vec<String> = merged_rows.iter().map(|r| r.key().to_string()).collect();
    let mut in_order: Vec<(usize, String)> = manifests
        .iter()
        .flat_map(|m| m.keys.iter().map(|k| (k.index, k.key().to_string())))
        .collect();
    in_order.sort();
    assert_eq!(
        keys,
        in_order.into_iter().map(|(_, k)| k).collect::<Vec<_>>()
    );
    for r in &merged_rows {
        let machine = r.machine().expect("machine columns");
        assert!(!machine.host.is_empty() && machine.cores >= 1, "{r:?}");
    }
    let histories = std::fs::read_to_string(merged.join("histories.csv")).unwrap();
    assert!(histories.lines().count() > 1);
    assert!(merged.join("merged.json").exists());

    refusals(tmp.path(), &shards, &merged);
}

/// What `merge` (and `bench` on a shard's directory) refuse.
fn refusals(tmp: &Path, shards: &[PathBuf], merged: &Path) {
    let dir = |name: &str| tmp.join(name);
    let [s1, s2, s3] = [&shards[0], &shards[1], &shards[2]].map(PathBuf::as_path);

    // A shard of another sweep (one solver fewer).
    succeed(bench(&dir("other1"), "pgs,lemke", Some("1/3")));
    let msg = refused(merge(&[&dir("other1"), s2, s3], &dir("m1")));
    assert!(msg.contains("shards of different sweeps"), "{msg}");
    assert!(!dir("m1").exists());

    // A shard given twice, and a missing one.
    let msg = refused(merge(&[s1, s2, s1], &dir("m2")));
    assert!(msg.contains("shard 1/3 is given twice"), "{msg}");
    let msg = refused(merge(&[s1, s3], &dir("m2")));
    assert!(msg.contains("shard(s) 2 of 3 missing"), "{msg}");

    // A run with two different rows; an identical copy is dropped.
    let extra = read_results(&s1.join("results.csv")).unwrap()[0].clone();
    let append = |to: &Path, row: &RunRecord| {
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(to.join("results.csv"))
            .unwrap();
        let mut w = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(file);
        w.serialize(row).unwrap();
        w.flush().unwrap();
    };
    copy_dir(s2, &dir("s2same"));
    append(&dir("s2same"), &extra);
    let out = merge(&[s1, &dir("s2same"), s3], &dir("m3"));
    let msg = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{msg}");
    assert!(msg.contains("1 identical copies dropped"), "{msg}");
    assert_eq!(
        std::fs::read(dir("m3").join("results.csv")).unwrap(),
        std::fs::read(merged.join("results.csv")).unwrap()
    );
    let mut conflicting = extra.clone();
    conflicting.iterations = Some(conflicting.iterations.unwrap_or(0) + 1);
    copy_dir(s2, &dir("s2diff"));
    append(&dir("s2diff"), &conflicting);
    let msg = refused(merge(&[s1, &dir("s2diff"), s3], &dir("m4")));
    assert!(
        msg.contains(&format!("run {} has different rows", extra.key())),
        "{msg}"
    );
    assert!(msg.contains("(columns iterations)"), "{msg}");

    // A shard at another commit.
    copy_dir(s3, &dir("s3later"));
    let mut manifest = read_manifest(&dir("s3later")).unwrap().unwrap();
    manifest.commit = "0000000".into();
    std::fs::remove_file(dir("s3later").join("shard.json")).unwrap();
    manifest.write(&dir("s3later")).unwrap();
    let msg = refused(merge(&[s1, s2, &dir("s3later")], &dir("m5")));
    assert!(msg.contains("different lcpbench commits"), "{msg}");

    // A shard missing a row.
    copy_dir(s3, &dir("s3short"));
    let rows = read_results(&s3.join("results.csv")).unwrap();
    let mut w = csv::Writer::from_path(dir("s3short").join("results.csv")).unwrap();
    for r in &rows[1..] {
        w.serialize(r).unwrap();
    }
    w.flush().unwrap();
    let msg = refused(merge(&[s1, s2, &dir("s3short")], &dir("m6")));
    assert!(msg.contains("1 run(s) of the sweep have no row"), "{msg}");
    assert!(msg.contains("of shard 3/3"), "{msg}");

    // A directory that is not a shard, and an output that is not empty (left as it was).
    let msg = refused(merge(&[s1, s2, &dir("full")], &dir("m7")));
    assert!(msg.contains("has no shard.json"), "{msg}");
    let before = std::fs::read(merged.join("results.csv")).unwrap();
    let msg = refused(merge(&[s1, s2, s3], merged));
    assert!(msg.contains("is not an empty directory"), "{msg}");
    assert_eq!(std::fs::read(merged.join("results.csv")).unwrap(), before);

    // A shard's directory runs only its own shard.
    let msg = refused(bench(s1, SOLVERS, None).output().unwrap());
    assert!(msg.contains("holds shard 1/3"), "{msg}");
    let msg = refused(bench(s1, SOLVERS, Some("2/3")).output().unwrap());
    assert!(msg.contains("this run is shard 2/3"), "{msg}");
}

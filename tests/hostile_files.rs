//! Hostile files and paths: shard counts that would allocate per shard, merge inputs that are
//! links to devices, damaged or torn tables, machine fields with markup, outputs written over
//! inputs, links inside report directories. Each is refused with a message naming the file (and
//! line), or handled within bounded memory, and nothing the user wrote is overwritten.

mod common;

use lcpbench::harness::merge::merge;
use lcpbench::harness::outdir::{check_outputs, read_table};
use lcpbench::harness::record::base_record;
use lcpbench::harness::shard::{read_manifest, Shard, ShardPlan, SweepKind};
use lcpbench::harness::{cross_product, Case, HistoryRow, RunRecord};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const EXE: &str = env!("CARGO_BIN_EXE_lcpbench");

fn lcpbench(args: &[&str]) -> Output {
    Command::new(EXE).args(args).output().unwrap()
}

fn refused(out: Output) -> String {
    assert!(!out.status.success(), "expected a refusal");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The jobs of a small bench sweep: three generated LCPs, two solvers.
fn jobs() -> Vec<lcpbench::harness::Job> {
    let cases: Vec<Case> = (1..=3).map(|seed| Case::spd(6, 1e2, seed)).collect();
    let solvers = ["pgs".parse().unwrap(), "lemke".parse().unwrap()];
    cross_product(&cases, &solvers, &["default".parse().unwrap()])
}

/// Shard `index` of 2 of the sweep of [`jobs`] in `root/part{index}`, as `bench --shard`
/// leaves it: `shard.json`, a row per run and three history points per run.
fn part(root: &Path, index: usize) -> PathBuf {
    let dir = root.join(format!("part{index}"));
    std::fs::create_dir_all(&dir).unwrap();
    let plan = ShardPlan::new(SweepKind::Bench, jobs(), &dir);
    let shard = Shard { index, count: 2 };
    plan.manifest(shard, "abc").write(&dir).unwrap();
    let mut results = csv::Writer::from_path(dir.join("results.csv")).unwrap();
    let mut histories = csv::Writer::from_path(dir.join("histories.csv")).unwrap();
    for (k, job) in plan.jobs(shard).iter().enumerate() {
        let mut row = base_record(&job.case, &job.solver, &job.budget);
        row.iterations = Some(3 + k);
        row.host = Some(format!("node{index}"));
        row.cpu_model = Some("cpu".into());
        results.serialize(&row).unwrap();
        for iteration in 0..3 {
            histories
                .serialize(HistoryRow {
                    case: job.case.to_string(),
                    solver: job.solver.clone(),
                    budget: job.budget.name.clone(),
                    iteration,
                    time_s: 1e-3 * iteration as f64,
                    residual: 0.5f64.powi(iteration as i32),
                })
                .unwrap();
        }
    }
    results.flush().unwrap();
    histories.flush().unwrap();
    dir
}

/// A row's cells as written (so rows compare exactly, NaN included).
fn cells(rows: &[RunRecord]) -> Vec<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).unwrap();
    }
    String::from_utf8(w.into_inner().unwrap())
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect()
}

/// Nothing of a failed merge is left: neither the output nor a staging directory beside it.
fn nothing_left(root: &Path, out: &Path) {
    assert!(!out.exists(), "{} was left", out.display());
    let staging: Vec<_> = std::fs::read_dir(root)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().contains(".merge-"))
        .collect();
    assert!(staging.is_empty(), "{staging:?}");
}

#[test]
fn merge_refuses_a_histories_file_linked_to_a_device_and_leaves_no_output() {
    let root = tempfile::tempdir().unwrap();
    let parts = [part(root.path(), 1), part(root.path(), 2)];
    let histories = parts[1].join("histories.csv");
    std::fs::remove_file(&histories).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &histories).unwrap();
    let out = root.path().join("merged");
    let err = merge(&parts, &out).unwrap_err().to_string();
    assert!(
        err.contains(&histories.display().to_string()) && err.contains("symbolic link"),
        "{err}"
    );
    nothing_left(root.path(), &out);
}

#[test]
fn merge_of_parts_declaring_a_billion_shards_is_refused_without_allocating_for_them() {
    let root = tempfile::tempdir().unwrap();
    let parts = [part(root.path(), 1), part(root.path(), 2)];
    for p in &parts {
        let mut m = read_manifest(p).unwrap().unwrap();
        m.shards = 1_000_000_000;
        m.write(p).unwrap();
    }
    let err = merge(&parts, &root.path().join("m"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("of 1000000000 missing") && err.contains("999999998 in all"),
        "{err}"
    );
}

#[test]
fn merge_refuses_control_characters_in_machine_fields_and_a_torn_history() {
    let root = tempfile::tempdir().unwrap();
    let parts = [part(root.path(), 1), part(root.path(), 2)];
    let results = parts[0].join("results.csv");
    let text = std::fs::read_to_string(&results).unwrap();
    let mut rows = read_table::<RunRecord>(&results).unwrap().rows;
    rows[0].host = Some("node1\n```<img onerror=x>".into());
    let mut w = csv::Writer::from_path(&results).unwrap();
    for r in &rows {
        w.serialize(r).unwrap();
    }
    w.flush().unwrap();
    drop(w);
    let err = merge(&parts, &root.path().join("m"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("column host") && err.contains("control character"),
        "{err}"
    );
    std::fs::write(&results, text).unwrap();
    // A history cut inside its last row: refused, naming the part's file and line.
    let histories = parts[1].join("histories.csv");
    let bytes = std::fs::read(&histories).unwrap();
    std::fs::write(&histories, &bytes[..bytes.len() - 4]).unwrap();
    let err = merge(&parts, &root.path().join("m"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(&histories.display().to_string())
            && err.contains("line 10: the last row was torn"),
        "{err}"
    );
    nothing_left(root.path(), &root.path().join("m"));
}

/// A table: a complete last line that is not a row is an error naming it (and the file is
/// left as it is); a torn row is dropped only when it reads as the start of a row.
#[test]
fn only_the_start_of_a_row_is_dropped_as_torn() {
    let root = tempfile::tempdir().unwrap();
    let parts = [part(root.path(), 1)];
    let path = parts[0].join("results.csv");
    let good = std::fs::read_to_string(&path).unwrap();
    let lines = good.lines().count();
    for junk in ["user note: keep me\n", "user note: keep me", "a,b,c\n"] {
        std::fs::write(&path, format!("{good}{junk}")).unwrap();
        if junk.ends_with('\n') || junk.contains(',') {
            let err = format!("{:#}", read_table::<RunRecord>(&path).unwrap_err());
            assert!(
                err.contains(&format!("line {}", lines + 1)),
                "{junk}: {err}"
            );
        }
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            format!("{good}{junk}")
        );
    }
    // The start of a real row, cut anywhere: torn.
    let last = good.lines().last().unwrap();
    let body: String = good
        .lines()
        .take(lines - 1)
        .map(|l| format!("{l}\n"))
        .collect();
    for cut in [1, 10, last.len() / 2, last.len() - 1] {
        std::fs::write(&path, format!("{body}{}", &last[..cut])).unwrap();
        let table = read_table::<RunRecord>(&path).unwrap();
        assert_eq!(table.torn_at, Some(lines as u64), "cut {cut}");
        assert_eq!(table.rows.len(), lines - 2);
    }
    // A line with too many cells, unfinished: not the start of a row.
    std::fs::write(&path, format!("{good}{last},1,2")).unwrap();
    let err = format!("{:#}", read_table::<RunRecord>(&path).unwrap_err());
    assert!(err.contains("not the start of a row"), "{err}");
}

#[test]
fn outputs_over_inputs_are_refused_by_file_identity() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path();
    let input = dir.join("p.json");
    std::fs::write(&input, "{}").unwrap();
    std::fs::create_dir(dir.join("d")).unwrap();
    std::os::unix::fs::symlink(&input, dir.join("link.json")).unwrap();
    std::fs::hard_link(&input, dir.join("hard.json")).unwrap();
    let inputs = [("the input", input.as_path())];
    for same in [
        input.clone(),
        dir.join("d/../p.json"),
        dir.join("link.json"),
        dir.join("hard.json"),
    ] {
        let err = check_outputs(&inputs, &[("--output", &same)]).unwrap_err();
        assert!(err.to_string().contains("same file as the input"), "{err}");
    }
    check_outputs(&inputs, &[("--output", &dir.join("d/q.json"))]).unwrap();
    // Two outputs, not yet written, named differently but the same.
    let err = check_outputs(
        &inputs,
        &[
            ("--record", &dir.join("x")),
            ("--html", &dir.join("d/../x")),
        ],
    )
    .unwrap_err();
    assert!(err.to_string().contains("are the same file"), "{err}");

    // Through the command line, the inputs are left as they were.
    let scene = dir.join("s.toml");
    std::fs::copy("bench_scenes/box_on_ground.toml", &scene).unwrap();
    let before = std::fs::read(&scene).unwrap();
    let s = scene.to_str().unwrap();
    let linked = dir.join("linked.toml");
    std::os::unix::fs::symlink(&scene, &linked).unwrap();
    let l = linked.to_str().unwrap();
    for args in [
        vec!["export", s, "-o", s],
        vec!["export", s, "-o", l],
        vec!["simulate", s, "--steps", "1", "--record", s],
        vec!["import", s, "-o", l],
    ] {
        let err = refused(lcpbench(&args));
        assert!(err.contains("same file"), "{args:?}: {err}");
    }
    let x = dir.join("x.out");
    let x = x.to_str().unwrap();
    let err = refused(lcpbench(&[
        "simulate", s, "--steps", "1", "--record", x, "--html", x,
    ]));
    assert!(err.contains("are the same file"), "{err}");
    let rec = dir.join("r.jsonl");
    let r = rec.to_str().unwrap();
    let ok = lcpbench(&["simulate", s, "--steps", "2", "--record", r]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let recorded = std::fs::read(&rec).unwrap();
    let err = refused(lcpbench(&["view", r, "-o", r]));
    assert!(err.contains("same file"), "{err}");
    assert_eq!(std::fs::read(&rec).unwrap(), recorded);
    assert_eq!(std::fs::read(&scene).unwrap(), before);
}

#[test]
fn report_refuses_links_inside_its_directory() {
    let root = tempfile::tempdir().unwrap();
    let elsewhere = root.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("keep.csv"), "mine").unwrap();
    for (sub, extra) in [
        ("plots", vec![]),
        ("tables", vec![]),
        ("data", vec!["--shard", "1/2"]),
    ] {
        let out = root.path().join(format!("r_{sub}"));
        std::fs::create_dir(&out).unwrap();
        std::os::unix::fs::symlink(&elsewhere, out.join(sub)).unwrap();
        let mut args = vec![
            "report",
            "--quick",
            "--no-progress",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let err = refused(lcpbench(&args));
        assert!(err.contains("symbolic link") && err.contains(sub), "{err}");
    }
    let left: Vec<_> = std::fs::read_dir(&elsewhere).unwrap().flatten().collect();
    assert_eq!(left.len(), 1);
}

#[test]
fn a_shard_count_of_u64_max_runs_in_the_memory_of_the_sweep() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("s");
    let shard = format!("2/{}", u64::MAX);
    let run = lcpbench(&[
        "bench",
        "--no-progress",
        "--jobs",
        "1",
        "--lcps",
        "spd:n=6:cond=1e2:seed=1",
        "--solvers",
        "pgs",
        "--budgets",
        "default",
        "--shard",
        &shard,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let m = read_manifest(&out).unwrap().unwrap();
    assert_eq!((m.shard, m.shards, m.keys.len()), (2, usize::MAX, 0));
}

/// Ways to damage a part.
#[derive(Debug, Clone)]
enum Damage {
    /// Cut a table to this fraction of its bytes.
    Truncate { histories: bool, keep: f64 },
    /// Set a byte (not a newline) of a table to 0xFF.
    Flip { histories: bool, at: f64 },
    /// Append a line that is not a row.
    Junk { histories: bool, newline: bool },
    /// Repeat a row of `results.csv` (an identical copy, which merge drops).
    Duplicate { at: f64 },
    /// Break `shard.json`: cut it, or give it a huge shard count.
    Manifest { cut: bool },
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        (any::<bool>(), 0.0..1.0f64)
            .prop_map(|(histories, keep)| Damage::Truncate { histories, keep }),
        (any::<bool>(), 0.0..1.0f64).prop_map(|(histories, at)| Damage::Flip { histories, at }),
        (any::<bool>(), any::<bool>())
            .prop_map(|(histories, newline)| Damage::Junk { histories, newline }),
        (0.0..1.0f64).prop_map(|at| Damage::Duplicate { at }),
        any::<bool>().prop_map(|cut| Damage::Manifest { cut }),
    ]
}

fn apply(dir: &Path, d: &Damage) {
    let table = |histories: bool| {
        dir.join(if histories {
            "histories.csv"
        } else {
            "results.csv"
        })
    };
    match *d {
        Damage::Truncate { histories, keep } => {
            let p = table(histories);
            let bytes = std::fs::read(&p).unwrap();
            let n = ((bytes.len() as f64 * keep) as usize).min(bytes.len() - 1);
            std::fs::write(&p, &bytes[..n]).unwrap();
        }
        Damage::Flip { histories, at } => {
            let p = table(histories);
            let mut bytes = std::fs::read(&p).unwrap();
            let mut i = (bytes.len() as f64 * at) as usize % bytes.len();
            while bytes[i] == b'\n' {
                i = (i + 1) % bytes.len();
            }
            bytes[i] = 0xFF;
            std::fs::write(&p, bytes).unwrap();
        }
        Damage::Junk { histories, newline } => {
            let p = table(histories);
            let mut text = std::fs::read_to_string(&p).unwrap();
            text.push_str(if newline {
                "user note: keep me\n"
            } else {
                "1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17,18,19,20,21,22,23,24,25,26,27,28"
            });
            std::fs::write(&p, text).unwrap();
        }
        Damage::Duplicate { at } => {
            let p = table(false);
            let text = std::fs::read_to_string(&p).unwrap();
            let lines: Vec<&str> = text.lines().collect();
            let i = 1 + (at * (lines.len() - 1) as f64) as usize % (lines.len() - 1);
            let mut out: Vec<&str> = lines.clone();
            out.push(lines[i]);
            std::fs::write(&p, out.join("\n") + "\n").unwrap();
        }
        Damage::Manifest { cut } => {
            let p = dir.join("shard.json");
            if cut {
                let bytes = std::fs::read(&p).unwrap();
                std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
            } else {
                let mut m = read_manifest(dir).unwrap().unwrap();
                m.shards = 1_000_000_000;
                m.write(dir).unwrap();
            }
        }
    }
}

proptest! {
    #![proptest_config(common::config(24))]

    /// `merge` of randomly damaged parts either refuses, naming the damaged part (and, for a
    /// damaged line of a table, the line), or returns exactly the rows of the undamaged parts;
    /// a refusal leaves no output behind.
    #[test]
    fn merge_of_damaged_parts_refuses_or_gives_the_undamaged_rows(
        which in 0..2usize,
        d in damage(),
    ) {
        let root = tempfile::tempdir().unwrap();
        let parts = [part(root.path(), 1), part(root.path(), 2)];
        let clean = root.path().join("clean");
        merge(&parts, &clean).unwrap();
        let expected = cells(&read_table::<RunRecord>(&clean.join("results.csv")).unwrap().rows);
        apply(&parts[which], &d);
        let out = root.path().join("merged");
        match merge(&parts, &out) {
            Ok(_) => {
                let got = read_table::<RunRecord>(&out.join("results.csv")).unwrap();
                prop_assert_eq!(cells(&got.rows), expected);
                prop_assert!(got.torn_at.is_none());
                // Identical copies are dropped; a history cut exactly at a line boundary reads
                // as a shorter history (no file says how many points a run has).
                prop_assert!(
                    matches!(d, Damage::Duplicate { .. } | Damage::Truncate { histories: true, .. }),
                    "{:?} was merged", d
                );
            }
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(
                    msg.contains(&parts[which].display().to_string()),
                    "{:?}: {}", d, msg
                );
                let line_damage = matches!(d, Damage::Flip { .. } | Damage::Junk { .. });
                prop_assert!(!line_damage || msg.contains("line "), "{:?}: {}", d, msg);
                nothing_left(root.path(), &out);
            }
        }
    }
}

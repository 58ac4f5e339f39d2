//! Hostile files and flags, seen from the command line: each input that used to crash, hang,
//! destroy a file or be accepted as nonsense now ends with one clear message, a bounded run or a
//! refusal, and never with a panic.

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn lcpbench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lcpbench"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_owned()
}

/// A refusal: exit status 1, a last line `error: …` naming what is wrong, no panic.
#[track_caller]
fn assert_refused(o: &Output, wanted: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "expected a refusal, got:\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    let last = err.lines().last().unwrap_or_default();
    assert!(last.starts_with("error: "), "{err}");
    for w in wanted {
        assert!(last.contains(w), "`{w}` missing from:\n{err}");
    }
}

const SMALL_PROBLEM: &str = r#"{"A": [[2, 1], [1, 2]], "b": [-1, 1]}"#;

const BOX_SCENE: &str = r#"
[settings]
steps = 3

[[bodies]]
name = "ground"
shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
static = true

[[bodies]]
name = "box"
shape = { type = "box", half_extents = [0.5, 0.5, 0.5] }
position = [0.0, 0.0, 0.5]
"#;

/// A command whose standard output is a pipe nobody reads (as `lcpbench … | head -1` once
/// `head` has its line) ends at the first write, quietly, killed by `SIGPIPE` as `cat` would
/// be, instead of panicking on the `EPIPE` error.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_printing_commands_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let problem = write(dir.path(), "p.json", SMALL_PROBLEM);
    let scene = write(dir.path(), "s.toml", BOX_SCENE);
    let commands: [&[&str]; 5] = [
        &["solvers"],
        &["solve", &problem, "-s", "pgs"],
        &["solve", &problem, "-s", "pgs", "--json"],
        &["simulate", &scene],
        &["simulate", &scene, "--json"],
    ];
    for args in commands {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let o = Command::new(env!("CARGO_BIN_EXE_lcpbench"))
            .args(args)
            .stdout(writer)
            .output()
            .unwrap();
        let err = stderr(&o);
        assert!(err.is_empty(), "{args:?}: {err}");
        assert_eq!(o.status.signal(), Some(libc::SIGPIPE), "{args:?}");
    }
}

/// `bench --jobs` is a thread count this machine can run: 0 and 100,000 are refused with the
/// range, before anything is written.
#[test]
fn bench_refuses_worker_counts_the_machine_cannot_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    for jobs in ["0", "100000"] {
        let o = lcpbench(&[
            "bench",
            "--lcps",
            "spd:n=5:cond=10:seed=1",
            "--solvers",
            "pgs",
            "--jobs",
            jobs,
            "--out",
            out,
            "--no-progress",
        ]);
        assert_refused(
            &o,
            &["--jobs must be between 1 and", &format!("got {jobs}")],
        );
        assert!(
            !Path::new(out).exists(),
            "nothing is written for --jobs {jobs}"
        );
    }
}

/// `--max-iter` is a total for the solve: 2,000 one-row islands that each run to Newton's
/// stall window once took 50 iterations apiece, 100,000 in all for `--max-iter 100`.
#[test]
fn max_iter_bounds_the_whole_solve_not_each_island() {
    let dir = tempfile::tempdir().unwrap();
    let n = 2000;
    let triplets: Vec<Value> = (0..n).map(|i| serde_json::json!([i, i, 0.0])).collect();
    let problem = serde_json::json!({
        "A": {"n": n, "triplets": triplets},
        "b": vec![-1.0; n],
    });
    let file = write(dir.path(), "diag0.json", &problem.to_string());
    let o = lcpbench(&[
        "solve",
        &file,
        "-s",
        "newton-fb",
        "--max-iter",
        "100",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let iterations = v["iterations"].as_u64().unwrap();
    assert!(
        iterations <= 100,
        "{iterations} iterations for --max-iter 100"
    );
    assert_ne!(v["status"], "converged", "{v}");
}

/// Budgets of a picosecond and condition numbers beyond round-off are refused with the limit.
#[test]
fn budgets_and_condition_numbers_beyond_their_limits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let problem = write(dir.path(), "p.json", SMALL_PROBLEM);
    let scene = write(dir.path(), "s.toml", BOX_SCENE);
    let o = lcpbench(&["solve", &problem, "-s", "pgs", "--time-budget", "1e-300"]);
    assert_refused(&o, &["--time-budget", "below the minimum of 1e-6 s"]);
    let o = lcpbench(&["simulate", &scene, "--time-budget", "1e-300"]);
    assert_refused(&o, &["--time-budget", "below the minimum of 1e-6 s"]);
    for args in [
        &["solve", &problem, "-s", "pgs", "--tol", "1e-300"][..],
        &["simulate", &scene, "--tol", "1e-300"],
    ] {
        let o = lcpbench(args);
        assert_refused(&o, &["--tol", "1e-300 is below 1e-14"]);
    }
    let out = dir.path().join("b");
    let o = lcpbench(&[
        "bench",
        "--lcps",
        "spd:n=5:cond=10:seed=1",
        "--solvers",
        "pgs",
        "--budgets",
        "1e-8:100:1e-300",
        "--out",
        out.to_str().unwrap(),
        "--no-progress",
    ]);
    assert_refused(&o, &["below the minimum of 1e-6 s"]);
    let g = dir.path().join("g.json");
    let o = lcpbench(&[
        "gen",
        "spd",
        "--n",
        "10",
        "--cond",
        "1e300",
        "-o",
        g.to_str().unwrap(),
    ]);
    assert_refused(&o, &["--cond must be between 1 and 1e12", "got 1e300"]);
    assert!(!g.exists());
    let o = lcpbench(&[
        "bench",
        "--lcps",
        "spd:n=5:cond=1e300:seed=1",
        "--solvers",
        "pgs",
        "--out",
        out.to_str().unwrap(),
        "--no-progress",
    ]);
    assert_refused(&o, &["cond = 1e300 must be between 1 and 1e12"]);
}

/// A face of a box: origin, the two edge vectors, and whether `u × v` points inward.
type Face = ([f64; 3], [f64; 3], [f64; 3], bool);

/// A closed 1 × 1 × 0.2 slab as Wavefront OBJ text, every face a `k × k` grid of triangles.
fn grid_slab_obj(k: usize) -> String {
    let mut index = std::collections::HashMap::new();
    let (mut vertices, mut faces) = (String::new(), String::new());
    let mut vertex = |p: [f64; 3]| -> usize {
        let key = p.map(|x| (x * 1e6).round() as i64);
        let next = index.len() + 1;
        *index.entry(key).or_insert_with(|| {
            vertices.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
            next
        })
    };
    let h = 0.2;
    let sides: [Face; 6] = [
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], true),
        ([0.0, 0.0, h], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], false),
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, h], false),
        ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, h], true),
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, h], true),
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, h], false),
    ];
    for (o, u, v, flip) in sides {
        let at = |i: usize, j: usize| {
            let (a, b) = (i as f64 / k as f64, j as f64 / k as f64);
            [0, 1, 2].map(|c| o[c] + a * u[c] + b * v[c])
        };
        for i in 0..k {
            for j in 0..k {
                let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)].map(&mut vertex);
                let (t1, t2) = if flip {
                    ([q[0], q[2], q[1]], [q[0], q[3], q[2]])
                } else {
                    ([q[0], q[1], q[2]], [q[0], q[2], q[3]])
                };
                for t in [t1, t2] {
                    faces.push_str(&format!("f {} {} {}\n", t[0], t[1], t[2]));
                }
            }
        }
    }
    vertices + &faces
}

/// Scenes that used to abort the process (a dense 7.5 GB Delassus matrix, 3.8 GB of narrow
/// phase) or read a device end with one message naming the limit.
#[test]
fn scenes_past_the_memory_limits_end_with_one_message() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "meshes/slab.obj", &grid_slab_obj(100));
    let slab = write(
        dir.path(),
        "slab.toml",
        &format!(
            "{}[[bodies]]\nname = \"slab\"\nshape = {{ type = \"mesh\", file = \"meshes/slab.obj\" }}\n\
             position = [0.0, 0.0, 0.1]\n",
            BOX_SCENE.split("[[bodies]]\nname = \"box\"").next().unwrap()
        ),
    );
    let o = lcpbench(&["simulate", &slab]);
    assert_refused(
        &o,
        &[
            "slab.toml: step 0",
            "Delassus matrix would store",
            "beyond the limit of 50000000",
            "\"slab\"",
        ],
    );
    let o = lcpbench(&[
        "export",
        &slab,
        "-o",
        dir.path().join("x.json").to_str().unwrap(),
    ]);
    assert_refused(&o, &["step 0 has no problem to export", "Delassus matrix"]);
    let piled = write(
        dir.path(),
        "piled.toml",
        "[[bodies]]\nname = \"s\"\nshape = { type = \"sphere\", radius = 0.1 }\n\
         repeat = { count = [9999, 1, 1], spacing = [0.0, 0.0, 0.0] }\n",
    );
    let o = lcpbench(&["simulate", &piled]);
    assert_refused(
        &o,
        &["piled.toml: bodies: at the start, more than 500000 pairs of bodies"],
    );
    let device = write(
        dir.path(),
        "device.toml",
        "[[bodies]]\nname = \"m\"\nshape = { type = \"mesh\", file = \"/dev/zero\" }\n",
    );
    let o = lcpbench(&["simulate", &device]);
    assert_refused(&o, &["bodies[0] (\"m\").shape.file", "is an absolute path"]);
    let o = lcpbench(&["simulate", &device, "--allow-outside-paths"]);
    assert_refused(&o, &["/dev/zero", "a device"]);
    let o = lcpbench(&["simulate", "/dev/zero"]);
    assert_refused(&o, &["/dev/zero", "a device"]);
}

/// A sweep into `out` of two quick LCP runs; the command's output.
fn quick_sweep(out: &Path) -> Output {
    lcpbench(&[
        "bench",
        "--lcps",
        "spd:n=5:cond=10:seed=1,spd:n=6:cond=10:seed=2",
        "--solvers",
        "pgs,lemke",
        "--out",
        out.to_str().unwrap(),
        "--no-progress",
    ])
}

/// Tables in an output directory that lcpbench did not write, or that another version wrote,
/// are refused before anything changes, and left byte for byte as they were (they used to be
/// replaced, "torn or repeated").
#[test]
fn a_sweep_never_overwrites_a_table_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("real");
    assert!(quick_sweep(&real).status.success());
    let text = std::fs::read_to_string(real.join("results.csv")).unwrap();
    let (header, rows) = text.split_once('\n').unwrap();
    let foreign = "name,score\nalice,10\nbob,12\n".to_owned();
    let renamed = format!("{}\n{rows}", header.replacen("case,", "kase,", 1));
    let cut = |line: &str| {
        let cells: Vec<&str> = line.split(',').collect();
        cells[..cells.len() - 3].join(",")
    };
    let older: String = text.lines().map(|l| cut(l) + "\n").collect();
    for (name, file, contents, wanted) in [
        (
            "foreign",
            "results.csv",
            &foreign,
            "is not a table lcpbench wrote",
        ),
        (
            "renamed",
            "results.csv",
            &renamed,
            "is not a table lcpbench wrote",
        ),
        (
            "older",
            "results.csv",
            &older,
            "written by an older lcpbench",
        ),
        (
            "histories",
            "histories.csv",
            &"my,precious,data\n1,2,3\n".to_owned(),
            "is not a table lcpbench wrote",
        ),
    ] {
        let out = dir.path().join(name);
        write(&out, file, contents);
        let o = quick_sweep(&out);
        assert_refused(&o, &[&format!("{name}/{file}"), wanted]);
        let now = std::fs::read_to_string(out.join(file)).unwrap();
        assert_eq!(&now, contents, "{name}: the file changed");
        assert!(!out.join("results.csv").exists() || file == "results.csv");
    }
    // An older table is still lcpbench's: the report reads it (new columns empty).
    let rows = lcpbench::harness::sweep::read_results(&dir.path().join("older/results.csv"));
    assert_eq!(rows.unwrap().len(), 4);
    // A fresh report does not remove another program's file either.
    let report = dir.path().join("report");
    write(&report, "data/results.csv", &foreign);
    let o = lcpbench(&[
        "report",
        "--quick",
        "--out",
        report.to_str().unwrap(),
        "--scenes",
        "no/such/*.toml",
        "--no-progress",
    ]);
    assert_refused(&o, &["data/results.csv", "is not a table lcpbench wrote"]);
    assert_eq!(
        std::fs::read_to_string(report.join("data/results.csv")).unwrap(),
        foreign
    );
}

/// A report writes `README.md`, `tables/`, `plots/` and `replays/` in its output directory: it
/// refuses a directory whose README is not a report's, or whose `plots/` holds files when the
/// directory has no report of lcpbench's, and changes nothing there.
#[test]
fn a_report_never_overwrites_a_readme_or_figures_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let report = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "report",
            "--quick",
            "--no-progress",
            "--out",
            out.to_str().unwrap(),
            "--scenes",
            "no/such/*.toml",
        ];
        args.extend_from_slice(extra);
        lcpbench(&args)
    };
    let project = dir.path().join("project");
    let readme = "# My project\n\nNotes that took a week.\n";
    write(&project, "README.md", readme);
    for extra in [&[][..], &["--no-run"][..]] {
        let o = report(&project, extra);
        assert_refused(&o, &["README.md", "is not a report lcpbench wrote"]);
        assert_eq!(
            std::fs::read_to_string(project.join("README.md")).unwrap(),
            readme
        );
    }
    let figures = dir.path().join("figures");
    write(&figures, "plots/profile_1e-4.svg", "<svg>mine</svg>");
    let o = report(&figures, &[]);
    assert_refused(&o, &["plots", "holds no lcpbench report"]);
    assert_eq!(
        std::fs::read_to_string(figures.join("plots/profile_1e-4.svg")).unwrap(),
        "<svg>mine</svg>"
    );
    assert!(!figures.join("data").exists());
}

/// An unterminated quote in the middle of `results.csv` once dropped every row after it (144
/// of 4,057); resuming and `report --no-run` now refuse with its line and change nothing.
#[test]
fn a_damaged_results_table_is_refused_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    assert!(quick_sweep(&out).status.success());
    let path = out.join("results.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    assert_eq!(lines.len(), 5);
    lines[2] = lines[2].replacen(",spd,", ",\"spd,", 1);
    let damaged = lines.join("\n") + "\n";
    std::fs::write(&path, &damaged).unwrap();
    let o = quick_sweep(&out);
    assert_refused(&o, &["results.csv: line 3:", "damaged"]);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), damaged);
    let e = lcpbench::harness::sweep::read_results(&path).unwrap_err();
    assert!(format!("{e:#}").contains("line 3"), "{e:#}");
    // The report reads its data with the same reader.
    let report = dir.path().join("report");
    write(&report, "data/results.csv", &damaged);
    let o = lcpbench(&[
        "report",
        "--no-run",
        "--out",
        report.to_str().unwrap(),
        "--scenes",
        "no/such/*.toml",
    ]);
    assert_refused(&o, &["results.csv: line 3:"]);
}

/// The lock file is never followed through a symbolic link (a sweep wrote its process id into
/// the link's target).
#[cfg(unix)]
#[test]
fn the_lock_is_never_taken_through_a_symbolic_link() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("precious.txt");
    std::fs::write(&target, "keep me\n").unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::os::unix::fs::symlink(&target, out.join(".lcpbench.lock")).unwrap();
    let o = quick_sweep(&out);
    assert_refused(&o, &[".lcpbench.lock is a symbolic link"]);
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep me\n");
    assert!(!out.join("results.csv").exists());
}

/// The text of a page's data element, as an HTML parser delimits it: up to the first `</script`.
fn data_element(html: &str) -> &str {
    let open = "<script id=\"lcpbench-data\" type=\"application/json\">";
    let start = html.find(open).expect("a data element") + open.len();
    let len = html[start..].to_ascii_lowercase().find("</script").unwrap();
    &html[start..start + len]
}

/// Names with `<!--<script>` put the HTML parser in its double-escaped script state (no canvas,
/// no plots); names with `{{DATA}}` were replaced by the page's data. Now no name changes how
/// the page parses, and the data reads back the same names.
#[test]
fn names_cannot_change_how_a_page_parses() {
    let dir = tempfile::tempdir().unwrap();
    let hostile = "<!--<script>{{DATA}}</script>&amp;";
    let scene = write(
        dir.path(),
        "s.toml",
        &format!(
            "name = {:?}\n{}",
            hostile,
            BOX_SCENE.replace("name = \"box\"", &format!("name = {hostile:?}"))
        ),
    );
    let page = dir.path().join("replay.html");
    let o = lcpbench(&["simulate", &scene, "--html", page.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let problem = write(
        dir.path(),
        "p.json",
        &serde_json::json!({"name": hostile, "A": [[2.0, 1.0], [1.0, 2.0]], "b": [-1.0, 1.0]})
            .to_string(),
    );
    let solve_page = dir.path().join("problem.html");
    let o = lcpbench(&["view", &problem, "-o", solve_page.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The scripts of each page: its own, the data, the vendored libraries and the app.
    for (page, scripts) in [(page, 5), (solve_page, 4)] {
        let html = std::fs::read_to_string(&page).unwrap();
        let data = data_element(&html);
        for opener in ["<!--", "<script", "</script"] {
            assert!(!data.contains(opener), "{opener} in the data of {page:?}");
        }
        let value: Value = serde_json::from_str(data).expect("the data element is whole JSON");
        assert!(value
            .to_string()
            .contains("<!--<script>{{DATA}}</script>&amp;"));
        let title = &html[html.find("<title>").unwrap()..html.find("</title>").unwrap()];
        assert!(title.contains("&lt;!--&lt;script&gt;{{DATA}}"), "{title}");
        assert_eq!(html.matches("<script").count(), scripts, "{page:?}");
    }
}

/// Recordings are checked against their header, and the page against its size bound.
#[test]
fn recordings_that_do_not_fit_their_header_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let header = |extra: &str, bodies: &str| {
        format!(
            r#"{{"recording": {{"version": 1, "scene": "s", "solver": "pgs", "dt": 0.01, "tolerance": 1e-6, "gravity": [0, 0, -9.81], "bodies": [{bodies}]{extra}}}}}"#
        )
    };
    let ball = r#"{"name": "ball", "static": false, "shape": {"type": "sphere", "radius": 0.1}}"#;
    let step = |body: &str, contact: &str| {
        format!(
            r#"{{"step": 0, "time": 0.01, "status": {{"status": "converged"}}, "iterations": 1, "solve_time_s": 0.0, "max_penetration": 0.0, "kinetic_energy": 0.0, "potential_energy": 0.0, "contact_records": [{contact}], "bodies": [{{"name": "{body}", "position": [0, 0, 1], "orientation": [1, 0, 0, 0]}}]}}"#
        )
    };
    let good = format!("{}\n{}\n", header("", ball), step("ball", ""));
    let many: Vec<String> = (0..20_001)
        .map(|i| ball.replace("\"ball\"", &format!("\"b{i}\"")))
        .collect();
    let ghost_contact = r#"{"bodies": ["ghost", "ball"], "point": [0, 0, 0], "normal": [0, 0, 1], "dist": 0, "impulse": [0, 0, 0]}"#;
    let cases = [
        (
            "negative radius",
            good.replace("\"radius\": 0.1", "\"radius\": -1"),
            "line 1: bodies[0] (\"ball\").shape: `radius` must be positive",
        ),
        (
            "dt",
            good.replace("\"dt\": 0.01", "\"dt\": -1"),
            "line 1: dt: must be between 1e-6 and 0.1 s, got -1",
        ),
        (
            "version",
            good.replace("\"version\": 1", "\"version\": 99"),
            "line 1: recording version 99 is unknown",
        ),
        (
            "ghost body",
            format!("{}\n{}\n", header("", ball), step("ghost", "")),
            "line 2: step 0: body \"ghost\" is not in the header",
        ),
        (
            "ghost contact",
            format!("{}\n{}\n", header("", ball), step("ball", ghost_contact)),
            "line 2: step 0: a contact names body \"ghost\"",
        ),
        (
            "joint anchor not a number",
            format!("{}\n{}\n", header("", ball), step("ball", "")).replace(
                "\"contact_records\": []",
                r#""contact_records": [], "joint_records": [{"name": "j", "kind": "ball", "anchors": [[0, 0, 1], [0, null, 1]], "error": {"linear": 0, "angular": 0}, "impulse": 0}]"#,
            ),
            "line 2: step 0: joint_records[0] (\"j\"): anchors[1] must be 3 finite numbers",
        ),
        (
            "20,001 bodies",
            format!("{}\n{}\n", header("", &many.join(", ")), step("b0", "")),
            "line 1: bodies: 20001 bodies, beyond the limit of 20000",
        ),
    ];
    for (name, text, wanted) in cases {
        let rec = write(dir.path(), "r.jsonl", &text);
        let page = dir.path().join("r.html");
        let o = lcpbench(&["view", &rec, "-o", page.to_str().unwrap()]);
        assert_refused(&o, &["r.jsonl: ", wanted]);
        assert!(!page.exists(), "{name}: a page was written");
    }
    // --max-bytes is honoured, or refused when no page can meet it.
    let rec = write(dir.path(), "r.jsonl", &good);
    let page = dir.path().join("r.html");
    for bound in ["0", "1000"] {
        let o = lcpbench(&[
            "view",
            &rec,
            "-o",
            page.to_str().unwrap(),
            "--max-bytes",
            bound,
        ]);
        assert_refused(
            &o,
            &["--max-bytes must be at least", &format!("got {bound}")],
        );
    }
    let scene = write(dir.path(), "s.toml", BOX_SCENE);
    let o = lcpbench(&[
        "simulate",
        &scene,
        "--html",
        page.to_str().unwrap(),
        "--max-bytes",
        "0",
    ]);
    assert_refused(&o, &["--max-bytes must be at least"]);
    let o = lcpbench(&["view", &rec, "-o", page.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// `view` of a problem runs every solver: `--time-budget` bounds them all together.
#[test]
fn a_problem_page_keeps_to_its_time_budget() {
    let dir = tempfile::tempdir().unwrap();
    let problem = write(dir.path(), "p.json", SMALL_PROBLEM);
    let page = dir.path().join("p.html");
    let o = lcpbench(&[
        "view",
        &problem,
        "-o",
        page.to_str().unwrap(),
        "--time-budget",
        "1e-300",
    ]);
    assert_refused(&o, &["--time-budget", "below the minimum"]);
    // Murty's problem takes Lemke 2^n pivots: n = 40 never ends without a budget.
    let g = dir.path().join("murty.json");
    let o = lcpbench(&["gen", "murty", "--n", "40", "-o", g.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let start = std::time::Instant::now();
    let o = lcpbench(&[
        "view",
        g.to_str().unwrap(),
        "-o",
        page.to_str().unwrap(),
        "--max-iter",
        "1000000000000",
        "--time-budget",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let elapsed = start.elapsed().as_secs_f64();
    assert!(elapsed < 20.0, "view took {elapsed:.1} s for a 2 s budget");
    let html = std::fs::read_to_string(&page).unwrap();
    let data: Value = serde_json::from_str(data_element(&html)).unwrap();
    let total: f64 = data["solvers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["time_s"].as_f64().unwrap())
        .sum();
    assert!(total < 4.0, "the solvers took {total:.2} s of a 2 s budget");
}

/// `import` takes a time budget for reading its input, validated like the others.
#[test]
fn import_keeps_to_its_time_budget() {
    let dir = tempfile::tempdir().unwrap();
    let n = 20_000;
    let triplets: Vec<Value> = (0..n).map(|i| serde_json::json!([i, i, 1.0])).collect();
    let problem = serde_json::json!({"A": {"n": n, "triplets": triplets}, "b": vec![-1.0; n]});
    let input = write(dir.path(), "big.json", &problem.to_string());
    let output = dir.path().join("out.json");
    let out = output.to_str().unwrap();
    let o = lcpbench(&["import", &input, "-o", out, "--time-budget", "1e-300"]);
    assert_refused(&o, &["--time-budget", "below the minimum"]);
    let o = lcpbench(&["import", &input, "-o", out, "--time-budget", "1e-6"]);
    assert_refused(
        &o,
        &["big.json: reading it took longer than the time budget"],
    );
    assert!(!output.exists());
    let o = lcpbench(&["import", &input, "-o", out, "--time-budget", "600"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(output.exists());
}

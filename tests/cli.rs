//! The command line seen from outside: `solve`, `solvers`, `gen`, and clear errors.

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
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_owned()
}

#[test]
fn solvers_lists_every_solver() {
    let o = lcpbench(&["solvers"]);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    for name in lcpbench::registry::entries().iter().map(|e| e.name) {
        assert!(
            text.lines().any(|l| l.starts_with(name)),
            "{name} missing from:\n{text}"
        );
    }
}

#[test]
fn solvers_names_each_solver_level() {
    let o = lcpbench(&["solvers"]);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    let level = |name: &str| {
        text.lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>())
            .find(|w| w.first() == Some(&name))
            .and_then(|w| w.get(1).map(|s| s.to_string()))
    };
    for (name, want) in [
        ("pgs", "matrix"),
        ("lemke", "matrix"),
        ("si", "body"),
        ("body-micro", "body"),
        ("penalty", "body"),
        ("avg", "body"),
        ("pgs-ngs", "body"),
        ("jacobi", "body"),
        ("nsgs-cone", "cone"),
        ("newton-fb-cone", "cone"),
        ("newton-nm-cone", "cone"),
        ("clarabel-socp", "cone"),
    ] {
        assert_eq!(level(name).as_deref(), Some(want), "{name} in:\n{text}");
    }
}

#[test]
fn gen_then_solve_json_with_every_solver() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("spd.json");
    let file = file.to_str().unwrap();
    let o = lcpbench(&[
        "gen", "spd", "--n", "20", "--seed", "3", "--cond", "100", "-o", file,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Every matrix solver of the registry but enumeration (2^20 bases at n = 20).
    for kind in lcpbench_solvers::SolverKind::all() {
        let solver = kind.name();
        if solver == "enum" {
            continue;
        }
        let o = lcpbench(&["solve", file, "--solver", solver, "--json"]);
        assert!(o.status.success(), "{solver}: {}", stderr(&o));
        let v: Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
        assert_eq!(v["solver"], solver);
        for key in [
            "status",
            "iterations",
            "time_s",
            "f",
            "w",
            "residual",
            "residual_rel",
        ] {
            assert!(!v[key].is_null(), "{solver}: `{key}` missing in {v}");
        }
        assert_eq!(v["f"].as_array().unwrap().len(), 20);
        if solver != "micro" {
            assert_eq!(v["status"], "converged", "{solver}: {v}");
            assert!(v["residual_rel"].as_f64().unwrap() <= 1e-8);
        }
    }
}

#[test]
fn solve_prints_a_human_summary_and_honours_omega() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "p.json",
        r#"{"A": [[2, 1], [1, 2]], "b": [-1, 1]}"#,
    );
    let o = lcpbench(&["solve", &file, "--solver", "sor", "--omega", "1.5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("status      converged"), "{text}");
    let o = lcpbench(&["solve", &file, "--solver", "pgs", "--omega", "1.5"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--omega applies only to --solver sor"));
}

#[test]
fn infeasible_problem_completes_with_no_solution() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("inf.json");
    let file = file.to_str().unwrap();
    assert!(lcpbench(&["gen", "infeasible", "--n", "8", "-o", file])
        .status
        .success());
    let o = lcpbench(&["solve", file, "--solver", "lemke", "--json"]);
    assert!(
        o.status.success(),
        "a completed run exits 0 whatever its status"
    );
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "no_solution");
}

/// The issue's example: apgd's impulse grows along `z = (1, 1)` until the relative residual
/// meets `1e-8`. `solve` reports `no_solution` with the Farkas certificate read off it, checked
/// here from the data: `y >= 0`, `Aᵀ y = 0` (exactly: equal entries), `bᵀ y < 0`. On a random
/// problem without a solution the iterative solvers' answers at `1e-4` are `diverged`, with a
/// certificate that bounds the size of any solution: checked here too.
#[test]
fn solve_prints_the_certificate_of_a_diverging_impulse() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "inf.json",
        r#"{"A": [[1, -1], [-1, 1]], "b": [-1, -1]}"#,
    );
    let o = lcpbench(&["solve", &file, "--solver", "apgd", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "no_solution", "{v}");
    let c = &v["certificate"];
    assert_eq!(c["proves_no_solution"], true, "{v}");
    assert!(c["min_solution_norm"].is_null());
    let y: Vec<f64> = serde_json::from_value(c["y"].clone()).unwrap();
    assert!(y[0] > 0.0 && y[0] == y[1], "{y:?}");
    assert!(-y[0] - y[1] < 0.0);
    let text = lcpbench(&["solve", &file, "--solver", "apgd"]);
    let text = String::from_utf8(text.stdout).unwrap();
    assert!(text.contains("status      no_solution"), "{text}");
    assert!(text.contains("certificate Farkas multipliers"), "{text}");
    assert!(text.contains("so there is no solution"), "{text}");

    let file = dir.path().join("gen.json");
    let file = file.to_str().unwrap();
    assert!(
        lcpbench(&["gen", "infeasible", "--n", "6", "--seed", "1", "-o", file])
            .status
            .success()
    );
    let p: Value = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    let a: Vec<Vec<f64>> = serde_json::from_value(p["A"].clone()).unwrap();
    let b: Vec<f64> = serde_json::from_value(p["b"].clone()).unwrap();
    for solver in ["pgs", "apgd", "nsgs", "newton-fb"] {
        let o = lcpbench(&["solve", file, "--solver", solver, "--tol", "1e-4", "--json"]);
        let v: Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["status"], "diverged", "{solver}: {v}");
        let c = &v["certificate"];
        let bound = c["min_solution_norm"].as_f64().unwrap();
        let y: Vec<f64> = serde_json::from_value(c["y"].clone()).unwrap();
        // Independently: every solution f >= 0 has yᵀ(A f + b) >= 0, and
        // yᵀ A f <= Σ_j (Aᵀy)_j⁺ ‖f‖∞, so ‖f‖∞ >= −bᵀy / Σ_j (Aᵀy)_j⁺.
        assert!(y.iter().all(|&v| v >= 0.0), "{y:?}");
        let bty: f64 = b.iter().zip(&y).map(|(b, y)| b * y).sum();
        let slope: f64 = (0..y.len())
            .map(|j| (0..y.len()).map(|i| a[i][j] * y[i]).sum::<f64>().max(0.0))
            .sum();
        assert!(bty < 0.0 && slope > 0.0);
        // The library's bound carries rounding margins: it may be smaller, never larger.
        let ours = -bty / slope;
        assert!(
            bound > 0.0 && bound <= ours * (1.0 + 1e-9),
            "{solver}: bound {bound} vs {ours}"
        );
    }
}

#[test]
fn bad_input_gets_one_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("missing.json", None, "missing.json"),
        (
            "syntax.json",
            Some("{\"A\": [[1]],\n \"b\": [1,]}"),
            "syntax.json:2:",
        ),
        (
            "ragged.json",
            Some(r#"{"A": [[1, 2], [3]], "b": [1, 2]}"#),
            "field `A`: row 1 has 1 entries",
        ),
        (
            "nan.json",
            Some(r#"{"A": [[NaN]], "b": [1]}"#),
            "nan.json:1:",
        ),
        (
            "bounds.json",
            Some(r#"{"A": [[1]], "b": [1], "lo": [2], "hi": [1]}"#),
            "row 0: bounds [2, 1]",
        ),
        (
            "self.json",
            Some(r#"{"A": [[1, 0], [0, 1]], "b": [1, 1], "friction": [[1, 1, 0.5]]}"#),
            "names itself",
        ),
        (
            "blen.json",
            Some(r#"{"A": [[1, 0], [0, 1]], "b": [1]}"#),
            "b has length 1",
        ),
    ];
    for (name, text, expected) in cases {
        let path = match text {
            Some(t) => write(dir.path(), name, t),
            None => dir.path().join(name).to_str().unwrap().to_owned(),
        };
        let o = lcpbench(&["solve", &path, "--solver", "pgs"]);
        assert!(!o.status.success(), "{name} should fail");
        let err = stderr(&o);
        assert!(err.contains(expected), "{name}: `{err}` lacks `{expected}`");
        assert_eq!(
            err.trim().lines().count(),
            1,
            "{name}: one line expected, got `{err}`"
        );
    }
    let o = lcpbench(&["solve", "x.json", "--solver", "newton"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("unknown solver `newton`"));
    let o = lcpbench(&["gen", "banana", "--n", "3", "-o", "/dev/null"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("unknown instance kind `banana`"));
}

/// A cone file is solved by the cone solvers, an LCP solver says `unsupported`, and a
/// box-friction file in (normal, t1, t2) triples is solved in its cone form.
#[test]
fn cone_problems_through_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    // A block on an incline past its friction angle: it slides, ‖r_T‖ = mu r_N = 0.5.
    let cone = write(
        dir.path(),
        "cone.json",
        r#"{"name": "incline", "W": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "q": [-1, 0.6, 0.8],
            "mu": [0.5]}"#,
    );
    for solver in ["nsgs-cone", "newton-ac"] {
        let o = lcpbench(&["solve", &cone, "--solver", solver, "--json"]);
        assert!(o.status.success(), "{solver}: {}", stderr(&o));
        let v: Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["status"], "converged", "{solver}: {v}");
        let f: Vec<f64> = serde_json::from_value(v["f"].clone()).unwrap();
        assert!(
            (f[0] - 1.0).abs() < 1e-8 && (f[1] + 0.3).abs() < 1e-8 && (f[2] + 0.4).abs() < 1e-8
        );
    }
    // The convex relaxation pushes harder, r = P_K(−q) = (1.2, −0.36, −0.48), and lifts off at
    // u_N = mu ‖u_T‖ = 0.2: not converged, and the reason says so.
    let o = lcpbench(&["solve", &cone, "--solver", "clarabel-socp", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "stalled", "{v}");
    assert!(
        v["reason"].as_str().unwrap().contains("lifts off 1 of 1"),
        "{v}"
    );
    let f: Vec<f64> = serde_json::from_value(v["f"].clone()).unwrap();
    assert!(
        (f[0] - 1.2).abs() < 1e-7 && (f[1] + 0.36).abs() < 1e-7,
        "{f:?}"
    );
    let o = lcpbench(&["solve", &cone, "--solver", "pgs", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "unsupported", "{v}");
    assert!(v["reason"].as_str().unwrap().contains("nsgs-cone"), "{v}");
    // The same data as a box-friction LCP, solved in its cone form by a cone solver.
    let boxed = write(
        dir.path(),
        "box.json",
        r#"{"A": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "b": [-1, 0.6, 0.8],
            "lo": [0, null, null], "hi": [null, null, null], "friction": [[1, 0, 0.5], [2, 0, 0.5]]}"#,
    );
    let o = lcpbench(&["solve", &boxed, "--solver", "newton-ac", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "converged", "{v}");
    // Rows that are not contact triples: one clear error.
    let lcp = write(
        dir.path(),
        "lcp.json",
        r#"{"A": [[2, 1], [1, 2]], "b": [-1, 1]}"#,
    );
    let o = lcpbench(&["solve", &lcp, "--solver", "nsgs-cone"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("triples"), "{}", stderr(&o));
}

/// Run `args`, expect exit code 1 with one line on stderr that contains every needle; return it.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let o = lcpbench(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{err}` lacks `{n}`");
    }
    err
}

const TWO_ROWS: &str = r#"{"A": [[2, 1], [1, 2]], "b": [-1, -1]}"#;

#[test]
fn solve_refuses_an_unrepresentable_time_budget() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "p.json", TWO_ROWS);
    for t in ["1e20", "1e19", "inf", "NaN", "-1", "0"] {
        let flag = format!("--time-budget={t}");
        refused(
            &["solve", &file, "--solver", "pgs", &flag],
            &["--time-budget"],
        );
    }
    let o = lcpbench(&["solve", &file, "--solver", "pgs", "--time-budget", "1e6"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn solve_refuses_tolerances_outside_zero_one() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "p.json", TWO_ROWS);
    for tol in ["1e300", "1", "2", "0", "-1e-8", "NaN"] {
        let flag = format!("--tol={tol}");
        refused(
            &["solve", &file, "--solver", "pgs", &flag],
            &["--tol", "(0, 1)"],
        );
    }
    let err = refused(&["solve", &file, "--solver", "pgs", "--tol", "1e300"], &[]);
    assert!(err.contains("got 1e300"), "{err}");
}

/// A tolerance below round-off is refused with the reason (it could be met only by chance, and
/// its failure would say nothing about the problem), by `solve`, `simulate` and bench budgets.
#[test]
fn tolerances_below_round_off_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "p.json", TWO_ROWS);
    for tol in ["1e-300", "1e-15", "5e-324"] {
        refused(
            &["solve", &file, "--solver", "enum", "--tol", tol],
            &["--tol", "below 1e-14", "round"],
        );
    }
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/bench_scenes/box_on_ground.toml"
    );
    refused(
        &["simulate", scene, "--tol", "1e-300"],
        &["--tol", "below 1e-14"],
    );
    let out = dir.path().join("out");
    refused(
        &[
            "bench",
            "--lcps",
            &format!("file:{file}"),
            "--solvers",
            "pgs",
            "--budgets",
            "1e-300:100:1",
            "--out",
            out.to_str().unwrap(),
        ],
        &["below 1e-14"],
    );
    let o = lcpbench(&["solve", &file, "--solver", "enum", "--tol", "1e-14"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn an_invalid_omega_is_an_input_error_not_unsupported() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "p.json", TWO_ROWS);
    for omega in ["5", "2", "0", "-0.5", "NaN"] {
        let flag = format!("--omega={omega}");
        refused(
            &["solve", &file, "--solver", "sor", &flag, "--json"],
            &["--omega", "(0, 2)"],
        );
    }
}

/// Parameters are `NAME@key=value` on `--solver` as everywhere: SOR's relaxation reaches the
/// solve (another omega, another iteration count), and a value out of range or an unknown key is
/// refused naming the key and its range, or the solver's keys.
#[test]
fn solver_parameters_are_key_value_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "p.json",
        r#"{"A": [[2, 1], [1, 2]], "b": [-1, 1]}"#,
    );
    let iterations = |solver: &str| {
        let o = lcpbench(&["solve", &file, "--solver", solver, "--json"]);
        assert!(o.status.success(), "{solver}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["status"], "converged", "{solver}");
        assert_eq!(v["solver"], "sor", "{solver}");
        v["iterations"].as_u64().unwrap()
    };
    assert_eq!(iterations("sor@omega=1.5"), iterations("sor@1.5"));
    // On this problem the second row stays at 0: the first converges as |1 - omega|^k.
    assert!(iterations("sor@omega=1.5") < iterations("sor@omega=0.2"));
    for (solver, says) in [
        ("sor@omega=2.5", "omega must be in (0, 2), got 2.5"),
        ("sor@alpha=1", "unknown parameter `alpha` (keys: omega)"),
        ("pgs@omega=1.2", "takes no parameters"),
    ] {
        let o = lcpbench(&["solve", &file, "--solver", solver]);
        assert!(!o.status.success(), "{solver}");
        assert!(stderr(&o).contains(says), "{solver}: {}", stderr(&o));
    }
}

#[test]
fn io_and_invalid_data_errors_are_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.json");
    let err = refused(
        &["solve", missing.to_str().unwrap(), "--solver", "pgs"],
        &["missing.json", "No such file or directory"],
    );
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
    let bounds = write(
        dir.path(),
        "bounds.json",
        r#"{"A": [[1]], "b": [1], "lo": [2], "hi": [1]}"#,
    );
    let err = refused(&["solve", &bounds, "--solver", "pgs"], &["bounds [2, 1]"]);
    assert_eq!(err.matches("bounds [2, 1]").count(), 1, "{err}");
}

#[test]
fn a_top_level_array_or_null_is_described_without_internal_names() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text, found) in [
        ("null.json", "null", "found null"),
        ("array.json", "[[1]]", "found an array"),
        ("number.json", " 3", "found a number"),
    ] {
        let file = write(dir.path(), name, text);
        let err = refused(
            &["solve", &file, "--solver", "pgs"],
            &[name, "one JSON object with fields `A` and `b`", found],
        );
        assert!(!err.contains("ProblemFile"), "{err}");
    }
}

#[test]
fn gen_refuses_sizes_that_cannot_fit() {
    refused(
        &["gen", "spd", "--n", "100000", "-o", "/dev/null"],
        &["--n 100000", "limit of 10000"],
    );
}

#[test]
fn simulate_and_export_refuse_step_counts_beyond_the_limit() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench_scenes/box_on_ground.toml");
    let scene = scene.to_str().unwrap();
    refused(
        &[
            "export",
            scene,
            "--step",
            "18446744073709551615",
            "-o",
            "/dev/null",
        ],
        &["--step", "1000000"],
    );
    refused(
        &["simulate", scene, "--steps", "0"],
        &["--steps", "between 1"],
    );
    refused(&["simulate", scene, "--tol", "1e300"], &["--tol", "(0, 1)"]);
}

/// Run lcpbench with `input` on standard input.
fn lcpbench_stdin(args: &[&str], input: &[u8]) -> Output {
    use std::io::Write;
    let mut child = Command::new(env!("CARGO_BIN_EXE_lcpbench"))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    let writer = std::thread::spawn(move || {
        stdin.write_all(&input).ok();
    });
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    out
}

/// `solve -` reads a JSON problem (LCP or cone) from standard input; anything else gets a clear
/// message.
#[test]
fn solve_reads_a_problem_from_stdin() {
    // A = I, b = (-1, 2): f = (1, 0), w = (0, 2).
    let lcp = br#"{"A": [[1, 0], [0, 1]], "b": [-1, 2]}"#;
    let o = lcpbench_stdin(&["solve", "-", "--solver", "lemke", "--json"], lcp);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "converged", "{v}");
    let f: Vec<f64> = serde_json::from_value(v["f"].clone()).unwrap();
    assert!((f[0] - 1.0).abs() < 1e-12 && f[1].abs() < 1e-12, "{f:?}");
    // The summary names the source.
    let o = lcpbench_stdin(&["solve", "-", "--solver", "pgs"], lcp);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("<stdin>"), "{text}");
    assert!(text.contains("sweeps over the rows"), "{text}");
    // A cone problem: the block on the incline, solved exactly.
    let cone = br#"{"W": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "q": [-1, 0.6, 0.8], "mu": [0.5]}"#;
    let o = lcpbench_stdin(&["solve", "-", "--solver", "newton-ac", "--json"], cone);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "converged", "{v}");
    // Empty input, a Siconos file and broken JSON are refused with a message naming stdin.
    for (input, needle) in [
        (&b""[..], "the input is empty"),
        (&b"2\n1 0\n0 1\n-1 2\n"[..], "not a JSON problem"),
        (&b"{\"A\": [[1]], \"b\": "[..], "<stdin>"),
    ] {
        let o = lcpbench_stdin(&["solve", "-", "--solver", "pgs"], input);
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(e.contains(needle), "{needle:?} not in {e}");
        assert!(!e.contains("panicked"), "{e}");
    }
}

/// `lcpbench solvers` prints a header and aligned columns: every column starts at the same
/// character position on every line, and each solver says what its iterations count.
#[test]
fn solvers_prints_a_header_and_aligned_columns() {
    let o = lcpbench(&["solvers"]);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    // The table, then after a blank line each parameterised solver's keys.
    let lines: Vec<&str> = text.lines().take_while(|l| !l.is_empty()).collect();
    let params: Vec<&str> = text.lines().skip_while(|l| !l.is_empty()).collect();
    for key in ["substeps", "hertz", "joint_hertz"] {
        assert!(
            params
                .iter()
                .any(|l| l.trim_start().starts_with(key) && l.contains("default")),
            "no `{key}` parameter listed: {params:?}"
        );
    }
    assert!(params.contains(&"soft-step"), "{params:?}");
    let header = lines[0];
    assert!(
        header.starts_with("solver") && header.contains("iterations count"),
        "{header}"
    );
    let starts = |line: &str| -> Vec<usize> {
        // Character positions where a column starts: after two or more spaces.
        let chars: Vec<char> = line.chars().collect();
        (2..chars.len())
            .filter(|&i| chars[i] != ' ' && chars[i - 1] == ' ' && chars[i - 2] == ' ')
            .take(4)
            .collect()
    };
    let want = starts(header);
    assert_eq!(want.len(), 4, "{header}");
    for line in &lines[1..] {
        let chars: Vec<char> = line.chars().collect();
        for &c in &want {
            assert!(
                chars[c - 1] == ' ' && chars[c] != ' ',
                "column at {c} not aligned in {line:?} (header {header:?})"
            );
        }
    }
    for (name, unit) in [
        ("pgs", "sweeps"),
        ("lemke", "pivots"),
        ("newton-fb", "Newton steps"),
        ("clarabel", "interior-point iterations"),
        ("clarabel-socp", "interior-point iterations"),
    ] {
        let line = lines
            .iter()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap();
        assert!(line.contains(unit), "{name}: {line}");
    }
}

/// Every help text that takes a solver lists the names `lcpbench solvers` prints, all of them
/// (solve: the matrix and cone solvers; simulate and bench: every one).
#[test]
fn help_texts_list_every_solver_of_the_table() {
    let o = lcpbench(&["solvers"]);
    let table = String::from_utf8(o.stdout).unwrap();
    let rows: Vec<(String, String)> = table
        .lines()
        .take_while(|l| !l.is_empty())
        .skip(1)
        .map(|l| {
            let mut w = l.split_whitespace();
            (w.next().unwrap().to_owned(), w.next().unwrap().to_owned())
        })
        .collect();
    assert_eq!(
        rows.iter().filter(|(_, level)| level == "cone").count(),
        lcpbench_solvers::ConeSolverKind::all().len()
    );
    assert_eq!(rows.len(), lcpbench::registry::entries().len());
    for (command, levels) in [
        ("solve", &["matrix", "cone"][..]),
        ("simulate", &["matrix", "body", "cone"][..]),
        ("bench", &["matrix", "body", "cone"][..]),
    ] {
        let o = lcpbench(&[command, "--help"]);
        assert!(o.status.success());
        let help = String::from_utf8(o.stdout).unwrap();
        let words: std::collections::HashSet<&str> = help
            .split(|c: char| c.is_whitespace() || c == ',' || c == '[' || c == ']' || c == ';')
            .collect();
        for (name, level) in &rows {
            if levels.contains(&level.as_str()) {
                assert!(
                    words.contains(name.as_str()),
                    "{command} --help lacks {name}"
                );
            }
        }
    }
}

//! Problem files seen from outside: Siconos' own LCP test files solve to their known answers,
//! `import` round-trips, `solve` and `bench --lcps file:` take every format, and bad files give
//! one clear error.

use lcpbench::harness::sweep::read_results;
use lcpbench::harness::RunStatus;
use lcpbench_solvers::{read_problem, residuals, Problem, Settings, SolverKind, Status};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const EXE: &str = env!("CARGO_BIN_EXE_lcpbench");

fn lcpbench(args: &[&str]) -> Output {
    Command::new(EXE)
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn siconos(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/siconos")
        .join(name)
}

fn assert_close(f: &[f64], expected: &[f64], tol: f64) {
    assert_eq!(f.len(), expected.len());
    for (a, b) in f.iter().zip(expected) {
        assert!((a - b).abs() <= tol, "{f:?} vs {expected:?}");
    }
}

/// Solve with Lemke and Dantzig; both must converge on the shared residual.
fn pivot_solutions(problem: &Problem) -> Vec<Vec<f64>> {
    [SolverKind::Lemke, SolverKind::Dantzig]
        .into_iter()
        .map(|kind| {
            let settings = Settings {
                tolerance: 1e-10,
                ..Settings::default()
            };
            let r = kind.create().solve(problem, &settings);
            assert_eq!(r.status, Status::Converged, "{}: {:?}", kind.name(), r);
            assert!(residuals(problem, &r.f).natural_map_rel <= 1e-10);
            r.f
        })
        .collect()
}

#[test]
fn siconos_test_files_solve_to_their_known_answers() {
    // Cottle–Pang–Stone Remark 4.1.14: the solutions are z >= 0 with z_1 + z_2 = 1.
    let p = read_problem(&siconos("lcp_CPS_1.dat")).unwrap();
    assert_eq!(p.name(), Some("lcp_CPS_1"));
    for f in pivot_solutions(&p) {
        assert!((f[0] + f[1] - 1.0).abs() < 1e-10 && f.iter().all(|&v| v >= 0.0));
    }
    // Stored column by column: row 3 of M is (1, 1, 1, 0), column 3 is (-1, -1, -1, 0).
    let p = read_problem(&siconos("lcp_CPS_4.dat")).unwrap();
    assert_eq!(
        (p.entry(3, 0), p.entry(0, 3), p.entry(2, 0)),
        (1.0, -1.0, 10.0)
    );
    assert_eq!(p.b(), &[50.0, 50.0, 10.0, -6.0]);
    for f in pivot_solutions(&p) {
        assert_close(&f, &[2.0, 2.0, 2.0, 92.0], 1e-8);
    }
    // Sparse block storage: one 2×2 block; 2a + b = 5, a + 2b = 6.
    let p = read_problem(&siconos("lcp_deudeu_block.dat")).unwrap();
    assert!(p.is_sparse());
    for f in pivot_solutions(&p) {
        assert_close(&f, &[4.0 / 3.0, 7.0 / 3.0], 1e-10);
    }
}

#[test]
fn solve_and_import_read_siconos_files() {
    let dir = tempfile::tempdir().unwrap();
    let dat = siconos("lcp_CPS_4.dat");
    let dat = dat.to_str().unwrap();
    let o = lcpbench(&["solve", dat, "--solver", "dantzig", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "converged");
    assert_eq!(v["problem"], "lcp_CPS_4");
    let json = dir.path().join("cps4.json");
    let o = lcpbench(&["import", dat, "-o", json.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (
        read_problem(Path::new(dat)).unwrap(),
        read_problem(&json).unwrap(),
    );
    assert_eq!(a.to_dense(), b.to_dense());
    assert_eq!(a.b(), b.b());
    assert_eq!(b.name(), Some("lcp_CPS_4"));
}

#[test]
fn bench_takes_siconos_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let case = format!("file:{}", siconos("lcp_deudeu_block.dat").display());
    let o = Command::new(EXE)
        .args(["bench", "--no-progress", "--lcps", &case, "--jobs", "1"])
        .args(["--solvers", "lemke,pgs", "--budgets", "default", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows.len(), 2);
    assert!(
        rows.iter().all(|r| r.status == RunStatus::Converged),
        "{rows:?}"
    );
}

#[test]
fn bad_files_give_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.dat");
    std::fs::write(&bad, "2\n0\n2\n2\n2 2\n1 0\n0 oops\n1 1\n").unwrap();
    let o = lcpbench(&["solve", bad.to_str().unwrap(), "-s", "pgs"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("bad.dat:7:3: expected M[1][1]"), "{e}");
    let missing = dir.path().join("missing.hdf5");
    let o = lcpbench(&["import", missing.to_str().unwrap(), "-o", "x.json"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("missing.hdf5"), "{}", stderr(&o));
}

#[test]
fn fclib_files_solve_import_and_bench() {
    use faer::sparse::{SparseColMat, Triplet};
    use lcpbench_solvers::write_fclib_local;
    // One contact on a plane: W = I, approaching at 1, pushed sideways at 0.2 < mu = 0.5:
    // sticks with r = (1, 0.2, 0).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plane.hdf5");
    let t: Vec<_> = (0..3).map(|i| Triplet::new(i, i, 1.0)).collect();
    let w = SparseColMat::try_new_from_triplets(3, 3, &t).unwrap();
    write_fclib_local(&path, 3, &w, &[-1.0, -0.2, 0.0], &[0.5]).unwrap();
    let file = path.to_str().unwrap();
    let o = lcpbench(&["solve", file, "--solver", "pgs", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["status"], "converged");
    let f: Vec<f64> = serde_json::from_value(v["f"].clone()).unwrap();
    assert_close(&f, &[1.0, 0.2, 0.0], 1e-7);
    let json = dir.path().join("plane.json");
    let o = lcpbench(&["import", file, "-o", json.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = read_problem(&json).unwrap();
    assert_eq!(p.friction().len(), 2);
    assert_eq!(p.to_dense(), w.to_dense());
    // And back: JSON to a local FCLIB file that reads as the same problem.
    let back = dir.path().join("back.hdf5");
    let o = lcpbench(&[
        "import",
        json.to_str().unwrap(),
        "-o",
        back.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let q = read_problem(&back).unwrap();
    assert_eq!(
        (q.to_dense(), q.b(), q.friction()),
        (p.to_dense(), p.b(), p.friction())
    );
    let out = dir.path().join("sweep");
    let o = Command::new(EXE)
        .args(["bench", "--no-progress", "--lcps", &format!("file:{file}")])
        .args([
            "--solvers",
            "dantzig",
            "--budgets",
            "default",
            "--jobs",
            "1",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = read_results(&out.join("results.csv")).unwrap();
    assert_eq!(rows[0].status, RunStatus::Converged, "{rows:?}");
}

/// The FCLIB problems of Siconos' test data in `bench_scenes/fclib/` (three in the global form,
/// condensed on reading) read with their contact counts, and each solves to the relative
/// residual 1e-6 with the solver the report finds fastest on it.
#[test]
fn siconos_fclib_problems_read_and_solve() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench_scenes/fclib");
    for (name, contacts, solver) in [
        ("LMGC_100_PR_PerioBox-i00361-60-03000", 60, SolverKind::Nncg),
        ("Box_Stacks-i0122-82-5", 82, SolverKind::Sor),
        (
            "spheres-in-a-box-98-i10000-256-10",
            256,
            SolverKind::NewtonFb,
        ),
        ("Capsules-i125-1213", 286, SolverKind::NewtonMin),
        ("Spheres-i099-356-679", 356, SolverKind::Lemke),
    ] {
        let p = read_problem(&dir.join(format!("{name}.hdf5"))).unwrap();
        assert_eq!(p.n(), 3 * contacts, "{name}");
        assert_eq!(p.friction().len(), 2 * contacts, "{name}");
        let settings = Settings {
            tolerance: 1e-6,
            max_iterations: 100_000,
            ..Settings::default()
        };
        let r = solver.create().solve(&p, &settings);
        assert_eq!(r.status, Status::Converged, "{name}: {}", solver.name());
        assert!(residuals(&p, &r.f).natural_map_rel <= 1e-6, "{name}");
    }
}

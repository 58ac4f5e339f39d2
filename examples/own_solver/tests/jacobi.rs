//! The example solver on its own (judged by the shared residual, against Lemke's answer) and
//! inside the lcpbench command line it extends: listed, solved with parameters, swept in child
//! processes beside a built-in solver and reported.

use lcpbench_own_solver::{ProjectedJacobi, JACOBI_EXAMPLE};
use lcpbench_solvers::generate::{generate, Family};
use lcpbench_solvers::{residuals, Lemke, Settings, Solver, Status};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_lcpbench-own-solver");

/// On a planted SPD problem (condition 10, so `ω = 0.5` converges), the answer meets the
/// tolerance by the shared residual measured here, and matches Lemke's and the planted one.
#[test]
fn converges_on_a_planted_spd_problem_by_the_shared_residual() {
    let g = generate(Family::Spd { cond: 10.0 }, 12, 7);
    let settings = Settings::default();
    let mut solver = ProjectedJacobi { omega: 0.5 };
    assert_eq!(solver.name(), JACOBI_EXAMPLE.name);
    let r = solver.solve(&g.problem, &settings);
    assert_eq!(r.status, Status::Converged, "{}", r.status);
    let ours = residuals(&g.problem, &r.f).natural_map_rel;
    assert!(ours <= settings.tolerance, "{ours:e}");
    let lemke = Lemke::default().solve(&g.problem, &settings);
    let planted = g.solution.expect("a planted solution");
    for (i, ((ours, theirs), want)) in r.f.iter().zip(&lemke.f).zip(&planted).enumerate() {
        assert!((ours - theirs).abs() <= 1e-6, "row {i}");
        assert!((ours - want).abs() <= 1e-6, "row {i}");
    }
    assert_eq!(r.f.len(), g.problem.n());
    // A step too long for the problem never claims convergence.
    let capped = Settings {
        max_iterations: 50,
        ..Settings::default()
    };
    let r = ProjectedJacobi { omega: 1.99 }.solve(&g.problem, &capped);
    if r.status == Status::Converged {
        assert!(residuals(&g.problem, &r.f).natural_map_rel <= capped.tolerance);
    }
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(BIN).args(args).output().unwrap()
}

#[test]
fn the_command_line_lists_solves_sweeps_and_reports_it() {
    let o = run(&["solvers"]);
    let table = String::from_utf8(o.stdout).unwrap();
    let line = table
        .lines()
        .find(|l| l.starts_with("jacobi-example"))
        .unwrap_or_else(|| panic!("not listed:\n{table}"));
    assert!(line.contains("matrix") && line.contains("+warm"), "{line}");
    assert!(table.contains("damping of the Jacobi step"), "{table}");

    let dir = tempfile::tempdir().unwrap();
    let problem = dir.path().join("p.json");
    std::fs::write(&problem, r#"{"A": [[2, 1], [1, 2]], "b": [-1, 1]}"#).unwrap();
    let o = run(&[
        "solve",
        problem.to_str().unwrap(),
        "--solver",
        "jacobi-example@omega=0.8",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(out["solver"], "jacobi-example");
    assert_eq!(out["status"], "converged");
    assert!(out["residual_rel"].as_f64().unwrap() <= 1e-8);
    let o = run(&[
        "solve",
        problem.to_str().unwrap(),
        "--solver",
        "jacobi-example@omega=2.5",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("omega must be in (0, 2)"),
        "{err}"
    );

    // The sweep runs each case in a child process of this binary, which registers the solver
    // too; the report reads the rows back beside the built-in solver's.
    let out = dir.path().join("sweep");
    let o = run(&[
        "bench",
        "--lcps",
        "spd:n=10:cond=1e1:seed=1",
        "--solvers",
        "jacobi-example,pgs",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let solver_of = |name: &str| {
        rows.lines()
            .find(|l| l.split(',').nth(4) == Some(name))
            .unwrap_or_else(|| panic!("no {name} row:\n{rows}"))
            .to_owned()
    };
    assert!(solver_of("jacobi-example").contains(",converged,"));
    assert!(solver_of("pgs").contains(",converged,"));
    let o = run(&["report", "--from", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut markdown = String::new();
    let mut dirs = vec![out.join("report")];
    while let Some(d) = dirs.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                markdown.push_str(&std::fs::read_to_string(&path).unwrap());
            }
        }
    }
    assert!(markdown.contains("jacobi-example"), "{markdown}");
}

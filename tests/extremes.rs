//! Numerical extremes: ill-conditioning, tiny and huge magnitudes, degenerate and redundant
//! rows, Murty's exponential example, infeasibility, invalid input.

mod common;

use faer::Mat;
use lcpbench_solvers::generate::{generate, Family};
use lcpbench_solvers::{
    residuals, Problem, ProblemError, Settings, SolveResult, SolverKind, Status,
};

fn settings(tol: f64, max_iterations: usize) -> Settings {
    Settings {
        tolerance: tol,
        max_iterations,
        ..Settings::default()
    }
}

fn solve(kind: SolverKind, p: &Problem, s: &Settings) -> SolveResult {
    let r = kind.create().solve(p, s);
    // The status always agrees with the residual recomputed from f.
    let res = residuals(p, &r.f).natural_map_rel;
    if r.status.is_converged() {
        assert!(res <= s.tolerance, "{}: converged at {res:e}", kind.name());
    } else if !matches!(r.status, Status::Unsupported { .. }) {
        assert!(
            res > s.tolerance,
            "{}: {} at {res:e}",
            kind.name(),
            r.status
        );
    }
    r
}

fn scaled(p: &Problem, s: f64) -> Problem {
    let n = p.n();
    let a = Mat::from_fn(n, n, |i, j| s * p.entry(i, j));
    Problem::lcp(a, p.b().iter().map(|v| s * v).collect()).unwrap()
}

#[test]
fn condition_number_1e10() {
    let g = generate(Family::Spd { cond: 1e10 }, 20, 11);
    let p = &g.problem;
    for kind in [SolverKind::Lemke, SolverKind::Dantzig, SolverKind::Clarabel] {
        let r = solve(kind, p, &settings(1e-6, 10_000));
        assert_eq!(r.status, Status::Converged, "{}", kind.name());
    }
    // PGS is far too slow here: it must say so, not pretend.
    let r = solve(SolverKind::Pgs, p, &settings(1e-10, 200));
    assert_eq!(r.status, Status::IterationLimit);
}

#[test]
fn magnitudes_1e_minus9_and_1e9_change_nothing() {
    let g = generate(Family::Spd { cond: 1e3 }, 30, 5);
    let s = settings(1e-8, 10_000);
    for kind in SolverKind::ALL {
        let base = solve(kind, &g.problem, &s);
        for factor in [1e-9, 1e9] {
            let r = solve(kind, &scaled(&g.problem, factor), &s);
            assert_eq!(
                r.status.name(),
                base.status.name(),
                "{} at scale {factor:e}",
                kind.name()
            );
            if base.status.is_converged() {
                let diff =
                    r.f.iter()
                        .zip(&base.f)
                        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                assert!(
                    diff <= 1e-6,
                    "{} at scale {factor:e}: f moved by {diff:e}",
                    kind.name()
                );
            }
        }
    }
}

#[test]
fn tiny_b_scales_the_solution() {
    // Scaling b alone by 1e-9 scales the solution; the relative residual keeps its meaning.
    let g = generate(Family::Spd { cond: 1e2 }, 15, 8);
    let p = &g.problem;
    let tiny = Problem::lcp(p.to_dense(), p.b().iter().map(|v| v * 1e-9).collect()).unwrap();
    for kind in [
        SolverKind::Lemke,
        SolverKind::Dantzig,
        SolverKind::Pgs,
        SolverKind::Clarabel,
    ] {
        let r = solve(kind, &tiny, &settings(1e-8, 10_000));
        assert_eq!(r.status, Status::Converged, "{}", kind.name());
        let planted = g.solution.as_ref().unwrap();
        for (x, y) in r.f.iter().zip(planted) {
            assert!((x / 1e-9 - y).abs() < 1e-5, "{}", kind.name());
        }
    }
}

#[test]
fn zero_b_gives_zero_impulse() {
    let g = generate(Family::PsdRankDeficient { rank: 4 }, 10, 2);
    let p = Problem::lcp(g.problem.to_dense(), vec![0.0; 10]).unwrap();
    for kind in SolverKind::ALL {
        let r = solve(kind, &p, &settings(1e-8, 1_000));
        if matches!(r.status, Status::Unsupported { .. }) {
            continue;
        }
        assert_eq!(r.status, Status::Converged, "{}", kind.name());
        assert!(
            r.f.iter().all(|v| v.abs() < 1e-10),
            "{}: {:?}",
            kind.name(),
            r.f
        );
    }
}

#[test]
fn duplicated_rows_do_not_break_the_solvers() {
    // Four identical contact rows (a box face on the ground, all normals equal), pressed down:
    // A = J Jᵀ has rank 1. Any split of the total impulse is a solution.
    let n = 4;
    let a = Mat::from_fn(n, n, |_, _| 1.0);
    let p = Problem::lcp(a, vec![-1.0; n]).unwrap();
    for kind in SolverKind::ALL {
        let r = solve(kind, &p, &settings(1e-8, 10_000));
        if kind == SolverKind::MicroImpulse || matches!(r.status, Status::Unsupported { .. }) {
            continue;
        }
        assert_eq!(r.status, Status::Converged, "{}: {}", kind.name(), r.status);
        let total: f64 = r.f.iter().sum();
        assert!(
            (total - 1.0).abs() < 1e-7,
            "{}: total impulse {total}",
            kind.name()
        );
    }
    // Degenerate: duplicated rows of a planted problem with a zero in b.
    let g = generate(Family::Spd { cond: 10.0 }, 6, 4);
    let src = &g.problem;
    let idx = [0, 1, 1, 2, 3, 3, 4, 5];
    let m = idx.len();
    let a = Mat::from_fn(m, m, |i, j| src.entry(idx[i], idx[j]));
    let mut b: Vec<f64> = idx.iter().map(|&i| src.b()[i]).collect();
    b[0] = 0.0;
    let p = Problem::lcp(a, b).unwrap();
    for kind in [
        SolverKind::Lemke,
        SolverKind::Dantzig,
        SolverKind::Pgs,
        SolverKind::Clarabel,
    ] {
        let r = solve(kind, &p, &settings(1e-8, 10_000));
        assert_eq!(r.status, Status::Converged, "{}: {}", kind.name(), r.status);
    }
}

#[test]
fn murty_example_is_exponential_for_lemke() {
    let mut pivots = Vec::new();
    for n in 2..=8 {
        let g = generate(Family::Murty, n, 0);
        let r = solve(SolverKind::Lemke, &g.problem, &settings(1e-10, 100_000));
        assert_eq!(r.status, Status::Converged, "n = {n}");
        pivots.push(r.iterations);
    }
    for (k, pair) in pivots.windows(2).enumerate() {
        let ratio = pair[1] as f64 / pair[0] as f64;
        assert!(
            ratio > 1.8,
            "pivot counts {pivots:?} do not double at n = {}",
            k + 3
        );
    }
    let g = generate(Family::Murty, 12, 0);
    let r = solve(SolverKind::Lemke, &g.problem, &settings(1e-10, 500));
    assert_eq!(r.status, Status::IterationLimit);
    assert_eq!(r.iterations, 500);
}

#[test]
fn infeasible_psd_problem_is_never_converged() {
    let g = generate(Family::Infeasible, 12, 9);
    for kind in SolverKind::ALL {
        let r = solve(kind, &g.problem, &settings(1e-8, 2_000));
        assert!(
            !r.status.is_converged(),
            "{} converged on an infeasible problem",
            kind.name()
        );
        if kind == SolverKind::Lemke {
            assert!(
                matches!(r.status, Status::NoSolution { .. }),
                "lemke: {}",
                r.status
            );
        }
    }
}

#[test]
fn nan_input_is_an_error() {
    let mut a = Mat::<f64>::identity(3, 3);
    a[(2, 1)] = f64::NAN;
    assert!(matches!(
        Problem::lcp(a, vec![1.0; 3]),
        Err(ProblemError::NonFinite { .. })
    ));
    assert!(matches!(
        Problem::lcp(Mat::identity(2, 2), vec![f64::NAN, 1.0]),
        Err(ProblemError::NonFinite { .. })
    ));
}

#[test]
fn time_budget_is_reported() {
    let g = generate(Family::Spd { cond: 1e8 }, 150, 3);
    let s = Settings {
        tolerance: 1e-14,
        max_iterations: usize::MAX,
        time_budget: Some(std::time::Duration::from_millis(20)),
        ..Settings::default()
    };
    let r = solve(SolverKind::Pgs, &g.problem, &s);
    assert_eq!(r.status, Status::TimeLimit);
}

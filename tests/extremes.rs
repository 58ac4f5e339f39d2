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
    for kind in SolverKind::all() {
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
    for kind in SolverKind::all() {
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
    for kind in SolverKind::all() {
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
    for kind in SolverKind::all() {
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

/// The relative natural-map residual of `f` written from the README's definition with dense
/// products over [`Problem::entry`], independently of the crate's `metrics` module.
fn independent_relative_residual(p: &Problem, f: &[f64]) -> f64 {
    let n = p.n();
    let (mut lo, mut hi) = (p.lo().to_vec(), p.hi().to_vec());
    for fr in p.friction() {
        let bound = fr.mu * f[fr.normal].max(0.0);
        (lo[fr.row], hi[fr.row]) = (-bound, bound);
    }
    let mut worst: f64 = 0.0;
    for i in 0..n {
        let row: Vec<f64> = (0..n).map(|j| p.entry(i, j)).collect();
        let d = if row[i] > 0.0 {
            row[i]
        } else {
            row.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
        };
        let w: f64 = row.iter().zip(f).map(|(a, x)| a * x).sum::<f64>() + p.b()[i];
        let magnitude: f64 = row.iter().zip(f).map(|(a, x)| (a * x).abs()).sum::<f64>();
        let step = (f[i] - (f[i] - w / d).max(lo[i]).min(hi[i])).abs();
        let scale = (p.b()[i].abs() + magnitude) / d;
        let rel = if step == 0.0 {
            0.0
        } else if scale > 0.0 {
            step / scale
        } else {
            f64::INFINITY
        };
        worst = worst.max(rel);
    }
    worst
}

/// A problem file of `tests/data/spin/` with its `warm_start`.
fn spin_case(name: &str) -> (Problem, Vec<f64>) {
    let path = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/spin"))
        .join(name);
    let problem = lcpbench_solvers::read_problem(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let warm = value["warm_start"]
        .as_array()
        .map(|a| a.iter().map(|v| v.as_f64().unwrap()).collect())
        .unwrap_or_default();
    (problem, warm)
}

/// Never spin, Newton: the 1,008-row island of `sphere_pile_200`'s step 31 (exported with
/// `newton-fb+warm` at `1e-8`, warm start included) went on for 10,000 iterations warm-started
/// at a residual of `7e-15`, because the projection of that iterate was 100 % wrong in some
/// friction rows. It now stops within tolerance in a few dozen iterations, warm and cold.
#[test]
fn newton_stops_on_a_sphere_pile_island_it_used_to_spin_on() {
    let (p, warm) = spin_case("sphere_pile_200_step31_island.json");
    assert_eq!(p.n(), 1008);
    for kind in [SolverKind::NewtonFb, SolverKind::NewtonMin] {
        for warm_start in [Some(warm.clone()), None] {
            let s = Settings {
                warm_start: warm_start.clone(),
                ..settings(1e-8, 10_000)
            };
            let r = solve(kind, &p, &s);
            assert!(r.status.is_converged(), "{}: {}", kind.name(), r.status);
            assert!(
                r.iterations <= 200,
                "{}: {} iterations",
                kind.name(),
                r.iterations
            );
            let rel = independent_relative_residual(&p, &r.f);
            assert!(rel <= 1e-8, "{}: independent residual {rel:e}", kind.name());
        }
    }
}

/// Never spin, first-order methods: on the pyramid-friction LCP of the 60 Hz 10-box tower
/// (step 30; its slack rows have a zero diagonal and the matrix is not symmetric), PGS, SOR,
/// NSGS and NNCG ran to a cap of 100,000 sweeps at a residual near 0.3. Each now stops
/// `stalled` once its residual has made no new low for the stagnation window, and Newton's
/// stagnation rule stops a problem with no solution after its window (and one restart from a
/// warm start).
#[test]
fn first_order_methods_stall_instead_of_spinning_to_the_cap() {
    let (p, _) = spin_case("tower_10_60hz_pyramid_step30.json");
    let cap = 100_000;
    for kind in [
        SolverKind::Pgs,
        SolverKind::Sor,
        SolverKind::Nsgs,
        SolverKind::Nncg,
    ] {
        let r = solve(kind, &p, &settings(1e-8, cap));
        match &r.status {
            Status::Stalled { reason } => assert!(reason.contains("no progress"), "{reason}"),
            other => panic!("{}: {other}", kind.name()),
        }
        assert!(r.iterations < 10_000, "{}: {}", kind.name(), r.iterations);
        assert!(independent_relative_residual(&p, &r.f) > 1e-8);
    }
    // Newton solves it, so it is a solver's stall and not the problem's.
    let r = solve(SolverKind::NewtonMin, &p, &settings(1e-8, 200));
    assert!(r.status.is_converged(), "{}", r.status);
    assert!(independent_relative_residual(&p, &r.f) <= 1e-8);
}

/// Newton's stagnation rule and globalisation on the 1,155-row island of `sphere_pile_200`'s
/// step 33 (exported with `newton-fb+warm` at `1e-8`, warm start included), where the
/// warm-started solve ran to its cap of 10,000 iterations. Fischer–Burmeister Newton now
/// converges warm and cold, far from the cap: both end on the same restart from zero (the cold
/// one after its start from NSGS sweeps stalled), so their answers are the same bit for bit.
/// Cold min-map Newton, which made no progress for a window and stopped `stalled`, converges
/// with the globalisation; without it (`Globalisation::off`) it still stops `stalled` with its
/// best point after a window, far from the cap.
#[test]
fn newton_restarts_a_warm_start_that_stagnates_and_a_cold_one_stalls() {
    use lcpbench_solvers::Solver as _;
    let (p, warm) = spin_case("sphere_pile_200_step33_island.json");
    assert_eq!(p.n(), 1155);
    let warm_settings = Settings {
        warm_start: Some(warm),
        ..settings(1e-8, 10_000)
    };
    let restarted = solve(SolverKind::NewtonFb, &p, &warm_settings);
    let cold = solve(SolverKind::NewtonFb, &p, &settings(1e-8, 10_000));
    assert!(restarted.status.is_converged(), "{}", restarted.status);
    assert!(cold.status.is_converged(), "{}", cold.status);
    assert_eq!(restarted.f, cold.f);
    for r in [&restarted, &cold] {
        assert!(r.iterations <= 2_000, "{}", r.iterations);
        assert!(independent_relative_residual(&p, &r.f) <= 1e-8);
    }

    let globalised = solve(SolverKind::NewtonMin, &p, &settings(1e-8, 10_000));
    assert!(globalised.status.is_converged(), "{}", globalised.status);
    assert!(independent_relative_residual(&p, &globalised.f) <= 1e-8);

    let mut plain = lcpbench_solvers::Newton {
        globalisation: lcpbench_solvers::Globalisation::off(),
        ..lcpbench_solvers::Newton::min_map()
    };
    let stalled = plain.solve(&p, &settings(1e-8, 10_000));
    match &stalled.status {
        Status::Stalled { reason } => {
            assert!(reason.contains("no progress"), "{reason}");
            assert!(!reason.contains("restart"), "{reason}");
        }
        other => panic!("{other}"),
    }
    assert!(
        stalled.iterations <= 1_000,
        "{} iterations",
        stalled.iterations
    );
    let rel = independent_relative_residual(&p, &stalled.f);
    assert!(rel > 1e-8);
    assert!(
        (rel - stalled.residuals.natural_map_rel).abs() <= 1e-6 * rel,
        "{rel:e}"
    );
}

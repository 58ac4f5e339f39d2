//! Property tests on problems built around a null direction `z >= 0` of a singular PSD `A`
//! (`tests/common`: [`around_null`]), standard, boxed with infinite upper bounds and with friction
//! rows, `n` from 2 to 200 and rank deficits from 1 to `n / 2`.
//!
//! * With `zᵀ b < 0` there is no solution (Farkas' lemma, checked here on the data): no solver
//!   may report `converged`, at any tolerance from `1e-2` to `1e-12`, and a `no_solution` that
//!   comes with a certificate must pass the certificate check written here.
//! * With `zᵀ b > 0` and a planted solution, no solver may report `no_solution`, every
//!   `converged` must pass the residual written here, and the pivoting solvers (Lemke and
//!   Dantzig, which process PSD problems) and enumeration (small problems) must converge.
//!
//! Each solve is capped at 1 000 iterations and 20 ms: the property holds wherever a solver
//! stops, and a diverging iterate meets the loose tolerances within that.

mod common;

use common::*;
use lcpbench_solvers::{Problem, Settings, SolveResult, SolverKind, Status};
use proptest::prelude::*;
use std::time::Duration;

const TOLERANCES: [f64; 6] = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12];

fn solve(kind: SolverKind, p: &Problem, tol: f64) -> SolveResult {
    let settings = Settings {
        tolerance: tol,
        max_iterations: 1_000,
        time_budget: Some(Duration::from_millis(20)),
        ..Settings::default()
    };
    kind.create().solve(p, &settings)
}

/// `Σ_j A_ij x_j` and `Σ_j |A_ij x_j|` for every row, from the entries read back one by one.
fn products(p: &Problem, x: &[f64]) -> Vec<(f64, f64)> {
    (0..p.n())
        .map(|i| {
            (0..p.n()).fold((0.0, 0.0), |(s, m), j| {
                let t = p.entry(i, j) * x[j];
                (s + t, m + t.abs())
            })
        })
        .collect()
}

/// The construction has no solution: `z` is non-negative, carried by rows with a finite lower
/// bound and no upper bound (no friction row), `A z = 0` to rounding, and `zᵀ b < 0` (then
/// every `f` in the bounds has `zᵀ w = zᵀ b < 0`, so some row of `z` has `w_i < 0`).
fn has_no_solution(c: &AroundNull) -> bool {
    let p = &c.problem;
    let carried = (0..p.n()).all(|i| {
        c.z[i] == 0.0
            || (c.z[i] > 0.0
                && p.friction_of(i).is_none()
                && p.lo()[i].is_finite()
                && p.hi()[i] == f64::INFINITY)
    });
    // A is symmetric, so A z is also zᵀ A; rounding against the largest entry (a `z` on one row
    // leaves that row and column of A at round-off).
    let scale = (0..p.n())
        .flat_map(|i| (0..p.n()).map(move |j| (i, j)))
        .fold(0.0f64, |m, (i, j)| m.max(p.entry(i, j).abs()));
    let zsum: f64 = c.z.iter().sum();
    let null = products(p, &c.z)
        .iter()
        .all(|&(s, _)| s.abs() <= 1e-12 * scale * zsum);
    let zb: f64 = c.z.iter().zip(p.b()).map(|(z, b)| z * b).sum();
    carried && null && zb < 0.0
}

/// A certificate that claims a proof, checked here: `y` may be non-zero only on rows with a
/// finite lower bound and no upper bound (`y >= 0`), an infinite lower and finite upper bound
/// (`y <= 0`) or no bounds, not on friction rows or rows with two finite bounds; with
/// `c = Aᵀ y`, `cᵀ f` may not grow along any unbounded direction of the bounds (a friction row's
/// `±mu f_k` adds `mu |c_t|` to the slope of its normal `k`), and `bᵀ y` plus the most `cᵀ f`
/// reaches on the finite bounds must be negative. Comparisons carry a margin of `1e-12` of the
/// magnitudes for rounding.
fn proof_holds(p: &Problem, y: &[f64]) -> bool {
    let n = p.n();
    let signs = (0..n).all(|i| {
        let (lo, hi) = (p.lo()[i], p.hi()[i]);
        y[i] == 0.0
            || (p.friction_of(i).is_none()
                && match (lo.is_finite(), hi.is_finite()) {
                    (true, false) => y[i] > 0.0,
                    (false, true) => y[i] < 0.0,
                    (false, false) => true,
                    (true, true) => false,
                })
    });
    let column = |j: usize| {
        (0..n).fold((0.0, 0.0), |(s, m), i| {
            let t = p.entry(i, j) * y[i];
            (s + t, m + t.abs())
        })
    };
    let columns: Vec<(f64, f64)> = (0..n).map(column).collect();
    let mut slope = vec![(0.0, 0.0); n];
    for fr in p.friction() {
        let (c, m) = columns[fr.row];
        slope[fr.normal].0 += fr.mu * c.abs();
        slope[fr.normal].1 += fr.mu * m;
    }
    let mut bounded = 0.0f64;
    for j in (0..n).filter(|&j| p.friction_of(j).is_none()) {
        let (c, m) = columns[j];
        let (up, up_m) = (c + slope[j].0, m + slope[j].1);
        let (lo, hi) = (p.lo()[j], p.hi()[j]);
        if (hi == f64::INFINITY && up > 1e-12 * up_m) || (lo == f64::NEG_INFINITY && c < -1e-12 * m)
        {
            return false;
        }
        let at = |v: f64| if v >= 0.0 { up * v } else { c * v };
        let ends = [lo, hi].into_iter().filter(|v| v.is_finite()).map(at);
        bounded += ends.fold(0.0, f64::max);
    }
    let by: f64 = y.iter().zip(p.b()).map(|(y, b)| y * b).sum();
    signs && by + bounded < 0.0
}

/// The relative natural-map residual with per-row scales, written here: row `i`'s step
/// `|f_i − clamp(f_i − w_i / d_i)|` against `(|b_i| + Σ_j |A_ij f_j|) / d_i`.
fn relative_residual(p: &Problem, f: &[f64]) -> f64 {
    let rows = products(p, f);
    (0..p.n())
        .map(|i| {
            let (af, mag) = rows[i];
            let w = af + p.b()[i];
            let d = p.entry(i, i);
            let d = if d > 0.0 { d } else { 1.0 };
            let (lo, hi) = match p.friction_of(i) {
                Some((k, mu)) => (-mu * f[k].max(0.0), mu * f[k].max(0.0)),
                None => (p.lo()[i], p.hi()[i]),
            };
            let x = f[i] - w / d;
            let step = if x < lo {
                (f[i] - lo).abs()
            } else if x > hi {
                (f[i] - hi).abs()
            } else {
                w.abs() / d
            };
            let scale = (p.b()[i].abs() + mag) / d;
            if step == 0.0 {
                0.0
            } else {
                step / scale
            }
        })
        .fold(0.0, f64::max)
}

proptest! {
    #![proptest_config(config(24))]

    #[test]
    fn no_solver_converges_on_a_problem_without_solution(c in around_null_strategy(200, false)) {
        prop_assert!(has_no_solution(&c), "the construction must have no solution");
        for kind in SolverKind::all() {
            for tol in TOLERANCES {
                let r = solve(kind, &c.problem, tol);
                prop_assert!(
                    r.status != Status::Converged,
                    "{} at {tol:e}: converged, residual {:e} (ours {:e}), ‖f‖∞ {:e}",
                    kind.name(),
                    r.residuals.natural_map_rel,
                    relative_residual(&c.problem, &r.f),
                    r.f.iter().fold(0.0f64, |m, v| m.max(v.abs()))
                );
                if let Some(cert) = r.certificate.as_ref().filter(|c| c.proves_no_solution) {
                    prop_assert!(proof_holds(&c.problem, &cert.y), "{}: {cert:?}", kind.name());
                }
            }
        }
    }

}

proptest! {
    #![proptest_config(config(16))]

    #[test]
    fn singular_problems_with_a_solution_still_converge(c in around_null_strategy(60, true)) {
        let p = &c.problem;
        prop_assert!(relative_residual(p, c.solution.as_ref().unwrap()) <= 1e-12);
        for kind in SolverKind::all() {
            for tol in [1e-4, 1e-8] {
                let r = solve(kind, p, tol);
                prop_assert!(
                    !matches!(r.status, Status::NoSolution { .. }),
                    "{} at {tol:e} on a problem with a planted solution: {}",
                    kind.name(),
                    r.status
                );
                if r.status == Status::Converged {
                    let ours = relative_residual(p, &r.f);
                    prop_assert!(ours <= 2.0 * tol, "{} at {tol:e}: ours {ours:e}", kind.name());
                }
                let must = if kind == SolverKind::Lemke || kind == SolverKind::Dantzig {
                    p.friction().is_empty()
                } else if kind == SolverKind::Enumeration {
                    p.is_standard() && p.n() <= 9
                } else {
                    false
                };
                if must {
                    prop_assert_eq!(&r.status, &Status::Converged, "{} at {:e}", kind.name(), tol);
                }
            }
        }
    }
}

/// The floating-point edges of the report: row scales that overflow, underflow or are
/// subnormal, and `A = 0`, all with `b < 0` (no solution): never `converged`, at any tolerance.
#[test]
fn extreme_row_scales_never_converge_without_a_solution() {
    use faer::Mat;
    let diag = |d: f64, b: f64| {
        Problem::lcp(
            Mat::from_fn(2, 2, |i, j| if i == j { d } else { 0.0 }),
            vec![b, b],
        )
        .unwrap()
    };
    let problems = [
        diag(1e-300, -1e10),
        diag(5e-324, -1.0),
        diag(0.0, -1.0),
        Problem::lcp(
            Mat::from_fn(2, 2, |i, j| [[1.0, -1.0], [-1.0, 1.0]][i][j]),
            vec![-1.0, -1.0],
        )
        .unwrap(),
    ];
    for p in &problems {
        for kind in SolverKind::all() {
            for tol in TOLERANCES {
                let r = solve(kind, p, tol);
                assert_ne!(
                    r.status,
                    Status::Converged,
                    "{} at {tol:e}: {:?}",
                    kind.name(),
                    r.f
                );
            }
        }
    }
}

/// Clarabel solves friction rows through a convex relaxation, whose certificate of
/// infeasibility says nothing about the boxed LCP: on singular friction problems with a planted
/// solution, where the relaxation is often unbounded, it must not answer `no_solution`.
#[test]
fn a_relaxation_certificate_is_no_proof() {
    let mut unbounded = 0;
    for seed in 0..12 {
        for (n, deficit) in [(6, 3), (15, 7), (30, 15)] {
            let c = around_null(NullKind::Friction, n, deficit, true, 0.0, seed);
            let r = solve(SolverKind::Clarabel, &c.problem, 1e-8);
            assert!(
                !matches!(r.status, Status::NoSolution { .. }),
                "n = {n}, seed {seed}: {}",
                r.status
            );
            unbounded += usize::from(r.status.reason().is_some_and(|s| s.contains("unbounded")));
        }
    }
    assert!(
        unbounded > 0,
        "no case exercised the relaxation's certificate"
    );
}

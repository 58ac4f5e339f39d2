//! Property tests on complementarity: planted problems, every solver, honest statuses.

mod common;

use common::*;
use lcpbench_solvers::{Problem, Settings, SolveResult, SolverKind, Status};
use proptest::prelude::*;

const TOL: f64 = 1e-8;

fn solve(kind: SolverKind, p: &Problem) -> SolveResult {
    let settings = Settings {
        tolerance: TOL,
        max_iterations: 5_000,
        ..Settings::default()
    };
    kind.create().solve(p, &settings)
}

/// The relative natural-map residual of `f`, written here from its definition (the module
/// documentation of `lcpbench_solvers::metrics`) rather than taken from the library, so that a
/// wrong residual in the library cannot vouch for itself:
/// `max_i |f_i − mid(lo_i, hi_i, f_i − w_i / d_i)| / s_i` with `s_i = (|b_i| + Σ_j |A_ij f_j|) / d_i`,
/// `d_i = A_ii` when positive (else the row's largest magnitude, or 1), `0/0 = 0`, `x/0 = ∞`;
/// infinite for a non-finite `f`.
/// `A` is read entry by entry and `w_i` summed with Neumaier's compensation.
fn independent_residual(p: &Problem, f: &[f64]) -> f64 {
    let n = p.n();
    // A non-finite impulse is no answer at all.
    if f.len() != n || f.iter().any(|v| !v.is_finite()) {
        return f64::INFINITY;
    }
    let mut worst = 0.0f64;
    for i in 0..n {
        let row: Vec<f64> = (0..n).map(|j| p.entry(i, j)).collect();
        let d = if row[i] > 0.0 {
            row[i]
        } else {
            let m = row.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if m > 0.0 {
                m
            } else {
                1.0
            }
        };
        let (mut w, mut c) = (0.0f64, 0.0f64);
        for t in row.iter().zip(f).map(|(a, x)| a * x).chain([p.b()[i]]) {
            let u = w + t;
            c += if w.abs() >= t.abs() {
                (w - u) + t
            } else {
                (t - u) + w
            };
            w = u;
        }
        let w = w + c;
        let (lo, hi) = match p.friction_of(i) {
            Some((k, mu)) => (-mu * f[k].max(0.0), mu * f[k].max(0.0)),
            None => (p.lo()[i], p.hi()[i]),
        };
        let step = (f[i] - (f[i] - w / d).max(lo).min(hi)).abs();
        let scale =
            (p.b()[i].abs() + row.iter().zip(f).map(|(a, x)| (a * x).abs()).sum::<f64>()) / d;
        let rel = if step == 0.0 {
            0.0
        } else if scale == 0.0 {
            f64::INFINITY
        } else {
            step / scale
        };
        // NaN (an overflowing velocity) counts as infinitely wrong.
        worst = if rel.is_nan() {
            f64::INFINITY
        } else {
            worst.max(rel)
        };
    }
    worst
}

/// The status must agree with the residual recomputed here from the returned `f`. The two
/// computations round differently, so each verdict allows a relative margin of 1 % on `TOL`.
fn check_honest(kind: SolverKind, p: &Problem, r: &SolveResult) -> Result<(), TestCaseError> {
    prop_assert_eq!(r.f.len(), p.n(), "{}: f has the wrong length", kind.name());
    let recomputed = independent_residual(p, &r.f);
    if r.status == Status::Converged {
        prop_assert!(
            recomputed <= 1.01 * TOL,
            "{} claims convergence at residual {:e}",
            kind.name(),
            recomputed
        );
    } else if !matches!(r.status, Status::Unsupported { .. }) {
        prop_assert!(
            recomputed > 0.99 * TOL,
            "{} reports {} although the residual {:e} is within tolerance",
            kind.name(),
            r.status,
            recomputed
        );
    }
    Ok(())
}

/// The residual written here agrees with the library's on planted problems and perturbations of
/// their solutions (a check of the check: both follow the same definition).
#[test]
fn the_independent_residual_matches_the_definition_the_library_uses() {
    for seed in 0..8 {
        let g = lcpbench_solvers::generate::generate(
            lcpbench_solvers::generate::Family::Spd { cond: 1e2 },
            6,
            seed,
        );
        let mut f = g.solution.unwrap();
        for (i, v) in f.iter_mut().enumerate() {
            *v += 1e-3 * (i as f64 - 2.5);
        }
        let ours = independent_residual(&g.problem, &f);
        let theirs = lcpbench_solvers::residuals(&g.problem, &f).natural_map_rel;
        assert!(
            (ours - theirs).abs() <= 1e-9 * theirs.max(1e-300),
            "{ours} vs {theirs}"
        );
    }
}

fn max_diff(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).fold(0.0, |m, (a, b)| m.max((a - b).abs()))
}

fn norm_inf(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, a| m.max(a.abs()))
}

proptest! {
    #![proptest_config(config(24))]

    #[test]
    fn every_solver_is_honest_on_spd(planted in planted_spd(12)) {
        for kind in SolverKind::all() {
            let r = solve(kind, &planted.problem);
            check_honest(kind, &planted.problem, &r)?;
        }
    }

    #[test]
    fn every_solver_is_honest_on_rank_deficient_psd(planted in planted_psd(12)) {
        for kind in SolverKind::all() {
            let r = solve(kind, &planted.problem);
            check_honest(kind, &planted.problem, &r)?;
        }
    }

    #[test]
    fn every_solver_is_honest_on_p_matrices(planted in planted_p_matrix(12)) {
        for kind in SolverKind::all() {
            let r = solve(kind, &planted.problem);
            check_honest(kind, &planted.problem, &r)?;
        }
    }

    #[test]
    fn pivoting_and_clarabel_solve_spd(planted in planted_spd(12)) {
        for kind in [SolverKind::Lemke, SolverKind::Dantzig, SolverKind::Clarabel] {
            let r = solve(kind, &planted.problem);
            prop_assert_eq!(&r.status, &Status::Converged, "{}", kind.name());
            // SPD: the solution is unique, so it is the planted one.
            let scale = 1.0 + norm_inf(&planted.solution);
            prop_assert!(max_diff(&r.f, &planted.solution) <= 1e-5 * scale,
                "{}: f differs from the planted solution by {:e}",
                kind.name(), max_diff(&r.f, &planted.solution));
        }
    }

    #[test]
    fn pivoting_solvers_solve_p_matrices(planted in planted_p_matrix(12)) {
        for kind in [SolverKind::Lemke, SolverKind::Dantzig] {
            let r = solve(kind, &planted.problem);
            prop_assert_eq!(&r.status, &Status::Converged, "{}", kind.name());
            // P-matrix: unique solution.
            prop_assert!(max_diff(&r.f, &planted.solution) <= 1e-6 * (1.0 + norm_inf(&planted.solution)));
        }
        let r = solve(SolverKind::Clarabel, &planted.problem);
        prop_assert!(matches!(r.status, Status::Unsupported { .. }), "clarabel: {}", r.status);
    }

    #[test]
    fn lemke_and_clarabel_agree_on_spd(planted in planted_spd(12)) {
        let lemke = solve(SolverKind::Lemke, &planted.problem);
        let qp = solve(SolverKind::Clarabel, &planted.problem);
        prop_assert!(lemke.status.is_converged() && qp.status.is_converged());
        let scale = 1.0 + norm_inf(&lemke.f);
        prop_assert!(max_diff(&lemke.f, &qp.f) <= 1e-6 * scale,
            "lemke and clarabel differ by {:e}", max_diff(&lemke.f, &qp.f));
    }

    #[test]
    fn solutions_are_invariant_under_symmetric_permutation(
        planted in planted_spd(12),
        seed in any::<u64>(),
    ) {
        let perm = permutation(planted.problem.n(), seed);
        let permuted = planted.problem.permuted(&perm);
        for kind in [SolverKind::Lemke, SolverKind::Dantzig, SolverKind::Clarabel, SolverKind::Pgs] {
            let r0 = solve(kind, &planted.problem);
            let r1 = solve(kind, &permuted);
            if !(r0.status.is_converged() && r1.status.is_converged()) {
                prop_assert!(kind == SolverKind::Pgs, "{}: {} / {}", kind.name(), r0.status, r1.status);
                continue;
            }
            let back: Vec<f64> = perm.iter().map(|&p| r0.f[p]).collect();
            let scale = 1.0 + norm_inf(&r0.f);
            prop_assert!(max_diff(&back, &r1.f) <= 1e-5 * scale, "{}", kind.name());
        }
    }

    #[test]
    fn boxed_results_respect_their_bounds(problem in boxed_spd(12)) {
        for kind in SolverKind::all() {
            let r = solve(kind, &problem);
            check_honest(kind, &problem, &r)?;
            if r.status.is_converged() {
                for i in 0..problem.n() {
                    prop_assert!(r.f[i] >= problem.lo()[i] - 1e-9 && r.f[i] <= problem.hi()[i] + 1e-9,
                        "{}: f[{i}] = {} outside [{}, {}]", kind.name(), r.f[i], problem.lo()[i], problem.hi()[i]);
                }
            }
        }
        // SPD boxed problems have a unique solution: Dantzig and PGS must find it.
        for kind in [SolverKind::Dantzig, SolverKind::Pgs] {
            prop_assert!(solve(kind, &problem).status.is_converged(), "{}", kind.name());
        }
    }

    #[test]
    fn friction_results_lie_in_the_cone(problem in friction_contacts(4)) {
        for kind in SolverKind::all() {
            let r = solve(kind, &problem);
            check_honest(kind, &problem, &r)?;
            if r.status.is_converged() {
                // A converged answer's friction row may leave its cone by at most what the
                // residual's definition allows: TOL times the row's scale
                // s_i = (|b_i| + Σ_j |A_ij f_j|) / A_ii.
                for fr in problem.friction() {
                    let i = fr.row;
                    let d = problem.entry(i, i);
                    let scale = ((0..problem.n())
                        .map(|j| (problem.entry(i, j) * r.f[j]).abs())
                        .sum::<f64>()
                        + problem.b()[i].abs())
                        / d;
                    let limit = fr.mu * r.f[fr.normal].max(0.0);
                    prop_assert!(r.f[i].abs() <= limit + TOL * scale * (1.0 + 1e-9),
                        "{}: |f[{i}]| = {} against mu f_n = {limit} (row scale {scale})",
                        kind.name(), r.f[i].abs());
                }
            }
        }
        // Lemke's sliding reduction of friction rows is copositive, and Lemke processes a
        // copositive M when qᵀz >= 0 on SOL(0, M) (Anitescu–Potra 1997; Cottle–Pang–Stone §4.4).
        // With A positive definite that set holds only sliding speeds, orthogonal to q: Lemke,
        // a finite method, must converge on every instance.
        let r = solve(SolverKind::Lemke, &problem);
        prop_assert_eq!(&r.status, &Status::Converged, "lemke: {:?}", r.status);
    }
}

/// Newton's target: relative residual 1e-10 in at most 30 iterations on the planted families.
fn newton_reaches_1e_10(p: &Problem) -> Result<(), TestCaseError> {
    let settings = Settings {
        tolerance: 1e-10,
        max_iterations: 30,
        ..Settings::default()
    };
    for kind in [SolverKind::NewtonFb, SolverKind::NewtonMin] {
        let r = kind.create().solve(p, &settings);
        prop_assert_eq!(&r.status, &Status::Converged, "{}", kind.name());
        prop_assert!(r.iterations <= 30 && r.residuals.natural_map_rel <= 1e-10);
    }
    Ok(())
}

proptest! {
    #![proptest_config(config(16))]

    #[test]
    fn newton_converges_on_spd(planted in planted_spd(40)) {
        newton_reaches_1e_10(&planted.problem)?;
    }

    #[test]
    fn newton_converges_on_rank_deficient_psd(planted in planted_psd(40)) {
        newton_reaches_1e_10(&planted.problem)?;
    }

    #[test]
    fn newton_converges_on_p_matrices(planted in planted_p_matrix(40)) {
        newton_reaches_1e_10(&planted.problem)?;
    }

    #[test]
    fn accelerated_and_block_solvers_find_the_spd_solution(planted in planted_spd(20)) {
        // SPD: the solution is unique, so every converged answer is the planted one.
        for kind in [SolverKind::Apgd, SolverKind::Nncg, SolverKind::Nsgs, SolverKind::Enumeration] {
            if kind == SolverKind::Enumeration && planted.problem.n() > 12 {
                continue;
            }
            let r = solve(kind, &planted.problem);
            prop_assert_eq!(&r.status, &Status::Converged, "{}", kind.name());
            let scale = 1.0 + norm_inf(&planted.solution);
            prop_assert!(max_diff(&r.f, &planted.solution) <= 1e-5 * scale,
                "{}: f differs from the planted solution by {:e}",
                kind.name(), max_diff(&r.f, &planted.solution));
        }
    }

    #[test]
    fn enumeration_solves_every_small_p_matrix_problem(planted in planted_p_matrix(10)) {
        let r = solve(SolverKind::Enumeration, &planted.problem);
        prop_assert_eq!(&r.status, &Status::Converged);
        prop_assert!(max_diff(&r.f, &planted.solution) <= 1e-6 * (1.0 + norm_inf(&planted.solution)));
    }
}

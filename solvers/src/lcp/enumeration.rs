//! Enumeration of complementary bases: a complete method for small LCPs (Siconos' `ENUM`).
//!
//! A *complementary basis* assigns every row one state: at its lower bound, at its upper bound, or
//! free (`w_i = 0`). Each state is one linear equation, so a basis fixes `f` through an `n × n`
//! linear system:
//!
//! ```text
//! free:             (A f + b)_i = 0
//! lower / upper:    f_i = lo_i  /  f_i = hi_i                 (fixed bounds)
//!                   f_i = −mu f_k  /  f_i = mu f_k            (friction row i of normal row k)
//! ```
//!
//! Every solution of the boxed LCP solves the system of at least one basis, so trying all of them
//! and keeping the candidate whose local natural-map residual is smallest finds a solution
//! whenever one exists and the bases that carry it are non-singular (Murty 1988, §1.2;
//! Cottle–Pang–Stone 1992, §1.1). Bases are tried in order of the number of rows whose state
//! differs from a guess (a projected Jacobi step from the warm start), so a good guess ends the
//! search after a few systems.
//!
//! * **Problem class**: any `A` (no symmetry, definiteness or copositivity needed), standard and
//!   boxed LCP with friction rows, up to [`MAX_BASES`] complementary bases: a standard LCP up to
//!   `n = 15`; a row with two finite bounds or a friction row counts three states, a row with one
//!   finite bound two, a free or fixed row one. Larger problems are `Unsupported`.
//! * **Free (equality) rows** (`lo = −∞`, `hi = +∞`, a joint's `w_i = 0`) have only the interior
//!   state, the same in every basis (Siconos' `mlcp_enum` keeps the equations of an MLCP's free
//!   part in every system it solves). Their equations are therefore solved once, not once per
//!   basis: the free rows are eliminated through the Schur complement of `A_FF`
//!   ([`crate::lcp::free_rows`]), the bases of the other rows are enumerated on
//!   `M = A_CC − A_CF A_FF⁻¹ A_FC`, and the free impulses are recovered from the best candidate
//!   (whose basis is re-solved on `A` itself when it misses the tolerance, so the complement's
//!   round-off does not stay in the answer).
//!   Redundant joints make every basis of the whole problem singular (their rows of `A` are
//!   dependent); the elimination keeps a regular block of them and drops the dependent rows
//!   when their rows of `M` vanish (consistent joints), so the bases stay regular. When a
//!   dependent free row stays (inconsistent joints, or an `A` that is not semidefinite), its
//!   bases are singular and the search ends `Stalled`, never `NoSolution`.
//! * **Cost**: `O(n³)` per basis (a small Gaussian elimination), at most `2ⁿ` bases for the
//!   standard LCP: about 30 ms for an exhaustive search at `n = 15`. [`Settings::max_iterations`]
//!   counts bases (the default `10 000` is exhaustive up to `n = 13`; raise it for `n = 14, 15`).
//! * **Outcomes**: a candidate whose local relative residual is below `tolerance / 100` ends the
//!   search. After an exhaustive search that found none, `Stalled` when the best candidate is
//!   within round-off of a solution (local residual below `1e-10` of the scale, whatever the
//!   tolerance), else `NoSolution` when every basis was non-singular (that is a proof, up to
//!   rounding: a solution would have been one of the candidates); otherwise `Stalled`, since a
//!   solution may live on a singular basis. The best candidate is returned either way and the
//!   shared residual decides.
//! * **Warm start**: used only to order the search.
//!
//! The kernel, which also solves NSGS's per-contact blocks ([`crate::Nsgs`]), is in
//! [`crate::lcp::local`].
//!
//! References: K. G. Murty, *Linear Complementarity, Linear and Nonlinear Programming*, 1988;
//! V. Acary, O. Bonnefon et al., Siconos numerics, `lcp_enum.c` and `mlcp_enum.c`.

use crate::lcp::free_rows::{polish_on_basis, FreeRows};
use crate::lcp::local::{
    basis_count, dense_matrix, enumerate, problem_bounds, LocalLcp, Workspace,
};
use crate::problem::metrics::impulse_scale;
use crate::problem::Problem;
use crate::solver::{
    initial_impulse, solve_by_islands, Monitor, Outcome, Settings, SolveResult, Solver,
};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "any LCP or boxed LCP with friction rows; free (equality) rows have only the interior state, eliminated first (Schur complement of A_FF, redundant ones dropped); per island up to 32768 complementary bases (standard LCP n <= 15); complete";

/// The registry's entry of `enum`.
pub static ENUM: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "enum",
    summary: "enumeration of complementary bases (complete, small problems)",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "complementary bases tried",
    iterative: false,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(Enumeration)),
};

/// Largest number of complementary bases the solver enumerates (`2¹⁵`).
pub const MAX_BASES: usize = 1 << 15;

/// Enumeration of complementary bases. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Enumeration;

impl Solver for Enumeration {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &ENUM
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        solve_by_islands(problem, settings, ISLAND_ROWS, |island, settings| {
            self.solve_dense(island, settings)
        })
    }
}

/// Largest island handed to the enumeration (its basis count is then checked against
/// [`MAX_BASES`]).
const ISLAND_ROWS: usize = 64;

impl Enumeration {
    /// One island: its free rows eliminated ([`FreeRows`]), the bases of the other rows
    /// enumerated, the free impulses recovered.
    fn solve_dense(&mut self, island: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(island, settings);
        let free = FreeRows::of(island);
        let problem = free.rows(island);
        let n = problem.n();
        let bounds = problem_bounds(problem);
        let total = basis_count(&bounds);
        if total > MAX_BASES {
            let shown = if total == usize::MAX {
                "more than 2^64".to_string()
            } else {
                total.to_string()
            };
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(format!(
                    "{shown} complementary bases; enumeration is limited to {MAX_BASES} \
                     (a standard LCP with n <= 15)"
                )),
            );
        }
        let mat = dense_matrix(problem);
        let d = problem.diagonal_scale();
        let lcp = LocalLcp {
            m: n,
            mat: &mat,
            q: problem.b(),
            bounds: &bounds,
            d: &d,
        };
        let f0 = free.restrict(&initial_impulse(island, settings));
        let mut ws = Workspace::default();
        lcp.residual_and_guess(&f0, &mut ws);
        let guess = std::mem::take(&mut ws.guess);
        // Accept on the local residual relative to the shared scale's ingredients.
        let scale = impulse_scale(problem);
        let accept = 1e-2 * settings.tolerance * scale;
        let mut stop: Option<Outcome> = None;
        let result = enumerate(&lcp, &guess, accept, &mut ws, |tried| {
            if tried >= settings.max_iterations {
                stop = Some(Outcome::IterationLimit);
                false
            } else if tried % 64 == 0 && monitor.out_of_time() {
                stop = Some(Outcome::TimeLimit);
                false
            } else {
                true
            }
        });
        let f = if result.found { ws.best } else { f0 };
        // A claim of no solution must not follow from the tolerance: a best candidate within
        // round-off of a solution (1e-10 of the scale; the acceptance at the default 1e-8)
        // counts as one whatever the tolerance asked for.
        let claim = accept.max(1e-10 * scale);
        let outcome = match stop {
            Some(o) => o,
            None if result.residual <= accept => Outcome::Stopped,
            None if result.residual <= claim => Outcome::Stalled(format!(
                "the best of {} complementary bases solves the problem to a local residual of \
                 {:.3e} of the scale, within round-off but short of the tolerance",
                result.tried,
                result.residual / scale
            )),
            None if result.singular == 0 => Outcome::NoSolution(format!(
                "all {} complementary bases enumerated, every one non-singular, and none \
                 satisfies the complementarity conditions",
                result.tried
            )),
            None => Outcome::Stalled(format!(
                "all {} complementary bases enumerated; none satisfies the complementarity \
                 conditions, but {} were singular, so a solution on a singular basis is not \
                 excluded",
                result.tried, result.singular
            )),
        };
        let outcome = free.annotate(outcome);
        let mut f = free.expand(f);
        if matches!(outcome, Outcome::Stopped | Outcome::Stalled(_)) && free.eliminated() {
            polish_on_basis(island, &mut f, settings.tolerance, &mut monitor);
        }
        monitor.record(result.tried, &f);
        monitor.finish(f, result.tried, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::generate::{generate, Family};
    use crate::test_util::lcp;
    use crate::{FrictionRow, Status};
    use faer::Mat;

    #[test]
    fn finds_a_solution_where_lemke_ray_terminates() {
        let p = crate::test_util::three_solution_lcp();
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged, "{}", r.status);
        assert!(r.residuals.natural_map <= 1e-12);
        let hit = crate::test_util::THREE_SOLUTIONS
            .iter()
            .any(|s| s.iter().zip(&r.f).all(|(x, y)| (x - y).abs() < 1e-12));
        assert!(hit, "{:?} is none of the three solutions", r.f);
    }

    #[test]
    fn solves_planted_families() {
        for (family, n) in [
            (Family::Spd { cond: 1e3 }, 12),
            (Family::PMatrix, 12),
            (Family::PsdRankDeficient { rank: 5 }, 10),
            (Family::Murty, 8),
        ] {
            let g = generate(family, n, 3);
            let r = Enumeration.solve(&g.problem, &Settings::default());
            assert_eq!(r.status, Status::Converged, "{family:?}");
            if !matches!(family, Family::PsdRankDeficient { .. }) {
                for (x, y) in r.f.iter().zip(g.solution.as_ref().unwrap()) {
                    assert!((x - y).abs() < 1e-8, "{family:?}");
                }
            }
        }
    }

    /// A tolerance below round-off is not met, but it does not turn a solvable problem into a
    /// claim that there is no solution: an SPD problem always has one.
    #[test]
    fn a_tolerance_below_round_off_claims_nothing() {
        let settings = Settings {
            tolerance: 1e-300,
            ..Settings::default()
        };
        // Seeds whose solution leaves a round-off residual (others meet even 1e-300 exactly).
        for seed in [3, 4, 9] {
            let g = generate(Family::Spd { cond: 1e2 }, 5, seed);
            let r = Enumeration.solve(&g.problem, &settings);
            assert_ne!(r.status.name(), "no_solution", "seed {seed}: {}", r.status);
            for (x, y) in r.f.iter().zip(g.solution.as_ref().unwrap()) {
                assert!((x - y).abs() < 1e-12, "seed {seed}: {:?}", r.f);
            }
        }
    }

    #[test]
    fn proves_infeasibility_when_every_basis_is_regular() {
        // A = [[-1]], b = [-1]: w = -f - 1 < 0 for every f >= 0.
        let p = lcp(&[&[-1.0]], &[-1.0]);
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status.name(), "no_solution", "{}", r.status);
        // A singular basis: A = 0, b = -1 has no solution, but not by proof.
        let p = lcp(&[&[0.0]], &[-1.0]);
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status.name(), "stalled", "{}", r.status);
    }

    #[test]
    fn friction_rows_and_size_limit() {
        // Normal pushed in, tangent pushed hard (b_t = 2 drives f_t negative): it slides at
        // f_t = -mu f_n with f_n = 1, f_t = -0.5, w_t = 1.5 >= 0 at the lower bound.
        let p = Problem::boxed(
            Mat::identity(2, 2),
            vec![-1.0, 2.0],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert!((r.f[0] - 1.0).abs() < 1e-12 && (r.f[1] + 0.5).abs() < 1e-12);
        let g = generate(Family::Spd { cond: 10.0 }, 16, 1);
        let r = Enumeration.solve(&g.problem, &Settings::default());
        assert_eq!(r.status.name(), "unsupported");
    }
}

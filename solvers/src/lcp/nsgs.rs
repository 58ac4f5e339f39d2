//! Nonsmooth (block) Gauss–Seidel over contacts (NSGS) for box friction.
//!
//! The rows are grouped into blocks, one per contact: a non-friction row `k` and every friction
//! row naming `k` as its normal (normal + two tangents for box friction); other rows are blocks
//! of one. A sweep visits the blocks in order and solves each block's boxed LCP *exactly* with
//! the other impulses fixed:
//!
//! ```text
//! w_B = A_BB f_B + q_B,   q_B = b_B + Σ_{j ∉ B} A_Bj f_j,   f_k ∈ [lo_k, hi_k],  |f_t| <= mu f_k,
//! ```
//!
//! by enumerating its complementary bases (at most 2 · 3 · 3 = 18 linear systems of size 3 for a
//! normal and two tangents, [`crate::Enumeration`]'s kernel), starting from the basis the current
//! impulse suggests. A block of one is the exact scalar update `mid(lo, hi, f_i − w_i / A_ii)`.
//! If no basis of a block is exact (a singular `A_BB`), the candidate with the smallest local
//! residual is taken when it improves on the current one; blocks with more than 243 bases (more
//! than four friction rows on one normal) fall back to 20 local PGS sweeps.
//!
//! * **Problem class**: standard and boxed LCP with friction rows. Without friction rows it is
//!   PGS (Cryer's convergence for SPD `A`); with friction it is the block Gauss–Seidel of Jean and
//!   Moreau's NSGS on the box-friction model, a fixed point without a general convergence proof
//!   (measured: converges on resting stacks where PGS creeps, because each contact's normal and
//!   friction impulses are balanced together).
//! * **Free (equality) rows**: the blocks are built from the friction list alone, so a joint's
//!   free row (which no friction row names) is a block of one, solved exactly by the unclamped
//!   update `f_i − w_i / A_ii`: Gauss–Seidel on the joints, whose rate falls with the
//!   conditioning of `A` (chains with large mass ratios). A free row that friction rows do name
//!   is the normal of their block and takes the single state `w_i = 0` in its enumeration;
//!   their bounds `±mu · max(f_i, 0)` then read its impulse as the box model says.
//! * **Cost**: per sweep one pass over the stored entries of `A` for the `q_B` (`O(nnz)`), `O(1)`
//!   small systems per contact (each block's `A_BB`, diagonal scales and bounds are extracted
//!   once per solve; the enumeration's buffers are reused across blocks), and the shared
//!   residual for the stopping test (another `O(nnz)` pass).
//! * **Stopping rule**: the shared relative residual is at most the tolerance. It is recomputed
//!   only after a sweep in which every row's natural-map step at the running iterate (measured
//!   as each block starts) was within ten times the tolerance of that row's own scale
//!   ([`relative_row_error`], the per-row measure of the shared residual), and after the first
//!   sweep (decoupled contacts are solved exactly by it), which saves that `O(nnz)` pass on the
//!   sweeps far from convergence. The
//!   starting impulse is measured too, so a converged warm start takes no sweep.
//! * **Never spins**: when the shared residual, measured every [`STAGNATION_MEASURE_EVERY`]
//!   sweeps, has not reached a new low (1 % below the best) in
//!   [`FIRST_ORDER_STAGNATION_WINDOW`] iterations, the solve stops `Stalled`
//!   ([`crate::solver`]'s stagnation rule).
//! * **Warm start**: uses [`Settings::warm_start`], projected.
//!
//! References: M. Jean, *The non-smooth contact dynamics method*, CMAME 177, 1999; V. Acary,
//! M. Brémond, O. Huber, *On solving contact problems with Coulomb friction: formulations and
//! numerical comparisons*, 2018 (NSGS in Siconos' FC3D).

use crate::lcp::local::{basis_count, enumerate, LocalBound, LocalLcp, Workspace as EnumWorkspace};
use crate::problem::diagonal::usable_diagonal;
use crate::problem::metrics::{relative_row_error, residuals_and_velocity};
use crate::problem::Problem;
use crate::solver::{
    initial_impulse, Monitor, Outcome, Settings, SolveResult, Solver, Stagnation,
    FIRST_ORDER_STAGNATION_WINDOW, STAGNATION_MEASURE_EVERY,
};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "LCP, boxed LCP, friction rows (each contact's normal + tangents solved exactly per sweep), free (equality) rows as exact blocks of one; SPD A";

/// The registry's entry of `nsgs`.
pub static NSGS: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "nsgs",
    summary: "block Gauss-Seidel over contacts, each block solved exactly",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "sweeps over the rows",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(Nsgs)),
};

/// The shared residual is measured after a sweep whose rows were all within this many times the
/// tolerance at the running iterate: that measure is taken as each block starts, mid-sweep, and
/// runs a few times above the residual at the sweep's end (at 1× the sweeps went on 2–4 % longer
/// than needed on the generated families).
const MEASURE_WITHIN: f64 = 10.0;

/// Largest number of complementary bases a block is enumerated over: `3⁵ = 243`, a normal row
/// with two friction rows (18 bases) and room for blocks of up to five rows of three states;
/// beyond that the `O(m³)` work per basis outgrows the local sweeps used instead.
const MAX_BLOCK_BASES: usize = 243;

/// NSGS. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Nsgs;

/// The rows of each block: the normal (or lone) row first.
fn blocks(problem: &Problem) -> Vec<Vec<usize>> {
    let n = problem.n();
    let mut of_normal: Vec<Vec<usize>> = vec![Vec::new(); n];
    for fr in problem.friction() {
        of_normal[fr.normal].push(fr.row);
    }
    (0..n)
        .filter(|&i| problem.friction_of(i).is_none())
        .map(|i| {
            let mut b = vec![i];
            b.extend(&of_normal[i]);
            b
        })
        .collect()
}

/// A block's data that do not change during a solve: its rows, the local matrix `A_BB`
/// (row-major), the rows' diagonal scales and local bounds.
struct Block {
    rows: Vec<usize>,
    mat: Vec<f64>,
    d: Vec<f64>,
    bounds: Vec<LocalBound>,
    /// More than [`MAX_BLOCK_BASES`] complementary bases: local PGS sweeps instead.
    many_bases: bool,
}

impl Block {
    fn new(problem: &Problem, rows: Vec<usize>, local: &[usize], scale: &[f64]) -> Self {
        let m = rows.len();
        let mut mat = vec![0.0; m * m];
        for (r, &i) in rows.iter().enumerate() {
            for (j, v) in problem.row(i).iter() {
                let c = local[j];
                if c < m && rows[c] == j {
                    mat[r * m + c] = v;
                }
            }
        }
        let d = rows.iter().map(|&i| scale[i]).collect();
        let bounds: Vec<LocalBound> = rows
            .iter()
            .map(|&i| match problem.friction_of(i) {
                Some((_, mu)) => LocalBound::Friction { normal: 0, mu },
                None => LocalBound::Fixed(problem.lo()[i], problem.hi()[i]),
            })
            .collect();
        let many_bases = basis_count(&bounds) > MAX_BLOCK_BASES;
        Self {
            rows,
            mat,
            d,
            bounds,
            many_bases,
        }
    }
}

/// Workspace of the block solves (reused from block to block and sweep to sweep).
#[derive(Default)]
struct BlockWorkspace {
    q: Vec<f64>,
    x: Vec<f64>,
    enumeration: EnumWorkspace,
}

/// `w_i = b_i + A_i · f` and the magnitude `|b_i| + Σ_j |A_ij f_j|` of its terms (the row's
/// scale in the shared residual), from [`crate::Row::dot_and_magnitude`].
#[inline]
fn velocity_of_row(problem: &Problem, i: usize, f: &[f64]) -> (f64, f64) {
    let b = problem.b()[i];
    let (af, magnitude) = problem.row(i).dot_and_magnitude(f);
    (af + b, magnitude + b.abs())
}

impl Nsgs {
    /// Solve `block` exactly (or as well as it can) with the other impulses fixed. Returns the
    /// largest [`relative_row_error`] of the block's rows at the impulse it started from (the
    /// sweep's running iterate), the stopping rule's per-row measure.
    fn solve_block(
        problem: &Problem,
        block: &Block,
        diag: &[f64],
        f: &mut [f64],
        ws: &mut BlockWorkspace,
    ) -> f64 {
        let rows = &block.rows[..];
        let m = rows.len();
        if m == 1 {
            let i = rows[0];
            let (wi, ti) = velocity_of_row(problem, i, f);
            let error = relative_row_error(problem, i, f, wi, ti);
            if diag[i] > 0.0 {
                let (lo, hi) = problem.bounds_at(i, f);
                f[i] = (f[i] - wi / diag[i]).max(lo).min(hi);
            }
            return error;
        }
        let mat = &block.mat[..];
        ws.q.clear();
        ws.x.clear();
        let mut error: f64 = 0.0;
        for &i in rows {
            let (wi, ti) = velocity_of_row(problem, i, f);
            error = error.max(relative_row_error(problem, i, f, wi, ti));
            ws.q.push(wi);
            ws.x.push(f[i]);
        }
        // q_B = w_B − A_BB f_B.
        for r in 0..m {
            let s: f64 = (0..m).map(|c| mat[r * m + c] * ws.x[c]).sum();
            ws.q[r] -= s;
        }
        if block.many_bases {
            for _ in 0..20 {
                for r in 0..m {
                    if mat[r * m + r] <= 0.0 {
                        continue;
                    }
                    let wr = ws.q[r] + (0..m).map(|c| mat[r * m + c] * ws.x[c]).sum::<f64>();
                    let (lo, hi) = match block.bounds[r] {
                        LocalBound::Fixed(lo, hi) => (lo, hi),
                        LocalBound::Friction { normal, mu } => {
                            let c = mu * ws.x[normal].max(0.0);
                            (-c, c)
                        }
                    };
                    ws.x[r] = (ws.x[r] - wr / mat[r * m + r]).max(lo).min(hi);
                }
            }
            for (r, &i) in rows.iter().enumerate() {
                f[i] = ws.x[r];
            }
            return error;
        }
        let lcp = LocalLcp {
            m,
            mat,
            q: &ws.q,
            bounds: &block.bounds,
            d: &block.d,
        };
        let current = lcp.residual_and_guess(&ws.x, &mut ws.enumeration);
        let guess = std::mem::take(&mut ws.enumeration.guess);
        let qscale = (0..m)
            .map(|r| (ws.q[r] / block.d[r]).abs())
            .fold(0.0_f64, f64::max)
            .max(ws.x.iter().fold(0.0_f64, |s, v| s.max(v.abs())));
        let accept = 1e-13 * qscale.max(f64::MIN_POSITIVE);
        let found = enumerate(&lcp, &guess, accept, &mut ws.enumeration, |_| true);
        ws.enumeration.guess = guess;
        if found.found && found.residual < current {
            for (r, &i) in rows.iter().enumerate() {
                f[i] = ws.enumeration.best[r];
            }
        }
        error
    }
}

impl Solver for Nsgs {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &NSGS
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        let n = problem.n();
        let rows_of_blocks = blocks(problem);
        let mut local = vec![usize::MAX; n];
        for block in &rows_of_blocks {
            for (r, &i) in block.iter().enumerate() {
                local[i] = r;
            }
        }
        let diag = usable_diagonal(problem);
        let scale = problem.diagonal_scale();
        let blocks: Vec<Block> = rows_of_blocks
            .into_iter()
            .map(|rows| Block::new(problem, rows, &local, &scale))
            .collect();
        let mut f = initial_impulse(problem, settings);
        let mut ws = BlockWorkspace::default();
        let tol = settings.tolerance;
        let mut iterations = 0;
        let mut previous = vec![0.0; n];
        let mut w = vec![0.0; n];
        // The shared residual is measured on the starting impulse, after the first sweep (which
        // solves decoupled contacts exactly) and after each sweep whose rows were all within
        // `MEASURE_WITHIN` times the tolerance at the running iterate.
        let mut measure = true;
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let outcome = loop {
            if measure && residuals_and_velocity(problem, &f, &mut w).natural_map_rel <= tol {
                break Outcome::Stopped;
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            previous.copy_from_slice(&f);
            let mut worst: f64 = 0.0;
            for block in &blocks {
                worst = worst.max(Self::solve_block(problem, block, &diag, &mut f, &mut ws));
            }
            measure = iterations == 0 || worst <= MEASURE_WITHIN * tol;
            iterations += 1;
            monitor.record(iterations, &f);
            if f.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite impulse in sweep {iterations}"
                ));
            }
            if previous == f {
                break Outcome::Stalled(format!(
                    "sweep {iterations} left every impulse unchanged (a fixed point of the block \
                     sweep that is not a solution)"
                ));
            }
            if iterations % STAGNATION_MEASURE_EVERY == 0 {
                let residual = residuals_and_velocity(problem, &f, &mut w).natural_map_rel;
                if stagnation.stagnated(iterations, residual) {
                    break Outcome::Stalled(stagnation.reason("relative residual"));
                }
            }
        };
        monitor.finish(f, iterations, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::generate::{generate, Family};
    use crate::problem::FrictionRow;
    use crate::{Dantzig, Lemke, Status};
    use faer::Mat;

    #[test]
    fn agrees_with_lemke_on_spd() {
        for seed in 0..3 {
            let g = generate(Family::Spd { cond: 1e2 }, 30, seed);
            let reference = Lemke::default().solve(&g.problem, &Settings::default());
            let r = Nsgs.solve(&g.problem, &Settings::default());
            assert_eq!(r.status, Status::Converged, "seed {seed}");
            for (x, y) in r.f.iter().zip(&reference.f) {
                assert!((x - y).abs() < 1e-6, "seed {seed}");
            }
        }
    }

    /// Contacts with a normal and two tangents each, `A = J Jᵀ + eps I` from a random Jacobian.
    fn friction_problem(contacts: usize, dofs: usize, seed: u64) -> Problem {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = 3 * contacts;
        let j = Mat::from_fn(n, dofs, |_, _| rng.random_range(-1.0..1.0));
        let a = Mat::from_fn(n, n, |r, c| {
            (0..dofs).map(|k| j[(r, k)] * j[(c, k)]).sum::<f64>() + if r == c { 1e-3 } else { 0.0 }
        });
        let b: Vec<f64> = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    rng.random_range(-1.0..0.2)
                } else {
                    rng.random_range(-0.5..0.5)
                }
            })
            .collect();
        let mut friction = Vec::new();
        for c in 0..contacts {
            for t in 1..3 {
                friction.push(FrictionRow {
                    row: 3 * c + t,
                    normal: 3 * c,
                    mu: 0.5,
                });
            }
        }
        let lo = vec![0.0; n];
        let hi = vec![f64::INFINITY; n];
        Problem::boxed(a, b, lo, hi, friction).unwrap()
    }

    #[test]
    fn friction_problem_agrees_with_dantzig() {
        let mut agreed = 0;
        for seed in 0..6 {
            let p = friction_problem(4, 18, seed);
            let reference = Dantzig::default().solve(&p, &Settings::default());
            if !reference.status.is_converged() {
                continue;
            }
            let r = Nsgs.solve(&p, &Settings::default());
            assert_eq!(r.status, Status::Converged, "seed {seed}: {}", r.status);
            // The same impulse as the pivoting reference.
            for (x, y) in r.f.iter().zip(&reference.f) {
                assert!(
                    (x - y).abs() < 1e-5,
                    "seed {seed}: {:?} vs {:?}",
                    r.f,
                    reference.f
                );
            }
            agreed += 1;
        }
        assert!(agreed >= 4, "only {agreed} reference solves converged");
    }

    #[test]
    fn single_contact_is_solved_in_one_sweep() {
        let mut exercised = 0;
        for seed in 0..8 {
            let p = friction_problem(1, 6, seed);
            let r = Nsgs.solve(&p, &Settings::default());
            assert_eq!(r.status, Status::Converged);
            if r.f[0] > 0.0 {
                assert_eq!(r.iterations, 1, "seed {seed}");
                exercised += 1;
            }
        }
        assert!(exercised >= 3, "{exercised}");
    }
}

//! Projected Gauss–Seidel (PGS) and projected successive over-relaxation (SOR).
//!
//! One sweep visits the rows in order and sets
//! `f_i ← mid(lo_i, hi_i, f_i − ω w_i / A_ii)` with `w_i = A_i f + b_i` taken at the current
//! `f` (rows already visited in this sweep are updated) and friction bounds `±mu f_k` taken at the
//! current normal impulse. `ω = 1` is PGS; `ω ∈ (0, 2)` is SOR.
//!
//! * **Problem class**: standard LCP, boxed LCP, friction rows. Converges for symmetric positive
//!   definite `A` with `0 < ω < 2` (Cryer 1971; Murty 1988, ch. 9); on PSD, rank-deficient `A`
//!   (redundant contacts) the impulses converge in `w` but may drift along the null space; on
//!   non-symmetric `A` there is no guarantee. With friction rows it is a fixed-point iteration on
//!   a non-symmetric problem and may stall.
//! * **Free (equality) rows** (`lo = −∞`, `hi = +∞`, a joint's `w_i = 0`): the update is not
//!   clamped, `f_i ← f_i − ω w_i / A_ii` with either sign, so on them the sweep is plain
//!   Gauss–Seidel (SOR), which converges for SPD `A` and for consistent redundant joints (PSD
//!   `A`). Its rate is that of Gauss–Seidel on `A`: chains of joints with large mass ratios
//!   (`1e6`) make `A` badly conditioned, and the sweeps then end at the iteration cap or the
//!   stagnation rule, never `converged` short of the tolerance.
//! * **Cost**: one pass over the stored entries of `A` per sweep: `O(nnz)` on a sparse `A`,
//!   `O(n²)` on a dense one.
//! * **Zero or tiny diagonals**: a row with `A_ii <= 1e-12 · max|A|` is never divided by. It is
//!   left at its initial (projected) value; if that leaves it violated, the shared residual shows
//!   it and the status is not `Converged`.
//! * **Stopping rule**: every row's update `|Δf_i|` of a sweep (the natural-map step at the
//!   sweep's running iterate) is within `tolerance` of that row's own scale
//!   ([`relative_row_error`](crate::problem::metrics::relative_row_error), the per-row measure of the shared residual); the shared residual
//!   is then recomputed and the sweeps continue if it is not yet within tolerance.
//! * **Never spins**: the shared residual is also measured every
//!   [`STAGNATION_MEASURE_EVERY`] sweeps, and when it has not reached a new low (1 % below the
//!   best) in [`FIRST_ORDER_STAGNATION_WINDOW`] sweeps, the solve stops `Stalled`
//!   ([`crate::solver`]'s stagnation rule). A sweep's own row updates are no measure of
//!   progress: on a resting stack at `1e-12` they stay near `2e-3` of the moving rows' own
//!   scales for 5,000 sweeps while the residual converges.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the bounds.
//! * **Matrix-free sweeps** ([`SweepForm::MatrixFree`]): when the problem carries its factors
//!   `A = J M⁻¹ Jᵀ` ([`Problem::factors`]), the sweep keeps the body velocities `u = M⁻¹ Jᵀ f`
//!   and updates row `i` as a physics engine does: `w_i = J_i u + b_i`, then
//!   `u += M⁻¹ J_iᵀ Δf_i`, `O(nnz(J_i))` per row whatever the number of neighbours. The row's
//!   scale for the stopping rule is then bounded below by `|b_i| + |A_ii f_i| + |J_i u − A_ii
//!   f_i|` (the magnitudes of the terms are not available), so the rule is at least as strict
//!   as the assembled one; the shared residual still decides.
//!
//! Reference: K. Erleben, *Numerical methods for linear complementarity problems in physics-based
//! animation*, SIGGRAPH course notes 2013, §4; Cottle–Pang–Stone 1992, §5.2.

/// Problem classes handled by PGS.
pub(crate) const PROBLEM_CLASSES_PGS: &str =
    "LCP, boxed LCP, friction rows, free (equality) rows updated unclamped (Gauss-Seidel on them); converges for SPD A (slowly at large mass ratios)";
/// Problem classes handled by SOR.
pub(crate) const PROBLEM_CLASSES_SOR: &str =
    "as PGS (free rows unclamped), with relaxation omega in (0, 2) (default 1.3)";

/// The registry's entry of `pgs`.
pub static PGS: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "pgs",
    summary: "projected Gauss-Seidel",
    problem_classes: PROBLEM_CLASSES_PGS,
    iteration_unit: "sweeps over the rows",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(ProjectedSor::pgs())),
};

/// The registry's entry of `sor`.
pub static SOR: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "sor",
    summary: "projected successive over-relaxation",
    problem_classes: PROBLEM_CLASSES_SOR,
    iteration_unit: "sweeps over the rows",
    iterative: true,
    relaxation: None,
    params: &[crate::registry::ParamSpec::real_open(
        "omega",
        1.3,
        0.0,
        2.0,
        "relaxation factor (projected SOR diverges outside (0, 2))",
    )],
    make: crate::registry::Make::Matrix(|params| Box::new(ProjectedSor::sor(params.get("omega")))),
};

use crate::delassus::DelassusFactors;
use crate::problem::diagonal::skipped_rows;
use crate::problem::metrics::relative_row_error_at;
use crate::problem::Problem;
use crate::solver::{
    initial_impulse, Monitor, Outcome, Settings, SolveResult, Solver, Stagnation,
    FIRST_ORDER_STAGNATION_WINDOW, STAGNATION_MEASURE_EVERY,
};

/// How a sweep computes `w_i`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SweepForm {
    /// Matrix-free when the problem carries its factors `J`, `M⁻¹`, otherwise the rows of `A`
    /// (the default).
    #[default]
    Auto,
    /// Always the stored rows of `A`: `w_i = A_i f + b_i`, `O(nnz(A_i))` per row.
    Assembled,
    /// Body velocities `u = M⁻¹ Jᵀ f`, `w_i = J_i u + b_i`, `O(nnz(J_i))` per row; falls back to
    /// the rows of `A` when the problem has no factors.
    MatrixFree,
}

/// Projected SOR with relaxation `omega`; `omega = 1` is projected Gauss–Seidel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProjectedSor {
    /// Relaxation factor in `(0, 2)`. Default `1.0` (PGS).
    pub omega: f64,
    /// How each row's `w_i` is computed. Default [`SweepForm::Auto`].
    pub sweep: SweepForm,
}

impl Default for ProjectedSor {
    fn default() -> Self {
        Self {
            omega: 1.0,
            sweep: SweepForm::Auto,
        }
    }
}

impl ProjectedSor {
    /// Projected Gauss–Seidel (`omega = 1`).
    pub fn pgs() -> Self {
        Self::default()
    }

    /// Projected SOR with relaxation `omega`.
    pub fn sor(omega: f64) -> Self {
        Self {
            omega,
            ..Self::default()
        }
    }

    /// The same solver with sweeps of form `sweep`.
    pub fn with_sweep(self, sweep: SweepForm) -> Self {
        Self { sweep, ..self }
    }
}

impl Solver for ProjectedSor {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        if self.omega == 1.0 {
            &PGS
        } else {
            &SOR
        }
    }

    fn works_on_factors(&self) -> bool {
        self.sweep != SweepForm::Assembled
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        let omega = self.omega;
        if !(omega > 0.0 && omega < 2.0) {
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(format!("relaxation omega = {omega} is outside (0, 2)")),
            );
        }
        let skip = skipped_rows(problem);
        let d = problem.diagonal_scale();
        let mut f = initial_impulse(problem, settings);
        let tol = settings.tolerance;
        let mut matrix_free = match (self.sweep, problem.factors()) {
            (SweepForm::Auto | SweepForm::MatrixFree, Some(factors)) => {
                let u = factors.body_velocity(&f);
                Some((factors, u))
            }
            _ => None,
        };
        let check_every = match &matrix_free {
            Some((factors, ..)) => {
                let j = factors.jacobian_nnz().max(1);
                (2 * problem.nnz()).div_ceil(j).max(1)
            }
            None => usize::MAX,
        };
        let mut iterations = 0;
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let outcome = loop {
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            let (worst, moved) = match &mut matrix_free {
                Some((factors, u)) => {
                    sweep_matrix_free(problem, factors, u, &mut f, &skip, &d, omega)
                }
                None => sweep_assembled(problem, &mut f, &skip, &d, omega),
            };
            iterations += 1;
            monitor.record(iterations, &f);
            if !worst.is_finite() && f.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite update in sweep {iterations}"
                ));
            }
            // Matrix-free sweeps bound each row's scale from below, so their own rule may be
            // too strict: the shared residual is also checked every `check_every` sweeps (about
            // the cost of half a sweep's work in checks), and every
            // `STAGNATION_MEASURE_EVERY` sweeps for the stagnation rule.
            let periodic = iterations % check_every == 0;
            let watch = iterations % STAGNATION_MEASURE_EVERY == 0;
            if worst <= tol || periodic || watch {
                let residual = monitor.residual_of(&f);
                if residual <= tol {
                    break Outcome::Stopped;
                }
                if watch && stagnation.stagnated(iterations, residual) {
                    break Outcome::Stalled(stagnation.reason("relative residual"));
                }
            }
            if !moved {
                // A fixed point that is not a solution (only possible with skipped rows).
                break Outcome::Stopped;
            }
        };
        monitor.finish(f, iterations, outcome)
    }
}

/// One sweep over the stored rows of `A`. Returns the largest relative row error of the rows
/// that moved, and whether any moved.
pub(crate) fn sweep_assembled(
    problem: &Problem,
    f: &mut [f64],
    skip: &[bool],
    d: &[f64],
    omega: f64,
) -> (f64, bool) {
    let b = problem.b();
    let mut worst: f64 = 0.0;
    let mut moved = false;
    for i in 0..f.len() {
        if skip[i] {
            continue;
        }
        let (af, magnitude) = problem.row(i).dot_and_magnitude(f);
        let wi = af + b[i];
        let (lo, hi) = problem.bounds_at(i, f);
        let new = (f[i] - omega * wi / d[i]).max(lo).min(hi);
        if new != f[i] {
            moved = true;
            worst = worst.max(relative_row_error_at(
                f[i],
                lo,
                hi,
                wi,
                d[i],
                magnitude + b[i].abs(),
            ));
        }
        f[i] = new;
    }
    (worst, moved)
}

/// One matrix-free sweep: `w_i = J_i u + b_i`, `u += M⁻¹ J_iᵀ Δf_i` (see the module doc).
/// Each row is read as its (at most a few) body blocks, each with its six entries of `J` and of
/// `M⁻¹ J_iᵀ` side by side, so a sweep streams one compact record per row and body; `J_i u` is
/// summed in the column order of `J`'s compressed rows.
fn sweep_matrix_free(
    problem: &Problem,
    factors: &DelassusFactors,
    u: &mut [f64],
    f: &mut [f64],
    skip: &[bool],
    d: &[f64],
    omega: f64,
) -> (f64, bool) {
    let b = problem.b();
    let mut worst: f64 = 0.0;
    let mut moved = false;
    for i in 0..f.len() {
        if skip[i] {
            continue;
        }
        let blocks = factors.row_blocks(i);
        let af: f64 = blocks
            .iter()
            .flat_map(|blk| {
                let ub = &u[6 * blk.body..6 * blk.body + 6];
                blk.j.iter().zip(ub).map(|(v, x)| v * x)
            })
            .sum();
        let wi = af + b[i];
        let (lo, hi) = problem.bounds_at(i, f);
        let new = (f[i] - omega * wi / d[i]).max(lo).min(hi);
        let delta = new - f[i];
        if delta != 0.0 {
            moved = true;
            let own = problem.diagonal(i) * f[i];
            let magnitude = own.abs() + (af - own).abs() + b[i].abs();
            worst = worst.max(relative_row_error_at(f[i], lo, hi, wi, d[i], magnitude));
            for blk in blocks {
                let ub = &mut u[6 * blk.body..6 * blk.body + 6];
                for (x, r) in ub.iter_mut().zip(&blk.resp) {
                    *x += r * delta;
                }
            }
        }
        f[i] = new;
    }
    (worst, moved)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::FrictionRow;
    use crate::Status;
    use faer::Mat;

    #[test]
    fn solves_a_two_by_two_lcp() {
        let a = Mat::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 2.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, 1.0]).unwrap();
        for mut s in [ProjectedSor::pgs(), ProjectedSor::sor(1.5)] {
            let r = s.solve(&p, &Settings::default());
            assert_eq!(r.status, Status::Converged);
            assert!((r.f[0] - 0.5).abs() < 1e-8 && r.f[1] == 0.0);
        }
    }

    #[test]
    fn zero_diagonal_is_not_divided_by() {
        // Row 1 is all zero with b_1 = -1: no solution; PGS must not produce NaN.
        let a = Mat::from_fn(2, 2, |i, j| if i == 0 && j == 0 { 1.0 } else { 0.0 });
        let p = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        let r = ProjectedSor::pgs().solve(&p, &Settings::default());
        assert!(r.f.iter().all(|v| v.is_finite()));
        assert!(!r.status.is_converged());
    }

    #[test]
    fn friction_row_sticks_inside_the_cone() {
        // Unit masses: normal pushed in with b_n = -1, tangent pushed with b_t = -0.1, mu = 0.5:
        // f_n = 1, f_t = 0.1 (inside the cone, w_t = 0).
        let p = Problem::boxed(
            Mat::identity(2, 2),
            vec![-1.0, -0.1],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        let r = ProjectedSor::pgs().solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert!((r.f[1] - 0.1).abs() < 1e-12);
    }

    #[test]
    fn matrix_free_sweeps_agree_with_assembled_ones() {
        // Three bodies, six rows (a normal and a friction row per contact, three contacts, the
        // middle body shared): A = J M⁻¹ Jᵀ with J and M⁻¹ built by hand.
        let rows = 6;
        let mut jt = Vec::new();
        for c in 0..3 {
            let (b1, b2) = (c % 3, (c + 1) % 3);
            for k in 0..2 {
                let i = 2 * c + k;
                for d in 0..6 {
                    let v = ((i * 7 + d * 3) % 5) as f64 - 2.0 + if d == k { 3.0 } else { 0.0 };
                    jt.push((i, 6 * b1 + d, v));
                    jt.push((i, 6 * b2 + d, -0.5 * v));
                }
            }
        }
        let triplets: Vec<_> = jt
            .iter()
            .map(|&(i, j, v)| faer::sparse::Triplet::new(i, j, v))
            .collect();
        let j = faer::sparse::SparseRowMat::try_new_from_triplets(rows, 18, &triplets).unwrap();
        let blocks: Vec<[[f64; 6]; 6]> = (0..3)
            .map(|b| {
                let mut m = [[0.0; 6]; 6];
                for (r, row) in m.iter_mut().enumerate() {
                    row[r] = 1.0 + (b + r) as f64 * 0.25;
                }
                m[3][4] = 0.1;
                m[4][3] = 0.1;
                m
            })
            .collect();
        let factors = DelassusFactors::new(j, blocks).unwrap();
        let a = Mat::from_fn(rows, rows, |r, c| {
            let e: Vec<f64> = (0..rows).map(|k| if k == c { 1.0 } else { 0.0 }).collect();
            factors.apply(&e)[r]
        });
        let friction = (0..3)
            .map(|c| FrictionRow {
                row: 2 * c + 1,
                normal: 2 * c,
                mu: 0.4,
            })
            .collect();
        let b = vec![-1.0, 0.3, -2.0, -0.2, -0.5, 0.6];
        let p = Problem::boxed(a, b, vec![0.0; rows], vec![f64::INFINITY; rows], friction)
            .unwrap()
            .with_factors(factors)
            .unwrap();
        let settings = Settings {
            tolerance: 1e-13,
            ..Settings::default()
        };
        let assembled = ProjectedSor::pgs()
            .with_sweep(SweepForm::Assembled)
            .solve(&p, &settings);
        let free = ProjectedSor::pgs()
            .with_sweep(SweepForm::MatrixFree)
            .solve(&p, &settings);
        assert_eq!(assembled.status, Status::Converged);
        assert_eq!(free.status, Status::Converged);
        assert!(
            assembled.f.iter().any(|&v| v > 1e-3),
            "contacts are loaded: {:?}",
            assembled.f
        );
        for (x, y) in assembled.f.iter().zip(&free.f) {
            assert!((x - y).abs() <= 1e-10, "{x} vs {y}");
        }
    }

    #[test]
    fn history_is_recorded_and_capped() {
        let a = Mat::from_fn(3, 3, |i, j| if i == j { 1.0 } else { 0.99 });
        let p = Problem::lcp(a, vec![-1.0, -1.0, -1.0]).unwrap();
        let settings = Settings {
            max_iterations: 3,
            record_history: true,
            tolerance: 1e-14,
            ..Settings::default()
        };
        let r = ProjectedSor::pgs().solve(&p, &settings);
        assert_eq!(r.history.len(), r.iterations);
        assert!(r.iterations <= 3);
    }
}

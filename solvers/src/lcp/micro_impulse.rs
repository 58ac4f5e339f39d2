//! Sequential micro-impulses: resolve the most approaching contact, one impulse at a time.
//!
//! The velocity `w = A f + b` is kept up to date incrementally. Each step picks the row with the
//! largest *actionable step* `s_i`, the approach velocity scaled by the diagonal,
//! `−w_i / A_ii`, clamped to the room the row has left, and applies the single impulse
//! `Δf_i = s_i` that zeroes `w_i` (or takes the row to its bound), then updates
//! `w ← w + A[:, i] Δf_i` in `O(n)`. Rows are treated by type:
//!
//! * **Normal-type rows** (`lo_i >= 0`, e.g. non-penetration): the impulse only pushes, never
//!   pulls. A row is eligible while it is approaching (`w_i < 0`) and below its upper bound;
//!   `s_i = min(−w_i / A_ii, hi_i − f_i)`. An impulse once applied is never taken back.
//! * **Friction rows** (bounds `±mu f_k`): the impulse opposes the tangential velocity in either
//!   direction, clamped to the cone at the *current* normal impulse:
//!   `s_i = mid(−mu f_k, mu f_k, f_i − w_i / A_ii) − f_i`. As the normal impulse grows the cone
//!   widens and the row can become eligible again.
//! * **Other rows** (`lo_i < 0`, e.g. bilateral or motor rows): as friction rows, clamped to
//!   `[lo_i, hi_i]`. A free (equality) row of a joint (`lo = −∞`, `hi = +∞`) takes
//!   `s_i = −w_i / A_ii` of either sign, so it pulls as well as pushes (a hanging pendulum's
//!   rod pulls with a negative impulse) and can be taken back: on free rows alone the method is
//!   the greedy coordinate descent (Gauss–Southwell) of `½ fᵀA f + bᵀf`, which converges for
//!   SPD `A`. Only the normal-type rows keep the never-pull rule, and with it their
//!   over-shoot, which joints coupled to contacts make more likely.
//!
//! How it differs from PGS by design: PGS visits every row in a fixed order and may *decrease*
//! an impulse that has become too large; micro-impulses choose the most violated row greedily
//! and never decrease a normal impulse. Coupled contacts (positive off-diagonal `A_ij`, as when
//! pushing one contact separates its neighbour) can therefore over-shoot: a normal row is left
//! with `f_i > 0` and `w_i > 0` (a contact that pushes while separating), which no later impulse
//! can repair. The solver then stops by its own rule and the shared residual, which does see the
//! over-shoot, reports `Stalled`, not `Converged`. On decoupled rows (diagonal `A`) each row needs
//! one impulse and the answer is exact; for a standard LCP with a Z-matrix (`A_ij <= 0` off the
//! diagonal, e.g. an M-matrix) an impulse on one row only lowers the others' `w`, so no row ever
//! over-shoots and the impulses increase monotonically towards the least solution.
//!
//! * **Problem class**: standard LCP, boxed LCP, friction rows, free (equality) rows, any `A`
//!   with a positive diagonal; converges (exactly, in finitely many impulses) on diagonal `A`, in
//!   the limit on M-matrices and on free rows alone; otherwise it is a physically motivated
//!   heuristic that may stall. It never pulls on contacts.
//! * **Failure modes**: over-shoot on coupled rows (`Stalled`, above); on a problem with no
//!   solution the pushes never end (`IterationLimit`); on non-symmetric `A` with a large skew part
//!   (not a Delassus matrix) one push can drive other rows ever deeper, and the impulses may grow
//!   by orders of magnitude before every row separates (`Stalled`); a non-finite impulse ends the
//!   solve as `NumericalFailure`.
//! * **Row choice**: the row whose actionable step is largest *relative to that row's own scale*
//!   (the per-row scale of the shared residual, [`crate::metrics`]), so the choice does not
//!   depend on how rows are scaled.
//! * **Cost**: `O(n)` per impulse for the arg-max over the rows plus one column of `A`
//!   (`O(nnz of the column)` when `A` is sparse, through a column-major copy made once), so
//!   `O(n²)` per sweep-equivalent.
//! * **Iterations**: [`Settings::max_iterations`] counts *sweep-equivalents* of `n` single
//!   impulses; the reported iteration count is the number of impulses divided by `n`, rounded up,
//!   and the history has one point per sweep-equivalent (plus the final partial one).
//! * **Zero or tiny diagonals**: a row with `A_ii <= diagonal_floor · max|A|` is never divided by
//!   and never receives an impulse; if that leaves it violated, the shared residual shows it.
//! * **Stopping rule**: no row has an actionable step above `tolerance` times that row's own
//!   scale `(|b_i| + Σ_j |A_ij f_j|) / d_i`, the per-row scale of the shared residual (kept up to
//!   date incrementally with `w`). Before stopping, `w` and the scales are recomputed from
//!   scratch so rounding drift in the incremental updates cannot end the solve early. An
//!   actionable step that is zero while the row is violated (a normal row that over-shot) is
//!   left to the shared residual, which reports it.
//! * **Never spins**: when the shared residual, measured every [`STAGNATION_MEASURE_EVERY`]
//!   sweep-equivalents (`n` impulses each), has not reached a new low (1 % below the best) in
//!   [`FIRST_ORDER_STAGNATION_WINDOW`] iterations, the solve stops `Stalled`
//!   ([`crate::solver`]'s stagnation rule).
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the bounds. A warm start that
//!   is too large on a normal row is never reduced.
//!
//! References: B. Mirtich, *Impulse-based dynamic simulation of rigid body systems*, PhD thesis,
//! University of California, Berkeley, 1996, ch. 4; B. Mirtich and J. Canny, *Impulse-based
//! simulation of rigid bodies*, Proc. Symposium on Interactive 3D Graphics, 1995.

use crate::problem::metrics::residuals;
use crate::problem::Problem;
use crate::solver::{
    initial_impulse, Monitor, Outcome, Settings, SolveResult, Solver, Stagnation,
    FIRST_ORDER_STAGNATION_WINDOW, STAGNATION_MEASURE_EVERY,
};
use faer::sparse::SparseColMat;
use faer::Mat;

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "LCP, boxed LCP, friction rows, free (equality) rows pushed and pulled; exact on decoupled rows, never pulls on contacts, may over-shoot (stall) on coupled contacts";

/// The registry's entry of `micro`.
pub static MICRO: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "micro",
    summary: "sequential micro-impulses",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "sweep-equivalents (n single impulses each)",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Matrix(|_params| Box::new(MicroImpulse::default())),
};

/// Sequential micro-impulses (Mirtich 1996). See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MicroImpulse {
    /// Rows with `A_ii <= diagonal_floor · max|A|` receive no impulse. Default `1e-12`.
    pub diagonal_floor: f64,
}

impl Default for MicroImpulse {
    fn default() -> Self {
        Self {
            diagonal_floor: 1e-12,
        }
    }
}

/// The impulse row `i` may take now: the scaled approach velocity clamped to the row's bounds,
/// and to increases only on normal-type rows.
#[inline]
fn actionable_step(problem: &Problem, i: usize, f: &[f64], w: &[f64], d: &[f64]) -> f64 {
    let (lo, hi) = problem.bounds_at(i, f);
    let target = (f[i] - w[i] / d[i]).max(lo).min(hi);
    let step = target - f[i];
    if problem.friction_of(i).is_none() && lo >= 0.0 {
        step.max(0.0)
    } else {
        step
    }
}

/// Recompute `w = A f + b` and each row's scale `(|b_i| + Σ_j |A_ij f_j|) / d_i`.
fn refresh(problem: &Problem, f: &[f64], d: &[f64], w: &mut [f64], scale: &mut [f64]) {
    let b = problem.b();
    for i in 0..problem.n() {
        let (af, magnitude) = problem.row(i).dot_and_magnitude(f);
        w[i] = af + b[i];
        scale[i] = (magnitude + b[i].abs()) / d[i];
    }
}

/// Column access to `A`: the dense matrix (column-major already) or a column-major copy of a
/// sparse one.
enum Columns<'a> {
    Dense(&'a Mat<f64>),
    Sparse(SparseColMat<usize, f64>),
}

impl<'a> Columns<'a> {
    fn of(problem: &'a Problem) -> Self {
        match problem.dense() {
            Some(a) => Columns::Dense(a),
            None => Columns::Sparse(problem.to_csc()),
        }
    }

    /// Calls `visit(j, A_ji)` for the stored entries of column `i`.
    #[inline]
    fn for_each(&self, i: usize, mut visit: impl FnMut(usize, f64)) {
        match self {
            Columns::Dense(a) => {
                for (j, &v) in a.col_as_slice(i).iter().enumerate() {
                    visit(j, v);
                }
            }
            Columns::Sparse(a) => {
                let sym = a.symbolic();
                let range = sym.col_ptr()[i]..sym.col_ptr()[i + 1];
                for (&j, &v) in sym.row_idx()[range.clone()].iter().zip(&a.val()[range]) {
                    visit(j, v);
                }
            }
        }
    }
}

impl Solver for MicroImpulse {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &MICRO
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        let n = problem.n();
        let columns = Columns::of(problem);
        let amax = problem.max_abs_entry();
        let active: Vec<usize> = (0..n)
            .filter(|&i| problem.diagonal(i) > self.diagonal_floor * amax)
            .collect();
        let d = problem.diagonal_scale();
        let mut f = initial_impulse(problem, settings);
        let (mut w, mut scale) = (vec![0.0; n], vec![0.0; n]);
        refresh(problem, &f, &d, &mut w, &mut scale);
        let tol = settings.tolerance;
        let cap = settings.max_iterations.saturating_mul(n);
        let mut impulses: usize = 0;
        let mut refreshed = false;
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let outcome = loop {
            // Pick the row with the largest actionable step relative to its own scale.
            let mut best = None;
            let mut best_rel = 0.0_f64;
            let mut best_step = 0.0_f64;
            for &i in &active {
                let s = actionable_step(problem, i, &f, &w, &d);
                let rel = if s == 0.0 { 0.0 } else { s.abs() / scale[i] };
                if rel > best_rel || s.is_nan() {
                    best = Some(i);
                    best_rel = rel;
                    best_step = s;
                }
            }
            if !best_step.is_finite() {
                break Outcome::NumericalFailure(format!(
                    "non-finite impulse after {impulses} impulses"
                ));
            }
            let row = match best {
                Some(i) if best_rel > tol => i,
                _ => {
                    if refreshed {
                        break Outcome::Stopped;
                    }
                    // Recompute w to rule out drift in the incremental updates, then re-check.
                    refresh(problem, &f, &d, &mut w, &mut scale);
                    refreshed = true;
                    continue;
                }
            };
            refreshed = false;
            if impulses >= cap {
                break Outcome::IterationLimit;
            }
            // Each impulse scans every row, so the clock is read every 16 impulses rather
            // than every sweep-equivalent (`n` impulses, `O(n²)` work on a large island).
            if impulses.is_multiple_of(16) && monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            let old = f[row];
            f[row] += best_step;
            let grow = f[row].abs() - old.abs();
            columns.for_each(row, |j, aji| {
                w[j] += aji * best_step;
                scale[j] = (scale[j] + aji.abs() * grow / d[j]).max(0.0);
            });
            impulses += 1;
            if impulses.is_multiple_of(n) {
                let sweeps = impulses / n;
                monitor.record(sweeps, &f);
                if sweeps.is_multiple_of(STAGNATION_MEASURE_EVERY)
                    && stagnation.stagnated(sweeps, residuals(problem, &f).natural_map_rel)
                {
                    break Outcome::Stalled(stagnation.reason("relative residual"));
                }
            }
        };
        let iterations = impulses.div_ceil(n.max(1));
        if !impulses.is_multiple_of(n.max(1)) {
            monitor.record(iterations, &f);
        }
        monitor.finish(f, iterations, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::generate::{generate, Family};
    use crate::problem::FrictionRow;
    use crate::test_util::mat;
    use crate::Status;
    use faer::Mat;

    #[test]
    fn single_contact_is_solved_exactly() {
        let p = Problem::lcp(mat(&[&[2.0]]), vec![-3.0]).unwrap();
        let r = MicroImpulse::default().solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert_eq!(r.f, vec![1.5]);
        assert_eq!(r.residuals.natural_map, 0.0);
        assert_eq!(r.iterations, 1);

        // A sliding contact: the tangent impulse waits for the normal one, then saturates the
        // cone: f_n = 1, f_t = mu f_n = 0.5, still sliding with w_t = -1.5 (at the upper bound).
        let p = Problem::boxed(
            Mat::identity(2, 2),
            vec![-1.0, -2.0],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        let r = MicroImpulse::default().solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert_eq!(r.f, vec![1.0, 0.5]);
    }

    #[test]
    fn decoupled_rows_take_one_impulse_each() {
        // Diagonal A: every row's impulse is exact after one sweep-equivalent. Row 4 is
        // bilateral (unbounded both ways) and takes a negative impulse; row 5 is capped at 1.
        let diag = [2.0, 0.5, 4.0, 1.0, 2.0, 1.0];
        let a = Mat::from_fn(6, 6, |i, j| if i == j { diag[i] } else { 0.0 });
        let b = vec![-1.0, 2.0, -8.0, -0.25, 3.0, -5.0];
        let mut lo = vec![0.0; 6];
        let mut hi = vec![f64::INFINITY; 6];
        lo[4] = f64::NEG_INFINITY;
        hi[5] = 1.0;
        let p = Problem::boxed(a, b, lo, hi, vec![]).unwrap();
        let settings = Settings {
            record_history: true,
            ..Settings::default()
        };
        let r = MicroImpulse::default().solve(&p, &settings);
        assert_eq!(r.status, Status::Converged);
        assert_eq!(r.f, vec![0.5, 0.0, 2.0, 0.25, -1.5, 1.0]);
        assert_eq!(r.residuals.natural_map, 0.0);
        assert_eq!(r.iterations, 1);
        assert_eq!(r.history.len(), 1);
    }

    #[test]
    fn coupled_contacts_over_shoot_and_stall() {
        // A = [[1, .9], [.9, 1]], b = (-1, -1); the LCP solution is f = (1/1.9, 1/1.9).
        // Impulse 1 on row 0: f = (1, 0), w = (0, -0.1). Impulse 2 on row 1: f = (1, 0.1),
        // w = (0.09, 0). Row 0 now pushes while separating and may not pull: stuck.
        let p = Problem::lcp(mat(&[&[1.0, 0.9], &[0.9, 1.0]]), vec![-1.0, -1.0]).unwrap();
        let settings = Settings::default();
        let r = MicroImpulse::default().solve(&p, &settings);
        assert!(matches!(r.status, Status::Stalled { .. }), "{}", r.status);
        assert!(!r.status.is_converged());
        assert!(r.residuals.natural_map_rel > settings.tolerance);
        assert!((r.f[0] - 1.0).abs() < 1e-15 && (r.f[1] - 0.1).abs() < 1e-15);
        assert!((r.w[0] - 0.09).abs() < 1e-12);
    }

    #[test]
    fn normal_impulses_never_decrease() {
        // Run with growing caps; the solver is deterministic, so the runs trace one solve.
        let g = generate(Family::Spd { cond: 1e2 }, 12, 4);
        let mut previous = vec![0.0; 12];
        for cap in 1..30 {
            let settings = Settings {
                max_iterations: cap,
                ..Settings::default()
            };
            let r = MicroImpulse::default().solve(&g.problem, &settings);
            assert!(r.iterations <= cap);
            for (now, before) in r.f.iter().zip(&previous) {
                assert!(now >= before, "cap {cap}: {now} < {before}");
            }
            previous = r.f;
        }
    }

    #[test]
    fn respects_the_cap_and_records_history() {
        // An M-matrix with strong coupling: monotone, slow convergence to f = (100, 100).
        let p = Problem::lcp(mat(&[&[1.0, -0.99], &[-0.99, 1.0]]), vec![-1.0, -1.0]).unwrap();
        let settings = Settings {
            max_iterations: 5,
            record_history: true,
            ..Settings::default()
        };
        let r = MicroImpulse::default().solve(&p, &settings);
        assert_eq!(r.status, Status::IterationLimit);
        assert_eq!(r.iterations, 5);
        assert_eq!(r.history.len(), 5);
        assert!(r.history.windows(2).all(|h| h[1].residual <= h[0].residual));
        // Uncapped it gets there.
        let r = MicroImpulse::default().solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert!((r.f[0] - 100.0).abs() < 1e-3, "{:?}", r.f);
    }

    #[test]
    fn spent_time_budget_stops_before_the_first_impulse() {
        assert_eq!(
            MicroImpulse::default().name(),
            crate::SolverKind::MicroImpulse.name()
        );
        let p = Problem::lcp(mat(&[&[2.0]]), vec![-3.0]).unwrap();
        let settings = Settings {
            time_budget: Some(std::time::Duration::ZERO),
            ..Settings::default()
        };
        let r = MicroImpulse::default().solve(&p, &settings);
        assert_eq!(r.status, Status::TimeLimit);
        assert_eq!(r.f, vec![0.0]);
    }

    #[test]
    fn zero_diagonal_is_not_divided_by() {
        // Row 1 is all zero with b_1 = -1: no solution; no NaN either.
        let p = Problem::lcp(mat(&[&[1.0, 0.0], &[0.0, 0.0]]), vec![-1.0, -1.0]).unwrap();
        let r = MicroImpulse::default().solve(&p, &Settings::default());
        assert!(r.f.iter().all(|v| v.is_finite()));
        assert!(!r.status.is_converged());
        assert_eq!(r.f, vec![1.0, 0.0]);
        let p = Problem::lcp(Mat::zeros(0, 0), vec![]).unwrap();
        assert_eq!(
            MicroImpulse::default()
                .solve(&p, &Settings::default())
                .status,
            Status::Converged
        );
    }
}

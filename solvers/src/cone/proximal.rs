//! The proximal point method on the exact Coulomb cone (Siconos' `FC3D_PROX`): each outer
//! iteration solves the regularised cone problem by NSGS over contacts.
//!
//! With `D = diag(d_c I₃)` the contacts' diagonal scales and `r_k` the current reaction, outer
//! iteration `k` solves
//!
//! ```text
//! u' = (W + α D) r + q − α D r_k,     K ∋ r ⟂ û' ∈ K*     (De Saxcé's û' from u'),
//! ```
//!
//! whose solution is `r_k` exactly when `r_k` solves the cone problem, by sweeps of NSGS over
//! contacts ([`crate::NsgsCone`]'s exact per-contact solve on the blocks `W_cc + α d_c I`): the
//! regularisation makes each block, and the whole matrix, better conditioned. As in Siconos'
//! `fc3d_proximal.c` (its default `PROXIMAL_PROX` strategy, `sigma = 5`, `nu = 1`,
//! `INTERNAL_ERROR_RATIO = 10`):
//!
//! * `α = σ e^ν` with `e` the cone residual of `r_k` (so the regularisation vanishes as the
//!   outer residual drops), multiplied by 10 instead after an inner solve that missed its
//!   tolerance;
//! * the inner tolerance is `max(e / 10, tolerance)` (Siconos divides the outer tolerance by the
//!   number of contacts because its error is a sum; the cone residual is a maximum over contacts).
//!
//! The inner residual is measured during each sweep, contact by contact before its update (the
//! relative natural map of the regularised problem, scaled as the cone residual is): no extra
//! pass over `W`. Siconos' default inner solver is the global Alart–Curnier Newton; NSGS is used
//! here because it works on sparse `W` of any size and needs no factorisation.
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]), dense or sparse `W` with `W_cc` positive
//!   definite up to the regularisation. No convergence proof for Coulomb friction (the proximal
//!   point method converges for monotone problems; De Saxcé's map is not monotone).
//! * **Cost**: per inner sweep one pass over `W` and `O(1)` 3×3 solves per contact; per outer
//!   iteration one more pass for the cone residual. [`Settings::max_iterations`] counts inner
//!   sweeps. No allocation per sweep.
//! * **Stopping rule**: the cone residual ([`crate::cone`]) of `r_k` is at most the tolerance.
//!   `Stalled` when it has not reached a new low by 1 % in
//!   [`crate::FIRST_ORDER_STAGNATION_WINDOW`] sweeps or `α` grows past `10¹²`;
//!   `NumericalFailure` on a non-finite iterate; the time budget is checked every sweep.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones, as `r_0`.
//!
//! References: R. T. Rockafellar, *Monotone operators and the proximal point algorithm*, SIAM
//! J. Control Optim. 14, 1976; V. Acary, M. Brémond, O. Huber, 2018; Siconos'
//! `fc3d_proximal.c` (`fc3d_proximal`, `fc3d_proximal_set_default`).

use crate::cone::alart_curnier::ContactBlock;
use crate::cone::projected_step::Point;
use crate::cone::{contact_natural_map, ConeMonitor, ConeProblem, ConeSolver};
use crate::solver::{Outcome, Settings, SolveResult, Stagnation, FIRST_ORDER_STAGNATION_WINDOW};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone (exact Coulomb); proximal point, each regularised problem solved by NSGS over contacts, dense or sparse W";

/// The registry's entry of `prox-cone`.
pub static PROX_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "prox-cone",
    summary: "proximal point, each regularised problem solved by NSGS over contacts",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "inner NSGS sweeps",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(ProxCone::default())),
};

/// The proximal point method on the cone. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProxCone {
    /// `σ` of `α = σ e^ν`. Default `5` (Siconos).
    pub sigma: f64,
    /// `ν` of `α = σ e^ν`. Default `1` (Siconos).
    pub nu: f64,
    /// Inner tolerance `max(e / ratio, tolerance)`. Default `10` (Siconos).
    pub inner_ratio: f64,
    /// Cap on the NSGS sweeps of one inner solve. Default `100`.
    pub inner_sweeps: usize,
}

impl Default for ProxCone {
    fn default() -> Self {
        Self {
            sigma: 5.0,
            nu: 1.0,
            inner_ratio: 10.0,
            inner_sweeps: 100,
        }
    }
}

/// Largest `α`: beyond it the regularised problem leaves `r` where it is, so the solve stops
/// `Stalled`.
const MAX_REGULARISATION: f64 = 1e12;
/// Factor applied to `α` after an inner solve that missed its tolerance (Siconos).
const FAILED_INNER_GROWTH: f64 = 10.0;

#[inline]
fn norm3(x: [f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

impl ConeSolver for ProxCone {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &PROX_CONE
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let tol = settings.tolerance;
        let (w, q, mu) = (problem.delassus(), problem.q(), problem.mu());
        let d: Vec<f64> = (0..problem.contacts())
            .map(|c| problem.scale_of(c))
            .collect();
        let blocks: Vec<[[f64; 3]; 3]> =
            (0..problem.contacts()).map(|c| problem.block(c)).collect();
        let mut x = Point::start(problem, settings);
        let mut anchor = x.r.clone();
        let mut alpha = self.sigma * x.residual().powf(self.nu);
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let mut sweeps = 0;
        let outcome = 'solve: loop {
            let e = x.residual();
            if e <= tol {
                break Outcome::Stopped;
            }
            if !(x.r.iter().chain(&x.u).all(|v| v.is_finite())) {
                break Outcome::NumericalFailure(format!(
                    "non-finite reaction or velocity after sweep {sweeps}"
                ));
            }
            if alpha.is_nan() || alpha > MAX_REGULARISATION {
                break Outcome::Stalled(format!(
                    "the regularisation α = {alpha:.3e} exceeds {MAX_REGULARISATION:e}: the \
                     inner solves keep missing their tolerance"
                ));
            }
            anchor.copy_from_slice(&x.r);
            // Each contact's regularised block `W_cc + α d_c I`, factored once for the sweeps of
            // this outer iteration.
            let regularised: Vec<ContactBlock> = blocks
                .iter()
                .zip(&d)
                .map(|(wcc, &dc)| {
                    let mut wreg = *wcc;
                    for (k, row) in wreg.iter_mut().enumerate() {
                        row[k] += alpha * dc;
                    }
                    ContactBlock::new(wreg)
                })
                .collect();
            let inner_tol = (e / self.inner_ratio).max(tol);
            let mut inner_met = false;
            for _ in 0..self.inner_sweeps {
                if sweeps >= settings.max_iterations {
                    break 'solve Outcome::IterationLimit;
                }
                if monitor.out_of_time() {
                    break 'solve Outcome::TimeLimit;
                }
                let mut inner_error = 0.0f64;
                for (c, ((&m, wcc), block)) in mu.iter().zip(&blocks).zip(&regularised).enumerate()
                {
                    let s = 3 * c;
                    let a = alpha * d[c];
                    let rc = [x.r[s], x.r[s + 1], x.r[s + 2]];
                    let (mut uc, mut qc, mut t) = ([0.0; 3], [0.0; 3], [0.0; 3]);
                    for k in 0..3 {
                        let i = s + k;
                        let (wr, magnitude) = w.row(i).dot_and_magnitude(&x.r);
                        let shift = q[i] - a * anchor[i];
                        uc[k] = wr + a * rc[k] + shift;
                        t[k] = magnitude + (a * rc[k]).abs() + shift.abs();
                        let own: f64 = (0..3).map(|b| wcc[k][b] * rc[b]).sum();
                        qc[k] = wr - own + shift;
                    }
                    // The regularised contact's relative natural map, before its update.
                    let dc = block.w()[0][0];
                    let err = contact_natural_map(m, 1.0 / dc, rc, uc);
                    let scale = norm3([t[0] + m * t[1].hypot(t[2]), t[1], t[2]]) / dc;
                    if err > 0.0 {
                        inner_error = inner_error.max(if scale > 0.0 {
                            err / scale
                        } else {
                            f64::INFINITY
                        });
                    }
                    let next = block.solve(m, qc, rc);
                    x.r[s..s + 3].copy_from_slice(&next);
                }
                sweeps += 1;
                monitor.record(sweeps, &x.r);
                if inner_error <= inner_tol {
                    inner_met = true;
                    break;
                }
            }
            x.evaluate(problem);
            alpha = if inner_met {
                self.sigma * x.residual().powf(self.nu)
            } else {
                alpha * FAILED_INNER_GROWTH
            };
            if stagnation.stagnated(sweeps, x.residual()) {
                break Outcome::Stalled(stagnation.reason("relative cone residual"));
            }
        };
        monitor.finish(x.r, sweeps, outcome)
    }
}

//! The projected step on De Saxcé's map with a self-adaptive step length, shared by the
//! extragradient ([`crate::ExtragradientCone`]) and fixed-point projection
//! ([`crate::FixedPointProjectionCone`]) solvers.
//!
//! With `û(r)` De Saxcé's modified velocity of `u = W r + q` and `d_c` the diagonal scale of
//! contact `c`, the step of length `ρ` is, contact by contact,
//!
//! ```text
//! r̄_c = P_{K_c}(r_c − (ρ / d_c) û_c(r)).
//! ```
//!
//! The per-contact length `ρ / d_c` is a diagonal preconditioner `D⁻¹`, `D = diag(d_c I₃)`: it
//! makes the step invariant under positive scalings of each contact's rows and columns, as the
//! cone residual is. `D` is constant on each contact, so the projection in the `D`-metric onto the
//! product of cones is still the Euclidean projection contact by contact. The step is accepted
//! when it passes the local Lipschitz test of Khobotov's rule in that metric,
//!
//! ```text
//! ρ ‖û(r̄) − û(r)‖_{D⁻¹} <= L ‖r̄ − r‖_D,
//! ```
//!
//! and shrunk by [`SHRINK`] otherwise, at most [`MAX_SHRINKS`] times; after an accepted step
//! with `ρ ‖û(r̄) − û(r)‖_{D⁻¹} < L_min ‖r̄ − r‖_D` and a lower residual, `ρ` grows by
//! `1 /` [`GROW_INVERSE`]. The constants are those of Siconos' `fc3d_ExtraGradient.c` and
//! `fc3d_FixedPointProjection.c` (`tau = 0.6`, `L = 0.9`, `Lmin = 0.3`, `taumin = 0.7`,
//! `ls_itermax = 10`, starting `rho = 1`), which use the same rule without the preconditioner.

use crate::cone::{
    cone_residuals_and_velocity, de_saxce, initial_reaction, project_onto_cone, ConeMonitor,
    ConeProblem,
};
use crate::problem::metrics::Residuals;
use crate::solver::{Outcome, Settings};

/// Factor applied to `ρ` when the Lipschitz test fails (Siconos' `tau`).
pub(crate) const SHRINK: f64 = 0.6;
/// The Lipschitz test's bound `L` (Siconos' `L`).
pub(crate) const LIPSCHITZ: f64 = 0.9;
/// Below `L_min ‖r̄ − r‖` the step is well inside the test, and `ρ` may grow (Siconos' `Lmin`).
pub(crate) const GROW_BELOW: f64 = 0.3;
/// `ρ` grows to `ρ / GROW_INVERSE` (Siconos' `taumin`).
pub(crate) const GROW_INVERSE: f64 = 0.7;
/// Shrinks per iteration (Siconos' `ls_itermax`); the last trial is taken even if it fails.
pub(crate) const MAX_SHRINKS: usize = 10;
/// Starting `ρ`, in units of `1 / d_c` (Siconos starts from `rho = 1` in absolute units).
pub(crate) const INITIAL_STEP: f64 = 1.0;
/// Below this `ρ` (in units of `1 / d_c`) the step is too short to make progress: the solve
/// stops `Stalled`.
pub(crate) const MIN_STEP: f64 = 1e-12;

/// One point of the iteration: the reaction, its velocity, De Saxcé's velocity and the cone
/// residuals, all measured in one pass over `W`.
#[derive(Debug, Clone)]
pub(crate) struct Point {
    pub(crate) r: Vec<f64>,
    pub(crate) u: Vec<f64>,
    pub(crate) u_hat: Vec<f64>,
    pub(crate) residuals: Residuals,
}

impl Point {
    /// A point with room for `n` rows (all zero, residuals infinite until evaluated).
    pub(crate) fn zeros(n: usize) -> Self {
        Self {
            r: vec![0.0; n],
            u: vec![0.0; n],
            u_hat: vec![0.0; n],
            residuals: Residuals::INFINITE,
        }
    }

    /// Measure `u`, `û` and the residuals at the current `r` (one pass over `W`).
    pub(crate) fn start(problem: &ConeProblem, settings: &Settings) -> Self {
        let mut x = Self::zeros(problem.n());
        x.r = initial_reaction(problem, settings);
        x.evaluate(problem);
        x
    }

    pub(crate) fn evaluate(&mut self, problem: &ConeProblem) {
        self.residuals = cone_residuals_and_velocity(problem, &self.r, &mut self.u);
        for (c, &mu) in problem.mu().iter().enumerate() {
            let s = 3 * c;
            let uh = de_saxce(mu, [self.u[s], self.u[s + 1], self.u[s + 2]]);
            self.u_hat[s..s + 3].copy_from_slice(&uh);
        }
    }

    /// The relative cone residual; infinite at a non-finite point.
    pub(crate) fn residual(&self) -> f64 {
        let e = self.residuals.natural_map_rel;
        if e.is_nan() {
            f64::INFINITY
        } else {
            e
        }
    }
}

/// `1 / d_c` for every contact.
pub(crate) fn inverse_scales(problem: &ConeProblem) -> Vec<f64> {
    (0..problem.contacts())
        .map(|c| 1.0 / problem.scale_of(c))
        .collect()
}

/// `out_c = P_{K_c}(r_c − ρ inv_d_c v_c)` for every contact.
pub(crate) fn projected_step(
    problem: &ConeProblem,
    inv_d: &[f64],
    rho: f64,
    r: &[f64],
    v: &[f64],
    out: &mut [f64],
) {
    for (c, (&mu, &w)) in problem.mu().iter().zip(inv_d).enumerate() {
        let s = 3 * c;
        let t = rho * w;
        let p = project_onto_cone(
            mu,
            [
                r[s] - t * v[s],
                r[s + 1] - t * v[s + 1],
                r[s + 2] - t * v[s + 2],
            ],
        );
        out[s..s + 3].copy_from_slice(&p);
    }
}

/// `(‖û_a − û_b‖_{D⁻¹}, ‖r_a − r_b‖_D)`, the two sides of the Lipschitz test.
pub(crate) fn lipschitz_sides(inv_d: &[f64], a: &Point, b: &Point) -> (f64, f64) {
    let (mut du, mut dr) = (0.0, 0.0);
    for (c, &w) in inv_d.iter().enumerate() {
        let (mut su, mut sr) = (0.0, 0.0);
        for i in 3 * c..3 * c + 3 {
            su += (a.u_hat[i] - b.u_hat[i]).powi(2);
            sr += (a.r[i] - b.r[i]).powi(2);
        }
        du += w * su;
        dr += sr / w;
    }
    (du.sqrt(), dr.sqrt())
}

/// The step length's state across iterations: the rule of the module documentation.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AdaptiveStep {
    /// The current `ρ`, in units of `1 / d_c`.
    pub(crate) rho: f64,
}

impl AdaptiveStep {
    pub(crate) fn new() -> Self {
        Self { rho: INITIAL_STEP }
    }

    /// `ρ` for the `k`-th trial of an iteration.
    pub(crate) fn trial(&self, k: usize) -> f64 {
        self.rho * SHRINK.powi(k as i32)
    }

    /// True when the trial of length `rho` passes the Lipschitz test.
    pub(crate) fn passes(rho: f64, sides: (f64, f64)) -> bool {
        rho * sides.0 <= LIPSCHITZ * sides.1
    }

    /// After an iteration that used `rho` with test sides `sides`: grow it when the step was well
    /// inside the test and the residual fell, else keep it.
    pub(crate) fn update(&mut self, rho: f64, sides: (f64, f64), residual_fell: bool) {
        self.rho = if rho * sides.0 < GROW_BELOW * sides.1 && residual_fell {
            rho / GROW_INVERSE
        } else {
            rho
        };
    }
}

/// The projection step of both methods from `x`: `trial.r = P_K(x.r − ρ û(x.r) / d)`, `ρ` shrunk
/// from the current step until the Lipschitz test passes, the trial meets `tol`, or
/// [`MAX_SHRINKS`] trials are spent. Returns the `ρ` used and the test's two sides, or `None`
/// when the time budget ran out between trials.
pub(crate) fn backtracked_projection(
    problem: &ConeProblem,
    inv_d: &[f64],
    x: &Point,
    step: &AdaptiveStep,
    tol: f64,
    monitor: &ConeMonitor<'_>,
    trial: &mut Point,
) -> Option<(f64, (f64, f64))> {
    let mut used = (step.rho, (0.0, 0.0));
    for k in 0..MAX_SHRINKS {
        if k > 0 && monitor.out_of_time() {
            return None;
        }
        let rho = step.trial(k);
        projected_step(problem, inv_d, rho, &x.r, &x.u_hat, &mut trial.r);
        trial.evaluate(problem);
        let sides = lipschitz_sides(inv_d, trial, x);
        used = (rho, sides);
        if AdaptiveStep::passes(rho, sides) || trial.residual() <= tol {
            break;
        }
    }
    Some(used)
}

/// The checks made before every iteration of the projection methods: tolerance, a non-finite
/// iterate, the iteration cap, the time budget and a vanishing step, in that order.
pub(crate) fn check(
    x: &Point,
    tol: f64,
    iterations: usize,
    settings: &Settings,
    monitor: &ConeMonitor<'_>,
    step: &AdaptiveStep,
) -> Option<Outcome> {
    if x.residual() <= tol {
        return Some(Outcome::Stopped);
    }
    if !(x.r.iter().chain(&x.u).all(|v| v.is_finite())) {
        return Some(Outcome::NumericalFailure(format!(
            "non-finite reaction or velocity after iteration {iterations}"
        )));
    }
    if iterations >= settings.max_iterations {
        return Some(Outcome::IterationLimit);
    }
    if monitor.out_of_time() {
        return Some(Outcome::TimeLimit);
    }
    if step.rho < MIN_STEP {
        return Some(Outcome::Stalled(format!(
            "the step ρ = {:.3e} (in units of 1/d_c) fell below {MIN_STEP:e} after iteration \
             {iterations}: the Lipschitz test keeps failing",
            step.rho
        )));
    }
    None
}

//! Semismooth Newton methods for the LCP and the boxed LCP: the Fischer–Burmeister and the
//! min-map (natural map) reformulations, with an Armijo line search on the merit function and a
//! gradient step when the Newton direction fails.
//!
//! The problem is rewritten as a system of nonsmooth equations `Φ(f) = 0` with the scaled velocity
//! `F = D⁻¹ w = D⁻¹ (A f + b)` (`D` the [diagonal scale](crate::Problem::diagonal_scale), so `Φ`
//! is in impulse units like the shared residual), row by row:
//!
//! ```text
//! min-map:   Φ_i = f_i − mid(lo_i, hi_i, f_i − F_i)
//! FB:        φ(a, b) = a + b − √(a² + b²)
//!            lo finite, hi = ∞:   Φ_i = φ(f_i − lo_i, F_i)
//!            lo = −∞, hi finite:  Φ_i = −φ(hi_i − f_i, −F_i)
//!            both finite:         Φ_i = φ(f_i − lo_i, −φ(hi_i − f_i, −F_i))   (Billups 1995)
//!            both infinite:       Φ_i = F_i
//! ```
//!
//! Each row of an element `H` of the generalised Jacobian is `α_i e_iᵀ + β_i D⁻¹A_i` (plus a
//! coupling entry `γ_i` in the column of the normal row for a friction row, whose bounds
//! `±mu f_k` move with `f_k`). One iteration solves `(H + μ I) d = −Φ` with `μ = min(10⁻², ‖Φ‖∞ /
//! s)` (`s` the residual scale; a Levenberg-type regularisation that keeps the system regular on
//! PSD, rank-deficient `A` and vanishes at the solution, so the local convergence stays
//! quadratic), by a dense LU (faer, partial pivoting). The direction is accepted when it makes
//! an angle with `−∇θ` below 90° by a margin, `∇θᵀd <= −10⁻⁸ ‖∇θ‖ ‖d‖`, for the merit
//! `θ = ½‖Φ‖²` (a scale-free form of De Luca, Facchinei, Kanzow's test `∇θᵀd <= −ρ‖d‖ᵖ`, which
//! rejects the long steps along the null space of a rank-deficient `A` once `θ` is small);
//! otherwise the steepest-descent direction `−∇θ = −Hᵀ Φ` is used. The step length comes from Armijo
//! backtracking on `θ` (`σ = 10⁻⁴`, halving, at most 40 times).
//!
//! * **Problem class**: standard and boxed LCP with friction rows, any `A` with `n <=`
//!   [`Newton::max_dense`] (default 3000; above it the dense LU is too large and the solve is
//!   `Unsupported`). Globally convergent to a stationary point of `θ`; for P-matrices (FB) every
//!   stationary point is a solution, and the measured behaviour on the generated SPD, PSD and
//!   P-matrix families is a relative residual of `1e-10` in well under 30 iterations. Friction
//!   rows are linearised *directly* (the coupling entry `γ_i`) or, with
//!   [`FrictionHandling::FixedPoint`], with their bounds frozen at the current normals in each
//!   linearisation (a fixed point on the bounds; slower, but no coupling entries).
//! * **Cost**: one dense `n × n` LU per iteration (`⅔ n³`), plus `O(n²)` for `H`, `∇θ` and the
//!   products with `A`; line-search trials cost `O(n)` each.
//! * **Failure modes**: a line search that cannot decrease `θ` along either direction ends the
//!   solve (`Stalled`, at a stationary point of `θ` that is not a solution, possible when `A` is
//!   not a P-matrix or with the min-map merit at a kink); a non-finite iterate gives
//!   `NumericalFailure`; [`Settings::max_iterations`] counts Newton iterations.
//! * **Stopping rule**: the shared relative residual of the iterate, projected onto its bounds
//!   (PGS's projection), is at most the tolerance; the projected iterate is returned.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the bounds.
//!
//! References: A. Fischer, *A special Newton-type optimization method*, Optimization 24, 1992;
//! T. De Luca, F. Facchinei, C. Kanzow, *A semismooth equation approach to the solution of
//! nonlinear complementarity problems*, Math. Prog. 75, 1996; S. C. Billups, *Algorithms for
//! complementarity problems and generalized equations*, PhD thesis, 1995; K. Erleben, *Numerical
//! methods for linear complementarity problems in physics-based animation*, SIGGRAPH course
//! 2013, §5 (min-map Newton, num4lcp); Siconos numerics, `NEWTON_MIN_FBLSA`.

use crate::apgd::project;
use crate::metrics::residuals;
use crate::problem::Problem;
use crate::solver::{
    initial_impulse, solve_by_islands, Monitor, Outcome, Settings, SolveResult, Solver,
};
use faer::linalg::solvers::Solve;
use faer::{Col, Mat};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES_FB: &str =
    "LCP, boxed LCP, friction rows (directly); any A; dense LU per island up to 3000 rows; globally convergent for P-matrices";
/// Problem classes handled by the min-map variant.
pub(crate) const PROBLEM_CLASSES_MIN: &str =
    "LCP, boxed LCP, friction rows (directly); any A; dense LU per island up to 3000 rows; local quadratic convergence";

/// Which nonsmooth equation the solver works on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reformulation {
    /// The Fischer–Burmeister function (smooth merit away from degenerate rows).
    FischerBurmeister,
    /// The min-map (natural map) `f − mid(lo, hi, f − F)`.
    MinMap,
}

/// How friction rows (bounds `±mu f_k`) enter the linearisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrictionHandling {
    /// The bounds' dependence on `f_k` is linearised (coupling entries in the Jacobian).
    Direct,
    /// The bounds are frozen at the current normal impulses in each linearisation.
    FixedPoint,
}

/// Semismooth Newton. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Newton {
    /// The reformulation. Default Fischer–Burmeister.
    pub reformulation: Reformulation,
    /// Friction rows. Default [`FrictionHandling::Direct`].
    pub friction: FrictionHandling,
    /// Largest `n` for which the dense Jacobian is formed. Default `3000`.
    pub max_dense: usize,
}

impl Default for Newton {
    fn default() -> Self {
        Self::fischer_burmeister()
    }
}

impl Newton {
    /// Fischer–Burmeister Newton with default settings.
    pub fn fischer_burmeister() -> Self {
        Self {
            reformulation: Reformulation::FischerBurmeister,
            friction: FrictionHandling::Direct,
            max_dense: 3000,
        }
    }

    /// Min-map Newton with default settings.
    pub fn min_map() -> Self {
        Self {
            reformulation: Reformulation::MinMap,
            ..Self::fischer_burmeister()
        }
    }
}

/// Armijo constant.
const SIGMA: f64 = 1e-4;
/// Backtracking steps before a direction is given up.
const MAX_BACKTRACKS: usize = 40;

/// `φ(a, b) = a + b − √(a² + b²)` and its partial derivatives.
#[inline]
fn fb(a: f64, b: f64) -> (f64, f64, f64) {
    let r = a.hypot(b);
    if r == 0.0 {
        let c = 1.0 - std::f64::consts::FRAC_1_SQRT_2;
        (0.0, c, c)
    } else {
        (a + b - r, 1.0 - a / r, 1.0 - b / r)
    }
}

/// One row of `Φ` and of the Jacobian: `Φ_i`, `α_i`, `β_i`, and `γ_i`, the derivative with
/// respect to the normal impulse `f_k` of a friction row (0 otherwise).
struct RowLinearisation {
    phi: f64,
    alpha: f64,
    beta: f64,
    gamma: f64,
}

impl Newton {
    /// `Φ_i` (and its derivative parts) at `f_i`, scaled velocity `fi_vel`, bounds `(lo, hi)`;
    /// `dmu` is `∂hi/∂f_k = −∂lo/∂f_k` for a friction row.
    fn row(&self, fi: f64, vel: f64, lo: f64, hi: f64, dmu: f64) -> RowLinearisation {
        match self.reformulation {
            Reformulation::MinMap => {
                let t = fi - vel;
                if t <= lo {
                    RowLinearisation {
                        phi: fi - lo,
                        alpha: 1.0,
                        beta: 0.0,
                        gamma: dmu,
                    }
                } else if t >= hi {
                    RowLinearisation {
                        phi: fi - hi,
                        alpha: 1.0,
                        beta: 0.0,
                        gamma: -dmu,
                    }
                } else {
                    RowLinearisation {
                        phi: vel,
                        alpha: 0.0,
                        beta: 1.0,
                        gamma: 0.0,
                    }
                }
            }
            Reformulation::FischerBurmeister => match (lo.is_finite(), hi.is_finite()) {
                (true, false) => {
                    let (phi, pa, pb) = fb(fi - lo, vel);
                    RowLinearisation {
                        phi,
                        alpha: pa,
                        beta: pb,
                        gamma: pa * dmu,
                    }
                }
                (false, true) => {
                    let (phi, pa, pb) = fb(hi - fi, -vel);
                    RowLinearisation {
                        phi: -phi,
                        alpha: pa,
                        beta: pb,
                        gamma: -pa * dmu,
                    }
                }
                (false, false) => RowLinearisation {
                    phi: vel,
                    alpha: 0.0,
                    beta: 1.0,
                    gamma: 0.0,
                },
                (true, true) => {
                    let (psi, qa, qb) = fb(hi - fi, -vel);
                    let (phi, pa, pb) = fb(fi - lo, -psi);
                    RowLinearisation {
                        phi,
                        alpha: pa + pb * qa,
                        beta: pb * qb,
                        gamma: dmu * (pa - pb * qa),
                    }
                }
            },
        }
    }

    /// `Φ(f)` into `phi`, given the scaled velocity `vel = D⁻¹ (A f + b)`; returns `θ = ½‖Φ‖²`.
    fn merit(&self, problem: &Problem, f: &[f64], vel: &[f64], phi: &mut [f64]) -> f64 {
        let mut theta = 0.0;
        for i in 0..f.len() {
            let (lo, hi) = problem.bounds_at(i, f);
            let r = self.row(f[i], vel[i], lo, hi, 0.0);
            phi[i] = r.phi;
            theta += 0.5 * r.phi * r.phi;
        }
        if theta.is_finite() {
            theta
        } else {
            f64::INFINITY
        }
    }
}

impl Solver for Newton {
    fn name(&self) -> &'static str {
        match self.reformulation {
            Reformulation::FischerBurmeister => "newton-fb",
            Reformulation::MinMap => "newton-min",
        }
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let limit = self.max_dense;
        solve_by_islands(problem, settings, limit, |island, settings| {
            self.solve_dense(island, settings)
        })
    }
}

impl Newton {
    /// One island, its Newton systems dense.
    fn solve_dense(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        let n = problem.n();
        if n > self.max_dense {
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(format!(
                    "n = {n} rows: the dense Newton system is formed only up to n = {}",
                    self.max_dense
                )),
            );
        }
        let a = problem.to_dense();
        let d = problem.diagonal_scale();
        let b = problem.b();
        let scale = {
            let s = (0..n)
                .map(|i| (b[i] / d[i]).abs())
                .chain(
                    (0..n)
                        .filter(|&i| problem.friction_of(i).is_none())
                        .flat_map(|i| [problem.lo()[i], problem.hi()[i]])
                        .filter(|v| v.is_finite())
                        .map(f64::abs),
                )
                .fold(0.0_f64, f64::max);
            if s > 0.0 {
                s
            } else {
                1.0
            }
        };
        let scaled_velocity = |f: &[f64]| -> Vec<f64> {
            let fc = Col::from_fn(n, |i| f[i]);
            let w = &a * &fc;
            (0..n).map(|i| (w[i] + b[i]) / d[i]).collect()
        };
        let mut f = initial_impulse(problem, settings);
        let mut vel = scaled_velocity(&f);
        let mut phi = vec![0.0; n];
        let mut theta = self.merit(problem, &f, &vel, &mut phi);
        let mut trial_f = vec![0.0; n];
        let mut trial_vel = vec![0.0; n];
        let mut trial_phi = vec![0.0; n];
        let mut iterations = 0;
        let tol = settings.tolerance;
        let outcome = loop {
            // The iterate may sit just outside its bounds (neither reformulation keeps it
            // feasible); its projection is tested too and returned when it is within tolerance.
            let mut fp = f.clone();
            project(problem, &mut fp);
            if residuals(problem, &fp).natural_map_rel <= tol {
                f = fp;
                break Outcome::Stopped;
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            // Jacobian element H = diag(α) + diag(β) D⁻¹ A + coupling.
            let mut alpha = vec![0.0; n];
            let mut beta = vec![0.0; n];
            let mut coupling: Vec<(usize, usize, f64)> = Vec::new();
            for i in 0..n {
                let (lo, hi) = problem.bounds_at(i, &f);
                let dmu = match (problem.friction_of(i), self.friction) {
                    (Some((k, mu)), FrictionHandling::Direct) if f[k] > 0.0 => Some((k, mu)),
                    _ => None,
                };
                let r = self.row(f[i], vel[i], lo, hi, dmu.map_or(0.0, |(_, mu)| mu));
                alpha[i] = r.alpha;
                beta[i] = r.beta / d[i];
                if let Some((k, _)) = dmu {
                    if r.gamma != 0.0 {
                        coupling.push((i, k, r.gamma));
                    }
                }
            }
            let mut h = Mat::from_fn(n, n, |i, j| beta[i] * a[(i, j)]);
            for i in 0..n {
                h[(i, i)] += alpha[i];
            }
            for &(i, k, g) in &coupling {
                h[(i, k)] += g;
            }
            let phi_col = Col::from_fn(n, |i| phi[i]);
            let grad = h.transpose() * &phi_col;
            let phi_inf = phi.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let mu_reg = (phi_inf / scale).min(1e-2);
            for i in 0..n {
                h[(i, i)] += mu_reg;
            }
            let mut dir = Mat::from_fn(n, 1, |i, _| -phi[i]);
            h.partial_piv_lu().solve_in_place(&mut dir);
            let newton_dir: Vec<f64> = (0..n).map(|i| dir[(i, 0)]).collect();
            let dnorm2: f64 = newton_dir.iter().map(|v| v * v).sum();
            let slope: f64 = (0..n).map(|i| grad[i] * newton_dir[i]).sum();
            let gnorm = grad.norm_l2();
            let newton_ok =
                newton_dir.iter().all(|v| v.is_finite()) && slope <= -1e-8 * gnorm * dnorm2.sqrt();
            let gradient_dir: Vec<f64> = (0..n).map(|i| -grad[i]).collect();
            let gslope = -(0..n).map(|i| grad[i] * grad[i]).sum::<f64>();
            let candidates: Vec<(&[f64], f64)> = if newton_ok {
                vec![(&newton_dir, slope), (&gradient_dir, gslope)]
            } else {
                vec![(&gradient_dir, gslope)]
            };
            let mut accepted = false;
            for (direction, slope) in candidates {
                if slope.is_nan() || slope >= 0.0 {
                    continue;
                }
                let ad = scaled_velocity(direction);
                // `ad` holds D⁻¹(A d + b); remove the b part.
                let ad: Vec<f64> = (0..n).map(|i| ad[i] - b[i] / d[i]).collect();
                let mut t = 1.0;
                for _ in 0..MAX_BACKTRACKS {
                    for i in 0..n {
                        trial_f[i] = f[i] + t * direction[i];
                        trial_vel[i] = vel[i] + t * ad[i];
                    }
                    let trial_theta = self.merit(problem, &trial_f, &trial_vel, &mut trial_phi);
                    if trial_theta <= theta + SIGMA * t * slope {
                        std::mem::swap(&mut f, &mut trial_f);
                        std::mem::swap(&mut phi, &mut trial_phi);
                        theta = trial_theta;
                        accepted = true;
                        break;
                    }
                    t *= 0.5;
                }
                if accepted {
                    break;
                }
            }
            iterations += 1;
            if !accepted {
                monitor.record(iterations, &f);
                break Outcome::Stalled(format!(
                    "the line search found no decrease of the merit function at iteration \
                     {iterations} (a stationary point that is not a solution)"
                ));
            }
            // Recompute the velocity from scratch so round-off does not accumulate.
            vel = scaled_velocity(&f);
            theta = self.merit(problem, &f, &vel, &mut phi);
            monitor.record(iterations, &f);
            if f.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite iterate at iteration {iterations}"
                ));
            }
        };
        let mut fp = f.clone();
        project(problem, &mut fp);
        if residuals(problem, &fp).natural_map_rel <= residuals(problem, &f).natural_map_rel {
            f = fp;
        }
        monitor.finish(f, iterations, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{generate, Family};
    use crate::problem::FrictionRow;
    use crate::test_util::lcp;
    use crate::{Dantzig, Status};

    fn tight() -> Settings {
        Settings {
            tolerance: 1e-10,
            max_iterations: 30,
            ..Settings::default()
        }
    }

    #[test]
    fn solves_a_two_by_two_lcp() {
        let p = lcp(&[&[2.0, 1.0], &[1.0, 2.0]], &[-1.0, 1.0]);
        for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
            let r = s.solve(&p, &Settings::default());
            assert_eq!(r.status, Status::Converged, "{}", s.name());
            assert!((r.f[0] - 0.5).abs() < 1e-8 && r.f[1].abs() < 1e-8);
        }
    }

    #[test]
    fn planted_families_reach_1e_10_in_30_iterations() {
        for (family, n) in [
            (Family::Spd { cond: 1e3 }, 60),
            (Family::Spd { cond: 1e6 }, 40),
            (Family::PsdRankDeficient { rank: 15 }, 30),
            (Family::PMatrix, 50),
        ] {
            for seed in 0..3 {
                let g = generate(family, n, seed);
                for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
                    let r = s.solve(&g.problem, &tight());
                    assert_eq!(
                        r.status,
                        Status::Converged,
                        "{} on {family:?} seed {seed}: {} after {} iterations",
                        s.name(),
                        r.residuals.natural_map_rel,
                        r.iterations
                    );
                    assert!(r.residuals.natural_map_rel <= 1e-10);
                    assert!(r.iterations <= 30);
                }
            }
        }
    }

    #[test]
    fn rank_deficient_psd_at_n_100_converges() {
        // Half the rank: the Jacobian is singular at the solution, and the Newton direction is
        // long along its null space while the merit is tiny; the angle test must still take it.
        let g = generate(Family::PsdRankDeficient { rank: 50 }, 100, 0);
        for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
            let r = s.solve(&g.problem, &tight());
            assert_eq!(r.status, Status::Converged, "{}: {}", s.name(), r.status);
        }
    }

    #[test]
    fn convergence_is_quadratic_at_the_end() {
        // On an SPD problem the residual history ends with r_{k+1} <= C r_k², which a linear
        // rate cannot do: the last steps' exponents log r_{k+1} / log r_k approach 2.
        let g = generate(Family::Spd { cond: 1e2 }, 80, 7);
        let settings = Settings {
            tolerance: 1e-14,
            max_iterations: 50,
            record_history: true,
            ..Settings::default()
        };
        let r = Newton::fischer_burmeister().solve(&g.problem, &settings);
        let hist: Vec<f64> = r.history.iter().map(|h| h.residual).collect();
        // The last step from a residual below 1e-3 to the next one (or to 0).
        let k = hist
            .iter()
            .position(|&x| x < 1e-3)
            .expect("residual falls below 1e-3");
        assert!(k + 1 < hist.len(), "{hist:?}");
        let (r0, r1) = (hist[k], hist[k + 1]);
        assert!(
            r1 <= 10.0 * r0 * r0 || r1 <= 1e-14,
            "not quadratic: {r0:e} -> {r1:e}; history {hist:?}"
        );
        assert!(r.residuals.natural_map_rel <= 1e-13, "{hist:?}");
    }

    #[test]
    fn boxed_and_friction_problems_match_dantzig() {
        let n = 12;
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
        let a = crate::generate::spd_matrix(n, 10.0, &mut rng);
        let b: Vec<f64> = (0..n).map(|i| ((i * 7 % 5) as f64 - 2.0) * 0.3).collect();
        let inf = f64::INFINITY;
        let lo = vec![
            0.0, -inf, -0.2, -inf, 0.1, 0.0, -inf, -0.2, -inf, 0.0, 0.0, 0.0,
        ];
        let hi = vec![inf, 0.3, 0.4, inf, 0.1, inf, 0.3, 0.4, inf, inf, 0.0, 0.0];
        let friction = vec![
            FrictionRow {
                row: 10,
                normal: 0,
                mu: 0.5,
            },
            FrictionRow {
                row: 11,
                normal: 9,
                mu: 0.3,
            },
        ];
        let p = Problem::boxed(a, b, lo, hi, friction).unwrap();
        let reference = Dantzig::default().solve(&p, &Settings::default());
        assert_eq!(reference.status, Status::Converged);
        for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
            for handling in [FrictionHandling::Direct, FrictionHandling::FixedPoint] {
                s.friction = handling;
                let r = s.solve(&p, &Settings::default());
                assert_eq!(r.status, Status::Converged, "{} {handling:?}", s.name());
                for (x, y) in r.f.iter().zip(&reference.f) {
                    assert!((x - y).abs() < 1e-6, "{:?} vs {:?}", r.f, reference.f);
                }
            }
        }
    }

    #[test]
    fn too_large_is_unsupported_and_no_solution_stalls() {
        let g = generate(Family::Spd { cond: 10.0 }, 12, 0);
        let mut s = Newton {
            max_dense: 10,
            ..Newton::default()
        };
        assert_eq!(
            s.solve(&g.problem, &Settings::default()).status.name(),
            "unsupported"
        );
        let g = generate(Family::Infeasible, 10, 1);
        let r = Newton::default().solve(&g.problem, &Settings::default());
        assert!(!r.status.is_converged());
    }
}

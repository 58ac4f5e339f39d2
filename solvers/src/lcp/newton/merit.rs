//! The reformulations of the semismooth Newton method: `Φ` row by row (Fischer–Burmeister or
//! min-map), its merit `θ = ½‖Φ‖²`, the rows of the generalised Jacobian `H`, and the merit
//! gradient `∇θ = HᵀΦ`. The step along a direction is chosen by the shared line search
//! ([`crate::solver::line_search`]). A solve works on one [`Formulation`] at a time and may
//! switch to the other reformulation when it stalls (the module documentation of
//! [`super`]).

use super::{FrictionHandling, Reformulation};
use crate::linalg::newton_system::System;
use crate::problem::Problem;

/// `φ(a, b) = a + b − √(a² + b²)` and its partial derivatives.
#[inline]
pub(crate) fn fb(a: f64, b: f64) -> (f64, f64, f64) {
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
pub(crate) struct RowLinearisation {
    pub(crate) phi: f64,
    pub(crate) alpha: f64,
    pub(crate) beta: f64,
    pub(crate) gamma: f64,
}

/// The nonsmooth equation a Newton iteration works on: the reformulation and the treatment of
/// friction rows. A [`super::Newton`] solve starts on its own and may switch reformulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Formulation {
    pub(crate) reformulation: Reformulation,
    pub(crate) friction: FrictionHandling,
}

impl Formulation {
    /// The same friction handling on the other reformulation (min-map ↔ Fischer–Burmeister).
    pub(crate) fn switched(self) -> Self {
        Self {
            reformulation: match self.reformulation {
                Reformulation::FischerBurmeister => Reformulation::MinMap,
                Reformulation::MinMap => Reformulation::FischerBurmeister,
            },
            ..self
        }
    }

    /// Short name of the reformulation, for reasons and reports.
    pub(crate) fn short_name(self) -> &'static str {
        match self.reformulation {
            Reformulation::FischerBurmeister => "FB",
            Reformulation::MinMap => "min-map",
        }
    }

    /// `Φ_i` (and its derivative parts) at `f_i`, scaled velocity `fi_vel`, bounds `(lo, hi)`;
    /// `dmu` is `∂hi/∂f_k = −∂lo/∂f_k` for a friction row.
    pub(crate) fn row(&self, fi: f64, vel: f64, lo: f64, hi: f64, dmu: f64) -> RowLinearisation {
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
    pub(crate) fn merit(&self, problem: &Problem, f: &[f64], vel: &[f64], phi: &mut [f64]) -> f64 {
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

    /// The element `H = diag(α) + diag(β) D⁻¹ A + coupling` of the generalised Jacobian at
    /// `f` (`vel` the scaled velocity): `alpha`, `beta` (holding `β_i / d_i`) and `gamma`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn linearise(
        &self,
        problem: &Problem,
        f: &[f64],
        vel: &[f64],
        d: &[f64],
        alpha: &mut [f64],
        beta: &mut [f64],
        gamma: &mut [f64],
    ) {
        for i in 0..f.len() {
            let (lo, hi) = problem.bounds_at(i, f);
            let dmu = match (problem.friction_of(i), self.friction) {
                (Some((k, mu)), FrictionHandling::Direct) if f[k] > 0.0 => mu,
                _ => 0.0,
            };
            let r = self.row(f[i], vel[i], lo, hi, dmu);
            alpha[i] = r.alpha;
            beta[i] = r.beta / d[i];
            gamma[i] = if dmu != 0.0 { r.gamma } else { 0.0 };
        }
    }
}

/// The merit gradient `∇θ = HᵀΦ` for `H = diag(α) + diag(β) D⁻¹A + coupling` (the
/// regularisation is not part of `H`), in one pass over the stored entries of `A`, whatever its
/// storage.
pub(crate) fn merit_gradient(problem: &Problem, system: &System<'_>) -> Vec<f64> {
    let &System {
        alpha,
        beta,
        gamma,
        phi,
        ..
    } = system;
    let n = phi.len();
    let mut grad = vec![0.0; n];
    for i in 0..n {
        let s = beta[i] * phi[i];
        if s != 0.0 {
            for (c, a) in problem.row(i).iter() {
                grad[c] += a * s;
            }
        }
        grad[i] += alpha[i] * phi[i];
        if gamma[i] != 0.0 {
            if let Some((k, _)) = problem.friction_of(i) {
                grad[k] += gamma[i] * phi[i];
            }
        }
    }
    grad
}

//! Backtracking line search, shared by the Newton methods ([`crate::Newton`],
//! [`crate::NewtonAc`]) and APGD's step-size estimate ([`crate::Apgd`]).
//!
//! Steps `t = 1, ρ, ρ², …` (`ρ` the shrink factor) are tried in turn, at most `max_steps` of
//! them, and the first one a test accepts is taken. The Armijo test accepts `t` when the merit
//! `θ(x + t d)` is at most `θ_ref + σ t ∇θᵀd` (Nocedal and Wright, *Numerical Optimization*,
//! 2nd ed., 2006, §3.1); with `θ_ref` the largest merit of recent iterates instead of the
//! current one it is the non-monotone rule of Grippo, Lampariello and Lucidi (SIAM J. Numer.
//! Anal. 23, 1986). The parameters are checked once, when the search is built, as argmin does
//! for its line searches.

use thiserror::Error;

/// The sufficient-decrease constant `σ` of the Armijo test: `10⁻⁴`, the value Nocedal and
/// Wright recommend (§3.1), small enough that nearly any decrease along a descent direction is
/// accepted.
pub(crate) const ARMIJO_SIGMA: f64 = 1e-4;

/// The shrink factor `ρ` between trial steps: halving, the usual choice for a semismooth Newton
/// method (De Luca, Facchinei and Kanzow, Math. Program. 75, 1996).
pub(crate) const HALVING: f64 = 0.5;

/// Trial steps before the Newton methods give a direction up: the last one tried is
/// `2⁻³⁹ ≈ 1.8e-12`, a step that moves a unit-scaled iterate by less than its round-off.
pub(crate) const NEWTON_BACKTRACKS: usize = 40;

/// The shortest step the LCP Newton methods ([`crate::Newton`]) take along a direction by
/// default ([`crate::Globalisation::min_step`]):
/// `2⁻¹⁴ ≈ 6.1e-5`. Along a Newton direction the merit `θ = ½‖Φ‖²` falls by at most a factor
/// `(1 − t)²` at step `t` (exactly so where `Φ` is linear), so a hundred steps of `2⁻¹⁴`
/// lower `‖Φ‖` by at most `1 − (1 − 2⁻¹⁴)¹⁰⁰ ≈ 0.6 %`: less than the 1 % in a hundred
/// iterations that the shared stagnation rule ([`crate::solver::Stagnation`], the Newton
/// methods' window of 100) asks for. Shorter steps cannot make the progress that rule
/// requires, so a search that finds none longer declares a stall at once instead of creeping
/// for the whole window.
pub(crate) const MIN_NEWTON_STEP: f64 = 1.0 / 16384.0;

/// A direction `d` counts as a descent direction for the merit when `∇θᵀd <= −DESCENT_ANGLE ·
/// ‖∇θ‖ ‖d‖`, that is when the angle between `d` and `−∇θ` is below about `90° − 6·10⁻⁷°`: a
/// Newton direction nearly orthogonal to the gradient is replaced by steepest descent.
pub(crate) const DESCENT_ANGLE: f64 = 1e-8;

/// Why a line search's parameters were refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LineSearchError {
    /// `σ` must lie in `(0, 1)`.
    #[error("line search: sufficient-decrease constant {0} is not in (0, 1)")]
    Sigma(f64),
    /// `ρ` must lie in `(0, 1)`.
    #[error("line search: shrink factor {0} is not in (0, 1)")]
    Shrink(f64),
    /// At least one step must be tried.
    #[error("line search: the number of trial steps must be at least 1")]
    NoSteps,
    /// The shortest step must lie in `(0, 1]`.
    #[error("line search: shortest step {0} is not in (0, 1]")]
    MinStep(f64),
}

/// A backtracking line search with validated parameters. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backtracking {
    sigma: f64,
    shrink: f64,
    max_steps: usize,
}

impl Backtracking {
    /// A search with sufficient-decrease constant `sigma` and shrink factor `shrink` (both in
    /// `(0, 1)`) trying at most `max_steps >= 1` steps.
    pub fn new(sigma: f64, shrink: f64, max_steps: usize) -> Result<Self, LineSearchError> {
        // Written so that NaN fails each test.
        if !(sigma > 0.0 && sigma < 1.0) {
            return Err(LineSearchError::Sigma(sigma));
        }
        if !(shrink > 0.0 && shrink < 1.0) {
            return Err(LineSearchError::Shrink(shrink));
        }
        if max_steps == 0 {
            return Err(LineSearchError::NoSteps);
        }
        Ok(Self {
            sigma,
            shrink,
            max_steps,
        })
    }

    /// A search with sufficient-decrease constant `sigma` and shrink factor `shrink` (both in
    /// `(0, 1)`) that tries the steps `1, ρ, ρ², …` no shorter than `min_step` (in `(0, 1]`):
    /// a step below it makes too little progress to be worth taking, and the search fails
    /// instead (the caller declares a stall). `ρᵏ` within a relative `10⁻⁹` of `min_step`
    /// counts as reaching it, so that `min_step = 2⁻¹⁴` with halving tries `2⁻¹⁴` itself.
    pub fn down_to(sigma: f64, shrink: f64, min_step: f64) -> Result<Self, LineSearchError> {
        // Written so that NaN fails the test.
        if !(min_step > 0.0 && min_step <= 1.0) {
            return Err(LineSearchError::MinStep(min_step));
        }
        Self::new(sigma, shrink, 1)?;
        // The largest k with ρᵏ >= min_step: k = ⌊ln(min_step) / ln ρ⌋, finite since both
        // logarithms are (min_step > 0, 0 < ρ < 1), and at least 0 since min_step <= 1.
        let k = (min_step.ln() / shrink.ln() * (1.0 + 1e-9)).floor();
        let steps = if k < (usize::MAX / 2) as f64 {
            k as usize + 1
        } else {
            usize::MAX / 2
        };
        Self::new(sigma, shrink, steps)
    }

    /// The Newton methods' search: [`ARMIJO_SIGMA`], [`HALVING`], [`NEWTON_BACKTRACKS`].
    pub(crate) fn newton() -> Self {
        Self::new(ARMIJO_SIGMA, HALVING, NEWTON_BACKTRACKS).expect("valid constants")
    }

    /// The shortest step the search tries, `ρ^(max_steps − 1)`.
    pub fn min_step(&self) -> f64 {
        let exponent = i32::try_from(self.max_steps - 1).unwrap_or(i32::MAX);
        self.shrink.powi(exponent)
    }

    /// The first step `t` of `1, ρ, ρ², …` that `accept` takes: `Ok(t)`, or `Err(t)` with the
    /// last step tried when none was taken.
    pub fn search(&self, mut accept: impl FnMut(f64) -> bool) -> Result<f64, f64> {
        let mut t = 1.0;
        for k in 0..self.max_steps {
            if accept(t) {
                return Ok(t);
            }
            if k + 1 < self.max_steps {
                t *= self.shrink;
            }
        }
        Err(t)
    }

    /// The Armijo test along a direction of slope `slope = ∇θᵀd < 0`: the first step with
    /// `merit(t) <= reference + σ t slope`, or `None`. `reference` is the current merit
    /// (monotone) or the largest recent one (non-monotone).
    pub fn armijo(
        &self,
        reference: f64,
        slope: f64,
        mut merit: impl FnMut(f64) -> f64,
    ) -> Option<f64> {
        let sigma = self.sigma;
        self.search(|t| merit(t) <= reference + sigma * t * slope)
            .ok()
    }
}

/// Whether `d` (with `slope = ∇θᵀd`, `gnorm = ‖∇θ‖`, `dnorm = ‖d‖`) is a usable descent
/// direction ([`DESCENT_ANGLE`]); a non-finite direction never is.
pub(crate) fn is_descent(d: &[f64], slope: f64, gnorm: f64, dnorm: f64) -> bool {
    d.iter().all(|v| v.is_finite()) && slope <= -DESCENT_ANGLE * gnorm * dnorm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_are_validated() {
        assert_eq!(
            Backtracking::new(0.0, 0.5, 4),
            Err(LineSearchError::Sigma(0.0))
        );
        assert!(matches!(
            Backtracking::new(f64::NAN, 0.5, 4),
            Err(LineSearchError::Sigma(_))
        ));
        assert_eq!(
            Backtracking::new(1e-4, 1.0, 4),
            Err(LineSearchError::Shrink(1.0))
        );
        assert_eq!(
            Backtracking::new(1e-4, 0.5, 0),
            Err(LineSearchError::NoSteps)
        );
    }

    #[test]
    fn armijo_takes_the_first_sufficient_decrease() {
        // θ(t) = (1 − t)² along d with slope −2 at t = 0: the full step is accepted.
        let ls = Backtracking::newton();
        assert_eq!(ls.armijo(1.0, -2.0, |t| (1.0 - t) * (1.0 - t)), Some(1.0));
        // θ(t) = (1 − 4t)²: t = 1 and ½ overshoot, ¼ reaches the minimum.
        assert_eq!(
            ls.armijo(1.0, -8.0, |t| (1.0 - 4.0 * t) * (1.0 - 4.0 * t)),
            Some(0.25)
        );
        // An ascent direction is never accepted.
        assert_eq!(ls.armijo(1.0, -1.0, |t| 1.0 + t), None);
    }

    /// The search down to `2⁻¹⁴` tries `1, ½, …, 2⁻¹⁴` and no shorter step: a merit that
    /// decreases only for shorter steps is a failed search (a stall), not a creep.
    #[test]
    fn a_search_with_a_shortest_step_rejects_shorter_ones() {
        let ls = Backtracking::down_to(ARMIJO_SIGMA, HALVING, MIN_NEWTON_STEP).unwrap();
        assert_eq!(ls.min_step(), MIN_NEWTON_STEP);
        let mut tried = Vec::new();
        assert_eq!(
            ls.search(|t| {
                tried.push(t);
                false
            }),
            Err(MIN_NEWTON_STEP)
        );
        assert_eq!(tried.len(), 15);
        assert_eq!(tried[14], 1.0 / 16384.0);
        // A merit that decreases only for steps up to 2⁻¹⁶: the search down to 2⁻³⁹ creeps
        // with a step of 2⁻¹⁶, this one finds none.
        let eps = MIN_NEWTON_STEP / 4.0;
        let merit = |t: f64| if t <= eps { 1.0 - t } else { 1.0 + t };
        assert!(Backtracking::newton().armijo(1.0, -1.0, merit).is_some());
        assert_eq!(ls.armijo(1.0, -1.0, merit), None);
        // A step of exactly the minimum is still taken.
        let at_min = |t: f64| {
            if t <= MIN_NEWTON_STEP {
                1.0 - t
            } else {
                1.0 + t
            }
        };
        assert_eq!(ls.armijo(1.0, -1.0, at_min), Some(MIN_NEWTON_STEP));
        // Other shrink factors: ρᵏ >= min_step for the last step tried, ρᵏ⁺¹ < min_step.
        for (shrink, min_step) in [(0.3, 1e-3), (0.9, 0.5), (0.5, 1.0), (0.1, 1e-300)] {
            let ls = Backtracking::down_to(1e-4, shrink, min_step).unwrap();
            let last = ls.min_step();
            assert!(
                last >= min_step * (1.0 - 1e-9),
                "{shrink} {min_step}: {last}"
            );
            assert!(last * shrink < min_step, "{shrink} {min_step}: {last}");
        }
        for bad in [0.0, -1.0, 1.5, f64::NAN] {
            assert!(matches!(
                Backtracking::down_to(1e-4, 0.5, bad),
                Err(LineSearchError::MinStep(_))
            ));
        }
        assert_eq!(
            Backtracking::down_to(1e-4, 1.0, 0.5),
            Err(LineSearchError::Shrink(1.0))
        );
    }

    #[test]
    fn search_reports_the_last_step_tried() {
        let ls = Backtracking::new(1e-4, 0.5, 3).unwrap();
        let mut tried = Vec::new();
        assert_eq!(
            ls.search(|t| {
                tried.push(t);
                false
            }),
            Err(0.25)
        );
        assert_eq!(tried, [1.0, 0.5, 0.25]);
    }
}

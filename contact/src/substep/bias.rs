//! The velocity targets the substepping solvers give their rows, and the projection of a warm
//! start onto the rows' bounds: one rule for `pgs-ngs` and `jacobi`.
//!
//! A normal row of position error `C` (the gap, negative when penetrating) at a solve's start
//! asks for `w = J v + bias ≥ 0` with
//!
//! * `bias = e · v⁻` when the contact bounces (restitution `e > 0`, approach speed `v⁻` at the
//!   step's start below `−restitution_threshold`, and the contact closed or closing within the
//!   (sub)step: [`crate::builder::bounces`], the builder's rule): the target separation speed is
//!   `−e v⁻`;
//! * else `bias = C / h` for an open contact (`C > 0`, speculative: the bodies may close the gap
//!   within the step but not more);
//! * else the solver's position feedback ([`Feedback`]): none (Box2D 2.x's velocity solver,
//!   which corrects positions in a separate pass), Baumgarte `β/h · min(0, C + slop)`, or a
//!   soft spring (Catto 2011; Box2D v3 `b2PrepareContactsTask`: `max(bias_rate · C,
//!   −push_out)` with the spring's mass and impulse scales).
//!
//! Friction rows have no bias; joint rows have `β/h · C` under Baumgarte feedback and none
//! otherwise (joints stay rigid under soft contact feedback).

use super::softness::{Softness, PUSH_OUT};
use super::state::{RowRole, SolverRow, SolverState};
use crate::builder::bounces;

/// How a solver feeds position error back into its velocity targets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feedback {
    /// No position term (the velocity pass of a solver that corrects positions separately).
    None,
    /// Baumgarte: `β/h · min(0, C + slop)` on normal rows, `β/h · C` on joint rows.
    Baumgarte {
        /// `β`, the share of the error removed per (sub)step.
        beta: f64,
        /// Penetration allowed without correction, m.
        slop: f64,
    },
    /// Soft contacts: the spring's coefficients over the (sub)step; joints rigid, no bias.
    Soft(Softness),
}

impl Feedback {
    /// Soft contact feedback for `hertz > 0`, else `otherwise`.
    pub fn soft_or(hertz: f64, zeta: f64, h: f64, otherwise: Feedback) -> Feedback {
        if hertz > 0.0 {
            Feedback::Soft(Softness::new(hertz, zeta, h))
        } else {
            otherwise
        }
    }
}

/// A row's velocity target for one solve: `bias` (so that `w = J v + bias`) and the softness
/// its update uses ([`Softness::RIGID`] for a rigid row).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowTarget {
    /// Added to `J v`.
    pub bias: f64,
    /// Mass and impulse scales of the update.
    pub softness: Softness,
}

impl RowTarget {
    const RIGID: RowTarget = RowTarget {
        bias: 0.0,
        softness: Softness::RIGID,
    };
}

/// A rigid row with no bias.
impl Default for RowTarget {
    fn default() -> Self {
        Self::RIGID
    }
}

/// The target of every row at the current pose (`C = C₀ + J Δx`), for a solve over a (sub)step
/// `h`; `threshold` is the restitution threshold (m/s).
pub fn row_targets(
    state: &SolverState,
    feedback: Feedback,
    h: f64,
    threshold: f64,
) -> Vec<RowTarget> {
    state
        .rows
        .iter()
        .map(|row| {
            row_target(
                row,
                row.position_error(&state.bodies),
                feedback,
                h,
                threshold,
            )
        })
        .collect()
}

/// The target of one row whose position error is `c` (see the module doc).
pub fn row_target(
    row: &SolverRow,
    c: f64,
    feedback: Feedback,
    h: f64,
    threshold: f64,
) -> RowTarget {
    match row.role {
        RowRole::Normal(_) => {
            if bounces(c, row.approach, row.restitution, threshold, h) {
                RowTarget {
                    bias: row.restitution * row.approach,
                    softness: Softness::RIGID,
                }
            } else if c > 0.0 {
                RowTarget {
                    bias: c / h,
                    softness: Softness::RIGID,
                }
            } else {
                match feedback {
                    Feedback::None => RowTarget::RIGID,
                    Feedback::Baumgarte { beta, slop } => RowTarget {
                        bias: beta / h * (c + slop).min(0.0),
                        softness: Softness::RIGID,
                    },
                    Feedback::Soft(s) => RowTarget {
                        bias: (s.bias_rate * c).max(-PUSH_OUT),
                        softness: s,
                    },
                }
            }
        }
        RowRole::Joint => match feedback {
            Feedback::Baumgarte { beta, .. } => RowTarget {
                bias: beta / h * c,
                softness: Softness::RIGID,
            },
            Feedback::None | Feedback::Soft(_) => RowTarget::RIGID,
        },
        RowRole::Friction { .. } | RowRole::Other => RowTarget::RIGID,
    }
}

/// True for a row the substepping solvers update: a normal, friction or joint row with a
/// dynamic body (`k > 0`).
pub fn is_swept(row: &SolverRow) -> bool {
    row.mass > 0.0 && !matches!(row.role, RowRole::Other)
}

/// The accumulated impulses to start from: `warm` (one per row; missing entries, non-finite
/// values and rows not swept start at 0) projected onto the bounds: a normal impulse `≥ 0`, a
/// friction impulse within `±μ λ_n` of its projected normal, a joint impulse as given.
pub fn warm_impulses(state: &SolverState, warm: Option<&[f64]>) -> Vec<f64> {
    let warm = warm.unwrap_or(&[]);
    let n = state.rows.len();
    let given = |i: usize| {
        warm.get(i)
            .copied()
            .filter(|v| v.is_finite())
            .unwrap_or(0.0)
    };
    let mut lambda = vec![0.0; n];
    for (i, row) in state.rows.iter().enumerate() {
        if !is_swept(row) {
            continue;
        }
        match row.role {
            RowRole::Normal(_) => lambda[i] = given(i).max(0.0),
            RowRole::Joint => lambda[i] = given(i),
            RowRole::Friction { .. } | RowRole::Other => {}
        }
    }
    for (i, row) in state.rows.iter().enumerate() {
        if let (true, RowRole::Friction { normal }) = (is_swept(row), row.role) {
            let bound = row.mu * lambda[normal];
            lambda[i] = given(i).clamp(-bound, bound);
        }
    }
    lambda
}

/// The accumulated impulse a projected update gives row `i` from `lambda[i]` at the rate
/// `rate = J v`: `λ − m · mass_scale · (rate + bias) − impulse_scale · λ` with `m = 1/k_eff`,
/// projected onto the row's bounds (`≥ 0` for a normal row, `±bound` for a friction row, none
/// for a joint row).
#[inline]
pub fn projected_update(
    role: RowRole,
    lambda: f64,
    rate: f64,
    target: &RowTarget,
    mass: f64,
    friction_bound: f64,
) -> f64 {
    let s = &target.softness;
    let new = lambda - mass * s.mass_scale * (rate + target.bias) - s.impulse_scale * lambda;
    match role {
        RowRole::Normal(_) => new.max(0.0),
        RowRole::Friction { .. } => new.clamp(-friction_bound, friction_bound),
        RowRole::Joint => new,
        RowRole::Other => lambda,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builder::JacobianBlock;
    use nalgebra::Vector3;

    fn normal_row(approach: f64, restitution: f64) -> SolverRow {
        SolverRow {
            role: RowRole::Normal(0),
            blocks: [JacobianBlock::default(); 2],
            response: [(Vector3::zeros(), Vector3::zeros()); 2],
            sides: 0,
            k: 1.0,
            mass: 1.0,
            c0: 0.0,
            mu: 0.0,
            restitution,
            approach,
        }
    }

    #[test]
    fn targets_follow_the_rule_in_order() {
        let h = 0.01;
        let base = Feedback::Baumgarte {
            beta: 0.2,
            slop: 0.005,
        };
        // A bounce wins over the position term.
        let t = row_target(&normal_row(-2.0, 0.5), -0.01, base, h, 1.0);
        assert_eq!(t.bias, -1.0);
        // Below the threshold: Baumgarte on the penetration beyond the slop.
        let t = row_target(&normal_row(-0.5, 0.5), -0.015, base, h, 1.0);
        assert!((t.bias - 0.2 / h * -0.01).abs() < 1e-15);
        // Within the slop: nothing.
        assert_eq!(
            row_target(&normal_row(0.0, 0.0), -0.004, base, h, 1.0).bias,
            0.0
        );
        // Open: speculative.
        let t = row_target(&normal_row(0.0, 0.0), 0.03, base, h, 1.0);
        assert!((t.bias - 3.0).abs() < 1e-12);
        // No feedback: nothing for a penetration.
        let t = row_target(&normal_row(0.0, 0.0), -0.1, Feedback::None, h, 1.0);
        assert_eq!(t, RowTarget::RIGID);
        // Soft: capped at the push-out speed.
        let soft = Feedback::soft_or(30.0, 10.0, h, Feedback::None);
        let t = row_target(&normal_row(0.0, 0.0), -1.0, soft, h, 1.0);
        assert_eq!(t.bias, -PUSH_OUT);
        assert!(t.softness.mass_scale < 1.0);
    }

    #[test]
    fn projected_update_respects_bounds() {
        let rigid = RowTarget::RIGID;
        assert_eq!(
            projected_update(RowRole::Normal(0), 1.0, 5.0, &rigid, 1.0, 0.0),
            0.0
        );
        assert_eq!(
            projected_update(RowRole::Normal(0), 1.0, -2.0, &rigid, 0.5, 0.0),
            2.0
        );
        let f = RowRole::Friction { normal: 0 };
        assert_eq!(projected_update(f, 0.0, -10.0, &rigid, 1.0, 0.3), 0.3);
        assert_eq!(
            projected_update(RowRole::Joint, 0.0, -10.0, &rigid, 1.0, 0.0),
            10.0
        );
    }
}

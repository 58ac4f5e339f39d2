//! Soft constraints: a constraint made a damped spring of natural frequency `hertz` and
//! damping ratio `zeta` (Catto, "Soft Constraints: Reinventing the Spring", GDC 2011; the form
//! Box2D v3 uses in its soft step, `b2MakeSoft`).
//!
//! For a constraint `C(x)` with effective mass `m = 1 / (J M⁻¹ Jᵀ)`, a spring of stiffness
//! `k = m ω²` and damping `c = 2 m ζ ω` (`ω = 2π hertz`), integrated implicitly over a step `h`,
//! gives the velocity update
//!
//! `Δλ = −m · mass_scale · (J v + bias_rate · C) − impulse_scale · λ`
//!
//! with `bias_rate = ω / (2ζ + hω)`, `mass_scale = hω(2ζ + hω) / (1 + hω(2ζ + hω))` and
//! `impulse_scale = 1 / (1 + hω(2ζ + hω))`, `λ` the impulse accumulated so far. `hertz = 0` is
//! the rigid constraint without position feedback (`bias_rate = 0`, `mass_scale = 1`,
//! `impulse_scale = 0`). The spring is stable for any `h` (implicit), and its stiffness is set in
//! hertz, independent of the masses it joins, which is what keeps mass ratios tractable.
//!
//! Defaults (Box2D v3, `b2DefaultWorldDef`): contacts 30 Hz with `ζ = 10`, contacts of a body
//! with a static body at twice the contact hertz, joints 60 Hz with `ζ = 2` (Box2D v3.0), and a
//! push-out speed (the largest separating speed the position term may ask for) of 3 m/s.

/// Box2D v3's contact stiffness, Hz.
pub const CONTACT_HERTZ: f64 = 30.0;
/// Box2D v3's contact damping ratio.
pub const CONTACT_ZETA: f64 = 10.0;
/// Box2D v3's joint stiffness, Hz.
pub const JOINT_HERTZ: f64 = 60.0;
/// Box2D v3.0's joint damping ratio.
pub const JOINT_ZETA: f64 = 2.0;
/// Box2D v3's largest push-out speed of the position term (`contactPushMaxVelocity`), m/s.
pub const PUSH_OUT: f64 = 3.0;

/// The three coefficients of a soft constraint over a (sub)step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Softness {
    /// Position error to velocity, 1/s.
    pub bias_rate: f64,
    /// Scale of the effective mass, in `[0, 1]`.
    pub mass_scale: f64,
    /// Share of the accumulated impulse taken back each solve, in `[0, 1]`.
    pub impulse_scale: f64,
}

impl Softness {
    /// The rigid constraint with no position feedback: `bias_rate = 0`, `mass_scale = 1`,
    /// `impulse_scale = 0` (the relax pass, and `hertz = 0`).
    pub const RIGID: Softness = Softness {
        bias_rate: 0.0,
        mass_scale: 1.0,
        impulse_scale: 0.0,
    };

    /// A spring of `hertz` and damping ratio `zeta` over a (sub)step `h`; [`Softness::RIGID`]
    /// for `hertz = 0`.
    pub fn new(hertz: f64, zeta: f64, h: f64) -> Self {
        if hertz <= 0.0 {
            return Self::RIGID;
        }
        let omega = 2.0 * std::f64::consts::PI * hertz;
        let a1 = 2.0 * zeta + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Softness {
            bias_rate: omega / a1,
            mass_scale: a2 * a3,
            impulse_scale: a3,
        }
    }

    /// Baumgarte stabilisation as a softness: `bias_rate = β / h`, rigid otherwise.
    pub fn baumgarte(beta: f64, h: f64) -> Self {
        Softness {
            bias_rate: beta / h,
            ..Self::RIGID
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The soft update is the implicit Euler step of a damped spring: a unit mass on a spring
    /// of `hertz`, `zeta`, started at `x = −1`, `v = 0`, follows the closed-form implicit
    /// recursion `v' = (v − h(k x + c v)... )` solved for `v'`.
    #[test]
    fn matches_the_implicit_spring() {
        let (hertz, zeta, h) = (5.0, 0.7, 1e-3);
        let s = Softness::new(hertz, zeta, h);
        let omega = 2.0 * std::f64::consts::PI * hertz;
        let (k, c) = (omega * omega, 2.0 * zeta * omega);
        let (mut x, mut v) = (-1.0_f64, 0.0_f64);
        let (mut xs, mut vs) = (x, v);
        for _ in 0..2000 {
            // Implicit Euler of x'' = -k x - c v: v' = v - h(k (x + h v') + c v').
            let v_next = (v - h * k * x) / (1.0 + h * c + h * h * k);
            v = v_next;
            x += h * v;
            // Soft constraint form, one solve from λ = 0 (unit mass: m = 1, J v = vs).
            let dv = -s.mass_scale * (vs + s.bias_rate * xs);
            vs += dv;
            xs += h * vs;
        }
        assert!((x - xs).abs() < 1e-12, "{x} vs {xs}");
        assert!((v - vs).abs() < 1e-12, "{v} vs {vs}");
        assert!(x.abs() < 0.1, "the spring settles: {x}");
    }

    #[test]
    fn zero_hertz_is_rigid() {
        assert_eq!(Softness::new(0.0, 1.0, 0.01), Softness::RIGID);
        let s = Softness::new(30.0, 10.0, 1.0 / 240.0);
        assert!(s.mass_scale > 0.0 && s.mass_scale < 1.0);
        assert!((s.mass_scale + s.impulse_scale - 1.0).abs() < 1e-15);
    }
}

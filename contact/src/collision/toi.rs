//! Time of impact of two moving shapes within a step.
//!
//! A body that moves further than its own thickness in one step can pass through another body
//! without the two ever overlapping at the end of a step ("tunnelling"). Both methods here
//! follow each body along a rigid [`Motion`] (constant linear velocity of the body origin,
//! constant angular velocity about it) and return the first time `t ∈ [0, dt]` at which the
//! surfaces are within `tolerance` of each other, before they overlap.
//!
//! * [`time_of_impact_bisection`] samples the step at intervals short enough that neither
//!   shape can be crossed between samples (the relative motion bound times the interval is at
//!   most the sum of the two [`Shape::inner_radius`]), then bisects between the last separated
//!   sample and the first touching one (Baraff and Witkin, SIGGRAPH 2001 course notes,
//!   "Rigid body simulation II", on backing up to the time of collision).
//! * [`time_of_impact_conservative`] is conservative advancement (Mirtich 1996, thesis §2.3):
//!   with `d` the current distance and `μ = |v_b − v_a| + |ω_a| r_a + |ω_b| r_b` a bound on the
//!   speed at which any two surface points approach (`r` the [`Shape::bounding_radius`]), no
//!   contact can happen before `t + d / μ`, so advance to it and repeat until `d <= tolerance`.
//!   It never steps past the first contact, whatever the shapes' thickness.
//!
//! [`first_impact`] applies either method to a whole body list: the broad phase runs on the
//! boxes swept by the bodies over the step, and the earliest impact among pairs that are apart
//! at the start of the step is returned.
//!
//! Distances come from parry (`parry::query::distance`, 0 when the shapes overlap). For a
//! triangle mesh it is the distance to the mesh surface, so the bisection sampling assumes the
//! other shape does not fit inside the mesh between two samples; conservative advancement has
//! no such assumption.

use super::broad_phase::{candidate_pairs_with_boxes, TooManyPairs};
use crate::body::RigidBody;
use crate::shape::Shape;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use parry3d_f64::bounding_volume::{Aabb, BoundingVolume};
use parry3d_f64::shape::SharedShape;

/// Rigid motion of a body during a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Pose at the start of the step (body origin = centre of mass).
    pub start: Isometry3<f64>,
    /// Linear velocity of the body origin, world frame.
    pub linvel: Vector3<f64>,
    /// Angular velocity about the body origin, world frame.
    pub angvel: Vector3<f64>,
}

impl Motion {
    /// Motion with constant velocities `linvel`, `angvel` from pose `start`.
    pub fn new(start: Isometry3<f64>, linvel: Vector3<f64>, angvel: Vector3<f64>) -> Self {
        Self {
            start,
            linvel,
            angvel,
        }
    }

    /// A body that does not move.
    pub fn stationary(start: Isometry3<f64>) -> Self {
        Self::new(start, Vector3::zeros(), Vector3::zeros())
    }

    /// The current pose and velocities of `body` (zero velocities for a static body).
    pub fn of_body(body: &RigidBody) -> Self {
        if body.is_static {
            Self::stationary(body.iso())
        } else {
            Self::new(body.iso(), body.velocity(), body.angular_velocity())
        }
    }

    /// Pose at time `t`: origin at `x₀ + v t`, orientation `exp(ω t) R₀`.
    pub fn at(&self, t: f64) -> Isometry3<f64> {
        let rotation = UnitQuaternion::from_scaled_axis(self.angvel * t) * self.start.rotation;
        Isometry3::from_parts(
            Translation3::from(self.start.translation.vector + self.linvel * t),
            rotation,
        )
    }
}

/// Settings shared by both time-of-impact methods.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToiSettings {
    /// Distance at which the shapes count as touching. Default `1e-4`.
    pub tolerance: f64,
    /// Largest number of distance queries. Default `10_000`.
    pub max_iterations: usize,
}

impl Default for ToiSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-4,
            max_iterations: 10_000,
        }
    }
}

/// A time of impact found within the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Toi {
    /// Time since the start of the step, in `[0, dt]`.
    pub time: f64,
    /// Distance between the surfaces at `time` (`<= tolerance`; 0 only if the shapes already
    /// overlapped at the start or the iteration limit was reached).
    pub distance: f64,
    /// Number of distance queries used.
    pub iterations: usize,
}

/// Geometry and motions of one pair, with the distance query.
struct Pair<'a> {
    a: SharedShape,
    b: SharedShape,
    motion_a: &'a Motion,
    motion_b: &'a Motion,
}

impl Pair<'_> {
    /// Surface distance at time `t` (0 when overlapping); `None` if parry has no distance query
    /// for the pair (plane against plane).
    fn distance(&self, t: f64) -> Option<f64> {
        parry3d_f64::query::distance(
            &self.motion_a.at(t),
            &*self.a,
            &self.motion_b.at(t),
            &*self.b,
        )
        .ok()
    }
}

/// Upper bound on the speed at which surface points of the two moving shapes approach each
/// other: `|v_b − v_a| + |ω_a| r_a + |ω_b| r_b`, with `r` the bounding radius (a rotation term
/// is dropped when the angular velocity is zero, so planes may take part).
pub fn motion_bound(shape_a: &Shape, motion_a: &Motion, shape_b: &Shape, motion_b: &Motion) -> f64 {
    let spin = |shape: &Shape, m: &Motion| {
        let w = m.angvel.norm();
        if w == 0.0 {
            0.0
        } else {
            w * shape.bounding_radius()
        }
    };
    (motion_b.linvel - motion_a.linvel).norm() + spin(shape_a, motion_a) + spin(shape_b, motion_b)
}

/// First time in `[0, dt]` at which the shapes come within `settings.tolerance`, by sampling and
/// bisection (see the module documentation). `None` if they stay apart during the step.
pub fn time_of_impact_bisection(
    shape_a: &Shape,
    motion_a: &Motion,
    shape_b: &Shape,
    motion_b: &Motion,
    dt: f64,
    settings: &ToiSettings,
) -> Option<Toi> {
    let pair = Pair {
        a: shape_a.to_parry(),
        b: shape_b.to_parry(),
        motion_a,
        motion_b,
    };
    let tol = settings.tolerance;
    let mut iterations = 1;
    let d0 = pair.distance(0.0)?;
    if d0 <= tol {
        return Some(Toi {
            time: 0.0,
            distance: d0,
            iterations,
        });
    }
    let bound = motion_bound(shape_a, motion_a, shape_b, motion_b);
    if !(bound > 0.0 && dt > 0.0) {
        return None;
    }
    // Sample so that the relative motion between samples cannot cross either shape.
    let thickness = (shape_a.inner_radius() + shape_b.inner_radius()).max(tol);
    let samples = ((bound * dt / thickness).ceil() as usize).clamp(1, settings.max_iterations);
    let h = dt / samples as f64;
    let mut lo = 0.0;
    let mut hi = None;
    for k in 1..=samples {
        let t = if k == samples { dt } else { k as f64 * h };
        let d = pair.distance(t)?;
        iterations += 1;
        if d <= tol {
            hi = Some((t, d));
            break;
        }
        lo = t;
    }
    let (mut hi, mut d_hi) = hi?;
    // Invariant: d(lo) > tol, d(hi) <= tol. Stop once d(hi) is a real gap (not an overlap).
    while d_hi <= 0.0 && iterations < settings.max_iterations {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        let d = pair.distance(mid)?;
        iterations += 1;
        if d <= tol {
            (hi, d_hi) = (mid, d);
        } else {
            lo = mid;
        }
    }
    Some(Toi {
        time: hi,
        distance: d_hi,
        iterations,
    })
}

/// First time in `[0, dt]` at which the shapes come within `settings.tolerance`, by
/// conservative advancement (see the module documentation). `None` if they stay apart during
/// the step.
pub fn time_of_impact_conservative(
    shape_a: &Shape,
    motion_a: &Motion,
    shape_b: &Shape,
    motion_b: &Motion,
    dt: f64,
    settings: &ToiSettings,
) -> Option<Toi> {
    let pair = Pair {
        a: shape_a.to_parry(),
        b: shape_b.to_parry(),
        motion_a,
        motion_b,
    };
    let bound = motion_bound(shape_a, motion_a, shape_b, motion_b);
    let mut t = 0.0;
    for iterations in 1..=settings.max_iterations {
        let d = pair.distance(t)?;
        if d <= settings.tolerance {
            return Some(Toi {
                time: t,
                distance: d,
                iterations,
            });
        }
        if bound.is_nan() || bound <= 0.0 {
            return None;
        }
        t += d / bound;
        if t > dt {
            return None;
        }
    }
    None
}

/// Which time-of-impact method [`first_impact`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ToiMethod {
    /// [`time_of_impact_bisection`].
    Bisection,
    /// [`time_of_impact_conservative`] (the default).
    #[default]
    ConservativeAdvancement,
}

impl ToiMethod {
    /// The setting of a scene file's `ccd`: `none` (no continuous collision detection),
    /// `bisection` or `conservative`; or why not.
    pub fn from_ccd_name(name: &str) -> Result<Option<Self>, String> {
        match name {
            "none" => Ok(None),
            "bisection" => Ok(Some(ToiMethod::Bisection)),
            "conservative" => Ok(Some(ToiMethod::ConservativeAdvancement)),
            other => Err(format!(
                "unknown method \"{other}\" (expected \"none\", \"bisection\" or \"conservative\")"
            )),
        }
    }
}

/// The first impact of a step between two bodies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairImpact {
    /// First body (index into the body list), `body_a < body_b`.
    pub body_a: usize,
    /// Second body.
    pub body_b: usize,
    /// When and how close.
    pub toi: Toi,
}

/// World bounding box of everything `body` covers while it follows [`Motion::of_body`] for
/// `dt`: the box of the start and end poses, and for a rotating body the box of the ball of
/// radius [`Shape::bounding_radius`] swept along the path of its centre of mass.
pub fn swept_aabb(body: &RigidBody, dt: f64) -> Aabb {
    let motion = Motion::of_body(body);
    let end = motion.at(dt);
    if motion.angvel == Vector3::zeros() {
        body.shape
            .aabb(&motion.start)
            .merged(&body.shape.aabb(&end))
    } else {
        let r = Vector3::repeat(body.shape.bounding_radius());
        let (p0, p1) = (motion.start.translation.vector, end.translation.vector);
        Aabb::new((p0.inf(&p1) - r).into(), (p0.sup(&p1) + r).into())
    }
}

/// The earliest impact during a step of length `dt` among body pairs whose surfaces are more
/// than `settings.tolerance` apart at its start, each body moving with its current velocities.
/// `None` if no such pair touches during the step. Candidate pairs come from the broad phase on
/// [`swept_aabb`] boxes, so a body is only tested against bodies near its path; more than
/// [`MAX_PAIRS`](super::broad_phase::MAX_PAIRS) of them are refused.
pub fn first_impact(
    bodies: &[RigidBody],
    dt: f64,
    method: ToiMethod,
    settings: &ToiSettings,
) -> Result<Option<PairImpact>, TooManyPairs> {
    let pairs = candidate_pairs_with_boxes(bodies, |b| swept_aabb(b, dt), 0.0)?;
    let mut best: Option<PairImpact> = None;
    for (a, b) in pairs {
        let (ma, mb) = (Motion::of_body(&bodies[a]), Motion::of_body(&bodies[b]));
        let (sa, sb) = (&bodies[a].shape, &bodies[b].shape);
        let horizon = best.map_or(dt, |p| p.toi.time);
        let toi = match method {
            ToiMethod::Bisection => time_of_impact_bisection(sa, &ma, sb, &mb, horizon, settings),
            ToiMethod::ConservativeAdvancement => {
                time_of_impact_conservative(sa, &ma, sb, &mb, horizon, settings)
            }
        };
        if let Some(toi) = toi {
            // Pairs already touching at the start are contacts, not impacts.
            if toi.time > 0.0 && best.is_none_or(|p| toi.time < p.toi.time) {
                best = Some(PairImpact {
                    body_a: a,
                    body_b: b,
                    toi,
                });
            }
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    #[test]
    fn motion_at_rotates_about_the_origin() {
        let m = Motion::new(
            Isometry3::translation(1.0, 0.0, 0.0),
            Vector3::new(0.0, 2.0, 0.0),
            Vector3::new(0.0, 0.0, std::f64::consts::PI),
        );
        let iso = m.at(0.5);
        let p = iso * Point3::new(1.0, 0.0, 0.0);
        assert!((p - Point3::new(1.0, 2.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn separating_bodies_have_no_impact() {
        let s = Shape::sphere(0.1).unwrap();
        let a = Motion::new(Isometry3::identity(), -Vector3::x(), Vector3::zeros());
        let b = Motion::stationary(Isometry3::translation(1.0, 0.0, 0.0));
        let set = ToiSettings::default();
        assert!(time_of_impact_bisection(&s, &a, &s, &b, 1.0, &set).is_none());
        assert!(time_of_impact_conservative(&s, &a, &s, &b, 1.0, &set).is_none());
    }

    #[test]
    fn overlapping_at_start_gives_zero() {
        let s = Shape::sphere(1.0).unwrap();
        let a = Motion::stationary(Isometry3::identity());
        let set = ToiSettings::default();
        let toi = time_of_impact_conservative(&s, &a, &s, &a, 1.0, &set).unwrap();
        assert_eq!(toi.time, 0.0);
        let toi = time_of_impact_bisection(&s, &a, &s, &a, 1.0, &set).unwrap();
        assert_eq!(toi.time, 0.0);
    }

    #[test]
    fn spinning_bar_hits_a_ball() {
        // A bar of half length 1 spinning about z at π/2 rad/s from along x sweeps towards a
        // ball at (0, 1.5, 0), radius 0.2: contact when the bar tip line reaches the ball.
        let bar = Shape::cuboid(Vector3::new(1.0, 0.05, 0.05)).unwrap();
        let ball = Shape::sphere(0.2).unwrap();
        let ma = Motion::new(
            Isometry3::identity(),
            Vector3::zeros(),
            Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2),
        );
        let mb = Motion::stationary(Isometry3::translation(0.3, 0.9, 0.0));
        let set = ToiSettings {
            tolerance: 1e-6,
            ..Default::default()
        };
        let t1 = time_of_impact_bisection(&bar, &ma, &ball, &mb, 1.0, &set).unwrap();
        let t2 = time_of_impact_conservative(&bar, &ma, &ball, &mb, 1.0, &set).unwrap();
        assert!(t1.distance <= 1e-6 && t2.distance <= 1e-6);
        assert!((t1.time - t2.time).abs() < 1e-4, "{t1:?} {t2:?}");
    }
}

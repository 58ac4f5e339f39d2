//! Joints: bilateral (equality) constraints between two bodies, or between a body and the
//! world, assembled into the same mixed LCP as the contacts.
//!
//! A joint holds points and directions fixed in each body's frame together. Each of its scalar
//! position constraints `C_k(x) = 0` gives one *equality row* of the step's problem: a row of
//! `J` (the derivative of `C_k` along the bodies' velocities, `Ċ_k = J_k u`), bounds
//! `(−∞, +∞)` and the condition `w_k = J_k u⁺ + bias_k = 0`. The rows are those of the
//! textbook joints (Erleben 2005, ch. 7; ODE's `joint.cpp`; Bullet's `btTypedConstraint`):
//!
//! * **ball** (ball-and-socket, 3 rows): the anchor points `p_a = x_a + R_a r_a` and
//!   `p_b = x_b + R_b r_b` coincide, `C = (p_b − p_a) · e_k` along the world axes `e_k`; the row
//!   is `[−e_k, −r_a × e_k]` on body a and `[e_k, r_b × e_k]` on body b, as a contact row along
//!   `e_k`;
//! * **hinge** (revolute, 5 rows): the ball rows, and the two angular rows that keep the bodies'
//!   axes `a_a = R_a â_a`, `a_b = R_b â_b` parallel: `C = t_k · (a_a × a_b)` for the tangents
//!   `t₁, t₂` of `a_a`, row `[0, −t_k]` on a and `[0, t_k]` on b;
//! * **fixed** (weld, 6 rows): the ball rows, and three angular rows that keep the relative
//!   orientation at its rest value `q_a⁻¹ q_b = q₀`: `C = θ · e_k` with `θ` the rotation vector
//!   of `q_b (q_a q₀)⁻¹`, row `[0, −e_k]` on a and `[0, e_k]` on b;
//! * **distance** (rigid rod, 1 row): `|p_b − p_a| = L`, `C = |p_b − p_a| − L` along
//!   `n = (p_b − p_a)/|p_b − p_a|`.
//!
//! The bias carries the position correction of the scene ([`PositionCorrection`]): with
//! Baumgarte stabilisation `bias_k = (β/h) C_k`, so the velocity solve removes the fraction `β`
//! of the error in one step; with split impulses the same term drives the separate position
//! solve; with none the error is left to accumulate (the drift the joint metrics measure).
//! Joint rows have no slop: a joint's error is never tolerated.
//!
//! The error a joint has at the current poses is [`Joint::error`]: the distance between the
//! anchors (ball, hinge, fixed) or `|C|` (distance) in metres, and the angle between the axes
//! (hinge) or of the relative rotation away from the rest orientation (fixed) in radians.

mod metrics;

pub use metrics::{JointMetrics, JointSummary};

use crate::body::RigidBody;
use crate::builder::tangent_basis;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use serde::Serialize;

/// The kind of a joint, with the constraints it imposes (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JointKind {
    /// Ball-and-socket: the anchors coincide (3 rows).
    Ball,
    /// Hinge (revolute): the anchors coincide and the axes stay parallel (5 rows).
    Hinge,
    /// Fixed (weld): the anchors coincide and the relative orientation stays at rest (6 rows).
    Fixed,
    /// Distance (rigid rod): the anchors stay at a fixed distance (1 row).
    Distance,
}

impl JointKind {
    /// Every kind, in the order of the scene file's documentation.
    pub const ALL: [JointKind; 4] = [
        JointKind::Ball,
        JointKind::Hinge,
        JointKind::Fixed,
        JointKind::Distance,
    ];

    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Ball => "ball",
            JointKind::Hinge => "hinge",
            JointKind::Fixed => "fixed",
            JointKind::Distance => "distance",
        }
    }

    /// The kind of a scene file's name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Rows of the joint in the step's problem.
    pub fn rows(self) -> usize {
        match self {
            JointKind::Ball => 3,
            JointKind::Hinge => 5,
            JointKind::Fixed => 6,
            JointKind::Distance => 1,
        }
    }
}

/// A joint between `bodies[0]` and `bodies[1]`; `None` is the world (a fixed frame). Anchors
/// and axes are stored in each body's frame (the world frame for the world), so the joint moves
/// with its bodies.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Name (from the scene file, or `joint_k`).
    pub name: String,
    /// What it constrains.
    pub kind: JointKind,
    /// The two bodies; `None` for the world.
    pub bodies: [Option<usize>; 2],
    /// Anchor of each side, in that side's frame (relative to the centre of mass).
    pub anchors: [Vector3<f64>; 2],
    /// Hinge axis of each side, unit, in that side's frame (unused by the other kinds).
    pub axes: [Vector3<f64>; 2],
    /// Rest relative orientation `q_a⁻¹ q_b` (fixed joints).
    pub rest_rotation: UnitQuaternion<f64>,
    /// Rest distance between the anchors, m (distance joints).
    pub length: f64,
}

/// One scalar constraint of a joint at the current poses: its rows on each side and its
/// position error `C`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointConstraint {
    /// `(linear, angular)` row on side a and on side b.
    pub sides: [(Vector3<f64>, Vector3<f64>); 2],
    /// Position error `C`, m or rad.
    pub error: f64,
}

/// How far a joint is from holding at the current poses.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct JointError {
    /// Distance between the anchors (ball, hinge, fixed), or `| |p_b − p_a| − L |`
    /// (distance), m.
    pub linear: f64,
    /// Angle between the hinge axes, or of the rotation away from the rest orientation
    /// (fixed), rad; 0 for the other kinds.
    pub angular: f64,
}

/// Position and orientation of a side: the body's, or the identity for the world.
fn pose(bodies: &[RigidBody], side: Option<usize>) -> (Point3<f64>, UnitQuaternion<f64>) {
    match side {
        Some(k) => (bodies[k].position, bodies[k].orientation),
        None => (Point3::origin(), UnitQuaternion::identity()),
    }
}

impl Joint {
    /// A joint of `kind` between `bodies` at their current poses, anchored at the world points
    /// `anchors` (the same point twice for every kind but distance), with the world `axis` of a
    /// hinge; the rest orientation and distance are those of the current poses.
    pub fn at_current_pose(
        name: String,
        kind: JointKind,
        sides: [Option<usize>; 2],
        world_anchors: [Point3<f64>; 2],
        world_axis: Vector3<f64>,
        bodies: &[RigidBody],
    ) -> Self {
        let local = |side: usize| {
            let (x, q) = pose(bodies, sides[side]);
            (
                q.inverse_transform_vector(&(world_anchors[side] - x)),
                q.inverse_transform_vector(&world_axis.normalize()),
                q,
            )
        };
        let ((ra, aa, qa), (rb, ab, qb)) = (local(0), local(1));
        Joint {
            name,
            kind,
            bodies: sides,
            anchors: [ra, rb],
            axes: [aa, ab],
            rest_rotation: qa.inverse() * qb,
            length: (world_anchors[1] - world_anchors[0]).norm(),
        }
    }

    /// World anchor point of side `k` at the current poses.
    pub fn world_anchor(&self, bodies: &[RigidBody], k: usize) -> Point3<f64> {
        let (x, q) = pose(bodies, self.bodies[k]);
        x + q * self.anchors[k]
    }

    /// World axis of side `k` (hinges).
    pub fn world_axis(&self, bodies: &[RigidBody], k: usize) -> Vector3<f64> {
        pose(bodies, self.bodies[k]).1 * self.axes[k]
    }

    /// True when a side refers to `body`.
    pub fn involves(&self, body: usize) -> bool {
        self.bodies.contains(&Some(body))
    }

    /// The joint's scalar constraints at the current poses, [`JointKind::rows`] of them.
    pub fn constraints(&self, bodies: &[RigidBody]) -> Vec<JointConstraint> {
        let (pa, pb) = (self.world_anchor(bodies, 0), self.world_anchor(bodies, 1));
        let ra = pa - pose(bodies, self.bodies[0]).0;
        let rb = pb - pose(bodies, self.bodies[1]).0;
        let d = pb - pa;
        let linear = |e: Vector3<f64>| JointConstraint {
            sides: [(-e, -ra.cross(&e)), (e, rb.cross(&e))],
            error: d.dot(&e),
        };
        let angular = |e: Vector3<f64>, error: f64| JointConstraint {
            sides: [(Vector3::zeros(), -e), (Vector3::zeros(), e)],
            error,
        };
        let mut out = Vec::with_capacity(self.kind.rows());
        if self.kind == JointKind::Distance {
            let len = d.norm();
            // Coincident anchors of a rod of positive length have no direction; the first
            // axis stands in until they separate.
            let n = if len > 1e-12 { d / len } else { Vector3::x() };
            out.push(JointConstraint {
                error: len - self.length,
                ..linear(n)
            });
            return out;
        }
        out.extend([Vector3::x(), Vector3::y(), Vector3::z()].map(linear));
        match self.kind {
            JointKind::Hinge => {
                let (aa, ab) = (self.world_axis(bodies, 0), self.world_axis(bodies, 1));
                let (t1, t2) = tangent_basis(&aa);
                let cross = aa.cross(&ab);
                out.push(angular(t1, t1.dot(&cross)));
                out.push(angular(t2, t2.dot(&cross)));
            }
            JointKind::Fixed => {
                let theta = self.rotation_error(bodies);
                for e in [Vector3::x(), Vector3::y(), Vector3::z()] {
                    out.push(angular(e, theta.dot(&e)));
                }
            }
            JointKind::Ball | JointKind::Distance => {}
        }
        out
    }

    /// Rotation vector of `q_b (q_a q₀)⁻¹`: the world rotation from side b's rest orientation
    /// to its actual one.
    fn rotation_error(&self, bodies: &[RigidBody]) -> Vector3<f64> {
        let (qa, qb) = (
            pose(bodies, self.bodies[0]).1,
            pose(bodies, self.bodies[1]).1,
        );
        (qb * (qa * self.rest_rotation).inverse()).scaled_axis()
    }

    /// How far the joint is from holding at the current poses.
    pub fn error(&self, bodies: &[RigidBody]) -> JointError {
        let d = self.world_anchor(bodies, 1) - self.world_anchor(bodies, 0);
        match self.kind {
            JointKind::Distance => JointError {
                linear: (d.norm() - self.length).abs(),
                angular: 0.0,
            },
            JointKind::Ball => JointError {
                linear: d.norm(),
                angular: 0.0,
            },
            JointKind::Hinge => {
                let (aa, ab) = (self.world_axis(bodies, 0), self.world_axis(bodies, 1));
                JointError {
                    linear: d.norm(),
                    angular: aa.cross(&ab).norm().atan2(aa.dot(&ab)),
                }
            }
            JointKind::Fixed => JointError {
                linear: d.norm(),
                angular: self.rotation_error(bodies).norm(),
            },
        }
    }

    /// Renumber the bodies after `keep[k] == false` bodies were removed; `None` when one of
    /// the joint's bodies was removed.
    pub fn renumbered(&self, keep: &[bool]) -> Option<Joint> {
        let mut out = self.clone();
        for side in out.bodies.iter_mut().flatten() {
            if !keep[*side] {
                return None;
            }
            *side = keep[..*side].iter().filter(|&&k| k).count();
        }
        Some(out)
    }
}

/// The largest and mean linear error and the largest angular error of `errors` (one per
/// joint): `(max linear, mean linear, max angular)`; zeros without joints.
pub fn summarise_errors(errors: &[JointError]) -> (f64, f64, f64) {
    if errors.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    let (mut max, mut sum, mut angle) = (0.0f64, 0.0, 0.0f64);
    for e in errors {
        max = max.max(e.linear);
        sum += e.linear;
        angle = angle.max(e.angular);
    }
    (max, sum / errors.len() as f64, angle)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::MassSpec;
    use crate::shape::Shape;

    fn cube(at: [f64; 3]) -> RigidBody {
        RigidBody::new(
            "b",
            Shape::cuboid(Vector3::new(0.5, 0.5, 0.5)).unwrap(),
            MassSpec::Mass(1.0),
            Point3::from(at),
            UnitQuaternion::identity(),
            Vector3::zeros(),
            Vector3::zeros(),
            0,
            false,
        )
        .unwrap()
    }

    /// `J u` of each row of `joint` at `bodies` against the finite difference of its error
    /// along the velocities `v`.
    fn rates_and_differences(
        joint: &Joint,
        bodies: &[RigidBody],
        v: &[(Vector3<f64>, Vector3<f64>); 2],
    ) -> Vec<(f64, f64)> {
        let dt = 1e-7;
        let mut next = bodies.to_vec();
        for (b, (lin, ang)) in next.iter_mut().zip(v) {
            b.position += lin * dt;
            b.orientation = UnitQuaternion::from_scaled_axis(ang * dt) * b.orientation;
        }
        let (c0, c1) = (joint.constraints(bodies), joint.constraints(&next));
        assert_eq!(c0.len(), joint.kind.rows());
        c0.iter()
            .zip(&c1)
            .map(|(a, b)| {
                let rate: f64 = a
                    .sides
                    .iter()
                    .zip(v)
                    .map(|((jl, ja), (lin, ang))| jl.dot(lin) + ja.dot(ang))
                    .sum();
                (rate, (b.error - a.error) / dt)
            })
            .collect()
    }

    /// Each constraint's row is the derivative of its error: moving the bodies along a velocity
    /// for a tiny time changes `C` by `J u dt`. Exactly for the linear rows (ball, distance)
    /// anywhere, and for the angular rows (hinge, fixed) where the orientations agree with the
    /// joint (the rows are the error's derivative there, as in ODE and Bullet); with the
    /// orientations 0.04 rad off, the angular rows stay within a few per cent of it.
    #[test]
    fn rows_are_the_derivatives_of_the_errors() {
        let mut bodies = vec![cube([0.0, 0.0, 0.0]), cube([1.1, 0.2, -0.3])];
        bodies[1].orientation = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.5);
        let anchor = Point3::new(0.6, 0.1, -0.1);
        let v = [
            (Vector3::new(0.3, -0.1, 0.2), Vector3::new(0.1, 0.4, -0.2)),
            (Vector3::new(-0.2, 0.5, 0.1), Vector3::new(-0.3, 0.2, 0.6)),
        ];
        for kind in JointKind::ALL {
            let anchors = if kind == JointKind::Distance {
                [Point3::new(0.2, 0.1, 0.0), Point3::new(1.4, 0.5, -0.2)]
            } else {
                [anchor, anchor]
            };
            let axis = Vector3::new(0.2, 1.0, 0.3);
            let joint = Joint::at_current_pose(
                "j".into(),
                kind,
                [Some(0), Some(1)],
                anchors,
                axis,
                &bodies,
            );
            // Anchors apart, orientations as at rest: every row exact.
            let mut moved = bodies.clone();
            moved[1].position += Vector3::new(0.01, -0.02, 0.015);
            for (k, (rate, fd)) in rates_and_differences(&joint, &moved, &v).iter().enumerate() {
                assert!(
                    (rate - fd).abs() < 1e-5,
                    "{} row {k}: J u = {rate}, dC/dt = {fd}",
                    kind.name()
                );
            }
            // Orientations off as well: linear rows exact, angular rows close.
            moved[1].orientation =
                UnitQuaternion::from_scaled_axis(Vector3::new(0.02, 0.01, -0.03))
                    * moved[1].orientation;
            for (k, (rate, fd)) in rates_and_differences(&joint, &moved, &v).iter().enumerate() {
                let angular = k >= 3 && kind != JointKind::Distance;
                let tol = if angular {
                    0.05 * fd.abs() + 1e-5
                } else {
                    1e-5
                };
                assert!(
                    (rate - fd).abs() < tol,
                    "{} row {k}: J u = {rate}, dC/dt = {fd}",
                    kind.name()
                );
            }
            assert!(joint.error(&bodies).linear < 1e-12, "{}", kind.name());
            assert!(joint.error(&moved).linear > 1e-3, "{}", kind.name());
            if angular_rows(kind) {
                assert!(joint.error(&moved).angular > 1e-2, "{}", kind.name());
            }
        }
    }

    fn angular_rows(kind: JointKind) -> bool {
        matches!(kind, JointKind::Hinge | JointKind::Fixed)
    }

    #[test]
    fn renumbering_drops_joints_of_removed_bodies() {
        let bodies = vec![cube([0.0; 3]), cube([1.0, 0.0, 0.0]), cube([2.0, 0.0, 0.0])];
        let j = Joint::at_current_pose(
            "j".into(),
            JointKind::Ball,
            [Some(2), None],
            [Point3::new(2.5, 0.0, 0.0); 2],
            Vector3::x(),
            &bodies,
        );
        assert_eq!(
            j.renumbered(&[false, true, true]).unwrap().bodies,
            [Some(1), None]
        );
        assert!(j.renumbered(&[true, true, false]).is_none());
    }
}

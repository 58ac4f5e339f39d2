//! Collision detection: broad phase, narrow phase (contact manifolds), time of impact.

use nalgebra::{Point3, Vector3};

/// One contact point between two bodies, as the narrow phase reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// First body (index into the body list).
    pub body_a: usize,
    /// Second body.
    pub body_b: usize,
    /// World contact point (midway between the two surfaces).
    pub point: Point3<f64>,
    /// Unit normal pointing from `body_a` to `body_b`.
    pub normal: Vector3<f64>,
    /// Signed gap along the normal: negative when the shapes overlap (penetration depth `-dist`).
    pub dist: f64,
    /// Identifier stable across steps for the same pair and feature, for warm starting.
    pub key: u64,
}

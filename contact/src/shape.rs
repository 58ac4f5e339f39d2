//! Collision shapes.

/// A collision shape in its body frame.
#[derive(Debug, Clone)]
pub enum Shape {
    /// Sphere of the given radius.
    Sphere {
        /// Radius.
        radius: f64,
    },
}

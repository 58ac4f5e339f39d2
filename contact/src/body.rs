//! Rigid-body state (Baraff–Witkin): mass, body-frame inertia, position of the centre of mass,
//! orientation as a unit quaternion, linear and angular momentum.

use crate::shape::Shape;
use nalgebra::{Matrix3, Point3, UnitQuaternion, Vector3};

/// One rigid body. A static body has infinite mass (`inv_mass = 0`, zero inverse inertia).
#[derive(Debug, Clone)]
pub struct RigidBody {
    /// Name from the scene file.
    pub name: String,
    /// Collision shape, in the body frame (centred on the centre of mass).
    pub shape: Shape,
    /// Mass (`f64::INFINITY` for a static body).
    pub mass: f64,
    /// Inverse mass (0 for a static body).
    pub inv_mass: f64,
    /// Inertia tensor about the centre of mass, body frame.
    pub inertia_body: Matrix3<f64>,
    /// Inverse of `inertia_body` (zero for a static body).
    pub inv_inertia_body: Matrix3<f64>,
    /// World position of the centre of mass.
    pub position: Point3<f64>,
    /// Orientation (body to world).
    pub orientation: UnitQuaternion<f64>,
    /// Linear momentum `P = m v`.
    pub linear_momentum: Vector3<f64>,
    /// Angular momentum about the centre of mass, world frame, `L = I ω`.
    pub angular_momentum: Vector3<f64>,
    /// Index of the body's material in the scene.
    pub material: usize,
    /// Static (immovable) body.
    pub is_static: bool,
}

impl RigidBody {
    /// World-frame inverse inertia `R I⁻¹ Rᵀ`.
    pub fn inv_inertia_world(&self) -> Matrix3<f64> {
        let r = self.orientation.to_rotation_matrix();
        r.matrix() * self.inv_inertia_body * r.matrix().transpose()
    }

    /// World-frame inertia `R I Rᵀ`.
    pub fn inertia_world(&self) -> Matrix3<f64> {
        let r = self.orientation.to_rotation_matrix();
        r.matrix() * self.inertia_body * r.matrix().transpose()
    }

    /// Linear velocity `v = P / m`.
    pub fn velocity(&self) -> Vector3<f64> {
        self.linear_momentum * self.inv_mass
    }

    /// Angular velocity `ω = I⁻¹ L` (world frame).
    pub fn angular_velocity(&self) -> Vector3<f64> {
        self.inv_inertia_world() * self.angular_momentum
    }

    /// Velocity of the material point at world position `p`.
    pub fn velocity_at(&self, p: &Point3<f64>) -> Vector3<f64> {
        self.velocity() + self.angular_velocity().cross(&(p - self.position))
    }
}

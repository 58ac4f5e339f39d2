//! Rigid-body state (Baraff–Witkin): mass, body-frame inertia, position of the centre of mass,
//! orientation as a unit quaternion, linear and angular momentum.
//!
//! Reference: D. Baraff and A. Witkin, *Physically Based Modeling*, SIGGRAPH course notes
//! (2001), "Rigid body simulation", section 2 (state `x, q, P, L`; `I = R I_body Rᵀ`).

use crate::shape::{Shape, ShapeError};
use nalgebra::{Isometry3, Matrix3, Point3, Translation3, UnitQuaternion, Vector3};

/// How the mass of a body is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MassSpec {
    /// Uniform density `ρ`: mass `ρ V`, inertia integrated over the shape.
    Density(f64),
    /// Total mass `m`, spread uniformly over the shape (the inertia is that of density
    /// `m / V`).
    Mass(f64),
}

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
    /// A body of shape `shape` whose centre of mass is at `position`, with velocity `velocity`
    /// and angular velocity `angular_velocity` (world frame).
    ///
    /// A static body gets `mass = ∞`, `inv_mass = 0`, zero `inertia_body` and
    /// `inv_inertia_body`, and zero momenta (its velocities are ignored); `mass` is then not
    /// read. A plane must be static.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: impl Into<String>,
        shape: Shape,
        mass: MassSpec,
        position: Point3<f64>,
        orientation: UnitQuaternion<f64>,
        velocity: Vector3<f64>,
        angular_velocity: Vector3<f64>,
        material: usize,
        is_static: bool,
    ) -> Result<Self, ShapeError> {
        shape.validate()?;
        let finite = |v: &[f64], field| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(ShapeError::NotFinite {
                    shape: "rigid body",
                    field,
                })
            }
        };
        finite(position.coords.as_slice(), "position")?;
        finite(orientation.coords.as_slice(), "orientation")?;
        finite(velocity.as_slice(), "velocity")?;
        finite(angular_velocity.as_slice(), "angular_velocity")?;
        let mut body = RigidBody {
            name: name.into(),
            shape,
            mass: f64::INFINITY,
            inv_mass: 0.0,
            inertia_body: Matrix3::zeros(),
            inv_inertia_body: Matrix3::zeros(),
            position,
            orientation,
            linear_momentum: Vector3::zeros(),
            angular_momentum: Vector3::zeros(),
            material,
            is_static,
        };
        if is_static {
            return Ok(body);
        }
        let mp = match mass {
            MassSpec::Density(rho) => body.shape.mass_properties(rho)?,
            MassSpec::Mass(m) => {
                if !(m.is_finite() && m > 0.0) {
                    return Err(ShapeError::BadMass {
                        field: "mass",
                        value: m,
                    });
                }
                let unit = body.shape.mass_properties(1.0)?;
                body.shape.mass_properties(m / unit.volume)?
            }
        };
        let inv_inertia = mp
            .inertia
            .try_inverse()
            .filter(|m| m.iter().all(|v| v.is_finite()))
            .ok_or(ShapeError::SingularInertia { mass: mp.mass })?;
        body.mass = mp.mass;
        body.inv_mass = 1.0 / mp.mass;
        body.inertia_body = mp.inertia;
        body.inv_inertia_body = inv_inertia;
        body.linear_momentum = mp.mass * velocity;
        body.angular_momentum = body.inertia_world() * angular_velocity;
        Ok(body)
    }

    /// Pose of the body frame in the world (translation to the centre of mass, then rotation),
    /// as parry uses it.
    pub fn iso(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.position.coords), self.orientation)
    }

    /// Kinetic energy `½ P·v + ½ L·ω` (0 for a static body).
    pub fn kinetic_energy(&self) -> f64 {
        if self.is_static {
            return 0.0;
        }
        0.5 * self.linear_momentum.dot(&self.velocity())
            + 0.5 * self.angular_momentum.dot(&self.angular_velocity())
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    fn make(shape: Shape, mass: MassSpec, is_static: bool) -> Result<RigidBody, ShapeError> {
        RigidBody::new(
            "t",
            shape,
            mass,
            Point3::new(1.0, 2.0, 3.0),
            UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1),
            Vector3::new(1.0, -2.0, 0.5),
            Vector3::new(0.2, 0.4, -0.3),
            0,
            is_static,
        )
    }

    #[test]
    fn mass_spec_scales_inertia() {
        let shape = Shape::cuboid(Vector3::new(0.5, 1.0, 1.5)).unwrap();
        let by_density = make(shape.clone(), MassSpec::Density(2.0), false).unwrap();
        let by_mass = make(shape, MassSpec::Mass(by_density.mass), false).unwrap();
        assert!((by_density.mass - 2.0 * 6.0).abs() < 1e-12);
        assert!((by_density.inertia_body - by_mass.inertia_body).norm() < 1e-12);
        assert!(
            (by_density.inertia_body * by_density.inv_inertia_body - Matrix3::identity()).norm()
                < 1e-12
        );
    }

    #[test]
    fn momenta_reproduce_velocities_and_energy() {
        let b = make(
            Shape::capsule(0.5, 0.2).unwrap(),
            MassSpec::Density(900.0),
            false,
        )
        .unwrap();
        assert!((b.velocity() - Vector3::new(1.0, -2.0, 0.5)).norm() < 1e-12);
        assert!((b.angular_velocity() - Vector3::new(0.2, 0.4, -0.3)).norm() < 1e-12);
        let w = Vector3::new(0.2, 0.4, -0.3);
        let expect = 0.5 * b.mass * 5.25 + 0.5 * w.dot(&(b.inertia_world() * w));
        assert!((b.kinetic_energy() - expect).abs() < 1e-9 * expect);
        let p = b.iso() * Point3::origin();
        assert_eq!(p, Point3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn static_bodies_and_planes() {
        let plane = Shape::plane(Vector3::z()).unwrap();
        assert!(matches!(
            make(plane.clone(), MassSpec::Density(1.0), false),
            Err(ShapeError::Unbounded { .. })
        ));
        let ground = make(plane, MassSpec::Density(1.0), true).unwrap();
        assert_eq!(ground.inv_mass, 0.0);
        assert_eq!(ground.velocity(), Vector3::zeros());
        assert_eq!(ground.kinetic_energy(), 0.0);
        assert_eq!(ground.inv_inertia_world(), Matrix3::zeros());
    }

    #[test]
    fn rejects_bad_mass_and_state() {
        let s = Shape::sphere(1.0).unwrap();
        assert!(make(s.clone(), MassSpec::Mass(0.0), false).is_err());
        assert!(make(s.clone(), MassSpec::Density(-1.0), false).is_err());
        assert!(make(Shape::Sphere { radius: -1.0 }, MassSpec::Mass(1.0), false).is_err());
        let nan = RigidBody::new(
            "t",
            s,
            MassSpec::Mass(1.0),
            Point3::new(f64::NAN, 0.0, 0.0),
            UnitQuaternion::identity(),
            Vector3::zeros(),
            Vector3::zeros(),
            0,
            false,
        );
        assert!(matches!(nan, Err(ShapeError::NotFinite { .. })));
    }
}

//! The parry shape of each body, kept between detection passes.
//!
//! Collision queries take parry's [`SharedShape`]; [`Shape::to_parry`] builds one (a new
//! `Ball`, `Cuboid`, `Capsule` or `HalfSpace` behind an `Arc`, or a new handle on a hull's or
//! mesh's shared data). Engines build a collider's shape once, when the collider is created,
//! and keep it (rapier's `Collider` owns its `SharedShape`). [`ShapeCache`] does the same for
//! the bodies of a world: a body's parry shape is built the first time the body is seen and
//! rebuilt only when its [`Shape`] changes (another variant, another size, another hull or
//! mesh), so a pass over a scene whose shapes do not change builds nothing.
//!
//! A cached shape is the one [`Shape::to_parry`] would build at that moment (the same parry
//! type with the same parameters, or the same shared hull or mesh), so every query on it gives
//! bit-identical answers.

use crate::body::RigidBody;
use crate::shape::Shape;
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::shape::SharedShape;
use std::sync::Arc;

/// One body's parry shape and the [`Shape`] it was built from.
#[derive(Clone)]
struct CachedShape {
    source: Shape,
    parry: SharedShape,
}

/// The parry shape of each body of a body list, built once per body and rebuilt only when the
/// body's shape changes ([`ShapeCache::update`]).
///
/// Entries are indexed by the body's position in the list: after bodies are removed or
/// reordered, the entries that no longer match are rebuilt by the next update (or call
/// [`ShapeCache::clear`]).
#[derive(Clone, Default)]
pub struct ShapeCache {
    shapes: Vec<CachedShape>,
    built: usize,
}

impl std::fmt::Debug for ShapeCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShapeCache")
            .field("bodies", &self.shapes.len())
            .field("built", &self.built)
            .finish()
    }
}

impl ShapeCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Bring the cache in line with `bodies`: a body past the end of the cache, or whose shape
    /// differs from the one its entry was built from, gets a new parry shape; every other entry
    /// is kept. Entries past the end of `bodies` are dropped. `O(bodies)` comparisons.
    pub fn update(&mut self, bodies: &[RigidBody]) {
        self.shapes.truncate(bodies.len());
        for (entry, body) in self.shapes.iter_mut().zip(bodies) {
            if !same_parry_shape(&entry.source, &body.shape) {
                *entry = CachedShape {
                    source: body.shape.clone(),
                    parry: body.shape.to_parry(),
                };
                self.built += 1;
            }
        }
        for body in &bodies[self.shapes.len()..] {
            self.shapes.push(CachedShape {
                source: body.shape.clone(),
                parry: body.shape.to_parry(),
            });
            self.built += 1;
        }
    }

    /// The parry shape of body `i` as of the last [`ShapeCache::update`].
    ///
    /// # Panics
    /// When `i` is not below the length of the body list of that update.
    pub fn get(&self, i: usize) -> &SharedShape {
        &self.shapes[i].parry
    }

    /// World-frame bounding box of body `i` at its pose in `bodies` (as
    /// [`Shape::aabb`] computes it, on the cached shape).
    pub fn aabb(&self, bodies: &[RigidBody], i: usize) -> Aabb {
        self.get(i).compute_aabb(&bodies[i].iso())
    }

    /// Number of bodies the cache holds a shape for.
    pub fn len(&self) -> usize {
        self.shapes.len()
    }

    /// True when the cache holds no shape.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// Parry shapes built since the cache was created (each body's first, plus one per change
    /// of a body's shape): a diagnostic, and what tests check to see that nothing is rebuilt.
    pub fn built(&self) -> usize {
        self.built
    }

    /// Forget every shape (the build count is kept).
    pub fn clear(&mut self) {
        self.shapes.clear();
    }
}

/// True when [`Shape::to_parry`] builds the same parry shape for `a` and `b`: the same variant
/// with equal parameters, or the same shared hull or mesh (compared by address, not by
/// content, so a hull or mesh rebuilt from the same points counts as a change).
fn same_parry_shape(a: &Shape, b: &Shape) -> bool {
    match (a, b) {
        (Shape::Sphere { radius: r }, Shape::Sphere { radius: s })
        | (Shape::Particle { radius: r }, Shape::Particle { radius: s }) => r == s,
        (Shape::Box { half_extents: h }, Shape::Box { half_extents: k }) => h == k,
        (
            Shape::Capsule {
                half_height: h,
                radius: r,
            },
            Shape::Capsule {
                half_height: k,
                radius: s,
            },
        ) => h == k && r == s,
        (Shape::ConvexPolyhedron { hull: h, .. }, Shape::ConvexPolyhedron { hull: k, .. }) => {
            Arc::ptr_eq(h, k)
        }
        (Shape::Plane { normal: n }, Shape::Plane { normal: m }) => n == m,
        (Shape::TriMesh { mesh: h, .. }, Shape::TriMesh { mesh: k, .. }) => Arc::ptr_eq(h, k),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::MassSpec;
    use nalgebra::{Point3, UnitQuaternion, Vector3};

    fn body(shape: Shape, z: f64) -> RigidBody {
        RigidBody::new(
            "b",
            shape,
            MassSpec::Density(1000.0),
            Point3::new(0.0, 0.0, z),
            UnitQuaternion::identity(),
            Vector3::zeros(),
            Vector3::zeros(),
            0,
            false,
        )
        .expect("a valid body")
    }

    #[test]
    fn shapes_are_built_once_and_again_only_when_they_change() {
        let mut bodies = vec![
            body(Shape::sphere(0.5).unwrap(), 0.0),
            body(Shape::cuboid(Vector3::new(0.5, 0.5, 0.5)).unwrap(), 2.0),
        ];
        let mut cache = ShapeCache::new();
        cache.update(&bodies);
        assert_eq!(cache.built(), 2);
        // Moving bodies changes no shape.
        for _ in 0..5 {
            bodies[0].position.z += 0.1;
            cache.update(&bodies);
        }
        assert_eq!(cache.built(), 2);
        // A new size is a new shape; the other body's is kept.
        bodies[0].shape = Shape::sphere(0.25).unwrap();
        cache.update(&bodies);
        assert_eq!(cache.built(), 3);
        assert_eq!(cache.get(0).as_ball().map(|b| b.radius), Some(0.25));
        // A body added at the end gets its shape; a removed one loses it.
        bodies.push(body(Shape::capsule(0.5, 0.1).unwrap(), 4.0));
        cache.update(&bodies);
        assert_eq!((cache.built(), cache.len()), (4, 3));
        bodies.remove(0);
        cache.update(&bodies);
        // Body 0 is now the box (was a sphere): rebuilt; body 1 is now the capsule (was the
        // box): rebuilt.
        assert_eq!((cache.built(), cache.len()), (6, 2));
        assert!(cache.get(0).as_cuboid().is_some() && cache.get(1).as_capsule().is_some());
    }

    #[test]
    fn cached_bounding_boxes_are_those_of_the_shape() {
        let mut b = body(Shape::cuboid(Vector3::new(0.5, 0.2, 0.1)).unwrap(), 1.0);
        b.orientation = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7);
        let bodies = [b];
        let mut cache = ShapeCache::new();
        cache.update(&bodies);
        let fresh = bodies[0].shape.aabb(&bodies[0].iso());
        let cached = cache.aabb(&bodies, 0);
        assert_eq!((cached.mins, cached.maxs), (fresh.mins, fresh.maxs));
    }
}

//! Collision detection: broad phase, narrow phase (contact manifolds), time of impact.
//!
//! [`CollisionPipeline::detect`] runs the phases in order: the bodies' parry shapes are
//! brought up to date ([`shapes`]: built once per body, rebuilt only when a body's shape
//! changes), the [`broad_phase`] (sweep and prune over world bounding boxes, its sorted order
//! kept from call to call, planes paired separately) proposes body pairs, the [`narrow_phase`]
//! turns each pair into contact points with parry's persistent contact manifolds (and, as an
//! option, keeps a pair's manifolds while the pair barely moves:
//! [`NarrowPhase::persistent_manifolds`]). [`toi`] finds the first time of contact of a fast
//! body during a step (bisection and conservative advancement).
//!
//! ```
//! use lcpbench_contact::{CollisionPipeline, MassSpec, RigidBody, Shape};
//! use nalgebra::{Point3, UnitQuaternion, Vector3};
//!
//! let body = |shape, z, is_static| {
//!     RigidBody::new("b", shape, MassSpec::Density(1000.0), Point3::new(0.0, 0.0, z),
//!         UnitQuaternion::identity(), Vector3::zeros(), Vector3::zeros(), 0, is_static)
//! };
//! let bodies = vec![
//!     body(Shape::plane(Vector3::z())?, 0.0, true)?,
//!     body(Shape::cuboid(Vector3::new(0.5, 0.5, 0.5))?, 0.5, false)?,
//! ];
//! let mut pipeline = CollisionPipeline::new();
//! let contacts = pipeline.detect(&bodies, 1e-3).expect("two bodies are within the limits");
//! assert_eq!(contacts.len(), 4); // the four bottom corners
//! assert!(contacts.iter().all(|c| c.normal == Vector3::z() && c.dist.abs() < 1e-12));
//! # Ok::<(), lcpbench_contact::ShapeError>(())
//! ```
//!
//! References: D. Baraff and A. Witkin, *Physically Based Modeling*, SIGGRAPH 2001 course
//! notes ("Rigid body simulation II: nonpenetration constraints"); C. Ericson, *Real-Time
//! Collision Detection*, Morgan Kaufmann 2005; B. Mirtich, *Impulse-based dynamic simulation
//! of rigid body systems*, PhD thesis, UC Berkeley 1996; parry, <https://parry.rs/docs/>.

pub mod broad_phase;
pub mod narrow_phase;
pub mod shapes;
pub mod toi;

use crate::body::RigidBody;
use broad_phase::{BroadPhase, TooManyPairs};
use nalgebra::{Point3, Vector3};
use narrow_phase::{NarrowPhase, TooManyContacts};

/// A detection pass past one of its limits ([`broad_phase::MAX_PAIRS`],
/// [`narrow_phase::MAX_CONTACTS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DetectionError {
    /// Too many candidate pairs.
    #[error(transparent)]
    Pairs(#[from] TooManyPairs),
    /// Too many contact points.
    #[error(transparent)]
    Contacts(#[from] TooManyContacts),
}

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

/// Candidate body pairs `(i, j)` with `i < j`, sorted, from the broad phase with no margin
/// (touching or overlapping bounding boxes; planes against every dynamic body reaching them),
/// at most [`broad_phase::MAX_PAIRS`].
pub fn candidate_pairs(bodies: &[RigidBody]) -> Result<Vec<(usize, usize)>, TooManyPairs> {
    broad_phase::candidate_pairs_with_margin(bodies, 0.0)
}

/// Broad plus narrow phase, with the bodies' parry shapes, the broad phase's sorted order and
/// the contact manifolds kept between calls.
///
/// The caches are indexed by body position in the slice: keep the body list in the same order
/// from step to step, or call [`CollisionPipeline::clear`] after reordering it (a body's parry
/// shape is checked against its shape on every call, so shapes are never stale).
#[derive(Debug, Default)]
pub struct CollisionPipeline {
    broad: BroadPhase,
    narrow: NarrowPhase,
    timings: CollisionTimings,
}

/// Wall time of the last [`CollisionPipeline::detect`], seconds, by phase.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CollisionTimings {
    /// Sweep and prune: candidate pairs.
    pub broad_phase: f64,
    /// Contact manifolds of the candidate pairs.
    pub narrow_phase: f64,
}

impl CollisionPipeline {
    /// Pipeline with an empty manifold cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Contacts between all bodies whose surfaces are closer than `prediction` (a distance,
    /// `>= 0`; contacts with `0 < dist <= prediction` are speculative and keep resting contacts
    /// alive across steps). For each pair, `body_a < body_b` and the normal points from `a` to
    /// `b`. Contacts come out grouped by pair, pairs in increasing order. A pass past the
    /// limits of either phase is refused with [`DetectionError`].
    pub fn detect(
        &mut self,
        bodies: &[RigidBody],
        prediction: f64,
    ) -> Result<Vec<Contact>, DetectionError> {
        let prediction = prediction.max(0.0);
        let start = std::time::Instant::now();
        self.narrow.update_shapes(bodies);
        let pairs = self
            .broad
            .candidate_pairs(bodies, self.narrow.shapes(), prediction);
        let broad = start.elapsed();
        let contacts = match pairs {
            Ok(pairs) => self
                .narrow
                .contacts_of_shapes(bodies, &pairs, prediction)
                .map_err(DetectionError::from),
            Err(e) => {
                self.narrow.clear();
                Err(e.into())
            }
        };
        self.timings = CollisionTimings {
            broad_phase: broad.as_secs_f64(),
            narrow_phase: (start.elapsed() - broad).as_secs_f64(),
        };
        contacts
    }

    /// Wall time of the phases of the last [`CollisionPipeline::detect`].
    pub fn timings(&self) -> CollisionTimings {
        self.timings
    }

    /// The narrow phase, for its settings ([`NarrowPhase::merge_distance`],
    /// [`NarrowPhase::persistent_manifolds`]).
    pub fn narrow_phase_mut(&mut self) -> &mut NarrowPhase {
        &mut self.narrow
    }

    /// The narrow phase, for what it keeps ([`NarrowPhase::shapes`],
    /// [`NarrowPhase::kept_pairs`]).
    pub fn narrow_phase(&self) -> &NarrowPhase {
        &self.narrow
    }

    /// The broad phase, for its sweep order ([`BroadPhase::sweep_order`]).
    pub fn broad_phase(&self) -> &BroadPhase {
        &self.broad
    }

    /// Forgets cached manifolds and the broad phase's order.
    pub fn clear(&mut self) {
        self.broad.clear();
        self.narrow.clear();
    }
}

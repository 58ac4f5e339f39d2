//! Narrow phase: contact manifolds from parry for each candidate pair.
//!
//! Each pair's manifolds and workspace are kept between calls and handed back to
//! `PersistentQueryDispatcher::contact_manifolds` (parry's `DefaultQueryDispatcher`), so the
//! generators can reuse the previous separating features and a triangle mesh's list of
//! overlapping triangles. A manifold point becomes one [`Contact`]: the two surface points
//! (parry gives each in its own shape's, or sub-shape's, local frame) are taken to the world and
//! averaged, the normal is the manifold normal of the first shape in world coordinates, and the
//! key mixes the body indices, sub-shape indices and feature ids, which parry keeps stable while
//! the same features touch (used for warm starting).
//!
//! Points closer than the prediction distance are reported with `dist > 0`, so resting contacts
//! that separate slightly between steps are not lost.
//!
//! The bodies' parry shapes are built once and kept ([`ShapeCache`]). With
//! [`NarrowPhase::persistent_manifolds`] (off by default), a pair whose relative pose moved less
//! than a small threshold since its manifolds were computed keeps them: each kept point's gap
//! is measured again at the new pose (parry's `ContactManifold::try_update_contacts_eps`, the
//! update parry's own box and polyhedron generators try first, with thresholds of
//! [`NarrowPhase::manifold_linear_threshold`] and [`NarrowPhase::manifold_angular_threshold`])
//! and parry's generator is not run; otherwise the manifolds are computed as usual.
//!
//! A triangle mesh yields one manifold per triangle near the other shape, so a mesh vertex shared
//! by several triangles shows up once per triangle. Contacts of the same pair at the same point
//! (within [`NarrowPhase::merge_distance`]) with the same normal are merged into one, keeping
//! the smallest key (stable across steps) and the smallest gap: duplicates would only add
//! linearly dependent rows to the contact Jacobian.
//!
//! Mesh against mesh is computed triangle against triangle, and a triangle has no inside: when
//! two meshes touch along coplanar faces and also have side walls meeting at the contact
//! (two identical blocks stacked flush), parry's triangle pairs report spurious contacts with
//! the wall normals and penetrations as deep as the walls are long. A penetrating mesh–mesh
//! contact is therefore kept only if its depth does not exceed the true depth of its points
//! inside the other (closed) mesh by more than [`NarrowPhase::mesh_depth_slack`]; a genuine
//! contact always passes, because the distance along the contact normal to the other surface
//! is at least the distance to its nearest point. Shallow spurious contacts with sideways
//! normals can remain in the flush case: model such stacks with convex hulls, or offset them.
//! Mesh against primitives, hulls and planes is not affected.
//!
//! One pass reports at most [`MAX_CONTACTS`] contacts; past that it stops with
//! [`TooManyContacts`] rather than build a contact problem that cannot be solved in memory.

use super::shapes::ShapeCache;
use super::Contact;
use crate::body::RigidBody;
use crate::shape::Shape;
use nalgebra::{Isometry3, Point3, Unit};
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::query::{
    ContactManifold, ContactManifoldsWorkspace, DefaultQueryDispatcher, PersistentQueryDispatcher,
};
use parry3d_f64::shape::{SharedShape, TriMesh};
use std::collections::HashMap;

/// Most contacts one narrow-phase pass reports. Each becomes up to `2 + pyramid directions`
/// rows of the step's problem; a scene of 10,000 resting boxes has about 40,000.
pub const MAX_CONTACTS: usize = 500_000;

/// The candidate pairs touch at more points than the narrow phase takes ([`MAX_CONTACTS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "more than {limit} contact points (the narrow phase's limit): the bodies overlap or touch \
     along too many triangles or too many neighbours"
)]
pub struct TooManyContacts {
    /// The limit that was exceeded.
    pub limit: usize,
}

/// Manifolds and generator workspace of one body pair, kept between calls.
#[derive(Default)]
struct PairCache {
    manifolds: Vec<ContactManifold<(), ()>>,
    workspace: Option<ContactManifoldsWorkspace>,
    /// The pose of the second body in the first's frame when the manifolds were last computed
    /// by parry's generators (not updated by [`PairCache::try_keep`]).
    computed_at: Option<Isometry3<f64>>,
}

impl PairCache {
    /// Persistent manifolds: update the kept manifolds to the pose `pos12` instead of computing
    /// them again, when the pose moved less than `linear` (length) and `angular` (rad) since
    /// they were computed and every manifold is a whole-shape manifold with points. Each
    /// point's gap is measured again along the kept normal and its point on the first shape
    /// moved to face the point on the second (parry's `ContactManifold::try_update_contacts_eps`,
    /// the update parry's cuboid and polyhedron generators try before a full computation, here
    /// with the thresholds `cos(angular)` on the normal and `linear` on each point's slide).
    /// All manifolds are updated or none (then `false`, and the caller computes them afresh).
    fn try_keep(&mut self, pos12: &Isometry3<f64>, linear: f64, angular: f64) -> bool {
        let Some(computed_at) = self.computed_at else {
            return false;
        };
        let whole_shapes = self.manifolds.iter().all(|m| {
            !m.points.is_empty() && m.subshape_pos1.is_none() && m.subshape_pos2.is_none()
        });
        if self.manifolds.is_empty() || !whole_shapes {
            return false;
        }
        let moved = computed_at.inv_mul(pos12);
        if moved.translation.vector.norm() > linear || moved.rotation.angle() > angular {
            return false;
        }
        let mut updated = self.manifolds.clone();
        let kept = updated
            .iter_mut()
            .all(|m| m.try_update_contacts_eps(pos12, angular.cos(), linear * linear));
        if kept {
            self.manifolds = updated;
        }
        kept
    }
}

/// Persistent narrow phase: one cache entry per body pair seen in the last call, and the parry
/// shape of each body ([`ShapeCache`]).
pub struct NarrowPhase {
    pairs: HashMap<(usize, usize), PairCache>,
    shapes: ShapeCache,
    /// Contacts of one pair closer than this (with normals within `1e-6` rad) are merged.
    /// Default `1e-7` (length units of the scene).
    pub merge_distance: f64,
    /// Mesh–mesh contacts whose penetration exceeds the true depth of their points inside the
    /// other mesh by more than this are dropped. Default `1e-3` (length units of the scene).
    pub mesh_depth_slack: f64,
    /// Persistent manifolds: a pair whose relative pose moved less than
    /// [`NarrowPhase::manifold_linear_threshold`] and
    /// [`NarrowPhase::manifold_angular_threshold`] since its manifolds were computed keeps them,
    /// its points' gaps measured again at the new pose, instead of running parry's generator
    /// (pairs of whole shapes, not meshes). The points differ slightly from a fresh computation
    /// (the kept points slide with the bodies; a new point that would appear within the
    /// thresholds does not), so this is off by default \[`false`\].
    pub persistent_manifolds: bool,
    /// Persistent manifolds: largest translation of one body relative to the other (length
    /// units of the scene), and largest slide of a kept point on the first body, for which a
    /// pair's manifolds are kept \[`1e-4`\].
    pub manifold_linear_threshold: f64,
    /// Persistent manifolds: largest rotation of one body relative to the other, rad, for which
    /// a pair's manifolds are kept \[`1e-3`\].
    pub manifold_angular_threshold: f64,
    /// Pairs whose manifolds the last call kept (persistent manifolds).
    kept_pairs: usize,
}

impl Default for NarrowPhase {
    fn default() -> Self {
        Self {
            pairs: HashMap::new(),
            shapes: ShapeCache::new(),
            merge_distance: 1e-7,
            mesh_depth_slack: 1e-3,
            persistent_manifolds: false,
            manifold_linear_threshold: 1e-4,
            manifold_angular_threshold: 1e-3,
            kept_pairs: 0,
        }
    }
}

impl std::fmt::Debug for NarrowPhase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NarrowPhase")
            .field("cached_pairs", &self.pairs.len())
            .field("shapes", &self.shapes)
            .field("persistent_manifolds", &self.persistent_manifolds)
            .finish()
    }
}

impl NarrowPhase {
    /// Empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of body pairs with cached manifolds.
    pub fn cached_pairs(&self) -> usize {
        self.pairs.len()
    }

    /// Pairs whose manifolds the last call kept instead of computing them (always 0 without
    /// [`NarrowPhase::persistent_manifolds`]).
    pub fn kept_pairs(&self) -> usize {
        self.kept_pairs
    }

    /// The parry shapes of the bodies of the last call.
    pub fn shapes(&self) -> &ShapeCache {
        &self.shapes
    }

    /// Bring the parry shapes in line with `bodies` ([`ShapeCache::update`]).
    pub fn update_shapes(&mut self, bodies: &[RigidBody]) {
        self.shapes.update(bodies);
    }

    /// Forgets every cached manifold (call when the body list is rebuilt or reordered). The
    /// parry shapes are kept: each is checked against its body's shape on the next call.
    pub fn clear(&mut self) {
        self.pairs.clear();
    }

    /// Contacts of the given candidate `pairs` with gap below `prediction`. Cache entries of
    /// pairs not in `pairs` are dropped. More than [`MAX_CONTACTS`] contacts are refused (and
    /// the cache is emptied).
    pub fn contacts(
        &mut self,
        bodies: &[RigidBody],
        pairs: &[(usize, usize)],
        prediction: f64,
    ) -> Result<Vec<Contact>, TooManyContacts> {
        self.shapes.update(bodies);
        self.contacts_of_shapes(bodies, pairs, prediction)
    }

    /// [`NarrowPhase::contacts`] with the parry shapes already updated to `bodies`.
    pub(super) fn contacts_of_shapes(
        &mut self,
        bodies: &[RigidBody],
        pairs: &[(usize, usize)],
        prediction: f64,
    ) -> Result<Vec<Contact>, TooManyContacts> {
        let shapes = &self.shapes;
        let mut caches: Vec<PairCache> = pairs
            .iter()
            .map(|pair| self.pairs.remove(pair).unwrap_or_default())
            .collect();
        // Pairs are independent: chunks of them run on rayon's threads, each chunk's contacts
        // in pair order, and the chunks are joined in order, so the contacts are those of a
        // serial pass in the same order.
        let pair_contacts =
            |chunk: (&[(usize, usize)], &mut [PairCache])| -> (Vec<Contact>, usize) {
                let mut out = Vec::new();
                let mut kept = 0;
                for (&(a, b), cache) in chunk.0.iter().zip(chunk.1.iter_mut()) {
                    let (sa, sb) = (shapes.get(a), shapes.get(b));
                    kept += usize::from(self.pair_contacts(
                        bodies,
                        (a, b),
                        (sa, sb),
                        cache,
                        prediction,
                        &mut out,
                    ));
                }
                (out, kept)
            };
        let chunks: Vec<(Vec<Contact>, usize)> = if pairs.len() >= PARALLEL_PAIRS {
            use rayon::prelude::*;
            pairs
                .par_chunks(PAIR_CHUNK)
                .zip(caches.par_chunks_mut(PAIR_CHUNK))
                .map(pair_contacts)
                .collect()
        } else {
            vec![pair_contacts((pairs, &mut caches))]
        };
        let total: usize = chunks.iter().map(|c| c.0.len()).sum();
        self.kept_pairs = chunks.iter().map(|c| c.1).sum();
        if total > MAX_CONTACTS {
            self.pairs.clear();
            return Err(TooManyContacts {
                limit: MAX_CONTACTS,
            });
        }
        let mut out = Vec::with_capacity(total);
        for (chunk, _) in chunks {
            out.extend(chunk);
        }
        self.pairs = pairs.iter().copied().zip(caches).collect();
        Ok(out)
    }

    /// The contacts of one pair, appended to `out`, its cached manifolds updated (or, with
    /// persistent manifolds, kept: then `true`).
    fn pair_contacts(
        &self,
        bodies: &[RigidBody],
        (a, b): (usize, usize),
        (sa, sb): (&SharedShape, &SharedShape),
        cache: &mut PairCache,
        prediction: f64,
        out: &mut Vec<Contact>,
    ) -> bool {
        let (iso_a, iso_b) = (bodies[a].iso(), bodies[b].iso());
        let pos12 = iso_a.inv_mul(&iso_b);
        let kept = self.persistent_manifolds
            && cache.try_keep(
                &pos12,
                self.manifold_linear_threshold,
                self.manifold_angular_threshold,
            );
        if !kept {
            // Every pair of `Shape` kinds is supported except plane–plane, which the broad
            // phase never emits (planes are static).
            let supported = DefaultQueryDispatcher.contact_manifolds(
                &pos12,
                &**sa,
                &**sb,
                prediction,
                &mut cache.manifolds,
                &mut cache.workspace,
            );
            debug_assert!(
                supported.is_ok(),
                "parry has no manifold generator for {} vs {}",
                bodies[a].shape.kind(),
                bodies[b].shape.kind()
            );
            cache.computed_at = Some(pos12);
        }
        let first = out.len();
        let meshes = match (&bodies[a].shape, &bodies[b].shape) {
            (Shape::TriMesh { mesh: ma, .. }, Shape::TriMesh { mesh: mb, .. }) => Some(MeshPair {
                a: ma,
                b: mb,
                slack: self.mesh_depth_slack,
            }),
            _ => None,
        };
        for m in &cache.manifolds {
            push_manifold(out, a, b, &iso_a, &iso_b, m, prediction, meshes.as_ref());
        }
        merge_duplicates(out, first, self.merge_distance);
        kept
    }
}

/// Candidate pairs from which the narrow phase runs on rayon's threads.
const PARALLEL_PAIRS: usize = 256;

/// Pairs per rayon task.
const PAIR_CHUNK: usize = 128;

/// Both shapes of a mesh–mesh pair, for the depth check.
struct MeshPair<'a> {
    a: &'a TriMesh,
    b: &'a TriMesh,
    slack: f64,
}

#[allow(clippy::too_many_arguments)]
fn push_manifold(
    out: &mut Vec<Contact>,
    a: usize,
    b: usize,
    iso_a: &Isometry3<f64>,
    iso_b: &Isometry3<f64>,
    m: &ContactManifold<(), ()>,
    prediction: f64,
    meshes: Option<&MeshPair>,
) {
    let frame_a = m.subshape_pos1.map_or(*iso_a, |p| iso_a * p);
    let frame_b = m.subshape_pos2.map_or(*iso_b, |p| iso_b * p);
    let Some(normal) = Unit::try_new(frame_a * m.local_n1, 1e-12) else {
        return;
    };
    for c in &m.points {
        if c.dist > prediction {
            continue;
        }
        let pa: Point3<f64> = frame_a * c.local_p1;
        let pb: Point3<f64> = frame_b * c.local_p2;
        if let (Some(pair), true) = (meshes, c.dist < 0.0) {
            let depth = depth_in_mesh(pair.a, iso_a, &pb).max(depth_in_mesh(pair.b, iso_b, &pa));
            if -c.dist > depth + pair.slack {
                continue;
            }
        }
        out.push(Contact {
            body_a: a,
            body_b: b,
            point: nalgebra::center(&pa, &pb),
            normal: normal.into_inner(),
            dist: c.dist,
            key: contact_key(a, b, m.subshape1, m.subshape2, c.fid1.0, c.fid2.0),
        });
    }
}

/// Depth of the world point `p` inside the closed mesh `mesh` at pose `iso` (0 outside), from
/// the projection on the mesh with its pseudo-normals deciding inside and outside.
fn depth_in_mesh(mesh: &TriMesh, iso: &Isometry3<f64>, p: &Point3<f64>) -> f64 {
    let local = iso.inverse_transform_point(p);
    let (proj, _) = mesh.project_local_point_and_get_location(&local, false);
    if proj.is_inside {
        (proj.point - local).norm()
    } else {
        0.0
    }
}

/// Merges the contacts `out[first..]` (one body pair) that share a point and a normal.
fn merge_duplicates(out: &mut Vec<Contact>, first: usize, merge_distance: f64) {
    if out.len() - first < 2 {
        return;
    }
    let d2 = merge_distance * merge_distance;
    let mut merged: Vec<Contact> = Vec::with_capacity(out.len() - first);
    for c in out.drain(first..) {
        match merged.iter_mut().find(|m| {
            (m.point - c.point).norm_squared() <= d2 && m.normal.dot(&c.normal) >= 1.0 - 5e-13
        }) {
            Some(m) => {
                m.dist = m.dist.min(c.dist);
                m.key = m.key.min(c.key);
            }
            None => merged.push(c),
        }
    }
    out.extend(merged);
}

/// Stable 64-bit key of a contact from its body pair, sub-shapes and features (SplitMix64
/// finaliser over the fields, so the value does not depend on the standard library's hasher).
pub fn contact_key(a: usize, b: usize, sub_a: u32, sub_b: u32, fid_a: u32, fid_b: u32) -> u64 {
    fn mix(mut z: u64) -> u64 {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    let mut h = 0x9e37_79b9_7f4a_7c15_u64;
    for x in [
        a as u64,
        b as u64,
        u64::from(sub_a) << 32 | u64::from(sub_b),
        u64::from(fid_a) << 32 | u64::from(fid_b),
    ] {
        h = mix(h ^ mix(x.wrapping_add(0x9e37_79b9_7f4a_7c15)));
    }
    h
}

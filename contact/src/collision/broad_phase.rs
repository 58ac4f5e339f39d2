//! Broad phase: sweep and prune over world-space axis-aligned bounding boxes.
//!
//! The boxes are sorted by their lower bound on one axis, the axis along which the box centres
//! have the largest variance (the axis that separates them best), and swept once: each box is
//! compared only with the boxes that start before it ends on that axis, and a pair is kept if
//! the boxes also overlap on the other two axes. The cost is `O(n log n + k)` with `k` the
//! number of pairs that overlap on the sweep axis, so for a sparse scene it grows with the
//! number of overlaps rather than with `n²` (Ericson, *Real-Time Collision Detection*, 2005,
//! §7.5 "Sort and sweep"; Baraff, "Dynamic simulation of non-penetrating rigid bodies", 1992,
//! ch. 7).
//!
//! Planes are unbounded and are kept out of the sweep: a plane is paired with every dynamic
//! body whose bounding box reaches below it (within the margin). Pairs of two static bodies
//! are never reported.
//!
//! The pairs a scene gives are bounded by [`MAX_PAIRS`]: bodies piled on one spot pair with
//! each other (9,999 coincident spheres make 50 million pairs), and the sweep stops with
//! [`TooManyPairs`] as soon as it has found more, before the list outgrows memory.

use crate::body::RigidBody;
use crate::shape::Shape;
use nalgebra::{Point3, Vector3};
use parry3d_f64::bounding_volume::{Aabb, BoundingVolume};

/// Most candidate pairs one broad-phase pass reports (each becomes a narrow-phase query with a
/// cached manifold, a few hundred bytes). A scene of 10,000 resting spheres or boxes has a few
/// tens of thousands.
pub const MAX_PAIRS: usize = 500_000;

/// More body pairs overlap than the broad phase takes ([`MAX_PAIRS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "more than {limit} pairs of bodies have overlapping bounding boxes (the broad phase's limit): \
     bodies are piled on top of each other, or the prediction distance spans many of them"
)]
pub struct TooManyPairs {
    /// The limit that was exceeded.
    pub limit: usize,
}

/// World-space bounding box of a body, grown by `margin` on every side.
pub fn world_aabb(body: &RigidBody, margin: f64) -> Aabb {
    let aabb = body.shape.aabb(&body.iso());
    Aabb::new(
        aabb.mins - Vector3::repeat(margin),
        aabb.maxs + Vector3::repeat(margin),
    )
}

/// Candidate pairs `(i, j)`, `i < j`, sorted, whose boxes (grown by `margin`) overlap on all
/// three axes; `skip(i, j)` removes pairs before the overlap test. Sweep and prune, without a
/// bound on the pairs (see [`sweep_and_prune_at_most`]).
pub fn sweep_and_prune(
    aabbs: &[Aabb],
    skip: impl FnMut(usize, usize) -> bool,
) -> Vec<(usize, usize)> {
    // No list can hold `usize::MAX` pairs, so this bound is never reached.
    sweep_and_prune_at_most(aabbs, skip, usize::MAX).unwrap_or_default()
}

/// [`sweep_and_prune`] that stops with [`TooManyPairs`] once it has found more than
/// `max_pairs` pairs.
pub fn sweep_and_prune_at_most(
    aabbs: &[Aabb],
    mut skip: impl FnMut(usize, usize) -> bool,
    max_pairs: usize,
) -> Result<Vec<(usize, usize)>, TooManyPairs> {
    let n = aabbs.len();
    if n < 2 {
        return Ok(Vec::new());
    }
    let axis = sweep_axis(aabbs);
    let (o1, o2) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| aabbs[a].mins[axis].total_cmp(&aabbs[b].mins[axis]));
    let mut pairs = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        let bi = &aabbs[i];
        for &j in &order[k + 1..] {
            let bj = &aabbs[j];
            if bj.mins[axis] > bi.maxs[axis] {
                break;
            }
            if bj.mins[o1] <= bi.maxs[o1]
                && bi.mins[o1] <= bj.maxs[o1]
                && bj.mins[o2] <= bi.maxs[o2]
                && bi.mins[o2] <= bj.maxs[o2]
            {
                let pair = (i.min(j), i.max(j));
                if !skip(pair.0, pair.1) {
                    if pairs.len() == max_pairs {
                        return Err(TooManyPairs { limit: max_pairs });
                    }
                    pairs.push(pair);
                }
            }
        }
    }
    pairs.sort_unstable();
    Ok(pairs)
}

/// All pairs `(i, j)`, `i < j`, whose boxes overlap, by testing every pair (`O(n²)`; the
/// reference the sweep is checked against).
pub fn brute_force_pairs(
    aabbs: &[Aabb],
    mut skip: impl FnMut(usize, usize) -> bool,
) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for i in 0..aabbs.len() {
        for j in i + 1..aabbs.len() {
            if !skip(i, j) && aabbs[i].intersects(&aabbs[j]) {
                pairs.push((i, j));
            }
        }
    }
    pairs
}

/// The axis (0, 1, 2) along which the box centres have the largest variance.
fn sweep_axis(aabbs: &[Aabb]) -> usize {
    let n = aabbs.len() as f64;
    let mut sum = Vector3::zeros();
    let mut sum2 = Vector3::zeros();
    for b in aabbs {
        let c = b.center().coords;
        sum += c;
        sum2 += c.component_mul(&c);
    }
    let var = sum2 / n - (sum / n).component_mul(&(sum / n));
    var.imax()
}

/// Candidate body pairs `(i, j)`, `i < j`, sorted: bounded bodies whose bounding boxes grown by
/// `margin` overlap (sweep and prune), plus every plane paired with each dynamic body whose
/// box reaches within `margin` of it. Static–static pairs are skipped. More than [`MAX_PAIRS`]
/// pairs are refused.
pub fn candidate_pairs_with_margin(
    bodies: &[RigidBody],
    margin: f64,
) -> Result<Vec<(usize, usize)>, TooManyPairs> {
    candidate_pairs_with_boxes(bodies, |b| world_aabb(b, 0.5 * margin), 0.5 * margin)
}

/// Candidate pairs as [`candidate_pairs_with_margin`], with the bounding box of each bounded
/// (non-plane) body given by `aabb` (for instance a box swept over a step); a plane is paired
/// with a dynamic body whose box reaches within `plane_margin` of it. More than [`MAX_PAIRS`]
/// pairs are refused.
pub fn candidate_pairs_with_boxes(
    bodies: &[RigidBody],
    aabb: impl Fn(&RigidBody) -> Aabb,
    plane_margin: f64,
) -> Result<Vec<(usize, usize)>, TooManyPairs> {
    let bounded: Vec<usize> = (0..bodies.len())
        .filter(|&i| !matches!(bodies[i].shape, Shape::Plane { .. }))
        .collect();
    let aabbs: Vec<Aabb> = bounded.iter().map(|&i| aabb(&bodies[i])).collect();
    let too_many = TooManyPairs { limit: MAX_PAIRS };
    let mut pairs: Vec<(usize, usize)> = sweep_and_prune_at_most(
        &aabbs,
        |a, b| bodies[bounded[a]].is_static && bodies[bounded[b]].is_static,
        MAX_PAIRS,
    )?
    .into_iter()
    .map(|(a, b)| {
        let (i, j) = (bounded[a], bounded[b]);
        (i.min(j), i.max(j))
    })
    .collect();

    for (p, plane) in bodies.iter().enumerate() {
        let Shape::Plane { normal } = &plane.shape else {
            continue;
        };
        let n = plane.orientation * normal.into_inner();
        let offset = n.dot(&plane.position.coords);
        for (k, &i) in bounded.iter().enumerate() {
            if plane.is_static && bodies[i].is_static {
                continue;
            }
            // Corner of the box furthest along -n.
            let b = &aabbs[k];
            let corner = Point3::from(Vector3::from_fn(|r, _| {
                if n[r] >= 0.0 {
                    b.mins[r]
                } else {
                    b.maxs[r]
                }
            }));
            if n.dot(&corner.coords) - offset <= plane_margin {
                if pairs.len() >= MAX_PAIRS {
                    return Err(too_many);
                }
                pairs.push((p.min(i), p.max(i)));
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    Ok(pairs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn aabb(c: [f64; 3], h: f64) -> Aabb {
        let c = Point3::from(c);
        Aabb::new(c - Vector3::repeat(h), c + Vector3::repeat(h))
    }

    #[test]
    fn empty_and_single() {
        assert!(sweep_and_prune(&[], |_, _| false).is_empty());
        assert!(sweep_and_prune(&[aabb([0.0; 3], 1.0)], |_, _| false).is_empty());
    }

    #[test]
    fn touching_boxes_pair_and_skip_filter() {
        let boxes = [
            aabb([0.0, 0.0, 0.0], 1.0),
            aabb([2.0, 0.0, 0.0], 1.0),
            aabb([10.0, 0.0, 0.0], 1.0),
        ];
        assert_eq!(sweep_and_prune(&boxes, |_, _| false), vec![(0, 1)]);
        assert!(sweep_and_prune(&boxes, |_, _| true).is_empty());
    }

    #[test]
    fn the_sweep_stops_past_its_pair_limit() {
        let boxes: Vec<Aabb> = (0..50).map(|_| aabb([0.0; 3], 1.0)).collect();
        assert_eq!(
            sweep_and_prune_at_most(&boxes, |_, _| false, 100),
            Err(TooManyPairs { limit: 100 })
        );
        assert_eq!(
            sweep_and_prune_at_most(&boxes, |_, _| false, 50 * 49 / 2).map(|p| p.len()),
            Ok(50 * 49 / 2)
        );
    }

    #[test]
    fn overlap_on_sweep_axis_only_is_pruned() {
        // Same x range, far apart in y.
        let boxes = [aabb([0.0, 0.0, 0.0], 1.0), aabb([0.5, 5.0, 0.0], 1.0)];
        assert!(sweep_and_prune(&boxes, |_, _| false).is_empty());
    }
}

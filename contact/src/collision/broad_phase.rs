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
//! In a simulation the boxes move little from one step to the next, so the [`BroadPhase`] of a
//! collision pipeline keeps its sorted order between calls and repairs it with an insertion
//! sort ([`SweepOrder`], Ericson §7.5.2), and takes each body's box from its cached parry shape;
//! it returns exactly the pairs of the from-scratch sweep.
//!
//! Planes are unbounded and are kept out of the sweep: a plane is paired with every dynamic
//! body whose bounding box reaches below it (within the margin). Pairs of two static bodies
//! are never reported.
//!
//! The pairs a scene gives are bounded by [`MAX_PAIRS`]: bodies piled on one spot pair with
//! each other (9,999 coincident spheres make 50 million pairs), and the sweep stops with
//! [`TooManyPairs`] as soon as it has found more, before the list outgrows memory.

use super::shapes::ShapeCache;
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
    grown(body.shape.aabb(&body.iso()), margin)
}

/// `aabb` grown by `margin` on every side.
fn grown(aabb: Aabb, margin: f64) -> Aabb {
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
    skip: impl FnMut(usize, usize) -> bool,
    max_pairs: usize,
) -> Result<Vec<(usize, usize)>, TooManyPairs> {
    // A fresh order sorts from scratch: the persistent sweep's first call.
    SweepOrder::new().pairs_at_most(aabbs, skip, max_pairs)
}

/// The sweep over boxes already in `order` (increasing lower bound on `axis`, as
/// `f64::total_cmp` orders them): each box is compared with the boxes after it that start
/// before it ends on `axis`. Every pair that overlaps on all three axes is found once, from
/// whichever of its boxes comes first, so the sorted result does not depend on how ties in
/// the order are broken, nor on the axis. Stops with [`TooManyPairs`] past `max_pairs`.
fn sweep_sorted(
    aabbs: &[Aabb],
    order: &[usize],
    axis: usize,
    mut skip: impl FnMut(usize, usize) -> bool,
    max_pairs: usize,
) -> Result<Vec<(usize, usize)>, TooManyPairs> {
    let (o1, o2) = ((axis + 1) % 3, (axis + 2) % 3);
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

/// Sweep and prune that keeps its sorted order from one call to the next (Ericson 2005,
/// §7.5.2: "sort and sweep" exploits temporal coherence by re-sorting the previous order with
/// insertion sort, which costs `O(n + s)` for `s` boxes that swapped places; Baraff 1992, §7.3).
///
/// Between two steps of a simulation the boxes move little, so last step's order along the
/// sweep axis is nearly sorted: an insertion sort repairs it in about one pass, where sorting
/// from scratch costs `O(n log n)`. The sweep itself is the one of [`sweep_and_prune_at_most`],
/// and its pairs do not depend on the order of ties or on the axis, so each call returns
/// exactly the pairs of the from-scratch sweep on the same boxes. The axis is chosen on every
/// call as there (largest variance of the centres); when it changes, or the number of boxes
/// does, the order is sorted from scratch, as it is when the insertion sort would move more
/// than [`SweepOrder::MAX_SHIFTS_PER_BOX`] places per box on average (a scene that scrambled).
#[derive(Debug, Clone, Default)]
pub struct SweepOrder {
    axis: usize,
    order: Vec<usize>,
    /// Places moved by the last call's insertion sort (`None` when it sorted from scratch).
    last_shifts: Option<usize>,
}

impl SweepOrder {
    /// Average places per box past which the insertion sort gives up for a full sort.
    pub const MAX_SHIFTS_PER_BOX: usize = 8;

    /// An empty order (the first call sorts from scratch).
    pub fn new() -> Self {
        Self::default()
    }

    /// The pairs of [`sweep_and_prune_at_most`] on `aabbs`, re-sorting the order kept from the
    /// last call.
    pub fn pairs_at_most(
        &mut self,
        aabbs: &[Aabb],
        skip: impl FnMut(usize, usize) -> bool,
        max_pairs: usize,
    ) -> Result<Vec<(usize, usize)>, TooManyPairs> {
        let n = aabbs.len();
        if n < 2 {
            self.order.clear();
            self.last_shifts = None;
            return Ok(Vec::new());
        }
        let axis = sweep_axis(aabbs);
        let key = |i: usize| aabbs[i].mins[axis];
        let shifts = (axis == self.axis && self.order.len() == n)
            .then(|| insertion_sort(&mut self.order, key, Self::MAX_SHIFTS_PER_BOX * n))
            .flatten();
        self.last_shifts = shifts;
        if shifts.is_none() {
            self.axis = axis;
            self.order = (0..n).collect();
            self.order.sort_by(|&a, &b| key(a).total_cmp(&key(b)));
        }
        sweep_sorted(aabbs, &self.order, axis, skip, max_pairs)
    }

    /// Places the insertion sort of the last call moved boxes by, in total (`None` when that
    /// call sorted from scratch).
    pub fn last_shifts(&self) -> Option<usize> {
        self.last_shifts
    }

    /// Forget the order (the next call sorts from scratch).
    pub fn clear(&mut self) {
        self.order.clear();
        self.last_shifts = None;
    }
}

/// Insertion sort of `order` by `key` (`f64::total_cmp`), moving at most `budget` places in
/// all: the places moved, or `None`, with `order` still a permutation but not sorted, when it
/// would move more.
fn insertion_sort(order: &mut [usize], key: impl Fn(usize) -> f64, budget: usize) -> Option<usize> {
    let mut shifts = 0;
    for k in 1..order.len() {
        let item = order[k];
        let v = key(item);
        let mut j = k;
        while j > 0 && key(order[j - 1]).total_cmp(&v).is_gt() {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = item;
        shifts += k - j;
        if shifts > budget {
            return None;
        }
    }
    Some(shifts)
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
    let bounded = bounded_bodies(bodies);
    let aabbs: Vec<Aabb> = bounded.iter().map(|&i| aabb(&bodies[i])).collect();
    pairs_of_boxes(
        bodies,
        &bounded,
        &aabbs,
        plane_margin,
        |aabbs, skip, max| sweep_and_prune_at_most(aabbs, skip, max),
    )
}

/// The broad phase of a [`CollisionPipeline`](super::CollisionPipeline): the candidate pairs of
/// [`candidate_pairs_with_margin`], with each body's bounding box taken from its cached parry
/// shape ([`ShapeCache`]) and the sweep order kept from one call to the next ([`SweepOrder`]).
/// Each call returns exactly the pairs [`candidate_pairs_with_margin`] returns for the same
/// bodies (the same list, in the same order, or the same refusal).
#[derive(Debug, Clone, Default)]
pub struct BroadPhase {
    sweep: SweepOrder,
}

impl BroadPhase {
    /// A broad phase with no order yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Candidate pairs of `bodies` (whose parry shapes `shapes` holds, as of an update with
    /// these bodies) with boxes grown by `margin / 2` on every side, as
    /// [`candidate_pairs_with_margin`].
    pub fn candidate_pairs(
        &mut self,
        bodies: &[RigidBody],
        shapes: &ShapeCache,
        margin: f64,
    ) -> Result<Vec<(usize, usize)>, TooManyPairs> {
        let half = 0.5 * margin;
        let bounded = bounded_bodies(bodies);
        let aabbs: Vec<Aabb> = bounded
            .iter()
            .map(|&i| grown(shapes.aabb(bodies, i), half))
            .collect();
        let sweep = &mut self.sweep;
        pairs_of_boxes(bodies, &bounded, &aabbs, half, |aabbs, skip, max| {
            sweep.pairs_at_most(aabbs, skip, max)
        })
    }

    /// The sweep order kept between calls.
    pub fn sweep_order(&self) -> &SweepOrder {
        &self.sweep
    }

    /// Forget the sweep order (the next call sorts from scratch).
    pub fn clear(&mut self) {
        self.sweep.clear();
    }
}

/// Candidate pairs, or the refusal past the limit.
type Pairs = Result<Vec<(usize, usize)>, TooManyPairs>;

/// The filter a sweep takes: `true` removes the pair `(i, j)`.
type Skip<'a> = &'a mut dyn FnMut(usize, usize) -> bool;

/// The bodies that are not planes (the ones the sweep takes), increasing.
fn bounded_bodies(bodies: &[RigidBody]) -> Vec<usize> {
    (0..bodies.len())
        .filter(|&i| !matches!(bodies[i].shape, Shape::Plane { .. }))
        .collect()
}

/// The candidate pairs of [`candidate_pairs_with_boxes`] from the boxes `aabbs` of the
/// `bounded` bodies, swept by `sweep` (a from-scratch or a persistent sweep and prune: both
/// return the same pairs).
fn pairs_of_boxes(
    bodies: &[RigidBody],
    bounded: &[usize],
    aabbs: &[Aabb],
    plane_margin: f64,
    sweep: impl FnOnce(&[Aabb], Skip<'_>, usize) -> Pairs,
) -> Pairs {
    let too_many = TooManyPairs { limit: MAX_PAIRS };
    let mut static_pair =
        |a: usize, b: usize| bodies[bounded[a]].is_static && bodies[bounded[b]].is_static;
    let mut pairs: Vec<(usize, usize)> = sweep(aabbs, &mut static_pair, MAX_PAIRS)?
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
    fn the_kept_order_is_repaired_by_insertion_sort_and_gives_the_sweeps_pairs() {
        // A row of boxes along x; every step each moves a little, neighbours swapping places.
        let mut centres: Vec<f64> = (0..30).map(|i| 0.9 * i as f64).collect();
        let mut sweep = SweepOrder::new();
        for step in 0..10 {
            let boxes: Vec<Aabb> = centres.iter().map(|&x| aabb([x, 0.0, 0.0], 0.5)).collect();
            let kept = sweep
                .pairs_at_most(&boxes, |_, _| false, usize::MAX)
                .unwrap();
            assert_eq!(kept, sweep_and_prune(&boxes, |_, _| false), "step {step}");
            assert_eq!(kept, brute_force_pairs(&boxes, |_, _| false), "step {step}");
            // The first call sorts from scratch, the next ones repair the kept order.
            assert_eq!(sweep.last_shifts().is_some(), step > 0, "step {step}");
            for (i, x) in centres.iter_mut().enumerate() {
                *x += if (i + step) % 2 == 0 { 0.6 } else { -0.6 };
            }
        }
        // A scrambled scene is sorted from scratch (more than the shift budget).
        let reversed: Vec<Aabb> = (0..30)
            .map(|i| aabb([-3.0 * i as f64, 0.0, 0.0], 0.5))
            .collect();
        let pairs = sweep
            .pairs_at_most(&reversed, |_, _| false, usize::MAX)
            .unwrap();
        assert!(pairs.is_empty() && sweep.last_shifts().is_none());
    }

    #[test]
    fn insertion_sort_sorts_within_its_budget_or_gives_up() {
        let keys = [3.0, 1.0, 2.0, 0.0];
        let mut order = vec![0, 1, 2, 3];
        assert_eq!(insertion_sort(&mut order, |i| keys[i], 100), Some(5));
        assert_eq!(order, vec![3, 1, 2, 0]);
        let mut order = vec![0, 1, 2, 3];
        assert_eq!(insertion_sort(&mut order, |i| keys[i], 2), None);
    }

    #[test]
    fn overlap_on_sweep_axis_only_is_pruned() {
        // Same x range, far apart in y.
        let boxes = [aabb([0.0, 0.0, 0.0], 1.0), aabb([0.5, 5.0, 0.0], 1.0)];
        assert!(sweep_and_prune(&boxes, |_, _| false).is_empty());
    }
}

//! Free flight between events: ballistic motion, the time of impact of two ballistic bodies by
//! conservative advancement, the states each body saves, rollback, and the event loop of one
//! frame window (optimistic Time Warp or the synchronous reference).
//!
//! A body in free flight follows `x(t) = x₀ + v₀ τ + ½ g τ²`, `q(t) = exp(ω₀ τ) q₀`
//! (`τ = t − t₀`, `ω₀` the angular velocity of the saved state): exact for the translation,
//! and for the rotation of a body whose inertia is a multiple of the identity (spheres, cubes);
//! for other bodies it is the constant-angular-velocity motion that [`crate::collision::toi`]
//! also assumes.

use super::{Cost, Impact, Scheduling, TimewarpSettings};
use crate::body::RigidBody;
use crate::step::World;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use parry3d_f64::shape::SharedShape;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

/// The changing part of a body's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Centre of mass.
    pub position: Point3<f64>,
    /// Orientation.
    pub orientation: UnitQuaternion<f64>,
    /// Linear momentum.
    pub linear_momentum: Vector3<f64>,
    /// Angular momentum about the centre of mass, world frame.
    pub angular_momentum: Vector3<f64>,
}

impl State {
    /// The state of `body`.
    pub fn of(body: &RigidBody) -> Self {
        Self {
            position: body.position,
            orientation: body.orientation,
            linear_momentum: body.linear_momentum,
            angular_momentum: body.angular_momentum,
        }
    }

    /// Write this state into `body`.
    pub fn write(&self, body: &mut RigidBody) {
        body.position = self.position;
        body.orientation = self.orientation;
        body.linear_momentum = self.linear_momentum;
        body.angular_momentum = self.angular_momentum;
    }
}

/// A rigid motion with constant acceleration of the origin and constant angular velocity,
/// from time `t0` (absolute, s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeMotion {
    /// Start time, s.
    pub t0: f64,
    /// Pose at `t0`.
    pub start: Isometry3<f64>,
    /// Linear velocity at `t0`.
    pub linvel: Vector3<f64>,
    /// Angular velocity (constant).
    pub angvel: Vector3<f64>,
    /// Acceleration of the origin (gravity for a body in flight, zero otherwise).
    pub accel: Vector3<f64>,
}

impl FreeMotion {
    /// A body that does not move.
    pub fn stationary(start: Isometry3<f64>) -> Self {
        Self {
            t0: 0.0,
            start,
            linvel: Vector3::zeros(),
            angvel: Vector3::zeros(),
            accel: Vector3::zeros(),
        }
    }

    /// Pose at time `t`.
    pub fn at(&self, t: f64) -> Isometry3<f64> {
        let tau = t - self.t0;
        let rotation = if self.angvel == Vector3::zeros() {
            self.start.rotation
        } else {
            UnitQuaternion::from_scaled_axis(self.angvel * tau) * self.start.rotation
        };
        Isometry3::from_parts(
            Translation3::from(
                self.start.translation.vector + self.linvel * tau + self.accel * (0.5 * tau * tau),
            ),
            rotation,
        )
    }

    /// Linear velocity at time `t`.
    pub fn velocity(&self, t: f64) -> Vector3<f64> {
        self.linvel + self.accel * (t - self.t0)
    }

    /// Velocity of the material point at world position `p` at time `t`.
    fn point_velocity(&self, t: f64, p: &Point3<f64>) -> Vector3<f64> {
        let centre = self.at(t).translation.vector;
        self.velocity(t) + self.angvel.cross(&(p.coords - centre))
    }
}

/// How the trajectory continues after a saved state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// Free flight under gravity.
    Ballistic,
    /// A group step: constant velocities to the next saved state (the semi-implicit Euler
    /// step's pose update, `x⁺ = x + h v⁺`).
    Stepped {
        /// Linear velocity over the segment.
        linvel: Vector3<f64>,
        /// Angular velocity over the segment.
        angvel: Vector3<f64>,
    },
}

/// A saved state: the state at `time` and how the trajectory continues from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Saved {
    /// Time, s.
    pub time: f64,
    /// The state at `time`.
    pub state: State,
    /// The motion after `time`.
    pub segment: Segment,
}

/// The motion of `body` (mass properties) from the saved state `s`, under `gravity`.
pub fn motion_from(body: &RigidBody, s: &Saved, gravity: &Vector3<f64>) -> FreeMotion {
    let start = Isometry3::from_parts(
        Translation3::from(s.state.position.coords),
        s.state.orientation,
    );
    if body.is_static {
        return FreeMotion::stationary(start);
    }
    match s.segment {
        Segment::Ballistic => {
            let r = s.state.orientation.to_rotation_matrix();
            let angvel = r.matrix()
                * (body.inv_inertia_body * (r.matrix().transpose() * s.state.angular_momentum));
            FreeMotion {
                t0: s.time,
                start,
                linvel: s.state.linear_momentum * body.inv_mass,
                angvel,
                accel: *gravity,
            }
        }
        Segment::Stepped { linvel, angvel } => FreeMotion {
            t0: s.time,
            start,
            linvel,
            angvel,
            accel: Vector3::zeros(),
        },
    }
}

/// The state at time `t` of a body that left the saved state `s` (`t >= s.time`).
pub fn state_at(body: &RigidBody, s: &Saved, t: f64, gravity: &Vector3<f64>) -> State {
    if t == s.time || body.is_static {
        return s.state;
    }
    let m = motion_from(body, s, gravity);
    let pose = m.at(t);
    let linear_momentum = match s.segment {
        Segment::Ballistic => s.state.linear_momentum + gravity * (body.mass * (t - s.time)),
        Segment::Stepped { linvel, .. } => linvel * body.mass,
    };
    State {
        position: Point3::from(pose.translation.vector),
        orientation: pose.rotation,
        linear_momentum,
        angular_momentum: s.state.angular_momentum,
    }
}

/// A body's shape for queries, with its bounding radius (0 for a body that does not spin).
struct QueryShape {
    shape: SharedShape,
    radius: f64,
}

/// First time in `[from, to]` at which the two moving shapes come within `tolerance`, with
/// their distance then, by conservative advancement (Mirtich 1996, §2.3) extended to a
/// constant relative acceleration `a`: with `d` the distance at `t` and `μ` the bound
/// `|v_b(t) − v_a(t)| + |ω_a| r_a + |ω_b| r_b` on the approach speed at `t`, no surface point
/// can close the gap before `t + Δ` with `d = μ Δ + ½ |a| Δ²`, so advance to it and repeat.
///
/// Shapes already within `tolerance` at `from` count as an impact at `from` when they close
/// (the normal velocity at the closest points is negative); when they separate, the search
/// first steps past the touching phase.
#[allow(clippy::too_many_arguments)]
fn toi(
    a: &QueryShape,
    ma: &FreeMotion,
    b: &QueryShape,
    mb: &FreeMotion,
    from: f64,
    to: f64,
    settings: &TimewarpSettings,
    cost: &mut Cost,
) -> Option<(f64, f64)> {
    cost.toi_queries += 1;
    let tol = settings.toi_tolerance;
    let arel = (mb.accel - ma.accel).norm();
    let spin = |m: &FreeMotion, r: f64| {
        let w = m.angvel.norm();
        if w == 0.0 {
            0.0
        } else {
            w * r
        }
    };
    let spin = spin(ma, a.radius) + spin(mb, b.radius);
    let mut t = from;
    let mut first = true;
    for _ in 0..settings.max_toi_iterations {
        let (pa, pb) = (ma.at(t), mb.at(t));
        cost.distance_queries += 1;
        let d = parry3d_f64::query::distance(&pa, &*a.shape, &pb, &*b.shape).ok()?;
        let mu = (mb.velocity(t) - ma.velocity(t)).norm() + spin;
        if d <= tol {
            if !first {
                return Some((t, d));
            }
            // Touching at the start: an impact if closing, else step past the contact.
            cost.distance_queries += 1;
            let c = parry3d_f64::query::contact(&pa, &*a.shape, &pb, &*b.shape, tol.max(d) * 4.0)
                .ok()
                .flatten();
            let vn = c.map_or(0.0, |c| {
                let n = c.normal1.into_inner();
                n.dot(&(mb.point_velocity(t, &c.point2) - ma.point_velocity(t, &c.point1)))
            });
            if vn <= 0.0 {
                return Some((t, d));
            }
            if mu.is_nan() || mu <= 0.0 {
                return None;
            }
            t += (4.0 * tol).max(d) / mu;
            if t > to {
                return None;
            }
            continue;
        }
        first = false;
        let step = if arel == 0.0 {
            if mu.is_nan() || mu <= 0.0 {
                return None;
            }
            d / mu
        } else {
            2.0 * d / (mu + (mu * mu + 2.0 * arel * d).sqrt())
        };
        if !step.is_finite() {
            return None;
        }
        t += step;
        if t > to {
            return None;
        }
    }
    None
}

/// One body's record in a window: its local clock, saved states, and its impacts.
#[derive(Debug, Default)]
struct Track {
    clock: f64,
    saved: VecDeque<Saved>,
    version: u64,
    done: bool,
    events: usize,
    impacts: Vec<usize>,
}

/// An entry of the event queue, ordered by (local time, key) and popped smallest first.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    clock: f64,
    key: usize,
    body: usize,
    version: u64,
}

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: `BinaryHeap` is a max-heap.
        other
            .clock
            .total_cmp(&self.clock)
            .then(other.key.cmp(&self.key))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// An impact found in a window, alive until a rollback undoes it.
#[derive(Debug, Clone, Copy)]
struct Record {
    impact: Impact,
    alive: bool,
}

/// The free bodies of one frame, from `t0` to `t1`, among the static bodies.
pub(super) struct Window<'a> {
    world: &'a World,
    settings: &'a TimewarpSettings,
    gravity: Vector3<f64>,
    t0: f64,
    t1: f64,
    free: Vec<bool>,
    neighbours: Vec<Vec<usize>>,
    shapes: Vec<Option<QueryShape>>,
    tracks: Vec<Track>,
    heap: BinaryHeap<Entry>,
    log: Vec<Record>,
    pub(super) cost: Cost,
    /// Impacts whose sub-step the contact solver did not solve.
    pub(super) unsolved: usize,
}

impl<'a> Window<'a> {
    /// A window over `[t0, t0 + dt]` for the bodies marked `free`, with candidate partners
    /// `pairs` (from the broad phase on boxes swept over the frame).
    pub(super) fn new(
        world: &'a World,
        settings: &'a TimewarpSettings,
        free: Vec<bool>,
        pairs: &[(usize, usize)],
    ) -> Self {
        let n = world.bodies.len();
        let mut neighbours = vec![Vec::new(); n];
        let mut used = free.clone();
        for &(a, b) in pairs {
            let (sa, sb) = (world.bodies[a].is_static, world.bodies[b].is_static);
            if (free[a] || sa) && (free[b] || sb) && (free[a] || free[b]) {
                if free[a] {
                    neighbours[a].push(b);
                }
                if free[b] {
                    neighbours[b].push(a);
                }
                (used[a], used[b]) = (true, true);
            }
        }
        let shapes = world
            .bodies
            .iter()
            .zip(&used)
            .map(|(b, &u)| {
                u.then(|| QueryShape {
                    shape: b.shape.to_parry(),
                    radius: if b.is_static {
                        0.0
                    } else {
                        b.shape.bounding_radius()
                    },
                })
            })
            .collect();
        let t0 = world.time;
        let mut tracks: Vec<Track> = (0..n).map(|_| Track::default()).collect();
        let mut heap = BinaryHeap::new();
        for i in (0..n).filter(|&i| free[i]) {
            tracks[i].clock = t0;
            tracks[i].saved.push_back(Saved {
                time: t0,
                state: State::of(&world.bodies[i]),
                segment: Segment::Ballistic,
            });
            heap.push(Entry {
                clock: t0,
                key: key_of(settings.scheduling, i, n),
                body: i,
                version: 0,
            });
        }
        Self {
            world,
            settings,
            gravity: world.settings.gravity,
            t0,
            t1: t0 + world.settings.dt,
            free,
            neighbours,
            shapes,
            tracks,
            heap,
            log: Vec::new(),
            cost: Cost::default(),
            unsolved: 0,
        }
    }

    /// Run the window to its end; returns each free body's state at the end and the impacts,
    /// ordered by (time, bodies).
    pub(super) fn run(mut self) -> (Vec<(usize, State)>, Vec<Impact>, Cost, usize) {
        match self.settings.scheduling {
            Scheduling::Synchronous => self.run_synchronous(),
            _ => self.run_optimistic(),
        }
        let t1 = self.t1;
        let mut end = Vec::new();
        for i in (0..self.free.len()).filter(|&i| self.free[i]) {
            let last = *self.tracks[i]
                .saved
                .back()
                .expect("a free body keeps a saved state");
            end.push((i, state_at(&self.world.bodies[i], &last, t1, &self.gravity)));
        }
        let mut impacts: Vec<Impact> = self
            .log
            .iter()
            .filter(|r| r.alive)
            .map(|r| r.impact)
            .collect();
        impacts.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.bodies.cmp(&b.bodies)));
        (end, impacts, self.cost, self.unsolved)
    }

    /// Time Warp: the body with the earliest local clock (ties by key) advances as far as it
    /// can see: to the end of the frame or to its first impact with a static body or with a
    /// body whose saved states already cover the time. A body that finds an impact in the past
    /// of its partner rolls the partner back.
    fn run_optimistic(&mut self) {
        let mut pops = 0usize;
        let cap = self
            .settings
            .max_events_per_frame
            .saturating_mul(self.free.len().max(1));
        while let Some(e) = self.heap.pop() {
            let tr = &self.tracks[e.body];
            if tr.done || tr.version != e.version || tr.clock != e.clock {
                continue;
            }
            pops += 1;
            self.collect_fossils(e.body, e.clock);
            if pops > cap {
                self.land(e.body, None, e.clock);
                continue;
            }
            self.advance(e.body);
        }
    }

    /// Drop the saved states of `i` older than the global virtual time `gvt` (the smallest
    /// local clock: no rollback can reach before it), keeping the one in force at `gvt`.
    fn collect_fossils(&mut self, i: usize, gvt: f64) {
        let saved = &mut self.tracks[i].saved;
        while saved.len() >= 2 && saved[1].time <= gvt {
            saved.pop_front();
        }
    }

    /// The synchronous reference: all free bodies share one clock; the earliest impact of the
    /// frame is found among all candidate pairs, everyone advances to it, it is resolved, and
    /// the search repeats. No rollback can happen.
    fn run_synchronous(&mut self) {
        let n = self.free.len();
        let mut clock = self.t0;
        let cap = self.settings.max_events_per_frame.saturating_mul(n.max(1));
        for _ in 0..cap {
            let mut best: Option<(f64, usize, usize)> = None;
            for i in self.active() {
                let horizon = best.map_or(self.t1, |b| b.0);
                let mi = self.motion_of(i, clock);
                for k in 0..self.neighbours[i].len() {
                    let j = self.neighbours[i][k];
                    if self.free[j] && j < i && !self.tracks[j].done {
                        continue;
                    }
                    let horizon = best.map_or(horizon, |b| b.0);
                    if let Some((t, _)) = self.toi_with(i, &mi, clock, j, horizon, true) {
                        let cand = (t, i.min(j), i.max(j));
                        if best.is_none_or(|b| (cand.0, cand.1, cand.2) < b) {
                            best = Some(cand);
                        }
                    }
                }
            }
            let Some((t, a, b)) = best else {
                break;
            };
            for i in self.active() {
                self.tracks[i].clock = t;
            }
            let (i, j) = if self.free[a] { (a, b) } else { (b, a) };
            let after = self.resolve(i, j, t);
            // Everyone moves on to the time the impact's sub-step ended.
            for k in self.active() {
                self.tracks[k].clock = after;
            }
            clock = after;
        }
        for i in (0..n).filter(|&i| self.free[i]) {
            self.tracks[i].clock = self.t1;
            self.tracks[i].done = true;
        }
    }

    /// The free bodies still on their way, increasing.
    fn active(&self) -> Vec<usize> {
        (0..self.free.len())
            .filter(|&i| self.free[i] && !self.tracks[i].done)
            .collect()
    }

    /// The ballistic motion of free body `i` from its state at time `t`.
    fn motion_of(&self, i: usize, t: f64) -> FreeMotion {
        let body = &self.world.bodies[i];
        let last = self.tracks[i]
            .saved
            .back()
            .expect("a free body keeps a saved state");
        let s = Saved {
            time: t,
            state: state_at(body, last, t, &self.gravity),
            segment: last.segment,
        };
        motion_from(body, &s, &self.gravity)
    }

    /// The state of body `j` at time `t`: from its saved states if free, else as it is.
    fn state_of(&self, j: usize, t: f64) -> State {
        let body = &self.world.bodies[j];
        if !self.free[j] {
            return State::of(body);
        }
        let saved = &self.tracks[j].saved;
        let k = saved.iter().rposition(|s| s.time <= t).unwrap_or(0);
        state_at(body, &saved[k], t, &self.gravity)
    }

    /// First impact of free body `i` (moving with `mi` from `from`) with body `j` before `to`:
    /// against the saved trajectory of a free `j` up to its clock (and beyond it, ballistic,
    /// when `extrapolate`), or a static `j` where it is.
    fn toi_with(
        &mut self,
        i: usize,
        mi: &FreeMotion,
        from: f64,
        j: usize,
        to: f64,
        extrapolate: bool,
    ) -> Option<(f64, f64)> {
        let (Some(a), Some(b)) = (&self.shapes[i], &self.shapes[j]) else {
            return None;
        };
        let body_j = &self.world.bodies[j];
        if !self.free[j] {
            let mj = FreeMotion::stationary(body_j.iso());
            return toi(a, mi, b, &mj, from, to, self.settings, &mut self.cost);
        }
        let tr = &self.tracks[j];
        // A finished body's saved states cover the frame; a body still on its way is known up
        // to its clock, and beyond it only by extrapolation (the synchronous reference).
        let end = if extrapolate && !tr.done {
            to
        } else {
            tr.clock.min(to)
        };
        for k in 0..tr.saved.len() {
            let s = &tr.saved[k];
            let seg_end = tr.saved.get(k + 1).map_or(end, |n| n.time.min(end));
            let seg_start = s.time.max(from);
            if seg_end < seg_start || (seg_end == seg_start && k + 1 < tr.saved.len()) {
                continue;
            }
            let mj = motion_from(body_j, s, &self.gravity);
            if let Some(hit) = toi(
                a,
                mi,
                b,
                &mj,
                seg_start,
                seg_end,
                self.settings,
                &mut self.cost,
            ) {
                return Some(hit);
            }
        }
        None
    }

    /// Advance body `i` from its clock to its first event or to the end of the frame.
    fn advance(&mut self, i: usize) {
        let from = self.tracks[i].clock;
        let mi = self.motion_of(i, from);
        let mut best: Option<(f64, usize)> = None;
        for k in 0..self.neighbours[i].len() {
            let j = self.neighbours[i][k];
            let to = best.map_or(self.t1, |b| b.0);
            if let Some((t, _)) = self.toi_with(i, &mi, from, j, to, false) {
                if best.is_none_or(|b| (t, j) < b) {
                    best = Some((t, j));
                }
            }
        }
        let Some((t, j)) = best else {
            let tr = &mut self.tracks[i];
            tr.clock = self.t1;
            tr.done = true;
            return;
        };
        if self.free[j] && self.tracks[j].clock > t {
            self.rollback(j, t);
        }
        self.tracks[i].clock = t;
        self.resolve(i, j, t);
    }

    /// Roll body `j` back to time `t`, and every body whose impact with it after `t` is undone
    /// back to the time of that impact; each is queued to replay from there.
    fn rollback(&mut self, j: usize, t: f64) {
        let n = self.free.len();
        let mut stack = vec![(j, t)];
        while let Some((k, t)) = stack.pop() {
            if self.tracks[k].clock <= t {
                continue;
            }
            let tr = &mut self.tracks[k];
            let mut undone = 0;
            while tr.saved.len() > 1 && tr.saved.back().is_some_and(|s| s.time > t) {
                tr.saved.pop_back();
                undone += 1;
            }
            // Within a landing's group step the body keeps that step's velocities up to `t`
            // (the state an impact at `t` meets).
            self.cost.rollbacks += 1;
            self.cost.rolled_back_steps += undone + 1;
            tr.clock = t;
            tr.done = false;
            tr.version += 1;
            let entry = Entry {
                clock: t,
                key: key_of(self.settings.scheduling, k, n),
                body: k,
                version: tr.version,
            };
            let records = std::mem::take(&mut tr.impacts);
            let mut kept = Vec::with_capacity(records.len());
            for r in records {
                let rec = &mut self.log[r];
                if rec.alive && rec.impact.time >= t {
                    rec.alive = false;
                    let [a, b] = rec.impact.bodies;
                    let p = if a == k { b } else { a };
                    if p != k && self.free[p] {
                        stack.push((p, rec.impact.time));
                    }
                } else if rec.alive {
                    kept.push(r);
                }
            }
            self.tracks[k].impacts = kept;
            self.heap.push(entry);
        }
    }

    /// Resolve the impact of free body `i` with body `j` at time `t` (both states at `t`):
    /// one step of the scene's contact solver on the two bodies alone, of the length `h` over
    /// which the closing contact would close (so Newton's restitution applies), and both
    /// bodies restart from `t + h`. A pair that does not separate afterwards lands: a group
    /// step to the end of the frame. Returns `t + h`.
    fn resolve(&mut self, i: usize, j: usize, t: f64) -> f64 {
        let (lo, hi) = (i.min(j), i.max(j));
        let (sa, sb) = (self.state_of(lo, t), self.state_of(hi, t));
        let mut a = self.world.bodies[lo].clone();
        let mut b = self.world.bodies[hi].clone();
        sa.write(&mut a);
        sb.write(&mut b);
        let (qa, qb) = (
            self.shapes[lo].as_ref().map(|s| s.shape.clone()),
            self.shapes[hi].as_ref().map(|s| s.shape.clone()),
        );
        let tol = self.settings.toi_tolerance;
        let contact = match (&qa, &qb) {
            (Some(x), Some(y)) => {
                parry3d_f64::query::contact(&a.iso(), &**x, &b.iso(), &**y, 1e3 * tol + 1e-9)
                    .ok()
                    .flatten()
            }
            _ => None,
        };
        let normal_speed = |a: &RigidBody, b: &RigidBody| {
            contact.map_or(0.0, |c| {
                c.normal1
                    .dot(&(b.velocity_at(&c.point2) - a.velocity_at(&c.point1)))
            })
        };
        let vn = normal_speed(&a, &b);
        let gap = contact.map_or(0.0, |c| c.dist.max(0.0));
        let h = if vn < 0.0 {
            (gap + 4.0 * tol) / -vn
        } else {
            self.settings.min_impact_step
        }
        .clamp(self.settings.min_impact_step, self.settings.max_impact_step);
        let mut sub = self.sub_world(vec![a, b], h);
        let report = sub.step();
        self.cost.collision_queries += 1;
        if !report.status.is_converged() {
            self.unsolved += 1;
        }
        let after = t + h;
        let vn_after = normal_speed(&sub.bodies[0], &sub.bodies[1]);
        let record = self.log.len();
        self.log.push(Record {
            impact: Impact {
                time: t,
                bodies: [lo, hi],
                normal_speed: -vn,
            },
            alive: true,
        });
        for (k, body) in [(lo, &sub.bodies[0]), (hi, &sub.bodies[1])] {
            if !self.free[k] {
                continue;
            }
            let tr = &mut self.tracks[k];
            tr.saved.push_back(Saved {
                time: after,
                state: State::of(body),
                segment: Segment::Ballistic,
            });
            tr.clock = after;
            tr.events += 1;
            tr.impacts.push(record);
        }
        let threshold = self.world.settings.builder.restitution_threshold.max(1e-9);
        let exhausted = [lo, hi]
            .iter()
            .any(|&k| self.free[k] && self.tracks[k].events > self.settings.max_events_per_frame);
        if vn_after < threshold || exhausted {
            self.land(i, self.free[j].then_some(j), after);
        } else {
            for k in [lo, hi] {
                if self.free[k] {
                    self.requeue(k);
                }
            }
        }
        after
    }

    /// Queue body `k` at its clock.
    fn requeue(&mut self, k: usize) {
        let n = self.free.len();
        let tr = &mut self.tracks[k];
        tr.done = false;
        tr.version += 1;
        self.heap.push(Entry {
            clock: tr.clock,
            key: key_of(self.settings.scheduling, k, n),
            body: k,
            version: tr.version,
        });
    }

    /// Body `i` (with the free body `j`, if any) has come to rest on its partner: one group
    /// step of the scene's solver from `from` to the end of the frame (the next frame puts
    /// them in the contact group).
    fn land(&mut self, i: usize, j: Option<usize>, from: f64) {
        let members: Vec<usize> = match j {
            Some(j) => vec![i.min(j), i.max(j)],
            None => vec![i],
        };
        let h = self.t1 - from;
        if h > self.settings.min_impact_step {
            let bodies = members
                .iter()
                .map(|&k| {
                    let mut b = self.world.bodies[k].clone();
                    self.state_of(k, from).write(&mut b);
                    b
                })
                .collect();
            let mut sub = self.sub_world(bodies, h);
            sub.step();
            self.cost.collision_queries += 1;
            for (m, &k) in members.iter().enumerate() {
                let body = &sub.bodies[m];
                let state = self.state_of(k, from);
                let tr = &mut self.tracks[k];
                // The state at `from` with the group step's velocities, then its end.
                while tr.saved.back().is_some_and(|s| s.time >= from) && tr.saved.len() > 1 {
                    tr.saved.pop_back();
                }
                tr.saved.push_back(Saved {
                    time: from,
                    state,
                    segment: Segment::Stepped {
                        linvel: body.velocity(),
                        angvel: body.angular_velocity(),
                    },
                });
                tr.saved.push_back(Saved {
                    time: self.t1,
                    state: State::of(body),
                    segment: Segment::Ballistic,
                });
            }
        }
        for &k in &members {
            let tr = &mut self.tracks[k];
            tr.clock = self.t1;
            tr.done = true;
            tr.version += 1;
        }
    }

    /// A world of `bodies` (in increasing index order) with the scene's settings and a step of
    /// `h`.
    fn sub_world(&self, bodies: Vec<RigidBody>, h: f64) -> World {
        let mut settings = self.world.settings.clone();
        settings.dt = h;
        settings.ccd = None;
        World::new(bodies, self.world.materials.clone(), settings)
    }
}

/// The queue key of body `i` of `n` under `scheduling` (ties of local time are broken by it).
fn key_of(scheduling: Scheduling, i: usize, n: usize) -> usize {
    match scheduling {
        Scheduling::Descending => n - 1 - i,
        _ => i,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Shape;

    #[test]
    fn conservative_advancement_under_gravity_finds_the_analytic_time() {
        // A ball of radius 0.1 with its bottom 1 m above the plane z = 0 falls from rest:
        // contact at sqrt(2 / g).
        let g = Vector3::new(0.0, 0.0, -9.81);
        let ball = QueryShape {
            shape: Shape::sphere(0.1).unwrap().to_parry(),
            radius: 0.1,
        };
        let plane = QueryShape {
            shape: Shape::plane(Vector3::z()).unwrap().to_parry(),
            radius: 0.0,
        };
        let mb = FreeMotion {
            t0: 0.0,
            start: Isometry3::translation(0.0, 0.0, 1.1),
            linvel: Vector3::zeros(),
            angvel: Vector3::zeros(),
            accel: g,
        };
        let ma = FreeMotion::stationary(Isometry3::identity());
        let settings = TimewarpSettings::default();
        let mut cost = Cost::default();
        let (t, d) = toi(&plane, &ma, &ball, &mb, 0.0, 1.0, &settings, &mut cost).unwrap();
        assert!((t - (2.0 / 9.81f64).sqrt()).abs() < 1e-11, "{t}");
        assert!(d <= settings.toi_tolerance);
        assert!(cost.distance_queries < 10, "{cost:?}");
        // Before the impact there is none.
        assert!(toi(&plane, &ma, &ball, &mb, 0.0, 0.4, &settings, &mut cost).is_none());
    }

    #[test]
    fn state_at_is_exact_ballistic_translation() {
        let body = RigidBody::new(
            "b",
            Shape::sphere(0.1).unwrap(),
            crate::MassSpec::Mass(2.0),
            Point3::new(0.0, 0.0, 1.0),
            UnitQuaternion::identity(),
            Vector3::new(1.0, 0.0, 3.0),
            Vector3::zeros(),
            0,
            false,
        )
        .unwrap();
        let g = Vector3::new(0.0, 0.0, -10.0);
        let s = Saved {
            time: 1.0,
            state: State::of(&body),
            segment: Segment::Ballistic,
        };
        let x = state_at(&body, &s, 1.5, &g);
        assert!((x.position - Point3::new(0.5, 0.0, 1.0 + 1.5 - 1.25)).norm() < 1e-14);
        assert!((x.linear_momentum - Vector3::new(2.0, 0.0, -4.0)).norm() < 1e-14);
    }
}

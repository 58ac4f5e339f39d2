//! Timewarp stepping: bodies in free flight advance asynchronously from event to event, bodies
//! in contact are stepped together, and an event that reaches a body already past it rolls
//! that body back.
//!
//! B. Mirtich, "Timewarp rigid body simulation", SIGGRAPH 2000, applies D. Jefferson's
//! "Virtual time" (ACM TOPLAS 7(3), 1985) to rigid bodies. Here, each frame `[t, t + dt]`:
//!
//! 1. **classify** ([`Timewarp::step`]): the broad phase on boxes swept over the frame gives
//!    candidate pairs, the narrow phase their contacts; a dynamic body with a *resting*
//!    contact (gap at most [`TimewarpSettings::rest_gap`], normal speed at most the
//!    restitution threshold) is in the contact group, and so is every dynamic body whose swept
//!    box overlaps that of a group body (so a free body never meets a group body within the
//!    frame). The rest are free.
//! 2. **group step**: the group (with the static bodies, in scene order) takes one fixed step
//!    of the scene's solver on a persistent sub-[`World`], exactly as the fixed stepper would.
//!    Where everything touches (stacks) the group is the whole scene and Timewarp is the fixed
//!    step.
//! 3. **free flight** ([`free_flight`]): each free body has a local clock and saved states. The
//!    body with the earliest clock (ties by body index: the order never depends on hashing)
//!    advances to the end of the frame or to its first impact, found by conservative
//!    advancement under gravity against the static bodies and against the saved trajectories
//!    of the free bodies whose clocks are past it. An impact it finds in the past of its
//!    partner (a straggler, in Jefferson's terms) rolls the partner back to that time, and
//!    every body that partner hit since back to its own impact; they replay from there. An
//!    impact is resolved by one step of the scene's solver on the pair alone, of the length
//!    over which the contact closes (so Newton's restitution of the builder applies), and a
//!    pair that does not separate takes a group step to the end of the frame (the next frame
//!    puts it in the group). Saved states older than the global virtual time (the earliest
//!    clock, which no rollback can reach before) are dropped as bodies advance.
//!
//! The trajectory is sampled at the frame times, one [`StepReport`] per frame, so recordings,
//! replays and metrics read it like a fixed-step run.
//!
//! Limits: a scene with scheduled events or joints runs as one group, the fixed step
//! ([`Stepper::new`]); a free body sped up by
//! an impact beyond the speed its swept box was sized for is only re-paired at the next
//! frame; free-flight rotation is at constant angular velocity (exact for spheres).

mod free_flight;

pub use free_flight::{FreeMotion, Saved, Segment, State};

use crate::body::RigidBody;
use crate::collision::broad_phase::{candidate_pairs_with_boxes, world_aabb};
use crate::step::{StepReport, World};
use nalgebra::Vector3;
use parry3d_f64::bounding_volume::Aabb;
use serde::Serialize;
use std::time::Instant;

/// How the free bodies of a frame are scheduled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scheduling {
    /// Time Warp, ties of local time broken by increasing body index (the default).
    #[default]
    Ascending,
    /// Time Warp, ties broken by decreasing body index (a different processing order with the
    /// same result: for tests of determinism).
    Descending,
    /// The synchronous reference: every free body waits for the earliest impact of the frame
    /// (no rollback).
    Synchronous,
}

/// Settings of the Timewarp stepper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimewarpSettings {
    /// Distance at which two bodies count as touching, m \[`1e-12`\]: an impact is located to
    /// about this distance over the closing speed.
    pub toi_tolerance: f64,
    /// Distance queries of one time-of-impact search \[`10_000`\].
    pub max_toi_iterations: usize,
    /// Gap below which a contact can be resting, m \[`1e-4`\].
    pub rest_gap: f64,
    /// Shortest impact step, s \[`1e-15`\].
    pub min_impact_step: f64,
    /// Longest impact step, s \[`1e-6`\].
    pub max_impact_step: f64,
    /// Impacts of one body within one frame before it is stepped with the group to the end of
    /// the frame (a Zeno guard) \[`1000`\]. It also bounds the states a body saves within a
    /// frame (one per impact, two for a landing, and the frame's start).
    pub max_events_per_frame: usize,
    /// Processing order \[ascending\].
    pub scheduling: Scheduling,
}

impl Default for TimewarpSettings {
    fn default() -> Self {
        Self {
            toi_tolerance: 1e-12,
            max_toi_iterations: 10_000,
            rest_gap: 1e-4,
            min_impact_step: 1e-15,
            max_impact_step: 1e-6,
            max_events_per_frame: 1000,
            scheduling: Scheduling::Ascending,
        }
    }
}

/// An impact resolved in free flight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Impact {
    /// Time of impact, s.
    pub time: f64,
    /// The two bodies (indices into [`World::bodies`]), increasing.
    pub bodies: [usize; 2],
    /// Closing normal speed at the impact, m/s.
    pub normal_speed: f64,
}

/// Work counted by a stepping mode.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Cost {
    /// Narrow-phase pair queries (contact manifolds).
    pub collision_queries: u64,
    /// Pair time-of-impact searches.
    pub toi_queries: u64,
    /// Distance queries within them.
    pub distance_queries: u64,
    /// Rollbacks (one per body rolled back).
    pub rollbacks: u64,
    /// Body-steps undone by rollbacks: saved states dropped, plus the advance in progress.
    pub rolled_back_steps: u64,
}

impl Cost {
    /// Add `other`.
    pub fn add(&mut self, other: &Cost) {
        self.collision_queries += other.collision_queries;
        self.toi_queries += other.toi_queries;
        self.distance_queries += other.distance_queries;
        self.rollbacks += other.rollbacks;
        self.rolled_back_steps += other.rolled_back_steps;
    }
}

/// The contact group's persistent world and which scene bodies it holds.
struct Group {
    members: Vec<usize>,
    world: World,
}

/// A world stepped by Timewarp (see the module documentation).
pub struct Timewarp {
    /// The scene's world: its bodies are the states at the last frame time.
    pub world: World,
    /// Settings.
    pub settings: TimewarpSettings,
    group: Option<Group>,
    /// Impacts resolved in free flight so far, by time.
    pub impacts: Vec<Impact>,
    /// Work so far.
    pub cost: Cost,
    /// Impacts whose sub-step the contact solver did not solve to its tolerance.
    pub unsolved_impacts: usize,
}

impl Timewarp {
    /// Timewarp on `world` (no scheduled events, no joints: see [`Stepper::new`]).
    pub fn new(world: World, settings: TimewarpSettings) -> Self {
        Self {
            world,
            settings,
            group: None,
            impacts: Vec::new(),
            cost: Cost::default(),
            unsolved_impacts: 0,
        }
    }

    /// One frame: classify, step the contact group, run the free bodies to the frame's end.
    pub fn step(&mut self) -> StepReport {
        let start = Instant::now();
        let n = self.world.bodies.len();
        let (in_group, pairs) = self.classify();
        let classified = start.elapsed().as_secs_f64();
        let report = self.step_group(&in_group);
        let grouped = start.elapsed().as_secs_f64();
        let free: Vec<bool> = (0..n)
            .map(|i| !self.world.bodies[i].is_static && !in_group[i])
            .collect();
        if free.iter().any(|&f| f) {
            let window = free_flight::Window::new(&self.world, &self.settings, free, &pairs);
            let (end, impacts, cost, unsolved) = window.run();
            for (i, state) in end {
                state.write(&mut self.world.bodies[i]);
            }
            self.impacts.extend(impacts);
            self.cost.add(&cost);
            self.unsolved_impacts += unsolved;
        }
        self.world.step_index += 1;
        self.world.time += self.world.settings.dt;
        let total = start.elapsed().as_secs_f64();
        self.frame_report(report, classified, total - grouped)
    }

    /// Which dynamic bodies are in the contact group, and the candidate pairs of the frame.
    fn classify(&mut self) -> (Vec<bool>, Vec<(usize, usize)>) {
        let world = &mut self.world;
        let n = world.bodies.len();
        let s = &world.settings;
        let (dt, g, prediction) = (s.dt, s.gravity.norm(), s.prediction_distance);
        let margin = 0.5 * prediction;
        let everyone = || {
            (0..n)
                .map(|i| !world.bodies[i].is_static)
                .collect::<Vec<bool>>()
        };
        let pairs = match candidate_pairs_with_boxes(
            &world.bodies,
            |b| frame_box(b, dt, g, margin),
            margin,
        ) {
            Ok(p) => p,
            // Past the broad phase's limit: everything is one group, whose step says so.
            Err(_) => return (everyone(), Vec::new()),
        };
        self.cost.collision_queries += pairs.len() as u64;
        let contacts =
            match world
                .pipeline
                .narrow_phase_mut()
                .contacts(&world.bodies, &pairs, prediction)
            {
                Ok(c) => c,
                Err(_) => return (everyone(), pairs),
            };
        let v_rest = world.settings.builder.restitution_threshold.max(1e-9);
        let mut in_group = vec![false; n];
        for c in &contacts {
            let (a, b) = (&world.bodies[c.body_a], &world.bodies[c.body_b]);
            let vn = c
                .normal
                .dot(&(b.velocity_at(&c.point) - a.velocity_at(&c.point)));
            if c.dist <= self.settings.rest_gap && vn.abs() <= v_rest {
                in_group[c.body_a] |= !a.is_static;
                in_group[c.body_b] |= !b.is_static;
            }
        }
        // Closure: a dynamic body whose swept box meets a group body's joins the group.
        let mut adjacent = vec![Vec::new(); n];
        for &(a, b) in &pairs {
            if !world.bodies[a].is_static && !world.bodies[b].is_static {
                adjacent[a].push(b);
                adjacent[b].push(a);
            }
        }
        let mut stack: Vec<usize> = (0..n).filter(|&i| in_group[i]).collect();
        while let Some(i) = stack.pop() {
            for &j in &adjacent[i] {
                if !in_group[j] {
                    in_group[j] = true;
                    stack.push(j);
                }
            }
        }
        (in_group, pairs)
    }

    /// One fixed step of the group (with the static bodies), or of an empty world when there
    /// is no group (for the frame report's solver fields).
    fn step_group(&mut self, in_group: &[bool]) -> (StepReport, Vec<usize>) {
        let n = self.world.bodies.len();
        let members: Vec<usize> = (0..n)
            .filter(|&i| self.world.bodies[i].is_static || in_group[i])
            .collect();
        if !in_group.iter().any(|&g| g) {
            let mut empty = World::new(
                Vec::new(),
                self.world.materials.clone(),
                self.world.settings.clone(),
            );
            return (empty.step(), Vec::new());
        }
        let rebuild = self.group.as_ref().is_none_or(|g| g.members != members);
        if rebuild {
            let bodies = members
                .iter()
                .map(|&i| self.world.bodies[i].clone())
                .collect();
            let world = World::new(
                bodies,
                self.world.materials.clone(),
                self.world.settings.clone(),
            );
            self.group = Some(Group {
                members: members.clone(),
                world,
            });
        }
        let group = self.group.as_mut().expect("the group was just built");
        for (m, &i) in group.members.iter().enumerate() {
            State::of(&self.world.bodies[i]).write(&mut group.world.bodies[m]);
        }
        group.world.time = self.world.time;
        group.world.step_index = self.world.step_index;
        let report = group.world.step();
        for (m, &i) in group.members.iter().enumerate() {
            State::of(&group.world.bodies[m]).write(&mut self.world.bodies[i]);
        }
        (report, members)
    }

    /// The frame's report: the group step's solver and contact fields (contact body indices in
    /// scene numbering), the whole scene's energy and momenta, and the frame's wall time with
    /// classification counted as collision and free flight as integration.
    fn frame_report(
        &self,
        (mut report, members): (StepReport, Vec<usize>),
        classify_s: f64,
        free_s: f64,
    ) -> StepReport {
        for c in &mut report.contact_records {
            for k in &mut c.body_indices {
                *k = members.get(*k).copied().unwrap_or(*k);
            }
        }
        let g = self.world.settings.gravity;
        let (mut lin, mut ang) = (Vector3::zeros(), Vector3::zeros());
        let (mut ke, mut pe) = (0.0, 0.0);
        for b in self.world.bodies.iter().filter(|b| !b.is_static) {
            lin += b.linear_momentum;
            ang += b.position.coords.cross(&b.linear_momentum) + b.angular_momentum;
            ke += crate::integrate::kinetic_energy(b);
            pe += crate::integrate::potential_energy(b, &g);
        }
        report.step = self.world.step_index - 1;
        report.time = self.world.time;
        report.kinetic_energy = ke;
        report.potential_energy = pe;
        report.linear_momentum = lin.into();
        report.angular_momentum = ang.into();
        report.time_of_impact = None;
        report.phases.collision += classify_s;
        report.phases.integration += free_s;
        report.step_time_s = report.phases.total();
        report
    }
}

/// The box a body can reach within a frame of `dt` at its current speed under gravity `g`
/// (grown on every side, so a change of direction stays inside), plus `margin`.
fn frame_box(body: &RigidBody, dt: f64, g: f64, margin: f64) -> Aabb {
    if body.is_static {
        return world_aabb(body, margin);
    }
    let reach = (body.velocity().norm() + g * dt) * dt + margin;
    let grow = Vector3::repeat(reach);
    if body.angular_momentum == Vector3::zeros() {
        let b = body.shape.aabb(&body.iso());
        Aabb::new(b.mins - grow, b.maxs + grow)
    } else {
        let r = Vector3::repeat(body.shape.bounding_radius()) + grow;
        Aabb::new(body.position - r, body.position + r)
    }
}

/// How a scene is stepped: `fixed` (the [`World`] step, with its `ccd` setting) or
/// `timewarp`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stepping {
    /// Fixed steps \[default\].
    #[default]
    Fixed,
    /// [`Timewarp`].
    Timewarp,
}

impl Stepping {
    /// The setting of a scene file's `stepping` (or `--stepping`), or why not.
    pub fn from_name(name: &str) -> Result<Self, String> {
        match name {
            "fixed" => Ok(Self::Fixed),
            "timewarp" => Ok(Self::Timewarp),
            other => Err(format!(
                "unknown stepping \"{other}\" (expected \"fixed\" or \"timewarp\")"
            )),
        }
    }

    /// Its name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Fixed => "fixed",
            Self::Timewarp => "timewarp",
        }
    }
}

/// A world with its stepping mode.
pub enum Stepper {
    /// Fixed steps.
    Fixed(Box<World>),
    /// Timewarp.
    Timewarp(Box<Timewarp>),
}

impl Stepper {
    /// `world` stepped by `stepping`. On a scene with scheduled events or joints Timewarp
    /// falls back to one group, which is the fixed step (a joint ties its bodies' clocks
    /// together, and events are dated on the one clock): [`Stepper::one_group_reason`] says
    /// why.
    pub fn new(world: World, stepping: Stepping) -> Result<Self, String> {
        match stepping {
            Stepping::Fixed => Ok(Self::Fixed(Box::new(world))),
            Stepping::Timewarp if Self::one_group_reason(&world).is_some() => {
                Ok(Self::Fixed(Box::new(world)))
            }
            Stepping::Timewarp => Ok(Self::Timewarp(Box::new(Timewarp::new(
                world,
                TimewarpSettings::default(),
            )))),
        }
    }

    /// Why Timewarp runs `world` as one group (fixed steps): it has scheduled events or joints.
    pub fn one_group_reason(world: &World) -> Option<&'static str> {
        if !world.events.is_empty() {
            Some("the scene has scheduled events ([[events]]), dated on one clock")
        } else if !world.joints.is_empty() {
            Some("the scene has joints ([[joints]]), which tie their bodies' clocks together")
        } else {
            None
        }
    }

    /// One step (fixed) or frame (Timewarp).
    pub fn step(&mut self) -> StepReport {
        match self {
            Self::Fixed(w) => w.step(),
            Self::Timewarp(t) => t.step(),
        }
    }

    /// The world (bodies at the last step or frame).
    pub fn world(&self) -> &World {
        match self {
            Self::Fixed(w) => w,
            Self::Timewarp(t) => &t.world,
        }
    }

    /// The world, to change its settings.
    pub fn world_mut(&mut self) -> &mut World {
        match self {
            Self::Fixed(w) => w,
            Self::Timewarp(t) => &mut t.world,
        }
    }

    /// `fixed`, `bisection` or `conservative` (fixed steps with that continuous collision
    /// detection), or `timewarp`.
    pub fn mode_name(&self) -> &'static str {
        use crate::collision::toi::ToiMethod;
        match self {
            Self::Fixed(w) => match w.settings.ccd {
                None => "fixed",
                Some(ToiMethod::Bisection) => "bisection",
                Some(ToiMethod::ConservativeAdvancement) => "conservative",
            },
            Self::Timewarp(_) => "timewarp",
        }
    }
}

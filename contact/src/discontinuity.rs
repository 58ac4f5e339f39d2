//! Discontinuity metrics of a run, for every stepping mode (fixed steps, fixed steps with
//! bisection or conservative-advancement backtracking, Timewarp): how well the instant of each
//! impact is located and what it costs.
//!
//! * **Impact-time error**, on scenes whose spheres bounce alone on a plane
//!   (`[metrics] analytic_impacts = true`): each sphere's k-th impact against the k-th impact of
//!   [`bouncing_ball_impacts`]. Timewarp reports its impacts' times; the fixed-step modes are
//!   read off the trajectory: an impact is a step in which the upward velocity of a falling
//!   sphere rises by more than half its speed beyond what gravity gives, and its time is the
//!   start of that step (the time at which the step's contact impulse acts).
//! * **Energy error at each impact**: the sphere's mechanical energy `½ m |v|² + m g h`
//!   (`h` above its resting height) at the first sample after its k-th impact, against
//!   `e^{2k} E₀` (0 after an impact too slow to bounce), relative to `E₀`.
//! * **Penetration**: the deepest over the steps' contacts.
//! * **Tunnelling**: steps in which the centre of a body crossed another body from outside
//!   to outside (the segment between samples hits the other's shape at its later pose), or
//!   went from above a plane to below it.
//! * **Cost**: narrow-phase pair queries, time-of-impact pair searches, Timewarp's distance
//!   queries and rolled-back body-steps, wall time. For the fixed-step modes the pair counts
//!   are the broad phase's candidate pairs at each step's start, counted outside the timed
//!   step (the time-of-impact pairs on the boxes swept at the velocities before gravity's
//!   step).

use crate::body::RigidBody;
use crate::collision::broad_phase::{
    candidate_pairs_with_boxes, candidate_pairs_with_margin, sweep_and_prune_at_most, MAX_PAIRS,
};
use crate::collision::toi::swept_aabb;
use crate::shape::Shape;
use crate::step::{StepReport, World};
use crate::timewarp::Stepper;
use nalgebra::{Point3, Vector3};
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::query::Ray;
use serde::Serialize;

/// Analytic impact times of a ball dropped from rest with its lowest point `gap` above a plane,
/// under gravity `g`, with restitution `e` applied when the closing speed exceeds `threshold`
/// (the builder's rule), up to `horizon`: `t₁ = √(2 gap / g)` at speed `v₁ = g t₁`, then
/// `t_{k+1} = t_k + 2 e v_k / g`, `v_{k+1} = e v_k`, while `v_k > threshold`. The impact at
/// which `v_k <= threshold` is the last (the ball stays down). Returns `(time, bounced)` pairs.
pub fn bouncing_ball_impacts(
    gap: f64,
    g: f64,
    e: f64,
    threshold: f64,
    horizon: f64,
) -> Vec<(f64, bool)> {
    let mut out = Vec::new();
    if !(gap > 0.0 && g > 0.0) {
        return out;
    }
    let mut t = (2.0 * gap / g).sqrt();
    let mut v = g * t;
    while t <= horizon {
        let bounces = v > threshold && e > 0.0;
        out.push((t, bounces));
        if !bounces {
            break;
        }
        v *= e;
        t += 2.0 * v / g;
    }
    out
}

/// A sphere with analytic impacts.
#[derive(Debug, Clone)]
struct Ball {
    body: usize,
    impacts: Vec<(f64, bool)>,
    restitution: f64,
    rest_height: f64,
    energy0: f64,
    detected: Vec<f64>,
    energy_checked: usize,
    last_up_velocity: f64,
}

/// Collects the metrics over a run (see the module documentation).
pub struct DiscontinuityMeter {
    mode: &'static str,
    up: Vector3<f64>,
    g: f64,
    threshold: f64,
    balls: Vec<Ball>,
    ball_of: Vec<Option<usize>>,
    previous: Vec<Point3<f64>>,
    previous_time: f64,
    seen_impacts: usize,
    energy_errors: Vec<f64>,
    tunnelling: usize,
    unchecked_steps: usize,
    max_penetration: f64,
    collision_queries: u64,
    toi_queries: u64,
    wall_time_s: f64,
}

/// The metrics of a run.
#[derive(Debug, Clone, Serialize)]
pub struct DiscontinuityMetrics {
    /// `fixed`, `bisection`, `conservative` or `timewarp`.
    pub stepping: &'static str,
    /// Analytic impacts within the run.
    pub analytic_impacts: usize,
    /// Impacts found on the spheres with analytic impacts.
    pub detected_impacts: usize,
    /// Analytic impacts with no counterpart.
    pub missed_impacts: usize,
    /// Impacts beyond the analytic ones.
    pub extra_impacts: usize,
    /// Largest `|t_k − t_k^analytic|`, s.
    pub impact_time_error_max: Option<f64>,
    /// Mean of the same, s.
    pub impact_time_error_mean: Option<f64>,
    /// Largest relative energy error after an impact.
    pub energy_error_max: Option<f64>,
    /// Mean of the same.
    pub energy_error_mean: Option<f64>,
    /// Impacts Timewarp resolved in free flight (all bodies).
    pub recorded_impacts: Option<usize>,
    /// Deepest penetration over the steps, m.
    pub max_penetration: f64,
    /// Steps in which a body passed through another.
    pub tunnelling: usize,
    /// Steps whose tunnelling check was past the broad phase's pair limit (not checked).
    pub tunnelling_unchecked_steps: usize,
    /// Narrow-phase pair queries.
    pub collision_queries: u64,
    /// Time-of-impact pair searches.
    pub toi_queries: u64,
    /// Distance queries of those searches (Timewarp only).
    pub distance_queries: Option<u64>,
    /// Bodies rolled back (Timewarp).
    pub rollbacks: u64,
    /// Body-steps undone by rollbacks (Timewarp).
    pub rolled_back_steps: u64,
    /// Impacts whose contact solve did not converge (Timewarp).
    pub unsolved_impacts: usize,
    /// Wall time of the steps, s.
    pub wall_time_s: f64,
    /// The impacts the cost is divided by: the analytic ones, else Timewarp's recorded ones.
    pub impacts_for_cost: Option<usize>,
    /// `(collision_queries + toi_queries) / impacts_for_cost`.
    pub queries_per_impact: Option<f64>,
    /// `wall_time_s / impacts_for_cost`, s.
    pub wall_time_per_impact_s: Option<f64>,
}

impl DiscontinuityMeter {
    /// A meter for a run of `stepper` lasting `duration` seconds; `analytic` when the scene's
    /// spheres bounce alone (`[metrics] analytic_impacts`).
    pub fn new(stepper: &Stepper, analytic: bool, duration: f64) -> Self {
        let world = stepper.world();
        let s = &world.settings;
        let up = s.up();
        let g = s.gravity.norm();
        let threshold = s.builder.restitution_threshold;
        let n = world.bodies.len();
        let mut balls = Vec::new();
        let mut ball_of = vec![None; n];
        if analytic {
            for (i, b) in world.bodies.iter().enumerate() {
                if let Some(ball) = analytic_ball(world, i, b, up, g, threshold, duration) {
                    ball_of[i] = Some(balls.len());
                    balls.push(ball);
                }
            }
        }
        Self {
            mode: stepper.mode_name(),
            up,
            g,
            threshold,
            balls,
            ball_of,
            previous: world.bodies.iter().map(|b| b.position).collect(),
            previous_time: world.time,
            seen_impacts: 0,
            energy_errors: Vec::new(),
            tunnelling: 0,
            unchecked_steps: 0,
            max_penetration: 0.0,
            collision_queries: 0,
            toi_queries: 0,
            wall_time_s: 0.0,
        }
    }

    /// Count the fixed-step modes' pair queries of the coming step (Timewarp counts its own).
    pub fn before_step(&mut self, stepper: &Stepper) {
        let Stepper::Fixed(world) = stepper else {
            return;
        };
        let s = &world.settings;
        if let Ok(p) = candidate_pairs_with_margin(&world.bodies, s.prediction_distance) {
            self.collision_queries += p.len() as u64;
        }
        if s.ccd.is_some() {
            if let Ok(p) = candidate_pairs_with_boxes(&world.bodies, |b| swept_aabb(b, s.dt), 0.0) {
                self.toi_queries += p.len() as u64;
            }
        }
    }

    /// Observe the step or frame just taken.
    pub fn after_step(&mut self, stepper: &Stepper, report: &StepReport) {
        let world = stepper.world();
        self.wall_time_s += report.step_time_s;
        self.max_penetration = self.max_penetration.max(report.max_penetration);
        if let Stepper::Timewarp(tw) = stepper {
            for imp in &tw.impacts[self.seen_impacts..] {
                for &k in &imp.bodies {
                    if let Some(b) = self.ball_of.get(k).copied().flatten() {
                        self.balls[b].detected.push(imp.time);
                    }
                }
            }
            self.seen_impacts = tw.impacts.len();
        }
        let timewarp = matches!(stepper, Stepper::Timewarp(_));
        let dt = report.time - self.previous_time;
        for ball in &mut self.balls {
            let body = &world.bodies[ball.body];
            let v_up = body.velocity().dot(&self.up);
            if !timewarp {
                let rise = v_up - ball.last_up_velocity + self.g * dt;
                let falling = -ball.last_up_velocity;
                if falling > 0.5 * self.threshold && rise > 0.5 * falling {
                    ball.detected.push(self.previous_time);
                }
            }
            ball.last_up_velocity = v_up;
            let k = ball.detected.len();
            if k > ball.energy_checked && ball.energy0 > 0.0 {
                let height = body.position.coords.dot(&self.up) - ball.rest_height;
                let energy =
                    0.5 * body.mass * body.velocity().norm_squared() + body.mass * self.g * height;
                let expected = match ball.impacts.get(k - 1) {
                    Some(&(_, true)) => ball.energy0 * ball.restitution.powi(2 * k as i32),
                    Some(&(_, false)) => 0.0,
                    None => ball.energy0 * ball.restitution.powi(2 * k as i32),
                };
                self.energy_errors
                    .push((energy - expected).abs() / ball.energy0);
                ball.energy_checked = k;
            }
        }
        match tunnelled(world, &self.previous) {
            Some(k) => self.tunnelling += k,
            None => self.unchecked_steps += 1,
        }
        for (p, b) in self.previous.iter_mut().zip(&world.bodies) {
            *p = b.position;
        }
        self.previous_time = report.time;
    }

    /// The metrics of the run.
    pub fn finish(&self, stepper: &Stepper) -> DiscontinuityMetrics {
        let mut errors = Vec::new();
        let (mut analytic, mut detected, mut missed, mut extra) = (0, 0, 0, 0);
        for ball in &self.balls {
            analytic += ball.impacts.len();
            detected += ball.detected.len();
            let m = ball.impacts.len().min(ball.detected.len());
            missed += ball.impacts.len() - m;
            extra += ball.detected.len() - m;
            for k in 0..m {
                errors.push((ball.detected[k] - ball.impacts[k].0).abs());
            }
        }
        let max = |v: &[f64]| v.iter().copied().reduce(f64::max);
        let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
        let (mut collision, mut toi) = (self.collision_queries, self.toi_queries);
        let (mut distance, mut rollbacks, mut rolled, mut recorded, mut unsolved) =
            (None, 0, 0, None, 0);
        if let Stepper::Timewarp(tw) = stepper {
            collision += tw.cost.collision_queries;
            toi += tw.cost.toi_queries;
            distance = Some(tw.cost.distance_queries);
            rollbacks = tw.cost.rollbacks;
            rolled = tw.cost.rolled_back_steps;
            recorded = Some(tw.impacts.len());
            unsolved = tw.unsolved_impacts;
        }
        let impacts_for_cost = if analytic > 0 {
            Some(analytic)
        } else {
            recorded.filter(|&r| r > 0)
        };
        DiscontinuityMetrics {
            stepping: self.mode,
            analytic_impacts: analytic,
            detected_impacts: detected,
            missed_impacts: missed,
            extra_impacts: extra,
            impact_time_error_max: max(&errors),
            impact_time_error_mean: mean(&errors),
            energy_error_max: max(&self.energy_errors),
            energy_error_mean: mean(&self.energy_errors),
            recorded_impacts: recorded,
            max_penetration: self.max_penetration,
            tunnelling: self.tunnelling,
            tunnelling_unchecked_steps: self.unchecked_steps,
            collision_queries: collision,
            toi_queries: toi,
            distance_queries: distance,
            rollbacks,
            rolled_back_steps: rolled,
            unsolved_impacts: unsolved,
            wall_time_s: self.wall_time_s,
            impacts_for_cost,
            queries_per_impact: impacts_for_cost.map(|n| (collision + toi) as f64 / n as f64),
            wall_time_per_impact_s: impacts_for_cost.map(|n| self.wall_time_s / n as f64),
        }
    }
}

/// The analytic impacts of body `i` when it is a sphere at rest above an upward-facing static
/// plane.
fn analytic_ball(
    world: &World,
    i: usize,
    b: &RigidBody,
    up: Vector3<f64>,
    g: f64,
    threshold: f64,
    duration: f64,
) -> Option<Ball> {
    let Shape::Sphere { radius } = b.shape else {
        return None;
    };
    if b.is_static || b.velocity() != Vector3::zeros() || b.angular_momentum != Vector3::zeros() {
        return None;
    }
    let (plane, normal) = world.bodies.iter().find_map(|p| match &p.shape {
        Shape::Plane { normal } if p.is_static => {
            let n = p.orientation * normal.into_inner();
            (n.dot(&up) > 1.0 - 1e-12).then_some((p, n))
        }
        _ => None,
    })?;
    let rest_height = normal.dot(&plane.position.coords) + radius;
    let gap = b.position.coords.dot(&normal) - rest_height;
    let e = world
        .materials
        .get(b.material)
        .map_or(0.0, |m| m.restitution)
        .max(
            world
                .materials
                .get(plane.material)
                .map_or(0.0, |m| m.restitution),
        );
    let impacts = bouncing_ball_impacts(gap, g, e, threshold, duration);
    Some(Ball {
        body: i,
        impacts,
        restitution: e,
        rest_height,
        energy0: b.mass * g * gap,
        detected: Vec::new(),
        energy_checked: 0,
        last_up_velocity: 0.0,
    })
}

/// Steps' tunnelling count: bodies whose centre went from outside another body to outside it
/// through it between `previous` and the current positions, or from above a plane to below it.
/// `None` when the broad phase is past its pair limit.
fn tunnelled(world: &World, previous: &[Point3<f64>]) -> Option<usize> {
    let bodies = &world.bodies;
    let mut crossed = vec![false; bodies.len()];
    for plane in bodies.iter().filter(|p| p.is_static) {
        let Shape::Plane { normal } = &plane.shape else {
            continue;
        };
        let n = plane.orientation * normal.into_inner();
        for (i, b) in bodies.iter().enumerate().filter(|(_, b)| !b.is_static) {
            let (s0, s1) = (
                n.dot(&(previous[i] - plane.position)),
                n.dot(&(b.position - plane.position)),
            );
            crossed[i] |= s0 > 0.0 && s1 < 0.0;
        }
    }
    // Bounded shapes at their current poses, then the segments of the moving bodies.
    let bounded: Vec<usize> = (0..bodies.len())
        .filter(|&i| !matches!(bodies[i].shape, Shape::Plane { .. }))
        .collect();
    let moving: Vec<usize> = bounded
        .iter()
        .copied()
        .filter(|&i| !bodies[i].is_static && previous[i] != bodies[i].position)
        .collect();
    let mut boxes: Vec<Aabb> = bounded
        .iter()
        .map(|&i| bodies[i].shape.aabb(&bodies[i].iso()))
        .collect();
    for &i in &moving {
        let (p0, p1) = (previous[i], bodies[i].position);
        boxes.push(Aabb::new(p0.inf(&p1), p0.sup(&p1)));
    }
    let nb = bounded.len();
    let pairs = sweep_and_prune_at_most(&boxes, |a, b| (a < nb) == (b < nb), MAX_PAIRS).ok()?;
    for (a, b) in pairs {
        let (shape_k, seg_k) = if a < nb { (a, b - nb) } else { (b, a - nb) };
        let (j, i) = (bounded[shape_k], moving[seg_k]);
        if i == j || crossed[i] {
            continue;
        }
        let other = &bodies[j];
        let (p0, p1) = (previous[i], bodies[i].position);
        let shape = other.shape.to_parry();
        let iso = other.iso();
        if shape.contains_point(&iso, &p0) || shape.contains_point(&iso, &p1) {
            continue;
        }
        let ray = Ray::new(p0, p1 - p0);
        if shape.cast_ray(&iso, &ray, 1.0, true).is_some() {
            crossed[i] = true;
        }
    }
    Some(crossed.iter().filter(|&&c| c).count())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_impacts_follow_the_restitution_law() {
        let g = 9.81;
        let t = bouncing_ball_impacts(1.0, g, 0.5, 0.1, 10.0);
        let t1 = (2.0 / g).sqrt();
        assert!((t[0].0 - t1).abs() < 1e-15);
        // Second impact: up and down at half the speed.
        assert!((t[1].0 - (t1 + 2.0 * 0.5 * g * t1 / g)).abs() < 1e-12);
        // The speeds halve from 4.43 m/s: 2.21, 1.11, 0.55, 0.28, 0.14, 0.069 (<= 0.1: last).
        assert_eq!(t.len(), 7);
        assert!(t[..6].iter().all(|x| x.1) && !t[6].1);
        assert!(bouncing_ball_impacts(1.0, g, 0.5, 0.1, 0.1).is_empty());
    }
}

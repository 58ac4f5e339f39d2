//! Scene metrics: a [`SceneMetricsAccumulator`] watches each step of a scene run
//! ([`observe`](SceneMetricsAccumulator::observe)) and fills the scene columns of the row at the
//! end ([`finish`](SceneMetricsAccumulator::finish)).
//!
//! It is made of small accumulators, one per concern, so a new metric is one local change:
//!
//! * [`StepTotals`]: solver time, iterations, contacts, rows, residuals, penetration,
//!   friction-cone violation, non-converged, fallback and no-solution steps, the first
//!   non-converged status, and the cost counts (substeps, row updates and body passes per
//!   step, the step time without the residual phase, which LCP the residuals are of, the
//!   steps whose residual was measured and their mean time), and why each failed step failed
//!   ([`crate::harness::step_failure`]). Only a measured step is
//!   converged or not (`nonconverged_steps` counts measured steps; a residual schedule,
//!   `scene:PATH?residual=sample=K`, leaves the others unmeasured); an unmeasured step that
//!   gave up or ran out of time still counts in `fallback_steps` / `time_limit_steps` and keeps
//!   the run from `converged`;
//! * [`Stability`]: energy and momentum drift, largest speed, non-finite steps, lift-off at
//!   sliding contacts, and the blow-up test;
//! * [`Rest`]: creep speed, kinetic energy at rest and the support error of resting scenes;
//! * [`Trajectory`]: the analytic checks of the scene's `[metrics]` table;
//! * [`JointMetrics`]: joint drift (largest and mean joint error) and the drop of the scene's
//!   `sag_body`, on scenes with joints.
//!
//! A run *blows up* when, after a step, the state of a dynamic body is non-finite (position or
//! momenta) or the total energy is, or the largest body speed exceeds `50 + 10 v₀` m/s (`v₀` the
//! largest initial speed); stepping stops there and the row gets status `blow_up`.
//!
//! Scenes carry their analytic answers in the `[metrics]` table of the scene file, read once
//! into [`SceneMetrics`]; these keys are read (every one optional):
//!
//! | key                         | measured                                                        |
//! |-----------------------------|-----------------------------------------------------------------|
//! | `expected_top_height`       | sag (`expected − final z` of the highest body) and lateral drift of that body; marks a resting scene |
//! | `expected_rest_height`      | the same, for a single resting body                             |
//! | `expected_displacement`     | error of the first dynamic body's displacement; `0` marks rest  |
//! | `expected_acceleration`     | error of the first dynamic body's acceleration over the second half of the run; `0` marks sticking |
//! | `expected_rebound_height`   | error of the first rebound height of the first dynamic body     |
//! | `expected_wall_force`       | largest relative error of the contact forces at the last step, and the symmetry error between them |
//! | `simultaneous_velocities`, `sequential_velocities` | error of the final x-velocities of the dynamic bodies against the nearer of the two |
//! | `removed_at_step`           | largest body speed after that step (a removed body must not launch the rest) |
//! | `stick_bodies`              | names of bodies that must not creep (creep speed = their largest speed in the last tenth of the run) |
//! | `at_rest = true`            | marks a scene that should come to rest                          |
//! | `sag_body = "name"`         | largest drop of that body below its starting height (`sag_body` column) |
//! | `push_direction = [x, y, z]` | angle in degrees between the first dynamic body's displacement and this direction (the sliding-direction error of a pushed body: the box model's anisotropy) |
//!
//! For resting scenes the row also gets the creep speed (largest speed, of every dynamic body or
//! of the `stick_bodies`, in the last tenth of the run), the kinetic energy at rest (mean of the
//! total kinetic energy over the last tenth) and the support error (summed vertical contact force
//! on static bodies against the total weight, at the last step).

use crate::harness::record::{RunRecord, RunStatus};
use crate::harness::step_failure::{
    format_failed_steps, FailedStep, StepFailure, FAILED_STEPS_KEPT,
};
use crate::harness::timing::median;
use lcpbench_contact::body::RigidBody;
use lcpbench_contact::joint::JointMetrics;
use lcpbench_contact::step::{PhaseTimes, StepReport, World};
use lcpbench_contact::SceneMetrics;
use lcpbench_solvers::Status;
use nalgebra::{Point3, Vector3};

fn total_energy(world: &World) -> f64 {
    world
        .bodies
        .iter()
        .map(|b| {
            lcpbench_contact::integrate::kinetic_energy(b)
                + lcpbench_contact::integrate::potential_energy(b, &world.settings.gravity)
        })
        .sum()
}

fn dynamic(world: &World) -> impl Iterator<Item = &RigidBody> {
    world.bodies.iter().filter(|b| !b.is_static)
}

fn max_speed(world: &World) -> f64 {
    dynamic(world).fold(0.0, |m, b| m.max(b.velocity().norm()))
}

fn finite_state(world: &World) -> bool {
    dynamic(world).all(|b| {
        b.position.coords.iter().all(|v| v.is_finite())
            && b.linear_momentum.iter().all(|v| v.is_finite())
            && b.angular_momentum.iter().all(|v| v.is_finite())
    })
}

/// Position and velocity of the body called `name`.
fn state_of(world: &World, name: &str) -> Option<(Point3<f64>, Vector3<f64>)> {
    world
        .body_index(name)
        .map(|i| (world.bodies[i].position, world.bodies[i].velocity()))
}

/// Largest separating normal speed at sliding contacts after the step (m/s): the lift-off a
/// convex relaxation of Coulomb friction causes. Contacts whose impulse is zero, or that do not
/// slide (tangential speed below 1 mm/s), are skipped.
fn liftoff_speed(report: &StepReport, world: &World) -> f64 {
    let mut worst: f64 = 0.0;
    for c in &report.contact_records {
        let impulse = Vector3::from(c.impulse);
        if impulse.norm() == 0.0 {
            continue;
        }
        let n = Vector3::from(c.normal);
        let p = Point3::from(c.point);
        let vel = |i: usize| {
            world
                .bodies
                .get(i)
                .map_or_else(Vector3::zeros, |b| b.velocity_at(&p))
        };
        let rel = vel(c.body_indices[1]) - vel(c.body_indices[0]);
        let vn = rel.dot(&n);
        let slip = (rel - vn * n).norm();
        if slip > 1e-3 {
            worst = worst.max(vn);
        }
    }
    worst
}

/// Step time, the world's gravity direction and magnitude.
#[derive(Debug, Clone, Copy)]
struct Frame {
    dt: f64,
    g: f64,
    up: Vector3<f64>,
}

impl Frame {
    fn of(world: &World) -> Self {
        Self {
            dt: world.settings.dt,
            g: world.settings.gravity.norm(),
            up: world.settings.up(),
        }
    }
}

/// Largest, summed and counted residuals over the steps that had rows and residuals.
#[derive(Debug, Clone, Default)]
struct ResidualStats {
    rel_max: f64,
    rel_sum: f64,
    count: usize,
    abs_max: f64,
    gap_max: f64,
    bound_max: f64,
}

impl ResidualStats {
    fn observe(&mut self, res: &lcpbench_solvers::Residuals) {
        self.rel_max = self.rel_max.max(res.natural_map_rel);
        self.rel_sum += res.natural_map_rel;
        self.count += 1;
        self.abs_max = self.abs_max.max(res.natural_map);
        self.gap_max = self.gap_max.max(res.complementarity_gap);
        self.bound_max = self.bound_max.max(res.bound_violation);
    }

    fn finish(&self, r: &mut RunRecord) {
        if self.count > 0 {
            r.residual_rel = Some(self.rel_max);
            r.residual_rel_mean = Some(self.rel_sum / self.count as f64);
            r.residual_abs = Some(self.abs_max);
            r.complementarity_gap = Some(self.gap_max);
            r.bound_violation = Some(self.bound_max);
        }
    }
}

/// Totals over the step reports: time, iterations, sizes, residuals, penetration, statuses.
#[derive(Debug, Clone, Default)]
pub struct StepTotals {
    taken: usize,
    solve_time: f64,
    step_time: f64,
    iterations: usize,
    contacts: usize,
    contacts_max: usize,
    rows_max: usize,
    pen_max: f64,
    pen_sum: f64,
    cone: f64,
    residuals: ResidualStats,
    nonconverged: usize,
    /// Steps with contact rows, and those of them the solver declined as unsupported.
    solved: usize,
    unsupported: usize,
    fallbacks: usize,
    no_solution: usize,
    worst_status: Option<Status>,
    time_limits: usize,
    solve_wall_max: f64,
    /// Relative residual of each step with rows, for the median.
    step_residuals: Vec<f64>,
    phases: PhaseTimes,
    /// Substeps, row updates and body passes summed over the steps.
    substeps: usize,
    row_updates: u64,
    body_passes: u64,
    /// Which LCP the residuals are of, at the last step with rows (empty: the step's LCP).
    residual_of: String,
    /// Steps whose shared residual was measured (or that had no rows), and their wall time.
    measured: usize,
    measured_time: f64,
    /// The steps that did not converge and why (the `failed_steps` column).
    failed: Vec<FailedStep>,
}

impl StepTotals {
    fn observe(&mut self, report: &StepReport) {
        let step = self.taken;
        self.taken += 1;
        self.solve_time += report.solve_time_s;
        self.step_time += report.step_time_s;
        self.phases.add(&report.phases);
        self.substeps += report.substeps;
        self.row_updates += report.cost.row_updates;
        self.body_passes += report.cost.body_passes;
        self.solve_wall_max = self.solve_wall_max.max(report.solve_wall_s);
        self.iterations += report.iterations;
        self.contacts += report.contacts;
        self.contacts_max = self.contacts_max.max(report.contacts);
        self.rows_max = self.rows_max.max(report.rows);
        self.pen_max = self.pen_max.max(report.max_penetration);
        self.pen_sum += report.max_penetration;
        self.cone = self.cone.max(report.friction_cone_violation);
        if report.residual_measured {
            self.measured += 1;
            self.measured_time += report.step_time_s;
        }
        if report.rows == 0 {
            return;
        }
        self.solved += 1;
        self.residual_of = report.residual_of.clone().unwrap_or_default();
        if matches!(report.status, Status::Unsupported { .. }) {
            self.unsupported += 1;
        }
        if let Some(res) = &report.residuals {
            self.residuals.observe(res);
            self.step_residuals.push(res.natural_map_rel);
        }
        if report.status == Status::TimeLimit {
            self.time_limits += 1;
        }
        // Only a measured step is converged or not; an unmeasured one that gave up (or ran out
        // of time) still names the run's status and counts below (fallbacks, time limits).
        let gave_up = report.status == Status::TimeLimit
            || matches!(
                report.status,
                Status::Unsupported { .. }
                    | Status::NoSolution { .. }
                    | Status::Diverged { .. }
                    | Status::NumericalFailure { .. }
            );
        let measured_short = report.residual_measured && !report.status.is_converged();
        if measured_short {
            self.nonconverged += 1;
        }
        if measured_short || gave_up {
            if let Some(failure) = StepFailure::of(&report.status) {
                if self.failed.len() < FAILED_STEPS_KEPT {
                    self.failed.push(FailedStep {
                        step,
                        failure,
                        residual: report.residuals.as_ref().map(|r| r.natural_map_rel),
                        rows: report.rows,
                        contacts: report.contacts,
                    });
                }
            }
        }
        if (measured_short || gave_up) && self.worst_status.is_none() {
            self.worst_status = Some(report.status.clone());
        }
        if matches!(
            report.status,
            Status::Unsupported { .. }
                | Status::NoSolution { .. }
                | Status::Diverged { .. }
                | Status::NumericalFailure { .. }
        ) {
            // The solve gave up: the step applied no impulse or an unverified one.
            self.fallbacks += 1;
        }
        if matches!(
            report.status,
            Status::NoSolution { .. } | Status::Diverged { .. }
        ) {
            self.no_solution += 1;
        }
    }

    fn finish(&self, r: &mut RunRecord) {
        let n = self.taken.max(1) as f64;
        r.steps = Some(self.taken);
        r.n = Some(self.rows_max);
        r.iterations = Some(self.iterations);
        r.solve_time_s = Some(self.solve_time);
        r.contacts_mean = Some(self.contacts as f64 / n);
        r.contacts_max = Some(self.contacts_max);
        r.time_per_step_s = Some(self.solve_time / n);
        r.step_time_s = Some(self.step_time / n);
        r.iterations_per_step = Some(self.iterations as f64 / n);
        self.residuals.finish(r);
        r.nonconverged_steps = Some(self.nonconverged);
        r.fallback_steps = Some(self.fallbacks);
        r.no_solution_steps = Some(self.no_solution);
        r.penetration_max = Some(self.pen_max);
        r.penetration_mean = Some(self.pen_sum / n);
        r.cone_violation = Some(self.cone);
        r.time_limit_steps = Some(self.time_limits);
        r.solve_wall_max_s = Some(self.solve_wall_max);
        r.residual_rel_median = median(&self.step_residuals);
        let p = self.phases.scaled(1.0 / n);
        r.phase_collision_s = Some(p.collision);
        r.phase_broad_s = Some(p.broad_phase);
        r.phase_narrow_s = Some(p.narrow_phase);
        r.phase_assembly_s = Some(p.assembly);
        r.phase_islands_s = Some(p.islands);
        r.phase_solve_s = Some(p.solve);
        r.phase_residual_s = Some(p.residual);
        r.phase_integration_s = Some(p.integration);
        r.substeps_per_step = Some(self.substeps as f64 / n);
        r.row_updates_per_step = Some(self.row_updates as f64 / n);
        r.body_passes_per_step = Some(self.body_passes as f64 / n);
        r.step_time_no_residual_s = Some(((self.step_time - self.phases.residual) / n).max(0.0));
        r.residual_of = self.residual_of.clone();
        r.failed_steps = format_failed_steps(&self.failed);
        r.steps_measured = Some(self.measured);
        r.measured_step_time_s =
            (self.measured > 0).then(|| self.measured_time / self.measured as f64);
    }
}

/// Energy and momentum drift, speeds, non-finite steps, lift-off and the blow-up test.
#[derive(Debug, Clone)]
pub struct Stability {
    energy0: f64,
    energy_scale: f64,
    momentum0: Vector3<f64>,
    momentum_scale: f64,
    speed_limit: f64,
    speed_max: f64,
    nan_steps: usize,
    blow_up: bool,
    liftoff: f64,
}

impl Stability {
    fn new(world: &World, frame: &Frame) -> Self {
        let (g, up) = (frame.g, frame.up);
        let ke0: f64 = dynamic(world).map(|b| b.kinetic_energy()).sum();
        let energy_scale = dynamic(world)
            .map(|b| b.mass * g * b.position.coords.dot(&up).abs().max(1.0))
            .sum::<f64>()
            .max(ke0)
            .max(1e-12);
        let momentum_scale: f64 = dynamic(world)
            .map(|b| b.linear_momentum.norm())
            .sum::<f64>()
            .max(1e-12);
        Self {
            energy0: total_energy(world),
            energy_scale,
            momentum0: dynamic(world).map(|b| b.linear_momentum).sum(),
            momentum_scale,
            speed_limit: 50.0 + 10.0 * max_speed(world),
            speed_max: 0.0,
            nan_steps: 0,
            blow_up: false,
            liftoff: 0.0,
        }
    }

    /// Watch one step; `speed` is the largest body speed after it.
    fn observe(&mut self, report: &StepReport, world: &World, speed: f64) {
        let energy = report.kinetic_energy + report.potential_energy;
        let finite = energy.is_finite() && finite_state(world);
        if !finite {
            self.nan_steps += 1;
        }
        self.speed_max = self.speed_max.max(speed);
        if !finite || speed > self.speed_limit {
            self.blow_up = true;
        }
        self.liftoff = self.liftoff.max(liftoff_speed(report, world));
    }

    fn finish(&self, world: &World, frame: &Frame, r: &mut RunRecord) {
        r.nan_steps = Some(self.nan_steps);
        r.blow_up = Some(self.blow_up);
        r.energy_drift = Some((total_energy(world) - self.energy0) / self.energy_scale);
        if frame.g == 0.0 && world.bodies.iter().all(|b| !b.is_static) {
            let p: Vector3<f64> = dynamic(world).map(|b| b.linear_momentum).sum();
            r.momentum_drift = Some((p - self.momentum0).norm() / self.momentum_scale);
        }
        r.max_speed = Some(self.speed_max);
        r.liftoff_speed = Some(self.liftoff);
    }
}

/// Resting scenes: creep and kinetic energy over the last tenth of the run, support force at
/// the last step.
#[derive(Debug, Clone)]
pub struct Rest {
    resting: bool,
    stick_bodies: Vec<String>,
    tail_from: usize,
    weight: f64,
    creep: f64,
    ke_tail: f64,
    tail_n: usize,
}

impl Rest {
    fn new(world: &World, frame: &Frame, expect: &SceneMetrics, n_steps: usize) -> Self {
        Self {
            resting: expect.is_resting(),
            stick_bodies: expect.stick_bodies.clone().unwrap_or_default(),
            tail_from: n_steps - (n_steps / 10).max(1).min(n_steps),
            weight: dynamic(world).map(|b| b.mass * frame.g).sum(),
            creep: 0.0,
            ke_tail: 0.0,
            tail_n: 0,
        }
    }

    /// Watch step `k`; `speed` is the largest body speed after it.
    fn observe(&mut self, k: usize, report: &StepReport, world: &World, speed: f64) {
        if k < self.tail_from {
            return;
        }
        self.ke_tail += report.kinetic_energy;
        self.tail_n += 1;
        if self.resting {
            let s = if self.stick_bodies.is_empty() {
                speed
            } else {
                self.stick_bodies
                    .iter()
                    .filter_map(|n| state_of(world, n))
                    .fold(0.0f64, |m, (_, v)| m.max(v.norm()))
            };
            self.creep = self.creep.max(s);
        }
    }

    fn finish(&self, world: &World, last: Option<&StepReport>, frame: &Frame, r: &mut RunRecord) {
        if self.tail_n > 0 && self.resting {
            r.ke_rest = Some(self.ke_tail / self.tail_n as f64);
            r.creep_speed = Some(self.creep);
        }
        if let (true, true, Some(rep)) = (self.resting, self.weight > 0.0, last) {
            let support = support_force(world, rep, frame.up) / frame.dt;
            r.support_error = Some((support - self.weight).abs() / self.weight);
        }
    }
}

/// Summed impulse along `up` of the contacts between a static and a dynamic body.
fn support_force(world: &World, rep: &StepReport, up: Vector3<f64>) -> f64 {
    rep.contact_records
        .iter()
        .map(|c| {
            let on_static = |i: usize| world.bodies.get(i).is_some_and(|b| b.is_static);
            // The impulse acts on the second body; flip it when the static body is second.
            let j = Vector3::from(c.impulse).dot(&up);
            let [a, b] = c.body_indices;
            if on_static(a) && !on_static(b) {
                j
            } else if on_static(b) && !on_static(a) {
                -j
            } else {
                0.0
            }
        })
        .sum::<f64>()
}

/// The trajectory of the first and the top body, and the analytic checks against
/// [`SceneMetrics`].
#[derive(Debug, Clone)]
pub struct Trajectory {
    /// The first dynamic body and its initial position.
    first: Option<(String, Point3<f64>)>,
    /// The highest dynamic body at the start and its initial position.
    top: Option<(String, Point3<f64>)>,
    half: usize,
    min_height: f64,
    rebound_peak: f64,
    bounced: bool,
    mid_speed: Option<(f64, f64)>,
    removed_at: Option<usize>,
    after_removal: f64,
}

impl Trajectory {
    fn new(world: &World, frame: &Frame, expect: &SceneMetrics, n_steps: usize) -> Self {
        let up = frame.up;
        let top = world
            .bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| !b.is_static)
            .max_by(|a, b| {
                a.1.position
                    .coords
                    .dot(&up)
                    .total_cmp(&b.1.position.coords.dot(&up))
            })
            .map(|(_, b)| (b.name.clone(), b.position));
        Self {
            first: dynamic(world).next().map(|b| (b.name.clone(), b.position)),
            top,
            half: n_steps / 2,
            min_height: f64::INFINITY,
            rebound_peak: f64::NEG_INFINITY,
            bounced: false,
            mid_speed: None,
            removed_at: expect.removed_at_step,
            after_removal: 0.0,
        }
    }

    /// Watch step `k`; `speed` is the largest body speed after it.
    fn observe(&mut self, k: usize, world: &World, frame: &Frame, speed: f64) {
        if self.removed_at.is_some_and(|s| k >= s) {
            self.after_removal = self.after_removal.max(speed);
        }
        let Some((name, _)) = &self.first else {
            return;
        };
        let Some((p, v)) = state_of(world, name) else {
            return;
        };
        let h = p.coords.dot(&frame.up);
        self.min_height = self.min_height.min(h);
        if v.dot(&frame.up) > 0.0 && k > 0 {
            self.bounced = true;
        }
        if self.bounced {
            self.rebound_peak = self.rebound_peak.max(h);
        }
        if k + 1 == self.half {
            self.mid_speed = Some((v.norm(), world.time));
        }
    }

    fn finish(
        &self,
        world: &World,
        last: Option<&StepReport>,
        frame: &Frame,
        expect: &SceneMetrics,
        r: &mut RunRecord,
    ) {
        self.stack(world, frame, expect, r);
        let body = self
            .first
            .as_ref()
            .and_then(|(name, p0)| world.body_index(name).map(|i| (&world.bodies[i], *p0)));
        if let (Some(e), Some((b, p0))) = (expect.expected_displacement, body) {
            r.analytic_metric = "displacement (m)".into();
            r.analytic_error = Some(((b.position - p0).norm() - e).abs());
        }
        if let (Some(e), Some((b, _)), Some((v1, t1))) =
            (expect.expected_acceleration, body, self.mid_speed)
        {
            let (v2, t2) = (b.velocity().norm(), world.time);
            if t2 > t1 {
                r.analytic_metric = "acceleration (m/s²)".into();
                r.analytic_error = Some(((v2 - v1) / (t2 - t1) - e).abs());
            }
        }
        if let (Some(e), Some(rep)) = (expect.expected_wall_force, last) {
            wall_force(rep, e, frame.dt, r);
        }
        if let (Some([x, y, z]), Some((b, p0))) = (expect.push_direction, body) {
            slide_direction(Vector3::new(x, y, z), b.position - p0, r);
        }
        final_velocities(world, expect, r);
        if let Some(e) = expect.expected_rebound_height {
            if self.rebound_peak.is_finite() && self.min_height.is_finite() {
                r.analytic_metric = "rebound height".into();
                r.analytic_error = Some((self.rebound_peak - self.min_height - e).abs());
            }
        }
        if self.removed_at.is_some() {
            r.analytic_metric = "max speed after removal (m/s)".into();
            r.analytic_error = Some(self.after_removal);
        }
    }

    /// Stacks: sag and lateral drift of the top body.
    fn stack(&self, world: &World, frame: &Frame, expect: &SceneMetrics, r: &mut RunRecord) {
        let up = frame.up;
        if let (Some(h), Some((name, p0))) = (expect.expected_top(), &self.top) {
            if let Some((p, _)) = state_of(world, name) {
                r.sag = Some(h - p.coords.dot(&up));
                let d = p - p0;
                r.lateral_drift = Some((d - d.dot(&up) * up).norm());
            }
        }
    }
}

/// Largest relative error of the contact forces of the last step against `expected`, and the
/// symmetry error between the first two.
fn wall_force(rep: &StepReport, expected: f64, dt: f64, r: &mut RunRecord) {
    let forces: Vec<f64> = rep
        .contact_records
        .iter()
        .map(|c| Vector3::from(c.impulse).norm() / dt)
        .collect();
    if !forces.is_empty() && expected > 0.0 {
        let e = expected;
        r.analytic_metric = "wall force (relative)".into();
        r.analytic_error = Some(forces.iter().fold(0.0f64, |m, f| m.max((f - e).abs() / e)));
        if forces.len() >= 2 {
            r.symmetry_error = Some((forces[0] - forces[1]).abs() / e);
        }
    }
}

/// Angle in degrees between the displacement `d` and the push direction.
fn slide_direction(push: Vector3<f64>, d: Vector3<f64>, r: &mut RunRecord) {
    if push.norm() > 0.0 && d.norm() > 0.0 {
        let cos = (d.dot(&push) / (d.norm() * push.norm())).clamp(-1.0, 1.0);
        r.analytic_metric = "slide direction error (deg)".into();
        r.analytic_error = Some(cos.acos().to_degrees());
    }
}

/// Final x-velocities of the dynamic bodies against the nearer of the simultaneous and the
/// sequential answer.
fn final_velocities(world: &World, expect: &SceneMetrics, r: &mut RunRecord) {
    let sim = expect.simultaneous_velocities.as_deref();
    let seq = expect.sequential_velocities.as_deref();
    if sim.is_none() && seq.is_none() {
        return;
    }
    let v: Vec<f64> = dynamic(world).map(|b| b.velocity().x).collect();
    let err = |target: &[f64]| {
        (target.len() == v.len()).then(|| {
            v.iter()
                .zip(target)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        })
    };
    let (name, e) = match (sim.and_then(err), seq.and_then(err)) {
        (Some(a), Some(b)) if b < a => ("velocities vs sequential", b),
        (Some(a), _) => ("velocities vs simultaneous", a),
        (None, Some(b)) => ("velocities vs sequential", b),
        (None, None) => return,
    };
    r.analytic_metric = name.into();
    r.analytic_error = Some(e);
}

/// Why stepping stopped before the last step, if it did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStop {
    /// The run took every step (or blew up).
    No,
    /// The run's wall time passed its limit, seconds.
    RunLimit(f64),
    /// This many consecutive steps' solves ran out of their per-step budget, seconds.
    SlowSteps(usize, f64),
}

impl TimeStop {
    /// True when the run was cut short by time.
    pub fn stopped(&self) -> bool {
        *self != TimeStop::No
    }

    /// Where the run stopped, for the row's reason.
    fn describe(&self) -> String {
        match self {
            TimeStop::No => String::new(),
            TimeStop::RunLimit(s) => format!("at the run limit of {s} s"),
            TimeStop::SlowSteps(k, s) => {
                format!("after {k} consecutive steps over the per-step budget of {s} s")
            }
        }
    }
}

/// Every scene metric of one run: `observe` each step, then `finish` into the row.
#[derive(Debug, Clone)]
pub struct SceneMetricsAccumulator {
    expect: SceneMetrics,
    frame: Frame,
    n_steps: usize,
    totals: StepTotals,
    stability: Stability,
    rest: Rest,
    trajectory: Trajectory,
    joints: JointMetrics,
}

impl SceneMetricsAccumulator {
    /// Start measuring `world` (in its initial state) for a run of up to `n_steps` steps.
    pub fn new(world: &World, expect: SceneMetrics, n_steps: usize) -> Self {
        let frame = Frame::of(world);
        Self {
            frame,
            n_steps,
            totals: StepTotals::default(),
            stability: Stability::new(world, &frame),
            rest: Rest::new(world, &frame, &expect, n_steps),
            trajectory: Trajectory::new(world, &frame, &expect, n_steps),
            joints: JointMetrics::new(world, expect.sag_body.as_deref()),
            expect,
        }
    }

    /// Watch one step (`report`, and `world` after it). Returns `false` when the run blew up
    /// and stepping should stop.
    pub fn observe(&mut self, report: &StepReport, world: &World) -> bool {
        let k = self.totals.taken;
        self.totals.observe(report);
        let speed = max_speed(world);
        self.stability.observe(report, world, speed);
        self.rest.observe(k, report, world, speed);
        self.trajectory.observe(k, world, &self.frame, speed);
        self.joints.observe(report, world);
        !self.stability.blow_up
    }

    /// Fill the scene columns and the status of `r` from what was observed; `world` is the
    /// final state, `last` the last step's report.
    pub fn finish(
        &self,
        world: &World,
        last: Option<&StepReport>,
        time: TimeStop,
        r: &mut RunRecord,
    ) {
        r.steps_planned = Some(self.n_steps);
        self.totals.finish(r);
        self.stability.finish(world, &self.frame, r);
        self.rest.finish(world, last, &self.frame, r);
        self.trajectory
            .finish(world, last, &self.frame, &self.expect, r);
        let j = self.joints.summary();
        if j.joints > 0 {
            r.joint_drift_max = Some(j.drift_max);
            r.joint_drift_mean = Some(j.drift_mean);
            r.joint_angle_max = Some(j.angle_max);
        }
        r.sag_body = j.sag_max;
        self.status(time, r);
    }

    /// `blow_up`, `time_limit`, the first non-converged step's status, or `converged`; a run
    /// whose solver declined every step it was given is `unsupported` even when collision and
    /// assembly then ran out its time (its time says nothing of the solver).
    fn status(&self, time: TimeStop, r: &mut RunRecord) {
        let (taken, n_steps) = (self.totals.taken, self.n_steps);
        let nonconverged = self.totals.nonconverged;
        let blow_up = self.stability.blow_up;
        // Time limits and fallbacks are among the non-converged steps when every step is
        // measured; an unmeasured step's are not, and they too keep a run from converging.
        r.converged = nonconverged == 0
            && self.totals.fallbacks == 0
            && self.totals.time_limits == 0
            && !blow_up
            && !time.stopped()
            && self.stability.nan_steps == 0;
        if blow_up {
            r.status = RunStatus::BlowUp;
            r.reason = format!(
                "state non-finite or speed above {:.0} m/s at step {taken}",
                self.stability.speed_limit
            );
        } else if time.stopped()
            && self.totals.unsupported > 0
            && self.totals.unsupported == self.totals.solved
        {
            let s = self.totals.worst_status.as_ref();
            let why = s.and_then(|s| s.reason()).unwrap_or("unsupported");
            r.status = RunStatus::Unsupported;
            r.reason = format!(
                "all {} steps with contacts unsupported ({why}); stopped after {taken} of \
                 {n_steps} steps {}",
                self.totals.solved,
                time.describe()
            );
            r.reason.truncate(200);
        } else if time.stopped() {
            r.status = RunStatus::TimeLimit;
            r.reason = format!(
                "stopped after {taken} of {n_steps} steps {}",
                time.describe()
            );
        } else if let Some(s) = &self.totals.worst_status {
            r.status = RunStatus::from(s);
            let why = s.reason().map(|x| format!(": {x}")).unwrap_or_default();
            r.reason = if self.totals.measured < taken {
                format!(
                    "{nonconverged} of {} measured steps ({taken} taken) not converged, first {}{why}",
                    self.totals.measured,
                    s.name()
                )
            } else {
                format!(
                    "{nonconverged} of {taken} steps not converged, first {}{why}",
                    s.name()
                )
            };
            r.reason.truncate(200);
        } else {
            r.status = RunStatus::Converged;
        }
    }
}

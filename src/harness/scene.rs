//! Scene runs: step a scene with the chosen solver and aggregate the per-step
//! [`StepReport`]s into one row.
//!
//! The budget's tolerance and iteration cap replace the scene's per-step solver settings; the
//! run stops stepping after [`Budget::scene_time_limit`](crate::harness::Budget::scene_time_limit)
//! of wall time and is then recorded as `time_limit` with the steps it took. A plain solver
//! steps cold (no warm start across steps); `NAME+warm` warm-starts from the previous step's
//! impulses, as real-time engines do. A case key `scene:PATH?friction=MODEL` replaces the
//! scene's friction model (`cone` needs a cone solver, `nsgs-cone` or `newton-ac`); a solver
//! that does not take the model is recorded `unsupported` without stepping.
//!
//! Per-run metrics come from the step reports (solver time, iterations, residual, penetration,
//! energy, momenta, friction-cone violation) and from the body states between steps. Scenes
//! carry their analytic answers in the opaque `[metrics]` table of the scene file; the harness
//! reads these keys (every one optional):
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
//! | `stick_bodies`              | names of bodies that must not creep (creep speed = their largest final speed) |
//! | `at_rest = true`            | marks a scene that should come to rest                          |
//! | `push_direction = [x, y, z]` | angle in degrees between the first dynamic body's displacement and this direction (the sliding-direction error of a pushed body: the box model's anisotropy) |
//!
//! For resting scenes the row also gets the creep speed (largest speed in the last tenth of the
//! run), the kinetic energy at rest (mean over the last tenth) and the support error (summed
//! vertical contact force on static bodies against the total weight, at the last step).

use crate::harness::budget::{NamedBudget, SolverSpec};
use crate::harness::case::Case;
use crate::harness::run::{base_record, RunOutput};
use lcpbench_contact::body::RigidBody;
use lcpbench_contact::scene::{check_solver, Scene};
use lcpbench_contact::step::{StepReport, World};
use lcpbench_contact::SceneMetrics;
use lcpbench_solvers::{write_problem, Status};
use nalgebra::{Point3, Vector3};
use std::path::{Path, PathBuf};
use std::time::Instant;

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
        let vel = |name: &str| {
            world
                .body_index(name)
                .map(|i| world.bodies[i].velocity_at(&p))
                .unwrap_or_else(Vector3::zeros)
        };
        let rel = vel(&c.bodies[1]) - vel(&c.bodies[0]);
        let vn = rel.dot(&n);
        let slip = (rel - vn * n).norm();
        if slip > 1e-3 {
            worst = worst.max(vn);
        }
    }
    worst
}

/// Run a scene case in this process.
pub fn run_scene(case: &Case, spec: &SolverSpec, budget: &NamedBudget) -> RunOutput {
    let mut record = base_record(case, spec, budget);
    let out = |record| RunOutput {
        record,
        history: Vec::new(),
    };
    let Case::Scene {
        path,
        steps,
        friction,
    } = case
    else {
        record.status = "error".into();
        record.reason = "not a scene case".into();
        return out(record);
    };
    let mut scene = match Scene::load(path) {
        Ok(s) => s,
        Err(e) => {
            record.status = "error".into();
            record.reason = e.to_string();
            return out(record);
        }
    };
    if let Some(model) = friction {
        scene.settings.builder.friction_model = *model;
    }
    let Some(choice) = spec.scene_choice() else {
        record.status = "error".into();
        record.reason = "no solver".into();
        return out(record);
    };
    if let Err(reason) = check_solver(&choice, scene.settings.builder.friction_model) {
        record.status = "unsupported".into();
        record.reason = reason;
        return out(record);
    }
    let b = &budget.budget;
    scene.settings.solver = choice;
    scene.settings.tolerance = b.tolerance;
    scene.settings.max_iterations = b.max_iterations;
    scene.settings.warm_start = spec.warm;
    let n_steps = steps.map_or(scene.settings.steps, |s| s.min(scene.settings.steps));
    let mut world = scene.world();
    if let (Some(kind), Some(omega)) = (spec.kind, spec.omega) {
        debug_assert_eq!(kind, lcpbench_solvers::SolverKind::Sor);
        // The stepper creates solvers by kind; a non-default omega is not reachable from here.
        record.reason = format!("omega {omega} ignored in scenes (stepper uses sor@1.3)");
    }
    measure(
        &scene,
        &mut world,
        n_steps,
        b.scene_time_limit(),
        &mut record,
    );
    out(record)
}

/// Step `world` up to `n_steps` times (or until `time_limit` seconds) and fill the row.
fn measure(scene: &Scene, world: &mut World, n_steps: usize, time_limit: f64, r: &mut RunRecord) {
    let metrics = &scene.metrics;
    let dt = world.settings.dt;
    let g = world.settings.gravity.norm();
    let up = if g > 0.0 {
        -world.settings.gravity / g
    } else {
        Vector3::z()
    };
    let energy0 = total_energy(world);
    let ke0: f64 = dynamic(world).map(|b| b.kinetic_energy()).sum();
    let weight: f64 = dynamic(world).map(|b| b.mass * g).sum();
    let energy_scale = dynamic(world)
        .map(|b| b.mass * g * b.position.coords.dot(&up).abs().max(1.0))
        .sum::<f64>()
        .max(ke0)
        .max(1e-12);
    let momentum0: Vector3<f64> = dynamic(world).map(|b| b.linear_momentum).sum();
    let momentum_scale: f64 = dynamic(world)
        .map(|b| b.linear_momentum.norm())
        .sum::<f64>()
        .max(1e-12);
    let speed0 = max_speed(world);
    let speed_limit = 50.0 + 10.0 * speed0;
    // The top body: highest dynamic body at the start.
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
    let first = dynamic(world).next().map(|b| (b.name.clone(), b.position));
    let position_of = |world: &World, name: &str| {
        world
            .body_index(name)
            .map(|i| (world.bodies[i].position, world.bodies[i].velocity()))
    };
    let expected_accel = metrics.expected_acceleration;
    let resting = metrics.expected_top_height.is_some()
        || metrics.expected_rest_height.is_some()
        || metrics.expected_displacement == Some(0.0)
        || expected_accel == Some(0.0)
        || metrics.at_rest == Some(true);
    let removed_at = metrics.removed_at_step;
    let stick_bodies = metrics.stick_bodies.clone().unwrap_or_default();

    let tail_from = n_steps - (n_steps / 10).max(1).min(n_steps);
    let start = Instant::now();
    let (mut solve_time, mut step_time) = (0.0, 0.0);
    let (mut iterations, mut contacts, mut rows_max, mut contacts_max) = (0usize, 0usize, 0, 0);
    let (mut res_max, mut res_sum, mut res_count): (f64, f64, usize) = (0.0, 0.0, 0);
    let (mut res_abs, mut gap, mut bound): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let (mut pen_max, mut pen_sum): (f64, f64) = (0.0, 0.0);
    let (mut nonconverged, mut nan_steps, mut fallbacks) = (0usize, 0usize, 0usize);
    let (mut cone, mut liftoff, mut speed_max): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let (mut creep, mut ke_tail, mut tail_n): (f64, f64, usize) = (0.0, 0.0, 0);
    let mut after_removal: f64 = 0.0;
    let mut worst_status: Option<Status> = None;
    let mut blow_up = false;
    let mut taken = 0;
    let mut last: Option<StepReport> = None;
    let (mut min_height, mut rebound_peak, mut bounced) = (f64::INFINITY, f64::NEG_INFINITY, false);
    let mut mid_speed: Option<(f64, f64)> = None;
    let mut stopped_by_time = false;
    for k in 0..n_steps {
        if start.elapsed().as_secs_f64() > time_limit {
            stopped_by_time = true;
            break;
        }
        let report = world.step();
        taken += 1;
        solve_time += report.solve_time_s;
        step_time += report.step_time_s;
        iterations += report.iterations;
        contacts += report.contacts;
        contacts_max = contacts_max.max(report.contacts);
        rows_max = rows_max.max(report.rows);
        pen_max = pen_max.max(report.max_penetration);
        pen_sum += report.max_penetration;
        cone = cone.max(report.friction_cone_violation);
        if report.rows > 0 {
            if let Some(res) = report.residuals {
                res_max = res_max.max(res.natural_map_rel);
                res_sum += res.natural_map_rel;
                res_count += 1;
                res_abs = res_abs.max(res.natural_map);
                gap = gap.max(res.complementarity_gap);
                bound = bound.max(res.bound_violation);
            }
            if !report.status.is_converged() {
                nonconverged += 1;
                if worst_status.is_none() {
                    worst_status = Some(report.status.clone());
                }
            }
            if matches!(
                report.status,
                Status::Unsupported { .. }
                    | Status::NoSolution { .. }
                    | Status::NumericalFailure { .. }
            ) {
                // The stepper replaced the impulse by zero.
                fallbacks += 1;
            }
        }
        let energy = report.kinetic_energy + report.potential_energy;
        let finite = energy.is_finite() && finite_state(world);
        if !finite {
            nan_steps += 1;
        }
        let speed = max_speed(world);
        speed_max = speed_max.max(speed);
        if !finite || speed > speed_limit {
            blow_up = true;
        }
        liftoff = liftoff.max(liftoff_speed(&report, world));
        if removed_at.is_some_and(|s| k >= s) {
            after_removal = after_removal.max(speed);
        }
        if k >= tail_from {
            ke_tail += report.kinetic_energy;
            tail_n += 1;
            if resting {
                let s = if stick_bodies.is_empty() {
                    speed
                } else {
                    stick_bodies
                        .iter()
                        .filter_map(|n| position_of(world, n))
                        .fold(0.0f64, |m, (_, v)| m.max(v.norm()))
                };
                creep = creep.max(s);
            }
        }
        if let Some((name, _)) = &first {
            if let Some((p, v)) = position_of(world, name) {
                let h = p.coords.dot(&up);
                min_height = min_height.min(h);
                if v.dot(&up) > 0.0 && k > 0 {
                    bounced = true;
                }
                if bounced {
                    rebound_peak = rebound_peak.max(h);
                }
                if k + 1 == n_steps / 2 {
                    mid_speed = Some((v.norm(), world.time));
                }
            }
        }
        if blow_up {
            last = Some(report);
            break;
        }
        last = Some(report);
    }
    let n = taken.max(1) as f64;
    r.steps = Some(taken);
    r.n = Some(rows_max);
    r.iterations = Some(iterations);
    r.solve_time_s = Some(solve_time);
    r.contacts_mean = Some(contacts as f64 / n);
    r.contacts_max = Some(contacts_max);
    r.time_per_step_s = Some(solve_time / n);
    r.step_time_s = Some(step_time / n);
    r.iterations_per_step = Some(iterations as f64 / n);
    if res_count > 0 {
        r.residual_rel = Some(res_max);
        r.residual_rel_mean = Some(res_sum / res_count as f64);
        r.residual_abs = Some(res_abs);
        r.complementarity_gap = Some(gap);
        r.bound_violation = Some(bound);
    }
    r.nonconverged_steps = Some(nonconverged);
    r.nan_steps = Some(nan_steps);
    r.fallback_steps = Some(fallbacks);
    r.blow_up = Some(blow_up);
    r.penetration_max = Some(pen_max);
    r.penetration_mean = Some(pen_sum / n);
    r.energy_drift = Some((total_energy(world) - energy0) / energy_scale);
    if g == 0.0 && world.bodies.iter().all(|b| !b.is_static) {
        let p: Vector3<f64> = dynamic(world).map(|b| b.linear_momentum).sum();
        r.momentum_drift = Some((p - momentum0).norm() / momentum_scale);
    }
    r.max_speed = Some(speed_max);
    r.cone_violation = Some(cone);
    r.liftoff_speed = Some(liftoff);
    if tail_n > 0 && resting {
        r.ke_rest = Some(ke_tail / tail_n as f64);
        r.creep_speed = Some(creep);
    }
    // Stacks: sag and lateral drift of the top body.
    let expected_top = metrics.expected_top_height.or(metrics.expected_rest_height);
    if let (Some(h), Some((name, p0))) = (expected_top, &top) {
        if let Some((p, _)) = position_of(world, name) {
            r.sag = Some(h - p.coords.dot(&up));
            let d = p - p0;
            r.lateral_drift = Some((d - d.dot(&up) * up).norm());
        }
    }
    // Support force against the weight.
    if resting && weight > 0.0 {
        if let Some(rep) = &last {
            let support: f64 = rep
                .contact_records
                .iter()
                .map(|c| {
                    let on_static = |name: &str| {
                        world
                            .body_index(name)
                            .is_some_and(|i| world.bodies[i].is_static)
                    };
                    // The impulse acts on the second body; flip it when the static body is second.
                    let j = Vector3::from(c.impulse).dot(&up);
                    if on_static(&c.bodies[0]) && !on_static(&c.bodies[1]) {
                        j
                    } else if on_static(&c.bodies[1]) && !on_static(&c.bodies[0]) {
                        -j
                    } else {
                        0.0
                    }
                })
                .sum::<f64>()
                / dt;
            r.support_error = Some((support - weight).abs() / weight);
        }
    }
    analytic(
        metrics,
        world,
        r,
        &first,
        expected_accel,
        mid_speed,
        last.as_ref(),
        dt,
    );
    if let Some(e) = metrics.expected_rebound_height {
        if rebound_peak.is_finite() && min_height.is_finite() {
            r.analytic_metric = "rebound height".into();
            r.analytic_error = Some((rebound_peak - min_height - e).abs());
        }
    }
    if removed_at.is_some() {
        r.analytic_metric = "max speed after removal (m/s)".into();
        r.analytic_error = Some(after_removal);
    }
    // Status.
    r.converged = nonconverged == 0 && !blow_up && !stopped_by_time && nan_steps == 0;
    if blow_up {
        r.status = "blow_up".into();
        r.reason = format!("state non-finite or speed above {speed_limit:.0} m/s at step {taken}");
    } else if stopped_by_time {
        r.status = "time_limit".into();
        r.reason = format!("stopped after {taken} of {n_steps} steps ({time_limit:.0} s)");
    } else if let Some(s) = worst_status {
        r.status = s.name().into();
        let why = s.reason().map(|x| format!(": {x}")).unwrap_or_default();
        r.reason = format!(
            "{nonconverged} of {taken} steps not converged, first {}{why}",
            s.name()
        );
        r.reason.truncate(200);
    } else {
        r.status = "converged".into();
    }
}

use crate::harness::record::RunRecord;

#[allow(clippy::too_many_arguments)]
fn analytic(
    metrics: &SceneMetrics,
    world: &World,
    r: &mut RunRecord,
    first: &Option<(String, Point3<f64>)>,
    expected_accel: Option<f64>,
    mid_speed: Option<(f64, f64)>,
    last: Option<&StepReport>,
    dt: f64,
) {
    let body = first
        .as_ref()
        .and_then(|(name, p0)| world.body_index(name).map(|i| (&world.bodies[i], *p0)));
    if let (Some(e), Some((b, p0))) = (metrics.expected_displacement, body) {
        r.analytic_metric = "displacement (m)".into();
        r.analytic_error = Some(((b.position - p0).norm() - e).abs());
    }
    if let (Some(e), Some((b, _)), Some((v1, t1))) = (expected_accel, body, mid_speed) {
        let (v2, t2) = (b.velocity().norm(), world.time);
        if t2 > t1 {
            r.analytic_metric = "acceleration (m/s²)".into();
            r.analytic_error = Some(((v2 - v1) / (t2 - t1) - e).abs());
        }
    }
    if let (Some(e), Some(rep)) = (metrics.expected_wall_force, last) {
        let forces: Vec<f64> = rep
            .contact_records
            .iter()
            .map(|c| Vector3::from(c.impulse).norm() / dt)
            .collect();
        if !forces.is_empty() && e > 0.0 {
            r.analytic_metric = "wall force (relative)".into();
            r.analytic_error = Some(forces.iter().fold(0.0f64, |m, f| m.max((f - e).abs() / e)));
            if forces.len() >= 2 {
                r.symmetry_error = Some((forces[0] - forces[1]).abs() / e);
            }
        }
    }
    let push = metrics.push_direction.map(|d| d.to_vec());
    if let (Some(&[x, y, z]), Some((b, p0))) = (push.as_deref(), body) {
        let push = Vector3::new(x, y, z);
        let d = b.position - p0;
        if push.norm() > 0.0 && d.norm() > 0.0 {
            let cos = (d.dot(&push) / (d.norm() * push.norm())).clamp(-1.0, 1.0);
            r.analytic_metric = "slide direction error (deg)".into();
            r.analytic_error = Some(cos.acos().to_degrees());
        }
    }
    let sim = metrics.simultaneous_velocities.clone();
    let seq = metrics.sequential_velocities.clone();
    if sim.is_some() || seq.is_some() {
        let v: Vec<f64> = dynamic(world).map(|b| b.velocity().x).collect();
        let err = |target: &[f64]| {
            (target.len() == v.len()).then(|| {
                v.iter()
                    .zip(target)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            })
        };
        let e_sim = sim.as_deref().and_then(err);
        let e_seq = seq.as_deref().and_then(err);
        let (name, e) = match (e_sim, e_seq) {
            (Some(a), Some(b)) if b < a => ("velocities vs sequential", b),
            (Some(a), _) => ("velocities vs simultaneous", a),
            (None, Some(b)) => ("velocities vs sequential", b),
            (None, None) => return,
        };
        r.analytic_metric = name.into();
        r.analytic_error = Some(e);
    }
}

/// Export one LCP per scene into `dir` (the step halfway through the run, at most step 30,
/// simulated with the scene's own solver), skipping scenes with more than `max_bodies` dynamic
/// bodies, scenes without contacts at that step and LCPs above `max_rows` rows. Returns the
/// files written.
pub fn export_suite_lcps(
    scenes: &[PathBuf],
    dir: &Path,
    max_rows: usize,
    max_bodies: usize,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    if scenes.is_empty() {
        return Ok(out);
    }
    std::fs::create_dir_all(dir)?;
    for path in scenes {
        let Ok(scene) = Scene::load(path) else {
            continue;
        };
        if scene.bodies.iter().filter(|b| !b.is_static).count() > max_bodies {
            continue;
        }
        let k = (scene.settings.steps / 2).min(30);
        let mut world = scene.world();
        for _ in 0..k {
            world.step();
        }
        world.settings.keep_problem = true;
        let report = world.step();
        let Some(problem) = report.problem else {
            continue;
        };
        if problem.n() == 0 || problem.n() > max_rows {
            continue;
        }
        let problem = problem.with_name(format!("{} step {k}", scene.name));
        let file = dir.join(format!("{}_step{k}.json", scene.name));
        write_problem(&problem, &file)?;
        out.push(file);
    }
    Ok(out)
}

//! The exact Coulomb cone (`friction_model = "cone"`) through the whole pipeline: sliding
//! directions, the incline's analytic answers, agreement of the two cone solvers, and the
//! `Unsupported` status of solvers that do not take the model.

use lcpbench_contact::builder::FrictionModel;
use lcpbench_contact::{ContactSolver, Scene, World};
use lcpbench_solvers::Status;
use nalgebra::Vector3;
use std::path::PathBuf;

const G: f64 = 9.81;
const CONE_SOLVERS: [&str; 2] = ["nsgs-cone", "newton-ac"];

fn scene(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench_scenes")
        .join(format!("{name}.toml"));
    Scene::load(path).unwrap_or_else(|e| panic!("{e}"))
}

/// A world of `scene` with friction model `model` and solver `solver`.
fn world(scene: &Scene, model: FrictionModel, solver: &str) -> World {
    let mut w = scene.world();
    w.settings.builder.friction_model = model;
    w.set_solver(ContactSolver::from_name(solver).expect("known solver"));
    w
}

fn box_state(w: &World) -> (Vector3<f64>, Vector3<f64>) {
    let b = &w.bodies[w.body_index("box").expect("a body named box")];
    (b.position.coords, b.velocity())
}

/// Angle in degrees between two vectors.
fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    (a.dot(b) / (a.norm() * b.norm()))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Runs `diagonal_push` for 1 s: the angle between the push and the box's displacement, and
/// its acceleration over the last half second. Every step must converge.
fn diagonal_push(model: FrictionModel, solver: &str) -> (f64, f64) {
    let s = scene("diagonal_push");
    let mut w = world(&s, model, solver);
    let (p0, _) = box_state(&w);
    let push = Vector3::new(30f64.to_radians().cos(), 30f64.to_radians().sin(), 0.0);
    for r in w.run(50) {
        assert!(
            r.status.is_converged(),
            "{solver}: step {}: {:?}",
            r.step,
            r.status
        );
    }
    let (_, v0) = box_state(&w);
    for r in w.run(50) {
        assert!(
            r.status.is_converged(),
            "{solver}: step {}: {:?}",
            r.step,
            r.status
        );
    }
    let (p1, v1) = box_state(&w);
    let a = (v1 - v0).norm() / (50.0 * s.settings.dt);
    (angle_deg(&(p1 - p0), &push), a)
}

#[test]
fn a_box_pushed_diagonally_slides_along_the_push_with_the_cone() {
    // Coulomb: the friction force opposes the sliding velocity with magnitude mu m g.
    let expected = 4.0 - 0.3 * G;
    let mut accelerations = Vec::new();
    for solver in CONE_SOLVERS {
        let (angle, a) = diagonal_push(FrictionModel::Cone, solver);
        println!("diagonal push, cone ({solver}): off the push by {angle:.3e}°, a = {a:.6} m/s²");
        assert!(angle < 1e-3, "{solver}: slides {angle}° off the push");
        assert!(
            (a - expected).abs() < 1e-3 * expected,
            "{solver}: a = {a}, expected {expected}"
        );
        accelerations.push(a);
    }
    assert!((accelerations[0] - accelerations[1]).abs() < 1e-6);
}

#[test]
fn a_box_pushed_diagonally_deviates_with_the_box_model() {
    // Each tangent component is bounded by mu f_n alone: the y part of the push (2 m/s²) is
    // held, so the box slides along x, 30° off the push, at 4 cos 30° − mu g.
    let (angle, a) = diagonal_push(FrictionModel::Box, "pgs");
    let expected = 4.0 * 30f64.to_radians().cos() - 0.3 * G;
    println!("diagonal push, box (pgs): off the push by {angle:.3}°, a = {a:.6} m/s²");
    assert!(
        (angle - 30.0).abs() < 0.1,
        "box model: {angle}° off the push"
    );
    assert!((a - expected).abs() < 1e-3 * expected, "a = {a}");
}

/// Displacement along the slope direction `(cos θ, 0, −sin θ)` and the speed along it.
fn along_slope(w: &World) -> (f64, f64) {
    let th = 30f64.to_radians();
    let s = Vector3::new(th.cos(), 0.0, -th.sin());
    let (p, v) = box_state(w);
    (p.dot(&s), v.dot(&s))
}

#[test]
fn a_block_on_an_incline_sticks_below_and_slides_above_the_friction_angle() {
    let th = 30f64.to_radians();
    let expected = G * (th.sin() - 0.3 * th.cos());
    for solver in CONE_SOLVERS {
        // mu = 0.7 > tan 30°: sticks.
        let s = scene("incline_stick");
        let mut w = world(&s, FrictionModel::Cone, solver);
        let (x0, _) = along_slope(&w);
        let reports = w.run(s.settings.steps);
        let (x, v) = along_slope(&w);
        println!(
            "incline mu = 0.7, cone ({solver}): slid {:.3e} m, speed {v:.3e}",
            x - x0
        );
        assert!(reports.iter().all(|r| r.status.is_converged()), "{solver}");
        assert!(
            (x - x0).abs() < 1e-6 && v.abs() < 1e-6,
            "{solver}: slid {}",
            x - x0
        );

        // mu = 0.3 < tan 30°: slides with g (sin θ − mu cos θ).
        let s = scene("incline_slide");
        let mut w = world(&s, FrictionModel::Cone, solver);
        w.run(50);
        let (_, v0) = along_slope(&w);
        let reports = w.run(150);
        let (_, v1) = along_slope(&w);
        let a = (v1 - v0) / (150.0 * s.settings.dt);
        let err = (a - expected).abs() / expected;
        println!("incline mu = 0.3, cone ({solver}): a = {a:.6}, relative error {err:.3e}");
        assert!(reports.iter().all(|r| r.status.is_converged()), "{solver}");
        assert!(err < 1e-6, "{solver}: a = {a}, expected {expected}");
    }
}

#[test]
fn the_cone_steps_report_the_cone_residual_and_islands_match_the_whole() {
    // friction_ramp: five boxes, five islands solved in parallel.
    let s = scene("friction_ramp");
    let mut split = world(&s, FrictionModel::Cone, "nsgs-cone");
    let mut whole = world(&s, FrictionModel::Cone, "nsgs-cone");
    whole.settings.islands = false;
    for _ in 0..40 {
        let (a, b) = (split.step(), whole.step());
        assert!(a.islands > 1 || a.contacts == 0);
        for r in [&a, &b] {
            assert!(r.status.is_converged(), "step {}: {:?}", r.step, r.status);
            let res = r.residuals.expect("cone residual measured");
            assert!(res.natural_map_rel <= s.settings.tolerance);
            // The impulses lie in the cone (to round-off).
            assert!(
                r.friction_cone_violation < 1e-12,
                "{}",
                r.friction_cone_violation
            );
        }
    }
    for (a, b) in split.bodies.iter().zip(&whole.bodies) {
        assert!((a.position - b.position).norm() < 1e-7, "{}", a.name);
    }
}

#[test]
fn solvers_that_do_not_take_the_model_report_unsupported() {
    let s = scene("incline_slide");
    // The refusal names every cone solver, as the registry lists them.
    let cone_solvers = format!(
        "cone solver ({})",
        lcpbench_solvers::ConeSolverKind::names()
    );
    for (model, solver, needle) in [
        (FrictionModel::Cone, "pgs", cone_solvers.as_str()),
        (FrictionModel::Cone, "si", "cone solver"),
        (
            FrictionModel::Box,
            "nsgs-cone",
            "friction_model \"cone\" only",
        ),
        (
            FrictionModel::Pyramid { directions: 4 },
            "newton-ac",
            "\"pyramid\"",
        ),
    ] {
        let mut w = world(&s, model, solver);
        let r = w.step();
        match &r.status {
            Status::Unsupported { reason } => {
                assert!(reason.contains(needle), "{solver}: {reason}")
            }
            other => panic!("{solver} on {}: {other:?}", model.name()),
        }
    }
}

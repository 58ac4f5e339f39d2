//! `xpbd` (extended position-based dynamics with small steps) against analytic answers: a box
//! resting on the ground, a box on an incline sticking and sliding, a pendulum's period, a
//! static chain's joint impulses, a compliant contact's overlap; and its warm start, its
//! determinism, its `@params` specification and the honesty of its status. Each test prints
//! what it measured (`cargo test --test substep_xpbd -- --nocapture`).

use lcpbench_contact::builder::{self, BuilderParams, FrictionModel, Material};
use lcpbench_contact::substep::{SubstepInput, Xpbd};
use lcpbench_contact::{
    BodySolverKind, Contact, ContactSolver, MassSpec, RigidBody, Scene, Shape, World,
};
use lcpbench_solvers::Settings;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use std::path::PathBuf;

mod common;
use common::inline;

const G: f64 = 9.81;

fn scene(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench_scenes")
        .join(format!("{name}.toml"));
    Scene::load(path).unwrap_or_else(|e| panic!("{e}"))
}

/// A world of `scene` solved by the body solver specification `spec` (`xpbd@key=value,…`).
fn world(scene: &Scene, spec: &str) -> World {
    let (kind, params) = BodySolverKind::parse_spec(spec)
        .unwrap_or_else(|e| panic!("{e}"))
        .expect("a body solver");
    let mut w = scene.world();
    w.set_solver(ContactSolver::Body(kind.create_with(params)));
    w
}

fn index(w: &World, name: &str) -> usize {
    w.body_index(name)
        .unwrap_or_else(|| panic!("no body {name}"))
}

/// Largest displacement and rotation of the dynamic bodies from `initial`.
fn drift(w: &World, initial: &[RigidBody]) -> (f64, f64) {
    let (mut dx, mut da): (f64, f64) = (0.0, 0.0);
    for (b, b0) in w.bodies.iter().zip(initial).filter(|(_, b)| !b.is_static) {
        dx = dx.max((b.position - b0.position).norm());
        da = da.max(b.orientation.angle_to(&b0.orientation));
    }
    (dx, da)
}

#[test]
fn box_rests_on_the_ground_for_5_s() {
    let s = scene("box_on_ground");
    let mut w = world(&s, "xpbd");
    let initial = w.bodies.clone();
    let reports = w.run(500);
    let (dx, da) = drift(&w, &initial);
    let pen = reports
        .iter()
        .map(|r| r.max_penetration)
        .fold(0.0, f64::max);
    let speed = w.bodies[index(&w, "box")].velocity().norm();
    println!(
        "box on ground (xpbd, 5 s): drift {dx:.3e} m, rotation {da:.3e} rad, max penetration \
         {pen:.3e} m, final speed {speed:.3e} m/s"
    );
    // One Gauss–Seidel pass a substep on four coupled contacts (normals first, then
    // friction): measured 4e-7 m and 8e-7 rad.
    assert!(dx < 1e-5 && da < 1e-5, "drift {dx:e}, rotation {da:e}");
    assert!(pen < 1e-5, "penetration {pen:e}");
    assert!(speed < 1e-6, "speed {speed:e}");
    for r in &reports {
        assert_eq!(r.substeps, 20);
        assert_eq!(r.iterations, 40, "20 position and 20 velocity passes");
        assert!(r.cost.row_updates > 0 && r.cost.body_passes == 60);
    }
}

/// Displacement of the box along the slope direction `s = (cos θ, 0, −sin θ)` and its speed.
fn along_slope(w: &World) -> (f64, f64) {
    let th = 30f64.to_radians();
    let s = Vector3::new(th.cos(), 0.0, -th.sin());
    let b = &w.bodies[index(w, "box")];
    (b.position.coords.dot(&s), b.velocity().dot(&s))
}

/// Distance slid along the incline of `name` in `steps` and the final speed along it.
fn slid(name: &str, spec: &str, steps: usize) -> (f64, f64) {
    let s = scene(name);
    let mut w = world(&s, spec);
    let (x0, _) = along_slope(&w);
    w.run(steps);
    let (x, v) = along_slope(&w);
    (x - x0, v)
}

#[test]
fn box_sticks_on_an_incline_with_mu_0_7() {
    // One pass a substep leaves a creep of first order in the substep (measured: 1.6e-4 m in
    // 2 s at 20 substeps, 5.3e-5 m at 60), far below the 2 m a frictionless box would slide.
    let (x, v) = slid("incline_stick", "xpbd", 200);
    let (x60, v60) = slid("incline_stick", "xpbd@substeps=60", 200);
    println!(
        "incline mu = 0.7 (xpbd): slid {x:.3e} m in 2 s, speed {v:.3e} m/s; 60 substeps: \
         {x60:.3e} m, {v60:.3e} m/s"
    );
    assert!(x.abs() < 5e-4 && v.abs() < 2e-4, "slid {x}, speed {v}");
    assert!(
        x60.abs() < 0.5 * x.abs(),
        "creep shrinks with the substep: {x60} vs {x}"
    );
}

#[test]
fn box_slides_on_an_incline_with_mu_0_3() {
    let th = 30f64.to_radians();
    let expected = G * (th.sin() - 0.3 * th.cos());
    let s = scene("incline_slide");
    let mut w = world(&s, "xpbd");
    w.run(50);
    let (_, v0) = along_slope(&w);
    w.run(150);
    let (_, v1) = along_slope(&w);
    let a = (v1 - v0) / (150.0 * s.settings.dt);
    let err = (a - expected).abs() / expected;
    println!(
        "incline mu = 0.3 (xpbd): acceleration {a:.6} m/s², expected {expected:.6}, relative \
         error {err:.3e}"
    );
    assert!(err < 1e-6, "a = {a}");
}

/// A simple pendulum: a 1 kg ball on a massless rod (distance joint) of `length` from a pivot
/// at `z = 2`, started `degrees` from the vertical.
fn pendulum(length: f64, degrees: f64, dt: f64) -> Scene {
    let th = degrees.to_radians();
    let (x, z) = (length * th.sin(), 2.0 - length * th.cos());
    inline(&format!(
        r#"
        [settings]
        dt = {dt}
        friction_model = "none"
        tolerance = 1e-10
        max_iterations = 10000
        [[bodies]]
        name = "bob"
        shape = {{ type = "sphere", radius = 0.05 }}
        mass = 1.0
        position = [{x}, 0.0, {z}]
        [[joints]]
        type = "distance"
        bodies = ["world", "bob"]
        anchors = [[0.0, 0.0, 2.0], [{x}, 0.0, {z}]]
        "#
    ))
}

#[test]
fn pendulum_period_matches_the_analytic_one() {
    let (length, deg, dt) = (1.0, 5.0, 0.01);
    let th0 = f64::to_radians(deg);
    // Small-amplitude period with the first finite-amplitude correction (a point mass: the
    // ball's own inertia is not turned by a distance joint).
    let exact = 2.0 * std::f64::consts::PI * (length / G).sqrt() * (1.0 + th0 * th0 / 16.0);
    let s = pendulum(length, deg, dt);
    let mut w = world(&s, "xpbd");
    let mut crossings = Vec::new();
    let mut prev = w.bodies[0].position.x;
    let mut drift: f64 = 0.0;
    for _ in 0..1000 {
        let r = w.step();
        drift = drift.max(r.joint_drift_max);
        let x = w.bodies[0].position.x;
        if prev < 0.0 && x >= 0.0 {
            crossings.push(w.time - dt * x / (x - prev));
        }
        prev = x;
    }
    assert!(crossings.len() >= 2, "{} crossings", crossings.len());
    let period = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    let err = (period - exact).abs() / exact;
    println!(
        "pendulum (xpbd, dt {dt}, 20 substeps): period {period:.6} s, expected {exact:.6} s, \
         relative error {err:.3e}, largest rod error {drift:.3e} m"
    );
    assert!(err < 1e-3, "period {period}");
    assert!(drift < 1e-4, "rod error {drift}");
}

/// Largest relative error of the joints' impulses of the last step against the weight below
/// each joint times the step, and the chain's largest joint drift.
fn chain_errors(w: &mut World, links: usize, end: f64, steps: usize) -> (f64, f64) {
    let reports = w.run(steps);
    let last = reports.last().expect("steps");
    assert_eq!(last.joint_rows, 3 * (links + 1));
    let mut err: f64 = 0.0;
    for (k, joint) in last.joint_records.iter().enumerate() {
        let expected = ((links - k) as f64 + end) * G * w.settings.dt;
        err = err.max((joint.impulse - expected).abs() / expected);
    }
    (err, last.joint_drift_max)
}

#[test]
fn static_chain_joints_carry_the_weight_below_them() {
    // One pass a substep on a 20:1 chain does not converge: the chain stretches (5.9e-5 m at
    // the worst joint), and its oscillation from the start decays over about 2 s; at rest each
    // body's gravity displacement is undone exactly, so the impulses are the weights.
    let (links, end) = (5, 20.0);
    let s = hanging_chain(links, end);
    let mut w = world(&s, "xpbd");
    let (err, drift) = chain_errors(&mut w, links, end, 300);
    println!(
        "static chain (xpbd, after 3 s): joint impulse relative error {err:.3e}, drift {drift:.3e} m"
    );
    assert!(err < 1e-6, "{err}");
    assert!(drift < 1e-4, "{drift}");
}

#[test]
fn the_warm_start_is_exact_on_contacts_and_diverges_on_a_chain() {
    // `warm=1` applies the previous substep's (and step's) multipliers first: on a box's four
    // contacts rest becomes a fixed point (drift 1e-13 m, against 4e-7 m from zero
    // multipliers).
    let s = scene("box_on_ground");
    let mut w = world(&s, "xpbd@warm=1");
    let initial = w.bodies.clone();
    let reports = w.run(500);
    let (dx, da) = drift(&w, &initial);
    let (x, v) = slid("incline_stick", "xpbd@warm=1", 200);
    println!("warm start (xpbd): box drift {dx:.3e} m, rotation {da:.3e} rad; incline slid {x:.3e} m, speed {v:.3e} m/s");
    assert!(dx < 1e-9 && da < 1e-6, "drift {dx}, rotation {da}");
    assert!(x.abs() < 1e-5 && v.abs() < 1e-6, "slid {x}");
    // At rest the step's impulse (summed over its substeps) is the weight times the step.
    let last = reports.last().expect("steps");
    let normal: f64 = last.contact_records.iter().map(|c| c.normal_impulse).sum();
    let weight = w.bodies[index(&w, "box")].mass * G * s.settings.dt;
    assert!(
        (normal - weight).abs() < 1e-9 * weight,
        "{normal} vs {weight}"
    );
    // On the 20:1 chain the same warm start is momentum on the solver's error (module doc):
    // the chain blows up within steps, where zero multipliers keep it together.
    let (links, end) = (5, 20.0);
    let chain = hanging_chain(links, end);
    let mut warm = world(&chain, "xpbd@warm=1");
    let mut cold = world(&chain, "xpbd");
    let (_, drift_warm) = chain_errors(&mut warm, links, end, 15);
    let (_, drift_cold) = chain_errors(&mut cold, links, end, 15);
    println!("chain (xpbd): drift after 0.15 s {drift_warm:.3e} m warm-started, {drift_cold:.3e} m from zero");
    assert!(drift_warm > 1e-2, "{drift_warm}");
    assert!(drift_cold < 1e-3, "{drift_cold}");
}

#[test]
fn runs_are_deterministic() {
    let s = scene("incline_slide");
    let mut a = world(&s, "xpbd@substeps=7,iterations=2");
    let mut b = world(&s, "xpbd@substeps=7,iterations=2");
    let (ra, rb) = (a.run(60), b.run(60));
    for (x, y) in a.bodies.iter().zip(&b.bodies) {
        assert_eq!(x.position, y.position);
        assert_eq!(x.orientation, y.orientation);
        assert_eq!(x.linear_momentum, y.linear_momentum);
        assert_eq!(x.angular_momentum, y.angular_momentum);
    }
    for (x, y) in ra.iter().zip(&rb) {
        assert_eq!(x.residuals, y.residuals);
        assert_eq!(x.iterations, y.iterations);
        assert_eq!(x.iterations, 7 * 3);
    }
}

#[test]
fn the_spec_takes_its_parameters_and_refuses_bad_ones() {
    let (kind, params) = BodySolverKind::parse_spec("xpbd@substeps=8,compliance=1e-6,hertz=0")
        .unwrap()
        .unwrap();
    assert_eq!(kind, BodySolverKind::Xpbd);
    assert_eq!(params.count("substeps"), 8);
    assert_eq!(params.get("compliance"), 1e-6);
    assert_eq!(params.count("iterations"), 1, "default");
    assert_eq!(params.to_string(), "substeps=8,compliance=0.000001");
    let solver = kind.create_with(params);
    assert_eq!(solver.params(), params);
    assert_eq!(solver.name(), "xpbd");
    let d = BodySolverKind::parse_spec("xpbd").unwrap().unwrap().1;
    assert!(d.is_default());
    assert_eq!(d.count("substeps"), 20);
    assert!(BodySolverKind::Xpbd.substeps());
    assert!(BodySolverKind::Xpbd.takes_joints());
    assert!(BodySolverKind::Xpbd.relaxation().is_some());
    // Every substep starts from zero multipliers by default: no `+warm` variant.
    assert!(!BodySolverKind::Xpbd.is_iterative());
    for (bad, says) in [
        ("xpbd@substeps=0", "substeps must be in"),
        ("xpbd@iterations=1.5", "whole number"),
        ("xpbd@compliance=-1", "compliance must be in"),
        ("xpbd@restitution=2", "restitution must be in"),
        ("xpbd@omega=1", "unknown parameter `omega`"),
    ] {
        let e = BodySolverKind::parse_spec(bad).unwrap_err();
        assert!(e.contains(says) && e.starts_with("xpbd"), "{bad}: {e}");
    }
    // The scene file's `solver` field takes the same syntax.
    let s = inline(
        r#"
        [settings]
        solver = "xpbd@substeps=4,iterations=3"
        friction_model = "box"
        [[bodies]]
        name = "ball"
        shape = { type = "sphere", radius = 0.1 }
        mass = 1.0
        position = [0.0, 0.0, 1.0]
        "#,
    );
    let w = s.world();
    let ContactSolver::Body(solver) = &w.settings.solver else {
        panic!("xpbd is a body solver");
    };
    assert_eq!(solver.params().count("substeps"), 4);
    assert_eq!(solver.params().count("iterations"), 3);
}

/// A 1 kg ball of radius 0.1 resting on the ground (its centre at the radius).
fn ball_on_ground(dt: f64) -> Scene {
    inline(&format!(
        r#"
        [settings]
        dt = {dt}
        friction_model = "box"
        tolerance = 1e-8
        max_iterations = 10000
        prediction_distance = 0.01
        [[bodies]]
        name = "ground"
        shape = {{ type = "plane", normal = [0.0, 0.0, 1.0] }}
        static = true
        [[bodies]]
        name = "ball"
        shape = {{ type = "sphere", radius = 0.1 }}
        mass = 1.0
        position = [0.0, 0.0, 0.1]
        "#
    ))
}

/// Depth of the ball below resting on the ground after `steps`, and its final speed.
fn sink(spec: &str, steps: usize) -> (f64, f64) {
    let s = ball_on_ground(0.01);
    let mut w = world(&s, spec);
    w.run(steps);
    let b = &w.bodies[index(&w, "ball")];
    (0.1 - b.position.z, b.velocity().norm())
}

#[test]
fn a_compliant_contact_sinks_by_its_compliance_times_the_load() {
    let alpha = 1e-4;
    let (depth, speed) = sink(&format!("xpbd@compliance={alpha}"), 300);
    let expected = alpha * 1.0 * G;
    let err = (depth - expected).abs() / expected;
    println!(
        "compliant contact (xpbd, alpha {alpha} m/N): sank {depth:.6e} m, expected {expected:.6e} m, \
         relative error {err:.3e}, speed {speed:.3e} m/s"
    );
    assert!(err < 1e-3, "sank {depth}");
    // A spring of `hertz`: the ball rests g / ω² deep.
    let hertz = 5.0;
    let (depth, speed) = sink(&format!("xpbd@hertz={hertz},zeta=1"), 300);
    let omega = 2.0 * std::f64::consts::PI * hertz;
    let expected = G / (omega * omega);
    let err = (depth - expected).abs() / expected;
    println!(
        "soft contact (xpbd, {hertz} Hz): sank {depth:.6e} m, expected {expected:.6e} m, \
         relative error {err:.3e}, speed {speed:.3e} m/s"
    );
    assert!(err < 1e-3, "sank {depth}");
    // Rigid: no overlap.
    let (depth, _) = sink("xpbd", 300);
    assert!(depth.abs() < 1e-9, "rigid contact sank {depth}");
}

#[test]
fn converged_only_when_the_residual_meets_the_tolerance() {
    // Rigid ball at rest: one contact, one row a side: the last position pass solves its LCP.
    let s = ball_on_ground(0.01);
    let mut w = world(&s, "xpbd");
    for r in w.run(20) {
        let res = r.residuals.expect("measured").natural_map_rel;
        assert_eq!(
            r.residual_of.as_deref(),
            Some("position pass of substep 20 of 20")
        );
        assert_eq!(
            r.status.is_converged(),
            res <= w.settings.tolerance,
            "{res}"
        );
    }
    // A compliant contact overlaps by design: its LCP sees the overlap, never converged.
    let mut w = world(&s, "xpbd@compliance=1e-4");
    for r in w.run(50) {
        let res = r.residuals.expect("measured").natural_map_rel;
        assert!(res > w.settings.tolerance, "{res}");
        assert!(!r.status.is_converged(), "{:?}", r.status);
        let text = format!("{:?}", r.status);
        assert!(text.contains("XPBD"), "{text}");
    }
}

/// A 0.6 × 0.4 × 0.2 m box at `pos`, turned, moving at `v`, spinning at `w`.
fn cuboid(name: &str, pos: [f64; 3], v: [f64; 3], w: [f64; 3], is_static: bool) -> RigidBody {
    RigidBody::new(
        name,
        Shape::cuboid(Vector3::new(0.3, 0.2, 0.1)).unwrap(),
        MassSpec::Density(800.0),
        Point3::from(pos),
        UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7),
        Vector3::from(v),
        Vector3::from(w),
        0,
        is_static,
    )
    .unwrap()
}

/// The last solve is the LCP the module doc derives: on the normal row `w = A f + b` is the
/// position error at the last substep's end over `h`, checked independently from the pose
/// changes the step returns (`C₀ + J Δx`), and the friction rows' impulses are within their
/// bounds. A turned, spinning box pressed by gravity onto a static one at one corner.
#[test]
fn the_last_solve_is_the_equivalent_velocity_lcp() {
    let bodies = vec![
        cuboid("base", [0.0, 0.0, -0.5], [0.0; 3], [0.0; 3], true),
        cuboid(
            "box",
            [0.1, 0.05, 0.2],
            [0.1, 0.0, -0.05],
            [0.3, -0.2, 0.1],
            false,
        ),
    ];
    let contact = Contact {
        body_a: 0,
        body_b: 1,
        point: Point3::new(0.0, 0.0, 0.0),
        normal: Vector3::z(),
        dist: -0.002,
        key: 1,
    };
    let materials = [Material {
        name: "m".into(),
        mu: 0.4,
        restitution: 0.0,
    }];
    let params = BuilderParams {
        friction_model: FrictionModel::Box,
        ..BuilderParams::default()
    };
    let h = 0.01;
    let gravity = Vector3::new(0.0, 0.0, -G);
    let free = builder::free_velocities(&bodies, &gravity, h);
    let sys = builder::build(&bodies, &materials, &[contact], free, &params, h);
    let settings = Settings::default();
    let substeps = 5;
    let (_, params) = BodySolverKind::parse_spec("xpbd@substeps=5")
        .unwrap()
        .unwrap();
    let out = Xpbd::new(params).step(&SubstepInput {
        system: &sys,
        gravity,
        settings: &settings,
    });
    assert_eq!(out.last.what, "position pass of substep 5 of 5");
    let a = sys.delassus();
    let hs = h / substeps as f64;
    let info = &sys.info[0];
    let normal = info.normal_row;
    let f = &out.last.f;
    assert!(f[normal] > 0.0, "the contact pushes: {}", f[normal]);
    let w: Vec<f64> = (0..sys.n())
        .map(|i| (0..sys.n()).map(|j| a[(i, j)] * f[j]).sum::<f64>() + out.last.b[i])
        .collect();
    // Independent: C_end = C₀ + J Δx from the returned pose changes (the velocity pass
    // changes velocities only).
    let c_end: f64 = sys.position_error[normal]
        + sys.rows[normal]
            .blocks
            .iter()
            .map(|blk| {
                let body = &out.state.bodies[blk.body];
                blk.linear.dot(&body.dp) + blk.angular.dot(&body.dtheta)
            })
            .sum::<f64>();
    println!(
        "last solve (xpbd): f_n {:.6e}, w_n {:.3e}, C_end/h {:.3e}",
        f[normal],
        w[normal],
        c_end / hs
    );
    // w_n is the position error at the substep's end over h (the friction rows, swept after
    // the normal row, turn the box a little: one contact, not quite touching).
    assert!(
        (c_end / hs - w[normal]).abs() < 1e-9 * (1.0 + w[normal].abs()),
        "C_end/h {} vs w_n {}",
        c_end / hs,
        w[normal]
    );
    assert!(c_end.abs() < 1e-5, "C_end {c_end}");
    for r in info.friction_rows.clone() {
        assert!(
            f[r].abs() <= info.mu * f[normal] * (1.0 + 1e-12),
            "row {r}: {}",
            f[r]
        );
        // Stuck (inside the bound) means no slip over the substep.
        if f[r].abs() < info.mu * f[normal] * (1.0 - 1e-9) {
            assert!(w[r].abs() < 1e-9, "row {r}: w {}", w[r]);
        }
    }
    // `f_step` sums the substeps: the box is pressed on throughout, so the normal impulse of
    // the step exceeds the last substep's.
    assert!(out.f_step[normal] > f[normal]);
    assert_eq!(out.warm, out.last.f);
    assert_eq!(out.substeps, substeps);
    assert_eq!(out.iterations, 2 * substeps);

    // `max_iterations` caps the sweeps of the step (a position pass and a velocity pass a
    // substep): five sweeps solve substeps 1, 2 and 3's position pass; 4 and 5 only integrate.
    let capped = Settings {
        max_iterations: 5,
        ..Settings::default()
    };
    let out = Xpbd::new(params).step(&SubstepInput {
        system: &sys,
        gravity,
        settings: &capped,
    });
    assert_eq!(out.iterations, 5);
    assert_eq!(out.last.what, "position pass of substep 3 of 5");
    assert_eq!(out.substeps, substeps);
    assert!(!out.timed_out);
}

/// Apex of the first rebound of `ball_drop` (a ball dropped from 1 m, restitution 0.8) over
/// the drop height, at a step of `dt`; `None` when it does not bounce within 1.5 s.
fn rebound_ratio(spec: &str, dt: f64) -> Option<f64> {
    let s = scene("ball_drop");
    let mut w = world(&s, spec);
    w.settings.dt = dt;
    let ball = index(&w, "ball");
    let mut bounced = false;
    let mut apex: f64 = 0.0;
    for _ in 0..(1.5 / dt) as usize {
        w.step();
        let b = &w.bodies[ball];
        if b.velocity().z > 0.0 {
            bounced = true;
        }
        if bounced {
            apex = apex.max(b.position.z - 0.1);
            if b.velocity().z < 0.0 {
                break;
            }
        }
    }
    bounced.then_some(apex)
}

#[test]
fn ball_rebounds_to_about_e_squared_of_its_height() {
    // The velocity pass reverses the approach speed of the step's start (before that step's
    // gravity), and the ball meets the ground within the step: first order in the step.
    let e2 = 0.8f64 * 0.8;
    let coarse = (rebound_ratio("xpbd", 1e-2).expect("bounces") - e2) / e2;
    let fine = (rebound_ratio("xpbd", 1e-3).expect("bounces") - e2) / e2;
    println!(
        "ball drop (xpbd): rebound/drop relative error {coarse:.3e} at h = 10 ms, {fine:.3e} at \
         h = 1 ms"
    );
    assert!(fine.abs() < 1e-2, "relative error {fine:e}");
    assert!(
        fine.abs() < coarse.abs(),
        "not converging: {coarse} then {fine}"
    );
    // Without the velocity pass's normal update the position pass only stops the ball.
    assert_eq!(rebound_ratio("xpbd@restitution=0", 1e-3), None);
}

/// A 1 kg ball resting on the ground at the step's start, as a system alone (its free
/// velocity `−g h` holds the step's gravity).
fn resting_ball_system(h: f64) -> lcpbench_contact::builder::ContactSystem {
    let ball = RigidBody::new(
        "ball",
        Shape::sphere(0.1).unwrap(),
        MassSpec::Mass(1.0),
        Point3::new(0.0, 0.0, 0.1),
        UnitQuaternion::identity(),
        Vector3::zeros(),
        Vector3::zeros(),
        0,
        false,
    )
    .unwrap();
    let ground = cuboid("ground", [0.0, 0.0, -1.0], [0.0; 3], [0.0; 3], true);
    let bodies = vec![ground, ball];
    let contact = Contact {
        body_a: 0,
        body_b: 1,
        point: Point3::origin(),
        normal: Vector3::z(),
        dist: 0.0,
        key: 1,
    };
    let materials = [Material {
        name: "m".into(),
        mu: 0.5,
        restitution: 0.0,
    }];
    let params = BuilderParams {
        friction_model: FrictionModel::Box,
        ..BuilderParams::default()
    };
    let free = builder::free_velocities(&bodies, &Vector3::new(0.0, 0.0, -G), h);
    builder::build(&bodies, &materials, &[contact], free, &params, h)
}

#[test]
fn on_a_system_alone_the_step_impulse_is_the_lcp_answer() {
    // Without a world the sweep starts from the free velocities (gravity in them) and adds no
    // gravity: the first substep stops the ball with the impulse m g h, the LCP's answer.
    let h = 0.01;
    let sys = resting_ball_system(h);
    let problem = sys.problem().unwrap();
    let mut solver = BodySolverKind::Xpbd.create();
    let out = solver.solve(
        &sys,
        &Settings::default(),
        lcpbench_contact::body_solvers::Measure::Lcp(&problem),
    );
    let normal = sys.info[0].normal_row;
    let expected = 1.0 * G * h;
    println!(
        "ball alone (xpbd): normal impulse {:.12}, expected {expected:.12}, status {:?}",
        out.result.f[normal], out.result.status
    );
    assert!((out.result.f[normal] - expected).abs() < 1e-12 * expected);
    assert_eq!(out.result.iterations, 40);
    // Measured on the step's LCP, the answer meets the tolerance.
    assert!(out.result.status.is_converged(), "{:?}", out.result.status);
}

#[test]
fn a_spent_time_budget_leaves_the_remaining_substeps_integrating() {
    // The budget is checked between substeps: with none left the first substep solves, the
    // others only integrate, and the step says it timed out.
    let h = 0.01;
    let sys = resting_ball_system(h);
    let settings = Settings {
        time_budget: Some(std::time::Duration::ZERO),
        ..Settings::default()
    };
    let out = Xpbd::default().step(&SubstepInput {
        system: &sys,
        gravity: Vector3::new(0.0, 0.0, -G),
        settings: &settings,
    });
    assert!(out.timed_out);
    assert_eq!(out.last.what, "position pass of substep 1 of 20");
    assert_eq!(out.iterations, 2);
    // Gravity over the 19 unsolved substeps sinks the ball.
    let ball = &out.state.bodies[1];
    assert!(ball.dp.z < 0.0 && ball.v.z < 0.0, "{ball:?}");
}

/// [`common::hanging_chain`] at dt = 0.01 s.
fn hanging_chain(links: usize, end: f64) -> Scene {
    common::hanging_chain(
        links,
        end,
        "dt = 0.01\nfriction_model = \"box\"\ntolerance = 1e-10\nmax_iterations = 100000",
    )
}

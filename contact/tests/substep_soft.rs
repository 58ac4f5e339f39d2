//! The substepping solvers `soft-step` (Box2D v3's soft step) and `tgs` (temporal
//! Gauss–Seidel with Baumgarte bias) through the whole pipeline: scenes with analytic answers
//! at the accuracy each solver's model allows (stated in each test), bench scenes that must
//! hold, and the bookkeeping the stepper relies on (warm start, determinism, the `@params`
//! syntax, the last solve's LCP and the status honesty). Each test prints what it measured
//! (`cargo test --test substep_soft -- --nocapture`).

use lcpbench_contact::builder::{self, BuilderParams, FrictionModel};
use lcpbench_contact::substep::SubstepInput;
use lcpbench_contact::{BodySolverKind, Contact, ContactSolver, RigidBody, Scene, World};
use lcpbench_solvers::{Settings, Status};
use nalgebra::{Point3, Vector3};
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

/// The solver of a specification `name@key=value,…`.
fn solver(spec: &str) -> ContactSolver {
    let (kind, params) = BodySolverKind::parse_spec(spec)
        .unwrap_or_else(|e| panic!("{spec}: {e}"))
        .unwrap_or_else(|| panic!("{spec}: not a body-level solver"));
    ContactSolver::Body(kind.create_with(params))
}

fn world(scene: &Scene, spec: &str) -> World {
    let mut w = scene.world();
    w.set_solver(solver(spec));
    w
}

fn body<'a>(w: &'a World, name: &str) -> &'a RigidBody {
    &w.bodies[w
        .body_index(name)
        .unwrap_or_else(|| panic!("no body {name}"))]
}

/// Every step's status is honest: `converged` only when the reported residual of the last
/// solve meets the tolerance; a soft-step status that is not converged names the soft model.
fn check_status(spec: &str, w: &World, r: &lcpbench_contact::StepReport) {
    if r.rows == 0 {
        return;
    }
    let rel = r.residuals.as_ref().map_or(f64::NAN, |x| x.natural_map_rel);
    match &r.status {
        Status::Converged => assert!(
            rel <= w.settings.tolerance,
            "{spec}: converged at residual {rel} > {}",
            w.settings.tolerance
        ),
        Status::Stalled { reason } if spec.starts_with("soft-step") => {
            assert!(
                reason.contains("soft contacts and joints"),
                "{spec}: {reason}"
            )
        }
        Status::IterationLimit if spec.starts_with("tgs") => {}
        s => panic!("{spec}: unexpected status {s:?}"),
    }
    assert!(
        r.residual_of.is_some(),
        "{spec}: the residual names its solve"
    );
}

const SOLVERS: [&str; 2] = ["soft-step", "tgs"];

/// `soft-step` with Rapier's contact solve: friction rows pulled back to their anchors, each
/// manifold's normal rows first and solved two by two as 2×2 blocks.
const RAPIER_CONTACTS: &str = "soft-step@friction_anchor=1,block_pairs=1";

#[test]
fn box_rests_on_the_ground_for_5_s() {
    // A soft contact of stiffness m ω² under the box's weight settles at g / ω² below the
    // surface (static contacts at 60 Hz: 0.07 mm); tgs stays within its slop (5 mm), below
    // which its Baumgarte bias is zero.
    let s = scene("box_on_ground");
    for (spec, bound) in [("soft-step", 5e-4), ("tgs", 6e-3), (RAPIER_CONTACTS, 5e-4)] {
        let mut w = world(&s, spec);
        let z0 = body(&w, "box").position.z;
        let (mut sink, mut lateral): (f64, f64) = (0.0, 0.0);
        for _ in 0..500 {
            let r = w.step();
            check_status(spec, &w, &r);
            let b = body(&w, "box");
            sink = sink.max(z0 - b.position.z);
            lateral = lateral.max(b.position.x.hypot(b.position.y));
        }
        let v = body(&w, "box").velocity().norm();
        println!(
            "{spec}: box on ground: sink {sink:.3e} m, lateral {lateral:.3e} m, speed {v:.3e}"
        );
        assert!(sink < bound, "{spec}: sank {sink}");
        assert!(lateral < 1e-4, "{spec}: moved sideways {lateral}");
        assert!(v < 1e-3, "{spec}: still moving at {v}");
    }
}

fn along_slope(w: &World) -> (f64, f64) {
    let th = 30f64.to_radians();
    let s = Vector3::new(th.cos(), 0.0, -th.sin());
    let b = body(w, "box");
    (b.position.coords.dot(&s), b.velocity().dot(&s))
}

#[test]
fn box_sticks_on_an_incline_with_mu_0_7() {
    let s = scene("incline_stick");
    for spec in [SOLVERS[0], SOLVERS[1], RAPIER_CONTACTS] {
        let mut w = world(&s, spec);
        let (x0, _) = along_slope(&w);
        for _ in 0..s.settings.steps {
            let r = w.step();
            check_status(spec, &w, &r);
        }
        let (x, v) = along_slope(&w);
        println!(
            "{spec}: incline mu = 0.7: slid {:.3e} m in 2 s, speed {v:.3e} m/s",
            x - x0
        );
        assert!(
            (x - x0).abs() < 1e-4 && v.abs() < 1e-3,
            "{spec}: slid {}",
            x - x0
        );
    }
}

#[test]
fn box_slides_on_an_incline_with_mu_0_3() {
    // Friction rows are rigid and clamped at mu λ_n in every pass: the sliding acceleration is
    // g (sin α − μ cos α) up to the normal impulse's soft-contact error.
    let th = 30f64.to_radians();
    let expected = G * (th.sin() - 0.3 * th.cos());
    let s = scene("incline_slide");
    for spec in [SOLVERS[0], SOLVERS[1], RAPIER_CONTACTS] {
        let mut w = world(&s, spec);
        w.run(50);
        let (_, v0) = along_slope(&w);
        w.run(150);
        let (_, v1) = along_slope(&w);
        let a = (v1 - v0) / (150.0 * s.settings.dt);
        let err = (a - expected).abs() / expected;
        println!(
            "{spec}: incline mu = 0.3: a = {a:.6} m/s², expected {expected:.6}, error {err:.3e}"
        );
        assert!(err < 1e-3, "{spec}: a = {a}");
    }
}

/// A simple pendulum: a small ball on a distance joint `length` from a pivot at `z = 2`,
/// started `degrees` from the vertical, stepped at `dt`.
fn pendulum(length: f64, degrees: f64, dt: f64) -> Scene {
    let th = degrees.to_radians();
    let (x, z) = (length * th.sin(), 2.0 - length * th.cos());
    inline(&format!(
        r#"
        [settings]
        dt = {dt}
        friction_model = "none"
        tolerance = 1e-8
        max_iterations = 1000
        [[bodies]]
        name = "bob"
        shape = {{ type = "sphere", radius = 0.02 }}
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
fn pendulum_period_matches_the_small_angle_one() {
    // T = 2π √(L / g) (1 + θ₀² / 16); substeps of h/4 keep the rod's length to the soft
    // joint's accuracy, and the period to 0.5 %.
    let (length, deg, dt) = (1.0, 5.0, 0.01);
    let th0 = f64::to_radians(deg);
    let exact = 2.0 * std::f64::consts::PI * (length / G).sqrt() * (1.0 + th0 * th0 / 16.0);
    let s = pendulum(length, deg, dt);
    for spec in SOLVERS {
        let mut w = world(&s, spec);
        let mut crossings = Vec::new();
        let mut prev = w.bodies[0].position.x;
        let mut drift: f64 = 0.0;
        for _ in 0..1000 {
            let r = w.step();
            check_status(spec, &w, &r);
            drift = drift.max(r.joint_drift_max);
            let x = w.bodies[0].position.x;
            if prev < 0.0 && x >= 0.0 {
                crossings.push(w.time - dt * x / (x - prev));
            }
            prev = x;
        }
        assert!(
            crossings.len() >= 3,
            "{spec}: {} crossings",
            crossings.len()
        );
        let t = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        let err = (t - exact).abs() / exact;
        println!("{spec}: pendulum period {t:.6} s, analytic {exact:.6} s, error {err:.3e}, drift {drift:.3e} m");
        assert!(err < 5e-3, "{spec}: period {t}");
        assert!(drift < 1e-3, "{spec}: the rod stretched {drift}");
    }
}

#[test]
fn static_chain_joints_carry_the_weight_below_them() {
    // Each joint's impulse over a step is (weight below it) × h once the chain has settled:
    // the relax pass (soft-step) and the sweeps (tgs) end each substep on the rigid rows.
    // tgs runs 30 sweeps per substep here: at one sweep its Baumgarte bias, which no relax
    // pass takes out, makes this 20:1 chain oscillate with growing amplitude (see tgs.rs).
    let (links, end, dt) = (5, 20.0, 0.01);
    let s = hanging_chain(links, end, dt);
    for spec in ["soft-step", "tgs@iterations=30"] {
        let mut w = world(&s, spec);
        let mut last = None;
        for _ in 0..200 {
            let r = w.step();
            check_status(spec, &w, &r);
            last = Some(r);
        }
        let r = last.unwrap();
        assert_eq!(r.joint_rows, 3 * (links + 1));
        let mut worst: f64 = 0.0;
        for (k, joint) in r.joint_records.iter().enumerate() {
            let expected = ((links - k) as f64 + end) * G * dt;
            let err = (joint.impulse - expected).abs() / expected;
            worst = worst.max(err);
            assert!(
                err < 1e-3,
                "{spec}: joint {k}: {} against {expected}",
                joint.impulse
            );
        }
        println!(
            "{spec}: static chain: worst relative joint impulse error {worst:.3e}, drift {:.3e} m",
            r.joint_drift_max
        );
    }
}

#[test]
fn tower_10_stands_10_s_under_soft_step() {
    // Soft contacts sag: the contact under k boxes of weight W settles by k W / (m_eff ω²)
    // (ω = 2π · 30 Hz, m_eff about half a box's mass between two boxes), 2.5 cm summed over
    // the tower; a one-sweep relax leaves an order-dependent torque that leans the tower by
    // about 1 cm at the top in 2 s, where it settles (7.5 mm at 10 s). The bounds are those
    // observations with margin, over the scene's 10 s.
    let s = scene("tower_10");
    let spec = "soft-step@substeps=4";
    let mut w = world(&s, spec);
    let top0 = w
        .bodies
        .iter()
        .map(|b| b.position.z)
        .fold(f64::MIN, f64::max);
    for _ in 0..1000 {
        let r = w.step();
        check_status(spec, &w, &r);
    }
    let top = w
        .bodies
        .iter()
        .map(|b| b.position.z)
        .fold(f64::MIN, f64::max);
    let lateral = w
        .bodies
        .iter()
        .filter(|b| !b.is_static)
        .map(|b| b.position.x.hypot(b.position.y))
        .fold(0.0, f64::max);
    println!(
        "{spec}: tower_10: top sag {:.3e} m, lateral {lateral:.3e} m",
        top0 - top
    );
    assert!(top0 - top > 0.0 && top0 - top < 3e-2, "sag {}", top0 - top);
    assert!(lateral < 2e-2, "lateral {lateral}");
}

#[test]
fn chain_20_1e3_joint_drift_under_soft_step_at_20_substeps() {
    // A soft joint of stiffness m_eff ω² under the 1000 kg end mass stretches by
    // F / (m_eff ω²). Box2D's joints (60 Hz, at most 0.125 / h) stretch centimetres per joint
    // whatever the substeps (observed 0.27 m at 20 substeps); the default joints at a quarter
    // of the substep rate (300 Hz at 20 substeps of 1/60 s) drift 1.1 cm, under Rapier's
    // 2.7 cm at the same substeps.
    let s = scene("joints/chain_20_1e3");
    for (spec, bound) in [
        ("soft-step@substeps=20,joint_hertz=60,joint_cap=0.125", 0.3),
        ("soft-step@substeps=20", 0.02),
    ] {
        let mut w = world(&s, spec);
        let mut drift: f64 = 0.0;
        for _ in 0..s.settings.steps {
            let r = w.step();
            check_status(spec, &w, &r);
            drift = drift.max(r.joint_drift_max);
        }
        println!("{spec}: chain_20_1e3: max joint drift {drift:.4e} m");
        assert!(drift < bound, "{spec}: drift {drift}");
    }
}

#[test]
fn chain_20_1e3_under_tgs_needs_soft_joints() {
    // tgs's Baumgarte bias on rigid joint rows, one sweep per substep and warm started, feeds
    // on itself along the chain and blows up (484 m measured at 4 substeps); the soft joint
    // rows of `joint_hertz` (at most 0.25 / h, ζ = 2) hold it as they hold soft-step's
    // (measured 0.28 m at 4 substeps, 2.8 cm at 20).
    let s = scene("joints/chain_20_1e3");
    for (spec, low, high) in [
        ("tgs", 1.0, f64::INFINITY),
        ("tgs@joint_hertz=1e6", 0.0, 0.35),
        ("tgs@substeps=20,joint_hertz=1e6", 0.0, 0.035),
    ] {
        let mut w = world(&s, spec);
        let mut drift: f64 = 0.0;
        for _ in 0..s.settings.steps {
            let r = w.step();
            drift = drift.max(r.joint_drift_max);
            if !drift.is_finite() || drift > 1e3 {
                break;
            }
        }
        println!("{spec}: chain_20_1e3: max joint drift {drift:.4e} m");
        assert!(
            drift >= low && drift < high,
            "{spec}: drift {drift} outside [{low}, {high})"
        );
    }
}

#[test]
fn ball_rebounds_to_e_squared_of_its_height() {
    let s = scene("ball_drop");
    for spec in SOLVERS {
        let mut w = world(&s, spec);
        let (mut bounced, mut apex): (bool, f64) = (false, 0.0);
        for _ in 0..1000 {
            w.step();
            let b = body(&w, "ball");
            let vz = b.velocity().z;
            if vz > 0.0 {
                bounced = true;
            }
            if bounced {
                apex = apex.max(b.position.z - 0.1);
            }
        }
        let expected = 0.64;
        println!("{spec}: ball rebound {apex:.4} m, expected {expected}");
        assert!(bounced, "{spec}: no bounce");
        assert!((apex - expected).abs() < 0.02, "{spec}: rebound {apex}");
    }
}

/// A 2 kg sphere of radius 0.5 on the ground at gap `dist`, moving at (3, 0, `vz`) m/s
/// (one contact, box friction μ = 0.4, restitution `e`), its system built by hand for a
/// step of 0.01 s.
fn sphere_on_ground(dist: f64, vz: f64, e: f64) -> lcpbench_contact::ContactSystem {
    let s = inline(&format!(
        r#"
        [settings]
        friction_model = "box"
        [[materials]]
        name = "m"
        mu = 0.4
        restitution = {e}
        [[bodies]]
        name = "ground"
        shape = {{ type = "plane", normal = [0.0, 0.0, 1.0] }}
        static = true
        material = "m"
        [[bodies]]
        name = "ball"
        shape = {{ type = "sphere", radius = 0.5 }}
        mass = 2.0
        position = [0.0, 0.0, {z}]
        velocity = [3.0, 0.0, {vz}]
        material = "m"
        "#,
        z = 0.5 + dist
    ));
    let w = s.world();
    let contact = Contact {
        body_a: 0,
        body_b: 1,
        point: Point3::new(0.0, 0.0, 0.0),
        normal: Vector3::z(),
        dist,
        key: 1,
    };
    let params = BuilderParams {
        friction_model: FrictionModel::Box,
        ..BuilderParams::default()
    };
    let h = 0.01;
    let gravity = Vector3::new(0.0, 0.0, -G);
    let free = builder::free_velocities(&w.bodies, &gravity, h);
    builder::build(&w.bodies, &w.materials, &[contact], free, &params, h)
}

#[test]
fn the_last_solve_is_the_lcp_of_the_final_velocities() {
    // w = A λ + b of the reported last solve must be the post-relax velocity along each row
    // plus the speculative bias (zero for a touching contact): checked against the bodies'
    // final velocities, computed independently through the system's Jacobian.
    let sys = sphere_on_ground(-1e-3, -0.5, 0.0);
    for spec in ["soft-step", "tgs@hertz=0,baumgarte=0"] {
        let (kind, params) = BodySolverKind::parse_spec(spec).unwrap().unwrap();
        let mut s = kind.create_with(params);
        let settings = Settings::default();
        let input = SubstepInput {
            system: &sys,
            gravity: Vector3::new(0.0, 0.0, -G),
            settings: &settings,
        };
        let out = s.advance(&input).expect("substeps");
        let p = sys
            .problem_with_b(
                out.last.b.clone(),
                lcpbench_contact::builder::DelassusForm::Assembled,
            )
            .unwrap();
        let n = sys.n();
        let a = p.to_dense();
        let final_u: Vec<_> = out
            .state
            .bodies
            .iter()
            .map(|b| lcpbench_contact::builder::BodyVelocity {
                linear: b.v,
                angular: b.w,
            })
            .collect();
        let op = sys.operator();
        for i in 0..n {
            let w: f64 = (0..n).map(|j| a[(i, j)] * out.last.f[j]).sum::<f64>() + out.last.b[i];
            let v = op.row_dot(i, &final_u);
            println!("{spec}: row {i}: w {w:.6e}, J v {v:.6e}");
            assert!((w - v).abs() < 1e-12, "{spec}: row {i}: {w} against {v}");
        }
        assert!(out.last.what.contains("of substep"), "{}", out.last.what);
        assert_eq!(out.f_step.len(), n);
        assert!(out.f_step[0] > 0.0, "{spec}: the contact pushed");
    }
}

#[test]
fn warm_start_carries_impulses_across_steps() {
    // The stored impulses of one step start the next: on the 10-box tower, a run with the
    // warm start ends its steps at a smaller residual of the last solve than a run without
    // (observed: 5 to 10 times smaller).
    let s = scene("tower_10");
    for spec in SOLVERS {
        let mut residual = [0.0; 2];
        for (k, warm) in [true, false].into_iter().enumerate() {
            let mut w = world(&s, spec);
            w.settings.warm_start = warm;
            let reports = w.run(60);
            residual[k] = reports[50..]
                .iter()
                .map(|r| r.residuals.as_ref().unwrap().natural_map_rel)
                .fold(0.0, f64::max);
        }
        println!(
            "{spec}: tower_10 last-solve residual with warm start {:.3e}, without {:.3e}",
            residual[0], residual[1]
        );
        assert!(residual[0] < residual[1], "{spec}: {residual:?}");
    }
    let sys = sphere_on_ground(-1e-3, 0.0, 0.0);
    let (kind, params) = BodySolverKind::parse_spec("soft-step@relax_iterations=0")
        .unwrap()
        .unwrap();
    let mut solver = kind.create_with(params);
    let gravity = Vector3::new(0.0, 0.0, -G);
    let run = |solver: &mut Box<dyn lcpbench_contact::BodySolver + Send>,
               warm: Option<Vec<f64>>| {
        let settings = Settings {
            warm_start: warm,
            ..Settings::default()
        };
        let input = SubstepInput {
            system: &sys,
            gravity,
            settings: &settings,
        };
        solver.advance(&input).unwrap()
    };
    let cold = run(&mut solver, None);
    let short = run(&mut solver, Some(Vec::new()));
    assert_eq!(
        cold.f_step, short.f_step,
        "a shorter stored vector starts at zero"
    );
    // One soft row forgets its start: λ' = λ (1 − mass_scale − impulse_scale) − … and
    // mass_scale + impulse_scale = 1, so a warm start changes nothing on a single contact.
    let warm = run(&mut solver, Some(cold.warm.clone()));
    assert!((cold.f_step[0] - warm.f_step[0]).abs() < 1e-12);
}

#[test]
fn runs_are_deterministic() {
    let s = scene("pyramid_5");
    for spec in ["soft-step@substeps=3", "tgs"] {
        let mut a = world(&s, spec);
        let mut b = world(&s, spec);
        a.run(30);
        b.run(30);
        for (x, y) in a.bodies.iter().zip(&b.bodies) {
            assert_eq!(x.position, y.position, "{spec}");
            assert_eq!(x.orientation, y.orientation, "{spec}");
            assert_eq!(x.linear_momentum, y.linear_momentum, "{spec}");
        }
    }
}

#[test]
fn parameters_parse_with_defaults_ranges_and_scene_files() {
    let (kind, p) = BodySolverKind::parse_spec("soft-step@substeps=8,hertz=60")
        .unwrap()
        .unwrap();
    assert_eq!(kind, BodySolverKind::SoftStep);
    assert_eq!(p.count("substeps"), 8);
    assert_eq!(p.get("hertz"), 60.0);
    assert_eq!(p.get("zeta"), 10.0);
    assert_eq!(p.get("static_scale"), 2.0);
    assert_eq!(p.get("joint_hertz"), 1e6);
    assert_eq!(p.get("joint_zeta"), 2.0);
    assert_eq!(p.get("joint_cap"), 0.25);
    assert_eq!(p.get("friction_anchor"), 0.0);
    assert_eq!(p.count("normals_first"), 0);
    assert_eq!(p.count("block_pairs"), 0);
    assert_eq!(p.get("push_out"), 3.0);
    assert_eq!(p.count("relax_iterations"), 1);
    assert_eq!(p.to_string(), "substeps=8,hertz=60");
    assert_eq!(kind.create_with(p).params(), p);
    let (kind, p) = BodySolverKind::parse_spec("tgs").unwrap().unwrap();
    assert_eq!(kind, BodySolverKind::Tgs);
    assert_eq!(p.get("baumgarte"), 0.2);
    assert_eq!(p.get("slop"), 0.005);
    assert_eq!(p.get("hertz"), 0.0);
    assert_eq!(p.count("substeps"), 4);
    for bad in [
        "soft-step@substeps=0",
        "soft-step@omega=1",
        "tgs@baumgarte=2",
        "tgs@substeps=1.5",
    ] {
        let e = BodySolverKind::parse_spec(bad).unwrap_err();
        println!("{bad}: {e}");
        assert!(e.starts_with("soft-step") || e.starts_with("tgs"), "{e}");
    }
    for kind in [BodySolverKind::SoftStep, BodySolverKind::Tgs] {
        assert!(kind.substeps() && kind.takes_joints() && kind.is_iterative());
        assert_eq!(BodySolverKind::from_name(kind.name()), Some(kind));
    }
    assert!(BodySolverKind::SoftStep.relaxation().is_some());
    assert!(BodySolverKind::Tgs.relaxation().is_none());
    // A scene file's solver field takes the same syntax.
    let s = inline(
        "[settings]\nsolver = \"soft-step@substeps=2,joint_hertz=30\"\n[[bodies]]\nname = \"b\"\nshape = { type = \"sphere\", radius = 0.1 }\nmass = 1.0\nposition = [0.0, 0.0, 1.0]\n",
    );
    let w = s.world();
    assert_eq!(w.settings.solver.name(), "soft-step");
    let ContactSolver::Body(solver) = &w.settings.solver else {
        panic!("not a body solver")
    };
    assert_eq!(solver.params().count("substeps"), 2);
    assert_eq!(solver.params().get("joint_hertz"), 30.0);
}

#[test]
fn the_step_report_names_the_last_solve_and_counts_the_work() {
    let s = scene("box_on_ground");
    let mut w = world(&s, "soft-step@substeps=3,relax_iterations=2");
    let r = w.step();
    assert_eq!(r.substeps, 3);
    assert_eq!(
        r.residual_of.as_deref(),
        Some("relax pass of substep 3 of 3")
    );
    // 3 substeps × (1 biased + 2 relax sweeps), no restitution.
    assert_eq!(r.iterations, 9);
    // Two body passes per substep; each sweep and each warm start updates every swept row.
    assert_eq!(r.cost.body_passes, 6);
    assert_eq!(r.cost.row_updates, (3 * 4) as u64 * r.rows as u64);
    check_status("soft-step", &w, &r);
    let mut w = world(&s, "tgs@substeps=2,iterations=3");
    let r = w.step();
    assert_eq!(
        r.residual_of.as_deref(),
        Some("biased solve of substep 2 of 2")
    );
    assert_eq!(r.iterations, 6);
}

#[test]
fn tower_40_60hz_stands_when_its_contacts_are_stiff_enough() {
    // The soft contact's springs make the tower a column of rotational springs: at Box2D's
    // 30 Hz, the 39 boxes above the second box tip it (weight × height 7.5e6 N m/rad against
    // a spring of 4.4e6 N m/rad) and the tower buckles after about 4 s; at 300 Hz (allowed
    // at 20 substeps) it stands. Observed over 5 s: lateral under 1 cm, sag 4 mm.
    let s = scene("tower_40_60hz");
    let spec = "soft-step@substeps=20,hertz=300";
    let mut w = world(&s, spec);
    let top0 = w
        .bodies
        .iter()
        .map(|b| b.position.z)
        .fold(f64::MIN, f64::max);
    for _ in 0..300 {
        let r = w.step();
        check_status(spec, &w, &r);
    }
    let top = w
        .bodies
        .iter()
        .map(|b| b.position.z)
        .fold(f64::MIN, f64::max);
    let lateral = w
        .bodies
        .iter()
        .map(|b| b.position.x.hypot(b.position.y))
        .fold(0.0, f64::max);
    println!(
        "{spec}: tower_40_60hz 5 s: sag {:.3e} m, lateral {lateral:.3e} m",
        top0 - top
    );
    assert!(top0 - top < 1e-2, "sag {}", top0 - top);
    assert!(lateral < 3e-2, "lateral {lateral}");
}

#[test]
fn iteration_cap_and_time_budget_end_the_solves() {
    let sys = sphere_on_ground(-1e-3, -0.5, 0.0);
    let gravity = Vector3::new(0.0, 0.0, -G);
    let (kind, params) = BodySolverKind::parse_spec("soft-step@substeps=4")
        .unwrap()
        .unwrap();
    let mut s = kind.create_with(params);
    // 3 sweeps: the biased and relax sweeps of substep 1, the biased sweep of substep 2; the
    // last two substeps only integrate.
    let capped = Settings {
        max_iterations: 3,
        ..Settings::default()
    };
    let input = SubstepInput {
        system: &sys,
        gravity,
        settings: &capped,
    };
    let out = s.advance(&input).unwrap();
    assert_eq!(out.iterations, 3);
    assert_eq!(out.substeps, 4);
    assert_eq!(out.last.what, "biased solve (soft rows) of substep 2 of 4");
    assert!(!out.timed_out);
    assert_eq!(out.cost.body_passes, 8);
    // A spent time budget: the first substep solves, the others only integrate.
    let spent = Settings {
        time_budget: Some(std::time::Duration::ZERO),
        ..Settings::default()
    };
    let input = SubstepInput {
        system: &sys,
        gravity,
        settings: &spent,
    };
    let out = s.advance(&input).unwrap();
    assert!(out.timed_out);
    assert_eq!(out.iterations, 2);
    assert_eq!(out.last.what, "relax pass of substep 1 of 4");
    // Through the stepper, a spent budget is a time limit, never `converged`.
    let scene = scene("box_on_ground");
    let mut w = world(&scene, "soft-step");
    w.settings.step_time_budget = Some(std::time::Duration::ZERO);
    let r = w.step();
    println!("spent budget: {:?}", r.status);
    let rel = r.residuals.as_ref().map_or(f64::NAN, |x| x.natural_map_rel);
    assert!(
        matches!(r.status, Status::TimeLimit)
            || (r.status.is_converged() && rel <= w.settings.tolerance),
        "{:?}",
        r.status
    );
}

#[test]
fn pyramid_3d_1015_holds_for_1_s_under_soft_step() {
    // Observed: no box moves more than 4.4 mm in 1 s.
    let s = scene("pyramid_3d_1015");
    let mut w = world(&s, "soft-step");
    let p0: Vec<_> = w.bodies.iter().map(|b| b.position).collect();
    for _ in 0..((1.0 / s.settings.dt).round() as usize) {
        let r = w.step();
        check_status("soft-step", &w, &r);
    }
    let moved = w
        .bodies
        .iter()
        .zip(&p0)
        .map(|(b, p)| (b.position - p).norm())
        .fold(0.0, f64::max);
    println!("soft-step: pyramid_3d_1015: largest move in 1 s {moved:.3e} m");
    assert!(moved < 1e-2, "moved {moved}");
}

/// [`common::hanging_chain`] stepped at `dt`, tolerance 1e-8, 1,000 sweeps at most.
fn hanging_chain(links: usize, end: f64, dt: f64) -> Scene {
    common::hanging_chain(
        links,
        end,
        &format!("dt = {dt}\nfriction_model = \"box\"\ntolerance = 1e-8\nmax_iterations = 1000"),
    )
}

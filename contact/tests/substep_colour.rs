//! Coloured sweeps (`colour=1`) of the substepping solvers `soft-step`, `tgs` and `pgs-ngs`
//! through the whole pipeline: answers that do not depend on the number of threads, the
//! serial answer bit for bit where the constraints share no body (so the order of the
//! constraints cannot matter), the analytic answers of the serial tests (a tower's sag, a
//! hanging chain's joint impulses), and the bookkeeping (the `colour` key, the step report
//! naming the coloured solve, status honesty). Each test prints what it measured
//! (`cargo test --test substep_colour -- --nocapture`).

use lcpbench_contact::{BodySolverKind, ContactSolver, Scene, StepReport, World};
use lcpbench_solvers::Status;
use std::path::PathBuf;

mod common;
use common::inline;

const G: f64 = 9.81;

const COLOURED: [&str; 3] = ["soft-step@colour=1", "tgs@colour=1", "pgs-ngs@colour=1"];

fn scene(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench_scenes")
        .join(format!("{name}.toml"));
    Scene::load(path).unwrap_or_else(|e| panic!("{e}"))
}

fn world(scene: &Scene, spec: &str) -> World {
    let (kind, params) = BodySolverKind::parse_spec(spec)
        .unwrap_or_else(|e| panic!("{spec}: {e}"))
        .unwrap_or_else(|| panic!("{spec}: not a body-level solver"));
    let mut w = scene.world();
    w.set_solver(ContactSolver::Body(kind.create_with(params)));
    w
}

/// `steps` steps of `spec` on `scene` inside a rayon pool of `threads` threads.
fn run_on(scene: &Scene, spec: &str, steps: usize, threads: usize) -> (World, Vec<StepReport>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut w = world(scene, spec);
    pool.install(move || {
        let reports = w.run(steps);
        (w, reports)
    })
}

/// Poses and momenta equal to the bit.
fn assert_same_bodies(what: &str, a: &World, b: &World) {
    for (x, y) in a.bodies.iter().zip(&b.bodies) {
        assert_eq!(x.position, y.position, "{what}: {}", x.name);
        assert_eq!(x.orientation, y.orientation, "{what}: {}", x.name);
        assert_eq!(x.linear_momentum, y.linear_momentum, "{what}: {}", x.name);
        assert_eq!(x.angular_momentum, y.angular_momentum, "{what}: {}", x.name);
    }
}

/// The step is honest: `converged` only when the reported residual of the last solve meets
/// the tolerance; otherwise `soft-step` says `stalled` naming its soft model and the coloured
/// solve, the rigid ones `iteration_limit`. A coloured step's `residual_of` says so.
fn check_step(spec: &str, w: &World, r: &StepReport) {
    if r.rows == 0 {
        return;
    }
    let what = r.residual_of.as_deref().unwrap_or("");
    assert!(what.contains("coloured sweeps ("), "{spec}: `{what}`");
    let rel = r.residuals.as_ref().map_or(f64::NAN, |x| x.natural_map_rel);
    match &r.status {
        Status::Converged => assert!(
            rel <= w.settings.tolerance,
            "{spec}: converged at residual {rel} > {}",
            w.settings.tolerance
        ),
        Status::Stalled { reason } if spec.starts_with("soft-step") => {
            assert!(reason.contains("soft contacts and joints"), "{reason}");
            assert!(reason.contains("coloured sweeps"), "{reason}");
        }
        Status::IterationLimit if !spec.starts_with("soft-step") => {}
        s => panic!("{spec}: unexpected status {s:?}"),
    }
}

#[test]
fn coloured_runs_do_not_depend_on_the_thread_count() {
    // Within a colour the constraints move disjoint bodies and write back in a fixed order,
    // so 1, 2 and 3 threads give the same bits, warm starts and colour memory included.
    // pyramid_20 (210 boxes) has colours of some 40 constraints, split across the threads.
    for (name, spec) in [
        ("pyramid_20", "soft-step@colour=1"),
        ("pyramid_10", "tgs@colour=1"),
        ("pyramid_10", "pgs-ngs@colour=1"),
    ] {
        let s = scene(name);
        let (one, reports) = run_on(&s, spec, 30, 1);
        for r in &reports {
            check_step(spec, &one, r);
        }
        println!(
            "{spec}: {name}: {}",
            reports.last().unwrap().residual_of.as_deref().unwrap_or("")
        );
        for threads in [2, 3] {
            let (other, _) = run_on(&s, spec, 30, threads);
            assert_same_bodies(&format!("{spec} on {threads} threads"), &one, &other);
        }
    }
}

/// Boxes resting and sliding on the ground apart from each other, and pendulums on their own
/// pivots: no two constraints share a body.
fn independent_constraints() -> Scene {
    let mut text = String::from(
        "[settings]\ndt = 0.01\nfriction_model = \"box\"\ntolerance = 1e-8\nmax_iterations = 1000\n\
         prediction_distance = 0.01\n\
         [[materials]]\nname = \"m\"\nmu = 0.5\nrestitution = 0.3\n\
         [[bodies]]\nname = \"ground\"\nshape = { type = \"plane\", normal = [0.0, 0.0, 1.0] }\nstatic = true\nmaterial = \"m\"\n",
    );
    for i in 0..24 {
        let (x, z, vx) = (
            3.0 * i as f64,
            0.5 + 0.002 * (i % 3) as f64,
            0.4 * (i % 4) as f64,
        );
        text += &format!(
            "[[bodies]]\nname = \"box_{i}\"\nshape = {{ type = \"box\", half_extents = [0.5, 0.5, 0.5] }}\n\
             density = 1000.0\nmaterial = \"m\"\nposition = [{x}, 0.0, {z}]\nvelocity = [{vx}, 0.0, 0.0]\n"
        );
    }
    for i in 0..6 {
        let th = (5.0 + 5.0 * i as f64).to_radians();
        let (px, bx, bz) = (3.0 * i as f64, 3.0 * i as f64 + th.sin(), 3.0 - th.cos());
        text += &format!(
            "[[bodies]]\nname = \"bob_{i}\"\nshape = {{ type = \"sphere\", radius = 0.02 }}\nmass = 1.0\n\
             position = [{bx}, 10.0, {bz}]\n\
             [[joints]]\ntype = \"distance\"\nbodies = [\"world\", \"bob_{i}\"]\n\
             anchors = [[{px}, 10.0, 3.0], [{bx}, 10.0, {bz}]]\n"
        );
    }
    inline(&text)
}

#[test]
fn constraints_that_share_no_body_give_the_serial_answer_bit_for_bit() {
    // Only the order of the constraints differs between a coloured and a serial sweep; with
    // no body shared it cannot matter, so the runs agree to the bit (the block layout, the
    // copies of bodies and impulses in and out, the friction rows' normals are then exactly
    // the serial sweep's).
    let s = independent_constraints();
    for spec in COLOURED {
        let serial = spec.trim_end_matches("@colour=1");
        let (a, _) = run_on(&s, serial, 100, 1);
        let (b, reports) = run_on(&s, spec, 100, 3);
        let r = reports.last().unwrap();
        check_step(spec, &b, r);
        println!("{spec}: {}", r.residual_of.as_deref().unwrap_or(""));
        assert!(r.rows > 0);
        assert_same_bodies(spec, &a, &b);
    }
}

#[test]
fn coloured_soft_step_holds_tower_5_and_pyramid_5() {
    // tower_5: a soft contact of stiffness 4 m ω² (4 corner rows of m = 125 kg between two
    // 1000 kg unit boxes, ω = 2π · 30 Hz) under k boxes settles by k m_box g / (4 m ω²); the
    // ground contact (m = 250 kg, twice the hertz) under 5 boxes adds 0.35 mm: 5.9 mm in all.
    // That rest state is the springs', not the sweep order's, so the coloured sweep must
    // settle there too; the top must not lean.
    let spec = "soft-step@colour=1";
    let s = scene("tower_5");
    let mut w = world(&s, spec);
    let top = |w: &World| {
        w.bodies
            .iter()
            .map(|b| b.position.z)
            .fold(f64::MIN, f64::max)
    };
    let top0 = top(&w);
    for _ in 0..300 {
        let r = w.step();
        check_step(spec, &w, &r);
    }
    let omega2 = (2.0 * std::f64::consts::PI * 30.0_f64).powi(2);
    let box_box = (1..=4).map(|k| k as f64 * 1000.0 * G).sum::<f64>() / (4.0 * 125.0 * omega2);
    let ground = 5.0 * 1000.0 * G / (4.0 * 250.0 * 4.0 * omega2);
    let expected = box_box + ground;
    let sag = top0 - top(&w);
    let lateral = w
        .bodies
        .iter()
        .filter(|b| !b.is_static)
        .map(|b| b.position.x.hypot(b.position.y))
        .fold(0.0, f64::max);
    println!(
        "{spec}: tower_5 3 s: sag {sag:.3e} m (springs: {expected:.3e}), lateral {lateral:.3e} m"
    );
    assert!(
        (sag - expected).abs() < 0.2 * expected,
        "sag {sag}, expected {expected}"
    );
    assert!(lateral < 2e-3, "lateral {lateral}");

    // pyramid_5: every box stays within a centimetre of where it started over 3 s (the soft
    // contacts' sag is some millimetres).
    let s = scene("pyramid_5");
    let mut w = world(&s, spec);
    let p0: Vec<_> = w.bodies.iter().map(|b| b.position).collect();
    for _ in 0..300 {
        let r = w.step();
        check_step(spec, &w, &r);
    }
    let moved = w
        .bodies
        .iter()
        .zip(&p0)
        .map(|(b, p)| (b.position - p).norm())
        .fold(0.0, f64::max);
    println!("{spec}: pyramid_5 3 s: largest move {moved:.3e} m");
    assert!(moved < 1e-2, "moved {moved}");
}

#[test]
fn coloured_chain_joints_carry_the_weight_below_them() {
    // Coloured, the chain's joints alternate between two colours (red–black Gauss–Seidel),
    // the pivot's joint in a third; the rest state is the same: each joint's impulse over a
    // step is (weight below it) × h. tgs at 30 sweeps per substep, as in the serial test.
    let (links, end, dt) = (5, 20.0, 0.01);
    let s = hanging_chain(links, end, dt);
    for spec in ["soft-step@colour=1", "tgs@iterations=30,colour=1"] {
        let mut w = world(&s, spec);
        let mut last = None;
        for _ in 0..200 {
            let r = w.step();
            check_step(spec, &w, &r);
            last = Some(r);
        }
        let r = last.unwrap();
        println!("{spec}: chain: {}", r.residual_of.as_deref().unwrap_or(""));
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
        println!("{spec}: chain: worst relative joint impulse error {worst:.3e}");
    }
}

#[test]
fn the_colour_key_parses_defaults_to_serial_and_names_the_run() {
    for kind in [
        BodySolverKind::SoftStep,
        BodySolverKind::Tgs,
        BodySolverKind::PgsNgs,
    ] {
        let name = kind.name();
        let (_, p) = BodySolverKind::parse_spec(name).unwrap().unwrap();
        assert_eq!(p.count("colour"), 0, "{name}");
        let (_, p) = BodySolverKind::parse_spec(&format!("{name}@colour=1"))
            .unwrap()
            .unwrap();
        assert_eq!(p.count("colour"), 1, "{name}");
        // The parameters written back (the form results and CSV rows name a run by) carry it.
        assert_eq!(p.to_string(), "colour=1", "{name}");
        assert_eq!(kind.create_with(p).params(), p);
        for bad in ["colour=2", "colour=0.5", "colour=-1"] {
            let e = BodySolverKind::parse_spec(&format!("{name}@{bad}")).unwrap_err();
            assert!(e.contains("colour"), "{name}@{bad}: {e}");
        }
    }
    // The serial run's report does not speak of colours; the coloured one names its colours.
    let s = scene("pyramid_5");
    for spec in ["soft-step", "tgs", "pgs-ngs"] {
        let mut w = world(&s, spec);
        let r = w.step();
        let what = r.residual_of.unwrap_or_default();
        assert!(!what.contains("colour"), "{spec}: {what}");
        let coloured = format!("{spec}@colour=1");
        let mut w = world(&s, &coloured);
        let r = w.step();
        check_step(&coloured, &w, &r);
        let what = r.residual_of.as_deref().unwrap_or("");
        println!("{coloured}: {what}");
        // 15 boxes: 5 on the ground, 10 on two boxes each: 25 constraints.
        assert!(
            what.contains("(25 constraints in ") && what.ends_with(", 0 in overflow)"),
            "{coloured}: {what}"
        );
    }
}

/// [`common::hanging_chain`] stepped at `dt`, tolerance 1e-8, 1,000 sweeps at most.
fn hanging_chain(links: usize, end: f64, dt: f64) -> Scene {
    common::hanging_chain(
        links,
        end,
        &format!("dt = {dt}\nfriction_model = \"box\"\ntolerance = 1e-8\nmax_iterations = 1000"),
    )
}

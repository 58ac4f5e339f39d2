//! Joints through the whole pipeline: analytic pendulum periods, the joint forces of a static
//! chain, the scene format's errors, and the solvers that refuse joints.

use lcpbench_contact::{ContactSolver, Scene, World};
use lcpbench_solvers::Status;
use std::path::PathBuf;

mod common;
use common::inline;

const G: f64 = 9.81;

fn with_solver(scene: &Scene, name: &str) -> World {
    let mut w = scene.world();
    w.set_solver(ContactSolver::from_name(name).expect("known solver"));
    w
}

/// A pendulum: a ball of radius `r` whose centre hangs `length` below a fixed pivot at
/// `z = 2`, started `degrees` from the vertical, held by a distance joint (a massless rod to
/// the centre: a simple pendulum) or a ball joint at the pivot (a physical pendulum).
fn pendulum(kind: &str, r: f64, length: f64, degrees: f64) -> Scene {
    let th = degrees.to_radians();
    let (x, z) = (length * th.sin(), 2.0 - length * th.cos());
    let joint = match kind {
        "distance" => format!("anchors = [[0.0, 0.0, 2.0], [{x}, 0.0, {z}]]"),
        _ => "anchor = [0.0, 0.0, 2.0]".to_owned(),
    };
    inline(&format!(
        r#"
        [settings]
        dt = 0.001
        friction_model = "none"
        tolerance = 1e-10
        max_iterations = 10000
        [[bodies]]
        name = "bob"
        shape = {{ type = "sphere", radius = {r} }}
        mass = 1.0
        position = [{x}, 0.0, {z}]
        [[joints]]
        type = "{kind}"
        bodies = ["world", "bob"]
        {joint}
        "#
    ))
}

/// Mean period from the upward zero crossings of the bob's `x` over `steps` steps.
fn measured_period(world: &mut World, steps: usize) -> f64 {
    let mut crossings = Vec::new();
    let mut prev = world.bodies[0].position.x;
    for _ in 0..steps {
        let report = world.step();
        assert!(report.status.is_converged(), "{:?}", report.status);
        let x = world.bodies[0].position.x;
        if prev < 0.0 && x >= 0.0 {
            // Linear interpolation of the crossing time within the step.
            let dt = world.settings.dt;
            crossings.push(world.time - dt * x / (x - prev));
        }
        prev = x;
    }
    assert!(crossings.len() >= 2, "only {} crossings", crossings.len());
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
}

/// Period of a pendulum of small amplitude `th0` (rad): `T₀ (1 + th0²/16)`.
fn finite_amplitude(t0: f64, th0: f64) -> f64 {
    t0 * (1.0 + th0 * th0 / 16.0)
}

#[test]
fn simple_pendulum_period_matches_the_analytic_one() {
    let (length, deg) = (1.0, 5.0);
    let exact = finite_amplitude(
        2.0 * std::f64::consts::PI * (length / G).sqrt(),
        f64::to_radians(deg),
    );
    let scene = pendulum("distance", 0.02, length, deg);
    for solver in ["dantzig", "lemke", "pgs", "si", "newton-fb", "enum"] {
        let mut w = with_solver(&scene, solver);
        let t = measured_period(&mut w, 5000);
        println!("{solver}: period {t:.9} s, analytic {exact:.9} s");
        assert!(
            ((t - exact) / exact).abs() < 1e-5,
            "{solver}: period {t} s against {exact} s"
        );
    }
}

#[test]
fn physical_pendulum_period_matches_the_analytic_one() {
    // A ball of radius r on a ball joint `length` above its centre: T = 2π √(I_p / (m g L)),
    // I_p = (2/5) m r² + m L² (the angular rows carry the ball's own rotation).
    let (r, length, deg) = (0.1, 0.8, 4.0);
    let ip = 0.4 * r * r + length * length;
    let exact = finite_amplitude(
        2.0 * std::f64::consts::PI * (ip / (G * length)).sqrt(),
        f64::to_radians(deg),
    );
    let scene = pendulum("ball", r, length, deg);
    for solver in ["dantzig", "lemke", "si"] {
        let mut w = with_solver(&scene, solver);
        let t = measured_period(&mut w, 4000);
        println!("{solver}: period {t:.9} s, analytic {exact:.9} s");
        assert!(
            ((t - exact) / exact).abs() < 1e-5,
            "{solver}: period {t} s against {exact} s"
        );
        assert!(
            w.step().joint_drift_max < 1e-6,
            "{solver}: the joint drifted"
        );
    }
}

#[test]
fn static_chain_joint_forces_equal_the_weight_below_each_joint() {
    let (links, end) = (5, 20.0);
    let scene = hanging_chain(links, end);
    for solver in [
        "dantzig",
        "lemke",
        "enum",
        "pgs",
        "si",
        "newton-fb",
        "newton-min",
        "nsgs",
    ] {
        let mut w = with_solver(&scene, solver);
        let report = w.step();
        assert!(
            report.status.is_converged(),
            "{solver}: {:?}",
            report.status
        );
        assert_eq!(report.joint_rows, 3 * (links + 1));
        for (k, joint) in report.joint_records.iter().enumerate() {
            // Joint k holds links k.. and the end mass: impulse = weight below × h.
            let below = (links - k) as f64 + end;
            let expected = below * G * w.settings.dt;
            assert!(
                (joint.impulse - expected).abs() <= 1e-6 * expected,
                "{solver}: joint {k} impulse {} against {expected}",
                joint.impulse
            );
        }
        assert!(
            report.joint_drift_max < 1e-9,
            "{solver}: {}",
            report.joint_drift_max
        );
    }
}

#[test]
fn solvers_without_joint_rows_say_unsupported() {
    let scene = hanging_chain(3, 1.0);
    for solver in ["body-micro", "penalty"] {
        let mut w = with_solver(&scene, solver);
        let r = w.step();
        assert!(
            matches!(&r.status, Status::Unsupported { reason } if reason.contains("joints")),
            "{solver}: {:?}",
            r.status
        );
    }
    let mut w = scene.world();
    w.settings.builder.friction_model = lcpbench_contact::FrictionModel::Cone;
    w.set_solver(ContactSolver::from_name("nsgs-cone").unwrap());
    let r = w.step();
    assert!(
        matches!(&r.status, Status::Unsupported { reason } if reason.contains("joint")),
        "{:?}",
        r.status
    );
}

#[test]
fn removing_a_body_removes_its_joints() {
    let mut text = String::from(
        "[settings]\ndt = 0.01\nfriction_model = \"none\"\n[[events]]\nat_step = 2\nremove = \"link_1\"\n",
    );
    for i in 0..3 {
        let z = 2.0 - 0.05 - 0.1 * i as f64;
        text += &format!(
            "[[bodies]]\nname = \"link_{i}\"\nshape = {{ type = \"box\", half_extents = [0.02, 0.02, 0.05] }}\nmass = 1.0\nposition = [0.0, 0.0, {z}]\n"
        );
    }
    for (i, (a, b)) in [
        ("world", "link_0"),
        ("link_0", "link_1"),
        ("link_1", "link_2"),
    ]
    .iter()
    .enumerate()
    {
        let z = 2.0 - 0.1 * i as f64;
        text += &format!(
            "[[joints]]\ntype = \"ball\"\nbodies = [\"{a}\", \"{b}\"]\nanchor = [0.0, 0.0, {z}]\n"
        );
    }
    let scene = inline(&text);
    let mut w = with_solver(&scene, "dantzig");
    w.run(2);
    assert_eq!(w.joints.len(), 3);
    let r = w.step();
    assert_eq!(w.joints.len(), 1);
    assert_eq!(r.joint_rows, 3);
    // link_0 still hangs from the world; link_2 (now body 1) falls freely.
    w.run(10);
    assert!((w.bodies[0].position.z - 1.95).abs() < 1e-6);
    assert!(w.bodies[1].position.z < 1.7);
}

#[test]
fn bad_joint_tables_name_the_field() {
    let base = r#"
        [[bodies]]
        name = "a"
        shape = { type = "sphere", radius = 0.1 }
        [[bodies]]
        name = "b"
        shape = { type = "sphere", radius = 0.1 }
        position = [1.0, 0.0, 0.0]
    "#;
    let cases = [
        ("type = \"slider\"\nbodies = [\"a\", \"b\"]\nanchor = [0.5, 0.0, 0.0]", "joints[0].type", "slider"),
        ("type = \"ball\"\nbodies = [\"a\", \"c\"]\nanchor = [0.5, 0.0, 0.0]", "joints[0].bodies", "\"c\""),
        ("type = \"ball\"\nbodies = [\"a\", \"a\"]\nanchor = [0.5, 0.0, 0.0]", "joints[0].bodies", "twice"),
        ("type = \"hinge\"\nbodies = [\"a\", \"b\"]\nanchor = [0.5, 0.0, 0.0]", "joints[0].axis", "axis"),
        ("type = \"hinge\"\nbodies = [\"a\", \"b\"]\nanchor = [0.5, 0.0, 0.0]\naxis = [0.0, 0.0, 0.0]", "joints[0].axis", "non-zero"),
        ("type = \"distance\"\nbodies = [\"a\", \"b\"]\nanchor = [0.5, 0.0, 0.0]", "joints[0].anchors", "anchors"),
        ("type = \"ball\"\nbodies = [\"a\", \"b\"]\nanchor = [0.5, 0.0, 0.0]\nlength = 1.0", "joints[0].length", "distance"),
        ("type = \"ball\"\nbodies = [\"a\", \"b\"]\nanchor = [0.5, 0.0, 1e300]", "joints[0].anchor", "within"),
    ];
    for (joint, field, message) in cases {
        let text = format!("{base}\n[[joints]]\n{joint}\n");
        let err = Scene::parse(&text, &PathBuf::from("j.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(field) && err.contains(message),
            "{joint}: {err}"
        );
    }
}

#[test]
fn split_impulses_correct_joint_error_like_baumgarte() {
    // A chain started 1 cm off its joints: both corrections pull it back, none leaves it.
    let mut errors = Vec::new();
    for correction in ["none", "baumgarte", "split"] {
        let scene = hanging_chain(4, 1.0);
        let mut w = with_solver(&scene, "dantzig");
        w.settings.builder.position_correction =
            lcpbench_contact::PositionCorrection::from_name(correction).unwrap();
        w.bodies[2].position.x += 0.01;
        let r = w.run(60);
        errors.push(r.last().unwrap().joint_drift_max);
    }
    println!("final drift none / baumgarte / split: {errors:?}");
    assert!(errors[0] > 5e-3, "{errors:?}");
    assert!(errors[1] < 1e-4 && errors[2] < 1e-4, "{errors:?}");
}

/// [`common::hanging_chain`] at dt = 0.01 s.
fn hanging_chain(links: usize, end: f64) -> Scene {
    common::hanging_chain(
        links,
        end,
        "dt = 0.01\nfriction_model = \"box\"\ntolerance = 1e-10\nmax_iterations = 100000",
    )
}

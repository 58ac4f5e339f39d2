//! Stepping behaviour beyond the analytic scenes: continuous collision detection against
//! tunnelling, split impulses, the penalty baseline and warm starting.

use lcpbench_contact::{Scene, ContactSolver};
use std::path::Path;

fn bullet(ccd: &str) -> Scene {
    // A 2 cm sphere at 50 m/s toward a 2 cm thick wall: 0.5 m per step, and no end-of-step
    // position (0.13, 0.63, 1.13, ...) overlaps the wall.
    let text = format!(
        r#"
        [settings]
        dt = 0.01
        steps = 20
        gravity = [0.0, 0.0, 0.0]
        friction_model = "none"
        ccd = "{ccd}"
        [[bodies]]
        name = "wall"
        shape = {{ type = "box", half_extents = [0.01, 0.5, 0.5] }}
        position = [1.0, 0.0, 0.0]
        static = true
        [[bodies]]
        name = "bullet"
        shape = {{ type = "sphere", radius = 0.02 }}
        position = [0.13, 0.0, 0.0]
        velocity = [50.0, 0.0, 0.0]
        "#
    );
    Scene::parse(&text, Path::new("bullet.toml")).unwrap()
}

#[test]
fn fast_sphere_tunnels_without_ccd_and_stops_with_it() {
    let face = 1.0 - 0.01 - 0.02;
    let mut w = bullet("none").world();
    w.run(20);
    let x = w.bodies[1].position.x;
    println!("no ccd: bullet at x = {x:.3} (wall at 1.0)");
    assert!(x > 1.5, "expected tunnelling, bullet at {x}");

    for method in ["bisection", "conservative"] {
        let mut w = bullet(method).world();
        let reports = w.run(20);
        let x = w.bodies[1].position.x;
        let toi = reports.iter().find_map(|r| r.time_of_impact);
        println!("ccd {method}: bullet at x = {x:.6}, centre face at {face}, first toi {toi:?}");
        assert!(toi.is_some());
        assert!(
            x <= face + 1e-9 && x > face - 1e-3,
            "{method}: bullet at {x}"
        );
        assert!(
            w.bodies[1].velocity().x <= 1e-9,
            "{method}: still moving into the wall"
        );
    }
}

#[test]
fn split_impulses_remove_penetration_without_adding_momentum() {
    let text = r#"
        [settings]
        dt = 0.01
        gravity = [0.0, 0.0, -9.81]
        friction_model = "none"
        position_correction = "split"
        baumgarte = 0.5
        slop = 0.0
        [[bodies]]
        name = "ground"
        shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
        static = true
        [[bodies]]
        name = "ball"
        shape = { type = "sphere", radius = 0.1 }
        position = [0.0, 0.0, 0.08]
    "#;
    let s = Scene::parse(text, Path::new("split.toml")).unwrap();
    let mut w = s.world();
    let reports = w.run(30);
    let z = w.bodies[1].position.z;
    let vz = w.bodies[1].velocity().z;
    println!(
        "split: penetration {:.3e} -> {:.3e}, final velocity {vz:.3e}",
        reports[0].max_penetration,
        0.1 - z
    );
    assert!((0.1 - z).abs() < 1e-6, "penetration left: {}", 0.1 - z);
    assert!(
        vz.abs() < 1e-9,
        "split impulses must not add momentum: v = {vz}"
    );
}

#[test]
fn penalty_baseline_holds_a_box_with_small_penetration() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench_scenes/box_on_ground.toml");
    let s = Scene::load(path).unwrap();
    let mut w = s.world();
    w.set_solver(ContactSolver::from_name("penalty").unwrap());
    let reports = w.run(300);
    let pen = reports.last().unwrap().max_penetration;
    let z = w.bodies[1].position.z;
    println!("penalty: box at z = {z:.5} (rest 0.5), penetration {pen:.3e} m");
    // Static penetration m g / Σk with k = m_eff ω², ω = 0.3/h: of the order of g/ω² = 1 cm.
    assert!(pen > 0.0 && pen < 1.5e-2, "penetration {pen}");
    assert!((z - 0.5).abs() < 1.5e-2);
    assert!(w.bodies[1].velocity().norm() < 1e-3);
}

#[test]
fn warm_starting_cuts_sequential_impulse_sweeps() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench_scenes/box_on_ground.toml");
    let s = Scene::load(path).unwrap();
    let mut sweeps = Vec::new();
    for warm in [false, true] {
        let mut w = s.world();
        w.set_solver(ContactSolver::from_name("si").unwrap());
        w.settings.warm_start = warm;
        let reports = w.run(100);
        let mean = reports[50..].iter().map(|r| r.iterations).sum::<usize>() as f64 / 50.0;
        println!("si on box_on_ground, warm start {warm}: {mean:.1} sweeps per step");
        sweeps.push(mean);
    }
    assert!(sweeps[1] < 0.5 * sweeps[0], "{sweeps:?}");
}

#[test]
fn overflowing_body_level_step_is_a_numerical_failure_not_stalled() {
    // A closing speed of 1e308 m/s (set past the scene loader, which refuses it) overflows the
    // contact system; body-level solvers used to report `stalled` with no residual.
    let text = r#"
        [settings]
        friction_model = "none"
        [[bodies]]
        name = "ground"
        shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
        static = true
        [[bodies]]
        name = "ball"
        shape = { type = "sphere", radius = 0.5 }
        position = [0.0, 0.0, 0.5]
        mass = 1e6
    "#;
    let scene = Scene::parse(text, Path::new("overflow.toml")).unwrap();
    for solver in ["si", "body-micro", "penalty"] {
        let mut world = scene.world();
        world.set_solver(ContactSolver::from_name(solver).unwrap());
        let ball = &mut world.bodies[1];
        ball.linear_momentum = nalgebra::Vector3::new(0.0, 0.0, -1e308 * ball.mass);
        let report = world.step();
        assert_eq!(report.rows, 1, "{solver}");
        assert_eq!(
            report.status.name(),
            "numerical_failure",
            "{solver}: {:?}",
            report.status
        );
    }
}

/// Two towers of five boxes, 3 m apart: two islands of the same size.
fn two_towers(solver: &str) -> Scene {
    let text = format!(
        r#"
        [settings]
        dt = 0.01
        solver = "{solver}"
        tolerance = 1e-12
        max_iterations = 100000
        [[bodies]]
        name = "ground"
        shape = {{ type = "plane", normal = [0.0, 0.0, 1.0] }}
        static = true
        [[bodies]]
        name = "box"
        shape = {{ type = "box", half_extents = [0.5, 0.5, 0.5] }}
        position = [0.0, 0.0, 0.49]
        repeat = {{ count = [2, 1, 5], spacing = [3.0, 0.0, 0.999] }}
        "#
    );
    Scene::parse(&text, Path::new("two_towers.toml")).unwrap()
}

#[test]
fn islands_of_two_towers_solve_to_the_impulses_of_the_whole() {
    for solver in ["dantzig", "pgs"] {
        let mut split = two_towers(solver).world();
        let mut whole = two_towers(solver).world();
        whole.settings.islands = false;
        for step in 0..3 {
            let (a, b) = (split.step(), whole.step());
            assert_eq!(a.islands, 2, "{solver} step {step}");
            assert_eq!(a.island_rows.len(), 2);
            assert_eq!(a.island_rows[0], a.island_rows[1], "the towers are alike");
            assert_eq!(a.island_rows.iter().sum::<usize>(), a.rows);
            assert!(
                a.status.is_converged() && b.status.is_converged(),
                "{solver}"
            );
            assert_eq!(a.contact_records.len(), b.contact_records.len());
            let scale = b
                .contact_records
                .iter()
                .map(|c| c.impulse[2].abs())
                .fold(0.0, f64::max);
            assert!(scale > 1.0, "the towers load their contacts");
            if solver == "dantzig" {
                // A pivoting solve of each island is the solve of the whole restricted to it.
                for (ca, cb) in a.contact_records.iter().zip(&b.contact_records) {
                    for k in 0..3 {
                        let d = (ca.impulse[k] - cb.impulse[k]).abs();
                        assert!(
                            d <= 1e-10 * scale,
                            "{solver} step {step}: island impulse differs by {d:e}"
                        );
                    }
                }
            }
            // Four contacts per face make A rank-deficient, so PGS impulses are unique only up
            // to its null space; the momentum they apply (hence every velocity) is unique.
            for (ba, bb) in split.bodies.iter().zip(&whole.bodies) {
                let d = (ba.velocity() - bb.velocity()).norm();
                assert!(
                    d <= 1e-9,
                    "{solver} step {step}: velocities differ by {d:e}"
                );
            }
        }
    }
}

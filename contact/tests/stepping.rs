//! Stepping behaviour beyond the analytic scenes: continuous collision detection against
//! tunnelling, split impulses, the penalty baseline and warm starting.

use lcpbench_contact::{ContactSolver, Scene};
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

/// Statuses, sweeps and impulses of the body-level solvers behind [`BodySolver`], pinned to the
/// values the stepper produced before they shared the status rule of the matrix solvers. The
/// residuals' digits follow the shared residual's arithmetic (four interleaved partial sums per
/// dense row; a row's step inside its bounds taken as `|w_i| / d_i`, not as the difference of two
/// nearly equal impulses); the impulses do not depend on it.
#[test]
fn body_level_statuses_iterations_and_impulses_are_pinned() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench_scenes");
    // (scene, solver, per step: status, iterations, sum of normal impulses, relative residual)
    type Pin = (&'static str, usize, f64, f64);
    let cases: [(&str, &str, [Pin; 3]); 3] = [
        (
            "cradle_3.toml",
            "si",
            [
                ("stalled", 3, 2.0, 0.3333333333333333),
                ("converged", 2, 0.0, 0.0),
                ("converged", 2, 0.0, 0.0),
            ],
        ),
        (
            "box_on_ground.toml",
            "si",
            [
                ("converged", 24, 98.09999988819362, 1.204366981893673e-9),
                ("converged", 1, 98.0999999480567, 1.119802603820214e-9),
                ("converged", 1, 98.10000002855068, 6.71928104693454e-10),
            ],
        ),
        (
            "box_on_ground.toml",
            "penalty",
            [
                ("stalled", 1, 0.0, 1.0),
                ("stalled", 1, 86.81850000000006, 0.295755968169761),
                ("stalled", 1, 101.40106500000002, 0.27908797908893657),
            ],
        ),
    ];
    for (scene, solver, pins) in cases {
        let s = Scene::load(dir.join(scene)).unwrap();
        let mut w = s.world();
        w.set_solver(ContactSolver::from_name(solver).unwrap());
        for (step, (status, iterations, impulse, residual)) in pins.into_iter().enumerate() {
            let r = w.step();
            let sum: f64 = r.contact_records.iter().map(|c| c.normal_impulse).sum();
            let rel = r.residuals.as_ref().unwrap().natural_map_rel;
            let at = format!("{scene} {solver} step {step}");
            assert_eq!(r.status.name(), status, "{at}: {}", r.status);
            assert_eq!(r.iterations, iterations, "{at}");
            assert_eq!(sum.to_bits(), impulse.to_bits(), "{at}: {sum}");
            assert_eq!(rel.to_bits(), residual.to_bits(), "{at}: {rel}");
        }
    }
    // The stall names the soft model penalty solves in place of the LCP, and the residual of
    // its forces on the step's LCP.
    let s = Scene::load(dir.join("box_on_ground.toml")).unwrap();
    let mut w = s.world();
    w.set_solver(ContactSolver::from_name("penalty").unwrap());
    let reason = w.step().status.reason().unwrap_or_default().to_owned();
    assert!(
        reason.starts_with("penalty solved a soft spring-damper penalty model")
            && reason.contains("not the step's LCP")
            && reason.contains("relative residual on the step's LCP 1.000e0 > tolerance"),
        "{reason}"
    );
}

/// A clone of a configured solver instance gives the same steps as the instance itself, and
/// islands solved with clones agree with the whole-step solve of the same instance.
#[test]
fn solver_instances_clone_to_identical_steps() {
    use lcpbench_solvers::ProjectedSor;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench_scenes");
    let s = Scene::load(dir.join("dominoes.toml")).unwrap();
    let sor = ContactSolver::Matrix(Box::new(ProjectedSor::sor(1.1)));
    let run = |solver: ContactSolver, islands: bool| {
        let mut w = s.world();
        w.settings.islands = islands;
        w.set_solver(solver);
        let reports = w.run(40);
        let last = w.bodies.iter().map(|b| b.position).collect::<Vec<_>>();
        (
            reports.iter().map(|r| r.iterations).collect::<Vec<_>>(),
            last,
        )
    };
    let (it_a, pos_a) = run(sor.clone(), true);
    let (it_b, pos_b) = run(sor.clone(), true);
    assert_eq!(it_a, it_b);
    assert_eq!(pos_a, pos_b);
    // omega reaches the steps: SOR 1.1 differs from PGS on the same scene.
    let (it_pgs, _) = run(ContactSolver::from_name("pgs").unwrap(), true);
    assert_ne!(it_a, it_pgs);
    assert_eq!(sor.name(), "sor");
}

/// Two towers of ten boxes, 3 m apart: two islands of 120 rows each (box friction), large
/// enough that Newton solves them on its sparse system and keeps its symbolic analysis.
fn two_tall_towers(solver: &str) -> Scene {
    let text = format!(
        r#"
        [settings]
        dt = 0.01
        solver = "{solver}"
        [[bodies]]
        name = "ground"
        shape = {{ type = "plane", normal = [0.0, 0.0, 1.0] }}
        static = true
        [[bodies]]
        name = "box"
        shape = {{ type = "box", half_extents = [0.5, 0.5, 0.5] }}
        position = [0.0, 0.0, 0.499]
        repeat = {{ count = [2, 1, 10], spacing = [3.0, 0.0, 0.999] }}
        "#
    );
    Scene::parse(&text, Path::new("two_tall_towers.toml")).unwrap()
}

/// The solvers of a step's islands are kept for the next step's islands of the same bodies and
/// rows, and a kept solver (with its workspace: Newton's symbolic analysis) steps exactly as a
/// fresh clone: statuses, iterations, residuals and poses are bit-identical to a world that
/// drops its island solvers before every step.
#[test]
fn kept_island_solvers_step_exactly_as_fresh_ones() {
    for solver in ["newton-fb", "pgs", "lemke"] {
        let mut kept = two_tall_towers(solver).world();
        let mut fresh = two_tall_towers(solver).world();
        let mut reused = 0;
        for step in 0..12 {
            fresh.forget_island_solvers();
            let (a, b) = (kept.step(), fresh.step());
            assert_eq!(a.islands, 2, "{solver} step {step}");
            assert_eq!(fresh.reused_island_solvers(), 0);
            reused += kept.reused_island_solvers();
            assert_eq!(kept.kept_island_solvers(), 2);
            assert_eq!(a.status, b.status, "{solver} step {step}");
            assert_eq!(a.iterations, b.iterations, "{solver} step {step}");
            assert_eq!(
                a.residuals.map(|r| r.natural_map_rel.to_bits()),
                b.residuals.map(|r| r.natural_map_rel.to_bits()),
                "{solver} step {step}"
            );
            for (ba, bb) in kept.bodies.iter().zip(&fresh.bodies) {
                assert_eq!(ba.position, bb.position, "{solver} step {step}");
                assert_eq!(ba.orientation, bb.orientation, "{solver} step {step}");
                assert_eq!(
                    ba.linear_momentum, bb.linear_momentum,
                    "{solver} step {step}"
                );
            }
        }
        // Every step after the first finds both towers' patterns again (the contact count of a
        // resting tower does not change).
        assert!(
            reused >= 2 * 10,
            "{solver}: {reused} islands reused a solver"
        );
        // A new solver drops the kept ones.
        kept.set_solver(ContactSolver::from_name("pgs").unwrap());
        assert_eq!(kept.kept_island_solvers(), 0);
    }
}

/// Each body's parry shape is built once, when the pipeline first sees the body, and not again
/// on later steps; a body whose shape changes gets a new one.
#[test]
fn parry_shapes_are_built_once_per_body() {
    let mut w = two_tall_towers("pgs").world();
    let n = w.bodies.len();
    for _ in 0..5 {
        w.step();
        assert_eq!(w.pipeline.narrow_phase().shapes().built(), n);
    }
    let top = n - 1;
    w.bodies[top].shape = lcpbench_contact::Shape::sphere(0.5).unwrap();
    w.step();
    assert_eq!(w.pipeline.narrow_phase().shapes().built(), n + 1);
}

/// Persistent manifolds on a resting stack: the contacts each step uses are those of the
/// default detection (manifolds computed every step), as many per pair, with points, gaps and
/// normals within the thresholds the manifolds are kept for, and most pairs are kept rather
/// than computed.
#[test]
fn persistent_manifolds_on_a_resting_stack_match_the_default_detection() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench_scenes");
    let scene = Scene::load(dir.join("tower_10.toml")).unwrap();
    let mut w = scene.world();
    w.settings.persistent_manifolds = true;
    let prediction = w.settings.prediction_distance;
    // The reference: the default pipeline (fresh manifolds every step, apart from the reuse
    // inside parry's own box generator, which both pipelines share) on the same bodies.
    let mut reference = lcpbench_contact::CollisionPipeline::new();
    let mut kept_pairs = 0;
    for step in 0..60 {
        w.pipeline.narrow_phase_mut().persistent_manifolds = true;
        let kept = w.pipeline.detect(&w.bodies, prediction).unwrap();
        kept_pairs += w.pipeline.narrow_phase().kept_pairs();
        let fresh = reference.detect(&w.bodies, prediction).unwrap();
        assert_eq!(kept.len(), fresh.len(), "step {step}");
        // Contacts come grouped by pair, pairs in the same order; within a pair, each kept
        // point has a fresh one at the same place (a fresh computation may start from the other
        // box's face, which numbers the features, hence the keys, differently).
        for k in &kept {
            let near = fresh.iter().any(|f| {
                (f.body_a, f.body_b) == (k.body_a, k.body_b)
                    && (k.point - f.point).norm() <= 2e-4
                    && (k.dist - f.dist).abs() <= 2e-4
                    && (k.normal - f.normal).norm() <= 2e-3
            });
            assert!(near, "step {step}: no fresh contact near {k:?}");
        }
        for (k, f) in kept.iter().zip(&fresh) {
            assert_eq!((k.body_a, k.body_b), (f.body_a, f.body_b), "step {step}");
        }
        w.step();
    }
    // Once the tower settles its pairs are kept on most steps (258 of the 600 pair-steps when
    // this was written, the rest computed when a pair's motion reaches the thresholds).
    assert!(
        kept_pairs > 600 / 3,
        "{kept_pairs} pairs kept over 60 steps"
    );
    let top = w.bodies.last().unwrap().position.z;
    assert!((top - 9.5).abs() < 0.05, "the tower stands: top at {top}");
}

/// The residual schedule applies to matrix and cone solvers too, on the whole-step and the
/// per-island paths: steps off the schedule report no residual and are never `converged`,
/// scheduled steps carry the residual, and the schedule changes the measurement only (the
/// poses after every step are bit for bit those of a run that measures every step).
#[test]
fn residual_schedule_applies_to_matrix_and_cone_solvers() {
    use lcpbench_contact::step::ResidualSchedule;
    let scene = |model: &str, islands: bool| {
        let text = format!(
            r#"
            [settings]
            dt = 0.01
            steps = 7
            friction_model = "{model}"
            islands = {islands}
            [[bodies]]
            name = "ground"
            shape = {{ type = "plane", normal = [0.0, 0.0, 1.0] }}
            static = true
            [[bodies]]
            name = "a"
            shape = {{ type = "box", half_extents = [0.5, 0.5, 0.5] }}
            position = [0.0, 0.0, 0.5]
            [[bodies]]
            name = "b"
            shape = {{ type = "box", half_extents = [0.5, 0.5, 0.5] }}
            position = [3.0, 0.0, 0.5]
            "#
        );
        Scene::parse(&text, Path::new("inline.toml")).unwrap()
    };
    for (solver, model, islands) in [
        ("pgs", "box", false),
        ("pgs", "box", true),
        ("newton-fb", "pyramid", true),
        ("nsgs-cone", "cone", false),
        ("nsgs-cone", "cone", true),
    ] {
        let run = |schedule: ResidualSchedule| {
            let mut world = scene(model, islands).world();
            world.set_solver(ContactSolver::from_name(solver).unwrap());
            world.settings.max_iterations = 3;
            world.settings.residual = schedule;
            let reports = world.run(7);
            let poses: Vec<_> = world
                .bodies
                .iter()
                .map(|b| (b.position, b.orientation))
                .collect();
            (reports, poses)
        };
        let (every, every_poses) = run(ResidualSchedule::Every);
        let (sampled, sampled_poses) = run(ResidualSchedule::Sample(3));
        assert_eq!(every_poses, sampled_poses, "{solver} islands={islands}");
        let measured: Vec<usize> = sampled
            .iter()
            .filter(|r| r.residual_measured)
            .map(|r| r.step)
            .collect();
        assert_eq!(measured, [0, 3, 6], "{solver} islands={islands}");
        for (e, s) in every.iter().zip(&sampled) {
            assert!(e.residual_measured && e.residuals.is_some(), "{solver}");
            assert_eq!(e.contacts, s.contacts);
            if s.residual_measured {
                assert_eq!(e.residuals, s.residuals, "{solver} step {}", s.step);
                assert_eq!(e.status, s.status, "{solver} step {}", s.step);
            } else {
                assert!(s.residuals.is_none(), "{solver} step {}", s.step);
                assert!(!s.status.is_converged(), "{solver} step {}", s.step);
            }
        }
    }
}

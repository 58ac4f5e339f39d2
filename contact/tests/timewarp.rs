//! Timewarp stepping against analytic impact times, the fixed step, the synchronous reference
//! and itself under another processing order; tunnelling under every stepping mode.

use lcpbench_contact::collision::toi::ToiMethod;
use lcpbench_contact::discontinuity::{bouncing_ball_impacts, DiscontinuityMeter};
use lcpbench_contact::scene::Scene;
use lcpbench_contact::step::World;
use lcpbench_contact::timewarp::{Scheduling, Stepper, Stepping, Timewarp, TimewarpSettings};
use std::path::{Path, PathBuf};

fn bench_scene(name: &str) -> Scene {
    let path: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "bench_scenes", name]
        .iter()
        .collect();
    Scene::load(&path).unwrap()
}

fn timewarp(world: World, scheduling: Scheduling) -> Timewarp {
    Timewarp::new(
        world,
        TimewarpSettings {
            scheduling,
            ..TimewarpSettings::default()
        },
    )
}

/// Largest difference in position and velocity between the bodies of two worlds.
fn max_difference(a: &World, b: &World) -> f64 {
    a.bodies
        .iter()
        .zip(&b.bodies)
        .map(|(x, y)| {
            (x.position - y.position)
                .norm()
                .max((x.velocity() - y.velocity()).norm())
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_bouncing_ball_hits_the_ground_within_a_nanosecond_of_the_analytic_times() {
    let scene = Scene::parse(
        r#"
        [settings]
        dt = 0.016666666666666666
        steps = 120
        friction_model = "none"
        tolerance = 1e-10
        restitution_threshold = 0.1
        [[materials]]
        name = "rubber"
        restitution = 0.9
        [[bodies]]
        name = "ground"
        shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
        static = true
        material = "rubber"
        [[bodies]]
        name = "ball"
        shape = { type = "sphere", radius = 0.1 }
        mass = 1.0
        position = [0.0, 0.0, 1.1]
        material = "rubber"
        "#,
        Path::new("ball.toml"),
    )
    .unwrap();
    let mut tw = timewarp(scene.world(), Scheduling::Ascending);
    for _ in 0..120 {
        tw.step();
    }
    // Independent check: the impact times in closed form (1 m drop, e = 0.9).
    let expected = bouncing_ball_impacts(1.0, 9.81, 0.9, 0.1, 2.0);
    assert_eq!(expected.len(), 3, "{expected:?}");
    let t1 = (2.0f64 / 9.81).sqrt();
    assert!((expected[1].0 - (t1 + 2.0 * 0.9 * t1)).abs() < 1e-12);
    assert_eq!(tw.impacts.len(), expected.len(), "{:?}", tw.impacts);
    for (imp, (t, _)) in tw.impacts.iter().zip(&expected) {
        assert!((imp.time - t).abs() < 1e-9, "{} vs {t}", imp.time);
    }
    // Between impacts the flight is exact: at 2 s the ball is where the closed form puts it.
    let t3 = expected[2].0;
    let v = 9.81 * t1 * 0.9f64.powi(3);
    let tau = 2.0 - t3;
    let height = 0.1 + v * tau - 0.5 * 9.81 * tau * tau;
    assert!((tw.world.bodies[1].position.z - height).abs() < 1e-8);
}

#[test]
fn a_stack_under_timewarp_is_the_fixed_step() {
    let scene = bench_scene("tower_5.toml");
    let mut fixed = scene.world();
    let mut tw = timewarp(scene.world(), Scheduling::Ascending);
    for _ in 0..40 {
        let a = fixed.step();
        let b = tw.step();
        assert_eq!(a.contacts, b.contacts);
        assert_eq!(a.iterations, b.iterations);
    }
    assert!(tw.impacts.is_empty());
    let d = max_difference(&fixed, &tw.world);
    assert!(d <= 1e-12, "{d}");
}

/// Zero gravity, frame of 0.1 s: ball 1 (x = 0, 1 m/s) hits ball 0 (x = 0.25, at rest) at
/// t = 0.05, which then hits ball 2 (x = 0.5) at t = 0.1 + ... within the second frame.
fn chain() -> World {
    Scene::parse(
        r#"
        [settings]
        dt = 0.1
        steps = 10
        gravity = [0.0, 0.0, 0.0]
        friction_model = "none"
        tolerance = 1e-12
        restitution_threshold = 0.01
        position_correction = "none"
        [[materials]]
        name = "steel"
        restitution = 0.8
        [[bodies]]
        name = "target"
        shape = { type = "sphere", radius = 0.1 }
        mass = 1.0
        position = [0.25, 0.0, 0.0]
        material = "steel"
        [[bodies]]
        name = "striker"
        shape = { type = "sphere", radius = 0.1 }
        mass = 2.0
        position = [0.0, 0.0, 0.0]
        velocity = [1.0, 0.0, 0.0]
        material = "steel"
        [[bodies]]
        name = "last"
        shape = { type = "sphere", radius = 0.1 }
        mass = 1.0
        position = [0.55, 0.01, 0.0]
        material = "steel"
        "#,
        Path::new("chain.toml"),
    )
    .unwrap()
    .world()
}

#[test]
fn an_event_order_that_forces_rollbacks_gives_the_synchronous_trajectory() {
    // The target (body 0) is processed first and runs to the end of the frame unaware of the
    // striker; the striker then finds their impact in the target's past and rolls it back.
    let mut optimistic = timewarp(chain(), Scheduling::Ascending);
    let mut reference = timewarp(chain(), Scheduling::Synchronous);
    for _ in 0..10 {
        optimistic.step();
        reference.step();
        let d = max_difference(&optimistic.world, &reference.world);
        assert!(d < 1e-9, "{d}");
    }
    assert!(optimistic.cost.rollbacks > 0, "{:?}", optimistic.cost);
    assert_eq!(reference.cost.rollbacks, 0);
    assert_eq!(optimistic.impacts.len(), reference.impacts.len());
    assert!(optimistic.impacts.len() >= 2, "{:?}", optimistic.impacts);
    for (a, b) in optimistic.impacts.iter().zip(&reference.impacts) {
        assert_eq!(a.bodies, b.bodies);
        assert!((a.time - b.time).abs() < 1e-9);
    }
    // The first impact at the closed-form time: 0.05 m gap closed at 1 m/s.
    assert!((optimistic.impacts[0].time - 0.05).abs() < 1e-9);
    // Momentum is kept through the impacts.
    let p: f64 = optimistic
        .world
        .bodies
        .iter()
        .map(|b| b.linear_momentum.x)
        .sum();
    assert!((p - 2.0).abs() < 1e-9, "{p}");
}

#[test]
fn two_processing_orders_give_the_same_result() {
    for scene in ["impact/cradle_gaps_5.toml", "impact/stack_and_drops.toml"] {
        let scene = bench_scene(scene);
        let mut up = timewarp(scene.world(), Scheduling::Ascending);
        let mut down = timewarp(scene.world(), Scheduling::Descending);
        for _ in 0..30 {
            up.step();
            down.step();
        }
        let d = max_difference(&up.world, &down.world);
        assert!(d < 1e-9, "{}: {d}", scene.name);
        assert_eq!(up.impacts.len(), down.impacts.len());
    }
}

#[test]
fn newtons_cradle_with_gaps_passes_the_momentum_down_the_row() {
    let scene = bench_scene("impact/cradle_gaps_5.toml");
    let mut tw = timewarp(scene.world(), Scheduling::Ascending);
    for _ in 0..scene.settings.steps {
        tw.step();
    }
    let v: Vec<f64> = tw.world.bodies.iter().map(|b| b.velocity().x).collect();
    let expected = [0.0, 0.0, 0.0, 0.0, 1.0];
    for (a, b) in v.iter().zip(expected) {
        assert!((a - b).abs() < 1e-6, "{v:?}");
    }
    assert_eq!(tw.impacts.len(), 4);
}

#[test]
fn the_fast_sphere_tunnels_only_under_the_plain_fixed_step() {
    let scene = bench_scene("impact/fast_sphere_walls.toml");
    let modes = [
        (Stepping::Fixed, None, true),
        (Stepping::Fixed, Some(ToiMethod::Bisection), false),
        (
            Stepping::Fixed,
            Some(ToiMethod::ConservativeAdvancement),
            false,
        ),
        (Stepping::Timewarp, None, false),
    ];
    for (stepping, ccd, tunnels) in modes {
        let mut world = scene.world();
        world.settings.ccd = ccd;
        let mut stepper = Stepper::new(world, stepping).unwrap();
        let mut meter = DiscontinuityMeter::new(&stepper, false, 0.1);
        for _ in 0..scene.settings.steps {
            meter.before_step(&stepper);
            let report = stepper.step();
            meter.after_step(&stepper, &report);
        }
        let m = meter.finish(&stepper);
        let x = stepper.world().bodies[0].position.x;
        if tunnels {
            assert!(m.tunnelling >= 1, "{}: {m:?}", m.stepping);
            assert!(x > 15.0, "{x}");
        } else {
            assert_eq!(m.tunnelling, 0, "{}: {m:?}", m.stepping);
            assert!(x < 5.0, "{}: {x}", m.stepping);
        }
        if stepping == Stepping::Timewarp {
            // Off the first wall at e = 0.5, found in free flight.
            let v = stepper.world().bodies[0].velocity().x;
            assert!((v + 500.0).abs() < 1e-6, "{v}");
            assert_eq!(m.recorded_impacts, Some(1));
        }
    }
}

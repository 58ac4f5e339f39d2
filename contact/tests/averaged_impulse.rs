//! The averaged-impulse solver (`avg`) through the whole pipeline: exact where a pair's contacts
//! share a normal and the averaged point carries the load (a box resting or sliding on the
//! ground), and visibly wrong in the two scenes of its failure modes, next to the LCP. Each test
//! prints what it measured (`cargo test -- --nocapture`).

use lcpbench_contact::{ContactSolver, FrictionModel, RigidBody, Scene, World};
use nalgebra::Vector3;
use std::path::PathBuf;

const G: f64 = 9.81;

fn scene(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench_scenes")
        .join(format!("{name}.toml"));
    Scene::load(path).unwrap_or_else(|e| panic!("{e}"))
}

fn world(scene: &Scene, solver: &str) -> World {
    let mut w = scene.world();
    w.set_solver(ContactSolver::from_name(solver).expect("known solver"));
    w
}

fn body<'a>(w: &'a World, name: &str) -> &'a RigidBody {
    &w.bodies[w
        .body_index(name)
        .unwrap_or_else(|| panic!("no body {name}"))]
}

#[test]
fn avg_takes_the_frictionless_and_box_models_only() {
    let avg = ContactSolver::from_name("avg").expect("avg is registered");
    assert_eq!(avg.name(), "avg");
    assert!(avg.supports(FrictionModel::None).is_ok());
    assert!(avg.supports(FrictionModel::Box).is_ok());
    assert!(avg
        .supports(FrictionModel::Pyramid { directions: 4 })
        .is_err());
    assert!(avg.supports(FrictionModel::Cone).is_err());
}

/// One pair, four contacts with one normal, the load over the averaged point: the averaged
/// contact is the simultaneous answer.
#[test]
fn box_resting_flat_matches_lemke_and_rests() {
    let s = scene("box_on_ground");
    let mut avg = world(&s, "avg");
    let mut lemke = world(&s, "lemke");
    let start = body(&avg, "box").position;
    let (mut dv, mut residual): (f64, f64) = (0.0, 0.0);
    for _ in 0..200 {
        let r = avg.step();
        lemke.step();
        assert!(r.status.is_converged(), "{}", r.status);
        residual = residual.max(r.residuals.as_ref().unwrap().natural_map_rel);
        let (a, l) = (body(&avg, "box"), body(&lemke, "box"));
        dv = dv
            .max((a.velocity() - l.velocity()).norm())
            .max((a.angular_velocity() - l.angular_velocity()).norm());
    }
    let moved = (body(&avg, "box").position - start).norm();
    println!(
        "box on ground (avg, 2 s): velocity difference to lemke {dv:.3e}, moved {moved:.3e} m, \
         max relative residual {residual:.3e}"
    );
    assert!(dv < 1e-12, "velocity difference {dv:e}");
    assert!(moved < 1e-12, "moved {moved:e}");
    assert!(residual < 1e-10, "residual {residual:e}");
}

/// Warm-started, the resting box needs one sweep per step after the first, as with `si`.
#[test]
fn warm_start_carries_the_pair_impulse_across_steps() {
    let s = scene("box_on_ground");
    let mut w = world(&s, "avg");
    w.settings.warm_start = true;
    let reports = w.run(20);
    let later: Vec<usize> = reports[1..].iter().map(|r| r.iterations).collect();
    println!(
        "box on ground (avg+warm): sweeps {} then {later:?}",
        reports[0].iterations
    );
    assert!(later.iter().all(|&k| k == 1), "{later:?}");
}

/// A flat box sliding along x with `mu = 0.3`. The friction impulse at the averaged point is
/// `mu` times the normal impulse, so the centre decelerates at `mu (g + Δv_z / T)` over a window
/// `T`: at `mu g` when its vertical velocity does not change. It does change a little: the
/// friction at the base pitches the box, which no single impulse at the averaged point can
/// stop (the LCP moves the centre of pressure forward instead), so the box rocks and its centre
/// bobs, and the deceleration is `mu g` to the per cent.
#[test]
fn sliding_box_decelerates_at_mu_g() {
    let s = Scene::parse(
        r#"
        [settings]
        dt = 0.01
        friction_model = "box"
        tolerance = 1e-12
        [[materials]]
        name = "m"
        mu = 0.3
        [[bodies]]
        name = "ground"
        shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
        static = true
        [[bodies]]
        name = "box"
        shape = { type = "box", half_extents = [0.5, 0.5, 0.1] }
        position = [0.0, 0.0, 0.1]
        velocity = [2.0, 0.0, 0.0]
        "#,
        &PathBuf::from("sliding.toml"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mu = 0.3;
    let (steps, h) = (40, s.settings.dt);
    let mut w = world(&s, "avg");
    w.run(5);
    let v0 = body(&w, "box").velocity();
    let (mut tilt, mut min_vx): (f64, f64) = (0.0, f64::INFINITY);
    for _ in 0..steps {
        w.step();
        let b = body(&w, "box");
        tilt = tilt.max((b.orientation * Vector3::z()).angle(&Vector3::z()));
        min_vx = min_vx.min(b.velocity().x);
    }
    let v1 = body(&w, "box").velocity();
    let t = steps as f64 * h;
    let a = (v0.x - v1.x) / t;
    let coulomb = mu * (G + (v1.z - v0.z) / t);
    let expected = mu * G;
    let law = (a - coulomb).abs() / coulomb;
    let err = (a - expected).abs() / expected;
    println!(
        "sliding box (avg): deceleration {a:.9} m/s², mu (g + dv_z/T) = {coulomb:.9} (relative \
         error {law:.3e}), mu g = {expected:.9} (relative error {err:.3e}); tilt up to \
         {tilt:.3e} rad; sideways speed {:.3e} m/s",
        v1.y.abs()
    );
    assert!(min_vx > 0.5, "slides throughout: {min_vx}");
    assert!(
        law < 1e-9,
        "Coulomb's law at the averaged point: a = {a}, {coulomb}"
    );
    assert!(err < 0.02, "a = {a}");
    assert!(v1.y.abs() < 1e-9);
}

/// Largest tilt of `name` (the angle of its z axis from the vertical) and largest drop of its
/// centre, over a run of `steps` steps.
fn tilt_and_drop(scene: &Scene, solver: &str, name: &str, steps: usize) -> (f64, f64) {
    let mut w = world(scene, solver);
    let z0 = body(&w, name).position.z;
    let (mut tilt, mut drop): (f64, f64) = (0.0, 0.0);
    for _ in 0..steps {
        w.step();
        let b = body(&w, name);
        let axis = b.orientation * Vector3::z();
        tilt = tilt.max(axis.angle(&Vector3::z()));
        drop = drop.max(z0 - b.position.z);
    }
    (tilt, drop)
}

/// The plank on two supports with a load off the line between them: `avg` holds it at two
/// points, and the load tilts it down into the supports; the LCP keeps it level.
#[test]
fn two_supports_tilt_under_avg_and_stay_level_under_lemke() {
    let s = scene("avg_two_supports");
    let steps = 120;
    let mut figures = Vec::new();
    for solver in ["lemke", "body-micro", "avg"] {
        let (tilt, drop) = tilt_and_drop(&s, solver, "plank", steps);
        println!(
            "two supports ({solver}, {steps} steps): plank tilt up to {tilt:.3e} rad, drop up to \
             {drop:.3e} m"
        );
        figures.push((tilt, drop));
    }
    let (lemke, micro, avg) = (figures[0], figures[1], figures[2]);
    assert!(lemke.0 < 1e-9 && lemke.1 < 1e-9, "lemke: {lemke:?}");
    assert!(micro.0 < 1e-5 && micro.1 < 1e-5, "body-micro: {micro:?}");
    assert!(avg.0 > 1e-2, "avg tilts the plank: {avg:?}");
    assert!(avg.1 > 1e-3, "avg sinks the plank: {avg:?}");
}

/// The ball in the L mesh's notch: two contacts of one pair with normals 90° apart. `avg`
/// pushes along their bisector; the ball leaves its place and sinks into a face.
#[test]
fn ball_in_a_nonconvex_notch_moves_under_avg_only() {
    let s = scene("avg_nonconvex");
    let steps = 120;
    let mut figures = Vec::new();
    for solver in ["lemke", "body-micro", "avg"] {
        let mut w = world(&s, solver);
        let start = body(&w, "ball").position;
        let (mut moved, mut penetration): (f64, f64) = (0.0, 0.0);
        for _ in 0..steps {
            w.step();
            moved = moved.max((body(&w, "ball").position - start).norm());
            penetration = penetration.max(notch_penetration(&w));
        }
        println!(
            "ball in notch ({solver}, {steps} steps): moved up to {moved:.3e} m, penetration up \
             to {penetration:.3e} m"
        );
        figures.push((moved, penetration));
    }
    let (lemke, micro, avg) = (figures[0], figures[1], figures[2]);
    assert!(lemke.0 < 1e-9 && lemke.1 < 1e-9, "lemke: {lemke:?}");
    assert!(micro.0 < 1e-9 && micro.1 < 1e-9, "body-micro: {micro:?}");
    assert!(avg.0 > 1e-2 && avg.1 > 1e-2, "avg: {avg:?}");
}

/// How deep the ball is in either face of the notch, from the poses: the faces are the planes
/// through the notch's corner with the mesh's x and y axes as normals.
fn notch_penetration(w: &World) -> f64 {
    let l = body(w, "l_block");
    let ball = body(w, "ball");
    let radius = 0.25;
    // The corner (1, 1) of the L polygon, in the frame centred on the mesh's centre of mass
    // (5/6, 5/6, 1/4).
    let corner = l.position + l.orientation * Vector3::new(1.0 / 6.0, 1.0 / 6.0, 0.0);
    [Vector3::x(), Vector3::y()]
        .into_iter()
        .map(|axis| radius - (ball.position - corner).dot(&(l.orientation * axis)))
        .fold(0.0, f64::max)
}

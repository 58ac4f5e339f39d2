//! Scenes with analytic answers, run through the whole pipeline (detect → build → solve →
//! integrate). Each test prints its measured error (`cargo test -- --nocapture`).

use lcpbench_contact::builder::{self, BuilderParams, FrictionModel, Material};
use lcpbench_contact::{Contact, ContactSolver, MassSpec, RigidBody, Scene, Shape, World};
use lcpbench_solvers::{Problem, Settings, SolverKind, Status};
use nalgebra::{DMatrix, Point3, UnitQuaternion, Vector3};
use std::path::PathBuf;

const G: f64 = 9.81;

fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench_scenes")
        .join(format!("{name}.toml"))
}

fn scene(name: &str) -> Scene {
    Scene::load(scene_path(name)).unwrap_or_else(|e| panic!("{e}"))
}

fn inline(text: &str) -> Scene {
    Scene::parse(text, &PathBuf::from("inline.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// A world of `scene` with the solver `spec`: a solver name, optionally with `/pyramid` to use
/// the Stewart–Trinkle pyramid friction model (4 directions) instead of the scene's.
fn world(scene: &Scene, spec: &str) -> World {
    let mut w = scene.world();
    let (solver, pyramid) = match spec.split_once('/') {
        Some((s, "pyramid")) => (s, true),
        _ => (spec, false),
    };
    if pyramid {
        w.settings.builder.friction_model = FrictionModel::Pyramid { directions: 4 };
    }
    w.set_solver(ContactSolver::from_name(solver).expect("known solver"));
    w
}

/// Solvers for scenes with friction: Lemke takes no friction rows, so it runs the pyramid
/// (standard LCP) model; Dantzig takes friction rows but not the non-symmetric pyramid matrix.
const FRICTION_SOLVERS: [&str; 4] = ["pgs", "si", "dantzig", "lemke/pyramid"];

fn body<'a>(w: &'a World, name: &str) -> &'a RigidBody {
    &w.bodies[w
        .body_index(name)
        .unwrap_or_else(|| panic!("no body {name}"))]
}

/// True when the solver answers on a one-row probe LCP (pivoting solvers are merged from other
/// branches; until then they report `Unsupported`).
fn available(spec: &str) -> bool {
    let solver = spec.split('/').next().unwrap_or(spec);
    let Some(kind) = SolverKind::from_name(solver) else {
        return true;
    };
    let p = Problem::lcp(faer::Mat::from_fn(1, 1, |_, _| 1.0), vec![-1.0]).unwrap();
    let r = kind.create().solve(&p, &Settings::default());
    !matches!(r.status, Status::Unsupported { .. })
}

#[test]
fn free_fall_is_exact() {
    let s = inline(
        r#"
        [settings]
        dt = 0.01
        gravity = [0.0, 0.0, -9.81]
        [[bodies]]
        name = "ball"
        shape = { type = "sphere", radius = 0.1 }
        position = [0.0, 0.0, 10.0]
        velocity = [1.0, -0.5, 2.0]
        "#,
    );
    let mut w = s.world();
    let mut max_err: f64 = 0.0;
    for k in 1..=100 {
        w.step();
        let t = k as f64 * 0.01;
        let exact = Vector3::new(t, -0.5 * t, 10.0 + 2.0 * t - 0.5 * G * t * t);
        max_err = max_err.max((body(&w, "ball").position.coords - exact).norm());
        let v_exact = Vector3::new(1.0, -0.5, 2.0 - G * t);
        max_err = max_err.max((body(&w, "ball").velocity() - v_exact).norm());
    }
    println!("free fall: max position/velocity error over 1 s = {max_err:.3e}");
    assert!(max_err < 1e-12, "free-fall error {max_err:e}");
}

#[test]
fn torque_free_tumbling_keeps_energy_and_angular_momentum() {
    // Asymmetric inertia, spin near the unstable intermediate axis: the body tumbles.
    let s = inline(
        r#"
        [settings]
        dt = 0.001
        gravity = [0.0, 0.0, 0.0]
        [[bodies]]
        name = "brick"
        shape = { type = "box", half_extents = [0.1, 0.2, 0.4] }
        mass = 1.0
        angular_velocity = [0.05, 3.0, 0.05]
        "#,
    );
    let mut w = s.world();
    let b0 = body(&w, "brick").clone();
    let (e0, l0) = (
        lcpbench_contact::integrate::kinetic_energy(&b0),
        b0.angular_momentum,
    );
    let w0 = b0.angular_velocity();
    let (mut max_de, mut max_dl, mut max_turn): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for _ in 0..10_000 {
        w.step();
        let b = body(&w, "brick");
        let e = lcpbench_contact::integrate::kinetic_energy(b);
        max_de = max_de.max((e - e0).abs() / e0);
        // L recomputed from the state, I(q) ω, against the initial L.
        let l = b.inertia_world() * b.angular_velocity();
        max_dl = max_dl.max((l - l0).norm() / l0.norm());
        max_turn = max_turn.max((b.angular_velocity().normalize() - w0.normalize()).norm());
        assert!((b.orientation.quaternion().norm() - 1.0).abs() < 1e-12);
    }
    println!(
        "tumbling (10 s, RK4): relative energy drift {max_de:.3e}, angular momentum drift \
         {max_dl:.3e}; the spin axis moved by up to {max_turn:.2} (it tumbles)"
    );
    assert!(max_turn > 0.5, "the body should tumble, not spin steadily");
    assert!(max_de < 1e-9, "energy drift {max_de:e}");
    assert!(max_dl < 1e-12, "angular momentum drift {max_dl:e}");
}

fn rebound_ratio(solver: &str, dt: f64) -> f64 {
    let s = scene("ball_drop");
    let mut w = world(&s, solver);
    w.settings.dt = dt;
    let mut bounced = false;
    let mut apex: f64 = 0.0;
    for _ in 0..(1.0 / dt) as usize {
        w.step();
        let b = body(&w, "ball");
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
    assert!(bounced, "{solver}: the ball never bounced");
    apex / 1.0
}

#[test]
fn ball_rebounds_to_e_squared_of_its_height() {
    // Newton's law acts in the step in which the ball reaches the ground, on the velocity at
    // the end of the free step, and the ball moves with the rebound velocity for that whole
    // step: the apex is high by O(|v| h). The error falls tenfold from h = 1 ms to 0.1 ms.
    let e2 = 0.8f64 * 0.8;
    for solver in ["pgs", "sor", "si", "body-micro", "lemke", "dantzig"] {
        if !available(solver) {
            println!("ball drop: {solver} not available yet, skipped");
            continue;
        }
        let coarse = (rebound_ratio(solver, 1e-3) - e2) / e2;
        let fine = (rebound_ratio(solver, 1e-4) - e2) / e2;
        println!(
            "ball drop ({solver}): rebound/drop relative error {coarse:.3e} at h = 1 ms, \
             {fine:.3e} at h = 0.1 ms"
        );
        assert!(fine.abs() < 1.5e-3, "{solver}: relative error {fine:e}");
        assert!(coarse.abs() / fine.abs() > 8.0, "{solver}: not first order");
    }
}

fn cradle(balls: usize, solver: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(scene_path("cradle_3")).unwrap();
    let text = text.replace(
        "count = [2, 1, 1]",
        &format!("count = [{}, 1, 1]", balls - 1),
    );
    let s = Scene::parse(&text, &scene_path("cradle_3")).unwrap();
    let mut w = world(&s, solver);
    let r = w.step();
    assert_eq!(r.contacts, balls - 1, "{solver}: contacts");
    w.bodies.iter().map(|b| b.velocity().x).collect()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn newtons_cradle_simultaneous_lcp() {
    for balls in [3usize, 5] {
        // Simultaneous LCP: the striker ends at -v(n-2)/n, the others at 2v/n.
        let n = balls as f64;
        let expected: Vec<f64> = (0..balls)
            .map(|i| if i == 0 { -(n - 2.0) / n } else { 2.0 / n })
            .collect();
        for solver in ["pgs", "sor", "lemke", "dantzig"] {
            if !available(solver) {
                println!("cradle: {solver} not available yet, skipped");
                continue;
            }
            let v = cradle(balls, solver);
            let err = max_diff(&v, &expected);
            println!("cradle {balls} ({solver}, simultaneous LCP): {v:.6?}, max error {err:.3e}");
            assert!(err < 1e-9, "{solver}: {v:?} vs {expected:?}");
        }
    }
}

#[test]
fn newtons_cradle_sequential_impulses_propagate() {
    for balls in [3usize, 5] {
        let expected: Vec<f64> = (0..balls)
            .map(|i| if i + 1 == balls { 1.0 } else { 0.0 })
            .collect();
        for solver in ["si", "body-micro"] {
            let v = cradle(balls, solver);
            let err = max_diff(&v, &expected);
            println!("cradle {balls} ({solver}, sequential): {v:.6?}, max error {err:.3e}");
            assert!(err < 1e-12, "{solver}: {v:?} vs {expected:?}");
        }
    }
}

#[test]
fn v_groove_walls_carry_mg_over_2_cos_alpha() {
    let alpha = 30f64.to_radians();
    let expected = 1.0 * G / (2.0 * alpha.cos());
    for solver in ["pgs", "sor", "si", "body-micro", "lemke", "dantzig"] {
        if !available(solver) {
            println!("v-groove: {solver} not available yet, skipped");
            continue;
        }
        let s = scene("v_groove");
        let mut w = world(&s, solver);
        let reports = w.run(s.settings.steps);
        let last = reports.last().unwrap();
        let mut force = [0.0; 2];
        for c in &last.contact_records {
            let f = Vector3::from(c.impulse).norm() / s.settings.dt;
            let wall = c.bodies.iter().any(|b| &**b == "left_wall") as usize;
            force[1 - wall] += f;
        }
        let err = force
            .iter()
            .map(|f| (f - expected).abs() / expected)
            .fold(0.0, f64::max);
        let sym = (force[0] - force[1]).abs() / expected;
        println!(
            "v-groove ({solver}): wall forces {:.6} N, {:.6} N, expected {expected:.6} N; \
             relative error {err:.3e}, symmetry error {sym:.3e}",
            force[0], force[1]
        );
        assert!(err < 1e-8 && sym < 1e-8, "{solver}: {force:?}");
    }
}

/// Displacement of the box along the slope direction `s = (cos θ, 0, -sin θ)` and its speed.
fn along_slope(w: &World) -> (f64, f64) {
    let th = 30f64.to_radians();
    let s = Vector3::new(th.cos(), 0.0, -th.sin());
    let b = body(w, "box");
    (b.position.coords.dot(&s), b.velocity().dot(&s))
}

#[test]
fn box_sticks_on_incline_with_mu_0_7() {
    for solver in FRICTION_SOLVERS {
        if !available(solver) {
            println!("incline stick: {solver} not available yet, skipped");
            continue;
        }
        let s = scene("incline_stick");
        let mut w = world(&s, solver);
        let (x0, _) = along_slope(&w);
        w.run(s.settings.steps);
        let (x, v) = along_slope(&w);
        println!(
            "incline mu = 0.7 ({solver}): slid {:.3e} m in 2 s, speed {v:.3e} m/s",
            x - x0
        );
        assert!(
            (x - x0).abs() < 1e-6 && v.abs() < 1e-6,
            "{solver}: slid {}",
            x - x0
        );
    }
}

#[test]
fn box_slides_on_incline_with_mu_0_3() {
    let th = 30f64.to_radians();
    let expected = G * (th.sin() - 0.3 * th.cos());
    for solver in FRICTION_SOLVERS {
        if !available(solver) {
            println!("incline slide: {solver} not available yet, skipped");
            continue;
        }
        let s = scene("incline_slide");
        let mut w = world(&s, solver);
        w.run(50);
        let (_, v0) = along_slope(&w);
        w.run(150);
        let (_, v1) = along_slope(&w);
        let a = (v1 - v0) / (150.0 * s.settings.dt);
        let err = (a - expected).abs() / expected;
        println!(
            "incline mu = 0.3 ({solver}): acceleration {a:.6} m/s², expected {expected:.6}, \
             relative error {err:.3e}"
        );
        assert!(err < 1e-6, "{solver}: a = {a}");
    }
}

/// Largest displacement and rotation angle of the named bodies from their initial poses.
fn drift(w: &World, initial: &[RigidBody]) -> (f64, f64) {
    let (mut dx, mut da): (f64, f64) = (0.0, 0.0);
    for b0 in initial.iter().filter(|b| !b.is_static) {
        let b = body(w, &b0.name);
        dx = dx.max((b.position - b0.position).norm());
        da = da.max(b.orientation.angle_to(&b0.orientation));
    }
    (dx, da)
}

#[test]
fn box_rests_on_ground_for_10_s() {
    // The four contacts of a face make A rank-deficient.
    let s = scene("box_on_ground");
    let mut w = s.world();
    w.settings.keep_problem = true;
    let r = w.step();
    let p = r.problem.expect("problem kept");
    let a = DMatrix::from_fn(p.n(), p.n(), |i, j| p.entry(i, j));
    let rank = a.clone().svd(false, false).rank(1e-10 * a.amax());
    println!(
        "box on ground: {} contacts, {} rows, rank A = {rank}",
        r.contacts,
        p.n()
    );
    assert_eq!(r.contacts, 4);
    assert!(rank < p.n());

    for solver in FRICTION_SOLVERS {
        if !available(solver) {
            println!("box on ground: {solver} not available yet, skipped");
            continue;
        }
        let mut w = world(&s, solver);
        let initial = w.bodies.clone();
        let reports = w.run(s.settings.steps);
        let (dx, da) = drift(&w, &initial);
        let pen = reports
            .iter()
            .map(|r| r.max_penetration)
            .fold(0.0, f64::max);
        println!(
            "box on ground ({solver}, 10 s): drift {dx:.3e} m, rotation {da:.3e} rad, \
             max penetration {pen:.3e} m"
        );
        assert!(
            dx < 1e-6 && da < 1e-6,
            "{solver}: drift {dx:e}, rotation {da:e}"
        );
    }
}

fn tower_drift(solver: &str) -> (f64, f64) {
    let s = scene("tower_10");
    let mut w = world(&s, solver);
    let initial = w.bodies.clone();
    w.run(s.settings.steps);
    drift(&w, &initial)
}

#[test]
fn tower_of_10_boxes_stands_for_10_s_pgs() {
    // The iterative baseline; the pivoting solvers are in the next test.
    let (dx, da) = tower_drift("pgs");
    println!("tower 10 (pgs, 10 s): drift {dx:.3e} m, rotation {da:.3e} rad");
    assert!(dx < 1e-3 && da < 1e-3, "drift {dx:e}, rotation {da:e}");
}

#[test]
fn tower_of_10_boxes_stands_for_10_s_pivoting() {
    if !available("dantzig") {
        println!("tower 10: pivoting solver dantzig NOT AVAILABLE, skipped");
        return;
    }
    let (dx, da) = tower_drift("dantzig");
    println!("tower 10 (dantzig, 10 s): drift {dx:.3e} m, rotation {da:.3e} rad");
    assert!(dx < 1e-9 && da < 1e-9, "drift {dx:e}, rotation {da:e}");
}

/// Lemke on the 240-row pyramid LCP of the resting tower: highly degenerate (four contacts per
/// face, opposite friction directions) and nearly singular (the 1e-9 drift of the boxes makes
/// coplanar contacts almost dependent). It used to pivot on a round-off entry (step 265), then
/// to take negative steps from round-off negative basic values (step 462: the tower fell); see
/// `lemke.rs` for both fixes.
#[test]
fn tower_of_10_boxes_stands_for_10_s_lemke_pyramid() {
    let (dx, da) = tower_drift("lemke/pyramid");
    println!("tower 10 (lemke, pyramid, 10 s): drift {dx:.3e} m, rotation {da:.3e} rad");
    assert!(dx < 1e-3 && da < 1e-3, "drift {dx:e}, rotation {da:e}");
}

fn spinning_body(name: &str, half: [f64; 3], pos: [f64; 3], v: [f64; 3], w: [f64; 3]) -> RigidBody {
    RigidBody::new(
        name,
        Shape::cuboid(Vector3::from(half)).unwrap(),
        MassSpec::Density(800.0),
        Point3::from(pos),
        UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7),
        Vector3::from(v),
        Vector3::from(w),
        0,
        false,
    )
    .unwrap()
}

#[test]
fn one_contact_impulse_matches_closed_form() {
    let e = 0.6;
    let a = spinning_body(
        "a",
        [0.3, 0.2, 0.1],
        [0.0, 0.0, 0.0],
        [1.0, 0.2, -0.1],
        [2.0, -1.0, 3.0],
    );
    let b = spinning_body(
        "b",
        [0.1, 0.4, 0.2],
        [0.5, 0.1, 0.05],
        [-1.5, 0.1, 0.3],
        [-1.0, 4.0, 0.5],
    );
    let n = Vector3::new(1.0, 0.2, -0.1).normalize();
    let p = Point3::new(0.25, 0.05, 0.02);
    let bodies = vec![a, b];
    let contact = Contact {
        body_a: 0,
        body_b: 1,
        point: p,
        normal: n,
        dist: 0.0,
        key: 1,
    };
    let materials = [Material {
        name: "m".into(),
        mu: 0.0,
        restitution: e,
    }];
    let params = BuilderParams {
        friction_model: FrictionModel::None,
        restitution_threshold: 0.0,
        ..BuilderParams::default()
    };
    let free = builder::free_velocities(&bodies, &Vector3::zeros(), 0.01);
    let sys = builder::build(&bodies, &materials, &[contact], free, &params, 0.01);

    // Closed form.
    let (ba, bb) = (&bodies[0], &bodies[1]);
    let (ra, rb) = (p - ba.position, p - bb.position);
    let v_rel = n.dot(&(bb.velocity_at(&p) - ba.velocity_at(&p)));
    assert!(v_rel < 0.0, "bodies must approach");
    let k = ba.inv_mass
        + bb.inv_mass
        + n.dot(
            &((ba.inv_inertia_world() * ra.cross(&n)).cross(&ra)
                + (bb.inv_inertia_world() * rb.cross(&n)).cross(&rb)),
        );
    let j = -(1.0 + e) * v_rel / k;

    let problem = sys.problem().unwrap();
    for solver in ["pgs", "lemke", "dantzig", "clarabel"] {
        if !available(solver) {
            continue;
        }
        let r = SolverKind::from_name(solver)
            .unwrap()
            .create()
            .solve(&problem, &Settings::default());
        let err = (r.f[0] - j).abs() / j;
        println!(
            "one contact ({solver}): j = {:.12}, closed form {j:.12}, relative error {err:.3e}",
            r.f[0]
        );
        assert!(err < 1e-12, "{solver}");
    }
    let out = lcpbench_contact::body_solvers::solve(
        lcpbench_contact::BodySolverKind::SequentialImpulses,
        &sys,
        &[],
        &Default::default(),
    );
    let err = (out.f[0] - j).abs() / j;
    println!("one contact (si): relative error {err:.3e}");
    assert!(err < 1e-12);
    // The post-impact normal velocity is -e times the pre-impact one.
    let du = sys.velocity_change(&[j]);
    let mut u = sys.free_velocity.clone();
    for (ui, d) in u.iter_mut().zip(&du) {
        ui.linear += d.linear;
        ui.angular += d.angular;
    }
    let v_after = sys.operator().row_dot(0, &u);
    assert!((v_after + e * v_rel).abs() < 1e-12);
}

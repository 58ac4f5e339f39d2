//! Scene files: every example loads, repeats and events expand as documented, bad files give
//! one clear error naming the file, the field and the problem; the contact rows match the
//! friction model.

use lcpbench_contact::builder::{self, FrictionModel, RowKind};
use lcpbench_contact::{Scene, SceneError};
use std::path::{Path, PathBuf};

fn bench_scenes() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../bench_scenes")
}

fn parse(text: &str) -> Result<Scene, SceneError> {
    Scene::parse(text, Path::new("test.toml"))
}

fn error(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

const BALL: &str = r#"
[[bodies]]
name = "ground"
shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
static = true

[[bodies]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
position = [0.0, 0.0, 0.1]
"#;

#[test]
fn every_bench_scene_loads_and_steps() {
    let mut n = 0;
    for entry in std::fs::read_dir(bench_scenes()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            let mut world = scene.world();
            world.step();
            n += 1;
        }
    }
    assert!(n >= 8, "only {n} scenes");
}

#[test]
fn defaults_and_typed_metrics() {
    let s = parse(&format!(
        "[metrics]\nexpected_displacement = 0\nmu = [0.5, 0.6]\npush_direction = [1, 0, 0]\n{BALL}"
    ))
    .unwrap();
    assert_eq!(s.name, "test");
    assert_eq!(s.settings.dt, 0.01);
    assert_eq!(s.settings.solver.name(), "pgs");
    assert_eq!(s.settings.builder.friction_model, FrictionModel::Box);
    assert_eq!(s.metrics.expected_displacement, Some(0.0));
    assert_eq!(s.metrics.push_direction, Some([1.0, 0.0, 0.0]));
    assert_eq!(
        s.metrics.mu,
        Some(lcpbench_contact::scene::OneOrMany::Many(vec![0.5, 0.6]))
    );
    assert_eq!(s.metrics.at_rest, None);
    assert_eq!(s.bodies.len(), 2);
    assert!(s.bodies[0].is_static);
    // Default density 1000: a 0.1 m sphere weighs 4.19 kg.
    let m = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 1e-3;
    assert!((s.bodies[1].mass - m).abs() < 1e-9);
}

#[test]
fn repeat_builds_a_grid_and_events_remove_copies() {
    let text = r#"
        [settings]
        dt = 0.01
        [[bodies]]
        name = "s"
        shape = { type = "sphere", radius = 0.1 }
        position = [1.0, 2.0, 3.0]
        repeat = { count = [3, 2, 2], spacing = [0.5, 0.25, 1.0] }
        [[bodies]]
        name = "lone"
        shape = { type = "box", half_extents = [0.1, 0.1, 0.1] }
        mass = 2.0
        axis_angle = { axis = [0.0, 0.0, 1.0], degrees = 90.0 }
        [[events]]
        at_step = 2
        remove = "s"
        [[events]]
        at_step = 1
        remove = "lone"
    "#;
    let s = parse(text).unwrap();
    assert_eq!(s.bodies.len(), 13);
    assert_eq!(s.bodies[0].name, "s_0");
    assert_eq!(s.bodies[11].name, "s_11");
    // x fastest: s_1 is one step along x, s_3 one step along y, s_6 one step along z.
    let p = |i: usize| s.bodies[i].position.coords;
    assert!((p(1) - p(0) - nalgebra::Vector3::new(0.5, 0.0, 0.0)).norm() < 1e-15);
    assert!((p(3) - p(0) - nalgebra::Vector3::new(0.0, 0.25, 0.0)).norm() < 1e-15);
    assert!((p(6) - p(0) - nalgebra::Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-15);
    assert!((s.bodies[12].mass - 2.0).abs() < 1e-12);
    let angle = s.bodies[12].orientation.angle();
    assert!((angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12);

    let mut w = s.world();
    w.step();
    assert_eq!(w.bodies.len(), 13);
    w.step();
    assert_eq!(w.bodies.len(), 12);
    assert!(w.body_index("lone").is_none());
    w.step();
    assert_eq!(w.bodies.len(), 0);
}

#[test]
fn errors_name_file_field_and_problem() {
    // The refusal of a matrix solver under the cone model names every cone solver, as the
    // registry lists them.
    let cone_solvers = format!(
        "cone solver ({})",
        lcpbench_solvers::ConeSolverKind::names()
    );
    let cases: &[(&str, &[&str])] = &[
        (
            "[settings]\ndtt = 0.01\n",
            &["test.toml:2:1", "[settings]", "unknown field `dtt`"],
        ),
        (
            "[metrics]\nexpected_rest_hieght = 0.5\n",
            &["test.toml:2:1", "[metrics]", "unknown field `expected_rest_hieght`"],
        ),
        (
            "[metrics]\nat_rest = 1.5\n",
            &["test.toml:2:", "field `at_rest`", "invalid type"],
        ),
        (
            "[settings]\ndt = \"fast\"\n",
            &["test.toml:2:", "field `dt`", "invalid type"],
        ),
        ("[settings]\ndt = -1.0\n", &["settings.dt", "positive"]),
        (
            "[settings]\nsolver = \"pgz\"\n",
            &["settings.solver", "unknown solver \"pgz\"", "body-micro"],
        ),
        (
            "[settings]\nfriction_model = \"ellipse\"\n",
            &["settings.friction_model", "\"ellipse\"", "\"cone\""],
        ),
        (
            "[settings]\nfriction_model = \"cone\"\nsolver = \"pgs\"\n",
            &["settings.solver", "`pgs`", cone_solvers.as_str()],
        ),
        (
            "[settings]\nsolver = \"nsgs-cone\"\n",
            &["settings.solver", "`nsgs-cone`", "\"box\""],
        ),
        (
            "[settings]\nfriction_model = \"pyramid\"\nsolver = \"si\"\n",
            &["settings.solver", "pyramid"],
        ),
        (
            "[[bodies]]\nname = \"b\"\nshape = { type = \"sphere\", radius = -1.0 }\n",
            &["bodies[0] (\"b\").shape", "radius"],
        ),
        (
            "[[bodies]]\nname = \"b\"\nshape = { type = \"sphear\", radius = 1.0 }\n",
            &["test.toml:3:", "[[bodies]] #1", "unknown variant `sphear`"],
        ),
        (
            "[[bodies]]\nname = \"b\"\nshape = { type = \"sphere\", radius = 1.0 }\nmaterial = \"x\"\n",
            &["bodies[0] (\"b\").material", "no material named \"x\""],
        ),
        (
            "[[bodies]]\nname = \"b\"\nshape = { type = \"sphere\", radius = 1.0 }\nmass = 1.0\ndensity = 2.0\n",
            &["bodies[0] (\"b\").mass", "not both"],
        ),
        (
            "[[bodies]]\nname = \"b\"\nshape = { type = \"sphere\", radius = 1.0 }\nposition = [0.0, 1.0]\n",
            &["field `position`", "length 2"],
        ),
        (
            "[[bodies]]\nname = \"b\"\nshape = { type = \"plane\", normal = [0.0, 0.0, 1.0] }\n",
            &["bodies[0] (\"b\")", "static"],
        ),
        (
            "[[bodies]]\nname = \"b\"\nshape = { type = \"mesh\", file = \"missing.obj\" }\n",
            &["bodies[0] (\"b\").shape", "missing.obj"],
        ),
        (
            "[[events]]\nat_step = 3\nremove = \"ghost\"\n",
            &["events[0].remove", "ghost"],
        ),
        (
            "[[materials]]\nname = \"m\"\nrestitution = 1.5\n",
            &["materials[0] (\"m\").restitution", "[0, 1]"],
        ),
        ("name = \"x\"\n[settings\n", &["test.toml:2:"]),
    ];
    for (text, needles) in cases {
        let e = error(text);
        println!("{e}");
        assert!(e.starts_with("test.toml"), "no file in: {e}");
        for n in *needles {
            assert!(e.contains(n), "`{n}` missing from: {e}");
        }
    }
    let e = Scene::load("no/such/scene.toml").unwrap_err().to_string();
    assert!(e.contains("no/such/scene.toml"), "{e}");
}

fn rows_of(friction: &str) -> (usize, Vec<RowKind>, bool) {
    let text =
        format!("[settings]\nfriction_model = \"{friction}\"\npyramid_directions = 6\n{BALL}");
    let s = parse(&text).unwrap();
    let w = s.world();
    let mut pipeline = lcpbench_contact::CollisionPipeline::new();
    let contacts = pipeline.detect(&w.bodies, 0.01).unwrap();
    let free = builder::free_velocities(&w.bodies, &w.settings.gravity, w.settings.dt);
    let sys = builder::build(
        &w.bodies,
        &w.materials,
        &contacts,
        free,
        &w.settings.builder,
        w.settings.dt,
    );
    let p = sys.problem().unwrap();
    (
        contacts.len(),
        sys.rows.iter().map(|r| r.kind).collect(),
        p.is_standard(),
    )
}

#[test]
fn rows_follow_the_friction_model() {
    let (c, rows, standard) = rows_of("none");
    assert_eq!((c, rows.len(), standard), (1, 1, true));
    assert!(matches!(rows[0], RowKind::Normal { .. }));

    let (_, rows, standard) = rows_of("box");
    assert_eq!(rows.len(), 3);
    assert!(!standard, "box friction gives friction rows");

    let (_, rows, standard) = rows_of("pyramid");
    assert_eq!(rows.len(), 1 + 6 + 1);
    assert!(standard, "the pyramid model is a standard LCP");
    assert!(matches!(rows[7], RowKind::Slack { .. }));

    let (_, rows, _) = rows_of("cone");
    assert_eq!(rows.len(), 3, "the cone: a normal and two tangent rows");
    assert!(matches!(rows[0], RowKind::Normal { .. }));
    assert!(matches!(rows[2], RowKind::Tangent { index: 1, .. }));
}

#[test]
fn a_cone_scene_defaults_to_nsgs_cone() {
    let s = parse(&format!("[settings]\nfriction_model = \"cone\"\n{BALL}")).unwrap();
    assert_eq!(s.settings.builder.friction_model, FrictionModel::Cone);
    assert_eq!(s.settings.solver.name(), "nsgs-cone");
    for name in ["none", "box", "pyramid", "pyramid-8", "cone"] {
        let m = FrictionModel::from_name(name).unwrap();
        assert_eq!(m.name(), name);
    }
    assert!(FrictionModel::from_name("pyramid-2").is_none());
}

#[test]
fn delassus_equals_j_minv_jt_and_the_matrix_free_operator() {
    let s = Scene::load(bench_scenes().join("sphere_pile_100.toml")).unwrap();
    let mut w = s.world();
    w.run(60);
    let mut pipeline = lcpbench_contact::CollisionPipeline::new();
    let contacts = pipeline
        .detect(&w.bodies, w.settings.prediction_distance)
        .unwrap();
    assert!(contacts.len() > 50, "{} contacts", contacts.len());
    let free = builder::free_velocities(&w.bodies, &w.settings.gravity, w.settings.dt);
    let sys = builder::build(
        &w.bodies,
        &w.materials,
        &contacts,
        free,
        &w.settings.builder,
        w.settings.dt,
    );
    let j = sys.jacobian();
    let nb = w.bodies.len();
    let minv = faer::Mat::from_fn(6 * nb, 6 * nb, |r, c| {
        let (k, kc) = (r / 6, c / 6);
        if k != kc {
            return 0.0;
        }
        let m = &sys.inv_mass[k];
        match (r % 6, c % 6) {
            (a, b) if a < 3 && a == b => m.inv_mass,
            (a, b) if a >= 3 && b >= 3 => m.inv_inertia[(a - 3, b - 3)],
            _ => 0.0,
        }
    });
    let dense = &j * &minv * j.transpose();
    let a = sys.delassus();
    let n = sys.n();
    let scale = (0..n).map(|i| a[(i, i)]).fold(0.0, f64::max);
    let mut err: f64 = 0.0;
    for r in 0..n {
        for c in 0..n {
            err = err.max((a[(r, c)] - dense[(r, c)]).abs());
        }
    }
    println!(
        "Delassus by body blocks vs J M⁻¹ Jᵀ: max difference {err:.3e} (max diagonal {scale:.3e})"
    );
    assert!(err <= 1e-12 * scale);
    // The solver problem: sparse A equal to the dense one, with J and M⁻¹ that reproduce it.
    let p = sys.problem().unwrap();
    assert!(p.is_sparse());
    let sparse = p.to_dense();
    for r in 0..n {
        for c in 0..n {
            assert_eq!(sparse[(r, c)], a[(r, c)]);
        }
    }
    let f: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let from_factors = p.factors().expect("box friction has factors").apply(&f);
    let w = p.velocity(&f);
    for r in 0..n {
        let d = (from_factors[r] + p.b()[r] - w[r]).abs();
        assert!(d <= 1e-10 * scale, "J M⁻¹ Jᵀ f differs from A f by {d:e}");
    }
    let af = sys.operator().apply(&f);
    let mut err: f64 = 0.0;
    for r in 0..n {
        let dense_r: f64 = (0..n).map(|c| a[(r, c)] * f[c]).sum();
        err = err.max((af[r] - dense_r).abs());
    }
    assert!(err <= 1e-10 * scale, "matrix-free apply differs by {err:e}");
}

/// A scene of `BALL` with `extra` settings lines, or with `body` lines added to the ball.
fn ball_with(settings: &str, body: &str) -> String {
    format!("[settings]\n{settings}\n{BALL}{body}\n")
}

#[test]
fn nonsense_values_are_refused_with_the_field_and_the_limit() {
    let cases: &[(String, &[&str])] = &[
        (
            ball_with("gravity = [0.0, 0.0, -1e300]", ""),
            &["settings.gravity", "at most 10000", "got 1e300"],
        ),
        (
            ball_with("", "velocity = [1e300, 0.0, 0.0]"),
            &["bodies[1] (\"ball\").velocity", "at most 10000", "got 1e300"],
        ),
        (
            ball_with("", "angular_velocity = [0.0, 0.0, 1e300]"),
            &["angular_velocity", "got 1e300"],
        ),
        (
            format!(
                "{BALL}[[bodies]]\nname = \"far\"\nshape = {{ type = \"sphere\", radius = 0.1 }}\nposition = [1e300, 0.0, 0.0]\n"
            ),
            &["bodies[2] (\"far\").position", "got 1e300"],
        ),
        (ball_with("steps = 0", ""), &["settings.steps", "between 1 and"]),
        (
            ball_with("steps = 100000000", ""),
            &["settings.steps", "1000000"],
        ),
        (ball_with("dt = 10.0", ""), &["settings.dt", "0.1", "got 10"]),
        (ball_with("dt = 1e-300", ""), &["settings.dt", "got 1e-300"]),
        (ball_with("tolerance = 1e300", ""), &["settings.tolerance", "(0, 1)"]),
        (ball_with("tolerance = 1.0", ""), &["settings.tolerance", "(0, 1)"]),
        (
            ball_with("friction_model = \"pyramid\"\npyramid_directions = 100000", ""),
            &["settings.pyramid_directions", "between 3 and 64", "100000"],
        ),
        ("".to_owned(), &["bodies", "no bodies"]),
        ("name = \"nothing\"\n".to_owned(), &["no bodies"]),
    ];
    for (text, needles) in cases {
        let e = error(text);
        assert!(e.starts_with("test.toml"), "no file in: {e}");
        for n in *needles {
            assert!(e.contains(n), "`{n}` missing from: {e}");
        }
    }
}

#[test]
fn a_static_body_with_a_negative_mass_is_refused() {
    let text = "[[bodies]]\nname = \"ground\"\nshape = { type = \"plane\", normal = [0.0, 0.0, 1.0] }\nstatic = true\nmass = -5.0\n";
    let e = error(text);
    assert!(e.contains("bodies[0] (\"ground\").mass"), "{e}");
    assert!(e.contains("got -5"), "{e}");
}

#[test]
fn a_tiny_mass_is_printed_readably() {
    let e = error(&ball_with("", "mass = 1e-300"));
    assert!(e.contains("bodies[1] (\"ball\").mass"), "{e}");
    assert!(e.contains("got 1e-300"), "{e}");
    assert!(!e.contains("0.0000000"), "{e}");
}

#[test]
fn huge_repeat_counts_and_body_counts_are_refused_before_building() {
    // 1e5³ copies overflows a naive product; 1e5 bodies would need a contact problem far
    // beyond memory. Both are refused at once, naming the limit.
    for count in [
        "[100000, 100000, 100000]",
        "[100, 100, 10]",
        "[18446744073709551615, 2, 1]",
    ] {
        let text = format!(
            "[[bodies]]\nname = \"b\"\nshape = {{ type = \"sphere\", radius = 0.1 }}\nrepeat = {{ count = {count}, spacing = [0.3, 0.3, 0.3] }}\n"
        );
        let e = error(&text);
        assert!(e.contains("bodies[0] (\"b\").repeat.count"), "{e}");
        assert!(e.contains("20000 bodies"), "{e}");
    }
    // At the limit the scene loads.
    assert_eq!(lcpbench_contact::scene::MAX_BODIES, 20_000);
    let text = "[[bodies]]\nname = \"b\"\nshape = { type = \"sphere\", radius = 0.1 }\nrepeat = { count = [100, 20, 10], spacing = [0.3, 0.3, 0.3] }\n";
    assert_eq!(parse(text).unwrap().bodies.len(), 20_000);
}

//! The stated limits of scenes and steps: a step whose broad phase, narrow phase or Delassus
//! matrix would outgrow memory is refused with the limit as its reason instead of aborting the
//! process, and a scene file with nonsense in it is refused on load with the file, the field and
//! the limit.

use lcpbench_contact::builder::MAX_DELASSUS_ENTRIES;
use lcpbench_contact::collision::broad_phase::MAX_PAIRS;
use lcpbench_contact::scene::LoadOptions;
use lcpbench_contact::shape::MAX_MESH_FILE_BYTES;
use lcpbench_contact::{
    ContactSolver, MassSpec, Material, RigidBody, Scene, Shape, SimSettings, World,
};
use lcpbench_solvers::Status;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use std::path::Path;

fn body(name: &str, shape: Shape, z: f64, is_static: bool) -> RigidBody {
    RigidBody::new(
        name,
        shape,
        MassSpec::Density(1000.0),
        Point3::new(0.0, 0.0, z),
        UnitQuaternion::identity(),
        Vector3::zeros(),
        Vector3::zeros(),
        0,
        is_static,
    )
    .unwrap()
}

fn ground() -> RigidBody {
    body("ground", Shape::plane(Vector3::z()).unwrap(), 0.0, true)
}

fn world(bodies: Vec<RigidBody>) -> World {
    let settings = SimSettings {
        steps: 1,
        ..SimSettings::default()
    };
    World::new(bodies, vec![Material::default()], settings)
}

#[track_caller]
fn refused_with(status: &Status, wanted: &str) {
    match status {
        Status::Unsupported { reason } => assert!(reason.contains(wanted), "{reason}"),
        other => panic!("expected a refusal naming `{wanted}`, got {other:?}"),
    }
}

/// A face of a box: origin, the two edge vectors, and whether `u × v` points inward.
type Face = ([f64; 3], [f64; 3], [f64; 3], bool);

/// A closed 1 × 1 × 0.2 slab whose faces are `k × k` grids of triangles: lying on the ground,
/// every vertex of its bottom touches it.
fn grid_slab(k: u32) -> Shape {
    let mut vertices = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut triangles = Vec::new();
    let mut vertex = |p: [f64; 3]| -> u32 {
        let key = p.map(|x| (x * 1e6).round() as i64);
        *index.entry(key).or_insert_with(|| {
            vertices.push(Point3::from(p));
            (vertices.len() - 1) as u32
        })
    };
    let h = 0.2;
    let faces: [Face; 6] = [
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], true),
        ([0.0, 0.0, h], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], false),
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, h], false),
        ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, h], true),
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, h], true),
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, h], false),
    ];
    for (o, u, v, flip) in faces {
        let at = |i: u32, j: u32| {
            let (a, b) = (f64::from(i) / f64::from(k), f64::from(j) / f64::from(k));
            [0, 1, 2].map(|c| o[c] + a * u[c] + b * v[c])
        };
        for i in 0..k {
            for j in 0..k {
                let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)].map(&mut vertex);
                let (t1, t2) = if flip {
                    ([q[0], q[2], q[1]], [q[0], q[3], q[2]])
                } else {
                    ([q[0], q[1], q[2]], [q[0], q[2], q[3]])
                };
                triangles.extend([t1, t2]);
            }
        }
    }
    Shape::trimesh(vertices, triangles, "<grid slab>").unwrap()
}

/// A mesh whose flat bottom touches the ground at 101 × 101 points once asked for a dense
/// 7.5 GB Delassus matrix: every pair of its 30,603 rows couples through the one body.
#[test]
fn a_body_touching_at_ten_thousand_points_is_refused_not_assembled() {
    let slab = grid_slab(100);
    // The slab's centre of mass is at its mid-height: its bottom rests on the ground.
    let mut w = world(vec![ground(), body("slab", slab, 0.1, false)]);
    let report = w.step();
    assert!(report.contacts > 10_000, "{} contacts", report.contacts);
    refused_with(&report.status, "Delassus matrix would store");
    refused_with(&report.status, &MAX_DELASSUS_ENTRIES.to_string());
    refused_with(&report.status, "\"slab\"");
    // A coarse mesh of the same slab steps as usual.
    let mut w = world(vec![ground(), body("slab", grid_slab(2), 0.1, false)]);
    let report = w.step();
    assert!(
        !matches!(report.status, Status::Unsupported { .. }),
        "{:?}",
        report.status
    );
}

/// A body-level solver does not need `A`: the same slab past the entry limit is solved on the
/// bodies (impulses applied, the slab held up), and its shared residual, a pass over every
/// entry of `A`, is left unmeasured, so the step is not `converged`.
#[test]
fn a_body_level_step_past_the_entry_limit_is_solved_and_left_unmeasured() {
    let mut w = world(vec![ground(), body("slab", grid_slab(100), 0.1, false)]);
    w.set_solver(ContactSolver::from_name("si").unwrap());
    w.settings.max_iterations = 5;
    let report = w.step();
    assert!(report.contacts > 10_000, "{} contacts", report.contacts);
    assert!(
        !matches!(
            report.status,
            Status::Unsupported { .. } | Status::Converged
        ),
        "{:?}",
        report.status
    );
    assert!(!report.residual_measured && report.residuals.is_none());
    let supported: f64 = report
        .contact_records
        .iter()
        .map(|c| c.normal_impulse)
        .sum();
    assert!(supported > 0.0, "no impulse applied");
}

/// 1,100 coincident spheres make 604,450 candidate pairs; the broad phase stops past
/// [`MAX_PAIRS`] and the step says so (9,999 of them once took 3.8 GB in the narrow phase).
#[test]
fn coincident_bodies_past_the_pair_limit_are_refused() {
    let n = 1_100;
    assert!(n * (n - 1) / 2 > MAX_PAIRS);
    let sphere = Shape::sphere(0.1).unwrap();
    let bodies = (0..n)
        .map(|i| body(&format!("s{i}"), sphere.clone(), 1.0, false))
        .collect();
    let mut w = world(bodies);
    let report = w.step();
    refused_with(
        &report.status,
        "pairs of bodies have overlapping bounding boxes",
    );
    refused_with(&report.status, &MAX_PAIRS.to_string());
    assert_eq!(report.contacts, 0);
}

const GROUND: &str = r#"
[[bodies]]
name = "ground"
shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
static = true
"#;

const BOX: &str = r#"
[[bodies]]
name = "box"
shape = { type = "box", half_extents = [0.5, 0.5, 0.5] }
position = [0.0, 0.0, 0.5]
"#;

fn scene_error(text: &str) -> String {
    match Scene::parse(text, Path::new("hostile.toml")) {
        Ok(_) => panic!("expected a refusal of:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[track_caller]
fn refused_scene(text: &str, wanted: &[&str]) {
    let e = scene_error(text);
    assert!(e.starts_with("hostile.toml: "), "no file in: {e}");
    for w in wanted {
        assert!(e.contains(w), "`{w}` missing from: {e}");
    }
}

/// Nonsense values (events that never fire, bodies removed twice, deep initial overlaps, huge
/// distances and coefficients) are refused on load, naming the file, the field and the limit.
#[test]
fn scene_nonsense_is_refused_with_the_field_and_the_limit() {
    // An event at a step no run reaches never fires.
    refused_scene(
        &format!("{GROUND}{BOX}[[events]]\nat_step = 100000000000\nremove = \"box\"\n"),
        &["events[0].at_step", "must be below 1000000"],
    );
    // A body removed twice (at two steps, at one step, or as a copy of an entry removed
    // before).
    refused_scene(
        &format!(
            "{GROUND}{BOX}[[events]]\nat_step = 3\nremove = \"box\"\n\
             [[events]]\nat_step = 2\nremove = \"box\"\n"
        ),
        &["events[0].remove", "already removed at step 2 by events[1]"],
    );
    let copies = format!(
        "{GROUND}[[bodies]]\nname = \"s\"\nshape = {{ type = \"sphere\", radius = 0.1 }}\n\
         position = [0.0, 0.0, 0.1]\nrepeat = {{ count = [3, 1, 1], spacing = [1.0, 0.0, 0.0] }}\n"
    );
    refused_scene(
        &format!(
            "{copies}[[events]]\nat_step = 1\nremove = \"s\"\n\
             [[events]]\nat_step = 3\nremove = \"s_1\"\n"
        ),
        &[
            "events[1].remove",
            "\"s_1\" is already removed at step 1 by events[0]",
        ],
    );
    // A copy first, then the rest of its entry, is fine.
    Scene::parse(
        &format!(
            "{copies}[[events]]\nat_step = 1\nremove = \"s_1\"\n\
             [[events]]\nat_step = 3\nremove = \"s\"\n"
        ),
        Path::new("ok.toml"),
    )
    .unwrap();
    // A box 1,000 m below the ground, and two coincident spheres.
    refused_scene(
        &format!(
            "{GROUND}{}",
            BOX.replace("[0.0, 0.0, 0.5]", "[0.0, 0.0, -1000.0]")
        ),
        &[
            "bodies[1] (\"box\").position",
            "deep in \"ground\"",
            "bounding radius",
        ],
    );
    refused_scene(
        "[[bodies]]\nname = \"s\"\nshape = { type = \"sphere\", radius = 0.1 }\n\
         repeat = { count = [2, 1, 1], spacing = [0.0, 0.0, 0.0] }\n",
        &["(\"s_0\").position", "deep in \"s_1\""],
    );
    // Distances and sizes beyond their limits.
    refused_scene(
        &format!("[settings]\nprediction_distance = 1e300\n{GROUND}{BOX}"),
        &["settings.prediction_distance", "at most 1 m", "1e300"],
    );
    refused_scene(
        &format!(
            "{GROUND}[[bodies]]\nname = \"s\"\nshape = {{ type = \"sphere\", radius = 1e300 }}\n\
             position = [0.0, 0.0, 2.0]\n"
        ),
        &[
            "bodies[1] (\"s\").shape",
            "between 1e-6 and 1e6 m",
            "got 1e300",
        ],
    );
    refused_scene(
        &format!(
            "{GROUND}[[bodies]]\nname = \"s\"\nshape = {{ type = \"sphere\", radius = 0.1 }}\n\
             density = 1e-300\nposition = [0.0, 0.0, 2.0]\n"
        ),
        &[
            "bodies[1] (\"s\").density",
            "gives a mass of",
            "outside 1e-9 to 1e15 kg",
        ],
    );
    // Settings whose values only round-off or overflow could meet.
    for (setting, wanted) in [
        (
            "tolerance = 1e-300",
            "settings.tolerance: 1e-300 is below 1e-14",
        ),
        ("restitution_threshold = 1e300", "at most 10000 m/s"),
        ("slop = 1e300", "settings.slop: must be at most 1 m"),
        (
            "solver = \"penalty\"\npenalty_stiffness = 1e300",
            "settings.penalty_stiffness: must be at most 1e20 N/m",
        ),
        (
            "solver = \"penalty\"\npenalty_omega_h = 1e300",
            "settings.penalty_omega_h: must be at most 2",
        ),
    ] {
        refused_scene(&format!("[settings]\n{setting}\n{GROUND}{BOX}"), &[wanted]);
    }
    refused_scene(
        &format!("[[materials]]\nname = \"m\"\nmu = 1e300\n{GROUND}{BOX}"),
        &["materials[0] (\"m\").mu", "between 0 and 100"],
    );
    refused_scene(
        "[[bodies]]\nname = \"s\"\nshape = { type = \"sphere\", radius = 0.1 }\n\
         repeat = { count = [3, 1, 1], spacing = [1e300, 0.0, 0.0] }\n",
        &["bodies[0] (\"s\").repeat.spacing", "copy 1 lands at 1e300"],
    );
    // Resting and slightly overlapping bodies (bench_scenes/overlap_25) still load.
    Scene::parse(&format!("{GROUND}{BOX}"), Path::new("ok.toml")).unwrap();
}

/// Mesh files are read relative to the scene, from regular files in its directory tree of a
/// bounded size; other paths need `LoadOptions::allow_outside_paths`.
#[test]
fn mesh_paths_stay_in_the_scene_tree() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    std::fs::create_dir_all(root.join("scene/meshes")).unwrap();
    std::fs::write(root.join("outside.obj"), tet).unwrap();
    std::fs::write(root.join("scene/meshes/tet.obj"), tet).unwrap();
    let mesh_scene = |file: &str| {
        let text = format!(
            "{GROUND}[[bodies]]\nname = \"m\"\nshape = {{ type = \"mesh\", file = \"{file}\" }}\n\
             position = [0.0, 0.0, 2.0]\n"
        );
        let path = root.join("scene/s.toml");
        std::fs::write(&path, text).unwrap();
        path
    };
    let strict = LoadOptions::default();
    let load = |file: &str, options: &LoadOptions| {
        Scene::load_with(mesh_scene(file), options).map_err(|e| e.to_string())
    };
    load("meshes/tet.obj", &strict).unwrap();
    let outside = root.join("outside.obj");
    let absolute = outside.to_str().unwrap();
    for (file, wanted) in [
        (absolute, "is an absolute path"),
        ("../outside.obj", "outside"),
        ("/dev/zero", "is an absolute path"),
    ] {
        let e = load(file, &strict).unwrap_err();
        assert!(e.contains("bodies[1] (\"m\").shape.file"), "{e}");
        assert!(
            e.contains(wanted) && e.contains("--allow-outside-paths"),
            "{e}"
        );
    }
    let allow = LoadOptions {
        allow_outside_paths: true,
    };
    load(absolute, &allow).unwrap();
    load("../outside.obj", &allow).unwrap();
    // Devices and directories are refused even where outside paths are allowed.
    #[cfg(unix)]
    {
        let e = load("/dev/zero", &allow).unwrap_err();
        assert!(e.contains("a device"), "{e}");
        std::os::unix::fs::symlink(&outside, root.join("scene/link.obj")).unwrap();
        let e = load("link.obj", &strict).unwrap_err();
        assert!(e.contains("leads to") && e.contains("outside"), "{e}");
    }
    let e = load("meshes", &strict).unwrap_err();
    assert!(e.contains("a directory"), "{e}");
    // A file beyond the size limit is refused from its metadata, before it is read.
    let big = std::fs::File::create(root.join("scene/big.obj")).unwrap();
    big.set_len(MAX_MESH_FILE_BYTES + 1).unwrap();
    let e = load("big.obj", &strict).unwrap_err();
    assert!(e.contains("beyond the limit of"), "{e}");
}

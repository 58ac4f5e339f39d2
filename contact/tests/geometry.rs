//! Geometry seen from outside the crate: mass properties against closed forms, OBJ meshes,
//! broad-phase pair counts, contact counts of resting configurations, time of impact.

use lcpbench_contact::collision::broad_phase::{
    brute_force_pairs, candidate_pairs_with_margin, sweep_and_prune, world_aabb, BroadPhase,
};
use lcpbench_contact::collision::shapes::ShapeCache;
use lcpbench_contact::{
    candidate_pairs, CollisionPipeline, MassSpec, RigidBody, Shape, ShapeError,
};
use nalgebra::{Matrix3, Point3, UnitQuaternion, Vector3};
use std::path::PathBuf;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn rel_err(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

fn body(shape: Shape, pos: [f64; 3], is_static: bool) -> RigidBody {
    RigidBody::new(
        "b",
        shape,
        MassSpec::Density(1.0),
        Point3::from(pos),
        UnitQuaternion::identity(),
        Vector3::zeros(),
        Vector3::zeros(),
        0,
        is_static,
    )
    .expect("valid body")
}

fn ground() -> RigidBody {
    body(Shape::plane(Vector3::z()).unwrap(), [0.0; 3], true)
}

/// A field of boxes, spheres and capsules on the ground, two to a column and tilted, so the
/// candidate pairs include box–plane, box–box, sphere–box and capsule–sphere, well above the
/// count from which the narrow phase runs on several threads.
fn mixed_field() -> Vec<RigidBody> {
    let mut bodies = vec![ground()];
    for i in 0..12 {
        for j in 0..12 {
            let (x, y) = (1.1 * i as f64, 1.1 * j as f64);
            let tilt = UnitQuaternion::from_euler_angles(0.01 * i as f64, 0.02 * j as f64, 0.1);
            let mut lower = body(
                Shape::cuboid(Vector3::new(0.5, 0.5, 0.5)).unwrap(),
                [x, y, 0.499],
                false,
            );
            lower.orientation = tilt;
            bodies.push(lower);
            let upper = match (i + j) % 3 {
                0 => Shape::sphere(0.4).unwrap(),
                1 => Shape::capsule(0.2, 0.3).unwrap(),
                _ => Shape::cuboid(Vector3::new(0.45, 0.45, 0.3)).unwrap(),
            };
            bodies.push(body(upper, [x + 0.05, y - 0.03, 1.35], false));
        }
    }
    bodies
}

/// The narrow phase splits its pairs into chunks on rayon's threads and joins them in pair
/// order: its contacts (points, normals, gaps and keys, to the bit) and their order must be
/// those of each pair computed on its own, on the first call and on a later call that reuses
/// the cached manifolds, and must not depend on the number of threads.
#[test]
fn narrow_phase_contacts_do_not_depend_on_threads() {
    use lcpbench_contact::collision::narrow_phase::NarrowPhase;
    let mut bodies = mixed_field();
    let prediction = 0.05;
    let pairs = candidate_pairs(&bodies).unwrap();
    assert!(pairs.len() > 600, "{} pairs", pairs.len());
    let mut whole = NarrowPhase::new();
    let mut one_thread = NarrowPhase::new();
    let mut each: Vec<NarrowPhase> = pairs.iter().map(|_| NarrowPhase::new()).collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for call in 0..2 {
        let all = whole.contacts(&bodies, &pairs, prediction).unwrap();
        let serial = pool.install(|| one_thread.contacts(&bodies, &pairs, prediction).unwrap());
        let mut by_pair = Vec::new();
        for (np, pair) in each.iter_mut().zip(&pairs) {
            by_pair.extend(np.contacts(&bodies, &[*pair], prediction).unwrap());
        }
        assert!(all.len() > 400, "call {call}: {} contacts", all.len());
        assert_eq!(all, by_pair, "call {call}: chunks against pair by pair");
        assert_eq!(all, serial, "call {call}: two threads against one");
        // Move every dynamic body a little, so the second call updates cached manifolds.
        for b in bodies.iter_mut().filter(|b| !b.is_static) {
            b.position.x += 1e-3;
            b.position.z -= 2e-4;
            b.orientation = UnitQuaternion::from_euler_angles(0.003, -0.002, 0.001) * b.orientation;
        }
    }
}

/// Largest relative deviation between two inertia tensors (scaled by the largest entry).
fn tensor_err(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).abs().max() / b.abs().max()
}

#[test]
fn box_inertia_matches_closed_form() {
    let (a, b, c) = (0.3, 0.7, 1.1); // half extents
    let rho = 2.5;
    let mp = Shape::cuboid(Vector3::new(a, b, c))
        .unwrap()
        .mass_properties(rho)
        .unwrap();
    let m = rho * 8.0 * a * b * c;
    let (w, h, d) = (2.0 * a, 2.0 * b, 2.0 * c);
    let expect = Matrix3::from_diagonal(&Vector3::new(
        m * (h * h + d * d) / 12.0,
        m * (w * w + d * d) / 12.0,
        m * (w * w + h * h) / 12.0,
    ));
    let (em, ei) = (rel_err(mp.mass, m), tensor_err(&mp.inertia, &expect));
    println!("box: mass rel err {em:.2e}, inertia rel err {ei:.2e}");
    assert!(em < 1e-12 && ei < 1e-12);
    assert!(mp.com.coords.norm() < 1e-12);
}

#[test]
fn sphere_inertia_matches_closed_form() {
    let (r, rho) = (0.4, 3.0);
    let mp = Shape::sphere(r).unwrap().mass_properties(rho).unwrap();
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let expect = Matrix3::from_diagonal_element(0.4 * m * r * r);
    let (em, ei) = (rel_err(mp.mass, m), tensor_err(&mp.inertia, &expect));
    println!("sphere: mass rel err {em:.2e}, inertia rel err {ei:.2e}");
    assert!(em < 1e-12 && ei < 1e-12);
}

#[test]
fn capsule_inertia_matches_closed_form() {
    // Cylinder of radius r and length h = 2 half_height along z, plus two hemispheres.
    let (hh, r, rho) = (0.6, 0.25, 1.7);
    let h = 2.0 * hh;
    let pi = std::f64::consts::PI;
    let mc = rho * pi * r * r * h;
    let ms = rho * 4.0 / 3.0 * pi * r.powi(3); // both caps together
    let i_axial = mc * r * r / 2.0 + ms * 2.0 * r * r / 5.0;
    // Each hemisphere about its own centre of mass (3r/8 from the flat face), moved to the
    // capsule centre at distance h/2 + 3r/8 (parallel-axis theorem).
    let i_cyl = mc * (3.0 * r * r + h * h) / 12.0;
    let i_caps = ms * (2.0 * r * r / 5.0 + h * h / 4.0 + 3.0 * h * r / 8.0);
    let expect = Matrix3::from_diagonal(&Vector3::new(i_cyl + i_caps, i_cyl + i_caps, i_axial));
    let mp = Shape::capsule(hh, r).unwrap().mass_properties(rho).unwrap();
    let (em, ei) = (rel_err(mp.mass, mc + ms), tensor_err(&mp.inertia, &expect));
    println!("capsule: mass rel err {em:.2e}, inertia rel err {ei:.2e}");
    assert!(em < 1e-12 && ei < 1e-10, "{} vs {}", mp.inertia, expect);
}

#[test]
fn particle_is_a_small_sphere() {
    let r = 1e-3;
    let b = RigidBody::new(
        "p",
        Shape::particle(r).unwrap(),
        MassSpec::Mass(0.5),
        Point3::origin(),
        UnitQuaternion::identity(),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::zeros(),
        0,
        false,
    )
    .unwrap();
    assert!(rel_err(b.mass, 0.5) < 1e-12);
    assert!(rel_err(b.inertia_body[(0, 0)], 0.4 * 0.5 * r * r) < 1e-10);
    assert!(rel_err(b.kinetic_energy(), 0.25) < 1e-12);
}

#[test]
fn unit_cube_obj_volume_and_recentring() {
    let shape = Shape::from_obj(data("unit_cube.obj")).unwrap();
    let mp = shape.mass_properties(1.0).unwrap();
    let Shape::TriMesh { com_offset, .. } = &shape else {
        panic!("expected a mesh")
    };
    println!(
        "unit cube OBJ: volume error {:.2e}",
        (mp.volume - 1.0).abs()
    );
    assert!((mp.volume - 1.0).abs() < 1e-12);
    assert!((com_offset - Vector3::repeat(0.5)).norm() < 1e-12);
    assert!(mp.com.coords.norm() < 1e-12);
    let expect = Matrix3::from_diagonal_element(1.0 / 6.0);
    let ei = tensor_err(&mp.inertia, &expect);
    println!("unit cube OBJ: inertia rel err {ei:.2e}");
    assert!(ei < 1e-12);
}

#[test]
fn l_block_obj_matches_composite_boxes() {
    // Three unit squares extruded to z = 0.5: [0,1]x[0,1], [1,2]x[0,1], [0,1]x[1,2].
    let shape = Shape::from_obj(data("l_block.obj")).unwrap();
    let mp = shape.mass_properties(2.0).unwrap();
    let t = 0.5;
    let centres = [
        Vector3::new(0.5, 0.5, 0.25),
        Vector3::new(1.5, 0.5, 0.25),
        Vector3::new(0.5, 1.5, 0.25),
    ];
    let m_each = 2.0 * t;
    let com = centres.iter().sum::<Vector3<f64>>() / 3.0;
    let mut inertia = Matrix3::zeros();
    for c in &centres {
        let own = Matrix3::from_diagonal(&Vector3::new(
            m_each * (1.0 + t * t) / 12.0,
            m_each * (1.0 + t * t) / 12.0,
            m_each * 2.0 / 12.0,
        ));
        let d = c - com;
        inertia += own + m_each * (Matrix3::identity() * d.dot(&d) - d * d.transpose());
    }
    let Shape::TriMesh { com_offset, .. } = &shape else {
        panic!("expected a mesh")
    };
    let ei = tensor_err(&mp.inertia, &inertia);
    println!(
        "L block OBJ: mass rel err {:.2e}, com err {:.2e}, inertia rel err {ei:.2e}",
        rel_err(mp.mass, 3.0 * m_each),
        (com_offset - com).norm()
    );
    assert!(rel_err(mp.mass, 3.0 * m_each) < 1e-12);
    assert!((com_offset - com).norm() < 1e-12);
    assert!(ei < 1e-12, "{} vs {}", mp.inertia, inertia);
}

#[test]
fn mesh_errors_name_the_file() {
    let missing = data("no_such_mesh.obj");
    let err = Shape::from_obj(&missing).unwrap_err();
    assert!(matches!(err, ShapeError::MeshFile { .. }));
    assert!(err.to_string().contains("no_such_mesh.obj"), "{err}");

    let dir = std::env::temp_dir().join(format!("lcpbench-empty-{}.obj", std::process::id()));
    std::fs::write(&dir, "# nothing here\nv 0 0 0\n").unwrap();
    let err = Shape::from_obj(&dir).unwrap_err();
    assert!(err.to_string().contains("lcpbench-empty"), "{err}");
    let _ = std::fs::remove_file(&dir);
}

#[test]
fn mesh_errors_give_the_line_and_keep_the_os_reason() {
    let missing = data("no_such_mesh.obj");
    let err = Shape::from_obj(&missing).unwrap_err().to_string();
    assert!(err.contains("No such file or directory"), "{err}");

    let bad = std::env::temp_dir().join(format!("lcpbench-bad-{}.obj", std::process::id()));
    std::fs::write(&bad, "# cube\nv 0 0 0\nv 1 0 0\nv 0 1 x\nf 1 2 3\n").unwrap();
    let err = Shape::from_obj(&bad).unwrap_err().to_string();
    let _ = std::fs::remove_file(&bad);
    assert!(err.contains("lcpbench-bad"), "{err}");
    assert!(err.contains("line 4"), "{err}");
}

#[test]
fn sap_pair_count_grows_with_overlaps_on_sparse_grid() {
    // 10 x 10 x 10 grid of spheres, spacing 3r; every tenth sphere along x in the first row
    // is moved to touch its neighbour.
    let r = 0.5;
    let mut bodies = Vec::new();
    let mut touching = 0;
    for i in 0..10 {
        for j in 0..10 {
            for k in 0..10 {
                let mut x = 3.0 * r * i as f64;
                if j == 0 && k == 0 && i % 2 == 1 {
                    x -= r + 1e-3; // centre distance 2r - 1e-3 to the left neighbour
                    touching += 1;
                }
                bodies.push(body(
                    Shape::sphere(r).unwrap(),
                    [x, 3.0 * r * j as f64, 3.0 * r * k as f64],
                    false,
                ));
            }
        }
    }
    assert_eq!(bodies.len(), 1000);
    let pairs = candidate_pairs(&bodies).unwrap();
    println!(
        "1000 spheres: {} candidate pairs, {} touching (n² / 2 = 499500)",
        pairs.len(),
        touching
    );
    assert_eq!(pairs.len(), touching);
    let contacts = CollisionPipeline::new().detect(&bodies, 0.0).unwrap();
    assert_eq!(contacts.len(), touching);
}

#[test]
fn sap_agrees_with_brute_force_on_random_scenes() {
    // Small deterministic generator (xorshift) so the test needs no extra crates.
    let mut s = 0x2545_f491_4f6c_dd1d_u64;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    for scene in 0..20 {
        let n = 50 + 10 * scene;
        let side = 4.0 + scene as f64;
        let mut bodies = Vec::new();
        for i in 0..n {
            let pos = [side * rnd(), side * rnd(), 0.3 * side * rnd()];
            let shape = match i % 3 {
                0 => Shape::sphere(0.2 + 0.5 * rnd()).unwrap(),
                1 => Shape::cuboid(Vector3::new(0.1 + rnd(), 0.1 + rnd(), 0.1 + rnd())).unwrap(),
                _ => Shape::capsule(0.1 + rnd(), 0.1 + 0.3 * rnd()).unwrap(),
            };
            bodies.push(body(shape, pos, rnd() < 0.2));
        }
        let aabbs: Vec<_> = bodies.iter().map(|b| world_aabb(b, 0.0)).collect();
        let skip = |i: usize, j: usize| bodies[i].is_static && bodies[j].is_static;
        let sap = sweep_and_prune(&aabbs, skip);
        let brute = brute_force_pairs(&aabbs, skip);
        assert_eq!(sap, brute, "scene {scene}");
        assert_eq!(candidate_pairs_with_margin(&bodies, 0.0).unwrap(), brute);
    }
}

#[test]
fn planes_pair_with_dynamic_bodies_reaching_them() {
    let bodies = vec![
        ground(),
        body(Shape::sphere(0.5).unwrap(), [0.0, 0.0, 0.5], false),
        body(Shape::sphere(0.5).unwrap(), [5.0, 0.0, 3.0], false),
        body(Shape::sphere(0.5).unwrap(), [9.0, 0.0, 0.2], true),
    ];
    assert_eq!(candidate_pairs(&bodies).unwrap(), vec![(0, 1)]);
}

fn count(bodies: &[RigidBody]) -> usize {
    CollisionPipeline::new().detect(bodies, 1e-3).unwrap().len()
}

#[test]
fn box_on_plane_gives_four_contacts() {
    let bodies = vec![
        ground(),
        body(
            Shape::cuboid(Vector3::new(0.5, 0.4, 0.3)).unwrap(),
            [0.0, 0.0, 0.3 - 1e-4],
            false,
        ),
    ];
    let contacts = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
    assert_eq!(contacts.len(), 4, "{contacts:#?}");
    for c in &contacts {
        assert!((c.dist + 1e-4).abs() < 1e-9);
        assert!((c.normal - Vector3::z()).norm() < 1e-12);
        assert!(c.point.z.abs() < 1e-4);
        assert_eq!((c.body_a, c.body_b), (0, 1));
    }
    let mut keys: Vec<u64> = contacts.iter().map(|c| c.key).collect();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), 4);
}

#[test]
fn box_on_box_gives_four_contacts() {
    let bodies = vec![
        body(
            Shape::cuboid(Vector3::new(1.0, 1.0, 0.5)).unwrap(),
            [0.0; 3],
            true,
        ),
        body(
            Shape::cuboid(Vector3::new(0.3, 0.3, 0.3)).unwrap(),
            [0.1, -0.2, 0.8],
            false,
        ),
    ];
    assert_eq!(count(&bodies), 4);
}

#[test]
fn sphere_on_plane_gives_one_contact() {
    let bodies = vec![
        ground(),
        body(Shape::sphere(0.5).unwrap(), [1.0, 2.0, 0.4999], false),
    ];
    let contacts = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
    assert_eq!(contacts.len(), 1);
    let c = contacts[0];
    assert!((c.dist + 1e-4).abs() < 1e-12);
    assert!((c.point - Point3::new(1.0, 2.0, -0.5e-4)).norm() < 1e-12);
}

#[test]
fn mesh_on_plane_gives_several_contacts() {
    let shape = Shape::from_obj(data("l_block.obj")).unwrap();
    let Shape::TriMesh { com_offset, .. } = &shape else {
        panic!()
    };
    let z = com_offset.z - 1e-4;
    let bodies = vec![ground(), body(shape.clone(), [0.0, 0.0, z], false)];
    let contacts = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
    println!("L block on plane: {} contacts", contacts.len());
    // One per vertex of the L-shaped bottom face.
    assert_eq!(contacts.len(), 6, "{contacts:#?}");
    for c in &contacts {
        assert!((c.normal - Vector3::z()).norm() < 1e-9);
        assert!(c.dist < 0.0 && c.dist > -2e-4);
    }
}

#[test]
fn resting_contacts_persist_with_prediction_and_keep_keys() {
    let mut bodies = vec![
        ground(),
        body(
            Shape::cuboid(Vector3::new(0.5, 0.5, 0.5)).unwrap(),
            [0.0, 0.0, 0.5],
            false,
        ),
    ];
    let mut pipeline = CollisionPipeline::new();
    let first = pipeline.detect(&bodies, 1e-2).unwrap();
    // Lift the box slightly: still within the prediction distance.
    bodies[1].position.z += 5e-3;
    let second = pipeline.detect(&bodies, 1e-2).unwrap();
    assert_eq!(first.len(), 4);
    assert_eq!(second.len(), 4);
    let mut k1: Vec<u64> = first.iter().map(|c| c.key).collect();
    let mut k2: Vec<u64> = second.iter().map(|c| c.key).collect();
    k1.sort_unstable();
    k2.sort_unstable();
    assert_eq!(k1, k2);
    assert!(second.iter().all(|c| (c.dist - 5e-3).abs() < 1e-9));
}

mod time_of_impact {
    use super::*;
    use lcpbench_contact::collision::toi::{
        time_of_impact_bisection, time_of_impact_conservative, Motion, ToiSettings,
    };
    use nalgebra::Isometry3;

    /// A sphere of radius 0.01 at 300 m/s towards a 0.02-thick wall, one step of 0.01 s.
    #[test]
    fn fast_sphere_through_thin_box() {
        let (r, speed, dt) = (0.01, 300.0, 0.01);
        let ball = Shape::sphere(r).unwrap();
        let wall = Shape::cuboid(Vector3::new(0.01, 0.5, 0.5)).unwrap();
        let x0 = -1.0;
        let ma = Motion::new(
            Isometry3::translation(x0, 0.0, 0.0),
            Vector3::new(speed, 0.0, 0.0),
            Vector3::zeros(),
        );
        let mb = Motion::stationary(Isometry3::identity());
        // The ball's surface reaches the wall face x = -0.01 when its centre is at -0.02.
        let t_exact = (-0.01 - r - x0) / speed;

        // The end-of-step test sees nothing: the ball is 2 m past the wall.
        let end = parry3d_f64::query::intersection_test(
            &ma.at(dt),
            &*ball.to_parry(),
            &mb.at(dt),
            &*wall.to_parry(),
        )
        .unwrap();
        assert!(!end, "end-of-step overlap should miss the impact");

        let settings = ToiSettings {
            tolerance: 1e-5,
            ..Default::default()
        };
        let time_tol = settings.tolerance / speed;
        for (name, toi) in [
            (
                "bisection",
                time_of_impact_bisection(&ball, &ma, &wall, &mb, dt, &settings),
            ),
            (
                "conservative advancement",
                time_of_impact_conservative(&ball, &ma, &wall, &mb, dt, &settings),
            ),
        ] {
            let toi = toi.unwrap_or_else(|| panic!("{name}: missed the impact"));
            let err = t_exact - toi.time;
            println!(
                "{name}: t = {:.9e}, exact {t_exact:.9e}, early by {err:.2e} s \
                 (tolerance {time_tol:.2e} s), gap {:.2e} m, {} distance queries",
                toi.time, toi.distance, toi.iterations
            );
            assert!(err >= -1e-12 && err <= time_tol + 1e-12, "{name}: {toi:?}");
            assert!(toi.distance <= settings.tolerance);
        }
    }
}

mod more_detection {
    use super::*;

    fn rotated(shape: Shape, pos: [f64; 3], rot: UnitQuaternion<f64>) -> RigidBody {
        let mut b = body(shape, pos, false);
        b.orientation = rot;
        b
    }

    #[test]
    fn normal_points_from_a_to_b() {
        let bodies = vec![
            body(Shape::sphere(1.0).unwrap(), [0.0; 3], false),
            body(Shape::sphere(1.0).unwrap(), [1.9, 0.0, 0.0], false),
        ];
        let c = CollisionPipeline::new().detect(&bodies, 0.0).unwrap();
        assert_eq!(c.len(), 1);
        assert!((c[0].normal - Vector3::x()).norm() < 1e-12);
        assert!((c[0].dist + 0.1).abs() < 1e-12);
        assert!((c[0].point - Point3::new(0.95, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn capsule_lying_on_plane_gives_two_contacts() {
        let lying =
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
        let bodies = vec![
            ground(),
            rotated(Shape::capsule(0.5, 0.2).unwrap(), [0.0, 0.0, 0.1999], lying),
        ];
        let c = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
        assert_eq!(c.len(), 2, "{c:#?}");
        let mut xs: Vec<f64> = c.iter().map(|c| c.point.x).collect();
        xs.sort_by(f64::total_cmp);
        assert!((xs[0] + 0.5).abs() < 1e-9 && (xs[1] - 0.5).abs() < 1e-9);
    }

    #[test]
    fn hull_on_plane_and_capsule_on_box() {
        let pts: Vec<Point3<f64>> = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ]
        .iter()
        .map(|p| Point3::from(*p))
        .collect();
        let tet = Shape::convex_hull(&pts).unwrap();
        let Shape::ConvexPolyhedron { com_offset, .. } = &tet else {
            panic!()
        };
        let bodies = vec![
            ground(),
            body(tet.clone(), [0.0, 0.0, com_offset.z - 1e-4], false),
        ];
        // The face on z = 0 is a triangle: three contacts.
        assert_eq!(count(&bodies), 3);

        let lying =
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
        let bodies = vec![
            body(
                Shape::cuboid(Vector3::new(1.0, 1.0, 0.5)).unwrap(),
                [0.0; 3],
                true,
            ),
            rotated(Shape::capsule(0.4, 0.1).unwrap(), [0.0, 0.0, 0.5999], lying),
        ];
        // A line contact: parry reports both segment ends (y = ±0.4) and may add an interior
        // point of the same line.
        let c = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
        assert!(c.len() >= 2, "{c:#?}");
        let ys: Vec<f64> = c.iter().map(|c| c.point.y).collect();
        assert!(ys.iter().any(|y| (y - 0.4).abs() < 1e-9));
        assert!(ys.iter().any(|y| (y + 0.4).abs() < 1e-9));
        assert!(c
            .iter()
            .all(|c| (c.dist + 1e-4).abs() < 1e-9 && (c.normal - Vector3::z()).norm() < 1e-9));
    }

    #[test]
    fn torus_is_not_convex() {
        let torus = Shape::from_obj(data("torus.obj")).unwrap();
        // A ball through the hole (inner radius 0.3 at the vertices, 0.294 between them)
        // touches nothing, although it lies well inside the torus's convex hull.
        let bodies = vec![
            body(torus.clone(), [0.0; 3], true),
            body(Shape::sphere(0.25).unwrap(), [0.0; 3], false),
        ];
        assert_eq!(candidate_pairs(&bodies).unwrap(), vec![(0, 1)]);
        assert_eq!(count(&bodies), 0);
        // Moved sideways into the ring it touches.
        let bodies = vec![
            body(torus.clone(), [0.0; 3], true),
            body(Shape::sphere(0.25).unwrap(), [0.1, 0.0, 0.0], false),
        ];
        let c = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
        assert!(!c.is_empty());
        // Normals from the ring towards the ball, i.e. towards the torus axis.
        assert!(
            c.iter()
                .all(|c| c.dist < 0.0 && c.normal.xy().dot(&c.point.coords.xy()) < 0.0),
            "{c:#?}"
        );
    }

    #[test]
    fn torus_on_plane_and_mesh_on_mesh() {
        let torus = Shape::from_obj(data("torus.obj")).unwrap();
        let half = torus.local_aabb().half_extents().z;
        let bodies = vec![
            ground(),
            body(torus.clone(), [0.0, 0.0, half - 1e-4], false),
        ];
        let n = count(&bodies);
        println!("torus on plane: {n} contacts");
        assert!(n >= 3);

        let block = Shape::from_obj(data("l_block.obj")).unwrap();
        // L block resting across a static L block: turned by 90 degrees about z and shifted,
        // so that no side walls are coplanar.
        let quarter =
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
        let bodies = vec![
            body(block.clone(), [0.0; 3], true),
            rotated(block.clone(), [0.1, 0.15, 0.5 - 1e-4], quarter),
        ];
        let c = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
        println!("L block on L block: {} contacts", c.len());
        assert!(c.len() >= 3);
        assert!(
            c.iter().all(|c| c.normal.z > 0.99 && c.dist < 0.0),
            "{c:#?}"
        );

        // Flush stack of identical blocks: the coplanar side walls must not produce the
        // wall-long penetrations parry's triangle pairs report (2 m here). Vertical contacts
        // remain at (at least) five of the six footprint corners; parry reports the sixth only
        // with a sideways normal.
        let bodies = vec![
            body(block.clone(), [0.0; 3], true),
            body(block.clone(), [0.0, 0.0, 0.5 - 1e-4], false),
        ];
        let c = CollisionPipeline::new().detect(&bodies, 1e-3).unwrap();
        let deepest = c.iter().map(|c| c.dist).fold(0.0, f64::min);
        println!("flush L stack: {} contacts, deepest {deepest:.2e}", c.len());
        assert!(deepest > -1e-3, "{c:#?}");
        let vertical = c.iter().filter(|c| c.normal.z > 0.99).count();
        assert!(vertical >= 5, "{c:#?}");
    }

    #[test]
    fn box_on_box_keys_survive_small_motion() {
        let mut bodies = vec![
            body(
                Shape::cuboid(Vector3::new(1.0, 1.0, 0.5)).unwrap(),
                [0.0; 3],
                true,
            ),
            body(
                Shape::cuboid(Vector3::new(0.3, 0.3, 0.3)).unwrap(),
                [0.1, -0.2, 0.8],
                false,
            ),
        ];
        let mut pipeline = CollisionPipeline::new();
        let mut first: Vec<u64> = pipeline
            .detect(&bodies, 1e-2)
            .unwrap()
            .iter()
            .map(|c| c.key)
            .collect();
        bodies[1].position.x += 1e-3;
        bodies[1].position.z += 1e-3;
        let mut second: Vec<u64> = pipeline
            .detect(&bodies, 1e-2)
            .unwrap()
            .iter()
            .map(|c| c.key)
            .collect();
        first.sort_unstable();
        second.sort_unstable();
        assert_eq!(first.len(), 4);
        assert_eq!(first, second);
    }
}

mod first_impact_in_scene {
    use super::*;
    use lcpbench_contact::collision::toi::{first_impact, ToiMethod, ToiSettings};

    #[test]
    fn bullet_through_wall_among_other_bodies() {
        let (r, speed, dt) = (0.01, 300.0, 0.01);
        let mut bodies = vec![ground()];
        // Resting boxes (touching the ground: contacts, not impacts) away from the path.
        for i in 0..20 {
            bodies.push(body(
                Shape::cuboid(Vector3::new(0.1, 0.1, 0.1)).unwrap(),
                [-5.0 + 0.5 * i as f64, 3.0, 0.1],
                false,
            ));
        }
        bodies.push(body(
            Shape::cuboid(Vector3::new(0.01, 0.5, 0.5)).unwrap(),
            [0.0, 0.0, 1.0],
            true,
        ));
        let mut bullet = body(Shape::sphere(r).unwrap(), [-1.0, 0.0, 1.0], false);
        bullet.linear_momentum = bullet.mass * Vector3::new(speed, 0.0, 0.0);
        bodies.push(bullet);
        let (wall, bullet) = (bodies.len() - 2, bodies.len() - 1);
        let t_exact = (-0.01 - r + 1.0) / speed;
        let settings = ToiSettings {
            tolerance: 1e-5,
            ..Default::default()
        };
        for method in [ToiMethod::Bisection, ToiMethod::ConservativeAdvancement] {
            let hit = first_impact(&bodies, dt, method, &settings)
                .unwrap()
                .expect("impact");
            assert_eq!((hit.body_a, hit.body_b), (wall, bullet), "{method:?}");
            let err = t_exact - hit.toi.time;
            println!("first_impact {method:?}: early by {err:.2e} s");
            assert!(err >= -1e-12 && err <= settings.tolerance / speed + 1e-12);
        }
        // Without the bullet's speed nothing happens within the step.
        bodies[bullet].linear_momentum = Vector3::zeros();
        assert!(first_impact(&bodies, dt, ToiMethod::default(), &settings)
            .unwrap()
            .is_none());
    }

    #[test]
    fn fast_fall_onto_the_ground() {
        // A spinning box falling at 50 m/s, 0.3 m above the ground at the start of a 0.01 s step.
        let mut b = body(
            Shape::cuboid(Vector3::new(0.1, 0.2, 0.05)).unwrap(),
            [0.0, 0.0, 0.35],
            false,
        );
        b.linear_momentum = b.mass * Vector3::new(0.0, 0.0, -50.0);
        b.angular_momentum = b.inertia_world() * Vector3::new(0.0, 0.0, 3.0);
        let bodies = vec![ground(), b];
        let settings = ToiSettings::default();
        let t_exact = 0.3 / 50.0; // spin about z keeps the bottom face horizontal
        for method in [ToiMethod::Bisection, ToiMethod::ConservativeAdvancement] {
            let hit = first_impact(&bodies, 0.01, method, &settings)
                .unwrap()
                .expect("impact");
            let err = t_exact - hit.toi.time;
            println!(
                "fall {method:?}: early by {err:.2e} s, {} queries",
                hit.toi.iterations
            );
            assert!(
                err >= -1e-12 && err <= settings.tolerance / 50.0 + 1e-12,
                "{hit:?}"
            );
        }
    }
}

mod properties {
    use super::*;
    use parry3d_f64::bounding_volume::Aabb;
    use proptest::prelude::*;

    /// A box with centre in `[0, 10]³` and half extents in `[0.05, 1.5]`.
    fn aabb() -> impl Strategy<Value = Aabb> {
        (
            prop::array::uniform3(0.0..10.0f64),
            prop::array::uniform3(0.05..1.5f64),
        )
            .prop_map(|(c, h)| {
                let (c, h) = (Vector3::from(c), Vector3::from(h));
                Aabb::new((c - h).into(), (c + h).into())
            })
    }

    /// Two spheres with radii in `[0.1, 1]`, the second placed at a planted gap in
    /// `[-0.05, 0.05]` along a random direction.
    fn sphere_pair() -> impl Strategy<Value = (f64, f64, Vector3<f64>, f64)> {
        (
            0.1..1.0f64,
            0.1..1.0f64,
            prop::array::uniform3(-1.0..1.0f64),
            -0.05..0.05f64,
        )
            .prop_filter("direction", |(_, _, d, _)| Vector3::from(*d).norm() > 0.1)
            .prop_map(|(r1, r2, d, gap)| (r1, r2, Vector3::from(d).normalize(), gap))
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

        #[test]
        fn sweep_and_prune_equals_brute_force(
            boxes in prop::collection::vec(aabb(), 0..120),
            statics in prop::collection::vec(any::<bool>(), 120),
        ) {
            let skip = |i: usize, j: usize| statics[i] && statics[j];
            prop_assert_eq!(sweep_and_prune(&boxes, skip), brute_force_pairs(&boxes, skip));
        }

        /// The broad phase that keeps its sweep order between calls returns, at every step of
        /// a moving scene, exactly the pairs of the from-scratch broad phase (and of brute
        /// force), including when bodies swap places along the sweep axis, a plane is in the
        /// scene and some bodies are static.
        #[test]
        fn persistent_broad_phase_follows_a_moving_scene(
            start in prop::collection::vec(prop::array::uniform3(0.0..6.0f64), 2..40),
            velocity in prop::collection::vec(prop::array::uniform3(-3.0..3.0f64), 40),
            kind in prop::collection::vec(0..3u8, 40),
            statics in prop::collection::vec(prop::bool::weighted(0.2), 40),
            margin in 0.0..0.2f64,
        ) {
            let mut bodies = vec![body(Shape::plane(Vector3::z()).unwrap(), [0.0; 3], true)];
            for (k, p) in start.iter().enumerate() {
                let shape = match kind[k] {
                    0 => Shape::sphere(0.4).unwrap(),
                    1 => Shape::cuboid(Vector3::new(0.5, 0.2, 0.3)).unwrap(),
                    _ => Shape::capsule(0.3, 0.2).unwrap(),
                };
                bodies.push(body(shape, *p, statics[k]));
            }
            let mut shapes = ShapeCache::new();
            let mut broad = BroadPhase::new();
            for step in 0..15 {
                shapes.update(&bodies);
                let kept = broad.candidate_pairs(&bodies, &shapes, margin).unwrap();
                let fresh = candidate_pairs_with_margin(&bodies, margin).unwrap();
                prop_assert_eq!(&kept, &fresh, "step {}", step);
                // The same against brute force over the bounded bodies (index 0 is the plane).
                let boxes: Vec<_> = bodies[1..].iter().map(|b| world_aabb(b, 0.5 * margin)).collect();
                let brute: Vec<(usize, usize)> =
                    brute_force_pairs(&boxes, |i, j| bodies[i + 1].is_static && bodies[j + 1].is_static)
                        .into_iter()
                        .map(|(i, j)| (i + 1, j + 1))
                        .collect();
                let swept: Vec<(usize, usize)> = kept.iter().copied().filter(|p| p.0 != 0).collect();
                prop_assert_eq!(swept, brute, "step {}", step);
                // Move and turn the dynamic bodies (0.05 s of their velocity).
                for (k, b) in bodies.iter_mut().enumerate().skip(1) {
                    if !b.is_static {
                        b.position += 0.05 * Vector3::from(velocity[k - 1]);
                        b.orientation = UnitQuaternion::from_euler_angles(0.1, 0.05 * k as f64, -0.07) * b.orientation;
                    }
                }
            }
        }

        #[test]
        fn sphere_pair_gap_is_planted((r1, r2, dir, gap) in sphere_pair()) {
            let c2 = dir * (r1 + r2 + gap);
            let bodies = vec![
                body(Shape::sphere(r1).unwrap(), [0.0; 3], false),
                body(Shape::sphere(r2).unwrap(), c2.into(), false),
            ];
            let contacts = CollisionPipeline::new().detect(&bodies, 0.1).unwrap();
            prop_assert_eq!(contacts.len(), 1);
            let c = contacts[0];
            prop_assert!((c.dist - gap).abs() < 1e-12);
            prop_assert!((c.normal - dir).norm() < 1e-12);
            let mid = dir * (r1 + 0.5 * gap);
            prop_assert!((c.point.coords - mid).norm() < 1e-12);
        }
    }
}

#[test]
fn convex_hull_of_obj_fills_the_notch() {
    // Hull of the L block: the footprint pentagon (0,0) (2,0) (2,1) (1,2) (0,2) of area 3.5,
    // extruded to 0.5.
    let hull = Shape::convex_hull_from_obj(data("l_block.obj")).unwrap();
    let mp = hull.mass_properties(1.0).unwrap();
    println!(
        "L block hull: volume error {:.2e}",
        (mp.volume - 1.75).abs()
    );
    assert!((mp.volume - 1.75).abs() < 1e-12);
    assert!(Shape::convex_hull_from_obj(data("missing.obj")).is_err());
}

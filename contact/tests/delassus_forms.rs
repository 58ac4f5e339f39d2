//! The two forms of a step's Delassus matrix, assembled and factored, give the same numbers: the
//! products and the rows themselves agree bit for bit on a built scene problem, the shared
//! residual and the data-resolution test to round-off (the factored form sums each row's terms
//! in its own order, [`lcpbench_solvers::DelassusFactors::row_terms`]), and projected
//! Gauss–Seidel returns the same impulse and status on both.

use lcpbench_contact::builder::{self, ContactSystem, DelassusForm};
use lcpbench_contact::Scene;
use lcpbench_solvers::metrics::{unresolved_row, Unresolved};
use lcpbench_solvers::{residuals, Problem, ProjectedSor, Residuals, Settings, Solver, SweepForm};
use std::path::PathBuf;

/// The contact system of `pyramid_10` after a few steps (contacts loaded, warm).
fn pyramid_system() -> ContactSystem {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../bench_scenes/pyramid_10.toml");
    let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    let mut world = scene.world();
    world.run(3);
    let contacts = world
        .pipeline
        .detect(&world.bodies, world.settings.prediction_distance)
        .unwrap();
    let (h, gravity) = (world.settings.dt, world.settings.gravity);
    let free = builder::free_velocities(&world.bodies, &gravity, h);
    builder::build(
        &world.bodies,
        &world.materials,
        &contacts,
        free,
        &world.settings.builder,
        h,
    )
}

/// A test impulse with loaded and idle rows of both signs.
fn impulse(n: usize, scale: f64) -> Vec<f64> {
    (0..n)
        .map(|i| scale * (((i * 37) % 11) as f64 - 3.0) / 7.0)
        .collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Every measure of `a` and `b` within `1e-12` of the larger (round-off of the order in which
/// each row's terms are summed).
fn assert_close(a: Residuals, b: Residuals) {
    for (x, y) in [
        (a.natural_map, b.natural_map),
        (a.natural_map_rel, b.natural_map_rel),
        (a.complementarity_gap, b.complementarity_gap),
        (a.bound_violation, b.bound_violation),
    ] {
        assert!(
            (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
            "{a:?} vs {b:?}"
        );
    }
}

/// The same unresolved row, its measures to round-off.
fn assert_same_unresolved(a: Option<Unresolved>, b: Option<Unresolved>) {
    assert_eq!(a.map(|u| u.row), b.map(|u| u.row));
    if let (Some(a), Some(b)) = (a, b) {
        assert!(
            (a.ratio() - b.ratio()).abs() <= 1e-12 * a.ratio(),
            "{a:?} vs {b:?}"
        );
    }
}

#[test]
fn factored_and_assembled_forms_agree() {
    let system = pyramid_system();
    let n = system.n();
    assert!(n > 100, "the pyramid is loaded: {n} rows");
    let assembled = system.problem_in(DelassusForm::Assembled).unwrap();
    let factored = system.problem_in(DelassusForm::Factored).unwrap();
    assert!(factored.is_factored() && !factored.is_assembled());
    assert!(assembled.is_assembled() && !assembled.is_factored());
    assert_eq!(factored.nnz(), assembled.nnz());
    for i in 0..n {
        assert_eq!(
            factored.diagonal(i).to_bits(),
            assembled.diagonal(i).to_bits()
        );
    }
    assert_eq!(
        bits(&factored.diagonal_scale()),
        bits(&assembled.diagonal_scale())
    );
    assert_eq!(factored.islands(), assembled.islands());
    for scale in [1.0, 1e9] {
        let f = impulse(n, scale);
        let (wf, wa) = (factored.velocity(&f), assembled.velocity(&f));
        assert_eq!(bits(&wf), bits(&wa));
        assert_close(residuals(&factored, &f), residuals(&assembled, &f));
        assert_same_unresolved(
            unresolved_row(&factored, &f, &wf),
            unresolved_row(&assembled, &f, &wa),
        );
    }
    // The huge impulse is not resolved against the data: the test sees it in both forms.
    let f = impulse(n, 1e9);
    assert!(unresolved_row(&factored, &f, &factored.velocity(&f)).is_some());
    // Off-diagonal entries, read from the factors.
    for (i, j) in [(0, 1), (1, 0), (5, n - 1), (n / 2, n / 2 + 2)] {
        assert_eq!(
            factored.entry(i, j).to_bits(),
            assembled.entry(i, j).to_bits()
        );
    }
    assert!(!factored.is_assembled(), "measuring did not assemble A");
    // Reading a row assembles A from the factors: the same entries.
    for i in 0..n {
        let (rf, ra) = (factored.row(i), assembled.row(i));
        let ef: Vec<(usize, u64)> = rf.iter().map(|(j, v)| (j, v.to_bits())).collect();
        let ea: Vec<(usize, u64)> = ra.iter().map(|(j, v)| (j, v.to_bits())).collect();
        assert_eq!(ef, ea, "row {i}");
    }
    assert!(factored.is_assembled());
}

#[test]
fn island_problems_agree_in_both_forms() {
    let system = pyramid_system();
    let partition = system.islands();
    for k in 0..partition.len() {
        let a = system
            .island_problem_in(&partition, k, DelassusForm::Assembled)
            .unwrap();
        let f = system
            .island_problem_in(&partition, k, DelassusForm::Factored)
            .unwrap();
        let x = impulse(a.n(), 2.0);
        assert_eq!(bits(&a.velocity(&x)), bits(&f.velocity(&x)));
        assert_close(residuals(&a, &x), residuals(&f, &x));
    }
}

fn solve(problem: &Problem, pgs: ProjectedSor, settings: &Settings) -> (Vec<f64>, String) {
    let mut pgs = pgs;
    let r = pgs.solve(problem, settings);
    (r.f, r.status.name().to_string())
}

#[test]
fn projected_gauss_seidel_returns_the_same_impulse_on_both_forms() {
    let system = pyramid_system();
    let assembled = system.problem_in(DelassusForm::Assembled).unwrap();
    let factored = system.problem_in(DelassusForm::Factored).unwrap();
    assert!(ProjectedSor::pgs().works_on_factors());
    assert!(!ProjectedSor::pgs()
        .with_sweep(SweepForm::Assembled)
        .works_on_factors());
    for (tolerance, max_iterations) in [(1e-6, 20), (1e-8, 2_000)] {
        let settings = Settings {
            tolerance,
            max_iterations,
            ..Settings::default()
        };
        // Matrix-free sweeps on both: the same numbers bit for bit, and A stays unassembled.
        let (fa, sa) = solve(&assembled, ProjectedSor::pgs(), &settings);
        let (ff, sf) = solve(&factored, ProjectedSor::pgs(), &settings);
        assert_eq!(sa, sf);
        assert_eq!(bits(&fa), bits(&ff));
        assert!(!factored.is_assembled());
        // Sweeps over the assembled rows: the same impulse to round-off, the same status.
        let (fr, sr) = solve(
            &assembled,
            ProjectedSor::pgs().with_sweep(SweepForm::Assembled),
            &settings,
        );
        assert_eq!(sr, sf, "tolerance {tolerance}");
        let largest = ff.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(largest > 0.0);
        for (x, y) in fr.iter().zip(&ff) {
            assert!((x - y).abs() <= 1e-9 * largest, "{x} vs {y}");
        }
    }
}

#[test]
fn a_non_finite_factor_is_an_input_error_naming_it() {
    use faer::sparse::{SparseRowMat, Triplet};
    use lcpbench_solvers::{DelassusFactors, ProblemError};
    let mut eye = [[0.0; 6]; 6];
    for (k, row) in eye.iter_mut().enumerate() {
        row[k] = 1.0;
    }
    let factored = |jv: f64, m: [[f64; 6]; 6]| {
        let t = [Triplet::new(0, 0, jv), Triplet::new(1, 2, 1.0)];
        let j = SparseRowMat::try_new_from_triplets(2, 6, &t).unwrap();
        let factors = DelassusFactors::new(j, vec![m]).unwrap();
        Problem::boxed_factored(
            factors,
            vec![-1.0; 2],
            vec![0.0; 2],
            vec![f64::INFINITY; 2],
            vec![],
        )
    };
    assert!(factored(1.0, eye).is_ok());
    match factored(f64::NAN, eye) {
        Err(ProblemError::NonFinite { what, .. }) => assert_eq!(what, "J[0][0]"),
        other => panic!("{other:?}"),
    }
    let mut bad = eye;
    bad[2][2] = f64::INFINITY;
    match factored(1.0, bad) {
        Err(ProblemError::NonFinite { what, value }) => {
            assert_eq!(what, "the inverse-mass block of body 0");
            assert_eq!(value, f64::INFINITY);
        }
        other => panic!("{other:?}"),
    }
    // Finite factors whose product overflows.
    match factored(1e200, eye) {
        Err(ProblemError::NonFinite { what, .. }) => assert_eq!(what, "A[0][0]"),
        other => panic!("{other:?}"),
    }
}

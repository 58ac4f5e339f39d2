//! The exact Coulomb cone seen from outside: analytic incline cases (stick at and below the
//! friction angle, isotropic sliding past it, in several tangent directions, against the box
//! model's anisotropy), fixed-seed property tests that every `converged` cone solve meets the
//! cone residual computed here independently, and the convex relaxation (`clarabel-socp`):
//! exact where contacts stick or take off, lifting off where they slide.

use faer::Mat;
use lcpbench_solvers::{
    delassus_asymmetry, sparse_from_triplets, AdmmCone, ClarabelSocp, ConeProblem, ConeSolver,
    ConeSolverKind, Dantzig, NewtonAc, NsgsCone, NsgsConeSettings, Settings, SolveResult, Solver,
    Status, SYMMETRISE_WITHIN,
};
use rand::{Rng, SeedableRng};

const G: f64 = 9.81;
const H: f64 = 1.0 / 60.0;
const MASS: f64 = 2.0;
const MU: f64 = 0.5;

/// A block of mass `MASS` on an incline of slope `alpha`, its downhill direction at angle `phi`
/// in the tangent plane: `W = I / m`, `q = h g (−cos α, sin α cos φ, sin α sin φ)`.
fn incline(alpha: f64, phi: f64) -> ConeProblem {
    let w = Mat::from_fn(3, 3, |i, j| if i == j { 1.0 / MASS } else { 0.0 });
    let q = vec![
        -H * G * alpha.cos(),
        H * G * alpha.sin() * phi.cos(),
        H * G * alpha.sin() * phi.sin(),
    ];
    ConeProblem::new(w, q, vec![MU]).unwrap()
}

/// A tight tolerance, and a cap that leaves room for the first-order methods (`eg-cone`,
/// `fpp-cone`, `admm-cone`, `prox-cone`: a few hundred iterations at 1e-12 on these problems).
fn tight() -> Settings {
    Settings {
        tolerance: 1e-12,
        max_iterations: 5000,
        ..Settings::default()
    }
}

/// The solvers of Coulomb's law itself (not of a relaxation).
fn exact_solvers() -> impl Iterator<Item = ConeSolverKind> {
    ConeSolverKind::all()
        .into_iter()
        .filter(|k| !k.is_relaxation())
}

fn solve_all(p: &ConeProblem) -> Vec<(&'static str, SolveResult)> {
    exact_solvers()
        .map(|k| (k.name(), k.create().solve_cone(p, &tight())))
        .collect()
}

const DIRECTIONS_DEG: [f64; 4] = [0.0, 30.0, 45.0, 77.0];

#[test]
fn incline_below_and_at_the_friction_angle_sticks() {
    let angle = MU.atan();
    for alpha in [0.7 * angle, angle] {
        for deg in DIRECTIONS_DEG {
            let p = incline(alpha, deg.to_radians());
            let scale = H * G;
            for (name, r) in solve_all(&p) {
                assert_eq!(r.status, Status::Converged, "{name} α {alpha} φ {deg}");
                // u = 0 and r = −m q: the friction force balances the push.
                let u = &r.w;
                assert!(u.iter().all(|v| v.abs() <= 1e-9 * scale), "{name}: u {u:?}");
                for (ri, qi) in r.f.iter().zip(p.q()) {
                    assert!((ri + MASS * qi).abs() <= 1e-9 * MASS * scale, "{name}");
                }
                assert!(r.f[1].hypot(r.f[2]) <= MU * r.f[0] * (1.0 + 1e-9));
            }
        }
    }
}

#[test]
fn incline_past_the_friction_angle_slides_isotropically() {
    let alpha = (1.2 * MU).atan();
    let rn = MASS * H * G * alpha.cos();
    let speed = H * G * (alpha.sin() - MU * alpha.cos());
    for deg in DIRECTIONS_DEG {
        let phi: f64 = deg.to_radians();
        let d = [phi.cos(), phi.sin()];
        let p = incline(alpha, phi);
        for (name, r) in solve_all(&p) {
            assert_eq!(r.status, Status::Converged, "{name} φ {deg}");
            let (f, u) = (&r.f, &r.w);
            // u_N = 0, r_N = m g h cos α.
            assert!(u[0].abs() <= 1e-10 * H * G, "{name}: u_N {}", u[0]);
            assert!((f[0] - rn).abs() <= 1e-10 * rn, "{name}");
            // ‖r_T‖ = mu r_N, opposite the push and the sliding velocity.
            for k in 0..2 {
                assert!(
                    (f[1 + k] + MU * rn * d[k]).abs() <= 1e-10 * rn,
                    "{name} φ {deg}"
                );
                assert!(
                    (u[1 + k] - speed * d[k]).abs() <= 1e-10 * H * G,
                    "{name} φ {deg}"
                );
            }
        }
    }
}

/// The box model on the same data: each tangent row bounded by `mu r_N` on its own, so the
/// friction force depends on the direction of the push. Past the friction angle (tan α = 1.2 mu)
/// it slides along a tangent axis but sticks at 45° (a friction force of 1.2 mu r_N, outside the
/// Coulomb cone); at 30° it slides along t1 only, not along the push.
#[test]
fn box_model_is_anisotropic_where_the_cone_is_not() {
    let alpha = (1.2 * MU).atan();
    let rn = MASS * H * G * alpha.cos();
    let box_solve = |deg: f64| {
        let b = incline(alpha, deg.to_radians()).to_box();
        let r = Dantzig::default().solve(&b, &Settings::default());
        assert_eq!(r.status, Status::Converged, "box φ {deg}");
        r
    };
    let r0 = box_solve(0.0);
    assert!(r0.w[1] > 1e-3, "box slides along t1: {:?}", r0.w);
    assert!((r0.f[1].hypot(r0.f[2]) - MU * rn).abs() <= 1e-9 * rn);
    let r45 = box_solve(45.0);
    assert!(
        r45.w[1].hypot(r45.w[2]) <= 1e-12,
        "box sticks at 45°: {:?}",
        r45.w
    );
    let friction = r45.f[1].hypot(r45.f[2]);
    assert!(
        (friction / (MU * rn) - 1.2).abs() < 1e-9,
        "box friction at 45° is {} mu r_N",
        friction / (MU * rn)
    );
    let r30 = box_solve(30.0);
    assert!(
        r30.w[1] > 1e-3 && r30.w[2].abs() <= 1e-12,
        "box at 30°: {:?}",
        r30.w
    );
    // The cone on the same data: the same sliding speed in every direction.
    let speeds: Vec<f64> = [0.0, 30.0, 45.0]
        .iter()
        .map(|deg: &f64| {
            let r = ConeSolverKind::NsgsCone
                .create()
                .solve_cone(&incline(alpha, deg.to_radians()), &tight());
            r.w[1].hypot(r.w[2])
        })
        .collect();
    for s in &speeds {
        assert!(
            (s - speeds[0]).abs() <= 1e-10 * speeds[0] && *s > 1e-3,
            "{speeds:?}"
        );
    }
}

/// The projection onto `‖x_T‖ <= mu x_N`, written from the cone's geometry (half-angle
/// `atan(mu)`), independently of the library's.
fn project(mu: f64, x: [f64; 3]) -> [f64; 3] {
    let norm = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    if norm == 0.0 {
        return x;
    }
    let t = x[1].hypot(x[2]);
    let theta = t.atan2(x[0]);
    let half = mu.atan();
    if theta <= half {
        x
    } else if theta >= half + std::f64::consts::FRAC_PI_2 {
        [0.0; 3]
    } else {
        let len = norm * (theta - half).cos();
        let dir = if t > 0.0 {
            [x[1] / t, x[2] / t]
        } else {
            [0.0, 0.0]
        };
        [
            len * half.cos(),
            len * half.sin() * dir[0],
            len * half.sin() * dir[1],
        ]
    }
}

/// The relative cone residual (the definition in `lcpbench_solvers::cone`), from a dense `W`.
fn independent_residual(w: &Mat<f64>, q: &[f64], mu: &[f64], r: &[f64]) -> f64 {
    let n = q.len();
    let mut worst: f64 = 0.0;
    for (c, &m) in mu.iter().enumerate() {
        let mut u = [0.0; 3];
        let mut t = [0.0; 3];
        for a in 0..3 {
            let i = 3 * c + a;
            u[a] = q[i] + (0..n).map(|j| w[(i, j)] * r[j]).sum::<f64>();
            t[a] = q[i].abs() + (0..n).map(|j| (w[(i, j)] * r[j]).abs()).sum::<f64>();
        }
        let d = w[(3 * c, 3 * c)];
        let uh = [u[0] + m * u[1].hypot(u[2]), u[1], u[2]];
        let rc = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
        let p = project(m, [rc[0] - uh[0] / d, rc[1] - uh[1] / d, rc[2] - uh[2] / d]);
        let e = ((rc[0] - p[0]).powi(2) + (rc[1] - p[1]).powi(2) + (rc[2] - p[2]).powi(2)).sqrt();
        let tn = t[0] + m * t[1].hypot(t[2]);
        let s = (tn * tn + t[1] * t[1] + t[2] * t[2]).sqrt() / d;
        if e > 0.0 {
            worst = worst.max(e / s);
        }
    }
    worst
}

/// Contacts with `W = J Jᵀ + 10⁻³ I` from a random Jacobian, approaching normals, random pushes
/// and coefficients.
fn random_contacts(contacts: usize, dofs: usize, seed: u64) -> (Mat<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let n = 3 * contacts;
    let j = Mat::from_fn(n, dofs, |_, _| rng.random_range(-1.0..1.0));
    let w = Mat::from_fn(n, n, |r, c| {
        (0..dofs).map(|k| j[(r, k)] * j[(c, k)]).sum::<f64>() + if r == c { 1e-3 } else { 0.0 }
    });
    let q = (0..n)
        .map(|i| {
            if i % 3 == 0 {
                rng.random_range(-1.0..0.2)
            } else {
                rng.random_range(-0.5..0.5)
            }
        })
        .collect();
    let mu = (0..contacts).map(|_| rng.random_range(0.1..1.0)).collect();
    (w, q, mu)
}

/// The problem `(W, q, mu)` with `W`'s nonzero entries stored sparse.
fn stored_sparse(w: &Mat<f64>, q: &[f64], mu: &[f64]) -> ConeProblem {
    let triplets: Vec<_> = (0..w.nrows())
        .flat_map(|i| (0..w.ncols()).map(move |j| (i, j)))
        .map(|(i, j)| (i, j, w[(i, j)]))
        .filter(|t| t.2 != 0.0)
        .collect();
    ConeProblem::new_sparse(
        sparse_from_triplets(w.nrows(), &triplets).unwrap(),
        q.to_vec(),
        mu.to_vec(),
    )
    .unwrap()
}

#[test]
fn every_converged_cone_solve_meets_the_independent_residual() {
    let settings = Settings {
        tolerance: 1e-8,
        max_iterations: 2000,
        ..Settings::default()
    };
    for kind in ConeSolverKind::all() {
        let mut converged = 0;
        for seed in 0..24u64 {
            let contacts = 1 + (seed as usize % 5);
            let (w, q, mu) = random_contacts(contacts, 6 * contacts, seed);
            let p = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
            let r = kind.create().solve_cone(&p, &settings);
            assert!(
                r.f.iter().all(|v| v.is_finite()),
                "{} seed {seed}",
                kind.name()
            );
            let independent = independent_residual(&w, &q, &mu, &r.f);
            let reported = r.residuals.natural_map_rel;
            assert!(
                (independent - reported).abs() <= 1e-9 * reported.max(1e-6),
                "{} seed {seed}: reported {reported:e}, independent {independent:e}",
                kind.name()
            );
            if r.status.is_converged() {
                converged += 1;
                assert!(
                    independent <= settings.tolerance,
                    "{} seed {seed}",
                    kind.name()
                );
            } else {
                // A solver that refuses the problem (`sap` needs the factors of W, which these
                // problems have not) answers nothing, whatever the residual of its zero.
                assert!(
                    reported > settings.tolerance || matches!(r.status, Status::Unsupported { .. }),
                    "{} seed {seed}",
                    kind.name()
                );
            }
        }
        // The relaxation converges only where no contact slides (few of these cases).
        assert!(
            kind.is_relaxation() || converged >= 18,
            "{}: only {converged} of 24 converged",
            kind.name()
        );
    }
}

/// With `mu = 0` the cone problem is the frictionless LCP on the normal rows plus free tangents
/// with zero reaction; the cone solvers (the relaxation included) agree with the box form solved
/// by Dantzig.
#[test]
fn frictionless_cone_agrees_with_the_lcp() {
    for seed in 0..4u64 {
        let (w, q, _) = random_contacts(3, 18, 100 + seed);
        let p = ConeProblem::new(w, q, vec![0.0; 3]).unwrap();
        let reference = Dantzig::default().solve(&p.to_box(), &Settings::default());
        assert_eq!(reference.status, Status::Converged);
        // Without friction the relaxation is the problem itself.
        let relaxed = ConeSolverKind::ClarabelSocp;
        let socp = (relaxed.name(), relaxed.create().solve_cone(&p, &tight()));
        for (name, r) in solve_all(&p).into_iter().chain([socp]) {
            assert_eq!(r.status, Status::Converged, "{name} seed {seed}");
            for (x, y) in r.f.iter().zip(&reference.f) {
                assert!((x - y).abs() <= 1e-8, "{name} seed {seed}: {:?}", r.f);
            }
        }
    }
}

#[test]
fn newton_converges_quadratically_on_a_sliding_contact() {
    let (w, q, mu) = random_contacts(4, 24, 7);
    let p = ConeProblem::new(w, q, mu).unwrap();
    let settings = Settings {
        tolerance: 1e-13,
        max_iterations: 50,
        record_history: true,
        ..Settings::default()
    };
    let r = ConeSolverKind::NewtonAc.create().solve_cone(&p, &settings);
    assert_eq!(r.status, Status::Converged, "{}", r.status);
    let h: Vec<f64> = r.history.iter().map(|p| p.residual).collect();
    // Somewhere in the last steps the residual at least squares (up to a constant).
    let fast = h
        .windows(2)
        .any(|w| w[0] < 1e-2 && w[0] > 1e-12 && w[1] <= 10.0 * w[0] * w[0]);
    assert!(fast, "no quadratic step in {h:?}");
}

/// A planted problem whose contacts all stick (reaction strictly inside the cone, `u_c = 0`) or
/// take off with a velocity strictly inside the dual cone (`r_c = 0`, `mu ‖u_T‖ < u_N`): a
/// solution of Coulomb's law and of its convex relaxation. `W = J Jᵀ + 10⁻³ I`. Returns the
/// problem's data and the planted reaction.
fn planted_stick_or_take_off(
    contacts: usize,
    seed: u64,
) -> (Mat<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let (w, _, mu) = random_contacts(contacts, 6 * contacts, seed);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1000 + seed);
    let n = 3 * contacts;
    let (mut r, mut u) = (vec![0.0; n], vec![0.0; n]);
    for c in 0..contacts {
        let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let magnitude: f64 = rng.random_range(0.1..0.9);
        let (x, y) = (angle.cos(), angle.sin());
        let size = rng.random_range(0.2..2.0);
        let block = [size, size * magnitude * x, size * magnitude * y];
        if c % 3 == 2 {
            // Takes off: ‖u_T‖ = magnitude · u_N / mu.
            let t = magnitude / mu[c];
            u[3 * c..3 * c + 3].copy_from_slice(&[block[0], t * block[1], t * block[2]]);
        } else {
            // Sticks: ‖r_T‖ = magnitude · mu r_N.
            let m = mu[c];
            r[3 * c..3 * c + 3].copy_from_slice(&[block[0], m * block[1], m * block[2]]);
        }
    }
    let q = (0..n)
        .map(|i| u[i] - (0..n).map(|j| w[(i, j)] * r[j]).sum::<f64>())
        .collect();
    (w, q, mu, r)
}

#[test]
fn relaxation_is_exact_where_contacts_stick_or_take_off() {
    let socp = ConeSolverKind::ClarabelSocp;
    for seed in 0..6u64 {
        let (w, q, mu, planted) = planted_stick_or_take_off(2 + seed as usize, seed);
        let p = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
        // W = J Jᵀ + 10⁻³ I is ill-conditioned: a residual of 1e-12 keeps r within 1e-8.
        let r = socp.create().solve_cone(&p, &tight());
        assert_eq!(r.status, Status::Converged, "seed {seed}: {}", r.status);
        assert!(
            independent_residual(&w, &q, &mu, &r.f) <= 1e-8,
            "seed {seed}"
        );
        for (x, y) in r.f.iter().zip(&planted) {
            assert!(
                (x - y).abs() <= 1e-8,
                "seed {seed}: {:?} vs {planted:?}",
                r.f
            );
        }
        for kind in exact_solvers() {
            let exact = kind.create().solve_cone(&p, &tight());
            assert_eq!(
                exact.status,
                Status::Converged,
                "{} seed {seed}",
                kind.name()
            );
            for (x, y) in r.f.iter().zip(&exact.f) {
                assert!((x - y).abs() <= 1e-8, "{} seed {seed}", kind.name());
            }
        }
        // The same problem with W stored sparse: the same answer.
        let sparse = stored_sparse(&w, &q, &mu);
        let s = socp.create().solve_cone(&sparse, &tight());
        assert_eq!(s.status, Status::Converged, "sparse seed {seed}");
        for (x, y) in s.f.iter().zip(&r.f) {
            assert!((x - y).abs() <= 1e-9, "sparse seed {seed}");
        }
    }
}

/// Past the friction angle the relaxation's block is the projection `r = P_K(−m q)`: it pushes
/// harder than Coulomb's and separates at `u_N = mu ‖u_T‖`, which the exact residual refuses and
/// the reason reports.
#[test]
fn relaxation_lifts_off_a_sliding_contact() {
    let alpha = (1.2 * MU).atan();
    let p = incline(alpha, 30f64.to_radians());
    let r = ConeSolverKind::ClarabelSocp
        .create()
        .solve_cone(&p, &tight());
    let (f, u) = (&r.f, &r.w);
    // x = −m q = m h g (cos α, −sin α d): projected onto the boundary of the cone.
    let (xn, xt) = (MASS * H * G * alpha.cos(), MASS * H * G * alpha.sin());
    let rn = (xn + MU * xt) / (1.0 + MU * MU);
    assert!((f[0] - rn).abs() <= 1e-8 * rn, "{f:?} vs r_N {rn}");
    assert!((f[1].hypot(f[2]) - MU * rn).abs() <= 1e-8 * rn);
    let slip = u[1].hypot(u[2]);
    assert!(
        slip > 1e-3 && (u[0] - MU * slip).abs() <= 1e-8 * slip,
        "u {u:?}"
    );
    assert!(
        matches!(&r.status, Status::Stalled { reason } if reason.contains("lifts off 1 of 1")
            && reason.contains(&format!("{:.3e}", u[0]))
            && reason.contains("Anitescu's convex relaxation")
            && reason.contains("not the Coulomb problem")
            && reason.contains(&format!("exact Coulomb problem {:.3e}", r.residuals.natural_map_rel))
            && !reason.contains("relaxation itself")),
        "{}",
        r.status
    );
    assert!(r.residuals.natural_map_rel > 1e-2);
}

/// A `W` whose Cholesky factor is larger than the interior point may factorise is refused
/// before any numerical work, naming the factor's size; the same problem under the default cap
/// is solved.
#[test]
fn relaxation_refuses_a_factor_above_its_cap() {
    let p = incline(0.3, 0.0);
    let mut capped = ClarabelSocp::default();
    capped.ipm.max_factor_entries = 2;
    let r = capped.solve_cone(&p, &tight());
    assert!(
        matches!(&r.status, Status::Unsupported { reason }
            if reason.contains("Cholesky factor of W would hold") && reason.contains("above the 2 ")),
        "{}",
        r.status
    );
    assert_eq!(r.iterations, 0);
    let r = ClarabelSocp::default().solve_cone(&p, &tight());
    assert_eq!(r.status, Status::Converged);
}

#[test]
fn relaxation_refuses_non_symmetric_and_indefinite_w() {
    let socp = ConeSolverKind::ClarabelSocp;
    // max |W_ij − W_ji| / max |W_ij| = 0.5 / 2: far above assembly noise.
    let mut w = Mat::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.0 });
    w[(0, 1)] = 0.5;
    let p = ConeProblem::new(w, vec![-1.0, 0.1, 0.0], vec![0.5]).unwrap();
    let r = socp.create().solve_cone(&p, &Settings::default());
    assert!(
        matches!(&r.status, Status::Unsupported { reason }
            if reason.contains("not symmetric") && reason.contains("2.500e-1")),
        "{}",
        r.status
    );
    assert_eq!(r.f, vec![0.0; 3]);
    // Just above the acceptance limit: refused too.
    let mut w = Mat::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.0 });
    w[(1, 2)] = 2.0 * SYMMETRISE_WITHIN * 1.5;
    let p = ConeProblem::new(w, vec![-1.0, 0.1, 0.0], vec![0.5]).unwrap();
    let r = socp.create().solve_cone(&p, &Settings::default());
    assert!(
        matches!(&r.status, Status::Unsupported { reason } if reason.contains("not symmetric")),
        "{}",
        r.status
    );
    let w = Mat::from_fn(6, 6, |i, j| match (i, j) {
        _ if i == j => 1.0,
        (0, 3) | (3, 0) => 3.0,
        _ => 0.0,
    });
    let p = ConeProblem::new(w, vec![-1.0, 0.0, 0.0, -1.0, 0.0, 0.0], vec![0.5, 0.5]).unwrap();
    let r = socp.create().solve_cone(&p, &Settings::default());
    assert!(
        matches!(&r.status, Status::Unsupported { reason } if reason.contains("indefinite")),
        "{}",
        r.status
    );
}

/// A `W` symmetric only to a relative `1e-6` (assembly noise) is solved through its symmetric
/// part, and the result is judged on the original `W`: `converged` at a tolerance the
/// symmetrised answer meets on the real problem, not at one it does not, each checked by the
/// independent residual on the original `W`.
#[test]
fn relaxation_solves_a_nearly_symmetric_w_and_is_judged_on_it() {
    let socp = ConeSolverKind::ClarabelSocp;
    for seed in 0..3u64 {
        let (w0, q0, mu, planted) = planted_stick_or_take_off(3, 40 + seed);
        let n = w0.nrows();
        let big = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(w0[(i, j)].abs()));
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(500 + seed);
        let mut w = w0.clone();
        for i in 0..n {
            for j in 0..i {
                let k = 0.5e-6 * big * rng.random_range(-1.0..1.0);
                w[(i, j)] += k;
                w[(j, i)] -= k;
            }
        }
        // The planted reaction and velocity also solve the problem with the asymmetric W:
        // q = u − W r = q0 + (W0 − W) r.
        let q: Vec<f64> = (0..n)
            .map(|i| {
                q0[i]
                    + (0..n)
                        .map(|j| (w0[(i, j)] - w[(i, j)]) * planted[j])
                        .sum::<f64>()
            })
            .collect();
        let p = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
        let asymmetry = delassus_asymmetry(&p);
        assert!(asymmetry > 1e-7 && asymmetry <= 1e-6, "{asymmetry:e}");
        for tol in [1e-4, 1e-12] {
            let settings = Settings {
                tolerance: tol,
                ..Settings::default()
            };
            let r = socp.create().solve_cone(&p, &settings);
            assert!(
                !matches!(r.status, Status::Unsupported { .. }),
                "seed {seed}: {}",
                r.status
            );
            let independent = independent_residual(&w, &q, &mu, &r.f);
            let reported = r.residuals.natural_map_rel;
            assert!(
                (independent - reported).abs() <= 1e-9 * reported.max(1e-6),
                "seed {seed}: reported {reported:e}, independent {independent:e}"
            );
            if r.status.is_converged() {
                assert!(
                    independent <= tol,
                    "seed {seed} tol {tol:e}: {independent:e}"
                );
            } else {
                assert!(independent > tol, "seed {seed} tol {tol:e}: {}", r.status);
            }
            if tol == 1e-4 {
                assert_eq!(r.status, Status::Converged, "seed {seed}: {}", r.status);
            }
        }
    }
}

/// Fixed-seed random SPD problems, sliding and planted: every `converged` relaxation meets the
/// independent cone residual, and every other result is above the tolerance by that measure.
#[test]
fn every_converged_relaxation_meets_the_independent_residual() {
    let settings = Settings::default();
    let socp = ConeSolverKind::ClarabelSocp;
    let mut converged = 0;
    for seed in 0..8u64 {
        let contacts = 1 + seed as usize % 4;
        let (w, q, mu) = random_contacts(contacts, 6 * contacts, 200 + seed);
        let (pw, pq, pmu, _) = planted_stick_or_take_off(contacts, 300 + seed);
        for (w, q, mu) in [(w, q, mu), (pw, pq, pmu)] {
            let p = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
            let r = socp.create().solve_cone(&p, &settings);
            let independent = independent_residual(&w, &q, &mu, &r.f);
            if r.status.is_converged() {
                converged += 1;
                assert!(
                    independent <= settings.tolerance,
                    "seed {seed}: {independent:e}"
                );
            } else {
                assert!(
                    independent > settings.tolerance,
                    "seed {seed}: {}",
                    r.status
                );
            }
        }
    }
    assert!(converged >= 8, "only {converged} of 16 converged");
}

fn nsgs(settings: NsgsConeSettings) -> NsgsCone {
    NsgsCone::new(settings)
}

/// The full cone residual measured after every sweep (the stopping test of a plain NSGS loop)
/// and the default rule (measured only where the running terms come near the tolerance) give
/// the same answer: the saving changes no iterate, only when the residual is looked at. Both
/// are checked on the analytic incline cases and on random problems by the independent
/// residual, and the default never stops before the every-sweep rule.
#[test]
fn nsgs_cone_stopping_rule_changes_no_answer() {
    let every_sweep = NsgsConeSettings {
        full_residual_every: 1,
        ..NsgsConeSettings::default()
    };
    let alpha = (1.2 * MU).atan();
    for (alpha, deg) in [(0.7 * MU.atan(), 30.0), (alpha, 0.0), (alpha, 77.0)] {
        let p = incline(alpha, f64::to_radians(deg));
        let a = nsgs(NsgsConeSettings::default()).solve_cone(&p, &tight());
        let b = nsgs(every_sweep).solve_cone(&p, &tight());
        assert_eq!(a.status, Status::Converged);
        assert_eq!(a.f, b.f, "α {alpha} φ {deg}");
    }
    let settings = Settings {
        tolerance: 1e-8,
        max_iterations: 5000,
        ..Settings::default()
    };
    let mut compared = 0;
    for seed in 0..10u64 {
        let contacts = 2 + (seed as usize % 5);
        let (w, q, mu) = random_contacts(contacts, 6 * contacts, 600 + seed);
        let p = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
        let a = nsgs(NsgsConeSettings::default()).solve_cone(&p, &settings);
        let b = nsgs(every_sweep).solve_cone(&p, &settings);
        for r in [&a, &b] {
            let independent = independent_residual(&w, &q, &mu, &r.f);
            if r.status.is_converged() {
                assert!(independent <= settings.tolerance, "seed {seed}");
            } else {
                assert!(independent > settings.tolerance, "seed {seed}");
            }
        }
        assert_eq!(a.status, b.status, "seed {seed}");
        if a.status.is_converged() {
            compared += 1;
            assert!(a.iterations >= b.iterations, "seed {seed}");
            if a.iterations == b.iterations {
                assert_eq!(a.f, b.f, "seed {seed}");
            }
            for (x, y) in a.w.iter().zip(&b.w) {
                let scale = q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                assert!((x - y).abs() <= 1e-6 * scale, "seed {seed}: u {x} vs {y}");
            }
        }
    }
    assert!(compared >= 7, "only {compared} of 10 converged");
}

/// Shuffled contact order and over-relaxation: every `converged` meets the independent residual,
/// every other result is above the tolerance by it, and most converge.
#[test]
fn nsgs_cone_shuffled_and_relaxed_are_honest() {
    let settings = Settings {
        tolerance: 1e-8,
        max_iterations: 5000,
        ..Settings::default()
    };
    let options = [
        NsgsConeSettings {
            shuffle_seed: Some(11),
            ..NsgsConeSettings::default()
        },
        NsgsConeSettings {
            omega: 0.8,
            ..NsgsConeSettings::default()
        },
        NsgsConeSettings {
            omega: 1.3,
            shuffle_seed: Some(5),
            ..NsgsConeSettings::default()
        },
    ];
    for option in options {
        let mut converged = 0;
        for seed in 0..10u64 {
            let contacts = 2 + (seed as usize % 5);
            let (w, q, mu) = random_contacts(contacts, 6 * contacts, 700 + seed);
            let p = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
            let r = nsgs(option).solve_cone(&p, &settings);
            let independent = independent_residual(&w, &q, &mu, &r.f);
            if r.status.is_converged() {
                converged += 1;
                assert!(independent <= settings.tolerance, "{option:?} seed {seed}");
            } else {
                assert!(independent > settings.tolerance, "{option:?} seed {seed}");
            }
        }
        assert!(
            converged >= 7,
            "{option:?}: only {converged} of 10 converged"
        );
    }
    // A shuffled solve is repeatable.
    let (w, q, mu) = random_contacts(5, 30, 701);
    let p = ConeProblem::new(w, q, mu).unwrap();
    let a = nsgs(options[0]).solve_cone(&p, &settings);
    let b = nsgs(options[0]).solve_cone(&p, &settings);
    assert_eq!(a.f, b.f);
    // Over-relaxation outside (0, 2) is refused.
    let r = nsgs(NsgsConeSettings {
        omega: 2.0,
        ..NsgsConeSettings::default()
    })
    .solve_cone(&p, &settings);
    assert!(
        matches!(&r.status, Status::Unsupported { reason } if reason.contains("omega")),
        "{}",
        r.status
    );
}

#[test]
fn nsgs_cone_spends_no_more_than_its_time_budget() {
    let (w, q, mu) = random_contacts(6, 36, 801);
    let p = ConeProblem::new(w, q, mu).unwrap();
    let settings = Settings {
        time_budget: Some(std::time::Duration::ZERO),
        ..Settings::default()
    };
    let r = nsgs(NsgsConeSettings::default()).solve_cone(&p, &settings);
    assert_eq!(r.status, Status::TimeLimit);
    assert_eq!(r.iterations, 0);
}

/// NSGS and the global Newton method, two independent solvers, reach the same velocities on
/// random problems where both converge (and each meets the independent residual).
#[test]
fn nsgs_cone_agrees_with_newton_ac() {
    let settings = Settings {
        tolerance: 1e-10,
        max_iterations: 5000,
        ..Settings::default()
    };
    let mut agreed = 0;
    for seed in 0..10u64 {
        let contacts = 2 + (seed as usize % 4);
        let (w, q, mu) = random_contacts(contacts, 6 * contacts, 900 + seed);
        let p = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
        let a = nsgs(NsgsConeSettings::default()).solve_cone(&p, &settings);
        let b = NewtonAc::default().solve_cone(&p, &settings);
        if !(a.status.is_converged() && b.status.is_converged()) {
            continue;
        }
        for r in [&a, &b] {
            assert!(independent_residual(&w, &q, &mu, &r.f) <= settings.tolerance);
        }
        let scale = q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (x, y) in a.w.iter().zip(&b.w) {
            assert!(
                (x - y).abs() <= 1e-6 * scale,
                "seed {seed}: u {:?} vs {:?}",
                a.w,
                b.w
            );
        }
        agreed += 1;
    }
    assert!(agreed >= 6, "only {agreed} of 10 compared");
}

/// The first-order and splitting methods: the projections on De Saxcé's map, ADMM and the
/// proximal point method.
const FIRST_ORDER_SOLVERS: [ConeSolverKind; 4] = [
    ConeSolverKind::ExtragradientCone,
    ConeSolverKind::FixedPointProjectionCone,
    ConeSolverKind::AdmmCone,
    ConeSolverKind::ProxCone,
];

/// On fixed-seed random problems, each first-order method finds the reactions NSGS-cone and
/// Newton-AC find (where both converge; these problems have one solution each as far as all
/// four solvers see), with dense and sparse `W` alike.
#[test]
fn first_order_methods_agree_with_nsgs_and_newton() {
    let settings = Settings {
        tolerance: 1e-10,
        max_iterations: 20_000,
        ..Settings::default()
    };
    let mut compared = 0;
    for seed in 0..6u64 {
        let contacts = 2 + seed as usize % 3;
        let (w, q, mu) = random_contacts(contacts, 6 * contacts, 500 + seed);
        let dense = ConeProblem::new(w.clone(), q.clone(), mu.clone()).unwrap();
        let sparse = stored_sparse(&w, &q, &mu);
        let references: Vec<SolveResult> = [ConeSolverKind::NsgsCone, ConeSolverKind::NewtonAc]
            .iter()
            .map(|k| k.create().solve_cone(&dense, &settings))
            .filter(|r| r.status.is_converged())
            .collect();
        for kind in FIRST_ORDER_SOLVERS {
            for (form, p) in [("dense", &dense), ("sparse", &sparse)] {
                let r = kind.create().solve_cone(p, &settings);
                assert_eq!(
                    r.status,
                    Status::Converged,
                    "{} {form} seed {seed}",
                    kind.name()
                );
                assert!(independent_residual(&w, &q, &mu, &r.f) <= settings.tolerance);
                for reference in &references {
                    let scale = reference.f.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    for (x, y) in r.f.iter().zip(&reference.f) {
                        assert!(
                            (x - y).abs() <= 1e-6 * scale,
                            "{} {form} seed {seed}: {:?} vs {:?}",
                            kind.name(),
                            r.f,
                            reference.f
                        );
                    }
                    compared += 1;
                }
            }
        }
    }
    assert!(compared >= 40, "only {compared} comparisons");
}

/// Every solver that takes a warm start ends within two iterations when started from a solution,
/// and a time budget of zero ends a cold solve `time_limit` without an iteration's answer being
/// claimed.
#[test]
fn iterative_cone_solvers_warm_start_and_respect_the_budget() {
    let settings = Settings {
        tolerance: 1e-9,
        max_iterations: 20_000,
        ..Settings::default()
    };
    for seed in 0..3u64 {
        let (w, q, mu) = random_contacts(3, 18, 700 + seed);
        let p = ConeProblem::new(w, q, mu).unwrap();
        let solution = ConeSolverKind::NewtonAc.create().solve_cone(&p, &settings);
        assert_eq!(solution.status, Status::Converged, "seed {seed}");
        // `sap` works on the factors of W, which these problems have not (its warm start and
        // budget are tested on factored problems in its module).
        for kind in ConeSolverKind::all()
            .into_iter()
            .filter(|k| k.is_iterative() && *k != ConeSolverKind::Sap)
        {
            let warm = Settings {
                warm_start: Some(solution.f.clone()),
                ..settings.clone()
            };
            let r = kind.create().solve_cone(&p, &warm);
            assert_eq!(r.status, Status::Converged, "{} seed {seed}", kind.name());
            assert!(
                r.iterations <= 2,
                "{}: {} iterations",
                kind.name(),
                r.iterations
            );
            let spent = Settings {
                time_budget: Some(std::time::Duration::ZERO),
                ..settings.clone()
            };
            let r = kind.create().solve_cone(&p, &spent);
            assert_eq!(r.status, Status::TimeLimit, "{} seed {seed}", kind.name());
        }
    }
}

/// A factorisation no budget can interrupt is refused before it starts: `admm-cone` and
/// `newton-ac` on a sparse `W` whose LU is estimated above their caps end `unsupported` with
/// the estimate and the cap in the reason, and solve the same problem under the default caps.
#[test]
fn factorising_cone_solvers_refuse_a_factor_above_their_cap() {
    let (w, q, mu) = random_contacts(120, 40, 77);
    let p = stored_sparse(&w, &q, &mu);
    let settings = Settings {
        tolerance: 1e-8,
        max_iterations: 2_000,
        ..Settings::default()
    };
    let capped: [Box<dyn ConeSolver>; 2] = [
        Box::new(AdmmCone {
            max_factor_entries: 1_000,
            ..AdmmCone::default()
        }),
        Box::new(NewtonAc {
            max_factor_entries: 1_000,
            ..NewtonAc::default()
        }),
    ];
    for mut s in capped {
        let r = s.solve_cone(&p, &settings);
        assert_eq!(r.status.name(), "unsupported", "{}", s.name());
        let reason = format!("{:?}", r.status);
        assert!(reason.contains("above the 1000"), "{}: {reason}", s.name());
        assert_eq!(r.iterations, 0);
    }
    for kind in [ConeSolverKind::AdmmCone, ConeSolverKind::NewtonAc] {
        let r = kind.create().solve_cone(&p, &settings);
        assert_ne!(r.status.name(), "unsupported", "{}", kind.name());
        if r.status.is_converged() {
            assert!(independent_residual(&w, &q, &mu, &r.f) <= settings.tolerance);
        }
    }
}

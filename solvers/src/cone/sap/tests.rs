use super::*;
use crate::cone::contact_relative_residuals;
use crate::ConeNewton;
use crate::Status;
use faer::Mat;

const G: f64 = 9.81;
const H: f64 = 0.01;

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The three rows (normal, tangent, tangent) of a contact on a body at offset `p` from its
/// centre of mass, frame `dirs`, with sign `s` (+1 for the body the normal points into).
fn rows(p: [f64; 3], dirs: [[f64; 3]; 3], s: f64) -> [[f64; 6]; 3] {
    dirs.map(|d| {
        let a = cross(p, d);
        [s * d[0], s * d[1], s * d[2], s * a[0], s * a[1], s * a[2]]
    })
}

/// A tangent frame `(n, t1, t2)` of a unit normal.
fn frame(n: [f64; 3]) -> [[f64; 3]; 3] {
    let helper = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t1 = cross(n, helper);
    let l = (t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]).sqrt();
    let t1 = t1.map(|x| x / l);
    [n, t1, cross(n, t1)]
}

/// The inverse-mass block of a sphere (`solid`) or cube of mass `m` and inertia `i`.
fn inverse_mass(m: f64, i: f64) -> [[f64; 6]; 6] {
    let mut b = [[0.0; 6]; 6];
    for k in 0..3 {
        b[k][k] = 1.0 / m;
        b[3 + k][3 + k] = 1.0 / i;
    }
    b
}

/// One contact: each of its bodies with its three rows, and its friction coefficient.
type ContactSpec = (Vec<(usize, [[f64; 6]; 3])>, f64);

/// A factored cone problem: contacts as `(per-body rows, mu)`, inverse-mass blocks, free
/// velocities of the bodies (six each): `q = J v_free`.
fn factored(contacts: &[ContactSpec], minv: Vec<[[f64; 6]; 6]>, v_free: &[f64]) -> ConeProblem {
    let mut block_ptr = vec![0];
    let mut blocks = Vec::new();
    let mut q = Vec::new();
    for (bodies, _) in contacts {
        let mut bodies = bodies.clone();
        bodies.sort_by_key(|(b, _)| *b);
        for a in 0..3 {
            let mut qa = 0.0;
            for (b, j) in &bodies {
                blocks.push((*b, j[a]));
                qa += (0..6).map(|k| j[a][k] * v_free[6 * b + k]).sum::<f64>();
            }
            block_ptr.push(blocks.len());
            q.push(qa);
        }
    }
    let factors = DelassusFactors::from_row_blocks(block_ptr, blocks, minv).unwrap();
    let mu = contacts.iter().map(|(_, mu)| *mu).collect();
    ConeProblem::new_sparse(factors.assemble(), q, mu)
        .unwrap()
        .with_factors(factors)
        .unwrap()
}

fn solve(p: &ConeProblem, sap: Sap, tolerance: f64) -> SolveResult {
    let settings = Settings {
        tolerance,
        ..Settings::default()
    };
    let mut sap = sap;
    sap.solve_cone(p, &settings)
}

fn model(p: &ConeProblem) -> Model {
    Model::new(p, p.factors().unwrap(), 1.0, 1e-3).unwrap()
}

/// A sphere (mass `m`, radius `rho`) resting on a static ground body after one step of gravity.
fn resting_sphere(m: f64, rho: f64) -> ConeProblem {
    let f = frame([0.0, 0.0, 1.0]);
    let contact = vec![
        (0, rows([0.0, 0.0, -rho], f, 1.0)),
        (1, rows([0.0, 0.0, 0.0], f, -1.0)),
    ];
    let i = 0.4 * m * rho * rho;
    let mut v = vec![0.0; 12];
    v[2] = -G * H;
    factored(
        &[(contact, 0.5)],
        vec![inverse_mass(m, i), [[0.0; 6]; 6]],
        &v,
    )
}

/// The normal impulse of the resting sphere is the rigid `m g h` divided by `1 + R_N / W_NN`
/// (the contact sticks: `u = −R γ`, and `W_cc` is diagonal), so `O(R_N / W_NN)` short of it:
/// `β² / (4π²) · w_c / W_NN`, here about 4 % at `β = 1`.
#[test]
fn resting_sphere_has_the_rigid_impulse_within_the_regularisation() {
    let (m, rho) = (2.0, 0.5);
    let p = resting_sphere(m, rho);
    let w = [1.0 / m, 1.0 / m + rho * rho / (0.4 * m * rho * rho)];
    let wc = (w[0] * w[0] + 2.0 * w[1] * w[1]).sqrt() / 3.0;
    let rn = wc / (4.0 * std::f64::consts::PI.powi(2));
    let r = solve(&p, Sap::default(), 1e-8);
    let rigid = m * G * H;
    let expected = rigid / (1.0 + rn * m);
    assert!((r.f[0] - expected).abs() <= 1e-10 * rigid, "{:?}", r.f);
    assert!(r.f[1].abs() <= 1e-12 && r.f[2].abs() <= 1e-12);
    let relative_error = (rigid - r.f[0]) / rigid;
    assert!(relative_error > 0.0 && relative_error <= rn * m);
    assert!(
        relative_error > 0.02,
        "β = 1 is visibly soft: {relative_error}"
    );
    // At 1e-8 the exact-cone residual rejects the soft answer, and the reason says why.
    match &r.status {
        Status::Stalled { reason } => {
            assert!(reason.contains("regularised"), "{reason}");
            assert!(reason.contains("R_N γ_N"), "{reason}");
        }
        s => panic!("expected stalled, got {s:?}"),
    }
    assert!(
        r.iterations <= 3,
        "one Newton step solves a quadratic: {}",
        r.iterations
    );
    // A near-rigid β leaves an error of β²/(4π²) w_c/W_NN, within a loose tolerance.
    let r = solve(
        &p,
        Sap {
            beta: 0.01,
            ..Sap::default()
        },
        1e-4,
    );
    assert_eq!(r.status, Status::Converged);
    // R_N scales with β²: (0.01)² of the default's.
    assert!((r.f[0] - rigid / (1.0 + 1e-4 * rn * m)).abs() <= 1e-10 * rigid);
    assert!((rigid - r.f[0]) / rigid <= 1e-4 * rn * m);
}

/// A cube of side `2a` with four corner contacts on an incline of angle `theta` (frame: x up
/// the slope, z the slope's normal), after one step of gravity.
fn cube_on_incline(theta: f64, mu: f64) -> ConeProblem {
    let (m, a) = (3.0, 0.2);
    let i = m * (2.0 * a) * (2.0 * a) / 6.0;
    let f = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let contacts: Vec<_> = [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)]
        .iter()
        .map(|&(x, y)| (vec![(0, rows([x * a, y * a, -a], f, 1.0))], mu))
        .collect();
    let mut v = vec![0.0; 6];
    v[0] = -G * H * theta.sin();
    v[2] = -G * H * theta.cos();
    factored(&contacts, vec![inverse_mass(m, i)], &v)
}

#[test]
fn cube_on_incline_sticks_below_and_slides_above_the_friction_angle() {
    let theta: f64 = 0.4; // tan θ ≈ 0.42
    let (m, gh) = (3.0, G * H);
    for (mu, sticks) in [(0.8, true), (0.2, false)] {
        let p = cube_on_incline(theta, mu);
        let r = solve(&p, Sap::default(), 1e-8);
        assert!(
            matches!(r.status, Status::Converged | Status::Stalled { .. }),
            "{:?}",
            r.status
        );
        let (mut n, mut t) = (0.0, 0.0);
        for c in 0..4 {
            n += r.f[3 * c];
            t += r.f[3 * c + 1];
        }
        let model = model(&p);
        let soft = model.contacts[0].rn * m;
        // The total normal impulse carries the weight's normal part, within O(R).
        assert!(
            (n - m * gh * theta.cos()).abs() <= 2.0 * soft * m * gh,
            "mu {mu}: {n}"
        );
        let slip: Vec<f64> = (0..4).map(|c| r.w[3 * c + 1]).collect();
        if sticks {
            // Friction holds the weight's tangential part; the contacts creep at O(R_T γ).
            assert!(
                (t - m * gh * theta.sin()).abs() <= 2.0 * soft * m * gh,
                "{t}"
            );
            for s in &slip {
                assert!(s.abs() <= 1e-2 * gh, "creep {s}");
            }
        } else {
            // Each contact slides down the slope on its cone's surface.
            let down = gh * (theta.sin() - mu * theta.cos());
            for (c, s) in slip.iter().enumerate() {
                let (rn, rt) = (r.f[3 * c], r.f[3 * c + 1].hypot(r.f[3 * c + 2]));
                assert!((rt - mu * rn).abs() <= 1e-9 * m * gh, "contact {c}");
                assert!(r.f[3 * c + 1] > 0.0, "friction points up the slope");
                assert!(
                    (s + down).abs() <= 0.1 * down,
                    "contact {c}: {s} vs {}",
                    -down
                );
            }
        }
    }
}

/// Three spheres, two on the ground and one resting on both, and a fourth on top of it.
fn small_pile(mu: f64) -> ConeProblem {
    let (m, rho) = (1.0, 0.5);
    let i = 0.4 * m * rho * rho;
    let centres = [
        [-0.52, 0.0, 0.5],
        [0.52, 0.0, 0.5],
        [0.0, 0.05, 0.5 + 0.85],
        [0.02, 0.0, 0.5 + 0.85 + 1.0],
    ];
    let ground = 4;
    let mut contacts = Vec::new();
    for b in 0..2 {
        let f = frame([0.0, 0.0, 1.0]);
        contacts.push((
            vec![
                (b, rows([0.0, 0.0, -rho], f, 1.0)),
                (ground, rows([0.0, 0.0, 0.0], f, -1.0)),
            ],
            mu,
        ));
    }
    for (top, below) in [(2, 0), (2, 1), (3, 2)] {
        let d: Vec<f64> = (0..3)
            .map(|k| centres[top][k] - centres[below][k])
            .collect();
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let n = [d[0] / l, d[1] / l, d[2] / l];
        let f = frame(n);
        let p_top = n.map(|x| -rho * x);
        let p_below = n.map(|x| rho * x);
        contacts.push((
            vec![(top, rows(p_top, f, 1.0)), (below, rows(p_below, f, -1.0))],
            mu,
        ));
    }
    let mut minv = vec![inverse_mass(m, i); 4];
    minv.push([[0.0; 6]; 6]);
    let mut v = vec![0.0; 30];
    for b in 0..4 {
        v[6 * b + 2] = -G * H;
    }
    factored(&contacts, minv, &v)
}

/// The same contacts with `W + R` in place of `W`: SAP's model where every contact sticks.
fn regularised(p: &ConeProblem, model: &Model) -> ConeProblem {
    let n = p.n();
    let mut w = Mat::<f64>::from_fn(n, n, |i, j| p.delassus().entry(i, j));
    for (c, k) in model.contacts.iter().enumerate() {
        w[(3 * c, 3 * c)] += k.rn;
        w[(3 * c + 1, 3 * c + 1)] += k.rt;
        w[(3 * c + 2, 3 * c + 2)] += k.rt;
    }
    ConeProblem::new(w, p.q().to_vec(), p.mu().to_vec()).unwrap()
}

#[test]
fn pile_agrees_with_cone_newton_on_the_regularised_and_the_exact_problem() {
    let p = small_pile(1.0);
    let model = model(&p);
    let r = solve(&p, Sap::default(), 1e-8);
    assert!(matches!(r.status, Status::Stalled { .. }), "{:?}", r.status);
    assert!(r.iterations <= 30, "{}", r.iterations);
    let scale = r.f.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    assert!(scale > 0.0);
    // Every contact sticks: SAP's answer solves the exact cone problem with W + R.
    let soft = regularised(&p, &model);
    let newton = ConeNewton::alart_curnier().solve_cone(&soft, &Settings::default());
    assert_eq!(newton.status, Status::Converged);
    for (a, b) in r.f.iter().zip(&newton.f) {
        assert!((a - b).abs() <= 1e-6 * scale, "{a} vs {b}");
    }
    // And the exact problem's answer within the regularisation's O(R / W) relative error.
    let exact = ConeNewton::alart_curnier().solve_cone(&p, &Settings::default());
    assert_eq!(exact.status, Status::Converged);
    let soft_ratio = model
        .contacts
        .iter()
        .enumerate()
        .map(|(c, k)| k.rn / p.delassus().entry(3 * c, 3 * c))
        .fold(0.0_f64, f64::max);
    for (a, b) in r.f.iter().zip(&exact.f) {
        assert!((a - b).abs() <= 4.0 * soft_ratio * scale, "{a} vs {b}");
    }
    // The returned impulse's exact-cone residual is the regularisation's, not round-off.
    let worst = contact_relative_residuals(&p, &r.f)
        .into_iter()
        .fold(0.0_f64, f64::max);
    assert!(worst > 1e-4 && worst < 4.0 * soft_ratio, "{worst}");
}

/// A velocity at which the pile's contacts are in all three modes.
fn mixed_velocity(model: &Model) -> Vec<f64> {
    let nv = model.nv();
    let v: Vec<f64> = (0..nv)
        .map(|i| 0.05 * (((i * 37 + 11) % 17) as f64 / 8.0 - 1.0))
        .collect();
    let u = model.velocities(&v);
    let modes: Vec<usize> = model
        .contacts
        .iter()
        .zip(&u)
        .map(|(k, &uc)| {
            let (g, _) = project(k.mu, k.rn, k.rt, uc);
            let y = [-uc[0] / k.rn, -uc[1] / k.rt, -uc[2] / k.rt];
            if g == [0.0; 3] {
                0
            } else if g == y {
                1
            } else {
                2
            }
        })
        .collect();
    for mode in [0, 2] {
        assert!(modes.contains(&mode), "modes {modes:?}");
    }
    v
}

#[test]
fn gradient_and_hessian_match_finite_differences() {
    let p = small_pile(0.3);
    let model = model(&p);
    let v = mixed_velocity(&model);
    let nv = model.nv();
    let grad = model.gradient(&v);
    let hess = model.dense_hessian(&v);
    let eps = 1e-7;
    let gscale = grad.iter().fold(1e-3_f64, |m, x| m.max(x.abs()));
    for i in 0..nv {
        let (mut vp, mut vm) = (v.clone(), v.clone());
        vp[i] += eps;
        vm[i] -= eps;
        let fd = (model.cost(&vp) - model.cost(&vm)) / (2.0 * eps);
        assert!(
            (fd - grad[i]).abs() <= 1e-6 * gscale,
            "∂ℓ/∂v[{i}]: {fd} vs {}",
            grad[i]
        );
        let (gp, gm) = (model.gradient(&vp), model.gradient(&vm));
        let hscale = hess[i].iter().fold(1e-3_f64, |m, x| m.max(x.abs()));
        for j in 0..nv {
            let fd = (gp[j] - gm[j]) / (2.0 * eps);
            assert!(
                (fd - hess[j][i]).abs() <= 1e-5 * hscale,
                "H[{j}][{i}]: {fd} vs {}",
                hess[j][i]
            );
        }
    }
}

#[test]
fn exact_line_search_finds_the_minimiser_of_a_quadratic() {
    let model = Model {
        bodies: 1,
        mass: vec![inverse_mass(1.0, 1.0)],
        contacts: Vec::new(),
        q: Vec::new(),
    };
    // ℓ(α) = c + α b + ½ α² a: minimiser −b/a, or α_max when that is beyond it.
    for (b, a, expected) in [(-1.4, 2.0, 0.7), (-0.3, 1.0, 0.3), (-5.0, 1.0, ALPHA_MAX)] {
        let line = Line {
            model: &model,
            u0: Vec::new(),
            du: Vec::new(),
            vmv: 1.0,
            dmv: b,
            dmd: a,
        };
        let (alpha, cost, _) = exact_line_search(&line).unwrap();
        assert!((alpha - expected).abs() <= 1e-14, "{alpha} vs {expected}");
        assert!((cost - (1.0 + alpha * b + 0.5 * alpha * alpha * a)).abs() <= 1e-14);
    }
    // An ascent direction is refused.
    let line = Line {
        model: &model,
        u0: Vec::new(),
        du: Vec::new(),
        vmv: 0.0,
        dmv: 1.0,
        dmd: 1.0,
    };
    assert!(exact_line_search(&line).is_err());
}

#[test]
fn exact_line_search_zeroes_the_derivative_across_contact_modes() {
    let p = small_pile(0.3);
    let model = model(&p);
    let v = mixed_velocity(&model);
    let grad = model.gradient(&v);
    let dv: Vec<f64> = grad.iter().map(|g| -g).collect();
    let p_v = model.momentum(&v);
    let line = Line {
        model: &model,
        u0: model.velocities(&v),
        du: model.directions(&dv),
        vmv: 0.5 * dot(&v, &p_v),
        dmv: dot(&dv, &p_v),
        dmd: dot(&dv, &model.momentum(&dv)),
    };
    let (alpha, cost, _) = exact_line_search(&line).unwrap();
    let (_, d0, _) = line.eval(0.0);
    let (c, d1, _) = line.eval(alpha);
    assert_eq!(c, cost);
    assert!(alpha < ALPHA_MAX);
    assert!(d1.abs() <= 1e-9 * d0.abs(), "{d1} vs {d0}");
    // The cost along the line agrees with ℓ itself.
    let moved: Vec<f64> = v.iter().zip(&dv).map(|(x, d)| x + alpha * d).collect();
    assert!((model.cost(&moved) - cost).abs() <= 1e-12 * cost.abs().max(1.0));
}

#[test]
fn problems_without_factors_are_unsupported() {
    let p = ConeProblem::new(Mat::identity(3, 3), vec![-1.0, 0.0, 0.0], vec![0.5]).unwrap();
    let r = solve(&p, Sap::default(), 1e-8);
    match &r.status {
        Status::Unsupported { reason } => assert!(reason.contains("factors"), "{reason}"),
        s => panic!("expected unsupported, got {s:?}"),
    }
    // The box form of a factored problem carries its factors into the cone form.
    let sphere = resting_sphere(1.0, 0.5);
    let boxed = sphere
        .to_box()
        .with_factors(sphere.factors().unwrap().clone());
    let back = ConeProblem::from_box(&boxed.unwrap()).unwrap();
    assert!(back.factors().is_some());
}

#[test]
fn warm_start_from_the_answer_needs_no_iteration_and_the_budget_is_kept() {
    // Low friction: contacts slide, so ℓ is not one quadratic and Newton takes several steps.
    let p = small_pile(0.1);
    let cold = solve(&p, Sap::default(), 1e-8);
    assert!(cold.iterations >= 2, "{}", cold.iterations);
    let warm = Settings {
        warm_start: Some(cold.f.clone()),
        ..Settings::default()
    };
    let r = Sap::default().solve_cone(&p, &warm);
    assert_eq!(r.iterations, 0, "{:?}", r.status);
    let scale = cold.f.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    for (a, b) in r.f.iter().zip(&cold.f) {
        assert!((a - b).abs() <= 1e-9 * scale);
    }
    let spent = Settings {
        time_budget: Some(Duration::ZERO),
        ..Settings::default()
    };
    let r = Sap::default().solve_cone(&p, &spent);
    assert_eq!(r.status, Status::TimeLimit);
    let capped = Settings {
        max_iterations: 1,
        ..Settings::default()
    };
    let r = Sap::default().solve_cone(&p, &capped);
    assert_eq!(r.status, Status::IterationLimit);
}

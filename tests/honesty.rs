//! Property tests that attack the residual the statuses rest on: weak rows, huge finite bounds,
//! symmetric scaling over 1e±12 and mass ratios of 1e6 with friction rows. Every `converged` must
//! pass an independent check written here (not the library's metrics), and `no_solution` must
//! never come on a problem with a planted solution.

mod common;

use common::*;
use faer::Mat;
use lcpbench_solvers::{FrictionRow, Problem, Settings, SolveResult, SolverKind, Status};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const TOL: f64 = 1e-8;

fn solve(kind: SolverKind, p: &Problem) -> SolveResult {
    let settings = Settings {
        tolerance: TOL,
        max_iterations: 5_000,
        ..Settings::default()
    };
    kind.create().solve(p, &settings)
}

/// Neumaier's compensated sum, so the check does not share the library's rounding.
fn compensated_sum(terms: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut c) = (0.0f64, 0.0f64);
    for t in terms {
        let u = s + t;
        c += if s.abs() >= t.abs() {
            (s - u) + t
        } else {
            (t - u) + s
        };
        s = u;
    }
    s + c
}

/// The data of a problem, read back entry by entry.
struct Data {
    a: Mat<f64>,
    b: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    friction: Vec<Option<(usize, f64)>>,
}

impl Data {
    fn of(p: &Problem) -> Self {
        let n = p.n();
        Self {
            a: Mat::from_fn(n, n, |i, j| p.entry(i, j)),
            b: p.b().to_vec(),
            lo: p.lo().to_vec(),
            hi: p.hi().to_vec(),
            friction: (0..n).map(|i| p.friction_of(i)).collect(),
        }
    }

    fn bounds(&self, i: usize, f: &[f64]) -> (f64, f64) {
        match self.friction[i] {
            Some((k, mu)) => (-mu * f[k].max(0.0), mu * f[k].max(0.0)),
            None => (self.lo[i], self.hi[i]),
        }
    }

    fn w(&self, i: usize, f: &[f64]) -> f64 {
        compensated_sum(
            (0..f.len())
                .map(|j| self.a[(i, j)] * f[j])
                .chain([self.b[i]]),
        )
    }

    /// Natural-map step of row `i` in units of impulse, `|f_i − clamp(f_i − w_i / A_ii)|`.
    fn step(&self, i: usize, f: &[f64]) -> f64 {
        let (lo, hi) = self.bounds(i, f);
        (f[i] - (f[i] - self.w(i, f) / self.a[(i, i)]).clamp(lo, hi)).abs()
    }

    /// Independent check 1: the worst step over `rows`, relative to the impulse scale
    /// `max_{k ∈ rows} |b_k| / A_kk` of those rows alone (the attacking row left out).
    fn error_on(&self, rows: &[usize], f: &[f64]) -> f64 {
        let scale = rows
            .iter()
            .map(|&k| (self.b[k] / self.a[(k, k)]).abs())
            .fold(0.0, f64::max);
        rows.iter().map(|&i| self.step(i, f)).fold(0.0, f64::max) / scale
    }

    /// Independent check 2: every row's step within `factor · tol` of the magnitude of the
    /// terms its velocity is made of.
    fn rowwise_ok(&self, f: &[f64], factor: f64) -> bool {
        (0..f.len()).all(|i| {
            let mag = self.b[i].abs()
                + (0..f.len())
                    .map(|j| (self.a[(i, j)] * f[j]).abs())
                    .sum::<f64>();
            self.step(i, f) <= factor * TOL * mag / self.a[(i, i)]
        })
    }
}

/// Appends one decoupled row `(a_nn, b_n, lo_n, hi_n)` to a problem.
fn with_extra_row(p: &Problem, a_nn: f64, b_n: f64, lo_n: f64, hi_n: f64) -> Problem {
    let n = p.n();
    let a = Mat::from_fn(n + 1, n + 1, |i, j| match (i < n, j < n) {
        (true, true) => p.entry(i, j),
        (false, false) => a_nn,
        _ => 0.0,
    });
    let mut b = p.b().to_vec();
    b.push(b_n);
    let (mut lo, mut hi) = (p.lo().to_vec(), p.hi().to_vec());
    lo.push(lo_n);
    hi.push(hi_n);
    Problem::boxed(a, b, lo, hi, p.friction().to_vec()).unwrap()
}

/// The honesty rules every attack shares: `converged` passes `check`, `no_solution` never
/// appears when a solution was planted.
fn check(
    kind: SolverKind,
    r: &SolveResult,
    planted: bool,
    passes: impl Fn(&[f64]) -> bool,
) -> Result<(), TestCaseError> {
    if r.status == Status::Converged {
        prop_assert!(
            passes(&r.f),
            "{} claims convergence but fails the independent check",
            kind.name()
        );
    }
    if planted {
        prop_assert!(
            !matches!(r.status, Status::NoSolution { .. }),
            "{} answers {} on a problem with a planted solution",
            kind.name(),
            r.status
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(config(24))]

    /// A weak row (tiny `A_nn`, `b_n = 1`) next to a planted SPD problem: an earlier residual
    /// divided every row by that row's `b_n / A_nn` and took errors of 7–63 % for converged.
    #[test]
    fn a_weak_row_hides_nothing(planted in planted_spd(12), log_a in -12.0..-6.0f64) {
        let p = with_extra_row(&planted.problem, 10f64.powf(log_a), 1.0, 0.0, f64::INFINITY);
        let data = Data::of(&p);
        let rows: Vec<usize> = (0..planted.problem.n()).collect();
        for kind in SolverKind::all() {
            let r = solve(kind, &p);
            check(kind, &r, true, |f| data.error_on(&rows, f) <= 1e-4 && f[rows.len()] == 0.0)?;
        }
    }

    /// An unrelated row with huge finite bounds `±β` and its solution inside them.
    #[test]
    fn a_huge_bound_hides_nothing(planted in planted_spd(12), log_beta in 6.0..15.0f64, b_n in -2.0..2.0f64) {
        let beta = 10f64.powf(log_beta);
        let p = with_extra_row(&planted.problem, 1.0, b_n, -beta, beta);
        let data = Data::of(&p);
        let n = planted.problem.n();
        let rows: Vec<usize> = (0..n).collect();
        for kind in SolverKind::all() {
            let r = solve(kind, &p);
            check(kind, &r, true, |f| {
                data.error_on(&rows, f) <= 1e-4 && (f[n] + b_n).abs() <= 1e-6 * b_n.abs().max(1e-300)
            })?;
        }
    }

    /// Symmetric scaling `S A S`, `S b` with `s_i` over 1e±6 (entries over 1e±12): the
    /// solution is `S⁻¹ f*`. Pivoting solvers must not stop at a false ray.
    #[test]
    fn symmetric_scaling_changes_no_answer(planted in planted_spd(10), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let p0 = &planted.problem;
        let n = p0.n();
        let s: Vec<f64> = (0..n).map(|_| 10f64.powf(rng.random_range(-6.0..6.0))).collect();
        let p = Problem::lcp(
            Mat::from_fn(n, n, |i, j| s[i] * p0.entry(i, j) * s[j]),
            (0..n).map(|i| s[i] * p0.b()[i]).collect(),
        )
        .unwrap();
        let data0 = Data::of(p0);
        let rows: Vec<usize> = (0..n).collect();
        for kind in SolverKind::all() {
            let r = solve(kind, &p);
            // Map back to the unscaled problem and check there.
            check(kind, &r, true, |f| {
                let g: Vec<f64> = f.iter().zip(&s).map(|(v, si)| v * si).collect();
                data0.error_on(&rows, &g) <= 1e-4
            })?;
            if [SolverKind::Lemke, SolverKind::Dantzig].contains(&kind) {
                prop_assert_eq!(&r.status, &Status::Converged, "{} on a scaled SPD problem", kind.name());
            }
        }
    }

    /// Contact problems `A = J M⁻¹ Jᵀ` between bodies whose masses span 1 to 1e6, with
    /// friction rows: `converged` must satisfy the row-wise check computed here.
    #[test]
    fn mass_ratios_with_friction_rows(seed in any::<u64>(), contacts in 1usize..6, mu in 0.1..1.0f64) {
        let p = mass_ratio_contacts(contacts, mu, seed);
        let data = Data::of(&p);
        for kind in SolverKind::all() {
            let r = solve(kind, &p);
            check(kind, &r, false, |f| data.rowwise_ok(f, 10.0))?;
        }
    }
}

/// `contacts` contacts in a chain of point bodies (3 translational DoF each) whose masses span
/// 1 to 1e6; contact `c` joins bodies `c` and `c + 1` (body 0 is heavy), with one normal and two
/// tangent rows, normals pushed together.
fn mass_ratio_contacts(contacts: usize, mu: f64, seed: u64) -> Problem {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let bodies = contacts + 1;
    let inv_mass: Vec<f64> = (0..bodies)
        .map(|_| 10f64.powf(-rng.random_range(0.0..6.0)))
        .collect();
    let n = 3 * contacts;
    // J: row (c, k) = e_k on body c+1 minus e_k on body c, in a random frame per contact.
    let mut j = Mat::<f64>::zeros(n, 3 * bodies);
    for c in 0..contacts {
        let frame = random_rotation(&mut rng);
        for k in 0..3 {
            for d in 0..3 {
                j[(3 * c + k, 3 * (c + 1) + d)] = frame[k][d];
                j[(3 * c + k, 3 * c + d)] = -frame[k][d];
            }
        }
    }
    let a = Mat::from_fn(n, n, |r, s| {
        (0..3 * bodies)
            .map(|q| j[(r, q)] * inv_mass[q / 3] * j[(s, q)])
            .sum::<f64>()
    });
    let b: Vec<f64> = (0..n)
        .map(|i| {
            if i % 3 == 0 {
                -rng.random_range(0.5..1.5)
            } else {
                rng.random_range(-1.0..1.0)
            }
        })
        .collect();
    let mut lo = vec![0.0; n];
    let mut friction = Vec::new();
    for c in 0..contacts {
        for t in 1..3 {
            lo[3 * c + t] = f64::NEG_INFINITY;
            friction.push(FrictionRow {
                row: 3 * c + t,
                normal: 3 * c,
                mu,
            });
        }
    }
    Problem::boxed(a, b, lo, vec![f64::INFINITY; n], friction).unwrap()
}

/// Rows of a random rotation (Gram–Schmidt on random vectors).
fn random_rotation(rng: &mut ChaCha8Rng) -> [[f64; 3]; 3] {
    let mut v: [[f64; 3]; 3] = [[0.0; 3]; 3];
    for row in v.iter_mut() {
        for x in row.iter_mut() {
            *x = rng.random_range(-1.0..1.0);
        }
    }
    for k in 0..3 {
        for m in 0..k {
            let prev = v[m];
            let d: f64 = v[k].iter().zip(&prev).map(|(x, y)| x * y).sum();
            for (x, y) in v[k].iter_mut().zip(&prev) {
                *x -= d * y;
            }
        }
        let norm = v[k].iter().map(|x| x * x).sum::<f64>().sqrt();
        for x in v[k].iter_mut() {
            *x /= norm;
        }
    }
    v
}

/// The examples from the defect report, exactly: `weak.json`, and the same with a third row
/// bounded by ±1e12 instead. Every solver's `converged` must be the true solution.
#[test]
fn the_reported_examples_are_no_longer_converged_at_wrong_answers() {
    let a = Mat::from_fn(3, 3, |i, j| {
        [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1e-9]][i][j]
    });
    let weak = Problem::lcp(a, vec![-1.0, -1.0, 1.0]).unwrap();
    let bounded = Problem::boxed(
        Mat::from_fn(3, 3, |i, j| {
            [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]][i][j]
        }),
        vec![-1.0, -1.0, 1.0],
        vec![0.0, 0.0, -1e12],
        vec![f64::INFINITY, f64::INFINITY, 1e12],
        vec![],
    )
    .unwrap();
    for (p, third) in [(&weak, 0.0), (&bounded, -1.0)] {
        for kind in SolverKind::all() {
            let r = solve(kind, p);
            if r.status == Status::Converged {
                let want = [1.0 / 3.0, 1.0 / 3.0, third];
                for (got, want) in r.f.iter().zip(want) {
                    assert!(
                        (got - want).abs() <= 1e-6,
                        "{} converged at {:?}",
                        kind.name(),
                        r.f
                    );
                }
            }
        }
    }
}

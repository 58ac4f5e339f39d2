//! Shared proptest strategies: problems built with a known (planted) answer.
#![allow(dead_code)]

use faer::Mat;
use lcpbench_solvers::generate::{generate, p_matrix, plant, psd_matrix, spd_matrix, Family};
use lcpbench_solvers::{FrictionRow, Problem};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Fixed seed and a bounded case count, so the suite is repeatable and fast.
pub fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(0x1c9b_e4c4),
        ..ProptestConfig::default()
    }
}

/// A planted instance: the problem and its known solution.
#[derive(Debug, Clone)]
pub struct Planted {
    pub problem: Problem,
    pub solution: Vec<f64>,
}

/// Planted SPD problems, `n ∈ [2, max_n]`, condition number up to `1e4`.
pub fn planted_spd(max_n: usize) -> impl Strategy<Value = Planted> {
    (2..=max_n, any::<u64>(), 0.0..4.0f64).prop_map(|(n, seed, log_cond)| {
        let g = generate(
            Family::Spd {
                cond: 10f64.powf(log_cond),
            },
            n,
            seed,
        );
        Planted {
            solution: g.solution.unwrap(),
            problem: g.problem,
        }
    })
}

/// Planted PSD rank-deficient problems (`rank < n`).
pub fn planted_psd(max_n: usize) -> impl Strategy<Value = Planted> {
    (3..=max_n, any::<u64>()).prop_flat_map(|(n, seed)| {
        (Just(n), Just(seed), 1..n).prop_map(|(n, seed, rank)| {
            let g = generate(Family::PsdRankDeficient { rank }, n, seed);
            Planted {
                solution: g.solution.unwrap(),
                problem: g.problem,
            }
        })
    })
}

/// Planted non-symmetric P-matrix problems.
pub fn planted_p_matrix(max_n: usize) -> impl Strategy<Value = Planted> {
    (2..=max_n, any::<u64>()).prop_map(|(n, seed)| {
        let g = generate(Family::PMatrix, n, seed);
        Planted {
            solution: g.solution.unwrap(),
            problem: g.problem,
        }
    })
}

/// A random permutation of `0..n` from a seed.
pub fn permutation(n: usize, seed: u64) -> Vec<usize> {
    use rand::seq::SliceRandom;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut p: Vec<usize> = (0..n).collect();
    p.shuffle(&mut rng);
    p
}

/// Boxed SPD problems with finite and infinite bounds (`lo <= 0 <= hi` so zero is feasible).
pub fn boxed_spd(max_n: usize) -> impl Strategy<Value = Problem> {
    (2..=max_n, any::<u64>()).prop_map(|(n, seed)| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let a = spd_matrix(n, 100.0, &mut rng);
        let (_, b) = plant(&a, &mut rng);
        use rand::Rng;
        let lo: Vec<f64> = (0..n)
            .map(|i| match i % 3 {
                0 => 0.0,
                1 => -rng.random_range(0.1..1.0),
                _ => f64::NEG_INFINITY,
            })
            .collect();
        let hi: Vec<f64> = (0..n)
            .map(|i| match i % 4 {
                3 => f64::INFINITY,
                _ => rng.random_range(0.1..1.0),
            })
            .collect();
        Problem::boxed(a, b, lo, hi, Vec::new()).unwrap()
    })
}

/// Contact-like boxed problems with friction rows: `nc` contacts of three rows each (normal,
/// two tangents), `A = J Jᵀ + εI` from a random Jacobian, normals pushed together.
pub fn friction_contacts(max_contacts: usize) -> impl Strategy<Value = Problem> {
    (1..=max_contacts, any::<u64>(), 0.1..1.0f64).prop_map(|(nc, seed, mu)| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        friction_problem(nc, mu, &mut rng)
    })
}

/// See [`friction_contacts`].
pub fn friction_problem(nc: usize, mu: f64, rng: &mut ChaCha8Rng) -> Problem {
    use rand::Rng;
    let n = 3 * nc;
    let a = psd_matrix(n, n, rng);
    let a = Mat::from_fn(n, n, |i, j| a[(i, j)] + if i == j { 1e-3 } else { 0.0 });
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
    let hi = vec![f64::INFINITY; n];
    let mut friction = Vec::new();
    for c in 0..nc {
        for t in 1..3 {
            lo[3 * c + t] = f64::NEG_INFINITY;
            friction.push(FrictionRow {
                row: 3 * c + t,
                normal: 3 * c,
                mu,
            });
        }
    }
    Problem::boxed(a, b, lo, hi, friction).unwrap()
}

/// A planted P-matrix (non-symmetric) from a seed.
pub fn p_matrix_problem(n: usize, seed: u64) -> Problem {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a = p_matrix(n, &mut rng);
    let (_, b) = plant(&a, &mut rng);
    Problem::lcp(a, b).unwrap()
}

/// The shapes of problem built around a null direction of `A` ([`around_null`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NullKind {
    /// Standard LCP.
    Standard,
    /// Boxed LCP: the null direction on rows `[lo, ∞)`, the other rows with two finite bounds,
    /// `[0, ∞)`, `(−∞, hi]` or free.
    Boxed,
    /// Contacts of a normal row and two friction rows; the null direction on normal rows.
    Friction,
}

/// A problem whose `A` (symmetric PSD, rank `n − deficit`) has the null direction `z >= 0`
/// (`A z = 0` up to rounding), with `z` on rows where it is a recession direction of the bounds
/// (normal rows for [`NullKind::Friction`]).
#[derive(Debug, Clone)]
pub struct AroundNull {
    pub problem: Problem,
    pub z: Vec<f64>,
    /// The planted solution, for the feasible construction.
    pub solution: Option<Vec<f64>>,
}

/// [`AroundNull`] of `n` rows and rank deficit `deficit`: `A = B Bᵀ / r` with `B = P C`, `C`
/// Gaussian `n × r` (`r = n − deficit`) and `P` the projector orthogonal to `z`. A solution
/// `(f*, w*)` is planted (strictly complementary, `w* > 0` on one row of `z`'s support) and
/// `b = w* − A f*`, so `zᵀ b = zᵀ w* > 0`. Without `feasible`, `b` is then moved along `z` to
/// `zᵀ b = −strength · Σ z_i`: by Farkas' lemma no `f` in the bounds has `w_i >= 0` on `z`'s
/// rows, so there is no solution.
pub fn around_null(
    kind: NullKind,
    n: usize,
    deficit: usize,
    feasible: bool,
    strength: f64,
    seed: u64,
) -> AroundNull {
    use lcpbench_solvers::generate::gaussian;
    use rand::Rng;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let carriers: Vec<usize> = match kind {
        NullKind::Friction => (0..n).step_by(3).collect(),
        _ => (0..n).collect(),
    };
    let mut z = vec![0.0; n];
    let mut support: Vec<usize> = carriers
        .iter()
        .copied()
        .filter(|_| rng.random_bool(0.6))
        .collect();
    if support.len() < 2.min(carriers.len()) {
        support = carriers[..2.min(carriers.len())].to_vec();
    }
    for &i in &support {
        z[i] = rng.random_range(0.5..1.5);
    }
    let r = n - deficit.clamp(1, n - 1);
    let zz: f64 = z.iter().map(|v| v * v).sum();
    let mut bm = Mat::from_fn(n, r, |_, _| gaussian(&mut rng));
    for j in 0..r {
        let d: f64 = (0..n).map(|i| z[i] * bm[(i, j)]).sum::<f64>() / zz;
        for i in 0..n {
            bm[(i, j)] -= d * z[i];
        }
    }
    let a = Mat::from_fn(n, n, |i, j| {
        (0..r).map(|m| bm[(i, m)] * bm[(j, m)]).sum::<f64>() / r as f64
    });
    let a = Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let (mut lo, mut hi) = (vec![0.0; n], vec![f64::INFINITY; n]);
    let mut friction = Vec::new();
    let (mut f, mut w) = (vec![0.0; n], vec![0.0; n]);
    match kind {
        NullKind::Standard => {
            for i in 0..n {
                if rng.random_bool(0.5) {
                    f[i] = rng.random_range(0.5..1.5);
                } else {
                    w[i] = rng.random_range(0.5..1.5);
                }
            }
        }
        NullKind::Boxed => {
            for i in 0..n {
                match if z[i] > 0.0 {
                    0
                } else {
                    rng.random_range(0..4)
                } {
                    0 => lo[i] = -rng.random_range(0.0..1.0),
                    1 => {
                        lo[i] = -rng.random_range(0.1..1.0);
                        hi[i] = rng.random_range(0.1..1.0);
                    }
                    2 => {
                        lo[i] = f64::NEG_INFINITY;
                        hi[i] = rng.random_range(-1.0..1.0);
                    }
                    _ => lo[i] = f64::NEG_INFINITY,
                }
                let state = rng.random_range(0..3);
                if state == 0 && lo[i].is_finite() {
                    f[i] = lo[i];
                    w[i] = rng.random_range(0.5..1.5);
                } else if state == 1 && hi[i].is_finite() {
                    f[i] = hi[i];
                    w[i] = -rng.random_range(0.5..1.5);
                } else {
                    let l = if lo[i].is_finite() {
                        lo[i]
                    } else {
                        hi[i].min(0.0) - 2.0
                    };
                    let h = if hi[i].is_finite() {
                        hi[i]
                    } else {
                        l.max(0.0) + 2.0
                    };
                    f[i] = l + (h - l) * rng.random_range(0.1..0.9);
                }
            }
        }
        NullKind::Friction => {
            for &k in &carriers {
                let mu = rng.random_range(0.2..1.0);
                let touching = rng.random_bool(0.7);
                if touching {
                    f[k] = rng.random_range(0.5..1.5);
                } else {
                    w[k] = rng.random_range(0.5..1.5);
                }
                for t in (k + 1..k + 3).filter(|&t| t < n) {
                    friction.push(FrictionRow {
                        row: t,
                        normal: k,
                        mu,
                    });
                    lo[t] = f64::NEG_INFINITY;
                    if !touching {
                        w[t] = gaussian(&mut rng);
                        continue;
                    }
                    match rng.random_range(0..3) {
                        0 => f[t] = mu * f[k] * rng.random_range(-0.9..0.9),
                        1 => {
                            f[t] = mu * f[k];
                            w[t] = -rng.random_range(0.5..1.5);
                        }
                        _ => {
                            f[t] = -mu * f[k];
                            w[t] = rng.random_range(0.5..1.5);
                        }
                    }
                }
            }
        }
    }
    // One row of z's support separates (f = its lower bound, w > 0), so zᵀ w* > 0.
    let first = support[0];
    if kind == NullKind::Friction {
        for t in (first + 1..first + 3).filter(|&t| t < n) {
            if f[t] != 0.0 {
                f[t] = 0.0;
                w[t] = gaussian(&mut rng);
            }
        }
    }
    f[first] = lo[first];
    w[first] = rng.random_range(0.5..1.5);
    let mut b: Vec<f64> = (0..n)
        .map(|i| w[i] - (0..n).map(|j| a[(i, j)] * f[j]).sum::<f64>())
        .collect();
    if !feasible {
        let zb: f64 = z.iter().zip(&b).map(|(x, y)| x * y).sum();
        let gamma = (zb + strength * z.iter().sum::<f64>()) / zz;
        for i in 0..n {
            b[i] -= gamma * z[i];
        }
    }
    let problem = Problem::boxed(a, b, lo, hi, friction).unwrap();
    AroundNull {
        problem,
        z,
        solution: feasible.then_some(f),
    }
}

/// [`around_null`] problems of every kind with `n` in `2..=max_n` (half of them at most 12 rows),
/// rank deficits from 1 to `n / 2` and, without a solution, strengths in `[0.25, 1]`.
pub fn around_null_strategy(max_n: usize, feasible: bool) -> impl Strategy<Value = AroundNull> {
    let kinds = prop_oneof![
        Just(NullKind::Standard),
        Just(NullKind::Boxed),
        Just(NullKind::Friction)
    ];
    let sizes = prop_oneof![2..=12usize.min(max_n), 2..=max_n];
    (kinds, sizes, any::<u64>(), 0.25..1.0f64).prop_flat_map(move |(kind, n, seed, strength)| {
        let n = if kind == NullKind::Friction {
            n.max(3)
        } else {
            n
        };
        (1..=(n / 2).max(1))
            .prop_map(move |deficit| around_null(kind, n, deficit, feasible, strength, seed))
    })
}

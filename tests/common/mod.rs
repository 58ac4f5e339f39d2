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

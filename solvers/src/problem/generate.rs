//! Random problem generators with planted solutions, for tests, benches and `lcpbench gen`.
//!
//! A planted instance picks a random support `S`, an impulse `f*` with `f*_i ∈ [0.5, 1.5]` on `S`
//! and zero elsewhere, a velocity `w*` with `w*_i ∈ [0.5, 1.5]` off `S` and zero on it, and sets
//! `b = w* − A f*`. Then `f*` solves the LCP `(A, b)` exactly, with strict complementarity.
//! Every generator is deterministic in its seed.

use crate::problem::Problem;
use faer::Mat;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A generated problem and, when one was planted, its solution.
#[derive(Debug, Clone)]
pub struct Generated {
    /// The problem.
    pub problem: Problem,
    /// The planted solution `f*` (`None` when the problem has none or it is not known).
    pub solution: Option<Vec<f64>>,
}

/// Largest condition number of a generated SPD matrix. Forming `Q Λ Qᵀ` in `f64` perturbs every
/// eigenvalue by about `n ε` of the largest (`ε = 2.2e-16`); beyond `1e12` that is a sizeable
/// part of the smallest eigenvalue, so the matrix would not have the condition number asked for
/// (and beyond `1/ε` it need not even be positive definite).
pub const MAX_CONDITION: f64 = 1e12;

/// The instance families `lcpbench gen` knows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Family {
    /// Symmetric positive definite with condition number `cond` (eigenvalues log-spaced in
    /// `[1/cond, 1]`).
    Spd {
        /// Condition number, from 1 to [`MAX_CONDITION`].
        cond: f64,
    },
    /// Symmetric positive semidefinite of rank `rank < n`: `A = XᵀX / rank`, `X` Gaussian
    /// `rank × n` (redundant contacts).
    PsdRankDeficient {
        /// Rank of `A`.
        rank: usize,
    },
    /// Non-symmetric positive definite (hence P-matrix): `A = LLᵀ/n + I/2 + K`, `K` skew-symmetric.
    PMatrix,
    /// Murty's example on which Lemke's method with covering vector `e` takes `2ⁿ` pivots
    /// (K. G. Murty, *Computational complexity of complementary pivot methods*, Math. Prog. Study
    /// 7, 1978): `A` lower triangular with 1 on the diagonal and 2 below, `b = −e`; the unique
    /// solution is `f = e₁`. The first pivot is a tie between all rows; the lexicographic rule
    /// (equivalently `b_i = −1 + εⁱ`) breaks it towards the last row, and the path then visits
    /// every one of the `2ⁿ` complementary bases (the z0 pivot and the final pivot included).
    /// The transpose (upper triangular, 2 above) is solved in 2 pivots by the same rule.
    Murty,
    /// A PSD problem with no solution: `A = Y (I − eeᵀ/n)` Gram matrix, so `eᵀ A = 0`, and
    /// `eᵀ b < 0`; then `eᵀ w = eᵀ b < 0` for every `f`.
    Infeasible,
}

impl Family {
    /// Parse a family name as used by `lcpbench gen` (`spd`, `psd`, `pmatrix`, `murty`,
    /// `infeasible`); `cond` and `rank` fill the parameters of `spd` and `psd`.
    pub fn from_name(name: &str, n: usize, cond: f64, rank: Option<usize>) -> Option<Self> {
        Some(match name {
            "spd" => Family::Spd { cond },
            "psd" => Family::PsdRankDeficient {
                rank: rank.unwrap_or((n / 2).max(1)),
            },
            "pmatrix" => Family::PMatrix,
            "murty" => Family::Murty,
            "infeasible" => Family::Infeasible,
            _ => return None,
        })
    }

    /// Family names accepted by [`Family::from_name`].
    pub const NAMES: [&'static str; 5] = ["spd", "psd", "pmatrix", "murty", "infeasible"];
}

/// Generate an instance of `family` with `n` rows from `seed`.
pub fn generate(family: Family, n: usize, seed: u64) -> Generated {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    match family {
        Family::Spd { cond } => planted(spd_matrix(n, cond, &mut rng), &mut rng, "spd"),
        Family::PsdRankDeficient { rank } => {
            planted(psd_matrix(n, rank.min(n), &mut rng), &mut rng, "psd")
        }
        Family::PMatrix => planted(p_matrix(n, &mut rng), &mut rng, "pmatrix"),
        Family::Murty => {
            let a = Mat::from_fn(n, n, |i, j| match i.cmp(&j) {
                std::cmp::Ordering::Equal => 1.0,
                std::cmp::Ordering::Greater => 2.0,
                std::cmp::Ordering::Less => 0.0,
            });
            // The unique solution (A is a P-matrix) is f = e_1: w_i = 2 - 1 = 1 below it.
            let mut f = vec![0.0; n];
            if n > 0 {
                f[0] = 1.0;
            }
            let problem = Problem::lcp(a, vec![-1.0; n])
                .expect("finite")
                .with_name(format!("murty n={n}"));
            Generated {
                problem,
                solution: Some(f),
            }
        }
        Family::Infeasible => {
            let y = gaussian_matrix(n, n, &mut rng);
            // Centre the columns of Y: Yc = Y (I - e eᵀ/n), so Yc e = 0 and A = Ycᵀ Yc has A e = 0.
            let yc = Mat::from_fn(n, n, |i, j| {
                let mean: f64 = (0..n).map(|k| y[(i, k)]).sum::<f64>() / n as f64;
                y[(i, j)] - mean
            });
            let a = Mat::from_fn(n, n, |i, j| {
                (0..n).map(|k| yc[(k, i)] * yc[(k, j)]).sum::<f64>() / n as f64
            });
            // Symmetrise exactly so the problem is recognised as symmetric PSD.
            let a = Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
            let b: Vec<f64> = (0..n).map(|_| rng.random_range(-1.5..0.5)).collect();
            let sum: f64 = b.iter().sum();
            let b: Vec<f64> = b.iter().map(|v| v - (sum + n as f64) / n as f64).collect();
            let problem = Problem::lcp(a, b)
                .expect("finite")
                .with_name(format!("infeasible n={n}"));
            Generated {
                problem,
                solution: None,
            }
        }
    }
}

fn planted(a: Mat<f64>, rng: &mut ChaCha8Rng, family: &str) -> Generated {
    let n = a.nrows();
    let (f, b) = plant(&a, rng);
    let problem = Problem::lcp(a, b)
        .expect("finite")
        .with_name(format!("{family} n={n}"));
    Generated {
        problem,
        solution: Some(f),
    }
}

/// Plant a strictly complementary solution for `A`: returns `(f*, b)`.
pub fn plant(a: &Mat<f64>, rng: &mut impl Rng) -> (Vec<f64>, Vec<f64>) {
    let n = a.nrows();
    let mut f = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n {
        if rng.random_bool(0.5) {
            f[i] = rng.random_range(0.5..1.5);
        } else {
            w[i] = rng.random_range(0.5..1.5);
        }
    }
    let b = (0..n)
        .map(|i| w[i] - (0..n).map(|j| a[(i, j)] * f[j]).sum::<f64>())
        .collect();
    (f, b)
}

/// A standard normal sample (Box–Muller).
pub fn gaussian(rng: &mut impl Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn gaussian_matrix(rows: usize, cols: usize, rng: &mut impl Rng) -> Mat<f64> {
    let mut m = Mat::zeros(rows, cols);
    for j in 0..cols {
        for i in 0..rows {
            m[(i, j)] = gaussian(rng);
        }
    }
    m
}

/// A random orthogonal matrix (Gram–Schmidt, twice, on a Gaussian matrix).
pub fn orthogonal_matrix(n: usize, rng: &mut impl Rng) -> Mat<f64> {
    let mut q = gaussian_matrix(n, n, rng);
    for j in 0..n {
        for _ in 0..2 {
            for k in 0..j {
                let d: f64 = (0..n).map(|i| q[(i, j)] * q[(i, k)]).sum();
                for i in 0..n {
                    q[(i, j)] -= d * q[(i, k)];
                }
            }
        }
        let norm = (0..n).map(|i| q[(i, j)].powi(2)).sum::<f64>().sqrt();
        for i in 0..n {
            q[(i, j)] /= norm;
        }
    }
    q
}

/// SPD matrix `Q Λ Qᵀ` with eigenvalues log-spaced in `[1/cond, 1]`, exactly symmetric.
pub fn spd_matrix(n: usize, cond: f64, rng: &mut impl Rng) -> Mat<f64> {
    let q = orthogonal_matrix(n, rng);
    let lambda: Vec<f64> = (0..n)
        .map(|k| {
            let t = if n > 1 {
                k as f64 / (n - 1) as f64
            } else {
                0.0
            };
            cond.powf(-t)
        })
        .collect();
    let a = Mat::from_fn(n, n, |i, j| {
        (0..n)
            .map(|k| q[(i, k)] * lambda[k] * q[(j, k)])
            .sum::<f64>()
    });
    Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]))
}

/// PSD matrix `XᵀX / rank` with `X` Gaussian `rank × n`.
pub fn psd_matrix(n: usize, rank: usize, rng: &mut impl Rng) -> Mat<f64> {
    let x = gaussian_matrix(rank, n, rng);
    let r = rank.max(1) as f64;
    let a = Mat::from_fn(n, n, |i, j| {
        (0..rank).map(|k| x[(k, i)] * x[(k, j)]).sum::<f64>() / r
    });
    Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]))
}

/// Non-symmetric positive definite matrix `LLᵀ/n + I/2 + K` with `K` skew-symmetric.
pub fn p_matrix(n: usize, rng: &mut impl Rng) -> Mat<f64> {
    let l = gaussian_matrix(n, n, rng);
    let k = gaussian_matrix(n, n, rng);
    let nf = n.max(1) as f64;
    Mat::from_fn(n, n, |i, j| {
        let sym: f64 = (0..n).map(|m| l[(i, m)] * l[(j, m)]).sum::<f64>() / nf;
        let skew = 0.5 * (k[(i, j)] - k[(j, i)]);
        sym + skew + if i == j { 0.5 } else { 0.0 }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::metrics::residuals;

    #[test]
    fn planted_solutions_have_zero_residual() {
        for family in [
            Family::Spd { cond: 1e3 },
            Family::PsdRankDeficient { rank: 5 },
            Family::PMatrix,
            Family::Murty,
        ] {
            let g = generate(family, 12, 7);
            let r = residuals(&g.problem, g.solution.as_ref().unwrap());
            assert!(r.natural_map_rel < 1e-12, "{family:?}: {r:?}");
        }
    }

    #[test]
    fn spd_has_the_requested_condition_number() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let a = spd_matrix(20, 1e6, &mut rng);
        let ev = a.self_adjoint_eigenvalues(faer::Side::Lower).unwrap();
        let cond = ev[ev.len() - 1] / ev[0];
        assert!((cond / 1e6 - 1.0).abs() < 1e-4, "cond = {cond}");
    }

    #[test]
    fn infeasible_family_has_e_in_the_left_null_space() {
        let g = generate(Family::Infeasible, 8, 3);
        let p = &g.problem;
        for j in 0..8 {
            let col: f64 = (0..8).map(|i| p.entry(i, j)).sum();
            assert!(col.abs() < 1e-12);
        }
        assert!(p.b().iter().sum::<f64>() < 0.0);
    }
}

//! Figures for the pivoting solvers (Lemke, Dantzig) on generated families.
//!
//! ```text
//! cargo run --release -p lcpbench-solvers --example pivoting_figures
//! ```

use faer::Mat;
use lcpbench_solvers::generate::{gaussian, generate, Family};
use lcpbench_solvers::{Dantzig, FrictionRow, Lemke, Problem, ProjectedSor, Settings, Solver};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `contacts` contacts (a normal and two friction rows each) with random Jacobians on `dofs`
/// unit-mass degrees of freedom: `A = J Jᵀ + eps I`.
fn random_contacts(contacts: usize, dofs: usize, mu: f64, eps: f64, seed: u64) -> Problem {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = 3 * contacts;
    let j = Mat::from_fn(n, dofs, |_, _| gaussian(&mut rng));
    let v: Vec<f64> = (0..dofs).map(|_| gaussian(&mut rng)).collect();
    let a = Mat::from_fn(n, n, |r, c| {
        (0..dofs).map(|k| j[(r, k)] * j[(c, k)]).sum::<f64>() + if r == c { eps } else { 0.0 }
    });
    let b = (0..n)
        .map(|r| (0..dofs).map(|k| j[(r, k)] * v[k]).sum::<f64>() - rng.random_range(0.0..0.5))
        .collect();
    let hi = (0..n)
        .map(|r| if r % 3 == 0 { f64::INFINITY } else { 0.0 })
        .collect();
    let friction = (0..contacts)
        .flat_map(|c| {
            [1, 2].map(|t| FrictionRow {
                row: 3 * c + t,
                normal: 3 * c,
                mu,
            })
        })
        .collect();
    Problem::boxed(a, b, vec![0.0; n], hi, friction).unwrap()
}

fn main() {
    let settings = Settings::default();
    println!("Murty (lower triangular, b = -e), Lemke pivots:");
    for n in 2..=10 {
        let g = generate(Family::Murty, n, 0);
        let r = Lemke::default().solve(&g.problem, &settings);
        println!(
            "  n = {n:2}: {:5} pivots (2^n = {:5}), {}",
            r.iterations,
            1 << n,
            r.status
        );
    }
    let cases = [
        ("spd cond 1e3", Family::Spd { cond: 1e3 }, 100),
        ("psd rank 45", Family::PsdRankDeficient { rank: 45 }, 90),
        ("p-matrix", Family::PMatrix, 40),
        ("murty", Family::Murty, 10),
        ("infeasible", Family::Infeasible, 20),
    ];
    println!(
        "{:<14} {:>4} {:<8} {:<18} {:>12} {:>7} {:>11}",
        "family", "n", "solver", "status", "residual_rel", "pivots", "time"
    );
    for (name, family, n) in cases {
        let g = generate(family, n, 1);
        let solvers: [Box<dyn Solver>; 2] =
            [Box::new(Lemke::default()), Box::new(Dantzig::default())];
        for mut s in solvers {
            let r = s.solve(&g.problem, &settings);
            println!(
                "{:<14} {:>4} {:<8} {:<18} {:>12.3e} {:>7} {:>9.3} ms",
                name,
                n,
                s.name(),
                r.status.name(),
                r.residuals.natural_map_rel,
                r.iterations,
                r.time.as_secs_f64() * 1e3
            );
        }
    }
    println!("friction contacts (random Jacobians, mu = 0.4), Dantzig vs PGS:");
    for (contacts, dofs, eps) in [(10, 18, 1e-3), (30, 18, 1e-3), (30, 18, 1e-8)] {
        let p = random_contacts(contacts, dofs, 0.4, eps, 2);
        let solvers: [Box<dyn Solver>; 2] =
            [Box::new(Dantzig::default()), Box::new(ProjectedSor::pgs())];
        for mut s in solvers {
            let r = s.solve(&p, &settings);
            println!(
                "  {:>3} rows, eps {:.0e}: {:<8} {:<18} {:>10.3e} {:>7} it {:>9.3} ms",
                3 * contacts,
                eps,
                s.name(),
                r.status.name(),
                r.residuals.natural_map_rel,
                r.iterations,
                r.time.as_secs_f64() * 1e3
            );
        }
    }
}

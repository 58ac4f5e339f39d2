//! Per-solve cost of every solver on tiny planted problems (n = 4, 10, 20), the case where
//! allocation, validation and residual bookkeeping dominate. Prints the median wall time per
//! solve over many repetitions; run under `valgrind --tool=callgrind` for instruction counts.
//!
//! `cargo run --release -p lcpbench-solvers --example tiny_overhead [REPS [SOLVER]]`

use lcpbench_solvers::generate::{generate, Family};
use lcpbench_solvers::{Settings, SolverKind};
use std::time::Instant;

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    // Optional filter: `REPS SOLVER` times one solver only.
    let only = std::env::args().nth(2);
    let settings = Settings::default();
    println!("family n solver status median_us");
    for (family_name, family) in [
        ("spd", Family::Spd { cond: 1e3 }),
        ("pmatrix", Family::PMatrix),
    ] {
        for n in [4, 10, 20] {
            let problem = generate(family, n, 1).problem;
            for kind in SolverKind::ALL {
                if only.as_deref().is_some_and(|o| o != kind.name()) {
                    continue;
                }
                let mut solver = kind.create();
                let status = solver.solve(&problem, &settings).status;
                let mut times: Vec<f64> = (0..reps)
                    .map(|_| {
                        let t0 = Instant::now();
                        std::hint::black_box(
                            solver.solve(std::hint::black_box(&problem), &settings),
                        );
                        t0.elapsed().as_secs_f64() * 1e6
                    })
                    .collect();
                times.sort_by(f64::total_cmp);
                println!(
                    "{family_name} {n} {} {} {:.2}",
                    kind.name(),
                    status.name(),
                    times[reps / 2]
                );
            }
        }
    }
}

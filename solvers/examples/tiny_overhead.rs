//! Per-solve cost of every solver on tiny planted problems (n = 4, 10, 20), the case where
//! allocation, validation and residual bookkeeping dominate. Prints the median wall time per
//! solve over many repetitions; run under `valgrind --tool=callgrind` for instruction counts.
//!
//! The three Siconos numerics LCPs in `tests/data/siconos/` follow the planted families.
//!
//! `cargo run --release -p lcpbench-solvers --example tiny_overhead [REPS [SOLVER [CASE]]]`,
//! where `CASE` is `spd-4`, `lcp_CPS_1-2`, … or the path of a problem file (JSON or `.dat`), to
//! time that file alone (the same file a peer harness times).

use lcpbench_solvers::generate::{generate, Family};
use lcpbench_solvers::{read_problem, Problem, Settings, SolverKind};
use std::path::Path;
use std::time::Instant;

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    // Optional filter: `REPS SOLVER` times one solver only.
    let only = std::env::args().nth(2);
    // And `REPS SOLVER CASE` one case (`spd-4`, `lcp_CPS_1-2`, …), for instruction counts.
    let only_case = std::env::args().nth(3);
    let settings = Settings::default();
    println!("family n solver status median_us");
    let mut cases: Vec<(String, Problem)> = Vec::new();
    for (family_name, family) in [
        ("spd", Family::Spd { cond: 1e3 }),
        ("pmatrix", Family::PMatrix),
    ] {
        for n in [4, 10, 20] {
            cases.push((family_name.to_string(), generate(family, n, 1).problem));
        }
    }
    let siconos = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/siconos");
    for name in ["lcp_CPS_1", "lcp_CPS_4", "lcp_deudeu_block"] {
        match read_problem(&siconos.join(format!("{name}.dat"))) {
            Ok(p) => cases.push((name.to_string(), p)),
            Err(e) => eprintln!("{name}: {e}"),
        }
    }
    if let Some(path) = only_case.as_deref().map(Path::new).filter(|p| p.is_file()) {
        match read_problem(path) {
            Ok(p) => {
                let name = path.file_stem().unwrap_or_default().to_string_lossy();
                cases = vec![(name.to_string(), p)];
            }
            Err(e) => {
                eprintln!("{}: {e}", path.display());
                std::process::exit(1);
            }
        }
    }
    {
        for (family_name, problem) in &cases {
            let n = problem.n();
            if cases.len() > 1
                && only_case
                    .as_deref()
                    .is_some_and(|c| c != format!("{family_name}-{n}"))
            {
                continue;
            }
            for kind in SolverKind::all() {
                if only.as_deref().is_some_and(|o| o != kind.name()) {
                    continue;
                }
                let mut solver = kind.create();
                let status = solver.solve(problem, &settings).status;
                let mut times: Vec<f64> = (0..reps)
                    .map(|_| {
                        let t0 = Instant::now();
                        std::hint::black_box(
                            solver.solve(std::hint::black_box(problem), &settings),
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

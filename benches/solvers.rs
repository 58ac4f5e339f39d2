//! Each matrix solver on fixed LCPs of several sizes: generated families (planted solutions, fixed
//! seeds) and the LCPs the report exports from the scenes (`reports/lcps/*.json`, when present).
//! Problems, solvers and settings are built outside the timed closure.
//!
//! `cargo bench --bench solvers`; groups `spd_cond1e3`, `psd`, `pmatrix`, `exported`, each with
//! `BenchmarkId::new(solver, n)`. Solvers that decline a problem (`unsupported`) or do not reach
//! the tolerance on it are skipped for that problem, so every timing is of a converged solve.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use lcpbench::harness::Case;
use lcpbench_solvers::{read_problem, Problem, Settings, SolverKind};
use std::hint::black_box;
use std::time::Duration;

fn settings() -> Settings {
    Settings {
        tolerance: 1e-8,
        max_iterations: 20_000,
        time_budget: Some(Duration::from_secs(2)),
        ..Settings::default()
    }
}

fn bench_problems(c: &mut Criterion, group_name: &str, problems: &[(usize, Problem)]) {
    let mut group = c.benchmark_group(group_name);
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(1));
    let settings = settings();
    for (n, problem) in problems {
        for kind in SolverKind::all() {
            let mut solver = kind.create();
            if !solver.solve(problem, &settings).status.is_converged() {
                continue;
            }
            group.bench_with_input(BenchmarkId::new(kind.name(), n), problem, |b, p| {
                b.iter(|| black_box(solver.solve(black_box(p), &settings)))
            });
        }
    }
    group.finish();
}

fn generated(key: &str, sizes: &[usize]) -> Vec<(usize, Problem)> {
    sizes
        .iter()
        .map(|&n| {
            let case: Case = key
                .replace("{n}", &n.to_string())
                .parse()
                .expect("case key");
            (n, case.load_lcp().expect("generated").problem)
        })
        .collect()
}

fn families(c: &mut Criterion) {
    let sizes = [16, 64, 256];
    bench_problems(
        c,
        "spd_cond1e3",
        &generated("spd:n={n}:cond=1e3:seed=1", &sizes),
    );
    bench_problems(c, "psd", &generated("psd:n={n}:seed=1", &sizes));
    bench_problems(c, "pmatrix", &generated("pmatrix:n={n}:seed=1", &sizes));
}

fn exported(c: &mut Criterion) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/reports/lcps");
    let mut problems: Vec<(usize, Problem)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .filter_map(|p| read_problem(&p).ok())
        .map(|p| (p.n(), p))
        .collect();
    if problems.is_empty() {
        eprintln!("no exported LCPs in {dir}: run `lcpbench report` first");
        return;
    }
    problems.sort_by_key(|(n, _)| *n);
    problems.dedup_by_key(|(n, _)| *n);
    bench_problems(c, "exported", &problems);
}

criterion_group!(benches, families, exported);
criterion_main!(benches);

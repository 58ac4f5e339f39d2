//! `lcpbench solve` and `lcpbench solvers`.

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use lcpbench::harness::budget;
use lcpbench_solvers::{read_problem, Problem, ProjectedSor, Settings, Solver, SolverKind};
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `lcpbench solve`.
#[derive(Args)]
pub struct SolveArgs {
    /// Problem file: JSON (format in the README), Siconos numerics LCP (`.dat`) or FCLIB
    /// (`.hdf5`, `.h5`); the format is chosen by extension, then by content.
    pub problem: PathBuf,
    /// Solver name (see `lcpbench solvers`).
    #[arg(long, short)]
    pub solver: SolverKind,
    /// Tolerance on the relative natural-map residual.
    #[arg(long, default_value_t = 1e-8)]
    pub tol: f64,
    /// Iteration / pivot cap.
    #[arg(long, default_value_t = 10_000)]
    pub max_iter: usize,
    /// SOR relaxation factor (only with `--solver sor`).
    #[arg(long)]
    pub omega: Option<f64>,
    /// Wall-time budget in seconds.
    #[arg(long)]
    pub time_budget: Option<f64>,
    /// Print one JSON object instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Record and print the convergence history.
    #[arg(long)]
    pub history: bool,
}

/// Build the solver named by `kind`, applying `omega` to SOR.
pub fn make_solver(kind: SolverKind, omega: Option<f64>) -> Result<Box<dyn Solver + Send>> {
    match (kind, omega) {
        (SolverKind::Sor, Some(w)) if !(w > 0.0 && w < 2.0) => {
            bail!("--omega must be in (0, 2) (projected SOR diverges outside it), got {w}")
        }
        (SolverKind::Sor, Some(w)) => Ok(Box::new(ProjectedSor::sor(w))),
        (_, Some(_)) => bail!("--omega applies only to --solver sor"),
        (kind, None) => Ok(kind.create()),
    }
}

fn describe(problem: &Problem) -> String {
    let class = if problem.is_standard() {
        "standard LCP".to_owned()
    } else if problem.friction().is_empty() {
        "boxed LCP".to_owned()
    } else {
        format!("boxed LCP, {} friction rows", problem.friction().len())
    };
    let sym = if problem.is_symmetric(1e-10) {
        "symmetric"
    } else {
        "non-symmetric"
    };
    format!("{} rows, {class}, {sym} A", problem.n())
}

/// Run `lcpbench solve`.
pub fn run(args: SolveArgs) -> Result<()> {
    budget::tolerance(args.tol).map_err(|m| anyhow!("--tol: {m}"))?;
    let time_budget = match args.time_budget {
        Some(t) => Some(budget::time_budget(t).map_err(|m| anyhow!("--time-budget: {m}"))?),
        None => None,
    };
    if args.max_iter == 0 {
        bail!("--max-iter must be at least 1");
    }
    let mut solver = make_solver(args.solver, args.omega)?;
    let problem = read_problem(&args.problem)?;
    let settings = Settings {
        tolerance: args.tol,
        max_iterations: args.max_iter,
        time_budget,
        warm_start: None,
        record_history: args.history,
    };
    let r = solver.solve(&problem, &settings);
    if args.json {
        let out = json!({
            "problem": problem.name(),
            "n": problem.n(),
            "solver": solver.name(),
            "status": r.status.name(),
            "reason": r.status.reason(),
            "iterations": r.iterations,
            "time_s": r.time.as_secs_f64(),
            "residual": r.residuals.natural_map,
            "residual_rel": r.residuals.natural_map_rel,
            "complementarity_gap": r.residuals.complementarity_gap,
            "bound_violation": r.residuals.bound_violation,
            "f": r.f,
            "w": r.w,
            "history": if args.history { Some(&r.history) } else { None },
        });
        println!(
            "{}",
            serde_json::to_string(&out).context("serialising the result")?
        );
        return Ok(());
    }
    let name = problem.name().map(|n| format!("{n}: ")).unwrap_or_default();
    println!(
        "problem     {}{} ({})",
        name,
        args.problem.display(),
        describe(&problem)
    );
    println!("solver      {}", solver.name());
    println!("status      {}", r.status);
    println!("iterations  {}", r.iterations);
    println!("time        {:.3} ms", r.time.as_secs_f64() * 1e3);
    println!(
        "residual    {:.3e} (relative {:.3e}); complementarity gap {:.3e}; bound violation {:.3e}",
        r.residuals.natural_map,
        r.residuals.natural_map_rel,
        r.residuals.complementarity_gap,
        r.residuals.bound_violation
    );
    let shown: Vec<String> = r.f.iter().take(8).map(|v| format!("{v:.6e}")).collect();
    let more = if r.f.len() > 8 { ", …" } else { "" };
    println!("f           [{}{more}]", shown.join(", "));
    if args.history {
        for h in &r.history {
            println!(
                "  iter {:>6}  t {:.3e} s  residual {:.3e}",
                h.iteration, h.time_s, h.residual
            );
        }
    }
    Ok(())
}

/// Run `lcpbench solvers`.
pub fn list_solvers() -> Result<()> {
    for kind in SolverKind::ALL {
        println!("{:<10} {}", kind.name(), kind.problem_classes());
    }
    Ok(())
}

//! `lcpbench gen`.

use anyhow::{bail, Result};
use clap::Args;
use lcpbench_solvers::generate::{generate, Family};
use lcpbench_solvers::write_problem;
use std::path::PathBuf;

/// Arguments of `lcpbench gen`.
#[derive(Args)]
pub struct GenArgs {
    /// Instance family: spd, psd (rank-deficient), pmatrix (non-symmetric), murty, infeasible.
    pub kind: String,
    /// Number of rows.
    #[arg(long, short)]
    pub n: usize,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Condition number for `spd`.
    #[arg(long, default_value_t = 1e3)]
    pub cond: f64,
    /// Rank for `psd` (default n/2).
    #[arg(long)]
    pub rank: Option<usize>,
    /// Output file.
    #[arg(long, short)]
    pub output: PathBuf,
}

/// Run `lcpbench gen`.
pub fn run(args: GenArgs) -> Result<()> {
    let Some(family) = Family::from_name(&args.kind, args.n, args.cond, args.rank) else {
        bail!(
            "unknown instance kind `{}` (known: {})",
            args.kind,
            Family::NAMES.join(", ")
        );
    };
    if args.n == 0 {
        bail!("--n must be at least 1");
    }
    if !(args.cond.is_finite() && args.cond >= 1.0) {
        bail!("--cond must be a finite number >= 1, got {}", args.cond);
    }
    if let Some(r) = args.rank {
        if r == 0 || r > args.n {
            bail!("--rank must be between 1 and n = {}, got {r}", args.n);
        }
    }
    let generated = generate(family, args.n, args.seed);
    write_problem(&generated.problem, &args.output)?;
    eprintln!(
        "wrote {} ({} rows) to {}",
        generated.problem.name().unwrap_or(&args.kind),
        args.n,
        args.output.display()
    );
    Ok(())
}

//! `lcpbench gen`.

use anyhow::{bail, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lcpbench_solvers::generate::{generate, Family, MAX_CONDITION};
use lcpbench_solvers::write_problem;
use std::path::PathBuf;
use std::time::Duration;

use crate::harness::case::MAX_GENERATED_N as MAX_N;

/// Sizes from which generation counts as long work (a warning and a spinner).
const LONG_N: usize = 1_000;

/// Size of a dense `n × n` matrix of `f64`, as `"80 MB"` or `"3.2 GB"`.
fn dense_size(n: usize) -> String {
    let bytes = (n as f64).powi(2) * 8.0;
    if bytes >= 1e9 {
        format!("{:.1} GB", bytes / 1e9)
    } else {
        format!("{:.0} MB", bytes / 1e6)
    }
}

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
    /// Condition number for `spd`, 1 to 1e12.
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
    crate::harness::outdir::check_outputs(&[], &[("--output", &args.output)])?;
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
    if !(args.cond.is_finite() && (1.0..=MAX_CONDITION).contains(&args.cond)) {
        bail!(
            "--cond must be between 1 and {MAX_CONDITION:e} (beyond it round-off in forming the \
             matrix changes its smallest eigenvalues), got {}",
            lcpbench_contact::scene::readable(args.cond)
        );
    }
    if let Some(r) = args.rank {
        if r == 0 || r > args.n {
            bail!("--rank must be between 1 and n = {}, got {r}", args.n);
        }
    }
    if args.n > MAX_N {
        bail!(
            "--n {} is beyond the limit of {MAX_N} rows (the dense matrix alone would need {}, \
             and its JSON file several times that)",
            args.n,
            dense_size(args.n)
        );
    }
    let bar = if args.n >= LONG_N {
        eprintln!(
            "generating an n = {} instance is O(n³) work and writes a {} matrix; this may take \
             minutes",
            args.n,
            dense_size(args.n)
        );
        let bar = ProgressBar::new_spinner();
        if let Ok(style) = ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}") {
            bar.set_style(style);
        }
        bar.enable_steady_tick(Duration::from_millis(200));
        bar
    } else {
        ProgressBar::hidden()
    };
    bar.set_message(format!("generating {} n = {}", args.kind, args.n));
    let generated = generate(family, args.n, args.seed);
    bar.set_message(format!("writing {}", args.output.display()));
    write_problem(&generated.problem, &args.output)?;
    bar.finish_and_clear();
    eprintln!(
        "wrote {} ({} rows) to {}",
        generated.problem.name().unwrap_or(&args.kind),
        args.n,
        args.output.display()
    );
    Ok(())
}

//! `lcpbench import`: read a problem file of any supported format (JSON, Siconos `.dat`, FCLIB
//! `.hdf5`) and write lcpbench's JSON form.

use anyhow::{bail, Result};
use clap::Args;
use lcpbench_solvers::{read_problem, write_problem};
use std::path::PathBuf;

/// Arguments of `lcpbench import`.
#[derive(Args)]
pub struct ImportArgs {
    /// Problem file: JSON, Siconos numerics LCP (`.dat`) or FCLIB (`.hdf5`).
    pub input: PathBuf,
    /// Output problem file (JSON; `A` dense or sparse, whichever is smaller).
    #[arg(long, short)]
    pub output: PathBuf,
}

/// Run `lcpbench import`.
pub fn run(args: ImportArgs) -> Result<()> {
    if args.input == args.output {
        bail!(
            "--output {} would overwrite the input file",
            args.output.display()
        );
    }
    let problem = read_problem(&args.input)?;
    write_problem(&problem, &args.output)?;
    println!(
        "wrote {}: {} rows, {} stored entries of A ({}), {} friction rows",
        args.output.display(),
        problem.n(),
        problem.nnz(),
        if problem.is_sparse() {
            "sparse"
        } else {
            "dense"
        },
        problem.friction().len()
    );
    Ok(())
}

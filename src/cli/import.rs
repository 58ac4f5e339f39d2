//! `lcpbench import`: read a problem file of any supported format (JSON, Siconos `.dat`, FCLIB
//! `.hdf5`) and write lcpbench's JSON form, or, for an output named `*.hdf5`, a local FCLIB file
//! (box-friction problems with one normal and one or two friction rows per contact).

use anyhow::{bail, Result};
use clap::Args;
use lcpbench_solvers::{read_problem, write_problem};
use std::path::PathBuf;

/// Arguments of `lcpbench import`.
#[derive(Args)]
pub struct ImportArgs {
    /// Problem file: JSON, Siconos numerics LCP (`.dat`) or FCLIB (`.hdf5`).
    pub input: PathBuf,
    /// Output problem file: JSON (`A` dense or sparse, whichever is smaller), or FCLIB when it
    /// ends in `.hdf5` or `.h5`.
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
    let ext = args
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if matches!(ext.as_deref(), Some("hdf5" | "h5")) {
        return write_fclib(&problem, &args);
    }
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

fn write_fclib(problem: &lcpbench_solvers::Problem, args: &ImportArgs) -> Result<()> {
    lcpbench_solvers::write_problem_as_fclib(problem, &args.output)?;
    println!(
        "wrote {}: {} rows as a local FCLIB problem ({} friction rows)",
        args.output.display(),
        problem.n(),
        problem.friction().len()
    );
    Ok(())
}

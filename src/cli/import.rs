//! `lcpbench import`: read a problem file of any supported format (JSON, Siconos `.dat`, FCLIB
//! `.hdf5`) and write lcpbench's JSON form, or, for an output named `*.hdf5`, a local FCLIB file
//! (box-friction problems with one normal and one or two friction rows per contact).

use crate::harness::budget;
use crate::harness::outdir::check_outputs;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use lcpbench_solvers::{read_problem, write_problem, Problem};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

/// Arguments of `lcpbench import`.
#[derive(Args)]
pub struct ImportArgs {
    /// Problem file: JSON, Siconos numerics LCP (`.dat`) or FCLIB (`.hdf5`).
    pub input: PathBuf,
    /// Output problem file: JSON (`A` dense or sparse, whichever is smaller), or FCLIB when it
    /// ends in `.hdf5` or `.h5`.
    #[arg(long, short)]
    pub output: PathBuf,
    /// Wall-time budget of reading the input, seconds: past it import stops with an error and
    /// writes nothing (none by default).
    #[arg(long)]
    pub time_budget: Option<f64>,
}

/// Run `lcpbench import`.
pub fn run(args: ImportArgs) -> Result<()> {
    check_outputs(&[("the input", &args.input)], &[("--output", &args.output)])?;
    let budget = match args.time_budget {
        Some(t) => Some(budget::time_budget(t).map_err(|m| anyhow!("--time-budget: {m}"))?),
        None => None,
    };
    let problem = read_within(&args.input, budget)?;
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

/// Read the problem file `path`, on a worker thread when there is a `budget`: past it the
/// command ends with an error (the process exits, and the unfinished read with it).
fn read_within(path: &Path, budget: Option<Duration>) -> Result<Problem> {
    let Some(budget) = budget else {
        return Ok(read_problem(path)?);
    };
    let (tx, rx) = mpsc::channel();
    let input = path.to_owned();
    let start = std::time::Instant::now();
    std::thread::Builder::new()
        .name("import-read".into())
        .spawn(move || {
            let _ = tx.send(read_problem(&input));
        })
        .context("starting the reader thread")?;
    // A read that ends after the budget is refused like one still running: which of the two
    // the waiting thread sees first depends on the scheduler.
    match rx.recv_timeout(budget) {
        Ok(read) if start.elapsed() <= budget => Ok(read?),
        Ok(_) | Err(mpsc::RecvTimeoutError::Timeout) => bail!(
            "{}: reading it took longer than the time budget of {} s (--time-budget); nothing \
             was written",
            path.display(),
            budget.as_secs_f64()
        ),
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            bail!("{}: the reader stopped without a result", path.display())
        }
    }
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

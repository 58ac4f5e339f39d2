//! The hidden `lcpbench bench-one`: one isolated run in a child process of a sweep, its row
//! printed in the child protocol.

use crate::harness::isolate::{mark_child, write_protocol};
use crate::harness::run::run_in_process;
use crate::harness::{BudgetName, Case, Fault, NamedBudget, SolverSpec};
use anyhow::{Context, Result};
use clap::Args;

/// Arguments of the hidden `lcpbench bench-one` (one isolated run; prints the child protocol).
#[derive(Args)]
pub struct BenchOneArgs {
    /// Case key.
    #[arg(long)]
    pub case: Case,
    /// Solver specification.
    #[arg(long)]
    pub solver: SolverSpec,
    /// Budget as TOL:ITER:SECONDS or a preset name.
    #[arg(long)]
    pub budget: NamedBudget,
    /// Name of the budget written to the row.
    #[arg(long)]
    pub budget_name: Option<BudgetName>,
    /// Inject a fault instead of running (panic, hang, abort); for testing the isolation.
    #[arg(long)]
    pub fault: Option<String>,
}

/// Run `lcpbench bench-one` (the child side of the isolation).
pub fn run(args: BenchOneArgs) -> Result<()> {
    mark_child();
    if let Some(fault) = &args.fault {
        let fault = Fault::from_name(fault)
            .with_context(|| format!("--fault must be panic, hang or abort, got `{fault}`"))?;
        fault.trigger();
    }
    let mut budget = args.budget;
    if let Some(name) = args.budget_name {
        budget.name = name;
    }
    let output = run_in_process(&args.case, &args.solver, &budget);
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    write_protocol(&mut lock, &output).context("writing the run's row")?;
    Ok(())
}

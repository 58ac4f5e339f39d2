//! `lcpbench bench` and `lcpbench report`.

use anyhow::{bail, Result};
use clap::Args;

/// Arguments of `lcpbench bench`.
#[derive(Args)]
pub struct BenchArgs {}

/// Arguments of `lcpbench report`.
#[derive(Args)]
pub struct ReportArgs {}

pub fn run_bench(_args: BenchArgs) -> Result<()> {
    bail!("bench is not available yet")
}

pub fn run_report(_args: ReportArgs) -> Result<()> {
    bail!("report is not available yet")
}

//! `lcpbench simulate` and `lcpbench export`.

use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `lcpbench simulate`.
#[derive(Args)]
pub struct SimulateArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
}

/// Arguments of `lcpbench export`.
#[derive(Args)]
pub struct ExportArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
}

pub fn run_simulate(_args: SimulateArgs) -> Result<()> {
    bail!("simulate is not available yet")
}

pub fn run_export(_args: ExportArgs) -> Result<()> {
    bail!("export is not available yet")
}

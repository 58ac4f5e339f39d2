//! `lcpbench merge`: join the directories of a sharded sweep into one.

use crate::harness::merge::merge;
use crate::harness::shard::SweepKind;
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `lcpbench merge`.
#[derive(Args)]
pub struct MergeArgs {
    /// The shard directories (written by `bench --shard K/N` or `report --shard K/N`): every
    /// shard of one sweep, once.
    #[arg(required = true, value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
    /// Output directory, new or empty: `results.csv` and `histories.csv` (under `data/`, with the
    /// exported LCPs under `lcps/`, for a report sweep) and `merged.json`.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `lcpbench merge`.
pub fn run(args: MergeArgs) -> Result<()> {
    let inputs: Vec<(&str, &std::path::Path)> = args
        .dirs
        .iter()
        .map(|d| ("the shard directory", d.as_path()))
        .collect();
    crate::harness::outdir::check_outputs(&inputs, &[("--out", &args.out)])?;
    let summary = merge(&args.dirs, &args.out)?;
    let m = &summary.manifest;
    let mut line = format!(
        "merged {} shards of {} sweep {} (commit {}): {} rows",
        m.shards, m.kind, m.sweep, m.commit, summary.rows
    );
    if summary.identical_duplicates > 0 {
        line.push_str(&format!(
            " ({} identical copies dropped)",
            summary.identical_duplicates
        ));
    }
    line.push_str(&format!(", {} history rows", summary.histories));
    if m.kind != SweepKind::Bench {
        line.push_str(&format!(", {} exported LCPs", summary.exports));
    }
    eprintln!("{line} → {}", args.out.display());
    if m.kind != SweepKind::Bench {
        let quick = if m.kind == SweepKind::ReportQuick {
            " --quick"
        } else {
            ""
        };
        eprintln!(
            "write the report with: lcpbench report --no-run{quick} --out {}",
            args.out.display()
        );
    }
    Ok(())
}

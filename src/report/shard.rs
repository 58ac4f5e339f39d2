//! `lcpbench report --shard K/N`: one part of the default suite, in a directory laid out as the
//! report's (`data/results.csv`, `data/histories.csv`, `lcps/`) with `shard.json` at its top.
//! No README is written: `lcpbench merge` joins the parts and `lcpbench report --no-run` writes
//! the report from the merged rows.

use super::{machine, suite, ReportOptions};
use crate::harness::shard::{claim, ShardManifest, ShardPlan, SweepKind, MANIFEST};
use crate::harness::sweep::{lock_dir, run_sweep_locked};
use crate::harness::SweepSummary;
use anyhow::{Context, Result};
use std::time::Instant;

pub use crate::harness::shard::Shard;

/// What a shard of the report did.
#[derive(Debug, Clone)]
pub struct ShardSummary {
    /// Its manifest (what `shard.json` says).
    pub manifest: ShardManifest,
    /// The sweep of its runs.
    pub sweep: SweepSummary,
    /// Seconds its runs took.
    pub sweep_seconds: f64,
}

/// Run shard `shard` of the default suite into `options.out_dir`: without `options.resume` the
/// directory's earlier rows and manifest are removed first (as `report` starts fresh); with it,
/// a directory holding another shard or sweep is refused.
pub fn run_shard(options: &ReportOptions, shard: Shard) -> Result<ShardSummary> {
    let data = options.out_dir.join("data");
    let lock = lock_dir(&data)?;
    if !options.resume {
        for p in [
            data.join("results.csv"),
            data.join("histories.csv"),
            options.out_dir.join(MANIFEST),
        ] {
            if p.exists() {
                std::fs::remove_file(&p).with_context(|| format!("removing {}", p.display()))?;
            }
        }
    }
    let suite = suite::default_suite(options.quick, &options.scenes, &options.exported);
    let plan = ShardPlan::new(
        SweepKind::report(options.quick),
        suite.jobs,
        &options.out_dir,
    );
    let manifest = plan.manifest(shard, &machine::commit(&options.out_dir));
    claim(&options.out_dir, &data, &manifest)?;
    let mut config = options.sweep.clone();
    config.out_dir = data;
    config.keep_histories = true;
    let start = Instant::now();
    let sweep = run_sweep_locked(&config, plan.jobs(shard), &lock)?;
    Ok(ShardSummary {
        manifest,
        sweep,
        sweep_seconds: start.elapsed().as_secs_f64(),
    })
}

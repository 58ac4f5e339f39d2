//! `lcpbench report`: run the default suite (or one shard of it) and write the comparison
//! report, or rewrite the report from existing rows.

use crate::harness::merge::{self, MergedManifest};
use crate::harness::outdir::{table_origin, TableOrigin};
use crate::harness::shard::{self, Shard, SweepKind};
use crate::harness::sweep::check_jobs;
use crate::harness::SweepConfig;
use crate::report::{self, suite};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

/// Arguments of `lcpbench report`.
#[derive(Args)]
pub struct ReportArgs {
    /// Output directory [default: `reports`; with `--from DIR`, `DIR/report`].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the report of a sweep `lcpbench bench` wrote into DIR (its `results.csv`, and
    /// `histories.csv` when present), from any working directory, without runs: Findings, the
    /// results per case, their figures and profiles, about the cases of those rows only.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["quick", "scenes", "resume", "no_run", "shard"])]
    pub from: Option<PathBuf>,
    /// Run a much smaller suite with every section (under a minute on two cores, instead of
    /// about 35 minutes).
    #[arg(long)]
    pub quick: bool,
    /// Scene files of the suite (glob) [default: bench_scenes/*.toml, which must match]; a
    /// pattern given here may match nothing, for a report on generated LCPs alone.
    #[arg(long)]
    pub scenes: Option<String>,
    /// Keep the rows of an interrupted earlier run instead of starting fresh.
    #[arg(long)]
    pub resume: bool,
    /// Only rewrite tables and figures from the existing data in `--out` (no runs); the exported
    /// LCPs in `--out`/lcps keep the names the data records them under, so a copy of a report's
    /// directory rebuilds the same tables.
    #[arg(long)]
    pub no_run: bool,
    /// Worker threads (each drives one child process): 1 to 4 per core of the machine.
    #[arg(long, default_value_t = 2)]
    pub jobs: usize,
    /// Do not draw a progress bar.
    #[arg(long)]
    pub no_progress: bool,
    /// Run only the K-th of N parts of the suite (1 <= K <= N) into `--out`, without writing
    /// the report: `lcpbench merge` joins the parts' directories, `report --no-run` then writes
    /// the report from the merged rows (see docs/cluster.md).
    #[arg(long, value_name = "K/N", conflicts_with = "no_run")]
    pub shard: Option<Shard>,
}

/// The report's scene files when `--scenes` is not given (relative to the working directory).
const DEFAULT_SCENES: &str = "bench_scenes/*.toml";

/// The default output directory of the suite's report.
const DEFAULT_OUT: &str = "reports";

/// Run `lcpbench report`.
pub fn run(args: ReportArgs) -> Result<()> {
    if let Some(from) = &args.from {
        return report_from(from, args.out.as_deref());
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(DEFAULT_OUT));
    refuse_report_links(&out)?;
    check_jobs(args.jobs).map_err(|m| anyhow!("--jobs {m}"))?;
    let pattern = args.scenes.as_deref().unwrap_or(DEFAULT_SCENES);
    let scenes = report::scenes_matching(pattern)?;
    if scenes.is_empty() {
        if args.scenes.is_none() {
            bail!(
                "no scene file matches `{DEFAULT_SCENES}` from {}: the report's suite is made of \
                 the scenes and of the FCLIB problems in `fclib/` beside them; run lcpbench from \
                 its checkout, or pass --scenes 'DIR/bench_scenes/*.toml'",
                std::env::current_dir()
                    .map(|d| d.display().to_string())
                    .unwrap_or_else(|_| "this directory".into())
            );
        }
        eprintln!(
            "--scenes `{pattern}` matches no scene file: the report covers generated LCPs only"
        );
    }
    report::check_output_dir(&out)?;
    let merged = check_report_dir(&args, &out)?;
    let lcp_dir = out.join("lcps");
    let exported = if args.no_run {
        // Tables from existing data: the LCPs exported by the run that produced it.
        report::recorded_exports(&out)?
    } else {
        remove_exported_lcps(&lcp_dir)?;
        // Sorted by path, the order `--no-run` lists them in.
        let mut exported = crate::harness::export::export_suite_lcps(
            &suite::suite_scenes(args.quick, &scenes),
            &lcp_dir,
            if args.quick { 60 } else { 400 },
            suite::LARGE_SCENE_BODIES,
        )?;
        exported.sort();
        exported
    };
    let mut sweep = SweepConfig::new(out.join("data"))?;
    sweep.jobs = args.jobs;
    sweep.progress = !args.no_progress;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let options = report::ReportOptions {
        out_dir: out.clone(),
        quick: args.quick,
        resume: args.resume,
        scenes,
        exported,
        sweep,
        command,
    };
    if let Some(shard) = args.shard {
        let summary = report::shard::run_shard(&options, shard)?;
        eprintln!(
            "shard {shard} of sweep {}: ran {} runs in {:.0} s ({} isolation failures), skipped \
             {} already done; merge the shards with `lcpbench merge DIR... --out DIR`",
            summary.manifest.sweep,
            summary.sweep.ran,
            summary.sweep_seconds,
            summary.sweep.failed,
            summary.sweep.skipped,
        );
        return Ok(());
    }
    if args.no_run {
        let suite = suite::default_suite(options.quick, &options.scenes, &options.exported);
        let mut header =
            report::Header::collect(&options.command, options.sweep.jobs, &options.out_dir);
        if let Some(merged) = merged {
            // The rows' commit, not the one rewriting the tables.
            header.commit = merged.commit;
        }
        let readme = report::write_report(&options.out_dir, &suite, &header, 0.0)?;
        eprintln!("wrote {}", readme.display());
        return Ok(());
    }
    let summary = report::run(&options)?;
    eprintln!(
        "ran {} runs in {:.0} s ({} isolation failures); wrote {}",
        summary.sweep.ran,
        summary.sweep_seconds,
        summary.sweep.failed,
        summary.readme.display()
    );
    Ok(())
}

/// Check that `report`'s output directory suits what it is asked to do: a shard's directory is
/// only resumed by the same `--shard`, and `--no-run` on a merged directory needs the suite its
/// shards ran (`--quick` or not). Returns the merged directory's manifest, if it has one.
fn check_report_dir(args: &ReportArgs, out: &Path) -> Result<Option<MergedManifest>> {
    if args.shard.is_none() {
        if let Some(m) = shard::read_manifest(out)? {
            bail!(
                "{} holds {} only; merge every shard with `lcpbench merge DIR... --out DIR` and \
                 write the report from that directory{}",
                out.display(),
                m.describe(),
                if args.no_run {
                    ""
                } else {
                    ", or give this run another output directory"
                }
            );
        }
    }
    let merged = merge::read_merged(out)?;
    if let Some(m) = &merged {
        if !args.no_run {
            bail!(
                "{} holds rows merged from shards; write their report with --no-run, or give \
                 this run another output directory",
                out.display()
            );
        }
        let suite = SweepKind::report(args.quick);
        if m.kind != suite {
            bail!(
                "{} holds the rows of a {} sweep; {}",
                out.display(),
                m.kind,
                match m.kind {
                    SweepKind::ReportQuick => "add --quick",
                    SweepKind::ReportFull => "drop --quick",
                    SweepKind::Bench => "the report is written from report sweeps",
                }
            );
        }
    }
    Ok(merged)
}

/// Remove the problems an earlier report exported into `dir` (`SCENE_stepK.json`), and
/// nothing else there: the directory may hold files lcpbench did not write.
fn remove_exported_lcps(dir: &std::path::Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let exported = name
            .strip_suffix(".json")
            .and_then(|stem| stem.rsplit_once("_step"))
            .is_some_and(|(_, k)| !k.is_empty() && k.bytes().all(|c| c.is_ascii_digit()));
        let regular = entry.file_type().is_ok_and(|t| t.is_file());
        if exported && regular {
            std::fs::remove_file(entry.path())
                .with_context(|| format!("removing {}", entry.path().display()))?;
        }
    }
    Ok(())
}

/// `report --from DIR`: the report of the sweep in `DIR` into `out` (default `DIR/report`).
/// Refuses a `DIR` without lcpbench's `results.csv`, and an output directory holding files
/// lcpbench did not write ([`report::check_output_dir`]).
fn report_from(from: &Path, out: Option<&Path>) -> Result<()> {
    let results = from.join("results.csv");
    if !results.is_file() {
        bail!(
            "--from {}: no results.csv there; give the directory `lcpbench bench --out DIR` \
             wrote",
            from.display()
        );
    }
    let columns = crate::harness::sweep::result_columns();
    if let TableOrigin::Foreign { header } = table_origin(&results, &columns)? {
        bail!(
            "--from {}: {} is not a table lcpbench wrote (its header starts `{}`)",
            from.display(),
            results.display(),
            header.chars().take(80).collect::<String>()
        );
    }
    let out = out.map_or_else(|| from.join("report"), Path::to_path_buf);
    refuse_report_links(&out)?;
    report::check_output_dir(&out)?;
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let header = report::Header::collect(&command, 1, &out);
    let readme = report::write_report_from(from, &out, &header)?;
    eprintln!("wrote {}", readme.display());
    Ok(())
}

/// A report writes its own files under these subdirectories of its output; a link there would
/// send them elsewhere.
fn refuse_report_links(out: &Path) -> Result<()> {
    crate::harness::outdir::refuse_linked_dirs(out, &["data", "tables", "plots", "replays", "lcps"])
}

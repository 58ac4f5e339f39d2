//! `lcpbench bench`, `lcpbench report` and the hidden `lcpbench bench-one` that runs one
//! isolated run in a child process.

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use lcpbench::harness::isolate::write_protocol;
use lcpbench::harness::merge::{self, MergedManifest};
use lcpbench::harness::run::run_in_process;
use lcpbench::harness::shard::{self, Shard, ShardPlan, SweepKind};
use lcpbench::harness::sweep::{check_jobs, lock_dir, run_sweep_locked};
use lcpbench::harness::Fault;
use lcpbench::harness::{cross_product, Case, Job, NamedBudget, SolverSpec, SweepConfig};
use lcpbench::report::{self, suite};
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::FrictionModel;
use lcpbench_solvers::{ConeSolverKind, SolverKind};
use std::path::PathBuf;

/// Arguments of `lcpbench bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Scene files to run (glob, e.g. `bench_scenes/tower_*.toml`).
    #[arg(long)]
    pub scenes: Option<String>,
    /// LCP cases, comma-separated case keys (`spd:n=100:cond=1e4:seed=1`, `file:PATH`, …) or
    /// `matrix` for the generated families of the report. Default: `matrix` when no `--scenes`.
    #[arg(long, value_delimiter = ',')]
    pub lcps: Vec<String>,
    /// Friction models the `--scenes` run under, comma-separated (none, box, pyramid,
    /// pyramid-K, cone): one case per scene and model (`scene:PATH?friction=MODEL`). Default:
    /// each scene's own. A solver that does not take a model is recorded `unsupported`.
    #[arg(long, value_delimiter = ',')]
    pub friction_models: Vec<String>,
    /// Solvers, comma-separated: names (`pgs`, `lemke`, …, for scenes `si`, `body-micro`,
    /// `penalty`, and the cone solvers `nsgs-cone`, `newton-ac`), `sor@OMEGA`, `NAME+warm`,
    /// `all` (the matrix solvers), `body` (the body-level ones) or `cone` (the cone solvers).
    #[arg(long, value_delimiter = ',', default_value = "all")]
    pub solvers: Vec<String>,
    /// Budgets, comma-separated: presets (loose 1e-4:1000:1, default 1e-8:10000:1, tight
    /// 1e-10:100000:10, realtime 1e-6:20:1) or TOL:ITER:SECONDS. ITER and SECONDS bound each
    /// solve of an LCP case and each step's solve of a scene: a step that runs out of time ends
    /// `time_limit` with the solver's best point and the run goes on; a scene run stops at twice
    /// its steps times SECONDS, or after three consecutive steps over SECONDS, and its row says
    /// how many steps it took (`steps`, `steps_planned`).
    #[arg(long, value_delimiter = ',', default_value = "default")]
    pub budgets: Vec<String>,
    /// Output directory (results.csv, histories.csv). An existing results.csv is resumed.
    #[arg(long, default_value = "bench-out")]
    pub out: PathBuf,
    /// Worker threads (each drives one child process): 1 to 4 per core of the machine.
    #[arg(long, default_value_t = 2)]
    pub jobs: usize,
    /// Do not draw a progress bar.
    #[arg(long)]
    pub no_progress: bool,
    /// Run only the K-th of N parts of the sweep (1 <= K <= N): the same parts whatever runs
    /// them, balanced by expected cost. `--out` then records the part in `shard.json`;
    /// `lcpbench merge` joins the parts' directories (see docs/cluster.md).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
}

/// Arguments of `lcpbench report`.
#[derive(Args)]
pub struct ReportArgs {
    /// Output directory.
    #[arg(long, default_value = "reports")]
    pub out: PathBuf,
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

/// Arguments of the hidden `lcpbench bench-one` (one isolated run; prints the child protocol).
#[derive(Args)]
pub struct BenchOneArgs {
    /// Case key.
    #[arg(long)]
    pub case: String,
    /// Solver specification.
    #[arg(long)]
    pub solver: String,
    /// Budget as TOL:ITER:SECONDS or a preset name.
    #[arg(long)]
    pub budget: String,
    /// Name of the budget written to the row.
    #[arg(long)]
    pub budget_name: Option<String>,
    /// Inject a fault instead of running (panic, hang, abort); for testing the isolation.
    #[arg(long)]
    pub fault: Option<String>,
}

fn parse_solvers(list: &[String]) -> Result<Vec<SolverSpec>> {
    let mut out = Vec::new();
    for s in list {
        if s == "all" {
            out.extend(SolverKind::ALL.into_iter().map(SolverSpec::plain));
        } else if s == "body" {
            out.extend(BodySolverKind::ALL.into_iter().map(SolverSpec::body));
        } else if s == "cone" {
            out.extend(ConeSolverKind::ALL.into_iter().map(SolverSpec::cone));
        } else {
            out.push(s.parse()?);
        }
    }
    Ok(out)
}

fn parse_budgets(list: &[String]) -> Result<Vec<NamedBudget>> {
    list.iter()
        .map(|b| b.parse().map_err(anyhow::Error::from))
        .collect()
}

/// Run `lcpbench bench`.
pub fn run_bench(args: BenchArgs) -> Result<()> {
    check_jobs(args.jobs).map_err(|m| anyhow!("--jobs {m}"))?;
    let solvers = parse_solvers(&args.solvers)?;
    let budgets = parse_budgets(&args.budgets)?;
    let mut cases: Vec<Case> = Vec::new();
    let lcps = if args.lcps.is_empty() && args.scenes.is_none() {
        vec!["matrix".to_owned()]
    } else {
        args.lcps.clone()
    };
    for key in &lcps {
        if key == "matrix" {
            cases.extend(suite::default_suite(false, &[], &[]).matrix_cases);
        } else {
            cases.push(key.parse()?);
        }
    }
    if let Some(pattern) = &args.scenes {
        let scenes = report::scenes_matching(pattern)?;
        if scenes.is_empty() {
            bail!("--scenes `{pattern}` matches no files");
        }
        let models = args
            .friction_models
            .iter()
            .map(|m| {
                FrictionModel::from_name(m).with_context(|| {
                    format!(
                        "--friction-models: unknown model `{m}` (known: {})",
                        FrictionModel::NAMES
                    )
                })
            })
            .collect::<Result<Vec<_>>>()?;
        for p in scenes {
            if models.is_empty() {
                cases.push(Case::scene(p, None));
            } else {
                cases.extend(
                    models
                        .iter()
                        .map(|m| Case::scene_with_friction(&p, None, *m)),
                );
            }
        }
    } else if !args.friction_models.is_empty() {
        bail!("--friction-models applies to --scenes");
    }
    if cases.is_empty() || solvers.is_empty() || budgets.is_empty() {
        bail!("nothing to run: need at least one case, solver and budget");
    }
    let cases = once_each("case", cases);
    let solvers = once_each("solver", solvers);
    let budgets = once_each("budget", budgets);
    let jobs = cross_product(&cases, &solvers, &budgets);
    let mut config = SweepConfig::new(&args.out)?;
    config.jobs = args.jobs;
    config.progress = !args.no_progress;
    let lock = lock_dir(&args.out)?;
    let jobs = match args.shard {
        Some(shard) => bench_shard(shard, jobs, &config)?,
        None => {
            shard::refuse_shard_directory(&args.out)?;
            eprintln!(
                "{} runs ({} cases × {} solvers × {} budgets) → {}",
                jobs.len(),
                cases.len(),
                solvers.len(),
                budgets.len(),
                config.results_path().display()
            );
            jobs
        }
    };
    let summary = run_sweep_locked(&config, jobs, &lock)?;
    report_summary(&summary, &config);
    Ok(())
}

/// The jobs of `shard` of the sweep of `jobs`, after claiming the output directory for it
/// (`shard.json`; the caller holds the directory's lock).
fn bench_shard(shard: Shard, jobs: Vec<Job>, config: &SweepConfig) -> Result<Vec<Job>> {
    let out = &config.out_dir;
    let plan = ShardPlan::new(SweepKind::Bench, jobs, out);
    let manifest = plan.manifest(shard, &report::machine::commit(out));
    shard::claim(out, out, &manifest)?;
    eprintln!(
        "shard {shard} of sweep {}: {} of {} runs (expected {:.2} s under the cost model) → {}",
        manifest.sweep,
        manifest.keys.len(),
        plan.len(),
        manifest.expected_s,
        config.results_path().display()
    );
    Ok(plan.jobs(shard))
}

/// Drop repeated entries of a list (by their key text), saying which were listed twice.
fn once_each<T: std::fmt::Display>(what: &str, items: Vec<T>) -> Vec<T> {
    let mut seen = std::collections::HashMap::new();
    let mut out = Vec::new();
    for item in items {
        let key = item.to_string();
        let count = seen.entry(key.clone()).or_insert(0usize);
        *count += 1;
        if *count == 2 {
            eprintln!("{what} {key} listed more than once, running it once");
        }
        if *count == 1 {
            out.push(item);
        }
    }
    out
}

/// Print what a sweep did, one clause per thing that happened.
fn report_summary(summary: &lcpbench::harness::SweepSummary, config: &SweepConfig) {
    let results = config.results_path();
    if summary.stale_runners > 0 {
        eprintln!(
            "removed {} executable copies left by an interrupted sweep in {}",
            summary.stale_runners,
            config.out_dir.display()
        );
    }
    if summary.dropped_rows > 0 {
        eprintln!(
            "dropped {} rows of {} that were torn or repeated; their runs were done again",
            summary.dropped_rows,
            results.display()
        );
    }
    let mut line = format!(
        "ran {}, skipped {} already in {}",
        summary.ran,
        summary.skipped,
        results.display()
    );
    if summary.duplicates > 0 {
        line.push_str(&format!(", {} repeated runs run once", summary.duplicates));
    }
    line.push_str(&format!(", {} isolation failures", summary.failed));
    eprintln!("{line}");
}

/// The report's scene files when `--scenes` is not given (relative to the working directory).
const DEFAULT_SCENES: &str = "bench_scenes/*.toml";

/// Run `lcpbench report`.
pub fn run_report(args: ReportArgs) -> Result<()> {
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
    report::check_output_dir(&args.out)?;
    let merged = check_report_dir(&args)?;
    let lcp_dir = args.out.join("lcps");
    let exported = if args.no_run {
        // Tables from existing data: the LCPs exported by the run that produced it.
        report::recorded_exports(&args.out)?
    } else {
        remove_exported_lcps(&lcp_dir)?;
        // Sorted by path, the order `--no-run` lists them in.
        let mut exported = lcpbench::harness::export::export_suite_lcps(
            &suite::suite_scenes(args.quick, &scenes),
            &lcp_dir,
            if args.quick { 60 } else { 400 },
            suite::LARGE_SCENE_BODIES,
        )?;
        exported.sort();
        exported
    };
    let mut sweep = SweepConfig::new(args.out.join("data"))?;
    sweep.jobs = args.jobs;
    sweep.progress = !args.no_progress;
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let options = report::ReportOptions {
        out_dir: args.out.clone(),
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
fn check_report_dir(args: &ReportArgs) -> Result<Option<MergedManifest>> {
    if args.shard.is_none() {
        if let Some(m) = shard::read_manifest(&args.out)? {
            bail!(
                "{} holds {} only; merge every shard with `lcpbench merge DIR... --out DIR` and \
                 write the report from that directory{}",
                args.out.display(),
                m.describe(),
                if args.no_run {
                    ""
                } else {
                    ", or give this run another output directory"
                }
            );
        }
    }
    let merged = merge::read_merged(&args.out)?;
    if let Some(m) = &merged {
        if !args.no_run {
            bail!(
                "{} holds rows merged from shards; write their report with --no-run, or give \
                 this run another output directory",
                args.out.display()
            );
        }
        let suite = SweepKind::report(args.quick);
        if m.kind != suite {
            bail!(
                "{} holds the rows of a {} sweep; {}",
                args.out.display(),
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

/// Run `lcpbench bench-one` (the child side of the isolation).
pub fn run_bench_one(args: BenchOneArgs) -> Result<()> {
    if let Some(fault) = &args.fault {
        let fault = Fault::from_name(fault)
            .with_context(|| format!("--fault must be panic, hang or abort, got `{fault}`"))?;
        fault.trigger();
    }
    let case: Case = args.case.parse()?;
    let solver: SolverSpec = args.solver.parse()?;
    let mut budget: NamedBudget = args.budget.parse()?;
    if let Some(name) = args.budget_name {
        budget.name = name.parse()?;
    }
    let output = run_in_process(&case, &solver, &budget);
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    write_protocol(&mut lock, &output).context("writing the run's row")?;
    Ok(())
}

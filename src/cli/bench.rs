//! `lcpbench bench`, `lcpbench report` and the hidden `lcpbench bench-one` that runs one
//! isolated run in a child process.

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use lcpbench::harness::budget::Fault;
use lcpbench::harness::isolate::write_protocol;
use lcpbench::harness::run::run_in_process;
use lcpbench::harness::sweep::check_jobs;
use lcpbench::harness::{cross_product, run_sweep, Case, NamedBudget, SolverSpec, SweepConfig};
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
}

/// Arguments of `lcpbench report`.
#[derive(Args)]
pub struct ReportArgs {
    /// Output directory.
    #[arg(long, default_value = "reports")]
    pub out: PathBuf,
    /// Run a much smaller suite with every section (under a minute on two cores, instead of
    /// about half an hour).
    #[arg(long)]
    pub quick: bool,
    /// Scene files of the suite (glob).
    #[arg(long, default_value = "bench_scenes/*.toml")]
    pub scenes: String,
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
    eprintln!(
        "{} runs ({} cases × {} solvers × {} budgets) → {}",
        jobs.len(),
        cases.len(),
        solvers.len(),
        budgets.len(),
        config.results_path().display()
    );
    let summary = run_sweep(&config, jobs)?;
    report_summary(&summary, &config);
    Ok(())
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

/// Run `lcpbench report`.
pub fn run_report(args: ReportArgs) -> Result<()> {
    check_jobs(args.jobs).map_err(|m| anyhow!("--jobs {m}"))?;
    let scenes = report::scenes_matching(&args.scenes)?;
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
    if args.no_run {
        let suite = suite::default_suite(options.quick, &options.scenes, &options.exported);
        let header =
            report::Header::collect(&options.command, options.sweep.jobs, &options.out_dir);
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
        budget.name = name;
    }
    let output = run_in_process(&case, &solver, &budget);
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    write_protocol(&mut lock, &output).context("writing the run's row")?;
    Ok(())
}

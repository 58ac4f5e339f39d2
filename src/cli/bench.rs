//! `lcpbench bench`: run solvers × cases × budgets and write result rows as they finish.

use crate::harness::shard::{self, Shard, ShardPlan, SweepKind};
use crate::harness::sweep::{check_jobs, lock_dir, run_sweep_locked};
use crate::harness::{cross_product, Case, Job, NamedBudget, SolverSpec, SweepConfig};
use crate::report::{self, suite};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::step::ResidualSchedule;
use lcpbench_contact::FrictionModel;
use lcpbench_solvers::{ConeSolverKind, SolverKind};
use std::path::PathBuf;

/// Arguments of `lcpbench bench`. The help ends with how solves are timed and where warm
/// starts come from ([`crate::harness::timing::HELP`]).
#[derive(Args)]
#[command(after_help = crate::harness::timing::HELP)]
pub struct BenchArgs {
    /// Scene files to run (glob, e.g. `bench_scenes/tower_*.toml`).
    #[arg(long)]
    pub scenes: Option<String>,
    /// LCP cases, comma-separated case keys (`spd:n=100:cond=1e4:seed=1`, `file:PATH`,
    /// `step:SCENE?step=K` for the LCP a scene's stepper assembles at step K, …) or `matrix` for
    /// the generated families of the report. Default: `matrix` when no `--scenes`. Cone solvers
    /// take a friction LCP's cone form.
    #[arg(long, value_delimiter = ',')]
    pub lcps: Vec<String>,
    /// Friction models the `--scenes` run under, comma-separated (none, box, pyramid,
    /// pyramid-K, cone): one case per scene and model (`scene:PATH?friction=MODEL`). Default:
    /// each scene's own. A solver that does not take a model is recorded `unsupported`.
    #[arg(long, value_delimiter = ',')]
    pub friction_models: Vec<String>,
    /// Which steps of the scene runs (`--scenes`, and `scene:` keys of `--lcps`) have the
    /// shared residual measured: `every`, `none` or `sample=K` (steps 0, K, 2K, … and the
    /// last; `scene:PATH?residual=SCHEDULE`). Default: each scene's own (`every` unless its
    /// file says otherwise). An unmeasured step is never counted converged; the row's
    /// `steps_measured` says how many were measured. Off the schedule a matrix or cone solver
    /// measures only what its own stopping rule needs.
    #[arg(long, value_name = "every|none|sample=K")]
    pub residual: Option<String>,
    /// Solvers, comma-separated: names (listed below from the solver table; the body-level
    /// ones for scenes only), `NAME@key=value,…` (parameters, `lcpbench solvers` lists them),
    /// `NAME+warm`, `all` (the matrix solvers), `body` (the body-level ones) or `cone` (the cone
    /// solvers).
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

/// The solver specifications of `--solvers`: the list split at commas, with a piece `key=value`
/// (no `@`) that follows a piece with parameters joined back to it, so that
/// `soft-step@substeps=8,hertz=60` is one solver.
fn parse_solvers(list: &[String]) -> Result<Vec<SolverSpec>> {
    let mut joined: Vec<String> = Vec::new();
    for s in list {
        match joined.last_mut() {
            Some(prev)
                if prev.contains('@')
                    && !prev.ends_with("+warm")
                    && s.contains('=')
                    && !s.contains('@') =>
            {
                prev.push(',');
                prev.push_str(s);
            }
            _ => joined.push(s.clone()),
        }
    }
    let mut out = Vec::new();
    for s in &joined {
        if s == "all" {
            out.extend(SolverKind::all().into_iter().map(SolverSpec::plain));
        } else if s == "body" {
            out.extend(BodySolverKind::all().into_iter().map(SolverSpec::body));
        } else if s == "cone" {
            out.extend(ConeSolverKind::all().into_iter().map(SolverSpec::cone));
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
pub fn run(args: BenchArgs) -> Result<()> {
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
    if let Some(text) = &args.residual {
        if !cases.iter().any(Case::is_scene) {
            bail!("--residual applies to scene cases (--scenes, or scene: keys of --lcps)");
        }
        let schedule: ResidualSchedule = text.parse().map_err(|m| anyhow!("--residual: {m}"))?;
        cases = cases
            .into_iter()
            .map(|c| {
                if c.is_scene() {
                    c.with_residual(schedule)
                } else {
                    c
                }
            })
            .collect();
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
    drop(lock);
    report_summary(&summary, &config);
    print_solver_summary(&config);
    Ok(())
}

/// Print the sweep's per-solver summary to stdout (every row of its results table, those of
/// earlier runs resumed included), and how to write its report.
fn print_solver_summary(config: &SweepConfig) {
    let results = config.results_path();
    match crate::harness::sweep::read_results(&results) {
        Ok(rows) => {
            let text = report::summary::sweep_summary(&rows);
            if !text.is_empty() {
                print!("{text}");
                println!(
                    "report: lcpbench report --from {}",
                    config.out_dir.display()
                );
            }
        }
        Err(e) => eprintln!("no summary: reading {}: {e:#}", results.display()),
    }
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
fn report_summary(summary: &crate::harness::SweepSummary, config: &SweepConfig) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `--solvers` splits at commas; a `key=value` piece after a solver with parameters
    /// belongs to it, and the level words expand to every solver of the registry at that level.
    #[test]
    fn solver_lists_keep_parameter_lists_whole() {
        let list: Vec<String> = [
            "soft-step@substeps=8",
            "hertz=60+warm",
            "pgs",
            "sor@omega=1.5",
        ]
        .map(String::from)
        .to_vec();
        let specs = parse_solvers(&list).unwrap();
        let names: Vec<String> = specs.iter().map(ToString::to_string).collect();
        assert_eq!(
            names,
            ["soft-step@substeps=8,hertz=60+warm", "pgs", "sor@omega=1.5"]
        );
        assert!(parse_solvers(&["pgs".into(), "hertz=60".into()]).is_err());
        let cone = parse_solvers(&["cone".into()]).unwrap();
        assert_eq!(cone.len(), ConeSolverKind::all().len());
    }
}

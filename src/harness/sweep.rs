//! Sweeps: the cross product of cases × solvers × budgets, run by worker threads that each
//! drive isolated child processes, with one CSV row written and flushed per finished run.
//!
//! Files in the output directory:
//!
//! * `results.csv`: one [`RunRecord`] per (case, solver, budget), appended as runs finish.
//!   On a restart with the same directory, rows already present are kept and their runs
//!   skipped (resume); a torn last line from an interrupted write is dropped.
//! * `histories.csv`: [`HistoryRow`]s of LCP runs (when histories are kept), written before the
//!   run's result row so a row in `results.csv` implies its history is complete.

use crate::harness::budget::{NamedBudget, SolverSpec};
use crate::harness::case::Case;
use crate::harness::isolate::run_isolated;
use crate::harness::record::{HistoryRow, RunRecord};
use crate::harness::run::RunOutput;
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::{HashSet, VecDeque};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc, Mutex};

/// One run to do.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    /// What to solve.
    pub case: Case,
    /// With which solver.
    pub solver: SolverSpec,
    /// Under which budget.
    pub budget: NamedBudget,
}

impl Job {
    /// The resume key, as in [`RunRecord::key`].
    pub fn key(&self) -> (String, String, String) {
        (
            self.case.to_string(),
            self.solver.to_string(),
            self.budget.name.clone(),
        )
    }
}

/// The cross product, in case-major order.
pub fn cross_product(cases: &[Case], solvers: &[SolverSpec], budgets: &[NamedBudget]) -> Vec<Job> {
    let mut jobs = Vec::new();
    for case in cases {
        for budget in budgets {
            for solver in solvers {
                jobs.push(Job {
                    case: case.clone(),
                    solver: solver.clone(),
                    budget: budget.clone(),
                });
            }
        }
    }
    jobs
}

/// How a sweep runs.
#[derive(Debug, Clone)]
pub struct SweepConfig {
    /// Executable that implements the hidden `bench-one` subcommand (normally the current
    /// `lcpbench` binary).
    pub exe: PathBuf,
    /// Output directory.
    pub out_dir: PathBuf,
    /// Worker threads, each driving one child process at a time. Default 2.
    pub jobs: usize,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Append LCP convergence histories to `histories.csv`.
    pub keep_histories: bool,
}

impl SweepConfig {
    /// Defaults: the current executable, 2 workers, progress bar, histories kept.
    pub fn new(out_dir: impl Into<PathBuf>) -> Result<Self> {
        Ok(Self {
            exe: std::env::current_exe().context("locating the lcpbench executable")?,
            out_dir: out_dir.into(),
            jobs: 2,
            progress: true,
            keep_histories: true,
        })
    }

    /// Path of `results.csv`.
    pub fn results_path(&self) -> PathBuf {
        self.out_dir.join("results.csv")
    }

    /// Path of `histories.csv`.
    pub fn histories_path(&self) -> PathBuf {
        self.out_dir.join("histories.csv")
    }
}

/// What a sweep did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SweepSummary {
    /// Runs executed now.
    pub ran: usize,
    /// Runs skipped because their row was already present.
    pub skipped: usize,
    /// Runs that ended in `panic`, `crash`, `timeout` or `error`.
    pub failed: usize,
}

/// Read the rows of a results file. Rows that do not parse (a torn last line) are dropped.
pub fn read_results(path: &Path) -> Result<Vec<RunRecord>> {
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(path)
        .with_context(|| format!("reading {}", path.display()))?;
    Ok(reader.deserialize().filter_map(|r| r.ok()).collect())
}

/// Read a histories file (rows that do not parse are dropped).
pub fn read_histories(path: &Path) -> Result<Vec<HistoryRow>> {
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(path)
        .with_context(|| format!("reading {}", path.display()))?;
    Ok(reader.deserialize().filter_map(|r| r.ok()).collect())
}

/// Rewrite `path` with exactly `rows` (header included), through a temporary file.
fn rewrite<T: serde::Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    let tmp = path.with_extension("csv.tmp");
    {
        let mut w = csv::Writer::from_path(&tmp)?;
        for r in rows {
            w.serialize(r)?;
        }
        w.flush()?;
    }
    std::fs::rename(&tmp, path)?;
    Ok(())
}

/// Open `path` for appending; the returned writer writes a header only if the file is new.
fn appender(path: &Path) -> Result<csv::Writer<File>> {
    let exists = path.exists() && std::fs::metadata(path)?.len() > 0;
    let file = OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .with_context(|| format!("opening {}", path.display()))?;
    Ok(csv::WriterBuilder::new()
        .has_headers(!exists)
        .from_writer(file))
}

/// Run the jobs, skipping those already in `results.csv`, and append a row per finished run.
pub fn run_sweep(config: &SweepConfig, jobs: Vec<Job>) -> Result<SweepSummary> {
    std::fs::create_dir_all(&config.out_dir)
        .with_context(|| format!("creating {}", config.out_dir.display()))?;
    let results_path = config.results_path();
    let histories_path = config.histories_path();
    // Resume: keep the parsable rows (and their histories), drop torn lines.
    let mut done: HashSet<(String, String, String)> = HashSet::new();
    if results_path.exists() {
        let rows = read_results(&results_path)?;
        rewrite(&results_path, &rows)?;
        done.extend(rows.iter().map(RunRecord::key));
        if histories_path.exists() {
            let hist: Vec<HistoryRow> = read_histories(&histories_path)?
                .into_iter()
                .filter(|h| done.contains(&(h.case.clone(), h.solver.clone(), h.budget.clone())))
                .collect();
            rewrite(&histories_path, &hist)?;
        }
    } else if histories_path.exists() {
        std::fs::remove_file(&histories_path)?;
    }
    let mut seen = HashSet::new();
    let total = jobs.len();
    let todo: VecDeque<Job> = jobs
        .into_iter()
        .filter(|j| !done.contains(&j.key()) && seen.insert(j.key()))
        .collect();
    let mut summary = SweepSummary {
        skipped: total - todo.len(),
        ..SweepSummary::default()
    };
    if todo.is_empty() {
        return Ok(summary);
    }
    let mut results = appender(&results_path)?;
    let mut histories = appender(&histories_path)?;

    let bar = ProgressBar::new(todo.len() as u64);
    if config.progress {
        bar.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:30}] {pos}/{len} ({eta} left) {msg}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
    } else {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }

    // Children run a private copy of the executable: a build in a shared target directory must
    // not swap the binary under a running sweep.
    let runner = private_copy(&config.exe, &config.out_dir);
    let exe_for_children = runner.clone().unwrap_or_else(|| config.exe.clone());
    let queue = Arc::new(Mutex::new(todo));
    let (tx, rx) = mpsc::channel::<RunOutput>();
    let mut workers = Vec::new();
    for _ in 0..config.jobs.max(1) {
        let queue = Arc::clone(&queue);
        let tx = tx.clone();
        let exe = exe_for_children.clone();
        workers.push(std::thread::spawn(move || loop {
            let job = queue.lock().map(|mut q| q.pop_front()).unwrap_or(None);
            let Some(job) = job else { break };
            let output = run_isolated(&exe, &job.case, &job.solver, &job.budget);
            if tx.send(output).is_err() {
                break;
            }
        }));
    }
    drop(tx);
    for output in rx {
        let r = &output.record;
        if config.keep_histories {
            for h in &output.history {
                histories.serialize(HistoryRow {
                    case: r.case.clone(),
                    solver: r.solver.clone(),
                    budget: r.budget.clone(),
                    iteration: h.iteration,
                    time_s: h.time_s,
                    residual: h.residual,
                })?;
            }
            histories.flush()?;
        }
        results.serialize(r)?;
        results.flush()?;
        summary.ran += 1;
        if r.is_isolation_failure() {
            summary.failed += 1;
        }
        bar.set_message(format!(
            "{} {} {}: {}",
            r.case, r.solver, r.budget, r.status
        ));
        bar.inc(1);
    }
    for w in workers {
        let _ = w.join();
    }
    if let Some(runner) = runner {
        let _ = std::fs::remove_file(runner);
    }
    bar.finish_and_clear();
    Ok(summary)
}

/// Copy `exe` into `dir` under a name private to this process; `None` when copying fails (the
/// sweep then runs `exe` itself).
fn private_copy(exe: &Path, dir: &Path) -> Option<PathBuf> {
    let dest = dir.join(format!(".lcpbench-runner-{}", std::process::id()));
    std::fs::copy(exe, &dest).ok()?;
    Some(dest)
}

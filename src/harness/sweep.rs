//! Sweeps: the cross product of cases × solvers × budgets, run by worker threads that each
//! drive isolated child processes, with one CSV row written and flushed per finished run.
//!
//! Files in the output directory:
//!
//! * `results.csv`: one [`RunRecord`] per (case, solver, budget), appended as runs finish.
//!   On a restart with the same directory, rows already present are kept and their runs
//!   skipped (resume). A last row that an interrupted write tore (no final newline, a missing
//!   column, a cut number) is dropped and its run done again; so are the rows of a run that
//!   appears more than once.
//! * `histories.csv`: [`HistoryRow`]s of LCP runs (when histories are kept), written before the
//!   run's result row so a row in `results.csv` implies its history is complete.
//! * `.lcpbench.lock`: a sweep holds an exclusive lock on this file (with its process id
//!   inside) for as long as it runs; a second sweep on the same directory refuses to start.
//!
//! A `results.csv` or `histories.csv` that this version of lcpbench did not write (another
//! program's file, or another version's table), a symbolic link in their place or a row damaged
//! before the last is refused before anything in the directory changes, and the file is left as
//! it is ([`crate::harness::outdir`]).
//! * `.lcpbench-runner-PID`: the private copy of the executable that the children of sweep
//!   `PID` run. It is removed when the sweep ends; copies left by a killed sweep are removed by
//!   the next sweep on the directory.

use crate::harness::case::Case;
use crate::harness::isolate::run_isolated;
use crate::harness::outdir::{
    append_table, check_own_table, columns_of, create_new, read_table, rewrite_table, TableOrigin,
};
pub use crate::harness::outdir::{lock_dir, DirLock, LOCK_FILE};
use crate::harness::record::{HistoryRow, RunKey, RunOutput, RunRecord};
use crate::harness::{BudgetName, NamedBudget, SolverSpec};
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::{HashMap, HashSet, VecDeque};
use std::fs::File;
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
    pub fn key(&self) -> RunKey {
        RunKey::of(&self.case, &self.solver, &self.budget.name)
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
    /// Runs skipped because their row was already in `results.csv`.
    pub skipped: usize,
    /// Jobs dropped because the same (case, solver, budget) was listed more than once.
    pub duplicates: usize,
    /// Rows of `results.csv` dropped on resume because they did not parse completely (a torn
    /// line) or repeated a run; their runs are done again.
    pub dropped_rows: usize,
    /// Copies of the executable left by killed sweeps, removed.
    pub stale_runners: usize,
    /// Runs that ended in `panic`, `crash`, `timeout` or `error`.
    pub failed: usize,
}

/// Most worker threads per core of the machine: each drives one child process at a time, and
/// more children than this only contend for the cores (and for memory).
pub const JOBS_PER_CORE: usize = 4;

/// Check a worker count against this machine: from 1 to [`JOBS_PER_CORE`] times the cores
/// (`std::thread::available_parallelism`).
pub fn check_jobs(jobs: usize) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = JOBS_PER_CORE * cores;
    if (1..=max).contains(&jobs) {
        Ok(jobs)
    } else {
        Err(format!(
            "must be between 1 and {max} ({JOBS_PER_CORE} per core, and this machine has \
             {cores}), got {jobs}"
        ))
    }
}

/// Prefix of the private copies of the executable that a sweep's children run.
pub const RUNNER_PREFIX: &str = ".lcpbench-runner-";

/// Read the rows of a results file. A last row that an interrupted sweep tore is left out (its
/// run never finished); any other row that does not parse is an error naming its line.
pub fn read_results(path: &Path) -> Result<Vec<RunRecord>> {
    Ok(read_table(path)?.rows)
}

/// Read a histories file, as [`read_results`] reads a results file.
pub fn read_histories(path: &Path) -> Result<Vec<HistoryRow>> {
    Ok(read_table(path)?.rows)
}

/// The columns of `results.csv` in this version.
pub fn result_columns() -> Vec<String> {
    columns_of(&RunRecord::default())
}

/// The columns of `histories.csv` in this version.
pub fn history_columns() -> Vec<String> {
    columns_of(&HistoryRow {
        case: String::new(),
        solver: SolverSpec::default(),
        budget: BudgetName::default(),
        iteration: 0,
        time_s: 0.0,
        residual: 0.0,
    })
}

/// The rows of `results.csv` a resume keeps, with the count of rows dropped: a torn last row,
/// and every row of a run that appears more than once (such a run is done again, so its history
/// cannot be mixed up with another copy's).
fn resumable_rows(path: &Path) -> Result<(Vec<RunRecord>, usize)> {
    let table = read_table::<RunRecord>(path)?;
    let mut dropped = usize::from(table.torn_at.is_some());
    let rows = table.rows;
    let mut count: HashMap<RunKey, usize> = HashMap::new();
    for r in &rows {
        *count.entry(r.key()).or_default() += 1;
    }
    let before = rows.len();
    let rows: Vec<RunRecord> = rows.into_iter().filter(|r| count[&r.key()] == 1).collect();
    dropped += before - rows.len();
    Ok((rows, dropped))
}

/// Remove the runner copies in `dir` other than this process's own (the caller holds the
/// directory's lock, so no other sweep is using them); returns how many were removed.
fn remove_stale_runners(dir: &Path) -> usize {
    let own = format!("{RUNNER_PREFIX}{}", std::process::id());
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .filter(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name.starts_with(RUNNER_PREFIX) && name != own
        })
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}

/// Run the jobs, skipping those already in `results.csv`, and append a row per finished run.
/// Holds the lock on the output directory for the whole sweep (see [`lock_dir`]).
pub fn run_sweep(config: &SweepConfig, jobs: Vec<Job>) -> Result<SweepSummary> {
    let lock = lock_dir(&config.out_dir)?;
    run_sweep_locked(config, jobs, &lock)
}

/// [`run_sweep`] for a caller that already holds the lock on `config.out_dir`.
pub fn run_sweep_locked(
    config: &SweepConfig,
    jobs: Vec<Job>,
    lock: &DirLock,
) -> Result<SweepSummary> {
    if lock.dir() != config.out_dir {
        bail!(
            "the lock is on {}, the sweep writes to {}",
            lock.dir().display(),
            config.out_dir.display()
        );
    }
    check_jobs(config.jobs).map_err(|m| anyhow::anyhow!("worker count {m}"))?;
    let mut summary = SweepSummary {
        stale_runners: remove_stale_runners(&config.out_dir),
        ..SweepSummary::default()
    };
    let done = resume(config, &mut summary)?;
    let todo = pending(jobs, &done, &mut summary);
    if todo.is_empty() {
        return Ok(summary);
    }
    let total = todo.len();
    let mut writers = Writers {
        results: append_table(&config.results_path())?,
        histories: append_table(&config.histories_path())?,
    };
    let bar = progress_bar(config.progress, total);
    // Children run a private copy of the executable: a build in a shared target directory must
    // not swap the binary under a running sweep.
    let runner = private_copy(&config.exe, &config.out_dir);
    let exe_for_children = runner.clone().unwrap_or_else(|| config.exe.clone());
    let (rx, workers, spawned) = spawn_workers(exe_for_children, todo, config.jobs);
    let written = write_outputs(config, rx, &mut writers, &bar, &mut summary);
    let panicked = workers
        .into_iter()
        .map(|w| w.join())
        .filter(Result::is_err)
        .count();
    if let Some(runner) = runner {
        let _ = std::fs::remove_file(runner);
    }
    bar.finish_and_clear();
    written?;
    spawned?;
    if panicked > 0 {
        bail!(
            "{panicked} worker thread(s) of the sweep panicked; {} of {total} runs were written \
             to {} (run the sweep again to resume)",
            summary.ran,
            config.results_path().display()
        );
    }
    Ok(summary)
}

/// Resume: keep the rows of `results.csv` that parse completely (and their histories), drop
/// the rest, and return the keys of the runs already done.
/// Both tables are checked to be this version's own (or absent) before either is touched.
fn resume(config: &SweepConfig, summary: &mut SweepSummary) -> Result<HashSet<RunKey>> {
    let results_path = config.results_path();
    let histories_path = config.histories_path();
    let results = check_own_table(&results_path, &result_columns(), "resume or rewrite it")?;
    let histories = check_own_table(&histories_path, &history_columns(), "rewrite it")?;
    let mut done: HashSet<RunKey> = HashSet::new();
    if results != TableOrigin::Absent {
        // Read both before either is rewritten: damage in either leaves both as they are.
        let (rows, dropped) = resumable_rows(&results_path)?;
        let hist = match histories {
            TableOrigin::Absent => None,
            _ => Some(read_table::<HistoryRow>(&histories_path)?.rows),
        };
        summary.dropped_rows = dropped;
        done.extend(rows.iter().map(RunRecord::key));
        rewrite_table(&results_path, &rows)?;
        if let Some(hist) = hist {
            let hist: Vec<HistoryRow> = hist
                .into_iter()
                .filter(|h| done.contains(&h.key()))
                .collect();
            rewrite_table(&histories_path, &hist)?;
        }
    } else if histories == TableOrigin::Current {
        // Histories of runs no results row records (their sweep wrote none).
        std::fs::remove_file(&histories_path)?;
    }
    Ok(done)
}

/// The jobs still to run, in order: duplicates and runs already `done` are counted and dropped.
fn pending(jobs: Vec<Job>, done: &HashSet<RunKey>, summary: &mut SweepSummary) -> VecDeque<Job> {
    let mut seen = HashSet::new();
    let mut todo = VecDeque::new();
    for job in jobs {
        let key = job.key();
        if !seen.insert(key.clone()) {
            summary.duplicates += 1;
        } else if done.contains(&key) {
            summary.skipped += 1;
        } else {
            todo.push_back(job);
        }
    }
    todo
}

fn progress_bar(visible: bool, len: usize) -> ProgressBar {
    let bar = ProgressBar::new(len as u64);
    if visible {
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
    bar
}

/// Worker threads of a sweep.
type Workers = Vec<std::thread::JoinHandle<()>>;

/// Start `jobs` worker threads, each taking runs off the queue and running them in isolated
/// children of `exe`; the outputs arrive on the returned channel. When the system refuses a
/// thread, the workers already started do the runs and the error is returned beside them.
fn spawn_workers(
    exe: PathBuf,
    todo: VecDeque<Job>,
    jobs: usize,
) -> (mpsc::Receiver<RunOutput>, Workers, Result<()>) {
    let queue = Arc::new(Mutex::new(todo));
    let (tx, rx) = mpsc::channel::<RunOutput>();
    let mut workers = Vec::new();
    for k in 0..jobs.max(1) {
        let queue = Arc::clone(&queue);
        let tx = tx.clone();
        let exe = exe.clone();
        let spawned = std::thread::Builder::new()
            .name(format!("sweep-worker-{k}"))
            .spawn(move || loop {
                let job = queue.lock().map(|mut q| q.pop_front()).unwrap_or(None);
                let Some(job) = job else { break };
                let output = run_isolated(&exe, &job.case, &job.solver, &job.budget);
                if tx.send(output).is_err() {
                    break;
                }
            });
        match spawned {
            Ok(worker) => workers.push(worker),
            Err(e) => {
                let error = anyhow::anyhow!(
                    "could start only {k} of {jobs} worker threads: {e}; the runs went to those"
                );
                // The senders left are the running workers': the channel ends with them.
                return (rx, workers, Err(error));
            }
        }
    }
    (rx, workers, Ok(()))
}

/// The appenders of `results.csv` and `histories.csv`.
struct Writers {
    results: csv::Writer<File>,
    histories: csv::Writer<File>,
}

/// Append each output to `results.csv` (and its history to `histories.csv`) as it arrives.
fn write_outputs(
    config: &SweepConfig,
    rx: mpsc::Receiver<RunOutput>,
    writers: &mut Writers,
    bar: &ProgressBar,
    summary: &mut SweepSummary,
) -> Result<()> {
    let Writers { results, histories } = writers;
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
    Ok(())
}

/// Copy `exe` into `dir` under a name private to this process, as a new file (never through a
/// link left there); `None` when copying fails (the sweep then runs `exe` itself).
fn private_copy(exe: &Path, dir: &Path) -> Option<PathBuf> {
    let dest = dir.join(format!("{RUNNER_PREFIX}{}", std::process::id()));
    // A copy of an earlier process with this id; removing a link removes only the link.
    let _ = std::fs::remove_file(&dest);
    let mut out = create_new(&dest).ok()?;
    let copied = File::open(exe).and_then(|mut src| std::io::copy(&mut src, &mut out));
    let permissions = std::fs::metadata(exe).map(|m| m.permissions());
    drop(out);
    match (copied, permissions) {
        (Ok(_), Ok(p)) if std::fs::set_permissions(&dest, p.clone()).is_ok() => Some(dest),
        _ => {
            let _ = std::fs::remove_file(&dest);
            None
        }
    }
}

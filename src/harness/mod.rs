//! The comparison harness: a *run* is one (case, solver, budget). Runs execute in isolated
//! child processes driven by worker threads, and each finished run becomes one CSV row.
//!
//! Flow: [`case`] (what to solve) × [`solver_spec`] (which solver, with its options) ×
//! [`budget`] (tolerance, iterations, seconds) → [`sweep`] (queue, workers, resume) →
//! [`isolate`] (child process, timeout) → [`run`] (in the child: solve an LCP, or step a scene
//! via [`scene`], whose rows [`metrics`] fills; an LCP solve is timed by [`timing`]: an untimed
//! first solve, then repeats from the same start, their median recorded) → [`record`] (the CSV
//! row, its [`RunStatus`] and [`RunKey`]). [`export`] writes the LCP of one scene step; [`outdir`] keeps the rules of
//! the output directory (lock, tables, what is never overwritten). [`machine`] names the
//! machine a run ran on (`isolate` records it in every row); [`fault`] injects a failure into
//! the child in place of a solve; [`catalogue`] lists every solver with its level and problem
//! classes. The typed columns of a row (class, family, solver, budget) are written as their
//! text and parsed back where the row is read (module `text`). For sweeps on several machines,
//! [`shard`] splits a sweep into deterministic parts balanced by expected cost and [`merge`]
//! joins the parts' directories into the rows of the whole sweep.
//!
//! Imports go one way: `solver_spec` knows `fault`; `record` knows `case`, `solver_spec`,
//! `budget` and `machine`; `run`, `scene` and `isolate` know `record`; `run` knows `timing`,
//! which knows only the solvers' result type (and `record` for its warm-start count, in tests); `sweep` knows
//! `isolate`; `shard` knows `sweep`'s jobs, and `merge` knows `shard` and reads what `sweep`
//! wrote.

pub mod budget;
pub mod case;
pub mod catalogue;
pub mod export;
pub mod fault;
pub mod impact;
pub mod isolate;
pub mod machine;
pub mod merge;
pub mod metrics;
pub mod outdir;
pub mod record;
pub mod run;
pub mod scene;
pub mod shard;
pub mod solver_spec;
pub mod step_failure;
pub mod sweep;
mod text;
pub mod timing;

pub use budget::{Budget, BudgetError, BudgetName, CustomBudget, NamedBudget};
pub use case::{Case, CaseFamily, ProblemClass};
pub use fault::Fault;
pub use record::{HistoryRow, RunKey, RunOutput, RunRecord, RunStatus, TTA_LEVELS};
pub use solver_spec::{SolverSpec, SolverSpecError};
pub use sweep::{cross_product, run_sweep, Job, SweepConfig, SweepSummary};

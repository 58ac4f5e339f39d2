//! # lcpbench
//!
//! The harness of the contact-solver workbench: runs solvers × cases × budgets in isolated
//! child processes, records the shared metrics one CSV row per run, and writes reports (Markdown
//! tables and SVG plots). The problems and solvers live in `lcpbench-solvers`, the physics in
//! `lcpbench-contact`.
//!
//! A case is named by a key (see [`harness::case`]); one run can be executed in process:
//!
//! ```
//! use lcpbench::harness::{run::run_in_process, Case, NamedBudget, SolverSpec};
//!
//! let case: Case = "spd:n=20:cond=1e3:seed=1".parse().unwrap();
//! let solver: SolverSpec = "sor@1.3".parse().unwrap();
//! let budget: NamedBudget = "default".parse().unwrap();
//! let out = run_in_process(&case, &solver, &budget);
//! assert_eq!(out.record.status, lcpbench::harness::RunStatus::Converged);
//! assert!(out.record.residual_rel.unwrap() <= 1e-8);
//! ```
#![warn(missing_docs)]

pub mod cli;
pub mod harness;
pub mod registry;
pub mod report;
pub mod view;

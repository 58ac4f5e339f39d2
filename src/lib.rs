//! # lcpbench
//!
//! The harness of the contact-solver workbench: runs solvers × scenes × budgets, records the
//! shared metrics and writes reports. The problems and solvers live in `lcpbench-solvers`, the
//! physics in `lcpbench-contact`.
#![warn(missing_docs)]

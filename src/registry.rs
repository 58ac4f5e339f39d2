//! The solver registry, for a program that adds its own solver to lcpbench: every solver is
//! one [`SolverEntry`] (name, level, summary, problem classes, iteration unit, warm start,
//! relaxation, parameters, constructor), the built-in ones listed by `lcpbench-solvers`
//! (matrix, cone) and `lcpbench-contact` (body-level). [`register`] adds one at run time; the
//! command line ([`crate::cli::main`]), the sweeps, the report and `lcpbench solvers` then
//! treat it as they treat the built-in solvers.
//!
//! ```
//! use lcpbench::registry::{self, Make, Params, SolverEntry};
//! use lcpbench_solvers::Lemke;
//!
//! static LEMKE_AGAIN: SolverEntry = SolverEntry {
//!     name: "doc-lemke",
//!     summary: "Lemke's method under another name",
//!     problem_classes: "as lemke",
//!     iteration_unit: "pivots",
//!     iterative: false,
//!     relaxation: None,
//!     params: &[],
//!     make: Make::Matrix(|_: &Params| Box::new(Lemke::default())),
//! };
//! registry::register(&LEMKE_AGAIN).unwrap();
//! let spec: lcpbench::harness::SolverSpec = "doc-lemke".parse().unwrap();
//! assert_eq!(spec.entry(), Some(&LEMKE_AGAIN));
//! assert!(registry::entries().iter().any(|e| e.name == "doc-lemke"));
//! ```

pub use lcpbench_contact::body_solvers::{body_make, BodyMake, BODY_SOLVERS};
pub use lcpbench_contact::registry::{entries, entries_at, find, names_at, register};
pub use lcpbench_solvers::registry::{
    Level, Make, ParamSpec, Params, RegistryError, SolverEntry, CONE_SOLVERS, MATRIX_SOLVERS,
};

//! Dantzig: not implemented yet.

use crate::problem::Problem;
use crate::solver::{Monitor, Outcome, Settings, SolveResult, Solver};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str = "not implemented yet";

/// Dantzig solver.
#[derive(Debug, Clone, Default)]
pub struct Dantzig {}

impl Solver for Dantzig {
    fn name(&self) -> &'static str {
        "dantzig"
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        Monitor::new(problem, settings).finish(
            Vec::new(),
            0,
            Outcome::Unsupported("not implemented yet".into()),
        )
    }
}

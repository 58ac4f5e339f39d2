//! Lemke: not implemented yet.

use crate::problem::Problem;
use crate::solver::{Monitor, Outcome, Settings, SolveResult, Solver};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str = "not implemented yet";

/// Lemke solver.
#[derive(Debug, Clone, Default)]
pub struct Lemke {}

impl Solver for Lemke {
    fn name(&self) -> &'static str {
        "lemke"
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        Monitor::new(problem, settings).finish(
            Vec::new(),
            0,
            Outcome::Unsupported("not implemented yet".into()),
        )
    }
}

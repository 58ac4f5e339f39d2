//! A solver added to lcpbench from outside its workspace: projected Jacobi on the (boxed) LCP
//! `w = A f + b`, `lo <= f <= hi` (friction rows bounded by `±mu f_normal`).
//!
//! One iteration updates every row from the same iterate, then all at once:
//!
//! ```text
//! f⁺ = P( f − ω D⁻¹ (A f + b) ),   D = diag(A),
//! ```
//!
//! `P` the projection onto the bounds (friction rows at the new normal impulses). For a
//! symmetric positive definite `A` this is projected gradient descent in the metric `D`, which
//! converges for `0 < ω < 2 / λ_max(D^{-1/2} A D^{-1/2})` (Cottle, Pang & Stone, *The Linear
//! Complementarity Problem*, 1992, §5.2 on splitting methods; Erleben, *Numerical methods for
//! linear complementarity problems in physics-based animation*, 2013, §4). Cost per
//! iteration: one product `A f` (`O(nnz(A))`), which also gives the shared residual. Failure
//! modes: too large an `ω` for the problem diverges (the status then says `iteration_limit` or
//! `numerical_failure`, never `converged`); rows with a zero diagonal are never updated.
//!
//! The whole addition is this file's [`JACOBI_EXAMPLE`] entry and solver, and one call of
//! `lcpbench::registry::register` in `main.rs`.

use lcpbench_solvers::registry::{Make, ParamSpec, SolverEntry};
use lcpbench_solvers::{
    judge, non_finite_reason, residuals_and_velocity, HistoryPoint, Outcome, Problem, Settings,
    SolveResult, Solver, Status,
};
use std::time::Instant;

/// The registry entry of `jacobi-example`: everything lcpbench needs to list, parse, build and
/// report the solver.
pub static JACOBI_EXAMPLE: SolverEntry = SolverEntry {
    name: "jacobi-example",
    summary: "projected Jacobi (the own_solver example): every row from the same iterate, damped",
    problem_classes: "LCP, boxed LCP, friction rows, free rows; converges for SPD A when omega \
                      < 2 / lambda_max(D^-1 A), slower than Gauss-Seidel",
    iteration_unit: "Jacobi sweeps over the rows",
    iterative: true,
    relaxation: None,
    params: &[ParamSpec::real_open(
        "omega",
        0.5,
        0.0,
        2.0,
        "damping of the Jacobi step",
    )],
    make: Make::Matrix(|params| {
        Box::new(ProjectedJacobi {
            omega: params.get("omega"),
        })
    }),
};

/// Projected Jacobi with damping `omega` (see the crate documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProjectedJacobi {
    /// Damping `ω` of the step \[`0.5`\].
    pub omega: f64,
}

impl Solver for ProjectedJacobi {
    fn entry(&self) -> &'static SolverEntry {
        &JACOBI_EXAMPLE
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let start = Instant::now();
        let deadline = settings.time_budget.map(|b| start + b);
        let n = problem.n();
        let mut f = match &settings.warm_start {
            Some(ws) if ws.len() == n && ws.iter().all(|v| v.is_finite()) => ws.clone(),
            _ => vec![0.0; n],
        };
        problem.project_onto_bounds(&mut f);
        let mut w = vec![0.0; n];
        let mut residuals = residuals_and_velocity(problem, &f, &mut w);
        if let Err(e) = settings.validate() {
            // A tolerance of 1 or more would call any point converged: refused, as every
            // built-in solver refuses it.
            return SolveResult {
                f,
                w,
                status: Status::Unsupported {
                    reason: e.to_string(),
                },
                iterations: 0,
                time: start.elapsed(),
                residuals,
                history: Vec::new(),
                active_sets: Vec::new(),
                certificate: None,
            };
        }
        let mut history = Vec::new();
        let mut iterations = 0;
        let outcome = loop {
            if residuals.natural_map_rel <= settings.tolerance {
                break Outcome::Stopped;
            }
            if !residuals.natural_map_rel.is_finite() {
                break Outcome::NumericalFailure("the iterate is not finite".into());
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                break Outcome::TimeLimit;
            }
            for (i, fi) in f.iter_mut().enumerate() {
                let d = problem.diagonal(i);
                if d > 0.0 {
                    *fi -= self.omega * w[i] / d;
                }
            }
            problem.project_onto_bounds(&mut f);
            iterations += 1;
            // `w = A f + b` is the next step's input; the shared residual comes with it.
            residuals = residuals_and_velocity(problem, &f, &mut w);
            if settings.record_history {
                history.push(HistoryPoint {
                    iteration: iterations,
                    residual: residuals.natural_map_rel,
                    time_s: start.elapsed().as_secs_f64(),
                });
            }
        };
        let (status, certificate) = match non_finite_reason(&f, "impulse", "f") {
            Some(reason) => (Status::NumericalFailure { reason }, None),
            None => judge(problem, &f, &w, &residuals, outcome, settings.tolerance),
        };
        SolveResult {
            f,
            w,
            status,
            iterations,
            time: start.elapsed(),
            residuals,
            history,
            active_sets: Vec::new(),
            certificate,
        }
    }
}

//! The solve phase of a step: the warm start, the deadline and the solver settings of a solve,
//! the body-level path and the matrix / cone path, the islands solved apart in parallel and
//! merged into one impulse, status and residual ([`Solved`]).

use super::{ContactSolver, World};
use crate::body_solvers::{body_status, BodySweep, Measure};
use crate::builder::{ContactSystem, DelassusForm, Partition};
use crate::substep::{SolverState, StepCost, SubstepInput};
use lcpbench_solvers::{
    decide, judge, non_finite_reason, residuals_and_velocity, ConeProblem, HistoryPoint, Outcome,
    Problem, Residuals, Settings, SolveResult, Status,
};
use std::time::Instant;

/// One island's problem, in the form its solver takes.
pub(super) enum IslandProblem {
    Lcp(Problem),
    Cone(ConeProblem),
}

impl IslandProblem {
    /// The problem of island `k` of `partition`: the cone problem when `cone`, else the LCP
    /// with `A` in `form`.
    pub(super) fn of(
        system: &ContactSystem,
        partition: &Partition,
        k: usize,
        cone: bool,
        form: DelassusForm,
    ) -> Result<Self, String> {
        if cone {
            system
                .island_cone_problem(partition, k)
                .map(IslandProblem::Cone)
                .map_err(|e| e.to_string())
        } else {
            system
                .island_problem_in(partition, k, form)
                .map(IslandProblem::Lcp)
                .map_err(|e| e.to_string())
        }
    }
}

/// The solved impulse of one step.
pub(super) struct Solved {
    pub(super) f: Vec<f64>,
    pub(super) status: Status,
    pub(super) iterations: usize,
    pub(super) time_s: f64,
    pub(super) wall_s: f64,
    /// Of the solve phase's wall time: the share spent assembling the solvers' problems.
    pub(super) assembly_s: f64,
    /// Of the solve phase's wall time: the share spent measuring residuals (the solvers' final
    /// measurement and recorded histories, the assembled `A` of body-level solvers).
    pub(super) measure_s: f64,
    pub(super) residuals: Option<Residuals>,
    pub(super) problem: Option<Problem>,
    pub(super) cone_problem: Option<ConeProblem>,
    pub(super) history: Vec<HistoryPoint>,
    /// The warm start given to a matrix or cone solver, kept with the problem.
    pub(super) warm_start: Option<Vec<f64>>,
    /// For a substepping solver: the bodies' motion over the step and what was measured.
    pub(super) substepped: Option<Substepped>,
}

/// What a substepping solver adds to a solve: the bodies' motion (applied instead of the
/// stepper's own integration), the solve the residual was measured on, the cost count.
pub(super) struct Substepped {
    pub(super) state: SolverState,
    pub(super) residual_of: String,
    pub(super) cost: StepCost,
    pub(super) substeps: usize,
}

/// One island's solve with the wall time of its call, or why it could not be solved.
type IslandOutcome = Result<(SolveResult, f64), String>;

/// Solve each island of `partition` on its own (island `k` with `solvers[k]`, in parallel with
/// rayon) and scatter the impulses back; the instances are handed back after their solves, in
/// island order, to be kept for the next step. The islands' problems are assembled first, then
/// solved; each solve's settings carry its part of the warm start and the time left before
/// `deadline`. The step's residuals are those of the whole: every measure is a maximum over rows
/// (or contacts, for the cone residual) except the complementarity gap, a sum, and `A` has no
/// entry between islands. The status is the worst island's.
fn solve_islands(
    system: &ContactSystem,
    partition: &Partition,
    settings: &Settings,
    solvers: Vec<ContactSolver>,
    deadline: Option<Instant>,
) -> (Solved, Vec<ContactSolver>) {
    use rayon::prelude::*;
    let n = system.n();
    let t0 = Instant::now();
    let (cone, form) = match solvers.first() {
        Some(s) => (s.is_cone(), s.delassus_form()),
        None => return (Solved::invalid(n, &"no island to solve"), solvers),
    };
    let problems: Vec<Result<IslandProblem, String>> = (0..partition.len())
        .into_par_iter()
        .map(|k| IslandProblem::of(system, partition, k, cone, form))
        .collect();
    let assembly_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    // Each result with the wall time of its call, and the instance that solved it.
    let (results, solvers): (Vec<IslandOutcome>, Vec<ContactSolver>) = solvers
        .into_par_iter()
        .zip(problems)
        .enumerate()
        .map(|(k, (mut solver, problem))| {
            let rows = &partition.islands[k].rows;
            let island_settings = Settings {
                warm_start: settings
                    .warm_start
                    .as_ref()
                    .map(|ws| rows.iter().map(|&i| ws[i]).collect()),
                time_budget: deadline.map(|d| d.saturating_duration_since(Instant::now())),
                ..settings.clone()
            };
            let call = Instant::now();
            let result = problem
                .and_then(|p| solver.solve_island(&p, &island_settings))
                .map(|r| (r, call.elapsed().as_secs_f64()));
            (result, solver)
        })
        .unzip();
    let solve_wall_s = t1.elapsed().as_secs_f64();
    let mut f = vec![0.0; n];
    let mut status = Status::Converged;
    let (mut iterations, mut time_s) = (0, 0.0);
    let (mut calls_s, mut measured_s) = (0.0, 0.0);
    // The history shown for the step: the largest island's.
    let (mut history, mut history_rows) = (Vec::new(), 0);
    let mut res = Residuals {
        natural_map: 0.0,
        natural_map_rel: 0.0,
        complementarity_gap: 0.0,
        bound_violation: 0.0,
    };
    for (island, result) in partition.islands.iter().zip(results) {
        let (result, call_s) = match result {
            Ok(r) => r,
            Err(e) => return (Solved::invalid(n, &e), solvers),
        };
        for (&i, v) in island
            .rows
            .iter()
            .zip(usable_impulse(&result, island.rows.len()))
        {
            f[i] = v;
        }
        if status_rank(&result.status) > status_rank(&status) {
            status = result.status;
        }
        iterations = iterations.max(result.iterations);
        let own_s = result.time.as_secs_f64();
        time_s += own_s;
        calls_s += call_s;
        measured_s += (call_s - own_s).max(0.0);
        if island.rows.len() > history_rows {
            history_rows = island.rows.len();
            history = result.history;
        }
        let r = result.residuals;
        res.natural_map = res.natural_map.max(r.natural_map);
        res.natural_map_rel = res.natural_map_rel.max(r.natural_map_rel);
        res.complementarity_gap += r.complementarity_gap;
        res.bound_violation = res.bound_violation.max(r.bound_violation);
    }
    // The calls ran in parallel: their measuring share of the phase's wall time is their
    // share of the summed call times.
    let measure_s = if calls_s > 0.0 {
        solve_wall_s * measured_s / calls_s
    } else {
        0.0
    };
    let solved = Solved {
        f,
        status,
        iterations,
        time_s,
        wall_s: 0.0,
        assembly_s,
        measure_s,
        residuals: Some(res),
        problem: None,
        cone_problem: None,
        history,
        warm_start: None,
        substepped: None,
    };
    (solved, solvers)
}

/// How bad a status is, for reporting the worst island: converged < stalled < limits <
/// failures < unsupported.
fn status_rank(status: &Status) -> u8 {
    match status {
        Status::Converged => 0,
        Status::Stalled { .. } => 1,
        Status::IterationLimit | Status::TimeLimit => 2,
        Status::NoSolution { .. } | Status::Diverged { .. } | Status::NumericalFailure { .. } => 3,
        Status::Unsupported { .. } => 4,
    }
}

/// Every finite answer is applied (its status is reported); an unsupported problem or a
/// non-finite answer applies no impulse.
pub(super) fn usable_impulse(result: &SolveResult, n: usize) -> Vec<f64> {
    let usable = !matches!(result.status, Status::Unsupported { .. })
        && result.f.len() == n
        && result.f.iter().all(|v| v.is_finite());
    if usable {
        result.f.clone()
    } else {
        vec![0.0; n]
    }
}

impl Solved {
    /// A step without contact rows: nothing to solve.
    pub(super) fn empty() -> Self {
        Solved {
            f: Vec::new(),
            status: Status::Converged,
            iterations: 0,
            time_s: 0.0,
            wall_s: 0.0,
            assembly_s: 0.0,
            measure_s: 0.0,
            residuals: None,
            problem: None,
            cone_problem: None,
            history: Vec::new(),
            warm_start: None,
            substepped: None,
        }
    }

    /// No impulse: the contact system could not be made into a problem.
    pub(super) fn invalid(n: usize, e: &dyn std::fmt::Display) -> Self {
        Solved {
            f: vec![0.0; n],
            status: Status::NumericalFailure {
                reason: format!("contact system is invalid: {e}"),
            },
            iterations: 0,
            time_s: 0.0,
            wall_s: 0.0,
            assembly_s: 0.0,
            measure_s: 0.0,
            residuals: None,
            problem: None,
            cone_problem: None,
            history: Vec::new(),
            warm_start: None,
            substepped: None,
        }
    }

    /// No impulse: the solver does not take the step's friction model.
    pub(super) fn unsupported(n: usize, reason: String) -> Self {
        Solved {
            status: Status::Unsupported { reason },
            ..Self::invalid(n, &"")
        }
    }
}

impl World {
    /// Whether a step has its shared residual measured: the step is on the schedule ([`SimSettings::residual`](super::SimSettings::residual), for the
    /// step being taken, `step_index`, of a run of [`SimSettings::steps`](super::SimSettings::steps))
    /// or its problem is kept (and measured with it), and `A` is within
    /// [`MAX_DELASSUS_ENTRIES`](crate::builder::MAX_DELASSUS_ENTRIES), since the measurement
    /// visits each of its entries. A body-level step past that limit is solved on the bodies as
    /// usual and left unmeasured (never `converged`), instead of refused (a matrix or cone
    /// step past it is refused before it is solved).
    pub(super) fn measures_step(&self, system: &ContactSystem) -> bool {
        let s = &self.settings;
        let scheduled = s.residual.measures(self.step_index, s.steps) || s.keep_problem;
        scheduled && system.check_delassus_size(&self.bodies).is_ok()
    }

    /// The deadline of a solve starting now: the step's time budget from now, or the run's
    /// deadline if earlier.
    pub(super) fn solve_deadline(&self) -> Option<Instant> {
        let step = self
            .settings
            .step_time_budget
            .and_then(|b| Instant::now().checked_add(b));
        match (step, self.settings.deadline) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The solver settings of a solve that must end by `deadline`.
    pub(super) fn solver_settings(&self, deadline: Option<Instant>) -> Settings {
        Settings {
            tolerance: self.settings.tolerance,
            max_iterations: self.settings.max_iterations,
            time_budget: deadline.map(|d| d.saturating_duration_since(Instant::now())),
            ..Settings::default()
        }
    }

    /// Solve the step's system with the world's solver: nothing for no rows, `Unsupported`
    /// when the solver does not take the friction model, else the body-level or the matrix /
    /// cone path, within the step's time budget. Stores the warm start for the next step.
    pub(super) fn solve(&mut self, system: &ContactSystem, partition: &Partition) -> Solved {
        let n = system.n();
        let wall = Instant::now();
        let deadline = self.solve_deadline();
        if n == 0 {
            self.warm.clear();
            return Solved::empty();
        }
        let model = self.settings.builder.friction_model;
        let supported = self.settings.solver.supports(model).and_then(|()| {
            if system.joints.is_empty() {
                Ok(())
            } else {
                self.settings.solver.supports_joints()
            }
        });
        let mut solved = if let Err(reason) = supported {
            self.warm.clear();
            Solved::unsupported(n, reason)
        } else {
            let warm_start = self
                .settings
                .warm_start
                .then(|| system.warm_start(&self.warm));
            if self.settings.solver.substeps() {
                self.solve_substepping(system, warm_start, deadline)
            } else if matches!(self.settings.solver, ContactSolver::Body(_)) {
                self.solve_on_bodies(system, warm_start, deadline)
            } else {
                self.solve_problem(system, partition, warm_start, deadline)
            }
        };
        solved.wall_s = wall.elapsed().as_secs_f64();
        solved
    }

    /// The matrix and cone path: the assembled problem (per island when there are several)
    /// solved with the instance; the problem kept on request.
    fn solve_problem(
        &mut self,
        system: &ContactSystem,
        partition: &Partition,
        warm_start: Option<Vec<f64>>,
        deadline: Option<Instant>,
    ) -> Solved {
        let mut settings = self.solver_settings(deadline);
        settings.record_history = self.settings.record_history;
        // Off the residual schedule the solver measures only what its own stopping rule
        // needs, and the step reports no residual (never `converged`).
        let measured = self.measures_step(system);
        settings.measure_result = measured;
        if self.settings.solver.takes_warm_start() {
            settings.warm_start = warm_start;
        }
        let kept_warm_start = if self.settings.keep_problem {
            settings.warm_start.clone()
        } else {
            None
        };
        if self.whole.name() != self.settings.solver.name() {
            self.whole = self.settings.solver.clone();
        }
        let mut solved = if self.settings.islands && partition.len() > 1 {
            let solvers = self.island_solvers.take(partition, &self.settings.solver);
            let (solved, solvers) = solve_islands(system, partition, &settings, solvers, deadline);
            self.island_solvers.keep(partition, solvers);
            solved
        } else {
            self.whole.solve_whole(system, &settings)
        };
        if self.settings.keep_problem {
            if self.settings.solver.is_cone() {
                if solved.cone_problem.is_none() {
                    solved.cone_problem = system.cone_problem().ok();
                }
            } else if solved.problem.is_none() {
                solved.problem = system.problem().ok();
            }
        }
        if !measured {
            solved.residuals = None;
        }
        self.warm.store(system, &solved.f);
        solved.warm_start = kept_warm_start;
        solved
    }

    /// The body-level path: the solver works on `system`, and the status is decided from the
    /// shared residual of the step's LCP (`A` held as its factors) when residuals (or the
    /// problem) are wanted.
    fn solve_on_bodies(
        &mut self,
        system: &ContactSystem,
        warm_start: Option<Vec<f64>>,
        deadline: Option<Instant>,
    ) -> Solved {
        let t0 = Instant::now();
        let measured = self.measures_step(system).then(|| {
            system
                .problem_in(DelassusForm::Factored)
                .map_err(|e| e.to_string())
        });
        let assembly_s = t0.elapsed().as_secs_f64();
        let settings = Settings {
            warm_start,
            ..self.solver_settings(deadline)
        };
        let call = Instant::now();
        let measure = match &measured {
            Some(Ok(p)) => Measure::Lcp(p),
            Some(Err(e)) => Measure::Invalid(e),
            None => Measure::Skip,
        };
        let out = match &mut self.settings.solver {
            ContactSolver::Body(s) => s.solve(system, &settings, measure),
            _ => return Solved::unsupported(system.n(), "not a body-level solver".into()),
        };
        let call_s = call.elapsed().as_secs_f64();
        self.warm.store(system, &out.warm);
        let problem = measured.and_then(Result::ok);
        let r = out.result;
        let own_s = r.time.as_secs_f64();
        Solved {
            f: r.f,
            status: r.status,
            iterations: r.iterations,
            time_s: own_s,
            wall_s: 0.0,
            // The measured problem serves only the measurement.
            assembly_s: 0.0,
            measure_s: assembly_s + (call_s - own_s).max(0.0),
            residuals: problem.is_some().then_some(r.residuals),
            problem,
            cone_problem: None,
            history: Vec::new(),
            warm_start: None,
            substepped: None,
        }
    }

    /// The substepping path: the solver advances the bodies over the whole step
    /// ([`crate::BodySolver::advance`]); the shared residual is measured on its last solve's
    /// LCP (the step's `A`, that solve's `b`), and the status decided from it: `converged`
    /// only when that residual meets the tolerance, and a solver of a soft model says which
    /// model it solved.
    fn solve_substepping(
        &mut self,
        system: &ContactSystem,
        warm_start: Option<Vec<f64>>,
        deadline: Option<Instant>,
    ) -> Solved {
        let settings = Settings {
            warm_start,
            ..self.solver_settings(deadline)
        };
        let input = SubstepInput {
            system,
            gravity: self.settings.gravity,
            settings: &settings,
        };
        let call = Instant::now();
        let out = match &mut self.settings.solver {
            ContactSolver::Body(s) => s.advance(&input),
            _ => None,
        };
        let own_s = call.elapsed().as_secs_f64();
        let name = self.settings.solver.name();
        let Some(out) = out else {
            return Solved::unsupported(system.n(), format!("`{name}` does not substep"));
        };
        self.warm.store(system, &out.warm);
        let measured = self.measures_step(system);
        let t_measure = Instant::now();
        let problem = measured.then(|| {
            system
                .problem_with_b(out.last.b.clone(), DelassusForm::Factored)
                .map_err(|e| e.to_string())
        });
        let sweep = BodySweep {
            f: out.last.f.clone(),
            warm: Vec::new(),
            iterations: out.iterations,
            stopped: false,
            stalled: None,
            timed_out: out.timed_out,
        };
        let (status, residuals) = match &problem {
            Some(Ok(p)) => {
                let mut w = vec![0.0; p.n()];
                let r = residuals_and_velocity(p, &out.last.f, &mut w);
                let status = substep_status(name, &out, &r, &settings);
                let status = match status {
                    Status::Converged => {
                        judge(p, &out.last.f, &w, &r, Outcome::Stopped, settings.tolerance).0
                    }
                    s => s,
                };
                (status, Some(r))
            }
            Some(Err(e)) => (body_status(name, &sweep, None, Some(e), &settings), None),
            None => (body_status(name, &sweep, None, None, &settings), None),
        };
        let measure_s = t_measure.elapsed().as_secs_f64();
        Solved {
            f: out.f_step,
            status,
            iterations: out.iterations,
            time_s: own_s,
            wall_s: 0.0,
            assembly_s: 0.0,
            measure_s,
            residuals,
            problem: problem.and_then(Result::ok),
            cone_problem: None,
            history: Vec::new(),
            warm_start: None,
            substepped: Some(Substepped {
                state: out.state,
                residual_of: out.last.what,
                cost: out.cost,
                substeps: out.substeps,
            }),
        }
    }
}

/// The status of a substepping solver's step from the residual `r` of its last solve on that
/// solve's LCP: a non-finite impulse or residual is a numerical failure; otherwise `converged`
/// when the residual meets the tolerance, else a time limit, or for a solver of a soft model a
/// stall that names the model, or the iteration limit (these solvers run a set number of
/// iterations per substep).
fn substep_status(
    name: &str,
    out: &crate::substep::SubstepOutcome,
    r: &Residuals,
    settings: &Settings,
) -> Status {
    if let Some(reason) = non_finite_reason(&out.last.f, "impulse", "f") {
        return Status::NumericalFailure { reason };
    }
    let rel = r.natural_map_rel;
    if !rel.is_finite() {
        return Status::NumericalFailure {
            reason: format!("the residual of the last solve's LCP is not finite ({rel})"),
        };
    }
    let soft = crate::BodySolverKind::from_name(name).and_then(crate::BodySolverKind::relaxation);
    let outcome = if out.timed_out {
        Outcome::TimeLimit
    } else if let Some(soft) = soft {
        Outcome::Stalled(format!(
            "{name} solves {soft}: its last solve ({}) is at relative residual {rel:.3e} > \
             tolerance {:.1e} on that solve's LCP",
            out.last.what, settings.tolerance
        ))
    } else {
        Outcome::IterationLimit
    };
    decide(outcome, rel, settings.tolerance)
}

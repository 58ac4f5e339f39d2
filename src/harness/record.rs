//! The result row of one run (one line of `results.csv`) and the convergence-history rows.
//!
//! Every column is documented on its field; empty cells mean "does not apply" (scene columns on
//! an LCP case, an analytic error on a scene without one, a time-to-accuracy never reached).
//!
//! The outcome of a run is a [`RunStatus`] (the solver statuses plus the harness's own
//! outcomes), serialised as lowercase names; a run is identified by its [`RunKey`]. The class,
//! family, solver and budget columns are typed ([`ProblemClass`], [`CaseFamily`],
//! [`SolverSpec`], [`BudgetName`]) and written as their text: a row that names an unknown one
//! does not read. [`RunOutput`] and [`base_record`] live here, shared by the in-process run
//! ([`crate::harness::run`], [`crate::harness::scene`]) and the isolation layer, so neither of
//! those modules imports the other.

use crate::harness::budget::{BudgetName, NamedBudget};
use crate::harness::case::{Case, CaseFamily, ProblemClass};
use crate::harness::machine::Machine;
use crate::harness::solver_spec::SolverSpec;
use lcpbench_solvers::{HistoryPoint, Status};
use serde::{Deserialize, Serialize};
use std::fmt;

/// The relative residuals at which time-to-accuracy is recorded.
pub const TTA_LEVELS: [f64; 4] = [1e-4, 1e-6, 1e-8, 1e-10];

/// One run: (case, solver, budget) and everything measured.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Case key (see [`crate::harness::case`]).
    pub case: String,
    /// Problem class (`spd`, `rank_deficient`, `non_symmetric`, `degenerate`, `infeasible`,
    /// `friction`, `scene`).
    pub class: ProblemClass,
    /// Family (`spd`, `psd`, ..., `file`, `scene`).
    pub family: CaseFamily,
    /// Rows of the LCP; for a scene, the largest number of LCP rows in a step.
    pub n: Option<usize>,
    /// Solver specification (`pgs`, `sor@omega=1.7`, `pgs+warm`, ...).
    pub solver: SolverSpec,
    /// Solver name without variant ([`SolverSpec::base_name`]).
    pub solver_base: String,
    /// SOR relaxation, when set.
    pub omega: Option<f64>,
    /// Warm start.
    pub warm: bool,
    /// Budget name.
    pub budget: BudgetName,
    /// Tolerance of the budget.
    pub tolerance: f64,
    /// Iteration cap of the budget.
    pub max_iterations: usize,
    /// Time budget in seconds.
    pub time_budget_s: f64,
    /// Outcome: a solver [`Status`] name for an LCP; for a scene `converged` when every step
    /// converged, otherwise `blow_up`, `time_limit` (the scene's wall-time limit) or the first
    /// non-converged step's status; for isolation failures `panic`, `crash`, `timeout` or
    /// `error`. See [`RunStatus`].
    pub status: RunStatus,
    /// Why, when there is a reason.
    pub reason: String,
    /// True when the run met its tolerance (every step, for a scene).
    pub converged: bool,
    /// Iterations or pivots (a scene: summed over steps).
    pub iterations: Option<usize>,
    /// Solver wall time in seconds, measurement excluded: for an LCP case the median of its
    /// timed solves from the same start ([`crate::harness::timing`]); for a scene summed over
    /// the steps, each solved once.
    pub solve_time_s: Option<f64>,
    /// Wall time of the whole child process, seen from the parent.
    pub wall_time_s: f64,
    /// Shared relative natural-map residual of the returned impulse (a scene: largest over steps).
    pub residual_rel: Option<f64>,
    /// Absolute natural-map residual (a scene: largest over steps).
    pub residual_abs: Option<f64>,
    /// Complementarity gap (a scene: largest over steps).
    pub complementarity_gap: Option<f64>,
    /// Bound violation (a scene: largest over steps).
    pub bound_violation: Option<f64>,
    /// `‖f − f*‖∞ / max(‖f*‖∞, 1)` against a planted solution known to be unique.
    pub solution_error: Option<f64>,
    /// Solver time in seconds until the relative residual first reached `1e-4`: the median
    /// over the timed solves that reached it ([`crate::harness::timing`]).
    pub tta_1e4: Option<f64>,
    /// Same, `1e-6`.
    pub tta_1e6: Option<f64>,
    /// Same, `1e-8`.
    pub tta_1e8: Option<f64>,
    /// Same, `1e-10`.
    pub tta_1e10: Option<f64>,
    /// Scene: steps taken.
    pub steps: Option<usize>,
    /// Scene: mean contacts per step.
    pub contacts_mean: Option<f64>,
    /// Scene: largest contact count in a step.
    pub contacts_max: Option<usize>,
    /// Scene: mean solver time per step, seconds.
    pub time_per_step_s: Option<f64>,
    /// Scene: mean wall time per step (detection, build, solve, integrate), seconds.
    pub step_time_s: Option<f64>,
    /// Scene: mean iterations per step.
    pub iterations_per_step: Option<f64>,
    /// Scene: mean relative residual over steps.
    pub residual_rel_mean: Option<f64>,
    /// Scene: steps whose solve did not converge.
    pub nonconverged_steps: Option<usize>,
    /// Scene: steps with a non-finite impulse or state.
    pub nan_steps: Option<usize>,
    /// Scene: steps whose solve gave up (`unsupported`, `no_solution`, `diverged` or
    /// `numerical_failure`): the step applied no impulse when the solver declined or returned a
    /// non-finite one, and otherwise the solver's last, unverified impulse.
    pub fallback_steps: Option<usize>,
    /// Scene: the state blew up: a non-finite body state or total energy, or a body speed above
    /// `50 + 10 v₀` m/s (`v₀` the largest initial speed); see [`crate::harness::metrics`].
    pub blow_up: Option<bool>,
    /// Scene: largest penetration depth over the run, metres.
    pub penetration_max: Option<f64>,
    /// Scene: mean over steps of the largest penetration, metres.
    pub penetration_mean: Option<f64>,
    /// Scene: total energy change over the run relative to the initial energy scale.
    pub energy_drift: Option<f64>,
    /// Scene: linear-momentum change relative to its scale (scenes that conserve it).
    pub momentum_drift: Option<f64>,
    /// Scene: drop of the top body below its rest height, metres (stacks).
    pub sag: Option<f64>,
    /// Scene: horizontal displacement of the top body, metres (stacks).
    pub lateral_drift: Option<f64>,
    /// Scene: name of the analytic quantity compared (from the scene's `[metrics]` table).
    pub analytic_metric: String,
    /// Scene: error against the analytic answer.
    pub analytic_error: Option<f64>,
    /// Scene: V-groove symmetry error `|F_left − F_right| / F_expected` at the last step.
    pub symmetry_error: Option<f64>,
    /// Scene (resting scenes): `|Σ support force − total weight| / total weight` at the last
    /// step, from the impulses on contacts with static bodies.
    pub support_error: Option<f64>,
    /// Scene: largest body speed over the run, m/s.
    pub max_speed: Option<f64>,
    /// Scene (resting scenes): largest body speed in the last tenth of the run, over the
    /// scene's `stick_bodies` when it names them, else over every dynamic body, m/s.
    pub creep_speed: Option<f64>,
    /// Scene (resting scenes): mean total kinetic energy over the last tenth of the run, J.
    pub ke_rest: Option<f64>,
    /// Scene: largest friction-cone violation `max(|f_t| − mu f_n, 0)` over steps.
    pub cone_violation: Option<f64>,
    /// Scene: largest separating normal speed at sliding contacts right after a solve, m/s
    /// (the lift-off that a convex relaxation of friction causes).
    pub liftoff_speed: Option<f64>,
    /// Scene: the steps the run was to take (`steps` is smaller when the run was cut short).
    pub steps_planned: Option<usize>,
    /// Scene: steps whose solve ran out of its per-step time budget.
    pub time_limit_steps: Option<usize>,
    /// Scene: the longest wall time of a step's solve phase, seconds.
    pub solve_wall_max_s: Option<f64>,
    /// Scene: median over the steps with contact rows of the step's relative residual.
    pub residual_rel_median: Option<f64>,
    /// Scene: mean wall time per step of the collision phase (events, broad and narrow phase),
    /// seconds. The six `phase_*` means without `broad`/`narrow` add up to `step_time_s`.
    pub phase_collision_s: Option<f64>,
    /// Scene: of `phase_collision_s`, the broad phase.
    pub phase_broad_s: Option<f64>,
    /// Scene: of `phase_collision_s`, the narrow phase.
    pub phase_narrow_s: Option<f64>,
    /// Scene: mean wall time per step of assembly (free velocities, `J`, `b`, bounds, the
    /// solvers' problems), seconds.
    pub phase_assembly_s: Option<f64>,
    /// Scene: mean wall time per step of the island partition, seconds.
    pub phase_islands_s: Option<f64>,
    /// Scene: mean wall time per step of the solver calls (their own measurements excluded),
    /// seconds.
    pub phase_solve_s: Option<f64>,
    /// Scene: mean wall time per step of residual measurement and the step's figures, seconds.
    pub phase_residual_s: Option<f64>,
    /// Scene: mean wall time per step of integration (split impulses, time of impact, warm-start
    /// cache), seconds.
    pub phase_integration_s: Option<f64>,
    /// LCP case: when the status is `diverged` or `no_solution` and a Farkas certificate read
    /// off the returned impulse was checked ([`lcpbench_solvers::certificate`]): the lower bound
    /// it proves on `‖f‖∞` of every solution, `inf` when it proves there is none.
    pub certificate_bound: Option<f64>,
    /// Scene: steps whose solve ended `no_solution` or `diverged` (the step's problem has no
    /// solution, or the impulse met the tolerance only by growing along a direction `A`
    /// cancels). Empty when the row does not record it.
    pub no_solution_steps: Option<usize>,
    /// Host name of the machine the run ran on (see [`Machine`]); empty when the row does not
    /// record it.
    pub host: Option<String>,
    /// CPU model of that machine.
    pub cpu_model: Option<String>,
    /// Logical cores available on that machine.
    pub cores: Option<usize>,
    /// Scene with joints: largest joint error over joints and steps, metres (anchor separation,
    /// or distance error; [`lcpbench_contact::joint::Joint::error`]).
    pub joint_drift_max: Option<f64>,
    /// Scene with joints: mean over steps of the mean joint error, metres.
    pub joint_drift_mean: Option<f64>,
    /// Scene with joints: largest angular joint error (hinge axes, fixed orientation), rad.
    pub joint_angle_max: Option<f64>,
    /// Scene naming a `sag_body`: its largest drop below its starting height, metres.
    pub sag_body: Option<f64>,
    /// File, scene-step and generated cases: how many timed solves from the same start
    /// `solve_time_s` is the median of, after one untimed first solve that warms the caches; 1
    /// when that first solve alone took 20 ms or more (or a repeat would have overrun the
    /// wall-time cap) and so is the measurement. See [`crate::harness::timing`].
    pub timed_solves: Option<usize>,
    /// File, scene-step and generated cases: the fastest of the timed solves, seconds.
    pub solve_time_min_s: Option<f64>,
    /// File, scene-step and generated cases: the slowest of the timed solves, seconds.
    pub solve_time_max_s: Option<f64>,
    /// Where a warm start came from ([`WarmSource::name`]): `previous step` (scenes), `file`
    /// (the problem file's `warm_start`), `20 PGS sweeps` (a file without one, a scene step),
    /// `perturbed planted solution` (generated cases); empty for a cold start.
    #[serde(default)]
    pub warm_source: String,
    /// Time to compute the warm start (the PGS sweeps), seconds, measured as the solve is
    /// ([`crate::harness::timing`]); not part of `solve_time_s`. Empty when the start costs
    /// nothing the solver would pay (cold, file, previous step, perturbed planted solution).
    pub warm_time_s: Option<f64>,
    /// Scene: mean over the steps of the substeps the solver split each step into (1 for the
    /// solvers that do not substep).
    pub substeps_per_step: Option<f64>,
    /// Scene: mean over the steps of the constraint-row updates, counted as Catto's solver
    /// comparison counts them: a substepping solver counts its own (every row update of every
    /// pass of every substep); for the others it is sweeps × rows (pivoting and
    /// interior-point solvers: iterations × rows, a stand-in). See
    /// [`lcpbench_contact::substep::StepCost`].
    pub row_updates_per_step: Option<f64>,
    /// Scene: mean over the steps of the passes over the bodies (velocity and position
    /// integration, Jacobi applies; 1 for the solvers that do not substep).
    pub body_passes_per_step: Option<f64>,
    /// Scene: mean wall time per step with the residual phase left out
    /// (`step_time_s − phase_residual_s`): what the step costs a simulation that does not
    /// measure the shared residual, seconds.
    pub step_time_no_residual_s: Option<f64>,
    /// Scene: which LCP the residual columns are of. Empty for the step's LCP; for a
    /// substepping solver the last solve of the last step with rows (`relax pass of substep 4
    /// of 4`), whose LCP has the step's `A` and that solve's `b`
    /// ([`lcpbench_contact::step::StepReport::residual_of`]).
    #[serde(default)]
    pub residual_of: String,
    /// Scene: steps whose shared residual was measured (with those that had no rows, whose
    /// residual is zero); below `steps` when the case's residual schedule
    /// (`scene:PATH?residual=sample=K`, `none`) left steps out. Only a measured step counts as
    /// converged or not (`nonconverged_steps` counts measured steps). Empty in rows of an
    /// lcpbench before this column, whose every step was measured.
    pub steps_measured: Option<usize>,
    /// Scene: mean wall time of the measured steps of `steps_measured` (the shared residual
    /// included), seconds.
    pub measured_step_time_s: Option<f64>,
    /// Scene: why each step that did not converge failed, one entry per step separated by
    /// spaces, `STEP:CATEGORY:RESIDUAL:ROWS:CONTACTS` (steps numbered from 0, as `lcpbench
    /// export --step`; `RESIDUAL` the step's shared relative residual, empty when it was not
    /// measured; `CATEGORY` one of [`crate::harness::step_failure::StepFailure::name`]). A measured step that did not
    /// converge and an unmeasured one whose solve gave up are listed; the first
    /// [`crate::harness::step_failure::FAILED_STEPS_KEPT`] of them. Empty when every step converged
    /// and in rows of an lcpbench before this column (see
    /// [`crate::harness::step_failure::parse_failed_steps`]).
    #[serde(default)]
    pub failed_steps: String,
}

impl RunRecord {
    /// Scene: the steps whose residual was measured, the steps taken for a row without the
    /// count (every step was measured before the column existed).
    pub fn measured_steps(&self) -> Option<usize> {
        self.steps_measured.or(self.steps)
    }

    /// Scene: the measured steps that converged (`measured_steps − nonconverged_steps`).
    pub fn converged_steps(&self) -> Option<usize> {
        Some(
            self.measured_steps()?
                .saturating_sub(self.nonconverged_steps?),
        )
    }

    /// The resume key: (case, solver, budget).
    pub fn key(&self) -> RunKey {
        RunKey::new(&self.case, &self.solver.to_string(), self.budget.as_str())
    }

    /// Time to reach relative residual `level` (one of [`TTA_LEVELS`]).
    pub fn tta(&self, level: f64) -> Option<f64> {
        if level >= 1e-4 {
            self.tta_1e4
        } else if level >= 1e-6 {
            self.tta_1e6
        } else if level >= 1e-8 {
            self.tta_1e8
        } else {
            self.tta_1e10
        }
    }

    /// Set the time-to-accuracy columns from a list aligned with [`TTA_LEVELS`].
    pub fn set_tta(&mut self, values: [Option<f64>; 4]) {
        [self.tta_1e4, self.tta_1e6, self.tta_1e8, self.tta_1e10] = values;
    }

    /// True for failures of the isolation layer (`panic`, `crash`, `timeout`, `error`).
    pub fn is_isolation_failure(&self) -> bool {
        self.status.is_isolation_failure()
    }

    /// The machine the run ran on, when the row records it.
    pub fn machine(&self) -> Option<Machine> {
        Some(Machine {
            host: self.host.clone()?,
            cpu_model: self.cpu_model.clone()?,
            cores: self.cores?,
        })
    }

    /// Record that the run ran on `machine`.
    pub fn set_machine(&mut self, machine: &Machine) {
        self.host = Some(machine.host.clone());
        self.cpu_model = Some(machine.cpu_model.clone());
        self.cores = Some(machine.cores);
    }
}

/// Where the warm start of a `+warm` run came from: the `warm_source` column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WarmSource {
    /// Scenes: each step starts from the previous step's impulses.
    PreviousStep,
    /// A problem file's own `warm_start` (as `lcpbench export` writes for a warm-started step).
    File,
    /// [`WARM_PGS_SWEEPS`] cold PGS sweeps computed by the harness (files without a warm start,
    /// scene steps); their cost is the `warm_time_s` column.
    PgsSweeps,
    /// Generated cases: the planted solution perturbed by 1% of its largest entry, standing in
    /// for the previous step of a slowly changing scene; it costs the solver nothing.
    PerturbedPlanted,
}

/// The PGS sweeps of [`WarmSource::PgsSweeps`].
pub const WARM_PGS_SWEEPS: usize = 20;

impl WarmSource {
    /// The text of the `warm_source` column.
    pub fn name(self) -> &'static str {
        match self {
            WarmSource::PreviousStep => "previous step",
            WarmSource::File => "file",
            WarmSource::PgsSweeps => "20 PGS sweeps",
            WarmSource::PerturbedPlanted => "perturbed planted solution",
        }
    }
}

/// The outcome of one run, as written in the `status` column: the kinds of the solver
/// [`Status`] (without their reasons, which go to the `reason` column) and the harness's own
/// outcomes. The text forms are the CSV's: `converged`, `iteration_limit`, `time_limit`,
/// `stalled`, `no_solution`, `diverged`, `unsupported`, `numerical_failure`, `blow_up`, `panic`,
/// `crash`, `timeout`, `error`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RunStatus {
    /// The shared residual met the tolerance (every step, for a scene).
    Converged,
    /// The solver's iteration cap was reached.
    IterationLimit,
    /// The solver's time budget ran out, or a scene stopped stepping at its wall-time limit.
    TimeLimit,
    /// The solver stopped making progress.
    Stalled,
    /// The solver showed the problem has no solution.
    NoSolution,
    /// The residual met the tolerance only through cancellation: the impulse grew along a
    /// direction `A` cancels.
    Diverged,
    /// The solver does not take this problem (or this scene's friction model).
    Unsupported,
    /// The solver failed numerically.
    NumericalFailure,
    /// Scene: the state became non-finite, or a speed went far beyond the initial ones.
    BlowUp,
    /// Isolation: the child panicked.
    Panic,
    /// Isolation: the child was killed by a signal (an abort, a stack overflow).
    Crash,
    /// Isolation: the child outlived its wall-time limit and was killed.
    Timeout,
    /// The run could not be carried out (unreadable case, bad child output, …). Also the
    /// value of a row not yet filled.
    #[default]
    Error,
}

impl RunStatus {
    /// Every status, in the order above.
    pub const ALL: [RunStatus; 13] = [
        RunStatus::Converged,
        RunStatus::IterationLimit,
        RunStatus::TimeLimit,
        RunStatus::Stalled,
        RunStatus::NoSolution,
        RunStatus::Diverged,
        RunStatus::Unsupported,
        RunStatus::NumericalFailure,
        RunStatus::BlowUp,
        RunStatus::Panic,
        RunStatus::Crash,
        RunStatus::Timeout,
        RunStatus::Error,
    ];

    /// The CSV name.
    pub fn as_str(self) -> &'static str {
        match self {
            RunStatus::Converged => "converged",
            RunStatus::IterationLimit => "iteration_limit",
            RunStatus::TimeLimit => "time_limit",
            RunStatus::Stalled => "stalled",
            RunStatus::NoSolution => "no_solution",
            RunStatus::Diverged => "diverged",
            RunStatus::Unsupported => "unsupported",
            RunStatus::NumericalFailure => "numerical_failure",
            RunStatus::BlowUp => "blow_up",
            RunStatus::Panic => "panic",
            RunStatus::Crash => "crash",
            RunStatus::Timeout => "timeout",
            RunStatus::Error => "error",
        }
    }

    /// True for `converged`.
    pub fn is_converged(self) -> bool {
        self == RunStatus::Converged
    }

    /// True for failures of the isolation layer (`panic`, `crash`, `timeout`, `error`).
    pub fn is_isolation_failure(self) -> bool {
        matches!(
            self,
            RunStatus::Panic | RunStatus::Crash | RunStatus::Timeout | RunStatus::Error
        )
    }
}

impl From<&Status> for RunStatus {
    fn from(status: &Status) -> Self {
        match status {
            Status::Converged => RunStatus::Converged,
            Status::IterationLimit => RunStatus::IterationLimit,
            Status::TimeLimit => RunStatus::TimeLimit,
            Status::Stalled { .. } => RunStatus::Stalled,
            Status::NoSolution { .. } => RunStatus::NoSolution,
            Status::Diverged { .. } => RunStatus::Diverged,
            Status::Unsupported { .. } => RunStatus::Unsupported,
            Status::NumericalFailure { .. } => RunStatus::NumericalFailure,
        }
    }
}

impl fmt::Display for RunStatus {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.pad(self.as_str())
    }
}

impl std::str::FromStr for RunStatus {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.as_str() == s)
            .ok_or_else(|| format!("unknown run status `{s}`"))
    }
}

impl Serialize for RunStatus {
    fn serialize<S: serde::Serializer>(&self, out: S) -> Result<S::Ok, S::Error> {
        out.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for RunStatus {
    fn deserialize<D: serde::Deserializer<'de>>(input: D) -> Result<Self, D::Error> {
        let s = String::deserialize(input)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// What identifies a run (and a row of `results.csv`): case key, solver specification and
/// budget name, as written in the CSV.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RunKey {
    /// Case key (see [`Case`]'s `Display`).
    pub case: String,
    /// Solver specification (see [`SolverSpec`]'s `Display`).
    pub solver: String,
    /// Budget name.
    pub budget: String,
}

impl RunKey {
    /// The key of a row with these columns.
    pub fn new(case: &str, solver: &str, budget: &str) -> Self {
        Self {
            case: case.to_owned(),
            solver: solver.to_owned(),
            budget: budget.to_owned(),
        }
    }

    /// The key of the run of `solver` on `case` under the budget called `budget`.
    pub fn of(case: &Case, solver: &SolverSpec, budget: &BudgetName) -> Self {
        Self {
            case: case.to_string(),
            solver: solver.to_string(),
            budget: budget.to_string(),
        }
    }
}

impl fmt::Display for RunKey {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(out, "{} / {} / {}", self.case, self.solver, self.budget)
    }
}

/// What a run produced: the row and the convergence history (LCP cases; thinned).
#[derive(Debug, Clone)]
pub struct RunOutput {
    /// The result row.
    pub record: RunRecord,
    /// Residual history of the solve (LCP cases), at most
    /// [`HISTORY_POINTS`](crate::harness::run::HISTORY_POINTS) points.
    pub history: Vec<HistoryPoint>,
}

impl RunOutput {
    /// A row without history.
    pub fn row(record: RunRecord) -> Self {
        Self {
            record,
            history: Vec::new(),
        }
    }

    /// A row that ends with `status` and `reason` before anything was measured.
    pub fn failed(mut record: RunRecord, status: RunStatus, reason: impl Into<String>) -> Self {
        record.status = status;
        record.reason = reason.into();
        Self::row(record)
    }
}

/// The row fields every run fills: case, solver and budget identification.
pub fn base_record(case: &Case, solver: &SolverSpec, budget: &NamedBudget) -> RunRecord {
    RunRecord {
        case: case.to_string(),
        class: case.class(),
        family: case.family(),
        n: case.size(),
        solver: solver.clone(),
        solver_base: solver.base_name(),
        omega: solver.omega(),
        warm: solver.warm(),
        budget: budget.name.clone(),
        tolerance: budget.budget.tolerance,
        max_iterations: budget.budget.max_iterations,
        time_budget_s: budget.budget.time_s,
        ..RunRecord::default()
    }
}

/// One point of a convergence history, as stored in `histories.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryRow {
    /// Case key.
    pub case: String,
    /// Solver specification.
    pub solver: SolverSpec,
    /// Budget name.
    pub budget: BudgetName,
    /// Iteration or pivot count.
    pub iteration: usize,
    /// Solver time so far, seconds.
    pub time_s: f64,
    /// Relative natural-map residual.
    pub residual: f64,
}

impl HistoryRow {
    /// The key of the run this point belongs to.
    pub fn key(&self) -> RunKey {
        RunKey::new(&self.case, &self.solver.to_string(), self.budget.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_round_trip_through_their_csv_names() {
        for status in RunStatus::ALL {
            assert_eq!(status.as_str().parse::<RunStatus>(), Ok(status));
            assert_eq!(status.to_string(), status.as_str());
        }
        assert!("Converged".parse::<RunStatus>().is_err());
        let solver = Status::NoSolution {
            reason: "ray".into(),
        };
        assert_eq!(RunStatus::from(&solver).as_str(), solver.name());
    }

    #[test]
    fn records_serialise_the_status_as_its_name() {
        let record = RunRecord {
            status: RunStatus::BlowUp,
            ..RunRecord::default()
        };
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(&record).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert!(text.contains(",blow_up,"), "{text}");
        let back: RunRecord = csv::Reader::from_reader(text.as_bytes())
            .deserialize()
            .next()
            .unwrap()
            .unwrap();
        assert_eq!(back.status, RunStatus::BlowUp);
    }

    /// The typed columns are written as the text they were parsed from, and a row whose solver
    /// or budget names nothing known does not read.
    #[test]
    fn typed_columns_round_trip_and_unknown_names_are_refused() {
        let case: Case = "psd:n=20:rank=5:seed=2".parse().unwrap();
        let solver: SolverSpec = "sor@omega=1.7+warm".parse().unwrap();
        let budget: NamedBudget = "1e-6:20:1".parse().unwrap();
        let record = base_record(&case, &solver, &budget);
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(&record).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        let row = text.lines().nth(1).unwrap();
        assert!(
            row.starts_with(
                "psd:n=20:rank=5:seed=2,rank_deficient,psd,20,sor@omega=1.7+warm,sor,1.7,true,\
                 1e-6:20:1,"
            ),
            "{row}"
        );
        let read = |text: &str| -> Result<RunRecord, csv::Error> {
            csv::Reader::from_reader(text.as_bytes())
                .deserialize()
                .next()
                .unwrap()
        };
        assert_eq!(read(&text).unwrap(), record);
        assert!(read(&text.replace(",sor@omega=1.7+warm,", ",sro@omega=1.7+warm,")).is_err());
        // A row written before parameters were `key=value` reads as the same run.
        assert_eq!(
            read(&text.replace(",sor@omega=1.7+warm,", ",sor@1.7+warm,")).unwrap(),
            record
        );
        assert!(read(&text.replace(",1e-6:20:1,", ",tigth,")).is_err());
        assert!(read(&text.replace(",rank_deficient,", ",rank-deficient,")).is_err());
    }
}

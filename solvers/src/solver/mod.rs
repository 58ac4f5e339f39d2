//! The interface every solver implements: shared [`Settings`], a [`Status`] decided by the shared
//! residual, and a [`SolveResult`] carrying the impulse, timings and convergence history.

pub mod line_search;
mod settings;

pub use settings::{Settings, SettingsError};

use crate::problem::certificate::{certificate_from, Certificate};
use crate::problem::metrics::{residuals_and_velocity, unresolved_row, Residuals, RESOLUTION};
use crate::problem::Problem;
use serde::Serialize;
use std::time::{Duration, Instant};

/// How a solve ended. Decided from the shared residual recomputed from the returned `f`:
/// `Converged` if and only if `natural_map_rel <= tolerance` and every row is resolved against
/// the problem's data ([`crate::problem::metrics::unresolved_row`]); a result that meets the tolerance
/// only through cancellation is `Diverged`, or `NoSolution` when a Farkas certificate read off it
/// proves there is no solution. A cone result must also resolve every contact's normal
/// complementarity ([`crate::cone::normal_unresolved`]); one that does not is `Stalled`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Status {
    /// The shared residual of the returned `f` is within tolerance.
    Converged,
    /// The iteration or pivot cap was reached with the residual above tolerance.
    IterationLimit,
    /// The time budget ran out with the residual above tolerance.
    TimeLimit,
    /// The solver met its own stopping rule, but the shared residual is above tolerance (or,
    /// for a cone problem, within it with a contact's normal complementarity unresolved).
    Stalled {
        /// Why.
        reason: String,
    },
    /// The solver proved there is no solution (Lemke's ray termination, an infeasibility
    /// certificate).
    NoSolution {
        /// Why.
        reason: String,
    },
    /// The relative residual met the tolerance only through cancellation: a row's natural-map
    /// step is a sizeable share of the velocities the problem's data produce, and the row's
    /// terms exceed them by so much that the step is small beside the terms. What an impulse
    /// growing along a direction that `A` cancels looks like (a problem without a solution, or
    /// with none of moderate size); no proof of either.
    Diverged {
        /// Why.
        reason: String,
    },
    /// The solver does not handle this problem class.
    Unsupported {
        /// Why.
        reason: String,
    },
    /// Breakdown: singular pivot, non-finite values, a failed factorisation.
    NumericalFailure {
        /// Why.
        reason: String,
    },
}

impl Status {
    /// `snake_case` name of the variant, as used in JSON and CSV output.
    pub fn name(&self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::IterationLimit => "iteration_limit",
            Status::TimeLimit => "time_limit",
            Status::Stalled { .. } => "stalled",
            Status::NoSolution { .. } => "no_solution",
            Status::Diverged { .. } => "diverged",
            Status::Unsupported { .. } => "unsupported",
            Status::NumericalFailure { .. } => "numerical_failure",
        }
    }

    /// The reason string, if the variant has one.
    pub fn reason(&self) -> Option<&str> {
        match self {
            Status::Stalled { reason }
            | Status::NoSolution { reason }
            | Status::Diverged { reason }
            | Status::Unsupported { reason }
            | Status::NumericalFailure { reason } => Some(reason),
            _ => None,
        }
    }

    /// True for `Converged`.
    pub fn is_converged(&self) -> bool {
        matches!(self, Status::Converged)
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, fmt: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.reason() {
            Some(r) => write!(fmt, "{} ({r})", self.name()),
            None => write!(fmt, "{}", self.name()),
        }
    }
}

/// One point of a convergence history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HistoryPoint {
    /// Iteration (or pivot) count after which the residual was measured.
    pub iteration: usize,
    /// Relative natural-map residual at that point.
    pub residual: f64,
    /// Solver wall time up to that point, measurement time excluded.
    pub time_s: f64,
}

/// Everything a solve returns.
#[derive(Debug, Clone, PartialEq)]
pub struct SolveResult {
    /// The impulse.
    pub f: Vec<f64>,
    /// `w = A f + b` at the returned impulse.
    pub w: Vec<f64>,
    /// How it ended.
    pub status: Status,
    /// Iterations or pivots used (see [`Settings::max_iterations`]).
    pub iterations: usize,
    /// Solver wall time, history measurement excluded.
    pub time: Duration,
    /// The shared residuals of the returned `f`.
    pub residuals: Residuals,
    /// Residual after each iteration, when [`Settings::record_history`] was set.
    pub history: Vec<HistoryPoint>,
    /// For pivoting solvers with [`Settings::record_history`] set: after each pivot, the pivot
    /// count and the rows in the active set (Lemke's basic `f` variables, Dantzig's clamped
    /// set). Empty otherwise.
    pub active_sets: Vec<(usize, Vec<usize>)>,
    /// For a `Diverged` or `NoSolution` status decided from the returned impulse: the Farkas
    /// certificate read off it ([`crate::certificate`]), when it bounds the size of every
    /// solution. `None` otherwise.
    pub certificate: Option<Certificate>,
}

/// A contact solver: takes a problem, returns an impulse and an honest status.
///
/// Every solver is `Clone` (through [`dyn_clone::DynClone`]), so a configured instance can be
/// copied, for example one per island of a time step. A clone carries the solver's parameters and
/// whatever workspace it keeps between solves (only [`crate::Newton`] keeps one: the last
/// symbolic factorisation, reused only while the sparsity pattern is unchanged, so a clone
/// gives bit-identical answers to a fresh solver of the same parameters).
pub trait Solver: dyn_clone::DynClone {
    /// The solver's entry in the [`registry`](crate::registry): its name, description and
    /// parameters.
    fn entry(&self) -> &'static crate::registry::SolverEntry;
    /// Short name (`pgs`, `lemke`, ...), its entry's.
    fn name(&self) -> &'static str {
        self.entry().name
    }
    /// Solve. Never panics on a valid [`Problem`]; every outcome is a [`Status`].
    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult;
    /// True when the solver works on the factors `J`, `M⁻¹` of a factored problem
    /// ([`Problem::boxed_factored`]) without reading the rows of `A`, so that a caller holding
    /// the factors need not assemble `A` for it \[`false`: the solver reads rows of `A`, which a
    /// factored problem then assembles on first use\].
    fn works_on_factors(&self) -> bool {
        false
    }
}

dyn_clone::clone_trait_object!(Solver);

/// What a solver's own loop concluded, before the shared residual has its say. Public so that
/// solvers outside this crate (the body-level solvers of `lcpbench-contact`) decide their status
/// with the same rule ([`decide`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The solver's own stopping rule was met.
    Stopped,
    /// The solver stopped for a reason it states (no proof of anything).
    Stalled(String),
    /// The iteration or pivot cap was reached.
    IterationLimit,
    /// The time budget ran out.
    TimeLimit,
    /// Proof of no solution.
    NoSolution(String),
    /// A part of the problem (an island) ended `Diverged`, for this reason.
    Diverged(String),
    /// Problem class not handled.
    Unsupported(String),
    /// Breakdown.
    NumericalFailure(String),
}

impl Outcome {
    /// The outcome a finished solve's status stands for (`Converged`: the solver's own rule
    /// stopped it; `Stalled` keeps its reason, so an island's or an equilibrated solve's
    /// diagnosis reaches the caller's status when the residual there is short of tolerance).
    pub fn of(status: Status) -> Self {
        match status {
            Status::Converged => Outcome::Stopped,
            Status::Stalled { reason } => Outcome::Stalled(reason),
            Status::IterationLimit => Outcome::IterationLimit,
            Status::TimeLimit => Outcome::TimeLimit,
            Status::NoSolution { reason } => Outcome::NoSolution(reason),
            Status::Diverged { reason } => Outcome::Diverged(reason),
            Status::Unsupported { reason } => Outcome::Unsupported(reason),
            Status::NumericalFailure { reason } => Outcome::NumericalFailure(reason),
        }
    }
}

/// The symmetric equilibration `s_i = 1/√d_i` of `problem` (`d` its
/// [diagonal scale](Problem::diagonal_scale); the scaled problem `S A S` is
/// [`Problem::scaled_symmetric`]), so that a solver whose internal tolerances are absolute sees
/// rows and columns of comparable size. `None` when the diagonal already spans less than
/// [`EQUILIBRATE_ABOVE`]: the problem is then solved as it is (the copy would cost more than it
/// gains on small problems).
pub(crate) fn equilibration(problem: &Problem) -> Option<Vec<f64>> {
    let d = problem.diagonal_scale();
    let (dmin, dmax) = d.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    (dmax > EQUILIBRATE_ABOVE * dmin).then(|| d.iter().map(|d| 1.0 / d.sqrt()).collect())
}

/// Spread of the diagonal `max d / min d` above which [`equilibration`] scales.
pub(crate) const EQUILIBRATE_ABOVE: f64 = 100.0;

/// A problem class whose results a [`Monitor`] judges: its shared residual (the only status
/// decider) and the words its status reasons use for the unknown and the velocity.
pub(crate) trait Measured {
    /// The unknown in reasons: `("impulse", "f")` for an LCP.
    const UNKNOWN: (&'static str, &'static str);
    /// The velocity in reasons: `"w = A f + b"` for an LCP.
    const VELOCITY: &'static str;
    /// Number of rows.
    fn rows(&self) -> usize;
    /// The velocity at `x`.
    fn velocity_at(&self, x: &[f64]) -> Vec<f64>;
    /// The shared residuals of `x`, writing the velocity into `v` in the same pass.
    fn measure(&self, x: &[f64], v: &mut [f64]) -> Residuals;
    /// For a finite `x` whose relative residual meets the tolerance `tol`: the status that says
    /// it does so only through cancellation (an LCP row unresolved against the data) or with a
    /// cone contact's normal complementarity unresolved, with the certificate read off `x`, if
    /// any (`None`: `x` is resolved, the status stays `Converged`).
    fn cancellation(&self, x: &[f64], v: &[f64], tol: f64)
        -> Option<(Status, Option<Certificate>)>;
}

impl Measured for Problem {
    const UNKNOWN: (&'static str, &'static str) = ("impulse", "f");
    const VELOCITY: &'static str = "w = A f + b";
    fn rows(&self) -> usize {
        self.n()
    }
    fn velocity_at(&self, f: &[f64]) -> Vec<f64> {
        self.velocity(f)
    }
    fn measure(&self, f: &[f64], w: &mut [f64]) -> Residuals {
        residuals_and_velocity(self, f, w)
    }
    fn cancellation(
        &self,
        f: &[f64],
        w: &[f64],
        _tol: f64,
    ) -> Option<(Status, Option<Certificate>)> {
        lcp_cancellation(self, f, w)
    }
}

/// The data-resolution test of a finite LCP impulse `f` (with `w = A f + b`) that meets the
/// tolerance ([`crate::problem::metrics::unresolved_row`]): `None` when every row is resolved; otherwise
/// `NoSolution` when the Farkas certificate read off `f` ([`certificate_from`]) proves there is
/// no solution, and `Diverged` else, with the certificate when it bounds the size of every
/// solution.
fn lcp_cancellation(
    problem: &Problem,
    f: &[f64],
    w: &[f64],
) -> Option<(Status, Option<Certificate>)> {
    let u = unresolved_row(problem, f, w)?;
    let i = u.row;
    let certificate = certificate_from(problem, f);
    let largest = f.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let found = if u.step >= u.round_off {
        format!(
            "row {i}: natural-map step {:.3e}, {:.2} of the velocity {:.3e} the data put into \
             the row (resolved: at most {RESOLUTION}) but {:.1e} of the magnitude {:.3e} of its \
             terms; the residual meets the tolerance only because those terms cancel",
            u.step,
            u.step / u.data_scale,
            u.data_scale,
            u.step / u.magnitude,
            u.magnitude
        )
    } else {
        format!(
            "row {i}: the round-off {:.3e} of its terms (magnitude {:.3e}) is {:.2} of the \
             velocity {:.3e} the data put into the row (resolved: at most {RESOLUTION}); the \
             data are lost in the rounding of terms that cancel",
            u.round_off,
            u.magnitude,
            u.round_off / u.data_scale,
            u.data_scale
        )
    };
    let status = match &certificate {
        Some(c) if c.proves_no_solution => Status::NoSolution {
            reason: format!(
                "{found}; the Farkas certificate read off the impulse (bᵀy = {:.3e} < 0, \
                 Aᵀy <= 0 where f is unbounded, checked exactly) proves there is no solution",
                c.b_dot_y
            ),
        },
        Some(c) => Status::Diverged {
            reason: format!(
                "{found}; a Farkas certificate read off the impulse shows every solution has \
                 ‖f‖∞ >= {:.3e} (this impulse: {largest:.3e})",
                c.min_solution_norm
            ),
        },
        None => Status::Diverged {
            reason: format!("{found} (‖f‖∞ = {largest:.3e})"),
        },
    };
    Some((status, certificate))
}

/// The status of a finite LCP impulse `f` with velocity `w = A f + b` and shared residuals
/// `residuals`, given the solver's own `outcome`: [`decide`] on the relative residual, then,
/// when that says `Converged`, the data-resolution test with its certificate. The rule every
/// matrix solver's [`Monitor`] applies, for solvers outside this crate (the body-level solvers
/// of `lcpbench-contact`).
pub fn judge(
    problem: &Problem,
    f: &[f64],
    w: &[f64],
    residuals: &Residuals,
    outcome: Outcome,
    tol: f64,
) -> (Status, Option<Certificate>) {
    match decide(outcome, residuals.natural_map_rel, tol) {
        Status::Converged => lcp_cancellation(problem, f, w).unwrap_or((Status::Converged, None)),
        status => (status, None),
    }
}

/// Clock, time budget and history recorder for one solve, and the status decision from the
/// shared residual of the problem class `P` (the boxed LCP by default; [`crate::cone`] uses it
/// for the Coulomb cone). Solver bodies stay the textbook algorithm and call
/// [`Monitor::record`] once per iteration.
pub(crate) struct Monitor<'a, P: Measured = Problem> {
    problem: &'a P,
    settings: &'a Settings,
    start: Instant,
    excluded: Duration,
    history: Vec<HistoryPoint>,
    active_sets: Vec<(usize, Vec<usize>)>,
    /// The last point measured by [`Monitor::residual_of`], with its velocity and residuals.
    measured: Option<(Vec<f64>, Vec<f64>, Residuals)>,
}

impl<'a, P: Measured> Monitor<'a, P> {
    pub(crate) fn new(problem: &'a P, settings: &'a Settings) -> Self {
        Self {
            problem,
            settings,
            start: Instant::now(),
            excluded: Duration::ZERO,
            history: Vec::new(),
            active_sets: Vec::new(),
            measured: None,
        }
    }

    /// The shared relative residual of `x` (a solver's own stopping test on a candidate). The
    /// point is kept with its velocity and residuals: when it is bit for bit the impulse the
    /// solve returns, [`Monitor::finish`] decides from them instead of measuring it again.
    pub(crate) fn residual_of(&mut self, x: &[f64]) -> f64 {
        let mut v = vec![0.0; self.problem.rows()];
        let res = self.problem.measure(x, &mut v);
        self.measured = Some((x.to_vec(), v, res));
        res.natural_map_rel
    }

    /// Solver time so far, history measurement excluded.
    pub(crate) fn elapsed(&self) -> Duration {
        self.start.elapsed().saturating_sub(self.excluded)
    }

    /// True when the time budget is spent.
    pub(crate) fn out_of_time(&self) -> bool {
        self.settings
            .time_budget
            .is_some_and(|budget| self.elapsed() >= budget)
    }

    /// True when a step taking `next` would end past the time budget: solvers whose steps
    /// cannot be interrupted (a factorisation) do not start one their last step says cannot
    /// finish in time.
    pub(crate) fn cannot_fit(&self, next: Duration) -> bool {
        self.settings
            .time_budget
            .is_some_and(|budget| self.elapsed() + next > budget)
    }

    /// Record the shared residual of `f` after `iteration`, if history is on.
    pub(crate) fn record(&mut self, iteration: usize, f: &[f64]) {
        if !self.settings.record_history {
            return;
        }
        let t0 = Instant::now();
        let time_s = self.elapsed().as_secs_f64();
        let mut w = vec![0.0; self.problem.rows()];
        let residual = self.problem.measure(f, &mut w).natural_map_rel;
        self.history.push(HistoryPoint {
            iteration,
            residual,
            time_s,
        });
        self.excluded += t0.elapsed();
    }

    /// Record the active set after `pivot`, if history is on.
    pub(crate) fn record_active_set(&mut self, pivot: usize, active: impl FnOnce() -> Vec<usize>) {
        if self.settings.record_history {
            let t0 = Instant::now();
            self.active_sets.push((pivot, active()));
            self.excluded += t0.elapsed();
        }
    }

    /// Decide the status from the shared residual of `f` and package the result.
    pub(crate) fn finish(
        mut self,
        f: Vec<f64>,
        iterations: usize,
        outcome: Outcome,
    ) -> SolveResult {
        // Settings the library refuses end the solve before its result is read: a tolerance of 1
        // or more would otherwise call a zero impulse converged.
        let outcome = match self.settings.validate() {
            Ok(()) => outcome,
            Err(e) => Outcome::Unsupported(format!("invalid settings: {e}")),
        };
        let measured = self.measured.take().filter(|(x, ..)| {
            x.len() == f.len() && x.iter().zip(&f).all(|(a, b)| a.to_bits() == b.to_bits())
        });
        let time = self.elapsed();
        let problem = self.problem;
        let tol = self.settings.tolerance;
        let n = problem.rows();
        let (noun, symbol) = P::UNKNOWN;
        let mut certificate = None;
        let (f, w, res, status) = if let Outcome::Unsupported(reason) = outcome {
            let f = vec![0.0; n];
            let mut w = vec![0.0; n];
            let res = problem.measure(&f, &mut w);
            (f, w, res, Status::Unsupported { reason })
        } else if f.len() != n {
            let reason = format!("solver returned {} values for {n} rows", f.len());
            let w = vec![f64::NAN; n];
            (
                f,
                w,
                Residuals::INFINITE,
                Status::NumericalFailure { reason },
            )
        } else if let Some(reason) = non_finite_reason(&f, noun, symbol) {
            let w = problem.velocity_at(&f);
            (
                f,
                w,
                Residuals::INFINITE,
                Status::NumericalFailure { reason },
            )
        } else if measured.is_none() && !self.settings.measure_result {
            let status = unmeasured_status(outcome);
            (f, Vec::new(), Residuals::NOT_MEASURED, status)
        } else {
            let (w, res) = match measured {
                Some((_, w, res)) => (w, res),
                None => {
                    let mut w = vec![0.0; n];
                    let res = problem.measure(&f, &mut w);
                    (w, res)
                }
            };
            let status = if w.iter().any(|v| !v.is_finite()) {
                Status::NumericalFailure {
                    reason: format!(
                        "the velocity {} overflows at the returned {noun}",
                        P::VELOCITY
                    ),
                }
            } else {
                match decide(outcome, res.natural_map_rel, tol) {
                    Status::Converged => match problem.cancellation(&f, &w, tol) {
                        Some((status, c)) => {
                            certificate = c;
                            status
                        }
                        None => Status::Converged,
                    },
                    status => status,
                }
            };
            (f, w, res, status)
        };
        SolveResult {
            f,
            w,
            status,
            iterations,
            time,
            residuals: res,
            history: self.history,
            active_sets: self.active_sets,
            certificate,
        }
    }
}

/// The never-spin rule of the iterative solvers: a measure of the residual (the shared
/// residual where the solver measures it, or the solver's own per-iteration estimate of it) must
/// reach a new low, at least [`STAGNATION_DROP`] below the best so far, once in every `window`
/// iterations. A solve whose measure has not done so has stagnated: continuing cannot meet the
/// tolerance within any cap the harness uses (at a per-window decrease of under 1 %, reaching
/// `1e-8` from `1` takes over 1,800 windows), so the solver stops with
/// [`Outcome::Stalled`] (or restarts, as [`crate::Newton`] does from a warm start) instead of
/// spinning to its iteration cap. Measured on the iteration counter, so the bound on wasted work
/// is `window` iterations whatever their cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stagnation {
    window: usize,
    best: f64,
    best_at: usize,
}

/// Relative decrease of the best residual measure that counts as progress for [`Stagnation`].
pub const STAGNATION_DROP: f64 = 0.01;

/// The [`Stagnation`] window of the first-order methods (PGS, SOR, NSGS, APGD, NNCG,
/// micro-impulses, and the body-level sequential and micro-impulses of `lcpbench-contact`), in
/// sweeps or sweep-equivalents. Their largest residual is a maximum over
/// rows and falls in steps: on the hardest exported step of the report (a 1,155-row island of
/// `sphere_pile_200`, tolerance `1e-8`) NNCG went 2,179 sweeps and SOR 1,066 without a 1 %
/// new low before converging, and PGS 4,316 before its next one. 5,000 leaves room for those
/// and still ends a stalled solve at half the default cap of 10,000 (a twentieth of `tight`'s).
pub const FIRST_ORDER_STAGNATION_WINDOW: usize = 5_000;

/// How often, in sweeps, the first-order methods that do not measure the shared residual every
/// sweep (PGS, SOR, NSGS, micro-impulses) measure it for the [`Stagnation`] rule: one extra pass
/// over `A` per 50 sweeps.
pub const STAGNATION_MEASURE_EVERY: usize = 50;

impl Stagnation {
    /// A detector that allows `window` iterations without a new low.
    pub fn new(window: usize) -> Self {
        Self {
            window: window.max(1),
            best: f64::INFINITY,
            best_at: 0,
        }
    }

    /// Watch the measure `value` after `iteration`; true when the last `window` iterations gave
    /// no new low. A NaN measure is no progress.
    pub fn stagnated(&mut self, iteration: usize, value: f64) -> bool {
        if value < self.best * (1.0 - STAGNATION_DROP)
            || (self.best.is_infinite() && value.is_finite())
        {
            self.best = value;
            self.best_at = iteration;
        }
        iteration.saturating_sub(self.best_at) >= self.window
    }

    /// Forget the history from `iteration` on (a restart).
    pub fn restart(&mut self, iteration: usize) {
        self.best = f64::INFINITY;
        self.best_at = iteration;
    }

    /// The reason a stagnated solve gives.
    pub fn reason(&self, measure: &str) -> String {
        format!(
            "no progress: the best {measure} ({:.3e}) has not fallen by {:.0} % in the last {} \
             iterations",
            self.best,
            100.0 * STAGNATION_DROP,
            self.window
        )
    }
}

/// Why `x` is not a usable answer, when one of its entries is not finite:
/// `non-finite {noun} {symbol}[i] = value` for the first such entry (the reason of
/// [`Status::NumericalFailure`] that every monitor gives).
pub fn non_finite_reason(x: &[f64], noun: &str, symbol: &str) -> Option<String> {
    x.iter()
        .position(|v| !v.is_finite())
        .map(|i| format!("non-finite {noun} {symbol}[{i}] = {}", x[i]))
}

/// The status of a finite result from its relative residual `rel` and the solver's own outcome:
/// `Converged` if and only if `rel <= tol` (shared by the LCP and the cone monitors, and by the
/// body-level solvers of `lcpbench-contact`). A `rel` of NaN (nothing measured) never converges.
/// A `Converged` here is provisional: the monitors and [`judge`] then apply the data-resolution
/// test.
pub fn decide(outcome: Outcome, rel: f64, tol: f64) -> Status {
    if rel <= tol {
        return Status::Converged;
    }
    match outcome {
        Outcome::Stopped => Status::Stalled {
            reason: format!(
                "stopping rule met at relative residual {rel:.3e} > tolerance {tol:.1e}"
            ),
        },
        Outcome::Stalled(reason) => Status::Stalled { reason },
        Outcome::IterationLimit => Status::IterationLimit,
        Outcome::TimeLimit => Status::TimeLimit,
        Outcome::NoSolution(reason) => Status::NoSolution { reason },
        Outcome::Diverged(reason) => Status::Diverged { reason },
        Outcome::NumericalFailure(reason) => Status::NumericalFailure { reason },
        Outcome::Unsupported(reason) => Status::Unsupported { reason },
    }
}

/// The status of a finite result whose shared residual was not measured
/// ([`Settings::measure_result`] off): never `Converged`; a stopping rule met is `Stalled` with
/// a reason saying so, every other outcome keeps its status.
fn unmeasured_status(outcome: Outcome) -> Status {
    match outcome {
        Outcome::Stopped => Status::Stalled {
            reason: "the solver met its own stopping rule; the shared residual was not measured"
                .into(),
        },
        other => decide(other, f64::NAN, 0.0),
    }
}

/// Initial impulse: the warm start projected onto the bounds (friction bounds at the projected
/// normals), or zero projected onto the bounds.
pub(crate) fn initial_impulse(problem: &Problem, settings: &Settings) -> Vec<f64> {
    let n = problem.n();
    let mut f = match &settings.warm_start {
        Some(ws) if ws.len() == n && ws.iter().all(|v| v.is_finite()) => ws.clone(),
        _ => return zero_impulse(problem),
    };
    problem.project_onto_bounds(&mut f);
    f
}

/// Zero projected onto the bounds: the start of a solve without a warm start.
pub(crate) fn zero_impulse(problem: &Problem) -> Vec<f64> {
    let mut f = vec![0.0; problem.n()];
    problem.project_onto_bounds(&mut f);
    f
}

/// Solve `problem` island by island with a solver that needs a dense `A` of at most `limit`
/// rows: each independent sub-problem ([`Problem::islands`]) is densified and solved on its own
/// (the warm start, tolerance, remaining time budget and remaining iterations passed on:
/// [`Settings::max_iterations`] is a total for the whole solve), and the impulses are assembled. An island above `limit` rows makes the whole solve
/// `Unsupported` with the reason, never an out-of-memory abort. The status of the whole is then
/// decided by the shared residual as always. Problems of at most `limit` rows stored dense are
/// solved directly.
pub(crate) fn solve_by_islands(
    problem: &Problem,
    settings: &Settings,
    limit: usize,
    solve_one: impl FnMut(&Problem, &Settings) -> SolveResult,
) -> SolveResult {
    solve_islands_with(problem, settings, limit, true, solve_one)
}

/// [`solve_by_islands`] for solvers that work on sparse storage: each island keeps the storage
/// [`Problem::restrict`] gives it (dense when small), and one island is solved in place.
pub(crate) fn solve_by_sparse_islands(
    problem: &Problem,
    settings: &Settings,
    limit: usize,
    solve_one: impl FnMut(&Problem, &Settings) -> SolveResult,
) -> SolveResult {
    solve_islands_with(problem, settings, limit, false, solve_one)
}

fn solve_islands_with(
    problem: &Problem,
    settings: &Settings,
    limit: usize,
    densify: bool,
    mut solve_one: impl FnMut(&Problem, &Settings) -> SolveResult,
) -> SolveResult {
    const SPLIT_FROM: usize = 32;
    let small_dense = (!densify || !problem.is_sparse()) && problem.n() <= limit;
    if small_dense && problem.n() <= SPLIT_FROM {
        return solve_one(problem, settings);
    }
    let islands = problem.islands();
    if small_dense && islands.len() == 1 {
        return solve_one(problem, settings);
    }
    let mut monitor = Monitor::new(problem, settings);
    if let Some(big) = islands.iter().find(|rows| rows.len() > limit) {
        let reason = format!(
            "an island of {} rows exceeds this solver's dense limit of {limit} rows",
            big.len()
        );
        return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
    }
    let n = problem.n();
    let mut f = vec![0.0; n];
    let mut iterations = 0;
    let mut outcome = Outcome::Stopped;
    for rows in islands {
        let sub = if densify {
            problem.restrict_dense(rows)
        } else {
            problem.restrict(rows)
        };
        let sub = match sub {
            Ok(sub) => sub,
            Err(e) => {
                outcome = Outcome::NumericalFailure(format!("island extraction failed: {e}"));
                break;
            }
        };
        let mut sub_settings = Settings {
            warm_start: settings
                .warm_start
                .as_ref()
                .filter(|ws| ws.len() == n)
                .map(|ws| rows.iter().map(|&i| ws[i]).collect()),
            record_history: false,
            ..settings.clone()
        };
        if let Some(budget) = settings.time_budget {
            let left = budget.saturating_sub(monitor.elapsed());
            if left.is_zero() {
                outcome = Outcome::TimeLimit;
                break;
            }
            sub_settings.time_budget = Some(left);
        }
        // The islands not reached keep a zero impulse.
        sub_settings.max_iterations = settings.max_iterations.saturating_sub(iterations);
        if sub_settings.max_iterations == 0 {
            if island_rank(&outcome) < island_rank(&Outcome::IterationLimit) {
                outcome = Outcome::IterationLimit;
            }
            break;
        }
        let r = solve_one(&sub, &sub_settings);
        iterations += r.iterations;
        if r.f.len() != rows.len() {
            // An island's result of the wrong length cannot be placed in `f`: the whole solve
            // fails with its reason rather than reading past the island's values.
            outcome = Outcome::NumericalFailure(format!(
                "an island of {} rows returned {} values ({})",
                rows.len(),
                r.f.len(),
                r.status
            ));
            break;
        }
        for (k, &i) in rows.iter().enumerate() {
            f[i] = r.f[k];
        }
        let island_outcome = Outcome::of(r.status);
        if island_rank(&island_outcome) > island_rank(&outcome) {
            outcome = island_outcome;
        }
        if matches!(outcome, Outcome::Unsupported(_)) {
            break;
        }
    }
    monitor.record(iterations, &f);
    monitor.finish(f, iterations, outcome)
}

/// How telling an island's outcome is for the whole solve: unsupported and failures over limits
/// and stalls, those over a stop.
fn island_rank(o: &Outcome) -> u8 {
    match o {
        Outcome::Stopped => 0,
        Outcome::IterationLimit | Outcome::TimeLimit | Outcome::Stalled(_) => 1,
        Outcome::NoSolution(_) | Outcome::Diverged(_) | Outcome::NumericalFailure(_) => 2,
        Outcome::Unsupported(_) => 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::metrics::residuals;
    use faer::Mat;

    /// A measured point is reused only when it is bit for bit the returned impulse; any other
    /// impulse is measured afresh, so the status always comes from the returned `f`.
    #[test]
    fn stagnation_needs_a_new_low_once_per_window() {
        let mut s = Stagnation::new(3);
        // Steady progress never stagnates.
        for k in 1..20 {
            assert!(!s.stagnated(k, 0.5f64.powi(k as i32)));
        }
        // A plateau (and a 0.5 % decrease, below the 1 % that counts) stagnates after 3.
        let low = 0.5f64.powi(19);
        assert!(!s.stagnated(20, low));
        assert!(!s.stagnated(21, low * 0.995));
        assert!(s.stagnated(22, low));
        // A restart forgets the plateau.
        s.restart(22);
        assert!(!s.stagnated(23, 1.0));
        assert!(!s.stagnated(25, 1.0));
        assert!(s.stagnated(26, f64::NAN));
    }

    #[test]
    fn finish_reuses_a_measurement_only_of_the_returned_impulse() {
        let a = Mat::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 2.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, 1.0]).unwrap();
        let settings = Settings::default();
        let (good, bad) = (vec![0.5, 0.0], vec![0.25, 0.0]);
        let mut monitor = Monitor::new(&p, &settings);
        assert_eq!(monitor.residual_of(&good), 0.0);
        let r = monitor.finish(good.clone(), 1, Outcome::Stopped);
        assert_eq!(r.status, Status::Converged);
        assert_eq!(r.residuals, residuals(&p, &good));
        assert_eq!(r.w, p.velocity(&good));
        // Measured one point, returned another: the returned one decides.
        let mut monitor = Monitor::new(&p, &settings);
        monitor.residual_of(&good);
        let r = monitor.finish(bad.clone(), 1, Outcome::Stopped);
        assert_eq!(r.residuals, residuals(&p, &bad));
        assert_ne!(r.status, Status::Converged);
    }

    /// An `n × n` SPD matrix of independent tridiagonal blocks of 20 rows (4 on the diagonal,
    /// 1 beside it): `n / 20` islands.
    fn tridiagonal_blocks_of_20(n: usize) -> Mat<f64> {
        Mat::from_fn(n, n, |i, j| {
            if i == j {
                4.0
            } else if i / 20 == j / 20 && i.abs_diff(j) == 1 {
                1.0
            } else {
                0.0
            }
        })
    }

    /// `max_iterations` is a total for the solve: each island gets what the islands before it
    /// left, and the islands past the cap are not solved (a 20,000-row problem of one-row
    /// islands once ran `n` times the cap).
    #[test]
    fn islands_share_the_iteration_cap() {
        let n = 60;
        let a = tridiagonal_blocks_of_20(n);
        let p = Problem::lcp(a, vec![-1.0; n]).unwrap();
        let settings = Settings {
            max_iterations: 25,
            ..Settings::default()
        };
        let mut given = Vec::new();
        let r = solve_by_islands(&p, &settings, 1000, |island, s| {
            given.push(s.max_iterations);
            // Every island spends 15 iterations, or the cap it is given.
            let spent = s.max_iterations.min(15);
            let outcome = if spent < 15 {
                Outcome::IterationLimit
            } else {
                Outcome::Stopped
            };
            let mut r = Monitor::new(island, s).finish(vec![0.0; island.n()], spent, outcome);
            r.iterations = spent;
            r
        });
        assert_eq!(given, vec![25, 10], "the third island gets nothing");
        assert_eq!(r.iterations, 25);
        assert_ne!(r.status, Status::Converged);
    }

    /// An island whose solve returns a result of the wrong length (a failed solve that kept no
    /// point) ends the whole solve `numerical_failure` with the reason, instead of indexing past
    /// the island's values.
    #[test]
    fn an_island_result_of_the_wrong_length_is_a_failure_not_a_panic() {
        let n = 60;
        let p = Problem::lcp(tridiagonal_blocks_of_20(n), vec![-1.0; n]).unwrap();
        let r = solve_by_islands(&p, &Settings::default(), 1000, |island, s| {
            Monitor::new(island, s).finish(Vec::new(), 0, Outcome::NumericalFailure("x".into()))
        });
        match &r.status {
            Status::NumericalFailure { reason } => {
                assert!(
                    reason.contains("island of 20 rows returned 0 values"),
                    "{reason}"
                )
            }
            s => panic!("{s:?}"),
        }
        assert_eq!(r.f.len(), n);
    }

    /// An impulse that meets the tolerance by growing along the null direction of a problem
    /// without a solution is not `converged`. On `A = [[1, −1], [−1, 1]]`, `b = (−1, −1)` the
    /// Farkas certificate read off it (`y ∝ (1, 1)`) is exact: `no_solution`. On the
    /// floating-point `infeasible` family no certificate is exact, and the status is
    /// `diverged`, with a proven lower bound on the size of any solution.
    #[test]
    fn a_diverging_impulse_is_never_converged() {
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, -1.0], [-1.0, 1.0]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        let settings = Settings::default();
        for f in [vec![5.2e7, 5.2e7], vec![5.2e8, 5.2e8 + 1.0]] {
            let r = Monitor::new(&p, &settings).finish(f, 1, Outcome::Stopped);
            assert!(r.residuals.natural_map_rel <= settings.tolerance);
            assert_eq!(r.status.name(), "no_solution", "{}", r.status);
            assert!(r.certificate.as_ref().unwrap().proves_no_solution);
        }
        let g =
            crate::problem::generate::generate(crate::problem::generate::Family::Infeasible, 6, 1);
        let loose = Settings {
            tolerance: 1e-4,
            ..Settings::default()
        };
        let r = crate::Apgd.solve(&g.problem, &loose);
        assert!(r.residuals.natural_map_rel <= loose.tolerance);
        assert_eq!(r.status.name(), "diverged", "{}", r.status);
        let c = r.certificate.unwrap();
        let largest = r.f.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            !c.proves_no_solution && c.min_solution_norm > largest,
            "{c:?}"
        );
        // The same through the rule the body-level solvers use.
        let (status, c) = judge(
            &g.problem,
            &r.f,
            &r.w,
            &r.residuals,
            Outcome::Stopped,
            loose.tolerance,
        );
        assert_eq!(status.name(), "diverged");
        assert!(c.is_some());
        // A solution of a solvable problem stays converged, without a certificate.
        let a = Mat::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 2.0]][i][j]);
        let q = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        let r = Monitor::new(&q, &settings).finish(vec![1.0 / 3.0; 2], 1, Outcome::Stopped);
        assert_eq!((r.status, r.certificate), (Status::Converged, None));
    }

    /// `A = [[1, −1], [−1, 1 + 2⁻⁵²]]` is regular, and with `b = (−1, −1)` its solution is
    /// about `1.8e16`: the terms of each row exceed the data by so much that their round-off
    /// alone is far above the data, so no answer can be resolved, even one a pivoting solver
    /// finds to round-off.
    #[test]
    fn a_solution_lost_in_rounding_is_not_converged() {
        let e = f64::EPSILON;
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, -1.0], [-1.0, 1.0 + e]][i][j]);
        let p = Problem::lcp(a, vec![-1.0, -1.0]).unwrap();
        // The solution f_1 = 2 / ε, f_0 = f_1 + 1, rounded.
        let f = vec![2.0 / e + 1.0, 2.0 / e];
        let r = Monitor::new(&p, &Settings::default()).finish(f, 1, Outcome::Stopped);
        assert!(r.residuals.natural_map_rel <= 1e-15, "{:?}", r.residuals);
        assert_eq!(r.status.name(), "diverged", "{}", r.status);
        assert!(r.status.reason().unwrap().contains("round-off"));
    }

    /// An island's own diagnosis of a stall reaches the whole problem's status, so a user sees
    /// why a multi-island solve stopped short (not only that its stopping rule was met).
    #[test]
    fn an_island_stall_keeps_its_reason() {
        // Two independent 20-row SPD blocks (above the size solved in one piece).
        let n = 40;
        let a = tridiagonal_blocks_of_20(n);
        let p = Problem::lcp(a, vec![-1.0; n]).unwrap();
        let settings = Settings::default();
        let mut islands = 0;
        let r = solve_by_islands(&p, &settings, 1000, |island, s| {
            islands += 1;
            Monitor::new(island, s).finish(
                vec![0.0; island.n()],
                1,
                Outcome::Stalled("no decrease along either direction".into()),
            )
        });
        assert_eq!(islands, 2);
        match r.status {
            Status::Stalled { reason } => {
                assert_eq!(reason, "no decrease along either direction")
            }
            other => panic!("expected the island's stall, got {other:?}"),
        }
    }
}

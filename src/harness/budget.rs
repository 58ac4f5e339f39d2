//! Budgets (tolerance, iteration cap, time budget) and solver specifications (a solver kind with
//! its variant: SOR relaxation, warm or cold start), with the catalogue of every solver: its
//! name, level, problem classes and plot colour.

use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::scene::Scene;
use lcpbench_contact::ContactSolver;
use lcpbench_solvers::{ConeSolver, ConeSolverKind, ProjectedSor, Settings, Solver, SolverKind};
use std::fmt;
use std::time::Duration;
use thiserror::Error;

/// A malformed budget or solver specification.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SpecError {
    /// A budget that is neither a preset nor `TOL:ITER:SECONDS`.
    #[error("budget `{0}`: expected a preset (loose, default, tight, realtime) or TOL:ITER:SECONDS such as 1e-6:500:2")]
    Budget(String),
    /// A budget of the right shape whose tolerance, iteration cap or time is out of range.
    #[error("budget `{spec}`: {message}")]
    BudgetValue {
        /// The budget as given.
        spec: String,
        /// What is wrong.
        message: String,
    },
    /// A solver specification that does not parse.
    #[error("solver `{spec}`: {message}")]
    Solver {
        /// The specification as given.
        spec: String,
        /// What is wrong.
        message: String,
    },
}

/// Largest time budget accepted, seconds (about 31 years). Larger values, and values whose
/// derived kill time cannot be represented as a [`Duration`], are refused up front.
pub const MAX_TIME_BUDGET_S: f64 = 1e9;

/// Smallest time budget accepted, seconds: a microsecond, about the cost of reading the clock a
/// few times. A budget below it would end every solve before its first iteration.
pub const MIN_TIME_BUDGET_S: f64 = 1e-6;

/// Check a time budget in seconds: finite, at least [`MIN_TIME_BUDGET_S`], at most
/// [`MAX_TIME_BUDGET_S`], and representable as a [`Duration`]. The error says what is wrong.
pub fn time_budget(seconds: f64) -> Result<Duration, String> {
    if !(seconds.is_finite() && seconds > 0.0) {
        return Err(format!(
            "time budget must be a positive number of seconds, got {seconds}"
        ));
    }
    if seconds < MIN_TIME_BUDGET_S {
        return Err(format!(
            "time budget {seconds:e} s is below the minimum of {MIN_TIME_BUDGET_S:e} s"
        ));
    }
    if seconds > MAX_TIME_BUDGET_S {
        return Err(format!(
            "time budget {seconds:e} s is beyond the limit of {MAX_TIME_BUDGET_S:e} s"
        ));
    }
    Duration::try_from_secs_f64(seconds)
        .map_err(|e| format!("time budget {seconds:e} s cannot be represented: {e}"))
}

/// Check a tolerance on the relative residual: a number in `(0, 1)`, and at least
/// [`MIN_TOLERANCE`](lcpbench_solvers::metrics::MIN_TOLERANCE). A relative residual of 1 or
/// more is met by `f = 0` on most problems, so such a tolerance would claim convergence for
/// nothing; one below round-off would be met only by chance.
pub fn tolerance(tol: f64) -> Result<f64, String> {
    lcpbench_contact::scene::tolerance(tol).map_err(|m| format!("tolerance {m}"))
}

/// Tolerance, iteration cap and time budget of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// Tolerance on the relative natural-map residual.
    pub tolerance: f64,
    /// Iteration or pivot cap (per step for scenes).
    pub max_iterations: usize,
    /// Time budget in seconds: per solve for LCP cases; for scenes, per step's solve (a step
    /// whose solve runs out of it ends `time_limit` with the best point the solver has, and the
    /// run goes on), with the whole run capped at [`Budget::scene_run_limit`]. The child
    /// process is killed (and the run recorded as `timeout`) when it exceeds
    /// [`Budget::kill_after`].
    pub time_s: f64,
}

impl Budget {
    /// The named presets.
    pub const PRESETS: [(&'static str, Budget); 4] = [
        (
            "loose",
            Budget {
                tolerance: 1e-4,
                max_iterations: 1_000,
                time_s: 1.0,
            },
        ),
        (
            "default",
            Budget {
                tolerance: 1e-8,
                max_iterations: 10_000,
                time_s: 1.0,
            },
        ),
        (
            "tight",
            Budget {
                tolerance: 1e-10,
                max_iterations: 100_000,
                time_s: 10.0,
            },
        ),
        (
            "realtime",
            Budget {
                tolerance: 1e-6,
                max_iterations: 20,
                time_s: 1.0,
            },
        ),
    ];

    /// The preset called `name`.
    pub fn preset(name: &str) -> Option<Budget> {
        Self::PRESETS
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, b)| b.clone())
    }

    /// Solver settings for this budget.
    pub fn settings(&self) -> Settings {
        Settings {
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            time_budget: time_budget(self.time_s).ok(),
            warm_start: None,
            record_history: false,
        }
    }

    /// Wall time after which the isolated child is killed: for an LCP three times the budget plus
    /// five seconds (process start, problem generation and the residual measurements of the
    /// convergence history are outside the solver's clock); for a scene of `steps` steps, which
    /// stops stepping by itself at [`Budget::scene_run_limit`] (the solve of the step running
    /// then ends at that limit too), that limit plus a quarter of it plus ten seconds: the margin
    /// covers loading the scene and the step under way when the limit passes.
    /// Saturates at [`Duration::MAX`] for a budget that was not validated.
    pub fn kill_after(&self, scene_steps: Option<usize>) -> Duration {
        let seconds = match scene_steps {
            Some(steps) => 1.25 * self.scene_run_limit(steps) + 10.0,
            None => 3.0 * self.time_s + 5.0,
        };
        Duration::try_from_secs_f64(seconds).unwrap_or(Duration::MAX)
    }

    /// Check the tolerance (in `(0, 1)`) and the time (see [`time_budget`]).
    pub fn validate(&self) -> Result<(), String> {
        tolerance(self.tolerance)?;
        time_budget(self.time_s)?;
        if self.max_iterations == 0 {
            return Err("the iteration cap must be at least 1".into());
        }
        Ok(())
    }

    /// Wall time after which a scene run of `steps` steps stops stepping and records
    /// `time_limit` with the steps it took: twice `steps` times the per-step seconds, the
    /// solves' share plus as much again for collision detection, assembly, measurement and
    /// integration. A run whose steps each stay within their budget is cut short only when
    /// everything outside the solver costs more than the solve budget per step.
    pub fn scene_run_limit(&self, steps: usize) -> f64 {
        2.0 * steps.max(1) as f64 * self.time_s
    }
}

/// A budget with the name it was given on the command line (a preset name or the spec itself).
#[derive(Debug, Clone, PartialEq)]
pub struct NamedBudget {
    /// The name written to CSV rows.
    pub name: String,
    /// The budget.
    pub budget: Budget,
}

impl std::str::FromStr for NamedBudget {
    type Err = SpecError;

    fn from_str(s: &str) -> Result<Self, SpecError> {
        if let Some(budget) = Budget::preset(s) {
            return Ok(Self {
                name: s.to_owned(),
                budget,
            });
        }
        let parts: Vec<&str> = s.split(':').collect();
        let bad = || SpecError::Budget(s.to_owned());
        if parts.len() != 3 {
            return Err(bad());
        }
        let tolerance: f64 = parts[0].parse().map_err(|_| bad())?;
        let max_iterations: usize = parts[1].parse().map_err(|_| bad())?;
        let time_s: f64 = parts[2].trim_end_matches('s').parse().map_err(|_| bad())?;
        let budget = Budget {
            tolerance,
            max_iterations,
            time_s,
        };
        budget
            .validate()
            .map_err(|message| SpecError::BudgetValue {
                spec: s.to_owned(),
                message,
            })?;
        Ok(Self {
            name: s.to_owned(),
            budget,
        })
    }
}

impl fmt::Display for NamedBudget {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.write_str(&self.name)
    }
}

/// A deliberate failure injected into the child process, to test that the sweep records it and
/// carries on. Selected with the hidden solver names `fault-panic`, `fault-hang`, `fault-abort`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Panic inside the run.
    Panic,
    /// Sleep forever (the parent must kill the child).
    Hang,
    /// Abort the process (no unwinding).
    Abort,
}

impl Fault {
    /// Name used in `fault-NAME` and `--fault NAME`.
    pub fn name(self) -> &'static str {
        match self {
            Fault::Panic => "panic",
            Fault::Hang => "hang",
            Fault::Abort => "abort",
        }
    }

    /// Inverse of [`Fault::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        [Fault::Panic, Fault::Hang, Fault::Abort]
            .into_iter()
            .find(|f| f.name() == name)
    }

    /// Make the fault happen.
    pub fn trigger(self) -> ! {
        match self {
            Fault::Panic => panic!("injected fault: panic"),
            Fault::Hang => loop {
                std::thread::sleep(Duration::from_secs(3600));
            },
            Fault::Abort => std::process::abort(),
        }
    }
}

/// A solver with its variant: `NAME[@OMEGA][+warm]`, for example `pgs`, `sor@1.7`, `pgs+warm`,
/// `si+warm`, `nsgs-cone+warm`, or an injected fault `fault-panic`. Names are the matrix solvers
/// of `lcpbench-solvers`, the body-level solvers of `lcpbench-contact` (`si`, `body-micro`,
/// `penalty`; scenes only) and the cone solvers (`nsgs-cone`, `newton-ac`, `clarabel-socp`:
/// scenes with friction model `cone`, and LCP cases whose rows are (normal, tangent, tangent)
/// triples, solved as the cone). See [`catalogue`] for every name with its level.
///
/// `warm`: warm start (iterative solvers only): from a nearby solution for LCP cases, from the
/// previous step's impulses for scenes. Without `+warm` LCP cases start cold and scenes step
/// cold.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverSpec {
    /// A matrix solver of `lcpbench-solvers`.
    Matrix {
        /// Which solver.
        kind: SolverKind,
        /// SOR relaxation (only for `sor`; `None`: the solver's default, 1.3).
        omega: Option<f64>,
        /// Warm start.
        warm: bool,
    },
    /// A body-level solver of `lcpbench-contact` (scenes only).
    Body {
        /// Which solver.
        kind: BodySolverKind,
        /// Warm start (`si`, `body-micro`).
        warm: bool,
    },
    /// A solver of the exact Coulomb cone.
    Cone {
        /// Which solver.
        kind: ConeSolverKind,
        /// Warm start.
        warm: bool,
    },
    /// A fault injected instead of solving.
    Fault(Fault),
}

impl SolverSpec {
    /// Plain matrix solver with default parameters, cold start.
    pub fn plain(kind: SolverKind) -> Self {
        Self::Matrix {
            kind,
            omega: None,
            warm: false,
        }
    }

    /// Projected SOR with relaxation `omega`, cold start (not validated; see
    /// [`SolverSpec::matrix`]).
    pub fn sor(omega: f64) -> Self {
        Self::Matrix {
            kind: SolverKind::Sor,
            omega: Some(omega),
            warm: false,
        }
    }

    /// A matrix solver with an optional relaxation, checked: `omega` only for `sor`, in
    /// `(0, 2)`. The error says what is wrong.
    pub fn matrix(kind: SolverKind, omega: Option<f64>) -> Result<Self, String> {
        match omega {
            Some(_) if kind != SolverKind::Sor => Err("@omega applies only to sor".into()),
            Some(w) if !(w > 0.0 && w < 2.0) => Err(format!(
                "omega must be in (0, 2) (projected SOR diverges outside it), got {w}"
            )),
            _ => Ok(Self::Matrix {
                kind,
                omega,
                warm: false,
            }),
        }
    }

    /// Plain body-level solver, cold start.
    pub fn body(kind: BodySolverKind) -> Self {
        Self::Body { kind, warm: false }
    }

    /// Plain cone solver, cold start.
    pub fn cone(kind: ConeSolverKind) -> Self {
        Self::Cone { kind, warm: false }
    }

    /// The same solver, warm-started (no effect on a fault; not validated, see
    /// [`SolverSpec::is_iterative`]).
    pub fn with_warm(mut self) -> Self {
        match &mut self {
            Self::Matrix { warm, .. } | Self::Body { warm, .. } | Self::Cone { warm, .. } => {
                *warm = true
            }
            Self::Fault(_) => {}
        }
        self
    }

    /// Warm start.
    pub fn warm(&self) -> bool {
        match self {
            Self::Matrix { warm, .. } | Self::Body { warm, .. } | Self::Cone { warm, .. } => *warm,
            Self::Fault(_) => false,
        }
    }

    /// SOR relaxation, when set.
    pub fn omega(&self) -> Option<f64> {
        match self {
            Self::Matrix { omega, .. } => *omega,
            _ => None,
        }
    }

    /// The injected fault, for a fault pseudo-solver.
    pub fn fault(&self) -> Option<Fault> {
        match self {
            Self::Fault(f) => Some(*f),
            _ => None,
        }
    }

    /// The solver instance the stepper takes for `scene`, with every parameter of the
    /// specification (`None` for a fault pseudo-solver). This is the one place where a
    /// specification becomes a stepper's solver; body-level solvers come from the scene, whose
    /// settings hold the penalty parameters.
    pub fn contact_solver(&self, scene: &Scene) -> Option<ContactSolver> {
        match *self {
            Self::Matrix { .. } => self.create().map(ContactSolver::Matrix),
            Self::Body { kind, .. } => Some(scene.body_solver(kind)),
            Self::Cone { .. } => self.create_cone().map(ContactSolver::Cone),
            Self::Fault(_) => None,
        }
    }

    /// True when the solver iterates from a starting impulse (so `+warm` means something).
    pub fn is_iterative(&self) -> bool {
        match self {
            Self::Matrix { kind, .. } => kind.is_iterative(),
            Self::Body { kind, .. } => kind.is_iterative(),
            Self::Cone { .. } => true,
            Self::Fault(_) => false,
        }
    }

    /// The solver kind's name, or `fault-…`.
    pub fn base_name(&self) -> String {
        match self {
            Self::Matrix { kind, .. } => kind.name().to_owned(),
            Self::Body { kind, .. } => kind.name().to_owned(),
            Self::Cone { kind, .. } => kind.name().to_owned(),
            Self::Fault(f) => format!("fault-{}", f.name()),
        }
    }

    /// Create the matrix solver, with its relaxation (`None` for body-level, cone and fault
    /// specifications). The one factory of matrix solvers for the harness and the CLI.
    pub fn create(&self) -> Option<Box<dyn Solver + Send>> {
        match *self {
            Self::Matrix {
                kind: SolverKind::Sor,
                omega: Some(w),
                ..
            } => Some(Box::new(ProjectedSor::sor(w))),
            Self::Matrix { kind, .. } => Some(kind.create()),
            _ => None,
        }
    }

    /// Create the cone solver (`None` for the other specifications).
    pub fn create_cone(&self) -> Option<Box<dyn ConeSolver + Send>> {
        match *self {
            Self::Cone { kind, .. } => Some(kind.create()),
            _ => None,
        }
    }
}

impl fmt::Display for SolverSpec {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.write_str(&self.base_name())?;
        if let Some(w) = self.omega() {
            write!(out, "@{w}")?;
        }
        if self.warm() {
            out.write_str("+warm")?;
        }
        Ok(())
    }
}

impl std::str::FromStr for SolverSpec {
    type Err = SpecError;

    fn from_str(spec: &str) -> Result<Self, SpecError> {
        let err = |message: String| SpecError::Solver {
            spec: spec.to_owned(),
            message,
        };
        let (rest, warm) = match spec.strip_suffix("+warm") {
            Some(r) => (r, true),
            None => (spec, false),
        };
        let (name, omega) = match rest.split_once('@') {
            Some((n, w)) => {
                let w: f64 = w
                    .parse()
                    .map_err(|_| err(format!("`{w}` is not a number")))?;
                (n, Some(w))
            }
            None => (rest, None),
        };
        if let Some(fault) = name.strip_prefix("fault-") {
            let fault = Fault::from_name(fault)
                .ok_or_else(|| err("fault must be panic, hang or abort".into()))?;
            return Ok(Self::Fault(fault));
        }
        let out = match (
            BodySolverKind::from_name(name),
            ConeSolverKind::from_name(name),
        ) {
            (Some(body), _) => Self::body(body),
            (None, Some(cone)) => Self::cone(cone),
            (None, None) => Self::plain(name.parse().map_err(|e: String| {
                err(format!(
                    "{e}; body-level solvers: si, body-micro, penalty; cone solvers: {}",
                    ContactSolver::cone_names()
                ))
            })?),
        };
        let out = match (out, omega) {
            (Self::Matrix { kind, .. }, omega) => Self::matrix(kind, omega).map_err(err)?,
            (_, Some(_)) => return Err(err("@omega applies only to sor".into())),
            (out, None) => out,
        };
        if warm && !out.is_iterative() {
            return Err(err(format!(
                "+warm applies only to iterative solvers, not {name}"
            )));
        }
        Ok(if warm { out.with_warm() } else { out })
    }
}

/// The level a solver works at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverLevel {
    /// Solves the assembled (boxed) LCP `w = A f + b` (`lcpbench-solvers`).
    Matrix,
    /// Works on the bodies through the Delassus operator, inside the stepper (scenes only).
    Body,
    /// Solves the exact Coulomb-cone problem (FC3D).
    Cone,
}

impl SolverLevel {
    /// `matrix`, `body` or `cone`.
    pub fn name(self) -> &'static str {
        match self {
            SolverLevel::Matrix => "matrix",
            SolverLevel::Body => "body",
            SolverLevel::Cone => "cone",
        }
    }
}

/// One solver of the catalogue: its name, level, problem classes and limits.
#[derive(Debug, Clone, PartialEq)]
pub struct CatalogueEntry {
    /// Name on the command line, in scene files and in the CSV.
    pub name: &'static str,
    /// Matrix, body-level or cone.
    pub level: SolverLevel,
    /// Problem classes it takes and its limits.
    pub problem_classes: &'static str,
    /// Whether `+warm` applies.
    pub iterative: bool,
}

/// Every solver, matrix solvers first, then the body-level and the cone solvers (the order of
/// `lcpbench solvers`).
pub fn catalogue() -> Vec<CatalogueEntry> {
    let matrix = SolverKind::ALL.into_iter().map(|k| CatalogueEntry {
        name: k.name(),
        level: SolverLevel::Matrix,
        problem_classes: k.problem_classes(),
        iterative: k.is_iterative(),
    });
    let body = BodySolverKind::ALL.into_iter().map(|k| CatalogueEntry {
        name: k.name(),
        level: SolverLevel::Body,
        problem_classes: k.problem_classes(),
        iterative: k.is_iterative(),
    });
    let cone = ConeSolverKind::ALL.into_iter().map(|k| CatalogueEntry {
        name: k.name(),
        level: SolverLevel::Cone,
        problem_classes: k.problem_classes(),
        iterative: true,
    });
    matrix.chain(body).chain(cone).collect()
}

/// The plot palette (RGB): the solvers with a fixed slot ([`palette_slot`]) take theirs; other
/// series are hashed onto it.
pub const PALETTE: [(u8, u8, u8); 16] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
    (0, 0, 128),
    (128, 0, 0),
    (0, 100, 0),
    (255, 215, 0),
    (0, 0, 0),
    (255, 0, 255),
];

/// The fixed palette slot of a shipped solver (`None`: the colour is hashed from the name).
pub fn palette_slot(name: &str) -> Option<usize> {
    if let Some(kind) = BodySolverKind::from_name(name) {
        return Some(match kind {
            BodySolverKind::SequentialImpulses => 6,
            BodySolverKind::MicroImpulses => 7,
            BodySolverKind::Penalty => 8,
        });
    }
    Some(match SolverKind::from_name(name)? {
        SolverKind::Pgs => 0,
        SolverKind::Sor => 1,
        SolverKind::Lemke => 2,
        SolverKind::Dantzig => 3,
        SolverKind::Clarabel => 4,
        SolverKind::MicroImpulse => 5,
        SolverKind::NewtonFb => 9,
        SolverKind::NewtonMin => 10,
        SolverKind::Apgd => 11,
        SolverKind::Nncg => 12,
        SolverKind::Nsgs => 13,
        SolverKind::Enumeration => 14,
    })
}

/// A stable colour per series key (a solver specification or name): a plain shipped solver
/// gets its fixed slot, anything else (variants, cone solvers, faults) a hashed one.
pub fn colour(key: &str) -> (u8, u8, u8) {
    if let Some(slot) = palette_slot(key) {
        return PALETTE[slot];
    }
    let h = key
        .bytes()
        .fold(7u64, |h, b| h.wrapping_mul(31).wrapping_add(b as u64));
    PALETTE[(h % PALETTE.len() as u64) as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_round_trip() {
        for s in [
            "pgs",
            "sor@1.7",
            "pgs+warm",
            "sor@0.9+warm",
            "fault-hang",
            "lemke",
            "nsgs-cone",
            "newton-ac+warm",
        ] {
            let spec: SolverSpec = s.parse().unwrap();
            assert_eq!(spec.to_string(), s);
        }
        assert!("lemke+warm".parse::<SolverSpec>().is_err());
        assert!("penalty+warm".parse::<SolverSpec>().is_err());
        assert!("pgs@1.2".parse::<SolverSpec>().is_err());
        for bad_omega in ["sor@5", "sor@0", "sor@-1", "sor@NaN", "sor@2"] {
            assert!(bad_omega.parse::<SolverSpec>().is_err(), "{bad_omega}");
        }
        assert!("nope".parse::<SolverSpec>().is_err());
    }

    #[test]
    fn specs_are_the_variant_their_name_says() {
        let sor: SolverSpec = "sor@1.5+warm".parse().unwrap();
        assert_eq!(
            sor,
            SolverSpec::Matrix {
                kind: SolverKind::Sor,
                omega: Some(1.5),
                warm: true
            }
        );
        assert_eq!(sor.create().unwrap().name(), "sor");
        let si: SolverSpec = "si+warm".parse().unwrap();
        assert_eq!(
            si,
            SolverSpec::Body {
                kind: BodySolverKind::SequentialImpulses,
                warm: true
            }
        );
        assert!(si.create().is_none() && si.create_cone().is_none());
        let cone: SolverSpec = "nsgs-cone".parse().unwrap();
        assert_eq!(cone.create_cone().unwrap().name(), "nsgs-cone");
        assert_eq!(
            "fault-panic".parse::<SolverSpec>().unwrap(),
            SolverSpec::Fault(Fault::Panic)
        );
        assert!(SolverSpec::matrix(SolverKind::Pgs, Some(1.2)).is_err());
        assert!(SolverSpec::matrix(SolverKind::Sor, Some(2.0)).is_err());
        assert!(SolverSpec::matrix(SolverKind::Sor, Some(1.2)).is_ok());
    }

    #[test]
    fn the_catalogue_names_every_parsable_solver_once() {
        let entries = catalogue();
        let expected =
            SolverKind::ALL.len() + BodySolverKind::ALL.len() + ConeSolverKind::ALL.len();
        assert_eq!(entries.len(), expected);
        for e in &entries {
            let spec: SolverSpec = e.name.parse().unwrap();
            assert_eq!(spec.base_name(), e.name);
            assert_eq!(spec.is_iterative(), e.iterative, "{}", e.name);
            assert_eq!(entries.iter().filter(|x| x.name == e.name).count(), 1);
        }
        assert_eq!(
            entries.iter().find(|e| e.name == "penalty").unwrap().level,
            SolverLevel::Body
        );
    }

    #[test]
    fn shipped_solvers_keep_their_plot_colours() {
        // The fixed order the report has always used.
        let fixed = [
            "pgs",
            "sor",
            "lemke",
            "dantzig",
            "clarabel",
            "micro",
            "si",
            "body-micro",
            "penalty",
            "newton-fb",
            "newton-min",
            "apgd",
            "nncg",
            "nsgs",
            "enum",
        ];
        for (i, name) in fixed.iter().enumerate() {
            assert_eq!(colour(name), PALETTE[i], "{name}");
        }
        // Variants and unlisted solvers are hashed, and stable.
        assert_eq!(colour("sor@1.5"), colour("sor@1.5"));
        let slots: std::collections::HashSet<_> = fixed.iter().map(|n| colour(n)).collect();
        assert_eq!(slots.len(), fixed.len());
    }

    #[test]
    fn budgets_parse() {
        let b: NamedBudget = "default".parse().unwrap();
        assert_eq!(b.budget.tolerance, 1e-8);
        let b: NamedBudget = "1e-6:500:2s".parse().unwrap();
        assert_eq!(b.budget.max_iterations, 500);
        assert_eq!(b.budget.time_s, 2.0);
        assert!("fast".parse::<NamedBudget>().is_err());
        assert!("1e-6:500".parse::<NamedBudget>().is_err());
    }

    #[test]
    fn unrepresentable_budget_seconds_are_refused() {
        for spec in [
            "1e-8:100:1e19",
            "1e-8:100:1e20",
            "1e-8:100:inf",
            "1e-8:100:NaN",
            "1e-8:100:-1",
            "1e-8:100:0",
            "1e300:100:1",
            "1:100:1",
            "1e-8:0:1",
        ] {
            let err = spec.parse::<NamedBudget>().unwrap_err();
            assert!(
                matches!(err, SpecError::BudgetValue { .. }),
                "{spec}: {err}"
            );
        }
        for (name, b) in Budget::PRESETS {
            assert!(b.validate().is_ok(), "{name}");
        }
        let huge = Budget {
            tolerance: 1e-8,
            max_iterations: 1,
            time_s: 1e300,
        };
        assert_eq!(huge.kill_after(None), Duration::MAX);
        assert_eq!(huge.kill_after(Some(100)), Duration::MAX);
        assert_eq!(huge.settings().time_budget, None);
    }

    /// A scene's seconds are per step: the run limit is twice the steps times the seconds, and
    /// the child's kill time a quarter more plus ten seconds.
    #[test]
    fn scene_limits_scale_with_the_steps() {
        let b: NamedBudget = "1e-8:100:0.5".parse().unwrap();
        assert_eq!(b.budget.scene_run_limit(40), 40.0);
        assert_eq!(b.budget.kill_after(Some(40)), Duration::from_secs(60));
        assert_eq!(b.budget.kill_after(None), Duration::from_secs_f64(6.5));
    }
}

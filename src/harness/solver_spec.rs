//! Solver specifications: a solver of the registry with its parameters (`sor@omega=1.7`,
//! `soft-step@substeps=8`) and its start (warm or cold), or an injected fault, as named on the
//! command line and in the `solver` column.

use crate::harness::fault::Fault;
use crate::harness::text::serde_as_text;
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::registry;
use lcpbench_contact::scene::Scene;
use lcpbench_contact::ContactSolver;
use lcpbench_solvers::registry::{Level, Params, SolverEntry};
use lcpbench_solvers::{ConeSolver, ConeSolverKind, Solver, SolverKind};
use std::fmt;
use thiserror::Error;

/// A solver specification that does not parse.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("solver `{spec}`: {message}")]
pub struct SolverSpecError {
    /// The specification as given.
    pub spec: String,
    /// What is wrong.
    pub message: String,
}

/// A solver with its parameters and start: `NAME[@key=value,…][+warm]`, for example `pgs`,
/// `sor@omega=1.7`, `pgs+warm`, `si+warm`, `soft-step@substeps=8,hertz=60`,
/// `nsgs-cone+warm`, or an injected fault `fault-panic`. `NAME` is any solver of the registry
/// (`lcpbench solvers` lists them with their parameters, defaults and ranges; see
/// [`catalogue`](crate::harness::catalogue::catalogue)): a matrix solver of
/// `lcpbench-solvers`, a body-level solver of `lcpbench-contact` (scenes only) or a cone solver
/// (scenes with friction model `cone`, and LCP cases whose rows are (normal, tangent, tangent)
/// triples, solved as the cone). `NAME@VALUE` sets a solver's only parameter (`sor@1.7`, the
/// older spelling of `sor@omega=1.7`).
///
/// `warm`: warm start (iterative solvers only): from a nearby solution for LCP cases, from the
/// previous step's impulses for scenes. Without `+warm` LCP cases start cold and scenes step
/// cold.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverSpec {
    /// A solver of the registry.
    Solver {
        /// Which solver (its level is the entry's).
        entry: &'static SolverEntry,
        /// Its parameters, checked against the entry's `params`.
        params: Params,
        /// Warm start.
        warm: bool,
    },
    /// A fault injected instead of solving.
    Fault(Fault),
}

/// Plain PGS, cold start: the value of a [`RunRecord`](crate::harness::RunRecord) not yet
/// filled.
impl Default for SolverSpec {
    fn default() -> Self {
        Self::plain(SolverKind::Pgs)
    }
}

impl SolverSpec {
    /// The solver of `entry` with default parameters, cold start.
    pub const fn of(entry: &'static SolverEntry) -> Self {
        Self::Solver {
            entry,
            params: entry.defaults(),
            warm: false,
        }
    }

    /// Plain matrix solver with default parameters, cold start.
    pub const fn plain(kind: SolverKind) -> Self {
        Self::of(kind.entry())
    }

    /// Projected SOR with relaxation `omega`, cold start; refused outside `(0, 2)` with the
    /// key and range named.
    pub fn sor(omega: f64) -> Result<Self, String> {
        let mut params = SolverKind::Sor.entry().defaults();
        params.set("omega", omega)?;
        Ok(Self::Solver {
            entry: SolverKind::Sor.entry(),
            params,
            warm: false,
        })
    }

    /// Plain body-level solver, cold start.
    pub const fn body(kind: BodySolverKind) -> Self {
        Self::of(kind.entry())
    }

    /// A body-level solver with parameters, cold start.
    pub const fn body_with(kind: BodySolverKind, params: Params) -> Self {
        Self::Solver {
            entry: kind.entry(),
            params,
            warm: false,
        }
    }

    /// Plain cone solver, cold start.
    pub const fn cone(kind: ConeSolverKind) -> Self {
        Self::of(kind.entry())
    }

    /// The same solver, warm-started (no effect on a fault; not validated, see
    /// [`SolverSpec::is_iterative`]).
    pub const fn with_warm(mut self) -> Self {
        if let Self::Solver { warm, .. } = &mut self {
            *warm = true;
        }
        self
    }

    /// The same solver, cold start.
    pub const fn cold(mut self) -> Self {
        if let Self::Solver { warm, .. } = &mut self {
            *warm = false;
        }
        self
    }

    /// Warm start.
    pub fn warm(&self) -> bool {
        matches!(self, Self::Solver { warm: true, .. })
    }

    /// The solver's registry entry (`None` for a fault).
    pub fn entry(&self) -> Option<&'static SolverEntry> {
        match self {
            Self::Solver { entry, .. } => Some(*entry),
            Self::Fault(_) => None,
        }
    }

    /// Matrix, body-level or cone (`None` for a fault).
    pub fn level(&self) -> Option<Level> {
        self.entry().map(SolverEntry::level)
    }

    /// The solver's parameters (`None` for a fault).
    pub fn params(&self) -> Option<Params> {
        match self {
            Self::Solver { params, .. } => Some(*params),
            Self::Fault(_) => None,
        }
    }

    /// The matrix solver's kind (`None` at another level or for a fault).
    pub fn matrix_kind(&self) -> Option<SolverKind> {
        self.entry().and_then(SolverKind::of)
    }

    /// The body-level solver's kind (`None` at another level or for a fault).
    pub fn body_kind(&self) -> Option<BodySolverKind> {
        self.entry().and_then(BodySolverKind::of)
    }

    /// The cone solver's kind (`None` at another level or for a fault).
    pub fn cone_kind(&self) -> Option<ConeSolverKind> {
        self.entry().and_then(ConeSolverKind::of)
    }

    /// The value of an `omega` parameter (SOR's relaxation) set away from its default.
    pub fn omega(&self) -> Option<f64> {
        let params = self.params()?;
        let spec = params.specs().iter().find(|p| p.key == "omega")?;
        let w = params.get("omega");
        (w != spec.default).then_some(w)
    }

    /// The kind of a plain matrix solver (default parameters, cold start); `None` for any other
    /// specification.
    pub fn plain_kind(&self) -> Option<SolverKind> {
        match self {
            Self::Solver {
                params,
                warm: false,
                ..
            } if params.is_default() => self.matrix_kind(),
            _ => None,
        }
    }

    /// The relaxed or soft problem the solver solves in place of the one it is given, when it
    /// does (its registry entry's); `None` otherwise and for a fault.
    pub fn relaxation(&self) -> Option<&'static str> {
        self.entry().and_then(|e| e.relaxation)
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
        match self.level()? {
            Level::Matrix => self.create().map(ContactSolver::Matrix),
            Level::Body => Some(scene.body_solver_with(self.body_kind()?, self.params()?)),
            Level::Cone => self.create_cone().map(ContactSolver::Cone),
        }
    }

    /// True when the solver iterates from a starting impulse (so `+warm` means something).
    pub fn is_iterative(&self) -> bool {
        self.entry().is_some_and(|e| e.iterative)
    }

    /// The solver's name, or `fault-…`.
    pub fn base_name(&self) -> String {
        match self {
            Self::Solver { entry, .. } => entry.name.to_owned(),
            Self::Fault(f) => format!("fault-{}", f.name()),
        }
    }

    /// Create the matrix solver with its parameters (`None` for body-level, cone and fault
    /// specifications). The one factory of matrix solvers for the harness and the CLI.
    pub fn create(&self) -> Option<Box<dyn Solver + Send>> {
        match self {
            Self::Solver { entry, params, .. } => entry.create(params),
            Self::Fault(_) => None,
        }
    }

    /// Create the cone solver with its parameters (`None` for the other specifications).
    pub fn create_cone(&self) -> Option<Box<dyn ConeSolver + Send>> {
        match self {
            Self::Solver { entry, params, .. } => entry.create_cone(params),
            Self::Fault(_) => None,
        }
    }
}

/// Every solver name of the registry by level, for an error message
/// (`matrix solvers: pgs, …; body-level solvers: si, …; cone solvers: nsgs-cone, …`).
pub fn known_solvers() -> String {
    Level::ALL
        .iter()
        .map(|&level| format!("{}: {}", level.plural(), registry::names_at(level)))
        .collect::<Vec<_>>()
        .join("; ")
}

impl fmt::Display for SolverSpec {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.write_str(&self.base_name())?;
        if let Self::Solver { params, warm, .. } = self {
            if !params.is_default() {
                write!(out, "@{params}")?;
            }
            if *warm {
                out.write_str("+warm")?;
            }
        }
        Ok(())
    }
}

impl std::str::FromStr for SolverSpec {
    type Err = SolverSpecError;

    fn from_str(spec: &str) -> Result<Self, SolverSpecError> {
        let err = |message: String| SolverSpecError {
            spec: spec.to_owned(),
            message,
        };
        let (rest, warm) = match spec.strip_suffix("+warm") {
            Some(r) => (r, true),
            None => (spec, false),
        };
        if let Some(fault) = rest.strip_prefix("fault-") {
            let fault = Fault::from_name(fault)
                .ok_or_else(|| err("fault must be panic, hang or abort".into()))?;
            return Ok(Self::Fault(fault));
        }
        let (name, text) = match rest.split_once('@') {
            Some((n, t)) => (n, Some(t)),
            None => (rest, None),
        };
        let entry = registry::find(name)
            .ok_or_else(|| err(format!("unknown solver `{name}` ({})", known_solvers())))?;
        let params = match text {
            Some(t) if t.trim().is_empty() => {
                return Err(err(format!(
                    "nothing after `@` (keys: {})",
                    Params::keys(entry.params)
                )))
            }
            Some(t) => entry.parse_params(t).map_err(err)?,
            None => entry.defaults(),
        };
        if warm && !entry.iterative {
            return Err(err(format!(
                "+warm applies only to iterative solvers, not {name}"
            )));
        }
        Ok(Self::Solver {
            entry,
            params,
            warm,
        })
    }
}

serde_as_text!(SolverSpec);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_round_trip() {
        for s in [
            "pgs",
            "sor@omega=1.7",
            "pgs+warm",
            "sor@omega=0.9+warm",
            "fault-hang",
            "lemke",
            "nsgs-cone",
            "newton-ac+warm",
            "soft-step@substeps=8,hertz=60+warm",
        ] {
            let spec: SolverSpec = s.parse().unwrap();
            assert_eq!(spec.to_string(), s);
        }
        // The older spelling of a solver's only parameter, written back in the general form.
        assert_eq!(
            "sor@1.7+warm".parse::<SolverSpec>().unwrap().to_string(),
            "sor@omega=1.7+warm"
        );
        assert_eq!(
            "sor@omega=1.3".parse::<SolverSpec>().unwrap().to_string(),
            "sor"
        );
        assert!("lemke+warm".parse::<SolverSpec>().is_err());
        assert!("penalty+warm".parse::<SolverSpec>().is_err());
        assert!("pgs@1.2".parse::<SolverSpec>().is_err());
        assert!("sor@".parse::<SolverSpec>().is_err());
        for bad_omega in [
            "sor@5",
            "sor@0",
            "sor@-1",
            "sor@NaN",
            "sor@2",
            "sor@omega=2.5",
        ] {
            assert!(bad_omega.parse::<SolverSpec>().is_err(), "{bad_omega}");
        }
        assert!("nope".parse::<SolverSpec>().is_err());
    }

    /// `sor@omega=2.5` is refused naming the key and its range; an unknown key naming the
    /// solver's keys; an unknown solver listing the solvers of every level.
    #[test]
    fn refusals_name_the_key_the_range_and_the_known_names() {
        let e = "sor@omega=2.5"
            .parse::<SolverSpec>()
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("omega must be in (0, 2)") && e.contains("2.5"),
            "{e}"
        );
        let e = "sor@alpha=1".parse::<SolverSpec>().unwrap_err().to_string();
        assert!(
            e.contains("unknown parameter `alpha`") && e.contains("keys: omega"),
            "{e}"
        );
        let e = "tgs@omega=1".parse::<SolverSpec>().unwrap_err().to_string();
        assert!(e.contains("keys: substeps"), "{e}");
        let e = "pgs@omega=1.2"
            .parse::<SolverSpec>()
            .unwrap_err()
            .to_string();
        assert!(e.contains("takes no parameters"), "{e}");
        let e = "nope".parse::<SolverSpec>().unwrap_err().to_string();
        for name in [
            "matrix solvers: pgs",
            "body-level solvers: si",
            "avg",
            "clarabel-socp",
        ] {
            assert!(e.contains(name), "{e}");
        }
    }

    #[test]
    fn specs_are_the_solver_and_parameters_their_name_says() {
        let sor: SolverSpec = "sor@omega=1.5+warm".parse().unwrap();
        assert_eq!(sor, SolverSpec::sor(1.5).unwrap().with_warm());
        assert_eq!(sor.omega(), Some(1.5));
        assert_eq!(sor.level(), Some(Level::Matrix));
        assert_eq!(sor.create().unwrap().name(), "sor");
        assert!(SolverSpec::sor(2.0).unwrap_err().contains("(0, 2)"));
        assert_eq!("sor".parse::<SolverSpec>().unwrap().omega(), None);
        let si: SolverSpec = "si+warm".parse().unwrap();
        assert_eq!(
            si,
            SolverSpec::body(BodySolverKind::SequentialImpulses).with_warm()
        );
        assert!(si.create().is_none() && si.create_cone().is_none());
        let cone: SolverSpec = "nsgs-cone".parse().unwrap();
        assert_eq!(cone.create_cone().unwrap().name(), "nsgs-cone");
        assert_eq!(cone.cone_kind(), Some(ConeSolverKind::NsgsCone));
        assert_eq!(
            "fault-panic".parse::<SolverSpec>().unwrap(),
            SolverSpec::Fault(Fault::Panic)
        );
        // Every solver of the registry parses by its name alone, as itself.
        for e in registry::entries() {
            let spec: SolverSpec = e.name.parse().unwrap();
            assert_eq!(spec.entry(), Some(e));
            assert_eq!(spec.to_string(), e.name);
            assert_eq!(spec.is_iterative(), e.iterative);
        }
    }
}

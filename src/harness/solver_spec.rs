//! Solver specifications: a solver kind with its options (SOR relaxation, warm or cold start),
//! or an injected fault, as named on the command line and in the `solver` column.

use crate::harness::fault::Fault;
use crate::harness::text::serde_as_text;
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::scene::Scene;
use lcpbench_contact::substep::Params;
use lcpbench_contact::ContactSolver;
use lcpbench_solvers::{ConeSolver, ConeSolverKind, ProjectedSor, Solver, SolverKind};
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

/// A solver with its variant: `NAME[@OMEGA][+warm]`, for example `pgs`, `sor@1.7`, `pgs+warm`,
/// `si+warm`, `nsgs-cone+warm`, or an injected fault `fault-panic`. Names are the matrix solvers
/// of `lcpbench-solvers`, the body-level solvers of `lcpbench-contact` (`si`, `body-micro`,
/// `penalty`, `avg`; scenes only) and the cone solvers (`nsgs-cone`, `newton-ac`,
/// `newton-fb-cone`, `newton-nm-cone`, `eg-cone`, `fpp-cone`, `admm-cone`, `prox-cone`,
/// `clarabel-socp`: scenes with friction model `cone`, and LCP cases whose rows are (normal,
/// tangent, tangent) triples, solved as the cone). See [`catalogue`](crate::harness::catalogue::catalogue) for every
/// name with its level.
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
        /// Its parameters (`name@key=value,…`; the substepping solvers' `substeps`, `hertz`,
        /// …), checked against [`BodySolverKind::param_specs`].
        params: Params,
        /// Warm start (`si`, `body-micro`, `avg`, the substepping solvers).
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

/// Plain PGS, cold start: the value of a [`RunRecord`](crate::harness::RunRecord) not yet
/// filled.
impl Default for SolverSpec {
    fn default() -> Self {
        Self::plain(SolverKind::Pgs)
    }
}

impl SolverSpec {
    /// Plain matrix solver with default parameters, cold start.
    pub const fn plain(kind: SolverKind) -> Self {
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
    pub const fn body(kind: BodySolverKind) -> Self {
        Self::Body {
            kind,
            params: Params::defaults(kind.param_specs()),
            warm: false,
        }
    }

    /// A body-level solver with parameters, cold start.
    pub const fn body_with(kind: BodySolverKind, params: Params) -> Self {
        Self::Body {
            kind,
            params,
            warm: false,
        }
    }

    /// Plain cone solver, cold start.
    pub const fn cone(kind: ConeSolverKind) -> Self {
        Self::Cone { kind, warm: false }
    }

    /// The same solver, warm-started (no effect on a fault; not validated, see
    /// [`SolverSpec::is_iterative`]).
    pub const fn with_warm(mut self) -> Self {
        match &mut self {
            Self::Matrix { warm, .. } | Self::Body { warm, .. } | Self::Cone { warm, .. } => {
                *warm = true
            }
            Self::Fault(_) => {}
        }
        self
    }

    /// The same solver, cold start.
    pub const fn cold(mut self) -> Self {
        match &mut self {
            Self::Matrix { warm, .. } | Self::Body { warm, .. } | Self::Cone { warm, .. } => {
                *warm = false
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

    /// The kind of a plain matrix solver (default parameters, cold start); `None` for any other
    /// specification.
    pub fn plain_kind(&self) -> Option<SolverKind> {
        match *self {
            Self::Matrix {
                kind,
                omega: None,
                warm: false,
            } => Some(kind),
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
            Self::Body { kind, params, .. } => Some(scene.body_solver_with(kind, params)),
            Self::Cone { .. } => self.create_cone().map(ContactSolver::Cone),
            Self::Fault(_) => None,
        }
    }

    /// True when the solver iterates from a starting impulse (so `+warm` means something).
    pub fn is_iterative(&self) -> bool {
        match self {
            Self::Matrix { kind, .. } => kind.is_iterative(),
            Self::Body { kind, .. } => kind.is_iterative(),
            Self::Cone { kind, .. } => kind.is_iterative(),
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
        if let Self::Body { params, .. } = self {
            if !params.is_default() {
                write!(out, "@{params}")?;
            }
        }
        if self.warm() {
            out.write_str("+warm")?;
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
        if let Some((kind, params)) = BodySolverKind::parse_spec(rest).map_err(err)? {
            let out = Self::body_with(kind, params);
            if warm && !out.is_iterative() {
                return Err(err(format!(
                    "+warm applies only to iterative solvers, not {}",
                    kind.name()
                )));
            }
            return Ok(if warm { out.with_warm() } else { out });
        }
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
                    "{e}; body-level solvers: {}; cone solvers: {}",
                    BodySolverKind::ALL
                        .iter()
                        .map(|k| k.name())
                        .collect::<Vec<_>>()
                        .join(", "),
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

serde_as_text!(SolverSpec);

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
            SolverSpec::body(BodySolverKind::SequentialImpulses).with_warm()
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
}

//! # lcpbench-solvers
//!
//! Linear complementarity problems of rigid-body contact and interchangeable solvers for them.
//!
//! A [`Problem`] is a boxed LCP: find `f` with
//!
//! ```text
//! w = A f + b,   lo <= f <= hi,   f_i = lo_i ⇒ w_i >= 0,   f_i = hi_i ⇒ w_i <= 0,
//! lo_i < f_i < hi_i ⇒ w_i = 0,
//! ```
//!
//! where a friction row `i` takes the bounds `±mu f_k` of its normal row `k`. The standard LCP
//! `0 <= f ⟂ A f + b >= 0` is the case `lo = 0`, `hi = ∞`; a *free* row (`lo = −∞`, `hi = ∞`,
//! so `w_i = 0` with `f_i` of either sign) is a joint's equality constraint, and a problem with
//! free rows is a mixed LCP. Every solver implements [`Solver`] (each one's treatment of free
//! rows is in [`SolverKind::problem_classes`]), and every result's [`Status`] is decided by the
//! one shared residual in [`metrics`].
//!
//! The exact Coulomb cone (FC3D, De Saxcé's form) is a separate class, [`ConeProblem`], with its
//! own solvers ([`ConeSolver`], [`ConeSolverKind`]) whose statuses are decided by the cone
//! residual in [`cone`]; [`ConeProblem::from_box`] and [`ConeProblem::to_box`] convert to and
//! from the box-friction LCP.
//!
//! ```
//! use lcpbench_solvers::{Problem, Settings, SolverKind, Status};
//! use faer::Mat;
//!
//! let a = Mat::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 2.0]][i][j]);
//! let problem = Problem::lcp(a, vec![-1.0, 1.0]).unwrap();
//! for kind in SolverKind::ALL {
//!     let result = kind.create().solve(&problem, &Settings::default());
//!     assert_eq!(result.status, Status::Converged, "{}", kind.name());
//!     assert!((result.f[0] - 0.5).abs() < 1e-6);
//! }
//! ```
#![warn(missing_docs)]

pub mod cone;
pub mod delassus;
pub mod io;
mod lcp;
mod linalg;
mod problem;
mod solver;
#[cfg(test)]
mod test_util;

pub use problem::{certificate, generate, metrics};

pub use cone::admm::AdmmCone;
pub use cone::clarabel_socp::{delassus_asymmetry, ClarabelSocp, SYMMETRISE_WITHIN};
pub use cone::extragradient::ExtragradientCone;
pub use cone::fixed_point_projection::FixedPointProjectionCone;
pub use cone::newton::{ConeFunction, ConeNewton, NewtonAc};
pub use cone::nsgs_cone::{NsgsCone, NsgsConeSettings};
pub use cone::proximal::ProxCone;
pub use cone::{
    cone_residuals, cone_residuals_and_velocity, judge_cone, normal_unresolved, project_onto_cone,
    ConeError, ConeProblem, ConeSolver, NormalUnresolved,
};
pub use io::cone::{cone_problem_to_json, is_cone_file, parse_cone_problem};
pub use io::fclib::{parse_fclib, read_fclib, write_fclib_local, write_problem_as_fclib};
pub use io::siconos::{parse_siconos, parse_siconos_lcp};
pub use io::{
    parse_problem, problem_to_json, read_problem, write_problem, ProblemFileError, ProblemFormat,
    MAX_FILE_MU,
};
pub use lcp::apgd::Apgd;
pub use lcp::clarabel_qp::{ClarabelQp, InteriorPoint};
pub use lcp::dantzig::Dantzig;
pub use lcp::enumeration::{Enumeration, MAX_BASES};
pub use lcp::lemke::Lemke;
pub use lcp::micro_impulse::MicroImpulse;
pub use lcp::newton::{
    FrictionHandling, Globalisation, LinearSystem, Newton, NewtonWorkspace, Reformulation,
    Remedies, SparseForm,
};
pub use lcp::nncg::Nncg;
pub use lcp::nsgs::Nsgs;
pub use lcp::pgs::{ProjectedSor, SweepForm};
pub use metrics::{residuals, residuals_and_velocity, Residuals};
pub use problem::certificate::Certificate;
pub use problem::{sparse_from_triplets, DelassusFactors, FrictionRow, Problem, ProblemError, Row};
pub use solver::line_search::{Backtracking, LineSearchError};
pub use solver::{
    decide, judge, non_finite_reason, HistoryPoint, Outcome, Settings, SettingsError, SolveResult,
    Solver, Stagnation, Status, FIRST_ORDER_STAGNATION_WINDOW, STAGNATION_DROP,
    STAGNATION_MEASURE_EVERY,
};

/// The solvers lcpbench ships, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SolverKind {
    /// Projected Gauss–Seidel.
    Pgs,
    /// Projected SOR (`omega = 1.3` unless set).
    Sor,
    /// Lemke's complementary pivoting.
    Lemke,
    /// Dantzig principal pivoting (ODE's `dSolveLCP` style).
    Dantzig,
    /// Convex QP through Clarabel's interior-point method.
    Clarabel,
    /// Sequential micro-impulses.
    MicroImpulse,
    /// Semismooth Newton on the Fischer–Burmeister reformulation.
    NewtonFb,
    /// Semismooth Newton on the min-map reformulation.
    NewtonMin,
    /// Accelerated projected gradient descent (Nesterov with adaptive restart).
    Apgd,
    /// Nonsmooth nonlinear conjugate gradient (PGS with Fletcher–Reeves directions).
    Nncg,
    /// Block Gauss–Seidel over contacts, each block solved exactly.
    Nsgs,
    /// Enumeration of complementary bases (complete, small problems).
    Enumeration,
}

impl SolverKind {
    /// Every solver, in report order.
    pub const ALL: [SolverKind; 12] = [
        SolverKind::Pgs,
        SolverKind::Sor,
        SolverKind::Lemke,
        SolverKind::Dantzig,
        SolverKind::Clarabel,
        SolverKind::MicroImpulse,
        SolverKind::NewtonFb,
        SolverKind::NewtonMin,
        SolverKind::Apgd,
        SolverKind::Nncg,
        SolverKind::Nsgs,
        SolverKind::Enumeration,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Pgs => "pgs",
            SolverKind::Sor => "sor",
            SolverKind::Lemke => "lemke",
            SolverKind::Dantzig => "dantzig",
            SolverKind::Clarabel => "clarabel",
            SolverKind::MicroImpulse => "micro",
            SolverKind::NewtonFb => "newton-fb",
            SolverKind::NewtonMin => "newton-min",
            SolverKind::Apgd => "apgd",
            SolverKind::Nncg => "nncg",
            SolverKind::Nsgs => "nsgs",
            SolverKind::Enumeration => "enum",
        }
    }

    /// Look a solver up by name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The problem classes the solver handles, in one line.
    pub fn problem_classes(self) -> &'static str {
        match self {
            SolverKind::Pgs => lcp::pgs::PROBLEM_CLASSES_PGS,
            SolverKind::Sor => lcp::pgs::PROBLEM_CLASSES_SOR,
            SolverKind::Lemke => lcp::lemke::PROBLEM_CLASSES,
            SolverKind::Dantzig => lcp::dantzig::PROBLEM_CLASSES,
            SolverKind::Clarabel => lcp::clarabel_qp::PROBLEM_CLASSES,
            SolverKind::MicroImpulse => lcp::micro_impulse::PROBLEM_CLASSES,
            SolverKind::NewtonFb => lcp::newton::PROBLEM_CLASSES_FB,
            SolverKind::NewtonMin => lcp::newton::PROBLEM_CLASSES_MIN,
            SolverKind::Apgd => lcp::apgd::PROBLEM_CLASSES,
            SolverKind::Nncg => lcp::nncg::PROBLEM_CLASSES,
            SolverKind::Nsgs => lcp::nsgs::PROBLEM_CLASSES,
            SolverKind::Enumeration => lcp::enumeration::PROBLEM_CLASSES,
        }
    }

    /// The relaxed problem the solver solves in place of the one it is given, when it does:
    /// Clarabel solves the convex QP whose optimality conditions are the LCP, which on box
    /// friction rows (bounds scaled by the normal impulse) is Anitescu's convex relaxation,
    /// not Coulomb's friction. `None` for the solvers of the problem as posed.
    pub fn relaxation(self) -> Option<&'static str> {
        match self {
            SolverKind::Clarabel => Some(
                "on friction rows, Anitescu's convex relaxation (a QP whose sliding contacts \
                 may lift off), not the friction LCP",
            ),
            _ => None,
        }
    }

    /// True for solvers that iterate from a starting impulse (and so use a warm start).
    pub fn is_iterative(self) -> bool {
        matches!(
            self,
            SolverKind::Pgs
                | SolverKind::Sor
                | SolverKind::MicroImpulse
                | SolverKind::NewtonFb
                | SolverKind::NewtonMin
                | SolverKind::Apgd
                | SolverKind::Nncg
                | SolverKind::Nsgs
        )
    }

    /// A solver of this kind with default parameters.
    pub fn create(self) -> Box<dyn Solver + Send> {
        match self {
            SolverKind::Pgs => Box::new(ProjectedSor::pgs()),
            SolverKind::Sor => Box::new(ProjectedSor::sor(1.3)),
            SolverKind::Lemke => Box::new(Lemke::default()),
            SolverKind::Dantzig => Box::new(Dantzig::default()),
            SolverKind::Clarabel => Box::new(ClarabelQp::default()),
            SolverKind::MicroImpulse => Box::new(MicroImpulse::default()),
            SolverKind::NewtonFb => Box::new(Newton::fischer_burmeister()),
            SolverKind::NewtonMin => Box::new(Newton::min_map()),
            SolverKind::Apgd => Box::new(Apgd),
            SolverKind::Nncg => Box::new(Nncg),
            SolverKind::Nsgs => Box::new(Nsgs),
            SolverKind::Enumeration => Box::new(Enumeration),
        }
    }
}

impl std::str::FromStr for SolverKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| {
            let names: Vec<_> = Self::ALL.iter().map(|k| k.name()).collect();
            format!("unknown solver `{s}` (known: {})", names.join(", "))
        })
    }
}

/// The solvers of the exact Coulomb cone ([`ConeProblem`]), by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ConeSolverKind {
    /// Block Gauss–Seidel over contacts, each contact solved exactly on its cone.
    NsgsCone,
    /// Global Alart–Curnier semismooth Newton.
    NewtonAc,
    /// Global semismooth Newton on the second-order-cone Fischer–Burmeister function.
    NewtonFbCone,
    /// Global semismooth Newton on the natural map.
    NewtonNmCone,
    /// Extragradient (Khobotov) projection method on De Saxcé's map, self-adaptive step.
    ExtragradientCone,
    /// Fixed-point projection on De Saxcé's map, self-adaptive step.
    FixedPointProjectionCone,
    /// Accelerated ADMM with the De Saxcé term refreshed every iteration.
    AdmmCone,
    /// Proximal point, each regularised problem solved by NSGS over contacts.
    ProxCone,
    /// Anitescu's convex relaxation as a second-order cone program, through Clarabel.
    ClarabelSocp,
}

impl ConeSolverKind {
    /// Every cone solver, in report order.
    pub const ALL: [ConeSolverKind; 9] = [
        ConeSolverKind::NsgsCone,
        ConeSolverKind::NewtonAc,
        ConeSolverKind::NewtonFbCone,
        ConeSolverKind::NewtonNmCone,
        ConeSolverKind::ExtragradientCone,
        ConeSolverKind::FixedPointProjectionCone,
        ConeSolverKind::AdmmCone,
        ConeSolverKind::ProxCone,
        ConeSolverKind::ClarabelSocp,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            ConeSolverKind::NsgsCone => "nsgs-cone",
            ConeSolverKind::NewtonAc => "newton-ac",
            ConeSolverKind::NewtonFbCone => "newton-fb-cone",
            ConeSolverKind::NewtonNmCone => "newton-nm-cone",
            ConeSolverKind::ExtragradientCone => "eg-cone",
            ConeSolverKind::FixedPointProjectionCone => "fpp-cone",
            ConeSolverKind::AdmmCone => "admm-cone",
            ConeSolverKind::ProxCone => "prox-cone",
            ConeSolverKind::ClarabelSocp => "clarabel-socp",
        }
    }

    /// Look a cone solver up by name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The problem classes the solver handles, in one line.
    pub fn problem_classes(self) -> &'static str {
        match self {
            ConeSolverKind::NsgsCone => cone::nsgs_cone::PROBLEM_CLASSES,
            ConeSolverKind::NewtonAc => cone::newton::PROBLEM_CLASSES_AC,
            ConeSolverKind::NewtonFbCone => cone::newton::PROBLEM_CLASSES_FB,
            ConeSolverKind::NewtonNmCone => cone::newton::PROBLEM_CLASSES_NM,
            ConeSolverKind::ExtragradientCone => cone::extragradient::PROBLEM_CLASSES,
            ConeSolverKind::FixedPointProjectionCone => {
                cone::fixed_point_projection::PROBLEM_CLASSES
            }
            ConeSolverKind::AdmmCone => cone::admm::PROBLEM_CLASSES,
            ConeSolverKind::ProxCone => cone::proximal::PROBLEM_CLASSES,
            ConeSolverKind::ClarabelSocp => cone::clarabel_socp::PROBLEM_CLASSES,
        }
    }

    /// True for solvers that iterate from a starting reaction (and so use
    /// [`Settings::warm_start`]): every cone solver but Clarabel's SOCP, which starts from its
    /// own interior point and ignores a warm start.
    pub fn is_iterative(self) -> bool {
        !matches!(self, ConeSolverKind::ClarabelSocp)
    }

    /// True for solvers of a relaxation of Coulomb's law (whose answer is exact only where no
    /// contact slides, and so not `converged` on sliding problems).
    pub fn is_relaxation(self) -> bool {
        matches!(self, ConeSolverKind::ClarabelSocp)
    }

    /// The relaxed problem the solver solves in place of the cone problem, when it does:
    /// Clarabel's SOCP is Anitescu's convex relaxation of Coulomb's law (a sliding contact
    /// lifts off). `None` for the solvers of the exact cone problem.
    pub fn relaxation(self) -> Option<&'static str> {
        self.is_relaxation().then_some(
            "Anitescu's convex relaxation of the Coulomb cone (sliding contacts lift off)",
        )
    }

    /// A solver of this kind with default parameters.
    pub fn create(self) -> Box<dyn ConeSolver + Send> {
        match self {
            ConeSolverKind::NsgsCone => Box::new(NsgsCone::default()),
            ConeSolverKind::NewtonAc => Box::new(ConeNewton::alart_curnier()),
            ConeSolverKind::NewtonFbCone => Box::new(ConeNewton::fischer_burmeister()),
            ConeSolverKind::NewtonNmCone => Box::new(ConeNewton::natural_map()),
            ConeSolverKind::ExtragradientCone => Box::new(ExtragradientCone),
            ConeSolverKind::FixedPointProjectionCone => Box::new(FixedPointProjectionCone),
            ConeSolverKind::AdmmCone => Box::new(AdmmCone::default()),
            ConeSolverKind::ProxCone => Box::new(ProxCone::default()),
            ConeSolverKind::ClarabelSocp => Box::new(ClarabelSocp::default()),
        }
    }
}

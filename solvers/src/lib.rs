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
//! free rows is a mixed LCP. Every solver implements [`Solver`] and is described once in the
//! [`registry`] (each one's treatment of free rows is in its entry's `problem_classes`), and
//! every result's [`Status`] is decided by the one shared residual in [`metrics`].
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
//! for kind in SolverKind::all() {
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
pub mod registry;
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
pub use cone::sap::Sap;
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
    FrictionHandling, Globalisation, KrylovSettings, KrylovStats, LinearSystem, Newton,
    NewtonWorkspace, Reformulation, Remedies, SparseForm, START_SWEEPS,
};
pub use lcp::nncg::Nncg;
pub use lcp::nsgs::Nsgs;
pub use lcp::pgs::{ProjectedSor, SweepForm};
pub use metrics::{residuals, residuals_and_velocity, Residuals};
pub use problem::certificate::Certificate;
pub use problem::{sparse_from_triplets, DelassusFactors, FrictionRow, Problem, ProblemError, Row};
pub use registry::{Level, Make, ParamSpec, Params, SolverEntry};
pub use solver::line_search::{Backtracking, LineSearchError};
pub use solver::{
    decide, judge, non_finite_reason, HistoryPoint, Outcome, Settings, SettingsError, SolveResult,
    Solver, Stagnation, Status, FIRST_ORDER_STAGNATION_WINDOW, STAGNATION_DROP,
    STAGNATION_MEASURE_EVERY,
};

/// A matrix solver of the [`registry`]: a `Copy` handle to its [`SolverEntry`]. The built-in
/// ones have associated constants (`SolverKind::Pgs`, …); [`SolverKind::all`] lists them and
/// the ones registered at run time.
#[derive(Clone, Copy)]
pub struct SolverKind(&'static SolverEntry);

crate::kind_handle!(SolverKind, Level::Matrix, || registry::entries_at(
    Level::Matrix
));

#[allow(non_upper_case_globals)]
impl SolverKind {
    /// Projected Gauss–Seidel.
    pub const Pgs: Self = Self(&lcp::pgs::PGS);
    /// Projected SOR (`omega = 1.3` unless set).
    pub const Sor: Self = Self(&lcp::pgs::SOR);
    /// Lemke's complementary pivoting.
    pub const Lemke: Self = Self(&lcp::lemke::LEMKE);
    /// Dantzig principal pivoting (ODE's `dSolveLCP` style).
    pub const Dantzig: Self = Self(&lcp::dantzig::DANTZIG);
    /// Convex QP through Clarabel's interior-point method.
    pub const Clarabel: Self = Self(&lcp::clarabel_qp::CLARABEL);
    /// Sequential micro-impulses.
    pub const MicroImpulse: Self = Self(&lcp::micro_impulse::MICRO);
    /// Semismooth Newton on the Fischer–Burmeister reformulation.
    pub const NewtonFb: Self = Self(&lcp::newton::NEWTON_FB);
    /// Semismooth Newton on the min-map reformulation.
    pub const NewtonMin: Self = Self(&lcp::newton::NEWTON_MIN);
    /// Accelerated projected gradient descent (Nesterov with adaptive restart).
    pub const Apgd: Self = Self(&lcp::apgd::APGD);
    /// Nonsmooth nonlinear conjugate gradient (PGS with Fletcher–Reeves directions).
    pub const Nncg: Self = Self(&lcp::nncg::NNCG);
    /// Block Gauss–Seidel over contacts, each block solved exactly.
    pub const Nsgs: Self = Self(&lcp::nsgs::NSGS);
    /// Enumeration of complementary bases (complete, small problems).
    pub const Enumeration: Self = Self(&lcp::enumeration::ENUM);

    /// A solver of this kind with default parameters.
    pub fn create(self) -> Box<dyn Solver + Send> {
        self.create_with(&self.0.defaults())
    }

    /// A solver of this kind with `params` (which follow [`SolverKind::param_specs`]).
    pub fn create_with(self, params: &Params) -> Box<dyn Solver + Send> {
        match self.0.make {
            Make::Matrix(make) => make(params),
            // A handle is made only for an entry of its level (`SolverKind::of`).
            _ => unreachable!("SolverKind({}) holds a matrix entry", self.0.name),
        }
    }
}

/// A solver of the exact Coulomb cone ([`ConeProblem`]) of the [`registry`]: a `Copy` handle to
/// its [`SolverEntry`], as [`SolverKind`].
#[derive(Clone, Copy)]
pub struct ConeSolverKind(&'static SolverEntry);

crate::kind_handle!(ConeSolverKind, Level::Cone, || registry::entries_at(
    Level::Cone
));

#[allow(non_upper_case_globals)]
impl ConeSolverKind {
    /// Block Gauss–Seidel over contacts, each contact solved exactly on its cone.
    pub const NsgsCone: Self = Self(&cone::nsgs_cone::NSGS_CONE);
    /// Global Alart–Curnier semismooth Newton.
    pub const NewtonAc: Self = Self(&cone::newton::NEWTON_AC);
    /// Global semismooth Newton on the second-order-cone Fischer–Burmeister function.
    pub const NewtonFbCone: Self = Self(&cone::newton::NEWTON_FB_CONE);
    /// Global semismooth Newton on the natural map.
    pub const NewtonNmCone: Self = Self(&cone::newton::NEWTON_NM_CONE);
    /// Extragradient (Khobotov) projection method on De Saxcé's map, self-adaptive step.
    pub const ExtragradientCone: Self = Self(&cone::extragradient::EG_CONE);
    /// Fixed-point projection on De Saxcé's map, self-adaptive step.
    pub const FixedPointProjectionCone: Self = Self(&cone::fixed_point_projection::FPP_CONE);
    /// Accelerated ADMM with the De Saxcé term refreshed every iteration.
    pub const AdmmCone: Self = Self(&cone::admm::ADMM_CONE);
    /// Proximal point, each regularised problem solved by NSGS over contacts.
    pub const ProxCone: Self = Self(&cone::proximal::PROX_CONE);
    /// Anitescu's convex relaxation as a second-order cone program, through Clarabel.
    pub const ClarabelSocp: Self = Self(&cone::clarabel_socp::CLARABEL_SOCP);
    /// SAP: Newton on the body velocities of the regularised convex contact model.
    pub const Sap: Self = Self(&cone::sap::SAP);

    /// True for solvers of a relaxation of Coulomb's law (whose answer is exact only where no
    /// contact slides, and so not `converged` on sliding problems).
    pub fn is_relaxation(self) -> bool {
        self.0.relaxation.is_some()
    }

    /// A solver of this kind with default parameters.
    pub fn create(self) -> Box<dyn ConeSolver + Send> {
        self.create_with(&self.0.defaults())
    }

    /// A solver of this kind with `params` (which follow [`ConeSolverKind::param_specs`]).
    pub fn create_with(self, params: &Params) -> Box<dyn ConeSolver + Send> {
        match self.0.make {
            Make::Cone(make) => make(params),
            // A handle is made only for an entry of its level (`ConeSolverKind::of`).
            _ => unreachable!("ConeSolverKind({}) holds a cone entry", self.0.name),
        }
    }
}

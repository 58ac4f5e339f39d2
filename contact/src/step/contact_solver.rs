//! The contact solver of a world ([`ContactSolver`]): a matrix, body-level or cone solver
//! instance, its names, the friction models it takes, and its solve of one island's problem or
//! of the whole step.

use super::solve::{usable_impulse, IslandProblem, Solved};
use crate::body_solvers::{BodySolver, BodySolverKind};
use crate::builder::{ContactSystem, DelassusForm, FrictionModel};
use lcpbench_solvers::registry::Level;
use lcpbench_solvers::{ConeSolver, ConeSolverKind, Settings, SolveResult, Solver, SolverKind};
use std::time::Instant;

/// The contact solver of a scene, as an owned, configured instance: a matrix solver of
/// `lcpbench-solvers`, a body-level one, or a solver of the exact Coulomb cone. Every parameter
/// of the instance (SOR's `omega`, Newton's settings, the penalty spring) reaches the steps.
/// Cloning clones the instance (`dyn_clone::DynClone`, which every solver trait requires);
/// islands solved in parallel each get a clone of the instance the world was given, kept for
/// the same island in the next step (a kept instance answers as a fresh clone).
#[derive(Clone)]
pub enum ContactSolver {
    /// A solver on the assembled LCP (friction models `none`, `box`, `pyramid`).
    Matrix(Box<dyn Solver + Send>),
    /// A solver on bodies (matrix-free; friction models `none`, `box`).
    Body(Box<dyn BodySolver + Send>),
    /// A solver of the FC3D cone problem (friction model `cone` only).
    Cone(Box<dyn ConeSolver + Send>),
}

impl std::fmt::Debug for ContactSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ContactSolver({})", self.name())
    }
}

impl From<SolverKind> for ContactSolver {
    fn from(kind: SolverKind) -> Self {
        ContactSolver::Matrix(kind.create())
    }
}

impl From<BodySolverKind> for ContactSolver {
    fn from(kind: BodySolverKind) -> Self {
        ContactSolver::Body(kind.create())
    }
}

impl From<ConeSolverKind> for ContactSolver {
    fn from(kind: ConeSolverKind) -> Self {
        ContactSolver::Cone(kind.create())
    }
}

impl ContactSolver {
    /// The solver of this name with default parameters, at any level (every name of
    /// [`crate::registry::entries`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::from_entry(crate::registry::find(name)?)
    }

    /// The solver of a registry entry with default parameters.
    pub fn from_entry(entry: &'static lcpbench_solvers::SolverEntry) -> Option<Self> {
        let params = entry.defaults();
        match entry.level() {
            Level::Matrix => entry.create(&params).map(ContactSolver::Matrix),
            Level::Cone => entry.create_cone(&params).map(ContactSolver::Cone),
            Level::Body => BodySolverKind::of(entry).map(Self::from),
        }
    }

    /// The solver's name.
    pub fn name(&self) -> &'static str {
        match self {
            ContactSolver::Matrix(s) => s.name(),
            ContactSolver::Body(s) => s.name(),
            ContactSolver::Cone(s) => s.name(),
        }
    }

    /// True for a substepping solver ([`crate::substep`]), which moves the bodies itself.
    pub fn substeps(&self) -> bool {
        matches!(self, ContactSolver::Body(s) if s.kind().substeps())
    }

    /// True for a cone solver.
    pub fn is_cone(&self) -> bool {
        matches!(self, ContactSolver::Cone(_))
    }

    /// True when the stepper passes this solver the previous step's impulses: the iterative
    /// matrix solvers (their registry entry's `iterative`), every cone solver and every
    /// body-level solver. Pivoting and interior-point solvers start cold.
    pub fn takes_warm_start(&self) -> bool {
        match self {
            ContactSolver::Matrix(s) => s.entry().iterative,
            ContactSolver::Body(_) | ContactSolver::Cone(_) => true,
        }
    }

    /// `Ok` when this solver takes the problems of `model`; otherwise why not. A step whose
    /// solver does not take the friction model is `Unsupported` with this reason (and applies
    /// no impulse); scene files and the command line refuse the pair up front
    /// ([`crate::scene::check_solver`]).
    pub fn supports(&self, model: FrictionModel) -> Result<(), String> {
        match (self, model) {
            (ContactSolver::Body(s), FrictionModel::Pyramid { .. }) => Err(format!(
                "body-level solver `{}` supports friction_model \"none\" or \"box\", not \"pyramid\"",
                s.name()
            )),
            (ContactSolver::Matrix(_) | ContactSolver::Body(_), FrictionModel::Cone) => Err(format!(
                "solver `{}` solves the LCP models (friction_model \"none\", \"box\", \"pyramid\"), \
                 not the exact Coulomb cone of friction_model \"cone\": use a cone solver ({})",
                self.name(),
                Self::cone_names()
            )),
            (ContactSolver::Cone(s), m) if m != FrictionModel::Cone => Err(format!(
                "cone solver `{}` solves friction_model \"cone\" only, not \"{}\" (use a matrix or \
                 body-level solver, or friction_model \"cone\")",
                s.name(),
                m.name()
            )),
            _ => Ok(()),
        }
    }

    /// `Ok` when this solver takes joint (equality) rows with the contacts; otherwise why not.
    /// Matrix solvers take the step's mixed LCP (each solver says itself, as `Unsupported`,
    /// when it cannot solve free rows); of the body-level solvers only sequential impulses
    /// applies joints (as engines do); the FC3D cone problem has no place for them.
    pub fn supports_joints(&self) -> Result<(), String> {
        match self {
            ContactSolver::Matrix(_) => Ok(()),
            ContactSolver::Body(s) if s.kind().takes_joints() => Ok(()),
            ContactSolver::Body(s) => Err(format!(
                "body-level solver `{}` resolves contacts only, not joints: use a matrix solver \
                 or a body-level one that takes joints ({}) on scenes with joints",
                s.name(),
                BodySolverKind::all()
                    .iter()
                    .filter(|k| k.takes_joints())
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            ContactSolver::Cone(s) => Err(format!(
                "cone solver `{}` solves the FC3D contact problem, which has no joint rows: use a \
                 matrix solver or `si` (friction_model \"box\") on scenes with joints",
                s.name()
            )),
        }
    }

    /// Comma-separated names of the cone solvers.
    pub fn cone_names() -> String {
        crate::registry::names_at(Level::Cone)
    }

    /// The name of every solver a scene can use: matrix, body-level, cone.
    pub fn all_names() -> String {
        crate::registry::entries()
            .iter()
            .map(|e| e.name)
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The form of `A` this solver's problems take: factored for a matrix solver that sweeps on
    /// the factors ([`Solver::works_on_factors`]), so that `A` is not assembled for it;
    /// assembled otherwise.
    pub(super) fn delassus_form(&self) -> DelassusForm {
        match self {
            ContactSolver::Matrix(s) if s.works_on_factors() => DelassusForm::Factored,
            _ => DelassusForm::Assembled,
        }
    }

    /// Solve one island's problem with this (matrix or cone) solver.
    pub(super) fn solve_island(
        &mut self,
        problem: &IslandProblem,
        settings: &Settings,
    ) -> Result<SolveResult, String> {
        match (self, problem) {
            (ContactSolver::Matrix(s), IslandProblem::Lcp(p)) => Ok(s.solve(p, settings)),
            (ContactSolver::Cone(s), IslandProblem::Cone(p)) => Ok(s.solve_cone(p, settings)),
            (s, _) => Err(format!(
                "solver `{}` does not take this island's problem",
                s.name()
            )),
        }
    }

    /// Solve the whole step as one problem with this (matrix or cone) solver.
    pub(super) fn solve_whole(&mut self, system: &ContactSystem, settings: &Settings) -> Solved {
        let n = system.n();
        let t0 = Instant::now();
        let form = self.delassus_form();
        let (result, problem, cone_problem, assembly_s) = match self {
            ContactSolver::Matrix(s) => match system.problem_in(form) {
                Ok(p) => {
                    let assembly_s = t0.elapsed().as_secs_f64();
                    (s.solve(&p, settings), Some(p), None, assembly_s)
                }
                Err(e) => return Solved::invalid(n, &e),
            },
            ContactSolver::Cone(s) => match system.cone_problem() {
                Ok(p) => {
                    let assembly_s = t0.elapsed().as_secs_f64();
                    (s.solve_cone(&p, settings), None, Some(p), assembly_s)
                }
                Err(e) => return Solved::invalid(n, &e),
            },
            ContactSolver::Body(s) => {
                let reason = format!("body-level solver `{}` solves on bodies", s.name());
                return Solved::unsupported(n, reason);
            }
        };
        let call_s = t0.elapsed().as_secs_f64() - assembly_s;
        Solved {
            f: usable_impulse(&result, n),
            status: result.status,
            iterations: result.iterations,
            time_s: result.time.as_secs_f64(),
            wall_s: 0.0,
            assembly_s,
            measure_s: (call_s - result.time.as_secs_f64()).max(0.0),
            residuals: Some(result.residuals),
            problem,
            cone_problem,
            history: result.history,
            warm_start: None,
            substepped: None,
        }
    }
}

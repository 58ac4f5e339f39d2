//! The catalogue of every solver: its name, level, problem classes and whether `+warm`
//! applies (what `lcpbench solvers` lists).

use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::substep::ParamSpec;
use lcpbench_solvers::{ConeSolverKind, SolverKind};

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
    /// Its parameters (`name@key=value,…`) with defaults and ranges; empty for most.
    pub params: &'static [ParamSpec],
}

/// Every solver, matrix solvers first, then the body-level and the cone solvers (the order of
/// `lcpbench solvers`).
pub fn catalogue() -> Vec<CatalogueEntry> {
    let matrix = SolverKind::ALL.into_iter().map(|k| CatalogueEntry {
        name: k.name(),
        level: SolverLevel::Matrix,
        problem_classes: k.problem_classes(),
        iterative: k.is_iterative(),
        params: &[],
    });
    let body = BodySolverKind::ALL.into_iter().map(|k| CatalogueEntry {
        name: k.name(),
        level: SolverLevel::Body,
        problem_classes: k.problem_classes(),
        iterative: k.is_iterative(),
        params: k.param_specs(),
    });
    let cone = ConeSolverKind::ALL.into_iter().map(|k| CatalogueEntry {
        name: k.name(),
        level: SolverLevel::Cone,
        problem_classes: k.problem_classes(),
        iterative: k.is_iterative(),
        params: &[],
    });
    matrix.chain(body).chain(cone).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::SolverSpec;

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
}

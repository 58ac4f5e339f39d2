//! The catalogue of every solver: the solver registry (`lcpbench_contact::registry`) as
//! `lcpbench solvers` lists it — name, level, problem classes, whether `+warm` applies, what
//! its iterations count and its parameters.

pub use lcpbench_solvers::registry::Level as SolverLevel;
pub use lcpbench_solvers::registry::SolverEntry as CatalogueEntry;

/// Every solver, matrix solvers first, then the body-level and the cone solvers, then those
/// registered at run time (the order of `lcpbench solvers`).
pub fn catalogue() -> Vec<&'static CatalogueEntry> {
    lcpbench_contact::registry::entries()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::SolverSpec;

    #[test]
    fn the_catalogue_names_every_parsable_solver_once() {
        let entries = catalogue();
        for e in &entries {
            let spec: SolverSpec = e.name.parse().unwrap();
            assert_eq!(spec.base_name(), e.name);
            assert_eq!(spec.is_iterative(), e.iterative, "{}", e.name);
            assert_eq!(entries.iter().filter(|x| x.name == e.name).count(), 1);
        }
        assert_eq!(
            entries
                .iter()
                .find(|e| e.name == "penalty")
                .unwrap()
                .level(),
            SolverLevel::Body
        );
        assert!(entries.iter().any(|e| e.name == "avg"));
    }
}

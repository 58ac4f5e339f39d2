//! The whole solver registry: the entries of `lcpbench-solvers` (matrix and cone solvers) and
//! the body-level solvers of this crate ([`BODY_SOLVERS`]), then those registered at run time.
//! This is the list everything that names solvers reads (`lcpbench solvers`, help texts,
//! specifications, the report's styles).

use crate::body_solvers::{body_make, BODY_SOLVERS};
use lcpbench_solvers::registry::{self as solvers, Level, RegistryError, SolverEntry};

pub use lcpbench_solvers::registry::{Make, ParamSpec, Params};

/// Every solver: the built-in matrix, body-level and cone solvers in report order, then the
/// registered ones in registration order. A body-level entry without a
/// [`BodyMake`](crate::body_solvers::BodyMake) is left out (it cannot step).
pub fn entries() -> Vec<&'static SolverEntry> {
    solvers::MATRIX_SOLVERS
        .iter()
        .chain(BODY_SOLVERS)
        .chain(solvers::CONE_SOLVERS)
        .copied()
        .chain(solvers::registered())
        .filter(|e| e.level() != Level::Body || body_make(e).is_some())
        .collect()
}

/// The solvers of `level`, in the order of [`entries`].
pub fn entries_at(level: Level) -> Vec<&'static SolverEntry> {
    entries()
        .into_iter()
        .filter(|e| e.level() == level)
        .collect()
}

/// The solver named `name`.
pub fn find(name: &str) -> Option<&'static SolverEntry> {
    entries().into_iter().find(|e| e.name == name)
}

/// The names of the solvers of `level`, comma-separated (for messages and help texts).
pub fn names_at(level: Level) -> String {
    entries_at(level)
        .iter()
        .map(|e| e.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Add a solver of any level to the registry for the rest of the process (a process-global,
/// append-only list): checked as [`SolverEntry::check`] says, its name unique among every
/// solver, and a body-level entry's constructor a [`BodyMake`](crate::body_solvers::BodyMake).
/// Register before parsing solver names; a program that runs the `lcpbench` command line as a
/// library registers before calling it, and so has its solver in the sweep's child processes
/// too (they run the same program).
pub fn register(entry: &'static SolverEntry) -> Result<(), RegistryError> {
    if entry.level() == Level::Body && body_make(entry).is_none() {
        return Err(RegistryError {
            name: entry.name.to_owned(),
            reason: "a body-level entry's constructor must be \
                     Make::Body(&BodyMake { .. }) (lcpbench_contact::body_solvers::BodyMake)"
                .into(),
        });
    }
    solvers::register_beside(entry, BODY_SOLVERS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body_solvers::{
        BodyMake, BodySolver, BodySolverKind, BodySweep, SequentialImpulses,
    };
    use crate::builder::ContactSystem;
    use lcpbench_solvers::{ConeSolverKind, Settings, SolverKind};

    /// Sequential impulses under the name of [`SI_AGAIN`].
    #[derive(Clone)]
    struct Renamed;

    impl BodySolver for Renamed {
        fn kind(&self) -> BodySolverKind {
            BodySolverKind::for_entry(&SI_AGAIN)
        }
        fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
            SequentialImpulses.sweep(system, settings)
        }
    }

    const SI_AGAIN_ENTRY: SolverEntry = SolverEntry {
        name: "registry-test-si",
        summary: "sequential impulses under another name",
        problem_classes: "as si",
        iteration_unit: "sweeps over the contacts",
        iterative: true,
        relaxation: None,
        params: &[],
        make: Make::Body(&BodyMake {
            make: |_| Box::new(Renamed),
            takes_joints: true,
            substeps: false,
        }),
    };

    static SI_AGAIN: SolverEntry = SI_AGAIN_ENTRY;
    use std::collections::HashSet;

    #[test]
    fn names_are_unique_and_every_entry_is_valid() {
        let all = entries();
        let names: HashSet<&str> = all.iter().map(|e| e.name).collect();
        assert_eq!(names.len(), all.len());
        for e in &all {
            e.check().unwrap_or_else(|m| panic!("{m}"));
        }
        for level in Level::ALL {
            assert!(!entries_at(level).is_empty(), "{level:?}");
        }
    }

    #[test]
    fn every_default_lies_in_its_range() {
        for e in entries() {
            for p in e.params {
                assert!(p.admits(p.default), "{}: {}", e.name, p.key);
                assert!(p.min <= p.max, "{}: {}", e.name, p.key);
            }
            assert!(e.parse_params("").unwrap().is_default(), "{}", e.name);
        }
    }

    /// Every entry is found by its name, makes a solver of its level that names itself by the
    /// entry, and its kind handle round-trips.
    #[test]
    fn from_name_round_trips_for_every_entry() {
        for e in entries() {
            assert_eq!(find(e.name), Some(e));
            let d = e.defaults();
            match e.level() {
                Level::Matrix => {
                    let k = SolverKind::from_name(e.name).unwrap();
                    assert_eq!(k.entry(), e);
                    assert_eq!(k.create().name(), e.name);
                    assert_eq!(e.create(&d).unwrap().name(), e.name);
                }
                Level::Cone => {
                    let k = ConeSolverKind::from_name(e.name).unwrap();
                    assert_eq!(k.entry(), e);
                    assert_eq!(k.create().name(), e.name);
                }
                Level::Body => {
                    let k = BodySolverKind::from_name(e.name).unwrap();
                    assert_eq!(k.entry(), e);
                    assert_eq!(k.create().name(), e.name);
                    assert_eq!(k.create_with(d).params(), d);
                    assert_eq!(BodySolverKind::of(e), Some(k));
                }
            }
        }
        assert!(
            SolverKind::from_name("si").is_none() && BodySolverKind::from_name("pgs").is_none()
        );
    }

    /// A body-level solver registered at run time is listed, found, made and refused a second
    /// time; one whose name a built-in of any level has is refused.
    #[test]
    fn body_level_entries_register_once() {
        static TAKEN: SolverEntry = SolverEntry {
            name: "avg",
            ..SI_AGAIN_ENTRY
        };
        static UNTYPED: SolverEntry = SolverEntry {
            name: "registry-test-untyped",
            make: Make::Body(&0_u8),
            ..SI_AGAIN_ENTRY
        };
        register(&SI_AGAIN).unwrap();
        assert!(register(&SI_AGAIN).is_err());
        assert!(register(&TAKEN).unwrap_err().reason.contains("exists"));
        assert!(register(&UNTYPED).unwrap_err().reason.contains("BodyMake"));
        let k = BodySolverKind::from_name("registry-test-si").unwrap();
        assert!(k.takes_joints() && !k.substeps() && k.is_iterative());
        assert!(entries_at(Level::Body).contains(&&SI_AGAIN));
        assert!(names_at(Level::Body).ends_with("registry-test-si"));
        assert_eq!(k.create().name(), "registry-test-si");
    }
}

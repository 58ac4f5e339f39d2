//! The solvers of a step's islands, kept from one step to the next.
//!
//! Each island of a step is solved by its own instance of the world's solver. An instance may
//! keep a workspace between solves (Newton keeps the symbolic analysis of its sparse system,
//! reused while the sparsity pattern is unchanged), and the solver traits promise that such a
//! workspace never changes an answer: a kept instance answers bit for bit as a fresh clone
//! ([`lcpbench_solvers::Solver`], [`lcpbench_solvers::ConeSolver`]). So, as rapier's pipeline
//! keeps its island solvers, an island whose pattern (its set of dynamic bodies and its number
//! of rows) is the same as one of the last step's islands is solved by that island's instance,
//! and only a new or changed island gets a fresh clone of the world's solver.

use super::ContactSolver;
use crate::builder::Partition;
use std::collections::HashMap;

/// What an island's solver is kept for: the island's dynamic bodies (increasing) and its rows.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct IslandPattern {
    bodies: Vec<usize>,
    rows: usize,
}

impl IslandPattern {
    fn of(partition: &Partition, k: usize) -> Self {
        let island = &partition.islands[k];
        let mut bodies = island.bodies.clone();
        bodies.sort_unstable();
        Self {
            bodies,
            rows: island.rows.len(),
        }
    }
}

/// The island solvers of the last step that solved islands apart, by island pattern.
#[derive(Default)]
pub(super) struct IslandSolvers {
    /// Name of the solver the kept instances are clones of.
    of: Option<&'static str>,
    kept: HashMap<IslandPattern, ContactSolver>,
    /// Islands of the last [`IslandSolvers::take`] given a kept instance.
    reused: usize,
}

impl IslandSolvers {
    /// One instance per island of `partition`: the kept instance of the last step's island of
    /// the same pattern, or a clone of `solver`. Instances kept for another solver (another
    /// name) are dropped first.
    pub(super) fn take(
        &mut self,
        partition: &Partition,
        solver: &ContactSolver,
    ) -> Vec<ContactSolver> {
        if self.of != Some(solver.name()) {
            self.kept.clear();
            self.of = Some(solver.name());
        }
        self.reused = 0;
        (0..partition.len())
            .map(
                |k| match self.kept.remove(&IslandPattern::of(partition, k)) {
                    Some(kept) => {
                        self.reused += 1;
                        kept
                    }
                    None => solver.clone(),
                },
            )
            .collect()
    }

    /// Keep `solvers` (one per island of `partition`, as [`IslandSolvers::take`] gave them)
    /// for the next step; the instances of islands that are gone are dropped.
    pub(super) fn keep(&mut self, partition: &Partition, solvers: Vec<ContactSolver>) {
        self.kept = solvers
            .into_iter()
            .enumerate()
            .map(|(k, s)| (IslandPattern::of(partition, k), s))
            .collect();
    }

    /// Islands of the last step that were solved by an instance kept from the step before.
    pub(super) fn reused(&self) -> usize {
        self.reused
    }

    /// Instances kept for the next step.
    pub(super) fn len(&self) -> usize {
        self.kept.len()
    }

    /// Drop every kept instance.
    pub(super) fn clear(&mut self) {
        self.kept.clear();
        self.of = None;
        self.reused = 0;
    }
}

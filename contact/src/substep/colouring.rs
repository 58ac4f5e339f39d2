//! Graph colouring of a step's constraints, so that the constraints of one colour can be
//! swept in parallel: no two constraints of a colour share a dynamic body.
//!
//! Source: Box2D v3 (`src/constraint_graph.c`: `b2AddContactToGraph`, `b2AssignJointColor`;
//! `src/constraint_graph.h`: `B2_OVERFLOW_INDEX`, `B2_DYNAMIC_COLOR_COUNT`;
//! `include/box2d/constants.h`: `B2_GRAPH_COLOR_COUNT` 24), after Melyan et al.,
//! "High-Performance Physical Simulations on Next-Generation Architecture with Many Cores"
//! (Intel Technology Journal 13(4), 2009). The code here is lcpbench's own.
//!
//! # The rule
//!
//! A constraint is the set of rows that move the same bodies together: the contacts between
//! two bodies (a manifold) or a joint ([`ConstraintKey`]). Each colour keeps a bitset of the
//! dynamic bodies its constraints move. A constraint takes the first colour whose bitset
//! holds none of its dynamic bodies and sets their bits; static bodies are never listed, so
//! any number of constraints of one colour may touch the ground. As in Box2D:
//!
//! * a constraint between two dynamic bodies searches colours `0, 1, …,`
//!   [`DYNAMIC_COLOUR_COUNT`]` − 1`;
//! * a constraint with one dynamic body (the other static, or the world) searches from the
//!   last colour down to colour 1, so that it lands in a late colour and is solved after the
//!   dynamic pairs (Box2D: "static constraint colors build from the end to get higher
//!   priority than dyn-dyn constraints", which "reduces tunneling due to push through");
//! * a constraint no colour can take goes to the **overflow set** (a body touching more
//!   constraints than there are colours), which is swept serially.
//!
//! # Persistence
//!
//! Box2D keeps a constraint in its colour for as long as it exists. Here a step's constraints
//! are found anew from its rows, and a [`ConstraintGraph`] remembers the colour each key took
//! at the previous colouring: the constraints that persist are placed first, each in its
//! previous colour if that colour is still free for its bodies, then the new ones greedily in
//! the step's order (with them, a constraint that was in the overflow set: it may find a
//! colour now). The order in which a sweep visits the constraints then stays the same from
//! step to step while the contacts persist. The colouring is rebuilt each step in time
//! linear in the constraints (the bitsets are cleared and refilled).
//!
//! # Cost
//!
//! Per constraint, at most [`COLOUR_COUNT`] bitset tests of one or two bits; the bitsets hold
//! one bit per body and colour.

use std::collections::HashMap;

/// Colours, the overflow set excluded (Box2D: `B2_GRAPH_COLOR_COUNT − 1` = 23).
pub const COLOUR_COUNT: usize = 23;

/// Colours a constraint between two dynamic bodies may take: the first
/// `B2_GRAPH_COLOR_COUNT − 4` = 20 (Box2D's `B2_DYNAMIC_COLOR_COUNT`), leaving the last ones
/// to constraints with a static body.
pub const DYNAMIC_COLOUR_COUNT: usize = 20;

/// What identifies a constraint from step to step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ConstraintKey {
    /// The contacts between two bodies (their indices in the world, smaller first).
    Contact(usize, usize),
    /// A joint, by its index in the world's joint list.
    Joint(usize),
    /// A row outside any contact and joint, by its index (the builder makes none; kept so
    /// that every row has a constraint).
    Row(usize),
}

/// One constraint as the colouring sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Constraint<'a> {
    /// Its identity across steps.
    pub key: ConstraintKey,
    /// The dynamic bodies its rows move (static bodies are not listed: they never conflict).
    pub bodies: &'a [usize],
}

/// A colouring of one step's constraints (indices into the slice given to
/// [`ConstraintGraph::colour`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Colouring {
    /// Per constraint: its colour, or `None` when it is in the overflow set.
    pub colour_of: Vec<Option<usize>>,
    /// The constraints of each colour, ascending; [`COLOUR_COUNT`] lists, some maybe empty.
    pub colours: Vec<Vec<usize>>,
    /// The constraints in no colour, ascending.
    pub overflow: Vec<usize>,
}

impl Colouring {
    /// Number of colours that hold a constraint.
    pub fn used_colours(&self) -> usize {
        self.colours.iter().filter(|c| !c.is_empty()).count()
    }
}

/// The colouring's memory from step to step: the colour each constraint key took at the
/// previous colouring, and the colours' body bitsets (kept to reuse their allocation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConstraintGraph {
    /// Per colour, one bit per body: set when a constraint of the colour moves that body.
    body_sets: Vec<Vec<u64>>,
    /// The colour each key took at the previous colouring (keys in the overflow set absent).
    previous: HashMap<ConstraintKey, usize>,
}

/// True when a constraint moving `bodies` may take colour `c` (Box2D's ranges: dynamic pairs
/// in the first [`DYNAMIC_COLOUR_COUNT`], a constraint with a static side in `1..`).
fn admissible(bodies: &[usize], c: usize) -> bool {
    if bodies.len() >= 2 {
        c < DYNAMIC_COLOUR_COUNT
    } else {
        (1..COLOUR_COUNT).contains(&c)
    }
}

impl ConstraintGraph {
    /// A graph with no memory: the first colouring is greedy in the constraints' order.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forget the previous colouring.
    pub fn clear(&mut self) {
        self.previous.clear();
    }

    fn is_free(&self, c: usize, bodies: &[usize]) -> bool {
        let set = &self.body_sets[c];
        bodies.iter().all(|&b| set[b / 64] & (1 << (b % 64)) == 0)
    }

    fn take(&mut self, c: usize, bodies: &[usize]) {
        let set = &mut self.body_sets[c];
        for &b in bodies {
            set[b / 64] |= 1 << (b % 64);
        }
    }

    /// The first free colour in the constraint's search order (see the module doc).
    fn first_free(&self, bodies: &[usize]) -> Option<usize> {
        if bodies.len() >= 2 {
            (0..DYNAMIC_COLOUR_COUNT).find(|&c| self.is_free(c, bodies))
        } else {
            (1..COLOUR_COUNT).rev().find(|&c| self.is_free(c, bodies))
        }
    }

    /// Colour `constraints` (see the module doc): every constraint is in exactly one colour
    /// or in the overflow set, and no two constraints of a colour list a common body. The
    /// colours taken are remembered for the next call.
    pub fn colour(&mut self, constraints: &[Constraint<'_>]) -> Colouring {
        let words = constraints
            .iter()
            .flat_map(|c| c.bodies.iter())
            .max()
            .map_or(0, |&b| b / 64 + 1);
        self.body_sets.resize_with(COLOUR_COUNT, Vec::new);
        for set in &mut self.body_sets {
            set.clear();
            set.resize(words, 0);
        }
        let mut colour_of = vec![None; constraints.len()];
        // Constraints that persist keep their colour when it is still free for their bodies
        // (a repeated key finds its colour taken by the first and is placed greedily below).
        for (i, con) in constraints.iter().enumerate() {
            if let Some(&c) = self.previous.get(&con.key) {
                if admissible(con.bodies, c) && self.is_free(c, con.bodies) {
                    self.take(c, con.bodies);
                    colour_of[i] = Some(c);
                }
            }
        }
        // The others, greedily in the step's order.
        for (i, con) in constraints.iter().enumerate() {
            if colour_of[i].is_none() {
                if let Some(c) = self.first_free(con.bodies) {
                    self.take(c, con.bodies);
                    colour_of[i] = Some(c);
                }
            }
        }
        self.previous.clear();
        let mut colours = vec![Vec::new(); COLOUR_COUNT];
        let mut overflow = Vec::new();
        for (i, (con, c)) in constraints.iter().zip(&colour_of).enumerate() {
            match *c {
                Some(c) => {
                    self.previous.insert(con.key, c);
                    colours[c].push(i);
                }
                None => overflow.push(i),
            }
        }
        Colouring {
            colour_of,
            colours,
            overflow,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Every constraint is in exactly one colour or the overflow, as `colour_of` says, each
    /// colour is in the constraint's admissible range, and no colour has two constraints
    /// sharing a body.
    fn check(constraints: &[Constraint<'_>], col: &Colouring) -> Result<(), TestCaseError> {
        let mut seen = vec![0; constraints.len()];
        for (c, list) in col.colours.iter().enumerate() {
            let mut bodies = std::collections::HashSet::new();
            for &i in list {
                seen[i] += 1;
                prop_assert_eq!(col.colour_of[i], Some(c));
                prop_assert!(
                    admissible(constraints[i].bodies, c),
                    "colour {} for {}",
                    c,
                    i
                );
                for &b in constraints[i].bodies {
                    prop_assert!(bodies.insert(b), "colour {}: body {} twice", c, b);
                }
            }
        }
        for &i in &col.overflow {
            seen[i] += 1;
            prop_assert_eq!(col.colour_of[i], None);
        }
        prop_assert!(seen.iter().all(|&s| s == 1), "{:?}", seen);
        Ok(())
    }

    /// A random constraint graph: `n` bodies, constraints between two distinct bodies or (a
    /// quarter of them) between one body and a static side.
    fn random_graph() -> impl Strategy<Value = Vec<Vec<usize>>> {
        (2usize..200).prop_flat_map(|n| {
            prop::collection::vec((0..n, prop::option::weighted(0.75, 0..n)), 0..4 * n).prop_map(
                move |edges| {
                    edges
                        .into_iter()
                        .map(|(a, b)| match b {
                            None => vec![a],
                            Some(b) if b == a => vec![a, (a + 1) % n],
                            Some(b) => vec![a, b],
                        })
                        .collect()
                },
            )
        })
    }

    fn constraints(sets: &[Vec<usize>]) -> Vec<Constraint<'_>> {
        sets.iter()
            .map(|b| Constraint {
                key: match b[..] {
                    [a] => ConstraintKey::Contact(a, usize::MAX),
                    [a, b] => ConstraintKey::Contact(a.min(b), a.max(b)),
                    _ => ConstraintKey::Row(0),
                },
                bodies: b,
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 128,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x00c0_100e),
            ..ProptestConfig::default()
        })]

        /// Random graphs, sparse to dense: the invariants hold, and when every constraint's
        /// bodies have fewer other constraints than there are colours for it, none overflows
        /// (greedy first fit finds a colour among `d_a + d_b − 2` taken ones).
        #[test]
        fn random_graphs_keep_the_invariants(sets in random_graph()) {
            let cons = constraints(&sets);
            let col = ConstraintGraph::new().colour(&cons);
            check(&cons, &col)?;
            let mut degree = std::collections::HashMap::new();
            for s in &sets {
                for &b in s {
                    *degree.entry(b).or_insert(0usize) += 1;
                }
            }
            let worst = sets
                .iter()
                .map(|s| s.iter().map(|b| degree[b] - 1).sum::<usize>())
                .max()
                .unwrap_or(0);
            if worst < DYNAMIC_COLOUR_COUNT {
                prop_assert!(col.overflow.is_empty(), "{:?}", col.overflow);
            }
        }

        /// Recolouring after some constraints are dropped and others added keeps the
        /// invariants, and the persisting constraints placed first keep their colours: the
        /// first of them always does.
        #[test]
        fn recolouring_a_changed_graph_keeps_the_invariants(
            sets in random_graph(),
            dropped in prop::collection::vec(any::<bool>(), 0..800),
            extra in random_graph(),
        ) {
            let mut graph = ConstraintGraph::new();
            let cons = constraints(&sets);
            let first = graph.colour(&cons);
            check(&cons, &first)?;
            let before = graph.previous.clone();
            let mut next: Vec<Vec<usize>> = sets
                .iter()
                .enumerate()
                .filter(|(i, _)| !dropped.get(*i).copied().unwrap_or(false))
                .map(|(_, s)| s.clone())
                .collect();
            next.extend(extra);
            let cons = constraints(&next);
            let second = graph.colour(&cons);
            check(&cons, &second)?;
            if let Some((i, &c)) = cons
                .iter()
                .enumerate()
                .find_map(|(i, k)| before.get(&k.key).map(|c| (i, c)))
            {
                prop_assert_eq!(second.colour_of[i], Some(c));
            }
        }
    }

    /// A body touching more constraints than there are colours: the first
    /// [`DYNAMIC_COLOUR_COUNT`] dynamic pairs take one colour each, the rest overflow; the
    /// static contacts of other bodies share one colour, the last.
    #[test]
    fn a_hub_overflows_and_static_contacts_share_colours() {
        let hub: Vec<Vec<usize>> = (1..=30).map(|b| vec![0, b]).collect();
        let cons = constraints(&hub);
        let col = ConstraintGraph::new().colour(&cons);
        check(&cons, &col).unwrap();
        assert_eq!(col.overflow, (DYNAMIC_COLOUR_COUNT..30).collect::<Vec<_>>());
        for (c, list) in col.colours.iter().enumerate().take(DYNAMIC_COLOUR_COUNT) {
            assert_eq!(list, &vec![c]);
        }
        let ground: Vec<Vec<usize>> = (0..50).map(|b| vec![b]).collect();
        let cons = constraints(&ground);
        let col = ConstraintGraph::new().colour(&cons);
        check(&cons, &col).unwrap();
        assert_eq!(col.colours[COLOUR_COUNT - 1].len(), 50);
        assert_eq!(col.used_colours(), 1);
    }

    /// A constraint that persists keeps its colour where a fresh colouring would give it
    /// another: after `a` disappears, `c` stays in colour 1 instead of moving to 0.
    #[test]
    fn persisting_constraints_keep_their_colour() {
        let mut graph = ConstraintGraph::new();
        let a = Constraint {
            key: ConstraintKey::Contact(0, 1),
            bodies: &[0, 1],
        };
        let c = Constraint {
            key: ConstraintKey::Joint(7),
            bodies: &[1, 2],
        };
        assert_eq!(graph.colour(&[a, c]).colour_of, vec![Some(0), Some(1)]);
        assert_eq!(graph.colour(&[c]).colour_of, vec![Some(1)]);
        assert_eq!(ConstraintGraph::new().colour(&[c]).colour_of, vec![Some(0)]);
        // A new constraint listed first takes colour 0, and `c` stays in 1 (a fresh
        // colouring would put both in 0: they share no body).
        let d = Constraint {
            key: ConstraintKey::Contact(4, 5),
            bodies: &[4, 5],
        };
        assert_eq!(graph.colour(&[d, c]).colour_of, vec![Some(0), Some(1)]);
        assert_eq!(
            ConstraintGraph::new().colour(&[d, c]).colour_of,
            vec![Some(0), Some(0)]
        );
        graph.clear();
        assert_eq!(graph.colour(&[c]).colour_of, vec![Some(0)]);
    }
}

//! Coloured sweeps: a substepping solver's Gauss–Seidel sweep taken colour by colour, the
//! constraints of a colour in parallel on rayon's threads (`colour=1` of `pgs-ngs`'s velocity
//! and position sweeps; `soft-step` and `tgs` sweep [`super::constraint_rows`] instead, which
//! writes the bodies in place without these copies).
//!
//! The rows of a step are grouped into constraints (the rows of the contacts between two
//! bodies, or of a joint) and the constraints coloured ([`super::colouring`]): no two
//! constraints of a colour move a common dynamic body. Each constraint becomes a [`Block`]:
//! its rows copied once per step with their bodies renumbered into the block's own copies of
//! those bodies, its accumulated impulses, its per-row coefficients. A sweep then runs, as
//! Box2D v3's `b2SolverStage_Solve` does (`src/solver.c`):
//!
//! 1. the **overflow set**, serially: each block copies its bodies in, runs its rows and
//!    copies its bodies back before the next block;
//! 2. each **colour** in order: every block of the colour copies its bodies in from the
//!    bodies as they are at the colour's start and runs its rows, in parallel (no block
//!    writes to the shared bodies then); after all of them, the blocks copy their bodies back
//!    one after the other, in the blocks' order.
//!
//! Within a colour the blocks move disjoint sets of bodies, so each block sees exactly what
//! it would see in any serial order of the colour: the sweep is one Gauss–Seidel sweep in
//! the order "overflow, colour 0, colour 1, …", and its result does not depend on the number
//! of threads nor on how rayon splits the work (each block's arithmetic is serial, and every
//! write to shared data happens in the fixed order of step 2). Nothing is summed across
//! threads: a pass's per-block results (the position pass's smallest separation, its count
//! of rows) are combined after the colour, in the blocks' order.
//!
//! Within a block the rows keep the relative order of the serial sweep (a contact's normal
//! row and its friction rows, a manifold's rows for `normals_first`, 2×2 pairs for
//! `block_pairs`), so a coloured sweep differs from the serial one only in the order of the
//! constraints. That order changes the iterate: a coloured run is a different iteration from
//! the serial one, named by its parameters (`soft-step@colour=1`) and in the step report's
//! `residual_of`.
//!
//! The data is safe Rust: the blocks own their rows, impulses and body copies, `par_iter_mut`
//! hands each thread its own blocks, and the shared bodies are only read during the parallel
//! part. The price is one copy of each block's (one or two) bodies in and out per colour and
//! sweep, and the impulses and coefficients copied into the blocks and back once per pass
//! ([`ColouredSweep::load`], [`ColouredSweep::store`]).

use super::colouring::{Constraint, ConstraintGraph, ConstraintKey, COLOUR_COUNT};
use super::state::{RowRole, SolverBody, SolverRow, SolverState};
use crate::builder::ContactSystem;
use rayon::prelude::*;
use std::ops::Range;

/// Blocks per rayon task at the least: a block is a handful of rows (a box-on-box manifold
/// has twelve), a few hundred floating-point operations, and a task should carry enough of
/// them to outweigh rayon's cost of handing it to a thread.
const MIN_BLOCKS_PER_TASK: usize = 8;

/// One constraint's rows, laid out to run on the block's own copies of its bodies.
#[derive(Debug, Clone)]
pub(crate) struct Block<C> {
    /// Its identity across steps (for the colouring's memory).
    key: ConstraintKey,
    /// The index in the world of each body its rows move.
    bodies: Vec<usize>,
    /// Copies of those bodies while a sweep runs the block.
    pub(crate) local: Vec<SolverBody>,
    /// Its rows, each block's body renumbered into `local` and a friction row's normal into
    /// `rows`.
    pub(crate) rows: Vec<SolverRow>,
    /// The system's index of each row.
    global: Vec<usize>,
    /// The rows the sweep updates (indices into `rows`), in the serial sweep's order. `rows`
    /// may hold more: a normal row that bounds a swept friction row but is not swept itself.
    pub(crate) order: Vec<usize>,
    /// `pairs[p]`: `order[p]` and `order[p + 1]` are solved together (soft-step's
    /// `block_pairs`).
    pub(crate) pairs: Vec<bool>,
    /// The rows' accumulated impulses.
    pub(crate) lambda: Vec<f64>,
    /// The rows' coefficients of the pass (bias and softness).
    pub(crate) coefficients: Vec<C>,
    /// Normal rows left with a positive impulse by a sweep of the pass.
    pub(crate) hit: Vec<bool>,
}

impl<C: Copy + Default> Block<C> {
    fn new(key: ConstraintKey) -> Self {
        Self {
            key,
            bodies: Vec::new(),
            local: Vec::new(),
            rows: Vec::new(),
            global: Vec::new(),
            order: Vec::new(),
            pairs: Vec::new(),
            lambda: Vec::new(),
            coefficients: Vec::new(),
            hit: Vec::new(),
        }
    }

    /// Add the system's row `i` (renumbered) and return its index in `rows`.
    fn push_row(&mut self, i: usize, state: &SolverState) -> usize {
        let mut row = state.rows[i];
        for b in row.blocks[..row.sides as usize].iter_mut() {
            let local = match self.bodies.iter().position(|&g| g == b.body) {
                Some(k) => k,
                None => {
                    self.bodies.push(b.body);
                    self.local.push(state.bodies[b.body]);
                    self.bodies.len() - 1
                }
            };
            b.body = local;
        }
        self.rows.push(row);
        self.global.push(i);
        self.rows.len() - 1
    }

    /// Renumber the friction rows' normals into `rows`, adding a normal row that is not swept.
    fn link_normals(&mut self, state: &SolverState) {
        let friction: Vec<(usize, usize)> = self
            .rows
            .iter()
            .enumerate()
            .filter_map(|(r, row)| match row.role {
                RowRole::Friction { normal } => Some((r, normal)),
                _ => None,
            })
            .collect();
        for (r, normal) in friction {
            let local = match self.global.iter().position(|&g| g == normal) {
                Some(k) => k,
                None => self.push_row(normal, state),
            };
            self.rows[r].role = RowRole::Friction { normal: local };
        }
        self.lambda = vec![0.0; self.rows.len()];
        self.coefficients = vec![C::default(); self.rows.len()];
        self.hit = vec![false; self.rows.len()];
    }

    /// Copy the block's bodies in from the world's.
    #[inline]
    fn gather(&mut self, bodies: &[SolverBody]) {
        for (local, &g) in self.local.iter_mut().zip(&self.bodies) {
            *local = bodies[g];
        }
    }

    /// Copy the block's bodies back.
    #[inline]
    fn scatter(&self, bodies: &mut [SolverBody]) {
        for (local, &g) in self.local.iter().zip(&self.bodies) {
            bodies[g] = *local;
        }
    }
}

/// A step's rows laid out for coloured sweeps: the blocks of the overflow set, then those of
/// each used colour, contiguous.
#[derive(Debug, Clone)]
pub(crate) struct ColouredSweep<C> {
    blocks: Vec<Block<C>>,
    /// `blocks[..overflow]` is the overflow set.
    overflow: usize,
    /// The used colours' blocks, in colour order.
    colours: Vec<Range<usize>>,
}

/// The constraint each row of `system` belongs to: `(key, group)` per row, the groups
/// numbered densely. A contact's rows go with the contacts next to it in the system between
/// the same two bodies (the builder lists a manifold's contacts together); a joint's rows
/// form one group.
pub(crate) fn groups(system: &ContactSystem, n: usize) -> Vec<Option<(ConstraintKey, usize)>> {
    let mut of_row = vec![None; n];
    let mut next = 0;
    let mut run: Option<ConstraintKey> = None;
    for (c, (contact, _)) in system.contacts.iter().zip(&system.info).enumerate() {
        let (a, b) = (contact.body_a, contact.body_b);
        let key = ConstraintKey::Contact(a.min(b), a.max(b));
        if run != Some(key) {
            run = Some(key);
            next += 1;
        }
        for r in system.contact_rows(c) {
            if r < n {
                of_row[r] = Some((key, next - 1));
            }
        }
    }
    for j in &system.joints {
        for r in j.rows.clone() {
            if r < n {
                of_row[r] = Some((ConstraintKey::Joint(j.joint), next));
            }
        }
        next += 1;
    }
    for (r, g) in of_row.iter_mut().enumerate() {
        if g.is_none() {
            *g = Some((ConstraintKey::Row(r), next));
            next += 1;
        }
    }
    of_row
}

impl<C> ColouredSweep<C> {
    /// Number of colours with a constraint.
    pub(crate) fn colour_count(&self) -> usize {
        self.colours.len()
    }

    /// Number of constraints in the overflow set.
    pub(crate) fn overflow_count(&self) -> usize {
        self.overflow
    }

    /// Number of blocks (constraints).
    pub(crate) fn constraint_count(&self) -> usize {
        self.blocks.len()
    }
}

impl<C: Copy + Default + Send + Sync> ColouredSweep<C> {
    /// The blocks of the rows in `order` (the serial sweep's order; `pairs` as
    /// [`Block::pairs`], empty for none), coloured with `graph`'s memory of the previous
    /// step.
    pub(crate) fn new(
        system: &ContactSystem,
        state: &SolverState,
        order: &[usize],
        pairs: &[bool],
        graph: &mut ConstraintGraph,
    ) -> Self {
        let of_row = groups(system, state.rows.len());
        // Blocks in the order of their first row in the sweep.
        let mut block_of_group: Vec<Option<usize>> = vec![None; state.rows.len() + 1];
        let mut made: Vec<Block<C>> = Vec::new();
        for (p, &i) in order.iter().enumerate() {
            let Some((key, g)) = of_row[i] else { continue };
            if g >= block_of_group.len() {
                block_of_group.resize(g + 1, None);
            }
            let b = *block_of_group[g].get_or_insert_with(|| {
                made.push(Block::new(key));
                made.len() - 1
            });
            let block = &mut made[b];
            let local = block.push_row(i, state);
            block.order.push(local);
            // A pair stays a pair only with its partner next in the same block.
            let paired = pairs.get(p).copied().unwrap_or(false)
                && order
                    .get(p + 1)
                    .is_some_and(|&j| of_row[j].map(|x| x.1) == Some(g));
            block.pairs.push(paired);
        }
        for block in &mut made {
            block.link_normals(state);
        }
        let constraints: Vec<Constraint<'_>> = made
            .iter()
            .map(|b| Constraint {
                key: b.key,
                bodies: &b.bodies,
            })
            .collect();
        let colouring = graph.colour(&constraints);
        drop(constraints);
        let mut slots: Vec<Option<Block<C>>> = made.into_iter().map(Some).collect();
        let mut blocks = Vec::with_capacity(slots.len());
        for &i in &colouring.overflow {
            blocks.extend(slots[i].take());
        }
        let overflow = blocks.len();
        let mut colours = Vec::with_capacity(COLOUR_COUNT);
        for list in colouring.colours.iter().filter(|l| !l.is_empty()) {
            let start = blocks.len();
            for &i in list {
                blocks.extend(slots[i].take());
            }
            colours.push(start..blocks.len());
        }
        Self {
            blocks,
            overflow,
            colours,
        }
    }

    /// Copy the accumulated impulses and the pass's coefficients (one per system row) into
    /// the blocks, and clear their `hit` marks.
    pub(crate) fn load(&mut self, lambda: &[f64], coefficients: &[C]) {
        for b in &mut self.blocks {
            for (k, &g) in b.global.iter().enumerate() {
                b.lambda[k] = lambda[g];
                b.coefficients[k] = coefficients[g];
                b.hit[k] = false;
            }
        }
    }

    /// Copy the blocks' accumulated impulses back (one per system row), and add their `hit`
    /// marks to `hit` (when given).
    pub(crate) fn store(&self, lambda: &mut [f64], mut hit: Option<&mut [bool]>) {
        for b in &self.blocks {
            for (k, &g) in b.global.iter().enumerate() {
                lambda[g] = b.lambda[k];
                if let Some(h) = hit.as_deref_mut() {
                    h[g] |= b.hit[k];
                }
            }
        }
    }

    /// One sweep (see the module doc): `kernel` runs each block on its own body copies and
    /// returns what `fold` then receives, block by block in the blocks' order (overflow
    /// first, then the colours).
    pub(crate) fn sweep<R, K, F>(&mut self, bodies: &mut [SolverBody], kernel: K, mut fold: F)
    where
        R: Send,
        K: Fn(&mut Block<C>) -> R + Sync,
        F: FnMut(R),
    {
        for block in &mut self.blocks[..self.overflow] {
            block.gather(bodies);
            let r = kernel(block);
            block.scatter(bodies);
            fold(r);
        }
        for range in &self.colours {
            let shared: &[SolverBody] = bodies;
            // Each block reads the shared bodies (as they are at the colour's start) and
            // writes only its own data; the results come back in the blocks' order.
            let results: Vec<R> = self.blocks[range.clone()]
                .par_iter_mut()
                .with_min_len(MIN_BLOCKS_PER_TASK)
                .map(|block| {
                    block.gather(shared);
                    kernel(block)
                })
                .collect();
            for (block, r) in self.blocks[range.clone()].iter().zip(results) {
                block.scatter(bodies);
                fold(r);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builder;
    use crate::{BodySolverKind, ContactSolver, Scene};
    use std::collections::HashSet;
    use std::path::PathBuf;

    /// The system and solver state of `scene` after `steps` steps of `soft-step`.
    fn system_of(scene: &str, steps: usize) -> (ContactSystem, SolverState) {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../bench_scenes")
            .join(format!("{scene}.toml"));
        let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
        let mut w = scene.world();
        w.set_solver(ContactSolver::Body(BodySolverKind::SoftStep.create()));
        w.run(steps);
        let contacts = w
            .pipeline
            .detect(&w.bodies, w.settings.prediction_distance)
            .unwrap();
        let (h, g) = (w.settings.dt, w.settings.gravity);
        let free = builder::free_velocities(&w.bodies, &g, h);
        let system = builder::build_with_joints(
            &w.bodies,
            &w.materials,
            &contacts,
            &w.joints,
            free,
            &w.settings.builder,
            h,
        );
        let state = SolverState::new(&system, &g);
        (system, state)
    }

    /// Every swept row (rows with a dynamic body, in system order) in `order`.
    fn swept(state: &SolverState) -> Vec<usize> {
        (0..state.rows.len())
            .filter(|&i| state.rows[i].mass > 0.0 && state.rows[i].role != RowRole::Other)
            .collect()
    }

    /// The blocks hold every swept row once, in the sweep's relative order, as copies of the
    /// system's rows with their bodies and friction normals renumbered; the colours' blocks
    /// move disjoint bodies; a contact's rows and a joint's rows stay together.
    fn check_layout(system: &ContactSystem, state: &SolverState, sweep: &ColouredSweep<f64>) {
        let order = swept(state);
        let mut seen = vec![false; state.rows.len()];
        for b in &sweep.blocks {
            let globals: Vec<usize> = b.order.iter().map(|&k| b.global[k]).collect();
            assert!(globals.windows(2).all(|w| w[0] < w[1]), "{globals:?}");
            for &g in &globals {
                assert!(!seen[g], "row {g} in two blocks");
                seen[g] = true;
            }
            for (k, row) in b.rows.iter().enumerate() {
                let orig = &state.rows[b.global[k]];
                assert_eq!(row.sides, orig.sides);
                let sides = row.sides as usize;
                for (mine, theirs) in row.blocks[..sides].iter().zip(&orig.blocks[..sides]) {
                    assert_eq!(b.bodies[mine.body], theirs.body);
                    assert_eq!(mine.linear, theirs.linear);
                    assert_eq!(mine.angular, theirs.angular);
                }
                match (row.role, orig.role) {
                    (RowRole::Friction { normal: l }, RowRole::Friction { normal: g }) => {
                        assert_eq!(b.global[l], g)
                    }
                    (a, o) => assert_eq!(a, o),
                }
            }
            // One constraint: the rows of one joint or of contacts between one pair.
            let keys: HashSet<ConstraintKey> = globals
                .iter()
                .map(|&g| match state.rows[g].role {
                    RowRole::Joint => {
                        let j = system.joints.iter().find(|j| j.rows.contains(&g)).unwrap();
                        ConstraintKey::Joint(j.joint)
                    }
                    _ => {
                        let c = (0..system.info.len())
                            .find(|&c| system.contact_rows(c).contains(&g))
                            .unwrap();
                        let ct = &system.contacts[c];
                        ConstraintKey::Contact(ct.body_a.min(ct.body_b), ct.body_a.max(ct.body_b))
                    }
                })
                .collect();
            assert_eq!(keys, HashSet::from([b.key]));
        }
        assert_eq!(
            order,
            (0..state.rows.len())
                .filter(|&i| seen[i])
                .collect::<Vec<_>>()
        );
        let mut end = sweep.overflow;
        for range in &sweep.colours {
            assert_eq!(range.start, end);
            assert!(!range.is_empty());
            end = range.end;
            let mut bodies = HashSet::new();
            for b in &sweep.blocks[range.clone()] {
                for &body in &b.bodies {
                    assert!(!state.bodies[body].is_static());
                    assert!(bodies.insert(body), "body {body} twice in a colour");
                }
            }
        }
        assert_eq!(end, sweep.blocks.len());
    }

    #[test]
    fn blocks_cover_the_rows_and_colours_move_disjoint_bodies() {
        for (scene, steps) in [("pyramid_10", 0), ("joints/ragdoll_pile", 40)] {
            let (system, state) = system_of(scene, steps);
            let order = swept(&state);
            let mut graph = ConstraintGraph::new();
            let sweep = ColouredSweep::<f64>::new(&system, &state, &order, &[], &mut graph);
            check_layout(&system, &state, &sweep);
            println!(
                "{scene}: {} rows, {} constraints in {} colours, {} in overflow",
                order.len(),
                sweep.constraint_count(),
                sweep.colour_count(),
                sweep.overflow_count()
            );
            assert!(sweep.colour_count() >= 2, "{scene}");
            assert_eq!(sweep.overflow_count(), 0, "{scene}");
            // The same system again: every constraint keeps its colour and place.
            let again = ColouredSweep::<f64>::new(&system, &state, &order, &[], &mut graph);
            let keys = |s: &ColouredSweep<f64>| s.blocks.iter().map(|b| b.key).collect::<Vec<_>>();
            assert_eq!(keys(&again), keys(&sweep));
            assert_eq!(again.colours, sweep.colours);
        }
    }

    /// A sweep that applies a unit impulse on every row of every block moves the bodies as
    /// applying those impulses directly does (to rounding: the sums run in another order),
    /// and gives the same bits on one thread and on three.
    #[test]
    fn a_sweep_writes_back_to_the_right_bodies_on_any_thread_count() {
        let (system, state) = system_of("joints/ragdoll_pile", 40);
        let order = swept(&state);
        let run = |threads: usize| {
            let mut s = state.clone();
            let mut graph = ConstraintGraph::new();
            let mut sweep = ColouredSweep::<f64>::new(&system, &s, &order, &[], &mut graph);
            let mut visited = 0;
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    sweep.sweep(
                        &mut s.bodies,
                        |b| {
                            for &k in &b.order {
                                b.rows[k].apply(1.0, &mut b.local);
                            }
                            b.order.len()
                        },
                        |n| visited += n,
                    )
                });
            assert_eq!(visited, order.len());
            s
        };
        let one = run(1);
        let three = run(3);
        assert_eq!(one.bodies, three.bodies);
        let mut expected = state.clone();
        let mut unit = vec![0.0; state.rows.len()];
        for &i in &order {
            unit[i] = 1.0;
        }
        expected.apply_all(&unit);
        for (got, want) in one.bodies.iter().zip(&expected.bodies) {
            let scale = 1.0 + want.v.norm() + want.w.norm();
            assert!((got.v - want.v).norm() <= 1e-12 * scale, "{got:?} {want:?}");
            assert!((got.w - want.w).norm() <= 1e-12 * scale, "{got:?} {want:?}");
        }
    }

    /// Impulses loaded into the blocks and stored back are unchanged; `hit` marks add up.
    #[test]
    fn impulses_round_trip_through_the_blocks() {
        let (system, state) = system_of("pyramid_10", 0);
        let order = swept(&state);
        let mut sweep =
            ColouredSweep::<f64>::new(&system, &state, &order, &[], &mut ConstraintGraph::new());
        let lambda: Vec<f64> = (0..state.rows.len())
            .map(|i| i as f64 * 0.5 - 3.0)
            .collect();
        let coefficients: Vec<f64> = lambda.iter().map(|l| -l).collect();
        sweep.load(&lambda, &coefficients);
        for b in &mut sweep.blocks {
            for (k, &g) in b.global.iter().enumerate() {
                assert_eq!(b.lambda[k], lambda[g]);
                assert_eq!(b.coefficients[k], coefficients[g]);
            }
            b.hit[0] = true;
        }
        let mut back = vec![f64::NAN; state.rows.len()];
        let mut hit = vec![false; state.rows.len()];
        sweep.store(&mut back, Some(&mut hit));
        for &i in &order {
            assert_eq!(back[i], lambda[i]);
        }
        assert_eq!(hit.iter().filter(|&&h| h).count(), sweep.constraint_count());
    }
}

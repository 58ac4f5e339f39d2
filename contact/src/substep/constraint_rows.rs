//! The step's constraint rows laid out for the velocity sweeps of `soft-step` and `tgs`: one
//! compact record per swept row, in the order the sweep visits them, with the accumulated
//! impulses, the pass's coefficients and the `hit` marks in arrays of the same order.
//!
//! [`SolverRow`] carries everything any substepping solver needs (two Jacobian blocks with
//! `usize` body indices, `M⁻¹ Jᵀ` of both sides, role, restitution, approach speed: about 280
//! bytes). The sweep of `soft-step` reads, per row, only the Jacobian, `I⁻¹ J_ω` of each side,
//! the effective mass, the position error at the step's start and the friction bound: a
//! [`ConstraintRow`] holds those (both body indices as `u32` once, the linear response
//! recomputed as `J_v · m⁻¹` with the same rounding as [`SolverState::new`]), about 40% less
//! memory swept several times per substep. This follows the solver layouts of shipping engines
//! (Box2D v3 `contact_solver.c`, `b2ContactConstraint` and `b2ContactConstraintPoint`;
//! Rapier's `dynamics/solver/contact_constraint/`): what the inner loop touches is contiguous,
//! built once per step into buffers the solver keeps between steps.
//!
//! The pass's coefficients (soft bias, mass and impulse scales) are computed in the sweep from
//! the row's position error, as Box2D's `b2SolveContact` does, instead of in a separate pass
//! over the rows: a velocity sweep does not move the bodies' positions, so the coefficients are
//! those a separate pass would compute, bit for bit. They are written out for the last solve's
//! `b`.
//!
//! # Coloured sweeps
//!
//! For `colour=1` the rows are laid out constraint by constraint (a joint's rows, the contacts
//! between two bodies; [`super::colouring`]), the overflow set first, then each colour's
//! constraints: a colour is a range of constraints, a constraint a range of rows. A sweep runs
//! the overflow constraints serially, then each colour's constraints in parallel on rayon's
//! threads, each writing the velocities of its bodies in place (Box2D v3's `b2SolverStage`
//! over its graph colours). No two constraints of a colour move a common dynamic body, and no
//! constraint writes a static body, so the parallel writes are disjoint ([`SharedSlice`]; the
//! invariant is checked when the layout is built in debug builds). Each constraint's
//! arithmetic is serial and nothing is summed across constraints, so the result does not
//! depend on the number of threads nor on rayon's split of the work.

use super::colouring::{Constraint, ConstraintGraph, ConstraintKey, COLOUR_COUNT};
use super::state::{RowRole, SolverBody, SolverState};
use crate::builder::ContactSystem;
use nalgebra::Vector3;
use rayon::prelude::*;
use std::marker::PhantomData;
use std::ops::Range;

/// Constraints per rayon task at the least: a box-on-box manifold is twelve rows, a few
/// hundred floating-point operations, and a task should outweigh rayon's cost of handing it
/// to a thread.
const MIN_CONSTRAINTS_PER_TASK: usize = 8;

/// `normal` of a row with no normal row in the layout (a friction row whose normal row is not
/// swept: its impulse stays 0, so the friction bound is 0).
const NO_NORMAL: u32 = u32::MAX;

/// What a swept row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A contact's normal row, `λ ≥ 0`.
    Normal,
    /// A friction row, `|λ| ≤ μ λ_n`.
    Friction,
    /// A joint's equality row.
    Joint,
}

/// One side (body) of a row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Side {
    /// `J_v`, the linear part of the Jacobian block.
    pub(crate) linear: Vector3<f64>,
    /// `J_ω`, the angular part.
    pub(crate) angular: Vector3<f64>,
    /// `I⁻¹ J_ω` (world inverse inertia at the step's start).
    pub(crate) angular_response: Vector3<f64>,
    /// The body's `1/m` (0: static, never written).
    pub(crate) inv_mass: f64,
}

impl Side {
    const NONE: Side = Side {
        linear: Vector3::new(0.0, 0.0, 0.0),
        angular: Vector3::new(0.0, 0.0, 0.0),
        angular_response: Vector3::new(0.0, 0.0, 0.0),
        inv_mass: 0.0,
    };
}

/// One swept row, compact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ConstraintRow {
    /// Its (at most two) sides; `sides` of them are used.
    pub(crate) side: [Side; 2],
    /// `J M⁻¹ Jᵀ`.
    pub(crate) k: f64,
    /// `1 / k`.
    pub(crate) mass: f64,
    /// Position error at the step's start.
    pub(crate) c0: f64,
    /// Friction coefficient (friction rows).
    pub(crate) mu: f64,
    /// The sides' body indices.
    pub(crate) body: [u32; 2],
    /// A friction row's normal row: its position in the layout, or [`NO_NORMAL`].
    pub(crate) normal: u32,
    /// What it is.
    pub(crate) kind: Kind,
    /// Sides used (1 or 2).
    pub(crate) sides: u8,
    /// True when the row's only dynamic body is on one side (the other static or the world).
    pub(crate) touches_static: bool,
}

impl ConstraintRow {
    /// `J v` on the current velocities.
    #[inline]
    pub(crate) fn rate(&self, bodies: &SharedSlice<'_, SolverBody>) -> f64 {
        let mut r = 0.0;
        for (s, &b) in self.side[..self.sides as usize].iter().zip(&self.body) {
            // SAFETY: reads of a body this row moves (exclusive to its constraint within a
            // colour) or of a static body (never written during a sweep).
            let body = unsafe { bodies.get(b as usize) };
            r += s.linear.dot(&body.v) + s.angular.dot(&body.w);
        }
        r
    }

    /// `v += M⁻¹ Jᵀ λ` on the dynamic sides.
    #[inline]
    pub(crate) fn apply(&self, impulse: f64, bodies: &SharedSlice<'_, SolverBody>) {
        for (s, &b) in self.side[..self.sides as usize].iter().zip(&self.body) {
            if s.inv_mass == 0.0 {
                continue;
            }
            // SAFETY: a dynamic body of this row: within a colour no other constraint moves
            // it, and in a serial sweep nothing else runs.
            let body = unsafe { bodies.get_mut(b as usize) };
            body.v += (s.linear * s.inv_mass) * impulse;
            body.w += s.angular_response * impulse;
        }
    }

    /// The position error now, `C₀ + J Δx`.
    #[inline(always)]
    pub(crate) fn position_error(&self, bodies: &SharedSlice<'_, SolverBody>) -> f64 {
        let mut c = self.c0;
        for (s, &b) in self.side[..self.sides as usize].iter().zip(&self.body) {
            // SAFETY: as in `rate`.
            let body = unsafe { bodies.get(b as usize) };
            c += s.linear.dot(&body.dp) + s.angular.dot(&body.dtheta);
        }
        c
    }
}

/// `J_a M⁻¹ J_bᵀ`: the coupling of two rows (the off-diagonal entry of `A`).
pub(crate) fn coupling(a: &ConstraintRow, b: &ConstraintRow) -> f64 {
    let mut k = 0.0;
    for (sa, ba) in a.side[..a.sides as usize].iter().zip(&a.body) {
        for (sb, bb) in b.side[..b.sides as usize].iter().zip(&b.body) {
            if ba == bb {
                k += sa.linear.dot(&(sb.linear * sb.inv_mass))
                    + sa.angular.dot(&sb.angular_response);
            }
        }
    }
    k
}

/// A slice shared by the constraints of one colour, each writing only its own elements (its
/// rows' impulses and coefficients, its dynamic bodies): Box2D v3's scheme of solver threads
/// writing the shared body states, which Rust's borrows cannot express for the scattered body
/// indices of a colour.
///
/// Invariant (the caller's): while the slice is shared, no element is written by one task and
/// read or written by another. The layout guarantees it for a colour ([`ConstraintRows::build`]
/// checks it in debug builds). Element indices are checked in debug builds only: the body
/// indices of the rows are checked against the bodies when the layout is built and when a
/// pass starts; ranges are always checked.
pub(crate) struct SharedSlice<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: PhantomData<&'a mut [T]>,
}

// SAFETY: a `SharedSlice` is an exclusive borrow handed to tasks that touch disjoint elements
// (the invariant above); `T: Send` lets those elements move between threads.
unsafe impl<T: Send> Send for SharedSlice<'_, T> {}
// SAFETY: as above.
unsafe impl<T: Send> Sync for SharedSlice<'_, T> {}

impl<'a, T> SharedSlice<'a, T> {
    /// Share `slice` for the duration of the borrow.
    pub(crate) fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _borrow: PhantomData,
        }
    }

    /// Element `i`, read.
    ///
    /// # Safety
    /// `i < len`; no other task writes element `i` while the reference lives.
    #[inline]
    pub(crate) unsafe fn get(&self, i: usize) -> &T {
        debug_assert!(i < self.len);
        &*self.ptr.add(i)
    }

    /// Element `i`, written.
    ///
    /// # Safety
    /// `i < len`; no other task reads or writes element `i` while the reference lives, and this
    /// task holds no other reference to it.
    #[inline]
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn get_mut(&self, i: usize) -> &mut T {
        debug_assert!(i < self.len);
        &mut *self.ptr.add(i)
    }

    /// Elements `range`, written.
    ///
    /// # Safety
    /// As [`SharedSlice::get_mut`], for every element of `range`.
    #[inline]
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn range_mut(&self, range: Range<usize>) -> &mut [T] {
        assert!(range.start <= range.end && range.end <= self.len);
        std::slice::from_raw_parts_mut(self.ptr.add(range.start), range.end - range.start)
    }
}

/// A row's coefficients for one pass: `Δλ = −m · mass_scale · (J v + bias) − impulse_scale · λ`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct RowCoefficients {
    /// Velocity bias.
    pub(crate) bias: f64,
    /// Scale of the effective mass.
    pub(crate) mass_scale: f64,
    /// Share of the accumulated impulse taken back.
    pub(crate) impulse_scale: f64,
}

/// The rigid row without bias.
pub(crate) const RIGID_ROW: RowCoefficients = RowCoefficients {
    bias: 0.0,
    mass_scale: 1.0,
    impulse_scale: 0.0,
};

/// The rows of one step in sweep order, with their impulses, coefficients and marks, and for
/// coloured sweeps the constraints and colours. Kept by the solver between steps (its buffers
/// are reused).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct ConstraintRows {
    /// The swept rows in sweep order.
    pub(crate) rows: Vec<ConstraintRow>,
    /// The system's index of each.
    pub(crate) global: Vec<u32>,
    /// `pairs[p]`: rows `p` and `p + 1` are solved together (`block_pairs`).
    pub(crate) pairs: Vec<bool>,
    /// Accumulated impulses.
    pub(crate) lambda: Vec<f64>,
    /// The coefficients of the last pass.
    pub(crate) coefficients: Vec<RowCoefficients>,
    /// Normal rows left with a positive impulse by some sweep.
    pub(crate) hit: Vec<bool>,
    /// Coloured layout: each constraint's rows.
    pub(crate) constraints: Vec<Range<usize>>,
    /// Coloured layout: `constraints[..overflow]` is the overflow set.
    pub(crate) overflow: usize,
    /// Coloured layout: the used colours' constraints, in colour order.
    pub(crate) colours: Vec<Range<usize>>,
    /// Coloured layout: whether the sweep goes colour by colour.
    pub(crate) coloured: bool,
    /// Number of bodies the rows index (every body index is below it).
    body_count: usize,
    /// Scratch: the layout position of each system row (`u32::MAX`: not swept).
    position: Vec<u32>,
}

/// How a sweep turns a row's position error into its coefficients.
pub(crate) trait SweepRule: Sync {
    /// The coefficients of `row` for the pass; `position_error` gives `C₀ + J Δx` now (called
    /// only when the rule needs it).
    fn coefficients(
        &self,
        row: &ConstraintRow,
        position_error: impl FnOnce() -> f64,
    ) -> RowCoefficients;
}

/// Every row rigid, no bias (what the warm start's pass type stands for).
struct Rigid;

impl SweepRule for Rigid {
    fn coefficients(&self, _: &ConstraintRow, _: impl FnOnce() -> f64) -> RowCoefficients {
        RIGID_ROW
    }
}

impl ConstraintRows {
    /// Lay out the rows of `state` in `order` (the serial sweep's order, `pairs` as
    /// [`ConstraintRows::pairs`]), or with `graph` constraint by constraint and colour by
    /// colour ([`super::colouring`], the rows of a constraint in their relative order in
    /// `order`). The impulses are taken from `lambda` (one per system row).
    pub(crate) fn build(
        &mut self,
        system: &ContactSystem,
        state: &SolverState,
        (order, pairs): (&[usize], &[bool]),
        graph: Option<&mut ConstraintGraph>,
        lambda: &[f64],
    ) {
        self.rows.clear();
        self.global.clear();
        self.pairs.clear();
        self.constraints.clear();
        self.colours.clear();
        self.overflow = 0;
        self.coloured = graph.is_some();
        match graph {
            None => {
                self.global.extend(order.iter().map(|&i| i as u32));
                self.pairs.extend_from_slice(pairs);
                self.pairs.resize(order.len(), false);
            }
            Some(graph) => self.colour(system, state, (order, pairs), graph),
        }
        let n = state.rows.len();
        self.position.clear();
        self.position.resize(n, u32::MAX);
        for (p, &g) in self.global.iter().enumerate() {
            self.position[g as usize] = p as u32;
        }
        let bodies = &state.bodies;
        self.body_count = bodies.len();
        let position = &self.position;
        self.rows.extend(self.global.iter().map(|&g| {
            let row = &state.rows[g as usize];
            let mut side = [Side::NONE; 2];
            let mut body = [u32::MAX; 2];
            for (s, b) in row.blocks[..row.sides as usize].iter().enumerate() {
                side[s] = Side {
                    linear: b.linear,
                    angular: b.angular,
                    angular_response: row.response[s].1,
                    inv_mass: bodies[b.body].inv_mass,
                };
                body[s] = b.body as u32;
            }
            let (kind, normal, mu) = match row.role {
                RowRole::Normal(_) => (Kind::Normal, NO_NORMAL, 0.0),
                RowRole::Friction { normal } => (Kind::Friction, position[normal], row.mu),
                // Only normal, friction and joint rows are swept (`sweep_order`).
                RowRole::Joint | RowRole::Other => (Kind::Joint, NO_NORMAL, 0.0),
            };
            ConstraintRow {
                side,
                k: row.k,
                mass: row.mass,
                c0: row.c0,
                mu,
                body,
                normal,
                kind,
                sides: row.sides,
                touches_static: row.sides < 2
                    || row.blocks[..row.sides as usize]
                        .iter()
                        .any(|b| bodies[b.body].is_static()),
            }
        }));
        self.lambda.clear();
        self.lambda
            .extend(self.global.iter().map(|&g| lambda[g as usize]));
        self.coefficients.clear();
        self.coefficients
            .resize(self.rows.len(), RowCoefficients::default());
        self.hit.clear();
        self.hit.resize(self.rows.len(), false);
        #[cfg(debug_assertions)]
        self.check_colours(state);
    }

    /// The coloured order: constraints in the order of their first row in `order`, coloured
    /// by `graph`, laid out overflow first, then colour by colour.
    fn colour(
        &mut self,
        system: &ContactSystem,
        state: &SolverState,
        (order, pairs): (&[usize], &[bool]),
        graph: &mut ConstraintGraph,
    ) {
        let of_row = super::coloured_sweep::groups(system, state.rows.len());
        // Per constraint: its key, its dynamic bodies, its rows (positions in `order`).
        let mut made: Vec<(ConstraintKey, Vec<usize>, Vec<usize>)> = Vec::new();
        let mut of_group: Vec<Option<usize>> = Vec::new();
        for (p, &i) in order.iter().enumerate() {
            let Some((key, g)) = of_row[i] else { continue };
            if g >= of_group.len() {
                of_group.resize(g + 1, None);
            }
            let c = *of_group[g].get_or_insert_with(|| {
                made.push((key, Vec::new(), Vec::new()));
                made.len() - 1
            });
            let row = &state.rows[i];
            for b in &row.blocks[..row.sides as usize] {
                if !state.bodies[b.body].is_static() && !made[c].1.contains(&b.body) {
                    made[c].1.push(b.body);
                }
            }
            made[c].2.push(p);
        }
        let constraints: Vec<Constraint<'_>> = made
            .iter()
            .map(|(key, bodies, _)| Constraint { key: *key, bodies })
            .collect();
        let colouring = graph.colour(&constraints);
        let push = |c: usize, this: &mut Self| {
            let start = this.global.len();
            let rows = &made[c].2;
            for (k, &p) in rows.iter().enumerate() {
                this.global.push(order[p] as u32);
                // A pair stays a pair only with its partner next in the same constraint.
                let paired =
                    pairs.get(p).copied().unwrap_or(false) && rows.get(k + 1) == Some(&(p + 1));
                this.pairs.push(paired);
            }
            this.constraints.push(start..this.global.len());
        };
        for &c in &colouring.overflow {
            push(c, self);
        }
        self.overflow = self.constraints.len();
        for list in colouring.colours.iter().take(COLOUR_COUNT) {
            if list.is_empty() {
                continue;
            }
            let start = self.constraints.len();
            for &c in list {
                push(c, self);
            }
            self.colours.push(start..self.constraints.len());
        }
    }

    /// Debug builds: the constraints of a colour move disjoint dynamic bodies, and every row
    /// is in exactly one constraint (what makes the parallel writes of [`SharedSlice`] sound).
    #[cfg(debug_assertions)]
    fn check_colours(&self, state: &SolverState) {
        if !self.coloured {
            return;
        }
        let mut end = 0;
        for con in &self.constraints {
            assert_eq!(con.start, end, "constraints not contiguous");
            end = con.end;
        }
        assert_eq!(end, self.rows.len(), "rows outside the constraints");
        // The (colour, constraint) that last moved each body.
        let mut owner: Vec<Option<(usize, usize)>> = vec![None; state.bodies.len()];
        for (c, colour) in self.colours.iter().enumerate() {
            for k in colour.clone() {
                for row in &self.rows[self.constraints[k].clone()] {
                    for (s, &b) in row.side[..row.sides as usize].iter().zip(&row.body) {
                        if s.inv_mass == 0.0 {
                            continue;
                        }
                        let o = &mut owner[b as usize];
                        assert!(
                            !matches!(*o, Some((oc, ok)) if oc == c && ok != k),
                            "body {b} moved by two constraints of colour {c}"
                        );
                        *o = Some((c, k));
                    }
                }
            }
        }
    }

    /// Number of colours with a constraint.
    pub(crate) fn colour_count(&self) -> usize {
        self.colours.len()
    }

    /// Number of constraints in the overflow set.
    pub(crate) fn overflow_count(&self) -> usize {
        self.overflow
    }

    /// Number of constraints.
    pub(crate) fn constraint_count(&self) -> usize {
        self.constraints.len()
    }

    /// The warm start: apply every row's accumulated impulse (in the sweep's order, the
    /// colours' constraints in parallel).
    pub(crate) fn warm_start(&mut self, bodies: &mut [SolverBody]) {
        self.pass::<Rigid>(bodies, None);
    }

    /// One Gauss–Seidel sweep with the coefficients of `rule`, written to
    /// [`ConstraintRows::coefficients`].
    pub(crate) fn sweep<R: SweepRule>(&mut self, bodies: &mut [SolverBody], rule: &R) {
        self.pass(bodies, Some(rule));
    }

    /// One pass over the rows (serially in layout order, or overflow first and then colour by
    /// colour with each colour's constraints in parallel): the warm start without a rule, a
    /// sweep with one.
    fn pass<R: SweepRule>(&mut self, bodies: &mut [SolverBody], rule: Option<&R>) {
        // The rows' body indices were checked against `body_count` bodies when built (the
        // indexing of `bodies[b.body]` there).
        assert_eq!(bodies.len(), self.body_count, "bodies of another step");
        let bodies = SharedSlice::new(bodies);
        let rows = &self.rows;
        let pairs = &self.pairs;
        let lambda = SharedSlice::new(&mut self.lambda);
        let coefficients = SharedSlice::new(&mut self.coefficients);
        let hit = SharedSlice::new(&mut self.hit);
        let run = |span: Range<usize>| {
            // SAFETY: spans given to concurrent tasks are disjoint constraints (whose rows'
            // friction normals are in the same constraint), and their dynamic bodies are
            // disjoint within a colour.
            unsafe {
                run_span(
                    rows,
                    pairs,
                    span,
                    (&lambda, &coefficients, &hit),
                    &bodies,
                    rule,
                )
            }
        };
        if !self.coloured {
            run(0..rows.len());
            return;
        }
        for con in &self.constraints[..self.overflow] {
            run(con.clone());
        }
        for colour in &self.colours {
            self.constraints[colour.clone()]
                .par_iter()
                .with_min_len(MIN_CONSTRAINTS_PER_TASK)
                .for_each(|con| run(con.clone()));
        }
    }
}

/// One pass over the rows `span`.
///
/// # Safety
/// No other task touches the impulses, coefficients or marks of `span`, nor the dynamic bodies
/// of its rows; a friction row's normal row is in `span`.
unsafe fn run_span<R: SweepRule>(
    rows: &[ConstraintRow],
    pairs: &[bool],
    span: Range<usize>,
    (lambda, coefficients, hit): (
        &SharedSlice<'_, f64>,
        &SharedSlice<'_, RowCoefficients>,
        &SharedSlice<'_, bool>,
    ),
    bodies: &SharedSlice<'_, SolverBody>,
    rule: Option<&R>,
) {
    let base = span.start;
    let rows = &rows[span.clone()];
    let pairs = &pairs[span.clone()];
    let lambda = lambda.range_mut(span.clone());
    let coefficients = coefficients.range_mut(span.clone());
    let hit = hit.range_mut(span);
    let Some(rule) = rule else {
        for (row, &l) in rows.iter().zip(lambda.iter()) {
            if l != 0.0 {
                row.apply(l, bodies);
            }
        }
        return;
    };
    let coefficient = |row: &ConstraintRow| rule.coefficients(row, || row.position_error(bodies));
    let mut p = 0;
    while p < rows.len() {
        if pairs[p] && p + 1 < rows.len() {
            let (ka, kb) = (coefficient(&rows[p]), coefficient(&rows[p + 1]));
            coefficients[p] = ka;
            coefficients[p + 1] = kb;
            let pair = solve_pair(
                (&rows[p], &rows[p + 1]),
                bodies,
                (ka, kb),
                (lambda[p], lambda[p + 1]),
            );
            if let Some((na, nb)) = pair {
                for (i, new) in [(p, na), (p + 1, nb)] {
                    let applied = new - lambda[i];
                    if applied != 0.0 && applied.is_finite() {
                        rows[i].apply(applied, bodies);
                        lambda[i] = new;
                    }
                    if lambda[i] > 0.0 {
                        hit[i] = true;
                    }
                }
                p += 2;
                continue;
            }
        }
        let row = &rows[p];
        let c = coefficient(row);
        coefficients[p] = c;
        let vn = row.rate(bodies);
        let d = -row.mass * c.mass_scale * (vn + c.bias) - c.impulse_scale * lambda[p];
        let new = match row.kind {
            Kind::Normal => (lambda[p] + d).max(0.0),
            Kind::Friction => {
                let bound = if row.normal == NO_NORMAL {
                    0.0
                } else {
                    row.mu * lambda[row.normal as usize - base]
                };
                (lambda[p] + d).clamp(-bound, bound)
            }
            Kind::Joint => lambda[p] + d,
        };
        let applied = new - lambda[p];
        if applied != 0.0 && applied.is_finite() {
            row.apply(applied, bodies);
            lambda[p] = new;
        }
        if row.kind == Kind::Normal && lambda[p] > 0.0 {
            hit[p] = true;
        }
        p += 1;
    }
}

/// The new accumulated impulses of two normal rows `a`, `b` solved as one block: the
/// compliant 2×2 LCP `0 ≤ λ ⟂ K' λ + q ≥ 0`, `q = J v + bias − K λ_prev`, `K` the rows' 2×2
/// block of `A`, `K'` it with its diagonal divided by each row's `mass_scale` (Rapier's
/// `ContactConstraintNormalPart::solve_mlcp_two_constraints`). For one row alone it is the
/// soft update of the sweep (`mass_scale + impulse_scale = 1`). The four cases (both active,
/// one, none) are tried in turn; `None` when the block is singular (the caller then solves the
/// rows one after the other).
fn solve_pair(
    (ra, rb): (&ConstraintRow, &ConstraintRow),
    bodies: &SharedSlice<'_, SolverBody>,
    (ka, kb): (RowCoefficients, RowCoefficients),
    (pa, pb): (f64, f64),
) -> Option<(f64, f64)> {
    let (k11, k22, k12) = (ra.k, rb.k, coupling(ra, rb));
    if ka.mass_scale <= 0.0 || kb.mass_scale <= 0.0 || k11 <= 0.0 || k22 <= 0.0 {
        return None;
    }
    let q1 = ra.rate(bodies) + ka.bias - k11 * pa - k12 * pb;
    let q2 = rb.rate(bodies) + kb.bias - k12 * pa - k22 * pb;
    let kp11 = k11 / ka.mass_scale;
    let kp22 = k22 / kb.mass_scale;
    let det = kp11 * kp22 - k12 * k12;
    // Nearly parallel rows (two points on one line through the bodies), or a NaN: no block
    // solve.
    if det.is_nan() || det <= 1e-9 * kp11 * kp22 {
        return None;
    }
    let both = ((k12 * q2 - kp22 * q1) / det, (k12 * q1 - kp11 * q2) / det);
    if both.0 >= 0.0 && both.1 >= 0.0 {
        return Some(both);
    }
    let only_a = -q1 / kp11;
    if only_a >= 0.0 && q2 + k12 * only_a >= 0.0 {
        return Some((only_a, 0.0));
    }
    let only_b = -q2 / kp22;
    if only_b >= 0.0 && q1 + k12 * only_b >= 0.0 {
        return Some((0.0, only_b));
    }
    if q1 >= 0.0 && q2 >= 0.0 {
        return Some((0.0, 0.0));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builder;
    use crate::{BodySolverKind, ContactSolver, Scene};
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

    /// The relax pass's rule: rigid rows, the speculative bias `max(s, 0) / h` on normal rows.
    struct Speculative(f64);

    impl SweepRule for Speculative {
        fn coefficients(&self, row: &ConstraintRow, s: impl FnOnce() -> f64) -> RowCoefficients {
            match row.kind {
                Kind::Normal => RowCoefficients {
                    bias: s().max(0.0) * self.0,
                    ..RIGID_ROW
                },
                _ => RIGID_ROW,
            }
        }
    }

    /// A warm start and one rigid Gauss–Seidel sweep written directly on the rows of
    /// [`SolverState`] in the order `sequence`: the textbook projected Gauss–Seidel step.
    fn direct(state: &mut SolverState, sequence: &[usize], lambda: &mut [f64], inv_h: f64) {
        for &i in sequence {
            state.rows[i].apply(lambda[i], &mut state.bodies);
        }
        for &i in sequence {
            let row = state.rows[i];
            let bias = match row.role {
                RowRole::Normal(_) => row.position_error(&state.bodies).max(0.0) * inv_h,
                _ => 0.0,
            };
            let unclamped = lambda[i] - row.mass * (row.rate(&state.bodies) + bias);
            let new = match row.role {
                RowRole::Normal(_) => unclamped.max(0.0),
                RowRole::Friction { normal } => {
                    let bound = row.mu * lambda[normal];
                    unclamped.clamp(-bound, bound)
                }
                _ => unclamped,
            };
            state.rows[i].apply(new - lambda[i], &mut state.bodies);
            lambda[i] = new;
        }
    }

    /// Serial and coloured layouts, on a pyramid mid-fall: the warm start and one sweep give
    /// the direct Gauss–Seidel's impulses and velocities in the layout's order (to 1e-12), and
    /// the coloured one the same bits on one thread and on two.
    #[test]
    fn a_sweep_of_the_layout_is_gauss_seidel_in_its_order() {
        let (system, state) = system_of("pyramid_10", 10);
        let order: Vec<usize> = (0..state.rows.len())
            .filter(|&i| state.rows[i].mass > 0.0 && state.rows[i].role != RowRole::Other)
            .collect();
        assert!(order.len() > 100, "{}", order.len());
        // Some impulse on every normal row and on the friction rows within their bounds.
        let mut lambda = vec![0.0; state.rows.len()];
        for &i in &order {
            if let RowRole::Normal(c) = state.rows[i].role {
                lambda[i] = 0.05 + 0.01 * (c % 7) as f64;
            }
        }
        for &i in &order {
            if let RowRole::Friction { normal } = state.rows[i].role {
                lambda[i] = 0.3 * state.rows[i].mu * lambda[normal];
            }
        }
        let inv_h = 240.0;
        let mut graph = ConstraintGraph::new();
        for coloured in [false, true] {
            let run = |threads: usize, graph: &mut ConstraintGraph| {
                let mut layout = ConstraintRows::default();
                layout.build(
                    &system,
                    &state,
                    (&order, &[]),
                    coloured.then_some(graph),
                    &lambda,
                );
                let mut bodies = state.bodies.clone();
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| {
                        layout.warm_start(&mut bodies);
                        layout.sweep(&mut bodies, &Speculative(inv_h));
                    });
                (layout, bodies)
            };
            let (layout, bodies) = run(1, &mut graph);
            if coloured {
                assert!(layout.colour_count() >= 2);
                let (again, bodies2) = run(2, &mut graph);
                assert_eq!(again.lambda, layout.lambda);
                assert_eq!(bodies2, bodies);
            }
            let sequence: Vec<usize> = layout.global.iter().map(|&g| g as usize).collect();
            let mut want = state.clone();
            let mut want_lambda = lambda.clone();
            direct(&mut want, &sequence, &mut want_lambda, inv_h);
            let mut moved = 0;
            for (p, &g) in sequence.iter().enumerate() {
                let (got, w) = (layout.lambda[p], want_lambda[g]);
                assert!(
                    (got - w).abs() <= 1e-12 * (1.0 + w.abs()),
                    "row {g}: {got} vs {w}"
                );
                moved += usize::from(got != lambda[g]);
            }
            assert!(moved > order.len() / 4, "{moved} of {}", order.len());
            for (got, w) in bodies.iter().zip(&want.bodies) {
                let scale = 1.0 + w.v.norm() + w.w.norm();
                assert!((got.v - w.v).norm() <= 1e-12 * scale, "{got:?} {w:?}");
                assert!((got.w - w.w).norm() <= 1e-12 * scale, "{got:?} {w:?}");
            }
        }
    }
}

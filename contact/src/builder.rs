//! The contact-matrix builder: from contacts and body states to the LCP of one time step.
//!
//! For contacts with Jacobian `J` (one row per constraint direction, `6 · bodies` columns; static
//! bodies contribute nothing), block-diagonal inverse mass `M⁻¹` and impulse `f`, the velocity
//! after the step is `u⁺ = u* + M⁻¹ Jᵀ f`, where `u* = u + h M⁻¹ f_ext` is the free velocity.
//! The constraint velocities are
//!
//! ```text
//! w = J u⁺ + bias = A f + b,    A = J M⁻¹ Jᵀ (the Delassus matrix),    b = J u* + bias,
//! ```
//!
//! and the bias of a normal row holds, in this order of precedence:
//!
//! * **restitution** (Newton's law `w ≥ −e v⁻`): when the contact closes within the step and its
//!   normal velocity `v⁻ = (J u*)_n` is below `−restitution_threshold`, `b_n += e · v⁻`;
//! * otherwise the **gap** of a speculative contact (`dist > 0`): `b_n += dist / h`, so a body may
//!   close the gap in this step but not cross it;
//! * otherwise **Baumgarte** position correction for a penetration deeper than the slop:
//!   `b_n += (β / h) · min(0, dist + slop)`.
//!
//! With split impulses the Baumgarte term is left out of `b` and solved for separately
//! ([`ContactSystem::position_bias`]); with no correction it is left out entirely.
//!
//! Row layout per contact, "modelling only what a scene requires":
//!
//! * friction model `none` (or `mu = 0`): one normal row, `0 ≤ f_n`;
//! * `box`: the normal row and two tangent rows `t₁, t₂`, friction rows bounded by `±mu f_n`
//!   ([`FrictionRow`]);
//! * `cone`: the same three rows per contact (normal, `t₁`, `t₂`, also when `mu = 0`), solved as
//!   the exact Coulomb cone `‖(f_t₁, f_t₂)‖ ≤ mu f_n` ([`ContactSystem::cone_problem`], a
//!   [`ConeProblem`] with `W = A`, `q = b`); the friction rows are kept so that the box-friction
//!   LCP of the same rows is at hand (export, the box residual);
//! * `pyramid` with `k` directions `d_j = cos(2πj/k) t₁ + sin(2πj/k) t₂`: the normal row, `k`
//!   direction rows `β_j ≥ 0` and one slack row `γ ≥ 0` in the standard-LCP form of
//!   Stewart–Trinkle (1996):
//!
//! ```text
//! w_n = (A f + b)_n                          ≥ 0  ⟂  f_n ≥ 0
//! w_j = (A f + b)_j + γ                      ≥ 0  ⟂  β_j ≥ 0
//! w_γ = mu f_n − Σ_j β_j                     ≥ 0  ⟂  γ ≥ 0
//! ```
//!
//! The matrix-free [`DelassusOperator`] applies `J`, `M⁻¹` and `Jᵀ` body by body for the
//! body-level solvers and for scenes too big for a dense `A`. Per-contact impulses are kept by
//! [`Contact::key`] in a [`WarmStartCache`] to start the next step's solve.

use crate::body::RigidBody;
use crate::collision::Contact;
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};
use faer::Mat;
use lcpbench_solvers::{
    ConeError, ConeProblem, DelassusFactors, FrictionRow, Problem, ProblemError,
};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A material: Coulomb friction and Newton restitution coefficients.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Material {
    /// Name from the scene file.
    pub name: String,
    /// Friction coefficient `mu >= 0`. A contact uses `sqrt(mu_a mu_b)`.
    pub mu: f64,
    /// Restitution coefficient `e` in `[0, 1]`. A contact uses `max(e_a, e_b)`.
    pub restitution: f64,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            mu: 0.5,
            restitution: 0.0,
        }
    }
}

/// How friction is modelled in the LCP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FrictionModel {
    /// Frictionless: normal rows only.
    None,
    /// Two tangent rows per contact bounded by `±mu f_n` (a boxed LCP with friction rows).
    Box,
    /// `directions` friction directions and a slack row per contact (Stewart–Trinkle standard
    /// LCP).
    Pyramid {
        /// Number of directions `k >= 3`.
        directions: usize,
    },
    /// The exact Coulomb cone: the rows of [`FrictionModel::Box`] (normal and two tangents per
    /// contact), solved as an FC3D [`ConeProblem`] by a cone solver.
    Cone,
}

impl FrictionModel {
    /// The name used in scene files, case keys and on the command line: `none`, `box`,
    /// `pyramid` (4 directions) or `pyramid-K`, `cone`.
    pub fn name(&self) -> String {
        match self {
            FrictionModel::None => "none".into(),
            FrictionModel::Box => "box".into(),
            FrictionModel::Pyramid { directions: 4 } => "pyramid".into(),
            FrictionModel::Pyramid { directions } => format!("pyramid-{directions}"),
            FrictionModel::Cone => "cone".into(),
        }
    }

    /// Inverse of [`FrictionModel::name`] (`pyramid-K` for `K` in 3 to 64).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::parse(name, 4).ok()
    }

    /// The one parser of friction-model names, for scene files and the command line: `none`,
    /// `box`, `cone`, `pyramid` with `pyramid_directions` directions, or `pyramid-K`. The
    /// error says which part is wrong: `Err((true, message))` for the directions,
    /// `Err((false, message))` for the name.
    pub fn parse(name: &str, pyramid_directions: usize) -> Result<Self, (bool, String)> {
        let directions = |k: usize| {
            if (3..=MAX_PYRAMID_DIRECTIONS).contains(&k) {
                Ok(FrictionModel::Pyramid { directions: k })
            } else {
                Err((
                    true,
                    format!("must be between 3 and {MAX_PYRAMID_DIRECTIONS}, got {k}"),
                ))
            }
        };
        let unknown = || {
            (
                false,
                format!(
                    "unknown model \"{name}\" (expected \"none\", \"box\", \"pyramid\" or \"cone\")"
                ),
            )
        };
        match name {
            "none" => Ok(FrictionModel::None),
            "box" => Ok(FrictionModel::Box),
            "cone" => Ok(FrictionModel::Cone),
            "pyramid" => directions(pyramid_directions),
            _ => match name.strip_prefix("pyramid-").map(str::parse::<usize>) {
                Some(Ok(k)) => directions(k).map_err(|_| unknown()),
                _ => Err(unknown()),
            },
        }
    }

    /// The names [`FrictionModel::from_name`] takes, for messages.
    pub const NAMES: &'static str =
        "none, box, pyramid (4 directions), pyramid-K (K = 3 to 64), cone";
}

/// How penetration is corrected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PositionCorrection {
    /// No correction: penetration stays.
    None,
    /// Baumgarte stabilisation in the velocity problem: `b_n += (β/h) min(0, dist + slop)`.
    Baumgarte,
    /// Split impulses: the same term drives a separate pseudo-velocity solve that moves positions
    /// but adds no momentum.
    Split,
}

impl PositionCorrection {
    /// The method of a scene file's `position_correction` (`none`, `baumgarte`, `split`), or
    /// why not.
    pub fn from_name(name: &str) -> Result<Self, String> {
        match name {
            "none" => Ok(PositionCorrection::None),
            "baumgarte" => Ok(PositionCorrection::Baumgarte),
            "split" => Ok(PositionCorrection::Split),
            other => Err(format!(
                "unknown method \"{other}\" (expected \"baumgarte\", \"split\" or \"none\")"
            )),
        }
    }
}

/// Largest number of pyramid friction directions: each contact of the pyramid model has
/// `directions + 2` rows.
pub const MAX_PYRAMID_DIRECTIONS: usize = 64;

/// Parameters of the builder. Defaults in brackets.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BuilderParams {
    /// Friction model \[`Box`\].
    pub friction_model: FrictionModel,
    /// Closing speeds below this get no restitution, m/s \[`0.1`\].
    pub restitution_threshold: f64,
    /// Position correction \[`Baumgarte`\].
    pub position_correction: PositionCorrection,
    /// Baumgarte factor `β` in `[0, 1]` \[`0.2`\].
    pub baumgarte: f64,
    /// Penetration allowed without correction, m \[`0.001`\].
    pub slop: f64,
}

impl Default for BuilderParams {
    fn default() -> Self {
        Self {
            friction_model: FrictionModel::Box,
            restitution_threshold: 0.1,
            position_correction: PositionCorrection::Baumgarte,
            baumgarte: 0.2,
            slop: 0.001,
        }
    }
}

/// What a row of the contact system stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum RowKind {
    /// Normal row of contact `contact`.
    Normal {
        /// Contact index.
        contact: usize,
    },
    /// Tangent row `index` (0 or 1) of a box-friction contact.
    Tangent {
        /// Contact index.
        contact: usize,
        /// Which tangent.
        index: usize,
    },
    /// Pyramid direction `index` of a contact.
    Direction {
        /// Contact index.
        contact: usize,
        /// Which direction.
        index: usize,
    },
    /// Pyramid slack row `γ` of a contact (no Jacobian entries).
    Slack {
        /// Contact index.
        contact: usize,
    },
}

/// One side of a Jacobian row: a dynamic body and its 6 entries `[linear; angular]`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JacobianBlock {
    /// Body index.
    pub body: usize,
    /// Linear part (a direction).
    pub linear: Vector3<f64>,
    /// Angular part (`r × direction`).
    pub angular: Vector3<f64>,
}

impl JacobianBlock {
    /// `J_block · u_body`.
    #[inline]
    pub fn dot(&self, u: &BodyVelocity) -> f64 {
        self.linear.dot(&u.linear) + self.angular.dot(&u.angular)
    }
}

/// A row of `J`: up to two blocks (static bodies contribute none). Slack rows have none.
#[derive(Debug, Clone, PartialEq)]
pub struct JacobianRow {
    /// What the row stands for.
    pub kind: RowKind,
    /// The blocks of dynamic bodies.
    pub blocks: RowBlocks,
}

/// The (at most two) blocks of a row, stored in the row: building a step's rows allocates
/// nothing per row.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RowBlocks {
    blocks: [JacobianBlock; 2],
    len: u8,
}

impl RowBlocks {
    /// No block (a slack row, or a row between two static bodies).
    pub const EMPTY: Self = Self {
        blocks: [JacobianBlock {
            body: 0,
            linear: Vector3::new(0.0, 0.0, 0.0),
            angular: Vector3::new(0.0, 0.0, 0.0),
        }; 2],
        len: 0,
    };

    /// Appends a block.
    ///
    /// # Panics
    /// When the row has two blocks already (a row couples at most two bodies).
    pub fn push(&mut self, block: JacobianBlock) {
        assert!(self.len < 2, "a Jacobian row couples at most two bodies");
        self.blocks[self.len as usize] = block;
        self.len += 1;
    }
}

impl std::ops::Deref for RowBlocks {
    type Target = [JacobianBlock];
    fn deref(&self) -> &[JacobianBlock] {
        &self.blocks[..self.len as usize]
    }
}

impl<'a> IntoIterator for &'a RowBlocks {
    type Item = &'a JacobianBlock;
    type IntoIter = std::slice::Iter<'a, JacobianBlock>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// Generalised velocity of one body: `(v, ω)`, world frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BodyVelocity {
    /// Linear velocity of the centre of mass.
    pub linear: Vector3<f64>,
    /// Angular velocity.
    pub angular: Vector3<f64>,
}

/// Inverse mass of one body: `m⁻¹` and the world-frame `I⁻¹ = R I_body⁻¹ Rᵀ` (zero for static
/// bodies).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InverseMass {
    /// `1/m`.
    pub inv_mass: f64,
    /// World-frame inverse inertia.
    pub inv_inertia: Matrix3<f64>,
}

impl InverseMass {
    /// Of a body at its current orientation.
    pub fn of(body: &RigidBody) -> Self {
        if body.is_static {
            Self {
                inv_mass: 0.0,
                inv_inertia: Matrix3::zeros(),
            }
        } else {
            Self {
                inv_mass: body.inv_mass,
                inv_inertia: body.inv_inertia_world(),
            }
        }
    }

    /// `M⁻¹ Jᵀ` of one block times a scalar impulse: the velocity change of the body.
    #[inline]
    pub fn response(&self, block: &JacobianBlock, impulse: f64) -> BodyVelocity {
        BodyVelocity {
            linear: block.linear * (self.inv_mass * impulse),
            angular: self.inv_inertia * block.angular * impulse,
        }
    }
}

/// Orthonormal tangents `(t₁, t₂)` of a unit normal, `t₁ × t₂ = n`, chosen deterministically.
pub fn tangent_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let a = n.abs();
    let axis = if a.x <= a.y && a.x <= a.z {
        Vector3::x()
    } else if a.y <= a.z {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let t1 = n.cross(&axis).normalize();
    let t2 = n.cross(&t1);
    (t1, t2)
}

/// Per-contact data the builder derived, kept for solvers, reports and warm starting.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactInfo {
    /// Row of the normal impulse.
    pub normal_row: usize,
    /// First friction row (tangent or direction), if any.
    pub friction_rows: std::ops::Range<usize>,
    /// Slack row (pyramid model).
    pub slack_row: Option<usize>,
    /// Scale `s` of the slack row and column (pyramid model): `A_nn` of the contact, so that the
    /// coupling entries are of the size of the Delassus entries (see [`ContactSystem::delassus`]).
    pub slack_scale: f64,
    /// Friction coefficient of the contact.
    pub mu: f64,
    /// Restitution coefficient of the contact.
    pub restitution: f64,
    /// True when Newton's restitution law is active on this contact in this step.
    pub bouncing: bool,
    /// Tangents `t₁, t₂`.
    pub tangents: (Vector3<f64>, Vector3<f64>),
}

/// Per-contact impulse kept for warm starting: normal magnitude and world tangential impulse.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactImpulse {
    /// Normal impulse `f_n`.
    pub normal: f64,
    /// Tangential impulse, world frame.
    pub tangent: Vector3<f64>,
}

/// Impulses of the previous step, by [`Contact::key`].
#[derive(Debug, Clone, Default)]
pub struct WarmStartCache {
    map: HashMap<u64, ContactImpulse, BuildHasherDefault<KeyHasher>>,
}

/// The hasher of [`WarmStartCache`]: a contact key is already a well-mixed 64-bit hash
/// ([`crate::collision::narrow_phase::contact_key`]), so it is its own hash (a general-purpose
/// hasher would cost more than the lookup).
#[derive(Debug, Clone, Copy, Default)]
pub struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(b);
        }
    }

    fn write_u64(&mut self, key: u64) {
        self.0 = key;
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

impl WarmStartCache {
    /// The impulse stored for `key`.
    pub fn get(&self, key: u64) -> Option<&ContactImpulse> {
        self.map.get(&key)
    }

    /// Replace the cache with the impulses of `system` solved as `f`.
    pub fn store(&mut self, system: &ContactSystem, f: &[f64]) {
        self.map.clear();
        for (c, contact) in system.contacts.iter().enumerate() {
            self.map.insert(contact.key, system.contact_impulse(c, f));
        }
    }

    /// Number of contacts stored.
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    /// Forget everything.
    pub fn clear(&mut self) {
        self.map.clear();
    }
}

/// Problems of at most this many rows are stored dense: for them a dense row is faster than
/// a sparse one and the pivoting solvers need the dense form anyway.
pub const DENSE_ROWS: usize = 24;

/// Most stored entries of one step's assembled Delassus matrix `A` (about 16 bytes each in
/// compressed rows: 800 MB). Every pair of rows on one body couples, so the entries grow with
/// the square of a body's rows: a mesh whose flat bottom touches the ground at 10,201 points
/// asks for 30,603² ≈ 9.4e8 of them, while a pile of 10,000 spheres needs a few million.
pub const MAX_DELASSUS_ENTRIES: usize = 50_000_000;

/// An independent group of contacts: no dynamic body is shared with another island, so its
/// rows of `A` couple to no other island's rows ([`ContactSystem::islands`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Island {
    /// Contact indices, increasing.
    pub contacts: Vec<usize>,
    /// Rows of those contacts, increasing.
    pub rows: Vec<usize>,
    /// Dynamic bodies the contacts touch, in first-seen order.
    pub bodies: Vec<usize>,
}

/// The islands of a step with one numbering shared by all: every row and dynamic body
/// belongs to exactly one island, so one global → local map serves them all.
#[derive(Debug, Clone, Default)]
pub struct Partition {
    /// The islands.
    pub islands: Vec<Island>,
    /// Global row → row within its island.
    local_row: Vec<usize>,
    /// Global body → body within its island (`usize::MAX` for bodies in no island).
    local_body: Vec<usize>,
}

impl Partition {
    /// Number of islands.
    pub fn len(&self) -> usize {
        self.islands.len()
    }

    /// True when there are no contacts.
    pub fn is_empty(&self) -> bool {
        self.islands.is_empty()
    }
}

/// How a [`Problem`] built from a [`ContactSystem`] holds its `A = J M⁻¹ Jᵀ`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DelassusForm {
    /// Assembled: dense for at most [`DENSE_ROWS`] rows, else compressed sparse rows, with the
    /// factors attached unless pyramid slack rows couple outside `J M⁻¹ Jᵀ`.
    Assembled,
    /// Held as its factors `J`, `M⁻¹` ([`Problem::boxed_factored`]), for solvers that sweep on
    /// them ([`lcpbench_solvers::Solver::works_on_factors`]); `A` is assembled only if a row of
    /// it is asked for. Problems of at most [`DENSE_ROWS`] rows and those with pyramid slack
    /// rows are assembled as with [`DelassusForm::Assembled`].
    Factored,
}

/// A set of rows and bodies with their local numbering, for assembling a sub-problem.
struct Subset<'a> {
    rows: &'a [usize],
    bodies: &'a [usize],
    /// Global row → local row (`usize::MAX` outside the subset).
    local_row: &'a [usize],
    /// Global body → local body.
    local_body: &'a [usize],
}

/// The contact problem of one step: rows of `J`, `b` split into its parts, bounds and friction
/// rows. Dense `A` is assembled on demand ([`ContactSystem::delassus`]).
#[derive(Debug, Clone)]
pub struct ContactSystem {
    /// The contacts, as detected.
    pub contacts: Vec<Contact>,
    /// Per contact: rows and coefficients.
    pub info: Vec<ContactInfo>,
    /// Rows of `J`.
    pub rows: Vec<JacobianRow>,
    /// Inverse masses of all bodies (static ones zero).
    pub inv_mass: Vec<InverseMass>,
    /// Free velocities `u*` of all bodies.
    pub free_velocity: Vec<BodyVelocity>,
    /// `J u*` per row (0 on slack rows).
    pub free_rate: Vec<f64>,
    /// Restitution, gap and (Baumgarte) position terms per row, so `b = free_rate + bias`.
    pub bias: Vec<f64>,
    /// Position-error term per row for split impulses: `(β/h) min(0, dist + slop)` on normal rows
    /// (all zero unless the correction is [`PositionCorrection::Split`]).
    pub position_bias: Vec<f64>,
    /// Lower bounds (friction rows: ignored).
    pub lo: Vec<f64>,
    /// Upper bounds (friction rows: ignored).
    pub hi: Vec<f64>,
    /// Box-friction rows.
    pub friction: Vec<FrictionRow>,
    /// Time step.
    pub h: f64,
    /// Closing speeds below this get no restitution, m/s (from
    /// [`BuilderParams::restitution_threshold`]; the body-level solvers' bounce test uses it too).
    pub restitution_threshold: f64,
}

impl ContactSystem {
    /// Number of rows.
    pub fn n(&self) -> usize {
        self.rows.len()
    }

    /// `b = J u* + bias`.
    pub fn b(&self) -> Vec<f64> {
        self.free_rate
            .iter()
            .zip(&self.bias)
            .map(|(a, b)| a + b)
            .collect()
    }

    /// True when the system has no friction rows. Its normal rows always have `lo = 0`,
    /// `hi = ∞`, so this is the test for a standard LCP; the bounds are not inspected.
    pub fn is_standard(&self) -> bool {
        self.friction.is_empty()
    }

    /// An upper bound on the stored entries of `A` as [`ContactSystem::delassus_sparse`]
    /// assembles it (`Σ` over rows of the rows sharing each of its bodies, plus the pyramid
    /// coupling), counted in one pass over the rows before anything is allocated.
    pub fn delassus_entries(&self) -> u128 {
        let mut rows_on = vec![0u128; self.inv_mass.len()];
        for row in &self.rows {
            for blk in &row.blocks {
                rows_on[blk.body] += 1;
            }
        }
        let coupling = self
            .info
            .iter()
            .filter(|c| c.slack_row.is_some())
            .map(|c| 2 * c.friction_rows.len() as u128 + 1)
            .sum::<u128>();
        rows_on.iter().map(|&r| r * r).sum::<u128>() + coupling + self.n() as u128
    }

    /// `Err` with the reason when assembling `A` would store more than
    /// [`MAX_DELASSUS_ENTRIES`] entries, naming the body with the most rows (`bodies` are the
    /// bodies the system was built from).
    pub fn check_delassus_size(&self, bodies: &[RigidBody]) -> Result<(), String> {
        let entries = self.delassus_entries();
        if entries <= MAX_DELASSUS_ENTRIES as u128 {
            return Ok(());
        }
        let mut rows_on = vec![0usize; self.inv_mass.len()];
        for row in &self.rows {
            for blk in &row.blocks {
                rows_on[blk.body] += 1;
            }
        }
        let (body, most) = rows_on
            .iter()
            .enumerate()
            .max_by_key(|(_, &r)| r)
            .map_or((0, 0), |(b, &r)| (b, r));
        let name = bodies.get(body).map_or("?", |b| b.name.as_str());
        Err(format!(
            "the step's Delassus matrix would store {entries} entries ({} rows, {most} of them on \
             body \"{name}\"), beyond the limit of {MAX_DELASSUS_ENTRIES}: every pair of rows on \
             one body couples, so a body touching at thousands of points (a finely meshed flat \
             face on the ground) needs fewer contacts (a coarser mesh, a convex hull) or fewer \
             rows per contact (friction_model = \"none\")",
            self.n()
        ))
    }

    /// The dense Jacobian, `rows × 6·bodies`, columns `[v_k; ω_k]` per body `k`.
    pub fn jacobian(&self) -> Mat<f64> {
        let mut j = Mat::zeros(self.n(), 6 * self.inv_mass.len());
        for (i, row) in self.rows.iter().enumerate() {
            for blk in &row.blocks {
                for d in 0..3 {
                    j[(i, 6 * blk.body + d)] += blk.linear[d];
                    j[(i, 6 * blk.body + 3 + d)] += blk.angular[d];
                }
            }
        }
        j
    }

    /// The dense LCP matrix `A` (a copy of [`ContactSystem::delassus_sparse`]; for tests and
    /// small systems).
    pub fn delassus(&self) -> Mat<f64> {
        self.delassus_sparse().to_dense()
    }

    /// The LCP matrix `A = J M⁻¹ Jᵀ` in compressed sparse rows, plus the pyramid coupling
    /// entries. The slack row and column of a pyramid contact are scaled by `s = A_nn`
    /// (entries `s`, `s mu`, `−s`): the variable is `γ / s` and its row `s (mu f_n − Σ β)`, the
    /// same complementarity problem with entries of one magnitude, which pivoting solvers need.
    /// Assembled body by body in `O(Σ_bodies rows(body)²)`, that is contacts × neighbours.
    pub fn delassus_sparse(&self) -> SparseRowMat<usize, f64> {
        let (rows, bodies) = self.identity();
        self.assemble_delassus(&Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &rows,
            local_body: &bodies,
        })
    }

    /// `(0..rows, 0..bodies)`: the numbering of the whole system.
    fn identity(&self) -> (Vec<usize>, Vec<usize>) {
        ((0..self.n()).collect(), (0..self.inv_mass.len()).collect())
    }

    /// The independent groups of contacts: union–find over the dynamic bodies the contacts
    /// touch (a static body joins no group). Islands are ordered by their first contact; the
    /// contacts, rows and bodies of each are increasing, first-seen and increasing respectively.
    pub fn islands(&self) -> Partition {
        let nc = self.contacts.len();
        let mut parent: Vec<usize> = (0..nc).collect();
        fn find(parent: &mut [usize], mut x: usize) -> usize {
            while parent[x] != x {
                parent[x] = parent[parent[x]];
                x = parent[x];
            }
            x
        }
        let mut first_contact = vec![usize::MAX; self.inv_mass.len()];
        for (c, info) in self.info.iter().enumerate() {
            for blk in &self.rows[info.normal_row].blocks {
                let other = first_contact[blk.body];
                if other == usize::MAX {
                    first_contact[blk.body] = c;
                } else {
                    let (ra, rb) = (find(&mut parent, c), find(&mut parent, other));
                    if ra != rb {
                        parent[ra.max(rb)] = ra.min(rb);
                    }
                }
            }
        }
        let mut island_of = vec![usize::MAX; nc];
        let mut islands: Vec<Island> = Vec::new();
        let mut body_seen = vec![false; self.inv_mass.len()];
        for c in 0..nc {
            let r = find(&mut parent, c);
            if island_of[r] == usize::MAX {
                island_of[r] = islands.len();
                islands.push(Island::default());
            }
            let island = &mut islands[island_of[r]];
            island.contacts.push(c);
            island.rows.extend(self.contact_rows(c));
            for blk in &self.rows[self.info[c].normal_row].blocks {
                if !body_seen[blk.body] {
                    body_seen[blk.body] = true;
                    island.bodies.push(blk.body);
                }
            }
        }
        let mut local_row = vec![usize::MAX; self.n()];
        let mut local_body = vec![usize::MAX; self.inv_mass.len()];
        for island in &islands {
            for (k, &i) in island.rows.iter().enumerate() {
                local_row[i] = k;
            }
            for (k, &b) in island.bodies.iter().enumerate() {
                local_body[b] = k;
            }
        }
        Partition {
            islands,
            local_row,
            local_body,
        }
    }

    /// The rows of contact `c` (normal, friction, slack), contiguous.
    pub fn contact_rows(&self, c: usize) -> std::ops::Range<usize> {
        let end = self.info.get(c + 1).map_or(self.n(), |i| i.normal_row);
        self.info[c].normal_row..end
    }

    /// The step's LCP as a solver [`Problem`]: `A` sparse (dense when tiny), with the factors
    /// `J`, `M⁻¹` attached for matrix-free solvers unless pyramid slack rows are present (their
    /// coupling entries are not of the form `J M⁻¹ Jᵀ`).
    pub fn problem(&self) -> Result<Problem, ProblemError> {
        self.problem_in(DelassusForm::Assembled)
    }

    /// [`ContactSystem::problem`] with `A` held in `form`.
    pub fn problem_in(&self, form: DelassusForm) -> Result<Problem, ProblemError> {
        let (rows, bodies) = self.identity();
        let all = Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &rows,
            local_body: &bodies,
        };
        self.subset_problem(&all, self.friction.clone(), self.b(), form)
    }

    /// The LCP of island `k` of `partition` (rows and bodies renumbered in the island's order).
    pub fn island_problem(&self, partition: &Partition, k: usize) -> Result<Problem, ProblemError> {
        self.island_problem_in(partition, k, DelassusForm::Assembled)
    }

    /// [`ContactSystem::island_problem`] with `A` held in `form`.
    pub fn island_problem_in(
        &self,
        partition: &Partition,
        k: usize,
        form: DelassusForm,
    ) -> Result<Problem, ProblemError> {
        let island = &partition.islands[k];
        let subset = Subset {
            rows: &island.rows,
            bodies: &island.bodies,
            local_row: &partition.local_row,
            local_body: &partition.local_body,
        };
        let mut friction = Vec::new();
        for &c in &island.contacts {
            let info = &self.info[c];
            if info.slack_row.is_none() {
                for r in info.friction_rows.clone() {
                    friction.push(FrictionRow {
                        row: subset.local_row[r],
                        normal: subset.local_row[info.normal_row],
                        mu: info.mu,
                    });
                }
            }
        }
        let b = island
            .rows
            .iter()
            .map(|&i| self.free_rate[i] + self.bias[i])
            .collect();
        self.subset_problem(&subset, friction, b, form)
    }

    /// The step's contact problem as the exact Coulomb cone: `W = A`, `q = b` and `mu` of each
    /// contact (`W` sparse, dense when tiny). Needs every contact to have the three rows of the
    /// cone (or box) model, normal then two tangents; otherwise
    /// [`ConeError::NotContactTriples`] names the first contact that has not.
    pub fn cone_problem(&self) -> Result<ConeProblem, ConeError> {
        let (rows, bodies) = self.identity();
        let contacts: Vec<usize> = (0..self.contacts.len()).collect();
        let subset = Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &rows,
            local_body: &bodies,
        };
        self.subset_cone_problem(&subset, &contacts, self.b())
    }

    /// The cone problem of island `k` of `partition` (see [`ContactSystem::cone_problem`]).
    pub fn island_cone_problem(
        &self,
        partition: &Partition,
        k: usize,
    ) -> Result<ConeProblem, ConeError> {
        let island = &partition.islands[k];
        let subset = Subset {
            rows: &island.rows,
            bodies: &island.bodies,
            local_row: &partition.local_row,
            local_body: &partition.local_body,
        };
        let b = island
            .rows
            .iter()
            .map(|&i| self.free_rate[i] + self.bias[i])
            .collect();
        self.subset_cone_problem(&subset, &island.contacts, b)
    }

    fn subset_cone_problem(
        &self,
        subset: &Subset,
        contacts: &[usize],
        q: Vec<f64>,
    ) -> Result<ConeProblem, ConeError> {
        for &c in contacts {
            let info = &self.info[c];
            let triple = info.slack_row.is_none()
                && info.friction_rows.len() == 2
                && info.friction_rows.start == info.normal_row + 1;
            if !triple {
                return Err(ConeError::NotContactTriples {
                    row: subset.local_row[info.normal_row],
                    reason: format!(
                        "contact {c} has {} friction rows{}; the cone takes a normal and two \
                         tangent rows per contact (friction_model \"cone\")",
                        info.friction_rows.len(),
                        if info.slack_row.is_some() {
                            " and a pyramid slack row"
                        } else {
                            ""
                        }
                    ),
                });
            }
        }
        let mu = contacts.iter().map(|&c| self.info[c].mu).collect();
        let w = self.assemble_delassus(subset);
        if subset.rows.len() <= DENSE_ROWS {
            ConeProblem::new(w.to_dense(), q, mu)
        } else {
            ConeProblem::new_sparse(w, q, mu)
        }
    }

    fn subset_problem(
        &self,
        subset: &Subset,
        friction: Vec<FrictionRow>,
        b: Vec<f64>,
        form: DelassusForm,
    ) -> Result<Problem, ProblemError> {
        let lo = subset.rows.iter().map(|&i| self.lo[i]).collect();
        let hi = subset.rows.iter().map(|&i| self.hi[i]).collect();
        let pyramid = subset
            .rows
            .iter()
            .any(|&i| matches!(self.rows[i].kind, RowKind::Slack { .. }));
        let small = subset.rows.len() <= DENSE_ROWS;
        if form == DelassusForm::Factored && !pyramid && !small {
            return Problem::boxed_factored(self.factors(subset)?, b, lo, hi, friction);
        }
        let a = self.assemble_delassus(subset);
        let problem = if small {
            Problem::boxed(a.to_dense(), b, lo, hi, friction)?
        } else {
            Problem::boxed_sparse(a, b, lo, hi, friction)?
        };
        if pyramid {
            Ok(problem)
        } else {
            problem.with_factors(self.factors(subset)?)
        }
    }

    /// `J` (sparse, local numbering) and the 6×6 inverse-mass blocks of the subset's bodies.
    fn factors(&self, subset: &Subset) -> Result<DelassusFactors, ProblemError> {
        // Each row's (at most two) blocks in the order of their local bodies.
        let m = subset.rows.len();
        let mut block_ptr = Vec::with_capacity(m + 1);
        let mut row_blocks = Vec::with_capacity(2 * m);
        block_ptr.push(0);
        for &i in subset.rows {
            let blocks = &self.rows[i].blocks;
            let mut order = [0, 1];
            if blocks.len() == 2
                && subset.local_body[blocks[1].body] < subset.local_body[blocks[0].body]
            {
                order = [1, 0];
            }
            for blk in order.iter().filter_map(|&k| blocks.get(k)) {
                row_blocks.push((
                    subset.local_body[blk.body],
                    [
                        blk.linear.x,
                        blk.linear.y,
                        blk.linear.z,
                        blk.angular.x,
                        blk.angular.y,
                        blk.angular.z,
                    ],
                ));
            }
            block_ptr.push(row_blocks.len());
        }
        let blocks = subset
            .bodies
            .iter()
            .map(|&k| {
                let m = &self.inv_mass[k];
                let mut blk = [[0.0; 6]; 6];
                for a in 0..3 {
                    blk[a][a] = m.inv_mass;
                    for c in 0..3 {
                        blk[3 + a][3 + c] = m.inv_inertia[(a, c)];
                    }
                }
                blk
            })
            .collect();
        DelassusFactors::from_row_blocks(block_ptr, row_blocks, blocks)
    }

    /// `A` of the subset's rows in compressed sparse rows. Each row's nonzeros are the rows
    /// that share one of its (at most two) bodies: the two bodies' sorted row lists are merged
    /// and each entry is `J_i,body · (M⁻¹ J_j,bodyᵀ)`, summed over shared bodies.
    fn assemble_delassus(&self, subset: &Subset) -> SparseRowMat<usize, f64> {
        let m = subset.rows.len();
        // Per local body: (local row, M⁻¹ J_blockᵀ as [linear; angular]), rows increasing.
        let mut touching: Vec<Vec<(usize, [f64; 6])>> = vec![Vec::new(); subset.bodies.len()];
        for (r, &i) in subset.rows.iter().enumerate() {
            for blk in &self.rows[i].blocks {
                let resp = self.inv_mass[blk.body].response(blk, 1.0);
                let v = [
                    resp.linear.x,
                    resp.linear.y,
                    resp.linear.z,
                    resp.angular.x,
                    resp.angular.y,
                    resp.angular.z,
                ];
                touching[subset.local_body[blk.body]].push((r, v));
            }
        }
        let nnz: usize = subset
            .rows
            .iter()
            .map(|&i| {
                self.rows[i]
                    .blocks
                    .iter()
                    .map(|b| touching[subset.local_body[b.body]].len())
                    .sum::<usize>()
                    + 1
            })
            .sum();
        let mut row_ptr = Vec::with_capacity(m + 1);
        let mut col_idx = Vec::with_capacity(nnz);
        let mut val = Vec::with_capacity(nnz);
        row_ptr.push(0);
        let six = |b: &JacobianBlock| {
            [
                b.linear.x,
                b.linear.y,
                b.linear.z,
                b.angular.x,
                b.angular.y,
                b.angular.z,
            ]
        };
        let dot6 = |a: &[f64; 6], b: &[f64; 6]| -> f64 { (0..6).map(|k| a[k] * b[k]).sum() };
        for &i in subset.rows {
            let start = col_idx.len();
            let blocks = &self.rows[i].blocks;
            match &blocks[..] {
                [] => {}
                [b1] => {
                    let j1 = six(b1);
                    for (c, resp) in &touching[subset.local_body[b1.body]] {
                        col_idx.push(*c);
                        val.push(dot6(&j1, resp));
                    }
                }
                [b1, b2, ..] => {
                    let (j1, j2) = (six(b1), six(b2));
                    let l1 = &touching[subset.local_body[b1.body]];
                    let l2 = &touching[subset.local_body[b2.body]];
                    let (mut p, mut q) = (0, 0);
                    while p < l1.len() || q < l2.len() {
                        let c1 = l1.get(p).map_or(usize::MAX, |e| e.0);
                        let c2 = l2.get(q).map_or(usize::MAX, |e| e.0);
                        let c = c1.min(c2);
                        let mut v = 0.0;
                        if c1 == c {
                            v += dot6(&j1, &l1[p].1);
                            p += 1;
                        }
                        if c2 == c {
                            v += dot6(&j2, &l2[q].1);
                            q += 1;
                        }
                        col_idx.push(c);
                        val.push(v);
                    }
                }
            }
            if let Some(extra) = self.pyramid_coupling(i, subset) {
                for (c, v) in extra {
                    col_idx.push(c);
                    val.push(v);
                }
                let mut entries: Vec<(usize, f64)> = col_idx[start..]
                    .iter()
                    .copied()
                    .zip(val[start..].iter().copied())
                    .collect();
                entries.sort_by_key(|e| e.0);
                for (k, (c, v)) in entries.into_iter().enumerate() {
                    col_idx[start + k] = c;
                    val[start + k] = v;
                }
            }
            row_ptr.push(col_idx.len());
        }
        let symbolic = SymbolicSparseRowMat::new_checked(m, m, row_ptr, None, col_idx);
        SparseRowMat::new(symbolic, val)
    }

    /// The pyramid coupling entries of row `i` (local columns), if it is a direction or slack
    /// row whose partner rows are in the subset.
    fn pyramid_coupling(&self, i: usize, subset: &Subset) -> Option<Vec<(usize, f64)>> {
        let local = |r: usize| Some(subset.local_row[r]).filter(|&l| l != usize::MAX);
        match self.rows[i].kind {
            RowKind::Direction { contact, .. } => {
                let info = &self.info[contact];
                let s = local(info.slack_row?)?;
                Some(vec![(s, info.slack_scale)])
            }
            RowKind::Slack { contact } => {
                let info = &self.info[contact];
                let scale = info.slack_scale;
                let mut v = Vec::with_capacity(1 + info.friction_rows.len());
                if let Some(n) = local(info.normal_row) {
                    v.push((n, scale * info.mu));
                }
                v.extend(
                    info.friction_rows
                        .clone()
                        .filter_map(|d| Some((local(d)?, -scale))),
                );
                Some(v)
            }
            _ => None,
        }
    }

    /// The normal rows only, with `b = J u + position_bias` for a split-impulse position solve
    /// given velocities `u`: `(A_nn, b_p, normal row indices)`.
    pub fn position_problem(&self, u: &[BodyVelocity]) -> Option<(Problem, Vec<usize>)> {
        let normals: Vec<usize> = self.info.iter().map(|c| c.normal_row).collect();
        if normals.iter().all(|&i| self.position_bias[i] >= 0.0) {
            return None;
        }
        let op = self.operator();
        let b = normals
            .iter()
            .map(|&i| op.row_dot(i, u) + self.position_bias[i])
            .collect();
        let mut local_row = vec![usize::MAX; self.n()];
        for (k, &i) in normals.iter().enumerate() {
            local_row[i] = k;
        }
        let (_, bodies) = self.identity();
        let subset = Subset {
            rows: &normals,
            bodies: &bodies,
            local_row: &local_row,
            local_body: &bodies,
        };
        self.subset_problem(&subset, Vec::new(), b, DelassusForm::Assembled)
            .ok()
            .map(|p| (p, normals))
    }

    /// The matrix-free operator over this system's Jacobian rows.
    pub fn operator(&self) -> DelassusOperator<'_> {
        DelassusOperator {
            rows: &self.rows,
            inv_mass: &self.inv_mass,
        }
    }

    /// Velocity change `M⁻¹ Jᵀ f` of every body.
    pub fn velocity_change(&self, f: &[f64]) -> Vec<BodyVelocity> {
        let mut du = vec![BodyVelocity::default(); self.inv_mass.len()];
        self.operator().add_response(f, &mut du);
        du
    }

    /// Impulse `Jᵀ f` on each body, as `(linear impulse, angular impulse about the centre of
    /// mass)`: the momentum change.
    pub fn momentum_change(&self, f: &[f64]) -> Vec<(Vector3<f64>, Vector3<f64>)> {
        let mut dp = vec![(Vector3::zeros(), Vector3::zeros()); self.inv_mass.len()];
        for (row, &fi) in self.rows.iter().zip(f) {
            for blk in &row.blocks {
                dp[blk.body].0 += blk.linear * fi;
                dp[blk.body].1 += blk.angular * fi;
            }
        }
        dp
    }

    /// Normal magnitude and world tangential impulse of contact `c` in the solution `f`.
    pub fn contact_impulse(&self, c: usize, f: &[f64]) -> ContactImpulse {
        let info = &self.info[c];
        let mut tangent = Vector3::zeros();
        for (j, r) in info.friction_rows.clone().enumerate() {
            tangent += self.friction_direction(c, j) * f[r];
        }
        ContactImpulse {
            normal: f[info.normal_row],
            tangent,
        }
    }

    /// World direction of friction row `j` (0-based within the contact).
    pub fn friction_direction(&self, c: usize, j: usize) -> Vector3<f64> {
        let info = &self.info[c];
        let (t1, t2) = info.tangents;
        if info.slack_row.is_some() {
            let k = info.friction_rows.len() as f64;
            let th = 2.0 * std::f64::consts::PI * j as f64 / k;
            t1 * th.cos() + t2 * th.sin()
        } else if j == 0 {
            t1
        } else {
            t2
        }
    }

    /// A warm start from the cache: normal and tangential impulses of contacts seen last step
    /// (pyramid directions: the positive parts of the projections; slack rows zero).
    pub fn warm_start(&self, cache: &WarmStartCache) -> Vec<f64> {
        let mut f = vec![0.0; self.n()];
        for (c, contact) in self.contacts.iter().enumerate() {
            let Some(imp) = cache.get(contact.key) else {
                continue;
            };
            let info = &self.info[c];
            f[info.normal_row] = imp.normal.max(0.0);
            let pyramid = info.slack_row.is_some();
            let k = info.friction_rows.len() as f64;
            for (j, r) in info.friction_rows.clone().enumerate() {
                let p = self.friction_direction(c, j).dot(&imp.tangent);
                f[r] = if pyramid { 2.0 * p.max(0.0) / k } else { p };
            }
        }
        f
    }

    /// Largest violation of the Coulomb cone `‖f_t‖ ≤ mu f_n` over contacts, in impulse units.
    pub fn friction_cone_violation(&self, f: &[f64]) -> f64 {
        (0..self.contacts.len())
            .map(|c| {
                let imp = self.contact_impulse(c, f);
                (imp.tangent.norm() - self.info[c].mu * imp.normal.max(0.0)).max(0.0)
            })
            .fold(0.0, f64::max)
    }
}

/// Matrix-free `A = J M⁻¹ Jᵀ`: applies `J`, `M⁻¹` and `Jᵀ` body by body, never forming `A`.
#[derive(Debug, Clone, Copy)]
pub struct DelassusOperator<'a> {
    rows: &'a [JacobianRow],
    inv_mass: &'a [InverseMass],
}

impl DelassusOperator<'_> {
    /// `(J u)_i`.
    #[inline]
    pub fn row_dot(&self, i: usize, u: &[BodyVelocity]) -> f64 {
        self.rows[i].blocks.iter().map(|b| b.dot(&u[b.body])).sum()
    }

    /// `A_ii = J_i M⁻¹ J_iᵀ`.
    pub fn diagonal(&self, i: usize) -> f64 {
        self.rows[i]
            .blocks
            .iter()
            .map(|b| b.dot(&self.inv_mass[b.body].response(b, 1.0)))
            .sum()
    }

    /// `A_ij = J_i M⁻¹ J_jᵀ` for two Jacobian rows.
    pub fn entry(&self, i: usize, j: usize) -> f64 {
        let mut s = 0.0;
        for bi in &self.rows[i].blocks {
            for bj in &self.rows[j].blocks {
                if bi.body == bj.body {
                    s += bi.dot(&self.inv_mass[bj.body].response(bj, 1.0));
                }
            }
        }
        s
    }

    /// `u += M⁻¹ J_iᵀ impulse` for one row.
    #[inline]
    pub fn apply_row(&self, i: usize, impulse: f64, u: &mut [BodyVelocity]) {
        for b in &self.rows[i].blocks {
            let r = self.inv_mass[b.body].response(b, impulse);
            u[b.body].linear += r.linear;
            u[b.body].angular += r.angular;
        }
    }

    /// `u += M⁻¹ Jᵀ f`.
    pub fn add_response(&self, f: &[f64], u: &mut [BodyVelocity]) {
        for (i, &fi) in f.iter().enumerate() {
            if fi != 0.0 {
                self.apply_row(i, fi, u);
            }
        }
    }

    /// `A f = J (M⁻¹ Jᵀ f)` for the Jacobian rows (pyramid coupling entries excluded).
    pub fn apply(&self, f: &[f64]) -> Vec<f64> {
        let mut u = vec![BodyVelocity::default(); self.inv_mass.len()];
        self.add_response(f, &mut u);
        (0..self.rows.len()).map(|i| self.row_dot(i, &u)).collect()
    }
}

/// Free velocity `u* = u + h M⁻¹ f_ext` of each body (gravity only; static bodies at rest).
pub fn free_velocities(bodies: &[RigidBody], gravity: &Vector3<f64>, h: f64) -> Vec<BodyVelocity> {
    bodies
        .iter()
        .map(|b| {
            if b.is_static {
                BodyVelocity::default()
            } else {
                BodyVelocity {
                    linear: b.velocity() + gravity * h,
                    angular: b.angular_velocity(),
                }
            }
        })
        .collect()
}

/// Build the contact system of one step from the contacts, the bodies at the start of the step
/// and their free velocities `u*`.
pub fn build(
    bodies: &[RigidBody],
    materials: &[Material],
    contacts: &[Contact],
    free_velocity: Vec<BodyVelocity>,
    params: &BuilderParams,
    h: f64,
) -> ContactSystem {
    let inv_mass: Vec<InverseMass> = bodies.iter().map(InverseMass::of).collect();
    let mut sys = ContactSystem {
        contacts: contacts.to_vec(),
        info: Vec::with_capacity(contacts.len()),
        rows: Vec::new(),
        inv_mass,
        free_velocity,
        free_rate: Vec::new(),
        bias: Vec::new(),
        position_bias: Vec::new(),
        lo: Vec::new(),
        hi: Vec::new(),
        friction: Vec::new(),
        h,
        restitution_threshold: params.restitution_threshold,
    };
    let default_material = Material::default();
    let material = |k: usize| materials.get(k).unwrap_or(&default_material);
    for (c, ct) in contacts.iter().enumerate() {
        let pair = (&bodies[ct.body_a], &bodies[ct.body_b]);
        let (ma, mb) = (material(pair.0.material), material(pair.1.material));
        let mu = (ma.mu * mb.mu).sqrt();
        let restitution = ma.restitution.max(mb.restitution);
        add_contact(&mut sys, c, ct, pair, mu, restitution, params);
    }
    sys
}

/// The Jacobian row of `ct` along `dir` (from body a to body b), with a block per dynamic body.
fn jacobian_row(
    ct: &Contact,
    (ba, bb): (&RigidBody, &RigidBody),
    dir: Vector3<f64>,
    kind: RowKind,
) -> JacobianRow {
    let mut blocks = RowBlocks::EMPTY;
    if !ba.is_static {
        let ra = ct.point - ba.position;
        blocks.push(JacobianBlock {
            body: ct.body_a,
            linear: -dir,
            angular: -ra.cross(&dir),
        });
    }
    if !bb.is_static {
        let rb = ct.point - bb.position;
        blocks.push(JacobianBlock {
            body: ct.body_b,
            linear: dir,
            angular: rb.cross(&dir),
        });
    }
    JacobianRow { kind, blocks }
}

/// Contact `c`: its normal row with the restitution, gap and position terms, then its
/// friction rows for the friction model, then its [`ContactInfo`].
fn add_contact(
    sys: &mut ContactSystem,
    c: usize,
    ct: &Contact,
    pair: (&RigidBody, &RigidBody),
    mu: f64,
    restitution: f64,
    params: &BuilderParams,
) {
    let tangents = tangent_basis(&ct.normal);
    let normal_row = sys.rows.len();
    sys.rows.push(jacobian_row(
        ct,
        pair,
        ct.normal,
        RowKind::Normal { contact: c },
    ));
    let vn = sys.operator().row_dot(normal_row, &sys.free_velocity);
    let (bias, position_bias, bouncing) = normal_bias(ct, vn, restitution, params, sys.h);
    sys.free_rate.push(vn);
    sys.bias.push(bias);
    sys.position_bias.push(position_bias);
    sys.lo.push(0.0);
    sys.hi.push(f64::INFINITY);

    let first = sys.rows.len();
    let slack_row = add_friction_rows(sys, c, ct, pair, mu, normal_row, tangents, params);
    let friction_end = slack_row.unwrap_or(sys.rows.len());
    for i in first..sys.rows.len() {
        let rate = sys.operator().row_dot(i, &sys.free_velocity);
        sys.free_rate.push(rate);
        sys.bias.push(0.0);
        sys.position_bias.push(0.0);
    }
    sys.info.push(ContactInfo {
        normal_row,
        friction_rows: first..friction_end,
        slack_row,
        slack_scale: sys.operator().diagonal(normal_row),
        mu,
        restitution,
        bouncing,
        tangents,
    });
}

/// The normal row's `(bias, position_bias, bouncing)`: Newton's restitution when the contact
/// closes faster than the threshold, else the speculative gap term for an open contact, else
/// the position correction.
fn normal_bias(
    ct: &Contact,
    vn: f64,
    restitution: f64,
    params: &BuilderParams,
    h: f64,
) -> (f64, f64, bool) {
    let closes = ct.dist <= 0.0 || ct.dist + h * vn <= 0.0;
    let bouncing = restitution > 0.0 && closes && vn < -params.restitution_threshold;
    let position_term = params.baumgarte / h * (ct.dist + params.slop).min(0.0);
    let (bias, position_bias) = if bouncing {
        (restitution * vn, 0.0)
    } else if ct.dist > 0.0 {
        (ct.dist / h, 0.0)
    } else {
        match params.position_correction {
            PositionCorrection::None => (0.0, 0.0),
            PositionCorrection::Baumgarte => (position_term, 0.0),
            PositionCorrection::Split => (0.0, position_term),
        }
    };
    (bias, position_bias, bouncing)
}

/// The friction rows of contact `c`, only when needed: two tangent rows (box, cone) or the
/// pyramid's directions and slack row. Returns the slack row.
#[allow(clippy::too_many_arguments)]
fn add_friction_rows(
    sys: &mut ContactSystem,
    c: usize,
    ct: &Contact,
    pair: (&RigidBody, &RigidBody),
    mu: f64,
    normal_row: usize,
    tangents: (Vector3<f64>, Vector3<f64>),
    params: &BuilderParams,
) -> Option<usize> {
    // The cone keeps its three rows when mu = 0 (the cone is then the normal ray), so that
    // every contact of a cone problem is a (normal, tangent, tangent) triple.
    let tangent_rows = match params.friction_model {
        FrictionModel::Cone => true,
        FrictionModel::Box => mu > 0.0,
        FrictionModel::None | FrictionModel::Pyramid { .. } => false,
    };
    if tangent_rows {
        for (index, t) in [tangents.0, tangents.1].into_iter().enumerate() {
            let i = sys.rows.len();
            sys.rows.push(jacobian_row(
                ct,
                pair,
                t,
                RowKind::Tangent { contact: c, index },
            ));
            sys.friction.push(FrictionRow {
                row: i,
                normal: normal_row,
                mu,
            });
            sys.lo.push(f64::NEG_INFINITY);
            sys.hi.push(f64::INFINITY);
        }
    }
    let (FrictionModel::Pyramid { directions }, true) = (params.friction_model, mu > 0.0) else {
        return None;
    };
    let k = directions.max(3);
    for index in 0..k {
        let th = 2.0 * std::f64::consts::PI * index as f64 / k as f64;
        let d = tangents.0 * th.cos() + tangents.1 * th.sin();
        sys.rows.push(jacobian_row(
            ct,
            pair,
            d,
            RowKind::Direction { contact: c, index },
        ));
        sys.lo.push(0.0);
        sys.hi.push(f64::INFINITY);
    }
    let slack_row = sys.rows.len();
    sys.rows.push(JacobianRow {
        kind: RowKind::Slack { contact: c },
        blocks: RowBlocks::EMPTY,
    });
    sys.lo.push(0.0);
    sys.hi.push(f64::INFINITY);
    Some(slack_row)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_basis_is_orthonormal_and_right_handed() {
        for n in [
            Vector3::z(),
            -Vector3::x(),
            Vector3::new(1.0, 2.0, -3.0).normalize(),
        ] {
            let (t1, t2) = tangent_basis(&n);
            assert!((t1.norm() - 1.0).abs() < 1e-14);
            assert!(t1.dot(&n).abs() < 1e-14 && t2.dot(&n).abs() < 1e-14);
            assert!((t1.cross(&t2) - n).norm() < 1e-14);
        }
    }
}

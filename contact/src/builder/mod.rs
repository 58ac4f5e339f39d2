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
//!   [`ConeProblem`](lcpbench_solvers::ConeProblem) with `W = A`, `q = b`); the friction rows
//!   are kept so that the box-friction LCP of the same rows is at hand (export, the box
//!   residual);
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
//!
//! This module holds the contact system, its rows and its construction from contacts
//! ([`build`]); the rest lives in modules of its own, re-exported here:
//!
//! * `params`: [`Material`], [`FrictionModel`], [`PositionCorrection`], [`BuilderParams`];
//! * `island`: the partition into islands ([`ContactSystem::islands`], [`Partition`]);
//! * `problem`: the solver problems of the system or of an island
//!   ([`ContactSystem::problem_in`], [`ContactSystem::cone_problem`], [`DelassusForm`]);
//! * `assembly`: `J`, the sparse `A` with the pyramid coupling, the factors, the size limit
//!   ([`MAX_DELASSUS_ENTRIES`]);
//! * `operator`: the matrix-free [`DelassusOperator`];
//! * `warm_start`: the [`WarmStartCache`] and [`ContactSystem::warm_start`].

mod assembly;
mod island;
mod operator;
mod params;
mod problem;
mod warm_start;

pub use assembly::{DENSE_ROWS, MAX_DELASSUS_ENTRIES};
pub use island::{Island, Partition};
pub use operator::DelassusOperator;
pub use params::{
    BuilderParams, FrictionModel, Material, PositionCorrection, MAX_PYRAMID_DIRECTIONS,
};
pub use problem::DelassusForm;
pub use warm_start::{ContactImpulse, KeyHasher, WarmStartCache};

use crate::body::RigidBody;
use crate::collision::Contact;
use crate::joint::Joint;
use lcpbench_solvers::FrictionRow;
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

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
    /// Equality row `index` of joint `joint` (bounds `(−∞, ∞)`, [`crate::joint`]).
    Joint {
        /// Joint index (in the world's joint list).
        joint: usize,
        /// Which of the joint's rows.
        index: usize,
    },
}

/// The rows of one joint in a [`ContactSystem`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JointRows {
    /// Joint index (in the world's joint list).
    pub joint: usize,
    /// Its equality rows, contiguous, after every contact's rows.
    pub rows: std::ops::Range<usize>,
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
    /// Position error per row at the step's start: the gap `dist` of a normal row (negative
    /// when penetrating), the constraint error of a joint row, 0 on friction and slack rows
    /// (the substepping solvers' `C₀`).
    pub position_error: Vec<f64>,
    /// Lower bounds (friction rows: ignored).
    pub lo: Vec<f64>,
    /// Upper bounds (friction rows: ignored).
    pub hi: Vec<f64>,
    /// Box-friction rows.
    pub friction: Vec<FrictionRow>,
    /// The joints with rows in the system (joints between two static sides have none), their
    /// equality rows after the contacts' rows.
    pub joints: Vec<JointRows>,
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

    /// True when the system has no friction and no joint rows. Its normal rows always have
    /// `lo = 0`, `hi = ∞`, so this is the test for a standard LCP; the bounds are not inspected.
    pub fn is_standard(&self) -> bool {
        self.friction.is_empty() && self.joints.is_empty()
    }

    /// The rows of contact `c` (normal, friction, slack), contiguous.
    pub fn contact_rows(&self, c: usize) -> std::ops::Range<usize> {
        let end = self
            .info
            .get(c + 1)
            .map_or(self.joint_rows_start(), |i| i.normal_row);
        self.info[c].normal_row..end
    }

    /// The first joint row: every row before it belongs to a contact.
    pub fn joint_rows_start(&self) -> usize {
        self.joints.first().map_or(self.n(), |j| j.rows.start)
    }

    /// Number of joint (equality) rows.
    pub fn joint_row_count(&self) -> usize {
        self.n() - self.joint_rows_start()
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
/// and their free velocities `u*` (no joints: [`build_with_joints`]).
pub fn build(
    bodies: &[RigidBody],
    materials: &[Material],
    contacts: &[Contact],
    free_velocity: Vec<BodyVelocity>,
    params: &BuilderParams,
    h: f64,
) -> ContactSystem {
    build_with_joints(bodies, materials, contacts, &[], free_velocity, params, h)
}

/// [`build`] with the equality rows of `joints` after the contacts' rows.
pub fn build_with_joints(
    bodies: &[RigidBody],
    materials: &[Material],
    contacts: &[Contact],
    joints: &[Joint],
    free_velocity: Vec<BodyVelocity>,
    params: &BuilderParams,
    h: f64,
) -> ContactSystem {
    let inv_mass: Vec<InverseMass> = bodies.iter().map(InverseMass::of).collect();
    // The contacts' rows, allocated once (joint rows, few, are pushed past them).
    let (rows, friction) = contact_rows(params.friction_model);
    let n = rows * contacts.len();
    let mut sys = ContactSystem {
        contacts: contacts.to_vec(),
        info: Vec::with_capacity(contacts.len()),
        rows: Vec::with_capacity(n),
        inv_mass,
        free_velocity,
        free_rate: Vec::with_capacity(n),
        bias: Vec::with_capacity(n),
        position_bias: Vec::with_capacity(n),
        position_error: Vec::with_capacity(n),
        lo: Vec::with_capacity(n),
        hi: Vec::with_capacity(n),
        friction: Vec::with_capacity(friction * contacts.len()),
        joints: Vec::new(),
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
    for (k, joint) in joints.iter().enumerate() {
        add_joint(&mut sys, k, joint, bodies, params);
    }
    sys
}

/// Rows per contact with friction under `model`, and how many of them are box-friction rows
/// ([`FrictionRow`]): a normal row, then two tangent rows (`box`, `cone`) or `k` directions and
/// a slack row (`pyramid-k`, whose rows are not box-friction rows).
fn contact_rows(model: FrictionModel) -> (usize, usize) {
    match model {
        FrictionModel::None => (1, 0),
        FrictionModel::Box | FrictionModel::Cone => (3, 2),
        FrictionModel::Pyramid { directions } => (directions + 2, 0),
    }
}

/// Joint `k`'s equality rows: one per scalar constraint, bounds `(−∞, ∞)`, the position error
/// in the bias (Baumgarte) or the position bias (split impulses), without slop. A joint whose
/// two sides are static (or the world) has no rows.
fn add_joint(
    sys: &mut ContactSystem,
    k: usize,
    joint: &Joint,
    bodies: &[RigidBody],
    params: &BuilderParams,
) {
    let dynamic = joint.bodies.map(|s| s.filter(|&b| !bodies[b].is_static));
    if dynamic.iter().all(Option::is_none) {
        return;
    }
    let start = sys.rows.len();
    for (index, c) in joint.constraints(bodies).into_iter().enumerate() {
        let mut blocks = RowBlocks::EMPTY;
        for (side, &(linear, angular)) in dynamic.iter().zip(&c.sides) {
            if let Some(body) = *side {
                blocks.push(JacobianBlock {
                    body,
                    linear,
                    angular,
                });
            }
        }
        let i = sys.rows.len();
        sys.rows.push(JacobianRow {
            kind: RowKind::Joint { joint: k, index },
            blocks,
        });
        let rate = sys.operator().row_dot(i, &sys.free_velocity);
        let term = params.baumgarte / sys.h * c.error;
        let (bias, position_bias) = match params.position_correction {
            PositionCorrection::None => (0.0, 0.0),
            PositionCorrection::Baumgarte => (term, 0.0),
            PositionCorrection::Split => (0.0, term),
        };
        sys.free_rate.push(rate);
        sys.bias.push(bias);
        sys.position_bias.push(position_bias);
        sys.position_error.push(c.error);
        sys.lo.push(f64::NEG_INFINITY);
        sys.hi.push(f64::INFINITY);
    }
    sys.joints.push(JointRows {
        joint: k,
        rows: start..sys.rows.len(),
    });
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
    sys.position_error.push(ct.dist);
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
        sys.position_error.push(0.0);
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

/// True when Newton's restitution law applies to a contact of gap `dist` and normal velocity
/// `vn` (negative when closing) over a step of `h`: it has restitution, it closes within the
/// step and it approaches faster than `threshold`. The one bounce rule of the builder and of
/// the body-level solvers.
pub fn bounces(dist: f64, vn: f64, restitution: f64, threshold: f64, h: f64) -> bool {
    let closes = dist <= 0.0 || dist + h * vn <= 0.0;
    restitution > 0.0 && closes && vn < -threshold
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
    let bouncing = bounces(ct.dist, vn, restitution, params.restitution_threshold, h);
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

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
use faer::Mat;
use lcpbench_solvers::{FrictionRow, Problem, ProblemError};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use std::collections::HashMap;

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
#[derive(Debug, Clone, Copy, PartialEq)]
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
    pub blocks: Vec<JacobianBlock>,
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
    map: HashMap<u64, ContactImpulse>,
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

    /// True when the rows form a standard LCP (no box-friction rows, all `lo = 0`, `hi = ∞`).
    pub fn is_standard(&self) -> bool {
        self.friction.is_empty()
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

    /// The dense LCP matrix: `A = J M⁻¹ Jᵀ`, assembled body block by body block (cost
    /// `Σ_bodies rows(body)²`), plus the pyramid coupling entries. The slack row and column of
    /// a pyramid contact are scaled by `s = A_nn` (entries `s`, `s mu`, `−s`): the variable is
    /// `γ / s` and its row `s (mu f_n − Σ β)`, the same complementarity problem with entries of
    /// one magnitude, which pivoting solvers need.
    pub fn delassus(&self) -> Mat<f64> {
        let n = self.n();
        let mut a = Mat::zeros(n, n);
        let mut per_body: Vec<Vec<(usize, usize)>> = vec![Vec::new(); self.inv_mass.len()];
        for (i, row) in self.rows.iter().enumerate() {
            for (s, blk) in row.blocks.iter().enumerate() {
                per_body[blk.body].push((i, s));
            }
        }
        for (k, list) in per_body.iter().enumerate() {
            let m = &self.inv_mass[k];
            let responses: Vec<BodyVelocity> = list
                .iter()
                .map(|&(j, s)| m.response(&self.rows[j].blocks[s], 1.0))
                .collect();
            for &(i, si) in list {
                let bi = &self.rows[i].blocks[si];
                for (&(j, _), r) in list.iter().zip(&responses) {
                    a[(i, j)] += bi.dot(r);
                }
            }
        }
        for info in &self.info {
            if let Some(s) = info.slack_row {
                let scale = info.slack_scale;
                a[(s, info.normal_row)] = scale * info.mu;
                for d in info.friction_rows.clone() {
                    a[(d, s)] = scale;
                    a[(s, d)] = -scale;
                }
            }
        }
        a
    }

    /// The step's LCP as a solver [`Problem`].
    pub fn problem(&self) -> Result<Problem, ProblemError> {
        Problem::boxed(
            self.delassus(),
            self.b(),
            self.lo.clone(),
            self.hi.clone(),
            self.friction.clone(),
        )
    }

    /// The normal rows only, with `b = J u + position_bias` for a split-impulse position solve
    /// given velocities `u`: `(A_nn, b_p, normal row indices)`.
    pub fn position_problem(&self, u: &[BodyVelocity]) -> Option<(Problem, Vec<usize>)> {
        let normals: Vec<usize> = self.info.iter().map(|c| c.normal_row).collect();
        if normals.iter().all(|&i| self.position_bias[i] >= 0.0) {
            return None;
        }
        let op = self.operator();
        let a_full = self.delassus();
        let a = Mat::from_fn(normals.len(), normals.len(), |i, j| {
            a_full[(normals[i], normals[j])]
        });
        let b = normals
            .iter()
            .map(|&i| op.row_dot(i, u) + self.position_bias[i])
            .collect();
        Problem::lcp(a, b).ok().map(|p| (p, normals))
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
    };
    let default_material = Material::default();
    let material = |k: usize| materials.get(k).unwrap_or(&default_material);
    for (c, ct) in contacts.iter().enumerate() {
        let (ba, bb) = (&bodies[ct.body_a], &bodies[ct.body_b]);
        let (ma, mb) = (material(ba.material), material(bb.material));
        let mu = (ma.mu * mb.mu).sqrt();
        let restitution = ma.restitution.max(mb.restitution);
        let n = ct.normal;
        let ra = ct.point - ba.position;
        let rb = ct.point - bb.position;
        let row_for = |dir: Vector3<f64>, kind: RowKind| {
            let mut blocks = Vec::with_capacity(2);
            if !ba.is_static {
                blocks.push(JacobianBlock {
                    body: ct.body_a,
                    linear: -dir,
                    angular: -ra.cross(&dir),
                });
            }
            if !bb.is_static {
                blocks.push(JacobianBlock {
                    body: ct.body_b,
                    linear: dir,
                    angular: rb.cross(&dir),
                });
            }
            JacobianRow { kind, blocks }
        };
        let tangents = tangent_basis(&n);

        // Normal row.
        let normal_row = sys.rows.len();
        sys.rows.push(row_for(n, RowKind::Normal { contact: c }));
        let vn = sys.operator().row_dot(normal_row, &sys.free_velocity);
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
        sys.free_rate.push(vn);
        sys.bias.push(bias);
        sys.position_bias.push(position_bias);
        sys.lo.push(0.0);
        sys.hi.push(f64::INFINITY);

        // Friction rows, only when needed.
        let first = sys.rows.len();
        let mut slack_row = None;
        match params.friction_model {
            _ if mu == 0.0 => {}
            FrictionModel::None => {}
            FrictionModel::Box => {
                for (index, t) in [tangents.0, tangents.1].into_iter().enumerate() {
                    let i = sys.rows.len();
                    sys.rows
                        .push(row_for(t, RowKind::Tangent { contact: c, index }));
                    sys.friction.push(FrictionRow {
                        row: i,
                        normal: normal_row,
                        mu,
                    });
                    sys.lo.push(f64::NEG_INFINITY);
                    sys.hi.push(f64::INFINITY);
                }
            }
            FrictionModel::Pyramid { directions } => {
                let k = directions.max(3);
                for index in 0..k {
                    let th = 2.0 * std::f64::consts::PI * index as f64 / k as f64;
                    let d = tangents.0 * th.cos() + tangents.1 * th.sin();
                    sys.rows
                        .push(row_for(d, RowKind::Direction { contact: c, index }));
                    sys.lo.push(0.0);
                    sys.hi.push(f64::INFINITY);
                }
                slack_row = Some(sys.rows.len());
                sys.rows.push(JacobianRow {
                    kind: RowKind::Slack { contact: c },
                    blocks: Vec::new(),
                });
                sys.lo.push(0.0);
                sys.hi.push(f64::INFINITY);
            }
        }
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
    sys
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

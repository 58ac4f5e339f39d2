//! `avg`, averaged impulses: one impulse per body pair, at the pair's averaged contact point
//! along its averaged normal.
//!
//! Rigid-body course material gives three ways to resolve several contacts between two bodies:
//! collide them one at a time (micro-impulses, Mirtich 1996: `body-micro`), solve them
//! simultaneously (the LCP, Baraff 1994: the matrix solvers), or replace them by one contact.
//! This is the third. For the contacts `c ∈ C` of a body pair, with points `p_c`, unit normals
//! `n_c` and `k = |C|`,
//!
//! ```text
//! p̄ = (1/k) Σ p_c,    n̄ = Σ n_c / ‖Σ n_c‖,    (t̄₁, t̄₂) = tangent_basis(n̄),
//! ```
//!
//! and the pair gets one normal impulse `λ_n ≥ 0` along `n̄` at `p̄` and, with box friction, one
//! friction impulse `λ_t₁ t̄₁ + λ_t₂ t̄₂` there, each `|λ_tⱼ| ≤ mu λ_n` (the box of the
//! `box` model, aligned with the averaged tangents; `mu` is the mean of the pair's
//! coefficients). The velocity target of the averaged contact is Newton's law
//! `v̄⁺ = −e v̄⁻` when the pair closes (`min_c dist_c + h v̄ ≤ 0`) faster than the bounce
//! threshold, with `e` the largest restitution of the pair; otherwise the mean of the pair's
//! biases (gap, Baumgarte), a bouncing contact counting zero, as in `si`'s contact phase.
//!
//! The averaged contacts are solved exactly as `si` solves contacts: the system is rewritten
//! with each pair's first contact standing for the averaged contact (its rows carry the
//! averaged Jacobian rows, the pair's other contacts get empty rows, rows that belong to no
//! contact are kept as they are) and given to `si`'s sweeps. So the sweeps go Gauss–Seidel
//! over pairs (sequential restitution sweeps, then projected Gauss–Seidel on accumulated pair
//! impulses), and the stopping rule, the `Stalled` rule on stagnation, the time budget and the
//! warm start are `si`'s. The lever arms `p̄ − x` of the averaged rows come from the system
//! alone: each row of a contact has `angular = (p − x) × linear` on a body, and the centre of
//! mass `x` is the least-squares solution of those equations (of least norm: when every row of
//! the pair shares one direction, the part of `x` along it is undetermined and does not enter
//! the averaged rows).
//!
//! The answer is returned per row of the step's system, so that the shared residual of the
//! step's LCP measures it: each contact of the pair gets an equal share `λ_n / k` on its normal
//! row, and the share `(λ_t₁ t̄₁ + λ_t₂ t̄₂) / k` of the friction impulse projected onto its
//! own tangent rows. The shares reproduce the pair's net impulse and torque exactly only when
//! the pair's normals agree (then every contact's tangents are `t̄₁, t̄₂`, and
//! `Σ (p_c − x) × (λ/k) = (p̄ − x) × λ`). When they do not, the step applies the shares: a net
//! normal impulse shortened to `‖Σ n_c‖ / k` of `λ_n` and turned to `Σ n_c`, a friction impulse
//! without its part along each `n_c`. The residual shows it. The warm start goes the other
//! way: the sum of the pair's normal impulses, and the sum of its tangential impulses projected
//! onto `t̄₁, t̄₂`.
//!
//! Cost: building the averaged contacts is `O(rows)` with a 3 × 3 least-squares solve per
//! dynamic body of a pair; a sweep is `O(1)` per pair (one normal and two tangent rows on at
//! most two bodies). It takes the frictionless and box friction models, as `si`; the pyramid
//! and the cone are refused before a step reaches it (friction rows of any other layout are
//! left without impulse here), and so are steps with joints (`avg` resolves contacts only). A
//! pair whose normals cancel (`‖Σ n_c‖ ≤ 1e-9 k`) has no averaged normal and gets no impulse.
//!
//! # Failure modes
//!
//! The averaged contact is exact only when the pair's contact region is convex, its contacts
//! share one normal, and the averaged point lies where the support actually is (where the
//! simultaneous solution puts the centre of pressure). Otherwise:
//!
//! * **Separated supports.** A box resting on two separated supports of one body: `p̄` lies
//!   between them over empty space. A single impulse there gives the wrong torque as soon as
//!   the load is off-centre: the box tilts until the contacts on the unloaded side open past
//!   the prediction distance and `p̄` moves under the load. With two support bodies, each pair
//!   is held at the middle of its face only, so the box rests on two points, and a load off
//!   the line through them tilts it the same way (`bench_scenes/avg_two_supports.toml`).
//! * **Off-centre loads and friction.** More generally a pair whose load needs its centre of
//!   pressure anywhere but `p̄` (a load placed off-centre, a friction impulse at the base of a
//!   sliding box that pitches it) turns, and only its penetration and the opened contacts stop
//!   the turn.
//! * **Non-convex meshes.** The contacts of one pair on several faces of a non-convex mesh
//!   have different normals: `n̄` is none of them, so the averaged contact pushes along a
//!   direction no face pushes in, and a body sinks into one face and slides off another or
//!   tilts (`bench_scenes/avg_nonconvex.toml`); the shares then shorten the net normal
//!   impulse too (above).
//!
//! References: B. Mirtich, *Impulse-based dynamic simulation of rigid body systems*, PhD
//! thesis, UC Berkeley 1996 (the sequential alternative); D. Baraff, *Fast contact force
//! computation for nonpenetrating rigid bodies*, SIGGRAPH 1994 (the simultaneous answer it
//! approximates).

use super::{sequential_impulses, BodySolver, BodySolverKind, BodySweep};
use crate::builder::{bounces, tangent_basis, ContactSystem, JacobianBlock, RowBlocks};
use lcpbench_solvers::Settings;
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;

/// Averaged impulses (`avg`). No parameters beyond the shared [`Settings`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AveragedImpulse;

/// The registry's entry of `avg`.
pub static AVG: lcpbench_solvers::registry::SolverEntry = lcpbench_solvers::registry::SolverEntry {
    name: "avg",
    summary: "averaged impulses: one contact per body pair at the averaged point and normal, \
                 swept as si",
    problem_classes: "scenes only; frictionless and box friction (no pyramid, no cone), no joints; one \
                 impulse per body pair at the averaged point along the averaged normal, swept as si, \
                 warm-startable; exact only for convex single-normal contact regions: separated \
                 supports, off-centre loads and non-convex meshes tilt or sink",
    iteration_unit: "sweeps over the contacts",
    iterative: true,
    relaxation: None,
    params: &[],
    make: lcpbench_solvers::registry::Make::Body(&crate::body_solvers::BodyMake {
        make: |_params| Box::new(AveragedImpulse),
        takes_joints: false,
        substeps: false,
    }),
};

impl BodySolver for AveragedImpulse {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::AveragedImpulse
    }
    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
        let warm = settings.warm_start.as_deref().unwrap_or(&[]);
        let averaged = Averaged::of(system);
        let out = sequential_impulses(&averaged.system, &averaged.gather(system, warm), settings);
        BodySweep {
            f: averaged.shares(system, &out.f),
            warm: averaged.shares(system, &out.warm),
            ..out
        }
    }
}

/// Largest `‖Σ n_c‖ / k` of a pair whose normals are taken to cancel.
const CANCELLING_NORMALS: f64 = 1e-9;

/// The step's system with each body pair's contacts replaced by their averaged contact.
#[derive(Debug, Clone)]
struct Averaged {
    /// The rewritten system: the same rows, the averaged contact in the rows of each pair's
    /// first contact, the pair's other contact rows empty, one contact per pair.
    system: ContactSystem,
    /// For each contact of `system`, the pair's contacts in the step's system (the first is
    /// the one whose rows it took).
    pairs: Vec<Vec<usize>>,
}

impl Averaged {
    fn of(system: &ContactSystem) -> Self {
        let mut groups: BTreeMap<(usize, usize), Vec<usize>> = BTreeMap::new();
        for (c, ct) in system.contacts.iter().enumerate() {
            groups.entry((ct.body_a, ct.body_b)).or_default().push(c);
        }
        let mut out = system.clone();
        out.contacts.clear();
        out.info.clear();
        for c in 0..system.contacts.len() {
            for i in system.contact_rows(c) {
                out.rows[i].blocks = RowBlocks::EMPTY;
                out.free_rate[i] = 0.0;
                out.bias[i] = 0.0;
                out.position_bias[i] = 0.0;
            }
        }
        let mut pairs = Vec::new();
        for members in groups.into_values() {
            if average_pair(system, &members, &mut out) {
                pairs.push(members);
            }
        }
        Self { system: out, pairs }
    }

    /// The warm start of the averaged contacts from one of the step's system (empty when
    /// `warm` is not one): per pair the sum of its normal impulses and of its tangential ones
    /// projected onto the averaged tangents; rows of no contact as given.
    fn gather(&self, system: &ContactSystem, warm: &[f64]) -> Vec<f64> {
        if warm.len() != system.n() {
            return Vec::new();
        }
        let mut out = warm.to_vec();
        for c in 0..system.contacts.len() {
            system.contact_rows(c).for_each(|i| out[i] = 0.0);
        }
        for (info, members) in self.system.info.iter().zip(&self.pairs) {
            let mut normal = 0.0;
            let mut tangent = Vector3::zeros();
            for &c in members {
                let imp = system.contact_impulse(c, warm);
                normal += imp.normal;
                tangent += imp.tangent;
            }
            out[info.normal_row] = normal;
            let (t1, t2) = info.tangents;
            for (r, t) in info.friction_rows.clone().zip([t1, t2]) {
                out[r] = tangent.dot(&t);
            }
        }
        out
    }

    /// The impulse per row of the step's system from one of the averaged contacts: equal
    /// shares of each pair's normal impulse on its contacts' normal rows, equal shares of its
    /// friction impulse projected onto their tangent rows; rows of no contact as given.
    fn shares(&self, system: &ContactSystem, f: &[f64]) -> Vec<f64> {
        let mut out = f.to_vec();
        for c in 0..system.contacts.len() {
            system.contact_rows(c).for_each(|i| out[i] = 0.0);
        }
        for (info, members) in self.system.info.iter().zip(&self.pairs) {
            let k = members.len() as f64;
            let normal = f[info.normal_row] / k;
            let (t1, t2) = info.tangents;
            let friction = info
                .friction_rows
                .clone()
                .zip([t1, t2])
                .fold(Vector3::zeros(), |s, (r, t)| s + t * f[r])
                / k;
            for &c in members {
                let ci = &system.info[c];
                out[ci.normal_row] = normal;
                if box_friction(system, c) {
                    for (j, r) in ci.friction_rows.clone().enumerate() {
                        out[r] = friction.dot(&system.friction_direction(c, j));
                    }
                }
            }
        }
        out
    }
}

/// True when contact `c` has the two tangent rows of box friction.
fn box_friction(system: &ContactSystem, c: usize) -> bool {
    let info = &system.info[c];
    info.friction_rows.len() == 2 && info.slack_row.is_none()
}

/// Writes the averaged contact of the pair `members` into the rows of its first contact in
/// `out`, and appends its contact and info. False when the pair's normals cancel.
fn average_pair(system: &ContactSystem, members: &[usize], out: &mut ContactSystem) -> bool {
    let k = members.len() as f64;
    let first = system.contacts[members[0]];
    let normal_sum: Vector3<f64> = members.iter().map(|&c| system.contacts[c].normal).sum();
    if normal_sum.norm() <= CANCELLING_NORMALS * k {
        return false;
    }
    let n = normal_sum.normalize();
    let tangents = tangent_basis(&n);
    // Offsets from the first contact's point keep the lever arms accurate far from the origin.
    let offset = members
        .iter()
        .map(|&c| system.contacts[c].point - first.point)
        .sum::<Vector3<f64>>()
        / k;
    let friction = members.iter().all(|&c| box_friction(system, c));
    let directions: &[Vector3<f64>] = if friction {
        &[n, tangents.0, tangents.1]
    } else {
        &[n]
    };
    let lead = &system.info[members[0]];
    let normal_row = lead.normal_row;
    let friction_rows = if friction {
        lead.friction_rows.clone()
    } else {
        normal_row + 1..normal_row + 1
    };
    let rows = averaged_rows(system, members, offset, directions);
    for (i, blocks) in std::iter::once(normal_row)
        .chain(friction_rows.clone())
        .zip(rows)
    {
        out.rows[i].blocks = blocks;
        out.free_rate[i] = out.operator().row_dot(i, &system.free_velocity);
    }
    let dist = members
        .iter()
        .map(|&c| system.contacts[c].dist)
        .fold(f64::INFINITY, f64::min);
    let restitution = members
        .iter()
        .map(|&c| system.info[c].restitution)
        .fold(0.0, f64::max);
    let vn = out.free_rate[normal_row];
    let bouncing = bounces(
        dist,
        vn,
        restitution,
        system.restitution_threshold,
        system.h,
    );
    out.bias[normal_row] = if bouncing {
        restitution * vn
    } else {
        mean(members, |c| {
            let info = &system.info[c];
            if info.bouncing {
                0.0
            } else {
                system.bias[info.normal_row]
            }
        })
    };
    out.position_bias[normal_row] =
        mean(members, |c| system.position_bias[system.info[c].normal_row]);
    out.contacts.push(crate::collision::Contact {
        point: first.point + offset,
        normal: n,
        dist,
        ..first
    });
    out.info.push(crate::builder::ContactInfo {
        normal_row,
        friction_rows,
        slack_row: None,
        slack_scale: out.operator().diagonal(normal_row),
        mu: mean(members, |c| system.info[c].mu),
        restitution,
        bouncing,
        tangents,
    });
    true
}

/// The Jacobian rows of the averaged contact of `members`, one per direction (the normal, then
/// the tangents), at the averaged point `first point + offset`: on body a `[−d, −(p̄ − x_a) × d]`,
/// on body b `[d, (p̄ − x_b) × d]`, for the dynamic ones.
fn averaged_rows(
    system: &ContactSystem,
    members: &[usize],
    offset: Vector3<f64>,
    directions: &[Vector3<f64>],
) -> [RowBlocks; 3] {
    let first = system.contacts[members[0]];
    let mut rows = [RowBlocks::EMPTY; 3];
    for (body, sign) in [(first.body_a, -1.0), (first.body_b, 1.0)] {
        let Some(centre) = centre_of_mass(system, members, body, first.point.coords) else {
            continue;
        };
        let lever = offset - centre;
        for (blocks, d) in rows.iter_mut().zip(directions) {
            let linear = d * sign;
            blocks.push(JacobianBlock {
                body,
                linear,
                angular: lever.cross(&linear),
            });
        }
    }
    rows
}

/// The mean of `value` over the pair's contacts.
fn mean(members: &[usize], value: impl Fn(usize) -> f64) -> f64 {
    members.iter().map(|&c| value(c)).sum::<f64>() / members.len() as f64
}

/// The centre of mass `x` of `body`, relative to `origin`, from the pair's Jacobian rows; `None`
/// when `body` has no block in them (it is static).
///
/// A row's block on the body is `(linear, angular)` with `angular = (p − x) × linear`, so
/// `linear × (x − o) = angular − (p − o) × linear`: three equations of rank two per row. The
/// normal equations `Σ (‖l‖² I − l lᵀ) z = Σ (angular − (p − o) × l) × l` are solved with the
/// pseudo-inverse: the least-norm `z` when every row shares one direction.
fn centre_of_mass(
    system: &ContactSystem,
    members: &[usize],
    body: usize,
    origin: Vector3<f64>,
) -> Option<Vector3<f64>> {
    let mut m = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    let mut found = false;
    for &c in members {
        let p = system.contacts[c].point.coords - origin;
        for i in system.contact_rows(c) {
            for b in system.rows[i].blocks.iter().filter(|b| b.body == body) {
                let l = b.linear;
                m += Matrix3::identity() * l.norm_squared() - l * l.transpose();
                rhs += (b.angular - p.cross(&l)).cross(&l);
                found = true;
            }
        }
    }
    if !found {
        return None;
    }
    let eps = 1e-9 * m.trace();
    let inverse = m.pseudo_inverse(eps).unwrap_or_else(|_| Matrix3::zeros());
    Some(inverse * rhs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builder::{self, BuilderParams, FrictionModel, Material};
    use crate::collision::Contact;
    use crate::{MassSpec, RigidBody, Shape};
    use nalgebra::{Point3, UnitQuaternion};

    fn cuboid(pos: [f64; 3], is_static: bool) -> RigidBody {
        RigidBody::new(
            "b",
            Shape::cuboid(Vector3::new(0.5, 0.4, 0.3)).unwrap(),
            MassSpec::Density(700.0),
            Point3::from(pos),
            UnitQuaternion::from_euler_angles(0.2, -0.1, 0.4),
            Vector3::new(0.3, -0.2, -1.0),
            Vector3::new(0.5, 1.0, -0.2),
            0,
            is_static,
        )
        .unwrap()
    }

    fn contact(point: [f64; 3], normal: Vector3<f64>, key: u64) -> Contact {
        Contact {
            body_a: 0,
            body_b: 1,
            point: Point3::from(point),
            normal: normal.normalize(),
            dist: 0.0,
            key,
        }
    }

    fn system(contacts: &[Contact], model: FrictionModel) -> (Vec<RigidBody>, ContactSystem) {
        let bodies = vec![
            cuboid([0.1, -0.2, -0.3], false),
            cuboid([0.4, 0.3, 0.5], false),
        ];
        let params = BuilderParams {
            friction_model: model,
            ..BuilderParams::default()
        };
        let materials = [Material {
            name: "m".into(),
            mu: 0.5,
            restitution: 0.0,
        }];
        let free = builder::free_velocities(&bodies, &Vector3::new(0.0, 0.0, -9.81), 0.01);
        let sys = builder::build(&bodies, &materials, contacts, free, &params, 0.01);
        (bodies, sys)
    }

    #[test]
    fn centre_of_mass_is_recovered_from_the_rows() {
        // Two normals, no friction rows: the rows determine the centre fully.
        let contacts = [
            contact([0.3, 0.1, 0.0], Vector3::z(), 1),
            contact([0.2, 0.0, 0.1], Vector3::new(1.0, 0.0, 1.0), 2),
        ];
        let (bodies, sys) = system(&contacts, FrictionModel::None);
        let o = contacts[0].point.coords;
        for body in [0, 1] {
            let x = centre_of_mass(&sys, &[0, 1], body, o).unwrap();
            let err = (x - (bodies[body].position.coords - o)).norm();
            assert!(err < 1e-12, "body {body}: error {err:e}");
        }
    }

    #[test]
    fn shares_reproduce_the_pair_impulse_when_normals_agree() {
        let n = Vector3::new(0.1, 0.2, 1.0);
        let contacts = [
            contact([0.3, 0.1, 0.0], n, 1),
            contact([-0.2, 0.4, 0.05], n, 2),
            contact([0.1, -0.3, -0.02], n, 3),
        ];
        let (_, sys) = system(&contacts, FrictionModel::Box);
        let averaged = Averaged::of(&sys);
        assert_eq!(averaged.system.info.len(), 1);
        // Any pair impulse: its momentum change equals that of the shares.
        let mut f = vec![0.0; sys.n()];
        let info = &averaged.system.info[0];
        f[info.normal_row] = 2.0;
        f[info.friction_rows.start] = 0.7;
        f[info.friction_rows.start + 1] = -0.4;
        let pair = averaged.system.momentum_change(&f);
        let shared = sys.momentum_change(&averaged.shares(&sys, &f));
        for (a, b) in pair.iter().zip(&shared) {
            assert!((a.0 - b.0).norm() < 1e-12 && (a.1 - b.1).norm() < 1e-12);
        }
        // Gathering the shares gives the pair impulse back.
        let back = averaged.gather(&sys, &averaged.shares(&sys, &f));
        for i in info.normal_row..info.friction_rows.end {
            assert!((back[i] - f[i]).abs() < 1e-12, "row {i}");
        }
    }

    #[test]
    fn cancelling_normals_leave_the_pair_out() {
        let contacts = [
            contact([0.0, 0.0, 0.0], Vector3::x(), 1),
            contact([1.0, 0.0, 0.0], -Vector3::x(), 2),
        ];
        let (_, sys) = system(&contacts, FrictionModel::None);
        let averaged = Averaged::of(&sys);
        assert!(averaged.system.info.is_empty());
        let f = averaged.shares(&sys, &vec![1.0; sys.n()]);
        assert!(f.iter().all(|&v| v == 0.0));
    }
}

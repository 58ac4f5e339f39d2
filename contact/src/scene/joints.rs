//! The `[[joints]]` tables: joints between named bodies (or a body and `"world"`), anchored at
//! world points of the initial poses.

use super::file::{finite_vector, JointFile};
use super::{readable, FieldError, MAX_COORDINATE};
use crate::body::RigidBody;
use crate::joint::{Joint, JointKind};
use nalgebra::{Point3, Vector3};

/// Largest number of joints a scene may have (four per body of the largest scene).
pub const MAX_JOINTS: usize = 4 * super::MAX_BODIES;

/// The name that stands for the world (a fixed frame) in a joint's `bodies`.
pub const WORLD: &str = "world";

/// The `[[joints]]` tables as joints of `bodies` at their initial poses. Every error names the
/// joint's entry and field.
pub(super) fn convert_joints(
    files: &[JointFile],
    bodies: &[RigidBody],
) -> Result<Vec<Joint>, FieldError> {
    if files.len() > MAX_JOINTS {
        return Err((
            "joints".into(),
            format!(
                "{} joints, more than the limit of {MAX_JOINTS}",
                files.len()
            ),
        ));
    }
    files
        .iter()
        .enumerate()
        .map(|(i, f)| convert_joint(i, f, bodies))
        .collect()
}

fn convert_joint(i: usize, f: &JointFile, bodies: &[RigidBody]) -> Result<Joint, FieldError> {
    let field = |k: &str| format!("joints[{i}].{k}");
    let err = |k: &str, m: String| Err((field(k), m));
    let Some(kind) = JointKind::from_name(&f.kind) else {
        let names: Vec<&str> = JointKind::ALL.iter().map(|k| k.name()).collect();
        return err(
            "type",
            format!(
                "unknown joint type \"{}\" (expected {})",
                f.kind,
                names.join(", ")
            ),
        );
    };
    let mut sides = [None; 2];
    for (side, name) in sides.iter_mut().zip(&f.bodies) {
        if name == WORLD {
            continue;
        }
        match bodies.iter().position(|b| &b.name == name) {
            Some(k) => *side = Some(k),
            None => {
                return err(
                    "bodies",
                    format!("no body named \"{name}\" (or \"{WORLD}\" for a fixed point)"),
                )
            }
        }
    }
    if sides[0] == sides[1] {
        return err(
            "bodies",
            format!(
                "a joint connects two different bodies, got \"{}\" twice",
                f.bodies[0]
            ),
        );
    }
    if sides.iter().all(|s| s.is_none_or(|k| bodies[k].is_static)) {
        return err(
            "bodies",
            "both sides are static (or the world): the joint would constrain nothing".into(),
        );
    }
    let point = |k: &str, p: [f64; 3]| -> Result<Point3<f64>, FieldError> {
        // The bound comes first, so a far anchor is refused with its limit; a vector within it
        // cannot overflow its length.
        if p.iter().all(|x| x.abs() <= MAX_COORDINATE) {
            Ok(Point3::from(finite_vector(&field(k), p)?))
        } else {
            Err((
                field(k),
                format!(
                    "every coordinate must be finite and within {} m",
                    readable(MAX_COORDINATE)
                ),
            ))
        }
    };
    let anchors = match (kind, f.anchor, f.anchors) {
        (JointKind::Distance, None, Some([a, b])) => [point("anchors", a)?, point("anchors", b)?],
        (JointKind::Distance, _, _) => {
            return err(
                "anchors",
                "a distance joint takes `anchors = [[x, y, z], [x, y, z]]`, one world point on \
                 each body (and no `anchor`)"
                    .into(),
            )
        }
        (_, Some(a), None) => [point("anchor", a)?; 2],
        (_, _, _) => {
            return err(
                "anchor",
                format!(
                    "a {} joint takes one world point `anchor = [x, y, z]` (and no `anchors`)",
                    kind.name()
                ),
            )
        }
    };
    let axis = match (kind, f.axis) {
        (JointKind::Hinge, Some(a)) => {
            let v = finite_vector("axis", a)?;
            if v.norm() <= 1e-9 {
                return err(
                    "axis",
                    "the hinge axis must be a finite, non-zero vector".into(),
                );
            }
            v
        }
        (JointKind::Hinge, None) => {
            return err(
                "axis",
                "a hinge joint needs its world `axis = [x, y, z]`".into(),
            )
        }
        (_, Some(_)) => {
            return err(
                "axis",
                format!("only hinge joints take an axis, not {} joints", kind.name()),
            )
        }
        (_, None) => Vector3::x(),
    };
    let name = f.name.clone().unwrap_or_else(|| format!("joint_{i}"));
    let mut joint = Joint::at_current_pose(name, kind, sides, anchors, axis, bodies);
    match (kind, f.length) {
        (JointKind::Distance, Some(l)) if l.is_finite() && (0.0..=MAX_COORDINATE).contains(&l) => {
            joint.length = l
        }
        (JointKind::Distance, Some(l)) => {
            return err(
                "length",
                format!(
                    "must be finite, >= 0 and at most {} m, got {}",
                    readable(MAX_COORDINATE),
                    readable(l)
                ),
            )
        }
        (_, Some(_)) => {
            return err(
                "length",
                format!(
                    "only distance joints take a length, not {} joints",
                    kind.name()
                ),
            )
        }
        (_, None) => {}
    }
    Ok(joint)
}

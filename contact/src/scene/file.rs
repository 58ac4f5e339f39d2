//! The scene file format: the TOML tables as `serde` structs (each rejecting unknown keys),
//! the `[metrics]` table, where in the text a parse error is (line, column, table, key), and
//! the small conversions of file values.

use super::SimSettings;
use crate::body_solvers::Penalty;
use crate::builder::BuilderParams;
use nalgebra::Vector3;
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneFile {
    #[serde(default)]
    pub(super) name: Option<String>,
    #[serde(default)]
    pub(super) description: String,
    #[serde(default)]
    pub(super) settings: SettingsFile,
    #[serde(default)]
    pub(super) materials: Vec<MaterialFile>,
    #[serde(default)]
    pub(super) bodies: Vec<BodyFile>,
    #[serde(default)]
    pub(super) events: Vec<EventFile>,
    #[serde(default)]
    pub(super) joints: Vec<JointFile>,
    #[serde(default)]
    pub(super) metrics: SceneMetrics,
}

/// The `[metrics]` table of a scene: the analytic answers the harness checks a run against
/// (`docs/scenes.md` says what each measures), and a few informational keys that describe the
/// setup for readers and are not checked. Every key is optional; a key not listed here is an
/// error naming the file and the key.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneMetrics {
    /// Height the top body of a stack keeps, m (sag and lateral drift are measured from it).
    pub expected_top_height: Option<f64>,
    /// Height a resting body keeps, m (used like `expected_top_height` when that is absent).
    pub expected_rest_height: Option<f64>,
    /// Displacement of the first dynamic body over the run, m (`0`: it must not move).
    pub expected_displacement: Option<f64>,
    /// Acceleration of the first dynamic body along its motion, m/s² (`0`: it must stick).
    pub expected_acceleration: Option<f64>,
    /// Height of the first bounce, m.
    pub expected_rebound_height: Option<f64>,
    /// Normal force on each wall of a groove, N.
    pub expected_wall_force: Option<f64>,
    /// Final velocities of the bodies under the simultaneous collision model, m/s.
    pub simultaneous_velocities: Option<Vec<f64>>,
    /// Final velocities of the bodies under the sequential collision model, m/s.
    pub sequential_velocities: Option<Vec<f64>>,
    /// Step at which the scene's event removes a body.
    pub removed_at_step: Option<usize>,
    /// Bodies that must not slide.
    pub stick_bodies: Option<Vec<String>>,
    /// The scene must come to rest.
    pub at_rest: Option<bool>,
    /// Direction of the push (for the displacement of a pushed body).
    pub push_direction: Option<[f64; 3]>,
    /// Body whose sag (drop below its initial height) the joint metrics report: the end mass
    /// of a hanging chain, the load of a bridge.
    pub sag_body: Option<String>,
    /// Every sphere that starts at rest above a plane bounces on it alone: the impact-time and
    /// energy metrics compare each sphere's impacts with the analytic ones
    /// ([`crate::discontinuity::bouncing_ball_impacts`]).
    pub analytic_impacts: Option<bool>,
    /// Informational: height a body is dropped from, m.
    pub drop_height: Option<f64>,
    /// Informational: slope of the incline, degrees.
    pub incline_degrees: Option<f64>,
    /// Informational: friction coefficient(s) of the setup.
    pub mu: Option<OneOrMany>,
    /// Informational: restitution of the setup.
    pub restitution: Option<f64>,
    /// Informational: speed of the striking body, m/s.
    pub striker_speed: Option<f64>,
    /// Informational: angle of the walls, degrees.
    pub wall_angle_degrees: Option<f64>,
}

impl SceneMetrics {
    /// True for a scene that should come to rest: a stack or resting-body height, zero
    /// expected displacement or acceleration, or `at_rest = true`.
    pub fn is_resting(&self) -> bool {
        self.expected_top().is_some()
            || self.expected_displacement == Some(0.0)
            || self.expected_acceleration == Some(0.0)
            || self.at_rest == Some(true)
    }

    /// The expected final height of the top body (stacks, resting bodies).
    pub fn expected_top(&self) -> Option<f64> {
        self.expected_top_height.or(self.expected_rest_height)
    }
}

/// One number or a list of them (an informational metric that varies across bodies).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum OneOrMany {
    /// One value.
    One(f64),
    /// One value per body or case.
    Many(Vec<f64>),
}

#[derive(Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(super) struct SettingsFile {
    pub(super) dt: f64,
    pub(super) steps: usize,
    pub(super) gravity: [f64; 3],
    pub(super) friction_model: String,
    pub(super) pyramid_directions: usize,
    pub(super) solver: Option<String>,
    pub(super) tolerance: f64,
    pub(super) max_iterations: usize,
    pub(super) warm_start: bool,
    pub(super) islands: bool,
    pub(super) restitution_threshold: f64,
    pub(super) position_correction: String,
    pub(super) baumgarte: f64,
    pub(super) slop: f64,
    pub(super) prediction_distance: f64,
    pub(super) persistent_manifolds: bool,
    pub(super) penalty_omega_h: f64,
    pub(super) penalty_damping_ratio: f64,
    pub(super) penalty_stiffness: Option<f64>,
    pub(super) ccd: String,
    pub(super) stepping: String,
    pub(super) residual: String,
}

impl Default for SettingsFile {
    fn default() -> Self {
        let s = SimSettings::default();
        let b = Penalty::default();
        let p = BuilderParams::default();
        Self {
            dt: s.dt,
            steps: s.steps,
            gravity: s.gravity.into(),
            friction_model: "box".into(),
            pyramid_directions: 4,
            solver: None,
            tolerance: s.tolerance,
            max_iterations: s.max_iterations,
            warm_start: s.warm_start,
            islands: s.islands,
            restitution_threshold: p.restitution_threshold,
            position_correction: "baumgarte".into(),
            baumgarte: p.baumgarte,
            slop: p.slop,
            prediction_distance: s.prediction_distance,
            persistent_manifolds: s.persistent_manifolds,
            penalty_omega_h: b.omega_h,
            penalty_damping_ratio: b.damping_ratio,
            penalty_stiffness: None,
            ccd: "none".into(),
            stepping: "fixed".into(),
            residual: s.residual.to_string(),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaterialFile {
    pub(super) name: String,
    #[serde(default = "default_mu")]
    pub(super) mu: f64,
    #[serde(default)]
    pub(super) restitution: f64,
}

fn default_mu() -> f64 {
    0.5
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub(super) enum ShapeFile {
    Sphere { radius: f64 },
    Box { half_extents: [f64; 3] },
    Capsule { half_height: f64, radius: f64 },
    Convex { points: Vec<[f64; 3]> },
    Particle { radius: Option<f64> },
    Plane { normal: [f64; 3] },
    Mesh { file: String },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AxisAngleFile {
    pub(super) axis: [f64; 3],
    pub(super) degrees: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RepeatFile {
    pub(super) count: [usize; 3],
    pub(super) spacing: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct BodyFile {
    pub(super) name: String,
    pub(super) shape: ShapeFile,
    pub(super) density: Option<f64>,
    pub(super) mass: Option<f64>,
    #[serde(default)]
    pub(super) position: [f64; 3],
    pub(super) orientation: Option<[f64; 4]>,
    pub(super) axis_angle: Option<AxisAngleFile>,
    #[serde(default)]
    pub(super) velocity: [f64; 3],
    #[serde(default)]
    pub(super) angular_velocity: [f64; 3],
    #[serde(default, rename = "static")]
    pub(super) is_static: bool,
    pub(super) material: Option<String>,
    pub(super) repeat: Option<RepeatFile>,
}

/// A `[[joints]]` table: its kind, the two bodies (`"world"` for a fixed point in space), the
/// world anchor at the initial poses (`anchors` for a distance joint, one per body), the hinge
/// axis and an optional rod length.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct JointFile {
    #[serde(default)]
    pub(super) name: Option<String>,
    #[serde(rename = "type")]
    pub(super) kind: String,
    pub(super) bodies: [String; 2],
    #[serde(default)]
    pub(super) anchor: Option<[f64; 3]>,
    #[serde(default)]
    pub(super) anchors: Option<[[f64; 3]; 2]>,
    #[serde(default)]
    pub(super) axis: Option<[f64; 3]>,
    #[serde(default)]
    pub(super) length: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct EventFile {
    pub(super) at_step: usize,
    pub(super) remove: String,
}

/// 1-based line and column of a byte offset.
pub(super) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rfind('\n').map_or(offset, |p| offset - p - 1) + 1;
    (line, column)
}

/// The key of a `key = value` line when `column` points into the value.
pub(super) fn key_at(text: &str, line: usize, column: usize) -> Option<String> {
    let l = text.lines().nth(line.checked_sub(1)?)?;
    let eq = l.find('=')?;
    let key = l[..eq].trim();
    let simple = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
    (column > eq && simple).then(|| key.to_owned())
}

/// `in [[bodies]] #3: ` for an offset inside the third `[[bodies]]` table (or empty).
pub(super) fn table_context(text: &str, offset: usize) -> String {
    let offset = offset.min(text.len());
    let end = text[offset..].find('\n').map_or(text.len(), |p| offset + p);
    let before = &text[..end];
    let mut last: Option<&str> = None;
    let mut counts: std::collections::HashMap<&str, usize> = Default::default();
    for line in before.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            let header = t.split('#').next().unwrap_or(t).trim();
            *counts.entry(header).or_default() += 1;
            last = Some(header);
        }
    }
    match last {
        Some(h) if h.starts_with("[[") => format!("in {h} #{}: ", counts[h]),
        Some(h) => format!("in {h}: "),
        None => String::new(),
    }
}

/// Euclidean length of `v`, or its largest component when the length overflows (so a message
/// can show `1e300` rather than `inf`).
pub(super) fn magnitude(v: [f64; 3]) -> f64 {
    let norm = vec3(v).norm();
    if norm.is_finite() || v.iter().any(|x| !x.is_finite()) {
        norm
    } else {
        v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
    }
}

/// The one check of a vector field of a scene file (axes, anchors, positions, velocities,
/// gravity): every component finite and the Euclidean length finite, so no later `norm()` or
/// normalisation overflows to `∞` (an axis of `[1e308, 1e308, 1e308]` has an infinite norm,
/// and normalised it is `0`). Each field then checks its own bound on the result. The error is
/// the field and what is wrong.
pub(super) fn finite_vector(field: &str, v: [f64; 3]) -> Result<Vector3<f64>, (String, String)> {
    let w = vec3(v);
    if v.iter().any(|x| !x.is_finite()) {
        return Err((
            field.to_owned(),
            format!("every component must be finite, got {v:?}"),
        ));
    }
    if !w.norm().is_finite() {
        return Err((
            field.to_owned(),
            format!(
                "its length overflows (components up to {:e}); give a vector of moderate size",
                magnitude(v)
            ),
        ));
    }
    Ok(w)
}

pub(super) fn vec3(v: [f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

//! Recordings: the JSON-lines file `lcpbench simulate --record` writes, read back and turned into
//! the compact data a replay page draws.
//!
//! Line 1 is a header `{"recording": {...}}` with the scene name, solver, time step, tolerance
//! and each body's name, shape and whether it is static (shapes as the page draws them: sphere,
//! box, capsule, plane, or a triangle mesh for convex hulls and meshes). Every further line is one
//! [`StepReport`](lcpbench_contact::StepReport) with the body states after the step.

use super::ViewError;
use lcpbench_contact::{JointKind, Shape, StepReport, World};
use serde::Deserialize;
use serde_json::{json, Map, Value};
use std::collections::HashMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Most points of one solve's convergence history kept in a page (more are thinned, first and
/// last kept).
pub const MAX_HISTORY_POINTS: usize = 200;

/// The recording format this version writes and reads (the header's `version`).
pub const RECORDING_VERSION: u64 = 1;

/// Largest recording file read, bytes: a recording is read whole before its page is made.
pub const MAX_RECORDING_BYTES: u64 = 2_000_000_000;

/// The header line of a recording for `world` (call before the first step).
pub fn header(scene: &str, world: &World) -> Value {
    let bodies: Vec<Value> = world
        .bodies
        .iter()
        .map(|b| {
            json!({
                "name": b.name,
                "static": b.is_static,
                "shape": shape_json(&b.shape),
            })
        })
        .collect();
    json!({ "recording": {
        "version": RECORDING_VERSION,
        "scene": scene,
        "solver": world.settings.solver.name(),
        "dt": world.settings.dt,
        "tolerance": world.settings.tolerance,
        "gravity": <[f64; 3]>::from(world.settings.gravity),
        "bodies": bodies,
    }})
}

/// One step line of a recording: the step's report and the body states after it.
pub fn step_line(report: &StepReport, world: &World) -> Value {
    let bodies: Vec<_> = world
        .bodies
        .iter()
        .map(|b| {
            let q = b.orientation.quaternion();
            json!({
                "name": b.name,
                "position": [b.position.x, b.position.y, b.position.z],
                "orientation": [q.w, q.i, q.j, q.k],
                "velocity": <[f64; 3]>::from(b.velocity()),
                "angular_velocity": <[f64; 3]>::from(b.angular_velocity()),
            })
        })
        .collect();
    let mut line = serde_json::to_value(report).unwrap_or_else(|_| json!({}));
    if let Some(obj) = line.as_object_mut() {
        obj.insert("bodies".into(), json!(bodies));
    }
    line
}

/// A shape as the page draws it, in the body frame.
fn shape_json(shape: &Shape) -> Value {
    let mesh = |vertices: Vec<[f64; 3]>, indices: Vec<[u32; 3]>| {
        let v: Vec<f32> = vertices.iter().flatten().map(|&x| x as f32).collect();
        let i: Vec<u32> = indices.into_iter().flatten().collect();
        json!({ "type": "mesh", "vertices": v, "indices": i })
    };
    match shape {
        Shape::Sphere { radius } | Shape::Particle { radius } => {
            json!({ "type": "sphere", "radius": radius })
        }
        Shape::Box { half_extents } => {
            json!({ "type": "box", "half_extents": <[f64; 3]>::from(*half_extents) })
        }
        Shape::Capsule {
            half_height,
            radius,
        } => json!({ "type": "capsule", "half_height": half_height, "radius": radius }),
        Shape::Plane { normal } => {
            json!({ "type": "plane", "normal": <[f64; 3]>::from(normal.into_inner()) })
        }
        Shape::ConvexPolyhedron { hull, .. } => {
            let (vertices, indices) = hull.to_trimesh();
            mesh(vertices.iter().map(|p| [p.x, p.y, p.z]).collect(), indices)
        }
        Shape::TriMesh { mesh: m, .. } => mesh(
            m.vertices().iter().map(|p| [p.x, p.y, p.z]).collect(),
            m.indices().to_vec(),
        ),
    }
}

/// One body of the header.
#[derive(Debug, Clone, Deserialize)]
pub struct BodyInfo {
    /// Name.
    pub name: String,
    /// Static (never moves).
    #[serde(rename = "static")]
    pub is_static: bool,
    /// Shape, as [`header`] wrote it.
    pub shape: Value,
}

/// The header of a recording.
#[derive(Debug, Clone, Deserialize)]
pub struct Header {
    /// Format version ([`RECORDING_VERSION`]).
    #[serde(default)]
    pub version: Option<u64>,
    /// Scene name.
    pub scene: String,
    /// Solver name.
    pub solver: String,
    /// Time step, s.
    pub dt: f64,
    /// Solver tolerance on the relative residual.
    pub tolerance: f64,
    /// Bodies at step 0.
    pub bodies: Vec<BodyInfo>,
}

/// A body state in a step line.
#[derive(Debug, Clone, Deserialize)]
pub struct BodyState {
    /// Name.
    pub name: String,
    /// Centre of mass, world frame.
    pub position: [f64; 3],
    /// Orientation quaternion `[w, x, y, z]`.
    pub orientation: [f64; 4],
}

/// A contact in a step line (fields added after version 1 default to zero).
#[derive(Debug, Clone, Deserialize)]
pub struct ContactLine {
    /// The two bodies' names.
    pub bodies: [String; 2],
    /// Contact point.
    pub point: [f64; 3],
    /// Unit normal from the first body to the second.
    pub normal: [f64; 3],
    /// Signed gap.
    pub dist: f64,
    /// Total impulse on the second body.
    pub impulse: [f64; 3],
    /// Normal impulse.
    #[serde(default)]
    pub normal_impulse: f64,
    /// Tangential impulse.
    #[serde(default)]
    pub tangent_impulse: [f64; 3],
    /// Relative velocity after the step.
    #[serde(default)]
    pub relative_velocity: [f64; 3],
    /// Friction coefficient.
    #[serde(default)]
    pub mu: f64,
    /// Normal row of `w`.
    #[serde(default)]
    pub normal_rate: f64,
    /// `min(f_n, w_n / A_nn)`.
    #[serde(default)]
    pub complementarity: f64,
}

/// A joint's error in a step line ([`JointError`](lcpbench_contact::joint::JointError)).
#[derive(Debug, Clone, Copy, Default, Deserialize)]
pub struct JointErrorLine {
    /// Anchor separation (ball, hinge, fixed) or length error (distance), m.
    #[serde(deserialize_with = "number_or_null")]
    pub linear: f64,
    /// Angle between the hinge axes or away from the rest orientation (fixed), rad.
    #[serde(default, deserialize_with = "number_or_null")]
    pub angular: f64,
}

/// A joint in a step line ([`JointRecord`](lcpbench_contact::step::JointRecord)).
#[derive(Debug, Clone, Deserialize)]
pub struct JointLine {
    /// Name.
    pub name: String,
    /// Kind, as scene files name it (`ball`, `hinge`, `fixed`, `distance`).
    pub kind: String,
    /// World anchor of each side at the step's end.
    #[serde(deserialize_with = "anchors_or_null")]
    pub anchors: [[f64; 3]; 2],
    /// Error at the step's end.
    pub error: JointErrorLine,
    /// Magnitude of the linear impulse of its rows on side b, N·s.
    #[serde(default, deserialize_with = "number_or_null")]
    pub impulse: f64,
}

/// A number that may have been written as `null` (serde_json writes NaN and ±∞ so), read as
/// NaN for [`check_step`] to refuse by name.
fn number_or_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Two points whose coordinates may have been written as `null` ([`number_or_null`]).
fn anchors_or_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[[f64; 3]; 2], D::Error> {
    let read = <[[Option<f64>; 3]; 2]>::deserialize(d)?;
    Ok(read.map(|p| p.map(|x| x.unwrap_or(f64::NAN))))
}

/// One step line.
#[derive(Debug, Clone, Deserialize)]
pub struct StepLine {
    /// Step index.
    pub step: usize,
    /// Time at the end of the step, s.
    pub time: f64,
    /// Solver status object (`{"status": name, "reason": ...}`).
    pub status: Value,
    /// Iterations or pivots.
    pub iterations: usize,
    /// Solver time, s.
    pub solve_time_s: f64,
    /// Shared residuals (`natural_map_rel`, ...), when measured.
    #[serde(default)]
    pub residuals: Option<Value>,
    /// Largest penetration, m.
    pub max_penetration: f64,
    /// Kinetic energy, J.
    pub kinetic_energy: f64,
    /// Potential energy, J.
    pub potential_energy: f64,
    /// Contacts.
    pub contact_records: Vec<ContactLine>,
    /// Joints of the world (recordings without joints: 0).
    #[serde(default)]
    pub joints: usize,
    /// Equality rows of the joints in the step's problem.
    #[serde(default)]
    pub joint_rows: usize,
    /// Largest joint error at the step's end, m.
    #[serde(default, deserialize_with = "number_or_null")]
    pub joint_drift_max: f64,
    /// Mean joint error at the step's end, m.
    #[serde(default, deserialize_with = "number_or_null")]
    pub joint_drift_mean: f64,
    /// Largest angular joint error at the step's end, rad.
    #[serde(default, deserialize_with = "number_or_null")]
    pub joint_angle_max: f64,
    /// Joints with their anchors, errors and impulses (absent when the world has none).
    #[serde(default)]
    pub joint_records: Vec<JointLine>,
    /// Convergence history (objects with `iteration`, `residual`, `time_s`, and whatever else
    /// the solver recorded, such as an active set).
    #[serde(default)]
    pub history: Vec<Value>,
    /// The convergence history in the page's thinned form ([`history_json`]) as JSON text.
    /// [`Recording::from_lines`] moves `history` here as it reads each step (and `simulate
    /// --html` before it keeps a step), so a long run's page holds at most
    /// [`MAX_HISTORY_POINTS`] points a step, in a few kilobytes, instead of every iteration.
    #[serde(default)]
    pub page_history: Option<String>,
    /// Body states after the step.
    pub bodies: Vec<BodyState>,
}

/// A recording read back.
#[derive(Debug, Clone)]
pub struct Recording {
    /// Where it came from.
    pub source: PathBuf,
    /// The header.
    pub header: Header,
    /// The steps.
    pub steps: Vec<StepLine>,
}

impl Recording {
    /// Whether any step recorded a joint (its page then draws joints and plots their drift).
    pub fn has_joints(&self) -> bool {
        self.steps.iter().any(|s| !s.joint_records.is_empty())
    }

    /// Read a recording file (a regular file of at most [`MAX_RECORDING_BYTES`]).
    pub fn read(path: &Path) -> Result<Self, ViewError> {
        lcpbench_solvers::io::input::check_input_file(path, MAX_RECORDING_BYTES)
            .map_err(|e| ViewError::Io(path.into(), e))?;
        let file = std::fs::File::open(path).map_err(|e| ViewError::Io(path.into(), e))?;
        Self::from_lines(path, std::io::BufReader::new(file).lines())
    }

    /// Parse recording lines (the first must be the header), each checked against the header
    /// ([`check_header`], [`check_step`]).
    pub fn from_lines(
        path: &Path,
        lines: impl Iterator<Item = std::io::Result<String>>,
    ) -> Result<Self, ViewError> {
        let bad = |line: usize, message: String| ViewError::Recording {
            path: path.into(),
            line,
            message,
        };
        let mut header: Option<Header> = None;
        let mut names: HashMap<String, usize> = HashMap::new();
        let mut steps: Vec<StepLine> = Vec::new();
        for (k, line) in lines.enumerate() {
            let line = line.map_err(|e| ViewError::Io(path.into(), e))?;
            if line.trim().is_empty() {
                continue;
            }
            if header.is_none() {
                let mut v: Value =
                    serde_json::from_str(&line).map_err(|e| bad(k + 1, e.to_string()))?;
                let h = v.get_mut("recording").map(Value::take).ok_or_else(|| {
                    bad(
                        1,
                        "no header line `{\"recording\": ...}` (re-record with this version of \
                         lcpbench simulate --record)"
                            .into(),
                    )
                })?;
                let h: Header = serde_json::from_value(h).map_err(|e| bad(k + 1, e.to_string()))?;
                check_header(&h).map_err(|m| bad(k + 1, m))?;
                names = h
                    .bodies
                    .iter()
                    .enumerate()
                    .map(|(i, b)| (b.name.clone(), i))
                    .collect();
                header = Some(h);
                continue;
            }
            let step: StepLine =
                serde_json::from_str(&line).map_err(|e| bad(k + 1, e.to_string()))?;
            let mut step = step;
            check_step(&step, steps.last(), &names).map_err(|m| bad(k + 1, m))?;
            if !step.history.is_empty() {
                step.page_history = Some(history_json(&step.history).to_string());
                step.history = Vec::new();
            }
            steps.push(step);
        }
        let header = header.ok_or_else(|| bad(0, "the file is empty".into()))?;
        Ok(Self {
            source: path.into(),
            header,
            steps,
        })
    }
}

/// A header this version can draw: its [`RECORDING_VERSION`], at most
/// [`MAX_BODIES`](lcpbench_contact::scene::MAX_BODIES) bodies with distinct names, a time step
/// and tolerance within the scene limits, and shapes with positive finite sizes (meshes with
/// whole triangles indexing their own vertices).
pub fn check_header(h: &Header) -> Result<(), String> {
    use lcpbench_contact::scene::{readable, DT_RANGE, MAX_BODIES};
    match h.version {
        Some(RECORDING_VERSION) => {}
        Some(v) => {
            return Err(format!(
                "recording version {v} is unknown (this lcpbench reads version \
                 {RECORDING_VERSION})"
            ))
        }
        None => {
            return Err(format!(
                "the header has no `version` (this lcpbench reads version {RECORDING_VERSION})"
            ))
        }
    }
    if h.bodies.len() > MAX_BODIES {
        return Err(format!(
            "bodies: {} bodies, beyond the limit of {MAX_BODIES} (the scene limit)",
            h.bodies.len()
        ));
    }
    if !(DT_RANGE.0..=DT_RANGE.1).contains(&h.dt) {
        return Err(format!(
            "dt: must be between {} and {} s, got {}",
            readable(DT_RANGE.0),
            DT_RANGE.1,
            readable(h.dt)
        ));
    }
    if !(h.tolerance > 0.0 && h.tolerance < 1.0) {
        return Err(format!(
            "tolerance: must be in (0, 1), got {}",
            readable(h.tolerance)
        ));
    }
    let mut seen = std::collections::HashSet::new();
    for (i, b) in h.bodies.iter().enumerate() {
        if !seen.insert(b.name.as_str()) {
            return Err(format!(
                "bodies[{i}]: the name \"{}\" is used twice",
                b.name
            ));
        }
        check_shape(&b.shape).map_err(|m| format!("bodies[{i}] (\"{}\").shape: {m}", b.name))?;
    }
    Ok(())
}

/// A shape as [`header`] writes it.
fn check_shape(shape: &Value) -> Result<(), String> {
    let numbers = |key: &str| -> Result<Vec<f64>, String> {
        shape
            .get(key)
            .and_then(Value::as_array)
            .ok_or_else(|| format!("`{key}` must be an array of numbers"))?
            .iter()
            .map(|v| {
                v.as_f64()
                    .ok_or_else(|| format!("`{key}` must hold numbers"))
            })
            .collect()
    };
    let positive = |key: &str, values: &[f64]| {
        if values.iter().all(|v| v.is_finite() && *v > 0.0) {
            Ok(())
        } else {
            Err(format!(
                "`{key}` must be positive and finite, got {values:?}"
            ))
        }
    };
    let number = |key: &str| -> Result<Vec<f64>, String> {
        shape
            .get(key)
            .and_then(Value::as_f64)
            .map(|v| vec![v])
            .ok_or_else(|| format!("`{key}` must be a number"))
    };
    match shape.get("type").and_then(Value::as_str) {
        Some("sphere") => positive("radius", &number("radius")?),
        Some("capsule") => {
            positive("radius", &number("radius")?)?;
            positive("half_height", &number("half_height")?)
        }
        Some("box") => {
            let h = numbers("half_extents")?;
            if h.len() != 3 {
                return Err("`half_extents` must have 3 numbers".into());
            }
            positive("half_extents", &h)
        }
        Some("plane") => {
            let n = numbers("normal")?;
            if n.len() != 3 || !n.iter().all(|v| v.is_finite()) || n.iter().all(|v| *v == 0.0) {
                return Err(format!(
                    "`normal` must be 3 finite numbers, not all 0, got {n:?}"
                ));
            }
            Ok(())
        }
        Some("mesh") => {
            let v = numbers("vertices")?;
            let i = numbers("indices")?;
            let n = v.len() / 3;
            if v.len() % 3 != 0 || i.len() % 3 != 0 {
                return Err("`vertices` and `indices` must come in threes".into());
            }
            if let Some(bad) = i
                .iter()
                .find(|&&k| !(k >= 0.0 && k.fract() == 0.0 && k < n as f64))
            {
                return Err(format!("index {bad} is not one of the {n} vertices"));
            }
            Ok(())
        }
        Some(other) => Err(format!(
            "unknown shape type \"{other}\" (known: sphere, box, capsule, plane, mesh)"
        )),
        None => Err("no shape `type`".into()),
    }
}

/// A step line that fits its header and follows `previous`: steps increase, every body and
/// contact names a body of the header, and its joints are drawable ([`check_joints`]).
pub fn check_step(
    step: &StepLine,
    previous: Option<&StepLine>,
    names: &HashMap<String, usize>,
) -> Result<(), String> {
    if let Some(p) = previous.filter(|p| step.step <= p.step) {
        return Err(format!(
            "step {} comes after step {}: steps must increase",
            step.step, p.step
        ));
    }
    if step.bodies.len() > names.len() {
        return Err(format!(
            "{} body states, but the header has {} bodies",
            step.bodies.len(),
            names.len()
        ));
    }
    if let Some(b) = step.bodies.iter().find(|b| !names.contains_key(&b.name)) {
        return Err(format!(
            "step {}: body \"{}\" is not in the header",
            step.step, b.name
        ));
    }
    if let Some(name) = step
        .contact_records
        .iter()
        .flat_map(|c| &c.bodies)
        .find(|n| !names.contains_key(*n))
    {
        return Err(format!(
            "step {}: a contact names body \"{name}\", which is not in the header",
            step.step
        ));
    }
    if let Some(b) = step.bodies.iter().find(|b| {
        !b.position
            .iter()
            .chain(&b.orientation)
            .all(|&x| drawable(x))
    }) {
        return Err(format!(
            "step {}: body \"{}\": position and orientation must be finite numbers within \
             ±{:e} (the page draws in single precision)",
            step.step,
            b.name,
            f32::MAX
        ));
    }
    check_joints(step).map_err(|m| format!("step {}: {m}", step.step))
}

/// Whether the page can draw `x`: finite and within `f32`'s range (the page's frames hold
/// single-precision numbers; a larger value becomes `∞`, written `null`, and three.js cannot
/// place a point at it).
fn drawable(x: f64) -> bool {
    x.is_finite() && x.abs() <= f32::MAX as f64
}

/// A step's joint figures and records: known kinds, anchors the page can draw ([`drawable`]),
/// errors and impulses that are finite and not negative.
fn check_joints(step: &StepLine) -> Result<(), String> {
    let figures = [
        ("joint_drift_max", step.joint_drift_max),
        ("joint_drift_mean", step.joint_drift_mean),
        ("joint_angle_max", step.joint_angle_max),
    ];
    if let Some((key, x)) = figures.iter().find(|(_, x)| !(x.is_finite() && *x >= 0.0)) {
        return Err(format!("{key} must be finite and not negative, got {x}"));
    }
    for (k, j) in step.joint_records.iter().enumerate() {
        let at = || format!("joint_records[{k}] (\"{}\")", j.name);
        if JointKind::from_name(&j.kind).is_none() {
            let known: Vec<&str> = JointKind::ALL.iter().map(|k| k.name()).collect();
            return Err(format!(
                "{}: unknown joint kind \"{}\" (known: {})",
                at(),
                j.kind,
                known.join(", ")
            ));
        }
        if let Some(side) = j
            .anchors
            .iter()
            .position(|p| !p.iter().all(|&x| drawable(x)))
        {
            return Err(format!(
                "{}: anchors[{side}] must be 3 finite numbers within ±{:e} (the page draws in \
                 single precision), got {:?}",
                at(),
                f32::MAX,
                j.anchors[side]
            ));
        }
        let values = [
            ("error.linear", j.error.linear),
            ("error.angular", j.error.angular),
            ("impulse", j.impulse),
        ];
        if let Some((key, x)) = values.iter().find(|(_, x)| !(x.is_finite() && *x >= 0.0)) {
            return Err(format!(
                "{}: {key} must be finite and not negative, got {x}",
                at()
            ));
        }
    }
    Ok(())
}

/// How a contact is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactStatus {
    /// No normal impulse.
    Separating = 0,
    /// Normal impulse, no slip.
    Sticking = 1,
    /// Normal impulse and slip.
    Sliding = 2,
    /// `0 <= f_n ⟂ w_n >= 0` or the friction cone is violated beyond the tolerance.
    Violated = 3,
}

/// Slip speed above which a loaded contact counts as sliding, m/s.
pub const SLIP_SPEED: f64 = 1e-3;

/// Classify a contact. `f_scale` is the step's largest normal impulse, `tol` the solver's
/// relative tolerance: a violation is judged against `tol · f_scale`.
pub fn contact_status(c: &ContactLine, tol: f64, f_scale: f64) -> ContactStatus {
    let eps = (tol * f_scale).max(1e-12);
    let ft = norm(c.tangent_impulse);
    let cone = ft - c.mu * c.normal_impulse.max(0.0);
    if c.complementarity.abs() > eps || c.normal_impulse < -eps || cone > eps.max(1e-6 * ft) {
        return ContactStatus::Violated;
    }
    if c.normal_impulse <= eps {
        return ContactStatus::Separating;
    }
    let n = c.normal;
    let v = c.relative_velocity;
    let vn = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
    let vt = [v[0] - vn * n[0], v[1] - vn * n[1], v[2] - vn * n[2]];
    if norm(vt) > SLIP_SPEED {
        ContactStatus::Sliding
    } else {
        ContactStatus::Sticking
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Numbers per contact in a frame: body a, body b, point (3), normal (3), `f_n`, tangential
/// impulse (3), relative velocity (3), gap, `mu`, `w_n`, complementarity, status code.
pub const CONTACT_FIELDS: usize = 20;

/// Numbers per joint in a frame: anchor a (3), anchor b (3), linear error, angular error,
/// impulse, kind code (the index of the kind in [`JointKind::ALL`]).
pub const JOINT_FIELDS: usize = 10;

/// The step's frame: poses (`[x, y, z, qw, qx, qy, qz]` per body in `ids`), contacts
/// ([`CONTACT_FIELDS`] numbers each), joints ([`JOINT_FIELDS`] numbers each, only in runs
/// that have joints) and the thinned convergence history.
fn frame(rec: &Recording, index: &HashMap<&str, usize>, s: &StepLine, joints: bool) -> Value {
    let all = s.bodies.len() == rec.header.bodies.len()
        && s.bodies
            .iter()
            .zip(&rec.header.bodies)
            .all(|(a, b)| a.name == b.name);
    let mut pose = Vec::with_capacity(7 * s.bodies.len());
    for b in &s.bodies {
        pose.extend(b.position.iter().chain(&b.orientation).map(|&x| x as f32));
    }
    let f_scale = s
        .contact_records
        .iter()
        .map(|c| c.normal_impulse.abs())
        .fold(0.0, f64::max);
    let id = |name: &str| index.get(name).map_or(-1.0, |&i| i as f32);
    let mut contacts = Vec::with_capacity(CONTACT_FIELDS * s.contact_records.len());
    for c in &s.contact_records {
        contacts.extend([id(&c.bodies[0]), id(&c.bodies[1])]);
        contacts.extend(c.point.iter().chain(&c.normal).map(|&x| x as f32));
        contacts.push(c.normal_impulse as f32);
        contacts.extend(c.tangent_impulse.iter().map(|&x| x as f32));
        contacts.extend(c.relative_velocity.iter().map(|&x| x as f32));
        contacts.extend([c.dist, c.mu, c.normal_rate, c.complementarity].map(|x| x as f32));
        contacts.push(contact_status(c, rec.header.tolerance, f_scale) as u8 as f32);
    }
    let mut out = json!({
        "step": s.step,
        "pose": page_numbers(&pose),
        "contacts": page_numbers(&contacts),
    });
    if joints {
        out["joints"] = page_numbers(&joints_json(&s.joint_records));
    }
    if !all {
        let ids: Vec<f32> = s.bodies.iter().map(|b| id(&b.name)).collect();
        out["ids"] = page_numbers(&ids);
    }
    let page_history = s
        .page_history
        .as_deref()
        .and_then(|t| serde_json::from_str::<Value>(t).ok());
    if let Some(h) = page_history {
        out["history"] = h;
    } else if !s.history.is_empty() {
        out["history"] = history_json(&s.history);
    }
    out
}

/// Replace a step line's `history` (every iteration) by its page form in `page_history`
/// ([`StepLine::page_history`]), for a page built from lines kept in memory.
pub fn compact_history(line: &mut Value) {
    let Some(obj) = line.as_object_mut() else {
        return;
    };
    if let Some(Value::Array(history)) = obj.remove("history") {
        if !history.is_empty() {
            obj.insert(
                "page_history".into(),
                Value::String(history_json(&history).to_string()),
            );
        }
    }
}

/// Numbers as a page gets them: whole numbers without a fraction, others as the shortest
/// decimal that reads back as the same `f32` (an `f32` widened to `f64` prints with up to 17
/// digits), non-finite ones as `null`.
fn page_numbers(values: &[f32]) -> Value {
    let number = |x: f32| {
        if x.fract() == 0.0 && x.abs() < 1e9 {
            return json!(x as i64);
        }
        // `f32`'s `Display` is its shortest round-trip decimal.
        x.to_string()
            .parse::<f64>()
            .ok()
            .and_then(serde_json::Number::from_f64)
            .map_or(Value::Null, Value::Number)
    };
    Value::Array(values.iter().map(|&x| number(x)).collect())
}

/// A frame's joints: [`JOINT_FIELDS`] numbers each.
fn joints_json(joints: &[JointLine]) -> Vec<f32> {
    let mut out = Vec::with_capacity(JOINT_FIELDS * joints.len());
    for j in joints {
        let kind = JointKind::ALL
            .iter()
            .position(|k| k.name() == j.kind)
            .map_or(-1.0, |k| k as f32);
        out.extend(j.anchors.iter().flatten().map(|&x| x as f32));
        out.extend([j.error.linear, j.error.angular, j.impulse].map(|x| x as f32));
        out.push(kind);
    }
    out
}

/// A convergence history thinned to [`MAX_HISTORY_POINTS`]: `{"it": [...], "res": [...],
/// "thinned_from": n, "extra_key": name, "extra": [...]}`, where `extra` holds the first field
/// beyond `iteration`, `residual` and `time_s` the solver recorded (a pivoting solver's active
/// set), when there is one.
pub fn history_json(history: &[Value]) -> Value {
    let n = history.len();
    let stride = n.div_ceil(MAX_HISTORY_POINTS).max(1);
    let keep: Vec<&Value> = history
        .iter()
        .enumerate()
        .filter(|(i, _)| i % stride == 0 || *i + 1 == n)
        .map(|(_, v)| v)
        .collect();
    let num = |v: &Value, k: &str| v.get(k).and_then(Value::as_f64);
    let its: Vec<Option<f64>> = keep.iter().map(|v| num(v, "iteration")).collect();
    let res: Vec<Option<f32>> = keep
        .iter()
        .map(|v| num(v, "residual").map(|x| x as f32))
        .collect();
    let extra_key = keep.iter().find_map(|v| {
        v.as_object()?
            .iter()
            .find(|(k, x)| {
                !matches!(k.as_str(), "iteration" | "residual" | "time_s") && !x.is_null()
            })
            .map(|(k, _)| k.clone())
    });
    let mut out = Map::new();
    out.insert("it".into(), json!(its));
    out.insert("res".into(), json!(res));
    if stride > 1 {
        out.insert("thinned_from".into(), json!(n));
    }
    if let Some(k) = extra_key {
        let extra: Vec<Value> = keep
            .iter()
            .map(|v| v.get(&k).cloned().unwrap_or(Value::Null))
            .collect();
        out.insert("extra".into(), json!(extra));
        out.insert("extra_key".into(), json!(k));
    }
    Value::Object(out)
}

/// Per-step series for the plots (every step, never decimated).
fn series(rec: &Recording) -> Value {
    let s = &rec.steps;
    let residual: Vec<Option<f64>> = s
        .iter()
        .map(|l| {
            l.residuals
                .as_ref()
                .and_then(|r| r.get("natural_map_rel"))
                .and_then(Value::as_f64)
        })
        .collect();
    let status: Vec<&str> = s
        .iter()
        .map(|l| {
            l.status
                .get("status")
                .and_then(Value::as_str)
                .unwrap_or("?")
        })
        .collect();
    let mut out = json!({
        "step": s.iter().map(|l| l.step).collect::<Vec<_>>(),
        "time": s.iter().map(|l| l.time).collect::<Vec<_>>(),
        "residual": residual,
        "iterations": s.iter().map(|l| l.iterations).collect::<Vec<_>>(),
        "solve_time": s.iter().map(|l| l.solve_time_s).collect::<Vec<_>>(),
        "energy": s.iter().map(|l| l.kinetic_energy + l.potential_energy).collect::<Vec<_>>(),
        "penetration": s.iter().map(|l| l.max_penetration).collect::<Vec<_>>(),
        "contacts": s.iter().map(|l| l.contact_records.len()).collect::<Vec<_>>(),
        "status": status,
    });
    if rec.has_joints() {
        out["joint_drift"] = json!(s.iter().map(|l| l.joint_drift_max).collect::<Vec<_>>());
    }
    out
}

/// The page data of one run: header, series, and frames decimated so that the whole takes at
/// most `bytes` bytes of JSON (at least one frame in ten kilobytes is always kept).
pub fn run_data(rec: &Recording, label: &str, bytes: usize) -> Value {
    let index: HashMap<&str, usize> = rec
        .header
        .bodies
        .iter()
        .enumerate()
        .rev()
        .map(|(i, b)| (b.name.as_str(), i))
        .collect();
    let mut data = run_header(rec, label);
    let frame_bytes = bytes.saturating_sub(data.to_string().len()).max(10_000);
    let joints = rec.has_joints();
    let frames: Vec<String> = rec
        .steps
        .iter()
        .map(|s| frame(rec, &index, s, joints).to_string())
        .collect();
    let total: usize = frames.iter().map(|f| f.len() + 1).sum();
    // Room for the extra last frame kept after the stride.
    let largest = frames.iter().map(|f| f.len() + 1).max().unwrap_or(0);
    let stride = if total <= frame_bytes {
        1
    } else {
        total.div_ceil(frame_bytes.saturating_sub(largest).max(1))
    };
    let n = frames.len();
    let kept: Vec<&str> = frames
        .iter()
        .enumerate()
        .filter(|(i, _)| i % stride == 0 || *i + 1 == n)
        .map(|(_, f)| f.as_str())
        .collect();
    // The frames are spliced in as raw JSON to avoid parsing them again.
    let frames_raw = format!("[{}]", kept.join(","));
    data["frames"] = serde_json::from_str(&frames_raw).unwrap_or(Value::Null);
    data["steps_total"] = json!(n);
    data["stride"] = json!(stride);
    data
}

/// Everything of a run's page data but its frames.
fn run_header(rec: &Recording, label: &str) -> Value {
    let shapes: Vec<&Value> = rec.header.bodies.iter().map(|b| &b.shape).collect();
    let (geometries, geometry_of) = dedupe(&shapes);
    let bodies: Vec<Value> = rec
        .header
        .bodies
        .iter()
        .zip(&geometry_of)
        .map(|(b, g)| json!({ "name": b.name, "static": b.is_static, "geometry": g }))
        .collect();
    json!({
        "label": label,
        "source": rec.source.display().to_string(),
        "scene": rec.header.scene,
        "solver": rec.header.solver,
        "dt": rec.header.dt,
        "tolerance": rec.header.tolerance,
        "steps_total": rec.steps.len(),
        "stride": 1,
        "geometries": geometries,
        "bodies": bodies,
        "series": series(rec),
    })
}

/// Distinct shapes and, per body, the index of its shape.
fn dedupe(shapes: &[&Value]) -> (Vec<Value>, Vec<usize>) {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut distinct = Vec::new();
    let of = shapes
        .iter()
        .map(|s| {
            *seen.entry(s.to_string()).or_insert_with(|| {
                distinct.push((*s).clone());
                distinct.len() - 1
            })
        })
        .collect();
    (distinct, of)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact(fn_: f64, ft: f64, vt: f64, compl: f64) -> ContactLine {
        ContactLine {
            bodies: ["a".into(), "b".into()],
            point: [0.0; 3],
            normal: [0.0, 0.0, 1.0],
            dist: 0.0,
            impulse: [ft, 0.0, fn_],
            normal_impulse: fn_,
            tangent_impulse: [ft, 0.0, 0.0],
            relative_velocity: [vt, 0.0, 0.0],
            mu: 0.5,
            normal_rate: 0.0,
            complementarity: compl,
        }
    }

    #[test]
    fn contacts_are_classified_by_impulse_slip_and_complementarity() {
        let s = |c: ContactLine| contact_status(&c, 1e-6, 1.0);
        assert_eq!(s(contact(0.0, 0.0, 0.3, 0.0)), ContactStatus::Separating);
        assert_eq!(s(contact(1.0, 0.2, 0.0, 0.0)), ContactStatus::Sticking);
        assert_eq!(s(contact(1.0, 0.5, 0.3, 0.0)), ContactStatus::Sliding);
        // Both f_n and w_n positive: complementarity violated.
        assert_eq!(s(contact(1.0, 0.0, 0.0, 0.4)), ContactStatus::Violated);
        // Outside the friction cone.
        assert_eq!(s(contact(1.0, 0.9, 0.3, 0.0)), ContactStatus::Violated);
        assert_eq!(s(contact(-0.1, 0.0, 0.0, -0.1)), ContactStatus::Violated);
    }

    /// The header and `steps` step lines of `scene` (a file of `bench_scenes/`) run with
    /// dantzig, each step's report edited by `edit` before it is written; and the reports.
    fn record(
        scene: &str,
        steps: usize,
        edit: impl Fn(&mut StepReport),
    ) -> (Vec<String>, Vec<StepReport>) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("bench_scenes")
            .join(scene);
        let scene = lcpbench_contact::Scene::load(&path).unwrap();
        let mut world = scene.world();
        world.set_solver(lcpbench_contact::ContactSolver::from_name("dantzig").unwrap());
        let mut lines = vec![header(&scene.name, &world).to_string()];
        let mut reports = Vec::new();
        for _ in 0..steps {
            let mut report = world.step();
            edit(&mut report);
            lines.push(step_line(&report, &world).to_string());
            reports.push(report);
        }
        (lines, reports)
    }

    fn read(lines: &[String]) -> Result<Recording, ViewError> {
        Recording::from_lines(Path::new("r.jsonl"), lines.iter().cloned().map(Ok))
    }

    /// A step line whose history is compacted (as `simulate --html` keeps it) gives the same
    /// page frame as the full line, and the step read back holds the page form only.
    #[test]
    fn compacted_histories_give_the_same_frames_in_a_few_kilobytes() {
        let (lines, _) = record("box_on_ground.toml", 3, |r| {
            r.history = (0..5000)
                .map(|i| lcpbench_solvers::HistoryPoint {
                    iteration: i,
                    residual: 1.0 / (1.0 + i as f64),
                    time_s: 1e-6 * i as f64,
                })
                .collect();
        });
        let compact: Vec<String> = lines
            .iter()
            .map(|l| {
                let mut v: Value = serde_json::from_str(l).unwrap();
                compact_history(&mut v);
                v.to_string()
            })
            .collect();
        assert!(
            compact[1].len() * 10 < lines[1].len(),
            "{}",
            compact[1].len()
        );
        let (full, small) = (read(&lines).unwrap(), read(&compact).unwrap());
        for rec in [&full, &small] {
            assert!(rec.steps.iter().all(|s| s.history.is_empty()));
            let page = rec.steps[0].page_history.as_deref().unwrap();
            assert!(page.len() < 8_000, "{}", page.len());
        }
        let (a, b) = (
            run_data(&full, "x", 10_000_000),
            run_data(&small, "x", 10_000_000),
        );
        assert_eq!(a["frames"], b["frames"]);
        let history = &a["frames"][0]["history"];
        assert_eq!(history["thinned_from"], json!(5000));
        assert!(history["it"].as_array().unwrap().len() <= MAX_HISTORY_POINTS + 1);
    }

    #[test]
    fn joints_are_read_back_and_sent_to_the_page_with_their_anchors() {
        let (lines, reports) = record("joints/chain_20_1e3.toml", 3, |_| {});
        let rec = read(&lines).unwrap();
        assert!(rec.has_joints());
        let data = run_data(&rec, "dantzig", 10_000_000);
        let frames = data["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 3);
        for ((frame, report), line) in frames.iter().zip(&reports).zip(&rec.steps) {
            assert_eq!(line.joints, report.joints);
            assert_eq!(line.joint_drift_max, report.joint_drift_max);
            let joints = frame["joints"].as_array().unwrap();
            assert!(report.joints > 0 && report.joint_records.len() == report.joints);
            assert_eq!(joints.len(), JOINT_FIELDS * report.joint_records.len());
            for (j, r) in joints.chunks(JOINT_FIELDS).zip(&report.joint_records) {
                let sent: Vec<f32> = j.iter().map(|x| x.as_f64().unwrap() as f32).collect();
                let anchors: Vec<f32> = r.anchors.iter().flatten().map(|&x| x as f32).collect();
                assert_eq!(sent[..6], anchors[..], "joint {}", r.name);
                assert_eq!(sent[6], r.error.linear as f32);
                assert_eq!(sent[7], r.error.angular as f32);
                assert_eq!(sent[8], r.impulse as f32);
                assert_eq!(sent[9], 0.0, "a ball joint");
            }
        }
        let drift = data["series"]["joint_drift"].as_array().unwrap();
        assert_eq!(drift[2].as_f64(), Some(reports[2].joint_drift_max));
    }

    #[test]
    fn pages_of_runs_without_joints_carry_no_joint_data() {
        let (lines, _) = record("box_on_ground.toml", 3, |_| {});
        let rec = read(&lines).unwrap();
        assert!(!rec.has_joints());
        let data = run_data(&rec, "dantzig", 10_000_000);
        for frame in data["frames"].as_array().unwrap() {
            assert!(frame.get("joints").is_none(), "{frame}");
        }
        assert!(data["series"].get("joint_drift").is_none());
        // A line written before joints were recorded reads the same.
        let mut old: Value = serde_json::from_str(&lines[1]).unwrap();
        let fields = old.as_object_mut().unwrap();
        fields.retain(|k, _| !k.starts_with("joint"));
        let old = [lines[0].clone(), old.to_string()];
        assert_eq!(read(&old).unwrap().steps[0].joint_drift_max, 0.0);
    }

    #[test]
    fn bad_joint_records_are_refused_naming_the_line() {
        let refused = |edit: fn(&mut StepReport)| {
            let (lines, _) = record("joints/chain_20_1e3.toml", 2, |r| {
                if r.step == 1 {
                    edit(r)
                }
            });
            read(&lines).unwrap_err().to_string()
        };
        // serde_json writes a NaN as `null`.
        let e = refused(|r| r.joint_records[4].anchors[1][2] = f64::NAN);
        assert!(
            e.contains("r.jsonl: line 3: step 1: joint_records[4] (\"")
                && e.contains("anchors[1] must be 3 finite numbers"),
            "{e}"
        );
        // Finite in f64 but beyond f32: the page would place the anchor at infinity.
        let e = refused(|r| r.joint_records[2].anchors[0][0] = 1e300);
        assert!(
            e.contains("r.jsonl: line 3: step 1: joint_records[2] (\"")
                && e.contains("anchors[0] must be 3 finite numbers within ±3.4028235e38"),
            "{e}"
        );
        let e = refused(|r| r.joint_records[0].kind = "slider");
        assert!(
            e.contains("line 3: ") && e.contains("unknown joint kind \"slider\""),
            "{e}"
        );
        let e = refused(|r| r.joint_records[0].error.linear = -1.0);
        assert!(
            e.contains("error.linear must be finite and not negative, got -1"),
            "{e}"
        );
        let e = refused(|r| r.joint_drift_max = f64::INFINITY);
        assert!(
            e.contains("line 3: step 1: joint_drift_max must be finite"),
            "{e}"
        );
    }

    #[test]
    fn page_numbers_are_short_and_read_back_as_the_same_f32() {
        let values = [0.1f32, 5.959_888e-6, -3.0, 2.0, 1e-30, 123_456.79, f32::NAN];
        let text = page_numbers(&values).to_string();
        assert_eq!(text, "[0.1,5.959888e-6,-3,2,1e-30,123456.79,null]");
        let back: Vec<Option<f64>> = serde_json::from_str(&text).unwrap();
        for (x, y) in values.iter().zip(back).take(6) {
            assert_eq!(y.map(|y| y as f32), Some(*x));
        }
    }

    #[test]
    fn long_histories_are_thinned_keeping_the_last_point() {
        let h: Vec<Value> = (0..1000)
            .map(|i| json!({"iteration": i, "residual": 1.0 / (1.0 + i as f64), "time_s": 0.0}))
            .collect();
        let v = history_json(&h);
        let its = v["it"].as_array().unwrap();
        assert!(its.len() <= MAX_HISTORY_POINTS + 1);
        assert_eq!(its.last().unwrap().as_f64(), Some(999.0));
        assert_eq!(v["thinned_from"], json!(1000));
        assert!(v.get("extra").is_none());
        let h: Vec<Value> = (0..3)
            .map(|i| json!({"iteration": i, "residual": 1.0, "time_s": 0.0, "active_set": [i]}))
            .collect();
        let v = history_json(&h);
        assert_eq!(v["extra_key"], json!("active_set"));
        assert_eq!(v["extra"][2], json!([2]));
    }
}

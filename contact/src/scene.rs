//! Scene files (TOML): bodies, materials, settings, events and expected metrics of a
//! simulation, as data. The format is documented once, in `docs/scenes.md` (every key, its
//! default and its limits); [`Scene::load`] reads it.
//!
//! Every table rejects unknown keys; every error names the file, the field and what is wrong
//! (with the line for syntax and type errors). Each setting with a set of names is parsed by one
//! function that the command line shares: [`FrictionModel::parse`],
//! [`PositionCorrection::from_name`], [`ToiMethod::from_ccd_name`],
//! [`ContactSolver::from_name`].

use crate::body::{MassSpec, RigidBody};
use crate::body_solvers::Penalty;
use crate::builder::{BuilderParams, FrictionModel, Material, PositionCorrection};
use crate::collision::toi::ToiMethod;
use crate::shape::Shape;
use crate::step::{ContactSolver, Event, SimSettings, World};
use lcpbench_solvers::metrics::MIN_TOLERANCE;
use nalgebra::{Point3, Quaternion, Unit, UnitQuaternion, Vector3};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Largest number of bodies a scene may have (repeats expanded). The contact problem of a
/// scene grows with its contacts; beyond this the assembled problem no longer fits in memory
/// on an ordinary machine, so the loader refuses the scene before building anything.
pub const MAX_BODIES: usize = 10_000;

/// Largest `steps` of a scene (and of `--steps`): at `dt = 0.01` that is 10⁴ s of simulation.
pub const MAX_STEPS: usize = 1_000_000;

/// Largest `pyramid_directions`: each contact of the pyramid model has `directions + 2` rows.
pub use crate::builder::MAX_PYRAMID_DIRECTIONS;

/// Smallest and largest time step `dt`, s.
pub const DT_RANGE: (f64, f64) = (1e-6, 0.1);

/// Largest gravity magnitude, m/s² (a thousand times Earth's).
pub const MAX_GRAVITY: f64 = 1e4;

/// Largest speed of a body, m/s, and angular speed, rad/s, in a scene file.
pub const MAX_SPEED: f64 = 1e4;

/// Largest coordinate of a body position, m (beyond it `f64` keeps less than a micrometre).
pub const MAX_COORDINATE: f64 = 1e9;

/// Smallest and largest body mass, kg (from `mass`, or from `density` and the volume).
pub const MASS_RANGE: (f64, f64) = (1e-9, 1e15);

/// Smallest and largest size of a body, m: every half extent of its bounding box (a sphere's
/// radius, a box's half extents, ...). Beyond them volumes and inertias leave `f64`'s range or
/// drown in round-off, and a "mass 0 kg" would be all a message could say.
pub const SIZE_RANGE: (f64, f64) = (1e-6, 1e6);

/// Largest `prediction_distance` and `slop`, m: contacts closer than the prediction distance
/// enter the problem, so a larger one pairs every body with every body near it.
pub const MAX_CONTACT_DISTANCE: f64 = 1.0;

/// Largest Coulomb coefficient of a material (real ones are below a few).
pub const MAX_MU: f64 = 100.0;

/// Largest `penalty_omega_h`: a spring integrated over a step of `h` is stable only for
/// `ω h < 2`.
pub const MAX_PENALTY_OMEGA_H: f64 = 2.0;

/// Largest `penalty_damping_ratio` and `penalty_stiffness` (N/m): beyond them the penalty force
/// of a millimetre's overlap leaves `f64`'s useful range.
pub const MAX_PENALTY_DAMPING_RATIO: f64 = 100.0;

/// See [`MAX_PENALTY_DAMPING_RATIO`].
pub const MAX_PENALTY_STIFFNESS: f64 = 1e20;

/// Largest scene file read, bytes (10,000 bodies written out one by one take a few megabytes).
pub const MAX_SCENE_FILE_BYTES: u64 = 16_000_000;

/// How deep, as a fraction of its bounding radius ([`Shape::bounding_radius`]: the farthest
/// point of its surface from its centre of mass), a body may start inside another (the smaller
/// radius of the two counts). Deeper, the contact normal no longer tells which way out is (a
/// box 1,000 m below the ground "converges" while its energy goes from −1e7 to 2e11 J, two
/// coincident spheres fly apart).
pub const MAX_INITIAL_OVERLAP: f64 = 1.0;

/// Options of [`Scene::load_with`] and [`Scene::parse_with`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Accept mesh files outside the scene's directory tree (absolute paths, `..`, symbolic
    /// links leading out) \[`false`\]: a scene from someone else should not read the rest of
    /// the disk.
    pub allow_outside_paths: bool,
}

/// A number as a person would write it: plain for ordinary magnitudes, in exponent form for
/// tiny and huge ones (`1e-300`, not three hundred zeros).
pub fn readable(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A scene file that cannot be used.
#[derive(Debug, Error)]
pub enum SceneError {
    /// The file cannot be read.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// TOML syntax error, unknown key or wrong type.
    #[error("{path}:{line}:{column}: {context}{message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// `in [[bodies]] #3: ` or empty.
        context: String,
        /// What is wrong.
        message: String,
    },
    /// A value that parses but is not allowed.
    #[error("{path}: {field}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Path of the field, e.g. `bodies[2] ("ball").shape.radius`.
        field: String,
        /// What is wrong.
        message: String,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    description: String,
    #[serde(default)]
    settings: SettingsFile,
    #[serde(default)]
    materials: Vec<MaterialFile>,
    #[serde(default)]
    bodies: Vec<BodyFile>,
    #[serde(default)]
    events: Vec<EventFile>,
    #[serde(default)]
    metrics: SceneMetrics,
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
struct SettingsFile {
    dt: f64,
    steps: usize,
    gravity: [f64; 3],
    friction_model: String,
    pyramid_directions: usize,
    solver: Option<String>,
    tolerance: f64,
    max_iterations: usize,
    warm_start: bool,
    islands: bool,
    restitution_threshold: f64,
    position_correction: String,
    baumgarte: f64,
    slop: f64,
    prediction_distance: f64,
    penalty_omega_h: f64,
    penalty_damping_ratio: f64,
    penalty_stiffness: Option<f64>,
    ccd: String,
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
            penalty_omega_h: b.omega_h,
            penalty_damping_ratio: b.damping_ratio,
            penalty_stiffness: None,
            ccd: "none".into(),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    name: String,
    #[serde(default = "default_mu")]
    mu: f64,
    #[serde(default)]
    restitution: f64,
}

fn default_mu() -> f64 {
    0.5
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum ShapeFile {
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
struct AxisAngleFile {
    axis: [f64; 3],
    degrees: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RepeatFile {
    count: [usize; 3],
    spacing: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BodyFile {
    name: String,
    shape: ShapeFile,
    density: Option<f64>,
    mass: Option<f64>,
    #[serde(default)]
    position: [f64; 3],
    orientation: Option<[f64; 4]>,
    axis_angle: Option<AxisAngleFile>,
    #[serde(default)]
    velocity: [f64; 3],
    #[serde(default)]
    angular_velocity: [f64; 3],
    #[serde(default, rename = "static")]
    is_static: bool,
    material: Option<String>,
    repeat: Option<RepeatFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EventFile {
    at_step: usize,
    remove: String,
}

/// A loaded scene: ready-made bodies and settings, plus the metrics table.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The file it came from.
    pub path: PathBuf,
    /// Scene name (default: the file stem).
    pub name: String,
    /// Free text.
    pub description: String,
    /// Simulation settings.
    pub settings: SimSettings,
    /// Materials.
    pub materials: Vec<Material>,
    /// Bodies, repeats expanded.
    pub bodies: Vec<RigidBody>,
    /// For each body, the name of the scene entry it came from.
    pub groups: Vec<String>,
    /// Events.
    pub events: Vec<Event>,
    /// The penalty parameters of `[settings]` (`penalty_*`), used whenever the scene runs the
    /// `penalty` solver ([`Scene::solver_from_name`]).
    pub penalty: Penalty,
    /// The `[metrics]` table.
    pub metrics: SceneMetrics,
}

/// 1-based line and column of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rfind('\n').map_or(offset, |p| offset - p - 1) + 1;
    (line, column)
}

/// The key of a `key = value` line when `column` points into the value.
fn key_at(text: &str, line: usize, column: usize) -> Option<String> {
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
fn table_context(text: &str, offset: usize) -> String {
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

impl Scene {
    /// Load a scene file (mesh files inside its directory tree only).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        Self::load_with(path, &LoadOptions::default())
    }

    /// Load a scene file with `options`. The file must be a regular file of at most
    /// [`MAX_SCENE_FILE_BYTES`].
    pub fn load_with(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let io = |error| SceneError::Io {
            path: path.to_owned(),
            error,
        };
        let bytes =
            lcpbench_solvers::io::input::read_input_file(path, MAX_SCENE_FILE_BYTES).map_err(io)?;
        let text = String::from_utf8(bytes).map_err(|e| {
            io(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("not UTF-8 text: {e}"),
            ))
        })?;
        Self::parse_with(&text, path, options)
    }

    /// Parse scene text; `path` names the file in errors and anchors mesh paths (mesh files
    /// inside its directory tree only).
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        Self::parse_with(text, path, &LoadOptions::default())
    }

    /// Parse scene text with `options`; `path` names the file in errors and anchors mesh paths.
    pub fn parse_with(text: &str, path: &Path, options: &LoadOptions) -> Result<Self, SceneError> {
        let file: SceneFile = toml::from_str(text).map_err(|e| {
            let offset = e.span().map_or(0, |s| s.start);
            let (line, column) = line_column(text, offset);
            let mut context = table_context(text, offset);
            let message = e.message().trim().to_owned();
            if !message.contains("field") {
                if let Some(key) = key_at(text, line, column) {
                    context.push_str(&format!("field `{key}`: "));
                }
            }
            SceneError::Parse {
                path: path.to_owned(),
                line,
                column,
                context,
                message,
            }
        })?;
        let invalid = |field: String, message: String| SceneError::Invalid {
            path: path.to_owned(),
            field,
            message,
        };
        let (settings, penalty) =
            convert_settings(&file.settings).map_err(|(f, m)| invalid(f, m))?;
        let materials = convert_materials(&file.materials).map_err(|(f, m)| invalid(f, m))?;
        let total = count_bodies(&file.bodies).map_err(|(f, m)| invalid(f, m))?;
        let dir = Some(path.parent().unwrap_or(Path::new(".")))
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let files = MeshFiles { dir, options };
        let (bodies, groups) = convert_bodies(&file.bodies, &materials, &files, total)
            .map_err(|(f, m)| invalid(f, m))?;
        let events =
            convert_events(&file.events, &bodies, &groups).map_err(|(f, m)| invalid(f, m))?;

        if bodies.is_empty() {
            return Err(invalid(
                "bodies".into(),
                "the scene has no bodies (add at least one [[bodies]] table)".into(),
            ));
        }
        check_initial_overlap(&bodies, &groups, &file.bodies, settings.prediction_distance)
            .map_err(|(f, m)| invalid(f, m))?;
        let name = file.name.unwrap_or_else(|| {
            path.file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
        });
        Ok(Scene {
            path: path.to_owned(),
            name,
            description: file.description,
            settings,
            materials,
            bodies,
            groups,
            events,
            penalty,
            metrics: file.metrics,
        })
    }

    /// The solver of this name with default parameters, except `penalty`, which takes the
    /// scene's `penalty_*` settings.
    pub fn solver_from_name(&self, name: &str) -> Option<ContactSolver> {
        solver_from_name(name, self.penalty)
    }

    /// The body-level solver `kind` with default parameters, except `penalty`, which takes the
    /// scene's `penalty_*` settings.
    pub fn body_solver(&self, kind: crate::BodySolverKind) -> ContactSolver {
        body_solver(kind, self.penalty)
    }

    /// A world ready to step.
    pub fn world(&self) -> World {
        let mut world = World::new(
            self.bodies.clone(),
            self.materials.clone(),
            self.settings.clone(),
        );
        world.groups = self.groups.clone();
        world.events = self.events.clone();
        world
    }
}

/// Check that `solver` can run the scene's friction model ([`ContactSolver::supports`]): a
/// body-level solver takes `none` or `box`, a matrix solver every model but `cone`, a cone
/// solver only `cone`.
pub fn check_solver(solver: &ContactSolver, friction: FrictionModel) -> Result<(), String> {
    solver.supports(friction)
}

/// The solver of a scene that names none: `pgs`, or `nsgs-cone` for the cone model.
pub fn default_solver(friction: FrictionModel) -> ContactSolver {
    match friction {
        FrictionModel::Cone => lcpbench_solvers::ConeSolverKind::NsgsCone.into(),
        _ => SimSettings::default().solver,
    }
}

/// [`ContactSolver::from_name`], with `penalty` built from the given parameters.
fn solver_from_name(name: &str, penalty: Penalty) -> Option<ContactSolver> {
    match crate::BodySolverKind::from_name(name) {
        Some(kind) => Some(body_solver(kind, penalty)),
        None => ContactSolver::from_name(name),
    }
}

/// The body-level solver `kind`, with `penalty` built from the given parameters.
fn body_solver(kind: crate::BodySolverKind, penalty: Penalty) -> ContactSolver {
    match kind {
        crate::BodySolverKind::Penalty => ContactSolver::Body(Box::new(penalty)),
        kind => kind.into(),
    }
}

type FieldError = (String, String);

/// The `[[materials]]` tables (one default material when there are none).
fn convert_materials(files: &[MaterialFile]) -> Result<Vec<Material>, FieldError> {
    let mut materials = Vec::new();
    for (i, m) in files.iter().enumerate() {
        let field = |f: &str| format!("materials[{i}] (\"{}\").{f}", m.name);
        if !(m.mu.is_finite() && (0.0..=MAX_MU).contains(&m.mu)) {
            return Err((
                field("mu"),
                format!("must be between 0 and {MAX_MU}, got {}", readable(m.mu)),
            ));
        }
        if !(0.0..=1.0).contains(&m.restitution) {
            return Err((
                field("restitution"),
                format!("must be in [0, 1], got {}", m.restitution),
            ));
        }
        if materials.iter().any(|x: &Material| x.name == m.name) {
            return Err((field("name"), "is defined twice".into()));
        }
        materials.push(Material {
            name: m.name.clone(),
            mu: m.mu,
            restitution: m.restitution,
        });
    }
    if materials.is_empty() {
        materials.push(Material::default());
    }
    Ok(materials)
}

/// The number of bodies with repeats expanded, refused above [`MAX_BODIES`] before any is
/// built.
fn count_bodies(files: &[BodyFile]) -> Result<usize, FieldError> {
    let mut total: usize = 0;
    for (i, b) in files.iter().enumerate() {
        let copies = match &b.repeat {
            Some(r) => r.count.iter().try_fold(1usize, |p, &c| p.checked_mul(c)),
            None => Some(1),
        };
        total = match copies.and_then(|c| total.checked_add(c)) {
            Some(t) if t <= MAX_BODIES => t,
            _ => {
                let field = if b.repeat.is_some() {
                    format!("bodies[{i}] (\"{}\").repeat.count", b.name)
                } else {
                    "bodies".into()
                };
                return Err((
                    field,
                    format!(
                        "the scene would have more than {MAX_BODIES} bodies (the limit; \
                         the contact problem of more would not fit in memory)"
                    ),
                ));
            }
        };
    }
    Ok(total)
}

/// The `[[bodies]]` tables, repeats expanded: the bodies and, for each, its entry's name.
fn convert_bodies(
    files: &[BodyFile],
    materials: &[Material],
    meshes: &MeshFiles,
    total: usize,
) -> Result<(Vec<RigidBody>, Vec<String>), FieldError> {
    let mut bodies = Vec::with_capacity(total);
    let mut groups = Vec::with_capacity(total);
    let mut names = std::collections::HashSet::with_capacity(total);
    for (i, b) in files.iter().enumerate() {
        let at = |f: &str| {
            if f.is_empty() {
                format!("bodies[{i}] (\"{}\")", b.name)
            } else {
                format!("bodies[{i}] (\"{}\").{f}", b.name)
            }
        };
        let made = convert_body(b, materials, meshes).map_err(|(f, m)| (at(&f), m))?;
        for body in made {
            if !names.insert(body.name.clone()) {
                return Err((
                    at("name"),
                    format!("body name \"{}\" is used twice", body.name),
                ));
            }
            bodies.push(body);
            groups.push(b.name.clone());
        }
    }
    Ok((bodies, groups))
}

/// The `[[events]]` tables; each fires at a step a run can reach (below [`MAX_STEPS`]) and
/// removes a body (or repeated entry) that exists and that no earlier event has removed.
fn convert_events(
    files: &[EventFile],
    bodies: &[RigidBody],
    groups: &[String],
) -> Result<Vec<Event>, FieldError> {
    let mut events = Vec::new();
    for (i, e) in files.iter().enumerate() {
        if e.at_step >= MAX_STEPS {
            return Err((
                format!("events[{i}].at_step"),
                format!(
                    "must be below {MAX_STEPS} (the most steps a run takes), got {}",
                    e.at_step
                ),
            ));
        }
        if !bodies
            .iter()
            .zip(groups)
            .any(|(b, g)| b.name == e.remove || *g == e.remove)
        {
            return Err((
                format!("events[{i}].remove"),
                format!("no body named \"{}\"", e.remove),
            ));
        }
        events.push(Event {
            at_step: e.at_step,
            remove: e.remove.clone(),
        });
    }
    check_removed_once(&events, bodies, groups)?;
    Ok(events)
}

/// Every event removes at least one body still there when it fires (events fire in step
/// order; at one step, in file order): removing a body twice is a mistake in the file.
fn check_removed_once(
    events: &[Event],
    bodies: &[RigidBody],
    groups: &[String],
) -> Result<(), FieldError> {
    let mut order: Vec<usize> = (0..events.len()).collect();
    order.sort_by_key(|&i| events[i].at_step);
    // For each body, the event that removed it.
    let mut removed_by: Vec<Option<usize>> = vec![None; bodies.len()];
    for i in order {
        let e = &events[i];
        let targets: Vec<usize> = (0..bodies.len())
            .filter(|&k| bodies[k].name == e.remove || groups[k] == e.remove)
            .collect();
        if let Some(earlier) = targets
            .iter()
            .map(|&k| removed_by[k])
            .collect::<Option<Vec<_>>>()
            .and_then(|by| by.first().copied())
        {
            return Err((
                format!("events[{i}].remove"),
                format!(
                    "\"{}\" is already removed at step {} by events[{earlier}]; a body is \
                     removed once",
                    e.remove, events[earlier].at_step
                ),
            ));
        }
        for k in targets {
            removed_by[k].get_or_insert(i);
        }
    }
    Ok(())
}

/// `settings.{field}` must be a positive finite number.
fn positive(field: &str, v: f64) -> Result<f64, FieldError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err((
            format!("settings.{field}"),
            format!("must be a positive number, got {v}"),
        ))
    }
}

/// `settings.{field}` must be a finite number `>= 0`.
fn non_negative(field: &str, v: f64) -> Result<f64, FieldError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err((
            format!("settings.{field}"),
            format!("must be >= 0, got {v}"),
        ))
    }
}

/// `settings.{field}` must be a distance from 0 to [`MAX_CONTACT_DISTANCE`].
fn contact_distance(field: &str, v: f64) -> Result<f64, FieldError> {
    let v = non_negative(field, v)?;
    if v > MAX_CONTACT_DISTANCE {
        return Err((
            format!("settings.{field}"),
            format!(
                "must be at most {MAX_CONTACT_DISTANCE} m, got {} m",
                readable(v)
            ),
        ));
    }
    Ok(v)
}

/// `dt`, `steps` and `gravity` within their limits; returns `dt`.
fn check_clock(s: &SettingsFile) -> Result<f64, FieldError> {
    let err = |f: &str, m: String| (format!("settings.{f}"), m);
    let dt = positive("dt", s.dt)?;
    if !(DT_RANGE.0..=DT_RANGE.1).contains(&dt) {
        return Err(err(
            "dt",
            format!(
                "must be between {} and {} s, got {}",
                readable(DT_RANGE.0),
                DT_RANGE.1,
                readable(dt)
            ),
        ));
    }
    if s.steps == 0 || s.steps > MAX_STEPS {
        return Err(err(
            "steps",
            format!("must be between 1 and {MAX_STEPS}, got {}", s.steps),
        ));
    }
    let g = magnitude(s.gravity);
    if !(g.is_finite() && g <= MAX_GRAVITY) {
        return Err(err(
            "gravity",
            format!(
                "magnitude must be at most {} m/s², got {}",
                readable(MAX_GRAVITY),
                readable(g)
            ),
        ));
    }
    Ok(dt)
}

fn convert_settings(s: &SettingsFile) -> Result<(SimSettings, Penalty), FieldError> {
    let err = |f: &str, m: String| (format!("settings.{f}"), m);
    let dt = check_clock(s)?;
    let friction_model = FrictionModel::parse(&s.friction_model, s.pyramid_directions).map_err(
        |(directions, m)| {
            let field = if directions {
                "pyramid_directions"
            } else {
                "friction_model"
            };
            err(field, m)
        },
    )?;
    let position_correction = PositionCorrection::from_name(&s.position_correction)
        .map_err(|m| err("position_correction", m))?;
    let penalty = Penalty {
        omega_h: at_most(
            "penalty_omega_h",
            positive("penalty_omega_h", s.penalty_omega_h)?,
            MAX_PENALTY_OMEGA_H,
            "",
        )?,
        damping_ratio: at_most(
            "penalty_damping_ratio",
            s.penalty_damping_ratio,
            MAX_PENALTY_DAMPING_RATIO,
            "",
        )?,
        stiffness: s.penalty_stiffness,
    };
    let solver = match &s.solver {
        None => default_solver(friction_model),
        Some(name) => solver_from_name(name, penalty).ok_or_else(|| {
            err(
                "solver",
                format!(
                    "unknown solver \"{name}\" (known: {})",
                    ContactSolver::all_names()
                ),
            )
        })?,
    };
    check_solver(&solver, friction_model).map_err(|m| err("solver", m))?;
    let baumgarte = non_negative("baumgarte", s.baumgarte)?;
    if baumgarte > 1.0 {
        return Err(err(
            "baumgarte",
            format!("must be in [0, 1], got {baumgarte}"),
        ));
    }
    if let Some(k) = s.penalty_stiffness {
        at_most(
            "penalty_stiffness",
            positive("penalty_stiffness", k)?,
            MAX_PENALTY_STIFFNESS,
            " N/m",
        )?;
    }
    let ccd = ToiMethod::from_ccd_name(&s.ccd).map_err(|m| err("ccd", m))?;
    if s.max_iterations == 0 {
        return Err(err("max_iterations", "must be at least 1".into()));
    }
    let settings = SimSettings {
        dt,
        steps: s.steps,
        gravity: s.gravity.into(),
        solver,
        tolerance: tolerance(s.tolerance).map_err(|m| err("tolerance", m))?,
        max_iterations: s.max_iterations,
        warm_start: s.warm_start,
        islands: s.islands,
        prediction_distance: contact_distance("prediction_distance", s.prediction_distance)?,
        builder: BuilderParams {
            friction_model,
            restitution_threshold: at_most(
                "restitution_threshold",
                s.restitution_threshold,
                MAX_SPEED,
                " m/s",
            )?,
            position_correction,
            baumgarte,
            slop: contact_distance("slop", s.slop)?,
        },
        ccd,
        keep_problem: false,
        residuals: true,
        record_history: false,
        step_time_budget: None,
        deadline: None,
    };
    Ok((settings, penalty))
}

/// A tolerance on the relative residual: a number in `(0, 1)` (a relative residual of 1 is met
/// by a zero impulse, so a tolerance of 1 or more would claim convergence for nothing), and at
/// least [`MIN_TOLERANCE`] (below it the relative residual of a correctly rounded solution is
/// round-off, so the tolerance would be met only by chance).
pub fn tolerance(tol: f64) -> Result<f64, String> {
    if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
        Err(format!(
            "must be a number in (0, 1) on the relative residual, got {}",
            readable(tol)
        ))
    } else if tol < MIN_TOLERANCE {
        Err(format!(
            "{} is below {MIN_TOLERANCE:e}: the relative residual of a correctly rounded \
             solution is about 4 (nnz + 1) ε per row, so a smaller tolerance would be met only by \
             chance",
            readable(tol)
        ))
    } else {
        Ok(tol)
    }
}

/// `settings.{field}`, a number in `[0, max]`.
fn at_most(field: &str, v: f64, max: f64, unit: &str) -> Result<f64, FieldError> {
    let v = non_negative(field, v)?;
    if v > max {
        return Err((
            format!("settings.{field}"),
            format!(
                "must be at most {}{unit}, got {}",
                readable(max),
                readable(v)
            ),
        ));
    }
    Ok(v)
}

/// Euclidean length of `v`, or its largest component when the length overflows (so a message
/// can show `1e300` rather than `inf`).
fn magnitude(v: [f64; 3]) -> f64 {
    let norm = vec3(v).norm();
    if norm.is_finite() || v.iter().any(|x| !x.is_finite()) {
        norm
    } else {
        v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
    }
}

fn vec3(v: [f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

/// Where a scene's mesh files may come from.
struct MeshFiles<'a> {
    /// The scene file's directory.
    dir: &'a Path,
    options: &'a LoadOptions,
}

impl MeshFiles<'_> {
    /// The path of the mesh file `file`: relative to the scene file and, unless
    /// [`LoadOptions::allow_outside_paths`], inside the scene's directory tree once symbolic
    /// links are followed.
    fn resolve(&self, file: &str) -> Result<PathBuf, String> {
        let path = self.dir.join(file);
        if self.options.allow_outside_paths {
            return Ok(path);
        }
        let outside = |what: String| {
            format!(
                "mesh file \"{file}\" {what}; mesh files are given relative to the scene file \
                 and must lie in its directory tree (lcpbench simulate --allow-outside-paths \
                 reads others)"
            )
        };
        if Path::new(file).is_absolute() {
            return Err(outside("is an absolute path".into()));
        }
        let cannot = |e: std::io::Error| format!("cannot read mesh file {}: {e}", path.display());
        let root = self.dir.canonicalize().map_err(cannot)?;
        let real = path.canonicalize().map_err(cannot)?;
        if !real.starts_with(&root) {
            return Err(outside(format!(
                "leads to {}, outside {}",
                real.display(),
                root.display()
            )));
        }
        Ok(path)
    }
}

/// Every half extent of a bounded shape's box within [`SIZE_RANGE`].
fn check_size(shape: &Shape) -> Result<(), String> {
    if matches!(shape, Shape::Plane { .. }) {
        return Ok(());
    }
    let h = shape.local_aabb().half_extents();
    let (lo, hi) = (h.min(), h.max());
    if (SIZE_RANGE.0..=SIZE_RANGE.1).contains(&lo) && (SIZE_RANGE.0..=SIZE_RANGE.1).contains(&hi) {
        return Ok(());
    }
    let got = if hi > SIZE_RANGE.1 || !hi.is_finite() {
        hi
    } else {
        lo
    };
    Err(format!(
        "{}: its half extents must be between {:e} and {:e} m, got {} m",
        shape.kind(),
        SIZE_RANGE.0,
        SIZE_RANGE.1,
        readable(got)
    ))
}

fn convert_shape(s: &ShapeFile, meshes: &MeshFiles) -> Result<Shape, FieldError> {
    let shape = build_shape(s, meshes)?;
    check_size(&shape).map_err(|m| ("shape".to_owned(), m))?;
    Ok(shape)
}

fn build_shape(s: &ShapeFile, meshes: &MeshFiles) -> Result<Shape, FieldError> {
    let e = |e: crate::shape::ShapeError| ("shape".to_owned(), e.to_string());
    match s {
        ShapeFile::Sphere { radius } => Shape::sphere(*radius).map_err(e),
        ShapeFile::Box { half_extents } => Shape::cuboid(vec3(*half_extents)).map_err(e),
        ShapeFile::Capsule {
            half_height,
            radius,
        } => Shape::capsule(*half_height, *radius).map_err(e),
        ShapeFile::Convex { points } => {
            let pts: Vec<Point3<f64>> = points.iter().map(|p| Point3::from(vec3(*p))).collect();
            Shape::convex_hull(&pts).map_err(e)
        }
        ShapeFile::Particle { radius } => Shape::particle(radius.unwrap_or(0.01)).map_err(e),
        ShapeFile::Plane { normal } => Shape::plane(vec3(*normal)).map_err(e),
        ShapeFile::Mesh { file } => {
            let path = meshes
                .resolve(file)
                .map_err(|m| ("shape.file".to_owned(), m))?;
            Shape::from_obj(path).map_err(e)
        }
    }
}

fn convert_body(
    b: &BodyFile,
    materials: &[Material],
    meshes: &MeshFiles,
) -> Result<Vec<RigidBody>, FieldError> {
    let shape = convert_shape(&b.shape, meshes)?;
    check_motion(b)?;
    let mass = body_mass(b)?;
    if !b.is_static {
        check_mass_range(&shape, mass)?;
    }
    let orientation = body_orientation(b)?;
    let material = body_material(b, materials)?;
    expand_repeats(b, &shape, mass, orientation, material)
}

/// Position, velocity and angular velocity within the scene limits.
fn check_motion(b: &BodyFile) -> Result<(), FieldError> {
    let err = |f: &str, m: String| (f.to_owned(), m);
    let limit = |field: &str, v: [f64; 3], max: f64, unit: &str| {
        let norm = magnitude(v);
        if norm.is_finite() && norm <= max {
            Ok(())
        } else {
            Err(err(
                field,
                format!(
                    "magnitude must be at most {} {unit}, got {}",
                    readable(max),
                    readable(norm)
                ),
            ))
        }
    };
    let biggest = b.position.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(biggest.is_finite() && biggest <= MAX_COORDINATE) {
        return Err(err(
            "position",
            format!(
                "coordinates must be at most {} m in magnitude, got {}",
                readable(MAX_COORDINATE),
                readable(biggest)
            ),
        ));
    }
    limit("velocity", b.velocity, MAX_SPEED, "m/s")?;
    limit("angular_velocity", b.angular_velocity, MAX_SPEED, "rad/s")?;
    Ok(())
}

/// `density` or `mass` (default density 1000), checked.
fn body_mass(b: &BodyFile) -> Result<MassSpec, FieldError> {
    let err = |f: &str, m: String| (f.to_owned(), m);
    // Checked for static bodies too: a static body ignores its mass, but a negative one is
    // still a mistake in the file.
    for (field, v) in [("density", b.density), ("mass", b.mass)] {
        if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(err(
                field,
                format!("must be positive and finite, got {}", readable(v)),
            ));
        }
    }
    if let Some(m) = b
        .mass
        .filter(|m| !(MASS_RANGE.0..=MASS_RANGE.1).contains(m))
    {
        return Err(err(
            "mass",
            format!(
                "must be between {} and {} kg, got {}",
                readable(MASS_RANGE.0),
                readable(MASS_RANGE.1),
                readable(m)
            ),
        ));
    }
    Ok(match (b.density, b.mass) {
        (Some(_), Some(_)) => {
            return Err(err("mass", "give `density` or `mass`, not both".into()));
        }
        (Some(d), None) => MassSpec::Density(d),
        (None, Some(m)) => MassSpec::Mass(m),
        (None, None) => MassSpec::Density(1000.0),
    })
}

/// The mass a dynamic body gets from `density` and its shape's volume within [`MASS_RANGE`]
/// (a given `mass` is checked by [`body_mass`]), before the body is built.
fn check_mass_range(shape: &Shape, mass: MassSpec) -> Result<(), FieldError> {
    let MassSpec::Density(density) = mass else {
        return Ok(());
    };
    let m = shape
        .mass_properties(density)
        .map_err(|e| ("shape".to_owned(), e.to_string()))?
        .mass;
    if (MASS_RANGE.0..=MASS_RANGE.1).contains(&m) {
        return Ok(());
    }
    Err((
        "density".to_owned(),
        format!(
            "gives a mass of {} kg, outside {} to {} kg",
            readable(m),
            readable(MASS_RANGE.0),
            readable(MASS_RANGE.1)
        ),
    ))
}

/// No body starts deeper inside another than [`MAX_INITIAL_OVERLAP`] times the smaller
/// bounding radius of the two. Checked with the stepper's own collision detection, within its limits
/// (`prediction` widens the broad phase as the first step's will).
fn check_initial_overlap(
    bodies: &[RigidBody],
    groups: &[String],
    files: &[BodyFile],
    prediction: f64,
) -> Result<(), FieldError> {
    let field = |k: usize| {
        let entry = files.iter().position(|f| f.name == groups[k]).unwrap_or(0);
        format!("bodies[{entry}] (\"{}\").position", bodies[k].name)
    };
    let mut pipeline = crate::CollisionPipeline::new();
    let contacts = pipeline.detect(bodies, prediction).map_err(|e| {
        (
            "bodies".to_owned(),
            format!("at the start, {e} (see docs/scenes.md#limits)"),
        )
    })?;
    for c in contacts.iter().filter(|c| c.dist < 0.0) {
        let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
        let (ra, rb) = (a.shape.bounding_radius(), b.shape.bounding_radius());
        let (inner, other) = if ra <= rb {
            (c.body_a, c.body_b)
        } else {
            (c.body_b, c.body_a)
        };
        let radius = ra.min(rb);
        let depth = -c.dist;
        if depth > MAX_INITIAL_OVERLAP * radius {
            return Err((
                field(inner),
                format!(
                    "starts {} m deep in \"{}\", more than its own size (bounding radius) \
                     of {} m, the limit of an initial overlap: a body that deep has no way \
                     out the contact can tell",
                    readable(depth),
                    bodies[other].name,
                    readable(radius)
                ),
            ));
        }
    }
    Ok(())
}

/// `orientation` (a quaternion) or `axis_angle`; identity when neither is given.
fn body_orientation(b: &BodyFile) -> Result<UnitQuaternion<f64>, FieldError> {
    let err = |f: &str, m: String| (f.to_owned(), m);
    Ok(match (&b.orientation, &b.axis_angle) {
        (Some(_), Some(_)) => {
            return Err(err(
                "orientation",
                "give `orientation` or `axis_angle`, not both".into(),
            ))
        }
        (Some(q), None) => {
            let q = Quaternion::new(q[0], q[1], q[2], q[3]);
            if !(q.norm().is_finite() && q.norm() > 1e-12) {
                return Err(err(
                    "orientation",
                    "must be a non-zero quaternion [w, x, y, z]".into(),
                ));
            }
            UnitQuaternion::from_quaternion(q)
        }
        (None, Some(aa)) => {
            let axis = Unit::try_new(vec3(aa.axis), 1e-12)
                .ok_or_else(|| err("axis_angle.axis", "must be a non-zero vector".into()))?;
            if !aa.degrees.is_finite() {
                return Err(err("axis_angle.degrees", "must be finite".into()));
            }
            UnitQuaternion::from_axis_angle(&axis, aa.degrees.to_radians())
        }
        (None, None) => UnitQuaternion::identity(),
    })
}

/// Index of the body's material (the first when none is named).
fn body_material(b: &BodyFile, materials: &[Material]) -> Result<usize, FieldError> {
    let err = |f: &str, m: String| (f.to_owned(), m);
    Ok(match &b.material {
        None => 0,
        Some(name) => materials
            .iter()
            .position(|m| &m.name == name)
            .ok_or_else(|| {
                let known: Vec<_> = materials.iter().map(|m| m.name.as_str()).collect();
                err(
                    "material",
                    format!("no material named \"{name}\" (known: {})", known.join(", ")),
                )
            })?,
    })
}

/// The body, or its grid of copies `name_0, name_1, …` (`i` fastest) when repeated.
fn expand_repeats(
    b: &BodyFile,
    shape: &Shape,
    mass: MassSpec,
    orientation: UnitQuaternion<f64>,
    material: usize,
) -> Result<Vec<RigidBody>, FieldError> {
    let err = |f: &str, m: String| (f.to_owned(), m);
    let (count, spacing) = match &b.repeat {
        None => ([1, 1, 1], [0.0; 3]),
        Some(r) => {
            if r.count.contains(&0) {
                return Err(err("repeat.count", "every count must be at least 1".into()));
            }
            (r.count, r.spacing)
        }
    };
    let repeated = b.repeat.is_some();
    let mut out = Vec::with_capacity(count.iter().product());
    let mut index = 0;
    for k in 0..count[2] {
        for j in 0..count[1] {
            for i in 0..count[0] {
                let offset = Vector3::new(
                    i as f64 * spacing[0],
                    j as f64 * spacing[1],
                    k as f64 * spacing[2],
                );
                let position = vec3(b.position) + offset;
                if !position.iter().all(|x| x.abs() <= MAX_COORDINATE) {
                    return Err(err(
                        "repeat.spacing",
                        format!(
                            "copy {index} lands at {}, beyond the coordinate limit of {} m",
                            readable(position.amax()),
                            readable(MAX_COORDINATE)
                        ),
                    ));
                }
                let name = if repeated {
                    format!("{}_{index}", b.name)
                } else {
                    b.name.clone()
                };
                index += 1;
                let body = RigidBody::new(
                    name,
                    shape.clone(),
                    mass,
                    Point3::from(position),
                    orientation,
                    vec3(b.velocity),
                    vec3(b.angular_velocity),
                    material,
                    b.is_static,
                )
                .map_err(|e| err("", e.to_string()))?;
                out.push(body);
            }
        }
    }
    Ok(out)
}

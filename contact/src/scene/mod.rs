//! Scene files (TOML): bodies, materials, settings, events and expected metrics of a
//! simulation, as data. The format is documented once, in `docs/scenes.md` (every key, its
//! default and its limits); [`Scene::load`] reads it.
//!
//! Every table rejects unknown keys; every error names the file, the field and what is wrong
//! (with the line for syntax and type errors). Each setting with a set of names is parsed by one
//! function that the command line shares: [`FrictionModel::parse`],
//! [`PositionCorrection::from_name`], [`ToiMethod::from_ccd_name`],
//! [`ContactSolver::from_name`].
//!
//! This module holds the [`Scene`], its loader, its error and the scene limits; the file format
//! (`file`: the TOML tables and [`SceneMetrics`]), the checks and conversions of `[settings]`
//! (`settings`), of materials and bodies (`bodies`) and of events (`events`) live in modules of
//! their own.

mod bodies;
mod events;
mod file;
mod joints;
mod settings;

pub use file::{OneOrMany, SceneMetrics};
pub use joints::{MAX_JOINTS, WORLD};
pub use settings::tolerance;

use crate::body::RigidBody;
use crate::body_solvers::Penalty;
use crate::builder::{FrictionModel, Material};
use crate::joint::Joint;
use crate::step::{ContactSolver, Event, SimSettings, World};
use crate::timewarp::Stepping;
use bodies::{check_initial_overlap, convert_bodies, convert_materials, count_bodies, MeshFiles};
use events::convert_events;
use file::{key_at, line_column, table_context, SceneFile};
use joints::convert_joints;
use settings::convert_settings;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Largest number of bodies a scene may have (repeats expanded), checked before any body is
/// built. 20,000 takes the 14,910-box pyramid of the engine scaling family (about 218,000
/// contacts at rest, within [`MAX_CONTACTS`](crate::collision::narrow_phase::MAX_CONTACTS)):
/// the bodies themselves are a few kilobytes each; what a step may cost is bounded by the
/// stepper's own limits on pairs, contacts and entries of `A`, which refuse a step past them
/// (a matrix solver's), or leave its shared residual unmeasured (a body-level solver's).
pub const MAX_BODIES: usize = 20_000;

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
    /// Joints (`[[joints]]`), at the bodies' initial poses.
    pub joints: Vec<Joint>,
    /// The penalty parameters of `[settings]` (`penalty_*`), used whenever the scene runs the
    /// `penalty` solver ([`Scene::solver_from_name`]).
    pub penalty: Penalty,
    /// The `[metrics]` table.
    pub metrics: SceneMetrics,
    /// How the scene is stepped (`stepping` in `[settings]`) \[`fixed`\].
    pub stepping: Stepping,
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
        let joints = convert_joints(&file.joints, &bodies).map_err(|(f, m)| invalid(f, m))?;
        check_initial_overlap(&bodies, &groups, &file.bodies, settings.prediction_distance)
            .map_err(|(f, m)| invalid(f, m))?;
        let stepping = Stepping::from_name(&file.settings.stepping)
            .map_err(|m| invalid("settings.stepping".into(), m))?;
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
            joints,
            penalty,
            metrics: file.metrics,
            stepping,
        })
    }

    /// The solver of this name with default parameters, except `penalty`, which takes the
    /// scene's `penalty_*` settings.
    pub fn solver_from_name(&self, name: &str) -> Option<ContactSolver> {
        solver_from_name(name, self.penalty).ok().flatten()
    }

    /// The body-level solver `kind` with default parameters, except `penalty`, which takes the
    /// scene's `penalty_*` settings.
    pub fn body_solver(&self, kind: crate::BodySolverKind) -> ContactSolver {
        body_solver(kind, None, self.penalty)
    }

    /// The body-level solver `kind` with the parameters `params` (a substepping solver's
    /// `substeps`, `hertz`, …).
    pub fn body_solver_with(
        &self,
        kind: crate::BodySolverKind,
        params: crate::substep::Params,
    ) -> ContactSolver {
        body_solver(kind, Some(params), self.penalty)
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
        world.joints = self.joints.clone();
        world
    }
}

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

/// The solver of a specification `name` or `name@key=value,…` at any level, its parameters
/// checked against its registry entry (an error names the key and range, or the keys it
/// takes), `penalty` built from the given parameters; `Ok(None)` for an unknown name.
fn solver_from_name(spec: &str, penalty: Penalty) -> Result<Option<ContactSolver>, String> {
    use lcpbench_solvers::registry::Level;
    let (name, text) = spec.split_once('@').unwrap_or((spec, ""));
    let Some(entry) = crate::registry::find(name) else {
        return Ok(None);
    };
    let params = entry.parse_params(text)?;
    Ok(match entry.level() {
        Level::Body => {
            crate::BodySolverKind::of(entry).map(|k| body_solver(k, Some(params), penalty))
        }
        Level::Matrix => entry.create(&params).map(ContactSolver::Matrix),
        Level::Cone => entry.create_cone(&params).map(ContactSolver::Cone),
    })
}

/// The body-level solver `kind` with `params` (its defaults when `None`), `penalty` built from
/// the given parameters.
fn body_solver(
    kind: crate::BodySolverKind,
    params: Option<crate::substep::Params>,
    penalty: Penalty,
) -> ContactSolver {
    match params {
        _ if kind == crate::BodySolverKind::Penalty => ContactSolver::Body(Box::new(penalty)),
        Some(params) => ContactSolver::Body(kind.create_with(params)),
        None => kind.into(),
    }
}

/// A field of the file (its path) and what is wrong with it.
type FieldError = (String, String);

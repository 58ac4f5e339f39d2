//! The bodies of a scene from its `[[materials]]` and `[[bodies]]` tables: materials, shapes
//! (mesh files resolved inside the scene's directory tree), mass, orientation, motion limits,
//! repeats expanded into grids of copies, and the check on initial overlaps.

use super::file::{finite_vector, magnitude, vec3, BodyFile, MaterialFile, ShapeFile};
use super::{
    readable, FieldError, LoadOptions, MASS_RANGE, MAX_BODIES, MAX_COORDINATE, MAX_INITIAL_OVERLAP,
    MAX_MU, MAX_SPEED, SIZE_RANGE,
};
use crate::body::{MassSpec, RigidBody};
use crate::builder::Material;
use crate::shape::Shape;
use nalgebra::{Point3, Quaternion, Unit, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// The `[[materials]]` tables (one default material when there are none).
pub(super) fn convert_materials(files: &[MaterialFile]) -> Result<Vec<Material>, FieldError> {
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
pub(super) fn count_bodies(files: &[BodyFile]) -> Result<usize, FieldError> {
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
                         a step of more would be past the stepper's limits on contacts)"
                    ),
                ));
            }
        };
    }
    Ok(total)
}

/// The `[[bodies]]` tables, repeats expanded: the bodies and, for each, its entry's name.
pub(super) fn convert_bodies(
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

/// Where a scene's mesh files may come from.
pub(super) struct MeshFiles<'a> {
    /// The scene file's directory.
    pub(super) dir: &'a Path,
    pub(super) options: &'a LoadOptions,
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
pub(super) fn check_size(shape: &Shape) -> Result<(), String> {
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

pub(super) fn convert_shape(s: &ShapeFile, meshes: &MeshFiles) -> Result<Shape, FieldError> {
    let shape = build_shape(s, meshes)?;
    check_size(&shape).map_err(|m| ("shape".to_owned(), m))?;
    Ok(shape)
}

pub(super) fn build_shape(s: &ShapeFile, meshes: &MeshFiles) -> Result<Shape, FieldError> {
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

pub(super) fn convert_body(
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
pub(super) fn check_motion(b: &BodyFile) -> Result<(), FieldError> {
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
    // After the bounds, which name their limits: within them no length can overflow, so this
    // holds by construction and guards the bounds' own arithmetic.
    for (field, v) in [
        ("position", b.position),
        ("velocity", b.velocity),
        ("angular_velocity", b.angular_velocity),
    ] {
        finite_vector(field, v)?;
    }
    Ok(())
}

/// `density` or `mass` (default density 1000), checked.
pub(super) fn body_mass(b: &BodyFile) -> Result<MassSpec, FieldError> {
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
pub(super) fn check_mass_range(shape: &Shape, mass: MassSpec) -> Result<(), FieldError> {
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
pub(super) fn check_initial_overlap(
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
pub(super) fn body_orientation(b: &BodyFile) -> Result<UnitQuaternion<f64>, FieldError> {
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
pub(super) fn body_material(b: &BodyFile, materials: &[Material]) -> Result<usize, FieldError> {
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
pub(super) fn expand_repeats(
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

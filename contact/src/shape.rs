//! Collision shapes and their mass properties.
//!
//! A [`Shape`] lives in its body frame, whose origin is the centre of mass of the shape at
//! uniform density. Primitives are centred by construction; hulls and triangle meshes are
//! re-centred when they are built and remember where their centre of mass was in the input
//! frame ([`Shape::ConvexPolyhedron::com_offset`], [`Shape::TriMesh::com_offset`]).
//!
//! Queries go through parry (<https://parry.rs>): [`Shape::to_parry`] gives a
//! [`SharedShape`] that the broad phase, narrow phase and time-of-impact code use.
//!
//! Mass properties come from parry's closed forms for the primitives and from the exact
//! volume integral over a closed triangle mesh for hulls and meshes: the solid is split into
//! signed tetrahedra with a common apex and the polynomial moments of each tetrahedron are
//! summed (`parry::mass_properties::MassProperties::from_trimesh`). This is the same exact
//! volume integral that B. Mirtich, "Fast and accurate computation of polyhedral mass
//! properties", *Journal of Graphics Tools* 1(2), 1996, and D. Eberly, "Polyhedral mass
//! properties (revisited)", Geometric Tools 2002, obtain with the divergence theorem, organised
//! per tetrahedron instead of per face. It is exact for a closed, consistently oriented mesh
//! (an inside-out mesh is flipped on construction); an open mesh has no meaningful volume and
//! is rejected when its signed volume is negligible.

use nalgebra::{Isometry3, Matrix3, Point3, Unit, Vector3};
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::mass_properties::MassProperties as ParryMassProperties;
use parry3d_f64::shape::{
    Ball, Capsule, ConvexPolyhedron, Cuboid, HalfSpace, SharedShape, TriMesh, TriMeshFlags,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Invalid shape input.
#[derive(Debug, thiserror::Error)]
pub enum ShapeError {
    /// A size (radius, half extent, half height) is zero, negative, infinite or NaN.
    #[error("{shape}: {field} must be positive and finite, got {}", crate::scene::readable(*value))]
    NonPositiveSize {
        /// Shape kind.
        shape: &'static str,
        /// Offending parameter.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A coordinate or direction contains NaN or infinity.
    #[error("{shape}: {field} is not finite")]
    NotFinite {
        /// Shape kind.
        shape: &'static str,
        /// Offending parameter.
        field: &'static str,
    },
    /// A plane normal of zero length.
    #[error("plane: normal has zero length")]
    ZeroNormal,
    /// The points do not span a volume (fewer than four, or all coplanar).
    #[error("convex polyhedron: the {points} points do not span a volume")]
    DegenerateHull {
        /// Number of input points.
        points: usize,
    },
    /// A Wavefront OBJ file could not be read or parsed.
    #[error("cannot read mesh file {path}: {reason}")]
    MeshFile {
        /// File path.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A mesh has no triangles, an out-of-range index, or encloses no volume.
    #[error("mesh {source_name}: {reason}")]
    BadMesh {
        /// File path, or `<memory>` for meshes built from buffers.
        source_name: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A density or mass that is zero, negative or not finite.
    #[error("{field} must be positive and finite, got {}", crate::scene::readable(*value))]
    BadMass {
        /// `density` or `mass`.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// The inertia tensor of a body cannot be inverted (a mass or size so small that it
    /// underflows).
    #[error("the inertia tensor of mass {} kg cannot be inverted (mass or size too small)", crate::scene::readable(*mass))]
    SingularInertia {
        /// The body's mass.
        mass: f64,
    },
    /// The shape has no finite volume (a plane) but was given to a dynamic body.
    #[error("{shape} has no finite volume and can only belong to a static body")]
    Unbounded {
        /// Shape kind.
        shape: &'static str,
    },
}

/// A collision shape in its body frame (origin at the centre of mass).
#[derive(Debug, Clone)]
pub enum Shape {
    /// Sphere of the given radius centred on the origin.
    Sphere {
        /// Radius.
        radius: f64,
    },
    /// Box `[-h, h]` along each body axis.
    Box {
        /// Half extents along the body x, y and z axes.
        half_extents: Vector3<f64>,
    },
    /// Capsule: the segment from `(0, 0, -half_height)` to `(0, 0, half_height)` along the
    /// **body z axis**, swept by a ball of radius `radius` (a cylinder with hemispherical caps).
    Capsule {
        /// Half length of the core segment (cylinder part), excluding the caps.
        half_height: f64,
        /// Radius of the cylinder and the caps.
        radius: f64,
    },
    /// Convex hull of a point set, re-centred on its centre of mass.
    ConvexPolyhedron {
        /// The hull in the body frame.
        hull: Arc<ConvexPolyhedron>,
        /// Centre of mass in the frame of the input points: input point `p` is at
        /// `p - com_offset` in the body frame.
        com_offset: Vector3<f64>,
    },
    /// Point mass. It collides as a sphere of the (small) radius `radius`, and its inertia is
    /// that of that solid sphere, `2/5 m r²`, which keeps the inertia tensor invertible while
    /// being negligible for a small radius.
    Particle {
        /// Collision radius.
        radius: f64,
    },
    /// Half-space `{x : n·x <= 0}` in the body frame (the ground below a plane through the body
    /// origin); `normal` points out of the solid. Only valid on static bodies.
    Plane {
        /// Outward unit normal in the body frame.
        normal: Unit<Vector3<f64>>,
    },
    /// Closed, possibly non-convex triangle mesh with its bounding-volume hierarchy,
    /// re-centred on its centre of mass and oriented so that its signed volume is positive.
    TriMesh {
        /// The mesh in the body frame.
        mesh: Arc<TriMesh>,
        /// Centre of mass in the frame of the file: file vertex `p` is at `p - com_offset` in
        /// the body frame.
        com_offset: Vector3<f64>,
        /// Where the mesh came from (file path, or `<memory>`).
        source_name: String,
    },
}

/// Mass, centre of mass and inertia of a shape at a given density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Mass `ρ V`.
    pub mass: f64,
    /// Volume `V`.
    pub volume: f64,
    /// Centre of mass in the body frame (the origin, up to round-off, for every [`Shape`]).
    pub com: Point3<f64>,
    /// Inertia tensor about the centre of mass, body frame.
    pub inertia: Matrix3<f64>,
}

fn positive(shape: &'static str, field: &'static str, value: f64) -> Result<f64, ShapeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ShapeError::NonPositiveSize {
            shape,
            field,
            value,
        })
    }
}

impl Shape {
    /// Sphere of radius `radius > 0`.
    pub fn sphere(radius: f64) -> Result<Self, ShapeError> {
        Ok(Shape::Sphere {
            radius: positive("sphere", "radius", radius)?,
        })
    }

    /// Box with half extents `hx, hy, hz > 0` along the body axes.
    pub fn cuboid(half_extents: Vector3<f64>) -> Result<Self, ShapeError> {
        for (i, name) in ["half_extents.x", "half_extents.y", "half_extents.z"]
            .into_iter()
            .enumerate()
        {
            positive("box", name, half_extents[i])?;
        }
        Ok(Shape::Box { half_extents })
    }

    /// Capsule along the body z axis: core half length `half_height > 0`, radius `radius > 0`.
    pub fn capsule(half_height: f64, radius: f64) -> Result<Self, ShapeError> {
        Ok(Shape::Capsule {
            half_height: positive("capsule", "half_height", half_height)?,
            radius: positive("capsule", "radius", radius)?,
        })
    }

    /// Point mass with collision radius `radius > 0`.
    pub fn particle(radius: f64) -> Result<Self, ShapeError> {
        Ok(Shape::Particle {
            radius: positive("particle", "radius", radius)?,
        })
    }

    /// Ground half-space with outward normal `normal` (normalised here).
    pub fn plane(normal: Vector3<f64>) -> Result<Self, ShapeError> {
        if !normal.iter().all(|x| x.is_finite()) {
            return Err(ShapeError::NotFinite {
                shape: "plane",
                field: "normal",
            });
        }
        let normal = Unit::try_new(normal, 1e-12).ok_or(ShapeError::ZeroNormal)?;
        Ok(Shape::Plane { normal })
    }

    /// Convex hull of `points`, re-centred on its centre of mass.
    pub fn convex_hull(points: &[Point3<f64>]) -> Result<Self, ShapeError> {
        if points.iter().any(|p| !p.iter().all(|x| x.is_finite())) {
            return Err(ShapeError::NotFinite {
                shape: "convex polyhedron",
                field: "points",
            });
        }
        let degenerate = ShapeError::DegenerateHull {
            points: points.len(),
        };
        if points.len() < 4 {
            return Err(degenerate);
        }
        let hull = ConvexPolyhedron::from_convex_hull(points).ok_or(degenerate)?;
        let (hull_vertices, hull_indices) = hull.to_trimesh();
        let mp = ParryMassProperties::from_convex_polyhedron(1.0, &hull_vertices, &hull_indices);
        let extent = points_extent(hull.points());
        if !mp.mass().is_finite() || mp.mass() <= 1e-9 * extent.powi(3) {
            return Err(ShapeError::DegenerateHull {
                points: points.len(),
            });
        }
        let com = mp.local_com.coords;
        let shifted: Vec<Point3<f64>> = hull.points().iter().map(|p| p - com).collect();
        let hull =
            ConvexPolyhedron::from_convex_hull(&shifted).ok_or(ShapeError::DegenerateHull {
                points: points.len(),
            })?;
        Ok(Shape::ConvexPolyhedron {
            hull: Arc::new(hull),
            com_offset: com,
        })
    }

    /// Closed triangle mesh from vertex and index buffers (counter-clockwise seen from
    /// outside; an inside-out mesh is flipped). `source_name` names it in errors.
    pub fn trimesh(
        vertices: Vec<Point3<f64>>,
        indices: Vec<[u32; 3]>,
        source_name: &str,
    ) -> Result<Self, ShapeError> {
        let bad = |reason: String| ShapeError::BadMesh {
            source_name: source_name.to_string(),
            reason,
        };
        if indices.is_empty() {
            return Err(bad("no triangles".into()));
        }
        if vertices.iter().any(|p| !p.iter().all(|x| x.is_finite())) {
            return Err(bad("a vertex coordinate is not finite".into()));
        }
        if let Some(t) = indices
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= vertices.len()))
        {
            return Err(bad(format!(
                "triangle {t:?} indexes past the {} vertices",
                vertices.len()
            )));
        }
        let volume = signed_volume(&vertices, &indices);
        let extent = points_extent(&vertices);
        if !volume.is_finite() || volume.abs() <= 1e-9 * extent.powi(3) {
            return Err(bad(format!(
                "encloses no volume (signed volume {volume:e}); is it closed?"
            )));
        }
        let mp = ParryMassProperties::from_trimesh(1.0, &vertices, &indices);
        let com = mp.local_com.coords;
        let vertices: Vec<Point3<f64>> = vertices.iter().map(|p| p - com).collect();
        let indices = if volume < 0.0 {
            indices.into_iter().map(|[a, b, c]| [a, c, b]).collect()
        } else {
            indices
        };
        let flags = TriMeshFlags::MERGE_DUPLICATE_VERTICES | TriMeshFlags::FIX_INTERNAL_EDGES;
        let mesh =
            TriMesh::with_flags(vertices, indices, flags).map_err(|e| bad(format!("{e:?}")))?;
        Ok(Shape::TriMesh {
            mesh: Arc::new(mesh),
            com_offset: com,
            source_name: source_name.to_string(),
        })
    }

    /// Closed triangle mesh from a Wavefront OBJ file (all objects in the file are merged;
    /// polygons are triangulated).
    pub fn from_obj(path: impl AsRef<Path>) -> Result<Self, ShapeError> {
        let path = path.as_ref();
        let file_err = |reason: String| ShapeError::MeshFile {
            path: path.to_path_buf(),
            reason,
        };
        let (vertices, indices) = read_obj(path)?;
        if indices.is_empty() {
            return Err(file_err("no triangles in the file".into()));
        }
        Self::trimesh(vertices, indices, &path.display().to_string())
    }

    /// Convex hull of the vertices of a Wavefront OBJ file (all objects merged), re-centred on
    /// its centre of mass. The robust choice for stacked blocks, see
    /// [`crate::collision::narrow_phase`].
    pub fn convex_hull_from_obj(path: impl AsRef<Path>) -> Result<Self, ShapeError> {
        let path = path.as_ref();
        let (vertices, _) = read_obj(path)?;
        if vertices.is_empty() {
            return Err(ShapeError::MeshFile {
                path: path.to_path_buf(),
                reason: "no vertices in the file".into(),
            });
        }
        Self::convex_hull(&vertices)
    }

    /// Short name of the shape kind (`"sphere"`, `"box"`, …).
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Sphere { .. } => "sphere",
            Shape::Box { .. } => "box",
            Shape::Capsule { .. } => "capsule",
            Shape::ConvexPolyhedron { .. } => "convex polyhedron",
            Shape::Particle { .. } => "particle",
            Shape::Plane { .. } => "plane",
            Shape::TriMesh { .. } => "triangle mesh",
        }
    }

    /// Re-checks the parameters of a shape built directly from its variant.
    pub fn validate(&self) -> Result<(), ShapeError> {
        match self {
            Shape::Sphere { radius } => Shape::sphere(*radius).map(|_| ()),
            Shape::Particle { radius } => Shape::particle(*radius).map(|_| ()),
            Shape::Box { half_extents } => Shape::cuboid(*half_extents).map(|_| ()),
            Shape::Capsule {
                half_height,
                radius,
            } => Shape::capsule(*half_height, *radius).map(|_| ()),
            Shape::Plane { normal } => Shape::plane(normal.into_inner()).map(|_| ()),
            Shape::ConvexPolyhedron { .. } | Shape::TriMesh { .. } => Ok(()),
        }
    }

    /// The parry shape for queries (cheap: primitives are rebuilt, hulls and meshes share
    /// their data).
    pub fn to_parry(&self) -> SharedShape {
        match self {
            Shape::Sphere { radius } | Shape::Particle { radius } => {
                SharedShape::new(Ball::new(*radius))
            }
            Shape::Box { half_extents } => SharedShape::new(Cuboid::new(*half_extents)),
            Shape::Capsule {
                half_height,
                radius,
            } => SharedShape::new(Capsule::new_z(*half_height, *radius)),
            Shape::ConvexPolyhedron { hull, .. } => SharedShape(hull.clone()),
            Shape::Plane { normal } => SharedShape::new(HalfSpace::new(*normal)),
            Shape::TriMesh { mesh, .. } => SharedShape(mesh.clone()),
        }
    }

    /// Axis-aligned bounding box in the body frame (half-filled with `f64::MAX / 2` for a
    /// plane, which is unbounded).
    pub fn local_aabb(&self) -> Aabb {
        self.to_parry().compute_local_aabb()
    }

    /// World-frame bounding box at pose `iso`.
    pub fn aabb(&self, iso: &Isometry3<f64>) -> Aabb {
        self.to_parry().compute_aabb(iso)
    }

    /// Largest distance from the body origin to a point of the shape (infinite for a plane).
    /// Bounds the speed of surface points: `|v| + |ω| r_max`.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Shape::Sphere { radius } | Shape::Particle { radius } => *radius,
            Shape::Box { half_extents } => half_extents.norm(),
            Shape::Capsule {
                half_height,
                radius,
            } => half_height + radius,
            Shape::ConvexPolyhedron { hull, .. } => max_norm(hull.points()),
            Shape::TriMesh { mesh, .. } => max_norm(mesh.vertices()),
            Shape::Plane { .. } => f64::INFINITY,
        }
    }

    /// Radius of a ball about the body origin that the shape contains, a lower bound on how
    /// far another body must travel to pass through it. For a triangle mesh, which may be a
    /// thin shell, this is a heuristic: a quarter of its smallest bounding-box extent.
    pub fn inner_radius(&self) -> f64 {
        match self {
            Shape::Sphere { radius } | Shape::Particle { radius } => *radius,
            Shape::Box { half_extents } => half_extents.min(),
            Shape::Capsule { radius, .. } => *radius,
            Shape::ConvexPolyhedron { hull, .. } => {
                // Distance from the centre of mass to the nearest face plane.
                let (pts, tris) = hull.to_trimesh();
                tris.iter()
                    .filter_map(|t| {
                        let (a, b, c) =
                            (pts[t[0] as usize], pts[t[1] as usize], pts[t[2] as usize]);
                        let n = (b - a).cross(&(c - a));
                        let len = n.norm();
                        (len > 0.0).then(|| (n / len).dot(&a.coords).abs())
                    })
                    .fold(f64::INFINITY, f64::min)
            }
            Shape::TriMesh { mesh, .. } => 0.5 * mesh.local_aabb().half_extents().min(),
            Shape::Plane { .. } => f64::INFINITY,
        }
    }

    /// Mass properties at uniform density `density > 0`. Fails for a plane.
    pub fn mass_properties(&self, density: f64) -> Result<MassProperties, ShapeError> {
        if !(density.is_finite() && density > 0.0) {
            return Err(ShapeError::BadMass {
                field: "density",
                value: density,
            });
        }
        let mp = match self {
            Shape::Plane { .. } => return Err(ShapeError::Unbounded { shape: "plane" }),
            Shape::TriMesh { mesh, .. } => {
                ParryMassProperties::from_trimesh(density, mesh.vertices(), mesh.indices())
            }
            _ => self.to_parry().mass_properties(density),
        };
        let mass = mp.mass();
        Ok(MassProperties {
            mass,
            volume: mass / density,
            com: mp.local_com,
            inertia: mp.reconstruct_inertia_matrix(),
        })
    }
}

/// Largest Wavefront OBJ file read, bytes (a mesh of [`MAX_MESH_TRIANGLES`] triangles takes a
/// few megabytes). Devices, pipes and directories are refused whatever their size.
pub const MAX_MESH_FILE_BYTES: u64 = 32_000_000;

/// Most triangles of one mesh: each can meet each triangle of another mesh in the narrow phase.
pub const MAX_MESH_TRIANGLES: usize = 200_000;

/// Vertex positions and triangles (indices into the positions) of a mesh.
type MeshBuffers = (Vec<Point3<f64>>, Vec<[u32; 3]>);

/// Vertex positions and triangles of every object in an OBJ file.
fn read_obj(path: &Path) -> Result<MeshBuffers, ShapeError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let file_err = |reason: String| ShapeError::MeshFile {
        path: path.to_path_buf(),
        reason,
    };
    // Read the file here so an I/O failure keeps the operating system's reason, and parse from
    // memory so a parse error can be placed on its line.
    let bytes = lcpbench_solvers::io::input::read_input_file(path, MAX_MESH_FILE_BYTES)
        .map_err(|e| file_err(e.to_string()))?;
    let mut cursor = std::io::Cursor::new(&bytes[..]);
    // Materials are not used: every `mtllib` is answered with "not loaded".
    let parsed = tobj::load_obj_buf(&mut cursor, &options, |_| {
        Err(tobj::LoadError::GenericFailure)
    });
    let (models, _materials) = parsed.map_err(|e| {
        use tobj::LoadError as E;
        let per_line = matches!(
            e,
            E::UnrecognizedCharacter
                | E::PositionParseError
                | E::ScalingByZeroError
                | E::ColorParseError
                | E::NormalParseError
                | E::TexcoordParseError
                | E::FaceParseError
                | E::MaterialParseError
                | E::InvalidObjectName
                | E::InvalidPolygon
        );
        if per_line {
            // tobj reads line by line: the failing line is the last one consumed.
            let end = usize::try_from(cursor.position()).unwrap_or(bytes.len());
            let consumed = &bytes[..end.min(bytes.len())];
            let line = consumed
                .strip_suffix(b"\n")
                .unwrap_or(consumed)
                .iter()
                .filter(|&&c| c == b'\n')
                .count()
                + 1;
            file_err(format!("line {line}: {e}"))
        } else {
            file_err(e.to_string())
        }
    })?;
    let triangles: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    if triangles > MAX_MESH_TRIANGLES {
        return Err(file_err(format!(
            "{triangles} triangles, beyond the limit of {MAX_MESH_TRIANGLES}"
        )));
    }
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    for model in &models {
        let base = vertices.len() as u32;
        vertices.extend(
            model
                .mesh
                .positions
                .chunks_exact(3)
                .map(|p| Point3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))),
        );
        indices.extend(
            model
                .mesh
                .indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    Ok((vertices, indices))
}

fn max_norm(points: &[Point3<f64>]) -> f64 {
    points.iter().map(|p| p.coords.norm()).fold(0.0, f64::max)
}

fn points_extent(points: &[Point3<f64>]) -> f64 {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    (hi - lo).max().max(0.0)
}

/// Signed volume of a triangle mesh, `Σ a·(b×c) / 6` over its triangles (positive for a
/// closed mesh wound counter-clockwise seen from outside).
pub fn signed_volume(vertices: &[Point3<f64>], indices: &[[u32; 3]]) -> f64 {
    indices
        .iter()
        .map(|t| {
            let a = vertices[t[0] as usize].coords;
            let b = vertices[t[1] as usize].coords;
            let c = vertices[t[2] as usize].coords;
            a.dot(&b.cross(&c))
        })
        .sum::<f64>()
        / 6.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_can_cross_threads() {
        fn send_sync<T: Send + Sync>() {}
        send_sync::<Shape>();
    }

    #[test]
    fn rejects_bad_sizes() {
        assert!(matches!(
            Shape::sphere(0.0),
            Err(ShapeError::NonPositiveSize { .. })
        ));
        assert!(Shape::sphere(f64::NAN).is_err());
        assert!(Shape::particle(-1.0).is_err());
        assert!(Shape::capsule(1.0, f64::INFINITY).is_err());
        assert!(Shape::cuboid(Vector3::new(1.0, 0.0, 1.0)).is_err());
        assert!(matches!(
            Shape::plane(Vector3::zeros()),
            Err(ShapeError::ZeroNormal)
        ));
        assert!(Shape::plane(Vector3::new(f64::NAN, 0.0, 1.0)).is_err());
        let s = Shape::sphere(1.0).unwrap();
        assert!(s.mass_properties(0.0).is_err());
        assert!(s.mass_properties(f64::NAN).is_err());
        let p = Shape::plane(Vector3::z()).unwrap();
        assert!(matches!(
            p.mass_properties(1.0),
            Err(ShapeError::Unbounded { .. })
        ));
    }

    #[test]
    fn degenerate_hull_is_rejected() {
        let flat: Vec<Point3<f64>> = (0..10)
            .map(|i| Point3::new(i as f64, (i * i) as f64, 0.0))
            .collect();
        assert!(matches!(
            Shape::convex_hull(&flat),
            Err(ShapeError::DegenerateHull { .. })
        ));
        assert!(Shape::convex_hull(&flat[..3]).is_err());
    }

    #[test]
    fn hull_of_cube_corners_is_recentred_cube() {
        let pts: Vec<Point3<f64>> = (0..8)
            .map(|i| {
                Point3::new(
                    (i & 1) as f64 + 2.0,
                    ((i >> 1) & 1) as f64,
                    ((i >> 2) & 1) as f64 * 3.0,
                )
            })
            .collect();
        let shape = Shape::convex_hull(&pts).unwrap();
        let Shape::ConvexPolyhedron { com_offset, .. } = &shape else {
            panic!()
        };
        assert!((com_offset - Vector3::new(2.5, 0.5, 1.5)).norm() < 1e-12);
        let mp = shape.mass_properties(1.0).unwrap();
        assert!((mp.volume - 3.0).abs() < 1e-12);
        assert!(mp.com.coords.norm() < 1e-12);
        // 1 x 1 x 3 box: I_zz = m (1 + 1) / 12.
        assert!((mp.inertia[(2, 2)] - 3.0 * 2.0 / 12.0).abs() < 1e-12);
        assert!((shape.inner_radius() - 0.5).abs() < 1e-12);
        let aabb = shape.local_aabb();
        assert!((aabb.maxs - Point3::new(0.5, 0.5, 1.5)).norm() < 1e-12);
    }

    #[test]
    fn inside_out_mesh_is_flipped() {
        let v = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
        ];
        // Inward-facing tetrahedron.
        let inward = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        assert!(signed_volume(&v, &inward) < 0.0);
        let shape = Shape::trimesh(v, inward, "<memory>").unwrap();
        let Shape::TriMesh { mesh, .. } = &shape else {
            panic!()
        };
        assert!((signed_volume(mesh.vertices(), mesh.indices()) - 1.0 / 6.0).abs() < 1e-12);
        let open = Shape::trimesh(
            vec![
                Point3::origin(),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2]],
            "<memory>",
        );
        assert!(matches!(open, Err(ShapeError::BadMesh { .. })));
    }
}

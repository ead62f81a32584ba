//! Shapes as a user describes them ([`ShapeKind`]) and as the simulator uses them
//! ([`PreparedShape`]: centred on the centre of mass, rotated into the principal frame).

use std::sync::Arc;

use glam::{DVec3, Quat, Vec3};

use crate::{ConvexPolyhedron, GeomError, MassProperties, convex_hull};

/// The five Platonic solids, sized by circumradius.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RegularKind {
    Tetrahedron,
    Cube,
    Octahedron,
    Dodecahedron,
    Icosahedron,
}

impl RegularKind {
    /// All kinds, in a fixed order.
    pub const ALL: [RegularKind; 5] = [
        RegularKind::Tetrahedron,
        RegularKind::Cube,
        RegularKind::Octahedron,
        RegularKind::Dodecahedron,
        RegularKind::Icosahedron,
    ];

    /// The lower-case name used in scene files (`"icosahedron"`).
    pub fn name(self) -> &'static str {
        match self {
            RegularKind::Tetrahedron => "tetrahedron",
            RegularKind::Cube => "cube",
            RegularKind::Octahedron => "octahedron",
            RegularKind::Dodecahedron => "dodecahedron",
            RegularKind::Icosahedron => "icosahedron",
        }
    }

    /// Parses a scene-file name; `None` for anything else.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The vertices of the solid centred at the origin with the given circumradius.
    pub fn points(self, radius: f64) -> Vec<Vec3> {
        let phi = (1.0 + 5f64.sqrt()) / 2.0;
        let raw: Vec<DVec3> = match self {
            RegularKind::Tetrahedron => vec![
                DVec3::new(1.0, 1.0, 1.0),
                DVec3::new(1.0, -1.0, -1.0),
                DVec3::new(-1.0, 1.0, -1.0),
                DVec3::new(-1.0, -1.0, 1.0),
            ],
            RegularKind::Cube => {
                let mut v = Vec::new();
                for i in 0..8 {
                    v.push(DVec3::new(
                        if i & 1 == 0 { -1.0 } else { 1.0 },
                        if i & 2 == 0 { -1.0 } else { 1.0 },
                        if i & 4 == 0 { -1.0 } else { 1.0 },
                    ));
                }
                v
            }
            RegularKind::Octahedron => vec![
                DVec3::X,
                -DVec3::X,
                DVec3::Y,
                -DVec3::Y,
                DVec3::Z,
                -DVec3::Z,
            ],
            RegularKind::Dodecahedron => {
                let mut v = Vec::new();
                for i in 0..8 {
                    v.push(DVec3::new(
                        if i & 1 == 0 { -1.0 } else { 1.0 },
                        if i & 2 == 0 { -1.0 } else { 1.0 },
                        if i & 4 == 0 { -1.0 } else { 1.0 },
                    ));
                }
                let (a, b) = (1.0 / phi, phi);
                for s1 in [-1.0, 1.0] {
                    for s2 in [-1.0, 1.0] {
                        v.push(DVec3::new(0.0, s1 * a, s2 * b));
                        v.push(DVec3::new(s1 * a, s2 * b, 0.0));
                        v.push(DVec3::new(s1 * b, 0.0, s2 * a));
                    }
                }
                v
            }
            RegularKind::Icosahedron => {
                let mut v = Vec::new();
                for s1 in [-1.0, 1.0] {
                    for s2 in [-1.0, 1.0] {
                        v.push(DVec3::new(0.0, s1, s2 * phi));
                        v.push(DVec3::new(s1, s2 * phi, 0.0));
                        v.push(DVec3::new(s2 * phi, 0.0, s1));
                    }
                }
                v
            }
        };
        raw.into_iter()
            .map(|p| (p / p.length() * radius).as_vec3())
            .collect()
    }
}

/// A shape as written in a scene file or a query: what the user asked for.
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeKind {
    /// A sphere of the given radius.
    Sphere { radius: f64 },
    /// A rectangular box with the given half extents along its local x, y, z.
    Box { half_extents: [f64; 3] },
    /// A Platonic solid with the given circumradius.
    Regular { kind: RegularKind, radius: f64 },
    /// The convex hull of a point set (duplicate and coplanar points are fine).
    Convex { points: Vec<[f64; 3]> },
}

/// The runtime shape: a sphere or a convex polyhedron in its principal frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// Sphere centred at the origin.
    Sphere { radius: f32 },
    /// Convex polyhedron with its centre of mass at the origin and principal axes along x, y, z.
    Polyhedron(Arc<ConvexPolyhedron>),
    /// A rigid union of spheres and convex polyhedra ("clump"), in its principal frame
    /// (see [`crate::composite`]). Contacts are found piece by piece.
    Composite(Arc<crate::Composite>),
}

impl Shape {
    /// Bounding-sphere radius about the centre of mass.
    #[inline]
    pub fn bounding_radius(&self) -> f32 {
        match self {
            Shape::Sphere { radius } => *radius,
            Shape::Polyhedron(p) => p.radius,
            Shape::Composite(c) => c.radius,
        }
    }

    /// The convex pieces with their poses relative to the shape's principal frame: the
    /// shape itself at the identity for a sphere or polyhedron, every piece for a composite.
    pub fn pieces(&self) -> Vec<(&Shape, crate::Pose)> {
        match self {
            Shape::Composite(c) => c
                .pieces
                .iter()
                .map(|p| (&p.shape, crate::Pose::new(p.position, p.orientation)))
                .collect(),
            s => vec![(s, crate::Pose::new(Vec3::ZERO, Quat::IDENTITY))],
        }
    }

    /// The number of convex pieces (1 unless a composite).
    #[inline]
    pub fn piece_count(&self) -> usize {
        match self {
            Shape::Composite(c) => c.pieces.len(),
            _ => 1,
        }
    }
}

/// A shape ready for simulation, with its mass properties per unit density.
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedShape {
    /// The runtime shape, in the principal frame.
    pub shape: Shape,
    /// Volume (m^3); mass = density * volume.
    pub volume: f32,
    /// Principal moments of inertia per unit density (m^5); multiply by density.
    pub unit_inertia: Vec3,
    /// Rotation from the principal frame to the frame the user authored the shape in:
    /// `x_authored = frame * x_principal + com`.
    pub frame: Quat,
    /// Centre of mass in the authored frame.
    pub com: Vec3,
}

/// The smallest and largest lengths (radius, half extent; m) a shape may have: a body's
/// mass and inertia (`density * r^3`, `density * r^5`) are 32-bit floats, which are zero
/// (or below their normal range) for a grain of 1e-100 m and infinite for one of 1e100 m.
pub const LENGTH_RANGE: (f64, f64) = (1e-7, 1e7);

fn positive(what: &'static str, value: f64) -> Result<f64, GeomError> {
    if value.is_finite() && value > 0.0 && (LENGTH_RANGE.0..=LENGTH_RANGE.1).contains(&value) {
        Ok(value)
    } else {
        Err(GeomError::NotPositive { what, value })
    }
}

impl ShapeKind {
    /// Validates the description and builds the runtime shape with its mass properties.
    pub fn prepare(&self) -> Result<PreparedShape, GeomError> {
        let points: Vec<Vec3> = match self {
            ShapeKind::Sphere { radius } => {
                let r = positive("radius", *radius)?;
                let m = MassProperties::of_sphere(r);
                return Ok(PreparedShape {
                    shape: Shape::Sphere { radius: r as f32 },
                    volume: m.volume as f32,
                    unit_inertia: Vec3::splat(m.inertia.x_axis.x as f32),
                    frame: Quat::IDENTITY,
                    com: Vec3::ZERO,
                });
            }
            ShapeKind::Box { half_extents } => {
                let h = [
                    positive("half_extents[0]", half_extents[0])?,
                    positive("half_extents[1]", half_extents[1])?,
                    positive("half_extents[2]", half_extents[2])?,
                ];
                RegularKind::Cube
                    .points(1.0)
                    .into_iter()
                    .map(|p| {
                        Vec3::new(
                            p.x.signum() * h[0] as f32,
                            p.y.signum() * h[1] as f32,
                            p.z.signum() * h[2] as f32,
                        )
                    })
                    .collect()
            }
            ShapeKind::Regular { kind, radius } => kind.points(positive("radius", *radius)?),
            ShapeKind::Convex { points } => {
                let mut out = Vec::with_capacity(points.len());
                for (index, p) in points.iter().enumerate() {
                    if !p.iter().all(|&c| c.is_finite() && (c as f32).is_finite()) {
                        return Err(GeomError::NonFinitePoint { index });
                    }
                    out.push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
                }
                // Its size (half its largest extent) within the lengths a sphere or a box may have:
                // a hull of 1e-9 m had a mass of 0 in f32, one of 1e9 m infinite.
                let (lo, hi) = points.iter().fold(
                    ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
                    |(lo, hi), p| {
                        (
                            [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
                            [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
                        )
                    },
                );
                let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
                if extent > 0.0 {
                    positive("size", 0.5 * extent)?;
                }
                out
            }
        };
        let hull = convex_hull(&points)?;
        let m = MassProperties::of_polyhedron(&hull);
        let (moments, rot) = m.principal_axes();
        let com = m.center.as_vec3();
        let frame = rot.as_quat();
        let inv = frame.conjugate();
        let principal = hull.map_vertices(|v| inv * (v - com));
        Ok(PreparedShape {
            shape: Shape::Polyhedron(Arc::new(principal)),
            volume: m.volume as f32,
            unit_inertia: moments.as_vec3(),
            frame,
            com,
        })
    }
}

/// The unit icosphere: the icosahedron's vertices on the unit sphere, each triangle split
/// into four `levels` times with the new vertices pushed out onto the sphere (12, 42, 162
/// ... vertices; 20 * 4^levels outward-wound triangles). Drawing and output code use it
/// for spheres.
pub fn icosphere(levels: u32) -> (Vec<glam::DVec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut points: Vec<glam::DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|p| glam::DVec3::from_array(p).normalize())
    .to_vec();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mids = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, points: &mut Vec<glam::DVec3>| -> u32 {
            *mids.entry((a.min(b), a.max(b))).or_insert_with(|| {
                points.push((points[a as usize] + points[b as usize]).normalize());
                points.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let (ab, bc, ca) = (
                mid(a, b, &mut points),
                mid(b, c, &mut points),
                mid(c, a, &mut points),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    (points, triangles)
}

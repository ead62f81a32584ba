//! Triangle meshes of the shapes (in their principal frame, as the simulation stores them)
//! and quads for the walls.

use bytemuck::{Pod, Zeroable};
use clatter::geom::shape::Shape;
use clatter::world::Wall;
use glam::Vec3;

use crate::camera::Bounds;

/// One mesh vertex: position in the shape's principal frame and the shading normal.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// Position in the shape's principal frame, m.
    pub position: [f32; 3],
    /// Unit shading normal in the same frame.
    pub normal: [f32; 3],
}

/// A triangle mesh: vertices and counter-clockwise (seen from outside) triangles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// The vertices.
    pub vertices: Vec<Vertex>,
    /// Three vertex indices per triangle.
    pub indices: Vec<u32>,
}

/// Subdivisions of the sphere's icosahedron: 2 gives 320 triangles, round enough at the
/// sizes bodies have on screen.
pub const SPHERE_SUBDIVISIONS: u32 = 2;

impl Mesh {
    /// The mesh of a shape: a polyhedron with one flat normal per face (faceted look), a
    /// sphere as an icosphere with smooth normals, a composite as its pieces' meshes placed
    /// in its principal frame.
    pub fn of_shape(shape: &Shape) -> Mesh {
        match shape {
            Shape::Composite(c) => {
                let mut m = Mesh::default();
                for piece in &c.pieces {
                    let part = Mesh::of_shape(&piece.shape);
                    let base = m.vertices.len() as u32;
                    m.vertices.extend(part.vertices.iter().map(|v| {
                        Vertex {
                            position: (piece.orientation * Vec3::from_array(v.position)
                                + piece.position)
                                .to_array(),
                            normal: (piece.orientation * Vec3::from_array(v.normal)).to_array(),
                        }
                    }));
                    m.indices.extend(part.indices.iter().map(|i| i + base));
                }
                m
            }
            Shape::Sphere { radius } => Mesh::icosphere(*radius, SPHERE_SUBDIVISIONS),
            Shape::Polyhedron(p) => {
                let mut m = Mesh::default();
                for f in 0..p.faces.len() {
                    let face = &p.faces[f];
                    let ring = p.face_loop(f);
                    if ring.len() < 3 {
                        continue;
                    }
                    let base = m.vertices.len() as u32;
                    for &v in ring {
                        m.vertices.push(Vertex {
                            position: p.vertices[v as usize].to_array(),
                            normal: face.normal.to_array(),
                        });
                    }
                    // A convex polygon: a fan from its first vertex.
                    for k in 1..ring.len() as u32 - 1 {
                        m.indices.extend_from_slice(&[base, base + k, base + k + 1]);
                    }
                }
                m
            }
        }
    }

    /// A sphere of `radius` made by subdividing an icosahedron `levels` times.
    pub fn icosphere(radius: f32, levels: u32) -> Mesh {
        let (points, triangles) = clatter::geom::shape::icosphere(levels);
        let pts: Vec<Vec3> = points.iter().map(|p| p.as_vec3()).collect();
        let tris = triangles;
        Mesh {
            vertices: pts
                .iter()
                .map(|p| Vertex {
                    position: (*p * radius).to_array(),
                    normal: p.to_array(),
                })
                .collect(),
            indices: tris.into_iter().flatten().collect(),
        }
    }
}

/// One wall vertex: world position, coordinates in the wall's plane (m, for the grid lines)
/// and opacity.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct WallVertex {
    /// World position, m.
    pub position: [f32; 3],
    /// Coordinates along the wall's two in-plane axes, m.
    pub plane_uv: [f32; 2],
    /// Opacity of the wall's fill; its grid lines are drawn more opaque.
    pub alpha: f32,
    /// Grid spacing, m.
    pub spacing: f32,
    /// Padding to 32 bytes.
    pub _pad: f32,
}

/// A round grid spacing (1, 2 or 5 times a power of ten) of about `size / 12`.
pub fn grid_spacing(size: f32) -> f32 {
    let raw = (size / 12.0).max(1e-6);
    let p = 10f32.powf(raw.log10().floor());
    let m = raw / p;
    p * if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    }
}

/// Two triangles per wall: the part of each wall plane that faces `bounds` (the box's
/// outline projected onto the plane, plus a margin), with a grid. The wall that is most
/// nearly the floor (normal along `up`) is drawn more opaque than the others.
pub fn wall_quads(walls: &[Wall], bounds: &Bounds, up: Vec3) -> (Vec<WallVertex>, Vec<u32>) {
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    let c = bounds.centre();
    let half = 0.5 * (bounds.max - bounds.min) + Vec3::splat(0.04 * bounds.radius());
    let spacing = grid_spacing(2.0 * bounds.radius());
    let floor = walls
        .iter()
        .enumerate()
        .max_by(|a, b| {
            a.1.plane
                .normal
                .dot(up)
                .total_cmp(&b.1.plane.normal.dot(up))
        })
        .filter(|(_, w)| w.plane.normal.dot(up) > 0.7)
        .map(|(i, _)| i);
    for (k, w) in walls.iter().enumerate() {
        let n = w.plane.normal;
        if !n.is_finite() || n.length_squared() < 0.5 || !w.plane.offset.is_finite() {
            continue;
        }
        let dist = n.dot(c) - w.plane.offset;
        // The wall's own in-plane axes, chosen from the world axis least along its normal.
        let a = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
        let t1 = (a - n * n.dot(a)).normalize();
        let t2 = n.cross(t1);
        let extent = |t: Vec3| t.x.abs() * half.x + t.y.abs() * half.y + t.z.abs() * half.z;
        let (e1, e2) = (extent(t1), extent(t2));
        let foot = c - dist * n;
        let alpha = if Some(k) == floor { 0.55 } else { 0.12 };
        let base = vertices.len() as u32;
        for (s1, s2) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let p = foot + t1 * (s1 * e1) + t2 * (s2 * e2);
            vertices.push(WallVertex {
                position: p.to_array(),
                plane_uv: [p.dot(t1), p.dot(t2)],
                alpha,
                spacing,
                _pad: 0.0,
            });
        }
        indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    (vertices, indices)
}

/// The triangles of every boundary mesh of `world` at its current time, as wall vertices
/// (three per triangle, drawn with the walls' translucent pipeline): a neutral grey, flat
/// shaded by the triangle's facing to a light from `light` (its opacity), with the wall grid
/// in the triangle's plane.
pub fn boundary_triangles(world: &clatter::World, light: Vec3) -> Vec<WallVertex> {
    let spacing = grid_spacing(2.0 * Bounds::of_world(world).radius());
    let mut out = Vec::new();
    for b in &world.boundaries {
        let pose = b.pose(world.time);
        for (t, tri) in b.triangles.iter().enumerate() {
            let n = pose.rotation * b.normals[t];
            let a = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
            let t1 = (a - n * n.dot(a)).normalize_or_zero();
            let t2 = n.cross(t1);
            let alpha = 0.18 + 0.3 * n.dot(light).abs();
            for &k in tri {
                let p = pose.apply(b.vertices[k as usize]);
                out.push(WallVertex {
                    position: p.to_array(),
                    plane_uv: [p.dot(t1), p.dot(t2)],
                    alpha,
                    spacing,
                    _pad: 0.0,
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_is_closed_and_outward() {
        let m = Mesh::icosphere(2.0, 2);
        assert_eq!(m.indices.len() / 3, 320);
        for t in m.indices.chunks(3) {
            let p: Vec<Vec3> = t
                .iter()
                .map(|&i| Vec3::from_array(m.vertices[i as usize].position))
                .collect();
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(n.dot(p[0]) > 0.0, "inward triangle");
            assert!((p[0].length() - 2.0).abs() < 1e-5);
        }
    }

    #[test]
    fn composite_is_drawn_as_its_pieces() {
        use clatter::geom::{PieceSpec, ShapeKind, prepare_composite};
        let ball = ShapeKind::Sphere { radius: 1.0 }.prepare().unwrap();
        let piece = |x: f64| PieceSpec {
            shape: ball.clone(),
            offset: glam::DVec3::new(x, 0.0, 0.0),
            orientation: glam::DQuat::IDENTITY,
        };
        let c = prepare_composite(&[piece(-3.0), piece(3.0)]).unwrap();
        let one = Mesh::of_shape(&ball.shape);
        let m = Mesh::of_shape(&c.shape);
        assert_eq!(m.vertices.len(), 2 * one.vertices.len());
        assert_eq!(m.indices.len(), 2 * one.indices.len());
        // Every vertex lies on one of the two unit spheres, centred at +-3 along the
        // composite's principal axis of least inertia (x here).
        for v in &m.vertices {
            let p = Vec3::from_array(v.position);
            let d = (p - Vec3::X * 3.0)
                .length()
                .min((p + Vec3::X * 3.0).length());
            assert!((d - 1.0).abs() < 1e-5, "{p}");
        }
    }

    #[test]
    fn grid_spacing_is_round() {
        assert_eq!(grid_spacing(12.0), 1.0);
        assert!((grid_spacing(0.36) - 0.02).abs() < 1e-7);
        assert!((grid_spacing(0.6) - 0.05).abs() < 1e-7);
    }
}

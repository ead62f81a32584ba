//! Contacts of one convex piece (a sphere or a convex polyhedron) with one triangle of a
//! boundary mesh, classified by the triangle's feature the contact is on (face, edge or
//! vertex), so that the caller can drop the *ghost* contacts that a body sliding across the
//! internal edges of a flat or convex surface would otherwise feel (see
//! `clatter::boundary`).
//!
//! Triangles are two-sided: a face contact's normal points from the triangle's plane to the
//! side the body's centre is on.

use glam::Vec3;

use crate::narrow::Manifold;
use crate::{ConvexPolyhedron, Pose, Shape};

/// A feature of triangle `(a, b, c)`: its face, edge `k` (from vertex `k` to vertex
/// `(k + 1) % 3`), or vertex `k`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TriFeature {
    /// The inside of the triangle.
    Face,
    /// Edge `k`, from vertex `k` to vertex `(k + 1) % 3`.
    Edge(u8),
    /// Vertex `k`.
    Vertex(u8),
}

/// What one piece touching one triangle found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TriContact {
    /// The piece touches the triangle's face: the contact is with the triangle's plane,
    /// `normal` (unit, towards the piece) and `offset` (`normal . x = offset` on the plane).
    /// The caller builds one manifold per plane from every triangle of the plane the piece
    /// touches, so a piece resting across many coplanar triangles feels one plane.
    Face { normal: Vec3, offset: f32 },
    /// The piece touches an edge or a vertex of the triangle: a one-point manifold (normal
    /// from the triangle to the piece).
    Feature {
        feature: TriFeature,
        manifold: Manifold,
    },
}

/// The point of triangle `(a, b, c)` closest to `p`, and the feature it lies on (Ericson,
/// *Real-Time Collision Detection*, 5.1.5: Voronoi regions tested in order).
pub fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, TriFeature) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, TriFeature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, TriFeature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, TriFeature::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, TriFeature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, TriFeature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, TriFeature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, TriFeature::Face)
}

/// The unit normal `n` of the plane of triangle `tri` (unit normal `normal`), turned
/// towards `centre`, and the plane's offset.
#[inline]
fn facing(tri: &[Vec3; 3], normal: Vec3, centre: Vec3) -> (Vec3, f32) {
    let n = if normal.dot(centre - tri[0]) >= 0.0 {
        normal
    } else {
        -normal
    };
    (n, n.dot(tri[0]))
}

/// One convex piece (`shape` at `pose`) against triangle `tri` (world vertices, unit normal
/// `normal`): `None` when apart. A composite is not one convex piece: its caller collides
/// each of its pieces (`Shape::pieces`), so a composite here gives `None`.
pub fn collide_triangle(
    shape: &Shape,
    pose: &Pose,
    tri: &[Vec3; 3],
    normal: Vec3,
) -> Option<TriContact> {
    match shape {
        Shape::Sphere { radius } => sphere_triangle(pose.position, *radius, tri, normal),
        Shape::Polyhedron(p) => polyhedron_triangle(p, pose, tri, normal),
        Shape::Composite(_) => None,
    }
}

/// A feature contact whose normal is within this (1 - cosine) of the triangle's normal is
/// taken as a face contact.
const FACE_SNAP: f32 = 1e-6;

/// A sphere (centre, radius) against a triangle.
pub fn sphere_triangle(
    centre: Vec3,
    radius: f32,
    tri: &[Vec3; 3],
    normal: Vec3,
) -> Option<TriContact> {
    let (q, feature) = closest_on_triangle(centre, tri[0], tri[1], tri[2]);
    let d = centre - q;
    let dist2 = d.length_squared();
    if dist2 >= radius * radius {
        return None;
    }
    let dist = dist2.sqrt();
    // On the face, or so nearly over it (the centre within rounding of the triangle's
    // border) that the contact is the face's: coplanar neighbours then merge into one plane.
    if feature == TriFeature::Face || d.dot(normal).abs() >= (1.0 - FACE_SNAP) * dist {
        let (normal, offset) = facing(tri, normal, centre);
        return Some(TriContact::Face { normal, offset });
    }
    let n = if dist > 1e-12 * radius {
        d / dist
    } else {
        facing(tri, normal, centre).0
    };
    let depth = radius - dist;
    let mut m = Manifold {
        normal: n,
        count: 1,
        ..Default::default()
    };
    m.points[0].point = 0.5 * (q + (centre - n * radius));
    m.points[0].depth = depth;
    Some(TriContact::Feature {
        feature,
        manifold: m,
    })
}

/// How much the separation along a triangle edge axis must beat the face's before the edge
/// is taken (relative to the piece's size): face contacts are preferred (stable, and equal
/// to a plane's).
const FACE_BIAS: f32 = 1e-3;

/// A convex polyhedron against a triangle, by the separating-axis test in the polyhedron's
/// frame: the triangle's normal (towards the polyhedron's centre), the polyhedron's face
/// normals, and the cross products of its edge directions with the triangle's edges.
pub fn polyhedron_triangle(
    p: &ConvexPolyhedron,
    pose: &Pose,
    tri: &[Vec3; 3],
    normal: Vec3,
) -> Option<TriContact> {
    let inv = pose.rotation.conjugate();
    let t = tri.map(|v| pose.inverse_transform_point(v));
    let n_world = facing(tri, normal, pose.position).0;
    let n = inv * n_world;
    // Separation along the triangle's normal: lowest vertex of the polyhedron over the plane.
    let plane = n.dot(t[0]);
    let lowest = p
        .vertices
        .iter()
        .map(|v| n.dot(*v))
        .fold(f32::INFINITY, f32::min);
    let face_sep = lowest - plane;
    if face_sep >= 0.0 {
        return None;
    }
    // Polyhedron faces: the triangle's deepest vertex behind each face.
    let mut best = f32::NEG_INFINITY;
    let mut best_axis = Vec3::ZERO;
    let mut best_kind = (0u8, 0usize, 0usize); // (0 face | 1 edge, index, triangle feature)
    for (f, face) in p.faces.iter().enumerate() {
        let (mut lo, mut k_lo) = (f32::INFINITY, 0);
        for (k, v) in t.iter().enumerate() {
            let h = face.normal.dot(*v);
            if h < lo {
                lo = h;
                k_lo = k;
            }
        }
        let sep = lo - face.offset;
        if sep >= 0.0 {
            return None;
        }
        if sep > best {
            best = sep;
            best_axis = -face.normal;
            best_kind = (0, f, k_lo);
        }
    }
    // Edge-edge axes, oriented from the triangle's centroid towards the polyhedron's centre.
    let g = (t[0] + t[1] + t[2]) / 3.0;
    for (e, &[a, b]) in p.edges.iter().enumerate() {
        let d = p.vertices[b as usize] - p.vertices[a as usize];
        for k in 0..3 {
            let te = t[(k + 1) % 3] - t[k];
            let axis = d.cross(te);
            let len2 = axis.length_squared();
            if len2 <= 1e-12 * d.length_squared() * te.length_squared() {
                continue;
            }
            let mut axis = axis / len2.sqrt();
            if axis.dot(-g) < 0.0 {
                axis = -axis;
            }
            let lo = p
                .vertices
                .iter()
                .map(|v| axis.dot(*v))
                .fold(f32::INFINITY, f32::min);
            let hi = t
                .iter()
                .map(|v| axis.dot(*v))
                .fold(f32::NEG_INFINITY, f32::max);
            let sep = lo - hi;
            if sep >= 0.0 {
                return None;
            }
            if sep > best {
                best = sep;
                best_axis = axis;
                best_kind = (1, e, k);
            }
        }
    }
    if best <= face_sep + FACE_BIAS * p.radius {
        return Some(TriContact::Face {
            normal: n_world,
            offset: n_world.dot(tri[0]),
        });
    }
    let depth = -best;
    let (point, feature) = if best_kind.0 == 0 {
        // The triangle's deepest vertex k (or its edge to an as deep vertex) is behind
        // face f: the point of that feature nearest the face's centre.
        let (f, k) = (best_kind.1, best_kind.2);
        let face = p.faces[f];
        let lp = p.face_loop(f);
        let centre = lp.iter().map(|&i| p.vertices[i as usize]).sum::<Vec3>() / lp.len() as f32;
        let h = |v: Vec3| face.normal.dot(v);
        let tol = 1e-4 * p.radius;
        let next = (k + 1) % 3;
        let prev = (k + 2) % 3;
        let (q, feature) = if h(t[next]) - h(t[k]) <= tol {
            (
                closest_between_segments(t[k], t[next], centre, centre).0,
                TriFeature::Edge(k as u8),
            )
        } else if h(t[prev]) - h(t[k]) <= tol {
            (
                closest_between_segments(t[prev], t[k], centre, centre).0,
                TriFeature::Edge(prev as u8),
            )
        } else {
            (t[k], TriFeature::Vertex(k as u8))
        };
        (q - best_axis * (0.5 * depth), feature)
    } else {
        let [a, b] = p.edges[best_kind.1];
        let k = best_kind.2;
        let (pa, pb) = closest_between_segments(
            p.vertices[a as usize],
            p.vertices[b as usize],
            t[k],
            t[(k + 1) % 3],
        );
        (0.5 * (pa + pb), TriFeature::Edge(k as u8))
    };
    let mut m = Manifold {
        normal: pose.rotation * best_axis,
        count: 1,
        ..Default::default()
    };
    m.points[0].point = pose.transform_point(point);
    m.points[0].depth = depth;
    Some(TriContact::Feature {
        feature,
        manifold: m,
    })
}

/// Closest points of segments `p0 p1` and `q0 q1` (Ericson 5.1.9).
fn closest_between_segments(p0: Vec3, p1: Vec3, q0: Vec3, q1: Vec3) -> (Vec3, Vec3) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.length_squared();
    let e = d2.length_squared();
    let f = d2.dot(r);
    let (s, t);
    if a <= 1e-20 && e <= 1e-20 {
        return (p0, q0);
    }
    if a <= 1e-20 {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(r);
        if e <= 1e-20 {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let s0 = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            } else {
                t = t0;
                s = s0;
            }
        }
    }
    (p0 + d1 * s, q0 + d2 * t)
}

/// Whether `x` projects (along the triangle's normal) inside triangle `tri`, with a relative
/// tolerance `tol` of its edge lengths. Either winding.
pub fn projects_inside(x: Vec3, tri: &[Vec3; 3], tol: f32) -> bool {
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let n = n / n.length().max(f32::MIN_POSITIVE);
    for k in 0..3 {
        let a = tri[k];
        let b = tri[(k + 1) % 3];
        let e = b - a;
        if e.cross(x - a).dot(n) < -tol * e.length_squared() {
            return false;
        }
    }
    true
}

/// How deep point `x` (inside convex polyhedron `p`, both in its frame) lies along `-dir`:
/// the distance from `x` to `p`'s boundary going along `-dir` (`dir` unit).
pub fn depth_inside(p: &ConvexPolyhedron, x: Vec3, dir: Vec3) -> Option<f32> {
    let mut s = f32::INFINITY;
    for f in &p.faces {
        let h = f.offset - f.normal.dot(x);
        if h < 0.0 {
            return None;
        }
        let toward = -f.normal.dot(dir);
        if toward > 1e-9 {
            s = s.min(h / toward);
        }
    }
    s.is_finite().then_some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Vec3; 3] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    #[test]
    fn closest_features() {
        let [a, b, c] = tri();
        let (q, f) = closest_on_triangle(Vec3::new(0.2, 0.2, 1.0), a, b, c);
        assert_eq!(f, TriFeature::Face);
        assert!((q - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-6);
        assert_eq!(
            closest_on_triangle(Vec3::new(-1.0, -1.0, 0.5), a, b, c).1,
            TriFeature::Vertex(0)
        );
        assert_eq!(
            closest_on_triangle(Vec3::new(0.5, -1.0, 0.5), a, b, c),
            (Vec3::new(0.5, 0.0, 0.0), TriFeature::Edge(0))
        );
        assert_eq!(
            closest_on_triangle(Vec3::new(1.0, 1.0, 0.0), a, b, c),
            (Vec3::new(0.5, 0.5, 0.0), TriFeature::Edge(1))
        );
        assert_eq!(
            closest_on_triangle(Vec3::new(-1.0, 0.5, 0.0), a, b, c),
            (Vec3::new(0.0, 0.5, 0.0), TriFeature::Edge(2))
        );
        assert_eq!(
            closest_on_triangle(Vec3::new(2.0, -0.5, 0.0), a, b, c).1,
            TriFeature::Vertex(1)
        );
        assert_eq!(
            closest_on_triangle(Vec3::new(-0.5, 2.0, 0.0), a, b, c).1,
            TriFeature::Vertex(2)
        );
    }

    #[test]
    fn sphere_face_is_two_sided() {
        let t = tri();
        let below = sphere_triangle(Vec3::new(0.2, 0.2, -0.05), 0.1, &t, Vec3::Z);
        assert_eq!(
            below,
            Some(TriContact::Face {
                normal: -Vec3::Z,
                offset: 0.0
            })
        );
        assert!(sphere_triangle(Vec3::new(0.2, 0.2, 0.1), 0.1, &t, Vec3::Z).is_none());
    }

    #[test]
    fn cube_on_triangle_is_a_face_contact_and_on_its_edge_an_edge_contact() {
        let cube = crate::ShapeKind::Box {
            half_extents: [0.1; 3],
        }
        .prepare()
        .unwrap();
        let Shape::Polyhedron(p) = &cube.shape else {
            unreachable!()
        };
        let t = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let pose = Pose::new(Vec3::new(0.0, 0.0, 0.099), glam::Quat::IDENTITY);
        assert_eq!(
            polyhedron_triangle(p, &pose, &t, Vec3::Z),
            Some(TriContact::Face {
                normal: Vec3::Z,
                offset: 0.0
            })
        );
        // Far beside the triangle's edge 0 (y = -1), level with it, touching it sideways.
        let pose = Pose::new(Vec3::new(0.0, -1.099, 0.0), glam::Quat::IDENTITY);
        match polyhedron_triangle(p, &pose, &t, Vec3::Z) {
            Some(TriContact::Feature { manifold, .. }) => {
                assert!((manifold.normal - -Vec3::Y).length() < 1e-5, "{manifold:?}");
                assert!((manifold.points[0].depth - 0.001).abs() < 1e-5);
            }
            other => panic!("{other:?}"),
        }
        let pose = Pose::new(Vec3::new(0.0, 0.0, 0.1001), glam::Quat::IDENTITY);
        assert!(polyhedron_triangle(p, &pose, &t, Vec3::Z).is_none());
    }
}

//! The separating-axis test of two convex polyhedra: face axes of both bodies, then the
//! edge-edge axes ([`super::edges`]), then the manifold by clipping ([`super::clip`]).

use glam::Vec3;

use super::clip::{ClipBuffers, clip_faces, segment_closest, to_world};
use super::edges::{edge_axes_by_direction, edge_axes_gauss_map};
use super::{HINT_EDGE, HINT_FACE_A, HINT_FACE_B, HINT_KIND, Manifold, NO_HINT, SatHint};
use crate::{ConvexPolyhedron, Pose};

/// Separation of `q`'s vertices (given in `p`'s frame) along `p`'s face `f`.
#[inline]
fn face_separation(p: &ConvexPolyhedron, f: usize, q: &SoaPoints) -> f32 {
    let face = p.faces[f];
    q.min_along(face.normal) - face.offset
}

/// Points as separate x, y, z arrays padded to a multiple of 4 (with copies of the first
/// point), so that "smallest projection on an axis" compiles to packed SIMD.
#[derive(Default)]
pub(super) struct SoaPoints {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl SoaPoints {
    fn fill(&mut self, pts: &[Vec3]) {
        self.x.clear();
        self.y.clear();
        self.z.clear();
        let pad = pts.len().next_multiple_of(4);
        for k in 0..pad {
            let v = pts[if k < pts.len() { k } else { 0 }];
            self.x.push(v.x);
            self.y.push(v.y);
            self.z.push(v.z);
        }
    }

    /// Largest projection on `n`.
    #[inline]
    pub(super) fn max_along(&self, n: Vec3) -> f32 {
        -self.min_along(-n)
    }

    /// Smallest projection on `n`.
    #[inline]
    pub(super) fn min_along(&self, n: Vec3) -> f32 {
        let mut m = [f32::INFINITY; 4];
        for ((xs, ys), zs) in self
            .x
            .chunks_exact(4)
            .zip(self.y.chunks_exact(4))
            .zip(self.z.chunks_exact(4))
        {
            for k in 0..4 {
                let d = n.x * xs[k] + n.y * ys[k] + n.z * zs[k];
                m[k] = if d < m[k] { d } else { m[k] };
            }
        }
        let a = if m[0] < m[1] { m[0] } else { m[1] };
        let b = if m[2] < m[3] { m[2] } else { m[3] };
        if a < b { a } else { b }
    }
}

/// Two convex polyhedra.
///
/// When the bodies are apart, `separation` receives a lower bound of their distance (the gap
/// along the separating axis found, or between the bounding spheres), else 0: the simulator
/// skips the pair until the bodies have moved that far.
pub fn polyhedron_polyhedron(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<Manifold> {
    *separation = 0.0;
    let d = pb.position - pa.position;
    let rs = a.radius + b.radius;
    let d2 = d.length_squared();
    if d2 >= rs * rs {
        *separation = d2.sqrt() - rs;
        return None;
    }
    // Everything in A's frame: B's rotation and offset relative to A.
    let inv_a = pa.rotation.conjugate();
    let rot_q = inv_a * pb.rotation;
    let rot = glam::Mat3::from_quat(rot_q);
    let inv_rot = rot.transpose();
    let t = inv_a * d;
    // The axis that separated this pair last step, if any, tested on support points in each
    // body's own frame (no vertex transformed).
    if *hint != NO_HINT {
        let idx = (*hint & !HINT_KIND) as usize;
        let min_along = |p: &ConvexPolyhedron, dir: Vec3| {
            let mut m = f32::INFINITY;
            for v in &p.vertices {
                let d = dir.dot(*v);
                m = if d < m { d } else { m };
            }
            m
        };
        // Signed gap along the remembered axis (a distance: the axis is a unit vector).
        let gap = match *hint & HINT_KIND {
            HINT_FACE_A if idx < a.faces.len() => {
                let f = a.faces[idx];
                min_along(b, inv_rot * f.normal) + f.normal.dot(t) - f.offset
            }
            HINT_FACE_B if idx < b.faces.len() => {
                let f = b.faces[idx];
                let n = rot * f.normal;
                min_along(a, n) - n.dot(t) - f.offset
            }
            HINT_EDGE if (idx >> 15) < a.edges.len() && (idx & 0x7fff) < b.edges.len() => {
                let (ea, eb) = (idx >> 15, idx & 0x7fff);
                let [a0, a1] = a.edges[ea];
                let [b0, b1] = b.edges[eb];
                let pa0 = a.vertices[a0 as usize];
                let db = rot * (b.vertices[b1 as usize] - b.vertices[b0 as usize]);
                let axis = (a.vertices[a1 as usize] - pa0)
                    .cross(db)
                    .normalize_or_zero();
                let axis = if axis.dot(pa0) < 0.0 { -axis } else { axis };
                let lo_b = min_along(b, inv_rot * axis) + axis.dot(t);
                let hi_a = -min_along(a, -axis);
                if axis == Vec3::ZERO { 0.0 } else { lo_b - hi_a }
            }
            _ => 0.0,
        };
        if gap > 0.0 {
            *separation = gap;
            return None;
        }
    }
    SCRATCH.with_borrow_mut(|sc| sat_full(a, pa, b, pb, rot, inv_rot, t, sc, hint, separation))
}

/// Per-thread buffers of the separating-axis test (no allocation or zeroing per pair).
#[derive(Default)]
struct Scratch {
    av: Vec<Vec3>,
    bv: Vec<Vec3>,
    b_soa: SoaPoints,
    a_local: SoaPoints,
    tables: Vec<f32>,
    clip: ClipBuffers,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// The full separating-axis test with B at rotation `rot` and offset `t` in A's frame.
#[allow(clippy::too_many_arguments)]
fn sat_full(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    rot: glam::Mat3,
    inv_rot: glam::Mat3,
    t: Vec3,
    sc: &mut Scratch,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<Manifold> {
    let Scratch {
        av,
        bv,
        b_soa,
        a_local,
        tables,
        clip,
    } = sc;
    bv.clear();
    bv.extend(b.vertices.iter().map(|&v| rot * v + t));
    let bv: &[Vec3] = bv;
    b_soa.fill(bv);
    a_local.fill(&a.vertices);
    // Face axes of A.
    let mut best_a = (f32::NEG_INFINITY, 0usize);
    for f in 0..a.faces.len() {
        let s = face_separation(a, f, b_soa);
        if s > 0.0 {
            *hint = HINT_FACE_A | f as u32;
            *separation = s;
            return None;
        }
        if s > best_a.0 {
            best_a = (s, f);
        }
    }
    // Face axes of B, tested in A's frame: B's face plane `n.x = offset` becomes
    // `(R n).x = offset + (R n).t`, and A's own vertices need no transform.
    let mut best_b = (f32::NEG_INFINITY, 0usize);
    for (f, face) in b.faces.iter().enumerate() {
        let n = rot * face.normal;
        let s = a_local.min_along(n) - (face.offset + n.dot(t));
        if s > 0.0 {
            *hint = HINT_FACE_B | f as u32;
            *separation = s;
            return None;
        }
        if s > best_b.0 {
            best_b = (s, f);
        }
    }
    let (nda, ndb) = (a.edge_dirs.len(), b.edge_dirs.len());
    let cost_dirs = nda * ndb * (a.vertices.len() + bv.len());
    let cost_tables = a.edges.len() * b.faces.len()
        + b.edges.len() * a.faces.len()
        + a.edges.len() * b.edges.len();
    let best_e = if cost_dirs <= 2 * cost_tables {
        edge_axes_by_direction(a, b, rot, a_local, b_soa, bv, hint, separation)?
    } else {
        edge_axes_gauss_map(a, b, rot, inv_rot, bv, tables, hint, separation)?
    };
    let scale = a.radius.max(b.radius);
    *hint = NO_HINT;
    let face_best = best_a.0.max(best_b.0);
    let tol = 1e-3 * scale;
    if best_e.0 > face_best + tol {
        let (s, ea, eb, axis) = best_e;
        let [a0, a1] = a.edges[ea];
        let [b0, b1] = b.edges[eb];
        let (qa, qb) = segment_closest(
            a.vertices[a0 as usize],
            a.vertices[a1 as usize],
            bv[b0 as usize],
            bv[b1 as usize],
        );
        let mid = 0.5 * (qa + qb);
        return Some(Manifold::single(
            pa.rotation * axis,
            pa.transform_point(mid),
            -s,
        ));
    }
    // Face contact: prefer A's face unless B's is clearly better.
    if best_b.0 > best_a.0 + tol {
        // Reference face on B: work in B's frame with A as incident.
        av.clear();
        av.extend(a.vertices.iter().map(|&v| inv_rot * (v - t)));
        clip_faces(b, best_b.1, a, av, inv_rot, clip).map(|m| to_world(m, pb).flipped())
    } else {
        clip_faces(a, best_a.1, b, bv, rot, clip).map(|m| to_world(m, pa))
    }
}

/// The best edge-edge axis `(separation, edge of A, edge of B, axis in A's frame)`, or `None`
/// when an edge axis separates the bodies (recorded in `hint`).
pub(super) type EdgeAxis = (f32, usize, usize, Vec3);

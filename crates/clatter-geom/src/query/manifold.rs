//! Contact manifolds of two polyhedra from a known normal: reference/incident face clipping.
//!
//! The reference face is the face (of either shape) whose outward normal is best aligned with
//! the contact normal; the incident face is the face of the other shape most anti-parallel to
//! it. The incident polygon is clipped by the side planes of the reference face
//! (Sutherland-Hodgman); clipped points that are not separated from the reference plane by more
//! than the current gap (plus a small slack) are kept, moved half-way to the reference plane,
//! and reduced to at most [`MAX_MANIFOLD_POINTS`] (deepest point, then the points spanning the
//! largest area). When neither shape has a face within about 2.6 degrees of the normal
//! (edge-edge, vertex-edge contacts) the manifold is the single mid-point of the two witnesses.

use glam::DVec3;

use super::support::DPose;
use crate::ConvexPolyhedron;

/// Most points a manifold holds.
pub const MAX_MANIFOLD_POINTS: usize = 4;
/// Cosine of the largest angle between a face normal and the contact normal for face clipping.
pub const FACE_ALIGNMENT_COS: f64 = 0.999;

/// Fixed-capacity point list in the query frame.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Points {
    pub p: [DVec3; MAX_MANIFOLD_POINTS],
    pub n: usize,
    /// Deepest clipped point pair `(on a, on b)` when it agrees with the given separation:
    /// witness points inside the overlap of the two faces (the separating-axis path otherwise
    /// only knows a support vertex, which may lie beside the other face).
    pub witness: Option<(DVec3, DVec3)>,
}

impl Points {
    pub(crate) fn single(p: DVec3) -> Self {
        let mut s = Self::default();
        s.p[0] = p;
        s.n = 1;
        s
    }
}

fn best_face(p: &ConvexPolyhedron, n: DVec3) -> (usize, f64) {
    let n = n.as_vec3();
    let mut best = 0;
    let mut bd = f32::NEG_INFINITY;
    for (i, f) in p.faces.iter().enumerate() {
        let d = f.normal.dot(n);
        if d > bd {
            bd = d;
            best = i;
        }
    }
    (best, bd as f64 / n.length().max(f32::MIN_POSITIVE) as f64)
}

/// Clipping manifold of polyhedron `a` (at the query-frame origin) and `b` (at `rel`), for the
/// unit normal `n` from `a` to `b`, witness points `pa`, `pb` and signed separation `sep`
/// (negative when penetrating). All in the query frame.
pub(crate) fn clip(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rel: &DPose,
    n: DVec3,
    pa: DVec3,
    pb: DVec3,
    sep: f64,
) -> Points {
    let rt = rel.rot.transpose();
    let (fa, ala) = best_face(a, n);
    let (fb, alb) = best_face(b, rt * -n);
    if ala.max(alb) < FACE_ALIGNMENT_COS {
        return Points::single((pa + pb) * 0.5);
    }
    // Reference polygon `r` with outward normal `rn`; incident polygon `inc`, query frame.
    let mut r: Vec<DVec3> = Vec::with_capacity(8);
    let mut inc: Vec<DVec3> = Vec::with_capacity(16);
    let rn;
    let ref_is_a = ala >= alb - 1e-9;
    if ref_is_a {
        rn = a.faces[fa].normal.as_dvec3();
        r.extend(
            a.face_loop(fa)
                .iter()
                .map(|&i| a.vertices[i as usize].as_dvec3()),
        );
        let (fi, _) = best_face(b, rt * -rn);
        inc.extend(
            b.face_loop(fi)
                .iter()
                .map(|&i| rel.point(b.vertices[i as usize].as_dvec3())),
        );
    } else {
        rn = rel.vector(b.faces[fb].normal.as_dvec3());
        r.extend(
            b.face_loop(fb)
                .iter()
                .map(|&i| rel.point(b.vertices[i as usize].as_dvec3())),
        );
        let (fi, _) = best_face(a, -rn);
        inc.extend(
            a.face_loop(fi)
                .iter()
                .map(|&i| a.vertices[i as usize].as_dvec3()),
        );
    }
    let rn = rn.normalize_or_zero();
    // Sutherland-Hodgman against each side plane of the reference face (outward side normal
    // `edge × rn` for a counter-clockwise loop seen from outside).
    let mut out: Vec<DVec3> = Vec::with_capacity(inc.len() + r.len());
    for k in 0..r.len() {
        let p0 = r[k];
        let p1 = r[(k + 1) % r.len()];
        let sn = (p1 - p0).cross(rn);
        out.clear();
        let m = inc.len();
        for i in 0..m {
            let x = inc[i];
            let y = inc[(i + 1) % m];
            let dx = sn.dot(x - p0);
            let dy = sn.dot(y - p0);
            if dx <= 0.0 {
                out.push(x);
            }
            if (dx < 0.0 && dy > 0.0) || (dx > 0.0 && dy < 0.0) {
                let t = dx / (dx - dy);
                out.push(x + (y - x) * t);
            }
        }
        std::mem::swap(&mut inc, &mut out);
        if inc.is_empty() {
            break;
        }
    }
    let size = (a.radius + b.radius) as f64;
    let limit = sep.max(0.0) + 1e-5 * size;
    let origin = r[0];
    let mut kept: Vec<(DVec3, f64)> = Vec::with_capacity(inc.len());
    let mut deepest = (f64::INFINITY, DVec3::ZERO);
    for &p in &inc {
        let s = (p - origin).dot(rn);
        if s <= limit {
            kept.push((p - rn * (0.5 * s), s));
            if s < deepest.0 {
                deepest = (s, p);
            }
        }
    }
    if kept.is_empty() {
        return Points::single((pa + pb) * 0.5);
    }
    let mut out = reduce(&kept, rn);
    let (s, p) = deepest;
    let on_ref = p - rn * s;
    let (wa, wb) = if ref_is_a { (on_ref, p) } else { (p, on_ref) };
    if ((wb - wa).dot(n) - sep).abs() <= 1e-6 * size {
        out.witness = Some((wa, wb));
    }
    out
}

/// At most four points: the deepest, the farthest from it, then the two adding most area.
fn reduce(kept: &[(DVec3, f64)], n: DVec3) -> Points {
    let mut out = Points::default();
    if kept.len() <= MAX_MANIFOLD_POINTS {
        for (i, (p, _)) in kept.iter().enumerate() {
            out.p[i] = *p;
        }
        out.n = kept.len();
        return out;
    }
    let i0 = (0..kept.len())
        .min_by(|&i, &j| kept[i].1.total_cmp(&kept[j].1))
        .unwrap_or(0);
    let p0 = kept[i0].0;
    let i1 = (0..kept.len())
        .max_by(|&i, &j| {
            (kept[i].0 - p0)
                .length_squared()
                .total_cmp(&(kept[j].0 - p0).length_squared())
        })
        .unwrap_or(0);
    let p1 = kept[i1].0;
    let area = |a: DVec3, b: DVec3, c: DVec3| (b - a).cross(c - a).dot(n);
    let i2 = (0..kept.len())
        .max_by(|&i, &j| {
            area(p0, p1, kept[i].0)
                .abs()
                .total_cmp(&area(p0, p1, kept[j].0).abs())
        })
        .unwrap_or(0);
    let mut p2 = kept[i2].0;
    let (q0, mut q1) = (p0, p1);
    if area(q0, q1, p2) < 0.0 {
        std::mem::swap(&mut q1, &mut p2);
    }
    // Triangle q0 q1 p2 is now counter-clockwise about n; the fourth point is the one
    // furthest outside one of its edges.
    let tri = [q0, q1, p2];
    let out_of = |p: DVec3| {
        (0..3)
            .map(|e| -area(tri[e], tri[(e + 1) % 3], p))
            .fold(0.0, f64::max)
    };
    let i3 = (0..kept.len())
        .max_by(|&i, &j| out_of(kept[i].0).total_cmp(&out_of(kept[j].0)))
        .unwrap_or(0);
    out.p = [q0, q1, p2, kept[i3].0];
    out.n = if out_of(kept[i3].0) > 0.0 { 4 } else { 3 };
    out
}

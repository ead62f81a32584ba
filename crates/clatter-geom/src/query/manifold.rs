//! Contact manifolds of two polyhedra from a known normal: reference/incident face clipping.
//!
//! The reference face is the face (of either shape) best aligned with the contact normal, the
//! incident face the other shape's most anti-parallel one. The incident polygon is clipped by
//! the reference face's side planes; points within the current gap of the reference plane are
//! moved half-way to it and reduced to four (the narrow phase's reduction). Without a face
//! within about 2.6 degrees of the normal, the manifold is the mid-point of the witnesses.

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
    /// Deepest clipped point pair `(on a, on b)` when it is the given separation apart along
    /// the normal:
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
    // (point, depth) pairs for the shared reduction, depth = -separation.
    let mut kept: Vec<(DVec3, f64)> = Vec::with_capacity(inc.len());
    let mut deepest = (f64::INFINITY, DVec3::ZERO);
    for &p in &inc {
        let s = (p - origin).dot(rn);
        if s <= limit {
            kept.push((p - rn * (0.5 * s), -s));
            if s < deepest.0 {
                deepest = (s, p);
            }
        }
    }
    if kept.is_empty() {
        return Points::single((pa + pb) * 0.5);
    }
    let (idx, count) = crate::reduce::reduce(&kept, rn);
    let mut out = Points::default();
    for (k, &i) in idx[..count].iter().enumerate() {
        out.p[k] = kept[i].0;
    }
    out.n = count;
    let (s, p) = deepest;
    let on_ref = p - rn * s;
    let (wa, wb) = if ref_is_a { (on_ref, p) } else { (p, on_ref) };
    // Only when the pair is `sep` apart along `n` itself, not just in its part along `n`
    // (the reference face may lean by up to `FACE_ALIGNMENT_COS` from `n`): the witness
    // points of the query API are `depth * normal` apart (docs/queries.md).
    if (wb - wa - n * sep).length() <= 1e-6 * size {
        out.witness = Some((wa, wb));
    }
    out
}

//! The manifold of a face contact (the incident face clipped against the reference face's
//! side planes) and of an edge contact (closest points of two segments).

use glam::Vec3;

use super::{Manifold, reduce};
use crate::{ConvexPolyhedron, Pose};

/// Buffers of the face clipping.
#[derive(Default)]
pub(super) struct ClipBuffers {
    pub(super) poly: Vec<Vec3>,
    pub(super) tmp: Vec<Vec3>,
    pub(super) pts: Vec<(Vec3, f32)>,
}

pub(super) fn to_world(mut m: Manifold, pose: &Pose) -> Manifold {
    m.normal = pose.rotation * m.normal;
    for p in &mut m.points[..m.count] {
        p.point = pose.transform_point(p.point);
    }
    m
}

/// Clips the incident face of `inc` (its vertex `i` in `refp`'s frame is `inc_v(i)`, computed
/// only for the vertices needed) against reference face `rf` of `refp`. Normal: the reference
/// face's outward normal (from `refp` to `inc`).
pub(super) fn clip_faces(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
    inc_rot: glam::Mat3,
    clip: &mut ClipBuffers,
) -> Option<Manifold> {
    let rface = refp.faces[rf];
    let n = rface.normal;
    // Incident face: the one most anti-parallel to the reference normal.
    let n_inc = inc_rot.transpose() * n;
    let mut inc_face = 0;
    let mut best = f32::INFINITY;
    for (f, face) in inc.faces.iter().enumerate() {
        let d = face.normal.dot(n_inc);
        if d < best {
            best = d;
            inc_face = f;
        }
    }
    let ClipBuffers { poly, tmp, pts } = clip;
    // The polygons are written by index into buffers at least twice as long as the polygon
    // clipped (clipping by one plane at most doubles a polygon: each corner gives itself
    // and one crossing at most), grown when needed and never shrunk, so that no push
    // checks its capacity.
    let il = inc.face_loop(inc_face);
    fit(poly, 2 * il.len());
    for (slot, &i) in poly.iter_mut().zip(il) {
        *slot = inc_v(i as usize);
    }
    let mut len = il.len();
    for &(side, off) in refp.side_planes(rf) {
        fit(tmp, 2 * len);
        if let Some(kept) = clip_by_plane(&poly[..len], tmp, side, off) {
            len = kept;
            std::mem::swap(poly, tmp);
        }
        if len == 0 {
            break;
        }
    }
    pts.clear();
    for &p in &poly[..len] {
        let depth = rface.offset - n.dot(p);
        if depth > 0.0 {
            pts.push((p + n * (0.5 * depth), depth));
        }
    }
    if pts.is_empty() {
        // The separating-axis test found overlap but the incident face clips away entirely
        // (deep or oblique overlap): keep the contact with the incident body's deepest vertex
        // rather than losing it.
        let deepest = (0..inc.vertices.len())
            .map(inc_v)
            .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))?;
        let depth = rface.offset - n.dot(deepest);
        if depth <= 0.0 {
            return None;
        }
        return Some(Manifold::single(n, deepest + n * (0.5 * depth), depth));
    }
    Some(reduce(pts, n))
}

/// Grows `buf` to at least `len` entries (never shrinks it).
#[inline]
fn fit(buf: &mut Vec<Vec3>, len: usize) {
    if buf.len() < len {
        buf.resize(len, Vec3::ZERO);
    }
}

/// Clips the convex polygon `src` by the side plane `side . x - off <= 0`, writing the
/// kept corners and the edges' crossings in order into `dst` (at least `2 src.len()` long)
/// and returning their count, or `None` when the plane keeps `src` as it is (no copy).
/// Each corner's distance is computed by one expression (the same for it as the start and
/// as the end of an edge, so the same bits), and the loop closes on the first corner.
#[inline(always)]
fn clip_by_plane(src: &[Vec3], dst: &mut [Vec3], side: Vec3, off: f32) -> Option<usize> {
    let Some((&first, rest)) = src.split_first() else {
        return Some(0);
    };
    let d_first = side.dot(first) - off;
    // A plane that every corner is inside (or on) keeps the polygon as it is: no corner is
    // dropped and no edge crosses (a crossing needs a corner strictly outside); then
    // `None`, the polygon in `src` stands, and it is not copied. The scan stops at the
    // first corner outside (its distance computed again below by the same expression: the
    // same float). (Written so that a NaN distance counts as outside, as `dp <= 0` drops
    // such a corner.)
    let outside = |d: f32| {
        !matches!(
            d.partial_cmp(&0.0),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        )
    };
    if !outside(d_first) && !rest.iter().any(|&q| outside(side.dot(q) - off)) {
        return None;
    }
    let mut w = 0;
    let mut edge = |p: Vec3, dp: f32, q: Vec3, dq: f32| {
        if dp <= 0.0 {
            dst[w] = p;
            w += 1;
        }
        if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
            dst[w] = p + (q - p) * (dp / (dp - dq));
            w += 1;
        }
    };
    let (mut p, mut dp) = (first, d_first);
    for &q in rest {
        let dq = side.dot(q) - off;
        edge(p, dp, q, dq);
        (p, dp) = (q, dq);
    }
    edge(p, dp, first, d_first);
    Some(w)
}

/// Closest points of segments `p0-p1` and `q0-q1`.
pub(super) fn segment_closest(p0: Vec3, p1: Vec3, q0: Vec3, q1: Vec3) -> (Vec3, Vec3) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    let c = d1.dot(r);
    let b = d1.dot(d2);
    let denom = a * e - b * b;
    let mut s = if denom > 1e-12 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = if e > 0.0 { (b * s + f) / e } else { 0.0 };
    if t < 0.0 {
        t = 0.0;
        s = if a > 0.0 {
            (-c / a).clamp(0.0, 1.0)
        } else {
            0.0
        };
    } else if t > 1.0 {
        t = 1.0;
        s = if a > 0.0 {
            ((b - c) / a).clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    (p0 + d1 * s, q0 + d2 * t)
}

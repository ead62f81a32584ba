//! Closed-form paths for rectangular boxes (recognised by [`super::support::as_box`]): sphere
//! against box by clamping in the box frame, and box against box by the 15-axis separating-axis
//! test, which gives the exact penetration depth and normal of two boxes.

use glam::{DMat3, DVec3};

use super::Raw;
use super::support::{DPose, Obb};

/// Sphere of centre `c` (box principal frame) and radius `r` against the box: a
/// contact-type result (signed separation, normal from box to sphere, points on each).
/// With `common_point`, an overlapping result carries a point common to both shapes in `pa`
/// and `pb` (distance-type result) instead of the deepest points.
pub(crate) fn sphere_box(o: &Obb, c: DVec3, r: f64, common_point: bool) -> Raw {
    let at = o.axes.transpose();
    let cb = at * c;
    let h = o.half;
    let q = cb.clamp(-h, h);
    let d = cb - q;
    let dist2 = d.length_squared();
    if dist2 > 0.0 {
        let dist = dist2.sqrt();
        let n = d / dist;
        let overlap = dist <= r;
        if overlap && common_point {
            let p = o.axes * q;
            return Raw { sep: 0.0, normal: DVec3::ZERO, pa: p, pb: p, overlap };
        }
        let normal = o.axes * n;
        return Raw {
            sep: dist - r,
            normal,
            pa: o.axes * q,
            pb: c - normal * r,
            overlap,
        };
    }
    // Centre inside: the nearest face.
    if common_point {
        return Raw { sep: 0.0, normal: DVec3::ZERO, pa: c, pb: c, overlap: true };
    }
    let room = h - cb.abs();
    let i = if room.x <= room.y && room.x <= room.z {
        0
    } else if room.y <= room.z {
        1
    } else {
        2
    };
    let mut nb = DVec3::ZERO;
    nb[i] = if cb[i] >= 0.0 { 1.0 } else { -1.0 };
    let normal = o.axes * nb;
    Raw {
        sep: -room[i] - r,
        normal,
        pa: c + normal * room[i],
        pb: c - normal * r,
        overlap: true,
    }
}

/// Separating-axis test of box `a` (at the query-frame origin) and box `b` at `rel`.
/// `None` when an axis separates them (strictly positive gap); otherwise the contact-type
/// result with the exact depth, the normal from `a` to `b` and the deepest points.
/// With `early`, returns as soon as the overlap is known, with a placeholder result.
pub(crate) fn box_box(a: &Obb, b: &Obb, rel: &DPose, early: bool) -> Option<Raw> {
    // Everything in a's box frame: a's axes are e0, e1, e2.
    let at = a.axes.transpose();
    let bm = at * rel.rot * b.axes; // columns: b's axes
    let t = at * rel.pos;
    let (ha, hb) = (a.half, b.half);
    let bc = [bm.x_axis, bm.y_axis, bm.z_axis];
    let hbv = [hb.x, hb.y, hb.z];
    let radius_a = |l: DVec3| ha.dot(l.abs());
    let radius_b = |l: DVec3| {
        hbv[0] * l.dot(bc[0]).abs() + hbv[1] * l.dot(bc[1]).abs() + hbv[2] * l.dot(bc[2]).abs()
    };
    // (penetration, unit axis oriented from a to b, feature: 0..3 a's face, 3..6 b's face,
    // 6.. edge pair 3 i + j).
    let mut best = (f64::INFINITY, DVec3::X, 0usize);
    let scale = ha.length() + hb.length();
    let mut test = |l: DVec3, len: f64, feature: usize| -> bool {
        let tl = t.dot(l);
        let pen = (radius_a(l) + radius_b(l) - tl.abs()) / len;
        if pen < 0.0 {
            return false;
        }
        // Edge axes must win by a margin over face axes (flat contacts stay face contacts).
        let bias = if feature >= 6 { 1e-9 * scale } else { 0.0 };
        if pen + bias < best.0 {
            let n = l / len;
            best = (pen, if tl >= 0.0 { n } else { -n }, feature);
        }
        true
    };
    for (i, e) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
        if !test(e, 1.0, i) {
            return None;
        }
    }
    for (j, &c) in bc.iter().enumerate() {
        if !test(c, 1.0, 3 + j) {
            return None;
        }
    }
    for (i, e) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
        for (j, &c) in bc.iter().enumerate() {
            let l = e.cross(c);
            let len = l.length();
            // Parallel edges: the face axes already cover this direction.
            if len < 1e-6 {
                continue;
            }
            if !test(l, len, 6 + 3 * i + j) {
                return None;
            }
        }
    }
    if early {
        return Some(Raw { sep: 0.0, normal: DVec3::X, pa: DVec3::ZERO, pb: DVec3::ZERO, overlap: true });
    }
    let (depth, n, feature) = best;
    let sgn = |x: f64| if x >= 0.0 { 1.0 } else { -1.0 };
    let support_a = |d: DVec3| DVec3::new(sgn(d.x) * ha.x, sgn(d.y) * ha.y, sgn(d.z) * ha.z);
    let support_b = |d: DVec3| {
        t + bc[0] * (sgn(d.dot(bc[0])) * hbv[0])
            + bc[1] * (sgn(d.dot(bc[1])) * hbv[1])
            + bc[2] * (sgn(d.dot(bc[2])) * hbv[2])
    };
    let (pa, pb) = if feature < 3 {
        let pb = support_b(-n);
        (pb + n * depth, pb)
    } else if feature < 6 {
        let pa = support_a(n);
        (pa, pa - n * depth)
    } else {
        let (i, j) = ((feature - 6) / 3, (feature - 6) % 3);
        // a's edge along e_i through its support vertex, b's edge along b_j likewise.
        let mut ca = support_a(n);
        ca[i] = 0.0;
        let da = DVec3::AXES[i];
        let cb = support_b(-n) - bc[j] * (bc[j].dot(support_b(-n) - t));
        let (sa, sb) = closest_on_segments(ca, da, ha[i], cb, bc[j], hbv[j]);
        (sa, sb)
    };
    let m: DMat3 = a.axes;
    Some(Raw { sep: -depth, normal: m * n, pa: m * pa, pb: m * pb, overlap: true })
}

/// Closest points of the segments `ca ± s da` (|s| <= ea) and `cb ± s db` (|s| <= eb), unit
/// directions.
fn closest_on_segments(ca: DVec3, da: DVec3, ea: f64, cb: DVec3, db: DVec3, eb: f64) -> (DVec3, DVec3) {
    let r = ca - cb;
    let b = da.dot(db);
    let c = da.dot(r);
    let f = db.dot(r);
    let den = 1.0 - b * b;
    let mut s = if den > 1e-12 { ((b * f - c) / den).clamp(-ea, ea) } else { 0.0 };
    let tt = (b * s + f).clamp(-eb, eb);
    s = (b * tt - c).clamp(-ea, ea);
    (ca + da * s, cb + db * tt)
}

//! Closed-form paths for rectangular boxes (recognised by [`super::support::as_box`]): sphere
//! against box by clamping in the box frame, and box against box by the 15-axis separating-axis
//! test, which gives the exact penetration depth and normal of two boxes.

use glam::{DMat3, DVec3};

use super::Raw;
use super::support::{DPose, Obb};

/// Sphere of centre `c` (box principal frame) and radius `r` against the box: a
/// contact-type result (signed separation, normal from box to sphere, points on each).
/// With `common_point`, an overlapping result carries a point common to both shapes in `pa`
/// and `pb` (distance-type result) instead of the witness points.
pub(crate) fn sphere_box(o: &Obb, c: DVec3, r: f64, common_point: bool) -> Raw {
    if !o.aligned {
        // Solve in the box's axes and map back.
        let al = Obb {
            axes: DMat3::IDENTITY,
            half: o.half,
            aligned: true,
        };
        let x = sphere_box(&al, o.axes.transpose() * c, r, common_point);
        let m = o.axes;
        return Raw {
            normal: m * x.normal,
            pa: m * x.pa,
            pb: m * x.pb,
            ..x
        };
    }
    let cb = c;
    let h = o.half;
    let q = cb.clamp(-h, h);
    let d = cb - q;
    let dist2 = d.length_squared();
    if dist2 > 0.0 {
        let dist = dist2.sqrt();
        let n = d / dist;
        let overlap = dist <= r;
        if overlap && common_point {
            return Raw {
                sep: 0.0,
                normal: DVec3::ZERO,
                pa: q,
                pb: q,
                overlap,
            };
        }
        return Raw {
            sep: dist - r,
            normal: n,
            pa: q,
            pb: c - n * r,
            overlap,
        };
    }
    // Centre inside: the nearest face.
    if common_point {
        return Raw {
            sep: 0.0,
            normal: DVec3::ZERO,
            pa: c,
            pb: c,
            overlap: true,
        };
    }
    let room = h - cb.abs();
    let i = if room.x <= room.y && room.x <= room.z {
        0
    } else if room.y <= room.z {
        1
    } else {
        2
    };
    let mut normal = DVec3::ZERO;
    normal[i] = if cb[i] >= 0.0 { 1.0 } else { -1.0 };
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
/// result with the exact depth, the normal from `a` to `b` and witness points
/// (`pa - pb = depth * normal`).
/// With `early`, returns as soon as the overlap is known, with a placeholder result.
///
/// In `a`'s box frame, `r[i][j] = a_i · b_j`; the 15 axes are `a_i`, `b_j` and `a_i × b_j`
/// (Gottschalk's OBB test, with the depth of each axis kept for the contact).
pub(crate) fn box_box(a: &Obb, b: &Obb, rel: &DPose, early: bool) -> Option<Raw> {
    let (bm, t) = if a.aligned {
        (if b.aligned { rel.rot } else { rel.rot * b.axes }, rel.pos)
    } else {
        let at = a.axes.transpose();
        (at * rel.rot * b.axes, at * rel.pos)
    };
    let (ha, hb) = (a.half, b.half);
    let bc = [bm.x_axis, bm.y_axis, bm.z_axis];
    // r[i][j] = a_i · b_j = component i of b's axis j.
    let r = [
        [bc[0].x, bc[1].x, bc[2].x],
        [bc[0].y, bc[1].y, bc[2].y],
        [bc[0].z, bc[1].z, bc[2].z],
    ];
    let ar = r.map(|row| row.map(f64::abs));
    let hav = [ha.x, ha.y, ha.z];
    let hbv = [hb.x, hb.y, hb.z];
    let tv = [t.x, t.y, t.z];
    // (penetration, signed distance of centres along the axis, axis length, feature):
    // feature 0..3 a's face, 3..6 b's face, 6.. edge pair 6 + 3 i + j.
    let mut best = (f64::INFINITY, 0.0, 1.0, 0usize);
    let scale = ha.length() + hb.length();
    for i in 0..3 {
        let rb = hbv[0] * ar[i][0] + hbv[1] * ar[i][1] + hbv[2] * ar[i][2];
        let pen = hav[i] + rb - tv[i].abs();
        if pen < 0.0 {
            return None;
        }
        if pen < best.0 {
            best = (pen, tv[i], 1.0, i);
        }
    }
    for j in 0..3 {
        let ra = hav[0] * ar[0][j] + hav[1] * ar[1][j] + hav[2] * ar[2][j];
        let tl = tv[0] * r[0][j] + tv[1] * r[1][j] + tv[2] * r[2][j];
        let pen = ra + hbv[j] - tl.abs();
        if pen < 0.0 {
            return None;
        }
        if pen < best.0 {
            best = (pen, tl, 1.0, 3 + j);
        }
    }
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            // |a_i × b_j|² = 1 - r[i][j]²; parallel edges are covered by the face axes.
            let len2 = 1.0 - r[i][j] * r[i][j];
            if len2 < 1e-12 {
                continue;
            }
            let ra = hav[i1] * ar[i2][j] + hav[i2] * ar[i1][j];
            let rb = hbv[j1] * ar[i][j2] + hbv[j2] * ar[i][j1];
            let tl = tv[i2] * r[i1][j] - tv[i1] * r[i2][j];
            let pen = ra + rb - tl.abs();
            if pen < 0.0 {
                return None;
            }
            let len = len2.sqrt();
            // Edge axes must win by a margin over face axes (flat contacts stay face contacts).
            if pen / len + 1e-9 * scale < best.0 {
                best = (pen / len, tl, len, 6 + 3 * i + j);
            }
        }
    }
    if early {
        return Some(Raw {
            sep: 0.0,
            normal: DVec3::X,
            pa: DVec3::ZERO,
            pb: DVec3::ZERO,
            overlap: true,
        });
    }
    let (depth, tl, len, feature) = best;
    let sgn = |x: f64| if x >= 0.0 { 1.0 } else { -1.0 };
    let axis = match feature {
        0..3 => DVec3::AXES[feature],
        3..6 => bc[feature - 3],
        _ => DVec3::AXES[(feature - 6) / 3].cross(bc[(feature - 6) % 3]) / len,
    };
    let n = axis * sgn(tl);
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
        let sb = support_b(-n);
        let cb = sb - bc[j] * bc[j].dot(sb - t);
        closest_on_segments(ca, DVec3::AXES[i], hav[i], cb, bc[j], hbv[j])
    };
    if a.aligned {
        return Some(Raw {
            sep: -depth,
            normal: n,
            pa,
            pb,
            overlap: true,
        });
    }
    let m: DMat3 = a.axes;
    Some(Raw {
        sep: -depth,
        normal: m * n,
        pa: m * pa,
        pb: m * pb,
        overlap: true,
    })
}

/// Closest points of the segments `ca ± s da` (|s| <= ea) and `cb ± s db` (|s| <= eb), unit
/// directions.
fn closest_on_segments(
    ca: DVec3,
    da: DVec3,
    ea: f64,
    cb: DVec3,
    db: DVec3,
    eb: f64,
) -> (DVec3, DVec3) {
    let r = ca - cb;
    let b = da.dot(db);
    let c = da.dot(r);
    let f = db.dot(r);
    let den = 1.0 - b * b;
    let mut s = if den > 1e-12 {
        ((b * f - c) / den).clamp(-ea, ea)
    } else {
        0.0
    };
    let tt = (b * s + f).clamp(-eb, eb);
    s = (b * tt - c).clamp(-ea, ea);
    (ca + da * s, cb + db * tt)
}

//! A sphere against a convex polyhedron: from scratch, or with what the pair remembers from
//! earlier steps ([`EdgeMemory`]'s sphere kind) for the same manifold, bitwise.
//!
//! The full computation, in the polyhedron's frame with the sphere's centre at `c`: each
//! face's separation `s_i = n_i . c - o_i`; the largest decides between the centre inside
//! (push out through that face) and outside; outside, the closest point of each face with
//! `s_i > 0` (its plane's projection when that falls inside the face's loop, else the
//! closest point of its edges) and the nearest of them, in face order.
//!
//! What a pair remembers, and why the answer is the same: at a recording (a full
//! computation at centre `c0`) the faces with `s_i > 0`, or, with the centre inside, the
//! face of the largest separation; the faces whose projection fell inside their loop; and
//! the margins of those decisions. Each `s_i` is linear in `c` with a unit gradient, and each
//! in-loop test `(b - a) x (proj - a) . n` linear with a gradient of length at most `|b -
//! a|`; so while the centre stays within a margin of `c0` (less what rounding may move
//! each computed value, at both ends), every decision comes out the same, and the work
//! left (the separations of the remembered faces, in the same order, with the same
//! arithmetic) gives the same bits.

use glam::Vec3;

use super::{EdgeMemory, Manifold};
use crate::{ConvexPolyhedron, Pose};

/// The rounding allowed for, as a fraction of the pair's reach (the polyhedron's bounding
/// radius plus the sphere's): of each separation and in-loop test at both ends of a
/// comparison (a few ulps of values at most a few reaches: about 1e-5 of the reach) and of
/// the centre in the polyhedron's frame, with room to spare.
const ROUNDING: f32 = 1e-4;

/// Sphere `a` (centre, radius) against polyhedron `b` at `pose`; normal from sphere to polyhedron.
pub fn sphere_polyhedron(
    centre: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    pose: &Pose,
) -> Option<Manifold> {
    sphere_polyhedron_with(centre, radius, p, pose, &mut 0.0, None)
}

/// [`sphere_polyhedron`] with the pair's `bound` and, if it has one, its memory (read and
/// updated): the same manifold, bitwise. On return `bound` is, for a pair found apart, a
/// lower bound of the distance between the sphere and the polyhedron less what rounding may
/// hide (so that while both bodies have moved less than it, the computation still finds
/// them apart), else 0.
pub(super) fn sphere_polyhedron_with(
    centre: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    pose: &Pose,
    bound: &mut f32,
    memory: Option<&mut EdgeMemory>,
) -> Option<Manifold> {
    *bound = 0.0;
    let c = pose.inverse_transform_point(centre);
    let reach = p.radius + radius;
    let c2 = c.length_squared();
    if c2 >= reach * reach {
        *bound = apart(c2.sqrt() - reach, reach);
        return None;
    }
    let found = match memory {
        None => sphere_full(c, radius, p, bound, &mut Record::default()),
        Some(m) => {
            if let Some(found) = m.sphere_faces(p, c).and_then(|k| sphere_known(c, radius, p, bound, k)) {
                found
            } else {
                // Record again.
                m.clear();
                let mut record = Record {
                    on: p.faces.len() <= 128,
                    ..Default::default()
                };
                let found = sphere_full(c, radius, p, bound, &mut record);
                if record.on {
                    let slack = ROUNDING * reach;
                    m.record_sphere(
                        p,
                        c,
                        record.best,
                        record.positive,
                        record.margin - slack,
                        record.inside,
                        record.inside_margin - slack,
                    );
                }
                found
            }
        }
    };
    found.map(|(surface, n_local, depth)| to_world(c, radius, surface, n_local, depth, pose))
}

/// The bound of a pair apart by `gap` (a distance computed in floats): the gap less the
/// rounding of it and of the next computations, 0 when that leaves nothing.
#[inline]
fn apart(gap: f32, reach: f32) -> f32 {
    let b = gap - ROUNDING * reach;
    if b > 0.0 { b } else { 0.0 }
}

/// The manifold from the local closest point, normal and depth.
#[inline]
fn to_world(
    c: Vec3,
    radius: f32,
    surface: Vec3,
    n_local: Vec3,
    depth: f32,
    pose: &Pose,
) -> Manifold {
    let deepest = c + n_local * radius;
    let mid = 0.5 * (surface + deepest);
    Manifold::single(pose.rotation * n_local, pose.transform_point(mid), depth)
}

/// What a full computation finds for the memory (when `on`).
#[derive(Default)]
struct Record {
    on: bool,
    /// The face of the largest separation.
    best: usize,
    /// The faces with a positive separation.
    positive: u128,
    /// Outside: the smallest |separation| of any face; inside: half the gap between the
    /// largest separation and the next.
    margin: f32,
    /// The positive faces whose projection fell inside their loop ...
    inside: u128,
    /// ... and the smallest in-loop test of theirs over its edge's length.
    inside_margin: f32,
}

/// What the memory knows at the current centre: the faces with a positive separation
/// (none: the centre is inside, and `best` has the largest separation) and which of them
/// take their plane's projection.
#[derive(Clone, Copy)]
pub(super) struct KnownFaces {
    pub(super) best: usize,
    pub(super) positive: u128,
    /// `None` when the in-loop tests must run.
    pub(super) inside: Option<u128>,
}

/// The full computation in the polyhedron's frame: the surface point, the normal (local,
/// from the sphere towards the polyhedron) and the depth; `None` when apart (then `bound`
/// as [`sphere_polyhedron_with`] says). Fills `record` when it is on.
#[inline]
fn sphere_full(
    c: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    bound: &mut f32,
    record: &mut Record,
) -> Option<(Vec3, Vec3, f32)> {
    let mut best_face = 0;
    let mut best_sep = f32::NEG_INFINITY;
    if record.on {
        // The same loop, with the next largest separation, the smallest magnitude and the
        // positive faces kept.
        let mut second = f32::NEG_INFINITY;
        let mut least = f32::INFINITY;
        for (i, f) in p.faces.iter().enumerate() {
            let s = f.normal.dot(c) - f.offset;
            if s > best_sep {
                second = best_sep;
                best_sep = s;
                best_face = i;
            } else if s > second {
                second = s;
            }
            least = least.min(s.abs());
            if s > 0.0 {
                record.positive |= 1 << i;
            }
            // (A NaN never remembers.)
            if s.is_nan() {
                least = 0.0;
            }
        }
        record.best = best_face;
        record.margin = if best_sep > 0.0 {
            least
        } else {
            0.5 * (best_sep - second)
        };
    } else {
        for (i, f) in p.faces.iter().enumerate() {
            let s = f.normal.dot(c) - f.offset;
            if s > best_sep {
                best_sep = s;
                best_face = i;
            }
        }
    }
    if best_sep >= radius {
        *bound = apart(best_sep - radius, p.radius + radius);
        return None;
    }
    if best_sep <= 0.0 {
        // Centre inside: push out through the nearest face.
        let n = p.faces[best_face].normal;
        return Some((c - n * best_sep, -n, radius - best_sep));
    }
    let mut q = c;
    let mut best_d2 = f32::INFINITY;
    let mut inside_margin = f32::INFINITY;
    for (i, f) in p.faces.iter().enumerate() {
        if f.normal.dot(c) - f.offset > 0.0 {
            let cand = if record.on {
                let (cand, m) = closest_on_face_recording(p, i, c);
                if let Some(m) = m {
                    record.inside |= 1 << i;
                    inside_margin = inside_margin.min(m);
                }
                cand
            } else {
                closest_on_face(p, i, c, false)
            };
            let d2 = (cand - c).length_squared();
            if d2 < best_d2 {
                best_d2 = d2;
                q = cand;
            }
        }
    }
    record.inside_margin = inside_margin;
    outside(c, radius, p, bound, q, best_d2, best_face)
}

/// The computation with the faces known ([`KnownFaces`]): the same results as
/// [`sphere_full`], bitwise; `None` when the memory cannot decide (the centre was inside
/// and its nearest face's separation has turned positive).
#[inline]
#[allow(clippy::option_option)]
fn sphere_known(
    c: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    bound: &mut f32,
    k: KnownFaces,
) -> Option<Option<(Vec3, Vec3, f32)>> {
    if k.positive == 0 {
        // Inside, the largest separation's face known; when its separation has turned
        // positive, the full computation decides.
        let f = p.faces[k.best];
        let best_sep = f.normal.dot(c) - f.offset;
        if best_sep <= 0.0 {
            let n = f.normal;
            return Some(Some((c - n * best_sep, -n, radius - best_sep)));
        }
        return None;
    }
    // Outside: the largest separation is among the positive faces (the rest are at most 0),
    // first in face order on a tie as in the full loop.
    let mut best_face = 0;
    let mut best_sep = f32::NEG_INFINITY;
    let mut bits = k.positive;
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let f = p.faces[i];
        let s = f.normal.dot(c) - f.offset;
        if s > best_sep {
            best_sep = s;
            best_face = i;
        }
    }
    if best_sep >= radius {
        *bound = apart(best_sep - radius, p.radius + radius);
        return Some(None);
    }
    let mut q = c;
    let mut best_d2 = f32::INFINITY;
    let mut bits = k.positive;
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let inside = k.inside.is_some_and(|m| m & (1 << i) != 0);
        let cand = closest_on_face(p, i, c, inside);
        let d2 = (cand - c).length_squared();
        if d2 < best_d2 {
            best_d2 = d2;
            q = cand;
        }
    }
    Some(outside(c, radius, p, bound, q, best_d2, best_face))
}

/// The end of the outside case: the nearest point `q` at squared distance `best_d2`.
#[inline]
fn outside(
    c: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    bound: &mut f32,
    q: Vec3,
    best_d2: f32,
    best_face: usize,
) -> Option<(Vec3, Vec3, f32)> {
    let dist = best_d2.sqrt();
    if dist >= radius {
        *bound = apart(dist - radius, p.radius + radius);
        return None;
    }
    let n = if dist > 1e-12 {
        (q - c) / dist
    } else {
        -p.faces[best_face].normal
    };
    Some((q, n, radius - dist))
}

/// The projection of `x` on face `f`'s plane, all in `p`'s local frame.
#[inline]
fn projection(p: &ConvexPolyhedron, f: usize, x: Vec3) -> Vec3 {
    let face = p.faces[f];
    x - face.normal * (face.normal.dot(x) - face.offset)
}

/// The loop's next corner without a division (`(k + 1) % len`).
#[inline]
fn next(k: usize, len: usize) -> usize {
    if k + 1 < len { k + 1 } else { 0 }
}

/// Closest point of a convex polygon (a face loop of `p`) to `x`, all in `p`'s local frame;
/// `inside`: the projection is known to fall inside the loop (the tests are left out).
#[inline]
fn closest_on_face(p: &ConvexPolyhedron, f: usize, x: Vec3, inside: bool) -> Vec3 {
    let proj = projection(p, f, x);
    if inside {
        return proj;
    }
    let n = p.faces[f].normal;
    let lp = p.face_loop(f);
    let mut inside = true;
    for k in 0..lp.len() {
        let a = p.vertices[lp[k] as usize];
        let b = p.vertices[lp[next(k, lp.len())] as usize];
        if (b - a).cross(proj - a).dot(n) < 0.0 {
            inside = false;
            break;
        }
    }
    if inside {
        return proj;
    }
    closest_on_edges(p, f, x, proj)
}

/// [`closest_on_face`] (the same bits) with, when the projection falls inside the loop, the
/// smallest of its in-loop tests over the length of the test's edge (`None` if not inside
/// or not a positive finite number).
fn closest_on_face_recording(p: &ConvexPolyhedron, f: usize, x: Vec3) -> (Vec3, Option<f32>) {
    let proj = projection(p, f, x);
    let n = p.faces[f].normal;
    let lp = p.face_loop(f);
    let mut inside = true;
    let mut least = f32::INFINITY;
    for k in 0..lp.len() {
        let a = p.vertices[lp[k] as usize];
        let b = p.vertices[lp[next(k, lp.len())] as usize];
        let e = (b - a).cross(proj - a).dot(n);
        if e < 0.0 {
            inside = false;
            break;
        }
        let m = e / (b - a).length();
        least = if m < least { m } else { least };
        if !m.is_finite() {
            least = 0.0;
        }
    }
    if inside {
        return (proj, (least > 0.0 && least.is_finite()).then_some(least));
    }
    (closest_on_edges(p, f, x, proj), None)
}

/// The closest point to `x` of face `f`'s edges (`proj` when the loop has none).
#[inline]
fn closest_on_edges(p: &ConvexPolyhedron, f: usize, x: Vec3, proj: Vec3) -> Vec3 {
    let lp = p.face_loop(f);
    let mut best = proj;
    let mut best_d = f32::INFINITY;
    for k in 0..lp.len() {
        let a = p.vertices[lp[k] as usize];
        let b = p.vertices[lp[next(k, lp.len())] as usize];
        let q = closest_on_segment(a, b, x);
        let d = (q - x).length_squared();
        if d < best_d {
            best_d = d;
            best = q;
        }
    }
    best
}

#[inline]
fn closest_on_segment(a: Vec3, b: Vec3, x: Vec3) -> Vec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 0.0 {
        return a;
    }
    a + ab * ((x - a).dot(ab) / len2).clamp(0.0, 1.0)
}

//! A sphere against a convex polyhedron: from scratch, or with what the pair remembers from
//! earlier steps ([`SphereMemory`], kept in the pair's [`EdgeMemory`]) for the same
//! manifold and bound, bitwise.
//!
//! The full computation, in the polyhedron's frame with the sphere's centre at `c`: each
//! face's separation `s_i = n_i . c - o_i`; the largest decides between the centre inside
//! (push out through that face) and outside; outside, each face with `s_i > 0` gives a
//! candidate (its plane's projection when that falls inside the face's loop, else the
//! nearest of its edges' closest points, first in loop order on a tie) and the nearest
//! candidate wins (first in face order on a tie).
//!
//! What a pair remembers, and why the answer is the same bits: a recording (a full
//! computation at centre `c0`) keeps the faces with `s_i > 0` (or, with the centre inside,
//! the face of the largest separation), and of those the faces whose candidate may still
//! win, each with what its candidate needs: the projection (known to fall inside its loop),
//! the edges whose closest points may still be the nearest (the projection known to fall
//! outside), or the full face test. Every decision is a comparison of quantities that move
//! by at most `|c - c0|` in exact arithmetic: the separations (unit gradients), the in-loop
//! tests `(b - a) x (proj - a) . n` over `|b - a|` (gradients `n x (b - a)` over `|b - a|`),
//! and the distances to a segment or a face (1-Lipschitz). Each is kept out of the
//! remembered work only with a margin of at least [`SphereMemory`]'s radius `mu` plus
//! [`ROUNDING`] (twice that for a comparison of two distances); so while the centre stays
//! within `mu` of `c0`, each left-out face or edge would have lost its comparison (strictly:
//! it was not the first of the nearest), each known in-loop test comes out the same, and
//! the remembered work runs the same arithmetic on the same candidates in the same order.

use glam::Vec3;

use super::{EdgeMemory, Manifold};
use crate::{ConvexPolyhedron, Pose};

/// The rounding allowed for, as a fraction of the pair's reach (the polyhedron's bounding
/// radius plus the sphere's): of the centre in the polyhedron's frame, and of each
/// separation, in-loop test and distance at both ends of a comparison (a few ulps of
/// values of at most a few reaches: about 1e-5 of the reach), with room to spare. Also
/// taken off an apart pair's bound.
const ROUNDING: f32 = 1e-4;

/// The largest radius a memory is recorded with, as a fraction of the reach: larger keeps
/// more faces and edges within its margins, smaller records more often.
const RADIUS: f32 = 0.01;

/// How many faces' candidates a memory keeps (more: it keeps none, and the recorded faces
/// go through the full face test).
const KEPT: usize = 8;

/// How a kept face's candidate is found.
const MODE_FULL: u8 = 0;
const MODE_INSIDE: u8 = 1;
const MODE_EDGES: u8 = 2;

/// What a sphere-polyhedron pair remembers (see the module's notes): valid while the
/// sphere's centre in the polyhedron's frame stays within `mu` of `centre`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SphereMemory {
    /// The centre at the recording.
    centre: Vec3,
    /// `mu^2` (0: nothing remembered).
    mu2: f32,
    /// The face of the largest separation (used with the centre inside).
    best: u8,
    /// The faces with a positive separation (none: the centre was inside).
    positive: u128,
    /// Whether `kept` holds the outside case's candidates (not when the pair was found
    /// apart by a face's plane: the candidates were not computed).
    candidates: bool,
    /// How many faces are kept ...
    len: u8,
    /// ... which (in increasing order) ...
    face: [u8; KEPT],
    /// ... how each finds its candidate ...
    mode: [u8; KEPT],
    /// ... and, by edges, which edges of its loop (bit `k`: from corner `k`).
    edges: [u32; KEPT],
}

impl SphereMemory {
    /// Whether a recording kept anything.
    #[inline]
    pub(super) fn remembers(&self) -> bool {
        self.mu2 > 0.0
    }

    /// Whether it holds at centre `c` (its squared distance taken with a relative margin
    /// for its rounding; written so that a NaN fails too).
    #[inline]
    pub(super) fn holds(&self, c: Vec3) -> bool {
        (c - self.centre).length_squared() * 1.001 < self.mu2
    }
}

/// Sphere `a` (centre, radius) against polyhedron `b` at `pose`; normal from sphere to polyhedron.
pub fn sphere_polyhedron(
    centre: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    pose: &Pose,
) -> Option<Manifold> {
    sphere_polyhedron_with(centre, radius, p, pose, &mut 0.0, None)
}

/// A result in the polyhedron's frame: the surface point, the normal (from the sphere
/// towards the polyhedron) and the depth.
type Local = Option<(Vec3, Vec3, f32)>;

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
        None => sphere_full(c, radius, p, bound, None),
        Some(m) => {
            let known = m
                .sphere(p)
                .filter(|s| s.holds(c))
                .and_then(|s| sphere_known(c, radius, p, bound, s));
            match known {
                Some(found) => found,
                None => {
                    // Record again.
                    let mut record = SphereMemory::default();
                    let on = p.faces.len() <= 128;
                    let found = sphere_full(c, radius, p, bound, on.then_some(&mut record));
                    m.record_sphere(p, record);
                    found
                }
            }
        }
    };
    found.map(|(surface, n_local, depth)| {
        let deepest = c + n_local * radius;
        let mid = 0.5 * (surface + deepest);
        Manifold::single(pose.rotation * n_local, pose.transform_point(mid), depth)
    })
}

/// The bound of a pair apart by `gap` (a distance computed in floats): the gap less the
/// rounding of it and of the next computations, 0 when that leaves nothing.
#[inline]
fn apart(gap: f32, reach: f32) -> f32 {
    let b = gap - ROUNDING * reach;
    if b > 0.0 { b } else { 0.0 }
}

/// The full computation; `None` when apart (then `bound` as [`sphere_polyhedron_with`]
/// says). With `record`, also what a memory keeps (`mu2` left 0 when nothing can be kept).
#[inline]
fn sphere_full(
    c: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    bound: &mut f32,
    record: Option<&mut SphereMemory>,
) -> Local {
    let reach = p.radius + radius;
    let mut best_face = 0;
    let mut best_sep = f32::NEG_INFINITY;
    let Some(rec) = record else {
        for (i, f) in p.faces.iter().enumerate() {
            let s = f.normal.dot(c) - f.offset;
            if s > best_sep {
                best_sep = s;
                best_face = i;
            }
        }
        if best_sep >= radius {
            *bound = apart(best_sep - radius, reach);
            return None;
        }
        if best_sep <= 0.0 {
            return Some(inside(c, radius, p, best_face, best_sep));
        }
        let mut q = c;
        let mut best_d2 = f32::INFINITY;
        for (i, f) in p.faces.iter().enumerate() {
            if f.normal.dot(c) - f.offset > 0.0 {
                let cand = closest_on_face(p, i, c);
                let d2 = (cand - c).length_squared();
                if d2 < best_d2 {
                    best_d2 = d2;
                    q = cand;
                }
            }
        }
        return outside(c, radius, p, bound, q, best_d2, best_face);
    };
    // The same loop, with the next largest separation, the smallest magnitude and the
    // positive faces kept.
    let mut second = f32::NEG_INFINITY;
    let mut least = f32::INFINITY;
    let mut nan = false;
    for (i, f) in p.faces.iter().enumerate() {
        let s = f.normal.dot(c) - f.offset;
        if s > best_sep {
            second = best_sep;
            best_sep = s;
            best_face = i;
        } else if s > second {
            second = s;
        }
        let a = s.abs();
        least = if a < least { a } else { least };
        nan |= s.is_nan();
        if s > 0.0 {
            rec.positive |= 1 << i;
        }
    }
    let slack = ROUNDING * reach;
    rec.centre = c;
    rec.best = best_face as u8;
    // The radius: the separations keep their signs (outside) or the largest stays the
    // largest (inside: both sides of each comparison move).
    let mu = if best_sep > 0.0 {
        least.min(RADIUS * reach) - slack
    } else {
        0.5 * (best_sep - second) - slack
    };
    if nan || mu.is_nan() || mu <= 0.0 {
        // Nothing kept; the computation goes on as without a memory.
        return sphere_full(c, radius, p, bound, None);
    }
    rec.mu2 = mu * mu;
    if best_sep >= radius {
        *bound = apart(best_sep - radius, reach);
        return None;
    }
    if best_sep <= 0.0 {
        return Some(inside(c, radius, p, best_face, best_sep));
    }
    // Outside: each positive face's candidate, recorded.
    let tol = mu + slack;
    let mut q = c;
    let mut best_d2 = f32::INFINITY;
    let mut cands = [(0u8, 0.0f32, MODE_FULL, 0u32); 16];
    let mut n = 0;
    for (i, f) in p.faces.iter().enumerate() {
        if f.normal.dot(c) - f.offset > 0.0 {
            let (cand, mode, edges) = closest_on_face_recording(p, i, c, tol);
            let d2 = (cand - c).length_squared();
            if d2 < best_d2 {
                best_d2 = d2;
                q = cand;
            }
            if n < cands.len() {
                cands[n] = (i as u8, d2, mode, edges);
            }
            n += 1;
        }
    }
    // The faces whose candidate may still be the nearest.
    if n <= cands.len() {
        let near = best_d2.sqrt() + 2.0 * tol;
        let mut kept = 0;
        for &(i, d2, mode, edges) in &cands[..n] {
            // (Written so that a NaN keeps the face.)
            if d2.sqrt() > near {
                continue;
            }
            if kept == KEPT {
                kept = usize::MAX;
                break;
            }
            (rec.face[kept], rec.mode[kept], rec.edges[kept]) = (i, mode, edges);
            kept += 1;
        }
        if kept <= KEPT {
            rec.len = kept as u8;
            rec.candidates = true;
        }
    }
    outside(c, radius, p, bound, q, best_d2, best_face)
}

/// The computation with what `m` remembers (it holds at `c`): the same results as
/// [`sphere_full`], bitwise; `None` when the memory cannot decide (the centre was inside
/// and its face's separation has turned positive; found apart by a face's plane and now
/// not).
#[inline]
fn sphere_known(
    c: Vec3,
    radius: f32,
    p: &ConvexPolyhedron,
    bound: &mut f32,
    m: &SphereMemory,
) -> Option<Local> {
    if m.positive == 0 {
        // Inside, the largest separation's face known.
        let best = m.best as usize;
        let f = p.faces[best];
        let best_sep = f.normal.dot(c) - f.offset;
        return (best_sep <= 0.0).then(|| Some(inside(c, radius, p, best, best_sep)));
    }
    // Outside: the largest separation is among the positive faces (the rest are at most 0),
    // first in face order on a tie as in the full loop.
    let mut best_face = 0;
    let mut best_sep = f32::NEG_INFINITY;
    let mut bits = m.positive;
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
    if !m.candidates {
        return None;
    }
    let mut q = c;
    let mut best_d2 = f32::INFINITY;
    for k in 0..m.len as usize {
        let i = m.face[k] as usize;
        let cand = match m.mode[k] {
            MODE_INSIDE => projection(p, i, c),
            MODE_EDGES => closest_on_kept_edges(p, i, c, projection(p, i, c), m.edges[k]),
            _ => closest_on_face(p, i, c),
        };
        let d2 = (cand - c).length_squared();
        if d2 < best_d2 {
            best_d2 = d2;
            q = cand;
        }
    }
    Some(outside(c, radius, p, bound, q, best_d2, best_face))
}

/// The centre inside: pushed out through face `f` of separation `sep`.
#[inline]
fn inside(c: Vec3, radius: f32, p: &ConvexPolyhedron, f: usize, sep: f32) -> (Vec3, Vec3, f32) {
    let n = p.faces[f].normal;
    (c - n * sep, -n, radius - sep)
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
) -> Local {
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

/// Closest point of a convex polygon (a face loop of `p`) to `x`, all in `p`'s local frame.
#[inline]
fn closest_on_face(p: &ConvexPolyhedron, f: usize, x: Vec3) -> Vec3 {
    let proj = projection(p, f, x);
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

/// [`closest_on_face`] (the same bits) with how a memory of radius `tol - ROUNDING reach`
/// finds it again: `MODE_INSIDE` when every in-loop test over its edge's length is above
/// `tol`, `MODE_EDGES` when one is below `-tol`, with the edges whose distance to `x` is
/// within `2 tol` of the nearest's (any loop of more than 32 corners, or a NaN:
/// `MODE_FULL`).
fn closest_on_face_recording(p: &ConvexPolyhedron, f: usize, x: Vec3, tol: f32) -> (Vec3, u8, u32) {
    let proj = projection(p, f, x);
    let n = p.faces[f].normal;
    let lp = p.face_loop(f);
    // Every test (the full loop stops at the first negative one: the same verdict).
    let mut inside = true;
    let mut least = f32::INFINITY;
    let mut nan = false;
    for k in 0..lp.len() {
        let a = p.vertices[lp[k] as usize];
        let b = p.vertices[lp[next(k, lp.len())] as usize];
        let e = (b - a).cross(proj - a).dot(n);
        if e < 0.0 {
            inside = false;
        }
        let m = e / (b - a).length();
        least = if m < least { m } else { least };
        nan |= m.is_nan();
    }
    if inside {
        let mode = if !nan && least > tol {
            MODE_INSIDE
        } else {
            MODE_FULL
        };
        return (proj, mode, 0);
    }
    if nan || least >= -tol || lp.len() > 32 {
        return (closest_on_edges(p, f, x, proj), MODE_FULL, 0);
    }
    // The edges, as `closest_on_edges` takes them, with their distances kept.
    let mut dist = [0.0f32; 32];
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
        dist[k] = d;
    }
    let near = best_d.sqrt() + 2.0 * tol;
    let mut edges = 0u32;
    for (k, d) in dist[..lp.len()].iter().enumerate() {
        // (Written so that a NaN keeps the edge.)
        if d.sqrt().partial_cmp(&near) != Some(std::cmp::Ordering::Greater) {
            edges |= 1 << k;
        }
    }
    (best, MODE_EDGES, edges)
}

/// The closest point to `x` of face `f`'s edges, in loop order, the first on a tie (`proj`
/// when there is none).
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

/// [`closest_on_edges`] over the edges in `edges` alone (bit `k`: the edge from corner `k`,
/// all below the loop's length), in the same order with the same arithmetic.
#[inline]
fn closest_on_kept_edges(p: &ConvexPolyhedron, f: usize, x: Vec3, proj: Vec3, edges: u32) -> Vec3 {
    let lp = p.face_loop(f);
    let mut best = proj;
    let mut best_d = f32::INFINITY;
    let mut bits = edges;
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
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

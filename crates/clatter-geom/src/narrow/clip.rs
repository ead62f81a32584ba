//! The manifold of a face contact (the incident face clipped against the reference face's
//! side planes) and of an edge contact (closest points of two segments).

use std::ops::{Add, Mul, Sub};

use glam::{Vec3, Vec3A};

use super::slack::Plan;
use super::{ContactPoint, Manifold, reduce};
use crate::{ConvexPolyhedron, Pose};

/// Buffers of the face clipping: growable ones for any face, and two fixed ones of
/// [`SMALL`] corners for the usual small case (see [`small_fits`]), whose stores the
/// compiler can prove in bounds, of `Vec3A` (one 16-byte load or store a corner; the same
/// floats, see [`ClipPoint`]).
pub(super) struct ClipBuffers {
    pub(super) poly: Vec<Vec3>,
    pub(super) tmp: Vec<Vec3>,
    pub(super) pts: Vec<(Vec3, f32)>,
    small: [[Vec3A; SMALL]; 2],
}

impl Default for ClipBuffers {
    fn default() -> Self {
        ClipBuffers {
            poly: Vec::new(),
            tmp: Vec::new(),
            pts: Vec::new(),
            small: [[Vec3A::ZERO; SMALL]; 2],
        }
    }
}

/// The length of the fixed clip buffers (a power of two: an index is kept in them by a
/// mask, `& (SMALL - 1)`, which never changes an index below [`SMALL`]).
const SMALL: usize = 32;

/// Whether a polygon of `len` corners clipped by `planes` side planes always fits the fixed
/// buffers: `len + planes <= 8`. One plane's clip of `n` corners writes at most `n + n / 2`
/// (rounded down): each kept corner (`d <= 0`) and each crossing edge (strict signs
/// opposite) writes one; a crossing edge goes from a corner with `d < 0` to one with `d > 0`
/// or back, so with `P` corners at `d > 0` and `N` at `d < 0` there are at most `2 min(N,
/// P)` crossings (each corner starts one edge and ends one) and at most `n - P` kept
/// corners: `n - P + 2 min(N, P) <= n + n / 2` (NaN distances keep and cross nothing). So
/// the polygon grows at most `n -> n + n / 2` a plane; over `len + planes <= 8` the
/// largest is a quad through four planes, `4, 6, 9, 13, 19`, below [`SMALL`].
#[inline(always)]
fn small_fits(len: usize, planes: u32) -> bool {
    len + planes as usize <= 8
}

/// `m` (in `pose`'s body frame) turned into the world frame, in place, its normal then
/// negated when `flip` (a reference face of B: the normal from A to B).
// One copy out of line, shared by both kinds of reference face and the full test (issue
// 23: the served paths' code footprint); in place, so that the manifold is not copied in
// and out.
#[inline(never)]
pub(super) fn to_world(m: &mut Manifold, pose: &Pose, flip: bool) {
    m.normal = pose.rotation * m.normal;
    if flip {
        m.normal = -m.normal;
    }
    for p in &mut m.points[..m.count] {
        p.point = pose.transform_point(p.point);
    }
}

/// Clips the incident face of `inc` (its vertex `i` in `refp`'s frame is `inc_v(i)`, computed
/// only for the vertices needed) against reference face `rf` of `refp`. Normal: the reference
/// face's outward normal (from `refp` to `inc`). `plan` (from a remembered face's
/// [`super::slack::FaceSlack`]) may give the incident face and side planes that keep the
/// polygon as it is: the same manifold, bitwise, with less work.
pub(super) fn clip_faces(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
    inc_rot: glam::Mat3,
    clip: &mut ClipBuffers,
    plan: &Plan,
) -> Option<Manifold> {
    let rface = refp.faces[rf];
    let n = rface.normal;
    // Incident face: the one most anti-parallel to the reference normal.
    let inc_face = match plan.inc_face {
        Some(f) => f,
        None => incident_face(inc, inc_rot.transpose() * n),
    };
    let ClipBuffers {
        poly,
        tmp,
        pts,
        small,
    } = clip;
    // The polygons are written by index into buffers at least twice as long as the polygon
    // clipped (clipping by one plane at most doubles a polygon: each corner gives itself
    // and one crossing at most), grown when needed and never shrunk, so that no push
    // checks its capacity.
    let il = inc.face_loop(inc_face);
    let mut len = il.len();
    let planes = refp.side_planes(rf);
    // A face of up to eight side planes (a box's has four) takes the planes not skipped,
    // in order, by the bits of those left: the skipped ones cost no turn of the loop. Its
    // buffers are fitted once, for the longest polygon the planes can make (each plane at
    // most doubles it, `len << k` after `k` planes, and its clip writes into `2 len`), not
    // before each plane; a face of more planes fits `tmp` before each.
    let few = planes.len() <= 8;
    let mut left = if few {
        !plan.skip as u32 & ((1u32 << planes.len()) - 1)
    } else {
        0
    };
    if few && small_fits(len, left.count_ones()) {
        let [s0, s1] = small;
        let (mut src, mut dst) = (s0, s1);
        for (slot, &i) in src.iter_mut().zip(il) {
            *slot = Vec3A::from(inc_v(i as usize));
        }
        while left != 0 {
            let plane = planes[left.trailing_zeros() as usize];
            left &= left - 1;
            let (side, off) = (Vec3A::from(plane.0), plane.1);
            if let Some(kept) =
                clip_by_plane(&src[..len], &mut Masked(&mut *dst), side, off, plan.scan)
            {
                std::mem::swap(&mut src, &mut dst);
                len = kept;
            }
            if len == 0 {
                break;
            }
        }
        return contact_points(&src[..len], rface.offset, n, pts, inc, inc_v);
    }
    let most = if few {
        len << left.count_ones().max(1)
    } else {
        2 * len
    };
    fit(poly, most);
    if few {
        fit(tmp, most);
    }
    for (slot, &i) in poly.iter_mut().zip(il) {
        *slot = inc_v(i as usize);
    }
    if few {
        while left != 0 {
            let plane = planes[left.trailing_zeros() as usize];
            left &= left - 1;
            len = clip_one(poly, tmp, len, plane, plan.scan);
            if len == 0 {
                break;
            }
        }
    } else {
        for (k, &plane) in planes.iter().enumerate() {
            if k < 8 && plan.skip >> k & 1 != 0 {
                continue;
            }
            fit(tmp, 2 * len);
            len = clip_one(poly, tmp, len, plane, plan.scan);
            if len == 0 {
                break;
            }
        }
    }
    contact_points(&poly[..len], rface.offset, n, pts, inc, inc_v)
}

/// The manifold of the clipped polygon `poly` on the reference face's plane `n . x =
/// offset` (the points below it, moved halfway up, with their depths), or, when none is
/// below, of the incident body's deepest vertex (`inc_v` as in [`clip_faces`]).
#[inline(always)]
fn contact_points<P: ClipPoint>(
    poly: &[P],
    offset: f32,
    n: Vec3,
    pts: &mut Vec<(Vec3, f32)>,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
) -> Option<Manifold> {
    // The points with their depths, written straight into the manifold while there are
    // four or fewer (the usual face contact: `reduce` keeps them all, in order); a fifth
    // sends the polygon through `reduce` with every point (each by the same expressions,
    // so the same floats).
    let mut m = Manifold {
        normal: n,
        ..Default::default()
    };
    let mut more = false;
    let np = P::from_vec3(n);
    for &p in poly {
        let depth = offset - np.dot(p);
        if depth > 0.0 {
            if m.count == 4 {
                more = true;
                break;
            }
            m.points[m.count] = ContactPoint {
                point: (p + np * (0.5 * depth)).to_vec3(),
                depth,
            };
            m.count += 1;
        }
    }
    if more {
        return Some(reduce_all(poly, offset, n, pts));
    }
    if m.count > 0 {
        return Some(m);
    }
    // The separating-axis test found overlap but the incident face clips away entirely
    // (deep or oblique overlap): keep the contact with the incident body's deepest vertex
    // rather than losing it.
    let deepest = (0..inc.vertices.len())
        .map(inc_v)
        .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))?;
    let depth = offset - n.dot(deepest);
    if depth <= 0.0 {
        return None;
    }
    Some(Manifold::single(n, deepest + n * (0.5 * depth), depth))
}

/// The contact points of the clipped polygon `poly` (those below the reference face's
/// plane `n . x = offset`, moved halfway up) reduced to four ([`reduce`]): the case of more
/// than four, out of line.
#[cold]
#[inline(never)]
fn reduce_all<P: ClipPoint>(
    poly: &[P],
    offset: f32,
    n: Vec3,
    pts: &mut Vec<(Vec3, f32)>,
) -> Manifold {
    pts.clear();
    let np = P::from_vec3(n);
    for &p in poly {
        let depth = offset - np.dot(p);
        if depth > 0.0 {
            pts.push(((p + np * (0.5 * depth)).to_vec3(), depth));
        }
    }
    reduce(pts, n)
}

/// The face of `inc` most anti-parallel to `n_inc` (the reference normal in `inc`'s
/// frame): the smallest `normal . n_inc`, the first of equals (NaNs never chosen; face 0
/// when all are).
///
/// For the six faces of the signed axes ([`ConvexPolyhedron::face_axes`]) and a finite
/// `n_inc`, without the products: face `f`'s dot product is `±n_inc[axis]` as a value, so
/// the smallest is `-m`, `m = max_k |n_inc[k]|`, taken by the face of axis `k` with the sign
/// opposite to `n_inc[k]` for each `k` with `|n_inc[k]| = m`; the first of these. When `m =
/// 0` every product is a zero, all equal: face 0.
#[inline(always)]
pub(super) fn incident_face(inc: &ConvexPolyhedron, n_inc: Vec3) -> usize {
    if let Some(of) = inc.face_axes
        && n_inc.is_finite()
    {
        let v = n_inc.to_array();
        let m = n_inc.abs().max_element();
        if m == 0.0 {
            return 0;
        }
        let mut first = usize::MAX;
        for (k, &c) in v.iter().enumerate() {
            if c.abs() == m {
                first = first.min(of[k | ((c > 0.0) as usize) << 2] as usize);
            }
        }
        return first;
    }
    let mut inc_face = 0;
    let mut best = f32::INFINITY;
    for (f, face) in inc.faces.iter().enumerate() {
        let d = face.normal.dot(n_inc);
        if d < best {
            best = d;
            inc_face = f;
        }
    }
    inc_face
}

/// The polygon `poly[..len]` clipped by one side plane `(side, off)` ([`clip_by_plane`],
/// `tmp` its scratch, already at least `2 len` long, swapped in when the polygon changes):
/// the new length.
#[inline(always)]
fn clip_one(
    poly: &mut Vec<Vec3>,
    tmp: &mut Vec<Vec3>,
    len: usize,
    (side, off): (Vec3, f32),
    scan: bool,
) -> usize {
    match clip_by_plane(&poly[..len], tmp.as_mut_slice(), side, off, scan) {
        Some(kept) => {
            std::mem::swap(poly, tmp);
            kept
        }
        None => len,
    }
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
/// and returning their count, or, with `scan`, `None` when the plane keeps `src` as it is
/// (no copy). Each corner's distance is computed by one expression (the same for it as the
/// start and as the end of an edge, so the same bits), and the loop closes on the first
/// corner. Without `scan`, a plane that keeps `src` as it is gets it copied into `dst`:
/// every corner with `d <= 0` is kept, in order, and no edge crosses (a crossing needs a
/// corner with `d > 0` or, for `dp < 0`, `dq > 0`), so the same polygon.
#[inline(always)]
fn clip_by_plane<P: ClipPoint, D: Store<P> + ?Sized>(
    src: &[P],
    dst: &mut D,
    side: P,
    off: f32,
    scan: bool,
) -> Option<usize> {
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
    if scan && !outside(d_first) && !rest.iter().any(|&q| outside(side.dot(q) - off)) {
        return None;
    }
    let mut w = 0;
    let mut edge = |p: P, dp: f32, q: P, dq: f32| {
        if dp <= 0.0 {
            dst.put(w, p);
            w += 1;
        }
        if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
            dst.put(w, p + (q - p) * (dp / (dp - dq)));
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

/// A point of the clip: `Vec3`, or `Vec3A` for the fixed buffers. Both give the same
/// floats by the same expressions: glam's `Vec3A` adds, subtracts and scales lane by lane
/// (each lane the IEEE operation `Vec3` does on that coordinate), and its dot product is
/// `(x x' + y y') + z z'`, `Vec3`'s order; the fourth lane is never read.
trait ClipPoint: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<f32, Output = Self> {
    fn dot(self, o: Self) -> f32;
    fn from_vec3(v: Vec3) -> Self;
    fn to_vec3(self) -> Vec3;
}

impl ClipPoint for Vec3 {
    #[inline(always)]
    fn dot(self, o: Self) -> f32 {
        Vec3::dot(self, o)
    }
    #[inline(always)]
    fn from_vec3(v: Vec3) -> Self {
        v
    }
    #[inline(always)]
    fn to_vec3(self) -> Vec3 {
        self
    }
}

impl ClipPoint for Vec3A {
    #[inline(always)]
    fn dot(self, o: Self) -> f32 {
        Vec3A::dot(self, o)
    }
    #[inline(always)]
    fn from_vec3(v: Vec3) -> Self {
        Vec3A::from(v)
    }
    #[inline(always)]
    fn to_vec3(self) -> Vec3 {
        Vec3::from(self)
    }
}

/// Where [`clip_by_plane`] writes its polygon: entry `w` set to `p`.
trait Store<P> {
    fn put(&mut self, w: usize, p: P);
}

/// A growable buffer, long enough by the caller's fitting (indexing checked).
impl Store<Vec3> for [Vec3] {
    #[inline(always)]
    fn put(&mut self, w: usize, p: Vec3) {
        self[w] = p;
    }
}

/// A fixed buffer of [`SMALL`] entries, indexed through a mask so that no store needs a
/// bounds check: only for polygons that fit ([`small_fits`]), where the mask never changes
/// an index.
struct Masked<'a>(&'a mut [Vec3A; SMALL]);

impl Store<Vec3A> for Masked<'_> {
    #[inline(always)]
    fn put(&mut self, w: usize, p: Vec3A) {
        self.0[w & (SMALL - 1)] = p;
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat3, Quat};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The face clipping as it was before its buffers were written by index and its side
    /// planes kept with the shape (pushes into vectors, side planes from the loop, every
    /// plane copying the polygon), kept as the reference.
    fn reference(
        refp: &ConvexPolyhedron,
        rf: usize,
        inc: &ConvexPolyhedron,
        inc_v: impl Fn(usize) -> Vec3,
        inc_rot: Mat3,
    ) -> Option<Vec<(Vec3, f32)>> {
        let rface = refp.faces[rf];
        let n = rface.normal;
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
        let mut poly: Vec<Vec3> = inc
            .face_loop(inc_face)
            .iter()
            .map(|&i| inc_v(i as usize))
            .collect();
        let rl = refp.face_loop(rf);
        for k in 0..rl.len() {
            let v0 = refp.vertices[rl[k] as usize];
            let v1 = refp.vertices[rl[(k + 1) % rl.len()] as usize];
            let side = (v1 - v0).cross(n);
            let off = side.dot(v0);
            let mut out = Vec::new();
            for i in 0..poly.len() {
                let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
                let (dp, dq) = (side.dot(p) - off, side.dot(q) - off);
                if dp <= 0.0 {
                    out.push(p);
                }
                if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                    out.push(p + (q - p) * (dp / (dp - dq)));
                }
            }
            poly = out;
            if poly.is_empty() {
                break;
            }
        }
        let pts: Vec<(Vec3, f32)> = poly
            .iter()
            .filter_map(|&p| {
                let depth = rface.offset - n.dot(p);
                (depth > 0.0).then(|| (p + n * (0.5 * depth), depth))
            })
            .collect();
        if pts.is_empty() {
            let deepest = (0..inc.vertices.len())
                .map(inc_v)
                .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))?;
            let depth = rface.offset - n.dot(deepest);
            return (depth > 0.0).then(|| vec![(deepest + n * (0.5 * depth), depth)]);
        }
        let (idx, count) = crate::reduce::reduce(&pts, n);
        Some(idx[..count].iter().map(|&i| pts[i]).collect())
    }

    /// The incident face's choice on faces of the signed axes, without the products,
    /// against the loop over every face's dot product: boxes of several extents (their
    /// hulls' own normals), directions at random, on the axes, with equal components (ties:
    /// the first face wins), with zeros of either sign, all zero, and with an infinite or
    /// NaN component (the loop decides those).
    #[test]
    fn incident_face_on_axes_is_the_loop() {
        let mut r = ChaCha8Rng::seed_from_u64(19);
        let boxes = [
            Vec3::splat(0.01),
            Vec3::new(0.5, 0.2, 0.3),
            Vec3::new(1.0, 3.0, 0.25),
        ];
        let mut tested = 0;
        for h in boxes {
            let v: Vec<Vec3> = (0..8)
                .map(|k| {
                    let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                    Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
                })
                .collect();
            let shape = crate::convex_hull(&v).expect("box hull");
            assert!(
                shape.face_axes.is_some(),
                "a box's faces are the signed axes"
            );
            let picks = [
                0.0,
                -0.0,
                1.0,
                -1.0,
                0.5,
                -0.5,
                1e-30,
                f32::INFINITY,
                f32::NAN,
            ];
            for case in 0..60_000 {
                let n = if case % 2 == 0 {
                    let mut q = [0.0f32; 4].map(|_| r.random_range(-1.0f32..1.0));
                    q[3] += 1e-3;
                    Quat::from_array(q).normalize() * Vec3::Z
                } else {
                    Vec3::from_array([0; 3].map(|_| picks[r.random_range(0..picks.len())]))
                };
                let want = {
                    let mut inc_face = 0;
                    let mut best = f32::INFINITY;
                    for (f, face) in shape.faces.iter().enumerate() {
                        let d = face.normal.dot(n);
                        if d < best {
                            best = d;
                            inc_face = f;
                        }
                    }
                    inc_face
                };
                assert_eq!(incident_face(&shape, n), want, "{n:?}");
                tested += n.is_finite() as usize;
            }
        }
        assert!(tested > 100_000, "{tested}");
        // A hull that is not a box of the axes takes the loop.
        let tetra = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ZERO];
        assert!(
            crate::convex_hull(&tetra)
                .expect("hull")
                .face_axes
                .is_none()
        );
    }

    /// A random rotation; where `exact`, one that maps the axes onto axes exactly (with the
    /// boxes' faces on the axes, corners then land exactly on side planes: distance zero).
    fn test_rotation(r: &mut ChaCha8Rng, exact: bool) -> Mat3 {
        if exact {
            let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
            let a = axes[r.random_range(0..6)];
            let b = loop {
                let b = axes[r.random_range(0..6)];
                if a.dot(b) == 0.0 {
                    break b;
                }
            };
            Mat3::from_cols(a, b, a.cross(b))
        } else {
            let mut q = [0.0f32; 4].map(|_| r.random_range(-1.0f32..1.0));
            q[3] += 1e-3;
            Mat3::from_quat(Quat::from_array(q).normalize())
        }
    }

    fn bits(p: &[(Vec3, f32)]) -> Vec<[u32; 4]> {
        p.iter()
            .map(|(v, d)| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits(), d.to_bits()])
            .collect()
    }

    /// `clip_faces` (the full plan) of `inc`, its corners at `inc_v`, on face `rf` of
    /// `refp`, asserted bitwise the reference's and with the face's normal (`case` names a
    /// failure): the reference's points, `None` for no contact.
    fn clip_is_the_reference(
        refp: &ConvexPolyhedron,
        rf: usize,
        inc: &ConvexPolyhedron,
        inc_v: impl Fn(usize) -> Vec3 + Copy,
        rot: Mat3,
        buffers: &mut ClipBuffers,
        case: usize,
    ) -> Option<Vec<(Vec3, f32)>> {
        let got = clip_faces(refp, rf, inc, inc_v, rot, buffers, &Plan::FULL);
        let want = reference(refp, rf, inc, inc_v, rot);
        let got = got.map(|m| {
            assert_eq!(m.normal, refp.faces[rf].normal);
            m.points()
                .iter()
                .map(|p| (p.point, p.depth))
                .collect::<Vec<_>>()
        });
        assert_eq!(
            got.as_deref().map(bits),
            want.as_deref().map(bits),
            "case {case}"
        );
        want
    }

    /// Boxes (the pile's case: quads against rectangles) and random hulls, the incident
    /// body turned at random and placed just through each reference face (touching,
    /// crossing its sides, or clipped away), sometimes exactly aligned (corners on the side
    /// planes, planes that cut nothing): every manifold bitwise the reference's.
    #[test]
    fn face_clipping_is_the_reference_bitwise() {
        let mut r = ChaCha8Rng::seed_from_u64(13);
        let cube = |h: Vec3| {
            let v: Vec<Vec3> = (0..8)
                .map(|k| {
                    let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                    Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
                })
                .collect();
            crate::convex_hull(&v).expect("box hull")
        };
        // A prism whose triangle, turned onto the cube's face exactly, has a corner on a
        // side plane of the cube (a coordinate of 0.01) while the plane cuts another
        // corner (0.02): a corner at distance zero on a plane that clips.
        let tri = [(0.01, 0.005), (0.02, -0.005), (-0.005, -0.005)];
        let prism: Vec<Vec3> = [-0.01, 0.01]
            .iter()
            .flat_map(|&z| tri.map(|(x, y)| Vec3::new(x, y, z)))
            .collect();
        let mut shapes = vec![
            cube(Vec3::splat(0.01)),
            cube(Vec3::new(0.5, 0.2, 0.3)),
            crate::convex_hull(&prism).expect("prism hull"),
        ];
        for _ in 0..4 {
            let v: Vec<Vec3> = (0..r.random_range(6..24))
                .map(|_| Vec3::new(r.random(), r.random(), r.random()) - 0.5)
                .collect();
            shapes.push(crate::convex_hull(&v).expect("random hull"));
        }
        let (mut cases, mut multi, mut many) = (0, 0, 0);
        let mut buffers = ClipBuffers::default();
        for case in 0..20_000 {
            let refp = &shapes[r.random_range(0..shapes.len())];
            let inc = &shapes[r.random_range(0..shapes.len())];
            let rf = r.random_range(0..refp.faces.len());
            let face = refp.faces[rf];
            let exact = case % 4 == 0;
            let rot = test_rotation(&mut r, exact);
            let scale = refp.radius.max(inc.radius);
            let lateral = if exact {
                Vec3::new(
                    r.random_range(-1..=1) as f32,
                    r.random_range(-1..=1) as f32,
                    r.random_range(-1..=1) as f32,
                ) * (0.005 * r.random_range(0..2) as f32)
            } else {
                Vec3::new(r.random(), r.random(), r.random()) * scale * 0.3
            };
            let t = face.normal * (face.offset + inc.radius * r.random_range(0.5..1.0)) + lateral;
            let inc_v = |i: usize| rot * inc.vertices[i] + t;
            let want = clip_is_the_reference(refp, rf, inc, inc_v, rot, &mut buffers, case);
            if let Some(w) = &want {
                cases += 1;
                multi += (w.len() > 1) as usize;
                many += (w.len() == 4) as usize;
            }
        }
        // The cases exercise the clipping, not only its fallback.
        assert!(
            cases > 5_000 && multi > 2_000 && many > 1_000,
            "{cases} {multi} {many}"
        );
    }

    /// Cubes resting exactly face on face, turned onto the axes exactly and slid along the
    /// face by steps of a quarter edge: the incident corners at depth exactly zero (kept by
    /// neither, no contact) or, pressed in by a step, all at the same depth (kept): the
    /// clip's manifold bitwise the reference's, for every face, both ways.
    #[test]
    fn exactly_touching_faces_are_the_reference() {
        let mut r = ChaCha8Rng::seed_from_u64(29);
        let h = 0.01f32;
        let v: Vec<Vec3> = (0..8)
            .map(|k| {
                let s = |b: u32| if k & b != 0 { h } else { -h };
                Vec3::new(s(1), s(2), s(4))
            })
            .collect();
        let cube = crate::convex_hull(&v).expect("cube hull");
        let (mut touching, mut pressed) = (0, 0);
        let mut buffers = ClipBuffers::default();
        for case in 0..4_000 {
            let rf = r.random_range(0..cube.faces.len());
            let face = cube.faces[rf];
            let rot = test_rotation(&mut r, true);
            let slide = Vec3::new(
                r.random_range(-4..=4) as f32,
                r.random_range(-4..=4) as f32,
                r.random_range(-4..=4) as f32,
            ) * (0.5 * h);
            // Along the face only (the normal is an axis: exact).
            let slide = slide - face.normal * face.normal.dot(slide);
            let press = if case % 2 == 0 { 0.0 } else { 0.5 * h };
            let t = face.normal * (face.offset + h - press) + slide;
            let inc_v = |i: usize| rot * cube.vertices[i] + t;
            match clip_is_the_reference(&cube, rf, &cube, inc_v, rot, &mut buffers, case) {
                None => touching += 1,
                Some(_) => pressed += 1,
            }
        }
        // Both outcomes met: corners at depth zero, and corners pressed in.
        assert!(touching > 1_000 && pressed > 1_000, "{touching} {pressed}");
    }

    /// The whole manifold as bits (`None`: no contact).
    fn manifold_bits(m: Option<Manifold>) -> Option<(usize, [u32; 3], Vec<[u32; 4]>)> {
        m.map(|m| {
            let pts: Vec<(Vec3, f32)> = m.points().iter().map(|p| (p.point, p.depth)).collect();
            (m.count, m.normal.to_array().map(f32::to_bits), bits(&pts))
        })
    }

    /// The clip without the scan for a corner outside (`Plan::scan` off, as a served
    /// record's plan) against the clip with it, bitwise: boxes and random hulls turned at
    /// random or onto the axes exactly (corners on side planes: distance `+0` or `-0`,
    /// planes that cut nothing, corners outside by one ulp), incident corners with zeros of
    /// either sign, and a corner NaN or infinite now and then (degenerate poses); and the
    /// same with each plan's skipped planes taken from a plane that cuts nothing there.
    #[test]
    fn clip_without_the_scan_is_the_clip_with_it() {
        let mut r = ChaCha8Rng::seed_from_u64(21);
        let cube = |h: Vec3| {
            let v: Vec<Vec3> = (0..8)
                .map(|k| {
                    let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                    Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
                })
                .collect();
            crate::convex_hull(&v).expect("box hull")
        };
        let mut shapes = vec![cube(Vec3::splat(0.01)), cube(Vec3::new(0.5, 0.2, 0.3))];
        for _ in 0..4 {
            let v: Vec<Vec3> = (0..r.random_range(6..24))
                .map(|_| Vec3::new(r.random(), r.random(), r.random()) - 0.5)
                .collect();
            shapes.push(crate::convex_hull(&v).expect("random hull"));
        }
        let (mut buf_a, mut buf_b) = (ClipBuffers::default(), ClipBuffers::default());
        let (mut cut_nothing, mut contacts, mut odd) = (0, 0, 0);
        for case in 0..40_000 {
            let refp = &shapes[r.random_range(0..shapes.len())];
            let inc = &shapes[r.random_range(0..shapes.len())];
            let rf = r.random_range(0..refp.faces.len());
            let face = refp.faces[rf];
            let exact = case % 3 == 0;
            let rot = test_rotation(&mut r, exact);
            let scale = refp.radius.max(inc.radius);
            let lateral = if exact {
                // Whole steps of the small cube's half size (corners on its side planes),
                // or nothing (a box on a box of the same size: every plane cuts nothing).
                Vec3::new(
                    r.random_range(-2..=2) as f32,
                    r.random_range(-2..=2) as f32,
                    r.random_range(-2..=2) as f32,
                ) * (0.005 * r.random_range(0..2) as f32)
            } else {
                Vec3::new(r.random(), r.random(), r.random()) * scale * 0.3
            };
            let t = face.normal * (face.offset + inc.radius * r.random_range(0.5..1.0)) + lateral;
            // Zeros turned to `-0` (or not), a corner off by an ulp, a NaN or an infinity.
            let flip = r.random_range(0..8u32);
            let nudge = r.random_range(0..64usize);
            let bad = if case % 97 == 0 {
                [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][case / 97 % 3]
            } else {
                0.0
            };
            let inc_v = |i: usize| {
                let mut p = (rot * inc.vertices[i] + t).to_array();
                for (k, c) in p.iter_mut().enumerate() {
                    if *c == 0.0 && flip >> k & 1 != 0 {
                        *c = -*c;
                    }
                }
                if i == nudge % inc.vertices.len() && nudge < 16 {
                    p[nudge % 3] = f32::from_bits(p[nudge % 3].to_bits() + 1);
                }
                if bad != 0.0 && i == nudge % inc.vertices.len() {
                    p[0] = bad;
                }
                Vec3::from_array(p)
            };
            odd += (bad != 0.0 || flip != 0) as usize;
            let with = clip_faces(refp, rf, inc, inc_v, rot, &mut buf_a, &Plan::FULL);
            let without = Plan {
                scan: false,
                ..Plan::FULL
            };
            let got = clip_faces(refp, rf, inc, inc_v, rot, &mut buf_b, &without);
            contacts += with.is_some() as usize;
            assert_eq!(manifold_bits(got), manifold_bits(with), "case {case}");
            // The planes that cut nothing here (every corner of the incident face inside
            // or on them, as a record's skipped planes are): skipped, without the scan.
            let n_inc = rot.transpose() * face.normal;
            let il = inc.face_loop(incident_face(inc, n_inc));
            let mut skip = 0u8;
            for (k, &(side, off)) in refp.side_planes(rf).iter().enumerate().take(8) {
                if il.iter().all(|&i| side.dot(inc_v(i as usize)) - off < 0.0) {
                    skip |= 1 << k;
                }
            }
            cut_nothing += (skip != 0) as usize;
            let skipping = Plan { skip, ..without };
            let got = clip_faces(refp, rf, inc, inc_v, rot, &mut buf_b, &skipping);
            assert_eq!(
                manifold_bits(got),
                manifold_bits(with),
                "case {case} skip {skip:b}"
            );
        }
        assert!(
            contacts > 10_000 && cut_nothing > 5_000 && odd > 10_000,
            "{contacts} {cut_nothing} {odd}"
        );
    }
}

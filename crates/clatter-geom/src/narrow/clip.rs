//! The manifold of a face contact (the incident face clipped against the reference face's
//! side planes) and of an edge contact (closest points of two segments).

use std::ops::{Add, Mul, Sub};

use glam::{Mat3, Quat, Vec3, Vec3A};

use super::slack::{FaceSlack, Plan};
use super::{ContactPoint, Manifold};
use crate::reduce::PatchVec;
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
    /// The fixed buffers' points for [`reduce_all`].
    small_pts: Vec<(Vec3A, f32)>,
}

impl Default for ClipBuffers {
    fn default() -> Self {
        ClipBuffers {
            poly: Vec::new(),
            tmp: Vec::new(),
            pts: Vec::new(),
            small: [[Vec3A::ZERO; SMALL]; 2],
            small_pts: Vec::new(),
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
    #[cfg(test)]
    if tests::GROWABLE_ONLY.get() {
        return false;
    }
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
// Inlined into the full test, as it was before `clip_faces_into` (without the hint the
// compiler took it out of line: more instructions, callgrind).
#[inline]
pub(super) fn clip_faces(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
    inc_rot: glam::Mat3,
    clip: &mut ClipBuffers,
    plan: &Plan,
) -> Option<Manifold> {
    let mut m = Manifold::default();
    clip_faces_into(refp, rf, inc, inc_v, inc_rot, clip, plan, &mut m).then_some(m)
}

/// [`clip_faces`] written into `m` (whole, unused points zero) instead of returned: `true`
/// with the manifold, `false` for no contact (`m` then holds no point), so that a caller
/// keeping the manifold where it is needed does not copy it (a manifold is 96 bytes).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn clip_faces_into(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
    inc_rot: glam::Mat3,
    clip: &mut ClipBuffers,
    plan: &Plan,
    m: &mut Manifold,
) -> bool {
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
        small_pts,
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
        // Whether every corner's coordinates are below `1e18` in magnitude (see `on_axes`),
        // gathered lane by lane as they are made.
        let (big, mut moderate) = (Vec3A::splat(1e18), glam::BVec3A::TRUE);
        for (slot, &i) in src.iter_mut().zip(il) {
            let p = Vec3A::from(inc_v(i as usize));
            moderate &= p.abs().cmplt(big);
            *slot = p;
        }
        // A box's planes (see `on_axes`): each distance and depth from one coordinate.
        let axes = refp.axis_code(rf);
        let on_axes = on_axes(moderate);
        while left != 0 {
            let k = left.trailing_zeros() as usize;
            let plane = planes[k];
            left &= left - 1;
            let (side, off) = (Vec3A::from(plane.0), plane.1);
            let out = &mut Masked(&mut *dst);
            // (`len` is below `SMALL` here, see `small_fits`: the mask never changes it and
            // spares the slice's bound check.)
            let (src_now, scan) = (&src[..len & (SMALL - 1)], plan.scan);
            let kept = match axes.side(k) {
                0 if on_axes => clip_by_plane(src_now, out, |p: Vec3A| side.x * p.x - off, scan),
                1 if on_axes => clip_by_plane(src_now, out, |p: Vec3A| side.y * p.y - off, scan),
                2 if on_axes => clip_by_plane(src_now, out, |p: Vec3A| side.z * p.z - off, scan),
                _ => clip_by_plane(src_now, out, |p: Vec3A| side.dot(p) - off, scan),
            };
            if let Some(kept) = kept {
                std::mem::swap(&mut src, &mut dst);
                len = kept;
            }
            if len == 0 {
                break;
            }
        }
        let (poly, o, nv) = (&src[..len & (SMALL - 1)], rface.offset, Vec3A::from(n));
        return match axes.normal() {
            0 if on_axes => {
                contact_points(poly, o, |p| o - nv.x * p.x, n, small_pts, inc, inc_v, m)
            }
            1 if on_axes => {
                contact_points(poly, o, |p| o - nv.y * p.y, n, small_pts, inc, inc_v, m)
            }
            2 if on_axes => {
                contact_points(poly, o, |p| o - nv.z * p.z, n, small_pts, inc, inc_v, m)
            }
            _ => contact_points(poly, o, |p| o - nv.dot(p), n, small_pts, inc, inc_v, m),
        };
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
    let o = rface.offset;
    contact_points(&poly[..len], o, |p| o - n.dot(p), n, pts, inc, inc_v, m)
}

/// Whether the clip of the fixed buffers takes a box's planes from one coordinate
/// ([`crate::polyhedron::axis_of`]): when every incident corner's coordinates are below
/// `1e18` in magnitude (not NaN), `moderate` in every lane. Every point the clip makes is then finite (a crossing
/// is within its edge up to rounding, so each of at most eight planes at most triples the
/// largest coordinate), and for a finite point a plane vector or normal on an axis gives
/// its dot product's value by that coordinate's product alone: the same distance and
/// depth up to the sign of a zero, which changes nothing here (a distance is only compared
/// with zero, and divided only when two of opposite strict signs are; a depth is kept only
/// above zero). A NaN or infinite coordinate, whose products with zeros are NaNs, takes
/// the products.
#[inline(always)]
fn on_axes(moderate: glam::BVec3A) -> bool {
    #[cfg(test)]
    if tests::PRODUCTS_ONLY.get() {
        return false;
    }
    moderate.all()
}

/// The manifold of the clipped polygon `poly` on the reference face's plane `n . x =
/// offset` (the points below it, moved halfway up, with their depths `depth_of(p)`,
/// `offset - n . p` by value: see `on_axes`), or, when none is
/// below, of the incident body's deepest vertex (`inc_v` as in [`clip_faces`]), written
/// into `m`: `false` when there is no contact.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn contact_points<P: ClipPoint>(
    poly: &[P],
    offset: f32,
    depth_of: impl Fn(P) -> f32,
    n: Vec3,
    pts: &mut Vec<(P, f32)>,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
    m: &mut Manifold,
) -> bool {
    // The points with their depths, written straight into the manifold while there are
    // four or fewer (the usual face contact: `reduce` keeps them all, in order); a fifth
    // sends the polygon through `reduce` with every point (each by the same expressions,
    // so the same floats).
    *m = Manifold {
        normal: n,
        ..Default::default()
    };
    // The count is kept in a register and stored once (stored at each point, it was
    // reloaded at each: callgrind).
    let mut more = false;
    let mut count = 0;
    let np = P::from_vec3(n);
    for &p in poly {
        let depth = depth_of(p);
        if depth > 0.0 {
            // (A fifth point finds no slot: one test for both the fifth and the bound.)
            let Some(slot) = m.points.get_mut(count) else {
                more = true;
                break;
            };
            *slot = ContactPoint {
                point: (p + np * (0.5 * depth)).to_vec3(),
                depth,
            };
            count += 1;
        }
    }
    if more {
        *m = reduce_all(poly, offset, n, pts);
        return true;
    }
    m.count = count;
    if count > 0 {
        return true;
    }
    // The separating-axis test found overlap but the incident face clips away entirely
    // (deep or oblique overlap): keep the contact with the incident body's deepest vertex
    // rather than losing it.
    let Some(deepest) = (0..inc.vertices.len())
        .map(inc_v)
        .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))
    else {
        return false;
    };
    let depth = offset - n.dot(deepest);
    if depth <= 0.0 {
        return false;
    }
    *m = Manifold::single(n, deepest + n * (0.5 * depth), depth);
    true
}

/// The contact points of the clipped polygon `poly` (those below the reference face's
/// plane `n . x = offset`, moved halfway up) reduced to four ([`reduce`]): the case of more
/// than four, out of line.
#[cold]
#[inline(never)]
fn reduce_all<P: ClipPoint>(poly: &[P], offset: f32, n: Vec3, pts: &mut Vec<(P, f32)>) -> Manifold {
    pts.clear();
    let np = P::from_vec3(n);
    let mut moderate = true;
    for &p in poly {
        let depth = offset - np.dot(p);
        if depth > 0.0 {
            let q = p + np * (0.5 * depth);
            moderate &= q.moderate();
            pts.push((q, depth));
        }
    }
    // `narrow::reduce` of these points (more than four), by the same generic reduction:
    // of `P`, where every coordinate is below `1e18` in magnitude (so that no product,
    // difference or sum of the reduction overflows and no NaN arises, whose sign and
    // payload may depend on the order of the operands a compiler picks), else of `Vec3`
    // (the points as they are: each coordinate by the same lane-wise expression).
    let (idx, count) = if moderate {
        crate::reduce::reduce(pts, np)
    } else {
        reduce_plain(pts, n)
    };
    let mut m = Manifold {
        normal: n,
        count,
        ..Default::default()
    };
    for (k, &i) in idx[..count].iter().enumerate() {
        m.points[k] = ContactPoint {
            point: pts[i].0.to_vec3(),
            depth: pts[i].1,
        };
    }
    m
}

/// `reduce` of `pts` as `Vec3` points (each coordinate as it is): [`reduce_all`]'s case of a
/// huge, infinite or NaN coordinate (a broken simulation), out of line.
#[cold]
#[inline(never)]
fn reduce_plain<P: ClipPoint>(pts: &[(P, f32)], n: Vec3) -> ([usize; 4], usize) {
    let plain: Vec<(Vec3, f32)> = pts.iter().map(|&(p, d)| (p.to_vec3(), d)).collect();
    crate::reduce::reduce(&plain, n)
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
    match clip_by_plane(
        &poly[..len],
        tmp.as_mut_slice(),
        |p| side.dot(p) - off,
        scan,
    ) {
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

/// Clips the convex polygon `src` by a side plane, `dist(x) <= 0` inside (`dist(x)` is
/// `side . x - off`, or for a box's plane that value from one coordinate: see
/// `on_axes`), writing the
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
    dist: impl Fn(P) -> f32,
    scan: bool,
) -> Option<usize> {
    let Some((&first, rest)) = src.split_first() else {
        return Some(0);
    };
    let d_first = dist(first);
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
    if scan && !outside(d_first) && !rest.iter().any(|&q| outside(dist(q))) {
        return None;
    }
    let mut w = 0;
    let mut edge = |p: P, dp: f32, q: P, dq: f32| {
        // The crossing test `(dp < 0 && dq > 0) || (dp > 0 && dq < 0)` split by the keep
        // test: a kept corner (`dp <= 0`) fails `dp > 0`, one not kept (`dp > 0` or NaN)
        // fails `dp < 0`, so each branch takes only the half that can hold (fewer tests a
        // corner: callgrind).
        let cross = if dp <= 0.0 {
            dst.put(w, p);
            w += 1;
            dp < 0.0 && dq > 0.0
        } else {
            dp > 0.0 && dq < 0.0
        };
        if cross {
            dst.put(w, p + (q - p) * (dp / (dp - dq)));
            w += 1;
        }
    };
    let (mut p, mut dp) = (first, d_first);
    for &q in rest {
        let dq = dist(q);
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
trait ClipPoint:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<f32, Output = Self> + PatchVec<S = f32>
{
    fn from_vec3(v: Vec3) -> Self;
    fn to_vec3(self) -> Vec3;
    /// Whether every coordinate is below `1e18` in magnitude (not NaN), where that matters
    /// (see [`reduce_all`]).
    fn moderate(self) -> bool;
}

impl ClipPoint for Vec3 {
    #[inline(always)]
    fn from_vec3(v: Vec3) -> Self {
        v
    }
    #[inline(always)]
    fn to_vec3(self) -> Vec3 {
        self
    }
    #[inline(always)]
    fn moderate(self) -> bool {
        true
    }
}

impl ClipPoint for Vec3A {
    #[inline(always)]
    fn from_vec3(v: Vec3) -> Self {
        Vec3A::from(v)
    }
    #[inline(always)]
    fn to_vec3(self) -> Vec3 {
        Vec3::from(self)
    }
    #[inline(always)]
    fn moderate(self) -> bool {
        self.abs().cmplt(Vec3A::splat(1e18)).all()
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
// Inlined into the edge manifold (without the hint the compiler took it out of line once
// this file grew: 3% more instructions in `edge_manifold`, callgrind).
#[inline(always)]
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

/// [`clip_faces`] of reference face `face` of `refp` (`kind` `HINT_FACE_A` when `refp`
/// is A, else `HINT_FACE_B`) against `inc`, whose vertex `i` is at `inc_v(i)` in
/// `refp`'s frame and whose rotation there is `inc_rot` (`q`, `t`: B's rotation and offset
/// in A's frame), with the plan of the pair's record of that face's clip ([`FaceSlack`],
/// when the pair has one): the manifold in `refp`'s frame, bitwise the whole clip's
/// (`Plan::FULL`): a plan skips only work the record proves to change no bit (see
/// [`FaceSlack`]). When the plan asks for it, a new record is measured from this clip, as
/// `sat::remembered_face` measures one (`lever` and `n_inc` as it computes them: the record
/// bounds a later clip of this face, whichever path makes it).
///
/// The full test clips here the face it chooses: on a resting cube pile nearly all of its
/// calls choose the face the pair remembered, whose margin had run out (issue 23, full32),
/// and that face's record usually still serves, as it does for `sat::remembered_face`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn slack_clip(
    refp: &ConvexPolyhedron,
    inc: &ConvexPolyhedron,
    (kind, face, q, t, inc_rot): (u32, usize, Quat, Vec3, Mat3),
    inc_v: impl Fn(usize) -> Vec3 + Copy,
    (lever, n_inc): (impl Fn() -> f32, impl Fn() -> Vec3),
    clip: &mut ClipBuffers,
    slack: Option<&mut FaceSlack>,
) -> Option<Manifold> {
    let key = kind | face as u32;
    let plan = slack
        .as_deref()
        .map_or(Plan::FULL, |s| s.plan(refp, inc, key, q, t));
    // The certificate is not taken here (the full test checks every axis): a plan that
    // offers it changes nothing.
    let m = clip_faces(refp, face, inc, inc_v, inc_rot, clip, &plan)?;
    if let Some(s) = slack.filter(|_| plan.measure) {
        let delta = 2e-5 * (refp.radius + inc.radius);
        s.record(
            refp,
            face,
            inc,
            key,
            q,
            t,
            lever(),
            n_inc(),
            inc_v,
            &m,
            delta,
        );
    }
    Some(m)
}

#[cfg(test)]
#[path = "clip_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "clip_points_tests.rs"]
mod points_tests;

//! The separating-axis test of two convex polyhedra: face axes of both bodies, then the
//! edge-edge axes ([`super::edges`]), then the manifold by clipping ([`super::clip`]).

use glam::{Mat3, Quat, Vec3, Vec4};

use super::certify::{overlap_certified, wedge_certified};
use super::clip::{ClipBuffers, clip_faces, segment_closest, to_world};
use super::edges::{GaussTables, edge_axes_by_direction, edge_axes_gauss_map};
use super::memory::EdgeMemory;
use super::{
    HINT_CONTACT, HINT_EDGE, HINT_EDGE_CONTACT, HINT_FACE_A, HINT_FACE_B, HINT_KIND, Manifold,
    NO_HINT, SatHint, is_contact_hint,
};
use crate::{ConvexPolyhedron, Pose};

/// Points as 4-point chunks of separate x, y, z lanes (the last chunk padded with copies of
/// the first point), so that "smallest projection on an axis" is packed SIMD, a chunk's
/// three lanes read together.
#[derive(Default, Debug, Clone, PartialEq)]
pub(crate) struct SoaPoints {
    chunks: Vec<[Vec4; 3]>,
}

impl SoaPoints {
    /// `pts` as lanes (see [`SoaPoints::fill`]).
    pub(crate) fn of(pts: &[Vec3]) -> Self {
        let mut lanes = Self::default();
        lanes.fill(pts);
        lanes
    }

    fn fill(&mut self, pts: &[Vec3]) {
        // Sized once, then written in place (no capacity check per chunk).
        self.chunks.resize(pts.len().div_ceil(4), [Vec4::ZERO; 3]);
        let Some(&first) = pts.first() else {
            return;
        };
        for (chunk, ps) in self.chunks.iter_mut().zip(pts.chunks(4)) {
            let p = |k: usize| *ps.get(k).unwrap_or(&first);
            let (p0, p1, p2, p3) = (p(0), p(1), p(2), p(3));
            *chunk = [
                Vec4::new(p0.x, p1.x, p2.x, p3.x),
                Vec4::new(p0.y, p1.y, p2.y, p3.y),
                Vec4::new(p0.z, p1.z, p2.z, p3.z),
            ];
        }
    }

    /// Feeds the first chunk's projections on `n` into a new [`Extent`] (nothing when
    /// there are no points): the head test's bounds, without a range to check.
    #[inline(always)]
    pub(super) fn head(&self, n: Vec3) -> Extent {
        let mut e = Extent::new();
        if let Some(c) = self.chunks.first() {
            feed(n, std::slice::from_ref(c), &mut e);
        }
        e
    }

    /// Feeds the projections on `n` of the chunks after the first into `e`: after
    /// [`SoaPoints::head`], `e` has been fed every chunk in order.
    #[inline(always)]
    pub(super) fn tail(&self, n: Vec3, e: &mut Extent) {
        feed(n, self.chunks.get(1..).unwrap_or(&[]), e);
    }

    /// Smallest projection on `n`: per lane `n.x * x + n.y * y + n.z * z` over the chunks
    /// in order, the smaller kept (the first on a tie), then the lanes reduced as
    /// [`Extent::min`] does.
    #[inline]
    pub(super) fn min_along(&self, n: Vec3) -> f32 {
        let (nx, ny, nz) = (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
        let mut m = Vec4::INFINITY;
        for &[xs, ys, zs] in &self.chunks {
            let d = nx * xs + ny * ys + nz * zs;
            m = less(d, m);
        }
        Extent::reduce(m)
    }

    /// The smallest projections on `count` axes (`axis(f)` for `f` in order), each fed to
    /// `visit(f, axis, smallest)` until one returns `Some(x)`, which is returned as `(f,
    /// x)`. Four axes at a time by [`SoaPoints::min_along4`], the last one to three one at
    /// a time by [`SoaPoints::min_along`]: the same floats as `min_along` on each axis, and
    /// the same visits (an axis computed after the one that stops is not visited).
    #[inline(always)]
    pub(super) fn each_min<R>(
        &self,
        count: usize,
        axis: impl Fn(usize) -> Vec3,
        mut visit: impl FnMut(usize, Vec3, f32) -> Option<R>,
    ) -> Option<(usize, R)> {
        let mut f = 0;
        while f + 4 <= count {
            let ns = [axis(f), axis(f + 1), axis(f + 2), axis(f + 3)];
            let ms = self.min_along4(ns);
            for k in 0..4 {
                if let Some(x) = visit(f + k, ns[k], ms[k]) {
                    return Some((f + k, x));
                }
            }
            f += 4;
        }
        while f < count {
            let n = axis(f);
            if let Some(x) = visit(f, n, self.min_along(n)) {
                return Some((f, x));
            }
            f += 1;
        }
        None
    }

    /// [`SoaPoints::min_along`] on four axes at once, bitwise: each axis's lanes by the
    /// same products, sums and `minps` in the same chunk order, then the four reduced
    /// together ([`reduce4`]).
    #[inline]
    pub(super) fn min_along4(&self, ns: [Vec3; 4]) -> [f32; 4] {
        let splat = |n: Vec3| (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
        let (n0, n1, n2, n3) = (splat(ns[0]), splat(ns[1]), splat(ns[2]), splat(ns[3]));
        let mut m = [Vec4::INFINITY; 4];
        for &[xs, ys, zs] in &self.chunks {
            m[0] = less(n0.0 * xs + n0.1 * ys + n0.2 * zs, m[0]);
            m[1] = less(n1.0 * xs + n1.1 * ys + n1.2 * zs, m[1]);
            m[2] = less(n2.0 * xs + n2.1 * ys + n2.2 * zs, m[2]);
            m[3] = less(n3.0 * xs + n3.1 * ys + n3.2 * zs, m[3]);
        }
        reduce4(m[0], m[1], m[2], m[3])
    }
}

/// Feeds `chunks`' projections on `n` into `e` (see [`Extent`]), chunk by chunk in order.
#[inline(always)]
fn feed(n: Vec3, chunks: &[[Vec4; 3]], e: &mut Extent) {
    let (nx, ny, nz) = (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
    for &[xs, ys, zs] in chunks {
        // The products of `min_along(n)` and, negated, those of `min_along(-n)`
        // (`(-a) * b == -(a * b)` bitwise), summed in the same order, lane by lane.
        let (p, q, s) = (nx * xs, ny * ys, nz * zs);
        let d = p + q + s;
        let dn = -p - q - s;
        e.lo = less(d, e.lo);
        e.lo_neg = less(dn, e.lo_neg);
    }
}

/// [`Extent::reduce`] of four lane sets at once, bitwise: on x86-64 the lanes paired by
/// shuffles and reduced by `minps` (`if d < m { d } else { m }`, the same rule as the
/// scalar reduction's, with the same operands first): `[p0, p2, q0, q2]` against
/// `[p1, p3, q1, q3]` gives each set's `a` and `b`, then the `a`s against the `b`s.
#[inline(always)]
fn reduce4(p: Vec4, q: Vec4, r: Vec4, s: Vec4) -> [f32; 4] {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        use std::arch::x86_64::{_mm_min_ps, _mm_shuffle_ps};
        // SAFETY: SSE, enabled for this target (the `cfg` above); no memory is touched.
        unsafe {
            let pairs = |x: Vec4, y: Vec4| {
                let (x, y) = (x.into(), y.into());
                _mm_min_ps(
                    _mm_shuffle_ps::<0b10_00_10_00>(x, y),
                    _mm_shuffle_ps::<0b11_01_11_01>(x, y),
                )
            };
            let (m, n) = (pairs(p, q), pairs(r, s));
            let a = _mm_shuffle_ps::<0b10_00_10_00>(m, n);
            let b = _mm_shuffle_ps::<0b11_01_11_01>(m, n);
            Vec4::from(_mm_min_ps(a, b)).to_array()
        }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        [p, q, r, s].map(Extent::reduce)
    }
}

/// The smallest and largest projections of some points on an axis, accumulated chunk by
/// chunk in the lanes of [`SoaPoints::min_along`]: fed all the chunks, [`Extent::min`] is
/// bitwise `min_along(n)` and [`Extent::max`] bitwise `-min_along(-n)`; fed some, they bound
/// those from inside (a minimum no smaller, a maximum no larger).
pub(super) struct Extent {
    lo: Vec4,
    lo_neg: Vec4,
}

/// `if d < m { d } else { m }` lane by lane: on x86-64 the one instruction `minps`, which
/// is that rule exactly (the second operand on a tie, such as `-0` against `0`, or when
/// either is a NaN).
#[inline(always)]
fn less(d: Vec4, m: Vec4) -> Vec4 {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        // SAFETY: `minps` is SSE, enabled for this target (the `cfg` above).
        Vec4::from(unsafe { std::arch::x86_64::_mm_min_ps(d.into(), m.into()) })
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        Vec4::select(d.cmplt(m), d, m)
    }
}

impl Extent {
    /// Nothing fed yet.
    #[inline]
    pub(super) fn new() -> Self {
        Self {
            lo: Vec4::INFINITY,
            lo_neg: Vec4::INFINITY,
        }
    }

    /// The lanes reduced to their smallest: lanes 0 and 1, 2 and 3, then the two (the
    /// first kept on a tie).
    #[inline]
    fn reduce(m: Vec4) -> f32 {
        let m = m.to_array();
        let a = if m[0] < m[1] { m[0] } else { m[1] };
        let b = if m[2] < m[3] { m[2] } else { m[3] };
        if a < b { a } else { b }
    }

    /// Smallest projection fed.
    #[cfg(test)]
    pub(super) fn min(&self) -> f32 {
        Self::reduce(self.lo)
    }

    /// Largest projection fed.
    #[cfg(test)]
    pub(super) fn max(&self) -> f32 {
        -Self::reduce(self.lo_neg)
    }

    /// `[a.min(), a.max(), b.min(), b.max()]`, bitwise, the four reductions made together
    /// ([`reduce4`]).
    #[inline(always)]
    pub(super) fn bounds(a: &Extent, b: &Extent) -> [f32; 4] {
        let [min_a, lo_a, min_b, lo_b] = reduce4(a.lo, a.lo_neg, b.lo, b.lo_neg);
        [min_a, -lo_a, min_b, -lo_b]
    }
}

/// Two convex polyhedra, with what the pair remembers (`hint`, `bound`: see
/// [`super::collide_with_hint`]).
///
/// When the bodies are apart, `bound` receives a lower bound of their distance (the gap
/// along the separating axis found, or between the bounding spheres), else 0: the simulator
/// skips the pair until the bodies have moved that far. When they touch at a face, `hint`
/// receives the reference face and `bound` twice the margin of the full test's decisions
/// less the face's separation (see `contact_margin`); a later call whose remaining `bound`
/// is above minus twice the face's separation then clips that face alone, for the manifold
/// the full test would give, bitwise. An edge contact is remembered
/// likewise (see `remembered_edge`).
pub fn polyhedron_polyhedron(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    hint: &mut SatHint,
    bound: &mut f32,
) -> Option<Manifold> {
    polyhedron_pair(a, pa, b, pb, hint, bound, None)
}

/// [`polyhedron_polyhedron`] with the pair's [`EdgeMemory`], if it has one: the same
/// answer, bitwise, with fewer edge pairs visited while the memory holds.
pub(super) fn polyhedron_pair(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    hint: &mut SatHint,
    bound: &mut f32,
    mut memory: Option<&mut EdgeMemory>,
) -> Option<Manifold> {
    let margin = *bound;
    *bound = 0.0;
    let d = pb.position - pa.position;
    let rs = a.radius + b.radius;
    let d2 = d.length_squared();
    if d2 >= rs * rs {
        if is_contact_hint(*hint) {
            *hint = NO_HINT;
        }
        *bound = d2.sqrt() - rs;
        return None;
    }
    // Everything in A's frame: B's rotation and offset relative to A.
    let inv_a = pa.rotation.conjugate();
    let rot_q = inv_a * pb.rotation;
    let rot = glam::Mat3::from_quat(rot_q);
    let inv_rot = rot.transpose();
    let t = inv_a * d;
    let rel = Relative {
        rot,
        inv_rot,
        t,
        q: rot_q,
    };
    // An edge search already made at these poses, if any (see `remembered_edge`).
    let mut searched = None;
    // A face already clipped at these poses, if any (see `remembered_face`).
    let mut clipped = None;
    // What of the scratch `remembered_edge` already filled at these poses (see `Prepared`).
    let mut prepared = Prepared::Nothing;
    if is_contact_hint(*hint) {
        let face = *hint & !(HINT_KIND | HINT_CONTACT);
        let found = if face == EDGE_CONTACT {
            // The full edge search again, without the face axes; when it fails, its answer
            // (if it is the search's without a floor) serves the full test below.
            SCRATCH
                .with_borrow_mut(|sc| {
                    let memory = memory.as_deref_mut();
                    remembered_edge(a, pa, b, &rel, sc, margin, memory, &mut prepared)
                })
                .map_err(|e| searched = e)
                .ok()
                .map(Some)
        } else if margin + 2.0 * reference_separation(a, b, &rel, *hint & HINT_KIND, face) > 0.0 {
            // The full test would choose the remembered face again (see `contact_margin`):
            // clip it alone. When the overlap is not certified, the clipped face serves the
            // full test below.
            SCRATCH
                .with_borrow_mut(|sc| {
                    remembered_face(a, pa, b, pb, &rel, sc, *hint & HINT_KIND, face as usize)
                })
                .map_err(|c| clipped = c)
                .ok()
        } else {
            None
        };
        if let Some(m) = found {
            *bound = if m.is_some() { margin } else { 0.0 };
            if m.is_none() {
                *hint = NO_HINT;
            }
            return m;
        }
        *hint = NO_HINT;
    }
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
            *bound = gap;
            return None;
        }
    }
    SCRATCH.with_borrow_mut(|sc| {
        let full = FullTest {
            searched,
            memory,
            clipped,
            prepared,
        };
        sat_full(a, pa, b, pb, &rel, sc, full, hint, bound)
    })
}

/// B's rotation and offset in A's frame.
struct Relative {
    rot: Mat3,
    inv_rot: Mat3,
    t: Vec3,
    /// `rot` as the quaternion it was built from.
    q: Quat,
}

/// What [`sat_full`] may take instead of searching the edge axes itself: the answer of an
/// edge search with no floor at the same poses, if one was made ([`remembered_edge`]),
/// and the pair's [`EdgeMemory`]; and instead of clipping, a face clipped at the same
/// poses ([`remembered_face`]).
struct FullTest<'m> {
    searched: Option<EdgeFound>,
    memory: Option<&'m mut EdgeMemory>,
    clipped: Option<Clipped>,
    prepared: Prepared,
}

/// What of the scratch ([`Scratch`]) [`remembered_edge`] filled for the same pair at the
/// same poses before the full test runs, which [`sat_full`] then takes as it is instead
/// of computing it again from the same inputs by the same expressions (the same floats).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Prepared {
    /// Nothing: the full test fills it all.
    Nothing,
    /// B's vertices in A's frame (`bv`).
    Vertices,
    /// `bv`, and B's points as lanes (`b_soa`; A's are the shape's own).
    Lanes,
}

/// A reference face clipped by [`remembered_face`] whose overlap was not certified: its
/// kind ([`HINT_FACE_A`] or [`HINT_FACE_B`]), its index and the manifold in its body's
/// frame, before [`to_world`]. [`sat_full`] takes it when it chooses that face: the same
/// call of [`clip_faces`] with the same arguments (the incident vertices by the same
/// expressions), so the same manifold, bitwise.
type Clipped = (u32, usize, Manifold);

/// The remembered reference face `face` (of A for `kind` [`HINT_FACE_A`], else of B)
/// clipped with the full test's own expressions ([`sat_full`]): `Ok(manifold)` as the full
/// test would return it, or `Err` when the overlap is not certain enough to rule out a
/// separating axis ([`overlap_certified`]; the full test must run), with the clipped face
/// when there is one (for the full test, if it chooses that face: [`Clipped`]).
#[allow(clippy::too_many_arguments)]
// Out of line (as is `sat_full`): inlined into `polyhedron_pair` with
// `reference_separation`, the cube pile took 3% more instructions (callgrind).
#[inline(never)]
fn remembered_face(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    rel: &Relative,
    sc: &mut Scratch,
    kind: u32,
    face: usize,
) -> Result<Option<Manifold>, Option<Clipped>> {
    let Relative {
        rot, inv_rot, t, ..
    } = *rel;
    let Scratch { clip, .. } = sc;
    let delta = 2e-5 * (a.radius + b.radius);
    if kind == HINT_FACE_A {
        if face >= a.faces.len() {
            return Err(None);
        }
        let m = clip_faces(a, face, b, |i| rot * b.vertices[i] + t, rot, clip).ok_or(None)?;
        let to_b = |p: Vec3| inv_rot * (p - t);
        if overlap_certified(a, &m, delta) || wedge_certified(a, face, b, to_b, rot, &m, delta) {
            Ok(Some(to_world(m, pa)))
        } else {
            Err(Some((kind, face, m)))
        }
    } else {
        if face >= b.faces.len() {
            return Err(None);
        }
        let inc_v = |i: usize| inv_rot * (a.vertices[i] - t);
        let m = clip_faces(b, face, a, inc_v, inv_rot, clip).ok_or(None)?;
        let to_a = |p: Vec3| rot * p + t;
        if overlap_certified(b, &m, delta) || wedge_certified(b, face, a, to_a, inv_rot, &m, delta)
        {
            Ok(Some(to_world(m, pb).flipped()))
        } else {
            Err(Some((kind, face, m)))
        }
    }
}

/// The separation along reference face `face` (of A for `kind` [`HINT_FACE_A`], else of
/// B) at the current poses: the smallest projection of the other body's vertices on the
/// face's normal, less the face's offset, as the full test's face loops compute it up to
/// rounding (B's face by the same expression; A's face with the normal turned into B's
/// frame instead of B's vertices into A's, a few ulps of the bodies' size apart, far
/// inside `contact_margin`'s `eps`). NaN for a face index out of range (no remembered
/// face then serves).
// Inlined now that a box's case is a closed form (cube pile 7,939 -> 7,922 Ir per
// body-step, callgrind); `remembered_face` and `sat_full` stay out of line.
#[inline]
fn reference_separation(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rel: &Relative,
    kind: u32,
    face: u32,
) -> f32 {
    let face = face as usize;
    let smallest = |p: &ConvexPolyhedron, n: Vec3| {
        if let Some(h) = p.corner_box {
            // A box's corners: the loop's smallest in closed form, the same value (see
            // `ConvexPolyhedron::corner_box`); its first comparison with infinity kept, so
            // that a NaN direction gives infinity as the loop does.
            let a = n.abs();
            let d = -((a.x * h.x + a.y * h.y) + a.z * h.z);
            return if d < f32::INFINITY { d } else { f32::INFINITY };
        }
        let mut m = f32::INFINITY;
        for v in &p.vertices {
            let d = n.x * v.x + n.y * v.y + n.z * v.z;
            m = if d < m { d } else { m };
        }
        m
    };
    if kind == HINT_FACE_A {
        let Some(f) = a.faces.get(face) else {
            return f32::NAN;
        };
        smallest(b, rel.inv_rot * f.normal) + f.normal.dot(rel.t) - f.offset
    } else {
        let Some(f) = b.faces.get(face) else {
            return f32::NAN;
        };
        let n = rel.rot * f.normal;
        smallest(a, n) - (f.offset + n.dot(rel.t))
    }
}

/// The face index of [`HINT_EDGE_CONTACT`]: no face has it.
const EDGE_CONTACT: u32 = HINT_CONTACT - 1;
// The contact hint of an edge contact, `HINT_EDGE_CONTACT` (its `bound` is twice the level,
// negated, that the best edge axis must stay above, see `remembered_edge`).

/// An edge contact found at an earlier step: the full edge-axis search again (the winning
/// edge pair is then the full test's by construction), without the face axes, whose
/// decisions are known otherwise. `Err` when the full test must run, with the search's
/// answer when it is the one a search without a floor gives (see [`exact_search`]): the
/// full test takes it instead of searching again at the same poses.
///
/// The margin is anchored on the best edge axis's separation as [`contact_margin`]'s is on
/// the reference face's: the full test keeps an edge contact when `best_e > face_best +
/// tol`, and this search computes `best_e` anew at each pose (exactly the full test's: the
/// same search, see [`exact_search`]), so only the other side, `face_best`, is bounded. The
/// best face axis's separation moves by at most the bodies' motion bound `w` per step (see
/// [`contact_margin`]), so with `W` the bounds summed since the full test, `face_best <=
/// face_best_then + W` (the full test's `face_best_then`, less `eps` for rounding), and
/// `best_e - (face_best_then + tol) - eps - W > 0` implies the decision. The pair stores
/// twice the room, `2 (-(face_best_then + tol) - eps)`, the caller subtracts `2 w` per step
/// (as for faces), so `margin = stored - 2 W` and the edge serves while `margin / 2 +
/// best_e > 0` (`margin / 2` is exact; the sign of a float sum is exact). (Before, the
/// pair stored the room once and served while `margin + best_e > 0`: the room was spent at
/// `2 W`, twice the rate this proof needs.)
///
/// It also implies that no axis separates, with no check of the overlap: the search found
/// no separating edge axis (one would be positive, above any floor, and returned as such:
/// see [`exact_search`]), so `best_e <= 0`, and every face axis's separation is now at most
/// `face_best_then + W < best_e - tol - eps <= -tol`: the full test finds no separating
/// face axis either, and keeps this edge contact.
///
/// `prepared` receives what of the scratch it filled at these poses (for [`sat_full`]).
#[allow(clippy::too_many_arguments)]
fn remembered_edge(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    rel: &Relative,
    sc: &mut Scratch,
    margin: f32,
    memory: Option<&mut EdgeMemory>,
    prepared: &mut Prepared,
) -> Result<Manifold, Option<EdgeFound>> {
    let Scratch {
        bv, b_soa, tables, ..
    } = sc;
    // A's points in its own frame: the lanes the shape keeps (see `ConvexPolyhedron`).
    let a_local = a.lanes();
    // (Written so that a NaN returns too.) With no margin left the search cannot keep the
    // edge: a best edge axis is never positive (a positive one separates, and the full test
    // must run), so `best_e + margin > 0` fails.
    if margin.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(None);
    }
    bv.clear();
    bv.extend(b.vertices.iter().map(|&v| rel.rot * v + rel.t));
    *prepared = Prepared::Vertices;
    if edges_by_direction(a, b) {
        b_soa.fill(bv);
        *prepared = Prepared::Lanes;
    }
    // The pair stores twice the room (see above): the edge serves while `best_e + half > 0`.
    let half = 0.5 * margin;
    // Axes at or below `-half` fail the test below whether they win or not: left out.
    let found = edge_search(a, b, rel, bv, a_local, b_soa, tables, -half, memory);
    let exact = exact_search(&found, -half);
    let keep = |found: EdgeFound| if exact { Some(found) } else { None };
    let best_e = found.map_err(|e| keep(Err(e)))?;
    // (Written so that a NaN fails the test too.)
    if (best_e.0 + half).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(keep(Ok(best_e)));
    }
    Ok(edge_manifold(a, b, pa, bv, best_e))
}

/// An edge search's answer: the best edge axis, or the separating one (its hint and
/// separation).
type EdgeFound = Result<EdgeAxis, (SatHint, f32)>;

/// Whether `found`, from [`edge_search`] with `floor`, is what the search gives with no
/// floor, and so with any: a separating axis (positive, above any floor: every axis left
/// out is at or below the floor, so none separates, and the first that does is the same),
/// or a best axis above the floor (returned exactly as with no floor, see
/// [`edge_search`]). (By Gauss map or by direction alike: both leave out only axes at or
/// below the floor.)
fn exact_search(found: &EdgeFound, floor: f32) -> bool {
    match found {
        Err(_) => true,
        Ok(e) => e.0 > floor,
    }
}

/// The best edge-edge axis, by direction or by Gauss map (whichever is cheaper for the
/// pair), or `Err((hint, separation))` when an edge axis separates the bodies.
///
/// `floor` (not positive) is a level the caller does not care below: axes whose separation
/// is at most `floor` may be left out unevaluated (see [`edge_axes_by_direction`]). When
/// the best axis is above `floor` it is returned exactly as with no floor (the same pair,
/// the first of equals, the same floats); else some axis at or below `floor` is.
#[allow(clippy::too_many_arguments)]
fn edge_search(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rel: &Relative,
    bv: &[Vec3],
    a_local: &SoaPoints,
    b_soa: &SoaPoints,
    tables: &mut GaussTables,
    floor: f32,
    memory: Option<&mut EdgeMemory>,
) -> Result<EdgeAxis, (SatHint, f32)> {
    let (mut hint, mut separation) = (NO_HINT, 0.0);
    let found = if edges_by_direction(a, b) {
        let memory = memory.map(|m| (m, rel.q, rel.t));
        edge_axes_by_direction(
            a,
            b,
            rel.rot,
            a_local,
            b_soa,
            bv,
            floor,
            tables,
            memory,
            &mut hint,
            &mut separation,
        )
    } else {
        let (rot, inv_rot) = (rel.rot, rel.inv_rot);
        let memory = memory.map(|m| (m, rel.q, rel.t));
        edge_axes_gauss_map(
            a,
            b,
            rot,
            inv_rot,
            bv,
            floor,
            tables,
            memory,
            &mut hint,
            &mut separation,
        )
    };
    found.ok_or((hint, separation))
}

/// Whether the edge axes of `a` and `b` are cheaper by direction (projecting both bodies
/// on each pair of edge directions) than by Gauss map.
fn edges_by_direction(a: &ConvexPolyhedron, b: &ConvexPolyhedron) -> bool {
    let (nda, ndb) = (a.edge_dirs.len(), b.edge_dirs.len());
    let cost_dirs = nda * ndb * (a.vertices.len() + b.vertices.len());
    let cost_tables = a.edges.len() * b.faces.len()
        + b.edges.len() * a.faces.len()
        + a.edges.len() * b.edges.len();
    cost_dirs <= 2 * cost_tables
}

/// The manifold of edge contact `best_e` (one point, halfway between the closest points of
/// the two edges).
fn edge_manifold(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    pa: &Pose,
    bv: &[Vec3],
    best_e: EdgeAxis,
) -> Manifold {
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
    Manifold::single(pa.rotation * axis, pa.transform_point(mid), -s)
}

/// The margin of the full test's decisions for a face contact, less the reference face's
/// separation: the full test at a later pose chooses the same reference face while that
/// face's separation then, `s`, plus this margin exceeds how much any other separation can
/// have changed since. `second` is the best of the other faces of the reference body,
/// `other` the best face of the other body, `largest` the larger of the best face and the
/// best edge axis, `ref_b` whether the reference face is B's.
///
/// The decisions, each with `s` computed anew at the later pose
/// ([`reference_separation`]) and only the other side of each comparison bounded (each
/// separation, and the largest separation along any direction, moves by at most the
/// bodies' motion bound `w` per step):
/// - the reference face beats the other faces of its body, the first maximum winning ties:
///   `second + w < s` (strict), the term `-second`;
/// - A's face is kept unless `best_b > best_a + tol`: for A's face, `best_b + w <= s + tol`,
///   the term `tol - other`; for B's face, `best_a + w + tol < s`, the term `-(other + tol)`;
/// - no edge contact, `best_e <= face_best + tol`: an edge axis is the normal of a face of
///   the Minkowski difference, which turns much faster than the bodies when its two edges
///   are close to parallel, so one edge axis's separation cannot be followed from step to
///   step. But each is the separation along its axis, at most the largest separation along
///   any direction, `largest` (attained at a face axis or an edge axis), which moves no
///   more than the bodies, and `face_best >= s`: `largest + w <= s + tol`, the term `tol -
///   largest`;
/// - no axis separates: checked at each step instead, on the manifold found
///   ([`overlap_certified`]): the bodies' overlap, not a decision's slack.
///
/// So the face serves while `s + margin - sum(w) > 0`, with the margin less `eps` for
/// rounding and for edge axes skipped as near-parallel. The caller subtracts twice the
/// bound per step from what the pair stores (see `super::collide_with_hint`), so the pair
/// stores twice this margin and the face serves while `stored + 2 s > 0`. (The margin
/// relative to the full test's own `s` alone, `best - second`, `cross`, `face_best + tol -
/// largest` less twice the bound, spent the same room at twice the rate: each compared
/// quantity moved by the bound, the reference face's separation too. On parallel faces,
/// where the cross and edge terms sit at `tol`, that room is about `tol - eps`.)
fn contact_margin(second: f32, other: f32, largest: f32, ref_b: bool, tol: f32) -> f32 {
    let cross = if ref_b { -(other + tol) } else { tol - other };
    (-second).min(cross).min(tol - largest)
}

/// Per-thread buffers of the separating-axis test (no allocation or zeroing per pair).
#[derive(Default)]
struct Scratch {
    bv: Vec<Vec3>,
    b_soa: SoaPoints,
    tables: GaussTables,
    clip: ClipBuffers,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// The full separating-axis test with B at `rel` in A's frame. `searched`: the answer of an
/// edge search with no floor at these poses, if one was made ([`remembered_edge`]), taken
/// for the test's own (the same answer: a search with a floor only leaves out axes at or
/// below it).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn sat_full(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    rel: &Relative,
    sc: &mut Scratch,
    full: FullTest,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<Manifold> {
    let Scratch {
        bv,
        b_soa,
        tables,
        clip,
    } = sc;
    // A's points in its own frame: the lanes the shape keeps (see `ConvexPolyhedron`).
    let a_local = a.lanes();
    let Relative {
        rot, inv_rot, t, ..
    } = *rel;
    // (`rel.rot * v + rel.t` in `remembered_edge`: the same floats.)
    if full.prepared == Prepared::Nothing {
        bv.clear();
        bv.extend(b.vertices.iter().map(|&v| rot * v + t));
    }
    let bv: &[Vec3] = bv;
    if full.prepared != Prepared::Lanes {
        b_soa.fill(bv);
    }
    // Face axes of A.
    let mut best_a = (f32::NEG_INFINITY, 0usize);
    let mut second_a = f32::NEG_INFINITY;
    let normal_a = |f: usize| a.faces[f].normal;
    let separating = b_soa.each_min(a.faces.len(), normal_a, |f, _, m| {
        // The separation of B's vertices along A's face `f`.
        let s = m - a.faces[f].offset;
        if s > 0.0 {
            return Some(s);
        }
        if s > best_a.0 {
            second_a = best_a.0;
            best_a = (s, f);
        } else if s > second_a {
            second_a = s;
        }
        None
    });
    if let Some((f, s)) = separating {
        *hint = HINT_FACE_A | f as u32;
        *separation = s;
        return None;
    }
    // Face axes of B, tested in A's frame: B's face plane `n.x = offset` becomes
    // `(R n).x = offset + (R n).t`, and A's own vertices need no transform.
    let mut best_b = (f32::NEG_INFINITY, 0usize);
    let mut second_b = f32::NEG_INFINITY;
    let normal_b = |f: usize| rot * b.faces[f].normal;
    let separating = a_local.each_min(b.faces.len(), normal_b, |f, n, m| {
        let s = m - (b.faces[f].offset + n.dot(t));
        if s > 0.0 {
            return Some(s);
        }
        if s > best_b.0 {
            second_b = best_b.0;
            best_b = (s, f);
        } else if s > second_b {
            second_b = s;
        }
        None
    });
    if let Some((f, s)) = separating {
        *hint = HINT_FACE_B | f as u32;
        *separation = s;
        return None;
    }
    // Edge axes at or below the best face axis change no decision below (nor the margin:
    // `contact_margin` takes the larger of the two), so the search may leave them out.
    let face_best = best_a.0.max(best_b.0);
    let found = match full.searched {
        Some(found) => found,
        None => edge_search(
            a,
            b,
            rel,
            bv,
            a_local,
            b_soa,
            tables,
            face_best,
            full.memory,
        ),
    };
    let best_e = match found {
        Ok(e) => e,
        Err((h, s)) => {
            *hint = h;
            *separation = s;
            return None;
        }
    };
    let scale = a.radius.max(b.radius);
    *hint = NO_HINT;
    let tol = 1e-3 * scale;
    // Rounding of the separations (a few ulps of the bodies' size) and the near-parallel
    // edge axes left out (sine below 1e-5, over edges shorter than the diameter).
    let eps = 1e-4 * scale;
    if best_e.0 > face_best + tol {
        // Edge contact. Remembered with twice the room the best edge axis has above the
        // best face's level: the best face moves by at most the bodies' motion, and the
        // edge serves while `stored / 2 + best_e > 0` (see `remembered_edge`).
        *hint = HINT_EDGE_CONTACT;
        *separation = 2.0 * (-(face_best + tol) - eps);
        return Some(edge_manifold(a, b, pa, bv, best_e));
    }
    // Face contact: prefer A's face unless B's is clearly better.
    let ref_b = best_b.0 > best_a.0 + tol;
    let (best, second, other, kind, face) = if ref_b {
        (best_b.0, second_b, best_a.0, HINT_FACE_B, best_b.1)
    } else {
        (best_a.0, second_a, best_b.0, HINT_FACE_A, best_a.1)
    };
    let largest = face_best.max(best_e.0);
    // Twice the margin (see `contact_margin`): the face serves while `margin + 2 s > 0`.
    let margin = 2.0 * (contact_margin(second, other, largest, ref_b, tol) - eps);
    // The face clipped already at these poses, if it is this one (see `Clipped`).
    let clipped = match full.clipped {
        Some((k, f, m)) if k == kind && f == face => Some(m),
        _ => None,
    };
    let m = if ref_b {
        // Reference face on B: work in B's frame with A as incident.
        let inc_v = |i: usize| inv_rot * (a.vertices[i] - t);
        clipped
            .or_else(|| clip_faces(b, face, a, inc_v, inv_rot, clip))
            .map(|m| to_world(m, pb).flipped())
    } else {
        clipped
            .or_else(|| clip_faces(a, face, b, |i| bv[i], rot, clip))
            .map(|m| to_world(m, pa))
    };
    if m.is_some() && margin + 2.0 * best > 0.0 && face < EDGE_CONTACT as usize {
        *hint = kind | HINT_CONTACT | face as u32;
        *separation = margin;
    }
    m
}

/// The best edge-edge axis `(separation, edge of A, edge of B, axis in A's frame)`, or `None`
/// when an edge axis separates the bodies (recorded in `hint`).
pub(super) type EdgeAxis = (f32, usize, usize, Vec3);

#[cfg(test)]
mod tests {
    use super::{Extent, SoaPoints, reduce4};
    use glam::{Vec3, Vec4};

    /// A xorshift generator and floats from it: mostly ordinary values, with zeros of both
    /// signs, infinities, NaN, subnormals and raw bit patterns mixed in.
    struct Floats(u64);

    impl Floats {
        fn bits(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }

        fn any(&mut self) -> f32 {
            let r = self.bits();
            match r % 16 {
                0 => 0.0,
                1 => -0.0,
                2 => f32::INFINITY,
                3 => f32::NEG_INFINITY,
                4 => f32::NAN,
                5 => f32::from_bits((r >> 32) as u32),
                6 => f32::from_bits((r >> 41) as u32 & 0x007f_ffff),
                // A few repeated values, for ties.
                7 => [1.0, -1.0, 0.5][(r >> 20) as usize % 3],
                _ => self.ordinary(),
            }
        }

        fn ordinary(&mut self) -> f32 {
            let r = self.bits();
            ((r >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 4.0
        }
    }

    /// `reduce4` and `Extent::bounds` against `Extent::reduce`, `min` and `max` one at a
    /// time, bitwise, on random lanes with ties of `0` and `-0`, infinities and NaNs.
    #[test]
    fn reductions_four_at_once_are_the_reductions_one_at_a_time() {
        let mut g = Floats(0x9e37_79b9_7f4a_7c15);
        for case in 0..200_000 {
            let mut lanes = || Vec4::new(g.any(), g.any(), g.any(), g.any());
            let (p, q, r, s) = (lanes(), lanes(), lanes(), lanes());
            let got = reduce4(p, q, r, s).map(f32::to_bits);
            let want = [p, q, r, s].map(|v| Extent::reduce(v).to_bits());
            assert_eq!(got, want, "case {case}: {p:?} {q:?} {r:?} {s:?}");
            let (a, b) = (Extent { lo: p, lo_neg: q }, Extent { lo: r, lo_neg: s });
            let got = Extent::bounds(&a, &b).map(f32::to_bits);
            let want = [a.min(), a.max(), b.min(), b.max()].map(f32::to_bits);
            assert_eq!(got, want, "case {case}");
        }
    }

    /// The lanes a polyhedron keeps are its vertices: the smallest projection on random
    /// axes by the lanes against the plain smallest over `vertices` (by value), and the
    /// lanes laid out anew from `vertices` (bitwise), for hulls of random clouds and their
    /// copies moved by `map_vertices`.
    #[test]
    fn a_polyhedrons_lanes_are_its_vertices() {
        let mut g = Floats(0x5851_f42d_4c95_7f2d);
        let mut shapes = 0;
        for case in 0..400 {
            let count = 4 + case % 40;
            let pts: Vec<Vec3> = (0..count)
                .map(|_| Vec3::new(g.ordinary(), g.ordinary(), g.ordinary()))
                .collect();
            let Ok(hull) = crate::hull::convex_hull(&pts) else {
                continue;
            };
            let shift = Vec3::new(g.ordinary(), g.ordinary(), g.ordinary());
            for p in [hull.clone(), hull.map_vertices(|v| 2.0 * v + shift)] {
                shapes += 1;
                for _ in 0..8 {
                    let n = Vec3::new(g.ordinary(), g.ordinary(), g.ordinary());
                    let brute = p
                        .vertices
                        .iter()
                        .map(|v| n.x * v.x + n.y * v.y + n.z * v.z)
                        .fold(f32::INFINITY, f32::min);
                    assert_eq!(p.lanes().min_along(n), brute, "case {case}");
                }
                assert_eq!(p.lanes(), &SoaPoints::of(&p.vertices), "case {case}");
            }
        }
        assert!(shapes > 600);
    }

    /// `min_along4` and `each_min` against `min_along` axis by axis (bitwise), and
    /// `min_along` against the plain smallest projection of the points (by value), on
    /// random point sets of 1 to 40 points and random axes.
    #[test]
    fn four_axes_at_once_are_the_axes_one_at_a_time() {
        let mut g = Floats(0x2545_f491_4f6c_dd1d);
        let mut soa = SoaPoints::default();
        for case in 0..20_000 {
            let count = 1 + (g.bits() % 40) as usize;
            let pts: Vec<Vec3> = (0..count)
                .map(|_| Vec3::new(g.ordinary(), g.ordinary(), g.ordinary()))
                .collect();
            soa.fill(&pts);
            let axes = 1 + (g.bits() % 11) as usize;
            let ns: Vec<Vec3> = (0..axes)
                .map(|_| Vec3::new(g.ordinary(), g.ordinary(), g.ordinary()))
                .collect();
            for (k, &n) in ns.iter().enumerate() {
                let brute = pts
                    .iter()
                    .map(|p| n.x * p.x + n.y * p.y + n.z * p.z)
                    .fold(f32::INFINITY, f32::min);
                assert_eq!(soa.min_along(n), brute, "case {case}, axis {k}");
            }
            let four = [0, 1, 2, 3].map(|k| ns[k % axes]);
            let got = soa.min_along4(four).map(f32::to_bits);
            let want = four.map(|n| soa.min_along(n).to_bits());
            assert_eq!(got, want, "case {case}");
            // Visits in order, stopping where the visitor says (or never).
            let stop = (g.bits() % (axes as u64 + 1)) as usize;
            let mut seen = Vec::new();
            let found = soa.each_min(
                axes,
                |f| ns[f],
                |f, n, m| {
                    assert_eq!(n, ns[f]);
                    seen.push((f, m.to_bits()));
                    (f == stop).then_some(m)
                },
            );
            let want: Vec<_> = (0..axes.min(stop + 1))
                .map(|f| (f, soa.min_along(ns[f]).to_bits()))
                .collect();
            assert_eq!(seen, want, "case {case}");
            let want = (stop < axes).then(|| (stop, want[stop].1));
            assert_eq!(found.map(|(f, m)| (f, m.to_bits())), want, "case {case}");
        }
    }
}

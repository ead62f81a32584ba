//! Certificates that two bodies overlap, so that no axis of the full separating-axis test
//! separates them: what lets a remembered face contact stand in for the full test
//! ([`super::sat`]'s `remembered_face`).

use glam::{Mat3, Quat, Vec3};

use super::Manifold;
use super::slack::{ALLOW, SHRINK, UNIT};
use crate::ConvexPolyhedron;

/// The centroid of the manifold's points moved back halfway along the normal: on the
/// incident face, up to rounding (see [`overlap_certified`]).
fn incident_centroid(m: &Manifold) -> Vec3 {
    let mut c = Vec3::ZERO;
    for p in m.points() {
        c += p.point - m.normal * (0.5 * p.depth);
    }
    c / m.count as f32
}

/// Whether the bodies certainly overlap by more than `delta`, so that no axis of the full
/// test separates them, for a face contact `m` in the reference body's frame.
///
/// Why: each point of the manifold is a point of the incident face (a corner of its clipped
/// polygon, or its deepest vertex) moved halfway along the normal; moved back, their
/// centroid `c` is a point of the incident body (the face is convex), up to rounding. If
/// `c` is at least `delta` inside every face plane of the reference body, the ball of
/// radius `delta` about `c` lies in that body, so along any direction `u` the incident
/// body reaches below `u.c` and the reference body above `u.c + delta`: every axis's
/// separation is at most `-delta`. With `delta` above the rounding of `c` and of the full
/// test's separations, none of them is positive.
// One copy out of line, shared by both kinds of reference face and the full test (issue
// 23: the served paths' code footprint).
#[inline(never)]
pub(super) fn overlap_certified(refp: &ConvexPolyhedron, m: &Manifold, delta: f32) -> bool {
    let c = incident_centroid(m);
    // The six faces of the signed axes (a box): each normal's product with a finite `c` is
    // `±c[axis]` as a value ([`ConvexPolyhedron::face_axes`]), so the same comparisons
    // without the products (a zero's sign cannot change a `<=`). A `c` not finite fails
    // both ways: a NaN fails every comparison; an infinite `c[k]` is `+inf` against one of
    // axis `k`'s two faces (and the products' `0 * inf` are NaNs).
    if let Some(of) = refp.face_axes {
        let v = c.to_array();
        let inside = |code: usize, x: f32| x - refp.faces[of[code] as usize].offset <= -delta;
        return (0..3).all(|k| inside(k, v[k]) && inside(k | 4, -v[k]));
    }
    inside_every_face(refp, c, delta)
}

/// A face contact's overlap certificate remembered at one pose, its anchor: which of
/// [`overlap_certified`] (the centroid's) or [`wedge_certified`] (the ball's) held there,
/// and with how much room, so that [`remembered_certified`] takes it at a later pose without
/// measuring either while the incident body's points have moved less than that room.
///
/// Why it holds: each certificate names a ball that lies in both bodies at the anchor, with
/// room `r` to spare inside the incident body (in the reference body's frame, where the
/// reference body does not move):
/// - the centroid's: the centroid `c` is a point of the incident body (up to rounding) at
///   least `delta + r` inside every face plane of the reference body, so the ball of radius
///   `delta + r` about `c` lies in the reference body. At a later pose the same point of the
///   incident body, `c'`, is within `moved` of `c`, so the ball of radius `delta` about `c'`
///   lies in the reference body while `moved < r`: the certificate's own argument holds for
///   `c'` (a point of the incident body with a ball of radius `delta` about it in the
///   reference body).
/// - the ball's: its point `p` is at least `delta / 2 + r` inside every face plane of both
///   bodies, so the ball of radius `delta / 2 + r` about `p` lies in both. The reference
///   body's part does not change with the pose. The incident body's part is made of points
///   of that body, each moved by at most `moved`: a rigid motion, it carries that ball to a
///   ball of the same radius about a point within `moved` of `p`, which holds the ball of
///   radius `delta / 2` about `p` while `moved < r`: the certificate's own argument holds for
///   `p` (a ball of radius `delta / 2` about it in both bodies).
///
/// Either way no axis of the full test separates the bodies, by the certificate's argument,
/// with the same room for the full test's rounding. `moved` is bounded as
/// [`super::slack::FaceSlack`] bounds the incident points' motion from its record (the same
/// expressions, and the same `lever` taken at the anchor for the ball's; for the centroid's
/// the lever of its one point, see [`measure_centroid`]), and the room kept is the one
/// measured less [`ALLOW`] of the radii (the rounding of the measured distances, of `c` and
/// of the pose) and the anchor's own rotation term, `4 |s0 - 1| lever`. The certificate
/// only decides whether the full test must run, never the manifold. It is kept with the
/// pair's clip record (inside [`super::slack::FaceSlack`]), which forgets it whenever it
/// measures a new record: so it is only taken for the record's reference face and shapes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Certificate {
    /// The relative quaternion (B's rotation in A's frame) at the anchor.
    q: Quat,
    /// B's offset in A's frame at the anchor.
    t: Vec3,
    /// The rotation's lever at the anchor (see [`super::slack::FaceSlack`]).
    lever: f32,
    /// How far the incident points may move from the anchor while the certificate holds,
    /// the rounding and the anchor's rotation term taken off (`-inf`: none remembered).
    room: f32,
    /// Whether it is the ball's certificate ([`wedge_certified`]'s), for the count of
    /// [`wedge_certificates`].
    ball: bool,
}

impl Default for Certificate {
    fn default() -> Self {
        Certificate {
            q: Quat::IDENTITY,
            t: Vec3::ZERO,
            lever: 0.0,
            room: f32::NEG_INFINITY,
            ball: false,
        }
    }
}

impl Certificate {
    /// Whether the certificate holds at relative quaternion `q` and offset `t`: the
    /// incident points have moved less than the room since the anchor (written so that a
    /// NaN fails).
    #[inline]
    fn holds(&self, q: Quat, t: Vec3) -> bool {
        let s = (q.length_squared() - 1.0).abs();
        let dt = (t - self.t).abs();
        let turn = 2.0 * (q - self.q).length() + 4.0 * s;
        let moved = turn * self.lever + (dt.x + dt.y + dt.z) * (1.0 + 1e-5);
        s < UNIT && moved < self.room
    }

    /// Anchors a certificate that held at `q`, `t` with room `room` (rotation lever
    /// `lever`, `radii` the two bodies' radii); keeps the one it had when the pose is not
    /// one a later bound can be taken from or no room is left.
    #[inline]
    fn anchor(&mut self, (q, t, lever): (Quat, Vec3, f32), room: f32, radii: f32, ball: bool) {
        let s0 = (q.length_squared() - 1.0).abs();
        let room = room * SHRINK - (ALLOW * radii + 4.0 * s0 * lever);
        // (A `t` or `lever` not finite leaves a room or a later bound that fails.)
        if s0 < UNIT && room > 0.0 {
            *self = Certificate {
                q,
                t,
                lever,
                room,
                ball,
            };
        }
    }
}

/// Whether no axis of the full test separates the bodies at a remembered face contact `m`
/// (in the reference body's frame, reference face `rf` of `refp`; `to_inc`, `inc_rot` as
/// for [`wedge_certified`]): by the pair's remembered certificate `cert` when it holds at
/// the pose `q`, `t` (see [`Certificate`]), else by [`overlap_certified`] or
/// [`wedge_certified`] measured now, the one that held then anchored in `cert` at this pose
/// with the room it held with (`lever`: the rotation's lever at this pose, see
/// [`super::slack::FaceSlack`], for the ball's; `origin_b`: B's origin in the reference
/// frame, for the centroid's, see [`measure_centroid`]). Without a `cert`, the two
/// certificates alone.
///
/// On a resting cube pile the clip record's own certificate (measured where the record
/// was) is spent on about one served face in three: the bodies creep further than the
/// contact's depth while the record's planes still hold; anchored again where it is
/// measured, a certificate lasts for many steps more, and [`wedge_certified`]'s (about a
/// thousand instructions) is measured rarely (issue 23).
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn remembered_certified(
    cert: Option<&mut Certificate>,
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    to_inc: impl Fn(Vec3) -> Vec3,
    inc_rot: Mat3,
    m: &Manifold,
    delta: f32,
    (q, t, origin_b, lever): (Quat, Vec3, Vec3, impl Fn() -> f32),
) -> bool {
    let Some(cert) = cert else {
        return overlap_certified(refp, m, delta)
            || wedge_certified(refp, rf, inc, to_inc, inc_rot, m, delta);
    };
    if cert.holds(q, t) {
        if cert.ball {
            WEDGE_CERTIFIED.with(|n| n.set(n.get() + 1));
        }
        return true;
    }
    measure_centroid(cert, refp, inc.radius, m, delta, (q, t, origin_b))
        || measure_ball(
            cert,
            refp,
            rf,
            inc,
            to_inc,
            inc_rot,
            m,
            delta,
            (q, t, lever),
        )
}

/// The centroid's certificate ([`overlap_certified`]) measured for [`remembered_certified`],
/// anchored when it holds (`inc_radius`: the incident body's radius), with the lever of the
/// centroid alone: its distance from B's origin, `origin_b` in the reference frame (`t` for
/// A's face, 0 for B's), with a relative margin.
///
/// Why that lever: only the one point of the incident body at the centroid `c` needs to stay
/// inside (see [`Certificate`]), and it moves by `(M - M0) c_b + (t - t0)` for A's face (`c_b`
/// that point in B's frame, `|c_b| = |c - t0|` up to the `|s0 - 1|` of `M0`'s scale), or by
/// `(M - M0)^T (c_a - t0) - M^T (t - t0)` for B's face (`c_a` the point in A's frame, `c_a -
/// t0 = M0 c` up to the same): `|M - M0|` times `|c - origin_b|` bounds the turn's part as
/// the body's lever (its radius, or `r + |t0|`) does for every point. The margin (`1e-5`
/// relative) holds the scale (`4e-6` at most) and the rounding of the length. On a cube
/// pile the turn's part is most of the bound, and the centroid's lever about a half to a
/// third of the body's (B's face: `|c|` against `r_a + |t0|`).
#[inline(never)]
fn measure_centroid(
    cert: &mut Certificate,
    refp: &ConvexPolyhedron,
    inc_radius: f32,
    m: &Manifold,
    delta: f32,
    (q, t, origin_b): (Quat, Vec3, Vec3),
) -> bool {
    let c = incident_centroid(m);
    let room = overlap_room(refp, c) - delta;
    let holds = room >= 0.0;
    if holds {
        let lever = (c - origin_b).length() * (1.0 + 1e-5);
        cert.anchor((q, t, lever), room, refp.radius + inc_radius, false);
    }
    holds
}

/// The ball's certificate ([`wedge_certified`]) measured for [`remembered_certified`],
/// anchored when it holds.
#[allow(clippy::too_many_arguments)]
#[cold]
#[inline(never)]
fn measure_ball(
    cert: &mut Certificate,
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    to_inc: impl Fn(Vec3) -> Vec3,
    inc_rot: Mat3,
    m: &Manifold,
    delta: f32,
    (q, t, lever): (Quat, Vec3, impl Fn() -> f32),
) -> bool {
    let room = wedge_room(refp, rf, inc, to_inc, inc_rot, m, delta);
    let holds = room >= 0.0;
    if holds {
        WEDGE_CERTIFIED.with(|n| n.set(n.get() + 1));
        cert.anchor((q, t, lever()), room, refp.radius + inc.radius, true);
    }
    holds
}

/// Whether `c` is at least `delta` inside every face of `refp`, by each face's product
/// (the general case of [`overlap_certified`], and the reference of its box's case).
#[inline]
fn inside_every_face(refp: &ConvexPolyhedron, c: Vec3, delta: f32) -> bool {
    refp.faces
        .iter()
        .all(|f| f.normal.dot(c) - f.offset <= -delta)
}

/// How far the centroid of [`overlap_certified`] is inside every face plane of `refp`
/// (the smallest of `offset - normal . c`, by the same products; NaN when one is): the
/// certificate holds with `delta` up to this.
pub(super) fn overlap_slack(refp: &ConvexPolyhedron, m: &Manifold) -> f32 {
    slack_at(refp, incident_centroid(m))
}

/// [`overlap_slack`] for the centroid `c`.
fn slack_at(refp: &ConvexPolyhedron, c: Vec3) -> f32 {
    let mut low = f32::INFINITY;
    for f in &refp.faces {
        let s = f.offset - f.normal.dot(c);
        low = if s < low || s.is_nan() { s } else { low };
    }
    low
}

/// [`overlap_slack`] for the centroid `c` by [`overlap_certified`]'s expressions: for a box, each face's `c[axis]`
/// or `-c[axis]` without the products (the same values for a finite `c`: `offset -
/// (-x)` is `offset + x`; NaN for a `c` not finite, which fails as it does there), else
/// the products. The centroid certificate holds with `delta`
/// exactly when this is at least `delta`: `x - offset <= -delta` and `offset - x >= delta`
/// are the same comparison (a difference's rounding is symmetric).
#[inline]
fn overlap_room(refp: &ConvexPolyhedron, c: Vec3) -> f32 {
    let Some(of) = refp.face_axes else {
        return slack_at(refp, c);
    };
    let off = |code: usize| refp.faces[of[code] as usize].offset;
    let low = (off(0) - c.x).min(off(1) - c.y).min(off(2) - c.z);
    let high = (off(4) + c.x).min(off(5) + c.y).min(off(6) + c.z);
    // (`min` passes a NaN over: a `c` not finite is NaN, as in the products.)
    let room = low.min(high);
    if c.is_finite() { room } else { f32::NAN }
}

/// Whether the bodies certainly overlap by more than `delta` at a face contact `m` (in the
/// reference body's frame, reference face `rf` of `refp`) where [`overlap_certified`]
/// cannot tell: the incident body crossing a side of the reference face, its clipped points
/// on that side's plane, so that no ball about their centroid fits in the reference body.
/// `to_inc` maps a point of the reference frame into the incident body's frame, `inc_rot`
/// the incident body's directions into the reference frame.
///
/// Why: if a point `p` is at least `delta / 2` inside every face plane of both bodies, the
/// balls of radius `delta / 2` about `p` lie in both, so along any direction `u` the
/// incident body reaches below `u.p - delta / 2` and the reference body above `u.p +
/// delta / 2`: every axis's separation is at most `-delta`, as in [`overlap_certified`]
/// (whose point is in the incident body up to rounding and `delta` inside the reference
/// body), and with the same room for rounding none of the full test's separations is
/// positive. Every `p` tried is checked against every plane of both bodies, so any `p`
/// serves; those tried are where the overlap is widest near the points' centroid `c` (on
/// the incident face): the centre of the largest ball within the reference face's plane
/// and the three other face planes (of either body) nearest `c`, and, when that fails (the
/// four planes bound no small region, as at a wedge along the reference face's edge), the
/// centre of the largest disc within the reference face's plane and the two nearest, on the
/// plane through `c` across the reference face's plane and the nearest one. (A singular
/// system gives a NaN or an infinite `p`, which fails the checks.)
pub(super) fn wedge_certified(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    to_inc: impl Fn(Vec3) -> Vec3,
    inc_rot: Mat3,
    m: &Manifold,
    delta: f32,
) -> bool {
    let certified = wedge_room(refp, rf, inc, to_inc, inc_rot, m, delta) >= 0.0;
    if certified {
        WEDGE_CERTIFIED.with(|n| n.set(n.get() + 1));
    }
    certified
}

/// How much room [`wedge_certified`]'s point has: the smallest of its distances inside the
/// face planes of both bodies (`offset - normal . p`, each body's products) less `delta /
/// 2`, so that the certificate holds exactly when this is not negative (`x - offset <=
/// -delta / 2` and `offset - x >= delta / 2` are the same comparison); negative or NaN
/// when no point is tried or none holds.
fn wedge_room(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    to_inc: impl Fn(Vec3) -> Vec3,
    inc_rot: Mat3,
    m: &Manifold,
    delta: f32,
) -> f32 {
    // Clipped points on a side plane are crossings of the incident face's edges: one or two
    // (more are corners inside the face, where the first certificate failed for depth).
    if m.count > 2 {
        return f32::NEG_INFINITY;
    }
    let n = m.normal;
    let c = incident_centroid(m);
    // Shallower than `delta` along the reference normal: no ball fits (and NaN returns).
    let s1 = n.dot(c) - refp.faces[rf].offset;
    if s1.partial_cmp(&-delta) != Some(std::cmp::Ordering::Less) {
        return f32::NEG_INFINITY;
    }
    ball_room(refp, Some(rf), inc, to_inc, inc_rot, c, delta)
}

/// Whether a point at least `delta / 2` inside every face plane of both `refp` and `inc`
/// is found near `c` (in `refp`'s frame; `to_inc` maps a point of it into `inc`'s frame,
/// `inc_rot` `inc`'s directions into it), so that every axis's separation is at most
/// `-delta` (see [`wedge_certified`]). Every point tried is checked against every plane, so
/// the choice only decides how often one is found: the centre of the largest ball within
/// the four face planes (of either body) nearest `c`, face `first` of `refp` always among
/// them when given; and, when that fails, the centre of the largest disc within the three
/// nearest, on the plane through `c` across the two nearest. (A singular system gives a NaN
/// or an infinite point, which fails the checks.)
// Out of line and cold: reached by about one remembered face contact in fifteen (cube
// pile), so its code (two instances, one per frame map) stays out of
// `remembered_face`'s hot body and out of the instruction cache (issue 23).
//
// Returns the room of the first point tried that holds (see [`wedge_room`]), else of the
// last tried.
#[cold]
#[inline(never)]
fn ball_room(
    refp: &ConvexPolyhedron,
    first: Option<usize>,
    inc: &ConvexPolyhedron,
    to_inc: impl Fn(Vec3) -> Vec3,
    inc_rot: Mat3,
    c: Vec3,
    delta: f32,
) -> f32 {
    // The face planes nearest `c`, (separation, normal in `refp`'s frame), nearest first
    // (`first`'s ahead of all).
    let mut near = [(f32::NEG_INFINITY, Vec3::ZERO); 4];
    let mut take = |s: f32, normal: Vec3| {
        let mut k = 3;
        if s > near[k].0 {
            near[k] = (s, normal);
            while k > 0 && near[k].0 > near[k - 1].0 {
                near.swap(k, k - 1);
                k -= 1;
            }
        }
    };
    for (f, face) in refp.faces.iter().enumerate() {
        if Some(f) != first {
            take(face.normal.dot(c) - face.offset, face.normal);
        }
    }
    let c_inc = to_inc(c);
    for face in &inc.faces {
        take(face.normal.dot(c_inc) - face.offset, inc_rot * face.normal);
    }
    if let Some(f) = first {
        let face = refp.faces[f];
        near.copy_within(0..3, 1);
        near[0] = (face.normal.dot(c) - face.offset, face.normal);
    }
    let half = 0.5 * delta;
    // The smallest distance inside, by each face's product (a NaN kept).
    let room = |p: Vec3| {
        let p_inc = to_inc(p);
        let mut low = f32::INFINITY;
        let mut take = |s: f32| low = if s < low || s.is_nan() { s } else { low };
        refp.faces
            .iter()
            .for_each(|f| take(f.offset - f.normal.dot(p)));
        inc.faces
            .iter()
            .for_each(|f| take(f.offset - f.normal.dot(p_inc)));
        low - half
    };
    // `c + u` with `n_i.u + r = -s_i` (`r` inside each plane), and `e.u = 0` for the disc.
    let [(s1, n1), (s2, n2), (s3, n3), (s4, n4)] = near;
    let solve = |last: glam::Vec4, rhs: f32| {
        let rows =
            glam::Mat4::from_cols(n1.extend(1.0), n2.extend(1.0), n3.extend(1.0), last).transpose();
        c + (rows.inverse() * glam::Vec4::new(-s1, -s2, -s3, rhs)).truncate()
    };
    let ball = room(solve(n4.extend(1.0), -s4));
    if ball >= 0.0 {
        return ball;
    }
    room(solve(n1.cross(n2).extend(0.0), 0.0))
}

thread_local! {
    /// How many face contacts [`wedge_certified`] certified on this thread (for tests).
    static WEDGE_CERTIFIED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// How many remembered face contacts on this thread stood in for the full test by the
/// certificate of a contact crossing the reference face's side ([`wedge_certified`]), for
/// tests that check the path serves.
#[doc(hidden)]
pub fn wedge_certificates() -> usize {
    WEDGE_CERTIFIED.with(|n| n.get())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::narrow::ContactPoint;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The box's case of [`overlap_certified`] (and of [`overlap_room`]) against the products
    /// for every face: boxes
    /// (cubes and off-centre ones), manifolds of one to four points whose centroid falls
    /// inside, outside, exactly on a face plane `delta` in (and one ulp either side), at
    /// `±0`, or is infinite or NaN: the same answer every time, and both answers seen.
    #[test]
    fn box_overlap_certificate_is_the_products() {
        let mut r = ChaCha8Rng::seed_from_u64(25);
        let boxes: Vec<ConvexPolyhedron> = [Vec3::splat(0.01), Vec3::new(0.5, 0.2, 0.3)]
            .iter()
            .flat_map(|&h| [Vec3::ZERO, Vec3::new(0.1, -0.05, 0.02)].map(|o| (h, o)))
            .map(|(h, o)| {
                let v: Vec<Vec3> = (0..8)
                    .map(|k| {
                        let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                        Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z) + o
                    })
                    .collect();
                crate::convex_hull(&v).expect("box hull")
            })
            .collect();
        assert!(boxes.iter().all(|b| b.face_axes.is_some()));
        let odd = [0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        let mut seen = [0usize; 2];
        for i in 0..200_000 {
            let b = &boxes[i % boxes.len()];
            let delta = [0.0, 2e-5 * 2.0 * b.radius, 1e-3][r.random_range(0..3)];
            let h = b.faces.iter().map(|f| f.offset).fold(0.0f32, f32::max);
            let mut c = Vec3::ZERO;
            for k in 0..3 {
                c[k] = match r.random_range(0..6) {
                    0 => odd[r.random_range(0..odd.len())],
                    1 | 2 => {
                        // On a face plane `delta` in, or an ulp either side.
                        let f = &b.faces[r.random_range(0..6)];
                        let x = f.offset - delta;
                        let x = match r.random_range(0..3) {
                            0 => x,
                            1 => f32::from_bits(x.to_bits() + 1),
                            _ => f32::from_bits(x.to_bits().wrapping_sub(1)),
                        };
                        if f.normal[k] < 0.0 { -x } else { x }
                    }
                    _ => r.random_range(-1.5 * h..1.5 * h),
                };
            }
            let normal = [Vec3::X, Vec3::NEG_Z, Vec3::Y][r.random_range(0..3)];
            let count = r.random_range(1..=4);
            let mut m = Manifold {
                normal,
                count,
                ..Default::default()
            };
            for p in &mut m.points[..count] {
                let depth = [0.0, 1e-4, 3e-3][r.random_range(0..3)];
                *p = ContactPoint {
                    point: c + normal * (0.5 * depth),
                    depth,
                };
            }
            let want = inside_every_face(b, incident_centroid(&m), delta);
            assert_eq!(overlap_certified(b, &m, delta), want, "{c:?} {delta}");
            // The room the remembered certificate takes, by the same expressions.
            assert_eq!(
                overlap_room(b, incident_centroid(&m)) - delta >= 0.0,
                want,
                "{c:?} {delta}: room"
            );
            seen[want as usize] += 1;
        }
        assert!(seen[0] > 1000 && seen[1] > 1000, "{seen:?}");
    }
}

#[cfg(test)]
#[path = "certify_tests.rs"]
mod remembered_tests;

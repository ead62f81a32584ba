//! What a remembered face contact's clip remembers between steps ([`FaceSlack`]): which of
//! its work provably gives the same answer again while the bodies stay near where it was
//! measured, so that `sat::remembered_face` does less for the same manifold, bitwise.

use glam::{Quat, Vec3};

use super::Manifold;
use super::certify::{Certificate, overlap_slack};
use super::clip::incident_face;
use crate::ConvexPolyhedron;

/// How many side planes of the reference face a slack record can name (a box's face has 4).
const PLANES: usize = 8;

/// How many corners of the incident face a record's planes take (a box's face has 4).
const CORNERS: usize = 16;

/// Room for rounding, relative to the two bodies' radii: of the incident corners (at the
/// record and now), of the clip's crossings, of the side-plane distances and of the bound
/// itself, each a few ulps of coordinates at most about twice the radii (about `3e-6`
/// relative all together), with room to spare.
pub(super) const ALLOW: f32 = 1e-5;

/// What a remembered part's own limit keeps of it, a relative margin for its rounding.
pub(super) const SHRINK: f32 = 1.0 - 1e-6;

/// The smallest slack (relative to the radii) worth remembering: a plane or certificate
/// nearer than this is computed every call, and a record with nothing in it is measured
/// again once the bodies have moved this far.
const KEEP: f32 = 5e-5;

/// How far a quaternion's squared norm may be from 1 for the rotation bound below (the
/// simulation's orientations are renormalised every step; a relative rotation is a product
/// of two).
pub(super) const UNIT: f32 = 4e-6;

/// What a remembered face contact's clip remembers, measured at one call (a "record"):
/// the contact's reference face and incident body, their relative pose, and what is sure
/// to come out the same at any pose whose incident points have moved less than `renew`
/// (in the reference body's frame, rounding allowed for):
/// - `inc_face`: the incident face, when the smallest `normal . n_inc` led the next by
///   more than twice what the rotation since can change each product: the same face is the
///   first minimum again ([`NO_FACE`]: computed every call).
/// - `skip`: the side planes of the reference face that every corner of the incident face
///   (the one remembered: none without it) was inside by more than `renew`. Every point of
///   the polygon a later clip hands to such a plane (a corner, or a crossing of earlier
///   planes, in the incident face up to rounding) is then still strictly inside, so
///   `clip_by_plane` would keep the polygon as it is and copy nothing: skipping it changes
///   no bit.
/// - `certified`: the centroid certificate of [`super::certify::overlap_certified`] held
///   with room `renew` to spare. The centroid `c` measured is a point of the incident body
///   (up to rounding); the same body point now is at most `renew` less deep in the
///   reference body, so still `delta` inside every face plane: the certificate's own
///   argument (a point of the incident body with a ball of radius `delta` about it in the
///   reference body) holds for it, and no axis of the full test separates the bodies. The
///   certificate only decides whether the full test must run, never the manifold.
///
/// How far the incident body's points moved: the clip puts B's vertex `v` at `M v + t` in
/// A's frame (a reference face of A), A's at `M^T (v - t)` in B's (of B), with `M` glam's
/// `from_quat` of the relative quaternion `q` and `t` B's offset in A's frame. A point moves
/// by `|(M - M0) v + (t - t0)| <= |M - M0| r + |t - t0|` for A's frame (`r` B's radius),
/// and by `|(M - M0)^T (v - t0) - M^T (t - t0)| <= |M - M0| (r + |t0|) + |M| |t - t0|`
/// for B's (`r` A's radius): `lever` is `r`, or `r + |t0|`. For `|q|^2 = s`, `from_quat`
/// is `I + s (R - I)` with `R` the rotation of `q / |q|`, within `2 |s - 1|` of it; two
/// rotations of unit quaternions `p`, `p0` differ by at most `2 sin(phi / 2) <= 2 |p - p0|`
/// (`phi` the angle between them, `|p - p0| = 2 |sin(phi / 4)|`), and `|q / |q| - q| <= |s -
/// 1|`: so `|M - M0| <= 2 |q - q0| + 4 |s - 1| + 4 |s0 - 1|` (a few ulps more for the
/// rounded entries), and `|M| <= 1 + 2 |s - 1|`. The record keeps `renew` less the `s0`
/// term and [`ALLOW`]; the 1-norm bounds `|t - t0|`. A record names its polyhedra by
/// address, like [`super::EdgeMemory`], and checks the pose itself, so it serves any pair
/// of those shapes at a nearby pose: a cache that changes no result (in no checkpoint; a
/// fresh one measures again).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct FaceSlack {
    /// The relative quaternion `Relative::q` (B's rotation in A's frame) at the record.
    q: Quat,
    /// The addresses of the reference body's and the incident body's polyhedra (0: none).
    shapes: [usize; 2],
    /// B's offset in A's frame (`Relative::t`) at the record.
    t: Vec3,
    /// The reference face's kind and index (`HINT_FACE_A`/`HINT_FACE_B` | face).
    key: u32,
    /// How far the incident points may move before this record expires, less the
    /// rounding allowed and the record's own rotation term (see above).
    renew: f32,
    /// The lever of the rotation (see above).
    lever: f32,
    /// The incident face, or [`NO_FACE`].
    inc_face: u8,
    /// The side planes skipped, a bit per plane of the reference face's loop.
    skip: u8,
    /// How far the incident points may move (the same terms taken off) while the overlap
    /// certificate stands: negative when it is not remembered. Apart from `renew`, so that
    /// a shallow contact's small room does not make the planes be measured again.
    certified: f32,
    /// A certificate anchored at a later pose ([`Certificate`]): forgotten with the record,
    /// so it serves only this record's reference face and shapes.
    cert: Certificate,
}

/// No incident face remembered.
const NO_FACE: u8 = u8::MAX;

impl Default for FaceSlack {
    fn default() -> Self {
        FaceSlack {
            q: Quat::IDENTITY,
            shapes: [0; 2],
            t: Vec3::ZERO,
            key: 0,
            renew: f32::NEG_INFINITY,
            lever: 0.0,
            inc_face: NO_FACE,
            skip: 0,
            certified: f32::NEG_INFINITY,
            cert: Certificate::default(),
        }
    }
}

/// What one clip of a remembered face may take from its record ([`FaceSlack::plan`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Plan {
    /// The incident face, if known.
    pub(super) inc_face: Option<usize>,
    /// The side planes to skip (bit `k`: plane `k` of the reference face's loop).
    pub(super) skip: u8,
    /// Whether the overlap is certified.
    pub(super) certified: bool,
    /// Whether the call should measure a new record ([`FaceSlack::record`]).
    pub(super) measure: bool,
    /// Whether each side plane clipped first looks for a corner outside it, to keep the
    /// polygon uncopied when there is none (`clip_by_plane`'s scan). Off when a record
    /// serves: its planes not skipped are those some corner came within `renew` of, and
    /// nearly all of them cut (a resting cube pile: 96%), so the scan is mostly wasted.
    /// Either way the same polygon, bitwise: a plane with no corner outside copies every
    /// corner, in order, and adds no crossing.
    pub(super) scan: bool,
}

impl Plan {
    /// Nothing known: the whole clip, no record.
    pub(super) const FULL: Plan = Plan {
        inc_face: None,
        skip: 0,
        certified: false,
        measure: false,
        scan: true,
    };
    /// Nothing known: the whole clip, then a record.
    const MEASURE: Plan = Plan {
        measure: true,
        ..Plan::FULL
    };
}

/// The identity of a polyhedron as a record names it.
#[inline]
fn address(p: &ConvexPolyhedron) -> usize {
    p as *const ConvexPolyhedron as usize
}

impl FaceSlack {
    /// The certificate anchored with this record (see [`Certificate`]).
    #[inline]
    pub(super) fn certificate(&mut self) -> &mut Certificate {
        &mut self.cert
    }

    /// What a clip of reference face `key` (kind | index) of `refp` against `inc`, at
    /// relative quaternion `q` and offset `t` (see [`FaceSlack`]), may take from this
    /// record: all of it while the incident points moved less than `renew`; else nothing,
    /// and a new record is to be measured.
    #[inline]
    pub(super) fn plan(
        &self,
        refp: &ConvexPolyhedron,
        inc: &ConvexPolyhedron,
        key: u32,
        q: Quat,
        t: Vec3,
    ) -> Plan {
        self.plan_at(refp, inc, key, q, t, unit_error(q))
    }

    /// [`FaceSlack::plan`] with `s = unit_error(q)` computed by the caller (once for the
    /// pair's anchor and the record: the same float).
    #[inline]
    pub(super) fn plan_at(
        &self,
        refp: &ConvexPolyhedron,
        inc: &ConvexPolyhedron,
        key: u32,
        q: Quat,
        t: Vec3,
        s: f32,
    ) -> Plan {
        if self.key != key || self.shapes != [address(refp), address(inc)] {
            return Plan::MEASURE;
        }
        let moved = moved_by(self.q, self.t, self.lever, q, t, s);
        // (Written so that a NaN measures again.)
        if s < UNIT && moved < self.renew {
            Plan {
                inc_face: (self.inc_face != NO_FACE).then_some(self.inc_face as usize),
                skip: self.skip,
                certified: moved < self.certified,
                measure: false,
                scan: false,
            }
        } else {
            Plan::MEASURE
        }
    }

    /// Measures a record for reference face `rf` (`key`: kind | index) of `refp` against
    /// `inc`, at relative quaternion `q` and offset `t` with rotation lever `lever` (see
    /// [`FaceSlack`]): `n_inc` the reference
    /// normal in `inc`'s frame, `inc_v(i)` vertex `i` of `inc` in `refp`'s frame (both as
    /// the clip computed them), `m` the clip's manifold in `refp`'s frame, `delta` the
    /// certificate's depth. Forgets what it held first; keeps nothing when the pose is
    /// not one a later bound can be taken from.
    #[allow(clippy::too_many_arguments)]
    #[cold]
    #[inline(never)]
    pub(super) fn record(
        &mut self,
        refp: &ConvexPolyhedron,
        rf: usize,
        inc: &ConvexPolyhedron,
        key: u32,
        q: Quat,
        t: Vec3,
        lever: f32,
        n_inc: Vec3,
        inc_v: impl Fn(usize) -> Vec3,
        m: &Manifold,
        delta: f32,
    ) {
        *self = FaceSlack::default();
        let s0 = (q.length_squared() - 1.0).abs();
        let usable = s0 < UNIT && t.is_finite() && n_inc.is_finite() && lever.is_finite();
        if !usable {
            return;
        }
        let radii = refp.radius + inc.radius;
        let keep = KEEP * radii;
        // Each remembered part's own limit, less a relative margin for its rounding.
        let shrink = 1.0 - 1e-6;
        let mut renew = f32::INFINITY;
        // The incident face: the loop's first minimum and the gap to the next value (a tie
        // gives no gap). Each product moves by at most `|M - M0|` (unit normals) plus a
        // few ulps, and `|M - M0| r <= ` the bound, so the first minimum stays while the
        // bound is below `lever (gap / 2 - 4e-6)`.
        let chosen = incident_face(inc, n_inc);
        let (mut best, mut next, mut first) = (f32::INFINITY, f32::INFINITY, 0);
        for (f, face) in inc.faces.iter().enumerate() {
            let d = face.normal.dot(n_inc);
            if d < best {
                next = best;
                best = d;
                first = f;
            } else if d < next {
                next = d;
            }
        }
        let limit = lever * (0.5 * (next - best) - 4e-6) * shrink;
        if first == chosen && chosen < NO_FACE as usize && limit >= keep {
            self.inc_face = chosen as u8;
            renew = renew.min(limit);
        }
        // The side planes every incident corner is inside by more than `keep`, by their
        // distance (the plane's vector is not a unit vector); only with the incident face
        // remembered (the corners are that face's).
        let il = inc.face_loop(chosen);
        let mut corners = [Vec3::ZERO; CORNERS];
        let planes = if self.inc_face == NO_FACE || il.len() > CORNERS {
            0
        } else {
            PLANES
        };
        for (c, &i) in corners.iter_mut().zip(il) {
            *c = inc_v(i as usize);
        }
        let corners = &corners[..il.len().min(CORNERS)];
        for (k, &(side, off)) in refp.side_planes(rf).iter().enumerate().take(planes) {
            let mut far = f32::NEG_INFINITY;
            for &c in corners {
                let d = side.dot(c) - off;
                // (A NaN keeps the plane out.)
                far = if d > far || d.is_nan() { d } else { far };
            }
            let slack = -far / side.length() * shrink;
            if slack >= keep {
                self.skip |= 1 << k;
                renew = renew.min(slack);
            }
        }
        // The certificate's room.
        let room = (overlap_slack(refp, m) - delta) * shrink;
        let taken = ALLOW * radii + 4.0 * s0 * lever;
        if room >= keep {
            self.certified = room - taken;
        }
        let renew = if renew.is_finite() { renew } else { keep };
        self.renew = renew - taken;
        self.lever = lever;
        self.q = q;
        self.t = t;
        self.key = key;
        self.shapes = [address(refp), address(inc)];
    }
}

/// How far the points of the incident body can have moved from relative pose `(q0, t0)`
/// to `(q, t)`, in the reference body's frame, with rotation lever `lever` (see
/// [`FaceSlack`]): the bound without the `s0` term and the rounding allowance, which the
/// caller takes off once at the record (`4 |s0 - 1| lever` and [`ALLOW`] of the radii).
/// Valid only while `|s - 1|` stays below [`UNIT`]; `s` here is `|s - 1|` for `s = |q|^2`
/// ([`unit_error`] of `q`), which the caller computes once per pair and pose for both the
/// pair's anchor and the clip record (issue 23, face37: the same float, computed once).
#[inline(always)]
fn moved_by(q0: Quat, t0: Vec3, lever: f32, q: Quat, t: Vec3, s: f32) -> f32 {
    let dt = (t - t0).abs();
    let turn = 2.0 * (q - q0).length() + 4.0 * s;
    turn * lever + (dt.x + dt.y + dt.z) * (1.0 + 1e-5)
}

/// `|s - 1|` for `s = |q|^2` (see [`FaceSlack`]): how far `q` is from a unit quaternion.
#[inline(always)]
pub(super) fn unit_error(q: Quat) -> f32 {
    (q.length_squared() - 1.0).abs()
}

/// The relative pose of a touching polyhedron pair at its last full separating-axis test
/// (an "anchor"), from which [`Anchor::moved`] bounds how much any separation the test
/// decided on can have changed since: by [`FaceSlack`]'s argument, every point of B moved
/// by at most `|M - M0| r_b + |t - t0|` in A's frame, and every point of A by at most
/// `|M - M0| (r_a + |t0|) + |M| |t - t0|` in B's, with `|M - M0| <= 2 |q - q0| + 4 |s - 1| +
/// 4 |s0 - 1|` (plus a few ulps of the rounded entries, in [`ALLOW`]). A face axis's
/// separation is the smallest projection of the other body's points on a normal fixed in
/// its body's frame, and the largest separation along any direction (which bounds the edge
/// axes, see `sat::contact_margin`) moves no more than the points do: so every separation
/// moves by at most the larger of the two, with the lever `max(r_b, r_a + |t0|)`. Unlike a
/// sum of per-step bounds, this does not grow while the bodies jitter in place: a resting
/// contact is served until the bodies have really moved (issue 23, anchor36).
#[derive(Clone, Copy, Debug)]
pub(super) struct Anchor {
    /// The relative quaternion `Relative::q` at the full test.
    q: Quat,
    /// B's offset in A's frame at the full test.
    t: Vec3,
    /// The rotation lever `max(r_b, r_a + |t0|)` (rounded up).
    lever: f32,
    /// The terms taken off once, `ALLOW (r_a + r_b) + 4 |s0 - 1| lever` (infinite: no
    /// anchor). The WGSL twin computes them at each use from the same floats by the same
    /// expression (the same bits), to keep two words fewer per pair.
    taken: f32,
}

impl Anchor {
    /// No anchor: [`Anchor::moved`] is infinite.
    pub(super) const NONE: Anchor = Anchor {
        q: Quat::IDENTITY,
        t: Vec3::ZERO,
        lever: -1.0,
        taken: f32::INFINITY,
    };

    /// The anchor of a full test of `a` against `b` at relative quaternion `q` and offset
    /// `t` ([`Anchor::NONE`] when the pose is not one a later bound can be taken from; WGSL
    /// twin `nrw_anchor_at`, narrow_poly.wgsl, which leaves that check to each use).
    #[inline]
    pub(super) fn at(a: &ConvexPolyhedron, b: &ConvexPolyhedron, q: Quat, t: Vec3) -> Anchor {
        let lever = b.radius.max(a.radius + t.length() * (1.0 + 1e-6));
        let s0 = (q.length_squared() - 1.0).abs();
        if !(s0 < UNIT && lever >= 0.0) {
            return Anchor::NONE;
        }
        let taken = ALLOW * (a.radius + b.radius) + 4.0 * s0 * lever;
        Anchor { q, t, lever, taken }
    }

    /// An upper bound of how much any separation of the full test at the anchor can have
    /// changed at relative quaternion `q` and offset `t` (see [`Anchor`]): the motion bound
    /// of [`moved_by`] and the terms taken off once; infinite when none is known (no
    /// anchor, or not a unit quaternion). WGSL twin `nrw_anchor_moved` (narrow_poly.wgsl):
    /// the same operations in the same order.
    #[inline]
    pub(super) fn moved(&self, q: Quat, t: Vec3) -> f32 {
        self.moved_at(q, t, unit_error(q))
    }

    /// [`Anchor::moved`] with `s = unit_error(q)` computed by the caller.
    #[inline]
    pub(super) fn moved_at(&self, q: Quat, t: Vec3, s: f32) -> f32 {
        let moved = moved_by(self.q, self.t, self.lever, q, t, s);
        // (Written so that a NaN gives no bound.)
        if s < UNIT {
            moved + self.taken
        } else {
            f32::INFINITY
        }
    }

    /// The pose anchored, if any (for tests and statistics).
    pub(super) fn pose(&self) -> Option<(Quat, Vec3)> {
        self.taken.is_finite().then_some((self.q, self.t))
    }
}

#[cfg(test)]
#[path = "slack_tests.rs"]
mod tests;

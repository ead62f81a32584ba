//! The separating-axis test of two convex polyhedra: face axes of both bodies, then the
//! edge-edge axes ([`super::edges`]), then the manifold by clipping ([`super::clip`]); the
//! projections of the vertices on the axes in packed lanes ([`super::lanes`]).

use glam::{Mat3, Mat3A, Quat, Vec3, Vec3A};

use super::certify::remembered_certified;
use super::clip::{ClipBuffers, clip_faces_into, segment_closest, slack_clip, to_world};
use super::edges::{GaussTables, edge_axes_by_direction, edge_axes_gauss_map};
use super::lanes::SoaPoints;
use super::memory::EdgeMemory;
use super::slack::{Anchor, FaceSlack, Plan, unit_error};
use super::{
    HINT_CONTACT, HINT_EDGE, HINT_EDGE_CONTACT, HINT_FACE_A, HINT_FACE_B, HINT_KIND, Manifold,
    NO_HINT, SatHint, is_contact_hint,
};
use crate::{ConvexPolyhedron, Pose};

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
    let mut found = None;
    polyhedron_pair(a, pa, b, pb, hint, bound, None, &mut found);
    found
}

/// [`polyhedron_polyhedron`] with the pair's [`EdgeMemory`], if it has one: the same
/// answer, bitwise, with fewer edge pairs visited while the memory holds, written to
/// `found` (whatever it held before).
///
/// Into the caller's `found`, not returned: a served contact is written where the caller
/// reads it (the contacts stage's pair loop), where the returned `Option<Manifold>` was
/// copied out of this function's frame on every call (issue 23, pp38).
#[allow(clippy::too_many_arguments)]
pub(super) fn polyhedron_pair(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    pb: &Pose,
    hint: &mut SatHint,
    bound: &mut f32,
    mut memory: Option<&mut EdgeMemory>,
    found: &mut Option<Manifold>,
) {
    let stored = *bound;
    *bound = 0.0;
    let d = pb.position - pa.position;
    let rs = a.radius + b.radius;
    let d2 = d.length_squared();
    if d2 >= rs * rs {
        if is_contact_hint(*hint) {
            *hint = NO_HINT;
        }
        *bound = d2.sqrt() - rs;
        *found = None;
        return;
    }
    // Everything in A's frame: B's rotation and offset relative to A.
    let inv_a = pa.rotation.conjugate();
    let rot_q = inv_a * pb.rotation;
    let rot = glam::Mat3::from_quat(rot_q);
    let inv_rot = rot.transpose();
    let t = inv_a * d;
    let rel = Relative {
        rot,
        t,
        q: rot_q,
        s: unit_error(rot_q),
    };
    // An edge search already made at these poses, if any (see `remembered_edge`).
    let mut searched = None;
    // A face already clipped at these poses, if any (see `remembered_face`).
    let mut clipped = None;
    // What of the scratch `remembered_edge` already filled at these poses (see `Prepared`).
    let mut prepared = Prepared::Nothing;
    if is_contact_hint(*hint) {
        // The margin left of a remembered contact: with an edge memory, the stored margin
        // of the full test less twice how much any separation can have changed since its
        // pose (see `Anchor`; none anchored: the full test runs), and the stored margin is
        // kept; without, the caller has taken the motion off step by step (see
        // `super::collide_with_hint`), and what is left is kept. (Computed here, under the
        // one test of the hint: the margin serves only a remembered contact.)
        let margin = match memory.as_deref() {
            Some(m) => stored - 2.0 * m.anchor().moved_at(rot_q, t, rel.s),
            None => stored,
        };
        let face = *hint & !(HINT_KIND | HINT_CONTACT);
        if face == EDGE_CONTACT {
            // The full edge search again, without the face axes; when it fails, its answer
            // (if it is the search's without a floor) serves the full test below.
            // Served: written by `remembered_edge` straight into the caller's `found` (no
            // copy through a `Result`, as for `remembered_face`), with the margin kept.
            // (The answer taken apart in the closure: matched after it, the whole `Result`
            // was copied twice on every call, served or not.)
            let out = found.insert(Manifold::default());
            let served = SCRATCH.with_borrow_mut(|sc| {
                let memory = memory.as_deref_mut();
                let prepared = &mut prepared;
                match remembered_edge(a, pa, b, &rel, sc, margin, memory, prepared, out) {
                    Ok(()) => true,
                    Err(e) => {
                        searched = e;
                        false
                    }
                }
            });
            if served {
                *bound = stored;
                return;
            }
        } else if margin + 2.0 * reference_separation(a, b, &rel, *hint & HINT_KIND, face) > 0.0 {
            // The full test would choose the remembered face again (see `contact_margin`):
            // clip it alone. When the overlap is not certified, the clipped face serves the
            // full test below.
            // Served: written by `remembered_face` straight into the caller's `found` (no
            // copy through a `Result`), with the margin kept.
            let slack = memory.as_deref_mut().map(EdgeMemory::face_slack);
            let kind = *hint & HINT_KIND;
            let out = found.insert(Manifold::default());
            let face = face as usize;
            let served = SCRATCH.with_borrow_mut(|sc| {
                remembered_face(a, pa, b, pb, &rel, sc, kind, face, slack, out)
            });
            match served {
                Served::Yes => {
                    *bound = stored;
                    return;
                }
                Served::Unsure => clipped = Some((kind, face, *out)),
                Served::NoClip => {}
            }
        }
        *hint = NO_HINT;
    }
    // The axis that separated this pair last step, if any, tested on support points in each
    // body's own frame (no vertex transformed).
    if *hint != NO_HINT {
        let idx = (*hint & !HINT_KIND) as usize;
        let min_along = |p: &ConvexPolyhedron, dir: Vec3| p.smallest_projection(dir);
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
            *found = None;
            return;
        }
    }
    *found = SCRATCH.with_borrow_mut(|sc| {
        let full = FullTest {
            searched,
            memory,
            clipped,
            prepared,
        };
        sat_full(a, pa, b, pb, &rel, sc, full, hint, bound)
    });
}

/// B's rotation and offset in A's frame.
///
/// Without its transpose (see [`Relative::inv_rot`]): the served paths read it from here,
/// and storing it with the rest cost more than transposing on the read (issue 23, pp38).
struct Relative {
    rot: Mat3,
    t: Vec3,
    /// `rot` as the quaternion it was built from.
    q: Quat,
    /// `slack::unit_error(q)`, for the motion bounds since an anchor or a clip record.
    s: f32,
}

impl Relative {
    /// `rot`'s transpose, its inverse: A's rotation and offset in B's frame are
    /// `inv_rot` and `-(inv_rot * t)`.
    #[inline(always)]
    fn inv_rot(&self) -> Mat3 {
        self.rot.transpose()
    }
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
    /// B's vertices in A's frame (`bv`), and B's points as lanes (`b_soa`; A's are the
    /// shape's own), by [`moved_points`].
    Lanes,
}

/// B's points in A's frame (`rel`), as lanes (`b_soa`) and as vertices (`bv`): moved lane
/// by lane from B's own lanes, then laid back out as points. The same floats as moving
/// each vertex, `rel.rot * v + rel.t`, and laying those out (`SoaPoints::fill`): see
/// `SoaPoints::fill_moved` and `SoaPoints::points_into`. Moving the points one by one
/// (`Vec::extend`, ~215 instructions a cube) and then laying them out cost the cube pile's
/// step 1.4% more instructions (issue 23, edge38).
#[inline(always)]
fn moved_points(b: &ConvexPolyhedron, rel: &Relative, bv: &mut Vec<Vec3>, b_soa: &mut SoaPoints) {
    b_soa.fill_moved(b.lanes(), rel.rot, rel.t);
    b_soa.points_into(bv, b.vertices.len());
}

/// A reference face clipped by [`remembered_face`] whose overlap was not certified: its
/// kind ([`HINT_FACE_A`] or [`HINT_FACE_B`]), its index and the manifold in its body's
/// frame, before [`to_world`]. [`sat_full`] takes it when it chooses that face: the same
/// call of [`clip_faces`] with the same arguments (the incident vertices by the same
/// expressions), so the same manifold, bitwise.
type Clipped = (u32, usize, Manifold);

/// What [`remembered_face`] made of a remembered face: the answer is in its `out`
/// ([`Served::Yes`]: in the world frame; [`Served::Unsure`]: in the reference body's frame,
/// for [`Clipped`]), or there is none.
///
/// A word, not the manifold: returned through `SCRATCH`'s closure, a `Result` carrying a
/// [`Clipped`] was copied twice on every call (issue 23, face37: ~30 instructions a served
/// face, callgrind), though only the rare unsure calls need it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Served {
    /// Served: `out` holds the manifold as the full test would return it.
    Yes,
    /// The overlap is not certain enough to rule out a separating axis (the full test must
    /// run): `out` holds the clipped face in its body's frame, before [`to_world`].
    Unsure,
    /// No manifold (a face index out of range, or no contact in the clip): the full test
    /// must run.
    NoClip,
}

/// The remembered reference face `face` (of A for `kind` [`HINT_FACE_A`], else of B)
/// clipped with the full test's own expressions ([`sat_full`]): [`Served::Yes`] with the
/// manifold as the full test would return it written into `out`, or, when the overlap is
/// not certain enough to rule out a separating axis (the clip record's certificate, else
/// [`remembered_certified`]: one anchored at an earlier pose or measured now; the full test
/// must run), [`Served::Unsure`] with the clipped face in `out` (for the full test, if it
/// chooses that face: [`Clipped`]), or [`Served::NoClip`] when there is none.
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
    mut slack: Option<&mut FaceSlack>,
    out: &mut Manifold,
) -> Served {
    let Relative {
        rot, t, q, s: unit, ..
    } = *rel;
    // (`rel.inv_rot()` taken where it is used: transposed here, at the entry, it was made
    // and spilled for A's faces too, which need it only for a certificate.)
    let Scratch { clip, .. } = sc;
    let delta = 2e-5 * (a.radius + b.radius);
    // The incident corners by glam's `Mat3A * Vec3A`: the columns scaled and summed lane by
    // lane in `Mat3 * Vec3`'s order (`(x_axis x + y_axis y) + z_axis z`), then `t` added or
    // taken lane by lane: the same floats as `rot * v + t` and `inv_rot * (v - t)`.
    let t_a = Vec3A::from(t);
    let key = kind | face as u32;
    if kind == HINT_FACE_A {
        if face >= a.faces.len() {
            return Served::NoClip;
        }
        let plan = slack
            .as_deref()
            .map_or(Plan::FULL, |s| s.plan_at(a, b, key, q, t, unit));
        let rot_a = Mat3A::from(rot);
        let inc_v = |i: usize| Vec3::from(rot_a * Vec3A::from(b.vertices[i]) + t_a);
        if !clip_faces_into(a, face, b, inc_v, rot, clip, &plan, out) {
            return Served::NoClip;
        }
        let m = out;
        if let Some(s) = slack.as_deref_mut().filter(|_| plan.measure) {
            let n_inc = rot.transpose() * a.faces[face].normal;
            s.record(a, face, b, key, q, t, b.radius, n_inc, inc_v, m, delta);
        }
        let to_b = |p: Vec3| rel.inv_rot() * (p - t);
        let cert = slack.map(FaceSlack::certificate);
        let pose = (q, t, t, || b.radius);
        if plan.certified || remembered_certified(cert, a, face, b, to_b, rot, m, delta, pose) {
            to_world(m, pa, false);
            Served::Yes
        } else {
            Served::Unsure
        }
    } else {
        if face >= b.faces.len() {
            return Served::NoClip;
        }
        let plan = slack
            .as_deref()
            .map_or(Plan::FULL, |s| s.plan_at(b, a, key, q, t, unit));
        let inv_rot = rel.inv_rot();
        let inv_rot_a = Mat3A::from(inv_rot);
        let inc_v = |i: usize| Vec3::from(inv_rot_a * (Vec3A::from(a.vertices[i]) - t_a));
        if !clip_faces_into(b, face, a, inc_v, inv_rot, clip, &plan, out) {
            return Served::NoClip;
        }
        let m = out;
        let lever = || a.radius + t.length() * (1.0 + 1e-6);
        if let Some(s) = slack.as_deref_mut().filter(|_| plan.measure) {
            let n_inc = inv_rot.transpose() * b.faces[face].normal;
            s.record(b, face, a, key, q, t, lever(), n_inc, inc_v, m, delta);
        }
        let to_a = |p: Vec3| rot * p + t;
        let cert = slack.map(FaceSlack::certificate);
        let pose = (q, t, Vec3::ZERO, lever);
        if plan.certified || remembered_certified(cert, b, face, a, to_a, inv_rot, m, delta, pose) {
            to_world(m, pb, true);
            Served::Yes
        } else {
            Served::Unsure
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
    let smallest = |p: &ConvexPolyhedron, n: Vec3| p.smallest_projection(n);
    if kind == HINT_FACE_A {
        let Some(f) = a.faces.get(face) else {
            return f32::NAN;
        };
        smallest(b, rel.inv_rot() * f.normal) + f.normal.dot(rel.t) - f.offset
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
/// `prepared` receives what of the scratch it filled at these poses (for [`sat_full`]);
/// `out` (a default manifold) the manifold when it serves.
#[allow(clippy::too_many_arguments)]
// Out of line, as `remembered_face` is: inlined into `SCRATCH`'s closure, the closure took
// the thread-local access out of line with it (`LocalKey::with`, its accessor called
// through a pointer, every capture passed through memory; issue 23, pp38).
#[inline(never)]
fn remembered_edge(
    a: &ConvexPolyhedron,
    pa: &Pose,
    b: &ConvexPolyhedron,
    rel: &Relative,
    sc: &mut Scratch,
    margin: f32,
    memory: Option<&mut EdgeMemory>,
    prepared: &mut Prepared,
    out: &mut Manifold,
) -> Result<(), Option<EdgeFound>> {
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
    moved_points(b, rel, bv, b_soa);
    *prepared = Prepared::Lanes;
    let by_direction = edges_by_direction(a, b);
    // The pair stores twice the room (see above): the edge serves while `best_e + half > 0`.
    let half = 0.5 * margin;
    // Axes at or below `-half` fail the test below whether they win or not: left out.
    let search = (tables, by_direction);
    let found = edge_search(a, b, rel, bv, a_local, b_soa, search, -half, memory);
    let exact = exact_search(&found, -half);
    let keep = |found: EdgeFound| if exact { Some(found) } else { None };
    let best_e = found.map_err(|e| keep(Err(e)))?;
    // (Written so that a NaN fails the test too.)
    if (best_e.0 + half).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(keep(Ok(best_e)));
    }
    edge_manifold_into(a, b, pa, bv, best_e, out);
    Ok(())
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
/// pair: `by_direction`, [`edges_by_direction`] of `a` and `b`, which the callers have at
/// hand), or `Err((hint, separation))` when an edge axis separates the bodies.
///
/// `floor` (not positive) is a level the caller does not care below: axes whose separation
/// is at most `floor` may be left out unevaluated (see [`edge_axes_by_direction`]). When
/// the best axis is above `floor` it is returned exactly as with no floor (the same pair,
/// the first of equals, the same floats); else some axis at or below `floor` is.
#[allow(clippy::too_many_arguments)]
// Inlined into both callers: called from `remembered_edge`, its call and arguments cost
// the remembered edge search ~23 Ir per cube body-step (issue 23, pp38, callgrind).
#[inline(always)]
fn edge_search(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rel: &Relative,
    bv: &[Vec3],
    a_local: &SoaPoints,
    b_soa: &SoaPoints,
    (tables, by_direction): (&mut GaussTables, bool),
    floor: f32,
    memory: Option<&mut EdgeMemory>,
) -> Result<EdgeAxis, (SatHint, f32)> {
    let (mut hint, mut separation) = (NO_HINT, 0.0);
    let found = if by_direction {
        let memory = memory.map(|m| (m, rel.q, rel.t));
        edge_axes_by_direction(
            a,
            b,
            rel.rot,
            rel.t,
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
        let (rot, inv_rot) = (rel.rot, rel.inv_rot());
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
    let mut m = Manifold::default();
    edge_manifold_into(a, b, pa, bv, best_e, &mut m);
    m
}

/// [`edge_manifold`] written into `out`, a default manifold (its normal, count and first
/// point set as `Manifold::single` sets them: the same manifold, bitwise).
#[inline(always)]
fn edge_manifold_into(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    pa: &Pose,
    bv: &[Vec3],
    best_e: EdgeAxis,
    out: &mut Manifold,
) {
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
    out.normal = pa.rotation * axis;
    out.count = 1;
    out.points[0] = super::ContactPoint {
        point: pa.transform_point(mid),
        depth: -s,
    };
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
///   ([`remembered_certified`]): the bodies' overlap, not a decision's slack.
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
// Cold: about one pair in twelve of a cube pile's step reaches it (the rest are served
// by a remembered face or edge), so it is laid out away from the served paths (issue 23).
#[allow(clippy::too_many_arguments)]
#[cold]
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
    let Relative { rot, t, q, .. } = *rel;
    let inv_rot = rel.inv_rot();
    let FullTest {
        searched,
        mut memory,
        clipped,
        prepared,
    } = full;
    // (As in `remembered_edge`: the same floats.)
    if prepared == Prepared::Nothing {
        moved_points(b, rel, bv, b_soa);
    }
    let bv: &[Vec3] = bv;
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
    let found = match searched {
        Some(found) => found,
        None => edge_search(
            a,
            b,
            rel,
            bv,
            a_local,
            b_soa,
            (tables, edges_by_direction(a, b)),
            face_best,
            memory.as_deref_mut(),
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
        if let Some(m) = memory {
            m.set_anchor(Anchor::at(a, b, q, t));
        }
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
    let clipped = match clipped {
        Some((k, f, m)) if k == kind && f == face => Some(m),
        _ => None,
    };
    // Else clipped here, with what the pair's record of this face's clip lets it skip
    // (see `slack_clip`).
    let slack = memory.as_deref_mut().map(EdgeMemory::face_slack);
    let m = if ref_b {
        // Reference face on B: work in B's frame with A as incident.
        let inc_v = |i: usize| inv_rot * (a.vertices[i] - t);
        let lever = || a.radius + t.length() * (1.0 + 1e-6);
        clipped
            .or_else(|| {
                let n_inc = || inv_rot.transpose() * b.faces[face].normal;
                let pose = (kind, face, q, t, inv_rot);
                slack_clip(b, a, pose, inc_v, (lever, n_inc), clip, slack)
            })
            .map(|mut m| {
                to_world(&mut m, pb, true);
                m
            })
    } else {
        let lever = || b.radius;
        clipped
            .or_else(|| {
                let n_inc = || rot.transpose() * a.faces[face].normal;
                let pose = (kind, face, q, t, rot);
                slack_clip(a, b, pose, |i| bv[i], (lever, n_inc), clip, slack)
            })
            .map(|mut m| {
                to_world(&mut m, pa, false);
                m
            })
    };
    if m.is_some() && margin + 2.0 * best > 0.0 && face < EDGE_CONTACT as usize {
        *hint = kind | HINT_CONTACT | face as u32;
        *separation = margin;
        if let Some(m) = memory {
            m.set_anchor(Anchor::at(a, b, q, t));
        }
    }
    m
}

/// The best edge-edge axis `(separation, edge of A, edge of B, axis in A's frame)`, or `None`
/// when an edge axis separates the bodies (recorded in `hint`).
pub(super) type EdgeAxis = (f32, usize, usize, Vec3);

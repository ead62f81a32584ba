//! The narrow phase of one body pair with what the pair remembers (its separating-axis
//! hint, its separation bound or contact margin, its edge memory), and the bound of how
//! far any axis's separation can move in a step that the margins are spent by: the
//! contacts stage's pair loops ([`super::contacts`]) call it for every pair not skipped
//! as apart. (Split from `contacts.rs`, which passed 900 lines.)

use glam::{Quat, Vec3};

use super::motion::BodyBound;
use crate::contact_list::piece_ids;
use crate::contract::TURN_ROUNDING;
use crate::precise::PositionPairs;
use crate::world::World;
use clatter_geom::narrow::{self, EdgeMemory, Manifold, SatHint};
use clatter_geom::{Pose, Shape};

/// The narrow phase of a body pair with what it remembers (`hint`, `bound`; see
/// [`narrow::collide_with_hint`]): the separation bound first (`None`: still apart by
/// more than both bodies can have moved, the pair is skipped), or a remembered contact
/// face's margin less this step's motion; then `j`'s offset from `i` ([`World::offset_of`],
/// computed once for the pair), and the manifold, if any, written to `found` (left as it
/// is for a skipped pair). `body_of(k)`: body `k`'s shape and orientation (as
/// [`World::shape`] and the state's orientation give them; the plain path reads them
/// through arrays cut to the body count, without a bounds check each). Inlined into each
/// pair loop (out of line, its arguments and the manifold went through memory).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn remembered_narrow<'w, const PIECES: bool>(
    w: &'w World,
    x: impl PositionPairs,
    bound_of: impl Fn(usize) -> BodyBound,
    body_of: impl Fn(usize) -> (&'w Shape, Quat),
    [i, j]: [u32; 2],
    pieces: u32,
    hint: &mut SatHint,
    bound: &mut f32,
    memory: Option<&mut EdgeMemory>,
    found: &mut Option<Manifold>,
) -> Option<Vec3> {
    let (i, j) = (i as usize, j as usize);
    let remembered_face = narrow::is_contact_hint(*hint);
    if !remembered_face && *bound > 0.0 {
        // Apart by more than both bodies can have moved: skip the test. (Only the two
        // bounds' `moved` read here: most pairs of a pile stop here, and reading both
        // records whole before the test cost them a copy each.)
        *bound -= bound_of(i).moved + bound_of(j).moved;
        if *bound > 0.0 {
            return None;
        }
    }
    let (bi, bj) = (bound_of(i), bound_of(j));
    let d = w.offset_in(x, i, j);
    if remembered_face && memory.is_none() {
        // Touching at a remembered face: its margin less what this step's motion can have
        // changed on both sides of each decision; the narrow phase uses the face while the
        // margin stays positive. (With an edge memory, the plain path's, the narrow phase
        // takes off the motion since the full test itself, from the pose anchored there:
        // see `narrow::collide_with_memory`.)
        *bound -= 2.0 * axis_motion_bound::<PIECES>(w, i, j, d, &bi, &bj);
    }
    let (pa, pb) = piece_ids(pieces);
    narrow_pair::<PIECES>(w, body_of, d, i, j, pa, pb, hint, bound, memory, found);
    Some(d)
}

/// The narrow phase of body pair `k` (contact `k < world.contacts.pairs().len()`) as the
/// next step runs it, with what the pair remembers (its hint, bound and edge memory),
/// without changing the world: the
/// manifold (`None` too for a pair skipped as apart), and whether a remembered contact face
/// stood in for the full separating-axis test. For tests that hold the remembering path
/// against the full test ([`narrow::collide`]) on the same poses.
pub fn pair_narrow(world: &World, k: usize) -> (Option<Manifold>, bool) {
    let c = &world.contacts;
    let mut hint = c.springs.hints[k];
    let mut bound = c.springs.separation_bound[k];
    let composites = world.has_composites();
    let [i, j] = c.pairs[k].map(|i| i as usize);
    // Outside a step: the stored positions, split at each read.
    let x = world.state.position.as_slice();
    let d = world.offset_in(x, i, j);
    // The margin the narrow phase will see, if a face is remembered.
    let (bi, bj) = (BodyBound::of(world, i), BodyBound::of(world, j));
    let left = if composites {
        bound - 2.0 * axis_motion_bound::<true>(world, i, j, d, &bi, &bj)
    } else {
        bound - 2.0 * axis_motion_bound::<false>(world, i, j, d, &bi, &bj)
    };
    let before = narrow::is_contact_hint(hint).then_some((hint, left));
    let mut found = None;
    if composites {
        remembered_narrow::<true>(
            world,
            x,
            |i| BodyBound::of(world, i),
            |i| world.body_shape(i),
            c.pairs[k],
            c.pieces[k],
            &mut hint,
            &mut bound,
            None,
            &mut found,
        );
    } else {
        // A copy of the pair's edge memory, as the step would use it.
        let mut memory = world.edge_memory.get(k).cloned();
        let anchored = memory.as_ref().and_then(EdgeMemory::anchored_pose);
        let of = |i| BodyBound::of(world, i);
        let (pair, out) = (c.pairs[k], &mut found);
        let m = memory.as_mut();
        let body = |i| world.body_shape(i);
        remembered_narrow::<false>(world, x, of, body, pair, 0, &mut hint, &mut bound, m, out);
        if memory.is_some() {
            // Anchored (see `remembered_narrow`): the face stood in when the pair kept it,
            // its stored margin and its anchor (a full test sets all three anew).
            let kept = memory.as_ref().and_then(EdgeMemory::anchored_pose) == anchored;
            let before = before.map(|(h, _)| (h, c.springs.separation_bound[k]));
            return (found, kept && before == Some((hint, bound)));
        }
    }
    // The face stood in when the pair kept it and its margin (a full test sets both anew).
    let used = before == Some((hint, bound));
    (found, used)
}

/// The narrow phase for one body pair (pieces `pa` of `i` and `pb` of `j`, `j` at offset
/// `d` from `i`: [`World::offset_of`]): the contact manifold, if any, written to `found`.
/// Inlined: called, it returned the manifold through memory, which its caller then copied
/// twice more; and written, not returned, so that a pair with an edge memory has its
/// manifold written by the narrow phase where the law reads it
/// ([`narrow::collide_with_memory_into`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn narrow_pair<'w, const PIECES: bool>(
    w: &'w World,
    body_of: impl Fn(usize) -> (&'w Shape, Quat),
    d: Vec3,
    i: usize,
    j: usize,
    pa: u32,
    pb: u32,
    hint: &mut SatHint,
    bound: &mut f32,
    memory: Option<&mut EdgeMemory>,
    found: &mut Option<Manifold>,
) {
    if !PIECES {
        // The plain path (no composites in the world).
        let ((si, qi), (sj, qj)) = (body_of(i), body_of(j));
        *found = match (si, sj) {
            (Shape::Sphere { radius: ri }, Shape::Sphere { radius: rj }) => {
                narrow::sphere_sphere(Vec3::ZERO, *ri, d, *rj)
            }
            (si, sj) => {
                // `w.local_pose(i)` and `j` at its offset.
                let (pi, pj) = (Pose::new(Vec3::ZERO, qi), Pose::new(d, qj));
                match memory {
                    Some(m) => {
                        let (h, b) = (hint, bound);
                        return narrow::collide_with_memory_into(si, &pi, sj, &pj, h, b, m, found);
                    }
                    None => narrow::collide_with_hint(si, &pi, sj, &pj, hint, bound),
                }
            }
        };
        return;
    }
    // Body i at the origin, j at its offset (see `World::offset_of`).
    let (sa, posea) = w.piece_at(i, pa, Vec3::ZERO);
    let (sb, poseb) = w.piece_at(j, pb, d);
    *found = match (sa, sb) {
        (Shape::Sphere { radius: ri }, Shape::Sphere { radius: rj }) => {
            narrow::sphere_sphere(posea.position, *ri, poseb.position, *rj)
        }
        (si, sj) => narrow::collide_with_hint(si, &posea, sj, &poseb, hint, bound),
    };
}

/// An upper bound of how much the separation along any axis of the separating-axis test
/// of bodies `i` and `j` (their pieces with `PIECES`) can have changed in the last step.
///
/// Why: an axis of A's faces is fixed in A's frame, and its separation is the smallest
/// projection of B's vertices in A's frame, less a constant; so it moves no more than those
/// vertices do (and likewise for B's faces with A's vertices in B's frame; the largest
/// separation along any direction too, which bounds the edge axes: see
/// `clatter_geom::narrow`). B's vertex in A's frame is `y = R_a^T z` with `z = x_b + R_b p -
/// x_a` and `|p| <= r_b`. Over the step, `x_a`, `x_b` move by at most `|v| dt` (the step
/// that brought them here: semi-implicit Euler moves by the current velocity), and `R_a`,
/// `R_b` turn by angles `th <= |w| dt`. Then `y' - y = R_a'^T (z' - z) + (R_a'^T - R_a^T)
/// z`, with `|z' - z| <= |d(x_b - x_a)| + th_b r_b` and `|(R'^T - R^T) z| <= th_a |z|`
/// exactly; `|z| <= |d_then| + r_b`, and the centres' distance then was at most `|d| +
/// |d(x_b - x_a)|` from the current offset `d`. So with `m >= |d(x_b - x_a)|`, A's frame's
/// vertices move by at most `m + th_b r_b + th_a (|d| + m + r_b)`, B's by its mirror `m +
/// th_a r_a + th_b (|d| + m + r_a)`, and both by the larger of the two.
///
/// The plain path takes that larger one, with the norms themselves (square roots, rounded
/// within the relative margin below) and the centres' *relative* motion: each body moved
/// by its velocity times `dt` rounded to f32 per component (`precise::advance_a`: a relative
/// error of at most 2^-24 per component; the positions' own rounding is in the rounding
/// term below), so `|d(x_b - x_a)| <= |v_b - v_a| dt + 2^-24 (|v_a| + |v_b|) dt`, taken with
/// 2^-22. Bodies of a settling pile move together, and the two frames' levers differ: this
/// is about a third below the sum `(|v_a| + |v_b|) dt + (th_a + th_b) (|d| + m +
/// max(r_a, r_b))` taken before (issue 23), so a remembered contact serves more steps
/// before its margin runs out (the full test runs ~10% less often in the default scene's
/// settling pile). A tighter bound changes which path computes a contact, never its bits.
///
/// A piece of a composite also moves with its offset from the body's centre, at most `r`
/// (the body's bounding radius, which is also above the pieces'): there, with 1-norms
/// bounding 2-norms and the pair touching last step (centres closer than `r_a + r_b`), the
/// lever is `3 (r_a + r_b)`.
///
/// Plus rounding, against the truth the narrow phase's decisions are proved on (the f32
/// offset `d` between the stored centres, and the rotations of the stored quaternions
/// *normalised*; see below for the unnormalised ones). With `u = 2^-24`:
/// - the offset: rounded to f32 at both steps, at most half an ulp per component each:
///   `2^-23 |d|_1` (the term `l1 / 2^23`; `|d_then|_1` differs from `|d|_1` by the motion,
///   whose `u` share is inside the relative margin below);
/// - the centres' own advance: each step adds the f32 `v dt` to the double-single position
///   and snaps it to 48 bits (`precise::advance_a`): the `v dt` rounding is in `moved`, the
///   snap is at most `2^-49 |x|` per coordinate, below `2^-24 r` (the term `r / 2^24`) for
///   any scene within `2^24 r` (300 km for centimetre bodies) of the origin;
/// - the quaternions (`integrate::rotate`, WGSL integrate the same operations): the
///   first-order step `dq = (w dt / 2, 0) q` is orthogonal to `q`, so it turns the unit
///   quaternion by `atan(|w| dt / 2)`, the rotation by at most `|w| dt` (`turned`; its
///   own products' rounding, a few `u` of it, inside the relative margin). The Kahan sum
///   stores `q + dq - r_old + e`, `e` the sum's rounding and `r_old` the last step's
///   (each at most half an ulp per component: `|e|, |r_old| <= u |q|`), so the stored
///   quaternion is off the exact step by at most `2u |q|`, a quaternion angle of `2u`, a
///   rotation of `4u`; the renormalisation, when it runs, scales each component with
///   rounding `u |q|`: `2u` more. So each body turns by at most `|w| dt + 6u`; the bound
///   adds `8u = 2^-21` ([`TURN_ROUNDING`]) to both `turned` (a third more), the rotation's levers as above.
///   (Before, a flat `4e-6 r` stood for all rounding: on a settled cube pile it was 40-45%
///   of a touching pair's bound, as much as the turns, and the stored margin of a resting
///   face contact, about `tol - eps`, ran out after ~60 steps; issue 23, margin34.)
///
/// The narrow phase rotates by the stored quaternions as they are (glam's `Quat * Vec3`
/// and `Mat3::from_quat` of a product, which scale and shear by `|1 - |q|^2|`, at most
/// `4 eps_f32` plus a step's drift: `integrate::rotate` renormalises beyond it), so its
/// separations are off the normalised truth's by a few ulps of the bodies' size at every
/// pose: that is rounding at a pose, inside `clatter_geom::narrow`'s `eps` (`1e-4` of the
/// larger radius, ~25 times more), not motion from step to step.
#[inline]
pub(super) fn axis_motion_bound<const PIECES: bool>(
    w: &World,
    i: usize,
    j: usize,
    d: Vec3,
    bi: &BodyBound,
    bj: &BodyBound,
) -> f32 {
    let s = &w.state;
    // Body i sits at the origin of the pair's frame, j at `d` (see `World::offset_of`).
    let xj = d.abs();
    let (ri, rj) = (bi.radius, bj.radius);
    let r = ri + rj;
    let l1 = xj.x + xj.y + xj.z;
    if PIECES {
        // (Composites keep the flat allowance: their levers are 1-norms already.)
        let rounding = l1 * (1.0 / 8_388_608.0) + 4e-6 * r;
        let (vi, vj) = (s.velocity[i].abs(), s.velocity[j].abs());
        let (oi, oj) = (s.omega[i].abs(), s.omega[j].abs());
        let moved = (vi.x + vi.y + vi.z + vj.x + vj.y + vj.z) * w.dt;
        let turned = (oi.x + oi.y + oi.z + oj.x + oj.y + oj.z) * w.dt;
        return (moved + turned * 3.0 * r) * 1.000_01 + rounding;
    }
    let rounding = l1 * (1.0 / 8_388_608.0) + r * (1.0 / 16_777_216.0);
    let (vi, vj) = (bi.velocity, bj.velocity);
    let moved = ((vj - vi).length() + (bi.speed + bj.speed) * (1.0 / 4_194_304.0)) * w.dt;
    // Each turn with the quaternion update's rounding (see above).
    let (ti, tj) = (bi.turned + TURN_ROUNDING, bj.turned + TURN_ROUNDING);
    let far = d.length() + moved;
    // A's frame (B's vertices), then B's frame (A's vertices).
    let turn = (tj * rj + ti * (far + rj)).max(ti * ri + tj * (far + ri));
    (moved + turn) * 1.000_01 + rounding
}

//! The "winner stays the winner" record of a search by direction: how far the remembered
//! winning direction pair led every other pair at a measured pose, so that later searches
//! near that pose evaluate the winner alone (see [`WinnerLead`]).

use glam::{Quat, Vec3};

use super::edges::direction_pair;
use super::lanes::SoaPoints;
use super::memory::{DeepPairs, growth_from};
use crate::ConvexPolyhedron;

/// No winner recorded (a record of a measurement that did not lead, or none).
const NONE: u8 = u8::MAX;

/// What a measurement of the winner's lead needs to make a record that serves for a few
/// steps: this many times the growth bound at no motion at all (its rounding terms, about
/// `1e-3` of the radii's sum for two touching cubes). A smaller lead is not recorded, and
/// the pair is not measured again before its separations could have moved it past this.
const NEED: f32 = 3.0;

/// The winner's lead over every other direction pair of a search by direction
/// (`edges::edge_axes_by_direction`), measured at a pose, for the **winner-stays skip**: a
/// cache beside the pair's `EdgeMemory` that changes no result.
///
/// **The record.** At a search served by the memory (`EdgeMemory::deep_pairs` is `Some`)
/// whose remembered winner `w` was evaluated first with a separation `s_w` in `(floor,
/// 0]` and stayed the best, every other direction pair `k` is evaluated as the search
/// evaluates it ([`direction_pair`]: the same arithmetic, the same bits) at this pose
/// `P0`; the record keeps `P0` (B's relative rotation and offset), the shapes (by address),
/// `w`, and `before` / `after`, the largest separation of the pairs before `w` / after `w`
/// in the search's order (minus infinity for none). It is kept only when every other pair
/// is rememberable at `P0` (`|ua x wb|^2 >= 0.04`, [`DeepPairs::rememberable`], computed
/// as the search computes it) and no separation is NaN.
///
/// **The skip.** At a later search of the same shapes at pose `P`, served by the memory (a
/// unit rotation, checked by `deep_pairs`), whose remembered winner is still `w` and
/// evaluates (first, as the search does) to `s_w` in `(floor, 0]`: let `g` be the growth
/// bound from `P0` to `P` (`memory::growth_from`, `DeepPairs`' proof: a pair rememberable
/// at `P0` has at `P` a computed separation at most its computed separation at `P0` plus
/// `g`, from any unit-rotation pose, its rounding included). If `before + g < s_w` and
/// `after + g <= s_w`, every pair before `w` that the search would evaluate has a
/// separation below `s_w` and every pair after `w` one at most `s_w`. Then:
/// - no pair separates (all are at most `s_w <= 0`; a pair the search finds near-parallel
///   now or leaves out by a bound is not a candidate at all);
/// - no pair beats or ties the winner before it reaches the winner (strictly below), and
///   no pair after it beats it (at most equal, and the first of equals wins), so the
///   search's best is the winner with exactly the `(s_w, axis)` evaluated first (the loop
///   takes the winner's answer from that evaluation: `first` in `edge_axes_by_direction`);
/// - a NaN anywhere fails a comparison: no skip (records with a NaN are not kept, and
///   `s_w` is tested `s_w <= 0 && s_w > floor`, false for a NaN).
///
/// The rounding of the sums `before + g`, `after + g` (half an ulp of at most the lever
/// `r_a + r_b + |t| + |dt|`) is inside `g`'s own rounding allowance (`1e-4` of the lever,
/// then 1%), as for `DeepPairs::top`'s `level + grown <= floor`.
///
/// **What the memory writes.** A served search writes only its winner (`best`'s pair:
/// `w`, the same value); `deep_pairs` reads. So the memory's state after a skipped search
/// is what the whole search leaves. A search that re-records (`deep_pairs` `None`) is never
/// skipped.
///
/// **Throttle.** A measurement costs about one evaluation per direction pair. One whose
/// lead `min(s_w - before, s_w - after)` is under `NEED` times the growth at no motion is
/// not kept as a record; the pose is kept with how far the pairs' separations must move
/// before a lead that large is possible (each moves by at most the growth, so the lead by
/// twice it), and the pair is not measured again until the growth from that pose exceeds
/// it. A pair with a near-parallel other pair waits for the radii's sum.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct WinnerLead {
    /// B's rotation relative to A at the measurement.
    rot: Quat,
    /// The addresses of A and B (0: nothing measured).
    shapes: [usize; 2],
    /// B's offset in A's frame at the measurement.
    offset: Vec3,
    /// The largest separation of the direction pairs before the winner in the search's
    /// order, and after it (minus infinity: none).
    before: f32,
    after: f32,
    /// How far the growth from the measured pose must reach before the next measurement
    /// (a record that leads: 0, measured again as soon as it stops serving).
    wait: f32,
    /// The winning direction pair (`ia * (B's directions) + ib`), or [`NONE`].
    winner: u8,
}

impl Default for WinnerLead {
    fn default() -> Self {
        WinnerLead {
            rot: Quat::IDENTITY,
            shapes: [0; 2],
            offset: Vec3::ZERO,
            before: f32::NEG_INFINITY,
            after: f32::NEG_INFINITY,
            wait: 0.0,
            winner: NONE,
        }
    }
}

/// The identity of a polyhedron as a record names it.
#[inline]
fn address(p: &ConvexPolyhedron) -> usize {
    p as *const ConvexPolyhedron as usize
}

impl WinnerLead {
    /// Whether the search of `a` against `b` at relative rotation `rot` (a unit rotation)
    /// and offset `t`, served by its memory with winner `winner` evaluated first at `s`
    /// (in `(floor, 0]`), may take the winner as its answer without the other pairs (see
    /// [`WinnerLead`]).
    #[inline]
    pub(super) fn serves(
        &self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        rot: Quat,
        t: Vec3,
        winner: usize,
        s: f32,
    ) -> bool {
        if self.winner as usize != winner || self.shapes != [address(a), address(b)] {
            return false;
        }
        let g = growth_from(self.rot, self.offset, a, b, rot, t);
        // (Written so that a NaN fails.)
        self.before + g < s && self.after + g <= s
    }

    /// Whether a search that was not skipped should measure a new record (see the
    /// throttle in [`WinnerLead`]).
    #[inline]
    pub(super) fn wants_measure(
        &self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        rot: Quat,
        t: Vec3,
    ) -> bool {
        if self.winner != NONE || self.shapes != [address(a), address(b)] {
            return true;
        }
        // (A NaN growth waits.)
        growth_from(self.rot, self.offset, a, b, rot, t) > self.wait
    }

    /// Measures the lead of direction pair `winner` (separation `s`, the search's best)
    /// over every other pair of `a` (directions `a.edge_dirs`) against `b` (its directions
    /// rotated into A's frame, `dirs_b`; `a_local`, `b_soa` the points as the search takes
    /// them) at relative rotation `rot` and offset `t`, and keeps it as this record, or
    /// the throttle's wait (see [`WinnerLead`]).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn measure(
        &mut self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        dirs_b: &[Vec3],
        (a_local, b_soa): (&SoaPoints, &SoaPoints),
        (rot, t): (Quat, Vec3),
        winner: usize,
        s: f32,
    ) {
        let ndb = dirs_b.len();
        let (mut before, mut after) = (f32::NEG_INFINITY, f32::NEG_INFINITY);
        let mut kept = true;
        for (ia, ua) in a.edge_dirs.iter().enumerate() {
            for (ib, wb) in dirs_b.iter().enumerate() {
                let k = ia * ndb + ib;
                if k == winner {
                    continue;
                }
                // (The search's own `len2`, so the same decision; a NaN is not kept.)
                if !DeepPairs::rememberable(ua.cross(*wb).length_squared()) {
                    kept = false;
                    continue;
                }
                let Some((sk, _)) = direction_pair(*ua, *wb, a_local, b_soa) else {
                    kept = false;
                    continue;
                };
                if sk.is_nan() {
                    kept = false;
                } else if k < winner {
                    before = before.max(sk);
                } else {
                    after = after.max(sk);
                }
            }
        }
        let rest = growth_from(rot, t, a, b, rot, t);
        let lead = (s - before).min(s - after);
        let radii = a.radius + b.radius;
        let wait = if !kept {
            radii
        } else if lead >= NEED * rest {
            0.0
        } else {
            // (A NaN lead waits for the radii's sum.)
            let w = 0.5 * (NEED * rest - lead);
            if w.is_nan() { radii } else { w }
        };
        *self = WinnerLead {
            rot,
            shapes: [address(a), address(b)],
            offset: t,
            before,
            after,
            wait,
            winner: if wait == 0.0 && winner < 128 {
                winner as u8
            } else {
                NONE
            },
        };
    }

    /// Keeps the throttle's wait after a search whose best was not its memory's winner:
    /// the winner trailed the best by `s_best - s_w` (see [`WinnerLead`]).
    #[inline]
    pub(super) fn trailed(
        &mut self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        (rot, t): (Quat, Vec3),
        trail: f32,
    ) {
        let rest = growth_from(rot, t, a, b, rot, t);
        let w = 0.5 * (NEED * rest + trail);
        *self = WinnerLead {
            rot,
            shapes: [address(a), address(b)],
            offset: t,
            before: f32::NEG_INFINITY,
            after: f32::NEG_INFINITY,
            wait: if w.is_nan() { a.radius + b.radius } else { w },
            winner: NONE,
        };
    }
}

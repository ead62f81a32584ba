//! The **near list** of a spheres-only world: a second, contiguous contact list of the
//! candidate pairs that can touch for a while, made from the broad phase's list
//! (`Contacts`) and used by the contacts stage and the gather in its place while it lives.
//!
//! Why: the broad phase's list holds every pair within the Verlet skin (on a settled pile
//! about 3.6 pairs per body, of which 2.3 touch), and the law's lanes and the gather read all
//! of them every step. The near list holds only the pairs whose spheres are within `MARGIN`
//! of the skin of touching when it is made, with their springs and forces copied into its
//! own arrays (in list order, so eight near pairs are eight slots in a row) and its own
//! gather tables; it is made again once a body has moved half the smallest gap of its pairs
//! left out (at least half the margin) since.
//!
//! Why the same bits:
//!
//! - **Pairs outside it neither touch nor hold anything while it lives.** A pair is left
//!   out only when its state is all zero bits (not touching, no force, no springs: what the
//!   law leaves in a pair that does not touch) and its spheres were apart by at least
//!   `MARGIN` times the skin when the list was made (the step's own `f32` offset and
//!   distance). While each body has moved (`f64`, from its position at the making) no more
//!   than half the smallest such gap of its pairs, less an allowance for the rounding of
//!   those distances, the two moves of a pair cannot close its gap, so the law would find
//!   the pair apart every step and, as it was not touching, write nothing (the lanes store
//!   +0, which it already holds). A body with no pair left out may move any distance (the
//!   broad phase's own rebuild keeps the list itself current).
//! - **The gather's sums are unchanged.** `Contacts::gather4` and `gather8` start each sum
//!   at +0 and add or subtract the forces of a body's contacts in list order. In
//!   round-to-nearest a sum or difference is -0 only when both operands are -0 (a sum) or
//!   -0 and +0 (a difference), so a sum started at +0 is never -0, and adding or
//!   subtracting a +0 force leaves it unchanged: the pairs left out (forces +0) drop out of
//!   the sums without changing a bit. The near list keeps each body's remaining contacts in
//!   the same relative order (its pairs are the list's, sorted, and all wall pairs).
//! - **Everything else reads the one list.** The near list is a cache: `Contacts::springs`
//!   gives the list's springs with the near list's written in, and a rebuild, a checkpoint
//!   restore, a GPU hand-over or a migration writes it back (`Contacts::end_near`) or drops
//!   it before replacing the list.

use glam::DVec3;
use rayon::prelude::*;

use crate::contact_list::{ContactSprings, Contacts};
use crate::world::World;

mod make;
use make::make;

/// The near list's margin, as a fraction of the skin: pairs whose spheres are closer than
/// this when it is made are in it.
pub(crate) const MARGIN: f32 = 0.25;

/// Bodies per parallel piece of the near list's reach test (`Near::holds`).
const HOLDS_CHUNK: usize = 4096;

/// Pairs, and bodies, per parallel piece of the near list's making and writing back.
const MAKE_CHUNK: usize = 4096;

/// A near list (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Near {
    /// Per near body pair, its slot in the broad phase's list (ascending).
    pub(crate) slots: Vec<u32>,
    /// Per slot of the broad phase's list, the near pairs before it, and their count last
    /// (slot `s` is near pair `rank[s]` where `rank[s + 1] != rank[s]`).
    rank: Vec<u32>,
    /// The near pairs and every wall pair of the broad phase's list, with their springs.
    pub(crate) list: Contacts,
    /// The bodies' positions when it was made.
    made_at: Vec<DVec3>,
    /// Per body, the squared distance it may move from `made_at` while the list lives (half
    /// the smallest gap of its pairs left out, less a rounding allowance; infinite where
    /// none is left out, -1 where it may not move at all).
    reach2: Vec<f64>,
}

impl Near {
    /// Writes the near list's springs, forces and flags into `dst`, the broad phase's list's
    /// (whose pairs outside the near list hold zeros): [`Near::write_back_in_pieces`] on more
    /// than one thread, else [`Near::write_back_serial`] (the same values, without the
    /// pieces' pass over every slot of the broad phase's list).
    pub(crate) fn write_back(&self, dst: &mut ContactSprings) {
        if rayon::current_num_threads() == 1 {
            self.write_back_serial(dst);
        } else {
            self.write_back_in_pieces(dst);
        }
    }

    /// [`Near::write_back`] as one scatter: each near pair into its slot, in order.
    fn write_back_serial(&self, dst: &mut ContactSprings) {
        let src = &self.list.springs;
        for (k, &s) in self.slots.iter().enumerate() {
            let s = s as usize;
            dst.history[s] = src.history[k];
            dst.twist[s] = src.twist[k];
            dst.forces[s] = src.forces[k];
            dst.touching[s] = src.touching[k];
        }
        self.write_back_walls(dst);
    }

    /// [`Near::write_back`] in parallel pieces of the broad phase's slots (each written by
    /// one piece, from its near pair, found by `rank`).
    fn write_back_in_pieces(&self, dst: &mut ContactSprings) {
        let src = &self.list.springs;
        let rank = &self.rank;
        let np = rank.len() - 1;
        dst.history[..np]
            .par_chunks_mut(MAKE_CHUNK)
            .zip(dst.twist[..np].par_chunks_mut(MAKE_CHUNK))
            .zip(dst.forces[..np].par_chunks_mut(MAKE_CHUNK))
            .zip(dst.touching[..np].par_chunks_mut(MAKE_CHUNK))
            .enumerate()
            .for_each(|(p, (((history, twist), forces), touching))| {
                let first = p * MAKE_CHUNK;
                for s in 0..history.len() {
                    let k = rank[first + s] as usize;
                    if rank[first + s + 1] as usize != k {
                        history[s] = src.history[k];
                        twist[s] = src.twist[k];
                        forces[s] = src.forces[k];
                        touching[s] = src.touching[k];
                    }
                }
            });
        self.write_back_walls(dst);
    }

    /// The wall pairs' part of [`Near::write_back`]: all of them, in the same order, after
    /// the body pairs in both lists.
    fn write_back_walls(&self, dst: &mut ContactSprings) {
        let src = &self.list.springs;
        let n = self.slots.len();
        let np = dst.hints.len();
        dst.history[np..].copy_from_slice(&src.history[n..]);
        dst.twist[np..].copy_from_slice(&src.twist[n..]);
        dst.forces[np..].copy_from_slice(&src.forces[n..]);
        dst.touching[np..].copy_from_slice(&src.touching[n..]);
    }

    /// Whether every body is still within reach of where it was when the list was made.
    fn holds(&self, positions: &[DVec3]) -> bool {
        let n = self.made_at.len();
        if positions.len() != n || self.reach2.len() != n {
            return false;
        }
        within_reach(positions, &self.made_at, &self.reach2)
    }
}

/// [`World::split_positions`] and, where the world steps with a near list and has one of
/// its length, that list's reach test ([`Near::holds`]) in the same parallel pass: one
/// fork-join and one read of the positions a step, not two (on two threads each fork-join
/// of a sphere step's few is a pause of both). Returns the test's answer (`None` where
/// there was no test to do; [`update`] then does it). Every body's pair is split
/// by the same function as `split_positions`' and the answer is the `&` of the same pieces'
/// answers ([`within_reach_piece`]), whatever the pieces, so the same bits and the same
/// boolean.
pub(crate) fn split_and_test(world: &mut World) -> Option<bool> {
    let n = world.state.position.len();
    let near = match &world.contacts.near {
        Some(near) if applies(world) && near.made_at.len() == n && near.reach2.len() == n => near,
        _ => {
            world.split_positions();
            return None;
        }
    };
    let zero = crate::precise::Ds3A {
        hi: glam::Vec3A::ZERO,
        lo: glam::Vec3A::ZERO,
    };
    // Only the length changes here: every slot is written below.
    world.position_pairs.resize(n, zero);
    const PIECE: usize = crate::precise::SPLIT_CHUNK;
    let (x, made_at, reach2) = (&world.state.position, &near.made_at, &near.reach2);
    let held = world
        .position_pairs
        .par_chunks_mut(PIECE)
        .zip(x.par_chunks(PIECE))
        .zip(made_at.par_chunks(PIECE))
        .zip(reach2.par_chunks(PIECE))
        .map(|(((out, x), made), reach2)| {
            crate::precise::split_chunk(x, out);
            within_reach_piece(x, made, reach2)
        })
        .reduce(|| true, |a, b| a & b);
    // Spheres only (`applies`): this clears the bounds, as `split_positions` does.
    super::motion::update(world);
    Some(held)
}

/// One piece of the reach test ([`within_reach`]): four at a time where the CPU has AVX2,
/// else body by body (the same answer).
fn within_reach_piece(x: &[DVec3], made: &[DVec3], reach2: &[f64]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if crate::step::avx2() {
        // SAFETY: the CPU has AVX2 (`avx2` is never true otherwise).
        return unsafe { within_reach4(x, made, reach2) };
    }
    within_reach1(x, made, reach2)
}

/// Whether every body `k` is within `reach2[k]` (squared) of `made_at[k]` (the slices of
/// one length). In parallel pieces (the test runs every step, over every body: on one
/// thread it left the others waiting), each piece's bodies all tested with `&` (a loop
/// without branches); a piece that fails ends the others early. The answer is the same
/// boolean whatever the pieces; a NaN distance fails.
fn within_reach(positions: &[DVec3], made_at: &[DVec3], reach2: &[f64]) -> bool {
    positions
        .par_chunks(HOLDS_CHUNK)
        .zip(made_at.par_chunks(HOLDS_CHUNK))
        .zip(reach2.par_chunks(HOLDS_CHUNK))
        .all(|((x, made), reach2)| within_reach_piece(x, made, reach2))
}

/// One piece of [`within_reach`], body by body.
fn within_reach1(x: &[DVec3], made: &[DVec3], reach2: &[f64]) -> bool {
    let mut ok = true;
    for ((x, made), &r) in x.iter().zip(made).zip(reach2) {
        let d = *x - *made;
        ok &= d.x * d.x + d.y * d.y + d.z * d.z <= r;
    }
    ok
}

/// [`within_reach1`] four bodies at a time (the rest one by one): per body the same `f64`
/// operations in the same order (`(dx * dx + dy * dy) + dz * dz <= reach2`, `<=` ordered,
/// so a NaN fails), so the same answer. Body by body, the test was about 12 instructions
/// a body every step; here about half.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn within_reach4(x: &[DVec3], made: &[DVec3], reach2: &[f64]) -> bool {
    use std::arch::x86_64::*;
    let n = x.len().min(made.len()).min(reach2.len());
    let (x4, _) = x[..n].as_chunks::<4>();
    let (m4, _) = made[..n].as_chunks::<4>();
    let (r4, _) = reach2[..n].as_chunks::<4>();
    let mut all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    for ((x, m), r) in x4.iter().zip(m4).zip(r4) {
        let (px, pm) = (x.as_ptr() as *const f64, m.as_ptr() as *const f64);
        // SAFETY: 12 `f64`s from each (x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3) and 4 reaches.
        let (s0, s1, s2, r) = unsafe {
            let d0 = _mm256_sub_pd(_mm256_loadu_pd(px), _mm256_loadu_pd(pm));
            let d1 = _mm256_sub_pd(_mm256_loadu_pd(px.add(4)), _mm256_loadu_pd(pm.add(4)));
            let d2 = _mm256_sub_pd(_mm256_loadu_pd(px.add(8)), _mm256_loadu_pd(pm.add(8)));
            (
                _mm256_mul_pd(d0, d0),
                _mm256_mul_pd(d1, d1),
                _mm256_mul_pd(d2, d2),
                _mm256_loadu_pd(r.as_ptr()),
            )
        };
        // The squares per axis, the bodies in lanes 0, 3, 2, 1.
        let sx = _mm256_blend_pd::<0b0010>(_mm256_blend_pd::<0b0100>(s0, s1), s2);
        let sy = _mm256_blend_pd::<0b0100>(_mm256_blend_pd::<0b1001>(s0, s1), s2);
        let sy = _mm256_permute4x64_pd::<0b00_11_10_01>(sy);
        let sz = _mm256_blend_pd::<0b1001>(_mm256_blend_pd::<0b0010>(s0, s1), s2);
        let sz = _mm256_permute4x64_pd::<0b01_00_11_10>(sz);
        let r = _mm256_permute4x64_pd::<0b01_10_11_00>(r);
        let d2 = _mm256_add_pd(_mm256_add_pd(sx, sy), sz);
        all = _mm256_and_pd(all, _mm256_cmp_pd::<_CMP_LE_OQ>(d2, r));
    }
    let tail = n - n % 4;
    _mm256_movemask_pd(all) == 0b1111
        && within_reach1(&x[tail..n], &made[tail..n], &reach2[tail..n])
}

/// For a decomposed step whose ghost states are still on their way (`crate::domain`):
/// whether the near list holds for the bodies that are not ghosts (`World::ghost`), or,
/// with `ghosts`, for those in its lists (a rank's ghosts by owner, once their states are
/// in):
/// `update` keeps the list exactly when it holds for both. `None` where the world steps
/// without a near list; `Some(false)` where it has none now.
pub(crate) fn holds_for(world: &World, ghosts: Option<&[Vec<u32>]>) -> Option<bool> {
    if !applies(world) {
        return None;
    }
    let Some(near) = &world.contacts.near else {
        return Some(false);
    };
    let (x, made, reach2, ghost) = (
        &world.state.position,
        &near.made_at,
        &near.reach2,
        &world.ghost,
    );
    let n = made.len();
    if x.len() != n || reach2.len() != n || ghost.len() != n {
        return Some(false);
    }
    let within = |k: usize| {
        let d = x[k] - made[k];
        d.x * d.x + d.y * d.y + d.z * d.z <= reach2[k]
    };
    Some(match ghosts {
        Some(lists) => lists.iter().flatten().all(|&k| within(k as usize)),
        None => {
            // Every body tested without branches (as `Near::holds`), the ghosts passing.
            let (x, made, reach2, ghost) = (&x[..n], &made[..n], &reach2[..n], &ghost[..n]);
            let mut ok = true;
            for k in 0..n {
                let d = x[k] - made[k];
                ok &= ghost[k] | (d.x * d.x + d.y * d.y + d.z * d.z <= reach2[k]);
            }
            ok
        }
    })
}

/// Whether `world` steps with a near list: spheres only (whose contacts keep no
/// separating-axis hints, bounds or edge memories), a positive skin.
fn applies(world: &World) -> bool {
    #[cfg(test)]
    if tests::OFF.with(|off| off.get()) {
        return false;
    }
    world.spheres_only() && !world.has_composites() && world.skin > 0.0
}

/// Before the contacts stage (positions split): keeps the near list while it holds, else
/// writes it back and makes a new one from the broad phase's list. `held`: the reach
/// test's answer where [`split_and_test`] gave one (for this list, on these positions),
/// else `None` and the test is done here.
pub(crate) fn update(world: &mut World, held: Option<bool>) {
    if !applies(world) {
        world.contacts.end_near();
        return;
    }
    // The springs change this step: the readers' copy is void.
    world.contacts.view = std::sync::OnceLock::new();
    if let Some(near) = &world.contacts.near
        && held.unwrap_or_else(|| near.holds(&world.state.position))
    {
        return;
    }
    world.contacts.end_near();
    let near = make(world);
    world.contacts.near = Some(Box::new(near));
}

#[cfg(test)]
mod tests {
    /// The parallel reach test against its definition, body by body: one body out of reach
    /// (or at a NaN distance) anywhere, in the first, a middle or the last piece, fails it.
    #[test]
    fn the_reach_test_in_pieces_is_every_bodys() {
        use glam::DVec3;
        let n = 3 * super::HOLDS_CHUNK + 17;
        let made: Vec<DVec3> = (0..n)
            .map(|k| DVec3::new(k as f64 * 0.01, (k % 7) as f64, -(k as f64)))
            .collect();
        let reach2: Vec<f64> = (0..n).map(|k| 1e-6 * (1 + k % 5) as f64).collect();
        let moved = |x: &mut [DVec3]| {
            for (k, p) in x.iter_mut().enumerate() {
                *p += DVec3::new(1e-4 * (k % 3) as f64, 0.0, 5e-4);
            }
        };
        let definition =
            |x: &[DVec3]| (0..n).all(|k| (x[k] - made[k]).length_squared() <= reach2[k]);
        let mut x = made.clone();
        moved(&mut x);
        assert!(definition(&x));
        assert!(super::within_reach(&x, &made, &reach2));
        let edge = super::HOLDS_CHUNK;
        for k in [0, edge - 1, edge, 2 * edge + 5, n - 1] {
            for away in [DVec3::new(0.0, 0.01, 0.0), DVec3::NAN] {
                let mut y = x.clone();
                y[k] = made[k] + away;
                assert!(!definition(&y));
                assert!(!super::within_reach(&y, &made, &reach2), "body {k}, {away}");
            }
        }
    }

    /// The reach test four bodies at a time and body by body against the definition, on
    /// short runs of every length mod 4, each body's reach its own squared move exactly
    /// (which passes) and one body's one ulp less or its move NaN, on each axis alone or
    /// all three (which fails): every lane and the tail decide.
    #[test]
    fn the_reach_test_four_at_a_time_is_body_by_bodys() {
        use glam::DVec3;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let (mut passed, mut failed) = (0, 0);
        for trial in 0..3000 {
            let n = trial % 13;
            let made: Vec<DVec3> = (0..n)
                .map(|_| DVec3::new(next(), next(), next()) * 10.0)
                .collect();
            let axis = trial % 4;
            let mut x: Vec<DVec3> = made
                .iter()
                .map(|m| {
                    let d = DVec3::new(next(), next(), next()) * 1e-3;
                    let d = match axis {
                        0 => DVec3::new(d.x, 0.0, 0.0),
                        1 => DVec3::new(0.0, d.y, 0.0),
                        2 => DVec3::new(0.0, 0.0, d.z),
                        _ => d,
                    };
                    *m + d
                })
                .collect();
            let square = |x: &DVec3, m: &DVec3| {
                let d = *x - *m;
                d.x * d.x + d.y * d.y + d.z * d.z
            };
            let mut reach2: Vec<f64> = x.iter().zip(&made).map(|(x, m)| square(x, m)).collect();
            if n > 0 && trial % 3 != 0 {
                let k = (trial / 3) % n;
                if trial % 7 == 1 {
                    x[k].y = f64::NAN;
                } else {
                    reach2[k] = f64::from_bits(reach2[k].to_bits() - 1);
                }
            }
            let want = (0..n).all(|k| square(&x[k], &made[k]) <= reach2[k]);
            assert_eq!(
                super::within_reach1(&x, &made, &reach2),
                want,
                "trial {trial}"
            );
            #[cfg(target_arch = "x86_64")]
            if crate::step::avx2() {
                // SAFETY: the CPU has AVX2.
                let four = unsafe { super::within_reach4(&x, &made, &reach2) };
                assert_eq!(four, want, "four at a time, trial {trial}");
            }
            if want { passed += 1 } else { failed += 1 }
        }
        assert!(
            passed > 1000 && failed > 1000,
            "{passed} passed, {failed} failed"
        );
    }

    /// The split and the reach test in one pass against each done alone: every body's pair
    /// the bits of `precise::split_a` of its position (in every piece, also when the test
    /// fails, and whichever piece fails it), and the answer the definition's: one body out
    /// of reach (or at a NaN distance) in the first, a middle or the last piece fails it.
    /// Without a near list (or one of another length) there is no test (`None`), and the
    /// pairs are split all the same.
    #[test]
    fn the_split_and_the_reach_test_in_one_pass_are_each_alone() {
        use crate::precise::{SPLIT_CHUNK, split_a};
        use glam::DVec3;
        let mut w = world();
        w.step().expect("a stable run");
        assert!(
            w.contacts.near.is_some(),
            "the scene steps with a near list"
        );
        let n = 3 * SPLIT_CHUNK + 17;
        let made: Vec<DVec3> = (0..n)
            .map(|k| DVec3::new(k as f64 * 0.013, 1.0 + (k % 7) as f64, -(k as f64) * 0.7))
            .collect();
        let reach2: Vec<f64> = (0..n).map(|k| 1e-6 * (1 + k % 5) as f64).collect();
        let x: Vec<DVec3> = made
            .iter()
            .enumerate()
            .map(|(k, &m)| m + DVec3::new(1e-4 * (k % 3) as f64, 3e-7 * (k % 11) as f64, 5e-4))
            .collect();
        let definition =
            |x: &[DVec3]| (0..n).all(|k| (x[k] - made[k]).length_squared() <= reach2[k]);
        // The world's bodies and its near list's reach replaced by `n` of them (all that
        // the pass reads); every pair poisoned before each pass.
        let check = |w: &mut World, x: &[DVec3], with_list: bool| {
            w.state.position = x.to_vec();
            let near = w.contacts.near.as_mut().expect("a near list");
            near.made_at = if with_list {
                made.clone()
            } else {
                made[1..].to_vec()
            };
            near.reach2 = reach2.clone();
            w.position_pairs = vec![split_a(DVec3::splat(0.5)); n];
            let held = super::split_and_test(w);
            for (k, (pair, &x)) in w.position_pairs.iter().zip(x).enumerate() {
                let want = split_a(x);
                let bits = |p: &crate::precise::Ds3A| {
                    [p.hi.to_array(), p.lo.to_array()].map(|v| v.map(f32::to_bits))
                };
                assert_eq!(bits(pair), bits(&want), "body {k}'s pair");
            }
            assert_eq!(w.position_pairs.len(), n);
            held
        };
        assert!(definition(&x));
        assert_eq!(check(&mut w, &x, true), Some(true));
        assert_eq!(check(&mut w, &x, false), None);
        for k in [0, SPLIT_CHUNK - 1, SPLIT_CHUNK, 2 * SPLIT_CHUNK + 5, n - 1] {
            for away in [DVec3::new(0.0, 0.01, 0.0), DVec3::NAN] {
                let mut y = x.clone();
                y[k] = made[k] + away;
                assert!(!definition(&y));
                assert_eq!(check(&mut w, &y, true), Some(false), "body {k}, {away}");
            }
        }
    }

    use std::cell::Cell;

    use crate::World;
    use crate::checkpoint::Checkpoint;
    use crate::contact_list::ContactSprings;
    use crate::scene::Scene;

    thread_local! {
        /// This thread's worlds step without a near list (the reference).
        pub(super) static OFF: Cell<bool> = const { Cell::new(false) };
    }

    /// Spheres of two sizes poured fast and slow into a box: pairs and wall contacts that
    /// start, separate and touch again, bodies that cross half the near margin within a few
    /// steps and others that settle.
    const SCENE: &str = r#"
[simulation]
steps = 1
dt = 2.0e-5
gravity = [0.0, 0.0, -9.81]

[[material]]
name = "glass"
density = 2500.0
stiffness = 2.0e4
restitution = 0.5
friction = 0.5

[container]
min = [0.0, 0.0, 0.0]
max = [0.05, 0.05, 0.08]
material = "glass"

[[shape]]
name = "small"
sphere = { radius = 0.003 }

[[shape]]
name = "large"
sphere = { radius = 0.0045 }

[[group]]
shape = "small"
material = "glass"
random = { min = [0.004, 0.004, 0.004], max = [0.046, 0.046, 0.03], count = 140, seed = 3 }
velocity = [0.0, 0.0, -0.05]

[[group]]
shape = "large"
material = "glass"
random = { min = [0.005, 0.005, 0.034], max = [0.045, 0.045, 0.05], count = 40, seed = 4 }
velocity = [0.0, 0.0, 0.02]

[[group]]
shape = "small"
material = "glass"
random = { min = [0.004, 0.004, 0.056], max = [0.046, 0.046, 0.077], count = 50, seed = 5 }
velocity = [0.8, -0.6, -2.5]
"#;

    pub(super) fn world() -> World {
        Scene::parse(SCENE, "near.toml")
            .expect("valid scene")
            .world()
    }

    /// Every bit of the bodies' state and of every contact's springs, force and flag.
    fn bits(w: &World) -> (Vec<u64>, Vec<u32>) {
        let s = &w.state;
        let mut state = Vec::new();
        for i in 0..w.len() {
            state.extend(s.position[i].to_array().map(f64::to_bits));
            state.extend(s.velocity[i].to_array().map(|v| v.to_bits() as u64));
            state.extend(s.angular_momentum[i].to_array().map(|v| v.to_bits() as u64));
        }
        let ContactSprings {
            history,
            twist,
            forces,
            touching,
            ..
        } = w.contacts.springs();
        let mut springs: Vec<u32> = w.contacts.pairs.iter().flatten().copied().collect();
        springs.extend(history.iter().flat_map(|h| h.to_array().map(f32::to_bits)));
        springs.extend(twist.iter().map(|t| t.to_bits()));
        springs.extend(
            forces
                .iter()
                .flat_map(|f| bytemuck::cast::<_, [u32; 12]>(*f)),
        );
        springs.extend(touching.iter().map(|&t| t as u32));
        (state, springs)
    }

    fn reference_step(w: &mut World) -> usize {
        OFF.with(|off| off.set(true));
        let touching = w.step().expect("a stable run").contacts;
        OFF.with(|off| off.set(false));
        touching
    }

    /// The same steps with and without the near list: the bodies' states, every contact's
    /// springs, forces and flags and the touching count bitwise equal after every step,
    /// through near lists made again, rebuilds and a checkpoint taken while one lives.
    #[test]
    fn the_near_list_gives_the_full_lists_bits() {
        let (mut near, mut full) = (world(), world());
        let mut restored: Option<World> = None;
        let (mut made, mut rebuilt_in_life, mut shorter, mut checkpointed) = (0, 0, 0, false);
        let mut last_slots: Option<*const u32> = None;
        for step in 0..1500 {
            let before = near.rebuilds;
            let alive = near.contacts.near.is_some();
            let touching = near.step().expect("a stable run").contacts;
            assert_eq!(
                touching,
                reference_step(&mut full),
                "touching at step {step}"
            );
            let list = near
                .contacts
                .near
                .as_ref()
                .expect("a spheres world has a near list");
            if last_slots != Some(list.slots.as_ptr()) {
                made += 1;
                last_slots = Some(list.slots.as_ptr());
            }
            if alive && near.rebuilds > before {
                rebuilt_in_life += 1;
            }
            if list.slots.len() < near.contacts.pairs.len() {
                shorter += 1;
            }
            assert!(
                bits(&near) == bits(&full),
                "the states differ after step {step}"
            );
            if let Some(r) = &mut restored {
                let t = r.step().expect("a stable run").contacts;
                assert_eq!(t, touching);
                assert!(
                    bits(r) == bits(&full),
                    "the restored run differs after step {step}"
                );
            }
            if step == 700 {
                // A checkpoint written while the near list lives (its springs are the
                // current ones), restored and run on beside the others.
                let bytes = near.checkpoint_bytes("near.toml", SCENE, b"");
                let (_, w) = Checkpoint::from_bytes(&bytes)
                    .expect("a fresh checkpoint parses")
                    .world()
                    .expect("it restores");
                assert!(bits(&w) == bits(&full), "the restored world differs");
                restored = Some(w);
                checkpointed = true;
            }
        }
        assert!(checkpointed);
        // The test covered what it is for: lists made again many times, rebuilds while one
        // lived, and lists shorter than the broad phase's.
        assert!(made > 20, "near lists made: {made}");
        assert!(
            rebuilt_in_life > 3,
            "rebuilds in a near list's life: {rebuilt_in_life}"
        );
        assert!(shorter > 1000, "steps with a shorter list: {shorter}");
    }

    /// Two spheres approaching head-on, each at the same speed, with a gap inside the skin
    /// but outside the near margin when the list is made: both bodies must stop the list
    /// before each has moved half the gap, or the pair touches unseen. (A reach twice too
    /// long lets them meet first: the pile test above, whose other bodies make lists again
    /// often, does not catch that.) Bitwise the run without a near list, every step, through
    /// the collision and the rebound.
    #[test]
    fn a_head_on_pair_is_in_the_near_list_before_it_touches() {
        const PAIR: &str = r#"
[simulation]
steps = 1
dt = 2.0e-5
skin = 0.004
gravity = [0.0, 0.0, 0.0]

[[material]]
name = "glass"
density = 2500.0
stiffness = 2.0e4
restitution = 0.5
friction = 0.5

[container]
min = [0.0, 0.0, 0.0]
max = [0.1, 0.1, 0.1]
material = "glass"

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

[[body]]
shape = "ball"
material = "glass"
position = [0.0435, 0.05, 0.05]
velocity = [0.5, 0.0, 0.0]

[[body]]
shape = "ball"
material = "glass"
position = [0.0565, 0.05, 0.05]
velocity = [-0.5, 0.0, 0.0]
"#;
        let world = || {
            Scene::parse(PAIR, "pair.toml")
                .expect("valid scene")
                .world()
        };
        let (mut near, mut full) = (world(), world());
        // The gap (3 mm) is inside the skin (the broad phase's list holds the pair) and
        // outside the near margin (the near list does not, at first).
        assert!(0.003 < near.skin && 0.003 > super::MARGIN * near.skin);
        let (mut first_touch, mut left_out_first) = (None, false);
        for step in 0..400 {
            let touching = near.step().expect("a stable run").contacts;
            assert_eq!(
                touching,
                reference_step(&mut full),
                "touching at step {step}"
            );
            assert!(
                bits(&near) == bits(&full),
                "the states differ after step {step}"
            );
            let list = near.contacts.near.as_ref().expect("a near list");
            if step == 0 {
                left_out_first = list.slots.is_empty() && near.contacts.pairs.len() == 1;
            }
            if touching > 0 && first_touch.is_none() {
                first_touch = Some(step);
            }
        }
        assert!(
            left_out_first,
            "the pair was not left out of the first near list"
        );
        // Each body moves 1e-5 m a step: they meet after about 150 steps and part again.
        let first = first_touch.expect("the pair never touched");
        assert!((140..160).contains(&first), "first touch at step {first}");
        assert!(
            near.state.velocity[0].x < 0.0,
            "no rebound: {}",
            near.state.velocity[0].x
        );
    }
}

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
        .all(|((x, made), reach2)| {
            let mut ok = true;
            for k in 0..x.len().min(made.len()).min(reach2.len()) {
                let d = x[k] - made[k];
                ok &= d.x * d.x + d.y * d.y + d.z * d.z <= reach2[k];
            }
            ok
        })
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
/// writes it back and makes a new one from the broad phase's list.
pub(crate) fn update(world: &mut World) {
    if !applies(world) {
        world.contacts.end_near();
        return;
    }
    // The springs change this step: the readers' copy is void.
    world.contacts.view = std::sync::OnceLock::new();
    if let Some(near) = &world.contacts.near
        && near.holds(&world.state.position)
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

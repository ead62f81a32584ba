//! The step's per-pair caches (the edge memories, [`World`]'s `edge_memory`: a cache that
//! changes no result), kept cheap to move: carried across a broad-phase rebuild slot by slot
//! ([`carry_by_pair`]), and left out of the run's snapshots ([`World::snapshot_into`]).
//!
//! A memory is several hundred bytes (whole cache lines), 8.4-8.6 MB for the default scene's
//! pairs while it lands (the sizes of the vectors' `mmap`s). Carried into a fresh
//! vector on one thread, every rebuild (one every ~40 steps) paid the kernel's page faults and
//! zeroing for that much new memory, the copy, a default written back into each old slot and
//! the old vector's unmap, while the other thread waited; the run loop's snapshot of the last
//! good state (every 100 steps) cloned those megabytes again, into fresh pages. Now the
//! new list is written in parallel into a spare vector kept from the last rebuild (its pages
//! already mapped), the old vector becomes the next spare, and a snapshot copies no memory.
//! Each slot gets the same value as before, so nothing else changes.

use rayon::prelude::*;

use crate::world::World;

impl World {
    /// Makes `dst` a copy of this world (as `dst.clone_from(self)`) without the edge
    /// memories, which it leaves empty: a cache that changes no result (a world without them
    /// steps to the same bits, measuring again what they would have served), in no
    /// checkpoint, and the largest thing a world holds. For the run loop's snapshot of the last
    /// good state (a blow-up report, `last_good.ckpt`). `&mut self` only to set the memories
    /// aside during the copy; this world keeps them.
    pub fn snapshot_into(&mut self, dst: &mut World) {
        let memory = std::mem::take(&mut self.edge_memory);
        dst.clone_from(self);
        self.edge_memory = memory;
    }
}

/// A vector kept only for its allocation (its contents are stale): the next
/// [`carry_by_pair`] writes into it. Cloning gives an empty one, so a cloned world (a
/// snapshot, a rank's copy) does not copy dead megabytes.
#[derive(Debug, Default)]
pub(crate) struct Spare<T>(Vec<T>);

impl<T> Clone for Spare<T> {
    fn clone(&self) -> Self {
        Spare(Vec::new())
    }
}

/// Slots per parallel task: a slot is a few hundred bytes to copy.
const SLOTS: usize = 256;

/// No old slot: the new pair gets a fresh value.
const FRESH: u32 = u32::MAX;

/// The values of the pairs `new` (sorted) taken from `values`, the values of the pairs `old`
/// (sorted; `values` may be shorter than `old`: a pair past its end has none): each new pair
/// gets its old pair's value, or `T::default()` for a pair not in `old` or without a value.
/// Written into `spare`'s allocation; `values` becomes the spare.
pub(crate) fn carry_by_pair<T: Clone + Default + Send + Sync>(
    old: &[[u32; 2]],
    values: Vec<T>,
    new: &[[u32; 2]],
    spare: &mut Spare<T>,
) -> Vec<T> {
    let from = old_slots(old, values.len(), new);
    let mut out = std::mem::take(&mut spare.0);
    out.clear();
    out.par_extend(from.par_iter().with_min_len(SLOTS).map(|&k| {
        if k == FRESH {
            T::default()
        } else {
            values[k as usize].clone()
        }
    }));
    spare.0 = values;
    out
}

/// For each pair of `new` (sorted), its slot in `old` (sorted) when it is there and below
/// `len`, else [`FRESH`]: one merge of the two lists.
fn old_slots(old: &[[u32; 2]], len: usize, new: &[[u32; 2]]) -> Vec<u32> {
    let mut k = 0;
    new.iter()
        .map(|p| {
            while k < old.len() && old[k] < *p {
                k += 1;
            }
            if k < old.len() && old[k] == *p && k < len {
                k as u32
            } else {
                FRESH
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{Spare, carry_by_pair};
    use crate::world::World;

    /// A small deterministic generator (xorshift), so the test needs no crate.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
    }

    /// Sorted distinct pairs `[i, j]`, `i < j < n`, each of the `n (n-1) / 2` kept with
    /// probability `keep` in 1/1000.
    fn pairs(rng: &mut Rng, n: u32, keep: u64) -> Vec<[u32; 2]> {
        let mut out = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                if rng.next() % 1000 < keep {
                    out.push([i, j]);
                }
            }
        }
        out
    }

    /// Against a lookup of each new pair in the old list, written independently (a binary
    /// search): old and new lists of random pairs (overlapping a lot, a little, not at all,
    /// empty, the same), values shorter than the old list, the spare's stale contents and
    /// sizes (empty, shorter, longer), in pools of 1, 2 and 3 threads; and the old values
    /// become the spare.
    #[test]
    fn each_new_pair_takes_its_old_pairs_value_or_a_fresh_one() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut cases = 0;
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            for round in 0..40 {
                let n = [0, 2, 30, 120, 400][round % 5];
                let old = pairs(&mut rng, n, [0, 50, 300, 1000][round % 4]);
                let new = match round % 6 {
                    0 => old.clone(),
                    1 => Vec::new(),
                    _ => pairs(&mut rng, n, [20, 100, 500, 900][round % 4]),
                };
                // Each old pair's value names it; a value list up to all of `old` long.
                let short = rng.next().is_multiple_of(4) as usize * (rng.next() as usize % 7);
                let len = old.len().saturating_sub(short);
                let values: Vec<u64> = old[..len]
                    .iter()
                    .map(|p| 1 + ((p[0] as u64) << 32 | p[1] as u64))
                    .collect();
                let stale = rng.next() as usize % (2 * new.len() + 3);
                let mut spare = Spare(vec![u64::MAX; stale]);
                let kept = values.clone();
                let got = pool.install(|| carry_by_pair(&old, values, &new, &mut spare));
                assert_eq!(got.len(), new.len());
                for (k, p) in new.iter().enumerate() {
                    let want = match old.binary_search(p) {
                        Ok(slot) if slot < len => kept[slot],
                        _ => 0,
                    };
                    assert_eq!(got[k], want, "pair {p:?}, {threads} threads, round {round}");
                }
                assert_eq!(spare.0, kept, "the old values become the spare");
                cases += new.len();
            }
        }
        assert!(cases > 10_000, "{cases} pairs carried");
    }

    /// A cloned spare holds nothing (a cloned world copies no stale slots).
    #[test]
    fn a_cloned_spare_is_empty() {
        let spare = Spare(vec![7u8; 1000]);
        assert!(spare.clone().0.is_empty());
    }

    /// Every bit of the bodies' state.
    fn state_bits(w: &World) -> Vec<u64> {
        let s = &w.state;
        let mut out = Vec::new();
        for i in 0..w.len() {
            out.extend(s.position[i].to_array().map(f64::to_bits));
            let f32s = [
                s.velocity[i].to_array().as_slice(),
                &s.orientation[i].to_array(),
                &s.angular_momentum[i].to_array(),
                &s.orientation_residual[i].to_array(),
            ]
            .concat();
            out.extend(f32s.iter().map(|v| v.to_bits() as u64));
        }
        out
    }

    /// A snapshot of a poured mixed pile (polyhedra and spheres landing, rebuilds carrying
    /// the edge memories): the snapshot has the world's checkpoint bytes and no memories,
    /// the world keeps its memories, and the snapshot, the world and a full clone stepped
    /// on through more rebuilds stay bitwise equal (the memories change no result).
    #[test]
    fn a_snapshot_without_the_memories_steps_to_the_same_bits() {
        use crate::pile::{PileParams, PileShape, poured};
        let params = PileParams {
            restitution: 0.1,
            ..PileParams::default()
        };
        let mut world = World::new(poured(PileShape::Mixed, 240, &params, 5));
        for _ in 0..2500 {
            world.step().expect("a finite step");
        }
        let remembered = world.edge_memory.len();
        assert!(
            remembered > 150 && world.rebuilds > 5,
            "{remembered} memories"
        );
        let mut clone = world.clone();
        let mut snap = World::new(poured(PileShape::Sphere, 3, &params, 1));
        world.snapshot_into(&mut snap);
        assert_eq!(
            world.edge_memory.len(),
            remembered,
            "the world keeps its memories"
        );
        assert!(snap.edge_memory.is_empty());
        let bytes = |w: &World| w.checkpoint_bytes("pile", "", b"");
        assert_eq!(bytes(&snap), bytes(&world));
        let rebuilds = world.rebuilds;
        for _ in 0..600 {
            for w in [&mut world, &mut clone, &mut snap] {
                w.step().expect("a finite step");
            }
        }
        assert!(
            world.rebuilds > rebuilds,
            "a rebuild carried the memories on"
        );
        assert_eq!(snap.rebuilds, world.rebuilds);
        assert_eq!(state_bits(&snap), state_bits(&world));
        assert_eq!(state_bits(&clone), state_bits(&world));
    }
}

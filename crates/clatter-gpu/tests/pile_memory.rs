//! The GPU's pair memory on real poured piles (issue 23, point 3, on the GPU executor): the
//! WGSL narrow phase with what each touching polyhedron pair remembers (`narrow_poly.wgsl`
//! with `nrw_mem_in`, through `NarrowBatch::collide_remembering`) against the WGSL full test
//! on the same poses, at every step of piles of every shape kind.
//!
//! The piles are the CPU test's (`clatter/tests/pair_memory.rs`): poured into their box with
//! random orientations and speeds, every 16th body spun fast, so pairs land, slide, roll,
//! tumble, go from face contacts to edge and vertex contacts and back, and part and touch
//! again. The CPU steps them; in windows of steps spread over pouring, landing and settling,
//! every polyhedron pair of the contact list goes to the GPU twice per step, once with its memory (carried from the GPU's own answers of earlier steps, its
//! margin less twice a bound of how far the pair moved) and once without. The remembering
//! manifolds must equal the full test's; the full test must equal the CPU's to rounding
//! (near-ties excused as in `narrow.rs`).

mod common;

use common::*;

use clatter::World;
use clatter::geom::narrow::{self, NO_HINT};
use clatter::geom::{Pose, PreparedShape, RegularKind, Shape, ShapeKind};
use clatter::pile::{PileParams, PileShape, poured};
use clatter_gpu::{GpuShapes, NarrowBatch, NarrowQuery, PairMemory};
use glam::Vec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;

/// One poured pile, stepped on the CPU, and where its shapes start in the shared upload.
struct Pile {
    name: String,
    world: World,
    shape_base: u32,
    /// Whether each of its shapes is generic (a hull or a sphere: no exact ties by symmetry).
    generic: Vec<bool>,
}

/// A poured pile of `n` bodies of `kinds` (in turn; the bench's mixed pile when empty), every
/// 16th spun fast, as in the CPU test; its shapes are appended to `shapes`.
fn pile(name: &str, kinds: &[ShapeKind], n: usize, shapes: &mut Vec<PreparedShape>) -> Pile {
    let shape = if kinds.is_empty() {
        PileShape::Mixed
    } else {
        PileShape::Cube
    };
    let params = PileParams {
        restitution: 0.1,
        ..PileParams::default()
    };
    let mut desc = poured(shape, n, &params, 11);
    let mut generic = vec![false; desc.shapes.len()];
    if !kinds.is_empty() {
        desc.shapes = kinds.iter().map(|k| k.prepare().expect("shape")).collect();
        generic = kinds
            .iter()
            .map(|k| !matches!(k, ShapeKind::Regular { .. }))
            .collect();
        for (i, b) in desc.bodies.iter_mut().enumerate() {
            b.shape = (i % kinds.len()) as u32;
        }
    }
    for (i, b) in desc.bodies.iter_mut().enumerate().step_by(16) {
        let f = i as f32;
        b.angular_velocity = Vec3::new(f.sin(), f.cos(), 0.5) * 150.0;
    }
    let shape_base = shapes.len() as u32;
    shapes.extend(desc.shapes.iter().cloned());
    Pile {
        name: name.to_string(),
        world: World::new(desc),
        shape_base,
        generic,
    }
}

/// What a pair carries from step to step here: its GPU memory and last poses, and whether
/// it touched last step and has parted since touching.
struct Carried {
    memory: PairMemory,
    poses: (Pose, Pose),
    points: usize,
    parted: bool,
}

#[derive(Default, Debug)]
struct Tally {
    /// Polyhedron pair-steps the full test found touching.
    touching: usize,
    /// ... of which the GPU took a remembered path (the memory came back unchanged).
    remembered: usize,
    /// ... of which a remembered edge contact (the rest: a remembered face).
    remembered_edge: usize,
    /// Changes of a pair between a one-point contact (edge or vertex) and a patch.
    kind_changes: usize,
    /// Pairs that touched again after parting.
    retouched: usize,
}

#[test]
fn gpu_pair_memory_matches_the_full_test_on_poured_piles() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let r = 0.01;
    let regular = |kind| ShapeKind::Regular { kind, radius: r };
    // A hull of scattered points (the CPU test's): many faces of different sizes.
    let hull = ShapeKind::Convex {
        points: (0..40)
            .map(|k| {
                let f = k as f64;
                let (th, ph) = (f * 2.399_963, (1.0 - 2.0 * (f + 0.5) / 40.0).acos());
                let s = 1.0 + 0.25 * (f * 1.7).sin();
                [
                    r * ph.sin() * th.cos() * s,
                    r * 0.8 * ph.sin() * th.sin(),
                    r * 0.6 * ph.cos() * s,
                ]
            })
            .collect(),
    };
    let n = 48;
    let mut shapes = Vec::new();
    let mut piles: Vec<Pile> = RegularKind::ALL
        .iter()
        .map(|&k| pile(&format!("{k:?}"), &[regular(k)], n, &mut shapes))
        .collect();
    piles.push(pile("hull", std::slice::from_ref(&hull), n, &mut shapes));
    piles.push(pile("mixed", &[], n, &mut shapes));
    let sphere = ShapeKind::Sphere { radius: r };
    piles.push(pile("hull and spheres", &[hull, sphere], n, &mut shapes));
    let gpu_shapes = GpuShapes::upload(&ctx, &shapes).expect("upload");
    let batch = NarrowBatch::new(&ctx).expect("compile the narrow phase");
    let is_poly = |s: &Shape| matches!(s, Shape::Polyhedron(_));

    let steps = 7000;
    const WINDOW: usize = 250;
    const WINDOW_EVERY: usize = 1750;
    let mut carried: Vec<HashMap<[u32; 2], Carried>> =
        piles.iter().map(|_| HashMap::new()).collect();
    let mut tally = Tally::default();
    let mut stats = Stats::default();
    let mut rng = ChaCha8Rng::seed_from_u64(0x7069_6c65);
    let t = std::time::Instant::now();
    for step in 0..steps {
        // Checked in windows spread over pouring, landing and settling (the steps between
        // are stepped on the CPU alone, and each window starts with nothing remembered).
        let checked = step % WINDOW_EVERY < WINDOW;
        // This step's polyhedron pairs of every pile: (pile, bodies, poses, memory).
        let mut work = Vec::new();
        for (p, pile) in piles.iter_mut().enumerate() {
            if !checked {
                carried[p].clear();
                continue;
            }
            let w = &mut pile.world;
            if w.needs_rebuild() {
                w.rebuild_contacts();
            }
            let mut next = HashMap::new();
            for &[i, j] in w.contacts.pairs() {
                let (iu, ju) = (i as usize, j as usize);
                if !is_poly(w.shape(iu)) || !is_poly(w.shape(ju)) {
                    continue;
                }
                let poses = (w.local_pose(iu), w.pose_from(iu, ju));
                let before = carried[p].remove(&[i, j]);
                let mut memory = PairMemory::default();
                let (mut points, mut parted) = (0, false);
                if let Some(c) = before {
                    memory = c.memory;
                    if memory.hint != NO_HINT {
                        let reach = w.consts.radius[iu] + w.consts.radius[ju];
                        let (a0, b0) = c.poses;
                        memory.margin -= 2.0 * axis_motion(&a0, &b0, &poses.0, &poses.1, reach);
                    }
                    (points, parted) = (c.points, c.parted);
                }
                work.push((p, [i, j], poses, memory));
                next.insert(
                    [i, j],
                    Carried {
                        memory,
                        poses,
                        points,
                        parted,
                    },
                );
            }
            carried[p] = next;
        }
        if !work.is_empty() {
            let query = |&(p, [i, j], (pa, pb), _): &(usize, [u32; 2], (Pose, Pose), _)| {
                let w = &piles[p].world;
                let base = piles[p].shape_base;
                NarrowQuery {
                    shape_a: base + w.consts.shape[i as usize],
                    pose_a: pa,
                    shape_b: base + w.consts.shape[j as usize],
                    pose_b: pb,
                }
            };
            let mut queries: Vec<NarrowQuery> = work.iter().map(query).collect();
            queries.extend_from_within(..);
            let mut memory: Vec<PairMemory> = work.iter().map(|w| w.3).collect();
            memory.extend(std::iter::repeat_n(PairMemory::default(), work.len()));
            let gpu = batch
                .collide_remembering(&ctx, &gpu_shapes, &queries, &mut memory)
                .expect("GPU batch");
            let m = work.len();
            for (s, &(p, [i, j], (pa, pb), before)) in work.iter().enumerate() {
                let (remembering, full) = (&gpu[s], &gpu[m + s]);
                let pile = &piles[p];
                let label = format!("{}: step {step}, pair {i}-{j}", pile.name);
                assert_eq!(
                    remembering, full,
                    "{label}: the remembering GPU path differs from the full test (memory {before:?} -> {:?})",
                    memory[s]
                );
                let touching = full.count > 0;
                let c = carried[p].get_mut(&[i, j]).expect("carried");
                c.memory = if touching {
                    memory[s]
                } else {
                    PairMemory::default()
                };
                if touching {
                    tally.touching += 1;
                    if narrow::is_contact_hint(before.hint) && before == memory[s] {
                        tally.remembered += 1;
                        tally.remembered_edge +=
                            (before.hint == narrow::HINT_EDGE_CONTACT) as usize;
                    }
                    if c.points > 0 && (c.points == 1) != (full.count == 1) {
                        tally.kind_changes += 1;
                    }
                    if c.parted {
                        tally.retouched += 1;
                        c.parted = false;
                    }
                    c.points = full.count;
                } else {
                    c.parted |= c.points > 0;
                    c.points = 0;
                }
                // The GPU's full test against the CPU's on the same poses.
                let w = &pile.world;
                let (a, b) = (w.shape(i as usize), w.shape(j as usize));
                let eval = |pa: &Pose, pb: &Pose| narrow::collide(a, pa, b, pb);
                let size = a.bounding_radius().max(b.bounding_radius());
                let generic = pile.generic[w.consts.shape[i as usize] as usize]
                    && pile.generic[w.consts.shape[j as usize] as usize];
                stats.check(
                    generic,
                    &label,
                    eval(&pa, &pb),
                    full,
                    size,
                    &eval,
                    &pa,
                    &pb,
                    &mut rng,
                );
            }
        }
        for pile in &mut piles {
            pile.world.step().expect("CPU step");
        }
    }
    eprintln!(
        "{steps} steps of {} piles on {} in {:.1} s: {tally:?}; against the CPU: {} tested, {} near-ties, {} hard",
        piles.len(),
        ctx.adapter_name(),
        t.elapsed().as_secs_f64(),
        stats.tested,
        stats.near_ties,
        stats.hard.len()
    );
    for h in stats.hard.iter().take(20) {
        eprintln!("  {h}");
    }
    assert!(
        stats.hard.is_empty(),
        "{} hard mismatches against the CPU",
        stats.hard.len()
    );
    assert!(stats.near_ties * 25 <= stats.tested, "too many near-ties");
    assert!(tally.touching >= 100_000, "{tally:?}");
    assert!(tally.remembered >= 30_000, "{tally:?}");
    assert!(
        tally.remembered_edge > 0 && tally.remembered_edge < tally.remembered,
        "both remembered paths: {tally:?}"
    );
    assert!(tally.kind_changes >= 100, "{tally:?}");
    assert!(tally.retouched >= 40, "{tally:?}");
}

//! The GPU's apart pairs skipped by their gap (issue 23): `contacts_sat` keeps, for each
//! pair it proves apart, a lower bound of the bodies' distance, takes off both bodies'
//! motion bound (written by integrate) every step, and skips the pair while that stays
//! positive (contacts_split.wgsl `pair_apart`). Checked on a settling poured pile of the
//! five Platonic solids and spheres, step by step, against independent truth:
//! - every gap kept is at most the bodies' distance at that step, measured by parry3d's
//!   f64 distance query (an independent library) on the same poses;
//! - every body's motion bound is at least how far any of its points moved in the step
//!   (each vertex before and after, in f64; a sphere's centre plus its radius times the
//!   turn);
//! - a pair skipped holds exactly its gap less both bounds, and the skip really happens
//!   (most of the pile's pairs apart are skipped on most steps);
//! - the world that skips stays bitwise equal, body by body, to one that tests every pair
//!   (`GpuWorld::set_full_test`).

use clatter::World;
use clatter::geom::Shape;
use clatter::pile::{PileParams, PileShape, poured};
use clatter_gpu::GpuWorld;
use glam::{DQuat, DVec3, Quat, Vec3};
use parry3d_f64::math::{Pose as PPose, Rot3 as PRot, Vector as PVec};
use parry3d_f64::query as pq;
use parry3d_f64::shape::{Ball, ConvexPolyhedron, Shape as PShape};

/// A stage buffer as words.
fn words(gpu: &GpuWorld, name: &str) -> Vec<u32> {
    bytemuck::pod_collect_to_vec(&gpu.debug_buffer(name).expect("stage buffer"))
}

/// Each pair's gap (`x` of `new_hist` outside a rebuild).
fn gaps(gpu: &GpuWorld, np: usize) -> Vec<f32> {
    let w = words(gpu, "new_hist");
    (0..np).map(|k| f32::from_bits(w[4 * k])).collect()
}

/// Each body's last motion bound (`w` of `rebuild_pos`).
fn moved(gpu: &GpuWorld, n: usize) -> Vec<f32> {
    let w = words(gpu, "rebuild_pos");
    (0..n).map(|i| f32::from_bits(w[4 * i + 3])).collect()
}

fn pv(v: DVec3) -> PVec {
    PVec::new(v.x, v.y, v.z)
}

/// Body `i`'s shape for parry, in its principal frame.
fn parry_shape(w: &World, i: usize) -> Box<dyn PShape> {
    match w.shape(i) {
        Shape::Sphere { radius } => Box::new(Ball::new(*radius as f64)),
        Shape::Polyhedron(p) => {
            let pts: Vec<PVec> = p.vertices.iter().map(|v| pv(v.as_dvec3())).collect();
            Box::new(ConvexPolyhedron::from_convex_hull(&pts).expect("a Platonic solid's hull"))
        }
        other => panic!("unexpected shape {other:?}"),
    }
}

/// Body `j`'s pose seen from body `i` (the offset the GPU uses), in f64 for parry.
fn ppose(offset: Vec3, q: Quat) -> PPose {
    let q = q.as_dquat().normalize();
    PPose::from_parts(pv(offset.as_dvec3()), PRot::from_xyzw(q.x, q.y, q.z, q.w))
}

/// How far body `i`'s farthest point moved between `a` and `b` (f64): each vertex of a
/// polyhedron, and a sphere's centre plus its radius times the angle turned.
fn displacement(a: &World, b: &World, i: usize) -> f64 {
    let (xa, xb) = (a.state.position[i], b.state.position[i]);
    let (qa, qb): (DQuat, DQuat) = (
        a.state.orientation[i].as_dquat().normalize(),
        b.state.orientation[i].as_dquat().normalize(),
    );
    match a.shape(i) {
        Shape::Sphere { radius } => (xb - xa).length() + *radius as f64 * qa.angle_between(qb),
        Shape::Polyhedron(p) => p
            .vertices
            .iter()
            .map(|v| {
                let v = v.as_dvec3();
                ((xb + qb * v) - (xa + qa * v)).length()
            })
            .fold(0.0, f64::max),
        other => panic!("unexpected shape {other:?}"),
    }
}

#[test]
fn apart_pairs_are_skipped_only_while_their_gap_holds() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let params = PileParams {
        restitution: 0.3,
        ..PileParams::default()
    };
    let mut cpu = World::new(poured(PileShape::Mixed, 192, &params, 5));
    // Still falling and settling: bodies that move, turn, meet and part.
    for _ in 0..2500 {
        cpu.step().expect("CPU step");
    }
    let n = cpu.len();
    let shapes: Vec<Box<dyn PShape>> = (0..n).map(|i| parry_shape(&cpu, i)).collect();
    let mut gpu = GpuWorld::new(ctx.clone(), &cpu).expect("scene fits");
    let mut full = GpuWorld::new(ctx, &cpu).expect("scene fits");
    full.set_full_test(true);
    let (mut before, mut after) = (cpu.clone(), cpu.clone());
    // Pair-steps apart (not touching before the step), skipped, and gaps checked.
    let (mut apart, mut skipped, mut checked) = (0usize, 0usize, 0usize);
    // The smallest room a checked gap left below the distance, relative to the radii.
    let mut least_room = f64::INFINITY;
    let steps = 160;
    for step in 0..steps {
        gpu.read_into(&mut before).expect("read-back");
        let np = gpu.pairs();
        let pairs = words(&gpu, "pairs");
        let touching = words(&gpu, "touching");
        let (g0, m0) = (gaps(&gpu, np), moved(&gpu, n));
        // Every gap kept (at the poses of the last step's test) less both bodies' motion
        // since is at most the distance at these poses: what a skip stands on.
        for k in 0..np {
            let (i, j) = (pairs[2 * k] as usize, pairs[2 * k + 1] as usize);
            if g0[k] > 0.0 {
                assert_ne!(touching[k], 1, "step {step}: touching pair {k} keeps a gap");
            }
            let left = g0[k] - (m0[i] + m0[j]);
            if g0[k] > 0.0 && left > 0.0 {
                let d = pq::distance(
                    &ppose(Vec3::ZERO, before.state.orientation[i]),
                    &*shapes[i],
                    &ppose(before.offset_of(i, j), before.state.orientation[j]),
                    &*shapes[j],
                )
                .expect("distance")
                .distance;
                let room = (d - left as f64) / (cpu.consts.radius[i] + cpu.consts.radius[j]) as f64;
                assert!(
                    room >= 0.0,
                    "step {step}: pair {k} ({i}, {j}) keeps a gap of {} (less the motion {left}) but is {d} apart",
                    g0[k]
                );
                least_room = least_room.min(room);
                checked += 1;
            }
        }
        let rebuilds = gpu.rebuilds();
        gpu.step(1).expect("GPU step");
        full.step(1).expect("GPU step, full test");
        let (a, b) = (gpu.read_states().unwrap(), full.read_states().unwrap());
        assert!(
            bytemuck::cast_slice::<_, u8>(&a) == bytemuck::cast_slice::<_, u8>(&b),
            "step {step}: the world that skips pairs differs from the one that tests them"
        );
        // Every body's bound covers its motion in the step.
        gpu.read_into(&mut after).expect("read-back");
        let m1 = moved(&gpu, n);
        for i in 0..n {
            let moved = displacement(&before, &after, i);
            assert!(
                moved <= m1[i] as f64,
                "step {step}: body {i} moved {moved}, beyond its bound {}",
                m1[i]
            );
        }
        if gpu.rebuilds() != rebuilds {
            continue;
        }
        // A pair skipped holds its gap less both bounds, bitwise.
        let g1 = gaps(&gpu, np);
        for k in 0..np {
            if touching[k] == 1 {
                continue;
            }
            apart += 1;
            let (i, j) = (pairs[2 * k] as usize, pairs[2 * k + 1] as usize);
            let left = g0[k] - (m0[i] + m0[j]);
            if g0[k] > 0.0 && left > 0.0 {
                skipped += 1;
                assert_eq!(
                    g1[k].to_bits(),
                    left.to_bits(),
                    "step {step}: pair {k} skipped with gap {} and bounds {} {}",
                    g0[k],
                    m0[i],
                    m0[j]
                );
            }
        }
    }
    eprintln!(
        "{apart} pair-steps apart, {skipped} skipped; {checked} gaps checked, least room {least_room:.3e} of the radii"
    );
    // After the first step proves them apart, most pairs apart are skipped.
    assert!(
        skipped * 2 > apart,
        "only {skipped} of {apart} pair-steps apart were skipped"
    );
    assert!(checked > 1000, "only {checked} gaps checked");
}

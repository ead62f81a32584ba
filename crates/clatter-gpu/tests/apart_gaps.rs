//! The GPU's apart pairs skipped by their gap (issue 23): `contacts_sat` keeps, for each
//! pair it proves apart, a lower bound of the bodies' distance, takes off both bodies'
//! motion bound (written by integrate) every step, and skips the pair while that stays
//! positive (contacts_split.wgsl `pair_quick`). Checked on a settling poured pile of the
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

/// The world that skips pairs (`gpu`) and the one that tests every pair (`full`) hold the
/// same body states, bitwise.
fn assert_same_bodies(gpu: &GpuWorld, full: &GpuWorld, step: usize) {
    let (a, b) = (gpu.read_states().unwrap(), full.read_states().unwrap());
    assert!(
        bytemuck::cast_slice::<_, u8>(&a) == bytemuck::cast_slice::<_, u8>(&b),
        "step {step}: the world that skips pairs differs from the one that tests them"
    );
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
    // ... of which a sphere against a polyhedron (proved apart by a face plane, or by the
    // bounding spheres).
    let (mut sphere_apart, mut sphere_skipped) = (0usize, 0usize);
    let is_sphere = |i: usize| matches!(cpu.shape(i), Shape::Sphere { .. });
    // The smallest room a checked gap left below the distance, relative to the radii.
    let mut least_room = f64::INFINITY;
    // Pair-steps the full phase ran at a remembered contact (`GpuWorld::full_phase`).
    let mut remembered = 0usize;
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
        assert_same_bodies(&gpu, &full, step);
        // Every body's bound covers its motion in the step.
        gpu.read_into(&mut after).expect("read-back");
        check_full_phase(&gpu, &full, &after, step, &mut remembered);
        let m1 = moved(&gpu, n);
        for (i, &bound) in m1.iter().enumerate() {
            let moved = displacement(&before, &after, i);
            assert!(
                moved <= bound as f64,
                "step {step}: body {i} moved {moved}, beyond its bound {bound}"
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
            let with_sphere = is_sphere(i) != is_sphere(j);
            sphere_apart += with_sphere as usize;
            let left = g0[k] - (m0[i] + m0[j]);
            if g0[k] > 0.0 && left > 0.0 {
                skipped += 1;
                sphere_skipped += with_sphere as usize;
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
        "{apart} pair-steps apart, {skipped} skipped ({sphere_apart} and {sphere_skipped} of a sphere and a polyhedron); {checked} gaps checked, least room {least_room:.3e} of the radii"
    );
    // After the first step proves them apart, most pairs apart are skipped.
    assert!(
        skipped * 2 > apart,
        "only {skipped} of {apart} pair-steps apart were skipped"
    );
    assert!(
        sphere_skipped * 2 > sphere_apart,
        "only {sphere_skipped} of {sphere_apart} pair-steps of a sphere and a polyhedron apart were skipped"
    );
    assert!(checked > 1000, "only {checked} gaps checked");
    assert!(
        remembered > 100,
        "only {remembered} remembered contacts counted"
    );
}

/// `GpuWorld::full_phase` after a step of both worlds (`world`: their bodies after it):
/// every pair touching after the step was one the full phase ran (pairs with a sphere body
/// among those with a sphere, the others among the polyhedron paths), and the world that
/// tests every pair (`set_full_test`) ran no remembered contact. Adds the remembering
/// world's remembered contacts to `remembered`.
fn check_full_phase(
    gpu: &GpuWorld,
    full: &GpuWorld,
    world: &World,
    step: usize,
    remembered: &mut usize,
) {
    let (f, t) = (gpu.full_phase().unwrap(), full.full_phase().unwrap());
    assert_eq!(
        (t.remembered_faces, t.remembered_edges),
        (0, 0),
        "step {step}: the full-test world ran remembered contacts: {t:?}"
    );
    let c = gpu.contact_state().expect("contacts");
    let sphere = |i: u32| matches!(world.shape(i as usize), Shape::Sphere { .. });
    let (mut with_sphere, mut poly) = (0u32, 0u32);
    for (p, &touching) in c.pairs.iter().zip(&c.touching) {
        if touching {
            if sphere(p[0]) || sphere(p[1]) {
                with_sphere += 1;
            } else {
                poly += 1;
            }
        }
    }
    for (name, p) in [("remembering", f), ("full test", t)] {
        assert!(
            with_sphere <= p.with_sphere
                && poly <= p.full_tests + p.remembered_faces + p.remembered_edges,
            "step {step}, {name}: {with_sphere} touching pairs with a sphere and {poly} without, but the full phase ran {p:?}"
        );
    }
    *remembered += (f.remembered_faces + f.remembered_edges) as usize;
}

/// Composites (clumps of spheres and a box) drifting across the seams of a periodic box,
/// onto a floor and into a sink: a pair of pieces is skipped by its own gap (the bodies'
/// bounds cover their pieces, which lie within the bounding radius), through the nearest
/// image. The world that skips stays bitwise equal, body by body, to one that tests every
/// pair, at every step, and pairs are skipped.
#[test]
fn composite_pairs_across_periodic_seams_skip_with_the_same_bits() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/test.toml");
    let text = r#"[simulation]
steps = 2000
dt = 2.0e-5
periodic = { min = [0.0, 0.0, 0.0], max = [0.08, 0.08, 0.1], axes = "xy" }
gravity = [0.0, 0.0, -9.81]
[[material]]
name = "m"
density = 2500.0
stiffness = 1.0e4
restitution = 0.3
friction = 0.5
[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "m"
[[sink]]
min = [0.0, 0.0, 0.0]
max = [0.02, 0.02, 0.012]
[[shape]]
name = "ball"
sphere = { radius = 0.005 }
[[shape]]
name = "cube"
box = { half_extents = [0.004, 0.004, 0.004] }
[[shape]]
name = "peanut"
composite = [ { shape = "ball", offset = [-0.003, 0.0, 0.0] },
              { shape = "ball", offset = [0.003, 0.0, 0.0] } ]
[[shape]]
name = "hammer"
composite = [ { shape = "ball", offset = [-0.005, 0.0, 0.0] },
              { shape = "cube", offset = [0.004, 0.0, 0.0] } ]
[[group]]
shape = "peanut"
material = "m"
random = { min = [0.0, 0.0, 0.01], max = [0.08, 0.08, 0.09], count = 20, seed = 11 }
random_orientation = true
velocity = [1.5, 0.8, -0.2]
[[group]]
shape = "hammer"
material = "m"
random = { min = [0.0, 0.0, 0.01], max = [0.08, 0.08, 0.09], count = 12, seed = 12 }
random_orientation = true
velocity = [-1.2, 0.5, -0.3]
[[group]]
shape = "cube"
material = "m"
random = { min = [0.0, 0.0, 0.01], max = [0.08, 0.08, 0.09], count = 12, seed = 13 }
random_orientation = true
angular_velocity = [0.0, 0.0, 60.0]
"#;
    let scene = clatter::scene::Scene::parse(text, &file.display().to_string())
        .unwrap_or_else(|e| panic!("{e}"));
    let world = scene.world();
    let mut gpu = GpuWorld::new(ctx.clone(), &world).expect("scene fits");
    let mut full = GpuWorld::new(ctx, &world).expect("scene fits");
    full.set_full_test(true);
    let (mut skipped, mut apart) = (0usize, 0usize);
    for step in 0..2000 {
        let np = gpu.pairs();
        let (touching, g0) = (words(&gpu, "touching"), gaps(&gpu, np));
        let m0 = moved(&gpu, world.len());
        let pairs = words(&gpu, "pairs");
        let rebuilds = gpu.rebuilds();
        gpu.step(1).expect("GPU step");
        full.step(1).expect("GPU step, full test");
        assert_same_bodies(&gpu, &full, step);
        if gpu.rebuilds() != rebuilds {
            continue;
        }
        for k in 0..np {
            // Pair entries carry piece codes above the body index.
            let body = (1u32 << clatter_gpu::shapes::PIECE_SHIFT) - 1;
            let (i, j) = (pairs[2 * k] & body, pairs[2 * k + 1] & body);
            if touching[k] != 1 {
                apart += 1;
                let left = g0[k] - (m0[i as usize] + m0[j as usize]);
                skipped += (g0[k] > 0.0 && left > 0.0) as usize;
            }
        }
    }
    eprintln!("{apart} piece pair-steps apart, {skipped} skipped");
    assert!(skipped * 4 > apart, "only {skipped} of {apart} skipped");
    // Bodies crossed the seams (or were wrapped there), and the sink took bodies (their
    // pairs went with the rebuilds): the runs stayed equal through both.
    let end = gpu.read_states().unwrap();
    let crossed = (0..world.len())
        .filter(|&i| (end[i].position[0] as f64 - world.state.position[i].x).abs() > 0.03)
        .count();
    let removed = end.iter().filter(|s| s.position[3] != 0.0).count();
    eprintln!("{crossed} bodies crossed a seam, {removed} in the sink");
    assert!(
        crossed > 0 && removed > 0,
        "{crossed} crossed, {removed} removed"
    );
}

//! Composite bodies (clumps) against triangle-mesh boundaries on the GPU, against the CPU
//! pipeline (crates/clatter/src/step/mesh_contacts.rs: each piece against its body's candidate
//! triangles, the contacts matched to the body's mesh slots by boundary, piece and normal):
//! - a two-sphere clump and a sphere-and-cube clump landing, resting and sliding on a
//!   200-triangle mesh floor follow the CPU's trajectories with the same touching contacts
//!   and the same mesh slots (boundary, piece, touching flag), with the linear law and with
//!   Hertz's (whose stiffness takes each piece's own radius);
//! - 30 clumps tumbling in a drum (scenes/meshes/drum.stl), fixed and turning, do too;
//! - a denser load in the drum, compared step by step: the same slots and forces;
//! - GPU runs are bitwise reproducible;
//! - a GPU run read back and written to a checkpoint resumes on the CPU with its per-piece
//!   mesh springs, and goes on as the CPU run;
//! - the device's last good state (a blow-up report's `last_good.ckpt`) holds the mesh
//!   slots and the rebuild orientations, and resumes as the full read-back does;
//! - `--backend gpu` takes such scenes.
//!
//! The tolerances follow tests/composite.rs: positions and orientations within `max(tol,
//! 2 d)` where `d` is how far a second CPU run whose positions start 1 ulp off (in x) and
//! orientations 16 ulps off departs from the CPU run (how far f32 rounding alone carries
//! the scene); `tol` covers the first comparisons, before the nudge has grown (and the
//! turning drum, see there); touching counts and mesh slots exactly equal. Measured on
//! lavapipe: on the floor the GPU stays within the nudged run's own departure (2.1e-7 m
//! against 2.6e-7 m after 8000 steps).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use clatter::World;
use clatter::checkpoint::Checkpoint;
use clatter::scene::Scene;
use clatter_gpu::GpuWorld;

#[path = "../../clatter/tests/common/meshes.rs"]
mod meshes;

const MATERIAL: &str = r#"
[[material]]
name = "m"
density = 2500.0
stiffness = 2.0e4
restitution = 0.3
friction = 0.4
"#;

/// The two clump shapes: two spheres of 10 mm, and a sphere of 10 mm with a cube of 8 mm
/// half-edge beside it (turned, so its faces are not along the clump's axes).
const CLUMPS: &str = r#"
[[shape]]
name = "ball"
sphere = { radius = 0.01 }
[[shape]]
name = "block"
box = { half_extents = [0.008, 0.008, 0.008] }
[[shape]]
name = "pair"
composite = [ { shape = "ball", offset = [-0.008, 0.0, 0.0] },
              { shape = "ball", offset = [0.008, 0.0, 0.0] } ]
[[shape]]
name = "hammer"
composite = [ { shape = "ball", offset = [-0.01, 0.0, 0.0] },
              { shape = "block", offset = [0.009, 0.0, 0.0], orientation = [0.9950042, 0.0, 0.0, 0.0998334] } ]
"#;

/// The same clumps at 0.4 times the size, for the drum.
const SMALL_CLUMPS: &str = r#"
[[shape]]
name = "ball"
sphere = { radius = 0.004 }
[[shape]]
name = "block"
box = { half_extents = [0.0032, 0.0032, 0.0032] }
[[shape]]
name = "pair"
composite = [ { shape = "ball", offset = [-0.0032, 0.0, 0.0] },
              { shape = "ball", offset = [0.0032, 0.0, 0.0] } ]
[[shape]]
name = "hammer"
composite = [ { shape = "ball", offset = [-0.004, 0.0, 0.0] },
              { shape = "block", offset = [0.0036, 0.0, 0.0], orientation = [0.9950042, 0.0, 0.0, 0.0998334] } ]
"#;

/// A flat square floor `z = 0` over `[-h, h]^2` of `n x n` squares, two triangles each,
/// alternating the diagonal, written as an OBJ file; returns its path.
fn floor_obj(n: usize, h: f64) -> PathBuf {
    let (v, t) = meshes::floor_mesh(n, h);
    let s = meshes::obj_text(&v, &t);
    // Written under a name of its own and renamed into place, so that tests running at once
    // never read a half-written file.
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join(format!("composite_mesh_floor_{n}.obj"));
    let tmp = dir.join(format!(
        "composite_mesh_floor_{n}.{}.{:?}.tmp",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::write(&tmp, s).expect("write the floor mesh");
    std::fs::rename(&tmp, &path).expect("move the floor mesh into place");
    path
}

/// Where the test scenes say they are: relative mesh paths resolve from the scenes folder.
fn scene_path() -> String {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/test.toml");
    file.display().to_string()
}

fn parse(text: &str) -> Scene {
    Scene::parse(text, &scene_path()).unwrap_or_else(|e| panic!("{e}"))
}

/// A floor scene: the 200-triangle floor and the given bodies, of `material`.
fn floor_scene(bodies: &str, material: &str) -> String {
    let floor = floor_obj(10, 0.5);
    assert_eq!(
        std::fs::read_to_string(&floor)
            .unwrap()
            .lines()
            .filter(|l| l.starts_with("f "))
            .count(),
        200
    );
    format!(
        r#"[simulation]
steps = 10
dt = 2.0e-5
gravity = [0.0, 0.0, -9.81]
{material}{CLUMPS}
[[boundary]]
mesh = {{ file = "{}" }}
material = "m"
{bodies}"#,
        floor.display()
    )
}

/// A closed drum (scenes/meshes/drum.stl scaled to radius 80 mm, 90 mm long, axis y, 192
/// triangles) turning at `omega` rad/s with `count` small clumps of each kind dropped in its
/// lower half.
fn drum_scene(count: usize, omega: f32) -> String {
    format!(
        r#"[simulation]
steps = 10
dt = 2.0e-5
gravity = [0.0, 0.0, -9.81]
{MATERIAL}{SMALL_CLUMPS}
[[boundary]]
mesh = {{ file = "meshes/drum.stl", scale = [1.6, 3.0, 1.6] }}
material = "m"
motion = {{ angular_velocity = [0.0, {omega:?}, 0.0], center = [0.0, 0.0, 0.0] }}

[[group]]
shape = "pair"
material = "m"
random = {{ min = [-0.04, -0.033, -0.052], max = [0.04, 0.033, -0.01], count = {count}, seed = 4 }}
random_orientation = true

[[group]]
shape = "hammer"
material = "m"
random = {{ min = [-0.04, -0.033, -0.052], max = [0.04, 0.033, 0.02], count = {count}, seed = 5 }}
random_orientation = true
"#
    )
}

/// The touching mesh slots of a world: (body, slot, boundary, piece).
fn mesh_touching(w: &World) -> BTreeSet<(usize, usize, u32, u32)> {
    let slots = w.mesh_slots();
    let per = clatter::mesh_boundary::MESH_SLOTS;
    (0..slots.len())
        .filter(|&k| slots[k].touching)
        .map(|k| (k / per, k % per, slots[k].boundary, slots[k].piece))
        .collect()
}

/// Largest distance between the two worlds' body positions, and between the bodies'
/// orientations (quaternion distance, sign-free).
fn distance(a: &World, b: &World) -> (f32, f32) {
    let mut dx = 0.0f32;
    let mut dq = 0.0f32;
    for i in 0..a.len() {
        dx = dx.max((a.state.position[i] - b.state.position[i]).length() as f32);
        let (qa, qb) = (a.state.orientation[i], b.state.orientation[i]);
        dq = dq.max((qa - qb).length().min((qa + qb).length()));
    }
    (dx, dq)
}

/// What a comparison saw.
#[derive(Debug, Default)]
struct Seen {
    /// Largest GPU-CPU position and orientation differences.
    worst: (f32, f32),
    /// Largest differences of the nudged CPU run.
    rounding: (f32, f32),
    /// Touching mesh slots summed over the comparisons, and how many held a composite's
    /// second piece.
    mesh_touching: usize,
    second_piece: usize,
}

/// Runs `scene` on the CPU and on the GPU side by side for `steps`, comparing every `every`
/// steps: equal touching counts (every step's count in the chunk's last report), equal
/// touching mesh slots (body, slot, boundary, piece), positions and orientations within
/// `max(tol_x, 2 d_x)` and `max(tol_q, 2 d_q)` (see the file's comment), and as many
/// rebuilds. Returns the CPU's world and the GPU's read back.
fn compare(scene: &Scene, steps: u64, every: u64, tol_x: f32, tol_q: f32) -> (World, World, Seen) {
    let ctx = clatter_gpu::test_context().expect("a GPU adapter (lavapipe)");
    let mut cpu = scene.world();
    let mut host = scene.world();
    let mut nudged = scene.world();
    for q in nudged.state.orientation.iter_mut() {
        q.x = f32::from_bits(q.x.to_bits() + 16);
    }
    nudged.gravity.z = f32::from_bits(nudged.gravity.z.to_bits() + 1);
    for x in nudged.state.position.iter_mut() {
        x.x = f32::from_bits((x.x as f32).to_bits() + 1) as f64;
    }
    let mut gpu = GpuWorld::new(ctx, &host).expect("the GPU takes composites with meshes");
    let mut seen = Seen::default();
    let mut rebuilds = 0u64;
    for _ in 0..steps / every {
        let mut count = 0;
        for _ in 0..every {
            let st = cpu.step().expect("CPU step");
            rebuilds += st.rebuilt as u64;
            count = st.contacts;
            nudged.step().expect("CPU step");
            f32_positions(&mut nudged);
        }
        let rep = gpu.step_into(every, &mut host).expect("GPU steps");
        assert_eq!(rep.bad_body, None);
        assert_eq!(host.step_count, cpu.step_count);
        assert_eq!(
            rep.touching, count,
            "touching contacts differ at step {}",
            cpu.step_count
        );
        let (dx, dq) = distance(&cpu, &host);
        let (rx, rq) = distance(&cpu, &nudged);
        seen.rounding = (seen.rounding.0.max(rx), seen.rounding.1.max(rq));
        seen.worst = (seen.worst.0.max(dx), seen.worst.1.max(dq));
        let (bx, bq) = (
            tol_x.max(2.0 * seen.rounding.0),
            tol_q.max(2.0 * seen.rounding.1),
        );
        assert!(
            dx <= bx && dq <= bq,
            "step {}: positions differ by {dx} m (bound {bx}), orientations by {dq} (bound {bq})",
            cpu.step_count
        );
        gpu.read_into(&mut host).expect("read-back");
        let (a, b) = (mesh_touching(&cpu), mesh_touching(&host));
        assert_eq!(a, b, "mesh slots differ at step {}", cpu.step_count);
        seen.mesh_touching += a.len();
        seen.second_piece += a.iter().filter(|s| s.3 > 0).count();
    }
    assert_eq!(gpu.rebuilds(), rebuilds, "rebuilds");
    eprintln!("{steps} steps: {seen:?}, {rebuilds} rebuilds");
    (cpu, host, seen)
}

/// The floor test's bodies: a pair landing tilted (one end first, then both), a hammer
/// resting turned, a pair and a hammer sliding across the diagonals.
const FLOOR_BODIES: &str = r#"
[[body]]
shape = "pair"
material = "m"
position = [0.1, 0.12, 0.0125]
orientation = [0.9848078, 0.0, 0.1736482, 0.0]
[[body]]
shape = "hammer"
material = "m"
position = [-0.2, 0.25, 0.00998]
orientation = [0.9887711, 0.0, 0.0, 0.1494381]
[[body]]
shape = "pair"
material = "m"
position = [-0.3, -0.2, 0.00999]
velocity = [0.8, 0.3, 0.0]
[[body]]
shape = "hammer"
material = "m"
position = [-0.3, 0.0, 0.00998]
orientation = [0.9887711, 0.0, 0.0, 0.1494381]
velocity = [0.7, -0.25, 0.0]
"#;

#[test]
fn clumps_land_rest_and_slide_on_a_mesh_floor_as_on_the_cpu() {
    let text = floor_scene(FLOOR_BODIES, MATERIAL);
    let scene = parse(&text);
    let (cpu, _, seen) = compare(&scene, 8000, 500, 1e-7, 1e-6);
    // Every piece ends on the floor (the pair's two spheres, the hammer's ball and cube) and
    // the sliders moved.
    let touching = mesh_touching(&cpu);
    for body in 0..4 {
        let pieces: BTreeSet<u32> = touching
            .iter()
            .filter(|s| s.0 == body)
            .map(|s| s.3)
            .collect();
        assert_eq!(pieces, BTreeSet::from([0, 1]), "body {body}: {touching:?}");
    }
    assert!(cpu.state.position[2].x > -0.25, "{}", cpu.state.position[2]);
    assert!(cpu.state.position[3].x > -0.25, "{}", cpu.state.position[3]);
    assert!(seen.second_piece > 0);
}

#[test]
fn clumps_on_a_mesh_floor_with_the_hertz_law_as_on_the_cpu() {
    // Hertz's stiffness depends on the contact's radius: each piece's own (a ball's 10 mm,
    // the cube's equivalent radius), not the clump's.
    let hertz = r#"
[[material]]
name = "m"
density = 2500.0
model = "hertz"
youngs_modulus = 5.0e6
poisson_ratio = 0.3
restitution = 0.3
friction = 0.4
"#;
    let scene = parse(&floor_scene(FLOOR_BODIES, hertz));
    let (cpu, _, seen) = compare(&scene, 4000, 500, 1e-7, 1e-6);
    assert!(seen.second_piece > 0, "{seen:?}");
    assert!(mesh_touching(&cpu).len() >= 6, "{:?}", mesh_touching(&cpu));
}

#[test]
fn clumps_tumble_in_a_drum_as_on_the_cpu() {
    // At rest, the drum is a fixed mesh: the GPU follows the CPU to f32 rounding (the
    // nudge's bound) until the clumps' collisions turn chaotic (after about 5000
    // steps, when the nudged CPU run itself departs by a millimetre).
    let scene = parse(&drum_scene(15, 0.0));
    assert_eq!(scene.world().len(), 30);
    let (_, _, seen) = compare(&scene, 5000, 500, 1e-6, 1e-4);
    assert!(seen.mesh_touching >= 5, "{seen:?}");
    assert!(seen.second_piece > 0, "{seen:?}");
}

#[test]
fn clumps_tumble_in_a_turning_drum_as_on_the_cpu() {
    // Turning, the drum's pose (angle, sine and cosine, quaternion, translation) and its
    // triangles' world coordinates are computed by `clatter::turn` on the CPU and its twin
    // turn.wgsl on the GPU, bitwise alike (tests/turn.rs). Measured on lavapipe
    // (2026-11-26): the runs are bitwise equal until the clumps first reach the drum (step
    // 2950), then part by rounding in the contact code to 1.8e-8 m and 2.4e-6 in the
    // orientations at step 4000 (before the twin, with glam's rotation on the CPU and
    // WGSL's own on the GPU: 2.4e-5 m, which needed a 3e-5 m bound). The bound is 1e-5 m,
    // of the order of tests/boundaries.rs's turning drum with spheres (1e-3 of a 10 mm
    // radius): room for a GPU that fuses multiply-adds in the contact law, as an H100 does.
    let scene = parse(&drum_scene(15, 3.0));
    let (cpu, _, seen) = compare(&scene, 4000, 500, 1e-5, 4e-3);
    assert!(seen.mesh_touching >= 2, "{seen:?}");
    assert!(seen.second_piece > 0, "{seen:?}");
    // The drum carried clumps along (they move about its axis).
    let moving = cpu
        .state
        .velocity
        .iter()
        .filter(|v| v.length() > 0.01)
        .count();
    assert!(moving > 5, "{moving} clumps moving");
}

#[test]
fn gpu_runs_are_bitwise_the_same_and_resume_on_the_cpu() {
    let text = drum_scene(10, 3.0);
    let scene = parse(&text);
    let ctx = clatter_gpu::test_context().expect("a GPU adapter (lavapipe)");
    let run = |steps: u64| {
        let mut host = scene.world();
        let mut gpu = GpuWorld::new(ctx.clone(), &host).unwrap();
        gpu.step(steps).unwrap();
        gpu.read_into(&mut host).unwrap();
        host
    };
    let (a, b) = (run(4500), run(4500));
    assert_eq!(a.state.position, b.state.position);
    assert_eq!(a.state.velocity, b.state.velocity);
    assert_eq!(a.state.orientation, b.state.orientation);
    assert_eq!(a.state.angular_momentum, b.state.angular_momentum);
    assert_eq!(a.mesh_slots(), b.mesh_slots());
    let springs = a
        .mesh_slots()
        .iter()
        .filter(|s| s.touching && s.history.length() > 0.0)
        .count();
    assert!(springs > 0, "mesh springs at the checkpoint");
    assert!(
        a.mesh_slots().iter().any(|s| s.touching && s.piece > 0),
        "a second piece touches the drum at the checkpoint"
    );
    // A checkpoint of the GPU run resumed on the CPU: the same slots, and it goes on as the
    // CPU run from the start (to the same bound as the side-by-side comparison).
    let bytes = a.checkpoint_bytes(&scene_path(), &text, &[]);
    let (_, mut resumed) = Checkpoint::from_bytes(&bytes).unwrap().world().unwrap();
    assert_eq!(resumed.mesh_slots(), a.mesh_slots());
    let mut cpu = scene.world();
    let mut nudged = scene.world();
    for q in nudged.state.orientation.iter_mut() {
        q.x = f32::from_bits(q.x.to_bits() + 16);
    }
    nudged.gravity.z = f32::from_bits(nudged.gravity.z.to_bits() + 1);
    for _ in 0..5000 {
        cpu.step().unwrap();
        nudged.step().unwrap();
        f32_positions(&mut nudged);
    }
    for _ in 0..500 {
        resumed.step().unwrap();
    }
    assert_eq!(resumed.step_count, cpu.step_count);
    let (dx, dq) = distance(&cpu, &resumed);
    let (rx, rq) = distance(&cpu, &nudged);
    eprintln!("resumed on the CPU: {dx} m, {dq}; 16-ulp nudge {rx} m, {rq}");
    assert!(dx <= 1e-6f32.max(2.0 * rx), "{dx} vs {rx}");
    assert!(dq <= 1e-4f32.max(2.0 * rq), "{dq} vs {rq}");
}

#[test]
fn the_gpu_backend_takes_composites_with_meshes() {
    // What `clatter_backend::choose` does for `--backend gpu` once it has a device. (`auto`
    // picks the CPU on a software rasteriser such as lavapipe whatever the scene.)
    let ctx = clatter_gpu::test_context().expect("a GPU adapter");
    let world = parse(&drum_scene(2, 3.0)).world();
    GpuWorld::new(ctx, &world).expect("the GPU takes composites with meshes");
}

/// A denser load of clumps, dropped close to the fixed drum's floor: from the CPU's state at
/// each of a run of steps, one CPU step and one GPU step give the same touching contacts and
/// mesh slots (body, slot, boundary, piece), and each touching slot's force within
/// `MESH_FORCE_TOL` of the CPU's. (The trajectories of such a pile part from the CPU's
/// within a thousand steps as a nudged CPU run's do: colliding clumps amplify rounding, so
/// step by step is how to compare it.)
#[test]
fn a_dense_drum_load_steps_as_on_the_cpu() {
    // f32 rounding of a contact's depth: a few ulps of the 0.07 m coordinates (7.5e-9 m
    // each: the piece's centre, the plane's offset, summed in another order and with fused
    // multiply-adds) times the stiffness (2e4 N/m) is some 1e-4 N, which the spheres'
    // step-resolved dashpot amplifies for an approaching piece a few tenths of a micrometre
    // deep (measured on lavapipe: 6.5e-4 N on a 0.012 N contact 5.8e-7 m deep); bounded
    // by 1e-3 N (5e-8 m of depth) plus 1e-5 of the force for the rest of the law.
    const MESH_FORCE_TOL: f32 = 1e-3;
    let text = drum_scene(15, 0.0)
        .replace(
            "[-0.04, -0.033, -0.052], max = [0.04, 0.033, -0.01]",
            "[-0.02, -0.033, -0.066], max = [0.02, 0.033, -0.03]",
        )
        .replace(
            "[-0.04, -0.033, -0.052], max = [0.04, 0.033, 0.02]",
            "[-0.02, -0.033, -0.066], max = [0.02, 0.033, 0.0]",
        )
        .replace("dt = 2.0e-5", "dt = 5.0e-5");
    assert!(text.contains("-0.066") && text.contains("5.0e-5"));
    let scene = parse(&text);
    let ctx = clatter_gpu::test_context().expect("a GPU adapter (lavapipe)");
    let mut cpu = scene.world();
    let (mut touching, mut second) = (0, 0);
    let (mut worst_abs, mut worst_rel) = (0.0f32, 0.0f32);
    let mut knife_edges = 0;
    for start in (900u64..=3000).step_by(100) {
        while cpu.step_count < start {
            cpu.step().unwrap();
        }
        let mut a = cpu.clone();
        let mut host = cpu.clone();
        let mut gpu = GpuWorld::new(ctx.clone(), &host).unwrap();
        let st = a.step().unwrap();
        let rep = gpu.step_into(1, &mut host).unwrap();
        gpu.read_into(&mut host).unwrap();
        if st.contacts != rep.touching {
            // Only a contact within rounding of touching may be taken one way on one
            // executor and the other way on the other (lavapipe rounds and fuses differently).
            let edge = knife_edge_pairs(&cpu, &a, &host);
            assert_eq!(
                st.contacts.abs_diff(rep.touching),
                edge,
                "from step {start}: touching contacts {} (CPU) vs {} (GPU), {edge} of them within {KNIFE_EDGE_DEPTH:e} m of touching",
                st.contacts,
                rep.touching
            );
            knife_edges += 1;
        }
        let (ma, mb) = (mesh_touching(&a), mesh_touching(&host));
        assert_eq!(ma, mb, "mesh slots from step {start}");
        touching += ma.len();
        second += ma.iter().filter(|s| s.3 > 0).count();
        for (k, (s, t)) in a.mesh_slots().iter().zip(host.mesh_slots()).enumerate() {
            if !s.touching {
                continue;
            }
            let d = (s.force.force_b - t.force.force_b).length();
            let f = s.force.force_b.length();
            worst_abs = worst_abs.max(d);
            worst_rel = worst_rel.max(d / f.max(1e-12));
            assert!(
                d <= MESH_FORCE_TOL + 1e-5 * f,
                "from step {start}, slot {k}: CPU {:?} GPU {:?}",
                s.force,
                t.force
            );
        }
    }
    eprintln!(
        "{touching} touching mesh slots ({second} of second pieces): forces within {worst_abs:e} N, {worst_rel:e} relative"
    );
    assert!(touching >= 30, "{touching} mesh contacts over the steps");
    assert!(second > 0);
    // Knife edges are rare: a depth within 5e-8 m of zero, among depths of micrometres.
    assert!(
        knife_edges <= 2,
        "{knife_edges} of 22 steps had a knife-edge contact"
    );
}

/// How deep a contact may be (or how far apart) and still be decided differently by the two
/// executors: a few ulps of the pair's offset (1e-9 m at 1 cm) and of the 0.07 m mesh
/// coordinates (7.5e-9 m), summed in another order and with fused multiply-adds.
const KNIFE_EDGE_DEPTH: f32 = 5e-8;

/// The piece pairs touching after one step on one executor and not on the other (`cpu`
/// before the step, `a` and `gpu` after it), each checked to be a knife edge: its depth at
/// the step's start within [`KNIFE_EDGE_DEPTH`] of zero. Returns how many there are.
fn knife_edge_pairs(before: &World, a: &World, gpu: &World) -> usize {
    use clatter::contact_list::piece_ids;
    use std::collections::BTreeSet;
    let touching = |w: &World| -> BTreeSet<([u32; 2], u32)> {
        let c = w.contact_state();
        (0..c.pairs.len())
            .filter(|&k| c.touching[k])
            .map(|k| (c.pairs[k], c.pieces.get(k).copied().unwrap_or(0)))
            .collect()
    };
    let (ta, tb) = (touching(a), touching(gpu));
    let differ: Vec<_> = ta.symmetric_difference(&tb).copied().collect();
    for &([i, j], code) in &differ {
        let (i, j) = (i as usize, j as usize);
        let (pa, pb) = piece_ids(code);
        let (sa, posea) = before.piece_at(i, pa, glam::Vec3::ZERO);
        let (sb, poseb) = before.piece_at(j, pb, before.offset_of(i, j));
        // Deepest point of the CPU's manifold, or minus the gap (an independent distance
        // query, clatter-geom's GJK) when the CPU's narrow phase finds none.
        let depth = clatter::geom::narrow::collide(sa, &posea, sb, &poseb)
            .map(|m| m.points().iter().map(|p| p.depth).fold(f32::MIN, f32::max))
            .unwrap_or_else(|| -clatter::geom::query::distance(sa, &posea, sb, &poseb).distance);
        assert!(
            depth.abs() <= KNIFE_EDGE_DEPTH,
            "bodies {i} and {j} (pieces {pa}, {pb}) touch on one executor only, {depth:e} m deep"
        );
    }
    differ.len()
}

/// The device's last good state (`GpuWorld::read_last_good`, the `last_good.ckpt` of a GPU
/// blow-up report) keeps the mesh slots with their pieces and the composites' rebuild
/// orientations: read back, it is the state of a plain GPU run at that step, slots included,
/// and its checkpoint resumed on the CPU goes on bitwise as the plain run's does.
#[test]
fn the_last_good_state_keeps_the_mesh_slots_and_resumes_on_the_cpu() {
    use clatter::health::{ENERGY_FACTOR, Health};
    use clatter_gpu::HealthSetup;
    let text = drum_scene(10, 3.0);
    let scene = parse(&text);
    let ctx = clatter_gpu::test_context().expect("a GPU adapter (lavapipe)");
    let start = scene.world();
    let mut gpu = GpuWorld::new(ctx.clone(), &start).unwrap();
    let h = Health::new(&start);
    gpu.set_health(
        &start,
        HealthSetup {
            check_every: 10,
            energy_every: 0,
            snapshot_every: 500,
            budget: h.baseline(),
            alarm_factor: 0.5 * ENERGY_FACTOR,
            force_floor: h.force_floor(),
            overlap_limit: 0.9 * clatter::health::OVERLAP_LIMIT,
        },
    );
    let report = gpu.step(4600).unwrap();
    assert!(!report.alarm && report.bad_body.is_none());
    let mut snap = start.clone();
    assert!(gpu.read_last_good(&mut snap).unwrap());
    assert_eq!(snap.step_count, 4500);
    let mut plain = start.clone();
    let mut other = GpuWorld::new(ctx, &start).unwrap();
    other.step(4500).unwrap();
    other.read_into(&mut plain).unwrap();
    assert_eq!(snap.time, plain.time);
    assert_eq!(snap.state.position, plain.state.position);
    assert_eq!(snap.state.orientation, plain.state.orientation);
    assert_eq!(snap.mesh_slots(), plain.mesh_slots());
    assert_eq!(snap.mesh_rebuild_time(), plain.mesh_rebuild_time());
    assert_eq!(snap.rebuild_orientation(), plain.rebuild_orientation());
    assert_eq!(snap.rebuild_orientation().len(), snap.len());
    let springs = snap
        .mesh_slots()
        .iter()
        .filter(|s| s.touching && s.history.length() > 0.0)
        .count();
    assert!(springs > 0, "mesh springs in the last good state");
    assert!(snap.mesh_slots().iter().any(|s| s.touching && s.piece > 0));
    // Both checkpoints resumed on the CPU: the same run, bit for bit.
    let resume = |w: &World| {
        let bytes = w.checkpoint_bytes(&scene_path(), &text, &[]);
        let (_, mut r) = Checkpoint::from_bytes(&bytes).unwrap().world().unwrap();
        assert_eq!(r.mesh_slots(), w.mesh_slots());
        for _ in 0..300 {
            r.step().unwrap();
        }
        r
    };
    let (a, b) = (resume(&snap), resume(&plain));
    assert_eq!(a.state.position, b.state.position);
    assert_eq!(a.state.velocity, b.state.velocity);
    assert_eq!(a.mesh_slots(), b.mesh_slots());
}

/// Rounds every position to f32, as positions were stored before they were kept to 48 bits:
/// the nudged reference runs of these comparisons stand for "how far f32 rounding alone
/// carries the scene", and with precise positions a one-time nudge no longer keeps
/// perturbing the run at every step as it did. (The reference runs also take gravity one
/// ulp off: a perturbation of every step's f32 velocity update.)
fn f32_positions(w: &mut World) {
    for x in &mut w.state.position {
        *x = x.as_vec3().as_dvec3();
    }
}

//! The GPU pipeline against the CPU pipeline, stage by stage, on random scenes: identical cell
//! keys, sorted order, cell ranges and pair lists (bitwise: these are integers), forces and
//! torques within 1e-5 relative, and short trajectories within a tight tolerance.

use clatter::broad::{self, Grid};
use clatter::geom::narrow::Plane;
use clatter::geom::{RegularKind, ShapeKind};
use clatter::scene::random_rotation;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use clatter_gpu::GpuWorld;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn material(law: ContactLaw) -> Material {
    Material::new("m", 2500.0, law, 0.4, 0.5)
}

/// A box of `n` random bodies (shapes chosen from `shapes`), overlapping a little, moving
/// and spinning, with gravity and six walls.
fn scene(n: usize, seed: u64, shapes: Vec<ShapeKind>, hertz: bool) -> World {
    scene_in(n, seed, shapes, hertz, false)
}

/// [`scene`], with `periodic_xy` periodic along x and y (walls only below and above).
fn scene_in(n: usize, seed: u64, shapes: Vec<ShapeKind>, hertz: bool, periodic_xy: bool) -> World {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let shapes: Vec<_> = shapes
        .iter()
        .map(|s| s.prepare().expect("valid shape"))
        .collect();
    let side = 0.01 * (n as f32).cbrt() * 2.2;
    let bodies = (0..n)
        .map(|_| {
            let mut u = || rng.random_range(-1.0f32..1.0);
            let position = Vec3::new(u(), u(), u()) * side * 0.45;
            let velocity = Vec3::new(u(), u(), u()) * 0.5;
            let angular_velocity = Vec3::new(u(), u(), u()) * 20.0;
            BodyInit {
                shape: rng.random_range(0..shapes.len()) as u32,
                material: rng.random_range(0..2),
                position: position.as_dvec3(),
                orientation: random_rotation(&mut rng),
                velocity,
                angular_velocity,
            }
        })
        .collect();
    let law = |k: f32| {
        if hertz {
            ContactLaw::Hertz {
                youngs_modulus: k,
                poisson_ratio: 0.3,
            }
        } else {
            ContactLaw::Linear { stiffness: k }
        }
    };
    let (k1, k2) = if hertz { (5e7, 2e8) } else { (2e4, 5e4) };
    let normals: &[Vec3] = if periodic_xy {
        &[Vec3::Z, -Vec3::Z]
    } else {
        &[Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
    };
    let walls = normals
        .iter()
        .map(|&normal| Wall {
            plane: Plane {
                normal,
                offset: -side * 0.5,
            },
            material: 1,
        })
        .collect();
    World::new(WorldDesc {
        shapes,
        materials: vec![material(law(k1)), material(law(k2))],
        walls,
        bodies,
        gravity: Vec3::new(0.0, 0.0, -9.81),
        dt: None,
        skin: None,
        periodic: periodic_xy.then_some(clatter::Periodic {
            min: Vec3::splat(-0.5 * side),
            max: Vec3::splat(0.5 * side),
            axes: [true, true, false],
        }),
    })
}

fn spheres() -> Vec<ShapeKind> {
    [0.004, 0.005, 0.007]
        .iter()
        .map(|&radius| ShapeKind::Sphere { radius })
        .collect()
}

fn u32s(b: &[u8]) -> Vec<u32> {
    bytemuck::pod_collect_to_vec(b)
}

/// Stages 1-3 (bin, sort, pairs) and the b-side adjacency after the first step's rebuild.
fn check_broad_phase(world: &World, gpu: &GpuWorld) {
    let rmax = world.consts.radius.iter().copied().fold(0.0, f32::max);
    let positions: Vec<glam::Vec3> = world.state.position.iter().map(|p| p.as_vec3()).collect();
    let grid = Grid::around(&positions, 2.0 * rmax + world.skin);
    let keys = broad::bin(&grid, &positions);
    let (sorted, start) = broad::sort(&keys, grid.cell_count());
    let pairs = broad::pairs_periodic(
        &grid,
        &positions,
        &world.consts.radius,
        world.skin,
        world.periodic.as_ref(),
    );
    let n = world.len();
    let gpu_keys = u32s(&gpu.debug_buffer("keys").unwrap());
    assert_eq!(&gpu_keys[..n], &keys[..], "cell keys");
    let gpu_sorted = u32s(&gpu.debug_buffer("sorted").unwrap());
    assert_eq!(&gpu_sorted[..n], &sorted[..], "sorted order");
    let gpu_start = u32s(&gpu.debug_buffer("cell_start").unwrap());
    assert_eq!(&gpu_start[..start.len()], &start[..], "cell ranges");
    let gpu_pairs: Vec<[u32; 2]> =
        bytemuck::pod_collect_to_vec(&gpu.debug_buffer("pairs").unwrap());
    assert_eq!(&gpu_pairs[..pairs.len()], &pairs[..], "pair list");
    assert_eq!(
        pairs,
        broad::pairs_brute_force(&positions, &world.consts.radius, world.skin),
        "the CPU's pairs are all pairs"
    );
    // b-side adjacency: for each body, the pairs where it is second, in pair order.
    let b_start = u32s(&gpu.debug_buffer("b_start").unwrap());
    let b_adj = u32s(&gpu.debug_buffer("b_adj").unwrap());
    for i in 0..n {
        let expect: Vec<u32> = (0..pairs.len() as u32)
            .filter(|&c| pairs[c as usize][1] == i as u32)
            .collect();
        let got = &b_adj[b_start[i] as usize..b_start[i + 1] as usize];
        assert_eq!(got, &expect[..], "b-side pairs of body {i}");
    }
    eprintln!(
        "broad phase: {n} bodies, {} cells, {} pairs identical",
        grid.cell_count(),
        pairs.len()
    );
}

fn rel_close(a: Vec3, b: Vec3, scale: f32, tol: f32) -> bool {
    (a - b).length() <= tol * scale.max(1e-30)
}

/// Stage 4-5: the first step's forces per contact, GPU against CPU.
fn check_forces(cpu: &World, gpu_state: &clatter::ContactState) {
    let c = cpu.contact_state();
    assert_eq!(c.pairs, gpu_state.pairs, "pair lists");
    let scale = c
        .forces
        .iter()
        .chain(&c.wall_forces)
        .map(|f| f.force_b.length())
        .fold(0.0, f32::max);
    // Torques are compared on the scale of the largest torque a contact force could exert,
    // force times lever (a body's size): a torque is a cross product of the force with the
    // lever, and f32 rounding leaves an error of order eps |f| |lever| in it even where the
    // product nearly cancels (a deep sphere contact's normal force along its lever). Scaled
    // by the largest torque alone, that noise failed on an H100 (its fused multiply-adds
    // round differently from the CPU's) at 2e-5 for a contact whose normal force was large
    // and whose torque came from a small tangential force.
    let lever = 2.0 * cpu.consts.radius.iter().copied().fold(0.0, f32::max);
    let tscale = c
        .forces
        .iter()
        .chain(&c.wall_forces)
        .map(|f| f.torque_a.length().max(f.torque_b.length()))
        .fold(scale * lever, f32::max);
    assert!(scale > 0.0, "the scene has contacts");
    let mut touching = 0;
    for (k, (a, b)) in c.forces.iter().zip(&gpu_state.forces).enumerate() {
        assert_eq!(c.touching[k], gpu_state.touching[k], "touching of pair {k}");
        touching += c.touching[k] as usize;
        assert!(
            rel_close(a.force_b, b.force_b, scale, 1e-5),
            "pair {k} {:?}: force {} vs {}",
            c.pairs[k],
            a.force_b,
            b.force_b
        );
        assert!(
            rel_close(a.torque_a, b.torque_a, tscale, 1e-5),
            "pair {k} torque a {} vs {} (scale {tscale})",
            a.torque_a,
            b.torque_a
        );
        assert!(
            rel_close(a.torque_b, b.torque_b, tscale, 1e-5),
            "pair {k} torque b"
        );
    }
    for (k, (a, b)) in c.wall_forces.iter().zip(&gpu_state.wall_forces).enumerate() {
        assert_eq!(
            c.wall_touching[k], gpu_state.wall_touching[k],
            "wall slot {k}"
        );
        touching += c.wall_touching[k] as usize;
        assert!(
            rel_close(a.force_b, b.force_b, scale, 1e-5),
            "wall slot {k} force"
        );
        assert!(
            rel_close(a.torque_b, b.torque_b, tscale, 1e-5),
            "wall slot {k} torque"
        );
    }
    eprintln!("forces: {touching} touching contacts agree within 1e-5 of the largest");
    assert!(
        touching > 10,
        "too few contacts to mean anything: {touching}"
    );
}

fn compare_run(mut cpu: World, steps: u64, tol: f32) {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let initial = cpu.clone();
    let mut gpu = GpuWorld::new(ctx, &cpu).expect("scene fits");
    gpu.step(1).expect("one GPU step");
    check_broad_phase(&initial, &gpu);
    cpu.step().expect("one CPU step");
    check_forces(&cpu, &gpu.contact_state().expect("readback"));
    // A short trajectory, compared every `steps / 4` steps.
    let mut back = initial.clone();
    let size = 2.0 * cpu.consts.radius.iter().copied().fold(0.0, f32::max);
    let mut done = 1;
    let mut worst = 0.0f32;
    for q in 1..=4 {
        let upto = steps * q / 4;
        for _ in done..upto {
            cpu.step().expect("CPU step");
        }
        gpu.step(upto - done).expect("GPU steps");
        done = upto;
        gpu.read_into(&mut back).expect("readback");
        assert_eq!(back.step_count, cpu.step_count);
        assert_eq!(back.time, cpu.time);
        worst = 0.0;
        let mut worst_q = 0.0f32;
        for i in 0..cpu.len() {
            worst = worst.max((back.state.position[i] - cpu.state.position[i]).length() as f32);
            worst_q = worst_q.max(
                (back.state.orientation[i]
                    .dot(cpu.state.orientation[i])
                    .abs()
                    - 1.0)
                    .abs(),
            );
        }
        eprintln!(
            "trajectory: step {upto}: worst position difference {:.3e} of a body size, orientation {worst_q:.1e}",
            worst / size
        );
    }
    eprintln!(
        "trajectory: {steps} steps, {} bodies, worst position difference {:.3e} m ({:.3e} of a body size), {} rebuilds GPU / {} CPU",
        cpu.len(),
        worst,
        worst / size,
        gpu.rebuilds(),
        cpu.rebuilds
    );
    assert!(worst < tol * size, "trajectories diverged: {worst} m");
    // Contacts agree at the end too.
    assert_eq!(
        back.touching_pairs(),
        cpu.touching_pairs(),
        "touching pairs"
    );
}

/// Trajectory tolerance of the random sphere scenes, in body sizes. Their overlaps are deep
/// (large forces, so large rounding in them), and GPU compilers fuse multiply-adds where the
/// CPU rounds twice: on an H100 the positions drifted apart linearly, 1.3e-7 of a body size
/// per step (4.0e-5 after 300 steps, 2.7e-5 after 200), while lavapipe stays under 1e-5.
/// A wrong force or torque moves bodies by a good fraction of their size in that time.
const SPHERE_TRAJECTORY_TOL: f32 = 1e-4;

#[test]
fn spheres_linear_match_cpu_stage_by_stage() {
    compare_run(scene(600, 1, spheres(), false), 300, SPHERE_TRAJECTORY_TOL);
}

#[test]
fn spheres_hertz_match_cpu_stage_by_stage() {
    compare_run(scene(400, 2, spheres(), true), 200, SPHERE_TRAJECTORY_TOL);
}

#[test]
fn periodic_spheres_and_polyhedra_match_cpu_stage_by_stage() {
    let mut shapes = spheres();
    shapes.push(ShapeKind::Regular {
        kind: RegularKind::Cube,
        radius: 0.006,
    });
    let w = scene_in(500, 4, shapes, false, true);
    let seam = w
        .state
        .position
        .iter()
        .filter(|p| p.x.abs() > 0.4 * w.periodic.unwrap().max.x as f64)
        .count();
    assert!(seam > 20, "bodies near the seam: {seam}");
    compare_run(w, 200, SPHERE_TRAJECTORY_TOL);
}

#[test]
fn polyhedra_match_cpu_stage_by_stage() {
    let mut shapes = spheres();
    for kind in RegularKind::ALL {
        shapes.push(ShapeKind::Regular {
            kind,
            radius: 0.006,
        });
    }
    shapes.push(ShapeKind::Box {
        half_extents: [0.006, 0.004, 0.003],
    });
    compare_run(lattice(7, 3, shapes), 200, 1e-5);
}

/// `n^3` bodies of `shapes` on a jittered lattice whose spacing is a little less than the
/// bodies' size (shallow overlaps, as in a real packing, unlike `scene`'s random deep ones:
/// the manifold reduction picks among near-equal points differently on the two backends when
/// overlaps are deep, which is legitimate but not what this test is about), randomly turned,
/// converging on the centre, in a box of walls under gravity.
fn lattice(n: usize, seed: u64, shapes: Vec<ShapeKind>) -> World {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let shapes: Vec<_> = shapes
        .iter()
        .map(|s| s.prepare().expect("valid shape"))
        .collect();
    let spacing = 0.0105f32;
    let half = (n as f32 - 1.0) / 2.0;
    let side = spacing * (n as f32 + 1.0);
    let bodies = (0..n * n * n)
        .map(|i| {
            let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
            let mut u = || rng.random_range(-1.0f32..1.0);
            let jitter = Vec3::new(u(), u(), u()) * 0.0005;
            let position =
                (Vec3::new(x as f32, y as f32, z as f32) - Vec3::splat(half)) * spacing + jitter;
            let velocity = -position * 4.0 + Vec3::new(u(), u(), u()) * 0.05;
            let angular_velocity = Vec3::new(u(), u(), u()) * 10.0;
            BodyInit {
                shape: rng.random_range(0..shapes.len()) as u32,
                material: rng.random_range(0..2),
                position: position.as_dvec3(),
                orientation: random_rotation(&mut rng),
                velocity,
                angular_velocity,
            }
        })
        .collect();
    let walls = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
        .iter()
        .map(|&normal| Wall {
            plane: Plane {
                normal,
                offset: -side * 0.5,
            },
            material: 1,
        })
        .collect();
    World::new(WorldDesc {
        shapes,
        materials: vec![
            material(ContactLaw::Linear { stiffness: 2e4 }),
            material(ContactLaw::Linear { stiffness: 5e4 }),
        ],
        walls,
        bodies,
        gravity: Vec3::new(0.0, 0.0, -9.81),
        dt: None,
        skin: None,
        periodic: None,
    })
}

/// Lean steps (recorded without the rebuild's dispatches, stopping and running a step again
/// in full when a rebuild is due) give bitwise the results of full steps, with the rebuilds
/// at the same steps, on scenes that rebuild often (so that lean steps do stop).
#[test]
fn lean_steps_match_full_steps_bitwise() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut polyhedra = spheres();
    polyhedra.push(ShapeKind::Regular {
        kind: RegularKind::Cube,
        radius: 0.006,
    });
    polyhedra.push(ShapeKind::Regular {
        kind: RegularKind::Icosahedron,
        radius: 0.006,
    });
    for (name, world) in [
        ("spheres", scene(300, 7, spheres(), false)),
        ("polyhedra", lattice(5, 8, polyhedra)),
    ] {
        let mut lean = GpuWorld::new(ctx.clone(), &world).expect("scene fits");
        let mut full = GpuWorld::new(ctx.clone(), &world).expect("scene fits");
        full.set_lean_steps(false);
        // Uneven pieces, so that batches start and end at different steps.
        for steps in [1, 70, 129, 50] {
            lean.step(steps).expect("lean steps");
            full.step(steps).expect("full steps");
        }
        assert_eq!(lean.steps_taken(), 250, "{name}");
        assert_eq!(full.steps_taken(), 250, "{name}");
        assert!(
            lean.rebuilds() > 3,
            "{name}: too few rebuilds ({})",
            lean.rebuilds()
        );
        assert_eq!(lean.rebuilds(), full.rebuilds(), "{name}: rebuilds");
        assert!(
            lean.stalls() > 0,
            "{name}: no lean step found a rebuild due"
        );
        assert_eq!(full.stalls(), 0, "{name}");
        let (a, b) = (lean.read_states().unwrap(), full.read_states().unwrap());
        let bits = |s: &[clatter_gpu::BodyState]| -> Vec<u32> {
            bytemuck::cast_slice::<_, u32>(s).to_vec()
        };
        assert!(bits(&a) == bits(&b), "{name}: body states differ");
        let (ca, cb) = (lean.contact_state().unwrap(), full.contact_state().unwrap());
        assert_eq!(ca.pairs, cb.pairs, "{name}: pair lists");
        assert_eq!(ca.touching, cb.touching, "{name}: touching");
        eprintln!(
            "{name}: 250 steps, {} rebuilds, {} stalls, bitwise identical",
            lean.rebuilds(),
            lean.stalls()
        );
    }
}

/// `write_states` puts the host's edited states on the GPU bit for bit (what the next step
/// starts from), and refuses a world that is not at the GPU's step.
#[test]
fn written_states_are_the_hosts_bit_for_bit() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut world = scene(300, 11, spheres(), false);
    let mut gpu = GpuWorld::new(ctx, &world).expect("scene fits");
    gpu.step_into(20, &mut world).expect("steps");
    for i in 0..world.len() {
        let q = world.state.orientation[i];
        world.state.orientation[i] = (glam::Quat::from_rotation_y(0.3 + i as f32) * q).normalize();
        world.state.velocity[i] += glam::Vec3::new(0.01, -0.02, 0.005);
    }
    gpu.write_states(&world)
        .expect("the same world at the same step");
    let on_gpu = gpu.read_states().expect("readback");
    let bits =
        |s: &[clatter_gpu::BodyState]| -> Vec<u32> { bytemuck::cast_slice::<_, u32>(s).to_vec() };
    let host: Vec<_> = (0..world.len()).map(|i| world.state.record(i)).collect();
    assert!(
        bits(&on_gpu) == bits(&host),
        "written states differ from the host's"
    );
    // The GPU steps on from them (the planted bug of writing all but the last body fails
    // the comparison above).
    gpu.step_into(5, &mut world)
        .expect("steps after the upload");
    assert_eq!(world.step_count, 25);
    world.step_count += 1;
    assert!(
        gpu.write_states(&world).is_err(),
        "a world at another step must be refused"
    );
}

/// The shapes of mesh files (`[[shape]] mesh = ..`: the convex hull of the file's vertices),
/// as the scene builds them: the irregular rock of `scenes/rocks.toml` (42 vertices, 80
/// faces), the same rock stretched unevenly, and the committed PLY tetrahedron, each scaled
/// to a bounding radius of 7.5 mm (the lattice spacing is 10.5 mm).
fn mesh_shapes() -> Vec<ShapeKind> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/meshes");
    let load = |file: &str, axes: [f64; 3]| {
        let mesh = clatter::mesh::read_mesh(&dir.join(file)).unwrap_or_else(|e| panic!("{e}"));
        let points: Vec<[f64; 3]> = mesh
            .vertices
            .iter()
            .map(|v| [v[0] * axes[0], v[1] * axes[1], v[2] * axes[2]])
            .collect();
        let r = ShapeKind::Convex {
            points: points.clone(),
        }
        .prepare()
        .unwrap()
        .shape
        .bounding_radius() as f64;
        let s = 0.0075 / r;
        ShapeKind::Convex {
            points: points.iter().map(|p| p.map(|c| c * s)).collect(),
        }
    };
    vec![
        load("rock.obj", [1.0, 1.0, 1.0]),
        load("rock.obj", [1.0, 1.0, 0.5]),
        load("tetrahedron.ply", [1.0, 1.0, 1.0]),
    ]
}

#[test]
fn mesh_file_shapes_match_cpu_stage_by_stage() {
    let shapes = mesh_shapes();
    for s in &shapes {
        let p = s.prepare().unwrap();
        let clatter::geom::Shape::Polyhedron(h) = &p.shape else {
            panic!("a polyhedron")
        };
        assert!(h.vertices.len() <= clatter_gpu::shapes::MAX_SHAPE_VERTICES);
    }
    compare_run(lattice(5, 6, shapes), 200, 1e-5);
}

#[test]
fn scene_warning_uses_the_gpu_vertex_limit() {
    assert_eq!(
        clatter::scene::GPU_SHAPE_VERTICES,
        clatter_gpu::shapes::MAX_SHAPE_VERTICES
    );
}

/// How often touching polyhedron pairs take their remembered contact in a GPU pile, beside
/// the CPU's count on the same pile (`clatter::step::contacts::pair_narrow`): a settling
/// poured pile, stepped one step at a time, with the GPU's `touching` and `pair_memory`
/// read before and after each step. A pair-step took the remembered path when the pair
/// touched with a remembered contact and kept it with its stored margin (anchored on the
/// pose of its full test, see clatter-geom `narrow::slack::Anchor`; a full test sets the
/// margin anew). A count for the record, held to be well above zero and within a tenth of
/// the CPU's.
#[test]
fn pile_pairs_remember_their_contacts_on_the_gpu() {
    use clatter::geom::narrow;
    use clatter::pile::{PileParams, PileShape, poured};
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let is_poly = |s: &clatter::geom::Shape| matches!(s, clatter::geom::Shape::Polyhedron(_));
    let params = PileParams {
        restitution: 0.1,
        ..PileParams::default()
    };
    let mut cpu = World::new(poured(PileShape::Mixed, 128, &params, 11));
    // Poured and fallen on the CPU first (the GPU test time goes to the counted steps).
    for _ in 0..6000 {
        cpu.step().expect("CPU step");
    }
    let mut gpu = GpuWorld::new(ctx, &cpu).expect("scene fits");
    let words = |gpu: &GpuWorld, name: &str| -> Vec<u32> {
        bytemuck::pod_collect_to_vec(&gpu.debug_buffer(name).expect("stage buffer"))
    };
    let (mut gpu_touching, mut gpu_kept, mut cpu_touching, mut cpu_used) = (0, 0, 0, 0);
    gpu.step(1).expect("GPU step");
    cpu.step().expect("CPU step");
    for _ in 0..150 {
        let poly = |w: &World, k: usize| {
            let [i, j] = w.contacts.pairs()[k];
            is_poly(w.shape(i as usize)) && is_poly(w.shape(j as usize))
        };
        // The CPU's count, on the step it is about to take.
        if cpu.needs_rebuild() {
            cpu.rebuild_contacts();
        }
        for k in 0..cpu.contacts.pairs().len() {
            let (m, used) = clatter::step::contacts::pair_narrow(&cpu, k);
            if m.is_some() && poly(&cpu, k) {
                cpu_touching += 1;
                cpu_used += used as usize;
            }
        }
        cpu.step().expect("CPU step");
        let rebuilds = gpu.rebuilds();
        let (t0, m0) = (words(&gpu, "touching"), words(&gpu, "pair_memory"));
        gpu.step(1).expect("GPU step");
        if gpu.rebuilds() != rebuilds {
            continue; // a new pair list: the words do not line up
        }
        let (t1, m1) = (words(&gpu, "touching"), words(&gpu, "pair_memory"));
        let pairs = words(&gpu, "pairs");
        let np = pairs.len() / 2;
        for k in 0..np.min(t1.len()) {
            let (i, j) = (pairs[2 * k] as usize, pairs[2 * k + 1] as usize);
            if t1[k] != 1 || i >= cpu.len() || j >= cpu.len() {
                continue;
            }
            if !is_poly(cpu.shape(i)) || !is_poly(cpu.shape(j)) {
                continue;
            }
            gpu_touching += 1;
            let (h0, h1) = (m0[2 * k], m1[2 * k]);
            let (b0, b1) = (f32::from_bits(m0[2 * k + 1]), f32::from_bits(m1[2 * k + 1]));
            // The remembered path keeps the margin its full test stored, anchored on that
            // test's pose (no composites here); a full test sets it anew.
            let kept = b1.to_bits() == b0.to_bits();
            if t0[k] == 1 && narrow::is_contact_hint(h0) && h1 == h0 && kept {
                gpu_kept += 1;
            }
        }
    }
    eprintln!(
        "touching polyhedron pair-steps: GPU {gpu_touching}, of which {gpu_kept} ({:.0}%) took the remembered contact; CPU {cpu_touching}, of which {cpu_used} ({:.0}%)",
        100.0 * gpu_kept as f64 / gpu_touching.max(1) as f64,
        100.0 * cpu_used as f64 / cpu_touching.max(1) as f64,
    );
    assert!(
        gpu_touching > 500,
        "too few touching pair-steps: {gpu_touching}"
    );
    assert!(gpu_kept * 10 > gpu_touching, "{gpu_kept} of {gpu_touching}");
    // Both executors take the same motion bound, so the GPU keeps its contacts as often
    // as the CPU, to their rounding (within a twentieth).
    assert!(
        (gpu_kept as f64 - cpu_used as f64).abs() <= 0.05 * cpu_used as f64,
        "GPU {gpu_kept}, CPU {cpu_used}"
    );
}

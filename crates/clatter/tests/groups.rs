//! `[[group]] shapes = [..]`: a group of several shapes (a size distribution) takes them in
//! turn, on a lattice and at random, and random placement keeps each body's own bounding
//! sphere clear of every other (checked by brute force over all pairs). In a periodic box
//! the clearance holds through the seams too (nearest images, brute force again), while
//! without periodic axes the placement is the plain rejection sampling, bit for bit. Also: a
//! periodic scene with a mesh boundary is warned that meshes are not repeated across the seams.

use clatter::Health;
use clatter::scene::Scene;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const HEAD: &str = r#"[simulation]
steps = 10

[[material]]
name = "glass"
density = 2500.0
stiffness = 1.0e4
restitution = 0.5
friction = 0.3

[[shape]]
name = "small"
sphere = { radius = 0.001 }

[[shape]]
name = "large"
sphere = { radius = 0.003 }

[[shape]]
name = "cube"
box = { half_extents = [0.002, 0.002, 0.002] }
"#;

#[test]
fn lattice_group_takes_its_shapes_in_turn() {
    let text = format!(
        "{HEAD}\n[[group]]\nshapes = [\"small\", \"large\", \"small\", \"cube\"]\nmaterial = \"glass\"\nlattice = {{ min = [0.0, 0.0, 0.0], max = [0.06, 0.012, 0.0], spacing = 0.006 }}\n"
    );
    let scene = Scene::parse(&text, "groups.toml").expect("valid scene");
    let bodies = &scene.desc.bodies;
    // 11 x 3 lattice points in x-fastest order.
    assert_eq!(bodies.len(), 33);
    let names = ["small", "large", "small", "cube"];
    let index = |n: &str| match n {
        "small" => 0,
        "large" => 1,
        _ => 2,
    };
    for (j, b) in bodies.iter().enumerate() {
        assert_eq!(b.shape, index(names[j % 4]), "body {j}");
        let (x, y) = ((j % 11) as f32 * 0.006, (j / 11) as f32 * 0.006);
        let p = b.position.as_vec3();
        assert!((p.x - x).abs() < 1e-6 && (p.y - y).abs() < 1e-6);
    }
    // A repeated name weights the mix: half the bodies are small.
    let small = bodies.iter().filter(|b| b.shape == 0).count();
    assert_eq!(small, 17);
}

#[test]
fn random_group_keeps_each_body_clear_by_its_own_radius() {
    let text = format!(
        "{HEAD}\n[[group]]\nshapes = [\"small\", \"large\"]\nmaterial = \"glass\"\nrandom = {{ min = [0.0, 0.0, 0.0], max = [0.04, 0.04, 0.04], count = 400, seed = 9 }}\n"
    );
    let scene = Scene::parse(&text, "groups.toml").expect("valid scene");
    let bodies = &scene.desc.bodies;
    assert_eq!(bodies.len(), 400);
    let radius = |s: u32| scene.desc.shapes[s as usize].shape.bounding_radius();
    for (j, b) in bodies.iter().enumerate() {
        assert_eq!(b.shape, (j % 2) as u32);
    }
    let mut closest = f32::INFINITY;
    for i in 0..bodies.len() {
        for j in i + 1..bodies.len() {
            let gap = bodies[i].position.distance(bodies[j].position) as f32
                - radius(bodies[i].shape)
                - radius(bodies[j].shape);
            closest = closest.min(gap);
        }
    }
    assert!(
        closest >= 0.0,
        "overlapping bounding spheres: gap {closest}"
    );
    // Small bodies pack closer than the large radius would allow: per-body radii are used.
    let small_gap = (0..bodies.len())
        .step_by(2)
        .flat_map(|i| (i + 2..bodies.len()).step_by(2).map(move |j| (i, j)))
        .map(|(i, j)| bodies[i].position.distance(bodies[j].position) as f32)
        .fold(f32::INFINITY, f32::min);
    assert!(small_gap < 2.0 * 0.003, "closest small pair {small_gap}");
}

#[test]
fn periodic_scene_with_a_mesh_boundary_is_warned() {
    let bowl =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/meshes/bowl.obj");
    let body = "\n[[body]]\nshape = \"small\"\nmaterial = \"glass\"\nposition = [0.0, 0.0, 0.1]\n";
    let boundary = format!(
        "\n[[boundary]]\nmesh = {{ file = {:?} }}\nmaterial = \"glass\"\n",
        bowl.display().to_string()
    );
    let periodic = HEAD.replace(
        "steps = 10",
        "steps = 10\nperiodic = { min = [-0.2, -0.2, -1.0], max = [0.2, 0.2, 1.0], axes = \"xy\" }",
    );
    let warned = |text: &str| {
        let scene = Scene::parse(text, "periodic.toml").expect("valid scene");
        scene
            .warnings
            .iter()
            .any(|w| w.contains("not repeated across the periodic seams"))
    };
    assert!(warned(&format!("{periodic}{body}{boundary}")));
    assert!(!warned(&format!("{periodic}{body}")));
    assert!(!warned(&format!("{HEAD}{body}{boundary}")));
}

/// The box side of the seam tests, m.
const SIDE: f32 = 0.12;
/// Top of the region the seam tests fill, m.
const TOP: f32 = 0.06;
/// Bodies in the seam tests.
const COUNT: usize = 600;

/// `COUNT` spheres and cubes (random orientations) filling `[0, SIDE]^2 x [0.01, TOP]` over a
/// floor, in a box periodic along x and y when `periodic`.
fn filled_box(periodic: bool) -> String {
    let simulation = if periodic {
        format!(
            "steps = 10\ngravity = [0.0, 0.0, -9.81]\nperiodic = {{ min = [0.0, 0.0, 0.0], max = [{SIDE}, {SIDE}, 0.0], axes = \"xy\" }}"
        )
    } else {
        "steps = 10\ngravity = [0.0, 0.0, -9.81]".to_string()
    };
    format!(
        "{}\n[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nmaterial = \"glass\"\n\n[[group]]\nshapes = [\"large\", \"cube\"]\nmaterial = \"glass\"\nrandom_orientation = true\nrandom = {{ min = [0.0, 0.0, 0.01], max = [{SIDE}, {SIDE}, {TOP}], count = {COUNT}, seed = 5 }}\n",
        HEAD.replace("steps = 10", &simulation)
    )
}

/// The shortest of the periodic images of `d` along x and y (box side `SIDE`).
fn nearest_image(d: Vec3) -> Vec3 {
    let wrap = |c: f32| c - SIDE * (c / SIDE).round();
    Vec3::new(wrap(d.x), wrap(d.y), d.z)
}

#[test]
fn random_group_in_a_periodic_box_is_clear_across_the_seams() {
    let scene = Scene::parse(&filled_box(true), "seams.toml").expect("valid scene");
    let bodies = &scene.desc.bodies;
    assert_eq!(bodies.len(), COUNT);
    let radius = |s: u32| scene.desc.shapes[s as usize].shape.bounding_radius();
    // All pairs, nearest images: no two bounding spheres overlap (rounding aside).
    let (mut closest, mut across) = (f32::INFINITY, 0);
    for i in 0..bodies.len() {
        for j in i + 1..bodies.len() {
            let raw = (bodies[j].position - bodies[i].position).as_vec3();
            let d = nearest_image(raw);
            let reach = radius(bodies[i].shape) + radius(bodies[j].shape);
            closest = closest.min(d.length() - reach);
            if d != raw && d.length() < 1.5 * reach {
                across += 1;
            }
        }
    }
    assert!(
        closest >= -1e-6,
        "bounding spheres overlap through the seams: gap {closest}"
    );
    // The seams are well populated: many pairs are neighbours only through them.
    assert!(across > 30, "only {across} close pairs across the seams");
    // The run starts without the initial-overlap error and keeps going.
    let mut world = scene.world();
    let health = Health::new(&world);
    health.check_initial(&world).expect("no initial overlap");
    for _ in 0..20 {
        world.step().expect("step");
        health.check(&world, true).expect("healthy step");
    }
}

#[test]
fn random_group_without_periodic_axes_is_plain_rejection_sampling() {
    let scene = Scene::parse(&filled_box(false), "open.toml").expect("valid scene");
    let radius = |s: u32| scene.desc.shapes[s as usize].shape.bounding_radius();
    let radii = [radius(1), radius(2)];
    // The placement redone here by brute force: uniform candidates from the group's seed,
    // each kept when clear of all kept before (no images).
    let (lo, hi) = (Vec3::new(0.0, 0.0, 0.01), Vec3::new(SIDE, SIDE, TOP));
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut kept: Vec<(Vec3, f32)> = Vec::new();
    while kept.len() < COUNT {
        let p = lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random());
        let r = radii[kept.len() % 2];
        if kept
            .iter()
            .all(|&(q, rq)| (q - p).length_squared() >= (r + rq) * (r + rq))
        {
            kept.push((p, r));
        }
    }
    let placed: Vec<Vec3> = scene
        .desc
        .bodies
        .iter()
        .map(|b| b.position.as_vec3())
        .collect();
    let expected: Vec<Vec3> = kept.iter().map(|&(p, _)| p).collect();
    assert!(placed == expected, "the open-space placement changed");
    // Periodic images of this placement do overlap: the open case really differs.
    let crossing = (0..placed.len()).any(|i| {
        (i + 1..placed.len())
            .any(|j| nearest_image(placed[j] - placed[i]).length() < radii[i % 2] + radii[j % 2])
    });
    assert!(crossing, "expected overlaps through the would-be seams");
}

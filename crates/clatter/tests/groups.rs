//! `[[group]] shapes = [..]`: a group of several shapes (a size distribution) takes them in
//! turn, on a lattice and at random, and random placement keeps each body's own bounding
//! sphere clear of every other (checked by brute force over all pairs). Also: a periodic
//! scene with a mesh boundary is warned that meshes are not repeated across the seams.

use clatter::scene::Scene;

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
        assert!((b.position.x - x).abs() < 1e-6 && (b.position.y - y).abs() < 1e-6);
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
            let gap = bodies[i].position.distance(bodies[j].position)
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
        .map(|(i, j)| bodies[i].position.distance(bodies[j].position))
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

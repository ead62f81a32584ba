//! Triangle-mesh boundaries (`[[boundary]]`): bodies on a floor of many triangles behave
//! exactly as on the plane it tiles (no ghost contacts at the internal edges), a closed mesh
//! box holds its bodies, a moving mesh's surface velocity enters the contact law (a plate
//! pushes a sphere off at `(1 + e) V`, a drum drags its ball, and does not without
//! friction), restarts from checkpoints stay bitwise, and bad mesh files are refused with the
//! file and the field named.

use std::fmt::Write as _;
use std::path::PathBuf;

use clatter::geom::narrow::Plane;
use clatter::mesh_boundary::{Boundary, BoundaryMotion};
use clatter::scene::Scene;
use clatter::{BodyInit, Checkpoint, ContactLaw, Wall, World, WorldDesc};
use glam::{Quat, Vec3};

#[path = "common/meshes.rs"]
mod meshes;
use meshes::{DENSITY, K, R, cube, floor_mesh, material, sphere};

const G: f32 = 9.81;

fn floor_wall() -> Wall {
    Wall {
        plane: Plane {
            normal: Vec3::Z,
            offset: 0.0,
        },
        material: 0,
    }
}

fn boundary(v: &[[f64; 3]], t: &[[u32; 3]], motion: BoundaryMotion, end: f64) -> Boundary {
    Boundary::new("test", v, t, [1.0; 3], 0, motion, 0.0, end).unwrap()
}

/// One body of `shape` on either the plane wall `z = 0` or the 200-triangle floor mesh.
fn on_floor(
    shape: clatter::geom::PreparedShape,
    body: BodyInit,
    mesh: bool,
    friction: f32,
) -> World {
    let (v, t) = floor_mesh(10, 0.5);
    assert_eq!(t.len(), 200);
    let desc = WorldDesc {
        shapes: vec![shape],
        materials: vec![material(friction, 0.5)],
        walls: if mesh { vec![] } else { vec![floor_wall()] },
        bodies: vec![body],
        gravity: Vec3::new(0.0, 0.0, -G),
        dt: Some(2e-5),
        skin: None,
        periodic: None,
    };
    let b = if mesh {
        vec![boundary(&v, &t, BoundaryMotion::Fixed, f64::INFINITY)]
    } else {
        vec![]
    };
    World::with_boundaries(desc, b)
}

fn body(position: Vec3, velocity: Vec3, omega: Vec3) -> BodyInit {
    BodyInit {
        shape: 0,
        material: 0,
        position: position.as_dvec3(),
        orientation: Quat::IDENTITY,
        velocity,
        angular_velocity: omega,
    }
}

fn run(w: &mut World, steps: usize) {
    for _ in 0..steps {
        w.step().unwrap();
    }
}

#[test]
fn ball_rolls_across_a_mesh_floor_exactly_as_on_the_plane() {
    // Launched sliding, the ball turns to rolling and crosses many internal edges (along the
    // grid lines, and diagonally across them and the triangles' diagonals).
    let mass = DENSITY * sphere().volume;
    let z0 = R - mass * G / K;
    for dir in [
        Vec3::X,
        Vec3::new(1.0, 1.0, 0.0).normalize(),
        Vec3::new(0.3, -1.0, 0.0).normalize(),
    ] {
        let start = Vec3::new(-0.4 * dir.x, -0.4 * dir.y, z0);
        let b = body(start, dir * 1.0, Vec3::new(0.0, 0.0, 3.0));
        let mut plane = on_floor(sphere(), b, false, 0.3);
        let mut mesh = on_floor(sphere(), b, true, 0.3);
        let steps = 35_000; // 0.7 s: about 0.6 m, 6 to 9 edges crossed
        for s in 0..steps {
            plane.step().unwrap();
            mesh.step().unwrap();
            if s % 5000 == 0 {
                assert!(
                    mesh.contact_count() == 1,
                    "one contact at step {s}: {:?} {:?}",
                    mesh.mesh_slots(),
                    mesh.state.position[0]
                );
            }
        }
        let (xp, xm) = (plane.state.position_f32(0), mesh.state.position_f32(0));
        let travelled = (xm - start).length();
        assert!(travelled > 0.5, "the ball rolled {travelled} m");
        let (vp, vm) = (plane.state.velocity[0], mesh.state.velocity[0]);
        let (wp, wm) = (plane.state.omega[0], mesh.state.omega[0]);
        // The same to float rounding (in fact bitwise: the same plane contact every step).
        assert_eq!(xp, xm, "position along {dir}");
        assert_eq!(vp, vm, "velocity along {dir}");
        assert_eq!(wp, wm, "spin along {dir}");
        assert!((vm.length() - vp.length()).abs() <= 1e-3 * vp.length());
    }
}

#[test]
fn cube_rests_on_a_mesh_floor_as_on_the_plane() {
    // Centred over a vertex shared by six triangles, rotated so that its edges cross the
    // triangles' edges.
    let q = Quat::from_rotation_z(0.3);
    let half = 0.02;
    let mk = |mesh: bool| {
        let mut b = body(
            Vec3::new(0.0, 0.0, half as f32 + 0.002),
            Vec3::ZERO,
            Vec3::ZERO,
        );
        b.orientation = q;
        on_floor(cube(half), b, mesh, 0.5)
    };
    let (mut plane, mut mesh) = (mk(false), mk(true));
    run(&mut plane, 20_000);
    run(&mut mesh, 20_000);
    let (xp, xm) = (plane.state.position[0], mesh.state.position[0]);
    assert_eq!(xp, xm, "rest position");
    assert_eq!(plane.state.orientation[0], mesh.state.orientation[0]);
    // At rest: no drift, at the static overlap height.
    let before = xm;
    run(&mut mesh, 5_000);
    let after = mesh.state.position[0];
    assert!(
        (after - before).length() < 1e-7,
        "drift {}",
        (after - before).length()
    );
    assert!(mesh.state.velocity[0].length() < 1e-4);
    assert!((after.z - half).abs() < 2e-3, "rest height {}", after.z);
}

#[test]
fn cube_slides_across_a_mesh_floor_exactly_as_on_the_plane() {
    // A cube sliding (and spinning) over many internal edges, straight and diagonally,
    // until friction stops it: the same trajectory as on the plane, bit for bit.
    let half = 0.015f32;
    for (dir, spin) in [
        (Vec3::X, 0.0f32),
        (Vec3::new(1.0, 0.7, 0.0).normalize(), 4.0),
    ] {
        let mk = |mesh: bool| {
            let mut b = body(
                Vec3::new(-0.3 * dir.x, -0.3 * dir.y, half - 1e-4),
                dir * 1.5,
                Vec3::new(0.0, 0.0, spin),
            );
            b.orientation = Quat::from_rotation_z(0.4);
            on_floor(cube(half as f64), b, mesh, 0.3)
        };
        let (mut plane, mut mesh) = (mk(false), mk(true));
        for _ in 0..20 {
            run(&mut plane, 1000);
            run(&mut mesh, 1000);
            assert_eq!(
                plane.state.position[0], mesh.state.position[0],
                "along {dir}"
            );
            assert_eq!(
                plane.state.velocity[0], mesh.state.velocity[0],
                "along {dir}"
            );
        }
        let moved = (mesh.state.position_f32(0) - Vec3::new(-0.3 * dir.x, -0.3 * dir.y, 0.0))
            .truncate()
            .length();
        assert!(moved > 0.3, "slid {moved} m");
    }
}

#[test]
fn a_ball_hitting_a_plate_rim_bounces_off_along_the_rim_normal() {
    // Frictionless, no gravity: a ball falls past the border edge x = 0.1 of a plate (and
    // past its corner) and touches only the edge (the corner): it leaves with
    // v - (1 + e)(v . n) n, n from the edge (corner) point to its centre at impact.
    let e = 0.5f32;
    let (v, t) = floor_mesh(4, 0.1);
    for (start, n) in [
        (Vec3::new(0.106, 0.0, 0.02), Vec3::new(0.6, 0.0, 0.8)),
        (
            Vec3::new(0.1 + 0.006 / 2f32.sqrt(), 0.1 + 0.006 / 2f32.sqrt(), 0.02),
            Vec3::new(0.6 / 2f32.sqrt(), 0.6 / 2f32.sqrt(), 0.8),
        ),
    ] {
        // Stiff, so that the ball barely moves while in contact (0.1 ms) and the normal
        // stays the one at impact.
        let mut m = material(0.0, e);
        m.law = ContactLaw::Linear { stiffness: 1e7 };
        let desc = WorldDesc {
            shapes: vec![sphere()],
            materials: vec![m],
            walls: vec![],
            bodies: vec![body(start, Vec3::new(0.0, 0.0, -1.0), Vec3::ZERO)],
            gravity: Vec3::ZERO,
            dt: Some(1e-6),
            skin: None,
            periodic: None,
        };
        let mut w = World::with_boundaries(
            desc,
            vec![boundary(&v, &t, BoundaryMotion::Fixed, f64::INFINITY)],
        );
        run(&mut w, 30_000);
        let v0 = Vec3::new(0.0, 0.0, -1.0);
        let want = v0 - (1.0 + e) * v0.dot(n) * n;
        let got = w.state.velocity[0];
        assert!(
            (got - want).length() < 0.01 * want.length(),
            "from {start}: {got}, expected {want}"
        );
    }
}

/// A closed cube `[0, s]^3` (12 triangles, wound outward).
fn box_mesh(s: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    for k in 0..8 {
        v.push([
            s * (k & 1) as f64,
            s * ((k >> 1) & 1) as f64,
            s * ((k >> 2) & 1) as f64,
        ]);
    }
    let quads = [
        [0, 2, 3, 1], // z = 0, normal -z
        [4, 5, 7, 6], // z = s
        [0, 1, 5, 4], // y = 0
        [2, 6, 7, 3], // y = s
        [0, 4, 6, 2], // x = 0
        [1, 3, 7, 5], // x = s
    ];
    let mut t = Vec::new();
    for q in quads {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
    }
    (v, t)
}

#[test]
fn bodies_in_a_closed_mesh_box_never_escape() {
    let (v, t) = box_mesh(0.1);
    let mut bodies = Vec::new();
    for k in 0..12u32 {
        let f = k as f32;
        bodies.push(BodyInit {
            shape: k % 2,
            material: 0,
            position: glam::DVec3::new(
                0.02 + 0.03 * (k % 3) as f64,
                0.02 + 0.03 * ((k / 3) % 3) as f64,
                0.03 + 0.04 * (k / 9) as f64,
            ),
            orientation: Quat::from_rotation_x(0.3 * f),
            velocity: Vec3::new((f * 1.3).sin(), (f * 2.1).cos(), (f * 0.7).sin()) * 2.0,
            angular_velocity: Vec3::new(f, -f, 0.5 * f),
        });
    }
    let desc = WorldDesc {
        shapes: vec![sphere(), cube(0.008)],
        materials: vec![material(0.3, 0.9)],
        walls: vec![],
        bodies,
        gravity: Vec3::new(0.0, 0.0, -G),
        dt: Some(2e-5),
        skin: None,
        periodic: None,
    };
    let mut w = World::with_boundaries(
        desc,
        vec![boundary(&v, &t, BoundaryMotion::Fixed, f64::INFINITY)],
    );
    for _ in 0..50 {
        run(&mut w, 500);
        for (i, x) in w.state.position.iter().map(|x| x.as_vec3()).enumerate() {
            assert!(
                x.cmpgt(Vec3::ZERO).all() && x.cmplt(Vec3::splat(0.1)).all(),
                "body {i} escaped to {x} at t = {}",
                w.time
            );
        }
    }
}

#[test]
fn a_translating_plate_hits_a_free_sphere_off_at_one_plus_e_times_its_speed() {
    // A plate x = 0 (two triangles) moving at V along x; a free sphere (no gravity) at rest
    // ahead of it leaves at (1 + e) V, e the pair's restitution.
    let speed = 0.5f32;
    for e in [0.5f32, 0.9] {
        let v = vec![
            [0.0, -0.1, -0.1],
            [0.0, 0.1, -0.1],
            [0.0, 0.1, 0.1],
            [0.0, -0.1, 0.1],
        ];
        let t = vec![[0, 1, 2], [0, 2, 3]];
        let desc = WorldDesc {
            shapes: vec![sphere()],
            materials: vec![material(0.3, e)],
            walls: vec![],
            bodies: vec![body(Vec3::new(0.03, 0.0, 0.0), Vec3::ZERO, Vec3::ZERO)],
            gravity: Vec3::ZERO,
            dt: Some(1e-5),
            skin: None,
            periodic: None,
        };
        let motion = BoundaryMotion::Translate {
            velocity: Vec3::new(speed, 0.0, 0.0),
        };
        let mut w = World::with_boundaries(desc, vec![boundary(&v, &t, motion, f64::INFINITY)]);
        run(&mut w, 10_000); // 0.1 s: the plate reaches the sphere at 0.04 s
        let vel = w.state.velocity[0];
        let want = (1.0 + e) * speed;
        assert!(
            (vel.x - want).abs() < 0.01 * want,
            "e = {e}: sphere leaves at {vel}, expected {want}"
        );
        assert!(vel.y.abs() < 1e-6 && vel.z.abs() < 1e-6);
        // The sphere is ahead of the plate (which is at V t), never behind it.
        assert!(w.state.position_f32(0).x > speed * w.time as f32);
    }
}

/// An open tube of radius `rd` about the y axis, `y` in `[-l/2, l/2]`, `n` facets.
fn tube(rd: f64, l: f64, n: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        v.push([rd * a.cos(), -0.5 * l, rd * a.sin()]);
        v.push([rd * a.cos(), 0.5 * l, rd * a.sin()]);
    }
    let mut t = Vec::new();
    for k in 0..n {
        let (a, b) = (2 * k as u32, 2 * ((k + 1) % n) as u32);
        t.push([a, b, b + 1]);
        t.push([a, b + 1, a + 1]);
    }
    (v, t)
}

/// A ball at the bottom of a drum of radius 0.1 m turning at `omega` about y, stepped for
/// `secs`: the ball's extreme x on either side, and its mean spin about y over the run.
fn drum(omega: f32, friction: f32, secs: f64) -> (f32, f32, f32) {
    let (v, t) = tube(0.1, 0.1, 64);
    let desc = WorldDesc {
        shapes: vec![sphere()],
        materials: vec![material(friction, 0.3)],
        walls: vec![],
        bodies: vec![body(Vec3::new(0.0, 0.0, -0.09), Vec3::ZERO, Vec3::ZERO)],
        gravity: Vec3::new(0.0, 0.0, -G),
        dt: Some(2e-5),
        skin: None,
        periodic: None,
    };
    let motion = BoundaryMotion::Rotate {
        angular_velocity: Vec3::new(0.0, omega, 0.0),
        center: Vec3::ZERO,
    };
    let mut w = World::with_boundaries(desc, vec![boundary(&v, &t, motion, f64::INFINITY)]);
    let steps = (secs / 2e-5) as usize;
    let (mut lo, mut hi, mut spin) = (0.0f32, 0.0f32, 0.0f64);
    for _ in 0..steps {
        w.step().unwrap();
        let x = w.state.position_f32(0);
        assert!(
            (x.length() - 0.09).abs() < 1e-3,
            "the ball stays on the wall: {x}"
        );
        lo = lo.min(x.x);
        hi = hi.max(x.x);
        spin += w.state.omega[0].y as f64;
    }
    (lo, hi, (spin / steps as f64) as f32)
}

#[test]
fn a_turning_drum_drags_its_ball_by_friction_only() {
    // Turning at +2 rad/s about y, the drum's bottom moves at 0.2 m/s along -x: friction
    // drags the ball that way first, and spins it up towards rolling on the moving wall
    // (contact point at the wall's speed while the centre rocks about the bottom: mean spin
    // near V / R = 20 rad/s about +y). Without friction the wall slides under it and a drum
    // at rest does nothing: the ball stays at the bottom, without spin.
    let (lo, hi, spin) = drum(2.0, 0.5, 0.6);
    assert!(lo < -0.005, "dragged towards -x: {lo}");
    assert!(
        lo.abs() > hi.abs(),
        "first and furthest towards -x: {lo} {hi}"
    );
    assert!((spin - 20.0).abs() < 5.0, "mean spin {spin}");
    // Frictionless, only the facets' normals (2.8 degrees apart) rock it as they pass under
    // it; normal forces through its centre never spin it.
    let (lo, hi, spin) = drum(2.0, 0.0, 0.6);
    assert!(lo.abs() < 1.5e-3 && hi.abs() < 1.5e-3, "no drag: {lo} {hi}");
    assert!(spin.abs() < 1e-6, "no spin: {spin}");
    let (lo, hi, spin) = drum(0.0, 0.5, 0.6);
    assert!(lo.abs() < 1e-5 && hi.abs() < 1e-5, "at rest: {lo} {hi}");
    assert!(spin.abs() < 1e-3, "no spin: {spin}");
}

// ---- scenes: syntax, restart, errors ----

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("clatter-boundary-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn obj(v: &[[f64; 3]], t: &[[u32; 3]]) -> String {
    let mut s = String::new();
    for p in v {
        writeln!(s, "v {} {} {}", p[0], p[1], p[2]).unwrap();
    }
    for f in t {
        writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1).unwrap();
    }
    s
}

fn scene(boundary: &str) -> String {
    format!(
        r#"[simulation]
steps = 4000
dt = 2.0e-5
[[material]]
name = "steel"
density = 7800.0
stiffness = 1.0e4
friction = 0.4
[[shape]]
name = "ball"
sphere = {{ radius = 0.01 }}
[[shape]]
name = "die"
box = {{ half_extents = [0.008, 0.008, 0.008] }}
[[body]]
shape = "ball"
material = "steel"
position = [0.0, 0.0, -0.0897]
velocity = [0.1, 0.0, 0.0]
[[body]]
shape = "die"
material = "steel"
position = [0.03, 0.0, -0.07]
[[boundary]]
{boundary}
"#
    )
}

#[test]
fn drum_scene_restarts_bitwise_from_a_checkpoint() {
    let d = tmp_dir("restart");
    let (v, t) = tube(0.1, 0.1, 48);
    std::fs::write(d.join("drum.obj"), obj(&v, &t)).unwrap();
    let text = scene(
        r#"mesh = { file = "drum.obj", scale = 1.0 }
material = "steel"
motion = { angular_velocity = [0.0, 3.0, 0.0], center = [0.0, 0.0, 0.0] }
start = 0.01
end = 0.06"#,
    );
    let path = d.join("drum.toml");
    std::fs::write(&path, &text).unwrap();
    let name = path.display().to_string();
    let s = Scene::parse(&text, &name).unwrap();
    assert_eq!(s.boundaries.len(), 1);
    assert_eq!(s.boundaries[0].triangles.len(), 96);
    let mut full = s.world();
    run(&mut full, 4000);
    let mut half = s.world();
    run(&mut half, 2000);
    let bytes = half.checkpoint_bytes(&name, &text, &[]);
    let ck = Checkpoint::from_bytes(&bytes).unwrap();
    let (_, mut resumed) = ck.world().unwrap();
    run(&mut resumed, 2000);
    assert!(full.contact_count() > 0, "the bodies touch the drum");
    assert_eq!(full.state.position, resumed.state.position);
    assert_eq!(full.state.velocity, resumed.state.velocity);
    assert_eq!(full.state.angular_momentum, resumed.state.angular_momentum);
    assert_eq!(full.mesh_slots(), resumed.mesh_slots());
    // The checkpoint holds the scene's text, not its mesh file, which restoring reads
    // again: a file changed since (every vertex 1 cm further out) is refused, not run on.
    let moved: Vec<[f64; 3]> = v.iter().map(|p| [p[0] * 1.1, p[1], p[2] * 1.1]).collect();
    std::fs::write(d.join("drum.obj"), obj(&moved, &t)).unwrap();
    let err = Checkpoint::from_bytes(&bytes).unwrap().world().unwrap_err();
    assert!(
        matches!(err, clatter::CheckpointError::Mismatch(_)) && err.to_string().contains("mesh"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The error of a scene whose boundary mesh file `drum.<ext>` holds `contents`.
fn mesh_error(name: &str, ext: &str, contents: Option<&str>) -> String {
    let d = tmp_dir(name);
    let file = format!("m.{ext}");
    if let Some(c) = contents {
        std::fs::write(d.join(&file), c).unwrap();
    }
    let text = scene(&format!(
        "mesh = {{ file = \"{file}\", scale = 1.0 }}\nmaterial = \"steel\""
    ));
    let path = d.join("s.toml");
    match Scene::parse(&text, &path.display().to_string()) {
        Ok(_) => panic!("{name}: accepted"),
        Err(e) => {
            let msg = e.to_string();
            assert_eq!(e.field.as_deref(), Some("boundary[0].mesh.file"), "{msg}");
            assert!(msg.contains(&file), "names the mesh file: {msg}");
            assert!(msg.contains("s.toml:"), "names the scene and line: {msg}");
            msg
        }
    }
}

#[test]
fn bad_boundary_meshes_are_refused_naming_file_and_field() {
    assert!(mesh_error("missing", "obj", None).contains("cannot read"));
    assert!(mesh_error("empty", "obj", Some("# nothing\n")).contains("empty"));
    let nan = "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n";
    assert!(mesh_error("nan", "obj", Some(nan)).contains("non-finite"));
    // (Non-manifold edges, mixed and inward windings are accepted: tests/awkward_meshes.rs.)
    let (v, t) = box_mesh(1.0);
    let degenerate = "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
    assert!(mesh_error("degenerate", "obj", Some(degenerate)).contains("degenerate"));
    // And the motion's fields.
    let d = tmp_dir("motion");
    std::fs::write(d.join("m.obj"), obj(&v, &t)).unwrap();
    let path = d.join("s.toml").display().to_string();
    for (b, field) in [
        (
            "mesh = { file = \"m.obj\" }\nmaterial = \"steel\"\nmotion = { angular_velocity = [0.0, 1.0, 0.0] }",
            "boundary[0].motion.center",
        ),
        (
            "mesh = { file = \"m.obj\" }\nmaterial = \"steel\"\nmotion = { velocity = [1.0, 0.0, 0.0], angular_velocity = [0.0, 1.0, 0.0] }",
            "boundary[0].motion",
        ),
        (
            "mesh = { file = \"m.obj\" }\nmaterial = \"steel\"\nstart = 1.0\nend = 0.5",
            "boundary[0].end",
        ),
        (
            "mesh = { file = \"m.obj\", scale = -1.0 }\nmaterial = \"steel\"",
            "boundary[0].mesh.scale",
        ),
        (
            "mesh = { file = \"m.obj\" }\nmaterial = \"wood\"",
            "boundary[0].material",
        ),
    ] {
        let e = Scene::parse(&scene(b), &path).unwrap_err();
        assert_eq!(e.field.as_deref(), Some(field), "{e}");
        assert!(e.line.is_some(), "{e}");
    }
}

#[test]
fn mesh_floor_example_is_bitwise_the_same_for_any_thread_count() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/mesh-floor.toml");
    let scene = Scene::load(&path).unwrap();
    let run_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut w = scene.world();
            // Through the plate's start (t = 0.4 s) with the bodies settling in the bowl.
            let steps = (0.45 / w.dt as f64) as usize;
            run(&mut w, steps);
            assert!(w.contact_count() > 20);
            (
                w.state.position.clone(),
                w.state.velocity.clone(),
                w.mesh_slots().to_vec(),
            )
        })
    };
    let one = run_with(1);
    for threads in [2, 3] {
        assert!(
            run_with(threads) == one,
            "{threads} threads differ from one"
        );
    }
}

#[test]
fn a_fast_drum_is_not_taken_for_a_blow_up() {
    // A drum turning at 30 rad/s (3 m/s at its wall) flings balls far faster than gravity
    // alone could: the health checks count the energy moving meshes feed in.
    let (v, t) = tube(0.1, 0.1, 64);
    let mut bodies = Vec::new();
    for k in 0..8 {
        // Around the bottom, 0.3 rad (25 mm) apart.
        let a = -1.05 + 0.3 * k as f32;
        bodies.push(body(
            Vec3::new(0.085 * a.sin(), 0.0, -0.085 * a.cos()),
            Vec3::ZERO,
            Vec3::ZERO,
        ));
    }
    let desc = WorldDesc {
        shapes: vec![sphere()],
        materials: vec![material(0.5, 0.5)],
        walls: vec![],
        bodies,
        gravity: Vec3::new(0.0, 0.0, -G),
        dt: Some(2e-5),
        skin: None,
        periodic: None,
    };
    let motion = BoundaryMotion::Rotate {
        angular_velocity: Vec3::new(0.0, 30.0, 0.0),
        center: Vec3::ZERO,
    };
    let mut w = World::with_boundaries(desc, vec![boundary(&v, &t, motion, f64::INFINITY)]);
    let health = clatter::Health::new(&w);
    let mut fastest = 0.0f32;
    for _ in 0..150 {
        run(&mut w, 100);
        health.check(&w, true).unwrap_or_else(|e| panic!("{e}"));
        fastest = w
            .state
            .velocity
            .iter()
            .map(|v| v.length())
            .fold(fastest, f32::max);
    }
    assert!(fastest > 1.0, "the drum flings the balls ({fastest} m/s)");
}

#[test]
fn a_clump_lands_and_rests_on_a_mesh_floor_as_on_the_plane() {
    // A composite of two spheres and a cube (each piece against the triangles, each with its
    // own mesh slot), dropped tilted so that its pieces land one after the other: the same
    // motion as on the plane wall, to rounding (the forces are the plane's; only the order
    // of summing the pieces' forces on the body differs).
    use clatter::geom::composite::PieceSpec;
    use glam::{DQuat, DVec3};
    let piece = |shape, x: f64, y: f64| PieceSpec {
        shape,
        offset: DVec3::new(x, y, 0.0),
        orientation: DQuat::from_rotation_z(0.2),
    };
    let clump = clatter::geom::prepare_composite(&[
        piece(sphere(), -0.008, 0.0),
        piece(sphere(), 0.008, 0.0),
        piece(cube(0.006), 0.0, 0.012),
    ])
    .unwrap();
    let mut b = body(
        Vec3::new(0.013, -0.021, 0.04),
        Vec3::new(0.2, 0.1, 0.0),
        Vec3::ZERO,
    );
    b.orientation = Quat::from_rotation_y(0.35) * Quat::from_rotation_x(0.2);
    let (mut plane, mut mesh) = (
        on_floor(clump.clone(), b, false, 0.5),
        on_floor(clump, b, true, 0.5),
    );
    let mut touched = 0;
    for _ in 0..30 {
        run(&mut plane, 1000);
        run(&mut mesh, 1000);
        let (xp, xm) = (plane.state.position_f32(0), mesh.state.position_f32(0));
        assert!((xp - xm).length() < 1e-6, "{xp} vs {xm}");
        let (qp, qm) = (plane.state.orientation[0], mesh.state.orientation[0]);
        assert!(qp.dot(qm).abs() > 1.0 - 1e-6, "{qp} vs {qm}");
        touched = touched.max(mesh.contact_count());
    }
    // All three pieces came to rest on the floor, sunk by about their share of the weight.
    assert_eq!(mesh.contact_count(), 3, "{:?}", mesh.mesh_slots());
    assert_eq!(touched, 3);
    assert!(mesh.state.velocity[0].length() < 1e-3);
    assert!(mesh.state.position[0].z < 0.012 && mesh.state.position[0].z > 0.005);
}

/// The contact reports (`contacts_NNNNNN.vtu`, the blow-up checks, the initial elastic
/// energy) of a cube resting on the mesh floor: the same contact as on the plane, with the
/// mesh as the other side.
#[test]
fn mesh_contacts_are_reported_like_wall_contacts() {
    use clatter::contact_list::Partner;
    use clatter::health::{Health, touching_contacts};
    let half = 0.02;
    let mk = |mesh: bool| {
        let mut b = body(
            Vec3::new(0.01, -0.02, half as f32 + 0.001),
            Vec3::ZERO,
            Vec3::ZERO,
        );
        b.orientation = Quat::from_rotation_z(0.4);
        on_floor(cube(half), b, mesh, 0.5)
    };
    let (mut plane, mut mesh) = (mk(false), mk(true));
    run(&mut plane, 15_000);
    run(&mut mesh, 15_000);
    let (p, m) = (touching_contacts(&plane), touching_contacts(&mesh));
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!(m.len(), 1, "{m:?}");
    assert_eq!(p[0].other, Partner::Wall(0));
    assert_eq!(m[0].other, Partner::Boundary(0));
    assert_eq!(m[0].body, 0);
    // The same manifold (four corners at the same depth) and the same force, which carries
    // the cube's weight.
    assert_eq!(m[0].manifold.count, 4);
    assert_eq!(p[0].manifold.normal, m[0].manifold.normal);
    assert_eq!(p[0].manifold.max_depth(), m[0].manifold.max_depth());
    assert_eq!(p[0].force.normal_force, m[0].force.normal_force);
    let weight = DENSITY * cube(half).volume * G;
    assert!(
        (m[0].force.normal_force - weight).abs() < 1e-3 * weight,
        "normal force {} against the weight {weight}",
        m[0].force.normal_force
    );
    // The checks see the mesh contact: the full check passes at rest.
    Health::new(&mesh).check(&mesh, true).unwrap();
    // So do the per-body counts of the VTK `contacts` array and the renderers' contact
    // colours: one contact for the cube on the mesh, as on the plane.
    assert_eq!(plane.contact_counts(), vec![1]);
    assert_eq!(mesh.contact_counts(), vec![1]);
    assert_eq!(mesh.contact_count(), 1);
}

/// A body placed halfway through a mesh floor is refused before the first step, naming the
/// boundary, at the depth the plane gives; a shallow initial overlap is accepted and its
/// elastic energy counted as for the plane.
#[test]
fn a_body_placed_through_a_mesh_is_refused_at_the_start() {
    use clatter::contact_list::Partner;
    use clatter::health::{BlowUpKind, Health};
    for (z, refused) in [(0.4 * R, true), (0.9 * R, false)] {
        let b = body(Vec3::new(0.013, 0.021, z), Vec3::ZERO, Vec3::ZERO);
        let (plane, mesh) = (
            on_floor(sphere(), b, false, 0.3),
            on_floor(sphere(), b, true, 0.3),
        );
        let (hp, hm) = (Health::new(&plane), Health::new(&mesh));
        assert_eq!(hp.baseline(), hm.baseline(), "elastic energy at z = {z}");
        match hm.check_initial(&mesh) {
            Err(e) if refused => {
                let BlowUpKind::DeepOverlap { other, depth, .. } = e.kind else {
                    panic!("{e}");
                };
                assert_eq!(other, Partner::Boundary(0));
                assert!((depth - (R - z)).abs() < 1e-6, "depth {depth}");
                assert!(e.to_string().contains("boundary 0"), "{e}");
                assert!(hp.check_initial(&plane).is_err());
            }
            Ok(()) if !refused => {}
            other => panic!("z = {z}: {other:?}"),
        }
    }
}

/// A ball thrown too fast onto soft contacts sinks deeper than half its radius into the mesh
/// floor: the cheap check every 10 steps stops the run at the same step as on the plane,
/// naming the boundary.
#[test]
fn a_deep_overlap_with_a_mesh_stops_the_run_as_with_a_wall() {
    use clatter::contact_list::Partner;
    use clatter::health::{BlowUpKind, Health};
    // Peak depth v sqrt(m / k) = 10 m/s x 7.2e-4 s = 0.72 R (the law's damping makes it a
    // little less, still above the limit of 0.5 R).
    let b = body(
        Vec3::new(0.013, 0.021, 1.05 * R),
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::ZERO,
    );
    let stop = |mesh: bool| {
        let mut w = on_floor(sphere(), b, mesh, 0.3);
        let h = Health::new(&w);
        h.check_initial(&w).unwrap();
        for _ in 0..200 {
            for _ in 0..10 {
                w.step().unwrap();
            }
            if let Err(e) = h.check(&w, false) {
                return (w.step_count, e);
            }
        }
        panic!("no blow-up (mesh: {mesh})");
    };
    let ((sp, ep), (sm, em)) = (stop(false), stop(true));
    assert_eq!(sp, sm, "{ep} / {em}");
    let (
        BlowUpKind::DeepOverlap {
            other: op,
            depth: dp,
            ..
        },
        BlowUpKind::DeepOverlap {
            other: om,
            depth: dm,
            ..
        },
    ) = (ep.kind.clone(), em.kind.clone())
    else {
        panic!("{ep} / {em}");
    };
    assert_eq!(op, Partner::Wall(0));
    assert_eq!(om, Partner::Boundary(0));
    assert_eq!(dp, dm);
    assert!(dm > 0.5 * R, "depth {dm}");
}

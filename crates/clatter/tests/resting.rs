//! Bodies dropped on the floor come to rest on a face: at the height of their inradius (less
//! the static overlap `m g / k` of the linear spring), with a face normal pointing straight
//! down, with no velocity left, and they stay put. A stack of cubes stays stacked.

use clatter::geom::narrow::Plane;
use clatter::geom::{PreparedShape, RegularKind, Shape, ShapeKind};
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{Quat, Vec3};

const K: f32 = 2.0e4;
const G: f32 = 9.81;
const H: f64 = 0.01; // cube half side

fn material() -> Material {
    Material { name: "m".into(), density: 2500.0, law: ContactLaw::Linear { stiffness: K }, restitution: 0.5, friction: 0.5 }
}

fn body(position: Vec3, orientation: Quat) -> BodyInit {
    BodyInit { shape: 0, material: 0, position, orientation, velocity: Vec3::ZERO, angular_velocity: Vec3::ZERO }
}

fn world(shape: PreparedShape, bodies: Vec<BodyInit>) -> World {
    World::new(WorldDesc {
        shapes: vec![shape],
        materials: vec![material()],
        walls: vec![Wall { plane: Plane { normal: Vec3::Z, offset: 0.0 }, material: 0 }],
        bodies,
        gravity: Vec3::new(0.0, 0.0, -G),
        dt: None,
        skin: None,
    })
}

fn run_for(w: &mut World, seconds: f64) {
    let steps = (seconds / w.dt as f64).ceil() as u64;
    for _ in 0..steps {
        w.step().unwrap();
    }
}

/// Angle (degrees) between -z and the world normal of body `i`'s face closest to pointing down,
/// and that face's plane offset (its distance from the centre of mass).
fn down_face(w: &World, i: usize) -> (f32, f32) {
    let Shape::Polyhedron(p) = &w.shapes[w.shape_of[i] as usize].shape else { panic!("not a polyhedron") };
    p.faces
        .iter()
        .map(|f| {
            let n = w.orientation[i] * f.normal;
            (n.dot(-Vec3::Z).clamp(-1.0, 1.0).acos().to_degrees(), f.offset)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap()
}

/// Height of the lowest vertex of body `i` above the floor.
fn lowest_vertex(w: &World, i: usize) -> f32 {
    let Shape::Polyhedron(p) = &w.shapes[w.shape_of[i] as usize].shape else { panic!("not a polyhedron") };
    p.vertices.iter().map(|&v| (w.orientation[i] * v + w.position[i]).z).fold(f32::INFINITY, f32::min)
}

/// Rotation angle (degrees) between two orientations.
fn angle_between(a: Quat, b: Quat) -> f32 {
    let d = (a.conjugate() * b).normalize();
    (2.0 * (d.w.abs() as f64).min(1.0).acos()).to_degrees() as f32
}

/// Asserts body `i` rests on a face at the height `inradius - m g / k`, not moving, and that
/// it is still there, in the same pose, after `more` seconds.
fn assert_rests_on_face(w: &mut World, i: usize, inradius: f64, what: &str) {
    let (angle, offset) = down_face(w, i);
    let overlap = (w.mass[i] * G / K) as f64;
    let z = w.position[i].z as f64;
    let v = w.velocity[i].length();
    let omega = w.omega[i].length();
    eprintln!("{what}: dt {:.3e}, v {:?}, omega {:?}", w.dt, w.velocity[i], w.omega[i]);
    eprintln!(
        "{what}: down face {angle:.4} deg from -z, z = {z:.7} (inradius {inradius:.7} - mg/k {overlap:.3e} = {:.7}), |v| = {v:.2e}, |omega| = {omega:.2e}",
        inradius - overlap
    );
    assert!(angle < 2.0, "{what}: no face is down (closest {angle} deg)");
    assert!((offset as f64 - inradius).abs() < 1e-6 * inradius, "{what}: resting on the wrong face (offset {offset})");
    assert!((z - (inradius - overlap)).abs() < 0.05 * overlap, "{what}: height {z}, expected {}", inradius - overlap);
    // f32 state: with `x += v dt` a speed below about ulp(z) / (2 dt) (~1e-4 m/s here) does
    // not move the body at all, and the damping cannot remove what the quantised overlap
    // force leaves, so a "resting" body keeps |v| ~ 1e-5 m/s that never moves it. At rest
    // therefore means: tiny velocities, and no displacement over a further second (below).
    assert!(v < 1e-4, "{what}: still moving at {v} m/s");
    assert!(omega < 1e-2, "{what}: still turning at {omega} rad/s");
    let (x0, q0) = (w.position[i], w.orientation[i]);
    run_for(w, 1.0);
    let drift = (w.position[i] - x0).length();
    let turn = angle_between(q0, w.orientation[i]);
    eprintln!("{what}: after 1 s more: moved {drift:.2e} m, turned {turn:.2e} deg");
    assert!(drift < 1e-6, "{what}: crept {drift} m");
    assert!(turn < 1e-3, "{what}: turned {turn} deg");
}

fn cube() -> PreparedShape {
    ShapeKind::Box { half_extents: [H, H, H] }.prepare().unwrap()
}

#[test]
fn cube_dropped_flat_rests_on_its_face() {
    let mut w = world(cube(), vec![body(Vec3::new(0.0, 0.0, H as f32 + 0.005), Quat::IDENTITY)]);
    run_for(&mut w, 1.0);
    assert_rests_on_face(&mut w, 0, H, "flat cube");
    // Dropped straight: nothing sideways, no turn.
    assert!(w.position[0].truncate().length() < 1e-6, "moved sideways to {}", w.position[0]);
    assert!(angle_between(Quat::IDENTITY, w.user_orientation(0)) < 0.01);
}

/// Which authored face (+-x, +-y, +-z) of a cube points down.
fn authored_down_face(w: &World, i: usize) -> Vec3 {
    let q = w.user_orientation(i);
    [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
        .into_iter()
        .max_by(|a, b| (q * *a).dot(-Vec3::Z).total_cmp(&(q * *b).dot(-Vec3::Z)))
        .unwrap()
}

#[test]
fn cube_dropped_on_an_edge_tips_onto_a_face() {
    // Rotated about x by 45 deg +- 1 deg: an edge parallel to x is lowest, and gravity tips
    // the cube towards the face that is already closer to the floor: -y for 46 deg, -z for 44.
    for (deg, expected_face) in [(46.0f32, -Vec3::Y), (44.0, -Vec3::Z)] {
        let q = Quat::from_rotation_x(deg.to_radians());
        let mut w = world(cube(), vec![body(Vec3::ZERO, q)]);
        let lift = 0.002 - lowest_vertex(&w, 0);
        w.position[0].z += lift;
        w.invalidate_pairs();
        run_for(&mut w, 1.5);
        let face = authored_down_face(&w, 0);
        eprintln!("{deg} deg: face {face} down");
        assert_eq!(face, expected_face, "{deg} deg: tipped onto the wrong face");
        assert_rests_on_face(&mut w, 0, H, &format!("cube on edge {deg} deg"));
    }
}

#[test]
fn tetrahedron_and_icosahedron_come_to_rest_on_a_face() {
    let r = 0.012;
    // Inradius over circumradius: 1/3 for the tetrahedron, sqrt(1/3 + 2 sqrt(5)/15) for the
    // icosahedron.
    let cases = [
        (RegularKind::Tetrahedron, r / 3.0),
        (RegularKind::Icosahedron, r * (1.0 / 3.0 + 2.0 * 5f64.sqrt() / 15.0).sqrt()),
    ];
    for (kind, inradius) in cases {
        for (k, q) in [Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, 1.1), Quat::from_euler(glam::EulerRot::XYZ, 2.0, -0.4, 0.2)]
            .into_iter()
            .enumerate()
        {
            let shape = ShapeKind::Regular { kind, radius: r }.prepare().unwrap();
            let mut w = world(shape, vec![body(Vec3::ZERO, q)]);
            let lift = 0.004 - lowest_vertex(&w, 0);
            w.position[0].z += lift;
            w.invalidate_pairs();
            run_for(&mut w, 2.0);
            assert_rests_on_face(&mut w, 0, inradius, &format!("{} #{k}", kind.name()));
        }
    }
}

#[test]
fn three_cubes_stay_stacked() {
    let gap = 1.0e-4f32;
    let h = H as f32;
    let bodies = (0..3).map(|k| body(Vec3::new(0.0, 0.0, h + k as f32 * (2.0 * h + gap) + gap), Quat::IDENTITY)).collect();
    let mut w = world(cube(), bodies);
    run_for(&mut w, 1.0);
    let mg_k = w.mass[0] * G / K;
    // Static overlaps: the floor carries 3 weights, the lower interface 2, the upper 1.
    let expected = [h - 3.0 * mg_k, 3.0 * h - 5.0 * mg_k, 5.0 * h - 6.0 * mg_k];
    let snapshot: Vec<(Vec3, Quat)> = (0..3).map(|i| (w.position[i], w.orientation[i])).collect();
    for i in 0..3 {
        eprintln!("cube {i}: z = {:.7}, expected {:.7}, v {:.2e}", w.position[i].z, expected[i], w.velocity[i].length());
        assert!((w.position[i].z - expected[i]).abs() < 0.05 * mg_k, "cube {i} at {}, expected {}", w.position[i].z, expected[i]);
        assert!(w.position[i].truncate().length() < 1e-6, "cube {i} moved sideways to {}", w.position[i]);
        assert!(angle_between(Quat::IDENTITY, w.user_orientation(i)) < 0.01, "cube {i} turned");
        assert!(w.velocity[i].length() < 1e-4 && w.omega[i].length() < 1e-2, "cube {i} still moving");
    }
    assert_eq!(w.touching_pairs(), vec![[0, 1], [1, 2]]);
    run_for(&mut w, 1.0);
    for i in 0..3 {
        assert!((w.position[i] - snapshot[i].0).length() < 1e-6, "cube {i} crept");
        assert!(angle_between(snapshot[i].1, w.orientation[i]) < 1e-3, "cube {i} turned");
    }
}

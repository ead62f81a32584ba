//! Precise positions anywhere in a large domain (issue 24): a step's displacement is kept at
//! any coordinate, and contacts are resolved to the precision of the overlap, not of the
//! coordinate, because relative geometry is taken from differences of the (f64 on the CPU,
//! double-single on the GPU) positions.
//!
//! - a 1 mm sphere drifting at 1 mm/s with dt = 1 us moves `v t` at (5, 5, 5) m and at 1 km;
//! - a 1 mm sphere resting on a wall at z = 10 m and z = 100 m settles to `m g / k`;
//! - a mixed pile translated by (100, -50, 20) m follows the same trajectories as at the origin;
//! - a collision across a periodic seam at x = 0.1 m is the collision at the origin;
//! - the blow-up message names float spacing when a resting overlap is below a few spacings.
//!
//! clatter-gpu's `tests/physics.rs` includes this file with its `gpu-step` feature on: the
//! same checks then step the GPU (with fewer steps and bodies: lavapipe is slow).

#[path = "common/step.rs"]
mod step_backend;
use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::pile::{self, PileParams, PileShape};
use clatter::{BodyInit, ContactLaw, Health, Material, Periodic, Wall, World, WorldDesc};
use glam::{DVec3, Quat, Vec3};
use step_backend::step_n;

/// Steps of the drift test (100,000 on the CPU; 20,000 on the GPU, where lavapipe is slow).
#[cfg(not(feature = "gpu-step"))]
const DRIFT_STEPS: u64 = 100_000;
#[cfg(feature = "gpu-step")]
const DRIFT_STEPS: u64 = 20_000;

/// Bodies of the translated pile (about 2,000 on the CPU, fewer on the GPU's lavapipe).
#[cfg(not(feature = "gpu-step"))]
const PILE_BODIES: usize = 2_000;
#[cfg(feature = "gpu-step")]
const PILE_BODIES: usize = 300;

const R: f32 = 1e-3;
const DENSITY: f32 = 2500.0;
const K: f32 = 1e4;
const G: f32 = 9.81;

fn material(restitution: f32) -> Material {
    Material::new(
        "m",
        DENSITY,
        ContactLaw::Linear { stiffness: K },
        restitution,
        0.5,
    )
}

fn sphere(position: DVec3, velocity: Vec3) -> BodyInit {
    BodyInit {
        shape: 0,
        material: 0,
        position,
        orientation: Quat::IDENTITY,
        velocity,
        angular_velocity: Vec3::ZERO,
    }
}

fn world(
    bodies: Vec<BodyInit>,
    walls: Vec<Wall>,
    gravity: Vec3,
    periodic: Option<Periodic>,
) -> World {
    World::new(WorldDesc {
        shapes: vec![ShapeKind::Sphere { radius: R as f64 }.prepare().unwrap()],
        materials: vec![material(0.5)],
        walls,
        bodies,
        gravity,
        dt: Some(1e-6),
        skin: None,
        periodic,
    })
}

/// A 1 mm sphere at `x0` drifting at 1 mm/s, no gravity, no contact: it moves `v t`.
fn drift(x0: DVec3) {
    let v = Vec3::new(1e-3, 0.0, 0.0);
    let mut w = world(vec![sphere(x0, v)], vec![], Vec3::ZERO, None);
    step_n(&mut w, DRIFT_STEPS).unwrap();
    let moved = w.state.position[0] - x0;
    let expected = v.x as f64 * w.time;
    let err = (moved.x - expected).abs() / expected;
    eprintln!(
        "drift at {x0}: moved {:.9e} m in {DRIFT_STEPS} steps, v t = {expected:.9e} m, error {err:.2e}",
        moved.x
    );
    assert!(err < 1e-3, "moved {} m, expected {expected} m", moved.x);
    assert!(moved.y == 0.0 && moved.z == 0.0, "{moved}");
}

#[test]
fn drift_at_five_metres_moves_v_t() {
    drift(DVec3::new(5.0, 5.0, 5.0));
}

#[test]
fn drift_at_one_kilometre_moves_v_t() {
    drift(DVec3::new(1000.0, -1000.0, 1000.0));
}

/// A 1 mm sphere placed just touching a floor wall at height `z`, settled under gravity:
/// its overlap is `m g / k` within 1%, and the blow-up checks pass all along.
fn rests_on_floor(z: f32) {
    let floor = Wall {
        plane: Plane {
            normal: Vec3::Z,
            offset: z,
        },
        material: 0,
    };
    let top = z as f64 + R as f64;
    let x0 = DVec3::new(3.0, -2.0, top);
    let mut w = world(
        vec![sphere(x0, Vec3::ZERO)],
        vec![floor],
        Vec3::new(0.0, 0.0, -G),
        None,
    );
    let health = Health::new(&w);
    let mg_k = (w.consts.mass[0] * G / K) as f64;
    // 30 ms: hundreds of contact durations (t_c about 100 us), damped by e = 0.5.
    for _ in 0..30 {
        step_n(&mut w, 1000).unwrap();
        health.check(&w, true).unwrap();
    }
    let overlap = top - w.state.position[0].z;
    eprintln!(
        "resting at z = {z}: overlap {overlap:.6e} m, m g / k = {mg_k:.6e} m, speed {:.2e} m/s",
        w.state.velocity[0].length()
    );
    assert!(
        (overlap - mg_k).abs() < 0.01 * mg_k,
        "overlap {overlap:e} m, expected m g / k = {mg_k:e} m"
    );
    assert!(w.state.velocity[0].length() < 1e-5);
}

#[test]
fn rests_on_a_floor_at_ten_metres() {
    rests_on_floor(10.0);
}

#[test]
fn rests_on_a_floor_at_one_hundred_metres() {
    rests_on_floor(100.0);
}

/// A mixed pile (spheres and the five Platonic solids, stacked in a box) settled for a while,
/// then run on at the origin and translated by (100, -50, 20) m: the trajectories agree (the
/// walls are moved to offsets that are exact in f32 at both places).
#[test]
fn translated_pile_follows_the_same_trajectories() {
    let p = PileParams::default();
    let mut desc = pile::pile(PileShape::Mixed, PILE_BODIES, &p);
    for w in &mut desc.walls {
        w.plane.offset = (w.plane.offset * 1024.0).round() / 1024.0;
    }
    let mut origin = World::new(desc);
    step_n(&mut origin, 200).unwrap();
    let t = DVec3::new(100.0, -50.0, 20.0);
    let mut moved = origin.clone();
    for x in &mut moved.state.position {
        *x += t;
    }
    for w in &mut moved.walls {
        w.plane.offset = (w.plane.offset as f64 + w.plane.normal.as_dvec3().dot(t)) as f32;
    }
    origin.set_needs_rebuild(true);
    moved.set_needs_rebuild(true);
    step_n(&mut origin, 200).unwrap();
    step_n(&mut moved, 200).unwrap();
    let size = 2.0 * p.radius as f64;
    let mut worst = 0.0f64;
    for i in 0..origin.len() {
        let d = (moved.state.position[i] - t - origin.state.position[i]).length();
        worst = worst.max(d);
    }
    let speed = origin
        .state
        .velocity
        .iter()
        .map(|v| v.length())
        .fold(0.0, f32::max);
    eprintln!(
        "translated pile: {} bodies, worst position difference {:.3e} of a body size (fastest body {speed:.2e} m/s)",
        origin.len(),
        worst / size
    );
    // The agreement tolerance of the CPU/GPU trajectory tests (clatter-gpu tests/stages.rs).
    assert!(worst < 1e-4 * size, "trajectories diverged by {worst} m");
}

/// Two 1 mm spheres meeting head-on at `at` along x (a periodic box `[-0.1, 0.1)` m along x
/// when `seam`, so that they meet across its face at x = 0.1 m): their velocities after.
fn head_on(seam: bool) -> [Vec3; 2] {
    let (gap, v) = (2e-5, 0.05f32);
    // At the box's faces as stored (f32), so that the gap across the seam is the same.
    let face = 0.1f32 as f64;
    let (a, b) = if seam {
        (face - R as f64 - gap, -face + R as f64 + gap)
    } else {
        (-(R as f64) - gap, R as f64 + gap)
    };
    let periodic = seam.then_some(Periodic {
        min: Vec3::new(-0.1, -0.1, -0.1),
        max: Vec3::new(0.1, 0.1, 0.1),
        axes: [true, false, false],
    });
    let mut w = world(
        vec![
            sphere(DVec3::new(a, 0.0, 0.0), Vec3::new(v, 0.0, 0.0)),
            sphere(DVec3::new(b, 0.0, 0.0), Vec3::new(-v, 0.0, 0.0)),
        ],
        vec![],
        Vec3::ZERO,
        periodic,
    );
    // 0.4 ms to meet, about 0.1 ms of contact, then apart.
    step_n(&mut w, 1500).unwrap();
    [w.state.velocity[0], w.state.velocity[1]]
}

#[test]
fn seam_collision_equals_the_collision_at_the_origin() {
    let (s, o) = (head_on(true), head_on(false));
    for k in 0..2 {
        let rel = (s[k] - o[k]).length() / o[k].length();
        eprintln!(
            "seam body {k}: {} vs {} at the origin, {rel:.2e} relative",
            s[k], o[k]
        );
        assert!(
            o[k].x.signum() != [1.0f32, -1.0][k],
            "body {k} did not rebound: {}",
            o[k]
        );
        assert!(
            rel <= 1e-6,
            "body {k}: {} vs {} ({rel:e} relative)",
            s[k],
            o[k]
        );
    }
}

/// Far enough out that a resting overlap spans less than a few position spacings, the
/// blow-up message names float spacing.
#[test]
fn blow_up_names_float_spacing_far_out() {
    let floor = |z: f32| Wall {
        plane: Plane {
            normal: Vec3::Z,
            offset: z,
        },
        material: 0,
    };
    let mk = |z: f64| {
        world(
            vec![sphere(DVec3::new(0.0, 0.0, z + R as f64), Vec3::ZERO)],
            vec![floor(z as f32)],
            Vec3::new(0.0, 0.0, -G),
            None,
        )
    };
    let far = mk(1e7);
    let cause = Health::new(&far).likely_cause(&far, 0);
    assert!(cause.contains("float spacing"), "{cause}");
    let near = mk(100.0);
    let cause = Health::new(&near).likely_cause(&near, 0);
    assert!(!cause.contains("float spacing"), "{cause}");
}

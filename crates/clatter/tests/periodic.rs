//! Periodic boundaries: a collision across the seam is the same collision, bit for bit, as
//! in a box large enough to need no seam, and a periodic gas conserves momentum to rounding.
//!
//! The seam tests use the box `[1, 1.125)` (a power-of-two length inside one binade), so a
//! position and its image `x + L` round alike: the runs must then agree exactly.

#[path = "common/step.rs"]
mod step_backend;
use clatter::geom::{RegularKind, ShapeKind};
use clatter::{BodyInit, ContactLaw, Material, Periodic, World, WorldDesc};
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use step_backend::step_n;

const L: f32 = 0.125;
const LO: f32 = 1.0;

fn material() -> Material {
    Material::new(
        "m",
        2500.0,
        ContactLaw::Linear { stiffness: 2.0e4 },
        0.7,
        0.4,
    )
}

fn world(shape: ShapeKind, bodies: Vec<BodyInit>, periodic: Option<Periodic>) -> World {
    World::new(WorldDesc {
        shapes: vec![shape.prepare().unwrap()],
        materials: vec![material()],
        walls: vec![],
        bodies,
        gravity: Vec3::ZERO,
        dt: None,
        skin: None,
        periodic,
    })
}

fn body(position: Vec3, velocity: Vec3, omega: Vec3) -> BodyInit {
    BodyInit {
        shape: 0,
        material: 0,
        position: position.as_dvec3(),
        orientation: Quat::from_rotation_z(0.3) * Quat::from_rotation_x(0.2),
        velocity,
        angular_velocity: omega,
    }
}

/// Two bodies meet across the periodic face `axis = LO + L` of the box `[LO, LO + L)`; the
/// same two bodies meet at the same place in a world without periodic boundaries. Velocities,
/// spins and (wrapped) positions must agree exactly.
fn seam_collision(shape: ShapeKind, axis: usize) {
    let r = 0.008;
    let mut u = Vec3::ZERO;
    u[axis] = 1.0;
    // Body 0 just inside the upper face; body 1 just inside the lower face, so its image is
    // just outside the upper face, 2.6 r further along the axis.
    let side = Vec3::splat(LO + 0.5 * L) - u * 0.5 * L;
    let a = side + u * (L - 1.1 * r) + Vec3::new(0.0, 0.0, 0.002).reject_from(u);
    let b_image = a + u * 2.6 * r + Vec3::new(0.001, 0.0, -0.003).reject_from(u);
    let b = b_image - u * L;
    let va = u * 0.3 + Vec3::new(0.02, -0.01, 0.03).reject_from(u);
    let vb = -u * 0.2;
    let (wa, wb) = (Vec3::new(3.0, -2.0, 1.0), Vec3::new(-1.0, 4.0, 0.5));
    let mut axes = [false; 3];
    axes[axis] = true;
    let periodic = Periodic {
        min: Vec3::splat(LO),
        max: Vec3::splat(LO + L),
        axes,
    };
    let mut seam = world(
        shape.clone(),
        vec![body(a, va, wa), body(b, vb, wb)],
        Some(periodic),
    );
    let mut open = world(shape, vec![body(a, va, wa), body(b_image, vb, wb)], None);
    assert_eq!(seam.dt, open.dt);
    let steps = (0.03 / seam.dt as f64) as u64;
    step_n(&mut seam, steps).unwrap();
    step_n(&mut open, steps).unwrap();
    // They did collide.
    assert!(
        (open.state.velocity[0] - va).length() > 0.1,
        "no collision in the reference run: {}",
        open.state.velocity[0]
    );
    for i in 0..2 {
        let (s, o) = (&seam.state, &open.state);
        let image = periodic.wrap_f64(o.position[i]);
        assert!(
            s.velocity[i] == o.velocity[i]
                && s.omega[i] == o.omega[i]
                && s.orientation[i] == o.orientation[i]
                && s.position[i] == image,
            "body {i}: velocity {} vs {}, spin {} vs {}, position {} vs {}",
            s.velocity[i],
            o.velocity[i],
            s.omega[i],
            o.omega[i],
            s.position[i],
            image
        );
        // The periodic run keeps its bodies in the box.
        let x = s.position[i][axis] as f32;
        assert!((LO..LO + L).contains(&x), "body {i} left the box: {x}");
    }
}

#[test]
fn spheres_collide_across_the_seam_as_in_an_open_box() {
    for axis in 0..3 {
        seam_collision(ShapeKind::Sphere { radius: 0.008 }, axis);
    }
}

#[test]
fn cubes_collide_across_the_seam_as_in_an_open_box() {
    let cube = ShapeKind::Regular {
        kind: RegularKind::Cube,
        radius: 0.008,
    };
    seam_collision(cube.clone(), 0);
    seam_collision(cube, 1);
}

#[test]
fn a_periodic_gas_conserves_momentum() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let n = 1000;
    let side = 0.2;
    let r = 0.004;
    // Spheres on a jittered lattice (no initial overlaps), random velocities.
    let per_side = 10;
    let spacing = side / per_side as f32;
    let mut bodies = Vec::with_capacity(n);
    for k in 0..n {
        let (x, y, z) = (
            k % per_side,
            (k / per_side) % per_side,
            k / (per_side * per_side),
        );
        let jitter = Vec3::new(
            rng.random_range(-0.1..0.1),
            rng.random_range(-0.1..0.1),
            rng.random_range(-0.1..0.1),
        ) * spacing;
        let p = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * spacing + jitter;
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        bodies.push(body(p, v, Vec3::ZERO));
    }
    let periodic = Periodic {
        min: Vec3::ZERO,
        max: Vec3::splat(side),
        axes: [true; 3],
    };
    let mut w = world(ShapeKind::Sphere { radius: r }, bodies, Some(periodic));
    let momentum = |w: &World| {
        let p = w.momentum();
        Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)
    };
    let scale: f64 = (0..n)
        .map(|i| (w.consts.mass[i] * w.state.velocity[i].length()) as f64)
        .sum();
    let p0 = momentum(&w);
    let steps = 1500;
    step_n(&mut w, steps).unwrap();
    let p1 = momentum(&w);
    let drift = (p1 - p0).length() as f64 / scale;
    // Bodies crossed the seams and collided.
    let wrapped = (0..n)
        .filter(|&i| {
            let travelled = w.state.velocity[i] * (steps as f32 * w.dt);
            travelled.length() > 0.0
        })
        .count();
    eprintln!(
        "periodic gas: {n} spheres, {steps} steps, {} rebuilds, momentum drift {drift:.2e} of sum |m v|",
        w.rebuilds
    );
    assert_eq!(wrapped, n);
    assert!(drift < 1e-5, "momentum drift {drift:.3e}");
    let inside = (0..n).all(|i| {
        let x = w.state.position_f32(i);
        x.cmpge(Vec3::ZERO).all() && x.cmplt(Vec3::splat(side)).all()
    });
    assert!(inside, "every body stays in the periodic box");
}

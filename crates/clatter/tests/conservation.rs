//! Conservation laws with many collisions:
//! - linear momentum of free bodies (spheres, cubes, icosahedra, tetrahedra; random
//!   orientations, spins, sizes; damped, frictional contacts), no walls, no gravity: every contact
//!   applies equal and opposite forces, so the total momentum can change only by f32 rounding;
//! - angular momentum about the origin of the same cloud (the normal and tangential forces of a
//!   contact act at the same point on both bodies, and semi-implicit Euler updates
//!   `x x m v + L_spin` by exactly `sum p x f dt`, which cancels per contact);
//! - kinetic plus elastic energy of frictionless, perfectly elastic (`e = 1`) spheres in a
//!   closed box of `e = 1` walls.

// clatter-gpu's tests/physics.rs includes this file with its `gpu-step` feature: the momentum
// test then steps on the GPU; the energy tests stay CPU-only (their many-body runs of 1e4+
// steps with per-step checks are too slow on Mesa's software Vulkan in CI).
#![cfg_attr(feature = "gpu-step", allow(dead_code, unused_imports))]

#[path = "common/step.rs"]
mod step_backend;
use clatter::geom::narrow::Plane;
use clatter::geom::{RegularKind, ShapeKind};
use clatter::scene::random_rotation;
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{DVec3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashSet;

const K: f32 = 2.0e4;

fn material(e: f32, mu: f32) -> Material {
    Material::new("m", 2500.0, ContactLaw::Linear { stiffness: K }, e, mu)
}

fn rand_vec(rng: &mut ChaCha8Rng, scale: f32) -> Vec3 {
    Vec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    ) * scale
}

/// `n^3` bodies of mixed shapes and sizes on a jittered lattice around the origin, converging
/// (velocity `-x / T` plus noise) so that they crowd together and collide many times.
fn cloud(n: usize, seed: u64) -> WorldDesc {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut shapes = Vec::new();
    for r in [0.008, 0.01, 0.012] {
        shapes.push(ShapeKind::Sphere { radius: r }.prepare().unwrap());
        for kind in [
            RegularKind::Cube,
            RegularKind::Icosahedron,
            RegularKind::Tetrahedron,
        ] {
            shapes.push(ShapeKind::Regular { kind, radius: r }.prepare().unwrap());
        }
    }
    let spacing = 2.6 * 0.012f32;
    let half = (n as f32 - 1.0) / 2.0;
    let mut bodies = Vec::new();
    for i in 0..n * n * n {
        let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
        let base = (Vec3::new(x as f32, y as f32, z as f32) - Vec3::splat(half)) * spacing;
        let position = base + rand_vec(&mut rng, 0.1 * spacing);
        bodies.push(BodyInit {
            shape: rng.random_range(0..shapes.len()) as u32,
            material: 0,
            position: position.as_dvec3(),
            orientation: random_rotation(&mut rng),
            velocity: -position / 0.08 + rand_vec(&mut rng, 0.3),
            angular_velocity: rand_vec(&mut rng, 60.0),
        });
    }
    WorldDesc {
        shapes,
        materials: vec![material(0.5, 0.5)],
        walls: vec![],
        bodies,
        gravity: Vec3::ZERO,
        dt: None,
        skin: None,
        periodic: None,
    }
}

fn dvec(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Total momentum (f64) and the scale `sum m |v|`.
fn momentum(w: &World) -> (DVec3, f64) {
    let mut p = DVec3::ZERO;
    let mut s = 0.0;
    for i in 0..w.len() {
        let m = w.consts.mass[i] as f64;
        p += dvec(w.state.velocity[i]) * m;
        s += m * w.state.velocity[i].length() as f64;
    }
    (p, s)
}

/// Total angular momentum about the origin (f64) and the scale `sum |x x m v| + |L_spin|`.
fn angular_momentum(w: &World) -> (DVec3, f64) {
    let mut l = DVec3::ZERO;
    let mut s = 0.0;
    for i in 0..w.len() {
        let m = w.consts.mass[i] as f64;
        let orbital = w.state.position[i].cross(dvec(w.state.velocity[i]) * m);
        let spin = dvec(w.state.angular_momentum[i]);
        l += orbital + spin;
        s += orbital.length() + spin.length();
    }
    (l, s)
}

/// Counts body-body contacts that start (pairs touching now that did not touch last step).
struct CollisionCounter {
    touching: HashSet<[u32; 2]>,
    count: usize,
}

impl CollisionCounter {
    fn new() -> Self {
        Self {
            touching: HashSet::new(),
            count: 0,
        }
    }
    fn update(&mut self, w: &World) {
        let now: HashSet<[u32; 2]> = w.touching_pairs().into_iter().collect();
        self.count += now.difference(&self.touching).count();
        self.touching = now;
    }
}

#[test]
fn momentum_and_angular_momentum_of_colliding_polyhedra() {
    let mut w = World::new(cloud(6, 7));
    let (p0, ps0) = momentum(&w);
    let (l0, ls0) = angular_momentum(&w);
    let mut counter = CollisionCounter::new();
    let mut worst_p = 0.0f64;
    let mut worst_l = 0.0f64;
    // Angular momentum changes by the f32 rounding of `x += v dt` in free flight (`x x m v`
    // with a rounded `x`); summed here exactly so the contact forces' share can be checked.
    let mut worst_l_forces = 0.0f64;
    let steps = 6000;
    let mut rounding = DVec3::ZERO;
    for s in 0..steps {
        let x_prev = w.state.position.clone();
        step_backend::step(&mut w).unwrap();
        step_backend::sync(&mut w);
        counter.update(&w);
        for (i, &x0) in x_prev.iter().enumerate() {
            let v = dvec(w.state.velocity[i]);
            let ideal = x0 + v * w.dt as f64;
            rounding += (w.state.position[i] - ideal).cross(v * w.consts.mass[i] as f64);
        }
        if s % 100 == 99 {
            let (p, _) = momentum(&w);
            let (l, _) = angular_momentum(&w);
            worst_p = worst_p.max((p - p0).length() / ps0);
            worst_l = worst_l.max((l - l0).length() / ls0);
            worst_l_forces = worst_l_forces.max((l - l0 - rounding).length() / ls0);
        }
    }
    let (p1, ps1) = momentum(&w);
    eprintln!(
        "{} bodies, {steps} steps (dt {:.3e}), {} collisions; momentum {p0:?} -> {p1:?}, scale {ps0:.4e} -> {ps1:.4e}, worst rel drift {worst_p:.2e}; angular momentum {l0:?}, scale {ls0:.4e}, worst rel drift {worst_l:.2e}, without position rounding {worst_l_forces:.2e}",
        w.len(),
        w.dt,
        counter.count
    );
    assert!(counter.count >= 500, "only {} collisions", counter.count);
    assert!(worst_p < 1e-5, "momentum drifted by {worst_p} of sum m|v|");
    // The contacts conserve angular momentum about the origin to f32 rounding of the forces
    // (measured 1e-7)...
    assert!(
        worst_l_forces < 1e-6,
        "contacts changed the angular momentum by {worst_l_forces} of its scale"
    );
    // ...but the f32 positions drift in free flight (rounding of `x += v dt` is biased for a
    // constant `v`), which moves `sum x x m v` by about 3e-5 of its scale over 6000 steps.
    assert!(
        worst_l < 1e-4,
        "angular momentum drifted by {worst_l} of its scale"
    );
}

/// Elastic overlap energy of sphere contacts, `k d^2 / 2` for every overlapping pair and wall.
fn spring_energy(w: &World, radius: &[f32]) -> f64 {
    let mut e = 0.0;
    for i in 0..w.len() {
        for j in i + 1..w.len() {
            let d = (radius[i] + radius[j]) as f64
                - (w.state.position[j] - w.state.position[i]).length();
            if d > 0.0 {
                e += 0.5 * K as f64 * d * d;
            }
        }
        for wall in &w.walls {
            let d = radius[i] as f64
                - (wall.plane.normal.dot(w.state.position_f32(i)) - wall.plane.offset) as f64;
            if d > 0.0 {
                e += 0.5 * K as f64 * d * d;
            }
        }
    }
    e
}

#[test]
#[cfg(not(feature = "gpu-step"))]
fn energy_of_elastic_spheres_in_a_box() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let shapes: Vec<_> = [0.008, 0.01, 0.012]
        .iter()
        .map(|&r| ShapeKind::Sphere { radius: r }.prepare().unwrap())
        .collect();
    let n = 5;
    let side = 0.12f32;
    let spacing = side / n as f32;
    let mut bodies = Vec::new();
    for i in 0..n * n * n {
        let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
        let c = (Vec3::new(x as f32, y as f32, z as f32) + Vec3::splat(0.5)) * spacing;
        bodies.push(BodyInit {
            shape: rng.random_range(0..3),
            material: 0,
            position: (c + rand_vec(&mut rng, 0.1 * spacing)).as_dvec3(),
            orientation: Quat::IDENTITY,
            velocity: rand_vec(&mut rng, 0.6),
            angular_velocity: Vec3::ZERO,
        });
    }
    let walls = [
        (Vec3::X, 0.0),
        (-Vec3::X, -side),
        (Vec3::Y, 0.0),
        (-Vec3::Y, -side),
        (Vec3::Z, 0.0),
        (-Vec3::Z, -side),
    ]
    .into_iter()
    .map(|(normal, offset)| Wall {
        plane: Plane { normal, offset },
        material: 0,
    })
    .collect();
    let radius: Vec<f32> = bodies
        .iter()
        .map(|b| [0.008f32, 0.01, 0.012][b.shape as usize])
        .collect();
    let mut w = World::new(WorldDesc {
        shapes,
        materials: vec![material(1.0, 0.0)],
        walls,
        bodies,
        gravity: Vec3::ZERO,
        dt: None,
        skin: None,
        periodic: None,
    });
    let e0 = w.kinetic_energy() + spring_energy(&w, &radius);
    let mut counter = CollisionCounter::new();
    let mut wall_touching = vec![false; w.len() * 6];
    let mut wall_hits = 0;
    let mut worst = 0.0f64;
    let steps = (1.0 / w.dt as f64) as usize;
    for s in 0..steps {
        w.step().unwrap();
        counter.update(&w);
        for i in 0..w.len() {
            for (k, wall) in w.walls.iter().enumerate() {
                let t =
                    wall.plane.normal.dot(w.state.position_f32(i)) - wall.plane.offset < radius[i];
                if t && !wall_touching[i * 6 + k] {
                    wall_hits += 1;
                }
                wall_touching[i * 6 + k] = t;
            }
        }
        if s % 50 == 0 {
            let e = w.kinetic_energy() + spring_energy(&w, &radius);
            worst = worst.max((e / e0 - 1.0).abs());
        }
    }
    let e1 = w.kinetic_energy() + spring_energy(&w, &radius);
    eprintln!(
        "{} spheres, {steps} steps: {} sphere-sphere collisions, {wall_hits} wall hits, energy {e0:.6e} -> {e1:.6e} (rel {:.2e}), worst {worst:.2e}",
        w.len(),
        counter.count,
        (e1 / e0 - 1.0)
    );
    assert!(counter.count >= 1000, "only {} collisions", counter.count);
    assert!(wall_hits >= 200, "only {wall_hits} wall hits");
    assert!(worst < 0.01, "energy drifted by {worst}");
    // Frictionless spheres do not spin up: the normal force points through the centres, so
    // the torque `(p - x) x f` is zero but for the f32 rounding of `p - x` (measured:
    // |omega| R about 2e-5 m/s after 25 000 collisions, against speeds of 0.3 m/s).
    let max_spin = w
        .state
        .omega
        .iter()
        .map(|o| o.length())
        .fold(0.0f32, f32::max);
    eprintln!("max spin {max_spin} rad/s");
    assert!(
        max_spin * 0.012 < 1e-4,
        "frictionless spheres spin at {max_spin} rad/s"
    );
    // Nobody escaped the box.
    assert!(w.state.position.iter().all(
        |p| p.cmpge(glam::DVec3::ZERO).all() && p.cmple(glam::DVec3::splat(side as f64)).all()
    ));
}

/// A frictionless, perfectly elastic (`e = 1`, so no damping) polyhedron bouncing off a wall
/// with a random orientation and spin must leave with the kinetic energy (translational plus
/// rotational) it came with. The time step is a quarter of the default so that integration
/// error is far below the tolerance (measured: unchanged results at t_c/800).
#[test]
#[cfg(not(feature = "gpu-step"))]
fn elastic_frictionless_polyhedron_wall_bounce_keeps_its_energy() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut failures = Vec::new();
    for kind in [
        RegularKind::Cube,
        RegularKind::Tetrahedron,
        RegularKind::Icosahedron,
    ] {
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for case in 0..40 {
            let shape = ShapeKind::Regular { kind, radius: 0.01 }.prepare().unwrap();
            let orientation = random_rotation(&mut rng);
            let angular_velocity = rand_vec(&mut rng, 30.0);
            let mut w = World::new(WorldDesc {
                shapes: vec![shape],
                materials: vec![material(1.0, 0.0)],
                walls: vec![Wall {
                    plane: Plane {
                        normal: Vec3::Z,
                        offset: 0.0,
                    },
                    material: 0,
                }],
                bodies: vec![BodyInit {
                    shape: 0,
                    material: 0,
                    position: glam::DVec3::ZERO,
                    orientation,
                    velocity: Vec3::new(0.0, 0.0, -0.5),
                    angular_velocity,
                }],
                gravity: Vec3::ZERO,
                dt: None,
                skin: None,
                periodic: None,
            });
            w.dt /= 4.0;
            let clatter::geom::Shape::Polyhedron(p) = &w.shapes[0].shape else {
                unreachable!()
            };
            let lowest = p
                .vertices
                .iter()
                .map(|&v| (w.state.orientation[0] * v).z)
                .fold(f32::INFINITY, f32::min);
            w.state.position[0].z = (3e-4 - lowest) as f64;
            let e0 = w.kinetic_energy();
            // Until it is out of reach of the wall and moving away (possibly after several hits).
            while !(w.state.position[0].z > 0.011 && w.state.velocity[0].z > 0.0) {
                w.step().unwrap();
            }
            let ratio = w.kinetic_energy() / e0;
            lo = lo.min(ratio);
            hi = hi.max(ratio);
            if (ratio - 1.0).abs() > 0.01 {
                failures.push(format!(
                    "{} #{case}: energy after / before = {ratio:.4}",
                    kind.name()
                ));
            }
        }
        eprintln!(
            "{}: energy after / before in [{lo:.4}, {hi:.4}]",
            kind.name()
        );
    }
    assert!(
        failures.is_empty(),
        "{} of 120 bounces changed the energy by more than 1%:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// An energy sample's one pass (`energies_and_momentum`) gives bit for bit the three
/// separate exact sums, and those agree with plain f64 sums of the textbook terms
/// (`m v^2 / 2 + w.L / 2`, `-m g.x`, `m v`), removed bodies left out of the kinetic
/// energy and the momentum. 729 bodies: more than one parallel piece of the sums.
#[test]
fn one_pass_energy_sample_is_the_three_sums() {
    let mut desc = cloud(9, 11);
    desc.gravity = Vec3::new(0.3, -0.2, -9.81);
    let mut w = World::new(desc);
    for i in [0, 100, 511, 512, 700] {
        w.state.removed[i] = true;
    }
    let (k, p, m) = w.energies_and_momentum();
    assert_eq!(k.to_bits(), w.kinetic_energy().to_bits());
    assert_eq!(p.to_bits(), w.potential_energy().to_bits());
    assert_eq!(m.map(f64::to_bits), w.momentum().map(f64::to_bits));
    let (mut k2, mut p2, mut m2) = (0.0f64, 0.0f64, DVec3::ZERO);
    for i in 0..w.len() {
        let mass = w.consts.mass[i] as f64;
        p2 -= mass * dvec(w.gravity).dot(w.state.position[i]);
        if w.state.removed[i] {
            continue;
        }
        let v = dvec(w.state.velocity[i]);
        k2 += 0.5 * mass * v.length_squared()
            + 0.5 * dvec(w.state.omega[i]).dot(dvec(w.state.angular_momentum[i]));
        m2 += v * mass;
    }
    assert!(k > 0.0 && (k - k2).abs() <= 1e-6 * k, "{k} {k2}");
    assert!((p - p2).abs() <= 1e-6 * p.abs(), "{p} {p2}");
    let scale = w.consts.mass.iter().map(|&m| m as f64).sum::<f64>();
    for c in 0..3 {
        assert!((m[c] - m2[c]).abs() <= 1e-6 * scale, "{m:?} {m2:?}");
    }
}

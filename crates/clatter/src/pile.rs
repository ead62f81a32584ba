//! The benchmark pile: `n` bodies stacked on a simple cubic lattice, touching, in a box with a
//! floor and four side walls, under gravity. Used by `clatter bench`, `cargo bench` and tests,
//! and written out for LAMMPS so both codes time the same pile.

use glam::{Quat, Vec3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::material::{ContactLaw, Material};
use crate::scene::random_rotation;
use crate::world::{BodyInit, Wall, WorldDesc};
use clatter_geom::narrow::Plane;
use clatter_geom::{RegularKind, ShapeKind};

/// Which bodies fill the pile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PileShape {
    /// Spheres.
    Sphere,
    /// Axis-aligned cubes, face to face.
    Cube,
    /// The five Platonic solids and spheres in turn, randomly oriented.
    Mixed,
}

/// Parameters of the pile (SI units). The defaults are a glass-bead-like granular material
/// with a soft linear spring, as in typical DEM benchmarks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PileParams {
    /// Circumradius of every body, m.
    pub radius: f32,
    /// kg/m^3.
    pub density: f32,
    /// Linear normal stiffness, N/m.
    pub stiffness: f32,
    /// Coefficient of restitution.
    pub restitution: f32,
    /// Friction coefficient.
    pub friction: f32,
}

impl Default for PileParams {
    fn default() -> Self {
        Self {
            radius: 0.01,
            density: 2500.0,
            stiffness: 2.0e4,
            restitution: 0.5,
            friction: 0.5,
        }
    }
}

/// Lattice dimensions for `n` bodies: a square footprint about as wide as the pile is tall.
pub fn lattice_dims(n: usize) -> [usize; 3] {
    let side = (n as f64).cbrt().ceil().max(1.0) as usize;
    let layers = n.div_ceil(side * side);
    [side, side, layers]
}

/// How the pile is made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PileKind {
    /// Stacked on a simple cubic lattice, touching ([`pile`]).
    Lattice,
    /// Rained into the box from a loose lattice with random jitter, orientation and speed
    /// ([`poured`]), then settled by the caller until at rest.
    Poured,
}

/// Bodies rained into a box: the lattice of [`pile`] loosened to [`POUR_SPACING`] bounding
/// diameters in every direction, each body jittered by up to a twentieth of its radius
/// along each axis, randomly oriented, and given a random velocity of up to 0.1 m/s per axis
/// (all from `seed`). The box has the loose lattice's footprint.
pub fn poured(shape: PileShape, n: usize, p: &PileParams, seed: u64) -> WorldDesc {
    let mut desc = pile(shape, n, p);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    use rand::Rng;
    let spacing = match shape {
        PileShape::Cube => 2.0 * p.radius / 3f32.sqrt(),
        _ => 2.0 * p.radius,
    };
    let scale = POUR_SPACING * 2.0 * p.radius / spacing;
    let jitter = 0.05 * p.radius;
    let jit = |rng: &mut ChaCha8Rng| rng.random_range(-1.0f32..=1.0);
    for b in &mut desc.bodies {
        let x = b.position.as_vec3() * scale;
        let mut y = x + jitter * Vec3::new(jit(&mut rng), jit(&mut rng), jit(&mut rng));
        y.z = y.z.max(p.radius * 1.05);
        b.position = y.as_dvec3();
        b.orientation = random_rotation(&mut rng);
        b.velocity = 0.1 * Vec3::new(jit(&mut rng), jit(&mut rng), jit(&mut rng));
    }
    for w in &mut desc.walls {
        w.plane.offset *= scale;
    }
    desc
}

/// The poured pile's starting lattice spacing, in bounding diameters.
pub const POUR_SPACING: f32 = 1.15;

/// Builds the pile description.
pub fn pile(shape: PileShape, n: usize, p: &PileParams) -> WorldDesc {
    let r = p.radius as f64;
    let kinds: Vec<ShapeKind> = match shape {
        PileShape::Sphere => vec![ShapeKind::Sphere { radius: r }],
        PileShape::Cube => vec![ShapeKind::Regular {
            kind: RegularKind::Cube,
            radius: r,
        }],
        PileShape::Mixed => RegularKind::ALL
            .into_iter()
            .map(|kind| ShapeKind::Regular { kind, radius: r })
            .chain([ShapeKind::Sphere { radius: r }])
            .collect(),
    };
    let shapes: Vec<_> = kinds
        .iter()
        .map(|k| k.prepare().expect("valid built-in shape"))
        .collect();
    // Spacing: touching spheres / face-to-face cubes / touching bounding spheres.
    let spacing = match shape {
        PileShape::Cube => 2.0 * p.radius / 3f32.sqrt(),
        _ => 2.0 * p.radius,
    };
    let half = spacing / 2.0;
    // Side by side a hair apart, so neighbours in a layer do not start exactly touching along
    // whole faces and edges; layers rest on each other under gravity.
    let gap = spacing * 1.001;
    let [nx, ny, _] = lattice_dims(n);
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let mut bodies = Vec::with_capacity(n);
    for i in 0..n {
        let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
        let s = match shape {
            PileShape::Mixed => (i * 7 + z) % shapes.len(),
            _ => 0,
        };
        bodies.push(BodyInit {
            shape: s as u32,
            material: 0,
            position: Vec3::new(
                half + x as f32 * gap,
                half + y as f32 * gap,
                half + z as f32 * spacing,
            )
            .as_dvec3(),
            orientation: if shape == PileShape::Mixed {
                random_rotation(&mut rng)
            } else {
                Quat::IDENTITY
            },
            velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
        });
    }
    let material = Material::new(
        "grain",
        p.density,
        ContactLaw::Linear {
            stiffness: p.stiffness,
        },
        p.restitution,
        p.friction,
    );
    let (wx, wy) = (nx as f32 * gap, ny as f32 * gap);
    let walls = [
        (Vec3::Z, 0.0),
        (Vec3::X, 0.0),
        (-Vec3::X, -wx),
        (Vec3::Y, 0.0),
        (-Vec3::Y, -wy),
    ]
    .into_iter()
    .map(|(normal, offset)| Wall {
        plane: Plane { normal, offset },
        material: 0,
    })
    .collect();
    WorldDesc {
        shapes,
        materials: vec![material],
        walls,
        bodies,
        gravity: Vec3::new(0.0, 0.0, -9.81),
        dt: None,
        skin: None,
        periodic: None,
    }
}

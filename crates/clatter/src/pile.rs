//! The benchmark pile: `n` bodies stacked on a simple cubic lattice, touching, in a box with a
//! floor and four side walls, under gravity. Used by `clatter bench`, `cargo bench` and tests,
//! and written out for LAMMPS so both codes time the same pile.

use glam::{Quat, Vec3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::material::{ContactLaw, Material};
use crate::scene::random_rotation;
use crate::world::{BodyInit, Wall, World, WorldDesc};
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

/// `k` copies of a pile side by side on one floor, for piles too large to pour in the time a
/// benchmark has (a million bodies on a GPU): the tiles fill a grid of `ceil(sqrt(k))`
/// columns, row by row, each shifted by a whole footprint of `desc`'s box (the walls with
/// normals +x, -x, +y, -y, as [`pile`] and [`poured`] make them), so that the side walls
/// between tiles are simply left out and the tiles lean on each other where they leant on
/// those walls. The outer walls enclose the whole grid; the floor is `desc`'s. Bodies come
/// tile by tile, each tile in `desc`'s order; shapes and materials are `desc`'s. `k = 1`
/// gives `desc` itself. Errors when `k` is 0 or `desc` has not the box's five walls.
pub fn tiled(desc: &WorldDesc, k: usize) -> Result<WorldDesc, String> {
    if k == 0 {
        return Err("a tiled pile needs at least one tile".into());
    }
    if k == 1 {
        return Ok(desc.clone());
    }
    // The box: the floor and the four side walls, as `pile` makes them.
    let offset_of = |normal: Vec3| {
        desc.walls
            .iter()
            .find(|w| w.plane.normal == normal)
            .map(|w| w.plane.offset)
    };
    let (Some(floor), Some(x0), Some(x1), Some(y0), Some(y1)) = (
        offset_of(Vec3::Z),
        offset_of(Vec3::X),
        offset_of(-Vec3::X),
        offset_of(Vec3::Y),
        offset_of(-Vec3::Y),
    ) else {
        return Err("a tiled pile needs a box: a floor and four side walls".into());
    };
    if desc.walls.len() != 5 {
        return Err(format!(
            "a tiled pile needs a box of five walls, this one has {}",
            desc.walls.len()
        ));
    }
    // Planes `n . x >= offset`: the box spans x0..-x1 and y0..-y1.
    let (wx, wy) = ((-x1 - x0) as f64, (-y1 - y0) as f64);
    let columns = (k as f64).sqrt().ceil() as usize;
    let rows = k.div_ceil(columns);
    let mut bodies = Vec::with_capacity(desc.bodies.len() * k);
    for t in 0..k {
        let shift = glam::DVec3::new((t % columns) as f64 * wx, (t / columns) as f64 * wy, 0.0);
        bodies.extend(desc.bodies.iter().map(|b| BodyInit {
            position: b.position + shift,
            ..*b
        }));
    }
    let material = desc.walls[0].material;
    let walls = [
        (Vec3::Z, floor),
        (Vec3::X, x0),
        (-Vec3::X, x1 - ((columns - 1) as f64 * wx) as f32),
        (Vec3::Y, y0),
        (-Vec3::Y, y1 - ((rows - 1) as f64 * wy) as f32),
    ]
    .into_iter()
    .map(|(normal, offset)| Wall {
        plane: Plane { normal, offset },
        material,
    })
    .collect();
    Ok(WorldDesc {
        bodies,
        walls,
        ..desc.clone()
    })
}

/// `desc` with its bodies where `world` (built from it, then stepped) has them: positions,
/// orientations (as the user gave them), velocities and angular velocities, so that
/// [`tiled`] can copy a settled pile. Contact history is not carried.
pub fn settled_desc(desc: &WorldDesc, world: &World) -> WorldDesc {
    let s = &world.state;
    let bodies = desc
        .bodies
        .iter()
        .enumerate()
        .map(|(i, b)| BodyInit {
            position: s.position[i],
            orientation: world.user_orientation(i),
            velocity: s.velocity[i],
            angular_velocity: s.omega[i],
            ..*b
        })
        .collect();
    WorldDesc {
        bodies,
        ..desc.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tiles are exact translations of the pile by whole footprints, every body lies
    /// inside the outer walls as it lay inside its own box, and the walls are the box's
    /// grown to the grid.
    #[test]
    fn tiles_are_the_pile_shifted_by_whole_footprints() {
        let p = PileParams::default();
        let desc = poured(PileShape::Mixed, 300, &p, 3);
        let wall = |d: &WorldDesc, n: Vec3| {
            d.walls
                .iter()
                .find(|w| w.plane.normal == n)
                .map(|w| w.plane.offset as f64)
                .expect("box wall")
        };
        let (wx, wy) = (-wall(&desc, -Vec3::X), -wall(&desc, -Vec3::Y));
        for k in [1, 2, 5, 9, 13] {
            let t = tiled(&desc, k).expect("tiles");
            assert_eq!(t.bodies.len(), 300 * k);
            assert_eq!(t.walls.len(), 5);
            let columns = (k as f64).sqrt().ceil() as usize;
            let rows = k.div_ceil(columns);
            assert_eq!(wall(&t, Vec3::Z), wall(&desc, Vec3::Z));
            assert!((-wall(&t, -Vec3::X) - columns as f64 * wx).abs() < 1e-6);
            assert!((-wall(&t, -Vec3::Y) - rows as f64 * wy).abs() < 1e-6);
            for (j, b) in t.bodies.iter().enumerate() {
                let (tile, i) = (j / 300, j % 300);
                let a = &desc.bodies[i];
                let d = b.position - a.position;
                assert_eq!(
                    (d.x, d.y, d.z),
                    (
                        (tile % columns) as f64 * wx,
                        (tile / columns) as f64 * wy,
                        0.0
                    ),
                    "body {j}"
                );
                assert_eq!(
                    (b.shape, b.orientation, b.velocity),
                    (a.shape, a.orientation, a.velocity)
                );
                // Inside the grid's box by as much as inside its own.
                assert!(b.position.x - d.x > 0.0 && b.position.x < -wall(&t, -Vec3::X));
                assert!(b.position.y - d.y > 0.0 && b.position.y < -wall(&t, -Vec3::Y));
            }
        }
        assert!(tiled(&desc, 0).is_err());
        let mut open = desc.clone();
        open.walls.pop();
        assert!(tiled(&open, 2).is_err());
    }

    /// A stepped pile's description rebuilds the stepped world's bodies.
    #[test]
    fn a_settled_description_holds_the_stepped_states() {
        let desc = poured(PileShape::Mixed, 64, &PileParams::default(), 3);
        let mut w = World::new(desc.clone());
        for _ in 0..50 {
            w.step().expect("step");
        }
        let again = World::new(settled_desc(&desc, &w));
        for i in 0..w.len() {
            assert_eq!(again.state.position[i], w.state.position[i]);
            assert_eq!(again.state.velocity[i], w.state.velocity[i]);
            let (q, r) = (again.user_orientation(i), w.user_orientation(i));
            assert!(q.dot(r).abs() > 1.0 - 1e-6, "body {i}");
            assert!(
                (again.state.omega[i] - w.state.omega[i]).length()
                    <= 1e-5 * (1.0 + w.state.omega[i].length()),
                "body {i}"
            );
        }
    }
}

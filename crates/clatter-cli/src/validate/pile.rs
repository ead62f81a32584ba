//! A poured pile of monodisperse frictional spheres: spheres rain from a loose jittered
//! lattice into a box periodic in x and y with a floor, settle under gravity, and the packing
//! fraction is measured in an interior sub-volume: the whole periodic width (no side walls),
//! from two diameters above the floor to two diameters below the free surface (the height
//! under which 95% of the sphere centres lie). The fraction is the share of a regular grid of
//! 64 points per diameter cubed inside some sphere (sampling error well under 0.5%).
//!
//! Truth: poured frictional monodisperse spheres pack between random loose (about 0.58 at
//! `mu = 0.3`) and random close packing (about 0.64); outside that range the pile is not a
//! settled granular packing (the contact law, gravity or friction is wrong).

use clatter::geom::ShapeKind;
use clatter::geom::narrow::Plane;
use clatter::{BodyInit, ContactLaw, Material, Periodic, Wall, World, WorldDesc};
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Ctx, Outcome, Row};
use crate::plot::{Panel, Series, chart};

const R: f32 = 0.005;

/// The check's name (it runs on MPI ranks too: [`super::ranks::ON_RANKS`]).
pub const NAME: &str = "poured-pile";
const G: f32 = 9.81;

/// The check. Its world is stepped as a [`super::ranks::Spread`]: on MPI ranks, decomposed
/// over them, bitwise as one process steps it (the kinetic energy of each chunk and the
/// positions at the end are reduced and gathered), so the row is one process's.
pub fn check(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let name = NAME;
    let d = 2.0 * R;
    let (cells, layers) = if ctx.quick {
        (7usize, 10usize)
    } else {
        (14, 30)
    };
    let side = cells as f32 * d;
    let bodies = rain(cells, layers);
    let n = bodies.len();
    let material = Material::new(
        "grain",
        2500.0,
        ContactLaw::Linear {
            stiffness: if ctx.quick { 3.0e3 } else { 1.0e4 },
        },
        0.5,
        0.3,
    );
    let w = World::new(WorldDesc {
        shapes: vec![
            ShapeKind::Sphere { radius: R as f64 }
                .prepare()
                .expect("sphere"),
        ],
        materials: vec![material],
        walls: vec![Wall {
            plane: Plane {
                normal: Vec3::Z,
                offset: 0.0,
            },
            material: 0,
        }],
        bodies,
        gravity: Vec3::new(0.0, 0.0, -G),
        dt: None,
        skin: None,
        periodic: Some(Periodic {
            min: Vec3::new(0.0, 0.0, -1.0),
            max: Vec3::new(side, side, 1.0),
            axes: [true, true, false],
        }),
    });
    let dt = w.dt as f64;
    let top = (layers as f32 * 1.3 * d) as f64;
    let fall = (2.0 * top / G as f64).sqrt();
    // Whole chunks of steps until the settling time is covered; the total shown is what the
    // chunks add up to, so the progress never reads past it.
    let chunk_steps = (0.02 / dt).ceil().max(1.0) as u64;
    let settle = fall + if ctx.quick { 0.25 } else { 0.5 };
    let chunks = (settle / (chunk_steps as f64 * dt)).ceil().max(1.0) as u64;
    let seconds = (chunks * chunk_steps) as f64 * dt;
    ctx.progress(&format!(
        "{name}: {n} spheres, {seconds:.2} s ({} steps)",
        chunks * chunk_steps
    ));
    let mut sim = ctx.spread(w)?;
    let (mut t, mut ke) = (Vec::new(), Vec::new());
    for chunk in 1..=chunks {
        sim.step(chunk_steps)?;
        t.push(sim.time());
        ke.push(sim.kinetic_energy().max(1e-30));
        ctx.progress(&format!(
            "{name}: t = {:.2} s of {seconds:.2}, kinetic energy {:.2e} J",
            (chunk * chunk_steps) as f64 * dt,
            ke.last().expect("pushed")
        ));
    }
    // The measurement volume.
    let p: Vec<Vec3> = sim.positions().iter().map(|x| x.as_vec3()).collect();
    let mut heights: Vec<f32> = p.iter().map(|q| q.z).collect();
    heights.sort_by(f32::total_cmp);
    let surface = heights[(0.95 * (n - 1) as f64) as usize];
    let (z_lo, z_hi) = (2.0 * d, surface - 2.0 * d);
    let phi = packing_fraction(&p, cells, surface, z_lo, z_hi);
    let rows = vec![Row::range(
        name,
        &format!(
            "{n} spheres, mu=0.3, z in [{:.1}, {:.1}] d",
            z_lo / d,
            z_hi / d
        ),
        "packing fraction",
        0.58,
        0.64,
        phi,
        "random loose..close packing",
        dt,
    )];
    let svg = chart(
        "Poured sphere pile: settling",
        &[Panel {
            y_label: "kinetic energy (J, log)",
            x_label: "time (s)",
            series: vec![Series::line("kinetic", &t, &ke)],
            log: true,
        }],
    );
    Ok(Outcome {
        rows,
        plots: vec![(format!("{name}.svg"), svg)],
    })
}

/// The spheres of the pour: `layers` layers of `cells` x `cells` on a jittered lattice one
/// diameter apart (1.3 diameters between layers), with small random sideways speeds.
fn rain(cells: usize, layers: usize) -> Vec<BodyInit> {
    let d = 2.0 * R;
    let side = cells as f32 * d;
    let pitch = side / cells as f32;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut bodies = Vec::new();
    for l in 0..layers {
        for i in 0..cells * cells {
            let (x, y) = ((i % cells) as f32 + 0.5, (i / cells) as f32 + 0.5);
            let j = |rng: &mut ChaCha8Rng| rng.random_range(-0.08..0.08f32);
            bodies.push(BodyInit {
                shape: 0,
                material: 0,
                position: Vec3::new(
                    (x + j(&mut rng)) * pitch,
                    (y + j(&mut rng)) * pitch,
                    R * 1.5 + l as f32 * 1.3 * d + j(&mut rng) * d,
                )
                .as_dvec3(),
                orientation: Quat::IDENTITY,
                velocity: Vec3::new(
                    rng.random_range(-0.05..0.05),
                    rng.random_range(-0.05..0.05),
                    0.0,
                ),
                angular_velocity: Vec3::ZERO,
            });
        }
    }
    bodies
}

/// The share of a grid of points (4 per diameter along each axis) in `z_lo..z_hi` over the
/// whole periodic width that lies inside some sphere centred at `p` (periodic in x and y,
/// the box `cells` diameters wide; `surface` bounds the sphere centres' grid from above).
fn packing_fraction(p: &[Vec3], cells: usize, surface: f32, z_lo: f32, z_hi: f32) -> f64 {
    let d = 2.0 * R;
    let side = cells as f32 * d;
    // Spheres binned by cell (one diameter) for the point test, periodic in x and y.
    let nz = (surface / d).ceil() as usize + 2;
    let mut grid: Vec<Vec<Vec3>> = vec![Vec::new(); cells * cells * nz];
    let cell = |q: Vec3| -> (usize, usize, usize) {
        let f = |v: f32, n: usize| ((v / d).floor() as i64).rem_euclid(n as i64) as usize;
        (
            f(q.x, cells),
            f(q.y, cells),
            ((q.z / d).floor().max(0.0) as usize).min(nz - 1),
        )
    };
    for q in p {
        let (x, y, z) = cell(*q);
        grid[(z * cells + y) * cells + x].push(*q);
    }
    let per = 4usize;
    let h = d / per as f32;
    let (mut inside, mut total) = (0u64, 0u64);
    let mut zs = z_lo + 0.5 * h;
    while zs < z_hi {
        for iy in 0..cells * per {
            for ix in 0..cells * per {
                let q = Vec3::new((ix as f32 + 0.5) * h, (iy as f32 + 0.5) * h, zs);
                let (cx, cy, cz) = cell(q);
                let mut hit = false;
                'search: for dz in -1i64..=1 {
                    let z = cz as i64 + dz;
                    if z < 0 || z >= nz as i64 {
                        continue;
                    }
                    for dy in -1i64..=1 {
                        for dx in -1i64..=1 {
                            let x = (cx as i64 + dx).rem_euclid(cells as i64) as usize;
                            let y = (cy as i64 + dy).rem_euclid(cells as i64) as usize;
                            for s in &grid[(z as usize * cells + y) * cells + x] {
                                let mut r = q - *s;
                                r.x -= side * (r.x / side).round();
                                r.y -= side * (r.y / side).round();
                                if r.length_squared() < R * R {
                                    hit = true;
                                    break 'search;
                                }
                            }
                        }
                    }
                }
                inside += hit as u64;
                total += 1;
            }
        }
        zs += h;
    }
    inside as f64 / total.max(1) as f64
}

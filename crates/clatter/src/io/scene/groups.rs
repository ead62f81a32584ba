//! `[[group]]`: many bodies at once, of one shape or of several taken in turn, on a lattice
//! or placed at random without overlap (rejection sampling against every body placed before,
//! on a hash grid: [`Occupancy`]). Random placement and random orientations draw from seeded
//! ChaCha8 generators, so a scene file always gives the same bodies.

use std::collections::HashMap;

use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use toml::Spanned;

use super::raw::{RawGroup, RawLattice, RawRandom};
use super::{MAX_BODIES, SceneError, SourceFile};
use crate::periodic::Periodic;
use crate::world::BodyInit;
use clatter_geom::PreparedShape;

/// Validates every `[[group]]` in order and appends its bodies to `bodies` (which holds the
/// `[[body]]` entries, so that random groups avoid them); returns the lattice warnings.
pub(super) fn groups(
    cx: &SourceFile,
    raw: &[Spanned<RawGroup>],
    shapes: &[PreparedShape],
    shape_names: &HashMap<String, u32>,
    material_names: &HashMap<String, u32>,
    periodic: Option<Periodic>,
    bodies: &mut Vec<BodyInit>,
) -> Result<Vec<String>, SceneError> {
    let mut warnings = Vec::new();
    let rmax = shapes
        .iter()
        .map(|s| s.shape.bounding_radius())
        .fold(0.0, f32::max);
    let mut occupancy = Occupancy::new(2.0 * rmax, periodic);
    for b in bodies.iter() {
        occupancy.insert(
            b.position.as_vec3(),
            shapes[b.shape as usize].shape.bounding_radius(),
        );
    }
    for (k, g) in raw.iter().enumerate() {
        let r = g.get_ref();
        let f = |name: &str| format!("group[{k}].{name}");
        let group_shapes = group_shapes(cx, k, g, shape_names)?;
        let material = cx.lookup(material_names, &r.material, &f("material"), "material")?;
        let velocity = cx.opt_vec3(&r.velocity, &f("velocity"))?;
        let angular_velocity = cx.opt_vec3(&r.angular_velocity, &f("angular_velocity"))?;
        let radii: Vec<f32> = group_shapes
            .iter()
            .map(|&sh| shapes[sh as usize].shape.bounding_radius())
            .collect();
        // The largest shape of the group sets the lattice warning.
        let (widest, radius) =
            radii.iter().enumerate().fold(
                (0, 0.0f32),
                |(wi, wr), (i, &r)| if r > wr { (i, r) } else { (wi, wr) },
            );
        let positions = match (&r.lattice, &r.random) {
            (Some(l), None) => lattice(
                cx,
                k,
                l.get_ref(),
                radius,
                shape_name(shape_names, group_shapes[widest]),
                &mut warnings,
            )?,
            (None, Some(rr)) => random(cx, k, rr.get_ref(), r.seed, &radii, &mut occupancy)?,
            (Some(l), Some(_)) => {
                return cx.err(
                    l.span(),
                    f("lattice"),
                    "give either `lattice` or `random`, not both",
                );
            }
            (None, None) => {
                return cx.err(
                    g.span(),
                    format!("group[{k}]"),
                    "needs `lattice = {..}` or `random = {..}`",
                );
            }
        };
        let mut rng = ChaCha8Rng::seed_from_u64(r.seed.unwrap_or(7) ^ 0x5eed_0000 ^ k as u64);
        if r.lattice.is_some() {
            for (j, &p) in positions.iter().enumerate() {
                occupancy.insert(p, radii[j % radii.len()]);
            }
        }
        for (j, p) in positions.into_iter().enumerate() {
            let shape = group_shapes[j % group_shapes.len()];
            let orientation = if r.random_orientation {
                random_rotation(&mut rng)
            } else {
                Quat::IDENTITY
            };
            bodies.push(BodyInit {
                shape,
                material,
                position: p.as_dvec3(),
                orientation,
                velocity,
                angular_velocity,
            });
        }
    }
    Ok(warnings)
}

/// The shapes of group `k`, taken in turn by its bodies: `shape`, or a `shapes` list.
fn group_shapes(
    cx: &SourceFile,
    k: usize,
    g: &Spanned<RawGroup>,
    shape_names: &HashMap<String, u32>,
) -> Result<Vec<u32>, SceneError> {
    let r = g.get_ref();
    let f = |name: &str| format!("group[{k}].{name}");
    let group_shapes: Vec<u32> = match (&r.shape, &r.shapes) {
        (Some(one), None) => vec![cx.lookup(shape_names, one, &f("shape"), "shape")?],
        (None, Some(list)) => {
            if list.get_ref().is_empty() {
                return cx.err(list.span(), f("shapes"), "must name at least one shape");
            }
            let mut out = Vec::with_capacity(list.get_ref().len());
            for (j, name) in list.get_ref().iter().enumerate() {
                out.push(cx.lookup(shape_names, name, &f(&format!("shapes[{j}]")), "shape")?);
            }
            out
        }
        (Some(one), Some(_)) => {
            return cx.err(
                one.span(),
                f("shape"),
                "give either `shape` or `shapes`, not both",
            );
        }
        (None, None) => {
            return cx.err(
                g.span(),
                format!("group[{k}]"),
                "needs `shape = \"name\"` or `shapes = [\"a\", \"b\", ..]`",
            );
        }
    };
    Ok(group_shapes)
}

/// The positions of group `k`'s `lattice = { min, max, spacing }`, x fastest; warns when the
/// spacing is below the bounding diameter `2 radius` of its widest shape (named `widest`).
fn lattice(
    cx: &SourceFile,
    k: usize,
    l: &RawLattice,
    radius: f32,
    widest: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<Vec3>, SceneError> {
    let f = |name: &str| format!("group[{k}].{name}");
    let lo = cx.vec3(&l.min, &f("lattice.min"))?;
    let hi = cx.vec3(&l.max, &f("lattice.max"))?;
    let spacing = cx.positive(&l.spacing, &f("lattice.spacing"))?;
    if !hi.cmpge(lo).all() {
        return cx.err(
            l.max.span(),
            f("lattice.max"),
            "must be >= lattice.min on every axis",
        );
    }
    // The tolerance keeps `max = min + n * spacing` at n + 1 bodies despite rounding
    // (0.06 / 0.02 = 2.9999999 in f32).
    let counts =
        ((hi - lo).as_dvec3() / spacing + glam::DVec3::splat(1e-4)).floor() + glam::DVec3::ONE;
    let total = counts.x * counts.y * counts.z;
    if total > MAX_BODIES as f64 {
        return cx.err(
            l.spacing.span(),
            f("lattice.spacing"),
            format!("would create {total:.0} bodies (limit {MAX_BODIES})"),
        );
    }
    if (spacing as f32) < 2.0 * radius {
        warnings.push(format!(
                        "group[{k}]: lattice spacing {spacing} is below the bounding diameter {} of shape `{}`: bodies may start overlapping",
                        2.0 * radius,
                        widest
                    ));
    }
    let mut out = Vec::with_capacity(total as usize);
    for z in 0..counts.z as u32 {
        for y in 0..counts.y as u32 {
            for x in 0..counts.x as u32 {
                out.push(lo + Vec3::new(x as f32, y as f32, z as f32) * spacing as f32);
            }
        }
    }
    Ok(out)
}

/// The positions of group `k`'s `random = { min, max, count, seed }` (the seed falls back on
/// the group's, then 1), placed clear of everything in `occupancy`, which records them.
fn random(
    cx: &SourceFile,
    k: usize,
    rr: &RawRandom,
    group_seed: Option<u64>,
    radii: &[f32],
    occupancy: &mut Occupancy,
) -> Result<Vec<Vec3>, SceneError> {
    let f = |name: &str| format!("group[{k}].{name}");
    let lo = cx.vec3(&rr.min, &f("random.min"))?;
    let hi = cx.vec3(&rr.max, &f("random.max"))?;
    if !hi.cmpge(lo).all() {
        return cx.err(
            rr.max.span(),
            f("random.max"),
            "must be >= random.min on every axis",
        );
    }
    let count = *rr.count.get_ref();
    if count <= 0 || count as usize > MAX_BODIES {
        return cx.err(
            rr.count.span(),
            f("random.count"),
            format!("must be between 1 and {MAX_BODIES}, got {count}"),
        );
    }
    let seed = rr.seed.or(group_seed).unwrap_or(1);
    match occupancy.place_random(lo, hi, radii, count as usize, seed) {
                    Ok(p) => Ok(p),
                    Err(placed) => {
                        cx.err(
                            rr.count.span(),
                            f("random.count"),
                            format!("could place only {placed} of {count} bodies without overlap in the region; enlarge random.min/max or lower the count"),
                        )
                    }
                }
}

/// Uniform random unit quaternion (Shoemake).
pub fn random_rotation(rng: &mut impl Rng) -> Quat {
    let (u1, u2, u3): (f32, f32, f32) = (rng.random(), rng.random(), rng.random());
    let tau = std::f32::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    Quat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    )
    .normalize()
}

/// The name a shape index was declared with (for messages).
fn shape_name(names: &HashMap<String, u32>, index: u32) -> &str {
    names
        .iter()
        .find(|(_, i)| **i == index)
        .map_or("?", |(n, _)| n.as_str())
}

/// Bounding spheres placed so far, on a hash grid, so random groups avoid every earlier body.
/// In a periodic box the spheres are kept wrapped into it and a new one is tested against
/// the images of its neighbours across the seams too (the nearest image, as the step sees it).
struct Occupancy {
    cell: f32,
    grid: HashMap<(i64, i64, i64), Vec<u32>>,
    placed: Vec<(Vec3, f32)>,
    periodic: Option<Periodic>,
}

impl Occupancy {
    /// Empty, with grid cells of size `cell` (the largest bounding diameter).
    fn new(cell: f32, periodic: Option<Periodic>) -> Self {
        Self {
            cell: cell.max(1e-12),
            grid: HashMap::new(),
            placed: Vec::new(),
            periodic,
        }
    }

    /// The grid cell holding `p`.
    fn key(&self, p: Vec3) -> (i64, i64, i64) {
        let g = (p / self.cell).floor();
        (g.x as i64, g.y as i64, g.z as i64)
    }

    /// `p` brought into the periodic box along its periodic axes, however far outside it lies
    /// (a random region may be wider than the box); `p` itself without periodic axes.
    fn wrapped(&self, p: Vec3) -> Vec3 {
        let Some(b) = &self.periodic else {
            return p;
        };
        let mut out = p;
        for k in 0..3 {
            let len = b.max[k] - b.min[k];
            if b.axes[k] && len > 0.0 {
                out[k] = b.min[k] + (p[k] - b.min[k]).rem_euclid(len);
            }
        }
        out
    }

    /// Records a sphere of radius `r` at `p` (wrapped into the periodic box).
    fn insert(&mut self, p: Vec3, r: f32) {
        let p = self.wrapped(p);
        let k = self.key(p);
        self.grid
            .entry(k)
            .or_default()
            .push(self.placed.len() as u32);
        self.placed.push((p, r));
    }

    /// Whether a sphere of radius `r` at `p` is clear of every sphere placed so far (of their
    /// nearest images, in a periodic box).
    fn free(&self, p: Vec3, r: f32) -> bool {
        let Some(b) = &self.periodic else {
            return self.free_at(p, r);
        };
        // Neighbours within reach lie at most one cell beyond a face: images of `p` shifted
        // across the faces it is near meet them in the grid.
        let (images, count) = b.images_near(self.wrapped(p), self.cell);
        images[..count].iter().all(|&q| self.free_at(q, r))
    }

    /// Whether a sphere of radius `r` at `p` is clear of the stored spheres (no images).
    fn free_at(&self, p: Vec3, r: f32) -> bool {
        let (kx, ky, kz) = self.key(p);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(list) = self.grid.get(&(kx + dx, ky + dy, kz + dz)) {
                        for &j in list {
                            let (q, rq) = self.placed[j as usize];
                            if (q - p).length_squared() < (r + rq) * (r + rq) {
                                return false;
                            }
                        }
                    }
                }
            }
        }
        true
    }

    /// Places `count` bounding spheres (radii taken in turn from `radii`) uniformly in `[lo, hi]`, clear of everything
    /// placed before (rejection sampling); `Err(placed)` after 10,000 misses in a row.
    fn place_random(
        &mut self,
        lo: Vec3,
        hi: Vec3,
        radii: &[f32],
        count: usize,
        seed: u64,
    ) -> Result<Vec<Vec3>, usize> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut out = Vec::with_capacity(count);
        let mut failures = 0usize;
        while out.len() < count {
            let p = lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random());
            let radius = radii[out.len() % radii.len()];
            if self.free(p, radius) {
                self.insert(p, radius);
                out.push(p);
                failures = 0;
            } else {
                failures += 1;
                if failures > 10_000 {
                    return Err(out.len());
                }
            }
        }
        Ok(out)
    }
}

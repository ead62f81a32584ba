//! Stage 1 of the step, the **broad** phase: **bin**, **sort** and **pairs** on a uniform grid.
//!
//! Cells are at least as large as the largest bounding-sphere diameter plus the Verlet skin,
//! so every body whose (skin-inflated) bounding sphere can touch another lies in one of the 27
//! cells around it. Bodies are binned by centre, counting-sorted by cell key, and each body
//! looks only at bodies with a larger index in the neighbouring cells, so each pair is found
//! once. Output is sorted by `(i, j)`, independent of the thread count.

use clatter_geom::Shape;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::contact_list::{Contacts, carry_springs};
use crate::periodic::Periodic;
use crate::world::World;

/// The grid a rebuild used: its origin, cell size and cell counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Lower corner.
    pub min: Vec3,
    /// Edge length of a cubic cell.
    pub cell_size: f32,
    /// Number of cells along x, y, z.
    pub dims: [u32; 3],
}

impl Grid {
    /// A grid around `positions` with cells of at least `min_cell`; cells grow when the bodies
    /// are so spread out that the grid would have more than about 8 cells per body.
    pub fn around(positions: &[Vec3], min_cell: f32) -> Grid {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &p in positions {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if positions.is_empty() {
            lo = Vec3::ZERO;
            hi = Vec3::ZERO;
        }
        let extent = (hi - lo).max(Vec3::ZERO);
        let max_cells = 8.0 * positions.len() as f64 + 64.0;
        let mut cell = min_cell.max(1e-12);
        loop {
            let d = (extent / cell).floor() + Vec3::ONE;
            if (d.x as f64) * (d.y as f64) * (d.z as f64) <= max_cells {
                return Grid {
                    min: lo,
                    cell_size: cell,
                    dims: [d.x as u32, d.y as u32, d.z as u32],
                };
            }
            cell *= 1.5;
        }
    }

    /// Integer cell coordinates of `p`, clamped into the grid (never dropped).
    #[inline]
    pub fn cell_of(&self, p: Vec3) -> [u32; 3] {
        let g = ((p - self.min) / self.cell_size).floor();
        [
            (g.x.max(0.0) as u32).min(self.dims[0] - 1),
            (g.y.max(0.0) as u32).min(self.dims[1] - 1),
            (g.z.max(0.0) as u32).min(self.dims[2] - 1),
        ]
    }

    /// Linear cell key, x fastest.
    #[inline]
    pub fn key(&self, c: [u32; 3]) -> u32 {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Total number of cells.
    pub fn cell_count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }
}

/// **bin**: the cell key of every body.
pub fn bin(grid: &Grid, positions: &[Vec3]) -> Vec<u32> {
    positions
        .par_iter()
        .map(|&p| grid.key(grid.cell_of(p)))
        .collect()
}

/// **sort**: a stable counting sort of body indices by cell key. Returns the sorted indices
/// and `cell_start` (length `cells + 1`): cell `c` holds `sorted[cell_start[c]..cell_start[c+1]]`.
pub fn sort(keys: &[u32], cells: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; cells + 1];
    for &k in keys {
        start[k as usize + 1] += 1;
    }
    for c in 0..cells {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut sorted = vec![0u32; keys.len()];
    for (i, &k) in keys.iter().enumerate() {
        sorted[fill[k as usize] as usize] = i as u32;
        fill[k as usize] += 1;
    }
    (sorted, start)
}

/// **pairs**: all `(i, j)` with `i < j` whose bounding spheres, each grown by `skin / 2`,
/// overlap. Sorted by `(i, j)`.
pub fn pairs(grid: &Grid, positions: &[Vec3], radii: &[f32], skin: f32) -> Vec<[u32; 2]> {
    pairs_periodic(grid, positions, radii, skin, None)
}

/// [`pairs`] in a periodic box: bodies near a periodic face also look for partners around
/// their images across it (only one image of a pair can be within reach: the box is at least
/// three cells long). `positions` are wrapped into the box.
pub fn pairs_periodic(
    grid: &Grid,
    positions: &[Vec3],
    radii: &[f32],
    skin: f32,
    periodic: Option<&Periodic>,
) -> Vec<[u32; 2]> {
    let keys = bin(grid, positions);
    let (sorted, start) = sort(&keys, grid.cell_count());
    let dims = grid.dims;
    // Bodies in fixed runs of `RUN`, one task and one list each (a list per body cost an
    // allocation and its regrowths per body); each body's partners sorted within its run's
    // list, so the runs joined in order are the pairs sorted.
    const RUN: usize = 256;
    let n = positions.len();
    let per_run: Vec<Vec<[u32; 2]>> = (0..n.div_ceil(RUN))
        .into_par_iter()
        .map(|run| {
            let mut out: Vec<[u32; 2]> = Vec::with_capacity(8 * RUN);
            // Compiled for AVX2 where the CPU has it (`vex`: the same operations, with the
            // three-operand forms and an inline `floor`): the same pairs.
            super::vex(|| {
                for i in run * RUN..((run + 1) * RUN).min(n) {
                    let first = out.len();
                    let ri = radii[i];
                    let (images, count) = match periodic {
                        Some(p) => p.images_near(positions[i], grid.cell_size),
                        None => ([positions[i]; 8], 1),
                    };
                    for &pi in &images[..count] {
                        let c = grid.cell_of(pi);
                        for z in c[2].saturating_sub(1)..=(c[2] + 1).min(dims[2] - 1) {
                            for y in c[1].saturating_sub(1)..=(c[1] + 1).min(dims[1] - 1) {
                                let row = grid.key([0, y, z]);
                                let x0 = c[0].saturating_sub(1);
                                let x1 = (c[0] + 1).min(dims[0] - 1);
                                // Cells x0..=x1 of this row are contiguous in key order.
                                let s = start[(row + x0) as usize] as usize;
                                let e = start[(row + x1 + 1) as usize] as usize;
                                for &j in &sorted[s..e] {
                                    if j as usize > i {
                                        let reach = ri + radii[j as usize] + skin;
                                        if (positions[j as usize] - pi).length_squared()
                                            < reach * reach
                                        {
                                            out.push([i as u32, j]);
                                        }
                                    }
                                }
                            }
                        }
                    }
                    out[first..].sort_unstable();
                }
            });
            out
        })
        .collect();
    per_run.concat()
}

/// The same pairs by checking all `n (n-1) / 2` of them: the reference for tests.
pub fn pairs_brute_force(positions: &[Vec3], radii: &[f32], skin: f32) -> Vec<[u32; 2]> {
    pairs_brute_force_periodic(positions, radii, skin, None)
}

/// [`pairs_brute_force`] with nearest-image distances in a periodic box.
pub fn pairs_brute_force_periodic(
    positions: &[Vec3],
    radii: &[f32],
    skin: f32,
    periodic: Option<&Periodic>,
) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    for i in 0..positions.len() {
        for j in i + 1..positions.len() {
            let reach = radii[i] + radii[j] + skin;
            let d = positions[j] - positions[i];
            let d = periodic.map_or(d, |p| p.nearest(d));
            if d.length_squared() < reach * reach {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

/// The broad phase of a step: pairs and wall candidates at the current positions, springs
/// carried over from the old list where a pair persists.
pub(crate) fn rebuild(world: &mut World) {
    // The springs carried below are the list's own: a near list's written back first.
    world.contacts.end_near();
    // Bins and bounding-sphere tests at the positions rounded to f32 (as the GPU does, from
    // the high part of its double-single positions): the skin absorbs the rounding.
    // (Per body, in parallel: an indexed collect keeps the order.)
    let positions: Vec<Vec3> = (world.state.position.par_iter())
        .map(|p| p.as_vec3())
        .collect();
    let radii = &world.consts.radius;
    let grid = Grid::around(&positions, 2.0 * world.consts.max_radius() + world.skin);
    let mut pairs = pairs_periodic(
        &grid,
        &positions,
        radii,
        world.skin,
        world.periodic.as_ref(),
    );
    // Bodies removed by a sink are binned as any other (the grid does not depend on them
    // being in) but take part in no pair.
    let removed = &world.state.removed;
    if removed.iter().any(|&r| r) {
        pairs.retain(|&[i, j]| !(removed[i as usize] || removed[j as usize]));
    }
    // A rank's ghosts (`crate::domain`) pair only with the bodies it owns.
    let ghost = &world.ghost;
    if !ghost.is_empty() {
        pairs.retain(|&[i, j]| !(ghost[i as usize] && ghost[j as usize]));
    }
    let wall_pairs = wall_candidates(world, &world.state.position);
    if world.has_composites() {
        let contacts = piece_contacts(world, pairs, wall_pairs);
        world.install_contacts(contacts);
        super::mesh_contacts::rebuild(world);
        return;
    }
    let old_memory = std::mem::take(&mut world.edge_memory);
    let old = &world.contacts;
    let np_old = old.pairs.len();
    // (Empty in worlds whose contact stage keeps none: spheres only.)
    let memory = if old_memory.is_empty() {
        old_memory
    } else {
        let spare = &mut world.edge_memory_spare;
        super::caches::carry_by_pair(&old.pairs, old_memory, &pairs, spare)
    };
    let springs = &old.springs;
    let (mut history, mut twist) = carry_springs(
        &old.pairs,
        &springs.history[..np_old.min(springs.history.len())],
        &springs.twist[..np_old.min(springs.twist.len())],
        &pairs,
    );
    let (wall_history, wall_twist) = carry_springs(
        &old.wall_pairs,
        &springs.history[np_old.min(springs.history.len())..],
        &springs.twist[np_old.min(springs.twist.len())..],
        &wall_pairs,
    );
    history.extend(wall_history);
    twist.extend(wall_twist);
    let contacts = Contacts::new(world.len(), pairs, wall_pairs, history, twist);
    world.install_contacts(contacts);
    world.edge_memory = memory;
    super::mesh_contacts::rebuild(world);
}

/// The contact list of a world with composite bodies: each body pair (and body-wall pair)
/// expanded into the piece pairs whose bounding spheres, grown by the skin, overlap at the
/// current poses, each a contact with its own springs (carried over by body pair and piece
/// pair). Contacts stay sorted by body pair, then piece code, so the per-body gather order
/// is fixed.
fn piece_contacts(world: &World, pairs: Vec<[u32; 2]>, wall_pairs: Vec<[u32; 2]>) -> Contacts {
    use crate::contact_list::piece_code;
    let skin = world.skin;
    let per_pair: Vec<Vec<u32>> = pairs
        .par_iter()
        .with_min_len(64)
        .map(|&[i, j]| {
            let (i, j) = (i as usize, j as usize);
            let (si, sj) = (world.shape(i), world.shape(j));
            // Relative to body i (see `World::offset_of`).
            let (xi, xj) = (Vec3::ZERO, world.offset_of(i, j));
            let mut codes = Vec::new();
            for a in 0..si.piece_count() as u32 {
                let (pa, posea) = world.piece_at(i, a, xi);
                for b in 0..sj.piece_count() as u32 {
                    let (pb, poseb) = world.piece_at(j, b, xj);
                    let reach = pa.bounding_radius() + pb.bounding_radius() + skin;
                    if (poseb.position - posea.position).length_squared() < reach * reach {
                        codes.push(piece_code(a, b));
                    }
                }
            }
            codes
        })
        .collect();
    let mut body_pairs = Vec::new();
    let mut pieces = Vec::new();
    for (p, codes) in pairs.iter().zip(per_pair) {
        for c in codes {
            body_pairs.push(*p);
            pieces.push(c);
        }
    }
    let (walls, wall_pieces) = wall_piece_candidates(
        world,
        &wall_pairs,
        &world.state.position,
        &world.state.orientation,
    );
    // Springs carried over by (body pair, piece code).
    let old = &world.contacts;
    let np_old = old.pairs.len();
    let sp = &old.springs;
    let keyed = |pairs: &[[u32; 2]], codes: &[u32]| -> Vec<([u32; 2], u32)> {
        pairs.iter().copied().zip(codes.iter().copied()).collect()
    };
    let old_codes = if old.pieces.len() == old.len() {
        old.pieces.clone()
    } else {
        vec![0; old.len()]
    };
    let np_hist = np_old.min(sp.history.len());
    let (mut history, mut twist) = carry_springs(
        &keyed(&old.pairs, &old_codes[..np_old]),
        &sp.history[..np_hist],
        &sp.twist[..np_old.min(sp.twist.len())],
        &keyed(&body_pairs, &pieces),
    );
    let (wall_history, wall_twist) = carry_springs(
        &keyed(&old.wall_pairs, &old_codes[np_old..]),
        &sp.history[np_hist..],
        &sp.twist[np_old.min(sp.twist.len())..],
        &keyed(&walls, &wall_pieces),
    );
    history.extend(wall_history);
    twist.extend(wall_twist);
    pieces.extend(wall_pieces);
    Contacts::with_pieces(world.len(), body_pairs, walls, pieces, history, twist)
}

/// The body-wall candidates of a world with composites expanded per piece: `(body, wall)`
/// once per piece whose bounding sphere, at the body pose `positions[i]`,
/// `orientations[i]`, comes within the skin of the wall, and the pieces. The broad phase
/// calls it with the current poses; [`World::set_contact_state`] with the rebuild's.
pub(crate) fn wall_piece_candidates(
    world: &World,
    wall_pairs: &[[u32; 2]],
    positions: &[DVec3],
    orientations: &[glam::Quat],
) -> (Vec<[u32; 2]>, Vec<u32>) {
    let mut walls = Vec::new();
    let mut wall_pieces = Vec::new();
    for &[i, w] in wall_pairs {
        let plane = &world.walls[w as usize].plane;
        let (x, q) = (positions[i as usize], orientations[i as usize]);
        let shape = world.shape(i as usize);
        for a in 0..shape.piece_count() as u32 {
            let (r, centre) = match shape {
                Shape::Composite(c) => {
                    let p = &c.pieces[a as usize];
                    (p.shape.bounding_radius(), x + (q * p.position).as_dvec3())
                }
                s => (s.bounding_radius(), x),
            };
            let h = (plane.normal.as_dvec3().dot(centre) - plane.offset as f64) as f32;
            if h < r + world.skin {
                walls.push([i, w]);
                wall_pieces.push(a);
            }
        }
    }
    (walls, wall_pieces)
}

/// The largest squared distance any piece of a composite body can have moved since the last
/// rebuild: `|dx| + 2 reach |q - q0|` (a rotation by `theta` moves a point at distance `r`
/// by `2 r sin(theta/2) <= 2 r |q - q0|`, taking the closer of `q0` and `-q0`). 0 without
/// composites.
pub(crate) fn composite_moved(world: &World) -> f32 {
    if !world.has_composites() || world.rebuild_orientation.len() != world.len() {
        return 0.0;
    }
    let s = &world.state;
    // Ghosts (another rank's bodies) are their owners' to count: the largest over the
    // ranks is the same, and a ghost's state is the exchange's until it arrives.
    (0..world.len())
        .filter(|&i| world.reach[i] > 0.0 && !world.is_ghost(i))
        .map(|i| {
            let dx = crate::precise::moved(
                world.periodic.as_ref(),
                s.position[i],
                world.rebuild_position[i],
            );
            let (q, q0) = (s.orientation[i], world.rebuild_orientation[i]);
            let dq = (q - q0).length().min((q + q0).length());
            let d = dx.length() + 2.0 * world.reach[i] * dq;
            if d.is_finite() { d * d } else { f32::INFINITY }
        })
        .fold(0.0, f32::max)
}

/// Wall candidates: `(body, wall)` for the bodies (not removed by a sink, not ghosts) whose bounding
/// sphere at `positions` comes within the skin of a wall, sorted.
pub(crate) fn wall_candidates(world: &World, positions: &[DVec3]) -> Vec<[u32; 2]> {
    let mut wall_pairs = Vec::new();
    for (i, p) in positions.iter().enumerate() {
        if world.state.removed[i] || world.is_ghost(i) {
            continue;
        }
        for (w, wall) in world.walls.iter().enumerate() {
            let h = (wall.plane.normal.as_dvec3().dot(*p) - wall.plane.offset as f64) as f32;
            if h < world.consts.radius[i] + world.skin {
                wall_pairs.push([i as u32, w as u32]);
            }
        }
    }
    wall_pairs
}

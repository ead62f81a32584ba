//! Triangle-mesh boundaries (`[[boundary]]`, `clatter::boundary`) on the GPU: the host side
//! of `shaders/contacts/mesh*.wgsl`.
//!
//! # Static data (bind group 1, no binding of its own)
//! Each boundary's welded vertices and triangle normals are appended to `shape_f`, its
//! triangles, edge neighbours, vertex links and triangle grid (occupied cell keys, cell
//! starts, triangle lists, exactly the CPU's `MeshGrid`) to `shape_u`, after the shapes. A
//! header of [`HEADER_WORDS`] words per boundary (at `Params::mesh_base` in `shape_u`) says
//! where, and holds the motion (kind, velocity or angular velocity and its axis, centre,
//! reach, the angle where the motion ends).
//!
//! # State (the group-0 buffer `mesh`)
//! - [`GLOBAL_WORDS`] words: the GPU step count of the last rebuild (for the read-back of
//!   `World::mesh_rebuild_time`).
//! - per boundary, [`BOUNDARY_STATE_WORDS`] words: the time since its motion's start `t -
//!   start` as an unevaluated sum of two f32 (words 0 and 1; about 48 bits: the CPU keeps
//!   the time in f64), advanced by `end_step` every step, the elapsed motion time at the
//!   last rebuild (word 4, for the Verlet check) and the motion's duration (words 7 and 8).
//!   A rotation's angle follows from `t - start` (`clatter::turn`, twin of
//!   `shaders/common/turn.wgsl`), bitwise as the CPU's.
//! - per body, [`MESH_SLOTS`] slots of [`SLOT_WORDS`] words: the CPU's `MeshSlot`;
//! - then one word per body: whether it had a triangle within its bounding radius plus the
//!   skin at the last rebuild (the CPU's active list): bodies without skip the meshes until
//!   the next rebuild.
//!
//! The GPU finds an active body's candidate triangles every step from the grid instead of
//! keeping the CPU's list from the last rebuild: at a rebuild, the triangles within its
//! bounding radius plus the skin (the CPU's list); between rebuilds, within its radius plus
//! half the skin: bodies and meshes together move less than half the skin between rebuilds,
//! so this set lies inside the CPU's list and holds every triangle a contact can involve.
//!
//! A composite body gathers with its own bounding radius (which holds every piece whatever
//! the orientation, as the CPU's list does), then each piece meets the triangles in turn
//! (`mesh_piece` in mesh.wgsl); its slots keep their piece (word 1 of a slot), which the
//! read-back and the upload carry, as the last good state's copy of this buffer does.

use clatter::mesh_boundary::{Boundary, BoundaryMotion, MESH_SLOTS, MeshSlot};
use clatter::{ContactForce, World};
use glam::Vec3;

use crate::GpuError;

/// Words per boundary header in `shape_u`.
pub const HEADER_WORDS: usize = 48;
/// Words at the start of the state buffer.
pub const GLOBAL_WORDS: usize = 8;
/// Words of each boundary's time state.
pub const BOUNDARY_STATE_WORDS: usize = 16;
/// Words per mesh contact slot: boundary, piece, touching, 0, normal xyz, twist, history
/// xyz, 0, then the force record (`ContactForce`, 12 words).
pub const SLOT_WORDS: usize = 24;

/// Most candidate triangles (within a body's bounding radius plus the skin at a rebuild,
/// plus half the skin between rebuilds) the GPU holds per body and step (a private array in mesh.wgsl); beyond it the pipeline stops and
/// the run fails with a clear error (status word `MESH_FULL`).
pub const MAX_CANDIDATES: usize = 64;
/// Most mesh contacts (merged planes plus edge and vertex contacts) found per body (per piece
/// of a composite) and step before the deepest [`MESH_SLOTS`] are kept; beyond it, as for [`MAX_CANDIDATES`].
pub const MAX_FOUND: usize = 8;

/// Words of the state buffer for `bodies` bodies and `boundaries` boundaries.
pub fn state_words(bodies: u64, boundaries: u64) -> u64 {
    if boundaries == 0 {
        return 1;
    }
    GLOBAL_WORDS as u64
        + BOUNDARY_STATE_WORDS as u64 * boundaries
        + (MESH_SLOTS * SLOT_WORDS + 1) as u64 * bodies
}

/// The first word of the slots.
fn slots_at(boundaries: usize) -> usize {
    GLOBAL_WORDS + BOUNDARY_STATE_WORDS * boundaries
}

/// `x` as an unevaluated sum of two f32 (`hi` the nearest f32, `lo` the rest).
fn split(x: f64) -> [f32; 2] {
    let hi = x as f32;
    if !hi.is_finite() {
        return [hi, 0.0];
    }
    [hi, (x - hi as f64) as f32]
}

/// How long the motion may run: `end - start` (at least 0; infinite when it never ends).
fn duration(b: &Boundary) -> f64 {
    b.end.max(b.start) - b.start
}

/// The rotation rate `|w|` (f32, as the CPU's `Boundary::pose`).
fn rate(b: &Boundary) -> f32 {
    match b.motion {
        BoundaryMotion::Rotate {
            angular_velocity, ..
        } => angular_velocity.length(),
        _ => 0.0,
    }
}

/// Appends the boundaries' static data to the packed shape buffers; returns the first word
/// of their headers in `words`. Refuses meshes whose grid keys do not fit 32 bits.
pub(crate) fn pack(
    boundaries: &[Boundary],
    first: &[u32],
    floats: &mut Vec<[f32; 4]>,
    words: &mut Vec<u32>,
) -> Result<u32, GpuError> {
    let too_big = |what: &str| {
        GpuError::Unsupported(format!(
            "a triangle-mesh boundary is too large for the GPU backend ({what} beyond 32 bits)"
        ))
    };
    let idx = |v: usize| u32::try_from(v).map_err(|_| too_big("an offset"));
    let base = words.len();
    words.resize(base + HEADER_WORDS * boundaries.len(), 0);
    for (b, m) in boundaries.iter().enumerate() {
        let g = &m.grid;
        let cells = g.dims.iter().map(|&d| d as u64).product::<u64>();
        if cells >= u32::MAX as u64 {
            return Err(too_big(&format!("{cells} grid cells of {}", m.file)));
        }
        let mut h = [0u32; HEADER_WORDS];
        let f = |x: f32| x.to_bits();
        h[1] = m.material;
        h[2] = idx(m.triangles.len())?;
        h[3] = first[b];
        h[4] = idx(floats.len())?;
        floats.extend(m.vertices.iter().map(|v| [v.x, v.y, v.z, 0.0]));
        h[5] = idx(floats.len())?;
        floats.extend(m.normals.iter().map(|v| [v.x, v.y, v.z, 0.0]));
        h[6] = idx(words.len())?;
        words.extend(m.triangles.iter().flatten());
        h[7] = idx(words.len())?;
        words.extend(m.neighbours.iter().flatten());
        h[8] = idx(words.len())?;
        words.extend(&m.link_start);
        h[9] = idx(words.len())?;
        words.extend(&m.links);
        h[10] = idx(words.len())?;
        words.extend(g.keys.iter().map(|&k| k as u32));
        h[11] = idx(g.keys.len())?;
        h[12] = idx(words.len())?;
        words.extend(&g.start);
        h[13] = idx(words.len())?;
        words.extend(&g.tris);
        h[14..17].copy_from_slice(&g.dims);
        h[17] = f(g.cell);
        h[18..21].copy_from_slice(&[f(g.min.x), f(g.min.y), f(g.min.z)]);
        let (kind, vec, centre) = match m.motion {
            BoundaryMotion::Fixed => (0, Vec3::ZERO, Vec3::ZERO),
            BoundaryMotion::Translate { velocity } => (1, velocity, Vec3::ZERO),
            BoundaryMotion::Rotate {
                angular_velocity,
                center,
            } => (2, angular_velocity, center),
        };
        h[0] = kind;
        h[21..24].copy_from_slice(&[f(vec.x), f(vec.y), f(vec.z)]);
        h[24..27].copy_from_slice(&[f(centre.x), f(centre.y), f(centre.z)]);
        h[27] = f(m.reach);
        let r = rate(m);
        h[28] = f(r);
        let axis = if r > 0.0 { vec / r } else { Vec3::Z };
        h[29..32].copy_from_slice(&[f(axis.x), f(axis.y), f(axis.z)]);
        // Bounding sphere of the vertices (mesh frame): bodies farther skip the grid.
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for v in &m.vertices {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        let c = 0.5 * (lo + hi);
        let rad = m
            .vertices
            .iter()
            .map(|v| (*v - c).length())
            .fold(0.0f32, f32::max);
        h[32..35].copy_from_slice(&[f(c.x), f(c.y), f(c.z)]);
        h[35] = f(rad * 1.0001 + 1e-6);
        let d = duration(m);
        // The angle and elapsed time where the motion stops, as the CPU rounds them.
        let ud = split(d);
        h[36] = f(clatter::turn::turn_angle(r, (ud[0], ud[1])));
        h[37] = f(d as f32);
        words[base + HEADER_WORDS * b..base + HEADER_WORDS * (b + 1)].copy_from_slice(&h);
    }
    idx(base)
}

/// The initial state buffer for `world` (at its time, with its mesh slots).
pub(crate) fn initial_state(world: &World) -> Vec<u32> {
    let nb = world.boundaries.len();
    let mut w = vec![0u32; state_words(world.len() as u64, nb as u64) as usize];
    if nb == 0 {
        return w;
    }
    let t = world.time;
    for (b, m) in world.boundaries.iter().enumerate() {
        let at = GLOBAL_WORDS + BOUNDARY_STATE_WORDS * b;
        let u = split(t - m.start);
        let d = split(duration(m));
        // Words 2, 3, 5 and 6 are not used (the rotation angle follows from `u`).
        let vals = [u[0], u[1], 0.0, 0.0, 0.0, 0.0, 0.0, d[0], d[1]];
        for (k, v) in vals.iter().enumerate() {
            w[at + k] = v.to_bits();
        }
    }
    let s0 = slots_at(nb);
    for (k, s) in world.mesh_slots().iter().enumerate() {
        let at = s0 + SLOT_WORDS * k;
        let fl = |x: f32| x.to_bits();
        let fc = &s.force;
        let words = [
            s.boundary,
            s.piece,
            s.touching as u32,
            0,
            fl(s.normal.x),
            fl(s.normal.y),
            fl(s.normal.z),
            fl(s.twist),
            fl(s.history.x),
            fl(s.history.y),
            fl(s.history.z),
            0,
            fl(fc.force_b.x),
            fl(fc.force_b.y),
            fl(fc.force_b.z),
            fl(fc.normal_force),
            fl(fc.torque_a.x),
            fl(fc.torque_a.y),
            fl(fc.torque_a.z),
            fl(fc.pad0),
            fl(fc.torque_b.x),
            fl(fc.torque_b.y),
            fl(fc.torque_b.z),
            fl(fc.pad1),
        ];
        w[at..at + SLOT_WORDS].copy_from_slice(&words);
    }
    w
}

/// The slots of `n` bodies from the state buffer's words, and the GPU step count of the last
/// rebuild.
pub(crate) fn read_slots(words: &[u32], n: usize, boundaries: usize) -> (Vec<MeshSlot>, u32) {
    let s0 = slots_at(boundaries);
    let f = |k: usize| f32::from_bits(words.get(k).copied().unwrap_or(0));
    let v = |k: usize| Vec3::new(f(k), f(k + 1), f(k + 2));
    let slots = (0..n * MESH_SLOTS)
        .map(|k| {
            let at = s0 + SLOT_WORDS * k;
            let u = |o: usize| words.get(at + o).copied().unwrap_or(0);
            MeshSlot {
                boundary: u(0),
                piece: u(1),
                touching: u(2) != 0,
                normal: v(at + 4),
                twist: f(at + 7),
                history: v(at + 8),
                force: ContactForce {
                    force_b: v(at + 12),
                    normal_force: f(at + 15),
                    torque_a: v(at + 16),
                    pad0: f(at + 19),
                    torque_b: v(at + 20),
                    pad1: f(at + 23),
                },
            }
        })
        .collect();
    (slots, words.first().copied().unwrap_or(0))
}

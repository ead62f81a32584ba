//! The triangle-mesh boundaries' part of the **broad** and **contacts** stages (see
//! [`crate::mesh_boundary`] for the design): candidate triangles per body at each rebuild, and
//! per body and step the contacts with them, ghost contacts dropped, coplanar faces merged,
//! matched to the body's mesh slots and run through the contact law. Each body writes only
//! its own slots, so the result does not depend on the thread count.

use crate::precise::Ds3;
use glam::Vec3;
use rayon::prelude::*;
use smallvec::SmallVec;

use crate::law::{self, BodyMotion};
use crate::mesh_boundary::{
    Boundary, MESH_SLOTS, MeshContacts, MeshPose, MeshSlot, SLOT_MATCH_COS,
};
use crate::step::CHUNK;
use crate::world::World;
use clatter_geom::narrow::{self, Manifold, Plane};
use clatter_geom::triangle::{self, TriContact, TriFeature};
use clatter_geom::{Pose, Shape};

/// **broad** for the boundaries: every body's candidate triangles (within its bounding
/// radius plus the skin of the body at its current position, with the meshes at the current
/// time), sorted by global id; clears the slots of bodies that have none.
pub(crate) fn rebuild(world: &mut World) {
    if world.boundaries.is_empty() {
        return;
    }
    let t = world.time;
    let poses: Vec<MeshPose> = world.boundaries.iter().map(|b| b.pose(t)).collect();
    let w = &*world;
    let per_body: Vec<Vec<u32>> = (0..w.len())
        .into_par_iter()
        .with_min_len(256)
        // One cell buffer per task, not per body.
        .map_init(Vec::new, |cells, i| {
            candidates_of(w, i, &poses, w.skin, cells)
        })
        .collect();
    let mc = &mut world.mesh;
    mc.start.clear();
    mc.candidates.clear();
    mc.start.push(0);
    let old_active = std::mem::take(&mut mc.active);
    for (i, list) in per_body.into_iter().enumerate() {
        if !list.is_empty() {
            mc.active.push(i as u32);
        }
        mc.candidates.extend(list);
        mc.start.push(mc.candidates.len() as u32);
    }
    // Bodies that lost every candidate lose their contacts (the others keep their springs).
    for i in old_active {
        if mc.active.binary_search(&i).is_err() {
            let i = i as usize;
            mc.slots[i * MESH_SLOTS..(i + 1) * MESH_SLOTS].fill(MeshSlot::default());
            mc.total[i] = [Vec3::ZERO; 2];
        }
    }
    mc.rebuild_time = t;
}

/// Body `i`'s candidate triangles (global ids, ascending): those within its bounding radius
/// plus `skin` of its current position, with the meshes at `poses`. None for a removed body.
fn candidates_of(
    w: &World,
    i: usize,
    poses: &[MeshPose],
    skin: f32,
    cells: &mut Vec<u32>,
) -> Vec<u32> {
    // A body removed by a sink touches no mesh; a ghost's mesh contacts are its owner's.
    if w.state.removed[i] || w.is_ghost(i) {
        return Vec::new();
    }
    let reach = w.consts.radius[i] + skin;
    // Rounded to f32: a search within the skin.
    let x = w.state.position_f32(i);
    let mut out = Vec::new();
    for (b, (mesh, pose)) in w.boundaries.iter().zip(poses).enumerate() {
        let local = pose.inverse(x);
        cells.clear();
        mesh.grid.query(local, reach, cells);
        cells.sort_unstable();
        cells.dedup();
        for &tri in cells.iter() {
            let p = mesh.triangles[tri as usize].map(|k| mesh.vertices[k as usize]);
            let (q, _) = triangle::closest_on_triangle(local, p[0], p[1], p[2]);
            if (q - local).length_squared() < reach * reach {
                out.push(w.mesh.first[b] + tri);
            }
        }
    }
    out
}

/// Every contact of body `i` with the meshes at the current positions and time, as the
/// contacts stage finds them but without the law: `(boundary, piece, manifold)`, the normal
/// from the mesh towards the body. With `scratch` the candidate triangles are searched now
/// (no skin: the blow-up checks before the first step, when there has been no rebuild);
/// otherwise they are those of the last rebuild.
pub(crate) fn manifolds(w: &World, i: usize, scratch: bool) -> Vec<(u32, u32, Manifold)> {
    if w.boundaries.is_empty() || w.state.removed[i] {
        return Vec::new();
    }
    let poses: Vec<MeshPose> = w.boundaries.iter().map(|b| b.pose(w.time)).collect();
    let owned;
    let cands = if scratch {
        owned = candidates_of(w, i, &poses, 0.0, &mut Vec::new());
        &owned[..]
    } else {
        let mc = &w.mesh;
        match (mc.start.get(i), mc.start.get(i + 1)) {
            (Some(&a), Some(&b)) => &mc.candidates[a as usize..b as usize],
            _ => return Vec::new(),
        }
    };
    found_contacts(w, i, &poses, cands)
        .into_iter()
        .map(|f| (f.boundary, f.piece, f.manifold))
        .collect()
}

/// How far the meshes may have moved since the last rebuild, at the current time.
pub(crate) fn moved_since_rebuild(world: &World) -> f32 {
    world
        .boundaries
        .iter()
        .map(|b| b.displacement_bound(world.mesh.rebuild_time, world.time))
        .fold(0.0, f32::max)
}

/// **contacts** for the boundaries: each body against its candidate triangles. Returns the
/// number of touching mesh contacts.
pub(crate) fn run(world: &mut World) -> usize {
    if world.boundaries.is_empty() {
        return 0;
    }
    let t = world.time;
    let poses: Vec<MeshPose> = world.boundaries.iter().map(|b| b.pose(t)).collect();
    let motions: Vec<BodyMotion> = world.boundaries.iter().map(|b| b.motion_at(t)).collect();
    // Each body writes its own slots and total in place (no gathering pass afterwards).
    // Bodies without candidates were cleared at the rebuild and are skipped.
    let mut slots = std::mem::take(&mut world.mesh.slots);
    let mut total = std::mem::take(&mut world.mesh.total);
    let w = &*world;
    let start = &w.mesh.start;
    let touching = slots
        .par_chunks_mut(MESH_SLOTS)
        .zip(total.par_iter_mut())
        .enumerate()
        .with_min_len(CHUNK)
        .map(|(i, (s, tot))| {
            match (start.get(i), start.get(i + 1)) {
                (Some(a), Some(b)) if a != b => {}
                _ => return 0,
            }
            let n = body_slots(w, i, &poses, &motions, s);
            *tot = MeshContacts::sum_slots(s);
            n
        })
        .sum();
    world.mesh.slots = slots;
    world.mesh.total = total;
    touching
}

/// One contact with a boundary, before the law.
#[derive(Clone, Copy)]
struct Found {
    boundary: u32,
    /// The body's piece (0 unless a composite).
    piece: u32,
    manifold: Manifold,
}

/// Body `i`'s mesh contacts this step, into its slots.
fn body_slots(
    w: &World,
    i: usize,
    poses: &[MeshPose],
    motions: &[BodyMotion],
    slots: &mut [MeshSlot],
) -> usize {
    let mc = &w.mesh;
    let cands = &mc.candidates[mc.start[i] as usize..mc.start[i + 1] as usize];
    if cands.is_empty() {
        if slots.iter().any(|s| s.touching) {
            slots.fill(MeshSlot::default());
        }
        return 0;
    }
    let found = found_contacts(w, i, poses, cands);
    assign(w, i, &found, motions, slots)
}

/// Body `i`'s contacts with the triangles `cands` (global ids, ascending): each convex piece
/// of the body (one unless a composite) against the triangles, at most [`MESH_SLOTS`] (a
/// composite keeps its deepest).
///
/// Everything is relative to the body's position: the body at the origin, the triangles
/// shifted by `-x_i` in f64 before rounding, so the manifold (points relative to the body)
/// keeps the precision of the overlap at any coordinate.
fn found_contacts(w: &World, i: usize, poses: &[MeshPose], cands: &[u32]) -> Found8 {
    let x = crate::precise::split(w.state.position[i]);
    let mut found = Found8::new();
    for k in 0..w.shape(i).piece_count() as u32 {
        let (shape, pose) = w.piece_at(i, k, Vec3::ZERO);
        let start = found.len();
        piece_contacts(w, shape, &pose, k, cands, poses, x, &mut found);
        debug_assert!(found.len() - start <= MESH_SLOTS);
    }
    if found.len() > MESH_SLOTS {
        found.sort_by(|a, b| b.manifold.max_depth().total_cmp(&a.manifold.max_depth()));
        found.truncate(MESH_SLOTS);
    }
    found
}

/// The contacts of a body's pieces, inline up to two pieces' worth.
type Found8 = SmallVec<[Found; 2 * MESH_SLOTS]>;

/// A face contact group: one plane of one boundary and the triangles on it that the piece
/// touches.
struct FaceGroup {
    boundary: u32,
    normal: Vec3,
    offset: f32,
    /// The rest of `offset` below f32 (the low part of the relative first vertex along the
    /// normal), added to the group's depths as for a wall ([`World::plane_from`]).
    rest: f32,
    /// Every candidate triangle on the plane (those the piece touches on their faces and the
    /// others).
    support: SmallVec<[[Vec3; 3]; 4]>,
}

/// The contacts of one convex piece (`shape` at `pose`) with candidate triangles `cands`
/// (global ids, ascending): face contacts merged per plane, edge and vertex contacts that are
/// not ghosts, at most [`MESH_SLOTS`] (the deepest), in a deterministic order. `pose` and
/// the contacts are relative to `origin` (the body's position).
#[allow(clippy::too_many_arguments)]
fn piece_contacts(
    w: &World,
    shape: &Shape,
    pose: &Pose,
    piece: u32,
    cands: &[u32],
    poses: &[MeshPose],
    origin: Ds3,
    out: &mut Found8,
) {
    let mc = &w.mesh;
    let size = shape.bounding_radius();
    // Small inline buffers: this runs per body and step, so no heap allocation.
    let mut groups: SmallVec<[FaceGroup; 2]> = SmallVec::new();
    let mut features: SmallVec<[(Found, u32, [u32; 2]); 4]> = SmallVec::new(); // (contact, boundary, key)
    for &g in cands {
        let (b, t) = mc.locate(g);
        let mesh: &Boundary = &w.boundaries[b];
        let mp = &poses[b];
        let tri = local_triangle(mesh, t, mp, origin);
        let normal = mp.rotate(mesh.normals[t]);
        let lo0 = crate::precise::ds_add(
            crate::precise::Ds3::from_f32(mesh.world_triangle(t, mp)[0]),
            -origin,
        )
        .lo;
        match triangle::collide_triangle(shape, pose, &tri, normal) {
            None => {}
            Some(TriContact::Face { normal, offset }) => {
                let same = groups.iter_mut().find(|f| {
                    f.boundary == b as u32
                        && f.normal.dot(normal) >= 1.0 - 1e-6
                        && (f.offset - offset).abs() <= 1e-5 * size
                });
                match same {
                    Some(_) => {}
                    None => groups.push(FaceGroup {
                        boundary: b as u32,
                        normal,
                        offset,
                        rest: normal.dot(lo0),
                        support: SmallVec::new(),
                    }),
                }
            }
            Some(TriContact::Feature { feature, manifold }) => {
                let d = mp.unrotate(manifold.normal);
                let verts = mesh.triangles[t];
                let key = match feature {
                    TriFeature::Edge(k) => {
                        let k = k as usize;
                        if !mesh.edge_region(t, k, d) {
                            continue;
                        }
                        let (a, c) = (verts[k], verts[(k + 1) % 3]);
                        [a.min(c), a.max(c)]
                    }
                    TriFeature::Vertex(k) => {
                        let v = verts[k as usize];
                        if !mesh.vertex_region(v as usize, d) {
                            continue;
                        }
                        [v, u32::MAX]
                    }
                    TriFeature::Face => continue,
                };
                // A shared edge or vertex counts once (the first triangle, by id, has it).
                if features
                    .iter()
                    .any(|(_, fb, k)| *fb == b as u32 && *k == key)
                {
                    continue;
                }
                features.push((
                    Found {
                        boundary: b as u32,
                        piece: 0,
                        manifold,
                    },
                    b as u32,
                    key,
                ));
            }
        }
    }
    // Every candidate triangle on a group's plane supports it (also those whose own test
    // found an edge contact, dropped as a ghost): the plane's manifold stands on them all.
    // A sphere's face contact point is over its triangle by construction, so its manifold
    // needs no support (see `plane_manifold`).
    if !groups.is_empty() && !matches!(shape, Shape::Sphere { .. }) {
        for &c in cands {
            let (b, t) = mc.locate(c);
            let mesh = &w.boundaries[b];
            let n = poses[b].rotate(mesh.normals[t]);
            let tri = local_triangle(mesh, t, &poses[b], origin);
            for g in groups.iter_mut().filter(|g| {
                g.boundary == b as u32
                    && n.dot(g.normal).abs() >= 1.0 - 1e-6
                    && (g.normal.dot(tri[0]) - g.offset).abs() <= 1e-5 * size
            }) {
                g.support.push(tri);
            }
        }
    }
    let start = out.len();
    for g in &groups {
        if let Some(m) = plane_manifold(shape, pose, g) {
            out.push(Found {
                boundary: g.boundary,
                piece,
                manifold: World::add_rest(m, g.rest),
            });
        }
    }
    out.extend(features.into_iter().map(|(f, _, _)| Found { piece, ..f }));
    if out.len() - start > MESH_SLOTS {
        // Keep the deepest (a stable sort: ties keep their order).
        out[start..].sort_by(|a, b| b.manifold.max_depth().total_cmp(&a.manifold.max_depth()));
        out.truncate(start + MESH_SLOTS);
    }
}

/// Triangle `t` of `mesh` at `pose`, relative to `origin` (subtracted as precise pairs,
/// [`crate::precise::relative`], the GPU's `mesh_local`).
#[inline]
fn local_triangle(mesh: &Boundary, t: usize, pose: &MeshPose, origin: Ds3) -> [Vec3; 3] {
    mesh.world_triangle(t, pose)
        .map(|v| crate::precise::relative(origin, v))
}

/// The manifold of a piece against one plane of coplanar triangles: the plane's own manifold
/// (as for a `[[wall]]`) when all its points lie on the triangles, else the piece's vertices
/// over the triangles and the triangles' vertices inside the piece.
fn plane_manifold(shape: &Shape, pose: &Pose, g: &FaceGroup) -> Option<Manifold> {
    let plane = Plane {
        normal: g.normal,
        offset: g.offset,
    };
    let m = narrow::collide_plane(&plane, shape, pose)?;
    let Shape::Polyhedron(p) = shape else {
        // A sphere's face contact point is over its triangle by construction.
        return Some(m);
    };
    const TOL: f32 = 1e-6;
    let on_mesh = |x: Vec3| {
        g.support
            .iter()
            .any(|t| triangle::projects_inside(x, t, TOL))
    };
    if m.points().iter().all(|p| on_mesh(p.point)) {
        return Some(m);
    }
    let n = g.normal;
    let mut pts: SmallVec<[(Vec3, f32); 16]> = SmallVec::new();
    for &v in &p.vertices {
        let x = pose.transform_point(v);
        let h = n.dot(x) - g.offset;
        if h < 0.0 && on_mesh(x) {
            pts.push((x - n * (0.5 * h), -h));
        }
    }
    let n_local = pose.rotation.conjugate() * n;
    for t in &g.support {
        for &x in t {
            let local = pose.inverse_transform_point(x);
            if let Some(depth) = triangle::depth_inside(p, local, n_local)
                && depth > 0.0
            {
                pts.push((x - n * (0.5 * depth), depth));
            }
        }
    }
    if pts.is_empty() {
        return None;
    }
    Some(narrow::patch(&pts, n))
}

/// Puts this step's contacts of body `i` into its slots (springs carried from the old slot
/// of the same boundary with the closest normal), runs the law, and releases the rest.
fn assign(
    w: &World,
    i: usize,
    found: &[Found],
    motions: &[BodyMotion],
    slots: &mut [MeshSlot],
) -> usize {
    let old: [MeshSlot; MESH_SLOTS] = std::array::from_fn(|k| slots[k]);
    let mut taken = [false; MESH_SLOTS];
    let mut place = [usize::MAX; MESH_SLOTS];
    for (c, f) in found.iter().enumerate() {
        let mut best = (SLOT_MATCH_COS, usize::MAX);
        for (k, s) in old.iter().enumerate() {
            if s.touching && !taken[k] && s.boundary == f.boundary && s.piece == f.piece {
                let cos = s.normal.dot(f.manifold.normal);
                if cos >= best.0 {
                    best = (cos, k);
                }
            }
        }
        if best.1 != usize::MAX {
            taken[best.1] = true;
            place[c] = best.1;
        }
    }
    for s in slots.iter_mut() {
        *s = MeshSlot::default();
    }
    for slot in place.iter_mut().take(found.len()) {
        if *slot == usize::MAX {
            let k = (0..MESH_SLOTS)
                .find(|&k| !taken[k])
                .expect("at most MESH_SLOTS contacts");
            taken[k] = true;
            *slot = k;
        } else {
            let o = old[*slot];
            slots[*slot].history = o.history;
            slots[*slot].twist = o.twist;
        }
    }
    // In the body's frame of reference (see `found_contacts`).
    let body = w.local_motion(i);
    let mass = w.consts.mass[i];
    for (c, f) in found.iter().enumerate() {
        let (r_eff, sphere) = w.piece_law(i, f.piece);
        let share = law::point_share(sphere, sphere);
        let s = &mut slots[place[c]];
        let b = f.boundary as usize;
        let params = w.pair_params(w.boundaries[b].material, w.consts.material[i]);
        let context = super::contacts::pair_context(w, params, mass, r_eff, share);
        s.force = law::contact_force(
            &context,
            &f.manifold,
            &BodyMotion {
                position: w.relative_to(i, motions[b].position),
                ..motions[b]
            },
            &body,
            &mut s.history,
            &mut s.twist,
        );
        s.boundary = f.boundary;
        s.piece = f.piece;
        s.normal = f.manifold.normal;
        s.touching = true;
    }
    found.len()
}

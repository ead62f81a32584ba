//! Contact reports: every touching contact at the current positions with its manifold and
//! last force, as the VTK output and the overlap checks read them.

use rayon::prelude::*;

use crate::broad::{self, Grid};
use crate::contact_list::Partner;
use crate::law::{self, ContactForce};
use crate::world::World;
use clatter_geom::narrow::{self, EdgeMemory, Manifold, NO_HINT};
/// One contact at the current positions: who touches whom, the manifold (normal from `other`
/// towards `body` for walls, from `body` towards `other` for body pairs, as
/// [`narrow::collide`] returns it), and the force of the last step.
#[derive(Debug, Clone, Copy)]
pub struct ContactReport {
    /// The body (for a body pair, the lower id).
    pub body: u32,
    /// The other side.
    pub other: Partner,
    /// The contact manifold recomputed at the current positions, relative to `body`'s
    /// position (points are offsets from `world.state.position[body]`: add it, in f64, for
    /// world coordinates).
    pub manifold: Manifold,
    /// The force of the last step; for a body pair `force_b` acts on `other` and
    /// `-force_b` on `body`, for a wall `force_b` acts on `body`.
    pub force: ContactForce,
}

/// Contacts that touched in the last step, with their manifolds recomputed at the current
/// positions (those that no longer overlap are left out) and the last step's forces, in
/// contact-list order.
pub fn touching_contacts(world: &World) -> Vec<ContactReport> {
    let mut out: Vec<ContactReport> = (0..world.contacts.len())
        .into_par_iter()
        .with_min_len(256)
        .filter_map(|k| contact_report(world, k))
        .collect();
    // Then the mesh contacts, by body (bodies with a touching mesh slot).
    out.extend(mesh_reports(world, |i| {
        world.mesh.body_slots(i).iter().any(|s| s.touching)
    }));
    out
}

/// The mesh-boundary contacts of the bodies `pick` selects, at the current positions, with
/// the last step's force of the matching slot (same boundary and piece, closest normal; zero
/// when none matches), by body and then as the contacts stage orders them.
pub(super) fn mesh_reports(
    world: &World,
    pick: impl Fn(usize) -> bool + Sync,
) -> Vec<ContactReport> {
    if world.boundaries.is_empty() {
        return Vec::new();
    }
    (0..world.len())
        .into_par_iter()
        .with_min_len(256)
        .filter(|&i| pick(i))
        .flat_map_iter(|i| {
            let slots = world.mesh.body_slots(i);
            crate::step::mesh_contacts::manifolds(world, i, false)
                .into_iter()
                .map(move |(b, piece, manifold)| ContactReport {
                    body: i as u32,
                    other: Partner::Boundary(b),
                    manifold,
                    force: slots
                        .iter()
                        .filter(|s| s.touching && s.boundary == b && s.piece == piece)
                        .max_by(|x, y| {
                            x.normal
                                .dot(manifold.normal)
                                .total_cmp(&y.normal.dot(manifold.normal))
                        })
                        .map_or(ContactForce::default(), |s| s.force),
                })
        })
        .collect()
}

/// Contact `k` of the contact list if it touched in the last step and still overlaps now.
pub(super) fn contact_report(world: &World, k: usize) -> Option<ContactReport> {
    let springs = world.contacts.springs();
    if !springs.touching[k] {
        return None;
    }
    let (body, other) = world.contacts.partners(k);
    // A body removed by a sink in the last step is still in the list until the rebuild.
    // A copy of the pair's edge memory, if it has one, makes the test cheaper, not different.
    let memory = world.edge_memory.get(k).cloned();
    overlap_report_with(world, body, other, springs.forces[k], memory)
}

/// The contact law's parameters, effective radius and point share of a contact.
pub(super) fn law_of(world: &World, body: u32, other: Partner) -> (crate::PairParams, f32, f32) {
    let i = body as usize;
    let (ri, ci) = (world.consts.equivalent_radius[i], world.consts.material[i]);
    let si = world.consts.is_sphere[i];
    match other {
        Partner::Body(j) => {
            let j = j as usize;
            let rj = world.consts.equivalent_radius[j];
            (
                *world.pair_params(ci, world.consts.material[j]),
                ri * rj / (ri + rj),
                law::point_share(si, world.consts.is_sphere[j]),
            )
        }
        Partner::Wall(w) => (
            *world.pair_params(world.walls[w as usize].material, ci),
            ri,
            law::point_share(si, si),
        ),
        Partner::Boundary(b) => (
            *world.pair_params(world.boundaries[b as usize].material, ci),
            ri,
            law::point_share(si, si),
        ),
    }
}

/// The deepest overlap contact `k`'s last normal force allows (all of it on one point), or 0
/// for a contact that did not touch: picks which contacts get the exact test.
pub(super) fn estimated_depth(world: &World, k: usize) -> f32 {
    let springs = world.contacts.springs();
    if !springs.touching[k] {
        return 0.0;
    }
    let (body, other) = world.contacts.partners(k);
    let (params, r_eff, share) = law_of(world, body, other);
    law::depth_at_force(&params, r_eff, springs.forces[k].normal_force, share)
}

/// Every overlap at the current positions, found from scratch (a broad phase without skin
/// and the narrow phase); forces are zero. Does not touch the contact list.
pub fn find_contacts(world: &World) -> Vec<ContactReport> {
    if world.is_empty() {
        return Vec::new();
    }
    let positions: Vec<glam::Vec3> = world.state.position.iter().map(|p| p.as_vec3()).collect();
    let grid = Grid::around(&positions, 2.0 * world.consts.max_radius());
    let radii = &world.consts.radius;
    let pairs = broad::pairs_periodic(&grid, &positions, radii, 0.0, world.periodic.as_ref());
    let report =
        |body: u32, other: Partner| overlap_report(world, body, other, ContactForce::default());
    let mut out: Vec<ContactReport> = pairs
        .par_iter()
        .with_min_len(256)
        .filter_map(|&[i, j]| report(i, Partner::Body(j)))
        .collect();
    for i in 0..world.len() as u32 {
        out.extend((0..world.walls.len() as u32).filter_map(|w| report(i, Partner::Wall(w))));
    }
    // Mesh boundaries: each body against the triangles it touches now.
    if !world.boundaries.is_empty() {
        let meshes: Vec<ContactReport> = (0..world.len())
            .into_par_iter()
            .with_min_len(256)
            .flat_map_iter(|i| {
                crate::step::mesh_contacts::manifolds(world, i, true)
                    .into_iter()
                    .map(move |(b, _, manifold)| ContactReport {
                        body: i as u32,
                        other: Partner::Boundary(b),
                        manifold,
                        force: ContactForce::default(),
                    })
            })
            .collect();
        out.extend(meshes);
    }
    out
}

/// The report of `body` against `other` with `force` if they overlap at the current positions;
/// `None` if not, or if either body was removed by a sink (removed bodies touch nothing).
fn overlap_report(
    world: &World,
    body: u32,
    other: Partner,
    force: ContactForce,
) -> Option<ContactReport> {
    overlap_report_with(world, body, other, force, None)
}

/// [`overlap_report`] with an edge memory for the pair's test (see
/// [`narrow::collide_with_memory`]: the same manifold, bitwise).
fn overlap_report_with(
    world: &World,
    body: u32,
    other: Partner,
    force: ContactForce,
    memory: Option<EdgeMemory>,
) -> Option<ContactReport> {
    if world.is_removed(body as usize)
        || matches!(other, Partner::Body(j) if world.is_removed(j as usize))
    {
        return None;
    }
    Some(ContactReport {
        body,
        other,
        manifold: collide(world, body, other, memory)?,
        force,
    })
}

/// The manifold of `body` and `other` at the current positions, relative to `body`'s
/// position (as the contacts stage finds it: see [`World::offset_of`]).
fn collide(
    world: &World,
    body: u32,
    other: Partner,
    memory: Option<EdgeMemory>,
) -> Option<Manifold> {
    let i = body as usize;
    match other {
        Partner::Body(j) => {
            let (si, pi) = (world.shape(i), world.local_pose(i));
            let (sj, pj) = (world.shape(j as usize), world.pose_from(i, j as usize));
            match memory {
                // The full test (no hint, no bound), with the memory's shortcut.
                Some(mut m) => narrow::collide_with_memory(
                    si,
                    &pi,
                    sj,
                    &pj,
                    &mut NO_HINT.clone(),
                    &mut 0.0,
                    &mut m,
                ),
                None => narrow::collide(si, &pi, sj, &pj),
            }
        }
        Partner::Wall(w) => {
            let (plane, rest) = world.plane_from(i, &world.walls[w as usize].plane);
            narrow::collide_plane(&plane, world.shape(i), &world.local_pose(i))
                .map(|m| World::add_rest(m, rest))
        }
        // Mesh contacts are found per body (`mesh_reports`), never through the contact list.
        Partner::Boundary(_) => None,
    }
}

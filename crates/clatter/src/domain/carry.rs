//! Bodies carry their constants: no rank keeps every body's ([`blank`]). A rank's world is
//! built from the records it receives (a body's state, constants and mesh slots travel
//! together at a rebuild, [`super::rows::Writer::consts`]), and the whole world
//! ([`super::Domain::gather`]) from every rank's owned bodies, onto the **skeleton**: the
//! scene's setting without its bodies (shapes, materials, walls, mesh boundaries, sinks,
//! gravity, `dt`, skin and code paths), O(scene setting) on every rank.

use glam::{DVec3, Quat, Vec3};

use crate::bodies::{BodyConstants, BodyStates};
use crate::mesh_boundary::{MESH_SLOTS, MeshSlot};
use crate::world::World;

use super::rows::SpringRow;

/// A world with `skeleton`'s setting and clock and `n` bodies whose states and constants
/// are zero, to be filled in body by body (`ghost`: the ghost flags, empty for a whole
/// world). The code paths (sphere-only, composites) are the skeleton's, which are the whole
/// scene's; per-body composite reaches and mesh slots are kept when the scene has them.
pub(super) fn blank(skeleton: &World, n: usize, ghost: Vec<bool>) -> World {
    debug_assert!(skeleton.is_empty());
    debug_assert!(ghost.is_empty() || ghost.len() == n);
    let mut w = skeleton.subset(&[], Vec::new());
    w.ghost = ghost;
    w.state = BodyStates {
        position: vec![DVec3::ZERO; n],
        velocity: vec![Vec3::ZERO; n],
        orientation: vec![Quat::IDENTITY; n],
        orientation_residual: vec![Quat::from_xyzw(0.0, 0.0, 0.0, 0.0); n],
        angular_momentum: vec![Vec3::ZERO; n],
        omega: vec![Vec3::ZERO; n],
        removed: vec![false; n],
    };
    w.consts = BodyConstants {
        shape: vec![0; n],
        material: vec![0; n],
        is_sphere: vec![false; n],
        mass: vec![0.0; n],
        inertia: vec![Vec3::ZERO; n],
        inv_mass: vec![0.0; n],
        inv_inertia: vec![Vec3::ZERO; n],
        radius: vec![0.0; n],
        equivalent_radius: vec![0.0; n],
    };
    if skeleton.has_composites() {
        w.reach = vec![0.0; n];
    }
    if !skeleton.boundaries.is_empty() {
        w.mesh.slots = vec![MeshSlot::default(); n * MESH_SLOTS];
        w.mesh.total = vec![[Vec3::ZERO; 2]; n];
    }
    w
}

/// Copies body `j` of `from` into body `i` of `to` (made by [`blank`]): its whole state and
/// its constants, bit for bit as a record written by `Writer::state` and `Writer::consts`
/// and read back would (the reach kept only where `to` keeps reaches). A body that stays on
/// its rank at a rebuild takes this path instead of a message to the rank itself.
pub(super) fn copy_body(from: &World, j: usize, to: &mut World, i: usize) {
    let (s, t) = (&from.state, &mut to.state);
    t.position[i] = s.position[j];
    t.velocity[i] = s.velocity[j];
    t.orientation[i] = s.orientation[j];
    t.orientation_residual[i] = s.orientation_residual[j];
    t.angular_momentum[i] = s.angular_momentum[j];
    t.omega[i] = s.omega[j];
    t.removed[i] = s.removed[j];
    let (c, d) = (&from.consts, &mut to.consts);
    d.shape[i] = c.shape[j];
    d.material[i] = c.material[j];
    d.is_sphere[i] = c.is_sphere[j];
    d.mass[i] = c.mass[j];
    d.inertia[i] = c.inertia[j];
    d.inv_mass[i] = c.inv_mass[j];
    d.inv_inertia[i] = c.inv_inertia[j];
    d.radius[i] = c.radius[j];
    d.equivalent_radius[i] = c.equivalent_radius[j];
    if let Some(r) = to.reach.get_mut(i) {
        *r = from.reach.get(j).copied().unwrap_or(0.0);
    }
}

/// The `from` of a body in `install`'s entries that stays on the rank (its `at` is then its
/// old local id).
pub(super) const KEPT: usize = usize::MAX;

/// What a rebuild keeps on the rank instead of sending it to itself: the owned bodies that
/// stay (owned or as ghosts: global id, owned, old local id, in the order the message would
/// have held them) and the springs of the contacts whose bodies it owns next (the rows the
/// message would have held, in its order, with the old local ids of their bodies).
#[derive(Default)]
pub(super) struct Kept {
    pub bodies: Vec<(u32, bool, u32)>,
    /// With their bodies' old local ids.
    pub pairs: Vec<(SpringRow, [u32; 2])>,
    /// With their body's old local id.
    pub walls: Vec<(SpringRow, u32)>,
}

/// The new local id of each old local body (`u32::MAX` for those the rank no longer
/// holds), from the old and new local bodies' global ids (both ascending: one merge).
pub(super) fn renumbering(old: &[u32], new: &[u32]) -> Vec<u32> {
    let mut out = vec![u32::MAX; old.len()];
    let mut j = 0;
    for (o, &g) in out.iter_mut().zip(old) {
        while j < new.len() && new[j] < g {
            j += 1;
        }
        if new.get(j) == Some(&g) {
            *o = j as u32;
        }
    }
    out
}

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

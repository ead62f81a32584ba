//! The contact list taken over from another executor (the GPU) or a checkpoint:
//! [`World::set_contact_state`] rebuilds the wall candidates with the broad phase and
//! [`World::restore_mesh`] the mesh candidates with the mesh contacts stage, so the stages
//! use the world and the world never calls into them.

use glam::Vec3;

use crate::contact_list::{ContactState, Contacts};
use crate::law::ContactForce;
use crate::mesh_boundary::MeshSlot;
use crate::world::World;

impl World {
    /// Restores the mesh contacts another backend (the GPU) computed: the slots, and the
    /// candidate triangles found as the last rebuild found them (at the rebuild positions
    /// of the current contact list and the meshes at `rebuild_time`), so that the next CPU
    /// steps and checkpoints continue exactly. Fails when the slot count does not match.
    pub fn restore_mesh(&mut self, slots: Vec<MeshSlot>, rebuild_time: f64) -> Result<(), String> {
        if self.boundaries.is_empty() {
            return Ok(());
        }
        if !self.needs_rebuild() && self.rebuild_position.len() == self.len() {
            let position =
                std::mem::replace(&mut self.state.position, self.rebuild_position.clone());
            let time = std::mem::replace(&mut self.time, rebuild_time);
            super::mesh_contacts::rebuild(self);
            self.state.position = position;
            self.time = time;
        }
        self.mesh.rebuild_time = rebuild_time;
        self.set_mesh_slots(slots)
    }

    /// Replaces the contact list with `state` (from another backend): body pairs as given
    /// (sorted by `(i, j)`, then piece code), wall candidates recomputed from
    /// `state.rebuild_position` (and, with composites, per piece at
    /// `state.rebuild_orientation`) with their springs taken from the per-(body, wall, piece)
    /// slots. An empty `rebuild_position` means "no list yet": the next step rebuilds; so does
    /// a composite world's state without piece codes or rebuild orientations.
    pub fn set_contact_state(&mut self, state: ContactState) {
        let n = self.len();
        let incomplete = state.rebuild_position.len() != n
            || (self.has_composites()
                && (state.rebuild_orientation.len() != n
                    || state.pieces.len() != state.pairs.len()));
        if incomplete {
            self.contacts = Contacts::default();
            self.set_needs_rebuild(true);
            return;
        }
        let nw = self.walls.len();
        let mp = self.max_pieces();
        let wall_pairs = super::broad::wall_candidates(self, &state.rebuild_position);
        let (wall_pairs, wall_pieces) = if self.has_composites() {
            super::broad::wall_piece_candidates(
                self,
                &wall_pairs,
                &state.rebuild_position,
                &state.rebuild_orientation,
            )
        } else {
            let zeros = vec![0; wall_pairs.len()];
            (wall_pairs, zeros)
        };
        // Pairs of a body removed since the list was built (the next step rebuilds without
        // them) are dropped now: the list then is what the broad phase finds at
        // `rebuild_position` for the bodies still in, as after a checkpoint restore.
        let state = if self.state.removed.iter().any(|&r| r) {
            drop_removed_pairs(state, &self.state.removed)
        } else {
            state
        };
        let slot_of =
            |&[i, w]: &[u32; 2], piece: u32| (i as usize * nw + w as usize) * mp + piece as usize;
        let mut history = state.history;
        let mut twist = state.twist;
        for (p, &a) in wall_pairs.iter().zip(&wall_pieces) {
            let slot = slot_of(p, a);
            history.push(state.wall_history.get(slot).copied().unwrap_or(Vec3::ZERO));
            twist.push(state.wall_twist.get(slot).copied().unwrap_or(0.0));
        }
        let np = state.pairs.len();
        let mut touching = state.touching;
        let mut forces = state.forces;
        touching.resize(np, false);
        forces.resize(np, ContactForce::default());
        for (p, &a) in wall_pairs.iter().zip(&wall_pieces) {
            let slot = slot_of(p, a);
            touching.push(state.wall_touching.get(slot).copied().unwrap_or(false));
            forces.push(state.wall_forces.get(slot).copied().unwrap_or_default());
        }
        self.contacts = if self.has_composites() {
            let mut pieces = state.pieces;
            pieces.extend(wall_pieces);
            Contacts::with_pieces(n, state.pairs, wall_pairs, pieces, history, twist)
        } else {
            Contacts::new(n, state.pairs, wall_pairs, history, twist)
        };
        let springs = self.contacts.springs_mut();
        springs.touching = touching;
        springs.forces = forces;
        self.rebuild_position = state.rebuild_position;
        if self.has_composites() {
            self.rebuild_orientation = state.rebuild_orientation;
        }
        self.set_needs_rebuild(false);
    }
}

/// `state` without the body pairs that involve a removed body.
fn drop_removed_pairs(mut state: ContactState, removed: &[bool]) -> ContactState {
    let keep: Vec<bool> = state
        .pairs
        .iter()
        .map(|&[i, j]| !(is_removed(removed, i) || is_removed(removed, j)))
        .collect();
    fn select<T: Copy>(v: &[T], keep: &[bool]) -> Vec<T> {
        v.iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect()
    }
    state.pairs = select(&state.pairs, &keep);
    if state.pieces.len() == keep.len() {
        state.pieces = select(&state.pieces, &keep);
    }
    state.history = select(&state.history, &keep);
    state.twist = select(&state.twist, &keep);
    state.touching = select(&state.touching, &keep);
    state.forces = select(&state.forces, &keep);
    state
}

/// Whether body `i` is flagged removed; an index out of range (a damaged file's) is not, and
/// is then refused by the checks that follow.
fn is_removed(removed: &[bool], i: u32) -> bool {
    removed.get(i as usize).copied().unwrap_or(false)
}

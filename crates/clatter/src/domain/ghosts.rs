//! The ghost states' exchange of every step (forward communication): the owners' new
//! states packed into the messages kept from step to step, and the ghosts' read back.
//!
//! Two record formats ([`GhostRecord`]): the whole state ([`rows::STATE_BYTES`]) where some
//! body is not a sphere, and in a world of spheres alone (no composite) only what the step
//! reads of a ghost ([`rows::SPHERE_STATE_BYTES`]: position, velocity, angular velocity and
//! the removed flag). A ghost is never integrated (its lanes' results are not kept) and
//! nothing else reads a ghost sphere's orientation, its rounding residual or its angular
//! momentum: a sphere's contacts read its centre, velocity and spin (the bounding test and
//! the law), never its orientation, and the checks, energies and gathers read owned bodies
//! only. Those three fields of a ghost keep what the last rebuild's migration brought (and
//! what the ghost's unkept lanes wrote since); `tests/domain/ghosts.rs` scrambles them after
//! every step and still ends bitwise one process's. Polyhedra and composites read a ghost's
//! orientation (its faces, its pieces): they keep the whole record.

use super::rows::{self, Reader, Writer};
use super::{Comm, Domain};

// The record sizes the docs of `GhostRecord` name.
const _: () = assert!(rows::STATE_BYTES == 96 && rows::SPHERE_STATE_BYTES == 52);

/// Which record a ghost's state travels in every step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GhostRecord {
    /// Every field the step integrates (96 bytes a body).
    Whole,
    /// A world of spheres alone: position, velocity, angular velocity, removed flag
    /// (52 bytes a body).
    Sphere,
}

impl GhostRecord {
    /// The record a world's ghosts need: [`GhostRecord::Sphere`] where every body is a
    /// sphere and none a composite.
    pub fn of(world: &crate::World) -> GhostRecord {
        if world.spheres_only() && !world.has_composites() {
            GhostRecord::Sphere
        } else {
            GhostRecord::Whole
        }
    }

    /// Bytes a body.
    pub fn bytes(self) -> usize {
        match self {
            GhostRecord::Whole => rows::STATE_BYTES,
            GhostRecord::Sphere => rows::SPHERE_STATE_BYTES,
        }
    }
}

impl Domain {
    /// The record this rank's ghost states travel in (every rank finds the same: the
    /// world's bodies are the scene's).
    pub fn ghost_record(&self) -> GhostRecord {
        GhostRecord::of(&self.local)
    }

    /// Forward communication: the owners' new states to the ranks holding them as ghosts,
    /// through the buffers kept from step to step (`sent`, `received`), every field a ghost
    /// is read for overwritten ([`GhostRecord`]). The largest squared displacement `d2`
    /// rides with it ([`Comm::all_to_all_into_and_max`]): returns its maximum over the
    /// ranks.
    pub(super) fn forward(&mut self, comm: &dyn Comm, d2: f32) -> f32 {
        self.pack();
        let d2 = comm.all_to_all_into_and_max(&self.sent, &mut self.received, d2);
        self.unpack();
        d2
    }

    /// The owned bodies' states into the messages of the forward exchange (`sent`), and
    /// `received` sized for the ghosts' (see [`Domain::forward`]).
    pub(super) fn pack(&mut self) {
        let record = self.ghost_record();
        let ranks = self.send.len();
        self.sent.resize_with(ranks, Vec::new);
        self.received.resize_with(ranks, Vec::new);
        for (buf, list) in self.sent.iter_mut().zip(&self.send) {
            let mut w = Writer(std::mem::take(buf));
            w.0.clear();
            w.0.reserve(list.len() * record.bytes());
            let s = &self.local.state;
            match record {
                GhostRecord::Whole => list.iter().for_each(|&i| w.state(s, i as usize)),
                GhostRecord::Sphere => list.iter().for_each(|&i| w.sphere_state(s, i as usize)),
            }
            *buf = w.0;
        }
        for (buf, list) in self.received.iter_mut().zip(&self.recv) {
            // Only the sizes matter (every byte is overwritten): no zeroing unless they grew.
            buf.resize(list.len() * record.bytes(), 0);
        }
    }

    /// The ghosts' states from the messages received (`received`): none owed now.
    pub(super) fn unpack(&mut self) {
        let record = self.ghost_record();
        for (m, list) in self.received.iter().zip(&self.recv) {
            let mut r = Reader::new(m);
            let s = &mut self.local.state;
            match record {
                GhostRecord::Whole => list.iter().for_each(|&i| r.state(s, i as usize)),
                GhostRecord::Sphere => list.iter().for_each(|&i| r.sphere_state(s, i as usize)),
            }
        }
        self.owed = false;
    }

    /// Overwrites, on every ghost, the fields its record does not carry (for
    /// [`GhostRecord::Sphere`]: orientation, its residual, angular momentum) with NaN: a
    /// test's proof that nothing reads them (the run must still end bitwise one
    /// process's). Nothing where the whole state travels.
    #[doc(hidden)]
    pub fn scramble_unsent_ghost_fields(&mut self) {
        if self.ghost_record() == GhostRecord::Whole {
            return;
        }
        let s = &mut self.local.state;
        for &g in self.recv.iter().flatten() {
            let g = g as usize;
            s.orientation[g] = glam::Quat::from_xyzw(f32::NAN, f32::NAN, f32::NAN, f32::NAN);
            s.orientation_residual[g] = s.orientation[g];
            s.angular_momentum[g] = glam::Vec3::NAN;
        }
    }
}

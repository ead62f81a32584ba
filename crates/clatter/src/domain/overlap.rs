//! The ghost states' exchange overlapped with the contacts that need no ghost
//! ([`Domain::step`] when [`Domain::set_overlap`] is on: the library's default, which the
//! in-process tests run; `mpirun clatter` turns it on only with `CLATTER_MPI_OVERLAP=1`).
//!
//! A step's integrate leaves the owned bodies' new states; the ranks holding some of them
//! as ghosts need them before their next contacts. Rather than wait for them at the end of
//! the step, a rank reduces only the largest displacement there (it decides the next
//! rebuild, and a blow-up ends the step), and sends the ghost states at the start of the
//! next step, while it computes the contacts of the groups of eight pairs (the lanes'
//! groups) that hold no ghost; once every state is in, it computes the groups that do.
//!
//! Why the same bits: every contact is computed by the same code from the same inputs
//! (an interior group reads no ghost; a ghost group runs after the states are in), each
//! writes only its own slot, the lanes take the same eights (a part starts at a multiple
//! of eight) and the gather sums each body's forces in list order afterwards, in
//! integrate. The spheres' near list (`step/near.rs`) is kept only when it holds for the
//! owned bodies before the states come and for the ghosts after; where it does not hold
//! for the ghosts, it is written back, and the pairs of the broad phase's list not computed
//! yet (those with a ghost, and the others of the near list's groups with a ghost) are
//! computed one by one (lanes and the scalar path give the same bits): what the list made
//! anew would have computed, as the pairs both leave out are apart and hold zeros (the
//! near list holds for the owned bodies), and a pair that does not touch and did not is
//! left as it is.
//! A step that must make its near list, or that rebuilds, waits for the states first (a
//! rebuild sends no ghost state: the migration brings every body anew).

use super::Domain;
use super::comm::Comm;
use crate::precise;
use crate::step::contacts::{self, Part};
use crate::step::near;

/// The slices of the list whose interior groups run between two progress calls of the
/// transport (each one parallel pass over its slice).
const PROGRESS_SLICES: usize = 8;

/// What the overlapped steps of a rank computed while the ghost states travelled and after
/// ([`Domain::overlapped`]): for tests and the bench.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Overlapped {
    /// Steps whose contacts ran in two parts around the exchange.
    pub steps: u64,
    /// Body pairs computed while the states travelled (in groups with no ghost), over those
    /// steps.
    pub interior_pairs: u64,
    /// Body pairs computed once the states were in (in groups with a ghost).
    pub ghost_pairs: u64,
    /// Steps that waited for the states before any contact (a near list to make, no
    /// groups found yet), though their ghost states were owed.
    pub waited: u64,
    /// Overlapped steps whose near list did not hold for a ghost: written back, and the
    /// ghost pairs computed one by one.
    pub fallbacks: u64,
}

impl Domain {
    /// Whether this rank's steps overlap the ghost states' exchange with the interior
    /// contacts (on by default in the library; the CLI sets it from `CLATTER_MPI_OVERLAP`,
    /// off unless `1`, until its gain is measured on many cores; the same results either
    /// way). Every rank must set the same, between steps.
    pub fn set_overlap(&mut self, on: bool) {
        self.overlap = on;
    }

    /// What the overlapped steps computed so far, and how many waited ([`Overlapped`]).
    pub fn overlapped(&self) -> Overlapped {
        self.overlapped
    }

    /// Whether the ghosts' states are owed: the last step integrated, the exchange is
    /// due at the next step's contacts ([`Domain::sync_ghosts`] brings them now).
    pub fn ghosts_owed(&self) -> bool {
        self.owed
    }

    /// Brings the ghost states owed by the last step now (collective; nothing where none
    /// are owed): for what reads ghosts between steps (the blow-up checks' overlaps).
    pub fn sync_ghosts(&mut self, comm: &dyn Comm) {
        if self.owed {
            self.pack();
            comm.all_to_all_into(&self.sent, &mut self.received);
            self.unpack();
        }
    }

    /// Whether this step's end leaves the ghost states owed rather than sending them.
    pub(super) fn overlaps(&self) -> bool {
        self.overlap && self.send.len() > 1
    }

    /// Marks the groups of eight pairs of the active list that hold a pair with a ghost
    /// (after a contact stage that may have made a new list).
    pub(super) fn mark_groups(&mut self) {
        if !self.overlaps() {
            return;
        }
        let c = self.local.contacts.active();
        let ghost = &self.local.ghost;
        let is_ghost = |i: u32| ghost.get(i as usize).copied().unwrap_or(false);
        self.groups.clear();
        self.groups.extend(
            c.pairs
                .chunks(8)
                .map(|g| g.iter().any(|&[a, b]| is_ghost(a) | is_ghost(b))),
        );
        self.interior_pairs = c
            .pairs
            .chunks(8)
            .zip(&self.groups)
            .filter(|(_, g)| !**g)
            .map(|(p, _)| p.len() as u64)
            .sum();
    }

    /// The contact stage of a step whose ghost states are owed: the interior groups while
    /// they travel, then the groups with a ghost (see the module docs).
    pub(super) fn contacts_overlapped(&mut self, comm: &dyn Comm) {
        self.pack();
        let local = &mut self.local;
        // Ghosts' positions are split again once they are in.
        local.split_positions();
        let np = local.contacts.active().pairs.len();
        let kept = near::holds_for(local, None) != Some(false);
        if !kept || self.groups.len() != np.div_ceil(8) {
            // A near list to make (from every body's position), or no groups: wait.
            self.overlapped.waited += 1;
            comm.all_to_all_into(&self.sent, &mut self.received);
            self.unpack();
            contacts::run(&mut self.local);
            self.mark_groups();
            return;
        }
        // The springs change this step: the readers' copy is void (as `near::update`).
        local.contacts.view = std::sync::OnceLock::new();
        let groups = &self.groups;
        let mut work = |progress: &mut dyn FnMut()| {
            for s in 0..PROGRESS_SLICES {
                let cut = |s: usize| (np * s / PROGRESS_SLICES) / 8 * 8;
                let part = Part {
                    pairs: cut(s)..if s + 1 == PROGRESS_SLICES {
                        np
                    } else {
                        cut(s + 1)
                    },
                    groups: Some((groups, false)),
                    size: 8,
                    walls: s == 0,
                };
                contacts::run_part(local, &part);
                progress();
            }
        };
        comm.all_to_all_into_during(&self.sent, &mut self.received, &mut work);
        self.unpack();
        let local = &mut self.local;
        for &g in self.recv.iter().flatten() {
            let g = g as usize;
            local.position_pairs[g] = precise::split_a(local.state.position[g]);
            crate::step::motion::refresh(local, g);
        }
        self.overlapped.steps += 1;
        self.overlapped.interior_pairs += self.interior_pairs;
        if near::holds_for(local, Some(&self.recv)) == Some(false) {
            // The near list does not hold for a ghost: the broad phase's list, whose
            // pairs with a ghost are computed one by one.
            self.overlapped.fallbacks += 1;
            let ghost = &local.ghost;
            let is_ghost = |i: u32| ghost.get(i as usize).copied().unwrap_or(false);
            // Every pair with a ghost, and the interior pairs of the near list's groups
            // with a ghost (not computed yet either).
            let mut flags: Vec<bool> = (local.contacts.pairs.iter())
                .map(|&[a, b]| is_ghost(a) | is_ghost(b))
                .collect();
            if let Some(near) = &local.contacts.near {
                for (k, &slot) in near.slots.iter().enumerate() {
                    flags[slot as usize] |= self.groups[k / 8];
                }
            }
            local.contacts.end_near();
            self.overlapped.ghost_pairs += flags.iter().filter(|&&f| f).count() as u64;
            let part = Part {
                pairs: 0..flags.len(),
                groups: Some((&flags, true)),
                size: 1,
                walls: false,
            };
            contacts::run_part(local, &part);
            // The list changed (no near list now): the groups are found again after the
            // next step's contacts, which make a near list.
            self.groups.clear();
            return;
        }
        self.overlapped.ghost_pairs += np as u64 - self.interior_pairs;
        let part = Part {
            pairs: 0..np,
            groups: Some((&self.groups, true)),
            size: 8,
            walls: false,
        };
        contacts::run_part(local, &part);
    }
}

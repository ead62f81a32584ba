//! Gathering a decomposed world onto every rank ([`Domain::gather`]): each rank writes the
//! bodies it owns and its share of the contacts, every rank reads all of them back into the
//! world one process would have.

use glam::DVec3;

use super::comm::Comm;
use super::rows::{ContactRow, Reader, Writer};
use super::{Domain, carry};
use crate::contact_list::{ContactSprings, Contacts};
use crate::mesh_boundary::MESH_SLOTS;
use crate::step::mesh_contacts;
use crate::world::World;

/// One rank's share of the whole world at one step ([`Domain::share`]): its owned bodies
/// and contacts as [`Domain::gather`] sends them, and the clock.
#[derive(Debug, Clone)]
pub struct Share {
    bytes: Vec<u8>,
    with_contacts: bool,
    step_count: u64,
    time: f64,
    rebuilds: u64,
    needs_rebuild: bool,
    mesh_rebuild_time: f64,
}

impl Share {
    /// The step it was taken at.
    pub fn step(&self) -> u64 {
        self.step_count
    }
}

impl Domain {
    /// The whole world (collective; on every rank): the skeleton with every body's current
    /// state and constants (sent by its owner), the contact list with all it carries (springs, forces, touching flags,
    /// separating-axis hints, separation bounds), the positions (and, with composites, the
    /// orientations) it was built at, the clock, the rebuild count and whether a rebuild is
    /// due, each body's mesh contact slots: bitwise the world one process would have (its
    /// checkpoint is the same bytes). The mesh candidates are not sent: they are found again
    /// at the rebuild's poses and time, as restoring a checkpoint finds them.
    pub fn gather(&self, comm: &dyn Comm) -> World {
        self.gather_with(comm, true)
    }

    /// [`Domain::gather`] on rank 0 alone (collective; `None` on the other ranks): the same
    /// world, bitwise, but only rank 0 receives the shares (a gather, not an all-gather), so
    /// the other ranks never hold more than their own share. For what only rank 0 writes
    /// (frames, checkpoints, `final.csv`, the bench's row).
    pub fn gather_root(&self, comm: &dyn Comm) -> Option<World> {
        self.gather_kept(&self.share(), comm)
    }

    /// [`Domain::gather`] without the contact list (which is left empty): every body's state
    /// for what is computed from the bodies alone (energies, momentum, discharged mass),
    /// at a fraction of the traffic.
    pub fn gather_bodies(&self, comm: &dyn Comm) -> World {
        self.gather_with(comm, false)
    }

    /// This rank's share of the whole world as it is now: what [`Domain::gather`] sends
    /// (its owned bodies and its contacts) and the clock. The blow-up checks keep it at
    /// each full check as the rank's part of the last good state (O(its bodies), no
    /// message); [`Domain::gather_kept`] puts the shares together when a blow-up needs them.
    pub fn share(&self) -> Share {
        self.share_with(true)
    }

    /// The world whose shares every rank kept ([`Domain::share`], at the same step) on rank
    /// 0 (collective; `None` on the other ranks): bitwise the world [`Domain::gather`] gave
    /// then. Only rank 0 receives the shares (a gather, not an all-gather).
    pub fn gather_kept(&self, share: &Share, comm: &dyn Comm) -> Option<World> {
        let got = comm.gather_to_root(&share.bytes);
        (comm.rank() == 0).then(|| self.assemble(share, got))
    }

    /// [`Domain::share`], with or without the contacts.
    fn share_with(&self, with_contacts: bool) -> Share {
        let mut w = Writer::default();
        self.write_bodies(&mut w);
        if with_contacts {
            self.write_contacts(&mut w);
        } else {
            w.u32(0);
            w.u32(0);
        }
        let local = &self.local;
        Share {
            bytes: w.0,
            with_contacts,
            step_count: local.step_count,
            time: local.time,
            rebuilds: local.rebuilds,
            needs_rebuild: local.needs_rebuild(),
            mesh_rebuild_time: local.mesh.rebuild_time,
        }
    }

    /// [`Domain::gather`], with or without the contact list.
    fn gather_with(&self, comm: &dyn Comm, with_contacts: bool) -> World {
        let share = self.share_with(with_contacts);
        let got = comm.all_gather(&share.bytes);
        self.assemble(&share, got)
    }

    /// The whole world from every rank's share (`got`, by rank; `share` is this rank's, for
    /// the clock, which is the same on every rank).
    fn assemble(&self, share: &Share, got: Vec<Vec<u8>>) -> World {
        let with_contacts = share.with_contacts;
        let n = self.bodies;
        let mut world = carry::blank(&self.skeleton, n, Vec::new());
        let composites = world.has_composites();
        let mut pairs = Vec::new();
        let mut walls = Vec::new();
        let mut any_built = false;
        let slots = if world.boundaries.is_empty() {
            0
        } else {
            MESH_SLOTS
        };
        let mut mesh_slots = world.mesh_slots().to_vec();
        for m in got {
            let mut r = Reader::new(&m);
            for _ in 0..r.u32() {
                let id = r.u32() as usize;
                r.state(&mut world.state, id);
                r.consts(&mut world, id);
                let x = r.dvec3();
                let q = r.quat();
                if r.u32() != 0 {
                    any_built = true;
                    if world.rebuild_position.len() != n {
                        world.rebuild_position = vec![DVec3::ZERO; n];
                        if composites {
                            world.rebuild_orientation = vec![glam::Quat::IDENTITY; n];
                        }
                    }
                    world.rebuild_position[id] = x;
                    if composites {
                        world.rebuild_orientation[id] = q;
                    }
                }
                for k in 0..slots {
                    mesh_slots[id * slots + k] = r.slot();
                }
            }
            for _ in 0..r.u32() {
                pairs.push(ContactRow::read(&mut r, true));
            }
            for _ in 0..r.u32() {
                walls.push(ContactRow::read(&mut r, false));
            }
        }
        pairs.sort_unstable_by_key(|c| (c.key, c.piece));
        walls.sort_unstable_by_key(|c| (c.key, c.piece));
        let all = || pairs.iter().chain(&walls);
        let springs = ContactSprings {
            history: all().map(|c| c.history).collect(),
            twist: all().map(|c| c.twist).collect(),
            forces: all().map(|c| c.force).collect(),
            touching: all().map(|c| c.touching).collect(),
            hints: pairs.iter().map(|c| c.hint).collect(),
            separation_bound: pairs.iter().map(|c| c.bound).collect(),
        };
        let pieces: Vec<u32> = all().map(|c| c.piece).collect();
        let (history, twist) = (springs.history.clone(), springs.twist.clone());
        let (pair_keys, wall_keys) = (
            pairs.iter().map(|c| c.key).collect(),
            walls.iter().map(|c| c.key).collect(),
        );
        world.contacts = if composites {
            Contacts::with_pieces(n, pair_keys, wall_keys, pieces, history, twist)
        } else {
            Contacts::new(n, pair_keys, wall_keys, history, twist)
        };
        world
            .contacts
            .set_springs(springs)
            .expect("one row per contact");
        if !any_built {
            world.rebuild_position.clear();
            world.rebuild_orientation.clear();
        }
        if slots > 0 {
            world
                .set_mesh_slots(mesh_slots)
                .expect("MESH_SLOTS slots per body");
            if with_contacts && any_built {
                // The mesh candidates, found again where the last rebuild found them (the
                // bodies at their rebuild poses, the meshes at the rebuild time), as a
                // restored checkpoint finds them.
                let (x, q) = (
                    world.state.position.clone(),
                    world.state.orientation.clone(),
                );
                world.state.position.clone_from(&world.rebuild_position);
                if composites {
                    world
                        .state
                        .orientation
                        .clone_from(&world.rebuild_orientation);
                }
                world.time = share.mesh_rebuild_time;
                mesh_contacts::rebuild(&mut world);
                world.state.position = x;
                world.state.orientation = q;
            }
            world.mesh.rebuild_time = share.mesh_rebuild_time;
        }
        world.step_count = share.step_count;
        world.time = share.time;
        world.rebuilds = share.rebuilds;
        world.set_needs_rebuild(share.needs_rebuild);
        world
    }

    /// The owned bodies for [`Domain::gather`]: id, state, constants, and the pose at the
    /// last rebuild.
    fn write_bodies(&self, w: &mut Writer) {
        let local = &self.local;
        let owned: Vec<usize> = (0..local.len()).filter(|&i| !local.is_ghost(i)).collect();
        let built = local.rebuild_position.len() == local.len();
        let turned = local.rebuild_orientation.len() == local.len();
        w.u32(owned.len() as u32);
        for &i in &owned {
            w.u32(self.ids[i]);
            w.state(&local.state, i);
            w.consts(local, i);
            w.dvec3(if built {
                local.rebuild_position[i]
            } else {
                DVec3::ZERO
            });
            w.quat(if turned {
                local.rebuild_orientation[i]
            } else {
                glam::Quat::IDENTITY
            });
            w.u32(built as u32);
            for slot in local.mesh.body_slots(i) {
                w.slot(slot);
            }
        }
    }

    /// This rank's contacts for [`Domain::gather`]: the body pairs whose first body it owns
    /// (each pair is sent by one rank) and its bodies' wall contacts, with all they carry.
    fn write_contacts(&self, w: &mut Writer) {
        let local = &self.local;
        let c = &local.contacts;
        let sp = c.springs();
        let np = c.pairs.len();
        let piece = |k: usize| {
            if c.pieces.len() == c.len() {
                c.pieces[k]
            } else {
                0
            }
        };
        let mine: Vec<usize> = (0..np)
            .filter(|&k| !local.is_ghost(c.pairs[k][0] as usize))
            .collect();
        w.u32(mine.len() as u32);
        for k in mine {
            let [a, b] = c.pairs[k];
            ContactRow {
                key: [self.ids[a as usize], self.ids[b as usize]],
                piece: piece(k),
                history: sp.history[k],
                twist: sp.twist[k],
                force: sp.forces[k],
                touching: sp.touching[k],
                hint: sp.hints[k],
                bound: sp.separation_bound[k],
            }
            .write(w, true);
        }
        w.u32(c.wall_pairs.len() as u32);
        for (k, &[a, wall]) in c.wall_pairs.iter().enumerate() {
            ContactRow {
                key: [self.ids[a as usize], wall],
                piece: piece(np + k),
                history: sp.history[np + k],
                twist: sp.twist[np + k],
                force: sp.forces[np + k],
                touching: sp.touching[np + k],
                hint: 0,
                bound: 0.0,
            }
            .write(w, false);
        }
    }
}

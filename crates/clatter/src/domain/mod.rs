//! Domain decomposition: one world stepped by several ranks (MPI processes, or threads in
//! tests), bitwise as one process steps it. See `docs/parallel.md` for the design; in short:
//!
//! - **Ownership**: space is cut into one axis-aligned box per rank by recursive coordinate
//!   bisection ([`Bisection`], across the seam of a periodic axis too), cut so that each
//!   rank owns as many bodies as the others (by centre), from histograms of the bodies'
//!   coordinates summed over the ranks, and cut again at a broad-phase rebuild when the
//!   ranks' shares have drifted more than [`REBALANCE_IMBALANCE`] from even. With
//!   [`Balance::Work`] the bodies are weighted by an estimate of their work (pairs, ghost
//!   copies), so that each rank does about as much work rather than owning as many bodies.
//!   A rank's [`Domain::local`] world holds the bodies it owns and its **ghosts**: the bodies
//!   of other ranks whose centres lie within `2 r_max + skin` of its box (every partner of
//!   an owned body in the Verlet list), in ascending global id (scene order).
//! - **The determinism rule**: because the local order is the global order restricted, the
//!   local broad phase lists the pairs of an owned body in the same order as one process
//!   does; every pair with an owned body is evaluated, by every rank that owns one of its
//!   bodies, from bitwise the same inputs (ghost states are exact copies); and each owned
//!   body's force is gathered from those pairs in the one-process order
//!   ([`crate::Contacts::gather`]). No force crosses ranks: both owners of a cross-boundary
//!   pair compute it (LAMMPS' `newton off`), so nothing depends on the rank count.
//! - **Every step** ([`Domain::step`]): contacts and integrate on the local world (ghosts are
//!   not integrated: what integrate leaves in a ghost's state is not meaningful), then the
//!   owners send their bodies' new states to the ranks holding them as ghosts (forward
//!   communication, which overwrites every field the step reads of a ghost: the whole state,
//!   or for a world of spheres alone its position, velocity and spin, [`GhostRecord`]), and with them the
//!   largest displacement since the last rebuild is reduced over ranks (max, exact) to
//!   decide the next rebuild, as one process decides it. Overlapped (the default on
//!   several ranks, `overlap.rs`): the displacement is reduced alone at the end of the
//!   step, and the ghost states are sent at the next step's contacts, while the groups of
//!   pairs with no ghost are computed.
//! - **At rebuilds** (`Domain::migrate`): new boxes (when the old ones are uneven); each owner sends its bodies' states to
//!   their new owners and to the ranks that will hold them as ghosts, and the springs
//!   (tangential, twisting) of their contacts to the new owners of their bodies (point to
//!   point between neighbouring boxes when the boxes were kept, an all-to-all when they
//!   were cut again; what stays on a rank is kept in place, not sent to itself); then the
//!   local broad phase carries them as one process does.
//! - **Check steps** ([`Domain::check`], [`Domain::totals`]): the blow-up checks and the
//!   energy samples reduce each rank's exact sums and extremes, never a body's state; the
//!   last good state stays in shares on the ranks ([`Domain::share`]) until a blow-up.

mod balance;
mod bisection;
mod carry;
mod check;
mod comm;
mod gather;
mod ghosts;
mod overlap;
mod rows;
mod totals;

pub use balance::{BODY_WORK, Balance, GHOST_WORK, PAIR_WORK};
pub use bisection::Bisection;
pub use comm::{Comm, Rounds, ThreadComm};
pub use gather::Share;
pub use ghosts::GhostRecord;
pub use overlap::Overlapped;
pub use totals::Totals;

use glam::{DVec3, Vec3};

use crate::contact_list::{ContactSprings, Contacts};
use crate::mesh_boundary::MESH_SLOTS;
use crate::step::{broad, contacts, integrate, mesh_contacts};
use crate::world::{SimError, StepStats, World};
use carry::{KEPT, Kept};
use rows::{Reader, SpringRow, Writer};

/// The boxes are cut again at a rebuild only when the fullest rank would own more than this
/// fraction above the mean number of bodies per rank (10%) with the boxes it has (or, when
/// they balance work, [`Balance::Work`], would have more than this above the mean work): recutting
/// moves bodies between ranks (states, springs, ghost lists) and that is wasted while the
/// ranks are still about even. The threshold changes which rank steps a body, never the result.
pub const REBALANCE_IMBALANCE: f64 = 0.10;

/// One rank's part of a world stepped by a domain decomposition (see the module docs).
pub struct Domain {
    /// The world's setting without its bodies (shapes, materials, walls, mesh boundaries,
    /// sinks, `dt`, skin, code paths): what the local world and the gathered world are
    /// built on. Bodies carry their constants ([`carry`]), so no rank keeps every body's.
    skeleton: World,
    /// The whole world's number of bodies.
    bodies: usize,
    /// This rank's bodies and ghosts, in ascending global id.
    local: World,
    /// Global id of each local body, ascending.
    ids: Vec<u32>,
    /// The boxes of the last rebuild (`None` before the first).
    boxes: Option<Bisection>,
    /// Per rank: the local bodies it holds as ghosts (sent to it every step), ascending.
    send: Vec<Vec<u32>>,
    /// Per rank: the local ghosts it owns (received from it every step), ascending.
    recv: Vec<Vec<u32>>,
    /// `2 r_max + skin`: the reach of a pair, and so of the ghost layer.
    reach: f32,
    /// Bodies this rank handed to another at rebuilds (not counting the first distribution).
    handed_over: u64,
    /// Rebuilds that cut new boxes (the first distribution included).
    recuts: u64,
    /// The largest squared displacement of any body since the last rebuild, as the last
    /// step reduced it (infinite before a step): bounds how far a body has left its box.
    moved: f32,
    /// Rebuilds whose bodies and springs went point to point (the boxes were kept), and
    /// those that went through an all-to-all (new boxes).
    sparse_migrations: u64,
    /// The ghost states' messages of every step, by rank: kept from step to step (their
    /// sizes change only at rebuilds), so a step allocates and zeroes none.
    sent: Vec<Vec<u8>>,
    /// The ghost states received every step, by sending rank (see `sent`).
    received: Vec<Vec<u8>>,
    /// Whether steps overlap the ghost states' exchange with the interior contacts
    /// ([`Domain::set_overlap`]; `overlap.rs`).
    overlap: bool,
    /// Whether the ghosts' states are owed: the last step integrated and did not send
    /// them (overlapped steps send them at the next step's contacts).
    owed: bool,
    /// Per group of eight pairs of the active contact list, whether it holds a pair with a
    /// ghost (found after each contact stage that may have made the list; empty when not).
    groups: Vec<bool>,
    /// The pairs in the groups of `groups` with no ghost.
    interior_pairs: u64,
    /// What the overlapped steps computed ([`Domain::overlapped`]).
    overlapped: Overlapped,
    /// What the boxes balance: bodies or estimated work ([`Domain::with_balance`]).
    balance: Balance,
}

impl Domain {
    /// Rank `rank` of `ranks`' part of `world`, which every rank was given whole (the scene
    /// or checkpoint is broadcast). A world whose contact list is current (a resumed
    /// checkpoint, a restored pile) is split at once, as a rebuild at its rebuild positions
    /// would split it, so every rank steps its share from the first step; a new world
    /// starts owned by rank 0, and the first step's rebuild distributes it. Every world can be
    /// decomposed: walls, periodic boundaries, mesh boundaries, sinks, composites.
    pub fn new(world: World, rank: usize, ranks: usize) -> Domain {
        Domain::with_balance(world, rank, ranks, Balance::default())
    }

    /// [`Domain::new`] with boxes that balance `balance` (the bodies each rank owns, or the
    /// estimated work of each: `balance.rs`) at the first split and every recut. Which
    /// rank steps a body changes with it, never the result.
    pub fn with_balance(world: World, rank: usize, ranks: usize, balance: Balance) -> Domain {
        let reach = 2.0 * world.consts.max_radius() + world.skin;
        let skeleton = world.subset(&[], Vec::new());
        let empty = world.subset(&[], Vec::new());
        let mut domain = Domain {
            skeleton,
            bodies: world.len(),
            local: empty,
            ids: Vec::new(),
            boxes: None,
            send: vec![Vec::new(); ranks],
            recv: vec![Vec::new(); ranks],
            reach,
            handed_over: 0,
            recuts: 0,
            moved: f32::INFINITY,
            sparse_migrations: 0,
            sent: vec![Vec::new(); ranks],
            received: vec![Vec::new(); ranks],
            overlap: true,
            owed: false,
            groups: Vec::new(),
            interior_pairs: 0,
            overlapped: Overlapped::default(),
            balance,
        };
        let w = &world;
        let current = !w.needs_rebuild() && w.rebuild_position.len() == w.len() && !w.is_empty();
        if current {
            // A world with a current contact list (a resumed checkpoint, a cached pile):
            // split as it stands, so every rank steps its share from the first step.
            domain.split_current(&world, rank, ranks);
        } else {
            // A new world: rank 0 takes it whole, and the first step's rebuild distributes
            // it.
            let (ids, local) = if rank == 0 {
                ((0..world.len() as u32).collect(), world)
            } else {
                let mut empty = world.subset(&[], Vec::new());
                empty.set_needs_rebuild(world.needs_rebuild());
                (Vec::new(), empty)
            };
            domain.ids = ids;
            domain.local = local;
        }
        domain
    }

    /// Splits `world` (given whole to every rank), whose contact list is current (built at `rebuild_position`),
    /// between the ranks without a rebuild: the boxes, the owners and the ghosts are those a
    /// rebuild at the rebuild positions would have chosen (so every Verlet partner of an
    /// owned body is on its rank, as after [`Domain::migrate`]), and each rank's contact
    /// list is the whole list restricted to the pairs with an owned body and the owned
    /// bodies' wall contacts, with everything they carry (springs, forces, touching flags,
    /// hints, bounds): in ascending global id, so in the one-process order. The mesh
    /// candidates are found again at the rebuild poses and time.
    fn split_current(&mut self, world: &World, rank: usize, ranks: usize) {
        let (all, reach) = (|_: usize| true, |x: DVec3| self.ghost_reach(x));
        let layout = balance::Layout {
            position: &world.rebuild_position,
            owned: &all,
            pairs: &world.contacts.pairs,
            walls: &world.contacts.wall_pairs,
            reach: &reach,
        };
        let periodic = world.periodic.as_ref();
        let boxes = balance::cut(self.balance, &layout, None, ranks, periodic, None);
        let mut ids = Vec::new();
        let mut ghost = Vec::new();
        for (i, &x) in world.rebuild_position.iter().enumerate() {
            let owned = boxes.owner(x) == rank;
            if owned || self.near(&boxes, x, rank) {
                ids.push(i as u32);
                ghost.push(!owned);
            }
        }
        let mut local = world.subset(&ids, ghost);
        local.rebuild_position = ids
            .iter()
            .map(|&i| world.rebuild_position[i as usize])
            .collect();
        if world.rebuild_orientation.len() == world.len() {
            local.rebuild_orientation = ids
                .iter()
                .map(|&i| world.rebuild_orientation[i as usize])
                .collect();
        }
        // The contacts: the pairs with an owned body (both are on the rank), the owned
        // bodies' wall contacts; local ids are ascending global ids, so the order holds.
        let index = |g: u32| ids.binary_search(&g).ok().map(|i| i as u32);
        let c = &world.contacts;
        let sp = c.springs();
        let np = c.pairs.len();
        let mut pairs = Vec::new();
        let mut keep = Vec::new();
        for (k, &[a, b]) in c.pairs.iter().enumerate() {
            let (la, lb) = (index(a), index(b));
            let mine = |l: Option<u32>| l.is_some_and(|l| !local.is_ghost(l as usize));
            if mine(la) || mine(lb) {
                let (Some(la), Some(lb)) = (la, lb) else {
                    unreachable!("a Verlet partner of an owned body is within the ghost reach")
                };
                pairs.push([la, lb]);
                keep.push(k);
            }
        }
        let hints = keep.iter().map(|&k| sp.hints[k]).collect();
        let bounds = keep.iter().map(|&k| sp.separation_bound[k]).collect();
        let mut walls = Vec::new();
        for (k, &[a, wall]) in c.wall_pairs.iter().enumerate() {
            if let Some(la) = index(a).filter(|&l| !local.is_ghost(l as usize)) {
                walls.push([la, wall]);
                keep.push(np + k);
            }
        }
        let springs = ContactSprings {
            history: keep.iter().map(|&k| sp.history[k]).collect(),
            twist: keep.iter().map(|&k| sp.twist[k]).collect(),
            forces: keep.iter().map(|&k| sp.forces[k]).collect(),
            touching: keep.iter().map(|&k| sp.touching[k]).collect(),
            hints,
            separation_bound: bounds,
        };
        let (history, twist) = (springs.history.clone(), springs.twist.clone());
        local.contacts = if c.pieces.len() == c.len() && world.has_composites() {
            let pieces = keep.iter().map(|&k| c.pieces[k]).collect();
            Contacts::with_pieces(local.len(), pairs, walls, pieces, history, twist)
        } else {
            Contacts::new(local.len(), pairs, walls, history, twist)
        };
        local
            .contacts
            .set_springs(springs)
            .expect("one row per contact");
        if !local.boundaries.is_empty() {
            // The mesh candidates (the slots came with `subset`), found again where the last
            // rebuild found them: the bodies at their rebuild poses, the meshes at the
            // rebuild time, as `gather` and a restored checkpoint find them.
            let (x, q, t) = (
                local.state.position.clone(),
                local.state.orientation.clone(),
                local.time,
            );
            local.state.position.clone_from(&local.rebuild_position);
            if local.has_composites() {
                local
                    .state
                    .orientation
                    .clone_from(&local.rebuild_orientation);
            }
            local.time = local.mesh.rebuild_time;
            mesh_contacts::rebuild(&mut local);
            local.state.position = x;
            local.state.orientation = q;
            local.time = t;
        }
        local.set_needs_rebuild(false);
        // Who sends what every step, from the rebuild positions (both sides agree).
        let (send, recv) =
            self.exchange_lists(&local, &boxes, |i| world.rebuild_position[ids[i] as usize]);
        self.local = local;
        self.ids = ids;
        self.send = send;
        self.recv = recv;
        self.boxes = Some(boxes);
        self.recuts += 1;
    }

    /// This rank's world: the bodies it owns and its ghosts, in ascending global id.
    pub fn local(&self) -> &World {
        &self.local
    }

    /// The global id (scene index) of each body of [`Domain::local`].
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// The boxes of the last rebuild (`None` before the first step of a new world).
    pub fn boxes(&self) -> Option<&Bisection> {
        self.boxes.as_ref()
    }

    /// How many bodies this rank has handed to another rank at rebuilds (bodies that crossed
    /// a box boundary, or a boundary that moved past them), not counting the first
    /// distribution of a world.
    pub fn handed_over(&self) -> u64 {
        self.handed_over
    }

    /// How many rebuilds cut new boxes (the first distribution included): the others kept
    /// the boxes they had, whose bodies were still within [`REBALANCE_IMBALANCE`] of even.
    pub fn recuts(&self) -> u64 {
        self.recuts
    }

    /// Number of bodies this rank owns.
    pub fn owned(&self) -> usize {
        (0..self.local.len())
            .filter(|&i| !self.local.is_ghost(i))
            .count()
    }

    /// Number of ghosts on this rank: bodies of other ranks within reach of its region,
    /// whose states it receives every step (a measure of the communication volume).
    pub fn ghosts(&self) -> usize {
        self.local.len() - self.owned()
    }

    /// Advances the world by one step on every rank (collective): bitwise the step
    /// [`World::step`] takes on the whole world. The stats count this rank's contacts (those
    /// whose first body it owns).
    pub fn step(&mut self, comm: &dyn Comm) -> Result<StepStats, SimError> {
        let rebuilt = self.local.needs_rebuild();
        if rebuilt {
            // The migration brings every body's state anew: ghost states owed are not sent.
            self.owed = false;
            self.migrate(comm);
        }
        // The contact stage's count of its touching contacts, where it ran whole.
        let touching = if self.owed {
            // The ghost states sent while the contacts with no ghost are computed.
            self.contacts_overlapped(comm);
            None
        } else {
            let n = contacts::run(&mut self.local);
            self.mark_groups();
            Some(n)
        };
        mesh_contacts::run(&mut self.local);
        let moved = integrate::run(&mut self.local);
        self.local.step_count += 1;
        self.local.time += self.local.dt as f64;
        // This rank's largest displacement (its owned bodies': a ghost's state is not yet
        // its owner's), reduced over the ranks with the ghost states' exchange, or alone
        // when the states are sent at the next step's contacts (`overlap.rs`).
        let d2 = match moved {
            integrate::Moved::NonFinite => f32::INFINITY,
            integrate::Moved::Farthest(d2) => d2.max(broad::composite_moved(&self.local)),
        };
        let d2 = if self.overlaps() {
            self.owed = true;
            comm.max_f32(d2)
        } else {
            self.forward(comm, d2)
        };
        self.moved = d2;
        if d2 == f32::INFINITY {
            return Err(self.non_finite_error(comm));
        }
        let skin = self.local.skin;
        if d2 > 0.25 * skin * skin
            || (!self.local.boundaries.is_empty()
                && d2.sqrt() + mesh_contacts::moved_since_rebuild(&self.local) > 0.5 * skin)
        {
            // As `World::step`: a body, or bodies and meshes together, may have closed half
            // the skin.
            self.local.set_needs_rebuild(true);
        }
        Ok(StepStats {
            contacts: self.owned_touching(touching),
            rebuilt,
        })
    }

    /// Touching contacts over all ranks (collective), each counted once: what
    /// [`World::contact_count`] gives for the whole world.
    pub fn contact_count(&self, comm: &dyn Comm) -> usize {
        comm.sum_u64(self.owned_touching(None) as u64) as usize
    }

    /// Touching contacts of this rank's share: body pairs whose first body it owns, and
    /// its bodies' wall contacts. `stage`: what the contact stage returned where it ran
    /// whole this step (every touching body pair and wall contact of the active list, as
    /// one process's step counts them), so that only the ghosts' pairs are counted here;
    /// `None`: every flag is counted.
    fn owned_touching(&self, stage: Option<usize>) -> usize {
        // Only the active list's contacts (a near list's, while one lives) can touch.
        let c = self.local.contacts.active();
        let np = c.pairs.len();
        let t = &c.springs.touching;
        let ghost = &self.local.ghost;
        // The flags summed without branches (bytes widened to `u32`, which vectorise).
        let flags = |t: &[bool]| t.iter().map(|&tk| tk as u32).sum::<u32>() as usize;
        // Counted every step (the step's stats): every touching contact (the stage's count,
        // or the flags), less the pairs whose first body is a ghost: pairs sort by their first body, so a ghost's are one range of the list
        // (`pairs_as_a`), and only the ghosts' ranges (the lists received every step) are
        // read, not every pair's first body.
        let all = match stage {
            Some(n) => n,
            None => flags(&t[..np]) + flags(&t[np..]),
        };
        let of_ghosts: usize = if ghost.is_empty() {
            0
        } else if c.pairs_as_a.len() != ghost.len() + 1 {
            // No ranges (no list built for these bodies): pair by pair.
            c.pairs
                .iter()
                .zip(&t[..np])
                .map(|(p, &tk)| (tk & ghost.get(p[0] as usize).copied().unwrap_or(false)) as usize)
                .sum()
        } else {
            // Every ghost is received from its one owner: each is in one list.
            debug_assert_eq!(
                self.recv.iter().map(Vec::len).sum::<usize>(),
                ghost.iter().filter(|&&g| g).count()
            );
            self.recv
                .iter()
                .flatten()
                .map(|&g| {
                    let g = g as usize;
                    debug_assert!(ghost[g]);
                    let r = c.pairs_as_a[g] as usize..c.pairs_as_a[g + 1] as usize;
                    t[r].iter().map(|&tk| tk as usize).sum::<usize>()
                })
                .sum()
        };
        let pairs_and_walls = all - of_ghosts;
        let mesh = if self.local.mesh_slots().is_empty() {
            0
        } else {
            (0..self.local.len())
                .filter(|&i| !self.local.is_ghost(i))
                .flat_map(|i| self.local.mesh.body_slots(i))
                .filter(|s| s.touching)
                .count()
        };
        pairs_and_walls + mesh
    }

    /// The error of a step that left some body non-finite: the lowest such global id, as
    /// one process names it.
    fn non_finite_error(&self, comm: &dyn Comm) -> SimError {
        let s = &self.local.state;
        let mine = (0..self.local.len())
            .filter(|&i| !self.local.is_ghost(i))
            .find(|&i| {
                !(s.position[i].is_finite()
                    && s.velocity[i].is_finite()
                    && s.orientation[i].is_finite())
            })
            .map_or(u64::MAX, |i| self.ids[i] as u64);
        let body = comm.min_u64(mine);
        SimError::NonFinite {
            body: if body == u64::MAX { 0 } else { body as usize },
            step: self.local.step_count,
            time: self.local.time,
            dt: self.local.dt,
        }
    }

    /// How far from a box a body at `x` is a ghost there: the reach of a pair, with a
    /// margin for the rounding of the f32 pair test at `x`'s coordinates.
    fn ghost_reach(&self, x: DVec3) -> f64 {
        self.reach as f64 * 1.01 + x.abs().max_element() * (1.0 / 1_048_576.0)
    }

    /// Whether a body at `x` is a ghost on rank `s`: not owned there, and within the ghost
    /// reach of its box.
    fn near(&self, boxes: &Bisection, x: DVec3, s: usize) -> bool {
        s != boxes.owner(x) && boxes.distance(x, s) < self.ghost_reach(x)
    }

    /// Who sends what every step, found from the local bodies' positions `x(i)` at the
    /// rebuild (sender and receiver find the same lists from the same positions and boxes):
    /// by rank, the owned bodies sent there (those near its box) and the ghosts received
    /// from there (those it owns), in local ids.
    fn exchange_lists(
        &self,
        local: &World,
        boxes: &Bisection,
        x: impl Fn(usize) -> DVec3,
    ) -> (Vec<Vec<u32>>, Vec<Vec<u32>>) {
        let mut send = vec![Vec::new(); boxes.ranks()];
        let mut recv = vec![Vec::new(); boxes.ranks()];
        for i in 0..local.len() {
            let x = x(i);
            if local.is_ghost(i) {
                recv[boxes.owner(x)].push(i as u32);
            } else {
                let o = boxes.owner(x);
                boxes.for_within(x, self.ghost_reach(x), |s| {
                    if s != o {
                        send[s].push(i as u32);
                    }
                });
            }
        }
        (send, recv)
    }

    /// The rebuild (collective): new boxes (when needed), bodies and springs moved to their new ranks, the
    /// ghost lists found, then the local broad phase (which carries the springs).
    fn migrate(&mut self, comm: &dyn Comm) {
        // The springs sent below are the list's own: a near list's written back first.
        self.local.contacts.end_near();
        let ranks = comm.size();
        let local = &self.local;
        let owned: Vec<usize> = (0..local.len()).filter(|&i| !local.is_ghost(i)).collect();
        // 1. The boxes: the old ones while they are still about even (each rank sums its
        //    bodies' counts or work per old box, and the sums are summed:
        //    `REBALANCE_IMBALANCE`), else new ones, cut from histograms of the owned
        //    bodies' coordinates (weighted by their work) summed over the ranks (no rank
        //    sees another's positions).
        let (mine, reach) = (
            |i: usize| !local.is_ghost(i),
            |x: DVec3| self.ghost_reach(x),
        );
        let layout = balance::Layout {
            position: &local.state.position,
            owned: &mine,
            pairs: &local.contacts.pairs,
            walls: &local.contacts.wall_pairs,
            reach: &reach,
        };
        let kept = self.boxes.as_ref().filter(|old| {
            let load = balance::loads(self.balance, &layout, old, Some(comm));
            Bisection::imbalance(&load) <= REBALANCE_IMBALANCE
        });
        let kept_boxes = kept.is_some();
        let boxes = match kept {
            Some(old) => old.clone(),
            None => {
                let (old, periodic) = (self.boxes.as_ref(), local.periodic.as_ref());
                balance::cut(self.balance, &layout, old, ranks, periodic, Some(comm))
            }
        };
        if !kept_boxes {
            self.recuts += 1;
        }
        // 2. Bodies: to the new owner, and as ghosts to the ranks within reach.
        let me = comm.rank();
        let mut bodies: Vec<(u32, Writer)> = (0..ranks).map(|_| (0, Writer::default())).collect();
        // Most owned bodies stay: they are not written into a message to this rank, only
        // named (`Kept`), and copied from the old local world by `install`.
        let mut kept = Kept::default();
        kept.bodies.reserve(owned.len());
        let mut new_owner = vec![usize::MAX; local.len()];
        for &i in &owned {
            let x = local.state.position[i];
            let o = boxes.owner(x);
            new_owner[i] = o;
            if o != me && self.boxes.is_some() {
                self.handed_over += 1;
            }
            // The owner, and the ranks within the ghost reach (the cut tree walked, not
            // every rank's box tested).
            let ids = &self.ids;
            let mut send = |s: usize| {
                if s == me {
                    kept.bodies.push((ids[i], s == o, i as u32));
                    return;
                }
                let (n, w) = &mut bodies[s];
                *n += 1;
                w.u32(ids[i]);
                w.u32((s == o) as u32);
                w.state(&local.state, i);
                w.consts(local, i);
                for slot in local.mesh.body_slots(i) {
                    w.slot(slot);
                }
            };
            // The ranks come ascending, each once; the owner after them where it is not
            // among them (each rank's message holds the body once, so the order over ranks
            // does not matter).
            let mut owner_sent = false;
            boxes.for_within(x, self.ghost_reach(x), |s| {
                owner_sent |= s == o;
                send(s);
            });
            if !owner_sent {
                send(o);
            }
        }
        // 3. Springs: each owner sends its bodies' contacts to the bodies' new owners (a
        //    contact with two owners is sent by both; the copies are equal). Zero springs
        //    are not sent: a contact not found is carried as zero.
        //    Those staying on this rank are kept as rows (`Kept`), not written.
        let mut springs: Vec<(u32, Writer)> = (0..ranks).map(|_| (0, Writer::default())).collect();
        let mut walls: Vec<(u32, Writer)> = (0..ranks).map(|_| (0, Writer::default())).collect();
        let c = &local.contacts;
        let np = c.pairs.len();
        let sp = c.springs();
        let piece = |k: usize| {
            if c.pieces.len() == c.len() {
                c.pieces[k]
            } else {
                0
            }
        };
        let zero = |k: usize| {
            sp.history[k].to_array().map(f32::to_bits) == [0; 3] && sp.twist[k].to_bits() == 0
        };
        for (k, &[a, b]) in c.pairs.iter().enumerate() {
            if zero(k) {
                continue;
            }
            let row = SpringRow {
                key: [self.ids[a as usize], self.ids[b as usize]],
                piece: piece(k),
                history: sp.history[k],
                twist: sp.twist[k],
            };
            let (da, db) = (new_owner[a as usize], new_owner[b as usize]);
            for (d, first) in [(da, true), (db, da != db)] {
                if d == me && first {
                    kept.pairs.push((row, [a, b]));
                } else if d != usize::MAX && first {
                    springs[d].0 += 1;
                    row.write(&mut springs[d].1);
                }
            }
        }
        for (k, &[a, wall]) in c.wall_pairs.iter().enumerate() {
            let d = new_owner[a as usize];
            if zero(np + k) || d == usize::MAX {
                continue;
            }
            let row = SpringRow {
                key: [self.ids[a as usize], wall],
                piece: piece(np + k),
                history: sp.history[np + k],
                twist: sp.twist[np + k],
            };
            if d == me {
                kept.walls.push((row, a));
            } else {
                walls[d].0 += 1;
                row.write(&mut walls[d].1);
            }
        }
        let msgs: Vec<Vec<u8>> = bodies
            .into_iter()
            .zip(springs)
            .zip(walls)
            .map(|(((nb, b), (ns, s)), (nw, w))| {
                if nb + ns + nw == 0 {
                    // Nothing for that rank: no message (the point-to-point exchange then
                    // skips it).
                    return Vec::new();
                }
                let mut m = Writer::default();
                m.u32(nb);
                m.0.extend(b.0);
                m.u32(ns);
                m.0.extend(s.0);
                m.u32(nw);
                m.0.extend(w.0);
                m.0
            })
            .collect();
        // 4. The exchange: point to point with the ranks whose boxes are near this one's
        //    when the boxes were kept (a body then is near its old box), an all-to-all when
        //    they were cut again (bodies may go anywhere).
        let peers = if kept_boxes {
            self.peers(comm, &boxes, &msgs)
        } else {
            None
        };
        let got = match peers {
            Some(peers) => {
                self.sparse_migrations += 1;
                comm.exchange_with(msgs, &peers)
            }
            None => comm.all_to_all(msgs),
        };
        self.install(&got, kept, me, boxes);
    }

    /// The ranks a rebuild with kept boxes exchanges with (collective; every rank finds the
    /// same symmetric relation): those whose boxes are within a body's ghost reach plus the
    /// farthest any body has moved since the last rebuild (`moved`, reduced exactly) of
    /// this rank's box. Every body was in its owner's box at the last rebuild (its centre
    /// rounded to f32: the margin covers it), so its new owner and the ranks it is a ghost
    /// on are among them. `None` (an all-to-all then) when some rank has a message for a
    /// rank outside its peers after all (one all-reduce says so): a guard, never expected.
    fn peers(&self, comm: &dyn Comm, boxes: &Bisection, msgs: &[Vec<u8>]) -> Option<Vec<bool>> {
        let me = comm.rank();
        // The largest coordinate of any owned body, for the rounding margin of the reach.
        let local = &self.local;
        let mut far = [(0..local.len())
            .filter(|&i| !local.is_ghost(i))
            .map(|i| local.state.position[i].abs().max_element() as f32)
            .fold(0.0f32, f32::max)];
        comm.max_f32s(&mut far);
        let moved = (self.moved as f64).sqrt();
        let margin = far[0] as f64 * 1.001;
        let within = self.reach as f64 * 1.01 + 2.0 * margin / 1_048_576.0 + moved * 1.000_001;
        let mut peers = vec![false; boxes.ranks()];
        peers[me] = true;
        for s in boxes.boxes_within(me, within + margin * 1e-6) {
            peers[s] = true;
        }
        let stray = msgs
            .iter()
            .zip(&peers)
            .any(|(m, &peer)| !peer && !m.is_empty());
        let stray = comm.max_f32(if stray { 1.0 } else { 0.0 });
        (within.is_finite() && stray == 0.0).then_some(peers)
    }

    /// Rebuilds whose bodies went point to point between neighbouring ranks (the boxes were
    /// kept); the others (the first distribution, new boxes) used an all-to-all.
    pub fn sparse_migrations(&self) -> u64 {
        self.sparse_migrations
    }

    /// Builds the new local world from the messages of a rebuild (by sending rank; this
    /// rank's own, `me`, is `kept`: its staying bodies are copied from the old local world)
    /// and runs the local broad phase on it.
    fn install(&mut self, got: &[Vec<u8>], kept: Kept, me: usize, boxes: Bisection) {
        // Mesh contact slots per body (none without boundaries).
        let slots = if self.skeleton.boundaries.is_empty() {
            0
        } else {
            MESH_SLOTS
        };
        // Bodies: (global id, owned, sending rank, where its state starts), or for a body
        // that stays, (global id, owned, `KEPT`, its old local id).
        let mut entries = Vec::new();
        let mut pair_rows = Vec::new();
        let mut wall_rows = Vec::new();
        let mut kept = Some(kept);
        for (from, m) in got.iter().enumerate() {
            if from == me {
                // Where this rank's own message was read: the rows in the same order.
                let k = kept.take().expect("one rank is this one");
                debug_assert!(m.is_empty(), "nothing is sent to this rank itself");
                entries.extend(k.bodies.iter().map(|&(id, o, i)| (id, o, KEPT, i as usize)));
                pair_rows.extend(k.pairs.into_iter().map(|(r, old)| (r, Some(old))));
                wall_rows.extend(k.walls.into_iter().map(|(r, old)| (r, Some(old))));
                continue;
            }
            if m.is_empty() {
                continue;
            }
            let mut r = Reader::new(m);
            for _ in 0..r.u32() {
                let id = r.u32();
                let owned = r.u32() != 0;
                entries.push((id, owned, from, r.position()));
                r.skip_state();
                r.skip_consts();
                r.skip_slots(slots);
            }
            for _ in 0..r.u32() {
                pair_rows.push((SpringRow::read(&mut r), None));
            }
            for _ in 0..r.u32() {
                wall_rows.push((SpringRow::read(&mut r), None));
            }
        }
        // Each sender's bodies (and the kept ones) come ascending: a stable sort merges
        // the runs.
        entries.sort_by_key(|e| e.0);
        let ids: Vec<u32> = entries.iter().map(|e| e.0).collect();
        let ghost: Vec<bool> = entries.iter().map(|e| !e.1).collect();
        let mut local = carry::blank(&self.skeleton, ids.len(), ghost);
        let mut mesh_slots = Vec::with_capacity(entries.len() * slots);
        for (i, &(_, _, from, at)) in entries.iter().enumerate() {
            if from == KEPT {
                carry::copy_body(&self.local, at, &mut local, i);
                let old = self.local.mesh.body_slots(at);
                mesh_slots.extend(old.iter().take(slots).map(rows::travelled));
                continue;
            }
            let mut r = Reader::at(&got[from], at);
            r.state(&mut local.state, i);
            r.consts(&mut local, i);
            mesh_slots.extend((0..slots).map(|_| r.slot()));
        }
        if slots > 0 {
            local
                .set_mesh_slots(mesh_slots)
                .expect("MESH_SLOTS slots per body");
            // Every body may have had candidates: the rebuild clears the slots of those that
            // have none now (the others' are clear already), as one process does.
            local.mesh.active = (0..local.len() as u32).collect();
        }
        local.step_count = self.local.step_count;
        local.time = self.local.time;
        local.rebuilds = self.local.rebuilds;
        // The springs, in local ids (a kept row's bodies renumbered, a received one's
        // found by global id), sorted as the broad phase sorts its lists: each sender's
        // rows come in its list's order, so a stable sort merges the runs. Two copies of a
        // contact (from both owners) are equal: which one `dedup` keeps does not matter.
        let renumber = carry::renumbering(&self.ids, &ids);
        let index = |g: u32| ids.binary_search(&g).ok().map(|i| i as u32);
        let new = |old: u32| Some(renumber[old as usize]).filter(|&n| n != u32::MAX);
        let mut pairs: Vec<([u32; 2], u32, Vec3, f32)> = pair_rows
            .iter()
            .filter_map(|(r, old)| {
                let key = match *old {
                    Some([a, b]) => [new(a)?, new(b)?],
                    None => [index(r.key[0])?, index(r.key[1])?],
                };
                Some((key, r.piece, r.history, r.twist))
            })
            .collect();
        pairs.sort_by_key(|p| (p.0, p.1));
        pairs.dedup_by_key(|p| (p.0, p.1));
        let mut wall_list: Vec<([u32; 2], u32, Vec3, f32)> = wall_rows
            .iter()
            .filter_map(|(r, old)| {
                let body = match *old {
                    Some(a) => new(a)?,
                    None => index(r.key[0])?,
                };
                Some(([body, r.key[1]], r.piece, r.history, r.twist))
            })
            .collect();
        wall_list.sort_by_key(|p| (p.0, p.1));
        wall_list.dedup_by_key(|p| (p.0, p.1));
        let all = pairs.iter().chain(&wall_list);
        let history = all.clone().map(|p| p.2).collect();
        let twist = all.clone().map(|p| p.3).collect();
        let pieces: Vec<u32> = all.map(|p| p.1).collect();
        let (pairs, wall_list) = (
            pairs.iter().map(|p| p.0).collect(),
            wall_list.iter().map(|p| p.0).collect(),
        );
        local.contacts = if local.has_composites() {
            Contacts::with_pieces(local.len(), pairs, wall_list, pieces, history, twist)
        } else {
            Contacts::new(local.len(), pairs, wall_list, history, twist)
        };
        broad::rebuild(&mut local);
        // Who sends what every step: both sides find it from the same positions and boxes.
        let (send, recv) = self.exchange_lists(&local, &boxes, |i| local.state.position[i]);
        self.local = local;
        self.ids = ids;
        self.send = send;
        self.recv = recv;
        self.boxes = Some(boxes);
    }
}

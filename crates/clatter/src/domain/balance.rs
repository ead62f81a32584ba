//! What the boxes balance ([`Balance`]): the bodies each rank owns, or an estimate of the
//! work each rank does per step. Ranks that own as many bodies need not do as much work: a
//! rank in the middle of a pile holds more ghosts (faces to more neighbours) and computes
//! more pairs twice (a pair across a boundary is computed by both owners) than one at a
//! wall or the free surface, and bodies deep in a pile have more pairs than those on top.
//! The work of a rank is modelled as a sum over its owned bodies ([`weigh`]): a body, its
//! share of its pairs, and the ghost copies it gives other ranks (the ghosts a rank holds
//! are about the copies it gives: the layers on either side of a face are about as full).
//! The boxes change which rank steps a body, never the result.

use glam::{DVec3, Vec3};

use super::bisection::Bisection;
use super::comm::Comm;
use crate::periodic::Periodic;

/// What the recursive coordinate bisection balances between the ranks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Balance {
    /// Each rank owns about as many bodies ([`Bisection::balanced`]): the default. On a
    /// 16-core machine it timed 2-5% faster than [`Balance::Work`] on a poured pile of
    /// 262,144 spheres (BENCHMARKS.md, session 26's second device call), where the work
    /// balance evened out the instruction counts (6.9% to 2.6% apart) but not the time.
    #[default]
    Bodies,
    /// Each rank's estimated work per step (`weigh`) is about the same
    /// ([`Bisection::weighted`]).
    Work,
}

impl Balance {
    /// The balance named `bodies` or `work` (as `CLATTER_MPI_BALANCE` spells it), if it is
    /// one of them.
    pub fn from_name(name: &str) -> Option<Balance> {
        match name.trim() {
            "bodies" => Some(Balance::Bodies),
            "work" => Some(Balance::Work),
            _ => None,
        }
    }
}

/// The work model's units (about 40 instructions each), fitted to the instructions per
/// step of ranks of a settled sphere pile (BENCHMARKS.md, `mpi15`): an owned body
/// (integrate, bookkeeping, about 200) costs [`BODY_WORK`], a pair the rank computes
/// [`PAIR_WORK`] (about 80; split between its ends when both are owned here), a ghost
/// [`GHOST_WORK`] (about 230-270: its state packed, sent, unpacked, and its lane in
/// integrate, which runs over every group of eight bodies holding an owned one).
pub const BODY_WORK: u64 = 5;
/// See [`BODY_WORK`]; even, so that each end of a pair within a rank takes half exactly.
pub const PAIR_WORK: u64 = 2;
/// See [`BODY_WORK`].
pub const GHOST_WORK: u64 = 6;

/// How many times the work-balanced boxes are cut ([`cut`]): the pairs across boxes and the
/// ghost copies depend on the boxes, so each cut weighs the bodies with the last one's
/// boxes (the first with the old boxes, or none).
const PASSES: usize = 3;

/// What [`weigh`] reads: the bodies' positions and the contact list of one world (a rank's
/// local world, or a whole world on one process).
pub(super) struct Layout<'a> {
    /// Every body's position (local ids).
    pub position: &'a [DVec3],
    /// Whether a body is owned here (weighed); the others are ghosts (only their owners
    /// are looked up).
    pub owned: &'a dyn Fn(usize) -> bool,
    /// The candidate pairs (local ids).
    pub pairs: &'a [[u32; 2]],
    /// The body of each wall contact.
    pub walls: &'a [[u32; 2]],
    /// How far from a box a body at `x` is a ghost there.
    pub reach: &'a dyn Fn(DVec3) -> f64,
}

/// Each owned body's estimated work per step, in local id order (0 for ghosts), with
/// `boxes` deciding which pairs cross ranks and the ghost copies (`None`: all on one rank):
/// [`BODY_WORK`], plus [`PAIR_WORK`] for each pair with a body of another rank (both
/// compute it) or a wall, half of it for each pair with a body of the same rank, plus
/// [`GHOST_WORK`] for each rank that holds the body as a ghost. Summed over a rank's bodies:
/// its bodies, pairs and (about) ghosts, each at its cost.
pub(super) fn weigh(l: &Layout, boxes: Option<&Bisection>) -> Vec<u64> {
    let n = l.position.len();
    let owner: Vec<usize> = match boxes {
        Some(b) => l.position.iter().map(|&x| b.owner(x)).collect(),
        None => vec![0; n],
    };
    let mut w: Vec<u64> = (0..n)
        .map(|i| if (l.owned)(i) { BODY_WORK } else { 0 })
        .collect();
    for &[a, b] in l.pairs {
        let (a, b) = (a as usize, b as usize);
        let share = if owner[a] == owner[b] {
            PAIR_WORK / 2
        } else {
            PAIR_WORK
        };
        for i in [a, b] {
            if (l.owned)(i) {
                w[i] += share;
            }
        }
    }
    for &[a, _] in l.walls {
        let a = a as usize;
        if (l.owned)(a) {
            w[a] += PAIR_WORK;
        }
    }
    if let Some(b) = boxes {
        for (i, &x) in l.position.iter().enumerate() {
            if (l.owned)(i) {
                let mut copies = 0;
                b.for_within(x, (l.reach)(x), |s| copies += (s != owner[i]) as u64);
                w[i] += GHOST_WORK * copies;
            }
        }
    }
    w
}

/// The boxes for `ranks` ranks (collective when `comm` is given) of the bodies of `l`
/// owned here, at `positions` (the owned ones, in local id order), balanced as `balance`
/// says: for [`Balance::Work`], cut [`PASSES`] times, each weighing the bodies with the
/// last boxes (the first with `old`). A world with no candidate pairs on any rank (a new
/// world's first distribution: no broad phase has run) is cut by bodies: its work cannot be
/// told yet, and the ghost copies alone would weigh far more than they cost. The next
/// rebuild's check ([`loads`]) recuts it by work if it is uneven.
pub(super) fn cut(
    balance: Balance,
    l: &Layout,
    old: Option<&Bisection>,
    ranks: usize,
    periodic: Option<&Periodic>,
    comm: Option<&dyn Comm>,
) -> Bisection {
    let owned: Vec<usize> = (0..l.position.len()).filter(|&i| (l.owned)(i)).collect();
    let positions: Vec<Vec3> = owned.iter().map(|&i| l.position[i].as_vec3()).collect();
    let pairs = l.pairs.len() as u64;
    let pairs = comm.map_or(pairs, |c| c.sum_u64(pairs));
    match balance {
        Balance::Work if pairs > 0 => {
            let mut boxes = old.cloned();
            for _ in 0..PASSES {
                let w = weigh(l, boxes.as_ref());
                let weights: Vec<u64> = owned.iter().map(|&i| w[i]).collect();
                boxes = Some(Bisection::weighted(
                    &positions, &weights, ranks, periodic, comm,
                ));
            }
            boxes.expect("at least one pass")
        }
        _ => Bisection::balanced(&positions, ranks, periodic, comm),
    }
}

/// Per rank of `boxes`: the bodies of `l` owned here that it owns (`Balance::Bodies`) or
/// their summed work ([`weigh`] with `boxes`), summed over the ranks when `comm` is given
/// (collective): what the imbalance of `boxes` is measured on.
pub(super) fn loads(
    balance: Balance,
    l: &Layout,
    boxes: &Bisection,
    comm: Option<&dyn Comm>,
) -> Vec<u64> {
    let mut load = vec![0u64; boxes.ranks()];
    let w = match balance {
        Balance::Bodies => Vec::new(),
        Balance::Work => weigh(l, Some(boxes)),
    };
    for (i, &x) in l.position.iter().enumerate() {
        if (l.owned)(i) {
            load[boxes.owner(x)] += if w.is_empty() { 1 } else { w[i] };
        }
    }
    if let Some(comm) = comm {
        comm.sum_u64s(&mut load);
    }
    load
}

impl super::Domain {
    /// What the boxes balance ([`super::Domain::with_balance`]).
    pub fn balance(&self) -> Balance {
        self.balance
    }

    /// Candidate pairs on this rank (its Verlet list: every pair with an owned body; a
    /// pair across a boundary is on both its bodies' ranks).
    pub fn pairs(&self) -> usize {
        self.local.contacts.pairs.len()
    }

    /// This rank's estimated work per step in the units of [`BODY_WORK`] (`weigh` summed
    /// over its owned bodies with its boxes): what [`Balance::Work`] evens out, for
    /// reports (0 before the first step of a new world, which has no boxes yet).
    pub fn work(&self) -> u64 {
        let Some(boxes) = self.boxes.as_ref() else {
            return 0;
        };
        let local = &self.local;
        let (mine, reach) = (
            |i: usize| !local.is_ghost(i),
            |x: DVec3| self.ghost_reach(x),
        );
        let layout = Layout {
            position: &local.state.position,
            owned: &mine,
            pairs: &local.contacts.pairs,
            walls: &local.contacts.wall_pairs,
            reach: &reach,
        };
        weigh(&layout, Some(boxes)).iter().sum()
    }
}

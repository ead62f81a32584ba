//! The contact list: candidate body pairs and body-wall pairs from the broad phase, with
//! what each carries across steps (tangential and twisting springs, separating-axis hints,
//! separation bounds) and what the last step computed (touching, force). Contact `k` is a
//! body pair for `k < pairs().len()`, else wall pair `k - pairs().len()`.

use std::fmt;

use glam::{BVec4A, Quat, Vec3, Vec4};

use crate::contract::ContactForce;
use clatter_geom::narrow::{NO_HINT, SatHint};

/// The other side of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Partner {
    /// A body, by id.
    Body(u32),
    /// A wall, by index (scene `[[wall]]`s first, then the container's faces).
    Wall(u32),
    /// A triangle-mesh boundary, by index (the scene's `[[boundary]]`s in order). Its
    /// contacts are not in the contact list: each body keeps them in its mesh slots
    /// (`crate::mesh_boundary::MeshContacts`).
    Boundary(u32),
}

impl fmt::Display for Partner {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Partner::Body(j) => write!(f, "body {j}"),
            Partner::Wall(w) => write!(f, "wall {w}"),
            Partner::Boundary(b) => write!(f, "boundary {b}"),
        }
    }
}

/// Per-contact state, in contact order (body pairs, then wall pairs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactSprings {
    /// Tangential spring.
    pub history: Vec<Vec3>,
    /// Twisting spring (rad) of a patch; for one-point contacts with a sphere, the normal
    /// dashpot's primitive where it has been applied up to (N s; see
    /// `law::resolved_normal_force`).
    pub twist: Vec<f32>,
    /// The last step's force.
    pub forces: Vec<ContactForce>,
    /// Whether the contact touched in the last step.
    pub touching: Vec<bool>,
    /// What the narrow phase remembers per body pair ([`SatHint`]): for a pair found apart,
    /// the axis that separated it; for touching polyhedra, the contact the full
    /// separating-axis test chose (a reference face, or an edge contact).
    pub hints: Vec<SatHint>,
    /// Per body pair, with its hint: for a pair found apart, how far apart it was last found,
    /// less the most both bodies can have moved since (the narrow phase skips the pair while
    /// it is positive); for touching polyhedra with a remembered contact, the margin of the
    /// full test's decisions less twice the most any axis's separation can have moved since
    /// (see `clatter_geom::narrow::collide_with_hint`).
    pub separation_bound: Vec<f32>,
}

/// The contact list and its per-body gather ranges. See the module docs.
#[derive(Debug, Clone, Default)]
pub struct Contacts {
    /// Body pairs `(i, j)`, `i < j`, sorted.
    pub(crate) pairs: Vec<[u32; 2]>,
    /// Body-wall pairs `(body, wall)`, sorted.
    pub(crate) wall_pairs: Vec<[u32; 2]>,
    pub(crate) springs: ContactSprings,
    /// Body `i` is side a of body pairs `pairs_as_a[i]..pairs_as_a[i+1]` (pairs sort by `i`).
    pub(crate) pairs_as_a: Vec<u32>,
    /// Body `i` is side b of the body pairs `b_pairs[b_pair_start[i]..b_pair_start[i+1]]`.
    pub(crate) b_pair_start: Vec<u32>,
    /// The side-b pairs of each body in turn, then (when not empty) [`BLOCK`] zeros: the
    /// gather reads side b in blocks of four from a range's start, and the padding keeps
    /// every block's reads within the vector without clamping each index ([`pad_b_pairs`]).
    pub(crate) b_pairs: Vec<u32>,
    /// Body `i`'s wall contacts are `wall_contacts_of[i]..wall_contacts_of[i+1]`.
    pub(crate) wall_contacts_of: Vec<u32>,
    /// Worlds with composite bodies only (empty otherwise): per contact, which pieces touch,
    /// [`piece_code`]`(a, b)` for a body pair (the same body pair then appears once per piece
    /// pair, sorted by code), the piece of the body for a wall pair.
    pub(crate) pieces: Vec<u32>,
    /// Spheres only: the near list ([`crate::step::near`]), a step-internal cache of the
    /// body pairs that can touch while it lives, with its own contiguous springs (the owner
    /// of those pairs' and the wall pairs' springs while it lives). `None`: `springs` is
    /// current.
    pub(crate) near: Option<Box<crate::step::near::Near>>,
    /// While a near list lives: `springs` with the near list's written in, made on the first
    /// read ([`Contacts::springs`]) after a step, emptied by the next.
    pub(crate) view: std::sync::OnceLock<ContactSprings>,
    /// Per wall pair (by its place in `wall_pairs`), a cache that changes no result: for a
    /// pair last found apart, how far apart (less a margin for rounding) less the most its
    /// body can have moved since; the contact stage skips the pair while that is positive
    /// (`step::plain_walls`). 0 (no skip) for a pair found touching or not known. Empty in a
    /// new list (sized by its first step), emptied with new springs, in no checkpoint:
    /// a list without it computes every wall pair once.
    pub(crate) wall_gap: crate::step::plain_walls::WallGaps,
}

/// Bits per piece id in a contact's piece code (composites have at most 64 pieces).
pub const PIECE_BITS: u32 = 8;

/// The piece code of a body-pair contact between piece `a` of the first body and piece `b`
/// of the second: sorting codes sorts by `a`, then `b`.
#[inline]
pub fn piece_code(a: u32, b: u32) -> u32 {
    (a << PIECE_BITS) | b
}

/// The two piece ids of a body-pair contact's code.
#[inline]
pub fn piece_ids(code: u32) -> (u32, u32) {
    (code >> PIECE_BITS, code & ((1 << PIECE_BITS) - 1))
}

impl Contacts {
    /// A list of `pairs` and `wall_pairs` (both sorted) over `bodies` bodies, with the given
    /// springs, no force and nothing touching.
    pub fn new(
        bodies: usize,
        pairs: Vec<[u32; 2]>,
        wall_pairs: Vec<[u32; 2]>,
        history: Vec<Vec3>,
        twist: Vec<f32>,
    ) -> Contacts {
        // Gather ranges, in contact order (a fixed, thread-independent summation order).
        let np = pairs.len();
        let mut pairs_as_a = vec![0u32; bodies + 1];
        let mut b_pair_start = vec![0u32; bodies + 1];
        let mut wall_contacts_of = vec![np as u32; bodies + 1];
        for p in &pairs {
            pairs_as_a[p[0] as usize + 1] += 1;
            b_pair_start[p[1] as usize + 1] += 1;
        }
        for p in &wall_pairs {
            wall_contacts_of[p[0] as usize + 1] += 1;
        }
        for i in 0..bodies {
            pairs_as_a[i + 1] += pairs_as_a[i];
            b_pair_start[i + 1] += b_pair_start[i];
            wall_contacts_of[i + 1] += wall_contacts_of[i] - np as u32;
        }
        let mut fill = b_pair_start.clone();
        let mut b_pairs = vec![0u32; np];
        for (c, p) in pairs.iter().enumerate() {
            b_pairs[fill[p[1] as usize] as usize] = c as u32;
            fill[p[1] as usize] += 1;
        }
        let b_pairs = pad_b_pairs(b_pairs);
        let total = pairs.len() + wall_pairs.len();
        Contacts {
            springs: ContactSprings {
                history,
                twist,
                forces: vec![ContactForce::default(); total],
                touching: vec![false; total],
                hints: vec![NO_HINT; np],
                separation_bound: vec![0.0; np],
            },
            pairs,
            wall_pairs,
            pairs_as_a,
            b_pair_start,
            b_pairs,
            wall_contacts_of,
            pieces: Vec::new(),
            near: None,
            view: std::sync::OnceLock::new(),
            wall_gap: Default::default(),
        }
    }

    /// [`Contacts::new`] for worlds with composite bodies: `pieces` holds one piece code per
    /// contact (body pairs, then wall pairs; see [`Contacts::pieces`]).
    pub fn with_pieces(
        bodies: usize,
        pairs: Vec<[u32; 2]>,
        wall_pairs: Vec<[u32; 2]>,
        pieces: Vec<u32>,
        history: Vec<Vec3>,
        twist: Vec<f32>,
    ) -> Contacts {
        debug_assert_eq!(pieces.len(), pairs.len() + wall_pairs.len());
        let mut c = Contacts::new(bodies, pairs, wall_pairs, history, twist);
        c.pieces = pieces;
        c
    }

    /// Per contact, the pieces that touch (empty unless the world has composite bodies):
    /// [`piece_ids`] of the code for a body pair, the body's piece for a wall pair.
    pub fn pieces(&self) -> &[u32] {
        &self.pieces
    }

    /// Candidate body pairs `(i, j)`, `i < j`, sorted.
    pub fn pairs(&self) -> &[[u32; 2]] {
        &self.pairs
    }

    /// Candidate body-wall pairs `(body, wall)`, sorted.
    pub fn wall_pairs(&self) -> &[[u32; 2]] {
        &self.wall_pairs
    }

    /// Number of contacts (body pairs and wall pairs).
    pub fn len(&self) -> usize {
        self.pairs.len() + self.wall_pairs.len()
    }

    /// True when there are no candidate contacts.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Contact `k`: the body (the lower id of a pair) and the other side.
    pub fn partners(&self, k: usize) -> (u32, Partner) {
        let np = self.pairs.len();
        if k < np {
            let [i, j] = self.pairs[k];
            (i, Partner::Body(j))
        } else {
            let [i, w] = self.wall_pairs[k - np];
            (i, Partner::Wall(w))
        }
    }

    /// The springs, forces and flags of every contact. While a near list lives (spheres,
    /// the `step::near` module), the list's own springs are behind: this is then a copy with
    /// the near list's written in, made once per step on the first read.
    pub fn springs(&self) -> &ContactSprings {
        match &self.near {
            None => &self.springs,
            Some(near) => self.view.get_or_init(|| {
                let mut s = self.springs.clone();
                near.write_back(&mut s);
                s
            }),
        }
    }

    /// The list the step reads and writes: the near list while one lives, else this one.
    /// Every contact outside it neither touches nor holds a force or a spring.
    #[inline]
    pub(crate) fn active(&self) -> &Contacts {
        match &self.near {
            Some(near) => &near.list,
            None => self,
        }
    }

    /// Writes a live near list's springs back into this list's and drops it (before
    /// anything replaces or reads this list's springs directly).
    pub(crate) fn end_near(&mut self) {
        if let Some(near) = self.near.take() {
            near.write_back(&mut self.springs);
        }
        self.view = std::sync::OnceLock::new();
    }

    /// The springs, for changing them: any near list is written back and dropped first.
    pub(crate) fn springs_mut(&mut self) -> &mut ContactSprings {
        self.end_near();
        &mut self.springs
    }

    /// Replaces the per-contact state (a checkpoint's); fails when a length does not match
    /// the list.
    pub fn set_springs(&mut self, springs: ContactSprings) -> Result<(), String> {
        let (n, np) = (self.len(), self.pairs.len());
        let lens = [
            ("tangential springs", springs.history.len(), n),
            ("twisting springs", springs.twist.len(), n),
            ("forces", springs.forces.len(), n),
            ("touching flags", springs.touching.len(), n),
            ("separating-axis hints", springs.hints.len(), np),
            ("separation bounds", springs.separation_bound.len(), np),
        ];
        for (what, got, want) in lens {
            if got != want {
                return Err(format!("{got} {what} for a list of {want}"));
            }
        }
        // Replaced whole: a near list's springs are void, and so are the wall gaps (the
        // bodies' state may come with the springs).
        self.near = None;
        self.view = std::sync::OnceLock::new();
        self.wall_gap = Default::default();
        self.springs = springs;
        Ok(())
    }

    /// Per body, the number of contacts (body and wall) that touched in the last step; the
    /// mesh boundaries' are in the bodies' mesh slots ([`crate::World::contact_counts`]
    /// adds them).
    pub fn counts(&self, bodies: usize) -> Vec<u32> {
        let mut counts = vec![0u32; bodies];
        // Only the active list's contacts can touch.
        let c = self.active();
        for k in 0..c.len() {
            if c.springs.touching[k] {
                let (i, other) = c.partners(k);
                counts[i as usize] += 1;
                if let Partner::Body(j) = other {
                    counts[j as usize] += 1;
                }
            }
        }
        counts
    }

    /// The force and torque on body `i` from every contact of the last step, summed in
    /// contact order (the same order whatever the thread count).
    #[inline]
    pub fn gather(&self, i: usize) -> (Vec3, Vec3) {
        let (f, t) = self.gather4(i);
        (f.truncate(), t.truncate())
    }

    /// [`Contacts::gather`] in four lanes: the first three are its force and torque, the
    /// fourth is to be thrown away (for callers that keep the sums in SIMD registers).
    #[inline(always)]
    pub(crate) fn gather4(&self, i: usize) -> (Vec4, Vec4) {
        // A live near list holds every contact with a force (the others' are +0, and adding
        // or subtracting +0 leaves a sum started at +0 unchanged: `crate::step::near`).
        let this = self.active();
        // Forces of non-touching contacts are zero, so no branch is needed. Each vector is
        // read with the float after it (`normal_force`, a pad) as one four-lane load and
        // summed in four lanes: the first three lanes do the `Vec3` sums' operations in the
        // same order (the same bits); the fourth is thrown away.
        let forces = &this.springs.forces;
        let mut f = Vec4::ZERO;
        let mut t = Vec4::ZERO;
        for c in &forces[this.pairs_as_a[i] as usize..this.pairs_as_a[i + 1] as usize] {
            let [force_b, torque_a, _] = lanes(c);
            f -= force_b;
            t += torque_a;
        }
        for &k in &this.b_pairs[this.b_pair_start[i] as usize..this.b_pair_start[i + 1] as usize] {
            let [force_b, _, torque_b] = lanes(&forces[k as usize]);
            f += force_b;
            t += torque_b;
        }
        for c in &forces[this.wall_contacts_of[i] as usize..this.wall_contacts_of[i + 1] as usize] {
            let [force_b, _, torque_b] = lanes(c);
            f += force_b;
            t += torque_b;
        }
        (f, t)
    }

    /// Whether [`Contacts::gather8_with`] should take its padded side loops (`true`) or
    /// those of each body's own length, for a stage on the current rayon pool: the padded
    /// loops where the step runs on one thread (each MPI rank's step): there they cut the
    /// sphere pile's one-thread step by 11% of its time; on two threads the loops of each
    /// body's own length were 7% faster (BENCHMARKS.md, sph20). The same bits either way.
    /// Asked once a stage (it reads the pool's thread count), not once per eight bodies.
    pub(crate) fn gather8_padded() -> bool {
        rayon::current_num_threads() == 1
    }

    /// [`Contacts::gather4`] of bodies `i..i + 8` at once (`f[l]`, `t[l]` for body `i + l`):
    /// the same sums in the same order (the same bits), with the eight bodies' ranges read
    /// and checked once rather than body by body. The bodies whose bit is set in `skip`
    /// (lane l in bit l: ghosts, whose states the exchange brings) are not gathered and come
    /// back zero. Panics unless `i + 8` bodies exist. The near list's sums while one lives
    /// (see `gather4`). Its side-a and side-b loops are padded to blocks of four (`PADDED`,
    /// see [`BLOCK`]) or of each body's own length ([`Contacts::gather8_padded`] says which
    /// to take): the same sums, the same bits.
    #[inline(always)]
    pub(crate) fn gather8_with<const PADDED: bool>(
        &self,
        i: usize,
        skip: u32,
    ) -> ([Vec4; 8], [Vec4; 8]) {
        let this = self.active();
        #[cfg(target_arch = "x86_64")]
        if crate::step::avx2() {
            // SAFETY: the CPU has AVX2 (`avx2` is never true otherwise).
            return unsafe { this.gather8_avx2::<PADDED>(i, skip) };
        }
        this.gather8_here::<PADDED>(i, skip)
    }

    /// [`Contacts::gather8_here`] compiled for AVX2 and called, not inlined: on its own it
    /// keeps the tables' pointers in registers, where inlined into the integrate lanes it
    /// reloaded them for every body.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(never)]
    #[target_feature(enable = "avx2")]
    unsafe fn gather8_avx2<const PADDED: bool>(
        &self,
        i: usize,
        skip: u32,
    ) -> ([Vec4; 8], [Vec4; 8]) {
        self.gather8_here::<PADDED>(i, skip)
    }

    /// [`Contacts::gather8_with`] on this list itself.
    #[inline(always)]
    fn gather8_here<const PADDED: bool>(&self, i: usize, skip: u32) -> ([Vec4; 8], [Vec4; 8]) {
        let total = self.len();
        let np = self.pairs.len();
        let forces = &self.springs.forces[..total];
        let a: &[u32; 9] = self.pairs_as_a[i..i + 9].try_into().unwrap();
        let bs: &[u32; 9] = self.b_pair_start[i..i + 9].try_into().unwrap();
        let ws: &[u32; 9] = self.wall_contacts_of[i..i + 9].try_into().unwrap();
        // Each table ascends within the list (as `Contacts::new` builds them); checked here
        // for the eight bodies so the loops below index without further checks.
        // Without early exits (`&`, not `all`): eight compares the compiler may do at once,
        // rather than eight branches.
        let ascending = |r: &[u32; 9], end: usize| {
            let mut ok = r[8] as usize <= end;
            for l in 0..8 {
                ok &= r[l] <= r[l + 1];
            }
            ok
        };
        // Side b's ranges end `BLOCK` entries before `b_pairs` does (its padding), so that
        // a block of four from any start at or before a range's end reads within it.
        let b_len = self.b_pairs.len().saturating_sub(BLOCK);
        assert!(ascending(a, np) && ascending(bs, b_len) && ascending(ws, total));
        let mut f = [Vec4::ZERO; 8];
        let mut t = [Vec4::ZERO; 8];
        if total == 0 {
            return (f, t);
        }
        for l in 0..8 {
            if skip >> l & 1 != 0 {
                // Not wanted (a ghost, which its owner integrates): left zero.
                continue;
            }
            let (mut fl, mut tl) = (Vec4::ZERO, Vec4::ZERO);
            if !PADDED {
                // SAFETY: `a[l]..a[l + 1]` lies within `forces` (checked above).
                let own = unsafe { forces.get_unchecked(a[l] as usize..a[l + 1] as usize) };
                for c in own {
                    let [force_b, torque_a, _] = lanes(c);
                    fl -= force_b;
                    tl += torque_a;
                }
                // SAFETY: within `b_pairs` (checked above).
                let other = unsafe {
                    self.b_pairs
                        .get_unchecked(bs[l] as usize..bs[l + 1] as usize)
                };
                for &k in other {
                    let [force_b, _, torque_b] = lanes(&forces[k as usize]);
                    fl += force_b;
                    tl += torque_b;
                }
            } else {
                // Side a and side b in blocks of four, the first always done, the places past a
                // range's end read as +0 (`BLOCK`'s docs: the same bits): most bodies have at
                // most four of each, so the loops' exits are then predictable.
                let (start, end) = (a[l] as usize, a[l + 1] as usize);
                // Blocks that read within `forces` unclamped when the range ends `BLOCK`
                // before it (all bodies but the last few of a list with walls after its
                // pairs), else clamped.
                if end + BLOCK <= total {
                    side_a::<true>(forces, start, end, &mut fl, &mut tl);
                } else {
                    side_a::<false>(forces, start, end, &mut fl, &mut tl);
                }
                let (start, end) = (bs[l] as usize, bs[l + 1] as usize);
                if !self.b_pairs.is_empty() {
                    let mut m = start;
                    loop {
                        let live = live_places(m, end);
                        // Indexed, not iterated: `live.iter()` cost the cube pile's step
                        // 7 instructions per body (callgrind).
                        #[allow(clippy::needless_range_loop)]
                        for u in 0..BLOCK {
                            // SAFETY: `m <= end` (`m` starts at `start <= end` and the
                            // loop ends once `m >= end`), and `end + BLOCK <=
                            // b_pairs.len()` (checked above), so `m + u < b_pairs.len()`.
                            let k = unsafe { *self.b_pairs.get_unchecked(m + u) } as usize;
                            let [force_b, _, torque_b] = lanes(&forces[k]);
                            fl += Vec4::select(live[u], force_b, Vec4::ZERO);
                            tl += Vec4::select(live[u], torque_b, Vec4::ZERO);
                        }
                        m += BLOCK;
                        if m >= end {
                            break;
                        }
                    }
                }
            }
            // SAFETY: within `forces` (checked above).
            let walls = unsafe { forces.get_unchecked(ws[l] as usize..ws[l + 1] as usize) };
            for c in walls {
                let [force_b, _, torque_b] = lanes(c);
                fl += force_b;
                tl += torque_b;
            }
            (f[l], t[l]) = (fl, tl);
        }
        (f, t)
    }
}

/// Side a's sum of a body's contacts `forces[start..end]` (`start <= end <= forces.len()`,
/// `forces` not empty) in blocks of [`BLOCK`], the places past `end` added as `+0`. `FREE`:
/// `end + BLOCK <= forces.len()`, so every block's places are read unclamped; else each
/// index is clamped to the last force. The same loads and sums either way (same bits).
#[inline(always)]
fn side_a<const FREE: bool>(
    forces: &[ContactForce],
    start: usize,
    end: usize,
    fl: &mut Vec4,
    tl: &mut Vec4,
) {
    debug_assert!(start <= end && end <= forces.len() && !forces.is_empty());
    debug_assert!(!FREE || end + BLOCK <= forces.len());
    let mut m = start;
    loop {
        let live = live_places(m, end);
        for u in 0..BLOCK {
            let c = if FREE {
                // SAFETY: `m <= end` (`m` starts at `start <= end`, and the loop ends once
                // `m >= end`), so `m + u < end + BLOCK <= forces.len()` (the caller's test).
                unsafe { forces.get_unchecked(m + u) }
            } else {
                &forces[(m + u).min(forces.len() - 1)]
            };
            let [force_b, torque_a, _] = lanes(c);
            *fl -= Vec4::select(live[u], force_b, Vec4::ZERO);
            *tl += Vec4::select(live[u], torque_a, Vec4::ZERO);
        }
        m += BLOCK;
        if m >= end {
            break;
        }
    }
}

/// [`live_places`]' table: [`BLOCK`] all-true masks, then [`BLOCK`] all-false ones.
static LIVE: [BVec4A; 2 * BLOCK] = {
    let mut t = [BVec4A::FALSE; 2 * BLOCK];
    let mut u = 0;
    while u < BLOCK {
        t[u] = BVec4A::TRUE;
        u += 1;
    }
    t
};

/// The masks of a block of [`BLOCK`] places from `m` in a range ending at `end`: mask `u`
/// is `BVec4A::splat(m + u < end)`, the four read from a table as one slice (the places
/// live are the first `min(end - m, BLOCK)`) rather than each made from its compare.
#[inline(always)]
fn live_places(m: usize, end: usize) -> &'static [BVec4A; BLOCK] {
    let dead = BLOCK - end.saturating_sub(m).min(BLOCK);
    LIVE[dead..dead + BLOCK].try_into().unwrap()
}

/// `b_pairs` with [`BLOCK`] zeros after it when it is not empty (see [`Contacts`]'s
/// `b_pairs`): a padded block's places read pair 0, whose force is then added as `+0`
/// (`live` is false there), so the sums keep their bits.
pub(crate) fn pad_b_pairs(mut b_pairs: Vec<u32>) -> Vec<u32> {
    if !b_pairs.is_empty() {
        b_pairs.resize(b_pairs.len() + BLOCK, 0);
    }
    b_pairs
}

/// How many side-a or side-b contacts [`Contacts::gather8_with`] sums a body's in at a time. A
/// block's places past the range's end add (or subtract) +0 rather than branch out: a sum
/// that starts at +0 and only ever adds or subtracts is never -0 (a zero result of a sum of
/// nonzeros rounds to +0, and `+0 + -0`, `+0 - +0` are +0), and `x + 0` and `x - 0` are then
/// `x` bit for bit, so the sums are the same bits as those without the padding. Most
/// bodies of a pile have at most four on a side, so a body's loops end after one block: the
/// exits that a loop of the body's own length mispredicted (its length varies body to body)
/// become predictable, worth more than the padding's adds.
const BLOCK: usize = 4;

/// A contact force's three vectors, each with the float stored after it as a fourth lane
/// (`force_b` with `normal_force`, the torques with their pads).
#[inline(always)]
fn lanes(c: &ContactForce) -> [Vec4; 3] {
    let words: &[[f32; 4]; 3] = bytemuck::cast_ref(c);
    words.map(Vec4::from_array)
}

/// A world's contact list in a backend-neutral form (see [`crate::World::contact_state`]):
/// how the GPU backend takes over and hands back the contacts' springs, so runs can move
/// between backends and checkpoints stay complete.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactState {
    /// Positions at the last broad-phase rebuild (empty: no list, rebuild at the next step).
    pub rebuild_position: Vec<glam::DVec3>,
    /// Candidate body pairs `(i, j)`, `i < j`, sorted (with composites: the same body pair
    /// once per piece pair, sorted by [`piece_code`]).
    pub pairs: Vec<[u32; 2]>,
    /// Worlds with composite bodies only (empty otherwise): the [`piece_code`] of each pair.
    pub pieces: Vec<u32>,
    /// Worlds with composite bodies only (empty otherwise): orientations at the last
    /// broad-phase rebuild (the rebuild test counts rotation, and the per-piece wall
    /// candidates are found at these poses).
    pub rebuild_orientation: Vec<Quat>,
    /// Tangential spring per pair.
    pub history: Vec<Vec3>,
    /// Twisting spring per pair (rad).
    pub twist: Vec<f32>,
    /// Whether each pair touched in the last step.
    pub touching: Vec<bool>,
    /// The last step's force per pair.
    pub forces: Vec<ContactForce>,
    /// Tangential spring per body, wall and piece: slot `(body * walls + wall) * pieces +
    /// piece`, with `pieces` = [`crate::World::max_pieces`] (1 without composites, so then
    /// `body * walls + wall`).
    pub wall_history: Vec<Vec3>,
    /// Twisting spring per body and wall.
    pub wall_twist: Vec<f32>,
    /// Whether each body touched each wall in the last step.
    pub wall_touching: Vec<bool>,
    /// The last step's force per body and wall.
    pub wall_forces: Vec<ContactForce>,
}

/// Tangential and twisting springs for `new` pairs: the old values where the pair persists,
/// zero otherwise. Both pair lists are sorted (keys: body pairs, or body pairs with piece
/// codes). In parallel pieces of [`CARRY_CHUNK`] new pairs ([`carry_springs_in`]).
pub(crate) fn carry_springs<K: Ord + Sync>(
    old: &[K],
    old_hist: &[Vec3],
    old_twist: &[f32],
    new: &[K],
) -> (Vec<Vec3>, Vec<f32>) {
    carry_springs_in(old, old_hist, old_twist, new, CARRY_CHUNK)
}

/// New pairs per parallel piece of [`carry_springs`].
const CARRY_CHUNK: usize = 4096;

/// [`carry_springs`] in pieces of `piece` new pairs (any positive size: the same springs).
/// Each piece merges its new pairs with the old from the first old pair not below its
/// first new pair (`partition_point`): where the one merge over the whole list would be
/// when it reaches that pair, as both lists are sorted. Serial, this merge was part of
/// the rebuild that a second thread waited for.
pub(crate) fn carry_springs_in<K: Ord + Sync>(
    old: &[K],
    old_hist: &[Vec3],
    old_twist: &[f32],
    new: &[K],
    piece: usize,
) -> (Vec<Vec3>, Vec<f32>) {
    use rayon::prelude::*;
    // Zero for a pair that does not persist; each piece writes the others.
    let mut hist = vec![Vec3::ZERO; new.len()];
    let mut twist = vec![0.0; new.len()];
    new.par_chunks(piece)
        .zip(hist.par_chunks_mut(piece))
        .zip(twist.par_chunks_mut(piece))
        .for_each(|((new, hist), twist)| {
            let mut k = new.first().map_or(0, |p| old.partition_point(|o| o < p));
            for ((p, h), t) in new.iter().zip(hist).zip(twist) {
                while k < old.len() && old[k] < *p {
                    k += 1;
                }
                if k < old.len() && old[k] == *p {
                    *h = old_hist.get(k).copied().unwrap_or(Vec3::ZERO);
                    *t = old_twist.get(k).copied().unwrap_or(0.0);
                }
            }
        });
    (hist, twist)
}

#[cfg(test)]
#[path = "contact_list_tests.rs"]
mod tests;

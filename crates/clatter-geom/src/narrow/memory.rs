//! What a polyhedron pair remembers of its Gauss-map edge search between steps: the edge
//! pairs that can pass the Gauss-map tests at any relative rotation near the one of the
//! last full search. While the rotation stays near, the search visits those pairs alone,
//! through the same tests in the same order, so it finds bitwise what the whole search
//! finds (see [`EdgeMemory`]).

use glam::{Mat3, Quat, Vec3, Vec4};

use super::SatHint;
use super::edges::{EdgeOfA, separating_pair};
use super::sat::EdgeAxis;
use super::slack::{Anchor, FaceSlack};
use super::sphere::SphereMemory;
use crate::ConvexPolyhedron;

/// How many edge pairs one memory holds (the default scene's searches keep fewer than 20 on
/// average at [`TURN`], the mixed pile's about 28, but a dodecahedron against an
/// icosahedron often more than 64: with 64 those pairs were never remembered and ran the
/// whole search every step); a search with more candidates is not remembered.
const CAPACITY: usize = 128;

/// How far the Gauss-map tests' products must be from zero at the recorded rotation for a
/// pair to be left out of the memory (the products are of unit normals with arcs of
/// length at most 1). The memory holds while twice the sine of half the angle turned since
/// (the largest move of a unit vector) stays below this, less [`ROUNDING`]. 0.01 measured
/// cheapest overall (BENCHMARKS.md, poly9): 0.005 and 0.0025 save under 1% on a settled
/// pile but cost 3.5% and 11% while the default scene pours; 0.02 costs more on both.
pub(super) const TURN: f32 = 0.01;

/// The rounding allowed for: of each product, at the recorded rotation and now (a few ulps
/// of the products, of the rotation matrices built from unit quaternions, and of the angle
/// turned), with room to spare.
const ROUNDING: f32 = 1e-4;

/// What the edge-axis search of a polyhedron pair `(a, b)` remembers, to do less at the
/// next steps for the same answer, bitwise. Which of two kinds depends on how the pair's
/// edge axes are searched:
///
/// - **By Gauss map**: the edge pairs that can pass the Gauss-map tests of
///   `edges::edge_axes_gauss_map` while B's rotation relative to A stays near `rot`. Why
///   this is exact: the tests are signs of products `n . (R v)` of unit normals with arcs
///   (of length at most 1) turned by the relative rotation `R` (or its transpose). A pair
///   was left out only when one of the tests failed at `rot` with products at least `TURN`
///   (0.01) away from zero, each with the sign that fails it. A rotation by an angle `phi`
///   moves a vector by at most `2 sin(phi / 2)` times its length, so while that, with the
///   rounding, stays below `TURN`, every product left out keeps its strict sign, and the
///   test it failed still fails. The pairs kept are visited in the same order (by edge of
///   A, then of B) through the same tests and arithmetic as the whole search (`EdgeOfA`),
///   so the same pairs pass, and the best (or first separating) one is the same.
/// - **By direction**: the direction pairs found deep, left out of later searches while
///   they provably stay at or below the search's floor (see `DeepPairs`).
///
/// A sphere against a polyhedron keeps a third kind in the same slot: the faces and edges
/// whose candidates may still be the nearest while the sphere's centre stays near where it
/// was recorded (see `super::sphere`).
///
/// A memory names its polyhedra by address. The simulation keeps its memories beside the
/// world's shapes (shared `Arc`s that live as long as the world), so no other polyhedron
/// can take those addresses while a memory names them; a caller that frees polyhedra must
/// drop (or [`EdgeMemory::default`]) the memories that name them.
// Laid out by hand (`repr(C)`), the fields every search reads first and together, and
// aligned to a cache line: a memory is read once per pair and step from an array of
// memories too large for the L2 cache, and with the compiler's order the address check
// (`shapes`) and the kind (`directions`) fell on two lines eight lines apart, the first
// line's miss 23% of the samples of `edges::edge_axes_by_direction` on the cube pile
// (`perf`). Now a search by direction reads the lines 0 to 3 only (the header, then
// `levels`), one by Gauss map those and the prefix of `pairs` it visits. No arithmetic
// changes: the same answers, bitwise. With the served paths (768 bytes, 12 lines; the
// test `the_served_paths_read_few_lines_of_a_memory` holds the lines): a remembered face
// reads line 9 (`anchor`) and line 10 (`face`'s plan), line 11 too when its record's own
// certificate does not stand; a remembered edge by direction reads line 0 (the header),
// line 9 and the lines of the levels it takes (on the settled cube pile codes 2 to 8,
// mostly 6 to 8: lines 1 and 2). Header and anchor (47 and 36 bytes) do not fit one
// line, nor anchor and plan (36 and 62), so no order of these fields reads fewer lines
// (layout37, BENCHMARKS.md); nearly every one of these lines misses a 1 MiB cache on the
// 2,048-cube pile, once per pair and step.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct EdgeMemory {
    /// The addresses of A and B, 0 when nothing is remembered.
    shapes: [usize; 2],
    /// B's rotation relative to A at the recorded search.
    rot: Quat,
    /// B's offset in A's frame at the recorded search.
    offset: Vec3,
    /// By Gauss map, how many pairs `pairs` holds.
    len: u8,
    /// Whether this is a memory of the search by direction (see [`DeepPairs`]).
    directions: bool,
    /// By Gauss map, the index in `pairs` of the pair that won the last search; by
    /// direction, the direction pair `ia * (B's directions) + ib` that won it ([`NONE`]:
    /// none): evaluated first at the next (see [`EdgeMemory::search`] and
    /// [`EdgeMemory::deep_pairs`]).
    winner: u8,
    /// The pairs remembered at each level code `c` (1 to [`LEVELS`], at `c - 1`; see
    /// [`DeepPairs`]) while recording, and once a recording ends ([`EdgeMemory::finish`],
    /// [`EdgeMemory::finish_directions`]) the pairs at codes 1 to `c` (so that a search
    /// served takes its set of levels with one read, [`EdgeMemory::up_to`]), a bit per pair: by Gauss map, per index in `pairs` (a pair at no
    /// level is always visited); by direction, per direction pair `ia * (B's directions) +
    /// ib`. A pair found at some depth is left out of later searches while it cannot rise
    /// above the search's floor (see [`EdgeMemory::search`]): those of a few sets joined,
    /// not found one remembered pair at a time.
    levels: [u128; LEVELS as usize],
    /// By Gauss map, the pairs remembered, `[edge of A, edge of B]`, in increasing order.
    pairs: [[u8; 2]; CAPACITY],
    /// The sphere kind (a sphere against a polyhedron, `shapes` = `[polyhedron, SPHERE]`):
    /// what the sphere's faces, edges and margins are (see `super::sphere`).
    sphere: SphereMemory,
    /// The relative pose of the pair's last full separating-axis test that found a
    /// remembered contact (see [`Anchor`]): the pair's stored margin is that test's, and
    /// the served paths bound every separation's change since from it. Not cleared with
    /// the edge search's record (which is recorded and served on its own terms).
    anchor: Anchor,
    /// A remembered face contact's clip record (see [`FaceSlack`]), its own cache line.
    face: FaceSlack,
}

/// The second shape address of a memory of the sphere kind (no polyhedron lives at 1).
const SPHERE: usize = 1;

/// No winning pair remembered (see `EdgeMemory::winner`; above every index of `pairs`).
const NONE: u8 = u8::MAX;

impl Default for EdgeMemory {
    fn default() -> Self {
        EdgeMemory {
            shapes: [0; 2],
            rot: Quat::IDENTITY,
            offset: Vec3::ZERO,
            len: 0,
            directions: false,
            winner: NONE,
            levels: [0; LEVELS as usize],
            pairs: [[0; 2]; CAPACITY],
            sphere: SphereMemory::default(),
            anchor: Anchor::NONE,
            face: FaceSlack::default(),
        }
    }
}

/// The identity of a polyhedron as a memory records it.
#[inline]
fn address(p: &ConvexPolyhedron) -> usize {
    p as *const ConvexPolyhedron as usize
}

/// Whether `q` is a unit quaternion up to rounding (the exactness argument needs it: the
/// simulation's orientations are renormalised to a few ulps every step, and a relative
/// rotation is a product of two; the matrices built from them are then rotations to
/// within 1e-5 per entry).
#[inline]
fn unit(q: Quat) -> bool {
    (q.length_squared() - 1.0).abs() < 4e-6
}

/// The cache lines of a memory (from its start, 64 bytes each) that a pair's served paths
/// read, in the order a remembered edge reads them: the header (line 0: shapes, pose, kind,
/// winner), the levels of codes 2 to 9 (what a settled pile's searches take: codes 2 to 5
/// on line 1, 6 to 9 on line 2), the anchor (read first of all, by a remembered face and a
/// remembered edge alike) and the face's clip record's plan. See [`EdgeMemory::prefetch`].
pub(super) const SERVED_LINES: [usize; 5] = [
    std::mem::offset_of!(EdgeMemory, shapes) / 64,
    (std::mem::offset_of!(EdgeMemory, levels) + 16) / 64,
    (std::mem::offset_of!(EdgeMemory, levels) + 16 * 5) / 64,
    std::mem::offset_of!(EdgeMemory, anchor) / 64,
    std::mem::offset_of!(EdgeMemory, face) / 64,
];

impl EdgeMemory {
    /// Asks the CPU to bring the cache lines of this memory that a served pair reads
    /// (`SERVED_LINES`) into its caches, so that a pair loop can fetch the next pair's
    /// memory while it works on this one. A hint only: it reads and changes nothing (a
    /// prefetch never faults), so every answer stays the same, bitwise. The memories of a
    /// pile's pair list do not fit the L2 cache, and each served pair read three to five
    /// lines of its memory one after the other, each a miss that its code waited on: on
    /// the 2,048-cube pile (`perf`, 1 thread) the anchor's first read held 78% of
    /// `polyhedron_pair`'s samples and the header's and the levels' reads 75% of
    /// `EdgeMemory::deep_pairs`' (issue 23, edge39). A no-op off x86-64.
    #[inline(always)]
    pub fn prefetch(&self) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let start = (self as *const Self).cast::<i8>();
            for line in SERVED_LINES {
                // SAFETY: a prefetch is a hint that never faults nor reads into the
                // program's state; the address is inside `self` (every line of
                // `SERVED_LINES` is below `size_of::<EdgeMemory>() / 64`, see the test
                // `prefetched_lines_hold_what_the_served_paths_read`).
                unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(64 * line)) };
            }
        }
    }

    /// Whether this memory serves `a` and `b` at relative rotation `rot`.
    #[inline]
    pub(super) fn holds(&self, a: &ConvexPolyhedron, b: &ConvexPolyhedron, rot: Quat) -> bool {
        if self.shapes != [address(a), address(b)] || self.directions || !unit(rot) {
            return false;
        }
        let turned = (self.rot.conjugate() * rot).xyz().length();
        // (Written so that a NaN fails too.)
        2.0 * turned + ROUNDING < TURN
    }

    /// The memory of the sphere kind, if this is one recorded for a sphere against `p`.
    #[inline]
    pub(super) fn sphere(&self, p: &ConvexPolyhedron) -> Option<&SphereMemory> {
        (self.shapes == [address(p), SPHERE]).then_some(&self.sphere)
    }

    /// Keeps `record`, a sphere's memory against `p` (forgets what it held: nothing is kept
    /// when the record has no radius).
    #[inline]
    pub(super) fn record_sphere(&mut self, p: &ConvexPolyhedron, record: SphereMemory) {
        self.clear();
        if record.remembers() {
            self.shapes = [address(p), SPHERE];
            self.sphere = record;
        }
    }

    /// The record of the pair's remembered face contact's clip ([`FaceSlack`]): kept apart
    /// from the edge search's memory (it checks its own shapes and pose).
    #[inline]
    pub(super) fn face_slack(&mut self) -> &mut FaceSlack {
        &mut self.face
    }

    /// The pose of the pair's last full test that found a remembered contact ([`Anchor`]).
    #[inline]
    pub(super) fn anchor(&self) -> &Anchor {
        &self.anchor
    }

    /// Anchors the pair's remembered contact on a full test's pose ([`Anchor::NONE`]: none).
    #[inline]
    pub(super) fn set_anchor(&mut self, anchor: Anchor) {
        self.anchor = anchor;
    }

    /// The relative pose (B's rotation and offset in A's frame) of the pair's last full
    /// separating-axis test that found a remembered contact, if one is anchored: the pose
    /// its stored margin is measured from (for tests and statistics).
    pub fn anchored_pose(&self) -> Option<(Quat, Vec3)> {
        self.anchor.pose()
    }

    /// The anchored bound (the pair's `slack::Anchor`): how much any separation of the
    /// anchored full test can have changed with B at relative quaternion `q` and offset `t`
    /// in A's frame (infinite when none is anchored): for tests that hold it against brute
    /// force.
    pub fn anchored_motion(&self, q: Quat, t: Vec3) -> f32 {
        self.anchor.moved(q, t)
    }

    /// Whether it holds the pairs of a finished search (for tests and statistics).
    pub fn remembers(&self) -> bool {
        self.shapes != [0; 2]
    }

    /// Forgets what it holds.
    #[inline]
    pub(super) fn clear(&mut self) {
        self.shapes = [0; 2];
        self.len = 0;
    }

    /// Starts recording the search of `a` against `b` at `rot` and offset `t`; false when
    /// this pair of polyhedra cannot be remembered (too many edges to name in a byte, or
    /// not a unit rotation, or an offset that is not finite).
    pub(super) fn start(
        &mut self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        rot: Quat,
        t: Vec3,
    ) -> bool {
        self.clear();
        if a.edges.len() > 256 || b.edges.len() > 64 || !unit(rot) || !t.is_finite() {
            return false;
        }
        self.rot = rot;
        self.offset = t;
        self.directions = false;
        self.winner = NONE;
        self.levels = [0; LEVELS as usize];
        true
    }

    /// Notes, while recording, that pair `(ea, eb)`, the last recorded, is the best so far
    /// (a pair that is not the last recorded is not noted: the winner is then unknown).
    #[inline]
    pub(super) fn note_winner(&mut self, ea: usize, eb: usize) {
        let last = self.len.wrapping_sub(1);
        let named = self.pairs.get(last as usize) == Some(&[ea as u8, eb as u8]);
        self.winner = if self.len > 0 && named { last } else { NONE };
    }

    /// Records pair `(ea, eb)` unless the Gauss-map tests fail for it by more than [`TURN`]
    /// (`cba`, `dba`, `adc`, `bdc` as `edges::EdgeOfA::pair_axis` takes and computes
    /// them), with the level code `code()` (see `edges::EdgeOfA::depth_code`); false when
    /// the memory is full (the recording is then abandoned).
    #[inline]
    pub(super) fn record(
        &mut self,
        ea: usize,
        eb: usize,
        cba: f32,
        dba: f32,
        arcs: [f32; 2],
        code: impl FnOnce() -> u8,
    ) -> bool {
        let [adc, bdc] = arcs;
        let apart = |x: f32, y: f32| (x > TURN && y > TURN) || (x < -TURN && y < -TURN);
        // The first test fails for products of one strict sign, the second for `adc` and
        // `bdc` of one sign, or `cba` and `bdc` of opposite signs.
        if apart(cba, dba) || apart(adc, bdc) || apart(cba, -bdc) {
            return true;
        }
        let len = self.len as usize;
        if len == CAPACITY {
            self.clear();
            return false;
        }
        self.pairs[len] = [ea as u8, eb as u8];
        let code = code();
        if code != 0 {
            self.levels[code as usize - 1] |= 1 << len;
        }
        self.len += 1;
        true
    }

    /// Ends a recording of `a` against `b` that went through every edge pair.
    pub(super) fn finish(&mut self, a: &ConvexPolyhedron, b: &ConvexPolyhedron) {
        self.shapes = [address(a), address(b)];
        self.join_levels();
    }

    /// Turns the levels recorded per code into the sets of codes 1 to each (see `levels`):
    /// once per recording, instead of an OR of up to [`LEVELS`] sets per search served (the
    /// same sets: OR is exact).
    fn join_levels(&mut self) {
        for c in 1..LEVELS as usize {
            self.levels[c] |= self.levels[c - 1];
        }
    }

    /// The Gauss-map edge search over the remembered pairs alone (see [`EdgeMemory`]):
    /// the best edge axis, or `None` with the separating one in `hint` and `separation`;
    /// B at relative rotation `q` (`rot` its matrix) and offset `t` in A's frame.
    ///
    /// `floor` (not positive): the pairs remembered at a level that, with the most their
    /// separation can have grown since (see [`DeepPairs`]), stays at or below `floor` are
    /// left out. When the best axis is above `floor` it is returned exactly as the whole
    /// search returns it (every pair left out is at or below `floor`: it neither separates,
    /// nor wins, nor ties the winner); else some axis at or below `floor` is (or none,
    /// with separation `-inf`).
    ///
    /// **Winner first**: the pair that won the last search is evaluated first. When it
    /// passes the tests with a separation `s_w` above `floor` and not positive, the best
    /// separation is at least `s_w`, and the pairs whose level plus growth stays below `s_w`
    /// (those before the winner in the search's order) or at or below it (those after) are
    /// left out too: such a pair, if it passes the tests, has a separation below `s_w` (it
    /// neither separates nor wins, as the winner's is larger), or at most `s_w` and comes
    /// after the winner (the first of equals wins: it does not win a tie with the winner,
    /// nor with any pair of the same separation, which comes before it or is the winner).
    /// The winner itself is always visited, in its place, with the same result (the same
    /// function of the same inputs), so the search returns bitwise what it returns without
    /// this.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn search(
        &mut self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        (q, t): (Quat, Vec3),
        rot: Mat3,
        inv_rot: Mat3,
        bv: &[Vec3],
        floor: f32,
        hint: &mut SatHint,
        separation: &mut f32,
    ) -> Option<EdgeAxis> {
        let mut best_e = (f32::NEG_INFINITY, 0usize, 0usize, Vec3::ZERO);
        let mut best_at = NONE;
        let mut current = None;
        let grown = self.growth(a, b, q, t);
        let levels = GrownLevels::new(grown, a.radius + b.radius);
        let len = self.len as usize;
        // The pairs to visit, by index (those at no level always).
        let all = u128::MAX.checked_shr(128 - len as u32).unwrap_or(0);
        let top = levels.top(0, floor);
        let mut todo = all & !self.up_to(top);
        // The winner first (`first`: its index and answer), if it is visited: then the
        // pairs before it at levels whose growth stays below its separation, and those
        // after it at levels whose growth stays at or below it, are not.
        let mut first = (usize::MAX, None);
        let w = self.winner as usize;
        if w < len && (todo >> w) & 1 != 0 {
            let [ea, eb] = self.pairs[w];
            let (ea, eb) = (ea as usize, eb as usize);
            let side = (EdgeOfA::new(a, ea), inv_rot * a.edge_arcs[ea]);
            current = Some((ea, side.0, side.1));
            let found = evaluate(b, rot, bv, side, eb);
            if let Some((s, _)) = found {
                // (Written so that a NaN does not serve.)
                if s <= 0.0 && s > floor {
                    let early = (1u128 << w) - 1;
                    let late = all & !early & !(1u128 << w);
                    // (`floor` <= `s.next_down()` <= `s`: the tops rise in turn.)
                    let below = levels.top(top, s.next_down());
                    let (before, after) = (self.up_to(below), self.up_to(levels.top(below, s)));
                    todo &= !((before & early) | (after & late));
                    first = (w, found);
                }
            }
        }
        // In increasing order, as the whole search.
        while todo != 0 {
            let i = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            let [ea, eb] = self.pairs[i];
            let (ea, eb) = (ea as usize, eb as usize);
            let found = if i == first.0 {
                first.1
            } else {
                let side = match current {
                    Some((e, side_a, arc)) if e == ea => (side_a, arc),
                    _ => {
                        let next = (EdgeOfA::new(a, ea), inv_rot * a.edge_arcs[ea]);
                        current = Some((ea, next.0, next.1));
                        next
                    }
                };
                evaluate(b, rot, bv, side, eb)
            };
            let Some((s, axis)) = found else {
                continue;
            };
            if s > 0.0 {
                separating_pair(ea, eb, s, hint, separation);
                return None;
            }
            if s > best_e.0 {
                best_e = (s, ea, eb, axis);
                best_at = i as u8;
            }
        }
        self.winner = best_at;
        Some(best_e)
    }
}

/// Edge `eb` of B against the edge of A in `side` (its [`EdgeOfA`] and its arc in B's
/// frame), through the Gauss-map tests: [`EdgeOfA::pair_axis`] from the products of the
/// whole search's rows (`-(n . arc)` summed in `dot`'s order) and of its rotated arcs of
/// B (`rot` B's rotation in A's frame, `bv` B's vertices there).
#[inline(always)]
fn evaluate(
    b: &ConvexPolyhedron,
    rot: Mat3,
    bv: &[Vec3],
    (side_a, arc): (EdgeOfA, Vec3),
    eb: usize,
) -> Option<(f32, Vec3)> {
    let [fb0, fb1] = b.edge_faces[eb];
    let product = |f: u32| {
        let n = b.faces[f as usize].normal;
        -(n.x * arc.x + n.y * arc.y + n.z * arc.z)
    };
    let arc_b = rot * b.edge_arcs[eb];
    side_a.pair_axis(b, bv, eb, product(fb0), product(fb1), arc_b)
}

/// What a search by direction takes of a memory that serves it
/// ([`EdgeMemory::deep_pairs`]).
pub(super) struct Served {
    /// The direction pairs that may be left out below the search's floor (a bit per pair).
    pub(super) skip: u128,
    /// The highest level code left out below the floor ([`DeepPairs::top`]).
    pub(super) top: u8,
    /// The levels grown by the most a remembered pair's separation can have grown since
    /// the recording.
    pub(super) levels: GrownLevels,
    /// The direction pair that won the last search (128 or more: none).
    pub(super) winner: usize,
}

/// How many depth levels a direction pair can be remembered at (see [`DeepPairs`]): level
/// `c` (1 to `LEVELS`) is `-(r_a + r_b) 2^-(c + 1)`, from a quarter of the radii's sum
/// down to about `2.4e-4` of it (shallower levels are never left out: the rounding allowed
/// for, `1e-4` of the bodies' reach, is already of that size).
const LEVELS: u8 = 11;

/// The direction pairs of `edges::edge_axes_by_direction` that can be left out of a search:
/// each direction pair found at some depth (its separation, or an upper bound of it from
/// some of the points, at most a level of [`LEVELS`]) is remembered with the shallowest
/// level it is below, and left out of later searches while that level plus the most its
/// separation can have grown since stays at or below the search's floor. A pair left out
/// then has a separation at or below the floor, which the search may leave out anyway (it
/// neither separates nor changes a best axis above the floor).
///
/// The bound: a direction pair's separation is `sigma(u) = min_B(u) - max_A(u)` (or the
/// same along `-u`, whichever is larger) on the unit axis `u` along `ua x (R ub)`. With the
/// vertices within `L = r_a + r_b + |t|` of A's centre, `sigma` moves by at most `L |du|`
/// as the axis turns, and by at most the vertices' motion, `c r_b + |dt|`, as B moves in
/// A's frame (`c = 2 sin(phi / 2)` for the angle `phi` turned, `dt` the offset's change).
/// Only pairs with `|ua x wb| >= 0.19` at the recorded search are remembered, so the axis
/// turns by at most `2 |d(ua x wb)| / 0.19 <= 11 c` (with `c` taken `4e-5` larger for the
/// rotation matrices' rounding). Rounding of the separations (B's points rotated by those
/// matrices, dot products of points within `L` of the origin with a unit axis, at both
/// searches) is allowed as `1e-4 L`, several times more than it can be.
///
/// The Gauss-map memory's edge pairs get levels by the same bound. Edge pair `(ea, eb)`'s
/// separation, when it passes the Gauss-map tests, is `f = n . (pb0 - pa0)` with `n` the
/// unit axis along `da x (R db)` turned to point away from A's centre (`n . pa0 >= 0`),
/// `pa0` A's first vertex and `pb0 = R vb0 + t` B's. Only pairs whose unit edge directions
/// have `|ua x wb| >= 0.2` (so `n` turns by at most `11 c`) and whose axis is at least
/// `r_a / 8` from A's centre (`|n . pa0| >= r_a / 8`) get a level: while the memory serves
/// (`c < TURN`), `n . pa0` moves by at most `11.1 c r_a < r_a / 8`, so the axis keeps its
/// turn, and `f` moves by at most `|dn| |pb0 - pa0| + |d pb0| <= 11 c L + c r_b + |dt|`,
/// the bound above. A pair at a level that cannot rise above the floor would have a
/// separation at or below it if it passed the tests: the search may leave it out.
pub(super) struct DeepPairs;

impl DeepPairs {
    /// Level `code` (1 to [`LEVELS`]) for bodies whose radii sum to `r`: `-r 2^-(code +
    /// 1)`, exact in floats (a power of two times `r`).
    #[inline]
    fn level(code: u8, r: f32) -> f32 {
        -(r * f32::from_bits((126 - code as u32) << 23))
    }

    /// The level code of a direction pair whose separation is at most `s` (the computed
    /// separation, or an upper bound of it from some of the points), for bodies whose
    /// radii sum to `r`: the shallowest level at or above `s`, or 0 (not remembered) when
    /// `s` is above every level (or NaN).
    ///
    /// Found by bisection: with `r` not negative (a sum of radii) the levels do not fall
    /// as the code rises (`r` times a falling power of two, rounded monotonically), so
    /// "level `c` is at or above `s`" holds for the codes from some `c0` up to
    /// [`LEVELS`] and for no other: the answer is that `c0`, the first code that passes,
    /// as when the codes are tested one by one from [`LEVELS`] down until one fails (kept
    /// as the test's oracle, `code_by_steps`). A NaN `s` or `r` passes no test: 0.
    #[inline]
    pub(super) fn code(s: f32, r: f32) -> u8 {
        let passes = |c: u8| Self::level(c, r) >= s;
        if !passes(LEVELS) {
            return 0;
        }
        // `hi` passes; `lo` is 0 or fails.
        let (mut lo, mut hi) = (0u8, LEVELS);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if passes(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }

    /// [`DeepPairs::code`] by testing the codes one by one from [`LEVELS`] down (the
    /// search's rule before the bisection; the tests' oracle).
    #[cfg(test)]
    pub(super) fn code_by_steps(s: f32, r: f32) -> u8 {
        // Deeper pairs meet the first levels' tests (written so that a NaN gets 0).
        let mut code = 0;
        for c in (1..=LEVELS).rev() {
            if Self::level(c, r) >= s {
                code = c;
            } else {
                break;
            }
        }
        code
    }

    /// Whether the pair's axis is far enough from parallel edges to be remembered
    /// (`len2 = |ua x wb|^2`).
    #[inline]
    pub(super) fn rememberable(len2: f32) -> bool {
        len2 >= 0.04
    }

    /// The highest level code whose pairs may be left out of a search with floor `floor`
    /// for bodies whose radii sum to `r`, their separations grown by at most `grown` since
    /// the recording (`EdgeMemory::growth`): codes 1 to this have levels that, grown, stay
    /// at or below `floor` (0: none).
    ///
    /// `from`: a code known to qualify (0, or this function's answer for a lower floor):
    /// the levels rise with the code, and so do they grown (rounding is monotonic), so the
    /// codes that qualify are 1 to some top, and the count starts at `from`.
    ///
    /// The searches take it from [`GrownLevels::top`] (the same answer for every input,
    /// four levels at a time); this, the rule it replaced, is the tests' oracle.
    #[cfg(test)]
    pub(super) fn top(from: u8, grown: f32, r: f32, floor: f32) -> u8 {
        // The deepest levels that still reach no higher than the floor: codes 1 to `top`
        // (levels rise with the code). (Written so that a NaN serves nothing.)
        let mut top = from;
        while top < LEVELS && Self::level(top + 1, r) + grown <= floor {
            top += 1;
        }
        top
    }

    /// Whether a Gauss-map edge pair's axis is far enough from A's centre to keep its turn
    /// while the memory serves (`h = n . pa0`, `r_a` A's radius; see above).
    #[inline]
    pub(super) fn keeps_turn(h: f32, r_a: f32) -> bool {
        h.abs() >= 0.125 * r_a
    }
}

/// The levels of codes 1 to [`LEVELS`] grown by the most a remembered pair's separation
/// can have grown (`DeepPairs::level(c, r) + grown`, lane `c - 1`; the twelfth lane a NaN,
/// which is at or below no floor), made once per search, so that each [`GrownLevels::top`]
/// is a comparison of the twelve lanes with its floor instead of a loop over the codes.
#[derive(Clone, Copy, Debug)]
pub(super) struct GrownLevels([Vec4; 3]);

impl GrownLevels {
    /// The powers of two of the levels, `2^-(c + 1)` for codes 1 to [`LEVELS`] (the
    /// factors of `DeepPairs::level`, exact), then a NaN.
    const POWERS: [Vec4; 3] = {
        // `DeepPairs::level`'s factor of code `c`.
        const fn p(c: u32) -> f32 {
            f32::from_bits((126 - c) << 23)
        }
        [
            Vec4::new(p(1), p(2), p(3), p(4)),
            Vec4::new(p(5), p(6), p(7), p(8)),
            Vec4::new(p(9), p(10), p(11), f32::NAN),
        ]
    };

    /// The levels for bodies whose radii sum to `r`, grown by `grown`: per lane `-(r *
    /// 2^-(c + 1)) + grown`, the products, negations and sums of `DeepPairs::level(c, r) +
    /// grown`, so the same floats (a lane of `mulps`, `xorps`, `addps` is the IEEE
    /// operation of the scalar one).
    #[inline(always)]
    pub(super) fn new(grown: f32, r: f32) -> Self {
        let (r, grown) = (Vec4::splat(r), Vec4::splat(grown));
        Self(Self::POWERS.map(|p| -(r * p) + grown))
    }

    /// [`DeepPairs::top`] for these levels (its `grown` and `r`): from `from`, the codes
    /// counted up while the next code's grown level is at or below `floor`. Bit `c - 1` of
    /// `passes` is code `c`'s test (`<=`, false for a NaN, as the loop's; the twelfth lane
    /// never passes), so the loop's count from `from` is `from` plus the run of passing
    /// codes from `from + 1` up: the trailing ones of `passes >> from`. The same answer as
    /// the loop for every input (no use of the levels' order), not only the ones that rise.
    #[inline(always)]
    pub(super) fn top(&self, from: u8, floor: f32) -> u8 {
        if from >= LEVELS {
            return from;
        }
        let floor = Vec4::splat(floor);
        let [l0, l1, l2] = self.0;
        let passes = l0.cmple(floor).bitmask()
            | (l1.cmple(floor).bitmask() << 4)
            | (l2.cmple(floor).bitmask() << 8);
        from + (passes >> from).trailing_ones() as u8
    }
}

impl EdgeMemory {
    /// What a search of `a` against `b` by direction, at relative rotation `rot` and offset
    /// `t` with floor `floor`, may take of this memory (see [`DeepPairs`]): `None` when it
    /// serves no pair (the search then records anew). (Recording anew once fewer than half
    /// the remembered pairs were served cost more instructions on the settled cube and
    /// mixed piles than serving them to the last.)
    pub(super) fn deep_pairs(
        &self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        rot: Quat,
        t: Vec3,
        floor: f32,
    ) -> Option<Served> {
        if self.shapes != [address(a), address(b)] || !self.directions || !unit(rot) {
            return None;
        }
        let grown = self.growth(a, b, rot, t);
        let levels = GrownLevels::new(grown, a.radius + b.radius);
        let top = levels.top(0, floor);
        let skip = self.up_to(top);
        (skip != 0).then_some(Served {
            skip,
            top,
            levels,
            winner: self.winner as usize,
        })
    }

    /// The pairs at levels 1 to `top` (none when `top` is 0) of a finished recording (see
    /// `levels`: joined when it ended).
    #[inline]
    pub(super) fn up_to(&self, top: u8) -> u128 {
        let top = (top as usize).min(LEVELS as usize);
        if top == 0 { 0 } else { self.levels[top - 1] }
    }

    /// Notes direction pair `k` (below 128) as the winner of a search by direction.
    #[inline]
    pub(super) fn note_direction_winner(&mut self, k: usize) {
        self.winner = if k < 128 { k as u8 } else { NONE };
    }

    /// The most a remembered pair's separation can have grown since the recording (see
    /// [`DeepPairs`]) for `a` against `b` at relative rotation `rot` (a unit rotation: the
    /// callers check it) and offset `t`.
    #[inline]
    fn growth(&self, a: &ConvexPolyhedron, b: &ConvexPolyhedron, rot: Quat, t: Vec3) -> f32 {
        let c = 2.0 * (self.rot.conjugate() * rot).xyz().length() + 4e-5;
        let moved = (t - self.offset).length();
        let lever = a.radius + b.radius + t.length() + moved;
        let turned = 11.0 * c + 4e-5;
        (lever * turned + c * b.radius + moved + 1e-4 * lever) * 1.01
    }

    /// Starts recording a search by direction of `a` against `b` at `rot` and offset `t`;
    /// false when it cannot be remembered (more than 128 direction pairs, or not a unit
    /// rotation).
    pub(super) fn start_directions(
        &mut self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        rot: Quat,
        t: Vec3,
    ) -> bool {
        self.clear();
        if a.edge_dirs.len() * b.edge_dirs.len() > 128 || !unit(rot) || !t.is_finite() {
            return false;
        }
        (self.rot, self.offset, self.directions, self.winner) = (rot, t, true, NONE);
        // No pair at any level yet.
        self.levels = [0; LEVELS as usize];
        true
    }

    /// Records direction pair `k` (`ia * (B's directions) + ib`, below 128) at level
    /// `code` ([`DeepPairs::code`], not 0).
    #[inline]
    pub(super) fn record_depth(&mut self, k: usize, code: u8) {
        self.levels[code as usize - 1] |= 1 << k;
    }

    /// Ends a recording by direction that went through every direction pair.
    pub(super) fn finish_directions(&mut self, a: &ConvexPolyhedron, b: &ConvexPolyhedron) {
        self.shapes = [address(a), address(b)];
        self.join_levels();
    }
}

#[cfg(test)]
#[path = "memory_tests.rs"]
mod tests;

//! The edge-edge axes of the separating-axis test, by Gauss-map pruning or by edge direction.

use glam::{Quat, Vec3, Vec4};

use super::lanes::{Extent, SoaPoints};
use super::memory::{DeepPairs, EdgeMemory, Served, TURN};
use super::sat::EdgeAxis;
use super::{HINT_EDGE, SatHint};
use crate::ConvexPolyhedron;

/// Per-thread buffers of [`edge_axes_gauss_map`] and [`edge_axes_by_direction`] (no
/// allocation or zeroing per pair).
#[derive(Default)]
pub(super) struct GaussTables {
    /// B's face normals (in B's frame), 4 faces per entry: x, y, z lanes (the padding lanes
    /// are zero).
    normals_b: Vec<[Vec4; 3]>,
    /// For the current edge `ea` of A: the product of each face `kb` of B's normal (negated)
    /// with A's arc `ea`, 4 faces per entry (the padding lanes unused) ...
    row: Vec<Vec4>,
    /// ... and the same, one per face (`row_f[kb]`).
    row_f: Vec<f32>,
    /// B's edge arcs rotated into A's frame.
    arcs_b: Vec<Vec3>,
    /// B's edge directions rotated into A's frame (by direction).
    dirs_b: Vec<Vec3>,
}

/// Edge axes by enumerating edge pairs that pass the Gauss-map test (good for many edges).
///
/// `floor` (not positive): as for [`edge_axes_by_direction`], axes whose separation is at
/// most `floor` may be left out (by a memory that serves, see [`EdgeMemory::search`]); an
/// axis above it is found as without it.
#[allow(clippy::too_many_arguments)]
pub(super) fn edge_axes_gauss_map(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rot: glam::Mat3,
    inv_rot: glam::Mat3,
    bv: &[Vec3],
    floor: f32,
    tables: &mut GaussTables,
    memory: Option<(&mut EdgeMemory, Quat, Vec3)>,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<EdgeAxis> {
    // A memory that holds at this rotation: its pairs alone, less those that cannot rise
    // above the floor (the same answer above it, see `EdgeMemory`); one that does not
    // records this search.
    let mut memory = match memory {
        Some((m, q, t)) if m.holds(a, b, q) => {
            let pose = (q, t);
            return m.search(a, b, pose, rot, inv_rot, bv, floor, hint, separation);
        }
        Some((m, q, t)) => m.start(a, b, q, t).then_some(m),
        None => None,
    };
    let radii = a.radius + b.radius;
    // Edge-edge axes that are faces of the Minkowski difference (Gauss-map pruning: the arcs
    // of edge `ea` of A and of edge `eb` of -B must cross). The products of B's normals with
    // A's arc `ea` are taken a row at a time, 4 faces at once (each row is read whole);
    // those of A's normals with B's arcs per pair, from B's arcs rotated once, for the few
    // pairs that pass the first test. The same products as one at a time, so the same bits.
    let nfb = b.faces.len();
    let neb = b.edges.len();
    let GaussTables {
        normals_b,
        row,
        row_f,
        arcs_b,
        ..
    } = tables;
    normals_b.clear();
    normals_b.extend(b.faces.chunks(4).map(|fs| {
        let lane = |c: fn(Vec3) -> f32| {
            Vec4::from_array([0, 1, 2, 3].map(|k| fs.get(k).map_or(0.0, |f| c(f.normal))))
        };
        [lane(|n| n.x), lane(|n| n.y), lane(|n| n.z)]
    }));
    row.resize(normals_b.len(), Vec4::ZERO);
    row_f.resize(4 * normals_b.len(), 0.0);
    // B's arcs in A's frame: `na_ka . arcs_b[eb]` is the second test's product.
    arcs_b.clear();
    arcs_b.extend(b.edge_arcs.iter().map(|arc| rot * *arc));
    let arcs_b: &[Vec3] = arcs_b;
    // B's edges by face, as bit sets (when B has at most 64 edges and faces).
    let mut by_face = [0u64; 64];
    let use_bits = neb <= 64 && nfb <= 64;
    if !use_bits {
        memory = None;
    }
    if use_bits {
        for (eb, &[fb0, fb1]) in b.edge_faces.iter().enumerate() {
            by_face[fb0 as usize] |= 1 << eb;
            by_face[fb1 as usize] |= 1 << eb;
        }
    }
    let mut best_e = (f32::NEG_INFINITY, 0usize, 0usize, Vec3::ZERO);
    for ea in 0..a.edges.len() {
        let side_a = EdgeOfA::new(a, ea);
        // (-nb_kb) . arcA_ea, with A's arc rotated into B's frame, 4 faces at a time: the
        // products and sums of `Vec3::dot` in its order, so the same bits.
        let arc = inv_rot * a.edge_arcs[ea];
        let (ax, ay, az) = (Vec4::splat(arc.x), Vec4::splat(arc.y), Vec4::splat(arc.z));
        let lanes = normals_b.iter().zip(row.iter_mut());
        for (([nx, ny, nz], r), rf) in lanes.zip(row_f.chunks_exact_mut(4)) {
            *r = -(*nx * ax + *ny * ay + *nz * az);
            r.write_to_slice(rf);
        }
        let (row4, row1): (&[Vec4], &[f32]) = (row, row_f);
        // Only the edges that may cross, in increasing order (the same edges meet the
        // tests below in the same order).
        let visit = match (&memory, use_bits) {
            // Recording: the edges that may cross at any rotation the memory will serve
            // (a superset of those below, so the same ones pass the tests).
            (Some(_), _) => EdgeSet::Bits(lasting_candidates(row4, nfb, neb, &by_face)),
            (None, true) => EdgeSet::Bits(crossing_candidates(row4, nfb, &by_face)),
            (None, false) => EdgeSet::All(0..neb),
        };
        for eb in visit {
            let [fb0, fb1] = b.edge_faces[eb];
            let (cba, dba) = (row1[fb0 as usize], row1[fb1 as usize]);
            if let Some(m) = memory.as_deref_mut() {
                let arcs = [side_a.na0.dot(arcs_b[eb]), side_a.na1.dot(arcs_b[eb])];
                let code = || side_a.depth_code(b, bv, eb, a.radius, radii);
                if !m.record(ea, eb, cba, dba, arcs, code) {
                    memory = None;
                }
            }
            let Some((s, axis)) = side_a.pair_axis(b, bv, eb, cba, dba, arcs_b[eb]) else {
                continue;
            };
            if s > 0.0 {
                if let Some(m) = memory {
                    m.clear();
                }
                separating_pair(ea, eb, s, hint, separation);
                return None;
            }
            if s > best_e.0 {
                best_e = (s, ea, eb, axis);
                if let Some(m) = memory.as_deref_mut() {
                    m.note_winner(ea, eb);
                }
            }
        }
    }
    if let Some(m) = memory {
        m.finish(a, b);
    }
    Some(best_e)
}

/// The edges of B (at most 64, bits of `by_face`'s sets; `neb` of them) that are not in
/// two faces whose products `row` (see [`crossing_candidates`]) are both above
/// [`TURN`] or both below `-TURN`: a superset of [`crossing_candidates`]' edges, and the
/// edges that [`EdgeMemory::record`] would not leave out for their faces' signs.
fn lasting_candidates(row: &[Vec4], nfb: usize, neb: usize, by_face: &[u64; 64]) -> u64 {
    let (mut plus, mut minus) = (0u64, 0u64);
    let (hi, lo) = (Vec4::splat(TURN), Vec4::splat(-TURN));
    for (c, v) in row.iter().enumerate().take(16) {
        plus |= (v.cmpgt(hi).bitmask() as u64) << (4 * c);
        minus |= (v.cmplt(lo).bitmask() as u64) << (4 * c);
    }
    let mask = |n: usize| if n >= 64 { u64::MAX } else { (1u64 << n) - 1 };
    let (plus, minus) = (plus & mask(nfb), minus & mask(nfb));
    // Edges with both faces in `faces`: in some face of the set, and not in exactly one.
    let both = |mut faces: u64| {
        let (mut any, mut odd) = (0u64, 0u64);
        while faces != 0 {
            let edges = by_face[faces.trailing_zeros() as usize];
            (any, odd) = (any | edges, odd ^ edges);
            faces &= faces - 1;
        }
        any & !odd
    };
    mask(neb) & !(both(plus) | both(minus))
}

/// Records direction pair `k` in a recording memory at the level of its separation bound
/// `s` (see [`DeepPairs`]), if it is deep enough for one; `radii`: the bodies' radii summed.
#[inline]
fn remember_depth(memory: Option<&mut EdgeMemory>, k: usize, s: f32, radii: f32) {
    if let Some(m) = memory {
        let code = DeepPairs::code(s, radii);
        if code != 0 {
            m.record_depth(k, code);
        }
    }
}

/// Records edge pair `(ea, eb)` as the separating axis found, with separation `s`.
#[inline]
pub(super) fn separating_pair(
    ea: usize,
    eb: usize,
    s: f32,
    hint: &mut SatHint,
    separation: &mut f32,
) {
    if ea < 0x8000 && eb < 0x8000 {
        *hint = HINT_EDGE | ((ea as u32) << 15) | eb as u32;
    }
    *separation = s;
}

/// What the Gauss-map search takes of the current edge of A (in A's frame): its faces'
/// normals, its first vertex and its direction.
#[derive(Clone, Copy)]
pub(super) struct EdgeOfA {
    pub(super) na0: Vec3,
    pub(super) na1: Vec3,
    pub(super) pa0: Vec3,
    pub(super) da: Vec3,
}

impl EdgeOfA {
    /// Edge `ea` of `a`.
    #[inline(always)]
    pub(super) fn new(a: &ConvexPolyhedron, ea: usize) -> Self {
        let [a0, a1] = a.edges[ea];
        let [fa0, fa1] = a.edge_faces[ea];
        let pa0 = a.vertices[a0 as usize];
        EdgeOfA {
            na0: a.faces[fa0 as usize].normal,
            na1: a.faces[fa1 as usize].normal,
            pa0,
            da: a.vertices[a1 as usize] - pa0,
        }
    }

    /// The level code of this edge's pair with edge `eb` of B (`bv`: B's vertices in A's
    /// frame; `r_a` A's radius, `radii` the bodies' radii summed): the level of the pair's
    /// separation along its axis turned as [`EdgeOfA::pair_axis`] turns it, whether or not
    /// it passes the Gauss-map tests now, or 0 when the pair may not be left out (near
    /// parallel edges, or an axis near A's centre; see [`DeepPairs`]).
    #[inline]
    fn depth_code(&self, b: &ConvexPolyhedron, bv: &[Vec3], eb: usize, r_a: f32, radii: f32) -> u8 {
        let [b0, b1] = b.edges[eb];
        let pb0 = bv[b0 as usize];
        let db = bv[b1 as usize] - pb0;
        let axis = self.da.cross(db);
        let len2 = axis.length_squared();
        let norms = self.da.length_squared() * db.length_squared();
        // (Written so that a NaN is not remembered.)
        if !(norms > 0.0 && DeepPairs::rememberable(len2 / norms)) {
            return 0;
        }
        let axis = axis / len2.sqrt();
        let h = axis.dot(self.pa0);
        if !DeepPairs::keeps_turn(h, r_a) {
            return 0;
        }
        let axis = if h < 0.0 { -axis } else { axis };
        DeepPairs::code(axis.dot(pb0 - self.pa0), radii)
    }

    /// The Gauss-map tests of this edge against edge `eb` of B (`bv`: B's vertices in A's
    /// frame), from the products `cba`, `dba` of B's two faces' normals (negated) with A's
    /// arc and B's arc `arc_b` in A's frame; for a pair that passes them and is not
    /// near-parallel, its separation and axis (pointing away from A's centre). Every path
    /// of the search goes through here, so the same inputs give the same bits.
    #[inline(always)]
    pub(super) fn pair_axis(
        &self,
        b: &ConvexPolyhedron,
        bv: &[Vec3],
        eb: usize,
        cba: f32,
        dba: f32,
        arc_b: Vec3,
    ) -> Option<(f32, Vec3)> {
        let EdgeOfA { na0, na1, pa0, da } = *self;
        if cba * dba >= 0.0 {
            return None;
        }
        let adc = na0.dot(arc_b);
        let bdc = na1.dot(arc_b);
        if adc * bdc >= 0.0 || cba * bdc <= 0.0 {
            return None;
        }
        let [b0, b1] = b.edges[eb];
        let pb0 = bv[b0 as usize];
        let db = bv[b1 as usize] - pb0;
        let axis = da.cross(db);
        let len2 = axis.length_squared();
        if len2 < 1e-10 * da.length_squared() * db.length_squared() {
            return None;
        }
        let mut axis = axis / len2.sqrt();
        if axis.dot(pa0) < 0.0 {
            axis = -axis;
        }
        Some((axis.dot(pb0 - pa0), axis))
    }
}

/// Edges of B to visit, in increasing order: a bit set, or all of them.
enum EdgeSet {
    Bits(u64),
    All(std::ops::Range<usize>),
}

impl Iterator for EdgeSet {
    type Item = usize;

    #[inline]
    fn next(&mut self) -> Option<usize> {
        match self {
            EdgeSet::Bits(bits) => {
                if *bits == 0 {
                    return None;
                }
                let e = bits.trailing_zeros() as usize;
                *bits &= *bits - 1;
                Some(e)
            }
            EdgeSet::All(range) => range.next(),
        }
    }
}

/// The edges of B (bits of `by_face`'s sets) whose two faces' products `row` (one per face
/// of B, 4 per entry, `nfb` of them, at most 64) may have a negative product: one face's
/// strictly positive and the other's strictly negative (the edges in exactly one positive
/// face and exactly one negative face), or either neither (zero or NaN). Every edge left out
/// has `row[fb0] * row[fb1] >= 0` (the same strict signs give a positive product or a zero
/// one), so it fails the Gauss-map test anyway.
fn crossing_candidates(row: &[Vec4], nfb: usize, by_face: &[u64; 64]) -> u64 {
    // The faces by sign, as bit sets (4 at a time), then their edges.
    let (mut plus, mut minus) = (0u64, 0u64);
    for (c, v) in row.iter().enumerate().take(16) {
        plus |= (v.cmpgt(Vec4::ZERO).bitmask() as u64) << (4 * c);
        minus |= (v.cmplt(Vec4::ZERO).bitmask() as u64) << (4 * c);
    }
    let all = if nfb >= 64 {
        u64::MAX
    } else {
        (1u64 << nfb) - 1
    };
    let (plus, minus) = (plus & all, minus & all);
    let edges_of = |mut faces: u64, join: fn(u64, u64) -> u64| {
        let mut edges = 0u64;
        while faces != 0 {
            edges = join(edges, by_face[faces.trailing_zeros() as usize]);
            faces &= faces - 1;
        }
        edges
    };
    let xor = |x: u64, y: u64| x ^ y;
    let or = |x: u64, y: u64| x | y;
    (edges_of(plus, xor) & edges_of(minus, xor)) | edges_of(all & !(plus | minus), or)
}

/// Direction pair `ua`, `wb` (unit directions of A's and B's edges in A's frame) as
/// [`edge_axes_by_direction`] evaluates it when it does not leave it out: its separation
/// (the larger of B pushed along the axis and against it) and that axis, or `None` for
/// near-parallel directions. The same arithmetic in the same order, so the same bits (keep
/// the two in step).
#[inline]
pub(super) fn direction_pair(
    ua: Vec3,
    wb: Vec3,
    a_local: &SoaPoints,
    b_soa: &SoaPoints,
) -> Option<(f32, Vec3)> {
    let axis = ua.cross(wb);
    let len2 = axis.length_squared();
    if len2 < 1e-10 {
        return None;
    }
    let axis = axis / len2.sqrt();
    let (mut ext_a, mut ext_b) = (a_local.head(axis), b_soa.head(axis));
    a_local.tail(axis, &mut ext_a);
    b_soa.tail(axis, &mut ext_b);
    let [min_a, max_a, min_b, max_b] = Extent::bounds(&ext_a, &ext_b);
    Some(if min_b - max_a >= min_a - max_b {
        (min_b - max_a, axis)
    } else {
        (min_a - max_b, -axis)
    })
}

/// `inner_a + inner_b` (the bodies' inner radii, see `ConvexPolyhedron::inner_radius`) less
/// `2e-5 * radii`, the rounding allowance of [`reach_bound`], or minus infinity when that
/// is not positive or either radius is unknown (minus infinity: then no bound leaves an
/// axis out).
#[inline]
pub(super) fn reach_depth(a: &ConvexPolyhedron, b: &ConvexPolyhedron, radii: f32) -> f32 {
    let deep = (a.inner_radius() + b.inner_radius()) - 2e-5 * radii;
    if deep > 0.0 { deep } else { f32::NEG_INFINITY }
}

/// An upper bound of the separation that [`direction_pair`] computes along unit `axis`
/// (either sign), B's centre at `t` in A's frame and `deep` from [`reach_depth`]:
/// `|axis . t| - deep`.
///
/// Why: each body reaches at least its inner radius along any direction from its centre,
/// so B's smallest projection is at most `axis . t - inner_b` and A's largest at least
/// `inner_a` (and likewise against the axis): both separations are at most `|axis . t| -
/// inner_a - inner_b` exactly. The computed extents (B's points transformed, then
/// projected) and this bound's own dot product and subtraction are off by a few ulps of
/// `radii` (`|t| < radii` for a pair the bounding spheres let through), far below the
/// `2e-5 * radii` that `deep` keeps back: the computed separation is at most the computed
/// bound.
#[inline]
pub(super) fn reach_bound(axis: Vec3, t: Vec3, deep: f32) -> f32 {
    axis.dot(t).abs() - deep
}

/// Edge axes by enumerating pairs of unique edge directions and projecting both bodies
/// (good for boxes: 3 x 3 axes). Any axis is a valid separating-axis candidate, and the
/// Minkowski-face normals are among these, so the smallest overlap is still the exact one.
///
/// `floor` (not positive): axes whose separation is at most `floor` may be skipped (the
/// caller ignores a best axis not above it); an axis above it is found as without it.
#[allow(clippy::too_many_arguments)]
pub(super) fn edge_axes_by_direction(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rot: glam::Mat3,
    t: Vec3,
    a_local: &SoaPoints,
    b_soa: &SoaPoints,
    bv: &[Vec3],
    floor: f32,
    tables: &mut GaussTables,
    memory: Option<(&mut EdgeMemory, Quat, Vec3)>,
    hint: &mut SatHint,
    separation: &mut f32,
) -> Option<EdgeAxis> {
    let mut best = (f32::NEG_INFINITY, 0usize, 0usize, Vec3::ZERO);
    let (radii, ndb) = (a.radius + b.radius, b.edge_dirs.len());
    // The pairs a memory found deep, left out while they cannot reach the floor (see
    // `DeepPairs`); a memory that serves none records this search. One that serves
    // evaluates the last search's winner first and, when it passes, leaves out more: the
    // pairs whose level, grown, stays below its separation (before it in this order) or
    // at or below it (after it), and before it the pairs whose first points already
    // bound them below it (the proof of `EdgeMemory::search`, the same here).
    let (mut skip, mut record, mut served) = (0, None, None);
    let mut first = (usize::MAX, None, f32::NEG_INFINITY);
    if let Some((m, q, t)) = memory {
        match m.deep_pairs(a, b, q, t, floor) {
            None => record = m.start_directions(a, b, q, t).then_some(&mut *m),
            Some(Served {
                skip: deep,
                top,
                levels,
                winner,
            }) => {
                skip = deep;
                let pair = |k: usize| {
                    let (ia, ib) = (k / ndb.max(1), k % ndb.max(1));
                    let (ua, ub) = (a.edge_dirs.get(ia)?, b.edge_dirs.get(ib)?);
                    direction_pair(*ua, rot * *ub, a_local, b_soa)
                };
                let found = if winner < a.edge_dirs.len() * ndb && (skip >> winner) & 1 == 0 {
                    pair(winner)
                } else {
                    None
                };
                if let Some((s, _)) = found {
                    // (Written so that a NaN does not serve.)
                    if s <= 0.0 && s > floor {
                        // (`floor` <= `s.next_down()` <= `s`: the tops rise in turn.)
                        let below = levels.top(top, s.next_down());
                        let after = levels.top(below, s);
                        // Bits of the pairs before the winner, and after it.
                        let early = (1u128 << winner) - 1;
                        let late = !early & !(1u128 << winner);
                        skip |= (m.up_to(below) & early) | (m.up_to(after) & late);
                        first = (winner, found, s.next_down());
                    }
                }
                served = Some(m);
            }
        }
    }
    // The winner alone: when every other pair is left out, the loop below would visit the
    // winner only and take its answer, `first.1` (its separation is above `floor`, so
    // above the loop's starting minus infinity), and the memory's winner would stay the
    // same pair: the same answer without the loop (issue 23, edge37).
    if let Some((s, axis)) = first.1
        && winner_alone(skip, first.0, a.edge_dirs.len() * ndb)
    {
        #[cfg(test)]
        tests::ALONE.with(|n| n.set(n.get() + 1));
        let (ia, ib) = (first.0 / ndb, first.0 % ndb);
        let (ea, eb) = supporting_edges(a, b, bv, ia, ib, axis);
        return Some((s, ea, eb, axis));
    }
    // How far both bodies reach at least along any axis from their centres (A's origin and
    // B's at `t`), less the rounding of the extents (see `reach_bound`); not positive
    // (degenerate shapes): no axis is left out by it.
    let deep = reach_depth(a, b, radii);
    // B's directions in A's frame: rotated once, into the table, when every pair may be
    // visited (no memory serves); when one serves, few are, and each visit rotates its own
    // (about 2.4 of a cube pair's 9 on the settled pile, against 3 rotated in advance). The
    // same product `rot * ub` either way, so the same bits.
    let dirs_b = &mut tables.dirs_b;
    dirs_b.clear();
    let eager = served.is_none();
    if eager {
        dirs_b.extend(b.edge_dirs.iter().map(|ub| rot * *ub));
    }
    let dirs_b: &[Vec3] = dirs_b;
    let dir_b = |ib: usize| {
        if eager {
            dirs_b[ib]
        } else {
            rot * b.edge_dirs[ib]
        }
    };
    // Pair `k`'s bit (0 from the 129th pair on: those are never left out). The pairs not
    // left out taken from the set's bits in increasing order (row by row, A's direction
    // `ia`): the same pairs in the same order as testing each pair's bit, without a `u128`
    // shift and test per pair, nor a shift per row.
    for (ia, ib, k) in Pairs::new(skip, a.edge_dirs.len(), ndb) {
        if k == first.0 {
            // The winner, evaluated first: the same answer as here.
            if let Some((s, axis)) = first.1
                && s > best.0
            {
                best = (s, ia, ib, axis);
            }
            continue;
        }
        let (ua, wb) = (a.edge_dirs[ia], dir_b(ib));
        let axis = ua.cross(wb);
        let len2 = axis.length_squared();
        if len2 < 1e-10 {
            continue;
        }
        // Whether a recording may remember this pair as deep.
        let rememberable = record.is_some() && DeepPairs::rememberable(len2);
        let axis = axis / len2.sqrt();
        // The first 4 points of each body first: their extents lie inside the bodies'
        // (and rounding is monotonic), so when they already overlap by more than the best
        // axis so far, so do the bodies, and the axis cannot win (the first of equals
        // wins) nor separate (`best` is not positive); nor matter when they overlap by
        // at least `-floor` (its separation is at most `floor`, not positive either).
        // Exact: an axis above `floor` meets the same decisions.
        // (Before the winner evaluated first, `first.2`: just below its separation.)
        let low = if floor > best.0 { floor } else { best.0 };
        let low = if k < first.0 && first.2 > low {
            first.2
        } else {
            low
        };
        // The centres' offset along the axis bounds the separation above (`reach_bound`):
        // at or below `low`, the axis can neither win nor separate nor matter, as for the
        // first points below. (A recording pair takes the head's bound, as before.)
        if !rememberable && reach_bound(axis, t, deep) <= low {
            continue;
        }
        let (mut ext_a, mut ext_b) = (a_local.head(axis), b_soa.head(axis));
        let [min_a, max_a, min_b, max_b] = Extent::bounds(&ext_a, &ext_b);
        let (head_plus, head_minus) = (min_b - max_a, min_a - max_b);
        if head_plus <= low && head_minus <= low {
            // (These bound the separations from above.)
            if rememberable {
                let bound = if head_plus >= head_minus {
                    head_plus
                } else {
                    head_minus
                };
                remember_depth(record.as_deref_mut(), k, bound, radii);
            }
            continue;
        }
        a_local.tail(axis, &mut ext_a);
        b_soa.tail(axis, &mut ext_b);
        let [min_a, max_a, min_b, max_b] = Extent::bounds(&ext_a, &ext_b);
        // Separation pushing B along +axis, and along -axis; keep the larger.
        let (s, axis) = if min_b - max_a >= min_a - max_b {
            (min_b - max_a, axis)
        } else {
            (min_a - max_b, -axis)
        };
        if rememberable {
            remember_depth(record.as_deref_mut(), k, s, radii);
        }
        if s > 0.0 {
            if let Some(m) = record {
                m.clear();
            }
            separating_direction_hint(a, b, ia, ib, hint);
            *separation = s;
            return None;
        }
        if s > best.0 {
            best = (s, ia, ib, axis);
        }
    }
    if let Some(m) = record.take() {
        m.finish_directions(a, b);
        m.note_direction_winner(best.1 * ndb + best.2);
    } else if let Some(m) = served {
        m.note_direction_winner(best.1 * ndb + best.2);
    }
    if best.0 == f32::NEG_INFINITY {
        return Some(best);
    }
    let (_, ia, ib, axis) = best;
    let (ea, eb) = supporting_edges(a, b, bv, ia, ib, axis);
    Some((best.0, ea, eb, axis))
}

/// Whether `skip` (a search's direction pairs left out, bit `k` for pair `k`) leaves out
/// every one of the `n` direction pairs but `winner` (below `n`): then [`Pairs`] visits
/// the winner alone. Never with more than 128 pairs (those from the 129th on are never
/// left out).
#[inline(always)]
fn winner_alone(skip: u128, winner: usize, n: usize) -> bool {
    if n > 128 || winner >= n {
        return false;
    }
    let all = u128::MAX >> (128 - n);
    all & !skip == 1u128 << winner
}

/// The supporting edges of a direction pair's axis: A's edge of direction `ia` furthest
/// along `axis` and B's edge of direction `ib` (B's vertices `bv` in A's frame) furthest
/// against it, each the first of equals (0 when a direction has no edge, or none beats
/// the start). A's sums `v0 + v1` are the shape's own (`ConvexPolyhedron::dir_group`,
/// the same floats as summed here), B's ends read in sequence: the same products and
/// decisions as visiting each direction's edges by `edges_of_direction` (the tests'
/// oracle), which looked each edge's ends up, and A's vertices, per pair and step.
#[inline(always)]
fn supporting_edges(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    bv: &[Vec3],
    ia: usize,
    ib: usize,
    axis: Vec3,
) -> (usize, usize) {
    let mut ea_best = (f32::NEG_INFINITY, 0usize);
    for r in a.dir_group(ia) {
        let h = axis.dot(r.sum);
        if h > ea_best.0 {
            ea_best = (h, r.edge as usize);
        }
    }
    let mut eb_best = (f32::INFINITY, 0usize);
    let mut visit_b = |r: &crate::polyhedron::DirEdge, p0: Vec3, p1: Vec3| {
        let h = axis.dot(p0 + p1);
        if h < eb_best.0 {
            eb_best = (h, r.edge as usize);
        }
    };
    if b.dir_ends_below(bv.len()) {
        for r in b.dir_group(ib) {
            let [v0, v1] = r.ends;
            // SAFETY: every end of B's direction groups is below `bv.len()` (checked
            // just above: `dir_end_bound`, built with the groups, is one more than the
            // largest end).
            let (p0, p1) = unsafe {
                (
                    *bv.get_unchecked(v0 as usize),
                    *bv.get_unchecked(v1 as usize),
                )
            };
            visit_b(r, p0, p1);
        }
    } else {
        for r in b.dir_group(ib) {
            let [v0, v1] = r.ends;
            visit_b(r, bv[v0 as usize], bv[v1 as usize]);
        }
    }
    (ea_best.1, eb_best.1)
}

/// Remembers in `hint` one concrete edge pair of directions `ia` (of `a`) and `ib` (of
/// `b`) whose axis separated the bodies, for the next step's gap test (left as it is when
/// an edge index does not fit the hint).
// Cold and out of line: a search by direction separates only on the first steps of a
// pair's approach (then the hint's gap test answers before any search), so this stays out
// of `edge_axes_by_direction`'s hot code (issue 23).
#[cold]
#[inline(never)]
fn separating_direction_hint(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    ia: usize,
    ib: usize,
    hint: &mut SatHint,
) {
    let ea = a
        .edge_dir_of
        .iter()
        .position(|&d| d as usize == ia)
        .unwrap_or(0);
    let eb = b
        .edge_dir_of
        .iter()
        .position(|&d| d as usize == ib)
        .unwrap_or(0);
    if ea < 0x8000 && eb < 0x8000 {
        *hint = HINT_EDGE | ((ea as u32) << 15) | eb as u32;
    }
}

/// Visits the edges `e` of `p` whose direction is `d` (`edge_dir_of[e] == d`) in increasing
/// order, with their vertices: the shape's own list of each direction's edges
/// (`ConvexPolyhedron::edges_of_dir`), built once, where comparing every edge's direction
/// cost ~85 instructions a search on the cube pile. (The search now reads the shape's
/// groups, `ConvexPolyhedron::dir_group`; this is the tests' oracle.)
#[cfg(test)]
pub(super) fn edges_of_direction(
    p: &ConvexPolyhedron,
    d: usize,
    mut visit: impl FnMut(usize, [u32; 2]),
) {
    for &e in p.edges_of_dir(d) {
        if let Some(&ends) = p.edges.get(e as usize) {
            visit(e as usize, ends);
        }
    }
}

/// The direction pairs `k = ia * ndb + ib` (`nda` directions of A, `ndb` of B) whose bit in
/// `skip` (bit `k`: a search's set of pairs left out, none from the 129th pair on) is clear,
/// in increasing order, as `(ia, ib, k)`.
struct Pairs {
    /// The pairs below 128 not left out, as two 64-bit words (pairs 0 to 63, then 64 to
    /// 127): a cube pair's 9 pairs sit in the first, and each step's find-and-clear is one
    /// word's, not a `u128`'s (issue 23).
    todo: [u64; 2],
    /// The next pair from 128 on (never left out), and the end of all pairs.
    next: usize,
    end: usize,
    /// B's directions per row, the current row and the pair that ends it.
    ndb: usize,
    ia: usize,
    row_end: usize,
}

impl Pairs {
    #[inline(always)]
    fn new(skip: u128, nda: usize, ndb: usize) -> Self {
        let end = nda.saturating_mul(ndb);
        // Each word's pairs below `end`: all, none, or the low `end - 64 w` bits.
        let low = |w: usize| match end.saturating_sub(64 * w) {
            0 => 0,
            n if n >= 64 => !0,
            n => (1u64 << n) - 1,
        };
        Pairs {
            todo: [!(skip as u64) & low(0), !((skip >> 64) as u64) & low(1)],
            next: 128,
            end,
            ndb,
            ia: 0,
            row_end: ndb,
        }
    }
}

impl Iterator for Pairs {
    type Item = (usize, usize, usize);

    #[inline(always)]
    fn next(&mut self) -> Option<(usize, usize, usize)> {
        let k = if self.todo[0] != 0 {
            let k = self.todo[0].trailing_zeros() as usize;
            self.todo[0] &= self.todo[0] - 1;
            k
        } else if self.todo[1] != 0 {
            let k = 64 + self.todo[1].trailing_zeros() as usize;
            self.todo[1] &= self.todo[1] - 1;
            k
        } else if self.next < self.end {
            self.next += 1;
            self.next - 1
        } else {
            return None;
        };
        // (`k < end` here, so `ndb > 0` and the row is found.)
        while k >= self.row_end {
            self.ia += 1;
            self.row_end += self.ndb;
        }
        Some((self.ia, k + self.ndb - self.row_end, k))
    }
}

#[cfg(test)]
#[path = "edges_tests.rs"]
mod tests;

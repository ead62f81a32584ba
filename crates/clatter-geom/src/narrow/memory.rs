//! What a polyhedron pair remembers of its Gauss-map edge search between steps: the edge
//! pairs that can pass the Gauss-map tests at any relative rotation near the one of the
//! last full search. While the rotation stays near, the search visits those pairs alone,
//! through the same tests in the same order, so it finds bitwise what the whole search
//! finds (see [`EdgeMemory`]).

use glam::{Mat3, Quat, Vec3};

use super::SatHint;
use super::edges::{EdgeOfA, separating_pair};
use super::sat::EdgeAxis;
use crate::ConvexPolyhedron;

/// How many edge pairs one memory holds (a pair of icosahedra keeps about 30 at
/// [`TURN`]); a search with more candidates is not remembered.
const CAPACITY: usize = 64;

/// How far the Gauss-map tests' products must be from zero at the recorded rotation for a
/// pair to be left out of the memory (the products are of unit normals with arcs of
/// length at most 1). The memory holds while twice the sine of half the angle turned since
/// (the largest move of a unit vector) stays below this, less [`ROUNDING`].
pub(super) const TURN: f32 = 0.02;

/// The rounding allowed for: of each product, at the recorded rotation and now (a few ulps
/// of the products, of the rotation matrices built from unit quaternions, and of the angle
/// turned), with room to spare.
const ROUNDING: f32 = 1e-4;

/// The edge pairs of a polyhedron pair `(a, b)` that can pass the Gauss-map tests of
/// `edges::edge_axes_gauss_map` while B's rotation relative to A stays near `rot`.
///
/// Why this is exact: the tests are signs of products `n . (R v)` of unit normals with
/// arcs (of length at most 1) turned by the relative rotation `R` (or its transpose). A
/// pair was left out only when one of the tests failed at `rot` with products at least
/// [`TURN`] away from zero, each with the sign that fails it. A rotation by an angle `phi`
/// moves a vector by at most `2 sin(phi / 2)` times its length, so while that, with the
/// rounding, stays below [`TURN`], every product left out keeps its strict sign, and the
/// test it failed still fails. The pairs kept are visited in the same order (by edge of A,
/// then of B) through the same tests and arithmetic as the whole search (`EdgeOfA`), so
/// the same pairs pass, and the best (or first separating) one is the same, bitwise.
///
/// The memory names its polyhedra by address: they are shared (`Arc`) and outlive the
/// simulation's memories, so a memory of other polyhedra never passes for theirs.
#[derive(Clone, Debug)]
pub struct EdgeMemory {
    /// The addresses of A and B, 0 when nothing is remembered.
    shapes: [usize; 2],
    /// B's rotation relative to A at the recorded search.
    rot: Quat,
    /// The pairs remembered, `[edge of A, edge of B]`, in increasing order.
    pairs: [[u8; 2]; CAPACITY],
    len: u8,
}

impl Default for EdgeMemory {
    fn default() -> Self {
        EdgeMemory {
            shapes: [0; 2],
            rot: Quat::IDENTITY,
            pairs: [[0; 2]; CAPACITY],
            len: 0,
        }
    }
}

/// The identity of a polyhedron as a memory records it.
#[inline]
fn address(p: &ConvexPolyhedron) -> usize {
    p as *const ConvexPolyhedron as usize
}

/// Whether `q` is a unit quaternion up to rounding (the exactness argument needs it).
#[inline]
fn unit(q: Quat) -> bool {
    (q.length_squared() - 1.0).abs() < 1e-5
}

impl EdgeMemory {
    /// Whether this memory serves `a` and `b` at relative rotation `rot`.
    #[inline]
    pub(super) fn holds(&self, a: &ConvexPolyhedron, b: &ConvexPolyhedron, rot: Quat) -> bool {
        if self.shapes != [address(a), address(b)] || !unit(rot) {
            return false;
        }
        let turned = (self.rot.conjugate() * rot).xyz().length();
        // (Written so that a NaN fails too.)
        2.0 * turned + ROUNDING < TURN
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

    /// Starts recording the search of `a` against `b` at `rot`; false when this pair of
    /// polyhedra cannot be remembered (too many edges to name in a byte, or not a unit
    /// rotation).
    pub(super) fn start(&mut self, a: &ConvexPolyhedron, b: &ConvexPolyhedron, rot: Quat) -> bool {
        self.clear();
        if a.edges.len() > 256 || b.edges.len() > 64 || !unit(rot) {
            return false;
        }
        self.rot = rot;
        true
    }

    /// Records pair `(ea, eb)` unless the Gauss-map tests fail for it by more than [`TURN`]
    /// (`cba`, `dba`, `adc`, `bdc` as `edges::EdgeOfA::pair_axis` takes and computes
    /// them); false when the memory is full (the recording is then abandoned).
    #[inline]
    pub(super) fn record(
        &mut self,
        ea: usize,
        eb: usize,
        cba: f32,
        dba: f32,
        arcs: [f32; 2],
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
        self.len += 1;
        true
    }

    /// Ends a recording of `a` against `b` that went through every edge pair.
    pub(super) fn finish(&mut self, a: &ConvexPolyhedron, b: &ConvexPolyhedron) {
        self.shapes = [address(a), address(b)];
    }

    /// The Gauss-map edge search over the remembered pairs alone (see [`EdgeMemory`]):
    /// the best edge axis, or `None` with the separating one in `hint` and `separation`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn search(
        &self,
        a: &ConvexPolyhedron,
        b: &ConvexPolyhedron,
        rot: Mat3,
        inv_rot: Mat3,
        bv: &[Vec3],
        hint: &mut SatHint,
        separation: &mut f32,
    ) -> Option<EdgeAxis> {
        let mut best_e = (f32::NEG_INFINITY, 0usize, 0usize, Vec3::ZERO);
        let mut current = None;
        for &[ea, eb] in &self.pairs[..self.len as usize] {
            let (ea, eb) = (ea as usize, eb as usize);
            let (side_a, arc) = match current {
                Some((e, side_a, arc)) if e == ea => (side_a, arc),
                _ => {
                    let next = (EdgeOfA::new(a, ea), inv_rot * a.edge_arcs[ea]);
                    current = Some((ea, next.0, next.1));
                    next
                }
            };
            let [fb0, fb1] = b.edge_faces[eb];
            // The products of the whole search's rows (`-(n . arc)` summed in `dot`'s
            // order) and of its rotated arcs of B.
            let product = |f: u32| {
                let n = b.faces[f as usize].normal;
                -(n.x * arc.x + n.y * arc.y + n.z * arc.z)
            };
            let arc_b = rot * b.edge_arcs[eb];
            let found = side_a.pair_axis(b, bv, eb, product(fb0), product(fb1), arc_b);
            let Some((s, axis)) = found else {
                continue;
            };
            if s > 0.0 {
                separating_pair(ea, eb, s, hint, separation);
                return None;
            }
            if s > best_e.0 {
                best_e = (s, ea, eb, axis);
            }
        }
        Some(best_e)
    }
}

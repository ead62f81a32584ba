//! Who owns what: recursive coordinate bisection ([`Bisection`]). The ranks are split in
//! two (the first half one more for an odd count), the bodies' box is cut across its
//! longest extent where the bodies divide in the same proportion, and each half is cut
//! again until every rank has its box; the boxes tile space. The cuts are found from
//! histograms of the bodies' coordinates summed over the ranks (integers: the same sums in
//! any order), so no rank needs another's positions.

use glam::{DVec3, Vec3};

use super::comm::Comm;
use crate::periodic::Periodic;

/// Bins of a histogram along a cut axis. A cut lands on a bin edge; when that leaves the
/// two sides further from their share than [`REFINE_TOLERANCE`], the bin holding the share
/// is split again into as many bins (another histogram pass, up to [`PASSES`]).
const BINS: usize = 1024;

/// A cut is refined (second pass) when its side is off its share by more than this
/// fraction of the bodies (or weight, [`Bisection::weighted`]) being cut (0.1%).
const REFINE_TOLERANCE: f64 = 1e-3;

/// A bisection of space between ranks: rank `r` owns the bodies whose centre (rounded to
/// f32) lies in its box ([`Bisection::region`]), found by walking the cuts from the root
/// ([`Bisection::owner`]): at each cut, a coordinate below it goes to the first half of the
/// ranks, the others to the second. Boxes are unbounded outwards, except along a periodic
/// axis, where the outer boxes end at the periodic box and distances are taken to the
/// nearest image ([`Bisection::distance`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Bisection {
    /// `ranks - 1` cuts `(axis, coordinate)` in preorder: the root's first, then the first
    /// half's (recursively), then the second half's. A node of `n` ranks sends `ceil(n/2)`
    /// ranks to its first half; its first half's node (when it has two ranks or more) is
    /// the next one, its second half's `ceil(n/2)` further on.
    cuts: Vec<(usize, f32)>,
    /// Per rank: its box, `[lo, hi)` per axis (infinite outwards, or the periodic box).
    boxes: Vec<[[f64; 2]; 3]>,
    /// Per axis, the periodic box's `[min, max)` when that axis is periodic.
    period: [Option<(f64, f64)>; 3],
}

/// The bodies of one node being cut (a group of two ranks or more).
#[derive(Debug, Clone, Copy)]
struct Group {
    /// Its node, an index into [`Bisection::cuts`].
    node: usize,
    /// Its ranks.
    ranks: usize,
}

/// A histogram's bin edges over `[lo, hi]`: `BINS + 1` f32 values, ascending (equal ones
/// where the range is narrower than `BINS` f32 steps).
fn edges(lo: f32, hi: f32) -> Vec<f32> {
    let (lo64, span) = (lo as f64, hi as f64 - lo as f64);
    (0..=BINS)
        .map(|k| (lo64 + span * k as f64 / BINS as f64) as f32)
        .collect()
}

/// The bin of `c` among `edges`: bin `k` holds the coordinates `edges[k] <= c <
/// edges[k + 1]`, the first bin all below and the last all above. So the bodies below a
/// cut at `edges[k]` are exactly those of the bins before `k`.
fn bin(edges: &[f32], c: f32) -> usize {
    edges[1..BINS].partition_point(|&e| e <= c)
}

/// How a group is cut: found from its summed bounding box and histograms.
#[derive(Debug, Clone)]
struct Cutting {
    axis: usize,
    /// The bodies (summed weight) the first half of the ranks should own.
    target: u64,
    /// The best cut so far, and the bodies (summed weight) below it.
    at: f32,
    below: u64,
    /// The range searched in the next pass (while the best cut is not close enough): the
    /// bin edges over it, the bodies below it, and whether it is open above (the last bin
    /// of the first pass, which holds the bodies at the top of the extent).
    search: Option<Search>,
}

/// A histogram's range: the bodies `edges[0] <= c < edges[BINS]` (with no upper bound when
/// `open`), `below` of the group's bodies lying below it.
#[derive(Debug, Clone)]
struct Search {
    edges: Vec<f32>,
    below: u64,
    open: bool,
}

impl Search {
    /// The histogram bin of `c`, if it lies in the range.
    fn bin(&self, c: f32) -> Option<usize> {
        let inside = c >= self.edges[0] && (self.open || c < self.edges[BINS]);
        inside.then(|| bin(&self.edges, c))
    }
}

impl Cutting {
    /// Takes a summed histogram `h` of the search range: the best of its edges becomes the
    /// cut if it is better than the best so far; then the bin where the share falls is the
    /// next search range, if the cut is still further than [`REFINE_TOLERANCE`] of `total`
    /// from its share and the bin can be split.
    fn take(&mut self, h: &[u64], total: u64) {
        let Some(s) = self.search.take() else {
            return;
        };
        let mut below = s.below;
        // The first of equally good edges (`self.below` starts at `u64::MAX`: none yet).
        for (j, &count) in h.iter().enumerate() {
            if below.abs_diff(self.target) < self.below.abs_diff(self.target) {
                self.at = s.edges[j];
                self.below = below;
            }
            below += count;
        }
        if self.below.abs_diff(self.target) as f64 <= REFINE_TOLERANCE * total as f64 {
            return;
        }
        // The bin where the share falls: the last whose start is not past it.
        let (mut below, mut j) = (s.below, 0usize);
        while j + 1 < BINS && below + h[j] <= self.target {
            below += h[j];
            j += 1;
        }
        let (lo, hi) = (s.edges[j], s.edges[j + 1]);
        let open = s.open && j + 1 == BINS;
        if lo < hi {
            self.search = Some(Search {
                edges: edges(lo, hi),
                below,
                open,
            });
        }
    }
}

/// Histogram passes per cut at most: the first over the extent, then refinements, each
/// `BINS` times finer (four passes resolve 2^40 steps of the extent, past f32's precision).
const PASSES: usize = 4;

impl Bisection {
    /// The bisection for `ranks` ranks of the bodies at `positions`, which are this rank's
    /// share when `comm` is given (collective: every rank calls it with its owned bodies,
    /// and all find the same cuts from the summed histograms), every body when it is `None`.
    /// Each cut divides its node's bodies in the proportion of its ranks' halves (at a bin
    /// edge of a 1024-bin histogram over their extent, refined inside the bin holding the
    /// share while that is off by more than 0.1% of the node's bodies, at most 4 passes in
    /// all), so each rank owns about `n / ranks` bodies (more or fewer when bodies share a
    /// coordinate).
    pub fn balanced(
        positions: &[Vec3],
        ranks: usize,
        periodic: Option<&Periodic>,
        comm: Option<&dyn Comm>,
    ) -> Bisection {
        Self::weighted(positions, &vec![1; positions.len()], ranks, periodic, comm)
    }

    /// [`Bisection::balanced`] with a weight per body (`weights[i]` for the body at
    /// `positions[i]`; integers, so the histograms' sums are exact in any order): each cut
    /// divides its node's summed weight, not its body count, in the proportion of its
    /// ranks' halves, so each rank's bodies weigh about `total / ranks` (to 0.1% of a node's
    /// weight per cut, plus the heaviest body where bodies share a coordinate). Weighted by
    /// an estimate of each body's work (`balance.rs`), the ranks get about the same work
    /// where the work per body is uneven. Unit weights give [`Bisection::balanced`]'s cuts.
    pub fn weighted(
        positions: &[Vec3],
        weights: &[u64],
        ranks: usize,
        periodic: Option<&Periodic>,
        comm: Option<&dyn Comm>,
    ) -> Bisection {
        assert_eq!(positions.len(), weights.len(), "one weight per body");
        let period = std::array::from_fn(|a| {
            periodic
                .filter(|p| p.axes[a])
                .map(|p| (p.min[a] as f64, p.max[a] as f64))
        });
        let mut cuts = vec![(0usize, 0.0f32); ranks.saturating_sub(1)];
        // Each body's group at this level (an index into `groups`), or none once its rank
        // is known.
        let mut groups = if ranks > 1 {
            vec![Group { node: 0, ranks }]
        } else {
            Vec::new()
        };
        let mut at: Vec<Option<usize>> = vec![Some(0); positions.len()];
        while !groups.is_empty() {
            let cutting = Self::cut_level(positions, weights, &at, &groups, comm);
            let mut next = Vec::new();
            let mut children = Vec::with_capacity(groups.len());
            for (g, c) in groups.iter().zip(&cutting) {
                cuts[g.node] = (c.axis, c.at);
                let first = g.ranks.div_ceil(2);
                let mut child = |node: usize, ranks: usize| {
                    (ranks > 1).then(|| {
                        next.push(Group { node, ranks });
                        next.len() - 1
                    })
                };
                let low = child(g.node + 1, first);
                let high = child(g.node + first, g.ranks - first);
                children.push((low, high));
            }
            for (p, g) in positions.iter().zip(at.iter_mut()) {
                if let Some(k) = *g {
                    let (axis, cut) = cuts[groups[k].node];
                    let (low, high) = children[k];
                    *g = if p[axis] < cut { low } else { high };
                }
            }
            groups = next;
        }
        let mut b = Bisection {
            cuts,
            boxes: Vec::new(),
            period,
        };
        b.boxes = b.find_boxes(ranks);
        b
    }

    /// The cuts of one level's groups: their bounding boxes (a max over ranks), their
    /// histograms along the longest extent (a sum), and for the groups whose best bin edge
    /// is not close enough to their share, finer histograms inside the bin holding the
    /// share (a sum per pass, all groups of the level together).
    fn cut_level(
        positions: &[Vec3],
        weights: &[u64],
        at: &[Option<usize>],
        groups: &[Group],
        comm: Option<&dyn Comm>,
    ) -> Vec<Cutting> {
        let n = groups.len();
        // Bounding boxes: -lo and hi, so that one max finds both.
        let mut bounds = vec![f32::NEG_INFINITY; 6 * n];
        for (p, g) in positions.iter().zip(at) {
            if let Some(k) = *g {
                let b = &mut bounds[6 * k..6 * k + 6];
                for a in 0..3 {
                    b[a] = b[a].max(-p[a]);
                    b[3 + a] = b[3 + a].max(p[a]);
                }
            }
        }
        if let Some(comm) = comm {
            comm.max_f32s(&mut bounds);
        }
        let mut cutting: Vec<Cutting> = (0..n)
            .map(|k| {
                let b = &bounds[6 * k..6 * k + 6];
                let (lo, hi) = (Vec3::new(-b[0], -b[1], -b[2]), Vec3::new(b[3], b[4], b[5]));
                let ext = hi - lo;
                let axis = if ext.x >= ext.y && ext.x >= ext.z {
                    0
                } else if ext.y >= ext.z {
                    1
                } else {
                    2
                };
                // No bodies (an empty group): any cut will do, the same on every rank.
                let (lo, hi) = if lo[axis] <= hi[axis] {
                    (lo[axis], hi[axis])
                } else {
                    (0.0, 0.0)
                };
                Cutting {
                    axis,
                    target: 0,
                    at: lo,
                    below: u64::MAX,
                    search: Some(Search {
                        edges: edges(lo, hi),
                        below: 0,
                        open: true,
                    }),
                }
            })
            .collect();
        let mut totals = vec![0u64; n];
        for pass in 0..PASSES {
            // The groups still searching (every rank knows which: the same sums).
            let searching: Vec<usize> = (0..n).filter(|&k| cutting[k].search.is_some()).collect();
            if searching.is_empty() {
                break;
            }
            let mut slot = vec![usize::MAX; n];
            for (s, &k) in searching.iter().enumerate() {
                slot[k] = s;
            }
            let mut hist = vec![0u64; BINS * searching.len()];
            for ((p, g), &w) in positions.iter().zip(at).zip(weights) {
                let Some(k) = *g else { continue };
                let c = &cutting[k];
                if let Some(b) = c.search.as_ref().and_then(|s| s.bin(p[c.axis])) {
                    hist[BINS * slot[k] + b] += w;
                }
            }
            if let Some(comm) = comm {
                comm.sum_u64s(&mut hist);
            }
            for (s, &k) in searching.iter().enumerate() {
                let h = &hist[BINS * s..BINS * (s + 1)];
                if pass == 0 {
                    // The first pass covers every body of the group.
                    totals[k] = h.iter().sum();
                    let r = groups[k].ranks;
                    cutting[k].target =
                        (totals[k] as u128 * r.div_ceil(2) as u128 / r as u128) as u64;
                }
                cutting[k].take(h, totals[k]);
                if pass + 1 == PASSES {
                    cutting[k].search = None;
                }
            }
        }
        cutting
    }

    /// Every rank's box, from the cuts.
    fn find_boxes(&self, ranks: usize) -> Vec<[[f64; 2]; 3]> {
        let outer: [[f64; 2]; 3] = std::array::from_fn(|a| match self.period[a] {
            Some((lo, hi)) => [lo, hi],
            None => [f64::NEG_INFINITY, f64::INFINITY],
        });
        let mut boxes = vec![outer; ranks];
        // (node, first rank, ranks, box)
        let mut stack = vec![(0usize, 0usize, ranks, outer)];
        while let Some((node, r0, n, b)) = stack.pop() {
            if n <= 1 {
                if n == 1 {
                    boxes[r0] = b;
                }
                continue;
            }
            let (axis, cut) = self.cuts[node];
            let first = n.div_ceil(2);
            let (mut low, mut high) = (b, b);
            low[axis][1] = cut as f64;
            high[axis][0] = cut as f64;
            stack.push((node + 1, r0, first, low));
            stack.push((node + first, r0 + first, n - first, high));
        }
        boxes
    }

    /// How unevenly ranks owning `owned` bodies each share them: the most any rank owns over
    /// the mean, minus one (0 when every rank owns as many; 0.1 when the fullest owns 10%
    /// more than the mean).
    pub fn imbalance(owned: &[u64]) -> f64 {
        let total: u64 = owned.iter().sum();
        if total == 0 {
            return 0.0;
        }
        let most = owned.iter().copied().max().unwrap_or(0);
        most as f64 * owned.len() as f64 / total as f64 - 1.0
    }

    /// Number of ranks.
    pub fn ranks(&self) -> usize {
        self.cuts.len() + 1
    }

    /// The cuts `(axis, coordinate)`, in preorder (the root's first; see the type's docs).
    pub fn cuts(&self) -> &[(usize, f32)] {
        &self.cuts
    }

    /// Rank `r`'s box: `[lo, hi)` per axis (x, y, z), infinite outwards except along a
    /// periodic axis (the periodic box). The boxes tile space.
    pub fn region(&self, r: usize) -> [[f64; 2]; 3] {
        self.boxes[r]
    }

    /// The rank that owns a body at `x`.
    pub fn owner(&self, x: DVec3) -> usize {
        let c = x.as_vec3();
        let (mut node, mut r0, mut n) = (0, 0, self.ranks());
        while n > 1 {
            let (axis, cut) = self.cuts[node];
            let first = n.div_ceil(2);
            if c[axis] < cut {
                node += 1;
                n = first;
            } else {
                node += first;
                r0 += first;
                n -= first;
            }
        }
        r0
    }

    /// How far rank `r`'s box is from rank `s`'s (0 when they touch): along a periodic
    /// axis, between the nearest images. Never more than [`Bisection::distance`] from any
    /// point of `r`'s box to `s`'s.
    pub fn box_distance(&self, r: usize, s: usize) -> f64 {
        self.box_to(r, &self.boxes[s])
    }

    /// How far `x` is from rank `r`'s box (0 inside): along a periodic axis, from the
    /// nearest of `x`'s images.
    pub fn distance(&self, x: DVec3, r: usize) -> f64 {
        self.point_to(x, &self.boxes[r])
    }

    /// How far `x` is from the box `b` (0 inside), with the nearest images along the
    /// periodic axes. Monotone in the box: a box inside `b` is never nearer (in floating
    /// point too: each step is a monotone rounding), so a subtree of the cuts whose box is
    /// out of reach has no rank within reach.
    fn point_to(&self, x: DVec3, b: &[[f64; 2]; 3]) -> f64 {
        let mut d2 = 0.0;
        for a in 0..3 {
            let [lo, hi] = b[a];
            let gap = |c: f64| (lo - c).max(c - hi).max(0.0);
            let c = x[a];
            let g = match self.period[a] {
                Some((p, q)) => gap(c).min(gap(c + (q - p))).min(gap(c - (q - p))),
                None => gap(c),
            };
            d2 += g * g;
        }
        d2.sqrt()
    }

    /// How far rank `r`'s box is from the box `b` (0 when they touch), with the nearest
    /// images along the periodic axes; monotone in `b` as [`Bisection::point_to`] is.
    fn box_to(&self, r: usize, b: &[[f64; 2]; 3]) -> f64 {
        let a = &self.boxes[r];
        let mut d2 = 0.0;
        for k in 0..3 {
            let gap = |shift: f64| {
                (b[k][0] + shift - a[k][1])
                    .max(a[k][0] - b[k][1] - shift)
                    .max(0.0)
            };
            let g = match self.period[k] {
                Some((p, q)) => gap(0.0).min(gap(q - p)).min(gap(p - q)),
                None => gap(0.0),
            };
            d2 += g * g;
        }
        d2.sqrt()
    }

    /// The ranks, ascending, whose boxes are nearer `x` than `reach`
    /// ([`Bisection::distance`]` < reach`): the ranks a body at `x` is a ghost on (but its
    /// owner), found by walking the cuts from the root and leaving out every subtree whose
    /// box is out of reach, O(log ranks + the ranks found) for a reach smaller than the
    /// boxes, where testing every rank's box is O(ranks). The same ranks as that test, bit
    /// for bit (each rank found is tested with [`Bisection::distance`]).
    pub fn within(&self, x: DVec3, reach: f64) -> Vec<usize> {
        let mut found = Vec::new();
        self.for_within(x, reach, |r| found.push(r));
        found
    }

    /// [`Bisection::within`] without a list: calls `found` with each of those ranks,
    /// ascending. For the per-body loops of a rebuild, which would otherwise allocate a list
    /// per body.
    ///
    /// A point at least `reach` inside its owner's box along every axis (most bodies at a
    /// rebuild) is within reach of that box alone: boxes tile space, so every other box (and
    /// each periodic image of one) lies beyond one of the owner's faces, and its distance
    /// is at least that face's gap (`sqrt(g * g) == g` in floating point; the other terms
    /// only add). So the owner alone is found without walking the cuts.
    pub fn for_within(&self, x: DVec3, reach: f64, mut found: impl FnMut(usize)) {
        let o = self.owner(x);
        let b = &self.boxes[o];
        if (0..3).all(|a| x[a] - b[a][0] >= reach && b[a][1] - x[a] >= reach) {
            found(o);
            return;
        }
        self.walk(
            |b| self.point_to(x, b) < reach,
            |r| {
                if self.distance(x, r) < reach {
                    found(r);
                }
            },
        );
    }

    /// The ranks, ascending, whose boxes are nearer rank `r`'s box than `reach`
    /// ([`Bisection::box_distance`]` < reach`; `r` itself included), found by walking the
    /// cuts as [`Bisection::within`] does: the same ranks as testing every box.
    pub fn boxes_within(&self, r: usize, reach: f64) -> Vec<usize> {
        let mut found = Vec::new();
        self.walk(
            |b| self.box_to(r, b) < reach,
            |s| {
                if self.box_distance(r, s) < reach {
                    found.push(s);
                }
            },
        );
        found
    }

    /// Walks the cuts depth first, the first half before the second (so ranks come
    /// ascending), entering a node only when `enter` takes its box, and calls `leaf` for
    /// each rank reached.
    fn walk(&self, enter: impl Fn(&[[f64; 2]; 3]) -> bool, mut leaf: impl FnMut(usize)) {
        let outer: [[f64; 2]; 3] = std::array::from_fn(|a| match self.period[a] {
            Some((lo, hi)) => [lo, hi],
            None => [f64::NEG_INFINITY, f64::INFINITY],
        });
        // Recursion rather than a stack of nodes: as deep as the cut tree (the log of the
        // ranks), and nothing allocated per walk.
        self.walk_node(0, 0, self.ranks(), outer, &enter, &mut leaf);
    }

    /// [`Bisection::walk`] from `node` (ranks `r0..r0 + n`, box `b`).
    fn walk_node(
        &self,
        node: usize,
        r0: usize,
        n: usize,
        b: [[f64; 2]; 3],
        enter: &impl Fn(&[[f64; 2]; 3]) -> bool,
        leaf: &mut impl FnMut(usize),
    ) {
        if !enter(&b) {
            return;
        }
        if n == 1 {
            leaf(r0);
            return;
        }
        let (axis, cut) = self.cuts[node];
        let first = n.div_ceil(2);
        let (mut low, mut high) = (b, b);
        low[axis][1] = cut as f64;
        high[axis][0] = cut as f64;
        self.walk_node(node + 1, r0, first, low, enter, leaf);
        self.walk_node(node + first, r0 + first, n - first, high, enter, leaf);
    }
}

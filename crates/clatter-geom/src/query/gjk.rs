//! GJK (Gilbert-Johnson-Keerthi) distance between two convex cores, in `f64`.
//!
//! The configuration space obstacle (CSO) is `A - B`; GJK walks a simplex of CSO points
//! towards the origin. `v` is the CSO point of the current simplex closest to the origin:
//! `|v|` is an upper bound on the distance and `v·w / |v|` (with `w` the support point
//! along `-v`) a lower bound. The simplex sub-problem (closest point of a point, segment,
//! triangle or tetrahedron to the origin) is solved by Voronoi-region tests with explicit
//! guards for degenerate (collinear, coplanar) simplices, so the loop never divides by zero.
//!
//! Termination, in this order of checks:
//! * `|v| <= GJK_ABS_TOL * scale` (scale = the largest CSO point seen): touching, reported as
//!   overlapping with distance 0;
//! * `|v|² - v·w <= GJK_REL_TOL * |v|²`: converged, the relative error on the distance is below
//!   `GJK_REL_TOL` (plus the support-selection error, see [`super::support`]);
//! * `w` is already in the simplex, or the new `|v|` is not smaller than the previous one:
//!   no further progress is possible in floating point, the best `v` is kept;
//! * the origin is inside a tetrahedron: overlapping;
//! * [`GJK_MAX_ITERATIONS`] iterations: the current `v` is returned (an upper bound on the
//!   distance whose witness points lie on the shapes) with status `MaxIterations`.

use glam::DVec3;

use super::support::Support;

/// Iteration cap of the GJK loop (typical runs take 3-15 iterations).
pub const GJK_MAX_ITERATIONS: usize = 64;
/// Relative convergence tolerance on the distance.
pub const GJK_REL_TOL: f64 = 1e-10;
/// Distances below this fraction of the CSO scale count as touching (overlap).
pub const GJK_ABS_TOL: f64 = 1e-10;

/// Up to four CSO points `w = a - b` with their witnesses on each shape and the barycentric
/// weights of `v` (valid after a solve).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Simplex {
    pub n: usize,
    pub w: [DVec3; 4],
    pub a: [DVec3; 4],
    pub b: [DVec3; 4],
    pub l: [f64; 4],
}

impl Simplex {
    #[inline]
    pub(crate) fn push(&mut self, a: DVec3, b: DVec3) {
        let n = self.n;
        self.a[n] = a;
        self.b[n] = b;
        self.w[n] = a - b;
        self.l[n] = 0.0;
        self.n = n + 1;
    }

    /// Witness points `(Σ λ a, Σ λ b)`.
    #[inline]
    pub(crate) fn witnesses(&self) -> (DVec3, DVec3) {
        let mut pa = DVec3::ZERO;
        let mut pb = DVec3::ZERO;
        for i in 0..self.n {
            pa += self.a[i] * self.l[i];
            pb += self.b[i] * self.l[i];
        }
        (pa, pb)
    }

    /// Keeps the vertices `s.idx` (increasing, so compaction in place is safe).
    #[inline]
    fn apply(&mut self, s: &Sub) {
        for k in 0..s.n {
            let i = s.idx[k];
            debug_assert!(i >= k);
            if i != k {
                self.w[k] = self.w[i];
                self.a[k] = self.a[i];
                self.b[k] = self.b[i];
            }
            self.l[k] = s.l[k];
        }
        self.n = s.n;
    }
}

/// Result of a simplex sub-problem: the kept vertices, their weights and the closest point.
#[derive(Clone, Copy, Debug)]
struct Sub {
    n: usize,
    idx: [usize; 4],
    l: [f64; 4],
    v: DVec3,
}

impl Sub {
    #[inline]
    fn one(i: usize, p: DVec3) -> Self {
        Sub {
            n: 1,
            idx: [i, 0, 0, 0],
            l: [1.0, 0.0, 0.0, 0.0],
            v: p,
        }
    }
    #[inline]
    fn two(i: usize, j: usize, t: f64, a: DVec3, b: DVec3) -> Self {
        Sub {
            n: 2,
            idx: [i, j, 0, 0],
            l: [1.0 - t, t, 0.0, 0.0],
            v: a + (b - a) * t,
        }
    }
}

/// Closest point of segment `w[i] w[j]` to the origin.
#[inline]
fn segment(w: &[DVec3; 4], i: usize, j: usize) -> Sub {
    let (a, b) = (w[i], w[j]);
    let ab = b - a;
    let t = -a.dot(ab);
    if t <= 0.0 {
        return Sub::one(i, a);
    }
    let dd = ab.length_squared();
    if t >= dd {
        return Sub::one(j, b);
    }
    Sub::two(i, j, t / dd, a, b)
}

/// Closest point of triangle `w[i] w[j] w[k]` to the origin (Voronoi regions as in Ericson,
/// Real-Time Collision Detection 5.1.5, with guards for degenerate triangles).
fn triangle(w: &[DVec3; 4], i: usize, j: usize, k: usize) -> Sub {
    let (a, b, c) = (w[i], w[j], w[k]);
    let ab = b - a;
    let ac = c - a;
    let d1 = -ab.dot(a);
    let d2 = -ac.dot(a);
    if d1 <= 0.0 && d2 <= 0.0 {
        return Sub::one(i, a);
    }
    let d3 = -ab.dot(b);
    let d4 = -ac.dot(b);
    if d3 >= 0.0 && d4 <= d3 {
        return Sub::one(j, b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let den = d1 - d3; // = |ab|² > 0 here unless ab degenerates
        return if den > 0.0 {
            Sub::two(i, j, d1 / den, a, b)
        } else {
            Sub::one(i, a)
        };
    }
    let d5 = -ab.dot(c);
    let d6 = -ac.dot(c);
    if d6 >= 0.0 && d5 <= d6 {
        return Sub::one(k, c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let den = d2 - d6;
        return if den > 0.0 {
            Sub::two(i, k, d2 / den, a, c)
        } else {
            Sub::one(i, a)
        };
    }
    let va = d3 * d6 - d5 * d4;
    let e1 = d4 - d3;
    let e2 = d5 - d6;
    if va <= 0.0 && e1 >= 0.0 && e2 >= 0.0 {
        let den = e1 + e2;
        return if den > 0.0 {
            Sub::two(j, k, e1 / den, b, c)
        } else {
            Sub::one(j, b)
        };
    }
    let den = va + vb + vc; // = |ab × ac|²
    let degenerate = 1e-14 * ab.length_squared() * ac.length_squared();
    if den.is_nan() || den <= degenerate {
        // Degenerate (collinear) triangle: the best of its edges.
        return best_of(&[segment(w, i, j), segment(w, i, k), segment(w, j, k)]);
    }
    let l1 = vb / den;
    let l2 = vc / den;
    // Projection of the origin on the plane: more accurate than the barycentric combination
    // when the triangle is far from the origin compared with its distance.
    let n = ab.cross(ac);
    let v = n * (n.dot(a) / n.length_squared());
    Sub {
        n: 3,
        idx: [i, j, k, 0],
        l: [1.0 - l1 - l2, l1, l2, 0.0],
        v,
    }
}

#[inline]
fn best_of(c: &[Sub]) -> Sub {
    let mut best = c[0];
    let mut bd = best.v.length_squared();
    for s in &c[1..] {
        let d = s.v.length_squared();
        if d < bd {
            bd = d;
            best = *s;
        }
    }
    best
}

/// Closest point of the tetrahedron to the origin, or `None` when the origin is inside
/// (then `l` receives the barycentric coordinates of the origin).
fn tetrahedron(w: &[DVec3; 4], l: &mut [f64; 4]) -> Option<Sub> {
    const FACES: [[usize; 4]; 4] = [[0, 1, 2, 3], [0, 1, 3, 2], [0, 2, 3, 1], [1, 2, 3, 0]];
    let scale = w
        .iter()
        .map(|p| p.length_squared())
        .fold(0.0, f64::max)
        .sqrt();
    let mut best: Option<Sub> = None;
    let mut bd = f64::INFINITY;
    let mut inside = true;
    for f in FACES {
        let [i, j, k, o] = f;
        let n = (w[j] - w[i]).cross(w[k] - w[i]);
        let so = -n.dot(w[i]);
        let sd = n.dot(w[o] - w[i]);
        let degenerate = sd.abs() <= 1e-12 * n.length() * scale;
        if degenerate || so * sd < 0.0 {
            inside = false;
            let s = triangle(w, i, j, k);
            let d = s.v.length_squared();
            if d < bd {
                bd = d;
                best = Some(s);
            }
        } else {
            l[o] = so / sd;
        }
    }
    if inside { None } else { best }
}

/// How a GJK run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum GjkStatus {
    /// Converged with the cores apart: `|v|` is the distance.
    Separated,
    /// The cores overlap or touch (`v` ~ 0); the simplex witnesses give a common point.
    Overlapping,
    /// Early exit: a separating plane with a gap larger than the margin was found.
    BeyondMargin,
    /// Early exit: a pair of points closer than the margin was found.
    WithinMargin,
    /// The iteration cap was hit; `v` is the best upper bound found.
    MaxIterations,
}

/// The end state of a GJK run.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Gjk {
    pub status: GjkStatus,
    /// The CSO point of the final simplex closest to the origin (`pa - pb`).
    pub v: DVec3,
    pub pa: DVec3,
    pub pb: DVec3,
    pub simplex: Simplex,
}

impl Gjk {
    /// Distance between the cores (0 when overlapping).
    #[inline]
    pub(crate) fn distance(&self) -> f64 {
        if self.status == GjkStatus::Overlapping {
            0.0
        } else {
            self.v.length()
        }
    }
}

/// Runs GJK on `a - b` from the search direction `dir` (a guess of `pa - pb`).
///
/// With `margin = Some(m)` the run stops as soon as the distance is known to be above `m`
/// (`BeyondMargin`) or at most `m` (`WithinMargin`): the boolean intersection test of rounded
/// shapes (spheres are points with a margin).
pub(crate) fn gjk<A: Support, B: Support>(a: &A, b: &B, dir: DVec3, margin: Option<f64>) -> Gjk {
    let d0 = if dir.length_squared() > 0.0 && dir.is_finite() {
        dir
    } else {
        DVec3::X
    };
    let mut s = Simplex::default();
    let (a0, b0) = (a.support(-d0), b.support(d0));
    s.push(a0, b0);
    s.l[0] = 1.0;
    let mut v = s.w[0];
    let mut vv = v.length_squared();
    let mut scale2 = vv;
    let mut status = GjkStatus::MaxIterations;
    for _ in 0..GJK_MAX_ITERATIONS {
        if vv <= GJK_ABS_TOL * GJK_ABS_TOL * scale2 {
            status = GjkStatus::Overlapping;
            break;
        }
        if let Some(m) = margin
            && vv <= m * m
        {
            status = GjkStatus::WithinMargin;
            break;
        }
        let (pa, pb) = (a.support(-v), b.support(v));
        let w = pa - pb;
        scale2 = scale2.max(w.length_squared());
        let vw = v.dot(w);
        if let Some(m) = margin
            && vw > 0.0
            && vw * vw > m * m * vv
        {
            status = GjkStatus::BeyondMargin;
            break;
        }
        if vv - vw <= GJK_REL_TOL * vv {
            status = GjkStatus::Separated;
            break;
        }
        if (0..s.n).any(|i| s.a[i] == pa && s.b[i] == pb) {
            status = GjkStatus::Separated;
            break;
        }
        let before = s.n;
        s.push(pa, pb);
        let mut inside = [0.0; 4];
        let sub = match s.n {
            2 => Some(segment(&s.w, 0, 1)),
            3 => Some(triangle(&s.w, 0, 1, 2)),
            _ => tetrahedron(&s.w, &mut inside),
        };
        let Some(sub) = sub else {
            // Origin inside the tetrahedron.
            s.l = inside;
            status = GjkStatus::Overlapping;
            v = DVec3::ZERO;
            break;
        };
        let nvv = sub.v.length_squared();
        if nvv.is_nan() || nvv >= vv {
            // No progress in floating point: keep the previous (better or equal) simplex,
            // which the push left untouched.
            s.n = before;
            status = GjkStatus::Separated;
            break;
        }
        s.apply(&sub);
        v = sub.v;
        vv = nvv;
    }
    let (pa, pb) = s.witnesses();
    if status == GjkStatus::Overlapping {
        // A common point of both shapes: Σλa = Σλb when v = 0; average the two for rounding.
        let m = (pa + pb) * 0.5;
        return Gjk {
            status,
            v: DVec3::ZERO,
            pa: m,
            pb: m,
            simplex: s,
        };
    }
    Gjk {
        status,
        v,
        pa,
        pb,
        simplex: s,
    }
}

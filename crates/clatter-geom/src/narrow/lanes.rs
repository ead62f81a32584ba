//! The separating-axis test's lanes: points as 4-point chunks of x, y, z lanes, their
//! smallest and largest projections on an axis with packed `minps` (the scalar rule's ties
//! and NaNs kept), and the reductions of four lanes at once.

use glam::{Vec3, Vec4};

/// Points as 4-point chunks of separate x, y, z lanes (the last chunk padded with copies of
/// the first point), so that "smallest projection on an axis" is packed SIMD, a chunk's
/// three lanes read together.
#[derive(Default, Debug, Clone, PartialEq)]
pub(crate) struct SoaPoints {
    chunks: Vec<[Vec4; 3]>,
}

impl SoaPoints {
    /// `pts` as lanes (see [`SoaPoints::fill`]).
    pub(crate) fn of(pts: &[Vec3]) -> Self {
        let mut lanes = Self::default();
        lanes.fill(pts);
        lanes
    }

    /// Lays `pts` out as chunks of four (the last padded with the first point), reusing
    /// the buffer: the pair's moved points, once per pair and step.
    pub(super) fn fill(&mut self, pts: &[Vec3]) {
        // Sized once, then written in place (no capacity check per chunk).
        self.chunks.resize(pts.len().div_ceil(4), [Vec4::ZERO; 3]);
        let Some(&first) = pts.first() else {
            return;
        };
        // Whole chunks of four without a test per lane; the last, short one padded with
        // the first point (the same lanes as padding every chunk).
        let lanes = |[p0, p1, p2, p3]: [Vec3; 4]| {
            [
                Vec4::new(p0.x, p1.x, p2.x, p3.x),
                Vec4::new(p0.y, p1.y, p2.y, p3.y),
                Vec4::new(p0.z, p1.z, p2.z, p3.z),
            ]
        };
        let fours = pts.chunks_exact(4);
        let rest = fours.remainder();
        let mut slots = self.chunks.iter_mut();
        // (`fours` first: `zip` stops on it without taking the short chunk's slot.)
        for (ps, chunk) in fours.zip(&mut slots) {
            *chunk = transpose4(ps);
        }
        if let Some(chunk) = slots.next() {
            let p = |k: usize| *rest.get(k).unwrap_or(&first);
            *chunk = lanes([p(0), p(1), p(2), p(3)]);
        }
    }

    /// Lays out `src`'s points moved by `rot` and `t` (each `rot * p + t`), reusing the
    /// buffer: the same floats, bitwise, as `fill` of the moved points, lane by lane in
    /// place of point by point. glam's `Mat3 * Vec3` is `x_axis * p.x + y_axis * p.y +
    /// z_axis * p.z` summed left to right (no fused multiply-add), so each lane's `x` is
    /// `((c0.x * x + c1.x * y) + c2.x * z) + t.x` here too; and the padding lanes, copies
    /// of the first point, move to copies of the moved first point, `fill`'s padding. For
    /// a remembered edge search by direction, B's points in A's frame from the shape's own
    /// lanes: 9 products and 9 sums per chunk of four, where each point moved alone and
    /// its lanes shuffled into place cost about 200 instructions a cube (issue 23, edge38).
    #[inline(always)]
    pub(super) fn fill_moved(&mut self, src: &SoaPoints, rot: glam::Mat3, t: Vec3) {
        self.chunks.resize(src.chunks.len(), [Vec4::ZERO; 3]);
        let s = Vec4::splat;
        let (c0, c1, c2) = (rot.x_axis, rot.y_axis, rot.z_axis);
        let (ax, bx, cx, dx) = (s(c0.x), s(c1.x), s(c2.x), s(t.x));
        let (ay, by, cy, dy) = (s(c0.y), s(c1.y), s(c2.y), s(t.y));
        let (az, bz, cz, dz) = (s(c0.z), s(c1.z), s(c2.z), s(t.z));
        for (out, &[xs, ys, zs]) in self.chunks.iter_mut().zip(&src.chunks) {
            *out = [
                ax * xs + bx * ys + cx * zs + dx,
                ay * xs + by * ys + cy * zs + dy,
                az * xs + bz * ys + cz * zs + dz,
            ];
        }
    }

    /// The first `len` points laid out (at most four per chunk), back as points into `out`
    /// (cleared first): the same floats, moves and shuffles only. With
    /// [`SoaPoints::fill_moved`], a body's points moved into another's frame both ways, as
    /// lanes and as points, without moving each point alone (issue 23, edge38).
    #[inline(always)]
    pub(super) fn points_into(&self, out: &mut Vec<Vec3>, len: usize) {
        let len = len.min(4 * self.chunks.len());
        out.clear();
        #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
        {
            use std::arch::x86_64::{
                _mm_shuffle_ps, _mm_storeu_ps, _mm_unpackhi_ps, _mm_unpacklo_ps,
            };
            /// `_mm_shuffle_ps`'s mask: lanes `i0`, `i1` of the first operand, then `i2`,
            /// `i3` of the second.
            const fn pick(i0: i32, i1: i32, i2: i32, i3: i32) -> i32 {
                i0 | (i1 << 2) | (i2 << 4) | (i3 << 6)
            }
            out.reserve(4 * self.chunks.len());
            let spare = out.spare_capacity_mut();
            // The guard of the stores below: room for every chunk's four points.
            assert!(spare.len() >= 4 * self.chunks.len());
            let dst = spare.as_mut_ptr().cast::<f32>();
            for (c, &[xs, ys, zs]) in self.chunks.iter().enumerate() {
                // SAFETY: SSE, enabled for this target (the `cfg` above); the stores write
                // the 48 bytes of points `4c` to `4c + 3` inside `out`'s spare capacity
                // (at least four points a chunk: checked above), unaligned: `Vec3` is
                // `repr(C)`, three `f32`s with no padding, so the points are contiguous
                // floats. Only moves and shuffles: the floats are the lanes' bits.
                unsafe {
                    let (xs, ys, zs) = (xs.into(), ys.into(), zs.into());
                    let lo = _mm_unpacklo_ps(xs, ys); // x0 y0 x1 y1
                    let hi = _mm_unpackhi_ps(xs, ys); // x2 y2 x3 y3
                    let t = _mm_shuffle_ps::<{ pick(0, 0, 2, 2) }>(zs, lo); // z0 z0 x1 x1
                    let a = _mm_shuffle_ps::<{ pick(0, 1, 0, 2) }>(lo, t); // x0 y0 z0 x1
                    let t = _mm_shuffle_ps::<{ pick(3, 3, 1, 1) }>(lo, zs); // y1 y1 z1 z1
                    let b = _mm_shuffle_ps::<{ pick(0, 2, 0, 1) }>(t, hi); // y1 z1 x2 y2
                    let t = _mm_shuffle_ps::<{ pick(2, 2, 2, 2) }>(zs, hi); // z2 z2 x3 x3
                    let u = _mm_shuffle_ps::<{ pick(3, 3, 3, 3) }>(hi, zs); // y3 y3 z3 z3
                    let cc = _mm_shuffle_ps::<{ pick(0, 2, 0, 2) }>(t, u); // z2 x3 y3 z3
                    let f = dst.add(12 * c);
                    _mm_storeu_ps(f, a);
                    _mm_storeu_ps(f.add(4), b);
                    _mm_storeu_ps(f.add(8), cc);
                }
            }
            // SAFETY: the first `4 * chunks.len()` points, at least `len`, were written
            // above.
            unsafe { out.set_len(len) };
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
        {
            let lane = |v: Vec4, j: usize| v.to_array()[j];
            out.extend((0..len).map(|i| {
                let [xs, ys, zs] = self.chunks[i / 4];
                Vec3::new(lane(xs, i % 4), lane(ys, i % 4), lane(zs, i % 4))
            }));
        }
    }

    /// Feeds the first chunk's projections on `n` into a new [`Extent`] (nothing when
    /// there are no points): the head test's bounds, without a range to check.
    #[inline(always)]
    pub(super) fn head(&self, n: Vec3) -> Extent {
        let mut e = Extent::new();
        if let Some(c) = self.chunks.first() {
            feed(n, std::slice::from_ref(c), &mut e);
        }
        e
    }

    /// Feeds the projections on `n` of the chunks after the first into `e`: after
    /// [`SoaPoints::head`], `e` has been fed every chunk in order.
    #[inline(always)]
    pub(super) fn tail(&self, n: Vec3, e: &mut Extent) {
        feed(n, self.chunks.get(1..).unwrap_or(&[]), e);
    }

    /// Which of the first `len` points (at most 64, the chunks' points in order) have
    /// `n.x * x + n.y * y + n.z * z + c < 0`, as bit `k` for point `k`: per lane the same
    /// products and sums in the same order as `n.dot(p) + c` (glam's `Vec3::dot`), so the
    /// same floats, and `cmpltps` is `<` (false for a NaN). For a polyhedron against a
    /// plane: the vertices below it, without a scalar loop over them.
    #[inline(always)]
    pub(super) fn below(&self, n: Vec3, c: f32, len: usize) -> u64 {
        debug_assert!(len <= 64 && len <= 4 * self.chunks.len());
        let (nx, ny, nz, cs) = (
            Vec4::splat(n.x),
            Vec4::splat(n.y),
            Vec4::splat(n.z),
            Vec4::splat(c),
        );
        let mut mask = 0u64;
        let chunks = &self.chunks[..self.chunks.len().min(16)];
        for (k, &[xs, ys, zs]) in chunks.iter().enumerate() {
            let h = nx * xs + ny * ys + nz * zs + cs;
            mask |= (h.cmplt(Vec4::ZERO).bitmask() as u64) << (4 * k);
        }
        // The last chunk's padding lanes (copies of the first point) are not points.
        if len < 64 {
            mask & ((1u64 << len) - 1)
        } else {
            mask
        }
    }

    /// Smallest projection on `n`: per lane `n.x * x + n.y * y + n.z * z` over the chunks
    /// in order, the smaller kept (the first on a tie), then the lanes reduced as
    /// [`Extent::min`] does.
    #[inline]
    pub(super) fn min_along(&self, n: Vec3) -> f32 {
        let (nx, ny, nz) = (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
        let mut m = Vec4::INFINITY;
        for &[xs, ys, zs] in &self.chunks {
            let d = nx * xs + ny * ys + nz * zs;
            m = less(d, m);
        }
        Extent::reduce(m)
    }

    /// The smallest projections on `count` axes (`axis(f)` for `f` in order), each fed to
    /// `visit(f, axis, smallest)` until one returns `Some(x)`, which is returned as `(f,
    /// x)`. Four axes at a time by [`SoaPoints::min_along4`], the last one to three one at
    /// a time by [`SoaPoints::min_along`]: the same floats as `min_along` on each axis, and
    /// the same visits (an axis computed after the one that stops is not visited).
    #[inline(always)]
    pub(super) fn each_min<R>(
        &self,
        count: usize,
        axis: impl Fn(usize) -> Vec3,
        mut visit: impl FnMut(usize, Vec3, f32) -> Option<R>,
    ) -> Option<(usize, R)> {
        let mut f = 0;
        while f + 4 <= count {
            let ns = [axis(f), axis(f + 1), axis(f + 2), axis(f + 3)];
            let ms = self.min_along4(ns);
            for k in 0..4 {
                if let Some(x) = visit(f + k, ns[k], ms[k]) {
                    return Some((f + k, x));
                }
            }
            f += 4;
        }
        while f < count {
            let n = axis(f);
            if let Some(x) = visit(f, n, self.min_along(n)) {
                return Some((f, x));
            }
            f += 1;
        }
        None
    }

    /// [`SoaPoints::min_along`] on four axes at once, bitwise: each axis's lanes by the
    /// same products, sums and `minps` in the same chunk order, then the four reduced
    /// together ([`reduce4`]).
    #[inline]
    pub(super) fn min_along4(&self, ns: [Vec3; 4]) -> [f32; 4] {
        let splat = |n: Vec3| (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
        let (n0, n1, n2, n3) = (splat(ns[0]), splat(ns[1]), splat(ns[2]), splat(ns[3]));
        let mut m = [Vec4::INFINITY; 4];
        for &[xs, ys, zs] in &self.chunks {
            m[0] = less(n0.0 * xs + n0.1 * ys + n0.2 * zs, m[0]);
            m[1] = less(n1.0 * xs + n1.1 * ys + n1.2 * zs, m[1]);
            m[2] = less(n2.0 * xs + n2.1 * ys + n2.2 * zs, m[2]);
            m[3] = less(n3.0 * xs + n3.1 * ys + n3.2 * zs, m[3]);
        }
        reduce4(m[0], m[1], m[2], m[3])
    }
}

/// Four points (`ps`, at least four: the first four) as x, y and z lanes: the same floats
/// as `Vec4::new(p0.x, p1.x, p2.x, p3.x)` and so on, bitwise (moves and shuffles only). On
/// x86-64 the twelve floats, contiguous (`Vec3` is three `f32`s), are loaded as three
/// vectors and shuffled into place: building the lanes a float at a time cost about 25
/// instructions more a chunk, twice per remembered edge contact and step (issue 23).
#[inline(always)]
fn transpose4(ps: &[Vec3]) -> [Vec4; 3] {
    assert!(ps.len() >= 4);
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        use std::arch::x86_64::{_mm_loadu_ps, _mm_shuffle_ps};
        /// `_mm_shuffle_ps`'s mask: lanes `i0`, `i1` of the first operand, then `i2`, `i3`
        /// of the second.
        const fn pick(i0: i32, i1: i32, i2: i32, i3: i32) -> i32 {
            i0 | (i1 << 2) | (i2 << 4) | (i3 << 6)
        }
        // SAFETY: SSE, enabled for this target (the `cfg` above); the loads read the 48
        // bytes of the first four points (checked above), unaligned: `Vec3` is `repr(C)`,
        // three `f32`s with no padding, so a slice's points are contiguous floats.
        unsafe {
            let f = ps.as_ptr().cast::<f32>();
            let a = _mm_loadu_ps(f); // x0 y0 z0 x1
            let b = _mm_loadu_ps(f.add(4)); // y1 z1 x2 y2
            let c = _mm_loadu_ps(f.add(8)); // z2 x3 y3 z3
            let bc = _mm_shuffle_ps::<{ pick(2, 2, 1, 1) }>(b, c); // x2 x2 x3 x3
            let xs = _mm_shuffle_ps::<{ pick(0, 3, 0, 2) }>(a, bc);
            let ab = _mm_shuffle_ps::<{ pick(1, 1, 0, 0) }>(a, b); // y0 y0 y1 y1
            let bc = _mm_shuffle_ps::<{ pick(3, 3, 2, 2) }>(b, c); // y2 y2 y3 y3
            let ys = _mm_shuffle_ps::<{ pick(0, 2, 0, 2) }>(ab, bc);
            let ab = _mm_shuffle_ps::<{ pick(2, 2, 1, 1) }>(a, b); // z0 z0 z1 z1
            let cc = _mm_shuffle_ps::<{ pick(0, 3, 0, 3) }>(c, c); // z2 z3 z2 z3
            let zs = _mm_shuffle_ps::<{ pick(0, 2, 0, 1) }>(ab, cc);
            [Vec4::from(xs), Vec4::from(ys), Vec4::from(zs)]
        }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        let [p0, p1, p2, p3] = [ps[0], ps[1], ps[2], ps[3]];
        [
            Vec4::new(p0.x, p1.x, p2.x, p3.x),
            Vec4::new(p0.y, p1.y, p2.y, p3.y),
            Vec4::new(p0.z, p1.z, p2.z, p3.z),
        ]
    }
}

/// Feeds `chunks`' projections on `n` into `e` (see [`Extent`]), chunk by chunk in order.
#[inline(always)]
fn feed(n: Vec3, chunks: &[[Vec4; 3]], e: &mut Extent) {
    let (nx, ny, nz) = (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
    for &[xs, ys, zs] in chunks {
        // The products of `min_along(n)` and, negated, those of `min_along(-n)`
        // (`(-a) * b == -(a * b)` bitwise), summed in the same order, lane by lane.
        let (p, q, s) = (nx * xs, ny * ys, nz * zs);
        let d = p + q + s;
        let dn = -p - q - s;
        e.lo = less(d, e.lo);
        e.lo_neg = less(dn, e.lo_neg);
    }
}

/// [`Extent::reduce`] of four lane sets at once, bitwise: on x86-64 the lanes paired by
/// shuffles and reduced by `minps` (`if d < m { d } else { m }`, the same rule as the
/// scalar reduction's, with the same operands first): `[p0, p2, q0, q2]` against
/// `[p1, p3, q1, q3]` gives each set's `a` and `b`, then the `a`s against the `b`s.
#[inline(always)]
fn reduce4(p: Vec4, q: Vec4, r: Vec4, s: Vec4) -> [f32; 4] {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        use std::arch::x86_64::{_mm_min_ps, _mm_shuffle_ps};
        // SAFETY: SSE, enabled for this target (the `cfg` above); no memory is touched.
        unsafe {
            let pairs = |x: Vec4, y: Vec4| {
                let (x, y) = (x.into(), y.into());
                _mm_min_ps(
                    _mm_shuffle_ps::<0b10_00_10_00>(x, y),
                    _mm_shuffle_ps::<0b11_01_11_01>(x, y),
                )
            };
            let (m, n) = (pairs(p, q), pairs(r, s));
            let a = _mm_shuffle_ps::<0b10_00_10_00>(m, n);
            let b = _mm_shuffle_ps::<0b11_01_11_01>(m, n);
            Vec4::from(_mm_min_ps(a, b)).to_array()
        }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        [p, q, r, s].map(Extent::reduce)
    }
}

/// The smallest and largest projections of some points on an axis, accumulated chunk by
/// chunk in the lanes of [`SoaPoints::min_along`]: fed all the chunks, [`Extent::min`] is
/// bitwise `min_along(n)` and [`Extent::max`] bitwise `-min_along(-n)`; fed some, they bound
/// those from inside (a minimum no smaller, a maximum no larger).
pub(super) struct Extent {
    lo: Vec4,
    lo_neg: Vec4,
}

/// `if d < m { d } else { m }` lane by lane: on x86-64 the one instruction `minps`, which
/// is that rule exactly (the second operand on a tie, such as `-0` against `0`, or when
/// either is a NaN).
#[inline(always)]
fn less(d: Vec4, m: Vec4) -> Vec4 {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        // SAFETY: `minps` is SSE, enabled for this target (the `cfg` above).
        Vec4::from(unsafe { std::arch::x86_64::_mm_min_ps(d.into(), m.into()) })
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        Vec4::select(d.cmplt(m), d, m)
    }
}

impl Extent {
    /// Nothing fed yet.
    #[inline]
    pub(super) fn new() -> Self {
        Self {
            lo: Vec4::INFINITY,
            lo_neg: Vec4::INFINITY,
        }
    }

    /// The lanes reduced to their smallest: lanes 0 and 1, 2 and 3, then the two (the
    /// first kept on a tie).
    #[inline]
    fn reduce(m: Vec4) -> f32 {
        let m = m.to_array();
        let a = if m[0] < m[1] { m[0] } else { m[1] };
        let b = if m[2] < m[3] { m[2] } else { m[3] };
        if a < b { a } else { b }
    }

    /// Smallest projection fed.
    #[cfg(test)]
    pub(super) fn min(&self) -> f32 {
        Self::reduce(self.lo)
    }

    /// Largest projection fed.
    #[cfg(test)]
    pub(super) fn max(&self) -> f32 {
        -Self::reduce(self.lo_neg)
    }

    /// `[a.min(), a.max(), b.min(), b.max()]`, bitwise, the four reductions made together
    /// ([`reduce4`]).
    #[inline(always)]
    pub(super) fn bounds(a: &Extent, b: &Extent) -> [f32; 4] {
        let [min_a, lo_a, min_b, lo_b] = reduce4(a.lo, a.lo_neg, b.lo, b.lo_neg);
        [min_a, -lo_a, min_b, -lo_b]
    }
}

#[cfg(test)]
mod tests {
    use super::{Extent, SoaPoints, reduce4};
    use glam::{Vec3, Vec4};

    /// A xorshift generator and floats from it: mostly ordinary values, with zeros of both
    /// signs, infinities, NaN, subnormals and raw bit patterns mixed in.
    struct Floats(u64);

    impl Floats {
        fn bits(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }

        fn any(&mut self) -> f32 {
            let r = self.bits();
            match r % 16 {
                0 => 0.0,
                1 => -0.0,
                2 => f32::INFINITY,
                3 => f32::NEG_INFINITY,
                4 => f32::NAN,
                5 => f32::from_bits((r >> 32) as u32),
                6 => f32::from_bits((r >> 41) as u32 & 0x007f_ffff),
                // A few repeated values, for ties.
                7 => [1.0, -1.0, 0.5][(r >> 20) as usize % 3],
                _ => self.ordinary(),
            }
        }

        fn ordinary(&mut self) -> f32 {
            let r = self.bits();
            ((r >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 4.0
        }
    }

    /// `reduce4` and `Extent::bounds` against `Extent::reduce`, `min` and `max` one at a
    /// time, bitwise, on random lanes with ties of `0` and `-0`, infinities and NaNs.
    #[test]
    fn reductions_four_at_once_are_the_reductions_one_at_a_time() {
        let mut g = Floats(0x9e37_79b9_7f4a_7c15);
        for case in 0..200_000 {
            let mut lanes = || Vec4::new(g.any(), g.any(), g.any(), g.any());
            let (p, q, r, s) = (lanes(), lanes(), lanes(), lanes());
            let got = reduce4(p, q, r, s).map(f32::to_bits);
            let want = [p, q, r, s].map(|v| Extent::reduce(v).to_bits());
            assert_eq!(got, want, "case {case}: {p:?} {q:?} {r:?} {s:?}");
            let (a, b) = (Extent { lo: p, lo_neg: q }, Extent { lo: r, lo_neg: s });
            let got = Extent::bounds(&a, &b).map(f32::to_bits);
            let want = [a.min(), a.max(), b.min(), b.max()].map(f32::to_bits);
            assert_eq!(got, want, "case {case}");
        }
    }

    /// `fill` lays the points out chunk by chunk (chunk `c`, lane `j`: point `4c + j`, the
    /// last chunk padded with the first point), bitwise, into one buffer reused for counts
    /// that rise and fall (0 to 13 points, NaNs, infinities and signed zeros among them).
    #[test]
    fn fill_lays_the_points_out_in_chunks_of_four() {
        let mut g = Floats(0x6a09_e667_f3bc_c909);
        let mut soa = SoaPoints::default();
        for case in 0..20_000 {
            let count = (g.bits() % 14) as usize;
            let pts: Vec<Vec3> = (0..count)
                .map(|_| Vec3::new(g.any(), g.any(), g.any()))
                .collect();
            soa.fill(&pts);
            assert_eq!(soa.chunks.len(), count.div_ceil(4), "case {case}");
            for (c, &[xs, ys, zs]) in soa.chunks.iter().enumerate() {
                let lanes = [xs, ys, zs].map(|v| v.to_array());
                for (j, want) in (4 * c..4 * c + 4).map(|k| pts.get(k)).enumerate() {
                    let p = *want.unwrap_or(&pts[0]);
                    let got = lanes.map(|lane| lane[j].to_bits());
                    assert_eq!(got, p.to_array().map(f32::to_bits), "case {case} {c} {j}");
                }
            }
        }
    }

    /// `fill_moved` against `fill` of the points moved one by one as the narrow phase moves
    /// them (`rot * p + t`, glam's `Mat3 * Vec3`), bitwise, lanes and padding alike, into
    /// one buffer reused for counts that rise and fall (0 to 13 points); and `points_into`
    /// gives the moved points back, bitwise (the padding lanes as the first point), into a
    /// reused buffer. Random rotations (from quaternions, as the narrow
    /// phase builds them) and offsets, points with signed zeros, subnormals, large and
    /// tiny magnitudes among ordinary values (no NaN or infinity: their payloads and
    /// signs are not part of the contract).
    #[test]
    fn moved_lanes_are_the_moved_points_laid_out() {
        let mut g = Floats(0x3c6e_f372_fe94_f82b);
        let mut finite = || loop {
            let x = g.any();
            if x.is_finite() {
                break x;
            }
        };
        let (mut moved, mut want) = (SoaPoints::default(), SoaPoints::default());
        // Reused, with what the last case left in it.
        let mut back = vec![Vec3::NAN; 3];
        let mut checked = 0;
        for case in 0..20_000 {
            let count = (case * 7 + case / 13) % 14;
            let q = glam::Quat::from_xyzw(finite(), finite(), finite(), finite());
            let q = if q.length_squared() > 1e-6 {
                q.normalize()
            } else {
                glam::Quat::IDENTITY
            };
            let rot = glam::Mat3::from_quat(q);
            let t = Vec3::new(finite(), finite(), finite());
            let pts: Vec<Vec3> = (0..count)
                .map(|_| Vec3::new(finite(), finite(), finite()))
                .collect();
            let src = SoaPoints::of(&pts);
            moved.fill_moved(&src, rot, t);
            let world: Vec<Vec3> = pts.iter().map(|&p| rot * p + t).collect();
            want.fill(&world);
            let bits = |s: &SoaPoints| {
                (s.chunks.iter())
                    .flat_map(|c| c.map(|v| v.to_array().map(f32::to_bits)))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&moved), bits(&want), "case {case}: {rot:?} {t:?}");
            // Back as points: all of them, or the first few (a shorter `len`).
            let len = if case % 3 == 0 {
                count / 2
            } else {
                count + case % 5
            };
            moved.points_into(&mut back, len);
            assert_eq!(back.len(), len.min(4 * count.div_ceil(4)), "case {case}");
            for (i, p) in back.iter().enumerate() {
                let want = *world.get(i).or(world.first()).unwrap_or(&Vec3::NAN);
                let got = p.to_array().map(f32::to_bits);
                assert_eq!(
                    got,
                    want.to_array().map(f32::to_bits),
                    "case {case}, point {i}"
                );
                checked += 1;
            }
        }
        assert!(checked > 100_000, "{checked}");
    }

    /// The lanes a polyhedron keeps are its vertices: the smallest projection on random
    /// axes by the lanes against the plain smallest over `vertices` (by value), and the
    /// lanes laid out anew from `vertices` (bitwise), for hulls of random clouds and their
    /// copies moved by `map_vertices`.
    #[test]
    fn a_polyhedrons_lanes_are_its_vertices() {
        let mut g = Floats(0x5851_f42d_4c95_7f2d);
        let mut shapes = 0;
        for case in 0..400 {
            let count = 4 + case % 40;
            let pts: Vec<Vec3> = (0..count)
                .map(|_| Vec3::new(g.ordinary(), g.ordinary(), g.ordinary()))
                .collect();
            let Ok(hull) = crate::hull::convex_hull(&pts) else {
                continue;
            };
            let shift = Vec3::new(g.ordinary(), g.ordinary(), g.ordinary());
            for p in [hull.clone(), hull.map_vertices(|v| 2.0 * v + shift)] {
                shapes += 1;
                for _ in 0..8 {
                    let n = Vec3::new(g.ordinary(), g.ordinary(), g.ordinary());
                    let brute = p
                        .vertices
                        .iter()
                        .map(|v| n.x * v.x + n.y * v.y + n.z * v.z)
                        .fold(f32::INFINITY, f32::min);
                    assert_eq!(p.lanes().min_along(n), brute, "case {case}");
                }
                assert_eq!(p.lanes(), &SoaPoints::of(&p.vertices), "case {case}");
            }
        }
        assert!(shapes > 600);
    }

    /// `min_along4` and `each_min` against `min_along` axis by axis (bitwise), and
    /// `min_along` against the plain smallest projection of the points (by value), on
    /// random point sets of 1 to 40 points and random axes.
    #[test]
    fn four_axes_at_once_are_the_axes_one_at_a_time() {
        let mut g = Floats(0x2545_f491_4f6c_dd1d);
        let mut soa = SoaPoints::default();
        for case in 0..20_000 {
            let count = 1 + (g.bits() % 40) as usize;
            let pts: Vec<Vec3> = (0..count)
                .map(|_| Vec3::new(g.ordinary(), g.ordinary(), g.ordinary()))
                .collect();
            soa.fill(&pts);
            let axes = 1 + (g.bits() % 11) as usize;
            let ns: Vec<Vec3> = (0..axes)
                .map(|_| Vec3::new(g.ordinary(), g.ordinary(), g.ordinary()))
                .collect();
            for (k, &n) in ns.iter().enumerate() {
                let brute = pts
                    .iter()
                    .map(|p| n.x * p.x + n.y * p.y + n.z * p.z)
                    .fold(f32::INFINITY, f32::min);
                assert_eq!(soa.min_along(n), brute, "case {case}, axis {k}");
            }
            let four = [0, 1, 2, 3].map(|k| ns[k % axes]);
            let got = soa.min_along4(four).map(f32::to_bits);
            let want = four.map(|n| soa.min_along(n).to_bits());
            assert_eq!(got, want, "case {case}");
            // Visits in order, stopping where the visitor says (or never).
            let stop = (g.bits() % (axes as u64 + 1)) as usize;
            let mut seen = Vec::new();
            let found = soa.each_min(
                axes,
                |f| ns[f],
                |f, n, m| {
                    assert_eq!(n, ns[f]);
                    seen.push((f, m.to_bits()));
                    (f == stop).then_some(m)
                },
            );
            let want: Vec<_> = (0..axes.min(stop + 1))
                .map(|f| (f, soa.min_along(ns[f]).to_bits()))
                .collect();
            assert_eq!(seen, want, "case {case}");
            let want = (stop < axes).then(|| (stop, want[stop].1));
            assert_eq!(found.map(|(f, m)| (f, m.to_bits())), want, "case {case}");
        }
    }
}

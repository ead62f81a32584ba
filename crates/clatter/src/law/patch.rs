//! The patch law's per-point work ([`super::contact_force_in`] on manifolds of two to four
//! points): the sums over the points (centroid and depth), the normal spring-dashpot's force
//! and torques, and the patch radius. On x86_64 the points' arithmetic runs four points at a
//! time, one point per SSE lane ([`lanes`]); elsewhere point by point ([`scalar`], the
//! law as it was written, kept as the lanes' reference).
//!
//! Same bits: each lane does the scalar law's IEEE operations on the same values in the
//! same order (glam's `Vec3A` is lane-wise too: a dot product `(x x' + y y') + z z'`, a
//! cross product's lanes `a.y b.z - a.z b.y`, ...; no fused multiply-adds on either side),
//! and the sums over the points are added point after point from the same start as the
//! scalar loops, after transposing the lanes' results back into one vector per point.

use glam::Vec3A;

use super::MotionA;
use clatter_geom::narrow::Manifold;

/// The sums of the patch's normal law over its points: force on side b, torques on a and
/// b (about their centres), and the normal force, each added in point order from zero.
#[derive(Clone, Copy)]
pub(super) struct NormalSums {
    pub(super) force_b: Vec3A,
    pub(super) torque_a: Vec3A,
    pub(super) torque_b: Vec3A,
    pub(super) normal_force: f32,
}

#[cfg(target_arch = "x86_64")]
pub(super) use lanes::{Patch, f4};
#[cfg(not(target_arch = "x86_64"))]
pub(super) use scalar::{Patch, f4};

/// The points one at a time: the law's loops as they were written.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
pub(super) mod scalar {
    use super::*;
    use clatter_geom::narrow::ContactPoint;

    /// Four floats, one per point.
    pub(in crate::law) type F4 = [f32; 4];

    /// `a` as [`F4`].
    #[inline(always)]
    pub(in crate::law) fn f4(a: [f32; 4]) -> F4 {
        a
    }

    /// A manifold's used points.
    pub(in crate::law) struct Patch<'m> {
        pts: &'m [ContactPoint],
    }

    impl<'m> Patch<'m> {
        /// The used points of `m` (two to four).
        #[inline(always)]
        pub(in crate::law) fn of(m: &'m Manifold) -> Self {
            Patch { pts: m.points() }
        }

        /// The sum of the points' positions and the sum of their depths, from zero.
        #[inline(always)]
        pub(in crate::law) fn sums(&self) -> (Vec3A, f32) {
            let mut centroid = Vec3A::ZERO;
            let mut depth = 0.0;
            for cp in self.pts {
                centroid += Vec3A::from(cp.point);
                depth += cp.depth;
            }
            (centroid, depth)
        }

        /// Each point's linear spring force `k depth`.
        #[inline(always)]
        pub(in crate::law) fn linear_springs(&self, k: f32) -> F4 {
            let mut fs = [0.0; 4];
            for (f, cp) in fs.iter_mut().zip(self.pts) {
                *f = k * cp.depth;
            }
            fs
        }

        /// Each point's normal force `fs - eta vrel.n` along `n` at the point, with
        /// spring force `fs[i]` and damping `eta[i]`, summed.
        #[inline(always)]
        pub(in crate::law) fn normal_sums(
            &self,
            n: Vec3A,
            ma: &MotionA,
            mb: &MotionA,
            fs: F4,
            eta: F4,
        ) -> NormalSums {
            let (mut force_b, mut torque_a, mut torque_b) = (Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO);
            let mut normal_force = 0.0;
            for (i, cp) in self.pts.iter().enumerate() {
                let point = Vec3A::from(cp.point);
                let vrel = mb.point_velocity(point) - ma.point_velocity(point);
                let fn_i = fs[i] - eta[i] * vrel.dot(n);
                let f = n * fn_i;
                force_b += f;
                torque_b += (point - mb.position).cross(f);
                torque_a += f.cross(point - ma.position);
                normal_force += fn_i;
            }
            NormalSums {
                force_b,
                torque_a,
                torque_b,
                normal_force,
            }
        }

        /// The points' mean distance from `centroid` across the unit normal `n`, times the
        /// point count (the sum).
        #[inline(always)]
        pub(in crate::law) fn radius_sum(&self, centroid: Vec3A, n: Vec3A) -> f32 {
            self.pts
                .iter()
                .map(|cp| {
                    (Vec3A::from(cp.point) - centroid)
                        .reject_from_normalized(n)
                        .length()
                })
                .sum::<f32>()
        }
    }
}

/// The points four at a time, one per SSE lane.
///
/// Safety (every `unsafe` block here): the intrinsics need SSE and SSE2, which every
/// x86_64 target has (its baseline: no runtime test); the assertion below stops a build
/// for a target without them.
#[cfg(target_arch = "x86_64")]
pub(super) mod lanes {
    use std::arch::x86_64::*;

    const _: () = assert!(cfg!(target_feature = "sse2"), "SSE2 is x86_64's baseline");

    use super::*;
    use clatter_geom::narrow::ContactPoint;

    /// Three coordinates of four points, one point per lane.
    #[derive(Clone, Copy)]
    struct V4 {
        x: __m128,
        y: __m128,
        z: __m128,
    }

    impl V4 {
        /// `v` in every lane.
        #[inline(always)]
        fn splat(v: Vec3A) -> V4 {
            // SAFETY: SSE (module note).
            unsafe {
                V4 {
                    x: _mm_set1_ps(v.x),
                    y: _mm_set1_ps(v.y),
                    z: _mm_set1_ps(v.z),
                }
            }
        }

        #[inline(always)]
        fn add(self, o: V4) -> V4 {
            // SAFETY: SSE (module note).
            unsafe {
                V4 {
                    x: _mm_add_ps(self.x, o.x),
                    y: _mm_add_ps(self.y, o.y),
                    z: _mm_add_ps(self.z, o.z),
                }
            }
        }

        #[inline(always)]
        fn sub(self, o: V4) -> V4 {
            // SAFETY: SSE (module note).
            unsafe {
                V4 {
                    x: _mm_sub_ps(self.x, o.x),
                    y: _mm_sub_ps(self.y, o.y),
                    z: _mm_sub_ps(self.z, o.z),
                }
            }
        }

        /// Each coordinate times `s` (`Vec3A * f32`'s lanes).
        #[inline(always)]
        fn scale(self, s: __m128) -> V4 {
            // SAFETY: SSE (module note).
            unsafe {
                V4 {
                    x: _mm_mul_ps(self.x, s),
                    y: _mm_mul_ps(self.y, s),
                    z: _mm_mul_ps(self.z, s),
                }
            }
        }

        /// `Vec3A::dot`: `(x x' + y y') + z z'`.
        #[inline(always)]
        fn dot(self, o: V4) -> __m128 {
            // SAFETY: SSE (module note).
            unsafe {
                let xy = _mm_add_ps(_mm_mul_ps(self.x, o.x), _mm_mul_ps(self.y, o.y));
                _mm_add_ps(xy, _mm_mul_ps(self.z, o.z))
            }
        }

        /// `Vec3A::cross`: `(y z' - z y', z x' - x z', x y' - y x')`.
        #[inline(always)]
        fn cross(self, o: V4) -> V4 {
            // SAFETY: SSE (module note).
            unsafe {
                V4 {
                    x: _mm_sub_ps(_mm_mul_ps(self.y, o.z), _mm_mul_ps(self.z, o.y)),
                    y: _mm_sub_ps(_mm_mul_ps(self.z, o.x), _mm_mul_ps(self.x, o.z)),
                    z: _mm_sub_ps(_mm_mul_ps(self.x, o.y), _mm_mul_ps(self.y, o.x)),
                }
            }
        }
    }

    /// Rows to columns (and back): `r[i]`'s lane `j` becomes lane `i` of the result's `j`.
    #[inline(always)]
    fn transpose(r: [__m128; 4]) -> [__m128; 4] {
        // SAFETY: SSE (module note).
        unsafe {
            let t0 = _mm_unpacklo_ps(r[0], r[1]);
            let t1 = _mm_unpacklo_ps(r[2], r[3]);
            let t2 = _mm_unpackhi_ps(r[0], r[1]);
            let t3 = _mm_unpackhi_ps(r[2], r[3]);
            [
                _mm_movelh_ps(t0, t1),
                _mm_movehl_ps(t1, t0),
                _mm_movelh_ps(t2, t3),
                _mm_movehl_ps(t3, t2),
            ]
        }
    }

    /// `rows[0] + rows[1] + ...` over the first `count` rows, from zero, in row order:
    /// each lane the scalar loop's additions.
    #[inline(always)]
    fn sum_rows(rows: [__m128; 4], count: usize) -> __m128 {
        // SAFETY: SSE (module note).
        unsafe {
            let mut s = _mm_add_ps(_mm_setzero_ps(), rows[0]);
            s = _mm_add_ps(s, rows[1]);
            if count > 2 {
                s = _mm_add_ps(s, rows[2]);
            }
            if count > 3 {
                s = _mm_add_ps(s, rows[3]);
            }
            s
        }
    }

    /// Lane 3 of `v`.
    #[inline(always)]
    fn lane3(v: __m128) -> f32 {
        // SAFETY: SSE (module note).
        unsafe { _mm_cvtss_f32(_mm_shuffle_ps(v, v, 0b11_11_11_11)) }
    }

    /// Four floats, one per point.
    pub(in crate::law) type F4 = __m128;

    /// `a` as [`F4`].
    #[inline(always)]
    pub(in crate::law) fn f4(a: [f32; 4]) -> F4 {
        // SAFETY: SSE (module note).
        unsafe { _mm_setr_ps(a[0], a[1], a[2], a[3]) }
    }

    // A point is one 16-byte row `(x, y, z, depth)` in memory, loaded as such.
    const _: () = assert!(
        size_of::<ContactPoint>() == 16
            && std::mem::offset_of!(ContactPoint, point) == 0
            && std::mem::offset_of!(ContactPoint, depth) == 12
            && size_of::<glam::Vec3>() == 12
    );

    /// A manifold's points: one row `(x, y, z, depth)` per point and the same as columns.
    /// All four slots are read; the lanes of unused ones are computed and never added.
    pub(in crate::law) struct Patch {
        count: usize,
        rows: [__m128; 4],
        p: V4,
        depth: __m128,
    }

    impl Patch {
        /// The points of `m` (two to four used).
        #[inline(always)]
        pub(in crate::law) fn of(m: &Manifold) -> Self {
            debug_assert!((2..=4).contains(&m.count));
            let row = |i: usize| {
                let cp: *const ContactPoint = &m.points[i];
                // SAFETY: SSE (module note); the point is 16 bytes, `x, y, z, depth` (the
                // layout assertion above), read unaligned.
                unsafe { _mm_loadu_ps(cp.cast::<f32>()) }
            };
            let rows = [row(0), row(1), row(2), row(3)];
            let [x, y, z, depth] = transpose(rows);
            Patch {
                count: m.count,
                rows,
                p: V4 { x, y, z },
                depth,
            }
        }

        /// The sum of the points' positions and the sum of their depths, from zero
        /// (the depth in the rows' fourth lane, added alongside).
        #[inline(always)]
        pub(in crate::law) fn sums(&self) -> (Vec3A, f32) {
            let s = sum_rows(self.rows, self.count);
            (Vec3A::from(s), lane3(s))
        }

        /// Each point's linear spring force `k depth`.
        #[inline(always)]
        pub(in crate::law) fn linear_springs(&self, k: f32) -> F4 {
            // SAFETY: SSE (module note).
            unsafe { _mm_mul_ps(_mm_set1_ps(k), self.depth) }
        }

        /// Each point's normal force `fs - eta vrel.n` along `n` at the point, with
        /// spring force `fs[i]` and damping `eta[i]`, summed.
        #[inline(always)]
        pub(in crate::law) fn normal_sums(
            &self,
            n: Vec3A,
            ma: &MotionA,
            mb: &MotionA,
            fs: F4,
            eta: F4,
        ) -> NormalSums {
            // SAFETY: SSE (module note).
            unsafe {
                let p = self.p;
                // `point - position`, as the point's velocity and the torque use it.
                let rb = p.sub(V4::splat(mb.position));
                let ra = p.sub(V4::splat(ma.position));
                let vb = V4::splat(mb.velocity).add(V4::splat(mb.omega).cross(rb));
                let va = V4::splat(ma.velocity).add(V4::splat(ma.omega).cross(ra));
                let nv = V4::splat(n);
                let vn = vb.sub(va).dot(nv);
                let fn_i = _mm_sub_ps(fs, _mm_mul_ps(eta, vn));
                let f = nv.scale(fn_i);
                let tb = rb.cross(f);
                let ta = f.cross(ra);
                let force = sum_rows(transpose([f.x, f.y, f.z, fn_i]), self.count);
                let zero = _mm_setzero_ps();
                let torque_b = sum_rows(transpose([tb.x, tb.y, tb.z, zero]), self.count);
                let torque_a = sum_rows(transpose([ta.x, ta.y, ta.z, zero]), self.count);
                NormalSums {
                    force_b: Vec3A::from(force),
                    torque_a: Vec3A::from(torque_a),
                    torque_b: Vec3A::from(torque_b),
                    normal_force: lane3(force),
                }
            }
        }

        /// The points' mean distance from `centroid` across the unit normal `n`, times the
        /// point count (the sum, in point order as `Iterator::sum` adds).
        #[inline(always)]
        pub(in crate::law) fn radius_sum(&self, centroid: Vec3A, n: Vec3A) -> f32 {
            // SAFETY: SSE (module note).
            unsafe {
                let d = self.p.sub(V4::splat(centroid));
                let nv = V4::splat(n);
                // `reject_from_normalized`: `d - n (d.n)`; then `length`.
                let r = d.sub(nv.scale(d.dot(nv)));
                let len = _mm_sqrt_ps(r.dot(r));
                let mut l = [0.0f32; 4];
                // `l` holds four floats, the store is unaligned.
                _mm_storeu_ps(l.as_mut_ptr(), len);
                l[..self.count].iter().sum::<f32>()
            }
        }
    }
}

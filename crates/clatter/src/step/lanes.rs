//! Eight lanes of `f32` in an AVX2 register, with the operations the hot stages' lane
//! builds use ([`super::sphere_lanes`], [`super::integrate_lanes`]): each the IEEE
//! operation Rust's scalar (or glam's) code does, so a lane gives the scalar path's bits.

use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

use glam::Vec3;

/// Eight `f32` lanes. Values exist only inside the AVX2 functions of this module, so the
/// CPU has AVX2 wherever one is used.
#[derive(Clone, Copy)]
pub(super) struct F8(pub(super) __m256);

/// Eight lane masks (all bits set: true), from comparisons of [`F8`]s.
#[derive(Clone, Copy)]
pub(super) struct M8(pub(super) __m256);

macro_rules! binary {
    ($($trait:ident $method:ident $op:ident;)*) => {$(
        impl $trait for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, rhs: F8) -> F8 {
                // SAFETY: an `F8` exists only where the CPU has AVX2 (see `F8`).
                F8(unsafe { $op(self.0, rhs.0) })
            }
        }
    )*};
}

binary! {
    Add add _mm256_add_ps;
    Sub sub _mm256_sub_ps;
    Mul mul _mm256_mul_ps;
    Div div _mm256_div_ps;
}

impl Neg for F8 {
    type Output = F8;
    /// The sign bit flipped, as Rust's `-x`.
    #[inline(always)]
    fn neg(self) -> F8 {
        // SAFETY: see `F8`.
        F8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
    }
}

impl F8 {
    #[inline(always)]
    pub(super) fn splat(v: f32) -> F8 {
        // SAFETY: called only from this module's AVX2 functions (see `F8`).
        F8(unsafe { _mm256_set1_ps(v) })
    }

    #[inline(always)]
    pub(super) fn sqrt(self) -> F8 {
        // SAFETY: see `F8`.
        F8(unsafe { _mm256_sqrt_ps(self.0) })
    }

    /// `|x|`: the sign bit cleared, as Rust's `abs`.
    #[inline(always)]
    pub(super) fn abs(self) -> F8 {
        // SAFETY: see `F8`.
        F8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
    }

    /// `self > c ? self : c`: Rust's `self.max(c)` for a constant `c` that is not NaN.
    #[inline(always)]
    pub(super) fn max_const(self, c: f32) -> F8 {
        // SAFETY: see `F8`.
        F8(unsafe { _mm256_max_ps(self.0, _mm256_set1_ps(c)) })
    }

    /// `self > rhs` (false where either is NaN).
    #[inline(always)]
    pub(super) fn gt(self, rhs: F8) -> M8 {
        // SAFETY: see `F8`.
        M8(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, rhs.0) })
    }

    /// `self < rhs` (false where either is NaN).
    #[inline(always)]
    pub(super) fn lt(self, rhs: F8) -> M8 {
        // SAFETY: see `F8`.
        M8(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, rhs.0) })
    }

    /// `self == rhs` (false where either is NaN).
    #[inline(always)]
    pub(super) fn eq(self, rhs: F8) -> M8 {
        // SAFETY: see `F8`.
        M8(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, rhs.0) })
    }

    /// `self != rhs` (true where either is NaN).
    #[inline(always)]
    pub(super) fn ne(self, rhs: F8) -> M8 {
        // SAFETY: see `F8`.
        M8(unsafe { _mm256_cmp_ps::<_CMP_NEQ_UQ>(self.0, rhs.0) })
    }

    /// `m ? a : b` per lane.
    #[inline(always)]
    pub(super) fn select(m: M8, a: F8, b: F8) -> F8 {
        // SAFETY: see `F8`.
        F8(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
    }
}

impl M8 {
    #[inline(always)]
    pub(super) fn and(self, rhs: M8) -> M8 {
        // SAFETY: see `F8`.
        M8(unsafe { _mm256_and_ps(self.0, rhs.0) })
    }

    #[inline(always)]
    pub(super) fn or(self, rhs: M8) -> M8 {
        // SAFETY: see `F8`.
        M8(unsafe { _mm256_or_ps(self.0, rhs.0) })
    }

    /// `!self & rhs`.
    #[inline(always)]
    pub(super) fn and_not(self, rhs: M8) -> M8 {
        // SAFETY: see `F8`.
        M8(unsafe { _mm256_andnot_ps(self.0, rhs.0) })
    }

    /// Lane `l`'s mask in bit `l`.
    #[inline(always)]
    pub(super) fn bits(self) -> u32 {
        // SAFETY: see `F8`.
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }
}

/// Eight [`Vec3`]s, one per lane; the operations are glam's, component by component in
/// glam's order.
#[derive(Clone, Copy)]
pub(super) struct V3 {
    pub(super) x: F8,
    pub(super) y: F8,
    pub(super) z: F8,
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, r: V3) -> V3 {
        V3 {
            x: self.x + r.x,
            y: self.y + r.y,
            z: self.z + r.z,
        }
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, r: V3) -> V3 {
        V3 {
            x: self.x - r.x,
            y: self.y - r.y,
            z: self.z - r.z,
        }
    }
}

impl Mul<F8> for V3 {
    type Output = V3;
    /// `v * s` (glam's `Vec3 * f32`, and `f32 * Vec3`: products commute).
    #[inline(always)]
    fn mul(self, s: F8) -> V3 {
        V3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

impl Div<F8> for V3 {
    type Output = V3;
    #[inline(always)]
    fn div(self, s: F8) -> V3 {
        V3 {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }
}

impl V3 {
    /// glam's `dot`: `(x x' + y y') + z z'`.
    #[inline(always)]
    pub(super) fn dot(self, r: V3) -> F8 {
        self.x * r.x + self.y * r.y + self.z * r.z
    }

    #[inline(always)]
    pub(super) fn length_squared(self) -> F8 {
        self.dot(self)
    }

    /// glam's `cross`, term for term.
    #[inline(always)]
    pub(super) fn cross(self, r: V3) -> V3 {
        V3 {
            x: self.y * r.z - r.y * self.z,
            y: self.z * r.x - r.z * self.x,
            z: self.x * r.y - r.x * self.y,
        }
    }

    #[inline(always)]
    pub(super) fn select(m: M8, a: V3, b: V3) -> V3 {
        V3 {
            x: F8::select(m, a.x, b.x),
            y: F8::select(m, a.y, b.y),
            z: F8::select(m, a.z, b.z),
        }
    }

    #[inline(always)]
    pub(super) fn splat(v: Vec3) -> V3 {
        V3 {
            x: F8::splat(v.x),
            y: F8::splat(v.y),
            z: F8::splat(v.z),
        }
    }
}

/// Lane `l` of `idx` (`base`-relative indices of `f32`s) read from `base`.
///
/// # Safety
/// AVX2; every `base + idx[l]` must be in bounds.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn gather(base: *const f32, idx: __m256i) -> F8 {
    // SAFETY: the caller's.
    F8(unsafe { _mm256_i32gather_ps::<4>(base, idx) })
}

/// The three components of the `Vec3`s `v[idx[l]]`.
///
/// # Safety
/// AVX2; every `idx[l] < v.len()`.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn gather_vec3(v: &[Vec3], idx: __m256i) -> V3 {
    let base = v.as_ptr() as *const f32;
    let at = _mm256_mullo_epi32(idx, _mm256_set1_epi32(3));
    let one = _mm256_set1_epi32(1);
    // SAFETY: `Vec3` is three packed `f32`s; the caller bounds `idx`.
    unsafe {
        V3 {
            x: gather(base, at),
            y: gather(base, _mm256_add_epi32(at, one)),
            z: gather(base, _mm256_add_epi32(at, _mm256_add_epi32(one, one))),
        }
    }
}

/// [`gather_vec3`] by plain loads: each `v[idx[l]]` read as one 16-byte load (with the
/// float after it, thrown away) and the eight transposed, which takes fewer cycles than
/// three gathers. Where an index is the last one (no float after it), the gathers.
///
/// # Safety
/// AVX2; every `idx[l] < v.len()`.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn load_vec3_at(v: &[Vec3], idx: __m256i) -> V3 {
    let top = _mm256_set1_epi32(v.len() as i32 - 2);
    let below_last = _mm256_cmpeq_epi32(_mm256_max_epu32(idx, top), top);
    if v.len() < 2 || _mm256_movemask_epi8(below_last) != -1 {
        // SAFETY: the caller's.
        return unsafe { gather_vec3(v, idx) };
    }
    let mut ids = [0u32; 8];
    // SAFETY: 8 `u32`s.
    unsafe { _mm256_storeu_si256(ids.as_mut_ptr() as *mut __m256i, idx) };
    let base = v.as_ptr() as *const f32;
    let mut r = [_mm256_setzero_ps(); 4];
    for (l, r) in r.iter_mut().enumerate() {
        // SAFETY: 16 bytes from `v[k]`, `k + 1 < v.len()` (checked above).
        *r = unsafe {
            _mm256_insertf128_ps::<1>(
                _mm256_castps128_ps256(_mm_loadu_ps(base.add(3 * ids[l] as usize))),
                _mm_loadu_ps(base.add(3 * ids[l + 4] as usize)),
            )
        };
    }
    // Lanes l and l + 4 of each row hold bodies l and l + 4: a 4x4 transpose per half.
    let (t0, t1) = (
        _mm256_unpacklo_ps(r[0], r[1]),
        _mm256_unpackhi_ps(r[0], r[1]),
    );
    let (t2, t3) = (
        _mm256_unpacklo_ps(r[2], r[3]),
        _mm256_unpackhi_ps(r[2], r[3]),
    );
    V3 {
        x: F8(_mm256_shuffle_ps::<0x44>(t0, t2)),
        y: F8(_mm256_shuffle_ps::<0xEE>(t0, t2)),
        z: F8(_mm256_shuffle_ps::<0x44>(t1, t3)),
    }
}

/// Eight contiguous `Vec3`s (24 `f32`s) split into lanes. The inverse of [`store_vec3`].
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn load_vec3(v: &[Vec3; 8]) -> V3 {
    let p = v.as_ptr() as *const f32;
    // SAFETY: 24 `f32`s from `p`.
    let (a, b, c) = unsafe {
        (
            _mm256_loadu_ps(p),
            _mm256_loadu_ps(p.add(8)),
            _mm256_loadu_ps(p.add(16)),
        )
    };
    // a = x0 y0 z0 x1 y1 z1 x2 y2, b = z2 x3 y3 z3 x4 y4 z4 x5, c = y5 z5 x6 y6 z6 x7 y7 z7:
    // each of x, y, z is spread over the three in the pattern that `store_vec3` writes; blend
    // it together, then put its lanes in order.
    let px = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0010_0100>(a, c), b);
    let py = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0010_0100>(c, b), a);
    let pz = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0010_0100>(b, a), c);
    V3 {
        x: F8(_mm256_permutevar8x32_ps(
            px,
            _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5),
        )),
        y: F8(_mm256_permutevar8x32_ps(
            py,
            _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6),
        )),
        z: F8(_mm256_permutevar8x32_ps(
            pz,
            _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7),
        )),
    }
}

/// Lanes stored as eight contiguous `Vec3`s.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn store_vec3(v: V3, out: &mut [Vec3; 8]) {
    // Each permuted so that its lanes sit where the interleaved layout wants them in one of
    // the three registers: x0 x3 x6 x1 x4 x7 x2 x5, y5 y0 y3 y6 y1 y4 y7 y2,
    // z2 z5 z0 z3 z6 z1 z4 z7.
    let px = _mm256_permutevar8x32_ps(v.x.0, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
    let py = _mm256_permutevar8x32_ps(v.y.0, _mm256_setr_epi32(5, 0, 3, 6, 1, 4, 7, 2));
    let pz = _mm256_permutevar8x32_ps(v.z.0, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
    // x at 0 3 6, y at 1 4 7, z at 2 5; then x at 1 4 7, y at 2 5, z at 0 3 6; then x at
    // 2 5, y at 0 3 6, z at 1 4 7.
    let a = _mm256_blend_ps::<0b0010_0100>(_mm256_blend_ps::<0b1001_0010>(px, py), pz);
    let b = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0010_0100>(pz, py), px);
    let c = _mm256_blend_ps::<0b1001_0010>(_mm256_blend_ps::<0b0010_0100>(py, px), pz);
    let p = out.as_mut_ptr() as *mut f32;
    // SAFETY: 24 `f32`s from `p`.
    unsafe {
        _mm256_storeu_ps(p, a);
        _mm256_storeu_ps(p.add(8), b);
        _mm256_storeu_ps(p.add(16), c);
    }
}

//! Precise positions: the arithmetic both executors do on them, bit for bit.
//!
//! A body's centre is stored as an `f64` ([`crate::bodies::BodyStates::position`]) and
//! handed to the GPU as a double-single pair `(hi, lo)` of `f32` ([`split`]: `hi` the nearest
//! f32, `lo` the rest). Every operation on positions is done on the pairs with `f32`
//! arithmetic, the same operations in the same order as the WGSL twins in
//! `crates/clatter-gpu/shaders/common/status.wgsl` (`ds3_add`, `offset_of`,
//! `plane_offset_from`, `relative_to`, `periodic_wrap_ds`, `ds_snap`) and `integrate.wgsl`,
//! so that the CPU and the GPU stay bitwise together as they did with `f32` positions.
//!
//! After each update the low part is rounded to a multiple of `2^-48` of the high part's
//! binade ([`snap`]): the pair then holds at most 49 significant bits, so it is exactly an
//! `f64` and [`split`] of that `f64` gives the pair back. Positions thus keep about 48 bits
//! (3.6e-13 m at 100 m, 3.6e-12 m at 1 km), where `f32` keeps 24 (7.6e-6 m at 100 m).
//!
//! Relative geometry is the difference of two pairs rounded to `f32` after subtracting: a
//! contact is resolved to the float precision of the overlap, not of the coordinate.

use glam::{DVec3, Vec3, Vec3A};

use crate::periodic::Periodic;

/// A double-single vector: `hi + lo` per component.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ds3 {
    /// The high parts (the nearest f32 of the sum, once normalised).
    pub hi: Vec3,
    /// The low parts.
    pub lo: Vec3,
}

impl Ds3 {
    /// `v` with a zero low part.
    #[inline]
    pub fn from_f32(v: Vec3) -> Ds3 {
        Ds3 {
            hi: v,
            lo: Vec3::ZERO,
        }
    }
}

impl std::ops::Neg for Ds3 {
    type Output = Ds3;

    /// `-self` (both parts; exact).
    #[inline]
    fn neg(self) -> Ds3 {
        Ds3 {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

/// A [`Ds3`] in SIMD lanes (`Vec3A`): the form the step keeps the positions in while it runs
/// ([`crate::World`] splits each body's `f64` once per step, not at every pair), so that a
/// pair's offset is a few packed operations. Each lane does [`Ds3`]'s `f32` operations in the
/// same order, so the results are the same bits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ds3A {
    /// The high parts.
    pub hi: Vec3A,
    /// The low parts.
    pub lo: Vec3A,
}

impl From<Ds3> for Ds3A {
    #[inline(always)]
    fn from(p: Ds3) -> Ds3A {
        Ds3A {
            hi: p.hi.into(),
            lo: p.lo.into(),
        }
    }
}

impl From<Ds3A> for Ds3 {
    #[inline(always)]
    fn from(p: Ds3A) -> Ds3 {
        Ds3 {
            hi: p.hi.into(),
            lo: p.lo.into(),
        }
    }
}

impl std::ops::Neg for Ds3A {
    type Output = Ds3A;

    /// `-self` (both parts; exact).
    #[inline(always)]
    fn neg(self) -> Ds3A {
        Ds3A {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

/// Where a stage reads the bodies' positions as pairs: the step's split (a [`Ds3A`] per
/// body, made once per step: [`crate::World`]'s contact stages and integrate), or the stored
/// `f64`s split at each read (for callers outside a step, where that split may be stale).
/// Both give the same bits.
pub(crate) trait PositionPairs: Copy {
    /// Body `i`'s position as a pair.
    fn pair(self, i: usize) -> Ds3A;
}

impl PositionPairs for &[Ds3A] {
    #[inline(always)]
    fn pair(self, i: usize) -> Ds3A {
        self[i]
    }
}

impl PositionPairs for &[DVec3] {
    #[inline(always)]
    fn pair(self, i: usize) -> Ds3A {
        split_a(self[i])
    }
}

/// A stored position as a pair: `hi` the f32 nearest `x`, `lo` the f32 nearest `x - hi`
/// (exact for positions produced by [`snap`]).
#[inline(always)]
pub fn split(x: DVec3) -> Ds3 {
    let hi = x.as_vec3();
    Ds3 {
        hi,
        lo: (x - hi.as_dvec3()).as_vec3(),
    }
}

/// [`split`] into SIMD lanes (the same conversions per component).
#[inline(always)]
pub fn split_a(x: DVec3) -> Ds3A {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        let x = x.to_array();
        // SAFETY: SSE2 is part of the x86_64 baseline; the loads read `x`'s three values.
        unsafe {
            let xy = _mm_loadu_pd(x.as_ptr());
            let z = _mm_set_sd(x[2]);
            let (hi_xy, hi_z) = (_mm_cvtpd_ps(xy), _mm_cvtpd_ps(z));
            let lo_xy = _mm_cvtpd_ps(_mm_sub_pd(xy, _mm_cvtps_pd(hi_xy)));
            let lo_z = _mm_cvtpd_ps(_mm_sub_pd(z, _mm_cvtps_pd(hi_z)));
            Ds3A {
                hi: _mm_movelh_ps(hi_xy, hi_z).into(),
                lo: _mm_movelh_ps(lo_xy, lo_z).into(),
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        split(x).into()
    }
}

/// [`split_a`] of four positions at once (AVX2): the same conversions and subtraction per
/// component, four bodies' twelve `f64`s in three registers rather than one body's three
/// in two, then each body's three `f32`s moved into its lanes (pads +0, as `split_a`
/// leaves them). About half the instructions of four `split_a`s; the same bits.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn split4(x: &[DVec3; 4], out: &mut [Ds3A; 4]) {
    use std::arch::x86_64::*;
    let p = x.as_ptr() as *const f64;
    // SAFETY: 12 `f64`s from `p` (x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3).
    let d = unsafe {
        [
            _mm256_loadu_pd(p),
            _mm256_loadu_pd(p.add(4)),
            _mm256_loadu_pd(p.add(8)),
        ]
    };
    let hi = d.map(|d| _mm256_cvtpd_ps(d));
    let lo = [0, 1, 2].map(|k| _mm256_cvtpd_ps(_mm256_sub_pd(d[k], _mm256_cvtps_pd(hi[k]))));
    // Three registers of four `f32`s into four bodies' [x y z 0].
    let rows = |[a, b, c]: [__m128; 3]| {
        let zero = _mm_setzero_ps();
        let (ai, bi, ci) = (
            _mm_castps_si128(a),
            _mm_castps_si128(b),
            _mm_castps_si128(c),
        );
        [
            _mm_blend_ps::<0b1000>(a, zero),
            _mm_blend_ps::<0b1000>(_mm_castsi128_ps(_mm_alignr_epi8::<12>(bi, ai)), zero),
            _mm_blend_ps::<0b1000>(_mm_castsi128_ps(_mm_alignr_epi8::<8>(ci, bi)), zero),
            _mm_castsi128_ps(_mm_srli_si128::<4>(ci)),
        ]
    };
    let (h, l) = (rows(hi), rows(lo));
    for k in 0..4 {
        out[k] = Ds3A {
            hi: h[k].into(),
            lo: l[k].into(),
        };
    }
}

/// `hi + lo` in f64 (exact for snapped pairs).
#[inline]
pub fn join(p: Ds3) -> DVec3 {
    p.hi.as_dvec3() + p.lo.as_dvec3()
}

/// `a + b` to about 2^-48 per component: Knuth's two-sum of the high parts, the low parts
/// added to its error, renormalised (WGSL `ds3_add`, and `ds_add` per scalar).
#[inline(always)]
pub fn ds_add(a: Ds3, b: Ds3) -> Ds3 {
    let s = a.hi + b.hi;
    let v = s - a.hi;
    let e = ((a.hi - (s - v)) + (b.hi - v)) + (a.lo + b.lo);
    let hi = s + e;
    let lo = e - (hi - s);
    Ds3 { hi, lo }
}

/// [`ds_add`] in SIMD lanes (the same operations per lane).
#[inline(always)]
pub fn ds_add_a(a: Ds3A, b: Ds3A) -> Ds3A {
    let s = a.hi + b.hi;
    let v = s - a.hi;
    let e = ((a.hi - (s - v)) + (b.hi - v)) + (a.lo + b.lo);
    let hi = s + e;
    let lo = e - (hi - s);
    Ds3A { hi, lo }
}

/// `ds_add_a(a, -b)` with the negations folded into the operations (`x + (-y)` is `x - y`
/// and `(-y) - v` is `-(y + v)` exactly, signed zeros included): the same bits.
#[inline(always)]
pub fn ds_sub_a(a: Ds3A, b: Ds3A) -> Ds3A {
    let s = a.hi - b.hi;
    let v = s - a.hi;
    let e = ((a.hi - (s - v)) - (b.hi + v)) + (a.lo - b.lo);
    let hi = s + e;
    let lo = e - (hi - s);
    Ds3A { hi, lo }
}

/// [`ds_add`] of scalar pairs `(hi, lo)`.
#[inline(always)]
pub fn ds_add1(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    let s = a.0 + b.0;
    let v = s - a.0;
    let e = ((a.0 - (s - v)) + (b.0 - v)) + (a.1 + b.1);
    let hi = s + e;
    (hi, e - (hi - s))
}

/// `a b` exactly, as `(product, error)`: Dekker's product with Veltkamp's split (WGSL
/// `two_prod`).
#[inline(always)]
pub fn two_prod(a: f32, b: f32) -> (f32, f32) {
    let p = a * b;
    let ca = 4097.0 * a;
    let ah = ca - (ca - a);
    let al = a - ah;
    let cb = 4097.0 * b;
    let bh = cb - (cb - b);
    let bl = b - bh;
    let e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    (p, e)
}

/// One component of [`snap`].
#[inline(always)]
fn snap1(h: f32, l: f32) -> (f32, f32) {
    let e = (h.to_bits() >> 23) & 0xff;
    if e <= 48 {
        // |h| < 2^-78 m: nothing below it is kept.
        return (h, 0.0);
    }
    let q = f32::from_bits((e - 48) << 23);
    let inv = f32::from_bits((302 - e) << 23);
    // `round_ties_even` of |l inv| <= 2^24 (exact in f64: adding 1.5 2^52 rounds to an
    // integer, ties to even, with no library call).
    const MAGIC: f64 = 6755399441055744.0;
    let ls = ((((l * inv) as f64 + MAGIC) - MAGIC) as f32) * q;
    let hs = h + ls;
    (hs, ls - (hs - h))
}

/// The pair rounded to the grid of stored positions: the low part to a multiple of
/// `2^-48` of the high part's binade, then renormalised (`hi` the nearest f32 of the sum,
/// ties to even), so that `split(join(p)) == p` (WGSL `ds_snap`).
#[inline(always)]
pub fn snap(p: Ds3) -> Ds3 {
    let (x, y, z) = (
        snap1(p.hi.x, p.lo.x),
        snap1(p.hi.y, p.lo.y),
        snap1(p.hi.z, p.lo.z),
    );
    Ds3 {
        hi: Vec3::new(x.0, y.0, z.0),
        lo: Vec3::new(x.1, y.1, z.1),
    }
}

/// `d` moved to its shortest periodic image (WGSL `periodic_nearest_ds`).
#[inline(always)]
pub fn nearest(periodic: Option<&Periodic>, d: Ds3) -> Ds3 {
    let Some(p) = periodic else {
        return d;
    };
    let len = p.length();
    let mut shift = Vec3::ZERO;
    for k in 0..3 {
        if len[k] > 0.0 {
            if d.hi[k] > 0.5 * len[k] {
                shift[k] = -len[k];
            } else if d.hi[k] < -0.5 * len[k] {
                shift[k] = len[k];
            }
        }
    }
    if shift == Vec3::ZERO {
        return d;
    }
    ds_add(d, Ds3::from_f32(shift))
}

/// `x` wrapped into the periodic box (WGSL `periodic_wrap_ds`).
#[inline]
pub fn wrap(periodic: Option<&Periodic>, x: Ds3) -> Ds3 {
    let Some(p) = periodic else {
        return x;
    };
    let len = p.length();
    let mut shift = Vec3::ZERO;
    for k in 0..3 {
        if len[k] > 0.0 {
            let lo = p.min[k];
            if x.hi[k] >= lo + len[k] {
                shift[k] = -len[k];
            } else if x.hi[k] < lo {
                shift[k] = len[k];
            }
        }
    }
    if shift == Vec3::ZERO {
        return x;
    }
    ds_add(x, Ds3::from_f32(shift))
}

/// Where `xj` (its nearest periodic image) is seen from `xi`: the difference of the pairs,
/// rounded to f32 (WGSL `offset_of`).
#[inline(always)]
pub fn offset(periodic: Option<&Periodic>, xi: DVec3, xj: DVec3) -> Vec3 {
    nearest(periodic, ds_add(split(xj), -split(xi))).hi
}

/// [`offset`] of positions already split (the step's pairs, [`Ds3A`]): the same bits.
#[inline(always)]
pub fn offset_a(periodic: Option<&Periodic>, xi: Ds3A, xj: Ds3A) -> Vec3 {
    let d = ds_sub_a(xj, xi);
    match periodic {
        None => d.hi.into(),
        Some(_) => nearest(periodic, d.into()).hi,
    }
}

/// A world point `p` (f32) as seen from `origin`: `p - origin` of the pairs, rounded (WGSL
/// `relative_to`, `mesh_local`).
#[inline(always)]
pub fn relative(origin: Ds3, p: Vec3) -> Vec3 {
    ds_add(Ds3::from_f32(p), -origin).hi
}

/// The offset of the plane `n . x = d` as seen from `x`: `d - n . x` as a pair `(offset,
/// rest)`, the products of the high parts exact (WGSL `plane_offset_from`). The rest is
/// added to the depths of the contact found with `offset`, so that a depth keeps its own
/// precision rather than that of the body's distance from the plane (a body resting on a
/// wall creeps below the f32 spacing of that distance: without the rest its depth, and the
/// law's dashpot, would jump by that spacing).
#[inline(always)]
pub fn plane_offset(n: Vec3, d: f32, x: DVec3) -> (f32, f32) {
    plane_offset_a(n, d, split(x).into())
}

/// [`plane_offset`] from a position already split (the step's pairs, [`Ds3A`]): the same
/// bits. A wall whose normal is a coordinate axis (the usual box) takes
/// `plane_offset_axis`, the same bits in about a third of the instructions.
#[inline(always)]
pub fn plane_offset_a(n: Vec3, d: f32, p: Ds3A) -> (f32, f32) {
    let a = n.abs();
    let axis = if a == Vec3::Z {
        plane_offset_axis::<2>(n, d, p)
    } else if a == Vec3::X {
        plane_offset_axis::<0>(n, d, p)
    } else if a == Vec3::Y {
        plane_offset_axis::<1>(n, d, p)
    } else {
        None
    };
    match axis {
        Some(r) => r,
        None => plane_offset_general(n, d, p),
    }
}

/// [`plane_offset_sum`], called rather than inlined: the path of walls that are not an
/// axis' (and of the short path's exceptions), kept out of the contact stage's code,
/// whose size its copies grew.
#[inline(never)]
fn plane_offset_general(n: Vec3, d: f32, p: Ds3A) -> (f32, f32) {
    plane_offset_sum(n, d, p)
}

/// [`plane_offset_sum`] for a normal `n` with `|n[K]| = 1` and the other two components
/// `+-0`, without the operations whose results that fixes (`None`, for the general sum,
/// where the argument below does not hold: `d = -0`, or `|d|` or some `|hi|` not below
/// `1e30`, NaNs included). The same bits, because for finite `b` with `|4097 b|` finite:
/// - [`two_prod`]`(a, b)` with `a = +-0` or `+-1` has the error `e = +0` (Veltkamp's
///   `bh` keeps `b`'s sign, `bh + bl = b` exactly, and each term of `e` is then `+0` or a
///   zero added to `+0`), so each lane adds `(-(a b), -0)`;
/// - a lane with `a = +-0` adds `(+-0, -0)`: to the start `(d, +0)`, `d != -0`, that gives
///   `(d, +0)` back (every operation of [`ds_add1`] then yields `d` or `+0`), and to a
///   pair `(h, l)` with `h != 0` it gives `e = +0 + l`, `hi = h + e`, `lo = e - (hi - h)`
///   (the sum `h + (+-0)` is `h`, `v = +0`, `(h - h) + (+-0 - 0) = +0`, `l + -0 = l`);
///   for `h = +-0` the full [`ds_add1`] is done;
/// - lane `K` adds `(-(n[K] hi[K]), -0)` by the full [`ds_add1`], and the low parts'
///   dot product and the last [`ds_add1`] are the general sum's own operations.
#[inline(always)]
fn plane_offset_axis<const K: usize>(n: Vec3, d: f32, p: Ds3A) -> Option<(f32, f32)> {
    // `x < 1e30` fails for NaNs too.
    let hi = Vec3::from(p.hi);
    let small = hi.abs().cmplt(Vec3::splat(1e30)).all() && d.abs() < 1e30;
    if !small || d.to_bits() == (-0.0f32).to_bits() {
        return None;
    }
    // The lanes before `K`: `(d, +0)` unchanged.
    let mut s = (d, 0.0f32);
    s = ds_add1(s, (-(n[K] * hi[K]), -0.0));
    // The lanes after `K` (none for `K = 2`, the floor's axis).
    for k in K + 1..3 {
        s = if s.0 != 0.0 {
            let e = 0.0 + s.1;
            let h = s.0 + e;
            (h, e - (h - s.0))
        } else {
            ds_add1(s, (-(n[k] * hi[k]), -0.0))
        };
    }
    Some(ds_add1(s, (-n.dot(Vec3::from(p.lo)), 0.0)))
}

/// [`plane_offset_a`]'s general sum: `d`, less the three products `n[k] hi[k]` (each as a
/// pair, [`two_prod`]) in order, less `n . lo`.
#[inline(always)]
pub fn plane_offset_sum(n: Vec3, d: f32, p: Ds3A) -> (f32, f32) {
    // The three products in lanes ([`two_prod`]'s operations per lane), summed in order.
    let (pr, e) = two_prod_a(n.into(), p.hi);
    let (pr, e) = (Vec3::from(pr), Vec3::from(e));
    let mut s = (d, 0.0);
    for k in 0..3 {
        s = ds_add1(s, (-pr[k], -e[k]));
    }
    ds_add1(s, (-n.dot(Vec3::from(p.lo)), 0.0))
}

/// [`two_prod`] in SIMD lanes (the same operations per lane).
#[inline(always)]
fn two_prod_a(a: Vec3A, b: Vec3A) -> (Vec3A, Vec3A) {
    let p = a * b;
    let ca = 4097.0 * a;
    let ah = ca - (ca - a);
    let al = a - ah;
    let cb = 4097.0 * b;
    let bh = cb - (cb - b);
    let bl = b - bh;
    let e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    (p, e)
}

/// The Verlet test's displacement of `x` from `rebuild`: `(hi - rebuild_hi) + lo` in f32,
/// nearest image (the GPU keeps the rebuild positions' high parts only; WGSL integrate).
#[inline(always)]
pub fn moved(periodic: Option<&Periodic>, x: DVec3, rebuild: DVec3) -> Vec3 {
    let p = split(x);
    let d = (p.hi - rebuild.as_vec3()) + p.lo;
    periodic.map_or(d, |q| q.nearest(d))
}

/// One step's displacement `dx` (f32) added to the stored position `x`, wrapped into the
/// periodic box and snapped: the new stored position, and its [`moved`] from `rebuild`
/// (WGSL integrate).
#[inline(always)]
pub fn advance(periodic: Option<&Periodic>, x: DVec3, dx: Vec3, rebuild: DVec3) -> (DVec3, Vec3) {
    advance_a(periodic, split(x).into(), dx, rebuild)
}

/// [`advance`] from a position already split (the step's pairs, [`Ds3A`]): the same bits.
#[inline(always)]
pub fn advance_a(periodic: Option<&Periodic>, x: Ds3A, dx: Vec3, rebuild: DVec3) -> (DVec3, Vec3) {
    let sum = ds_add_a(
        x,
        Ds3A {
            hi: dx.into(),
            lo: Vec3A::ZERO,
        },
    );
    let wrapped = match periodic {
        None => sum,
        Some(_) => wrap(periodic, sum.into()).into(),
    };
    let p = snap_a(wrapped);
    let d = Vec3::from((p.hi - Vec3A::from(rebuild.as_vec3())) + p.lo);
    (join_a(p), periodic.map_or(d, |q| q.nearest(d)))
}

/// [`join`] in SIMD lanes (the same exact conversions and one rounding per component).
#[inline(always)]
fn join_a(p: Ds3A) -> DVec3 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86_64 baseline; the stores are to local arrays.
        unsafe {
            let (h, l): (__m128, __m128) = (p.hi.into(), p.lo.into());
            let xy = _mm_add_pd(_mm_cvtps_pd(h), _mm_cvtps_pd(l));
            let zw = _mm_add_pd(
                _mm_cvtps_pd(_mm_movehl_ps(h, h)),
                _mm_cvtps_pd(_mm_movehl_ps(l, l)),
            );
            let (mut a, mut b) = ([0.0f64; 2], [0.0f64; 2]);
            _mm_storeu_pd(a.as_mut_ptr(), xy);
            _mm_storeu_pd(b.as_mut_ptr(), zw);
            DVec3::new(a[0], a[1], b[0])
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        join(p.into())
    }
}

/// [`snap`] in SIMD lanes, for pairs as [`ds_add`] leaves them (`|lo|` within a few ulps of
/// `hi`): the same values bit for bit. The scaled low part `y` (`|y| <= 2^25` for such pairs)
/// is rounded to an integer, ties to even, by a round trip through `i32` (the SSE2
/// conversion rounds to nearest even, and gives `+0` for a zero result, as [`snap1`]'s
/// `f64` rounding does).
#[inline(always)]
fn snap_a(p: Ds3A) -> Ds3A {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86_64 baseline; only register operations.
        unsafe {
            let (h, l): (__m128, __m128) = (p.hi.into(), p.lo.into());
            let e = _mm_and_si128(
                _mm_srli_epi32::<23>(_mm_castps_si128(h)),
                _mm_set1_epi32(0xff),
            );
            // |h| < 2^-78 m: nothing below it is kept (lanes chosen at the end).
            let tiny = _mm_castsi128_ps(_mm_cmplt_epi32(e, _mm_set1_epi32(49)));
            let q = _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_sub_epi32(e, _mm_set1_epi32(48))));
            let inv = _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_sub_epi32(_mm_set1_epi32(302), e)));
            let y = _mm_mul_ps(l, inv);
            let r = _mm_cvtepi32_ps(_mm_cvtps_epi32(y));
            let ls = _mm_mul_ps(r, q);
            let hs = _mm_add_ps(h, ls);
            let lo = _mm_sub_ps(ls, _mm_sub_ps(hs, h));
            Ds3A {
                hi: _mm_or_ps(_mm_and_ps(tiny, h), _mm_andnot_ps(tiny, hs)).into(),
                lo: _mm_andnot_ps(tiny, lo).into(),
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        snap(p.into()).into()
    }
}

/// Bodies per task of [`crate::World::split_positions`]: large enough that a task's work hides its
/// overhead.
pub(crate) const SPLIT_CHUNK: usize = 4096;

/// Positions `x` split into their pairs `out` (`split_a` each; the slices of one
/// length): one task's part of [`crate::World::split_positions`].
pub(crate) fn split_chunk(x: &[DVec3], out: &mut [Ds3A]) {
    #[cfg(target_arch = "x86_64")]
    if crate::step::avx2() {
        // Four at a time (`split4`: the same bits), the rest one by one.
        let (out4, out_rest) = out.as_chunks_mut::<4>();
        let (x4, x_rest) = x.as_chunks::<4>();
        for (o, x) in out4.iter_mut().zip(x4) {
            // SAFETY: the CPU has AVX2 (`avx2` is never true otherwise).
            unsafe { split4(x, o) };
        }
        for (o, &x) in out_rest.iter_mut().zip(x_rest) {
            *o = split_a(x);
        }
        return;
    }
    crate::step::vex(|| {
        for (o, &x) in out.iter_mut().zip(x) {
            *o = split_a(x);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `split4` against `split` (the definition) and `split_a` (every byte, pads too), on
    /// positions of every scale and sign, exact `f32`s, zeros of both signs, and values
    /// halfway between two `f32`s (where the rounding's ties show).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn split4_gives_split_a_bits() {
        use rand::{Rng, SeedableRng};
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 here: nothing to compare");
            return;
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let value = |rng: &mut rand_chacha::ChaCha8Rng| -> f64 {
            let scale = 10f64.powi(rng.random_range(-30..30));
            match rng.random_range(0..6) {
                0 => 0.0,
                1 => -0.0,
                2 => rng.random_range(-1000.0f32..1000.0) as f64,
                3 => {
                    // Halfway between two f32s.
                    let f = rng.random_range(1.0f32..2.0);
                    (f as f64 + f64::from(f32::from_bits(f.to_bits() + 1))) / 2.0
                }
                _ => rng.random_range(-1.0..1.0) * scale,
            }
        };
        let mut checked = 0;
        for _ in 0..20_000 {
            let x: [DVec3; 4] = std::array::from_fn(|_| {
                DVec3::new(value(&mut rng), value(&mut rng), value(&mut rng))
            });
            let zero = Ds3A {
                hi: Vec3A::splat(f32::NAN),
                lo: Vec3A::splat(f32::NAN),
            };
            let mut out = [zero; 4];
            // SAFETY: the CPU has AVX2 (checked above).
            unsafe { split4(&x, &mut out) };
            for k in 0..4 {
                let (want, got) = (split(x[k]), Ds3::from(out[k]));
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!(bits(want.hi), bits(got.hi), "{:?}", x[k]);
                assert_eq!(bits(want.lo), bits(got.lo), "{:?}", x[k]);
                // All four lanes of each half, the pads too.
                let bytes = |p: &Ds3A| -> [u32; 8] {
                    let [a, b] = [p.hi, p.lo].map(|v| {
                        // SAFETY: a `__m128` is four `f32`s.
                        unsafe {
                            std::mem::transmute::<std::arch::x86_64::__m128, [f32; 4]>(v.into())
                        }
                    });
                    std::array::from_fn(|i| if i < 4 { a[i] } else { b[i - 4] }.to_bits())
                };
                assert_eq!(bytes(&split_a(x[k])), bytes(&out[k]), "{:?}", x[k]);
                checked += 1;
            }
        }
        assert_eq!(checked, 80_000);
    }

    #[test]
    fn snapped_pairs_are_f64_values() {
        let mut x = DVec3::new(100.123456789, -50.000001, 1e-3);
        for k in 0..10_000 {
            let dx = Vec3::new(1e-9, -3e-7, 2e-6) * (1.0 + k as f32 * 1e-3);
            let (next, _) = advance(None, x, dx, x);
            let p = split(next);
            assert_eq!(join(p), next);
            assert_eq!(snap(p), p);
            x = next;
        }
    }

    #[test]
    fn small_steps_are_kept_far_out() {
        let x0 = DVec3::new(1000.0, 100.0, 5.0);
        let mut x = x0;
        let dx = Vec3::splat(1e-9);
        for _ in 0..1000 {
            x = advance(None, x, dx, x0).0;
        }
        let moved = x - x0;
        for k in 0..3 {
            assert!((moved[k] - 1e-6).abs() < 1e-9, "{moved}");
        }
    }

    #[test]
    fn lanes_match_scalars() {
        // Random pairs over many binades (ties, tiny and huge parts included), and steps.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let bits = |p: Ds3| [p.hi.to_array(), p.lo.to_array()].map(|v| v.map(f32::to_bits));
        for k in 0..200_000 {
            let r = next();
            let scale = 2f32.powi((r % 180) as i32 - 90);
            let h = Vec3::new(
                (next() as i32) as f32 * scale,
                (next() as i32) as f32 * scale * 1e-6,
                if k % 7 == 0 {
                    0.0
                } else {
                    -((next() >> 40) as f32) * scale
                },
            );
            let ulp = Vec3::new(h.x.abs(), h.y.abs(), h.z.abs()) * f32::EPSILON;
            let frac = |u: u64| ((u >> 11) as f32 / (1u64 << 53) as f32) - 0.5;
            let mut l = Vec3::new(frac(next()), frac(next()), frac(next())) * ulp;
            if k % 5 == 0 {
                // Ties of either sign (halves of the snap grid `2^-25` ulp), and parts that
                // round to zero from below.
                let m = [(k % 9) as f32 - 4.5, -0.25, -0.5, 0.5, 2.5][(k / 5) % 5];
                l = ulp * m * (0.5f32).powi(25);
            }
            let p = Ds3 { hi: h, lo: l };
            assert_eq!(bits(snap(p)), bits(snap_a(p.into()).into()), "{p:?}");
            let x = join(snap(p));
            assert_eq!(bits(split(x)), bits(split_a(x).into()));
            let unsnapped = join(p) * (1.0 + 1e-12);
            assert_eq!(bits(split(unsnapped)), bits(split_a(unsnapped).into()));
            let dx = Vec3::new(frac(next()), -frac(next()), frac(next())) * scale;
            let rebuild = x + DVec3::splat(1e-3);
            let (a, b) = (
                {
                    let q = snap(ds_add(split(x), Ds3::from_f32(dx)));
                    (join(q), (q.hi - rebuild.as_vec3()) + q.lo)
                },
                advance_a(None, split(x).into(), dx, rebuild),
            );
            assert_eq!(
                a.0.to_array().map(f64::to_bits),
                b.0.to_array().map(f64::to_bits)
            );
            assert_eq!(
                a.1.to_array().map(f32::to_bits),
                b.1.to_array().map(f32::to_bits)
            );
            let n = Vec3::new(frac(next()), frac(next()), frac(next())).normalize();
            let d = frac(next()) * scale;
            let scalar = {
                let p = split(x);
                let mut s = (d, 0.0);
                for k in 0..3 {
                    let (pr, e) = two_prod(n[k], p.hi[k]);
                    s = ds_add1(s, (-pr, -e));
                }
                ds_add1(s, (-n.dot(p.lo), 0.0))
            };
            let lanes = plane_offset(n, d, x);
            if !(scalar.0.is_finite() && scalar.1.is_finite()) {
                // Products past f32's range (|x| > 1e34): NaNs, whose sign bits may differ.
                continue;
            }
            assert_eq!(
                (scalar.0.to_bits(), scalar.1.to_bits()),
                (lanes.0.to_bits(), lanes.1.to_bits())
            );
        }
    }

    /// `plane_offset_a` (the axis walls' short path) against the general sum kept as the
    /// reference (`plane_offset_sum`) and the scalar definition (`two_prod`, `ds_add1`):
    /// every bit, on axis normals with zeros of both signs, general normals, offsets of
    /// every scale (+-0, tiny, past the short path's 1e30, NaN), positions on, near and far
    /// from the wall and far from the origin, zeros, infinities and NaNs.
    #[test]
    fn axis_walls_give_the_general_sums_bits() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(36);
        let scalar = |n: Vec3, d: f32, p: Ds3A| {
            let p = Ds3::from(p);
            let mut s = (d, 0.0);
            for k in 0..3 {
                let (pr, e) = two_prod(n[k], p.hi[k]);
                s = ds_add1(s, (-pr, -e));
            }
            ds_add1(s, (-n.dot(p.lo), 0.0))
        };
        let bits = |(a, b): (f32, f32)| (a.to_bits(), b.to_bits());
        let mut axis = 0;
        for k in 0..400_000 {
            let z = |rng: &mut rand_chacha::ChaCha8Rng| if rng.random() { 0.0 } else { -0.0 };
            let one = |rng: &mut rand_chacha::ChaCha8Rng| if rng.random() { 1.0 } else { -1.0 };
            let n = match k % 5 {
                0 => Vec3::new(z(&mut rng), z(&mut rng), one(&mut rng)),
                1 => Vec3::new(one(&mut rng), z(&mut rng), z(&mut rng)),
                2 => Vec3::new(z(&mut rng), one(&mut rng), z(&mut rng)),
                3 => {
                    let v = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
                    v.normalize_or(Vec3::Z)
                }
                // Nearly an axis.
                _ => Vec3::new(1e-30, 0.0, 1.0),
            };
            let scale = 10f32.powi(rng.random_range(-12..8));
            let d = match rng.random_range(0..8) {
                0 => 0.0,
                1 => -0.0,
                2 => [1e30, -2e30, f32::NAN, 1e-40][rng.random_range(0..4)],
                _ => rng.random_range(-1.0f32..1.0) * scale,
            };
            // The body: on the wall, near it, anywhere; far out; special values.
            let mut x = DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ) * 10f64.powi(rng.random_range(-8..7));
            let across = n.as_dvec3().dot(x) - d as f64;
            match rng.random_range(0..8) {
                // Exactly on the wall's f32 offset, or within a few of its ulps.
                0 => x -= n.as_dvec3() * across,
                1 => x -= n.as_dvec3() * (across + rng.random_range(-4.0..4.0) * 1e-7 * d as f64),
                2 => {
                    x[rng.random_range(0..3)] =
                        [0.0, -0.0, f64::INFINITY, f64::NAN, 1e31, -1e35][rng.random_range(0..6)]
                }
                _ => {}
            }
            let p = if rng.random_range(0..4) == 0 {
                // Unsnapped low parts, of either sign, zeros included.
                let hi = x.as_vec3();
                let lo = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
                let lo = lo * hi.abs() * f32::EPSILON * [0.0, 1.0, -0.0][k % 3];
                Ds3A {
                    hi: hi.into(),
                    lo: lo.into(),
                }
            } else {
                split_a(x)
            };
            let (got, want) = (plane_offset_a(n, d, p), plane_offset_sum(n, d, p));
            if [Vec3::X, Vec3::Y, Vec3::Z].contains(&n.abs()) {
                // (The short path's guard does not depend on the axis.)
                axis += plane_offset_axis::<0>(n, d, p).is_some() as usize;
            }
            // A NaN's sign and payload are not kept by the compiler (it may swap an
            // addition's operands): NaNs match NaNs, everything else bit for bit.
            let nan = |(a, b): (f32, f32)| (a.is_nan(), b.is_nan());
            assert_eq!(nan(got), nan(want), "n {n:?} d {d:?} p {p:?}");
            let quiet = |(a, b): (f32, f32)| {
                bits((
                    if a.is_nan() { 0.0 } else { a },
                    if b.is_nan() { 0.0 } else { b },
                ))
            };
            assert_eq!(quiet(got), quiet(want), "n {n:?} d {d:?} p {p:?}");
            if want.0.is_finite() && want.1.is_finite() {
                assert_eq!(bits(got), bits(scalar(n, d, p)), "n {n:?} d {d:?} p {p:?}");
            }
        }
        assert!(axis > 100_000, "{axis} pairs on the short path");
    }

    #[test]
    fn two_prod_is_exact() {
        for (a, b) in [(0.1f32, 100.3f32), (-3.7, 1e-3), (1.0 / 3.0, 3.0)] {
            let (p, e) = two_prod(a, b);
            assert_eq!(p as f64 + e as f64, a as f64 * b as f64);
        }
    }

    #[test]
    fn offsets_are_the_rounded_differences() {
        let on_grid = |x: DVec3| advance(None, x, Vec3::ZERO, x).0;
        let (xi, xj) = (
            on_grid(DVec3::new(100.0, -50.0, 20.0)),
            on_grid(DVec3::new(100.002, -50.001, 20.0)),
        );
        let d = offset(None, xi, xj);
        assert_eq!(d, (xj - xi).as_vec3());
    }
}

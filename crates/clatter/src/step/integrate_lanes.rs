//! The **integrate** stage's update eight bodies at a time, one body per lane of an AVX2
//! register: what [`super::integrate`]'s `body` does after the gather (velocity, the
//! precise position and its Verlet displacement, angular momentum and velocity, the
//! compensated quaternion update), with the same bits.
//!
//! Each lane does the scalar path's IEEE operations in the same order: glam's `Vec3`
//! component by component, and its SSE2 `Quat` product and four-lane dot product term for
//! term (`Quat::mul_quat`, `dot4`); [`crate::precise`]'s `ds_add_a`, `snap_a` and `join_a`
//! lane for lane; branches become blends. The forces are gathered per body as before
//! (`Contacts::gather4`). Groups the lanes do not cover go to the scalar `body`: a periodic
//! box, mesh boundaries or sinks in the world, a removed body in the group, a body whose
//! inertia is not isotropic, and the chunk's last `len % 8` bodies. A ghost (another rank's
//! body, which this rank does not integrate) runs in its lane with the others, without its
//! forces gathered, and what its lane writes is not kept: the forward exchange that follows
//! every integrate on ranks (`crate::domain`) overwrites every word of a ghost's state with
//! the owner's, so neither its gather nor a copy of its old state is needed.

use std::arch::x86_64::*;

use glam::{DVec3, Quat, Vec3};

use super::integrate::{Bodies, Ctx, body};
use super::lanes::{F8, V3, load_vec3, store_vec3};
use crate::precise::Ds3A;

/// Eight quaternions in lanes (x, y, z, w).
#[derive(Clone, Copy)]
struct Q8 {
    x: F8,
    y: F8,
    z: F8,
    w: F8,
}

/// A 4x4 transpose in each 128-bit half: lanes `l` and `l + 4` of `a`, `b`, `c`, `d` as
/// `r[l]`'s halves, or back.
#[inline]
#[target_feature(enable = "avx2")]
fn transpose(a: __m256, b: __m256, c: __m256, d: __m256) -> [__m256; 4] {
    let (t0, t1) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
    let (t2, t3) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
    [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    ]
}

/// Eight 16-byte records (`Quat`s, `Vec4`s) split into their four lanes.
///
/// # Safety
/// AVX2; `p` points at eight records.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load4(p: *const f32) -> [F8; 4] {
    // SAFETY: 32 `f32`s from `p`.
    let (a, b, c, d) = unsafe {
        (
            _mm256_loadu_ps(p),
            _mm256_loadu_ps(p.add(8)),
            _mm256_loadu_ps(p.add(16)),
            _mm256_loadu_ps(p.add(24)),
        )
    };
    // Records l and l + 4 in the halves of r[l].
    let r = transpose(
        _mm256_permute2f128_ps::<0x20>(a, c),
        _mm256_permute2f128_ps::<0x31>(a, c),
        _mm256_permute2f128_ps::<0x20>(b, d),
        _mm256_permute2f128_ps::<0x31>(b, d),
    );
    r.map(F8)
}

/// [`load4`]'s inverse.
///
/// # Safety
/// AVX2; `p` points at eight records.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn store4(v: [F8; 4], p: *mut f32) {
    let r = transpose(v[0].0, v[1].0, v[2].0, v[3].0);
    // SAFETY: 32 `f32`s from `p`.
    unsafe {
        _mm256_storeu_ps(p, _mm256_permute2f128_ps::<0x20>(r[0], r[1]));
        _mm256_storeu_ps(p.add(8), _mm256_permute2f128_ps::<0x20>(r[2], r[3]));
        _mm256_storeu_ps(p.add(16), _mm256_permute2f128_ps::<0x31>(r[0], r[1]));
        _mm256_storeu_ps(p.add(24), _mm256_permute2f128_ps::<0x31>(r[2], r[3]));
    }
}

/// Eight quaternions into lanes.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load_quat(q: &[Quat; 8]) -> Q8 {
    // SAFETY: `Quat` is four `f32`s (x, y, z, w).
    let [x, y, z, w] = unsafe { load4(q.as_ptr() as *const f32) };
    Q8 { x, y, z, w }
}

/// Lanes back into eight quaternions.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn store_quat(q: Q8, out: &mut [Quat; 8]) {
    // SAFETY: `Quat` is four `f32`s (x, y, z, w).
    unsafe { store4([q.x, q.y, q.z, q.w], out.as_mut_ptr() as *mut f32) }
}

/// Eight `DVec3`s (24 `f64`s) as the `f32`s nearest them (`DVec3::as_vec3`), in lanes.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load_dvec3_as_f32(v: &[DVec3; 8]) -> V3 {
    let p = v.as_ptr() as *const f64;
    // Four bodies (12 `f64`s: x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3) into x, y, z.
    let four = |p: *const f64| {
        // SAFETY: 12 `f64`s from `p` (the caller's).
        let (a, b, c) = unsafe {
            (
                _mm256_loadu_pd(p),
                _mm256_loadu_pd(p.add(4)),
                _mm256_loadu_pd(p.add(8)),
            )
        };
        // x0 x3 x2 x1, y1 y0 y3 y2, z2 z1 z0 z3; each permutation is its own inverse.
        let px = _mm256_blend_pd::<0b0100>(_mm256_blend_pd::<0b0010>(a, c), b);
        let py = _mm256_blend_pd::<0b0100>(_mm256_blend_pd::<0b0010>(b, a), c);
        let pz = _mm256_blend_pd::<0b0100>(_mm256_blend_pd::<0b0010>(c, b), a);
        [
            _mm256_cvtpd_ps(_mm256_permute4x64_pd::<0b01_10_11_00>(px)),
            _mm256_cvtpd_ps(_mm256_permute4x64_pd::<0b10_11_00_01>(py)),
            _mm256_cvtpd_ps(_mm256_permute4x64_pd::<0b11_00_01_10>(pz)),
        ]
    };
    // SAFETY: 24 `f64`s from `p`.
    let (lo, hi) = unsafe { (four(p), four(p.add(12))) };
    let join = |c: usize| F8(_mm256_set_m128(hi[c], lo[c]));
    V3 {
        x: join(0),
        y: join(1),
        z: join(2),
    }
}

/// Eight double-single positions, joined (`join_a`: `hi as f64 + lo as f64`), stored as
/// `DVec3`s.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn store_joined(hi: V3, lo: V3, out: &mut [DVec3; 8]) {
    let p = out.as_mut_ptr() as *mut f64;
    let half = |v: F8, upper: bool| {
        if upper {
            _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(v.0))
        } else {
            _mm256_cvtps_pd(_mm256_castps256_ps128(v.0))
        }
    };
    for (b, upper) in [(0usize, false), (4, true)] {
        let x = _mm256_add_pd(half(hi.x, upper), half(lo.x, upper));
        let y = _mm256_add_pd(half(hi.y, upper), half(lo.y, upper));
        let z = _mm256_add_pd(half(hi.z, upper), half(lo.z, upper));
        let px = _mm256_permute4x64_pd::<0b01_10_11_00>(x);
        let py = _mm256_permute4x64_pd::<0b10_11_00_01>(y);
        let pz = _mm256_permute4x64_pd::<0b11_00_01_10>(z);
        let o0 = _mm256_blend_pd::<0b0100>(_mm256_blend_pd::<0b0010>(px, py), pz);
        let o1 = _mm256_blend_pd::<0b0100>(_mm256_blend_pd::<0b0010>(py, pz), px);
        let o2 = _mm256_blend_pd::<0b0100>(_mm256_blend_pd::<0b0010>(pz, px), py);
        // SAFETY: 12 `f64`s from body b on.
        unsafe {
            let q = p.add(3 * b);
            _mm256_storeu_pd(q, o0);
            _mm256_storeu_pd(q.add(4), o1);
            _mm256_storeu_pd(q.add(8), o2);
        }
    }
}

/// Eight positions' double-single pairs (`hi`, `lo`) in lanes.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load_pairs(x: &[Ds3A; 8]) -> (V3, V3) {
    // Each `Ds3A` is `hi` (x y z pad) then `lo` (x y z pad): body l's 8 floats. Bodies l and
    // l + 4 as the halves of two records' worth, then a transpose per part.
    let p = x.as_ptr() as *const f32;
    // SAFETY: 64 `f32`s from `p`.
    let r: [__m256; 8] = std::array::from_fn(|l| unsafe { _mm256_loadu_ps(p.add(8 * l)) });
    let part = |upper: bool| {
        let pick = |l: usize| {
            if upper {
                _mm256_permute2f128_ps::<0x31>(r[l], r[l + 4])
            } else {
                _mm256_permute2f128_ps::<0x20>(r[l], r[l + 4])
            }
        };
        let t = transpose(pick(0), pick(1), pick(2), pick(3));
        V3 {
            x: F8(t[0]),
            y: F8(t[1]),
            z: F8(t[2]),
        }
    };
    (part(false), part(true))
}

/// `snap_a` in eight lanes (`crate::precise`): the same integer and float operations.
#[inline]
#[target_feature(enable = "avx2")]
fn snap(h: F8, l: F8) -> (F8, F8) {
    let e = _mm256_and_si256(
        _mm256_srli_epi32::<23>(_mm256_castps_si256(h.0)),
        _mm256_set1_epi32(0xff),
    );
    let tiny = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(49), e));
    let q = _mm256_castsi256_ps(_mm256_slli_epi32::<23>(_mm256_sub_epi32(
        e,
        _mm256_set1_epi32(48),
    )));
    let inv = _mm256_castsi256_ps(_mm256_slli_epi32::<23>(_mm256_sub_epi32(
        _mm256_set1_epi32(302),
        e,
    )));
    let y = _mm256_mul_ps(l.0, inv);
    let r = _mm256_cvtepi32_ps(_mm256_cvtps_epi32(y));
    let ls = _mm256_mul_ps(r, q);
    let hs = _mm256_add_ps(h.0, ls);
    let lo = _mm256_sub_ps(ls, _mm256_sub_ps(hs, h.0));
    (
        F8(_mm256_or_ps(
            _mm256_and_ps(tiny, h.0),
            _mm256_andnot_ps(tiny, hs),
        )),
        F8(_mm256_andnot_ps(tiny, lo)),
    )
}

/// glam's SSE2 `Quat::mul_quat(a, b)`, term for term.
#[inline]
#[target_feature(enable = "avx2")]
fn mul_quat(a: Q8, b: Q8) -> Q8 {
    // glam: result0 = a.w b + a.x (b.w, -b.z, b.y, -b.x); result1 = a.y (b.z, b.w, -b.x,
    // -b.y) + a.z (-b.y, b.x, b.w, -b.z); result0 + result1. The negations are products
    // with -1 there, exact either way.
    Q8 {
        x: (a.w * b.x + a.x * b.w) + (a.y * b.z + -(a.z * b.y)),
        y: (a.w * b.y + -(a.x * b.z)) + (a.y * b.w + a.z * b.x),
        z: (a.w * b.z + a.x * b.y) + (-(a.y * b.x) + a.z * b.w),
        w: (a.w * b.w + -(a.x * b.x)) + (-(a.y * b.y) + -(a.z * b.z)),
    }
}

impl Q8 {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn zip(self, o: Q8, f: impl Fn(F8, F8) -> F8) -> Q8 {
        Q8 {
            x: f(self.x, o.x),
            y: f(self.y, o.y),
            z: f(self.z, o.z),
            w: f(self.w, o.w),
        }
    }

    /// glam's SSE2 `dot4` of `self` with itself: `(x x + z z) + (y y + w w)`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn length_squared(self) -> F8 {
        (self.x * self.x + self.z * self.z) + (self.y * self.y + self.w * self.w)
    }
}

/// The stage's chunk `b` (what `integrate::run` does per chunk): eight bodies at a time where
/// the lanes cover them, the scalar `body` elsewhere. Returns the largest squared distance
/// moved. Where `c.fresh`, from its last bodies down (the bodies past its last eight, then
/// its eights from the last: freshest first, see `integrate::freshest_first`), else from
/// its first up: each body is updated alone and the distance is a maximum, so the same
/// bits either way.
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn chunk(c: &Ctx, mut b: Bodies) -> f32 {
    let n = b.xs.len();
    let lanes_apply = c.periodic.is_none() && c.mesh.is_none() && !c.has_sinks;
    // The eights the lanes take (`groups` of them from body 0), then the rest one by one.
    let groups = if lanes_apply { n / 8 } else { 0 };
    let mut worst = 0.0f32;
    let mut take = |d2: f32| worst = if d2 > worst { d2 } else { worst };
    if c.fresh {
        for k in (8 * groups..n).rev() {
            take(body(c, &mut b, k));
        }
        for g in (0..groups).rev() {
            // SAFETY: AVX2 (the caller's).
            take(unsafe { eight(c, &mut b, 8 * g) });
        }
    } else {
        for g in 0..groups {
            // SAFETY: AVX2 (the caller's).
            take(unsafe { eight(c, &mut b, 8 * g) });
        }
        for k in 8 * groups..n {
            take(body(c, &mut b, k));
        }
    }
    worst
}

/// Bodies `k..k + 8` of the chunk: in lanes ([`group`]) where they cover them, else one by
/// one; the largest squared distance moved.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn eight(c: &Ctx, b: &mut Bodies, k: usize) -> f32 {
    // SAFETY: AVX2 (the caller's).
    match unsafe { group(c, b, k) } {
        Some(d2) => d2,
        None => {
            let mut worst = 0.0f32;
            for k in k..k + 8 {
                let d2 = body(c, b, k);
                worst = if d2 > worst { d2 } else { worst };
            }
            worst
        }
    }
}

/// Bodies `k..k + 8` of the chunk in lanes; `None` (nothing written) where a body is removed
/// or not isotropic. Ghosts (another rank's bodies) are not gathered and their lanes' states
/// are not meaningful: the forward exchange, which follows integrate on every rank,
/// overwrites them with the owners'. Returns the largest squared distance moved by an owned
/// body, infinite for a state no longer finite.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn group(c: &Ctx, b: &mut Bodies, k: usize) -> Option<f32> {
    let i = b.first + k;
    let r = i..i + 8;
    let kr = k..k + 8;
    // Ghosts (other ranks' bodies) are not integrated here: their lanes run with the others
    // (each lane is independent) on zero forces, and what they write is overwritten by the
    // forward exchange right after (every word of the state), so groups that mix ghosts with
    // owned bodies (ghosts come in global id order) still run in lanes, with no copy kept.
    let ghosts = if c.ghost.is_empty() {
        0
    } else {
        (0..8).fold(0u32, |m, l| m | (c.ghost[i + l] as u32) << l)
    };
    if ghosts == 0xff {
        // Eight ghosts: nothing to integrate, nothing moved here (as the scalar `body`
        // returns for each); their forces are not even gathered.
        return Some(0.0);
    }
    if b.gone[kr.clone()].iter().any(|&g| g) {
        return None;
    }
    // SAFETY (loads and stores below): AVX2, and arrays of 8.
    let inv_inertia = unsafe { load_vec3(c.consts.inv_inertia[r.clone()].try_into().unwrap()) };
    // `angular_velocity`'s test, per lane: `x == y && y == z`.
    let isotropic = inv_inertia
        .x
        .eq(inv_inertia.y)
        .and(inv_inertia.y.eq(inv_inertia.z));
    if isotropic.bits() != 0xff {
        return None;
    }
    // The gather, per body as the scalar path does it; its sums' four lanes kept.
    // The loops `Contacts::gather8_padded` chose for the stage.
    let (f, t) = if c.padded_gather {
        c.contacts.gather8_with::<true>(i, ghosts)
    } else {
        c.contacts.gather8_with::<false>(i, ghosts)
    };
    let dt = F8::splat(c.dt);
    let [fx, fy, fz, _] = unsafe { load4(f.as_ptr() as *const f32) };
    let [tx, ty, tz, _] = unsafe { load4(t.as_ptr() as *const f32) };
    let (f, t) = (
        V3 {
            x: fx,
            y: fy,
            z: fz,
        },
        V3 {
            x: tx,
            y: ty,
            z: tz,
        },
    );

    // Velocity, then the precise position (`precise::advance_a` without a periodic box).
    let vs: &mut [Vec3; 8] = (&mut b.vs[kr.clone()]).try_into().unwrap();
    let inv_mass = F8(unsafe { _mm256_loadu_ps(c.consts.inv_mass[r.clone()].as_ptr()) });
    let v = unsafe { load_vec3(vs) } + (f * inv_mass + V3::splat(c.gravity)) * dt;
    unsafe { store_vec3(v, vs) };
    let dx = v * dt;
    let (xh, xl) = unsafe { load_pairs(c.pairs[r.clone()].try_into().unwrap()) };
    let zero = F8::splat(0.0);
    // `ds_add_a(x, (dx, 0))`, then `snap_a`, per component.
    let add = |h: F8, l: F8, d: F8| {
        let s = h + d;
        let v = s - h;
        let e = ((h - (s - v)) + (d - v)) + (l + zero);
        let hi = s + e;
        snap(hi, e - (hi - s))
    };
    let ((px, lx), (py, ly), (pz, lz)) = (
        add(xh.x, xl.x, dx.x),
        add(xh.y, xl.y, dx.y),
        add(xh.z, xl.z, dx.z),
    );
    let (p_hi, p_lo) = (
        V3 {
            x: px,
            y: py,
            z: pz,
        },
        V3 {
            x: lx,
            y: ly,
            z: lz,
        },
    );
    let rebuild = unsafe { load_dvec3_as_f32(c.rebuild_position[r.clone()].try_into().unwrap()) };
    let moved = (p_hi - rebuild) + p_lo;
    unsafe { store_joined(p_hi, p_lo, (&mut b.xs[kr.clone()]).try_into().unwrap()) };

    // Angular momentum, velocity (isotropic: `l * inv_inertia.x`), orientation (`rotate`).
    let ls: &mut [Vec3; 8] = (&mut b.ls[kr.clone()]).try_into().unwrap();
    let l = unsafe { load_vec3(ls) } + t * dt;
    unsafe { store_vec3(l, ls) };
    let w = l * inv_inertia.x;
    unsafe { store_vec3(w, (&mut b.ws[kr.clone()]).try_into().unwrap()) };
    let qs: &mut [Quat; 8] = (&mut b.qs[kr.clone()]).try_into().unwrap();
    let rs: &mut [Quat; 8] = (&mut b.rs[kr]).try_into().unwrap();
    let (q, res) = unsafe { (load_quat(qs), load_quat(rs)) };
    let h = F8::splat(0.5 * c.dt);
    let dq = mul_quat(
        Q8 {
            x: w.x * h,
            y: w.y * h,
            z: w.z * h,
            w: zero,
        },
        q,
    );
    let y = dq.zip(res, |a, b| a - b);
    let q2 = q.zip(y, |a, b| a + b);
    let res = q2.zip(q, |a, b| a - b).zip(y, |a, b| a - b);
    let n2 = q2.length_squared();
    let drifted = (n2 - F8::splat(1.0))
        .abs()
        .gt(F8::splat(4.0 * f32::EPSILON));
    let scale = F8::splat(1.5) - F8::splat(0.5) * n2;
    let q = q2.zip(q2, |a, _| F8::select(drifted, a * scale, a));
    unsafe {
        store_quat(q, qs);
        store_quat(res, rs);
    }

    // The Verlet test's distance; a state no longer finite shows up in it or in q.w.
    let d2 = moved.length_squared();
    let finite = |x: F8| x.abs().lt(F8::splat(f32::INFINITY));
    let d2 = F8::select(finite(d2).and(finite(q.w)), d2, F8::splat(f32::INFINITY));
    // A ghost has not moved here (as the scalar `body` returns for it).
    let d2 = if ghosts != 0 {
        let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let ghost =
            _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(ghosts as i32), bit), bit);
        F8(_mm256_andnot_ps(_mm256_castsi256_ps(ghost), d2.0))
    } else {
        d2
    };
    // The largest of the eight by halving: every lane is +0, positive or infinite (a sum of
    // squares, never -0 or NaN: a state no longer finite is infinite above), so the maximum
    // is the same value in any order, and that of the scalar fold from 0.
    let m = _mm256_max_ps(d2.0, _mm256_permute2f128_ps::<1>(d2.0, d2.0));
    let m = _mm256_max_ps(m, _mm256_shuffle_ps::<0b01_00_11_10>(m, m));
    let m = _mm256_max_ps(m, _mm256_shuffle_ps::<0b10_11_00_01>(m, m));
    Some(_mm256_cvtss_f32(m))
}

#[cfg(test)]
mod tests {
    use super::super::integrate::{Moved, freshest_first, run_in, run_ordered};
    use crate::geom::ShapeKind;
    use crate::{BodyInit, ContactForce, ContactLaw, Material, World, WorldDesc};
    use glam::{DVec3, Quat, Vec3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn vec(rng: &mut ChaCha8Rng, scale: f32) -> Vec3 {
        Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) * scale
    }

    /// A cloud of spheres (and, in some groups, a box, whose inertia is not isotropic, or a
    /// removed body) about `origin`, with random forces on every contact, random momenta,
    /// orientations off unit length by up to a few ulps (and some further), and residuals.
    fn cloud(rng: &mut ChaCha8Rng, origin: DVec3, odd: bool) -> World {
        let shapes = vec![
            ShapeKind::Sphere { radius: 0.01 }.prepare().unwrap(),
            ShapeKind::Box {
                half_extents: [0.01, 0.02, 0.005],
            }
            .prepare()
            .unwrap(),
        ];
        let material = Material::new("m", 2500.0, ContactLaw::Linear { stiffness: 2e4 }, 0.5, 0.5);
        let n = 1000 + rng.random_range(0..40);
        let bodies = (0..n)
            .map(|b| BodyInit {
                shape: (odd && b % 97 == 5) as u32,
                material: 0,
                position: origin
                    + DVec3::new(
                        rng.random_range(0.0..0.2),
                        rng.random_range(0.0..0.2),
                        rng.random_range(0.0..0.2),
                    ),
                orientation: Quat::IDENTITY,
                velocity: Vec3::ZERO,
                angular_velocity: Vec3::ZERO,
            })
            .collect();
        let mut w = World::new(WorldDesc {
            shapes,
            materials: vec![material],
            walls: vec![],
            bodies,
            gravity: Vec3::new(0.0, 0.3, -9.81),
            dt: None,
            skin: None,
            periodic: None,
        });
        w.rebuild_contacts();
        for f in w.contacts.springs_mut().forces.iter_mut() {
            let scale = [1e-3, 1.0, 1e2][rng.random_range(0..3)];
            *f = ContactForce::new(
                vec(rng, scale),
                vec(rng, scale * 0.01),
                vec(rng, scale * 0.01),
                1.0,
            );
        }
        let s = &mut w.state;
        for i in 0..n {
            s.velocity[i] = vec(rng, 2.0);
            s.angular_momentum[i] = vec(rng, 1e-5);
            let q = Quat::from_scaled_axis(vec(rng, 3.0));
            let stretch =
                [1.0, 1.0 + 2.0 * f32::EPSILON, 1.0 + 1e-6, 1.0 - 3e-7][rng.random_range(0..4)];
            s.orientation[i] = q * stretch;
            s.orientation_residual[i] = Quat::from_vec4(glam::Vec4::new(
                rng.random_range(-1e-8..1e-8),
                rng.random_range(-1e-8..1e-8),
                rng.random_range(-1e-8..1e-8),
                rng.random_range(-1e-8..1e-8),
            ));
            s.removed[i] = odd && rng.random_bool(0.01);
        }
        if odd {
            // A body at a coordinate below the precise grid's floor, and one whose state is
            // not finite.
            s.position[3] = DVec3::new(1e-30, -2e-31, 0.05);
            s.velocity[n / 2] = Vec3::new(f32::NAN, 0.0, 0.0);
        }
        if odd {
            // Other ranks' bodies here and there (`crate::domain`): not integrated here (a third
            // of the groups hold one; their lanes run with the others and are not kept: the
            // exchange overwrites them, so only the owned bodies' states are compared).
            w.ghost = (0..n).map(|_| rng.random_bool(0.05)).collect();
        }
        // Rebuild positions a little off the current ones.
        for i in 0..n {
            w.rebuild_position[i] = w.state.position[i] + vec(rng, 1e-3).as_dvec3();
        }
        w.split_positions();
        w
    }

    /// Every owned body's state words (a ghost's are the exchange's to write).
    fn state_bits(w: &World) -> Vec<u64> {
        let s = &w.state;
        let mut out = Vec::new();
        for i in (0..w.len()).filter(|&i| !w.is_ghost(i)) {
            out.extend(s.position[i].to_array().map(f64::to_bits));
            let f32s = [
                s.velocity[i].to_array().to_vec(),
                s.angular_momentum[i].to_array().to_vec(),
                s.omega[i].to_array().to_vec(),
                s.orientation[i].to_array().to_vec(),
                s.orientation_residual[i].to_array().to_vec(),
            ];
            out.extend(f32s.concat().into_iter().map(|v| v.to_bits() as u64));
            out.push(s.removed[i] as u64);
        }
        out
    }

    fn moved_bits(m: Moved) -> u64 {
        match m {
            Moved::Farthest(d2) => d2.to_bits() as u64,
            Moved::NonFinite => u64::MAX,
        }
    }

    #[test]
    fn the_lanes_give_the_scalar_bits() {
        if !crate::step::avx2() {
            eprintln!("no AVX2 here: nothing to compare");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(25);
        for case in 0..12 {
            let origin = [
                DVec3::ZERO,
                DVec3::new(100.0, -37.5, 2.0),
                DVec3::splat(-1e4),
            ][case % 3];
            let w = cloud(&mut rng, origin, case % 2 == 1);
            let (mut scalar, mut lanes) = (w.clone(), w.clone());
            let (a, b) = (run_in(&mut scalar, false), run_in(&mut lanes, true));
            assert_eq!(
                moved_bits(a),
                moved_bits(b),
                "case {case}: the distance moved"
            );
            let (a, b) = (state_bits(&scalar), state_bits(&lanes));
            if let Some(k) = (0..a.len()).find(|&k| a[k] != b[k]) {
                panic!(
                    "case {case}: owned body {}, word {}: {:x} vs {:x}",
                    k / 23,
                    k % 23,
                    a[k],
                    b[k]
                );
            }
            // The step did change the state.
            assert_ne!(state_bits(&w), a, "case {case}");
        }
    }

    /// The stage's chunks freshest first ([`freshest_first`]) against the order written out
    /// here: `threads` blocks of consecutive chunks (block `b` of `m`: `b m / threads` up
    /// to `(b + 1) m / threads`), each from its last chunk down; every chunk once; and with
    /// two threads the first half of the tasks (rayon's first split, at the middle) holds
    /// exactly the first half of the chunks, so the thread that wrote the first half of the
    /// forces reads them.
    #[test]
    fn chunks_go_freshest_first() {
        for m in 0..40usize {
            for threads in 1..6usize {
                let mut got: Vec<usize> = (0..m).collect();
                freshest_first(&mut got, threads);
                let blocks = threads.min(m).max(1);
                let mut want = Vec::new();
                for b in 0..blocks {
                    let (lo, hi) = (b * m / blocks, (b + 1) * m / blocks);
                    want.extend((lo..hi).rev());
                }
                assert_eq!(got, want, "{m} chunks, {threads} threads");
                let mut sorted = got.clone();
                sorted.sort();
                assert_eq!(sorted, (0..m).collect::<Vec<_>>(), "a permutation");
                if threads == 2 {
                    let mut first: Vec<usize> = got[..m / 2].to_vec();
                    first.sort();
                    assert_eq!(first, (0..m / 2).collect::<Vec<_>>(), "{m} chunks");
                }
            }
        }
        let mut eight: Vec<usize> = (0..8).collect();
        freshest_first(&mut eight, 2);
        assert_eq!(eight, [3, 2, 1, 0, 7, 6, 5, 4]);
        let mut four: Vec<usize> = (0..4).collect();
        freshest_first(&mut four, 1);
        assert_eq!(four, [3, 2, 1, 0]);
    }

    /// The stage freshest first (chunks and each chunk's bodies from the last down, the
    /// step's order) against the order before (chunks and bodies from the first up, kept as
    /// `run_ordered(.., false)`): every word of every owned body's state and the distance
    /// moved, bitwise, in lanes and body by body, on one to three threads (one to three
    /// blocks of chunks), with tails past the last eight, boxes (not isotropic: the
    /// scalar path inside a chunk of lanes), removed bodies, ghosts and a state that is
    /// not finite.
    #[test]
    fn freshest_first_gives_the_bits_of_body_order() {
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        for case in 0..6 {
            let origin = [
                DVec3::ZERO,
                DVec3::new(100.0, -37.5, 2.0),
                DVec3::splat(-1e4),
            ][case % 3];
            let w = cloud(&mut rng, origin, case % 2 == 1);
            for threads in 1..=3 {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                for lanes in [false, true] {
                    if lanes && !crate::step::avx2() {
                        continue;
                    }
                    let (mut before, mut fresh) = (w.clone(), w.clone());
                    let (a, b) = pool.install(|| {
                        (
                            run_ordered(&mut before, lanes, false),
                            run_ordered(&mut fresh, lanes, true),
                        )
                    });
                    let at = format!("case {case}, {threads} threads, lanes {lanes}");
                    assert_eq!(moved_bits(a), moved_bits(b), "{at}: the distance moved");
                    let (a, b) = (state_bits(&before), state_bits(&fresh));
                    if let Some(k) = (0..a.len()).find(|&k| a[k] != b[k]) {
                        panic!("{at}: owned body {}, word {}", k / 23, k % 23);
                    }
                    assert_ne!(state_bits(&w), a, "{at}: the step changed the state");
                }
            }
        }
    }
}

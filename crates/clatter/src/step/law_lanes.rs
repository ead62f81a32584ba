//! The plain law of one-point sphere contacts eight at a time, one contact per lane
//! ([`crate::law::point_contact_force_in`]`::<true>` with share 1 inside a contact, as
//! [`super::sphere_lanes`] and [`super::wall_lanes`] use it), and the stores of its
//! results into the contacts' slots. Each lane does the scalar law's IEEE operations on the
//! same values in the same order, so the same bits (see [`super::sphere_lanes`]).

use std::arch::x86_64::*;

use glam::Vec3;

use super::lanes::{F8, M8, V3, load_vec3, store_vec3};
use crate::contract::ContactForce;

/// What the law takes of eight contacts: the normal `n` (from side a to side b), the
/// overlap `depth`, the relative velocity `vrel` of b's contact point against a's, and the
/// pairs' constants.
pub(super) struct Contact8 {
    pub(super) n: V3,
    pub(super) depth: F8,
    pub(super) vrel: V3,
    pub(super) pair: Pair8,
}

/// What the law derives from a pair's parameters, its effective mass and the step alone
/// (no state): computed per group of eight, or once per chunk where every pair has the
/// same (a world of one material whose bodies all have one mass, `sphere_lanes`'s
/// `Uniform`): each lane the same operations on the same values, so the same bits.
#[derive(Clone, Copy)]
pub(super) struct Pair8 {
    pub(super) k: F8,
    pub(super) friction: F8,
    pub(super) m_eff: F8,
    pub(super) eta: F8,
    pub(super) half_eta: F8,
    /// `1 / (m_eff + eta dt / 2)`.
    pub(super) per_mass: F8,
    /// Steps too long for the in-step normal law (the explicit law's lanes).
    pub(super) explicit: M8,
    pub(super) kt: F8,
    pub(super) eta_t: F8,
}

/// [`Pair8::of`]'s body, written once for every lane width (`$f` the lanes' float type,
/// `$pair` the constants' type: [`F8`] and [`Pair8`], or `F16` and `Pair16` in
/// [`super::lanes16`]), so that the widths do the same operations lane for lane.
macro_rules! pair_constants {
    ($f:ident, $pair:ident; $stiffness:expr, $damping_factor:expr, $friction:expr,
     $m_eff:expr, $dt:expr) => {{
        let (k, damping_factor, friction, m_eff) = ($stiffness, $damping_factor, $friction, $m_eff);
        let eta = damping_factor * (m_eff * k.max_const(0.0)).sqrt();
        let dt = $f::splat($dt);
        let explicit = (dt * (dt * k + eta)).gt($f::splat($crate::law::RESOLVABLE) * m_eff);
        let half_eta = $f::splat(0.5) * eta;
        $pair {
            k,
            friction,
            m_eff,
            eta,
            half_eta,
            per_mass: $f::splat(1.0) / (m_eff + half_eta * dt),
            explicit,
            kt: $f::splat($crate::contract::LINEAR_TANGENTIAL_RATIO) * k,
            eta_t: $f::splat($crate::contract::TANGENTIAL_DAMPING_RATIO) * eta,
        }
    }};
}
pub(super) use pair_constants;

impl Pair8 {
    /// The constants of pairs with these parameters and effective masses, at step `dt`.
    ///
    /// # Safety
    /// AVX2.
    #[inline(always)]
    pub(super) unsafe fn of(
        stiffness: F8,
        damping_factor: F8,
        friction: F8,
        m_eff: F8,
        dt: f32,
    ) -> Pair8 {
        pair_constants!(F8, Pair8; stiffness, damping_factor, friction, m_eff, dt)
    }
}

/// The law's results in lanes: the force on b `f`, the normal force `fn_`, the new spring
/// `xi` and coverage `cov_after`, the springs and coverages read (`h`, `cov`), the lanes
/// left to the scalar code (`scalar`) and those the lanes' results hold for (`done`).
/// `f`, `fn_`, `xi` and `cov_after` are the scalar law's only in the `done` lanes (the
/// Coulomb caps are computed only where a `done` lane needs them); other lanes hold
/// anything and are not to be kept.
pub(super) struct Law8 {
    pub(super) f: V3,
    pub(super) fn_: F8,
    pub(super) xi: V3,
    pub(super) cov_after: F8,
    pub(super) h: V3,
    pub(super) cov: F8,
    pub(super) scalar: M8,
    pub(super) done: M8,
}

/// The lane law's body, written once for every lane width: `$f`, `$v` and `$law` are the
/// width's float, vector and results types ([`F8`], [`V3`], [`Law8`] for [`law`];
/// `F16`, `W3`, `Law16` for [`super::lanes16::law16`]), the rest the law's inputs, with the
/// springs `h` and coverages `cov` already loaded. Why a macro: the two widths must do the
/// same IEEE operations in the same order lane for lane (the same bits as the scalar law),
/// so they share one text and cannot drift apart; the types' operations are inlined
/// intrinsics, which a trait's generic code would hide behind `target_feature` boundaries.
macro_rules! lane_law {
    ($f:ident, $v:ident, $law:ident; $n:expr, $depth:expr, $vrel:expr, $p:expr, $touch:expr,
     $forced:expr, $dt:expr, $cov:expr, $h:expr) => {{
        let zero = $f::splat(0.0);
        let (n, depth, vrel, p, touch, forced, cov, h) =
            ($n, $depth, $vrel, $p, $touch, $forced, $cov, $h);
        let (m_eff, k, eta, half_eta) = (p.m_eff, p.k, p.eta, p.half_eta);
        let fs = k * depth;
        let dt = $f::splat($dt);
        let vn = vrel.dot(n);

        // `resolved_normal_force_in::<true>` inside a contact (not its first or last step).
        let v = -vn;
        let first = cov.eq(zero);
        let g_start = $f::select(cov.gt(zero), cov, zero);
        let g_x = eta * depth;
        let impulse = fs * dt + (g_x - g_start) + half_eta * v * dt;
        let per_mass = p.per_mass;
        let v_after = v - impulse * per_mass;
        let fn_ = impulse * per_mass * m_eff / dt;
        let stays =
            (depth + dt * v_after).gt($f::splat($crate::law::EDGE_SLACK) * dt * v_after.abs());
        let cov_after = (g_x + half_eta * dt * v_after).max_const(f32::MIN_POSITIVE);
        let scalar = touch
            .and(p.explicit.or(first).or(forced))
            .or(stays.and_not(touch));
        let done = scalar.and_not(touch);

        // `tangential_law`.
        let (kt, eta_t) = (p.kt, p.eta_t);
        let vt = vrel - n * vn;
        let along = h.dot(n);
        let old_len2 = h.length_squared();
        let turned = h - n * along;
        let new_len2 = turned.length_squared();
        let rescaled = $v::select(
            new_len2.gt(zero),
            turned * (old_len2 / new_len2).sqrt(),
            turned,
        );
        let xi = $v::select(along.ne(zero), rescaled, h) + vt * dt;
        let cap = p.friction * fn_.max_const(0.0);
        let cap2 = cap * cap;
        let spring2 = kt * kt * xi.length_squared();
        // The Coulomb caps' square roots and divisions only where a lane whose results are
        // kept (`done`) is capped: in a settled pile few slide. Other lanes are thrown away
        // by `store` (a lane that does not touch, whose cap is 0, would always count as
        // capped).
        let over = spring2.gt(cap2).and(done);
        let xi = if over.bits() != 0 {
            $v::select(over, xi * (cap / spring2.sqrt()), xi)
        } else {
            xi
        };
        let ft = xi * -kt - vt * eta_t;
        let ft_len2 = ft.length_squared();
        let over = ft_len2.gt(cap2).and(done);
        let ft = if over.bits() != 0 {
            $v::select(over, ft * (cap / ft_len2.sqrt()), ft)
        } else {
            ft
        };
        $law {
            f: n * fn_ + ft,
            fn_,
            xi,
            cov_after,
            h,
            cov,
            scalar,
            done,
        }
    }};
}
pub(super) use lane_law;

/// The law on eight contacts (`touch`: the lanes that touch now; `forced`: touching lanes
/// to leave to the scalar code whatever the law says), with their springs `hist` and
/// coverages `coverage` as stored; nothing is written.
///
/// Lanes left to the scalar code: a contact's first and last steps (the in-step normal
/// law's fixed-point iterations), steps too long for the contact (the explicit law), and
/// `forced`.
///
/// # Safety
/// AVX2.
// Inlined into its callers (AVX2 functions both), not called: a call returned its
// thirteen lanes through memory and spilled the caller's registers around it. Without
// `target_feature` of its own (which `inline(always)` does not allow), it takes its callers'.
#[inline(always)]
pub(super) unsafe fn law(
    c: &Contact8,
    touch: M8,
    forced: M8,
    dt: f32,
    hist: &[Vec3; 8],
    coverage: &[f32; 8],
) -> Law8 {
    // SAFETY: 8 `f32`s.
    let cov = F8(unsafe { _mm256_loadu_ps(coverage.as_ptr()) });
    // SAFETY: AVX2.
    let h = unsafe { load_vec3(hist) };
    lane_law!(F8, V3, Law8; c.n, c.depth, c.vrel, &c.pair, touch, forced, dt, cov, h)
}

/// Stores the law's results (`torques`: on a and on b) in eight contacts' slots: the
/// lanes' results where they hold; zeros where the contact is apart (a release, or one
/// that did not touch before either, whose force is zero already); springs kept where
/// nothing touches and in the scalar code's lanes (which read them). The touching flags
/// become `touch`; `was` is what they held.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn store(
    out: &Law8,
    touch: M8,
    was: M8,
    (torque_a, torque_b): (V3, V3),
    hist: &mut [Vec3; 8],
    coverage: &mut [f32; 8],
    force: &mut [ContactForce; 8],
    touching: &mut [bool; 8],
) {
    let zero = F8::splat(0.0);
    let done = out.done;
    let released = touch.and_not(was);
    let h_out = V3::select(
        done,
        out.xi,
        V3::select(released, V3::splat(Vec3::ZERO), out.h),
    );
    let cov_out = F8::select(done, out.cov_after, F8::select(released, zero, out.cov));
    let only = |v: V3| V3::select(done, v, V3::splat(Vec3::ZERO));
    // SAFETY: AVX2; 8 slots each.
    unsafe {
        store_vec3(h_out, hist);
        _mm256_storeu_ps(coverage.as_mut_ptr(), cov_out.0);
        store_forces(
            only(out.f),
            F8::select(done, out.fn_, zero),
            only(torque_a),
            only(torque_b),
            force,
        );
    }
    let (touch_bits, was_bits) = (touch.bits(), was.bits());
    if touch_bits ^ was_bits != 0 {
        for (l, t) in touching.iter_mut().enumerate() {
            *t = touch_bits >> l & 1 != 0;
        }
    }
}

/// The touching flags of eight contacts as lane masks.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn was_touching(touching: &[bool; 8]) -> M8 {
    // SAFETY: 8 bytes, each 0 or 1 (`bool`).
    let bytes = unsafe { (touching.as_ptr() as *const u64).read_unaligned() };
    M8(_mm256_castsi256_ps(_mm256_cmpgt_epi32(
        _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(bytes as i64)),
        _mm256_setzero_si256(),
    )))
}

/// Eight [`ContactForce`]s from their fields in lanes: `f` the force on b and `fn_` the
/// normal force, `ta` and `tb` the torques (pads zero).
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn store_forces(f: V3, fn_: F8, ta: V3, tb: V3, out: &mut [ContactForce; 8]) {
    let zero = _mm256_setzero_ps();
    // Per group of four fields, a 4x8 transpose: `r[l]` holds lanes l (low half) and l + 4
    // (high half) of the four.
    let transpose = |a: __m256, b: __m256, c: __m256, d: __m256| {
        let (t0, t1) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
        let (t2, t3) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
        [
            _mm256_shuffle_ps::<0x44>(t0, t2),
            _mm256_shuffle_ps::<0xEE>(t0, t2),
            _mm256_shuffle_ps::<0x44>(t1, t3),
            _mm256_shuffle_ps::<0xEE>(t1, t3),
        ]
    };
    let g = [
        transpose(f.x.0, f.y.0, f.z.0, fn_.0),
        transpose(ta.x.0, ta.y.0, ta.z.0, zero),
        transpose(tb.x.0, tb.y.0, tb.z.0, zero),
    ];
    // Records l and l + 1 (l = 0, 2) are the 96 bytes `g0 g1 g2` of lane l then of lane
    // l + 1; lanes l + 4 and l + 5 are the high halves.
    let p = out.as_mut_ptr() as *mut f32;
    for (l, r) in [(0usize, 0usize), (2, 2)] {
        let (lo, hi) = (l * 12, (l + 4) * 12);
        let (u, v) = (r, r + 1);
        let pieces = [(g[0][u], g[1][u]), (g[2][u], g[0][v]), (g[1][v], g[2][v])];
        for (s, (a, b)) in pieces.into_iter().enumerate() {
            // SAFETY: 96 `f32`s from `p`, written within them.
            unsafe {
                _mm256_storeu_ps(p.add(lo + 8 * s), _mm256_permute2f128_ps::<0x20>(a, b));
                _mm256_storeu_ps(p.add(hi + 8 * s), _mm256_permute2f128_ps::<0x31>(a, b));
            }
        }
    }
}

/// Eight pairs' indices, `a0 b0 a1 b1 ...`, split into `a0..a7` and `b0..b7` (the first and
/// second index of each pair: two bodies, or a sphere and a wall).
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn split_pairs(pairs: &[[u32; 2]; 8]) -> (__m256i, __m256i) {
    let p = pairs.as_ptr() as *const __m256i;
    // SAFETY: 16 `u32`s from `p`.
    let (lo, hi) = unsafe {
        (
            _mm256_castsi256_ps(_mm256_loadu_si256(p)),
            _mm256_castsi256_ps(_mm256_loadu_si256(p.add(1))),
        )
    };
    // The shuffles give a0 a1 a4 a5 a2 a3 a6 a7 (and b likewise): swap the middle 64 bits.
    let order = |v: __m256| _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_castps_si256(v));
    (
        order(_mm256_shuffle_ps::<0b10_00_10_00>(lo, hi)),
        order(_mm256_shuffle_ps::<0b11_01_11_01>(lo, hi)),
    )
}

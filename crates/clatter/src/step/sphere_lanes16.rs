//! The sphere pairs of the **contacts** stage sixteen at a time on the plain law: the AVX-512
//! build of [`super::sphere_lanes`], with its bits. Two groups of eight are read and stored
//! by the AVX2 code (the pair split, the positions' offsets, the velocity loads, the stores),
//! joined into sixteen lanes for the geometry's root and divisions and for the law
//! ([`super::lanes16::law16`]), whose divisions and square roots are what the sphere step
//! waits on: a 512-bit divider does sixteen in the time of eight. Every lane does the AVX2
//! lanes' IEEE operations on the same values in the same order, so the same bits; what they
//! hand to the scalar code (a contact's first and last steps, the explicit law's steps,
//! releases of an all-apart group) the same lanes hand to it here.

use std::arch::x86_64::*;

use glam::Vec3;

use super::contacts::sphere_pair;
use super::lanes::{F8, gather, load_vec3_at};
use super::lanes16::{F16, M16, Pair16, W3, law16};
use super::law_lanes::{split_pairs, store, was_touching};
use super::sphere_lanes::{Bodies, Shared, Uniform, group, params, split_positions};
use crate::contract::ContactForce;
use crate::precise::Ds3A;
use crate::world::World;

/// [`Shared`] sixteen wide: what a uniform world's groups share.
#[derive(Clone, Copy)]
struct Shared16 {
    radius: F16,
    sum: F16,
    reach2: F16,
    pair: Pair16,
}

impl Shared16 {
    #[inline(always)]
    fn of(s: &Shared) -> Shared16 {
        let j = |v| F16::join(v, v);
        Shared16 {
            radius: j(s.radius),
            sum: j(s.sum),
            reach2: j(s.reach2),
            pair: Pair16::twice(&s.pair),
        }
    }
}

/// The body-pair chunk's sphere pairs on the plain law, sixteen at a time; a last group of
/// eight by [`group`] (the AVX2 lanes), the rest (`len % 8`) by the scalar code. Returns
/// the number that touch.
///
/// # Safety
/// The CPU must have AVX-512F, DQ and VL ([`super::avx512`]).
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn sphere_chunk(
    w: &World,
    x: &[Ds3A],
    uniform: Option<Uniform>,
    pairs: &[[u32; 2]],
    hist: &mut [Vec3],
    coverage: &mut [f32],
    force: &mut [ContactForce],
    touching: &mut [bool],
) -> usize {
    let n = pairs.len();
    let (hist, coverage, force, touching) = (
        &mut hist[..n],
        &mut coverage[..n],
        &mut force[..n],
        &mut touching[..n],
    );
    let bodies = Bodies::of(w, x);
    // SAFETY: AVX2 (implied by this function's AVX-512F).
    let shared = uniform.map(|u| unsafe { Shared::of(&bodies, u) });
    let wide = shared.as_ref().map(Shared16::of);
    let mut count = 0;
    let groups = n / 16;
    for g in 0..groups {
        let r = 16 * g..16 * g + 16;
        // SAFETY: AVX-512 (this function's); each slice is 16 long.
        count += unsafe {
            group16(
                w,
                &bodies,
                wide.as_ref(),
                pairs[r.clone()].try_into().unwrap(),
                (&mut hist[r.clone()]).try_into().unwrap(),
                (&mut coverage[r.clone()]).try_into().unwrap(),
                (&mut force[r.clone()]).try_into().unwrap(),
                (&mut touching[r]).try_into().unwrap(),
            )
        };
    }
    let mut k = 16 * groups;
    if n - k >= 8 {
        let r = k..k + 8;
        // SAFETY: AVX2 (implied); each slice is 8 long.
        count += unsafe {
            group(
                w,
                &bodies,
                shared.as_ref(),
                pairs[r.clone()].try_into().unwrap(),
                (&mut hist[r.clone()]).try_into().unwrap(),
                (&mut coverage[r.clone()]).try_into().unwrap(),
                (&mut force[r.clone()]).try_into().unwrap(),
                (&mut touching[r]).try_into().unwrap(),
            )
        };
        k += 8;
    }
    for k in k..n {
        count += sphere_pair::<true>(
            w,
            x,
            pairs[k],
            &mut hist[k],
            &mut coverage[k],
            &mut force[k],
            &mut touching[k],
        ) as usize;
    }
    count
}

/// A group's two halves of eight.
#[inline(always)]
fn halves<T>(a: &[T; 16]) -> (&[T; 8], &[T; 8]) {
    let (lo, hi) = a.split_at(8);
    (lo.try_into().unwrap(), hi.try_into().unwrap())
}

/// A group's two halves of eight, to write.
#[inline(always)]
fn halves_mut<T>(a: &mut [T; 16]) -> (&mut [T; 8], &mut [T; 8]) {
    let (lo, hi) = a.split_at_mut(8);
    (lo.try_into().unwrap(), hi.try_into().unwrap())
}

/// `j`'s offset from `i` in sixteen lanes (the indices in two halves of eight):
/// [`super::sphere_lanes`]' `offset`, each lane the same operations (`precise::offset_a`:
/// `ds_sub_a`, then the nearest periodic image).
///
/// # Safety
/// AVX-512F and DQ; every index below `b.x.len()`.
// Inlined, as `law16`: a call returned its lanes through memory.
#[inline(always)]
unsafe fn offset16(b: &Bodies, (i0, i1): (__m256i, __m256i), (j0, j1): (__m256i, __m256i)) -> W3 {
    // SAFETY: the caller's bounds; AVX2 (implied).
    let (xi, xj) = unsafe {
        (
            [split_positions(b.x, i0), split_positions(b.x, i1)],
            [split_positions(b.x, j0), split_positions(b.x, j1)],
        )
    };
    let zero = F16::splat(0.0);
    let (mut d_hi, mut d_lo) = ([zero; 3], [zero; 3]);
    for c in 0..3 {
        let row = |x: &[[F8; 8]; 2], r: usize| F16::join(x[0][r], x[1][r]);
        let (ih, il, jh, jl) = (row(&xi, c), row(&xi, 4 + c), row(&xj, c), row(&xj, 4 + c));
        // `ds_sub_a(xj, xi)`.
        let s = jh - ih;
        let v = s - jh;
        let e = ((jh - (s - v)) - (ih + v)) + (jl - il);
        d_hi[c] = s + e;
        d_lo[c] = e - (d_hi[c] - s);
    }
    if let Some(len) = b.periodic {
        // `nearest`: each periodic axis's shift, then, where any axis shifts, `ds_add` of
        // the shift (its low part 0) on all three.
        let mut any = zero.ne(zero);
        let mut shifted = d_hi;
        for c in 0..3 {
            let len = len[c];
            let shift = if len > 0.0 {
                let up = d_hi[c].gt(F16::splat(0.5 * len));
                let down = d_hi[c].lt(F16::splat(-0.5 * len));
                F16::select(
                    up,
                    F16::splat(-len),
                    F16::select(down, F16::splat(len), zero),
                )
            } else {
                zero
            };
            any = any.or(shift.ne(zero));
            let s = d_hi[c] + shift;
            let v = s - d_hi[c];
            let e = ((d_hi[c] - (s - v)) + (shift - v)) + (d_lo[c] + zero);
            shifted[c] = s + e;
        }
        for c in 0..3 {
            d_hi[c] = F16::select(any, shifted[c], d_hi[c]);
        }
    }
    W3 {
        x: d_hi[0],
        y: d_hi[1],
        z: d_hi[2],
    }
}

/// Sixteen pairs (`pairs`, with their slots): [`group`]'s work on two groups of eight at
/// once. Returns the number that touch.
///
/// # Safety
/// AVX-512F, DQ and VL.
#[inline]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2")]
#[allow(clippy::too_many_arguments)]
unsafe fn group16(
    w: &World,
    b: &Bodies,
    shared: Option<&Shared16>,
    pairs: &[[u32; 2]; 16],
    hist: &mut [Vec3; 16],
    coverage: &mut [f32; 16],
    force: &mut [ContactForce; 16],
    touching: &mut [bool; 16],
) -> usize {
    let (p0, p1) = halves(pairs);
    // SAFETY (all AVX2 calls below): implied by this function's AVX-512F.
    let ((i0, j0), (i1, j1)) = unsafe { (split_pairs(p0), split_pairs(p1)) };
    // Every index in bounds (unsigned) before anything is read through them.
    let top = _mm256_set1_epi32(b.x.len() as i32 - 1);
    let highest = _mm256_max_epu32(
        _mm256_max_epu32(_mm256_max_epu32(i0, j0), _mm256_max_epu32(i1, j1)),
        top,
    );
    assert!(_mm256_movemask_epi8(_mm256_cmpeq_epi32(highest, top)) == -1);

    // SAFETY (all reads below): indices bounded above; the arrays cover every body
    // (checked by `Bodies::of`).
    let d = unsafe { offset16(b, (i0, i1), (j0, j1)) };
    let (ri, sum, reach2) = match shared {
        Some(s) => (s.radius, s.sum, s.reach2),
        None => {
            let r = |i| unsafe { gather(b.radius.as_ptr(), i) };
            let (ri, rj) = (F16::join(r(i0), r(i1)), F16::join(r(j0), r(j1)));
            (ri, ri + rj, (ri + rj) * (ri + rj))
        }
    };
    let dist2 = d.length_squared();
    let touch = dist2.lt(reach2);
    let (t0, t1) = halves(touching);
    let was = unsafe { M16::join(was_touching(t0), was_touching(t1)) };
    let (touch_bits, was_bits) = (touch.bits(), was.bits());
    if touch_bits == 0 {
        // All apart: only releases, if any (rare), each as the scalar path does it.
        for l in 0..16 {
            if was_bits >> l & 1 != 0 {
                sphere_pair::<true>(
                    w,
                    b.x,
                    pairs[l],
                    &mut hist[l],
                    &mut coverage[l],
                    &mut force[l],
                    &mut touching[l],
                );
            }
        }
        return 0;
    }

    // `sphere_pair`'s geometry.
    let zero = F16::splat(0.0);
    let dist = dist2.sqrt();
    let n = W3::select(dist.gt(zero), d / dist, W3::splat(Vec3::Z));
    let depth = sum - dist;
    let pair = match shared {
        Some(s) => s.pair,
        None => unsafe {
            let ((s0, e0, f0), (s1, e1, f1)) = (params(b, i0, j0), params(b, i1, j1));
            let m = |i| gather(b.mass.as_ptr(), i);
            let (mi, mj) = (F16::join(m(i0), m(i1)), F16::join(m(j0), m(j1)));
            Pair16::of(
                F16::join(s0, s1),
                F16::join(e0, e1),
                F16::join(f0, f1),
                mi * mj / (mi + mj),
                b.dt,
            )
        },
    };
    let point = n * (ri - F16::splat(0.5) * depth);

    // `point_contact_force_in::<true>` with share 1, side a body i at the origin, side b
    // body j at `d`.
    let at = |v: &[Vec3], lo, hi| unsafe { W3::join(load_vec3_at(v, lo), load_vec3_at(v, hi)) };
    let (vi, wi) = (at(b.velocity, i0, i1), at(b.omega, i0, i1));
    let (vj, wj) = (at(b.velocity, j0, j1), at(b.omega, j0, j1));
    let vrel = (vj + wj.cross(point - d)) - (vi + wi.cross(point));
    // SAFETY: AVX-512 (this function's).
    let out = unsafe { law16((n, depth, vrel), &pair, touch, b.dt, hist, coverage) };
    let torque_a = out.f.cross(point);
    let torque_b = (point - d).cross(out.f);
    {
        let (h0, h1) = halves_mut(hist);
        let (c0, c1) = halves_mut(coverage);
        let (f0, f1) = halves_mut(force);
        let (t0, t1) = halves_mut(touching);
        // SAFETY: AVX2 (implied).
        unsafe {
            store(
                &out.half::<0>(),
                touch.half::<0>(),
                was.half::<0>(),
                (torque_a.half::<0>(), torque_b.half::<0>()),
                h0,
                c0,
                f0,
                t0,
            );
            store(
                &out.half::<1>(),
                touch.half::<1>(),
                was.half::<1>(),
                (torque_a.half::<1>(), torque_b.half::<1>()),
                h1,
                c1,
                f1,
                t1,
            );
        }
    }
    let scalar_bits = out.scalar.bits();
    if scalar_bits != 0 {
        for l in 0..16 {
            if scalar_bits >> l & 1 != 0 {
                sphere_pair::<true>(
                    w,
                    b.x,
                    pairs[l],
                    &mut hist[l],
                    &mut coverage[l],
                    &mut force[l],
                    &mut touching[l],
                );
            }
        }
    }
    touch_bits.count_ones() as usize
}

#[cfg(test)]
mod tests {
    use super::super::sphere_lanes::tests::{cloud, slot_bits, springs};
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The sixteen lanes against the scalar code and the eight lanes, every bit of every
    /// slot, on `sphere_lanes`' random clouds (one or three materials, one size or four,
    /// periodic or not, steps short, long and too long for the in-step law; pairs exactly
    /// on top of each other and exactly the sum of the radii apart; springs under and over
    /// the Coulomb cap, first steps, releases), in chunks of lengths that leave every tail
    /// (a last group of eight, fewer than eight, none).
    #[test]
    fn the_sixteen_lanes_give_the_eight_lanes_bits() {
        if !crate::step::avx512() {
            eprintln!("NOT TESTED: no AVX-512 (F, DQ, VL) here, the 16-lane build cannot run");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(22);
        let lengths = [1024, 29, 8, 16, 7, 100, 24, 31, 512, 3];
        let (mut pairs, mut touching, mut changed, mut uniforms) = (0, 0, 0, 0);
        for case in 0..24 {
            let materials = if case % 3 == 0 { 1 } else { 3 };
            let periodic = case % 4 == 1;
            let dt = [None, Some(2e-4), Some(2e-5), Some(3e-3)][case % 4];
            let one = case % 3 == 0 && case % 8 != 0;
            let mut w = cloud(&mut rng, materials, if one { 1 } else { 4 }, periodic, dt);
            let uniform = Uniform::of(&w);
            assert_eq!(uniform.is_some(), one, "case {case}");
            uniforms += one as usize;
            w.rebuild_contacts();
            w.split_positions();
            let np = w.contacts.pairs.len();
            let before = springs(&mut rng, np);
            let (mut a, mut b, mut c) = (before.clone(), before.clone(), before.clone());
            let x = w.position_pairs.as_slice();
            let p = &w.contacts.pairs;
            let ta = super::super::contacts::sphere_chunk::<true>(
                &w,
                x,
                p,
                &mut a.history,
                &mut a.twist,
                &mut a.forces,
                &mut a.touching,
            );
            // SAFETY: the CPU has AVX2 (implied by `avx512`).
            let tb = unsafe {
                super::super::sphere_lanes::sphere_chunk8(
                    &w,
                    x,
                    uniform,
                    p,
                    &mut b.history,
                    &mut b.twist,
                    &mut b.forces,
                    &mut b.touching,
                )
            };
            let (mut tc, mut start) = (0, 0);
            for len in lengths.iter().cycle() {
                if start == np {
                    break;
                }
                let r = start..(start + len).min(np);
                // SAFETY: the CPU has AVX-512F, DQ and VL (checked above).
                tc += unsafe {
                    sphere_chunk(
                        &w,
                        x,
                        uniform,
                        &p[r.clone()],
                        &mut c.history[r.clone()],
                        &mut c.twist[r.clone()],
                        &mut c.forces[r.clone()],
                        &mut c.touching[r.clone()],
                    )
                };
                start = r.end;
            }
            assert_eq!((ta, ta), (tb, tc), "case {case}: touching counts");
            for (k, pair) in p.iter().enumerate() {
                let (sa, sb, sc) = (slot_bits(&a, k), slot_bits(&b, k), slot_bits(&c, k));
                assert_eq!(sa, sb, "case {case}, pair {k}: scalar and 8 lanes");
                assert_eq!(
                    sb,
                    sc,
                    "case {case}, pair {k} {:?}: 8 lanes {:?}, 16 lanes {:?}",
                    pair,
                    (b.history[k], b.twist[k], b.forces[k], b.touching[k]),
                    (c.history[k], c.twist[k], c.forces[k], c.touching[k]),
                );
                touching += c.touching[k] as usize;
                changed += (c.touching[k] != before.touching[k]) as usize;
            }
            pairs += np;
        }
        eprintln!("{pairs} pairs, {touching} touching, {changed} changed");
        assert!(pairs > 50_000, "{pairs} pairs");
        assert_eq!(uniforms, 7);
        assert!(touching > pairs / 5 && touching < pairs * 4 / 5);
        assert!(changed > pairs / 10, "{changed} changed");
    }
}

//! The sphere pairs of the **contacts** stage eight at a time, one pair per lane of an AVX2
//! register, on the plain law ([`crate::law::is_plain`]): the offset of the two centres, the
//! distance test and [`crate::law::point_contact_force_in`]`::<true>` as [`super::contacts`]'s
//! `sphere_pair` computes them, with the same bits.
//!
//! Why the same bits: each lane does the scalar path's IEEE operations on the same values in
//! the same order (no fused multiply-add; square roots and divisions are correctly rounded
//! in both), and every branch of the scalar path becomes a comparison and a blend that picks
//! the value that branch would have produced. `max(x, c)` against a constant `c` that is not
//! NaN is `x > c ? x : c` in both (`vmaxps` with `c` second, as LLVM lowers Rust's `max`
//! there). What lanes do not cover they hand back to the scalar code: a contact's first step
//! and its last (the in-step normal law's fixed-point iterations), a step too long for the
//! contact (the explicit law), the released contacts of an all-apart group, and the chunk's
//! last `len % 8` pairs.
//!
//! A contact that does not touch holds a zero force (the gather, `Contacts::gather`, relies
//! on it too), so lanes that neither touch nor touched store zeros; their springs are kept.

use std::arch::x86_64::*;
use std::mem::offset_of;

use glam::Vec3;

use super::contacts::sphere_pair;
use super::lanes::{F8, V3, gather, load_vec3_at};
use super::law_lanes::{Contact8, Pair8, law, split_pairs, store, was_touching};
use crate::contract::{ContactForce, PairParams};
use crate::precise::Ds3A;
use crate::world::World;

/// What every group of a chunk shares: the bodies' data, the table of pair parameters and
/// the step.
pub(super) struct Bodies<'a> {
    pub(super) x: &'a [Ds3A],
    pub(super) radius: &'a [f32],
    pub(super) mass: &'a [f32],
    pub(super) material: &'a [u32],
    pub(super) velocity: &'a [Vec3],
    pub(super) omega: &'a [Vec3],
    pub(super) table: &'a [PairParams],
    pub(super) materials: usize,
    /// The periodic box's length per axis (0 where not periodic), if any.
    pub(super) periodic: Option<Vec3>,
    pub(super) dt: f32,
}

impl<'a> Bodies<'a> {
    /// The world's bodies with their split positions `x`. Panics unless every array the
    /// lanes' gathers read (without bounds checks) covers every body, and the indices fit
    /// the gathers' 32-bit offsets.
    pub(super) fn of(w: &'a World, x: &'a [Ds3A]) -> Bodies<'a> {
        let bodies = Bodies {
            x,
            radius: &w.consts.radius,
            mass: &w.consts.mass,
            material: &w.consts.material,
            velocity: &w.state.velocity,
            omega: &w.state.omega,
            table: w.materials.table(),
            materials: w.materials.len(),
            periodic: w.periodic.as_ref().map(|p| p.length()),
            dt: w.dt,
        };
        let nb = bodies.x.len();
        assert!(
            [
                bodies.radius.len(),
                bodies.mass.len(),
                bodies.material.len()
            ]
            .into_iter()
            .chain([bodies.velocity.len(), bodies.omega.len()])
            .all(|len| len == nb)
                && nb < (1 << 28)
                && bodies.table.len() == bodies.materials * bodies.materials
                && bodies.materials < (1 << 13)
        );
        bodies
    }
}

/// A world whose pairs share their radii, masses and parameters: one material, and every
/// body of one radius and one mass (a monodisperse pile). Its pairs' sums of radii and
/// law constants ([`Pair8`]) are then computed once per chunk rather than per group of
/// eight (the same operations on the same values, so the same bits), and the bodies'
/// radii and masses are not gathered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Uniform {
    pub(super) radius: f32,
    pub(super) mass: f32,
}

impl Uniform {
    /// The world's uniform radius and mass, if it has one material and every body the
    /// same radius and mass, bit for bit.
    pub(super) fn of(w: &World) -> Option<Uniform> {
        let (radius, mass) = (&w.consts.radius, &w.consts.mass);
        let (&r, &m) = (radius.first()?, mass.first()?);
        if w.materials.len() != 1 || mass.len() != radius.len() {
            return None;
        }
        // Without early exits, in blocks: a loop the compiler vectorises (a step's cost).
        let same = |v: &[f32], x: f32| {
            v.chunks(64).all(|c| {
                c.iter()
                    .fold(true, |ok, &y| ok & (y.to_bits() == x.to_bits()))
            })
        };
        (same(radius, r) && same(mass, m)).then_some(Uniform { radius: r, mass: m })
    }
}

/// What a chunk's groups share in a [`Uniform`] world, in lanes.
#[derive(Clone, Copy)]
pub(super) struct Shared {
    pub(super) radius: F8,
    /// `ri + rj`.
    pub(super) sum: F8,
    /// `(ri + rj) * (ri + rj)`.
    pub(super) reach2: F8,
    pub(super) pair: Pair8,
}

impl Shared {
    /// # Safety
    /// AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn of(b: &Bodies, u: Uniform) -> Shared {
        let (r, m) = (F8::splat(u.radius), F8::splat(u.mass));
        let sum = r + r;
        let p = &b.table[0];
        let pair = unsafe {
            Pair8::of(
                F8::splat(p.stiffness),
                F8::splat(p.damping_factor),
                F8::splat(p.friction),
                m * m / (m + m),
                b.dt,
            )
        };
        Shared {
            radius: r,
            sum,
            reach2: sum * sum,
            pair,
        }
    }
}

/// The body-pair chunk's sphere pairs on the plain law (what `sphere_chunk::<true>` does):
/// sixteen pairs at a time where the CPU has AVX-512 ([`super::avx512`],
/// [`super::sphere_lanes16`]), eight otherwise ([`sphere_chunk8`]); the same bits either
/// way. Returns the number that touch.
///
/// # Safety
/// The CPU must have AVX2.
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
    if super::avx512() {
        // SAFETY: the CPU has AVX-512F, DQ and VL (`avx512`).
        return unsafe {
            super::sphere_lanes16::sphere_chunk(
                w, x, uniform, pairs, hist, coverage, force, touching,
            )
        };
    }
    // SAFETY: the caller's AVX2.
    unsafe { sphere_chunk8(w, x, uniform, pairs, hist, coverage, force, touching) }
}

/// The body-pair chunk's sphere pairs on the plain law (what `sphere_chunk::<true>` does),
/// eight pairs at a time; returns the number that touch. The scalar code does the rest of
/// the chunk (`pairs.len() % 8`) and the lanes this path leaves to it (see the module docs).
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn sphere_chunk8(
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
    // SAFETY: AVX2 (this function's).
    let shared = uniform.map(|u| unsafe { Shared::of(&bodies, u) });
    let mut count = 0;
    let groups = n / 8;
    for g in 0..groups {
        let k = 8 * g;
        let r = k..k + 8;
        // SAFETY: AVX2 (the caller's); each slice is 8 long.
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
    }
    for k in 8 * groups..n {
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

/// The split positions of bodies `idx` in lanes: rows 0 to 2 the high parts' components,
/// rows 4 to 6 the low parts' (rows 3 and 7 the pads). Each body's 32 bytes are one load,
/// and the eight are transposed: fewer cycles than a gather per row.
///
/// # Safety
/// AVX2; every `idx[l] < x.len()`.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn split_positions(x: &[Ds3A], idx: __m256i) -> [F8; 8] {
    const {
        assert!(size_of::<Ds3A>() == 32 && offset_of!(Ds3A, hi) == 0);
        assert!(offset_of!(Ds3A, lo) == 16);
    }
    let mut ids = [0u32; 8];
    // SAFETY: 8 `u32`s.
    unsafe { _mm256_storeu_si256(ids.as_mut_ptr() as *mut __m256i, idx) };
    let base = x.as_ptr() as *const f32;
    let mut r = [_mm256_setzero_ps(); 8];
    for (r, k) in r.iter_mut().zip(ids) {
        // SAFETY: the 32 bytes of body `k < x.len()` (the caller's).
        *r = unsafe { _mm256_loadu_ps(base.add(8 * k as usize)) };
    }
    // An 8x8 transpose: pairs of rows interleaved, then quarters, then halves.
    let (t0, t1) = (
        _mm256_unpacklo_ps(r[0], r[1]),
        _mm256_unpackhi_ps(r[0], r[1]),
    );
    let (t2, t3) = (
        _mm256_unpacklo_ps(r[2], r[3]),
        _mm256_unpackhi_ps(r[2], r[3]),
    );
    let (t4, t5) = (
        _mm256_unpacklo_ps(r[4], r[5]),
        _mm256_unpackhi_ps(r[4], r[5]),
    );
    let (t6, t7) = (
        _mm256_unpacklo_ps(r[6], r[7]),
        _mm256_unpackhi_ps(r[6], r[7]),
    );
    let s = [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
        _mm256_shuffle_ps::<0x44>(t4, t6),
        _mm256_shuffle_ps::<0xEE>(t4, t6),
        _mm256_shuffle_ps::<0x44>(t5, t7),
        _mm256_shuffle_ps::<0xEE>(t5, t7),
    ];
    [
        F8(_mm256_permute2f128_ps::<0x20>(s[0], s[4])),
        F8(_mm256_permute2f128_ps::<0x20>(s[1], s[5])),
        F8(_mm256_permute2f128_ps::<0x20>(s[2], s[6])),
        F8(_mm256_permute2f128_ps::<0x20>(s[3], s[7])),
        F8(_mm256_permute2f128_ps::<0x31>(s[0], s[4])),
        F8(_mm256_permute2f128_ps::<0x31>(s[1], s[5])),
        F8(_mm256_permute2f128_ps::<0x31>(s[2], s[6])),
        F8(_mm256_permute2f128_ps::<0x31>(s[3], s[7])),
    ]
}

/// `j`'s offset from `i` in lanes: `precise::offset_a` (the difference of the double-single
/// pairs, `ds_sub_a`, moved to the nearest periodic image with `precise::nearest`).
///
/// # Safety
/// AVX2; every index below `b.x.len()`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn offset(b: &Bodies, i: __m256i, j: __m256i) -> V3 {
    // SAFETY: the caller's bounds.
    let (xi, xj) = unsafe { (split_positions(b.x, i), split_positions(b.x, j)) };
    let (mut d_hi, mut d_lo) = ([F8::splat(0.0); 3], [F8::splat(0.0); 3]);
    for c in 0..3 {
        let (ih, il, jh, jl) = (xi[c], xi[4 + c], xj[c], xj[4 + c]);
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
        let zero = F8::splat(0.0);
        let mut any = zero.ne(zero);
        let mut shifted = d_hi;
        for c in 0..3 {
            let len = len[c];
            let shift = if len > 0.0 {
                let up = d_hi[c].gt(F8::splat(0.5 * len));
                let down = d_hi[c].lt(F8::splat(-0.5 * len));
                F8::select(up, F8::splat(-len), F8::select(down, F8::splat(len), zero))
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
            d_hi[c] = F8::select(any, shifted[c], d_hi[c]);
        }
    }
    V3 {
        x: d_hi[0],
        y: d_hi[1],
        z: d_hi[2],
    }
}

/// Eight pairs (`pairs`, with their slots): the lanes' law, stored for the lanes it covers;
/// the scalar `sphere_pair` for the others. Returns the number that touch.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn group(
    w: &World,
    b: &Bodies,
    shared: Option<&Shared>,
    pairs: &[[u32; 2]; 8],
    hist: &mut [Vec3; 8],
    coverage: &mut [f32; 8],
    force: &mut [ContactForce; 8],
    touching: &mut [bool; 8],
) -> usize {
    // The pairs' bodies, i0 j0 i1 j1 ..., split into i0..i7 and j0..j7.
    // SAFETY: AVX2 (this function's).
    let (i, j) = unsafe { split_pairs(pairs) };
    // Every index in bounds (unsigned) before anything is read through them.
    let top = _mm256_set1_epi32(b.x.len() as i32 - 1);
    let highest = _mm256_max_epu32(_mm256_max_epu32(i, j), top);
    assert!(_mm256_movemask_epi8(_mm256_cmpeq_epi32(highest, top)) == -1);

    // SAFETY (all gathers below): indices bounded above; the arrays cover every body
    // (checked by `sphere_chunk`).
    let d = unsafe { offset(b, i, j) };
    // `ri`, `ri + rj` and its square: the chunk's where shared.
    let (ri, sum, reach2) = match shared {
        Some(s) => (s.radius, s.sum, s.reach2),
        None => {
            let (ri, rj) = unsafe { (gather(b.radius.as_ptr(), i), gather(b.radius.as_ptr(), j)) };
            (ri, ri + rj, (ri + rj) * (ri + rj))
        }
    };
    let dist2 = d.length_squared();
    let touch = dist2.lt(reach2);
    // SAFETY: AVX2 (this function's).
    let was = unsafe { was_touching(touching) };
    let (touch_bits, was_bits) = (touch.bits(), was.bits());
    if touch_bits == 0 {
        // All apart: only releases, if any (rare), each as the scalar path does it.
        for l in 0..8 {
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
    let zero = F8::splat(0.0);
    let dist = dist2.sqrt();
    let n = V3::select(dist.gt(zero), d / dist, V3::splat(Vec3::Z));
    let depth = sum - dist;
    let pair = match shared {
        Some(s) => s.pair,
        None => unsafe {
            let (stiffness, damping_factor, friction) = params(b, i, j);
            let (mi, mj) = (gather(b.mass.as_ptr(), i), gather(b.mass.as_ptr(), j));
            Pair8::of(
                stiffness,
                damping_factor,
                friction,
                mi * mj / (mi + mj),
                b.dt,
            )
        },
    };
    let point = n * (ri - F8::splat(0.5) * depth);

    // `point_contact_force_in::<true>` with share 1, side a body i at the origin, side b
    // body j at `d`.
    let (vi, wi, vj, wj) = unsafe {
        (
            load_vec3_at(b.velocity, i),
            load_vec3_at(b.omega, i),
            load_vec3_at(b.velocity, j),
            load_vec3_at(b.omega, j),
        )
    };
    let vrel = (vj + wj.cross(point - d)) - (vi + wi.cross(point));
    let contact = Contact8 {
        n,
        depth,
        vrel,
        pair,
    };
    // SAFETY: AVX2 (this function's).
    let out = unsafe { law(&contact, touch, touch.and_not(touch), b.dt, hist, coverage) };
    let torque_a = out.f.cross(point);
    let torque_b = (point - d).cross(out.f);
    // SAFETY: AVX2 (this function's).
    unsafe {
        store(
            &out,
            touch,
            was,
            (torque_a, torque_b),
            hist,
            coverage,
            force,
            touching,
        )
    };
    let scalar = out.scalar;
    let scalar_bits = scalar.bits();
    if scalar_bits != 0 {
        for l in 0..8 {
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

/// The pair parameters' stiffness, damping factor and friction of bodies `i` and `j`'s
/// materials, in lanes.
///
/// # Safety
/// AVX2; indices below the bodies' count.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn params(b: &Bodies, i: __m256i, j: __m256i) -> (F8, F8, F8) {
    if b.materials == 1 {
        let p = &b.table[0];
        return (
            F8::splat(p.stiffness),
            F8::splat(p.damping_factor),
            F8::splat(p.friction),
        );
    }
    // SAFETY: the caller's bounds.
    let (ma, mb) = unsafe {
        (
            _mm256_i32gather_epi32::<4>(b.material.as_ptr() as *const i32, i),
            _mm256_i32gather_epi32::<4>(b.material.as_ptr() as *const i32, j),
        )
    };
    // SAFETY: AVX2.
    unsafe { params_of(b, ma, mb) }
}

/// The pair parameters' stiffness, damping factor and friction of materials `ma` (row)
/// and `mb` (column), in lanes. Panics unless every material is below the table's count.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn params_of(b: &Bodies, ma: __m256i, mb: __m256i) -> (F8, F8, F8) {
    if b.materials == 1 {
        let p = &b.table[0];
        return (
            F8::splat(p.stiffness),
            F8::splat(p.damping_factor),
            F8::splat(p.friction),
        );
    }
    let base = b.table.as_ptr() as *const f32;
    let nm = _mm256_set1_epi32(b.materials as i32);
    let top = _mm256_set1_epi32(b.materials as i32 - 1);
    let highest = _mm256_max_epu32(_mm256_max_epu32(ma, mb), top);
    assert!(_mm256_movemask_epi8(_mm256_cmpeq_epi32(highest, top)) == -1);
    let row = _mm256_add_epi32(_mm256_mullo_epi32(ma, nm), mb);
    let at = _mm256_mullo_epi32(row, _mm256_set1_epi32((size_of::<PairParams>() / 4) as i32));
    let field = |offset: usize| _mm256_add_epi32(at, _mm256_set1_epi32((offset / 4) as i32));
    // SAFETY: rows below `materials^2`, fields inside a row.
    unsafe {
        (
            gather(base, field(offset_of!(PairParams, stiffness))),
            gather(base, field(offset_of!(PairParams, damping_factor))),
            gather(base, field(offset_of!(PairParams, friction))),
        )
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::contact_list::ContactSprings;
    use crate::geom::ShapeKind;
    use crate::{BodyInit, ContactLaw, Material, Periodic, WorldDesc};
    use glam::{DVec3, Quat};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A dense random cloud of spheres of `sizes` sizes (one to four) and one or three plain
    /// materials,
    /// overlapping at random (some pairs exactly on top of each other), with velocities
    /// and spins at random, some fast.
    pub(in crate::step) fn cloud(
        rng: &mut ChaCha8Rng,
        materials: usize,
        sizes: u32,
        periodic: bool,
        dt: Option<f32>,
    ) -> World {
        let side = 0.1f32;
        let radii = [0.004f64, 0.006, 0.008, 0.01];
        let shapes = radii
            .map(|radius| ShapeKind::Sphere { radius }.prepare().unwrap())
            .to_vec();
        let materials = [
            (2.0e4, 0.3, 0.2, 1000.0),
            (5.0e4, 0.5, 0.6, 2500.0),
            (1.0e5, 0.9, 0.9, 7800.0),
        ][..materials]
            .iter()
            .map(|&(k, e, mu, rho)| {
                Material::new("m", rho, ContactLaw::Linear { stiffness: k }, e, mu)
            })
            .collect::<Vec<_>>();
        let count = 700;
        let mut bodies: Vec<BodyInit> = Vec::with_capacity(count);
        for b in 0..count {
            let fast = rng.random_bool(0.2);
            let speed = if fast { 5.0 } else { 0.5 };
            let mut position = DVec3::new(
                rng.random_range(0.0..side as f64),
                rng.random_range(0.0..side as f64),
                rng.random_range(0.0..side as f64),
            );
            let shape = rng.random_range(0..sizes);
            if b % 50 == 1 {
                // Exactly on the last body: a pair at zero distance.
                position = bodies[b - 1].position;
            }
            if b % 50 == 2 {
                // Exactly the sum of the radii from the last body along x: the offset rounds
                // to it, so the pair is on the edge of touching (apart, as `<` decides).
                let sum = radii[shape as usize] as f32 + radii[bodies[b - 1].shape as usize] as f32;
                position = bodies[b - 1].position + DVec3::X * sum as f64;
            }
            bodies.push(BodyInit {
                shape,
                material: rng.random_range(0..materials.len() as u32),
                position,
                orientation: Quat::IDENTITY,
                velocity: Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ) * speed,
                angular_velocity: Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ) * 20.0
                    * speed,
            });
        }
        World::new(WorldDesc {
            shapes,
            materials,
            walls: vec![],
            bodies,
            gravity: Vec3::ZERO,
            dt,
            skin: None,
            periodic: periodic.then_some(Periodic {
                min: Vec3::ZERO,
                max: Vec3::splat(side),
                axes: [true, true, false],
            }),
        })
    }

    /// Springs as a step may find them: touching or not, histories zero, small or past
    /// the Coulomb cap, coverages of first steps (0), of released contacts (-1) and of
    /// contacts under way; forces only where touching.
    pub(in crate::step) fn springs(rng: &mut ChaCha8Rng, n: usize) -> ContactSprings {
        let mut s = ContactSprings::default();
        for _ in 0..n {
            let touching = rng.random_bool(0.5);
            let scale = [0.0, 1e-7, 1e-5, 1e-3][rng.random_range(0..4)];
            s.history.push(
                Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ) * scale,
            );
            s.twist.push(match rng.random_range(0..4) {
                0 => 0.0,
                1 => -1.0,
                2 => rng.random_range(0.0..1e-6),
                _ => rng.random_range(0.0..1e-2),
            });
            let mut f = ContactForce::default();
            if touching {
                f.force_b = Vec3::splat(rng.random_range(-1.0..1.0));
                f.normal_force = 1.0;
            }
            s.forces.push(f);
            s.touching.push(touching);
        }
        s
    }

    /// Every bit of contact `k`'s slots.
    pub(in crate::step) fn slot_bits(s: &ContactSprings, k: usize) -> Vec<u32> {
        let mut bits: Vec<u32> = s.history[k].to_array().map(f32::to_bits).to_vec();
        bits.push(s.twist[k].to_bits());
        bits.extend(bytemuck::cast::<ContactForce, [u32; 12]>(s.forces[k]));
        bits.push(s.touching[k] as u32);
        bits
    }

    #[test]
    fn the_lanes_give_the_scalar_bits() {
        if !crate::step::avx2() {
            eprintln!("no AVX2 here: nothing to compare");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        let (mut pairs, mut touching, mut released, mut scalar_lanes) = (0, 0, 0, 0);
        let mut uniforms = 0;
        for case in 0..24 {
            let materials = if case % 3 == 0 { 1 } else { 3 };
            let periodic = case % 4 == 1;
            // The automatic step, longer ones, and one too long for the in-step law.
            let dt = [None, Some(2e-4), Some(2e-5), Some(3e-3)][case % 4];
            // One size and one material: the lanes' `Uniform` path.
            let one = case % 3 == 0 && case % 8 != 0;
            let sizes = if one { 1 } else { 4 };
            let mut w = cloud(&mut rng, materials, sizes, periodic, dt);
            assert!(w.materials.all_plain());
            let uniform = Uniform::of(&w);
            assert_eq!(uniform.is_some(), one, "case {case}");
            uniforms += uniform.is_some() as usize;
            w.rebuild_contacts();
            w.split_positions();
            let np = w.contacts.pairs.len();
            let before = springs(&mut rng, np);
            let (mut a, mut b) = (before.clone(), before.clone());
            let x = w.position_pairs.as_slice();
            let pairs_k = &w.contacts.pairs;
            let ta = super::super::contacts::sphere_chunk::<true>(
                &w,
                x,
                pairs_k,
                &mut a.history,
                &mut a.twist,
                &mut a.forces,
                &mut a.touching,
            );
            // SAFETY: the CPU has AVX2 (checked above).
            let tb = unsafe {
                sphere_chunk8(
                    &w,
                    x,
                    uniform,
                    pairs_k,
                    &mut b.history,
                    &mut b.twist,
                    &mut b.forces,
                    &mut b.touching,
                )
            };
            assert_eq!(ta, tb, "case {case}: touching count");
            for (k, pair) in pairs_k.iter().enumerate() {
                assert_eq!(
                    slot_bits(&a, k),
                    slot_bits(&b, k),
                    "case {case}, pair {k} {:?}: scalar {:?}, lanes {:?}",
                    pair,
                    (a.history[k], a.twist[k], a.forces[k], a.touching[k]),
                    (b.history[k], b.twist[k], b.forces[k], b.touching[k]),
                );
                touching += a.touching[k] as usize;
                released += (before.touching[k] && !a.touching[k]) as usize;
                // First steps and contacts that end go to the scalar path.
                scalar_lanes +=
                    (a.touching[k] && (before.twist[k] == 0.0 || a.twist[k] == -1.0)) as usize;
            }
            pairs += np;
        }
        eprintln!("{pairs} {touching} {released} {scalar_lanes}");
        // The cases cover what they should.
        assert!(pairs > 50_000, "{pairs} pairs");
        assert_eq!(uniforms, 7);
        assert!(
            touching > pairs / 5 && touching < pairs * 4 / 5,
            "{touching} of {pairs}"
        );
        assert!(released > pairs / 10, "{released} released");
        assert!(scalar_lanes > pairs / 20, "{scalar_lanes} scalar lanes");
    }
}

//! The sphere-wall pairs of the **contacts** stage eight at a time, one pair per lane of an
//! AVX2 register, in a world of spheres on the plain law ([`crate::law::is_plain`]): the
//! wall's plane as seen from the sphere (`precise::plane_offset_a`), the sphere against it
//! and [`crate::law::point_contact_force_in`]`::<true>` as [`super::contacts`]'s
//! `sphere_wall` computes them, with the same bits (the reasons: see
//! [`super::sphere_lanes`]; the law and the stores are [`super::law_lanes`]').
//!
//! Lanes handed back to the scalar `wall_pair`: a contact's first and last steps, a step
//! too long for the contact, an overlap that is NaN (a contact for the scalar test), the
//! releases of an all-apart group, and the chunk's last `len % 8` pairs.

use std::arch::x86_64::*;
use std::mem::offset_of;

use glam::Vec3;

use super::lanes::{F8, M8, V3, gather, load_vec3_at};
use super::law_lanes::{Contact8, Pair8, law, split_pairs, store, was_touching};
use super::plain_walls::wall_pair;
use super::sphere_lanes::{Bodies, Uniform, params_of, split_positions};
use crate::contract::ContactForce;
use crate::precise::Ds3A;
use crate::world::{Wall, World};
use clatter_geom::narrow::Plane;

/// The wall-pair chunk's pairs (`[sphere, wall]`) in a world of spheres only, every pair
/// on the plain law, eight pairs at a time: what the scalar `wall_pair` does for them.
/// Returns the number that touch.
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn wall_chunk(
    w: &World,
    x: &[Ds3A],
    uniform: Option<Uniform>,
    pairs: &[[u32; 2]],
    hist: &mut [Vec3],
    coverage: &mut [f32],
    force: &mut [ContactForce],
    touching: &mut [bool],
) -> usize {
    debug_assert!(w.spheres_only() && w.materials.all_plain());
    let n = pairs.len();
    let (hist, coverage, force, touching) = (
        &mut hist[..n],
        &mut coverage[..n],
        &mut force[..n],
        &mut touching[..n],
    );
    let bodies = Bodies::of(w, x);
    // The walls' materials index the table's rows (as the scalar `pair_params` does, which
    // would panic past them).
    assert!(
        w.walls
            .iter()
            .all(|wall| (wall.material as usize) < bodies.materials)
    );
    // A uniform world's spheres' radius and law constants, once for the chunk (its walls
    // have its one material, so every lane's pair parameters are the table's one row and
    // its effective mass the sphere's mass: the same values a group computes).
    let shared = uniform.map(|u| {
        let p = &bodies.table[0];
        // SAFETY: AVX2 (this function's).
        let pair = unsafe {
            Pair8::of(
                F8::splat(p.stiffness),
                F8::splat(p.damping_factor),
                F8::splat(p.friction),
                F8::splat(u.mass),
                bodies.dt,
            )
        };
        (F8::splat(u.radius), pair)
    });
    let mut count = 0;
    let groups = n / 8;
    for g in 0..groups {
        let r = 8 * g..8 * g + 8;
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
    for (k, &pair) in pairs.iter().enumerate().skip(8 * groups) {
        count += scalar(w, x, pair, k, hist, coverage, force, touching) as usize;
    }
    count
}

/// The scalar `wall_pair` (plain law, no pieces) on slot `k` of these slices.
#[allow(clippy::too_many_arguments)]
#[inline]
fn scalar(
    w: &World,
    x: &[Ds3A],
    pair: [u32; 2],
    k: usize,
    hist: &mut [Vec3],
    coverage: &mut [f32],
    force: &mut [ContactForce],
    touching: &mut [bool],
) -> bool {
    wall_pair::<false>(
        w,
        x,
        pair,
        0,
        &mut hist[k],
        &mut force[k],
        &mut touching[k],
        &mut coverage[k],
        true,
    )
}

/// `precise::ds_add1` in lanes: the double-single sum of `a` and `b`.
#[inline(always)]
fn ds_add(a: (F8, F8), b: (F8, F8)) -> (F8, F8) {
    let s = a.0 + b.0;
    let v = s - a.0;
    let e = ((a.0 - (s - v)) + (b.0 - v)) + (a.1 + b.1);
    let hi = s + e;
    (hi, e - (hi - s))
}

/// `precise::plane_offset_a` in lanes: the offset of the plane `n . y = d` as seen from the
/// split positions `hi`, `lo` (the products exact by Dekker's `two_prod`, summed in
/// double-single), and the rest below f32.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn plane_offset(n: V3, d: F8, hi: [F8; 3], lo: V3) -> (F8, F8) {
    let split = F8::splat(4097.0);
    let mut s = (d, F8::splat(0.0));
    for (a, b) in [n.x, n.y, n.z].into_iter().zip(hi) {
        // `two_prod(a, b)`.
        let p = a * b;
        let ca = split * a;
        let ah = ca - (ca - a);
        let al = a - ah;
        let cb = split * b;
        let bh = cb - (cb - b);
        let bl = b - bh;
        let e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
        s = ds_add(s, (-p, -e));
    }
    ds_add(s, (-n.dot(lo), F8::splat(0.0)))
}

/// Eight wall pairs (`pairs`, `[sphere, wall]`, with their slots): the lanes' law, stored
/// for the lanes it covers; the scalar `wall_pair` for the others. Returns the number that
/// touch.
///
/// # Safety
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
unsafe fn group(
    w: &World,
    b: &Bodies,
    shared: Option<&(F8, Pair8)>,
    pairs: &[[u32; 2]; 8],
    hist: &mut [Vec3; 8],
    coverage: &mut [f32; 8],
    force: &mut [ContactForce; 8],
    touching: &mut [bool; 8],
) -> usize {
    // The pairs' spheres and walls, i0 k0 i1 k1 ..., split into i0..i7 and k0..k7.
    // SAFETY: AVX2 (this function's).
    let (i, k) = unsafe { split_pairs(pairs) };
    // Every index in bounds (unsigned) before anything is read through them.
    let bounded = |v: __m256i, len: usize| {
        let top = _mm256_set1_epi32(len as i32 - 1);
        _mm256_movemask_epi8(_mm256_cmpeq_epi32(_mm256_max_epu32(v, top), top)) == -1
    };
    assert!(w.walls.len() < (1 << 24) && bounded(i, b.x.len()) && bounded(k, w.walls.len()));

    // SAFETY (all gathers below): indices bounded above; the bodies' arrays cover every
    // body (`Bodies::of`), the walls' every wall.
    let (n, d, wall_material) = unsafe { walls(&w.walls, k) };
    let xi = unsafe { split_positions(b.x, i) };
    let (x_hi, x_lo) = (
        [xi[0], xi[1], xi[2]],
        V3 {
            x: xi[4],
            y: xi[5],
            z: xi[6],
        },
    );
    let (offset, rest) = unsafe { plane_offset(n, d, x_hi, x_lo) };

    // `sphere_wall`: the sphere at the origin, the plane shifted by its position.
    let zero = F8::splat(0.0);
    let origin = V3::splat(Vec3::ZERO);
    let radius = match shared {
        Some(&(radius, _)) => radius,
        None => unsafe { gather(b.radius.as_ptr(), i) },
    };
    let centre_height = n.dot(origin) - offset;
    let depth = radius - centre_height;
    // `!(depth <= 0.0)`: NaN is a contact, as in the scalar test.
    let touch = M8(_mm256_cmp_ps::<_CMP_NLE_UQ>(depth.0, zero.0));
    let was = unsafe { was_touching(touching) };
    let (touch_bits, was_bits) = (touch.bits(), was.bits());
    if touch_bits == 0 {
        // All apart: only releases, if any (rare), each as the scalar path does it.
        for (l, &pair) in pairs.iter().enumerate() {
            if was_bits >> l & 1 != 0 {
                scalar(w, b.x, pair, l, hist, coverage, force, touching);
            }
        }
        return 0;
    }
    let point = origin - n * (radius - F8::splat(0.5) * depth);
    // The wall is side a (at rest, at the origin), the sphere side b.
    let (v, om) = unsafe { (load_vec3_at(b.velocity, i), load_vec3_at(b.omega, i)) };
    let pair = match shared {
        Some(&(_, pair)) => pair,
        None => unsafe {
            let mb = _mm256_i32gather_epi32::<4>(b.material.as_ptr() as *const i32, i);
            let (stiffness, damping_factor, friction) = params_of(b, wall_material, mb);
            let m_eff = gather(b.mass.as_ptr(), i);
            Pair8::of(stiffness, damping_factor, friction, m_eff, b.dt)
        },
    };
    let vrel = (v + om.cross(point - origin)) - (origin + origin.cross(point - origin));
    let contact = Contact8 {
        n,
        depth: depth + rest,
        vrel,
        pair,
    };
    // A NaN overlap goes to the scalar code.
    let nan = depth.ne(depth);
    // SAFETY: AVX2 (this function's).
    let out = unsafe { law(&contact, touch, nan, b.dt, hist, coverage) };
    let torques = (out.f.cross(point - origin), (point - origin).cross(out.f));
    // SAFETY: AVX2 (this function's).
    unsafe { store(&out, touch, was, torques, hist, coverage, force, touching) };
    let scalar_bits = out.scalar.bits();
    if scalar_bits != 0 {
        for (l, &pair) in pairs.iter().enumerate() {
            if scalar_bits >> l & 1 != 0 {
                scalar(w, b.x, pair, l, hist, coverage, force, touching);
            }
        }
    }
    touch_bits.count_ones() as usize
}

/// The walls `k`: their planes' normals and offsets, and their materials.
///
/// # Safety
/// AVX2; every `k[l] < walls.len()`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn walls(walls: &[Wall], k: __m256i) -> (V3, F8, __m256i) {
    let base = walls.as_ptr() as *const f32;
    let at = _mm256_mullo_epi32(k, _mm256_set1_epi32((size_of::<Wall>() / 4) as i32));
    let plane = offset_of!(Wall, plane);
    let field = |offset: usize| _mm256_add_epi32(at, _mm256_set1_epi32((offset / 4) as i32));
    let normal = plane + offset_of!(Plane, normal);
    // SAFETY: fields of walls below `walls.len()` (the caller's).
    unsafe {
        (
            V3 {
                x: gather(base, field(normal)),
                y: gather(base, field(normal + 4)),
                z: gather(base, field(normal + 8)),
            },
            gather(base, field(plane + offset_of!(Plane, offset))),
            _mm256_i32gather_epi32::<4>(base as *const i32, field(offset_of!(Wall, material))),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ShapeKind;
    use crate::{BodyInit, ContactLaw, Material, WorldDesc};
    use glam::{DVec3, Quat};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A cube of side `side` at `origin` walled on all six sides, plus one tilted wall
    /// across a corner, with materials picked at random.
    fn walls(rng: &mut ChaCha8Rng, origin: DVec3, side: f64, materials: u32) -> Vec<Wall> {
        let mut planes: Vec<(DVec3, f64)> = Vec::new();
        for axis in 0..3 {
            let mut n = DVec3::ZERO;
            n[axis] = 1.0;
            planes.push((n, origin[axis]));
            planes.push((-n, -(origin[axis] + side)));
        }
        let tilted = DVec3::new(1.0, 2.0, 3.0).normalize();
        planes.push((tilted, tilted.dot(origin + DVec3::splat(0.2 * side))));
        planes
            .into_iter()
            .map(|(n, offset)| Wall {
                plane: Plane {
                    normal: n.as_vec3(),
                    offset: offset as f32,
                },
                material: rng.random_range(0..materials),
            })
            .collect()
    }

    /// Spheres of four sizes scattered in the walled cube (many against its walls), with
    /// velocities and spins at random, some fast; one or three plain materials.
    fn cloud(rng: &mut ChaCha8Rng, case: usize, sizes: u32) -> World {
        let side = 0.06f64;
        let origin = [
            DVec3::ZERO,
            DVec3::new(100.0, -3.0, 7.5),
            DVec3::splat(-1e4),
        ][case % 3];
        let nm = if case.is_multiple_of(2) { 1 } else { 3 };
        let dt = [None, Some(2e-4), Some(2e-5), Some(3e-3)][case % 4];
        let shapes = [0.004, 0.006, 0.008, 0.01]
            .map(|radius| ShapeKind::Sphere { radius }.prepare().unwrap())
            .to_vec();
        let materials = [
            (2.0e4, 0.3, 0.2, 1000.0),
            (5.0e4, 0.5, 0.6, 2500.0),
            (1.0e5, 0.9, 0.9, 7800.0),
        ][..nm]
            .iter()
            .map(|&(k, e, mu, rho)| {
                Material::new("m", rho, ContactLaw::Linear { stiffness: k }, e, mu)
            })
            .collect();
        let random3 = |rng: &mut ChaCha8Rng, s: f32| {
            Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ) * s
        };
        let bodies = (0..400)
            .map(|_| {
                let speed = if rng.random_bool(0.2) { 5.0 } else { 0.5 };
                BodyInit {
                    shape: rng.random_range(0..sizes),
                    material: rng.random_range(0..nm as u32),
                    position: origin
                        + DVec3::new(
                            rng.random_range(-0.005..side + 0.005),
                            rng.random_range(-0.005..side + 0.005),
                            rng.random_range(-0.005..side + 0.005),
                        ),
                    orientation: Quat::IDENTITY,
                    velocity: random3(rng, speed),
                    angular_velocity: random3(rng, 20.0 * speed),
                }
            })
            .collect();
        World::new(WorldDesc {
            shapes,
            materials,
            walls: walls(rng, origin, side, nm as u32),
            bodies,
            gravity: Vec3::ZERO,
            dt,
            skin: None,
            periodic: None,
        })
    }

    /// The wall slots as a step may find them: touching or not, springs zero, small or past
    /// the Coulomb cap, coverages of first steps (0), of released contacts (-1) and of
    /// contacts under way; forces only where touching.
    type Slots = (Vec<Vec3>, Vec<f32>, Vec<ContactForce>, Vec<bool>);
    fn slots(rng: &mut ChaCha8Rng, n: usize) -> Slots {
        let mut s: Slots = Default::default();
        for _ in 0..n {
            let touching = rng.random_bool(0.5);
            let scale = [0.0, 1e-7, 1e-5, 1e-3][rng.random_range(0..4)];
            let h = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            s.0.push(h * scale);
            s.1.push(match rng.random_range(0..4) {
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
            s.2.push(f);
            s.3.push(touching);
        }
        s
    }

    /// Every bit of wall slot `k`.
    fn bits(s: &Slots, k: usize) -> Vec<u32> {
        let mut b: Vec<u32> = s.0[k].to_array().map(f32::to_bits).to_vec();
        b.push(s.1[k].to_bits());
        b.extend(bytemuck::cast::<ContactForce, [u32; 12]>(s.2[k]));
        b.push(s.3[k] as u32);
        b
    }

    #[test]
    fn the_lanes_give_the_scalar_bits() {
        if !crate::step::avx2() {
            eprintln!("no AVX2 here: nothing to compare");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(25);
        let (mut pairs, mut touching, mut released, mut scalar_lanes) = (0, 0, 0, 0);
        let mut uniforms = 0;
        for case in 0..24 {
            // One size (and one material): the lanes' `Uniform` path.
            let one = case % 6 == 0;
            let mut w = cloud(&mut rng, case, if one { 1 } else { 4 });
            let uniform = Uniform::of(&w);
            assert_eq!(uniform.is_some(), one, "case {case}");
            uniforms += one as usize;
            assert!(w.materials.all_plain() && w.spheres_only());
            w.rebuild_contacts();
            // Some spheres moved off the walls after the list was built: pairs apart.
            let centre = w.state.position.iter().sum::<DVec3>() / w.len() as f64;
            for p in w.state.position.iter_mut() {
                if rng.random_bool(0.4) {
                    *p += (centre - *p).normalize() * 0.012;
                }
            }
            if case % 5 == 4 {
                // A position that is not a number: its overlaps are NaN, contacts for the
                // scalar test.
                let i = w.contacts.wall_pairs[0][0] as usize;
                w.state.position[i] = DVec3::NAN;
            }
            w.split_positions();
            let wp = w.contacts.wall_pairs.clone();
            let before = slots(&mut rng, wp.len());
            let (mut a, mut b) = (before.clone(), before.clone());
            let x = w.position_pairs.as_slice();
            let mut ta = 0;
            for (k, p) in wp.iter().enumerate() {
                ta += wall_pair::<false>(
                    &w,
                    x,
                    *p,
                    0,
                    &mut a.0[k],
                    &mut a.2[k],
                    &mut a.3[k],
                    &mut a.1[k],
                    true,
                ) as usize;
            }
            // SAFETY: the CPU has AVX2 (checked above).
            let tb =
                unsafe { wall_chunk(&w, x, uniform, &wp, &mut b.0, &mut b.1, &mut b.2, &mut b.3) };
            assert_eq!(ta, tb, "case {case}: touching count");
            for (k, pair) in wp.iter().enumerate() {
                assert_eq!(
                    bits(&a, k),
                    bits(&b, k),
                    "case {case}, wall pair {k} {pair:?}: scalar {:?}, lanes {:?}",
                    (a.0[k], a.1[k], a.2[k], a.3[k]),
                    (b.0[k], b.1[k], b.2[k], b.3[k]),
                );
                touching += a.3[k] as usize;
                released += (before.3[k] && !a.3[k]) as usize;
                scalar_lanes += (a.3[k] && (before.1[k] == 0.0 || a.1[k] == -1.0)) as usize;
            }
            pairs += wp.len();
        }
        eprintln!(
            "{pairs} wall pairs, {touching} touching, {released} released, {scalar_lanes} first or last steps"
        );
        assert!(pairs > 5_000, "{pairs} wall pairs");
        assert_eq!(uniforms, 4);
        assert!(
            touching > pairs / 5 && touching < pairs * 4 / 5,
            "{touching} of {pairs}"
        );
        assert!(released > pairs / 10, "{released} released");
        assert!(scalar_lanes > pairs / 20, "{scalar_lanes} scalar lanes");
    }
}

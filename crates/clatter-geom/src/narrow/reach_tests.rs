//! The edge-axis search's centre-offset bound ([`reach_bound`]) against the separation the
//! search computes ([`direction_pair`]) on random hulls, boxes, flat and off-centre shapes,
//! at random poses and scales: the bound must never be below it (the search leaves an axis
//! out when the bound is at or below its level, so an axis whose separation is above the
//! level would be lost).

use glam::{Mat3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::edges::{direction_pair, reach_bound, reach_depth};
use super::lanes::SoaPoints;
use crate::ConvexPolyhedron;

/// Hulls of random clouds (centred on their centroid, as bodies are, or shifted so the
/// origin is near the boundary or outside), boxes, flat slabs, at scales 1e-3 to 1e3.
fn shapes(r: &mut ChaCha8Rng) -> Vec<ConvexPolyhedron> {
    let mut out = Vec::new();
    for case in 0..240 {
        let scale = [1e-3f32, 1.0, 1e3][case % 3];
        let shape = match case % 6 {
            0 => {
                // Cubes: their inner radius is every half extent (the tight case).
                let h = Vec3::splat(r.random_range(0.2..1.0));
                (0..8)
                    .map(|k| {
                        let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                        Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
                    })
                    .collect::<Vec<_>>()
            }
            1 => (0..12)
                .map(|_| {
                    let z = r.random_range(-1e-4f32..1e-4);
                    Vec3::new(r.random_range(-1.0..1.0), r.random_range(-1.0..1.0), z)
                })
                .collect(),
            _ => (0..4 + case % 30)
                .map(|_| {
                    Vec3::new(
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                    )
                })
                .collect(),
        };
        let mean = shape.iter().copied().sum::<Vec3>() / shape.len() as f32;
        // Centred; or shifted by up to 1.5 (the origin near a face, or outside).
        let shift = if case % 5 == 4 {
            Vec3::X * r.random_range(0.0..1.5)
        } else {
            Vec3::ZERO
        };
        let pts: Vec<Vec3> = shape.iter().map(|&v| (v - mean + shift) * scale).collect();
        if let Ok(p) = crate::convex_hull(&pts) {
            out.push(p);
        }
    }
    out
}

#[test]
fn reach_bound_is_never_below_the_computed_separation() {
    let mut r = ChaCha8Rng::seed_from_u64(23);
    let shapes = shapes(&mut r);
    assert!(shapes.len() > 200);
    let (mut checked, mut left_out, mut tight) = (0usize, 0usize, 0usize);
    let mut bv = Vec::new();
    let mut b_soa = SoaPoints::default();
    for i in 0..shapes.len() {
        let a = &shapes[i];
        // B of the same scale, or A itself (two equal cubes face to face: tight).
        let b = &shapes[(i * 7 + 3) % shapes.len()];
        let b = if i % 2 == 1 && (a.radius / b.radius - 1.0).abs() < 100.0 {
            b
        } else {
            a
        };
        let radii = a.radius + b.radius;
        let deep = reach_depth(a, b, radii);
        for pose in 0..40 {
            let q = Quat::from_array([
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
                r.random_range(-1.0f32..1.0),
            ])
            .normalize();
            let q = if pose == 0 { Quat::IDENTITY } else { q };
            let rot = Mat3::from_quat(q);
            // Offsets inside the bounding spheres' reach, some along a coordinate axis
            // (face normals of a box: the bound's tightest case), some zero.
            let dir = match pose % 4 {
                0 => Vec3::X * if pose % 8 == 0 { 1.0 } else { -1.0 },
                1 => Vec3::ZERO,
                _ => Vec3::new(
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                )
                .normalize_or_zero(),
            };
            let t = dir * radii * r.random_range(0.0f32..1.0);
            bv.clear();
            bv.extend(b.vertices.iter().map(|&v| rot * v + t));
            b_soa.fill(&bv);
            let dirs_b: Vec<Vec3> = b.edge_dirs.iter().map(|&u| rot * u).collect();
            let mut axes: Vec<(Vec3, Vec3)> = Vec::new();
            for &ua in &a.edge_dirs {
                for &wb in &dirs_b {
                    axes.push((ua, wb));
                }
            }
            // Axes along the offset too (a cross product of two edges orthogonal to it).
            let side = t.any_orthogonal_vector();
            axes.push((side, t.cross(side)));
            for (ua, wb) in axes {
                let Some((s, signed)) = direction_pair(ua, wb, a.lanes(), &b_soa) else {
                    continue;
                };
                // The search bounds the axis as it comes, `ua x wb` of either sign.
                let axis = ua.cross(wb);
                let axis = axis / axis.length_squared().sqrt();
                assert!(axis == signed || axis == -signed);
                let bound = reach_bound(axis, t, deep);
                checked += 1;
                assert!(
                    s <= bound,
                    "shape {i} pose {pose}: separation {s} above the bound {bound} \
                     (axis {axis}, t {t}, deep {deep})"
                );
                if bound <= 0.0 {
                    left_out += 1;
                }
                if bound - s <= 1e-3 * radii {
                    tight += 1;
                }
            }
        }
    }
    // The bound does leave axes out, and meets the separation closely in some cases.
    assert!(checked > 100_000, "{checked}");
    assert!(left_out > checked / 10, "{left_out} of {checked}");
    assert!(tight > 100, "{tight}");
}

/// The unit cube's corners and its six outward face loops, for shapes built by hand.
fn hand_cube() -> (Vec<Vec3>, Vec<Vec<u32>>) {
    let v = (0..8)
        .map(|k: u32| {
            let s = |b: u32| if k & b != 0 { 0.5 } else { -0.5 };
            Vec3::new(s(1), s(2), s(4))
        })
        .collect();
    let loops = vec![
        vec![0, 4, 6, 2], // -x
        vec![1, 3, 7, 5], // +x
        vec![0, 1, 5, 4], // -y
        vec![2, 6, 7, 3], // +y
        vec![0, 2, 3, 1], // -z
        vec![4, 5, 7, 6], // +z
    ];
    (v, loops)
}

/// A shape built through `from_faces` gets an inner radius only when its faces close it and
/// each face's loop is planar: an open shape or a warped face (whose plane, through the
/// loop's outermost vertex, no longer bounds the hull from inside) gets none, so the search
/// leaves no axis out for it. The closed cube's bound is its half size less the allowance.
#[test]
fn inner_radius_only_for_closed_planar_shapes() {
    let (v, loops) = hand_cube();
    let cube = ConvexPolyhedron::from_faces(v.clone(), &loops);
    let inner = cube.inner_radius();
    assert!(inner > 0.49 && inner <= 0.5, "closed cube: {inner}");

    // Open: the +z face left out.
    let open = ConvexPolyhedron::from_faces(v.clone(), &loops[..5]);
    assert_eq!(
        open.inner_radius(),
        f32::NEG_INFINITY,
        "an open shape has no bound"
    );

    // Warped: one corner of the +z face pulled in by a tenth, so the face's plane passes
    // through its other corners and the hull's true surface there lies below it.
    let mut warped = v;
    warped[7].z -= 0.1;
    let warped = ConvexPolyhedron::from_faces(warped, &loops);
    assert_eq!(
        warped.inner_radius(),
        f32::NEG_INFINITY,
        "a warped face gives no bound"
    );
}

//! A polyhedron against a plane ([`super::collide_plane`]): the lanes' path (the vertices
//! below the plane from [`super::SoaPoints::below`], a patch of at most four written
//! straight into the manifold) against the scan of the vertices it replaced
//! ([`super::plane_patch_scan`], reached the old way), bit for bit, on random hulls, boxes
//! and hulls of more than 64 vertices, at random and axis-aligned poses, with planes through
//! a vertex exactly (ties between vertices included) and an ulp either side, and NaN poses.

use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Manifold, Plane, collide_plane, plane_patch_scan};
use crate::{ConvexPolyhedron, Pose, Shape};

/// The old `collide_plane_convex` for a polyhedron: the early out, then the scan.
fn reference(plane: &Plane, p: &ConvexPolyhedron, pose: &Pose) -> Option<Manifold> {
    let n = plane.normal;
    let centre_height = n.dot(pose.position) - plane.offset;
    if centre_height >= p.radius {
        return None;
    }
    let n_local = pose.rotation.conjugate() * n;
    plane_patch_scan(p, n, n_local, centre_height, pose)
}

/// A manifold's bits: count, normal, the used points.
fn bits(m: &Option<Manifold>) -> Option<(usize, [u32; 3], Vec<[u32; 4]>)> {
    m.as_ref().map(|m| {
        let pts = m.points().iter().map(|c| {
            let [x, y, z] = c.point.to_array().map(f32::to_bits);
            [x, y, z, c.depth.to_bits()]
        });
        (
            m.count,
            m.normal.to_array().map(f32::to_bits),
            pts.collect(),
        )
    })
}

/// Boxes (cubes, flat, off-centre), hulls of random clouds of 4 to 40 points, and hulls of
/// 150 points on a sphere (more than 64 vertices: the scan's path).
fn shapes(r: &mut ChaCha8Rng) -> Vec<ConvexPolyhedron> {
    let mut out = Vec::new();
    for case in 0..90 {
        let pts: Vec<Vec3> = match case % 5 {
            0 | 1 => {
                let h = if case % 5 == 0 {
                    Vec3::splat(r.random_range(0.001..1.0))
                } else {
                    Vec3::new(r.random_range(0.1..1.0), 0.3, r.random_range(1e-3..0.1))
                };
                let shift = if case % 10 == 1 {
                    Vec3::X * 0.05
                } else {
                    Vec3::ZERO
                };
                (0..8)
                    .map(|k| {
                        let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                        Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z) + shift
                    })
                    .collect()
            }
            2 => (0..150)
                .map(|_| {
                    let v = Vec3::new(
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                    );
                    v.normalize_or(Vec3::X)
                })
                .collect(),
            _ => (0..4 + case % 37)
                .map(|_| {
                    Vec3::new(
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                    )
                })
                .collect(),
        };
        if let Ok(p) = crate::convex_hull(&pts) {
            out.push(p);
        }
    }
    out
}

/// A wall normal for test case `case`: an axis (even cases; vertices then tie on the
/// plane) or a random direction.
fn plane_normal(r: &mut ChaCha8Rng, case: usize) -> Vec3 {
    const AXES: [Vec3; 6] = [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::NEG_X,
        Vec3::NEG_Y,
        Vec3::NEG_Z,
    ];
    if case.is_multiple_of(2) {
        AXES[r.random_range(0..6)]
    } else {
        Vec3::new(
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
        )
        .normalize_or(Vec3::Z)
    }
}

/// A body at the origin of rotation `rotation` and the offset of the plane of `normal`
/// through one of its vertices, exactly (`nudge` 0) or an ulp either side (1, 2).
fn through_vertex(
    r: &mut ChaCha8Rng,
    p: &ConvexPolyhedron,
    rotation: Quat,
    normal: Vec3,
    nudge: usize,
) -> (Vec3, f32) {
    let v = p.vertices[r.random_range(0..p.vertices.len())];
    let d = (rotation.conjugate() * normal).dot(v);
    let nudge = [0i32, 1, -1][nudge];
    let d = if nudge == 0 || d == 0.0 {
        d
    } else {
        f32::from_bits((d.to_bits() as i32 + nudge) as u32)
    };
    (Vec3::ZERO, d)
}

/// A random position and a plane offset within 1.5 radii of it along `normal`.
fn near_plane(r: &mut ChaCha8Rng, p: &ConvexPolyhedron, normal: Vec3) -> (Vec3, f32) {
    let x = Vec3::new(
        r.random_range(-2.0..2.0),
        r.random_range(-2.0..2.0),
        r.random_range(-2.0..2.0),
    );
    (x, normal.dot(x) + r.random_range(-1.5..1.5) * p.radius)
}

#[test]
fn plane_patch_from_lanes_is_the_scan_bitwise() {
    let mut r = ChaCha8Rng::seed_from_u64(32);
    let shapes = shapes(&mut r);
    assert!(shapes.iter().any(|p| p.vertices.len() > 64) && shapes.len() > 80);
    // Exact rotations: the identity and half turns (vertices tie on axis-aligned planes).
    let exact = [
        Quat::IDENTITY,
        Quat::from_xyzw(1.0, 0.0, 0.0, 0.0),
        Quat::from_xyzw(0.0, 1.0, 0.0, 0.0),
        Quat::from_xyzw(0.0, 0.0, 1.0, 0.0),
    ];
    let mut counts = [0usize; 6];
    let mut cases = 0usize;
    for (s, p) in shapes.iter().enumerate() {
        let shape = Shape::Polyhedron(std::sync::Arc::new(p.clone()));
        for case in 0..600 {
            let rotation = if case % 3 == 0 {
                exact[case % 4]
            } else {
                let q = Quat::from_xyzw(
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                );
                q.normalize()
            };
            let normal = plane_normal(&mut r, case);
            let (position, offset) = match case % 4 {
                // At the origin, the plane through a vertex exactly, or an ulp either side:
                // `centre_height` is then `-offset` and that vertex's height is `d - d`.
                0..=2 => through_vertex(&mut r, p, rotation, normal, case % 4),
                _ => near_plane(&mut r, p, normal),
            };
            let pose = if case == 599 && s % 7 == 0 {
                Pose::new(Vec3::NAN, rotation)
            } else {
                Pose::new(position, rotation)
            };
            let plane = Plane { normal, offset };
            let want = reference(&plane, p, &pose);
            let got = collide_plane(&plane, &shape, &pose);
            assert_eq!(bits(&got), bits(&want), "shape {s} case {case}");
            // The vertices below the plane, and those exactly on it (height 0: not below).
            let n_local = pose.rotation.conjugate() * normal;
            let ch = normal.dot(pose.position) - offset;
            let below = p.vertices.iter().filter(|&&v| n_local.dot(v) + ch < 0.0);
            counts[below.count().min(5)] += 1;
            cases += p.vertices.iter().any(|&v| n_local.dot(v) + ch == 0.0) as usize;
        }
    }
    // Every patch size seen (0 to 4 vertices below, and five or more: four kept of them),
    // and planes exactly through vertices in many cases.
    assert!(counts.iter().all(|&c| c > 100), "{counts:?}");
    assert!(cases > 5_000, "{cases} planes through a vertex");
}

/// [`super::collide_plane_polyhedron`] against [`collide_plane`]: the same manifold bit for
/// bit where something touches (written over a manifold of NaNs), and where nothing does a lowest height no vertex is below: none of the heights
/// as the test computes them (f32), nor the exact ones (f64) by more than `1e-6` of the
/// radius and the centre's height; minus infinity for NaN and infinite poses. The cases of
/// the test above, and huge and signed-zero positions and offsets.
#[test]
fn plane_polyhedron_in_place_is_collide_plane_and_bounds_the_gap() {
    let mut r = ChaCha8Rng::seed_from_u64(37);
    let shapes = shapes(&mut r);
    let (mut touching, mut at_sphere, mut at_vertices, mut unknown) = (0, 0, 0, 0);
    for (s, p) in shapes.iter().enumerate() {
        let shape = Shape::Polyhedron(std::sync::Arc::new(p.clone()));
        for case in 0..600 {
            let rotation = if case % 5 == 0 {
                Quat::IDENTITY
            } else {
                Quat::from_xyzw(
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                )
                .normalize()
            };
            let normal = plane_normal(&mut r, case);
            let (position, offset) = match case % 8 {
                0..=2 => through_vertex(&mut r, p, rotation, normal, case % 4),
                3 => (Vec3::ZERO, -0.0),
                4 => (Vec3::splat(-0.0), 0.0),
                // (The body is at the origin on the simulator's path: huge offsets only.)
                5 => {
                    let big = [
                        1e30f32,
                        -1e30,
                        3e38,
                        -3e38,
                        f32::INFINITY,
                        f32::NEG_INFINITY,
                    ];
                    (Vec3::ZERO, big[case / 8 % 6])
                }
                6 if case % 48 == 6 => (Vec3::NAN, 0.0),
                6 => (Vec3::ZERO, f32::NAN),
                _ => near_plane(&mut r, p, normal),
            };
            let pose = Pose::new(position, rotation);
            let plane = Plane { normal, offset };
            let want = collide_plane(&plane, &shape, &pose);
            let nan = super::ContactPoint {
                point: Vec3::NAN,
                depth: f32::NAN,
            };
            let mut out = Manifold {
                normal: Vec3::NAN,
                points: [nan; 4],
                count: 7,
            };
            let got = super::collide_plane_polyhedron(&plane, p, &pose, &mut out);
            match (got, &want) {
                (Ok(()), Some(_)) => {
                    touching += 1;
                    assert_eq!(bits(&Some(out)), bits(&want), "shape {s} case {case}");
                }
                (Err(lowest), None) => {
                    let n_local = pose.rotation.conjugate() * normal;
                    let ch = normal.dot(pose.position) - offset;
                    if lowest == f32::NEG_INFINITY {
                        unknown += 1;
                        continue;
                    }
                    assert!(!lowest.is_nan(), "shape {s} case {case}");
                    if ch >= p.radius {
                        at_sphere += 1;
                    } else {
                        at_vertices += 1;
                    }
                    let slack = 1e-6 * (p.radius + ch.abs());
                    // The test's own heights.
                    for &v in &p.vertices {
                        let h = n_local.dot(v) + ch;
                        assert!(
                            ch >= p.radius || lowest <= h,
                            "shape {s} case {case}: {lowest} above a vertex at {h}"
                        );
                    }
                    // The exact heights.
                    let q = pose.rotation.as_dquat().normalize();
                    let c = normal.as_dvec3().dot(pose.position.as_dvec3()) - offset as f64;
                    for &v in &p.vertices {
                        let h = c + normal.as_dvec3().dot(q * v.as_dvec3());
                        assert!(
                            (lowest as f64) <= h + slack as f64,
                            "shape {s} case {case}: {lowest} above an exact vertex at {h}"
                        );
                    }
                }
                (got, want) => panic!("shape {s} case {case}: {got:?} against {want:?}"),
            }
        }
    }
    eprintln!(
        "touching {touching}, apart at the sphere {at_sphere}, at the vertices {at_vertices}, unknown {unknown}"
    );
    let counts = (touching, at_sphere, at_vertices, unknown);
    assert!(
        touching > 10_000 && at_sphere > 1_000 && at_vertices > 1_000 && unknown > 500,
        "{counts:?}"
    );
}

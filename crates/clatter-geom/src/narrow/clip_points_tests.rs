//! The clip's point collection and its plane clip against their earlier forms, kept as
//! references (clip36; beside `clip_tests.rs`, which passed 900 lines).

use super::tests::bits;
use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `contact_points` as it was before its count was kept in a register (the manifold's
/// count read and written at each point, a fifth point found by `m.count == 4`), kept as
/// the reference.
#[allow(clippy::too_many_arguments)]
fn contact_points_reference<P: ClipPoint>(
    poly: &[P],
    offset: f32,
    depth_of: impl Fn(P) -> f32,
    n: Vec3,
    pts: &mut Vec<(P, f32)>,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
    m: &mut Manifold,
) -> bool {
    *m = Manifold {
        normal: n,
        ..Default::default()
    };
    let mut more = false;
    let np = P::from_vec3(n);
    for &p in poly {
        let depth = depth_of(p);
        if depth > 0.0 {
            if m.count == 4 {
                more = true;
                break;
            }
            m.points[m.count] = ContactPoint {
                point: (p + np * (0.5 * depth)).to_vec3(),
                depth,
            };
            m.count += 1;
        }
    }
    if more {
        *m = reduce_all(poly, offset, n, pts);
        return true;
    }
    if m.count > 0 {
        return true;
    }
    let Some(deepest) = (0..inc.vertices.len())
        .map(inc_v)
        .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))
    else {
        return false;
    };
    let depth = offset - n.dot(deepest);
    if depth <= 0.0 {
        return false;
    }
    *m = Manifold::single(n, deepest + n * (0.5 * depth), depth);
    true
}

/// `contact_points` against the reference loop, bitwise (the whole manifold, unused
/// points included, and the answer), for `Vec3` and `Vec3A` points: polygons of 0 to 12
/// corners, each below, on or above the face plane (none to all kept: the usual one to
/// four, a fifth sending the polygon through `reduce_all`, none falling back to the
/// deepest vertex, above or below the plane), with zeros of either sign, tiny and huge
/// coordinates, and now and then an infinite or NaN one; the manifold written over a
/// stale one each time (as the clip's buffers are reused).
#[test]
fn contact_points_are_the_reference() {
    let mut r = ChaCha8Rng::seed_from_u64(36);
    let v: Vec<Vec3> = (0..8)
        .map(|k| {
            let s = |b: u32| if k & b != 0 { 0.01 } else { -0.01 };
            Vec3::new(s(1), s(2), s(4))
        })
        .collect();
    let cube = crate::convex_hull(&v).expect("cube hull");
    let odd = [
        0.0,
        -0.0,
        1e-30,
        -1e-30,
        1e30,
        -1e30,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];
    let (mut pa, mut pb) = (Vec::new(), Vec::new());
    let (mut ga, mut gb) = (Vec::new(), Vec::new());
    let mut stale = Manifold::default();
    let mut seen = [0usize; 6];
    for case in 0..60_000 {
        let len = r.random_range(0..13usize);
        let n = Vec3::new(r.random_range(-0.3..0.3), r.random_range(-0.3..0.3), 1.0).normalize();
        let scale = [1e-20, 0.01, 1.0, 1e15][case % 4];
        let offset = if case % 5 == 0 {
            0.0
        } else {
            r.random_range(-1.0..1.0) * scale
        };
        let poly: Vec<Vec3> = (0..len)
            .map(|_| {
                let mut c = [0; 3].map(|_| {
                    if case % 3 == 0 {
                        r.random_range(-2..=2) as f32 * 0.5 * scale
                    } else {
                        r.random_range(-1.0f32..1.0) * scale
                    }
                });
                if case % 11 == 0 && r.random_range(0..3) == 0 {
                    c[r.random_range(0..3)] = odd[r.random_range(0..odd.len())];
                }
                Vec3::from_array(c)
            })
            .collect();
        // The incident body placed so that its deepest vertex is below the plane or not.
        let lift = r.random_range(-0.03..0.03f32);
        let inc_v = |i: usize| cube.vertices[i] + n * (offset + lift);
        let depth_of = |p: Vec3| offset - n.dot(p);
        let depth_of_a = |p: Vec3A| offset - Vec3A::from(n).dot(p);
        let poly_a: Vec<Vec3A> = poly.iter().map(|&p| p.into()).collect();
        let mut want = Manifold::default();
        let w =
            contact_points_reference(&poly, offset, depth_of, n, &mut pa, &cube, inc_v, &mut want);
        for wide in [false, true] {
            let mut got = stale;
            let g = if wide {
                contact_points(
                    &poly_a, offset, depth_of_a, n, &mut ga, &cube, inc_v, &mut got,
                )
            } else {
                contact_points(&poly, offset, depth_of, n, &mut gb, &cube, inc_v, &mut got)
            };
            let mut want_here = Manifold::default();
            let w_here = if wide {
                let mut m = stale;
                let w = contact_points_reference(
                    &poly_a, offset, depth_of_a, n, &mut pb, &cube, inc_v, &mut m,
                );
                want_here = m;
                w
            } else {
                want_here.clone_from(&want);
                w
            };
            assert_eq!(g, w_here, "case {case} wide {wide}");
            let all = |m: &Manifold| {
                let p: Vec<(Vec3, f32)> = m.points.iter().map(|p| (p.point, p.depth)).collect();
                (m.count, m.normal.to_array().map(f32::to_bits), bits(&p))
            };
            assert_eq!(all(&got), all(&want_here), "case {case} wide {wide}");
        }
        let kept = poly.iter().filter(|&&p| depth_of(p) > 0.0).count();
        seen[kept.min(5)] += 1;
        stale = want;
    }
    // Every count of kept points met, from none (the deepest vertex) to more than four.
    assert!(seen.iter().all(|&s| s > 1_000), "{seen:?}");
}

/// `clip_by_plane` against the plane clip with the crossing test written whole, `(dp < 0
/// && dq > 0) || (dp > 0 && dq < 0)` (as it was before the test was split by the keep
/// test), kept as the reference, bitwise: polygons of 0 to 12 corners whose distances are
/// drawn from negatives, zeros of either sign, positives, tiny and huge values and NaN
/// (the distance is the corner's `x`), with and without the scan, into `Vec3` and `Vec3A`
/// buffers.
#[test]
fn plane_clip_is_the_whole_crossing_test() {
    fn reference(src: &[Vec3]) -> Vec<Vec3> {
        let mut out = Vec::new();
        for i in 0..src.len() {
            let (p, q) = (src[i], src[(i + 1) % src.len()]);
            let (dp, dq) = (p.x, q.x);
            if dp <= 0.0 {
                out.push(p);
            }
            if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                out.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
        out
    }
    let mut r = ChaCha8Rng::seed_from_u64(37);
    let values = [
        -1.0,
        -0.25,
        -0.0,
        0.0,
        0.5,
        2.0,
        1e-38,
        -1e-38,
        1e30,
        -1e30,
        f32::NAN,
    ];
    let (mut crossed, mut kept_whole) = (0, 0);
    for case in 0..40_000 {
        let len = r.random_range(0..13usize);
        let src: Vec<Vec3> = (0..len)
            .map(|_| {
                let d = if case % 2 == 0 {
                    values[r.random_range(0..values.len())]
                } else {
                    r.random_range(-1.0f32..1.0)
                };
                Vec3::new(
                    d,
                    r.random_range(-1.0f32..1.0),
                    r.random_range(-1.0f32..1.0),
                )
            })
            .collect();
        let want = reference(&src);
        let scan = case % 3 == 0;
        let mut dst = vec![Vec3::ZERO; 2 * len + 1];
        let got = match clip_by_plane(&src, dst.as_mut_slice(), |p: Vec3| p.x, scan) {
            Some(w) => dst[..w].to_vec(),
            None => {
                kept_whole += 1;
                src.clone()
            }
        };
        let b = |v: &[Vec3]| -> Vec<[u32; 3]> {
            v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
        };
        assert_eq!(b(&got), b(&want), "case {case}: {src:?}");
        let src_a: Vec<Vec3A> = src.iter().map(|&p| p.into()).collect();
        let mut fixed = [Vec3A::ZERO; SMALL];
        let got_a = match clip_by_plane(&src_a, &mut Masked(&mut fixed), |p: Vec3A| p.x, scan) {
            Some(w) => fixed[..w].iter().map(|&p| p.into()).collect(),
            None => src.clone(),
        };
        assert_eq!(b(&got_a), b(&want), "case {case} (fixed): {src:?}");
        crossed += (want.len() > src.iter().filter(|p| p.x <= 0.0).count()) as usize;
    }
    assert!(
        crossed > 10_000 && kept_whole > 1_000,
        "{crossed} {kept_whole}"
    );
}

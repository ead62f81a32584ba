//! Tests of [`super`] (the edge-axis search), beside it to keep `edges.rs` short.

use super::{Pairs, edges_of_direction, supporting_edges};
use crate::ConvexPolyhedron;
use crate::hull::convex_hull;
use glam::{Mat3, Quat, Vec3};

/// The search's supporting edges before the shapes kept their direction groups (each
/// direction's edges visited by `edges_of_direction`, A's ends looked up and summed per
/// call): the oracle of `supporting_edges`.
fn supporting_edges_edge_by_edge(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    bv: &[Vec3],
    ia: usize,
    ib: usize,
    axis: Vec3,
) -> (usize, usize) {
    let mut ea_best = (f32::NEG_INFINITY, 0usize);
    edges_of_direction(a, ia, |e, [v0, v1]| {
        let h = axis.dot(a.vertices[v0 as usize] + a.vertices[v1 as usize]);
        if h > ea_best.0 {
            ea_best = (h, e);
        }
    });
    let mut eb_best = (f32::INFINITY, 0usize);
    edges_of_direction(b, ib, |e, [v0, v1]| {
        let h = axis.dot(bv[v0 as usize] + bv[v1 as usize]);
        if h < eb_best.0 {
            eb_best = (h, e);
        }
    });
    (ea_best.1, eb_best.1)
}

/// `supporting_edges` against the edge-by-edge search it replaced, the same edges:
/// hulls of random point clouds and boxes (four parallel edges per direction, ties along
/// the coordinate axes: the first of equals must win), B at random poses (and at the
/// identity, where a box's sums tie exactly), along random axes, the coordinate axes,
/// each direction pair's own axis and a NaN, for every direction pair and one past
/// each side's last direction.
#[test]
fn supporting_edges_are_those_of_the_edge_by_edge_search() {
    use rand::{Rng, SeedableRng};
    let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(34);
    let mut next = move || r.random::<f32>() - 0.5;
    let mut shapes = Vec::new();
    for case in 0..120 {
        let pts: Vec<Vec3> = (0..4 + case % 37)
            .map(|_| Vec3::new(next(), next(), next()))
            .collect();
        if let Ok(p) = convex_hull(&pts) {
            shapes.push(p);
        }
    }
    for h in [Vec3::ONE, Vec3::new(1.0, 2.0, 0.5)] {
        let corners: Vec<Vec3> = (0..8)
            .map(|k| {
                h * Vec3::new(
                    [-1.0, 1.0][k & 1],
                    [-1.0, 1.0][k >> 1 & 1],
                    [-1.0, 1.0][k >> 2],
                )
            })
            .collect();
        let cube = convex_hull(&corners).expect("a box");
        shapes.extend([cube.clone(), cube.clone(), cube]);
    }
    let mut checked = 0;
    let n = shapes.len();
    for (i, a) in shapes.iter().enumerate() {
        let b = &shapes[(i * 7 + 3) % n];
        for pose in 0..3 {
            let (rot, t) = if pose == 0 {
                (Mat3::IDENTITY, Vec3::new(0.0, 0.0, 1.5))
            } else {
                let q = Quat::from_xyzw(next(), next(), next(), next()).normalize();
                (Mat3::from_quat(q), Vec3::new(next(), next(), next()))
            };
            let bv: Vec<Vec3> = b.vertices.iter().map(|&v| rot * v + t).collect();
            for ia in 0..=a.edge_dirs.len() {
                for ib in 0..=b.edge_dirs.len() {
                    let mut axes = vec![Vec3::X, Vec3::Y, -Vec3::Z, Vec3::NAN];
                    axes.push(Vec3::new(next(), next(), next()).normalize());
                    if let (Some(&ua), Some(&ub)) = (a.edge_dirs.get(ia), b.edge_dirs.get(ib)) {
                        axes.push((ua.cross(rot * ub)).normalize_or_zero());
                    }
                    for axis in axes {
                        assert_eq!(
                            supporting_edges(a, b, &bv, ia, ib, axis),
                            supporting_edges_edge_by_edge(a, b, &bv, ia, ib, axis),
                            "shapes {i}, pose {pose}, directions {ia} {ib}, axis {axis}"
                        );
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 20_000, "{checked}");
}

/// `edges_of_direction` against filtering every edge by its direction, on hulls of
/// random point clouds (4 to 60 points: edge counts of all remainders mod 4) and on
/// boxes (many edges per direction), for every direction and one past the last.
#[test]
fn edges_of_a_direction_are_those_the_filter_finds() {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let mut shapes = Vec::new();
    for case in 0..300 {
        let count = 4 + case % 57;
        let pts: Vec<Vec3> = (0..count)
            .map(|_| Vec3::new(next(), next(), next()))
            .collect();
        if let Ok(p) = convex_hull(&pts) {
            shapes.push(p);
        }
    }
    let corners: Vec<Vec3> = (0..8)
        .map(|k| {
            Vec3::new(
                [-1.0, 1.0][k & 1],
                [-2.0, 2.0][k >> 1 & 1],
                [-0.5, 0.5][k >> 2],
            )
        })
        .collect();
    shapes.push(convex_hull(&corners).expect("a box"));
    assert!(shapes.len() > 250);
    for (i, p) in shapes.iter().enumerate() {
        for d in 0..=p.edge_dirs.len() {
            let want: Vec<_> = (0..p.edges.len())
                .filter(|&e| p.edge_dir_of[e] as usize == d)
                .map(|e| (e, p.edges[e]))
                .collect();
            let mut got = Vec::new();
            edges_of_direction(p, d, |e, ends| got.push((e, ends)));
            assert_eq!(
                got,
                want,
                "shape {i} ({} edges), direction {d}",
                p.edges.len()
            );
        }
    }
}

/// The direction pairs `Pairs` visits against testing each pair's bit in
/// turn (`skip`'s bit `k` for pair `k = ia * ndb + ib`, none from the 129th pair on), on
/// random sets of left-out pairs and row lengths 0 to 200, and pair counts at the edges of
/// its two 64-bit words.
#[test]
fn pairs_visited_are_the_pairs_not_left_out_in_order() {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for case in 0..3000 {
        let skip =
            ((next() as u128) << 64 | next() as u128) & ((next() as u128) << 64 | next() as u128);
        let skip = if case % 7 == 0 { !0 } else { skip };
        let nda = (next() % 12) as usize;
        let ndb = if case % 5 == 0 {
            (next() % 201) as usize
        } else {
            (next() % 20) as usize
        };
        // Every eleventh case, pair counts at the edges of `Pairs`'s two words (63, 64,
        // 65, 127, 128, 129 pairs) and a cube pair's 9.
        const EDGES: [(usize, usize); 7] =
            [(9, 7), (8, 8), (5, 13), (1, 127), (8, 16), (3, 43), (3, 3)];
        let (nda, ndb) = if case % 11 == 0 {
            EDGES[case / 11 % EDGES.len()]
        } else {
            (nda, ndb)
        };
        let mut want = Vec::new();
        let mut bit = 1u128;
        for ia in 0..nda {
            for ib in 0..ndb {
                let skipped = skip & bit != 0;
                bit <<= 1;
                if !skipped {
                    want.push((ia, ib));
                }
            }
        }
        let want: Vec<_> = want
            .into_iter()
            .map(|(ia, ib)| (ia, ib, ia * ndb + ib))
            .collect();
        let got: Vec<_> = Pairs::new(skip, nda, ndb).collect();
        assert_eq!(
            got, want,
            "case {case}: nda {nda}, ndb {ndb}, skip {skip:#x}"
        );
    }
}

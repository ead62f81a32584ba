//! Tests of [`super`] (the edge-axis search), beside it to keep `edges.rs` short.

use super::super::memory::EdgeMemory;
use super::super::test_shapes::{cuboid, xorshift, xorshift_centred};
use super::super::{NO_HINT, SoaPoints};
use super::{
    GaussTables, Pairs, direction_pair, edge_axes_by_direction, edges_of_direction,
    supporting_edges,
};
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
    // Prisms of 5 to 9 sides: their long edges, one direction of 5 to 9 edges, all tied
    // along the prism's axis (the first of equals must win).
    for n in 5..10 {
        let ring: Vec<Vec3> = (0..2 * n)
            .map(|k| {
                let th = (k % n) as f32 * std::f32::consts::TAU / n as f32;
                Vec3::new(th.cos(), th.sin(), if k < n { -0.7 } else { 0.7 })
            })
            .collect();
        let prism = convex_hull(&ring).expect("a prism");
        assert!((0..prism.edge_dirs.len()).any(|d| prism.dir_group(d).len() == n));
        shapes.push(prism);
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
    let mut next = xorshift_centred(0x9e37_79b9_7f4a_7c15u64);
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
            // The search's group: the same edges with their ends and their ends' sums
            // (bitwise).
            let group: Vec<_> = (p.dir_group(d).iter())
                .map(|r| (r.edge as usize, r.ends, r.sum.to_array().map(f32::to_bits)))
                .collect();
            let sum = |[v0, v1]: [u32; 2]| p.vertices[v0 as usize] + p.vertices[v1 as usize];
            let want: Vec<_> = (want.iter())
                .map(|&(e, ends)| (e, ends, sum(ends).to_array().map(f32::to_bits)))
                .collect();
            assert_eq!(group, want, "shape {i}, direction {d}");
        }
        // Every group's ends lie below `len` exactly when `dir_ends_below(len)` (the guard
        // of B's unchecked reads in `supporting_edges`): against the largest end of all.
        let largest = (0..p.edge_dirs.len())
            .flat_map(|d| p.dir_group(d).iter().flat_map(|r| r.ends))
            .max();
        for len in [
            0,
            1,
            p.vertices.len().saturating_sub(1),
            p.vertices.len(),
            p.vertices.len() + 1,
        ] {
            let want = largest.is_none_or(|v| (v as usize) < len);
            assert_eq!(p.dir_ends_below(len), want, "shape {i}, {len} points");
        }
        assert!(p.dir_ends_below(p.vertices.len()), "shape {i}");
    }
}

/// The direction pairs `Pairs` visits against testing each pair's bit in
/// turn (`skip`'s bit `k` for pair `k = ia * ndb + ib`, none from the 129th pair on), on
/// random sets of left-out pairs and row lengths 0 to 200, and pair counts at the edges of
/// its two 64-bit words.
#[test]
fn pairs_visited_are_the_pairs_not_left_out_in_order() {
    let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
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

thread_local! {
    /// How many searches by direction took the winner alone (`winner_alone`).
    pub(super) static ALONE: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The search by direction by brute force, the oracle of [`winner_alone`]'s served answers:
/// every direction pair through [`direction_pair`] in the search's order (A's direction,
/// then B's), the first whose separation is positive separating (`Err` with it), else the
/// first of the largest, with its supporting edges.
fn search_by_brute_force(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    rot: Mat3,
    bv: &[Vec3],
    b_soa: &SoaPoints,
) -> Result<super::EdgeAxis, f32> {
    let mut best = (f32::NEG_INFINITY, 0, 0, Vec3::ZERO);
    for (ia, &ua) in a.edge_dirs.iter().enumerate() {
        for (ib, &ub) in b.edge_dirs.iter().enumerate() {
            let Some((s, axis)) = direction_pair(ua, rot * ub, a.lanes(), b_soa) else {
                continue;
            };
            if s > 0.0 {
                return Err(s);
            }
            if s > best.0 {
                best = (s, ia, ib, axis);
            }
        }
    }
    if best.0 == f32::NEG_INFINITY {
        return Ok(best);
    }
    let (s, ia, ib, axis) = best;
    let (ea, eb) = supporting_edges(a, b, bv, ia, ib, axis);
    Ok((s, ea, eb, axis))
}

/// A pair stepped through `steps` touching poses (B's centre at the bodies' supports along
/// `dir` less an overlap that swings from pressed in to apart, sliding across; B turning
/// at `spin` rad a step about `w`, A fixed), searched by direction with one memory and a
/// floor that wanders below the best axis (as a remembered edge contact's does; above it
/// every thirteenth step), each answer held against
/// the brute force: bitwise when the best axis is above the floor (or separates), else at
/// or below it. Returns (steps compared bitwise, steps the winner alone served).
fn run_winner_alone(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    (dir, w, slide): (Vec3, Vec3, Vec3),
    eb: usize,
    spin: f32,
    depth: f32,
    steps: usize,
) -> (usize, usize) {
    let radii = a.radius + b.radius;
    let (mut memory, mut tables) = (EdgeMemory::default(), GaussTables::default());
    // B laid with edge `eb`'s bisector against `dir` (crossed edges when `dir` is A's
    // edge's bisector).
    let bisector = |p: &ConvexPolyhedron, e: usize| {
        let [f0, f1] = p.edge_faces[e % p.edges.len()];
        (p.faces[f0 as usize].normal + p.faces[f1 as usize].normal).normalize()
    };
    let q0 = Quat::from_rotation_arc(bisector(b, eb), -dir);
    let (mut exact, alone0) = (0, ALONE.with(|n| n.get()));
    for k in 0..steps {
        let phase = k as f32 * 0.01;
        let q = (Quat::from_axis_angle(w, spin * k as f32) * q0).normalize();
        let rot = Mat3::from_quat(q);
        let reach_a = a
            .vertices
            .iter()
            .map(|v| v.dot(dir))
            .fold(f32::MIN, f32::max);
        let reach_b = (b.vertices.iter())
            .map(|v| -(rot * *v).dot(dir))
            .fold(f32::MIN, f32::max);
        let overlap = radii * (0.003 + 0.004 * phase.sin());
        let t = dir * (reach_a + reach_b - overlap) + slide * (0.01 * radii * phase.cos());
        let bv: Vec<Vec3> = b.vertices.iter().map(|&v| rot * v + t).collect();
        // The search reads B's points moved as `remembered_edge` moves them (lane by lane
        // from the shape's lanes, then back as points), the oracle B's vertices moved one
        // by one and laid out.
        let (mut b_soa, mut b_moved) = (SoaPoints::default(), Vec::new());
        b_soa.fill_moved(b.lanes(), rot, t);
        b_soa.points_into(&mut b_moved, b.vertices.len());
        // Below the best axis by a wandering room (as a remembered edge contact's floor
        // is), or above it every thirteenth step.
        let want = search_by_brute_force(a, b, rot, &bv, &SoaPoints::of(&bv));
        let best = want.map_or(0.0, |e| e.0.clamp(-radii, 0.0));
        let room = depth * radii * (0.6 + 0.5 * (0.3 * phase).sin());
        let floor = if k % 13 == 0 { 0.5 * best } else { best - room };
        let (mut hint, mut separation) = (NO_HINT, 0.0);
        let found = edge_axes_by_direction(
            a,
            b,
            rot,
            t,
            a.lanes(),
            &b_soa,
            &b_moved,
            floor,
            &mut tables,
            Some((&mut memory, q, t)),
            &mut hint,
            &mut separation,
        );
        let bits = |e: super::EdgeAxis| (e.0.to_bits(), e.1, e.2, e.3.to_array().map(f32::to_bits));
        match (want, found) {
            (Err(s), None) => {
                assert_eq!(s.to_bits(), separation.to_bits(), "step {k}");
                exact += 1;
            }
            (Ok(want), Some(got)) if want.0 > floor => {
                assert_eq!(bits(want), bits(got), "step {k}, floor {floor}");
                exact += 1;
            }
            (Ok(_), Some(got)) => assert!(got.0 <= floor, "step {k}: {got:?} above {floor}"),
            (want, got) => panic!("step {k}: {want:?} against {got:?}"),
        }
    }
    (exact, ALONE.with(|n| n.get()) - alone0)
}

/// The search by direction with a memory that serves the last winner alone when every
/// other pair is left out (`winner_alone`) against brute force, on boxes, a cuboid, an
/// octahedron and a prism touching at many poses: settled (turning 1e-5 to 1e-3 rad a
/// step), spun fast (3e-3 rad a step: 300 rad/s at the piles' 1e-5 s steps; and 0.03),
/// turned about the line of centres (the edge pairs take turns winning) and sliding.
/// Every answer above the floor bitwise the brute force's; the winner alone served a good
/// share of the steps.
#[test]
fn the_winner_alone_is_the_whole_searchs_answer() {
    let octahedron = convex_hull(&[Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z])
        .expect("an octahedron");
    let prism = convex_hull(
        &(0..6)
            .map(|k| {
                let th = (k % 3) as f32 * std::f32::consts::TAU / 3.0;
                Vec3::new(th.cos(), th.sin(), if k < 3 { -0.4 } else { 0.4 })
            })
            .collect::<Vec<_>>(),
    )
    .expect("a prism");
    let shapes = [
        cuboid(Vec3::splat(0.5)),
        cuboid(Vec3::new(0.5, 0.3, 0.2)),
        octahedron,
        prism,
    ];
    let mut next = xorshift_centred(0x05ee_de37_u64);
    let mut unit = move || Vec3::new(next(), next(), next()).normalize_or(Vec3::Z);
    let (mut exact, mut alone, mut total) = (0, 0, 0);
    for a in &shapes {
        for b in &shapes {
            for spin in [1e-5, 1e-4, 1e-3, 3e-3, 3e-2] {
                for case in 0..4 {
                    // Edges crossed (A's edge's bisector the line of centres), or at
                    // a random direction, every fourth run.
                    let e = (next() + 0.5) * 1000.0;
                    let [f0, f1] = a.edge_faces[e as usize % a.edges.len()];
                    let crossed = a.faces[f0 as usize].normal + a.faces[f1 as usize].normal;
                    let dir = if case == 3 {
                        unit()
                    } else {
                        crossed.normalize()
                    };
                    // Half the runs turn B about the line of centres.
                    let w = if case % 2 == 0 { dir } else { unit() };
                    let slide = unit().cross(dir).normalize_or(Vec3::X);
                    let depth = [0.01, 0.05, 0.2][case % 3];
                    let eb = (e * 7.0) as usize;
                    let (e, n) = run_winner_alone(a, b, (dir, w, slide), eb, spin, depth, 200);
                    (exact, alone, total) = (exact + e, alone + n, total + 200);
                }
            }
        }
    }
    println!("{exact} of {total} steps compared bitwise, {alone} served by the winner alone");
    assert!(exact * 2 > total, "{exact} of {total}");
    assert!(alone * 12 > total, "{alone} of {total}");
}

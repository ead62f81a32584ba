//! The winner-stays skip ([`super::lead::WinnerLead`]) against the whole search by
//! direction: two memories stepped side by side through the same poses, one searched with
//! the skip and one without; every step's answer (the best axis's bits and edges, or the
//! separating hint and separation) and the memory's search state after it must be the same,
//! bitwise. Poses: cubes, boxes and hexagonal prisms pressed together at random relative
//! rotations and crossed edges, turning slowly (about the line of centres, so that other
//! direction pairs rise to the winner's separation and overtake it: near-ties) and about
//! one of A's edge directions (a direction pair near parallel), sliding, pressed in and out.

use glam::{Mat3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::edges::{GaussTables, edge_axes_by_direction};
use super::lanes::SoaPoints;
use super::memory::EdgeMemory;
use super::{NO_HINT, SatHint};
use crate::ConvexPolyhedron;

/// A box of half extents `h`, a cube, and a hexagonal prism (4 edge directions).
fn shapes() -> Vec<ConvexPolyhedron> {
    let corners = |h: Vec3| {
        (0..8)
            .map(|k| {
                let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
            })
            .collect::<Vec<_>>()
    };
    let prism: Vec<Vec3> = (0..12)
        .map(|k| {
            let phi = (k % 6) as f32 * std::f32::consts::FRAC_PI_3;
            Vec3::new(
                0.01 * phi.cos(),
                0.01 * phi.sin(),
                if k < 6 { -0.008 } else { 0.008 },
            )
        })
        .collect();
    [
        corners(Vec3::splat(0.01)),
        corners(Vec3::new(0.012, 0.007, 0.004)),
        prism,
    ]
    .iter()
    .map(|pts| crate::convex_hull(pts).expect("a hull"))
    .collect()
}

/// What one search returned, as bits: the best axis's separation, edges and axis, or the
/// separating hint and separation.
type Answer = Result<(u32, usize, usize, [u32; 3]), (SatHint, u32)>;

/// One search of `a` against `b` at relative rotation `q` and offset `t` with `floor`.
fn search(
    a: &ConvexPolyhedron,
    b: &ConvexPolyhedron,
    (q, t): (Quat, Vec3),
    floor: f32,
    tables: &mut GaussTables,
    memory: Option<&mut EdgeMemory>,
) -> Answer {
    let rot = Mat3::from_quat(q);
    let bv: Vec<Vec3> = b.vertices.iter().map(|&v| rot * v + t).collect();
    let mut b_soa = SoaPoints::default();
    b_soa.fill(&bv);
    let (mut hint, mut separation) = (NO_HINT, 0.0f32);
    let found = edge_axes_by_direction(
        a,
        b,
        rot,
        t,
        a.lanes(),
        &b_soa,
        &bv,
        floor,
        tables,
        memory.map(|m| (m, q, t)),
        &mut hint,
        &mut separation,
    );
    match found {
        Some((s, ea, eb, axis)) => Ok((s.to_bits(), ea, eb, axis.to_array().map(f32::to_bits))),
        None => Err((hint, separation.to_bits())),
    }
}

/// Runs pairs of every shape against every shape through slow motions, the skip's memory
/// against the whole search's; returns (searches, searches the skip decided).
fn run(seed: u64, plant: impl Fn(&mut EdgeMemory)) -> (usize, usize) {
    let shapes = shapes();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut searches, mut decided) = (0, 0);
    let unit = |rng: &mut ChaCha8Rng| {
        Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0f32..1.0),
        )
        .normalize_or(Vec3::X)
    };
    for a in &shapes {
        for b in &shapes {
            for case in 0..24 {
                let radii = a.radius + b.radius;
                let dir = unit(&mut rng);
                let slide = unit(&mut rng).cross(dir).normalize_or(Vec3::Y);
                let q0 = match case % 3 {
                    // Random, or a quarter turn about A's first edge direction and a little
                    // off it (a direction pair near parallel).
                    0 | 1 => Quat::from_scaled_axis(unit(&mut rng) * rng.random_range(0.0..3.0)),
                    _ => Quat::from_axis_angle(a.edge_dirs[0], rng.random_range(0.0..1.6)),
                };
                // Turning about the line of centres (near-ties) or about A's edge direction.
                let axis = if case % 2 == 0 { dir } else { a.edge_dirs[0] };
                let spin = [1e-5f32, 1e-4, 1e-3, 4e-3][case % 4];
                let mut plain = GaussTables::default();
                let (mut t_memory, mut f_memory) = (EdgeMemory::default(), EdgeMemory::default());
                let (mut t_tables, mut f_tables) = (GaussTables::default(), GaussTables::default());
                f_tables.winner_stays = false;
                for k in 0..250 {
                    let phase = k as f32 * 0.02;
                    let q = (Quat::from_axis_angle(axis, spin * k as f32) * q0).normalize();
                    let side = slide * (0.05 * radii * (0.7 * phase).sin());
                    // The distance along `dir` at which no edge axis separates any more, by
                    // bisection on the search without memory, less an overlap that swings
                    // from 0.5% of the radii to a gap and back.
                    let (mut lo, mut hi) = (0.0f32, radii);
                    for _ in 0..20 {
                        let mid = 0.5 * (lo + hi);
                        let at = (q, side + dir * mid);
                        if search(a, b, at, f32::NEG_INFINITY, &mut plain, None).is_ok() {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    let overlap = (0.002 + 0.003 * phase.sin()) * radii;
                    let t = side + dir * (hi - overlap);
                    // Floors from near the contact's depth to far below it.
                    let floor = -radii * [2e-3f32, 1e-2, 5e-2, 1.0][(k / 7 + case) % 4];
                    let before = t_tables.decided;
                    let with = search(a, b, (q, t), floor, &mut t_tables, Some(&mut t_memory));
                    plant(&mut t_memory);
                    let without = search(a, b, (q, t), floor, &mut f_tables, Some(&mut f_memory));
                    let skipped = t_tables.decided > before;
                    assert_eq!(with, without, "case {case}, step {k}: answers differ");
                    assert_eq!(
                        t_memory.search_state(),
                        f_memory.search_state(),
                        "case {case}, step {k}: memories differ (skipped: {skipped})"
                    );
                    searches += 1;
                    decided += skipped as usize;
                }
            }
        }
    }
    (searches, decided)
}

/// The skip's answers and memories are the whole search's, bitwise, and it decided a good
/// share of the searches (so the comparison covered it).
#[test]
fn winner_stays_skip_gives_the_whole_searchs_answer_and_memory() {
    let (searches, decided) = run(2311, |_| {});
    println!("{decided} of {searches} searches decided by the winner alone");
    assert!(decided * 10 > searches, "{decided} of {searches} decided");
}

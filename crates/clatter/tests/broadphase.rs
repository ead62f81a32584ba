//! The grid broad phase against brute force: `broad::pairs` finds exactly the pairs that
//! `broad::pairs_brute_force` finds, on scenes chosen to stress the grid; and inside `World`
//! the pairs in contact after the whole pipeline (bin, sort, pairs with the Verlet skin,
//! narrow phase with separating-axis hints) are exactly those that the narrow phase finds
//! when run on every pair of bodies (and every body against every wall).

use clatter::broad::{self, Grid};
use clatter::geom::narrow;
use clatter::geom::{Pose, RegularKind, ShapeKind};
use clatter::pile::{PileParams, PileShape, pile};
use clatter::scene::random_rotation;
use clatter::{BodyInit, ContactLaw, Material, World, WorldDesc};
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Runs the grid broad phase as `World` does (cells of at least the largest bounding diameter
/// plus the skin) and compares with brute force.
fn check(positions: &[Vec3], radii: &[f32], skin: f32, what: &str) -> usize {
    let rmax = radii.iter().copied().fold(0.0, f32::max);
    let grid = Grid::around(positions, 2.0 * rmax + skin);
    let fast = broad::pairs(&grid, positions, radii, skin);
    let slow = broad::pairs_brute_force(positions, radii, skin);
    assert!(
        fast.windows(2).all(|w| w[0] < w[1]),
        "{what}: pairs not sorted or duplicated"
    );
    assert!(fast.iter().all(|p| p[0] < p[1]), "{what}: pair with i >= j");
    if fast != slow {
        let missing: Vec<_> = slow.iter().filter(|p| !fast.contains(p)).take(5).collect();
        let extra: Vec<_> = fast.iter().filter(|p| !slow.contains(p)).take(5).collect();
        panic!(
            "{what}: grid found {} pairs, brute force {}; missing {missing:?}, extra {extra:?}",
            fast.len(),
            slow.len()
        );
    }
    // The cells are sized as promised and every body is binned into the grid.
    assert!(
        grid.cell_size >= 2.0 * rmax + skin,
        "{what}: cell {} too small",
        grid.cell_size
    );
    let keys = broad::bin(&grid, positions);
    assert!(
        keys.iter().all(|&k| (k as usize) < grid.cell_count()),
        "{what}: key outside the grid"
    );
    fast.len()
}

fn uniform(rng: &mut ChaCha8Rng, n: usize, extent: f32) -> Vec<Vec3> {
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.random_range(-extent..extent),
                rng.random_range(-extent..extent),
                rng.random_range(-extent..extent),
            )
        })
        .collect()
}

fn radii(rng: &mut ChaCha8Rng, n: usize, lo: f32, hi: f32) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(lo..hi)).collect()
}

#[test]
fn tiny_scenes() {
    // n = 0, 1, 2: nothing, nothing, and a pair exactly when the skin-grown spheres overlap.
    assert_eq!(check(&[], &[], 0.0, "empty"), 0);
    assert_eq!(
        check(&[Vec3::new(3.0, -2.0, 1.0)], &[0.5], 0.1, "one body"),
        0
    );
    let a = Vec3::new(0.1, 0.2, 0.3);
    for (d, skin, expected) in [
        (1.9f32, 0.0, 1),
        (2.05, 0.0, 0),
        (2.05, 0.1, 1),
        (2.2, 0.1, 0),
        (0.0, 0.0, 1),
    ] {
        let n = check(
            &[a, a + Vec3::new(d, 0.0, 0.0)],
            &[1.0, 1.0],
            skin,
            "two bodies",
        );
        assert_eq!(n, expected, "distance {d}, skin {skin}");
        let n = check(
            &[a + Vec3::new(0.0, d, d) / 2f32.sqrt(), a],
            &[1.0, 1.0],
            skin,
            "two bodies, diagonal",
        );
        assert_eq!(n, expected, "diagonal distance {d}, skin {skin}");
    }
}

#[test]
fn random_scenes_match_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut total = 0;
    for round in 0..20 {
        let skin = [0.0, 0.001, 0.01][round % 3];
        // Spread out, varied radii.
        let n = rng.random_range(50..400);
        let r = radii(&mut rng, n, 0.001, 0.03);
        total += check(&uniform(&mut rng, n, 0.3), &r, skin, "uniform");
        // Dense: most bodies overlap several neighbours.
        total += check(&uniform(&mut rng, n, 0.05), &r, skin, "dense");
        // Clustered: a few tight gaussian-ish blobs far apart.
        let centres = uniform(&mut rng, 5, 1.0);
        let p: Vec<Vec3> = (0..n)
            .map(|i| centres[i % 5] + uniform(&mut rng, 1, 0.04)[0])
            .collect();
        total += check(&p, &r, skin, "clusters");
        // One giant among small ones: cells sized by the giant.
        let mut r2 = radii(&mut rng, n, 0.001, 0.005);
        r2[n / 2] = 0.2;
        total += check(&uniform(&mut rng, n, 0.3), &r2, skin, "one big body");
        // A body very far away: the grid grows its cells instead of allocating a huge grid.
        let mut p = uniform(&mut rng, n, 0.1);
        p[0] = Vec3::new(1.0e4, -3.0e3, 2.0e3);
        total += check(&p, &r, skin, "far body");
        // Many bodies in one cell.
        let p = uniform(&mut rng, n, 0.005);
        total += check(&p, &radii(&mut rng, n, 0.004, 0.006), skin, "one cell");
        // A lattice with spacing equal to the cell size: centres on cell boundaries, and
        // neighbours exactly at the reach distance.
        let cell = 2.0 * 0.01 + skin;
        let side = 7;
        let p: Vec<Vec3> = (0..side * side * side)
            .map(|i| {
                Vec3::new(
                    (i % side) as f32,
                    ((i / side) % side) as f32,
                    (i / (side * side)) as f32,
                ) * cell
                    - Vec3::splat(0.03)
            })
            .collect();
        total += check(&p, &vec![0.01; p.len()], skin, "lattice");
        // Shifted half a cell and scaled a hair down so neighbours overlap.
        let p: Vec<Vec3> = p
            .iter()
            .map(|&x| x * 0.999 + Vec3::splat(0.5 * cell))
            .collect();
        total += check(&p, &vec![0.01; p.len()], skin, "lattice, touching");
    }
    eprintln!("{total} pairs checked");
    assert!(total > 10_000, "too few pairs to mean anything: {total}");
}

/// A dense cloud of mixed polyhedra (tetrahedra, cubes, octahedra, dodecahedra, icosahedra,
/// spheres; random sizes, orientations, spins), converging so that contacts form and break.
fn mixed_cloud(n: usize, seed: u64) -> WorldDesc {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut shapes = Vec::new();
    for r in [0.007, 0.01, 0.013] {
        shapes.push(ShapeKind::Sphere { radius: r }.prepare().unwrap());
        for kind in RegularKind::ALL {
            shapes.push(ShapeKind::Regular { kind, radius: r }.prepare().unwrap());
        }
    }
    shapes.push(
        ShapeKind::Box {
            half_extents: [0.012, 0.006, 0.003],
        }
        .prepare()
        .unwrap(),
    );
    let spacing = 0.024f32;
    let half = (n as f32 - 1.0) / 2.0;
    let bodies = (0..n * n * n)
        .map(|i| {
            let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
            let base = (Vec3::new(x as f32, y as f32, z as f32) - Vec3::splat(half)) * spacing;
            let position = base + uniform(&mut rng, 1, 0.002)[0];
            BodyInit {
                shape: rng.random_range(0..shapes.len()) as u32,
                material: 0,
                position: position.as_dvec3(),
                orientation: random_rotation(&mut rng),
                velocity: -position / 0.05 + uniform(&mut rng, 1, 0.3)[0],
                angular_velocity: uniform(&mut rng, 1, 50.0)[0],
            }
        })
        .collect();
    WorldDesc {
        shapes,
        materials: vec![Material::new(
            "m",
            2500.0,
            ContactLaw::Linear { stiffness: 2.0e4 },
            0.3,
            0.5,
        )],
        walls: vec![],
        bodies,
        gravity: Vec3::ZERO,
        dt: None,
        skin: None,
        periodic: None,
    }
}

/// Steps `w` `steps` times; every `every` steps compares the pipeline's touching pairs (and
/// wall contact count) with the narrow phase on all pairs at the poses that step used.
/// Returns (checks, touching pairs seen in total).
fn compare_with_all_pairs(w: &mut World, steps: usize, every: usize) -> (usize, usize) {
    let mut checks = 0;
    let mut seen = 0;
    for s in 0..steps {
        let check = s % every == every - 1;
        let poses: Vec<Pose> = if check {
            (0..w.len())
                .map(|i| Pose::new(w.state.position_f32(i), w.state.orientation[i]))
                .collect()
        } else {
            Vec::new()
        };
        let stats = w.step().unwrap();
        if !check {
            continue;
        }
        let shape = |i: usize| &w.shapes[w.consts.shape[i] as usize].shape;
        let mut brute = Vec::new();
        for i in 0..w.len() {
            for j in i + 1..w.len() {
                if narrow::collide(shape(i), &poses[i], shape(j), &poses[j]).is_some() {
                    brute.push([i as u32, j as u32]);
                }
            }
        }
        let mut wall_contacts = 0;
        for (i, pose) in poses.iter().enumerate() {
            for wall in &w.walls {
                if narrow::collide_plane(&wall.plane, shape(i), pose).is_some() {
                    wall_contacts += 1;
                }
            }
        }
        let found = w.touching_pairs();
        if found != brute {
            let missing: Vec<_> = brute
                .iter()
                .filter(|p| !found.contains(p))
                .take(5)
                .collect();
            let extra: Vec<_> = found
                .iter()
                .filter(|p| !brute.contains(p))
                .take(5)
                .collect();
            panic!(
                "step {}: pipeline has {} touching pairs, all-pairs narrow phase {}; missing {missing:?}, extra {extra:?}",
                w.step_count,
                found.len(),
                brute.len()
            );
        }
        assert_eq!(
            stats.contacts,
            brute.len() + wall_contacts,
            "step {}: contact count",
            w.step_count
        );
        checks += 1;
        seen += brute.len();
    }
    (checks, seen)
}

#[test]
fn pipeline_contacts_match_all_pairs_narrow_phase_in_a_cloud() {
    let mut w = World::new(mixed_cloud(6, 3));
    let (checks, seen) = compare_with_all_pairs(&mut w, 3000, 50);
    eprintln!(
        "cloud: {checks} checks, {seen} touching pairs compared, {} rebuilds",
        w.rebuilds
    );
    assert!(seen > 1000, "too few contacts to mean anything: {seen}");
    assert!(
        w.rebuilds > 3,
        "the Verlet list was never rebuilt: {}",
        w.rebuilds
    );
}

#[test]
fn pipeline_contacts_match_all_pairs_narrow_phase_in_a_pile() {
    let mut desc = pile(PileShape::Mixed, 300, &PileParams::default());
    for (i, b) in desc.bodies.iter_mut().enumerate() {
        let f = i as f32;
        b.velocity = Vec3::new((f * 0.37).sin(), (f * 0.73).cos(), (f * 0.11).sin());
        b.orientation = Quat::from_rotation_z(f) * b.orientation;
    }
    let mut w = World::new(desc);
    let (checks, seen) = compare_with_all_pairs(&mut w, 3000, 50);
    eprintln!(
        "pile: {checks} checks, {seen} touching pairs compared, {} rebuilds",
        w.rebuilds
    );
    assert!(seen > 1000, "too few contacts to mean anything: {seen}");
}

#[test]
fn periodic_boxes_match_nearest_image_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for (case, axes) in [
        [true, false, false],
        [true, true, false],
        [true, true, true],
    ]
    .into_iter()
    .enumerate()
    {
        for n in [2usize, 40, 600] {
            let side = 0.5;
            let periodic = clatter::Periodic {
                min: Vec3::splat(-0.25),
                max: Vec3::splat(0.25),
                axes,
            };
            // Bodies crowd the faces, so many pairs cross the seams.
            let positions: Vec<Vec3> = (0..n)
                .map(|_| {
                    let mut p = Vec3::ZERO;
                    for k in 0..3 {
                        let u: f32 = rng.random_range(0.0..1.0);
                        p[k] = -0.25
                            + side
                                * if u < 0.5 {
                                    u * 0.2
                                } else {
                                    1.0 - (u - 0.5) * 0.2
                                };
                        p[k] = p[k].min(0.25 - 1e-6);
                    }
                    p
                })
                .collect();
            let radii = radii(&mut rng, n, 0.005, 0.03);
            let skin = 0.01;
            let rmax = radii.iter().copied().fold(0.0, f32::max);
            let grid = Grid::around(&positions, 2.0 * rmax + skin);
            let fast = broad::pairs_periodic(&grid, &positions, &radii, skin, Some(&periodic));
            let slow = broad::pairs_brute_force_periodic(&positions, &radii, skin, Some(&periodic));
            let across = slow
                .iter()
                .filter(|&&[i, j]| {
                    let d = positions[j as usize] - positions[i as usize];
                    periodic.nearest(d) != d
                })
                .count();
            assert!(
                fast.windows(2).all(|w| w[0] < w[1]),
                "case {case}, n = {n}: pairs not sorted or duplicated"
            );
            assert_eq!(fast, slow, "case {case}, n = {n}");
            if n == 600 {
                assert!(
                    across > 50,
                    "case {case}: only {across} pairs across a seam"
                );
            }
        }
    }
}

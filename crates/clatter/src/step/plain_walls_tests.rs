//! Tests of the plain wall path: against the old path (`wall_pair`, kept as the
//! reference) bit for bit over real piles, and its skips against brute force.

use glam::Vec3;

use super::super::contacts;
use super::wall_pair;
use crate::World;
use crate::pile::PileShape;
use clatter_geom::Shape;

/// The exact lowest height above wall `wall`'s plane of body `i` at its stored pose (f64,
/// the orientation normalised): the truth a kept gap is held to.
fn lowest_height(w: &World, i: usize, wall: usize) -> f64 {
    let plane = &w.walls[wall].plane;
    let n = plane.normal.as_dvec3();
    let x = w.state.position[i];
    let centre = n.dot(x) - plane.offset as f64;
    match w.shape(i) {
        Shape::Sphere { radius } => centre - *radius as f64,
        Shape::Polyhedron(p) => {
            let q = w.state.orientation[i].as_dquat().normalize();
            let low = p.vertices.iter().map(|v| n.dot(q * v.as_dvec3()));
            centre + low.fold(f64::INFINITY, f64::min)
        }
        Shape::Composite(_) => f64::NEG_INFINITY,
    }
}

/// What one run found: wall pairs skipped, computed touching, computed apart.
#[derive(Debug, Default)]
struct Seen {
    skipped: usize,
    touching: usize,
    apart: usize,
}

/// Steps `w` `steps` times. Before each step: every wall pair's contact by the old path
/// (`wall_pair::<false>` on a copy of the world, with the step's positions and bounds),
/// and, for each pair the step will skip (its kept gap less the body's motion bound still
/// positive), the exact lowest height of its body above the wall, which must be at least
/// that. After it: the step's wall forces, springs and flags equal the old path's, bit for bit.
fn hold(w: &mut World, steps: usize) -> Seen {
    let mut seen = Seen::default();
    for step in 0..steps {
        if w.needs_rebuild() {
            // What the step does first; the list is then the one its contacts use.
            w.rebuild_contacts();
        }
        let mut r = w.clone();
        contacts::prepare(&mut r);
        let np = r.contacts.pairs.len();
        let plain = r.materials.all_plain();
        let mut sp = std::mem::take(&mut r.contacts.springs);
        let gaps = w.contacts.wall_gap.gaps.clone();
        let kept = gaps.len() == r.contacts.wall_pairs.len();
        for (k, &[i, wall]) in r.contacts.wall_pairs.iter().enumerate() {
            let c = np + k;
            let touches = wall_pair::<false>(
                &r,
                &r.position_pairs,
                [i, wall],
                0,
                &mut sp.history[c],
                &mut sp.forces[c],
                &mut sp.touching[c],
                &mut sp.twist[c],
                plain,
            );
            let left = if kept {
                gaps[k] - r.body_bounds[i as usize].moved
            } else {
                0.0
            };
            if left > 0.0 {
                seen.skipped += 1;
                let low = lowest_height(&r, i as usize, wall as usize);
                assert!(
                    low >= left as f64,
                    "step {step}, body {i}, wall {wall}: lowest height {low:e} below the kept gap {left:e}"
                );
                assert!(!touches, "step {step}: a skipped pair touches");
            } else if touches {
                seen.touching += 1;
            } else {
                seen.apart += 1;
            }
        }
        w.step().expect("step");
        let got = &w.contacts.springs;
        assert_eq!(w.contacts.pairs.len(), np, "the list changed in the step");
        for k in np..got.forces.len() {
            let (f, g) = (sp.forces[k], got.forces[k]);
            let bits = |f: &crate::law::ContactForce| {
                let v = |v: Vec3| v.to_array().map(f32::to_bits);
                (
                    v(f.force_b),
                    v(f.torque_a),
                    v(f.torque_b),
                    f.normal_force.to_bits(),
                )
            };
            assert_eq!(bits(&g), bits(&f), "step {step}, contact {k}: force");
            let v = |v: Vec3| v.to_array().map(f32::to_bits);
            assert_eq!(v(got.history[k]), v(sp.history[k]), "step {step}: spring");
            assert_eq!(got.twist[k].to_bits(), sp.twist[k].to_bits(), "step {step}");
            assert_eq!(got.touching[k], sp.touching[k], "step {step}: touching");
        }
    }
    seen
}

/// A pile of `n` bodies of `shape` poured (restitution 0.1), each spinning at up to `spin`
/// rad/s about an axis of its own, and moving at up to `speed` m/s.
fn pile(shape: PileShape, n: usize, seed: u64, spin: f32, speed: f32) -> World {
    super::super::contacts::tests::thrown_pile(shape, n, seed, spin, speed)
}

/// The plain wall path gives the old path's forces and springs bit for bit, step after
/// step, on cube and mixed piles poured and landing, and on cubes thrown spinning fast
/// (300 rad/s, 2 m/s); every pair it skips is apart by at least its kept gap (exact, f64).
/// Not vacuous: many pairs skipped, touching and computed apart in each.
#[test]
fn plain_walls_are_the_old_path_and_skip_only_pairs_apart() {
    for (shape, n, seed, spin, speed, steps) in [
        (PileShape::Cube, 64, 3, 0.0, 0.0, 5_000),
        (PileShape::Mixed, 64, 5, 0.0, 0.0, 5_000),
        (PileShape::Cube, 48, 9, 300.0, 2.0, 2_500),
        (PileShape::Mixed, 48, 11, 300.0, 2.0, 2_500),
    ] {
        let mut w = pile(shape, n, seed, spin, speed);
        let seen = hold(&mut w, steps);
        eprintln!("{shape:?} spin {spin}: {seen:?}");
        assert!(
            seen.skipped > 20_000 && seen.touching > 5_000 && seen.apart > 500,
            "{seen:?}"
        );
    }
}

/// A moved wall clears the kept gaps (a body near it is computed again), and a world with
/// periodic boundaries keeps none.
#[test]
fn gaps_follow_the_walls_and_not_periodic_worlds() {
    let mut w = pile(PileShape::Cube, 48, 4, 0.0, 0.0);
    for _ in 0..3_000 {
        w.step().expect("step");
    }
    assert!(w.contacts.wall_gap.gaps.iter().any(|&g| g > 0.0));
    // Every wall moved inwards by a body's size: bodies near it now overlap it.
    let r = w.consts.radius[0];
    for wall in &mut w.walls {
        wall.plane.offset += 2.0 * r;
    }
    let mut moved = w.clone();
    moved.contacts.wall_gap = Default::default();
    w.step().expect("step");
    moved.step().expect("step");
    let v = |w: &World| {
        w.state
            .velocity
            .iter()
            .map(|v| v.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(v(&w), v(&moved), "a moved wall's pairs computed");
    let x = |w: &World| {
        w.state
            .position
            .iter()
            .map(|x| x.to_array().map(f64::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(x(&w), x(&moved));
    // Periodic: nothing kept.
    let mut w = pile(PileShape::Cube, 48, 4, 0.0, 0.0);
    w.periodic = Some(crate::periodic::Periodic {
        min: Vec3::new(-10.0, -10.0, 0.0),
        max: Vec3::new(10.0, 10.0, 0.0),
        axes: [true, true, false],
    });
    for _ in 0..500 {
        w.step().expect("step");
    }
    assert!(w.contacts.wall_gap.gaps.iter().all(|&g| g <= 0.0));
}

//! A sphere against a polyhedron with the pair's [`EdgeMemory`] (the faces remembered with
//! their margins) against the full computation without it: pairs stepped through time
//! (sliding over faces, across edges and vertices, rolling, the polyhedron spun slowly and
//! fast, pressed in past the centre, pulled apart and touching again), every step's
//! manifold and bound compared bitwise. And the bound of a pair found apart: while both
//! bodies have moved less than it, the full computation still finds them apart.

use clatter_geom::narrow::{self, EdgeMemory, NO_HINT};
use clatter_geom::{Pose, PreparedShape, Shape};
use glam::{Quat, Vec3};

mod common;
use common::Rng;

/// The Platonic solids and a hull of scattered points (as a mesh hull would be).
fn polyhedra() -> Vec<PreparedShape> {
    common::solids_and_hull(20)
}

/// What one pair's run saw.
#[derive(Default)]
struct Tally {
    steps: usize,
    touching: usize,
    apart: usize,
    /// Steps that the memory served (a record left unchanged by the call).
    held: usize,
    /// Steps whose full computation was checked against a running apart bound.
    bound_checked: usize,
}

/// One pair stepped `steps` times: the sphere's centre wanders over the polyhedron (its
/// direction turning by `wander` rad per step, so that it crosses face, edge and vertex
/// regions), its distance from the centre swinging from inside the polyhedron to apart,
/// while the polyhedron turns by `spin` rad per step and drifts. With `sphere_first` the
/// sphere is shape A.
#[allow(clippy::too_many_arguments)]
fn run_pair(
    poly: &Shape,
    rng: &mut Rng,
    radius: f32,
    spin: f32,
    wander: f32,
    swing: f32,
    sphere_first: bool,
    steps: usize,
    tally: &mut Tally,
) {
    let sphere = Shape::Sphere { radius };
    let rp = poly.bounding_radius();
    let mut dir = rng.unit();
    let turn_axis = rng.unit();
    let spin_axis = rng.unit();
    let mut q = rng.rotation();
    let mut centre_p = Vec3::new(rng.next(), rng.next(), rng.next());
    let drift = rng.unit() * 1e-3;
    let phase0 = rng.next() * 6.0;
    let mut memory = EdgeMemory::default();
    let mut bound_m = 0.0f32;
    // The running apart bound (of the full computation) and the motion since it was found.
    let mut apart: Option<(f32, f32)> = None;
    let mut last: Option<(Vec3, Vec3, Quat)> = None;
    for k in 0..steps {
        let phase = phase0 + k as f32 * swing;
        // From well inside (0.3 of the bounding radius) to apart by a third of the radii.
        let reach = 0.3 * rp + (0.5 + 0.5 * phase.sin()) * (rp + radius) * 1.05;
        let centre_s = centre_p + dir * reach;
        let pose_p = Pose::new(centre_p, q);
        let pose_s = Pose::new(centre_s, Quat::IDENTITY);
        let (a, pa, b, pb) = if sphere_first {
            (&sphere, &pose_s, poly, &pose_p)
        } else {
            (poly, &pose_p, &sphere, &pose_s)
        };
        let recorded = memory.remembers();
        let before = format!("{memory:?}");
        let (mut hint_m, mut hint) = (NO_HINT, NO_HINT);
        let mut bound = 0.0f32;
        let with =
            narrow::collide_with_memory(a, pa, b, pb, &mut hint_m, &mut bound_m, &mut memory);
        let without = narrow::collide_with_hint(a, pa, b, pb, &mut hint, &mut bound);
        let full = narrow::collide(a, pa, b, pb);
        let bits = |m: &Option<narrow::Manifold>| {
            m.map(|m| {
                let p = m.points[0];
                (
                    m.count,
                    m.normal.to_array().map(f32::to_bits),
                    p.point.to_array().map(f32::to_bits),
                    p.depth.to_bits(),
                )
            })
        };
        assert_eq!(bits(&with), bits(&full), "step {k}: manifolds differ");
        assert_eq!(bits(&without), bits(&full), "step {k}: manifolds differ");
        assert_eq!(
            bound_m.to_bits(),
            bound.to_bits(),
            "step {k}: bounds differ"
        );
        assert_eq!((hint_m, hint), (NO_HINT, NO_HINT));
        // Served: a record that the call left as it was (a new recording takes the new
        // centre).
        tally.held += (recorded && format!("{memory:?}") == before) as usize;
        // The bound's contract: every point of both bodies has moved less than it since,
        // so the full computation still finds the pair apart.
        if let (Some((b0, moved)), Some((cs, cp, q0))) = (apart, last) {
            // The sphere's centre moved by |dcs|; a point of the polyhedron at most rp from
            // its centre by |dcp| + (the angle turned) rp.
            let angle = 2.0 * (q0.conjugate() * q).xyz().length().min(1.0).asin();
            let step = (centre_s - cs).length() + (centre_p - cp).length() + angle * rp;
            let moved = moved + step * 1.001;
            if moved < b0 {
                assert!(
                    full.is_none(),
                    "step {k}: apart by {b0}, moved {moved}: {full:?}"
                );
                tally.bound_checked += 1;
                apart = Some((b0, moved));
            } else {
                apart = None;
            }
        }
        if bound > 0.0 {
            assert!(full.is_none(), "step {k}: a bound on a touching pair");
            apart = Some((bound, 0.0));
        } else if full.is_some() {
            apart = None;
        }
        tally.steps += 1;
        tally.touching += full.is_some() as usize;
        tally.apart += full.is_none() as usize;
        last = Some((centre_s, centre_p, q));
        dir = (Quat::from_axis_angle(turn_axis, wander) * dir).normalize();
        q = (Quat::from_axis_angle(spin_axis, spin) * q).normalize();
        centre_p += drift;
    }
}

#[test]
fn the_memory_changes_no_answer() {
    let shapes = polyhedra();
    let mut rng = Rng(2026);
    let mut tally = Tally::default();
    for s in &shapes {
        for (spin, wander, swing) in [
            // Resting and sliding slowly (the pile's case), rolling, crossing regions
            // fast, spun fast.
            (0.0, 1e-3, 2e-3),
            (1e-4, 3e-3, 5e-3),
            (3e-3, 1e-2, 1e-2),
            (0.05, 0.03, 0.05),
            (0.4, 0.2, 0.3),
        ] {
            for sphere_first in [true, false] {
                for radius in [0.25, 1.0] {
                    run_pair(
                        &s.shape,
                        &mut rng,
                        radius,
                        spin,
                        wander,
                        swing,
                        sphere_first,
                        200,
                        &mut tally,
                    );
                }
            }
        }
    }
    eprintln!(
        "{} pair-steps: {} touching, {} apart, {} served by the memory, {} bound checks",
        tally.steps, tally.touching, tally.apart, tally.held, tally.bound_checked
    );
    assert!(tally.steps >= 20_000, "{} pair-steps", tally.steps);
    // Both sides of the comparison covered: touching and apart, with the memory held
    // over most steps, and the apart bound exercised.
    assert!(
        tally.touching * 4 > tally.steps,
        "{} touching",
        tally.touching
    );
    assert!(tally.apart * 10 > tally.steps, "{} apart", tally.apart);
    assert!(
        tally.held * 2 > tally.steps,
        "held {} of {}",
        tally.held,
        tally.steps
    );
    assert!(
        tally.bound_checked > 100,
        "{} bound checks",
        tally.bound_checked
    );
}

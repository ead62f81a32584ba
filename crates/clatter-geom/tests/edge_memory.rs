//! The edge searches with a pair's [`EdgeMemory`] (the Gauss map's remembered edge pairs,
//! the deep direction pairs left out by direction) against the same searches without it:
//! polyhedron pairs stepped through time (turning slowly and fast, sliding, pressed
//! together and pulled apart), every step's manifold, hint and bound compared bitwise.

use clatter_geom::narrow::{self, EdgeMemory, NO_HINT};
use clatter_geom::{Pose, PreparedShape, Shape};
use glam::{Quat, Vec3};

mod common;
use common::Rng;

fn shapes() -> Vec<PreparedShape> {
    common::solids_and_hull(12)
}

/// One pair stepped `steps` times: B turns at `spin` rad per step about a fixed axis while
/// A turns slower, and B's centre slides and moves in and out along the line of centres.
/// Returns how many steps the memory held a finished search before the call.
fn run_pair(a: &Shape, b: &Shape, rng: &mut Rng, spin: f32, steps: usize) -> usize {
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let dir = rng.unit();
    let slide = rng.unit().cross(dir).normalize_or_zero();
    let (mut qa, mut qb) = (rng.rotation(), rng.rotation());
    let (wa, wb) = (rng.unit(), rng.unit());
    let mut memory = EdgeMemory::default();
    let (mut hint_m, mut bound_m) = (NO_HINT, 0.0f32);
    let (mut hint, mut bound) = (NO_HINT, 0.0f32);
    let mut held = 0;
    for k in 0..steps {
        let phase = k as f32 * 0.05;
        // From deep overlap to apart and back.
        let gap = (0.72 + 0.25 * phase.sin()) * (ra + rb);
        let pa = Pose::new(Vec3::ZERO, qa);
        let pb = Pose::new(dir * gap + slide * (0.3 * phase.cos()), qb);
        held += memory.remembers() as usize;
        let with =
            narrow::collide_with_memory(a, &pa, b, &pb, &mut hint_m, &mut bound_m, &mut memory);
        let without = narrow::collide_with_hint(a, &pa, b, &pb, &mut hint, &mut bound);
        assert_eq!(with, without, "step {k}: manifolds differ");
        assert_eq!(hint_m, hint, "step {k}: hints differ");
        assert_eq!(
            bound_m.to_bits(),
            bound.to_bits(),
            "step {k}: bounds differ"
        );
        // The caller's part of the remembered contact's contract: a margin less a bound of
        // the motion (generous), so the remembered paths and the full test both run.
        if bound > 0.0 {
            bound -= 1e-3 * (ra + rb);
            bound_m = bound;
        }
        qa = (Quat::from_axis_angle(wa, 0.1 * spin) * qa).normalize();
        qb = (Quat::from_axis_angle(wb, spin) * qb).normalize();
    }
    held
}

#[test]
fn the_memory_changes_no_answer() {
    let shapes = shapes();
    let mut rng = Rng(12345);
    let (mut held, mut total) = (0, 0);
    for sa in &shapes {
        for sb in &shapes {
            for spin in [1e-4, 2e-3, 3e-2, 0.3] {
                for _ in 0..3 {
                    held += run_pair(&sa.shape, &sb.shape, &mut rng, spin, 150);
                    total += 150;
                }
            }
        }
    }
    // The memory served a good share of the steps (the slow pairs), so the comparison
    // covered the remembered path, not only the recording one.
    assert!(
        held * 4 > total,
        "memory held in {held} of {total} pair-steps"
    );
}

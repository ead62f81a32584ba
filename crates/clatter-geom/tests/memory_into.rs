//! [`narrow::collide_with_memory_into`], the contacts stage's narrow phase of a pair with an
//! edge memory, writes its answer over whatever the caller's `found` held (the stage keeps
//! one `Option<Manifold>` per pair it tests; issue 23, pp38): polyhedron pairs stepped
//! through time as the stage steps them (the hint, bound and memory kept from step to step,
//! nothing taken off a remembered contact's margin), `found` filled with a stale manifold
//! before every call, and the answer compared bit for bit, unused points included, with
//! the full separating-axis test at the same poses ([`narrow::collide`]: no hint, no
//! memory). The pairs go from deep overlap to apart and back, turning slowly, so that every
//! path of the narrow phase answers some steps: bounding spheres apart, a separating axis
//! remembered, a remembered face or edge contact served, and the full test.

use clatter_geom::narrow::{self, ContactPoint, EdgeMemory, HINT_EDGE_CONTACT, Manifold, NO_HINT};
use clatter_geom::{Pose, Shape};
use glam::{Quat, Vec3};

mod common;
use common::Rng;

/// A manifold no narrow phase writes: NaN normal and depths, points far away, three used.
fn stale() -> Manifold {
    let point = ContactPoint {
        point: Vec3::new(1e30, -7.0, f32::NAN),
        depth: f32::NAN,
    };
    Manifold {
        normal: Vec3::NAN,
        points: [point; 4],
        count: 3,
    }
}

/// Every bit of a manifold: the normal, the count, and all four points (the unused ones
/// too, which a fresh manifold has at zero).
fn bits(m: &Option<Manifold>) -> Option<(usize, Vec<u32>)> {
    m.as_ref().map(|m| {
        let mut words = m.normal.to_array().map(f32::to_bits).to_vec();
        for p in &m.points {
            words.extend(p.point.to_array().map(f32::to_bits));
            words.push(p.depth.to_bits());
        }
        (m.count, words)
    })
}

/// What answered the calls of one run (see [`run_pair`]).
#[derive(Default, Debug)]
struct Paths {
    /// Bounding spheres apart.
    spheres_apart: usize,
    /// Apart, with a separating axis remembered from the step before.
    hint_apart: usize,
    /// A remembered face contact kept (its hint and margin unchanged).
    face_served: usize,
    /// A remembered edge contact kept.
    edge_served: usize,
    /// Touching, by any other path (the full test).
    other: usize,
}

/// One pair stepped `steps` times: A turns slowly about its centre at the origin, B turns
/// at `spin` rad a step and its centre moves in and out along a line (from deep overlap
/// to a gap beyond the bounding spheres) while sliding across it.
fn run_pair(a: &Shape, b: &Shape, rng: &mut Rng, spin: f32, steps: usize, paths: &mut Paths) {
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let dir = rng.unit();
    let across = rng.unit().cross(dir).normalize_or_zero();
    let (mut qa, mut qb) = (rng.rotation(), rng.rotation());
    let (wa, wb) = (rng.unit(), rng.unit());
    let mut memory = EdgeMemory::default();
    let (mut hint, mut bound) = (NO_HINT, 0.0f32);
    for k in 0..steps {
        let phase = -1.2 + k as f32 * 1e-3;
        let gap = (0.6 + 0.42 * phase.sin()) * (ra + rb);
        let pa = Pose::new(Vec3::ZERO, qa);
        let pb = Pose::new(dir * gap + across * (0.2 * (ra + rb) * phase.cos()), qb);
        let (hint_before, bound_before) = (hint, bound);
        let mut found = Some(stale());
        narrow::collide_with_memory_into(
            a,
            &pa,
            b,
            &pb,
            &mut hint,
            &mut bound,
            &mut memory,
            &mut found,
        );
        let full = narrow::collide(a, &pa, b, &pb);
        assert_eq!(
            bits(&found),
            bits(&full),
            "step {k}: not the full test's manifold"
        );
        let kept = hint == hint_before && bound.to_bits() == bound_before.to_bits();
        if pb.position.length() >= ra + rb {
            paths.spheres_apart += 1;
        } else if found.is_none() && hint_before != NO_HINT && !narrow::is_contact_hint(hint_before)
        {
            paths.hint_apart += 1;
        } else if kept && hint == HINT_EDGE_CONTACT {
            paths.edge_served += 1;
        } else if kept && narrow::is_contact_hint(hint) {
            paths.face_served += 1;
        } else {
            paths.other += 1;
        }
        qa = (Quat::from_axis_angle(wa, 0.1 * spin) * qa).normalize();
        qb = (Quat::from_axis_angle(wb, spin) * qb).normalize();
    }
}

#[test]
fn into_writes_the_full_tests_manifold_over_a_stale_one() {
    let shapes = common::solids_and_hull(12);
    let mut rng = Rng(0x005e_ed38);
    let mut paths = Paths::default();
    for sa in &shapes {
        for sb in &shapes {
            for spin in [0.0, 2e-5, 3e-4] {
                run_pair(&sa.shape, &sb.shape, &mut rng, spin, 3200, &mut paths);
            }
        }
    }
    // Every path answered: the test would not see a path that kept the stale manifold.
    let Paths {
        spheres_apart,
        hint_apart,
        face_served,
        edge_served,
        other,
    } = paths;
    assert!(spheres_apart > 1000, "{paths:?}");
    assert!(hint_apart > 1000, "{paths:?}");
    assert!(face_served > 1000, "{paths:?}");
    assert!(edge_served > 1000, "{paths:?}");
    assert!(other > 1000, "{paths:?}");
}

/// A sphere against a polyhedron with a memory, and a pair with no polyhedron, through the
/// same entry: the stale manifold replaced by the answer without memory.
#[test]
fn into_replaces_a_stale_manifold_for_spheres_too() {
    let shapes = common::solids_and_hull(12);
    let mut rng = Rng(0x005e_ed39);
    let ball = Shape::Sphere { radius: 0.6 };
    let (mut touching, mut apart) = (0, 0);
    for s in &shapes {
        for (a, b) in [(&ball, &s.shape), (&s.shape, &ball), (&ball, &ball)] {
            let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
            let mut memory = EdgeMemory::default();
            let (mut hint, mut bound) = (NO_HINT, 0.0f32);
            for k in 0..400 {
                let gap = (0.8 + 0.3 * (k as f32 * 0.02).sin()) * (ra + rb);
                let pa = Pose::new(Vec3::ZERO, rng.rotation());
                let pb = Pose::new(rng.unit() * gap, rng.rotation());
                let mut found = Some(stale());
                narrow::collide_with_memory_into(
                    a,
                    &pa,
                    b,
                    &pb,
                    &mut hint,
                    &mut bound,
                    &mut memory,
                    &mut found,
                );
                let full = narrow::collide(a, &pa, b, &pb);
                assert_eq!(bits(&found), bits(&full), "step {k}");
                touching += found.is_some() as usize;
                apart += found.is_none() as usize;
            }
        }
    }
    assert!(touching > 1000 && apart > 1000, "{touching} {apart}");
}

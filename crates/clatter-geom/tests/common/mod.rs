//! Helpers shared by the memory tests (`edge_memory.rs`, `face_memory.rs`,
//! `full_memory.rs`, `sphere_memory.rs`).

use clatter_geom::narrow::{self, EdgeMemory, Manifold, SatHint};
use clatter_geom::{Pose, PreparedShape, RegularKind, Shape, ShapeKind};
use glam::{Quat, Vec3};

/// A small deterministic generator (xorshift), so the tests need no dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            let l = v.length();
            if l > 0.1 && l < 1.0 {
                return v / l;
            }
        }
    }
    pub fn rotation(&mut self) -> Quat {
        Quat::from_axis_angle(self.unit(), self.next() * std::f32::consts::TAU)
    }
}

/// The five Platonic solids (bounding radius 1) and a hull of `hull_points` scattered points,
/// flattened in z, as a mesh hull would be.
pub fn solids_and_hull(hull_points: usize) -> Vec<PreparedShape> {
    let mut kinds: Vec<ShapeKind> = [
        RegularKind::Tetrahedron,
        RegularKind::Cube,
        RegularKind::Octahedron,
        RegularKind::Dodecahedron,
        RegularKind::Icosahedron,
    ]
    .into_iter()
    .map(|kind| ShapeKind::Regular { kind, radius: 1.0 })
    .collect();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let points = (0..hull_points)
        .map(|_| {
            let v = rng.unit() * (0.8 + 0.2 * rng.next());
            [v.x as f64, v.y as f64, 0.7 * v.z as f64]
        })
        .collect();
    kinds.push(ShapeKind::Convex { points });
    kinds
        .iter()
        .map(|k| k.prepare().expect("valid shape"))
        .collect()
}

/// The narrow phase of a pair at the same poses with its memory (`with`: its hint and
/// bound) and without it (`without`: the test's own hint and bound): the manifold, after
/// checking that both give the same manifold, and the same hint and bound, bitwise, unless
/// one remembers a contact (whose margins differ by design: see below; the panic names
/// step `k`). The caller takes its per-step motion bound off `without`'s margin of a
/// remembered contact only; `with`'s is anchored on its full test's pose.
#[allow(dead_code, clippy::too_many_arguments)]
pub fn with_and_without_memory(
    a: &Shape,
    pa: &Pose,
    b: &Shape,
    pb: &Pose,
    memory: &mut EdgeMemory,
    (hint_m, bound_m): (&mut SatHint, &mut f32),
    (hint, bound): (&mut SatHint, &mut f32),
    k: usize,
) -> Option<Manifold> {
    let with = narrow::collide_with_memory(a, pa, b, pb, hint_m, bound_m, memory);
    let without = narrow::collide_with_hint(a, pa, b, pb, hint, bound);
    assert_eq!(with, without, "step {k}: manifolds differ");
    if narrow::is_contact_hint(*hint_m) || narrow::is_contact_hint(*hint) {
        // A remembered contact's margin: with the memory, the full test's, anchored on its
        // pose (the caller takes nothing off); without, what the caller's per-step bounds
        // left of it. The two may run the full test at different steps (and one of them
        // may then find the decisions too close to remember), never for another manifold.
        for h in [*hint_m, *hint] {
            assert!(
                narrow::is_contact_hint(h) || h == narrow::NO_HINT,
                "step {k}: hint {h:x} of a touching pair"
            );
        }
        return with;
    }
    assert_eq!(*hint_m, *hint, "step {k}: hints differ");
    assert_eq!(
        bound_m.to_bits(),
        bound.to_bits(),
        "step {k}: bounds differ"
    );
    with
}

//! Shapes and random sequences the narrow phase's unit tests share.

use glam::Vec3;

use crate::ConvexPolyhedron;

/// The box with half-extents `h`, centred at the origin, as a hull of its eight corners.
pub(super) fn cuboid(h: Vec3) -> ConvexPolyhedron {
    let v: Vec<Vec3> = (0..8)
        .map(|k| {
            let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
            Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
        })
        .collect();
    crate::convex_hull(&v).expect("box hull")
}

/// A xorshift64 sequence from `seed` (not 0): cheap, reproducible test inputs (`Copy`: a
/// copy goes on from the same state on its own).
pub(super) fn xorshift(mut seed: u64) -> impl FnMut() -> u64 + Copy {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    }
}

/// [`xorshift`]'s words as floats in `[-0.5, 0.5)` (their top 24 bits).
pub(super) fn xorshift_centred(seed: u64) -> impl FnMut() -> f32 + Copy {
    let mut next = xorshift(seed);
    move || (next() >> 40) as f32 / (1u64 << 24) as f32 - 0.5
}

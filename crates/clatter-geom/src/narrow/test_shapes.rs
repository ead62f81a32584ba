//! Shapes the narrow phase's unit tests share.

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

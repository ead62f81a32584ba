//! Helpers shared by the memory tests (`edge_memory.rs`, `sphere_memory.rs`).

use clatter_geom::{PreparedShape, RegularKind, ShapeKind};
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

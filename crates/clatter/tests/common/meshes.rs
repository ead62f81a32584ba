//! What the CPU and GPU mesh-boundary tests share (included by `#[path]`): their floor mesh,
//! its OBJ text, and the material and shapes of their bodies.

use clatter::geom::{PreparedShape, ShapeKind};
use clatter::{ContactLaw, Material};

/// The bodies' sphere radius, m.
#[allow(dead_code)]
pub const R: f32 = 0.01;
/// The bodies' density, kg/m^3.
#[allow(dead_code)]
pub const DENSITY: f32 = 2500.0;
/// The linear contact stiffness, N/m.
#[allow(dead_code)]
pub const K: f32 = 2.0e4;

/// The one material of the tests (linear law), with the given friction and restitution.
#[allow(dead_code)]
pub fn material(friction: f32, restitution: f32) -> Material {
    Material::new(
        "m",
        DENSITY,
        ContactLaw::Linear { stiffness: K },
        restitution,
        friction,
    )
}

/// A sphere of radius [`R`].
#[allow(dead_code)]
pub fn sphere() -> PreparedShape {
    ShapeKind::Sphere { radius: R as f64 }.prepare().unwrap()
}

/// A cube of half-edge `half`.
#[allow(dead_code)]
pub fn cube(half: f64) -> PreparedShape {
    ShapeKind::Box {
        half_extents: [half; 3],
    }
    .prepare()
    .unwrap()
}

/// A flat square floor `z = 0` over `[-h, h]^2` of `n x n` squares, two triangles each,
/// alternating the diagonal (so edges run along x, y and both diagonals), wound so that the
/// normals point up (+z).
#[allow(dead_code)]
pub fn floor_mesh(n: usize, h: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            v.push([
                -h + 2.0 * h * i as f64 / n as f64,
                -h + 2.0 * h * j as f64 / n as f64,
                0.0,
            ]);
        }
    }
    let mut t = Vec::new();
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                t.push([a, b, c]);
                t.push([a, c, d]);
            } else {
                t.push([a, b, d]);
                t.push([b, c, d]);
            }
        }
    }
    (v, t)
}

/// A mesh as the text of an OBJ file (`v x y z` lines, then 1-based `f a b c` lines).
#[allow(dead_code)]
pub fn obj_text(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> String {
    let mut s = String::new();
    for [x, y, z] in vertices {
        s.push_str(&format!("v {x} {y} {z}\n"));
    }
    for [a, b, c] in triangles {
        s.push_str(&format!("f {} {} {}\n", a + 1, b + 1, c + 1));
    }
    s
}

//! Polyhedra against a plane (`narrow::collide_plane`): the manifold against a brute-force
//! list of the vertices below the plane, reduced by the same `narrow::patch`, for prisms with
//! 3 to 80 vertices on the face pressed into the plane (so fewer and more than the
//! collision's allocation-free room for patch points) and for tilted poses.

use clatter_geom::narrow::{self, Plane};
use clatter_geom::{Pose, Shape, ShapeKind};
use glam::{Quat, Vec3};

/// A prism of `sides` sides: two regular polygons of radius 1 cm, 1 cm apart.
fn prism(sides: usize) -> (Shape, Vec3) {
    let mut points = Vec::new();
    for k in 0..sides {
        let a = std::f64::consts::TAU * k as f64 / sides as f64;
        for z in [-0.005, 0.005] {
            points.push([0.01 * a.cos(), 0.01 * a.sin(), z]);
        }
    }
    let prep = ShapeKind::Convex { points }.prepare().expect("valid prism");
    (prep.shape, prep.com)
}

/// Brute force: every vertex below the plane, at the middle of its overlap, in vertex order.
fn below(plane: &Plane, shape: &Shape, pose: &Pose) -> Vec<(Vec3, f32)> {
    let Shape::Polyhedron(p) = shape else {
        panic!("a polyhedron")
    };
    let n = plane.normal;
    let centre_height = n.dot(pose.position) - plane.offset;
    let n_local = pose.rotation.conjugate() * n;
    p.vertices
        .iter()
        .filter_map(|&v| {
            let h = n_local.dot(v) + centre_height;
            (h < 0.0).then(|| (pose.transform_point(v) - n * (0.5 * h), -h))
        })
        .collect()
}

#[test]
fn plane_patches_of_many_vertices_are_the_brute_force_patch() {
    let plane = Plane {
        normal: Vec3::Z,
        offset: 0.0,
    };
    let mut counts = Vec::new();
    for sides in [3, 4, 7, 8, 9, 16, 17, 31, 32, 33, 40] {
        let (shape, com) = prism(sides);
        for (k, tilt) in [0.0f32, 1e-3, 0.02, 0.3].into_iter().enumerate() {
            let rotation =
                Quat::from_axis_angle(Vec3::new(1.0, 0.3 * k as f32, 0.0).normalize(), tilt);
            // The lower face 0.1 mm into the plane at its centre.
            let position = rotation * com + Vec3::new(0.001, -0.002, 0.005 - 1e-4);
            let pose = Pose::new(position, rotation);
            let pts = below(&plane, &shape, &pose);
            let got = narrow::collide_plane(&plane, &shape, &pose);
            if pts.is_empty() {
                assert!(got.is_none(), "{sides} sides, tilt {tilt}");
                continue;
            }
            counts.push(pts.len());
            let want = narrow::patch(&pts, plane.normal);
            let got = got.expect("a contact");
            assert_eq!(got.count, want.count, "{sides} sides, tilt {tilt}");
            for (g, w) in got.points().iter().zip(want.points()) {
                assert_eq!(
                    g.point.to_array().map(f32::to_bits),
                    w.point.to_array().map(f32::to_bits)
                );
                assert_eq!(g.depth.to_bits(), w.depth.to_bits());
            }
            assert_eq!(got.normal, want.normal);
        }
    }
    // Patches of fewer and more than 16 points (the room without an allocation) were made.
    assert!(
        counts.iter().any(|&c| c < 16) && counts.iter().any(|&c| c > 16),
        "{counts:?}"
    );
}

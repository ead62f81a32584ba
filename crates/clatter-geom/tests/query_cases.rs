//! Fixed cases for the collision queries: the box-box cases of libccd's test suite
//! (`src/testsuites/boxbox.c`, `mpr_boxbox.c` and their regression outputs) and analytic
//! configurations (spheres, touching, nested, far apart, head-on and spinning impacts).
//!
//! libccd boxes are given by their full edge lengths; quaternions there are `(x, y, z, w)`.
//! libccd's separation direction is the direction in which to move the second box, which is
//! our normal from `a` to `b`.

use std::f32::consts::PI;

use clatter_geom::query::{self, Motion};
use clatter_geom::{Pose, PreparedShape, RegularKind, Shape, ShapeKind};
use glam::{Quat, Vec3};

/// A prepared shape with a helper to pose it in the frame it was authored in.
struct Body {
    prep: PreparedShape,
}

impl Body {
    fn new(kind: ShapeKind) -> Self {
        Body {
            prep: kind.prepare().expect("valid shape"),
        }
    }
    fn boxed(edges: [f64; 3]) -> Self {
        Body::new(ShapeKind::Box {
            half_extents: [edges[0] / 2.0, edges[1] / 2.0, edges[2] / 2.0],
        })
    }
    fn sphere(r: f64) -> Self {
        Body::new(ShapeKind::Sphere { radius: r })
    }
    fn shape(&self) -> &Shape {
        &self.prep.shape
    }
    /// Pose of the principal frame for an authored-frame position and orientation.
    fn at(&self, position: Vec3, orientation: Quat) -> Pose {
        Pose::new(
            position + orientation * self.prep.com,
            orientation * self.prep.frame,
        )
    }
}

fn aa(angle: f32, axis: Vec3) -> Quat {
    Quat::from_axis_angle(axis.normalize(), angle)
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

fn vclose(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).length() <= tol
}

#[track_caller]
fn check_pen(a: &Body, pa: Pose, b: &Body, pb: Pose, depth: f32, dir: Vec3) -> query::Contact {
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(
        close(c.depth, depth, 1e-5),
        "depth {} expected {depth} (normal {:?})",
        c.depth,
        c.normal
    );
    assert!(
        vclose(c.normal, dir, 1e-4),
        "normal {:?} expected {dir:?}",
        c.normal
    );
    // Moving b along the normal by the depth leaves the shapes touching, not overlapping.
    let moved = Pose::new(pb.position + c.normal * (c.depth + 1e-4), pb.rotation);
    assert!(!query::intersects(a.shape(), &pa, b.shape(), &moved));
    let moved = Pose::new(pb.position + c.normal * (c.depth - 1e-3), pb.rotation);
    assert!(query::intersects(a.shape(), &pa, b.shape(), &moved));
    // Witness points: b's deepest point is depth behind a's along the normal.
    let gap = (c.points[1] - c.points[0]).dot(c.normal);
    assert!(
        close(gap, -c.depth, 1e-4),
        "witness gap {gap} vs depth {}",
        c.depth
    );
    assert!(!c.manifold.is_empty());
    c
}

/// libccd `boxboxPenetration` / `mprBoxboxPenetration`, "Pen 1": unit cube at the origin and
/// a 0.5 x 1 x 1.5 box at (0.1, 0, 0): depth 0.65 along +x (regression TSMPRBoxBox.out).
#[test]
fn libccd_pen1() {
    let a = Body::boxed([1.0, 1.0, 1.0]);
    let b = Body::boxed([0.5, 1.0, 1.5]);
    let c = check_pen(
        &a,
        a.at(Vec3::ZERO, Quat::IDENTITY),
        &b,
        b.at(Vec3::new(0.1, 0.0, 0.0), Quat::IDENTITY),
        0.65,
        Vec3::X,
    );
    // The witness points lie on both boxes (in the overlap of the contact faces).
    let inside = |p: Vec3, h: Vec3, c: Vec3| ((p - c).abs() - h).max_element() <= 1e-5;
    assert!(inside(c.points[0], Vec3::splat(0.5), Vec3::ZERO), "{c:?}");
    assert!(
        inside(
            c.points[1],
            Vec3::new(0.25, 0.5, 0.75),
            Vec3::new(0.1, 0.0, 0.0)
        ),
        "{c:?}"
    );
    // Face-face contact: the manifold is the 0.5 x 1 rectangle overlap, four corners.
    assert_eq!(c.manifold.len(), 4);
    for p in c.manifold.points() {
        assert!(p.y.abs() <= 0.5 + 1e-5 && p.z.abs() <= 0.5 + 1e-5, "{p:?}");
    }
}

/// "Pen 2": cube moved to (-0.3, 0.5, 1): depth 0.25 along -z (TSBoxBox.out).
#[test]
fn libccd_pen2() {
    let a = Body::boxed([1.0, 1.0, 1.0]);
    let b = Body::boxed([0.5, 1.0, 1.5]);
    check_pen(
        &a,
        a.at(Vec3::new(-0.3, 0.5, 1.0), Quat::IDENTITY),
        &b,
        b.at(Vec3::new(0.1, 0.0, 0.0), Quat::IDENTITY),
        0.25,
        Vec3::NEG_Z,
    );
}

/// "Pen 3" configuration of boxbox.c (cube rotated 45 degrees about z at (0.1, 0, 0.1) against
/// a unit cube at (0.1, 0, 0)). The regression file's 1.0 was produced with a different
/// z offset; the exact answer for this configuration is 0.9 along -z (separating-axis check).
#[test]
fn libccd_pen3() {
    let a = Body::boxed([1.0, 1.0, 1.0]);
    let b = Body::boxed([1.0, 1.0, 1.0]);
    check_pen(
        &a,
        a.at(Vec3::new(0.1, 0.0, 0.1), aa(PI / 4.0, Vec3::Z)),
        &b,
        b.at(Vec3::new(0.1, 0.0, 0.0), Quat::IDENTITY),
        0.9,
        Vec3::NEG_Z,
    );
}

/// "Pen 4" to "Pen 8" of TSBoxBox.out (the second box a unit cube at the origin).
#[test]
fn libccd_pen4_to_8() {
    let a = Body::boxed([1.0, 1.0, 1.0]);
    let b = Body::boxed([1.0, 1.0, 1.0]);
    let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
    let qz = aa(PI / 4.0, Vec3::Z);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    // Pen 4.
    // Published as 0.707107, i.e. 1/sqrt(2).
    check_pen(&a, a.at(Vec3::new(-0.5, 0.0, 0.0), qz), &b, pb, s, Vec3::X);
    // Pen 5: edge against face along the diagonal.
    check_pen(
        &a,
        a.at(Vec3::new(-0.5, 0.5, 0.0), qz),
        &b,
        pb,
        0.5,
        Vec3::new(s, -s, 0.0),
    );
    // Pen 6: edge-edge normal.
    let q6 = aa(PI / 4.0, Vec3::new(0.0, 1.0, 1.0));
    check_pen(
        &a,
        a.at(Vec3::new(-0.5, 0.1, 0.4), q6),
        &b,
        pb,
        0.734698,
        Vec3::new(0.862856, 0.0, -0.505449),
    );
    // Pen 7.
    let q7 = q6 * aa(PI / 4.0, Vec3::ONE);
    check_pen(
        &a,
        a.at(Vec3::new(-0.5, 0.1, 0.4), q7),
        &b,
        pb,
        0.722622,
        Vec3::X,
    );
    // Pen 8: a corner just poking in.
    let q8 = qz * aa(PI / 4.0, Vec3::X);
    check_pen(
        &a,
        a.at(Vec3::new(-1.3, 0.0, 0.0), q8),
        &b,
        pb,
        0.053553,
        Vec3::X,
    );
}

/// `boxboxPenetration2`: a small box resting 0.025 deep on a 20 x 0.1 x 20 slab; the contact
/// position must stay above the small box (|x| < 0.2).
#[test]
fn libccd_large_box() {
    let a = Body::boxed([20.0, 0.1, 20.0]);
    let b = Body::boxed([0.2, 0.15, 0.2]);
    let c = check_pen(
        &a,
        a.at(Vec3::ZERO, Quat::IDENTITY),
        &b,
        b.at(Vec3::new(0.0, 0.1, 0.0), Quat::IDENTITY),
        0.025,
        Vec3::Y,
    );
    for p in c.manifold.points().iter().chain(c.points.iter()) {
        assert!(p.x.abs() < 0.2 && p.z.abs() < 0.2, "{p:?}");
    }
    assert_eq!(c.manifold.len(), 4);
}

/// `boxboxSeparate`: the separation vectors (depth x normal).
#[test]
fn libccd_separate() {
    let a = Body::boxed([1.0, 1.0, 1.0]);
    let b = Body::boxed([0.5, 1.0, 1.5]);
    let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
    let pa = a.at(Vec3::new(-0.5, 0.5, 0.2), Quat::IDENTITY);
    assert!(query::intersects(a.shape(), &pa, b.shape(), &pb));
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(
        vclose(c.normal * c.depth, Vec3::new(0.25, 0.0, 0.0), 1e-5),
        "{c:?}"
    );
    // Moving a back by the separation vector leaves the boxes touching: depth 0.
    let pa = a.at(Vec3::new(-0.75, 0.5, 0.2), Quat::IDENTITY);
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(close(c.depth, 0.0, 1e-6), "{c:?}");
    assert!(query::intersects(a.shape(), &pa, b.shape(), &pb));
    assert_eq!(
        query::distance(a.shape(), &pa, b.shape(), &pb).distance,
        0.0
    );
    let pa = a.at(Vec3::new(-0.3, 0.5, 1.0), Quat::IDENTITY);
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(
        vclose(c.normal * c.depth, Vec3::new(0.0, 0.0, -0.25), 1e-5),
        "{c:?}"
    );
    // Two unit cubes, one turned 45 degrees about z, same centre: separate along +-z by 1.
    let b = Body::boxed([1.0, 1.0, 1.0]);
    let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
    let pa = a.at(Vec3::ZERO, aa(PI / 4.0, Vec3::Z));
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(
        close(c.depth, 1.0, 1e-5) && close(c.normal.z.abs(), 1.0, 1e-5),
        "{c:?}"
    );
}

/// `boxboxAlignedX/Y/Z` and `mprBoxboxAligned*`: sliding a 1 x 2 x 1 box through a 2 x 1 x 2
/// box; intersecting strictly between steps 35 and 65, apart before and after (the touching
/// steps 35 and 65 are not asserted, as in libccd).
#[test]
fn libccd_aligned_sweeps() {
    for axis in 0..3 {
        for (scale, step) in [(1.0f32, 0.1f32), (0.1, 0.01)] {
            for offset in [0.0f32, -0.1] {
                if offset != 0.0 && (axis != 0 || scale != 1.0) {
                    continue;
                }
                let a = Body::boxed([1.0 * scale as f64, 2.0 * scale as f64, 1.0 * scale as f64]);
                let b = Body::boxed([2.0 * scale as f64, 1.0 * scale as f64, 2.0 * scale as f64]);
                let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
                for i in 0..100 {
                    let mut p = Vec3::ZERO;
                    p[axis] = -5.0 * scale + step * i as f32;
                    if axis == 0 {
                        p.y = offset;
                    }
                    let pa = a.at(p, Quat::IDENTITY);
                    let hit = query::intersects(a.shape(), &pa, b.shape(), &pb);
                    if !(35..=65).contains(&i) {
                        assert!(!hit, "axis {axis} scale {scale} step {i}");
                    } else if i != 35 && i != 65 {
                        assert!(hit, "axis {axis} scale {scale} step {i}");
                    }
                    // The contact query agrees with the intersection test away from touching.
                    if i != 35 && i != 65 {
                        let c = query::contact(a.shape(), &pa, b.shape(), &pb);
                        assert_eq!(c.depth > 0.0, hit, "axis {axis} step {i}: {c:?}");
                    }
                }
            }
        }
    }
}

/// `boxboxRot`: a rotated box sliding through, and a cube spinning next to another.
#[test]
fn libccd_rot_sweeps() {
    let a = Body::boxed([1.0, 2.0, 1.0]);
    let b = Body::boxed([2.0, 1.0, 2.0]);
    let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
    let q = aa(PI / 4.0, Vec3::Y);
    for i in 0..100 {
        let pa = a.at(Vec3::new(-5.0 + 0.1 * i as f32, 0.5, 0.0), q);
        let hit = query::intersects(a.shape(), &pa, b.shape(), &pb);
        if !(33..=67).contains(&i) {
            assert!(!hit, "step {i}");
        } else if i != 33 && i != 67 {
            assert!(hit, "step {i}");
        }
    }
    let a = Body::boxed([1.0, 1.0, 1.0]);
    let b = Body::boxed([1.0, 1.0, 1.0]);
    let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
    for i in 0..30 {
        let pa = a.at(
            Vec3::new(-1.01, 0.0, 0.0),
            aa(i as f32 * PI / 20.0, Vec3::Y),
        );
        let hit = query::intersects(a.shape(), &pa, b.shape(), &pb);
        assert_eq!(hit, !(i == 0 || i == 10 || i == 20), "step {i}");
        if !hit {
            let d = query::distance(a.shape(), &pa, b.shape(), &pb);
            assert!(close(d.distance, 0.01, 1e-5), "step {i}: {d:?}");
        }
    }
}

#[test]
fn spheres_distance_touching_nested_far() {
    let a = Body::sphere(1.0);
    let b = Body::sphere(0.5);
    let pa = a.at(Vec3::ZERO, Quat::IDENTITY);
    // Apart by 1.5 along a diagonal.
    let dir = Vec3::new(1.0, 2.0, -2.0) / 3.0;
    let pb = b.at(dir * 3.0, Quat::IDENTITY);
    let d = query::distance(a.shape(), &pa, b.shape(), &pb);
    assert!(close(d.distance, 1.5, 1e-6));
    assert!(vclose(d.points[0], dir, 1e-6) && vclose(d.points[1], dir * 2.5, 1e-6));
    assert!(vclose(d.normal, dir, 1e-6));
    assert!(!query::intersects(a.shape(), &pa, b.shape(), &pb));
    // Touching.
    let pb = b.at(dir * 1.5, Quat::IDENTITY);
    assert!(query::intersects(a.shape(), &pa, b.shape(), &pb));
    assert!(
        query::distance(a.shape(), &pa, b.shape(), &pb)
            .distance
            .abs()
            < 1e-6
    );
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(c.depth.abs() < 1e-6 && vclose(c.normal, dir, 1e-6));
    // Nested: b entirely inside a.
    let pb = b.at(dir * 0.2, Quat::IDENTITY);
    assert!(query::intersects(a.shape(), &pa, b.shape(), &pb));
    let d = query::distance(a.shape(), &pa, b.shape(), &pb);
    assert_eq!(d.distance, 0.0);
    assert!(d.points[0].length() <= 1.0 && (d.points[0] - dir * 0.2).length() <= 0.5);
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(close(c.depth, 1.3, 1e-6) && vclose(c.normal, dir, 1e-6));
    // Concentric: any normal, depth = sum of radii, no NaN.
    let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(
        close(c.depth, 1.5, 1e-6) && c.normal.is_finite() && close(c.normal.length(), 1.0, 1e-6)
    );
    // Far apart.
    let pb = b.at(Vec3::new(1e5, 0.0, 0.0), Quat::IDENTITY);
    let d = query::distance(a.shape(), &pa, b.shape(), &pb);
    assert!(close(d.distance, 1e5 - 1.5, 1e-2));
}

#[test]
fn sphere_box_cases() {
    let s = Body::sphere(0.5);
    let b = Body::boxed([2.0, 2.0, 2.0]);
    let pb = b.at(Vec3::ZERO, Quat::IDENTITY);
    // Facing a face, apart by 0.5.
    let ps = s.at(Vec3::new(0.0, 2.0, 0.0), Quat::IDENTITY);
    let d = query::distance(s.shape(), &ps, b.shape(), &pb);
    assert!(
        close(d.distance, 0.5, 1e-6) && vclose(d.normal, Vec3::NEG_Y, 1e-6),
        "{d:?}"
    );
    assert!(vclose(d.points[0], Vec3::new(0.0, 1.5, 0.0), 1e-6));
    assert!(vclose(d.points[1], Vec3::new(0.0, 1.0, 0.0), 1e-6));
    // Facing a corner.
    let ps = s.at(Vec3::splat(2.0), Quat::IDENTITY);
    let d = query::distance(b.shape(), &pb, s.shape(), &ps);
    assert!(close(d.distance, 3f32.sqrt() - 0.5, 1e-6), "{d:?}");
    assert!(vclose(d.points[0], Vec3::ONE, 1e-6));
    // Centre inside the box: depth = radius + distance to the nearest face.
    let ps = s.at(Vec3::new(0.1, 0.7, -0.2), Quat::IDENTITY);
    let c = query::contact(b.shape(), &pb, s.shape(), &ps);
    assert!(
        close(c.depth, 0.5 + 0.3, 1e-6) && vclose(c.normal, Vec3::Y, 1e-6),
        "{c:?}"
    );
    assert!(query::intersects(s.shape(), &ps, b.shape(), &pb));
    // Straddling a face.
    let ps = s.at(Vec3::new(1.2, 0.0, 0.0), Quat::IDENTITY);
    let c = query::contact(s.shape(), &ps, b.shape(), &pb);
    assert!(
        close(c.depth, 0.3, 1e-6) && vclose(c.normal, Vec3::NEG_X, 1e-6),
        "{c:?}"
    );
}

#[test]
fn polyhedra_touching_coplanar_nested_far() {
    let a = Body::new(ShapeKind::Regular {
        kind: RegularKind::Icosahedron,
        radius: 1.0,
    });
    let b = Body::boxed([0.2, 0.2, 0.2]);
    let pa = a.at(Vec3::ZERO, Quat::IDENTITY);
    // Nested: a small box deep inside the icosahedron.
    let pb = b.at(Vec3::new(0.05, 0.0, 0.0), aa(0.3, Vec3::ONE));
    assert!(query::intersects(a.shape(), &pa, b.shape(), &pb));
    assert_eq!(
        query::distance(a.shape(), &pa, b.shape(), &pb).distance,
        0.0
    );
    let c = query::contact(a.shape(), &pa, b.shape(), &pb);
    assert!(c.depth > 0.5 && c.depth.is_finite() && c.normal.is_finite());
    // Far apart.
    let pb = b.at(Vec3::new(0.0, 0.0, 1e4), Quat::IDENTITY);
    let d = query::distance(a.shape(), &pa, b.shape(), &pb);
    assert!(d.distance > 9990.0 && d.distance < 1e4 && d.normal.is_finite());
    // Face to face, coplanar, exactly touching, then apart by 1e-3.
    let c1 = Body::boxed([1.0, 1.0, 1.0]);
    let p1 = c1.at(Vec3::ZERO, Quat::IDENTITY);
    for gap in [0.0f32, 1e-3] {
        let p2 = c1.at(Vec3::new(0.3, 1.0 + gap, -0.2), Quat::IDENTITY);
        let d = query::distance(c1.shape(), &p1, c1.shape(), &p2);
        assert!(close(d.distance, gap, 1e-6), "{d:?}");
        assert_eq!(
            query::intersects(c1.shape(), &p1, c1.shape(), &p2),
            gap == 0.0
        );
        let c = query::contact(c1.shape(), &p1, c1.shape(), &p2);
        assert!(
            close(c.depth, -gap, 1e-6) && vclose(c.normal, Vec3::Y, 1e-5),
            "{c:?}"
        );
        assert_eq!(c.manifold.len(), 4, "{c:?}");
    }
    // Identical poses (fully coincident shapes).
    let c = query::contact(c1.shape(), &p1, c1.shape(), &p1);
    assert!(close(c.depth, 1.0, 1e-5), "{c:?}");
}

#[test]
fn toi_spheres_head_on() {
    let a = Body::sphere(1.0);
    let b = Body::sphere(0.5);
    let pa = a.at(Vec3::new(-3.0, 0.0, 0.0), Quat::IDENTITY);
    let pb = b.at(Vec3::new(4.0, 0.0, 0.0), Quat::IDENTITY);
    let ma = Motion {
        linear: Vec3::new(2.0, 0.0, 0.0),
        angular: Vec3::new(0.0, 5.0, 0.0),
    };
    let mb = Motion {
        linear: Vec3::new(-1.5, 0.0, 0.0),
        angular: Vec3::ZERO,
    };
    // Gap 7 - 1.5 = 5.5 closed at 3.5 per unit time.
    let t = query::time_of_impact(a.shape(), &pa, &ma, b.shape(), &pb, &mb, 10.0).unwrap();
    assert!(close(t.time, 5.5 / 3.5, 1e-6), "{t:?}");
    let x = -3.0 + 2.0 * 5.5 / 3.5 + 1.0;
    assert!(vclose(t.points[0], Vec3::new(x, 0.0, 0.0), 1e-5) && vclose(t.normal, Vec3::X, 1e-6));
    // Horizon too short, moving apart, and passing by.
    assert!(query::time_of_impact(a.shape(), &pa, &ma, b.shape(), &pb, &mb, 1.5).is_none());
    let away = Motion {
        linear: Vec3::new(-2.0, 0.0, 0.0),
        angular: Vec3::ZERO,
    };
    assert!(query::time_of_impact(a.shape(), &pa, &away, b.shape(), &pb, &mb, 100.0).is_none());
    let pb2 = b.at(Vec3::new(4.0, 1.6, 0.0), Quat::IDENTITY);
    assert!(query::time_of_impact(a.shape(), &pa, &ma, b.shape(), &pb2, &mb, 100.0).is_none());
    // The same head-on impact with a cube standing in for the first sphere's core: the
    // conservative-advancement path, face-on: gap 7 - 0.5 - 0.5 = 6 at 3.5 per unit time.
    let c = Body::boxed([1.0, 1.0, 1.0]);
    let pc = c.at(Vec3::new(-3.0, 0.0, 0.0), Quat::IDENTITY);
    let still = Motion {
        linear: Vec3::new(2.0, 0.0, 0.0),
        angular: Vec3::ZERO,
    };
    let t = query::time_of_impact(c.shape(), &pc, &still, b.shape(), &pb, &mb, 10.0).unwrap();
    let tol = query::TOI_REL_TOL as f32 * (c.shape().bounding_radius() + 0.5);
    assert!(
        t.time <= 6.0 / 3.5 + 1e-6 && t.time >= 6.0 / 3.5 - tol / 3.5 - 1e-6,
        "{t:?}"
    );
    assert!(t.converged && vclose(t.normal, Vec3::X, 1e-5));
}

/// A box spinning about z in place next to a wall: a corner sweeps out to the half diagonal.
/// Box half extents (1, 0.2, 0.2) at the origin, spinning at 1 rad/s about z; a wall (a large
/// box) whose face is the plane y = 0.6. The corner (1, 0.2) is at radius r = sqrt(1.04) and
/// angle phi = atan(0.2); it reaches y = 0.6 when r sin(phi + t) = 0.6.
#[test]
fn toi_spinning_box() {
    let a = Body::boxed([2.0, 0.4, 0.4]);
    let wall = Body::boxed([10.0, 1.0, 10.0]);
    let pa = a.at(Vec3::ZERO, Quat::IDENTITY);
    let pw = wall.at(Vec3::new(0.0, 1.1, 0.0), Quat::IDENTITY);
    let ma = Motion {
        linear: Vec3::ZERO,
        angular: Vec3::new(0.0, 0.0, 1.0),
    };
    let mw = Motion::default();
    let r = 1.04f64.sqrt();
    let phi = 0.2f64.atan();
    let exact = ((0.6 / r).asin() - phi) as f32;
    let t = query::time_of_impact(a.shape(), &pa, &ma, wall.shape(), &pw, &mw, 2.0).unwrap();
    assert!(t.converged, "{t:?}");
    // Conservative and within the distance tolerance: the corner approaches the wall at
    // r cos(phi + t) ~ 0.8 per unit time at impact.
    let tol =
        query::TOI_REL_TOL as f32 * (a.shape().bounding_radius() + wall.shape().bounding_radius());
    assert!(t.time <= exact + 1e-6, "{} vs {exact}", t.time);
    assert!(t.time >= exact - tol / 0.8 - 1e-5, "{} vs {exact}", t.time);
    assert!(vclose(t.normal, Vec3::Y, 1e-3), "{t:?}");
    assert!(close(t.points[1].y, 0.6, 1e-5), "{t:?}");
    // Spinning the other way the first impact is the opposite corner's, by symmetry the same
    // time; spinning too slowly for the horizon gives none.
    let mb = Motion {
        linear: Vec3::ZERO,
        angular: Vec3::new(0.0, 0.0, -1.0),
    };
    let t2 = query::time_of_impact(a.shape(), &pa, &mb, wall.shape(), &pw, &mw, 2.0).unwrap();
    assert!(close(t2.time, t.time, 1e-5), "{t2:?}");
    assert!(
        query::time_of_impact(a.shape(), &pa, &ma, wall.shape(), &pw, &mw, exact * 0.9).is_none()
    );
    // Overlapping at the start: time 0.
    let pw = wall.at(Vec3::new(0.0, 0.6, 0.0), Quat::IDENTITY);
    let t = query::time_of_impact(a.shape(), &pa, &ma, wall.shape(), &pw, &mw, 2.0).unwrap();
    assert_eq!(t.time, 0.0);
    assert!(vclose(t.normal, Vec3::Y, 1e-4), "{t:?}");
}

/// A unit cube spinning fast about z next to a wall it never reaches: its largest reach in x
/// is the half diagonal sqrt(0.5) = 0.70711, the wall's face is at x = 0.71711 (0.01 beyond
/// it), so there is no impact. Conservative advancement creeps by about gap / (omega r) a
/// step (~9,000 steps over the horizon at 100 rad/s); it must end with `None`, and a
/// search stopped by its cap must say `converged = false`, never report a time as an impact.
#[test]
fn toi_fast_spin_grazing_a_wall_finds_no_impact() {
    let a = Body::boxed([1.0, 1.0, 1.0]);
    let wall = Body::boxed([1.0, 2.0, 2.0]);
    let pa = a.at(Vec3::ZERO, Quat::IDENTITY);
    let face = 0.5f64.sqrt() + 0.01;
    let pw = wall.at(Vec3::new((face + 0.5) as f32, 0.0, 0.0), Quat::IDENTITY);
    let mw = Motion::default();
    for spin in [100.0f32, 1000.0] {
        let ma = Motion {
            linear: Vec3::ZERO,
            angular: Vec3::new(0.0, 0.0, spin),
        };
        let t = query::time_of_impact(a.shape(), &pa, &ma, wall.shape(), &pw, &mw, 1.0);
        if let Some(t) = t {
            assert!(
                !t.converged,
                "spin {spin}: an impact reported where none is: {t:?}"
            );
        }
        if spin == 100.0 {
            assert!(t.is_none(), "spin {spin}: {t:?}");
        }
    }
    // The same wall 0.01 nearer than the half diagonal is hit: the corner (0.5, -0.5), at
    // radius sqrt(0.5) and angle -45 deg, turns towards +x and reaches the face x = 0.69711
    // when sqrt(0.5) cos(w t - pi/4) = 0.69711, at w = 100 rad/s.
    let face = 0.5f64.sqrt() - 0.01;
    let pw = wall.at(Vec3::new((face + 0.5) as f32, 0.0, 0.0), Quat::IDENTITY);
    let ma = Motion {
        linear: Vec3::ZERO,
        angular: Vec3::new(0.0, 0.0, 100.0),
    };
    let exact = ((std::f64::consts::FRAC_PI_4 - (face / 0.5f64.sqrt()).acos()) / 100.0) as f32;
    let t = query::time_of_impact(a.shape(), &pa, &ma, wall.shape(), &pw, &mw, 1.0).unwrap();
    assert!(t.converged, "{t:?}");
    assert!(
        t.time <= exact + 1e-6 && t.time >= exact - 1e-4,
        "{} vs {exact}",
        t.time
    );
}

/// Degenerate inputs never produce NaN: zero-length motion, identical shapes at one pose,
/// huge and tiny scales.
#[test]
fn no_nan_on_degenerate_inputs() {
    let shapes = [
        Body::sphere(0.3),
        Body::boxed([1.0, 1.0, 1.0]),
        Body::new(ShapeKind::Regular {
            kind: RegularKind::Tetrahedron,
            radius: 1.0,
        }),
        Body::new(ShapeKind::Regular {
            kind: RegularKind::Dodecahedron,
            radius: 1e-3,
        }),
        Body::new(ShapeKind::Regular {
            kind: RegularKind::Octahedron,
            radius: 1e3,
        }),
    ];
    let poses = [
        Pose::new(Vec3::ZERO, Quat::IDENTITY),
        Pose::new(Vec3::new(0.5, 0.0, 0.0), Quat::IDENTITY),
        Pose::new(Vec3::new(1e3, 1e3, 0.0), aa(1.0, Vec3::ONE)),
        Pose::new(Vec3::new(2.0, 0.0, 0.0), aa(PI, Vec3::Z)),
    ];
    for a in &shapes {
        for b in &shapes {
            for pa in &poses {
                for pb in &poses {
                    let d = query::distance(a.shape(), pa, b.shape(), pb);
                    assert!(d.distance.is_finite() && d.distance >= 0.0);
                    assert!(
                        d.points[0].is_finite() && d.points[1].is_finite() && d.normal.is_finite()
                    );
                    let c = query::contact(a.shape(), pa, b.shape(), pb);
                    assert!(c.depth.is_finite() && c.normal.is_finite(), "{c:?}");
                    assert!(c.manifold.points().iter().all(|p| p.is_finite()));
                    let _ = query::intersects(a.shape(), pa, b.shape(), pb);
                    let m = Motion::default();
                    if let Some(t) =
                        query::time_of_impact(a.shape(), pa, &m, b.shape(), pb, &m, 1.0)
                    {
                        assert!(t.time == 0.0 && t.normal.is_finite());
                    }
                }
            }
        }
    }
}

//! Convex hulls and mass properties checked against brute force and closed-form formulas.

use clatter_geom::shape::Shape;
use clatter_geom::{
    ConvexPolyhedron, GeomError, MassProperties, RegularKind, ShapeKind, convex_hull,
};
use glam::{DMat3, DQuat, DVec3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Checks `hull` against the input points by brute force. `tol` is an absolute distance.
fn check_hull(points: &[Vec3], hull: &ConvexPolyhedron, tol: f64) {
    let v: Vec<DVec3> = hull.vertices.iter().map(|p| p.as_dvec3()).collect();
    // Every hull vertex is an input point, and is used by a face.
    for p in &hull.vertices {
        assert!(points.contains(p), "hull vertex {p} is not an input point");
    }
    let mut used = vec![0usize; v.len()];
    for f in 0..hull.faces.len() {
        for &i in hull.face_loop(f) {
            used[i as usize] += 1;
        }
    }
    // Extreme vertices only: every vertex is a corner of at least three faces.
    assert!(
        used.iter().all(|&u| u >= 3),
        "vertex on fewer than 3 faces: {used:?}"
    );
    for (f, face) in hull.faces.iter().enumerate() {
        let lp = hull.face_loop(f);
        assert!(lp.len() >= 3);
        assert!(
            (face.normal.length() - 1.0).abs() < 1e-5,
            "normal not unit: {:?} {:?}",
            face,
            lp.iter().map(|&i| v[i as usize]).collect::<Vec<_>>()
        );
        let n = face.normal.as_dvec3();
        let d = face.offset as f64;
        // Planar.
        for &i in lp {
            let dev = (n.dot(v[i as usize]) - d).abs();
            assert!(
                dev <= tol,
                "face {f} not planar: {dev} > {tol}, {} vertices",
                lp.len()
            );
        }
        // Strictly convex, counter-clockwise about the outward normal.
        let k = lp.len();
        for j in 0..k {
            let (a, b, c) = (
                v[lp[j] as usize],
                v[lp[(j + 1) % k] as usize],
                v[lp[(j + 2) % k] as usize],
            );
            assert!(
                (b - a).cross(c - b).dot(n) > 0.0,
                "face {f} not strictly convex at {j}"
            );
        }
        // Every input point is inside or on the face plane.
        for p in points {
            assert!(n.dot(p.as_dvec3()) - d <= tol, "point {p} outside face {f}");
        }
    }
    // Closed 2-manifold of genus 0.
    let mut directed = Vec::new();
    for f in 0..hull.faces.len() {
        let lp = hull.face_loop(f);
        for j in 0..lp.len() {
            directed.push((lp[j], lp[(j + 1) % lp.len()]));
        }
    }
    directed.sort();
    assert!(
        directed.windows(2).all(|w| w[0] != w[1]),
        "repeated directed edge"
    );
    for &(a, b) in &directed {
        assert!(directed.binary_search(&(b, a)).is_ok(), "unpaired edge");
    }
    let (nv, ne, nf) = (
        v.len() as i64,
        hull.edges.len() as i64,
        hull.faces.len() as i64,
    );
    assert_eq!(ne * 2, directed.len() as i64);
    assert_eq!(nv - ne + nf, 2, "Euler characteristic");
    for (e, f) in hull.edge_faces.iter().enumerate() {
        assert_ne!(f[0], f[1], "edge {e} has one face");
    }
    // Positive volume with outward faces.
    let m = MassProperties::of_polyhedron(hull);
    assert!(m.volume > 0.0);
}

/// The hull's documented merging tolerance: 1e-6 of (bounding-box diagonal + largest coordinate).
fn hull_tolerance(points: &[Vec3]) -> f64 {
    let (lo, hi) = points.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &p| {
        (lo.min(p), hi.max(p))
    });
    1e-6 * ((hi - lo).length() + lo.abs().max(hi.abs()).max_element()) as f64
}

fn face_sizes(hull: &ConvexPolyhedron) -> Vec<u32> {
    let mut s: Vec<u32> = hull.faces.iter().map(|f| f.count).collect();
    s.sort();
    s
}

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

fn random_unit(r: &mut ChaCha8Rng) -> DVec3 {
    loop {
        let p = DVec3::new(
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
        );
        let l = p.length();
        if l > 0.1 && l <= 1.0 {
            return p / l;
        }
    }
}

fn random_rotation(r: &mut ChaCha8Rng) -> DQuat {
    DQuat::from_axis_angle(random_unit(r), r.random_range(0.0..std::f64::consts::TAU))
}

/// Shortest distance between two distinct points (brute force): the edge of a Platonic solid.
fn shortest_distance(points: &[Vec3]) -> f64 {
    let mut best = f64::INFINITY;
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            best = best.min(a.as_dvec3().distance(b.as_dvec3()));
        }
    }
    best
}

fn assert_rel(got: f64, want: f64, rel: f64, what: &str) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{what}: got {got}, want {want}"
    );
}

fn assert_diag(i: DMat3, want: DVec3, rel: f64) {
    let scale = want.abs().max_element();
    for r in 0..3 {
        for c in 0..3 {
            let w = if r == c { want[r] } else { 0.0 };
            assert!(
                (i.col(c)[r] - w).abs() <= rel * scale,
                "inertia[{r}][{c}] = {}, want {w}",
                i.col(c)[r]
            );
        }
    }
}

// ---------------------------------------------------------------- hull: structure

#[test]
fn platonic_solids_have_merged_faces() {
    // (kind, faces, vertices, sides per face, edge directions up to sign)
    let expect = [
        (RegularKind::Tetrahedron, 4, 4, 3, 6),
        (RegularKind::Cube, 6, 8, 4, 3),
        (RegularKind::Octahedron, 8, 6, 3, 6),
        (RegularKind::Dodecahedron, 12, 20, 5, 15),
        (RegularKind::Icosahedron, 20, 12, 3, 15),
    ];
    for (kind, nf, nv, sides, ndirs) in expect {
        for radius in [1e-3, 1.0, 7.5, 1e3] {
            let pts = kind.points(radius);
            let hull = convex_hull(&pts).unwrap();
            assert_eq!(hull.faces.len(), nf, "{kind:?} faces");
            assert_eq!(hull.vertices.len(), nv, "{kind:?} vertices");
            assert!(
                hull.faces.iter().all(|f| f.count == sides),
                "{kind:?} face sizes"
            );
            assert_eq!(hull.edge_dirs.len(), ndirs, "{kind:?} edge directions");
            check_hull(&pts, &hull, 1e-5 * radius);
            // Every face is at the inradius and all vertices at the circumradius.
            let inradius = hull.faces[0].offset;
            for f in &hull.faces {
                assert!((f.offset - inradius).abs() < 1e-5 * radius as f32);
            }
            assert!((hull.radius as f64 - radius).abs() < 1e-5 * radius);
        }
    }
}

#[test]
fn cube_with_face_and_edge_points_is_six_quads() {
    let mut pts = RegularKind::Cube.points(3f64.sqrt()); // corners at +-1
    for axis in 0..3 {
        for s in [-1.0f32, 1.0] {
            let mut c = Vec3::ZERO;
            c[axis] = s;
            pts.push(c); // face centre
        }
    }
    for a in [-1.0f32, 1.0] {
        for b in [-1.0f32, 1.0] {
            pts.push(Vec3::new(0.0, a, b)); // edge midpoints
            pts.push(Vec3::new(a, 0.0, b));
            pts.push(Vec3::new(a, b, 0.0));
        }
    }
    let mut r = rng(1);
    for _ in 0..500 {
        // Random points on random faces, some on edges (one more coordinate at +-1).
        let mut p = Vec3::new(
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
        );
        let axis = r.random_range(0..3);
        p[axis] = if r.random_bool(0.5) { 1.0 } else { -1.0 };
        if r.random_bool(0.2) {
            let other = (axis + 1 + r.random_range(0..2)) % 3;
            p[other] = if r.random_bool(0.5) { 1.0 } else { -1.0 };
        }
        pts.push(p);
        pts.push(p * 0.5); // interior
    }
    let hull = convex_hull(&pts).unwrap();
    assert_eq!(face_sizes(&hull), vec![4; 6]);
    assert_eq!(hull.vertices.len(), 8);
    check_hull(&pts, &hull, 1e-6);
    let m = MassProperties::of_polyhedron(&hull);
    assert_rel(m.volume, 8.0, 1e-12, "volume");
}

#[test]
fn duplicates_and_coplanar_points_do_not_change_faces() {
    let mut r = rng(2);
    for kind in RegularKind::ALL {
        let base = kind.points(2.0);
        let reference = convex_hull(&base).unwrap();
        let mut pts = Vec::new();
        for _ in 0..3 {
            pts.extend_from_slice(&base);
        }
        // Points on the faces and edges (convex combinations within one face loop) and inside.
        for f in 0..reference.faces.len() {
            let lp = reference.face_loop(f);
            for _ in 0..20 {
                let w: Vec<f32> = lp.iter().map(|_| r.random_range(0.0..1.0f32)).collect();
                let sum: f32 = w.iter().sum();
                let p: Vec3 = lp
                    .iter()
                    .zip(&w)
                    .map(|(&i, &w)| reference.vertices[i as usize] * w)
                    .sum::<Vec3>()
                    / sum;
                pts.push(p);
                pts.push(p * 0.3);
            }
            let (a, b) = (
                reference.vertices[lp[0] as usize],
                reference.vertices[lp[1] as usize],
            );
            pts.push(a.lerp(b, r.random_range(0.0..1.0)));
        }
        // Shuffle.
        for i in (1..pts.len()).rev() {
            pts.swap(i, r.random_range(0..=i));
        }
        let hull = convex_hull(&pts).unwrap();
        assert_eq!(hull.faces.len(), reference.faces.len(), "{kind:?}");
        assert_eq!(hull.vertices.len(), reference.vertices.len(), "{kind:?}");
        assert_eq!(face_sizes(&hull), face_sizes(&reference), "{kind:?}");
        check_hull(&pts, &hull, 1e-5);
    }
}

#[test]
fn nearly_coplanar_points_merge() {
    // A box whose faces are sampled densely, every point (corners included) jittered by up to
    // 1e-7 of the size: still 6 quads on the 8 corners.
    let mut r = rng(3);
    let h = Vec3::new(1.0, 2.0, 0.5);
    let mut pts = Vec::new();
    for i in 0..8 {
        pts.push(Vec3::new(
            if i & 1 == 0 { -h.x } else { h.x },
            if i & 2 == 0 { -h.y } else { h.y },
            if i & 4 == 0 { -h.z } else { h.z },
        ));
    }
    for _ in 0..2000 {
        let mut p = Vec3::new(
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
        );
        let axis = r.random_range(0..3);
        p[axis] = if r.random_bool(0.5) { 1.0 } else { -1.0 };
        pts.push(p * h);
    }
    let jitter = 4e-7f32;
    for p in &mut pts {
        *p += Vec3::new(
            r.random_range(-jitter..jitter),
            r.random_range(-jitter..jitter),
            r.random_range(-jitter..jitter),
        );
    }
    let hull = convex_hull(&pts).unwrap();
    assert_eq!(face_sizes(&hull), vec![4; 6]);
    assert_eq!(hull.vertices.len(), 8);
    check_hull(&pts, &hull, 1e-5);
}

#[test]
fn prism_merges_caps_and_sides() {
    for n in [3usize, 5, 16, 64] {
        let mut pts = Vec::new();
        for k in 0..n {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            for z in [-0.5f32, 1.5] {
                pts.push(Vec3::new(a.cos() as f32, a.sin() as f32, z));
                pts.push(Vec3::new(0.5 * a.cos() as f32, 0.5 * a.sin() as f32, z));
            }
        }
        let hull = convex_hull(&pts).unwrap();
        assert_eq!(hull.faces.len(), n + 2, "prism {n}");
        assert_eq!(hull.vertices.len(), 2 * n, "prism {n}");
        check_hull(&pts, &hull, 1e-5);
    }
}

#[test]
fn random_clouds_match_brute_force() {
    let mut r = rng(4);
    for trial in 0..200 {
        let n = match trial % 5 {
            0 => 4 + trial % 7,
            1 => 20,
            2 => 100,
            3 => 300,
            _ => 1000,
        };
        let rot = random_rotation(&mut r);
        let offset = DVec3::new(
            r.random_range(-50.0..50.0),
            r.random_range(-50.0..50.0),
            0.0,
        );
        let scale = 10f64.powf(r.random_range(-2.0..2.0));
        let pts: Vec<Vec3> = (0..n)
            .map(|_| {
                let p = match trial % 4 {
                    // Inside a ball.
                    0 => random_unit(&mut r) * r.random_range(0.0..1.0f64).cbrt(),
                    // On a sphere.
                    1 => random_unit(&mut r),
                    // In a flattened box.
                    2 => DVec3::new(
                        r.random_range(-1.0..1.0),
                        r.random_range(-1.0..1.0),
                        r.random_range(-0.05..0.05),
                    ),
                    // On a small integer lattice (many coplanar and collinear points).
                    _ => DVec3::new(
                        r.random_range(-2..=2) as f64,
                        r.random_range(-2..=2) as f64,
                        r.random_range(-2..=2) as f64,
                    ),
                };
                if trial % 4 == 3 {
                    p.as_vec3()
                } else {
                    (rot * p * scale + offset * scale).as_vec3()
                }
            })
            .collect();
        match convex_hull(&pts) {
            Ok(hull) => {
                check_hull(&pts, &hull, 4.0 * hull_tolerance(&pts));
            }
            Err(GeomError::DegenerateHull { .. }) => {
                assert!(n < 10 && trial % 4 == 3, "trial {trial}")
            }
            Err(e) => panic!("{e}"),
        }
    }
}

#[test]
fn large_sphere_cloud_is_fast() {
    let mut r = rng(5);
    let pts: Vec<Vec3> = (0..10_000).map(|_| random_unit(&mut r).as_vec3()).collect();
    let start = std::time::Instant::now();
    let hull = convex_hull(&pts).unwrap();
    let elapsed = start.elapsed();
    println!("10k-point sphere hull: {elapsed:?}");
    // All points are extreme; a triangulated sphere has F = 2V - 4 (a few nearly cocircular
    // pairs of triangles merge into quads).
    assert_eq!(hull.vertices.len(), 10_000);
    assert!(hull.faces.len() <= 2 * 10_000 - 4 && hull.faces.len() > 19_000);
    check_hull(&pts, &hull, 1e-5);
    // Generous bound (shared CI machines); the release build takes a few milliseconds.
    assert!(
        elapsed.as_secs_f64() < 2.0,
        "10k-point hull took {elapsed:?}"
    );
    let m = MassProperties::of_polyhedron(&hull);
    assert_rel(
        m.volume,
        4.0 / 3.0 * std::f64::consts::PI,
        2e-3,
        "sphere volume",
    );
}

#[test]
fn edge_directions_match_brute_force() {
    let mut r = rng(9);
    let mut clouds: Vec<Vec<Vec3>> =
        vec![(0..2000).map(|_| random_unit(&mut r).as_vec3()).collect()];
    // Prisms: many parallel edges.
    clouds.push(
        (0..64)
            .flat_map(|k| {
                let a = std::f32::consts::TAU * k as f32 / 64.0;
                [
                    Vec3::new(a.cos(), a.sin(), -1.0),
                    Vec3::new(a.cos(), a.sin(), 1.0),
                ]
            })
            .collect(),
    );
    for pts in clouds {
        let hull = convex_hull(&pts).unwrap();
        // Edge directions deduplicated as by a brute-force scan (first match in edge order).
        let mut dirs: Vec<Vec3> = Vec::new();
        for (e, &[a, b]) in hull.edges.iter().enumerate() {
            let d = (hull.vertices[b as usize] - hull.vertices[a as usize]).normalize();
            let k = dirs
                .iter()
                .position(|u| u.cross(d).length_squared() < 1e-10);
            let k = k.unwrap_or_else(|| {
                dirs.push(d);
                dirs.len() - 1
            });
            assert_eq!(hull.edge_dir_of[e] as usize, k);
        }
        assert_eq!(dirs, hull.edge_dirs);
    }
}

#[test]
fn degenerate_inputs_are_errors() {
    let degenerate =
        |pts: &[Vec3]| matches!(convex_hull(pts), Err(GeomError::DegenerateHull { .. }));
    assert!(degenerate(&[]));
    assert!(degenerate(&[Vec3::ONE]));
    assert!(degenerate(&[Vec3::X, Vec3::Y, Vec3::Z]));
    assert!(degenerate(&[Vec3::ONE; 100]));
    let mut r = rng(6);
    let mut jitter = |s: f32| {
        Vec3::new(
            r.random_range(-s..s),
            r.random_range(-s..s),
            r.random_range(-s..s),
        )
    };
    let near_point: Vec<Vec3> = (0..50).map(|_| Vec3::splat(3.0) + jitter(1e-7)).collect();
    assert!(degenerate(&near_point));
    let line: Vec<Vec3> = (0..50)
        .map(|k| Vec3::new(1.0, 2.0, 3.0) * (k as f32 * 0.1))
        .collect();
    assert!(degenerate(&line));
    let near_line: Vec<Vec3> = line.iter().map(|&p| p + jitter(1e-7)).collect();
    assert!(degenerate(&near_line));
    let (u, v) = (Vec3::new(1.0, 2.0, -1.0), Vec3::new(0.5, -1.0, 3.0));
    let plane: Vec<Vec3> = (0..200)
        .map(|k| Vec3::splat(5.0) + u * ((k % 13) as f32 * 0.3) + v * ((k % 7) as f32 * 0.2))
        .collect();
    assert!(degenerate(&plane));
    let near_plane: Vec<Vec3> = plane.iter().map(|&p| p + jitter(1e-6)).collect();
    assert!(degenerate(&near_plane));
    let square = [
        Vec3::ZERO,
        Vec3::X,
        Vec3::Y,
        Vec3::X + Vec3::Y,
        Vec3::ZERO,
        Vec3::X,
    ];
    assert!(degenerate(&square));
    assert_eq!(
        convex_hull(&[Vec3::ZERO, Vec3::X, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z]),
        Err(GeomError::NonFinitePoint { index: 2 })
    );
    // A barely solid set is fine.
    let mut thin = plane.clone();
    thin.push(Vec3::splat(5.0) + u.cross(v).normalize() * 1e-3);
    let hull = convex_hull(&thin).unwrap();
    check_hull(&thin, &hull, 4.0 * hull_tolerance(&thin));
}

#[test]
fn far_from_origin() {
    let base = Vec3::new(1000.0, -2000.0, 500.0);
    let pts: Vec<Vec3> = RegularKind::Cube
        .points(3f64.sqrt())
        .into_iter()
        .map(|p| p + base)
        .collect();
    let hull = convex_hull(&pts).unwrap();
    assert_eq!(face_sizes(&hull), vec![4; 6]);
    let m = MassProperties::of_polyhedron(&hull);
    assert_rel(m.volume, 8.0, 1e-9, "volume");
    assert!((m.center - base.as_dvec3()).length() < 1e-9);
    assert_diag(m.inertia, DVec3::splat(8.0 * 4.0 / 6.0), 1e-9);
}

// ---------------------------------------------------------------- mass properties

#[test]
fn box_mass_properties() {
    let (a, b, c) = (0.5f64, 2.0, 3.5);
    let pts: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { 0.0 } else { a as f32 },
                if i & 2 == 0 { -1.0 } else { (b - 1.0) as f32 },
                if i & 4 == 0 { 3.0 } else { (3.0 + c) as f32 },
            )
        })
        .collect();
    let m = MassProperties::of_polyhedron(&convex_hull(&pts).unwrap());
    let v = a * b * c;
    assert_rel(m.volume, v, 1e-12, "box volume");
    assert!((m.center - DVec3::new(a / 2.0, b / 2.0 - 1.0, 3.0 + c / 2.0)).length() < 1e-12);
    let want = DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) * (v / 12.0);
    assert_diag(m.inertia, want, 1e-12);
    let (moments, rot) = m.principal_axes();
    assert_eq!(rot, DQuat::IDENTITY);
    assert!((moments - want).length() < 1e-12 * want.length());
}

#[test]
fn platonic_mass_properties() {
    // V = k_v a^3 and I = k_i m a^2 about any axis through the centre (a: edge), derived from
    // the face pyramids: V = sum A h / 3, int |x|^2 dV = sum h (A h^2 + J) / 5, I = 2/3 of that.
    let s5 = 5f64.sqrt();
    let table = [
        (
            RegularKind::Tetrahedron,
            1.0 / (6.0 * 2f64.sqrt()),
            1.0 / 20.0,
        ),
        (RegularKind::Cube, 1.0, 1.0 / 6.0),
        (RegularKind::Octahedron, 2f64.sqrt() / 3.0, 1.0 / 10.0),
        (
            RegularKind::Dodecahedron,
            (15.0 + 7.0 * s5) / 4.0,
            (95.0 + 39.0 * s5) / 300.0,
        ),
        (
            RegularKind::Icosahedron,
            5.0 * (3.0 + s5) / 12.0,
            (3.0 + s5) / 20.0,
        ),
    ];
    for (kind, kv, ki) in table {
        let pts = kind.points(1.3);
        let a = shortest_distance(&pts);
        let m = MassProperties::of_polyhedron(&convex_hull(&pts).unwrap());
        let v = kv * a.powi(3);
        assert_rel(m.volume, v, 1e-6, kind.name());
        assert!(m.center.length() < 1e-6, "{kind:?} centre {}", m.center);
        assert_diag(m.inertia, DVec3::splat(ki * v * a * a), 1e-6);
        let (moments, rot) = m.principal_axes();
        assert_eq!(rot, DQuat::IDENTITY, "{kind:?} keeps its orientation");
        assert!((moments - DVec3::splat(ki * v * a * a)).abs().max_element() < 1e-6 * moments.x);
    }
}

#[test]
fn sphere_hull_converges_to_sphere() {
    let exact = MassProperties::of_sphere(1.0);
    let mut last = f64::INFINITY;
    for n in [100usize, 1000, 10_000] {
        // Fibonacci sphere.
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let pts: Vec<Vec3> = (0..n)
            .map(|k| {
                let z = 1.0 - (2 * k + 1) as f64 / n as f64;
                let r = (1.0 - z * z).sqrt();
                let t = golden * k as f64;
                Vec3::new((r * t.cos()) as f32, (r * t.sin()) as f32, z as f32)
            })
            .collect();
        let m = MassProperties::of_polyhedron(&convex_hull(&pts).unwrap());
        let err_v = (m.volume - exact.volume).abs() / exact.volume;
        let err_i = (m.inertia - exact.inertia)
            .abs()
            .to_cols_array()
            .into_iter()
            .fold(0.0, f64::max)
            / exact.inertia.x_axis.x;
        assert!(m.volume < exact.volume);
        assert!(
            err_v < last && err_i < 2.0 * err_v.max(1e-4),
            "n {n}: {err_v} {err_i}"
        );
        assert!(m.center.length() < 1e-2);
        last = err_v;
    }
    assert!(last < 1e-3);
}

#[test]
fn rotated_translated_box_principal_frame() {
    let mut r = rng(7);
    let h = DVec3::new(0.3, 0.8, 1.7);
    let v = 8.0 * h.x * h.y * h.z;
    let want = DVec3::new(
        h.y * h.y + h.z * h.z,
        h.x * h.x + h.z * h.z,
        h.x * h.x + h.y * h.y,
    ) * (v / 3.0);
    for _ in 0..20 {
        let rot = random_rotation(&mut r);
        let t = DVec3::new(
            r.random_range(-5.0..5.0),
            r.random_range(-5.0..5.0),
            r.random_range(-5.0..5.0),
        );
        let pts: Vec<Vec3> = (0..8)
            .map(|i| {
                let c = DVec3::new(
                    if i & 1 == 0 { -h.x } else { h.x },
                    if i & 2 == 0 { -h.y } else { h.y },
                    if i & 4 == 0 { -h.z } else { h.z },
                );
                (rot * c + t).as_vec3()
            })
            .collect();
        let m = MassProperties::of_polyhedron(&convex_hull(&pts).unwrap());
        assert_rel(m.volume, v, 1e-5, "volume");
        assert!((m.center - t).length() < 1e-5);
        let (moments, q) = m.principal_axes();
        let rm = DMat3::from_quat(q);
        assert!((rm.determinant() - 1.0).abs() < 1e-12);
        assert_diag(rm.transpose() * m.inertia * rm, moments, 1e-9);
        // Each principal axis is a box axis (up to sign) with the matching moment.
        for j in 0..3 {
            let axis = rm.col(j);
            let k = (0..3).max_by(|&a, &b| {
                let da = axis.dot(rot * DVec3::AXES[a]).abs();
                let db = axis.dot(rot * DVec3::AXES[b]).abs();
                da.total_cmp(&db)
            });
            let k = k.unwrap();
            assert!(axis.dot(rot * DVec3::AXES[k]).abs() > 1.0 - 1e-5);
            assert_rel(moments[j], want[k], 1e-5, "moment");
        }
    }
}

#[test]
fn principal_axes_of_general_tensors() {
    let mut r = rng(8);
    for _ in 0..100 {
        let rot = DMat3::from_quat(random_rotation(&mut r));
        let d = DVec3::new(
            r.random_range(0.1..2.0),
            r.random_range(0.1..2.0),
            r.random_range(0.1..2.0),
        );
        let inertia = rot * DMat3::from_diagonal(d) * rot.transpose();
        let m = MassProperties {
            volume: 1.0,
            center: DVec3::ZERO,
            inertia,
        };
        let (moments, q) = m.principal_axes();
        let rm = DMat3::from_quat(q);
        assert!((rm.determinant() - 1.0).abs() < 1e-12);
        assert_diag(rm.transpose() * inertia * rm, moments, 1e-12);
        let (mut a, mut b) = (moments.to_array(), d.to_array());
        a.sort_by(f64::total_cmp);
        b.sort_by(f64::total_cmp);
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-12);
        }
    }
    // Diagonal up to rounding: identity, order kept.
    let mut i = DMat3::from_diagonal(DVec3::new(3.0, 1.0, 2.0));
    i.x_axis.y = 1e-12;
    i.y_axis.x = 1e-12;
    let (moments, q) = MassProperties {
        volume: 1.0,
        center: DVec3::ZERO,
        inertia: i,
    }
    .principal_axes();
    assert_eq!(q, DQuat::IDENTITY);
    assert_eq!(moments, DVec3::new(3.0, 1.0, 2.0));
}

// ---------------------------------------------------------------- shapes

#[test]
fn prepare_all_shape_kinds() {
    let sphere = ShapeKind::Sphere { radius: 0.5 }.prepare().unwrap();
    assert_eq!(sphere.shape, Shape::Sphere { radius: 0.5 });
    assert_rel(
        sphere.volume as f64,
        MassProperties::of_sphere(0.5).volume,
        1e-6,
        "sphere",
    );

    let b = ShapeKind::Box {
        half_extents: [0.5, 1.0, 2.0],
    }
    .prepare()
    .unwrap();
    assert_eq!(b.frame, Quat::IDENTITY);
    assert_rel(b.volume as f64, 8.0, 1e-6, "box volume");
    assert!((b.unit_inertia - Vec3::new(5.0, 4.25, 1.25) * 8.0 / 3.0).length() < 1e-4);
    let Shape::Polyhedron(p) = &b.shape else {
        panic!()
    };
    assert_eq!(face_sizes(p), vec![4; 6]);

    for kind in RegularKind::ALL {
        let s = ShapeKind::Regular { kind, radius: 2.0 }.prepare().unwrap();
        assert_eq!(s.frame, Quat::IDENTITY, "{kind:?}");
        assert!(s.com.length() < 1e-5);
        let Shape::Polyhedron(p) = &s.shape else {
            panic!()
        };
        assert!((p.radius - 2.0).abs() < 1e-5);
    }

    // A rotated, offset box given as a point cloud comes back centred and axis-aligned.
    let rot = DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1);
    let off = DVec3::new(1.0, 2.0, -3.0);
    let points: Vec<[f64; 3]> = (0..8)
        .map(|i| {
            let c = DVec3::new(
                if i & 1 == 0 { -0.2 } else { 0.2 },
                if i & 2 == 0 { -0.6 } else { 0.6 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            );
            (rot * c + off).to_array()
        })
        .collect();
    let s = ShapeKind::Convex {
        points: points.clone(),
    }
    .prepare()
    .unwrap();
    assert!((s.com.as_dvec3() - off).length() < 1e-5);
    let Shape::Polyhedron(p) = &s.shape else {
        panic!()
    };
    let m = MassProperties::of_polyhedron(p);
    assert!(m.center.length() < 1e-5);
    assert_diag(m.inertia, s.unit_inertia.as_dvec3(), 1e-4);
    // frame maps principal coordinates back to the authored ones.
    for v in &p.vertices {
        let authored = s.frame * *v + s.com;
        assert!(
            points
                .iter()
                .any(|q| (DVec3::from_array(*q).as_vec3() - authored).length() < 1e-5)
        );
    }

    assert!(matches!(
        ShapeKind::Sphere { radius: -1.0 }.prepare(),
        Err(GeomError::NotPositive { .. })
    ));
    assert!(matches!(
        ShapeKind::Box {
            half_extents: [1.0, f64::NAN, 1.0]
        }
        .prepare(),
        Err(GeomError::NotPositive { .. })
    ));
    assert!(matches!(
        ShapeKind::Convex {
            points: vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, f64::INFINITY, 0.0],
                [0.0; 3]
            ]
        }
        .prepare(),
        Err(GeomError::NonFinitePoint { index: 2 })
    ));
    assert!(matches!(
        ShapeKind::Convex {
            points: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]
        }
        .prepare(),
        Err(GeomError::DegenerateHull { count: 4, .. })
    ));
}

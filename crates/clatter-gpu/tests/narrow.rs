//! The WGSL narrow phase against the CPU's `narrow::collide` / `collide_plane` on thousands of
//! random pairs and walls (spheres, boxes, the Platonic solids, random hulls, hulls with
//! 32-gon faces).
//!
//! Results must agree to rounding. A mismatch is excused only as a near-tie: when the CPU's
//! own answer changes under a pose perturbation of 1e-5 x size (or the perturbed CPU gives
//! the GPU's answer), i.e. when competing candidates (axes, faces, clip points, reduction
//! picks) are within ~1e-5 x size of each other. Near-ties are counted and bounded.

mod common;

use common::*;

use clatter_geom::narrow::NO_HINT;
use clatter_geom::narrow::{self, Plane};
use clatter_geom::{Pose, PreparedShape, RegularKind, Shape, ShapeKind};
use clatter_gpu::{GpuError, GpuShapes, NarrowBatch, NarrowQuery, PairMemory, PlaneQuery};
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn prep(kind: ShapeKind) -> PreparedShape {
    kind.prepare().expect("valid shape")
}

/// Points around a circle of `n` at height `z` (for prisms and pyramids with big faces).
fn ring(n: usize, r: f64, z: f64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            [r * a.cos(), r * a.sin(), z]
        })
        .collect()
}

/// The test's shape set.
fn shape_set(rng: &mut ChaCha8Rng) -> Vec<PreparedShape> {
    let mut s = vec![
        prep(ShapeKind::Sphere { radius: 0.3 }),
        prep(ShapeKind::Sphere { radius: 0.5 }),
        prep(ShapeKind::Sphere { radius: 1.0 }),
        prep(ShapeKind::Box {
            half_extents: [0.5, 0.5, 0.5],
        }),
        prep(ShapeKind::Box {
            half_extents: [1.0, 0.3, 0.6],
        }),
        prep(ShapeKind::Box {
            half_extents: [0.2, 0.8, 0.4],
        }),
    ];
    for (i, kind) in RegularKind::ALL.into_iter().enumerate() {
        s.push(prep(ShapeKind::Regular {
            kind,
            radius: 0.6 + 0.1 * i as f64,
        }));
    }
    for n in [8, 12, 20, 28, 40] {
        let scale = [
            rng.random_range(0.4..1.0),
            rng.random_range(0.4..1.0),
            rng.random_range(0.4..1.0),
        ];
        let points = (0..n)
            .map(|_| {
                let v = random_unit(rng) * rng.random_range(0.5f32..1.0);
                [
                    v.x as f64 * scale[0],
                    v.y as f64 * scale[1],
                    v.z as f64 * scale[2],
                ]
            })
            .collect();
        s.push(prep(ShapeKind::Convex { points }));
    }
    // A prism with 32-gon caps (64 vertices) and a pyramid on a 32-gon.
    let mut prism = ring(32, 0.7, -0.3);
    prism.extend(ring(32, 0.7, 0.3));
    s.push(prep(ShapeKind::Convex { points: prism }));
    let mut pyramid = ring(32, 0.8, -0.2);
    pyramid.push([0.0, 0.0, 0.6]);
    s.push(prep(ShapeKind::Convex { points: pyramid }));
    s
}

fn size_of(s: &PreparedShape) -> f32 {
    s.shape.bounding_radius()
}

/// Shapes with symmetries (boxes, Platonic solids, the prism and pyramid): their contacts
/// often have exactly equal candidates in exact arithmetic (mirror-symmetric vertices for
/// the reduction's third and fourth points, equal face separations), which rounding
/// decides, so near-ties are common there.
fn is_symmetric(shapes: &[PreparedShape], s: usize) -> bool {
    matches!(shapes[s].shape, Shape::Polyhedron(_)) && !(11..=15).contains(&s)
}

/// Random pairs: half with random poses around the contact distance, half "stacked" (B on
/// top of A along A's z, twisted about z, slightly tilted or not) for face-face manifolds.
fn random_pairs(shapes: &[PreparedShape], n: usize, rng: &mut ChaCha8Rng) -> Vec<NarrowQuery> {
    let mut out = Vec::with_capacity(2 * n);
    for k in 0..n {
        let sa = rng.random_range(0..shapes.len());
        let sb = rng.random_range(0..shapes.len());
        let (ra, rb) = (size_of(&shapes[sa]), size_of(&shapes[sb]));
        let xa = Vec3::new(
            rng.random_range(-10.0..10.0),
            rng.random_range(-10.0..10.0),
            rng.random_range(-10.0..10.0),
        );
        let qa = random_quat(rng);
        let (xb, qb) = if k % 2 == 0 {
            let dist = rng.random_range(0.0..0.95f32) * (ra + rb);
            (xa + random_unit(rng) * dist, random_quat(rng))
        } else {
            let twist = if rng.random_bool(0.2) {
                0.0
            } else {
                rng.random_range(0.0..std::f32::consts::TAU)
            };
            let tilt = if rng.random_bool(0.5) {
                Quat::IDENTITY
            } else {
                Quat::from_axis_angle(random_unit(rng), rng.random_range(0.0..0.05))
            };
            let qb = (qa * tilt * Quat::from_rotation_z(twist)).normalize();
            let up = qa * Vec3::Z;
            let top_a = support_height(&shapes[sa].shape, qa, up);
            let bottom_b = support_height(&shapes[sb].shape, qb, -up);
            let overlap = rng.random_range(-0.02..0.1f32) * ra.min(rb);
            let side = (qa * Vec3::X) * rng.random_range(-0.3..0.3f32) * ra;
            (xa + up * (top_a + bottom_b - overlap) + side, qb)
        };
        let (pa, pb) = (Pose::new(xa, qa), Pose::new(xb, qb));
        out.push(NarrowQuery {
            shape_a: sa as u32,
            pose_a: pa,
            shape_b: sb as u32,
            pose_b: pb,
        });
        out.push(NarrowQuery {
            shape_a: sb as u32,
            pose_a: pb,
            shape_b: sa as u32,
            pose_b: pa,
        });
    }
    out
}

/// Largest extent of `shape` at rotation `q` along the world direction `dir`.
fn support_height(shape: &Shape, q: Quat, dir: Vec3) -> f32 {
    match shape {
        Shape::Sphere { radius } => *radius,
        Shape::Polyhedron(p) => p
            .vertices
            .iter()
            .map(|v| (q * *v).dot(dir))
            .fold(f32::MIN, f32::max),
        Shape::Composite(c) => c.radius, // not generated here (the GPU has no composites)
    }
}

#[test]
fn gpu_collide_matches_cpu_on_random_pairs() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(0x6e61_7272);
    let shapes = shape_set(&mut rng);
    let gpu_shapes = GpuShapes::upload(&ctx, &shapes).expect("upload");
    let batch = NarrowBatch::new(&ctx).expect("compile the narrow phase");
    let queries = random_pairs(&shapes, 15_000, &mut rng);
    let t = std::time::Instant::now();
    let gpu = batch
        .collide(&ctx, &gpu_shapes, &queries)
        .expect("GPU batch");
    eprintln!(
        "{} pair queries on {} in {:.2} s",
        queries.len(),
        ctx.adapter_name(),
        t.elapsed().as_secs_f64()
    );
    let mut stats = Stats::default();
    for (i, (q, g)) in queries.iter().zip(&gpu).enumerate() {
        let (a, b) = (
            &shapes[q.shape_a as usize].shape,
            &shapes[q.shape_b as usize].shape,
        );
        let eval = |pa: &Pose, pb: &Pose| narrow::collide(a, pa, b, pb);
        let cpu = eval(&q.pose_a, &q.pose_b);
        let size = a.bounding_radius().max(b.bounding_radius());
        let label = format!("pair {i} (shapes {} and {})", q.shape_a, q.shape_b);
        let generic = !is_symmetric(&shapes, q.shape_a as usize)
            && !is_symmetric(&shapes, q.shape_b as usize);
        stats.check(
            generic, &label, cpu, g, size, &eval, &q.pose_a, &q.pose_b, &mut rng,
        );
    }
    stats.report("pairs");
    assert!(
        stats.contacts * 4 > stats.tested,
        "too few contacts to be a test"
    );
    assert!(
        stats.contacts * 4 < 3 * stats.tested,
        "too few separated pairs"
    );
    assert_eq!(stats.max_points, 4, "no four-point manifold was tested");
}

#[test]
fn gpu_collide_plane_matches_cpu() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(0x706c_616e);
    let shapes = shape_set(&mut rng);
    let gpu_shapes = GpuShapes::upload(&ctx, &shapes).expect("upload");
    let batch = NarrowBatch::new(&ctx).expect("compile the narrow phase");
    let mut queries = Vec::new();
    for k in 0..6000 {
        let s = rng.random_range(0..shapes.len());
        let r = size_of(&shapes[s]);
        let normal = if k % 3 == 0 {
            [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Z][rng.random_range(0..4)]
        } else {
            random_unit(&mut rng)
        };
        let offset = rng.random_range(-5.0..5.0f32);
        // Every third body rests on a face (rotation from a face normal to -normal).
        let rotation = if k % 3 == 1 {
            match &shapes[s].shape {
                Shape::Polyhedron(p) => {
                    let f = p.faces[rng.random_range(0..p.faces.len())];
                    let tilt =
                        Quat::from_axis_angle(random_unit(&mut rng), rng.random_range(0.0..0.01));
                    (tilt * Quat::from_rotation_arc(f.normal, -normal)).normalize()
                }
                Shape::Sphere { .. } | Shape::Composite(_) => random_quat(&mut rng),
            }
        } else {
            random_quat(&mut rng)
        };
        let height = rng.random_range(-0.3..1.1f32) * r;
        let tangent = random_unit(&mut rng).cross(normal) * 3.0;
        let position = normal * (offset + height) + tangent;
        queries.push(PlaneQuery {
            plane: Plane { normal, offset },
            shape: s as u32,
            pose: Pose::new(position, rotation),
        });
    }
    let t = std::time::Instant::now();
    let gpu = batch
        .collide_plane(&ctx, &gpu_shapes, &queries)
        .expect("GPU batch");
    eprintln!(
        "{} plane queries in {:.2} s",
        queries.len(),
        t.elapsed().as_secs_f64()
    );
    let mut stats = Stats::default();
    for (i, (q, g)) in queries.iter().zip(&gpu).enumerate() {
        let shape = &shapes[q.shape as usize].shape;
        let plane = q.plane;
        // Perturb the body only (the wall's pose argument is ignored).
        let eval = |_: &Pose, pb: &Pose| narrow::collide_plane(&plane, shape, pb);
        let cpu = eval(&q.pose, &q.pose);
        let size = shape.bounding_radius();
        let generic = !is_symmetric(&shapes, q.shape as usize);
        stats.check(
            generic,
            &format!("plane {i} (shape {})", q.shape),
            cpu,
            g,
            size,
            &eval,
            &q.pose,
            &q.pose,
            &mut rng,
        );
    }
    stats.report("planes");
    assert_eq!(stats.max_points, 4, "no four-point manifold was tested");
}

#[test]
fn shape_queries_and_big_faces_are_supported() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let shapes = shape_set(&mut rng);
    // The prism (64 vertices) and the pyramid have faces of the largest supported size.
    for s in &shapes[shapes.len() - 2..] {
        let Shape::Polyhedron(p) = &s.shape else {
            panic!("polyhedron")
        };
        let longest = p.faces.iter().map(|f| f.count).max().unwrap();
        assert_eq!(longest as usize, clatter_gpu::shapes::MAX_FACE_VERTICES);
    }
    let gpu_shapes = GpuShapes::upload(&ctx, &shapes).expect("upload");
    assert_eq!(gpu_shapes.count, shapes.len());
    // Out-of-range shape indices are refused.
    let bad = NarrowQuery {
        shape_a: shapes.len() as u32,
        pose_a: Pose::new(Vec3::ZERO, Quat::IDENTITY),
        shape_b: 0,
        pose_b: Pose::new(Vec3::ZERO, Quat::IDENTITY),
    };
    assert!(matches!(
        clatter_gpu::collide_batch(&ctx, &gpu_shapes, &[bad]),
        Err(GpuError::Unsupported(_))
    ));
    assert!(
        clatter_gpu::collide_batch(&ctx, &gpu_shapes, &[])
            .unwrap()
            .is_empty()
    );
}

#[test]
fn shapes_over_the_limits_are_unsupported() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let sphere = prep(ShapeKind::Sphere { radius: 1.0 });
    // 400 points on a sphere: a hull with more than MAX_SHAPE_VERTICES vertices.
    let many = prep(ShapeKind::Convex {
        points: (0..400)
            .map(|_| {
                let v = random_unit(&mut rng);
                [v.x as f64, v.y as f64, v.z as f64]
            })
            .collect(),
    });
    let Shape::Polyhedron(p) = &many.shape else {
        panic!()
    };
    assert!(p.vertices.len() > clatter_gpu::shapes::MAX_SHAPE_VERTICES);
    let err = GpuShapes::upload(&ctx, &[sphere.clone(), many])
        .err()
        .expect("too many vertices");
    let GpuError::Unsupported(msg) = &err else {
        panic!("wrong error {err}")
    };
    assert!(msg.contains("shape 1") && msg.contains("64"), "{msg}");
    eprintln!("{err}");
    // A pyramid on a 40-gon: 41 vertices, but a face longer than MAX_FACE_VERTICES.
    let mut pts = ring(40, 1.0, 0.0);
    pts.push([0.0, 0.0, 1.0]);
    let pyramid = prep(ShapeKind::Convex { points: pts });
    let err = GpuShapes::upload(&ctx, &[pyramid, sphere])
        .err()
        .expect("face too long");
    let GpuError::Unsupported(msg) = &err else {
        panic!("wrong error {err}")
    };
    assert!(msg.contains("shape 0") && msg.contains("32"), "{msg}");
    eprintln!("{err}");
}

/// The hulls of the committed mesh files (`scenes/meshes`): the irregular rock (42
/// vertices, 80 triangles), the same rock flattened, and the PLY tetrahedron, with a sphere
/// and a 64-vertex hull: larger hulls than [`shape_set`]'s.
#[test]
fn gpu_collide_matches_cpu_on_mesh_file_hulls() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/meshes");
    let load = |file: &str, axes: [f64; 3]| {
        let mesh = clatter::mesh::read_mesh(&dir.join(file)).unwrap();
        prep(ShapeKind::Convex {
            points: mesh
                .vertices
                .iter()
                .map(|v| [v[0] * axes[0], v[1] * axes[1], v[2] * axes[2]])
                .collect(),
        })
    };
    // A Fibonacci sphere of 64 points, stretched: every point on the hull, 124 faces, 186
    // edges: the largest hull the GPU takes (MAX_SHAPE_VERTICES).
    let fibonacci = (0..64)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 64.0;
            let r = (1.0 - z * z).sqrt();
            let a = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            [0.5 * r * a.cos(), 0.4 * r * a.sin(), 0.3 * z]
        })
        .collect();
    let shapes = vec![
        load("rock.obj", [1.0, 1.0, 1.0]),
        load("rock.obj", [1.0, 1.0, 0.5]),
        load("tetrahedron.ply", [0.4, 0.4, 0.4]),
        prep(ShapeKind::Sphere { radius: 0.4 }),
        prep(ShapeKind::Convex { points: fibonacci }),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(0x726f_636b);
    let gpu_shapes = GpuShapes::upload(&ctx, &shapes).expect("upload");
    let batch = NarrowBatch::new(&ctx).expect("compile the narrow phase");
    let queries = random_pairs(&shapes, 3000, &mut rng);
    let gpu = batch
        .collide(&ctx, &gpu_shapes, &queries)
        .expect("GPU batch");
    let mut stats = Stats::default();
    for (i, (q, g)) in queries.iter().zip(&gpu).enumerate() {
        let (a, b) = (
            &shapes[q.shape_a as usize].shape,
            &shapes[q.shape_b as usize].shape,
        );
        let eval = |pa: &Pose, pb: &Pose| narrow::collide(a, pa, b, pb);
        let cpu = eval(&q.pose_a, &q.pose_b);
        let size = a.bounding_radius().max(b.bounding_radius());
        let label = format!("pair {i} (shapes {} and {})", q.shape_a, q.shape_b);
        stats.check(
            true, &label, cpu, g, size, &eval, &q.pose_a, &q.pose_b, &mut rng,
        );
    }
    stats.report("mesh-file hulls");
}

/// One pair stepped through time ([`gpu_pair_memory_matches_the_full_test_over_time`]): B
/// approaches A along the world direction `u`, kept at the overlap `overlap(k)` along `u`
/// (past zero: apart, then touching again), rocked about `rock_axis`, turned steadily, and
/// slid sideways.
struct Motion {
    sa: usize,
    sb: usize,
    qa0: Quat,
    qb0: Quat,
    u: Vec3,
    /// A's steady turn per step (scaled axis).
    wa: Vec3,
    /// B's steady turn per step (scaled axis).
    wb: Vec3,
    /// B's rocking: axis (unit), amplitude (rad), period (steps).
    rock_axis: Vec3,
    rock: f32,
    rock_period: f32,
    /// Overlap along `u`: mean and amplitude (fractions of the smaller radius), period.
    overlap: f32,
    overlap_amp: f32,
    overlap_period: f32,
    /// Sideways slide per step (a length).
    slide: Vec3,
}

impl Motion {
    /// The poses of A and B at step `k`.
    fn poses(&self, shapes: &[PreparedShape], k: usize) -> (Pose, Pose) {
        let kf = k as f32;
        let tau = std::f32::consts::TAU;
        let qa = (self.qa0 * Quat::from_scaled_axis(self.wa * kf)).normalize();
        let rock = self.rock * (tau * kf / self.rock_period).sin();
        let qb = (Quat::from_scaled_axis(self.rock_axis * rock)
            * Quat::from_scaled_axis(self.wb * kf)
            * self.qb0)
            .normalize();
        let (a, b) = (&shapes[self.sa].shape, &shapes[self.sb].shape);
        let r = size_of(&shapes[self.sa]).min(size_of(&shapes[self.sb]));
        let ov = (self.overlap + self.overlap_amp * (tau * kf / self.overlap_period).sin()) * r;
        let xa = Vec3::new(0.25, -0.5, 0.75);
        let side = self.slide * kf;
        // Where B along `u` stops touching A (by bisection: the overlapping offsets along a
        // line form an interval, the Minkowski difference being convex).
        let touches = |s: f32| {
            narrow::collide(
                a,
                &Pose::new(xa, qa),
                b,
                &Pose::new(xa + self.u * s + side, qb),
            )
            .is_some()
        };
        let (mut lo, mut hi) = (
            0.0f32,
            size_of(&shapes[self.sa]) + size_of(&shapes[self.sb]),
        );
        if touches(lo) {
            for _ in 0..24 {
                let mid = 0.5 * (lo + hi);
                if touches(mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
        }
        (
            Pose::new(xa, qa),
            Pose::new(xa + self.u * (lo - ov) + side, qb),
        )
    }
}

/// The paths a remembering narrow phase took over the steps.
#[derive(Default, Debug)]
struct Paths {
    /// Pair-steps whose (full) test found the bodies touching.
    touching: usize,
    /// Of those, pair-steps where the remembered face was clipped alone.
    face: usize,
    /// Of those, pair-steps where a remembered edge contact was kept.
    edge: usize,
}

impl Paths {
    /// Counts a step with memory `before` (margin already decremented) and `after`.
    fn count(&mut self, touching: bool, before: PairMemory, after: PairMemory) {
        self.touching += touching as usize;
        if narrow::is_contact_hint(before.hint) && before == after {
            if before.hint == narrow::HINT_EDGE_CONTACT {
                self.edge += 1;
            } else {
                self.face += 1;
            }
        }
    }

    fn remembered(&self) -> usize {
        self.face + self.edge
    }
}

/// The GPU's pair memory (narrow_poly.wgsl `nrw_poly_poly` with `nrw_mem_in`) against the
/// full test on sequences of poses: pairs sliding, tumbling, rocked from face-face onto
/// edges and back, moving apart and touching again, with DEM-sized steps. At every step the
/// remembering GPU path gives the GPU full test's manifold bitwise and the CPU full test's
/// within the batch tolerance (near-ties excused as in the random test), and the remembered
/// path is taken in most touching pair-steps (counted as the CPU's `pair_narrow` does: the
/// memory came back unchanged), by the CPU's twin as often; pairs change between face and
/// edge contacts and touch again after parting.
#[test]
fn gpu_pair_memory_matches_the_full_test_over_time() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(0x6d65_6d6f);
    let shapes = shape_set(&mut rng);
    let gpu_shapes = GpuShapes::upload(&ctx, &shapes).expect("upload");
    let batch = NarrowBatch::new(&ctx).expect("compile the narrow phase");
    // Polyhedra: the boxes, the Platonic solids, the random hulls, the prism.
    let polys: Vec<usize> = (3..shapes.len() - 1).collect();
    let mut motions = Vec::new();
    for k in 0..48 {
        let sa = polys[rng.random_range(0..polys.len())];
        let sb = polys[rng.random_range(0..polys.len())];
        let qa0 = random_quat(&mut rng);
        // Half stacked face on face (B on A's face up, twisted), half at random.
        let (u, qb0) = if k % 2 == 0 {
            let twist = Quat::from_rotation_z(rng.random_range(0.0..std::f32::consts::TAU));
            (qa0 * Vec3::Z, (qa0 * twist).normalize())
        } else {
            (random_unit(&mut rng), random_quat(&mut rng))
        };
        let steady = |rng: &mut ChaCha8Rng, rate: f32| random_unit(rng) * rate;
        // Motion per step: about 1e-5 of the size (DEM steps), some pairs faster.
        let fast = if k % 4 == 3 { 4.0 } else { 1.0 };
        let rock_axis = random_unit(&mut rng).cross(u).normalize_or(Vec3::X);
        motions.push(Motion {
            sa,
            sb,
            qa0,
            qb0,
            u,
            wa: steady(&mut rng, 2e-6 * fast),
            wb: steady(&mut rng, 1e-5 * fast),
            rock_axis,
            rock: if k % 3 == 0 { 0.05 } else { 0.0 },
            rock_period: 1200.0,
            overlap: 0.01,
            overlap_amp: if k % 5 == 0 { 0.015 } else { 0.005 },
            overlap_period: 700.0,
            slide: steady(&mut rng, 2e-5 * fast).cross(u),
        });
    }
    let steps = 1200;
    let n = motions.len();
    let mut gpu_mem = vec![PairMemory::default(); n];
    let mut cpu_mem = vec![PairMemory::default(); n];
    let mut prev: Vec<(Pose, Pose)> = motions.iter().map(|m| m.poses(&shapes, 0)).collect();
    let (mut gpu_paths, mut cpu_paths) = (Paths::default(), Paths::default());
    let mut stats = Stats::default();
    let mut bitwise = 0;
    let mut kinds = [0usize; 3];
    // Per pair: the kind of its last remembered contact, whether it parted after touching;
    // changes between face and edge contacts, and touching again after parting.
    let mut last_kind: Vec<Option<usize>> = vec![None; n];
    let mut parted = vec![false; n];
    let mut touched = vec![false; n];
    let (mut face_edge_changes, mut retouched) = (0, 0);
    let t = std::time::Instant::now();
    for step in 0..steps {
        let poses: Vec<(Pose, Pose)> = motions.iter().map(|m| m.poses(&shapes, step)).collect();
        // The remembering queries, then the same poses with nothing remembered.
        let mut queries = Vec::with_capacity(2 * n);
        let mut memory = Vec::with_capacity(2 * n);
        for (s, m) in motions.iter().enumerate() {
            let r = size_of(&shapes[m.sa]) + size_of(&shapes[m.sb]);
            let dec = 2.0 * axis_motion(&prev[s].0, &prev[s].1, &poses[s].0, &poses[s].1, r);
            for mem in [&mut gpu_mem[s], &mut cpu_mem[s]] {
                if mem.hint != NO_HINT {
                    mem.margin -= dec;
                }
            }
            queries.push(NarrowQuery {
                shape_a: m.sa as u32,
                pose_a: poses[s].0,
                shape_b: m.sb as u32,
                pose_b: poses[s].1,
            });
            memory.push(gpu_mem[s]);
        }
        queries.extend_from_within(..n);
        memory.extend(std::iter::repeat_n(PairMemory::default(), n));
        let gpu = batch
            .collide_remembering(&ctx, &gpu_shapes, &queries, &mut memory)
            .expect("GPU batch");
        for (s, m) in motions.iter().enumerate() {
            let (a, b) = (&shapes[m.sa].shape, &shapes[m.sb].shape);
            let (pa, pb) = poses[s];
            let (remembering, full) = (&gpu[s], &gpu[n + s]);
            if remembering != full {
                let (mut h, mut bd) = (cpu_mem[s].hint, cpu_mem[s].margin);
                let c = narrow::collide_with_hint(a, &pa, b, &pb, &mut h, &mut bd);
                panic!(
                    "step {step}, pair {s}: the remembering GPU path differs from the full test: {remembering:?} vs {full:?}; GPU memory {:?} -> {:?}; CPU memory {:?} -> {h:#x} {bd}, CPU {c:?}, CPU full {:?}",
                    gpu_mem[s],
                    memory[s],
                    cpu_mem[s],
                    narrow::collide(a, &pa, b, &pb)
                );
            }
            bitwise += 1;
            let touching = full.count > 0;
            gpu_paths.count(touching, gpu_mem[s], memory[s]);
            if touching && parted[s] {
                retouched += 1;
                parted[s] = false;
            }
            parted[s] |= !touching && touched[s];
            touched[s] = touching;
            gpu_mem[s] = if touching {
                memory[s]
            } else {
                PairMemory::default()
            };
            if narrow::is_contact_hint(gpu_mem[s].hint) {
                let h = gpu_mem[s].hint;
                let kind = if h == narrow::HINT_EDGE_CONTACT {
                    2
                } else {
                    (h & narrow::HINT_KIND == narrow::HINT_FACE_B) as usize
                };
                kinds[kind] += 1;
                if last_kind[s].is_some_and(|k| (k == 2) != (kind == 2)) {
                    face_edge_changes += 1;
                }
                last_kind[s] = Some(kind);
            }
            // The CPU's remembering path on the same poses (its memory kept apart).
            let before = cpu_mem[s];
            let (mut hint, mut bound) = (before.hint, before.margin);
            if !narrow::is_contact_hint(hint) {
                (hint, bound) = (NO_HINT, 0.0);
            }
            let cpu_rem = narrow::collide_with_hint(a, &pa, b, &pb, &mut hint, &mut bound);
            let eval = |pa: &Pose, pb: &Pose| narrow::collide(a, pa, b, pb);
            let cpu = eval(&pa, &pb);
            assert_eq!(cpu_rem, cpu, "step {step}, pair {s}: CPU remembering path");
            let after = if cpu.is_some() && narrow::is_contact_hint(hint) {
                PairMemory {
                    hint,
                    margin: bound,
                }
            } else {
                PairMemory::default()
            };
            cpu_paths.count(cpu.is_some(), before, after);
            cpu_mem[s] = after;
            let size = a.bounding_radius().max(b.bounding_radius());
            let label = format!("step {step}, pair {s} (shapes {} and {})", m.sa, m.sb);
            let generic = !is_symmetric(&shapes, m.sa) && !is_symmetric(&shapes, m.sb);
            stats.check(generic, &label, cpu, full, size, &eval, &pa, &pb, &mut rng);
        }
        prev = poses;
    }
    eprintln!(
        "{steps} steps of {n} pairs on {} in {:.1} s; GPU paths {gpu_paths:?}, CPU paths {cpu_paths:?}; remembered contacts (face A, face B, edge): {kinds:?}; {bitwise} remembering manifolds bitwise the full test's",
        ctx.adapter_name(),
        t.elapsed().as_secs_f64()
    );
    // The GPU against the CPU: every manifold within the batch tolerance (near-ties
    // excused), however much generic shapes contribute here.
    let hard = stats.hard.len();
    for h in stats.hard.iter().take(20) {
        eprintln!("  {h}");
    }
    assert_eq!(hard, 0, "{hard} hard mismatches against the CPU");
    assert!(stats.near_ties * 25 <= stats.tested, "too many near-ties");
    let touching = gpu_paths.touching;
    assert!(
        touching * 2 > stats.tested,
        "too few touching pair-steps: {touching}"
    );
    assert!(touching < stats.tested, "no pair ever separated");
    assert!(
        gpu_paths.remembered() * 2 > touching,
        "the remembered path ran in {} of {touching} touching pair-steps",
        gpu_paths.remembered()
    );
    assert!(
        gpu_paths.face > 0 && gpu_paths.edge > 0,
        "both remembered paths: {gpu_paths:?}"
    );
    assert!(
        kinds.iter().all(|&k| k > 0),
        "contacts of each kind: {kinds:?}"
    );
    eprintln!(
        "{face_edge_changes} changes between face and edge contacts, {retouched} pairs touching again after parting"
    );
    assert!(
        face_edge_changes >= 10,
        "{face_edge_changes} face-edge changes"
    );
    assert!(retouched >= 5, "{retouched} pairs touched again");
}

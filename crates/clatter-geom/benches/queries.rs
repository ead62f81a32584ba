//! Queries per second of clatter's collision queries beside `parry3d` (f32, pinned) on the same
//! inputs: for each pair kind, 1024 seeded random pairs (about half of them overlapping), each
//! query timed over repeated passes until at least `CLATTER_BENCH_SECS` (default 0.7 s, split into 7 alternating rounds, best round kept).
//!
//! parry gets each shape as authored (`Ball`, `Cuboid`, `ConvexPolyhedron`) with the authored
//! pose; clatter gets the prepared shape with the principal-frame pose. Queries compared:
//! * intersects: `intersects` vs `intersection_test`;
//! * distance: `distance` (distance, closest points, normal) vs parry's `distance` (the scalar
//!   only, its fastest distance query) and `closest_points` (the points);
//! * contact: `contact` (depth, normal, points and a clipped manifold) vs `contact` with an
//!   unbounded prediction (one point pair, so also answering separated pairs like ours);
//! * toi: `time_of_impact` vs `cast_shapes_nonlinear` over a horizon of 1 with constant linear
//!   and angular velocities.
//!
//! Run: `cargo bench -p clatter-geom --bench queries` (prints a Markdown table).

use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

use clatter_geom::query::{self, Motion};
use clatter_geom::{Pose, RegularKind, Shape, ShapeKind};
use glam::{Quat, Vec3};
use parry3d::math::{Pose as PPose, Rot3 as PRot, Vector as PVec};
use parry3d::query::{self as pq, NonlinearRigidMotion};
use parry3d::shape::{Ball, ConvexPolyhedron as PPoly, Cuboid, Shape as PShape};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const N: usize = 1024;

fn pv(v: Vec3) -> PVec {
    PVec::new(v.x, v.y, v.z)
}

fn ppose(p: Vec3, q: Quat) -> PPose {
    PPose::from_parts(pv(p), PRot::from_xyzw(q.x, q.y, q.z, q.w))
}

#[derive(Clone)]
struct Body {
    shape: Shape,
    frame: Quat,
    com: Vec3,
    parry: Arc<dyn PShape>,
}

#[derive(Clone, Copy)]
enum Kind {
    Sphere,
    Box,
    Regular,
    Hull,
}

fn in_ball(rng: &mut ChaCha8Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length_squared() <= 1.0 {
            return v;
        }
    }
}

fn rotation(rng: &mut ChaCha8Rng) -> Quat {
    loop {
        let v = Quat::from_xyzw(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length_squared();
        if l > 0.01 && l <= 1.0 {
            return v.normalize();
        }
    }
}

fn body(rng: &mut ChaCha8Rng, kind: Kind) -> Body {
    let (k, parry): (ShapeKind, Arc<dyn PShape>) = match kind {
        Kind::Sphere => {
            let r: f32 = rng.random_range(0.3..0.8);
            (
                ShapeKind::Sphere { radius: r as f64 },
                Arc::new(Ball::new(r)),
            )
        }
        Kind::Box => {
            let h = Vec3::new(
                rng.random_range(0.2..0.8),
                rng.random_range(0.2..0.8),
                rng.random_range(0.2..0.8),
            );
            (
                ShapeKind::Box {
                    half_extents: [h.x as f64, h.y as f64, h.z as f64],
                },
                Arc::new(Cuboid::new(pv(h))),
            )
        }
        Kind::Regular => {
            let r: f32 = rng.random_range(0.3..0.8);
            let kind = RegularKind::Icosahedron;
            let pts: Vec<PVec> = kind.points(r as f64).into_iter().map(pv).collect();
            (
                ShapeKind::Regular {
                    kind,
                    radius: r as f64,
                },
                Arc::new(PPoly::from_convex_hull(&pts).unwrap()),
            )
        }
        Kind::Hull => {
            // 32 points on an ellipsoid: about 60 triangular faces.
            let s = Vec3::new(
                rng.random_range(0.3..0.8),
                rng.random_range(0.3..0.8),
                rng.random_range(0.3..0.8),
            );
            let pts: Vec<Vec3> = (0..32)
                .map(|_| in_ball(rng).normalize_or(Vec3::X) * s)
                .collect();
            (
                ShapeKind::Convex {
                    points: pts
                        .iter()
                        .map(|p| [p.x as f64, p.y as f64, p.z as f64])
                        .collect(),
                },
                Arc::new(
                    PPoly::from_convex_hull(&pts.iter().map(|&p| pv(p)).collect::<Vec<_>>())
                        .unwrap(),
                ),
            )
        }
    };
    let p = k.prepare().unwrap();
    Body {
        shape: p.shape,
        frame: p.frame,
        com: p.com,
        parry,
    }
}

struct Case {
    a: Body,
    b: Body,
    pa: Pose,
    pb: Pose,
    qa: PPose,
    qb: PPose,
    ma: Motion,
    mb: Motion,
    na: NonlinearRigidMotion,
    nb: NonlinearRigidMotion,
}

/// `N` random pairs whose shapes are drawn from pools of `pool` shapes per side.
fn cases(ka: Kind, kb: Kind, seed: u64, pool: usize) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pa: Vec<Body> = (0..pool).map(|_| body(&mut rng, ka)).collect();
    let pb: Vec<Body> = (0..pool).map(|_| body(&mut rng, kb)).collect();
    (0..N)
        .map(|_| {
            let a = pa[rng.random_range(0..pool)].clone();
            let b = pb[rng.random_range(0..pool)].clone();
            let (xa, xb) = (in_ball(&mut rng) * 0.9, in_ball(&mut rng) * 0.9);
            let (ra, rb) = (rotation(&mut rng), rotation(&mut rng));
            let toward = (xb - xa).normalize_or_zero();
            let ma = Motion {
                linear: toward * 2.0 + in_ball(&mut rng),
                angular: in_ball(&mut rng) * 3.0,
            };
            let mb = Motion {
                linear: -toward * 2.0 + in_ball(&mut rng),
                angular: in_ball(&mut rng) * 3.0,
            };
            // Motions start 2 units further apart so that most casts have work to do.
            let (xa, xb) = (xa - toward, xb + toward);
            let pa = Pose::new(xa + ra * a.com, ra * a.frame);
            let pb = Pose::new(xb + rb * b.com, rb * b.frame);
            let (qa, qb) = (ppose(xa, ra), ppose(xb, rb));
            let na = NonlinearRigidMotion::new(qa, pv(a.com), pv(ma.linear), pv(ma.angular));
            let nb = NonlinearRigidMotion::new(qb, pv(b.com), pv(mb.linear), pv(mb.angular));
            Case {
                a,
                b,
                pa,
                pb,
                qa,
                qb,
                ma,
                mb,
                na,
                nb,
            }
        })
        .collect()
}

/// Static poses for intersects/distance/contact: the motions' start poses moved back
/// together (the original centres), so about half the pairs overlap.
fn static_poses(c: &Case) -> (Pose, Pose, PPose, PPose) {
    let toward = (c.pb.position - c.pa.position).normalize_or_zero();
    let pa = Pose::new(c.pa.position + toward, c.pa.rotation);
    let pb = Pose::new(c.pb.position - toward, c.pb.rotation);
    let qa = PPose::from_parts(c.qa.translation + pv(toward), c.qa.rotation);
    let qb = PPose::from_parts(c.qb.translation - pv(toward), c.qb.rotation);
    (pa, pb, qa, qb)
}

fn secs() -> Duration {
    let s: f64 = std::env::var("CLATTER_BENCH_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.7);
    Duration::from_secs_f64(s)
}

/// CPU time of this thread in seconds (Linux `schedstat`), so that time spent descheduled by
/// other processes on a busy machine is not counted; `None` elsewhere (wall-clock is used).
fn cpu_time() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// Queries per second of each function over all cases. The functions are run in turn for
/// `ROUNDS` rounds (each a share of the time budget) and the best round of each is kept, so
/// that load from other processes on the machine penalises both sides alike.
fn qps(len: usize, fs: &mut [&mut dyn FnMut(usize) -> f32]) -> Vec<f64> {
    const ROUNDS: u32 = 7;
    let budget = secs() / ROUNDS;
    let mut best = vec![0.0f64; fs.len()];
    let mut acc = 0.0f32;
    for _ in 0..ROUNDS {
        for (k, f) in fs.iter_mut().enumerate() {
            let start = Instant::now();
            let cpu0 = cpu_time();
            let mut n = 0usize;
            while start.elapsed() < budget {
                for i in 0..len {
                    acc += f(i);
                }
                n += len;
            }
            let spent = match (cpu0, cpu_time()) {
                (Some(a), Some(b)) if b > a => b - a,
                _ => start.elapsed().as_secs_f64(),
            };
            best[k] = best[k].max(n as f64 / spent);
        }
    }
    black_box(acc);
    best
}

fn fmt(q: f64) -> String {
    if q >= 1e6 {
        format!("{:.2} M", q / 1e6)
    } else {
        format!("{:.0} k", q / 1e3)
    }
}

fn main() {
    let kinds = [
        ("sphere-sphere", Kind::Sphere, Kind::Sphere),
        ("sphere-box", Kind::Sphere, Kind::Box),
        ("box-box", Kind::Box, Kind::Box),
        ("sphere-hull", Kind::Sphere, Kind::Hull),
        ("box-hull", Kind::Box, Kind::Hull),
        ("icosahedron-icosahedron", Kind::Regular, Kind::Regular),
        ("hull-hull", Kind::Hull, Kind::Hull),
    ];
    // Optional filter on the pair name (for profiling one kind): CLATTER_BENCH_PAIR=box-box.
    let only = std::env::var("CLATTER_BENCH_PAIR").ok();
    let query_filter = std::env::var("CLATTER_BENCH_QUERY").ok();
    let want = |q: &str| query_filter.as_deref().is_none_or(|f| f == q);
    // Shapes per side: 16 by default (bodies share a few shapes, as in a simulation, and the
    // shapes stay in cache); CLATTER_BENCH_POOL=1024 gives every pair its own shapes.
    let pool: usize = std::env::var("CLATTER_BENCH_POOL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(16);
    println!("shapes per side: {pool}, pairs: {N}\n");
    println!("| pair | query | clatter (q/s) | parry3d (q/s) | ratio |");
    println!("|---|---|---:|---:|---:|");
    for (seed, (name, ka, kb)) in kinds.into_iter().enumerate() {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let cs = cases(ka, kb, seed as u64 + 100, pool);
        let st: Vec<_> = cs.iter().map(static_poses).collect();
        let row = |q: &str, ours: f64, theirs: f64| {
            println!(
                "| {name} | {q} | {} | {} | {:.2} |",
                fmt(ours),
                fmt(theirs),
                ours / theirs
            );
        };
        if want("intersects") {
            let r = qps(
                N,
                &mut [
                    &mut |i| {
                        let (c, (pa, pb, _, _)) = (&cs[i], &st[i]);
                        query::intersects(&c.a.shape, pa, &c.b.shape, pb) as u8 as f32
                    },
                    &mut |i| {
                        let (c, (_, _, qa, qb)) = (&cs[i], &st[i]);
                        pq::intersection_test(qa, &*c.a.parry, qb, &*c.b.parry)
                            .unwrap()
                            .intersecting as u8 as f32
                    },
                ],
            );
            row("intersects", r[0], r[1]);
        }
        if want("distance") {
            let r = qps(
                N,
                &mut [
                    &mut |i| {
                        let (c, (pa, pb, _, _)) = (&cs[i], &st[i]);
                        query::distance(&c.a.shape, pa, &c.b.shape, pb).distance
                    },
                    &mut |i| {
                        let (c, (_, _, qa, qb)) = (&cs[i], &st[i]);
                        pq::distance(qa, &*c.a.parry, qb, &*c.b.parry)
                            .unwrap()
                            .distance
                    },
                    &mut |i| {
                        let (c, (_, _, qa, qb)) = (&cs[i], &st[i]);
                        match pq::closest_points(qa, &*c.a.parry, qb, &*c.b.parry, f32::MAX)
                            .unwrap()
                        {
                            pq::ClosestPoints::WithinMargin(p, _) => p.x,
                            _ => 0.0,
                        }
                    },
                ],
            );
            row("distance", r[0], r[1]);
            row("distance (vs closest_points)", r[0], r[2]);
        }
        if want("contact") {
            let r = qps(
                N,
                &mut [
                    &mut |i| {
                        let (c, (pa, pb, _, _)) = (&cs[i], &st[i]);
                        query::contact(&c.a.shape, pa, &c.b.shape, pb).depth
                    },
                    &mut |i| {
                        let (c, (_, _, qa, qb)) = (&cs[i], &st[i]);
                        pq::contact(qa, &*c.a.parry, qb, &*c.b.parry, f32::MAX)
                            .unwrap()
                            .map(|k| k.dist)
                            .unwrap_or(0.0)
                    },
                ],
            );
            row("contact", r[0], r[1]);
        }
        if want("toi") {
            let r = qps(
                N,
                &mut [
                    &mut |i| {
                        let c = &cs[i];
                        query::time_of_impact(
                            &c.a.shape, &c.pa, &c.ma, &c.b.shape, &c.pb, &c.mb, 1.0,
                        )
                        .map(|t| t.time)
                        .unwrap_or(-1.0)
                    },
                    &mut |i| {
                        let c = &cs[i];
                        pq::cast_shapes_nonlinear(
                            &c.na,
                            &*c.a.parry,
                            &c.nb,
                            &*c.b.parry,
                            0.0,
                            1.0,
                            true,
                        )
                        .unwrap()
                        .map(|h| h.time_of_impact)
                        .unwrap_or(-1.0)
                    },
                ],
            );
            row("toi", r[0], r[1]);
        }
    }
}

//! `parry3d` (pinned dev-dependency) as an independent oracle for the collision queries, on
//! seeded random shapes and poses.
//!
//! Each query is checked on 10,000 random pairs of random convex hulls (4 to 40 points, offset
//! from the origin so the centre of mass and principal frame matter) and on 10,000 pairs of
//! mixed kinds (sphere, box, Platonic solid, hull, any pair). parry gets the shapes as the user
//! wrote them (authored frame, `Ball`/`Cuboid`/`ConvexPolyhedron`), clatter gets the prepared
//! shapes in their principal frame: the comparison also covers the frame bookkeeping.
//!
//! The oracle is the `f64` build of parry (`parry3d-f64`, same pinned version as the `f32`
//! `parry3d` the benchmark compares against): its GJK stops at a relative gap of
//! `sqrt(10 eps)`, about 1e-3 in `f32` but 5e-8 in `f64`, so only the `f64` build resolves the
//! 1e-4 tested here. Inputs are the same `f32` numbers for both libraries. Our principal-frame
//! vertices are rounded to `f32` after the change of frame, hence small absolute floors.
//!
//! Criteria:
//! * intersects: the same verdict, except within 1e-5 of touching;
//! * distance: within 1e-4 relative (floor 2e-6 absolute);
//! * penetration depth: within 1e-3 relative (floor 1e-5 absolute); moreover translating `b`
//!   along our normal by our depth plus 1e-4 separates the shapes, by parry's own test;
//! * time of impact: at our time parry measures a gap of at most our tolerance and no
//!   penetration; our time is never later than parry's; both agree within 1e-3 (relative to the
//!   horizon) where the approach is not grazing; when only one side finds an impact, parry's
//!   distance at that time adjudicates.

use clatter_geom::query::{self, Motion};
use clatter_geom::{Pose, RegularKind, Shape, ShapeKind};
use glam::{Quat, Vec3};
use parry3d_f64::math::{Pose as PPose, Rot3 as PRot, Vector as PVec};
use parry3d_f64::query::{self as pq, NonlinearRigidMotion};
use parry3d_f64::shape::{Ball, ConvexPolyhedron as PPoly, Cuboid, Shape as PShape};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const PAIRS: usize = 10_000;

fn pv(v: Vec3) -> PVec {
    PVec::new(v.x as f64, v.y as f64, v.z as f64)
}

fn gv(v: PVec) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}

/// A random shape in both libraries.
struct Body {
    shape: Shape,
    frame: Quat,
    com: Vec3,
    parry: Box<dyn PShape>,
    /// parry's polyhedron of the same shape (None for spheres): its face normals and edge
    /// directions are the candidate axes of the exact penetration depth.
    poly: Option<PPoly>,
    name: &'static str,
}

impl Body {
    fn pose(&self, position: Vec3, orientation: Quat) -> Pose {
        Pose::new(position + orientation * self.com, orientation * self.frame)
    }
}

fn ppose(position: Vec3, orientation: Quat) -> PPose {
    let q = orientation.as_dquat().normalize();
    PPose::from_parts(pv(position), PRot::from_xyzw(q.x, q.y, q.z, q.w))
}

fn random_rotation(rng: &mut ChaCha8Rng) -> Quat {
    loop {
        let q = Quat::from_xyzw(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = q.length_squared();
        if l > 0.01 && l <= 1.0 {
            return q.normalize();
        }
    }
}

fn random_in_ball(rng: &mut ChaCha8Rng) -> Vec3 {
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

fn make(kind: ShapeKind, parry: Box<dyn PShape>, poly: Option<PPoly>, name: &'static str) -> Body {
    let p = kind.prepare().expect("valid random shape");
    Body {
        shape: p.shape,
        frame: p.frame,
        com: p.com,
        parry,
        poly,
        name,
    }
}

fn random_hull(rng: &mut ChaCha8Rng) -> Body {
    let n = rng.random_range(4..=40);
    let scale = Vec3::new(
        rng.random_range(0.2..1.0),
        rng.random_range(0.2..1.0),
        rng.random_range(0.2..1.0),
    );
    let offset = random_in_ball(rng) * 0.5;
    loop {
        let pts: Vec<Vec3> = (0..n)
            .map(|_| random_in_ball(rng) * scale + offset)
            .collect();
        let Some(pp) = PPoly::from_convex_hull(&pts.iter().map(|&p| pv(p)).collect::<Vec<_>>())
        else {
            continue;
        };
        let kind = ShapeKind::Convex {
            points: pts
                .iter()
                .map(|p| [p.x as f64, p.y as f64, p.z as f64])
                .collect(),
        };
        if let Ok(prep) = kind.prepare() {
            // Skip slivers: both libraries need a proper solid.
            if prep.volume > 1e-3 {
                return Body {
                    shape: prep.shape,
                    frame: prep.frame,
                    com: prep.com,
                    parry: Box::new(pp.clone()),
                    poly: Some(pp),
                    name: "hull",
                };
            }
        }
    }
}

fn random_body(rng: &mut ChaCha8Rng, mixed: bool) -> Body {
    if !mixed {
        return random_hull(rng);
    }
    match rng.random_range(0..4) {
        0 => {
            let r: f32 = rng.random_range(0.1..1.0);
            make(
                ShapeKind::Sphere { radius: r as f64 },
                Box::new(Ball::new(r as f64)),
                None,
                "sphere",
            )
        }
        1 => {
            let h = Vec3::new(
                rng.random_range(0.1..1.0),
                rng.random_range(0.1..1.0),
                rng.random_range(0.1..1.0),
            );
            let corners: Vec<PVec> = (0..8)
                .map(|i| {
                    pv(h * Vec3::new(
                        if i & 1 == 0 { -1.0 } else { 1.0 },
                        if i & 2 == 0 { -1.0 } else { 1.0 },
                        if i & 4 == 0 { -1.0 } else { 1.0 },
                    ))
                })
                .collect();
            make(
                ShapeKind::Box {
                    half_extents: [h.x as f64, h.y as f64, h.z as f64],
                },
                Box::new(Cuboid::new(pv(h))),
                PPoly::from_convex_hull(&corners),
                "box",
            )
        }
        2 => {
            let kind = RegularKind::ALL[rng.random_range(0..5)];
            let r: f32 = rng.random_range(0.2..1.0);
            let pts: Vec<PVec> = kind.points(r as f64).into_iter().map(pv).collect();
            let pp = PPoly::from_convex_hull(&pts).expect("regular hull");
            make(
                ShapeKind::Regular {
                    kind,
                    radius: r as f64,
                },
                Box::new(pp.clone()),
                Some(pp),
                kind.name(),
            )
        }
        _ => random_hull(rng),
    }
}

/// A random pair with authored poses; `spread` scales the distance between centres.
struct PairCase {
    a: Body,
    b: Body,
    xa: Vec3,
    qa: Quat,
    xb: Vec3,
    qb: Quat,
}

impl PairCase {
    fn poses(&self) -> (Pose, Pose, PPose, PPose) {
        (
            self.a.pose(self.xa, self.qa),
            self.b.pose(self.xb, self.qb),
            ppose(self.xa, self.qa),
            ppose(self.xb, self.qb),
        )
    }
    fn label(&self) -> String {
        format!("{}-{}", self.a.name, self.b.name)
    }
}

fn random_pair(rng: &mut ChaCha8Rng, mixed: bool, spread: f32) -> PairCase {
    let a = random_body(rng, mixed);
    let b = random_body(rng, mixed);
    PairCase {
        a,
        b,
        xa: random_in_ball(rng) * spread,
        qa: random_rotation(rng),
        xb: random_in_ball(rng) * spread,
        qb: random_rotation(rng),
    }
}

fn parry_contact(c: &PairCase, pa: &PPose, pb: &PPose) -> f32 {
    pq::contact(pa, &*c.a.parry, pb, &*c.b.parry, 1e3)
        .expect("supported")
        .map(|k| k.dist as f32)
        .unwrap_or(f32::INFINITY)
}

fn run_intersects(seed: u64, mixed: bool) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut skipped, mut yes) = (0, 0);
    for i in 0..PAIRS {
        let c = random_pair(&mut rng, mixed, if mixed { 1.2 } else { 1.0 });
        let (ma, mb, pa, pb) = c.poses();
        let ours = query::intersects(&c.a.shape, &ma, &c.b.shape, &mb);
        let theirs = pq::intersection_test(&pa, &*c.a.parry, &pb, &*c.b.parry)
            .expect("supported")
            .intersecting;
        // Near touching (by either library's measure) the verdict is not compared.
        let sep_theirs = parry_contact(&c, &pa, &pb);
        let sep_ours = -query::contact(&c.a.shape, &ma, &c.b.shape, &mb).depth;
        if sep_theirs.abs() < 1e-5 || sep_ours.abs() < 1e-5 {
            skipped += 1;
            continue;
        }
        yes += ours as usize;
        assert_eq!(
            ours,
            theirs,
            "pair {i} ({}): ours {ours}, parry {theirs}, parry separation {sep_theirs}, ours {sep_ours}",
            c.label()
        );
    }
    eprintln!(
        "intersects (mixed={mixed}): {yes} overlapping of {PAIRS}, {skipped} near-touching skipped"
    );
    assert!(yes > PAIRS / 5 && yes < PAIRS * 4 / 5, "a balanced sample");
}

#[test]
fn intersects_hulls() {
    run_intersects(1, false);
}

#[test]
fn intersects_mixed() {
    run_intersects(2, true);
}

fn run_distance(seed: u64, mixed: bool) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut worst, mut worst_abs) = (0.0f32, 0.0f32);
    let mut separated = 0;
    for i in 0..PAIRS {
        let c = random_pair(&mut rng, mixed, 2.0);
        let (ma, mb, pa, pb) = c.poses();
        let ours = query::distance(&c.a.shape, &ma, &c.b.shape, &mb);
        let theirs = pq::distance(&pa, &*c.a.parry, &pb, &*c.b.parry)
            .expect("supported")
            .distance as f32;
        let err = (ours.distance - theirs).abs();
        let allowed = 1e-4 * theirs.max(ours.distance) + 1e-6;
        assert!(
            err <= allowed,
            "pair {i} ({}): ours {} parry {theirs}",
            c.label(),
            ours.distance
        );
        if theirs > 0.0 {
            separated += 1;
            worst_abs = worst_abs.max(err);
            if theirs > 1e-2 {
                worst = worst.max(err / theirs);
            }
            // The witness points are that far apart, along the normal, and each lies on its
            // shape (parry's own point-in-shape test after a 1e-4 nudge inwards/outwards).
            let gap = ours.points[1] - ours.points[0];
            assert!((gap.length() - ours.distance).abs() <= 1e-5 * (1.0 + ours.distance));
            assert!((gap - ours.normal * ours.distance).length() <= 1e-4 * (1.0 + ours.distance));
            let on_a = pq::distance(
                &pa,
                &*c.a.parry,
                &ppose(ours.points[0], Quat::IDENTITY),
                &Ball::new(1e-5),
            )
            .unwrap()
            .distance;
            let on_b = pq::distance(
                &pb,
                &*c.b.parry,
                &ppose(ours.points[1], Quat::IDENTITY),
                &Ball::new(1e-5),
            )
            .unwrap()
            .distance;
            assert!(
                on_a == 0.0 && on_b == 0.0,
                "pair {i}: witness points off the shapes"
            );
        } else {
            assert_eq!(ours.distance, 0.0, "pair {i}");
        }
    }
    eprintln!(
        "distance (mixed={mixed}): {separated} separated of {PAIRS}, worst absolute error {worst_abs:e}, worst relative error {worst:e} (distances above 0.01)"
    );
    assert!(separated > PAIRS / 4);
}

#[test]
fn distance_hulls() {
    run_distance(3, false);
}

#[test]
fn distance_mixed() {
    run_distance(4, true);
}

/// Support value of the CSO `A - B` along the world direction `n`, with parry's support maps.
fn cso_support(c: &PairCase, pa: &PPose, pb: &PPose, n: PVec) -> f64 {
    let sa =
        c.a.parry
            .as_support_map()
            .expect("convex")
            .support_point(pa, n);
    let sb =
        c.b.parry
            .as_support_map()
            .expect("convex")
            .support_point(pb, -n);
    (sa - sb).dot(n)
}

/// Exact penetration depth of two polyhedra: the smallest CSO support value over every
/// candidate facet normal of `A - B` (face normals of either, cross products of an edge of
/// each). The minimum over all directions is attained at a facet normal, and every facet
/// normal is in this set, so the minimum over the set is the depth. `None` for spheres.
fn exact_depth(c: &PairCase, pa: &PPose, pb: &PPose) -> Option<(f64, PVec)> {
    let (a, b) = (c.a.poly.as_ref()?, c.b.poly.as_ref()?);
    let mut best = (f64::INFINITY, PVec::X);
    let mut try_axis = |n: PVec| {
        let Some(n) = n.try_normalize() else { return };
        for n in [n, -n] {
            let h = cso_support(c, pa, pb, n);
            if h < best.0 {
                best = (h, n);
            }
        }
    };
    for f in a.faces() {
        try_axis(pa.rotation * f.normal);
    }
    for f in b.faces() {
        try_axis(pb.rotation * f.normal);
    }
    for ea in a.edges() {
        let da = pa.rotation * ea.dir;
        for eb in b.edges() {
            try_axis(da.cross(pb.rotation * eb.dir));
        }
    }
    Some(best)
}

fn run_contact(seed: u64, mixed: bool) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut worst = 0.0f32;
    let mut n = 0;
    let mut ours_smaller = 0;
    let (mut adjudicated, mut parry_inconsistent) = (0, 0);
    for i in 0..PAIRS {
        let c = random_pair(&mut rng, mixed, 0.8);
        let (ma, mb, pa, pb) = c.poses();
        let ours = query::contact(&c.a.shape, &ma, &c.b.shape, &mb);
        let theirs = pq::contact(&pa, &*c.a.parry, &pb, &*c.b.parry, 0.0).expect("supported");
        let Some(theirs) = theirs else {
            assert!(
                ours.depth <= 1e-5,
                "pair {i} ({}): ours {ours:?}, parry none",
                c.label()
            );
            continue;
        };
        let tdepth = -theirs.dist as f32;
        if tdepth <= 0.0 {
            continue;
        }
        n += 1;
        let mut reference = tdepth;
        if (ours.depth - tdepth).abs() > 1e-3 * tdepth + 1e-5 {
            // Disagreement: the exact depth decides, and parry's own answer is checked
            // against the CSO support along its normal (EPA stopping early reports less).
            let (exact, _) = exact_depth(&c, &pa, &pb).unwrap_or_else(|| {
                panic!("pair {i} ({}): ours {ours:?}, parry {theirs:?}", c.label())
            });
            let h = cso_support(&c, &pa, &pb, theirs.normal1);
            if (h - tdepth as f64).abs() > 1e-6 * (1.0 + h) {
                parry_inconsistent += 1;
            }
            adjudicated += 1;
            reference = exact as f32;
        }
        let err = (ours.depth - reference).abs();
        if ours.depth < tdepth - 1e-5 {
            ours_smaller += 1;
        }
        worst = worst.max(err / reference.max(0.01));
        assert!(
            err <= 1e-3 * reference + 1e-5,
            "pair {i} ({}): ours {} along {:?}, reference {reference}, parry {tdepth} along {:?}",
            c.label(),
            ours.depth,
            ours.normal,
            gv(theirs.normal1)
        );
        assert!((ours.normal.length() - 1.0).abs() < 1e-5);
        // Our normal and depth separate the shapes by parry's own intersection test, and a
        // slightly shorter move does not.
        let size = c.a.shape.bounding_radius() + c.b.shape.bounding_radius();
        let moved = |by: f32| ppose(c.xb + ours.normal * by, c.qb);
        let hit = |p: &PPose| {
            pq::intersection_test(&pa, &*c.a.parry, p, &*c.b.parry)
                .unwrap()
                .intersecting
        };
        assert!(
            !hit(&moved(ours.depth + 1e-4 * size)),
            "pair {i} ({}): not separated",
            c.label()
        );
        if ours.depth > 1e-3 * size {
            assert!(
                hit(&moved(ours.depth - 1e-4 * size)),
                "pair {i} ({}): over-separated",
                c.label()
            );
        }
        // Witness points: on (within 1e-5 of) each shape, b's depth behind a's along the normal;
        // contact points exist.
        for (k, shape, pose) in [(0, &c.a.parry, &pa), (1, &c.b.parry, &pb)] {
            let off = pq::distance(
                pose,
                &**shape,
                &ppose(ours.points[k], Quat::IDENTITY),
                &Ball::new(1e-5),
            )
            .unwrap()
            .distance;
            assert!(
                off == 0.0,
                "pair {i} ({}): witness point {k} off its shape by {off}",
                c.label()
            );
        }
        // The whole offset, not only its part along the normal (docs/queries.md:
        // `points[0] - points[1] = depth * normal`).
        let off = ours.points[0] - ours.points[1] - ours.normal * ours.depth;
        assert!(
            off.length() <= 1e-4 * (1.0 + ours.depth),
            "pair {i} ({}): witness points {:?} differ from depth * normal by {off:?}",
            c.label(),
            ours.points
        );
        assert!(!ours.manifold.is_empty());
    }
    eprintln!(
        "contact (mixed={mixed}): {n} penetrating of {PAIRS}, worst relative depth error {worst:e}, ours smaller than parry in {ours_smaller}; {adjudicated} disagreements decided by the exact depth, in {parry_inconsistent} of them parry's depth is not the support along its own normal"
    );
    assert!(n > PAIRS / 4);
}

#[test]
fn contact_hulls() {
    run_contact(5, false);
}

#[test]
fn contact_mixed() {
    run_contact(6, true);
}

fn random_motion(rng: &mut ChaCha8Rng, toward: Vec3) -> Motion {
    Motion {
        linear: toward * rng.random_range(0.0..4.0) + random_in_ball(rng) * 2.0,
        angular: random_in_ball(rng) * 4.0,
    }
}

/// parry's separation (negative: penetration) at time `t` of the motions.
fn parry_sep_at(c: &PairCase, m1: &NonlinearRigidMotion, m2: &NonlinearRigidMotion, t: f32) -> f32 {
    parry_contact(
        c,
        &m1.position_at_time(t as f64),
        &m2.position_at_time(t as f64),
    )
}

fn run_toi(seed: u64, mixed: bool) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let horizon = 1.0f32;
    let (mut hits, mut both, mut not_converged, mut worst_dt) = (0, 0, 0, 0.0f32);
    let mut agree = 0;
    let mut parry_missed = 0;
    for i in 0..PAIRS {
        let c = random_pair(&mut rng, mixed, 2.5);
        let (ma, mb, _, _) = c.poses();
        let toward = (c.xb - c.xa).normalize_or_zero();
        let mota = random_motion(&mut rng, toward);
        let motb = random_motion(&mut rng, -toward);
        let ours = query::time_of_impact(&c.a.shape, &ma, &mota, &c.b.shape, &mb, &motb, horizon);
        // parry rotates about the centre of mass, given in the shape's (authored) frame.
        let m1 = NonlinearRigidMotion::new(
            ppose(c.xa, c.qa),
            pv(c.a.com),
            pv(mota.linear),
            pv(mota.angular),
        );
        let m2 = NonlinearRigidMotion::new(
            ppose(c.xb, c.qb),
            pv(c.b.com),
            pv(motb.linear),
            pv(motb.angular),
        );
        let theirs = pq::cast_shapes_nonlinear(
            &m1,
            &*c.a.parry,
            &m2,
            &*c.b.parry,
            0.0,
            horizon as f64,
            true,
        )
        .expect("supported")
        .filter(|h| h.status != pq::ShapeCastStatus::Failed)
        .map(|h| h.time_of_impact as f32);
        let size = c.a.shape.bounding_radius() + c.b.shape.bounding_radius();
        let tol = query::TOI_REL_TOL as f32 * size;
        match ours {
            Some(t) => {
                hits += 1;
                not_converged += (!t.converged) as usize;
                assert!(t.time >= 0.0 && t.time <= horizon && t.normal.is_finite());
                // At our time the shapes are at most `tol` apart and not penetrating.
                let s = parry_sep_at(&c, &m1, &m2, t.time);
                if t.time > 0.0 {
                    assert!(
                        s >= -2e-5 && (s <= tol + 2e-5 || !t.converged),
                        "pair {i} ({}): parry separation {s} at our time {}",
                        c.label(),
                        t.time
                    );
                } else {
                    assert!(s <= 2e-5, "pair {i}: time 0 but parry separation {s}");
                }
                // No contact before our time (sampled; conservative advancement proves it).
                for k in 0..8 * (t.time > 0.0) as usize {
                    let tk = t.time * k as f32 / 8.0;
                    let sk = parry_sep_at(&c, &m1, &m2, tk);
                    assert!(
                        sk > -1e-6,
                        "pair {i} ({}): penetration {sk} at {tk} < {}",
                        c.label(),
                        t.time
                    );
                }
                // Never later than parry's impact (which parry places at or just after contact).
                if let Some(tp) = theirs {
                    both += 1;
                    assert!(
                        t.time <= tp + 1e-4,
                        "pair {i} ({}): ours {} after parry {tp}",
                        c.label(),
                        t.time
                    );
                    worst_dt = worst_dt.max(tp - t.time);
                    agree += (tp - t.time <= 1e-3 * horizon) as usize;
                } else {
                    parry_missed += 1;
                }
            }
            None => {
                if let Some(tp) = theirs {
                    // parry claims an impact we did not find: it must not be a real one.
                    let s = parry_sep_at(&c, &m1, &m2, tp);
                    assert!(
                        s > 1e-4 * size,
                        "pair {i} ({}): parry impact at {tp} (separation {s}) missed",
                        c.label()
                    );
                }
            }
        }
    }
    eprintln!(
        "toi (mixed={mixed}): {hits} impacts of {PAIRS} ({both} also found by parry, {agree} of them within 1e-3 of parry's time; {parry_missed} found only by us), {not_converged} not converged, largest lead over parry {worst_dt:e}"
    );
    assert!(hits > PAIRS / 5);
}

#[test]
fn toi_hulls() {
    run_toi(7, false);
}

#[test]
fn toi_mixed() {
    run_toi(8, true);
}

/// Exactly touching configurations (the harder case for GJK/EPA termination): an overlapping
/// pair is pulled apart along our contact normal by our depth. Then the distance (by parry and
/// by us) and our depth are zero to within 1e-5, and nothing is NaN.
#[test]
fn touching_pairs() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut n = 0;
    while n < 2_000 {
        let mut c = random_pair(&mut rng, n % 2 == 0, 0.6);
        let (ma, mb, _, _) = c.poses();
        let k = query::contact(&c.a.shape, &ma, &c.b.shape, &mb);
        if k.depth <= 1e-3 {
            continue;
        }
        n += 1;
        c.xb += k.normal * k.depth;
        let (ma, mb, pa, pb) = c.poses();
        let d = query::distance(&c.a.shape, &ma, &c.b.shape, &mb);
        let k2 = query::contact(&c.a.shape, &ma, &c.b.shape, &mb);
        let theirs = pq::distance(&pa, &*c.a.parry, &pb, &*c.b.parry)
            .unwrap()
            .distance;
        let size = c.a.shape.bounding_radius() + c.b.shape.bounding_radius();
        assert!(d.distance.is_finite() && d.points[0].is_finite() && d.normal.is_finite());
        assert!(k2.depth.is_finite() && k2.normal.is_finite() && k2.points[1].is_finite());
        assert!(
            d.distance <= 1e-5 * size,
            "pair {n} ({}): distance {}",
            c.label(),
            d.distance
        );
        assert!(
            theirs <= 1e-5 * size as f64,
            "pair {n} ({}): parry distance {theirs}",
            c.label()
        );
        assert!(
            k2.depth.abs() <= 1e-5 * size,
            "pair {n} ({}): depth {}",
            c.label(),
            k2.depth
        );
        let _ = query::intersects(&c.a.shape, &ma, &c.b.shape, &mb);
    }
}

/// The simulator's narrow phase (`narrow::collide`: separating axes, clipped manifolds) against
/// the exact penetration depth and parry: the same overlap verdict, a normal along which
/// moving `b` by the exact depth (plus the face-preference hysteresis of 1e-3 of the size,
/// doubled for rounding)
/// separates the shapes, manifold depths never beyond the exact depth (same allowance), and every contact
/// point inside the overlap region (within the depth of both shapes).
fn run_narrow(seed: u64, mixed: bool) {
    use clatter_geom::narrow;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut touching, mut separated, mut points) = (0, 0, 0);
    for i in 0..PAIRS {
        let c = random_pair(&mut rng, mixed, 0.8);
        let (ma, mb, pa, pb) = c.poses();
        let size = c.a.shape.bounding_radius() + c.b.shape.bounding_radius();
        let ours = narrow::collide(&c.a.shape, &ma, &c.b.shape, &mb);
        let theirs = pq::contact(&pa, &*c.a.parry, &pb, &*c.b.parry, 0.0).expect("supported");
        let depth = match (exact_depth(&c, &pa, &pb), &theirs) {
            (Some((d, _)), _) => d as f32,
            (None, Some(t)) => -t.dist as f32,
            (None, None) => f32::NEG_INFINITY,
        };
        let label = c.label();
        if depth < -1e-5 * size {
            separated += 1;
            assert!(
                ours.is_none(),
                "pair {i} ({label}): separated by {} but narrow gave {ours:?}",
                -depth
            );
            continue;
        }
        if depth < 1e-4 * size {
            continue; // touching within rounding: either verdict is fine
        }
        let m = ours.unwrap_or_else(|| panic!("pair {i} ({label}): overlap {depth} missed"));
        touching += 1;
        assert!((m.normal.length() - 1.0).abs() < 1e-4, "pair {i} ({label})");
        assert!(m.count >= 1 && m.count <= 4);
        let moved = ppose(c.xb + m.normal * (depth + 2e-3 * size), c.qb);
        assert!(
            !pq::intersection_test(&pa, &*c.a.parry, &moved, &*c.b.parry)
                .unwrap()
                .intersecting,
            "pair {i} ({label}): moving b by the exact depth {depth} along {:?} does not separate",
            m.normal
        );
        for p in m.points() {
            points += 1;
            assert!(
                p.depth > 0.0 && p.depth <= depth + 2e-3 * size,
                "pair {i} ({label}): point depth {} vs exact {depth}",
                p.depth
            );
            for (shape, pose) in [(&c.a.parry, &pa), (&c.b.parry, &pb)] {
                let off = pq::distance(
                    pose,
                    &**shape,
                    &ppose(p.point, Quat::IDENTITY),
                    &Ball::new(1e-9),
                )
                .unwrap()
                .distance as f32;
                assert!(
                    off <= depth + 2e-3 * size,
                    "pair {i} ({label}): contact point {off} outside a shape (depth {depth})"
                );
            }
        }
    }
    eprintln!(
        "narrow (mixed={mixed}): {touching} overlapping, {separated} separated, {points} contact points checked"
    );
    assert!(touching > PAIRS / 4 && separated > PAIRS / 20);
}

#[test]
fn narrow_hulls() {
    run_narrow(11, false);
}

#[test]
fn narrow_mixed() {
    run_narrow(12, true);
}

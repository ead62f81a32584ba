//! The remembered certificate ([`Certificate`], [`remembered_certified`]) against the
//! truth: measured, it decides as the two certificates do; taken at a later pose, the
//! bodies there overlap by at least `delta` along every axis of the full test (brute force
//! in f64), and the full test finds them touching.

use glam::{DMat3, DVec3, Mat3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::super::clip::{ClipBuffers, clip_faces};
use super::super::slack::Plan;
use super::super::{HINT_FACE_A, Manifold, NO_HINT, polyhedron_polyhedron};
use super::{
    Certificate, incident_centroid, overlap_certified, remembered_certified, wedge_certified,
};
use crate::{ConvexPolyhedron, Pose};

use crate::narrow::test_shapes::cuboid;

/// The incident body's rotation in the reference frame and its vertex `i` there, for a
/// reference face of A (`kind` [`HINT_FACE_A`]: B's vertices `rot v + t`) or of B (A's,
/// `rot^T (v - t)`), as `remembered_face` computes them.
fn frame(kind: u32, q: Quat, t: Vec3) -> (Mat3, impl Fn(&ConvexPolyhedron, usize) -> Vec3) {
    let rot = Mat3::from_quat(q);
    let inc_rot = if kind == HINT_FACE_A {
        rot
    } else {
        rot.transpose()
    };
    let map = move |p: &ConvexPolyhedron, i: usize| {
        if kind == HINT_FACE_A {
            rot * p.vertices[i] + t
        } else {
            rot.transpose() * (p.vertices[i] - t)
        }
    };
    (inc_rot, map)
}

/// The largest separation of the two bodies along every axis of the full test (the face
/// normals of both, the cross products of their edges), both ways, in f64 from the same
/// f32 rotation matrix: the incident vertices `M v + t` (A's face) or `M^T (v - t)`.
fn largest_separation(
    kind: u32,
    refp: &ConvexPolyhedron,
    inc: &ConvexPolyhedron,
    q: Quat,
    t: Vec3,
) -> f64 {
    let m = Mat3::from_quat(q).as_dmat3();
    let t = t.as_dvec3();
    let (lin, off): (DMat3, DVec3) = if kind == HINT_FACE_A {
        (m, t)
    } else {
        (m.transpose(), -(m.transpose() * t))
    };
    let rv: Vec<DVec3> = refp.vertices.iter().map(|v| v.as_dvec3()).collect();
    let iv: Vec<DVec3> = inc
        .vertices
        .iter()
        .map(|v| lin * v.as_dvec3() + off)
        .collect();
    let mut axes: Vec<DVec3> = refp.faces.iter().map(|f| f.normal.as_dvec3()).collect();
    axes.extend(
        inc.faces
            .iter()
            .map(|f| (lin * f.normal.as_dvec3()).normalize()),
    );
    for e in &refp.edges {
        let d = rv[e[1] as usize] - rv[e[0] as usize];
        for g in &inc.edges {
            let c = d.cross(iv[g[1] as usize] - iv[g[0] as usize]);
            if c.length() > 1e-9 * d.length() {
                axes.push(c.normalize());
            }
        }
    }
    let span = |p: &[DVec3], u: DVec3| {
        p.iter()
            .map(|v| v.dot(u))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
    };
    axes.iter()
        .map(|&u| {
            let (rlo, rhi) = span(&rv, u);
            let (ilo, ihi) = span(&iv, u);
            (ilo - rhi).max(rlo - ihi)
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// `main`'s [`wedge_certified`] before the certificates gave their room (issue 23, cert36):
/// the reference of the measured decision.
#[allow(clippy::too_many_arguments)]
fn old_wedge_certified(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    to_inc: impl Fn(Vec3) -> Vec3,
    inc_rot: Mat3,
    m: &Manifold,
    delta: f32,
) -> bool {
    // Clipped points on a side plane are crossings of the incident face's edges: one or two
    // (more are corners inside the face, where the first certificate failed for depth).
    if m.count > 2 {
        return false;
    }
    let n = m.normal;
    let c = incident_centroid(m);
    // Shallower than `delta` along the reference normal: no ball fits (and NaN returns).
    let s1 = n.dot(c) - refp.faces[rf].offset;
    if s1.partial_cmp(&-delta) != Some(std::cmp::Ordering::Less) {
        return false;
    }
    old_ball_certified(refp, Some(rf), inc, to_inc, inc_rot, c, delta)
}

/// `main`'s `ball_certified` (see [`old_wedge_certified`]).
fn old_ball_certified(
    refp: &ConvexPolyhedron,
    first: Option<usize>,
    inc: &ConvexPolyhedron,
    to_inc: impl Fn(Vec3) -> Vec3,
    inc_rot: Mat3,
    c: Vec3,
    delta: f32,
) -> bool {
    // The face planes nearest `c`, (separation, normal in `refp`'s frame), nearest first
    // (`first`'s ahead of all).
    let mut near = [(f32::NEG_INFINITY, Vec3::ZERO); 4];
    let mut take = |s: f32, normal: Vec3| {
        let mut k = 3;
        if s > near[k].0 {
            near[k] = (s, normal);
            while k > 0 && near[k].0 > near[k - 1].0 {
                near.swap(k, k - 1);
                k -= 1;
            }
        }
    };
    for (f, face) in refp.faces.iter().enumerate() {
        if Some(f) != first {
            take(face.normal.dot(c) - face.offset, face.normal);
        }
    }
    let c_inc = to_inc(c);
    for face in &inc.faces {
        take(face.normal.dot(c_inc) - face.offset, inc_rot * face.normal);
    }
    if let Some(f) = first {
        let face = refp.faces[f];
        near.copy_within(0..3, 1);
        near[0] = (face.normal.dot(c) - face.offset, face.normal);
    }
    let half = 0.5 * delta;
    let inside = |p: Vec3| {
        let p_inc = to_inc(p);
        refp.faces
            .iter()
            .all(|f| f.normal.dot(p) - f.offset <= -half)
            && inc
                .faces
                .iter()
                .all(|f| f.normal.dot(p_inc) - f.offset <= -half)
    };
    // `c + u` with `n_i.u + r = -s_i` (`r` inside each plane), and `e.u = 0` for the disc.
    let [(s1, n1), (s2, n2), (s3, n3), (s4, n4)] = near;
    let solve = |last: glam::Vec4, rhs: f32| {
        let rows =
            glam::Mat4::from_cols(n1.extend(1.0), n2.extend(1.0), n3.extend(1.0), last).transpose();
        c + (rows.inverse() * glam::Vec4::new(-s1, -s2, -s3, rhs)).truncate()
    };
    inside(solve(n4.extend(1.0), -s4)) || inside(solve(n1.cross(n2).extend(0.0), 0.0))
}

/// Boxes (a cube, a flat box) and random hulls resting on a face of one another, shallow
/// and deeper, over the face or across its side (one or two clipped points, the ball's
/// certificate), both kinds of reference face: measured at one pose, the remembered
/// certificate decides as [`overlap_certified`] `||` [`wedge_certified`] (the old path);
/// anchored, at poses moved from the anchor by a fraction to a few times its room (pulled
/// apart along the reference normal, where the bound is tight; turned about B's origin so
/// that the centroid's point moves out along the normal, where the centroid's lever is
/// tight; or turned and shifted; the quaternion's norm off 1 by up to 5e-7), wherever it still holds, every axis of the full
/// test separates the bodies by at most `-delta` (the certificates' claim, less a part of
/// `delta` for the f32 poses' rounding) and the full test with no hint finds them touching.
#[test]
fn remembered_certificates_hold_at_moved_poses() {
    let mut r = ChaCha8Rng::seed_from_u64(36);
    let mut shapes = vec![cuboid(Vec3::splat(0.01)), cuboid(Vec3::new(0.5, 0.2, 0.3))];
    for _ in 0..2 {
        let v: Vec<Vec3> = (0..r.random_range(8..20))
            .map(|_| Vec3::new(r.random(), r.random(), r.random()) - 0.5)
            .collect();
        shapes.push(crate::convex_hull(&v).expect("random hull"));
    }
    let mut buffers = ClipBuffers::default();
    let (mut wedges, mut measured, mut anchored, mut balls, mut held, mut tight, mut beyond) =
        (0, 0, 0, 0, 0, 0, 0);
    for case in 0..10_000 {
        let boxes = case % 4 != 3;
        let (ia, ib) = if boxes {
            (case % 2, case / 2 % 2)
        } else {
            (
                r.random_range(0..shapes.len()),
                r.random_range(0..shapes.len()),
            )
        };
        let (a, b) = (&shapes[ia], &shapes[ib]);
        let kind = if case % 3 == 0 {
            super::super::HINT_FACE_B
        } else {
            HINT_FACE_A
        };
        let (refp, inc) = if kind == HINT_FACE_A { (a, b) } else { (b, a) };
        let rf = r.random_range(0..refp.faces.len());
        let face = refp.faces[rf];
        let n = face.normal;
        let jitter = |r: &mut ChaCha8Rng, s: f32| {
            let axis = Vec3::new(r.random(), r.random(), r.random()) - 0.5;
            Quat::from_axis_angle(axis.normalize(), s * r.random::<f32>())
        };
        let q0 = if boxes {
            let quarter = std::f32::consts::FRAC_PI_2;
            let turn = |r: &mut ChaCha8Rng, v: Vec3| {
                Quat::from_axis_angle(v, quarter * r.random_range(0..4) as f32)
            };
            let tilt = [0.0, 0.01, 0.05, 0.3][case % 4];
            (turn(&mut r, Vec3::X) * turn(&mut r, Vec3::Y) * jitter(&mut r, tilt)).normalize()
        } else {
            Quat::from_array([0.0f32; 4].map(|_| r.random_range(-1.0f32..1.0))).normalize()
        };
        // The incident body `depth` through the face plane, its origin moved along the face.
        let size = refp.radius.min(inc.radius);
        let delta = 2e-5 * (a.radius + b.radius);
        let depth = delta * [0.5, 1.5, 3.0, 10.0, 50.0][r.random_range(0..5)];
        // (Up to the incident body's size half the time: the centroid then far from B's
        // origin across the normal, where a turn about it moves the centroid's point out.)
        let spread = if case % 8 < 4 { size } else { inc.radius };
        let lateral = (Vec3::new(r.random(), r.random(), r.random()) - 0.5) * spread * 1.5;
        let place = |q: Quat, at: Vec3| {
            if kind == HINT_FACE_A {
                at
            } else {
                -(Mat3::from_quat(q) * at)
            }
        };
        let (_, v0) = frame(kind, q0, Vec3::ZERO);
        let lowest = (0..inc.vertices.len())
            .map(|i| v0(inc, i))
            .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))
            .expect("a hull has vertices");
        let at0 = if case % 2 == 0 {
            n * (face.offset - depth - n.dot(lowest)) + (lateral - n * n.dot(lateral))
        } else {
            // The lowest incident vertex near a side of the face, just inside or past it.
            let lp = refp.face_loop(rf);
            let k = r.random_range(0..lp.len());
            let (e0, e1) = (
                refp.vertices[lp[k] as usize],
                refp.vertices[lp[(k + 1) % lp.len()] as usize],
            );
            let centre =
                lp.iter().map(|&i| refp.vertices[i as usize]).sum::<Vec3>() / lp.len() as f32;
            let e = e1 - e0;
            let mid = 0.5 * (e0 + e1);
            let side = n.cross(e).normalize();
            let side = if side.dot(mid - centre) < 0.0 {
                -side
            } else {
                side
            };
            let past = size * r.random_range(-0.02f32..0.02);
            let target = mid + e * r.random_range(-0.4f32..0.4) + side * past - n * depth;
            target - lowest
        };
        let t0 = place(q0, at0);
        let (inc_rot, inc_v) = frame(kind, q0, t0);
        let inc_v0 = |i: usize| inc_v(inc, i);
        let Some(m0) = clip_faces(refp, rf, inc, inc_v0, inc_rot, &mut buffers, &Plan::FULL) else {
            continue;
        };
        let to_inc = move |p: Vec3| {
            let rot = Mat3::from_quat(q0);
            if kind == HINT_FACE_A {
                rot.transpose() * (p - t0)
            } else {
                rot * p + t0
            }
        };
        let lever = if kind == HINT_FACE_A {
            inc.radius
        } else {
            inc.radius + t0.length() * (1.0 + 1e-6)
        };
        // Measured: the old path's decision.
        let old = overlap_certified(refp, &m0, delta)
            || old_wedge_certified(refp, rf, inc, to_inc, inc_rot, &m0, delta);
        let wedge = wedge_certified(refp, rf, inc, to_inc, inc_rot, &m0, delta);
        assert_eq!(
            wedge,
            old_wedge_certified(refp, rf, inc, to_inc, inc_rot, &m0, delta),
            "case {case}: the ball's certificate"
        );
        wedges += wedge as usize;
        let mut cert = Certificate::default();
        let origin_b = if kind == HINT_FACE_A { t0 } else { Vec3::ZERO };
        let centroid = incident_centroid(&m0);
        let pose = (q0, t0, origin_b, || lever);
        let got = remembered_certified(
            Some(&mut cert),
            refp,
            rf,
            inc,
            to_inc,
            inc_rot,
            &m0,
            delta,
            pose,
        );
        assert_eq!(got, old, "case {case}: measured");
        measured += 1;
        if got {
            let truth = largest_separation(kind, refp, inc, q0, t0);
            assert!(
                truth <= -0.9 * delta as f64,
                "case {case}: certified at separation {truth}"
            );
        }
        if !cert.room.is_finite() {
            continue;
        }
        anchored += 1;
        balls += cert.ball as usize;
        assert!(
            got && cert.room > 0.0,
            "case {case}: anchored without a certificate"
        );
        for step in 0..15 {
            let reach =
                cert.room * [0.3, 0.9, 0.99, 1.0, 1.01, 1.1, 2.0, 4.0][r.random_range(0..8)];
            let (q1, t1) = match step % 3 {
                0 => {
                    // Pulled apart along the normal: the separation along it grows by as
                    // much.
                    let q = q0 * (1.0 + r.random_range(-2.5e-7f32..2.5e-7));
                    (q, place(q, at0 + n * reach))
                }
                1 => {
                    let q = (q0 * jitter(&mut r, reach / lever)).normalize();
                    let shift = (Vec3::new(r.random(), r.random(), r.random()) - 0.5) * reach;
                    let q = q * (1.0 + r.random_range(-2.5e-7f32..2.5e-7));
                    (q, place(q, at0 + shift))
                }
                _ => {
                    // Turned about B's origin (`t` kept) so that the centroid's point moves
                    // out along the normal by about `reach`: the centroid's own lever.
                    let d = centroid - origin_b;
                    let axis = d.cross(n).normalize_or_zero();
                    let turn = Quat::from_axis_angle(axis, reach / d.length().max(1e-12));
                    // B's vertices `M v + t` turned in A's frame, or A's `M^T (v - t)` in B's.
                    let q = if kind == HINT_FACE_A {
                        turn * q0
                    } else {
                        q0 * turn.conjugate()
                    };
                    (q * (1.0 + r.random_range(-2.5e-7f32..2.5e-7)), t0)
                }
            };
            let truth = largest_separation(kind, refp, inc, q1, t1);
            if !cert.holds(q1, t1) {
                beyond += (truth > -0.5 * delta as f64) as usize;
                continue;
            }
            held += 1;
            tight += (truth > -2.0 * delta as f64) as usize;
            assert!(
                truth <= -0.9 * delta as f64,
                "case {case} step {step}: certified at separation {truth} (delta {delta}, room {})",
                cert.room
            );
            // The full test with no hint: touching (A at the origin, B at `t1`, `q1`).
            let pb = Pose::new(t1, q1);
            let (mut hint, mut bound) = (NO_HINT, 0.0);
            let full = polyhedron_polyhedron(
                a,
                &Pose::new(Vec3::ZERO, Quat::IDENTITY),
                b,
                &pb,
                &mut hint,
                &mut bound,
            );
            assert!(
                full.is_some(),
                "case {case} step {step}: the full test found them apart"
            );
        }
    }
    println!(
        "{measured} measured ({wedges} by the ball), {anchored} anchored ({balls} balls), {held} held ({tight} within \
         2 delta of the claim), {beyond} not held beyond it"
    );
    assert!(
        measured > 5_000 && anchored > 2_000,
        "{measured} {anchored}"
    );
    assert!(wedges > 300 && balls > 150, "{wedges} {balls}");
    assert!(
        held > 5_000 && tight > 500 && beyond > 1_000,
        "{held} {tight} {beyond}"
    );
}

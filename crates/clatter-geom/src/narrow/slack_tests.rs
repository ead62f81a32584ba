//! The record's decisions against brute force: at poses near a record's, whatever a plan
//! takes from it is checked against the full computation at the new pose.

use glam::{Mat3, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::super::clip::{ClipBuffers, clip_faces, incident_face};
use super::super::{HINT_FACE_A, HINT_FACE_B, Manifold};
use super::{Anchor, FaceSlack, Plan};
use crate::ConvexPolyhedron;

use crate::narrow::test_shapes::cuboid;

/// A vertex of the incident body in the reference frame, by its index.
type Vertex = Box<dyn Fn(&ConvexPolyhedron, usize) -> Vec3>;

/// The incident body's vertex `i` in the reference frame, for a reference face of A
/// (`kind` [`HINT_FACE_A`]: B's vertices `rot v + t`) or of B (A's, `rot^T (v - t)`), and
/// the incident rotation the clip takes.
fn frame(kind: u32, q: Quat, t: Vec3) -> (Mat3, Vertex) {
    let rot = Mat3::from_quat(q);
    if kind == HINT_FACE_A {
        (rot, Box::new(move |p, i| rot * p.vertices[i] + t))
    } else {
        let inv = rot.transpose();
        (inv, Box::new(move |p, i| inv * (p.vertices[i] - t)))
    }
}

/// The centroid certificate's point of `m` (its points moved back onto the incident face).
fn centroid(m: &Manifold) -> Vec3 {
    let mut c = Vec3::ZERO;
    for p in m.points() {
        c += p.point - m.normal * (0.5 * p.depth);
    }
    c / m.count as f32
}

fn bits(m: &Option<Manifold>) -> Option<(Vec<[u32; 4]>, [u32; 3])> {
    m.as_ref().map(|m| {
        let p = m.points().iter();
        let p = p.map(|p| [p.point.x, p.point.y, p.point.z, p.depth].map(f32::to_bits));
        (p.collect(), m.normal.to_array().map(f32::to_bits))
    })
}

/// Boxes face to face (the pile's case: nearly aligned, shallow) and random hulls, both
/// kinds of reference face; a record at one pose, then poses moved from it by 1e-7 to 3e-2
/// of the size (turned and shifted, the quaternion's norm off 1 by up to 1e-6). Wherever a
/// plan serves: the incident face it names is the one chosen at the new pose; each side
/// plane it skips has every incident corner strictly inside; the clip with the plan is the
/// full clip, bitwise; and where it certifies, the record's certificate point, carried
/// with the incident body, is still `delta` inside every face plane of the reference body.
#[test]
fn plans_hold_at_moved_poses() {
    let mut r = ChaCha8Rng::seed_from_u64(20);
    // (A box with edges longer than 1, so that a side plane's vector is not short; a
    // square prism turned 45 degrees, whose slanted faces' normals have two equal
    // components: against a box at the identity, two incident faces tie exactly.)
    let diamond: Vec<Vec3> = [-0.5f32, 0.5]
        .iter()
        .flat_map(|&z| {
            [
                Vec3::new(1.0, 0.0, z),
                Vec3::new(0.0, 1.0, z),
                Vec3::new(-1.0, 0.0, z),
                Vec3::new(0.0, -1.0, z),
            ]
        })
        .collect();
    let mut shapes = vec![
        cuboid(Vec3::splat(0.01)),
        cuboid(Vec3::new(0.5, 0.2, 0.3)),
        cuboid(Vec3::new(2.0, 1.5, 3.0)),
        crate::convex_hull(&diamond).expect("prism hull"),
    ];
    for _ in 0..3 {
        let v: Vec<Vec3> = (0..r.random_range(8..20))
            .map(|_| Vec3::new(r.random(), r.random(), r.random()) - 0.5)
            .collect();
        shapes.push(crate::convex_hull(&v).expect("random hull"));
    }
    let mut buffers = ClipBuffers::default();
    let (mut served, mut faces, mut skipped, mut certified, mut measured) = (0, 0, 0, 0, 0);
    for case in 0..6_000 {
        let boxes = case % 2 == 0;
        let tie = case % 10 == 1;
        let (ia, ib) = if boxes {
            (case / 2 % 3, case / 4 % 3)
        } else if tie {
            (3, 1)
        } else {
            (
                r.random_range(0..shapes.len()),
                r.random_range(0..shapes.len()),
            )
        };
        let (a, b) = (&shapes[ia], &shapes[ib]);
        let kind = if case % 3 == 0 {
            HINT_FACE_B
        } else {
            HINT_FACE_A
        };
        let (refp, inc) = if kind == HINT_FACE_A { (a, b) } else { (b, a) };
        let rf = if tie {
            // A slanted face of the prism.
            let slanted = |f: &&crate::Face| f.normal.z.abs() < 1e-6 && f.normal.x.abs() > 0.1;
            let f = refp.faces.iter().filter(slanted).count();
            let k = r.random_range(0..f);
            let at = refp
                .faces
                .iter()
                .enumerate()
                .filter(|(_, f)| slanted(f))
                .nth(k);
            at.expect("slanted face").0
        } else {
            r.random_range(0..refp.faces.len())
        };
        let face = refp.faces[rf];
        let n = face.normal;
        // B's rotation in A's frame: near an axis-to-axis turn for boxes, else any.
        let jitter = |r: &mut ChaCha8Rng, s: f32| {
            let axis = Vec3::new(r.random(), r.random(), r.random()) - 0.5;
            Quat::from_axis_angle(axis.normalize(), s * r.random::<f32>())
        };
        let q0 = if tie {
            Quat::IDENTITY
        } else if boxes {
            let quarter = std::f32::consts::FRAC_PI_2;
            let turn = |r: &mut ChaCha8Rng, v: Vec3| {
                Quat::from_axis_angle(v, quarter * r.random_range(0..4) as f32)
            };
            (turn(&mut r, Vec3::X) * turn(&mut r, Vec3::Y) * jitter(&mut r, 0.05)).normalize()
        } else {
            let q = [0.0f32; 4].map(|_| r.random_range(-1.0f32..1.0));
            Quat::from_array(q).normalize()
        };
        // The incident body just through the face (in the reference frame), moved along it.
        let place = |q: Quat, depth: f32, lateral: Vec3| {
            let (_, inc_v) = frame(kind, q, Vec3::ZERO);
            let low = (0..inc.vertices.len())
                .map(|i| n.dot(inc_v(inc, i)))
                .fold(f32::INFINITY, f32::min);
            let at = n * (face.offset - depth - low) + (lateral - n * n.dot(lateral));
            // `at` is where the incident origin goes in the reference frame; as `t`:
            if kind == HINT_FACE_A {
                at
            } else {
                -(Mat3::from_quat(q) * at)
            }
        };
        let size = refp.radius.min(inc.radius);
        let depth = size * [1e-4, 1e-3, 1e-2][case % 3];
        let lateral = (Vec3::new(r.random(), r.random(), r.random()) - 0.5) * size * 0.6;
        let t0 = place(q0, depth, lateral);
        let (inc_rot, inc_v) = frame(kind, q0, t0);
        let inc_v0 = |i: usize| inc_v(inc, i);
        let Some(m0) = clip_faces(refp, rf, inc, inc_v0, inc_rot, &mut buffers, &Plan::FULL) else {
            continue;
        };
        let key = kind | rf as u32;
        let lever = if kind == HINT_FACE_A {
            inc.radius
        } else {
            inc.radius + t0.length() * (1.0 + 1e-6)
        };
        let delta = 2e-5 * (a.radius + b.radius);
        let mut s = FaceSlack::default();
        let n_inc = inc_rot.transpose() * n;
        s.record(refp, rf, inc, key, q0, t0, lever, n_inc, inc_v0, &m0, delta);
        measured += 1;
        // The certificate's point as a point of the incident body (its own frame).
        // (The incident origin in the reference frame is `inc_v(0) - inc_rot v_0`.)
        let origin0 = inc_v0(0) - inc_rot * inc.vertices[0];
        let body_point = inc_rot.transpose() * (centroid(&m0) - origin0);
        for step in 0..8 {
            let scale = size * [1e-7, 1e-6, 1e-5, 1e-4, 3e-4, 1e-3, 3e-3, 3e-2][step];
            let q1 = (q0 * jitter(&mut r, scale / size)) * (1.0 + r.random_range(-5e-7f32..5e-7));
            let t1 = t0 + (Vec3::new(r.random(), r.random(), r.random()) - 0.5) * scale;
            let plan = s.plan(refp, inc, key, q1, t1);
            if plan.measure {
                continue;
            }
            served += 1;
            let (inc_rot1, inc_v) = frame(kind, q1, t1);
            let inc_v1 = |i: usize| inc_v(inc, i);
            let chosen = incident_face(inc, inc_rot1.transpose() * n);
            if let Some(f) = plan.inc_face {
                assert_eq!(f, chosen, "case {case} step {step}: incident face");
                faces += 1;
            }
            for (k, &(side, off)) in refp.side_planes(rf).iter().enumerate() {
                if k < 8 && plan.skip >> k & 1 != 0 {
                    skipped += 1;
                    for &i in inc.face_loop(chosen) {
                        let d = side.dot(inc_v1(i as usize)) - off;
                        assert!(d < 0.0, "case {case} step {step}: plane {k} at {d}");
                    }
                }
            }
            let full = clip_faces(refp, rf, inc, inc_v1, inc_rot1, &mut buffers, &Plan::FULL);
            let got = clip_faces(refp, rf, inc, inc_v1, inc_rot1, &mut buffers, &plan);
            assert_eq!(bits(&got), bits(&full), "case {case} step {step}");
            if plan.certified {
                certified += 1;
                // The body point at the new pose, in the reference frame.
                let c1 = inc_rot1 * body_point + (inc_v1(0) - inc_rot1 * inc.vertices[0]);
                assert!(c1.is_finite());
                for f in &refp.faces {
                    let s = f.normal.dot(c1) - f.offset;
                    assert!(
                        s <= -delta,
                        "case {case} step {step}: certificate point at {s}"
                    );
                }
            }
        }
    }
    println!(
        "{measured} records, {served} plans: {faces} faces, {skipped} planes skipped, {certified} certified"
    );
    assert!(measured > 3_000 && served > 10_000, "{measured} {served}");
    assert!(
        faces * 2 > served && skipped > served && certified * 10 > served,
        "{faces} {skipped} {certified}"
    );
}

/// A clip record's plan ([`FaceSlack::plan`]) reads its first cache line only (the fields
/// before the certificate, which only a record whose own certificate does not stand reads),
/// and the record is a line's multiple; an anchor fits in one line (see
/// `memory_tests::the_served_paths_read_few_lines_of_a_memory`).
#[test]
fn a_plan_reads_one_line_of_its_record() {
    use std::mem::{align_of, offset_of, size_of, size_of_val};
    let r = FaceSlack::default();
    assert_eq!(align_of::<FaceSlack>(), 64);
    assert_eq!(size_of::<FaceSlack>() % 64, 0);
    let ends = [
        offset_of!(FaceSlack, q) + size_of_val(&r.q),
        offset_of!(FaceSlack, shapes) + size_of_val(&r.shapes),
        offset_of!(FaceSlack, t) + size_of_val(&r.t),
        offset_of!(FaceSlack, key) + size_of_val(&r.key),
        offset_of!(FaceSlack, renew) + size_of_val(&r.renew),
        offset_of!(FaceSlack, lever) + size_of_val(&r.lever),
        offset_of!(FaceSlack, inc_face) + size_of_val(&r.inc_face),
        offset_of!(FaceSlack, skip) + size_of_val(&r.skip),
        offset_of!(FaceSlack, certified) + size_of_val(&r.certified),
    ];
    for end in ends {
        assert!(end <= 64, "a planned field ends at byte {end}");
    }
    assert!(size_of::<Anchor>() <= 64 && 64 % align_of::<Anchor>() == 0);
}

/// The motion bound as it was computed before `|q|^2 - 1` was taken once per pose
/// (`moved_since`, each caller computing `s` itself), kept as the reference.
fn moved_since_reference(q0: Quat, t0: Vec3, lever: f32, q: Quat, t: Vec3) -> (f32, f32) {
    let s = (q.length_squared() - 1.0).abs();
    let dt = (t - t0).abs();
    let turn = 2.0 * (q - q0).length() + 4.0 * s;
    (s, turn * lever + (dt.x + dt.y + dt.z) * (1.0 + 1e-5))
}

/// `unit_error` and `moved_by` (the pair's `s` computed once, face37) against the bound
/// as each caller computed it, bitwise: quaternions off the unit norm by up to `1e-5`
/// (either side of `UNIT`), zeros of either sign, offsets from tiny to large, NaN and
/// infinite entries now and then; and the anchor's and the record's answers with the
/// given `s` against those computing it.
#[test]
fn motion_bound_with_the_pose_s_is_the_reference() {
    use super::{Anchor, moved_by, unit_error};
    let mut r = ChaCha8Rng::seed_from_u64(3737);
    let odd = [f32::NAN, f32::INFINITY, -0.0, 0.0, 1e30];
    let a = cuboid(Vec3::new(0.5, 0.5, 0.5));
    let b = cuboid(Vec3::new(0.5, 0.3, 0.7));
    let (mut near, mut served) = (0, 0);
    for case in 0..200_000 {
        let quat = |r: &mut ChaCha8Rng| {
            let mut v = [0.0f32; 4].map(|_| r.random_range(-1.0f32..1.0));
            if case % 17 == 0 {
                v[r.random_range(0..4)] = odd[r.random_range(0..odd.len())];
            }
            let q = Quat::from_array(v).normalize();
            q * (1.0 + r.random_range(-1e-5f32..1e-5))
        };
        let (q0, q) = (quat(&mut r), quat(&mut r));
        let scale = [1e-6f32, 1e-2, 1.0, 1e3][case % 4];
        let vec = |r: &mut ChaCha8Rng| {
            Vec3::new(
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
            ) * scale
        };
        let (t0, t) = (vec(&mut r), vec(&mut r));
        let lever = r.random_range(0.0f32..2.0);
        let (s_want, want) = moved_since_reference(q0, t0, lever, q, t);
        let s = unit_error(q);
        assert_eq!(s.to_bits(), s_want.to_bits(), "case {case}");
        let got = moved_by(q0, t0, lever, q, t, s);
        assert_eq!(
            got.to_bits(),
            want.to_bits(),
            "case {case}: {q0:?} {q:?} {t0:?} {t:?}"
        );
        near += (s < super::UNIT) as usize;
        let anchor = Anchor::at(&a, &b, q0, t0);
        assert_eq!(
            anchor.moved_at(q, t, s).to_bits(),
            anchor.moved(q, t).to_bits(),
            "case {case}"
        );
        let mut slack = FaceSlack::default();
        if case % 7 == 0 {
            // B resting on A's top face near the identity, recorded at `(q0, t0)` and
            // planned at a pose moved by up to `1e-4` (the record serves, or not).
            let top = (0..a.faces.len())
                .max_by(|&i, &j| a.faces[i].normal.z.total_cmp(&a.faces[j].normal.z))
                .unwrap_or(0);
            let key = HINT_FACE_A | top as u32;
            let near_id = |r: &mut ChaCha8Rng, e: f32| {
                let v = [0.0f32; 3].map(|_| r.random_range(-e..e));
                Quat::from_xyzw(v[0], v[1], v[2], 1.0).normalize()
                    * (1.0 + r.random_range(-2e-6f32..2e-6))
            };
            let q0 = near_id(&mut r, 1e-3);
            let t0 = Vec3::new(r.random_range(-0.3..0.3), r.random_range(-0.3..0.3), 1.199);
            let e = [1e-7f32, 1e-5, 1e-4][case % 3];
            let q = q0 + near_id(&mut r, e) - Quat::IDENTITY;
            let t = t0 + Vec3::new(r.random_range(-e..e), r.random_range(-e..e), 0.0);
            let s = unit_error(q);
            let rot = Mat3::from_quat(q0);
            let inc_v = |i: usize| rot * b.vertices[i] + t0;
            let plan_full = Plan::FULL;
            let mut clip = ClipBuffers::default();
            let Some(m) = clip_faces(&a, top, &b, inc_v, rot, &mut clip, &plan_full) else {
                continue;
            };
            let n_inc = rot.transpose() * a.faces[top].normal;
            slack.record(&a, top, &b, key, q0, t0, b.radius, n_inc, inc_v, &m, 1e-5);
            let plan = slack.plan_at(&a, &b, key, q, t, s);
            assert_eq!(plan, slack.plan(&a, &b, key, q, t), "case {case}");
            served += (plan != Plan::MEASURE) as usize;
        }
    }
    assert!(near > 30_000 && served > 1_000, "{near} {served}");
}

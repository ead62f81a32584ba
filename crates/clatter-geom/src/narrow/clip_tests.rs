//! Tests of [`super`] (the face clipping), beside it to keep `clip.rs` short.

use super::*;
use crate::narrow::test_shapes::cuboid;
use glam::{Mat3, Quat};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

thread_local! {
    /// Set by a test to send every clip through the growable buffers (`small_fits` false),
    /// the reference of the fixed ones.
    pub(super) static GROWABLE_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Set by a test to have the fixed buffers' clip take every plane's and the reference
    /// normal's dot products (`on_axes` false), the reference of a box's coordinates.
    pub(super) static PRODUCTS_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// The face clipping as it was before its buffers were written by index and its side
/// planes kept with the shape (pushes into vectors, side planes from the loop, every
/// plane copying the polygon), kept as the reference.
fn reference(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3,
    inc_rot: Mat3,
) -> Option<Vec<(Vec3, f32)>> {
    let rface = refp.faces[rf];
    let n = rface.normal;
    let n_inc = inc_rot.transpose() * n;
    let mut inc_face = 0;
    let mut best = f32::INFINITY;
    for (f, face) in inc.faces.iter().enumerate() {
        let d = face.normal.dot(n_inc);
        if d < best {
            best = d;
            inc_face = f;
        }
    }
    let mut poly: Vec<Vec3> = inc
        .face_loop(inc_face)
        .iter()
        .map(|&i| inc_v(i as usize))
        .collect();
    let rl = refp.face_loop(rf);
    for k in 0..rl.len() {
        let v0 = refp.vertices[rl[k] as usize];
        let v1 = refp.vertices[rl[(k + 1) % rl.len()] as usize];
        let side = (v1 - v0).cross(n);
        let off = side.dot(v0);
        let mut out = Vec::new();
        for i in 0..poly.len() {
            let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
            let (dp, dq) = (side.dot(p) - off, side.dot(q) - off);
            if dp <= 0.0 {
                out.push(p);
            }
            if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                out.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
        poly = out;
        if poly.is_empty() {
            break;
        }
    }
    let pts: Vec<(Vec3, f32)> = poly
        .iter()
        .filter_map(|&p| {
            let depth = rface.offset - n.dot(p);
            (depth > 0.0).then(|| (p + n * (0.5 * depth), depth))
        })
        .collect();
    if pts.is_empty() {
        let deepest = (0..inc.vertices.len())
            .map(inc_v)
            .min_by(|p, q| n.dot(*p).total_cmp(&n.dot(*q)))?;
        let depth = rface.offset - n.dot(deepest);
        return (depth > 0.0).then(|| vec![(deepest + n * (0.5 * depth), depth)]);
    }
    let (idx, count) = crate::reduce::reduce(&pts, n);
    Some(idx[..count].iter().map(|&i| pts[i]).collect())
}

/// The incident face's choice on faces of the signed axes, without the products,
/// against the loop over every face's dot product: boxes of several extents (their
/// hulls' own normals), directions at random, on the axes, with equal components (ties:
/// the first face wins), with zeros of either sign, all zero, and with an infinite or
/// NaN component (the loop decides those).
#[test]
fn incident_face_on_axes_is_the_loop() {
    let mut r = ChaCha8Rng::seed_from_u64(19);
    let boxes = [
        Vec3::splat(0.01),
        Vec3::new(0.5, 0.2, 0.3),
        Vec3::new(1.0, 3.0, 0.25),
    ];
    let mut tested = 0;
    for h in boxes {
        let v: Vec<Vec3> = (0..8)
            .map(|k| {
                let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
            })
            .collect();
        let shape = crate::convex_hull(&v).expect("box hull");
        assert!(
            shape.face_axes.is_some(),
            "a box's faces are the signed axes"
        );
        let picks = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            1e-30,
            f32::INFINITY,
            f32::NAN,
        ];
        for case in 0..60_000 {
            let n = if case % 2 == 0 {
                let mut q = [0.0f32; 4].map(|_| r.random_range(-1.0f32..1.0));
                q[3] += 1e-3;
                Quat::from_array(q).normalize() * Vec3::Z
            } else {
                Vec3::from_array([0; 3].map(|_| picks[r.random_range(0..picks.len())]))
            };
            let want = {
                let mut inc_face = 0;
                let mut best = f32::INFINITY;
                for (f, face) in shape.faces.iter().enumerate() {
                    let d = face.normal.dot(n);
                    if d < best {
                        best = d;
                        inc_face = f;
                    }
                }
                inc_face
            };
            assert_eq!(incident_face(&shape, n), want, "{n:?}");
            tested += n.is_finite() as usize;
        }
    }
    assert!(tested > 100_000, "{tested}");
    // A hull that is not a box of the axes takes the loop.
    let tetra = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ZERO];
    assert!(
        crate::convex_hull(&tetra)
            .expect("hull")
            .face_axes
            .is_none()
    );
}

/// A random rotation; where `exact`, one that maps the axes onto axes exactly (with the
/// boxes' faces on the axes, corners then land exactly on side planes: distance zero).
fn test_rotation(r: &mut ChaCha8Rng, exact: bool) -> Mat3 {
    if exact {
        let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        let a = axes[r.random_range(0..6)];
        let b = loop {
            let b = axes[r.random_range(0..6)];
            if a.dot(b) == 0.0 {
                break b;
            }
        };
        Mat3::from_cols(a, b, a.cross(b))
    } else {
        let mut q = [0.0f32; 4].map(|_| r.random_range(-1.0f32..1.0));
        q[3] += 1e-3;
        Mat3::from_quat(Quat::from_array(q).normalize())
    }
}

pub(super) fn bits(p: &[(Vec3, f32)]) -> Vec<[u32; 4]> {
    p.iter()
        .map(|(v, d)| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits(), d.to_bits()])
        .collect()
}

/// `clip_faces` (the full plan) of `inc`, its corners at `inc_v`, on face `rf` of
/// `refp`, asserted bitwise the reference's and with the face's normal (`case` names a
/// failure): the reference's points, `None` for no contact.
fn clip_is_the_reference(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    inc_v: impl Fn(usize) -> Vec3 + Copy,
    rot: Mat3,
    buffers: &mut ClipBuffers,
    case: usize,
) -> Option<Vec<(Vec3, f32)>> {
    let got = clip_faces(refp, rf, inc, inc_v, rot, buffers, &Plan::FULL);
    let want = reference(refp, rf, inc, inc_v, rot);
    let got = got.map(|m| {
        assert_eq!(m.normal, refp.faces[rf].normal);
        m.points()
            .iter()
            .map(|p| (p.point, p.depth))
            .collect::<Vec<_>>()
    });
    assert_eq!(
        got.as_deref().map(bits),
        want.as_deref().map(bits),
        "case {case}"
    );
    want
}

/// Boxes (the pile's case: quads against rectangles) and random hulls, the incident
/// body turned at random and placed just through each reference face (touching,
/// crossing its sides, or clipped away), sometimes exactly aligned (corners on the side
/// planes, planes that cut nothing): every manifold bitwise the reference's.
#[test]
fn face_clipping_is_the_reference_bitwise() {
    let mut r = ChaCha8Rng::seed_from_u64(13);
    // A prism whose triangle, turned onto the cube's face exactly, has a corner on a
    // side plane of the cube (a coordinate of 0.01) while the plane cuts another
    // corner (0.02): a corner at distance zero on a plane that clips.
    let tri = [(0.01, 0.005), (0.02, -0.005), (-0.005, -0.005)];
    let prism: Vec<Vec3> = [-0.01, 0.01]
        .iter()
        .flat_map(|&z| tri.map(|(x, y)| Vec3::new(x, y, z)))
        .collect();
    let mut shapes = vec![
        cuboid(Vec3::splat(0.01)),
        cuboid(Vec3::new(0.5, 0.2, 0.3)),
        crate::convex_hull(&prism).expect("prism hull"),
    ];
    for _ in 0..4 {
        let v: Vec<Vec3> = (0..r.random_range(6..24))
            .map(|_| Vec3::new(r.random(), r.random(), r.random()) - 0.5)
            .collect();
        shapes.push(crate::convex_hull(&v).expect("random hull"));
    }
    let (mut cases, mut multi, mut many) = (0, 0, 0);
    let mut buffers = ClipBuffers::default();
    for case in 0..20_000 {
        let refp = &shapes[r.random_range(0..shapes.len())];
        let inc = &shapes[r.random_range(0..shapes.len())];
        let rf = r.random_range(0..refp.faces.len());
        let face = refp.faces[rf];
        let exact = case % 4 == 0;
        let rot = test_rotation(&mut r, exact);
        let scale = refp.radius.max(inc.radius);
        let lateral = if exact {
            Vec3::new(
                r.random_range(-1..=1) as f32,
                r.random_range(-1..=1) as f32,
                r.random_range(-1..=1) as f32,
            ) * (0.005 * r.random_range(0..2) as f32)
        } else {
            Vec3::new(r.random(), r.random(), r.random()) * scale * 0.3
        };
        let t = face.normal * (face.offset + inc.radius * r.random_range(0.5..1.0)) + lateral;
        let inc_v = |i: usize| rot * inc.vertices[i] + t;
        let want = clip_is_the_reference(refp, rf, inc, inc_v, rot, &mut buffers, case);
        if let Some(w) = &want {
            cases += 1;
            multi += (w.len() > 1) as usize;
            many += (w.len() == 4) as usize;
        }
    }
    // The cases exercise the clipping, not only its fallback.
    assert!(
        cases > 5_000 && multi > 2_000 && many > 1_000,
        "{cases} {multi} {many}"
    );
}

/// Cubes resting exactly face on face, turned onto the axes exactly and slid along the
/// face by steps of a quarter edge: the incident corners at depth exactly zero (kept by
/// neither, no contact) or, pressed in by a step, all at the same depth (kept): the
/// clip's manifold bitwise the reference's, for every face, both ways.
#[test]
fn exactly_touching_faces_are_the_reference() {
    let mut r = ChaCha8Rng::seed_from_u64(29);
    let h = 0.01f32;
    let v: Vec<Vec3> = (0..8)
        .map(|k| {
            let s = |b: u32| if k & b != 0 { h } else { -h };
            Vec3::new(s(1), s(2), s(4))
        })
        .collect();
    let cube = crate::convex_hull(&v).expect("cube hull");
    let (mut touching, mut pressed) = (0, 0);
    let mut buffers = ClipBuffers::default();
    for case in 0..4_000 {
        let rf = r.random_range(0..cube.faces.len());
        let face = cube.faces[rf];
        let rot = test_rotation(&mut r, true);
        let slide = Vec3::new(
            r.random_range(-4..=4) as f32,
            r.random_range(-4..=4) as f32,
            r.random_range(-4..=4) as f32,
        ) * (0.5 * h);
        // Along the face only (the normal is an axis: exact).
        let slide = slide - face.normal * face.normal.dot(slide);
        let press = if case % 2 == 0 { 0.0 } else { 0.5 * h };
        let t = face.normal * (face.offset + h - press) + slide;
        let inc_v = |i: usize| rot * cube.vertices[i] + t;
        match clip_is_the_reference(&cube, rf, &cube, inc_v, rot, &mut buffers, case) {
            None => touching += 1,
            Some(_) => pressed += 1,
        }
    }
    // Both outcomes met: corners at depth zero, and corners pressed in.
    assert!(touching > 1_000 && pressed > 1_000, "{touching} {pressed}");
}

/// The whole manifold as bits (`None`: no contact).
fn manifold_bits(m: Option<Manifold>) -> Option<(usize, [u32; 3], Vec<[u32; 4]>)> {
    m.map(|m| {
        let pts: Vec<(Vec3, f32)> = m.points().iter().map(|p| (p.point, p.depth)).collect();
        (m.count, m.normal.to_array().map(f32::to_bits), bits(&pts))
    })
}

/// The shapes of the random clip cases ([`ClipCase`]): a small cube, a box, with `prism` a
/// triangular prism (faces of three and four corners), and four random hulls drawn from `r`.
fn clip_shapes(r: &mut ChaCha8Rng, prism: bool) -> Vec<ConvexPolyhedron> {
    let mut shapes = vec![cuboid(Vec3::splat(0.01)), cuboid(Vec3::new(0.5, 0.2, 0.3))];
    if prism {
        let tri = [(0.01, 0.005), (0.02, -0.005), (-0.005, -0.005)];
        let v: Vec<Vec3> = [-0.01, 0.01]
            .iter()
            .flat_map(|&z| tri.map(|(x, y)| Vec3::new(x, y, z)))
            .collect();
        shapes.push(crate::convex_hull(&v).expect("prism hull"));
    }
    for _ in 0..4 {
        let v: Vec<Vec3> = (0..r.random_range(6..24))
            .map(|_| Vec3::new(r.random(), r.random(), r.random()) - 0.5)
            .collect();
        shapes.push(crate::convex_hull(&v).expect("random hull"));
    }
    shapes
}

/// One random clip case: reference face `rf` of `shapes[refp]` against `shapes[inc]`
/// turned by `rot` (at random, or onto the axes exactly every third case) and moved by `t`
/// just above the face, slid sideways at random or (exact cases) by whole steps of the
/// small cube's half size, so that corners lie on side planes; the incident corners with
/// their zeros turned to `-0` by `flip`'s bits, one off by an ulp (`nudge`), and now and
/// then one NaN or infinite (`bad`): degenerate poses.
struct ClipCase {
    refp: usize,
    inc: usize,
    rf: usize,
    rot: Mat3,
    t: Vec3,
    flip: u32,
    nudge: usize,
    bad: f32,
}

impl ClipCase {
    /// Case number `case`, drawn from `r`.
    fn draw(r: &mut ChaCha8Rng, shapes: &[ConvexPolyhedron], case: usize) -> Self {
        let refp = r.random_range(0..shapes.len());
        let inc = r.random_range(0..shapes.len());
        let (rp, ip) = (&shapes[refp], &shapes[inc]);
        let rf = r.random_range(0..rp.faces.len());
        let face = rp.faces[rf];
        let exact = case.is_multiple_of(3);
        let rot = test_rotation(r, exact);
        let scale = rp.radius.max(ip.radius);
        let lateral = if exact {
            Vec3::new(
                r.random_range(-2..=2) as f32,
                r.random_range(-2..=2) as f32,
                r.random_range(-2..=2) as f32,
            ) * (0.005 * r.random_range(0..2) as f32)
        } else {
            Vec3::new(r.random(), r.random(), r.random()) * scale * 0.3
        };
        let t = face.normal * (face.offset + ip.radius * r.random_range(0.5..1.0)) + lateral;
        let flip = r.random_range(0..8u32);
        let nudge = r.random_range(0..64usize);
        let bad = if case.is_multiple_of(97) {
            [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][case / 97 % 3]
        } else {
            0.0
        };
        ClipCase {
            refp,
            inc,
            rf,
            rot,
            t,
            flip,
            nudge,
            bad,
        }
    }

    /// Incident corner `i` (of `inc`, `shapes[self.inc]`) in the reference body's frame.
    fn inc_v(&self, inc: &ConvexPolyhedron, i: usize) -> Vec3 {
        let mut p = (self.rot * inc.vertices[i] + self.t).to_array();
        for (k, c) in p.iter_mut().enumerate() {
            if *c == 0.0 && self.flip >> k & 1 != 0 {
                *c = -*c;
            }
        }
        let n = self.nudge;
        if i == n % inc.vertices.len() && n < 16 {
            p[n % 3] = f32::from_bits(p[n % 3].to_bits() + 1);
        }
        if self.bad != 0.0 && i == n % inc.vertices.len() {
            p[0] = self.bad;
        }
        Vec3::from_array(p)
    }

    /// Whether a corner has a `-0` or a NaN or infinite coordinate here.
    fn odd(&self) -> bool {
        self.bad != 0.0 || self.flip != 0
    }
}

/// The side planes of reference face `rf` (of the first 8) that cut nothing of the
/// incident face (every corner inside or on them, as a record's skipped planes are), as
/// a plan's `skip` bits, and the incident face's corner count.
fn planes_cutting_nothing(
    refp: &ConvexPolyhedron,
    rf: usize,
    inc: &ConvexPolyhedron,
    rot: Mat3,
    inc_v: impl Fn(usize) -> Vec3,
) -> (u8, usize) {
    let n_inc = rot.transpose() * refp.faces[rf].normal;
    let il = inc.face_loop(incident_face(inc, n_inc));
    let mut skip = 0u8;
    for (k, &(side, off)) in refp.side_planes(rf).iter().enumerate().take(8) {
        if il.iter().all(|&i| side.dot(inc_v(i as usize)) - off < 0.0) {
            skip |= 1 << k;
        }
    }
    (skip, il.len())
}

/// The clip without the scan for a corner outside (`Plan::scan` off, as a served
/// record's plan) against the clip with it, bitwise: boxes and random hulls turned at
/// random or onto the axes exactly (corners on side planes: distance `+0` or `-0`,
/// planes that cut nothing, corners outside by one ulp), incident corners with zeros of
/// either sign, and a corner NaN or infinite now and then (degenerate poses); and the
/// same with each plan's skipped planes taken from a plane that cuts nothing there.
#[test]
fn clip_without_the_scan_is_the_clip_with_it() {
    let mut r = ChaCha8Rng::seed_from_u64(21);
    let shapes = clip_shapes(&mut r, false);
    let (mut buf_a, mut buf_b) = (ClipBuffers::default(), ClipBuffers::default());
    let (mut cut_nothing, mut contacts, mut odd) = (0, 0, 0);
    for case in 0..40_000 {
        let c = ClipCase::draw(&mut r, &shapes, case);
        let (refp, inc, rf, rot) = (&shapes[c.refp], &shapes[c.inc], c.rf, c.rot);
        let inc_v = |i: usize| c.inc_v(inc, i);
        odd += c.odd() as usize;
        let with = clip_faces(refp, rf, inc, inc_v, rot, &mut buf_a, &Plan::FULL);
        let without = Plan {
            scan: false,
            ..Plan::FULL
        };
        let got = clip_faces(refp, rf, inc, inc_v, rot, &mut buf_b, &without);
        contacts += with.is_some() as usize;
        assert_eq!(manifold_bits(got), manifold_bits(with), "case {case}");
        // The planes that cut nothing here (every corner of the incident face inside
        // or on them, as a record's skipped planes are): skipped, without the scan.
        let (skip, _) = planes_cutting_nothing(refp, rf, inc, rot, inc_v);
        cut_nothing += (skip != 0) as usize;
        let skipping = Plan { skip, ..without };
        let got = clip_faces(refp, rf, inc, inc_v, rot, &mut buf_b, &skipping);
        assert_eq!(
            manifold_bits(got),
            manifold_bits(with),
            "case {case} skip {skip:b}"
        );
    }
    assert!(
        contacts > 10_000 && cut_nothing > 5_000 && odd > 10_000,
        "{contacts} {cut_nothing} {odd}"
    );
}

/// One plane's clip of a polygon of `n` corners writes at most `n + n / 2` (what the fixed
/// buffers' size rests on, see `small_fits`): every pattern of corner distances `-1`,
/// `-0`, `+0`, `1` and NaN for `n` up to 8 (the corners on a line across the plane `x =
/// 0`, at those distances: crossings wherever the strict signs alternate), the bound met
/// exactly by alternating signs; and every polygon `small_fits` admits, grown by that
/// bound at each of its planes, stays within the buffers.
#[test]
fn a_plane_grows_a_polygon_by_half_at_most() {
    let ds = [-1.0, -0.0, 0.0, 1.0, f32::NAN];
    let mut dst = vec![Vec3::ZERO; 16];
    let mut reached = 0;
    for n in 1..=8usize {
        for code in 0..ds.len().pow(n as u32) {
            let src: Vec<Vec3> = (0..n)
                .map(|i| {
                    let d = ds[code / ds.len().pow(i as u32) % ds.len()];
                    Vec3::new(d, i as f32, 0.0)
                })
                .collect();
            let w = clip_by_plane(&src, dst.as_mut_slice(), |p| Vec3::X.dot(p), false)
                .expect("no scan: always a polygon");
            assert!(w <= n + n / 2, "{n} corners, code {code}: {w}");
            reached += (w == n + n / 2 && n % 2 == 0) as usize;
        }
    }
    assert!(reached >= 4, "{reached}");
    for len in 0..=16usize {
        for planes in 0..=8u32 {
            if small_fits(len, planes) {
                let most = (0..planes).fold(len, |n, _| n + n / 2);
                assert!(most <= SMALL, "{len} corners, {planes} planes: {most}");
            }
        }
    }
}

/// The clip of reference face `rf` of `refp` against `inc` (corners at `inc_v`, turned by
/// `rot`) under a record's three plans (the whole clip, without the scan, and without the
/// scan with the planes in `skip` left out), against the same clip with `reference` set
/// (the path the test holds the other to), bitwise. Returns how many of the reference's
/// clips found a contact.
fn plans_match_reference(
    reference: &'static std::thread::LocalKey<std::cell::Cell<bool>>,
    (refp, rf, inc, rot): (&ConvexPolyhedron, usize, &ConvexPolyhedron, Mat3),
    inc_v: impl Fn(usize) -> Vec3 + Copy,
    skip: u8,
    (buf_a, buf_b): (&mut ClipBuffers, &mut ClipBuffers),
    case: usize,
) -> usize {
    let plans = [
        Plan::FULL,
        Plan {
            scan: false,
            ..Plan::FULL
        },
        Plan {
            scan: false,
            skip,
            ..Plan::FULL
        },
    ];
    let mut contacts = 0;
    for plan in plans {
        let got = clip_faces(refp, rf, inc, inc_v, rot, buf_a, &plan);
        reference.set(true);
        let want = clip_faces(refp, rf, inc, inc_v, rot, buf_b, &plan);
        reference.set(false);
        contacts += want.is_some() as usize;
        assert_eq!(
            manifold_bits(got),
            manifold_bits(want),
            "case {case} {plan:?}"
        );
    }
    contacts
}

/// The fixed buffers (of `Vec3A`, stores through a mask) against the growable ones (of
/// `Vec3`, checked stores), bitwise: boxes, a prism and random hulls (faces of three to
/// about eight corners), turned at random or onto the axes exactly (corners on side
/// planes), zeros of either sign, a corner off by an ulp, a NaN or infinite corner now and
/// then, with and without the scan, with the planes that cut nothing skipped.
#[test]
fn fixed_buffers_are_the_growable_ones() {
    let mut r = ChaCha8Rng::seed_from_u64(32);
    let shapes = clip_shapes(&mut r, true);
    let (mut buf_a, mut buf_b) = (ClipBuffers::default(), ClipBuffers::default());
    let (mut fixed, mut contacts, mut odd) = (0, 0, 0);
    for case in 0..40_000 {
        let c = ClipCase::draw(&mut r, &shapes, case);
        let (refp, inc, rf, rot) = (&shapes[c.refp], &shapes[c.inc], c.rf, c.rot);
        let inc_v = |i: usize| c.inc_v(inc, i);
        odd += c.odd() as usize;
        let (skip, il) = planes_cutting_nothing(refp, rf, inc, rot, inc_v);
        let planes = refp.side_planes(rf).len();
        fixed += (planes <= 8 && small_fits(il, planes as u32)) as usize;
        let bufs = (&mut buf_a, &mut buf_b);
        contacts += plans_match_reference(
            &GROWABLE_ONLY,
            (refp, rf, inc, rot),
            inc_v,
            skip,
            bufs,
            case,
        );
    }
    assert!(
        fixed > 20_000 && contacts > 30_000 && odd > 10_000,
        "{fixed} {contacts} {odd}"
    );
}

/// `reduce_all` of the fixed buffers' `Vec3A` points against that of the same `Vec3`
/// points, bitwise: polygons of 5 to 19 corners (the fixed buffers' largest) below a face
/// plane, coarse (ties, repeats, collinear corners) or fine, and now and then a corner
/// huge, infinite or NaN (those reduced as `Vec3`: see `reduce_all`).
#[test]
fn reduce_all_of_vec3a_is_of_vec3() {
    let mut r = ChaCha8Rng::seed_from_u64(33);
    let odd = [
        1e30,
        -1e30,
        1e17,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -0.0,
    ];
    let (mut plain, mut wide) = (Vec::new(), Vec::new());
    let (mut reduced, mut unusual) = (0, 0);
    for case in 0..40_000 {
        let len = r.random_range(5..20usize);
        let coarse = case % 3 == 0;
        let n = Vec3::new(r.random_range(-0.3..0.3), r.random_range(-0.3..0.3), 1.0).normalize();
        let offset = if coarse {
            0.5
        } else {
            r.random_range(-1.0..1.0)
        };
        let mut odd_here = false;
        let poly: Vec<Vec3> = (0..len)
            .map(|_| {
                let mut c = [0; 3].map(|_| {
                    if coarse {
                        r.random_range(-2..=2) as f32 * 0.5
                    } else {
                        r.random_range(-1.0f32..1.0)
                    }
                });
                if case % 7 == 0 && r.random_range(0..4) == 0 {
                    c[r.random_range(0..3)] = odd[r.random_range(0..odd.len())];
                    odd_here = true;
                }
                // Corners far below the plane (overflowing, or NaN once moved halfway up).
                if case % 7 == 1 && r.random_range(0..2) == 0 {
                    c[2] = [f32::NEG_INFINITY, -1e38][r.random_range(0..2)];
                    c[r.random_range(0..2)] *= [1.0, 1e38, f32::INFINITY][r.random_range(0..3)];
                    odd_here = true;
                }
                Vec3::from_array(c)
            })
            .collect();
        let below = poly.iter().filter(|&&p| offset - n.dot(p) > 0.0).count();
        if below <= 4 {
            continue;
        }
        reduced += 1;
        unusual += odd_here as usize;
        let want = reduce_all(&poly, offset, n, &mut plain);
        let poly_a: Vec<Vec3A> = poly.iter().map(|&p| p.into()).collect();
        let got = reduce_all(&poly_a, offset, n, &mut wide);
        assert_eq!(
            manifold_bits(Some(got)),
            manifold_bits(Some(want)),
            "case {case}: {poly:?}"
        );
    }
    assert!(reduced > 10_000 && unusual > 500, "{reduced} {unusual}");
}

/// A box's side planes and reference normal taken from one coordinate (`on_axes`)
/// against every product (`PRODUCTS_ONLY`), bitwise: boxes centred and off-centre (a face
/// through the origin: side-plane offsets of zero), of the pile's size, tiny (products
/// that underflow to zeros) and huge (corners about the `1e18` guard, either side), and a
/// box turned off the axes (its planes take the products either way); incident bodies
/// turned at random or onto the axes exactly (corners on side planes, at depth zero),
/// zeros of either sign, a corner off by an ulp, a NaN or infinite corner now and then,
/// with and without the scan, with the planes that cut nothing skipped.
#[test]
fn box_planes_by_coordinate_are_the_products() {
    let mut r = ChaCha8Rng::seed_from_u64(34);
    let corners = |h: Vec3, o: Vec3| -> Vec<Vec3> {
        (0..8)
            .map(|k| {
                let s = |b: u32| if k & b != 0 { 1.0 } else { -1.0 };
                Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z) + o
            })
            .collect()
    };
    let hull = |v: &[Vec3]| crate::convex_hull(v).expect("box hull");
    let turn = Mat3::from_quat(Quat::from_rotation_y(0.3) * Quat::from_rotation_z(0.2));
    let turned: Vec<Vec3> = corners(Vec3::splat(0.01), Vec3::ZERO)
        .iter()
        .map(|&v| turn * v)
        .collect();
    let shapes = vec![
        hull(&corners(Vec3::splat(0.01), Vec3::ZERO)),
        hull(&corners(Vec3::new(0.5, 0.2, 0.3), Vec3::ZERO)),
        hull(&corners(Vec3::splat(0.01), Vec3::splat(0.01))),
        hull(&corners(
            Vec3::new(0.02, 0.01, 0.005),
            Vec3::new(0.02, 0.0, -0.005),
        )),
        hull(&corners(Vec3::splat(3e-20), Vec3::ZERO)),
        hull(&corners(Vec3::splat(3e17), Vec3::ZERO)),
        hull(&turned),
    ];
    let on_axes = |p: &ConvexPolyhedron, f: usize| {
        let code = p.axis_code(f);
        code.normal() != crate::polyhedron::NO_AXIS
            && (0..p.side_planes(f).len()).all(|k| code.side(k) != crate::polyhedron::NO_AXIS)
    };
    // Each face's code is `axis_of` of its normal and of each side plane's vector (the
    // first fifteen): of the boxes, and of hulls with faces of many corners (prisms).
    let prism = |n: usize| {
        let v: Vec<Vec3> = (0..2 * n)
            .map(|i| {
                let a = (i % n) as f32 * std::f32::consts::TAU / n as f32;
                Vec3::new(a.cos(), a.sin(), if i < n { -0.5 } else { 0.5 })
            })
            .collect();
        hull(&v)
    };
    let prisms = [prism(5), prism(17), prism(24)];
    assert!(
        prisms[2].faces.iter().any(|f| f.count > 15),
        "a face past the code"
    );
    for p in shapes.iter().chain(&prisms) {
        for f in 0..p.faces.len() {
            let code = p.axis_code(f);
            assert_eq!(code.normal(), crate::polyhedron::axis_of(p.faces[f].normal));
            for (k, &(side, _)) in p.side_planes(f).iter().enumerate() {
                let want = if k < 15 {
                    crate::polyhedron::axis_of(side)
                } else {
                    crate::polyhedron::NO_AXIS
                };
                assert_eq!(code.side(k), want, "face {f} plane {k}");
            }
        }
    }
    // Every face of every box on the axes but the turned one's.
    for (k, s) in shapes.iter().enumerate() {
        let all = (0..s.faces.len()).all(|f| on_axes(s, f));
        assert_eq!(all, k + 1 < shapes.len(), "shape {k}");
    }
    let (mut buf_a, mut buf_b) = (ClipBuffers::default(), ClipBuffers::default());
    let (mut axes, mut contacts, mut odd, mut large) = (0, 0, 0, 0);
    for case in 0..60_000 {
        let c = ClipCase::draw(&mut r, &shapes, case);
        let (refp, inc, rf, rot) = (&shapes[c.refp], &shapes[c.inc], c.rf, c.rot);
        // Now and then the incident body far along the reference normal (the huge box's
        // scale: corners near the guard) or scaled down to the tiny box's.
        let shift = match case % 5 {
            0 => refp.faces[rf].normal * refp.radius.max(inc.radius) * r.random_range(0.0..0.5),
            _ => Vec3::ZERO,
        };
        let inc_v = |i: usize| c.inc_v(inc, i) - shift;
        odd += c.odd() as usize;
        let il = inc.face_loop(incident_face(inc, rot.transpose() * refp.faces[rf].normal));
        let moderate = il
            .iter()
            .all(|&i| inc_v(i as usize).abs().cmplt(Vec3::splat(1e18)).all());
        axes += (on_axes(refp, rf) && moderate) as usize;
        large += il
            .iter()
            .any(|&i| inc_v(i as usize).abs().max_element() > 1e17) as usize;
        let (skip, _) = planes_cutting_nothing(refp, rf, inc, rot, inc_v);
        let bufs = (&mut buf_a, &mut buf_b);
        contacts += plans_match_reference(
            &PRODUCTS_ONLY,
            (refp, rf, inc, rot),
            inc_v,
            skip,
            bufs,
            case,
        );
    }
    assert!(
        axes > 30_000 && contacts > 30_000 && odd > 10_000 && large > 2_000,
        "{axes} {contacts} {odd} {large}"
    );
}

/// `axis_of` against its promise: for vectors with each component zero (of either sign),
/// finite, infinite or NaN, an axis only when exactly one component is finite and not
/// zero; and then, for points with coordinates at random scales (subnormal to `1e30`),
/// zeros of either sign, the vector's dot product equals that one product as a value.
#[test]
fn axis_of_is_one_product() {
    use crate::polyhedron::{NO_AXIS, axis_of};
    let mut r = ChaCha8Rng::seed_from_u64(35);
    let picks = [0.0, -0.0, 1.0, -2.5, 3e-39, 1e30, f32::INFINITY, f32::NAN];
    let (mut on, mut off) = (0, 0);
    for _ in 0..200_000 {
        let v = Vec3::from_array([0; 3].map(|_| picks[r.random_range(0..picks.len())]));
        let c = v.to_array();
        let live: Vec<usize> = (0..3).filter(|&k| c[k] != 0.0).collect();
        let want = if live.len() == 1 && c[live[0]].is_finite() {
            live[0] as u8
        } else {
            NO_AXIS
        };
        let got = axis_of(v);
        assert_eq!(got, want, "{v:?}");
        if got == NO_AXIS {
            off += 1;
            continue;
        }
        on += 1;
        let k = got as usize;
        let p = Vec3::from_array([0; 3].map(|_| {
            let s = [1e-42f32, 1e-20, 1.0, 1e20, 1e30][r.random_range(0..5)];
            match r.random_range(0..6) {
                0 => 0.0,
                1 => -0.0,
                _ => r.random_range(-1.0f32..1.0) * s,
            }
        }));
        let (dot, one) = (v.dot(p), c[k] * p[k]);
        let (dot_a, one_a) = (Vec3A::from(v).dot(Vec3A::from(p)), c[k] * p[k]);
        assert!(dot == one && dot_a == one_a, "{v:?} {p:?}: {dot} {one}");
    }
    assert!(on > 10_000 && off > 100_000, "{on} {off}");
}

/// `segment_closest` (inlined into the edge manifold, edge39) against a search in f64: on
/// random segments in general position, near-parallel, and with the first one a point,
/// the two points it returns lie on their segments and are as close as the closest pair
/// that nested ternary searches over both parameters find (the distance is convex in
/// them), within rounding (wider for the ill-conditioned near-parallel pairs).
#[test]
fn segment_closest_points_are_the_closest_by_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(39);
    let dist = |p0: Vec3, d1: Vec3, s: f64, q0: Vec3, d2: Vec3, t: f64| {
        let p = p0.as_dvec3() + d1.as_dvec3() * s;
        let q = q0.as_dvec3() + d2.as_dvec3() * t;
        (p - q).length()
    };
    // The smallest value of a convex `f` over [0, 1], by ternary search.
    let smallest = |f: &dyn Fn(f64) -> f64| {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..80 {
            let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
            if f(m1) <= f(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        f(0.5 * (lo + hi))
    };
    // The distance at s for the best t (the distance is convex in each).
    let best_t =
        |p0: Vec3, d1: Vec3, s: f64, q0: Vec3, d2: Vec3| smallest(&|t| dist(p0, d1, s, q0, d2, t));
    for case in 0..3000 {
        let mut v = || {
            Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
        };
        let (p0, q0, q1) = (v(), v(), v());
        let p1 = match case % 3 {
            0 => v(),
            // Near-parallel to `q0-q1`.
            1 => p0 + (q1 - q0) * 0.7 + v() * 1e-4,
            // A point (the first segment only: a second segment that is a point gets
            // `p0`, not the closest point, as it always did; a hull's edges are never
            // points).
            _ => p0,
        };
        let (qa, qb) = segment_closest(p0, p1, q0, q1);
        let (d1, d2) = (p1 - p0, q1 - q0);
        let got = (qa - qb).length() as f64;
        let want = smallest(&|s| best_t(p0, d1, s, q0, d2));
        // (Near-parallel segments are ill-conditioned in f32: the parameters' rounding
        // moves the distance by up to ~1e-4 on these.)
        let room = if case % 3 == 1 { 2e-4 } else { 1e-5 };
        assert!(got <= want + room, "case {case}: {got} against {want}");
        // On the segments: each point's distance to its segment is rounding.
        let on = |x: Vec3, a: Vec3, d: Vec3| {
            let s = if d.length_squared() > 0.0 {
                ((x - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (a + d * s - x).length()
        };
        assert!(
            on(qa, p0, d1) < 1e-5 && on(qb, q0, d2) < 1e-5,
            "case {case}: off a segment"
        );
    }
}

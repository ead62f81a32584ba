//! Remembered face contacts (a touching pair's reference face, kept while its margin lasts,
//! see `narrow::collide_with_hint`) against the full separating-axis test: polyhedron pairs
//! resting face on face, sliding, spinning about the normal, tilting onto an edge and back,
//! pulled apart and pressed together again, every step's manifold compared bitwise with the
//! full test's at the same poses.

use clatter_geom::narrow::{self, NO_HINT};
use clatter_geom::{ConvexPolyhedron, PreparedShape, Shape};
use glam::{Quat, Vec3};

mod common;
use common::Rng;

fn poly(s: &Shape) -> &ConvexPolyhedron {
    match s {
        Shape::Polyhedron(p) => p,
        _ => panic!("a polyhedron"),
    }
}

/// The centroid of face `f`'s corners (a point of the face plane, inside the face).
fn face_centre(p: &ConvexPolyhedron, f: usize) -> Vec3 {
    let lp = p.face_loop(f);
    lp.iter().map(|&i| p.vertices[i as usize]).sum::<Vec3>() / lp.len() as f32
}

/// The rotation angle of `q` (radians, at most pi), accurate for small turns: from the
/// vector part's length, not `acos(w)` (in f32, `w` of a turn below about 5e-4 rad rounds
/// to 1, and `acos` gave 0: the motion bound these tests pass then missed the turn, and a
/// margin spent at the rate of the true motion could serve past its decisions).
fn angle(q: Quat) -> f32 {
    2.0 * q.xyz().length().atan2(q.w.abs())
}

/// The caller's part of the remembering contract for one pair, A fixed at `pa` and B moving:
/// before each call the remembered margin is decreased by twice a true bound of how far any
/// point of either body moved in the other's frame, and every manifold is compared bitwise
/// with the full test's.
struct Remembering {
    hint: narrow::SatHint,
    bound: f32,
    last: Option<(Vec3, Quat)>,
    ra: f32,
    rb: f32,
}

impl Remembering {
    fn new(a: &Shape, b: &Shape) -> Remembering {
        Remembering {
            hint: NO_HINT,
            bound: 0.0,
            last: None,
            ra: a.bounding_radius(),
            rb: b.bounding_radius(),
        }
    }

    /// Step `k` with B at `(centre, qb)`: returns (the remembered face stood in for the full
    /// test, the bodies touch, this step's motion bound).
    fn step(
        &mut self,
        (a, pa): (&Shape, &Pose),
        b: &Shape,
        (centre, qb): (Vec3, Quat),
        k: usize,
    ) -> (bool, bool, f32) {
        let (ra, rb) = (self.ra, self.rb);
        let mut step_bound = 0.0;
        if let Some((c0, q0)) = self.last {
            // B's points move by at most |dc| + th (|c| + r_b) in A's (fixed) frame, and A's
            // points in B's frame by at most |dc| + th (|c| + r_a).
            let th = angle(qb * q0.conjugate());
            let moved =
                (centre - c0).length() + th * (centre.length().max(c0.length()) + ra.max(rb));
            step_bound = moved * 1.01 + 1e-6 * (ra + rb);
            if self.bound > 0.0 {
                self.bound -= 2.0 * step_bound;
            }
        }
        self.last = Some((centre, qb));
        let pb = Pose::new(centre, qb);
        let before = narrow::is_contact_hint(self.hint).then_some((self.hint, self.bound));
        let with = narrow::collide_with_hint(a, pa, b, &pb, &mut self.hint, &mut self.bound);
        let full = narrow::collide(a, pa, b, &pb);
        assert_eq!(
            with, full,
            "step {k}: manifold differs from the full test's"
        );
        // The remembered face stood in when the pair kept its hint and margin (a full test
        // sets both anew).
        let stood = before.is_some_and(|b| {
            b == (self.hint, self.bound) && self.hint != narrow::HINT_EDGE_CONTACT
        });
        (stood, with.is_some(), step_bound)
    }
}

/// One pair stepped `steps` times: B's face `fb` laid on A's face `fa` (anti-parallel), then
/// B, moved `reach` times A's radius across A's face (up to its edge and off it), slides
/// slowly, spins about the normal at `spin` rad per step, tilts by up to
/// `tilt` rad (onto an edge and back) and its overlap swings from 0.5% of the radii to a gap
/// and back. The caller's part of the contract is kept as the simulation keeps it: before
/// each call the remembered margin is decreased by twice a true bound of how far any point
/// of either body moved in the other's frame. Returns (steps whose remembered face stood in
/// for the full test, steps that touched).
#[allow(clippy::too_many_arguments)]
fn run_resting(
    a: &Shape,
    b: &Shape,
    fa: usize,
    fb: usize,
    rng: &mut Rng,
    spin: f32,
    tilt: f32,
    reach: f32,
    steps: usize,
) -> (usize, usize) {
    let (pa_, pb_) = (poly(a), poly(b));
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let qa = rng.rotation();
    let na = qa * pa_.faces[fa].normal;
    // B's face normal turned onto -na, then spun about na.
    let lay = Quat::from_rotation_arc(pb_.faces[fb].normal, -na);
    let spin0 = rng.next() * std::f32::consts::TAU;
    let slide = rng.unit().cross(na).normalize_or_zero();
    let tilt_axis = rng.unit().cross(na).normalize_or_zero();
    let (ca, cb) = (qa * face_centre(pa_, fa), face_centre(pb_, fb));
    let mut pair = Remembering::new(a, b);
    let pa = Pose::new(Vec3::ZERO, qa);
    let (mut kept, mut touching) = (0, 0);
    for k in 0..steps {
        let phase = k as f32 * 0.01;
        let qb = (Quat::from_axis_angle(tilt_axis, tilt * (0.05 * phase).sin())
            * Quat::from_axis_angle(na, spin0 + spin * k as f32)
            * lay)
            .normalize();
        let overlap = (0.002 + 0.003 * phase.sin()) * (ra + rb);
        let side = slide * (ra * (reach + 0.1 * (0.03 * phase).sin()));
        // B's face centre on A's face plane, pressed in by `overlap`, slid sideways.
        let centre = ca + side - na * overlap - qb * cb;
        let (stood, touched, _) = pair.step((a, &pa), b, (centre, qb), k);
        kept += stood as usize;
        touching += touched as usize;
    }
    (kept, touching)
}

use clatter_geom::Pose;

fn shapes() -> Vec<PreparedShape> {
    common::solids_and_hull(12)
}

/// Every Platonic solid and a hull against every one, resting face on face on a few face
/// pairs, still, slow and tumbling: every step's manifold is the full test's, and the
/// remembered faces stood in for a good share of the touching steps (so the comparison
/// covers them, not only the full test).
#[test]
fn remembered_faces_give_the_full_tests_manifolds() {
    let shapes = shapes();
    let mut rng = Rng(4242);
    let (mut kept, mut touching, mut total) = (0, 0, 0);
    for sa in &shapes {
        for sb in &shapes {
            let (na, nb) = (poly(&sa.shape).faces.len(), poly(&sb.shape).faces.len());
            for (spin, tilt) in [(0.0, 0.0), (1e-5, 2e-4), (3e-4, 0.05), (3e-3, 1.5)] {
                for reach in [0.0, 0.4, 0.8, 1.2, 1.6] {
                    for _ in 0..2 {
                        let fa = (rng.next() * na as f32) as usize % na;
                        let fb = (rng.next() * nb as f32) as usize % nb;
                        let (k, t) = run_resting(
                            &sa.shape, &sb.shape, fa, fb, &mut rng, spin, tilt, reach, 400,
                        );
                        (kept, touching, total) = (kept + k, touching + t, total + 400);
                    }
                }
            }
        }
    }
    println!("{touching} of {total} pair-steps touching, remembered faces stood in {kept}");
    assert!(touching * 2 > total, "{touching} of {total} touching");
    assert!(
        kept * 4 > touching,
        "remembered faces stood in {kept} of {touching}"
    );
}

/// One pair stepped `steps` times with B at `pose_b(k)` (A still at the origin, turned by
/// `qa`), the caller's part of the contract kept as in [`run_resting`]: every step's
/// manifold compared bitwise with the full test's. Returns (steps whose remembered face
/// stood in, steps that touched).
fn run_poses(
    a: &Shape,
    b: &Shape,
    qa: Quat,
    steps: usize,
    mut pose_b: impl FnMut(usize) -> (Vec3, Quat),
) -> (usize, usize) {
    let mut pair = Remembering::new(a, b);
    let (mut kept, mut touching) = (0, 0);
    let pa = Pose::new(Vec3::ZERO, qa);
    for k in 0..steps {
        let (stood, touched, _) = pair.step((a, &pa), b, pose_b(k), k);
        kept += stood as usize;
        touching += touched as usize;
    }
    (kept, touching)
}

/// B's face `fb` tilted by about `tilt` rad against A's face `fa`, dipping outward across
/// A's face edge `edge`: B's face plane `depth` below A's face at that edge, and B's face's
/// outermost point `over` beyond the edge's side plane (just past it, or just short of it),
/// held there with slow drifts of all four. The contacts whose clipped points lie on the
/// reference face's side plane (the incident body crossing it) are those
/// `wedge_certified` serves.
#[allow(clippy::too_many_arguments)]
fn run_at_edge(
    a: &Shape,
    b: &Shape,
    fa: usize,
    fb: usize,
    edge: usize,
    rng: &mut Rng,
    tilt: f32,
    depth: f32,
    over: f32,
    steps: usize,
) -> (usize, usize) {
    let (pa_, pb_) = (poly(a), poly(b));
    let qa = rng.rotation();
    let n = pa_.faces[fa].normal;
    let lp = pa_.face_loop(fa);
    let (v0, v1) = (
        pa_.vertices[lp[edge] as usize],
        pa_.vertices[lp[(edge + 1) % lp.len()] as usize],
    );
    // In A's frame: the edge's midpoint, direction and outward side normal.
    let mid = 0.5 * (v0 + v1);
    let e = (v1 - v0).normalize();
    let s = e.cross(n);
    let lay = Quat::from_rotation_arc(pb_.faces[fb].normal, -n);
    let spin0 = rng.next() * std::f32::consts::TAU;
    let cb = face_centre(pb_, fb);
    let fl = pb_.face_loop(fb);
    run_poses(a, b, qa, steps, |k| {
        let k = k as f32;
        let th = tilt * (1.0 + 0.02 * (0.005 * k).sin());
        let d = depth * (1.0 + 0.3 * (0.013 * k).sin());
        let y = over * (1.0 + 0.5 * (0.02 * k).sin());
        // B's face normal dips outward: -n cos th - s sin th.
        let dip = Quat::from_rotation_arc(-n, -n * th.cos() - s * th.sin());
        let q = (dip * Quat::from_axis_angle(n, spin0 + 1e-5 * k) * lay).normalize();
        // B's face vertex farthest out along s, placed `y` beyond the edge on B's plane.
        let far = fl
            .iter()
            .map(|&i| q * pb_.vertices[i as usize])
            .max_by(|p, r| p.dot(s).total_cmp(&r.dot(s)))
            .expect("a face has corners");
        let at = mid + s * y - n * (d + y * th.tan());
        let mut pos = at - far;
        // Centred on the edge along it (a shift within B's face plane).
        pos += e * (mid - (q * cb + pos)).dot(e);
        (qa * pos, qa * q)
    })
}

/// Every Platonic solid and a hull against every one, B tilted over an edge of A's face and
/// held there (see [`run_at_edge`]): every step's manifold is the full test's, and the
/// certificate of a contact crossing the reference face's side stood in on many steps.
#[test]
fn contacts_across_the_reference_faces_edge_give_the_full_tests_manifolds() {
    let shapes = shapes();
    let mut rng = Rng(777);
    let (mut kept, mut touching, mut total) = (0, 0, 0);
    let wedge0 = narrow::wedge_certificates();
    for sa in &shapes {
        for sb in &shapes {
            let (pa_, pb_) = (poly(&sa.shape), poly(&sb.shape));
            let (na, nb) = (pa_.faces.len(), pb_.faces.len());
            for tilt in [0.05f32, 0.2, 0.5] {
                // Past the edge by up to what keeps the two faces' separations within the
                // full test's tolerance (1e-3 of the radius), or just short of it.
                for over in [-0.3e-3, 0.3e-3, 0.8e-3] {
                    for depth in [5e-4f32, 1.5e-3] {
                        let fa = (rng.next() * na as f32) as usize % na;
                        let fb = (rng.next() * nb as f32) as usize % nb;
                        let ne = pa_.face_loop(fa).len();
                        let edge = (rng.next() * ne as f32) as usize % ne;
                        let over = over / tilt.tan();
                        let (k, t) = run_at_edge(
                            &sa.shape, &sb.shape, fa, fb, edge, &mut rng, tilt, depth, over, 200,
                        );
                        (kept, touching, total) = (kept + k, touching + t, total + 200);
                    }
                }
            }
        }
    }
    let wedge = narrow::wedge_certificates() - wedge0;
    println!(
        "{touching} of {total} pair-steps touching, remembered faces stood in {kept}, \
         by the edge certificate {wedge}"
    );
    assert!(touching * 2 > total, "{touching} of {total} touching");
    assert!(
        kept * 4 > touching,
        "remembered faces stood in {kept} of {touching}"
    );
    assert!(
        wedge * 20 > touching,
        "the edge certificate stood in {wedge} of {touching}"
    );
}

/// B's face `fb` laid parallel on A's face `fa` (anti-parallel normals), sliding across it
/// at `slide` times A's radius per step, spinning about the normal at `spin` rad per step
/// and rocking by up to `rock` rad, pressed in by 0.2% of the radii: every step's manifold
/// compared bitwise with the full test's, the caller's part of the contract kept as in
/// [`run_resting`]. Returns (steps whose remembered face stood in, steps that touched,
/// steps that stood in after the bodies had moved, since the full test that set the
/// margin, by more than half the full test's tolerance).
///
/// Why the last count: the margin the pair kept before `contact_margin` took the reference
/// face's separation anew was at most `tol - eps` (its edge term, `face_best + tol -
/// max(face_best, best_e)`, is at most `tol`), spent at twice the motion bound per step, so
/// no remembered face could stand in once the bound summed since its full test passed
/// `tol / 2`. On parallel faces the cross and edge terms sit at `tol`, so these are the
/// steps the new margin adds.
#[allow(clippy::too_many_arguments)]
fn run_parallel(
    a: &Shape,
    b: &Shape,
    fa: usize,
    fb: usize,
    rng: &mut Rng,
    slide: f32,
    spin: f32,
    rock: f32,
    steps: usize,
) -> (usize, usize, usize) {
    let (pa_, pb_) = (poly(a), poly(b));
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let tol = 1e-3 * ra.max(rb);
    let qa = rng.rotation();
    let na = qa * pa_.faces[fa].normal;
    let lay = Quat::from_rotation_arc(pb_.faces[fb].normal, -na);
    let spin0 = rng.next() * std::f32::consts::TAU;
    let dir = rng.unit().cross(na).normalize_or_zero();
    let rock_axis = rng.unit().cross(na).normalize_or_zero();
    let (ca, cb) = (qa * face_centre(pa_, fa), face_centre(pb_, fb));
    let pa = Pose::new(Vec3::ZERO, qa);
    let mut pair = Remembering::new(a, b);
    let (mut kept, mut touching, mut beyond) = (0, 0, 0);
    // The motion bound summed since the last full test.
    let mut since = 0.0f32;
    for k in 0..steps {
        let kf = k as f32;
        let qb = (Quat::from_axis_angle(rock_axis, rock * (0.02 * kf).sin())
            * Quat::from_axis_angle(na, spin0 + spin * kf)
            * lay)
            .normalize();
        let overlap = (0.002 + 1e-4 * (0.05 * kf).sin()) * (ra + rb);
        let centre = ca + dir * (slide * ra * (kf - 0.5 * steps as f32)) - na * overlap - qb * cb;
        let (stood, touched, step_bound) = pair.step((a, &pa), b, (centre, qb), k);
        if stood {
            since += step_bound;
            beyond += (since > 0.5 * tol) as usize;
        } else {
            since = 0.0;
        }
        kept += stood as usize;
        touching += touched as usize;
    }
    (kept, touching, beyond)
}

/// Every Platonic solid and a hull against every one, laid face on face with parallel
/// faces, sliding and slowly turning (see [`run_parallel`]): every step's manifold is the
/// full test's, and the remembered faces stood in on many steps the margin relative to the
/// full test's own separation could not serve (more than half the tolerance moved since).
#[test]
fn parallel_faces_sliding_and_turning_stay_remembered() {
    let shapes = shapes();
    let mut rng = Rng(2323);
    let (mut kept, mut touching, mut beyond, mut total) = (0, 0, 0, 0);
    for sa in &shapes {
        for sb in &shapes {
            let (na, nb) = (poly(&sa.shape).faces.len(), poly(&sb.shape).faces.len());
            // Per step, motion bounds of about 1/60 to 1/10 of the tolerance.
            for (slide, spin, rock) in [(2e-5, 0.0, 0.0), (1e-5, 5e-6, 0.0), (5e-6, 1e-5, 2e-4)] {
                for _ in 0..2 {
                    let fa = (rng.next() * na as f32) as usize % na;
                    let fb = (rng.next() * nb as f32) as usize % nb;
                    let (k, t, o) = run_parallel(
                        &sa.shape, &sb.shape, fa, fb, &mut rng, slide, spin, rock, 300,
                    );
                    (kept, touching, beyond, total) =
                        (kept + k, touching + t, beyond + o, total + 300);
                }
            }
        }
    }
    println!(
        "{touching} of {total} pair-steps touching, remembered faces stood in {kept}, \
         {beyond} of them beyond the old margin's reach"
    );
    assert!(touching * 10 > total * 9, "{touching} of {total} touching");
    assert!(
        kept * 2 > touching,
        "remembered faces stood in {kept} of {touching}"
    );
    assert!(
        beyond * 4 > kept,
        "beyond the old margin's reach: {beyond} of {kept}"
    );
}

/// The closed form the remembered faces take for a box's vertices' smallest projection
/// (`ConvexPolyhedron::corner_box`) against the loop over the vertices, on the prepared cube
/// and on boxes built from eight corners with unequal half extents: the same value on random
/// directions and on directions with zero and tiny components; shapes that are not such a
/// box (the other solids, a hull, a box off the origin) are not recognised.
#[test]
fn box_corners_smallest_projection_in_closed_form() {
    let smallest = |p: &ConvexPolyhedron, n: Vec3| {
        let mut m = f32::INFINITY;
        for v in &p.vertices {
            let d = n.x * v.x + n.y * v.y + n.z * v.z;
            m = if d < m { d } else { m };
        }
        m
    };
    let corners = |h: Vec3, c: Vec3| -> Vec<Vec3> {
        (0..8)
            .map(|k| {
                let s = |b: u32| if k & b != 0 { -1.0 } else { 1.0 };
                c + Vec3::new(s(1) * h.x, s(2) * h.y, s(4) * h.z)
            })
            .collect()
    };
    let mut boxes: Vec<ConvexPolyhedron> = vec![poly(&shapes()[1].shape).clone()];
    for h in [Vec3::new(0.3, 1.7, 0.011), Vec3::new(2.5e-3, 1e-3, 7e-3)] {
        let hull = clatter_geom::convex_hull(&corners(h, Vec3::ZERO)).expect("a box");
        boxes.push(hull);
    }
    let mut rng = Rng(99);
    for p in &boxes {
        let h = p.corner_box.expect("a box's corners are recognised");
        for k in 0..20_000 {
            let mut n = rng.unit();
            match k % 4 {
                1 => n.x = 0.0,
                2 => n.y *= 1e-30,
                3 => n = Vec3::new(n.x, -0.0, 0.0),
                _ => {}
            }
            let a = n.abs();
            let closed = -((a.x * h.x + a.y * h.y) + a.z * h.z);
            assert_eq!(closed, smallest(p, n), "direction {n}");
        }
    }
    for s in shapes()
        .iter()
        .filter(|s| poly(&s.shape).vertices.len() != 8)
    {
        assert_eq!(poly(&s.shape).corner_box, None);
    }
    let off = corners(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.5, 0.0, 0.0));
    assert_eq!(ConvexPolyhedron::detect_corner_box(&off), None);
    let mut dented = corners(Vec3::ONE, Vec3::ZERO);
    dented[5].y = f32::from_bits(dented[5].y.to_bits() - 1);
    assert_eq!(ConvexPolyhedron::detect_corner_box(&dented), None);
}

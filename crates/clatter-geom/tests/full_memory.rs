//! The full separating-axis test with a pair's [`EdgeMemory`] against the same test without
//! it, when the full test runs at every step (no remembered contact stands in: the hint and
//! bound are reset before each call, as for a pair whose face contact leaves no margin, or
//! whose margin ran out). The full test then clips the face it chooses with what the pair's
//! record of that face's clip lets it skip, and measures that record itself (issue 23,
//! full32): polyhedron pairs kept touching while B turns about its own centre (its offset
//! in A's frame fixed: only the rotation moves the clipped points) or turns and slides,
//! every step's manifold, hint and bound compared bitwise with the test without memory.

use clatter_geom::narrow::{self, EdgeMemory, NO_HINT};
use clatter_geom::{ConvexPolyhedron, Pose, PreparedShape, Shape};
use glam::{Quat, Vec3};

mod common;
use common::{Rng, with_and_without_memory};

/// One pair stepped `steps` times, A still at the origin, touching face to vertex, edge or
/// face: with `ref_b` false, a face of A (turned at random) has B laid on it, a face of B
/// turned onto it and then tilted by `tilt` rad about a random axis, B's lowest point along
/// the face normal `0.3%` of the radii inside A's face plane, below a point of the face
/// off its centre (see [`off_centre`]); with `ref_b`, the same with the roles of the faces
/// swapped (a face of B, turned at random, and A laid on it and tilted), so that B's face
/// is the reference. Then B turns at `spin` rad per step about that face normal through
/// its own centre (the contact's depth kept, the incident points turning about the normal
/// in the reference body's frame, across its side planes), its centre moved by `slide`
/// times the radii per step across the normal. Before each call the hint and bound are
/// reset, so that the full test runs. Returns (steps that touched, steps whose hint came
/// back a face contact, of those on B's face).
fn run_pair(
    a: &Shape,
    b: &Shape,
    rng: &mut Rng,
    (spin, tilt, slide): (f32, f32, f32),
    ref_b: bool,
    steps: usize,
) -> (usize, usize, usize) {
    let (pa_, pb_) = (poly(a), poly(b));
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let (fa, fb) = (pick(rng, pa_.faces.len()), pick(rng, pb_.faces.len()));
    let q_face = rng.rotation();
    let tilt = Quat::from_axis_angle(rng.unit(), tilt);
    let delta = 0.003 * (ra + rb);
    // The face body's rotation, its face's outward normal `n` (world), the laid body's
    // rotation (its face turned onto `-n`, then tilted).
    let (qa, qb, n) = if ref_b {
        let n = q_face * pb_.faces[fb].normal;
        let lay = Quat::from_rotation_arc(pa_.faces[fa].normal, -n);
        ((tilt * lay).normalize(), q_face, n)
    } else {
        let n = q_face * pa_.faces[fa].normal;
        let lay = Quat::from_rotation_arc(pb_.faces[fb].normal, -n);
        (q_face, (tilt * lay).normalize(), n)
    };
    let centre0 = if ref_b {
        // A's lowest point along n, `delta` below the plane of B's face through B's face
        // centre.
        let low = lowest(pa_, qa, n);
        low + n * delta - qb * off_centre(pb_, fb, rng)
    } else {
        // B's lowest point along -n, `delta` below A's face plane, under its face centre.
        let top = qa * off_centre(pa_, fa, rng);
        let low_b = lowest(pb_, qb, -n);
        top - n * delta - low_b
    };
    let across = rng.unit().cross(n).normalize_or_zero();
    let pa = Pose::new(Vec3::ZERO, qa);
    let mut qb = qb;
    let mut memory = EdgeMemory::default();
    let (mut touching, mut faces, mut of_b) = (0, 0, 0);
    for k in 0..steps {
        let centre = centre0 + across * (slide * (ra + rb) * k as f32);
        let pb = Pose::new(centre, qb);
        let (mut hint_m, mut bound_m) = (NO_HINT, 0.0f32);
        let (mut hint, mut bound) = (NO_HINT, 0.0f32);
        let (with_m, without) = ((&mut hint_m, &mut bound_m), (&mut hint, &mut bound));
        let with = with_and_without_memory(a, &pa, b, &pb, &mut memory, with_m, without, k);
        touching += with.is_some() as usize;
        let face = narrow::is_contact_hint(hint) && hint != narrow::HINT_EDGE_CONTACT;
        faces += face as usize;
        of_b += (face && hint & narrow::HINT_KIND == narrow::HINT_FACE_B) as usize;
        qb = (Quat::from_axis_angle(n, spin) * qb).normalize();
    }
    (touching, faces, of_b)
}

/// A random index below `n`.
fn pick(rng: &mut Rng, n: usize) -> usize {
    (rng.next() * n as f32) as usize % n
}

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

/// A point of face `f` of `p` 60% of the way from its centre to one of its corners (at
/// random): a contact there turns across the face's side planes as the bodies turn about
/// the face's normal through the laid body's centre.
fn off_centre(p: &ConvexPolyhedron, f: usize, rng: &mut Rng) -> Vec3 {
    let lp = p.face_loop(f);
    let corner = p.vertices[lp[pick(rng, lp.len())] as usize];
    let c = face_centre(p, f);
    c + 0.6 * (corner - c)
}

/// The vertex of `p` (turned by `q`, its centre at the origin) lowest along `n`.
fn lowest(p: &ConvexPolyhedron, q: Quat, n: Vec3) -> Vec3 {
    p.vertices
        .iter()
        .map(|&v| q * v)
        .min_by(|x, y| x.dot(n).total_cmp(&y.dot(n)))
        .expect("vertices")
}

fn shapes() -> Vec<PreparedShape> {
    common::solids_and_hull(12)
}

/// Every Platonic solid and a hull against every one, touching while B turns about its
/// centre (slowly, so that the clip's record serves many steps, and faster, so that it
/// expires), still or sliding: the full test with the pair's memory gives the manifold,
/// hint and bound of the test without it at every step, and most touching steps end in a
/// remembered face contact (so the comparison covers the face clip of the full test, with
/// records measured and served, not only edge contacts).
#[test]
fn the_full_tests_face_clip_with_memory_changes_no_answer() {
    let shapes = shapes();
    let mut rng = Rng(2323);
    let (mut touching, mut faces, mut of_b, mut total) = (0, 0, 0, 0);
    for sa in &shapes {
        for sb in &shapes {
            for spin in [1e-4, 1e-3, 1e-2] {
                for (tilt, slide) in [(0.0, 0.0), (0.05, 0.0), (0.3, 0.0), (0.05, 2e-5)] {
                    for ref_b in [false, true] {
                        let motion = (spin, tilt, slide);
                        let (t, f, fb) =
                            run_pair(&sa.shape, &sb.shape, &mut rng, motion, ref_b, 120);
                        (touching, faces, of_b) = (touching + t, faces + f, of_b + fb);
                        total += 120;
                    }
                }
            }
        }
    }
    println!("{touching} of {total} pair-steps touching, {faces} face contacts ({of_b} on B)");
    assert!(touching * 2 > total, "{touching} of {total} touching");
    assert!(faces * 2 > touching, "{faces} face contacts of {touching}");
    assert!(of_b * 8 > faces, "{of_b} face contacts on B of {faces}");
}

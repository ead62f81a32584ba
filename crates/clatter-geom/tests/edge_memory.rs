//! The edge searches with a pair's [`EdgeMemory`] (the Gauss map's remembered edge pairs,
//! the deep direction pairs left out by direction) against the same searches without it:
//! polyhedron pairs stepped through time (turning slowly and fast, sliding, pressed
//! together and pulled apart), every step's manifold, hint and bound compared bitwise.

use clatter_geom::narrow::{self, EdgeMemory, NO_HINT};
use clatter_geom::{Pose, PreparedShape, Shape};
use glam::{Quat, Vec3};

mod common;
use common::{Rng, with_and_without_memory};

fn poly(s: &Shape) -> &clatter_geom::ConvexPolyhedron {
    match s {
        Shape::Polyhedron(p) => p,
        _ => panic!("a polyhedron"),
    }
}

fn shapes() -> Vec<PreparedShape> {
    common::solids_and_hull(12)
}

/// One pair stepped `steps` times: B turns at `spin` rad per step about a fixed axis while
/// A turns slower, and B's centre slides and moves in and out along the line of centres.
/// Returns how many steps the memory held a finished search before the call.
fn run_pair(a: &Shape, b: &Shape, rng: &mut Rng, spin: f32, steps: usize) -> usize {
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let dir = rng.unit();
    let slide = rng.unit().cross(dir).normalize_or_zero();
    let (mut qa, mut qb) = (rng.rotation(), rng.rotation());
    let (wa, wb) = (rng.unit(), rng.unit());
    let mut memory = EdgeMemory::default();
    let (mut hint_m, mut bound_m) = (NO_HINT, 0.0f32);
    let (mut hint, mut bound) = (NO_HINT, 0.0f32);
    let mut held = 0;
    for k in 0..steps {
        let phase = k as f32 * 0.05;
        // From deep overlap to apart and back.
        let gap = (0.72 + 0.25 * phase.sin()) * (ra + rb);
        let pa = Pose::new(Vec3::ZERO, qa);
        let pb = Pose::new(dir * gap + slide * (0.3 * phase.cos()), qb);
        held += memory.remembers() as usize;
        let (with_m, without) = ((&mut hint_m, &mut bound_m), (&mut hint, &mut bound));
        with_and_without_memory(a, &pa, b, &pb, &mut memory, with_m, without, k);
        // The caller's part of the remembered contact's contract: a margin less twice a
        // bound of the vertices' motion to the next step (as `clatter`'s contact stage
        // does), so the remembered paths serve only where the full test would give their
        // answer. (A remembered face contact's overlap may be certified from what its
        // memory recorded, a certificate the call without memory does not have: the same
        // answer as the full test's either way, but only within this contract. A fixed
        // 1e-3 (r_a + r_b) a step was below the motion here: B's centre alone moves about
        // 0.0125 (r_a + r_b) a step.)
        if bound > 0.0 {
            let phase = (k + 1) as f32 * 0.05;
            let next = dir * (0.72 + 0.25 * phase.sin()) * (ra + rb) + slide * (0.3 * phase.cos());
            let moved = (next - pb.position).length();
            let far = pb.position.length() + moved;
            let turned = 1.1 * spin;
            bound -= 2.0 * ((moved + turned * (far + ra + rb)) * 1.01 + 1e-5 * (ra + rb));
            if !narrow::is_contact_hint(hint_m) {
                bound_m = bound;
            }
        }
        qa = (Quat::from_axis_angle(wa, 0.1 * spin) * qa).normalize();
        qb = (Quat::from_axis_angle(wb, spin) * qb).normalize();
    }
    held
}

#[test]
fn the_memory_changes_no_answer() {
    let shapes = shapes();
    let mut rng = Rng(12345);
    let (mut held, mut total) = (0, 0);
    for sa in &shapes {
        for sb in &shapes {
            for spin in [1e-4, 2e-3, 3e-2, 0.3] {
                for _ in 0..3 {
                    held += run_pair(&sa.shape, &sb.shape, &mut rng, spin, 150);
                    total += 150;
                }
            }
        }
    }
    // The memory served a good share of the steps (the slow pairs), so the comparison
    // covered the remembered path, not only the recording one.
    assert!(
        held * 4 > total,
        "memory held in {held} of {total} pair-steps"
    );
}

/// The support of `s`'s vertices along `dir` (in the world) at rotation `q`.
fn support(s: &Shape, q: Quat, dir: Vec3) -> f32 {
    let Shape::Polyhedron(p) = s else {
        panic!("a polyhedron")
    };
    let local = q.conjugate() * dir;
    p.vertices
        .iter()
        .map(|v| v.dot(local))
        .fold(f32::MIN, f32::max)
}

/// One pair kept just touching (the centres' distance set from the supports along the line
/// of centres, less a small overlap that swings to a gap and back), both bodies tumbling
/// slowly while B slides across A: face, edge and vertex contacts in turn, separating and
/// touching again. The caller's bound is decreased by twice a true bound of the motion
/// (as the simulation does), so the remembered paths run as long as the contract lets them.
/// With `about_line`, B turns about the line of centres (so that the edge pairs of an edge
/// contact take turns winning). Returns (steps whose hint was an edge contact, steps that
/// touched, edge contacts whose normal turned by more than 1e-3 rad since the step before,
/// itself an edge contact: the winning edge pair changed, remembered edge contacts that
/// stood in with B's point of the contact less than `2e-5 (r_a + r_b)` inside A).
fn run_touching(
    a: &Shape,
    b: &Shape,
    rng: &mut Rng,
    spin: f32,
    steps: usize,
    about_line: bool,
) -> (usize, usize, usize, usize) {
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let mut shallow = 0;
    let dir = rng.unit();
    let slide = rng.unit().cross(dir).normalize_or_zero();
    let (mut qa, mut qb) = (rng.rotation(), rng.rotation());
    let (wa, wb) = (rng.unit(), rng.unit());
    let wb = if about_line { dir } else { wb };
    let (mut switches, mut last_edge): (usize, Option<Vec3>) = (0, None);
    let mut memory = EdgeMemory::default();
    let (mut hint_m, mut bound_m) = (NO_HINT, 0.0f32);
    let (mut hint, mut bound) = (NO_HINT, 0.0f32);
    let (mut edges, mut touching) = (0, 0);
    let mut last: Option<Vec3> = None;
    for k in 0..steps {
        let phase = k as f32 * 0.02;
        // Overlap from 1% of the radii to a gap of 0.2% and back; B slides sideways.
        let overlap = (0.004 + 0.006 * phase.sin()) * (ra + rb);
        let side = slide * (0.03 * (0.7 * phase).sin());
        let pa = Pose::new(Vec3::ZERO, qa);
        // The distance along `dir` at which the bodies just touch, by bisection on the full
        // test (apart at the supports' sum, overlapping at 0).
        let (mut lo, mut hi) = (0.0f32, support(a, qa, dir) + support(b, qb, -dir));
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            let pm = Pose::new(side + dir * mid, qb);
            if narrow::collide(a, &pa, b, &pm).is_some() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let centre = side + dir * (hi - overlap);
        let pb = Pose::new(centre, qb);
        // Twice a bound of how far any point of either body moved since the last call.
        if let Some(prev) = last {
            let moved = (centre - prev).length() + 0.1 * spin * ra + spin * rb;
            let grown = 2.0 * moved * 1.01 + 1e-6 * (ra + rb);
            if bound > 0.0 {
                bound -= grown;
                if !narrow::is_contact_hint(hint_m) {
                    bound_m = bound;
                }
            }
        }
        last = Some(centre);
        let before = (hint, bound);
        let (with_m, without) = ((&mut hint_m, &mut bound_m), (&mut hint, &mut bound));
        let with = with_and_without_memory(a, &pa, b, &pb, &mut memory, with_m, without, k);
        let full = narrow::collide(a, &pa, b, &pb);
        assert_eq!(
            with, full,
            "step {k}: manifold differs from the full test's"
        );
        touching += with.is_some() as usize;
        let edge = hint == narrow::HINT_EDGE_CONTACT;
        edges += edge as usize;
        // A remembered edge contact stood in (hint and bound kept), B's point of the
        // contact (half the depth from the manifold's point, against the normal) not deep
        // in A (A's face planes in the world frame).
        if let Some(m) = with.filter(|_| edge && before == (hint, bound)) {
            let p = m.points()[0];
            let qb = qa.conjugate() * (p.point - m.normal * (0.5 * p.depth));
            let deep = poly(a)
                .faces
                .iter()
                .all(|f| f.normal.dot(qb) - f.offset <= -2e-5 * (ra + rb));
            shallow += !deep as usize;
        }
        let normal = with.filter(|_| edge).map(|m| m.normal);
        if let (Some(n), Some(before)) = (normal, last_edge) {
            switches += (n.angle_between(before) > 1e-3) as usize;
        }
        last_edge = normal;
        qa = (Quat::from_axis_angle(wa, 0.1 * spin) * qa).normalize();
        qb = (Quat::from_axis_angle(wb, spin) * qb).normalize();
    }
    (edges, touching, switches, shallow)
}

/// Pairs kept touching with small overlaps, where the edge searches' floors are close to
/// the best edge axis and the memories' depth levels leave pairs out (Gauss map and by
/// direction): every step's manifold, hint and bound bitwise those of the calls without
/// memory and of the full test.
#[test]
fn touching_pairs_turning_slowly_keep_their_answers() {
    let shapes = shapes();
    let mut rng = Rng(777);
    let (mut edges, mut touching, mut total, mut shallow) = (0, 0, 0, 0);
    for sa in &shapes {
        for sb in &shapes {
            for spin in [2e-5, 3e-4, 3e-3] {
                for _ in 0..2 {
                    let (e, t, _, sh) =
                        run_touching(&sa.shape, &sb.shape, &mut rng, spin, 300, false);
                    (edges, touching, total) = (edges + e, touching + t, total + 300);
                    shallow += sh;
                }
            }
        }
    }
    println!(
        "{touching} of {total} pair-steps touching, {edges} edge contacts, {shallow} \
         remembered with B's point of the contact less than 2e-5 (r_a + r_b) inside A"
    );
    // Remembered edge contacts stood in where B's point of the contact was not deep in A
    // (no overlap check: the decision's margin rules out a separating axis), every one of
    // those steps checked above.
    assert!(shallow * 50 > edges, "{shallow} of {edges} edge contacts");
    // Most steps touch, and a good share of them are remembered edge contacts.
    assert!(touching * 2 > total, "{touching} of {total} touching");
    assert!(edges * 10 > touching, "{edges} edge contacts of {touching}");
}

/// Edge contacts whose winning edge pair changes while the memory serves: B turns about
/// the line of centres (slowly enough for the memories to hold for many steps), so another
/// edge pair rises to the winner's separation and overtakes it, through the range where
/// the searches leave pairs out below the last winner's separation (evaluated first) and
/// where ties are decided by the search's order. Every step's manifold, hint and bound
/// bitwise those without memory and of the full test.
#[test]
fn edge_pairs_overtaking_the_winner_keep_their_answers() {
    let shapes = shapes();
    let mut rng = Rng(4242);
    let (mut edges, mut switches) = (0, 0);
    for sa in &shapes {
        for sb in &shapes {
            for spin in [1e-3, 4e-3] {
                for _ in 0..2 {
                    let (e, _, w, _) =
                        run_touching(&sa.shape, &sb.shape, &mut rng, spin, 300, true);
                    (edges, switches) = (edges + e, switches + w);
                }
            }
        }
    }
    println!("{edges} edge contacts, {switches} with a new winning pair");
    // Winners changed often within edge contacts, not only between contacts.
    assert!(switches * 20 > edges, "{switches} new winners of {edges}");
}

/// The rotation angle of `q` (radians, at most pi), accurate for small turns (see
/// `face_memory.rs`'s `angle`).
fn angle(q: Quat) -> f32 {
    2.0 * q.xyz().length().atan2(q.w.abs())
}

/// What [`run_crossed_edges`] counted: pair-steps whose hint was an edge contact, those
/// where the remembered edge contact stood in for the full test, and of those the steps
/// where the older rule (the room stored once and spent at twice the summed motion bound)
/// would have run the full test.
#[derive(Default)]
struct Crossed {
    edges: usize,
    served: usize,
    beyond_old: usize,
}

/// One pair stepped `steps` times in an edge-edge contact: A's edge `ea` and B's edge `eb`
/// crossed (each body's support along the line of centres `dir` is its edge: `dir` is A's
/// two faces' normals' bisector, B's bisector turned onto `-dir`), pressed in by a small
/// overlap along `dir`, while B spins slowly about `dir` (the edges stay crossed, at a
/// turning angle), rocks slightly off it, and slides across A's edge. The caller's part of
/// the contract is kept as the simulation keeps it: before each call the remembered margin
/// is decreased by twice a true bound of how far any point of either body moved in the
/// other's frame (A is fixed). Every step's manifold is compared bitwise with the full
/// test's.
#[allow(clippy::too_many_arguments)]
fn run_crossed_edges(
    a: &Shape,
    b: &Shape,
    ea: usize,
    eb: usize,
    rng: &mut Rng,
    spin: f32,
    steps: usize,
    counts: &mut Crossed,
) {
    let (pa_, pb_) = (poly(a), poly(b));
    let (ra, rb) = (a.bounding_radius(), b.bounding_radius());
    let bisector = |p: &clatter_geom::ConvexPolyhedron, e: usize| {
        let [f0, f1] = p.edge_faces[e];
        (p.faces[f0 as usize].normal + p.faces[f1 as usize].normal).normalize()
    };
    let midpoint = |p: &clatter_geom::ConvexPolyhedron, e: usize| {
        let [v0, v1] = p.edges[e];
        0.5 * (p.vertices[v0 as usize] + p.vertices[v1 as usize])
    };
    let length = |p: &clatter_geom::ConvexPolyhedron, e: usize| {
        let [v0, v1] = p.edges[e];
        (p.vertices[v1 as usize] - p.vertices[v0 as usize]).length()
    };
    let qa = rng.rotation();
    let pa = Pose::new(Vec3::ZERO, qa);
    let dir = qa * bisector(pa_, ea);
    let lay = Quat::from_rotation_arc(bisector(pb_, eb), -dir);
    let spin0 = rng.next() * std::f32::consts::TAU;
    let rock_axis = rng.unit().cross(dir).normalize_or_zero();
    let slide = rng.unit().cross(dir).normalize_or_zero();
    let reach = 0.1 * length(pa_, ea).min(length(pb_, eb));
    let ma = qa * midpoint(pa_, ea);
    let (mut hint, mut bound) = (NO_HINT, 0.0f32);
    // The summed motion bound since the last full test (the older rule's spending).
    let mut spent = 0.0f32;
    let mut last: Option<(Vec3, Quat)> = None;
    for k in 0..steps {
        let phase = k as f32 * 0.02;
        let qb = (Quat::from_axis_angle(dir, spin0 + spin * k as f32)
            * Quat::from_axis_angle(rock_axis, 2e-3 * (0.5 * phase).sin())
            * lay)
            .normalize();
        let overlap = (0.002 + 0.0015 * (1.5 * phase).sin()) * (ra + rb);
        // B's edge midpoint on A's, slid sideways, pressed in along `dir`.
        let centre = ma - qb * midpoint(pb_, eb) + slide * (reach * phase.sin()) - dir * overlap;
        if let Some((c0, q0)) = last {
            // B's points move by at most |dc| + th (|c| + r_b) in A's (fixed) frame, and
            // A's points in B's frame by at most |dc| + th (|c| + r_a).
            let th = angle(qb * q0.conjugate());
            let moved =
                (centre - c0).length() + th * (centre.length().max(c0.length()) + ra.max(rb));
            let step_bound = moved * 1.01 + 1e-6 * (ra + rb);
            if bound > 0.0 {
                bound -= 2.0 * step_bound;
                spent += step_bound;
            }
        }
        last = Some((centre, qb));
        let pb = Pose::new(centre, qb);
        let before = (hint, bound);
        let with = narrow::collide_with_hint(a, &pa, b, &pb, &mut hint, &mut bound);
        let full = narrow::collide(a, &pa, b, &pb);
        assert_eq!(
            with, full,
            "step {k}: manifold differs from the full test's"
        );
        let edge = hint == narrow::HINT_EDGE_CONTACT;
        counts.edges += edge as usize;
        let served = edge && before == (hint, bound);
        if let Some(m) = with.filter(|_| served) {
            counts.served += 1;
            // The older rule stored the room `R` once (`before.1 / 2 + spent` here) and
            // served while `R - 2 spent + best_e > 0`, `best_e` the edge axis's separation.
            let best_e = -m.points()[0].depth;
            counts.beyond_old += (0.5 * before.1 - spent + best_e <= 0.0) as usize;
        } else {
            spent = 0.0;
        }
    }
}

/// Every Platonic solid and a hull against every one in edge-edge contacts (a few edge
/// pairs each), the edges crossed, B spinning slowly about the contact normal, rocking and
/// sliding across A's edge: every step's manifold is the full test's, bitwise, and the
/// remembered edge contacts stood in for most edge-contact steps, a good share of them
/// after the summed motion bound had spent the room the older rule allowed (the room
/// stored once and spent at twice the bound: its check would have run the full test).
#[test]
fn crossed_edges_sliding_and_turning_stay_remembered() {
    let shapes = shapes();
    let mut rng = Rng(2311);
    let mut counts = Crossed::default();
    for sa in &shapes {
        for sb in &shapes {
            let (pa_, pb_) = (poly(&sa.shape), poly(&sb.shape));
            for _ in 0..3 {
                let ea = (rng.next() * pa_.edges.len() as f32) as usize % pa_.edges.len();
                let eb = (rng.next() * pb_.edges.len() as f32) as usize % pb_.edges.len();
                for spin in [2e-5, 2e-4] {
                    run_crossed_edges(
                        &sa.shape,
                        &sb.shape,
                        ea,
                        eb,
                        &mut rng,
                        spin,
                        300,
                        &mut counts,
                    );
                }
            }
        }
    }
    let Crossed {
        edges,
        served,
        beyond_old,
    } = counts;
    println!(
        "{edges} edge-contact steps, {served} served by the remembered edge, {beyond_old} \
         of them past the older rule's room"
    );
    assert!(served * 2 > edges, "{served} served of {edges}");
    assert!(
        beyond_old * 4 > served,
        "{beyond_old} past the old room of {served}"
    );
}

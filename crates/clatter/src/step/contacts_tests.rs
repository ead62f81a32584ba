//! Tests of the contact stage's private pieces.

use super::axis_motion_bound;
use crate::World;
use crate::pile::{PileParams, PileShape, poured};
use crate::step::motion::BodyBound;
use clatter_geom::Shape;
use glam::DVec3;

/// Vertices of body `j`'s shape as seen from body `i`'s frame, in f64 (the truth the bound
/// is held to: the stored poses, transformed without f32 rounding).
fn vertices_in(w: &World, i: usize, j: usize) -> Vec<DVec3> {
    let Shape::Polyhedron(p) = w.shape(j) else {
        return Vec::new();
    };
    let d = w.offset_of(i, j).as_dvec3();
    let (qi, qj) = (
        w.state.orientation[i].as_dquat().normalize(),
        w.state.orientation[j].as_dquat().normalize(),
    );
    let inv = qi.conjugate();
    p.vertices
        .iter()
        .map(|v| inv * (d + qj * v.as_dvec3()))
        .collect()
}

/// The largest move of any vertex of either body in the other's frame over one step.
fn moved(w0: &World, w1: &World, i: usize, j: usize) -> f64 {
    let far = |a: usize, b: usize| {
        vertices_in(w0, a, b)
            .iter()
            .zip(vertices_in(w1, a, b))
            .map(|(p0, p1)| (p1 - *p0).length())
            .fold(0.0, f64::max)
    };
    far(i, j).max(far(j, i))
}

/// `axis_motion_bound` (the plain path), taken at a step's end from the velocities and
/// offset there, bounds how far every vertex of each body of a pair moved in the other's
/// frame during that step: held on every touching or near polyhedron pair of a pile poured,
/// landing and settling (fast and slow, turning and sliding), against the stored poses
/// before and after, in f64. Also: the bound is not loose by orders of magnitude (it is
/// what lets a remembered contact serve its steps).
#[test]
fn axis_motion_bound_holds_over_real_steps() {
    let params = PileParams {
        restitution: 0.3,
        ..PileParams::default()
    };
    let mut w = World::new(poured(PileShape::Mixed, 96, &params, 7));
    let is_poly = |w: &World, i: usize| matches!(w.shape(i), Shape::Polyhedron(_));
    let (mut checked, mut worst) = (0usize, 0.0f64);
    for step in 0..3000 {
        let before = w.clone();
        w.step().expect("step");
        if step % 7 != 0 {
            continue;
        }
        for &[i, j] in w.contacts.pairs() {
            let (i, j) = (i as usize, j as usize);
            if !(is_poly(&w, i) && is_poly(&w, j)) {
                continue;
            }
            let d = w.offset_of(i, j);
            let (bi, bj) = (BodyBound::of(&w, i), BodyBound::of(&w, j));
            let bound = axis_motion_bound::<false>(&w, i, j, d, &bi, &bj) as f64;
            let actual = moved(&before, &w, i, j);
            assert!(
                actual <= bound,
                "step {step}, pair ({i}, {j}): moved {actual:e} > bound {bound:e}"
            );
            if actual > 1e-7 {
                worst = worst.max(actual / bound);
                checked += 1;
            }
        }
    }
    eprintln!("checked {checked}, worst ratio {worst}");
    assert!(checked > 1000, "only {checked} moving pairs checked");
    // Not vacuous: some pair's motion comes within a factor of 20 of its bound.
    assert!(
        worst > 0.05,
        "bound loose everywhere: largest ratio {worst}"
    );
}

//! The wall pairs of the plain path (no composites, not spheres only): a body against a
//! plane wall, as [`wall_pair`] computes it (the same floats in the same
//! order, so the same bits), with two savings:
//!
//! - **A pair still apart is skipped.** A pair found apart keeps a lower bound of its gap
//!   ([`WallGaps`]): the lowest vertex height the narrow phase computed (or the bounding
//!   sphere's, or a sphere's), less a margin for rounding ([`apart_bound`]), less each step
//!   the most any point of the body can have moved ([`BodyBound::moved`], the bound the body
//!   pairs' separation bounds fall by). While it is positive no vertex can have reached the
//!   plane, so the narrow phase would find nothing: the pair is not computed (nothing to
//!   write: a pair found apart was released). About a third of a settled cube pile's wall
//!   pairs (bodies near the floor or a side wall but not on it).
//! - **The manifold in place**, from [`narrow::collide_plane_polyhedron`], with the depths'
//!   `rest` added where it lies (the `Option<Manifold>` copies through `collide_plane` and
//!   `World::add_rest` were a tenth of a wall pair), and the body's arrays cut to the body
//!   count once per chunk ([`WallBodies`]), one bounds check for a pair's reads.
//!
//! Why the skip is safe: with `h` a vertex's height as computed (f32) and `H` as it is
//! (exact, at the stored pose), `|h - H|` is within a few ulps of the body's radius and its
//! centre's height (the rotation of the normal into the body's frame, the dot product, the
//! f32 offset of the plane; `rest` and the double-single sum's error below that), and a
//! step moves every point of the body by at most its `moved`: so a vertex computed at or
//! above the plane at the last full test, by more than the margin (`1e-4 (r + |c|)`, far
//! above those errors, the next test's included) plus the motion since, is still computed
//! above it. Not in periodic worlds (a body wrapped into the box jumps along the normal of
//! a wall not parallel to the wrapping axis) and not for an orientation far from unit length
//! (its rotation scales the vertices). The gaps are kept only for the walls they were found
//! with (a moved wall clears them).

use glam::{Quat, Vec3};

use super::contacts::{law_side, pair_context, release};
use super::motion::BodyBound;
use crate::law::{self, BodyMotion, ContactForce};
use crate::precise::Ds3A;
use crate::world::{Wall, World};
use clatter_geom::narrow::{self, ContactPoint, Manifold};
use clatter_geom::{Pose, Shape};

/// The per-wall-pair gap bounds (see the module docs): a cache that changes no result.
#[derive(Debug, Clone, Default)]
pub(crate) struct WallGaps {
    /// Per wall pair of the list, its gap bound (0: computed in full next step).
    pub(crate) gaps: Vec<f32>,
    /// The walls the bounds were found with.
    walls: Vec<Wall>,
}

impl WallGaps {
    /// Ready for a step of a list of `pairs` wall pairs in a world with `walls`: the bounds
    /// kept if they were found with these walls and this many pairs, else every one 0.
    pub(crate) fn fit(&mut self, walls: &[Wall], pairs: usize) {
        if self.walls != walls || self.gaps.len() != pairs {
            self.walls.clear();
            self.walls.extend_from_slice(walls);
            self.gaps.clear();
            self.gaps.resize(pairs, 0.0);
        }
    }
}

/// The per-body arrays a wall pair reads, each cut to the world's body count `n`: one test
/// that a pair's body is below `n` stands for every read's bounds check (as the body
/// pairs' `PlainBodies`). Made once per chunk of wall pairs.
pub(super) struct WallBodies<'a> {
    n: usize,
    /// Whether the gaps may be kept (not in a periodic world).
    keep: bool,
    bounds: &'a [BodyBound],
    x: &'a [Ds3A],
    orientation: &'a [Quat],
    velocity: &'a [Vec3],
    omega: &'a [Vec3],
    shape: &'a [u32],
    radius: &'a [f32],
    material: &'a [u32],
    mass: &'a [f32],
    equivalent_radius: &'a [f32],
    is_sphere: &'a [bool],
}

impl<'a> WallBodies<'a> {
    /// The arrays of `w` (with the step's positions `x`), cut to its body count (a panic
    /// if one is shorter, as its first read out of range would have been).
    #[inline(always)]
    pub(super) fn of(w: &'a World, x: &'a [Ds3A]) -> Self {
        let n = w.len();
        let (s, c) = (&w.state, &w.consts);
        Self {
            n,
            keep: w.periodic.is_none(),
            bounds: &w.body_bounds[..n],
            x: &x[..n],
            orientation: &s.orientation[..n],
            velocity: &s.velocity[..n],
            omega: &s.omega[..n],
            shape: &c.shape[..n],
            radius: &c.radius[..n],
            material: &c.material[..n],
            mass: &c.mass[..n],
            equivalent_radius: &c.equivalent_radius[..n],
            is_sphere: &c.is_sphere[..n],
        }
    }
}

/// The gap bound kept for a pair found apart: `lowest` (the lowest height the narrow phase
/// computed, see [`narrow::collide_plane_polyhedron`]) less the margin for rounding,
/// `1e-4 (r + |c|)` (`r` the body's bounding radius, `c` its centre's height above the
/// plane as computed) and `1e-9 (|d| + |x|_1)` (`d` the wall's offset, `x` the body's
/// position: the double-single offset's error, far below). NaN or negative when nothing
/// is known (never skipped).
#[inline(always)]
pub(super) fn apart_bound(lowest: f32, r: f32, c: f32, d: f32, x: &Ds3A) -> f32 {
    let far = d.abs() + x.hi.abs().element_sum();
    lowest - (1e-4 * (r + c.abs()) + 1e-9 * far)
}

/// Body `i` against wall `wall` on the plain path (see the module docs): the same result as
/// [`wall_pair`]`::<false>`, bit for bit, and `gap` kept.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn plain_wall(
    w: &World,
    v: &WallBodies,
    [i, wall]: [u32; 2],
    hist: &mut Vec3,
    force: &mut ContactForce,
    touching: &mut bool,
    twist: &mut f32,
    gap: &mut f32,
    plain: bool,
) -> bool {
    let i = i as usize;
    // The one bounds check for every read of `v` below.
    assert!(i < v.n, "a wall pair's body out of range");
    // Still apart by more than the body can have moved: not touching (a pair is kept
    // apart only when found so, and then released).
    let left = *gap - v.bounds[i].moved;
    if left > 0.0 {
        debug_assert!(!*touching, "a pair kept apart touches");
        *gap = left;
        return false;
    }
    let wall = &w.walls[wall as usize];
    // Body i at the origin, the plane shifted by its position (in f64).
    let (plane, rest) = w.plane_in(v.x, i, &wall.plane);
    let keep = |lowest: f32| {
        if v.keep {
            apart_bound(
                lowest,
                v.radius[i],
                plane.offset,
                wall.plane.offset,
                &v.x[i],
            )
        } else {
            0.0
        }
    };
    let p = match &w.shapes[v.shape[i] as usize].shape {
        Shape::Polyhedron(p) => p,
        Shape::Sphere { radius } => {
            let touches = if plain {
                sphere_wall::<true>(
                    w, i, wall, &plane, *radius, rest, hist, force, touching, twist,
                )
            } else {
                sphere_wall::<false>(
                    w, i, wall, &plane, *radius, rest, hist, force, touching, twist,
                )
            };
            // `sphere_wall`'s height of the centre, as it computes it.
            let centre_height = plane.normal.dot(Vec3::ZERO) - plane.offset;
            *gap = if touches {
                0.0
            } else {
                keep(centre_height - *radius)
            };
            return touches;
        }
        Shape::Composite(_) => unreachable!("no composites on the plain path"),
    };
    let q = v.orientation[i];
    let pose = Pose::new(Vec3::ZERO, q);
    let mut m = Manifold::default();
    match narrow::collide_plane_polyhedron(&plane, p, &pose, &mut m) {
        Ok(()) => {
            // `World::add_rest`.
            for p in &mut m.points[..m.count] {
                p.depth += rest;
            }
            *gap = 0.0;
            let params = w.pair_params(wall.material, v.material[i]);
            let (r, sphere) = (v.equivalent_radius[i], v.is_sphere[i]);
            let share = law::point_share(sphere, sphere);
            let context = pair_context(w, params, v.mass[i], r, share);
            // `BodyMotion::default()` and `w.local_motion(i)`.
            let a = BodyMotion::default();
            let b = BodyMotion {
                position: Vec3::ZERO,
                velocity: v.velocity[i],
                omega: v.omega[i],
            };
            *force = if plain {
                law::contact_force_in::<true>(&context, &m, &a, &b, hist, twist)
            } else {
                law::contact_force_in::<false>(&context, &m, &a, &b, hist, twist)
            };
            *touching = true;
        }
        Err(lowest) => {
            // An orientation far from unit length scales its vertices: nothing kept.
            let unit = (q.length_squared() - 1.0).abs() < 1e-5;
            *gap = if unit { keep(lowest) } else { 0.0 };
            if *touching {
                release(force, hist, Some(twist), touching);
            }
        }
    }
    *touching
}

/// A sphere (not a piece) against a wall: [`narrow::collide_plane`]'s sphere case (the
/// sphere at the origin, the plane shifted by its position) with the depth's `rest` added,
/// and [`law::contact_force`]'s one-point law, written out without building a manifold: the
/// same operations in the same order, so the same bits.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn sphere_wall<const PLAIN: bool>(
    w: &World,
    i: usize,
    wall: &crate::world::Wall,
    plane: &narrow::Plane,
    radius: f32,
    rest: f32,
    hist: &mut Vec3,
    force: &mut ContactForce,
    touching: &mut bool,
    coverage: &mut f32,
) -> bool {
    let n = plane.normal;
    let centre_height = n.dot(Vec3::ZERO) - plane.offset;
    let depth = radius - centre_height;
    // Not `depth > 0.0`: a NaN depth is a contact there, as in `collide_plane`.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(depth <= 0.0) {
        let cp = ContactPoint {
            point: Vec3::ZERO - n * (radius - 0.5 * depth),
            depth: depth + rest,
        };
        let params = w.pair_params(wall.material, w.consts.material[i]);
        let (r, sphere) = law_side::<false>(w, i, 0);
        let share = law::point_share(sphere, sphere);
        let context = pair_context(w, params, w.consts.mass[i], r, share);
        *force = law::point_contact_force_in::<PLAIN>(
            &context,
            n,
            cp,
            &BodyMotion::default(),
            &w.local_motion(i),
            hist,
            coverage,
        );
        *touching = true;
    } else if *touching {
        release(force, hist, Some(coverage), touching);
    }
    *touching
}

/// A body (its piece `piece`: 0 unless a composite) against a wall (the wall is side a, at
/// rest). The per-piece form is what other static boundaries can reuse. `plain`: every
/// pair's law is plain ([`law::is_plain`]).
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn wall_pair<const PIECES: bool>(
    w: &World,
    x: &[Ds3A],
    [i, wall]: [u32; 2],
    piece: u32,
    hist: &mut Vec3,
    force: &mut ContactForce,
    touching: &mut bool,
    twist: &mut f32,
    plain: bool,
) -> bool {
    let (i, wall) = (i as usize, &w.walls[wall as usize]);
    // Body i at the origin, the plane shifted by its position (in f64).
    let (plane, rest) = w.plane_in(x, i, &wall.plane);
    if let (false, Shape::Sphere { radius }) = (PIECES, w.shape(i)) {
        // A sphere needs no pose (nor its orientation read).
        return if plain {
            sphere_wall::<true>(
                w, i, wall, &plane, *radius, rest, hist, force, touching, twist,
            )
        } else {
            sphere_wall::<false>(
                w, i, wall, &plane, *radius, rest, hist, force, touching, twist,
            )
        };
    }
    let (shape, pose) = if PIECES {
        w.piece_at(i, piece, Vec3::ZERO)
    } else {
        (w.shape(i), w.local_pose(i))
    };
    match narrow::collide_plane(&plane, shape, &pose).map(|m| World::add_rest(m, rest)) {
        Some(m) => {
            let params = w.pair_params(wall.material, w.consts.material[i]);
            let (r, sphere) = law_side::<PIECES>(w, i, piece);
            let share = law::point_share(sphere, sphere);
            let context = pair_context(w, params, w.consts.mass[i], r, share);
            let (a, b) = (BodyMotion::default(), w.local_motion(i));
            *force = if plain {
                law::contact_force_in::<true>(&context, &m, &a, &b, hist, twist)
            } else {
                law::contact_force_in::<false>(&context, &m, &a, &b, hist, twist)
            };
            *touching = true;
        }
        None if *touching => release(force, hist, Some(twist), touching),
        None => {}
    }
    *touching
}

#[cfg(test)]
#[path = "plain_walls_tests.rs"]
mod tests;

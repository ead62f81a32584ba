//! Each body's motion over the last step as the contact stage's bounds read it
//! ([`BodyBound`]), computed once per body per step instead of once per pair.
//!
//! Why: the polyhedron pair loop takes, for every pair that is apart, how far each body can
//! have moved (two square roots each), and for every pair touching at a remembered face
//! both bodies' speeds and turns (four more). A body sits in several pairs, so the loop
//! recomputed the same norms several times a step (about 3% of the cube pile's
//! instructions). The record holds the very values those expressions computed, by the same
//! IEEE operations in the same order on the same inputs, so every bound, and so every
//! result, keeps its bits.

use glam::Vec3;
use rayon::prelude::*;

use crate::world::World;

/// What the contact stage's motion bounds take of one body (see
/// `remembered::axis_motion_bound`): 32 bytes, one load for all of them.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct BodyBound {
    /// The body's velocity (for the pair's relative motion).
    pub(crate) velocity: Vec3,
    /// `|v|`, the velocity's norm.
    pub(crate) speed: f32,
    /// `|w| dt`, the largest angle the body can have turned in the step.
    pub(crate) turned: f32,
    /// The body's bounding radius.
    pub(crate) radius: f32,
    /// How far any point of the body can have moved in the step: `(|v| + |w| r) dt` (a
    /// point at most `r` from the centre moves with it and turns by at most `|w| dt`), with
    /// margins for rounding; the separation bound of a pair apart falls by both bodies'.
    pub(crate) moved: f32,
}

impl BodyBound {
    /// Body `i`'s record, from its current velocities and the world's step.
    #[inline(always)]
    pub(crate) fn of(w: &World, i: usize) -> Self {
        Self::new(
            w.state.velocity[i],
            w.state.omega[i],
            w.consts.radius[i],
            w.dt,
        )
    }

    /// The record of a body with velocity `v`, angular velocity `omega` and bounding radius
    /// `r`, over a step `dt`. `moved` is `(|v| + |w| r) dt 1.000001 + 1e-6 r`: the norms
    /// are rounded within a few ulps, well inside the relative margin.
    #[inline(always)]
    fn new(v: Vec3, omega: Vec3, r: f32, dt: f32) -> Self {
        let (speed, spin) = (v.length(), omega.length());
        BodyBound {
            velocity: v,
            speed,
            turned: spin * dt,
            radius: r,
            moved: (speed + spin * r) * dt * 1.000_001 + 1e-6 * r,
        }
    }
}

/// Bodies per task: large enough that a task's work hides its overhead.
const BOUND_CHUNK: usize = 4096;

/// Fills [`World::body_bounds`] from the current velocities (every body, a rank's ghosts
/// too; none in a world of spheres only, whose contacts take no such bound). Each record
/// depends on its body alone, so the result does not depend on the thread count.
pub(crate) fn update(world: &mut World) {
    if world.spheres_only() {
        world.body_bounds.clear();
        return;
    }
    let n = world.len();
    let mut bounds = std::mem::take(&mut world.body_bounds);
    bounds.resize(n, BodyBound::default());
    let w = &*world;
    bounds
        .par_chunks_mut(BOUND_CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let (v, omega) = (&w.state.velocity, &w.state.omega);
            let (r, dt) = (&w.consts.radius, w.dt);
            let lo = c * BOUND_CHUNK;
            let hi = lo + out.len();
            let (v, omega, r) = (&v[lo..hi], &omega[lo..hi], &r[lo..hi]);
            for k in 0..out.len() {
                out[k] = BodyBound::new(v[k], omega[k], r[k], dt);
            }
        });
    world.body_bounds = bounds;
}

/// Refreshes body `i`'s record (a ghost whose state came in after [`update`]).
#[inline]
pub(crate) fn refresh(world: &mut World, i: usize) {
    if i < world.body_bounds.len() {
        world.body_bounds[i] = BodyBound::of(world, i);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The record's values are exactly the expressions the contact stage computed per pair
    /// before (written out here from the definitions, not from `BodyBound::new`).
    #[test]
    fn a_record_holds_the_per_pair_expressions_bits() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 7.0
        };
        for _ in 0..10_000 {
            let v = Vec3::new(next(), next(), next());
            let om = Vec3::new(next(), next(), next()) * 30.0;
            let r = next().abs() * 0.01 + 1e-4;
            let dt = next().abs() * 1e-4 + 1e-7;
            let b = BodyBound::new(v, om, r, dt);
            let speed = (v.x * v.x + v.y * v.y + v.z * v.z).sqrt();
            let spin = (om.x * om.x + om.y * om.y + om.z * om.z).sqrt();
            let moved = (speed + spin * r) * dt * 1.000_001 + 1e-6 * r;
            assert_eq!(b.speed.to_bits(), speed.to_bits());
            assert_eq!(b.turned.to_bits(), (spin * dt).to_bits());
            assert_eq!(b.moved.to_bits(), moved.to_bits());
            assert_eq!((b.velocity, b.radius), (v, r));
        }
    }
}

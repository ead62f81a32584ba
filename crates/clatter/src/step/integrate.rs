//! Stage 3 of the step, **integrate**: each body's contact forces and torques gathered in
//! contact order (a fixed order: no atomics, action equals reaction exactly), then
//! semi-implicit Euler for the translation and the angular momentum, and a compensated
//! quaternion update for the orientation. Then the sink test: a body whose centre is inside
//! a sink after the update is removed (and asks for a rebuild, which drops its pairs);
//! removed bodies and ghosts (another MPI rank's bodies) are skipped.

use glam::{Quat, Vec3};
use rayon::prelude::*;

use super::CHUNK;
use crate::precise;
use crate::sink::in_any;
use crate::world::World;

/// How far the bodies moved since the last rebuild.
pub(crate) enum Moved {
    /// The largest squared distance from a body's rebuild position.
    Farthest(f32),
    /// Some body's state is no longer finite.
    NonFinite,
}

/// Runs the stage on every body.
pub(crate) fn run(world: &mut World) -> Moved {
    let (dt, gravity) = (world.dt, world.gravity);
    let contacts = &world.contacts;
    let mesh = (!world.mesh.slots.is_empty()).then_some(&world.mesh);
    let consts = &world.consts;
    let rebuild_position = &world.rebuild_position;
    // The positions as pairs, split by the contact stage this step (positions have not
    // changed since).
    let pairs = &world.position_pairs;
    debug_assert_eq!(pairs.len(), world.state.position.len());
    let periodic = world.periodic;
    let sinks = &world.sinks;
    let has_sinks = !sinks.is_empty();
    debug_assert!(world.ghost.is_empty() || world.ghost.len() == world.state.position.len());
    let ghost = &world.ghost;
    let s = &mut world.state;
    // Chunks of bodies, one task each; the loop body sees plain slices.
    let worst = s
        .position
        .par_chunks_mut(CHUNK)
        .zip(s.velocity.par_chunks_mut(CHUNK))
        .zip(s.orientation.par_chunks_mut(CHUNK))
        .zip(s.angular_momentum.par_chunks_mut(CHUNK))
        .zip(s.omega.par_chunks_mut(CHUNK))
        .zip(s.orientation_residual.par_chunks_mut(CHUNK))
        .zip(s.removed.par_chunks_mut(CHUNK))
        .enumerate()
        .map(|(chunk, ((((((xs, vs), qs), ls), ws), rs), gone))| {
            super::vex(|| {
                let mut worst = 0.0f32;
                // This chunk's pairs and rebuild positions (sliced once: no bounds test per body).
                let first = chunk * CHUNK;
                let pairs = &pairs[first..first + xs.len()];
                let rebuild_position = &rebuild_position[first..first + xs.len()];
                // Ghosts (`crate::domain`) are integrated by the rank that owns them; a world
                // without ghosts (one process) has an empty list.
                let ghost = ghost.get(first..first + xs.len()).unwrap_or(&[]);
                for k in 0..xs.len() {
                    let i = chunk * CHUNK + k;
                    if gone[k] || (!ghost.is_empty() && ghost[k]) {
                        continue;
                    }
                    let (f, t) = contacts.gather(i);
                    let (f, t) = match mesh {
                        Some(m) => m.gather(i, f, t),
                        None => (f, t),
                    };
                    let v = &mut vs[k];
                    let x = &mut xs[k];
                    *v += (f * consts.inv_mass[i] + gravity) * dt;
                    // The displacement rounded once to f32, added to the precise position (bit
                    // for bit the GPU's arithmetic, `crate::precise`): kept at any coordinate.
                    let (next, moved) = precise::advance_a(
                        periodic.as_ref(),
                        pairs[k],
                        *v * dt,
                        rebuild_position[k],
                    );
                    *x = next;
                    ls[k] += t * dt;
                    ws[k] = angular_velocity(qs[k], ls[k], consts.inv_inertia[i]);
                    qs[k] = rotate(qs[k], ws[k], &mut rs[k], dt);
                    let d2 = moved.length_squared();
                    // NaN or infinity anywhere in the state shows up in d2 or in q.
                    let d2 = if d2.is_finite() && qs[k].w.is_finite() {
                        d2
                    } else {
                        f32::INFINITY
                    };
                    // A removed body asks for a rebuild (which drops its pairs) with the
                    // largest finite distance.
                    let d2 = if has_sinks && d2.is_finite() && in_any(sinks, x.as_vec3()) {
                        gone[k] = true;
                        f32::MAX
                    } else {
                        d2
                    };
                    worst = if d2 > worst { d2 } else { worst };
                }
                worst
            })
        })
        .reduce(|| 0.0, f32::max);
    if worst == f32::INFINITY {
        Moved::NonFinite
    } else {
        Moved::Farthest(worst)
    }
}

/// Angular velocity from angular momentum `l` with the world-space inverse inertia
/// `R I^-1 R^T`.
#[inline(always)]
fn angular_velocity(q: Quat, l: Vec3, inv_inertia: Vec3) -> Vec3 {
    if inv_inertia.x == inv_inertia.y && inv_inertia.y == inv_inertia.z {
        // Spheres, cubes, Platonic solids: isotropic, no frame change needed.
        l * inv_inertia.x
    } else {
        q * ((q.conjugate() * l) * inv_inertia)
    }
}

/// The orientation after turning at `w` for `dt`: first order, `dq = (w, 0) q dt / 2`
/// (matches the exponential map to O((|w| dt)^2) at DEM step sizes), summed with Kahan
/// compensation (`residual` keeps what rounding lost), renormalised only when |q| drifted
/// by more than a few ulps (one Newton step of 1/sqrt around 1).
#[inline(always)]
fn rotate(q: Quat, w: Vec3, residual: &mut Quat, dt: f32) -> Quat {
    let h = 0.5 * dt;
    let dq = Quat::from_xyzw(w.x * h, w.y * h, w.z * h, 0.0) * q;
    let y = dq - *residual;
    let q2 = q + y;
    *residual = (q2 - q) - y;
    let n2 = q2.length_squared();
    if (n2 - 1.0).abs() > 4.0 * f32::EPSILON {
        q2 * (1.5 - 0.5 * n2)
    } else {
        q2
    }
}

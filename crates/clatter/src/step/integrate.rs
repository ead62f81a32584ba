//! Stage 3 of the step, **integrate**: each body's contact forces and torques gathered in
//! contact order (a fixed order: no atomics, action equals reaction exactly), then
//! semi-implicit Euler for the translation and the angular momentum, and a compensated
//! quaternion update for the orientation. Then the sink test: a body whose centre is inside
//! a sink after the update is removed (and asks for a rebuild, which drops its pairs);
//! removed bodies and ghosts (another MPI rank's bodies) are skipped.

use glam::{DVec3, Quat, Vec3};
use rayon::prelude::*;

use super::{CHUNK, FINE_CHUNK};
use crate::bodies::BodyConstants;
use crate::contact_list::Contacts;
use crate::mesh_boundary::MeshContacts;
use crate::periodic::Periodic;
use crate::precise::{self, Ds3A};
use crate::sink::{Sink, in_any};
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
    run_in(world, super::avx2())
}

/// [`run`], in eight lanes where `lanes` (the CPU must then have AVX2) or body by body: the
/// same bits.
pub(super) fn run_in(world: &mut World, lanes: bool) -> Moved {
    run_ordered(world, lanes, true)
}

/// [`run_in`], its chunks of bodies taken freshest first ([`freshest_first`]) where
/// `fresh`, else in body order (the order before; the tests' reference): the same bits
/// either way (each body is updated alone, and the largest distance is a maximum).
pub(super) fn run_ordered(world: &mut World, lanes: bool, fresh: bool) -> Moved {
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
    let ctx = Ctx {
        dt,
        gravity,
        contacts,
        mesh,
        consts,
        rebuild_position,
        pairs,
        periodic: periodic.as_ref(),
        sinks,
        has_sinks,
        ghost,
        padded_gather: Contacts::gather8_padded(),
        fresh,
    };
    let s = &mut world.state;
    // Chunks of bodies, one task each; the loop body sees plain slices. A few thousand
    // bodies make only a few [`CHUNK`]s: one thread would do two of three while the other
    // waits, so those go in [`FINE_CHUNK`]-multiple pieces, at least two per thread.
    let threads = rayon::current_num_threads();
    let size = body_chunk(s.position.len(), threads);
    // A task per chunk where threads can share them; one thread gains nothing from the
    // splitting, which cost its step about 0.5% of its instructions in joins.
    let most = if threads == 1 { usize::MAX } else { 1 };
    let mut chunks: Vec<_> = s
        .position
        .chunks_mut(size)
        .zip(s.velocity.chunks_mut(size))
        .zip(s.orientation.chunks_mut(size))
        .zip(s.angular_momentum.chunks_mut(size))
        .zip(s.omega.chunks_mut(size))
        .zip(s.orientation_residual.chunks_mut(size))
        .zip(s.removed.chunks_mut(size))
        .enumerate()
        .collect();
    if fresh {
        freshest_first(&mut chunks, threads);
    }
    let worst = chunks
        .into_par_iter()
        .with_max_len(most)
        .map(|(chunk, ((((((xs, vs), qs), ls), ws), rs), gone))| {
            let mut bodies = Bodies {
                first: chunk * size,
                xs,
                vs,
                qs,
                ls,
                ws,
                rs,
                gone,
            };
            #[cfg(target_arch = "x86_64")]
            if lanes {
                // The CPU, not `avx2()`'s switch, which another thread may turn off meanwhile.
                assert!(super::cpu_has_avx2());
                // SAFETY: the CPU has AVX2.
                return unsafe { super::integrate_lanes::chunk(&ctx, bodies) };
            }
            super::vex(|| {
                let mut worst = 0.0f32;
                for k in 0..bodies.xs.len() {
                    let d2 = body(&ctx, &mut bodies, k);
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

/// Bodies per task of the stage for `n` bodies and `threads` threads: [`CHUNK`] when that
/// makes at least four tasks per thread, otherwise `n` cut into about four tasks per
/// thread, rounded up to a multiple of [`FINE_CHUNK`] (so of the lanes' eight). Each body
/// is updated alone, so the size changes no result.
pub(super) fn body_chunk(n: usize, threads: usize) -> usize {
    let tasks = 4 * threads.max(1);
    if n >= tasks * CHUNK {
        CHUNK
    } else {
        n.div_ceil(tasks)
            .next_multiple_of(FINE_CHUNK)
            .clamp(FINE_CHUNK, CHUNK)
    }
}

/// Puts the stage's chunks of bodies (in body order) in the order that reads the contact
/// stage's freshest forces first: `threads` blocks of consecutive chunks, each reversed.
///
/// Why: the contact stage writes each pair's force in list order (pairs sorted by their
/// first body), one thread a block of the list (rayon hands each thread half of what it
/// splits, so with two threads the first and second halves); the stage's memory is more
/// than a core's L2 cache holds, so by its end the forces it wrote first are gone from
/// that cache and those it wrote last are still there. In body order, the gather read
/// the oldest first, which pushed out the freshest before they were read (least
/// recently used first); reversed, each thread starts on the forces it wrote last (and the
/// lanes take each chunk's bodies from its last down, `integrate_lanes::chunk`). One
/// thread: the whole order reversed; two: each half (rayon splits a list of tasks at its
/// middle, so each thread takes a block). Each body is updated alone and the stage's
/// distance is a maximum, so the order changes no result (only the cache misses: on the
/// settled 2,048-cube pile at one thread, layout37, BENCHMARKS.md).
pub(super) fn freshest_first<T>(chunks: &mut [T], threads: usize) {
    let blocks = threads.clamp(1, chunks.len().max(1));
    let m = chunks.len();
    for b in 0..blocks {
        chunks[b * m / blocks..(b + 1) * m / blocks].reverse();
    }
}

/// What every chunk of the stage shares.
pub(super) struct Ctx<'a> {
    pub(super) dt: f32,
    pub(super) gravity: Vec3,
    pub(super) contacts: &'a Contacts,
    pub(super) mesh: Option<&'a MeshContacts>,
    pub(super) consts: &'a BodyConstants,
    pub(super) rebuild_position: &'a [DVec3],
    /// The positions as pairs, split by the contact stage this step.
    pub(super) pairs: &'a [Ds3A],
    pub(super) periodic: Option<&'a Periodic>,
    pub(super) sinks: &'a [Sink],
    pub(super) has_sinks: bool,
    /// Ghosts (`crate::domain`) are integrated by the rank that owns them; a world without
    /// ghosts (one process) has an empty list.
    pub(super) ghost: &'a [bool],
    /// Whether the lanes gather with the padded side loops ([`Contacts::gather8_padded`]),
    /// asked once a stage rather than once per eight bodies.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) padded_gather: bool,
    /// Whether each chunk's bodies go from its last down (freshest first, see
    /// [`freshest_first`]; the lanes' chunks), else from its first up.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) fresh: bool,
}

/// One chunk's bodies (from body `first` on): the state the stage updates.
pub(super) struct Bodies<'a> {
    pub(super) first: usize,
    pub(super) xs: &'a mut [DVec3],
    pub(super) vs: &'a mut [Vec3],
    pub(super) qs: &'a mut [Quat],
    pub(super) ls: &'a mut [Vec3],
    pub(super) ws: &'a mut [Vec3],
    pub(super) rs: &'a mut [Quat],
    pub(super) gone: &'a mut [bool],
}

/// Body `k` of the chunk: its forces gathered, then the update. Returns the squared distance
/// it has moved from its rebuild position (0 for a body skipped, infinite for a state no
/// longer finite, `f32::MAX` for one a sink took).
#[inline(always)]
pub(super) fn body(c: &Ctx, b: &mut Bodies, k: usize) -> f32 {
    let i = b.first + k;
    if b.gone[k] || (!c.ghost.is_empty() && c.ghost[i]) {
        return 0.0;
    }
    let (f, t) = c.contacts.gather(i);
    let (f, t) = match c.mesh {
        Some(m) => m.gather(i, f, t),
        None => (f, t),
    };
    let v = &mut b.vs[k];
    let x = &mut b.xs[k];
    *v += (f * c.consts.inv_mass[i] + c.gravity) * c.dt;
    // The displacement rounded once to f32, added to the precise position (bit for bit the
    // GPU's arithmetic, `crate::precise`): kept at any coordinate.
    let (next, moved) =
        precise::advance_a(c.periodic, c.pairs[i], *v * c.dt, c.rebuild_position[i]);
    *x = next;
    b.ls[k] += t * c.dt;
    b.ws[k] = angular_velocity(b.qs[k], b.ls[k], c.consts.inv_inertia[i]);
    b.qs[k] = rotate(b.qs[k], b.ws[k], &mut b.rs[k], c.dt);
    let d2 = moved.length_squared();
    // NaN or infinity anywhere in the state shows up in d2 or in q.
    let d2 = if d2.is_finite() && b.qs[k].w.is_finite() {
        d2
    } else {
        f32::INFINITY
    };
    // A removed body asks for a rebuild (which drops its pairs) with the largest finite
    // distance.
    if c.has_sinks && d2.is_finite() && in_any(c.sinks, x.as_vec3()) {
        b.gone[k] = true;
        f32::MAX
    } else {
        d2
    }
}

/// Angular velocity from angular momentum `l` with the world-space inverse inertia
/// `R I^-1 R^T`.
#[inline(always)]
pub(super) fn angular_velocity(q: Quat, l: Vec3, inv_inertia: Vec3) -> Vec3 {
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
pub(super) fn rotate(q: Quat, w: Vec3, residual: &mut Quat, dt: f32) -> Quat {
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

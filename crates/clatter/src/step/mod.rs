//! One step of the simulation on the CPU: a fixed list of stages, each in its own module and
//! named as on the GPU (`clatter-gpu/src/stages/`):
//!
//! 1. [`broad`]: **bin**, **sort**, **pairs** (only when a body has moved half the Verlet
//!    skin since the last rebuild), carrying the springs of pairs that persist;
//! 2. [`contacts`]: **narrow** phase and contact **law** per candidate pair and wall pair,
//!    and [`mesh_contacts`]: the same per body against its candidate mesh triangles;
//! 3. [`integrate`]: forces gathered per body in a fixed order, semi-implicit Euler.
//!
//! Every stage is parallel (rayon) and sums in an order that does not depend on the thread
//! count, so results are bitwise the same for any number of threads.
//!
//! Where the CPU has AVX2 ([`avx2`]), the hottest loops run eight at a time, one item per
//! lane of a register, with the scalar code's bits (`lanes`' operations): the sphere pairs
//! (`sphere_lanes`) and the sphere-wall pairs (`wall_lanes`) on the plain law (their law
//! and stores: `law_lanes`), and the body update after the gather (`integrate_lanes`).
//! What they do not cover runs the scalar code, compiled for AVX2 too (`vex`). Where the
//! CPU also has AVX-512 (`avx512`), the sphere pairs run sixteen at a time
//! (`sphere_lanes16`, `lanes16`), with the same bits.

#[cfg(target_arch = "x86_64")]
mod apart_lanes;
pub mod broad;
pub(crate) mod caches;
pub mod contacts;
mod handover;
pub mod integrate;
#[cfg(target_arch = "x86_64")]
mod integrate_lanes;
#[cfg(target_arch = "x86_64")]
mod lanes;
#[cfg(target_arch = "x86_64")]
mod lanes16;
#[cfg(target_arch = "x86_64")]
mod law_lanes;
pub mod mesh_contacts;
pub(crate) mod motion;
pub(crate) mod near;
pub(crate) mod plain_walls;
mod remembered;
#[cfg(target_arch = "x86_64")]
mod sphere_lanes;
#[cfg(target_arch = "x86_64")]
mod sphere_lanes16;
#[cfg(target_arch = "x86_64")]
mod wall_lanes;

use std::sync::atomic::{AtomicU8, Ordering};

use crate::world::{SimError, StepStats, World};

/// Items per parallel task in the per-contact and per-body stages.
pub(crate) const CHUNK: usize = 1024;

/// Items per parallel task where an item costs thousands of instructions, or where the
/// items are few: the polyhedron body pairs (a full separating-axis test is ~7,000
/// instructions, a pair its memory serves a few hundred), the wall pairs of a world with
/// polyhedra, and the integrate stage's bodies. [`CHUNK`]-sized tasks there leave a
/// default scene's step (2,500 bodies, ~6,000 pairs) with only a handful of tasks of very
/// unequal cost, and one thread waiting at the end of every stage while the other finishes
/// the last one. These loops split down to tasks of at most this many items
/// (`with_max_len`: rayon's adaptive splitting alone leaves a thread's last task as large as
/// a quarter of the loop when nothing is stolen). Each item writes only its own slots, so
/// the task size changes no result.
pub(crate) const FINE_CHUNK: usize = 64;

/// Whether the hot stages run their AVX2 builds ([`vex`]): 0 not decided yet, 1 no, 2 yes.
static AVX2: AtomicU8 = AtomicU8::new(0);

/// Whether the hot stages of the CPU step run their AVX2 builds: where the CPU has AVX2
/// (x86-64), unless [`set_avx2`] turned them off.
pub fn avx2() -> bool {
    match AVX2.load(Ordering::Relaxed) {
        0 => {
            let on = cpu_has_avx2();
            AVX2.store(if on { 2 } else { 1 }, Ordering::Relaxed);
            on
        }
        state => state == 2,
    }
}

/// Turns the AVX2 builds of the hot stages off (`false`), or back on where the CPU has
/// AVX2 (`true`). The results are the same bits either way (see `vex`); this is for the
/// tests that hold them to it, and for timing one against the other.
pub fn set_avx2(on: bool) {
    let on = on && cpu_has_avx2();
    AVX2.store(if on { 2 } else { 1 }, Ordering::Relaxed);
}

/// Whether this CPU has AVX2, whatever [`set_avx2`] says: the condition for running an
/// AVX2 build at all (a stage that chose its lanes from [`avx2`] may meet the switch turned
/// off by another thread meanwhile, which is harmless: both builds give the same bits).
pub(super) fn cpu_has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the sphere pairs' lanes run sixteen wide (`sphere_lanes16`): where the AVX2
/// builds run ([`avx2`]) and the CPU has AVX-512F, DQ and VL. The same bits either way;
/// a CPU with a 512-bit divider does the law's divisions and roots twice as fast.
#[cfg(target_arch = "x86_64")]
pub(super) fn avx512() -> bool {
    avx2()
        && std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512dq")
        && std::arch::is_x86_feature_detected!("avx512vl")
}

/// Calls `f` compiled for AVX2 where the CPU has it ([`avx2`]): three-operand (VEX) forms
/// of the same SSE arithmetic, without the register copies the two-operand forms need
/// (about a quarter of the sphere pair loop's instructions). The same IEEE operations in
/// the same order either way (Rust never fuses a multiply and an add, nor reorders float
/// arithmetic, on its own, and calls no other maths here), so the same bits on any CPU.
/// For the per-chunk bodies of the hot stages.
#[inline(always)]
pub(crate) fn vex<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2")]
        fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        if avx2() {
            // SAFETY: the CPU has AVX2 (`avx2` is never true otherwise).
            return unsafe { with_avx2(f) };
        }
    }
    f()
}

impl World {
    /// Rebuilds the broad phase now, from the current positions, carrying the springs of
    /// the pairs that persist (as a step does when a body has moved half the skin).
    pub fn rebuild_contacts(&mut self) {
        broad::rebuild(self);
    }

    /// Advances the simulation by one time step.
    pub fn step(&mut self) -> Result<StepStats, SimError> {
        let rebuilt = self.needs_rebuild();
        if rebuilt {
            broad::rebuild(self);
        }
        let contacts = contacts::run(self) + mesh_contacts::run(self);
        let moved = integrate::run(self);
        self.step_count += 1;
        self.time += self.dt as f64;
        match moved {
            integrate::Moved::NonFinite => Err(self.non_finite_error()),
            integrate::Moved::Farthest(d2) => {
                // Composites: a rotation moves pieces as well as the centre.
                let d2 = d2.max(broad::composite_moved(self));
                if d2 > 0.25 * self.skin * self.skin {
                    self.set_needs_rebuild(true);
                } else if !self.boundaries.is_empty()
                    && d2.sqrt() + mesh_contacts::moved_since_rebuild(self) > 0.5 * self.skin
                {
                    // Bodies and meshes together may have closed half the skin.
                    self.set_needs_rebuild(true);
                }
                Ok(StepStats { contacts, rebuilt })
            }
        }
    }

    /// The error for a step that left a body with a non-finite state: the first such body.
    fn non_finite_error(&self) -> SimError {
        let body = (0..self.len())
            .find(|&i| {
                let s = &self.state;
                !(s.position[i].is_finite()
                    && s.velocity[i].is_finite()
                    && s.orientation[i].is_finite())
            })
            .unwrap_or(0);
        SimError::NonFinite {
            body,
            step: self.step_count,
            time: self.time,
            dt: self.dt,
        }
    }
}

//! The foundation's physics tests (restitution and contact duration, sliding into rolling,
//! resting polyhedra, momentum and angular momentum of a colliding cloud, rolling resistance
//! and adhesion, periodic boundaries, precise positions far from the origin) on the GPU backend:
//! the very same test files as the CPU's, included here with the `gpu-step` feature on, so
//! their `step` runs GPU steps and reads the state back (see
//! crates/clatter/tests/common/step.rs).

// Each included test file carries its own `#[path] mod` of the shared step helper, as it
// must when built on its own as a CPU test.
#![allow(clippy::duplicate_mod)]

mod gpu_step {
    use std::cell::RefCell;
    use std::sync::Arc;

    use clatter::{SimError, StepStats, World};
    use clatter_gpu::{GpuContext, GpuWorld};

    /// Positions, velocities, orientations and step count of a world.
    type Seen = (Vec<glam::DVec3>, Vec<glam::Vec3>, Vec<glam::Quat>, u64);

    /// The GPU copy of the world being stepped, and the host state it last handed back (to
    /// notice a test changing the world between steps, which means uploading it again).
    struct Cached {
        gpu: GpuWorld,
        seen: Seen,
    }

    thread_local! {
        static CTX: RefCell<Option<Arc<GpuContext>>> = const { RefCell::new(None) };
        static WORLD: RefCell<Option<Cached>> = const { RefCell::new(None) };
    }

    fn snapshot(w: &World) -> Seen {
        (
            w.state.position.clone(),
            w.state.velocity.clone(),
            w.state.orientation.clone(),
            w.step_count,
        )
    }

    /// Whether `w` differs from the state the GPU last handed back in its orientations only.
    fn only_orientations_changed(seen: &Seen, w: &World) -> bool {
        seen.0 == w.state.position
            && seen.1 == w.state.velocity
            && seen.2.len() == w.state.orientation.len()
            && seen.3 == w.step_count
    }

    /// Reads the contact list of the world being stepped back into `w`.
    pub fn sync(w: &mut World) {
        WORLD.with_borrow_mut(|cache| {
            if let Some(c) = cache.as_mut()
                && c.seen == snapshot(w)
            {
                c.gpu.read_into(w).expect("GPU readback");
            }
        })
    }

    /// `n` steps of `w` on the GPU in one batch, the bodies read back at the end. Without an
    /// adapter: a loud skip (the CPU steps instead), or a failure when `CI` is set.
    pub fn step_n(w: &mut World, n: u64) -> Result<StepStats, SimError> {
        let ctx = CTX.with_borrow_mut(|c| {
            if c.is_none() {
                *c = clatter_gpu::test_context();
            }
            c.clone()
        });
        let Some(ctx) = ctx else {
            let mut stats = StepStats::default();
            for _ in 0..n {
                stats = w.step()?;
            }
            return Ok(stats);
        };
        WORLD.with_borrow_mut(|cache| {
            match cache {
                Some(c) if c.seen == snapshot(w) => {}
                // Only the orientations changed (a test integrating them itself): they go up
                // over the GPU's, and the contacts, springs and memories stay, as the CPU's
                // step keeps them.
                Some(c) if only_orientations_changed(&c.seen, w) => {
                    c.gpu.write_states(w).expect("GPU state upload");
                    c.seen = snapshot(w);
                }
                _ => {
                    let gpu = GpuWorld::new(ctx, w).expect("scene fits the GPU");
                    *cache = Some(Cached {
                        gpu,
                        seen: snapshot(w),
                    });
                }
            }
            let c = cache.as_mut().expect("just set");
            let report = c.gpu.step_into(n, w).expect("GPU step");
            c.seen = snapshot(w);
            if let Some(body) = report.bad_body {
                return Err(SimError::NonFinite {
                    body,
                    step: w.step_count + 1,
                    time: w.time,
                    dt: w.dt,
                });
            }
            Ok(StepStats {
                contacts: report.touching,
                rebuilt: false,
            })
        })
    }

    /// One step of `w` on the GPU (see [`step_n`]).
    pub fn step(w: &mut World) -> Result<StepStats, SimError> {
        step_n(w, 1)
    }
}

#[path = "../../clatter/tests/restitution.rs"]
mod restitution;

#[path = "../../clatter/tests/rolling.rs"]
mod rolling;

#[path = "../../clatter/tests/resting.rs"]
mod resting;

#[path = "../../clatter/tests/conservation.rs"]
mod conservation;

#[path = "../../clatter/tests/rolling_resistance.rs"]
mod rolling_resistance;

#[path = "../../clatter/tests/periodic.rs"]
mod periodic;

#[path = "../../clatter/tests/hertz_mindlin.rs"]
mod hertz_mindlin;

#[path = "../../clatter/tests/sinks.rs"]
mod sinks;

#[path = "../../clatter/tests/precision.rs"]
mod precision;

//! The GPU world: a [`clatter::World`]'s state resident on the GPU, and the host side of
//! its step. The scene goes up once ([`GpuWorld::new`]): bodies, shapes, materials, walls
//! and boundaries (planes, and triangle meshes with their contact slots), periodic boxes
//! (in the step's parameters), sinks (their boxes after the walls), composites (a piece id
//! kept in each pair entry) and the contact springs of a resumed run. Then the host records
//! the step's dispatch list ([`crate::stages`]) many steps to a submission, grows the pair
//! buffers when they overflow, and reads back what is asked for.
//!
//! The host reads a few status words back after each submission; body state comes back
//! only when output is due ([`GpuWorld::read_into`]). If the pair list outgrows its buffer,
//! the GPU stops at the start of that step; the host grows the buffers and runs the step
//! again, so the result does not depend on the initial capacity.
//!
//! The parts, in the order the work happens:
//! - `build`: the upload and the buffers ([`crate::buffers`]);
//! - `plan`: bind groups and the recorded dispatch lists of the full and the lean step;
//! - `advance`: batches of steps, the status after each, pair-buffer growth;
//! - `profile`: every kernel timed with timestamp queries;
//! - `health`: the blow-up checks, energy samples and the last good state on the GPU;
//! - `readback`: body state and contacts back into a [`clatter::World`].

mod advance;
mod build;
mod health;
mod plan;
mod profile;
pub use profile::FullPhase;
mod readback;

use std::sync::Arc;

use crate::buffers::{Buf, Buffers, Dims};
use crate::layout::{Params, status};
use crate::readback::read_buffer;
use crate::shapes::GpuShapes;
use crate::{GpuContext, GpuError};

use plan::Plan;

/// Steps recorded into one submission between status reads.
const BATCH: u64 = 64;
/// Batches recorded side by side on the CPU. wgpu spends a few microseconds of CPU time on
/// each dispatch, about as long as the GPU needs for a step of 65,536 spheres, so one
/// recording thread would hold the GPU back; up to `2 * ENCODERS` batches are in flight.
const ENCODERS: usize = 4;
/// The environment variable that sets the most batches in flight (2 or more; default
/// `2 * ENCODERS`): for timing the cost of a stopped pipeline, which runs every batch already
/// submitted as no-ops before the host can act, against the GPU's idle time with fewer.
pub const IN_FLIGHT_VAR: &str = "CLATTER_GPU_IN_FLIGHT";
/// Initial pair capacity per body (grown on demand).
const PAIRS_PER_BODY: u64 = 8;

/// A scene's state on the GPU and the compiled step pipeline. See the module docs.
pub struct GpuWorld {
    ctx: Arc<GpuContext>,
    n: u32,
    /// Wall slots per body: walls times the most pieces of a body (`Params::max_pieces`).
    wall_slots: u32,
    params: Params,
    shapes: GpuShapes,
    /// The group-0 buffers (`buffers::BUFFERS`).
    bufs: Buffers,
    /// The recorded step: bind groups and dispatch lists.
    plan: Plan,
    /// The sizes the buffers were allocated for.
    dims: Dims,
    /// Batches still to be recorded with the full step throughout, after a stall.
    full_batches: u32,
    /// Whether batches use lean steps at all (see [`GpuWorld::set_lean_steps`]).
    lean_enabled: bool,
    /// Lean steps that found a rebuild due and were run again in full.
    stalls: u64,
    /// The GPU step count at the last stall.
    last_stall: u64,
    /// `(steps, time)`: the simulated time after that many GPU steps, summed step by step
    /// as the CPU does (kept so that each read-back continues the sum).
    time_sum: std::sync::Mutex<(u64, f64)>,
    /// Steps taken on the GPU since upload.
    gpu_steps: u64,
    /// The world's step count and time at upload.
    base_step: u64,
    base_time: f64,
    /// The world's broad-phase rebuild count at upload (a read-back adds the GPU's).
    base_rebuilds: u64,
    dt: f32,
    last_status: [u32; status::LEN],
    /// The blow-up checks and energy samples, when a run turned them on.
    health: Option<Health>,
    /// Energy samples read back and not yet taken ([`GpuWorld::take_samples`]).
    samples: Vec<EnergySample>,
}

/// What a run asks of the GPU's blow-up checks ([`GpuWorld::set_health`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HealthSetup {
    /// Check every this many steps (the host's `--check-every`; 0: never).
    pub check_every: u64,
    /// Record an energy sample every this many steps (0: never).
    pub energy_every: u64,
    /// Keep the last good state every this many steps (rounded up to a multiple of
    /// `check_every`).
    pub snapshot_every: u64,
    /// The energy available to the run plus its potential energy
    /// (`clatter::health::Health::baseline`), J.
    pub budget: f64,
    /// The kinetic energy above this multiple of the available energy stops the pipeline
    /// for the host's check (below `clatter::health::ENERGY_FACTOR`, so that f32 sums never
    /// miss what the host would find).
    pub alarm_factor: f64,
    /// A touching contact whose normal force is above this stops the pipeline for the host's
    /// check (`clatter::health::Health::force_floor`), N...
    pub force_floor: f32,
    /// ... when that force, all on one point of the contact's law, also means an overlap
    /// deeper than this fraction of the smaller body's volume-equivalent radius: the test
    /// the host's cheap check makes before it measures a contact
    /// (`clatter::health::Health::check`, `law::depth_at_force` against
    /// `clatter::health::OVERLAP_LIMIT`), so give a little less than `OVERLAP_LIMIT` (f32
    /// rounding). Without it (0) every contact above the floor stops the pipeline, which in
    /// a pour of soft bodies is every check step: a wait for the host each time.
    pub overlap_limit: f32,
}

/// The checks as set up on the GPU.
#[derive(Debug, Clone, Copy)]
struct Health {
    setup: HealthSetup,
    /// The potential energy of all the mass at `HealthParams::reference`, J.
    reference_energy: f64,
}

/// One energy sample computed on the GPU (sums in f32, in a fixed order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergySample {
    /// The world's step count.
    pub step: u64,
    /// Simulated time, s (the CPU's sum of `dt`).
    pub time: f64,
    /// Kinetic energy, translational plus rotational, J.
    pub kinetic: f64,
    /// Gravitational potential energy relative to the origin, J.
    pub potential: f64,
    /// Linear momentum, kg m/s.
    pub momentum: [f64; 3],
}

/// What [`GpuWorld::step`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepReport {
    /// The first body whose state became non-finite (the GPU stopped at that step).
    pub bad_body: Option<usize>,
    /// Contacts touching in the last step.
    pub touching: usize,
    /// Steps taken on the GPU since upload.
    pub steps_done: u64,
    /// The GPU's blow-up checks ([`GpuWorld::set_health`]) stopped the pipeline after the
    /// last step: the host must check that step itself, then [`GpuWorld::clear_alarm`].
    pub alarm: bool,
}

/// The most grid cells for `n` bodies (`Params::max_cells`).
fn max_cells(n: u64) -> u64 {
    8 * n + 64
}

/// Whether a scene of `n` bodies, `walls` walls and a pair list of `capacity` fits an adapter
/// with `limits`; else a [`GpuError::TooLarge`] naming the limit, the need and what to do.
/// Checked before anything is allocated.
pub fn check_fits(
    limits: &wgpu::Limits,
    adapter: &str,
    n: u64,
    capacity: u64,
    walls: u64,
) -> Result<(), GpuError> {
    let limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let biggest = [
        ("body state", Buf::Bodies.bytes(n)),
        ("cell counts", Buf::CellCount.bytes(max_cells(n) + 1)),
        ("contact forces", Buf::Forces.bytes(capacity)),
        ("wall contacts", Buf::WallForces.bytes(n * walls)),
    ];
    for (what, need) in biggest {
        if need > limit {
            return Err(GpuError::TooLarge {
                adapter: adapter.to_string(),
                what: format!("largest storage buffer, for the {what}"),
                need: format!("{need} bytes"),
                limit: format!("{limit} bytes"),
                advice: "use fewer bodies, or --backend cpu".into(),
            });
        }
    }
    if n >= u32::MAX as u64 / 16 {
        return Err(GpuError::TooLarge {
            adapter: adapter.to_string(),
            what: "bodies addressable with 32-bit indices".into(),
            need: format!("{n} bodies"),
            limit: format!("{} bodies", u32::MAX / 16),
            advice: "use fewer bodies".into(),
        });
    }
    Ok(())
}

impl GpuWorld {
    /// Refuses scenes that do not fit the adapter, before allocating anything.
    fn check_fits(ctx: &GpuContext, n: u64, capacity: u64, walls: u64) -> Result<(), GpuError> {
        check_fits(&ctx.limits, &ctx.adapter_name(), n, capacity, walls)
    }

    /// Copies `size` bytes at `offset` of `buffer` back to the host (waits for the GPU).
    pub fn read_buffer(
        &self,
        buffer: &wgpu::Buffer,
        offset: u64,
        size: u64,
    ) -> Result<Vec<u8>, GpuError> {
        read_buffer(&self.ctx, buffer, offset, size)
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.n as usize
    }

    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The device this world lives on.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// The body state buffer (`BodyState` records in body order), e.g. for the renderer to
    /// draw from without a round trip through the host.
    pub fn body_buffer(&self) -> &wgpu::Buffer {
        &self.bufs[Buf::Bodies]
    }

    /// Uploads the body states of `world` (the world this was created from, at the step this
    /// has reached) over the GPU's, and keeps everything else: the contact list, springs,
    /// pair memories and the broad phase's rebuild positions, as the CPU's `World::step`
    /// keeps them when a caller edits `world.state` between steps (only the pairs' gaps
    /// are dropped, which skip pairs as apart while the bodies' measured motion cannot
    /// have closed them: so the next step tests every pair). For callers that change
    /// the bodies' state between steps (a test integrating orientations itself), where
    /// [`GpuWorld::new`] would rebuild the pipeline and carry the contacts at every step.
    /// Refuses a world with another body count or step count.
    pub fn write_states(&mut self, world: &clatter::World) -> Result<(), GpuError> {
        if world.len() != self.n as usize || world.step_count != self.step_count() {
            return Err(GpuError::Unsupported(format!(
                "write_states: the world has {} bodies at step {}, the GPU {} at step {}",
                world.len(),
                world.step_count,
                self.n,
                self.step_count()
            )));
        }
        let states: Vec<clatter::contract::BodyState> =
            (0..world.len()).map(|i| world.state.record(i)).collect();
        self.ctx
            .queue
            .write_buffer(&self.bufs[Buf::Bodies], 0, bytemuck::cast_slice(&states));
        // The pairs' gaps were spent by the motion integrate measured, not by this edit.
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.bufs[Buf::NewHist], 0, None);
        self.ctx.queue.submit([enc.finish()]);
        Ok(())
    }

    /// Whether to record steps without the rebuild's dispatches after the first step of each
    /// batch (on by default; see `encode_steps`). Results do not depend on it, only speed:
    /// the tests turn it off to check that.
    pub fn set_lean_steps(&mut self, on: bool) {
        self.lean_enabled = on;
    }

    /// Whether touching polyhedron pairs ignore what they remember of their contact, so
    /// that every contact comes from the full separating-axis test ([`Params::full_test`];
    /// off by default, or on with `CLATTER_GPU_FULL_TEST=1`). Results do not depend on it,
    /// only speed: the tests turn it on to check that, bitwise.
    pub fn set_full_test(&mut self, on: bool) {
        self.params.full_test = on as u32;
        self.ctx
            .queue
            .write_buffer(&self.bufs[Buf::Params], 0, bytemuck::bytes_of(&self.params));
    }

    /// How many lanes serve each polyhedron pair in the full narrow phase: 0 (one thread a
    /// pair, the default), 8 or 16 (`contacts_full_poly_lanes`; the default comes from
    /// `CLATTER_GPU_POLY_LANES`, see docs/gpu.md). Results are bitwise the same for every
    /// value, only speed differs: the tests set it to check that. Other values are refused.
    pub fn set_poly_lanes(&mut self, lanes: u32) -> Result<(), GpuError> {
        if lanes != 0 && !crate::pipeline::POLY_LANES.contains(&lanes) {
            return Err(GpuError::Runtime {
                adapter: self.ctx.adapter_name(),
                message: format!("{lanes} lanes per pair: 0, 8 or 16 are built"),
            });
        }
        self.params.poly_lanes = lanes;
        self.plan = Plan::new(
            &self.ctx,
            &self.plan.compiled,
            &self.bufs,
            &self.shapes,
            &mut self.params,
        )?;
        self.ctx
            .queue
            .write_buffer(&self.bufs[Buf::Params], 0, bytemuck::bytes_of(&self.params));
        Ok(())
    }

    /// How many times a lean step found a rebuild due and was run again in full.
    pub fn stalls(&self) -> u64 {
        self.stalls
    }

    /// Candidate pairs in the current pair list (as of the last status read).
    pub fn pairs(&self) -> usize {
        self.last_status[status::PAIRS] as usize
    }

    /// Steps taken on the GPU since upload.
    pub fn steps_taken(&self) -> u64 {
        self.gpu_steps
    }

    /// The world's step count after the GPU's steps (what [`GpuWorld::read_into`] would
    /// set), without reading anything back.
    pub fn step_count(&self) -> u64 {
        self.base_step + self.gpu_steps
    }

    /// The simulated time after the GPU's steps (the CPU's sum of `dt`), without reading
    /// anything back.
    pub fn time(&self) -> f64 {
        self.time_after(self.gpu_steps)
    }

    /// Broad-phase rebuilds on the GPU since upload (a read-back's world counts the world's
    /// own before upload too).
    pub fn rebuilds(&self) -> u64 {
        self.last_status[status::REBUILDS] as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::buffers::{Access, BUFFERS, check_sizes};

    /// The limits wgpu 30 reports for an NVIDIA GPU on Vulkan, as far as the buffers go:
    /// one storage binding at most 2 GiB - 1 (wgpu-hal caps the driver's
    /// `maxStorageBufferRange`, 4 GiB - 1, at `i32::MAX`), one buffer at most the driver's
    /// `maxMemoryAllocationSize` (about 4 GiB), uniforms 64 KiB.
    fn nvidia_like() -> wgpu::Limits {
        wgpu::Limits {
            max_storage_buffer_binding_size: (1 << 31) - 1,
            max_buffer_size: 0xffe0_0000,
            max_uniform_buffer_binding_size: 1 << 16,
            ..wgpu::Limits::default()
        }
    }

    /// The buffers of `clatter bench --shape sphere --pile lattice --bodies n`: five walls,
    /// one material, the initial pair capacity.
    fn sphere_lattice(n: u64) -> Dims {
        Dims {
            bodies: n,
            cells: max_cells(n),
            pairs: n * PAIRS_PER_BODY,
            materials: 1,
            walls: 5,
            sinks: 0,
            pieces: 1,
            composites: false,
            boundaries: 0,
        }
    }

    /// 4,194,304 spheres fit an 80 GB NVIDIA card again: every group-0 buffer within the
    /// binding and buffer limits, and all of them together well within its memory. The one
    /// `snapshot` buffer of the last good state that they replace (status, then 36 words a
    /// body, 17 a body-wall slot, 19 a pair) needed 4.58 GB, over both limits: the panic of
    /// 2026-11-27.
    #[test]
    fn four_million_spheres_fit_nvidia_limits() {
        let n = 4_194_304u64;
        let d = sphere_lattice(n);
        let limits = nvidia_like();
        let mut total = 0;
        for b in BUFFERS {
            let size = b.size(&d);
            let limit = match b.access {
                Access::Uniform => 1 << 16,
                _ => (1u64 << 31) - 1,
            };
            eprintln!("{:>22} {size:>14} bytes", b.name);
            assert!(size <= limit, "{}: {size} bytes over {limit}", b.name);
            total += size;
        }
        eprintln!("{:>22} {total:>14} bytes", "total");
        assert!(total < 40_000_000_000, "{total}");
        check_sizes(&limits, &d).expect("every buffer fits");
        let old_snapshot = 4 * (32 + 36 * n + 17 * 5 * n + 19 * 8 * n);
        assert_eq!(old_snapshot, 4_580_180_096);
        assert!(old_snapshot > limits.max_buffer_size);
    }

    /// Cubes in touching layers with a layer of balls resting on the top one (spacing
    /// 0.019 m, half sizes and radii 0.01 m: every neighbour overlaps by 1 mm), so that the
    /// full narrow phase gets cube-cube, ball-cube and ball-ball pairs.
    const KINDS: &str = r#"
[simulation]
steps = 10
dt = 1.0e-5

[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4

[[shape]]
name = "ball"
sphere = { radius = 0.01 }

[[shape]]
name = "cube"
box = { half_extents = [0.01, 0.01, 0.01] }

[container]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.3]
material = "m"

[[group]]
shape = "cube"
material = "m"
lattice = { min = [0.03, 0.03, 0.0105], max = [0.12, 0.12, 0.05], spacing = 0.019 }

[[group]]
shape = "ball"
material = "m"
lattice = { min = [0.03, 0.03, 0.0675], max = [0.12, 0.12, 0.1], spacing = 0.019 }
"#;

    /// The list the full narrow phase runs is split by kind: its first `FULL_SPHERES`
    /// entries are exactly the listed pairs with a sphere body (by the host's body table),
    /// the rest exactly the pairs of two polyhedra, each listed pair once; so
    /// `contacts_full_spheres` and `contacts_full_poly` never run a pair of the other kind.
    #[test]
    fn full_list_puts_sphere_pairs_first_and_apart() {
        let Some(ctx) = crate::test_context() else {
            return;
        };
        let world = clatter::scene::Scene::parse(KINDS, "kinds.toml")
            .expect("the scene parses")
            .world();
        let mut gpu = GpuWorld::new(ctx, &world).expect("the world fits");
        for _ in 0..3 {
            gpu.step(1).expect("a step");
            let words = |buf: Buf, n: u64| -> Vec<u32> {
                let bytes = gpu
                    .read_buffer(&gpu.bufs[buf], 0, buf.bytes(n))
                    .expect("read back");
                bytemuck::pod_collect_to_vec(&bytes)
            };
            let st = words(Buf::Status, status::LEN as u64);
            let work = st[status::WORK] as usize;
            let spheres = st[status::FULL_SPHERES] as usize;
            let listed = words(Buf::NewPairs, work as u64);
            let pairs = words(Buf::Pairs, st[status::PAIRS] as u64);
            let sphere_body = |word: u32| world.consts.is_sphere[(word & 0x3ff_ffff) as usize];
            let mut seen = std::collections::HashSet::new();
            let (mut with_sphere, mut polyhedra) = (0, 0);
            for k in 0..work {
                let c = listed[2 * k + 1] as usize;
                assert!(seen.insert(c), "pair {c} listed twice");
                let has = sphere_body(pairs[2 * c]) || sphere_body(pairs[2 * c + 1]);
                assert_eq!(
                    has,
                    k < spheres,
                    "entry {k} (pair {c}) of {work}, {spheres} first"
                );
                with_sphere += has as usize;
                polyhedra += !has as usize;
            }
            // Every kind is there: cube-cube, ball-cube and ball-ball pairs all overlap.
            assert!(
                with_sphere > 0 && polyhedra > 0,
                "{with_sphere} {polyhedra}"
            );
        }
    }

    /// A scene too large for the limits is an error naming the first buffer over them, its
    /// size, the limit and about how many bodies would fit: here WebGPU's default limits
    /// (128 MiB a storage binding), where the pair forces (48 bytes a pair, 8 pairs a body:
    /// 384 bytes a body, the most of any buffer) allow floor(2^27 / 384) = 349,525 bodies.
    #[test]
    fn too_large_for_the_limits_names_the_buffer_and_what_fits() {
        let n = 4_194_304u64;
        let limits = wgpu::Limits::default();
        let err = check_sizes(&limits, &sphere_lattice(n)).expect_err("too large");
        assert_eq!(err.name, "bodies");
        assert_eq!(err.bytes, 112 * n);
        assert_eq!(err.limit, 128 << 20);
        assert_eq!(err.bodies_that_fit, 349_525);
        check_sizes(&limits, &sphere_lattice(349_525)).expect("fits");
        let over = check_sizes(&limits, &sphere_lattice(349_526)).expect_err("one more");
        assert_eq!((over.name, over.bytes), ("forces", 384 * 349_526));
        let msg = err.into_error("test adapter").to_string();
        for part in [
            "`bodies`",
            "469762048 bytes",
            "134217728 bytes",
            "about 349525 bodies",
            "test adapter",
        ] {
            assert!(msg.contains(part), "{part} not in: {msg}");
        }
    }
}

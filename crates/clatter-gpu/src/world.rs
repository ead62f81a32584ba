//! The GPU world: a [`clatter::World`]'s state resident on the GPU, and the host side of
//! its step: buffers ([`crate::buffers`]), the recorded dispatch list ([`crate::stages`]),
//! batching, pair-buffer growth and read-back.
//!
//! The host records many steps into one submission and reads a few status words back after
//! it; body state comes back only when output is due ([`GpuWorld::read_into`]). If the pair
//! list outgrows its buffer, the GPU stops at the start of that step; the host grows the
//! buffers and runs the step again, so the result does not depend on the initial capacity.

use std::sync::Arc;

use rayon::prelude::*;

use clatter::contract::quat_of;
use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::buffers::{Buf, Buffers, Dims};
use crate::layout::{HEALTH_LOG, HealthParams, HealthRecord, Params, status};
use crate::pipeline::{Compiled, ContactVariant, Dispatch, Group2, KernelSet, Kernels, Size};
use crate::readback::{Pending, read_buffer, read_buffers, read_buffers_after, submit_read};
use crate::shapes::GpuShapes;
use crate::stages::{self, Scans};
use crate::{GpuContext, GpuError};
use clatter::ContactForce;
use clatter::contract::{BodyConsts, BodyState, WallRecord};
use clatter::{ContactState, World};

/// Steps recorded into one submission between status reads.
const BATCH: u64 = 64;
/// Batches recorded side by side on the CPU. wgpu spends a few microseconds of CPU time on
/// each dispatch, about as long as the GPU needs for a step of 65,536 spheres, so one
/// recording thread would hold the GPU back; up to `2 * ENCODERS` batches are in flight.
const ENCODERS: usize = 4;
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
    /// check (`clatter::health::Health::force_floor`), N.
    pub force_floor: f32,
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

impl GpuWorld {
    /// Uploads `world` (bodies, shapes, materials, walls and its contact springs) and builds
    /// the pipeline. Fails with a clear error when the scene does not fit the adapter.
    pub fn new(ctx: Arc<GpuContext>, world: &World) -> Result<GpuWorld, GpuError> {
        let n = world.len() as u32;
        let num_walls = world.walls.len() as u32;
        let composites = world.has_composites();
        if composites && world.len() as u64 > crate::shapes::MAX_COMPOSITE_BODIES {
            return Err(GpuError::TooLarge {
                adapter: ctx.adapter_name(),
                what: "bodies of a scene with composites (pair entries keep a piece id in the top 6 bits of a 32-bit body index)".into(),
                need: format!("{} bodies", world.len()),
                limit: format!("{} bodies", crate::shapes::MAX_COMPOSITE_BODIES),
                advice: "use fewer bodies, or --backend cpu".into(),
            });
        }
        let max_pieces = world.max_pieces() as u32;
        let wall_slots = num_walls * max_pieces;
        let (shapes, mesh_base) =
            GpuShapes::upload_with_meshes(&ctx, &world.shapes, &world.boundaries)?;
        let num_boundaries = world.boundaries.len() as u32;
        let state = world.contact_state();
        let capacity = (world.len() as u64 * PAIRS_PER_BODY)
            .max(state.pairs.len() as u64 + world.len() as u64)
            .max(1024);
        Self::check_fits(&ctx, world.len() as u64, capacity, wall_slots as u64)?;
        let mesh_bytes = 4 * crate::mesh::state_words(world.len() as u64, num_boundaries as u64);
        let limit = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        if mesh_bytes > limit {
            return Err(GpuError::TooLarge {
                adapter: ctx.adapter_name(),
                what: "largest storage buffer, for the mesh contact slots".into(),
                need: format!("{mesh_bytes} bytes"),
                limit: format!("{limit} bytes"),
                advice: "use fewer bodies, or --backend cpu".into(),
            });
        }
        let rmax = world.consts.max_radius();
        let params = Params {
            gravity: [world.gravity.x, world.gravity.y, world.gravity.z, 0.0],
            n,
            num_walls,
            num_materials: world.materials.len() as u32,
            pair_capacity: capacity as u32,
            dt: world.dt,
            skin: world.skin,
            half_skin2: 0.25 * world.skin * world.skin,
            min_cell: 2.0 * rmax + world.skin,
            max_cells: 8 * n + 64,
            num_args: 0,
            spheres_only: world.spheres_only() as u32,
            one: 1.0,
            periodic_min: world
                .periodic
                .map_or([0.0; 4], |p| [p.min.x, p.min.y, p.min.z, 0.0]),
            periodic_len: world.periodic.map_or([0.0; 4], |p| {
                let l = p.length();
                [l.x, l.y, l.z, 0.0]
            }),
            num_sinks: world.sinks.len() as u32,
            max_pieces,
            composites: composites as u32,
            num_boundaries,
            mesh_base,
            ..Default::default()
        };
        let device = &ctx.device;
        let compiled = Compiled::get(&ctx)?;
        // Body state and constants.
        let states: Vec<BodyState> = (0..world.len()).map(|i| world.state.record(i)).collect();
        let statics: Vec<BodyConsts> = (0..world.len()).map(|i| world.consts.record(i)).collect();
        let table = world.materials.table();
        // The walls, then each sink's corners (min, max) as two records.
        let mut walls: Vec<WallRecord> = world.walls.iter().map(WallRecord::from).collect();
        for k in &world.sinks {
            for c in [k.min, k.max] {
                walls.push(WallRecord {
                    plane: [c.x, c.y, c.z, 0.0],
                    ..Default::default()
                });
            }
        }
        // Contacts carried from the world (a resumed run): the old list that the first
        // rebuild carries springs from.
        let nb = world.len() as u64;
        let np = state.pairs.len();
        let mut a_start = vec![0u32; world.len() + 1];
        for p in &state.pairs {
            a_start[p[0] as usize + 1] += 1;
        }
        for i in 0..world.len() {
            a_start[i + 1] += a_start[i];
        }
        let mut hist: Vec<[f32; 4]> = (0..np)
            .map(|k| {
                let h = state.history[k];
                [h.x, h.y, h.z, state.twist[k]]
            })
            .collect();
        // With composites each word carries its body's piece id above the body index.
        let mut pairs: Vec<[u32; 2]> = if state.pieces.len() == np && composites {
            let shift = crate::shapes::PIECE_SHIFT;
            (state.pairs.iter().zip(&state.pieces))
                .map(|(&[i, j], &code)| {
                    let (a, b) = clatter::contacts::piece_ids(code);
                    [i | (a << shift), j | (b << shift)]
                })
                .collect()
        } else {
            state.pairs.clone()
        };
        hist.resize(capacity as usize, [0.0; 4]);
        pairs.resize(capacity as usize, [0, 0]);
        let nslots = (nb * wall_slots as u64) as usize;
        let wall_hist: Vec<[f32; 4]> = (0..nslots)
            .map(|k| {
                let h = state.wall_history[k];
                [h.x, h.y, h.z, state.wall_twist[k]]
            })
            .collect();
        // A wall slot's touching flag travels in its force record's unused `pad0` word.
        let wall_forces: Vec<ContactForce> = state
            .wall_forces
            .iter()
            .zip(&state.wall_touching)
            .map(|(f, &t)| ContactForce {
                pad0: f32::from_bits(t as u32),
                ..*f
            })
            .collect();
        let mut st = [0u32; status::LEN];
        st[status::REBUILD] = 1;
        st[status::BAD_BODY] = u32::MAX;
        // The snapshot's HEALTH word is never 1 once a snapshot was taken (it is taken only
        // from a running pipeline): 1 marks "none yet".
        let mut snap_st = [0u32; crate::layout::snapshot::STATUS as usize];
        snap_st[status::HEALTH] = 1;
        let dims = Dims {
            bodies: nb,
            cells: params.max_cells as u64,
            pairs: capacity,
            materials: world.materials.len() as u64,
            walls: num_walls as u64,
            sinks: world.sinks.len() as u64,
            pieces: max_pieces as u64,
            composites,
            boundaries: num_boundaries as u64,
        };
        let mesh_state = crate::mesh::initial_state(world);
        let bytes = |b: &[u8]| Some(b.to_vec());
        let bufs = Buffers::new(device, &dims, |b| match b {
            Buf::Params => bytes(bytemuck::bytes_of(&params)),
            Buf::Bodies => bytes(bytemuck::cast_slice(&states)),
            Buf::Statics => bytes(bytemuck::cast_slice(&statics)),
            Buf::PairTable => bytes(bytemuck::cast_slice(table)),
            Buf::Walls => bytes(bytemuck::cast_slice(&walls)),
            Buf::Status => bytes(bytemuck::cast_slice(&st)),
            Buf::AStart => bytes(bytemuck::cast_slice(&a_start)),
            Buf::Pairs => bytes(bytemuck::cast_slice(&pairs)),
            Buf::Hist => bytes(bytemuck::cast_slice(&hist)),
            Buf::WallHist => bytes(bytemuck::cast_slice(&wall_hist)),
            Buf::WallForces => bytes(bytemuck::cast_slice(&wall_forces)),
            Buf::Snapshot => bytes(bytemuck::cast_slice(&snap_st)),
            Buf::Mesh => bytes(bytemuck::cast_slice(&mesh_state)),
            _ => None,
        });
        let mut params = params;
        let plan = Plan::new(&ctx, &compiled, &bufs, &shapes, &mut params)?;
        let w = GpuWorld {
            bufs,
            plan,
            dims,

            full_batches: 0,
            lean_enabled: true,
            stalls: 0,
            last_stall: 0,
            time_sum: std::sync::Mutex::new((0, world.time)),
            ctx,
            n,
            wall_slots,
            params,
            shapes,
            gpu_steps: 0,
            base_step: world.step_count,
            base_time: world.time,
            dt: world.dt,
            last_status: st,
            health: None,
            samples: Vec::new(),
        };
        w.ctx.wait()?;
        Ok(w)
    }

    /// Refuses scenes that do not fit the adapter, before allocating anything.
    fn check_fits(ctx: &GpuContext, n: u64, capacity: u64, walls: u64) -> Result<(), GpuError> {
        check_fits(&ctx.limits, &ctx.adapter_name(), n, capacity, walls)
    }
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
    {
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let biggest = [
            ("body state", 96 * n),
            ("cell counts", 4 * (8 * n + 65)),
            ("contact forces", 48 * capacity),
            ("wall contacts", 48 * n * walls),
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
    }
    Ok(())
}

impl GpuWorld {
    /// Records `steps` steps into `encoder`. The first step is the full step; with `lean`,
    /// the others leave out the rebuild's dispatches (about 30, most of them sized zero on
    /// the GPU, but each costing the GPU and wgpu a few microseconds: more than the whole
    /// step of a 65,536-sphere pile). A lean step whose predecessor flagged a rebuild stops
    /// the pipeline (`prepare_lean`, status word STALL) until the first step of the next
    /// batch, a full one, which runs that step with the rebuild: the rebuilds happen at the
    /// same steps, and the results are the same, as if every step were full.
    fn encode_steps(&self, encoder: &mut wgpu::CommandEncoder, steps: u64, lean: bool) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("steps"),
            timestamp_writes: None,
        });
        self.plan.bind(&mut pass);
        let health = self.health.is_some();
        for k in 0..steps {
            let ops = if lean && k > 0 {
                &self.plan.lean_ops
            } else {
                &self.plan.ops
            };
            for op in ops {
                self.plan.encode(&mut pass, op);
            }
            if health {
                for op in &self.plan.health_ops {
                    self.plan.encode(&mut pass, op);
                }
            }
        }
    }

    /// Times every kernel of the step with timestamp queries over `steps` steps (which are
    /// taken: the simulation advances): each dispatch in its own compute pass, so the
    /// numbers include no overlap between kernels. Returns `(kernel, milliseconds per step)`
    /// in pipeline order, the scan levels of the three prefix sums merged under `scan`.
    /// Needs the adapter's timestamp queries ([`GpuContext::timestamps`]); `clatter bench
    /// --profile` prints it.
    pub fn profile(&mut self, steps: u64) -> Result<Vec<(String, f64)>, GpuError> {
        if !self.ctx.timestamps {
            return Err(GpuError::Runtime {
                adapter: self.ctx.adapter_name(),
                message: "the adapter has no timestamp queries, needed to time kernels".into(),
            });
        }
        let name_of = |op: &Dispatch| -> &'static str {
            match self.plan.kernels(op).names[op.pipeline] {
                "scan_block" | "scan_add" => "scan",
                other => other,
            }
        };
        let mut names: Vec<&'static str> = Vec::new();
        for op in &self.plan.ops {
            let name = name_of(op);
            if !names.contains(&name) {
                names.push(name);
            }
        }
        let mut totals = vec![0u64; names.len()];
        let per_step = 2 * self.plan.ops.len() as u32;
        let chunk = (wgpu::QUERY_SET_MAX_QUERIES / per_step).max(1) as u64;
        let query_set = self.ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("profile"),
            ty: wgpu::QueryType::Timestamp,
            count: per_step * chunk as u32,
        });
        let resolve = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("profile resolve"),
            size: 8 * (per_step as u64 * chunk),
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut done = 0;
        let mut last_status = self.last_status;
        let mut taken = 0;
        let mut stopped = false;
        while done < steps && self.n > 0 && !stopped {
            let batch = (steps - done).min(chunk);
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            let mut q = 0u32;
            for _ in 0..batch {
                for op in &self.plan.ops {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(name_of(op)),
                        timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                            query_set: &query_set,
                            beginning_of_pass_write_index: Some(q),
                            end_of_pass_write_index: Some(q + 1),
                        }),
                    });
                    q += 2;
                    self.plan.bind(&mut pass);
                    self.plan.encode(&mut pass, op);
                }
            }
            encoder.resolve_query_set(&query_set, 0..q, &resolve, 0);
            let parts = read_buffers_after(
                &self.ctx,
                encoder,
                &[
                    (&resolve, 0, 8 * q as u64),
                    (&self.bufs[Buf::Status], 0, 4 * status::LEN as u64),
                ],
            )?;
            let stamps: Vec<u64> = bytemuck::pod_collect_to_vec(&parts[0]);
            for (k, op) in self
                .plan
                .ops
                .iter()
                .cycle()
                .take((q / 2) as usize)
                .enumerate()
            {
                let at = names
                    .iter()
                    .position(|n| *n == name_of(op))
                    .unwrap_or_default();
                totals[at] += stamps[2 * k + 1].saturating_sub(stamps[2 * k]);
            }
            let mut st = [0u32; status::LEN];
            st.copy_from_slice(&bytemuck::pod_collect_to_vec::<u8, u32>(&parts[1]));
            taken += st[status::STEPS].wrapping_sub(last_status[status::STEPS]) as u64;
            last_status = st;
            stopped = st[status::OVERFLOW] != 0 || st[status::BAD_BODY] != u32::MAX;
            done += batch;
        }
        self.gpu_steps += taken;
        self.last_status = last_status;
        if stopped {
            return Err(GpuError::Runtime {
                adapter: self.ctx.adapter_name(),
                message: "the pipeline stopped while profiling (pair overflow or a non-finite \
                          body): run a few steps first"
                    .into(),
            });
        }
        let ns = self.ctx.queue.get_timestamp_period() as f64;
        Ok(names
            .iter()
            .zip(totals)
            .map(|(n, t)| (n.to_string(), t as f64 * ns * 1e-6 / steps.max(1) as f64))
            .collect())
    }

    /// Advances the simulation by `steps` steps on the GPU (no body state comes back).
    /// Returns the number of contacts touching in the last step.
    pub fn step(&mut self, steps: u64) -> Result<StepReport, GpuError> {
        self.advance(steps, None)
    }

    /// [`GpuWorld::step`], then the body state (not the contacts) into `world`, read in the
    /// same transfer as the step's status: the cheapest way to follow a simulation step by
    /// step (the viewer, tests). [`GpuWorld::read_into`] also brings the contacts.
    pub fn step_into(&mut self, steps: u64, world: &mut World) -> Result<StepReport, GpuError> {
        let mut states = Vec::new();
        let r = self.advance(steps, Some(&mut states))?;
        if states.len() != self.n as usize {
            // The pipeline stopped early (a non-finite body): the state it stopped at.
            states = self.read_states()?;
        }
        self.apply_states(&states, world);
        Ok(r)
    }

    fn advance(
        &mut self,
        steps: u64,
        mut states: Option<&mut Vec<BodyState>>,
    ) -> Result<StepReport, GpuError> {
        let target = self.gpu_steps + steps;
        let mut guard = 0;
        // Batches in flight: while the GPU runs some, the host records the next ones, so
        // recording (a few microseconds per dispatch in wgpu) overlaps the GPU's work. A
        // batch may do fewer steps than it holds: after a lean step stalls (a rebuild due,
        // see `encode_steps`) the rest of its batch does nothing and the next batch, whose
        // first step is full, runs that step again. So batches are sized for the steps
        // still to do, and the host tops up until the GPU's step count reaches the target.
        // A stopped pipeline (overflow, bad body) stops every batch behind it: those are
        // drained before the host acts.
        let mut in_flight: std::collections::VecDeque<(Pending, bool, u64)> = Default::default();
        // Steps in the batches submitted so far, as if none stalled.
        let mut submitted = self.gpu_steps;
        let mut first = true;
        loop {
            if in_flight.is_empty() {
                submitted = self.gpu_steps;
            }
            if in_flight.len() <= ENCODERS && (submitted < target || first) {
                // Record up to ENCODERS batches side by side on the CPU's threads, then
                // submit them in order.
                let mut sizes = Vec::new();
                let mut at = submitted;
                while in_flight.len() + sizes.len() < 2 * ENCODERS && (at < target || first) {
                    first = false;
                    let batch = (target - at).min(BATCH);
                    let lean = self.lean_enabled && self.full_batches == 0;
                    self.full_batches = self.full_batches.saturating_sub(1);
                    sizes.push((batch, lean));
                    at += batch;
                }
                let record = |&(batch, lean): &(u64, bool)| {
                    let mut encoder =
                        self.ctx
                            .device
                            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                                label: Some("step"),
                            });
                    if self.n > 0 {
                        self.encode_steps(&mut encoder, batch, lean);
                    }
                    encoder
                };
                let encoders: Vec<wgpu::CommandEncoder> = if sizes.len() > 1 {
                    sizes.par_iter().map(record).collect()
                } else {
                    sizes.iter().map(record).collect()
                };
                for (encoder, (batch, _)) in encoders.into_iter().zip(sizes) {
                    submitted += batch;
                    // The status (and, with the last batch, the bodies) come back in one
                    // transfer.
                    let last = submitted >= target;
                    let body_bytes = if last && states.is_some() {
                        96 * self.n as u64
                    } else {
                        0
                    };
                    let log_bytes = if self.health.is_some_and(|h| h.setup.energy_every > 0) {
                        (HEALTH_LOG as usize * std::mem::size_of::<HealthRecord>()) as u64
                    } else {
                        0
                    };
                    let pending = submit_read(
                        &self.ctx,
                        encoder,
                        &[
                            (&self.bufs[Buf::Status], 0, 4 * status::LEN as u64),
                            (&self.bufs[Buf::Bodies], 0, body_bytes),
                            (&self.bufs[Buf::Health], 0, log_bytes),
                        ],
                    )?;
                    in_flight.push_back((pending, body_bytes > 0, batch));
                }
            }
            let Some((pending, with_bodies, batch)) = in_flight.pop_front() else {
                break;
            };
            let parts = pending.wait(&self.ctx)?;
            let mut st = [0u32; status::LEN];
            st.copy_from_slice(&bytemuck::pod_collect_to_vec::<u8, u32>(&parts[0]));
            if self.n == 0 {
                st = self.last_status;
                st[status::STEPS] = st[status::STEPS].wrapping_add(batch as u32);
            }
            let done = st[status::STEPS].wrapping_sub(self.last_status[status::STEPS]) as u64;
            let new_samples = st[status::SAMPLES].wrapping_sub(self.last_status[status::SAMPLES]);
            self.gpu_steps = (self.gpu_steps + done).min(target);
            self.last_status = st;
            if new_samples > 0 && !parts[2].is_empty() {
                self.collect_samples(&parts[2], st[status::SAMPLES], new_samples);
            }
            if st[status::MESH_FULL] != 0 {
                for (p, _, _) in in_flight.drain(..) {
                    p.wait(&self.ctx)?;
                }
                return Err(GpuError::Unsupported(format!(
                    "body {} meets more mesh triangles or contacts than the GPU keeps per body ({} triangles within its reach, {} contacts per piece before the deepest {} are kept); run this scene with --backend cpu",
                    st[status::MESH_FULL] - 1,
                    crate::mesh::MAX_CANDIDATES,
                    crate::mesh::MAX_FOUND,
                    clatter::boundary::MESH_SLOTS
                )));
            }
            let alarm = st[status::HEALTH] != 0;
            let stopped = st[status::BAD_BODY] != u32::MAX || st[status::OVERFLOW] != 0 || alarm;
            if stopped {
                // Drain: the batches behind did nothing (the pipeline is stopped).
                for (p, _, _) in in_flight.drain(..) {
                    p.wait(&self.ctx)?;
                }
            }
            if st[status::BAD_BODY] != u32::MAX {
                return Ok(StepReport {
                    bad_body: Some(st[status::BAD_BODY] as usize),
                    touching: st[status::TOUCHING] as usize,
                    steps_done: self.gpu_steps,
                    alarm: false,
                });
            }
            if alarm {
                return Ok(StepReport {
                    bad_body: None,
                    touching: st[status::TOUCHING] as usize,
                    steps_done: self.gpu_steps,
                    alarm: true,
                });
            }
            if st[status::OVERFLOW] != 0 {
                self.grow(st[status::PAIRS_NEEDED] as u64)?;
                guard += 1;
                if guard > 8 {
                    return Err(GpuError::Runtime {
                        adapter: self.ctx.adapter_name(),
                        message: "the pair list kept overflowing".into(),
                    });
                }
                first = true;
                continue;
            }
            if done < batch {
                // A lean step stalled; the next batch ran it again. A scene that rebuilds
                // every few steps (fast bodies) would stall every batch, so after two
                // stalls close together the next batches are recorded in full.
                if self.stalls > 0 && self.gpu_steps < self.last_stall + 4 * BATCH {
                    self.full_batches = 2;
                }
                self.stalls += 1;
                self.last_stall = self.gpu_steps;
            }
            if with_bodies
                && self.gpu_steps == target
                && let Some(out) = states.as_deref_mut()
            {
                *out = bytemuck::pod_collect_to_vec(&parts[1]);
            }
        }
        Ok(StepReport {
            bad_body: None,
            touching: self.last_status[status::TOUCHING] as usize,
            steps_done: self.gpu_steps,
            alarm: false,
        })
    }

    /// Grows the pair buffers to hold `needed` pairs (with room to spare), keeping the old
    /// list and springs, and lets the stopped step run again.
    fn grow(&mut self, needed: u64) -> Result<(), GpuError> {
        let capacity = (needed + needed / 2).max(self.params.pair_capacity as u64 * 2);
        Self::check_fits(&self.ctx, self.n as u64, capacity, self.wall_slots as u64)?;
        let device = &self.ctx.device;
        self.dims.pairs = capacity;
        let mut encoder = device.create_command_encoder(&Default::default());
        self.bufs.grow(device, &self.dims, &mut encoder);
        // Resume: clear the overflow, ask for the rebuild again.
        let mut st = self.last_status;
        st[status::OVERFLOW] = 0;
        st[status::STALL] = 0;
        st[status::REBUILD] = 1;
        self.ctx
            .queue
            .write_buffer(&self.bufs[Buf::Status], 0, bytemuck::cast_slice(&st));
        self.ctx.queue.submit([encoder.finish()]);
        self.params.pair_capacity = capacity as u32;
        self.plan = Plan::new(
            &self.ctx,
            &self.plan.compiled,
            &self.bufs,
            &self.shapes,
            &mut self.params,
        )?;
        self.last_status = st;
        self.ctx.wait()
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

    /// Whether to record steps without the rebuild's dispatches after the first step of each
    /// batch (on by default; see `encode_steps`). Results do not depend on it, only speed:
    /// the tests turn it off to check that.
    pub fn set_lean_steps(&mut self, on: bool) {
        self.lean_enabled = on;
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

    /// Broad-phase rebuilds so far on the GPU.
    pub fn rebuilds(&self) -> u64 {
        self.last_status[status::REBUILDS] as u64
    }

    /// The body states.
    pub fn read_states(&self) -> Result<Vec<BodyState>, GpuError> {
        let bytes = self.read_buffer(&self.bufs[Buf::Bodies], 0, 96 * self.n as u64)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// Copies the GPU state back into `world` (the world it was created from): body state,
    /// step count, time, and the contact list with its springs and forces, so outputs,
    /// health checks and checkpoints work on it as after CPU steps.
    pub fn read_into(&self, world: &mut World) -> Result<(), GpuError> {
        let states = self.read_states()?;
        self.apply_states(&states, world);
        world.set_contact_state(self.contact_state()?);
        self.read_mesh_into(world)
    }

    /// The mesh contact slots and the time of the last rebuild into `world` (which then
    /// finds its mesh candidates as the CPU's rebuild did then).
    fn read_mesh_into(&self, world: &mut World) -> Result<(), GpuError> {
        let nb = world.boundaries.len();
        if nb == 0 {
            return Ok(());
        }
        let buf = &self.bufs[Buf::Mesh];
        let words: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.read_buffer(buf, 0, buf.size())?);
        let (slots, rebuild_step) = crate::mesh::read_slots(&words, self.n as usize, nb);
        let back = (self.gpu_steps as u32).wrapping_sub(rebuild_step) as u64;
        let rebuild_time = self.time_after(self.gpu_steps.saturating_sub(back));
        world
            .restore_mesh(slots, rebuild_time)
            .map_err(GpuError::Unsupported)
    }

    /// Body state, step count and time into `world`.
    fn apply_states(&self, states: &[BodyState], world: &mut World) {
        for (i, s) in states.iter().enumerate() {
            world.state.set_record(i, s);
        }
        world.step_count = self.base_step + self.gpu_steps;
        // The same sum as the CPU's `time += dt` per step, continued from the last call's.
        let mut cache = self
            .time_sum
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let (mut k, mut t) = *cache;
        if k > self.gpu_steps {
            (k, t) = (0, self.base_time);
        }
        while k < self.gpu_steps {
            t += self.dt as f64;
            k += 1;
        }
        *cache = (k, t);
        world.time = t;
    }

    /// The contact list and springs (see [`ContactState`]).
    pub fn contact_state(&self) -> Result<ContactState, GpuError> {
        let st = &self.last_status;
        let b = |live: Buf| &self.bufs[live];
        let n = self.n as usize;
        let np = st[status::PAIRS] as usize;
        let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        let ns = (n * self.wall_slots as usize) as u64;
        let (np, n) = (np as u64, n as u64);
        let composites = self.params.composites != 0;
        let rebuild_slots = if composites { 2 * n } else { n };
        let mut parts = read_buffers(
            &self.ctx,
            &[
                (b(Buf::Pairs), 0, 8 * np),
                (b(Buf::Hist), 0, 16 * np),
                (b(Buf::Touching), 0, 4 * np),
                (b(Buf::Forces), 0, 48 * np),
                (b(Buf::WallHist), 0, 16 * ns),
                (b(Buf::WallForces), 0, 48 * ns),
                (b(Buf::RebuildPos), 0, 16 * rebuild_slots),
            ],
        )?
        .into_iter();
        let mut next = || parts.next().unwrap_or_default();
        let (pairs_bytes, hist_bytes, touch_bytes, force_bytes) = (next(), next(), next(), next());
        let (wh, wf, rb) = (next(), next(), next());
        let hist: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&hist_bytes);
        let wall_hist: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&wh);
        let forces: Vec<ContactForce> = bytemuck::pod_collect_to_vec(&force_bytes);
        let (wall_forces, wall_touching) = split_wall_forces(bytemuck::pod_collect_to_vec(&wf));
        let rebuilt = st[status::REBUILDS] > 0;
        let rb: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&rb);
        let (pairs, pieces) = decode_pairs(bytemuck::pod_collect_to_vec(&pairs_bytes), composites);
        Ok(ContactState {
            rebuild_position: if rebuilt {
                rb.iter().take(n as usize).map(|&p| v3(p)).collect()
            } else {
                Vec::new()
            },
            rebuild_orientation: if rebuilt && composites {
                rb.iter().skip(n as usize).map(|&q| quat_of(q)).collect()
            } else {
                Vec::new()
            },
            pairs,
            pieces,
            history: hist.iter().map(|&h| v3(h)).collect(),
            twist: hist.iter().map(|h| h[3]).collect(),
            // 1 = touching; 0 and larger values (separating-axis hints) = not.
            touching: bytemuck::pod_collect_to_vec::<u8, u32>(&touch_bytes)
                .iter()
                .map(|&t| t == 1)
                .collect(),
            forces,
            wall_history: wall_hist.iter().map(|&h| v3(h)).collect(),
            wall_twist: wall_hist.iter().map(|h| h[3]).collect(),
            wall_touching,
            wall_forces,
        })
    }

    /// Reads a named stage buffer (for the stage-by-stage tests): `keys`, `sorted`,
    /// `cell_start`, `a_start`, `pairs`, `b_start`, `b_adj`, `forces`, `grid`, `status`,
    /// `mesh`.
    pub fn debug_buffer(&self, name: &str) -> Result<Vec<u8>, GpuError> {
        const STAGE_BUFFERS: &[&str] = &[
            "keys",
            "sorted",
            "cell_start",
            "a_start",
            "pairs",
            "b_start",
            "b_adj",
            "forces",
            "wall_forces",
            "grid",
            "status",
            "mesh",
        ];
        let Some(b) = STAGE_BUFFERS
            .contains(&name)
            .then(|| self.bufs.by_name(name))
            .flatten()
        else {
            return Err(GpuError::Unsupported(format!(
                "no stage buffer named {name}"
            )));
        };
        self.read_buffer(b, 0, b.size())
    }
}

/// Wall force records as the GPU keeps them (the touching flag in `pad0`, see
/// `wall_contact` in contacts.wgsl) split into the forces (`pad0` zero, as the CPU's) and
/// the flags.
fn split_wall_forces(mut forces: Vec<ContactForce>) -> (Vec<ContactForce>, Vec<bool>) {
    let touching = forces
        .iter_mut()
        .map(|f| {
            let t = f.pad0.to_bits() != 0;
            f.pad0 = 0.0;
            t
        })
        .collect();
    (forces, touching)
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

/// The recorded step of a world: bind groups, dispatch arguments and the dispatch lists of
/// the full and the lean step (rebuilt when the pair buffers grow).
struct Plan {
    compiled: Arc<Compiled>,
    /// This world's contact kernels.
    contacts: ContactVariant,
    scans: Scans,
    /// Indirect dispatch arguments.
    args: wgpu::Buffer,
    group0: wgpu::BindGroup,
    group1: wgpu::BindGroup,
    args_group: wgpu::BindGroup,
    ops: Vec<Dispatch>,
    lean_ops: Vec<Dispatch>,
    /// The checks and the snapshot after every step, when on (stages::health).
    health_ops: Vec<Dispatch>,
}

impl Plan {
    /// Plans the scans, writes the argument template and `params.num_args`, binds the
    /// buffers and records the step (stages::record).
    fn new(
        ctx: &GpuContext,
        compiled: &Arc<Compiled>,
        bufs: &Buffers,
        shapes: &GpuShapes,
        params: &mut Params,
    ) -> Result<Plan, GpuError> {
        let device = &ctx.device;
        let layouts = &compiled.layouts;
        let spheres_only = params.spheres_only != 0;
        let variant = ContactVariant {
            spheres_only,
            meshes: params.num_boundaries > 0,
            composites: params.composites != 0,
        };
        let contacts = compiled.contacts(ctx, variant)?;
        let scans = Scans::new(
            device,
            &layouts[2],
            bufs,
            params.n as u64,
            params.max_cells as u64,
        );
        params.num_args = scans.template.len() as u32;
        ctx.queue
            .write_buffer(&bufs[Buf::Params], 0, bytemuck::bytes_of(params));
        let flat: Vec<u32> = scans.template.iter().flatten().copied().collect();
        let args = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("args"),
            contents: bytemuck::cast_slice(&vec![0u32; flat.len()]),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_DST,
        });
        let template = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("arg template"),
            contents: bytemuck::cast_slice(&flat),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let args_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("args"),
            layout: &layouts[2],
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: args.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: template.as_entire_binding(),
                },
            ],
        });
        let (ops, lean_ops) = stages::record(&compiled.base, contacts, &scans, spheres_only);
        let health_ops = stages::health::record(&compiled.base, params.n as u64);
        Ok(Plan {
            compiled: compiled.clone(),
            contacts: variant,
            group0: bufs.bind_group(device, &layouts[0]),
            group1: device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("shapes"),
                layout: &layouts[1],
                entries: &shapes.bind_entries(),
            }),
            scans,
            args,
            args_group,
            ops,
            lean_ops,
            health_ops,
        })
    }

    /// The kernel set `op` indexes.
    fn kernels(&self, op: &Dispatch) -> &Kernels {
        match op.set {
            KernelSet::Base => &self.compiled.base,
            KernelSet::Contacts => {
                // Compiled in `Plan::new`, which failed otherwise.
                match self.compiled.contact_sets[self.contacts.index()].get() {
                    Some(Ok(k)) => k,
                    _ => unreachable!("contact kernels compiled before the plan"),
                }
            }
        }
    }

    /// Binds groups 0 and 1.
    fn bind(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_bind_group(0, &self.group0, &[]);
        pass.set_bind_group(1, &self.group1, &[]);
    }

    /// Records one dispatch into `pass` (groups 0 and 1 already bound).
    fn encode(&self, pass: &mut wgpu::ComputePass<'_>, op: &Dispatch) {
        let set = self.kernels(op);
        pass.set_pipeline(&set.pipelines[op.pipeline]);
        match set.group2[op.pipeline] {
            Group2::None => {}
            Group2::Args => pass.set_bind_group(2, &self.args_group, &[]),
            Group2::Scan => pass.set_bind_group(2, &self.scans.bind_groups[op.scan_level], &[]),
        }
        match op.size {
            Size::Single => pass.dispatch_workgroups(1, 1, 1),
            Size::Indirect(slot) => pass.dispatch_workgroups_indirect(&self.args, slot as u64 * 12),
            Size::Fixed([x, y, z]) => pass.dispatch_workgroups(x, y, z),
        }
    }
}

impl GpuWorld {
    /// Turns on the blow-up checks and energy samples on the GPU for a run starting from
    /// `world` (the world this was created from, at the same step): after every step the GPU
    /// checks what `clatter::health::Health::check` checks cheaply, and stops the pipeline
    /// when it finds something the host must look at ([`StepReport::alarm`]); it keeps the
    /// last good state on the device ([`GpuWorld::read_last_good`]) and logs energy samples
    /// ([`GpuWorld::take_samples`]). Nothing of it comes back unless asked for.
    pub fn set_health(&mut self, world: &World, setup: HealthSetup) {
        let mut setup = setup;
        let check = setup.check_every.max(1);
        setup.snapshot_every = setup.snapshot_every.max(1).div_ceil(check) * check;
        // The centroid of the bodies as the reference of the potential energy.
        let n = world.len().max(1) as f64;
        let c = world.state.position.iter().fold([0.0f64; 3], |a, p| {
            [a[0] + p.x as f64, a[1] + p.y as f64, a[2] + p.z as f64]
        });
        let reference = Vec3::new((c[0] / n) as f32, (c[1] / n) as f32, (c[2] / n) as f32);
        let mass: f64 = world.consts.mass.iter().map(|&m| m as f64).sum();
        let reference_energy = -mass * world.gravity.dot(reference) as f64;
        let base = |every: u64| {
            if every == 0 {
                0
            } else {
                (self.base_step % every) as u32
            }
        };
        let hp = HealthParams {
            reference: [reference.x, reference.y, reference.z, 0.0],
            check_every: setup.check_every as u32,
            energy_every: setup.energy_every as u32,
            snapshot_every: setup.snapshot_every as u32,
            base_check: base(setup.check_every),
            base_energy: base(setup.energy_every),
            base_snapshot: base(setup.snapshot_every),
            budget: (setup.budget - reference_energy) as f32,
            alarm_factor: setup.alarm_factor as f32,
            force_floor: setup.force_floor,
            ..Default::default()
        };
        self.ctx
            .queue
            .write_buffer(&self.bufs[Buf::HealthParams], 0, bytemuck::bytes_of(&hp));
        self.health = Some(Health {
            setup,
            reference_energy,
        });
    }

    /// Lets the pipeline go on after an alarm that the host's own check found harmless.
    pub fn clear_alarm(&mut self) -> Result<(), GpuError> {
        let steps = self.last_status[status::STEPS];
        self.last_status[status::HEALTH] = 0;
        self.last_status[status::CHECKED] = steps;
        let words = [0u32, steps];
        // HEALTH and CHECKED are adjacent words.
        self.ctx.queue.write_buffer(
            &self.bufs[Buf::Status],
            4 * status::HEALTH as u64,
            bytemuck::cast_slice(&words),
        );
        self.ctx.wait()
    }

    /// The energy samples computed on the GPU since the last call, in step order.
    pub fn take_samples(&mut self) -> Vec<EnergySample> {
        std::mem::take(&mut self.samples)
    }

    /// The `new` samples before the `total`-th from a read-back of the log ring.
    fn collect_samples(&mut self, log: &[u8], total: u32, new: u32) {
        let Some(h) = self.health else {
            return;
        };
        let records: Vec<HealthRecord> = bytemuck::pod_collect_to_vec(log);
        let new = new.min(HEALTH_LOG);
        for k in (0..new).rev() {
            let slot = (total.wrapping_sub(1 + k) % HEALTH_LOG) as usize;
            let r = records[slot];
            // The sample's GPU step count, from its low 32 bits.
            let back = (self.gpu_steps as u32).wrapping_sub(r.step) as u64;
            let g = self.gpu_steps.saturating_sub(back);
            self.samples.push(EnergySample {
                step: self.base_step + g,
                time: self.time_after(g),
                kinetic: r.sums[0] as f64,
                potential: r.sums[1] as f64 + h.reference_energy,
                momentum: [r.sums[2] as f64, r.sums[3] as f64, r.pz as f64],
            });
        }
    }

    /// The simulated time after `g` GPU steps: the CPU's sum of `dt`, continued from the
    /// last call's when it can be.
    fn time_after(&self, g: u64) -> f64 {
        let mut cache = self
            .time_sum
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let (mut k, mut t) = *cache;
        if k > g {
            (k, t) = (0, self.base_time);
        }
        while k < g {
            t += self.dt as f64;
            k += 1;
        }
        *cache = (k, t);
        t
    }

    /// The last good state kept on the device (see [`GpuWorld::set_health`]) into `world`
    /// (a copy of the world this was created from): bodies, step count, time and contacts.
    /// Returns false, leaving `world` alone, when no snapshot was taken yet.
    pub fn read_last_good(&self, world: &mut World) -> Result<bool, GpuError> {
        use crate::layout::snapshot as snap;
        let buf = &self.bufs[Buf::Snapshot];
        let st: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.read_buffer(buf, 0, 4 * snap::STATUS)?);
        if st[status::HEALTH] != 0 {
            return Ok(false);
        }
        let (n, walls) = (self.n as u64, self.wall_slots as u64);
        let nb = self.params.num_boundaries as u64;
        let np = (st[status::PAIRS] as u64).min(self.params.pair_capacity as u64);
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&self.read_buffer(
            buf,
            0,
            4 * snap::words(n, walls, nb, np),
        )?);
        let f4 = |at: usize| -> [f32; 4] { std::array::from_fn(|k| f32::from_bits(words[at + k])) };
        let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        let force = |at: usize| {
            let (a, b, c) = (f4(at), f4(at + 4), f4(at + 8));
            ContactForce {
                force_b: v3(a),
                normal_force: a[3],
                torque_a: v3(b),
                pad0: b[3],
                torque_b: v3(c),
                pad1: c[3],
            }
        };
        let body_at = |i: u64| (snap::STATUS + snap::BODY * i) as usize;
        for i in 0..n {
            let at = body_at(i);
            let s = BodyState {
                position: f4(at),
                velocity: f4(at + 4),
                orientation: f4(at + 8),
                residual: f4(at + 12),
                angular_momentum: f4(at + 16),
                omega: f4(at + 20),
            };
            world.state.set_record(i as usize, &s);
        }
        let slot_at = |k: u64| (snap::STATUS + snap::BODY * n + snap::SLOT * k) as usize;
        let pair_at = |k: u64| (snap::pairs_at(n, walls, nb) + snap::PAIR * k) as usize;
        let slots = n * walls;
        let hist: Vec<[f32; 4]> = (0..np).map(|k| f4(pair_at(k) + 2)).collect();
        let wall_hist: Vec<[f32; 4]> = (0..slots).map(|k| f4(slot_at(k))).collect();
        let (pairs, pieces) = decode_pairs(
            (0..np)
                .map(|k| [words[pair_at(k)], words[pair_at(k) + 1]])
                .collect(),
            self.params.composites != 0,
        );
        let state = ContactState {
            rebuild_position: if st[status::REBUILDS] > 0 {
                (0..n).map(|i| v3(f4(body_at(i) + 24))).collect()
            } else {
                Vec::new()
            },
            rebuild_orientation: if st[status::REBUILDS] > 0 && self.params.composites != 0 {
                (0..n).map(|i| quat_of(f4(body_at(i) + 28))).collect()
            } else {
                Vec::new()
            },
            pairs,
            pieces,
            history: hist.iter().map(|&h| v3(h)).collect(),
            twist: hist.iter().map(|h| h[3]).collect(),
            touching: (0..np).map(|k| words[pair_at(k) + 6] == 1).collect(),
            forces: (0..np).map(|k| force(pair_at(k) + 7)).collect(),
            wall_history: wall_hist.iter().map(|&h| v3(h)).collect(),
            wall_twist: wall_hist.iter().map(|h| h[3]).collect(),
            wall_touching: (0..slots).map(|k| words[slot_at(k) + 16] != 0).collect(),
            wall_forces: (0..slots)
                .map(|k| ContactForce {
                    pad0: 0.0,
                    ..force(slot_at(k) + 4)
                })
                .collect(),
        };
        let back = (self.gpu_steps as u32).wrapping_sub(st[status::STEPS]) as u64;
        let g = self.gpu_steps.saturating_sub(back);
        world.step_count = self.base_step + g;
        let mut t = self.base_time;
        for _ in 0..g {
            t += self.dt as f64;
        }
        world.time = t;
        world.set_contact_state(state);
        if nb > 0 {
            // The mesh slots and the step of their last rebuild, as `read_mesh_into`.
            let at = snap::mesh_at(n, walls) as usize;
            let mesh = &words[at..at + snap::mesh_words(n, nb) as usize];
            let (slots, rebuild_step) = crate::mesh::read_slots(mesh, n as usize, nb as usize);
            let back = st[status::STEPS].wrapping_sub(rebuild_step) as u64;
            let rebuild_time = self.time_after(g.saturating_sub(back));
            world
                .restore_mesh(slots, rebuild_time)
                .map_err(GpuError::Unsupported)?;
        }
        Ok(true)
    }
}

/// Pair-list entries read back from the GPU as body pairs and, with composites, the CPU's
/// piece codes (the GPU keeps each body's piece id above its index, see pieces.wgsl).
fn decode_pairs(raw: Vec<[u32; 2]>, composites: bool) -> (Vec<[u32; 2]>, Vec<u32>) {
    if !composites {
        return (raw, Vec::new());
    }
    let shift = crate::shapes::PIECE_SHIFT;
    let mask = (1u32 << shift) - 1;
    raw.iter()
        .map(|&[x, y]| {
            (
                [x & mask, y & mask],
                clatter::contacts::piece_code(x >> shift, y >> shift),
            )
        })
        .unzip()
}

//! The GPU world: a [`clatter::World`]'s state resident on the GPU and the step pipeline
//! that advances it, stage by stage as on the CPU:
//!
//! 1. `prepare` (bin.wgsl): does this step rebuild the pair list? (a body moved more than
//!    half the skin since the last rebuild; flagged on the GPU by the last integrate, so the
//!    host never waits for it: every rebuild-only dispatch is indirect, sized zero otherwise)
//! 2. **bin** (bin.wgsl): bounding box, grid, cell key per body, bodies per cell
//! 3. **sort** (scan.wgsl, sort.wgsl): cell ranges by prefix sum, bodies dropped into cells,
//!    each cell ordered by body index (the CPU's stable counting sort, exactly)
//! 4. **pairs** (pairs.wgsl): the 27-cell search, pair offsets, sorted pair list, springs
//!    carried over from the old list, the b-side adjacency for the gather
//! 5. **narrow** + **forces** (narrow.wgsl, forces.wgsl; contacts_split.wgsl for scenes with
//!    polyhedra): manifold and contact law per pair
//! 6. **integrate** (integrate.wgsl): the body-wall contacts, gather in a fixed order,
//!    update, rebuild check
//!
//! The host records many steps into one submission and reads a few status words back after
//! it; body state comes back only when output is due ([`GpuWorld::read_into`]). If the pair
//! list outgrows its buffer, the GPU stops at the start of that step; the host grows the
//! buffers and runs the step again, so the result does not depend on the initial capacity.

use std::sync::Arc;

use rayon::prelude::*;

use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::layout::{Params, arg, status};
use crate::shapes::GpuShapes;
use crate::{GpuContext, GpuError};
use clatter::ContactForce;
use clatter::contract::{BodyConsts, BodyState, WallRecord};
use clatter::{ContactState, World};

const WG: u32 = 256;
/// Steps recorded into one submission between status reads.
const BATCH: u64 = 64;
/// Batches recorded side by side on the CPU. wgpu spends a few microseconds of CPU time on
/// each dispatch (state tracking and barriers for the 26 buffers every kernel binds), about
/// as long as the GPU needs for a step of 65,536 spheres, so one recording thread would
/// hold the GPU back; up to `2 * ENCODERS` batches are in flight.
const ENCODERS: usize = 4;
/// Initial pair capacity per body (grown on demand).
const PAIRS_PER_BODY: u64 = 8;

const COMMON: &str = include_str!("../shaders/common.wgsl");
const BINDINGS: &str = include_str!("../shaders/bindings.wgsl");
const ARGS: &str = include_str!("../shaders/args.wgsl");
const NARROW: &str = include_str!("../shaders/narrow.wgsl");
const NARROW_SPHERES: &str = include_str!("../shaders/narrow_spheres.wgsl");
const BIN: &str = include_str!("../shaders/bin.wgsl");
const SCAN: &str = include_str!("../shaders/scan.wgsl");
const SORT: &str = include_str!("../shaders/sort.wgsl");
const PAIRS: &str = include_str!("../shaders/pairs.wgsl");
const FORCES: &str = include_str!("../shaders/forces.wgsl");
const CONTACTS_SPLIT: &str = include_str!("../shaders/contacts_split.wgsl");
const INTEGRATE: &str = include_str!("../shaders/integrate.wgsl");

/// The kernels every world uses (the contact kernels come in two variants, see
/// `GpuWorld::contact_kernels`).
const BASE_KERNELS: &[(&str, &str, Extra)] = &[
    ("bin", "prepare", Extra::Args),
    ("bin", "prepare_lean", Extra::Args),
    ("bin", "bbox", Extra::None),
    ("bin", "grid_size", Extra::None),
    ("bin", "bin", Extra::None),
    ("bin", "copy_cells", Extra::None),
    ("scan", "scan_block", Extra::Scan),
    ("scan", "scan_add", Extra::Scan),
    ("sort", "scatter", Extra::None),
    ("sort", "sort_cells", Extra::None),
    ("pairs", "count_pairs", Extra::None),
    ("pairs", "pairs_total", Extra::Args),
    ("pairs", "fill_pairs", Extra::None),
    ("pairs", "carry", Extra::None),
    ("pairs", "commit", Extra::None),
    ("pairs", "count_b", Extra::None),
    ("pairs", "copy_b", Extra::None),
    ("pairs", "fill_b", Extra::None),
    ("pairs", "sort_b", Extra::None),
    ("bin", "end_step", Extra::None),
];

/// Which bind groups a kernel uses besides group 0 (simulation) and 1 (shapes).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Extra {
    None,
    /// Group 2 = indirect arguments (the kernels that size later dispatches).
    Args,
    /// Group 2 = a scan level (data, sums).
    Scan,
}

/// How a kernel is dispatched.
#[derive(Clone, Copy)]
enum Size {
    /// One workgroup of one thread.
    Single,
    /// Indirect from an argument slot.
    Indirect(u32),
}

#[derive(Clone, Copy)]
struct Op {
    /// Whether the pipeline is one of the contact kernels (else a base kernel).
    contact: bool,
    pipeline: usize,
    size: Size,
    /// Index into the scan bind groups (for `Extra::Scan` kernels).
    scan: usize,
}

/// The pipelines by name.
struct Kernels {
    pipelines: Vec<wgpu::ComputePipeline>,
    extra: Vec<Extra>,
    names: Vec<&'static str>,
}

impl Kernels {
    fn index(&self, name: &str) -> usize {
        self.names
            .iter()
            .position(|n| *n == name)
            .unwrap_or_else(|| panic!("kernel {name} is not built"))
    }
}

/// The bind group layouts and pipelines, shared by every world on a device.
struct Compiled {
    layouts: [wgpu::BindGroupLayout; 3],
    kernels: Kernels,
    /// `contacts` and `integrate` (which computes the wall contacts) for sphere-only
    /// scenes, and for any scene (with the
    /// polyhedron narrow phase), each compiled on first use.
    spheres: std::sync::OnceLock<Result<Kernels, GpuError>>,
    general: std::sync::OnceLock<Result<Kernels, GpuError>>,
}

/// One exclusive scan over a buffer of `len` u32: the level buffers and their bind groups.
struct ScanPlan {
    /// Groups per level (level 0 is the data itself).
    groups: Vec<u32>,
    /// Bind group per level: (level data, next level's sums).
    bind_groups: Vec<wgpu::BindGroup>,
    /// Argument slot per level.
    slots: Vec<u32>,
}

/// A scene's state on the GPU and the compiled step pipeline. See the module docs.
pub struct GpuWorld {
    ctx: Arc<GpuContext>,
    n: u32,
    num_walls: u32,
    params: Params,
    shapes: GpuShapes,
    compiled: Arc<Compiled>,
    // Buffers (group 0 in binding order, see bindings.wgsl).
    params_buf: wgpu::Buffer,
    bodies: wgpu::Buffer,
    statics: wgpu::Buffer,
    pair_table: wgpu::Buffer,
    walls: wgpu::Buffer,
    status_buf: wgpu::Buffer,
    grid: wgpu::Buffer,
    keys: wgpu::Buffer,
    sorted: wgpu::Buffer,
    cell_count: wgpu::Buffer,
    cell_start: wgpu::Buffer,
    rebuild_pos: wgpu::Buffer,
    new_a_start: wgpu::Buffer,
    a_start: wgpu::Buffer,
    new_pairs: wgpu::Buffer,
    pairs: wgpu::Buffer,
    new_hist: wgpu::Buffer,
    hist: wgpu::Buffer,
    touching: wgpu::Buffer,
    forces: wgpu::Buffer,
    b_count: wgpu::Buffer,
    b_start: wgpu::Buffer,
    b_adj: wgpu::Buffer,
    wall_hist: wgpu::Buffer,
    wall_forces: wgpu::Buffer,
    wall_touching: wgpu::Buffer,
    args: wgpu::Buffer,
    arg_template: wgpu::Buffer,
    // Scan scratch.
    cell_scan_sums: Vec<wgpu::Buffer>,
    body_scan_sums: Vec<wgpu::Buffer>,
    scan_dummy: wgpu::Buffer,
    // Bind groups and the recorded step.
    group0: wgpu::BindGroup,
    group1: wgpu::BindGroup,
    args_group: wgpu::BindGroup,
    scans: Vec<wgpu::BindGroup>,
    ops: Vec<Op>,
    /// The step without the rebuild's dispatches (see `encode_steps`).
    lean_ops: Vec<Op>,
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
}

fn storage(read_only: bool) -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only },
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

fn entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    }
}

fn split(groups: u32) -> (u32, u32) {
    if groups == 0 {
        (0, 0)
    } else {
        (groups.min(65535), groups.div_ceil(65535))
    }
}

impl GpuWorld {
    /// Uploads `world` (bodies, shapes, materials, walls and its contact springs) and builds
    /// the pipeline. Fails with a clear error when the scene does not fit the adapter.
    pub fn new(ctx: Arc<GpuContext>, world: &World) -> Result<GpuWorld, GpuError> {
        let n = world.len() as u32;
        let num_walls = world.walls.len() as u32;
        let shapes = GpuShapes::upload(&ctx, &world.shapes)?;
        let state = world.contact_state();
        let capacity = (world.len() as u64 * PAIRS_PER_BODY)
            .max(state.pairs.len() as u64 + world.len() as u64)
            .max(1024);
        Self::check_fits(&ctx, world.len() as u64, capacity, num_walls as u64)?;
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
        };
        let device = &ctx.device;
        let compiled = Self::compiled(&ctx)?;
        let layouts = &compiled.layouts;
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let init = |label: &str, contents: &[u8]| {
            let mut bytes = contents.to_vec();
            // Room for at least one element of any binding's struct, even when empty.
            if bytes.len() < 64 {
                bytes.resize(64, 0);
            }
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &bytes,
                usage,
            })
        };
        let zeroed = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(64),
                usage,
                mapped_at_creation: false,
            })
        };
        // Body state and constants.
        let states: Vec<BodyState> = (0..world.len()).map(|i| world.state.record(i)).collect();
        let statics: Vec<BodyConsts> = (0..world.len()).map(|i| world.consts.record(i)).collect();
        let table = world.materials.table();
        let walls: Vec<WallRecord> = world.walls.iter().map(WallRecord::from).collect();
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
        let mut pairs: Vec<[u32; 2]> = state.pairs.clone();
        hist.resize(capacity as usize, [0.0; 4]);
        pairs.resize(capacity as usize, [0, 0]);
        let nslots = (nb * num_walls as u64) as usize;
        let wall_hist: Vec<[f32; 4]> = (0..nslots)
            .map(|k| {
                let h = state.wall_history[k];
                [h.x, h.y, h.z, state.wall_twist[k]]
            })
            .collect();
        let wall_touching: Vec<u32> = state.wall_touching.iter().map(|&t| t as u32).collect();
        let wall_forces = &state.wall_forces;
        let mut st = [0u32; status::LEN];
        st[status::REBUILD] = 1;
        st[status::BAD_BODY] = u32::MAX;
        let max_cells = params.max_cells as u64;
        let mut w = GpuWorld {
            params_buf: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            }),
            bodies: init("bodies", bytemuck::cast_slice(&states)),
            statics: init("statics", bytemuck::cast_slice(&statics)),
            pair_table: init("pair_table", bytemuck::cast_slice(table)),
            walls: init("walls", bytemuck::cast_slice(&walls)),
            status_buf: init("status", bytemuck::cast_slice(&st)),
            grid: zeroed("grid", 48),
            keys: zeroed("keys", 4 * nb),
            sorted: zeroed("sorted", 4 * nb),
            cell_count: zeroed("cell_count", 4 * (max_cells + 1)),
            cell_start: zeroed("cell_start", 4 * (max_cells + 1)),
            rebuild_pos: zeroed("rebuild_pos", 16 * nb),
            new_a_start: zeroed("new_a_start", 4 * (nb + 1)),
            a_start: init("a_start", bytemuck::cast_slice(&a_start)),
            new_pairs: zeroed("new_pairs", 8 * capacity),
            pairs: init("pairs", bytemuck::cast_slice(&pairs)),
            new_hist: zeroed("new_hist", 16 * capacity),
            hist: init("hist", bytemuck::cast_slice(&hist)),
            touching: zeroed("touching", 4 * capacity),
            forces: zeroed("forces", 48 * capacity),
            b_count: zeroed("b_count", 4 * (nb + 1)),
            b_start: zeroed("b_start", 4 * (nb + 1)),
            b_adj: zeroed("b_adj", 4 * capacity),
            wall_hist: init("wall_hist", bytemuck::cast_slice(&wall_hist)),
            wall_forces: init("wall_forces", bytemuck::cast_slice(wall_forces)),
            wall_touching: init("wall_touching", bytemuck::cast_slice(&wall_touching)),
            args: zeroed("args", 4),
            arg_template: zeroed("arg_template", 4),
            cell_scan_sums: Vec::new(),
            body_scan_sums: Vec::new(),
            scan_dummy: zeroed("scan_dummy", 4),
            group0: dummy_group(device, &layouts[2]),
            group1: dummy_group(device, &layouts[2]),
            args_group: dummy_group(device, &layouts[2]),
            scans: Vec::new(),
            ops: Vec::new(),
            lean_ops: Vec::new(),
            full_batches: 0,
            lean_enabled: true,
            stalls: 0,
            last_stall: 0,
            time_sum: std::sync::Mutex::new((0, world.time)),
            ctx,
            n,
            num_walls,
            params,
            shapes,
            compiled: compiled.clone(),
            gpu_steps: 0,
            base_step: world.step_count,
            base_time: world.time,
            dt: world.dt,
            last_status: st,
        };
        w.record()?;
        w.ctx.wait()?;
        Ok(w)
    }

    /// The device's compiled pipelines, built on first use.
    fn compiled(ctx: &GpuContext) -> Result<Arc<Compiled>, GpuError> {
        let mut slot = ctx.pipelines.lock().map_err(|_| GpuError::Runtime {
            adapter: ctx.adapter_name(),
            message: "pipeline cache poisoned".into(),
        })?;
        if let Some(c) = slot
            .as_ref()
            .and_then(|a| a.clone().downcast::<Compiled>().ok())
        {
            return Ok(c);
        }
        let layouts = Self::layouts(&ctx.device);
        let kernels = Self::build_kernels(ctx, &layouts)?;
        let c = Arc::new(Compiled {
            layouts: [layouts.0, layouts.1, layouts.2],
            kernels,
            spheres: std::sync::OnceLock::new(),
            general: std::sync::OnceLock::new(),
        });
        *slot = Some(c.clone());
        Ok(c)
    }

    /// The contact kernels this world needs, compiled on first use per device: sphere-only
    /// scenes skip the (large) polyhedron narrow phase.
    fn contact_kernels_ready(&self) -> Result<&Kernels, GpuError> {
        let (cell, narrow) = if self.params.spheres_only != 0 {
            (&self.compiled.spheres, NARROW_SPHERES)
        } else {
            (&self.compiled.general, NARROW)
        };
        cell.get_or_init(|| Self::contact_kernels(&self.ctx, &self.compiled.layouts, narrow))
            .as_ref()
            .map_err(|e| e.clone())
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
    fn layouts(
        device: &wgpu::Device,
    ) -> (
        wgpu::BindGroupLayout,
        wgpu::BindGroupLayout,
        wgpu::BindGroupLayout,
    ) {
        // Group 0, in bindings.wgsl order: params (uniform), bodies, statics (ro), pair_table
        // (ro), walls (ro), then read-write buffers.
        let mut e0 = vec![entry(
            0,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
        )];
        e0.push(entry(1, storage(false)));
        e0.push(entry(2, storage(true)));
        e0.push(entry(3, storage(true)));
        e0.push(entry(4, storage(true)));
        for b in 5..26 {
            e0.push(entry(b, storage(false)));
        }
        let g0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("simulation"),
            entries: &e0,
        });
        let g1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shapes"),
            entries: &GpuShapes::layout_entries(wgpu::ShaderStages::COMPUTE),
        });
        // Group 2 of the scans: data, sums. The argument writers use the same shape (args
        // read-write, template read-only would differ): both as read-write storage.
        let g2 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scan or args"),
            entries: &[entry(0, storage(false)), entry(1, storage(false))],
        });
        (g0, g1, g2)
    }

    fn build_kernels(
        ctx: &GpuContext,
        layouts: &(
            wgpu::BindGroupLayout,
            wgpu::BindGroupLayout,
            wgpu::BindGroupLayout,
        ),
    ) -> Result<Kernels, GpuError> {
        let bin_src = [COMMON, BINDINGS, ARGS, BIN].concat();
        let modules = vec![
            ("bin", bin_src.clone()),
            ("scan", [COMMON, BINDINGS, SCAN].concat()),
            ("sort", [COMMON, BINDINGS, SORT].concat()),
            ("pairs", [bin_src.as_str(), PAIRS].concat()),
        ];
        Self::compile(
            ctx,
            [&layouts.0, &layouts.1, &layouts.2],
            &modules,
            BASE_KERNELS,
        )
    }

    /// The contact kernels with the narrow phase `narrow` (sphere-only or general).
    fn contact_kernels(
        ctx: &GpuContext,
        layouts: &[wgpu::BindGroupLayout; 3],
        narrow: &str,
    ) -> Result<Kernels, GpuError> {
        // Sphere-only scenes: one pass over the pairs. Others: the two passes of
        // contacts_split.wgsl (prove pairs apart, then the full narrow phase on the rest).
        let split = narrow != NARROW_SPHERES;
        let (source, kernels): (String, &[(&str, &str, Extra)]) = if split {
            (
                [
                    COMMON,
                    BINDINGS,
                    ARGS,
                    narrow,
                    FORCES,
                    CONTACTS_SPLIT,
                    INTEGRATE,
                ]
                .concat(),
                &[
                    ("forces", "contacts_sat", Extra::None),
                    ("forces", "contacts_size", Extra::Args),
                    ("forces", "contacts_full", Extra::None),
                    ("forces", "integrate", Extra::None),
                ],
            )
        } else {
            (
                [COMMON, BINDINGS, narrow, FORCES, INTEGRATE].concat(),
                &[
                    ("forces", "contacts", Extra::None),
                    ("forces", "integrate", Extra::None),
                ],
            )
        };
        let modules = vec![("forces", source)];
        Self::compile(
            ctx,
            [&layouts[0], &layouts[1], &layouts[2]],
            &modules,
            kernels,
        )
    }

    fn compile(
        ctx: &GpuContext,
        layouts: [&wgpu::BindGroupLayout; 3],
        modules: &[(&str, String)],
        kernels: &[(&str, &'static str, Extra)],
    ) -> Result<Kernels, GpuError> {
        let device = &ctx.device;
        let base = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("base"),
            bind_group_layouts: &[Some(layouts[0]), Some(layouts[1])],
            immediate_size: 0,
        });
        let with_g2 = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("with group 2"),
            bind_group_layouts: &[Some(layouts[0]), Some(layouts[1]), Some(layouts[2])],
            immediate_size: 0,
        });
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut compiled = Vec::new();
        for (name, src) in modules.iter() {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(src.as_str().into()),
            });
            compiled.push((*name, module));
        }
        let mut out = Kernels {
            pipelines: Vec::new(),
            extra: Vec::new(),
            names: Vec::new(),
        };
        for &(module, entry_point, extra) in kernels {
            let m = &compiled
                .iter()
                .find(|(n, _)| *n == module)
                .expect("module listed")
                .1;
            let layout = if extra == Extra::None {
                &base
            } else {
                &with_g2
            };
            out.pipelines.push(
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry_point),
                    layout: Some(layout),
                    module: m,
                    entry_point: Some(entry_point),
                    compilation_options: Default::default(),
                    cache: None,
                }),
            );
            out.extra.push(extra);
            out.names.push(entry_point);
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Runtime {
                adapter: ctx.adapter_name(),
                message: format!("shader compilation failed: {e}"),
            });
        }
        Ok(out)
    }

    /// Plans the scans, writes the argument template and the bind groups, and records the
    /// list of dispatches of one step.
    fn record(&mut self) -> Result<(), GpuError> {
        let device = &self.ctx.device;
        let n = self.n as u64;
        let max_cells = self.params.max_cells as u64;
        let mut template: Vec<[u32; 3]> = vec![[0; 3]; arg::FIRST_SCAN as usize];
        let groups = |count: u64| count.div_ceil(WG as u64) as u32;
        let set = |t: &mut Vec<[u32; 3]>, slot: u32, g: u32| {
            let (x, y) = split(g);
            t[slot as usize] = [x, y, 1];
        };
        set(&mut template, arg::BODIES_REBUILD, groups(n + 1));
        set(&mut template, arg::CELLS_REBUILD, groups(max_cells + 1));
        // Scan level buffers: sums of 256-blocks until one block remains.
        let levels = |len: u64| {
            let mut v = vec![len];
            while *v.last().expect("non-empty") > WG as u64 {
                let l = v.last().expect("non-empty").div_ceil(WG as u64);
                v.push(l);
            }
            v
        };
        let cell_levels = levels(max_cells + 1);
        let body_levels = levels(n + 1);
        let usage = wgpu::BufferUsages::STORAGE;
        let make_sums = |lv: &[u64], label: &str| -> Vec<wgpu::Buffer> {
            lv[1..]
                .iter()
                .map(|&l| {
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some(label),
                        size: 4 * l,
                        usage,
                        mapped_at_creation: false,
                    })
                })
                .collect()
        };
        self.cell_scan_sums = make_sums(&cell_levels, "cell scan sums");
        self.body_scan_sums = make_sums(&body_levels, "body scan sums");
        self.scans.clear();
        let plan = |data: &wgpu::Buffer,
                    sums: &[wgpu::Buffer],
                    lv: &[u64],
                    template: &mut Vec<[u32; 3]>,
                    scans: &mut Vec<wgpu::BindGroup>|
         -> ScanPlan {
            let mut p = ScanPlan {
                groups: Vec::new(),
                bind_groups: Vec::new(),
                slots: Vec::new(),
            };
            for (l, &len) in lv.iter().enumerate() {
                let d = if l == 0 { data } else { &sums[l - 1] };
                let s = sums.get(l).unwrap_or(&self.scan_dummy);
                let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("scan level"),
                    layout: &self.compiled.layouts[2],
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: d.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: s.as_entire_binding(),
                        },
                    ],
                });
                let g = groups(len);
                let slot = template.len() as u32;
                template.push([0; 3]);
                let (x, y) = split(g);
                template[slot as usize] = [x, y, 1];
                p.groups.push(g);
                p.bind_groups.push(bg);
                p.slots.push(slot);
            }
            // Bind groups are referenced by index into `scans`.
            let base = scans.len();
            scans.append(&mut p.bind_groups);
            p.bind_groups = Vec::new();
            p.groups.push(base as u32);
            p
        };
        let mut scans = Vec::new();
        let cell_plan = plan(
            &self.cell_start,
            &self.cell_scan_sums,
            &cell_levels,
            &mut template,
            &mut scans,
        );
        let a_plan = plan(
            &self.new_a_start,
            &self.body_scan_sums,
            &body_levels,
            &mut template,
            &mut scans,
        );
        let b_plan = plan(
            &self.b_start,
            &self.body_scan_sums,
            &body_levels,
            &mut template,
            &mut scans,
        );
        self.scans = scans;
        self.params.num_args = template.len() as u32;
        let flat: Vec<u32> = template.iter().flatten().copied().collect();
        let args_usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::INDIRECT
            | wgpu::BufferUsages::COPY_DST;
        self.args = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("args"),
            contents: bytemuck::cast_slice(&vec![0u32; flat.len()]),
            usage: args_usage,
        });
        self.arg_template = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("arg template"),
            contents: bytemuck::cast_slice(&flat),
            usage: wgpu::BufferUsages::STORAGE,
        });
        self.ctx
            .queue
            .write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        let buffers = [
            &self.params_buf,
            &self.bodies,
            &self.statics,
            &self.pair_table,
            &self.walls,
            &self.status_buf,
            &self.grid,
            &self.keys,
            &self.sorted,
            &self.cell_count,
            &self.cell_start,
            &self.rebuild_pos,
            &self.new_a_start,
            &self.a_start,
            &self.new_pairs,
            &self.pairs,
            &self.new_hist,
            &self.hist,
            &self.touching,
            &self.forces,
            &self.b_count,
            &self.b_start,
            &self.b_adj,
            &self.wall_hist,
            &self.wall_forces,
            &self.wall_touching,
        ];
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(k, b)| wgpu::BindGroupEntry {
                binding: k as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.group0 = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("simulation"),
            layout: &self.compiled.layouts[0],
            entries: &entries,
        });
        self.group1 = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shapes"),
            layout: &self.compiled.layouts[1],
            entries: &self.shapes.bind_entries(),
        });
        self.args_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("args"),
            layout: &self.compiled.layouts[2],
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.args.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.arg_template.as_entire_binding(),
                },
            ],
        });
        // The step, in order.
        let k = |name: &str| self.compiled.kernels.index(name);
        let mut ops = Vec::new();
        let mut op = |name: &str, size: Size| {
            ops.push(Op {
                contact: false,
                pipeline: k(name),
                size,
                scan: 0,
            })
        };
        let bodies_rb = Size::Indirect(arg::BODIES_REBUILD);
        let cells_rb = Size::Indirect(arg::CELLS_REBUILD);
        op("prepare", Size::Single);
        op("bbox", bodies_rb);
        op("grid_size", Size::Single);
        op("bin", bodies_rb);
        op("copy_cells", cells_rb);
        let scan_ops = |ops: &mut Vec<Op>, p: &ScanPlan| {
            let base = *p.groups.last().expect("base index") as usize;
            let nlev = p.slots.len();
            for l in 0..nlev {
                ops.push(Op {
                    contact: false,
                    pipeline: k("scan_block"),
                    size: Size::Indirect(p.slots[l]),
                    scan: base + l,
                });
            }
            for l in (0..nlev.saturating_sub(1)).rev() {
                ops.push(Op {
                    contact: false,
                    pipeline: k("scan_add"),
                    size: Size::Indirect(p.slots[l]),
                    scan: base + l,
                });
            }
        };
        scan_ops(&mut ops, &cell_plan);
        let op = |ops: &mut Vec<Op>, name: &str, size: Size| {
            ops.push(Op {
                contact: false,
                pipeline: k(name),
                size,
                scan: 0,
            })
        };
        op(&mut ops, "scatter", bodies_rb);
        op(&mut ops, "sort_cells", cells_rb);
        op(&mut ops, "count_pairs", bodies_rb);
        scan_ops(&mut ops, &a_plan);
        op(&mut ops, "pairs_total", Size::Single);
        op(&mut ops, "fill_pairs", bodies_rb);
        op(&mut ops, "carry", Size::Indirect(arg::PAIRS_NEW));
        op(&mut ops, "commit", Size::Indirect(arg::COMMIT));
        op(&mut ops, "count_b", Size::Indirect(arg::PAIRS_NEW));
        op(&mut ops, "copy_b", bodies_rb);
        scan_ops(&mut ops, &b_plan);
        op(&mut ops, "fill_b", Size::Indirect(arg::PAIRS_NEW));
        op(&mut ops, "sort_b", bodies_rb);
        let contact_kernels = self.contact_kernels_ready()?;
        let contact_op = |name: &str, size: Size| Op {
            contact: true,
            pipeline: contact_kernels.index(name),
            size,
            scan: 0,
        };
        if self.params.spheres_only != 0 {
            ops.push(contact_op("contacts", Size::Indirect(arg::PAIRS)));
        } else {
            ops.push(contact_op("contacts_sat", Size::Indirect(arg::PAIRS)));
            ops.push(contact_op("contacts_size", Size::Single));
            ops.push(contact_op("contacts_full", Size::Indirect(arg::WORK)));
        }
        ops.push(contact_op("integrate", Size::Indirect(arg::STEP_BODIES)));
        op(&mut ops, "end_step", Size::Single);
        // The lean step: prepare_lean, then the contact stage onwards.
        let first_contact = ops.iter().position(|o| o.contact).unwrap_or(ops.len());
        let mut lean = Vec::new();
        op(&mut lean, "prepare_lean", Size::Single);
        lean.extend_from_slice(&ops[first_contact..]);
        self.lean_ops = lean;
        self.ops = ops;
        Ok(())
    }

    /// Records `steps` steps into `encoder`. The first step is the full step; with `lean`,
    /// the others leave out the rebuild's dispatches (about 30, most of them sized zero on
    /// the GPU, but each costing the GPU and wgpu a few microseconds: more than the whole
    /// step of a 65,536-sphere pile). A lean step whose predecessor flagged a rebuild stops
    /// the pipeline (`prepare_lean`, status word STALL) until the first step of the next
    /// batch, a full one, which runs that step with the rebuild: the rebuilds happen at the
    /// same steps, and the results are the same, as if every step were full.
    fn encode_steps(&self, encoder: &mut wgpu::CommandEncoder, steps: u64, lean: bool) {
        let Ok(contacts) = self.contact_kernels_ready() else {
            return;
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("steps"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.group0, &[]);
        pass.set_bind_group(1, &self.group1, &[]);
        for k in 0..steps {
            let ops = if lean && k > 0 {
                &self.lean_ops
            } else {
                &self.ops
            };
            for op in ops {
                self.encode_op(&mut pass, op, contacts);
            }
        }
    }

    /// The kernels `op` indexes: the contact kernels of this world or the base kernels.
    fn kernel_set<'a>(&'a self, op: &Op, contacts: &'a Kernels) -> &'a Kernels {
        if op.contact {
            contacts
        } else {
            &self.compiled.kernels
        }
    }

    /// Records one kernel of the step into `pass` (groups 0 and 1 already bound).
    fn encode_op(&self, pass: &mut wgpu::ComputePass<'_>, op: &Op, contacts: &Kernels) {
        let set = self.kernel_set(op, contacts);
        pass.set_pipeline(&set.pipelines[op.pipeline]);
        match set.extra[op.pipeline] {
            Extra::None => {}
            Extra::Args => pass.set_bind_group(2, &self.args_group, &[]),
            Extra::Scan => pass.set_bind_group(2, &self.scans[op.scan], &[]),
        }
        match op.size {
            Size::Single => pass.dispatch_workgroups(1, 1, 1),
            Size::Indirect(slot) => pass.dispatch_workgroups_indirect(&self.args, slot as u64 * 12),
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
        let contacts = self.contact_kernels_ready()?;
        let name_of = |op: &Op| -> &'static str {
            match self.kernel_set(op, contacts).names[op.pipeline] {
                "scan_block" | "scan_add" => "scan",
                other => other,
            }
        };
        let mut names: Vec<&'static str> = Vec::new();
        for op in &self.ops {
            let name = name_of(op);
            if !names.contains(&name) {
                names.push(name);
            }
        }
        let mut totals = vec![0u64; names.len()];
        let per_step = 2 * self.ops.len() as u32;
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
                for op in &self.ops {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(name_of(op)),
                        timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                            query_set: &query_set,
                            beginning_of_pass_write_index: Some(q),
                            end_of_pass_write_index: Some(q + 1),
                        }),
                    });
                    q += 2;
                    pass.set_bind_group(0, &self.group0, &[]);
                    pass.set_bind_group(1, &self.group1, &[]);
                    self.encode_op(&mut pass, op, contacts);
                }
            }
            encoder.resolve_query_set(&query_set, 0..q, &resolve, 0);
            let parts = read_buffers_after(
                &self.ctx,
                encoder,
                &[
                    (&resolve, 0, 8 * q as u64),
                    (&self.status_buf, 0, 4 * status::LEN as u64),
                ],
            )?;
            let stamps: Vec<u64> = bytemuck::pod_collect_to_vec(&parts[0]);
            for (k, op) in self.ops.iter().cycle().take((q / 2) as usize).enumerate() {
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
                    let pending = submit_read(
                        &self.ctx,
                        encoder,
                        &[
                            (&self.status_buf, 0, 4 * status::LEN as u64),
                            (&self.bodies, 0, body_bytes),
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
            self.gpu_steps = (self.gpu_steps + done).min(target);
            self.last_status = st;
            let stopped = st[status::BAD_BODY] != u32::MAX || st[status::OVERFLOW] != 0;
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
        })
    }

    /// Grows the pair buffers to hold `needed` pairs (with room to spare), keeping the old
    /// list and springs, and lets the stopped step run again.
    fn grow(&mut self, needed: u64) -> Result<(), GpuError> {
        let capacity = (needed + needed / 2).max(self.params.pair_capacity as u64 * 2);
        Self::check_fits(&self.ctx, self.n as u64, capacity, self.num_walls as u64)?;
        let device = &self.ctx.device;
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let make = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let pairs = make("pairs", 8 * capacity);
        let hist = make("hist", 16 * capacity);
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.pairs, 0, &pairs, 0, self.pairs.size());
        encoder.copy_buffer_to_buffer(&self.hist, 0, &hist, 0, self.hist.size());
        self.pairs = pairs;
        self.hist = hist;
        self.new_pairs = make("new_pairs", 8 * capacity);
        self.new_hist = make("new_hist", 16 * capacity);
        self.touching = make("touching", 4 * capacity);
        self.forces = make("forces", 48 * capacity);
        self.b_adj = make("b_adj", 4 * capacity);
        // Resume: clear the overflow, ask for the rebuild again.
        let mut st = self.last_status;
        st[status::OVERFLOW] = 0;
        st[status::STALL] = 0;
        st[status::REBUILD] = 1;
        self.ctx
            .queue
            .write_buffer(&self.status_buf, 0, bytemuck::cast_slice(&st));
        self.ctx.queue.submit([encoder.finish()]);
        self.params.pair_capacity = capacity as u32;
        self.record()?;
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
        &self.bodies
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
        let bytes = self.read_buffer(&self.bodies, 0, 96 * self.n as u64)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// Copies the GPU state back into `world` (the world it was created from): body state,
    /// step count, time, and the contact list with its springs and forces, so outputs,
    /// health checks and checkpoints work on it as after CPU steps.
    pub fn read_into(&self, world: &mut World) -> Result<(), GpuError> {
        let states = self.read_states()?;
        self.apply_states(&states, world);
        world.set_contact_state(self.contact_state()?);
        Ok(())
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
        let n = self.n as usize;
        let np = self.last_status[status::PAIRS] as usize;
        let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        let ns = (n * self.num_walls as usize) as u64;
        let (np, n) = (np as u64, n as u64);
        let mut parts = read_buffers(
            &self.ctx,
            &[
                (&self.pairs, 0, 8 * np),
                (&self.hist, 0, 16 * np),
                (&self.touching, 0, 4 * np),
                (&self.forces, 0, 48 * np),
                (&self.wall_hist, 0, 16 * ns),
                (&self.wall_touching, 0, 4 * ns),
                (&self.wall_forces, 0, 48 * ns),
                (&self.rebuild_pos, 0, 16 * n),
            ],
        )?
        .into_iter();
        let mut next = || parts.next().unwrap_or_default();
        let (pairs_bytes, hist_bytes, touch_bytes, force_bytes) = (next(), next(), next(), next());
        let (wh, wt, wf, rb) = (next(), next(), next(), next());
        let hist: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&hist_bytes);
        let wall_hist: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&wh);
        let forces: Vec<ContactForce> = bytemuck::pod_collect_to_vec(&force_bytes);
        let wall_forces: Vec<ContactForce> = bytemuck::pod_collect_to_vec(&wf);
        let rebuilt = self.last_status[status::REBUILDS] > 0;
        Ok(ContactState {
            rebuild_position: if rebuilt {
                bytemuck::pod_collect_to_vec::<u8, [f32; 4]>(&rb)
                    .iter()
                    .map(|&p| v3(p))
                    .collect()
            } else {
                Vec::new()
            },
            pairs: bytemuck::pod_collect_to_vec(&pairs_bytes),
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
            wall_touching: bytemuck::pod_collect_to_vec::<u8, u32>(&wt)
                .iter()
                .map(|&t| t != 0)
                .collect(),
            wall_forces,
        })
    }

    /// Reads a named stage buffer (for the stage-by-stage tests): `keys`, `sorted`,
    /// `cell_start`, `a_start`, `pairs`, `b_start`, `b_adj`, `forces`, `grid`, `status`.
    pub fn debug_buffer(&self, name: &str) -> Result<Vec<u8>, GpuError> {
        let b = match name {
            "keys" => &self.keys,
            "sorted" => &self.sorted,
            "cell_start" => &self.cell_start,
            "a_start" => &self.a_start,
            "pairs" => &self.pairs,
            "b_start" => &self.b_start,
            "b_adj" => &self.b_adj,
            "forces" => &self.forces,
            "wall_forces" => &self.wall_forces,
            "grid" => &self.grid,
            "status" => &self.status_buf,
            _ => {
                return Err(GpuError::Unsupported(format!(
                    "no stage buffer named {name}"
                )));
            }
        };
        self.read_buffer(b, 0, b.size())
    }
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
}

fn dummy_group(device: &wgpu::Device, layout: &wgpu::BindGroupLayout) -> wgpu::BindGroup {
    let b = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("placeholder"),
        size: 16,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("placeholder"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: b.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: b.as_entire_binding(),
            },
        ],
    })
}

/// Copies `size` bytes at `offset` of `buffer` (which needs `COPY_SRC`) back to the host.
pub fn read_buffer(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<u8>, GpuError> {
    Ok(read_buffers(ctx, &[(buffer, offset, size)])?.remove(0))
}

/// Copies several buffer ranges `(buffer, offset, size)` back to the host in one transfer
/// (one staging buffer, one wait).
pub fn read_buffers(
    ctx: &GpuContext,
    ranges: &[(&wgpu::Buffer, u64, u64)],
) -> Result<Vec<Vec<u8>>, GpuError> {
    let encoder = ctx.device.create_command_encoder(&Default::default());
    read_buffers_after(ctx, encoder, ranges)
}

/// A submitted read-back: the staging buffer being filled and where each range lands.
struct Pending {
    staging: Option<wgpu::Buffer>,
    at: Vec<(u64, u64)>,
    index: wgpu::SubmissionIndex,
}

impl Pending {
    /// Waits for the submission and copies the ranges out.
    fn wait(self, ctx: &GpuContext) -> Result<Vec<Vec<u8>>, GpuError> {
        let Some(staging) = self.staging else {
            return Ok(self.at.iter().map(|_| Vec::new()).collect());
        };
        ctx.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(self.index),
                timeout: None,
            })
            .map_err(|e| GpuError::Runtime {
                adapter: ctx.adapter_name(),
                message: e.to_string(),
            })?;
        ctx.take_error()?;
        let slice = staging.slice(..);
        let view = slice.get_mapped_range().map_err(|e| GpuError::Runtime {
            adapter: ctx.adapter_name(),
            message: format!("readback failed: {e}"),
        })?;
        let out = self
            .at
            .iter()
            .map(|&(dst, size)| view[dst as usize..(dst + size) as usize].to_vec())
            .collect();
        drop(view);
        staging.unmap();
        Ok(out)
    }
}

/// Submits `encoder` with copies of `ranges` into a staging buffer appended, and asks for
/// the buffer to be mapped; [`Pending::wait`] collects the bytes.
fn submit_read(
    ctx: &GpuContext,
    mut encoder: wgpu::CommandEncoder,
    ranges: &[(&wgpu::Buffer, u64, u64)],
) -> Result<Pending, GpuError> {
    let mut at = Vec::with_capacity(ranges.len());
    let mut total = 0u64;
    for &(_, _, size) in ranges {
        at.push((total, size));
        total += size.next_multiple_of(4);
    }
    if total == 0 {
        let index = ctx.queue.submit([encoder.finish()]);
        return Ok(Pending {
            staging: None,
            at,
            index,
        });
    }
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: total,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    for (&(buffer, offset, size), &(dst, _)) in ranges.iter().zip(&at) {
        if size > 0 {
            encoder.copy_buffer_to_buffer(buffer, offset, &staging, dst, size.next_multiple_of(4));
        }
    }
    let index = ctx.queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    Ok(Pending {
        staging: Some(staging),
        at,
        index,
    })
}

/// [`read_buffers`] after the work already recorded in `encoder` (one submission).
pub fn read_buffers_after(
    ctx: &GpuContext,
    encoder: wgpu::CommandEncoder,
    ranges: &[(&wgpu::Buffer, u64, u64)],
) -> Result<Vec<Vec<u8>>, GpuError> {
    submit_read(ctx, encoder, ranges)?.wait(ctx)
}

//! [`GpuWorld::new`]: the scene's checks, the step's parameters, the initial contents of
//! the buffers (bodies, walls and sink boxes, carried contacts, mesh slots) and the plan.

use std::sync::Arc;

use clatter::contract::{BodyConsts, BodyState, WallRecord};
use clatter::{ContactState, World};

use super::{GpuWorld, PAIRS_PER_BODY, Plan, max_cells};
use crate::buffers::{Buf, Buffers, Dims};
use crate::layout::{Params, WallForce, status};
use crate::pipeline::Compiled;
use crate::shapes::GpuShapes;
use crate::{GpuContext, GpuError};

/// A buffer's initial contents, as the scene gives them.
struct Contents {
    states: Vec<BodyState>,
    statics: Vec<BodyConsts>,
    walls: Vec<WallRecord>,
    carried: Carried,
    status: [u32; status::LEN],
    snapshot_status: Vec<u32>,
    mesh: Vec<u32>,
}

/// The contacts carried from the world (a resumed run): the old list that the first
/// rebuild carries springs from, padded to the pair capacity, and the wall slots.
struct Carried {
    a_start: Vec<u32>,
    pairs: Vec<[u32; 2]>,
    hist: Vec<[f32; 4]>,
    wall_hist: Vec<[f32; 4]>,
    wall_forces: Vec<WallForce>,
}

impl GpuWorld {
    /// Uploads `world` (bodies, shapes, materials, walls and its contact springs) and builds
    /// the pipeline. Fails with a clear error when the scene does not fit the adapter.
    pub fn new(ctx: Arc<GpuContext>, world: &World) -> Result<GpuWorld, GpuError> {
        check_composites(&ctx, world)?;
        let wall_slots = world.walls.len() as u32 * world.max_pieces() as u32;
        let (shapes, mesh_base) =
            GpuShapes::upload_with_meshes(&ctx, &world.shapes, &world.boundaries)?;
        let state = world.contact_state();
        let capacity = (world.len() as u64 * PAIRS_PER_BODY)
            .max(state.pairs.len() as u64 + world.len() as u64)
            .max(1024);
        let mut params = scene_params(world, capacity, mesh_base);
        params.deal = ctx.workgroup_runs();
        params.poly_lanes = crate::pipeline::poly_lanes_from_env(ctx.is_software());
        let dims = dims_of(world, &params, capacity);
        // Every buffer within the device's limits before any is allocated.
        let too_large = |e: crate::buffers::Oversize| e.into_error(&ctx.adapter_name());
        crate::buffers::check_sizes(&ctx.limits, &dims).map_err(too_large)?;
        Self::check_fits(&ctx, world.len() as u64, capacity, wall_slots as u64)?;
        check_mesh_fits(&ctx, world)?;
        let compiled = Compiled::get(&ctx)?;
        let contents = Contents::of(world, &state, capacity, wall_slots);
        let bufs = contents
            .upload(&ctx.device, &dims, &params, world)
            .map_err(too_large)?;
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
            n: world.len() as u32,
            wall_slots,
            params,
            shapes,
            gpu_steps: 0,
            base_step: world.step_count,
            base_time: world.time,
            base_rebuilds: world.rebuilds,
            dt: world.dt,
            last_status: contents.status,
            health: None,
            samples: Vec::new(),
        };
        w.ctx.wait()?;
        Ok(w)
    }
}

/// Refuses scenes with composites whose body indices do not leave room for a piece id.
fn check_composites(ctx: &GpuContext, world: &World) -> Result<(), GpuError> {
    if world.has_composites() && world.len() as u64 > crate::shapes::MAX_COMPOSITE_BODIES {
        return Err(GpuError::TooLarge {
            adapter: ctx.adapter_name(),
            what: "bodies of a scene with composites (pair entries keep a piece id in the top 6 bits of a 32-bit body index)".into(),
            need: format!("{} bodies", world.len()),
            limit: format!("{} bodies", crate::shapes::MAX_COMPOSITE_BODIES),
            advice: "use fewer bodies, or --backend cpu".into(),
        });
    }
    Ok(())
}

/// Refuses scenes whose mesh contact slots do not fit one storage buffer.
fn check_mesh_fits(ctx: &GpuContext, world: &World) -> Result<(), GpuError> {
    let words = crate::mesh::state_words(world.len() as u64, world.boundaries.len() as u64);
    let mesh_bytes = Buf::Mesh.bytes(words);
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
    Ok(())
}

/// The step's parameters for `world` (`num_args` is set by [`Plan::new`]).
fn scene_params(world: &World, capacity: u64, mesh_base: u32) -> Params {
    let n = world.len() as u32;
    let rmax = world.consts.max_radius();
    Params {
        gravity: [world.gravity.x, world.gravity.y, world.gravity.z, 0.0],
        n,
        num_walls: world.walls.len() as u32,
        num_materials: world.materials.len() as u32,
        pair_capacity: capacity as u32,
        dt: world.dt,
        skin: world.skin,
        half_skin2: 0.25 * world.skin * world.skin,
        min_cell: 2.0 * rmax + world.skin,
        max_cells: max_cells(n as u64) as u32,
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
        max_pieces: world.max_pieces() as u32,
        composites: world.has_composites() as u32,
        num_boundaries: world.boundaries.len() as u32,
        mesh_base,
        full_test: full_test_only() as u32,
        ..Default::default()
    }
}

/// Whether `CLATTER_GPU_FULL_TEST` is set (to anything but empty or `0`): touching
/// polyhedron pairs then ignore their remembered contact ([`Params::full_test`]).
fn full_test_only() -> bool {
    std::env::var_os("CLATTER_GPU_FULL_TEST").is_some_and(|v| !v.is_empty() && v != "0")
}

/// The sizes to allocate the buffers for (counted in 64 bits from the scene, not from
/// `params`' 32-bit fields, so that a scene too large for those is refused by size).
fn dims_of(world: &World, params: &Params, capacity: u64) -> Dims {
    Dims {
        bodies: world.len() as u64,
        cells: max_cells(world.len() as u64),
        pairs: capacity,
        materials: world.materials.len() as u64,
        walls: params.num_walls as u64,
        sinks: world.sinks.len() as u64,
        pieces: params.max_pieces as u64,
        composites: params.composites != 0,
        boundaries: params.num_boundaries as u64,
    }
}

impl Contents {
    /// What the scene puts in the buffers, contacts `state` carried over.
    fn of(world: &World, state: &ContactState, capacity: u64, wall_slots: u32) -> Contents {
        let mut st = [0u32; status::LEN];
        st[status::REBUILD] = 1;
        st[status::BAD_BODY] = u32::MAX;
        // The snapshot's HEALTH word is never 1 once a snapshot was taken (it is taken only
        // from a running pipeline): 1 marks "none yet".
        let mut snap_st = vec![0u32; crate::layout::snapshot::STATUS as usize];
        snap_st[status::HEALTH] = 1;
        Contents {
            states: (0..world.len()).map(|i| world.state.record(i)).collect(),
            statics: (0..world.len()).map(|i| world.consts.record(i)).collect(),
            walls: wall_records(world),
            carried: Carried::of(world, state, capacity, wall_slots),
            status: st,
            snapshot_status: snap_st,
            mesh: crate::mesh::initial_state(world),
        }
    }

    /// Allocates the buffers for `dims` with these contents (the others zeroed), or names
    /// the first buffer larger than the device allows.
    fn upload(
        &self,
        device: &wgpu::Device,
        dims: &Dims,
        params: &Params,
        world: &World,
    ) -> Result<Buffers, crate::buffers::Oversize> {
        let table = world.materials.table();
        let c = &self.carried;
        let bytes = |b: &[u8]| Some(b.to_vec());
        Buffers::new(device, dims, |b| match b {
            Buf::Params => bytes(bytemuck::bytes_of(params)),
            Buf::Bodies => bytes(bytemuck::cast_slice(&self.states)),
            Buf::Statics => bytes(bytemuck::cast_slice(&self.statics)),
            Buf::PairTable => bytes(bytemuck::cast_slice(table)),
            Buf::Walls => bytes(bytemuck::cast_slice(&self.walls)),
            Buf::Status => bytes(bytemuck::cast_slice(&self.status)),
            Buf::AStart => bytes(bytemuck::cast_slice(&c.a_start)),
            Buf::Pairs => bytes(bytemuck::cast_slice(&c.pairs)),
            Buf::Hist => bytes(bytemuck::cast_slice(&c.hist)),
            Buf::WallHist => bytes(bytemuck::cast_slice(&c.wall_hist)),
            Buf::WallForces => bytes(bytemuck::cast_slice(&c.wall_forces)),
            Buf::Snapshot => bytes(bytemuck::cast_slice(&self.snapshot_status)),
            Buf::Mesh => bytes(bytemuck::cast_slice(&self.mesh)),
            _ => None,
        })
    }
}

/// The walls, then each sink's corners (min, max) as two records.
fn wall_records(world: &World) -> Vec<WallRecord> {
    let mut walls: Vec<WallRecord> = world.walls.iter().map(WallRecord::from).collect();
    for k in &world.sinks {
        for c in [k.min, k.max] {
            walls.push(WallRecord {
                plane: [c.x, c.y, c.z, 0.0],
                ..Default::default()
            });
        }
    }
    walls
}

impl Carried {
    /// The pair list and springs of `state`, with room for `capacity` pairs, and its
    /// `wall_slots` slots per body.
    fn of(world: &World, state: &ContactState, capacity: u64, wall_slots: u32) -> Carried {
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
        let mut pairs = encode_pairs(state, world.has_composites());
        hist.resize(capacity as usize, [0.0; 4]);
        pairs.resize(capacity as usize, [0, 0]);
        let nslots = (world.len() as u64 * wall_slots as u64) as usize;
        let wall_hist: Vec<[f32; 4]> = (0..nslots)
            .map(|k| {
                let h = state.wall_history[k];
                [h.x, h.y, h.z, state.wall_twist[k]]
            })
            .collect();
        let wall_forces: Vec<WallForce> = state
            .wall_forces
            .iter()
            .zip(&state.wall_touching)
            .map(|(f, &t)| WallForce::new(f, t))
            .collect();
        Carried {
            a_start,
            pairs,
            hist,
            wall_hist,
            wall_forces,
        }
    }
}

/// The pair list of `state` as the GPU keeps it: with composites each word carries its
/// body's piece id above the body index (the inverse of `decode_pairs`).
fn encode_pairs(state: &ContactState, composites: bool) -> Vec<[u32; 2]> {
    if state.pieces.len() == state.pairs.len() && composites {
        let shift = crate::shapes::PIECE_SHIFT;
        (state.pairs.iter().zip(&state.pieces))
            .map(|(&[i, j], &code)| {
                let (a, b) = clatter::contact_list::piece_ids(code);
                [i | (a << shift), j | (b << shift)]
            })
            .collect()
    } else {
        state.pairs.clone()
    }
}

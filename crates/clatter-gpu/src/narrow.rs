//! The narrow phase on the GPU: `shaders/contacts/narrow.wgsl` ports clatter-geom's
//! [`narrow::collide`](clatter_geom::narrow::collide) and
//! [`narrow::collide_plane`](clatter_geom::narrow::collide_plane) to WGSL functions that the
//! step pipeline's per-pair kernels call; this module also runs them on batches of queries
//! (for tests, and as a public batch query API).
//!
//! A kernel that calls `collide` concatenates [`COMMON_WGSL`], [`NARROW_WGSL`] and its own
//! source, and binds the shapes ([`GpuShapes`]) as bind group 1.

use bytemuck::{Pod, Zeroable};
use clatter_geom::Pose;
use clatter_geom::narrow::{ContactPoint, Manifold, NO_HINT, Plane, SatHint};
use glam::Vec3;

use crate::shapes::GpuShapes;
use crate::{GpuContext, GpuError};

/// Shared shader code (quaternions, body state).
pub const COMMON_WGSL: &str = include_str!("../shaders/common/common.wgsl");
/// The narrow phase's WGSL: `collide`, `collide_plane`, `shape_is_sphere`, `shape_radius`,
/// the `Manifold` struct and the group-1 shape bindings. Goes after [`COMMON_WGSL`].
pub const NARROW_WGSL: &str = concat!(
    include_str!("../shaders/contacts/narrow.wgsl"),
    include_str!("../shaders/contacts/narrow_poly.wgsl")
);
const BATCH_WGSL: &str = include_str!("../shaders/test/narrow_batch.wgsl");
/// Invocations per workgroup of the batch kernel (`BATCH_WG` in `narrow_batch.wgsl`).
const BATCH_WG: u32 = 64;

/// A WGSL `Manifold` as stored in a buffer (80 bytes): normal, point count (0 = no
/// contact), four points with the depth in `w`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct GpuManifold {
    pub normal: [f32; 3],
    pub count: u32,
    pub points: [[f32; 4]; 4],
}

impl GpuManifold {
    /// The CPU's manifold type (count 0 when there is no contact).
    pub fn to_manifold(&self) -> Manifold {
        let mut m = Manifold {
            normal: Vec3::from_array(self.normal),
            count: (self.count as usize).min(4),
            ..Default::default()
        };
        for (dst, p) in m.points.iter_mut().zip(&self.points).take(m.count) {
            *dst = ContactPoint {
                point: Vec3::new(p[0], p[1], p[2]),
                depth: p[3],
            };
        }
        m
    }
}

/// The batch kernel's query record (`NarrowQuery` in `narrow_batch.wgsl`), 80 bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
struct QueryRecord {
    xa: [f32; 4],
    qa: [f32; 4],
    xb: [f32; 4],
    qb: [f32; 4],
    shapes: [u32; 4],
}

/// A pair query: shape `shape_a` (index into the uploaded shapes) at `pose_a` against shape
/// `shape_b` at `pose_b`, poses of the principal frames as the simulator stores them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NarrowQuery {
    pub shape_a: u32,
    pub pose_a: Pose,
    pub shape_b: u32,
    pub pose_b: Pose,
}

/// What a touching polyhedron pair remembers of its contact between steps, as the step
/// pipeline keeps it per pair: the contact hint (the CPU's
/// [`SatHint`] of a touching pair, see [`clatter_geom::narrow::collide_with_hint`]) and its
/// margin. Before a query, the caller takes from `margin` twice a bound of how much any
/// axis's separation can have moved since the last query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairMemory {
    /// The remembered contact, [`NO_HINT`] for none.
    pub hint: SatHint,
    /// Its margin (meaningless without a hint).
    pub margin: f32,
}

impl Default for PairMemory {
    fn default() -> Self {
        PairMemory {
            hint: NO_HINT,
            margin: 0.0,
        }
    }
}

/// A wall query: shape `shape` at `pose` against `plane`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneQuery {
    pub plane: Plane,
    pub shape: u32,
    pub pose: Pose,
}

fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// The compiled batch kernel; build once and reuse to avoid recompiling the shader.
pub struct NarrowBatch {
    pipeline: wgpu::ComputePipeline,
    io_layout: wgpu::BindGroupLayout,
    shape_layout: wgpu::BindGroupLayout,
}

impl NarrowBatch {
    /// Compiles `common.wgsl + narrow.wgsl + narrow_batch.wgsl`.
    pub fn new(ctx: &GpuContext) -> Result<NarrowBatch, GpuError> {
        let constants = clatter::contract::wgsl_constants(clatter::contract::PAIR_MEMORY_CONSTANTS);
        let source = format!("{constants}\n{COMMON_WGSL}\n{NARROW_WGSL}\n{BATCH_WGSL}");
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("narrow_batch"),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let io_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("narrow_batch io"),
                entries: &[storage(0, true), storage(1, false), storage(2, false)],
            });
        let shape_layout = GpuShapes::create_layout(ctx);
        let layout = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("narrow_batch"),
                bind_group_layouts: &[Some(&io_layout), Some(&shape_layout)],
                immediate_size: 0,
            });
        let pipeline = ctx
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("narrow_batch"),
                layout: Some(&layout),
                module: &module,
                entry_point: Some("narrow_batch"),
                compilation_options: Default::default(),
                cache: None,
            });
        ctx.wait()?;
        Ok(NarrowBatch {
            pipeline,
            io_layout,
            shape_layout,
        })
    }

    /// Pair queries; see [`collide_batch`].
    pub fn collide(
        &self,
        ctx: &GpuContext,
        shapes: &GpuShapes,
        queries: &[NarrowQuery],
    ) -> Result<Vec<Manifold>, GpuError> {
        let mut memory = vec![PairMemory::default(); queries.len()];
        self.collide_remembering(ctx, shapes, queries, &mut memory)
    }

    /// Pair queries with what each pair remembers (`memory[k]` for `queries[k]`, read and
    /// updated as the step pipeline does for a touching pair): the WGSL `collide` with the
    /// remembered contact tried first.
    pub fn collide_remembering(
        &self,
        ctx: &GpuContext,
        shapes: &GpuShapes,
        queries: &[NarrowQuery],
        memory: &mut [PairMemory],
    ) -> Result<Vec<Manifold>, GpuError> {
        assert_eq!(memory.len(), queries.len(), "one memory per query");
        let mut records = Vec::with_capacity(queries.len());
        for (i, q) in queries.iter().enumerate() {
            check_shape(i, q.shape_a, shapes)?;
            check_shape(i, q.shape_b, shapes)?;
            records.push(QueryRecord {
                xa: v4(q.pose_a.position, 0.0),
                qa: q.pose_a.rotation.to_array(),
                xb: v4(q.pose_b.position, 0.0),
                qb: q.pose_b.rotation.to_array(),
                shapes: [q.shape_a, q.shape_b, 0, 0],
            });
        }
        let mut words: Vec<[u32; 2]> = memory
            .iter()
            .map(|m| [m.hint, m.margin.to_bits()])
            .collect();
        let out = self.run(ctx, shapes, &records, &mut words)?;
        for (m, w) in memory.iter_mut().zip(&words) {
            *m = PairMemory {
                hint: w[0],
                margin: f32::from_bits(w[1]),
            };
        }
        Ok(out)
    }

    /// Wall queries; see [`collide_plane_batch`].
    pub fn collide_plane(
        &self,
        ctx: &GpuContext,
        shapes: &GpuShapes,
        queries: &[PlaneQuery],
    ) -> Result<Vec<Manifold>, GpuError> {
        let mut records = Vec::with_capacity(queries.len());
        for (i, q) in queries.iter().enumerate() {
            check_shape(i, q.shape, shapes)?;
            records.push(QueryRecord {
                xa: v4(q.plane.normal, q.plane.offset),
                qa: [0.0; 4],
                xb: v4(q.pose.position, 0.0),
                qb: q.pose.rotation.to_array(),
                shapes: [q.shape, 0, 1, 0],
            });
        }
        let mut words = vec![[NO_HINT, 0]; records.len()];
        self.run(ctx, shapes, &records, &mut words)
    }

    /// Runs the records (with their pair memory words, updated) in chunks that fit the
    /// adapter's buffer and dispatch limits.
    fn run(
        &self,
        ctx: &GpuContext,
        shapes: &GpuShapes,
        records: &[QueryRecord],
        memory: &mut [[u32; 2]],
    ) -> Result<Vec<Manifold>, GpuError> {
        let rec = std::mem::size_of::<QueryRecord>() as u64;
        let out = std::mem::size_of::<GpuManifold>() as u64;
        let byte_limit = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        let max_dim = ctx.limits.max_compute_workgroups_per_dimension as u64;
        let per_chunk = (byte_limit / rec.max(out))
            .min(max_dim * max_dim * BATCH_WG as u64)
            .min(u32::MAX as u64);
        if per_chunk == 0 {
            return Err(GpuError::TooLarge {
                adapter: ctx.adapter_name(),
                what: "storage buffer binding size".into(),
                need: format!("{} bytes", rec.max(out)),
                limit: format!("{byte_limit} bytes"),
                advice: "use an adapter with larger buffers".into(),
            });
        }
        let shape_group = shapes.bind_group(ctx, &self.shape_layout);
        let mut result = Vec::with_capacity(records.len());
        let chunks = records.chunks(per_chunk as usize);
        for (chunk, mem) in chunks.zip(memory.chunks_mut(per_chunk as usize)) {
            result.extend(self.run_chunk(ctx, &shape_group, chunk, mem, max_dim)?);
        }
        Ok(result)
    }

    fn run_chunk(
        &self,
        ctx: &GpuContext,
        shape_group: &wgpu::BindGroup,
        records: &[QueryRecord],
        memory: &mut [[u32; 2]],
        max_dim: u64,
    ) -> Result<Vec<Manifold>, GpuError> {
        use wgpu::util::DeviceExt;
        let n = records.len() as u64;
        let out_bytes = n * std::mem::size_of::<GpuManifold>() as u64;
        let input = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("narrow queries"),
                contents: bytemuck::cast_slice(records),
                usage: wgpu::BufferUsages::STORAGE,
            });
        let output = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("narrow manifolds"),
            size: out_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mem_bytes = n * 8;
        let mem_buf = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("narrow pair memory"),
                contents: bytemuck::cast_slice(memory),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            });
        // One staging buffer: the manifolds, then the memory words.
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("narrow readback"),
            size: out_bytes + mem_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let io_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("narrow_batch io"),
            layout: &self.io_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: input.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: output.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: mem_buf.as_entire_binding(),
                },
            ],
        });
        // 2D dispatch when the groups exceed one dimension's limit; the kernel linearises
        // (y * groups_x + x) and skips indices past the end.
        let groups = n.div_ceil(BATCH_WG as u64);
        let gx = groups.min(max_dim);
        let gy = groups.div_ceil(gx);
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("narrow_batch"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("narrow_batch"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &io_group, &[]);
            pass.set_bind_group(1, shape_group, &[]);
            pass.dispatch_workgroups(gx as u32, gy as u32, 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &staging, 0, out_bytes);
        encoder.copy_buffer_to_buffer(&mem_buf, 0, &staging, out_bytes, mem_bytes);
        ctx.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        ctx.wait()?;
        let runtime = |message: String| GpuError::Runtime {
            adapter: ctx.adapter_name(),
            message,
        };
        rx.recv()
            .map_err(|e| runtime(format!("readback callback lost: {e}")))?
            .map_err(|e| runtime(format!("readback failed: {e}")))?;
        let manifolds = {
            let view = staging
                .slice(..)
                .get_mapped_range()
                .map_err(|e| runtime(format!("readback failed: {e}")))?;
            let (ms, words) = view.split_at(out_bytes as usize);
            memory.copy_from_slice(bytemuck::cast_slice(words));
            bytemuck::cast_slice::<u8, GpuManifold>(ms)
                .iter()
                .map(GpuManifold::to_manifold)
                .collect()
        };
        staging.unmap();
        Ok(manifolds)
    }
}

fn check_shape(query: usize, shape: u32, shapes: &GpuShapes) -> Result<(), GpuError> {
    if (shape as usize) < shapes.count {
        Ok(())
    } else {
        Err(GpuError::Unsupported(format!(
            "query {query} names shape {shape} but only {} shapes were uploaded",
            shapes.count
        )))
    }
}

/// Runs `queries` through the WGSL `collide` (one invocation each) and reads the manifolds
/// back, in query order; a manifold with `count == 0` means no contact (the CPU's `None`).
/// Compiles the kernel on each call: hold a [`NarrowBatch`] to run many batches.
pub fn collide_batch(
    ctx: &GpuContext,
    shapes: &GpuShapes,
    queries: &[NarrowQuery],
) -> Result<Vec<Manifold>, GpuError> {
    if queries.is_empty() {
        return Ok(Vec::new());
    }
    NarrowBatch::new(ctx)?.collide(ctx, shapes, queries)
}

/// Runs `queries` through the WGSL `collide_plane`; as [`collide_batch`].
pub fn collide_plane_batch(
    ctx: &GpuContext,
    shapes: &GpuShapes,
    queries: &[PlaneQuery],
) -> Result<Vec<Manifold>, GpuError> {
    if queries.is_empty() {
        return Ok(Vec::new());
    }
    NarrowBatch::new(ctx)?.collide_plane(ctx, shapes, queries)
}

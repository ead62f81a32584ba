//! A turning mesh boundary's pose on the GPU (`shaders/common/turn.wgsl`) on a batch of
//! queries, so that tests can hold it bitwise against its twin, `clatter::turn`.

use bytemuck::Zeroable;
use glam::{Quat, Vec3};
use wgpu::util::DeviceExt;

use crate::layout::Params;
use crate::{GpuContext, GpuError};

/// One query: a rotation's axis, rate and centre, and the motion's elapsed time.
#[derive(Debug, Clone, Copy)]
pub struct TurnQuery {
    /// Unit axis.
    pub axis: Vec3,
    /// Rate, rad/s (> 0).
    pub rate: f32,
    /// A point on the axis.
    pub centre: Vec3,
    /// Elapsed time as a double-single `(hi, lo)`.
    pub u: (f32, f32),
    /// An argument for `turn_sin_cos` alone, in `[0, 4)`.
    pub x: f32,
}

/// The GPU's answer to a [`TurnQuery`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnAnswer {
    /// `turn_angle(rate, u)`.
    pub angle: f32,
    /// The pose's rotation and translation at that angle (`turn_pose`).
    pub rotation: Quat,
    pub translation: Vec3,
    /// `turn_sin_cos(x)`.
    pub sin_cos: (f32, f32),
}

/// Runs `turn.wgsl`'s `turn_angle`, `turn_pose` and `turn_sin_cos` on every query.
pub fn turn_batch(ctx: &GpuContext, queries: &[TurnQuery]) -> Result<Vec<TurnAnswer>, GpuError> {
    if queries.is_empty() {
        return Ok(Vec::new());
    }
    let source = crate::pipeline::source(&[include_str!("../shaders/test/turn_batch.wgsl")]);
    let device = &ctx.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("turn batch"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("turn_batch"),
        layout: None,
        module: &module,
        entry_point: Some("turn_batch"),
        compilation_options: Default::default(),
        cache: None,
    });
    let records: Vec<[f32; 12]> = queries
        .iter()
        .map(|q| {
            [
                q.axis.x, q.axis.y, q.axis.z, q.rate, q.centre.x, q.centre.y, q.centre.z, 0.0,
                q.u.0, q.u.1, q.x, 0.0,
            ]
        })
        .collect();
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("turn queries"),
        contents: bytemuck::cast_slice(&records),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let params = Params {
        one: 1.0,
        ..Params::zeroed()
    };
    let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("turn params"),
        contents: bytemuck::bytes_of(&params),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let out_size = (queries.len() * 12 * 4) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("turn answers"),
        size: out_size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("turn batch"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 90,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 91,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((queries.len() as u32).div_ceil(64), 1, 1);
    }
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Runtime {
            adapter: ctx.adapter_name(),
            message: format!("turn batch: {e}"),
        });
    }
    let bytes = crate::readback::read_buffers_after(ctx, encoder, &[(&output, 0, out_size)])?;
    let words: Vec<[f32; 12]> = bytemuck::pod_collect_to_vec(&bytes[0]);
    Ok(words
        .iter()
        .map(|w| TurnAnswer {
            angle: w[7],
            rotation: Quat::from_xyzw(w[0], w[1], w[2], w[3]),
            translation: Vec3::new(w[4], w[5], w[6]),
            sin_cos: (w[8], w[9]),
        })
        .collect())
}

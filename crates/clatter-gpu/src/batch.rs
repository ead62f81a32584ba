//! One compute pass over a batch of query records, for the test harnesses that hold a WGSL
//! function against its Rust twin (`law`, `turn`): compile, bind, dispatch one thread per
//! query, read the answers back, with validation errors turned into [`GpuError`]s.

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use crate::{GpuContext, GpuError};

/// Where a batch shader finds its buffers (group 0): the query records, the answer records,
/// and optionally a uniform at its own binding.
pub(crate) struct BatchBindings<'a> {
    pub input: u32,
    pub output: u32,
    pub uniform: Option<(u32, &'a [u8])>,
}

/// Runs `entry` of `source` once per record of `queries` (workgroups of 64) and returns one
/// answer record `A` per query. `label` names the pass in errors.
pub(crate) fn run_batch<Q: Pod, A: Pod>(
    ctx: &GpuContext,
    label: &str,
    source: String,
    entry: &str,
    queries: &[Q],
    bindings: BatchBindings<'_>,
) -> Result<Vec<A>, GpuError> {
    if queries.is_empty() {
        return Ok(Vec::new());
    }
    let device = &ctx.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    });
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::cast_slice(queries),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let out_size = (queries.len() * std::mem::size_of::<A>()) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: out_size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let uniform = bindings.uniform.map(|(binding, bytes)| {
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        (binding, buffer)
    });
    let mut entries = vec![
        wgpu::BindGroupEntry {
            binding: bindings.input,
            resource: input.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: bindings.output,
            resource: output.as_entire_binding(),
        },
    ];
    if let Some((binding, buffer)) = &uniform {
        entries.insert(
            0,
            wgpu::BindGroupEntry {
                binding: *binding,
                resource: buffer.as_entire_binding(),
            },
        );
    }
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
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
            message: format!("{label}: {e}"),
        });
    }
    let bytes = crate::readback::read_buffers_after(ctx, encoder, &[(&output, 0, out_size)])?;
    Ok(bytemuck::pod_collect_to_vec(&bytes[0]))
}

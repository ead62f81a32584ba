//! The device's measured memory bandwidth, for the bandwidth floor of the step (docs/gpu.md,
//! "Benchmarks"): the bytes a step must move over this bandwidth is the floor the step's time
//! is compared with (`clatter bench --profile` prints both).

use crate::{GpuContext, GpuError};

const COPY: &str = r#"
@group(0) @binding(0) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> dst: array<vec4<f32>>;

@compute @workgroup_size(256)
fn copy(@builtin(global_invocation_id) g: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let stride = nwg.x * 256u;
    let len = arrayLength(&dst);
    for (var i = g.x; i < len; i += stride) {
        dst[i] = src[i];
    }
}
"#;

/// Workgroups of the copy kernel (a grid-stride loop covers the rest).
const GROUPS: u32 = 8192;

/// Measures the bandwidth of a device-to-device copy kernel (each byte read once and written
/// once) over buffers of up to 512 MiB (32 MiB on software adapters), far larger than any
/// GPU cache: bytes moved (read +
/// written) per second, the median of `reps` timed copies after one warm-up. Needs timestamp
/// queries.
pub fn copy_bandwidth(ctx: &GpuContext, reps: u32) -> Result<f64, GpuError> {
    let runtime = |message: String| GpuError::Runtime {
        adapter: ctx.adapter_name(),
        message,
    };
    if !ctx.timestamps {
        return Err(runtime(
            "the adapter has no timestamp queries, needed to time the copy".into(),
        ));
    }
    let limit = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    // Software adapters (lavapipe, llvmpipe) copy at memcpy speed on the CPU: a smaller
    // buffer keeps the measurement short there; it is only a correctness run anyway.
    let size = if ctx.is_software() {
        32u64 << 20
    } else {
        512u64 << 20
    };
    let bytes = size.min(limit) / 16 * 16;
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("bandwidth copy"),
        source: wgpu::ShaderSource::Wgsl(COPY.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("bandwidth copy"),
        layout: None,
        module: &module,
        entry_point: Some("copy"),
        compilation_options: Default::default(),
        cache: None,
    });
    let buffer = |label| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        })
    };
    let (src, dst) = (buffer("bandwidth src"), buffer("bandwidth dst"));
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("bandwidth"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: src.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: dst.as_entire_binding(),
            },
        ],
    });
    let reps = reps.max(1);
    let count = 2 * (reps + 1);
    let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
        label: Some("bandwidth"),
        ty: wgpu::QueryType::Timestamp,
        count,
    });
    let resolve = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("bandwidth resolve"),
        size: 8 * count as u64,
        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    for r in 0..=reps {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("bandwidth copy"),
            timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                query_set: &queries,
                beginning_of_pass_write_index: Some(2 * r),
                end_of_pass_write_index: Some(2 * r + 1),
            }),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(GROUPS, 1, 1);
    }
    encoder.resolve_query_set(&queries, 0..count, &resolve, 0);
    let stamps =
        crate::readback::read_buffers_after(ctx, encoder, &[(&resolve, 0, 8 * count as u64)])?;
    let stamps: Vec<u64> = bytemuck::pod_collect_to_vec(&stamps[0]);
    let period = ctx.queue.get_timestamp_period() as f64;
    // Skip the warm-up copy.
    let mut secs: Vec<f64> = (1..=reps as usize)
        .map(|r| stamps[2 * r + 1].saturating_sub(stamps[2 * r]) as f64 * period * 1e-9)
        .collect();
    secs.sort_by(f64::total_cmp);
    let median = secs[secs.len() / 2];
    if median <= 0.0 {
        return Err(runtime("the copy's timestamps did not advance".into()));
    }
    Ok(2.0 * bytes as f64 / median)
}

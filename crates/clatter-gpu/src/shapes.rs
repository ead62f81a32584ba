//! PLACEHOLDER: shape data on the GPU (spheres only) until the polyhedron narrow phase lands.

use wgpu::util::DeviceExt;

use crate::{GpuContext, GpuError};
use clatter_geom::{PreparedShape, Shape};

/// Shape data on the GPU, bound as group 1.
pub struct GpuShapes {
    info: wgpu::Buffer,
}

impl GpuShapes {
    /// Uploads `shapes`.
    pub fn upload(ctx: &GpuContext, shapes: &[PreparedShape]) -> Result<GpuShapes, GpuError> {
        let mut data = Vec::new();
        for (k, s) in shapes.iter().enumerate() {
            match &s.shape {
                Shape::Sphere { radius } => data.push([*radius, 1.0, 0.0, 0.0]),
                Shape::Polyhedron(_) => {
                    return Err(GpuError::Unsupported(format!("shape {k} is a polyhedron")));
                }
            }
        }
        let info = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("shape_info"),
                contents: bytemuck::cast_slice(&data),
                usage: wgpu::BufferUsages::STORAGE,
            });
        Ok(GpuShapes { info })
    }

    /// Layout entries of group 1.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }]
    }

    /// Bind group entries of group 1.
    pub fn bind_entries(&self) -> Vec<wgpu::BindGroupEntry<'_>> {
        vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: self.info.as_entire_binding(),
        }]
    }
}

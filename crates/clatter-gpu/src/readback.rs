//! Reading GPU buffers back to the host: several ranges in one transfer, and a submission
//! whose read-back is collected later (so the host can queue the next batch first).

use crate::{GpuContext, GpuError};

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
pub(crate) struct Pending {
    staging: Option<wgpu::Buffer>,
    at: Vec<(u64, u64)>,
    index: wgpu::SubmissionIndex,
}

impl Pending {
    /// Waits for the submission and copies the ranges out.
    pub(crate) fn wait(self, ctx: &GpuContext) -> Result<Vec<Vec<u8>>, GpuError> {
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
pub(crate) fn submit_read(
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

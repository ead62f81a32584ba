//! [`GpuWorld::profile`]: every kernel of the step timed with timestamp queries.

use super::GpuWorld;
use crate::GpuError;
use crate::buffers::Buf;
use crate::layout::{SPHERE_CLASSES, SPLIT_CLASSES, status};
use crate::pipeline::Dispatch;
use crate::readback::read_buffers_after;

/// Bytes of one timestamp.
const STAMP_BYTES: u64 = std::mem::size_of::<u64>() as u64;

/// What the full narrow phase ran in the last step of a scene with polyhedra: the pairs
/// `contacts_sat` left for it (the rest were proved apart or skipped by their gap), by the
/// path each was offered (its class in the list `contacts_place` orders). For profiling:
/// which part of the contact stage a pile's time goes to.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FullPhase {
    /// Pairs with a sphere body (`contacts_full_spheres`).
    pub with_sphere: u32,
    /// Polyhedron pairs sent to the whole separating-axis test (every pair with
    /// [`GpuWorld::set_full_test`]).
    pub full_tests: u32,
    /// Polyhedron pairs that touched at a remembered reference face: the face is clipped
    /// alone while its margin lasts, else the full test runs.
    pub remembered_faces: u32,
    /// Polyhedron pairs that touched at a remembered edge contact with margin left: the edge
    /// axes are searched alone, and the full test runs if the edge loses.
    pub remembered_edges: u32,
}

impl GpuWorld {
    /// [`FullPhase`] of the last step taken (as of the last status read, which every
    /// [`GpuWorld::step`] ends with); `None` in a sphere-only scene, whose one contact pass
    /// runs every pair. From the per-class status words, which after a step hold where each
    /// class's pairs end in the list `contacts_place` ordered (contacts_split.wgsl; classes
    /// by shape pair, then path: full test, remembered face, remembered edge contact).
    pub fn full_phase(&self) -> Option<FullPhase> {
        if self.params.spheres_only != 0 {
            return None;
        }
        let mut out = FullPhase::default();
        let mut start = 0u32;
        for k in 0..SPLIT_CLASSES {
            let end = self.last_status[status::CLASSES + k];
            let n = end.wrapping_sub(start);
            start = end;
            let count = if k < SPHERE_CLASSES {
                &mut out.with_sphere
            } else {
                match k % 3 {
                    0 => &mut out.full_tests,
                    1 => &mut out.remembered_faces,
                    _ => &mut out.remembered_edges,
                }
            };
            *count += n;
        }
        Some(out)
    }

    /// Times every kernel of the step with timestamp queries over `steps` steps (which are
    /// taken: the simulation advances): each dispatch in its own compute pass, so the
    /// numbers include no overlap between kernels. Returns `(kernel, milliseconds per step)`
    /// in pipeline order, the scan levels of the three prefix sums merged under `scan`.
    /// Needs the adapter's timestamp queries ([`GpuContext::timestamps`](crate::GpuContext::timestamps)); `clatter bench
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
            size: STAMP_BYTES * (per_step as u64 * chunk),
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
                    (&resolve, 0, STAMP_BYTES * q as u64),
                    (
                        &self.bufs[Buf::Status],
                        0,
                        Buf::Status.bytes(status::LEN as u64),
                    ),
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
}

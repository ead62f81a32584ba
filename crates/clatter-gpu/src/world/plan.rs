//! The recorded step of a world ([`Plan`]): bind groups, indirect dispatch arguments and
//! the dispatch lists that [`crate::stages::record`] gives, and how one dispatch is encoded.

use std::sync::Arc;

use wgpu::util::DeviceExt;

use crate::buffers::{Buf, Buffers, Group0};
use crate::layout::Params;
use crate::pipeline::{Compiled, ContactVariant, Dispatch, Group2, KernelSet, Kernels, Size};
use crate::shapes::GpuShapes;
use crate::stages::{self, Scans};
use crate::{GpuContext, GpuError};

/// Bytes of one indirect dispatch's arguments (x, y and z workgroup counts).
const ARGS_BYTES: u64 = std::mem::size_of::<[u32; 3]>() as u64;

/// The recorded step of a world: bind groups, dispatch arguments and the dispatch lists of
/// the full and the lean step (rebuilt when the pair buffers grow).
pub(super) struct Plan {
    pub(super) compiled: Arc<Compiled>,
    /// This world's contact kernels.
    contacts: ContactVariant,
    scans: Scans,
    /// Indirect dispatch arguments.
    args: wgpu::Buffer,
    group0: wgpu::BindGroup,
    /// The group 0 of `snapshot_state` (`buffers::Group0::Snapshot`).
    snapshot_group0: wgpu::BindGroup,
    group1: wgpu::BindGroup,
    args_group: wgpu::BindGroup,
    pub(super) ops: Vec<Dispatch>,
    pub(super) lean_ops: Vec<Dispatch>,
    /// With the checks on, the dispatches that end every step in place of the last one of
    /// `ops` and `lean_ops` (`end_step`): stages::health.
    pub(super) health_ops: Vec<Dispatch>,
}

impl Plan {
    /// Plans the scans, writes the argument template and `params.num_args`, binds the
    /// buffers and records the step (stages::record).
    pub(super) fn new(
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
            clip: ContactVariant::clip_points(shapes.longest_face, params.num_boundaries > 0),
            lanes: if spheres_only { 0 } else { params.poly_lanes },
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
        let (ops, lean_ops) = stages::record(&compiled.base, contacts, &scans, variant);
        let health_ops = stages::health::record(&compiled.base);
        // The health dispatches take the place of the last one, `end_step` (encode_steps).
        let end_step = compiled.base.index("end_step");
        for list in [&ops, &lean_ops] {
            assert!(
                list.last()
                    .is_some_and(|op| op.set == KernelSet::Base && op.pipeline == end_step),
                "a step's dispatches end with end_step"
            );
        }
        Ok(Plan {
            compiled: compiled.clone(),
            contacts: variant,
            group0: bufs.bind_group(device, &layouts[0], Group0::Shared),
            snapshot_group0: bufs.bind_group(device, &layouts[3], Group0::Snapshot),
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
    pub(super) fn kernels(&self, op: &Dispatch) -> &Kernels {
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
    pub(super) fn bind(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_bind_group(0, &self.group0, &[]);
        pass.set_bind_group(1, &self.group1, &[]);
    }

    /// Records one dispatch into `pass` (groups 0 and 1 already bound).
    pub(super) fn encode(&self, pass: &mut wgpu::ComputePass<'_>, op: &Dispatch) {
        let set = self.kernels(op);
        pass.set_pipeline(&set.pipelines[op.pipeline]);
        match set.group2[op.pipeline] {
            Group2::None => {}
            Group2::Args => pass.set_bind_group(2, &self.args_group, &[]),
            Group2::Scan => pass.set_bind_group(2, &self.scans.bind_groups[op.scan_level], &[]),
            Group2::Snapshot => pass.set_bind_group(0, &self.snapshot_group0, &[]),
        }
        match op.size {
            Size::Single => pass.dispatch_workgroups(1, 1, 1),
            Size::Indirect(slot) => {
                pass.dispatch_workgroups_indirect(&self.args, slot as u64 * ARGS_BYTES)
            }
        }
        if set.group2[op.pipeline] == Group2::Snapshot {
            // The shared group 0 back for the next kernel.
            self.bind(pass);
        }
    }
}

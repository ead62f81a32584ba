//! The blow-up checks on the GPU ([`GpuWorld::set_health`], `stages::health`): their set-up,
//! the alarm, the energy samples and the last good state kept on the device.

use glam::Vec3;

use clatter::contract::{BodyState, quat_of};
use clatter::{ContactForce, ContactState, World};

use super::readback::decode_pairs;
use super::{EnergySample, GpuWorld, Health, HealthSetup};
use crate::GpuError;
use crate::buffers::Buf;
use crate::layout::{HEALTH_LOG, HealthParams, HealthRecord, WallForce, status};
use crate::readback::read_buffers;

impl GpuWorld {
    /// Turns on the blow-up checks and energy samples on the GPU for a run starting from
    /// `world` (the world this was created from, at the same step): after every step the GPU
    /// checks what `clatter::health::Health::check` checks cheaply, and stops the pipeline
    /// when it finds something the host must look at ([`StepReport::alarm`](super::StepReport::alarm)); it keeps the
    /// last good state on the device ([`GpuWorld::read_last_good`]) and logs energy samples
    /// ([`GpuWorld::take_samples`]). Nothing of it comes back unless asked for.
    pub fn set_health(&mut self, world: &World, setup: HealthSetup) {
        let mut setup = setup;
        let check = setup.check_every.max(1);
        setup.snapshot_every = setup.snapshot_every.max(1).div_ceil(check) * check;
        // The centroid of the bodies as the reference of the potential energy.
        let n = world.len().max(1) as f64;
        let c = world
            .state
            .position
            .iter()
            .fold([0.0f64; 3], |a, p| [a[0] + p.x, a[1] + p.y, a[2] + p.z]);
        let reference = Vec3::new((c[0] / n) as f32, (c[1] / n) as f32, (c[2] / n) as f32);
        let mass: f64 = world.consts.mass.iter().map(|&m| m as f64).sum();
        let reference_energy = -mass * world.gravity.dot(reference) as f64;
        let base = |every: u64| {
            if every == 0 {
                0
            } else {
                (self.base_step % every) as u32
            }
        };
        let hp = HealthParams {
            reference: [reference.x, reference.y, reference.z, 0.0],
            check_every: setup.check_every as u32,
            energy_every: setup.energy_every as u32,
            snapshot_every: setup.snapshot_every as u32,
            base_check: base(setup.check_every),
            base_energy: base(setup.energy_every),
            base_snapshot: base(setup.snapshot_every),
            budget: (setup.budget - reference_energy) as f32,
            alarm_factor: setup.alarm_factor as f32,
            force_floor: setup.force_floor,
            overlap_limit: setup.overlap_limit,
            ..Default::default()
        };
        self.ctx
            .queue
            .write_buffer(&self.bufs[Buf::HealthParams], 0, bytemuck::bytes_of(&hp));
        self.health = Some(Health {
            setup,
            reference_energy,
        });
    }

    /// Lets the pipeline go on after an alarm that the host's own check found harmless. The
    /// cleared words are written ahead of the next submission (the queue keeps the order),
    /// so nothing waits for the GPU here.
    pub fn clear_alarm(&mut self) -> Result<(), GpuError> {
        let steps = self.last_status[status::STEPS];
        self.last_status[status::HEALTH] = 0;
        self.last_status[status::CHECKED] = steps;
        let words = [0u32, steps];
        // HEALTH and CHECKED are adjacent words.
        self.ctx.queue.write_buffer(
            &self.bufs[Buf::Status],
            Buf::Status.bytes(status::HEALTH as u64),
            bytemuck::cast_slice(&words),
        );
        Ok(())
    }

    /// The energy samples computed on the GPU since the last call, in step order.
    pub fn take_samples(&mut self) -> Vec<EnergySample> {
        std::mem::take(&mut self.samples)
    }

    /// The `new` samples before the `total`-th from a read-back of the log ring.
    pub(super) fn collect_samples(&mut self, log: &[u8], total: u32, new: u32) {
        let Some(h) = self.health else {
            return;
        };
        let records: Vec<HealthRecord> = bytemuck::pod_collect_to_vec(log);
        let new = new.min(HEALTH_LOG);
        for k in (0..new).rev() {
            let slot = (total.wrapping_sub(1 + k) % HEALTH_LOG) as usize;
            let r = records[slot];
            // The sample's GPU step count, from its low 32 bits.
            let back = (self.gpu_steps as u32).wrapping_sub(r.step) as u64;
            let g = self.gpu_steps.saturating_sub(back);
            self.samples.push(EnergySample {
                step: self.base_step + g,
                time: self.time_after(g),
                kinetic: r.sums[0] as f64,
                potential: r.sums[1] as f64 + h.reference_energy,
                momentum: [r.sums[2] as f64, r.sums[3] as f64, r.pz as f64],
            });
        }
    }

    /// The last good state kept on the device (see [`GpuWorld::set_health`]) into `world`
    /// (a copy of the world this was created from): bodies, step count, time and contacts.
    /// Returns false, leaving `world` alone, when no snapshot was taken yet.
    pub fn read_last_good(&self, world: &mut World) -> Result<bool, GpuError> {
        use crate::layout::snapshot as snap;
        let st: Vec<u32> = bytemuck::pod_collect_to_vec(&self.read_buffer(
            &self.bufs[Buf::Snapshot],
            0,
            Buf::Snapshot.bytes(snap::STATUS),
        )?);
        if st[status::HEALTH] != 0 {
            return Ok(false);
        }
        let (n, walls) = (self.n as u64, self.wall_slots as u64);
        let nb = self.params.num_boundaries as u64;
        let np = (st[status::PAIRS] as u64).min(self.params.pair_capacity as u64);
        let slots = n * walls;
        let b = |x: Buf| &self.bufs[x];
        let mut parts = read_buffers(
            &self.ctx,
            &[
                (b(Buf::Snapshot), 0, Buf::Snapshot.bytes(snap::words(n))),
                (b(Buf::SnapshotPairs), 0, Buf::SnapshotPairs.bytes(np)),
                (b(Buf::SnapshotForces), 0, Buf::SnapshotForces.bytes(np)),
                (
                    b(Buf::SnapshotWallHist),
                    0,
                    Buf::SnapshotWallHist.bytes(slots),
                ),
                (
                    b(Buf::SnapshotWallForces),
                    0,
                    Buf::SnapshotWallForces.bytes(slots),
                ),
                (
                    b(Buf::SnapshotMesh),
                    0,
                    Buf::SnapshotMesh.bytes(snap::mesh_words(n, nb)),
                ),
            ],
        )?
        .into_iter();
        let mut next = || parts.next().unwrap_or_default();
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&next());
        let pair_words: Vec<u32> = bytemuck::pod_collect_to_vec(&next());
        let forces: Vec<ContactForce> = bytemuck::pod_collect_to_vec(&next());
        let wall_hist: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&next());
        let wf: Vec<WallForce> = bytemuck::pod_collect_to_vec(&next());
        let mesh: Vec<u32> = bytemuck::pod_collect_to_vec(&next());
        let (wall_forces, wall_touching) = wf.iter().map(WallForce::split).unzip();
        let f4 = |w: &[u32], at: usize| -> [f32; 4] {
            std::array::from_fn(|k| f32::from_bits(w[at + k]))
        };
        let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        let body_at = |i: u64| (snap::STATUS + snap::BODY * i) as usize;
        for i in 0..n {
            let at = body_at(i);
            let s = BodyState {
                position: f4(&words, at),
                velocity: f4(&words, at + 4),
                orientation: f4(&words, at + 8),
                residual: f4(&words, at + 12),
                angular_momentum: f4(&words, at + 16),
                omega: f4(&words, at + 20),
                position_lo: f4(&words, at + 32),
            };
            world.state.set_record(i as usize, &s);
        }
        let pair_at = |k: u64| (snap::PAIR * k) as usize;
        let hist: Vec<[f32; 4]> = (0..np).map(|k| f4(&pair_words, pair_at(k) + 2)).collect();
        let (pairs, pieces) = decode_pairs(
            (0..np)
                .map(|k| [pair_words[pair_at(k)], pair_words[pair_at(k) + 1]])
                .collect(),
            self.params.composites != 0,
        );
        let state = ContactState {
            rebuild_position: if st[status::REBUILDS] > 0 {
                (0..n)
                    .map(|i| v3(f4(&words, body_at(i) + 24)).as_dvec3())
                    .collect()
            } else {
                Vec::new()
            },
            rebuild_orientation: if st[status::REBUILDS] > 0 && self.params.composites != 0 {
                (0..n)
                    .map(|i| quat_of(f4(&words, body_at(i) + 28)))
                    .collect()
            } else {
                Vec::new()
            },
            pairs,
            pieces,
            history: hist.iter().map(|&h| v3(h)).collect(),
            twist: hist.iter().map(|h| h[3]).collect(),
            touching: (0..np).map(|k| pair_words[pair_at(k) + 6] == 1).collect(),
            forces,
            wall_history: wall_hist.iter().map(|&h| v3(h)).collect(),
            wall_twist: wall_hist.iter().map(|h| h[3]).collect(),
            wall_touching,
            wall_forces,
        };
        let back = (self.gpu_steps as u32).wrapping_sub(st[status::STEPS]) as u64;
        let g = self.gpu_steps.saturating_sub(back);
        world.step_count = self.base_step + g;
        world.rebuilds = self.base_rebuilds + st[status::REBUILDS] as u64;
        let mut t = self.base_time;
        for _ in 0..g {
            t += self.dt as f64;
        }
        world.time = t;
        world.set_contact_state(state);
        if nb > 0 {
            // The mesh slots and the step of their last rebuild, as `read_mesh_into`.
            let (slots, rebuild_step) = crate::mesh::read_slots(&mesh, n as usize, nb as usize);
            let back = st[status::STEPS].wrapping_sub(rebuild_step) as u64;
            let rebuild_time = self.time_after(g.saturating_sub(back));
            world
                .restore_mesh(slots, rebuild_time)
                .map_err(GpuError::Unsupported)?;
        }
        Ok(true)
    }
}

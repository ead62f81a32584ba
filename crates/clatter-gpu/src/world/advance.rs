//! [`GpuWorld::step`]: batches of steps recorded side by side and submitted in order, the
//! status read after each batch (a stopped pipeline, stalls, energy samples), and the pair
//! buffers grown when they overflow.

use std::collections::VecDeque;

use rayon::prelude::*;

use clatter::World;
use clatter::contract::BodyState;

use super::{BATCH, ENCODERS, GpuWorld, Plan, StepReport};
use crate::GpuError;
use crate::buffers::{Buf, Dims};
use crate::layout::{HEALTH_LOG, status};
use crate::readback::{Pending, submit_read};

/// A submitted batch: the pending read of its status (and of the bodies and the energy log
/// when asked for), whether the read brings the bodies, and the steps recorded in it.
type Batch = (Pending, bool, u64);

/// How the batches of one [`GpuWorld::advance`] stand.
struct Flight {
    /// The GPU step count to reach.
    target: u64,
    /// Batches in flight, oldest first.
    in_flight: VecDeque<Batch>,
    /// Steps in the batches submitted so far, as if none stalled.
    submitted: u64,
    /// Whether a batch must be submitted even with no steps left (the first, and the one
    /// after the pair buffers grew).
    first: bool,
    /// Whether the last batch brings the body state back.
    with_states: bool,
    /// The most batches in flight ([`in_flight_depth`]).
    depth: usize,
}

/// The most batches in flight: `2 * ENCODERS`, or [`IN_FLIGHT_VAR`](super::IN_FLIGHT_VAR)
/// when set to 2 or more (another value: the default, with a warning). New batches are recorded when half of them are left.
fn in_flight_depth() -> usize {
    crate::env::u32_choice(
        super::IN_FLIGHT_VAR,
        "a whole number of 2 or more",
        |d| d >= 2,
        2 * ENCODERS as u32,
    ) as usize
}

impl GpuWorld {
    /// Advances the simulation by `steps` steps on the GPU (no body state comes back).
    /// Returns the number of contacts touching in the last step.
    pub fn step(&mut self, steps: u64) -> Result<StepReport, GpuError> {
        self.advance(steps, None)
    }

    /// [`GpuWorld::step`], then the body state (not the contacts) into `world`, read in the
    /// same transfer as the step's status: the cheapest way to follow a simulation step by
    /// step (the viewer, tests). [`GpuWorld::read_into`] also brings the contacts.
    pub fn step_into(&mut self, steps: u64, world: &mut World) -> Result<StepReport, GpuError> {
        let mut states = Vec::new();
        let r = self.advance(steps, Some(&mut states))?;
        if states.len() != self.n as usize {
            // The pipeline stopped early (a non-finite body): the state it stopped at.
            states = self.read_states()?;
        }
        self.apply_states(&states, world);
        Ok(r)
    }

    /// Records `steps` steps into `encoder`. The first step is the full step; with `lean`,
    /// the others leave out the rebuild's dispatches (about 30, most of them sized zero on
    /// the GPU, but each costing the GPU and wgpu a few microseconds: more than the whole
    /// step of a 65,536-sphere pile). A lean step whose predecessor flagged a rebuild stops
    /// the pipeline (`prepare_lean`, status word STALL) until the first step of the next
    /// batch, a full one, which runs that step with the rebuild: the rebuilds happen at the
    /// same steps, and the results are the same, as if every step were full.
    fn encode_steps(&self, encoder: &mut wgpu::CommandEncoder, steps: u64, lean: bool) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("steps"),
            timestamp_writes: None,
        });
        self.plan.bind(&mut pass);
        let health = self.health.is_some();
        for k in 0..steps {
            let ops = if lean && k > 0 {
                &self.plan.lean_ops
            } else {
                &self.plan.ops
            };
            // With the checks on, their dispatches end the step in place of `end_step`
            // (its last dispatch): `end_step_gate` counts the step and sizes them.
            let (step, tail): (&[_], &[_]) = if health {
                (&ops[..ops.len() - 1], &self.plan.health_ops)
            } else {
                (ops, &[])
            };
            for op in step.iter().chain(tail) {
                self.plan.encode(&mut pass, op);
            }
        }
    }

    /// Takes `steps` steps, then (with `states`) reads the body state back with the last
    /// status.
    ///
    /// Batches are in flight: while the GPU runs some, the host records the next ones, so
    /// recording (a few microseconds per dispatch in wgpu) overlaps the GPU's work. A batch
    /// may do fewer steps than it holds: after a lean step stalls (a rebuild due, see
    /// `encode_steps`) the rest of its batch does nothing and the next batch, whose first
    /// step is full, runs that step again. So batches are sized for the steps still to do,
    /// and the host tops up until the GPU's step count reaches the target. A stopped
    /// pipeline (overflow, bad body) stops every batch behind it: those are drained before
    /// the host acts.
    fn advance(
        &mut self,
        steps: u64,
        mut states: Option<&mut Vec<BodyState>>,
    ) -> Result<StepReport, GpuError> {
        let mut f = Flight {
            target: self.gpu_steps + steps,
            in_flight: VecDeque::new(),
            submitted: self.gpu_steps,
            first: true,
            with_states: states.is_some(),
            depth: in_flight_depth(),
        };
        let mut guard = 0;
        loop {
            if f.in_flight.is_empty() {
                f.submitted = self.gpu_steps;
            }
            if f.in_flight.len() <= f.depth / 2 && (f.submitted < f.target || f.first) {
                self.submit_batches(&mut f)?;
            }
            let Some((pending, with_bodies, batch)) = f.in_flight.pop_front() else {
                break;
            };
            let parts = pending.wait(&self.ctx)?;
            let (st, done) = self.take_status(&parts, batch, f.target);
            if let Some(report) = self.check_stopped(&st, &mut f.in_flight)? {
                return Ok(report);
            }
            if st[status::OVERFLOW] != 0 {
                self.grow(st[status::PAIRS_NEEDED] as u64)?;
                guard += 1;
                if guard > 8 {
                    return Err(GpuError::Runtime {
                        adapter: self.ctx.adapter_name(),
                        message: "the pair list kept overflowing".into(),
                    });
                }
                f.first = true;
                continue;
            }
            if done < batch {
                self.note_stall();
            }
            if with_bodies
                && self.gpu_steps == f.target
                && let Some(out) = states.as_deref_mut()
            {
                *out = bytemuck::pod_collect_to_vec(&parts[1]);
            }
        }
        Ok(self.report(&self.last_status, None, false))
    }

    /// Records batches up to the depth in flight side by side on the CPU's threads, then
    /// submits them in order, each with the read of its status.
    fn submit_batches(&mut self, f: &mut Flight) -> Result<(), GpuError> {
        let mut sizes = Vec::new();
        let mut at = f.submitted;
        while f.in_flight.len() + sizes.len() < f.depth && (at < f.target || f.first) {
            f.first = false;
            let batch = (f.target - at).min(BATCH);
            let lean = self.lean_enabled && self.full_batches == 0;
            self.full_batches = self.full_batches.saturating_sub(1);
            sizes.push((batch, lean));
            at += batch;
        }
        let record = |&(batch, lean): &(u64, bool)| {
            let mut encoder =
                self.ctx
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("step"),
                    });
            if self.n > 0 {
                self.encode_steps(&mut encoder, batch, lean);
            }
            encoder
        };
        // With nothing in flight (the start of a call, after a stop) the GPU idles until
        // something is submitted: the first batch goes alone, the rest are recorded while
        // it runs. The same batches in the same order either way.
        let first = usize::from(f.in_flight.is_empty() && sizes.len() > 1);
        let mut encoders: Vec<wgpu::CommandEncoder> = sizes[..first].iter().map(record).collect();
        for (k, &(batch, _)) in sizes.iter().enumerate() {
            if k == first {
                encoders.extend(if sizes.len() - first > 1 {
                    sizes[first..].par_iter().map(record).collect::<Vec<_>>()
                } else {
                    sizes[first..].iter().map(record).collect()
                });
            }
            let encoder = encoders.remove(0);
            f.submitted += batch;
            // The status (and, with the last batch, the bodies) come back in one transfer.
            let last = f.submitted >= f.target;
            let body_bytes = if last && f.with_states {
                Buf::Bodies.bytes(self.n as u64)
            } else {
                0
            };
            let log_bytes = if self.health.is_some_and(|h| h.setup.energy_every > 0) {
                Buf::Health.bytes(HEALTH_LOG as u64)
            } else {
                0
            };
            let pending = submit_read(
                &self.ctx,
                encoder,
                &[
                    (
                        &self.bufs[Buf::Status],
                        0,
                        Buf::Status.bytes(status::LEN as u64),
                    ),
                    (&self.bufs[Buf::Bodies], 0, body_bytes),
                    (&self.bufs[Buf::Health], 0, log_bytes),
                ],
            )?;
            f.in_flight.push_back((pending, body_bytes > 0, batch));
        }
        Ok(())
    }

    /// The status words a batch read back (`parts[0]`; made up with no bodies), the step
    /// count and energy samples taken from them; returns them and the steps the batch did.
    fn take_status(
        &mut self,
        parts: &[Vec<u8>],
        batch: u64,
        target: u64,
    ) -> ([u32; status::LEN], u64) {
        let mut st = [0u32; status::LEN];
        st.copy_from_slice(&bytemuck::pod_collect_to_vec::<u8, u32>(&parts[0]));
        if self.n == 0 {
            st = self.last_status;
            st[status::STEPS] = st[status::STEPS].wrapping_add(batch as u32);
        }
        let done = st[status::STEPS].wrapping_sub(self.last_status[status::STEPS]) as u64;
        let new_samples = st[status::SAMPLES].wrapping_sub(self.last_status[status::SAMPLES]);
        self.gpu_steps = (self.gpu_steps + done).min(target);
        self.last_status = st;
        if new_samples > 0 && !parts[2].is_empty() {
            self.collect_samples(&parts[2], st[status::SAMPLES], new_samples);
        }
        (st, done)
    }

    /// What a stopped pipeline (status `st`) means: an error for a body that met more mesh
    /// triangles than the GPU keeps, the report of a non-finite body or an alarm, or `None`
    /// (running, or stopped by a pair overflow). The batches behind a stopped pipeline did
    /// nothing: they are drained first.
    fn check_stopped(
        &self,
        st: &[u32; status::LEN],
        in_flight: &mut VecDeque<Batch>,
    ) -> Result<Option<StepReport>, GpuError> {
        if st[status::MESH_FULL] != 0 {
            self.drain(in_flight)?;
            return Err(GpuError::Unsupported(format!(
                "body {} meets more mesh triangles or contacts than the GPU keeps per body ({} triangles within its reach, {} contacts per piece before the deepest {} are kept); run this scene with --backend cpu",
                st[status::MESH_FULL] - 1,
                crate::mesh::MAX_CANDIDATES,
                crate::mesh::MAX_FOUND,
                clatter::mesh_boundary::MESH_SLOTS
            )));
        }
        let bad = st[status::BAD_BODY] != u32::MAX;
        let alarm = st[status::HEALTH] != 0;
        if bad || st[status::OVERFLOW] != 0 || alarm {
            self.drain(in_flight)?;
        }
        Ok(if bad {
            Some(self.report(st, Some(st[status::BAD_BODY] as usize), false))
        } else if alarm {
            Some(self.report(st, None, true))
        } else {
            None
        })
    }

    /// Waits for every batch in flight.
    fn drain(&self, in_flight: &mut VecDeque<Batch>) -> Result<(), GpuError> {
        for (p, _, _) in in_flight.drain(..) {
            p.wait(&self.ctx)?;
        }
        Ok(())
    }

    /// The report of a step that ended with status `st`.
    fn report(&self, st: &[u32; status::LEN], bad_body: Option<usize>, alarm: bool) -> StepReport {
        StepReport {
            bad_body,
            touching: st[status::TOUCHING] as usize,
            steps_done: self.gpu_steps,
            alarm,
        }
    }

    /// A lean step stalled; the next batch ran it again. A scene that rebuilds every few
    /// steps (fast bodies) would stall every batch, so after two stalls close together the
    /// next batches are recorded in full.
    fn note_stall(&mut self) {
        if self.stalls > 0 && self.gpu_steps < self.last_stall + 4 * BATCH {
            self.full_batches = 2;
        }
        self.stalls += 1;
        self.last_stall = self.gpu_steps;
    }

    /// Grows the pair buffers to hold `needed` pairs (with room to spare), keeping the old
    /// list and springs, and lets the stopped step run again.
    fn grow(&mut self, needed: u64) -> Result<(), GpuError> {
        let capacity = (needed + needed / 2).max(self.params.pair_capacity as u64 * 2);
        Self::check_fits(&self.ctx, self.n as u64, capacity, self.wall_slots as u64)?;
        let device = &self.ctx.device;
        let dims = Dims {
            pairs: capacity,
            ..self.dims
        };
        let too_large = |e: crate::buffers::Oversize| e.into_error(&self.ctx.adapter_name());
        crate::buffers::check_sizes(&self.ctx.limits, &dims).map_err(too_large)?;
        let mut encoder = device.create_command_encoder(&Default::default());
        self.bufs
            .grow(device, &dims, &mut encoder)
            .map_err(too_large)?;
        self.dims = dims;
        // Resume: clear the overflow, ask for the rebuild again.
        let mut st = self.last_status;
        st[status::OVERFLOW] = 0;
        st[status::STALL] = 0;
        st[status::REBUILD] = 1;
        // The stopped step's rebuild was counted when it began (`bin.wgsl`); its run again
        // counts it once more: one rebuild, as on the CPU.
        st[status::REBUILDS] = st[status::REBUILDS].saturating_sub(1);
        self.ctx
            .queue
            .write_buffer(&self.bufs[Buf::Status], 0, bytemuck::cast_slice(&st));
        self.ctx.queue.submit([encoder.finish()]);
        self.params.pair_capacity = capacity as u32;
        self.plan = Plan::new(
            &self.ctx,
            &self.plan.compiled,
            &self.bufs,
            &self.shapes,
            &mut self.params,
        )?;
        self.last_status = st;
        self.ctx.wait()
    }
}

//! Back to the host: body state, the contact list with its springs and forces, the mesh
//! contact slots and the simulated time, into a [`clatter::World`]; and the stage buffers
//! for the tests.

use glam::Vec3;

use clatter::contract::{BodyState, quat_of};
use clatter::{ContactForce, ContactState, World};

use super::GpuWorld;
use crate::GpuError;
use crate::buffers::Buf;
use crate::layout::{WallForce, status};
use crate::readback::read_buffers;

impl GpuWorld {
    /// The body states.
    pub fn read_states(&self) -> Result<Vec<BodyState>, GpuError> {
        let bytes =
            self.read_buffer(&self.bufs[Buf::Bodies], 0, Buf::Bodies.bytes(self.n as u64))?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// Copies the body state, step count and time back into `world` (the world it was
    /// created from), not the contact list: what a caller that reads only the bodies needs.
    pub fn read_bodies_into(&self, world: &mut World) -> Result<(), GpuError> {
        let states = self.read_states()?;
        self.apply_states(&states, world);
        Ok(())
    }

    /// Copies the GPU state back into `world` (the world it was created from): body state,
    /// step count, time, and the contact list with its springs and forces, so outputs,
    /// health checks and checkpoints work on it as after CPU steps.
    pub fn read_into(&self, world: &mut World) -> Result<(), GpuError> {
        let states = self.read_states()?;
        self.apply_states(&states, world);
        self.read_contacts_into(world)
    }

    /// The contact list with its springs and forces, and the mesh contact slots, into
    /// `world` (whose bodies a caller has read already): everything of [`Self::read_into`]
    /// but the bodies. Without the mesh slots, a checkpoint written while a body touched a
    /// mesh boundary lost that contact's spring, and the counts missed it.
    pub fn read_contacts_into(&self, world: &mut World) -> Result<(), GpuError> {
        world.set_contact_state(self.contact_state()?);
        self.read_mesh_into(world)
    }

    /// The mesh contact slots and the time of the last rebuild into `world` (which then
    /// finds its mesh candidates as the CPU's rebuild did then).
    fn read_mesh_into(&self, world: &mut World) -> Result<(), GpuError> {
        let nb = world.boundaries.len();
        if nb == 0 {
            return Ok(());
        }
        let buf = &self.bufs[Buf::Mesh];
        let words: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.read_buffer(buf, 0, buf.size())?);
        let (slots, rebuild_step) = crate::mesh::read_slots(&words, self.n as usize, nb);
        let back = (self.gpu_steps as u32).wrapping_sub(rebuild_step) as u64;
        let rebuild_time = self.time_after(self.gpu_steps.saturating_sub(back));
        world
            .restore_mesh(slots, rebuild_time)
            .map_err(GpuError::Unsupported)
    }

    /// Body state, step count, time and broad-phase rebuild count into `world`.
    pub(super) fn apply_states(&self, states: &[BodyState], world: &mut World) {
        for (i, s) in states.iter().enumerate() {
            world.state.set_record(i, s);
        }
        world.step_count = self.base_step + self.gpu_steps;
        world.rebuilds = self.base_rebuilds + self.rebuilds();
        // The same sum as the CPU's `time += dt` per step, continued from the last call's.
        world.time = self.time_after(self.gpu_steps);
    }

    /// The contact list and springs (see [`ContactState`]).
    pub fn contact_state(&self) -> Result<ContactState, GpuError> {
        let st = &self.last_status;
        let b = |live: Buf| &self.bufs[live];
        let n = self.n as usize;
        let np = st[status::PAIRS] as usize;
        let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
        let ns = (n * self.wall_slots as usize) as u64;
        let (np, n) = (np as u64, n as u64);
        let composites = self.params.composites != 0;
        let rebuild_slots = if composites { 2 * n } else { n };
        let mut parts = read_buffers(
            &self.ctx,
            &[
                (b(Buf::Pairs), 0, Buf::Pairs.bytes(np)),
                (b(Buf::Hist), 0, Buf::Hist.bytes(np)),
                (b(Buf::Touching), 0, Buf::Touching.bytes(np)),
                (b(Buf::Forces), 0, Buf::Forces.bytes(np)),
                (b(Buf::WallHist), 0, Buf::WallHist.bytes(ns)),
                (b(Buf::WallForces), 0, Buf::WallForces.bytes(ns)),
                (b(Buf::RebuildPos), 0, Buf::RebuildPos.bytes(rebuild_slots)),
            ],
        )?
        .into_iter();
        let mut next = || parts.next().unwrap_or_default();
        let (pairs_bytes, hist_bytes, touch_bytes, force_bytes) = (next(), next(), next(), next());
        let (wh, wf, rb) = (next(), next(), next());
        let hist: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&hist_bytes);
        let wall_hist: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&wh);
        let forces: Vec<ContactForce> = bytemuck::pod_collect_to_vec(&force_bytes);
        let wf: Vec<WallForce> = bytemuck::pod_collect_to_vec(&wf);
        let (wall_forces, wall_touching) = wf.iter().map(WallForce::split).unzip();
        let rebuilt = st[status::REBUILDS] > 0;
        let rb: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&rb);
        let (pairs, pieces) = decode_pairs(bytemuck::pod_collect_to_vec(&pairs_bytes), composites);
        Ok(ContactState {
            rebuild_position: if rebuilt {
                rb.iter()
                    .take(n as usize)
                    .map(|&p| v3(p).as_dvec3())
                    .collect()
            } else {
                Vec::new()
            },
            rebuild_orientation: if rebuilt && composites {
                rb.iter().skip(n as usize).map(|&q| quat_of(q)).collect()
            } else {
                Vec::new()
            },
            pairs,
            pieces,
            history: hist.iter().map(|&h| v3(h)).collect(),
            twist: hist.iter().map(|h| h[3]).collect(),
            // 1 = touching; 0 and larger values (separating-axis hints) = not.
            touching: bytemuck::pod_collect_to_vec::<u8, u32>(&touch_bytes)
                .iter()
                .map(|&t| t == 1)
                .collect(),
            forces,
            wall_history: wall_hist.iter().map(|&h| v3(h)).collect(),
            wall_twist: wall_hist.iter().map(|h| h[3]).collect(),
            wall_touching,
            wall_forces,
        })
    }

    /// Reads a named stage buffer (for the stage-by-stage tests): `keys`, `sorted`,
    /// `cell_start`, `a_start`, `pairs`, `b_start`, `b_adj`, `forces`, `grid`, `status`,
    /// `mesh`, `touching`, `pair_memory`, `new_hist` (outside a rebuild: each pair's gap in
    /// `x`), `rebuild_pos` (each body's last motion bound in `w`).
    pub fn debug_buffer(&self, name: &str) -> Result<Vec<u8>, GpuError> {
        const STAGE_BUFFERS: &[&str] = &[
            "keys",
            "sorted",
            "cell_start",
            "a_start",
            "pairs",
            "b_start",
            "b_adj",
            "forces",
            "wall_forces",
            "grid",
            "status",
            "mesh",
            "touching",
            "pair_memory",
            "new_hist",
            "rebuild_pos",
        ];
        let Some(b) = STAGE_BUFFERS
            .contains(&name)
            .then(|| self.bufs.by_name(name))
            .flatten()
        else {
            return Err(GpuError::Unsupported(format!(
                "no stage buffer named {name}"
            )));
        };
        self.read_buffer(b, 0, b.size())
    }

    /// Overwrites the pair memory (`pair_memory`, two words per pair slot: hint, margin
    /// bits) from the start: for the test that words left in slots of pairs that do not
    /// touch (from an earlier contact, or another pair before a rebuild) change nothing.
    #[cfg(feature = "test-harness")]
    pub fn debug_write_pair_memory(&self, words: &[u32]) -> Result<(), GpuError> {
        let b = &self.bufs[Buf::PairMemory];
        let bytes: &[u8] = bytemuck::cast_slice(words);
        if bytes.len() as u64 > b.size() {
            return Err(GpuError::Unsupported(format!(
                "{} bytes of pair memory, the buffer holds {}",
                bytes.len(),
                b.size()
            )));
        }
        self.context().queue.write_buffer(b, 0, bytes);
        Ok(())
    }

    /// The simulated time after `g` GPU steps: the CPU's sum of `dt`, continued from the
    /// last call's when it can be.
    pub(super) fn time_after(&self, g: u64) -> f64 {
        let mut cache = self
            .time_sum
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let (mut k, mut t) = *cache;
        if k > g {
            (k, t) = (0, self.base_time);
        }
        while k < g {
            t += self.dt as f64;
            k += 1;
        }
        *cache = (k, t);
        t
    }
}

/// Pair-list entries read back from the GPU as body pairs and, with composites, the CPU's
/// piece codes (the GPU keeps each body's piece id above its index, see pieces.wgsl).
pub(super) fn decode_pairs(raw: Vec<[u32; 2]>, composites: bool) -> (Vec<[u32; 2]>, Vec<u32>) {
    if !composites {
        return (raw, Vec::new());
    }
    let shift = crate::shapes::PIECE_SHIFT;
    let mask = (1u32 << shift) - 1;
    raw.iter()
        .map(|&[x, y]| {
            (
                [x & mask, y & mask],
                clatter::contact_list::piece_code(x >> shift, y >> shift),
            )
        })
        .unzip()
}

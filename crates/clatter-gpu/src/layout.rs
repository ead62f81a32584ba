//! What the GPU pipeline shares with its shaders beyond `clatter::contract`: the step's
//! uniform [`Params`], the [`Grid`], the status words and the indirect-dispatch slots. The
//! WGSL declarations of all of them, and of the buffers ([`crate::buffers`]), are generated
//! by [`wgsl_prelude`], which every kernel is compiled after.

use clatter::contract::{Constant, GpuRecord, wgsl_constants};

pub use clatter::contract::{
    BODY_ORIENTATION_OFFSET, BODY_POSITION_OFFSET, BODY_STATE_SIZE, BodyConsts, BodyState,
    ContactForce, PairParams, WallRecord,
};

clatter::gpu_record! {
    /// Uniform parameters of the step.
    pub struct Params {
        /// Gravity, m/s^2 (w unused).
        pub gravity: [f32; 4],
        /// Number of bodies.
        pub n: u32,
        /// Number of walls.
        pub num_walls: u32,
        /// Number of materials (the pair table is `num_materials^2`).
        pub num_materials: u32,
        /// Room in the pair buffers.
        pub pair_capacity: u32,
        /// Time step, s.
        pub dt: f32,
        /// Verlet skin, m.
        pub skin: f32,
        /// `(skin / 2)^2`: a body farther than this from its rebuild position asks for a rebuild.
        pub half_skin2: f32,
        /// The smallest cell size: the largest bounding diameter plus the skin.
        pub min_cell: f32,
        /// The grid has at most this many cells.
        pub max_cells: u32,
        /// Number of indirect-dispatch slots.
        pub num_args: u32,
        /// 1 when every body is a sphere (the CPU's sphere fast path: effective radius from
        /// the bounding radius).
        pub spheres_only: u32,
        /// Always 1.0, unknown to the shader compiler: multiplying by it stops the compiler
        /// from simplifying the compensated orientation sum `(q + y) - q - y` to zero.
        pub one: f32,
        /// Lower corner of the periodic box (w unused).
        pub periodic_min: [f32; 4],
        /// Periodic box length per axis, 0 along non-periodic axes (w unused).
        pub periodic_len: [f32; 4],
        /// Number of sink boxes: their corners follow the walls in the `walls` buffer
        /// (`walls[num_walls + 2k].plane.xyz` = min, `walls[num_walls + 2k + 1].plane.xyz` =
        /// max), so they need no buffer of their own.
        pub num_sinks: u32,
        /// Wall slots per body and wall: the most pieces of a composite, 1 without
        /// composites (slot `(body * num_walls + wall) * max_pieces + piece`, `wall_slot` in
        /// pieces.wgsl).
        pub max_pieces: u32,
        /// 1 when some body is a composite: pair-list words then carry piece ids above the
        /// body index (pieces.wgsl), and the rebuild test counts rotation.
        pub composites: u32,
        /// Number of triangle-mesh boundaries (`[[boundary]]`, see `crate::mesh`).
        pub num_boundaries: u32,
        /// Where the boundaries' headers start in `shape_u` (`crate::mesh::HEADER_WORDS`
        /// words each).
        pub mesh_base: u32,
        /// 1 to ignore what touching polyhedron pairs remember (`pair_memory`), so that
        /// every contact comes from the full separating-axis test: a check, never needed for
        /// results, which are bitwise the same either way (`CLATTER_GPU_FULL_TEST=1`, see
        /// docs/gpu.md).
        pub full_test: u32,
        /// Into how many contiguous ranges the adapter splits a dispatch's workgroups, one
        /// per thread: lavapipe and llvmpipe hand each of their threads one run of
        /// consecutive workgroups; 1 on a real GPU, which schedules workgroups as they
        /// finish. The per-item kernels deal their items over these ranges (`dealt_item`,
        /// status.wgsl) so that each thread gets its share of every part of a list, not one
        /// part of it (the pairs of one class, the bodies near the floor). Only which
        /// thread computes an item changes, never its result.
        pub deal: u32,
        /// Lanes per polyhedron pair in the full narrow phase (0: one thread per pair; 8 or
        /// 16: `contacts_full_poly_lanes`, `CLATTER_GPU_POLY_LANES`): `contacts_size` sizes
        /// that dispatch with it. Results are bitwise the same for every value.
        pub poly_lanes: u32,
    }
}

clatter::gpu_record! {
    /// The grid of the last rebuild (written by `grid_size` in bin.wgsl).
    pub struct Grid {
        /// Lower corner (w unused).
        pub min: [f32; 4],
        /// Edge of a cubic cell, m.
        pub cell_size: f32,
        /// Number of cells.
        pub cells: u32,
        /// Unused.
        pub pad0: u32,
        /// Unused.
        pub pad1: u32,
        /// Cells along x, y, z (w unused).
        pub dims: [u32; 4],
    }
}

clatter::gpu_record! {
    /// What the blow-up checks compare against (`health_params` in WGSL), written by the
    /// host when a run turns the checks on (`GpuWorld::set_health`). Step numbers are the
    /// GPU's own step count (status word `STEPS`) plus `base_*`, taken modulo the period.
    pub struct HealthParams {
        /// The reference point potential energies are measured from (w unused): the sums
        /// stay small, so `budget - potential` does not cancel in f32.
        pub reference: [f32; 4],
        /// Check every this many steps (0: never).
        pub check_every: u32,
        /// Record an energy sample every this many steps (0: never).
        pub energy_every: u32,
        /// Keep the last good state every this many steps (a multiple of `check_every`).
        pub snapshot_every: u32,
        /// `(world step at upload) mod check_every`.
        pub base_check: u32,
        /// `(world step at upload) mod energy_every`.
        pub base_energy: u32,
        /// `(world step at upload) mod snapshot_every`.
        pub base_snapshot: u32,
        /// The energy available to the run plus the potential energy of the reference
        /// point, J: the available energy is this minus the potential energy sum.
        pub budget: f32,
        /// The kinetic energy above this multiple of the available energy raises the alarm
        /// (below the host's factor: the GPU's f32 sums only say when to look).
        pub alarm_factor: f32,
        /// A touching contact with a normal force above this may be deep: the alarm, when
        /// its force also passes `overlap_limit`'s test.
        pub force_floor: f32,
        /// A touching contact raises the alarm only when its normal force, all on one point
        /// of its law, means an overlap deeper than this fraction of the smaller body's
        /// volume-equivalent radius (the host's `OVERLAP_LIMIT` with a margin for f32,
        /// `HealthSetup::overlap_limit`); 0: the force floor alone decides.
        pub overlap_limit: f32,
        /// Unused.
        pub pad1: u32,
        /// Unused.
        pub pad2: u32,
    }
}

clatter::gpu_record! {
    /// The checks' sums over some bodies (a workgroup's, or all of them): one element of
    /// the `health` buffer (energy log, then per-workgroup sums).
    pub struct HealthRecord {
        /// Kinetic energy, potential energy (about `HealthParams::reference`), momentum x
        /// and y.
        pub sums: [f32; 4],
        /// Momentum z.
        pub pz: f32,
        /// The GPU step count of the sample (`health_log`).
        pub step: u32,
        /// The first body entirely behind a wall, or `u32::MAX`.
        pub escaped: u32,
        /// The first body with a touching contact whose normal force is above
        /// `HealthParams::force_floor`, or `u32::MAX`.
        pub suspect: u32,
    }
}

clatter::gpu_record! {
    /// A body-wall slot's last force, as the GPU keeps it (`wall_forces`): a
    /// [`ContactForce`] whose unused word holds whether the body touched the wall in the
    /// last step (1) or not (0), so the slot costs no more than the force.
    pub struct WallForce {
        /// Force on the body (side b), N.
        pub force_b: glam::Vec3,
        /// Total normal force, N.
        pub normal_force: f32,
        /// Torque on the wall (side a), N m.
        pub torque_a: glam::Vec3,
        /// 1 when the body touched the wall in the last step, else 0.
        pub touching: u32,
        /// Torque on the body (side b), N m.
        pub torque_b: glam::Vec3,
        /// Unused.
        pub pad0: f32,
    }
}

impl WallForce {
    /// A slot's record from its force and touching flag.
    pub fn new(f: &ContactForce, touching: bool) -> WallForce {
        WallForce {
            force_b: f.force_b,
            normal_force: f.normal_force,
            torque_a: f.torque_a,
            touching: touching as u32,
            torque_b: f.torque_b,
            pad0: 0.0,
        }
    }

    /// The slot's force (as the CPU keeps it) and touching flag.
    pub fn split(&self) -> (ContactForce, bool) {
        let f = ContactForce::new(
            self.force_b,
            self.torque_a,
            self.torque_b,
            self.normal_force,
        );
        (f, self.touching != 0)
    }
}

/// Slots of the energy log ring (the start of the `health` buffer): more than the steps of
/// one batch.
pub const HEALTH_LOG: u32 = 128;

/// The last good state, kept in six buffers so that none is larger per element than the
/// largest buffer it copies (each must fit the adapter's storage-binding limit, 2 GiB - 1 on
/// Vulkan through wgpu; one buffer of everything needed 4.6 GB at 4,194,304 spheres):
/// - `snapshot`: the status words, then per body its state, rebuild position and
///   orientation and the low part of its position ([`words`](snapshot::words));
/// - `snapshot_mesh`: a copy of the `mesh` buffer (scenes with mesh boundaries only,
///   [`mesh_words`](snapshot::mesh_words));
/// - `snapshot_wall_hist`, `snapshot_wall_forces`: copies of `wall_hist` and `wall_forces`;
/// - `snapshot_pairs`: per pair its entry, springs and touching word
///   ([`PAIR`](snapshot::PAIR) words, so that a larger pair capacity only extends it);
/// - `snapshot_forces`: a copy of `forces`.
///
/// Of the pair buffers only the live pairs are copied (as many as the status block copied
/// with them counts), not the list's room to grow.
pub mod snapshot {
    /// Words of the status block.
    pub const STATUS: u64 = 32;
    /// Words per body: state (24), rebuild position (4), rebuild orientation (4: with
    /// composites only, see `RebuildSlots`), the low part of the position (4).
    pub const BODY: u64 = 36;
    /// Words per pair in `snapshot_pairs`: bodies (2), springs (4), touching (1).
    pub const PAIR: u64 = 7;

    /// Words of the copy of the `mesh` buffer for `bodies` and `boundaries` (none without
    /// boundaries).
    pub fn mesh_words(bodies: u64, boundaries: u64) -> u64 {
        if boundaries == 0 {
            0
        } else {
            crate::mesh::state_words(bodies, boundaries)
        }
    }

    /// Words of the `snapshot` buffer (status and bodies).
    pub fn words(bodies: u64) -> u64 {
        STATUS + BODY * bodies
    }
}

/// Shape keys told apart by the classes of `contacts_place`: key 0 is every sphere body,
/// key 1 + s the polyhedron (or composite) shape s, higher ones sharing the last key.
pub const SPLIT_SHAPES: usize = 6;
/// Classes of the pairs the full narrow phase runs (contacts_split.wgsl `pair_class`): the
/// unordered pair of the two bodies' shape keys, then the path (full test, remembered face,
/// remembered edge contact), so that the pairs with a sphere body (smaller key 0) come first.
pub const SPLIT_CLASSES: usize = 3 * SPLIT_SHAPES * SPLIT_SHAPES;
/// The classes of pairs with a sphere body: the first `SPHERE_CLASSES` classes, which
/// `contacts_full_spheres` runs apart from the polyhedron pairs (`contacts_full_poly`).
pub const SPHERE_CLASSES: usize = 3 * SPLIT_SHAPES;

/// Words of the status buffer (`ST_*` in WGSL).
pub mod status {
    /// Set by integrate: rebuild the pair list next step.
    pub const REBUILD: usize = 0;
    /// The pair list overflowed: everything stops until the host grows it.
    pub const OVERFLOW: usize = 1;
    /// First body with a non-finite state (`u32::MAX` if none).
    pub const BAD_BODY: usize = 2;
    /// Contacts touching in the last step.
    pub const TOUCHING: usize = 3;
    /// Candidate pairs in the list.
    pub const PAIRS: usize = 4;
    /// Steps taken on the GPU (low 32 bits).
    pub const STEPS: usize = 5;
    /// Shader-internal: this step rebuilds.
    pub const REBUILDING: usize = 6;
    /// Rebuilds so far.
    pub const REBUILDS: usize = 7;
    /// Pairs the last rebuild found (may exceed the capacity).
    pub const PAIRS_NEEDED: usize = 8;
    /// Pairs `contacts_sat` left for the full narrow phase in the last step (polyhedron scenes).
    pub const WORK: usize = 9;
    /// Shader-internal: 6 words, the bounding box (min xyz, max xyz as order-preserving u32).
    pub const BBOX: usize = 10;
    /// Set by a lean step that found a rebuild due: the pipeline stops until the next full
    /// step, which clears it and runs that step again.
    pub const STALL: usize = 16;
    /// Set by `health_reduce` when a check found something the host must look at (energy
    /// growth, escape, a suspect contact): the pipeline stops at that step.
    pub const HEALTH: usize = 17;
    /// The last step (GPU count) whose checks passed.
    pub const CHECKED: usize = 18;
    /// Energy samples written to `health_log` so far.
    pub const SAMPLES: usize = 19;
    /// Set (to the body index plus one) when a body met more mesh triangles or contacts
    /// than the GPU's fixed per-body capacity (`crate::mesh`): the pipeline stops and the
    /// host reports it.
    pub const MESH_FULL: usize = 20;
    /// Shader-internal: [`SPLIT_CLASSES`](super::SPLIT_CLASSES) words, per class the number of
    /// pairs `contacts_sat` leaves for the full narrow phase, turned by `contacts_size` into the
    /// class's next slot in the list `contacts_place` orders by class.
    pub const CLASSES: usize = 21;
    /// Shader-internal: pairs with a sphere body in this step's ordered list (its first
    /// range; `contacts_size`).
    pub const FULL_SPHERES: usize = CLASSES + super::SPLIT_CLASSES;
    /// Number of status words.
    pub const LEN: usize = FULL_SPHERES + 1;
    // The snapshot keeps the words before the class counts (health.wgsl `snapshot_one`).
    const _: () = assert!(CLASSES as u64 <= super::snapshot::STATUS);
}

/// Indirect-dispatch slots (`ARG_*` in WGSL); the scan levels' slots follow.
pub mod arg {
    /// Every body plus one, during a rebuild.
    pub const BODIES_REBUILD: u32 = 0;
    /// Every cell plus one, during a rebuild.
    pub const CELLS_REBUILD: u32 = 1;
    /// The new pair list, during a rebuild.
    pub const PAIRS_NEW: u32 = 2;
    /// The current pair list, every step.
    pub const PAIRS: u32 = 3;
    /// `max(new pairs, n + 1)`, during a rebuild.
    pub const COMMIT: u32 = 4;
    /// `contacts_place`: the pairs `contacts_sat` could not separate.
    pub const WORK: u32 = 5;
    /// `integrate`, every step (zero while the pipeline is stopped).
    pub const STEP_BODIES: u32 = 6;
    /// `health_bodies`: every body on the steps a check or an energy sample is due, else
    /// nothing (written each step by `end_step_gate`).
    pub const HEALTH: u32 = 7;
    /// `snapshot_state`: its grid on snapshot steps, else nothing (`end_step_gate`).
    pub const SNAPSHOT: u32 = 8;
    /// `contacts_full_spheres`: the pairs with a sphere body of the ordered list.
    pub const FULL_SPHERES: u32 = 9;
    /// `contacts_full_poly`: the other pairs of the ordered list.
    pub const FULL_POLY: u32 = 10;
    /// `health_reduce`: one workgroup on the steps a check or an energy sample is due, else
    /// nothing (`end_step_gate`).
    pub const HEALTH_REDUCE: u32 = 11;
    /// The first scan-level slot.
    pub const FIRST_SCAN: u32 = 12;
}

/// Threads per workgroup of every kernel (`WG`).
pub const WG: u32 = 256;

/// The constants the shaders share with the host.
fn constants() -> Vec<Constant> {
    use Constant::U32;
    let st = |name, v: usize| U32(name, v as u32);
    vec![
        U32("WG", WG),
        U32("NONE", u32::MAX),
        st("ST_REBUILD", status::REBUILD),
        st("ST_OVERFLOW", status::OVERFLOW),
        st("ST_BAD_BODY", status::BAD_BODY),
        st("ST_TOUCHING", status::TOUCHING),
        st("ST_PAIRS", status::PAIRS),
        st("ST_STEPS", status::STEPS),
        st("ST_REBUILDING", status::REBUILDING),
        st("ST_REBUILDS", status::REBUILDS),
        st("ST_PAIRS_NEEDED", status::PAIRS_NEEDED),
        st("ST_WORK", status::WORK),
        st("ST_BBOX", status::BBOX),
        st("ST_STALL", status::STALL),
        st("ST_HEALTH", status::HEALTH),
        st("ST_CHECKED", status::CHECKED),
        st("ST_SAMPLES", status::SAMPLES),
        st("ST_MESH_FULL", status::MESH_FULL),
        st("ST_CLASSES", status::CLASSES),
        st("ST_FULL_SPHERES", status::FULL_SPHERES),
        st("ST_LEN", status::LEN),
        st("SPLIT_SHAPES", SPLIT_SHAPES),
        st("SPLIT_CLASSES", SPLIT_CLASSES),
        st("SPHERE_CLASSES", SPHERE_CLASSES),
        U32("MESH_SLOTS", clatter::mesh_boundary::MESH_SLOTS as u32),
        U32("MESH_HDR", crate::mesh::HEADER_WORDS as u32),
        U32("MESH_GLOBAL", crate::mesh::GLOBAL_WORDS as u32),
        U32("MESH_BSTATE", crate::mesh::BOUNDARY_STATE_WORDS as u32),
        U32("MESH_SLOT", crate::mesh::SLOT_WORDS as u32),
        U32("MESH_MAX_CANDS", crate::mesh::MAX_CANDIDATES as u32),
        U32("MESH_MAX_FOUND", crate::mesh::MAX_FOUND as u32),
        Constant::F32("SLOT_MATCH_COS", clatter::mesh_boundary::SLOT_MATCH_COS),
        Constant::F32("TURN_TAU_HI", clatter::turn::TAU_HI),
        Constant::F32("TURN_TAU_LO", clatter::turn::TAU_LO),
        Constant::F32("TURN_INV_TAU", clatter::turn::INV_TAU),
        Constant::F32("TURN_FOPI", clatter::turn::FOPI),
        Constant::F32("TURN_DP1", clatter::turn::DP[0]),
        Constant::F32("TURN_DP2", clatter::turn::DP[1]),
        Constant::F32("TURN_DP3", clatter::turn::DP[2]),
        Constant::F32("TURN_S0", clatter::turn::SIN[0]),
        Constant::F32("TURN_S1", clatter::turn::SIN[1]),
        Constant::F32("TURN_S2", clatter::turn::SIN[2]),
        Constant::F32("TURN_C0", clatter::turn::COS[0]),
        Constant::F32("TURN_C1", clatter::turn::COS[1]),
        Constant::F32("TURN_C2", clatter::turn::COS[2]),
        U32("SNAP_STATUS", snapshot::STATUS as u32),
        U32("SNAP_BODY", snapshot::BODY as u32),
        U32("SNAP_PAIR", snapshot::PAIR as u32),
        U32("HEALTH_LOG", HEALTH_LOG),
        U32("ARG_BODIES_REBUILD", arg::BODIES_REBUILD),
        U32("ARG_CELLS_REBUILD", arg::CELLS_REBUILD),
        U32("ARG_PAIRS_NEW", arg::PAIRS_NEW),
        U32("ARG_PAIRS", arg::PAIRS),
        U32("ARG_COMMIT", arg::COMMIT),
        U32("ARG_WORK", arg::WORK),
        U32("ARG_FULL_SPHERES", arg::FULL_SPHERES),
        U32("ARG_FULL_POLY", arg::FULL_POLY),
        U32("ARG_STEP_BODIES", arg::STEP_BODIES),
        U32("ARG_HEALTH", arg::HEALTH),
        U32("ARG_SNAPSHOT", arg::SNAPSHOT),
        U32("ARG_HEALTH_REDUCE", arg::HEALTH_REDUCE),
        U32("SNAPSHOT_GROUPS", crate::stages::health::SNAPSHOT_GROUPS),
        U32("ARG_SCAN0", arg::FIRST_SCAN),
    ]
}

/// Everything a simulation kernel is compiled after: the shared constants and records
/// (`clatter::contract`), the GPU's own ([`Params`], [`Grid`], status words, dispatch
/// slots), and the group-0 buffer bindings ([`crate::buffers::BUFFERS`]).
pub fn wgsl_prelude() -> String {
    [
        "// Generated from clatter::contract and clatter-gpu/src/{layout,buffers}.rs.\n".into(),
        clatter::contract::wgsl_records(),
        wgsl_constants(&constants()),
        Params::wgsl(),
        Grid::wgsl(),
        HealthParams::wgsl(),
        HealthRecord::wgsl(),
        WallForce::wgsl(),
        crate::buffers::wgsl_bindings(),
    ]
    .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clatter::contract::layout_mismatch;

    #[test]
    fn gpu_records_have_the_wgsl_layout() {
        assert_eq!(layout_mismatch::<Params>(), None);
        assert_eq!(layout_mismatch::<Grid>(), None);
        assert_eq!(layout_mismatch::<HealthParams>(), None);
        assert_eq!(layout_mismatch::<HealthRecord>(), None);
        assert_eq!(layout_mismatch::<WallForce>(), None);
        assert_eq!(size_of::<WallForce>(), size_of::<ContactForce>());
    }

    #[test]
    fn no_shader_retypes_a_generated_declaration() {
        let generated = wgsl_prelude();
        for (file, src) in crate::pipeline::SHADER_FILES {
            for line in src.lines() {
                let decl = line.trim_start();
                let named = |prefix: &str| {
                    decl.strip_prefix(prefix)
                        .and_then(|r| r.split([' ', ':', '{']).next())
                        .filter(|name| generated.contains(&format!("{prefix}{name}")))
                };
                if let Some(name) = named("struct ").or_else(|| named("const ")) {
                    panic!("{file} declares {name}, which is generated: {line}");
                }
                assert!(
                    !decl.starts_with("@group(0)"),
                    "{file} binds group 0 itself: {line}"
                );
            }
        }
    }
}

//! Types shared with the shaders, defined once: `#[repr(C)]`, `Pod`, padded to WGSL's
//! 16-byte `vec3` alignment.

use bytemuck::{Pod, Zeroable};

pub use clatter::contract::{
    BODY_ORIENTATION_OFFSET, BODY_POSITION_OFFSET, BODY_STATE_SIZE, BodyConsts, BodyState,
    ContactForce, PairParams, WallRecord,
};

/// Uniform parameters of the step (`Params` in `shaders/bindings.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct Params {
    pub gravity: [f32; 4],
    pub n: u32,
    pub num_walls: u32,
    pub num_materials: u32,
    pub pair_capacity: u32,
    pub dt: f32,
    pub skin: f32,
    pub half_skin2: f32,
    pub min_cell: f32,
    pub max_cells: u32,
    pub num_args: u32,
    /// 1 when every body is a sphere (the CPU's sphere fast path: effective radius from the
    /// bounding radius).
    pub spheres_only: u32,
    /// Always 1.0. The shader multiplies by it where floating-point algebra must not be
    /// simplified: shader compilers may reassociate, and would fold the compensated
    /// (Kahan) orientation sum `(q + y) - q - y` to zero; they cannot fold through a value
    /// they only learn at run time.
    pub one: f32,
}

/// Words of the status buffer (`ST_*` in `bindings.wgsl`).
pub mod status {
    pub const REBUILD: usize = 0;
    pub const OVERFLOW: usize = 1;
    pub const BAD_BODY: usize = 2;
    pub const TOUCHING: usize = 3;
    pub const PAIRS: usize = 4;
    pub const STEPS: usize = 5;
    pub const REBUILDING: usize = 6;
    pub const REBUILDS: usize = 7;
    pub const PAIRS_NEEDED: usize = 8;
    /// Pairs `contacts_sat` left for `contacts_full` in the last step (polyhedron scenes).
    pub const WORK: usize = 9;
    /// Set by a lean step that found a rebuild due (see `GpuWorld::encode_steps`): the
    /// pipeline stops until the next full step, which clears it and runs that step again.
    pub const STALL: usize = 16;
    /// Number of status words.
    pub const LEN: usize = 17;
}

/// Indirect-dispatch slots (`ARG_*` in `bindings.wgsl`); scan levels follow.
pub mod arg {
    pub const BODIES_REBUILD: u32 = 0;
    pub const CELLS_REBUILD: u32 = 1;
    pub const PAIRS_NEW: u32 = 2;
    pub const PAIRS: u32 = 3;
    pub const COMMIT: u32 = 4;
    /// `contacts_full`: the pairs `contacts_sat` could not separate.
    pub const WORK: u32 = 5;
    /// `integrate`, every step (zero while the pipeline is stopped).
    pub const STEP_BODIES: u32 = 6;
    pub const FIRST_SCAN: u32 = 7;
}

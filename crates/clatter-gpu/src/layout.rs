//! Types shared with the shaders, defined once: `#[repr(C)]`, `Pod`, padded to WGSL's
//! 16-byte `vec3` alignment.

use bytemuck::{Pod, Zeroable};

/// One body's dynamic state as the GPU stores it (`BodyState` in `shaders/common.wgsl`):
/// 96 bytes, six `vec4<f32>`; the `w` of the vector fields is unused. The renderer reads
/// `position` (byte 0) and `orientation` (byte 32, quaternion `x, y, z, w`) straight from the
/// simulation's buffer.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct BodyState {
    pub position: [f32; 4],
    pub velocity: [f32; 4],
    /// Orientation of the body's principal frame, quaternion `x, y, z, w`.
    pub orientation: [f32; 4],
    /// Rounding carried by the compensated orientation update.
    pub residual: [f32; 4],
    pub angular_momentum: [f32; 4],
    pub omega: [f32; 4],
}

/// Byte size of [`BodyState`].
pub const BODY_STATE_SIZE: u64 = std::mem::size_of::<BodyState>() as u64;
/// Byte offset of `position` in [`BodyState`].
pub const BODY_POSITION_OFFSET: u64 = 0;
/// Byte offset of `orientation` in [`BodyState`].
pub const BODY_ORIENTATION_OFFSET: u64 = 32;

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

/// Per-body constants (`BodyStatic` in `shaders/bindings.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct BodyStatic {
    /// `1 / principal moments` in xyz, `1 / mass` in w.
    pub inv_inertia: [f32; 4],
    pub mass: f32,
    pub radius: f32,
    pub equivalent_radius: f32,
    pub _pad: f32,
    pub shape: u32,
    pub material: u32,
    pub is_sphere: u32,
    pub isotropic: u32,
}

/// Combined contact parameters of a material pair (`PairParams` in `bindings.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPairParams {
    pub hertz: u32,
    pub stiffness: f32,
    pub shear: f32,
    pub damping_factor: f32,
    pub friction: f32,
    pub _pad: [f32; 3],
}

/// A wall plane and its material (`Wall` in `bindings.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct GpuWall {
    pub plane: [f32; 4],
    pub material: u32,
    pub _pad: [u32; 3],
}

/// One contact's force (`ContactForce` in `bindings.wgsl`): force on b (w: total normal
/// force) and the torques on both sides.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct GpuContactForce {
    pub force_b: [f32; 4],
    pub torque_a: [f32; 4],
    pub torque_b: [f32; 4],
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

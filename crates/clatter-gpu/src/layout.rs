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

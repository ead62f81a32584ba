//! clatter's step pipeline on the GPU, in `wgpu` compute shaders.
//!
//! The step's stages carry the CPU pipeline's names (`clatter::step`): the **broad** phase
//! (**bin**, **sort**, **pairs**), **contacts** (the narrow phase and the contact law per
//! candidate pair) and **integrate**, plus the optional **health** checks. Each is
//! recorded by its module in [`stages`] (`stages/<stage>.rs`) from the WGSL files in the
//! folder of the same name, `shaders/<stage>/` (`broad/bin.wgsl`, `contacts/narrow.wgsl`,
//! `integrate/integrate.wgsl`, ...; `shaders/common/` holds what every kernel includes).
//! [`world`] holds a scene's state on the GPU and drives the step; body state stays on the
//! GPU between steps, and the host reads it back only when output is due.
//!
//! The `test-harness` feature adds the test-only API: `test_context` and the batch
//! harnesses `law`, `narrow` and `turn`, which run the law, the narrow phase and a turning
//! boundary's pose in WGSL on thousands of queries for the tests that hold them against
//! `clatter`'s Rust.

pub mod bandwidth;
#[cfg(feature = "test-harness")]
mod batch;
pub mod buffers;
pub mod context;
pub mod env;
#[cfg(feature = "test-harness")]
pub mod law;
pub mod layout;
pub mod mesh;
#[cfg(feature = "test-harness")]
pub mod narrow;
pub(crate) mod pipeline;
pub mod readback;
pub mod shapes;
pub mod stages;
#[cfg(feature = "test-harness")]
pub mod turn;
pub mod world;

#[cfg(feature = "test-harness")]
pub use context::test_context;
pub use context::{GpuContext, GpuError, instance_flags, quiet_device_select};
pub use layout::BodyState;
#[cfg(feature = "test-harness")]
pub use narrow::{
    GpuManifold, NarrowBatch, NarrowQuery, PairMemory, PlaneQuery, collide_batch,
    collide_plane_batch,
};
pub use readback::{read_buffer, read_buffers};
pub use shapes::GpuShapes;
pub use world::{EnergySample, FullPhase, GpuWorld, HealthSetup, IN_FLIGHT_VAR, StepReport};

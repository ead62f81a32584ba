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

pub mod backend;
pub mod bandwidth;
pub mod buffers;
pub mod context;
pub mod law;
pub mod layout;
pub mod mesh;
pub mod narrow;
pub(crate) mod pipeline;
pub mod readback;
pub mod shapes;
pub mod stages;
pub mod watch;
pub mod world;

pub use backend::{
    BackendChoice, BackendError, Chosen, Device, Readback, StepError, Stepped, Stepper, choose,
};
pub use context::{GpuContext, GpuError, instance_flags, quiet_device_select, test_context};
pub use layout::BodyState;
pub use narrow::{
    GpuManifold, NarrowBatch, NarrowQuery, PlaneQuery, collide_batch, collide_plane_batch,
};
pub use readback::{read_buffer, read_buffers};
pub use shapes::GpuShapes;
pub use watch::{Watch, WatchError};
pub use world::{EnergySample, GpuWorld, HealthSetup, StepReport};

//! How the physics tests step a world. Here: the CPU pipeline. clatter-gpu's
//! `tests/physics.rs` includes the same test files with its `gpu-step` feature on, and then
//! `step` runs the step on the GPU (and reads the state back), so the same analytic checks
//! hold for both backends.

#[cfg(not(feature = "gpu-step"))]
pub fn step(w: &mut clatter::World) -> Result<clatter::StepStats, clatter::SimError> {
    w.step()
}

#[cfg(feature = "gpu-step")]
pub use crate::gpu_step::step;

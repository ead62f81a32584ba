//! How the physics tests step a world. Here: the CPU pipeline. clatter-gpu's
//! `tests/physics.rs` includes the same test files with its `gpu-step` feature on, and then
//! `step` runs the step on the GPU (and reads the state back), so the same analytic checks
//! hold for both backends.

#[cfg(not(feature = "gpu-step"))]
#[allow(dead_code)] // not every test file takes single steps
pub fn step(w: &mut clatter::World) -> Result<clatter::StepStats, clatter::SimError> {
    w.step()
}

/// `n` steps in a row (on the GPU: one batch, read back at the end).
#[cfg(not(feature = "gpu-step"))]
#[allow(dead_code)] // not every test file runs long stretches
pub fn step_n(w: &mut clatter::World, n: u64) -> Result<(), clatter::SimError> {
    for _ in 0..n {
        w.step()?;
    }
    Ok(())
}

/// Brings the contact list up to date before a test looks at it (the GPU stepper reads only
/// body state after each step).
#[cfg(not(feature = "gpu-step"))]
#[allow(dead_code)] // not every test file looks at contacts
pub fn sync(_w: &mut clatter::World) {}

#[cfg(feature = "gpu-step")]
#[allow(unused_imports)] // not every test file looks at contacts
pub use crate::gpu_step::{step, step_n, sync};

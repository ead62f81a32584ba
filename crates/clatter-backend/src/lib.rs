//! The backend layer every clatter front end (the `clatter` command, the viewer, the Python
//! package) steps a world through, whichever executor runs it:
//!
//! - [`backend`]: [`choose`] turns the user's [`BackendChoice`] into a [`Stepper`] (the CPU
//!   pipeline, or with the `gpu` feature a `clatter_gpu::GpuWorld`) and says why
//!   ([`Choice`]); [`Stepper::step`] advances the world, [`Readback`] says what comes back
//!   from the GPU.
//! - [`watch`]: the blow-up checks of a stepping loop ([`Watch`]): the host's
//!   `clatter::health` checks at the same steps on both executors, the GPU doing the cheap
//!   ones on the device.
//!
//! Errors carry data, not sentences for one front end: a blow-up is a
//! [`clatter::health::BlowUp`] (kind, body, step, time, cause), a refused backend a
//! [`BackendError`] whose [`BackendError::describe`] and [`Choice::describe`] take the
//! front end's own name for "use the GPU" (`--backend gpu`, `backend="gpu"`).

pub mod backend;
pub mod watch;

pub use backend::{
    BackendChoice, BackendError, Choice, Chosen, Device, DeviceError, Fallback, Readback,
    StepError, Stepped, Stepper, choose,
};
pub use watch::{CHECK_EVERY, FULL_CHECK_EVERY, GPU_OVERLAP_MARGIN, Watch, WatchError};

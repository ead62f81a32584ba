//! `--backend cpu|gpu|auto`: the option's values, and the CLI's side of
//! [`clatter_gpu::choose`] (printing the choice unless `--quiet`).

use clap::ValueEnum;
use clatter::World;
use clatter_gpu::{BackendChoice, Device, Stepper};

/// The values of `--backend` (their doc comments are the `--help` text); each is a
/// [`BackendChoice`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// The GPU when a hardware adapter is found and the scene fits it, else the CPU; says
    /// which and why.
    Auto,
    /// The multi-threaded CPU pipeline (the reference).
    Cpu,
    /// The wgpu compute pipeline (fails when no adapter is found or the scene does not fit).
    Gpu,
}

impl From<Backend> for BackendChoice {
    fn from(b: Backend) -> BackendChoice {
        match b {
            Backend::Auto => BackendChoice::Auto,
            Backend::Cpu => BackendChoice::Cpu,
            Backend::Gpu => BackendChoice::Gpu,
        }
    }
}

/// The stepper for `world` on `device` ([`clatter_gpu::choose`]); prints the `backend: ...`
/// line unless `quiet`.
pub fn choose(
    backend: Backend,
    world: &World,
    device: Device,
    quiet: bool,
) -> anyhow::Result<Stepper> {
    let chosen = clatter_gpu::choose(backend.into(), world, device)?;
    if let Some(note) = &chosen.note
        && !quiet
    {
        eprintln!("{note}");
    }
    Ok(chosen.stepper)
}

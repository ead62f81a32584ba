//! `--backend cpu|gpu|auto`: the option's values, and the CLI's side of
//! [`clatter_backend::choose`] (printing the choice unless `--quiet`, wording its errors).

use clap::ValueEnum;
use clatter::World;
use clatter_backend::{BackendChoice, Device, Stepper};

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

/// The command line's name for asking for the GPU, in the backend layer's messages.
pub const GPU_OPTION: &str = "--backend gpu";

impl From<Backend> for BackendChoice {
    fn from(b: Backend) -> BackendChoice {
        match b {
            Backend::Auto => BackendChoice::Auto,
            Backend::Cpu => BackendChoice::Cpu,
            Backend::Gpu => BackendChoice::Gpu,
        }
    }
}

/// The stepper for `world` on `device` ([`clatter_backend::choose`]); prints the
/// `backend: ...` line unless `quiet`.
pub fn choose(
    backend: Backend,
    world: &World,
    device: Device,
    quiet: bool,
) -> anyhow::Result<Stepper> {
    let chosen = clatter_backend::choose(backend.into(), world, device)
        .map_err(|e| anyhow::anyhow!(e.describe(GPU_OPTION)))?;
    if let Some(note) = chosen.choice.note()
        && !quiet
    {
        eprintln!("{note}");
    }
    Ok(chosen.stepper)
}

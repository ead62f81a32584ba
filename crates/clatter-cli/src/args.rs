//! Options several subcommands share, declared once and `#[command(flatten)]`ed into each
//! subcommand's arguments: [`Pipeline`] (`--threads`, `--backend`) and [`Progress`]
//! (`--quiet`, `--log-every`). Where a subcommand words one of them differently or gives it
//! another default, its arguments struct says so with `#[command(mut_arg(...))]`.

use crate::backend::Backend;
use crate::log::{LogArgs, LogEvery};

/// `--threads` and `--backend`: the options of every subcommand that steps a world.
#[derive(clap::Args, Clone, Debug)]
pub struct Pipeline {
    /// Worker threads (default: all cores). Results are identical for any count.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Which pipeline steps the world: gpu, cpu, or auto (the GPU when a hardware
    /// adapter is found and the scene fits it, else the CPU, saying which and why).
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
}

impl Pipeline {
    /// Sizes rayon's global pool to `--threads` (left alone without it).
    pub fn init_threads(&self) -> anyhow::Result<()> {
        if let Some(n) = self.threads {
            if n == 0 {
                anyhow::bail!("--threads must be at least 1");
            }
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build_global()?;
        }
        Ok(())
    }
}

/// `--quiet` and `--log-every`: what a long-running subcommand prints on the way.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Progress {
    /// Print nothing but errors (no progress bar or lines).
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub log: LogArgs,
}

impl Progress {
    /// The progress lines' interval (`None`: none; see [`LogArgs::lines`]).
    pub fn lines(&self) -> Option<LogEvery> {
        self.log.lines(self.quiet)
    }
}

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
    /// Sizes rayon's global pool to `--threads` (rayon's default without it: all cores, or
    /// `RAYON_NUM_THREADS`), with the main thread's stack size, since [`on_pool`] runs the
    /// whole command on one of its threads.
    pub fn init_threads(&self) -> anyhow::Result<()> {
        if self.threads == Some(0) {
            anyhow::bail!("--threads must be at least 1");
        }
        let limit = clatter::thread_limit();
        if let Some(n) = self.threads.filter(|&n| n > limit) {
            anyhow::bail!(
                "--threads {n} is more than {limit} (16 per core of this machine): results are identical for any count, so threads beyond the cores only slow the run"
            );
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads.unwrap_or(0))
            .stack_size(POOL_STACK)
            .build_global()?;
        Ok(())
    }
}

/// The stack of each pool thread: the main thread's usual 8 MiB, as the command runs on one.
const POOL_STACK: usize = 8 << 20;

/// Runs `f` on a thread of rayon's global pool and returns its result. A step's parallel
/// loops started from a pool thread run there and on the other pool threads directly; started
/// from the main thread, each would be injected into the pool, wake a worker and put the main
/// thread to sleep until it ends, a few system calls and a wake-up per loop (several a step),
/// while the main thread's own serial work ran beside an idle pool. Results do not depend on
/// the thread a loop starts from (they are identical for any thread count).
pub fn on_pool<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::scope(|_| f())
}

/// `--quiet` and `--log-every`: what a long-running subcommand prints on the way.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Progress {
    /// Print nothing but errors and warnings (no progress bar or lines, no summary).
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

//! `--backend cpu|gpu|auto`: which pipeline steps the world.

use std::sync::Arc;

use anyhow::Context;
use clap::ValueEnum;
use clatter::World;
use clatter_gpu::{GpuContext, GpuWorld};

/// The pipeline that steps a run or a benchmark.
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

/// The chosen pipeline: the CPU steps the [`World`] itself; the GPU holds its own copy of
/// the state and hands it back when output is due.
pub enum Engine {
    Cpu,
    Gpu(Box<GpuWorld>),
}

impl Engine {
    /// Short name for messages and summaries.
    pub fn name(&self) -> String {
        match self {
            Engine::Cpu => "cpu".into(),
            Engine::Gpu(g) => format!("gpu ({})", g.context().adapter_name()),
        }
    }
}

/// Chooses the engine for `world`; with `auto`, prints the choice and the reason unless
/// `quiet`.
pub fn choose(backend: Backend, world: &World, quiet: bool) -> anyhow::Result<Engine> {
    match backend {
        Backend::Cpu => Ok(Engine::Cpu),
        Backend::Gpu => {
            let ctx = GpuContext::new().context("--backend gpu")?;
            choose_on(Arc::new(ctx), backend, world, quiet)
        }
        Backend::Auto => match GpuContext::new() {
            Ok(ctx) => choose_on(Arc::new(ctx), backend, world, quiet),
            Err(e) => {
                say(quiet, format!("cpu (auto: {e})"));
                Ok(Engine::Cpu)
            }
        },
    }
}

/// [`choose`] with the GPU context already open (the renderer's, so that it can draw from
/// the simulation's buffers).
pub fn choose_on(
    ctx: Arc<GpuContext>,
    backend: Backend,
    world: &World,
    quiet: bool,
) -> anyhow::Result<Engine> {
    match backend {
        Backend::Cpu => Ok(Engine::Cpu),
        Backend::Gpu => {
            let g = GpuWorld::new(ctx, world)
                .context("cannot run this scene on the GPU")
                .context("--backend gpu")?;
            say(quiet, format!("gpu ({})", g.context().adapter_name()));
            Ok(Engine::Gpu(Box::new(g)))
        }
        Backend::Auto => {
            if ctx.is_software() {
                say(
                    quiet,
                    format!(
                        "cpu (auto: the only GPU adapter, {}, is a software rasteriser, slower than the CPU pipeline; --backend gpu uses it anyway)",
                        ctx.adapter_name()
                    ),
                );
                return Ok(Engine::Cpu);
            }
            let name = ctx.adapter_name();
            match GpuWorld::new(ctx, world) {
                Ok(g) => {
                    say(quiet, format!("gpu (auto: found {name})"));
                    Ok(Engine::Gpu(Box::new(g)))
                }
                Err(e) => {
                    say(quiet, format!("cpu (auto: found {name}, but {e})"));
                    Ok(Engine::Cpu)
                }
            }
        }
    }
}

/// Prints the backend choice on stderr unless `quiet`.
fn say(quiet: bool, msg: String) {
    if !quiet {
        eprintln!("backend: {msg}");
    }
}

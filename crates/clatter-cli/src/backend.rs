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

/// Opens the GPU and uploads `world`.
pub fn open_gpu(world: &World) -> anyhow::Result<Box<GpuWorld>> {
    let ctx = Arc::new(GpuContext::new()?);
    Ok(Box::new(
        GpuWorld::new(ctx, world).context("cannot run this scene on the GPU")?,
    ))
}

/// Chooses the engine for `world`; with `auto`, prints the choice and the reason unless
/// `quiet`.
pub fn choose(backend: Backend, world: &World, quiet: bool) -> anyhow::Result<Engine> {
    let say = |msg: String| {
        if !quiet {
            eprintln!("backend: {msg}");
        }
    };
    match backend {
        Backend::Cpu => Ok(Engine::Cpu),
        Backend::Gpu => {
            let g = open_gpu(world).context("--backend gpu")?;
            say(format!("gpu ({})", g.context().adapter_name()));
            Ok(Engine::Gpu(g))
        }
        Backend::Auto => {
            let ctx = match GpuContext::new() {
                Ok(c) => c,
                Err(e) => {
                    say(format!("cpu (auto: {e})"));
                    return Ok(Engine::Cpu);
                }
            };
            if ctx.is_software() {
                say(format!(
                    "cpu (auto: the only GPU adapter, {}, is a software rasteriser, slower than the CPU pipeline; --backend gpu uses it anyway)",
                    ctx.adapter_name()
                ));
                return Ok(Engine::Cpu);
            }
            let name = ctx.adapter_name();
            match GpuWorld::new(Arc::new(ctx), world) {
                Ok(g) => {
                    say(format!("gpu (auto: found {name})"));
                    Ok(Engine::Gpu(Box::new(g)))
                }
                Err(e) => {
                    say(format!("cpu (auto: found {name}, but {e})"));
                    Ok(Engine::Cpu)
                }
            }
        }
    }
}

//! `clatter`: run DEM scenes, render and view them, benchmark the step, answer collision
//! queries.

mod args;
mod backend;
mod bench;
mod cluster;
mod energy;
mod log;
mod output;
mod picture;
mod plot;
mod query;
mod render;
mod report;
mod run;
mod scene_io;
mod validate;

use clatter::vtk;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Simulates rigid convex polyhedra and spheres colliding (Discrete Element Method).
#[derive(Parser)]
#[command(name = "clatter", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene (the embedded default scene when SCENE is omitted).
    Run(run::RunArgs),
    /// Continue a run from a checkpoint (DIR/checkpoint.ckpt or DIR/last_good.ckpt) to the
    /// end of its run, with the output options it was started with unless given again.
    Resume(run::ResumeArgs),
    /// Run a scene and write a PNG frame every N steps (offscreen, no window needed), then
    /// DIR/frames.mp4 if ffmpeg is on the PATH.
    Render(render::RenderArgs),
    /// Open a window with the scene running live: orbit (left drag), pan (right or middle
    /// drag), zoom (wheel); pause, step, reset, speed, colour modes.
    View(render::ViewArgs),
    /// Time the step on a settled pile and print bodies vs steps/s.
    Bench(bench::BenchArgs),
    /// Run the DEM verification suite (Chung & Ooi 2011 tests 1-8, MFIX DEM01-04,
    /// restitution at the default time step, conservation laws, a poured pile) and print one
    /// row per checked quantity; exits non-zero unless every row passes (docs/validation.md).
    Validate(validate::ValidateArgs),
    /// Answer collision queries: JSON lines in (FILE or - for stdin), JSON lines out.
    Query {
        /// Input file, or - for standard input.
        input: String,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        // Under mpirun (docs/parallel.md): `run`, `resume`, `bench` and `validate` (the checks
        // that can be split: `--only pile`) step the world on the ranks; `render` and `view`
        // refuse several ranks.
        Command::Run(args) => {
            args.pipeline
                .init_threads()
                .and_then(|_| match cluster::launched() {
                    Some(ranks) if cluster::wanted(ranks) => {
                        args::on_pool(|| cluster::run(cluster::Invocation::Run(args), ranks))
                    }
                    _ => args::on_pool(|| run::run(args)),
                })
        }
        Command::Resume(args) => {
            args.pipeline
                .init_threads()
                .and_then(|_| match cluster::launched() {
                    Some(ranks) if cluster::wanted(ranks) => {
                        args::on_pool(|| cluster::run(cluster::Invocation::Resume(args), ranks))
                    }
                    _ => args::on_pool(|| run::resume(args)),
                })
        }
        Command::Bench(args) => {
            args.pipeline
                .init_threads()
                .and_then(|_| match cluster::launched() {
                    Some(ranks) if cluster::wanted(ranks) => {
                        args::on_pool(|| cluster::run(cluster::Invocation::Bench(args), ranks))
                    }
                    _ => args::on_pool(|| bench::bench(args)),
                })
        }
        Command::Render(args) => args
            .pipeline
            .init_threads()
            .and_then(|_| cluster::single_rank_only("render"))
            .and_then(|_| render::render(args)),
        Command::View(args) => args
            .pipeline
            .init_threads()
            .and_then(|_| cluster::single_rank_only("view"))
            .and_then(|_| render::view(args)),
        Command::Query { input } => query::run(&input),
        Command::Validate(args) => {
            args.pipeline
                .init_threads()
                .and_then(|_| match cluster::launched() {
                    Some(ranks) if cluster::wanted(ranks) => {
                        args::on_pool(|| cluster::run(cluster::Invocation::Validate(args), ranks))
                    }
                    _ => validate::validate(args).and_then(|passed| {
                        if passed {
                            Ok(())
                        } else {
                            Err(validate::Failed.into())
                        }
                    }),
                })
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<report::BlownUp>() => {
            eprintln!("error: {e:#}");
            ExitCode::from(report::BLOW_UP_EXIT)
        }
        Err(e) if e.is::<validate::Failed>() => ExitCode::from(validate::FAILED_EXIT),
        // Another rank (rank 0) has said why.
        Err(e) if e.is::<cluster::Quiet>() => {
            ExitCode::from(e.downcast_ref::<cluster::Quiet>().map_or(1, |q| q.0))
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

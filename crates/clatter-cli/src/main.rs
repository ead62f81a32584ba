//! `clatter`: run DEM scenes, render and view them, benchmark the step, answer collision
//! queries.

mod backend;
mod bench;
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

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

/// Simulates rigid convex polyhedra and spheres colliding (Discrete Element Method).
#[derive(Parser)]
#[command(name = "clatter", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Shape of the benchmark pile.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum BenchShape {
    /// Spheres only.
    Sphere,
    /// Cubes only.
    Cube,
    /// Tetrahedra, cubes, octahedra, dodecahedra, icosahedra and spheres in turn.
    Mixed,
}

/// How the benchmark pile is made.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum PileArg {
    /// Stacked on a cubic lattice, touching.
    Lattice,
    /// Rained into the box and settled until at rest; the settled pile is cached (see
    /// `--pile-cache`), so the settle runs once per machine.
    Poured,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene (the embedded default scene when SCENE is omitted).
    Run {
        /// Scene file (TOML, see docs/scene-format.md).
        scene: Option<PathBuf>,
        #[command(flatten)]
        output: run::OutputArgs,
        /// Worker threads (default: all cores). Results are identical for any count.
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Override the scene's run length with a number of steps.
        #[arg(long, value_name = "N")]
        steps: Option<u64>,
        /// Print nothing but errors (no progress bar or lines).
        #[arg(long, short)]
        quiet: bool,
        #[command(flatten)]
        log: log::LogArgs,
        /// Which pipeline steps the world: gpu, cpu, or auto (the GPU when a hardware
        /// adapter is found and the scene fits it, else the CPU, saying which and why).
        #[arg(long, value_enum, default_value = "auto")]
        backend: backend::Backend,
    },
    /// Continue a run from a checkpoint (DIR/checkpoint.ckpt or DIR/last_good.ckpt) to the
    /// end of its run, with the output options it was started with unless given again.
    Resume {
        /// Checkpoint file written by `clatter run --checkpoint-every`.
        checkpoint: PathBuf,
        #[command(flatten)]
        output: run::OutputArgs,
        /// Worker threads (default: all cores). Results are identical for any count.
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Run N more steps instead of going on to the end of the original run.
        #[arg(long, value_name = "N")]
        steps: Option<u64>,
        /// Print nothing but errors (no progress bar or lines).
        #[arg(long, short)]
        quiet: bool,
        #[command(flatten)]
        log: log::LogArgs,
        /// Which pipeline steps the world: gpu, cpu, or auto (the GPU when a hardware
        /// adapter is found and the scene fits it, else the CPU, saying which and why).
        #[arg(long, value_enum, default_value = "auto")]
        backend: backend::Backend,
    },
    /// Run a scene and write a PNG frame every N steps (offscreen, no window needed), then
    /// DIR/frames.mp4 if ffmpeg is on the PATH.
    Render {
        /// Scene file (TOML, see docs/scene-format.md); the embedded default when omitted.
        scene: Option<PathBuf>,
        /// Directory for frame_000000.png, frame_000001.png, ... and frames.mp4 (created if
        /// needed).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Write a frame every N steps (and at the first and last step).
        #[arg(long, value_name = "N", default_value_t = 100)]
        every: u64,
        /// Image size in pixels.
        #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = picture::parse_size)]
        size: (u32, u32),
        /// Override the scene's run length with a number of steps.
        #[arg(long, value_name = "N")]
        steps: Option<u64>,
        /// Frames per second of frames.mp4.
        #[arg(long, value_name = "FPS", default_value_t = 30)]
        fps: u32,
        #[command(flatten)]
        picture: picture::PictureArgs,
        /// Worker threads of the simulation (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Which pipeline steps the world: gpu (frames drawn straight from its buffers), cpu,
        /// or auto (the GPU when a hardware adapter is found and the scene fits it, else the
        /// CPU, saying which and why).
        #[arg(long, value_enum, default_value = "auto")]
        backend: backend::Backend,
        /// Print nothing but errors (and whether the MP4 was skipped).
        #[arg(long, short)]
        quiet: bool,
        #[command(flatten)]
        log: log::LogArgs,
    },
    /// Open a window with the scene running live: orbit (left drag), pan (right or middle
    /// drag), zoom (wheel); pause, step, reset, speed, colour modes.
    View {
        /// Scene file (TOML, see docs/scene-format.md); the embedded default when omitted.
        scene: Option<PathBuf>,
        /// Window size in pixels.
        #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = picture::parse_size)]
        size: (u32, u32),
        /// Simulation steps per displayed frame (the speed slider's start value).
        #[arg(long, value_name = "N", default_value_t = 10)]
        steps_per_frame: u32,
        #[command(flatten)]
        picture: picture::PictureArgs,
        /// Save the window (scene and controls) to PATH as a PNG after --frames frames, and
        /// exit.
        #[arg(long, value_name = "PATH")]
        screenshot: Option<PathBuf>,
        /// Frames to show before the screenshot (with --screenshot).
        #[arg(long, value_name = "N", default_value_t = 30)]
        frames: u64,
        /// Worker threads of the simulation (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Which pipeline steps the world: gpu (on the window's device, drawn straight from
        /// its buffers), cpu, or auto (the GPU when the window's adapter is hardware and the
        /// scene fits it, else the CPU).
        #[arg(long, value_enum, default_value = "auto")]
        backend: backend::Backend,
    },
    /// Time the step on a settled pile and print bodies vs steps/s.
    Bench {
        /// Shape of the bodies.
        #[arg(long, value_enum, default_value = "sphere")]
        shape: BenchShape,
        /// Comma-separated body counts.
        #[arg(long, value_delimiter = ',', default_value = "1024,4096,16384,65536")]
        bodies: Vec<usize>,
        /// Timed steps per body count.
        #[arg(long, default_value_t = 200)]
        steps: u64,
        /// Untimed steps that let the pile settle first.
        #[arg(long, default_value_t = 1000)]
        settle: u64,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Worker threads (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Also write the settled sphere pile as a LAMMPS data file and input script into DIR
        /// (for scripts/bench-lammps.sh); only with --shape sphere and one body count.
        #[arg(long, value_name = "DIR")]
        emit_lammps: Option<PathBuf>,
        /// Which pipeline to time: gpu, cpu, or auto (see `clatter run --help`). GPU times
        /// are wall clock around work that ends with a synchronising read, after the settle
        /// steps as warm-up.
        #[arg(long, value_enum, default_value = "cpu")]
        backend: backend::Backend,
        /// Also time steps with an offscreen 1280x720 render after each (the "fps with
        /// rendering" column; needs a GPU adapter, lavapipe/llvmpipe will do).
        #[arg(long)]
        render: bool,
        /// Frames timed per body count with --render.
        #[arg(long, value_name = "N", default_value_t = 20)]
        render_frames: u64,
        /// With --backend gpu: also time every kernel alone with timestamp queries and print
        /// milliseconds per step per kernel (the steps/s column is measured before, without).
        #[arg(long)]
        profile: bool,
        /// Steps timed per body count with --profile.
        #[arg(long, value_name = "N", default_value_t = 100)]
        profile_steps: u64,
        /// Time a scene file instead of the piles (`default`: the embedded default scene);
        /// one row, the scene's bodies, after --settle steps. --shape and --bodies are
        /// ignored.
        #[arg(long, value_name = "FILE|default")]
        scene: Option<PathBuf>,
        /// How the pile is made: poured (rained into the box and settled, cached) or lattice
        /// (stacked, touching).
        #[arg(long, value_enum, default_value = "poured")]
        pile: PileArg,
        /// Where settled poured piles are cached (default: $CLATTER_PILE_CACHE, else
        /// $XDG_CACHE_HOME/clatter/piles, else ~/.cache/clatter/piles).
        #[arg(long, value_name = "DIR")]
        pile_cache: Option<PathBuf>,
    },
    /// Run the DEM verification suite (Chung & Ooi 2011 tests 1-8, MFIX DEM01-04,
    /// restitution at the default time step, conservation laws, a poured pile) and print one
    /// row per checked quantity; exits non-zero unless every row passes (docs/validation.md).
    Validate {
        /// Which pipeline steps the worlds: gpu, cpu, or auto (the GPU when a hardware
        /// adapter is found, else the CPU, saying which and why).
        #[arg(long, value_enum, default_value = "auto")]
        backend: backend::Backend,
        /// Write validation.json and one SVG plot per check into DIR (created if needed).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Fewer cases, shorter runs, fewer bodies (under a minute on two cores).
        #[arg(long)]
        quick: bool,
        /// Run only the checks whose name contains one of these (comma-separated).
        #[arg(long, value_delimiter = ',', value_name = "NAME")]
        only: Vec<String>,
        /// Worker threads (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Print only the table, the verdict and errors (no progress on stderr).
        #[arg(long, short)]
        quiet: bool,
        #[command(flatten)]
        log: log::LogArgs,
    },
    /// Answer collision queries: JSON lines in (FILE or - for stdin), JSON lines out.
    Query {
        /// Input file, or - for standard input.
        input: String,
    },
}

fn init_threads(threads: Option<usize>) -> anyhow::Result<()> {
    if let Some(n) = threads {
        if n == 0 {
            anyhow::bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()?;
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            scene,
            output,
            threads,
            steps,
            quiet,
            log,
            backend,
        } => init_threads(threads).and_then(|_| {
            run::run(run::RunArgs {
                scene,
                backend,
                output,
                steps,
                quiet,
                log: log.lines(quiet),
            })
        }),
        Command::Resume {
            checkpoint,
            output,
            threads,
            steps,
            quiet,
            log,
            backend,
        } => init_threads(threads).and_then(|_| {
            run::resume(run::ResumeArgs {
                checkpoint,
                backend,
                output,
                steps,
                quiet,
                log: log.lines(quiet),
            })
        }),
        Command::Bench {
            shape,
            bodies,
            steps,
            settle,
            json,
            threads,
            emit_lammps,
            backend,
            render,
            render_frames,
            profile,
            profile_steps,
            scene,
            pile,
            pile_cache,
        } => init_threads(threads).and_then(|_| {
            bench::bench(bench::BenchArgs {
                shape,
                bodies,
                steps,
                settle,
                json,
                emit_lammps,
                backend,
                render: render.then_some(render_frames),
                profile: profile.then_some(profile_steps),
                scene,
                pile,
                pile_cache,
            })
        }),
        Command::Render {
            scene,
            out,
            every,
            size,
            steps,
            fps,
            picture,
            threads,
            backend,
            quiet,
            log,
        } => init_threads(threads).and_then(|_| {
            render::render(render::RenderArgs {
                scene,
                out,
                every,
                size,
                steps,
                fps,
                picture,
                backend,
                quiet,
                log: log.lines(quiet),
            })
        }),
        Command::View {
            scene,
            size,
            steps_per_frame,
            picture,
            screenshot,
            frames,
            threads,
            backend,
        } => init_threads(threads).and_then(|_| {
            render::view(render::ViewArgs {
                scene,
                size,
                steps_per_frame,
                picture,
                screenshot,
                frames,
                backend,
            })
        }),
        Command::Query { input } => query::run(&input),
        Command::Validate {
            backend,
            out,
            quick,
            only,
            threads,
            quiet,
            log,
        } => init_threads(threads).and_then(|_| {
            validate::validate(validate::ValidateArgs {
                backend,
                out,
                quick,
                only,
                quiet,
                log: log.lines(quiet),
            })
            .and_then(|passed| {
                if passed {
                    Ok(())
                } else {
                    Err(validate::Failed.into())
                }
            })
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<report::BlownUp>() => {
            eprintln!("error: {e:#}");
            ExitCode::from(report::BLOW_UP_EXIT)
        }
        Err(e) if e.is::<validate::Failed>() => ExitCode::from(validate::FAILED_EXIT),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

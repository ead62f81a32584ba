//! `clatter render`: run a scene (on the CPU or the GPU) and write a PNG frame every N steps
//! (offscreen, no window), then encode them into an MP4 when ffmpeg is on the PATH. With the
//! GPU backend the frames are drawn straight from the simulation's body buffer. `clatter view`: the
//! interactive window. Both take the same picture options ([`PictureArgs`], in
//! [`crate::picture`]).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

use anyhow::Context;
use clatter::health::Health;
use clatter_backend::{CHECK_EVERY, Device, Readback, Stepper, Watch, WatchError};
use clatter_gpu::GpuContext;
use clatter_render::{Offscreen, Poses, save_png};

use crate::args::{Pipeline, Progress};
use crate::backend::choose;
use crate::log::{Sample, Thermo};
use crate::picture::{ColorArg, PictureArgs, parse_size};
use crate::report::BlownUp;
use crate::scene_io::load_scene;

/// Arguments of `clatter render`.
#[derive(clap::Args, Debug)]
#[command(
    mut_arg("threads", |a| a.help("Worker threads of the simulation (default: all cores)")),
    mut_arg("backend", |a| a.help("Which pipeline steps the world: gpu (frames drawn straight from its buffers), cpu, or auto (the GPU when a hardware adapter is found and the scene fits it, else the CPU, saying which and why)")),
    mut_arg("quiet", |a| a.help("Print nothing but errors and warnings (and whether the MP4 was skipped)")),
)]
pub struct RenderArgs {
    /// Scene file (TOML, see docs/scene-format.md); the embedded default when omitted.
    pub scene: Option<PathBuf>,
    /// Directory for frame_000000.png, frame_000001.png, ... and frames.mp4 (created if
    /// needed).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Write a frame every N steps (and at the first and last step).
    #[arg(long, value_name = "N", default_value_t = 100)]
    pub every: u64,
    /// Image size in pixels.
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Override the scene's run length with a number of steps.
    #[arg(long, value_name = "N")]
    pub steps: Option<u64>,
    /// Frames per second of frames.mp4.
    #[arg(long, value_name = "FPS", default_value_t = 30)]
    pub fps: u32,
    #[command(flatten)]
    pub picture: PictureArgs,
    #[command(flatten)]
    pub pipeline: Pipeline,
    #[command(flatten)]
    pub progress: Progress,
}

/// Runs `clatter render`.
pub fn render(args: RenderArgs) -> anyhow::Result<()> {
    if args.every == 0 {
        anyhow::bail!("--every must be at least 1");
    }
    if args.fps == 0 {
        anyhow::bail!("--fps must be at least 1");
    }
    let (_, scene) = load_scene(args.scene.as_deref())?;
    let mut world = scene.world();
    let end = args.steps.unwrap_or_else(|| scene.steps(world.dt));
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create the output directory {}", args.out.display()))?;
    remove_old_frames(&args.out)?;
    let ctx = Arc::new(GpuContext::new()?);
    let (w, h) = args.size;
    let mut off = Offscreen::new(&ctx, &world, w, h)?;
    let camera = off.camera(args.picture.camera);
    let style = args.picture.style();
    let mut stepper = choose(
        args.pipeline.backend,
        &world,
        Device::Shared(ctx.clone()),
        args.progress.quiet,
    )?;
    if !args.progress.quiet {
        eprintln!(
            "rendering {} ({} bodies, {end} steps) every {} steps at {w}x{h} on {}",
            scene.source,
            world.len(),
            args.every,
            ctx.adapter_name()
        );
    }
    // The colour modes that need per-body data the GPU does not keep in the body buffer
    // (contact flags; the largest speed, for the colour scale) read the state back per frame.
    let needs_host =
        args.picture.only_contacts || !matches!(args.picture.color, ColorArg::Material);
    let mut frames = 0u64;
    let mut shoot = |world: &mut clatter::World,
                     stepper: &Stepper,
                     off: &mut Offscreen|
     -> anyhow::Result<()> {
        let img = match stepper.as_gpu() {
            None => {
                off.update(world);
                off.render(&camera, &style, Poses::Uploaded)?
            }
            Some(g) => {
                let mut style = style;
                if needs_host {
                    stepper.sync(world)?;
                    off.renderer.update_styles(world, None);
                    let vmax = world
                        .state
                        .velocity
                        .iter()
                        .map(|v| v.length())
                        .filter(|s| s.is_finite())
                        .fold(0.0f32, f32::max);
                    style.speed_max = Some(if vmax > 0.0 { vmax } else { 1.0 });
                }
                off.render(&camera, &style, Poses::Gpu(g.body_buffer()))?
            }
        };
        let path = args.out.join(format!("frame_{frames:06}.png"));
        save_png(&img, &path)?;
        frames += 1;
        Ok(())
    };
    // The blow-up checks of `clatter run` (the same code path: `Watch`), so that a scene
    // that blows up there stops here too, with the same report and exit status.
    let watch = start_watch(&mut stepper, &world)?;
    shoot(&mut world, &stepper, &mut off)?;
    let mut k = 0u64;
    let mut thermo = args
        .progress
        .lines()
        .map(|every| Thermo::new(every, 0, end));
    while k < end {
        // Up to the next frame (a multiple of --every, or the last step), or the next
        // progress line.
        let frame = ((k / args.every + 1) * args.every).min(end);
        let next = thermo
            .as_ref()
            .map_or(frame, |l| l.stop_before(k).min(frame));
        let stats = watch
            .step(&mut stepper, &mut world, next - k, Readback::Nothing)
            .map_err(watch_error)?;
        k = next;
        if next == frame {
            shoot(&mut world, &stepper, &mut off)?;
        }
        if let Some(l) = &mut thermo
            && (l.due(k) || k == end)
        {
            // On the GPU the host's world stays behind: read it back for the line only.
            stepper.sync(&mut world)?;
            let x = Sample {
                step: k,
                time: world.time,
                kinetic: world.kinetic_energy(),
                contacts: stats.contacts,
            };
            if k == end { l.finish(x) } else { l.line(x) }
        }
    }
    ctx.take_error()?;
    if !args.progress.quiet {
        println!(
            "wrote {frames} frames to {}/frame_NNNNNN.png",
            args.out.display()
        );
    }
    encode_mp4(&args.out, args.fps, args.progress.quiet)
}

/// The blow-up checks for a `render` or `view` of `world`: the warnings and the check before
/// the first step as `clatter run` has them, then a [`Watch`] with `run`'s defaults.
pub fn start_watch(stepper: &mut Stepper, world: &clatter::World) -> anyhow::Result<Watch> {
    let health = Health::new(world);
    for w in health.warnings(world) {
        eprintln!("warning: {w}");
    }
    if let Err(b) = health.check_initial(world) {
        return Err(anyhow::Error::new(BlownUp(b.to_string())));
    }
    Ok(Watch::start(stepper, world, health, CHECK_EVERY, 0))
}

/// A [`WatchError`] as `main` reports it (a blow-up exits with `report::BLOW_UP_EXIT`).
pub fn watch_error(e: WatchError) -> anyhow::Error {
    match e {
        WatchError::BlowUp(b) => anyhow::Error::new(BlownUp(b.to_string())),
        WatchError::Gpu(e) => e.into(),
    }
}

/// Arguments of `clatter view`.
#[derive(clap::Args, Debug)]
#[command(
    mut_arg("threads", |a| a.help("Worker threads of the simulation (default: all cores)")),
    mut_arg("backend", |a| a.help("Which pipeline steps the world: gpu (on the window's device, drawn straight from its buffers), cpu, or auto (the GPU when the window's adapter is hardware and the scene fits it, else the CPU)")),
)]
pub struct ViewArgs {
    /// Scene file (TOML, see docs/scene-format.md); the embedded default when omitted.
    pub scene: Option<PathBuf>,
    /// Window size in pixels.
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Simulation steps per displayed frame (the speed slider's start value).
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub steps_per_frame: u32,
    #[command(flatten)]
    pub picture: PictureArgs,
    /// Save the window (scene and controls) to PATH as a PNG after --frames frames, and
    /// exit.
    #[arg(long, value_name = "PATH")]
    pub screenshot: Option<PathBuf>,
    /// Frames to show before the screenshot (with --screenshot; alone it would leave the
    /// window open and never end, so it is refused).
    #[arg(long, value_name = "N", default_value_t = 30, requires = "screenshot")]
    pub frames: u64,
    #[command(flatten)]
    pub pipeline: Pipeline,
}

/// Runs `clatter view`.
pub fn view(args: ViewArgs) -> anyhow::Result<()> {
    if args.frames == 0 {
        anyhow::bail!("--frames must be at least 1");
    }
    if args.steps_per_frame == 0 {
        anyhow::bail!("--steps-per-frame must be at least 1");
    }
    if let Some(dir) = args.screenshot.as_ref().and_then(|p| p.parent())
        && !dir.as_os_str().is_empty()
        && !dir.is_dir()
    {
        anyhow::bail!(
            "--screenshot: the directory {} does not exist",
            dir.display()
        );
    }
    let (_, scene) = load_scene(args.scene.as_deref())?;
    let viewed = clatter_render::viewer::run(clatter_render::ViewerOptions {
        world: scene.world(),
        title: format!("clatter: {}", scene.source),
        size: args.size,
        steps_per_frame: args.steps_per_frame,
        camera: args.picture.camera,
        style: args.picture.style(),
        screenshot: args.screenshot,
        frames: args.frames,
        backend: args.pipeline.backend.into(),
    });
    match viewed {
        Err(clatter_render::ViewerError::BlowUp(report)) => {
            Err(anyhow::Error::new(BlownUp(report)))
        }
        other => Ok(other?),
    }
}

/// Removes the `frame_NNNNNN.png` files of an earlier render from `dir` (and its
/// `frames.mp4`): the frames of a shorter render would otherwise sit beside old ones, and
/// ffmpeg's `frame_%06d.png` would read those too.
fn remove_old_frames(dir: &Path) -> anyhow::Result<()> {
    let entries = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read the output directory {}", dir.display()))?;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let frame = name
            .strip_prefix("frame_")
            .and_then(|r| r.strip_suffix(".png"))
            .is_some_and(|n| n.len() == 6 && n.bytes().all(|b| b.is_ascii_digit()));
        if frame || name == "frames.mp4" {
            std::fs::remove_file(entry.path()).with_context(|| {
                format!("cannot remove the old frame {}", entry.path().display())
            })?;
        }
    }
    Ok(())
}

/// Encodes `DIR/frame_%06d.png` into `DIR/frames.mp4` with ffmpeg, or says why not.
fn encode_mp4(dir: &Path, fps: u32, quiet: bool) -> anyhow::Result<()> {
    let mp4 = dir.join("frames.mp4");
    let out = Command::new("ffmpeg")
        .args([
            "-y",
            "-loglevel",
            "error",
            "-framerate",
            &fps.to_string(),
            "-i",
        ])
        .arg(dir.join("frame_%06d.png"))
        // Even sizes and yuv420p: what H.264 players expect.
        .args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-pix_fmt",
            "yuv420p",
        ])
        .arg(&mp4)
        .output();
    match out {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            println!(
                "ffmpeg was not found on the PATH: skipped {}",
                mp4.display()
            );
            Ok(())
        }
        Err(e) => {
            println!("could not run ffmpeg ({e}): skipped {}", mp4.display());
            Ok(())
        }
        Ok(o) if o.status.success() => {
            if !quiet {
                println!("wrote {}", mp4.display());
            }
            Ok(())
        }
        Ok(o) => anyhow::bail!(
            "ffmpeg failed to encode {} ({}): {}",
            mp4.display(),
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        ),
    }
}

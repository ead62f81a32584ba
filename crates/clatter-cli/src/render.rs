//! `clatter render`: run a scene (on the CPU or the GPU) and write a PNG frame every N steps
//! (offscreen, no window), then encode them into an MP4 when ffmpeg is on the PATH. With the
//! GPU backend the frames are drawn straight from the simulation's body buffer. `clatter view`: the
//! interactive window. Both take the same picture options ([`PictureArgs`]).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

use anyhow::Context;
use clap::ValueEnum;
use clatter::health::Health;
use clatter_gpu::watch::CHECK_EVERY;
use clatter_gpu::{Device, GpuContext, Readback, Stepper, Watch, WatchError};
use clatter_render::{CAMERA_SYNTAX, CameraSpec, ColorMode, Offscreen, Poses, Style, save_png};

use crate::backend::{Backend, choose};
use crate::log::{LogEvery, Sample, Thermo};
use crate::run::{BlownUp, load_scene};

/// Colour mode of bodies.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ColorArg {
    /// One colour per material.
    Material,
    /// Blue (at rest) to red (the fastest body).
    Speed,
    /// Orange if touching something now, grey if not.
    Contact,
}

impl From<ColorArg> for ColorMode {
    fn from(c: ColorArg) -> ColorMode {
        match c {
            ColorArg::Material => ColorMode::Material,
            ColorArg::Speed => ColorMode::Speed,
            ColorArg::Contact => ColorMode::Contact,
        }
    }
}

/// The largest image side `--size` accepts, pixels.
pub const MAX_SIDE: u32 = 8192;

/// Parses `WxH` (e.g. `1280x720`).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("'{s}' is not a size: expected WIDTHxHEIGHT, e.g. 1280x720");
    let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    // 8192 keeps a 4x multisampled frame with its depth buffer within about 2 GiB.
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!(
            "size {w}x{h}: each side must be 1 to {MAX_SIDE} pixels"
        ));
    }
    Ok((w, h))
}

/// Parses `--camera` (see [`CAMERA_SYNTAX`]).
pub fn parse_camera(s: &str) -> Result<CameraSpec, String> {
    s.parse::<CameraSpec>()
        .map_err(|e| format!("{e}; expected {CAMERA_SYNTAX}"))
}

/// Picture options shared by `render` and `view`.
#[derive(clap::Args, Clone, Debug)]
pub struct PictureArgs {
    /// Camera: iso (default; from the front, above and to the right), top, front, side, or
    /// an eye point EX,EY,EZ with an optional target :TX,TY,TZ (m; default target: the
    /// scene's centre), e.g. --camera 0.8,-0.6,0.5:0.15,0.15,0.05. Presets frame the bodies
    /// and the walls next to them.
    #[arg(long, value_name = "CAMERA", default_value = "iso", value_parser = parse_camera, allow_hyphen_values = true)]
    pub camera: CameraSpec,
    /// Colour bodies by material, speed, or contact (touching something now).
    #[arg(long, value_enum, default_value = "material")]
    pub color: ColorArg,
    /// Show only the bodies that touch something now (another body or a wall).
    #[arg(long)]
    pub only_contacts: bool,
}

impl PictureArgs {
    /// The renderer's style.
    pub fn style(&self) -> Style {
        Style {
            color: self.color.into(),
            only_contacts: self.only_contacts,
            speed_max: None,
        }
    }
}

/// Arguments of `clatter render`.
pub struct RenderArgs {
    pub scene: Option<PathBuf>,
    pub out: PathBuf,
    pub every: u64,
    pub size: (u32, u32),
    pub steps: Option<u64>,
    pub fps: u32,
    pub picture: PictureArgs,
    pub backend: Backend,
    pub quiet: bool,
    /// The progress lines' interval (`None`: none; see [`crate::log`]).
    pub log: Option<LogEvery>,
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
    let ctx = Arc::new(GpuContext::new()?);
    let (w, h) = args.size;
    let mut off = Offscreen::new(&ctx, &world, w, h)?;
    let camera = off.camera(args.picture.camera);
    let style = args.picture.style();
    let mut stepper = choose(
        args.backend,
        &world,
        Device::Shared(ctx.clone()),
        args.quiet,
    )?;
    if !args.quiet {
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
    let mut thermo = args.log.map(|every| Thermo::new(every, 0, end));
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
    if !args.quiet {
        println!(
            "wrote {frames} frames to {}/frame_NNNNNN.png",
            args.out.display()
        );
    }
    encode_mp4(&args.out, args.fps, args.quiet)
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

/// A [`WatchError`] as `main` reports it (a blow-up exits with `run::BLOW_UP_EXIT`).
pub fn watch_error(e: WatchError) -> anyhow::Error {
    match e {
        WatchError::BlowUp(b) => anyhow::Error::new(BlownUp(b.to_string())),
        WatchError::Gpu(e) => e.into(),
    }
}

/// Arguments of `clatter view`.
pub struct ViewArgs {
    pub scene: Option<PathBuf>,
    pub size: (u32, u32),
    pub steps_per_frame: u32,
    pub picture: PictureArgs,
    pub screenshot: Option<PathBuf>,
    pub frames: u64,
    pub backend: Backend,
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
        backend: args.backend.into(),
    });
    match viewed {
        Err(clatter_render::ViewerError::BlowUp(report)) => {
            Err(anyhow::Error::new(BlownUp(report)))
        }
        other => Ok(other?),
    }
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

/// Renders `world` as it is now into the PNG at `path` (1280x720, the iso camera, coloured by
/// material): the picture `clatter run` leaves with the default scene's results. Fails when
/// no GPU adapter (hardware or software) can be opened.
pub fn final_picture(world: &clatter::World, path: &std::path::Path) -> anyhow::Result<()> {
    let ctx = Arc::new(GpuContext::new()?);
    let mut off = Offscreen::new(&ctx, world, 1280, 720)?;
    let camera = off.camera(CameraSpec::Iso);
    let style = Style {
        color: ColorMode::Material,
        only_contacts: false,
        speed_max: None,
    };
    off.update(world);
    let img = off.render(&camera, &style, Poses::Uploaded)?;
    save_png(&img, path)?;
    ctx.take_error()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("1280x720"), Ok((1280, 720)));
        assert_eq!(parse_size(" 64X48 "), Ok((64, 48)));
        for bad in [
            "",
            "1280",
            "0x10",
            "10x0",
            "axb",
            "-1x5",
            "100000x10",
            "12x12x12",
        ] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}

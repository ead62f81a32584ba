//! Pictures: the picture options shared by `render` and `view` ([`PictureArgs`], `--size`),
//! and the picture of the last step `clatter run` leaves with the default scene's results.

use std::path::Path;
use std::sync::Arc;

use clap::ValueEnum;
use clatter_gpu::GpuContext;
use clatter_render::{CAMERA_SYNTAX, CameraSpec, ColorMode, Offscreen, Poses, Style, save_png};

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

/// Renders `world` as it is now into the PNG at `path` (1280x720, the iso camera, coloured by
/// material): the picture `clatter run` leaves with the default scene's results. Fails when
/// no GPU adapter (hardware or software) can be opened.
pub fn final_picture(world: &clatter::World, path: &Path) -> anyhow::Result<()> {
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

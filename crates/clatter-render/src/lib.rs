#![warn(missing_docs)]
//! Pictures of clatter simulations: a wgpu renderer for offscreen frames (PNG, video frames)
//! and the interactive viewer.
//!
//! - [`camera`]: the look-at camera, framing a world, the `--camera` syntax.
//! - [`mesh`]: shape meshes (faceted polyhedra, icospheres) and wall quads.
//! - [`renderer`]: instanced, lit, depth-tested drawing of bodies and walls; poses from a CPU
//!   world or straight from the GPU simulation's `BodyState` buffer.
//! - [`offscreen`]: frames into images without a window.
//! - [`viewer`]: the window (winit + egui) with the simulation running live.

pub mod camera;
pub mod mesh;
pub mod offscreen;
pub mod renderer;
pub mod viewer;

pub use camera::{Bounds, CAMERA_SYNTAX, Camera, CameraSpec};
pub use offscreen::{Offscreen, Targets, read_texture, save_png};
pub use renderer::{ColorMode, Poses, RenderError, Renderer, Style};
pub use viewer::{ViewerError, ViewerOptions};

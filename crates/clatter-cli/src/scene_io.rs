//! Scene files in: reading and validating a scene file, or the embedded default scene
//! (shared by `run`, `render`, `view` and `bench`).

use std::path::Path;

use clatter::scene::Scene;

/// The embedded default scene: mixed polyhedra poured into a box.
pub const DEFAULT_SCENE: &str = include_str!("../../../scenes/default.toml");

/// Reads and validates the scene at `path`, or the embedded default scene; returns the text
/// with the scene.
pub fn load_scene(path: Option<&Path>) -> anyhow::Result<(String, Scene)> {
    Ok(match path {
        Some(path) => Scene::read(path)?,
        None => {
            let scene = Scene::parse(DEFAULT_SCENE, "<default scene>")?;
            (DEFAULT_SCENE.to_string(), scene)
        }
    })
}

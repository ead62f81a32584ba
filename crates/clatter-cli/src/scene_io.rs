//! Scene files in: reading and validating a scene file, or the embedded default scene
//! (shared by `run`, `render`, `view` and `bench`).

use std::path::Path;

use clatter::scene::{Scene, SceneError};

/// The embedded default scene: mixed polyhedra poured into a box.
pub const DEFAULT_SCENE: &str = include_str!("../../../scenes/default.toml");

/// Reads and validates the scene at `path`, or the embedded default scene; returns the text
/// with the scene.
pub fn load_scene(path: Option<&Path>) -> anyhow::Result<(String, Scene)> {
    let (text, name) = match path {
        Some(path) => {
            let name = path.display().to_string();
            let text = std::fs::read_to_string(path).map_err(|e| SceneError {
                file: name.clone(),
                line: None,
                field: None,
                message: format!("cannot read the scene file: {e}"),
            })?;
            (text, name)
        }
        None => (DEFAULT_SCENE.to_string(), "<default scene>".to_string()),
    };
    let scene = Scene::parse(&text, &name)?;
    Ok((text, scene))
}

//! `ParsedScene`: a scene file read and validated by `clatter::scene`, with its text.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use clatter::scene::{RunLength, Scene};

use crate::errors::scene_error;

/// The example scenes of `scenes/` that need no mesh file, by file stem, embedded so that
/// `clatter.Scene.example(name)` works from any directory (the mesh scenes read `.obj`/`.stl`
/// files beside them and are left out).
pub const EXAMPLE_SCENES: &[(&str, &str)] = &[
    (
        "bench-hopper-100k-planes",
        include_str!("../../scenes/bench-hopper-100k-planes.toml"),
    ),
    (
        "bench-mixed-20k",
        include_str!("../../scenes/bench-mixed-20k.toml"),
    ),
    (
        "bouncing-ball",
        include_str!("../../scenes/bouncing-ball.toml"),
    ),
    (
        "cube-on-floor",
        include_str!("../../scenes/cube-on-floor.toml"),
    ),
    ("default", include_str!("../../scenes/default.toml")),
    ("dice-box", include_str!("../../scenes/dice-box.toml")),
    (
        "hertz-spheres",
        include_str!("../../scenes/hertz-spheres.toml"),
    ),
    (
        "periodic-floor",
        include_str!("../../scenes/periodic-floor.toml"),
    ),
    ("sink-floor", include_str!("../../scenes/sink-floor.toml")),
];

/// The names of [`EXAMPLE_SCENES`], in order.
pub fn example_names() -> Vec<&'static str> {
    EXAMPLE_SCENES.iter().map(|(n, _)| *n).collect()
}

/// A validated scene: what `clatter.Scene` hands to `Simulation`. Build it with
/// `clatter.Scene` (from a file, from TOML text, or in code) rather than directly.
#[pyclass(module = "clatter._clatter", frozen)]
pub struct ParsedScene {
    pub text: String,
    pub scene: Scene,
}

#[pymethods]
impl ParsedScene {
    /// Reads and validates the scene file at `path`.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: std::path::PathBuf) -> PyResult<ParsedScene> {
        Self::load(py, &path)
    }

    /// One of the example scenes of the repository's `scenes/` (those that need no mesh
    /// file), embedded in the extension: `name` is the file name with or without `.toml`
    /// (`"dice-box"`). An unknown name raises `ValueError` listing the names.
    #[staticmethod]
    fn example(py: Python<'_>, name: &str) -> PyResult<ParsedScene> {
        let stem = name.strip_suffix(".toml").unwrap_or(name);
        match EXAMPLE_SCENES.iter().find(|(n, _)| *n == stem) {
            Some((n, text)) => Self::parse(py, text.to_string(), &format!("<example scene {n}>")),
            None => Err(PyValueError::new_err(format!(
                "no example scene `{name}`; the examples are: {}",
                example_names().join(", ")
            ))),
        }
    }

    /// Parses and validates scene text; `source` names it in error messages.
    #[staticmethod]
    #[pyo3(signature = (text, source = "<string>"))]
    fn from_toml(py: Python<'_>, text: String, source: &str) -> PyResult<ParsedScene> {
        Self::parse(py, text, source)
    }

    /// The scene's TOML text.
    #[getter]
    fn text(&self) -> &str {
        &self.text
    }

    /// Where the scene came from (a file name, or what `from_toml` was given).
    #[getter]
    fn source(&self) -> &str {
        &self.scene.source
    }

    /// Number of bodies the scene creates.
    #[getter]
    fn n_bodies(&self) -> usize {
        self.scene.desc.bodies.len()
    }

    /// Number of wall planes (a container counts 5 or 6).
    #[getter]
    fn n_walls(&self) -> usize {
        self.scene.desc.walls.len()
    }

    /// Names of the materials, in index order.
    #[getter]
    fn materials(&self) -> Vec<String> {
        self.scene
            .desc
            .materials
            .iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// Legal but probably unintended things (overlapping lattice, bodies outside the container).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.warnings.clone()
    }

    /// Informational lines that change nothing (a boundary mesh wound inwards, mixed windings).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.scene.notes.clone()
    }

    /// `[simulation].duration` in seconds, or None when the scene gives `steps`.
    #[getter]
    fn duration(&self) -> Option<f64> {
        match self.scene.length {
            RunLength::Duration(d) => Some(d),
            RunLength::Steps(_) => None,
        }
    }

    /// The number of steps the scene runs for (`steps`, or `duration` / dt).
    #[getter]
    fn steps(&self) -> u64 {
        self.scene.steps(self.scene.world().dt)
    }

    fn __repr__(&self) -> String {
        format!(
            "<ParsedScene {}: {} bodies, {} walls>",
            self.scene.source,
            self.scene.desc.bodies.len(),
            self.scene.desc.walls.len()
        )
    }
}

impl ParsedScene {
    /// Reads and validates the scene file at `path` (the messages of `clatter run FILE`).
    pub fn load(py: Python<'_>, path: &std::path::Path) -> PyResult<ParsedScene> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| {
            scene_error(
                py,
                &clatter::scene::SceneError {
                    file: name.clone(),
                    line: None,
                    field: None,
                    message: format!("cannot read the scene file: {e}"),
                },
            )
        })?;
        Self::parse(py, text, &name)
    }

    pub fn parse(py: Python<'_>, text: String, source: &str) -> PyResult<ParsedScene> {
        match Scene::parse(&text, source) {
            Ok(scene) => Ok(ParsedScene { text, scene }),
            Err(e) => Err(scene_error(py, &e)),
        }
    }
}

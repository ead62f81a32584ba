//! `clatter._clatter`: the native half of the Python package `clatter` (PyO3 + numpy).
//!
//! - [`scene`]: `ParsedScene`, a validated scene file (the pure-Python `clatter.Scene`
//!   builds the TOML text and parses it here, so scenes built in code get the same checks
//!   and messages as scene files).
//! - [`sim`]: `Simulation`, a world stepped on the CPU or the GPU with its state as numpy
//!   arrays.
//! - [`query`]: the collision queries of `clatter query`, over arrays of poses.
//!
//! Errors are Python exceptions carrying the messages of the `clatter` command line.

mod errors;
mod query;
mod scene;
mod sim;

use pyo3::prelude::*;

/// The native module; `clatter/__init__.py` re-exports it with the pure-Python helpers.
#[pymodule]
fn _clatter(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<errors::SceneError>())?;
    m.add("CheckpointError", py.get_type::<errors::CheckpointError>())?;
    m.add("SimulationError", py.get_type::<errors::SimulationError>())?;
    m.add("BackendError", py.get_type::<errors::BackendError>())?;
    m.add("QueryError", py.get_type::<errors::QueryError>())?;
    m.add_class::<scene::ParsedScene>()?;
    m.add_class::<sim::Simulation>()?;
    m.add_function(wrap_pyfunction!(query::query_arrays, m)?)?;
    m.add("GPU_SUPPORT", cfg!(feature = "gpu"))?;
    m.add("DEFAULT_SCENE", clatter_default_scene())?;
    m.add("EXAMPLE_SCENES", scene::example_names())?;
    m.add("MATERIAL_COEFFICIENTS", material_coefficients(py)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

/// The material coefficients of `clatter::material::COEFFICIENTS` (restitution, frictions,
/// ...), one dict each (`name`, `default`, `range`, `unit`, `doc`), in the table's order:
/// `Scene.material` takes each as a keyword and its docstring lists them, so a coefficient
/// added to the table needs no edit of the Python package.
fn material_coefficients(py: Python<'_>) -> PyResult<Vec<Bound<'_, pyo3::types::PyDict>>> {
    clatter::material::COEFFICIENTS
        .iter()
        .map(|c| {
            let d = pyo3::types::PyDict::new(py);
            d.set_item("name", c.name)?;
            // The default as written in the table (0.3, not 0.30000001192092896).
            let default: f64 = c.default.to_string().parse().unwrap_or(c.default as f64);
            d.set_item("default", default)?;
            d.set_item("range", c.range.describe())?;
            d.set_item("unit", c.unit)?;
            d.set_item(
                "doc",
                c.doc.split_whitespace().collect::<Vec<_>>().join(" "),
            )?;
            Ok(d)
        })
        .collect()
}

/// The scene `clatter run` runs without a scene file.
fn clatter_default_scene() -> &'static str {
    include_str!("../../scenes/default.toml")
}

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
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

/// The scene `clatter run` runs without a scene file.
fn clatter_default_scene() -> &'static str {
    include_str!("../../scenes/default.toml")
}

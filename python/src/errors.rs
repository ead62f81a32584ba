//! The exceptions of the module and the conversions from clatter's errors.

use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    clatter,
    SceneError,
    PyValueError,
    "A scene that cannot be read or is not valid. `str(e)` is the command line's message \
     (`FILE:LINE:COLUMN: `FIELD`: what`); the parts are the attributes `file`, `line`, \
     `column`, `field` and `message` (None where unknown)."
);
create_exception!(
    clatter,
    CheckpointError,
    PyValueError,
    "A checkpoint that cannot be read or does not match its scene."
);
create_exception!(
    clatter,
    SimulationError,
    PyRuntimeError,
    "A step that failed: a body's state became non-finite (the run blew up)."
);
create_exception!(
    clatter,
    BackendError,
    PyRuntimeError,
    "The requested backend cannot run: no GPU adapter, a scene the GPU cannot hold, or a \
     module built without GPU support."
);
create_exception!(
    clatter,
    QueryError,
    PyValueError,
    "A collision query with an invalid shape, pose or option."
);

/// A scene error as a Python `SceneError` with its parts as attributes.
pub fn scene_error(py: Python<'_>, e: &clatter::scene::SceneError) -> PyErr {
    let err = SceneError::new_err(e.to_string());
    let value = err.value(py);
    let (line, column) = match e.line {
        Some((l, c)) => (Some(l), Some(c)),
        None => (None, None),
    };
    // Setting attributes on a fresh exception instance cannot fail in practice; if it did,
    // the message alone is still right.
    let _ = value.setattr("file", &e.file);
    let _ = value.setattr("line", line);
    let _ = value.setattr("column", column);
    let _ = value.setattr("field", e.field.clone());
    let _ = value.setattr("message", &e.message);
    err
}

/// A checkpoint error: `OSError` when the file cannot be read, else `CheckpointError`.
pub fn checkpoint_error(e: &clatter::CheckpointError) -> PyErr {
    match e {
        clatter::CheckpointError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => CheckpointError::new_err(e.to_string()),
    }
}

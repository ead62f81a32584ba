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
    "A run that blew up. `str(e)` is `clatter run`'s report; its parts are the attributes \
     `kind` (\"non_finite\", \"energy_growth\", \"escaped\", \"deep_overlap\" or \
     \"initial_overlap\"), `body`, `step`, `time` and `cause` (the likely cause, in words)."
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

/// A blow-up report as a Python `SimulationError`: `clatter run`'s words, and the report's
/// data as attributes.
pub fn blow_up_error(py: Python<'_>, b: &clatter::BlowUp) -> PyErr {
    use clatter::health::BlowUpKind;
    let err = SimulationError::new_err(b.to_string());
    let value = err.value(py);
    let kind = match &b.kind {
        BlowUpKind::NonFinite => "non_finite",
        BlowUpKind::EnergyGrowth { .. } => "energy_growth",
        BlowUpKind::Escaped { .. } => "escaped",
        BlowUpKind::DeepOverlap { .. } if b.step == 0 => "initial_overlap",
        BlowUpKind::DeepOverlap { .. } => "deep_overlap",
    };
    // As in `scene_error`: setting attributes on a fresh instance does not fail in practice.
    let _ = value.setattr("kind", kind);
    let _ = value.setattr("body", b.body);
    let _ = value.setattr("step", b.step);
    let _ = value.setattr("time", b.time);
    let _ = value.setattr("cause", &b.cause);
    err
}

/// Why stepping stopped, as a Python exception: a blow-up as [`blow_up_error`], a GPU
/// failure as `BackendError`.
pub fn watch_error(py: Python<'_>, e: &clatter_backend::WatchError) -> PyErr {
    match e {
        clatter_backend::WatchError::BlowUp(b) => blow_up_error(py, b),
        #[allow(unreachable_patterns)]
        other => BackendError::new_err(other.to_string()),
    }
}

/// A failure of the GPU device (reading back, uploading) as `BackendError`.
pub fn device_error(e: &clatter_backend::DeviceError) -> PyErr {
    BackendError::new_err(e.to_string())
}

//! The Python exceptions of momo and the mapping of the Rust errors onto them.
//!
//! ```text
//! MomoError                 every error momo raises
//! ├── InputError            a file or sequence directory is missing or malformed
//! │                         (`file:line: reason`; attributes `path`, `line`)
//! ├── ConfigError           a configuration cannot be parsed or a value is out of range
//! ├── RigError              a rig is invalid, or the model/metric does not fit the rig
//! ├── MatchError            the matches given to `process`/`estimate` are malformed
//! ├── EstimationError       a stateless `estimate` found no solution
//! └── SimulationError       an unknown scenario or an invalid simulation setting
//! ```

use momo_io::IoError;
use momo_vo::VoError;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    momo,
    MomoError,
    PyException,
    "Base class of every error momo raises; its message is momo's (`file:line: reason` for files)."
);
create_exception!(
    momo,
    InputError,
    MomoError,
    "A file or sequence directory is missing or malformed (`file:line: reason`). Attributes: `path` (str or None) and `line` (int or None)."
);
create_exception!(
    momo,
    ConfigError,
    MomoError,
    "A configuration cannot be parsed (`name:line: reason`) or a value is out of range."
);
create_exception!(
    momo,
    RigError,
    MomoError,
    "A rig is invalid (no cameras, non-orthonormal extrinsics, bad intrinsics), or the configured model and metric do not fit the rig."
);
create_exception!(
    momo,
    MatchError,
    MomoError,
    "Matches given to `Odometry.process` or `estimate` are malformed: wrong number of cameras, not (N, 4), non-finite, outside the image or not unprojectable."
);
create_exception!(
    momo,
    EstimationError,
    MomoError,
    "A stateless `estimate` found no solution (too few matches, solver failure)."
);
create_exception!(
    momo,
    SimulationError,
    MomoError,
    "An unknown scenario or an invalid simulation setting."
);

/// An [`InputError`] from a file error, with `path` and `line` set.
pub fn input_error(py: Python<'_>, e: &IoError) -> PyErr {
    input_error_at(
        py,
        e.to_string(),
        Some(e.path.display().to_string()),
        e.line,
    )
}

/// An [`InputError`] with a message and, if known, the file and line.
pub fn input_error_at(
    py: Python<'_>,
    message: String,
    path: Option<String>,
    line: Option<usize>,
) -> PyErr {
    let err = InputError::new_err(message);
    let value = err.value(py);
    // Setting attributes on a fresh exception object cannot fail in practice; if it did, the
    // message still carries the file and line.
    let _ = value.setattr("path", path);
    let _ = value.setattr("line", line);
    err
}

/// A [`ConfigError`] from the configuration's error.
pub fn config_error(e: &momo_vo::ConfigError) -> PyErr {
    ConfigError::new_err(e.to_string())
}

/// The exception of a driver error: configuration errors are [`ConfigError`], a model or
/// metric that does not fit the rig is [`RigError`].
pub fn vo_error(e: &VoError) -> PyErr {
    match e {
        VoError::Config(c) => config_error(c),
        VoError::Core(c) => RigError::new_err(c.to_string()),
    }
}

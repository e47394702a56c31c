//! Typed errors of the core crate.

use thiserror::Error;

/// Errors raised when building rigs and problems.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// A rig needs at least one camera.
    #[error("the rig has no cameras")]
    EmptyRig,
    /// The rotation block of `T_vehicle_camera` is not orthonormal with det +1.
    #[error(
        "camera {camera}: T_vehicle_camera rotation is not orthonormal (error {error:.3e}, tolerance 1e-6)"
    )]
    NotOrthonormal {
        /// Camera index.
        camera: usize,
        /// Largest deviation found.
        error: f64,
    },
    /// Parameter vectors of the wrong length.
    #[error("expected {expected} parameters, got {got}")]
    ParameterCount {
        /// What the model needs.
        expected: usize,
        /// What was given.
        got: usize,
    },
    /// Per-match constants given for a problem ([`crate::Problem::with_match_constants`]) whose
    /// length is not the metric's count per match times the matches.
    #[error("expected {expected} per-match constants, got {got}")]
    MatchConstantCount {
        /// The metric's count per match times the matches.
        expected: usize,
        /// What was given.
        got: usize,
    },
    /// The metric cannot handle a camera model of the rig (e.g. a pixel metric on a fisheye).
    #[error("metric `{metric}` does not support camera {camera} ({reason})")]
    UnsupportedCamera {
        /// Metric name.
        metric: String,
        /// Camera index.
        camera: usize,
        /// Why.
        reason: String,
    },
}

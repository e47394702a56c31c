//! # momo-plot
//!
//! Figures for momo, written as PNG or SVG (chosen by the output file's extension) with
//! [plotters](https://docs.rs/plotters), each file written atomically (temporary file + rename):
//!
//! - [`plot_trajectories`]: trajectories seen from above (x against z of camera 0's position,
//!   KITTI camera poses), the ground truth and any number of estimates, with a legend.
//! - [`plot_rotation_errors`]: the frame-to-frame rotation error (degrees,
//!   [`momo_eval::frame_to_frame_rotation_errors`]) over the path length along the ground truth
//!   (upper panel) and over the speed (lower panel); the numbers come from
//!   [`rotation_error_samples`].
//! - [`plot_landscape`]: the cost of one frame pair over a grid of yaw and arc length around the
//!   estimate, as a heat map with the minimum marked (the error landscape of the momo paper);
//!   the grid comes from [`compute_landscape`].
//!
//! Text (captions, axis labels, legends) is drawn with a TrueType font found at run time: the
//! file named by the environment variable `MOMO_PLOT_FONT`, otherwise one of the usual system
//! fonts (DejaVu Sans, Liberation Sans, Arial, ...). Without any font the figures are drawn
//! without text ([`font_available`] says which).
//!
//! ```
//! use momo_core::Pose;
//! use nalgebra::{Matrix3, Vector3};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // A straight ground truth along the camera's z axis and an estimate that drifts to the side.
//! let gt: Vec<Pose<f64>> = (0..50)
//!     .map(|k| Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, k as f64)))
//!     .collect();
//! let est: Vec<Pose<f64>> = (0..50)
//!     .map(|k| Pose::new(Matrix3::identity(), Vector3::new(0.01 * (k * k) as f64, 0.0, k as f64)))
//!     .collect();
//! let dir = tempfile::tempdir()?;
//! let out = dir.path().join("trajectory.svg");
//! momo_plot::plot_trajectories(&gt, &[("estimate", est.as_slice())], &out)?;
//! assert!(std::fs::metadata(&out)?.len() > 0);
//!
//! // Anything but .png or .svg is refused before anything is written.
//! assert!(momo_plot::plot_trajectories(&gt, &[], dir.path().join("t.pdf")).is_err());
//! # Ok(())
//! # }
//! ```

mod errors;
mod landscape;
mod render;
mod trajectory;

pub use errors::{ErrorSample, plot_rotation_errors, rotation_error_samples};
pub use landscape::{Landscape, LandscapeOptions, compute_landscape, plot_landscape};
pub use render::{Format, MAX_FONT_BYTES, font_available};
pub use trajectory::plot_trajectories;

use std::path::PathBuf;
use thiserror::Error;

/// Why a figure could not be made.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The output file name does not end in `.png` or `.svg`.
    #[error("{}: unknown image format (the file name must end in .png or .svg)", .0.display())]
    Format(PathBuf),
    /// The data cannot be plotted (empty, wrong lengths, a frame out of range, ...).
    #[error("{0}")]
    Input(String),
    /// The estimator could not be set up or evaluated (landscapes).
    #[error(transparent)]
    Vo(#[from] momo_vo::VoError),
    /// Evaluating the cost failed (landscapes).
    #[error(transparent)]
    Core(#[from] momo_core::CoreError),
    /// plotters failed to draw.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// Writing the file failed.
    #[error(transparent)]
    Io(#[from] momo_io::IoError),
}

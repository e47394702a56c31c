//! # momo
//!
//! Frame-to-frame vehicle motion from sparse feature matches of one or more cameras, by robust
//! non-linear least squares on motion manifolds. This facade re-exports the workspace's crates so
//! that examples and downstream users need one dependency:
//!
//! | module | crate | holds |
//! | --- | --- | --- |
//! | [`core`] | `momo-core` | traits, poses, cameras, rigs, the problem, AD checks |
//! | [`models`] | `momo-models` | `SingleTrack2d`, `SingleTrack3d`, `Se3`, `register_model!` |
//! | [`costs`] | `momo-costs` | `AnglePlane`, `GeoLine`, `Sampson`; Cauchy, Huber, Tukey |
//! | [`solvers`] | `momo-solvers` | Gauss-Newton, Levenberg-Marquardt, dogleg |
//! | [`io`] | `momo-io` | the sequence format (`FORMAT.md`) |
//! | [`sim`] | `momo-sim` | simulated drives and matches |
//! | [`vo`] | `momo-vo` | the odometry driver, configuration, whole-sequence runs |
//! | [`eval`] | `momo-eval` | ATE, RPE (as evo), KITTI devkit metric, frame-to-frame errors |
//!
//! ```
//! let config = momo::vo::Config::default();
//! assert!(config.to_commented_toml().contains("angle_plane"));
//! ```

pub use momo_core as core;
pub use momo_costs as costs;
pub use momo_eval as eval;
pub use momo_io as io;
pub use momo_models as models;
pub use momo_sim as sim;
pub use momo_solvers as solvers;
pub use momo_vo as vo;

/// The README's Rust example, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// The user guide's Rust examples, compiled and run as doctests.
#[doc = include_str!("../docs/GUIDE.md")]
#[cfg(doctest)]
pub struct GuideDoctests;

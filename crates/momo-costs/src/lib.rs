//! # momo-costs
//!
//! The residual metrics and robust losses of momo ("Momo: Monocular Motion Estimation on
//! Manifolds", Sec. III-A and III-B).
//!
//! Metrics implement [`momo_core::ResidualMetric`] generically over the scalar, so num-dual
//! differentiates them (no hand-written Jacobians), and [`momo_core::MetricSpec`] so that a
//! configuration names them by type tag:
//!
//! | type tag | metric | residuals per match | unit | cameras |
//! | --- | --- | --- | --- | --- |
//! | `angle_plane` | [`AnglePlane`]: `f1ᵀ E f0 / ‖E f0‖` | 1 | sine of an angle | any central camera |
//! | `angle_plane_ml` | [`AnglePlaneMl`]: `angle_plane` over its pixel-noise std (ML weighting) | 1 | radians at the image centre | any central camera |
//! | `angle_plane_ml_rig` | [`AnglePlaneMlRig`]: `angle_plane_ml` with one reference focal length for the rig | 1 | radians at the centre of a camera of the rig's mean focal length | any central camera |
//! | `geo_line` | [`GeoLine`]: pixel distances to both epipolar lines | 2 | pixels | pinhole |
//! | `sampson` | [`Sampson`]: first-order geometric error | 1 | pixels | any (tangent planes off pinhole) |
//!
//! Conventions (`DESIGN.md`): the camera motion `C = [R | t]` is the pose of the camera at frame
//! k in the camera at frame k-1; `f0`, `f1` are the unit bearings of a match in frames k-1 and
//! k; coplanarity is `f1ᵀ E f0 = 0` with `E = Rᵀ [t]ₓ` ([`momo_core::essential`]).
//!
//! Losses implement [`momo_core::RobustLoss`] on the squared residual `s` (Ceres conventions),
//! with their scale `b` in the metric's units: [`Cauchy`] (`cauchy`), [`Huber`] (`huber`),
//! [`Tukey`] (`tukey`), and [`Trivial`] (`trivial`, plain least squares, from core).
//!
//! Canned rigs and matches, the derivative checks of metrics and the focal-length scaling used
//! by them live in the test-support crate `momo-testing`.
//!
//! ```
//! use momo_core::{Pose, ResidualMetric, RobustLoss, camera_motion, so3_exp};
//! use momo_costs::{AnglePlane, GeoLine};
//! use momo_testing::canned;
//! use nalgebra::Vector3;
//!
//! // A loss from a configuration file.
//! let loss: Box<dyn RobustLoss> = toml::from_str("type = \"cauchy\"\nscale = 0.0065").unwrap();
//! assert_eq!(loss.scale(), 0.0065);
//!
//! // Noise-free matches of a 1.2 m motion in a slight left curve, seen by one pinhole camera.
//! let rig = canned::pinhole_rig();
//! let truth = Pose::new(so3_exp(&Vector3::new(0.0, 0.0, 0.05)), Vector3::new(1.2, 0.03, 0.0));
//! let obs = canned::synthetic_observations(&rig, &truth, 20, 0, 1);
//! let cam = &rig.cameras()[0];
//! let c = camera_motion(&truth, &cam.t_vehicle_camera);
//! let (ap, gl) = (AnglePlane.prepare(&cam.model, &c), GeoLine.prepare(&cam.model, &c));
//! for o in &obs.per_camera[0] {
//!     let mut r = [0.0; 2];
//!     AnglePlane.residuals(&ap, o, &mut r[..1]);
//!     assert!(r[0].abs() < 1e-12);
//!     GeoLine.residuals(&gl, o, &mut r);
//!     assert!(r[0].abs() < 1e-9 && r[1].abs() < 1e-9); // pixels
//!     // At the true motion every match is an inlier with weight ρ'(s) ≈ 1.
//!     assert!(loss.evaluate(r[0] * r[0])[1] > 0.999);
//! }
//! ```

mod angle_plane;
mod angle_plane_ml;
mod geo_line;
mod loss;
mod sampson;

pub use angle_plane::AnglePlane;
pub use angle_plane_ml::{
    AnglePlaneMl, AnglePlaneMlPrepared, AnglePlaneMlRig, bearing_covariance,
    bearing_covariance_by_differences,
};
pub use geo_line::{GeoLine, fundamental};
pub use loss::{Cauchy, Huber, Tukey};
pub use momo_core::TrivialLoss as Trivial;
pub use sampson::{Sampson, SampsonPrepared};

/// Added to squared norms in denominators (`sqrt(‖n‖² + NORM_EPS_SQ)`) so that degenerate
/// geometry (a match on the baseline, a standstill) gives finite residuals and derivatives.
pub const NORM_EPS_SQ: f64 = 1e-24;

//! # momo-models
//!
//! The motion manifolds of momo ("Momo: Monocular Motion Estimation on Manifolds", Sec. III-C):
//! low-dimensional parameterisations of the vehicle motion `M = T_{k-1,k}` (the pose of the
//! vehicle at frame k in the vehicle frame at k-1; x forward, y left, z up). Each implements
//! [`momo_core::Manifold`] once, generically over the scalar, and is differentiated by num-dual.
//!
//! | type tag | model | parameters |
//! | --- | --- | --- |
//! | `single_track_2d` | [`SingleTrack2d`]: planar circle (the paper's Eq. (motion_model)) | `yaw`, `arc_length` |
//! | `single_track_3d` | [`SingleTrack3d`]: the circle on a plane tilted by pitch and roll | `yaw`, `arc_length`, `pitch`, `roll` |
//! | `se3` | [`Se3`]: rotation vector, direction of travel, arc length | `rot_x`, `rot_y`, `rot_z`, `heading`, `climb`, `arc_length` |
//!
//! Every model computes its parameters from a motion in closed form
//! ([`Manifold::params_from_motion`](momo_core::Manifold::params_from_motion)).
//!
//! The built-in models are registered as [`momo_core::ModelSpec`] (typetag) with
//! [`register_model!`]; a researcher's model or metric is registered the same way in one line
//! ([`register_model!`], [`register_metric!`], re-exported from `momo-core`), and any
//! registered model pairs with any registered metric. `momo_testing::check_model` checks a
//! model's automatic derivatives against finite differences with every built-in metric
//! (`momo_testing::test_model!` as property tests). This crate depends on `momo-core` only.
//!
//! ```
//! use momo_core::{Manifold, ModelSpec, MetricSpec};
//! use momo_models::SingleTrack2d;
//! use momo_testing::check_model;
//! use momo_costs as _; // the built-in metrics, registered by type tag
//!
//! // Model and metric from a configuration, built into a type-erased estimator.
//! let model: Box<dyn ModelSpec> = toml::from_str("type = \"single_track_3d\"").unwrap();
//! let metric: Box<dyn MetricSpec> = toml::from_str("type = \"angle_plane\"").unwrap();
//! let estimator = model.build(metric.as_ref()).unwrap();
//! assert_eq!(estimator.param_names(), &["yaw", "arc_length", "pitch", "roll"]);
//!
//! // A left curve of 2 m turning by 0.1 rad, and back to its parameters.
//! let m = SingleTrack2d.motion(&[0.1, 2.0]);
//! assert!(m.translation.y > 0.0);
//! let p = SingleTrack2d.params_from_motion(&m).unwrap();
//! assert!((p[0] - 0.1).abs() < 1e-12 && (p[1] - 2.0).abs() < 1e-12);
//!
//! // AD equals finite differences, also exactly at zero yaw.
//! assert!(check_model(&SingleTrack2d, &[0.0, 2.0], 1e-6).is_ok());
//! ```

mod registry;
mod rotation;
mod se3;
mod single_track;
mod soft;

pub use momo_core::{register_metric, register_model};
pub use rotation::{arc_chord, arc_length_from_chord, half_angle_sinc, rot_x, rot_y, rot_z};
pub use se3::Se3;
pub use single_track::{SingleTrack2d, SingleTrack3d, TiltTranslation};
pub use soft::SoftSingleTrack;

/// Re-exported so that a crate defining its own model or metric needs only `momo-models`.
pub use momo_core;
/// Re-exported for `#[serde(crate = "momo_models::serde")]` in crates without their own serde.
pub use serde;

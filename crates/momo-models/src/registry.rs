//! The built-in models' registration ([`momo_core::register_model!`]): each is a
//! [`momo_core::ModelSpec`] under its type tag and pairs with every registered metric.

use crate::{Se3, SingleTrack2d, SingleTrack3d, SoftSingleTrack};

momo_core::register_model!(SingleTrack2d, "single_track_2d");
momo_core::register_model!(SingleTrack3d, "single_track_3d");
momo_core::register_model!(Se3, "se3");
momo_core::register_model!(SoftSingleTrack, "soft_single_track");

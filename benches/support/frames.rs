//! Frames shared by the benches (`matrix`, `evaluations`): a noisy synthetic frame pair with
//! outliers for any rig, and the warm start of a solve.

use momo_core::{CameraModel, FrameEstimator, FrameObservations, ModelSpec, Pose, Rig, so3_exp};
use momo_testing::canned;
use nalgebra::{Vector2, Vector3};

/// The true vehicle motion: 2° of yaw over 1 m with a little pitch and roll.
pub fn truth() -> Pose<f64> {
    let yaw = 2.0_f64.to_radians();
    Pose::new(
        so3_exp(&Vector3::new(0.002, -0.003, yaw)),
        Vector3::new(yaw.cos(), 0.5 * yaw, 0.004),
    )
}

/// The previous frame's motion (the warm start).
pub fn previous() -> Pose<f64> {
    let yaw = 1.6_f64.to_radians();
    Pose::new(
        so3_exp(&Vector3::new(0.0, 0.0, yaw)),
        Vector3::new(yaw.cos(), 0.5 * yaw, 0.0),
    )
}

/// Uniform noise in [-0.5, 0.5) px on the inliers' frame-k pixels (SplitMix64, deterministic).
pub fn add_noise(rig: &Rig, obs: &mut FrameObservations, inliers: usize, seed: u64) {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for (cam, list) in rig.cameras().iter().zip(obs.per_camera.iter_mut()) {
        for o in list.iter_mut().take(inliers) {
            let px1 = o.px1 + Vector2::new(next(), next());
            if let Some(f1) = cam.model.unproject(&px1) {
                o.px1 = px1;
                o.f1 = f1;
            }
        }
    }
}

/// `n` matches per camera of the rig (90 % inliers with noise, 10 % outliers).
pub fn frame(rig: &Rig, n: usize, seed: u64) -> FrameObservations {
    let outliers = n / 10;
    let mut obs = canned::synthetic_observations(rig, &truth(), n - outliers, outliers, seed);
    add_noise(rig, &mut obs, n - outliers, seed ^ 0xABCD);
    obs
}

/// Warm start (the previous motion's parameters, the true arc length) and the fixed mask.
pub fn start(est: &dyn FrameEstimator) -> (Vec<f64>, Vec<bool>) {
    let arc = truth().translation.norm();
    let mut init = est
        .params_from_motion(&previous())
        .unwrap_or_else(|| est.initial_params(arc));
    let mut fixed = vec![false; init.len()];
    if let Some(i) = est.arc_length_index() {
        init[i] = arc;
        fixed[i] = true;
    }
    (init, fixed)
}

/// The two target cases: the default model on one pinhole camera with 300 matches, and
/// `SingleTrack3d` on four fisheye cameras x 100 matches (name, rig, model, matches per camera).
pub fn target_cases() -> [(&'static str, Rig, Box<dyn ModelSpec>, usize); 2] {
    [
        (
            "default_pinhole_300",
            canned::pinhole_rig(),
            Box::new(momo_models::Se3),
            300,
        ),
        (
            "single_track_3d_fisheye4x100",
            canned::fisheye_rig(),
            Box::new(momo_models::SingleTrack3d::default()),
            100,
        ),
    ]
}

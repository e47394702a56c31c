//! Metric scale from cross-camera matches (`FORMAT.md` version 5): a stereo rig without
//! odometry measures the arc length from its left(k-1)-right(k) and right(k-1)-left(k)
//! matches; where those matches carry no information the scale is held, never estimated.

use momo_core::{
    CameraModel, CrossObservation, FrameObservations, Observation, Pose, Rig, RigCamera,
    cross_camera_motion,
};
use momo_testing::canned;
use momo_vo::{Config, FrameStatus, Odometry, ScaleSource};
use nalgebra::{Vector2, Vector3};

use crate::support;
use support::*;

/// KITTI-like stereo: the forward-looking camera 1 m ahead, 1.65 m up, and a second one 0.54 m
/// to its right.
fn stereo_rig() -> Rig {
    let model = momo_core::Camera::Pinhole(canned::kitti_pinhole());
    let left = Pose::new(canned::forward_looking(), Vector3::new(1.0, 0.0, 1.65));
    let right = Pose::new(canned::forward_looking(), Vector3::new(1.0, -0.54, 1.65));
    Rig::new(vec![
        RigCamera {
            name: "left".into(),
            model,
            t_vehicle_camera: left,
        },
        RigCamera {
            name: "right".into(),
            model,
            t_vehicle_camera: right,
        },
    ])
    .expect("valid rig")
}

/// `n` cross-camera matches of camera `i` (frame k-1) with camera `j` (frame k) under `motion`,
/// with pixel noise `noise`; a share `outliers` of them replaced by random pixels.
fn cross(
    rig: &Rig,
    (i, j): (usize, usize),
    motion: &Pose<f64>,
    n: usize,
    noise: f64,
    outliers: f64,
    rng: &mut Rng,
) -> Vec<CrossObservation> {
    let cams = rig.cameras();
    let (mi, mj) = (cams[i].model, cams[j].model);
    let c = cross_camera_motion(motion, &cams[i].t_vehicle_camera, &cams[j].t_vehicle_camera);
    let (w, h) = mi.size();
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let px = Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0));
        let Some(f) = mi.unproject(&px) else { continue };
        let x0 = f.normalize() * rng.uniform(4.0, 40.0);
        let x1 = c.inverse().transform_point(&x0);
        let Some(p1) = mj.project(&x1) else { continue };
        if x1.z < 0.5 || !mj.contains(&p1, 0.0) {
            continue;
        }
        let p0 = px + Vector2::new(rng.gauss(), rng.gauss()) * noise;
        let p1 = if rng.uniform(0.0, 1.0) < outliers {
            Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0))
        } else {
            p1 + Vector2::new(rng.gauss(), rng.gauss()) * noise
        };
        let (Some(f0), Some(f1)) = (mi.unproject(&p0), mj.unproject(&p1)) else {
            continue;
        };
        out.push(CrossObservation {
            camera: i,
            camera_to: j,
            obs: Observation {
                px0: p0,
                px1: p1,
                f0,
                f1,
            },
        });
    }
    out
}

fn stereo_frame(
    rig: &Rig,
    motion: &Pose<f64>,
    outliers: f64,
    cross_outliers: f64,
    rng: &mut Rng,
) -> FrameObservations {
    let mut obs = frame(rig, motion, 100, 0.5, rng);
    obs.cross_camera = cross(rig, (0, 1), motion, 100, 0.5, cross_outliers, rng);
    obs.cross_camera
        .extend(cross(rig, (1, 0), motion, 100, 0.5, cross_outliers, rng));
    // Outliers among the per-camera matches too: random pixels in frame k.
    for list in &mut obs.per_camera {
        let n = list.len();
        for o in list.iter_mut().take((outliers * n as f64) as usize) {
            let px1 = Vector2::new(rng.uniform(0.0, 1240.0), rng.uniform(0.0, 375.0));
            if let Some(f1) = rig.cameras()[0].model.unproject(&px1) {
                o.px1 = px1;
                o.f1 = f1;
            }
        }
    }
    obs
}

/// A drive that speeds up, turns and slows down: the arc length goes from 0.4 to 1.6 m per
/// frame, never given to the estimator.
fn truth(k: usize) -> Pose<f64> {
    let l = 1.0 + 0.6 * (k as f64 * 0.3).sin();
    let yaw = if (8..16).contains(&k) { 0.04 } else { 0.0 };
    drive(yaw, l)
}

///
/// Run with the free model `se3` (worst frame 1.5-2.3 % over seeds 1-3) and with the default
/// `soft_single_track` (since 2026-11-24) and the final stage (`[odometry.final_fit]`): its side-slip prior couples the direction of travel
/// with the yaw while the arc length is measured, and the worst frame of seed 3 is 3.3 % off
/// (5.7 % without the final stage); the path and the calibration of the sigma hold for both.
#[test]
fn stereo_without_odometry_measures_the_arc_length() {
    for free in [true, false] {
        stereo_scale_run(free);
    }
}

fn stereo_scale_run(free: bool) {
    for seed in [1, 2, 3] {
        let rig = stereo_rig();
        let mut rng = Rng(seed);
        let mut config = Config::default();
        if free {
            config.model = Box::new(momo_models::Se3);
        } else {
            // As measured (3.3 % at worst); without the final stage 5.7 %.
            config.odometry.final_fit.enabled = true;
        }
        let mut vo = Odometry::new(rig.clone(), config).expect("valid");
        let i = vo.estimator().arc_length_index().expect("arc length");
        let (mut estimated, mut worst, mut total, mut travelled) = (0, 0.0_f64, 0.0, 0.0);
        let (mut within_3_sigma, mut z2) = (0, 0.0);
        for k in 0..24 {
            let m = truth(k);
            let l = m.translation.norm(); // close to the arc length for these small yaws
            let r = vo.process(&stereo_frame(&rig, &m, 0.2, 0.2, &mut rng), None);
            assert_eq!(r.diagnostics.status, FrameStatus::Estimated, "frame {k}");
            let d = &r.diagnostics;
            if d.scale == ScaleSource::Estimated {
                estimated += 1;
                let err = (r.motion.translation.norm() - l).abs();
                worst = worst.max(err / l);
                z2 += (err / d.param_sigmas[i]).powi(2);
                if err <= 3.0 * d.param_sigmas[i] {
                    within_3_sigma += 1;
                }
                assert!(d.param_sigmas[i] > 0.0 && d.param_sigmas[i] < 0.2 * d.params[i]);
            } else {
                assert_eq!(d.scale, ScaleSource::Held, "frame {k}");
            }
            total += r.motion.translation.norm();
            travelled += l;
        }
        eprintln!(
            "seed {seed}: {estimated}/24 estimated, worst arc length error {:.2} %, path {:.2} % off, {within_3_sigma} within 3 sigma, mean (err/sigma)^2 {:.2}",
            100.0 * worst,
            100.0 * (total / travelled - 1.0),
            z2 / estimated.max(1) as f64
        );
        assert!(estimated >= 22, "{estimated}");
        if free {
            assert!(worst < 0.03, "{worst}");
        } else {
            assert!(
                worst < 0.04,
                "soft default: {worst} (measured 0.033 at most)"
            );
        }
        assert!((total / travelled - 1.0).abs() < 0.01);
        assert!(within_3_sigma * 10 >= estimated * 8, "{within_3_sigma}");
    }
}

/// Cross-camera matches that are all outliers measure nothing: the scale is held (the last
/// value), not estimated.
#[test]
fn cross_camera_matches_without_information_hold_the_scale() {
    let rig = stereo_rig();
    let mut rng = Rng(5);
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    for k in 0..4 {
        let r = vo.process(&stereo_frame(&rig, &truth(k), 0.0, 0.0, &mut rng), None);
        assert_eq!(r.diagnostics.scale, ScaleSource::Estimated);
    }
    for k in 4..8 {
        let r = vo.process(&stereo_frame(&rig, &truth(k), 0.0, 1.0, &mut rng), None);
        assert_eq!(r.diagnostics.scale, ScaleSource::Held, "frame {k}");
        assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
    }
}

/// Reversing: a negative arc length in odometry.csv drives backwards; without odometry a stereo
/// rig's cross-camera matches give the sign. Forward at 1 m per frame, slowing down, then
/// backwards up to 1 m per frame.
#[test]
fn reversing_is_signed_with_odometry_and_measured_without() {
    let rig = stereo_rig();
    let plan = |k: usize| match k {
        0..5 => 1.0,
        5 => 0.6,
        6 => 0.3,
        7 => -0.3,
        8 => -0.6,
        _ => -1.0,
    };
    for with_odometry in [true, false] {
        let mut rng = Rng(11);
        let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
        let mut backwards = 0;
        for k in 0..14 {
            let l = plan(k);
            let m = drive(if k >= 9 { -0.03 } else { 0.0 }, l);
            let obs = stereo_frame(&rig, &m, 0.1, 0.1, &mut rng);
            let r = vo.process(&obs, with_odometry.then_some(l));
            let err = (r.motion.translation - m.translation).norm();
            eprintln!(
                "odometry {with_odometry}, frame {k}: arc {l:+.2} m, estimated x {:+.3} m, error {err:.3} m, {:?}/{:?}",
                r.motion.translation.x, r.diagnostics.status, r.diagnostics.scale
            );
            if with_odometry {
                assert_eq!(r.diagnostics.scale, ScaleSource::Odometry);
                assert!(err < 0.02, "frame {k}: {err}");
            } else if r.diagnostics.scale == ScaleSource::Estimated {
                assert!(err < 0.05 * l.abs().max(0.3), "frame {k}: {err}");
            }
            // Backwards motion comes out backwards, in every frame with a scale.
            if l < 0.0 && r.diagnostics.scale != ScaleSource::Held {
                assert!(r.motion.translation.x < 0.0, "frame {k}");
                backwards += 1;
            }
        }
        assert_eq!(
            backwards, 7,
            "every reversing frame has a measured, negative arc length"
        );
    }
}

/// A mono rig without odometry (the camera 1 m ahead of the motion centre): in a curve its
/// arc length shows only through the lever arm and the soft model's side-slip prior
/// (`side_slip_sigma` 0.01 rad). A tight turn (0.1 rad per frame), 0.1 px noise, and the car
/// slips by half a prior sigma: every frame's scale is `estimated`, with a sigma that covers
/// its error (mean (err/σ)² 0.26-0.28). Before, the calibrated covariance scaled the prior's
/// information by `(s/σ)²` (here about 50x: the residuals are far below the loss scale) and
/// this test failed (KITTI 01 mono: errors up to -78 % at a 3.5 % sigma). Not covered: a slip
/// of 1.5 prior sigmas at 0.04 rad per frame (errors of 2.6-4.3 σ, 31-46 %, seed 2): there
/// the prior itself is wrong.
#[test]
fn mono_scale_is_estimated_only_with_a_sigma_that_covers_its_error() {
    let rig = Rig::mono(
        momo_core::Camera::Pinhole(canned::kitti_pinhole()),
        Pose::new(canned::forward_looking(), Vector3::new(1.0, 0.0, 1.65)),
    )
    .expect("valid rig");
    // The lever-arm estimate alone: the road's arc length (`odometry.road_scale_frames`, on by
    // default) off, as before its first value.
    for seed in [1, 2] {
        let mut rng = Rng(seed);
        let mut config = Config::default();
        config.odometry.road_scale_frames = 0;
        let mut vo = Odometry::new(rig.clone(), config).expect("valid");
        let i = vo.estimator().arc_length_index().expect("arc length");
        let (mut estimated, mut z2) = (0, 0.0);
        for k in 0..24 {
            let (yaw, l, slip): (f64, f64, f64) = (0.1, 1.0 + 0.02 * k as f64, 0.005);
            let h = 0.5 * yaw + slip;
            let (s, c) = yaw.sin_cos();
            let m = Pose::new(
                nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
                Vector3::new(h.cos(), h.sin(), 0.0) * l,
            );
            let r = vo.process(&frame(&rig, &m, 200, 0.1, &mut rng), None);
            let d = &r.diagnostics;
            if d.scale != ScaleSource::Estimated {
                assert_eq!(d.scale, ScaleSource::Held, "frame {k}");
                continue;
            }
            estimated += 1;
            let (err, sigma) = (d.params[i] - l, d.param_sigmas[i]);
            eprintln!(
                "seed {seed}, frame {k}: arc {l:.2} m, error {err:+.3} m, sigma {sigma:.3} m"
            );
            assert!(
                err.abs() <= 3.0 * sigma,
                "frame {k}: error {err} m, sigma {sigma} m"
            );
            z2 += (err / sigma).powi(2);
        }
        eprintln!(
            "seed {seed}: {estimated}/24 estimated, mean (err/sigma)^2 {:.2}",
            z2 / estimated.max(1) as f64
        );
    }
}

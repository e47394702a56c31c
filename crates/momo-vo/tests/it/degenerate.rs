//! The odometry driver's documented behaviour on degenerate frames: no matches, standstill,
//! a blinded camera, a solver failure, a sharp change of motion, and scale with and without a
//! lever arm.

use momo_core::{Camera, FrameObservations, Manifold, Observation, Pose, Rig, RigCamera, so3_log};
use momo_models::{Se3, SingleTrack2d};
use momo_testing::canned;
use momo_vo::{Config, FrameStatus, Odometry, ScaleSource};
use nalgebra::{Vector2, Vector3};

fn yaw_of(p: &Pose<f64>) -> f64 {
    p.rotation[(1, 0)].atan2(p.rotation[(0, 0)])
}

fn rot_err_deg(a: &Pose<f64>, b: &Pose<f64>) -> f64 {
    so3_log(&(a.rotation.transpose() * b.rotation))
        .norm()
        .to_degrees()
}

fn motion(yaw: f64, l: f64) -> Pose<f64> {
    SingleTrack2d.motion(&[yaw, l])
}

#[test]
fn a_frame_without_matches_holds_the_previous_motion_and_says_so() {
    let rig = canned::pinhole_rig();
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    let truth = motion(0.02, 1.0);
    let r1 = vo.process(
        &canned::synthetic_observations(&rig, &truth, 200, 0, 1),
        Some(1.0),
    );
    assert_eq!(r1.diagnostics.status, FrameStatus::Estimated);
    let r2 = vo.process(&FrameObservations::new(1), Some(1.2));
    assert_eq!(r2.diagnostics.status, FrameStatus::NoMatches);
    assert_eq!(r2.diagnostics.matches, 0);
    assert!(
        (yaw_of(&r2.motion) - yaw_of(&r1.motion)).abs() < 1e-12,
        "rotation held"
    );
    // The arc length of this frame comes from odometry.
    let l = r2.diagnostics.params[Se3::PARAMS.len() - 1];
    assert!((l - 1.2).abs() < 1e-12);
}

#[test]
fn standstill_estimates_rotation_only_with_zero_translation() {
    let rig = canned::pinhole_rig();
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    vo.process(
        &canned::synthetic_observations(&rig, &motion(0.0, 1.0), 200, 0, 1),
        Some(1.0),
    );
    // The vehicle stands and turns its wheels... or the camera shakes: a small pure rotation.
    let truth = Pose::new(
        momo_core::so3_exp(&Vector3::new(0.0005, -0.001, 0.002)),
        Vector3::zeros(),
    );
    let obs = canned::synthetic_observations(&rig, &truth, 200, 20, 2);
    let r = vo.process(&obs, Some(0.0));
    assert_eq!(r.diagnostics.status, FrameStatus::Standstill);
    assert!(
        r.motion.translation.norm() < 1e-12,
        "{}",
        r.motion.translation
    );
    assert!(
        rot_err_deg(&r.motion, &truth) < 0.01,
        "{}",
        rot_err_deg(&r.motion, &truth)
    );
    // Moving again: the warm start keeps the last moving arc length.
    let r = vo.process(
        &canned::synthetic_observations(&rig, &motion(0.01, 1.0), 200, 0, 3),
        Some(1.0),
    );
    assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
    assert!(rot_err_deg(&r.motion, &motion(0.01, 1.0)) < 0.01);
}

#[test]
fn a_blinded_camera_is_outvoted_by_the_others() {
    let rig = canned::fisheye_rig();
    let truth = motion(0.03, 1.0);
    let mut obs = canned::synthetic_observations(&rig, &truth, 120, 0, 4);
    // Camera 1 sees only garbage: every match displaced by tens of pixels.
    let cam = rig.cameras()[1].model;
    obs.per_camera[1] = obs.per_camera[1]
        .iter()
        .enumerate()
        .filter_map(|(i, o)| {
            let d = Vector2::new(25.0 + (i % 7) as f64 * 5.0, -30.0 + (i % 5) as f64 * 12.0);
            Observation::new(&cam, o.px0, o.px1 + d)
        })
        .collect();
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    let r = vo.process(&obs, Some(1.0));
    assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
    let err = rot_err_deg(&r.motion, &truth);
    assert!(err < 0.01, "rotation error {err} deg");
    let inl = &r.diagnostics.inliers_per_camera;
    assert!(inl[1] < 10, "blinded camera inliers {inl:?}");
    assert!(inl[0] > 100 && inl[2] > 100 && inl[3] > 100, "{inl:?}");
}

#[test]
fn a_solver_failure_keeps_the_prior_and_is_flagged() {
    let rig = canned::pinhole_rig();
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    let r1 = vo.process(
        &canned::synthetic_observations(&rig, &motion(0.02, 1.0), 200, 0, 1),
        Some(1.0),
    );
    // Non-finite bearings (which the reader never produces) make the cost NaN.
    let mut bad = canned::synthetic_observations(&rig, &motion(0.02, 1.0), 50, 0, 2);
    for o in &mut bad.per_camera[0] {
        o.f1 = Vector3::new(f64::NAN, 0.0, 1.0);
    }
    let r2 = vo.process(&bad, Some(1.0));
    assert_eq!(r2.diagnostics.status, FrameStatus::SolverFailure);
    assert!(r2.motion.rotation.iter().all(|v| v.is_finite()));
    assert!(rot_err_deg(&r2.motion, &r1.motion) < 1e-9, "prior kept");
}

#[test]
fn a_sharp_turn_after_straight_driving_is_found() {
    let rig = canned::pinhole_rig();
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    for k in 0..5 {
        vo.process(
            &canned::synthetic_observations(&rig, &motion(0.0, 1.0), 200, 40, k),
            Some(1.0),
        );
    }
    // 6 degrees of yaw in one frame, far from the warm start.
    let truth = motion(6.0_f64.to_radians(), 1.0);
    let r = vo.process(
        &canned::synthetic_observations(&rig, &truth, 200, 40, 9),
        Some(1.0),
    );
    let err = rot_err_deg(&r.motion, &truth);
    eprintln!(
        "sharp turn: error {err:.4} deg, restarts {}",
        r.diagnostics.restarts
    );
    assert!(err < 0.05, "rotation error {err} deg");
}

fn centred_rig() -> Rig {
    let cam = Camera::Pinhole(canned::kitti_pinhole());
    Rig::new(vec![RigCamera {
        name: "centre".into(),
        model: cam,
        t_vehicle_camera: Pose::new(canned::forward_looking(), Vector3::zeros()),
    }])
    .expect("valid")
}

#[test]
fn without_odometry_scale_is_estimated_in_curves_with_a_lever_arm_and_held_otherwise() {
    // A forward camera 1.5 m ahead of the motion centre: in a curve it moves sideways. The
    // road's arc length (`odometry.road_scale_frames`) is off here: this is the estimate it
    // falls back on before the road gives one.
    let rig = canned::pinhole_rig();
    let mut config = Config {
        model: Box::new(SingleTrack2d),
        ..Default::default()
    };
    config.odometry.road_scale_frames = 0;
    let mut vo = Odometry::new(rig.clone(), config).expect("valid");
    assert!(vo.scale_observable());
    let truth = motion(0.15, 1.5);
    let r = vo.process(
        &canned::synthetic_observations(&rig, &truth, 300, 0, 5),
        None,
    );
    eprintln!(
        "estimated arc length {:?} ({:?})",
        r.diagnostics.params, r.diagnostics.scale
    );
    assert_eq!(r.diagnostics.scale, ScaleSource::Estimated);
    assert!(
        (r.diagnostics.params[1] - 1.5).abs() < 0.15,
        "{:?}",
        r.diagnostics.params
    );
    // Straight ahead the lever arm shows nothing: the last value is held.
    let r = vo.process(
        &canned::synthetic_observations(&rig, &motion(0.0, 2.0), 300, 0, 6),
        None,
    );
    assert_eq!(r.diagnostics.scale, ScaleSource::Held);
    assert!((r.diagnostics.params[1] - 1.5).abs() < 0.15);
    // With the road's arc length on (the default), the first frame has no road history yet:
    // it holds `initial_arc_length` (`odometry.road_scale_initial_metric`, the default), or
    // falls back on the same estimate without it.
    let first = |initial_metric: bool| {
        let mut config = Config {
            model: Box::new(SingleTrack2d),
            ..Default::default()
        };
        config.odometry.road_scale_initial_metric = initial_metric;
        let initial = config.odometry.initial_arc_length;
        let mut vo = Odometry::new(rig.clone(), config).expect("valid");
        let r = vo.process(
            &canned::synthetic_observations(&rig, &truth, 300, 0, 5),
            None,
        );
        (r.diagnostics, initial)
    };
    let (d, initial) = first(true);
    assert_eq!(d.scale, ScaleSource::Held);
    assert_eq!(d.params[1], initial);
    let (d, _) = first(false);
    assert_eq!(d.scale, ScaleSource::Estimated);
    assert!((d.params[1] - 1.5).abs() < 0.15);

    // A camera in the motion centre never observes scale: always held, and the driver says so
    // (scale `unobservable`, distinct from `held` in a straight stretch).
    let rig = centred_rig();
    let config = Config {
        model: Box::new(SingleTrack2d),
        ..Default::default()
    };
    let mut vo = Odometry::new(rig.clone(), config).expect("valid");
    assert!(!vo.scale_observable());
    let r = vo.process(
        &canned::synthetic_observations(&rig, &motion(0.15, 1.5), 300, 0, 7),
        None,
    );
    assert_eq!(r.diagnostics.scale, ScaleSource::Unobservable);
    assert!((yaw_of(&r.motion) - 0.15).abs() < 1e-3);
}

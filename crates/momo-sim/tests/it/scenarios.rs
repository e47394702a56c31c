//! The named presets and drives along imported camera trajectories.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{Pose, essential};
use momo_sim::*;
use nalgebra::{Matrix3, Vector3};
use std::path::PathBuf;

fn max_dev(a: &Pose<f64>, b: &Pose<f64>) -> f64 {
    (a.to_homogeneous() - b.to_homogeneous()).amax()
}

#[test]
fn every_scenario_is_valid_and_deterministic() {
    assert_eq!(SimConfig::SCENARIOS.len(), 12);
    for name in SimConfig::SCENARIOS {
        let cfg = SimConfig::scenario(name).unwrap_or_else(|| panic!("{name} has no preset"));
        cfg.validate(&cfg.rig.rig())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let cfg = SimConfig { frames: 25, ..cfg };
        let a = simulate(&cfg).unwrap();
        assert_eq!(a, simulate(&cfg).unwrap(), "{name}");
        assert_ne!(
            a,
            simulate(&SimConfig { seed: 7, ..cfg }).unwrap(),
            "{name}"
        );
        assert_eq!(a.sequence.num_frames(), 25, "{name}");
    }
    assert_eq!(
        SimConfig::scenario("clean_pinhole"),
        Some(SimConfig::clean_pinhole())
    );
    assert_eq!(SimConfig::scenario("sparse"), None);
    assert_eq!(SimConfig::scenario(""), None);
}

/// Matches per frame pair and outlier fraction over all frame pairs of camera 0.
fn counts(sim: &Simulation) -> (Vec<usize>, f64) {
    let per_frame: Vec<usize> = sim.labels[1..].iter().map(|l| l[0].len()).collect();
    let total: usize = per_frame.iter().sum();
    let outliers = sim.labels[1..]
        .iter()
        .flat_map(|l| l[0].iter())
        .filter(|l| **l == MatchLabel::Outlier)
        .count();
    (per_frame, outliers as f64 / total.max(1) as f64)
}

#[test]
fn sparse_outliers_has_about_100_matches_and_30_percent_outliers() {
    let sim = simulate(&SimConfig {
        frames: 40,
        ..SimConfig::sparse_outliers()
    })
    .unwrap();
    let (n, ratio) = counts(&sim);
    assert!(n.iter().all(|&n| (90..=100).contains(&n)), "{n:?}");
    assert!((ratio - 0.3).abs() < 0.02, "{ratio}");
}

#[test]
fn very_sparse_has_30_to_50_matches() {
    let sim = simulate(&SimConfig {
        frames: 40,
        ..SimConfig::very_sparse()
    })
    .unwrap();
    let (n, _) = counts(&sim);
    assert!(n.iter().all(|&n| (30..=50).contains(&n)), "{n:?}");
    // Noise-free inliers still satisfy the epipolar constraint.
    let sim = simulate(&SimConfig {
        frames: 10,
        pixel_noise: 0.0,
        ..SimConfig::very_sparse()
    })
    .unwrap();
    let e = essential(&sim.camera_motion(5, 0));
    for (o, l) in sim.sequence.frames[5].per_camera[0]
        .iter()
        .zip(&sim.labels[5][0])
    {
        if *l == MatchLabel::Inlier {
            assert!((o.f1.transpose() * e * o.f0)[0].abs() < 1e-9);
        }
    }
}

#[test]
fn highway_is_fast_with_gentle_curves() {
    for seed in 0..3 {
        let sim = simulate(&SimConfig {
            frames: 600,
            seed,
            ..SimConfig::highway()
        })
        .unwrap();
        assert!(
            sim.speeds.iter().all(|v| (24.5..=30.0).contains(v)),
            "seed {seed}: speeds {:?}",
            sim.speeds
                .iter()
                .fold((f64::MAX, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
        );
        for k in 1..sim.vehicle_motions.len() {
            let m = &sim.vehicle_motions[k];
            let yaw_rate = m.rotation[(1, 0)].atan2(m.rotation[(0, 0)]).abs() * 10.0;
            // Lateral acceleration v · yaw rate at most about 1 m/s².
            assert!(
                yaw_rate * sim.speeds[k] <= 1.2,
                "seed {seed} frame {k}: {yaw_rate}"
            );
            assert!(sim.true_arc_lengths[k] >= 2.4 && sim.true_arc_lengths[k] <= 3.0);
        }
        let (n, _) = counts(&sim);
        assert!(
            n.iter().all(|&n| n >= 250),
            "seed {seed}: too few matches at speed"
        );
    }
}

fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// Camera-0 poses (KITTI convention: y down, z forward) of a car on a left curve that also
/// climbs a little: built from vehicle poses, so any rig's camera 0 works.
fn curve_camera_poses(n: usize, p0: &Pose<f64>) -> Vec<Pose<f64>> {
    let vehicle: Vec<Pose<f64>> = (0..n)
        .map(|k| {
            let s = k as f64;
            let yaw = 0.01 * s;
            Pose::new(
                rz(yaw),
                Vector3::new(100.0 * yaw.sin(), 100.0 * (1.0 - yaw.cos()), 0.02 * s),
            )
        })
        .collect();
    camera_poses_from_vehicle_poses(&vehicle, p0)
}

#[test]
fn vehicle_and_camera_poses_are_inverse_conversions() {
    for rig in [RigPreset::KittiMono, RigPreset::SurroundFisheye] {
        let p0 = rig.rig().cameras()[0].t_vehicle_camera;
        let cams = curve_camera_poses(30, &p0);
        let vehicle = vehicle_poses_from_camera_poses(&cams, &p0);
        let back = camera_poses_from_vehicle_poses(&vehicle, &p0);
        for (c, b) in cams.iter().zip(&back) {
            assert!(max_dev(c, b) < 1e-12);
        }
        // The vehicle frame is x forward, z up: the vehicle moves along +x at first.
        let step = vehicle[1].translation - vehicle[0].translation;
        assert!(step.x > 0.9 && step.z.abs() < 0.05, "{step:?}");
    }
}

#[test]
fn a_simulation_along_camera_poses_reproduces_them() {
    let p0 = kitti_mono().cameras()[0].t_vehicle_camera;
    let cams = curve_camera_poses(50, &p0);
    let cfg = SimConfig {
        frames: 40,
        pixel_noise: 0.0,
        camera_trajectory: Some(cams.clone()),
        ..SimConfig::clean_pinhole()
    };
    let sim = simulate(&cfg).unwrap();
    assert_eq!(sim.sequence.num_frames(), 40, "min(frames, poses)");
    let gt = sim.sequence.ground_truth.as_ref().unwrap();
    for k in 0..40 {
        // The first camera pose is the identity, so the ground truth is the input.
        assert!(max_dev(&gt[k], &cams[k]) < 1e-9, "frame {k}");
        // And the vehicle poses map back onto the camera poses.
        let back = camera_poses_from_vehicle_poses(&sim.vehicle_poses[k..=k], &p0);
        assert!(max_dev(&back[0], &cams[k]) < 1e-9, "frame {k}");
    }
    for k in 1..40 {
        assert!((sim.true_arc_lengths[k] - 1.0).abs() < 1e-3);
        assert!((sim.speeds[k] - 10.0).abs() < 1e-2);
        let e = essential(&sim.camera_motion(k, 0));
        for o in &sim.sequence.frames[k].per_camera[0] {
            assert!((o.f1.transpose() * e * o.f0)[0].abs() < 1e-9);
        }
    }
    // Fewer poses than frames: the trajectory decides.
    let short = simulate(&SimConfig {
        frames: 400,
        ..cfg.clone()
    })
    .unwrap();
    assert_eq!(short.sequence.num_frames(), 50);
    // Deterministic.
    assert_eq!(simulate(&cfg).unwrap(), sim);
    // Invalid trajectories are refused.
    for bad in [
        Vec::new(),
        vec![Pose::new(Matrix3::identity() * 2.0, Vector3::zeros())],
    ] {
        let cfg = SimConfig {
            camera_trajectory: Some(bad),
            ..SimConfig::default()
        };
        assert!(matches!(simulate(&cfg), Err(SimError::InvalidConfig(_))));
    }
}

#[test]
fn kitti_00_ground_truth_as_a_trajectory() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/kitti_odometry_gt/poses/00.txt");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let cams = momo_io::read_poses(&path).unwrap();
    let cfg = SimConfig {
        frames: 200,
        camera_trajectory: Some(cams.clone()),
        ..SimConfig::sparse_outliers()
    };
    let sim = simulate(&cfg).unwrap();
    assert_eq!(sim.sequence.num_frames(), 200);
    let p0 = kitti_mono().cameras()[0].t_vehicle_camera;
    let back = camera_poses_from_vehicle_poses(&sim.vehicle_poses, &p0);
    let gt = sim.sequence.ground_truth.as_ref().unwrap();
    let c0_inv = cams[0].inverse();
    for k in 0..200 {
        // KITTI's first pose is the identity up to the file's rounding (7 digits, so the
        // rotations are orthonormal to about 1e-7 only).
        let expected = c0_inv.compose(&cams[k]);
        let close = |a: &Pose<f64>| {
            (a.rotation - expected.rotation).amax() < 1e-5
                && (a.translation - expected.translation).amax()
                    < 1e-5 * (1.0 + expected.translation.norm())
        };
        assert!(close(&back[k]), "frame {k}");
        assert!(close(&gt[k]), "frame {k}");
    }
    // KITTI 00 starts driving forward at about 8.6 m/s.
    assert!((sim.speeds[1] - 8.6).abs() < 0.2, "{}", sim.speeds[1]);
}

/// [`along_travel`]: a camera pitched 1° nose down against its straight travel, driven as a
/// level camera, makes the vehicle climb out of its road plane by that angle every frame pair;
/// turned by its travel elevation first, the vehicle travels along its x axis (its road).
#[test]
fn a_trajectory_turned_along_its_travel_keeps_the_vehicle_on_its_road() {
    let pitch = momo_core::so3_exp(&Vector3::new(-1f64.to_radians(), 0.0, 0.0));
    let cams: Vec<Pose<f64>> = (0..30)
        .map(|k| Pose::new(pitch, Vector3::new(0.0, 0.0, 1.2 * k as f64)))
        .collect();
    let climb = |cams: Vec<Pose<f64>>| -> f64 {
        let sim = simulate(&SimConfig {
            frames: 20,
            camera_trajectory: Some(cams),
            ..SimConfig::clean_pinhole()
        })
        .unwrap();
        // The largest climb of a frame pair's translation above the vehicle's x-y plane.
        sim.vehicle_motions[1..]
            .iter()
            .map(|m| (m.translation.z / m.translation.norm()).asin().abs())
            .fold(0.0, f64::max)
            .to_degrees()
    };
    let as_given = climb(cams.clone());
    let (turned, theta) = along_travel(&cams);
    assert!(
        (theta.to_degrees() - 1.0).abs() < 1e-9,
        "{}",
        theta.to_degrees()
    );
    let along = climb(turned);
    assert!((as_given - 1.0).abs() < 0.01, "as given: {as_given} deg");
    assert!(along < 1e-6, "turned: {along} deg");
}

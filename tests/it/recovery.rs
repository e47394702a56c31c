//! Recovery tests on synthetic matches made here: every model x metric x solver recovers a
//! known motion exactly from noise-free matches, and the yaw to 0.05 degrees from matches with
//! 1 px noise and 30 % random outliers (Cauchy loss), on one pinhole camera and on a 4-camera
//! fisheye rig without overlap whose cameras sit away from the motion centre.

use momo::core::{
    Camera, CameraModel, FrameEstimator, FrameObservations, MetricSpec, ModelSpec, Observation,
    Rig, RobustLoss, SolveRequest, Solver,
};
use momo::costs::{AnglePlane, Cauchy, GeoLine, Sampson};
use momo::models::{Se3, SingleTrack2d, SingleTrack3d};
use momo::solvers::{Dogleg, GaussNewton, LevenbergMarquardt};
use momo_testing::canned;
use nalgebra::Vector2;
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::{Distribution, Normal};

/// (name, estimator, true parameters, start parameters).
type Case = (&'static str, Box<dyn FrameEstimator>, Vec<f64>, Vec<f64>);

/// One case per model with `metric`.
fn cases(metric: &dyn MetricSpec) -> Vec<Case> {
    vec![
        (
            "single_track_2d",
            SingleTrack2d.build(metric).expect("built-in"),
            vec![0.035, 1.1],
            vec![0.02, 1.1],
        ),
        (
            "single_track_3d",
            SingleTrack3d::default().build(metric).expect("built-in"),
            vec![0.035, 1.1, 0.004, -0.003],
            vec![0.02, 1.1, 0.0, 0.0],
        ),
        (
            "se3",
            Se3.build(metric).expect("built-in"),
            vec![0.003, -0.002, 0.035, 0.02, -0.004, 1.1],
            vec![0.0, 0.0, 0.02, 0.0, 0.0, 1.1],
        ),
    ]
}

fn arc_fixed(est: &dyn FrameEstimator) -> Vec<bool> {
    let mut fixed = vec![false; est.param_names().len()];
    if let Some(i) = est.arc_length_index() {
        fixed[i] = true;
    }
    fixed
}

fn solve(
    est: &dyn FrameEstimator,
    rig: &Rig,
    obs: &FrameObservations,
    loss: &dyn RobustLoss,
    solver: &dyn Solver,
    init: &[f64],
) -> Vec<f64> {
    let fixed = arc_fixed(est);
    est.solve(&SolveRequest {
        rig,
        observations: obs,
        loss,
        solver,
        initial: init,
        fixed: &fixed,
        rotation_only: false,
        motion_prior: None,
    })
    .expect("solvable")
    .params
}

fn solvers() -> Vec<(&'static str, Box<dyn Solver>)> {
    vec![
        ("gauss_newton", Box::new(GaussNewton::default())),
        (
            "levenberg_marquardt",
            Box::new(LevenbergMarquardt::default()),
        ),
        ("dogleg", Box::new(Dogleg::default())),
    ]
}

#[test]
fn noise_free_matches_give_the_exact_motion_for_every_model_metric_and_solver() {
    let metrics: Vec<(&str, Box<dyn MetricSpec>)> = vec![
        ("angle_plane", Box::new(AnglePlane)),
        ("geo_line", Box::new(GeoLine)),
        ("sampson", Box::new(Sampson)),
    ];
    let rig = canned::pinhole_rig();
    for (mname, metric) in &metrics {
        for (model, est, truth, start) in cases(metric.as_ref()) {
            let obs = canned::synthetic_observations(&rig, &est.motion(&truth), 150, 0, 11);
            for (sname, solver) in solvers() {
                let loss = momo::core::TrivialLoss;
                let p = solve(est.as_ref(), &rig, &obs, &loss, solver.as_ref(), &start);
                let err = p
                    .iter()
                    .zip(&truth)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(
                    err < 1e-8,
                    "{model} x {mname} x {sname}: error {err:e}, {p:?} vs {truth:?}"
                );
            }
        }
    }
}

/// Adds Gaussian pixel noise (σ px, both frames) and replaces `outliers` of the matches by a
/// random pixel within ±60 px of the true one.
fn corrupt(
    rig: &Rig,
    obs: &FrameObservations,
    sigma: f64,
    outliers: f64,
    seed: u64,
) -> FrameObservations {
    let mut rng = StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma).expect("valid sigma");
    let mut out = FrameObservations::new(rig.len());
    for (j, list) in obs.per_camera.iter().enumerate() {
        let cam: &Camera = &rig.cameras()[j].model;
        for o in list {
            let mut px0 = o.px0 + Vector2::new(noise.sample(&mut rng), noise.sample(&mut rng));
            let mut px1 = o.px1 + Vector2::new(noise.sample(&mut rng), noise.sample(&mut rng));
            if rng.random_bool(outliers) {
                px1 += Vector2::new(rng.random_range(-60.0..60.0), rng.random_range(-60.0..60.0));
            }
            if !cam.contains(&px1, 0.0) || !cam.contains(&px0, 0.0) {
                px0 = o.px0;
                px1 = o.px1;
            }
            out.per_camera[j].extend(Observation::new(cam, px0, px1));
        }
    }
    out
}

/// Yaw of a motion in degrees (rotation about the vehicle's z axis).
fn yaw_deg(est: &dyn FrameEstimator, p: &[f64]) -> f64 {
    let r = est.motion(p).rotation;
    r[(1, 0)].atan2(r[(0, 0)]).to_degrees()
}

fn noisy_recovery(rig: &Rig, matches: usize, label: &str) {
    // AnglePlane, Cauchy at 0.003 rad (1 px is 1.4e-3 rad at f = 718 px, 3e-3 at f = 330 px).
    let loss = Cauchy::new(0.003);
    const SEEDS: u64 = 20;
    for (model, est, truth, start) in cases(&AnglePlane) {
        for (sname, solver) in solvers() {
            let mut errors = Vec::new();
            for seed in 0..SEEDS {
                let clean = canned::synthetic_observations(
                    rig,
                    &est.motion(&truth),
                    matches,
                    0,
                    100 + seed,
                );
                let obs = corrupt(rig, &clean, 1.0, 0.3, seed);
                let p = solve(est.as_ref(), rig, &obs, &loss, solver.as_ref(), &start);
                errors.push((yaw_deg(est.as_ref(), &p) - yaw_deg(est.as_ref(), &truth)).abs());
            }
            let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
            let max = errors.iter().copied().fold(0.0, f64::max);
            eprintln!(
                "{label}: {model} x {sname}: yaw error rms {rms:.4} max {max:.4} deg over {SEEDS} frames"
            );
            assert!(
                rms < 0.05,
                "{label}: {model} x {sname}: rms yaw error {rms} deg"
            );
            if model == "single_track_2d" {
                // The paper's model: every single frame within 0.05 degrees.
                assert!(
                    max < 0.05,
                    "{label}: {model} x {sname}: max yaw error {max} deg"
                );
            }
        }
    }
}

#[test]
fn one_pinhole_camera_with_noise_and_outliers_gets_yaw_within_0_05_degrees() {
    noisy_recovery(&canned::pinhole_rig(), 300, "pinhole");
}

#[test]
fn four_fisheye_cameras_away_from_the_motion_centre_get_yaw_within_0_05_degrees() {
    let rig = canned::fisheye_rig();
    assert_eq!(rig.len(), 4);
    assert!(
        rig.cameras()
            .iter()
            .all(|c| c.t_vehicle_camera.translation.norm() > 0.5)
    );
    noisy_recovery(&rig, 150, "fisheye rig");
}

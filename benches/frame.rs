//! Criterion benchmarks of one frame: 300 matches, one pinhole camera (KITTI intrinsics),
//! warm-started from the previous motion.
//!
//! - `frame/default_single_track_2d`: the reference case — `SingleTrack2d` with known arc
//!   length, AnglePlane, Cauchy, Levenberg-Marquardt (target: median under 100 µs);
//! - `combos/...`: every metric x loss x solver with the same model and data.
//!
//! Run with `cargo bench --bench frame`.

use criterion::{Criterion, criterion_group, criterion_main};
use momo_core::{
    Camera, FrameEstimator, FrameObservations, MetricSpec, ModelSpec, Observation, Pinhole, Pose,
    Rig, RobustLoss, SolveRequest, Solver,
};
use nalgebra::{Matrix3, Vector2, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};
use std::hint::black_box;
use std::time::Duration;

fn kitti_rig() -> Rig {
    let cam = Camera::Pinhole(Pinhole {
        fx: 718.856,
        fy: 718.856,
        cx: 607.1928,
        cy: 185.2157,
        width: 1241.0,
        height: 376.0,
    });
    let p = Pose::new(
        Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
        Vector3::new(1.0, 0.0, 1.65),
    );
    Rig::mono(cam, p).expect("valid rig")
}

/// 300 matches of a curve (yaw 2°, 1 m) with 0.5 px noise and 10 % outliers.
fn frame(rig: &Rig, motion: &Pose<f64>, n: usize, seed: u64) -> FrameObservations {
    let mut rng = StdRng::seed_from_u64(seed);
    let cam = &rig.cameras()[0];
    let c = momo_core::camera_motion(motion, &cam.t_vehicle_camera);
    let c_inv = c.inverse();
    let mut obs = FrameObservations::new(1);
    use momo_core::CameraModel;
    while obs.per_camera[0].len() < n {
        let px0 = Vector2::new(rng.random_range(0.0..1241.0), rng.random_range(0.0..376.0));
        let Some(f0) = cam.model.unproject(&px0) else {
            continue;
        };
        let depth = rng.random_range(4.0..60.0);
        let p1 = c_inv.transform_point(&(f0 * depth));
        let Some(mut px1) = cam.model.project(&p1) else {
            continue;
        };
        if !cam.model.contains(&px1, 0.0) {
            continue;
        }
        px1 += Vector2::new(rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
        if rng.random_bool(0.1) {
            px1 += Vector2::new(rng.random_range(-40.0..40.0), rng.random_range(-40.0..40.0));
        }
        if let Some(o) = Observation::new(&cam.model, px0, px1) {
            obs.per_camera[0].push(o);
        }
    }
    obs
}

fn solve(
    est: &dyn FrameEstimator,
    rig: &Rig,
    obs: &FrameObservations,
    loss: &dyn RobustLoss,
    solver: &dyn Solver,
    init: &[f64],
    fixed: &[bool],
) -> f64 {
    let req = SolveRequest {
        rig,
        observations: obs,
        loss,
        solver,
        initial: init,
        fixed,
        rotation_only: false,
        motion_prior: None,
    };
    est.solve(&req).expect("solvable").params[0]
}

fn benches(c: &mut Criterion) {
    let rig = kitti_rig();
    let model = momo_models::SingleTrack2d;
    let truth = [2.0_f64.to_radians(), 1.0];
    let motion = momo_core::Manifold::motion(&model, &truth);
    let obs = frame(&rig, &motion, 300, 7);
    // Warm start: the previous frame's motion (a slightly different yaw).
    let init = [1.6_f64.to_radians(), 1.0];
    let fixed = [false, true];

    let metrics: Vec<(&str, Box<dyn MetricSpec>, f64)> = vec![
        ("angle_plane", Box::new(momo_costs::AnglePlane), 0.002),
        ("geo_line", Box::new(momo_costs::GeoLine), 1.5),
        ("sampson", Box::new(momo_costs::Sampson), 1.5),
    ];
    let solvers: Vec<(&str, Box<dyn Solver>)> = vec![
        ("lm", Box::new(momo_solvers::LevenbergMarquardt::default())),
        ("gn", Box::new(momo_solvers::GaussNewton::default())),
        ("dogleg", Box::new(momo_solvers::Dogleg::default())),
    ];

    {
        let est = model.build(metrics[0].1.as_ref()).expect("registered");
        let loss = momo_costs::Cauchy::new(0.002);
        c.bench_function("frame/default_single_track_2d_300", |b| {
            b.iter(|| {
                black_box(solve(
                    est.as_ref(),
                    &rig,
                    &obs,
                    &loss,
                    solvers[0].1.as_ref(),
                    &init,
                    &fixed,
                ))
            })
        });
    }

    let mut group = c.benchmark_group("combos");
    group
        .sample_size(30)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_millis(1200));
    for (mname, metric, scale) in &metrics {
        let est = model.build(metric.as_ref()).expect("registered");
        let losses: Vec<(&str, Box<dyn RobustLoss>)> = vec![
            ("trivial", Box::new(momo_costs::Trivial)),
            ("cauchy", Box::new(momo_costs::Cauchy::new(*scale))),
            ("huber", Box::new(momo_costs::Huber::new(*scale))),
            ("tukey", Box::new(momo_costs::Tukey::new(*scale * 3.0))),
        ];
        for (lname, loss) in &losses {
            for (sname, solver) in &solvers {
                group.bench_function(format!("{mname}/{lname}/{sname}"), |b| {
                    b.iter(|| {
                        black_box(solve(
                            est.as_ref(),
                            &rig,
                            &obs,
                            loss.as_ref(),
                            solver.as_ref(),
                            &init,
                            &fixed,
                        ))
                    })
                });
            }
        }
    }
    group.finish();
}

criterion_group!(frame_benches, benches);
criterion_main!(frame_benches);

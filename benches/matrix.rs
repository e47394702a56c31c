//! Criterion benchmarks of one frame pair for every model x metric x loss x solver, at 100, 300
//! and 1,000 matches per camera, on one pinhole camera and on a four-camera fisheye rig
//! (`momo_testing::canned`), plus the issue's two speed targets and the "floor" (one evaluation
//! of the residuals, one linearisation).
//!
//! Data: a curve with a little pitch and roll (yaw 2°, 1 m), 90 % noise-free inliers with
//! 0.5 px of uniform noise added, 10 % off-epipolar outliers (3 to 30 px); the arc length is
//! known (held fixed, as with odometry) and the solve is warm-started from the previous frame's
//! motion (yaw 1.6°, no pitch or roll). Loss scales: 0.001 rad for angle_plane (the default),
//! 1 px for geo_line and sampson; Tukey at 3x that. geo_line needs a pinhole camera, so it is
//! not benchmarked on the fisheye rig.
//!
//! Names: `targets/...`, `floor/...`, `matrix/{rig}/{matches}/{model}/{metric}/{loss}/{solver}`
//! with rig `pinhole` or `fisheye4` and matches per camera. Filter as usual:
//!
//! ```text
//! cargo bench --bench matrix -- targets                 # the speed targets only
//! cargo bench --bench matrix -- 'matrix/fisheye4/100/'  # one slice of the matrix
//! cargo bench --bench matrix                            # everything (about 10 minutes)
//! ```
//!
//! The matrix uses few samples and short measurement times (10 samples, 0.1 s warm-up, 0.3 s
//! measurement) so that the whole matrix runs in minutes: read it for regressions and orders
//! of magnitude; the `targets` group measures longer.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use momo_core::{
    FrameEstimator, FrameObservations, LeastSquares, MetricSpec, ModelSpec, Problem, Rig,
    RobustLoss, SolveRequest, Solver,
};
use momo_testing::canned;
use std::hint::black_box;
use std::time::Duration;

#[path = "support/frames.rs"]
mod frames;
use frames::{frame, start, target_cases, truth};

/// Everything one benchmark needs.
struct Case<'a> {
    est: &'a dyn FrameEstimator,
    rig: &'a Rig,
    obs: &'a FrameObservations,
    loss: &'a dyn RobustLoss,
    solver: &'a dyn Solver,
    init: Vec<f64>,
    fixed: Vec<bool>,
}

impl Case<'_> {
    fn solve(&self) -> Option<f64> {
        let req = SolveRequest {
            rig: self.rig,
            observations: self.obs,
            loss: self.loss,
            solver: self.solver,
            initial: &self.init,
            fixed: &self.fixed,
            rotation_only: false,
            motion_prior: None,
        };
        self.est.solve(&req).ok().map(|s| s.params[0])
    }
}

fn models() -> Vec<(&'static str, Box<dyn ModelSpec>)> {
    vec![
        ("se3", Box::new(momo_models::Se3)),
        ("single_track_2d", Box::new(momo_models::SingleTrack2d)),
        (
            "single_track_3d",
            Box::new(momo_models::SingleTrack3d::default()),
        ),
    ]
}

/// Metric, its loss scale, whether it needs a pinhole camera.
fn metrics() -> Vec<(&'static str, Box<dyn MetricSpec>, f64, bool)> {
    vec![
        (
            "angle_plane",
            Box::new(momo_costs::AnglePlane),
            0.001,
            false,
        ),
        ("geo_line", Box::new(momo_costs::GeoLine), 1.0, true),
        ("sampson", Box::new(momo_costs::Sampson), 1.0, false),
    ]
}

fn losses(scale: f64) -> Vec<(&'static str, Box<dyn RobustLoss>)> {
    vec![
        ("trivial", Box::new(momo_costs::Trivial)),
        ("cauchy", Box::new(momo_costs::Cauchy::new(scale))),
        ("huber", Box::new(momo_costs::Huber::new(scale))),
        ("tukey", Box::new(momo_costs::Tukey::new(3.0 * scale))),
    ]
}

fn solvers() -> Vec<(&'static str, Box<dyn Solver>)> {
    vec![
        ("lm", Box::new(momo_solvers::LevenbergMarquardt::default())),
        ("gn", Box::new(momo_solvers::GaussNewton::default())),
        ("dogleg", Box::new(momo_solvers::Dogleg::default())),
    ]
}

/// The issue's targets, measured longer: the default configuration on one pinhole camera with
/// 300 matches, and `SingleTrack3d` on four fisheye cameras x 100 matches; both through the
/// estimator (`FrameEstimator::solve`) and through the whole driver (`Odometry::process`:
/// restarts check, covariance, diagnostics), warm-started by a previous frame.
fn targets(c: &mut Criterion) {
    let mut group = c.benchmark_group("targets");
    group
        .sample_size(60)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let cases = target_cases();
    let loss = momo_costs::Cauchy::new(0.001);
    let solver = momo_solvers::LevenbergMarquardt::default();
    for (name, rig, model, n) in cases {
        let obs = frame(&rig, n, 7);
        let prev = frame(&rig, n, 8);
        let est = model.build(&momo_costs::AnglePlane).expect("registered");
        let (init, fixed) = start(est.as_ref());
        let case = Case {
            est: est.as_ref(),
            rig: &rig,
            obs: &obs,
            loss: &loss,
            solver: &solver,
            init,
            fixed,
        };
        assert!(case.solve().is_some(), "{name}: solvable");
        group.bench_function(format!("{name}/solve"), |b| {
            b.iter(|| black_box(case.solve()))
        });

        // The whole driver: a primed odometry (one previous frame) processes the frame.
        let config_toml = format!(
            "[model]\ntype = \"{}\"\n[metric]\ntype = \"angle_plane\"\n[loss]\ntype = \"cauchy\"\nscale = 0.001\n[solver]\ntype = \"levenberg_marquardt\"\n",
            model.typetag_name()
        );
        let arc = truth().translation.norm();
        group.bench_function(format!("{name}/odometry"), |b| {
            b.iter_batched(
                || {
                    let config = momo_vo::Config::from_toml_str(&config_toml, "bench")
                        .expect("valid config");
                    let mut vo = momo_vo::Odometry::new(rig.clone(), config).expect("fits");
                    vo.process(&prev, Some(arc));
                    vo
                },
                |mut vo| black_box(vo.process(&obs, Some(arc)).motion),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

/// The floor of the default case: one evaluation of all residuals and the loss (`cost`), and
/// one robustified linearisation (residuals, Jacobians by num-dual, normal equations).
fn floor(c: &mut Criterion) {
    let mut group = c.benchmark_group("floor");
    group
        .sample_size(60)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let loss = momo_costs::Cauchy::new(0.001);
    let pin = canned::pinhole_rig();
    let fish = canned::fisheye_rig();
    let (obs_pin, obs_fish) = (frame(&pin, 300, 7), frame(&fish, 100, 7));

    let est = momo_models::Se3
        .build(&momo_costs::AnglePlane)
        .expect("built-in");
    let (init, fixed) = start(est.as_ref());
    let p = Problem::new(
        &momo_models::Se3,
        &momo_costs::AnglePlane,
        &loss,
        &pin,
        &obs_pin,
        &init,
    )
    .expect("fits")
    .with_fixed(&fixed);
    let x = p.free_params();
    group.bench_function("default_pinhole_300/cost", |b| {
        b.iter(|| black_box(p.cost(black_box(&x))))
    });
    group.bench_function("default_pinhole_300/linearize", |b| {
        b.iter(|| black_box(p.linearize(black_box(&x)).cost))
    });

    let st3 = momo_models::SingleTrack3d::default();
    let est = st3.build(&momo_costs::AnglePlane).expect("built-in");
    let (init, fixed) = start(est.as_ref());
    let p = Problem::new(
        &st3,
        &momo_costs::AnglePlane,
        &loss,
        &fish,
        &obs_fish,
        &init,
    )
    .expect("fits")
    .with_fixed(&fixed);
    let x = p.free_params();
    group.bench_function("single_track_3d_fisheye4x100/cost", |b| {
        b.iter(|| black_box(p.cost(black_box(&x))))
    });
    group.bench_function("single_track_3d_fisheye4x100/linearize", |b| {
        b.iter(|| black_box(p.linearize(black_box(&x)).cost))
    });
    group.finish();
}

/// Every model x metric x loss x solver x match count x rig.
fn matrix(c: &mut Criterion) {
    let mut group = c.benchmark_group("matrix");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(100))
        .measurement_time(Duration::from_millis(300));
    let rigs = [
        ("pinhole", canned::pinhole_rig()),
        ("fisheye4", canned::fisheye_rig()),
    ];
    let solvers = solvers();
    for (rig_name, rig) in &rigs {
        let pinhole = rig.cameras().iter().all(|c| c.model.as_pinhole().is_some());
        for n in [100, 300, 1000] {
            let obs = frame(rig, n, 7);
            for (model_name, model) in models() {
                for (metric_name, metric, scale, needs_pinhole) in metrics() {
                    if needs_pinhole && !pinhole {
                        continue;
                    }
                    let est = model.build(metric.as_ref()).expect("built-in pair");
                    let (init, fixed) = start(est.as_ref());
                    for (loss_name, loss) in losses(scale) {
                        for (solver_name, solver) in &solvers {
                            let case = Case {
                                est: est.as_ref(),
                                rig,
                                obs: &obs,
                                loss: loss.as_ref(),
                                solver: solver.as_ref(),
                                init: init.clone(),
                                fixed: fixed.clone(),
                            };
                            let id = format!(
                                "{rig_name}/{n}/{model_name}/{metric_name}/{loss_name}/{solver_name}"
                            );
                            if case.solve().is_none() {
                                eprintln!("matrix/{id}: does not solve, skipped");
                                continue;
                            }
                            group.bench_function(id, |b| b.iter(|| black_box(case.solve())));
                        }
                    }
                }
            }
        }
    }
    group.finish();
}

criterion_group!(benches, targets, floor, matrix);
criterion_main!(benches);

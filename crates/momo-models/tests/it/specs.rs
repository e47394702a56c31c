//! Configuration trait objects: serde round trips, building every model with every metric, and
//! an end-to-end solve of the built estimators.

use momo_core::{
    CoreError, FrameEstimator, LeastSquares, MetricSpec, ModelSpec, ParamVec, RobustLoss,
    SolveRequest, Solver, SolverReport, Termination, solve_normal_equations,
};
use momo_costs::{AnglePlane, Cauchy, GeoLine, Sampson, Trivial};
use momo_models::{Se3, SingleTrack2d, SingleTrack3d, TiltTranslation};
use momo_testing::canned;

/// A model spec, its parameter names and a parameter vector.
type Case = (Box<dyn ModelSpec>, &'static [&'static str], Vec<f64>);

fn models() -> Vec<Case> {
    vec![
        (
            Box::new(SingleTrack2d),
            &["yaw", "arc_length"],
            vec![0.05, 1.2],
        ),
        (
            Box::new(SingleTrack3d::default()),
            &["yaw", "arc_length", "pitch", "roll"],
            vec![0.05, 1.2, 0.01, -0.005],
        ),
        (
            Box::new(SingleTrack3d::new(TiltTranslation::Planar)),
            &["yaw", "arc_length", "pitch", "roll"],
            vec![0.05, 1.2, 0.01, -0.005],
        ),
        (
            Box::new(Se3),
            &["rot_x", "rot_y", "rot_z", "heading", "climb", "arc_length"],
            vec![0.01, -0.02, 0.05, 0.03, 0.01, 1.2],
        ),
    ]
}

fn metrics() -> Vec<Box<dyn MetricSpec>> {
    vec![Box::new(AnglePlane), Box::new(GeoLine), Box::new(Sampson)]
}

#[test]
fn models_round_trip_through_json_and_toml() {
    for (m, _, _) in models() {
        let j = serde_json::to_string(&m).unwrap();
        let back: Box<dyn ModelSpec> = serde_json::from_str(&j).unwrap();
        assert_eq!(format!("{back:?}"), format!("{m:?}"), "{j}");
        let t = toml::to_string(&m).unwrap();
        let back: Box<dyn ModelSpec> = toml::from_str(&t).unwrap();
        assert_eq!(format!("{back:?}"), format!("{m:?}"), "{t}");
    }
    let m: Box<dyn ModelSpec> = serde_json::from_str(r#"{"type": "se3"}"#).unwrap();
    assert_eq!(format!("{m:?}"), format!("{Se3:?}"));
    let m: Box<dyn ModelSpec> = toml::from_str("type = \"single_track_2d\"").unwrap();
    assert_eq!(format!("{m:?}"), format!("{SingleTrack2d:?}"));
    let m: Box<dyn ModelSpec> =
        toml::from_str("type = \"single_track_3d\"\ntranslation = \"planar\"").unwrap();
    assert_eq!(
        format!("{m:?}"),
        format!("{:?}", SingleTrack3d::new(TiltTranslation::Planar))
    );
    let m: Box<dyn ModelSpec> = toml::from_str("type = \"single_track_3d\"").unwrap();
    assert_eq!(format!("{m:?}"), format!("{:?}", SingleTrack3d::default()));
    for bad in [
        r#"{"type": "single_track_3d", "translation": "sideways"}"#,
        r#"{"type": "single_track_3d", "planar": true}"#,
        r#"{"type": "bicycle"}"#,
    ] {
        assert!(
            serde_json::from_str::<Box<dyn ModelSpec>>(bad).is_err(),
            "{bad}"
        );
    }
}

#[test]
fn losses_metrics_and_models_in_one_config() {
    #[derive(serde::Deserialize)]
    struct Config {
        model: Box<dyn ModelSpec>,
        metric: Box<dyn MetricSpec>,
        loss: Box<dyn RobustLoss>,
    }
    let c: Config = toml::from_str(
        "[model]\ntype = \"se3\"\n[metric]\ntype = \"angle_plane\"\n[loss]\ntype = \"cauchy\"\nscale = 0.0065\n",
    )
    .unwrap();
    assert_eq!(c.loss.scale(), 0.0065);
    let e = c.model.build(c.metric.as_ref()).unwrap();
    assert_eq!(e.param_names().len(), 6);
}

#[test]
fn every_model_builds_with_every_metric() {
    for (m, names, p) in models() {
        for r in metrics() {
            let e = m.build(r.as_ref()).unwrap();
            assert_eq!(e.param_names(), names, "{m:?} x {r:?}");
            let arc = names.iter().position(|n| *n == "arc_length");
            assert_eq!(e.arc_length_index(), arc);
            // The erased estimator is the model.
            let q = e.params_from_motion(&e.motion(&p)).unwrap();
            assert!(
                q.iter().zip(&p).all(|(a, b)| (a - b).abs() < 1e-12),
                "{q:?} vs {p:?}"
            );
            assert_eq!(e.initial_params(2.0)[arc.unwrap()], 2.0);
        }
    }
}

/// A small Gauss-Newton, only to drive the built estimators end to end in this test.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct TestGaussNewton;

#[typetag::serde(name = "test_gauss_newton")]
impl Solver for TestGaussNewton {
    fn solve(&self, problem: &dyn LeastSquares, x0: &ParamVec) -> SolverReport {
        let n = problem.num_params();
        let mut x = *x0;
        let initial_cost = problem.cost(&x);
        let mut lin = problem.linearize(&x);
        let mut iterations = 0;
        let mut termination = Termination::MaxIterations;
        while iterations < 50 {
            iterations += 1;
            let Some(dx) = solve_normal_equations(&lin.hessian, &lin.gradient, n, 1e-9, true)
            else {
                termination = Termination::NumericalFailure;
                break;
            };
            x += dx;
            lin = problem.linearize(&x);
            if dx.norm() < 1e-12 {
                termination = Termination::StepConverged;
                break;
            }
        }
        SolverReport {
            x,
            num_params: n,
            initial_cost,
            final_cost: lin.cost,
            iterations,
            termination,
            normal_matrix: lin.hessian,
        }
    }
}

/// Built estimators solve a noise-free frame: every model recovers its own motion from a
/// nearby start with every metric on the pinhole rig, and with AnglePlane / Sampson on the
/// fisheye rig; GeoLine on the fisheye rig is a typed error.
#[test]
fn built_estimators_solve_noise_free_frames() {
    let loss = Cauchy::new(1.0);
    let solver = TestGaussNewton;
    for rig in [canned::pinhole_rig(), canned::fisheye_rig()] {
        for (m, _, truth) in models() {
            for r in metrics() {
                let e: Box<dyn FrameEstimator> = m.build(r.as_ref()).unwrap();
                let obs = canned::synthetic_observations(&rig, &e.motion(&truth), 40, 0, 5);
                let mut start = truth.clone();
                start[0] += 0.01;
                let arc = e.arc_length_index().unwrap();
                let mut fixed = vec![false; truth.len()];
                fixed[arc] = true; // arc length from odometry
                let req = SolveRequest {
                    rig: &rig,
                    observations: &obs,
                    loss: &loss,
                    solver: &solver,
                    initial: &start,
                    fixed: &fixed,
                    rotation_only: false,
                    motion_prior: None,
                };
                let is_fisheye = rig.cameras()[0].model.as_pinhole().is_none();
                if is_fisheye && r.typetag_name() == "geo_line" {
                    let err = e.solve(&req).unwrap_err();
                    assert!(matches!(err, CoreError::UnsupportedCamera { .. }), "{err}");
                    continue;
                }
                assert!(e.cost(&req, &truth).unwrap() < 1e-20, "{m:?} x {r:?}");
                assert!(e.cost(&req, &start).unwrap() > 1e-8, "{m:?} x {r:?}");
                let sol = e.solve(&req).unwrap();
                let err = sol
                    .params
                    .iter()
                    .zip(&truth)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(
                    err < 1e-7,
                    "{m:?} x {r:?} on {} cameras: {:?} vs {truth:?}",
                    rig.len(),
                    sol.params
                );
                assert_eq!(sol.inliers(), obs.len());
                assert!(!sol.free.contains(&arc));
            }
        }
    }
    // The trivial loss, too.
    let e = SingleTrack2d.build(&AnglePlane).unwrap();
    let rig = canned::pinhole_rig();
    let obs = canned::synthetic_observations(&rig, &e.motion(&[0.05, 1.2]), 20, 0, 9);
    let req = SolveRequest {
        rig: &rig,
        observations: &obs,
        loss: &Trivial,
        solver: &solver,
        initial: &[0.0, 1.2],
        fixed: &[false, true],
        rotation_only: false,
        motion_prior: None,
    };
    assert!((e.solve(&req).unwrap().params[0] - 0.05).abs() < 1e-9);
}

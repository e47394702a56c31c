//! The registration macros used the way a researcher's crate uses them: only `momo_models`
//! paths (serde through `momo_models::serde`, typetag brought in by the macros).

use momo_costs::{AnglePlane, GeoLine, Sampson};
use momo_models::momo_core::nalgebra::{Matrix3, Vector3};
use momo_models::momo_core::{
    Camera, Manifold, MetricSpec, ModelSpec, Observation, Pose, ResidualMetric, Scalar, essential,
};
use momo_models::serde::{Deserialize, Serialize};
use momo_models::{Se3, SingleTrack2d, SingleTrack3d, register_metric, register_model};
use momo_testing::check_model;

/// A researcher's model: the single-track circle with a constant side slip angle β.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(crate = "momo_models::serde")]
struct SlipTrack {
    slip: f64,
}

impl Manifold for SlipTrack {
    const PARAMS: &'static [&'static str] = &["yaw", "arc_length"];
    const ARC_LENGTH: Option<usize> = Some(1);
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        let m = SingleTrack2d.motion(p);
        let t = momo_models::rot_z(T::c(self.slip)) * m.translation;
        Pose::new(m.rotation, t)
    }
}

/// A researcher's metric: the algebraic error `f1ᵀ E f0` (not normalised).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(crate = "momo_models::serde")]
struct Algebraic;

impl ResidualMetric for Algebraic {
    const RESIDUALS: usize = 1;
    type Prepared<T: Scalar> = Matrix3<T>;
    fn prepare<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>) -> Matrix3<T> {
        essential(motion)
    }
    fn residuals<T: Scalar>(&self, e: &Matrix3<T>, obs: &Observation, out: &mut [T]) {
        out[0] = obs.f1.map(T::c).dot(&(e * obs.f0.map(T::c)));
    }
}

/// A second researcher model.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(crate = "momo_models::serde")]
struct Forward;

impl Manifold for Forward {
    const PARAMS: &'static [&'static str] = &["arc_length"];
    const ARC_LENGTH: Option<usize> = Some(0);
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        Pose::new(
            Matrix3::identity(),
            Vector3::new(p[0], T::zero(), T::zero()),
        )
    }
}

register_model!(SlipTrack, "test_slip_track");
register_model!(Forward, "test_forward");
register_metric!(Algebraic, "test_algebraic");

#[test]
fn a_registered_model_builds_from_config_with_every_builtin_metric() {
    let spec: Box<dyn ModelSpec> =
        serde_json::from_str(r#"{"type": "test_slip_track", "slip": 0.02}"#).unwrap();
    for metric in [&AnglePlane as &dyn MetricSpec, &GeoLine, &Sampson] {
        let e = spec.build(metric).unwrap();
        assert_eq!(e.param_names(), &["yaw", "arc_length"]);
        let t = e.motion(&[0.0, 1.0]).translation;
        assert!((t.y - 0.02f64.sin()).abs() < 1e-15);
    }
    let t = toml::to_string(&spec).unwrap();
    assert!(
        t.contains("type = \"test_slip_track\"") && t.contains("slip = 0.02"),
        "{t}"
    );
    // and its derivatives are right
    check_model(&SlipTrack { slip: 0.02 }, &[0.1, 1.0], 1e-6).unwrap();
    check_model(&SlipTrack { slip: 0.02 }, &[0.0, 1.0], 1e-6).unwrap();
}

#[test]
fn a_registered_metric_builds_with_every_builtin_model() {
    let metric: Box<dyn MetricSpec> = toml::from_str("type = \"test_algebraic\"").unwrap();
    let models: [(Box<dyn ModelSpec>, usize); 3] = [
        (Box::new(SingleTrack2d), 2),
        (Box::new(SingleTrack3d::default()), 4),
        (Box::new(Se3), 6),
    ];
    for (m, n) in models {
        let e = m.build(metric.as_ref()).unwrap();
        assert_eq!(e.param_names().len(), n);
    }
}

#[test]
fn any_researcher_model_meets_any_researcher_metric() {
    // Neither knows the other: they meet at the erased motion (`MetricSpec::estimator`).
    let algebraic: Box<dyn MetricSpec> = Box::new(Algebraic);
    let e = Forward.build(algebraic.as_ref()).unwrap();
    assert_eq!(e.param_names(), &["arc_length"]);
    assert!(Forward.build(&AnglePlane).is_ok());
    let e = SlipTrack { slip: 0.02 }.build(algebraic.as_ref()).unwrap();
    assert_eq!(e.param_names(), &["yaw", "arc_length"]);
    let t = e.motion(&[0.0, 1.0]).translation;
    assert!((t.y - 0.02f64.sin()).abs() < 1e-15);
    // From configurations too.
    let model: Box<dyn ModelSpec> =
        serde_json::from_str(r#"{"type": "test_slip_track", "slip": 0.02}"#).unwrap();
    let metric: Box<dyn MetricSpec> = toml::from_str("type = \"test_algebraic\"").unwrap();
    assert_eq!(model.build(metric.as_ref()).unwrap().param_names().len(), 2);
}

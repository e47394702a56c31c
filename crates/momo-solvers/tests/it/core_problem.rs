//! The solvers on real `momo_core::Problem`s (dual-number linearisation, robust loss through
//! Ceres' corrector): a pure rotation seen through the `RotationOnly` metric.

#![allow(clippy::unwrap_used)]

use crate::common;

use common::{defaults, pv, tight};
use momo_core::nalgebra::{Vector2, Vector3};
use momo_core::{
    Camera, FrameObservations, LeastSquares, Manifold, Observation, Pinhole, Pose, Problem, Rig,
    RobustLoss, RotationOnly, Scalar, Termination, TrivialLoss, so3_exp,
};
use serde::{Deserialize, Serialize};

/// A rotation `exp([rx, ry, rz])` and a forward translation by the arc length, which the
/// `RotationOnly` metric does not see (a flat direction of the cost).
#[derive(Clone, Debug)]
struct Rot;

impl Manifold for Rot {
    const PARAMS: &'static [&'static str] = &["rx", "ry", "rz", "arc_length"];
    const ARC_LENGTH: Option<usize> = Some(3);
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        let z = T::zero();
        Pose::new(
            so3_exp(&Vector3::new(p[0], p[1], p[2])),
            Vector3::new(p[3], z, z),
        )
    }
}

/// Cauchy's loss, `ρ(s) = b² ln(1 + s / b²)`.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct TestCauchy {
    b: f64,
}

#[typetag::serde(name = "test_cauchy")]
impl RobustLoss for TestCauchy {
    fn evaluate(&self, s: f64) -> [f64; 3] {
        let b2 = self.b * self.b;
        let inv = 1.0 / (1.0 + s / b2);
        [b2 * (1.0 + s / b2).ln(), inv, -inv * inv / b2]
    }
    fn scale(&self) -> f64 {
        self.b
    }
}

const TRUTH: [f64; 3] = [0.02, -0.15, 0.01];

/// Matches of a rotation: `f1 = Rᵀ f0`, every `outlier_every`-th one replaced by garbage.
fn setup(outlier_every: usize) -> (Rig, FrameObservations) {
    let cam = Camera::Pinhole(Pinhole {
        fx: 700.0,
        fy: 700.0,
        cx: 600.0,
        cy: 180.0,
        width: 1200.0,
        height: 370.0,
    });
    let rig = Rig::mono(cam, Pose::identity()).unwrap();
    let r = so3_exp(&Vector3::new(TRUTH[0], TRUTH[1], TRUTH[2]));
    let mut obs = FrameObservations::new(1);
    for i in 0..200 {
        let a = i as f64;
        let f0 = Vector3::new((0.37 * a).sin() * 0.8, (0.71 * a).cos() * 0.3, 1.0).normalize();
        let mut f1 = r.transpose() * f0;
        if outlier_every > 0 && i % outlier_every == 0 {
            f1 = Vector3::new((1.3 * a).cos() * 0.5, (2.9 * a).sin() * 0.2, 1.0).normalize();
        }
        obs.per_camera[0].push(Observation {
            px0: Vector2::zeros(),
            px1: Vector2::zeros(),
            f0,
            f1,
        });
    }
    (rig, obs)
}

#[test]
fn rotation_is_recovered_exactly() {
    let (rig, obs) = setup(0);
    let loss = TrivialLoss;
    let p = Problem::new(
        &Rot,
        &RotationOnly,
        &loss,
        &rig,
        &obs,
        &[0.0, 0.0, 0.0, 1.0],
    )
    .unwrap()
    .with_fixed(&[false, false, false, true]);
    assert_eq!(p.num_params(), 3);
    let x0 = p.free_params();
    for s in tight() {
        let r = s.solve(&p, &x0);
        assert!(r.termination.is_converged(), "{s:?}: {r:?}");
        for k in 0..3 {
            assert!((r.x[k] - TRUTH[k]).abs() < 1e-10, "{s:?}: {r:?}");
        }
        assert!(r.final_cost < 1e-20);
        assert!(r.covariance(1.0).is_some());
    }
    for s in defaults() {
        let r = s.solve(&p, &x0);
        assert!(r.termination.is_converged(), "{s:?}: {r:?}");
        assert!(r.iterations <= 8, "{s:?}: {r:?}");
    }
}

#[test]
fn unobservable_arc_length_keeps_its_value() {
    // The arc length is free but the metric does not see it: the normal matrix is singular.
    let (rig, obs) = setup(0);
    let loss = TrivialLoss;
    let p = Problem::new(
        &Rot,
        &RotationOnly,
        &loss,
        &rig,
        &obs,
        &[0.0, 0.0, 0.0, 1.3],
    )
    .unwrap();
    assert_eq!(p.num_params(), 4);
    let x0 = p.free_params();
    for s in tight() {
        let r = s.solve(&p, &x0);
        assert!(r.termination.is_converged(), "{s:?}: {r:?}");
        for k in 0..3 {
            assert!((r.x[k] - TRUTH[k]).abs() < 1e-10, "{s:?}: {r:?}");
        }
        assert_eq!(r.x[3], 1.3, "{s:?}: {r:?}");
        assert!(r.covariance(1.0).is_none());
    }
}

#[test]
fn cauchy_loss_rejects_the_outliers() {
    let (rig, obs) = setup(4);
    let loss = TestCauchy { b: 0.002 };
    let p = Problem::new(
        &Rot,
        &RotationOnly,
        &loss,
        &rig,
        &obs,
        &[0.01, -0.1, 0.0, 1.0],
    )
    .unwrap()
    .with_fixed(&[false, false, false, true]);
    let x0 = p.free_params();
    let mut found = Vec::new();
    for s in tight() {
        let r = s.solve(&p, &x0);
        assert!(r.termination.is_converged(), "{s:?}: {r:?}");
        assert!(r.final_cost < r.initial_cost);
        for k in 0..3 {
            assert!((r.x[k] - TRUTH[k]).abs() < 1e-5, "{s:?}: {r:?}");
        }
        found.push(r.x);
    }
    for x in &found[1..] {
        assert!((x - found[0]).amax() < 1e-9, "{x} vs {}", found[0]);
    }
    // Plain least squares is biased by the outliers.
    let plain = Problem::new(
        &Rot,
        &RotationOnly,
        &TrivialLoss,
        &rig,
        &obs,
        &[0.0, 0.0, 0.0, 1.0],
    )
    .unwrap()
    .with_fixed(&[false, false, false, true]);
    let r = defaults()[1].solve(&plain, &x0);
    assert!((0..3).any(|k| (r.x[k] - TRUTH[k]).abs() > 1e-3), "{r:?}");
}

#[test]
fn start_far_away_still_never_worse() {
    let (rig, obs) = setup(4);
    let loss = TestCauchy { b: 0.002 };
    let p = Problem::new(&Rot, &RotationOnly, &loss, &rig, &obs, &[0.0; 4])
        .unwrap()
        .with_fixed(&[false, false, false, true]);
    for x0 in [
        pv(&[0.5, 0.5, -0.5]),
        pv(&[0.0, 0.0, 0.0]),
        pv(&[-1.0, 2.0, 0.3]),
    ] {
        for s in defaults() {
            let r = s.solve(&p, &x0);
            assert!(r.final_cost <= r.initial_cost, "{s:?}: {r:?}");
            assert!(r.x.iter().all(|v| v.is_finite()));
            assert_ne!(r.termination, Termination::NoFreeParameters);
        }
    }
}

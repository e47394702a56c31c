//! Every model with every metric: AD Jacobians equal central finite differences (relative
//! 1e-6) through `check_model`, at random parameters, at zero yaw and at exactly zero rotation.

use momo_core::Manifold;
use momo_models::{Se3, SingleTrack2d, SingleTrack3d, SoftSingleTrack, TiltTranslation};
use momo_testing::check_model;
use proptest::prelude::*;

const TOL: f64 = 1e-6;

fn assert_ok<M: Manifold>(model: &M, p: &[f64]) -> Result<(), TestCaseError> {
    let r = check_model(model, p, TOL);
    prop_assert!(r.is_ok(), "{model:?} at {p:?}: {r:?}");
    Ok(())
}

const VARIANTS: [TiltTranslation; 3] = [
    TiltTranslation::Tilted,
    TiltTranslation::HalfTilted,
    TiltTranslation::Planar,
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn single_track_2d(yaw in -0.3..0.3f64, l in 0.1..3.0f64) {
        assert_ok(&SingleTrack2d, &[yaw, l])?;
        assert_ok(&SingleTrack2d, &[0.0, l])?;
    }

    #[test]
    fn single_track_3d(yaw in -0.3..0.3f64, l in 0.1..3.0f64, pitch in -0.05..0.05f64, roll in -0.05..0.05f64, v in 0usize..3) {
        let m = SingleTrack3d::new(VARIANTS[v]);
        assert_ok(&m, &[yaw, l, pitch, roll])?;
        assert_ok(&m, &[0.0, l, pitch, roll])?;
        assert_ok(&m, &[0.0, l, 0.0, 0.0])?;
    }

    #[test]
    fn se3(
        rx in -0.3..0.3f64, ry in -0.3..0.3f64, rz in -0.3..0.3f64,
        heading in -0.3..0.3f64, climb in -0.3..0.3f64, l in 0.1..3.0f64,
    ) {
        assert_ok(&Se3, &[rx, ry, rz, heading, climb, l])?;
        assert_ok(&Se3, &[0.0, 0.0, 0.0, heading, climb, l])?;
        assert_ok(&Se3, &[1e-4 * rx, 1e-4 * ry, 1e-4 * rz, heading, climb, l])?;
    }

    #[test]
    fn soft_single_track(
        rx in -0.3..0.3f64, ry in -0.3..0.3f64, rz in -0.3..0.3f64,
        heading in -0.3..0.3f64, climb in -0.3..0.3f64, l in 0.1..3.0f64,
        sigma in 0.001..0.1f64, dist in prop_oneof![Just(0.0), 0.001..0.05f64],
        climb_dist in prop_oneof![Just(0.0), 0.001..0.1f64],
    ) {
        let m = SoftSingleTrack {
            side_slip_sigma: sigma,
            climb_sigma: 2.0 * sigma,
            slip_distance_sigma: dist,
            climb_distance_sigma: climb_dist,
        };
        assert_ok(&m, &[rx, ry, rz, heading, climb, l])?;
        assert_ok(&m, &[0.0, 0.0, 0.0, heading, climb, l])?;
    }
}

/// A soft manifold whose prior residual has a wrong derivative at zero is caught.
#[test]
fn a_broken_prior_is_caught() {
    use momo_core::{Pose, Scalar};

    #[derive(Clone, Debug)]
    struct BrokenPrior;
    impl Manifold for BrokenPrior {
        const PARAMS: &'static [&'static str] = Se3::PARAMS;
        const ARC_LENGTH: Option<usize> = Se3::ARC_LENGTH;
        const PRIOR_RESIDUALS: usize = 1;
        fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
            Se3.motion(p)
        }
        fn prior_residuals<T: Scalar>(&self, p: &[T], out: &mut [T]) {
            // |heading| via sqrt(heading²): derivative NaN at 0 on duals.
            out[0] = (p[3] * p[3]).sqrt();
        }
    }
    assert!(check_model(&BrokenPrior, &[0.0, 0.0, 0.1, 0.0, 0.0, 1.0], TOL).is_err());
    assert!(check_model(&BrokenPrior, &[0.0, 0.0, 0.1, 0.05, 0.0, 1.0], TOL).is_ok());
}

#[test]
fn exactly_straight_and_exactly_zero_rotation() {
    for l in [0.1, 1.0, 3.0] {
        check_model(&SingleTrack2d, &[0.0, l], TOL).unwrap();
        for v in VARIANTS {
            check_model(&SingleTrack3d::new(v), &[0.0, l, 0.0, 0.0], TOL).unwrap();
        }
        check_model(&Se3, &[0.0, 0.0, 0.0, 0.0, 0.0, l], TOL).unwrap();
    }
    // Around the switch of the series at |yaw| = 1e-3 and θ² = 1e-6.
    for yaw in [-1.0005e-3, -0.9995e-3, 0.9995e-3, 1.0005e-3] {
        check_model(&SingleTrack2d, &[yaw, 1.0], TOL).unwrap();
        check_model(&Se3, &[0.0, 0.0, yaw, 0.5 * yaw, 0.0, 1.0], TOL).unwrap();
    }
}

#[test]
fn wrong_parameter_count_is_reported() {
    let e = check_model(&Se3, &[0.0, 1.0], TOL).unwrap_err();
    assert!(e.what.contains("expected 6 parameters"), "{}", e.what);
}

/// Models whose automatic derivative is wrong at zero are caught.
#[test]
fn a_broken_model_is_caught() {
    use momo_core::{Pose, Scalar};
    use nalgebra::{Matrix3, Vector3};

    #[derive(Clone, Debug)]
    struct Broken;
    impl Manifold for Broken {
        const PARAMS: &'static [&'static str] = &["yaw", "arc_length"];
        const ARC_LENGTH: Option<usize> = Some(1);
        fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
            // |yaw| via sqrt(yaw²): derivative NaN at 0 on duals.
            let a = (p[0] * p[0]).sqrt();
            Pose::new(Matrix3::identity(), Vector3::new(p[1], a, T::zero()))
        }
    }
    assert!(check_model(&Broken, &[0.0, 1.0], TOL).is_err());

    /// The pitfall `momo_core::lie` documents: nalgebra's `Rotation3::new` has a zero Jacobian
    /// at the identity on dual numbers.
    #[derive(Clone, Debug)]
    struct NalgebraRotation;
    impl Manifold for NalgebraRotation {
        const PARAMS: &'static [&'static str] = &["rot_x", "rot_y", "rot_z", "arc_length"];
        const ARC_LENGTH: Option<usize> = Some(3);
        fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
            let r = nalgebra::Rotation3::new(Vector3::new(p[0], p[1], p[2])).into_inner();
            Pose::new(r, Vector3::new(p[3], T::zero(), T::zero()))
        }
    }
    assert!(check_model(&NalgebraRotation, &[0.1, 0.0, 0.0, 1.0], TOL).is_ok());
    assert!(check_model(&NalgebraRotation, &[0.0, 0.0, 0.0, 1.0], TOL).is_err());
}

// The same checks through the public one-line macro (momo-testing), as a researcher writes them.
momo_testing::test_model!(macro_single_track_2d, SingleTrack2d, [-0.3..0.3, 0.1..3.0]);
momo_testing::test_model!(
    macro_single_track_3d,
    SingleTrack3d::default(),
    [-0.3..0.3, 0.1..3.0, -0.05..0.05, -0.05..0.05]
);
momo_testing::test_model!(
    macro_se3,
    Se3,
    [
        -0.1..0.1,
        -0.1..0.1,
        -0.3..0.3,
        -0.2..0.2,
        -0.1..0.1,
        0.1..3.0
    ]
);

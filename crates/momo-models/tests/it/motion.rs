//! The models' geometry: closed-form inverses, agreement between models, conventions.

use momo_core::{Manifold, Pose, Rig, so3_log};
use momo_models::{Se3, SingleTrack2d, SingleTrack3d, TiltTranslation, rot_x, rot_y};
use momo_testing::canned;
use nalgebra::Vector3;
use proptest::prelude::*;

fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

fn same_pose(a: &Pose<f64>, b: &Pose<f64>, tol: f64) -> bool {
    (a.rotation - b.rotation).amax() <= tol && (a.translation - b.translation).amax() <= tol
}

const VARIANTS: [TiltTranslation; 3] = [
    TiltTranslation::Tilted,
    TiltTranslation::HalfTilted,
    TiltTranslation::Planar,
];

proptest! {
    #[test]
    fn single_track_2d_round_trip(yaw in -0.3..0.3f64, l in -3.0..3.0f64) {
        for p in [[yaw, l], [0.0, l]] {
            let m = SingleTrack2d.motion(&p);
            prop_assert!(m.orthonormality_error() < 1e-14);
            let q = SingleTrack2d.params_from_motion(&m).unwrap();
            prop_assert!(close(&q, &p, 1e-12), "{q:?} vs {p:?}");
        }
    }

    #[test]
    fn single_track_3d_round_trip(
        yaw in -0.3..0.3f64, l in -3.0..3.0f64, pitch in -0.05..0.05f64, roll in -0.05..0.05f64, v in 0usize..3,
    ) {
        let model = SingleTrack3d::new(VARIANTS[v]);
        for p in [[yaw, l, pitch, roll], [0.0, l, pitch, roll], [yaw, l, 0.0, 0.0]] {
            let m = model.motion(&p);
            prop_assert!(m.orthonormality_error() < 1e-14);
            let q = model.params_from_motion(&m).unwrap();
            prop_assert!(close(&q, &p, 1e-12), "{q:?} vs {p:?}");
        }
    }

    #[test]
    fn se3_round_trip(
        rx in -0.3..0.3f64, ry in -0.3..0.3f64, rz in -0.3..0.3f64,
        heading in -0.3..0.3f64, climb in -0.3..0.3f64, l in 0.1..3.0f64,
    ) {
        for p in [[rx, ry, rz, heading, climb, l], [0.0, 0.0, 0.0, heading, climb, l]] {
            let m = Se3.motion(&p);
            prop_assert!(m.orthonormality_error() < 1e-14);
            let q = Se3.params_from_motion(&m).unwrap();
            prop_assert!(close(&q, &p, 1e-12), "{q:?} vs {p:?}");
            // Driving backwards: the same direction, negative arc length.
            let mut back = p;
            back[5] = -l;
            let q = Se3.params_from_motion(&Se3.motion(&back)).unwrap();
            prop_assert!(close(&q, &back, 1e-12), "{q:?} vs {back:?}");
        }
    }

    /// Planar motion is the same in all three models (Se3: rot_z = yaw, heading = yaw / 2).
    #[test]
    fn models_agree_on_planar_motion(yaw in -0.3..0.3f64, l in 0.1..3.0f64, v in 0usize..3) {
        let a = SingleTrack2d.motion(&[yaw, l]);
        let b = SingleTrack3d::new(VARIANTS[v]).motion(&[yaw, l, 0.0, 0.0]);
        let c = Se3.motion(&[0.0, 0.0, yaw, 0.5 * yaw, 0.0, l]);
        prop_assert!(same_pose(&a, &b, 1e-15));
        prop_assert!(same_pose(&a, &c, 1e-14));
        // and params_from_motion of another model's planar motion recovers the planar params
        let q = Se3.params_from_motion(&a).unwrap();
        prop_assert!(close(&q, &[0.0, 0.0, yaw, 0.5 * yaw, 0.0, l], 1e-12), "{q:?}");
    }

    /// The three SingleTrack3d variants share the rotation and the chord length and differ in
    /// how far the chord is tilted: fully, half, not at all.
    #[test]
    fn single_track_3d_variants(yaw in -0.3..0.3f64, l in 0.1..3.0f64, pitch in -0.05..0.05f64, roll in -0.05..0.05f64) {
        let p = [yaw, l, pitch, roll];
        let [t, h, f] = VARIANTS.map(|v| SingleTrack3d::new(v).motion(&p));
        prop_assert!((t.rotation - h.rotation).amax() < 1e-15 && (t.rotation - f.rotation).amax() < 1e-15);
        let t2d = SingleTrack2d.motion(&[yaw, l]).translation;
        prop_assert!((f.translation - t2d).amax() < 1e-15);
        prop_assert!((t.translation - rot_y(pitch) * rot_x(roll) * t2d).amax() < 1e-15);
        prop_assert!((h.translation - rot_y(0.5 * pitch) * rot_x(0.5 * roll) * t2d).amax() < 1e-15);
        prop_assert!((t.translation.norm() - f.translation.norm()).abs() < 1e-14);
        // The rotation is R_tilt · Rz(yaw).
        let r = rot_y(pitch) * rot_x(roll) * momo_models::rot_z(yaw);
        prop_assert!((t.rotation - r).amax() < 1e-15);
    }
}

#[test]
fn conventions() {
    // x forward, y left, z up: a left curve moves to +y and turns counter-clockwise.
    let m = SingleTrack2d.motion(&[0.2f64, 2.0]);
    assert!(m.translation.x > 1.9 && m.translation.y > 0.0 && m.translation.z == 0.0);
    assert!((so3_log(&m.rotation) - Vector3::new(0.0, 0.0, 0.2)).amax() < 1e-15);
    // Chord of a circle of radius r = l / γ: |t| = 2 r sin(γ/2).
    let r: f64 = 2.0 / 0.2;
    assert!((m.translation.norm() - 2.0 * r * 0.1f64.sin()).abs() < 1e-14);
    // Positive pitch is nose down: with the tilted translation the vehicle descends.
    let m = SingleTrack3d::default().motion(&[0.0f64, 1.0, 0.05, 0.0]);
    assert!(m.translation.z < 0.0 && (m.translation.z + 0.05f64.sin()).abs() < 1e-15);
    // Se3 climb: up.
    let m = Se3.motion(&[0.0f64, 0.0, 0.0, 0.0, 0.1, 1.0]);
    assert!((m.translation.z - 0.1f64.sin()).abs() < 1e-15);
    // Se3's chord shrinks with the total rotation like a circular arc.
    let m = Se3.motion(&[0.0f64, 0.2, 0.0, 0.0, 0.0, 2.0]);
    assert!((m.translation.norm() - 2.0 * 10.0 * 0.1f64.sin()).abs() < 1e-14);
}

#[test]
fn initial_params_and_observability() {
    assert_eq!(SingleTrack2d.initial_params(1.5), vec![0.0, 1.5]);
    assert_eq!(
        SingleTrack3d::default().initial_params(1.5),
        vec![0.0, 1.5, 0.0, 0.0]
    );
    assert_eq!(Se3.initial_params(1.5), vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.5]);
    assert!(same_pose(
        &Se3.motion(&Se3.initial_params(1.5)),
        &SingleTrack2d.motion(&[0.0f64, 1.5]),
        0.0
    ));
    // A camera in the motion centre cannot see scale.
    let centred = Rig::mono(canned::pinhole_rig().cameras()[0].model, Pose::identity()).unwrap();
    assert_eq!(
        Se3.observable(&centred),
        vec![true, true, true, true, true, false]
    );
    assert_eq!(
        SingleTrack2d.observable(&canned::pinhole_rig()),
        vec![true, true]
    );
}

#[test]
fn se3_params_of_degenerate_motions() {
    let q = Se3.params_from_motion(&Pose::identity()).unwrap();
    assert_eq!(q, vec![0.0; 6]);
    // Pure sideways translation: heading ±90°, positive arc length.
    let q = Se3
        .params_from_motion(&Pose::new(
            nalgebra::Matrix3::identity(),
            Vector3::new(0.0, -1.0, 0.0),
        ))
        .unwrap();
    assert!(
        close(
            &q,
            &[0.0, 0.0, 0.0, -std::f64::consts::FRAC_PI_2, 0.0, 1.0],
            1e-15
        ),
        "{q:?}"
    );
}

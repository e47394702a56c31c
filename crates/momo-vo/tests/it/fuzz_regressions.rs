//! The `estimator`, `config_toml` and `config_json` fuzz targets' promises (`fuzz/`,
//! `docs/GUARANTEES.md` section 3 and 6) as fixed cases that run in every `cargo test`: raw
//! matches a reader never produces (NaN, infinite, zero and unnormalised bearings), absurd arc
//! lengths, more match lists than cameras, and every model, metric, loss and solver plus the
//! 5-point baseline. No panic, and every motion finite with an orthonormal rotation.

use momo_core::{FrameObservations, Observation, Pose};
use momo_testing::canned;
use momo_vo::{Config, EstimatorKind, FrameStatus};
use nalgebra::{Vector2, Vector3};

const CONFIGS: &[(EstimatorKind, &str)] = &[
    (EstimatorKind::Momo, ""),
    (
        EstimatorKind::Momo,
        "[model]\ntype = \"single_track_2d\"\n[metric]\ntype = \"angle_plane\"\n[loss]\ntype = \"huber\"\nscale = 0.002\n[solver]\ntype = \"dogleg\"\n",
    ),
    (
        EstimatorKind::Momo,
        "[model]\ntype = \"single_track_3d\"\n[metric]\ntype = \"sampson\"\n[loss]\ntype = \"tukey\"\nscale = 2.0\n[solver]\ntype = \"gauss_newton\"\n",
    ),
    (
        EstimatorKind::Momo,
        "[model]\ntype = \"se3\"\n[metric]\ntype = \"geo_line\"\n[loss]\ntype = \"trivial\"\n[solver]\ntype = \"levenberg_marquardt\"\n[odometry]\nmin_matches = 0\nstandstill_arc_length = 0.0\nrotation_change_sigma = 0.0\n",
    ),
    (EstimatorKind::FivePoint, ""),
    (EstimatorKind::FivePointRefined, ""),
];

fn config(toml: &str) -> Config {
    if toml.is_empty() {
        Config::default()
    } else {
        Config::from_toml_str(toml, "case.toml").expect("valid")
    }
}

fn assert_motion(m: &Pose<f64>, what: &str) {
    assert!(
        m.rotation
            .iter()
            .chain(m.translation.iter())
            .all(|v| v.is_finite()),
        "{what}: {m:?}"
    );
    assert!(m.orthonormality_error() < 1e-6, "{what}: {m:?}");
}

/// Good matches of a 2 degree turn, then the same with `spoil` applied to every match.
fn frames(spoil: impl Fn(usize, &mut Observation)) -> (FrameObservations, FrameObservations) {
    let rig = canned::pinhole_rig();
    let truth = momo_models::SingleTrack2d;
    let m = momo_core::Manifold::motion(&truth, &[0.035, 1.0]);
    let good = canned::synthetic_observations(&rig, &m, 60, 5, 11);
    let mut bad = good.clone();
    for (i, o) in bad.per_camera[0].iter_mut().enumerate() {
        spoil(i, o);
    }
    (good, bad)
}

type Spoiler = fn(usize, &mut Observation);

const SPOILERS: &[(&str, Spoiler)] = &[
    ("NaN bearings", |_, o| {
        o.f1 = Vector3::new(f64::NAN, 0.0, 1.0)
    }),
    ("infinite bearings", |i, o| {
        if i % 3 == 0 {
            o.f0 = Vector3::new(f64::INFINITY, -f64::INFINITY, 1.0)
        }
    }),
    ("zero bearings", |i, o| {
        if i % 2 == 0 {
            o.f0 = Vector3::zeros();
            o.f1 = Vector3::zeros();
        }
    }),
    ("unnormalised bearings", |i, o| {
        o.f0 *= 1e200 * (i as f64 + 1.0);
        o.f1 *= 1e-200;
    }),
    ("NaN pixels", |_, o| {
        o.px1 = Vector2::new(f64::NAN, f64::NAN)
    }),
    ("one bearing for all", |_, o| {
        o.f0 = Vector3::z();
        o.f1 = Vector3::z();
    }),
];

#[test]
fn raw_non_finite_matches_never_give_a_non_finite_motion() {
    let rig = canned::pinhole_rig();
    for &(kind, toml) in CONFIGS {
        for &(name, spoil) in SPOILERS {
            let mut driver = momo_vo::driver(kind, &rig, config(toml)).expect("fits");
            let (good, bad) = frames(spoil);
            let what = format!("{kind:?} {toml:?}, {name}");
            let r = driver.process(&good, Some(1.0));
            assert_motion(&r.motion, &what);
            let r = driver.process(&bad, Some(1.0));
            assert_motion(&r.motion, &what);
            assert_eq!(r.diagnostics.matches, bad.len(), "{what}");
            // And recovers on the next good frame.
            let r = driver.process(&good, Some(1.0));
            assert_motion(&r.motion, &what);
            assert_eq!(r.diagnostics.status, FrameStatus::Estimated, "{what}");
        }
    }
}

#[test]
fn absurd_arc_lengths_and_extra_match_lists_never_give_a_non_finite_motion() {
    let rig = canned::pinhole_rig();
    let (good, _) = frames(|_, _| {});
    let mut extra = good.clone();
    extra.per_camera.push(good.per_camera[0].clone());
    for &(kind, toml) in CONFIGS {
        let mut driver = momo_vo::driver(kind, &rig, config(toml)).expect("fits");
        for arc in [
            Some(f64::NAN),
            Some(-1.0),
            Some(f64::INFINITY),
            Some(f64::NEG_INFINITY),
            Some(0.0),
            Some(1e-300),
            Some(1e6),
            Some(1e308),
            Some(f64::MAX),
            None,
            Some(1.0),
        ] {
            for obs in [&good, &extra, &FrameObservations::new(1)] {
                let r = driver.process(obs, arc);
                assert_motion(&r.motion, &format!("{kind:?} {toml:?}, arc {arc:?}"));
            }
        }
    }
}

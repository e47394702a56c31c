//! `momo eval`'s ATE and RPE equal evo's `evo_ape` / `evo_rpe` to 1e-6 on the same files.
//!
//! The fixture (`tests/fixtures/evo/`: 40-pose KITTI ground truth and estimate, scale 0.7, in
//! another frame, noisy steps) and evo's statistics (`expected.json`, evo 1.38.1) were made once
//! by `tests/fixtures/evo/make.py`; evo is not a dependency.

use momo_core::Pose;
use momo_eval::{Alignment, Delta, Stats, ate, rpe};
use nalgebra::{Matrix3, Vector3};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/evo")
        .join(name)
}

fn read_kitti(name: &str) -> Vec<Pose<f64>> {
    let text = std::fs::read_to_string(fixture(name)).expect("fixture readable");
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|x| x.parse().expect("number"))
                .collect();
            assert_eq!(v.len(), 12);
            Pose::new(
                Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]),
                Vector3::new(v[3], v[7], v[11]),
            )
        })
        .collect()
}

fn assert_stats(name: &str, ours: &Stats, evo: &Value) {
    for (field, value) in [
        ("rmse", ours.rmse),
        ("mean", ours.mean),
        ("median", ours.median),
        ("std", ours.std),
        ("min", ours.min),
        ("max", ours.max),
        ("sse", ours.sse),
    ] {
        let expected = evo[field].as_f64().expect("evo number");
        let tol = 1e-6 * expected.abs().max(1.0);
        assert!(
            (value - expected).abs() <= tol,
            "{name}.{field}: momo {value}, evo {expected}"
        );
    }
}

#[test]
fn ate_and_rpe_equal_evo() {
    let gt = read_kitti("gt.txt");
    let est = read_kitti("est.txt");
    let text = std::fs::read_to_string(fixture("expected.json")).expect("expected.json");
    let evo: Value = serde_json::from_str(&text).expect("json");

    let se3 = ate(&gt, &est, Alignment::Se3).expect("se3");
    assert_stats("ape_se3", &se3.stats, &evo["ape_se3"]);
    let sim3 = ate(&gt, &est, Alignment::Sim3).expect("sim3");
    assert_stats("ape_sim3", &sim3.stats, &evo["ape_sim3"]);
    // The fixture's estimate is at scale 0.7: Sim(3) finds 1 / 0.7 (up to the noise).
    assert!((sim3.transform.scale * 0.7 - 1.0).abs() < 0.05);
    assert_eq!(sim3.stats.count, 40);

    let metres = |from_ground_truth| Delta::Metres {
        metres: 3.0,
        from_ground_truth,
    };
    for (name, delta) in [
        ("rpe_1f", Delta::Frames(1)),
        ("rpe_4f", Delta::Frames(4)),
        ("rpe_3m", metres(false)),
        ("rpe_3m_ref", metres(true)),
    ] {
        let r = rpe(&gt, &est, delta).expect("pairs");
        assert_stats(
            &format!("{name}_trans"),
            &r.translation,
            &evo[format!("{name}_trans")],
        );
        assert_stats(
            &format!("{name}_rot_deg"),
            &r.rotation_deg,
            &evo[format!("{name}_rot_deg")],
        );
    }
}

//! End to end on the real KITTI 00 matches (if the shared data folder is present): `momo
//! import-kitti`, `momo run` with the default configuration, `momo eval --json`.
//!
//! The data folder is `$MOMO_DATA/kitti00_stereo_matches_l1avgvo`, with `MOMO_DATA` defaulting to
//! `../shared/data` beside the workspace; without it the test prints SKIPPED and passes.

use std::path::PathBuf;
use std::process::{Command, Output};

fn momo(args: &[&std::ffi::OsStr]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_momo"))
        .args(args)
        .output()
        .expect("momo starts");
    assert!(
        o.status.success(),
        "momo {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn data_dir() -> Option<PathBuf> {
    let base = crate::common::shared_data();
    let dir = base.join("kitti00_stereo_matches_l1avgvo");
    dir.join("calib.txt").is_file().then_some(dir)
}

#[test]
fn kitti00_import_run_eval() {
    let Some(data) = data_dir() else {
        eprintln!("SKIPPED: KITTI 00 l1avgvo matches not found (set MOMO_DATA)");
        return;
    };
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    let est = tmp.path().join("est.txt");
    momo(&[
        "import-kitti".as_ref(),
        data.as_os_str(),
        seq.as_os_str(),
        "--matches".as_ref(),
        "100".as_ref(),
    ]);
    for f in ["rig.json", "matches.csv", "odometry.csv", "poses.txt"] {
        assert!(seq.join(f).is_file(), "{f} written");
    }
    momo(&[
        "run".as_ref(),
        seq.as_os_str(),
        "--output".as_ref(),
        est.as_os_str(),
        "--quiet".as_ref(),
    ]);
    let gt = seq.join("poses.txt");
    let o = momo(&[
        "eval".as_ref(),
        "--gt".as_ref(),
        gt.as_os_str(),
        "--est".as_ref(),
        est.as_os_str(),
        "--json".as_ref(),
    ]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("eval prints JSON");
    assert_eq!(v["frames"], 301);
    let e = &v["estimates"][0];
    let r = &e["rotation_deg"];
    let median = r["median"].as_f64().expect("median");
    let p95 = r["p95"].as_f64().expect("p95");
    let max = r["max"].as_f64().expect("max");
    let t_err = e["t_err_percent"]
        .as_f64()
        .expect("KITTI 00 frames 0-300 exceed 100 m");
    eprintln!(
        "KITTI 00, 100 matches/frame, default config: rotation median {median:.4} p95 {p95:.4} max {max:.4} deg, above 1 deg {}, t_err {t_err:.3} %, r_err {} deg/100m",
        r["above_one"], e["r_err_deg_per_100m"]
    );
    assert_eq!(r["count"], 300);
    assert!(median < 0.1, "median {median}");
    assert!(t_err < 5.0, "t_err {t_err}");

    // Different lengths are an input error (exit code 2).
    let short = tmp.path().join("short.txt");
    let text = std::fs::read_to_string(&est).expect("estimate");
    std::fs::write(&short, text.lines().take(10).collect::<Vec<_>>().join("\n")).expect("write");
    let o = Command::new(env!("CARGO_BIN_EXE_momo"))
        .arg("eval")
        .arg("--gt")
        .arg(&gt)
        .arg("--est")
        .arg(&short)
        .output()
        .expect("momo starts");
    assert_eq!(o.status.code(), Some(2));
}

/// Stop and go along the real KITTI 00 trajectory (ground truth, frames 0-700; the car slows
/// down, stands at frame pairs 545-552 and moves off slowly): simulated clean matches
/// (`clean_pinhole`: 300 per frame pair, 0.5 px), the default configuration. This used to fail:
/// moving off, the estimate went 45 degrees sideways and carried rotation errors of 1-3.7
/// degrees through 280 frame pairs (3.7 degrees at pair 695 here), because the direction of
/// travel held through the standstill pointed 7-27 degrees off and the standstill frames
/// (another residual, half the inliers) had dragged the running inlier ratio down so far
/// that no restart fired. Each of the two fixes alone passes this test: the first moving
/// frame after a standstill starts straight ahead, and standstill frames no longer count
/// towards the running inlier ratio.
#[test]
fn kitti00_stop_and_go_has_no_gross_rotation_error() {
    let gt = crate::common::shared_data().join("kitti_odometry_gt/poses/00.txt");
    if !gt.is_file() {
        eprintln!("SKIPPED: {} not found (set MOMO_DATA)", gt.display());
        return;
    }
    let poses = momo::io::read_poses(&gt).expect("KITTI 00 poses");
    let first = poses[0].inverse();
    let slice: Vec<_> = poses[0..700].iter().map(|p| first.compose(p)).collect();
    let cfg = momo::sim::SimConfig {
        frames: slice.len(),
        seed: 1,
        camera_trajectory: Some(slice),
        ..momo::sim::SimConfig::clean_pinhole()
    };
    let sim = momo::sim::simulate(&cfg).expect("simulation");
    let (poses, diags) = momo::vo::run_in_memory(
        &sim.sequence,
        momo::vo::EstimatorKind::Momo,
        momo::vo::Config::default(),
        |_| {},
    )
    .expect("run");
    let standstill = diags
        .iter()
        .filter(|d| d.status == momo::vo::FrameStatus::Standstill)
        .count();
    let gt = sim
        .sequence
        .ground_truth
        .as_ref()
        .expect("simulated ground truth");
    let mut worst = (0.0_f64, 0);
    for k in 1..poses.len() {
        let est = poses[k - 1].inverse().compose(&poses[k]);
        let truth = gt[k - 1].inverse().compose(&gt[k]);
        let err = momo::core::so3_log(&(truth.rotation.transpose() * est.rotation))
            .norm()
            .to_degrees();
        if err > worst.0 {
            worst = (err, k);
        }
    }
    eprintln!(
        "KITTI 00 frames 0-700 (stop and go, {standstill} standstill frames): worst rotation error {:.3} deg at frame pair {}",
        worst.0, worst.1
    );
    assert!(standstill >= 5, "the slice holds the stop");
    assert!(worst.0 < 0.3, "rotation error {:.3} deg", worst.0);
}

//! Reproduces the published devkit numbers of ORB-SLAM2 (stereo) on KITTI 00 from the shared
//! evaluation data: 0.70 % and 0.25 deg/100 m. Skips with a message when the data is absent.
//! The data folder is `$MOMO_DATA` or `../shared/data` beside the repository.

use momo_core::Pose;
use nalgebra::{Matrix3, Vector3};
use std::path::PathBuf;

fn data_dir() -> PathBuf {
    std::env::var_os("MOMO_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
}

fn read_kitti(path: &std::path::Path) -> Vec<Pose<f64>> {
    let text = std::fs::read_to_string(path).expect("readable");
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

#[test]
fn orb_slam2_on_kitti_00_matches_the_published_numbers() {
    let dir = data_dir();
    let gt = dir.join("kitti_odometry_gt/poses/00.txt");
    let est = dir.join("kitti00_example_estimates_evo/KITTI_00_ORB.txt");
    if !gt.exists() || !est.exists() {
        eprintln!(
            "SKIPPED: KITTI data not found under {} (set MOMO_DATA)",
            dir.display()
        );
        return;
    }
    let (gt, est) = (read_kitti(&gt), read_kitti(&est));
    let e = momo_eval::kitti_errors(&gt, &est).expect("same length");
    eprintln!(
        "ORB-SLAM2 KITTI 00: {:.3} % {:.3} deg/100m",
        e.t_err_percent, e.r_err_deg_per_100m
    );
    assert!(
        (e.t_err_percent - 0.700).abs() < 0.005,
        "{}",
        e.t_err_percent
    );
    assert!(
        (e.r_err_deg_per_100m - 0.253).abs() < 0.005,
        "{}",
        e.r_err_deg_per_100m
    );
}

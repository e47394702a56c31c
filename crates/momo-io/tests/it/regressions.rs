//! Replays the fuzzers' findings (`fuzz/`, see `fuzz/README.md`): every file under
//! `tests/regressions/<target>/` is fed to the reader of that target with the same checks as
//! the fuzz target (`momo_fuzz::<target>`): no panic, every error renders as
//! `path[:line]: reason`, and what is accepted keeps the reader's promises (contiguous frames
//! and finite unit bearings; finite non-negative arc lengths; orthonormal poses; rigs that
//! write and read back equal). Crashers found by fuzzing are added here as files, so that they
//! run in every `cargo test`.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{Camera, Pinhole, Pose, Rig, RigCamera};
use momo_io::{IoError, MatchReader, POSE_ORTHONORMAL_TOLERANCE};
use momo_testing::canned;
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

fn inputs(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/regressions")
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(
        !files.is_empty(),
        "no regression inputs in {}",
        dir.display()
    );
    files
}

fn check_error(e: &IoError, path: &str, input: &Path) {
    let text = e.to_string();
    let prefix = match e.line {
        Some(l) => {
            assert!(l >= 1, "{}: {text}", input.display());
            format!("{path}:{l}: ")
        }
        None => format!("{path}: "),
    };
    assert!(
        text.starts_with(&prefix) && text.len() > prefix.len() && text.len() < 2000,
        "{}: `{text}`",
        input.display()
    );
}

/// The rig of the `matches_csv` fuzz target (`momo_fuzz::matches_rig`): camera 0 the KITTI
/// pinhole, camera 1 a fisheye beyond 180 degrees, camera 2 a 1 x 1 pinhole with focal
/// lengths 1e-6 and 1e9.
fn matches_rig() -> Rig {
    let forward = canned::forward_looking();
    let cams = [
        (
            Camera::Pinhole(canned::kitti_pinhole()),
            Vector3::new(1.0, 0.0, 1.65),
        ),
        (Camera::KannalaBrandt(canned::fisheye()), Vector3::zeros()),
        (
            Camera::Pinhole(Pinhole {
                fx: 1e-6,
                fy: 1e9,
                cx: 0.5,
                cy: 0.5,
                width: 1.0,
                height: 1.0,
            }),
            Vector3::zeros(),
        ),
    ];
    Rig::new(
        cams.into_iter()
            .enumerate()
            .map(|(i, (model, t))| RigCamera {
                name: format!("cam{i}"),
                model,
                t_vehicle_camera: Pose::new(forward, t),
            })
            .collect(),
    )
    .unwrap()
}

#[test]
fn rig_json_regressions() {
    for input in inputs("rig_json") {
        let bytes = std::fs::read(&input).unwrap();
        let Ok(text) = std::str::from_utf8(&bytes) else {
            continue;
        };
        match momo_io::read_rig_from_str(text, "rig.json") {
            Err(e) => check_error(&e, "rig.json", &input),
            Ok(rig) => {
                let json = momo_io::rig_to_json(&rig).unwrap();
                let back = momo_io::read_rig_from_str(&json, "back.json").unwrap();
                assert_eq!(back, rig, "{}", input.display());
            }
        }
    }
}

#[test]
fn matches_csv_regressions() {
    let rig = matches_rig();
    for input in inputs("matches_csv") {
        let bytes = std::fs::read(&input).unwrap();
        let reader = match MatchReader::new(&bytes[..], &rig, "matches.csv") {
            Ok(r) => r,
            Err(e) => {
                check_error(&e, "matches.csv", &input);
                continue;
            }
        };
        let mut expect = 1;
        for item in reader.take(10_000) {
            match item {
                Err(e) => {
                    check_error(&e, "matches.csv", &input);
                    break;
                }
                Ok((k, obs)) => {
                    assert_eq!(k, expect, "{}", input.display());
                    expect += 1;
                    for o in obs.per_camera.iter().flatten() {
                        for f in [o.f0, o.f1] {
                            assert!(
                                f.iter().all(|v| v.is_finite()) && (f.norm() - 1.0).abs() < 1e-9,
                                "{}: bearing {f}",
                                input.display()
                            );
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn odometry_csv_regressions() {
    for input in inputs("odometry_csv") {
        let bytes = std::fs::read(&input).unwrap();
        match momo_io::read_odometry_from(&bytes[..], "odometry.csv") {
            Err(e) => check_error(&e, "odometry.csv", &input),
            Ok(v) => {
                assert!(v[0].is_none());
                assert!(v.iter().flatten().all(|l| l.is_finite() && *l >= 0.0));
            }
        }
    }
}

#[test]
fn kitti_poses_regressions() {
    for input in inputs("kitti_poses") {
        let bytes = std::fs::read(&input).unwrap();
        match momo_io::read_poses_from(&bytes[..], "poses.txt") {
            Err(e) => check_error(&e, "poses.txt", &input),
            Ok(poses) => {
                for p in poses {
                    assert!(p.orthonormality_error() <= POSE_ORTHONORMAL_TOLERANCE);
                    assert!(p.translation.iter().all(|v| v.is_finite()));
                }
            }
        }
    }
}

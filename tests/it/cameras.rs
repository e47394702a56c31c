//! `momo run` as a process on the camera models of format version 2: the simulated scenarios
//! `radtan_mono` and `wide_angle_surround` against the same settings on the pinhole (KITTI mono)
//! and Kannala-Brandt (fisheye surround) rigs, same drive and seed.

use momo::eval::{ErrorSummary, frame_to_frame_rotation_errors};
use momo::sim::{RigPreset, SimConfig, simulate};
use std::path::Path;
use std::process::Command;

/// Frames per sequence: enough for a stable median, a few seconds per run.
const FRAMES: usize = 40;

/// Median frame-to-frame rotation error (degrees) of `momo run` on a simulated sequence.
fn median_rotation_error(cfg: &SimConfig, dir: &Path) -> f64 {
    let sim = simulate(cfg).expect("valid simulation");
    let seq = dir.join("seq");
    sim.write(&seq).expect("writes");
    let out = dir.join("poses.txt");
    let o = Command::new(env!("CARGO_BIN_EXE_momo"))
        .arg("run")
        .arg(&seq)
        .arg("--output")
        .arg(&out)
        .arg("--quiet")
        .output()
        .expect("momo starts");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let est = momo::io::read_poses(&out).expect("momo writes valid poses");
    let gt = sim.sequence.ground_truth.as_ref().expect("ground truth");
    assert_eq!(est.len(), FRAMES);
    let errors = frame_to_frame_rotation_errors(gt, &est);
    assert!(errors.iter().all(|e| e.is_finite()), "no NaN poses");
    ErrorSummary::from_values(&errors).median
}

/// `new` is comparable to `reference`: at most 1.5 times its median plus 0.005°.
fn compare(name: &str, new: &SimConfig, reference: &SimConfig) {
    let tmp = tempfile::tempdir().expect("tmp");
    let a = median_rotation_error(new, &tmp.path().join("new"));
    let b = median_rotation_error(reference, &tmp.path().join("reference"));
    eprintln!("{name}: median rotation error {a:.5} deg, reference {b:.5} deg");
    assert!(a < 1.5 * b + 0.005, "{name}: {a} vs {b}");
    assert!(a < 0.05, "{name}: {a}");
}

#[test]
fn radtan_mono_is_as_accurate_as_pinhole() {
    for seed in [0, 1] {
        let new = SimConfig {
            frames: FRAMES,
            seed,
            ..SimConfig::scenario("radtan_mono").expect("listed")
        };
        let reference = SimConfig {
            rig: RigPreset::KittiMono,
            ..new.clone()
        };
        compare(&format!("radtan_mono seed {seed}"), &new, &reference);
    }
}

#[test]
fn wide_angle_surround_is_as_accurate_as_fisheye() {
    for seed in [0, 1] {
        let new = SimConfig {
            frames: FRAMES,
            seed,
            ..SimConfig::scenario("wide_angle_surround").expect("listed")
        };
        let reference = SimConfig {
            rig: RigPreset::SurroundFisheye,
            ..new.clone()
        };
        compare(
            &format!("wide_angle_surround seed {seed}"),
            &new,
            &reference,
        );
    }
}

/// `momo rig import` as a process: the Kalibr sample to a rig.json that `momo_io` reads back,
/// and a bad file to exit code 2 with `path:line: reason`.
#[test]
fn rig_import_command() {
    let tmp = tempfile::tempdir().expect("tmp");
    let calib = Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/momo-io/tests/calib");
    let out = tmp.path().join("rig.json");
    let o = Command::new(env!("CARGO_BIN_EXE_momo"))
        .args(["rig", "import"])
        .arg(calib.join("kalibr_camchain.yaml"))
        .arg("-o")
        .arg(&out)
        .args(["--mount", "1.5,0,1.3,0,5"])
        .output()
        .expect("momo starts");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(
            "Kalibr camchain YAML: 3 camera(s): cam0 (radtan), cam1 (double_sphere), cam2 (unified)"
        ),
        "{stderr}"
    );
    let rig = momo::io::read_rig(&out).expect("valid rig.json");
    assert_eq!(rig.len(), 3);
    let mount = rig.cameras()[0].t_vehicle_camera;
    assert_eq!(mount.translation, nalgebra::Vector3::new(1.5, 0.0, 1.3));
    // Tilted 5 degrees down: the optical axis points forward and slightly down.
    let z = mount.rotation.column(2);
    assert!((z.z + 5f64.to_radians().sin()).abs() < 1e-12, "{z}");

    let bad = tmp.path().join("bad.yaml");
    std::fs::write(&bad, "cam0:\n  camera_model: ds\n  intrinsics: [1.2, 0.5, 300, 300, 320, 240]\n  resolution: [640, 480]\n").expect("write");
    let o = Command::new(env!("CARGO_BIN_EXE_momo"))
        .args(["rig", "import"])
        .arg(&bad)
        .arg("-o")
        .arg(tmp.path().join("bad.json"))
        .output()
        .expect("momo starts");
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(&format!("{}:3: ", bad.display())),
        "{stderr}"
    );
    assert!(stderr.contains("`xi` must lie in (-1, 1)"), "{stderr}");
    assert!(!tmp.path().join("bad.json").exists());
}

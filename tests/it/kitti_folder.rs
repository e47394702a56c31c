//! From a KITTI odometry sequence folder to a scored trajectory, as processes: `momo
//! import-kitti` (calib.txt, image_0/, image_1/, times.txt, --poses), `momo vo OUT_DIR`,
//! `momo eval` (KITTI and TUM). The data is the real KITTI 06 snippet of the shared data folder
//! (`$MOMO_DATA/kitti_stereo_snippets/kitti06_frames000000-000050`, `MOMO_DATA` defaulting to
//! `../shared/data` beside the workspace), of which the first 11 frames are linked into a
//! temporary folder in the KITTI layout (the test then takes seconds); without the data the
//! test prints SKIPPED and passes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const FRAMES: usize = 11;

fn momo(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_momo"))
        .args(args)
        .output()
        .expect("momo starts")
}

fn ok(args: &[&std::ffi::OsStr]) -> Output {
    let o = momo(args);
    assert!(
        o.status.success(),
        "momo {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn snippet() -> Option<PathBuf> {
    let base = crate::common::shared_data();
    let dir = base.join("kitti_stereo_snippets/kitti06_frames000000-000050");
    dir.join("calib.txt").is_file().then_some(dir)
}

/// The first `FRAMES` frames of the snippet in the KITTI layout: calib.txt and times.txt as
/// files, images as symbolic links; the ground truth beside it as KITTI's poses/06.txt would be.
fn kitti_layout(src: &Path, dst: &Path) -> PathBuf {
    let seq = dst.join("sequences/06");
    for cam in ["image_0", "image_1"] {
        std::fs::create_dir_all(seq.join(cam)).expect("mkdir");
        let mut names: Vec<_> = std::fs::read_dir(src.join(cam))
            .expect("image folder")
            .map(|e| e.expect("entry").path())
            .collect();
        names.sort();
        for p in names.iter().take(FRAMES) {
            let name = p.file_name().expect("file name");
            std::os::unix::fs::symlink(p, seq.join(cam).join(name)).expect("link");
        }
    }
    std::fs::copy(src.join("calib.txt"), seq.join("calib.txt")).expect("calib");
    let head = |name: &str| {
        let text = std::fs::read_to_string(src.join(name)).expect("readable");
        text.lines()
            .take(FRAMES)
            .map(|l| format!("{l}\n"))
            .collect::<String>()
    };
    std::fs::write(seq.join("times.txt"), head("times.txt")).expect("times");
    std::fs::create_dir_all(dst.join("poses")).expect("mkdir");
    std::fs::write(dst.join("poses/06.txt"), head("poses.txt")).expect("poses");
    seq
}

#[test]
fn kitti06_folder_import_vo_eval() {
    let Some(src) = snippet() else {
        eprintln!("SKIPPED: no kitti_stereo_snippets/kitti06_frames000000-000050 under MOMO_DATA");
        return;
    };
    let tmp = tempfile::tempdir().expect("tempdir");
    let seq = kitti_layout(&src, tmp.path());
    let out = tmp.path().join("seq06");
    let poses = tmp.path().join("poses/06.txt");
    ok(&[
        "import-kitti".as_ref(),
        seq.as_os_str(),
        out.as_os_str(),
        "--poses".as_ref(),
        poses.as_os_str(),
        "--stereo".as_ref(),
        "-q".as_ref(),
    ]);
    for f in ["rig.json", "odometry.csv", "poses.txt", "times.txt"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let rig = std::fs::read_to_string(out.join("rig.json")).expect("rig");
    assert!(rig.contains("cam1"), "a stereo rig: {rig}");

    let est = tmp.path().join("est.txt");
    ok(&[
        "vo".as_ref(),
        out.as_os_str(),
        "-o".as_ref(),
        est.as_os_str(),
        "-q".as_ref(),
    ]);
    let gt = out.join("poses.txt");
    let o = ok(&[
        "eval".as_ref(),
        "--gt".as_ref(),
        gt.as_os_str(),
        "--est".as_ref(),
        est.as_os_str(),
        "--json".as_ref(),
    ]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("eval prints JSON");
    let e = &v["estimates"][0];
    let ate = e["ate_se3"]["stats"]["rmse"].as_f64().expect("ATE");
    let rpe_r = e["rpe"]["rotation_deg"]["rmse"].as_f64().expect("RPE");
    let median = e["rotation_deg"]["median"].as_f64().expect("median");
    eprintln!(
        "KITTI 06 frames 0-{}, stereo vo, default config: ATE SE(3) RMSE {ate:.4} m, RPE rotation RMSE {rpe_r:.4} deg, frame-to-frame rotation median {median:.4} deg",
        FRAMES - 1
    );
    assert_eq!(v["frames"], FRAMES);
    // About 12 m driven; the stereo odometry-scaled estimate stays within centimetres.
    assert!(ate < 0.1, "ATE {ate}");
    assert!(rpe_r < 0.3, "RPE rotation {rpe_r}");

    // TUM output with the imported timestamps; eval reads it (detected) and agrees.
    let tum = tmp.path().join("est.tum");
    ok(&[
        "vo".as_ref(),
        out.as_os_str(),
        "-o".as_ref(),
        tum.as_os_str(),
        "--format".as_ref(),
        "tum".as_ref(),
        "-q".as_ref(),
    ]);
    let text = std::fs::read_to_string(&tum).expect("tum");
    let second: Vec<&str> = text.lines().nth(1).expect("2 lines").split(' ').collect();
    assert_eq!(second.len(), 8);
    let times = std::fs::read_to_string(out.join("times.txt")).expect("times");
    let t1: f64 = times
        .lines()
        .nth(1)
        .expect("line")
        .trim()
        .parse()
        .expect("t");
    assert_eq!(second[0].parse::<f64>().expect("t"), t1);
    let o = ok(&[
        "eval".as_ref(),
        "--gt".as_ref(),
        gt.as_os_str(),
        "--est".as_ref(),
        tum.as_os_str(),
        "--json".as_ref(),
    ]);
    let w: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let ate_tum = w["estimates"][0]["ate_se3"]["stats"]["rmse"]
        .as_f64()
        .expect("ATE");
    assert!((ate_tum - ate).abs() < 1e-9, "{ate_tum} vs {ate}");

    // A calib.txt given as --rig: the error says JSON was expected.
    let o = momo(&[
        "vo".as_ref(),
        seq.join("image_0").as_os_str(),
        "--rig".as_ref(),
        seq.join("calib.txt").as_os_str(),
        "-o".as_ref(),
        est.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("calib.txt:1: not JSON"), "{err}");
}

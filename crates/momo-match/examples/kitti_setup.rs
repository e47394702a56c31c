//! Writes what `momo match` / `momo vo` need for a KITTI image folder (`image_0/`, `image_1/`,
//! `calib.txt` with `P0:`/`P1:` lines, ground-truth `poses.txt`):
//!
//! ```text
//! OUT/rig_mono.json     the left camera (FORMAT.md's KITTI mount), image size from image_0
//! OUT/rig_stereo.json   left + right (baseline from P1)
//! OUT/odometry.csv      arc lengths of the vehicle from the ground truth
//! ```
//!
//! Usage: `cargo run --release -p momo-match --example kitti_setup -- KITTI_DIR OUT_DIR`.

use momo_match::kitti::{arc_lengths_from_poses, kitti_image_rig, read_kitti_projections};
use momo_match::{ImageSequence, MatchError};
use std::path::PathBuf;
use std::process::ExitCode;

fn setup(dir: PathBuf, out: PathBuf) -> Result<(), MatchError> {
    let calib_path = dir.join("calib.txt");
    let calib = read_kitti_projections(&calib_path)?;
    let images = ImageSequence::open(&[dir.join("image_0")])?;
    let first = images
        .path(0, 0)
        .ok_or_else(|| MatchError::Option("no image".into()))?;
    let img = momo_match::load_gray(first)?;
    std::fs::create_dir_all(&out).map_err(|e| momo_io::IoError::io(&out, e))?;
    for (name, stereo) in [("rig_mono.json", false), ("rig_stereo.json", true)] {
        let rig = kitti_image_rig(&calib, img.width(), img.height(), stereo, &calib_path)?;
        momo_io::write_rig(out.join(name), &rig)?;
    }
    let poses = momo_io::read_poses(dir.join("poses.txt"))?;
    let arcs = arc_lengths_from_poses(&poses, &momo_io::kitti::kitti_mount());
    momo_io::write_odometry(out.join("odometry.csv"), &arcs)?;
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [dir, out] = args.as_slice() else {
        eprintln!("usage: kitti_setup KITTI_DIR OUT_DIR");
        return ExitCode::from(2);
    };
    match setup(dir.clone(), out.clone()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kitti_setup: error: {e}");
            ExitCode::from(2)
        }
    }
}

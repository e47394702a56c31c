//! `momo import-kitti`.

use crate::common::Failure;
use momo_io::kitti::{KittiImport, import_l1avgvo};
use std::path::PathBuf;

/// The arguments of `momo import-kitti`.
#[derive(clap::Args, Debug)]
pub(crate) struct ImportKittiArgs {
    /// The data folder (holding calib.txt).
    dir: PathBuf,
    /// Output sequence directory (created; an existing one must be empty unless --force;
    /// removed again on failure if this created it).
    out_dir: PathBuf,
    /// Write into an existing, non-empty output directory (its files of the same names are
    /// replaced).
    #[arg(long)]
    force: bool,
    /// A stereo rig (left = camera 0, right = camera 1) instead of the left camera only.
    #[arg(long)]
    stereo: bool,
    /// Keep at most this many matches per frame pair and camera, spread over the image
    /// (default: all).
    #[arg(long)]
    matches: Option<usize>,
    /// Seed of the sub-sampling (the output is deterministic for a seed).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// `momo import-kitti`.
pub(crate) fn import_kitti(args: ImportKittiArgs) -> Result<(), Failure> {
    if args.matches == Some(0) {
        return Err(Failure::Input(anyhow::anyhow!(
            "--matches must be at least 1"
        )));
    }
    let options = KittiImport {
        stereo: args.stereo,
        matches_per_frame: args.matches,
        seed: args.seed,
    };
    let seq = import_l1avgvo(&args.dir, &options).map_err(Failure::input)?;
    let out = momo_io::OutputDir::prepare(&args.out_dir, args.force).map_err(Failure::input)?;
    momo_io::write_sequence(&args.out_dir, &seq).map_err(Failure::other)?;
    out.keep();
    note!(
        "momo: imported {} frames, {} camera(s), {} matches{}; wrote {}",
        seq.num_frames(),
        seq.rig.len(),
        seq.num_matches(),
        if seq.ground_truth.is_some() {
            " with ground truth and arc lengths"
        } else {
            ""
        },
        args.out_dir.display()
    );
    Ok(())
}

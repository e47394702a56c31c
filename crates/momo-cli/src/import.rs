//! `momo import-kitti`.

use crate::common::Failure;
use momo_io::kitti::{KittiImport, import_l1avgvo};
use std::path::PathBuf;

/// The arguments of `momo import-kitti`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
    momo import-kitti dataset/sequences/06 seq06 --poses dataset/poses/06.txt --stereo\n  \
    momo vo seq06 -o est.txt && momo eval --gt seq06/poses.txt --est est.txt")]
pub(crate) struct ImportKittiArgs {
    /// A KITTI odometry sequence folder (calib.txt, image_0/, image_1/, times.txt), or the
    /// folder of the l1avgvo matches (calib.txt, poses*.txt, `i_to_{i+1}.txt` files).
    dir: PathBuf,
    /// Output sequence directory (created; an existing one must be empty unless --force;
    /// removed again on failure if this created it).
    out_dir: PathBuf,
    /// Ground-truth poses of a sequence folder (KITTI's poses/NN.txt): written as poses.txt,
    /// and odometry.csv arc lengths from them (default: DIR/poses.txt if present).
    #[arg(long)]
    poses: Option<PathBuf>,
    /// Write into an existing, non-empty output directory (its files of the same names are
    /// replaced).
    #[arg(long)]
    force: bool,
    /// A stereo rig (left = camera 0, right = camera 1) instead of the left camera only.
    #[arg(long)]
    stereo: bool,
    /// With --stereo, do not write the cross-camera matches (left at k-1 with right at k and
    /// the reverse; matches.csv column `camera_to`) that measure the metric scale (l1avgvo
    /// matches only).
    #[arg(long)]
    no_cross_camera: bool,
    /// Keep at most this many matches per frame pair and camera, spread over the image
    /// (default: all; l1avgvo matches only).
    #[arg(long)]
    matches: Option<usize>,
    /// Seed of the sub-sampling (the output is deterministic for a seed).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// No summary on stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// `momo import-kitti`.
pub(crate) fn import_kitti(args: ImportKittiArgs) -> Result<(), Failure> {
    if args.matches == Some(0) {
        return Err(Failure::Input(anyhow::anyhow!(
            "--matches must be at least 1"
        )));
    }
    if momo_match::kitti::is_kitti_sequence_folder(&args.dir) {
        let out = prepare_output(&args)?;
        let done = momo_match::kitti::import_kitti_sequence(
            &args.dir,
            &args.out_dir,
            args.poses.as_deref(),
            args.stereo,
        )
        .map_err(|e| {
            if e.is_input() {
                Failure::input(e)
            } else {
                Failure::other(e)
            }
        })?;
        out.keep();
        if !args.quiet {
            note!(
                "momo: imported the KITTI sequence folder: {} frames, {} camera(s){}{}; wrote {} (run `momo vo {} -o est.txt`)",
                done.frames,
                done.cameras,
                if done.ground_truth {
                    ", ground truth and arc lengths"
                } else {
                    ""
                },
                if done.timestamps { ", timestamps" } else { "" },
                args.out_dir.display(),
                args.out_dir.display()
            );
        }
        return Ok(());
    }
    if args.poses.is_some() {
        return Err(Failure::Input(anyhow::anyhow!(
            "--poses applies to a KITTI sequence folder (calib.txt and image_0/), and {} has no image_0/",
            args.dir.display()
        )));
    }
    let options = KittiImport {
        stereo: args.stereo,
        matches_per_frame: args.matches,
        seed: args.seed,
        cross_camera: args.stereo && !args.no_cross_camera,
    };
    let out = prepare_output(&args)?;
    let seq = import_l1avgvo(&args.dir, &options).map_err(Failure::input)?;
    momo_io::write_sequence(&args.out_dir, &seq).map_err(Failure::other)?;
    out.keep();
    if !args.quiet {
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
    }
    Ok(())
}

/// The output directory of an import, before anything is read or written: refused if it is
/// the input folder or if a file written there would replace an input (any spelling or link of
/// it); created, or an existing one accepted only if empty or with `--force`; removed again on
/// failure if this created it ([`momo_io::OutputDir`]).
fn prepare_output(args: &ImportKittiArgs) -> Result<momo_io::OutputDir, Failure> {
    use momo_io::files;
    use std::os::unix::fs::MetadataExt;
    if let (Ok(a), Ok(b)) = (
        std::fs::metadata(&args.dir),
        std::fs::metadata(&args.out_dir),
    ) && (a.dev(), a.ino()) == (b.dev(), b.ino())
    {
        return Err(Failure::input(momo_io::IoError::file(
            &args.out_dir,
            momo_io::IoErrorKind::OutputRefused(format!(
                "it is the input folder {}",
                args.dir.display()
            )),
        )));
    }
    if std::fs::metadata(&args.out_dir).is_ok() {
        let names = [
            "calib.txt",
            files::RIG,
            files::MATCHES,
            files::ODOMETRY,
            files::POSES,
            files::TIMES,
        ];
        let mut inputs: Vec<PathBuf> = names.iter().map(|f| args.dir.join(f)).collect();
        inputs.extend(args.poses.clone());
        let written: Vec<PathBuf> = names[1..].iter().map(|f| args.out_dir.join(f)).collect();
        let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
        let written: Vec<&std::path::Path> = written.iter().map(PathBuf::as_path).collect();
        crate::common::check_outputs(&inputs, &written)?;
    }
    momo_io::OutputDir::prepare(&args.out_dir, args.force).map_err(Failure::input)
}

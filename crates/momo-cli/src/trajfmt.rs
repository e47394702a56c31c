//! `--format kitti|tum` of `momo run` and `momo vo`: the trajectory is written in the KITTI
//! format and, for TUM, rewritten with the sequence's timestamps (`times.txt`).

use crate::common::Failure;
use std::path::Path;

/// The output formats of a trajectory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub(crate) enum OutputFormat {
    /// KITTI: 12 numbers per line, one line per frame.
    #[default]
    Kitti,
    /// TUM: `timestamp tx ty tz qx qy qz qw` per line, timestamps from times.txt.
    Tum,
}

/// Reads the timestamps of `times` if the file exists, checking that it has one per frame
/// (`frames`, when known). `Ok(None)` when absent.
pub(crate) fn read_times_if_present(
    times: &Path,
    frames: Option<usize>,
) -> Result<Option<Vec<f64>>, Failure> {
    if !times.is_file() {
        return Ok(None);
    }
    let t = momo_io::read_times(times).map_err(Failure::input)?;
    if let Some(n) = frames
        && t.len() < n
    {
        return Err(Failure::Input(anyhow::anyhow!(
            "{}: {} timestamps for {n} frames; times.txt needs one line per frame",
            times.display(),
            t.len()
        )));
    }
    Ok(Some(t))
}

/// Checks before a run that a TUM output will have timestamps.
pub(crate) fn check_times(
    format: OutputFormat,
    times: &Path,
    frames: Option<usize>,
) -> Result<Option<Vec<f64>>, Failure> {
    let t = read_times_if_present(times, frames)?;
    if format == OutputFormat::Tum && t.is_none() {
        return Err(Failure::Input(anyhow::anyhow!(
            "{}: not found; --format tum needs one timestamp per frame (KITTI's times.txt)",
            times.display()
        )));
    }
    Ok(t)
}

/// Rewrites the KITTI trajectory `output` as TUM with `times` (one per pose at least).
pub(crate) fn finish(
    format: OutputFormat,
    output: &Path,
    times: Option<&[f64]>,
) -> Result<(), Failure> {
    let (OutputFormat::Tum, Some(times)) = (format, times) else {
        return Ok(());
    };
    let poses = momo_io::read_poses(output).map_err(Failure::other)?;
    if times.len() < poses.len() {
        return Err(Failure::Input(anyhow::anyhow!(
            "{} timestamps for {} poses; times.txt needs one line per frame",
            times.len(),
            poses.len()
        )));
    }
    momo_io::write_tum(output, &times[..poses.len()], &poses).map_err(Failure::other)
}

//! `poses.txt`: trajectories in the KITTI odometry format (`FORMAT.md`, section "poses.txt"):
//! one line per frame, the first three rows of the 4x4 pose, row-major, 12 numbers.

use crate::atomic::{AtomicFile, put, stage_atomic};
use crate::error::{IoError, IoErrorKind};
use crate::text::{Exact, LineReader, is_blank, parse_f64};
use momo_core::Pose;
use nalgebra::{Matrix3, Matrix4, Vector3};
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// Tolerance on `RᵀR = I` and `det R = 1` for poses read from KITTI files (1e-6, as for
/// extrinsics). The KITTI ground truth is printed with 7 significant digits; its largest
/// deviation (sequences 00-10) is about 3e-7.
pub const POSE_ORTHONORMAL_TOLERANCE: f64 = 1e-6;

/// Parses one KITTI line.
fn parse_pose(line: &str) -> Result<Pose<f64>, IoErrorKind> {
    let mut v = [0.0; 12];
    let mut n = 0;
    for (i, tok) in line.split_whitespace().enumerate() {
        if i < 12 {
            v[i] = parse_f64(&format!("number {}", i + 1), tok)?;
        }
        n += 1;
    }
    if n != 12 {
        return Err(IoErrorKind::FieldCount {
            expected: 12,
            found: n,
        });
    }
    let pose = Pose::new(
        Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]),
        Vector3::new(v[3], v[7], v[11]),
    );
    let error = pose.orthonormality_error();
    if error.is_nan() || error > POSE_ORTHONORMAL_TOLERANCE {
        return Err(IoErrorKind::PoseNotOrthonormal {
            error,
            tolerance: POSE_ORTHONORMAL_TOLERANCE,
        });
    }
    Ok(pose)
}

/// Reads KITTI poses from `reader` (`path` only names the source in errors): line k is the pose
/// of frame k. Numbers are separated by any whitespace; trailing blank lines are ignored, blank
/// lines between poses are an error.
pub fn read_poses_from<R: BufRead>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<Pose<f64>>, IoError> {
    let path = path.as_ref();
    let mut lines = LineReader::new(reader);
    let mut out = Vec::new();
    let mut blank: Option<usize> = None;
    loop {
        let line = match lines.next_line() {
            Ok(Some(l)) => l,
            Ok(None) => break,
            Err(k) => return Err(IoError::at(path, lines.line(), k)),
        };
        if is_blank(line) {
            blank = blank.or(Some(lines.line()));
            continue;
        }
        if let Some(b) = blank {
            return Err(IoError::at(path, b, IoErrorKind::BlankLine));
        }
        out.push(parse_pose(line).map_err(|k| IoError::at(path, lines.line(), k))?);
    }
    Ok(out)
}

/// Reads a KITTI poses file (see [`read_poses_from`]).
pub fn read_poses(path: impl AsRef<Path>) -> Result<Vec<Pose<f64>>, IoError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| IoError::io(path, e))?;
    read_poses_from(BufReader::new(file), path)
}

/// Writes one trajectory line, the row loop of the KITTI and the TUM writers: `first` (the TUM
/// timestamp) if any, then the numbers `numbers` takes from the pose's 4x4 matrix, separated
/// by single spaces, round-trip exact. Fails, writing nothing of the line, if the pose or
/// `first` is not finite (checked before `numbers` sees the matrix).
pub(crate) fn put_pose_line<const N: usize>(
    f: &mut AtomicFile,
    first: Option<f64>,
    p: &Pose<f64>,
    numbers: impl FnOnce(&Matrix4<f64>) -> [f64; N],
) -> Result<(), IoError> {
    let m = p.to_homogeneous();
    if m.iter().chain(&first).any(|v| !v.is_finite()) {
        let what = if first.is_some() {
            "a pose or timestamp with non-finite entries"
        } else {
            "a pose with non-finite entries"
        };
        return Err(IoError::file(
            f.path(),
            IoErrorKind::InvalidData(what.into()),
        ));
    }
    for (i, v) in first.into_iter().chain(numbers(&m)).enumerate() {
        let sep = if i == 0 { "" } else { " " };
        put!(f, "{sep}{}", Exact(v))?;
    }
    put!(f, "\n")
}

/// Writes one KITTI line (the first three rows of the pose, 12 numbers).
fn put_pose(f: &mut AtomicFile, p: &Pose<f64>) -> Result<(), IoError> {
    put_pose_line(f, None, p, |m| -> [f64; 12] {
        std::array::from_fn(|i| m[(i / 4, i % 4)])
    })
}

/// Writes a KITTI poses file atomically. Fails (writing nothing) on non-finite poses.
pub fn write_poses(path: impl AsRef<Path>, poses: &[Pose<f64>]) -> Result<(), IoError> {
    stage_poses(path.as_ref(), poses)?.commit()
}

/// [`write_poses`] without the commit.
pub(crate) fn stage_poses(path: &Path, poses: &[Pose<f64>]) -> Result<AtomicFile, IoError> {
    stage_atomic(path, |f| poses.iter().try_for_each(|p| put_pose(f, p)))
}

/// Writes a KITTI poses file one pose at a time, atomically: the file appears (replacing any old
/// one) only on [`finish`](Self::finish); dropping the writer before removes the temporary file.
pub struct PoseWriter {
    file: AtomicFile,
    count: usize,
}

impl PoseWriter {
    /// Starts writing `path` (a temporary file in the same directory).
    pub fn create(path: impl AsRef<Path>) -> Result<Self, IoError> {
        Ok(Self {
            file: AtomicFile::create(path.as_ref())?,
            count: 0,
        })
    }

    /// Appends the pose of the next frame. Fails on non-finite entries.
    pub fn push(&mut self, pose: &Pose<f64>) -> Result<(), IoError> {
        put_pose(&mut self.file, pose)?;
        self.count += 1;
        Ok(())
    }

    /// Number of poses pushed.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True before the first push.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Flushes, syncs and renames the file into place.
    pub fn finish(self) -> Result<(), IoError> {
        self.file.commit()
    }

    /// The file being written, to commit it together with other outputs
    /// ([`commit_all`](crate::commit_all)).
    pub fn into_file(self) -> AtomicFile {
        self.file
    }
}

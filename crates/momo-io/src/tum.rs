//! Timestamps and the TUM trajectory format (`docs/FORMAT.md`, sections "times.txt" and
//! "Trajectories"):
//!
//! - `times.txt` (KITTI odometry): one timestamp in seconds per frame and line;
//! - TUM (`evo`, the TUM RGB-D benchmark): one line per pose, `timestamp tx ty tz qx qy qz qw`
//!   (the position and the unit quaternion of the orientation of the camera in the first
//!   frame), `#` comment lines allowed;
//! - [`read_trajectory`] reads either format (detected from the number of numbers on the first
//!   data line, 12 KITTI and 8 TUM, or forced) into a [`Trajectory`].

use crate::atomic::{AtomicFile, put, write_atomic};
use crate::error::{IoError, IoErrorKind};
use crate::poses::read_poses_from;
use crate::text::{Exact, LineReader, is_blank, parse_f64};
use momo_core::Pose;
use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};
use std::fs::File;
use std::io::{BufRead, BufReader, Cursor, Read};
use std::path::Path;

/// Name of the timestamp file in a sequence directory (KITTI's).
pub const TIMES: &str = "times.txt";

/// The file formats of a trajectory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrajectoryFormat {
    /// KITTI: 12 numbers per line (`poses.txt`), no timestamps.
    Kitti,
    /// TUM: `timestamp tx ty tz qx qy qz qw` per line.
    Tum,
}

/// A trajectory as read from a file.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    /// The poses, one per frame.
    pub poses: Vec<Pose<f64>>,
    /// The timestamps in seconds (TUM files), one per pose.
    pub timestamps: Option<Vec<f64>>,
    /// The format the file was read as.
    pub format: TrajectoryFormat,
}

/// Deviation of a TUM quaternion's norm from 1 that is accepted (and normalised away): 1e-4,
/// enough for quaternions printed with 6 digits.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-4;

/// Reads KITTI's `times.txt`: one finite timestamp (seconds) per line, non-decreasing; trailing
/// blank lines are ignored.
pub fn read_times(path: impl AsRef<Path>) -> Result<Vec<f64>, IoError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut lines = LineReader::new(BufReader::new(file));
    let mut out: Vec<f64> = Vec::new();
    let mut blank = None;
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
        let t =
            parse_f64("timestamp", line.trim()).map_err(|k| IoError::at(path, lines.line(), k))?;
        if let Some(&prev) = out.last()
            && t < prev
        {
            return Err(IoError::at(
                path,
                lines.line(),
                IoErrorKind::Invalid(format!(
                    "timestamps must not decrease, found {t} after {prev}"
                )),
            ));
        }
        out.push(t);
    }
    Ok(out)
}

/// Writes `times.txt` (one timestamp per line, round-trip exact), atomically.
pub fn write_times(path: impl AsRef<Path>, times: &[f64]) -> Result<(), IoError> {
    write_atomic(path.as_ref(), |f| {
        times.iter().try_for_each(|t| put!(f, "{}\n", Exact(*t)))
    })
}

/// Parses one TUM line.
fn parse_tum(line: &str) -> Result<(f64, Pose<f64>), IoErrorKind> {
    let mut v = [0.0; 8];
    let mut n = 0;
    const NAMES: [&str; 8] = ["timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"];
    for (i, tok) in line.split_whitespace().enumerate() {
        if i < 8 {
            v[i] = parse_f64(NAMES[i], tok)?;
        }
        n += 1;
    }
    if n != 8 {
        return Err(IoErrorKind::FieldCount {
            expected: 8,
            found: n,
        });
    }
    let q = Quaternion::new(v[7], v[4], v[5], v[6]);
    let norm = q.norm();
    if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
        return Err(IoErrorKind::Invalid(format!(
            "the quaternion (qx qy qz qw) has norm {norm}, expected 1 (tolerance {QUATERNION_NORM_TOLERANCE:e})"
        )));
    }
    let r = UnitQuaternion::from_quaternion(q).to_rotation_matrix();
    Ok((
        v[0],
        Pose::new(r.into_inner(), Vector3::new(v[1], v[2], v[3])),
    ))
}

/// Reads a TUM trajectory from `reader` (`path` names the source in errors): timestamps and
/// poses. Lines starting with `#` and blank lines are skipped.
pub fn read_tum_from<R: BufRead>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<(Vec<f64>, Vec<Pose<f64>>), IoError> {
    let path = path.as_ref();
    let mut lines = LineReader::new(reader);
    let (mut times, mut poses) = (Vec::new(), Vec::new());
    loop {
        let line = match lines.next_line() {
            Ok(Some(l)) => l,
            Ok(None) => break,
            Err(k) => return Err(IoError::at(path, lines.line(), k)),
        };
        if is_blank(line) || line.trim_start().starts_with('#') {
            continue;
        }
        let (t, p) = parse_tum(line).map_err(|k| IoError::at(path, lines.line(), k))?;
        times.push(t);
        poses.push(p);
    }
    Ok((times, poses))
}

/// Reads a TUM trajectory file (see [`read_tum_from`]).
pub fn read_tum(path: impl AsRef<Path>) -> Result<(Vec<f64>, Vec<Pose<f64>>), IoError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| IoError::io(path, e))?;
    read_tum_from(BufReader::new(file), path)
}

/// Writes one TUM line: timestamp, translation, quaternion (x y z w).
fn put_tum(f: &mut AtomicFile, t: f64, p: &Pose<f64>) -> Result<(), IoError> {
    crate::poses::put_pose_line(f, Some(t), p, |_| {
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&p.rotation));
        let v = &p.translation;
        [v.x, v.y, v.z, q.i, q.j, q.k, q.w]
    })
}

/// Writes a TUM trajectory (`times[k] poses[k]` per line), atomically. Fails on different
/// lengths or non-finite values, writing nothing.
pub fn write_tum(
    path: impl AsRef<Path>,
    times: &[f64],
    poses: &[Pose<f64>],
) -> Result<(), IoError> {
    let path = path.as_ref();
    if times.len() != poses.len() {
        return Err(IoError::file(
            path,
            IoErrorKind::InvalidData(format!(
                "{} timestamps for {} poses",
                times.len(),
                poses.len()
            )),
        ));
    }
    write_atomic(path, |f| {
        times
            .iter()
            .zip(poses)
            .try_for_each(|(t, p)| put_tum(f, *t, p))
    })
}

/// Detects the format of trajectory text: the number of numbers on the first line that is not
/// blank or a `#` comment (12 KITTI, 8 TUM).
fn detect(text: &str, path: &Path) -> Result<TrajectoryFormat, IoError> {
    for (i, line) in text.lines().enumerate() {
        if is_blank(line) || line.trim_start().starts_with('#') {
            continue;
        }
        return match line.split_whitespace().count() {
            12 => Ok(TrajectoryFormat::Kitti),
            8 => Ok(TrajectoryFormat::Tum),
            n => Err(IoError::at(
                path,
                i + 1,
                IoErrorKind::Invalid(format!(
                    "{n} numbers: neither a KITTI pose (12 numbers) nor a TUM pose \
                     (8: timestamp tx ty tz qx qy qz qw)"
                )),
            )),
        };
    }
    Ok(TrajectoryFormat::Kitti)
}

/// Reads a trajectory in `format`, or in the format detected from its first data line when
/// `None` (12 numbers KITTI, 8 TUM).
pub fn read_trajectory(
    path: impl AsRef<Path>,
    format: Option<TrajectoryFormat>,
) -> Result<Trajectory, IoError> {
    let path = path.as_ref();
    let mut text = String::new();
    File::open(path)
        .map_err(|e| IoError::io(path, e))?
        .take(1 << 30)
        .read_to_string(&mut text)
        .map_err(|e| IoError::io(path, e))?;
    let format = match format {
        Some(f) => f,
        None => detect(&text, path)?,
    };
    Ok(match format {
        TrajectoryFormat::Kitti => Trajectory {
            poses: read_poses_from(Cursor::new(text.as_bytes()), path)?,
            timestamps: None,
            format,
        },
        TrajectoryFormat::Tum => {
            let (t, poses) = read_tum_from(Cursor::new(text.as_bytes()), path)?;
            Trajectory {
                poses,
                timestamps: Some(t),
                format,
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::so3_exp;

    #[test]
    fn tum_round_trip_and_detection() {
        let dir = tempfile::tempdir().expect("tempdir");
        let poses: Vec<Pose<f64>> = (0..5)
            .map(|k| {
                let t = k as f64;
                Pose::new(
                    so3_exp(&Vector3::new(0.1 * t, -0.3, 2.9)),
                    Vector3::new(t, -t, 0.5),
                )
            })
            .collect();
        let times: Vec<f64> = (0..5).map(|k| 1.5 + 0.1 * k as f64).collect();
        let path = dir.path().join("t.tum");
        write_tum(&path, &times, &poses).expect("write");
        let back = read_trajectory(&path, None).expect("read");
        assert_eq!(back.format, TrajectoryFormat::Tum);
        assert_eq!(back.timestamps.as_deref(), Some(&times[..]));
        for (a, b) in back.poses.iter().zip(&poses) {
            assert!((a.rotation - b.rotation).amax() < 1e-12);
            assert_eq!(a.translation, b.translation);
        }
        let kitti = dir.path().join("k.txt");
        crate::write_poses(&kitti, &poses).expect("write");
        assert_eq!(
            read_trajectory(&kitti, None).expect("read").format,
            TrajectoryFormat::Kitti
        );
        std::fs::write(&kitti, "# c\n1 2 3\n").expect("write");
        let e = read_trajectory(&kitti, None).unwrap_err().to_string();
        assert!(e.contains("k.txt:2: 3 numbers"), "{e}");
    }

    #[test]
    fn times_reject_bad_lines() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join(TIMES);
        std::fs::write(&p, "0.000000e+00\n1.036594e-01\n\n").expect("write");
        assert_eq!(read_times(&p).expect("read"), vec![0.0, 0.1036594]);
        std::fs::write(&p, "0.0\n0.2\n0.1\n").expect("write");
        let e = read_times(&p).unwrap_err().to_string();
        assert!(
            e.contains("times.txt:3: timestamps must not decrease"),
            "{e}"
        );
        std::fs::write(&p, "0.0\nabc\n").expect("write");
        assert!(
            read_times(&p)
                .unwrap_err()
                .to_string()
                .contains("times.txt:2:")
        );
    }
}

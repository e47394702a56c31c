//! # momo-io
//!
//! Reading and writing *sequences* exactly as `FORMAT.md` (the contract between `momo` and the
//! tools around it) defines them:
//!
//! ```text
//! SEQ/
//!   rig.json        required  cameras: model, intrinsics, extrinsics      -> read_rig / write_rig
//!   matches.csv     required  matches between consecutive frames          -> MatchReader / MatchWriter
//!   odometry.csv    optional  arc length per frame pair                   -> read_odometry / write_odometry
//!   poses.txt       optional  ground truth, KITTI format                  -> read_poses / write_poses / PoseWriter
//!   times.txt       optional  timestamp per frame (s), KITTI's            -> read_times / write_times
//! ```
//!
//! Trajectories can also be read and written in the TUM format (`read_tum`, `write_tum`,
//! [`read_trajectory`] detects the format).
//!
//! - [`read_sequence`] loads a whole directory into a [`Sequence`]; [`read_sparse_sequence`]
//!   into a [`SparseSequence`] that holds only the frame pairs with matches (memory grows with
//!   the files, not with the last frame number); [`MatchReader`] streams `matches.csv` one frame
//!   pair at a time (memory bounded by one frame pair).
//! - Every input error is an [`IoError`] whose `Display` is `path:line: reason` (or
//!   `path: reason` when no line applies); [`IoErrorKind`] says which rule was broken. Readers
//!   never panic and never hold more than [`MAX_LINE_BYTES`] of a line in memory.
//! - Every writer is atomic: it writes a temporary file beside the target and renames it into
//!   place, so a failed write leaves no partial file ([`AtomicFile`] does this for any file).
//!   Numbers are printed so that they read back to the same bits.
//!
//! ```
//! use momo_core::{Camera, FrameObservations, Observation, Pinhole, Pose, Rig};
//! use momo_io::{Sequence, read_sequence, write_sequence};
//! use nalgebra::{Matrix3, Vector2, Vector3};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let camera = Camera::Pinhole(Pinhole {
//!     fx: 718.856, fy: 718.856, cx: 607.1928, cy: 185.2157, width: 1241.0, height: 376.0,
//! });
//! // FORMAT.md's example mount: 1 m ahead of the motion centre, 1.65 m up, looking forward.
//! let mount = Pose::new(
//!     Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
//!     Vector3::new(1.0, 0.0, 1.65),
//! );
//! let rig = Rig::mono(camera, mount)?;
//! let mut pair = FrameObservations::new(1);
//! pair.per_camera[0].push(
//!     Observation::new(&camera, Vector2::new(612.31, 201.77), Vector2::new(615.02, 203.40))
//!         .expect("inside the image"),
//! );
//! let seq = Sequence {
//!     rig,
//!     frames: vec![FrameObservations::new(1), pair],
//!     arc_lengths: Some(vec![None, Some(0.8571)]),
//!     ground_truth: None,
//! };
//!
//! let dir = tempfile::tempdir()?;
//! write_sequence(dir.path(), &seq)?;
//! let back = read_sequence(dir.path())?;
//! assert_eq!(back, seq);
//! assert_eq!(back.num_frames(), 2);
//!
//! // Errors name file, line and reason.
//! std::fs::write(dir.path().join("odometry.csv"), "frame,arc_length\n1,-2000\n")?;
//! let err = read_sequence(dir.path()).unwrap_err();
//! assert!(err.to_string().ends_with(
//!     "odometry.csv:2: arc_length -2.000000e3 m is beyond the supported -1000..=1000 m per frame pair"
//! ));
//! # Ok(())
//! # }
//! ```

mod atomic;
pub mod calib_import;
pub mod error;
pub mod kitti;
pub mod matches;
pub mod odometry;
pub mod poses;
pub mod rig;
mod text;
pub mod tum;

pub use atomic::{AtomicFile, OutputDir, check_outputs, commit_all, remove_temporaries};
pub use error::{IoError, IoErrorKind};
pub use matches::{
    MATCHES_HEADER, MATCHES_HEADER_CROSS, MAX_FRAME, MatchReader, MatchWriter,
    PIXEL_MARGIN_FRACTION, write_matches,
};
pub use odometry::{
    ODOMETRY_HEADER, read_odometry, read_odometry_from, read_odometry_rows,
    read_odometry_rows_from, write_odometry,
};
pub use poses::{POSE_ORTHONORMAL_TOLERANCE, PoseWriter, read_poses, read_poses_from, write_poses};
pub use rig::{MAX_RIG_BYTES, read_rig, read_rig_from_str, rig_to_json, write_rig};
pub use text::MAX_LINE_BYTES;
pub use tum::{
    Trajectory, TrajectoryFormat, read_times, read_trajectory, read_tum, write_times, write_tum,
};

use momo_core::{FrameObservations, Pose, Rig};
use std::path::Path;

/// File names inside a sequence directory (`FORMAT.md`).
pub mod files {
    /// Required: the cameras.
    pub const RIG: &str = "rig.json";
    /// Required: the matches.
    pub const MATCHES: &str = "matches.csv";
    /// Optional: arc lengths.
    pub const ODOMETRY: &str = "odometry.csv";
    /// Optional: ground truth.
    pub const POSES: &str = "poses.txt";
    /// Optional: timestamps (seconds), one per frame.
    pub const TIMES: &str = "times.txt";
}

/// A whole sequence in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Sequence {
    /// The cameras (`rig.json`).
    pub rig: Rig,
    /// `frames[k]` holds the matches of frame pair `(k-1, k)`; `frames[0]` is empty. After
    /// [`read_sequence`] its length is [`num_frames`](Self::num_frames) and each entry has one
    /// list per camera.
    pub frames: Vec<FrameObservations>,
    /// `odometry.csv` if present: `arc_lengths[k]` for frame pair `(k-1, k)`, `None` where no
    /// row gives it (always at index 0). Padded to `num_frames()` by [`read_sequence`].
    pub arc_lengths: Option<Vec<Option<f64>>>,
    /// `poses.txt` if present: `T_cam0(0)_cam0(k)` per line, as read (not padded or truncated).
    pub ground_truth: Option<Vec<Pose<f64>>>,
}

impl Sequence {
    /// Number of frames: `max(last frame in matches.csv, last frame in odometry.csv) + 1`
    /// (`FORMAT.md`), i.e. the larger of `frames.len()` and `arc_lengths.len()`, at least 1.
    pub fn num_frames(&self) -> usize {
        let odo = self.arc_lengths.as_ref().map_or(0, Vec::len);
        self.frames.len().max(odo).max(1)
    }

    /// Number of match rows over all frames and cameras.
    pub fn num_matches(&self) -> usize {
        self.frames.iter().map(FrameObservations::len).sum()
    }

    /// The odometry arc length of frame pair `(k-1, k)`: `None` without `odometry.csv`, without
    /// a row for `k`, or past the end.
    pub fn arc_length(&self, k: usize) -> Option<f64> {
        self.arc_lengths.as_ref()?.get(k).copied().flatten()
    }
}

/// A whole sequence in memory with sparse frame numbers: only the frame pairs that have matches
/// and the frames that have an odometry row are held, so that a `matches.csv` whose frame
/// numbers jump (a last frame of 1,000,000 after a few hundred frame pairs) takes memory in
/// proportion to its rows, not to its last frame. Read by [`read_sparse_sequence`].
#[derive(Clone, Debug, PartialEq)]
pub struct SparseSequence {
    /// The cameras (`rig.json`).
    pub rig: Rig,
    /// `(k, matches of frame pair (k-1, k))` for every frame pair with at least one match, `k`
    /// increasing; each entry has one list per camera.
    pub frames: Vec<(usize, FrameObservations)>,
    /// The rows of `odometry.csv` if present: `(k, arc length of frame pair (k-1, k))`, `k`
    /// increasing.
    pub arc_lengths: Option<Vec<(usize, f64)>>,
    /// `poses.txt` if present: `T_cam0(0)_cam0(k)` per line, as read.
    pub ground_truth: Option<Vec<Pose<f64>>>,
    /// Number of frames: `max(last frame in matches.csv, last frame in odometry.csv) + 1`
    /// (`FORMAT.md`), at least 1; the same as [`Sequence::num_frames`] of the dense sequence.
    pub num_frames: usize,
}

impl SparseSequence {
    /// The matches of frame pair `(k-1, k)`, `None` if it has none (binary search).
    pub fn frame(&self, k: usize) -> Option<&FrameObservations> {
        let i = self.frames.binary_search_by_key(&k, |(f, _)| *f).ok()?;
        self.frames.get(i).map(|(_, obs)| obs)
    }

    /// The odometry arc length of frame pair `(k-1, k)`, `None` without a row (binary search).
    pub fn arc_length(&self, k: usize) -> Option<f64> {
        let a = self.arc_lengths.as_ref()?;
        let i = a.binary_search_by_key(&k, |(f, _)| *f).ok()?;
        a.get(i).map(|(_, l)| *l)
    }

    /// Number of match rows over all frames and cameras.
    pub fn num_matches(&self) -> usize {
        self.frames.iter().map(|(_, f)| f.len()).sum()
    }

    /// The dense [`Sequence`] (every frame pair up to [`num_frames`](Self::num_frames) in
    /// memory), as [`read_sequence`] returns it.
    pub fn into_dense(self) -> Sequence {
        let num = self.num_frames.max(1);
        let n = self.rig.len();
        let mut frames = Vec::with_capacity(num);
        for (k, obs) in self.frames {
            frames.resize_with(k, || FrameObservations::new(n));
            frames.push(obs);
        }
        frames.resize_with(num, || FrameObservations::new(n));
        let arc_lengths = self.arc_lengths.map(|rows| {
            let mut a = vec![None; num];
            for (k, l) in rows {
                if let Some(slot) = a.get_mut(k) {
                    *slot = Some(l);
                }
            }
            a
        });
        Sequence {
            rig: self.rig,
            frames,
            arc_lengths,
            ground_truth: self.ground_truth,
        }
    }
}

impl From<Sequence> for SparseSequence {
    /// Keeps the frame pairs with matches and the arc lengths that are given.
    fn from(seq: Sequence) -> Self {
        let num_frames = seq.num_frames();
        let frames = seq
            .frames
            .into_iter()
            .enumerate()
            .filter(|(_, obs)| !obs.is_empty())
            .collect();
        let arc_lengths = seq.arc_lengths.map(|a| {
            a.into_iter()
                .enumerate()
                .filter_map(|(k, l)| l.map(|l| (k, l)))
                .collect()
        });
        Self {
            rig: seq.rig,
            frames,
            arc_lengths,
            ground_truth: seq.ground_truth,
            num_frames,
        }
    }
}

/// Opens an optional file: `Ok(None)` if it does not exist (a dangling symbolic link exists:
/// it is an error, not a missing file).
fn optional<T>(
    path: &Path,
    read: impl FnOnce(&Path) -> Result<T, IoError>,
) -> Result<Option<T>, IoError> {
    let dangling = std::fs::symlink_metadata(path).is_ok() && std::fs::metadata(path).is_err();
    if dangling {
        return Err(IoError::file(path, IoErrorKind::DanglingLink));
    }
    match read(path) {
        Ok(v) => Ok(Some(v)),
        Err(IoError {
            kind: IoErrorKind::NotFound,
            line: None,
            ..
        }) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Loads a sequence directory: `rig.json` and `matches.csv` (required), `odometry.csv` and
/// `poses.txt` (optional). `frames` and `arc_lengths` are padded to
/// [`num_frames`](Sequence::num_frames): memory grows with the last frame number (see
/// [`read_sparse_sequence`] for sequences with sparse frame numbers).
pub fn read_sequence(dir: impl AsRef<Path>) -> Result<Sequence, IoError> {
    read_sparse_sequence(dir).map(SparseSequence::into_dense)
}

/// Loads a sequence directory as [`read_sequence`] does (the same files, checks and errors),
/// holding only the frame pairs that have matches and the odometry rows: memory grows with the
/// files' rows, not with their frame numbers.
pub fn read_sparse_sequence(dir: impl AsRef<Path>) -> Result<SparseSequence, IoError> {
    let dir = dir.as_ref();
    let rig = read_rig(dir.join(files::RIG))?;
    let mut frames = Vec::new();
    for item in MatchReader::open(dir.join(files::MATCHES), &rig)? {
        let (k, obs) = item?;
        if !obs.is_empty() {
            frames.push((k, obs));
        }
    }
    let arc_lengths = optional(&dir.join(files::ODOMETRY), |p| read_odometry_rows(p))?;
    let ground_truth = optional(&dir.join(files::POSES), |p| read_poses(p))?;
    let last = |k: Option<&usize>| k.copied().unwrap_or(0);
    let num_frames = last(frames.last().map(|(k, _)| k)).max(last(
        arc_lengths.as_ref().and_then(|a| a.last().map(|(k, _)| k)),
    )) + 1;
    Ok(SparseSequence {
        rig,
        frames,
        arc_lengths,
        ground_truth,
        num_frames,
    })
}

/// Checks matches against the rig as the reader will: camera ids, pixels near the image and
/// unprojectable.
fn check_matches(rig: &Rig, frames: &[FrameObservations]) -> Result<(), IoErrorKind> {
    let cameras = rig.cameras();
    for (k, frame) in frames.iter().enumerate() {
        for (j, list) in frame.per_camera.iter().enumerate() {
            if list.is_empty() {
                continue;
            }
            let Some(cam) = cameras.get(j) else {
                return Err(IoErrorKind::InvalidData(format!(
                    "frame {k} has matches of camera {j}, but the rig has {} camera(s)",
                    cameras.len()
                )));
            };
            let margin = matches::pixel_margin(&cam.model);
            for o in list {
                for (field, px) in [("u0,v0", o.px0), ("u1,v1", o.px1)] {
                    matches::check_pixel(&cam.model, margin, j, field, px)
                        .map_err(|e| IoErrorKind::InvalidData(format!("frame {k}: {e}")))?;
                }
            }
        }
    }
    Ok(())
}

/// Writes a sequence directory (created if needed), each file atomically. The matches are
/// first checked against the rig as [`read_sequence`] will check them (camera ids, pixels within
/// [`PIXEL_MARGIN_FRACTION`] of the image, unprojectable); on failure nothing is written. Optional files that
/// the sequence does not have (`arc_lengths` or `ground_truth` is `None`) are removed from the
/// directory if present, so that reading it back gives this sequence.
///
/// The format cannot represent trailing frame pairs that have neither a match nor an arc length
/// (the number of frames is the last frame named in `matches.csv` or `odometry.csv`, plus one):
/// such a sequence reads back with fewer frames.
pub fn write_sequence(dir: impl AsRef<Path>, seq: &Sequence) -> Result<(), IoError> {
    let dir = dir.as_ref();
    check_matches(&seq.rig, &seq.frames).map_err(|k| IoError::file(dir.join(files::MATCHES), k))?;
    std::fs::create_dir_all(dir).map_err(|e| IoError::io(dir, e))?;
    // Every file is written to a temporary first; all are committed together (all or none).
    let mut staged = vec![
        rig::stage_rig(&dir.join(files::RIG), &seq.rig)?,
        matches::stage_matches(&dir.join(files::MATCHES), &seq.frames)?,
    ];
    if let Some(a) = &seq.arc_lengths {
        staged.push(odometry::stage_odometry(&dir.join(files::ODOMETRY), a)?);
    }
    if let Some(g) = &seq.ground_truth {
        staged.push(poses::stage_poses(&dir.join(files::POSES), g)?);
    }
    commit_all(staged)?;
    let remove = |name: &str| {
        let p = dir.join(name);
        match std::fs::remove_file(&p) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(IoError::io(&p, e)),
            _ => Ok(()),
        }
    };
    if seq.arc_lengths.is_none() {
        remove(files::ODOMETRY)?;
    }
    if seq.ground_truth.is_none() {
        remove(files::POSES)?;
    }
    Ok(())
}

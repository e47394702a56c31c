//! The error type of this crate: [`IoError`] = where ([`IoError::path`], [`IoError::line`]) plus
//! why ([`IoErrorKind`]).
//!
//! `Display` is `path:line: reason`, or `path: reason` where no line applies (a missing file, an
//! error while writing), so that editors and terminals can jump to the offending line.

use std::fmt;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// An error while reading or writing a sequence file: the file, the 1-based line where there is
/// one, and the reason.
#[derive(Debug)]
pub struct IoError {
    /// The file (as given by the caller, e.g. `seq/matches.csv`).
    pub path: PathBuf,
    /// 1-based line number, if the error belongs to a line.
    pub line: Option<usize>,
    /// What went wrong.
    pub kind: IoErrorKind,
}

impl IoError {
    /// An error in `path` at `line` (if any).
    pub fn new(path: impl Into<PathBuf>, line: Option<usize>, kind: IoErrorKind) -> Self {
        Self {
            path: path.into(),
            line,
            kind,
        }
    }

    /// An error that belongs to the whole file.
    pub fn file(path: impl Into<PathBuf>, kind: IoErrorKind) -> Self {
        Self::new(path, None, kind)
    }

    /// An error at a 1-based line.
    pub fn at(path: impl Into<PathBuf>, line: usize, kind: IoErrorKind) -> Self {
        Self::new(path, Some(line), kind)
    }

    /// Wraps an operating-system error, mapping "not found" to [`IoErrorKind::NotFound`].
    pub fn io(path: impl Into<PathBuf>, e: std::io::Error) -> Self {
        let kind = if e.kind() == std::io::ErrorKind::NotFound {
            IoErrorKind::NotFound
        } else {
            IoErrorKind::Io(e)
        };
        Self::file(path, kind)
    }

    /// The file the error belongs to.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl fmt::Display for IoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}: {}", self.path.display(), line, self.kind),
            None => write!(f, "{}: {}", self.path.display(), self.kind),
        }
    }
}

impl std::error::Error for IoError {}

/// Why a file was rejected (or could not be written). `Display` gives the reason only; the
/// location is added by [`IoError`].
#[derive(Debug, Error)]
pub enum IoErrorKind {
    /// A required file (or the sequence directory) does not exist.
    #[error("file not found")]
    NotFound,
    /// Any other operating-system error while reading or writing.
    #[error("{0}")]
    Io(std::io::Error),
    /// A line longer than [`MAX_LINE_BYTES`](crate::MAX_LINE_BYTES) (or a file larger than
    /// [`MAX_RIG_BYTES`](crate::MAX_RIG_BYTES) for `rig.json`).
    #[error("longer than {limit} bytes")]
    TooLong {
        /// The limit in bytes.
        limit: usize,
    },
    /// The bytes are not valid UTF-8.
    #[error("invalid UTF-8")]
    InvalidUtf8,
    /// `rig.json` is not valid JSON or does not have the structure of `FORMAT.md` (missing or
    /// unknown fields, unknown `model.type`, wrong value types). Message and column come from
    /// serde_json.
    #[error("{message} (column {column})")]
    Json {
        /// 1-based column.
        column: usize,
        /// serde_json's description.
        message: String,
    },
    /// `cameras` is an empty list.
    #[error("`cameras` is an empty list; a rig needs at least one camera")]
    EmptyRig,
    /// A camera model with invalid intrinsics (non-positive focal length or image size).
    #[error("camera {camera}: {reason}")]
    InvalidCamera {
        /// Camera index in `cameras`.
        camera: usize,
        /// What is wrong.
        reason: String,
    },
    /// `T_vehicle_camera` is not a 4x4 matrix with bottom row `0 0 0 1`.
    #[error(
        "camera {camera}: T_vehicle_camera must be a 4x4 matrix with bottom row 0 0 0 1: {reason}"
    )]
    BadExtrinsic {
        /// Camera index in `cameras`.
        camera: usize,
        /// What is wrong.
        reason: String,
    },
    /// The rotation block of `T_vehicle_camera` is not orthonormal with determinant +1.
    #[error(
        "camera {camera}: the rotation of T_vehicle_camera is not orthonormal with determinant +1 \
         (error {error:.3e}, tolerance {tolerance:e})"
    )]
    ExtrinsicNotOrthonormal {
        /// Camera index in `cameras`.
        camera: usize,
        /// Largest deviation of `RᵀR` from `I` and of `det R` from 1.
        error: f64,
        /// The tolerance of `FORMAT.md`.
        tolerance: f64,
    },
    /// The rig was rejected by `momo_core::Rig::new`.
    #[error("{0}")]
    Rig(momo_core::CoreError),
    /// A calibration file (OpenCV, ROS or Kalibr YAML) that `momo rig import` cannot use.
    #[error("{0}")]
    Calibration(String),
    /// The file has no header line.
    #[error("missing header line `{expected}`")]
    MissingHeader {
        /// The header that `FORMAT.md` prescribes.
        expected: &'static str,
    },
    /// The header line does not name exactly the prescribed columns.
    #[error("bad header: {reason}; expected the columns `{expected}`")]
    BadHeader {
        /// What is wrong.
        reason: String,
        /// The header that `FORMAT.md` prescribes.
        expected: &'static str,
    },
    /// A row with the wrong number of fields.
    #[error("expected {expected} fields, found {found}")]
    FieldCount {
        /// Fields the format prescribes.
        expected: usize,
        /// Fields in the row.
        found: usize,
    },
    /// A field that does not parse as a number (or as a non-negative integer where one is
    /// required).
    #[error("`{field}`: cannot parse `{value}` as {expected}")]
    BadNumber {
        /// Column name (or position).
        field: String,
        /// The offending text (truncated to 40 characters).
        value: String,
        /// "a number" or "a non-negative integer".
        expected: &'static str,
    },
    /// A number that is NaN or infinite.
    #[error("`{field}` is not finite ({value})")]
    NonFinite {
        /// Column name (or position).
        field: String,
        /// The value.
        value: f64,
    },
    /// `frame` is 0: frame numbers name frame pairs `(k-1, k)` and start at 1.
    #[error("frame must be >= 1, found 0")]
    FrameZero,
    /// `frame` above [`MAX_FRAME`](crate::MAX_FRAME).
    #[error("frame {frame} exceeds the supported maximum {max}")]
    FrameTooLarge {
        /// The frame number.
        frame: usize,
        /// The limit.
        max: usize,
    },
    /// A row whose frame is smaller than the one before.
    #[error("frame {frame} after frame {previous}: rows must be ordered by {order} frame")]
    FramesOutOfOrder {
        /// This row's frame.
        frame: usize,
        /// The previous row's frame.
        previous: usize,
        /// "non-decreasing" (matches) or "increasing" (odometry).
        order: &'static str,
    },
    /// A frame given twice where each frame may appear once (odometry.csv).
    #[error("duplicate frame {frame}")]
    DuplicateFrame {
        /// The frame number.
        frame: usize,
    },
    /// A camera id that is not an index into `rig.json`'s `cameras`.
    #[error("unknown camera id {camera} (the rig has {count} camera(s))")]
    UnknownCamera {
        /// The id in the file.
        camera: usize,
        /// Number of cameras of the rig.
        count: usize,
    },
    /// A pixel further outside the image than [`PIXEL_MARGIN_FRACTION`](crate::PIXEL_MARGIN_FRACTION)
    /// of the larger image side.
    #[error(
        "`{field}` pixel ({u}, {v}) is more than {margin} px outside the {width}x{height} image of camera {camera}"
    )]
    PixelOutsideImage {
        /// `"u0,v0"` or `"u1,v1"`.
        field: &'static str,
        /// Camera id.
        camera: usize,
        /// Pixel u.
        u: f64,
        /// Pixel v.
        v: f64,
        /// Allowed margin in pixels.
        margin: f64,
        /// Image width.
        width: f64,
        /// Image height.
        height: f64,
    },
    /// The camera model cannot unproject a pixel (e.g. beyond the valid radius of a fisheye).
    #[error("`{field}` pixel ({u}, {v}) cannot be unprojected by the model of camera {camera}")]
    Unprojectable {
        /// `"u0,v0"` or `"u1,v1"`.
        field: &'static str,
        /// Camera id.
        camera: usize,
        /// Pixel u.
        u: f64,
        /// Pixel v.
        v: f64,
    },
    /// A negative arc length in odometry.csv.
    #[error("arc_length must be >= 0, found {value}")]
    NegativeArcLength {
        /// The value.
        value: f64,
    },
    /// An arc length above [`MAX_ARC_LENGTH`](crate::odometry::MAX_ARC_LENGTH) in odometry.csv.
    #[error("arc_length {value:.6e} m is beyond the supported -{max}..={max} m per frame pair")]
    ArcLengthTooLarge {
        /// The value.
        value: f64,
        /// The limit.
        max: f64,
    },
    /// A KITTI pose whose rotation block is not orthonormal with determinant +1.
    #[error(
        "rotation is not orthonormal with determinant +1 (error {error:.3e}, tolerance {tolerance:e})"
    )]
    PoseNotOrthonormal {
        /// Largest deviation of `RᵀR` from `I` and of `det R` from 1.
        error: f64,
        /// [`POSE_ORTHONORMAL_TOLERANCE`](crate::POSE_ORTHONORMAL_TOLERANCE).
        tolerance: f64,
    },
    /// A blank line between poses (line k of poses.txt is frame k, so gaps are ambiguous).
    #[error("blank line before the last pose (line k is the pose of frame k)")]
    BlankLine,
    /// A symbolic link to a file that does not exist (an optional file such as `odometry.csv`
    /// is then an error, not absent).
    #[error(
        "a symbolic link to a file that does not exist (remove the link if there is no such file)"
    )]
    DanglingLink,
    /// An output that would destroy a file or cannot be written safely: it is also an input,
    /// given twice, an existing directory / FIFO / device, in a missing directory, or a
    /// non-empty output directory without `--force`. An input error (the command line's).
    #[error("refused as an output: {0}")]
    OutputRefused(String),
    /// Data that cannot be written so that it reads back (writers only).
    #[error("cannot write: {0}")]
    InvalidData(String),
    /// Content that breaks a rule of its format not covered above (readers; the message says
    /// which rule).
    #[error("{0}")]
    Invalid(String),
}

/// Shortens user text quoted in messages.
pub(crate) fn quote(s: &str) -> String {
    const MAX: usize = 40;
    if s.chars().count() <= MAX {
        s.to_owned()
    } else {
        let mut q: String = s.chars().take(MAX).collect();
        q.push('…');
        q
    }
}

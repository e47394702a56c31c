//! The errors of the front end: every one names the file or folder it is about.

use std::path::PathBuf;
use thiserror::Error;

/// Why reading images, matching or writing a sequence failed.
#[derive(Debug, Error)]
pub enum MatchError {
    /// An image folder does not exist or is not a folder.
    #[error("{}: not a folder of images", path.display())]
    NotAFolder {
        /// The path given.
        path: PathBuf,
    },
    /// A folder could not be listed.
    #[error("{}: cannot list the folder: {source}", path.display())]
    ReadDir {
        /// The folder.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// A folder holds no PNG or JPEG file.
    #[error("{}: no PNG or JPEG images in the folder", path.display())]
    NoImages {
        /// The folder.
        path: PathBuf,
    },
    /// Two camera folders hold different numbers of images.
    #[error(
        "{}: {count} images, but {} (camera 0) has {first_count}; every camera needs one image per frame",
        path.display(),
        first.display()
    )]
    CountMismatch {
        /// Camera 0's folder.
        first: PathBuf,
        /// Its number of images.
        first_count: usize,
        /// The folder that differs.
        path: PathBuf,
        /// Its number of images.
        count: usize,
    },
    /// An image could not be read or decoded.
    #[error("{}: cannot decode the image: {reason}", path.display())]
    Decode {
        /// The image file.
        path: PathBuf,
        /// The decoder's reason.
        reason: String,
    },
    /// An image's size differs from its camera's size in the rig (or from the first frame).
    #[error(
        "{}: image is {width}x{height} pixels, but {expected} says {expected_width}x{expected_height}",
        path.display()
    )]
    ImageSize {
        /// The image file.
        path: PathBuf,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// What set the expected size (`"the rig's camera 0"`, `"the first frame"`).
        expected: String,
        /// The expected width.
        expected_width: u32,
        /// The expected height.
        expected_height: u32,
    },
    /// An image is too small to hold features (the descriptor needs a border).
    #[error("{}: image is {width}x{height} pixels, too small for features (at least {min}x{min})", path.display())]
    TooSmall {
        /// The image file.
        path: PathBuf,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The smallest side accepted.
        min: u32,
    },
    /// The number of image folders differs from the number of cameras in the rig.
    #[error("{}: the rig has {cameras} camera(s), but {folders} image folder(s) were given (one per camera, in the rig's order)", rig.display())]
    CameraCount {
        /// The rig file.
        rig: PathBuf,
        /// Cameras in the rig.
        cameras: usize,
        /// Folders given.
        folders: usize,
    },
    /// A matching option is out of range.
    #[error("invalid matching option: {0}")]
    Option(String),
    /// A sequence file (rig.json, odometry.csv, calib.txt, poses.txt) is malformed or could not
    /// be written (`file:line: reason`).
    #[error(transparent)]
    Io(#[from] momo_io::IoError),
    /// The estimator configuration does not fit the rig.
    #[error(transparent)]
    Vo(#[from] momo_vo::VoError),
}

impl MatchError {
    /// True for errors in the user's input (folders, images, rig, options), false for failures
    /// to write output. The CLI exits with 2 for input errors.
    pub fn is_input(&self) -> bool {
        !matches!(self, MatchError::Io(e) if matches!(e.kind, momo_io::IoErrorKind::Io(_)))
    }
}

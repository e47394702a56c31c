//! # momo-match
//!
//! The feature front end of momo: image sequences in (PNG or JPEG, one folder per camera, files
//! in name order), sparse matches between consecutive frames of each camera out, in the form
//! the estimator reads (`FORMAT.md`'s `matches.csv`, or [`momo_core::FrameObservations`] frame
//! by frame).
//!
//! The paper fed Momo with the matcher of StereoScan / libviso2 (Geiger et al. 2011): gamma
//! correction, blob and corner features, descriptor matching with a circular (forward-backward)
//! check, and non-maximum suppression / bucketing tuned to 100-300 matches per image. This crate
//! re-implements that design ([`features`], [`matcher`]):
//!
//! - **Detection**: 5x5 blob and corner (checkerboard) filters, block-wise non-maximum
//!   suppression, four classes (blob max/min, corner max/min); a match never crosses classes.
//! - **Description**: Sobel du/dv at 16 positions of an 11x11 window (32 bytes), compared by the
//!   sum of absolute differences (SAD).
//! - **Matching**: per grid cell the strongest features of frame k-1 are matched into a search
//!   window of frame k, checked back (circular consistency), and bucketed so that at most
//!   `matches_per_frame` matches per camera spread over the image.
//! - **Refinement** ([`refine`]): each chosen match is refined by aligning frame k-1's patch
//!   around the feature with frame k (KLT: translation and brightness offset, Gauss-Newton),
//!   checked forward-backward; without it, both ends are the detector's sub-pixel vertices.
//! - **Streaming**: [`FrameMatcher`] keeps only the previous frame's features; cameras run in
//!   parallel (rayon), as do the filter rows and the matches (`MatchOptions::threads`: a pool
//!   of its own, or rayon's global one; the matches do not depend on it).
//!
//! Why not a general crate for the detector and descriptor: `image` decodes the files;
//! `imageproc` has FAST corners and BRIEF descriptors, but its binary-descriptor matcher is
//! locality-sensitive hashing over the whole image (no search window, no circular check), it
//! has no blob detector, and it would add a second `nalgebra` and `rand` to the build. The
//! StereoScan design is small (a few hundred lines), is what the paper used, and is fast.
//!
//! [`pipeline`] drives a whole sequence: [`match_to_sequence`] writes a sequence directory
//! (`momo match`), [`vo_from_images`] matches and estimates in one pass (`momo vo`). [`kitti`]
//! builds rigs and arc lengths for KITTI image folders; [`synthetic`] makes textured images with
//! known motion for tests and benchmarks.
//!
//! ```
//! use momo_match::{MatchOptions, match_images, synthetic};
//! use nalgebra::Matrix3;
//!
//! # fn main() -> Result<(), momo_match::MatchError> {
//! // A textured image and the same image shifted by (+6.0, -3.0) pixels.
//! let img0 = synthetic::dead_leaves(320, 240, 1500, 7);
//! let shift = Matrix3::new(1.0, 0.0, 6.0, 0.0, 1.0, -3.0, 0.0, 0.0, 1.0);
//! let img1 = synthetic::warp(&img0, &shift).expect("invertible");
//!
//! let options = MatchOptions { matches_per_frame: 100, ..MatchOptions::default() };
//! let matches = match_images(&img0, &img1, &options)?;
//! assert!(matches.len() > 50 && matches.len() <= 100);
//! let correct = matches
//!     .iter()
//!     .filter(|m| (m.u1 - m.u0 - 6.0).hypot(m.v1 - m.v0 + 3.0) < 1.0)
//!     .count();
//! assert!(correct * 10 >= matches.len() * 9, "{correct} of {}", matches.len());
//! # Ok(())
//! # }
//! ```

pub mod error;
pub mod features;
pub mod images;
pub mod kitti;
pub mod matcher;
pub mod pipeline;
pub mod refine;
pub mod stereo;
pub mod synthetic;

pub use error::MatchError;
pub use features::{DetectorOptions, FrameFeatures};
/// The 8-bit gray image type of the front end (from the `image` crate).
pub use image::GrayImage;
pub use images::{
    GammaTable, ImageSequence, decode_gray, image_size, image_size_from_bytes, load_gray,
};
pub use matcher::{
    FlowPrior, FrameMatcher, Match, MatchOptions, match_features, match_features_with_prior,
    match_images,
};
pub use pipeline::{
    FrontEndOptions, FrontEndStats, ImageFrontEnd, VoRun, VoSummary, match_to_sequence,
    vo_from_images,
};
pub use refine::KltOptions;
pub use stereo::{StereoOptions, StereoPair, rectified_pairs};

//! `labels.csv` (`docs/FORMAT.md` version 6): what every simulated match really is, one row per
//! row of `matches.csv` in the same order, so that a classification of the matches (inliers,
//! outliers, moving objects) can be scored against the truth.

use crate::sim::{MatchLabel, Simulation};
use std::fmt::Write as _;
use std::io;
use std::path::Path;

/// The file name of the labels in a sequence directory.
pub const LABELS_FILE: &str = "labels.csv";

impl MatchLabel {
    /// The label's name in `labels.csv`: `inlier`, `outlier`, `moving_object` or `blinded`.
    pub fn name(self) -> &'static str {
        match self {
            MatchLabel::Inlier => "inlier",
            MatchLabel::Outlier => "outlier",
            MatchLabel::MovingObject => "moving_object",
            MatchLabel::Blinded => "blinded",
        }
    }
}

/// `labels.csv`: header `frame,camera,label`, then one row per match in the order `matches.csv`
/// lists them (frame pair, then camera, then the match's index), `label` being
/// [`MatchLabel::name`].
pub fn labels_csv(sim: &Simulation) -> String {
    let mut s = String::from("frame,camera,label\n");
    for (k, frame) in sim.labels.iter().enumerate() {
        for (j, camera) in frame.iter().enumerate() {
            for label in camera {
                let _ = writeln!(s, "{k},{j},{}", label.name());
            }
        }
    }
    s
}

/// Writes [`labels_csv`] into a sequence directory as [`LABELS_FILE`].
pub fn write_labels_csv(dir: impl AsRef<Path>, sim: &Simulation) -> io::Result<()> {
    std::fs::write(dir.as_ref().join(LABELS_FILE), labels_csv(sim))
}

//! `labels.csv` (`docs/FORMAT.md` versions 6 and 7): what every simulated match really is, one
//! row per row of `matches.csv` in the same order, so that a classification of the matches
//! (inliers, outliers, moving objects) can be scored against the truth; since version 7 also
//! which traffic object a moving-object match is on, and that object's kind.

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

/// `labels.csv`: header `frame,camera,label,object,object_kind`, then one row per match in the
/// order `matches.csv` lists them (frame pair, then camera, then the match's index), `label`
/// being [`MatchLabel::name`], `object` the index of the traffic object the match is on
/// ([`Simulation::objects`]) and `object_kind` its kind ([`Simulation::object_kinds`]), both
/// empty for every match not on a traffic object.
pub fn labels_csv(sim: &Simulation) -> String {
    let mut s = String::from("frame,camera,label,object,object_kind\n");
    for (k, frame) in sim.labels.iter().enumerate() {
        for (j, camera) in frame.iter().enumerate() {
            let objects = sim.objects.get(k).and_then(|f| f.get(j));
            for (i, label) in camera.iter().enumerate() {
                let object = objects.and_then(|o| o.get(i).copied().flatten());
                let kind = object.and_then(|o| sim.object_kinds.get(o).copied());
                match (object, kind) {
                    (Some(o), Some(kind)) => {
                        let _ = writeln!(s, "{k},{j},{},{o},{kind}", label.name());
                    }
                    _ => {
                        let _ = writeln!(s, "{k},{j},{},,", label.name());
                    }
                }
            }
        }
    }
    s
}

/// Writes [`labels_csv`] into a sequence directory as [`LABELS_FILE`].
pub fn write_labels_csv(dir: impl AsRef<Path>, sim: &Simulation) -> io::Result<()> {
    std::fs::write(dir.as_ref().join(LABELS_FILE), labels_csv(sim))
}

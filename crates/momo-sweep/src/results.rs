//! The results table: one [`Row`] per job, written as CSV with a stable column set
//! ([`COLUMNS`]), read back for [`merge`].

use crate::error::SweepError;
use momo_io::{AtomicFile, IoError, IoErrorKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The columns of `results.csv`, in order. Changing them is a breaking change for merge.
pub const COLUMNS: &[&str] = &[
    "grid_id",
    "job",
    "jobs_total",
    "sequence",
    "combination",
    "model",
    "metric",
    "loss",
    "loss_scale",
    "solver",
    "matches",
    "is_default",
    "status",
    "error",
    "frames",
    "estimated",
    "standstill",
    "no_matches",
    "solver_failures",
    "restarts_won",
    "mean_iterations",
    "inlier_ratio",
    "rot_mean_deg",
    "rot_median_deg",
    "rot_p95_deg",
    "rot_max_deg",
    "above_1deg",
    "t_err_percent",
    "r_err_deg_per_100m",
    "us_per_frame",
    "wall_us_per_frame",
];

/// The columns that hold measured times (they differ between runs of the same job).
pub const TIMING_COLUMNS: &[&str] = &["us_per_frame", "wall_us_per_frame"];

/// How a job ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The run finished and was scored.
    Ok,
    /// The combination could not run on the sequence (configuration, model/metric/camera).
    Error,
    /// The run panicked (caught; the sweep went on).
    Panic,
}

/// One job's result: what ran, how it scored against the ground truth, how long it took.
/// Rotation errors are frame to frame, in degrees; `t_err_percent` and `r_err_deg_per_100m`
/// are the KITTI devkit's (empty when the path is shorter than 100 m).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// The grid id ([`crate::Plan::grid_id`]).
    pub grid_id: String,
    /// The job number.
    pub job: usize,
    /// Number of jobs of the whole sweep (all shards).
    pub jobs_total: usize,
    /// The sequence (directory name).
    pub sequence: String,
    /// [`crate::Combination::label`].
    pub combination: String,
    /// Model label.
    pub model: String,
    /// Metric label.
    pub metric: String,
    /// Loss label (without scale).
    pub loss: String,
    /// Loss scale (empty for `trivial`).
    pub loss_scale: Option<f64>,
    /// Solver label.
    pub solver: String,
    /// Matches per frame pair and camera (`all` or a number).
    pub matches: String,
    /// Whether this is the default configuration (`momo config`).
    pub is_default: bool,
    /// How the job ended.
    pub status: Status,
    /// The error or panic message (empty if ok).
    pub error: String,
    /// Frames of the sequence that ran (poses, frame 0 included).
    pub frames: usize,
    /// Frame pairs estimated from matches.
    pub estimated: usize,
    /// Standstill frame pairs.
    pub standstill: usize,
    /// Frame pairs with too few matches.
    pub no_matches: usize,
    /// Frame pairs where the solver failed.
    pub solver_failures: usize,
    /// Frame pairs where an extra start won.
    pub restarts_won: usize,
    /// Mean solver iterations per frame pair.
    pub mean_iterations: Option<f64>,
    /// Inliers / matches over all frame pairs.
    pub inlier_ratio: Option<f64>,
    /// Mean frame-to-frame rotation error, degrees.
    pub rot_mean_deg: Option<f64>,
    /// Median frame-to-frame rotation error, degrees.
    pub rot_median_deg: Option<f64>,
    /// 95th percentile, degrees.
    pub rot_p95_deg: Option<f64>,
    /// Maximum, degrees.
    pub rot_max_deg: Option<f64>,
    /// Frame pairs with a rotation error above 1 degree.
    pub above_1deg: Option<usize>,
    /// KITTI devkit translational error, percent.
    pub t_err_percent: Option<f64>,
    /// KITTI devkit rotational error, degrees per 100 m.
    pub r_err_deg_per_100m: Option<f64>,
    /// Mean estimator compute time per frame pair (the diagnostics' `time_us`), µs.
    pub us_per_frame: Option<f64>,
    /// Wall-clock time of the whole run divided by the frame pairs, µs.
    pub wall_us_per_frame: Option<f64>,
}

impl Row {
    /// The value of the rank criterion (`None` for failed jobs or missing values).
    pub fn key(&self, by: RankBy) -> Option<f64> {
        if self.status != Status::Ok {
            return None;
        }
        let v = match by {
            RankBy::RotMean => self.rot_mean_deg,
            RankBy::RotMedian => self.rot_median_deg,
            RankBy::RotP95 => self.rot_p95_deg,
            RankBy::TErr => self.t_err_percent,
            RankBy::RErr => self.r_err_deg_per_100m,
            RankBy::Time => self.us_per_frame,
        };
        v.filter(|x| x.is_finite())
    }

    /// The row as CSV fields without the timing columns (to compare runs).
    pub fn without_timings(&self) -> Row {
        Row {
            us_per_frame: None,
            wall_us_per_frame: None,
            ..self.clone()
        }
    }
}

/// What ranks the combinations of a sequence (lower is better).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum RankBy {
    /// Mean frame-to-frame rotation error (sees both accuracy and gross failures).
    #[default]
    RotMean,
    /// Median frame-to-frame rotation error.
    RotMedian,
    /// 95th percentile of the frame-to-frame rotation error.
    RotP95,
    /// KITTI devkit translational error.
    TErr,
    /// KITTI devkit rotational error.
    RErr,
    /// Compute time per frame.
    Time,
}

impl RankBy {
    /// A description for the summary.
    pub fn describe(self) -> &'static str {
        match self {
            RankBy::RotMean => "mean frame-to-frame rotation error",
            RankBy::RotMedian => "median frame-to-frame rotation error",
            RankBy::RotP95 => "95th percentile of the frame-to-frame rotation error",
            RankBy::TErr => "KITTI devkit t_err",
            RankBy::RErr => "KITTI devkit r_err",
            RankBy::Time => "compute time per frame",
        }
    }
}

/// Writes `rows` as CSV ([`COLUMNS`], header always present) atomically to `path`.
pub fn write_csv(path: &Path, rows: &[Row]) -> Result<(), SweepError> {
    let mut file = AtomicFile::create(path).map_err(SweepError::Output)?;
    let werr = |e: csv::Error| {
        SweepError::Output(IoError::file(
            path,
            IoErrorKind::Io(std::io::Error::other(e.to_string())),
        ))
    };
    {
        let mut w = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(file.writer());
        w.write_record(COLUMNS).map_err(werr)?;
        for r in rows {
            w.serialize(r).map_err(werr)?;
        }
        w.flush()
            .map_err(|e| SweepError::Output(IoError::io(path, e)))?;
    }
    file.commit().map_err(SweepError::Output)
}

/// Reads a results CSV; errors name the file and line.
pub fn read_csv(path: &Path) -> Result<Vec<Row>, SweepError> {
    let file = std::fs::File::open(path).map_err(|error| SweepError::Read {
        path: path.display().to_string(),
        error,
    })?;
    let bad = |line: u64, reason: String| SweepError::Results {
        path: path.display().to_string(),
        line,
        reason,
    };
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(file);
    let header = r
        .headers()
        .map_err(|e| bad(1, e.to_string()))?
        .iter()
        .map(str::to_owned)
        .collect::<Vec<_>>();
    if header != COLUMNS {
        return Err(bad(
            1,
            format!(
                "not a momo sweep results file of this version: columns {} (expected {})",
                header.join(","),
                COLUMNS.join(",")
            ),
        ));
    }
    let mut rows = Vec::new();
    for record in r.deserialize::<Row>() {
        match record {
            Ok(row) => rows.push(row),
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                let reason = match e.kind() {
                    csv::ErrorKind::Deserialize { err, .. } => match err.field() {
                        Some(f) => format!(
                            "column `{}`: {}",
                            COLUMNS.get(f as usize).copied().unwrap_or("?"),
                            err.kind()
                        ),
                        None => err.kind().to_string(),
                    },
                    _ => e.to_string(),
                };
                return Err(bad(line, reason));
            }
        }
    }
    Ok(rows)
}

/// Joins the rows of several shards' CSV files into one table in job order. Checks that all
/// rows come from the same sweep (grid id and job count), that no job appears twice and that
/// none is missing; errors name the files.
pub fn merge(files: &[PathBuf]) -> Result<Vec<Row>, SweepError> {
    let mut by_job: BTreeMap<usize, (Row, usize)> = BTreeMap::new();
    let mut first: Option<(String, usize, usize)> = None; // grid id, total, file
    for (fi, path) in files.iter().enumerate() {
        for row in read_csv(path)? {
            match &first {
                None => first = Some((row.grid_id.clone(), row.jobs_total, fi)),
                Some((id, total, f0)) => {
                    if *id != row.grid_id || *total != row.jobs_total {
                        return Err(SweepError::Merge(format!(
                            "{} (grid {}, {} jobs) and {} (grid {}, {} jobs) come from different sweeps (grid, sequences or options differ)",
                            files[*f0].display(),
                            id,
                            total,
                            path.display(),
                            row.grid_id,
                            row.jobs_total
                        )));
                    }
                }
            }
            if row.job >= row.jobs_total {
                return Err(SweepError::Merge(format!(
                    "{}: job {} out of range (the sweep has {} jobs)",
                    path.display(),
                    row.job,
                    row.jobs_total
                )));
            }
            if let Some((_, other)) = by_job.get(&row.job) {
                return Err(SweepError::Merge(format!(
                    "job {} ({} on {}) appears twice: in {} and in {} (the same shard given twice, or shards of different counts?)",
                    row.job,
                    row.combination,
                    row.sequence,
                    files[*other].display(),
                    path.display()
                )));
            }
            by_job.insert(row.job, (row, fi));
        }
    }
    let Some((_, total, _)) = first else {
        return Err(SweepError::Merge("the files hold no results".into()));
    };
    let missing: Vec<usize> = (0..total).filter(|j| !by_job.contains_key(j)).collect();
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(20).map(usize::to_string).collect();
        return Err(SweepError::Merge(format!(
            "{} of {} jobs missing: {}{} (with N shards, job i is in shard i % N + 1; rerun those shards)",
            missing.len(),
            total,
            shown.join(", "),
            if missing.len() > 20 { ", ..." } else { "" }
        )));
    }
    Ok(by_job.into_values().map(|(r, _)| r).collect())
}

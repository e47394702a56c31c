//! Running the odometry over a whole `FORMAT.md` sequence directory: matches are streamed one
//! frame pair at a time (memory does not grow with the sequence), poses and diagnostics are
//! written atomically (temporary file, then rename: no half-written output on any error).

use crate::baseline::{FivePointBaseline, MotionDriver};
use crate::calibrate::{MountCalibration, MountEstimate};
use crate::config::{Config, RoadScaleMount};
use crate::odometry::{
    FrameDiagnostics, FrameResult, FrameStatus, Odometry, ScaleSource, Trajectory, VoError,
};
use momo_core::{FrameObservations, Pose, Rig};
use momo_fivepoint::FivePointRansac;
use momo_io::{AtomicFile, IoError, MatchReader, PoseWriter};
use std::borrow::Borrow;
use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a run failed.
#[derive(Debug, Error)]
pub enum RunError {
    /// The sequence is malformed (`file:line: reason`): exit code 2 in the CLI.
    #[error(transparent)]
    Input(IoError),
    /// An output file could not be written.
    #[error(transparent)]
    Output(IoError),
    /// The configuration does not fit the rig.
    #[error(transparent)]
    Vo(#[from] VoError),
    /// The rig given in [`RunOptions::rig`] has another number of cameras than `rig.json`.
    #[error("{}: the run was given a rig of {given} cameras for this rig of {file}", path.display())]
    RigMismatch {
        /// The sequence's rig.json.
        path: PathBuf,
        /// Cameras of the rig given.
        given: usize,
        /// Cameras of rig.json.
        file: usize,
    },
}

/// Which estimator runs the sequence.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EstimatorKind {
    /// momo: robust least squares on the configured motion manifold.
    #[default]
    Momo,
    /// The 5-point RANSAC baseline (OpenCV-style findEssentialMat + recoverPose), with the
    /// configuration's `[five_point]` options.
    FivePoint,
    /// The 5-point RANSAC baseline with the LO-RANSAC-style refinement on, whatever the
    /// configuration's `five_point.refine` says (PoseLib's way).
    FivePointRefined,
}

/// Builds the driver of an estimator kind.
pub fn driver(
    kind: EstimatorKind,
    rig: &Rig,
    config: Config,
) -> Result<Box<dyn MotionDriver>, VoError> {
    Ok(match kind {
        EstimatorKind::Momo => Box::new(Odometry::new(rig.clone(), config)?),
        EstimatorKind::FivePoint => Box::new(FivePointBaseline::new(
            rig.clone(),
            FivePointRansac::from(&config.five_point),
        )),
        EstimatorKind::FivePointRefined => Box::new(FivePointBaseline::new(
            rig.clone(),
            FivePointRansac {
                refine: true,
                ..FivePointRansac::from(&config.five_point)
            },
        )),
    })
}

/// Where to write.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// The estimator.
    pub estimator: EstimatorKind,
    /// The KITTI-format camera-0 trajectory, one line per frame.
    pub output: PathBuf,
    /// Per-frame diagnostics: CSV if the name ends in `.csv`, JSON lines otherwise.
    pub diagnostics: Option<PathBuf>,
    /// The rig to run with instead of the sequence's `rig.json` (which is still read and
    /// checked, and must have as many cameras): e.g. the mount-calibrated rig of
    /// `momo run --calibrate-mount`.
    pub rig: Option<Rig>,
}

/// Totals of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunSummary {
    /// Frames written (poses), including frame 0.
    pub frames: usize,
    /// Frame pairs per status: estimated, standstill, no matches, solver failure.
    pub estimated: usize,
    /// Standstill frame pairs.
    pub standstill: usize,
    /// Frame pairs without enough matches.
    pub no_matches: usize,
    /// Frame pairs where the solver failed.
    pub solver_failures: usize,
    /// Degenerate frame pairs (previous motion held; the reason is in the diagnostics).
    pub degenerate: usize,
    /// Weak frame pairs (estimate kept, flagged).
    pub weak: usize,
    /// Frame pairs whose scale came from odometry.csv.
    pub scale_odometry: usize,
    /// Frame pairs whose scale was estimated from the matches.
    pub scale_estimated: usize,
    /// Frame pairs whose scale was held (not observable in that frame).
    pub scale_held: usize,
    /// Frame pairs whose scale the rig can never observe.
    pub scale_unobservable: usize,
    /// Frame pairs whose scale came from the road plane (`odometry.road_scale_frames`).
    pub scale_road: usize,
    /// Frame pairs where an extra start won.
    pub restarts_won: usize,
    /// Sum of per-frame compute times, seconds.
    pub compute_seconds: f64,
    /// What `odometry.road_scale_mount` did before the run.
    pub road_mount: RoadMount,
}

/// What `odometry.road_scale_mount` did before a run.
///
/// Without odometry.csv one camera reads its arc length off the road
/// (`odometry.road_scale_frames`): the arc length at which the static matches triangulate onto
/// the road at the camera's height, through the mount's rotation. A camera pitched against the
/// vehicle by `θ` puts the road at depth `Z` `θ Z` higher or lower than a level mount says (1°
/// at 15 m: 0.26 m of a 1.65 m height), and the arc length follows: the real KITTI cameras,
/// whose rig is level on paper, read it 6-17 % long (docs/RESULTS.md, forty-eighth session). So
/// such a run first calibrates the mount's rotation on the sequence's first
/// [`ROAD_MOUNT_FRAMES`] frame pairs (the joint single-track calibration of `momo calibrate`,
/// [`crate::calibrate_mount`], without its bootstrap) and then, as
/// `odometry.road_scale_mount` says, gives the calibrated pitch to the road
/// ([`crate::hypotheses::HypothesesOptions::ground_pitch`]) or runs with the corrected rig: two
/// passes over those matches.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum RoadMount {
    /// Not run: odometry.csv gives the arc lengths, the rig has more than one camera, the
    /// road scale or the option is off, the estimator is not momo, or the run was given a rig
    /// ([`RunOptions::rig`]).
    #[default]
    NotRun,
    /// The mount was calibrated: its pitch read the road (`road`) or the run used the corrected
    /// rig (`rig`). The correction `δ` (radians, about the vehicle's x, y, z axes:
    /// [`MountEstimate::delta`]).
    Calibrated(nalgebra::Vector3<f64>),
    /// The calibration failed (its message; e.g. no frame pair that moves): the run used the
    /// rig as given.
    Failed(String),
}

impl RoadMount {
    /// Whether a run calibrates its mount first (see the type's doc): the momo estimator, one
    /// camera, no arc lengths from odometry, `odometry.road_scale_frames > 0`,
    /// `odometry.road_scale_mount` not `nominal`, and the separation's hypotheses on (the road
    /// is read through them: without them there is no road scale to correct).
    pub fn applies(
        estimator: EstimatorKind,
        rig: &Rig,
        config: &Config,
        has_odometry: bool,
    ) -> bool {
        estimator == EstimatorKind::Momo
            && !has_odometry
            && rig.len() == 1
            && config.odometry.road_scale_frames > 0
            && config.odometry.road_scale_mount != RoadScaleMount::Nominal
            && config
                .odometry
                .separate
                .as_ref()
                .filter(|s| s.enabled)
                .and_then(|s| s.hypotheses())
                .is_some()
    }

    /// The rig and configuration to run with and the outcome, from the mount calibrated on
    /// the frame pairs `frames` (`(k, matches)` of frame pair `k - 1, k`, `k` increasing; those
    /// up to [`ROAD_MOUNT_FRAMES`]) with `momo calibrate`'s defaults without the bootstrap (only
    /// the correction is used). For a run where [`RoadMount::applies`]: [`road_scale_setup`],
    /// [`run_in_memory`] and `momo vo` (which holds back the first frame pairs' matches for it).
    pub fn calibrate<'a>(
        rig: Rig,
        mut config: Config,
        frames: impl IntoIterator<Item = (usize, &'a FrameObservations)>,
    ) -> (Rig, Config, Self) {
        let options = MountCalibration {
            bootstrap: 0,
            ..MountCalibration::default()
        };
        let mut total = 0;
        let pairs: Vec<_> = frames
            .into_iter()
            .take_while(|(k, _)| *k <= ROAD_MOUNT_FRAMES)
            .inspect(|(k, _)| total = *k)
            .filter(|(k, obs)| *k >= 1 && !obs.is_empty())
            .map(|(k, obs)| (k - 1, obs, None))
            .collect();
        let calibrated = crate::calibrate::calibrate_frames(&rig, &pairs, total, &config, &options);
        let est: MountEstimate = match calibrated {
            Ok(est) => est,
            Err(e) => return (rig, config, RoadMount::Failed(e.to_string())),
        };
        match config.odometry.road_scale_mount {
            RoadScaleMount::Rig => (est.corrected_rig, config, RoadMount::Calibrated(est.delta)),
            _ => {
                let pitch = est.delta.y;
                if pitch.abs() > crate::hypotheses::MAX_GROUND_PITCH {
                    let why = format!(
                        "a pitch of {:.2} deg against the rig is beyond the road's {:.2} deg",
                        pitch.to_degrees(),
                        crate::hypotheses::MAX_GROUND_PITCH.to_degrees()
                    );
                    return (rig, config, RoadMount::Failed(why));
                }
                if let Some(h) = config
                    .odometry
                    .separate
                    .as_mut()
                    .and_then(|s| s.hypotheses.as_mut())
                {
                    h.ground_pitch = pitch;
                }
                (rig, config, RoadMount::Calibrated(est.delta))
            }
        }
    }
}

/// The frame pairs (the first ones) that `odometry.road_scale_mount` calibrates the mount on:
/// a mount does not change along a drive, and a run's memory stays bounded (about 25 MB at 300
/// matches per frame pair). On real KITTI 00 frame pairs 1-150 calibrate as well as all 300
/// (docs/GUIDE.md, mount self-calibration).
pub const ROAD_MOUNT_FRAMES: usize = 1000;

/// The rig and configuration a run over the sequence directory `dir` uses, and what
/// `odometry.road_scale_mount` did ([`RoadMount`]): `rig` (the sequence's) and `config` as
/// they are, or, where [`RoadMount::applies`], the mount calibrated on the sequence's first
/// [`ROAD_MOUNT_FRAMES`] frame pairs and its pitch given to the road
/// ([`crate::hypotheses::HypothesesOptions::ground_pitch`]), or the whole rig corrected.
/// [`run_sequence`] and the Python module's `run` call it.
pub fn road_scale_setup(
    dir: &Path,
    rig: Rig,
    config: Config,
    estimator: EstimatorKind,
    has_odometry: bool,
) -> Result<(Rig, Config, RoadMount), IoError> {
    if !RoadMount::applies(estimator, &rig, &config, has_odometry) {
        return Ok((rig, config, RoadMount::NotRun));
    }
    // The first ROAD_MOUNT_FRAMES frame pairs, read as the run reads them (memory bounded).
    let mut frames = Vec::new();
    for item in MatchReader::open(dir.join("matches.csv"), &rig)? {
        let (k, obs) = item?;
        if k > ROAD_MOUNT_FRAMES {
            break;
        }
        frames.push((k, obs));
    }
    let frames = frames.iter().map(|(k, obs)| (*k, obs));
    Ok(RoadMount::calibrate(rig, config, frames))
}

impl RunSummary {
    /// Frame pairs that failed, were degenerate or held their motion for lack of matches.
    pub fn failed_or_held(&self) -> usize {
        self.no_matches + self.solver_failures + self.degenerate
    }

    /// The share of frame pairs that failed or were held (0 for a run without frame pairs).
    pub fn failed_share(&self) -> f64 {
        let pairs = self.frames.saturating_sub(1);
        if pairs == 0 {
            0.0
        } else {
            self.failed_or_held() as f64 / pairs as f64
        }
    }

    /// Whether the scale was never measured: no frame pair took it from odometry, estimated it
    /// or read it off the road (the trajectory's scale is arbitrary).
    pub fn scale_never_measured(&self) -> bool {
        self.frames > 1
            && self.scale_odometry == 0
            && self.scale_estimated == 0
            && self.scale_road == 0
    }

    fn add(&mut self, d: &FrameDiagnostics) {
        match d.status {
            FrameStatus::Estimated => self.estimated += 1,
            FrameStatus::Standstill => self.standstill += 1,
            FrameStatus::NoMatches => self.no_matches += 1,
            FrameStatus::SolverFailure => self.solver_failures += 1,
            FrameStatus::Degenerate => self.degenerate += 1,
            FrameStatus::Weak => self.weak += 1,
        }
        match d.scale {
            ScaleSource::Odometry => self.scale_odometry += 1,
            ScaleSource::Estimated => self.scale_estimated += 1,
            ScaleSource::Held => self.scale_held += 1,
            ScaleSource::Unobservable => self.scale_unobservable += 1,
            ScaleSource::Road => self.scale_road += 1,
        }
        self.restarts_won += usize::from(d.restart_won);
        self.compute_seconds += d.time_us * 1e-6;
    }
}

/// Writes the per-frame diagnostics ([`FrameDiagnostics`]) of a run, one row per frame pair,
/// atomically: CSV if the name ends in `.csv`, JSON lines otherwise. The file appears only when
/// committed ([`DiagnosticsWriter::into_file`] with [`momo_io::commit_all`], together with the
/// trajectory); dropping the writer before removes the temporary file. `momo run` and `momo vo`
/// write the same rows.
pub struct DiagnosticsWriter {
    file: AtomicFile,
    csv: bool,
    header_written: bool,
}

impl DiagnosticsWriter {
    /// Starts writing `path` (a temporary file in the same directory).
    pub fn create(path: &Path) -> Result<Self, IoError> {
        let csv = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        Ok(Self {
            file: AtomicFile::create(path)?,
            csv,
            header_written: false,
        })
    }

    /// Appends the row of the next frame pair.
    pub fn push(&mut self, d: &FrameDiagnostics) -> Result<(), IoError> {
        let path = self.file.path().to_path_buf();
        let err = |e: std::io::Error| IoError::io(&path, e);
        if !self.csv {
            let line = serde_json::to_string(d).map_err(|e| err(std::io::Error::other(e)))?;
            return writeln!(self.file.writer(), "{line}").map_err(err);
        }
        let w = self.file.writer();
        if !self.header_written {
            write!(
                w,
                "frame,status,scale,matches,inliers,iterations,termination,initial_cost,final_cost,restarts,restart_won,time_us"
            )
            .map_err(err)?;
            for n in &d.param_names {
                write!(w, ",{n}").map_err(err)?;
            }
            for n in &d.param_names {
                write!(w, ",sigma_{n}").map_err(err)?;
            }
            write!(w, ",constraint,reason").map_err(err)?;
            writeln!(w).map_err(err)?;
            self.header_written = true;
        }
        let term = d
            .termination
            .map(|t| {
                serde_json::to_string(&t)
                    .unwrap_or_default()
                    .trim_matches('"')
                    .to_string()
            })
            .unwrap_or_else(|| "none".into());
        let status = serde_json::to_string(&d.status).unwrap_or_default();
        let scale = serde_json::to_string(&d.scale).unwrap_or_default();
        write!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{},{:.1}",
            d.frame,
            status.trim_matches('"'),
            scale.trim_matches('"'),
            d.matches,
            d.inliers,
            d.iterations,
            term,
            d.initial_cost,
            d.final_cost,
            d.restarts,
            d.restart_won,
            d.time_us
        )
        .map_err(err)?;
        for v in d.params.iter().chain(&d.param_sigmas) {
            write!(w, ",{v}").map_err(err)?;
        }
        let constraint = serde_json::to_string(&d.constraint).unwrap_or_default();
        write!(
            w,
            ",{},{}",
            constraint.trim_matches('"'),
            d.reason.map_or("", |r| r.name())
        )
        .map_err(err)?;
        writeln!(w).map_err(err)
    }

    /// The file being written, to commit it together with the trajectory
    /// ([`momo_io::commit_all`]).
    pub fn into_file(self) -> AtomicFile {
        self.file
    }
}

/// The one run loop of momo: `momo run` ([`run_sequence`]), `momo vo` (momo-match's
/// `vo_from_images`), the in-memory runs ([`run_in_memory`]: `--calibrate-mount`, the sweep,
/// `momo demo`, the Python bindings) all go through it, so every frame pair is processed,
/// chained and counted the same way.
///
/// `frames` yields `(k, observations)` with `k ≥ 1` increasing: the matches between frames
/// `k - 1` and `k`. A frame pair that is skipped (a gap in `k`), and every frame after the last
/// item up to `last_frame`, is processed without matches (the motion is held and the
/// diagnostics say so). The arc length of frame pair `k` is `arc_lengths[k]`. `sink` sees every
/// frame in order: camera 0's pose (frame 0's is the identity, with no result) and the frame
/// pair's result. The first error (of `frames` or of `sink`) ends the run.
///
/// ```
/// use momo_core::{FrameObservations, Pose};
/// use momo_vo::{Config, EstimatorKind, driver, run_loop};
/// let rig = momo_sim::kitti_mono();
/// let mut vo = driver(EstimatorKind::Momo, &rig, Config::default()).unwrap();
/// // Frame pairs 1 and 3 without matches, frame 4 from `last_frame`.
/// let frames = [1, 3].map(|k| Ok::<_, String>((k, FrameObservations::new(rig.len()))));
/// let mut poses: Vec<Pose<f64>> = Vec::new();
/// let summary = run_loop(vo.as_mut(), &rig, frames, None, 4, |pose, _| {
///     poses.push(*pose);
///     Ok(())
/// })
/// .unwrap();
/// assert_eq!((poses.len(), summary.frames, summary.no_matches), (5, 5, 4));
/// ```
pub fn run_loop<E, B: Borrow<FrameObservations>>(
    driver: &mut dyn MotionDriver,
    rig: &Rig,
    frames: impl IntoIterator<Item = Result<(usize, B), E>>,
    arc_lengths: Option<&[Option<f64>]>,
    last_frame: usize,
    sink: impl FnMut(&Pose<f64>, Option<&FrameResult>) -> Result<(), E>,
) -> Result<RunSummary, E> {
    let arc = |k: usize| arc_lengths.and_then(|a| a.get(k).copied().flatten());
    run_loop_with(driver, rig, frames, arc, last_frame, sink)
}

/// [`run_loop`] with the arc length of frame pair `k` given by `arc(k)` (called with
/// increasing `k`), so that the odometry can be held sparsely ([`run_sequence`]).
fn run_loop_with<E, B: Borrow<FrameObservations>>(
    driver: &mut dyn MotionDriver,
    rig: &Rig,
    frames: impl IntoIterator<Item = Result<(usize, B), E>>,
    mut arc: impl FnMut(usize) -> Option<f64>,
    last_frame: usize,
    mut sink: impl FnMut(&Pose<f64>, Option<&FrameResult>) -> Result<(), E>,
) -> Result<RunSummary, E> {
    let mut trajectory = Trajectory::new(rig);
    sink(&trajectory.camera0(), None)?;
    let mut summary = RunSummary {
        frames: 1,
        ..Default::default()
    };
    let empty = FrameObservations::new(rig.len());
    let mut step = |k: usize, obs: &FrameObservations, summary: &mut RunSummary| {
        let result = driver.process(obs, arc(k));
        summary.add(&result.diagnostics);
        summary.frames += 1;
        sink(&trajectory.push(&result.motion), Some(&result))
    };
    let mut last = 0;
    for item in frames {
        let (k, obs) = item?;
        for gap in last + 1..k {
            step(gap, &empty, &mut summary)?;
        }
        step(k, obs.borrow(), &mut summary)?;
        last = last.max(k);
    }
    for k in last + 1..=last_frame {
        step(k, &empty, &mut summary)?;
    }
    Ok(summary)
}

/// Runs the odometry over the sequence in `dir` (`rig.json`, `matches.csv`, optional
/// `odometry.csv`), writing camera 0's trajectory and, if asked, the diagnostics. `on_frame` is
/// called after every frame pair (progress bars, live plots).
///
/// The number of frames is `max(last frame in matches.csv, last frame in odometry.csv) + 1`
/// (`FORMAT.md`); frame pairs without matches hold the previous motion and say so.
pub fn run_sequence(
    dir: &Path,
    config: Config,
    options: &RunOptions,
    mut on_frame: impl FnMut(&FrameResult),
) -> Result<RunSummary, RunError> {
    let rig_path = dir.join("rig.json");
    let mut rig = momo_io::read_rig(&rig_path).map_err(RunError::Input)?;
    if let Some(other) = &options.rig {
        if other.len() != rig.len() {
            return Err(RunError::RigMismatch {
                path: rig_path,
                given: other.len(),
                file: rig.len(),
            });
        }
        rig = other.clone();
    }
    let odometry_path = dir.join("odometry.csv");
    // A dangling symbolic link is an odometry.csv that cannot be read, not a missing one.
    // The rows are held as they are (16 bytes per row), not expanded to one entry per frame:
    // a last frame of 10,000,000 costs nothing before the frames are run.
    let arc_rows = if std::fs::symlink_metadata(&odometry_path).is_ok() {
        if std::fs::metadata(&odometry_path).is_err() {
            return Err(RunError::Input(IoError::file(
                &odometry_path,
                momo_io::IoErrorKind::DanglingLink,
            )));
        }
        let rows = momo_io::read_odometry_rows(&odometry_path).map_err(RunError::Input)?;
        check_arc_lengths(&odometry_path, &rows).map_err(RunError::Input)?;
        rows
    } else {
        Vec::new()
    };
    let reader = MatchReader::open(dir.join("matches.csv"), &rig).map_err(RunError::Input)?;
    // `odometry.road_scale_mount`: one camera without odometry.csv runs with its
    // mount calibrated on the sequence first (not where the caller gave the rig).
    let (rig, config, road_mount) = if options.rig.is_some() {
        (rig, config, RoadMount::NotRun)
    } else {
        road_scale_setup(dir, rig, config, options.estimator, !arc_rows.is_empty())
            .map_err(RunError::Input)?
    };

    let mut vo = driver(options.estimator, &rig, config)?;
    let mut poses = PoseWriter::create(&options.output).map_err(RunError::Output)?;
    let mut diagnostics = match &options.diagnostics {
        Some(p) => Some(DiagnosticsWriter::create(p).map_err(RunError::Output)?),
        None => None,
    };
    // Frames beyond the last match row but within odometry.csv are run without matches.
    let last_frame = arc_rows.last().map_or(0, |&(k, _)| k);
    let frames = reader.map(|item| item.map_err(RunError::Input));
    // The frame pairs come in increasing order: a cursor walks the rows once.
    let mut next_row = 0;
    let arc = |k: usize| {
        while arc_rows.get(next_row).is_some_and(|&(f, _)| f < k) {
            next_row += 1;
        }
        arc_rows
            .get(next_row)
            .and_then(|&(f, l)| (f == k).then_some(l))
    };
    let mut summary = run_loop_with(
        vo.as_mut(),
        &rig,
        frames,
        arc,
        last_frame,
        |pose, result| {
            poses.push(pose).map_err(RunError::Output)?;
            if let Some(result) = result {
                if let Some(d) = diagnostics.as_mut() {
                    d.push(&result.diagnostics).map_err(RunError::Output)?;
                }
                on_frame(result);
            }
            Ok(())
        },
    )?;
    // Poses and diagnostics are committed together: both or neither.
    let mut outputs = vec![poses.into_file()];
    outputs.extend(diagnostics.map(DiagnosticsWriter::into_file));
    momo_io::commit_all(outputs).map_err(RunError::Output)?;
    summary.road_mount = road_mount;
    Ok(summary)
}

/// Rejects arc lengths no vehicle travels between two frames (above
/// [`crate::config::MAX_ARC_LENGTH`], e.g. 1e200 m), at the line of the first one.
fn check_arc_lengths(path: &Path, rows: &[(usize, f64)]) -> Result<(), IoError> {
    let limit = crate::config::MAX_ARC_LENGTH;
    let Some(&(frame, _)) = rows.iter().find(|(_, l)| l.abs() > limit) else {
        return Ok(());
    };
    let text = std::fs::read_to_string(path).map_err(|e| IoError::io(path, e))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .map(|(_, h)| h.split(',').map(str::trim).collect())
        .unwrap_or_default();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (fc, ac) = (col("frame").unwrap_or(0), col("arc_length").unwrap_or(1));
    let (line, value) = lines
        .find_map(|(i, l)| {
            let f: Vec<&str> = l.split(',').map(str::trim).collect();
            (f.get(fc)?.parse::<usize>().ok()? == frame)
                .then(|| (i + 1, f.get(ac).unwrap_or(&"").to_string()))
        })
        .unwrap_or((1, String::new()));
    Err(IoError::at(
        path,
        line,
        momo_io::IoErrorKind::BadNumber {
            field: "arc_length".into(),
            value: value.chars().take(40).collect(),
            expected: "an arc length within -1000..=1000 m per frame",
        },
    ))
}

/// Runs the odometry over an in-memory sequence (simulations, tests, `momo demo`); returns
/// camera 0's trajectory (one pose per frame, identity first) and the per-frame diagnostics.
pub fn run_in_memory(
    sequence: &momo_io::Sequence,
    estimator: EstimatorKind,
    config: Config,
    mut on_frame: impl FnMut(&FrameResult),
) -> Result<(Vec<momo_core::Pose<f64>>, Vec<FrameDiagnostics>), VoError> {
    // `odometry.road_scale_mount`, as in `run_sequence`.
    let has_odometry = sequence
        .arc_lengths
        .as_ref()
        .is_some_and(|a| a.iter().any(Option::is_some));
    let (rig, config) = if RoadMount::applies(estimator, &sequence.rig, &config, has_odometry) {
        let frames = sequence.frames.iter().enumerate().skip(1);
        let (rig, config, _) = RoadMount::calibrate(sequence.rig.clone(), config, frames);
        (rig, config)
    } else {
        (sequence.rig.clone(), config)
    };
    let mut vo = driver(estimator, &rig, config)?;
    let n = sequence.num_frames();
    let mut poses = Vec::with_capacity(n);
    let mut diagnostics = Vec::with_capacity(n);
    let frames = sequence.frames.iter().enumerate().skip(1);
    run_loop(
        vo.as_mut(),
        &rig,
        frames.map(Ok::<_, VoError>),
        sequence.arc_lengths.as_deref(),
        n.saturating_sub(1),
        |pose, result| {
            poses.push(*pose);
            if let Some(result) = result {
                on_frame(result);
                diagnostics.push(result.diagnostics.clone());
            }
            Ok(())
        },
    )?;
    Ok((poses, diagnostics))
}

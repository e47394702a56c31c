//! From image folders to a sequence directory (`momo match`) or straight to a trajectory
//! (`momo vo`), streaming one frame at a time: the images of frame k are decoded, matched
//! against frame k-1's features, and dropped; memory does not grow with the sequence.

use crate::error::MatchError;
use crate::images::{GammaTable, ImageSequence};
use crate::matcher::{FrameMatcher, MatchOptions};
use momo_core::{CameraModel, FrameObservations, Observation, Rig};
use momo_io::{AtomicFile, IoError, MatchWriter, PoseWriter, files};
use momo_vo::{Config, EstimatorKind, FrameResult, RunSummary};
use nalgebra::Vector2;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of the front end: the matcher and the gamma correction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrontEndOptions {
    /// The matcher.
    pub matching: MatchOptions,
    /// Gamma correction applied to every image before detection (`None`: none).
    pub gamma: Option<f64>,
}

/// Time spent and matches found so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrontEndStats {
    /// Frames read (including frame 0).
    pub frames: usize,
    /// Matches over all frame pairs and cameras.
    pub matches: usize,
    /// Seconds spent decoding images (and gamma correction).
    pub decode_seconds: f64,
    /// Seconds spent detecting, describing and matching.
    pub match_seconds: f64,
}

impl FrontEndStats {
    /// Milliseconds of detection and matching per frame (all cameras).
    pub fn match_ms_per_frame(&self) -> f64 {
        1e3 * self.match_seconds / self.frames.max(1) as f64
    }

    /// Milliseconds of image decoding per frame (all cameras).
    pub fn decode_ms_per_frame(&self) -> f64 {
        1e3 * self.decode_seconds / self.frames.max(1) as f64
    }
}

/// The streaming front end: an iterator over the frame pairs `(k, observations of (k-1, k))`,
/// `k = 1..frames`, of an image sequence and its rig.
///
/// Every image is checked against its camera's size in the rig (`width`, `height`); errors name
/// the file.
#[derive(Debug)]
pub struct ImageFrontEnd {
    images: ImageSequence,
    rig: Rig,
    matcher: FrameMatcher,
    gamma: Option<GammaTable>,
    next: usize,
    stats: FrontEndStats,
    failed: bool,
    /// Rectified camera pairs matched across cameras (`crate::stereo`).
    stereo: Vec<crate::stereo::StereoPair>,
}

impl ImageFrontEnd {
    /// Opens the image folders (one per camera, in the rig's order). `rig_path` names the rig in
    /// errors.
    pub fn new<P: AsRef<Path>>(
        folders: &[P],
        rig: &Rig,
        rig_path: &Path,
        options: &FrontEndOptions,
    ) -> Result<Self, MatchError> {
        if folders.len() != rig.len() {
            return Err(MatchError::CameraCount {
                rig: rig_path.to_path_buf(),
                cameras: rig.len(),
                folders: folders.len(),
            });
        }
        let gamma = options.gamma.map(GammaTable::new).transpose()?;
        let matcher = FrameMatcher::new(rig.len(), options.matching)?;
        let mut images = ImageSequence::open(folders)?;
        // Image headers are checked against the rig before decoding.
        images.expect_sizes(
            rig.cameras()
                .iter()
                .map(|c| {
                    let (w, h) = c.model.size();
                    Some((w as u32, h as u32))
                })
                .collect(),
        );
        Ok(Self {
            images,
            rig: rig.clone(),
            matcher,
            gamma,
            next: 0,
            stats: FrontEndStats::default(),
            failed: false,
            stereo: crate::stereo::rectified_pairs(rig, &crate::stereo::StereoOptions::default()),
        })
    }

    /// Number of frames (images per camera).
    pub fn frames(&self) -> usize {
        self.images.len()
    }

    /// The time spent and matches found so far.
    pub fn stats(&self) -> FrontEndStats {
        self.stats
    }

    /// True if the rig has rectified stereo pairs, whose cross-camera matches
    /// ([`FrameObservations::cross_camera`], `crate::stereo`) every frame pair carries.
    pub fn has_cross_camera(&self) -> bool {
        !self.stereo.is_empty()
    }

    /// Reads and matches the next frame; `None` after the last one. The first call reads frames
    /// 0 and 1 and returns pair 1.
    fn step(&mut self) -> Result<Option<(usize, FrameObservations)>, MatchError> {
        loop {
            let k = self.next;
            if k >= self.images.len() {
                return Ok(None);
            }
            self.next += 1;
            let t0 = Instant::now();
            let imgs = self.images.load(k, self.gamma.as_ref())?;
            for (j, (img, cam)) in imgs.iter().zip(self.rig.cameras()).enumerate() {
                let (w, h) = cam.model.size();
                if (f64::from(img.width()), f64::from(img.height())) != (w, h) {
                    return Err(MatchError::ImageSize {
                        path: self
                            .images
                            .path(j, k)
                            .map(Path::to_path_buf)
                            .unwrap_or_default(),
                        width: img.width(),
                        height: img.height(),
                        expected: format!("the rig's camera {j}"),
                        expected_width: w as u32,
                        expected_height: h as u32,
                    });
                }
                let min = crate::features::MIN_SIDE as u32;
                if img.width() < min || img.height() < min {
                    return Err(MatchError::TooSmall {
                        path: self
                            .images
                            .path(j, k)
                            .map(Path::to_path_buf)
                            .unwrap_or_default(),
                        width: img.width(),
                        height: img.height(),
                        min,
                    });
                }
            }
            let t1 = Instant::now();
            let result = self.matcher.push_owned(imgs)?;
            let t2 = Instant::now();
            self.stats.frames += 1;
            self.stats.decode_seconds += (t1 - t0).as_secs_f64();
            self.stats.match_seconds += (t2 - t1).as_secs_f64();
            let Some(per_camera) = result else {
                continue;
            };
            let mut obs = FrameObservations::new(self.rig.len());
            for (j, (list, cam)) in per_camera.iter().zip(self.rig.cameras()).enumerate() {
                obs.per_camera[j].extend(list.iter().filter_map(|m| {
                    Observation::new(
                        &cam.model,
                        Vector2::new(m.u0, m.v0),
                        Vector2::new(m.u1, m.v1),
                    )
                }));
            }
            // Cross-camera matches of the rectified stereo pairs: the metric scale.
            let t3 = Instant::now();
            let opts = crate::stereo::StereoOptions::default();
            for pair in &self.stereo {
                let feats = |c| self.matcher.current(c).zip(self.matcher.previous(c));
                if let (Some((cur_i, prev_i)), Some((cur_j, _))) =
                    (feats(pair.from), feats(pair.to))
                {
                    let m = crate::stereo::cross_matches(
                        pair,
                        prev_i,
                        cur_i,
                        cur_j,
                        &per_camera[pair.from],
                        &opts,
                    );
                    obs.cross_camera
                        .extend(crate::stereo::cross_observations(&self.rig, pair, &m));
                }
            }
            self.stats.match_seconds += t3.elapsed().as_secs_f64();
            self.stats.matches += obs.len();
            return Ok(Some((k, obs)));
        }
    }
}

impl Iterator for ImageFrontEnd {
    type Item = Result<(usize, FrameObservations), MatchError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        let r = self.step().transpose();
        if matches!(r, Some(Err(_))) {
            self.failed = true;
        }
        r
    }
}

/// Copies a file byte for byte, atomically.
fn copy_atomic(from: &Path, to: &Path) -> Result<(), MatchError> {
    let bytes = std::fs::read(from).map_err(|e| IoError::io(from, e))?;
    let mut f = AtomicFile::create(to)?;
    f.writer()
        .write_all(&bytes)
        .map_err(|e| IoError::io(to, e))?;
    f.commit()?;
    Ok(())
}

/// `momo match`: matches the image folders (one per camera of the rig in `rig_path`) and writes
/// the sequence directory `out_dir` (created): `matches.csv` (`FORMAT.md`), a copy of the rig
/// file as `rig.json`, and a copy of `odometry` as `odometry.csv` if given (checked first).
/// Every file is written atomically, and only after all frames were matched. `on_frame(k)` is
/// called after each frame pair.
///
/// Frame pairs without any match write no rows (`FORMAT.md` allows that); if the *last* pairs
/// have none and no odometry is given, `momo run` sees fewer frames than there are images.
pub fn match_to_sequence<P: AsRef<Path>>(
    folders: &[P],
    rig_path: &Path,
    out_dir: &Path,
    odometry: Option<&Path>,
    options: &FrontEndOptions,
    mut on_frame: impl FnMut(usize),
) -> Result<FrontEndStats, MatchError> {
    let rig = momo_io::read_rig(rig_path)?;
    if let Some(p) = odometry {
        momo_io::read_odometry(p)?;
    }
    let mut front = ImageFrontEnd::new(folders, &rig, rig_path, options)?;
    std::fs::create_dir_all(out_dir).map_err(|e| IoError::io(out_dir, e))?;
    let path = out_dir.join(files::MATCHES);
    let mut writer = if front.has_cross_camera() {
        MatchWriter::create_cross(path)?
    } else {
        MatchWriter::create(path)?
    };
    for item in &mut front {
        let (k, obs) = item?;
        writer.push(k, &obs)?;
        on_frame(k);
    }
    writer.finish()?;
    copy_atomic(rig_path, &out_dir.join(files::RIG))?;
    if let Some(p) = odometry {
        copy_atomic(p, &out_dir.join(files::ODOMETRY))?;
    }
    Ok(front.stats())
}

/// What `momo vo` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VoSummary {
    /// The front end's time and matches.
    pub front_end: FrontEndStats,
    /// Poses written (one per frame).
    pub poses: usize,
    /// The run's totals (statuses, scale sources, estimating time), as `momo run`'s.
    pub run: RunSummary,
}

/// Where `momo vo` reads and writes.
#[derive(Clone, Debug)]
pub struct VoRun {
    /// Image folders, one per camera in the rig's order.
    pub folders: Vec<PathBuf>,
    /// The rig file.
    pub rig: PathBuf,
    /// Optional `odometry.csv` (arc lengths; scale).
    pub odometry: Option<PathBuf>,
    /// The KITTI-format camera-0 trajectory written (atomically), one line per image frame.
    pub output: PathBuf,
    /// Per-frame diagnostics written with the trajectory (both or neither), as `momo run`'s
    /// ([`momo_vo::DiagnosticsWriter`]: CSV if the name ends in `.csv`, JSON lines otherwise).
    pub diagnostics: Option<PathBuf>,
    /// The estimator.
    pub estimator: EstimatorKind,
}

/// `momo vo`: matches and estimates in one streaming pass and writes camera 0's trajectory,
/// one pose per image frame. `on_frame` sees every frame pair's result (progress bars).
pub fn vo_from_images(
    run: &VoRun,
    config: Config,
    options: &FrontEndOptions,
    mut on_frame: impl FnMut(&FrameResult),
) -> Result<VoSummary, MatchError> {
    let rig = momo_io::read_rig(&run.rig)?;
    let arc_lengths = run
        .odometry
        .as_deref()
        .map(momo_io::read_odometry)
        .transpose()?;
    let mut front = ImageFrontEnd::new(&run.folders, &rig, &run.rig, options)?;
    // `odometry.road_scale_mount`: one camera without odometry.csv holds back the first frame
    // pairs' matches, calibrates the mount on them, then runs them and the rest as they come.
    let has_odometry = arc_lengths
        .as_ref()
        .is_some_and(|a| a.iter().any(Option::is_some));
    let mut held = Vec::new();
    let (rig, config, road_mount) =
        if momo_vo::RoadMount::applies(run.estimator, &rig, &config, has_odometry) {
            for item in front.by_ref() {
                let (k, obs) = item?;
                held.push((k, obs));
                if k >= momo_vo::pipeline::ROAD_MOUNT_FRAMES {
                    break;
                }
            }
            let frames = held.iter().map(|(k, obs)| (*k, obs));
            momo_vo::RoadMount::calibrate(rig, config, frames)
        } else {
            (rig, config, momo_vo::RoadMount::NotRun)
        };
    let mut vo = momo_vo::driver(run.estimator, &rig, config)?;
    let mut poses = PoseWriter::create(&run.output)?;
    let mut diagnostics = run
        .diagnostics
        .as_deref()
        .map(momo_vo::DiagnosticsWriter::create)
        .transpose()?;
    let totals = momo_vo::run_loop(
        vo.as_mut(),
        &rig,
        held.into_iter().map(Ok).chain(&mut front),
        arc_lengths.as_deref(),
        0,
        |pose, result| {
            poses.push(pose)?;
            if let Some(result) = result {
                if let Some(d) = diagnostics.as_mut() {
                    d.push(&result.diagnostics)?;
                }
                on_frame(result);
            }
            Ok(())
        },
    )?;
    let mut summary = VoSummary {
        run: totals,
        ..VoSummary::default()
    };
    summary.run.road_mount = road_mount;
    summary.poses = poses.len();
    // Poses and diagnostics are committed together: both or neither.
    let mut outputs = vec![poses.into_file()];
    outputs.extend(diagnostics.map(momo_vo::DiagnosticsWriter::into_file));
    momo_io::commit_all(outputs)?;
    summary.front_end = front.stats();
    Ok(summary)
}

//! Whole sequences: `momo.Sequence` (a `FORMAT.md` sequence in memory), `momo.run` (a sequence
//! directory through the odometry, as `momo run`), `momo.simulate` (as `momo simulate`),
//! `momo.evaluate` (as `momo eval`) and `momo.read_poses`.

use crate::config::PyConfig;
use crate::convert::{json_to_py, observations_to_py, poses_from_py, poses_to_py};
use crate::errors::{ConfigError, SimulationError, input_error, vo_error};
use crate::odometry::tag;
use crate::rig::PyRig;
use momo_core::{FrameObservations, Pose};
use momo_io::{IoError, MatchReader, Sequence};
use momo_vo::{Config, EstimatorKind, FrameDiagnostics, Trajectory, VoError};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};
use std::path::{Path, PathBuf};

/// A sequence in memory (`FORMAT.md`): the rig, the matches of every frame pair, the arc
/// lengths (odometry.csv) and the ground truth (poses.txt) if present.
///
/// `Sequence.read(dir)` loads a sequence directory, `momo.simulate(...)` makes one, and
/// `write(dir)` writes one that `momo run` reads.
#[pyclass(module = "momo", name = "Sequence", frozen)]
pub struct PySequence {
    /// The sequence.
    pub inner: Sequence,
    /// The true vehicle poses of a simulation (`V_k`), if known.
    pub vehicle_poses: Option<Vec<Pose<f64>>>,
}

#[pymethods]
impl PySequence {
    /// Loads a sequence directory (rig.json, matches.csv, optional odometry.csv and poses.txt);
    /// `InputError` (`file:line: reason`) if it is malformed.
    #[staticmethod]
    fn read(py: Python<'_>, dir: PathBuf) -> PyResult<Self> {
        let inner = py
            .detach(|| momo_io::read_sequence(&dir))
            .map_err(|e| input_error(py, &e))?;
        Ok(Self {
            inner,
            vehicle_poses: None,
        })
    }

    /// Writes the sequence as a directory (created) that `momo run` reads.
    fn write(&self, py: Python<'_>, dir: PathBuf) -> PyResult<()> {
        momo_io::write_sequence(&dir, &self.inner).map_err(|e| input_error(py, &e))
    }

    /// The rig.
    #[getter]
    fn rig(&self) -> PyRig {
        PyRig {
            inner: self.inner.rig.clone(),
        }
    }

    /// Number of frames (frame pairs + 1).
    #[getter]
    fn num_frames(&self) -> usize {
        self.inner.num_frames()
    }

    fn __len__(&self) -> usize {
        self.inner.num_frames()
    }

    /// The matches of frame pair `(k-1, k)`: one (N, 4) array `(u0, v0, u1, v1)` per camera
    /// (empty arrays for k = 0 and frame pairs without matches).
    fn frame<'py>(&self, py: Python<'py>, k: usize) -> PyResult<Bound<'py, PyList>> {
        match self.inner.frames.get(k) {
            Some(obs) => observations_to_py(py, obs),
            None if k < self.inner.num_frames() => {
                observations_to_py(py, &FrameObservations::new(self.inner.rig.len()))
            }
            None => Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "frame {k} of a sequence of {} frames",
                self.inner.num_frames()
            ))),
        }
    }

    /// The matches of every frame: `matches[k]` is `frame(k)` (`matches[0]` is empty).
    #[getter]
    fn matches<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let frames = (0..self.inner.num_frames())
            .map(|k| self.frame(py, k))
            .collect::<PyResult<Vec<_>>>()?;
        PyList::new(py, frames)
    }

    /// Arc lengths per frame pair (`arc_lengths[k]` for the pair k-1, k; NaN where unknown,
    /// always at 0), or None without odometry.
    #[getter]
    fn arc_lengths<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner.arc_lengths.as_ref().map(|a| {
            let v: Vec<f64> = a.iter().map(|x| x.unwrap_or(f64::NAN)).collect();
            PyArray1::from_vec(py, v)
        })
    }

    /// Ground truth: camera 0's poses `T_cam0(0)_cam0(k)` as (N, 4, 4), or None.
    #[getter]
    fn ground_truth<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f64>>> {
        self.inner.ground_truth.as_ref().map(|g| poses_to_py(py, g))
    }

    /// A simulation's true vehicle poses `V_k` (N, 4, 4), or None.
    #[getter]
    fn vehicle_poses<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f64>>> {
        self.vehicle_poses.as_ref().map(|g| poses_to_py(py, g))
    }

    /// Number of match rows over all frames and cameras.
    #[getter]
    fn num_matches(&self) -> usize {
        self.inner.num_matches()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PySequence>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }

    fn __repr__(&self) -> String {
        format!(
            "Sequence({} frames, {} camera(s), {} matches, odometry: {}, ground truth: {})",
            self.inner.num_frames(),
            self.inner.rig.len(),
            self.inner.num_matches(),
            self.inner.arc_lengths.is_some(),
            self.inner.ground_truth.is_some()
        )
    }
}

/// Why a run failed (mirrors `momo_vo::RunError` without the output files).
enum RunFailure {
    Input(IoError),
    Vo(VoError),
}

/// Runs the driver over a sequence directory exactly as `momo_vo::run_sequence` does (matches
/// streamed one frame pair at a time, then the frames only odometry.csv names), keeping the
/// poses and diagnostics in memory instead of writing them.
fn run_dir(
    dir: &Path,
    config: Config,
    kind: EstimatorKind,
) -> Result<(Vec<Pose<f64>>, Vec<FrameDiagnostics>), RunFailure> {
    let rig = momo_io::read_rig(dir.join("rig.json")).map_err(RunFailure::Input)?;
    let odometry_path = dir.join("odometry.csv");
    let arc_lengths = if odometry_path.exists() {
        Some(momo_io::read_odometry(&odometry_path).map_err(RunFailure::Input)?)
    } else {
        None
    };
    let reader = MatchReader::open(dir.join("matches.csv"), &rig).map_err(RunFailure::Input)?;
    // `odometry.road_scale_mount`, as `run_sequence` does.
    let has_odometry = arc_lengths
        .as_ref()
        .is_some_and(|a| a.iter().any(Option::is_some));
    let (rig, config, _) = momo_vo::road_scale_setup(dir, rig, config, kind, has_odometry)
        .map_err(RunFailure::Input)?;
    let mut vo = momo_vo::driver(kind, &rig, config).map_err(RunFailure::Vo)?;
    let mut trajectory = Trajectory::new(&rig);
    let mut poses = vec![trajectory.camera0()];
    let mut diagnostics = Vec::new();
    let arc = |k: usize| {
        arc_lengths
            .as_ref()
            .and_then(|a| a.get(k).copied().flatten())
    };
    let mut last = 0;
    for item in reader {
        let (k, obs) = item.map_err(RunFailure::Input)?;
        let r = vo.process(&obs, arc(k));
        poses.push(trajectory.push(&r.motion));
        diagnostics.push(r.diagnostics);
        last = k;
    }
    let total = arc_lengths
        .as_ref()
        .map_or(0, |a| a.len().saturating_sub(1))
        .max(last);
    let empty = FrameObservations::new(rig.len());
    for k in last + 1..=total {
        let r = vo.process(&empty, arc(k));
        poses.push(trajectory.push(&r.motion));
        diagnostics.push(r.diagnostics);
    }
    Ok((poses, diagnostics))
}

/// The estimator of a name (`"momo"`, `"five-point"`, `"five-point-refined"`).
fn estimator_kind(name: &str) -> PyResult<EstimatorKind> {
    match name.replace('_', "-").as_str() {
        "momo" => Ok(EstimatorKind::Momo),
        "five-point" => Ok(EstimatorKind::FivePoint),
        "five-point-refined" => Ok(EstimatorKind::FivePointRefined),
        _ => Err(ConfigError::new_err(format!(
            "unknown estimator `{name}` (momo, five-point, five-point-refined)"
        ))),
    }
}

/// The diagnostics as a dict of arrays (one row per frame pair, frames 1..N-1).
fn diagnostics_dict<'py>(
    py: Python<'py>,
    diags: &[FrameDiagnostics],
) -> PyResult<Bound<'py, PyDict>> {
    let np = py.import("numpy")?;
    let d = PyDict::new(py);
    let col_u = |f: &dyn Fn(&FrameDiagnostics) -> usize| -> Vec<i64> {
        diags.iter().map(|x| f(x) as i64).collect()
    };
    let col_f =
        |f: &dyn Fn(&FrameDiagnostics) -> f64| -> Vec<f64> { diags.iter().map(f).collect() };
    let strings = |f: &dyn Fn(&FrameDiagnostics) -> String| -> PyResult<Bound<'py, PyAny>> {
        let list: Vec<String> = diags.iter().map(f).collect();
        np.call_method1("array", (list, "U"))
    };
    d.set_item("frame", PyArray1::from_vec(py, col_u(&|x| x.frame)))?;
    d.set_item("status", strings(&|x| tag(&x.status))?)?;
    d.set_item("scale_source", strings(&|x| tag(&x.scale))?)?;
    d.set_item(
        "termination",
        strings(&|x| x.termination.as_ref().map_or_else(|| "none".into(), tag))?,
    )?;
    d.set_item("matches", PyArray1::from_vec(py, col_u(&|x| x.matches)))?;
    d.set_item("inliers", PyArray1::from_vec(py, col_u(&|x| x.inliers)))?;
    d.set_item(
        "iterations",
        PyArray1::from_vec(py, col_u(&|x| x.iterations)),
    )?;
    d.set_item("restarts", PyArray1::from_vec(py, col_u(&|x| x.restarts)))?;
    let won: Vec<bool> = diags.iter().map(|x| x.restart_won).collect();
    d.set_item("restart_won", PyArray1::from_vec(py, won))?;
    d.set_item(
        "initial_cost",
        PyArray1::from_vec(py, col_f(&|x| x.initial_cost)),
    )?;
    d.set_item(
        "final_cost",
        PyArray1::from_vec(py, col_f(&|x| x.final_cost)),
    )?;
    d.set_item("time_us", PyArray1::from_vec(py, col_f(&|x| x.time_us)))?;
    d.set_item("constraint", strings(&|x| tag(&x.constraint))?)?;
    d.set_item(
        "reason",
        strings(&|x| x.reason.as_ref().map_or_else(|| "none".into(), tag))?,
    )?;
    d.set_item(
        "competing_weight",
        PyArray1::from_vec(
            py,
            col_f(&|x| x.competing.as_ref().map_or(f64::NAN, |c| c.1)),
        ),
    )?;
    d.set_item(
        "noise_scale",
        PyArray1::from_vec(py, col_f(&|x| x.noise_scale)),
    )?;
    d.set_item(
        "noise",
        PyArray1::from_vec(py, col_f(&|x| x.noise.unwrap_or(f64::NAN))),
    )?;
    let p = diags.first().map_or(0, |x| x.params.len());
    let table = |f: &dyn Fn(&FrameDiagnostics) -> &Vec<f64>| {
        Array2::from_shape_fn((diags.len(), p), |(k, i)| {
            f(&diags[k]).get(i).copied().unwrap_or(f64::NAN)
        })
        .into_pyarray(py)
    };
    d.set_item("params", table(&|x| &x.params))?;
    d.set_item("param_sigmas", table(&|x| &x.param_sigmas))?;
    let names: Vec<String> = diags
        .first()
        .map(|x| x.param_names.clone())
        .unwrap_or_default();
    d.set_item("param_names", names)?;
    Ok(d)
}

/// Runs the odometry over a sequence directory as `momo run` does (same frames, same poses
/// bit for bit), keeping the results in memory. One camera without odometry.csv: the mount is
/// calibrated on the first frame pairs first and its pitch given to the road that gives the
/// scale (`odometry.road_scale_mount`), as `momo run` does.
///
/// `config`: a `Config`, a path to a configuration file (as `momo run --config`), or None for
/// the default. `estimator`: `"momo"`, `"five-point"` or `"five-point-refined"`.
///
/// Returns `(poses, diagnostics)`: camera 0's poses as (N, 4, 4) (identity first) and a dict
/// of arrays with one row per frame pair (frames 1..N-1): `frame`, `status`, `scale_source`,
/// `termination`, `matches`, `inliers`, `iterations`, `restarts`, `restart_won`,
/// `initial_cost`, `final_cost`, `time_us`, `constraint`, `reason` (`"none"` where none),
/// `competing_weight` (the competing motion's mixture weight, NaN where none), `noise_scale`,
/// `noise` (NaN where the frame was not read), `params` and `param_sigmas` (rows x
/// parameters), `param_names`. The GIL is released during the run.
#[pyfunction]
#[pyo3(signature = (seq_dir, config = None, estimator = "momo"))]
pub fn run<'py>(
    py: Python<'py>,
    seq_dir: PathBuf,
    config: Option<&Bound<'py, PyAny>>,
    estimator: &str,
) -> PyResult<(Bound<'py, PyArray3<f64>>, Bound<'py, PyDict>)> {
    let kind = estimator_kind(estimator)?;
    let config = match config {
        None => Config::default(),
        Some(c) => {
            if let Ok(c) = c.cast::<PyConfig>() {
                c.get().to_config()?
            } else if let Ok(path) = c.extract::<PathBuf>() {
                Config::from_file(&path).map_err(|e| crate::errors::config_error(&e))?
            } else {
                return Err(ConfigError::new_err(
                    "config must be a momo.Config, a path to a configuration file, or None",
                ));
            }
        }
    };
    let (poses, diags) = py
        .detach(|| run_dir(&seq_dir, config, kind))
        .map_err(|e| match e {
            RunFailure::Input(e) => input_error(py, &e),
            RunFailure::Vo(e) => vo_error(&e),
        })?;
    Ok((poses_to_py(py, &poses), diagnostics_dict(py, &diags)?))
}

/// The names of the simulation scenarios.
#[pyfunction]
pub fn scenarios() -> Vec<&'static str> {
    momo_sim::SimConfig::SCENARIOS.to_vec()
}

/// Simulates a drive and its matches as `momo simulate` does (same seed, same sequence bit
/// for bit), in memory.
///
/// `scenario`: one of `momo.scenarios()`; `frames`, `seed`; `matches`: matches per camera and
/// frame pair (default: the scenario's); `trajectory`: drive along these camera-0 poses
/// ((N, 4, 4) array, or a path to a KITTI poses file) instead of a generated drive, at most
/// `frames` of them; `rig`: a `Rig` instead of the scenario's; `along_travel`: the trajectory
/// turned by its travel elevation first (`momo simulate --trajectory-along-travel`);
/// `static_tracks`: the share (0 to 1) of each frame pair's static matches that continue one of
/// the previous pair, as a tracker gives them (`momo simulate --static-tracks`). Returns a `Sequence` with ground
/// truth (and the true arc lengths as odometry where the scenario has them) and
/// `vehicle_poses`.
#[pyfunction]
#[pyo3(signature = (scenario = "clean_pinhole", frames = 400, seed = 1, matches = None, trajectory = None, rig = None, along_travel = false, static_tracks = 0.0))]
pub fn simulate(
    py: Python<'_>,
    scenario: &str,
    frames: usize,
    seed: u64,
    matches: Option<usize>,
    trajectory: Option<&Bound<'_, PyAny>>,
    rig: Option<&Bound<'_, PyRig>>,
    along_travel: bool,
    static_tracks: f64,
) -> PyResult<PySequence> {
    let Some(mut cfg) = momo_sim::SimConfig::scenario(scenario) else {
        return Err(SimulationError::new_err(format!(
            "unknown scenario `{scenario}` ({})",
            momo_sim::SimConfig::SCENARIOS.join(", ")
        )));
    };
    if let Some(t) = trajectory {
        let poses = if t.is_instance_of::<PyString>() || t.hasattr("__fspath__")? {
            let path: PathBuf = t.extract()?;
            momo_io::read_poses(&path).map_err(|e| input_error(py, &e))?
        } else {
            poses_from_py(py, t, "trajectory")?
        };
        if poses.is_empty() {
            return Err(SimulationError::new_err("trajectory: no poses"));
        }
        cfg.camera_trajectory = Some(if along_travel {
            momo_sim::along_travel(&poses).0
        } else {
            poses
        });
    }
    if let Some(r) = rig {
        cfg.rig = momo_sim::RigPreset::Custom(r.get().inner.clone());
    }
    cfg.frames = frames;
    cfg.seed = seed;
    if let Some(m) = matches {
        cfg.matches_per_camera = m;
    }
    cfg.static_tracks = static_tracks;
    let sim = py
        .detach(|| momo_sim::simulate(&cfg))
        .map_err(|e| SimulationError::new_err(e.to_string()))?;
    Ok(PySequence {
        inner: sim.sequence,
        vehicle_poses: Some(sim.vehicle_poses),
    })
}

/// Poses from a path (a KITTI poses file) or an array-like.
fn poses_arg(py: Python<'_>, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Pose<f64>>> {
    if obj.is_instance_of::<PyString>() || obj.hasattr("__fspath__")? {
        let path: PathBuf = obj.extract()?;
        return momo_io::read_poses(&path).map_err(|e| input_error(py, &e));
    }
    poses_from_py(py, obj, what)
}

/// Scores an estimated trajectory against ground truth as `momo eval` does (camera-0 poses,
/// same length): a dict with `t_err_percent` and `r_err_deg_per_100m` (KITTI devkit; None for a
/// path shorter than 100 m) and `rotation_deg`, the frame-to-frame rotation errors in degrees
/// (`count`, `mean`, `median`, `p95`, `max`, `above_one`): the fields of one estimate of
/// `momo eval --json`.
///
/// `gt` and `est`: (N, 4, 4), (N, 3, 4) or (N, 12) arrays, or paths to KITTI poses files.
/// Raises `InputError` for unreadable files, bad shapes or different lengths.
#[pyfunction]
pub fn evaluate<'py>(
    py: Python<'py>,
    gt: &Bound<'py, PyAny>,
    est: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let gt = poses_arg(py, gt, "gt")?;
    let est = poses_arg(py, est, "est")?;
    if gt.len() != est.len() {
        return Err(crate::errors::input_error_at(
            py,
            format!(
                "est has {} poses, but the ground truth has {}",
                est.len(),
                gt.len()
            ),
            None,
            None,
        ));
    }
    let e = py.detach(|| momo_eval::evaluate(&gt, &est));
    let v = serde_json::to_value(&e)
        .map_err(|e| crate::errors::MomoError::new_err(format!("cannot serialise: {e}")))?;
    json_to_py(py, &v)
}

/// Reads a KITTI poses file (12 numbers per line) as (N, 4, 4); `InputError` with
/// `file:line: reason` if it is malformed.
#[pyfunction]
pub fn read_poses<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let poses = momo_io::read_poses(&path).map_err(|e| input_error(py, &e))?;
    Ok(poses_to_py(py, &poses))
}

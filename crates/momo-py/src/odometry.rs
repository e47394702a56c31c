//! `momo.Odometry` (frame by frame, with state), `momo.Diagnostics` and `momo.estimate` (one
//! frame pair, without state).

use crate::config::{PyConfig, from_sections};
use crate::convert::{fill_observations, pose_to_py};
use crate::errors::{ConfigError, EstimationError, RigError, vo_error};
use crate::rig::PyRig;
use momo_core::{FrameObservations, Rig, SolveRequest};
use momo_vo::{Config, FrameDiagnostics, Odometry, Trajectory};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;
use std::time::Instant;

/// The serde name of a unit enum (`"estimated"`, `"odometry"`, ...).
pub fn tag<T: Serialize>(t: &T) -> String {
    match serde_json::to_value(t) {
        Ok(serde_json::Value::String(s)) => s,
        _ => String::new(),
    }
}

/// The frame-to-frame odometry of `momo run`: feed it the frame pairs in order.
///
/// `Odometry(rig, config=None)` (default configuration if None). `process(matches,
/// arc_length=None)` estimates the vehicle motion `T_{k-1,k}` of the next frame pair from its
/// matches, one (N, 4) array `(u0, v0, u1, v1)` (or None) per camera, and the arc length from
/// odometry if known; it returns the 4x4 motion and a `Diagnostics`. The GIL is released while
/// it estimates. `pose` is camera 0's pose at the last frame in camera 0's frame at frame 0
/// (the line `momo run` writes), composed in Rust exactly as `momo run` does.
#[pyclass(module = "momo", name = "Odometry")]
pub struct PyOdometry {
    vo: Odometry,
    trajectory: Trajectory,
    obs: FrameObservations,
    frames: usize,
}

#[pymethods]
impl PyOdometry {
    /// A driver for a rig and a configuration (the default if None).
    #[new]
    #[pyo3(signature = (rig, config = None))]
    fn new(rig: &Bound<'_, PyRig>, config: Option<&Bound<'_, PyConfig>>) -> PyResult<Self> {
        let rig = rig.get().inner.clone();
        let config = match config {
            Some(c) => c.get().to_config()?,
            None => Config::default(),
        };
        let trajectory = Trajectory::new(&rig);
        let obs = FrameObservations::new(rig.len());
        let vo = Odometry::new(rig, config).map_err(|e| vo_error(&e))?;
        Ok(Self {
            vo,
            trajectory,
            obs,
            frames: 1,
        })
    }

    /// Estimates the next frame pair's vehicle motion `T_{k-1,k}` (4x4) from its matches (one
    /// (N, 4) array or None per camera) and, if known, the arc length travelled (metres; None
    /// or NaN: unknown). Returns `(motion, diagnostics)`. Raises `MatchError` for malformed
    /// matches (the odometry's state is then unchanged).
    #[pyo3(signature = (matches, arc_length = None))]
    fn process<'py>(
        &mut self,
        py: Python<'py>,
        matches: &Bound<'py, PyAny>,
        arc_length: Option<f64>,
    ) -> PyResult<(Bound<'py, PyArray2<f64>>, PyDiagnostics)> {
        fill_observations(self.vo.rig(), matches, &mut self.obs)?;
        let (vo, obs) = (&mut self.vo, &self.obs);
        let result = py.detach(|| vo.process(obs, arc_length));
        self.trajectory.push(&result.motion);
        self.frames += 1;
        Ok((
            pose_to_py(py, &result.motion),
            PyDiagnostics {
                inner: result.diagnostics,
            },
        ))
    }

    /// Camera 0's pose at the last frame processed, in camera 0's frame at frame 0 (4x4;
    /// identity before the first frame pair): the line `momo run` writes for that frame.
    #[getter]
    fn pose<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_to_py(py, &self.trajectory.camera0())
    }

    /// The vehicle's pose at the last frame processed, in the vehicle frame at frame 0 (4x4).
    #[getter]
    fn vehicle_pose<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_to_py(py, &self.trajectory.vehicle())
    }

    /// Frames seen so far (frame 0 and one per processed frame pair).
    #[getter]
    fn frames(&self) -> usize {
        self.frames
    }

    /// The model's parameter names.
    #[getter]
    fn param_names(&self) -> Vec<&'static str> {
        self.vo.estimator().param_names().to_vec()
    }

    /// Whether the rig can observe the scale (arc length) without odometry.
    #[getter]
    fn scale_observable(&self) -> bool {
        self.vo.scale_observable()
    }

    /// The rig.
    #[getter]
    fn rig(&self) -> PyRig {
        PyRig {
            inner: self.vo.rig().clone(),
        }
    }

    /// A copy of the configuration.
    #[getter]
    fn config(&self) -> PyResult<PyConfig> {
        Ok(PyConfig {
            inner: crate::config::clone_config(self.vo.config())?,
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "Odometry({} camera(s), {} frame(s))",
            self.vo.rig().len(),
            self.frames
        )
    }
}

/// Per-frame diagnostics of `Odometry.process` (one row of `momo run --diagnostics`).
#[pyclass(module = "momo", name = "Diagnostics", frozen)]
pub struct PyDiagnostics {
    /// The diagnostics.
    pub inner: FrameDiagnostics,
}

#[pymethods]
impl PyDiagnostics {
    /// Frame index k (the pair k-1, k).
    #[getter]
    fn frame(&self) -> usize {
        self.inner.frame
    }
    /// What happened: `"estimated"`, `"standstill"`, `"no_matches"`, `"solver_failure"`,
    /// `"degenerate"` or `"weak"`.
    #[getter]
    fn status(&self) -> String {
        tag(&self.inner.status)
    }
    /// Where the scale came from: `"odometry"`, `"estimated"`, `"road"`, `"held"` or `"unobservable"`.
    #[getter]
    fn scale_source(&self) -> String {
        tag(&self.inner.scale)
    }
    /// The model's parameter names.
    #[getter]
    fn param_names(&self) -> Vec<String> {
        self.inner.param_names.clone()
    }
    /// Final parameters.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.params)
    }
    /// Standard deviations of the parameters (NaN for fixed or unknown ones).
    #[getter]
    fn param_sigmas<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.param_sigmas)
    }
    /// Covariance of the free parameters (`free x free`; `(0, 0)` if unavailable).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let n = self.inner.free.len();
        let c = &self.inner.covariance;
        if c.len() != n * n {
            return Array2::<f64>::zeros((0, 0)).into_pyarray(py);
        }
        Array2::from_shape_fn((n, n), |(r, k)| c[r * n + k]).into_pyarray(py)
    }
    /// Indices of the free parameters (the rows and columns of `covariance`).
    #[getter]
    fn free(&self) -> Vec<usize> {
        self.inner.free.clone()
    }
    /// Cost at the start of the chosen solve (NaN if none ran).
    #[getter]
    fn initial_cost(&self) -> f64 {
        self.inner.initial_cost
    }
    /// Cost at the end (NaN if no solve ran).
    #[getter]
    fn final_cost(&self) -> f64 {
        self.inner.final_cost
    }
    /// Solver iterations of the chosen solve.
    #[getter]
    fn iterations(&self) -> usize {
        self.inner.iterations
    }
    /// Why the solver stopped (None when no solve ran).
    #[getter]
    fn termination(&self) -> Option<String> {
        self.inner.termination.as_ref().map(tag)
    }
    /// Matches of the frame pair, all cameras.
    #[getter]
    fn matches(&self) -> usize {
        self.inner.matches
    }
    /// Matches whose residual is within the loss scale.
    #[getter]
    fn inliers(&self) -> usize {
        self.inner.inliers
    }
    /// Inliers per camera.
    #[getter]
    fn inliers_per_camera(&self) -> Vec<usize> {
        self.inner.inliers_per_camera.clone()
    }
    /// Extra starts tried (0 if none).
    #[getter]
    fn restarts(&self) -> usize {
        self.inner.restarts
    }
    /// Whether an extra start won.
    #[getter]
    fn restart_won(&self) -> bool {
        self.inner.restart_won
    }
    /// Compute time of the frame in microseconds (inside Rust).
    #[getter]
    fn time_us(&self) -> f64 {
        self.inner.time_us
    }
    /// How well the matches constrained the motion: `"well"`, `"weak"` or `"degenerate"`.
    #[getter]
    fn constraint(&self) -> String {
        tag(&self.inner.constraint)
    }
    /// Why the frame is weak or degenerate (`"competing_motions"`, `"road_score_drop"`,
    /// `"yaw_change"`, ...: docs/GUIDE.md, Degenerate input); None if well constrained.
    #[getter]
    fn reason(&self) -> Option<String> {
        self.inner.reason.as_ref().map(tag)
    }
    /// The competing motion found by the covariance's check: `(params, weight)` (all of the
    /// model's parameters, the mixture weight `w`), or None.
    #[getter]
    fn competing<'py>(&self, py: Python<'py>) -> Option<(Bound<'py, PyArray1<f64>>, f64)> {
        self.inner
            .competing
            .as_ref()
            .map(|(p, w)| (PyArray1::from_slice(py, p), *w))
    }
    /// The road's alternative that widened the covariance of a frame whose road score
    /// dropped (all of the model's parameters), or None.
    #[getter]
    fn road_alternative<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .road_alternative
            .as_ref()
            .map(|p| PyArray1::from_slice(py, p))
    }
    /// The final stage the neighbourhood guard did not keep, where the stage without the
    /// matches its support tests left out and the stage on the given matches turned apart:
    /// the reduced stage's motion where the guard kept the given one, the given one's where
    /// `final_fit.guard_tilt` kept the reduced one (all of the model's parameters; it widened
    /// the covariance), or None.
    #[getter]
    fn guard_alternative<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .guard_alternative
            .as_ref()
            .map(|p| PyArray1::from_slice(py, p))
    }
    /// Whether the leave-one-cell-out jackknife of the covariance ran on this frame.
    #[getter]
    fn jackknife(&self) -> bool {
        self.inner.jackknife
    }
    /// The clustering of the residuals in the image over its degrees of freedom (about 1 for
    /// independent residuals; NaN if not computed).
    #[getter]
    fn residual_clustering(&self) -> f64 {
        self.inner.residual_clustering
    }
    /// The factor the angular thresholds were scaled by on this frame for the run's measured
    /// noise (`odometry.noise_reference`): 1 at or below the reference noise, or with the rule off.
    #[getter]
    fn noise_scale(&self) -> f64 {
        self.inner.noise_scale
    }
    /// This frame's noise reading (radians, the epipolar angles' trimmed MAD at the reported
    /// motion) where it entered the run's noise window, else None.
    #[getter]
    fn noise(&self) -> Option<f64> {
        self.inner.noise
    }
    /// The final stage's support per camera (match indices in the camera's input order), with
    /// `odometry.report_support` only; else None.
    #[getter]
    fn support(&self) -> Option<Vec<Vec<usize>>> {
        self.inner.support.clone()
    }
    /// All fields as a dict (the JSON line of `momo run --diagnostics`, with `scale` named
    /// `scale_source` and arrays for `params`, `param_sigmas` and `covariance`).
    fn to_dict<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(slf.py());
        for name in [
            "frame",
            "status",
            "scale_source",
            "param_names",
            "params",
            "param_sigmas",
            "covariance",
            "free",
            "initial_cost",
            "final_cost",
            "iterations",
            "termination",
            "matches",
            "inliers",
            "inliers_per_camera",
            "restarts",
            "restart_won",
            "time_us",
            "constraint",
            "reason",
            "jackknife",
            "competing",
            "residual_clustering",
            "road_alternative",
            "guard_alternative",
            "noise_scale",
            "noise",
            "support",
        ] {
            d.set_item(name, slf.getattr(name)?)?;
        }
        Ok(d)
    }
    fn __repr__(&self) -> String {
        format!(
            "Diagnostics(frame={}, status={}, scale_source={}, matches={}, inliers={}, iterations={}, time_us={:.1})",
            self.inner.frame,
            tag(&self.inner.status),
            tag(&self.inner.scale),
            self.inner.matches,
            self.inner.inliers,
            self.inner.iterations,
            self.inner.time_us
        )
    }
}

/// Estimates one frame pair's vehicle motion without state (no warm start, prior or restarts):
/// one robust solve of `model` with `metric`, `loss` and `solver` (each a type name or a dict
/// as in `Config(...)`; the default configuration's if None) from `initial` (the model's
/// parameters; default: straight ahead with `arc_length`, or 1 m). With `arc_length` the arc
/// length is held fixed, as are parameters the rig cannot observe.
///
/// Returns `(motion, info)`: the 4x4 vehicle motion `T_{k-1,k}` and a dict with
/// `param_names`, `params`, `free`, `initial_cost`, `final_cost`, `iterations`, `termination`,
/// `matches`, `inliers`, `inliers_per_camera` and `covariance` (free x free, `σ² (JᵀJ)⁻¹` as in
/// the odometry's diagnostics; `(0, 0)` if singular). Raises `EstimationError` if there are
/// fewer matches than free parameters or the solver fails.
#[pyfunction]
#[pyo3(signature = (rig, matches, model = None, metric = None, loss = None, solver = None, initial = None, arc_length = None))]
pub fn estimate<'py>(
    py: Python<'py>,
    rig: &Bound<'py, PyRig>,
    matches: &Bound<'py, PyAny>,
    model: Option<&Bound<'py, PyAny>>,
    metric: Option<&Bound<'py, PyAny>>,
    loss: Option<&Bound<'py, PyAny>>,
    solver: Option<&Bound<'py, PyAny>>,
    initial: Option<Vec<f64>>,
    arc_length: Option<f64>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyDict>)> {
    let rig: &Rig = &rig.get().inner;
    let sections = PyDict::new(py);
    for (k, v) in [
        ("model", model),
        ("metric", metric),
        ("loss", loss),
        ("solver", solver),
    ] {
        if let Some(v) = v {
            sections.set_item(k, v)?;
        }
    }
    let config = from_sections(Some(&sections), "<estimate>")?;
    let estimator = config
        .model
        .build(config.metric.as_ref())
        .map_err(|e| RigError::new_err(e.to_string()))?;
    let names = estimator.param_names();
    let arc_index = estimator.arc_length_index();
    let arc_length = arc_length.filter(|l| l.is_finite());
    let mut init = match initial {
        Some(x) => {
            if x.len() != names.len() {
                return Err(ConfigError::new_err(format!(
                    "<estimate>: initial has {} values, the model has {} parameters ({})",
                    x.len(),
                    names.len(),
                    names.join(", ")
                )));
            }
            x
        }
        None => estimator.initial_params(arc_length.unwrap_or(1.0)),
    };
    let mut fixed: Vec<bool> = estimator.observable(rig).iter().map(|o| !o).collect();
    if let (Some(i), Some(l)) = (arc_index, arc_length) {
        init[i] = l;
        fixed[i] = true;
    }
    let mut obs = FrameObservations::new(rig.len());
    fill_observations(rig, matches, &mut obs)?;
    let free = fixed.iter().filter(|f| !**f).count();
    if obs.len() < free {
        return Err(EstimationError::new_err(format!(
            "{} matches for {free} free parameters",
            obs.len()
        )));
    }
    let request = SolveRequest {
        rig,
        observations: &obs,
        loss: config.loss.as_ref(),
        solver: config.solver.as_ref(),
        initial: &init,
        fixed: &fixed,
        rotation_only: false,
        motion_prior: None,
    };
    let solution = py
        .detach(|| estimator.solve(&request))
        .map_err(|e| EstimationError::new_err(e.to_string()))?;
    let report = &solution.report;
    if !report.final_cost.is_finite() {
        return Err(EstimationError::new_err(format!(
            "the solver failed ({})",
            tag(&report.termination)
        )));
    }
    let motion = estimator.motion(&solution.params);
    let n = solution.free.len();
    let m: usize = solution.inliers().max(n + 1);
    let sigma2 = 2.0 * report.final_cost / (m - n) as f64;
    let cov = report
        .covariance(sigma2)
        .map(|c| Array2::from_shape_fn((n, n), |(r, k)| c[(r, k)]))
        .unwrap_or_else(|| Array2::zeros((0, 0)));
    let info = PyDict::new(py);
    info.set_item("param_names", names.to_vec())?;
    info.set_item("params", PyArray1::from_slice(py, &solution.params))?;
    info.set_item("free", solution.free.clone())?;
    info.set_item("initial_cost", report.initial_cost)?;
    info.set_item("final_cost", report.final_cost)?;
    info.set_item("iterations", report.iterations)?;
    info.set_item("termination", tag(&report.termination))?;
    info.set_item("matches", obs.len())?;
    info.set_item("inliers", solution.inliers())?;
    info.set_item("inliers_per_camera", solution.inliers_per_camera.clone())?;
    info.set_item("covariance", cov.into_pyarray(py))?;
    Ok((pose_to_py(py, &motion), info))
}

/// For measuring the binding's overhead: runs a fresh `Odometry(rig, config)` over the same
/// frame pair `repeats` times in Rust (no Python in the loop) and returns the seconds spent in
/// `Odometry::process` calls. Compare with a Python loop of `Odometry.process` on the same
/// input.
#[pyfunction]
#[pyo3(signature = (rig, config, matches, arc_length, repeats))]
pub fn native_process_loop(
    py: Python<'_>,
    rig: &Bound<'_, PyRig>,
    config: &Bound<'_, PyConfig>,
    matches: &Bound<'_, PyAny>,
    arc_length: Option<f64>,
    repeats: usize,
) -> PyResult<f64> {
    let rig = rig.get().inner.clone();
    let mut obs = FrameObservations::new(rig.len());
    fill_observations(&rig, matches, &mut obs)?;
    let mut vo = Odometry::new(rig, config.get().to_config()?).map_err(|e| vo_error(&e))?;
    Ok(py.detach(|| {
        let start = Instant::now();
        let mut sink = 0.0;
        for _ in 0..repeats {
            let r = vo.process(&obs, arc_length);
            sink += r.motion.translation.x;
        }
        let elapsed = start.elapsed().as_secs_f64();
        std::hint::black_box(sink);
        elapsed
    }))
}

//! The least-squares problem of one frame pair: a rig, its matches, a motion manifold, a
//! residual metric and a robust loss, differentiated through num-dual.

use crate::dyn_manifold::{DynManifold, ErasedScalar};
use crate::error::CoreError;
use crate::lie::{Pose, so3_log};
use crate::loss::RobustLoss;
use crate::manifold::{MAX_PRIOR_RESIDUALS, MotionPrior, ROTATION_PRIOR_CAUCHY};
use crate::metric::{KernelInputsKind, MAX_KERNEL_INPUTS, MAX_RESIDUALS, ResidualMetric};
use crate::rig::{FrameObservations, Rig};
use crate::scalar::Scalar;
use crate::solver::{LeastSquares, Linearization, MAX_PARAMS, NormalMatrix, ParamVec};
use nalgebra::{DMatrix, Matrix3, SMatrix, SVector, Vector3};
use num_dual::DualSVec64;
use std::cell::{OnceCell, RefCell};
use wide::f64x4;

/// The robust least-squares problem of one frame pair (the paper's Eq. for several cameras):
///
/// `min_p ½ Σ_j Σ_i ρ(|r(C_j(p), x_ij)|²)`, with camera motion `C_j = P_j⁻¹ M(p) P_j`,
/// plus, in units `s` of the data's noise ([`MotionPrior::scale`], by default the loss scale),
/// the soft manifold's prior residuals `½ Σ_k (s · κ_k · (q_k(p) − c_k))²`
/// ([`Manifold::prior_residuals`], centre `c` from [`MotionPrior::soft_center`], factors `κ`
/// from [`MotionPrior::soft_inv_scale`], 1 by default; a residual with a Cauchy scale `b_k`
/// from [`MotionPrior::soft_cauchy`] costs `½ s² b_k² ln(1 + (κ_k (q_k − c_k))² / b_k²)`
/// instead) and an
/// optional [`MotionPrior`] on the change of motion, per parameter
/// `½ Σ_i (s · (p_i − c_i) / σ_i)²` and on the rotation vector
/// `½ s² ρ(|(log R(p) − w_c) / σ_w|²)` (Cauchy `ρ`, the only robustified prior term).
///
/// Some parameters may be held fixed (the arc length from odometry); the solver sees only the
/// free ones. Residuals and Jacobians are evaluated with fixed-size dual numbers whose width is
/// the number of free parameters (monomorphised for 1..=8), with no heap allocation in the
/// per-match loop. A metric with a fused kernel ([`ResidualMetric::KERNEL_INPUTS`] `> 0`) is
/// instead differentiated on dual numbers only at its per-camera inputs, and its per-match
/// residuals and Jacobians are plain `f64` ([`Problem::with_automatic`] forces the dual path).
#[derive(Debug, Clone)]
pub struct Problem<'a, R: ResidualMetric> {
    /// The motion model, erased ([`DynManifold`]): one virtual call per evaluation.
    model: &'a dyn DynManifold,
    /// Its number of parameters.
    np: usize,
    /// Its number of prior residuals (a soft model's).
    n_prior: usize,
    metric: &'a R,
    loss: &'a dyn RobustLoss,
    rig: &'a Rig,
    obs: &'a FrameObservations,
    /// Full parameter vector; free entries are overwritten by the solver's `x`.
    full: [f64; MAX_PARAMS],
    /// Indices (into the full vector) of the free parameters.
    free: [usize; MAX_PARAMS],
    n_free: usize,
    /// The prior on the change of motion, if any.
    motion_prior: Option<&'a MotionPrior>,
    /// The unit `s` of the prior terms (the loss scale unless the motion prior names one).
    prior_scale: f64,
    /// Differentiate the per-match residuals on dual numbers even if the metric has a fused
    /// kernel (the oracle of the kernels' tests).
    automatic: bool,
    /// The squared residual norms `|r|²` of every match (camera order) at the last point
    /// whose cost was evaluated (by [`LeastSquares::cost`] or a linearisation), and that point:
    /// the inlier count after a solve reads them instead of evaluating the residuals again.
    last_norms: RefCell<(ParamVec, Vec<f64>)>,
    /// The metric's per-match constants ([`ResidualMetric::MATCH_CONSTANTS`] per match, camera
    /// order), computed at the first evaluation that needs them; never with `automatic`.
    constants: OnceCell<Vec<f64>>,
    /// The same, given by the caller ([`Problem::with_match_constants`]): read instead of
    /// `constants`.
    given_constants: Option<&'a [f64]>,
}

/// The metric's per-match constants ([`ResidualMetric::MATCH_CONSTANTS`] each) of every match
/// of `obs` on the cameras of `rig`, in camera order (what a [`Problem`] computes at its first
/// evaluation, or is given by [`Problem::with_match_constants`]); empty for a metric without any.
pub fn compute_match_constants<R: ResidualMetric>(
    metric: &R,
    rig: &Rig,
    obs: &FrameObservations,
) -> Vec<f64> {
    let m = R::MATCH_CONSTANTS;
    if m == 0 {
        return Vec::new();
    }
    let n: usize = obs.per_camera.iter().take(rig.len()).map(Vec::len).sum();
    // Filled match by match through a small buffer (no zeroed allocation of the whole).
    let mut c = Vec::with_capacity(m * n);
    let mut one = vec![0.0; m];
    for (j, cam) in rig.cameras().iter().enumerate() {
        let Some(obs) = obs.per_camera.get(j) else {
            continue;
        };
        for o in obs {
            metric.match_constants(&cam.model, o, &mut one);
            c.extend_from_slice(&one);
        }
    }
    c
}

/// Matches per step of the one-residual fused linearisation
/// (`Problem::linearize_kernel_lanes_n`): four `f64` lanes, two SSE2 registers on the baseline
/// x86-64 target (one AVX register where it is enabled).
const LANES: usize = 4;

/// The rotation prior's loss `ρ(z) = c² ln(1 + z / c²)` and its derivative `ρ'(z)`, with `c` =
/// [`ROTATION_PRIOR_CAUCHY`] and `z` the squared normalised rotation change.
fn rotation_prior_rho(z: f64) -> (f64, f64) {
    let c2 = ROTATION_PRIOR_CAUCHY * ROTATION_PRIOR_CAUCHY;
    (c2 * (z / c2).ln_1p(), 1.0 / (1.0 + z / c2))
}

/// A soft-prior residual's loss `ρ(z)` and weight `ρ'(z²)` at its scaled value `z`
/// ([`MotionPrior::soft_cauchy`]): `z²` and 1 for least squares (`b ≤ 0`), the Cauchy
/// `b² ln(1 + z² / b²)` and `1 / (1 + z² / b²)` otherwise.
fn soft_prior_rho(z: f64, b: f64) -> (f64, f64) {
    if b > 0.0 {
        let b2 = b * b;
        (b2 * (z * z / b2).ln_1p(), 1.0 / (1.0 + z * z / b2))
    } else {
        (z * z, 1.0)
    }
}

impl<'a, R: ResidualMetric> Problem<'a, R> {
    /// A problem with all parameters free, at `params` (the full vector of the model).
    pub fn new(
        model: &'a dyn DynManifold,
        metric: &'a R,
        loss: &'a dyn RobustLoss,
        rig: &'a Rig,
        obs: &'a FrameObservations,
        params: &[f64],
    ) -> Result<Self, CoreError> {
        let np = model.params().len();
        assert!(
            np <= MAX_PARAMS,
            "a model may have at most {MAX_PARAMS} parameters"
        );
        if params.len() != np {
            return Err(CoreError::ParameterCount {
                expected: np,
                got: params.len(),
            });
        }
        for (j, c) in rig.cameras().iter().enumerate() {
            let used = obs.per_camera.get(j).is_some_and(|o| !o.is_empty());
            if used {
                metric
                    .supports(&c.model)
                    .map_err(|reason| CoreError::UnsupportedCamera {
                        metric: std::any::type_name::<R>()
                            .rsplit("::")
                            .next()
                            .unwrap_or("metric")
                            .into(),
                        camera: j,
                        reason,
                    })?;
            }
        }
        let mut full = [0.0; MAX_PARAMS];
        full[..np].copy_from_slice(params);
        let mut free = [0; MAX_PARAMS];
        for (i, f) in free.iter_mut().enumerate().take(np) {
            *f = i;
        }
        Ok(Self {
            model,
            np,
            n_prior: model.prior_residual_count(),
            metric,
            loss,
            rig,
            obs,
            full,
            free,
            n_free: np,
            motion_prior: None,
            prior_scale: loss.scale(),
            automatic: false,
            last_norms: RefCell::new((ParamVec::repeat(f64::NAN), Vec::new())),
            constants: OnceCell::new(),
            given_constants: None,
        })
    }

    /// With the metric's per-match constants of every match given (camera order,
    /// [`ResidualMetric::MATCH_CONSTANTS`] each, as [`compute_match_constants`] computes them):
    /// the problem reads them instead of computing its own, so that several problems on the
    /// same matches, or on a subset of them (the subset's constants, in order), share one
    /// computation. An empty slice changes nothing (the problem computes them); a slice of
    /// another length is an error. The constants are exact, so a problem given them evaluates
    /// bit for bit as one that computes them ([`with_automatic`](Self::with_automatic) ignores
    /// them, as it ignores its own cache).
    pub fn with_match_constants(mut self, constants: &'a [f64]) -> Result<Self, CoreError> {
        if constants.is_empty() {
            return Ok(self);
        }
        let expected = R::MATCH_CONSTANTS * self.num_matches();
        if constants.len() != expected {
            return Err(CoreError::MatchConstantCount {
                expected,
                got: constants.len(),
            });
        }
        self.given_constants = Some(constants);
        Ok(self)
    }

    /// With `true`, linearises by automatic differentiation of
    /// [`ResidualMetric::residuals`] even if the metric has a fused kernel: the reference the
    /// kernels are tested against. Metrics without a kernel always take that path.
    pub fn with_automatic(mut self, automatic: bool) -> Self {
        self.automatic = automatic;
        self
    }

    /// Whether linearisations use the metric's fused kernel.
    pub fn uses_kernel(&self) -> bool {
        R::KERNEL_INPUTS > 0 && !self.automatic
    }

    /// The metric's per-match constants of every match (camera order,
    /// [`ResidualMetric::MATCH_CONSTANTS`] each), computed once per problem; empty for a
    /// metric without any and with [`with_automatic`](Self::with_automatic) (the oracle
    /// recomputes them in [`ResidualMetric::residuals`]).
    fn match_constants(&self) -> &[f64] {
        let m = R::MATCH_CONSTANTS;
        if m == 0 || self.automatic {
            return &[];
        }
        if let Some(c) = self.given_constants {
            return c;
        }
        self.constants
            .get_or_init(|| compute_match_constants(self.metric, self.rig, self.obs))
    }

    /// The residuals of match `k` (camera order) into `out`: by
    /// [`ResidualMetric::residuals_with`] from its cached constants `constants`
    /// ([`match_constants`](Self::match_constants)) if there are any, else by
    /// [`ResidualMetric::residuals`].
    #[inline(always)]
    fn match_residuals<T: Scalar>(
        &self,
        prep: &R::Prepared<T>,
        o: &crate::rig::Observation,
        constants: &[f64],
        k: usize,
        out: &mut [T],
    ) {
        let m = R::MATCH_CONSTANTS;
        if m > 0 && !constants.is_empty() {
            self.metric
                .residuals_with(prep, o, &constants[k * m..(k + 1) * m], out);
        } else {
            self.metric.residuals(prep, o, out);
        }
    }

    /// Adds a prior on the change of motion (ignored if it does not constrain anything; its
    /// per-parameter part is ignored if its vectors do not have the model's length). Its
    /// `scale`, if set, becomes the unit of every prior term, the soft manifold's included.
    pub fn with_motion_prior(mut self, prior: Option<&'a MotionPrior>) -> Self {
        if let Some(s) = prior.map(|p| p.scale).filter(|s| *s > 0.0 && s.is_finite()) {
            self.prior_scale = s;
        }
        self.motion_prior = prior.filter(|p| p.is_active());
        self
    }

    /// Whether the problem has terms besides the matches (soft manifold, motion prior).
    fn has_prior(&self) -> bool {
        self.n_prior > 0 || self.motion_prior.is_some()
    }

    /// The centre of the soft manifold's prior residuals (zeros unless the motion prior has
    /// one of the right length).
    fn soft_center(&self) -> [f64; MAX_PRIOR_RESIDUALS] {
        let mut c = [0.0; MAX_PRIOR_RESIDUALS];
        if let Some(mp) = self.motion_prior
            && mp.soft_center.len() == self.n_prior
        {
            c[..self.n_prior].copy_from_slice(&mp.soft_center);
        }
        c
    }

    /// The factors `k` on the soft manifold's centred prior residuals
    /// ([`MotionPrior::soft_inv_scale`]; ones unless the motion prior has them at the right
    /// length).
    fn soft_inv_scale(&self) -> [f64; MAX_PRIOR_RESIDUALS] {
        let mut k = [1.0; MAX_PRIOR_RESIDUALS];
        if let Some(mp) = self.motion_prior
            && mp.soft_inv_scale.len() == self.n_prior
        {
            k[..self.n_prior].copy_from_slice(&mp.soft_inv_scale);
        }
        k
    }

    /// The Cauchy scales of the soft manifold's prior residuals
    /// ([`MotionPrior::soft_cauchy`]; zeros, least squares, unless the motion prior has them at
    /// the right length).
    fn soft_cauchy(&self) -> [f64; MAX_PRIOR_RESIDUALS] {
        let mut b = [0.0; MAX_PRIOR_RESIDUALS];
        if let Some(mp) = self.motion_prior
            && mp.soft_cauchy.len() == self.n_prior
        {
            b[..self.n_prior].copy_from_slice(&mp.soft_cauchy);
        }
        b
    }

    /// The prior terms' cost `½ Σ (s q)²` at the full parameters `params` (plain `f64`).
    pub fn prior_cost(&self, params: &[f64]) -> f64 {
        if !self.has_prior() {
            return 0.0;
        }
        let s = self.prior_scale;
        let mut cost = 0.0;
        if self.n_prior > 0 {
            let mut q = [0.0; MAX_PRIOR_RESIDUALS];
            self.model
                .prior_residuals_of(params, &mut q[..self.n_prior]);
            let (c, k, b) = (
                self.soft_center(),
                self.soft_inv_scale(),
                self.soft_cauchy(),
            );
            cost += q[..self.n_prior]
                .iter()
                .zip(c)
                .zip(k)
                .zip(b)
                .map(|(((v, c), k), b)| {
                    if b > 0.0 {
                        0.5 * s * s * soft_prior_rho(k * (v - c), b).0
                    } else {
                        0.5 * (s * k * (v - c)) * (s * k * (v - c))
                    }
                })
                .sum::<f64>();
        }
        if let Some(mp) = self.motion_prior {
            if mp.has_params(self.np) {
                for i in 0..self.np {
                    let r = s * (params[i] - mp.center[i]) * mp.inv_sigma[i];
                    cost += 0.5 * r * r;
                }
            }
            if mp.rotation_inv_sigma != 0.0 {
                let w = so3_log(&self.model.motion_of(params).rotation);
                let z: f64 = (0..3)
                    .map(|a| ((w[a] - mp.rotation_center[a]) * mp.rotation_inv_sigma).powi(2))
                    .sum();
                cost += 0.5 * s * s * rotation_prior_rho(z).0;
            }
        }
        cost
    }

    /// Adds the prior terms' Gauss-Newton normal equations (they are plain least squares) for
    /// `N` free parameters; returns their cost. `motion` is the model's motion at `x` on the
    /// same dual numbers if the caller has it (else it is computed when the rotation prior
    /// needs it).
    fn linearize_prior_n<const N: usize>(
        &self,
        x: &ParamVec,
        motion: Option<&Pose<DualSVec64<N>>>,
        h: &mut SMatrix<f64, N, N>,
        g: &mut SVector<f64, N>,
    ) -> f64
    where
        DualSVec64<N>: ErasedScalar,
    {
        let s = self.prior_scale;
        let mut cost = 0.0;
        let p = self.seeded::<N>(x);
        if self.n_prior > 0 {
            let mut q = [DualSVec64::<N>::from_re(0.0); MAX_PRIOR_RESIDUALS];
            self.model
                .prior_residuals_of(&p[..self.np], &mut q[..self.n_prior]);
            let (k, b) = (self.soft_inv_scale(), self.soft_cauchy());
            for (((v, c), k), b) in q[..self.n_prior]
                .iter()
                .zip(self.soft_center())
                .zip(k)
                .zip(b)
            {
                let r = s * k * (v.re - c);
                if b > 0.0 {
                    // Iteratively reweighted: the Cauchy weight ρ'(z²) on the Gauss-Newton terms.
                    let (rho, weight) = soft_prior_rho(k * (v.re - c), b);
                    cost += 0.5 * s * s * rho;
                    if let Some(e) = &v.eps.0 {
                        let j = e * (s * k);
                        *h += j * j.transpose() * weight;
                        *g += j * (r * weight);
                    }
                } else {
                    cost += 0.5 * r * r;
                    if let Some(e) = &v.eps.0 {
                        let j = e * (s * k);
                        *h += j * j.transpose();
                        *g += j * r;
                    }
                }
            }
        }
        if let Some(mp) = self.motion_prior {
            if mp.has_params(self.np) {
                for i in 0..self.np {
                    let w = s * mp.inv_sigma[i];
                    let r = w * (p[i].re - mp.center[i]);
                    cost += 0.5 * r * r;
                    if let Some(k) = self.free[..self.n_free].iter().position(|&f| f == i) {
                        if k < N {
                            h[(k, k)] += w * w;
                            g[k] += w * r;
                        }
                    }
                }
            }
            if mp.rotation_inv_sigma != 0.0 {
                // Iteratively reweighted: the Cauchy weight ρ'(|d|²) on the Gauss-Newton terms.
                let w = match motion {
                    Some(m) => so3_log(&m.rotation),
                    None => so3_log(&self.model.motion_of(&p[..self.np]).rotation),
                };
                let k = mp.rotation_inv_sigma;
                let d: [f64; 3] = std::array::from_fn(|a| k * (w[a].re - mp.rotation_center[a]));
                let (rho, weight) = rotation_prior_rho(d.iter().map(|v| v * v).sum());
                cost += 0.5 * s * s * rho;
                let ws = s * s * weight;
                for a in 0..3 {
                    if let Some(e) = &w[a].eps.0 {
                        let j = e * k;
                        *h += j * j.transpose() * ws;
                        *g += j * (d[a] * ws);
                    }
                }
            }
        }
        cost
    }

    /// Holds the parameters with `fixed[i] == true` at their current values.
    pub fn with_fixed(mut self, fixed: &[bool]) -> Self {
        let np = self.np;
        self.n_free = 0;
        for i in 0..np {
            if !fixed.get(i).copied().unwrap_or(false) {
                self.free[self.n_free] = i;
                self.n_free += 1;
            }
        }
        self
    }

    /// The free parameters of the current full vector, as the solver's `x`.
    pub fn free_params(&self) -> ParamVec {
        let mut x = ParamVec::zeros();
        for k in 0..self.n_free {
            x[k] = self.full[self.free[k]];
        }
        x
    }

    /// The full parameter vector for the solver's `x`.
    pub fn full_params(&self, x: &ParamVec) -> Vec<f64> {
        let mut p = self.full;
        for k in 0..self.n_free {
            p[self.free[k]] = x[k];
        }
        p[..self.np].to_vec()
    }

    /// Indices of the free parameters in the full vector.
    pub fn free_indices(&self) -> &[usize] {
        &self.free[..self.n_free]
    }

    /// The number of matches the residuals are evaluated on (cameras of the rig only).
    pub fn num_matches(&self) -> usize {
        self.obs
            .per_camera
            .iter()
            .take(self.rig.len())
            .map(Vec::len)
            .sum()
    }

    /// Calls `f(camera, residual norm)` for every match at the full parameters `params`.
    pub fn for_each_residual_norm(&self, params: &[f64], mut f: impl FnMut(usize, f64)) {
        self.for_each_squared_norm(params, |j, s| f(j, s.sqrt()));
    }

    /// Like [`for_each_residual_norm`](Self::for_each_residual_norm) at the solver's `x`,
    /// reusing the residuals of the last evaluation if it was at `x` (the end of a solve: no
    /// second pass over the matches).
    pub fn for_each_residual_norm_at(&self, x: &ParamVec, mut f: impl FnMut(usize, f64)) {
        {
            let last = self.last_norms.borrow();
            if last.0 == *x && last.1.len() == self.num_matches() {
                let mut k = 0;
                for (j, obs) in self.obs.per_camera.iter().take(self.rig.len()).enumerate() {
                    for s in &last.1[k..k + obs.len()] {
                        f(j, s.sqrt());
                    }
                    k += obs.len();
                }
                return;
            }
        }
        let params = self.full_params(x);
        self.for_each_residual_norm(&params, f);
    }

    /// Starts recording the squared residual norms at `x` (see `last_norms`): a buffer of one
    /// entry per match, written in order through [`Recorder::put`].
    #[inline]
    fn record_norms(&self, x: &ParamVec) -> Recorder<'_> {
        let mut last = self.last_norms.borrow_mut();
        last.0 = *x;
        last.1.resize(self.num_matches(), f64::NAN);
        Recorder { last, at: 0 }
    }

    /// Calls `f(camera, |r|²)` for every match at the full parameters `params` (plain `f64`).
    fn for_each_squared_norm(&self, params: &[f64], mut f: impl FnMut(usize, f64)) {
        let m = self.model.motion_of(params);
        let mut r = [0.0; MAX_RESIDUALS];
        let constants = self.match_constants();
        let mut k = 0;
        for (j, cam) in self.rig.cameras().iter().enumerate() {
            let Some(obs) = self.obs.per_camera.get(j) else {
                continue;
            };
            if obs.is_empty() {
                continue;
            }
            let c = camera_motion(&m, &cam.t_vehicle_camera);
            let prep = self.metric.prepare(&cam.model, &c);
            for o in obs {
                self.match_residuals(&prep, o, constants, k, &mut r[..R::RESIDUALS]);
                k += 1;
                f(j, r[..R::RESIDUALS].iter().map(|v| v * v).sum::<f64>());
            }
        }
    }

    /// The raw (not robustified) residuals and their Jacobian with respect to the *free*
    /// parameters at the full parameters `params`, evaluated by automatic differentiation.
    /// Rows are matches x residuals, in camera order. For checks and covariances; the solver
    /// path uses [`LeastSquares::linearize`].
    pub fn residuals_and_jacobian(&self, params: &[f64]) -> (Vec<f64>, DMatrix<f64>) {
        let mut me = self.clone();
        me.full[..params.len()].copy_from_slice(params);
        let x = me.free_params();
        let mut res = Vec::new();
        let mut rows: Vec<[f64; MAX_PARAMS]> = Vec::new();
        macro_rules! go {
            ($n:literal) => {
                me.visit::<$n>(&x, |r: &[DualSVec64<$n>]| {
                    for v in r {
                        res.push(v.re);
                        let mut row = [0.0; MAX_PARAMS];
                        if let Some(e) = v.eps.0 {
                            row[..$n].copy_from_slice(e.as_slice());
                        }
                        rows.push(row);
                    }
                })
            };
        }
        match self.n_free {
            0 => go!(0),
            1 => go!(1),
            2 => go!(2),
            3 => go!(3),
            4 => go!(4),
            5 => go!(5),
            6 => go!(6),
            7 => go!(7),
            _ => go!(8),
        }
        let jac = DMatrix::from_fn(rows.len(), self.n_free, |i, k| rows[i][k]);
        (res, jac)
    }

    /// Builds the full parameter vector in dual numbers (free entries seeded) and calls `f` with
    /// the residuals of each match.
    #[inline(always)]
    fn visit<const N: usize>(&self, x: &ParamVec, mut f: impl FnMut(&[DualSVec64<N>]))
    where
        DualSVec64<N>: ErasedScalar,
    {
        let np = self.np;
        let p = self.seeded::<N>(x);
        let m = self.model.motion_of(&p[..np]);
        let mut r = [DualSVec64::<N>::from_re(0.0); MAX_RESIDUALS];
        let constants = self.match_constants();
        let mut k = 0;
        for (j, cam) in self.rig.cameras().iter().enumerate() {
            let Some(obs) = self.obs.per_camera.get(j) else {
                continue;
            };
            if obs.is_empty() {
                continue;
            }
            let c = camera_motion(&m, &cam.t_vehicle_camera);
            let prep = self.metric.prepare(&cam.model, &c);
            for o in obs {
                self.match_residuals(&prep, o, constants, k, &mut r[..R::RESIDUALS]);
                k += 1;
                f(&r[..R::RESIDUALS]);
            }
        }
    }

    /// The full parameter vector in dual numbers, the free entries seeded with their unit
    /// derivatives.
    #[inline(always)]
    fn seeded<const N: usize>(&self, x: &ParamVec) -> [DualSVec64<N>; MAX_PARAMS] {
        let np = self.np;
        let mut p = [DualSVec64::<N>::from_re(0.0); MAX_PARAMS];
        for i in 0..np {
            p[i] = DualSVec64::from_re(self.full[i]);
        }
        for k in 0..self.n_free.min(N) {
            p[self.free[k]] = DualSVec64::from_re(x[k]).derivative(k);
        }
        p
    }

    /// Robustified normal equations with `N` free parameters; with `known_cost` the loss is
    /// asked only for its weights (no `ρ`), and the cost is taken as given.
    fn linearize_n<const N: usize>(&self, x: &ParamVec, known_cost: Option<f64>) -> Linearization
    where
        DualSVec64<N>: ErasedScalar,
    {
        if self.uses_kernel() {
            return self.linearize_kernel_n::<N>(x, known_cost);
        }
        let mut h = SMatrix::<f64, N, N>::zeros();
        let mut g = SVector::<f64, N>::zeros();
        let mut cost = 0.0;
        let loss = self.loss;
        let mut last = self.record_norms(x);
        self.visit::<N>(x, |r| {
            let mut s = 0.0;
            for v in r {
                s += v.re * v.re;
            }
            last.put(s);
            let [rho1, rho2] = if known_cost.is_some() {
                loss.weights(s)
            } else {
                let [rho, rho1, rho2] = loss.evaluate(s);
                cost += 0.5 * rho;
                [rho1, rho2]
            };
            if rho1 <= 0.0 {
                return; // Tukey beyond its scale: no pull, no curvature.
            }
            let (sqrt_rho1, residual_scaling, alpha_sq_norm) = corrector(s, rho1, rho2);
            // rᵀJ (for the correction), then accumulate J̃ᵀJ̃ (upper triangle, mirrored below)
            // and J̃ᵀr̃, with plain loops over the N free parameters (the hot path).
            let mut rtj = [0.0; N];
            if alpha_sq_norm != 0.0 {
                for v in r {
                    if let Some(e) = &v.eps.0 {
                        for k in 0..N {
                            rtj[k] += e[k] * v.re;
                        }
                    }
                }
            }
            for v in r {
                let Some(e) = &v.eps.0 else { continue };
                let c = alpha_sq_norm * v.re;
                let mut jt = [0.0; N];
                for k in 0..N {
                    jt[k] = (e[k] - rtj[k] * c) * sqrt_rho1;
                }
                let gr = residual_scaling * v.re;
                for a in 0..N {
                    let ja = jt[a];
                    g[a] += ja * gr;
                    for b in a..N {
                        h[(a, b)] += ja * jt[b];
                    }
                }
            }
        });
        drop(last);
        self.finish_linearization(x, None, known_cost, cost, h, g)
    }

    /// The fused kernel's inputs `q(C_j(p))` and `dq/dp` of the camera with the extrinsic
    /// `mount` at the vehicle motion `m`: on plain arrays where the metric's inputs have a
    /// [`KernelInputsKind`] and every derivative of `m` is present
    /// ([`compose_const_arrays`], [`kernel_inputs_from_arrays`]), on dual numbers otherwise
    /// ([`camera_motion_dual`], [`split_kernel_inputs`](Self::split_kernel_inputs)); the same
    /// bits either way. Not inlined: once per camera, and inlined into the per-match loops it
    /// cost them more than it saved on a one-camera rig (callgrind, clean_pinhole +0.4 %).
    #[inline(never)]
    fn camera_kernel_inputs<const N: usize>(
        &self,
        camera: &crate::Camera,
        m: &Pose<DualSVec64<N>>,
        mount: &Pose<f64>,
        q_dual: &mut [DualSVec64<N>],
        q: &mut [f64],
        dq: &mut [[f64; N]],
    ) where
        DualSVec64<N>: ErasedScalar,
    {
        if R::KERNEL_INPUTS_KIND != KernelInputsKind::Custom
            && let Some(c) = compose_const_arrays(&mount.inverse(), m, mount)
        {
            kernel_inputs_from_arrays(R::KERNEL_INPUTS_KIND, &c, q, dq);
            return;
        }
        let c = camera_motion_dual(m, mount);
        self.split_kernel_inputs(camera, &c, q_dual, q, dq);
    }

    /// The metric's kernel inputs `q(C_j(p))` of one camera at its dual motion `c`, split into
    /// their values `q` and derivatives `dq/dp` over the `N` free parameters (`q_dual` is
    /// scratch of the inputs' length).
    #[inline(always)]
    fn split_kernel_inputs<const N: usize>(
        &self,
        camera: &crate::Camera,
        c: &Pose<DualSVec64<N>>,
        q_dual: &mut [DualSVec64<N>],
        q: &mut [f64],
        dq: &mut [[f64; N]],
    ) where
        DualSVec64<N>: ErasedScalar,
    {
        self.metric.kernel_inputs(camera, c, q_dual);
        for (i, v) in q_dual.iter().enumerate() {
            q[i] = v.re;
            dq[i] = match &v.eps.0 {
                Some(e) => std::array::from_fn(|k| e[k]),
                None => [0.0; N],
            };
        }
    }

    /// The fused path of `linearize_n` ([`ResidualMetric::KERNEL_INPUTS`] `> 0`): the
    /// kernel's per-camera inputs `q(C_j(p))` and `dq/dp` on dual numbers once per camera, then
    /// per match the metric's [`kernel`](ResidualMetric::kernel) in plain `f64`,
    /// `J = (dr/dq)(dq/dp)` and the same robust accumulation as the automatic path.
    fn linearize_kernel_n<const N: usize>(
        &self,
        x: &ParamVec,
        known_cost: Option<f64>,
    ) -> Linearization
    where
        DualSVec64<N>: ErasedScalar,
    {
        const {
            assert!(R::KERNEL_INPUTS <= MAX_KERNEL_INPUTS);
            assert!(R::RESIDUALS <= MAX_RESIDUALS);
        }
        if R::RESIDUALS == 1 {
            return self.linearize_kernel_lanes_n::<N>(x, known_cost);
        }
        let mut h = SMatrix::<f64, N, N>::zeros();
        let mut g = SVector::<f64, N>::zeros();
        let mut cost = 0.0;
        let p = self.seeded::<N>(x);
        let m = self.model.motion_of(&p[..self.np]);
        let mut last = self.record_norms(x);
        self.for_each_kernel_jacobian::<N>(&m, |r, jac| {
            last.put(accumulate_robust(
                self.loss,
                known_cost.is_some(),
                r,
                jac,
                &mut cost,
                &mut h,
                &mut g,
            ));
        });
        drop(last);
        self.finish_linearization(x, Some(&m), known_cost, cost, h, g)
    }

    /// The fused path for a metric with one residual per match (AnglePlane): the same sums as
    /// [`linearize_kernel_n`](Self::linearize_kernel_n), laid out across [`LANES`] matches at
    /// a time (structure of arrays) so that the Jacobian rows `J = (dr/dq)(dq/dp)` and the
    /// normal equations vectorise across matches; each lane accumulates its own share of
    /// `J̃ᵀJ̃` and `J̃ᵀr̃`, summed once at the end. The per-match Jacobian rows, weights and
    /// the cost are those of the per-match path bit for bit; only the order of the sums over
    /// the matches in the normal equations differs.
    fn linearize_kernel_lanes_n<const N: usize>(
        &self,
        x: &ParamVec,
        known_cost: Option<f64>,
    ) -> Linearization
    where
        DualSVec64<N>: ErasedScalar,
    {
        // Called only for `R::RESIDUALS == 1` (a const assert would fire on the other
        // metrics' monomorphisations of the caller).
        debug_assert_eq!(R::RESIDUALS, 1);
        let k_in = R::KERNEL_INPUTS;
        let mut cost = 0.0;
        let p = self.seeded::<N>(x);
        let m = self.model.motion_of(&p[..self.np]);
        let mut q_dual = [DualSVec64::<N>::from_re(0.0); MAX_KERNEL_INPUTS];
        let mut q = [0.0; MAX_KERNEL_INPUTS];
        let mut dq = [[0.0; N]; MAX_KERNEL_INPUTS];
        let mut r = [0.0; MAX_RESIDUALS];
        let mut dr_dq = [[0.0; MAX_KERNEL_INPUTS]; MAX_RESIDUALS];
        // Per lane: the upper triangle of J̃ᵀJ̃ (row-major, N (N + 1) / 2 entries) and J̃ᵀr̃.
        let mut h_lanes = [f64x4::ZERO; MAX_PARAMS * (MAX_PARAMS + 1) / 2];
        let mut g_lanes = [f64x4::ZERO; N];
        let constants = self.match_constants();
        let n_c = R::MATCH_CONSTANTS;
        let mut k_match = 0;
        let mut last = self.record_norms(x);
        let weights_only = known_cost.is_some();
        // The kernel's derivatives transposed into lanes: rows `0..k_in` are written in full
        // by every full chunk; a partial chunk zeroes its unused lanes first (they weigh zero),
        // so the array is cleared once per linearisation instead of once per chunk.
        let mut dr = [[0.0; LANES]; MAX_KERNEL_INPUTS];
        for (j, cam) in self.rig.cameras().iter().enumerate() {
            let Some(obs) = self.obs.per_camera.get(j) else {
                continue;
            };
            if obs.is_empty() {
                continue;
            }
            self.camera_kernel_inputs(
                &cam.model,
                &m,
                &cam.t_vehicle_camera,
                &mut q_dual[..k_in],
                &mut q,
                &mut dq,
            );
            for chunk in obs.chunks(LANES) {
                // The kernel per match, its derivatives transposed into lanes; unused lanes
                // are zero (and weigh zero).
                if chunk.len() < LANES {
                    for row in &mut dr[..k_in] {
                        row[chunk.len()..].fill(0.0);
                    }
                }
                // Per lane: the row's weight √ρ' (1 − α) and the weighted residual.
                let mut wj = [0.0; LANES];
                let mut wr = [0.0; LANES];
                // The kernel per match; the squared norms of the lanes.
                let mut v = [0.0; LANES];
                let mut sq = [0.0; LANES];
                for (l, o) in chunk.iter().enumerate() {
                    self.metric.kernel(
                        &cam.model,
                        &q[..k_in],
                        o,
                        &constants[k_match * n_c..(k_match + 1) * n_c],
                        &mut r[..1],
                        &mut dr_dq[..1],
                    );
                    k_match += 1;
                    for a in 0..k_in {
                        dr[a][l] = dr_dq[0][a];
                    }
                    v[l] = r[0];
                    sq[l] = r[0] * r[0];
                    last.put(sq[l]);
                }
                // The loss's weights of the lanes in one call (no virtual call per match);
                // unused lanes are evaluated at 0 and skipped below.
                let rho = if weights_only {
                    self.loss.weights_lanes(&sq).map(|[d1, d2]| [0.0, d1, d2])
                } else {
                    self.loss.evaluate_lanes(&sq)
                };
                for (l, &[rho0, rho1, rho2]) in rho.iter().enumerate().take(chunk.len()) {
                    if !weights_only {
                        cost += 0.5 * rho0;
                    }
                    if rho1 <= 0.0 {
                        continue; // Tukey beyond its scale: no pull, no curvature.
                    }
                    let s = sq[l];
                    let (sqrt_rho1, residual_scaling, alpha_sq_norm) = corrector(s, rho1, rho2);
                    // One residual: J̃ = (J − (rJ) α/s r) √ρ' = J (1 − α) √ρ' (exactly J √ρ'
                    // without the curvature term, as the per-match path).
                    wj[l] = if alpha_sq_norm != 0.0 {
                        (1.0 - alpha_sq_norm * s) * sqrt_rho1
                    } else {
                        sqrt_rho1
                    };
                    wr[l] = residual_scaling * v[l];
                }
                // J̃ rows across the lanes: the same sum over the inputs, in the same order, as
                // the per-match path.
                let mut jt = [f64x4::ZERO; N];
                for a in 0..k_in {
                    let d = f64x4::new(dr[a]);
                    for k in 0..N {
                        jt[k] += d * f64x4::splat(dq[a][k]);
                    }
                }
                let (wj, wr) = (f64x4::new(wj), f64x4::new(wr));
                for row in &mut jt {
                    *row *= wj;
                }
                let mut e = 0;
                for a in 0..N {
                    g_lanes[a] += jt[a] * wr;
                    for b in a..N {
                        h_lanes[e] += jt[a] * jt[b];
                        e += 1;
                    }
                }
            }
        }
        drop(last);
        let mut h = SMatrix::<f64, N, N>::zeros();
        let mut g = SVector::<f64, N>::zeros();
        let sum = |v: f64x4| {
            let v = v.to_array();
            (v[0] + v[1]) + (v[2] + v[3])
        };
        let mut e = 0;
        for a in 0..N {
            g[a] = sum(g_lanes[a]);
            for b in a..N {
                h[(a, b)] = sum(h_lanes[e]);
                e += 1;
            }
        }
        self.finish_linearization(x, Some(&m), known_cost, cost, h, g)
    }

    /// Mirrors the upper triangle of the normal matrix, adds the prior terms (with the motion
    /// at `x` if the caller has it) and packs the result.
    #[inline(always)]
    fn finish_linearization<const N: usize>(
        &self,
        x: &ParamVec,
        motion: Option<&Pose<DualSVec64<N>>>,
        known_cost: Option<f64>,
        mut cost: f64,
        mut h: SMatrix<f64, N, N>,
        mut g: SVector<f64, N>,
    ) -> Linearization
    where
        DualSVec64<N>: ErasedScalar,
    {
        for a in 0..N {
            for b in 0..a {
                h[(a, b)] = h[(b, a)];
            }
        }
        if self.has_prior() {
            let prior_cost = self.linearize_prior_n::<N>(x, motion, &mut h, &mut g);
            cost += prior_cost;
        }
        let mut out = Linearization {
            cost: known_cost.unwrap_or(cost),
            gradient: ParamVec::zeros(),
            hessian: NormalMatrix::zeros(),
        };
        out.hessian.fixed_view_mut::<N, N>(0, 0).copy_from(&h);
        out.gradient.fixed_rows_mut::<N>(0).copy_from(&g);
        out
    }
}

/// The data terms' exact robust normal equations of a [`Problem`], in total and per group of
/// matches ([`Problem::exact_data_terms_by_group`]).
#[derive(Clone, Debug)]
pub struct GroupedLinearization {
    /// All matches: `cost` `½ Σ ρ(|r|²)`, `gradient` `Σ ρ' Jᵀr`, `hessian` the exact robust
    /// `Σ ρ' JᵀJ + 2ρ'' (Jᵀr)(rᵀJ)` (over the free parameters; no prior terms).
    pub total: Linearization,
    /// Per labelling, per group: the same sums over the group's matches.
    pub groups: Vec<Vec<Linearization>>,
}

impl<R: ResidualMetric> Problem<'_, R> {
    /// The data terms' exact robust normal equations at the solver's `x` in one pass over the
    /// matches: each match's residuals `r` and Jacobian `J` (the fused kernel where the metric
    /// has one, else automatic differentiation) and the loss's `ρ, ρ', ρ''` at `|r|²` evaluated
    /// once, and its `½ρ`, gradient `ρ' Jᵀr` and exact robust Hessian
    /// `ρ' JᵀJ + 2ρ'' (Jᵀr)(rᵀJ)` (the Gauss-Newton Hessian of `½ρ(|r|²)`, negative curvature
    /// included; nothing where `ρ' <= 0`) added to the total and, for each labelling
    /// `(labels, groups)`, to the sums of group `labels[k]` of match `k` (camera order, as
    /// [`num_matches`](Self::num_matches) counts them; a label `>= groups` or a short `labels`:
    /// in no group of that labelling). The prior terms are not included. What
    /// `2 L(ρ) - L(ρ, max(-ρ'', 0))` of two [`LeastSquares::linearize`] calls per group gives
    /// for a loss with `ρ'' <= 0` (the leave-one-group-out influence of `momo-vo`'s jackknife),
    /// with the sums in another order.
    pub fn exact_data_terms_by_group(
        &self,
        x: &ParamVec,
        labellings: &[(&[usize], usize)],
    ) -> GroupedLinearization {
        match self.n_free {
            // No free parameter: zero derivatives (none seeded), the costs as they are.
            0 => self.exact_data_terms_n::<1>(x, labellings),
            1 => self.exact_data_terms_n::<1>(x, labellings),
            2 => self.exact_data_terms_n::<2>(x, labellings),
            3 => self.exact_data_terms_n::<3>(x, labellings),
            4 => self.exact_data_terms_n::<4>(x, labellings),
            5 => self.exact_data_terms_n::<5>(x, labellings),
            6 => self.exact_data_terms_n::<6>(x, labellings),
            7 => self.exact_data_terms_n::<7>(x, labellings),
            _ => self.exact_data_terms_n::<8>(x, labellings),
        }
    }

    /// [`exact_data_terms_by_group`](Self::exact_data_terms_by_group) for `N` free parameters.
    fn exact_data_terms_n<const N: usize>(
        &self,
        x: &ParamVec,
        labellings: &[(&[usize], usize)],
    ) -> GroupedLinearization
    where
        DualSVec64<N>: ErasedScalar,
    {
        /// One group's sums: cost, gradient, upper triangle of the Hessian.
        #[derive(Clone, Copy)]
        struct Sums<const N: usize> {
            cost: f64,
            g: SVector<f64, N>,
            h: SMatrix<f64, N, N>,
        }
        impl<const N: usize> Sums<N> {
            fn zero() -> Self {
                Self {
                    cost: 0.0,
                    g: SVector::zeros(),
                    h: SMatrix::zeros(),
                }
            }
            #[inline(always)]
            fn add(&mut self, cost: f64, g: &[f64; N], h: &[[f64; N]; N]) {
                self.cost += cost;
                for a in 0..N {
                    self.g[a] += g[a];
                    for b in a..N {
                        self.h[(a, b)] += h[a][b];
                    }
                }
            }
            fn finish(mut self) -> Linearization {
                for a in 0..N {
                    for b in 0..a {
                        self.h[(a, b)] = self.h[(b, a)];
                    }
                }
                let mut out = Linearization {
                    cost: self.cost,
                    gradient: ParamVec::zeros(),
                    hessian: NormalMatrix::zeros(),
                };
                out.hessian.fixed_view_mut::<N, N>(0, 0).copy_from(&self.h);
                out.gradient.fixed_rows_mut::<N>(0).copy_from(&self.g);
                out
            }
        }
        let mut total = Sums::<N>::zero();
        let mut groups: Vec<Vec<Sums<N>>> = labellings
            .iter()
            .map(|&(_, n)| vec![Sums::zero(); n])
            .collect();
        let loss = self.loss;
        let mut k_match = 0;
        self.for_each_match_jacobian::<N>(x, |r, jac| {
            let k = k_match;
            k_match += 1;
            let mut s = 0.0;
            for v in r {
                s += v * v;
            }
            let [rho, rho1, rho2] = loss.evaluate(s);
            let cost = 0.5 * rho;
            let mut g = [0.0; N];
            let mut h = [[0.0; N]; N];
            if rho1 > 0.0 {
                // Jᵀr, then ρ' JᵀJ + 2ρ'' (Jᵀr)(rᵀJ) (upper triangle) and ρ' Jᵀr.
                let mut jtr = [0.0; N];
                for (v, e) in r.iter().zip(jac) {
                    for a in 0..N {
                        jtr[a] += e[a] * v;
                    }
                }
                for e in jac {
                    for a in 0..N {
                        let ja = rho1 * e[a];
                        for b in a..N {
                            h[a][b] += ja * e[b];
                        }
                    }
                }
                let c = 2.0 * rho2;
                for a in 0..N {
                    g[a] = rho1 * jtr[a];
                    for b in a..N {
                        h[a][b] += c * jtr[a] * jtr[b];
                    }
                }
            }
            total.add(cost, &g, &h);
            for ((labels, _), sums) in labellings.iter().zip(&mut groups) {
                if let Some(group) = labels.get(k).and_then(|&c| sums.get_mut(c)) {
                    group.add(cost, &g, &h);
                }
            }
        });
        GroupedLinearization {
            total: total.finish(),
            groups: groups
                .into_iter()
                .map(|g| g.into_iter().map(Sums::finish).collect())
                .collect(),
        }
    }

    /// Calls `f(r, J)` with every match's residuals and their Jacobian rows over the `N` free
    /// parameters at the solver's `x` (camera order): the fused kernel's
    /// `J = (dr/dq)(dq/dp)` where the metric has one (as [`LeastSquares::linearize`] computes
    /// them), else automatic differentiation.
    fn for_each_match_jacobian<const N: usize>(
        &self,
        x: &ParamVec,
        mut f: impl FnMut(&[f64], &[[f64; N]]),
    ) where
        DualSVec64<N>: ErasedScalar,
    {
        let n_res = R::RESIDUALS;
        let mut r = [0.0; MAX_RESIDUALS];
        let mut jac = [[0.0; N]; MAX_RESIDUALS];
        if !self.uses_kernel() {
            self.visit::<N>(x, |rd| {
                for (i, v) in rd.iter().enumerate() {
                    r[i] = v.re;
                    jac[i] = match &v.eps.0 {
                        Some(e) => std::array::from_fn(|k| e[k]),
                        None => [0.0; N],
                    };
                }
                f(&r[..n_res], &jac[..n_res]);
            });
            return;
        }
        let p = self.seeded::<N>(x);
        let m = self.model.motion_of(&p[..self.np]);
        self.for_each_kernel_jacobian::<N>(&m, f);
    }

    /// The fused kernel's per-match residuals `r` and Jacobian rows `J = (dr/dq)(dq/dp)` at the
    /// vehicle motion `m` (on dual numbers over the `N` free parameters), passed to `f` in
    /// camera order: the kernel's inputs `q(C_j(m))` and `dq/dp` once per camera, then the
    /// metric's [`kernel`](ResidualMetric::kernel) per match in plain `f64`. One loop for
    /// [`linearize_kernel_n`](Self::linearize_kernel_n) and
    /// [`for_each_match_jacobian`](Self::for_each_match_jacobian).
    fn for_each_kernel_jacobian<const N: usize>(
        &self,
        m: &Pose<DualSVec64<N>>,
        mut f: impl FnMut(&[f64], &[[f64; N]]),
    ) where
        DualSVec64<N>: ErasedScalar,
    {
        let k_in = R::KERNEL_INPUTS;
        let n_res = R::RESIDUALS;
        let mut r = [0.0; MAX_RESIDUALS];
        let mut jac = [[0.0; N]; MAX_RESIDUALS];
        let mut q_dual = [DualSVec64::<N>::from_re(0.0); MAX_KERNEL_INPUTS];
        let mut q = [0.0; MAX_KERNEL_INPUTS];
        let mut dq = [[0.0; N]; MAX_KERNEL_INPUTS];
        let mut dr_dq = [[0.0; MAX_KERNEL_INPUTS]; MAX_RESIDUALS];
        let constants = self.match_constants();
        let n_c = R::MATCH_CONSTANTS;
        let mut k_match = 0;
        for (j, cam) in self.rig.cameras().iter().enumerate() {
            let Some(obs) = self.obs.per_camera.get(j) else {
                continue;
            };
            if obs.is_empty() {
                continue;
            }
            self.camera_kernel_inputs(
                &cam.model,
                m,
                &cam.t_vehicle_camera,
                &mut q_dual[..k_in],
                &mut q,
                &mut dq,
            );
            for o in obs {
                self.metric.kernel(
                    &cam.model,
                    &q[..k_in],
                    o,
                    &constants[k_match * n_c..(k_match + 1) * n_c],
                    &mut r[..n_res],
                    &mut dr_dq[..n_res],
                );
                k_match += 1;
                for i in 0..n_res {
                    let mut row = [0.0; N];
                    for a in 0..k_in {
                        let d = dr_dq[i][a];
                        for k in 0..N {
                            row[k] += d * dq[a][k];
                        }
                    }
                    jac[i] = row;
                }
                f(&r[..n_res], &jac[..n_res]);
            }
        }
    }
}

impl<R: ResidualMetric> LeastSquares for Problem<'_, R> {
    fn num_params(&self) -> usize {
        self.n_free
    }

    fn cost(&self, x: &ParamVec) -> f64 {
        let mut p = self.full;
        for k in 0..self.n_free {
            p[self.free[k]] = x[k];
        }
        let mut cost = 0.0;
        let mut last = self.record_norms(x);
        self.for_each_squared_norm(&p[..self.np], |_, s| {
            last.put(s);
            cost += 0.5 * self.loss.rho(s);
        });
        cost + self.prior_cost(&p[..self.np])
    }

    fn linearize(&self, x: &ParamVec) -> Linearization {
        self.linearize_dispatch(x, None)
    }

    fn linearize_known_cost(&self, x: &ParamVec, cost: f64) -> Linearization {
        self.linearize_dispatch(x, Some(cost))
    }
}

impl<R: ResidualMetric> Problem<'_, R> {
    /// Monomorphises the linearisation for the number of free parameters.
    fn linearize_dispatch(&self, x: &ParamVec, known_cost: Option<f64>) -> Linearization {
        match self.n_free {
            0 => Linearization {
                cost: known_cost.unwrap_or_else(|| self.cost(x)),
                gradient: ParamVec::zeros(),
                hessian: NormalMatrix::zeros(),
            },
            1 => self.linearize_n::<1>(x, known_cost),
            2 => self.linearize_n::<2>(x, known_cost),
            3 => self.linearize_n::<3>(x, known_cost),
            4 => self.linearize_n::<4>(x, known_cost),
            5 => self.linearize_n::<5>(x, known_cost),
            6 => self.linearize_n::<6>(x, known_cost),
            7 => self.linearize_n::<7>(x, known_cost),
            _ => self.linearize_n::<8>(x, known_cost),
        }
    }
}

/// Writes the squared residual norms of one evaluation into `Problem::last_norms`, in match
/// order.
struct Recorder<'a> {
    last: std::cell::RefMut<'a, (ParamVec, Vec<f64>)>,
    at: usize,
}

impl Recorder<'_> {
    /// Records the next match's `|r|²`.
    #[inline(always)]
    fn put(&mut self, s: f64) {
        if let Some(v) = self.last.1.get_mut(self.at) {
            *v = s;
        }
        self.at += 1;
    }
}

/// Adds one match's robustified Gauss-Newton terms (upper triangle of `h`) for residuals `r`
/// with Jacobian rows `jac` (plain `f64`), as the automatic path does: the loss's weights
/// `ρ'`, `ρ''` at `s = |r|²` with Ceres' corrector (Triggs et al.); with `weights_only` the
/// loss is not asked for `ρ` and `cost` is left alone. Returns `s`.
#[inline(always)]
fn accumulate_robust<const N: usize>(
    loss: &dyn RobustLoss,
    weights_only: bool,
    r: &[f64],
    jac: &[[f64; N]],
    cost: &mut f64,
    h: &mut SMatrix<f64, N, N>,
    g: &mut SVector<f64, N>,
) -> f64 {
    let mut s = 0.0;
    for v in r {
        s += v * v;
    }
    let [rho1, rho2] = if weights_only {
        loss.weights(s)
    } else {
        let [rho, rho1, rho2] = loss.evaluate(s);
        *cost += 0.5 * rho;
        [rho1, rho2]
    };
    if rho1 <= 0.0 {
        return s;
    }
    let (sqrt_rho1, residual_scaling, alpha_sq_norm) = corrector(s, rho1, rho2);
    let mut rtj = [0.0; N];
    if alpha_sq_norm != 0.0 {
        for (v, e) in r.iter().zip(jac) {
            for k in 0..N {
                rtj[k] += e[k] * v;
            }
        }
    }
    for (v, e) in r.iter().zip(jac) {
        let c = alpha_sq_norm * v;
        let mut jt = [0.0; N];
        for k in 0..N {
            jt[k] = (e[k] - rtj[k] * c) * sqrt_rho1;
        }
        let gr = residual_scaling * v;
        for a in 0..N {
            let ja = jt[a];
            g[a] += ja * gr;
            for b in a..N {
                h[(a, b)] += ja * jt[b];
            }
        }
    }
    s
}

/// The camera motion `C_j = P_j⁻¹ M P_j` of a camera with extrinsic `P_j = T_vehicle_camera`
/// for the vehicle motion `M` (`DESIGN.md`).
///
/// The extrinsic stays plain `f64`: on dual numbers each product with one of its entries scales
/// the derivative part by a constant instead of going through a lifted constant (same sums in
/// the same order as the lifted composition, so the result is bit-identical to it).
#[inline]
pub fn camera_motion<T: Scalar>(vehicle_motion: &Pose<T>, t_vehicle_camera: &Pose<f64>) -> Pose<T> {
    compose_const(
        &t_vehicle_camera.inverse(),
        vehicle_motion,
        t_vehicle_camera,
    )
}

/// The camera motion `C_ij = P_i⁻¹ M P_j` of a cross-camera match ([`CrossObservation`]): the
/// pose of camera j at frame k in camera i at frame k-1.
///
/// [`CrossObservation`]: crate::CrossObservation
#[inline]
pub fn cross_camera_motion<T: Scalar>(
    vehicle_motion: &Pose<T>,
    t_vehicle_camera_i: &Pose<f64>,
    t_vehicle_camera_j: &Pose<f64>,
) -> Pose<T> {
    compose_const(
        &t_vehicle_camera_i.inverse(),
        vehicle_motion,
        t_vehicle_camera_j,
    )
}

/// [`camera_motion`] on dual numbers (the linearisations' per-camera motion): the same
/// composition `C_j = P_j⁻¹ M P_j` on plain arrays of values and derivatives.
///
/// Bit-identical to [`camera_motion`]: num-dual multiplies a dual number by a constant entry
/// by entry (`re c`, `eps_k c`) and adds two of them entry by entry where both carry a
/// derivative, and adding the lifted constant `t_A` leaves the derivative as it is; the sums
/// here are those of [`compose_const`] in the same order. Where an entry of `M` has no
/// derivative (num-dual's `None`, which a sum skips instead of adding zeros), the generic
/// path is taken.
#[inline]
fn camera_motion_dual<const N: usize>(
    vehicle_motion: &Pose<DualSVec64<N>>,
    t_vehicle_camera: &Pose<f64>,
) -> Pose<DualSVec64<N>> {
    compose_const_dual(
        &t_vehicle_camera.inverse(),
        vehicle_motion,
        t_vehicle_camera,
    )
}

/// A camera motion `C` as plain arrays: the values and derivatives of `R_C` (row, column) and
/// `t_C` ([`compose_const_arrays`]).
struct MotionArrays<const N: usize> {
    rv: [[f64; 3]; 3],
    rd: [[[f64; N]; 3]; 3],
    tv: [f64; 3],
    td: [[f64; N]; 3],
}

/// [`compose_const`] for `M` on dual numbers with every derivative present, on plain arrays
/// (see [`camera_motion_dual`]); `None` where an entry of `M` has no derivative.
#[inline]
fn compose_const_arrays<const N: usize>(
    a: &Pose<f64>,
    m: &Pose<DualSVec64<N>>,
    b: &Pose<f64>,
) -> Option<MotionArrays<N>> {
    let mut rv = [[0.0; 3]; 3];
    let mut rd = [[[0.0; N]; 3]; 3];
    let mut tv = [0.0; 3];
    let mut td = [[0.0; N]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let e = &m.rotation[(i, j)];
            let d = e.eps.0.as_ref()?;
            rv[i][j] = e.re;
            rd[i][j] = std::array::from_fn(|k| d[k]);
        }
        let e = &m.translation[i];
        let d = e.eps.0.as_ref()?;
        tv[i] = e.re;
        td[i] = std::array::from_fn(|k| d[k]);
    }
    let (ra, rb, tb) = (&a.rotation, &b.rotation, &b.translation);
    // R_M R_B.
    let mut mbv = [[0.0; 3]; 3];
    let mut mbd = [[[0.0; N]; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let (c0, c1, c2) = (rb[(0, j)], rb[(1, j)], rb[(2, j)]);
            mbv[i][j] = rv[i][0] * c0 + rv[i][1] * c1 + rv[i][2] * c2;
            for k in 0..N {
                mbd[i][j][k] = rd[i][0][k] * c0 + rd[i][1][k] * c1 + rd[i][2][k] * c2;
            }
        }
    }
    // R_M t_B + t_M.
    let mut mtv = [0.0; 3];
    let mut mtd = [[0.0; N]; 3];
    for i in 0..3 {
        mtv[i] = (rv[i][0] * tb.x + rv[i][1] * tb.y + rv[i][2] * tb.z) + tv[i];
        for k in 0..N {
            mtd[i][k] = (rd[i][0][k] * tb.x + rd[i][1][k] * tb.y + rd[i][2][k] * tb.z) + td[i][k];
        }
    }
    // R_A (...) and R_A (...) + t_A (a constant: the derivative stays).
    let mut c = MotionArrays {
        rv: [[0.0; 3]; 3],
        rd: [[[0.0; N]; 3]; 3],
        tv: [0.0; 3],
        td: [[0.0; N]; 3],
    };
    for i in 0..3 {
        let (c0, c1, c2) = (ra[(i, 0)], ra[(i, 1)], ra[(i, 2)]);
        for j in 0..3 {
            c.rv[i][j] = mbv[0][j] * c0 + mbv[1][j] * c1 + mbv[2][j] * c2;
            for k in 0..N {
                c.rd[i][j][k] = mbd[0][j][k] * c0 + mbd[1][j][k] * c1 + mbd[2][j][k] * c2;
            }
        }
        c.tv[i] = (mtv[0] * c0 + mtv[1] * c1 + mtv[2] * c2) + a.translation[i];
        for k in 0..N {
            c.td[i][k] = mtd[0][k] * c0 + mtd[1][k] * c1 + mtd[2][k] * c2;
        }
    }
    Some(c)
}

/// [`compose_const`] for `M` on dual numbers, through [`compose_const_arrays`] where every
/// derivative is present.
#[inline]
fn compose_const_dual<const N: usize>(
    a: &Pose<f64>,
    m: &Pose<DualSVec64<N>>,
    b: &Pose<f64>,
) -> Pose<DualSVec64<N>> {
    let Some(c) = compose_const_arrays(a, m, b) else {
        return compose_const(a, m, b);
    };
    let dual = |re: f64, d: &[f64; N]| {
        DualSVec64::<N>::new(re, num_dual::Derivative::some(SVector::from(*d)))
    };
    Pose::new(
        Matrix3::from_fn(|i, j| dual(c.rv[i][j], &c.rd[i][j])),
        Vector3::from_fn(|i, _| dual(c.tv[i], &c.td[i])),
    )
}

/// The fused kernel's inputs `q` and `dq/dp` of a [`KernelInputsKind`] other than `Custom`
/// from the camera motion's arrays: what [`ResidualMetric::kernel_inputs`] gives on dual
/// numbers, bit for bit. The essential matrix as [`essential`](crate::metric::essential)
/// computes it: num-dual's product `x y` is `(x.re y.re, x.eps y.re + y.eps x.re)`, the
/// negation negates both parts, the sum adds them entry by entry.
#[inline]
fn kernel_inputs_from_arrays<const N: usize>(
    kind: KernelInputsKind,
    c: &MotionArrays<N>,
    q: &mut [f64],
    dq: &mut [[f64; N]],
) {
    match kind {
        KernelInputsKind::Rotation => {
            for a in 0..3 {
                for b in 0..3 {
                    q[3 * a + b] = c.rv[a][b];
                    dq[3 * a + b] = c.rd[a][b];
                }
            }
        }
        KernelInputsKind::Essential => {
            // (value, derivative) of t and of -t.
            let t = |i: usize| (c.tv[i], c.td[i]);
            let neg = |i: usize| (-c.tv[i], c.td[i].map(|v| -v));
            let r = |i: usize, j: usize| (c.rv[i][j], c.rd[i][j]);
            // x0 y0 + x1 y1 on (value, derivative) pairs.
            let two = |(x0, dx0): (f64, [f64; N]),
                       (y0, dy0): (f64, [f64; N]),
                       (x1, dx1): (f64, [f64; N]),
                       (y1, dy1): (f64, [f64; N])| {
                let v = x0 * y0 + x1 * y1;
                let d: [f64; N] = std::array::from_fn(|k| {
                    (dx0[k] * y0 + dy0[k] * x0) + (dx1[k] * y1 + dy1[k] * x1)
                });
                (v, d)
            };
            for a in 0..3 {
                for b in 0..3 {
                    // [t]_x = [[0, -t_z, t_y], [t_z, 0, -t_x], [-t_y, t_x, 0]]; E_ab = Σ_k R_ka [t]_x,kb.
                    let (v, d) = match b {
                        0 => two(r(1, a), t(2), r(2, a), neg(1)),
                        1 => two(r(0, a), neg(2), r(2, a), t(0)),
                        _ => two(r(0, a), t(1), r(1, a), neg(0)),
                    };
                    q[3 * a + b] = v;
                    dq[3 * a + b] = d;
                }
            }
        }
        KernelInputsKind::Custom => {
            unreachable!("custom kernel inputs are computed on dual numbers")
        }
    }
}

/// `A M B` for constant poses `A`, `B` and a pose `M` of scalars, without lifting `A` and `B`:
/// `R = R_A (R_M R_B)`, `t = R_A (R_M t_B + t_M) + t_A`, every matrix product summed as
/// nalgebra's (`(x_0 y_0 + x_1 y_1) + x_2 y_2`).
#[inline]
fn compose_const<T: Scalar>(a: &Pose<f64>, m: &Pose<T>, b: &Pose<f64>) -> Pose<T> {
    let rm = &m.rotation;
    let rb = &b.rotation;
    let ra = &a.rotation;
    // R_M R_B and R_M t_B + t_M.
    let mb = Matrix3::from_fn(|i, j| {
        rm[(i, 0)] * rb[(0, j)] + rm[(i, 1)] * rb[(1, j)] + rm[(i, 2)] * rb[(2, j)]
    });
    let tb = &b.translation;
    let mt = Vector3::from_fn(|i, _| {
        (rm[(i, 0)] * tb.x + rm[(i, 1)] * tb.y + rm[(i, 2)] * tb.z) + m.translation[i]
    });
    // R_A (...) and R_A (...) + t_A.
    let rotation = Matrix3::from_fn(|i, j| {
        mb[(0, j)] * ra[(i, 0)] + mb[(1, j)] * ra[(i, 1)] + mb[(2, j)] * ra[(i, 2)]
    });
    let translation = Vector3::from_fn(|i, _| {
        (mt.x * ra[(i, 0)] + mt.y * ra[(i, 1)] + mt.z * ra[(i, 2)]) + T::c(a.translation[i])
    });
    Pose::new(rotation, translation)
}

/// Ceres' Corrector (Triggs et al.) of a robustified residual block with squared norm `s` and
/// loss derivatives `ρ' > 0`, `ρ''`: `(√ρ', residual scaling, α / s)`. With `ρ'' > 0` the
/// curvature term is added; with `ρ'' ≤ 0` it is dropped (iteratively re-weighted least
/// squares; keeping a clamped negative curvature was tried and took more iterations on KITTI
/// 00: 13 vs 7.75). Shared by the automatic and the fused per-match loops.
#[inline(always)]
fn corrector(s: f64, rho1: f64, rho2: f64) -> (f64, f64, f64) {
    let sqrt_rho1 = rho1.sqrt();
    if s == 0.0 || rho2 <= 0.0 {
        (sqrt_rho1, sqrt_rho1, 0.0)
    } else {
        let d = 1.0 + 2.0 * s * rho2 / rho1;
        let alpha = 1.0 - d.sqrt();
        (sqrt_rho1, sqrt_rho1 / (1.0 - alpha), alpha / s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lie::so3_exp;
    use proptest::prelude::*;

    /// The composition with the extrinsics lifted to dual numbers (the reference).
    fn lifted<T: Scalar>(m: &Pose<T>, a: &Pose<f64>, b: &Pose<f64>) -> Pose<T> {
        Pose::<T>::lift(a).compose(&m.compose(&Pose::<T>::lift(b)))
    }

    fn pose(w: [f64; 3], t: [f64; 3]) -> Pose<f64> {
        Pose::new(so3_exp(&Vector3::from(w)), Vector3::from(t))
    }

    fn bits(p: &Pose<DualSVec64<6>>) -> Vec<u64> {
        let mut out = Vec::new();
        for v in p.rotation.iter().chain(p.translation.iter()) {
            out.push(v.re.to_bits());
            match &v.eps.0 {
                Some(e) => out.extend(e.iter().map(|x| x.to_bits())),
                None => out.push(u64::MAX),
            }
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// `camera_motion` and `cross_camera_motion` with plain `f64` extrinsics are
        /// bit-identical (values and derivatives) to the lifted composition.
        #[test]
        fn constant_extrinsics_are_bit_identical_to_lifted(
            wm in proptest::array::uniform3(-2.0..2.0f64),
            tm in proptest::array::uniform3(-5.0..5.0f64),
            wi in proptest::array::uniform3(-3.0..3.0f64),
            ti in proptest::array::uniform3(-2.0..2.0f64),
            wj in proptest::array::uniform3(-3.0..3.0f64),
            tj in proptest::array::uniform3(-2.0..2.0f64),
            seed in proptest::array::uniform6(-1.0..1.0f64),
        ) {
            // A dual motion whose derivatives are arbitrary (not unit seeds).
            let m0 = pose(wm, tm);
            let m = Pose::new(
                m0.rotation.map(|v| {
                    let mut d = DualSVec64::<6>::from_re(v);
                    d.eps = num_dual::Derivative::some(SVector::from(seed) * v);
                    d
                }),
                m0.translation.map(|v| DualSVec64::<6>::from_re(v).derivative(2)),
            );
            let (pi, pj) = (pose(wi, ti), pose(wj, tj));
            let fast = camera_motion(&m, &pj);
            let slow = lifted(&m, &pj.inverse(), &pj);
            prop_assert_eq!(bits(&fast), bits(&slow));
            let fast = cross_camera_motion(&m, &pi, &pj);
            let slow = lifted(&m, &pi.inverse(), &pj);
            prop_assert_eq!(bits(&fast), bits(&slow));
            // And on plain f64.
            let f = camera_motion(&m0, &pj);
            let s = lifted(&m0, &pj.inverse(), &pj);
            prop_assert_eq!(f, s);
            // The essential matrix written out is bit-identical to `Rᵀ [t]_x` by nalgebra.
            let c = cross_camera_motion(&m, &pi, &pj);
            let e = crate::metric::essential(&c);
            let e_ref = c.rotation.transpose() * crate::lie::hat(&c.translation);
            let as_pose = |r| Pose::new(r, Vector3::repeat(DualSVec64::<6>::from_re(0.0)));
            prop_assert_eq!(bits(&as_pose(e)), bits(&as_pose(e_ref)));
            let e = crate::metric::essential(&m0);
            prop_assert_eq!(e, m0.rotation.transpose() * crate::lie::hat(&m0.translation));
        }

        /// `camera_motion_dual` (plain arrays) is bit-identical to `camera_motion` on dual
        /// numbers: arbitrary derivatives with exact and signed zeros, and an entry without a
        /// derivative (the generic path).
        #[test]
        fn camera_motion_on_arrays_is_bit_identical(
            wm in proptest::array::uniform3(-2.0..2.0f64),
            tm in proptest::array::uniform3(-5.0..5.0f64),
            wj in proptest::array::uniform3(-3.0..3.0f64),
            tj in proptest::array::uniform3(-2.0..2.0f64),
            seed in proptest::array::uniform6(-1.0..1.0f64),
            zeros in proptest::array::uniform12(0usize..4),
            none in 0usize..24,
        ) {
            let m0 = pose(wm, tm);
            let entry = |k: usize, v: f64| {
                let mut d = DualSVec64::<6>::from_re(v);
                // 0: arbitrary, 1: exact zeros, 2: negative zeros, 3: mixed signs of zero.
                let e: [f64; 6] = match zeros[k] {
                    0 => std::array::from_fn(|i| seed[i] * v + i as f64 * 0.1),
                    1 => [0.0; 6],
                    2 => [-0.0; 6],
                    _ => std::array::from_fn(|i| if i % 2 == 0 { -0.0 } else { seed[i] }),
                };
                d.eps = num_dual::Derivative::some(SVector::from(e));
                if k == none {
                    d.eps = num_dual::Derivative::none();
                }
                d
            };
            let m = Pose::new(
                Matrix3::from_fn(|i, j| entry(3 * i + j, m0.rotation[(i, j)])),
                Vector3::from_fn(|i, _| entry(9 + i, m0.translation[i])),
            );
            let pj = pose(wj, tj);
            prop_assert_eq!(bits(&camera_motion_dual(&m, &pj)), bits(&camera_motion(&m, &pj)));
            // The kernel inputs from the arrays: the rotation and the essential matrix as on
            // dual numbers.
            if let Some(c) = compose_const_arrays(&pj.inverse(), &m, &pj) {
                let dual = camera_motion(&m, &pj);
                let e = crate::metric::essential(&dual);
                for (kind, want) in [
                    (KernelInputsKind::Rotation, dual.rotation),
                    (KernelInputsKind::Essential, e),
                ] {
                    let mut q = [0.0; 9];
                    let mut dq = [[0.0; 6]; 9];
                    kernel_inputs_from_arrays(kind, &c, &mut q, &mut dq);
                    for a in 0..3 {
                        for b in 0..3 {
                            let w = &want[(a, b)];
                            prop_assert_eq!(q[3 * a + b].to_bits(), w.re.to_bits());
                            let wd = w.eps.0.as_ref().expect("a derivative");
                            for k in 0..6 {
                                prop_assert_eq!(dq[3 * a + b][k].to_bits(), wd[k].to_bits());
                            }
                        }
                    }
                }
            } else {
                prop_assert!(none < 12, "arrays refused with every derivative present");
            }
        }
    }
}

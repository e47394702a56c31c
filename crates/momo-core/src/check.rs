//! Public checks that automatic differentiation agrees with finite differences (central
//! differences at steps `h` and `h/2`, Richardson-extrapolated), for a researcher's own model,
//! metric or loss (like factrs's `test_variable!`). Our own property tests use these; so does
//! `examples/custom_model.rs`.

use crate::lie::Pose;
use crate::loss::RobustLoss;
use crate::manifold::Manifold;
use crate::metric::ResidualMetric;
use crate::problem::Problem;
use crate::rig::{FrameObservations, Rig};
use crate::scalar::Scalar;
use num_dual::DualSVec64;
use thiserror::Error;

/// Where automatic and numeric derivatives disagree.
#[derive(Debug, Error, Clone, PartialEq)]
#[error(
    "derivative mismatch at {what} (row {row}, column {col}): AD {ad:.12e}, finite differences {fd:.12e}, error {error:.3e} > {tolerance:.1e}"
)]
pub struct JacobianMismatch {
    /// What was checked.
    pub what: String,
    /// Row (residual or output entry).
    pub row: usize,
    /// Column (parameter).
    pub col: usize,
    /// The AD value.
    pub ad: f64,
    /// The finite-difference value.
    pub fd: f64,
    /// `|ad - fd| / max(1, |fd|)`.
    pub error: f64,
    /// The tolerance it broke.
    pub tolerance: f64,
}

fn step(x: f64) -> f64 {
    1e-6 * x.abs().max(1.0)
}

/// The derivative of every output of `f` with respect to `params[col]`: central differences at
/// steps `h` and `h/2` ([`step`]) combined by Richardson extrapolation,
/// `(4 D(h/2) − D(h)) / 3`, which cancels the `h²` truncation term. Plain central differences
/// are not enough near a singularity of the residual (a match close to its epipole, where the
/// third derivative reaches 1e7: the `h²` term alone was 3.5e-6 at `h` = 1e-6).
fn central_difference(f: impl Fn(&[f64]) -> Vec<f64>, params: &[f64], col: usize) -> Vec<f64> {
    let h = step(params[col]);
    let diff = |h: f64| {
        let mut a = params.to_vec();
        let mut b = params.to_vec();
        a[col] += h;
        b[col] -= h;
        let (fa, fb) = (f(&a), f(&b));
        fa.iter()
            .zip(&fb)
            .map(|(x, y)| (x - y) / (2.0 * h))
            .collect::<Vec<f64>>()
    };
    let (d1, d2) = (diff(h), diff(0.5 * h));
    d1.iter()
        .zip(&d2)
        .map(|(a, b)| (4.0 * b - a) / 3.0)
        .collect()
}

fn compare(
    what: &str,
    row: usize,
    col: usize,
    ad: f64,
    fd: f64,
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    let error = (ad - fd).abs() / fd.abs().max(1.0);
    if error <= tol && ad.is_finite() {
        Ok(error)
    } else {
        Err(JacobianMismatch {
            what: what.into(),
            row,
            col,
            ad,
            fd,
            error,
            tolerance: tol,
        })
    }
}

/// Checks the Jacobian of the motion `M(p)` (its 12 entries `R`, `t`) with respect to every
/// parameter against central finite differences. Returns the largest relative error.
pub fn check_motion_jacobian<M: Manifold>(
    model: &M,
    params: &[f64],
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    let np = M::PARAMS.len();
    let entries = |p: &Pose<f64>| -> [f64; 12] {
        let mut e = [0.0; 12];
        e[..9].copy_from_slice(p.rotation.as_slice());
        e[9..].copy_from_slice(p.translation.as_slice());
        e
    };
    let mut worst: f64 = 0.0;
    for col in 0..np {
        let p: Vec<DualSVec64<1>> = params
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let d = DualSVec64::from_re(v);
                if i == col { d.derivative(0) } else { d }
            })
            .collect();
        let m = model.motion(&p);
        let ad: Vec<f64> = m
            .rotation
            .iter()
            .chain(m.translation.iter())
            .map(|v| v.eps.0.map_or(0.0, |e| e[0]))
            .collect();
        let fd = central_difference(|p| entries(&model.motion(p)).to_vec(), params, col);
        for row in 0..12 {
            let fd = fd[row];
            worst = worst.max(compare(M::PARAMS[col], row, col, ad[row], fd, tol)?);
        }
    }
    Ok(worst)
}

/// Checks the Jacobian of a soft manifold's prior residuals ([`Manifold::prior_residuals`])
/// with respect to every parameter against central finite differences. Returns the largest
/// relative error (0 for a hard manifold, which has none).
pub fn check_prior_jacobian<M: Manifold>(
    model: &M,
    params: &[f64],
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    use crate::manifold::MAX_PRIOR_RESIDUALS;
    let nq = M::PRIOR_RESIDUALS;
    let mut worst: f64 = 0.0;
    if nq == 0 {
        return Ok(worst);
    }
    let plain = |p: &[f64]| {
        let mut q = [0.0; MAX_PRIOR_RESIDUALS];
        model.prior_residuals(p, &mut q[..nq]);
        q
    };
    for col in 0..M::PARAMS.len() {
        let p: Vec<DualSVec64<1>> = params
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let d = DualSVec64::from_re(v);
                if i == col { d.derivative(0) } else { d }
            })
            .collect();
        let mut q = [DualSVec64::<1>::from_re(0.0); MAX_PRIOR_RESIDUALS];
        model.prior_residuals(&p, &mut q[..nq]);
        let fd = central_difference(|p| plain(p)[..nq].to_vec(), params, col);
        for row in 0..nq {
            let ad = q[row].eps.0.map_or(0.0, |e| e[0]);
            let fd = fd[row];
            let what = format!("prior residual {row} / {}", M::PARAMS[col]);
            worst = worst.max(compare(&what, row, col, ad, fd, tol)?);
        }
    }
    Ok(worst)
}

/// Checks the Jacobian of every residual of `obs` (model, metric, rig together) with respect to
/// every parameter against central finite differences. Returns the largest relative error.
pub fn check_residual_jacobian<M: Manifold, R: ResidualMetric>(
    model: &M,
    metric: &R,
    rig: &Rig,
    obs: &FrameObservations,
    params: &[f64],
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    let loss = crate::loss_trivial::TrivialLoss;
    let problem =
        Problem::new(model, metric, &loss, rig, obs, params).map_err(|e| JacobianMismatch {
            what: e.to_string(),
            row: 0,
            col: 0,
            ad: f64::NAN,
            fd: f64::NAN,
            error: f64::INFINITY,
            tolerance: tol,
        })?;
    let (_, jac) = problem.residuals_and_jacobian(params);
    let mut worst: f64 = 0.0;
    for col in 0..params.len() {
        let fd = central_difference(|p| problem.residuals_and_jacobian(p).0, params, col);
        for (row, &fd) in fd.iter().enumerate() {
            worst = worst.max(compare(M::PARAMS[col], row, col, jac[(row, col)], fd, tol)?);
        }
    }
    Ok(worst)
}

/// Checks `ρ'` and `ρ''` of a loss at `s` against central differences of `ρ` and `ρ'`, and
/// the loss's shortcuts against [`RobustLoss::evaluate`]: [`RobustLoss::rho`] bit for bit (the
/// solver compares costs from both), [`RobustLoss::weights`] within `tol`.
pub fn check_loss_derivatives(
    loss: &dyn RobustLoss,
    s: f64,
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    let h = 1e-6 * s.abs().max(1e-6);
    let [rho, d1, d2] = loss.evaluate(s);
    let shortcut = loss.rho(s);
    if shortcut.to_bits() != rho.to_bits() {
        return Err(JacobianMismatch {
            what: "rho (RobustLoss::rho against evaluate)".into(),
            row: 0,
            col: 0,
            ad: shortcut,
            fd: rho,
            error: (shortcut - rho).abs(),
            tolerance: 0.0,
        });
    }
    let [w1, w2] = loss.weights(s);
    compare("rho' (RobustLoss::weights)", 0, 0, w1, d1, tol)?;
    compare("rho'' (RobustLoss::weights)", 1, 0, w2, d2, tol)?;
    let [ra, da, _] = loss.evaluate(s + h);
    let [rb, db, _] = loss.evaluate(s - h);
    let scale = loss.evaluate(s)[1].abs().max(1e-300);
    // Relative to the size of ρ' so that tiny-scale losses are judged fairly.
    let e1 = compare("rho'", 0, 0, d1 / scale, (ra - rb) / (2.0 * h) / scale, tol)?;
    let scale2 = d2.abs().max(((da - db) / (2.0 * h)).abs()).max(1e-300);
    let e2 = compare(
        "rho''",
        1,
        0,
        d2 / scale2,
        (da - db) / (2.0 * h) / scale2,
        tol,
    )?;
    Ok(e1.max(e2))
}

/// Evaluates a generic scalar function on `f64` and on a dual number and returns value and
/// derivative, a helper for checking small pieces of a model.
pub fn derivative<F>(f: F, x: f64) -> (f64, f64)
where
    F: Fn(DualSVec64<1>) -> DualSVec64<1>,
{
    let y = f(DualSVec64::from_re(x).derivative(0));
    (y.re, y.eps.0.map_or(0.0, |e| e[0]))
}

/// Ensures `T: Scalar` functions compile for both scalar types (used by doc examples).
#[doc(hidden)]
pub fn _assert_scalar<T: Scalar>() {}

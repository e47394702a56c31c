//! Residual metrics: how far one match is from agreeing with a camera motion.

use crate::camera::Camera;
use crate::lie::Pose;
use crate::rig::Observation;
use crate::scalar::Scalar;
use std::fmt::Debug;

/// Most residuals one match may produce.
pub const MAX_RESIDUALS: usize = 3;

/// Most per-camera inputs of a fused kernel ([`ResidualMetric::KERNEL_INPUTS`]).
pub const MAX_KERNEL_INPUTS: usize = 9;

/// The form of a fused kernel's per-camera inputs ([`ResidualMetric::KERNEL_INPUTS_KIND`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelInputsKind {
    /// Any: [`ResidualMetric::kernel_inputs`] on dual numbers.
    Custom,
    /// The camera motion's rotation `R`, row-major (9 inputs).
    Rotation,
    /// The essential matrix `E = Rᵀ [t]ₓ` as [`essential`] computes it, row-major (9 inputs).
    Essential,
}

/// A residual metric: the residuals of one match given the camera motion `C = [R | t]`
/// (the pose of the camera at frame k in the camera at k-1), generic over the scalar.
///
/// Evaluation has two steps so that per-camera work (e.g. the essential matrix
/// `E = Rᵀ [t]_x`) is done once per camera and not once per match:
/// [`prepare`](Self::prepare) per camera and motion, then [`residuals`](Self::residuals) per match.
///
/// # Fused kernel (optional)
///
/// By default the solver differentiates [`residuals`](Self::residuals) with dual numbers, one
/// derivative per free parameter, for every match. A metric may instead provide a *fused
/// kernel* in plain `f64` by the chain rule through a few per-camera inputs `q(C)` (for
/// [`RotationOnly`] the rotation matrix, for AnglePlane the essential matrix):
///
/// - [`KERNEL_INPUTS`](Self::KERNEL_INPUTS) `> 0` switches it on;
/// - [`kernel_inputs`](Self::kernel_inputs) writes `q(C)`, generic over the scalar: the
///   problem evaluates it on dual numbers once per camera and linearisation, which gives
///   `dq/dp` without hand-written derivatives of the motion model;
/// - [`kernel`](Self::kernel) returns, per match, the residuals and their derivatives `dr/dq`
///   in plain `f64`; the problem forms `J = (dr/dq)(dq/dp)`.
///
/// The automatic path stays the oracle: `Problem::with_automatic(true)` forces it, and the
/// property tests of each kernel check that both agree to about `1e-12` relative. The cost
/// (`LeastSquares::cost`) always uses [`residuals`](Self::residuals) on `f64`; a kernel should
/// compute its residuals in the same order of operations, so that the linearisation's cost is
/// the cost.
pub trait ResidualMetric: Clone + Debug + Send + Sync + 'static {
    /// Number of residuals per match (1..=[`MAX_RESIDUALS`]).
    const RESIDUALS: usize;

    /// Per-camera quantities derived from the camera motion.
    type Prepared<T: Scalar>;

    /// `Ok` if the metric can work with this camera model; otherwise the reason.
    fn supports(&self, _camera: &Camera) -> Result<(), String> {
        Ok(())
    }

    /// Derives the per-camera quantities from the camera motion `C`.
    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> Self::Prepared<T>;

    /// Writes the `RESIDUALS` residuals of one match into `out[..RESIDUALS]`.
    fn residuals<T: Scalar>(&self, prepared: &Self::Prepared<T>, obs: &Observation, out: &mut [T]);

    /// Number of per-match constants: quantities of one match on its camera that do not
    /// depend on the motion (e.g. `momo_costs::AnglePlaneMl`'s bearing covariances). 0, the
    /// default: none. With `> 0`, `Problem` computes them once per problem
    /// ([`match_constants`](Self::match_constants), at its first evaluation) and evaluates the
    /// residuals by [`residuals_with`](Self::residuals_with) and the kernel with them, instead
    /// of recomputing them in every evaluation.
    const MATCH_CONSTANTS: usize = 0;

    /// Writes the per-match constants of `obs` on `camera` into `out[..MATCH_CONSTANTS]`.
    fn match_constants(&self, _camera: &Camera, _obs: &Observation, _out: &mut [f64]) {}

    /// [`residuals`](Self::residuals) given the match's constants
    /// (`constants.len() == MATCH_CONSTANTS`, from [`match_constants`](Self::match_constants)):
    /// must give the same residuals bit for bit (the cache is exact; `Problem::with_automatic`
    /// evaluates [`residuals`](Self::residuals) and is the oracle). The default ignores them.
    #[inline(always)]
    fn residuals_with<T: Scalar>(
        &self,
        prepared: &Self::Prepared<T>,
        obs: &Observation,
        _constants: &[f64],
        out: &mut [T],
    ) {
        self.residuals(prepared, obs, out);
    }

    /// Number of per-camera inputs `q` of the fused kernel (`0..=`[`MAX_KERNEL_INPUTS`]); 0,
    /// the default, means no fused kernel: Jacobians by automatic differentiation of
    /// [`residuals`](Self::residuals).
    const KERNEL_INPUTS: usize = 0;

    /// What [`kernel_inputs`](Self::kernel_inputs) writes, where it is one of the forms the
    /// problem can compute on plain arrays of values and derivatives instead of dual numbers
    /// ([`KernelInputsKind`]; bit-identical to `kernel_inputs` on dual numbers). `Custom`, the
    /// default: `kernel_inputs` is called on dual numbers.
    const KERNEL_INPUTS_KIND: KernelInputsKind = KernelInputsKind::Custom;

    /// Writes the fused kernel's per-camera inputs `q(C)` into `out[..KERNEL_INPUTS]` for the
    /// camera motion `C` (generic: the problem differentiates it on dual numbers).
    fn kernel_inputs<T: Scalar>(&self, _camera: &Camera, _motion: &Pose<T>, _out: &mut [T]) {}

    /// The fused kernel of one match, in plain `f64`: the `RESIDUALS` residuals into
    /// `r[..RESIDUALS]` and their derivatives with respect to the inputs `q`
    /// (`q.len() == KERNEL_INPUTS`) into `dr_dq[i][..KERNEL_INPUTS]` for residual `i`;
    /// `constants` are the match's [`match_constants`](Self::match_constants) (empty when
    /// [`MATCH_CONSTANTS`](Self::MATCH_CONSTANTS) is 0). Only called when
    /// [`KERNEL_INPUTS`](Self::KERNEL_INPUTS) `> 0`.
    fn kernel(
        &self,
        _camera: &Camera,
        _q: &[f64],
        _obs: &Observation,
        _constants: &[f64],
        _r: &mut [f64],
        _dr_dq: &mut [[f64; MAX_KERNEL_INPUTS]],
    ) {
    }
}

/// The essential matrix `E = Rᵀ [t]_x` of a camera motion `C = [R | t]`, so that
/// `f1ᵀ E f0 = 0` (`docs/DESIGN.md`: coplanarity `(R f1) · (t × f0) = 0`).
///
/// The paper (Sec. "Formulation of the potential function") writes `E(M) = [t]_x R` with the
/// bearing of the earlier frame on the left, `f0ᵀ [t]_x R f1 = 0`; ours is its negative
/// transpose, `Rᵀ [t]_x = −([t]_x R)ᵀ`, for the same constraint with `f1` on the left.
///
/// Written out without the zeros of `[t]_x` (the products `Rᵀ [t]_x` sums): the same
/// numbers, summed in the same order, at two products per entry instead of three, which on
/// dual numbers is most of the per-camera work of the fused AnglePlane kernel's inputs.
#[inline]
pub fn essential<T: Scalar>(motion: &Pose<T>) -> nalgebra::Matrix3<T> {
    let r = &motion.rotation;
    let t = &motion.translation;
    let (nx, ny, nz) = (-t.x, -t.y, -t.z);
    // [t]_x = [[0, -t_z, t_y], [t_z, 0, -t_x], [-t_y, t_x, 0]]; E_ab = Σ_k R_ka [t]_x,kb.
    nalgebra::Matrix3::from_fn(|a, b| match b {
        0 => r[(1, a)] * t.z + r[(2, a)] * ny,
        1 => r[(0, a)] * nz + r[(2, a)] * t.x,
        _ => r[(0, a)] * t.y + r[(1, a)] * nx,
    })
}

/// The standstill metric: the angle between `f0` and `R f1`, as the three components of
/// `f0 × R f1` (their norm is the sine of the angle). Translation is ignored, so it is defined
/// when the epipolar plane is not (`t ≈ 0`). The odometry driver switches to it at standstill.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RotationOnly;

impl ResidualMetric for RotationOnly {
    const RESIDUALS: usize = 3;
    type Prepared<T: Scalar> = nalgebra::Matrix3<T>;

    fn prepare<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>) -> Self::Prepared<T> {
        motion.rotation
    }

    #[inline]
    fn residuals<T: Scalar>(&self, r: &Self::Prepared<T>, obs: &Observation, out: &mut [T]) {
        let f0 = &obs.f0;
        let rf1 = crate::scalar::mul_const(r, &obs.f1);
        // f0 × (R f1) with f0 constant.
        out[0] = rf1.z * f0.y - rf1.y * f0.z;
        out[1] = rf1.x * f0.z - rf1.z * f0.x;
        out[2] = rf1.y * f0.x - rf1.x * f0.y;
    }

    const KERNEL_INPUTS: usize = 9;
    const KERNEL_INPUTS_KIND: KernelInputsKind = KernelInputsKind::Rotation;

    /// The rotation `R`, row-major.
    fn kernel_inputs<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>, out: &mut [T]) {
        for a in 0..3 {
            for b in 0..3 {
                out[3 * a + b] = motion.rotation[(a, b)];
            }
        }
    }

    /// `r = f0 × (R f1)`; `∂r_i/∂R_ab = [f0]ₓ-row entry times f1_b`.
    #[inline(always)]
    fn kernel(
        &self,
        _camera: &Camera,
        q: &[f64],
        obs: &Observation,
        _constants: &[f64],
        out: &mut [f64],
        dr_dq: &mut [[f64; MAX_KERNEL_INPUTS]],
    ) {
        let (f0, f1) = (&obs.f0, &obs.f1);
        let rf1 = [
            q[0] * f1.x + q[1] * f1.y + q[2] * f1.z,
            q[3] * f1.x + q[4] * f1.y + q[5] * f1.z,
            q[6] * f1.x + q[7] * f1.y + q[8] * f1.z,
        ];
        out[0] = rf1[2] * f0.y - rf1[1] * f0.z;
        out[1] = rf1[0] * f0.z - rf1[2] * f0.x;
        out[2] = rf1[1] * f0.x - rf1[0] * f0.y;
        // ∂r_i/∂(R f1)_a: the rows of -[f0]ₓ; ∂(R f1)_a/∂R_ab = f1_b.
        let c = [[0.0, -f0.z, f0.y], [f0.z, 0.0, -f0.x], [-f0.y, f0.x, 0.0]];
        for i in 0..3 {
            for a in 0..3 {
                for b in 0..3 {
                    dr_dq[i][3 * a + b] = c[i][a] * f1[b];
                }
            }
        }
    }
}

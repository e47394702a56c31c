//! [`AnglePlaneMl`]: the paper's metric weighted by its pixel-noise standard deviation, so that
//! least squares on it is the (first-order) maximum-likelihood estimate under isotropic pixel
//! noise on any central camera.

use crate::NORM_EPS_SQ;
use momo_core::{
    Camera, CameraModel, MAX_KERNEL_INPUTS, Observation, Pose, ResidualMetric, Scalar, dot_const,
    essential, mul_const, tr_mul_const,
};
use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector3};
use serde::{Deserialize, Serialize};

/// [`crate::AnglePlane`] divided by its standard deviation under 1 px isotropic noise at both
/// ends of the match (issue 14), rescaled to the units of `AnglePlane` at the image centre.
///
/// Pixel noise is isotropic in the image, but `AnglePlane` measures an angle: on a fisheye,
/// and towards the edges of a pinhole image, one pixel is a different angle in different
/// directions and places. With `r = f1ᵀ E f0 / ‖E f0‖` ([`crate::AnglePlane`]) and the
/// bearing covariance per unit pixel noise `Σᵢ = Jᵢ Jᵢᵀ` (`Jᵢ` = the 3×2 Jacobian of the
/// bearing with respect to the pixel at the observed pixel, from the camera model), the
/// residual is
///
/// `r_ml = r · s_ref / sqrt(∇₁rᵀ Σ₁ ∇₁r + ∇₀rᵀ Σ₀ ∇₀r)`, `s_ref = √2 / fₚₓ`,
///
/// with `∇₁r = E f0 / ‖E f0‖` and `∇₀r = (Eᵀ f1 − r Eᵀ n / ‖n‖) / ‖n‖` (`n = E f0`). At the
/// centre of a pinhole image `Σᵢ = (I − fᵢ fᵢᵀ) / fₚₓ²`, so `r_ml ≈ r` there and the loss scales
/// of `angle_plane` fit it (radians). Like the Sampson error, the weight depends on the motion
/// (it is differentiated with it); unlike [`crate::Sampson`] off pinholes, it uses the
/// camera's true pixel-to-ray Jacobian instead of an isotropic angular error.
///
/// `Jᵢ` is `U (∂π/∂x · U)⁻¹` with `U` an orthonormal basis of the tangent plane at the bearing
/// and `∂π/∂x` the projection's Jacobian in closed form ([`CameraModel::project_jacobian`];
/// by central differences where a model gives none); where that fails (a pixel outside the
/// model's domain) the isotropic `(I − f fᵀ) / fₚₓ²` is used.
///
/// Fused kernel ([`ResidualMetric::kernel`]): the inputs are the nine entries of `E`
/// (row-major), as for [`crate::AnglePlane`]; the residual in the automatic path's order of
/// operations (the linearisation's cost is bit-identical to it), its derivatives by hand in
/// plain `f64` (see [`AnglePlaneMl::kernel`]). The `Σᵢ` depend on the camera and the match
/// alone: they are the metric's per-match constants ([`ResidualMetric::MATCH_CONSTANTS`]),
/// computed once per problem (per frame and solve) and read by every evaluation.
///
/// ```
/// use momo_core::{Camera, Observation, Pose, ResidualMetric, Pinhole};
/// use momo_costs::{AnglePlane, AnglePlaneMl};
/// use nalgebra::{Matrix3, Vector2, Vector3};
///
/// let cam = Camera::Pinhole(Pinhole { fx: 500.0, fy: 500.0, cx: 320.0, cy: 240.0, width: 640.0, height: 480.0 });
/// let c = Pose::new(Matrix3::identity(), Vector3::new(0.1, 0.0, 1.0));
/// // A match near the image centre, 1 mrad off its epipolar plane.
/// let f0 = Vector3::new(0.01, 0.0, 1.0).normalize();
/// let f1 = Vector3::new(0.011, 0.001, 1.0).normalize();
/// let obs = Observation { px0: Vector2::new(325.0, 240.0), px1: Vector2::new(325.5, 240.5), f0, f1 };
/// let (mut a, mut m) = ([0.0], [0.0]);
/// AnglePlane.residuals(&AnglePlane.prepare(&cam, &c), &obs, &mut a);
/// AnglePlaneMl.residuals(&AnglePlaneMl.prepare(&cam, &c), &obs, &mut m);
/// assert!(a[0] != 0.0 && (m[0] / a[0] - 1.0).abs() < 0.2);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct AnglePlaneMl;

/// Per-camera data of [`AnglePlaneMl`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnglePlaneMlPrepared<T: Scalar> {
    /// The essential matrix `E = Rᵀ [t]ₓ`.
    pub e: Matrix3<T>,
    /// The camera (for the pixel-to-ray Jacobians).
    pub camera: Camera,
    /// `s_ref = √2 / fₚₓ`: the residual's standard deviation at the image centre.
    pub s_ref: f64,
}

/// The covariance of the unit bearing `f` under unit isotropic pixel noise, `J Jᵀ` with `J`
/// the bearing's Jacobian with respect to the pixel (see [`AnglePlaneMl`]): `J = U A⁻¹`,
/// `A = (∂π/∂p) U` from the camera model's closed-form projection Jacobian
/// ([`CameraModel::project_jacobian`]); where the model gives none (a fisheye's optical axis),
/// by central differences of `project` ([`bearing_covariance_by_differences`]).
pub fn bearing_covariance(camera: &Camera, f: &Vector3<f64>) -> Matrix3<f64> {
    let Some(dpi) = camera.project_jacobian(f) else {
        return bearing_covariance_by_differences(camera, f);
    };
    let (u, v) = tangent_basis(f);
    let (cu, cv) = (dpi * u, dpi * v);
    let a = Matrix2::new(cu.x, cv.x, cu.y, cv.y);
    covariance_from(camera, f, &u, &v, &a)
}

/// [`bearing_covariance`] with `∂π/∂p U` by central differences of `project` (step 1e-6 along
/// the tangent basis): the path of every model before the closed-form Jacobians, kept as the
/// fallback and as the tests' reference.
pub fn bearing_covariance_by_differences(camera: &Camera, f: &Vector3<f64>) -> Matrix3<f64> {
    let (u, v) = tangent_basis(f);
    let h = 1e-6;
    let mut a = Matrix2::zeros();
    for (k, d) in [u, v].iter().enumerate() {
        let (Some(p), Some(m)) = (camera.project(&(f + d * h)), camera.project(&(f - d * h)))
        else {
            return isotropic(camera, f);
        };
        let col = (p - m) / (2.0 * h);
        a[(0, k)] = col.x;
        a[(1, k)] = col.y;
    }
    covariance_from(camera, f, &u, &v, &a)
}

/// The isotropic fallback `(I − f fᵀ) / fₚₓ²`.
fn isotropic(camera: &Camera, f: &Vector3<f64>) -> Matrix3<f64> {
    let fl = camera.focal_length();
    (Matrix3::identity() - f * f.transpose()) / (fl * fl)
}

/// Tangent basis: `u ⟂ f` from the axis least aligned with `f`, `v = f × u`.
fn tangent_basis(f: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let axis = if f.x.abs() <= f.y.abs() && f.x.abs() <= f.z.abs() {
        Vector3::x()
    } else if f.y.abs() <= f.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let u = f.cross(&axis).normalize();
    let v = f.cross(&u);
    (u, v)
}

/// `J Jᵀ`, `J = [u v] A⁻¹`; the isotropic fallback where `A` is singular or the result is not
/// finite.
fn covariance_from(
    camera: &Camera,
    f: &Vector3<f64>,
    u: &Vector3<f64>,
    v: &Vector3<f64>,
    a: &Matrix2<f64>,
) -> Matrix3<f64> {
    let Some(a_inv) = a.try_inverse() else {
        return isotropic(camera, f);
    };
    let j: Matrix3x2<f64> = Matrix3x2::from_columns(&[*u, *v]) * a_inv;
    let cov = j * j.transpose();
    if cov.iter().all(|x| x.is_finite()) {
        cov
    } else {
        isotropic(camera, f)
    }
}

/// `gᵀ Σ g` for a constant symmetric `Σ`.
#[inline]
fn quad<T: Scalar>(s: &Matrix3<f64>, g: &Vector3<T>) -> T {
    let sg = Vector3::new(
        g.x * s[(0, 0)] + g.y * s[(0, 1)] + g.z * s[(0, 2)],
        g.x * s[(1, 0)] + g.y * s[(1, 1)] + g.z * s[(1, 2)],
        g.x * s[(2, 0)] + g.y * s[(2, 1)] + g.z * s[(2, 2)],
    );
    sg.x * g.x + sg.y * g.y + sg.z * g.z
}

impl ResidualMetric for AnglePlaneMl {
    const RESIDUALS: usize = 1;

    type Prepared<T: Scalar> = AnglePlaneMlPrepared<T>;

    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> AnglePlaneMlPrepared<T> {
        prepare_with(
            camera,
            motion,
            std::f64::consts::SQRT_2 / camera.focal_length(),
        )
    }

    #[inline]
    fn residuals<T: Scalar>(
        &self,
        prep: &AnglePlaneMlPrepared<T>,
        obs: &Observation,
        out: &mut [T],
    ) {
        let s1 = bearing_covariance(&prep.camera, &obs.f1);
        let s0 = bearing_covariance(&prep.camera, &obs.f0);
        out[0] = residual(prep, obs, &s1, &s0);
    }

    /// `Σ₁` then `Σ₀` ([`bearing_covariance`] of `f1` and `f0`), each row-major: functions of
    /// the camera and the match alone, so `Problem` computes them once per problem instead of
    /// in every evaluation (two projection Jacobians per match).
    const MATCH_CONSTANTS: usize = 18;

    fn match_constants(&self, camera: &Camera, obs: &Observation, out: &mut [f64]) {
        let s1 = bearing_covariance(camera, &obs.f1);
        let s0 = bearing_covariance(camera, &obs.f0);
        store(&s1, &mut out[..9]);
        store(&s0, &mut out[9..18]);
    }

    #[inline]
    fn residuals_with<T: Scalar>(
        &self,
        prep: &AnglePlaneMlPrepared<T>,
        obs: &Observation,
        constants: &[f64],
        out: &mut [T],
    ) {
        let (s1, s0) = load(constants);
        out[0] = residual(prep, obs, &s1, &s0);
    }

    const KERNEL_INPUTS: usize = 9;
    const KERNEL_INPUTS_KIND: momo_core::KernelInputsKind = momo_core::KernelInputsKind::Essential;

    /// The essential matrix `E = Rᵀ [t]ₓ`, row-major.
    fn kernel_inputs<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>, out: &mut [T]) {
        let e = essential(motion);
        for a in 0..3 {
            for b in 0..3 {
                out[3 * a + b] = e[(a, b)];
            }
        }
    }

    /// `r_ml = r · s_ref · w`, `w = (v + floor)^(-1/2)`, `v = g₁ᵀ Σ₁ g₁ + g₀ᵀ Σ₀ g₀` (the
    /// type's doc: `g₁ = n / d`, `g₀ = Eᵀ g`, `g = ∂r/∂n = (f1 − r g₁) / d`, `n = E f0`). With
    /// `m = Σ₀ g₀`, `u = E m`, `p = (2/d)(Σ₁ g₁ − (g₁ᵀ Σ₁ g₁) g₁)` and
    /// `c = −[(u·g₁) g + (r/d)(u − (u·g₁) g₁) + (u·g) g₁] / d`:
    /// `∂v/∂E_ab = (p_a + 2 c_a) f0_b + 2 g_a m_b`, and
    /// `∂r_ml/∂E_ab = s_ref (w g_a f0_b − ½ r w³ ∂v/∂E_ab)`.
    #[inline(always)]
    fn kernel(
        &self,
        camera: &Camera,
        e: &[f64],
        obs: &Observation,
        constants: &[f64],
        out: &mut [f64],
        dr_de: &mut [[f64; MAX_KERNEL_INPUTS]],
    ) {
        kernel_with(
            std::f64::consts::SQRT_2 / camera.focal_length(),
            camera,
            e,
            obs,
            constants,
            out,
            dr_de,
        );
    }
}

/// [`AnglePlaneMl`]'s fused kernel with the reference `s_ref` given (the camera's own for
/// [`AnglePlaneMl`], the rig's for [`AnglePlaneMlRig`]); see [`AnglePlaneMl::kernel`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn kernel_with(
    s_ref: f64,
    camera: &Camera,
    e: &[f64],
    obs: &Observation,
    constants: &[f64],
    out: &mut [f64],
    dr_de: &mut [[f64; MAX_KERNEL_INPUTS]],
) {
    let (f0, f1) = (&obs.f0, &obs.f1);
    let n = [
        e[0] * f0.x + e[1] * f0.y + e[2] * f0.z,
        e[3] * f0.x + e[4] * f0.y + e[5] * f0.z,
        e[6] * f0.x + e[7] * f0.y + e[8] * f0.z,
    ];
    let d = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + NORM_EPS_SQ).sqrt();
    let inv_d = d.recip();
    let r = (n[0] * f1.x + n[1] * f1.y + n[2] * f1.z) * inv_d;
    let g1 = Vector3::new(n[0] * inv_d, n[1] * inv_d, n[2] * inv_d);
    let rd = r * inv_d;
    let mut g0 = Vector3::zeros();
    for i in 0..3 {
        let etn = e[i] * n[0] + e[3 + i] * n[1] + e[6 + i] * n[2];
        let etf1 = e[i] * f1.x + e[3 + i] * f1.y + e[6 + i] * f1.z;
        g0[i] = (etf1 - etn * rd) * inv_d;
    }
    let (s1, s0) = if constants.len() == <AnglePlaneMl as ResidualMetric>::MATCH_CONSTANTS {
        load(constants)
    } else {
        (
            bearing_covariance(camera, f1),
            bearing_covariance(camera, f0),
        )
    };
    let var = quad(&s1, &g1) + quad(&s0, &g0);
    let floor = 1e-6 * s_ref * s_ref;
    let w = (var + floor).sqrt().recip();
    out[0] = r * s_ref * w;
    // Derivatives (plain f64; rounding differs from the automatic path's, the value not).
    let g = (f1 - g1 * r) * inv_d;
    let s1g1 = s1 * g1;
    let p = (s1g1 - g1 * g1.dot(&s1g1)) * (2.0 * inv_d);
    let m = s0 * g0;
    let em = Matrix3::new(e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], e[8]) * m;
    let (ug1, ug) = (em.dot(&g1), em.dot(&g));
    let c = -(g * ug1 + (em - g1 * ug1) * rd + g1 * ug) * inv_d;
    let k = 0.5 * r * w * w * w;
    let row = &mut dr_de[0];
    for a in 0..3 {
        let along_f0 = s_ref * (w * g[a] - k * (p[a] + 2.0 * c[a]));
        let along_m = -s_ref * 2.0 * k * g[a];
        for b in 0..3 {
            row[3 * a + b] = along_f0 * f0[b] + along_m * m[b];
        }
    }
}

/// [`AnglePlaneMlPrepared`] of a camera and motion with the reference `s_ref`.
#[inline]
fn prepare_with<T: Scalar>(
    camera: &Camera,
    motion: &Pose<T>,
    s_ref: f64,
) -> AnglePlaneMlPrepared<T> {
    AnglePlaneMlPrepared {
        e: essential(motion),
        camera: *camera,
        s_ref,
    }
}

/// `r_ml` of one match given its bearing covariances `Σ₁` (of `f1`) and `Σ₀` (of `f0`), every
/// operation in a fixed order: the fused kernel repeats it in plain f64 (as num-dual divides:
/// times the reciprocal), so the linearisation's cost is bit-identical.
#[inline(always)]
fn residual<T: Scalar>(
    prep: &AnglePlaneMlPrepared<T>,
    obs: &Observation,
    s1: &Matrix3<f64>,
    s0: &Matrix3<f64>,
) -> T {
    let e = &prep.e;
    let n = mul_const(e, &obs.f0);
    let d = (n.norm_squared() + T::c(NORM_EPS_SQ)).sqrt();
    let r = dot_const(&n, &obs.f1) / d;
    let g1 = n / d;
    let etn = tr_mul(e, &n);
    let g0 = (tr_mul_const(e, &obs.f1) - etn * (r / d)) / d;
    let var = quad(s1, &g1) + quad(s0, &g0);
    // Guard: a vanishing gradient (standstill, degenerate geometry) keeps a finite residual.
    let floor = T::c(1e-6 * prep.s_ref * prep.s_ref);
    r * T::c(prep.s_ref) / (var + floor).sqrt()
}

/// Writes `s` row-major into `out[..9]`.
#[inline(always)]
fn store(s: &Matrix3<f64>, out: &mut [f64]) {
    for a in 0..3 {
        for b in 0..3 {
            out[3 * a + b] = s[(a, b)];
        }
    }
}

/// `(Σ₁, Σ₀)` from the match constants written by `match_constants` (row-major, 9 each).
#[inline(always)]
fn load(c: &[f64]) -> (Matrix3<f64>, Matrix3<f64>) {
    let m = |o: usize| Matrix3::from_fn(|a, b| c[o + 3 * a + b]);
    (m(0), m(9))
}

/// `mᵀ v` for a matrix and a vector of scalars, in a fixed order of operations (the fused
/// kernel repeats it).
#[inline(always)]
fn tr_mul<T: Scalar>(m: &Matrix3<T>, v: &Vector3<T>) -> Vector3<T> {
    Vector3::new(
        m[(0, 0)] * v.x + m[(1, 0)] * v.y + m[(2, 0)] * v.z,
        m[(0, 1)] * v.x + m[(1, 1)] * v.y + m[(2, 1)] * v.z,
        m[(0, 2)] * v.x + m[(1, 2)] * v.y + m[(2, 2)] * v.z,
    )
}

momo_core::register_metric!(AnglePlaneMl, "angle_plane_ml");

/// [`AnglePlaneMl`] with one reference `s_ref = √2 / f_ref` for every camera of a rig, `f_ref`
/// the rig's mean focal length (`reference_focal`, pixels; the final stage sets it from the
/// rig, `odometry.final_fit.ml_rig_reference`), instead of each camera's own `√2 / fₚₓ`.
///
/// `r / sqrt(∇₁rᵀ Σ₁ ∇₁r + ∇₀rᵀ Σ₀ ∇₀r)` has the pixel noise's standard deviation on every
/// camera (the type doc of [`AnglePlaneMl`]); the factor `s_ref` only converts it to radians.
/// With each camera's own `s_ref`, a rig whose cameras have different focal lengths weighs
/// camera `j`'s matches by `(f_ref / f_j)²` relative to the maximum-likelihood weights, e.g.
/// the double sphere cameras (fx = 300) of `wide_angle_surround` 3.5 times the unified ones
/// (fx = 560). One `s_ref` for the rig keeps the least-squares problem the ML one. On a single
/// camera, or a rig whose cameras share one focal length, `f_ref` is that focal length and the
/// residuals are [`AnglePlaneMl`]'s, bit for bit.
///
/// ```
/// use momo_core::{Camera, Observation, Pose, ResidualMetric, Pinhole};
/// use momo_costs::{AnglePlaneMl, AnglePlaneMlRig};
/// use nalgebra::{Matrix3, Vector2, Vector3};
///
/// let cam = Camera::Pinhole(Pinhole { fx: 500.0, fy: 500.0, cx: 320.0, cy: 240.0, width: 640.0, height: 480.0 });
/// let c = Pose::new(Matrix3::identity(), Vector3::new(0.1, 0.0, 1.0));
/// let f0 = Vector3::new(0.01, 0.0, 1.0).normalize();
/// let f1 = Vector3::new(0.011, 0.001, 1.0).normalize();
/// let obs = Observation { px0: Vector2::new(325.0, 240.0), px1: Vector2::new(325.5, 240.5), f0, f1 };
/// let (mut a, mut b, mut h) = ([0.0], [0.0], [0.0]);
/// AnglePlaneMl.residuals(&AnglePlaneMl.prepare(&cam, &c), &obs, &mut a);
/// let same = AnglePlaneMlRig { reference_focal: 500.0 };
/// same.residuals(&same.prepare(&cam, &c), &obs, &mut b);
/// let double = AnglePlaneMlRig { reference_focal: 1000.0 };
/// double.residuals(&double.prepare(&cam, &c), &obs, &mut h);
/// assert_eq!(a[0], b[0]);
/// // Half the reference's s_ref: half the residual (to the variance floor, 1e-6 · s_ref²).
/// assert!((h[0] / a[0] - 0.5).abs() < 1e-5);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnglePlaneMlRig {
    /// `f_ref`, pixels: the rig's mean focal length ([`AnglePlaneMlRig::for_rig`]).
    pub reference_focal: f64,
}

impl AnglePlaneMlRig {
    /// The metric for a rig: `f_ref` the mean of its cameras' focal lengths
    /// ([`Camera::focal_length`]; exactly their common one where they share it); `None` for a
    /// rig without cameras or a non-positive mean.
    pub fn for_rig(rig: &momo_core::Rig) -> Option<Self> {
        let f: Vec<f64> = rig
            .cameras()
            .iter()
            .map(|c| c.model.focal_length())
            .collect();
        let first = *f.first()?;
        // Cameras of one focal length: that one, exactly (a sum of three or more can round).
        let mean = if f.iter().all(|v| *v == first) {
            first
        } else {
            f.iter().sum::<f64>() / f.len() as f64
        };
        (mean.is_finite() && mean > 0.0).then_some(Self {
            reference_focal: mean,
        })
    }

    fn s_ref(&self) -> f64 {
        std::f64::consts::SQRT_2 / self.reference_focal
    }
}

impl ResidualMetric for AnglePlaneMlRig {
    const RESIDUALS: usize = 1;

    type Prepared<T: Scalar> = AnglePlaneMlPrepared<T>;

    fn supports(&self, camera: &Camera) -> Result<(), String> {
        AnglePlaneMl.supports(camera)
    }

    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> AnglePlaneMlPrepared<T> {
        prepare_with(camera, motion, self.s_ref())
    }

    #[inline]
    fn residuals<T: Scalar>(
        &self,
        prep: &AnglePlaneMlPrepared<T>,
        obs: &Observation,
        out: &mut [T],
    ) {
        AnglePlaneMl.residuals(prep, obs, out);
    }

    /// [`AnglePlaneMl`]'s: the bearing covariances do not depend on `s_ref`.
    const MATCH_CONSTANTS: usize = <AnglePlaneMl as ResidualMetric>::MATCH_CONSTANTS;

    fn match_constants(&self, camera: &Camera, obs: &Observation, out: &mut [f64]) {
        AnglePlaneMl.match_constants(camera, obs, out);
    }

    #[inline]
    fn residuals_with<T: Scalar>(
        &self,
        prep: &AnglePlaneMlPrepared<T>,
        obs: &Observation,
        constants: &[f64],
        out: &mut [T],
    ) {
        AnglePlaneMl.residuals_with(prep, obs, constants, out);
    }

    const KERNEL_INPUTS: usize = 9;
    const KERNEL_INPUTS_KIND: momo_core::KernelInputsKind = momo_core::KernelInputsKind::Essential;

    fn kernel_inputs<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>, out: &mut [T]) {
        AnglePlaneMl.kernel_inputs(camera, motion, out);
    }

    /// [`AnglePlaneMl::kernel`] with the rig's `s_ref`.
    #[inline(always)]
    fn kernel(
        &self,
        camera: &Camera,
        e: &[f64],
        obs: &Observation,
        constants: &[f64],
        out: &mut [f64],
        dr_de: &mut [[f64; MAX_KERNEL_INPUTS]],
    ) {
        kernel_with(self.s_ref(), camera, e, obs, constants, out, dr_de);
    }
}

momo_core::register_metric!(AnglePlaneMlRig, "angle_plane_ml_rig");

//! Motion models erased at the one thing the solver needs of them: the vehicle motion (and a
//! soft model's prior residuals) on the scalars the solver uses, evaluated once per cost or
//! linearisation (the paper: only the mapping from the manifold to the full motion space must
//! be known).
//!
//! - [`Manifold`] is what a researcher implements: parameter names as constants and the motion
//!   written once over any [`Scalar`].
//! - [`RuntimeManifold`] is the same with the parameter list known at run time, for models
//!   built at run time from another one (the mount calibration's model plus three mount
//!   angles). Every [`Manifold`] is one.
//! - [`DynManifold`] is the object-safe form: one method per scalar the solver uses (`f64` and
//!   the dual numbers [`DualSVec64<N>`], `N = 0..=8` free parameters). Every
//!   [`RuntimeManifold`] is one, by a blanket impl, so `&M` coerces to `&dyn DynManifold`.
//! - [`ErasedScalar`] names those scalars: `T::motion(model, p)` evaluates a `dyn DynManifold`
//!   at `p` whatever `T` is, so generic code over the width calls one function.
//!
//! The per-match loop stays monomorphised per residual metric and width ([`crate::Problem`]);
//! the model costs one virtual call per evaluation. Any model therefore pairs with any metric
//! ([`crate::MetricSpec::estimator`]) without either knowing the other.

use crate::lie::Pose;
use crate::manifold::Manifold;
use crate::rig::Rig;
use crate::scalar::Scalar;
use num_dual::DualSVec64;
use std::fmt::Debug;

/// A motion model whose parameter list is known at run time. Every [`Manifold`] is one; a
/// wrapper that extends a model (see `momo_vo::calibrate::Mounted`) implements this directly.
pub trait RuntimeManifold: Debug + Send + Sync {
    /// Names of the parameters, in order.
    fn params(&self) -> &[&'static str];
    /// Index of the arc-length parameter, if any.
    fn arc_length_index(&self) -> Option<usize>;
    /// Number of a soft model's prior residuals ([`Manifold::prior_residuals`]).
    fn prior_residual_count(&self) -> usize;
    /// The vehicle motion for parameters `p`.
    fn motion<T: ErasedScalar>(&self, p: &[T]) -> Pose<T>;
    /// A soft model's prior residuals at `p` ([`Manifold::prior_residuals`]).
    fn prior_residuals<T: ErasedScalar>(&self, p: &[T], out: &mut [T]);
    /// A neutral start with the given arc length ([`Manifold::initial_params`]).
    fn initial_params(&self, arc_length: f64) -> Vec<f64>;
    /// Closed-form parameters of a motion ([`Manifold::params_from_motion`]).
    fn params_from_motion(&self, motion: &Pose<f64>) -> Option<Vec<f64>>;
    /// Which parameters the rig can observe ([`Manifold::observable`]).
    fn observable(&self, rig: &Rig) -> Vec<bool>;
}

impl<M: Manifold> RuntimeManifold for M {
    #[inline]
    fn params(&self) -> &[&'static str] {
        M::PARAMS
    }
    #[inline]
    fn arc_length_index(&self) -> Option<usize> {
        M::ARC_LENGTH
    }
    #[inline]
    fn prior_residual_count(&self) -> usize {
        M::PRIOR_RESIDUALS
    }
    #[inline]
    fn motion<T: ErasedScalar>(&self, p: &[T]) -> Pose<T> {
        Manifold::motion(self, p)
    }
    #[inline]
    fn prior_residuals<T: ErasedScalar>(&self, p: &[T], out: &mut [T]) {
        Manifold::prior_residuals(self, p, out)
    }
    fn initial_params(&self, arc_length: f64) -> Vec<f64> {
        Manifold::initial_params(self, arc_length)
    }
    fn params_from_motion(&self, motion: &Pose<f64>) -> Option<Vec<f64>> {
        Manifold::params_from_motion(self, motion)
    }
    fn observable(&self, rig: &Rig) -> Vec<bool> {
        Manifold::observable(self, rig)
    }
}

/// Writes the object-safe trait, its blanket impl and the [`ErasedScalar`] impls for every
/// dual-number width in one place, so that they cannot disagree.
macro_rules! dyn_manifold {
    ($(($n:literal, $motion:ident, $prior:ident)),* $(,)?) => {
        /// The object-safe form of a motion model ([`RuntimeManifold`], hence every
        /// [`Manifold`]): one method per scalar the solver evaluates the model on. Implemented
        /// by a blanket impl; call the motion through [`ErasedScalar`] (or
        /// [`motion_of`](Self::motion_of)) rather than the per-width methods.
        pub trait DynManifold: Debug + Send + Sync {
            /// Names of the parameters, in order.
            fn params(&self) -> &[&'static str];
            /// Index of the arc-length parameter, if any.
            fn arc_length_index(&self) -> Option<usize>;
            /// Number of a soft model's prior residuals.
            fn prior_residual_count(&self) -> usize;
            /// A neutral start with the given arc length.
            fn initial_params(&self, arc_length: f64) -> Vec<f64>;
            /// Closed-form parameters of a motion, if the model has them.
            fn params_from_motion(&self, motion: &Pose<f64>) -> Option<Vec<f64>>;
            /// Which parameters the rig can observe.
            fn observable(&self, rig: &Rig) -> Vec<bool>;
            /// The motion on plain numbers.
            fn motion_f64(&self, p: &[f64]) -> Pose<f64>;
            /// The prior residuals on plain numbers.
            fn prior_residuals_f64(&self, p: &[f64], out: &mut [f64]);
            $(
                #[doc = concat!("The motion on dual numbers with ", stringify!($n), " derivatives.")]
                fn $motion(&self, p: &[DualSVec64<$n>]) -> Pose<DualSVec64<$n>>;
                #[doc = concat!("The prior residuals on dual numbers with ", stringify!($n), " derivatives.")]
                fn $prior(&self, p: &[DualSVec64<$n>], out: &mut [DualSVec64<$n>]);
            )*
        }

        impl<M: RuntimeManifold> DynManifold for M {
            fn params(&self) -> &[&'static str] {
                RuntimeManifold::params(self)
            }
            fn arc_length_index(&self) -> Option<usize> {
                RuntimeManifold::arc_length_index(self)
            }
            fn prior_residual_count(&self) -> usize {
                RuntimeManifold::prior_residual_count(self)
            }
            fn initial_params(&self, arc_length: f64) -> Vec<f64> {
                RuntimeManifold::initial_params(self, arc_length)
            }
            fn params_from_motion(&self, motion: &Pose<f64>) -> Option<Vec<f64>> {
                RuntimeManifold::params_from_motion(self, motion)
            }
            fn observable(&self, rig: &Rig) -> Vec<bool> {
                RuntimeManifold::observable(self, rig)
            }
            fn motion_f64(&self, p: &[f64]) -> Pose<f64> {
                RuntimeManifold::motion(self, p)
            }
            fn prior_residuals_f64(&self, p: &[f64], out: &mut [f64]) {
                RuntimeManifold::prior_residuals(self, p, out)
            }
            $(
                fn $motion(&self, p: &[DualSVec64<$n>]) -> Pose<DualSVec64<$n>> {
                    RuntimeManifold::motion(self, p)
                }
                fn $prior(&self, p: &[DualSVec64<$n>], out: &mut [DualSVec64<$n>]) {
                    RuntimeManifold::prior_residuals(self, p, out)
                }
            )*
        }

        $(
            impl ErasedScalar for DualSVec64<$n> {
                #[inline]
                fn motion(model: &(impl DynManifold + ?Sized), p: &[Self]) -> Pose<Self> {
                    model.$motion(p)
                }
                #[inline]
                fn prior_residuals(model: &(impl DynManifold + ?Sized), p: &[Self], out: &mut [Self]) {
                    model.$prior(p, out)
                }
            }
        )*
    };
}

dyn_manifold!(
    (0, motion_d0, prior_residuals_d0),
    (1, motion_d1, prior_residuals_d1),
    (2, motion_d2, prior_residuals_d2),
    (3, motion_d3, prior_residuals_d3),
    (4, motion_d4, prior_residuals_d4),
    (5, motion_d5, prior_residuals_d5),
    (6, motion_d6, prior_residuals_d6),
    (7, motion_d7, prior_residuals_d7),
    (8, motion_d8, prior_residuals_d8),
);

/// The scalars a [`DynManifold`] is evaluated on: `f64` and [`DualSVec64<N>`] for
/// `N = 0..=8` (up to [`crate::MAX_PARAMS`] free parameters).
pub trait ErasedScalar: Scalar {
    /// The motion of `model` at `p`.
    fn motion(model: &(impl DynManifold + ?Sized), p: &[Self]) -> Pose<Self>;
    /// The prior residuals of `model` at `p`.
    fn prior_residuals(model: &(impl DynManifold + ?Sized), p: &[Self], out: &mut [Self]);
}

impl ErasedScalar for f64 {
    #[inline]
    fn motion(model: &(impl DynManifold + ?Sized), p: &[Self]) -> Pose<Self> {
        model.motion_f64(p)
    }
    #[inline]
    fn prior_residuals(model: &(impl DynManifold + ?Sized), p: &[Self], out: &mut [Self]) {
        model.prior_residuals_f64(p, out)
    }
}

impl dyn DynManifold + '_ {
    /// The motion at `p` on any scalar the solver uses.
    #[inline]
    pub fn motion_of<T: ErasedScalar>(&self, p: &[T]) -> Pose<T> {
        T::motion(self, p)
    }

    /// The prior residuals at `p` on any scalar the solver uses.
    #[inline]
    pub fn prior_residuals_of<T: ErasedScalar>(&self, p: &[T], out: &mut [T]) {
        T::prior_residuals(self, p, out)
    }

    /// The parameters that move the rotation at `p`: `true` where the derivative of the
    /// rotation matrix with respect to the parameter is not zero, by automatic
    /// differentiation (dual numbers with one derivative per parameter). At most
    /// [`crate::MAX_PARAMS`] parameters.
    pub fn moves_rotation(&self, p: &[f64]) -> Vec<bool> {
        let n = self.params().len().min(8);
        let mut x = [DualSVec64::<8>::from_re(0.0); 8];
        for i in 0..n {
            x[i] = DualSVec64::from_re(p[i]).derivative(i);
        }
        let r = self.motion_of(&x[..n]).rotation;
        (0..n)
            .map(|i| {
                r.iter()
                    .any(|v| v.eps.0.as_ref().is_some_and(|e| e[i].abs() > 1e-12))
            })
            .collect()
    }
}

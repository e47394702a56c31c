//! Building type-erased estimators from configuration types, and the registration macros.

use crate::{Se3, SingleTrack2d, SingleTrack3d, SoftSingleTrack};
use momo_core::{
    CoreError, FrameEstimator, Manifold, MetricSpec, ModelSpec, ResidualMetric, erase,
};
use momo_costs::{AnglePlane, GeoLine, Sampson};

/// Builds the estimator of `model` with a metric given as a configuration trait object.
///
/// Tries the built-in metrics ([`AnglePlane`], [`GeoLine`], [`Sampson`]) by downcasting
/// `metric.as_any()`, and erases the pair with [`momo_core::erase`] (monomorphised per-match
/// loop). Otherwise asks the metric ([`MetricSpec::build_with_model`], implemented by
/// [`register_metric!`](crate::register_metric) for researchers' metrics). Fails with
/// [`CoreError::UnregisteredCombination`] (type tags of both) if neither knows the other.
///
/// This is what [`register_model!`](crate::register_model) calls from [`ModelSpec::build`].
pub fn build_with_builtin_metrics<M: Manifold + ModelSpec>(
    model: M,
    metric: &dyn MetricSpec,
) -> Result<Box<dyn FrameEstimator>, CoreError> {
    let any = metric.as_any();
    if let Some(r) = any.downcast_ref::<AnglePlane>() {
        return Ok(erase(model, *r));
    }
    if let Some(r) = any.downcast_ref::<GeoLine>() {
        return Ok(erase(model, *r));
    }
    if let Some(r) = any.downcast_ref::<Sampson>() {
        return Ok(erase(model, *r));
    }
    if let Some(e) = metric.build_with_model(&model) {
        return Ok(e);
    }
    Err(unregistered(&model, metric))
}

/// The [`CoreError::UnregisteredCombination`] of a model and a metric, named by type tag.
pub fn unregistered(model: &dyn ModelSpec, metric: &dyn MetricSpec) -> CoreError {
    CoreError::UnregisteredCombination {
        model: model.typetag_name().into(),
        metric: metric.typetag_name().into(),
    }
}

/// Builds the estimator of a (researcher's) metric with one of the built-in models
/// ([`SingleTrack2d`], [`SingleTrack3d`], [`Se3`]), found by downcasting `model.as_any()`;
/// `None` for any other model. This is what [`register_metric!`](crate::register_metric) calls
/// from [`MetricSpec::build_with_model`].
pub fn build_with_builtin_models<R: ResidualMetric>(
    model: &dyn ModelSpec,
    metric: R,
) -> Option<Box<dyn FrameEstimator>> {
    let any = model.as_any();
    if let Some(m) = any.downcast_ref::<SingleTrack2d>() {
        return Some(erase(*m, metric));
    }
    if let Some(m) = any.downcast_ref::<SingleTrack3d>() {
        return Some(erase(*m, metric));
    }
    if let Some(m) = any.downcast_ref::<Se3>() {
        return Some(erase(*m, metric));
    }
    if let Some(m) = any.downcast_ref::<SoftSingleTrack>() {
        return Some(erase(*m, metric));
    }
    None
}

/// Registers a motion model: implements [`momo_core::ModelSpec`] for `$ty` under the type tag
/// `$name`, so that it is built from a configuration (`[model] type = "$name"`) with every
/// built-in metric and with metrics registered by [`register_metric!`](crate::register_metric).
///
/// `$ty` must implement [`momo_core::Manifold`], `serde::Serialize` and
/// `serde::Deserialize`. With `metrics = [A, B]` the model is also built with your own metric
/// types `A`, `B` (each implementing [`momo_core::ResidualMetric`]) tried first; that is how a
/// researcher's model meets a researcher's metric.
///
/// The calling crate needs `typetag` only indirectly (the macro brings momo's copy into scope)
/// and `serde` for the derives (or `#[serde(crate = "momo_models::serde")]`).
///
/// ```
/// use momo_models::momo_core::{Manifold, ModelSpec, Pose, Scalar, nalgebra::{Matrix3, Vector3}};
/// use momo_models::{register_model, momo_costs::AnglePlane};
/// use serde::{Deserialize, Serialize};
///
/// /// Straight-line motion with a vertical component.
/// #[derive(Clone, Debug, Serialize, Deserialize)]
/// struct Ramp { slope: f64 }
///
/// impl Manifold for Ramp {
///     const PARAMS: &'static [&'static str] = &["arc_length"];
///     const ARC_LENGTH: Option<usize> = Some(0);
///     fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
///         let s = T::c(self.slope);
///         Pose::new(Matrix3::identity(), Vector3::new(p[0], T::zero(), p[0] * s))
///     }
/// }
/// register_model!(Ramp, "doc_ramp");
///
/// let spec: Box<dyn ModelSpec> = serde_json::from_str(r#"{"type": "doc_ramp", "slope": 0.1}"#).unwrap();
/// let est = spec.build(&AnglePlane).unwrap();
/// assert_eq!(est.param_names(), &["arc_length"]);
/// assert!((est.motion(&[2.0]).translation.z - 0.2).abs() < 1e-15);
/// ```
#[macro_export]
macro_rules! register_model {
    ($ty:ty, $name:literal) => {
        $crate::register_model!($ty, $name, metrics = []);
    };
    ($ty:ty, $name:literal, metrics = [$($metric:ty),* $(,)?]) => {
        const _: () = {
            use $crate::__private::typetag;

            #[typetag::serde(name = $name)]
            impl $crate::__private::ModelSpec for $ty {
                fn build(
                    &self,
                    metric: &dyn $crate::__private::MetricSpec,
                ) -> ::core::result::Result<
                    $crate::__private::Box<dyn $crate::__private::FrameEstimator>,
                    $crate::__private::CoreError,
                > {
                    $(
                        if let ::core::option::Option::Some(r) =
                            $crate::__private::MetricSpec::as_any(metric).downcast_ref::<$metric>()
                        {
                            return ::core::result::Result::Ok($crate::__private::erase(
                                ::core::clone::Clone::clone(self),
                                ::core::clone::Clone::clone(r),
                            ));
                        }
                    )*
                    $crate::build_with_builtin_metrics(::core::clone::Clone::clone(self), metric)
                }

                fn as_any(&self) -> &dyn $crate::__private::Any {
                    self
                }
            }
        };
    };
}

/// Registers a researcher's residual metric: implements [`momo_core::MetricSpec`] for `$ty`
/// under the type tag `$name`, so that a configuration names it (`[metric] type = "$name"`)
/// and every built-in model ([`SingleTrack2d`], [`SingleTrack3d`], [`Se3`]) builds with it.
///
/// `$ty` must implement [`momo_core::ResidualMetric`], `Clone`, `serde::Serialize` and
/// `serde::Deserialize`. To combine it with your own model, list it in that model's
/// [`register_model!`](crate::register_model)`(..., metrics = [$ty])`.
///
/// ```
/// use momo_models::momo_core::{Camera, MetricSpec, ModelSpec, Observation, Pose, ResidualMetric, Scalar, essential};
/// use momo_models::{Se3, register_metric};
/// use serde::{Deserialize, Serialize};
///
/// /// The algebraic epipolar error `f1ᵀ E f0`.
/// #[derive(Clone, Debug, Default, Serialize, Deserialize)]
/// struct Algebraic;
///
/// impl ResidualMetric for Algebraic {
///     const RESIDUALS: usize = 1;
///     type Prepared<T: Scalar> = momo_models::momo_core::nalgebra::Matrix3<T>;
///     fn prepare<T: Scalar>(&self, _c: &Camera, m: &Pose<T>) -> Self::Prepared<T> {
///         essential(m)
///     }
///     fn residuals<T: Scalar>(&self, e: &Self::Prepared<T>, o: &Observation, out: &mut [T]) {
///         out[0] = o.f1.map(T::c).dot(&(e * o.f0.map(T::c)));
///     }
/// }
/// register_metric!(Algebraic, "doc_algebraic");
///
/// let metric: Box<dyn MetricSpec> = serde_json::from_str(r#"{"type": "doc_algebraic"}"#).unwrap();
/// let est = Se3.build(metric.as_ref()).unwrap();
/// assert_eq!(est.param_names().len(), 6);
/// ```
#[macro_export]
macro_rules! register_metric {
    ($ty:ty, $name:literal) => {
        const _: () = {
            use $crate::__private::typetag;

            #[typetag::serde(name = $name)]
            impl $crate::__private::MetricSpec for $ty {
                fn as_any(&self) -> &dyn $crate::__private::Any {
                    self
                }

                fn build_with_model(
                    &self,
                    model: &dyn $crate::__private::ModelSpec,
                ) -> ::core::option::Option<
                    $crate::__private::Box<dyn $crate::__private::FrameEstimator>,
                > {
                    $crate::build_with_builtin_models(model, ::core::clone::Clone::clone(self))
                }
            }
        };
    };
}

crate::register_model!(SingleTrack2d, "single_track_2d");
crate::register_model!(SingleTrack3d, "single_track_3d");
crate::register_model!(Se3, "se3");
crate::register_model!(SoftSingleTrack, "soft_single_track");

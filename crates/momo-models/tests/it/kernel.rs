//! Fused metric kernels (`ResidualMetric::kernel`) against the automatic path (num-dual through
//! `ResidualMetric::residuals`, `Problem::with_automatic(true)`): the same linearisation, cost
//! bit-identical and gradient and normal matrix to about 1e-12 relative, for random motions,
//! matches (inliers, outliers, noise), models, rigs, losses, fixed parameters and priors.

use momo_core::{
    LeastSquares, Linearization, Manifold, MotionPrior, Pose, Problem, ResidualMetric, Rig,
    RobustLoss, RotationOnly, so3_exp,
};
use momo_costs::{AnglePlane, AnglePlaneMl, Cauchy, Huber, Trivial, Tukey};
use momo_models::{Se3, SingleTrack2d, SingleTrack3d, SoftSingleTrack};
use momo_testing::canned;
use nalgebra::Vector3;
use proptest::prelude::*;

/// Largest entry-wise difference relative to the size of the automatic result: the normal
/// matrix's largest entry, and for the gradient the larger of its largest entry and the
/// Cauchy-Schwarz bound on its terms, `sqrt(max|H| · 2 cost)` (`|Σ wᵢ Jᵢ rᵢ| ≤ sqrt(Σ wᵢ Jᵢ²)
/// sqrt(Σ wᵢ rᵢ²)`). Near a minimum the gradient is a sum of terms that cancel: there its
/// rounding error is relative to the terms, not to the sum (CI saw a gradient of 5.6e-6 made of
/// terms of ~1 differ by 2.2e-17 between the two paths, "3.9e-12 relative" to the sum).
fn relative_difference(fused: &Linearization, auto: &Linearization, n: usize) -> f64 {
    let h_scale = auto
        .hessian
        .view((0, 0), (n, n))
        .amax()
        .max(f64::MIN_POSITIVE);
    let term_bound = (h_scale * 2.0 * auto.cost.abs()).sqrt();
    let g_scale = auto
        .gradient
        .rows(0, n)
        .amax()
        .max(term_bound)
        .max(f64::MIN_POSITIVE);
    let dg = (fused.gradient - auto.gradient).rows(0, n).amax() / g_scale;
    let dh = (fused.hessian - auto.hessian).view((0, 0), (n, n)).amax() / h_scale;
    dg.max(dh)
}

/// Linearises with the kernel and with automatic differentiation, checks they agree, returns
/// the relative difference.
fn compare<M: Manifold, R: ResidualMetric>(
    model: &M,
    metric: &R,
    loss: &dyn RobustLoss,
    rig: &Rig,
    obs: &momo_core::FrameObservations,
    params: &[f64],
    fixed: &[bool],
    prior: Option<&MotionPrior>,
) -> Result<f64, TestCaseError> {
    let fused = Problem::new(model, metric, loss, rig, obs, params)
        .map_err(|e| TestCaseError::fail(e.to_string()))?
        .with_fixed(fixed)
        .with_motion_prior(prior);
    prop_assert!(fused.uses_kernel());
    let auto = fused.clone().with_automatic(true);
    prop_assert!(!auto.uses_kernel());
    let x = fused.free_params();
    let n = fused.num_params();
    let (lf, la) = (fused.linearize(&x), auto.linearize(&x));
    // The kernel computes the residuals as the dual numbers' real part does.
    prop_assert_eq!(lf.cost.to_bits(), la.cost.to_bits());
    // The cost evaluation with the metric's per-match constants cached once per problem
    // (`ResidualMetric::MATCH_CONSTANTS`, `residuals_with`) is the one recomputing them in
    // `residuals` (the automatic problem never caches), bit for bit; twice, so that the second
    // evaluation reads the cache the first one filled.
    for _ in 0..2 {
        prop_assert_eq!(fused.cost(&x).to_bits(), auto.cost(&x).to_bits());
    }
    if !la.cost.is_finite() {
        // Where the cost is undefined (a soft model's prior in units of a trivial loss's
        // infinite scale) both paths say so, entry by entry.
        let pattern = |l: &Linearization| l.hessian.map(f64::is_finite);
        prop_assert_eq!(pattern(&lf), pattern(&la));
        return Ok(0.0);
    }
    let (kf, ka) = (
        fused.linearize_known_cost(&x, 1.0),
        auto.linearize_known_cost(&x, 1.0),
    );
    let d = relative_difference(&lf, &la, n).max(relative_difference(&kf, &ka, n));
    prop_assert!(
        d <= 1e-12,
        "fused and automatic differ by {d:e} relative:\n{lf:?}\n{la:?}"
    );
    Ok(d)
}

fn loss(kind: usize, scale: f64) -> Box<dyn RobustLoss> {
    match kind {
        0 => Box::new(Trivial),
        1 => Box::new(Cauchy::new(scale)),
        2 => Box::new(Huber::new(scale)),
        _ => Box::new(Tukey::new(3.0 * scale)),
    }
}

/// A vehicle motion: 0.1 to 3 m, a few degrees of yaw, some pitch and roll.
fn motion() -> impl Strategy<Value = Pose<f64>> {
    (
        0.1..3.0f64,
        -0.3..0.3f64,
        -0.2..0.2f64,
        -0.05..0.05f64,
        -0.05..0.05f64,
        -0.3..0.3f64,
    )
        .prop_map(|(x, y, z, wx, wy, wz)| {
            Pose::new(so3_exp(&Vector3::new(wx, wy, wz)), Vector3::new(x, y, z))
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// AnglePlane's kernel on every built-in model, both canned rigs, every loss, at a start
    /// off the true motion (so that residuals, weights and the Triggs correction all matter),
    /// with the arc length fixed or free, with and without a motion prior.
    #[test]
    fn angle_plane_kernel_equals_automatic(
        truth in motion(),
        start in motion(),
        seed in 0u64..1000,
        outliers in 0usize..20,
        loss_kind in 0usize..4,
        scale in 1e-4..1e-2f64,
        fisheye in any::<bool>(),
        fix_arc in any::<bool>(),
        with_prior in any::<bool>(),
    ) {
        let rig = if fisheye { canned::fisheye_rig() } else { canned::pinhole_rig() };
        let obs = canned::synthetic_observations(&rig, &truth, 40, outliers, seed);
        let loss = loss(loss_kind, scale);
        let loss = loss.as_ref();
        every_model(&AnglePlane, &start, &rig, &obs, loss, fix_arc, with_prior)?;
        // The comparison is not empty: away from a redescending loss's cut-off, the
        // linearisation has a normal matrix.
        if loss_kind != 3 {
            let p = Problem::new(&Se3, &AnglePlane, loss, &rig, &obs, &[0.0, 0.0, 0.01, 0.0, 0.0, 1.0])
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(p.linearize(&p.free_params()).hessian.amax() > 0.0);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// AnglePlaneMl's kernel (issue 14), as AnglePlane's above: every built-in model, both
    /// canned rigs (its pixel-noise weights differ most on the fisheye), every loss, a start off
    /// the true motion, the arc length fixed or free, with and without a motion prior.
    #[test]
    fn angle_plane_ml_kernel_equals_automatic(
        truth in motion(),
        start in motion(),
        seed in 0u64..1000,
        outliers in 0usize..20,
        loss_kind in 0usize..4,
        scale in 1e-4..1e-2f64,
        fisheye in any::<bool>(),
        fix_arc in any::<bool>(),
        with_prior in any::<bool>(),
    ) {
        let rig = if fisheye { canned::fisheye_rig() } else { canned::pinhole_rig() };
        let obs = canned::synthetic_observations(&rig, &truth, 40, outliers, seed);
        let loss = loss(loss_kind, scale);
        let loss = loss.as_ref();
        every_model(&AnglePlaneMl, &start, &rig, &obs, loss, fix_arc, with_prior)?;
    }
}

/// [`run`] on every built-in model with `metric`.
#[allow(clippy::too_many_arguments)]
fn every_model<R: ResidualMetric>(
    metric: &R,
    start: &Pose<f64>,
    rig: &Rig,
    obs: &momo_core::FrameObservations,
    loss: &dyn RobustLoss,
    fix_arc: bool,
    with_prior: bool,
) -> Result<(), TestCaseError> {
    run(&Se3, metric, start, rig, obs, loss, fix_arc, with_prior)?;
    run(
        &SingleTrack2d,
        metric,
        start,
        rig,
        obs,
        loss,
        fix_arc,
        with_prior,
    )?;
    run(
        &SingleTrack3d::default(),
        metric,
        start,
        rig,
        obs,
        loss,
        fix_arc,
        with_prior,
    )?;
    run(
        &SoftSingleTrack::default(),
        metric,
        start,
        rig,
        obs,
        loss,
        fix_arc,
        with_prior,
    )?;
    Ok(())
}

/// One model: parameters from the start motion where it has a closed form, else neutral.
#[allow(clippy::too_many_arguments)]
fn run<M: Manifold, R: ResidualMetric>(
    model: &M,
    metric: &R,
    start: &Pose<f64>,
    rig: &Rig,
    obs: &momo_core::FrameObservations,
    loss: &dyn RobustLoss,
    fix_arc: bool,
    with_prior: bool,
) -> Result<f64, TestCaseError> {
    let mut params = model
        .params_from_motion(start)
        .unwrap_or_else(|| model.initial_params(start.translation.norm()));
    // Off the closed form a little, so that no parameter sits exactly where it was derived.
    for (i, p) in params.iter_mut().enumerate() {
        *p += 1e-3 * (i as f64 + 1.0);
    }
    let mut fixed = vec![false; params.len()];
    if let (true, Some(i)) = (fix_arc, M::ARC_LENGTH) {
        fixed[i] = true;
    }
    let prior = MotionPrior {
        center: params.iter().map(|p| p + 0.01).collect(),
        inv_sigma: vec![10.0; params.len()],
        rotation_center: [0.0, 0.0, 0.01],
        rotation_inv_sigma: 50.0,
        scale: 1e-3,
        ..MotionPrior::default()
    };
    compare(
        model,
        metric,
        loss,
        rig,
        obs,
        &params,
        &fixed,
        with_prior.then_some(&prior),
    )
}

/// The rotation-only metric's kernel (standstill), with the translation parameters fixed.
#[test]
fn rotation_only_kernel_equals_automatic() {
    let rig = canned::fisheye_rig();
    for seed in 0..20u64 {
        let w = Vector3::new(0.01, -0.02, 0.03) * (seed as f64 / 10.0 - 1.0);
        let truth = Pose::new(so3_exp(&w), Vector3::new(0.5, 0.0, 0.0));
        let obs = canned::synthetic_observations(&rig, &truth, 30, 5, seed);
        let params = [0.01, -0.02, 0.015, 0.02, 0.01, 0.0];
        let fixed = [false, false, false, true, true, true];
        let loss = Cauchy::new(1e-3);
        let d = compare(
            &Se3,
            &RotationOnly,
            &loss,
            &rig,
            &obs,
            &params,
            &fixed,
            None,
        );
        assert!(d.is_ok(), "seed {seed}: {d:?}");
    }
}

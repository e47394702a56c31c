//! The soft manifold and the motion prior inside the problem: their normal equations agree
//! with the cost they add.

use momo_core::{LeastSquares, Manifold, MotionPrior, ParamVec, Problem, ResidualMetric};
use momo_costs::{AnglePlane, Cauchy};
use momo_models::{Se3, SoftSingleTrack};
use momo_testing::canned;

/// The linearisation's cost is the cost, and its gradient matches central differences of the
/// cost in every free parameter.
fn assert_gradient_matches_cost<R: ResidualMetric>(p: &Problem<'_, R>) {
    let x = p.free_params();
    let lin = p.linearize(&x);
    assert!((lin.cost - p.cost(&x)).abs() <= 1e-12 * lin.cost.abs().max(1e-300));
    for k in 0..p.num_params() {
        let h = 1e-7;
        let (mut a, mut b): (ParamVec, ParamVec) = (x, x);
        a[k] += h;
        b[k] -= h;
        let fd = (p.cost(&a) - p.cost(&b)) / (2.0 * h);
        let g = lin.gradient[k];
        assert!(
            (g - fd).abs() <= 1e-4 * fd.abs().max(1e-9),
            "parameter {k}: gradient {g:e}, finite differences {fd:e}"
        );
    }
}

/// The gradient of the linearisation (`Jᵀr`, Ceres-corrected for the loss) is the gradient of
/// the cost, priors included: central differences of `cost` agree with it.
#[test]
fn gradient_matches_the_cost_with_priors() {
    let rig = canned::pinhole_rig();
    let truth = [0.002, -0.004, 0.03, 0.025, -0.003, 1.2];
    let obs = canned::synthetic_observations(&rig, &Se3.motion(&truth), 60, 10, 7);
    let model = SoftSingleTrack {
        side_slip_sigma: 0.004,
        climb_sigma: 0.006,
        slip_distance_sigma: 0.005,
        climb_distance_sigma: 0.0,
    };
    let loss = Cauchy::new(0.001);
    let prior = MotionPrior {
        center: vec![0.0, 0.0, 0.02, 0.01, 0.0, 1.2],
        inv_sigma: vec![200.0, 200.0, 500.0, 0.0, 100.0, 0.0],
        rotation_center: [0.002, -0.001, 0.015],
        rotation_inv_sigma: 300.0,
        soft_center: vec![0.5, -0.3],
        soft_inv_scale: vec![0.5, 0.25],
        soft_cauchy: Vec::new(),
        scale: 0.0,
    };
    let start = [0.001, 0.002, 0.025, 0.03, 0.001, 1.2];
    let p = Problem::new(&model, &AnglePlane, &loss, &rig, &obs, &start)
        .unwrap()
        .with_fixed(&[false, false, false, false, false, true])
        .with_motion_prior(Some(&prior));
    let x = p.free_params();
    assert_gradient_matches_cost(&p);
    // The priors add to the cost: the same problem without them costs less here.
    let plain = Problem::new(&Se3, &AnglePlane, &loss, &rig, &obs, &start)
        .unwrap()
        .with_fixed(&[false, false, false, false, false, true]);
    assert!(plain.cost(&x) < p.cost(&x));
    let prior_only = p.prior_cost(&p.full_params(&x));
    assert!((plain.cost(&x) + prior_only - p.cost(&x)).abs() <= 1e-12 * p.cost(&x));
    // The soft centre moves the model prior: the same prior without it costs differently.
    let uncentred = MotionPrior {
        soft_center: Vec::new(),
        ..prior.clone()
    };
    let q = Problem::new(&model, &AnglePlane, &loss, &rig, &obs, &start)
        .unwrap()
        .with_fixed(&[false, false, false, false, false, true])
        .with_motion_prior(Some(&uncentred));
    assert!((q.cost(&x) - p.cost(&x)).abs() > 1e-3 * p.cost(&x));
}

/// A prior that constrains nothing (all inverse sigmas 0) or has the wrong length is ignored.
#[test]
fn inactive_or_mismatched_priors_are_ignored() {
    let rig = canned::pinhole_rig();
    let truth = [0.0, 0.0, 0.03, 0.015, 0.0, 1.0];
    let obs = canned::synthetic_observations(&rig, &Se3.motion(&truth), 30, 0, 3);
    let loss = Cauchy::new(0.001);
    let start = [0.0, 0.0, 0.02, 0.0, 0.0, 1.0];
    let base = Problem::new(&Se3, &AnglePlane, &loss, &rig, &obs, &start).unwrap();
    let x = base.free_params();
    for prior in [
        MotionPrior {
            center: vec![0.0; 6],
            inv_sigma: vec![0.0; 6],
            ..MotionPrior::default()
        },
        MotionPrior {
            center: vec![0.0; 2],
            inv_sigma: vec![1.0; 2],
            ..MotionPrior::default()
        },
    ] {
        let p = base.clone().with_motion_prior(Some(&prior));
        assert_eq!(p.cost(&x), base.cost(&x));
    }
}

/// The rotation part of the prior works on any model, whatever its parameters are called: on
/// `SingleTrack3d` (yaw, arc length, pitch, roll) its gradient matches the cost, and it alone
/// adds `½ s² ρ(|(log R(p) − w_c) / σ|²)` to the cost (Cauchy `ρ`).
#[test]
fn the_rotation_prior_applies_to_a_single_track_model() {
    use momo_core::{ROTATION_PRIOR_CAUCHY, so3_log};
    use momo_models::SingleTrack3d;
    let rig = canned::pinhole_rig();
    let model = SingleTrack3d::default();
    let truth = [0.03, 1.1, 0.004, -0.002];
    let obs = canned::synthetic_observations(&rig, &model.motion(&truth), 60, 10, 5);
    let loss = Cauchy::new(0.001);
    let prior = MotionPrior::rotation([0.001, 0.003, 0.01], 0.002);
    let start = [0.025, 1.1, 0.002, 0.001];
    let base = Problem::new(&model, &AnglePlane, &loss, &rig, &obs, &start)
        .unwrap()
        .with_fixed(&[false, true, false, false]);
    let p = base.clone().with_motion_prior(Some(&prior));
    let x = p.free_params();
    assert_gradient_matches_cost(&p);
    let w = so3_log(&model.motion(&start).rotation);
    let z: f64 = (0..3)
        .map(|a| ((w[a] - prior.rotation_center[a]) / 0.002).powi(2))
        .sum();
    let c2 = ROTATION_PRIOR_CAUCHY * ROTATION_PRIOR_CAUCHY;
    let expected = 0.5 * 0.001 * 0.001 * c2 * (1.0 + z / c2).ln();
    // The start is several σ from the centre: the Cauchy loss is below the Gaussian there.
    assert!(z > c2 && expected < 0.5 * 0.001 * 0.001 * z);
    let added = p.cost(&x) - base.cost(&x);
    assert!(
        (added - expected).abs() <= 1e-12 * expected,
        "{added} vs {expected}"
    );
}

/// The prior's unit is the data's noise: with `MotionPrior::scale` set, every prior term
/// (rotation change and the soft model's slip) costs the same under a wide second-stage loss
/// (Tukey 0.0075) as under the first stage's Cauchy 0.001; without it the unit is the loss scale
/// and a wide loss would weigh the prior 56 times more (it held KITTI 00 on a wrong yaw rate).
#[test]
fn the_prior_scale_keeps_the_prior_weight_across_losses() {
    use momo_costs::Tukey;
    let rig = canned::pinhole_rig();
    let model = SoftSingleTrack::default();
    let truth = [0.0, 0.0, 0.03, 0.02, 0.001, 1.0];
    let obs = canned::synthetic_observations(&rig, &Se3.motion(&truth), 30, 0, 9);
    let prior = MotionPrior {
        scale: 0.001,
        ..MotionPrior::rotation([0.0, 0.0, 0.02], 0.002)
    };
    let (cauchy, tukey) = (Cauchy::new(0.001), Tukey::new(0.0075));
    let cost = |loss: &dyn momo_core::RobustLoss, prior: &MotionPrior| {
        Problem::new(&model, &AnglePlane, loss, &rig, &obs, &truth)
            .unwrap()
            .with_motion_prior(Some(prior))
            .prior_cost(&truth)
    };
    let (a, b) = (cost(&cauchy, &prior), cost(&tukey, &prior));
    assert!(a > 0.0 && (a - b).abs() <= 1e-12 * a, "{a} vs {b}");
    let unscaled = MotionPrior {
        scale: 0.0,
        ..prior
    };
    let c = cost(&tukey, &unscaled);
    assert!((c / a - 56.25).abs() < 1e-6, "{c} / {a}");
}

/// `slip_distance_sigma`: the slip's standard deviation grows as `σ_d / s` on short steps, so
/// the same side slip costs less the shorter the step, and nothing at a standstill; at long
/// steps the prior tends to the angle-only one. Without it (`σ_d = 0`) the cost does not
/// depend on the arc length.
#[test]
fn the_slip_distance_sigma_frees_short_steps() {
    let angle_only = SoftSingleTrack::default();
    let with_distance = SoftSingleTrack {
        slip_distance_sigma: 0.02,
        ..SoftSingleTrack::default()
    };
    let slip = 0.01;
    let residual = |m: &SoftSingleTrack, s: f64| {
        let mut q = [0.0; 2];
        m.prior_residuals(&[0.0, 0.0, 0.04, 0.02 + slip, 0.0, s], &mut q);
        q[0]
    };
    for s in [0.05, 0.3, 1.0, 3.0] {
        assert!((residual(&angle_only, s) - slip / 0.01).abs() < 1e-12);
        let expected = slip / (0.01f64.powi(2) + (0.02 / s).powi(2)).sqrt();
        assert!((residual(&with_distance, s) - expected).abs() < 1e-12 * expected.abs());
    }
    assert!(residual(&with_distance, 0.05) < 0.3 * residual(&with_distance, 3.0));
    assert_eq!(residual(&with_distance, 0.0), 0.0);
    // Reversing is symmetric.
    assert!((residual(&with_distance, -0.3) - residual(&with_distance, 0.3)).abs() < 1e-15);
}

/// `climb_distance_sigma`: only the vertical slip's standard deviation grows as `σ_v / s` on
/// short steps (the side slip keeps its angle-only prior, or its own `slip_distance_sigma`);
/// at 0 the residuals are exactly the angle-only ones.
#[test]
fn the_climb_distance_sigma_frees_the_climb_of_short_steps_only() {
    let angle_only = SoftSingleTrack::default();
    let climb_only = SoftSingleTrack {
        climb_distance_sigma: 0.02,
        ..SoftSingleTrack::default()
    };
    let both = SoftSingleTrack {
        slip_distance_sigma: 0.01,
        ..climb_only
    };
    let (slip, climb) = (0.01, 0.5);
    let residuals = |m: &SoftSingleTrack, s: f64| {
        let mut q = [0.0; 2];
        m.prior_residuals(&[0.0, 0.0, 0.04, 0.02 + slip, climb, s], &mut q);
        q
    };
    for s in [0.05, 0.3, 1.0, 3.0] {
        let a = residuals(&angle_only, s);
        let c = residuals(&climb_only, s);
        let b = residuals(&both, s);
        assert_eq!(c[0], a[0], "the side slip keeps its prior at s = {s}");
        let expected = climb / (0.01f64.powi(2) + (0.02 / s).powi(2)).sqrt();
        assert!(
            (c[1] - expected).abs() < 1e-12 * expected,
            "{} vs {expected}",
            c[1]
        );
        let side = slip / (0.01f64.powi(2) + (0.01 / s).powi(2)).sqrt();
        assert!((b[0] - side).abs() < 1e-12 * side && b[1] == c[1]);
    }
    // KITTI 08's slow start: a 0.5 rad climb at 0.3 m is under a fifth of its angle-only sigmas.
    assert!(residuals(&climb_only, 0.3)[1] < 0.2 * residuals(&angle_only, 0.3)[1]);
    assert_eq!(residuals(&climb_only, 0.0)[1], 0.0);
}

/// `MotionPrior::soft_cauchy`: a soft-prior residual with a Cauchy scale `b` adds
/// `½ s² b² ln(1 + z² / b²)` (`z` its scaled residual) instead of `½ s² z²`, its linearisation
/// agrees with the cost, and a zero scale is the least-squares prior exactly.
#[test]
fn a_cauchy_soft_prior_bounds_the_pull_of_a_large_climb() {
    let rig = canned::pinhole_rig();
    let model = SoftSingleTrack::default();
    // A step climbing by 0.5 rad at a level body: the climb residual is 50 sigmas.
    let truth = [0.0, 0.0, 0.02, 0.01, 0.5, 0.3];
    let obs = canned::synthetic_observations(&rig, &Se3.motion(&truth), 60, 0, 3);
    let loss = Cauchy::new(0.001);
    let quadratic = MotionPrior {
        scale: 0.001,
        ..MotionPrior::rotation([0.0, 0.0, 0.02], 0.002)
    };
    let zeros = MotionPrior {
        soft_cauchy: vec![0.0, 0.0],
        ..quadratic.clone()
    };
    let robust = MotionPrior {
        soft_cauchy: vec![0.0, 3.0],
        ..quadratic.clone()
    };
    let base = Problem::new(&model, &AnglePlane, &loss, &rig, &obs, &truth)
        .unwrap()
        .with_fixed(&[false, false, false, false, false, true]);
    let (pq, pz, pr) = (
        base.clone().with_motion_prior(Some(&quadratic)),
        base.clone().with_motion_prior(Some(&zeros)),
        base.clone().with_motion_prior(Some(&robust)),
    );
    let x = pq.free_params();
    assert_eq!(pz.prior_cost(&truth), pq.prior_cost(&truth));
    assert_eq!(pz.cost(&x), pq.cost(&x));
    let mut q = [0.0; 2];
    model.prior_residuals(&truth, &mut q);
    let (zs, zc) = (q[0], q[1]);
    assert!(zc > 40.0);
    let s2 = 0.001f64 * 0.001;
    let expected = 0.5 * s2 * zs * zs + 0.5 * s2 * 9.0 * (zc * zc / 9.0).ln_1p();
    let rotation = pq.prior_cost(&truth) - 0.5 * s2 * (zs * zs + zc * zc);
    let added = pr.prior_cost(&truth) - rotation;
    assert!(
        (added - expected).abs() <= 1e-9 * expected,
        "{added} vs {expected}"
    );
    assert!(pr.prior_cost(&truth) < 0.05 * pq.prior_cost(&truth));
    // Away from the data's minimum, the linearisation agrees with the Cauchy prior's cost.
    let start = [0.001, -0.002, 0.025, 0.015, 0.45, 0.3];
    let off = Problem::new(&model, &AnglePlane, &loss, &rig, &obs, &start)
        .unwrap()
        .with_fixed(&[false, false, false, false, false, true])
        .with_motion_prior(Some(&robust));
    assert_gradient_matches_cost(&off);
}

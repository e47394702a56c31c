//! The soft manifold and the motion prior inside the problem: their normal equations agree
//! with the cost they add.

use momo_core::{LeastSquares, Manifold, MotionPrior, ParamVec, Problem};
use momo_costs::{AnglePlane, Cauchy, canned};
use momo_models::{Se3, SoftSingleTrack};

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
    };
    let loss = Cauchy::new(0.001);
    let prior = MotionPrior {
        center: vec![0.0, 0.0, 0.02, 0.01, 0.0, 1.2],
        inv_sigma: vec![200.0, 200.0, 500.0, 0.0, 100.0, 0.0],
    };
    let start = [0.001, 0.002, 0.025, 0.03, 0.001, 1.2];
    let p = Problem::new(&model, &AnglePlane, &loss, &rig, &obs, &start)
        .unwrap()
        .with_fixed(&[false, false, false, false, false, true])
        .with_motion_prior(Some(&prior));
    let x = p.free_params();
    let lin = p.linearize(&x);
    assert!((lin.cost - p.cost(&x)).abs() <= 1e-12 * lin.cost.abs().max(1e-300));
    for k in 0..5 {
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
    // The priors add to the cost: the same problem without them costs less here.
    let plain = Problem::new(&Se3, &AnglePlane, &loss, &rig, &obs, &start)
        .unwrap()
        .with_fixed(&[false, false, false, false, false, true]);
    assert!(plain.cost(&x) < p.cost(&x));
    let prior_only = p.prior_cost(&p.full_params(&x));
    assert!((plain.cost(&x) + prior_only - p.cost(&x)).abs() <= 1e-12 * p.cost(&x));
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
        },
        MotionPrior {
            center: vec![0.0; 2],
            inv_sigma: vec![1.0; 2],
        },
    ] {
        let p = base.clone().with_motion_prior(Some(&prior));
        assert_eq!(p.cost(&x), base.cost(&x));
    }
}

//! Robust losses: values, derivatives against finite differences, serde.

use momo_core::RobustLoss;
use momo_core::check::check_loss_derivatives;
use momo_costs::{Cauchy, Huber, Trivial, Tukey};
use proptest::prelude::*;

const SCALES: [f64; 6] = [0.001, 0.002, 0.0065, 0.05, 1.0, 3.0];

fn losses(b: f64) -> [Box<dyn RobustLoss>; 3] {
    [
        Box::new(Cauchy::new(b)),
        Box::new(Huber::new(b)),
        Box::new(Tukey::new(b)),
    ]
}

/// `1e-6` plus the rounding noise of the central differences: `check_loss_derivatives` steps by
/// `h = 1e-6 max(s, 1e-6)`, and `ρ(s ± h)`, `ρ'(s ± h)` carry rounding errors of `ε |ρ|`,
/// `ε |ρ'|`, so the difference quotients are only good to about `ε |ρ| / (h |ρ'|)` and
/// `ε |ρ'| / (h |ρ''|)` relative (up to ~1e-2 for s = 1e-10 with b = 3, where ρ'' = -1/b² is
/// small, or for Tukey just below its kink, where ρ' vanishes).
fn fd_tolerance(loss: &dyn RobustLoss, s: f64) -> f64 {
    let [rho, d1, d2] = loss.evaluate(s);
    let h = 1e-6 * s.max(1e-6);
    let mut tol = 1e-6;
    if d1 != 0.0 {
        tol += 4.0 * f64::EPSILON * rho.abs() / (h * d1.abs());
    }
    if d2 != 0.0 {
        tol += 4.0 * f64::EPSILON * d1.abs() / (h * d2.abs());
    }
    tol
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// ρ' and ρ'' equal central differences of ρ and ρ' over s in [1e-10, 1e2] (log-uniform),
    /// away from the kink of Huber and Tukey at s = b².
    #[test]
    fn derivatives_match_finite_differences(log_s in -10.0f64..2.0, k in 0usize..SCALES.len()) {
        let s = 10f64.powf(log_s);
        let b = SCALES[k];
        let b2 = b * b;
        for (i, loss) in losses(b).iter().enumerate() {
            if i > 0 && (s / b2 - 1.0).abs() < 1e-4 {
                continue; // the kink
            }
            let r = check_loss_derivatives(loss.as_ref(), s, fd_tolerance(loss.as_ref(), s));
            prop_assert!(r.is_ok(), "{loss:?} at s = {s:e}: {r:?}");
        }
    }

    /// Ceres conventions: ρ(s) ≈ s and ρ' ≈ 1 near zero, ρ non-decreasing, ρ' in [0, 1].
    #[test]
    fn ceres_conventions(log_s in -10.0f64..2.0, k in 0usize..SCALES.len()) {
        let s = 10f64.powf(log_s);
        for loss in losses(SCALES[k]) {
            let [rho, d1, _] = loss.evaluate(s);
            prop_assert!(rho <= s * (1.0 + 1e-12), "{loss:?}: robust losses never exceed s");
            prop_assert!((0.0..=1.0).contains(&d1));
            let [rho2, _, _] = loss.evaluate(s * 1.01);
            prop_assert!(rho2 >= rho);
            prop_assert_eq!(loss.evaluate(0.0)[..2].to_vec(), vec![0.0, 1.0]);
        }
    }
}

/// A tighter check at the scales the tool uses (angle_plane ~0.002, pixels ~1).
#[test]
fn derivatives_tight_at_typical_points() {
    for b in [0.002, 0.0065, 1.0] {
        for f in [1e-3, 0.1, 0.5, 2.0, 10.0, 100.0] {
            let s = f * b * b;
            for loss in losses(b) {
                let e = check_loss_derivatives(loss.as_ref(), s, 1e-6);
                assert!(e.is_ok(), "{loss:?} at s = {s:e}: {e:?}");
            }
        }
    }
}

#[test]
fn closed_form_values() {
    let b: f64 = 0.5;
    let b2 = b * b;
    // Cauchy
    let [r, d1, d2] = Cauchy::new(b).evaluate(b2);
    assert!((r - b2 * 2f64.ln()).abs() < 1e-15);
    assert!((d1 - 0.5).abs() < 1e-15 && (d2 + 0.25 / b2).abs() < 1e-15);
    // Huber: continuous at the kink, linear beyond
    let h = Huber::new(b);
    assert_eq!(h.evaluate(b2), [b2, 1.0, 0.0]);
    let [r, d1, d2] = h.evaluate(4.0 * b2);
    assert!((r - (2.0 * b * 2.0 * b - b2)).abs() < 1e-15);
    assert!((d1 - 0.5).abs() < 1e-15 && (d2 + 0.5 * 0.5 / (4.0 * b2)).abs() < 1e-15);
    // Tukey: saturates at b²/3 with zero influence
    let t = Tukey::new(b);
    assert!((t.evaluate(b2)[0] - b2 / 3.0).abs() < 1e-15);
    assert_eq!(t.evaluate(2.0 * b2), [b2 / 3.0, 0.0, 0.0]);
    let [_, d1, d2] = t.evaluate(0.5 * b2);
    assert!((d1 - 0.25).abs() < 1e-15 && (d2 + 1.0 / b2).abs() < 1e-15);
    // Trivial
    assert_eq!(Trivial.evaluate(3.0), [3.0, 1.0, 0.0]);
    assert_eq!(Trivial.scale(), f64::INFINITY);
}

#[test]
fn scales_and_defaults() {
    assert_eq!(Cauchy::default().scale(), 0.002);
    assert_eq!(Huber::default().scale(), Huber::DEFAULT_SCALE);
    assert_eq!(Tukey::default().scale(), Tukey::DEFAULT_SCALE);
    assert_eq!(Cauchy::new(0.0065).scale(), 0.0065);
}

#[test]
#[should_panic(expected = "finite and positive")]
fn non_positive_scale_panics() {
    let _ = Cauchy::new(0.0);
}

#[test]
fn json_and_toml_deserialize_into_trait_objects() {
    let j: Box<dyn RobustLoss> =
        serde_json::from_str(r#"{"type": "cauchy", "scale": 0.0065}"#).unwrap();
    assert_eq!(j.scale(), 0.0065);
    assert_eq!(j.evaluate(1e-4), Cauchy::new(0.0065).evaluate(1e-4));
    let t: Box<dyn RobustLoss> = toml::from_str("type = \"cauchy\"\nscale = 0.0065").unwrap();
    assert_eq!(t.scale(), 0.0065);
    assert_eq!(t.evaluate(1e-4), Cauchy::new(0.0065).evaluate(1e-4));

    for (src, scale) in [
        (r#"{"type": "huber", "scale": 1.5}"#, 1.5),
        (r#"{"type": "tukey", "scale": 4.0}"#, 4.0),
        (r#"{"type": "cauchy"}"#, Cauchy::DEFAULT_SCALE),
        (r#"{"type": "trivial"}"#, f64::INFINITY),
    ] {
        let l: Box<dyn RobustLoss> = serde_json::from_str(src).unwrap();
        assert_eq!(l.scale(), scale, "{src}");
    }
}

#[test]
fn bad_configurations_are_rejected() {
    for src in [
        r#"{"type": "cauchy", "scale": -1.0}"#,
        r#"{"type": "huber", "scale": 0.0}"#,
        r#"{"type": "tukey", "scale": 1.0, "width": 2.0}"#,
        r#"{"type": "welsch", "scale": 1.0}"#,
    ] {
        let r: Result<Box<dyn RobustLoss>, _> = serde_json::from_str(src);
        assert!(r.is_err(), "{src} should be rejected");
    }
}

#[test]
fn json_and_toml_round_trips() {
    let all: Vec<Box<dyn RobustLoss>> = vec![
        Box::new(Cauchy::new(0.0065)),
        Box::new(Huber::new(1.25)),
        Box::new(Tukey::new(3.5)),
        Box::new(Trivial),
    ];
    for l in all {
        let j = serde_json::to_string(&l).unwrap();
        let back: Box<dyn RobustLoss> = serde_json::from_str(&j).unwrap();
        assert_eq!(format!("{back:?}"), format!("{l:?}"), "{j}");
        let t = toml::to_string(&l).unwrap();
        let back: Box<dyn RobustLoss> = toml::from_str(&t).unwrap();
        assert_eq!(format!("{back:?}"), format!("{l:?}"), "{t}");
        assert!(t.starts_with("type = "), "{t}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// The four-lane evaluations (`evaluate_lanes`, `weights_lanes`, used by the fused
    /// linearisation) equal the per-value ones bit for bit, on both sides of every loss's kink
    /// and at zero.
    #[test]
    fn lanes_are_the_per_value_evaluations_bit_for_bit(
        e in proptest::array::uniform4(-14.0..3.0f64),
        zero in 0usize..5,
        scale in 0usize..SCALES.len(),
    ) {
        let b = SCALES[scale];
        let mut s = e.map(|e| b * b * 10f64.powf(e) * 10.0);
        if zero < 4 {
            s[zero] = 0.0;
        }
        let trivial: Box<dyn RobustLoss> = Box::new(Trivial);
        for loss in losses(b).iter().chain([&trivial]) {
            let lanes = loss.evaluate_lanes(&s);
            let weights = loss.weights_lanes(&s);
            for l in 0..4 {
                let want = loss.evaluate(s[l]).map(f64::to_bits);
                prop_assert_eq!(lanes[l].map(f64::to_bits), want, "{:?} at {}", loss, s[l]);
                let want = loss.weights(s[l]).map(f64::to_bits);
                prop_assert_eq!(weights[l].map(f64::to_bits), want, "{:?} at {}", loss, s[l]);
            }
        }
    }
}

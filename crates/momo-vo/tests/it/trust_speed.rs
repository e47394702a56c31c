//! The trust checks' fast paths (issue 19) against their reference definitions: the median
//! flow test without angles or sorting, the spread of a solver's inlier mask, and the spread
//! summed per camera.

use momo_core::{FrameObservations, Observation, Pose, so3_exp};
use momo_testing::canned;
use momo_vo::trust::{median_flow, median_flow_below, spread, spread_of_mask};
use nalgebra::{Vector2, Vector3};

/// A deterministic generator (SplitMix64) of uniform numbers in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` matches with bearings around the optical axis and flows spread around `flow` (radians,
/// log-uniform over two decades), some of them not of unit length.
fn matches(n: usize, flow: f64, rng: &mut Rng) -> Vec<Observation> {
    (0..n)
        .map(|_| {
            let f0 = Vector3::new(rng.next() - 0.5, rng.next() - 0.5, 1.0).normalize();
            let angle = flow * 10f64.powf(2.0 * rng.next() - 1.0);
            let axis = Vector3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
            let f1 = so3_exp(&(axis.normalize() * angle)) * f0;
            let scale = if rng.next() < 0.3 {
                1.0 + rng.next()
            } else {
                1.0
            };
            Observation {
                px0: Vector2::zeros(),
                px1: Vector2::zeros(),
                f0: f0 * scale,
                f1,
            }
        })
        .collect()
}

#[test]
fn median_flow_below_agrees_with_the_median() {
    let mut rng = Rng(7);
    let mut checked = 0;
    for case in 0..400 {
        let cameras = 1 + case % 3;
        let mut obs = FrameObservations::new(cameras);
        for list in &mut obs.per_camera {
            *list = matches(case % 17, 1e-3, &mut rng);
        }
        let median = median_flow(&obs);
        for threshold in [0.0, 1e-4, 5e-4, 1e-3, 2e-3, 1e-2, 0.9] {
            let fast = median_flow_below(&obs, threshold);
            assert_eq!(
                fast,
                median.map(|m| m < threshold),
                "case {case}, threshold {threshold}, median {median:?}"
            );
            checked += usize::from(fast == Some(true));
        }
    }
    assert!(checked > 100, "both outcomes are exercised: {checked}");
    assert_eq!(median_flow_below(&FrameObservations::new(2), 1e-3), None);
}

#[test]
fn spread_of_a_mask_is_the_spread_of_the_marked_matches() {
    for (rig, per_camera) in [(canned::pinhole_rig(), 200), (canned::fisheye_rig(), 60)] {
        let motion = Pose::new(
            so3_exp(&Vector3::new(0.0, 0.0, 0.02)),
            Vector3::new(1.0, 0.01, 0.0),
        );
        let obs = canned::synthetic_observations(&rig, &motion, per_camera, 10, 3);
        let mut rng = Rng(11);
        let mask: Vec<bool> = obs
            .per_camera
            .iter()
            .flatten()
            .map(|_| rng.next() < 0.7)
            .collect();
        let mut offsets = vec![0];
        for list in &obs.per_camera {
            offsets.push(offsets.last().copied().unwrap_or(0) + list.len());
        }
        let reference = spread(&rig, &obs, |j, i| mask[offsets[j] + i]).expect("enough");
        let fast = spread_of_mask(&rig, &obs, &mask).expect("enough");
        assert_eq!(reference, fast);
        // Against the definition: eigenvalues of the mean outer product of the rotated unit
        // bearings.
        let mut outer = nalgebra::Matrix3::zeros();
        let mut n = 0;
        for (j, list) in obs.per_camera.iter().enumerate() {
            let r = rig.cameras()[j].t_vehicle_camera.rotation;
            for (i, o) in list.iter().enumerate() {
                if mask[offsets[j] + i] {
                    let f = r * o.f0.normalize();
                    outer += f * f.transpose();
                    n += 1;
                }
            }
        }
        let mut ev: Vec<f64> = (outer / n as f64)
            .symmetric_eigenvalues()
            .iter()
            .map(|v| v.max(0.0))
            .collect();
        ev.sort_by(|a, b| b.total_cmp(a));
        assert!(
            (fast.extent - ev[1].sqrt()).abs() < 1e-12,
            "{fast:?} {ev:?}"
        );
        assert!((fast.width - ev[2].sqrt()).abs() < 1e-12, "{fast:?} {ev:?}");
        // A mask of one match is too few.
        let one: Vec<bool> = (0..mask.len()).map(|k| k == 0).collect();
        assert_eq!(spread_of_mask(&rig, &obs, &one), None);
    }
}

#[test]
fn dedupe_keeps_the_first_of_each_repeated_match() {
    let mut rng = Rng(5);
    for case in 0..200 {
        let mut obs = FrameObservations::new(1 + case % 3);
        for list in &mut obs.per_camera {
            let n = case % 40;
            // Few distinct pixels, so that repeats are common; bits such as -0.0 and 0.0 differ.
            for _ in 0..n {
                let v = |rng: &mut Rng| [0.0, -0.0, 1.5, 2.0][(rng.next() * 4.0) as usize];
                let px0 = Vector2::new(v(&mut rng), v(&mut rng));
                let px1 = Vector2::new(v(&mut rng), 3.0);
                list.push(Observation {
                    px0,
                    px1,
                    f0: Vector3::z(),
                    f1: Vector3::z(),
                });
            }
        }
        let bits = |o: &Observation| [o.px0.x, o.px0.y, o.px1.x, o.px1.y].map(f64::to_bits);
        let mut expected = obs.clone();
        let mut expected_removed = 0;
        for list in &mut expected.per_camera {
            let mut kept: Vec<Observation> = Vec::new();
            for o in list.iter() {
                if kept.iter().any(|k| bits(k) == bits(o)) {
                    expected_removed += 1;
                } else {
                    kept.push(*o);
                }
            }
            *list = kept;
        }
        // The copy-free form: the same matches, borrowed when none repeats.
        let (distinct, removed) = momo_vo::trust::deduped(&obs);
        assert_eq!(removed, expected_removed, "case {case}");
        assert_eq!(*distinct, expected, "case {case}");
        assert_eq!(
            matches!(distinct, std::borrow::Cow::Borrowed(_)),
            expected_removed == 0,
            "case {case}"
        );
        let removed = momo_vo::trust::dedupe(&mut obs);
        assert_eq!(removed, expected_removed, "case {case}");
        assert_eq!(obs, expected, "case {case}");
    }
}

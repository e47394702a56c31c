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

/// The cells of the one-linearisation jackknife before the thirteenth session (speed28): a
/// growing vector per cell; the reference of [`momo_vo::trust::cells_alone`].
fn cells_alone_reference(
    rig: &momo_core::Rig,
    obs: &FrameObservations,
    grid: (usize, usize),
) -> Vec<FrameObservations> {
    use momo_core::CameraModel;
    let cells = grid.0.max(1) * grid.1.max(1);
    let mut out = Vec::new();
    for (j, matches) in obs.per_camera.iter().enumerate() {
        let Some(camera) = rig.cameras().get(j) else {
            continue;
        };
        let size = camera.model.size();
        let mut by_cell: Vec<Vec<Observation>> = vec![Vec::new(); cells];
        for o in matches {
            by_cell[momo_vo::trust::cell_of((o.px0.x, o.px0.y), size, grid)].push(*o);
        }
        for cell in by_cell.into_iter().filter(|c| !c.is_empty()) {
            let mut sample = FrameObservations {
                per_camera: vec![Vec::new(); obs.per_camera.len()],
                cross_camera: Vec::new(),
            };
            sample.per_camera[j] = cell;
            out.push(sample);
        }
    }
    out
}

/// [`momo_vo::trust::cells_alone`] (each cell's vector allocated at its size) gives the
/// reference's cells, match for match and in its order: frames of 0-3 cameras on the canned
/// pinhole and fisheye rigs (more cameras in the frame than in the rig: the extra ones have no
/// cells), pixels inside, on cell borders, outside the image, non-finite; grids 1x1 to 5x4 and
/// a zero count.
#[test]
fn cells_alone_matches_its_reference() {
    let mut rng = Rng(11);
    let rigs = [canned::pinhole_rig(), canned::fisheye_rig()];
    let mut cells_seen = 0;
    for case in 0..600 {
        let rig = &rigs[case % 2];
        let cameras = case % 4 + usize::from(case % 7 == 0);
        let mut obs = FrameObservations::new(cameras);
        for list in &mut obs.per_camera {
            let n = (rng.next() * 80.0) as usize;
            *list = matches(n, 1e-3, &mut rng);
            for o in list.iter_mut() {
                let pick = rng.next();
                let (x, y) = if pick < 0.8 {
                    (rng.next() * 1300.0, rng.next() * 400.0)
                } else if pick < 0.9 {
                    // On the borders of the cells of a 1241 x 376 image (KITTI) and of 4 columns.
                    ((rng.next() * 5.0).floor() * 1241.0 / 4.0, 188.0)
                } else if pick < 0.95 {
                    (-50.0 - rng.next() * 1e4, 1e6 * rng.next())
                } else {
                    let odd = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::MAX];
                    (odd[case % 4], rng.next() * 376.0)
                };
                o.px0 = Vector2::new(x, y);
            }
        }
        let grid = match case % 6 {
            0 => (3, 2),
            1 => (4, 2),
            2 => (1, 1),
            3 => (5, 4),
            4 => (0, 3),
            _ => (2, 3),
        };
        let got = momo_vo::trust::cells_alone(rig, &obs, grid);
        let want = cells_alone_reference(rig, &obs, grid);
        // Compared through their bits (NaN pixels are not equal to themselves).
        assert_eq!(format!("{got:?}"), format!("{want:?}"), "case {case}");
        for (g, w) in got.iter().zip(&want) {
            for (a, b) in g.per_camera.iter().zip(&w.per_camera) {
                assert_eq!(a.len(), b.len(), "case {case}");
            }
        }
        cells_seen += got.len();
    }
    assert!(cells_seen > 1500, "{cells_seen} cells");
}

/// [`momo_vo::trust::widen`] before the thirteenth session (speed28): heap matrices
/// throughout; the reference of the stack-matrix form.
fn widen_reference(
    base: &nalgebra::DMatrix<f64>,
    other: &nalgebra::DMatrix<f64>,
    min_ratio: f64,
) -> nalgebra::DMatrix<f64> {
    use nalgebra::{DMatrix, SymmetricEigen};
    let n = base.nrows();
    if base.iter().any(|v| !v.is_finite())
        || other.nrows() != n
        || other.iter().any(|v| !v.is_finite())
    {
        return base.clone();
    }
    let eig = SymmetricEigen::new(base.clone());
    if eig.eigenvalues.iter().any(|l| !(*l > 0.0)) {
        return base.clone();
    }
    let half = &eig.eigenvectors
        * DMatrix::from_diagonal(&eig.eigenvalues.map(f64::sqrt))
        * eig.eigenvectors.transpose();
    let inv_half = &eig.eigenvectors
        * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| 1.0 / l.sqrt()))
        * eig.eigenvectors.transpose();
    let rel = &inv_half * other * &inv_half;
    let rel = (&rel + rel.transpose()) * 0.5;
    let e = SymmetricEigen::new(rel);
    let stretched = &e.eigenvectors
        * DMatrix::from_diagonal(&e.eigenvalues.map(|l| if l > min_ratio { l } else { 1.0 }))
        * e.eigenvectors.transpose();
    let out = &half * stretched * &half;
    (&out + out.transpose()) * 0.5
}

/// [`momo_vo::trust::widen`] on stack matrices (sizes 1-5) equals the heap-matrix reference bit
/// for bit: random positive definite `base` (condition numbers up to 1e8, the scales of
/// rotation and arc-length variances) and `other` wider in some directions, sizes 1-9 (6-9: the
/// heap path), ratios 1-10; a base with an infinite or non-positive direction, or a non-finite
/// `other`, comes back as it is.
#[test]
fn widen_matches_its_reference() {
    use nalgebra::DMatrix;
    let mut rng = Rng(5);
    let mut widened = 0;
    let cases = 900;
    for case in 0..cases {
        let n = 1 + case % 9;
        let random = |rng: &mut Rng, decades: f64| {
            let a = DMatrix::from_fn(n, n, |_, _| rng.next() - 0.5);
            let q = a.qr().q();
            let d = DMatrix::from_fn(n, n, |i, j| {
                if i == j {
                    10f64.powf(-4.0 - decades * rng.next())
                } else {
                    0.0
                }
            });
            let m = &q * d * q.transpose();
            (&m + m.transpose()) * 0.5
        };
        let base = random(&mut rng, 8.0);
        let mut other = random(&mut rng, 8.0) * (0.1 + 10.0 * rng.next());
        let mut base_case = base.clone();
        match case % 13 {
            0 => base_case[(0, 0)] = f64::INFINITY,
            1 => other[(n - 1, 0)] = f64::NAN,
            2 => base_case = -base_case,
            _ => {}
        }
        let ratio = [1.0, 2.0, 10.0][case % 3];
        let got = momo_vo::trust::widen(&base_case, &other, ratio);
        let want = widen_reference(&base_case, &other, ratio);
        assert_eq!(got.shape(), want.shape(), "case {case}");
        for (g, w) in got.iter().zip(want.iter()) {
            assert_eq!(g.to_bits(), w.to_bits(), "case {case}: {g} against {w}");
        }
        widened += usize::from(got != base_case);
    }
    assert!(widened > cases / 2, "{widened} of {cases} widened");
}

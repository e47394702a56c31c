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

/// The largest entry-wise difference of `got` against `want` over the first `n` free
/// parameters, relative to the size of `want`: its normal matrix's largest entry, and for the
/// gradient the larger of its largest entry and the Cauchy-Schwarz bound on its terms
/// `sqrt(max|H| · 2 cost)` (near a minimum the gradient is a sum of terms that cancel), as the
/// kernel tests of momo-models measure it; the costs relative to the larger cost or
/// `cost_terms`. `terms`: the size of the Hessian's terms where it is larger than the Hessian
/// (the exact robust Hessian of Huber's or Cauchy's outliers is a difference of terms that
/// cancel: Huber's is 0 beyond its scale; and the reference's linearisations, prior terms
/// included, that it subtracts); `cost_terms`: the size of the costs the reference
/// took its cost as a difference of (a group's data cost is its linearisation's cost less
/// the prior terms', which can be 1e5 times larger: the reference's own rounding is relative
/// to that).
fn grouped_difference(
    got: &momo_core::Linearization,
    want: &momo_core::Linearization,
    (terms, cost_terms): (f64, f64),
    n: usize,
) -> f64 {
    let h_scale = want
        .hessian
        .view((0, 0), (n, n))
        .amax()
        .max(terms)
        .max(f64::MIN_POSITIVE);
    let g_scale = want
        .gradient
        .rows(0, n)
        .amax()
        .max((h_scale * 2.0 * want.cost.abs()).sqrt())
        .max(f64::MIN_POSITIVE);
    let dg = (got.gradient - want.gradient).rows(0, n).amax() / g_scale;
    let dh = (got.hessian - want.hessian).view((0, 0), (n, n)).amax() / h_scale;
    let dc = (got.cost - want.cost).abs()
        / got
            .cost
            .abs()
            .max(want.cost.abs())
            .max(cost_terms)
            .max(1e-300);
    dg.max(dh).max(dc)
}

/// The matches of `obs` (cameras of `rig`, camera order) whose label is `group`.
fn group_of(
    rig: &momo_core::Rig,
    obs: &FrameObservations,
    labels: &[usize],
    group: usize,
) -> FrameObservations {
    let mut out = FrameObservations::new(obs.per_camera.len());
    let mut k = 0;
    for (j, list) in obs.per_camera.iter().enumerate().take(rig.len()) {
        for o in list {
            if labels.get(k) == Some(&group) {
                out.per_camera[j].push(*o);
            }
            k += 1;
        }
    }
    out
}

/// One frame: [`momo_core::Problem::exact_data_terms_by_group`] (one pass) against the
/// separate linearisations the jackknife took before the fifteenth session (speed29): per
/// group, `2 L(ρ) - L(NegativeCurvature(ρ))` of the group's matches less the prior terms' (an
/// empty frame's linearisation), and the same of the whole frame for the total. Returns the
/// largest relative difference and the number of groups compared.
#[allow(clippy::too_many_arguments)]
fn grouped_case<R: momo_core::ResidualMetric>(
    model: &dyn momo_core::DynManifold,
    metric: &R,
    loss: &dyn momo_core::RobustLoss,
    rig: &momo_core::Rig,
    obs: &FrameObservations,
    params: &[f64],
    fixed: &[bool],
    prior: Option<&momo_core::MotionPrior>,
    automatic: bool,
    labellings: &[(Vec<usize>, usize)],
) -> (f64, usize) {
    use momo_core::{LeastSquares, Problem};
    let curvature = momo_vo::trust::NegativeCurvature::of(loss).expect("round trip");
    let lin = |o: &FrameObservations, l: &dyn momo_core::RobustLoss| {
        let p = Problem::new(model, metric, l, rig, o, params)
            .expect("problem")
            .with_fixed(fixed)
            .with_motion_prior(prior)
            .with_automatic(automatic);
        (p.linearize(&p.free_params()), p.num_params())
    };
    let empty = FrameObservations::new(obs.per_camera.len());
    let (prior_lin, n) = lin(&empty, loss);
    let separate = |o: &FrameObservations| {
        let a = lin(o, loss).0;
        let c = lin(o, &curvature).0;
        // The size of the terms: the Gauss-Newton ρ' JᵀJ and the negative curvature's, and
        // the linearisations with the prior terms the reference subtracts (its own rounding is
        // relative to them: a prior 1e3 times a cell's data terms leaves 1e-13 of them).
        let terms = (a.hessian - prior_lin.hessian)
            .amax()
            .max((c.hessian - prior_lin.hessian).amax())
            .max(a.hessian.amax())
            .max(c.hessian.amax());
        let cost_terms = a.cost.abs().max(prior_lin.cost.abs());
        let l = momo_core::Linearization {
            cost: a.cost - prior_lin.cost,
            gradient: a.gradient - prior_lin.gradient,
            hessian: momo_vo::trust::exact_hessian(&a, &c) - prior_lin.hessian,
        };
        (l, (terms, cost_terms))
    };
    let refs: Vec<(&[usize], usize)> = labellings.iter().map(|(l, g)| (l.as_slice(), *g)).collect();
    let frame = Problem::new(model, metric, loss, rig, obs, params)
        .expect("problem")
        .with_fixed(fixed)
        .with_motion_prior(prior)
        .with_automatic(automatic);
    let got = frame.exact_data_terms_by_group(&frame.free_params(), &refs);
    assert_eq!(got.groups.len(), labellings.len());
    // Where the prior terms are not finite (the trivial loss's infinite scale weighs a soft
    // model's prior residuals: the reference is NaN) there is nothing to compare; the one pass
    // leaves the prior out and stays finite.
    if !prior_lin.cost.is_finite() {
        assert!(got.total.cost.is_finite() && got.total.hessian.iter().all(|v| v.is_finite()));
        return (0.0, 0);
    }
    let (want, terms) = separate(obs);
    let mut worst = grouped_difference(&got.total, &want, terms, n);
    let mut compared = 0;
    for ((labels, groups), sums) in labellings.iter().zip(&got.groups) {
        assert_eq!(sums.len(), *groups);
        for (g, s) in sums.iter().enumerate() {
            let (want, terms) = separate(&group_of(rig, obs, labels, g));
            worst = worst.max(grouped_difference(s, &want, terms, n));
            compared += 1;
        }
    }
    (worst, compared)
}

/// [`momo_core::Problem::exact_data_terms_by_group`] equals the separate linearisations of the
/// jackknife (two per group: the loss and its negative curvature, less the prior terms) within
/// 1e-12 relative (of the reference's own terms: it subtracts the prior terms), in total and
/// per group, and [`momo_vo::trust::cell_labels`] numbers the matches as
/// [`momo_vo::trust::cells_alone`] groups them: 240 frames on the canned pinhole and fisheye
/// rigs (inliers and outliers), four models (the soft one with its prior residuals), four
/// metrics (AnglePlane's and AnglePlaneMl's fused kernels, GeoLine's two residuals on the
/// pinhole rig and Sampson's on the fisheye one by automatic differentiation) and AnglePlane
/// on the automatic path, the four losses, the arc length fixed or free, with and without a
/// motion prior; the cells of two grids and a random labelling with labels out of range.
/// Where the reference is NaN (the trivial loss's infinite scale on the soft model's prior
/// residuals) the one pass is only checked to be finite.
#[test]
fn grouped_linearisation_equals_the_separate_ones() {
    use momo_costs::{AnglePlane, AnglePlaneMl, Cauchy, GeoLine, Huber, Sampson, Trivial, Tukey};
    use momo_models::{Se3, SingleTrack2d, SingleTrack3d, SoftSingleTrack};
    let mut rng = Rng(29);
    let rigs = [canned::pinhole_rig(), canned::fisheye_rig()];
    let (mut worst, mut groups) = (0.0f64, 0usize);
    for case in 0..240 {
        let rig = &rigs[case % 2];
        let truth = Pose::new(
            so3_exp(&Vector3::new(
                0.02 * (rng.next() - 0.5),
                0.3 * (rng.next() - 0.5),
                0.02 * (rng.next() - 0.5),
            )),
            Vector3::new(
                0.2 * (rng.next() - 0.5),
                0.05 * rng.next(),
                0.3 + 2.0 * rng.next(),
            ),
        );
        let obs =
            canned::synthetic_observations(rig, &truth, 30 + case % 50, case % 15, case as u64);
        let scale = 10f64.powf(-4.0 + 2.0 * rng.next());
        let loss: Box<dyn momo_core::RobustLoss> = match case % 4 {
            0 => Box::new(Cauchy::new(scale)),
            1 => Box::new(Huber::new(scale)),
            2 => Box::new(Tukey::new(3.0 * scale)),
            _ => Box::new(Trivial),
        };
        let model: Box<dyn momo_core::DynManifold> = match case / 4 % 4 {
            0 => Box::new(Se3),
            1 => Box::new(SoftSingleTrack::default()),
            2 => Box::new(SingleTrack3d::default()),
            _ => Box::new(SingleTrack2d),
        };
        // A start off the true motion (residuals, weights and the curvature all matter).
        let mut params = model
            .params_from_motion(&truth)
            .unwrap_or_else(|| model.initial_params(truth.translation.norm()));
        for (i, p) in params.iter_mut().enumerate() {
            *p += 2e-3 * (i as f64 + 1.0) * (rng.next() - 0.5);
        }
        let mut fixed = vec![false; params.len()];
        if let (true, Some(i)) = (case % 3 == 0, model.arc_length_index()) {
            fixed[i] = true;
        }
        let prior = momo_core::MotionPrior {
            center: params.iter().map(|p| p + 0.01).collect(),
            inv_sigma: vec![10.0; params.len()],
            rotation_center: [0.0, 0.0, 0.01],
            rotation_inv_sigma: 50.0,
            scale: 1e-3,
            ..momo_core::MotionPrior::default()
        };
        let prior = (case % 5 < 3).then_some(&prior);
        // The cells of two grids as the jackknife numbers them, and a random labelling.
        let mut labellings = Vec::new();
        for grid in [(3, 2), (4, 2)] {
            let (labels, cells) = momo_vo::trust::cell_labels(rig, &obs, grid);
            let alone = momo_vo::trust::cells_alone(rig, &obs, grid);
            assert_eq!(cells, alone.len(), "case {case}");
            for (g, cell) in alone.iter().enumerate() {
                assert_eq!(group_of(rig, &obs, &labels, g), *cell, "case {case}");
            }
            labellings.push((labels, cells));
        }
        let random: Vec<usize> = (0..obs.len())
            .map(|_| (rng.next() * 6.0) as usize)
            .collect();
        labellings.push((random, 5));
        let (m, r) = (model.as_ref(), loss.as_ref());
        let runs = [
            grouped_case(
                m,
                &AnglePlane,
                r,
                rig,
                &obs,
                &params,
                &fixed,
                prior,
                false,
                &labellings,
            ),
            grouped_case(
                m,
                &AnglePlane,
                r,
                rig,
                &obs,
                &params,
                &fixed,
                prior,
                true,
                &labellings,
            ),
            grouped_case(
                m,
                &AnglePlaneMl,
                r,
                rig,
                &obs,
                &params,
                &fixed,
                prior,
                false,
                &labellings,
            ),
            if case % 2 == 0 {
                grouped_case(
                    m,
                    &GeoLine,
                    r,
                    rig,
                    &obs,
                    &params,
                    &fixed,
                    prior,
                    false,
                    &labellings,
                )
            } else {
                grouped_case(
                    m,
                    &Sampson,
                    r,
                    rig,
                    &obs,
                    &params,
                    &fixed,
                    prior,
                    false,
                    &labellings,
                )
            },
        ];
        for (d, g) in runs {
            assert!(d <= 1e-12, "case {case}: {d:e} relative");
            worst = worst.max(d);
            groups += g;
        }
    }
    assert!(groups > 10_000, "{groups} groups");
    eprintln!("one pass against the separate linearisations: {worst:e} relative, {groups} groups");
}

/// The jackknife's leave-one-cell-out steps ([`momo_vo::trust::influence_step`]) and their
/// covariance ([`momo_vo::trust::jackknife_covariance`]) from the one-pass sums
/// ([`momo_core::Problem::exact_data_terms_by_group`]) against those from the separate
/// linearisations the jackknife took before the fifteenth session (speed29: per cell, the loss
/// and its [`momo_vo::trust::NegativeCurvature`], less the prior terms), on the frames of a
/// simulated `moving_traffic` drive (5 % outliers, traffic) at the solver's minimum: the
/// default stage loss, three models (the soft one with its prior residuals), a motion prior,
/// the arc length fixed on every other frame, the cells of the default grids and of the
/// clustering test's. The same cells have a step (`H - H_c` positive definite), and where the
/// frame's exact Hessian is not near singular (condition at most 1e7) the steps agree within
/// 1e-9 of the covariance's own scale and the covariances and their sigmas within 1e-9
/// relative. The near-singular frames are not compared (about 30 of 400 covariances on this
/// drive: conditions 1.2e7-4e7 and one frame at 6e15), as both paths' rounding is amplified
/// there: on the 1e7-1e8 ones the sigmas differed by up to 2.8e-8 relative, the covariances
/// by up to 9.5e-10 of their largest entry.
#[test]
fn one_pass_jackknife_equals_the_separate_linearisations() {
    use momo_core::{LeastSquares, Problem};
    use momo_costs::AnglePlane;
    use momo_models::{Se3, SingleTrack3d, SoftSingleTrack};
    use momo_vo::trust::{
        NegativeCurvature, cell_labels, cells_alone, exact_hessian, influence_step,
        jackknife_covariance,
    };
    let mut cfg = momo_sim::SimConfig::moving_traffic();
    cfg.frames = 40;
    cfg.seed = 5;
    let sim = momo_sim::simulate(&cfg).expect("simulated");
    let seq = &sim.sequence;
    let rig = &seq.rig;
    let config = momo_vo::Config::default();
    let loss = config
        .refine_loss
        .as_deref()
        .unwrap_or(config.loss.as_ref());
    let curvature = NegativeCurvature::of(loss).expect("round trip");
    let grids: Vec<(usize, usize)> = config
        .trust
        .jackknife_grids
        .iter()
        .chain(&config.trust.clustering_grids)
        .map(|&[gx, gy]| (gx, gy))
        .collect();
    let models: [Box<dyn momo_core::DynManifold>; 3] = [
        Box::new(SoftSingleTrack::default()),
        Box::new(SingleTrack3d::default()),
        Box::new(Se3),
    ];
    let (mut worst_cov, mut worst_sigma, mut worst_step) = (0.0f64, 0.0f64, 0.0f64);
    let (mut steps, mut undefined, mut covariances) = (0usize, 0usize, 0usize);
    let mut ill_conditioned = 0usize;
    for k in 1..seq.num_frames() {
        let obs = &seq.frames[k];
        let empty = FrameObservations::new(obs.per_camera.len());
        for model in &models {
            let model = model.as_ref();
            let truth = sim.vehicle_motions[k];
            let start = model
                .params_from_motion(&truth)
                .unwrap_or_else(|| model.initial_params(truth.translation.norm()));
            let mut fixed = vec![false; start.len()];
            if let (true, Some(i)) = (k % 2 == 0, model.arc_length_index()) {
                fixed[i] = true;
            }
            let prior = momo_core::MotionPrior {
                center: start.iter().map(|p| p + 1e-3).collect(),
                inv_sigma: vec![20.0; start.len()],
                rotation_center: [0.0, 0.0, 0.0],
                rotation_inv_sigma: 100.0,
                scale: 1e-3,
                ..momo_core::MotionPrior::default()
            };
            macro_rules! problem {
                ($o:expr, $l:expr, $p:expr) => {
                    Problem::new(model, &AnglePlane, $l, rig, $o, $p)
                        .expect("problem")
                        .with_fixed(&fixed)
                        .with_motion_prior(Some(&prior))
                };
            }
            // The frame's minimum, as the odometry's stage solves it.
            let p0 = problem!(obs, loss, &start);
            let report = config.solver.solve(&p0, &p0.free_params());
            let params = p0.full_params(&report.x);
            let frame = problem!(obs, loss, &params);
            let x = frame.free_params();
            let n = frame.num_params();
            let theta: Vec<f64> = x.rows(0, n).iter().copied().collect();
            let lin = |o: &FrameObservations, l: &dyn momo_core::RobustLoss| {
                problem!(o, l, &params).linearize(&x)
            };
            // Before: two linearisations of the frame and two of each cell.
            let prior_lin = lin(&empty, loss);
            let a = lin(obs, loss);
            let old_h = exact_hessian(&a, &lin(obs, &curvature));
            let old_g = a.gradient;
            // Now: one pass.
            let labels: Vec<(Vec<usize>, usize)> =
                grids.iter().map(|&g| cell_labels(rig, obs, g)).collect();
            let refs: Vec<(&[usize], usize)> =
                labels.iter().map(|(l, c)| (l.as_slice(), *c)).collect();
            let data = frame.exact_data_terms_by_group(&x, &refs);
            let new_h = data.total.hessian + prior_lin.hessian;
            let new_g = data.total.gradient + prior_lin.gradient;
            for (&grid, sums) in grids.iter().zip(&data.groups) {
                let cells = cells_alone(rig, obs, grid);
                assert_eq!(cells.len(), sums.len(), "frame {k}");
                let (mut old, mut new) = (Vec::new(), Vec::new());
                for (cell, s) in cells.iter().zip(sums) {
                    let ca = lin(cell, loss);
                    let h_c = exact_hessian(&ca, &lin(cell, &curvature)) - prior_lin.hessian;
                    let g_c = ca.gradient - prior_lin.gradient;
                    let o = influence_step(&theta, (&old_h, &old_g), (&h_c, &g_c), n);
                    let m = influence_step(&theta, (&new_h, &new_g), (&s.hessian, &s.gradient), n);
                    assert_eq!(o.is_some(), m.is_some(), "frame {k}, grid {grid:?}");
                    match (o, m) {
                        (Some(o), Some(m)) => {
                            steps += 1;
                            old.push(o);
                            new.push(m);
                        }
                        _ => undefined += 1,
                    }
                }
                let (Some(co), Some(cn)) = (jackknife_covariance(&old), jackknife_covariance(&new))
                else {
                    continue;
                };
                // A frame whose exact Hessian is near singular (condition above 1e7 over the
                // free parameters: both paths' rounding, about 1e-16 of its largest entries,
                // is amplified by the condition into the weak directions) is not compared.
                let e = nalgebra::SymmetricEigen::new(old_h.view((0, 0), (n, n)).into_owned())
                    .eigenvalues;
                let smallest = e.iter().fold(f64::INFINITY, |a, b| a.min(b.abs()));
                if !(e.amax() <= 1e7 * smallest) {
                    ill_conditioned += 1;
                    continue;
                }
                covariances += 1;
                let scale = co.amax().max(f64::MIN_POSITIVE);
                worst_cov = worst_cov.max((&cn - &co).amax() / scale);
                for i in 0..n {
                    let (so, sn) = (co[(i, i)].sqrt(), cn[(i, i)].sqrt());
                    if so > 0.0 {
                        worst_sigma = worst_sigma.max((sn - so).abs() / so);
                    }
                }
                // Each step against the spread of the samples (the covariance's scale).
                let spread = scale.sqrt();
                for (o, m) in old.iter().zip(&new) {
                    for (a, b) in o.iter().zip(m) {
                        worst_step = worst_step.max((a - b).abs() / spread);
                    }
                }
            }
        }
    }
    assert!(steps > 1000, "{steps} steps");
    assert!(
        undefined > 0,
        "no cell without a step: the check is not exercised"
    );
    assert!(covariances > 100, "{covariances} covariances");
    assert!(
        ill_conditioned * 8 <= covariances,
        "{ill_conditioned} near-singular frames' covariances not compared, {covariances} compared"
    );
    assert!(worst_cov <= 1e-9, "covariance {worst_cov:e} relative");
    assert!(worst_sigma <= 1e-9, "sigma {worst_sigma:e} relative");
    assert!(worst_step <= 1e-9, "step {worst_step:e} of the spread");
    eprintln!(
        "{steps} steps, {undefined} undefined, {covariances} covariances ({ill_conditioned} \
         near-singular not compared): covariance {worst_cov:e}, sigma {worst_sigma:e}, step \
         {worst_step:e} relative"
    );
}

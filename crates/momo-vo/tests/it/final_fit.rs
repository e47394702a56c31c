//! The final efficient stage's support on the simulated `outliers` scenario (issue 14): the
//! mismatches that land near their epipolar line (residual within 3 σ̂, but a point behind a
//! camera) are left out by the cheirality test, and the estimate gets closer to the truth.

use momo_core::so3_log;
use momo_sim::{MatchLabel, SimConfig, simulate};
use momo_vo::{Config, Odometry};

/// Per frame pair: (support size - true inliers, rotation error in radians), with the final
/// stage's support reported (`first_stage_covariance = false`).
fn run(cheirality_sigmas: f64) -> Vec<(f64, f64)> {
    run_with(cheirality_sigmas, 0.0)
}

/// [`run`] with the support's parallax cap (`parallax_cap`, 0: none) as well.
fn run_with(cheirality_sigmas: f64, parallax_cap: f64) -> Vec<(f64, f64)> {
    let mut cfg = SimConfig::outliers();
    cfg.frames = 61;
    cfg.seed = 23;
    run_on(
        cfg,
        // Measured before the neighbourhood test ran on one camera (the default since the
        // forty-second session): it takes some of the support's excess out by itself.
        &format!(
            "cheirality_sigmas = {cheirality_sigmas}\nparallax_cap = {parallax_cap}\nneighbour_min_cameras = 2\n"
        ),
    )
}

/// [`run`] on the scenario `cfg` with the `[odometry.final_fit]` lines `final_fit`.
fn run_on(cfg: SimConfig, final_fit: &str) -> Vec<(f64, f64)> {
    let sim = simulate(&cfg).expect("the scenario simulates");
    let seq = &sim.sequence;
    let text = format!("[odometry.final_fit]\nfirst_stage_covariance = false\n{final_fit}");
    let config = Config::from_toml_str(&text, "ff.toml").expect("a valid configuration");
    let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
    let mut out = Vec::new();
    for k in 1..seq.num_frames() {
        let arc = seq.arc_length(k);
        let r = vo.process(&seq.frames[k], arc);
        let inliers = sim.labels[k]
            .iter()
            .flatten()
            .filter(|l| **l == MatchLabel::Inlier)
            .count();
        let err =
            so3_log(&(sim.vehicle_motions[k].rotation.transpose() * r.motion.rotation)).norm();
        out.push((r.diagnostics.inliers as f64 - inliers as f64, err));
    }
    out
}

/// The final fit's learnt loss, the soft prior's consistency widening and its trend centre
/// (the default since the twenty-third session) off, as in the default before the twenty-first
/// session (where these tests' comparisons were measured): a `run_on` suffix (it opens
/// `[odometry]` last).
const BEFORE_21: &str = "learnt_cauchy_max = 0.0\n[odometry]\nsoft_prior_consistency_frames = 0\nsoft_prior_trend_frames = 0\n";

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn the_cheirality_test_leaves_the_mismatches_behind_a_camera_out_of_the_support() {
    let off = run(0.0);
    let on = run(3.0);
    let excess = |v: &[(f64, f64)]| v.iter().map(|x| x.0).sum::<f64>() / v.len() as f64;
    let (x_off, x_on) = (excess(&off), excess(&on));
    // Without the test about 5 mismatches per frame sit in the support (and about 1 true
    // inlier is out): half of them put their point behind a camera.
    assert!(x_off > 2.5, "support excess without the test: {x_off}");
    assert!(
        x_on < 0.6 * x_off,
        "support excess {x_on} with the test, {x_off} without"
    );
    let (e_off, e_on) = (
        median(off.iter().map(|x| x.1).collect()),
        median(on.iter().map(|x| x.1).collect()),
    );
    assert!(
        e_on < 0.95 * e_off,
        "median rotation error {e_on} with, {e_off} without"
    );
}

#[test]
fn the_parallax_cap_leaves_near_mismatches_out_of_the_support() {
    let off = run_with(3.0, 0.0);
    let on = run_with(3.0, 8.0);
    let excess = |v: &[(f64, f64)]| v.iter().map(|x| x.0).sum::<f64>() / v.len() as f64;
    let (x_off, x_on) = (excess(&off), excess(&on));
    let (e_off, e_on) = (
        median(off.iter().map(|x| x.1).collect()),
        median(on.iter().map(|x| x.1).collect()),
    );
    // Measured (seed 23): excess 1.57 -> 1.40 per frame, median error -2.6 %. Along KITTI the
    // cap at 8x leaves out about a tenth of the kept mismatches and no inlier (RESULTS §9,
    // thirteenth session, slow28).
    assert!(
        x_on < 0.95 * x_off,
        "support excess {x_on} with the cap, {x_off} without"
    );
    assert!(
        e_on < e_off,
        "median rotation error {e_on} with, {e_off} without"
    );
}

#[test]
fn the_parallax_cap_leaves_a_support_without_a_tail_alone() {
    // The fisheye rig without mismatches (`outlier_ratio = 0`): the residual and cheirality
    // tests leave out a few per cent of the matches, below the default
    // `parallax_cap_min_outside` (0.1), so the cap does not act (the estimates are those
    // without it); forced to act, it drops true matches with a large parallax (the side
    // cameras' near points) and the estimates move. (With the scenario's 10 % mismatches the
    // share outside the support is about 0.10 and the default gate does not hold the cap
    // back: docs/RESULTS.md §9, fifteenth session.)
    let cfg = || {
        let mut c = SimConfig::fisheye_surround();
        c.frames = 21;
        c.seed = 3;
        c.outlier_ratio = 0.0;
        c
    };
    let off = run_on(cfg(), "");
    let gated = run_on(cfg(), "parallax_cap = 8\n");
    let forced = run_on(cfg(), "parallax_cap = 8\nparallax_cap_min_outside = 0\n");
    assert_eq!(gated, off);
    assert_ne!(forced, off);
    // Forced, the support holds fewer matches than without the cap on some frame.
    assert!(
        forced.iter().zip(&off).any(|(f, o)| f.0 < o.0),
        "the forced cap dropped no match"
    );
}

#[test]
fn the_inverse_distance_cap_leaves_more_near_mismatches_out() {
    // The cap on the baseline over distance (`parallax_cap_inverse_distance`) instead of the
    // parallax angle: a mismatch near the epipole, where a true point's parallax is small
    // whatever its distance, is capped too.
    let cfg = || {
        let mut c = SimConfig::outliers();
        c.frames = 61;
        c.seed = 23;
        c
    };
    let off = run_on(cfg(), "");
    let angle = run_on(cfg(), "parallax_cap = 8\n");
    let dist = run_on(
        cfg(),
        "parallax_cap = 8\nparallax_cap_inverse_distance = true\n",
    );
    let excess = |v: &[(f64, f64)]| v.iter().map(|x| x.0).sum::<f64>() / v.len() as f64;
    let err = |v: &[(f64, f64)]| median(v.iter().map(|x| x.1).collect());
    let (x_off, x_angle, x_dist) = (excess(&off), excess(&angle), excess(&dist));
    // Measured (seed 23): excess 1.57 without a cap, 1.40 with the parallax cap, 1.18 with
    // this one; median error 5.14e-4 -> 5.03e-4 rad.
    assert!(
        x_dist < x_angle && x_dist < 0.9 * x_off,
        "support excess {x_dist} with the inverse-distance cap, {x_angle} with the parallax cap, {x_off} without"
    );
    assert!(
        err(&dist) < err(&off),
        "median rotation error {} with, {} without",
        err(&dist),
        err(&off)
    );
}

#[test]
fn the_learnt_parallax_cap_leaves_near_mismatches_out_where_the_band_says_so() {
    // The learnt cap (`learnt_parallax_cap`, 0.4 by default) on 30 % mismatches: after its warm-up the band
    // next to the support estimates the mismatches' share among the support's largest
    // parallaxes, and the support leaves the tail out; on the fisheye rig (10 % mismatches,
    // true matches with large parallaxes in the side cameras) the band's share stays low and
    // the estimates are those without the cap.
    let cfg = || {
        let mut c = SimConfig::outliers();
        c.frames = 151;
        c.seed = 23;
        c
    };
    // Without the separation's yaw votes (the default since the thirty-ninth session): on this
    // drive one of their alternatives is kept in frame 121, whose final stage then runs on 140
    // of the ~210 static matches, and the learnt cap's later frames move with it (with the
    // votes on: excess 1.073 without the cap, 1.067 with it).
    let before = format!("{BEFORE_21}[odometry.separate]\nyaw_votes = 0\n");
    let off = run_on(cfg(), &format!("learnt_parallax_cap = 0.0\n{before}"));
    let on = run_on(cfg(), &before);
    let excess = |v: &[(f64, f64)]| v.iter().map(|x| x.0).sum::<f64>() / v.len() as f64;
    let err = |v: &[(f64, f64)]| median(v.iter().map(|x| x.1).collect());
    let (x_off, x_on) = (excess(&off), excess(&on));
    let (e_off, e_on) = (err(&off), err(&on));
    // Measured (seed 23, 150 frame pairs): excess 1.580
    // -> 1.547 per frame, median rotation error 5.96e-4 -> 5.86e-4 rad (-1.7 %).
    assert!(
        x_on < 0.99 * x_off,
        "support excess {x_on} with the learnt cap, {x_off} without"
    );
    assert!(
        e_on < e_off,
        "median rotation error {e_on} with, {e_off} without"
    );
    let fisheye = || {
        let mut c = SimConfig::fisheye_surround();
        c.frames = 101;
        c.seed = 3;
        c
    };
    assert_eq!(
        run_on(fisheye(), BEFORE_21),
        run_on(
            fisheye(),
            &format!("learnt_parallax_cap = 0.0\n{BEFORE_21}")
        )
    );
}

/// Camera-0 poses (KITTI convention: x right, y down, z forward) of a drive whose direction of
/// travel drifts upwards and sideways by centimetres per frame, as the KITTI ground truth's
/// does (docs/RESULTS.md §9, sixteenth session): `frames` poses, steps of 0.5-0.9 m, a slow
/// yaw, and per step a rise of 1-5 cm and a sideways shift of up to 2 cm off the heading.
fn drifting_drive(frames: usize) -> Vec<momo_core::Pose<f64>> {
    use nalgebra::Vector3;
    let mut poses = Vec::with_capacity(frames);
    let (mut p, mut yaw) = (Vector3::zeros(), 0.0_f64);
    for k in 0..frames {
        let kf = k as f64;
        let r = momo_core::so3_exp(&Vector3::new(0.0, yaw, 0.0));
        poses.push(momo_core::Pose::new(r, p));
        let step = Vector3::new(
            0.02 * (0.37 * kf).sin(),
            -(0.03 + 0.02 * (0.11 * kf).sin()),
            0.7 + 0.2 * (0.05 * kf).cos(),
        );
        p += r * step;
        yaw += 0.01 * (0.04 * kf).sin();
    }
    poses
}

/// Median rotation error (rad) of `clean_pinhole`'s 200 frame pairs along [`drifting_drive`],
/// seed `seed`, with the `run_on` suffixes `off` and `on`: `(off, on)`.
fn drifting_errors(seed: u64, off: &str, on: &str) -> (f64, f64) {
    let err = |suffix: &str| {
        let mut c = SimConfig::clean_pinhole();
        c.frames = 201;
        c.seed = seed;
        c.camera_trajectory = Some(drifting_drive(201));
        median(run_on(c, suffix).iter().map(|x| x.1).collect())
    };
    (err(off), err(on))
}

#[test]
fn the_learnt_cauchy_scale_weighs_gaussian_pixels_closer_to_least_squares() {
    // The learnt Cauchy scale (`learnt_cauchy_max`) on Gaussian pixel noise (the simulator's
    // `clean_pinhole`) along a drive whose direction of travel drifts off the soft prior: the
    // residual-tail share stays near the Gaussian's, the refit's scale widens from 2.4 σ̂ to
    // the clamp, the data weigh more against the (biased) priors, and the median rotation
    // error falls. Measured (200 frame pairs, seeds 1-6): -6.3 / -1.5 / -0.8 / -2.0 / -2.0 /
    // -2.9 %. (On the built-in drive, whose motion is single-track, the same comparison is
    // mixed: seeds 1-8 of 200 frames, 4 better and 4 worse, mean +1 %.)
    for seed in 1..=3 {
        let (off, on) = drifting_errors(
            seed,
            BEFORE_21,
            "learnt_cauchy_max = 6.0\n[odometry]\nsoft_prior_consistency_frames = 0\nsoft_prior_trend_frames = 0\n",
        );
        assert!(
            on < 0.995 * off,
            "seed {seed}: median rotation error {on} with the learnt scale, {off} without"
        );
    }
}

#[test]
fn the_consistency_widening_lets_a_drifting_direction_of_travel_pull_the_soft_prior_less() {
    // The soft prior's consistency widening (`odometry.soft_prior_consistency_frames = 10`,
    // limit 2) along a drive whose direction of travel drifts sideways and upwards off the
    // single-track prior by centimetres per frame (as the KITTI ground truth's does): the recent
    // frames' innovations keep disagreeing with the prior's width, the width grows until they
    // agree, and the (biased) prior pulls the rotation less. Measured (200 frame pairs), median
    // rotation error with / without: seeds 1-3 0.977 / 1.000 / 0.981 (mean 0.986).
    let ratios: Vec<f64> = (1..=3)
        .map(|seed| {
            let (off, on) = drifting_errors(
                seed,
                BEFORE_21,
                "learnt_cauchy_max = 0.0\n[odometry]\nsoft_prior_consistency_frames = 10\nsoft_prior_consistency_limit = 2.0\nsoft_prior_trend_frames = 0\n",
            );
            on / off
        })
        .collect();
    let mean = ratios.iter().sum::<f64>() / 3.0;
    assert!(
        mean < 0.995 && ratios.iter().all(|r| *r < 1.002),
        "median rotation error with / without the consistency widening, seeds 1-3: {ratios:?}"
    );
}

#[test]
fn the_trend_centre_follows_a_slowly_changing_climb() {
    // The soft prior's trend centre (`odometry.soft_prior_trend_frames = 20`, `z = 1`, soft
    // threshold: static36's form, without the blend and widening of today's default) against
    // the prior without a trend along a drive whose rise per step changes slowly (1-5 cm per
    // step over a period of about 57 frames): the recent frames' data-only levels of the slips move away
    // from the long (100-frame) centre, and the centre follows them. Measured (200 frame
    // pairs), median rotation error with / without: seeds 1-3 0.995 / 0.988 / 0.986. With
    // `m = 10` the same drive is worse (1.024 / 1.017 / 1.009): its sideways shift turns with
    // a period of about 17 frames, and a 10-frame level lags it by a quarter of that
    // (docs/RESULTS.md §9, twenty-second session, static36).
    let ratios: Vec<f64> = (1..=3)
        .map(|seed| {
            let (off, on) = drifting_errors(
                seed,
                "[odometry]\nsoft_prior_trend_frames = 0\n",
                "[odometry]\nsoft_prior_trend_frames = 20\nsoft_prior_trend_z = 1.0\n\
                 soft_prior_trend_blend = false\nsoft_prior_trend_widen = false\n",
            );
            on / off
        })
        .collect();
    let mean = ratios.iter().sum::<f64>() / 3.0;
    assert!(
        mean < 0.995 && ratios.iter().all(|r| *r < 1.0),
        "median rotation error with / without the trend centre, seeds 1-3: {ratios:?}"
    );
}

/// Median rotation error (radians) of `run_on` on `scenario` (built-in drive, `frames`, `seed`)
/// with the `[odometry.final_fit]` lines `final_fit`.
fn scenario_errors(scenario: &str, frames: usize, seed: u64, final_fit: &str) -> Vec<(f64, f64)> {
    let mut c = SimConfig::scenario(scenario).expect("a listed scenario");
    c.frames = frames;
    c.seed = seed;
    run_on(c, final_fit)
}

#[test]
fn one_reference_focal_length_weighs_a_rig_of_two_focal_lengths_by_its_pixel_noise() {
    // `ml_rig_reference` on `wide_angle_surround` (double sphere front and rear, fx = 300;
    // unified left and right, fx = 560): `angle_plane_ml` with each camera's own reference
    // weighs the double sphere cameras 3.5 times their maximum-likelihood weight, and its
    // 3 σ̂ support cuts their matches' tails. Measured here (60 frame pairs, first-stage
    // covariance off), median rotation error with / without: seeds 1-3 0.869 / 0.853 / 0.772.
    // With the `momo` binary (150 frames, error / bound): 1.21 / 1.23 / 1.21 -> 1.01 / 1.07 /
    // 1.08; along KITTI 00-10 (`static3`, seeds 1-2, 22 sequences) median 1.190 -> 1.010
    // (docs/RESULTS.md §9, twenty-seventh session, static41).
    for seed in 1..=3 {
        let err = |ff: &str| {
            median(
                scenario_errors("wide_angle_surround", 61, seed, ff)
                    .iter()
                    .map(|x| x.1)
                    .collect(),
            )
        };
        let (off, on) = (
            err("ml_rig_reference = false\n"),
            err("ml_rig_reference = true\n"),
        );
        eprintln!("seed {seed}: median rotation error {on} with one reference, {off} without");
        assert!(
            on < 0.95 * off,
            "seed {seed}: median rotation error {on} with one reference, {off} without"
        );
    }
}

#[test]
fn one_reference_focal_length_changes_nothing_on_a_rig_of_one_focal_length() {
    // `ml_rig_reference` on the fisheye rig (four equal cameras) and the KITTI mono camera: the
    // rig's mean focal length is each camera's own, so every estimate is the same, bit for bit.
    for scenario in ["fisheye_surround", "outliers"] {
        let off = scenario_errors(scenario, 31, 5, "ml_rig_reference = false\n");
        let on = scenario_errors(scenario, 31, 5, "ml_rig_reference = true\n");
        let bits = |v: &[(f64, f64)]| v.iter().map(|x| x.1.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&off), bits(&on), "{scenario}");
    }
}

/// Per frame pair of `cfg` with the `[odometry]` lines `odometry` and the `[odometry.final_fit]`
/// lines `final_fit` (first-stage covariance off, so the diagnostics' `inliers_per_camera` are
/// the final stage's support sizes): the motion's rotation and translation bits and the
/// diagnostics.
fn diagnostics_of(
    cfg: &SimConfig,
    odometry: &str,
    final_fit: &str,
) -> Vec<(Vec<u64>, momo_vo::FrameDiagnostics)> {
    let sim = simulate(cfg).expect("the scenario simulates");
    let seq = &sim.sequence;
    let text = format!(
        "[odometry]\n{odometry}\n[odometry.final_fit]\nfirst_stage_covariance = false\n{final_fit}\n"
    );
    let config = Config::from_toml_str(&text, "ff.toml").expect("a valid configuration");
    let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
    (1..seq.num_frames())
        .map(|k| {
            let r = vo.process(&seq.frames[k], seq.arc_length(k));
            let bits = r
                .motion
                .rotation
                .iter()
                .chain(r.motion.translation.iter())
                .map(|x| x.to_bits())
                .collect();
            (bits, r.diagnostics)
        })
        .collect()
}

#[test]
fn the_reported_support_is_the_final_stages_and_changes_nothing_else() {
    // `odometry.report_support`: on the mono `outliers` scenario and on the four-camera rig
    // with traffic all around, the motions and every other diagnostic are those without it;
    // the support lists, per camera, increasing indices of the camera's matches, as many as
    // the final stage refit on (`inliers_per_camera` with the first stage's covariance off),
    // and it holds the static scene's matches, not the mismatches.
    for scenario in ["outliers", "moving_traffic_surround"] {
        let mut cfg = SimConfig::scenario(scenario).expect("a listed scenario");
        cfg.frames = 31;
        cfg.seed = 3;
        let sim = simulate(&cfg).expect("the scenario simulates");
        let off = diagnostics_of(&cfg, "report_support = false", "");
        let on = diagnostics_of(&cfg, "report_support = true", "");
        let (mut reported, mut outliers_in, mut outliers, mut static_in, mut statics) =
            (0, 0, 0, 0, 0);
        for (k, ((bits_off, d_off), (bits_on, d_on))) in off.iter().zip(&on).enumerate() {
            assert_eq!(bits_off, bits_on, "{scenario} frame {}", k + 1);
            assert!(d_off.support.is_none(), "{scenario}: written while off");
            let mut stripped = d_on.clone();
            stripped.support = None;
            stripped.time_us = d_off.time_us;
            // Compared as text: the diagnostics hold NaNs (a fixed parameter's sigma).
            assert_eq!(
                format!("{stripped:?}"),
                format!("{d_off:?}"),
                "{scenario} frame {}",
                k + 1
            );
            let Some(support) = &d_on.support else {
                continue;
            };
            reported += 1;
            let frame = &sim.sequence.frames[k + 1];
            assert_eq!(support.len(), frame.per_camera.len());
            for (j, idx) in support.iter().enumerate() {
                assert!(
                    idx.windows(2).all(|w| w[0] < w[1]),
                    "{scenario}: not increasing"
                );
                assert!(idx.iter().all(|&i| i < frame.per_camera[j].len()));
                assert_eq!(
                    idx.len(),
                    d_on.inliers_per_camera[j],
                    "{scenario} camera {j}"
                );
                let labels = &sim.labels[k + 1][j];
                for (i, l) in labels.iter().enumerate() {
                    let member = idx.binary_search(&i).is_ok();
                    match l {
                        MatchLabel::Outlier => {
                            outliers += 1;
                            outliers_in += usize::from(member);
                        }
                        MatchLabel::Inlier => {
                            statics += 1;
                            static_in += usize::from(member);
                        }
                        _ => {}
                    }
                }
            }
        }
        eprintln!(
            "{scenario}: {reported} frames reported, static {static_in} / {statics} in, \
             mismatches {outliers_in} / {outliers} in"
        );
        assert!(
            reported >= 25,
            "{scenario}: {reported} frames with a support"
        );
        assert!(
            (static_in as f64) > 0.8 * statics as f64,
            "{scenario}: static {static_in} of {statics} in the support"
        );
        assert!(
            (outliers_in as f64) < 0.1 * outliers.max(1) as f64,
            "{scenario}: mismatches {outliers_in} of {outliers} in the support"
        );
    }
}

/// Over every frame with a reported support of the run of `cfg` with the `[odometry.final_fit]`
/// lines `final_fit`: the static and the object matches in it, and each frame's motion bits.
fn support_by_label(cfg: &SimConfig, final_fit: &str) -> (usize, usize, Vec<Vec<u64>>) {
    support_by_label_in(cfg, "", final_fit)
}

/// [`support_by_label`] with more of the configuration: `after` follows `[odometry]
/// report_support = true` (more odometry keys, or further sections such as a partial
/// `[odometry.separate]`).
fn support_by_label_in(
    cfg: &SimConfig,
    after: &str,
    final_fit: &str,
) -> (usize, usize, Vec<Vec<u64>>) {
    let sim = simulate(cfg).expect("the scenario simulates");
    let (mut statics, mut objects) = (0, 0);
    let mut bits = Vec::new();
    let odometry = format!("report_support = true\n{after}");
    for (k, (b, d)) in diagnostics_of(cfg, &odometry, final_fit)
        .into_iter()
        .enumerate()
    {
        bits.push(b);
        let Some(support) = d.support else { continue };
        for (j, idx) in support.iter().enumerate() {
            for &i in idx {
                match sim.labels[k + 1][j][i] {
                    MatchLabel::Inlier => statics += 1,
                    MatchLabel::MovingObject => objects += 1,
                    _ => {}
                }
            }
        }
    }
    (statics, objects, bits)
}

/// The neighbourhood test's effect on the support (`on` against `off`, as
/// [`support_by_label`] counts them): fewer than 0.8 x the object matches, more than 0.8 x the
/// static ones.
fn assert_objects_leave_and_static_stay(
    on: &(usize, usize, Vec<Vec<u64>>),
    off: &(usize, usize, Vec<Vec<u64>>),
) {
    assert_support_shares(on, off, 0.8, 0.8);
}

/// A test's effect on the support (`on` against `off`, as [`support_by_label`] counts them):
/// fewer than `objects` x the object matches, more than `statics` x the static ones.
fn assert_support_shares(
    on: &(usize, usize, Vec<Vec<u64>>),
    off: &(usize, usize, Vec<Vec<u64>>),
    objects: f64,
    statics: f64,
) {
    assert!(
        (on.1 as f64) < objects * off.1 as f64,
        "objects in the support: {} with the test, {} without",
        on.1,
        off.1
    );
    assert!(
        (on.0 as f64) > statics * off.0 as f64,
        "static matches in the support: {} with the test, {} without",
        on.0,
        off.0
    );
}

#[test]
fn the_neighbourhood_test_leaves_object_matches_out_of_a_rigs_support() {
    // `final_fit.neighbour_share = 0.375` on the four-camera rig with traffic all around
    // (built-in drive, 30 frame pairs, seed 3; measured: objects 3,201 -> 2,234, static 6,644
    // -> 6,190): the object matches that pass the residual test
    // next to their object's rejected ones leave the support, most static ones stay (along
    // KITTI, rigtraffic s1 + four rigdev sequences, 7,749 frames: objects in the support 58.6
    // -> 28.0 per frame, static 224.4 -> 202.4; docs/RESULTS.md §9, twenty-eighth session,
    // support42).
    let mut cfg = SimConfig::scenario("moving_traffic_surround").expect("a listed scenario");
    cfg.frames = 31;
    cfg.seed = 3;
    // The default is the test at 0.375 (since the twenty-eighth session); "off" writes 0. The
    // re-admission (default since the twenty-ninth session) is held off on both sides.
    let off = support_by_label(&cfg, "neighbour_share = 0.0\nreadmit_share = 0.0");
    let on = support_by_label(&cfg, "readmit_share = 0.0");
    eprintln!(
        "static / object matches in the support: off {} / {}, on {} / {}",
        off.0, off.1, on.0, on.1
    );
    assert_objects_leave_and_static_stay(&on, &off);
}

#[test]
fn the_neighbourhood_guard_keeps_the_given_stage_where_the_rotation_moved() {
    // `final_fit.neighbour_guard`: an angle no rotation reaches changes nothing, bit for bit;
    // a tiny one takes the stage on the given matches wherever the test moved the rotation at
    // all, so the frames' motions change and more object matches stay in the support.
    let mut cfg = SimConfig::scenario("moving_traffic").expect("a listed scenario");
    cfg.frames = 31;
    cfg.seed = 3;
    let on = support_by_label(&cfg, "neighbour_guard = 0.0");
    let wide = support_by_label(&cfg, "neighbour_guard = 3.0");
    let tight = support_by_label(&cfg, "neighbour_guard = 1e-12");
    eprintln!(
        "object matches in the support: test {}, guard 3 rad {}, guard 1e-12 rad {}",
        on.1, wide.1, tight.1
    );
    assert_eq!(on.2, wide.2, "a guard no rotation reaches changes nothing");
    assert_ne!(
        on.2, tight.2,
        "a tiny guard keeps the given stage somewhere"
    );
    assert!(tight.1 > on.1, "objects: {} guarded, {} not", tight.1, on.1);
}

#[test]
fn the_neighbourhood_test_on_one_camera() {
    // `final_fit.neighbour_min_cameras = 1` (the default since the forty-second session)
    // applies the test to a single camera: on the mono moving-traffic scenario (built-in drive,
    // 30 frame pairs, seed 3; measured unguarded: objects 357 -> 32, static 3,830 -> 3,731)
    // object matches leave the support and most static ones stay; with 2 one camera is
    // untouched, bit for bit (docs/RESULTS.md §9, forty-first session, nbmono56).
    let mut cfg = SimConfig::scenario("moving_traffic").expect("a listed scenario");
    cfg.frames = 31;
    cfg.seed = 3;
    let off = support_by_label(&cfg, "neighbour_share = 0.0");
    let two = support_by_label(&cfg, "neighbour_min_cameras = 2");
    let on = support_by_label(&cfg, "neighbour_guard = 0.0");
    eprintln!(
        "static / object matches in the support: off {} / {}, on {} / {}",
        off.0, off.1, on.0, on.1
    );
    assert_eq!(
        off.2, two.2,
        "one camera with neighbour_min_cameras = 2: the motions are the same"
    );
    assert_objects_leave_and_static_stay(&on, &off);
}

#[test]
fn the_readmission_adds_static_matches_to_a_rigs_support() {
    // `final_fit.readmit_share = 0.5` on the four-camera rig with traffic all around (built-in
    // drive, 30 frame pairs, seed 3; measured: static 6,190 -> 6,623, objects 2,234 -> 2,683):
    // the static matches that the separation's mask left out and that pass at the final motion
    // among passing neighbours join the support. Object matches join too (here about as many;
    // along KITTI, rigtraffic s1 + four rigdev sequences, 7,755 frames, static 205.6 -> 223.8
    // per frame, objects 28.0 -> 34.6; docs/RESULTS.md §9, twenty-ninth session, readmit43),
    // but fewer remain than without the neighbourhood test (`neighbour_share = 0`, 3,201). On
    // one camera (`outliers`) it changes nothing, bit for bit.
    let mut cfg = SimConfig::scenario("moving_traffic_surround").expect("a listed scenario");
    cfg.frames = 31;
    cfg.seed = 3;
    // The default is the re-admission at 0.5 gated by the Cauchy climb prior (since the
    // twenty-ninth session); here it is written out ungated, as measured, and "off" writes 0.
    let off = support_by_label(&cfg, "readmit_share = 0.0");
    let on = support_by_label(&cfg, "readmit_share = 0.5\nreadmit_skip_cauchy = false");
    let neither = support_by_label(&cfg, "neighbour_share = 0.0\nreadmit_share = 0.0");
    eprintln!(
        "static / object matches in the support: off {} / {}, on {} / {}, neither test {} / {}",
        off.0, off.1, on.0, on.1, neither.0, neither.1
    );
    assert!(
        on.0 as f64 > 1.05 * off.0 as f64,
        "static matches in the support: {} with the re-admission, {} without",
        on.0,
        off.0
    );
    assert!(
        on.1 < neither.1,
        "objects in the support: {} with the re-admission, {} without either test",
        on.1,
        neither.1
    );
    let mut mono = SimConfig::outliers();
    mono.frames = 31;
    mono.seed = 3;
    let a = support_by_label(&mono, "readmit_share = 0.0");
    let b = support_by_label(&mono, "readmit_share = 0.5\nreadmit_skip_cauchy = false");
    assert_eq!(a.2, b.2, "one camera: the motions are the same");
}

#[test]
fn the_under_road_test_leaves_vehicles_out_of_a_rigs_support() {
    // `separate.under_road_rig = 3` (the default since the sixty-third session) on the
    // four-camera rig with traffic all around (built-in drive, 30 frame pairs, seed 3;
    // measured as this file runs the stage, `first_stage_covariance = false`: objects 1,536 ->
    // 1,075, static 6,194 -> 6,084): the side and rear cameras see vehicles that move with the
    // ego vehicle beyond the road plane their rays meet, so object matches leave the final
    // stage's support and static ones stay (along KITTI 03, seed 1, 500 frames, the default
    // configuration: objects 14,165 -> 10,312, static 108,370 -> 107,100). On one camera the
    // rig's factor is not read (`under_road` is the one-camera test): off and on are the same
    // bit for bit.
    let support_under_road = |cfg: &SimConfig, sigmas: f64| {
        // A partial `[odometry.separate]` keeps the default's separation.
        support_by_label_in(
            cfg,
            &format!("[odometry.separate]\nunder_road_rig = {sigmas:?}"),
            "",
        )
    };
    let mut cfg = SimConfig::scenario("moving_traffic_surround").expect("a listed scenario");
    cfg.frames = 31;
    cfg.seed = 3;
    let off = support_under_road(&cfg, 0.0);
    let on = support_under_road(&cfg, 3.0);
    eprintln!(
        "static / object matches in the support: off {} / {}, on {} / {}",
        off.0, off.1, on.0, on.1
    );
    assert_support_shares(&on, &off, 0.9, 0.95);
    let mut mono = SimConfig::scenario("moving_traffic").expect("a listed scenario");
    mono.frames = 31;
    mono.seed = 3;
    assert_eq!(
        support_under_road(&mono, 0.0).2,
        support_under_road(&mono, 3.0).2,
        "one camera: under_road_rig changes nothing"
    );
}

/// `separate.under_road_guard` (default): on one camera the under-the-road test acts only
/// after a frame whose separation saw no second motion compete, and under
/// `final_fit.neighbour_guard`. Moving traffic along KITTI 10, seed 2, 1 px (the first frames
/// of `momo simulate --scenario moving_traffic --trajectory 10.txt --seed 2`): at the run's
/// start, with `under_road = 3` unguarded, the test takes the static road out under a motion
/// that follows a vehicle: frame 2 1.06 deg off, against 0.11 deg without the test
/// (sixty-fourth session). Guarded, those frames are the ones without the test (which of the
/// two safeguards acts here was not separated). Reads the KITTI poses from
/// `MOMO_DATA` (else `../shared/data`) and skips with a message without them.
#[test]
fn on_one_camera_the_road_test_is_guarded_at_the_runs_start() {
    let Some(sim) = crate::support::along_kitti("10", 8, 2, 1.0, SimConfig::moving_traffic())
    else {
        return;
    };
    let run = |sigmas: f64, guard: bool| {
        let mut config = Config::default();
        let separate = config
            .odometry
            .separate
            .as_mut()
            .expect("the default separates motions");
        separate.under_road = sigmas;
        separate.under_road_guard = guard;
        crate::support::rotation_errors(&sim, config)
    };
    let (without, unguarded, guarded) = (run(0.0, true), run(3.0, false), run(3.0, true));
    eprintln!("frame 2: without {without:?}, unguarded {unguarded:?}, guarded {guarded:?}");
    assert!(
        unguarded[1] > 1.0,
        "unguarded frame 2: {} deg",
        unguarded[1]
    );
    assert!(
        without[1] < 0.3,
        "frame 2 without the test: {} deg",
        without[1]
    );
    assert_eq!(guarded[..2], without[..2]);
}

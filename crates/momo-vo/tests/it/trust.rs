//! Trust (issue 15): every frame's answer is right or says it is not. Each case of the issue
//! is a test that shows the status and reason it now gets and the error it now has; the
//! configuration cases show the `file:line: reason` error they are rejected with before the
//! first frame.

use momo_core::{CameraModel, FrameObservations, Observation, Pose, Rig};
use momo_testing::canned;
use momo_vo::{Config, Constraint, FrameStatus, Odometry, Reason, RunOptions, run_sequence};
use nalgebra::{Vector2, Vector3};

use crate::support;
use support::*;

/// Every frame pair of `seq` through one odometry with `config`: each pair's motion and
/// diagnostics.
fn process_all(
    seq: &momo_io::Sequence,
    config: Config,
) -> Vec<(Pose<f64>, momo_vo::FrameDiagnostics)> {
    let mut vo = Odometry::new(seq.rig.clone(), config).expect("valid");
    (1..seq.num_frames())
        .map(|k| {
            let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
            let r = vo.process(&seq.frames[k], arc);
            (r.motion, r.diagnostics)
        })
        .collect()
}

/// The simulated sequence of `config`.
fn simulated(config: &momo_sim::SimConfig) -> momo_io::Sequence {
    momo_sim::simulate(config).expect("simulated").sequence
}

/// The `moving_traffic` scenario with `frames` frames from `seed`, simulated (the sequence and
/// its truth): most report-only rules' tests run on it.
fn traffic_sim(frames: usize, seed: u64) -> momo_sim::Simulation {
    momo_sim::simulate(&momo_sim::SimConfig {
        frames,
        seed,
        ..momo_sim::SimConfig::moving_traffic()
    })
    .expect("simulated")
}

/// [`traffic_sim`]'s sequence.
fn traffic(frames: usize, seed: u64) -> momo_io::Sequence {
    traffic_sim(frames, seed).sequence
}

/// One frame pair's reported motion and diagnostics.
type Frame = (Pose<f64>, momo_vo::FrameDiagnostics);

/// A report-only rule's runs compared frame by frame: every pose and covariance of `on` (the
/// rule on) is `off`'s (the rule off), and exactly the frames where `fires(off, on)` holds
/// (asked in frame order, with the frame's `estimated` state in `off`, an `ill_conditioned`
/// one counting as `estimated`: that is the last report-only flag, so the rule flags such a
/// frame first) are `weak` with `reason`; the others keep their status and reason. Returns the
/// frames flagged and the `estimated` frames kept.
fn assert_report_only(
    off: &[Frame],
    on: &[Frame],
    reason: Reason,
    mut fires: impl FnMut(bool, &Frame, &Frame) -> bool,
) -> (usize, usize) {
    let (mut flagged, mut kept) = (0, 0);
    for (k, (a, b)) in off.iter().zip(on).enumerate() {
        assert_eq!(a.0.rotation, b.0.rotation, "frame {k}");
        assert_eq!(a.0.translation, b.0.translation, "frame {k}");
        assert_eq!(a.1.covariance, b.1.covariance, "frame {k}");
        let estimated =
            a.1.status == FrameStatus::Estimated || a.1.reason == Some(Reason::IllConditioned);
        if fires(estimated, a, b) {
            assert_eq!(b.1.status, FrameStatus::Weak, "frame {k}");
            assert_eq!(b.1.reason, Some(reason), "frame {k}");
            flagged += 1;
        } else {
            assert_eq!(
                (a.1.status, a.1.reason),
                (b.1.status, b.1.reason),
                "frame {k}"
            );
            kept += usize::from(a.1.status == FrameStatus::Estimated);
        }
    }
    eprintln!("flagged {flagged}, kept estimated {kept}");
    (flagged, kept)
}

/// The default estimator, warmed up on `frames` ordinary frames of `warm` (each estimated).
fn warmed_up(
    rig: &Rig,
    config: Config,
    warm: &Pose<f64>,
    frames: usize,
    rng: &mut Rng,
) -> Odometry {
    let mut vo = Odometry::new(rig.clone(), config).expect("valid");
    for _ in 0..frames {
        let r = vo.process(&frame(rig, warm, 150, 0.5, rng), Some(1.0));
        assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
        assert_eq!(r.diagnostics.constraint, Constraint::Well);
    }
    vo
}

/// The default as before the neighbourhood test ran on one camera (the default since the
/// forty-second session) and before the one-camera under-the-road test (since the sixty-fourth):
/// for the tests whose reproductions and margins were measured then.
fn before_one_camera_test() -> Config {
    let mut c = Config::default();
    c.odometry.final_fit.neighbour_min_cameras = 2;
    without_one_camera_road_test(c)
}

/// `config` without the one-camera under-the-road test (`separate.under_road`, 3 by default
/// since the sixty-fourth session): for the tests measured before it, whose drives it changes.
fn without_one_camera_road_test(mut c: Config) -> Config {
    if let Some(s) = c.odometry.separate.as_mut() {
        s.under_road = 0.0;
    }
    c
}

/// A held frame: the previous motion, infinite standard deviations of the free parameters.
fn assert_held(r: &momo_vo::FrameResult, previous: &Pose<f64>, reason: Reason) {
    let d = &r.diagnostics;
    assert_eq!(d.status, FrameStatus::Degenerate, "{d:?}");
    assert_eq!(d.constraint, Constraint::Degenerate);
    assert_eq!(d.reason, Some(reason), "{d:?}");
    assert!(
        rot_err_deg(&r.motion, previous) < 1e-9,
        "the previous motion is held"
    );
    assert!(
        (r.motion.translation - previous.translation).norm() < 1e-9,
        "the previous motion is held"
    );
    assert!(
        d.param_sigmas.contains(&f64::INFINITY),
        "no confidence: {:?}",
        d.param_sigmas
    );
    assert!(
        d.param_sigmas
            .iter()
            .all(|s| s.is_nan() || *s == f64::INFINITY)
    );
}

// ---------------------------------------------------------------------------- configuration

fn config_error(toml: &str) -> String {
    match Config::from_toml_str(toml, "cfg.toml") {
        Ok(_) => panic!("accepted:\n{toml}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn trivial_loss_with_the_rotation_prior_is_rejected_at_its_line() {
    // Before: 14 of 29 frames `solver_failure`, exit 0 (the infinite scale became the prior's
    // unit).
    let e = config_error(
        "[model]\ntype = \"se3\"\n[metric]\ntype = \"angle_plane\"\n[loss]\ntype = \"trivial\"\n[solver]\ntype = \"levenberg_marquardt\"\n",
    );
    assert!(e.starts_with("cfg.toml:6: loss `trivial`"), "{e}");
    // With the prior off it is a valid (non-robust) configuration.
    Config::from_toml_str(
        "[model]\ntype = \"se3\"\n[metric]\ntype = \"angle_plane\"\n[loss]\ntype = \"trivial\"\n[solver]\ntype = \"levenberg_marquardt\"\n[odometry]\nrotation_change_sigma = 0.0\n",
        "cfg.toml",
    )
    .expect("trivial loss without the prior is fine");
}

const HEAD: &str = "[model]\ntype = \"se3\"\n[metric]\ntype = \"angle_plane\"\n";
const SOLVER: &str = "[solver]\ntype = \"levenberg_marquardt\"\n";

#[test]
fn loss_scales_outside_a_sane_range_are_rejected() {
    for scale in ["1e-300", "1e300"] {
        let e = config_error(&format!(
            "{HEAD}[loss]\ntype = \"cauchy\"\nscale = {scale}\n{SOLVER}"
        ));
        assert!(e.starts_with("cfg.toml:7: loss scale"), "{e}");
        assert!(e.contains("sane range"), "{e}");
    }
    // Pixels for geo_line: 1.0 is sane there, 1e-300 is not.
    let px = "[model]\ntype = \"se3\"\n[metric]\ntype = \"geo_line\"\n[loss]\ntype = \"cauchy\"\nscale = 1.0\n";
    Config::from_toml_str(&format!("{px}{SOLVER}"), "cfg.toml").expect("1 px is sane");
}

#[test]
fn absurd_arc_lengths_and_solver_options_are_rejected() {
    let loss = "[loss]\ntype = \"cauchy\"\nscale = 0.001\n";
    let e = config_error(&format!(
        "{HEAD}{loss}{SOLVER}[odometry]\ninitial_arc_length = 1e200\n"
    ));
    assert!(
        e.starts_with("cfg.toml:11: odometry.initial_arc_length"),
        "{e}"
    );
    let e = config_error(&format!("{HEAD}{loss}{SOLVER}max_iterations = 0\n"));
    assert!(e.starts_with("cfg.toml:10: solver.max_iterations"), "{e}");
    let e = config_error(&format!(
        "{HEAD}{loss}{SOLVER}min_lambda = 1.0\nmax_lambda = 0.001\n"
    ));
    assert!(e.starts_with("cfg.toml:10: solver.min_lambda"), "{e}");
    let e = config_error(&format!(
        "{HEAD}{loss}{SOLVER}[trust]\nmax_rotation = 7.0\n"
    ));
    assert!(e.starts_with("cfg.toml:11: trust.max_rotation"), "{e}");
    let e = config_error(&format!(
        "{HEAD}{loss}{SOLVER}[odometry]\nstandstill_cell_cap = -1.0\n"
    ));
    assert!(
        e.starts_with("cfg.toml:11: odometry.standstill_cell_cap"),
        "{e}"
    );
}

#[test]
fn geo_line_on_a_fisheye_rig_is_rejected_before_the_first_frame() {
    // Before: every frame failed, exit 0.
    let cfg = Config::from_toml_str(
        "[model]\ntype = \"se3\"\n[metric]\ntype = \"geo_line\"\n[loss]\ntype = \"cauchy\"\nscale = 1.0\n[solver]\ntype = \"levenberg_marquardt\"\n",
        "cfg.toml",
    )
    .expect("valid without a rig");
    let e = Odometry::new(canned::fisheye_rig(), cfg)
        .expect_err("geo_line needs pinhole cameras")
        .to_string();
    assert!(e.starts_with("cfg.toml:4: metric `geo_line`"), "{e}");
    assert!(e.contains("camera 0"), "{e}");
}

fn tempdir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("momo-trust-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("tempdir");
    d
}

#[test]
fn an_arc_length_of_1e200_in_odometry_csv_is_rejected_at_its_line() {
    let mut rng = Rng(3);
    let rig = canned::pinhole_rig();
    let dir = tempdir("arc");
    let seq = momo_io::Sequence {
        rig: rig.clone(),
        frames: vec![
            FrameObservations::new(1),
            frame(&rig, &drive(0.0, 1.0), 30, 0.5, &mut rng),
            frame(&rig, &drive(0.0, 1.0), 30, 0.5, &mut rng),
        ],
        arc_lengths: None,
        ground_truth: None,
    };
    momo_io::write_sequence(&dir, &seq).expect("writes");
    std::fs::write(
        dir.join("odometry.csv"),
        "frame,arc_length\n1,1.0\n2,1e200\n",
    )
    .expect("writes");
    let options = RunOptions {
        estimator: momo_vo::EstimatorKind::Momo,
        output: dir.join("est.txt"),
        diagnostics: None,
        rig: None,
    };
    let e = run_sequence(&dir, Config::default(), &options, |_| {})
        .expect_err("1e200 m per frame is rejected")
        .to_string();
    std::fs::remove_dir_all(&dir).ok();
    assert!(e.contains("odometry.csv:3:"), "{e}");
    assert!(e.contains("1000 m"), "{e}");
}

// ----------------------------------------------------------------------------- degeneracy

#[test]
fn one_match_repeated_300_times_counts_once_and_holds_the_motion() {
    // Before: `estimated`, 300 inliers, heading 14.5 deg off, sigma 2e-9 rad.
    let mut rng = Rng(11);
    let rig = canned::pinhole_rig();
    let warm = drive(0.01, 1.0);
    let mut vo = warmed_up(&rig, Config::default(), &warm, 3, &mut rng);
    let previous = vo.estimator().motion(vo.previous_params());
    let one = frame(&rig, &drive(0.05, 1.0), 1, 0.5, &mut rng);
    let mut obs = FrameObservations::new(1);
    obs.per_camera[0] = vec![one.per_camera[0][0]; 300];
    let r = vo.process(&obs, Some(1.0));
    assert_eq!(r.diagnostics.matches, 1, "repeated matches count once");
    assert_held(&r, &previous, Reason::RepeatedMatches);
    // The error is the held motion's: the truth turned 0.04 rad more.
    let err = rot_err_deg(&r.motion, &drive(0.05, 1.0));
    eprintln!("repeated: status degenerate, error {err:.2} deg, sigma inf");
    assert!((err - 0.04f64.to_degrees()).abs() < 0.1, "{err}");
}

#[test]
fn matches_in_a_small_corner_are_degenerate() {
    // Before: errors up to 54 deg, 310x the reported sigma, status `estimated`.
    let mut rng = Rng(12);
    let rig = canned::pinhole_rig();
    let mut vo = warmed_up(&rig, Config::default(), &drive(0.0, 1.0), 3, &mut rng);
    let previous = vo.estimator().motion(vo.previous_params());
    let model = rig.cameras()[0].model;
    let corner = |p: &Vector2<f64>| p.x > 1000.0 && p.x < 1100.0 && p.y > 250.0 && p.y < 310.0;
    let mut obs = FrameObservations::new(1);
    obs.per_camera[0] = matches(
        &rig,
        0,
        &drive(0.02, 1.0),
        60,
        0.5,
        &mut rng,
        move |rng| {
            let px = Vector2::new(rng.uniform(1000.0, 1100.0), rng.uniform(250.0, 310.0));
            model.unproject(&px).unwrap_or_else(Vector3::z)
        },
        (4.0, 40.0),
        corner,
    );
    let r = vo.process(&obs, Some(1.0));
    assert_held(&r, &previous, Reason::SmallRegion);
}

#[test]
fn a_90_degree_turn_between_frames_is_implausible_and_held() {
    // Before: 89 deg error, 44x sigma, `estimated`. The surround-view rig sees the turn.
    let mut rng = Rng(13);
    let rig = canned::fisheye_rig();
    let mut vo = warmed_up(&rig, Config::default(), &drive(0.0, 1.0), 3, &mut rng);
    let previous = vo.estimator().motion(vo.previous_params());
    let truth = drive(std::f64::consts::FRAC_PI_2, 1.0);
    let r = vo.process(&frame(&rig, &truth, 100, 0.5, &mut rng), Some(1.0));
    let d = &r.diagnostics;
    eprintln!(
        "90 deg turn: status {:?} reason {:?}, error {:.1} deg",
        d.status,
        d.reason,
        rot_err_deg(&r.motion, &truth)
    );
    // The solve either finds the turn (then it is implausible) or settles near the warm
    // start where almost nothing is an inlier (measured: 5 of 400): either way held.
    let reason = d.reason.unwrap_or(Reason::NoInliers);
    assert!(
        matches!(reason, Reason::ImplausibleRotation | Reason::TooFewInliers),
        "{d:?}"
    );
    assert_held(&r, &previous, reason);
}

#[test]
fn random_matches_with_large_flow_are_not_estimated() {
    // Before: median error 64 deg, every frame `estimated`.
    let mut rng = Rng(14);
    let rig = canned::pinhole_rig();
    let mut vo = warmed_up(&rig, Config::default(), &drive(0.0, 1.0), 3, &mut rng);
    let model = rig.cameras()[0].model;
    let (w, h) = model.size();
    let mut estimated = 0;
    for _ in 0..10 {
        let mut obs = FrameObservations::new(1);
        while obs.per_camera[0].len() < 150 {
            let p0 = Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0));
            let p1 = Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0));
            if (p1 - p0).norm() < 600.0 {
                continue;
            }
            if let Some(o) = Observation::new(&model, p0, p1) {
                obs.per_camera[0].push(o);
            }
        }
        let r = vo.process(&obs, Some(1.0));
        let d = &r.diagnostics;
        eprintln!(
            "random: status {:?} reason {:?} inliers {}",
            d.status, d.reason, d.inliers
        );
        estimated += usize::from(d.status == FrameStatus::Estimated);
        if d.status == FrameStatus::Degenerate {
            assert!(d.reason.is_some());
        }
    }
    assert_eq!(estimated, 0, "random matches are never `estimated`");
}

#[test]
fn a_tukey_scale_so_small_that_nothing_is_an_inlier_is_degenerate() {
    // Before: `estimated`.
    let mut rng = Rng(15);
    let rig = canned::pinhole_rig();
    let warm = drive(0.0, 1.0);
    let mut vo = warmed_up(&rig, Config::default(), &warm, 2, &mut rng);
    let previous = vo.estimator().motion(vo.previous_params());
    let cfg = Config::from_toml_str(
        "[model]\ntype = \"se3\"\n[metric]\ntype = \"angle_plane\"\n[loss]\ntype = \"tukey\"\nscale = 1e-7\n[solver]\ntype = \"levenberg_marquardt\"\n",
        "tukey.toml",
    )
    .expect("1e-7 rad is within range");
    let mut tiny = Odometry::new(rig.clone(), cfg).expect("valid");
    // Its own first frame: no previous motion but the start (straight ahead, 1 m).
    let obs = frame(&rig, &drive(0.01, 1.0), 150, 2.0, &mut rng);
    let r = tiny.process(&obs, Some(1.0));
    let d = &r.diagnostics;
    eprintln!(
        "tiny tukey: status {:?} reason {:?} inliers {}",
        d.status, d.reason, d.inliers
    );
    assert_eq!(d.status, FrameStatus::Degenerate);
    assert!(
        matches!(d.reason, Some(Reason::NoInliers | Reason::TooFewInliers)),
        "{d:?}"
    );
    assert!(d.inliers < 10);
    // The ordinary estimator on the same frame is fine: an estimate near the truth on its
    // inliers. (Since the final efficient stage is on by default, this 2 px frame is `weak`
    // with `competing_motions`: at 2 px the noise is about the competing-motions threshold,
    // 3e-3 rad, and a second motion fitted to the noise's tail explains 21 % of the matches;
    // before, it was `estimated`. A false alarm on the safe side, docs/RESULTS.md §9.)
    let r = vo.process(&obs, Some(1.0));
    let d = &r.diagnostics;
    eprintln!(
        "ordinary: {:?} {:?} inliers {}",
        d.status, d.reason, d.inliers
    );
    assert!(
        matches!(d.status, FrameStatus::Estimated | FrameStatus::Weak),
        "{d:?}"
    );
    assert!(d.inliers >= 30, "{d:?}");
    let err = rot_err_deg(&r.motion, &drive(0.01, 1.0));
    assert!(err < 0.2, "ordinary estimator {err} deg off");
    let _ = previous;
}

#[test]
fn matches_without_flow_while_moving_are_weak() {
    let mut rng = Rng(16);
    let rig = canned::pinhole_rig();
    let mut vo = warmed_up(&rig, Config::default(), &drive(0.0, 1.0), 3, &mut rng);
    let model = rig.cameras()[0].model;
    let (w, h) = model.size();
    let mut obs = FrameObservations::new(1);
    while obs.per_camera[0].len() < 150 {
        let p = Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0));
        if let Some(o) = Observation::new(&model, p, p) {
            obs.per_camera[0].push(o);
        }
    }
    let r = vo.process(&obs, Some(1.0));
    assert_eq!(r.diagnostics.status, FrameStatus::Weak);
    assert_eq!(r.diagnostics.reason, Some(Reason::LittleFlow));
}

/// The horizon-row case of issue 15: every match within half a pixel of the horizon row in a
/// curve. Before, the default rotation prior held each frame about 1 deg off (10.5 deg over
/// the curve) with a tiny sigma, while the matches alone (noise-free) gave 0.05 deg. Now the
/// frames are `weak` / `along_a_line`, a weak frame does not centre the next frame's prior, and
/// the prior yields to the evidence: measured 0.0-0.44 deg per frame after the first (which
/// still carries the warm-up's prior: 1.7 deg), 2.9 deg summed over the 10-frame curve.
///
/// Measured with `se3` (the default until 2026-11-24). With the default since then
/// (`soft_single_track`), frames 1-6 were 0.46-2.14 deg off (8.2 deg summed): its side-slip and
/// climb prior held them. Now every prior term is weighted by `trust.weak_prior_factor`² (0.1²)
/// on a weak frame: soft_single_track 0.005-0.011 deg per frame after the first (0.097 deg),
/// 0.17 deg summed; se3 0.000 after the first (0.073 deg), 0.07 deg summed. The bound (0.6 deg
/// per frame after the first, 1 deg summed) is asserted for both; with the factor at 1 the
/// default model fails it.
#[test]
fn the_prior_yields_to_matches_on_the_horizon_row() {
    horizon_row(
        Config {
            model: Box::new(momo_models::Se3),
            ..Config::default()
        },
        true,
    );
    horizon_row(Config::default(), true);
}

fn horizon_row(config: Config, bound_the_error: bool) {
    let mut rng = Rng(17);
    let rig = canned::pinhole_rig();
    let mut vo = warmed_up(&rig, config, &drive(0.0, 1.0), 3, &mut rng);
    let model = rig.cameras()[0].model;
    let (w, _) = model.size();
    let cam = rig.cameras()[0].t_vehicle_camera;
    // The horizon row: where the vehicle's horizontal plane through the camera projects.
    let horizon = |u: f64| {
        let f = model
            .unproject(&Vector2::new(u, 188.0))
            .unwrap_or_else(Vector3::z);
        let v = cam.rotation * f;
        let level = cam.rotation.transpose() * Vector3::new(v.x, v.y, 0.0);
        model.project(&level).map_or(188.0, |p| p.y)
    };
    let mut total = 0.0;
    for k in 0..10 {
        let truth = drive(0.03, 1.0);
        let mut obs = FrameObservations::new(1);
        obs.per_camera[0] = matches(
            &rig,
            0,
            &truth,
            120,
            0.0,
            &mut rng,
            |r| {
                let u = r.uniform(0.0, w - 1.0);
                let v = horizon(u) + r.uniform(-0.5, 0.5);
                model
                    .unproject(&Vector2::new(u, v))
                    .unwrap_or_else(Vector3::z)
            },
            (5.0, 60.0),
            |_| true,
        );
        let r = vo.process(&obs, Some(1.0));
        let d = &r.diagnostics;
        let err = rot_err_deg(&r.motion, &truth);
        total += err;
        eprintln!(
            "horizon row frame {k}: {:?} {:?}, error {err:.3} deg",
            d.status, d.reason
        );
        assert_eq!(d.status, FrameStatus::Weak, "{d:?}");
        assert_eq!(d.reason, Some(Reason::AlongALine));
        // The first frame still carries the warm-up's prior (centred on straight driving).
        if k > 0 && bound_the_error {
            assert!(err < 0.6, "frame {k}: {err} deg");
        }
    }
    eprintln!("horizon row: {total:.2} deg summed over the curve");
    if bound_the_error {
        assert!(total < 1.0, "{total} deg summed over the curve");
    }
}

/// Rotation NEES of a frame (as `examples/nees.rs`): the error `log(R_trueᵀ R_est)` against the
/// reported covariance carried to the rotation vector by central differences of the model's
/// motion. `None` without a covariance; 0 for an infinite one.
fn rotation_nees(
    vo: &Odometry,
    d: &momo_vo::FrameDiagnostics,
    truth: &nalgebra::Matrix3<f64>,
) -> Option<f64> {
    use momo_core::so3_log;
    let model = vo.estimator();
    let n = d.free.len();
    if n == 0 || d.covariance.len() != n * n {
        return None;
    }
    let cov = nalgebra::DMatrix::from_row_slice(n, n, &d.covariance);
    if cov.iter().any(|v| v.is_infinite()) {
        return Some(0.0);
    }
    let r0 = model.motion(&d.params).rotation;
    let mut jac = nalgebra::DMatrix::zeros(3, n);
    for (c, &i) in d.free.iter().enumerate() {
        let (mut plus, mut minus) = (d.params.clone(), d.params.clone());
        plus[i] += 1e-6;
        minus[i] -= 1e-6;
        let wp = so3_log(&(r0.transpose() * model.motion(&plus).rotation));
        let wm = so3_log(&(r0.transpose() * model.motion(&minus).rotation));
        jac.set_column(c, &((wp - wm) / 2e-6));
    }
    let cw = &jac * cov * jac.transpose();
    let inv = nalgebra::Matrix3::from_fn(|r, c| cw[(r, c)]).try_inverse()?;
    let e = so3_log(&(truth.transpose() * r0));
    Some((e.transpose() * inv * e)[(0, 0)])
}

/// Issue 15, two competing motions: 45 % of the matches on a rigid object that moves with the
/// vehicle (zero flow, `momo_sim`'s moving_object scenario) lock the robust fit into a motion
/// between the two, 0.1-0.5 deg off with a classical sigma of 0.01-0.02 deg (rotation NEES in
/// the hundreds). The leave-one-cell-out jackknife (`trust.jackknife_grids`) widens the
/// covariance where the estimate depends on a few image cells: most object frames are then
/// inside the 95 % chi-square bound; without it, most are far outside.
#[test]
fn a_rigid_object_moving_differently_widens_the_covariance() {
    const CHI2_3_95: f64 = 7.814_727_903_251_178;
    let inside = |config: Config| {
        let mut cfg = momo_sim::SimConfig::moving_object();
        cfg.frames = 42;
        cfg.seed = 1;
        if let Some(o) = cfg.moving_object.as_mut() {
            o.frames = 30..42;
        }
        let sim = momo_sim::simulate(&cfg).expect("simulated");
        let seq = &sim.sequence;
        let mut vo = Odometry::new(seq.rig.clone(), config).expect("valid");
        let mut scores = Vec::new();
        for k in 1..seq.num_frames() {
            let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
            let r = vo.process(&seq.frames[k], arc);
            if k < 30 {
                continue;
            }
            let d = &r.diagnostics;
            let nees = rotation_nees(&vo, d, &sim.vehicle_motions[k].rotation);
            let err = rot_err_deg(&r.motion, &sim.vehicle_motions[k]);
            eprintln!(
                "object frame {k}: {:?} error {err:.3} deg, NEES {nees:?}",
                d.status
            );
            if matches!(d.status, FrameStatus::Estimated | FrameStatus::Weak) {
                scores.push(nees.unwrap_or(f64::INFINITY));
            }
        }
        assert!(scores.len() >= 10, "{} object frames scored", scores.len());
        scores.iter().filter(|n| **n <= CHI2_3_95).count() as f64 / scores.len() as f64
    };
    // The lock-in this test needs: with the seventeenth session's defaults (the memory's
    // tracks, the road score's drop) the estimate leaves it on half of these frames (errors
    // 0.01-0.10 deg), so the claim is checked with the sixteenth session's separation.
    let base = || {
        Config::from_toml_str(&crate::support::sixteenth_session_defaults(""), "t.toml")
            .expect("valid")
    };
    let mut off = base();
    off.trust.jackknife_grids.clear();
    off.trust.clustering_grids.clear();
    off.trust.report_grids.clear();
    off.trust.clustering_z = 0.0;
    let (with, without) = (inside(base()), inside(off));
    eprintln!("inside the 95 % bound: {with:.2} with the jackknife, {without:.2} without");
    assert!(
        without < 0.3,
        "the classical covariance is over-confident here"
    );
    assert!(with >= 0.75, "{with}");
}

/// The residual-clustering test (`trust.clustering_z`): on a clean drive the per-cell sums of
/// the signed residuals are noise (T / cells about 1); with 45 % of the matches on a rigid
/// object moving with the vehicle, the compromise motion leaves whole image regions with
/// residuals of one sign.
#[test]
fn residuals_cluster_in_the_image_where_a_rigid_object_pulls_the_estimate() {
    let run = |mut cfg: momo_sim::SimConfig| {
        cfg.frames = 42;
        cfg.seed = 2;
        if let Some(o) = cfg.moving_object.as_mut() {
            o.frames = 30..42;
        }
        let seq = &simulated(&cfg);
        let mut vo = Odometry::new(seq.rig.clone(), Config::default()).expect("valid");
        (1..seq.num_frames())
            .map(|k| {
                let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
                let d = vo.process(&seq.frames[k], arc).diagnostics;
                (d.residual_clustering, d.jackknife)
            })
            .collect::<Vec<_>>()
    };
    let clean = run(momo_sim::SimConfig::clean_pinhole());
    let object = run(momo_sim::SimConfig::moving_object());
    let mean = |v: &[(f64, bool)]| v.iter().map(|x| x.0).sum::<f64>() / v.len() as f64;
    let (c, o) = (mean(&clean), mean(&object[29..]));
    eprintln!(
        "T / cells: clean {c:.2} (max {:.2}), object frames {o:.2}",
        clean.iter().map(|x| x.0).fold(0.0, f64::max)
    );
    assert!(
        clean.iter().all(|x| x.0.is_finite() && x.0 < 2.0),
        "{clean:?}"
    );
    assert!(c < 1.3 && o > 1.5 * c, "clean {c}, object {o}");
    // The jackknife runs on the object frames once the test fired.
    let jk = object[29..].iter().filter(|x| x.1).count();
    assert!(jk >= 10, "{jk} of 12 object frames jackknifed");
}

/// The one-step leave-one-group-out re-estimate of [`momo_vo::trust::influence_step`] is the
/// exact minimum of a quadratic cost without the group: `Σ_c ½ (θ - μ_c)ᵀ H_c (θ - μ_c)`
/// over three groups, linearised at a point that is not the minimum.
#[test]
fn the_influence_step_is_the_minimum_of_a_quadratic_without_the_group() {
    use momo_core::{NormalMatrix, ParamVec};
    use nalgebra::{DMatrix, DVector};
    let n = 3;
    let spd = |seed: f64| {
        let a = DMatrix::from_fn(n, n, |i, j| ((i * 3 + j) as f64 * 1.7 + seed).sin());
        &a * a.transpose() + DMatrix::identity(n, n) * 0.5
    };
    let groups: Vec<(DMatrix<f64>, DVector<f64>)> = (0..3)
        .map(|c| {
            let mu = DVector::from_fn(n, |i, _| ((c * n + i) as f64 * 0.9).cos());
            (spd(c as f64), mu)
        })
        .collect();
    let theta = DVector::from_vec(vec![0.3, -0.2, 0.1]);
    let pad = |m: &DMatrix<f64>| {
        NormalMatrix::from_fn(|i, j| if i < n && j < n { m[(i, j)] } else { 0.0 })
    };
    let padv = |v: &DVector<f64>| ParamVec::from_fn(|i, _| if i < n { v[i] } else { 0.0 });
    let (mut h, mut g) = (DMatrix::zeros(n, n), DVector::zeros(n));
    for (hc, mu) in &groups {
        h += hc;
        g += hc * (&theta - mu);
    }
    for (c, (hc, mu)) in groups.iter().enumerate() {
        let got = momo_vo::trust::influence_step(
            theta.as_slice(),
            (&pad(&h), &padv(&g)),
            (&pad(hc), &padv(&(hc * (&theta - mu)))),
            n,
        )
        .expect("positive definite");
        let (mut hr, mut b) = (DMatrix::zeros(n, n), DVector::zeros(n));
        for (d, (hd, md)) in groups.iter().enumerate() {
            if d != c {
                hr += hd;
                b += hd * md;
            }
        }
        let want = hr.try_inverse().expect("invertible") * b;
        for i in 0..n {
            assert!(
                (got[i] - want[i]).abs() < 1e-12,
                "group {c}: {got:?} vs {want}"
            );
        }
    }
    // Without any positive definite remainder there is no step.
    let z = NormalMatrix::zeros();
    assert!(
        momo_vo::trust::influence_step(
            &[0.0; 3],
            (&z, &ParamVec::zeros()),
            (&z, &ParamVec::zeros()),
            3
        )
        .is_none()
    );
}

/// The negative-curvature loss of the one-linearisation jackknife is the wrapped loss with
/// `ρ''` negated (and cut at 0), and the wrapped loss survives the copy.
#[test]
fn the_negative_curvature_loss_negates_the_second_derivative() {
    use momo_core::RobustLoss;
    let cauchy = momo_costs::Cauchy::new(0.001);
    let wrapped = momo_vo::trust::NegativeCurvature::of(&cauchy).expect("round-trips");
    assert_eq!(wrapped.scale(), cauchy.scale());
    for s in [0.0, 1e-8, 1e-6, 4e-6, 1e-3] {
        let [r, d1, d2] = cauchy.evaluate(s);
        assert!(d2 < 0.0);
        assert_eq!(wrapped.evaluate(s), [r, d1, -d2]);
    }
    // Its lanes (the fused linearisation's path) are its per-match values bit for bit, for a
    // loss with a negative (Cauchy) and a positive or zero (Huber, Tukey) second derivative.
    let losses: [Box<dyn RobustLoss>; 3] = [
        Box::new(cauchy),
        Box::new(momo_costs::Huber::new(0.001)),
        Box::new(momo_costs::Tukey::new(0.001)),
    ];
    for loss in &losses {
        let wrapped = momo_vo::trust::NegativeCurvature::of(loss.as_ref()).expect("round-trips");
        for lanes in [[0.0, 1e-8, 1e-6, 4e-6], [1e-3, 2e-6, 0.5e-6, 1e9]] {
            let got = wrapped.evaluate_lanes(&lanes);
            for (l, &s) in lanes.iter().enumerate() {
                assert_eq!(
                    got[l].map(f64::to_bits),
                    wrapped.evaluate(s).map(f64::to_bits)
                );
            }
        }
    }
}

/// The one-linearisation jackknife (`trust.jackknife_influence`, the default) changes only the
/// covariance: the poses are bit-identical to the solve-per-cell jackknife's (on this drive; a
/// frame whose status turns on the widened covariance changes the next frame's prior); and
/// with every cell solved in full (`trust.jackknife_solves` above the cell count) the
/// covariance is too (the cells line up with [`momo_vo::trust::leave_one_cell_out`]'s).
#[test]
fn the_one_linearisation_jackknife_changes_only_the_covariance() {
    let mut cfg = momo_sim::SimConfig::moving_object();
    cfg.frames = 36;
    cfg.seed = 3;
    if let Some(o) = cfg.moving_object.as_mut() {
        o.frames = 28..36;
    }
    let seq = &simulated(&cfg);
    let run = |config: Config| process_all(seq, config);
    let mut solves = Config::default();
    solves.trust.jackknife_influence = false;
    let base = run(solves);
    let one = Config::default();
    assert!(one.trust.jackknife_influence);
    let cheap = run(one);
    let mut every = Config::default();
    every.trust.jackknife_solves = 64;
    // Every cell solved by the configured solver, as the solve-per-cell path does (the default
    // lengthens the steps of the report grids' undefined cells' solves).
    every.trust.jackknife_undefined_max_step_extrapolation = 0.0;
    let all = run(every);
    let mut jackknifed = 0;
    for ((b, c), a) in base.iter().zip(&cheap).zip(&all) {
        assert_eq!(b.0.rotation, c.0.rotation);
        assert_eq!(b.0.translation, c.0.translation);
        assert_eq!(b.0.rotation, a.0.rotation);
        assert_eq!(b.1.covariance, a.1.covariance);
        assert_eq!(b.1.jackknife, c.1.jackknife);
        jackknifed += usize::from(b.1.jackknife);
    }
    assert!(jackknifed >= 5, "{jackknifed} frames jackknifed");
}

/// `trust.jackknife_undefined_steps` (off by default) replaces only the full solves of the
/// cells whose one-step re-estimate is undefined: on a clean drive (no such cell) the
/// covariances are bit-identical to the default's; on a moving-traffic drive some frames'
/// covariances change and their poses do not (on this drive: the option changes no status; a
/// status the covariance moves can move the next frame's prior; with the one-camera
/// under-the-road test, default since the sixty-fourth session, a pose moves on this drive,
/// not traced further: measured without it).
#[test]
fn gauss_newton_steps_for_the_undefined_cells_change_only_their_covariances() {
    let run = |cfg: &momo_sim::SimConfig, config: Config| process_all(&simulated(cfg), config);
    let default = || without_one_camera_road_test(Config::default());
    let steps = || {
        let mut c = default();
        c.trust.jackknife_undefined_steps = 1;
        c
    };
    let mut clean = momo_sim::SimConfig::clean_pinhole();
    clean.frames = 30;
    let base = run(&clean, Config::default());
    let with = run(&clean, steps());
    for (a, b) in base.iter().zip(&with) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.1.covariance, b.1.covariance);
    }
    let mut traffic = momo_sim::SimConfig::moving_traffic();
    traffic.frames = 60;
    traffic.seed = 1;
    let base = run(&traffic, default());
    let with = run(&traffic, steps());
    let mut changed = 0;
    for (a, b) in base.iter().zip(&with) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.0.translation, b.0.translation);
        changed += usize::from(a.1.covariance != b.1.covariance);
    }
    assert!(changed >= 3, "{changed} covariances changed");
}

/// `trust.jackknife_undefined_max_step_extrapolation` (and the two other options of the
/// undefined cells' solver, off by default) changes only the full solves of the cells whose
/// one-step re-estimate is undefined: on a clean drive (no such cell) the covariances are
/// bit-identical to the default's; on a moving-traffic drive some frames' covariances change
/// and (on this drive) no pose; a value below 1 is rejected.
#[test]
fn the_undefined_cells_solver_changes_only_their_covariances() {
    let run = |cfg: &momo_sim::SimConfig, config: Config| process_all(&simulated(cfg), config);
    // Off: the solver's own options on every grid (the default before the twenty-fifth
    // session); lengthened: on every grid.
    let off = || {
        let mut c = Config::default();
        c.trust.jackknife_undefined_max_step_extrapolation = 0.0;
        c.trust.jackknife_undefined_report_only = false;
        c
    };
    let lengthened = || {
        let mut c = off();
        c.trust.jackknife_undefined_max_step_extrapolation = 2.0;
        c
    };
    assert!(momo_vo::trust::undefined_cell_solver(off().solver.as_ref(), &off().trust).is_none());
    assert!(
        momo_vo::trust::undefined_cell_solver(off().solver.as_ref(), &lengthened().trust).is_some()
    );
    let mut bad = Config::default();
    bad.trust.jackknife_undefined_max_step_extrapolation = 0.5;
    assert!(Odometry::new(canned::fisheye_rig(), bad).is_err());
    let mut clean = momo_sim::SimConfig::clean_pinhole();
    clean.frames = 30;
    let base = run(&clean, off());
    let with = run(&clean, lengthened());
    for (a, b) in base.iter().zip(&with) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.1.covariance, b.1.covariance);
    }
    let mut traffic = momo_sim::SimConfig::moving_traffic();
    traffic.frames = 60;
    traffic.seed = 1;
    let base = run(&traffic, off());
    let with = run(&traffic, lengthened());
    let mut changed = 0;
    for (a, b) in base.iter().zip(&with) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.0.translation, b.0.translation);
        changed += usize::from(a.1.covariance != b.1.covariance);
    }
    assert!(changed >= 3, "{changed} covariances changed");
    // Only the report grids' cells: no status can change (their jackknife widens the reported
    // covariance after the competing-motions test).
    let mut report_only = lengthened();
    report_only.trust.jackknife_undefined_report_only = true;
    let with = run(&traffic, report_only);
    for (a, b) in base.iter().zip(&with) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.1.status, b.1.status);
        assert_eq!(a.1.reason, b.1.reason);
    }
}

/// Issue 14, the covariance where traffic moves with the vehicle (`momo_sim`'s moving_traffic
/// on the built-in drive, seeds 1-3): lead and cut-in cars hold about half of the matches and
/// pull the estimate into a compromise without any drop of the inlier share, so the jackknife
/// that ran only where that share dropped (`jackknife_support_drop` 0.7, the default until the
/// twelfth session) left many of those frames far outside the 95 % bound. The default
/// jackknife on every moving frame widens them (with sep27's `cell_cap` default, 200 frames,
/// seeds 1-3: 92.3 % inside against 84.1 % with the old trigger; before the cap, 86.4 against
/// 58.3 %).
#[test]
fn traffic_moving_with_the_vehicle_widens_the_covariance_of_every_frame() {
    const CHI2_3_95: f64 = 7.814_727_903_251_178;
    // As measured: before the neighbourhood test ran on one camera (the default since the
    // forty-second session), which leaves fewer frames in a compromise: with it 98.8 % inside
    // against 94.3 % with the old trigger.
    let before = before_one_camera_test;
    let drop = || {
        let mut c = before();
        c.trust.jackknife_support_drop = 0.7;
        c.trust.jackknife_solves = 1;
        c
    };
    let (mut every, mut dropped, mut scored) = (0usize, 0usize, 0usize);
    for seed in 1..=3 {
        let sim = traffic_sim(200, seed);
        let seq = &sim.sequence;
        let run = |config: Config| {
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("valid");
            let (mut inside, mut scored) = (0usize, 0usize);
            for k in 1..seq.num_frames() {
                let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
                let r = vo.process(&seq.frames[k], arc);
                let d = &r.diagnostics;
                if matches!(d.status, FrameStatus::Estimated | FrameStatus::Weak) {
                    let nees = rotation_nees(&vo, d, &sim.vehicle_motions[k].rotation);
                    scored += 1;
                    inside += usize::from(nees.is_some_and(|n| n <= CHI2_3_95));
                }
            }
            (inside, scored)
        };
        let ((a, n), (b, m)) = (run(before()), run(drop()));
        eprintln!(
            "seed {seed}: inside the 95 % bound {a} / {b} of {n} frames (every frame / where the share dropped)"
        );
        assert_eq!(n, m);
        (every, dropped, scored) = (every + a, dropped + b, scored + n);
    }
    assert!(scored >= 500, "{scored} frames scored");
    let (every, dropped) = (every as f64 / scored as f64, dropped as f64 / scored as f64);
    eprintln!("inside: {every:.3} on every frame, {dropped:.3} where the share dropped");
    assert!(
        every >= 0.9 && every > dropped + 0.05,
        "{every} against {dropped}"
    );
}

/// `trust::leave_cells_out` (the one-linearisation jackknife's full solves) builds the wanted
/// cells' samples only, each equal to [`momo_vo::trust::leave_one_cell_out`]'s, in its order.
#[test]
fn leave_cells_out_builds_the_wanted_samples_of_leave_one_cell_out() {
    use momo_vo::trust::{leave_cells_out, leave_one_cell_out};
    for cfg in [
        momo_sim::SimConfig::fisheye_surround(),
        momo_sim::SimConfig::moving_traffic(),
    ] {
        let sim = momo_sim::simulate(&momo_sim::SimConfig {
            frames: 3,
            seed: 1,
            ..cfg
        })
        .expect("simulated");
        let (rig, obs) = (&sim.sequence.rig, &sim.sequence.frames[1]);
        for grid in [(3, 2), (4, 2), (1, 2), (2, 1)] {
            let all = leave_one_cell_out(rig, obs, grid);
            let some = leave_cells_out(rig, obs, grid, |k| k % 3 == 1);
            assert_eq!(some.len(), all.len(), "{grid:?}");
            assert!(all.len() >= 2, "{grid:?}: {} cells", all.len());
            for (k, (s, a)) in some.iter().zip(&all).enumerate() {
                if k % 3 == 1 {
                    assert_eq!(s.as_ref(), Some(a), "{grid:?} cell {k}");
                } else {
                    assert!(s.is_none(), "{grid:?} cell {k}");
                }
            }
        }
    }
}

/// The road's alternatives in the covariance (`trust.road_alternative_weight`,
/// [`momo_vo::trust::alternatives_covariance`]): `Σ + w Σ_j d_j d_jᵀ`, each alternative within
/// `1/√w` standard deviations of the estimate; one alternative is the mixture's covariance of
/// `mixture_covariance` plus the squared offset of the mixture's mean; `w = 0` and non-finite
/// alternatives change nothing; the options out of range are rejected.
#[test]
fn the_road_alternatives_covariance_covers_each_alternative() {
    use momo_vo::trust::{alternatives_covariance, mixture_covariance};
    use nalgebra::{DMatrix, DVector};
    let cov = DMatrix::from_row_slice(3, 3, &[4e-6, 1e-6, 0.0, 1e-6, 2e-6, 0.0, 0.0, 0.0, 1e-6]);
    let a = [0.01, -0.002, 0.003];
    let c = [0.02, -0.001, 0.003];
    let p = [0.012, 0.004, -0.01];
    for w in [0.25, 0.5, 1.0] {
        let wide = alternatives_covariance(&cov, &a, &[&c, &p], w);
        let inv = wide.clone().try_inverse().expect("invertible");
        for alt in [&c, &p] {
            let d = DVector::from_iterator(3, alt.iter().zip(&a).map(|(x, y)| x - y));
            let m = (d.transpose() * &inv * &d)[(0, 0)];
            assert!(m <= 1.0 / w + 1e-9, "w = {w}: d'S^-1 d = {m}");
        }
        let one = alternatives_covariance(&cov, &a, &[&c], w);
        let d = DVector::from_iterator(3, c.iter().zip(&a).map(|(x, y)| x - y));
        let expected = mixture_covariance(&cov, &a, &c, w) + &d * d.transpose() * (w * w);
        assert!((one - expected).abs().max() < 1e-15);
    }
    assert_eq!(alternatives_covariance(&cov, &a, &[&c, &p], 0.0), cov);
    let bad = [f64::NAN, 0.0, 0.0];
    assert_eq!(alternatives_covariance(&cov, &a, &[&bad, &[0.0]], 1.0), cov);
    for (key, v) in [
        ("road_alternative_weight", "1.5"),
        ("road_alternative_weight", "-0.1"),
        ("after_flag_weight", "1.5"),
        ("after_flag_weight", "-0.1"),
        ("guard_alternative_weight", "1.5"),
        ("guard_alternative_weight", "-0.1"),
    ] {
        let e = config_error(&format!("[trust]\n{key} = {v}\n"));
        assert!(e.contains(&format!("trust.{key}")), "{e}");
    }
}

/// `trust.guard_alternative_weight` (default 1, report only): where the final stage's
/// neighbourhood guard (`odometry.final_fit.neighbour_guard`) kept the stage on the matches it
/// was given, the diagnostics carry the stage's motion without the matches its tests left out
/// (`guard_alternative`; the given stage's where `final_fit.guard_tilt` kept the reduced one),
/// and the reported covariance covers that motion at one standard deviation from the reported
/// one (`dᵀ Σ⁻¹ d <= 1/w`). Every pose, status and
/// `guard_alternative` is the run's with the weight 0, and every other frame's covariance is
/// that run's bit for bit. Moving traffic (100 matches per frame pair, a bus holding most of
/// them: the guard acts there), seeds 4 and 5, 120 frames.
#[test]
fn a_guarded_frames_covariance_covers_the_stage_without_the_left_out_matches() {
    let bits = |d: &momo_vo::FrameDiagnostics| -> Vec<u64> {
        d.covariance.iter().map(|v| v.to_bits()).collect()
    };
    let mut covered = 0;
    for seed in [4, 5] {
        let mut traffic = momo_sim::SimConfig::moving_traffic();
        traffic.frames = 120;
        traffic.seed = seed;
        traffic.matches_per_camera = 100;
        let seq = simulated(&traffic);
        let mut off = Config::default();
        off.trust.guard_alternative_weight = 0.0;
        let off = process_all(&seq, off);
        let on = process_all(&seq, Config::default());
        for ((pa, da), (pb, db)) in off.iter().zip(&on) {
            let k = da.frame;
            assert_eq!(pa, pb, "frame {k}: the pose is unchanged");
            assert_eq!((da.status, da.reason), (db.status, db.reason), "frame {k}");
            assert_eq!(da.guard_alternative, db.guard_alternative, "frame {k}");
            let Some(r) = &db.guard_alternative else {
                assert_eq!(bits(da), bits(db), "frame {k}: no guard, no widening");
                continue;
            };
            // The reduced stage's motion is a full parameter vector, apart from the reported one.
            assert_eq!(r.len(), db.params.len(), "frame {k}");
            let n = db.free.len();
            let cov = nalgebra::DMatrix::from_row_slice(n, n, &db.covariance);
            if !cov.iter().all(|v| v.is_finite()) {
                continue;
            }
            let d =
                nalgebra::DVector::from_iterator(n, db.free.iter().map(|&i| r[i] - db.params[i]));
            let inv = cov.try_inverse().expect("invertible covariance");
            let m = (d.transpose() * inv * &d)[(0, 0)];
            assert!(m <= 1.0 + 1e-6, "frame {k}: d'S^-1 d = {m}");
            covered += 1;
        }
    }
    assert!(covered >= 3, "{covered} guarded frames covered");
}

/// `trust.road_drop_scaled` (default true, report only): on frames with fewer matches than
/// `separate.count_reference`, the road score's drop is also tested against `ground_drop_min`
/// scaled to the frame's matches. Moving traffic with 100 matches per frame pair at 2 px (a
/// bus holding most of them) along KITTI 09 (300 frames) and 01 (60 frames), seed 2, as the
/// few100 set simulates them, against the rule off (skipped without `MOMO_DATA`):
/// - every pose is unchanged;
/// - every frame the rule flags was `estimated` and is now `weak` / `road_score_drop`, with a
///   covariance at least as wide in every direction that covers the road's alternatives at
///   one sigma;
/// - every other frame keeps its status, reason and covariance bit for bit;
/// - the flagged frames are the worse ones: their mean rotation error is above that of the
///   frames left `estimated`.
#[test]
fn road_drop_scaled_flags_few_match_frames_that_lost_the_road_and_changes_no_pose() {
    let bits = |d: &momo_vo::FrameDiagnostics| -> Vec<u64> {
        d.covariance.iter().map(|v| v.to_bits()).collect()
    };
    let (mut flagged, mut flagged_error) = (0, 0.0);
    let (mut kept, mut kept_error) = (0, 0.0);
    for (trajectory, frames) in [("09", 300), ("01", 60)] {
        let traffic = momo_sim::SimConfig {
            matches_per_camera: 100,
            ..momo_sim::SimConfig::moving_traffic()
        };
        let Some(sim) = crate::support::along_kitti(trajectory, frames, 2, 2.0, traffic) else {
            return;
        };
        let mut off = Config::default();
        off.trust.road_drop_scaled = false;
        let off = errors_and_diagnostics(&sim, off);
        let on = errors_and_diagnostics(&sim, Config::default());
        for ((ea, da), (eb, db)) in off.iter().zip(&on) {
            let k = da.frame;
            assert_eq!(
                (ea, &da.params),
                (eb, &db.params),
                "frame {k}: the pose is unchanged"
            );
            if (da.status, da.reason) == (db.status, db.reason) {
                assert_eq!(bits(da), bits(db), "frame {k}");
                kept += usize::from(db.status == FrameStatus::Estimated);
                kept_error += if db.status == FrameStatus::Estimated {
                    *eb
                } else {
                    0.0
                };
                continue;
            }
            assert_eq!(da.status, FrameStatus::Estimated, "frame {k}");
            assert_eq!(
                (db.status, db.reason),
                (FrameStatus::Weak, Some(Reason::RoadScoreDrop)),
                "frame {k}"
            );
            let n = db.free.len();
            let a = nalgebra::DMatrix::from_row_slice(n, n, &da.covariance);
            let b = nalgebra::DMatrix::from_row_slice(n, n, &db.covariance);
            let wider = nalgebra::SymmetricEigen::new(&b - &a).eigenvalues.min();
            assert!(wider >= -1e-12 * a.norm(), "frame {k}: narrower by {wider}");
            if let Some(c) = &db.road_alternative {
                let d = nalgebra::DVector::from_iterator(
                    n,
                    db.free.iter().map(|&i| c[i] - db.params[i]),
                );
                let m = (d.transpose() * b.clone().try_inverse().expect("invertible") * &d)[(0, 0)];
                assert!(m <= 1.0 + 1e-6, "frame {k}: d'S^-1 d = {m}");
            }
            flagged += 1;
            flagged_error += eb;
        }
    }
    let (f, e) = (
        flagged_error / flagged.max(1) as f64,
        kept_error / kept.max(1) as f64,
    );
    assert!(
        flagged >= 5 && f > e,
        "{flagged} frames flagged (mean error {f:.3} deg), {kept} kept estimated ({e:.3} deg)"
    );
}

/// `trust.covariance_memory` (off by default): a moving frame's reported covariance is at least
/// `ρ` times the previous frame's, applied after the competing-motions test. On a moving-traffic
/// drive the poses and every status stay as they are, every reported covariance is at least the
/// default's in every direction, some are wider, and where neither frame of a pair carries a
/// competing or alternative motion (both `estimated`, and the one before them too), the later
/// one is at least `ρ` times the earlier one. Out-of-range values are rejected.
#[test]
fn the_covariance_memory_floors_the_covariance_and_changes_no_pose() {
    let seq = &traffic(60, 1);
    let run = |config: Config| process_all(seq, config);
    const RHO: f64 = 0.5;
    // As measured: before the neighbourhood test ran on one camera (the default since the
    // forty-second session, which leaves fewer than ten plain pairs in these 60 frames).
    let before = before_one_camera_test;
    let base = run(before());
    let mut memory = before();
    memory.trust.covariance_memory = RHO;
    let with = run(memory);
    // The smallest eigenvalue of `a - s b`, relative to the largest of `a`.
    let excess = |a: &[f64], b: &[f64], s: f64| {
        let n = (a.len() as f64).sqrt() as usize;
        let a = nalgebra::DMatrix::from_row_slice(n, n, a);
        let b = nalgebra::DMatrix::from_row_slice(n, n, b);
        let d = &a - b * s;
        let scale = a.symmetric_eigen().eigenvalues.max();
        d.symmetric_eigen().eigenvalues.min() / scale
    };
    let (mut wider, mut floored) = (0, 0);
    for (a, b) in base.iter().zip(&with) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.0.translation, b.0.translation);
        assert_eq!(a.1.status, b.1.status);
        assert_eq!(a.1.reason, b.1.reason);
        if a.1.covariance.is_empty() || a.1.covariance.len() != b.1.covariance.len() {
            continue;
        }
        assert!(excess(&b.1.covariance, &a.1.covariance, 1.0) > -1e-9);
        wider += usize::from(a.1.covariance != b.1.covariance);
    }
    let plain = |d: &momo_vo::FrameDiagnostics| {
        d.status == FrameStatus::Estimated
            && d.competing.is_none()
            && d.road_alternative.is_none()
            && !d.covariance.is_empty()
    };
    for w in with.windows(3) {
        let (before, prev, this) = (&w[0].1, &w[1].1, &w[2].1);
        if plain(before) && plain(prev) && plain(this) && prev.free == this.free {
            assert!(excess(&this.covariance, &prev.covariance, RHO) > -1e-9);
            floored += 1;
        }
    }
    assert!(wider >= 3, "{wider} covariances widened");
    assert!(floored >= 10, "{floored} pairs checked");
    for v in ["1.0", "-0.1", "nan"] {
        let e = config_error(&format!("[trust]\ncovariance_memory = {v}\n"));
        assert!(e.contains("trust.covariance_memory"), "{e}");
    }
}

/// `trust.report_grids` widen only the reported covariance: the competing-motions test reads
/// the covariance before them, so on a moving-traffic drive the poses and every status stay as
/// they are without them, every reported covariance is at least as wide in every direction,
/// and some are wider (a lead vehicle in the image's middle column). Empty grids and a ratio
/// below 1 are rejected.
#[test]
fn report_grids_widen_only_the_reported_covariance() {
    let seq = &traffic(60, 2);
    let run = |grids: Vec<[usize; 2]>| {
        let mut config = Config::default();
        config.trust.report_grids = grids;
        process_all(seq, config)
    };
    let without = run(Vec::new());
    let with = run(vec![[3, 1]]);
    let mut wider = 0;
    for (a, b) in without.iter().zip(&with) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.0.translation, b.0.translation);
        assert_eq!(a.1.status, b.1.status);
        assert_eq!(a.1.reason, b.1.reason);
        assert_eq!(a.1.covariance.len(), b.1.covariance.len());
        if a.1.covariance.is_empty() {
            continue;
        }
        // A covariance that could not be computed (an ill-conditioned normal matrix: infinite
        // entries) is no report to widen: such a frame is not `estimated` and its sigmas are
        // not finite, with the grids or without.
        let finite = |d: &momo_vo::FrameDiagnostics| d.covariance.iter().all(|v| v.is_finite());
        if !finite(&a.1) || !finite(&b.1) {
            for d in [&a.1, &b.1] {
                assert_ne!(d.status, FrameStatus::Estimated, "frame {}", d.frame);
                assert!(d.free.iter().any(|&i| !d.param_sigmas[i].is_finite()));
            }
            continue;
        }
        let n = a.1.free.len();
        let a = nalgebra::DMatrix::from_row_slice(n, n, &a.1.covariance);
        let b = nalgebra::DMatrix::from_row_slice(n, n, &b.1.covariance);
        let scale = b.clone().symmetric_eigen().eigenvalues.max();
        assert!((&b - &a).symmetric_eigen().eigenvalues.min() / scale > -1e-9);
        wider += usize::from(a != b);
    }
    assert!(wider >= 3, "{wider} covariances widened");
    let e = config_error("[trust]\nreport_grids = [[0, 1]]\n");
    assert!(e.contains("trust.report_grids"), "{e}");
    let e = config_error("[trust]\nreport_min_ratio = 0.5\n");
    assert!(e.contains("trust.report_min_ratio"), "{e}");
}

/// `trust.report_pool_frames` pools the report grids' jackknife over recent frames and widens
/// only the reported covariance: on a moving-traffic drive the poses and every status are
/// those without the pool, some covariances change, and fewer unflagged frames have a
/// rotation NEES above chi-square(3)'s 99 % quantile (the over-confident frames behind a lead
/// vehicle whose own three-column jackknife happened to agree). A pool of one frame is no pool
/// bit for bit; a trim of at least the pool is rejected.
#[test]
fn the_report_pool_changes_only_the_reported_covariance() {
    const CHI2_3_99: f64 = 11.344_866_730_144_373;
    let sim = traffic_sim(120, 3);
    let seq = &sim.sequence;
    let run = |frames: usize, trim: usize, ratio: f64| {
        let mut config = Config::default();
        config.trust.report_pool_frames = frames;
        config.trust.report_pool_trim = trim;
        config.trust.report_min_ratio = ratio;
        let mut vo = Odometry::new(seq.rig.clone(), config).expect("valid");
        let mut rows = Vec::new();
        let mut over = 0;
        for k in 1..seq.num_frames() {
            let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
            let r = vo.process(&seq.frames[k], arc);
            let d = &r.diagnostics;
            if d.status == FrameStatus::Estimated
                && rotation_nees(&vo, d, &sim.vehicle_motions[k].rotation)
                    .is_some_and(|n| n > CHI2_3_99)
            {
                over += 1;
            }
            rows.push((r.motion, r.diagnostics));
        }
        (rows, over)
    };
    let (plain, before) = run(0, 0, 4.0);
    let (one, _) = run(1, 0, 4.0);
    for (a, b) in plain.iter().zip(&one) {
        assert_eq!(a.1.covariance, b.1.covariance);
    }
    let (pooled, after) = run(10, 2, 3.0);
    let mut changed = 0;
    for (a, b) in plain.iter().zip(&pooled) {
        assert_eq!(a.0.rotation, b.0.rotation);
        assert_eq!(a.0.translation, b.0.translation);
        assert_eq!(a.1.status, b.1.status);
        assert_eq!(a.1.reason, b.1.reason);
        changed += usize::from(a.1.covariance != b.1.covariance);
    }
    eprintln!("{changed} covariances changed; NEES above the 99 % quantile {before} -> {after}");
    assert!(changed >= 10, "{changed} covariances changed");
    assert!(
        after < before,
        "NEES above the 99 % quantile {before} -> {after}"
    );
    let e = config_error("[trust]\nreport_pool_frames = 3\nreport_pool_trim = 3\n");
    assert!(e.contains("trust.report_pool_trim"), "{e}");
}

/// `trust.yaw_change` (report only): with the rule on, every pose is the one without it; a
/// frame whose status or reason changed is one that was `estimated`, is now `weak` /
/// `yaw_change`, and whose reported yaw `ω_z` differs from the previous frame's by more than
/// `J`; every frame left `estimated` after a moving estimated frame changes its yaw by at most
/// `J`; a flagged frame's covariance adds the previous motion (`Σ + d dᵀ`: its yaw sigma is at
/// least as wide, its NEES no larger), and with `yaw_change_weight = 0` only the status
/// changes. Out-of-range values are rejected at their line.
#[test]
fn yaw_change_flags_a_jump_of_the_yaw_and_changes_no_pose() {
    use momo_core::so3_log;
    let seq = &traffic(120, 3);
    let run = |on: bool, j: f64, weight: f64| {
        let mut config = Config::default();
        if on {
            config.trust.yaw_change = j;
            config.trust.yaw_change_weight = weight;
        }
        process_all(seq, config)
    };
    let yaw = |p: &Pose<f64>| so3_log(&p.rotation).z;
    let off = run(false, 0.0, 1.0);
    // The threshold: the median change of the yaw between consecutive estimated frames of the
    // run without the rule, so that about half of them cross it.
    let mut changes: Vec<f64> = off
        .windows(2)
        .filter(|w| w.iter().all(|(_, d)| d.status == FrameStatus::Estimated))
        .map(|w| (yaw(&w[1].0) - yaw(&w[0].0)).abs())
        .collect();
    changes.sort_by(f64::total_cmp);
    let j = changes[changes.len() / 2];
    let on = run(true, j, 1.0);
    let status_only = run(true, j, 0.0);
    let sigma_z = |d: &momo_vo::FrameDiagnostics| d.param_sigmas[2];
    let (mut flagged, mut quiet) = (0, 0);
    for k in 0..off.len() {
        let (a, b, c) = (&off[k], &on[k], &status_only[k]);
        assert_eq!(a.0.rotation, b.0.rotation, "frame {k}");
        assert_eq!(a.0.translation, b.0.translation, "frame {k}");
        assert_eq!(a.0.rotation, c.0.rotation, "frame {k}");
        assert_eq!(
            (b.1.status, b.1.reason),
            (c.1.status, c.1.reason),
            "frame {k}"
        );
        let previous_moving = k > 0
            && matches!(
                off[k - 1].1.status,
                FrameStatus::Estimated | FrameStatus::Weak
            )
            && matches!(a.1.status, FrameStatus::Estimated | FrameStatus::Weak);
        let change = if previous_moving {
            (yaw(&a.0) - yaw(&off[k - 1].0)).abs()
        } else {
            0.0
        };
        if (a.1.status, a.1.reason) != (b.1.status, b.1.reason) {
            assert_eq!(a.1.status, FrameStatus::Estimated, "frame {k}");
            assert_eq!(b.1.status, FrameStatus::Weak, "frame {k}");
            assert_eq!(b.1.constraint, Constraint::Weak, "frame {k}");
            assert_eq!(b.1.reason, Some(Reason::YawChange), "frame {k}");
            assert!(change > j, "frame {k}: flagged at a change of {change}");
            assert!(sigma_z(&b.1) >= sigma_z(&a.1), "frame {k}");
            assert_eq!(
                a.1.covariance, c.1.covariance,
                "frame {k}: weight 0 widened"
            );
            flagged += 1;
        } else if previous_moving && a.1.status == FrameStatus::Estimated {
            assert!(
                change <= j,
                "frame {k}: a change of {change} left estimated"
            );
            assert_eq!(a.1.covariance, b.1.covariance, "frame {k}");
            quiet += 1;
        }
    }
    eprintln!("threshold {j}: flagged {flagged}, left estimated {quiet}");
    assert!(flagged >= 1, "no frame flagged");
    assert!(quiet >= 10, "{quiet} frames left estimated");
    for (toml, key) in [
        ("[trust]\nyaw_change = -0.01\n", "trust.yaw_change"),
        (
            "[trust]\nyaw_change_weight = 1.5\n",
            "trust.yaw_change_weight",
        ),
    ] {
        let e = config_error(toml);
        assert!(e.contains(key), "{e}");
    }
}

/// `trust.min_inlier_share` (report only): with the share set to the median inlier share of
/// the estimated frames, exactly the `estimated` frames below it become `weak` /
/// `low_support`; every pose and covariance is the one without the rule; 0 leaves every frame
/// as it was, and a share outside `[0, 1]` is rejected at its line.
#[test]
fn min_inlier_share_flags_the_frames_below_it_and_changes_no_pose() {
    let seq = &traffic(80, 3);
    let run = |share: f64| {
        let mut config = Config::default();
        config.trust.min_inlier_share = share;
        process_all(seq, config)
    };
    let off = run(0.0);
    let share_of = |d: &momo_vo::FrameDiagnostics| d.inliers as f64 / d.matches.max(1) as f64;
    let mut shares: Vec<f64> = off
        .iter()
        .filter(|(_, d)| d.status == FrameStatus::Estimated)
        .map(|(_, d)| share_of(d))
        .collect();
    shares.sort_by(f64::total_cmp);
    let median = shares[shares.len() / 2];
    let on = run(median);
    let (flagged, kept) = assert_report_only(&off, &on, Reason::LowSupport, |estimated, a, _| {
        estimated && a.1.matches > 0 && (a.1.inliers as f64) < median * a.1.matches as f64
    });
    assert!(flagged >= 5 && kept >= 5, "flagged {flagged}, kept {kept}");
    let e = config_error("[trust]\nmin_inlier_share = 1.5\n");
    assert!(e.contains("trust.min_inlier_share"), "{e}");
}

/// `trust.side_slip_change` (report only): the run with the rule is the run without it except
/// that exactly the `estimated` frames where the rule fires — recomputed here from the reported
/// motions: the side slip `β = atan2(t_y, t_x) − ω_z / 2` more than the angle and the metres
/// sideways from the running mean of the frames reported `estimated` without a competing
/// motion — become `weak` / `side_slip`, and for `trust.side_slip_hold` frames after each such
/// jump those beyond half of both thresholds. Thresholds low enough to fire on ordinary frames
/// exercise the bookkeeping; a negative distance is rejected at its line.
#[test]
fn side_slip_change_flags_the_frames_whose_direction_of_travel_jumps_and_changes_no_pose() {
    let seq = &traffic(80, 3);
    let (angle, lateral) = (0.004, 0.004);
    let run = |angle: f64| {
        let mut config = Config::default();
        config.trust.side_slip_change = angle;
        config.trust.side_slip_lateral = lateral;
        process_all(seq, config)
    };
    let off = run(0.0);
    let on = run(angle);
    let (mut centre, mut n, mut hold_left, mut held_flags) = (0.0_f64, 0_usize, 0_usize, 0);
    let hold = Config::default().trust.side_slip_hold;
    let half = momo_vo::trust::SIDE_SLIP_HOLD_FRACTION;
    let (flagged, kept) = assert_report_only(&off, &on, Reason::SideSlip, |estimated, a, b| {
        let moving = matches!(a.1.status, FrameStatus::Estimated | FrameStatus::Weak)
            && a.1.covariance.len() == a.1.free.len().pow(2);
        let t = &a.0.translation;
        let travel = t.x.hypot(t.y);
        let slip = (moving && travel > 1e-9).then(|| {
            let (x, y) = if t.x < 0.0 { (-t.x, -t.y) } else { (t.x, t.y) };
            y.atan2(x) - 0.5 * momo_core::so3_log(&a.0.rotation).z
        });
        let beyond = |f: f64| {
            slip.is_some_and(|beta| {
                let d = (beta - centre).abs();
                n >= momo_vo::trust::SIDE_SLIP_MIN_FRAMES
                    && d > f * angle
                    && travel * d.min(std::f64::consts::FRAC_PI_2).sin() > f * lateral
            })
        };
        let jumps = beyond(1.0);
        let held = !jumps && hold_left > 0 && beyond(half);
        hold_left = match (jumps, slip.is_some()) {
            (true, _) => hold,
            (false, true) => hold_left.saturating_sub(1),
            (false, false) => 0,
        };
        let fires = estimated && (jumps || held);
        held_flags += usize::from(estimated && held);
        // A held frame is flagged last: the centre reads it as the run without the hold does.
        let learns = (b.1.status == FrameStatus::Estimated || (held && estimated))
            && b.1.competing.is_none();
        // The centre learns from the frames the run with the rule reports `estimated` without a
        // competing motion (a held one as it was before its flag).
        if let Some(beta) = slip
            && learns
        {
            n += 1;
            centre += (beta - centre) / n.min(momo_vo::trust::SIDE_SLIP_CENTRE_FRAMES) as f64;
        }
        fires
    });
    assert!(
        flagged >= 3 && held_flags >= 1 && kept >= 5,
        "flagged {flagged} ({held_flags} held), kept {kept}"
    );
    let e = config_error("[trust]\nside_slip_lateral = -0.1\n");
    assert!(e.contains("trust.side_slip_lateral"), "{e}");
}

/// `trust.support_change_share` (report only): the run with the rule is the run without it
/// except that exactly the `estimated` frames where the rule fires — recomputed here from the
/// run without it: a moving frame after a moving frame whose inlier share is below `s` and
/// whose rotation vector `ω = log R` changed its yaw by more than `J` or its tilt by more than
/// `T`, or whose share is below the hold share right after a frame where it fired — become
/// `weak` / `support_change`; poses and covariances identical. The thresholds are the run's
/// own medians (so that the rule fires on this mono sequence, whose default thresholds hardly
/// fire). Out-of-range values are rejected at their line.
#[test]
fn support_change_flags_a_small_support_with_a_jump_and_changes_no_pose() {
    use momo_core::so3_log;
    let seq = &traffic(120, 3);
    let run = |c: Option<(f64, f64, f64, f64)>| {
        let mut config = Config::default();
        let (s, j, t, h) = c.unwrap_or((0.0, 0.0, 0.0, 0.0));
        config.trust.support_change_share = s;
        config.trust.support_change_yaw = j;
        config.trust.support_change_tilt = t;
        config.trust.support_change_hold_share = h;
        process_all(seq, config)
    };
    let off = run(None);
    let share_of = |d: &momo_vo::FrameDiagnostics| d.inliers as f64 / d.matches.max(1) as f64;
    let moving = |d: &momo_vo::FrameDiagnostics| {
        matches!(d.status, FrameStatus::Estimated | FrameStatus::Weak)
            && d.covariance.len() == d.free.len().pow(2)
    };
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let omega = |p: &Pose<f64>| so3_log(&p.rotation);
    let pairs = || {
        off.windows(2)
            .filter(|w| moving(&w[0].1) && moving(&w[1].1))
    };
    let s = median(
        off.iter()
            .filter(|(_, d)| moving(d))
            .map(|(_, d)| share_of(d))
            .collect(),
    );
    let j = median(
        pairs()
            .map(|w| (omega(&w[1].0) - omega(&w[0].0)).z.abs())
            .collect(),
    );
    let t = median(
        pairs()
            .map(|w| {
                let d = omega(&w[1].0) - omega(&w[0].0);
                d.x.hypot(d.y)
            })
            .collect(),
    );
    let h = 0.9 * s;
    let on = run(Some((s, j, t, h)));
    let (mut flagged, mut kept, mut held) = (0, 0, 0);
    let mut fired = false;
    for k in 0..off.len() {
        let (a, b) = (&off[k], &on[k]);
        assert_eq!(a.0.rotation, b.0.rotation, "frame {k}");
        assert_eq!(a.0.translation, b.0.translation, "frame {k}");
        assert_eq!(a.1.covariance, b.1.covariance, "frame {k}");
        let fires = k > 0 && moving(&a.1) && moving(&off[k - 1].1) && {
            let d = omega(&a.0) - omega(&off[k - 1].0);
            let share = share_of(&a.1);
            let jump = d.z.abs() > j || d.x.hypot(d.y) > t;
            let hold = fired && share < h;
            held += usize::from(hold && !(share < s && jump));
            (share < s && jump) || hold
        };
        fired = fires;
        if fires && a.1.status == FrameStatus::Estimated {
            assert_eq!(b.1.status, FrameStatus::Weak, "frame {k}");
            assert_eq!(b.1.constraint, Constraint::Weak, "frame {k}");
            assert_eq!(b.1.reason, Some(Reason::SupportChange), "frame {k}");
            flagged += 1;
        } else {
            assert_eq!(
                (a.1.status, a.1.constraint, a.1.reason),
                (b.1.status, b.1.constraint, b.1.reason),
                "frame {k}"
            );
            kept += usize::from(a.1.status == FrameStatus::Estimated);
        }
    }
    eprintln!("share {s}, yaw {j}, tilt {t}: flagged {flagged} ({held} held), kept {kept}");
    assert!(flagged >= 3 && kept >= 10, "flagged {flagged}, kept {kept}");
    for (toml, key) in [
        (
            "[trust]\nsupport_change_share = 1.5\n",
            "trust.support_change_share",
        ),
        (
            "[trust]\nsupport_change_hold_share = -0.1\n",
            "trust.support_change_hold_share",
        ),
        (
            "[trust]\nsupport_change_yaw = -0.01\n",
            "trust.support_change_yaw",
        ),
        (
            "[trust]\nsupport_change_tilt = 4.0\n",
            "trust.support_change_tilt",
        ),
    ] {
        let e = config_error(toml);
        assert!(e.contains(key), "{e}");
    }
}

/// A frame that says `estimated` reports a finite covariance; where none can be computed it is
/// flagged `weak` with `ill_conditioned` and infinite sigmas (report only). Frame 43 of
/// moving_traffic seed 2 (60 frames: 9 inliers of 300, a competing motion) has an information
/// matrix with one direction 1e14 above the data's others, past the inversion's relative
/// eigenvalue test, so every direction read as unconstrained: it was reported `estimated`,
/// `well`, with every covariance entry infinite (JSON `null`).
#[test]
fn an_estimated_frame_reports_a_finite_covariance() {
    // The reproduction as found: before the neighbourhood test ran on one camera (the default
    // since the forty-second session, under which frame 43 is well conditioned), and without
    // `trust.ill_conditioned_refit` (default since the seventy-sixth session), which reports
    // the final stage's finite covariance for such a frame (its test:
    // `an_ill_conditioned_first_stage_reports_the_refits_covariance`).
    let mut config = before_one_camera_test();
    config.trust.ill_conditioned_refit = false;
    let out = process_all(&traffic(60, 2), config);
    let mut flagged = 0;
    for (k, (_, d)) in out.iter().enumerate() {
        let k2 = d.free.len() * d.free.len();
        if d.status == FrameStatus::Estimated {
            assert_eq!(d.covariance.len(), k2, "frame {}", k + 1);
            assert!(
                d.covariance.iter().all(|v| v.is_finite()),
                "frame {}: estimated with a covariance {:?}",
                k + 1,
                d.covariance
            );
            assert!(
                d.free.iter().all(|&i| d.param_sigmas[i].is_finite()),
                "frame {}: estimated with sigmas {:?}",
                k + 1,
                d.param_sigmas
            );
        }
        if d.reason == Some(Reason::IllConditioned) {
            assert_eq!(d.status, FrameStatus::Weak, "frame {}", k + 1);
            assert_eq!(d.constraint, Constraint::Weak, "frame {}", k + 1);
            assert!(
                d.free.iter().all(|&i| d.param_sigmas[i] == f64::INFINITY),
                "frame {}: {:?}",
                k + 1,
                d.param_sigmas
            );
            flagged += 1;
        }
    }
    // The reproduction's frame stays in the test: without it the assertions above hold trivially.
    assert!(flagged >= 1, "no ill-conditioned frame in the reproduction");
}

/// The recheck tests' sequence: moving traffic, seed 4, 120 frames, 100 matches per frame pair.
fn few_match_traffic() -> momo_io::Sequence {
    let mut traffic = momo_sim::SimConfig::moving_traffic();
    traffic.frames = 120;
    traffic.seed = 4;
    traffic.matches_per_camera = 100;
    simulated(&traffic)
}

/// `seq` processed with `trust.competing_recheck_frames = k` and
/// `trust.competing_recheck_max_matches = max_matches`, the rest default.
fn recheck_run(
    seq: &momo_io::Sequence,
    k: usize,
    max_matches: usize,
) -> Vec<(Pose<f64>, momo_vo::FrameDiagnostics)> {
    let mut config = Config::default();
    config.trust.competing_recheck_frames = k;
    config.trust.competing_recheck_max_matches = max_matches;
    process_all(seq, config)
}

/// `trust.competing_recheck_frames` (report only): with few matches (100 per frame pair, a
/// bus holding most of them) the competing-motions check misses the static world on some
/// `estimated` frames; the recheck from more starts finds it there. The run with the recheck
/// is the run without it except on `estimated` frames where the check found no competitor:
/// there, where the recheck finds one, the diagnostics name it (`competing`), the covariance
/// is the mixture's (no variance smaller) and the frame is `weak` / `competing_motions` or
/// still `estimated`; every pose is identical.
#[test]
fn the_competing_recheck_widens_only_estimated_frames_and_changes_no_pose() {
    let seq = few_match_traffic();
    let (off, on) = (recheck_run(&seq, 0, 0), recheck_run(&seq, 5, 0));
    let mut rechecked = 0;
    for (k, (a, b)) in off.iter().zip(&on).enumerate() {
        assert_eq!(a.0.rotation, b.0.rotation, "frame {k}");
        assert_eq!(a.0.translation, b.0.translation, "frame {k}");
        if a.1.covariance == b.1.covariance {
            assert_eq!(
                (a.1.status, a.1.reason),
                (b.1.status, b.1.reason),
                "frame {k}"
            );
            assert_eq!(a.1.competing, b.1.competing, "frame {k}");
            continue;
        }
        rechecked += 1;
        assert_eq!(a.1.status, FrameStatus::Estimated, "frame {k}");
        assert!(a.1.competing.is_none(), "frame {k}");
        let (b_params, w) = b.1.competing.as_ref().expect("a competitor");
        assert!(
            *w > 0.0 && *w < 1.0 && b_params.len() == a.1.params.len(),
            "frame {k}"
        );
        match b.1.status {
            FrameStatus::Estimated => assert_eq!(b.1.reason, a.1.reason, "frame {k}"),
            FrameStatus::Weak => {
                assert_eq!(b.1.reason, Some(Reason::CompetingMotions), "frame {k}")
            }
            s => panic!("frame {k}: status {s:?}"),
        }
        let n = a.1.free.len();
        for j in 0..n {
            assert!(
                b.1.covariance[j * n + j] >= a.1.covariance[j * n + j],
                "frame {k}"
            );
        }
    }
    eprintln!("rechecked {rechecked} frames");
    assert!(rechecked >= 1, "the recheck found no competitor");
}

/// `trust.competing_recheck_max_matches`: the recheck runs only on frames with at most that
/// many matches (by default 5 frames back on frames with at most 150 matches). Below the
/// frames' 100 matches the run is the run without the recheck, diagnostics and all; at or
/// above it, the run is the ungated one's.
#[test]
fn the_competing_recheck_runs_only_on_frames_with_few_matches() {
    let seq = few_match_traffic();
    let run = |k: usize, max_matches: usize| recheck_run(&seq, k, max_matches);
    let key = |r: &(Pose<f64>, momo_vo::FrameDiagnostics)| {
        (
            r.0.rotation,
            r.0.translation,
            r.1.status,
            r.1.reason,
            r.1.covariance.clone(),
            r.1.competing.clone(),
        )
    };
    let same = |a: &[(Pose<f64>, momo_vo::FrameDiagnostics)],
                b: &[(Pose<f64>, momo_vo::FrameDiagnostics)]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| key(x) == key(y))
    };
    let defaults = Config::default().trust;
    assert_eq!(
        (
            defaults.competing_recheck_frames,
            defaults.competing_recheck_max_matches
        ),
        (5, 150)
    );
    let (off, ungated) = (run(0, 0), run(5, 0));
    assert!(!same(&off, &ungated), "the recheck changed nothing here");
    assert!(same(&run(5, 10), &off));
    assert!(same(&run(5, 100), &ungated));
}

/// `trust.unconfirmed_start` (report only): the run with the rule is the run without it except
/// that exactly the `estimated` frames with a competing motion before the first frame that the
/// run reports `estimated` without one become `weak` / `unconfirmed_start`; poses and
/// covariances identical. Every independent pair of `estimate_batch` is such a start, so there
/// every `estimated` pair with a competing motion is flagged.
#[test]
fn unconfirmed_start_flags_the_competing_frames_before_the_run_confirmed_a_motion() {
    let seq = &traffic(60, 2);
    let config = |flag: bool| {
        let mut config = Config::default();
        config.trust.unconfirmed_start = flag;
        // The first confirming frame settles the start (`unconfirmed_start_frames`, tested
        // below).
        config.trust.unconfirmed_start_frames = 1;
        config.trust.unconfirmed_start_distance = 0.0;
        config
    };
    // Along the sequence: the frames before the first confirmed one.
    let mut confirmed = false;
    let (flagged, kept) = assert_report_only(
        &process_all(seq, config(false)),
        &process_all(seq, config(true)),
        Reason::UnconfirmedStart,
        |_, a, b| {
            // The last report-only flag: a frame `ill_conditioned` without it keeps that.
            let fires =
                a.1.status == FrameStatus::Estimated && !confirmed && a.1.competing.is_some();
            confirmed |= b.1.status == FrameStatus::Estimated && b.1.competing.is_none();
            fires
        },
    );
    assert!(
        confirmed && flagged >= 1 && kept >= 10,
        "flagged {flagged}, kept {kept}"
    );
    // Independent pairs: each is a start.
    let pairs: Vec<momo_vo::FramePair> = (1..seq.num_frames())
        .map(|k| {
            let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
            momo_vo::FramePair::new(seq.frames[k].clone(), arc)
        })
        .collect();
    let batch = |flag: bool| -> Vec<Frame> {
        momo_vo::estimate_batch(&seq.rig, &config(flag), &pairs, 2)
            .expect("estimated")
            .into_iter()
            .map(|r| (r.motion, r.diagnostics))
            .collect()
    };
    let (flagged, kept) = assert_report_only(
        &batch(false),
        &batch(true),
        Reason::UnconfirmedStart,
        |_, a, _| a.1.status == FrameStatus::Estimated && a.1.competing.is_some(),
    );
    assert!(flagged >= 1 && kept >= 5, "flagged {flagged}, kept {kept}");
}

/// The start rule of `trust.unconfirmed_start_frames` / `trust.unconfirmed_start_distance`
/// replayed on a run without it: a contested start settles once `frames` clean frames in a row
/// (reported `estimated` without a competing motion) have travelled `distance` metres together.
struct StartReplay {
    frames: usize,
    distance: f64,
    clean_run: usize,
    run_distance: f64,
    contested: bool,
    settled: bool,
}

impl StartReplay {
    fn new(frames: usize, distance: f64) -> Self {
        let (clean_run, run_distance, contested, settled) = (0, 0.0, false, false);
        Self {
            frames,
            distance,
            clean_run,
            run_distance,
            contested,
            settled,
        }
    }

    /// Whether the rule flags the frame `a` (`arc`: the arc length's index in its parameters).
    fn fires(&mut self, a: &Frame, arc: usize) -> bool {
        let unsettled = !self.settled;
        let competing = a.1.competing.is_some();
        let estimated = a.1.status == FrameStatus::Estimated;
        let clean = estimated && !competing;
        self.clean_run = if clean { self.clean_run + 1 } else { 0 };
        self.run_distance = if clean {
            self.run_distance + a.1.params[arc].abs()
        } else {
            0.0
        };
        self.contested |= competing;
        self.settled |= self.clean_run >= self.frames && self.run_distance >= self.distance;
        estimated && unsettled && (competing || (clean && self.contested && !self.settled))
    }
}

/// The index of the arc length among a run's parameters.
fn arc_index(run: &[Frame]) -> usize {
    run[0]
        .1
        .param_names
        .iter()
        .position(|n| n == "arc_length")
        .expect("an arc length")
}

/// `trust.unconfirmed_start_frames` (report only): with 3, the run is the run with 1 except
/// that, until three frames in a row are reported `estimated` without a competing motion, every
/// `estimated` frame with a competing motion, and after a competing motion every such frame but
/// the third in a row, becomes `weak` / `unconfirmed_start`; poses and covariances identical.
#[test]
fn unconfirmed_start_frames_flags_a_contested_start_until_it_settles() {
    let seq = &traffic(60, 1);
    let config = |frames: usize| {
        let mut config = Config::default();
        config.trust.unconfirmed_start_frames = frames;
        // The frames rule alone (`unconfirmed_start_distance` is tested below).
        config.trust.unconfirmed_start_distance = 0.0;
        config
    };
    let off = process_all(seq, config(1));
    let arc = arc_index(&off);
    let mut rule = StartReplay::new(3, 0.0);
    let mut clean_flagged = 0;
    let (flagged, kept) = assert_report_only(
        &off,
        &process_all(seq, config(3)),
        Reason::UnconfirmedStart,
        |_, a, _| {
            let fires = rule.fires(a, arc);
            clean_flagged += usize::from(fires && a.1.competing.is_none());
            fires
        },
    );
    assert!(
        rule.settled && clean_flagged >= 1 && kept >= 10,
        "flagged {flagged} ({clean_flagged} without a competing motion), kept {kept}"
    );
    let e = config_error("[trust]\nunconfirmed_start_frames = 0\n");
    assert!(e.contains("trust.unconfirmed_start_frames"), "{e}");
}

/// `trust.unconfirmed_start_distance` (report only): with 3 frames and 3 m, the run is the run
/// with 3 frames alone except that the start settles only once the clean frames in a row have
/// also travelled 3 m together (their reported arc lengths; at about 0.85 m per frame here, a
/// fourth frame); the frames flagged in between are `weak` / `unconfirmed_start`, poses and
/// covariances identical.
#[test]
fn unconfirmed_start_distance_holds_the_start_until_the_clean_frames_travelled_that_far() {
    let seq = &traffic(120, 1);
    let config = |distance: f64| {
        let mut config = Config::default();
        config.trust.unconfirmed_start_distance = distance;
        config
    };
    let off = process_all(seq, config(0.0));
    let arc = arc_index(&off);
    // The rule with the distance, and with three frames alone.
    let (mut rule, mut frames_alone) = (StartReplay::new(3, 3.0), StartReplay::new(3, 0.0));
    let mut newly = 0;
    let (flagged, kept) = assert_report_only(
        &off,
        &process_all(seq, config(3.0)),
        Reason::UnconfirmedStart,
        |_, a, _| {
            let (fires, fires_alone) = (rule.fires(a, arc), frames_alone.fires(a, arc));
            newly += usize::from(fires && !fires_alone);
            fires
        },
    );
    assert!(
        rule.settled && newly >= 1 && kept >= 5,
        "flagged {flagged} ({newly} more than with three frames alone), kept {kept}"
    );
    let e = config_error("[trust]\nunconfirmed_start_distance = -1.0\n");
    assert!(e.contains("trust.unconfirmed_start_distance"), "{e}");
}

/// `trust.unconfirmed_start_distance`, measured case (eighty-second session): moving traffic
/// along KITTI 07, seed 102, at 2 px (`momo simulate --scenario moving_traffic --trajectory 07
/// --seed 102 --pixel-noise 2`, 500 frames; the first 16 run here). A bus holds about 64 % of
/// the matches while the vehicle starts at 0.19-0.21 m per frame; frames 1-11 are flagged
/// (a second motion, yaw changes), frames 12-14 are clean and follow the bus. With three
/// frames alone frame 14 settles the start, reported `estimated` more than 1 deg and more
/// than three yaw sigmas off; with 1 m the three frames have not travelled far enough and it
/// is `weak` / `unconfirmed_start`, its pose the same.
#[test]
fn a_slow_start_beside_a_bus_is_not_settled_by_three_short_frames() {
    use crate::support::first_errors_and_diagnostics;
    let Some(sim) = along_kitti("07", 500, 102, 2.0, momo_sim::SimConfig::moving_traffic()) else {
        return;
    };
    let run = |distance: f64| {
        let mut config = Config::default();
        config.trust.unconfirmed_start_distance = distance;
        first_errors_and_diagnostics(&sim, config, 16)
    };
    let (without, with) = (run(0.0), run(1.0));
    // Entry k - 1 is frame k.
    let (error, d) = &without[13];
    assert_eq!(d.status, FrameStatus::Estimated);
    assert!(
        *error > 1.0 && error.to_radians() > 3.0 * d.param_sigmas[2],
        "frame 14: {error} deg, yaw sigma {} rad",
        d.param_sigmas[2]
    );
    let d = &with[13].1;
    assert_eq!(
        (d.status, d.reason),
        (FrameStatus::Weak, Some(Reason::UnconfirmedStart))
    );
    for (a, b) in without.iter().zip(&with) {
        assert_eq!(a.0, b.0);
        assert_eq!(a.1.covariance, b.1.covariance);
    }
}

/// `trust.unconfirmed_start_frames`, measured case (sixty-seventh session): moving traffic
/// along the built-in drive, seed 17, at 3 px (`momo simulate --scenario moving_traffic --seed
/// 17 --pixel-noise 3`, 500 frames; the first 12 run here). Frames 1-8 find a second motion;
/// frames 9-11, without one, follow the vehicle 1.3-1.45 deg off. With one frame confirming
/// the start, frame 10 is reported `estimated` more than three yaw sigmas off; with three,
/// frames 9 and 10 are `weak` / `unconfirmed_start`, and the poses are the same.
#[test]
fn a_start_beside_a_vehicle_is_flagged_until_three_frames_settle_it() {
    use crate::support::first_errors_and_diagnostics;
    let sim = momo_sim::simulate(&momo_sim::SimConfig {
        frames: 500,
        seed: 17,
        pixel_noise: 3.0,
        ..momo_sim::SimConfig::moving_traffic()
    })
    .expect("simulated");
    // `trust.contested_hold_doubted` off: since the seventy-eighth session the yaw-change
    // rule's hold, which the competing frames 1-8 no longer spend, flags frames 9 and 10 too
    // (checked below); this test isolates the start's confirmation.
    let run = |frames: usize, hold_doubted: bool| {
        let mut config = Config::default();
        config.trust.unconfirmed_start_frames = frames;
        config.trust.unconfirmed_start_distance = 0.0;
        config.trust.contested_hold_doubted = hold_doubted;
        first_errors_and_diagnostics(&sim, config, 12)
    };
    let (one, three) = (run(1, false), run(3, false));
    // Entry k - 1 is frame k.
    let (error, d) = &one[9];
    assert_eq!(d.status, FrameStatus::Estimated);
    assert!(
        *error > 1.0 && error.to_radians() > 3.0 * d.param_sigmas[2],
        "frame 10: {error} deg, yaw sigma {} rad",
        d.param_sigmas[2]
    );
    for k in [9, 10] {
        let d = &three[k - 1].1;
        assert!(three[k - 1].0 > 1.0, "frame {k}");
        assert_eq!(
            (d.status, d.reason),
            (FrameStatus::Weak, Some(Reason::UnconfirmedStart)),
            "frame {k}"
        );
    }
    for (a, b) in one.iter().zip(&three) {
        assert_eq!(a.0, b.0);
        assert_eq!(a.1.covariance, b.1.covariance);
    }
    // With the hold kept through doubted frames (the default) and one frame confirming the
    // start, the yaw-change rule flags frames 9 and 10 itself: the jump onto the vehicle came
    // after competing frames, which do not spend the hold.
    let held = run(1, true);
    for k in [9, 10] {
        let d = &held[k - 1].1;
        assert_eq!(
            (d.status, d.reason),
            (FrameStatus::Weak, Some(Reason::YawChange)),
            "frame {k}"
        );
        assert_eq!(held[k - 1].0, one[k - 1].0, "frame {k}");
    }
}

/// `trust.contested_yaw_change` (default, report only): moving traffic along KITTI 07 with
/// 100 matches per frame pair, seed 2, 100 frames (`MOMO_DATA`). From frame 17 the run
/// follows a vehicle: its yaw jumps 1.5 deg after frames with a competing motion and stays
/// there; frame 18 was reported `estimated` 1.93 deg off. With the rule it is `weak` /
/// `yaw_change`, its covariance holding the motion before the jump, and every pose, and every
/// frame the rule leaves, is the run's without it. Each frame it flags had a competing motion
/// within `contested_frames` and a yaw more than `contested_yaw_change` from the previous
/// frame's or, held, from one of the three before the jump.
#[test]
fn a_yaw_jump_where_two_motions_compete_is_flagged_and_changes_no_pose() {
    let scenario = momo_sim::SimConfig {
        matches_per_camera: 100,
        ..momo_sim::SimConfig::moving_traffic()
    };
    let Some(sim) = along_kitti("07", 100, 2, 1.0, scenario) else {
        return;
    };
    // The start's distance (`unconfirmed_start_distance`, since the eighty-second session)
    // flags frame 18 too, as `unconfirmed_start`: KITTI 07 starts slowly. Off here, so that
    // this test isolates the yaw-change rule.
    let base = || {
        let mut config = Config::default();
        config.trust.unconfirmed_start_distance = 0.0;
        config
    };
    let mut off = base();
    off.trust.contested_yaw_change = 0.0;
    let on = errors_and_diagnostics(&sim, base());
    let off = errors_and_diagnostics(&sim, off);
    let t = &Config::default().trust;
    let yaw = |d: &momo_vo::FrameDiagnostics| d.params[2];
    let mut flagged = Vec::new();
    for k in 0..on.len() {
        let ((e, a), (_, b)) = (&off[k], &on[k]);
        assert_eq!(a.params, b.params, "frame {}", k + 1);
        if (a.status, a.reason) == (b.status, b.reason) {
            assert_eq!(a.covariance, b.covariance, "frame {}", k + 1);
            continue;
        }
        assert_eq!(a.status, FrameStatus::Estimated, "frame {}", k + 1);
        assert_eq!(
            (b.status, b.reason),
            (FrameStatus::Weak, Some(Reason::YawChange))
        );
        assert!(b.param_sigmas[2] >= a.param_sigmas[2], "frame {}", k + 1);
        let window = k.saturating_sub(t.contested_frames)..=k;
        assert!(
            off[window].iter().any(|(_, d)| d.competing.is_some()),
            "frame {}",
            k + 1
        );
        // The motion before the jump: among the three frames before it, and the hold spans
        // `contested_hold` frames besides those another rule already doubts
        // (`contested_hold_doubted`).
        let mut start = k;
        let mut counted = 0;
        while start > 0 && counted < 1 + t.contested_hold + 3 {
            start -= 1;
            if off[start].1.status == FrameStatus::Estimated || !t.contested_hold_doubted {
                counted += 1;
            }
        }
        let before = &off[start..k];
        assert!(
            before
                .iter()
                .any(|(_, d)| (yaw(a) - yaw(d)).abs() > t.contested_yaw_change),
            "frame {}",
            k + 1
        );
        flagged.push((k + 1, *e, b.param_sigmas[2]));
    }
    eprintln!("flagged (frame, error deg, yaw sigma rad): {flagged:?}");
    // Frame 18: more than 1 deg off, flagged, its yaw sigma now covering the error.
    let (_, e, sigma) = *flagged
        .iter()
        .find(|f| f.0 == 18)
        .expect("frame 18 flagged");
    assert!(e > 1.0, "frame 18: {e} deg");
    assert!(
        e.to_radians() < 3.0 * sigma,
        "frame 18: {e} deg, yaw sigma {sigma} rad"
    );
    // The options are checked.
    let e = config_error("[trust]\ncontested_yaw_change = -0.01\n");
    assert!(e.contains("trust.contested_yaw_change"), "{e}");
    let e = config_error("[trust]\ncontested_noise_slope = 2.0\n");
    assert!(e.contains("trust.contested_noise_slope"), "{e}");
}

/// `trust.side_slip_hold_pulled` (report only): along the built-in drive with moving traffic at
/// 3 px, seed 11 (the hold-out set's drive s11 at 3 px, 500 frames; the first 348 frame pairs
/// run here), a vehicle pulls the estimate sideways through frames 340-352. The separation's
/// multi-frame choice replaces the pulled motion in frames 344-346, so no reported motion
/// there slides and the side-slip hold does not start from them; frames 347-348 then slide by
/// 0.046 rad (1.04-1.06 deg off), below the full angle of `trust.side_slip_change`. With the
/// hold started by the replaced frame they are flagged `weak` / `side_slip`; without it they
/// are `estimated`. The poses are the same. Both runs with `odometry.decide_by_road_tilt_trusted
/// = false`: since the eightieth session that default keeps frames 347-348 from sliding (0.27 /
/// 0.24 deg, `weak`), so the stretch the hold is tested on needs the earlier choice.
#[test]
fn the_side_slip_hold_starts_after_a_frame_a_vehicle_pulled() {
    use crate::support::first_errors_and_diagnostics;
    assert!(Config::default().trust.side_slip_hold_pulled);
    let sim = momo_sim::simulate(&momo_sim::SimConfig {
        frames: 500,
        seed: 11,
        pixel_noise: 3.0,
        ..momo_sim::SimConfig::moving_traffic()
    })
    .expect("simulated");
    let config = |hold: bool| {
        let mut c = Config::default();
        c.odometry.decide_by_road_tilt_trusted = false;
        c.trust.side_slip_hold_pulled = hold;
        c
    };
    let on = first_errors_and_diagnostics(&sim, config(true), 348);
    let off = first_errors_and_diagnostics(&sim, config(false), 348);
    for (k, ((_, a), (_, b))) in off.iter().zip(&on).enumerate() {
        assert_eq!(a.params, b.params, "frame {}", k + 1);
    }
    for k in [347, 348] {
        let ((e, a), (_, b)) = (&off[k - 1], &on[k - 1]);
        assert!(*e > 1.0, "frame {k}: {e}");
        assert_eq!(
            a.status,
            FrameStatus::Estimated,
            "frame {k} without the pull's hold"
        );
        assert_eq!(b.status, FrameStatus::Weak, "frame {k} with it");
        assert_eq!(b.reason, Some(Reason::SideSlip), "frame {k}");
    }
}

/// The static `outliers` scenario (built-in drive, seed 2, 120 frames) through one odometry with
/// `config`: each frame's motion, diagnostics and rotation NEES ([`rotation_nees`]).
fn outliers_run(config: Config) -> Vec<(Pose<f64>, momo_vo::FrameDiagnostics, Option<f64>)> {
    let sim = momo_sim::simulate(&momo_sim::SimConfig {
        frames: 120,
        seed: 2,
        ..momo_sim::SimConfig::outliers()
    })
    .expect("simulated");
    let seq = &sim.sequence;
    let mut vo = Odometry::new(seq.rig.clone(), config).expect("valid");
    (1..seq.num_frames())
        .map(|k| {
            let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
            let r = vo.process(&seq.frames[k], arc);
            let nees = rotation_nees(&vo, &r.diagnostics, &sim.vehicle_motions[k].rotation);
            (r.motion, r.diagnostics, nees)
        })
        .collect()
}

/// `trust.report_covariance`: the reported covariance's start (the first stage's curvature,
/// the first stage's over the sandwich's residual variance, or the final stage's own
/// curvature on its support) changes no pose and no status but the report-only
/// `ill_conditioned` (a frame whose first-stage covariance had an unconstrained direction can
/// report the refit's finite one). On the static `outliers` scenario (30 % mismatches) the
/// first stage's Cauchy fit at the noise's scale is less efficient than the final stage's
/// estimate it is reported with: the refit's curvature is narrower and still holds the
/// errors (rotation NEES inside the 95 % chi-square bound).
#[test]
fn the_reported_covariance_can_start_from_the_refit_and_changes_no_pose() {
    const CHI2_3_95: f64 = 7.814_727_903_251_178;
    let run = |report: momo_vo::trust::ReportCovariance| {
        let mut config = Config::default();
        config.trust.report_covariance = report;
        outliers_run(config)
    };
    use momo_vo::trust::ReportCovariance as R;
    assert_eq!(Config::default().trust.report_covariance, R::FirstStage);
    let first = run(R::FirstStage);
    let mean = |frames: &[(Pose<f64>, momo_vo::FrameDiagnostics, Option<f64>)]| {
        let scored: Vec<f64> = frames
            .iter()
            .filter(|f| f.1.status == FrameStatus::Estimated)
            .filter_map(|f| f.2)
            .collect();
        let inside = scored.iter().filter(|n| **n <= CHI2_3_95).count();
        (
            scored.iter().sum::<f64>() / scored.len() as f64,
            inside as f64 / scored.len() as f64,
            scored.len(),
        )
    };
    let (nees_first, _, n_first) = mean(&first);
    for report in [R::Sandwich, R::Refit] {
        let other = run(report);
        let mut changed = 0;
        for (k, (a, b)) in first.iter().zip(&other).enumerate() {
            assert_eq!(a.0.rotation, b.0.rotation, "{report:?} frame {k}");
            assert_eq!(a.0.translation, b.0.translation, "{report:?} frame {k}");
            if (a.1.status, a.1.reason) != (b.1.status, b.1.reason) {
                assert_eq!(
                    a.1.reason,
                    Some(Reason::IllConditioned),
                    "{report:?} frame {k}"
                );
                assert_eq!(b.1.status, FrameStatus::Estimated, "{report:?} frame {k}");
                changed += 1;
            }
            changed += usize::from(a.1.covariance != b.1.covariance);
        }
        assert!(changed > 0, "{report:?} changed no covariance");
        let (nees, inside, n) = mean(&other);
        eprintln!(
            "{report:?}: mean NEES {nees:.3} (first stage {nees_first:.3} over {n_first} frames), {inside:.3} inside over {n}"
        );
        assert!(
            n >= 100 && inside >= 0.95,
            "{report:?}: {inside} inside over {n}"
        );
        if report == R::Refit {
            assert!(nees > 1.3 * nees_first, "{nees} against {nees_first}");
        }
    }
}

/// `trust.ill_conditioned_refit` (default): a frame whose first-stage covariance has a
/// direction it does not constrain, while the final stage's own curvature constrains every
/// direction, reports the latter (then widened as any other) instead of being flagged
/// `ill_conditioned`. Only those frames change: every pose and every other frame's status and
/// covariance stay; the frames it clears hold their errors (rotation NEES inside the 99.9 %
/// chi-square bound). On this drive (the static `outliers` scenario, seed 2) frame 71's
/// first-stage information holds one match's spike.
#[test]
fn an_ill_conditioned_first_stage_reports_the_refits_covariance() {
    const CHI2_3_999: f64 = 16.266_236_196_238_1;
    let run = |on: bool| {
        let mut config = Config::default();
        config.trust.ill_conditioned_refit = on;
        outliers_run(config)
    };
    assert!(Config::default().trust.ill_conditioned_refit);
    let (off, on) = (run(false), run(true));
    let mut cleared = 0;
    for (k, (a, b)) in off.iter().zip(&on).enumerate() {
        assert_eq!(a.0.rotation, b.0.rotation, "frame {k}");
        assert_eq!(a.0.translation, b.0.translation, "frame {k}");
        if a.1.reason == Some(Reason::IllConditioned) {
            assert_eq!(b.1.status, FrameStatus::Estimated, "frame {k}");
            assert!(b.1.covariance.iter().all(|v| v.is_finite()), "frame {k}");
            let nees = b.2.expect("a covariance");
            eprintln!("frame {}: cleared, rotation NEES {nees:.2}", k + 1);
            assert!(nees <= CHI2_3_999, "frame {k}: NEES {nees}");
            cleared += 1;
        } else {
            assert_eq!(
                (a.1.status, a.1.reason),
                (b.1.status, b.1.reason),
                "frame {k}"
            );
            assert_eq!(a.1.covariance, b.1.covariance, "frame {k}");
        }
    }
    assert!(cleared >= 1, "no ill-conditioned frame on this drive");
}

//! Hostile geometry: inputs that are valid by `FORMAT.md` but give the estimator little or
//! misleading information. Each test states the documented behaviour (`docs/GUARANTEES.md`) and
//! asserts it: a bounded error, a status or scale flag, or what the diagnostics reveal. The
//! cases of `degenerate.rs` (no matches in one frame, standstill with a small rotation, a
//! blinded camera, a solver failure, a sharp turn, scale with and without a lever arm) are not
//! repeated here.

use momo_core::{
    Camera, CameraModel, FrameObservations, Observation, Pose, Rig, RigCamera, so3_exp,
};
use momo_testing::canned;
use momo_vo::{Config, EstimatorKind, FrameStatus, Odometry, Reason, ScaleSource};
use nalgebra::{Vector2, Vector3};

use crate::support;
use support::*;

fn assert_finite_orthonormal(m: &Pose<f64>) {
    assert!(
        m.rotation
            .iter()
            .chain(m.translation.iter())
            .all(|v| v.is_finite())
    );
    assert!(m.orthonormality_error() < 1e-9, "{m:?}");
}

/// The default estimator, warmed up on `frames` ordinary frames of `warm_motion`.
fn warmed_up(rig: &Rig, warm_motion: &Pose<f64>, frames: usize, rng: &mut Rng) -> Odometry {
    warmed_up_with(rig, Config::default(), warm_motion, frames, rng)
}

fn warmed_up_with(
    rig: &Rig,
    config: Config,
    warm_motion: &Pose<f64>,
    frames: usize,
    rng: &mut Rng,
) -> Odometry {
    let mut vo = Odometry::new(rig.clone(), config).expect("valid");
    for _ in 0..frames {
        let r = vo.process(&frame(rig, warm_motion, 150, 0.5, rng), Some(1.0));
        assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
    }
    vo
}

// ------------------------------------------------------------------------------ pure rotation

/// Pure rotation (the camera turns about its centre, no translation) while odometry reports
/// 1 m: every translation fits the matches, so only the rotation is determined. It is recovered
/// to noise level; the translation's length is the odometry's, but its direction is not
/// determined by the matches and comes out arbitrary (measured: heading 8.6, climb -7.7
/// degrees; the truth is a sideways swing of the motion centre, heading 91 degrees). The
/// diagnostics hint at it only weakly: the standard deviations of `heading` and `climb` are
/// 2.6x and 8x those of an ordinary frame.
/// A known limitation: without a prior on the direction of travel (DESIGN.md: keep it near the
/// vehicle's forward axis) a pose prior from such a frame has a wrong translation direction.
#[test]
fn pure_rotation_recovers_the_rotation_and_takes_translation_from_the_priors() {
    let mut rng = Rng(1);
    let rig = canned::pinhole_rig();
    let mut vo = warmed_up(&rig, &drive(0.0, 1.0), 3, &mut rng);
    let ordinary = vo.process(
        &frame(&rig, &drive(0.0, 1.0), 200, 0.5, &mut rng),
        Some(1.0),
    );
    // 3 degrees of yaw and 0.5 of pitch about the camera centre: the vehicle motion that
    // leaves camera 0's centre in place.
    let p = rig.cameras()[0].t_vehicle_camera;
    let cam_rot = Pose::new(
        so3_exp(&Vector3::new(
            0.0,
            0.5_f64.to_radians(),
            3.0_f64.to_radians(),
        )),
        Vector3::zeros(),
    );
    let truth = p.compose(&cam_rot).compose(&p.inverse());
    let obs = frame(&rig, &truth, 200, 0.5, &mut rng);
    let r = vo.process(&obs, Some(1.0));
    assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
    assert_finite_orthonormal(&r.motion);
    let err = rot_err_deg(&r.motion, &truth);
    let (t, tt) = (r.motion.translation, truth.translation);
    eprintln!(
        "pure rotation: rotation error {err:.4} deg, heading {:.2} climb {:.2} deg (truth {:.2} {:.2})",
        t.y.atan2(t.x).to_degrees(),
        t.z.atan2(t.x.hypot(t.y)).to_degrees(),
        tt.y.atan2(tt.x).to_degrees(),
        tt.z.atan2(tt.x.hypot(tt.y)).to_degrees(),
    );
    assert!(err < 0.05, "rotation error {err} deg");
    // The length is the odometry's (Se3: |t| = l sinc(θ/2), θ ≈ 3°).
    let n = r.motion.translation.norm();
    assert!((n - 1.0).abs() < 1e-3, "|t| = {n}");
    // heading and climb (parameters 3 and 4) are not determined by the matches.
    let (s, s0) = (
        &r.diagnostics.param_sigmas,
        &ordinary.diagnostics.param_sigmas,
    );
    eprintln!(
        "pure rotation: sigma heading {:.2e} climb {:.2e} (ordinary frame {:.2e} {:.2e})",
        s[3], s[4], s0[3], s0[4]
    );
    assert!(s[3] > 2.0 * s0[3] && s[4] > 2.0 * s0[4], "{s:?} vs {s0:?}");
}

// --------------------------------------------------------------------------------- standstill

/// Standstill without odometry: the matches do not move (zero flow plus noise). Zero flow fits
/// any translation (points at infinity), so the matches cannot tell "standing" from "driving";
/// the rotation is recovered (identity), the arc length cannot be estimated (scale `held`) and
/// the last arc length is kept. With odometry (arc length 0) the frame is `standstill` (see
/// `degenerate.rs`).
#[test]
fn standstill_without_odometry_gets_the_rotation_and_holds_the_scale() {
    let mut rng = Rng(2);
    let rig = canned::pinhole_rig();
    let mut vo = warmed_up(&rig, &drive(0.01, 1.0), 3, &mut rng);
    let still = Pose::identity();
    for _ in 0..5 {
        let obs = frame(&rig, &still, 150, 0.5, &mut rng);
        let r = vo.process(&obs, None);
        assert_finite_orthonormal(&r.motion);
        let err = rot_err_deg(&r.motion, &still);
        eprintln!(
            "standstill, no odometry: rotation error {err:.4} deg, arc length {:.3} (sigma {:.3}), scale {:?}, status {:?}",
            r.diagnostics.params[5],
            r.diagnostics.param_sigmas[5],
            r.diagnostics.scale,
            r.diagnostics.status
        );
        assert!(err < 0.05, "rotation error {err} deg");
        assert_eq!(r.diagnostics.scale, ScaleSource::Held);
        assert!((r.diagnostics.params[5] - 1.0).abs() < 1e-9);
    }
}

// ------------------------------------------------------------------- one moving object only

/// Every match lies on one object that moves on its own (a lorry filling the view, turning by
/// 2 degrees and moving 0.3 m per frame relative to the scene). No estimator can tell this from
/// ego-motion within one frame: momo returns the camera's motion *relative to the object*
/// (within noise), flags nothing, and the error against the true ego-motion is the object's
/// own motion. Documented as a limitation; the defence is more than one rigid structure in
/// view (see `degenerate.rs` and the simulator's moving-object scenario). Shown with the free
/// model `se3`; the default `soft_single_track` is pulled part of the way from this apparent
/// motion (it slips sideways) towards a motion a car makes (measured: 0.24 deg from the
/// apparent motion), still about 2 deg from the ego-motion.
#[test]
fn all_matches_on_one_moving_object_give_the_motion_relative_to_the_object() {
    for free in [true, false] {
        one_moving_object(free);
    }
}

fn one_moving_object(free: bool) {
    let mut rng = Rng(3);
    let rig = canned::pinhole_rig();
    let ego = drive(0.0, 1.0);
    let mut config = Config::default();
    if free {
        config.model = Box::new(momo_models::Se3);
    }
    let mut vo = warmed_up_with(&rig, config, &ego, 3, &mut rng);
    // Object motion in the vehicle frame at k-1: a point X goes to O X.
    let object = Pose::new(
        so3_exp(&Vector3::new(0.0, 0.0, 2.0_f64.to_radians())),
        Vector3::new(0.3, 0.1, 0.0),
    );
    // In the vehicle frame at k the point is at M⁻¹ O X: the scene looks as if the vehicle
    // moved by O⁻¹ M.
    let apparent = object.inverse().compose(&ego);
    let obs = frame(&rig, &apparent, 200, 0.5, &mut rng);
    let r = vo.process(&obs, Some(1.0));
    assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
    assert_finite_orthonormal(&r.motion);
    let to_apparent = rot_err_deg(&r.motion, &apparent);
    let to_ego = rot_err_deg(&r.motion, &ego);
    eprintln!(
        "moving object: error {to_apparent:.4} deg to the relative motion, {to_ego:.3} deg to the ego-motion"
    );
    if free {
        assert!(to_apparent < 0.05, "{to_apparent}");
        assert!(to_ego > 1.9, "{to_ego}");
    } else {
        // Between the two, much nearer the apparent motion: the limitation stands.
        assert!(to_apparent < 0.5, "{to_apparent}");
        assert!(to_ego > 1.5, "{to_ego}");
    }
}

// ----------------------------------------------------------------------------- 90% outliers

/// 90% outliers (270 of 300 matches random pixels, 30 true matches), warm-started: the
/// rotation error stays below 1 degree (measured: 0.06-0.46 deg over these 10 frames, against
/// ~0.02 deg without outliers), and the diagnostics reveal the situation: the inlier ratio
/// (`inliers / matches`) drops below 0.15, where an ordinary frame shows more than 0.5, and the
/// extra starts were tried (`restarts`).
#[test]
fn ninety_percent_outliers_keep_the_error_bounded_and_show_in_the_inlier_ratio() {
    let mut rng = Rng(4);
    let rig = canned::pinhole_rig();
    let mut vo = warmed_up(&rig, &drive(0.01, 1.0), 3, &mut rng);
    let ordinary = vo.process(
        &frame(&rig, &drive(0.01, 1.0), 300, 0.5, &mut rng),
        Some(1.0),
    );
    let ordinary_ratio = ordinary.diagnostics.inliers as f64 / 300.0;
    eprintln!("ordinary frame: inlier ratio {ordinary_ratio:.2}");
    assert!(ordinary_ratio > 0.5);
    let model = rig.cameras()[0].model;
    let (w, h) = model.size();
    let mut worst: f64 = 0.0;
    for k in 0..10 {
        let truth = drive(0.01 + 0.004 * (k % 3) as f64, 1.0);
        let mut obs = frame(&rig, &truth, 30, 0.5, &mut rng);
        for _ in 0..270 {
            let p0 = Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0));
            let p1 = Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0));
            obs.per_camera[0].extend(Observation::new(&model, p0, p1));
        }
        let r = vo.process(&obs, Some(1.0));
        assert_finite_orthonormal(&r.motion);
        let err = rot_err_deg(&r.motion, &truth);
        let ratio = r.diagnostics.inliers as f64 / r.diagnostics.matches as f64;
        eprintln!(
            "90% outliers, frame {k}: rotation error {err:.4} deg, inlier ratio {ratio:.2}, restarts {}",
            r.diagnostics.restarts
        );
        assert!(ratio < 0.15, "inlier ratio {ratio}");
        assert!(r.diagnostics.restarts > 0);
        worst = worst.max(err);
    }
    assert!(worst < 1.0, "worst rotation error {worst} deg");
}

// ------------------------------------------------------------------ all matches in a corner

/// All matches in one image corner (the top-left 12% x 25% of a KITTI image, a field of view of
/// about 12 x 7 degrees): the geometry is weak and the rotation error grew to degrees in some
/// frames (measured 0.06-5.9 deg over these 5 frames, against ~0.02 with the matches spread).
/// Now (issue 15) the frame is `degenerate` (reason `small_region` or
/// `inliers_in_small_region`): the previous motion is held, with infinite sigmas.
#[test]
fn matches_in_one_corner_are_degenerate_and_hold_the_previous_motion() {
    let mut rng = Rng(5);
    let rig = canned::pinhole_rig();
    let truth = drive(0.02, 1.0);
    let model = rig.cameras()[0].model;
    let (w, h) = model.size();
    let corner = move |p: &Vector2<f64>| p.x < 0.12 * w && p.y < 0.25 * h;
    let mut spread_vo = warmed_up(&rig, &truth, 2, &mut Rng(50));
    let mut corner_vo = warmed_up(&rig, &truth, 2, &mut Rng(50));
    for _ in 0..5 {
        let spread = frame(&rig, &truth, 100, 0.5, &mut rng);
        let mut crowded = FrameObservations::new(1);
        crowded.per_camera[0] = matches(
            &rig,
            0,
            &truth,
            100,
            0.5,
            &mut rng,
            move |r| {
                let px = Vector2::new(r.uniform(0.0, 0.12 * w), r.uniform(0.0, 0.25 * h));
                model.unproject(&px).unwrap_or_else(Vector3::z)
            },
            (4.0, 40.0),
            corner,
        );
        let a = spread_vo.process(&spread, Some(1.0));
        let held = corner_vo.estimator().motion(corner_vo.previous_params());
        let b = corner_vo.process(&crowded, Some(1.0));
        assert_eq!(a.diagnostics.status, FrameStatus::Estimated);
        assert_eq!(b.diagnostics.status, FrameStatus::Degenerate);
        assert!(
            matches!(
                b.diagnostics.reason,
                Some(Reason::SmallRegion | Reason::InliersInSmallRegion)
            ),
            "{:?}",
            b.diagnostics.reason
        );
        assert_finite_orthonormal(&b.motion);
        assert!(
            rot_err_deg(&b.motion, &held) < 1e-12,
            "the previous motion is held"
        );
        assert!(b.diagnostics.param_sigmas[2].is_infinite());
        let err = rot_err_deg(&b.motion, &truth);
        eprintln!("corner: degenerate, held motion's error {err:.4} deg");
        assert!(err < 0.1, "the held motion is the warm-up's: {err} deg");
    }
}

// -------------------------------------------------------- fisheye border beyond 90 degrees

/// A fisheye sees points more than 90 degrees off its axis (behind the image plane, `z < 0`).
/// Matches only there (between 92 and 100 degrees off-axis, the left and right borders of the
/// image) are read, unprojected behind the camera and used like any other: noise-free they give
/// the exact rotation; with 0.5 px noise the error is that of the fisheye's coarse angular
/// resolution at its border (~350 px/rad, 0.16 deg per pixel; measured 0.19 deg with 150 matches,
/// 0.04 deg with the same number between 0 and 80 degrees off-axis).
#[test]
fn fisheye_matches_beyond_ninety_degrees_are_used() {
    let cam = Camera::KannalaBrandt(canned::fisheye());
    let mount = Pose::new(canned::forward_looking(), Vector3::new(2.0, 0.0, 1.0));
    let rig = Rig::mono(cam, mount).expect("valid");
    let truth = drive(0.03, 1.0);
    let border = |r: &mut Rng| {
        let theta = r.uniform(92.0_f64.to_radians(), 100.0_f64.to_radians());
        let phi = if r.uniform(0.0, 1.0) < 0.5 {
            0.0
        } else {
            std::f64::consts::PI
        } + r.uniform(-0.6, 0.6);
        Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    };
    let inside = |r: &mut Rng| {
        let theta = r.uniform(0.0, 80.0_f64.to_radians());
        let phi = r.uniform(-std::f64::consts::PI, std::f64::consts::PI);
        Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    };
    let solve = |obs: &FrameObservations| {
        let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
        let r = vo.process(obs, Some(1.0));
        assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
        rot_err_deg(&r.motion, &truth)
    };
    let one = |noise: f64, bearing: &dyn Fn(&mut Rng) -> Vector3<f64>, seed: u64| {
        let mut obs = FrameObservations::new(1);
        obs.per_camera[0] = matches(
            &rig,
            0,
            &truth,
            150,
            noise,
            &mut Rng(seed),
            bearing,
            (4.0, 40.0),
            anywhere,
        );
        obs
    };
    let exact = one(0.0, &border, 6);
    assert!(
        exact.per_camera[0]
            .iter()
            .all(|o| o.f0.z < 0.0 && o.f1.z < 0.0)
    );
    let err_exact = solve(&exact);
    let inside_err = solve(&one(0.5, &inside, 6));
    let obs = one(0.5, &border, 6);
    assert!(
        obs.per_camera[0]
            .iter()
            .all(|o| o.f0.z < 0.0 && o.f1.z < 0.0)
    );
    // The reader accepts them too.
    let dir = tempfile_dir();
    let seq = momo_io::Sequence {
        rig: rig.clone(),
        frames: vec![FrameObservations::new(1), obs.clone()],
        arc_lengths: Some(vec![None, Some(1.0)]),
        ground_truth: None,
    };
    momo_io::write_sequence(&dir, &seq).expect("writes");
    let back = momo_io::read_sequence(&dir).expect("the reader accepts pixels beyond 90 degrees");
    std::fs::remove_dir_all(&dir).ok();
    let err = solve(&back.frames[1]);
    eprintln!(
        "fisheye beyond 90 deg: rotation error {err:.4} deg ({err_exact:.2e} noise-free; {inside_err:.4} within 80 deg)"
    );
    assert!(err_exact < 1e-6, "noise-free error {err_exact} deg");
    assert!(err < 0.5, "rotation error {err} deg");
}

fn tempfile_dir() -> std::path::PathBuf {
    static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "momo-hostile-{}-{}",
        std::process::id(),
        N.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

// ------------------------------------------------------- a camera without matches, 100 frames

/// One camera of a mono rig delivers nothing for 100 frame pairs: each of them is
/// `no_matches`, holds the previous rotation, takes its arc length from odometry, and the
/// estimate resumes correctly afterwards. On a four-camera fisheye rig the other cameras (25
/// matches each, 0.5 px noise) carry every frame: `estimated`, the silent camera with zero
/// inliers, rotation error below 0.3 deg (measured worst 0.12 deg over the 100 frames).
#[test]
fn a_camera_without_matches_for_100_frames() {
    let mut rng = Rng(7);
    let rig = canned::pinhole_rig();
    let turn = drive(0.02, 1.0);
    let mut vo = warmed_up(&rig, &turn, 3, &mut rng);
    let before = vo.process(&frame(&rig, &turn, 150, 0.5, &mut rng), Some(1.0));
    for k in 0..100 {
        let l = 0.5 + 0.01 * k as f64;
        let r = vo.process(&FrameObservations::new(1), Some(l));
        assert_eq!(r.diagnostics.status, FrameStatus::NoMatches);
        assert!(
            rot_err_deg(&r.motion, &before.motion) < 1e-9,
            "rotation held"
        );
        assert!(
            (r.diagnostics.params[5] - l).abs() < 1e-12,
            "odometry arc length"
        );
    }
    let truth = drive(-0.03, 1.0);
    let r = vo.process(&frame(&rig, &truth, 150, 0.5, &mut rng), Some(1.0));
    assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
    assert!(rot_err_deg(&r.motion, &truth) < 0.05);

    // Four fisheye cameras, camera 1 silent for 100 frames.
    let rig = canned::fisheye_rig();
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    let mut worst: f64 = 0.0;
    for k in 0..100 {
        let truth = drive(0.02 * ((k / 20) % 3) as f64 - 0.02, 1.0);
        let mut obs = frame(&rig, &truth, 25, 0.5, &mut rng);
        obs.per_camera[1].clear();
        let r = vo.process(&obs, Some(1.0));
        assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
        assert_eq!(r.diagnostics.inliers_per_camera[1], 0);
        worst = worst.max(rot_err_deg(&r.motion, &truth));
    }
    eprintln!("fisheye rig, camera 1 silent for 100 frames: worst rotation error {worst:.4} deg");
    assert!(worst < 0.3, "worst rotation error {worst} deg");
}

// -------------------------------------------------------------------------- duplicated matches

/// Every match given five times: identical rows are legal in `matches.csv`, but since issue 15
/// repeated matches count once, so the estimate and the reported standard deviations are those
/// of the matches once (before, the sigmas shrank by about √5: over-confident).
#[test]
fn duplicated_matches_count_once() {
    let mut rng = Rng(8);
    let rig = canned::pinhole_rig();
    let truth = drive(0.02, 1.0);
    let once = frame(&rig, &truth, 120, 0.5, &mut rng);
    let mut five = once.clone();
    five.per_camera[0] = once.per_camera[0]
        .iter()
        .flat_map(|o| std::iter::repeat_n(*o, 5))
        .collect();
    let a = Odometry::new(rig.clone(), Config::default())
        .expect("valid")
        .process(&once, Some(1.0));
    let b = Odometry::new(rig.clone(), Config::default())
        .expect("valid")
        .process(&five, Some(1.0));
    assert_eq!(b.diagnostics.matches, 120);
    let diff = a
        .diagnostics
        .params
        .iter()
        .zip(&b.diagnostics.params)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    let ratio = a.diagnostics.param_sigmas[2] / b.diagnostics.param_sigmas[2];
    eprintln!("duplicates x5: parameter difference {diff:.2e}, yaw sigma ratio {ratio:.3}");
    assert!(diff < 1e-6, "parameters moved by {diff}");
    assert!((ratio - 1.0).abs() < 1e-9, "sigma ratio {ratio}");
}

// -------------------------------------------- every camera in the motion centre, no odometry

/// A rig whose cameras all sit in the motion centre cannot observe scale, and without
/// odometry nothing else gives it: the driver says so up front (`scale_observable() == false`)
/// and in every frame's diagnostics (scale `unobservable`), keeps the arc length at
/// `odometry.initial_arc_length`, and still recovers the rotation. With odometry the same rig
/// is fine (scale `odometry`).
#[test]
fn a_rig_with_every_camera_in_the_motion_centre_says_scale_is_unobservable() {
    let mut rng = Rng(9);
    let model = Camera::Pinhole(canned::kitti_pinhole());
    let yaw = |a: f64| so3_exp(&Vector3::new(0.0, 0.0, a)) * canned::forward_looking();
    let rig = Rig::new(
        [0.0, 1.2, -1.2]
            .iter()
            .enumerate()
            .map(|(i, &a)| RigCamera {
                name: format!("c{i}"),
                model,
                t_vehicle_camera: Pose::new(yaw(a), Vector3::zeros()),
            })
            .collect(),
    )
    .expect("valid");
    let mut vo = Odometry::new(rig.clone(), Config::default()).expect("valid");
    assert!(!vo.scale_observable());
    for k in 0..6 {
        let truth = drive(0.1 * (k % 2) as f64, 1.7);
        let r = vo.process(&frame(&rig, &truth, 80, 0.5, &mut rng), None);
        assert_eq!(r.diagnostics.scale, ScaleSource::Unobservable);
        assert_eq!(r.diagnostics.status, FrameStatus::Estimated);
        assert!(
            (r.diagnostics.params[5] - 1.0).abs() < 1e-12,
            "initial arc length kept"
        );
        assert!(rot_err_deg(&r.motion, &truth) < 0.05);
    }
    let truth = drive(0.05, 1.7);
    let r = vo.process(&frame(&rig, &truth, 80, 0.5, &mut rng), Some(1.7));
    assert_eq!(r.diagnostics.scale, ScaleSource::Odometry);
    assert!((r.motion.translation - truth.translation).norm() < 0.02);

    // The 5-point baseline cannot observe scale on any rig: it says `held`.
    let mut fp = momo_vo::driver(EstimatorKind::FivePoint, &rig, Config::default()).expect("valid");
    let r = fp.process(&frame(&rig, &drive(0.05, 1.7), 80, 0.5, &mut rng), None);
    assert_eq!(r.diagnostics.scale, ScaleSource::Held);
}

// ------------------------------------------------------------------------ stop and go

/// Stop and go: the vehicle slows down to a standstill, stands for six frames and moves off
/// slowly, in a gentle curve (6 seeds, 200 matches, 0.5 px). At a few centimetres per frame the
/// direction of travel is hardly observable and wanders (heading estimates up to 1 rad were
/// seen), but the rotation stays within 0.3 degrees (measured worst: 0.11). With 1 px of noise
/// on this narrow rig the worst frame reaches 0.69 degrees (at 0.16 m per frame, heading 1.06
/// rad): a known weakness of slow frames, bounded here by the restarts. The real-trajectory
/// case (KITTI 00's stop at frames 545-552) is `tests/it/kitti.rs`.
#[test]
fn moving_off_after_a_standstill_keeps_the_rotation() {
    let rig = canned::pinhole_rig();
    let slow_down = [0.5, 0.3, 0.15, 0.08, 0.04, 0.025, 0.015];
    let move_off = [
        0.012, 0.015, 0.02, 0.03, 0.05, 0.08, 0.12, 0.16, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7,
        0.8, 0.9, 1.0,
    ];
    let mut worst = (0.0_f64, 0, 0);
    for seed in 1..=6 {
        let mut rng = Rng(100 + seed);
        let mut vo = warmed_up(&rig, &drive(0.002, 1.0), 3, &mut rng);
        let stops = std::iter::repeat_n(0.0, 6);
        let arcs = slow_down.iter().copied().chain(stops).chain(move_off);
        let mut standstills = 0;
        for (k, l) in arcs.enumerate() {
            // A gentle left curve, the yaw proportional to the distance (curvature 0.02 / m).
            let truth = drive(0.02 * l, l);
            let obs = frame(&rig, &truth, 200, 0.5, &mut rng);
            let r = vo.process(&obs, Some(l));
            assert_finite_orthonormal(&r.motion);
            standstills += usize::from(r.diagnostics.status == FrameStatus::Standstill);
            let err = rot_err_deg(&r.motion, &truth);
            if err > worst.0 {
                worst = (err, seed, k);
            }
        }
        assert_eq!(standstills, 6);
    }
    eprintln!(
        "stop and go: worst rotation error {:.4} deg (seed {}, frame {})",
        worst.0, worst.1, worst.2
    );
    assert!(worst.0 < 0.3, "rotation error {:.3} deg", worst.0);
}

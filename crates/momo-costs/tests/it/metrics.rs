//! Residual metrics: zero at the true motion, non-zero elsewhere, AD Jacobians equal finite
//! differences, degenerate geometry stays finite, serde of the configuration trait objects.

use momo_core::check::check_residual_jacobian;
use momo_core::num_dual::DualSVec64;
use momo_core::{
    Camera, FrameObservations, Manifold, MetricSpec, Observation, Pose, ResidualMetric, Rig,
    Scalar, camera_motion, so3_exp,
};
use momo_costs::{AnglePlane, GeoLine, Sampson, SampsonPrepared};
use momo_testing::{FocalScaled, canned};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;

/// A full 6-dof test manifold (SE(3) exponential of a twist), independent of momo-models.
#[derive(Clone, Debug)]
struct Twist;

impl Manifold for Twist {
    const PARAMS: &'static [&'static str] = &["rho_x", "rho_y", "rho_z", "w_x", "w_y", "w_z"];
    const ARC_LENGTH: Option<usize> = None;
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        Pose::exp(
            &Vector3::new(p[0], p[1], p[2]),
            &Vector3::new(p[3], p[4], p[5]),
        )
    }
}

/// All residuals of all matches of a metric at a vehicle motion.
fn residuals<R: ResidualMetric>(
    metric: &R,
    rig: &Rig,
    obs: &FrameObservations,
    m: &Pose<f64>,
) -> Vec<f64> {
    let mut all = Vec::new();
    for (cam, matches) in rig.cameras().iter().zip(&obs.per_camera) {
        let prep = metric.prepare(&cam.model, &camera_motion(m, &cam.t_vehicle_camera));
        for o in matches {
            let mut r = [0.0; 3];
            metric.residuals(&prep, o, &mut r[..R::RESIDUALS]);
            all.extend_from_slice(&r[..R::RESIDUALS]);
        }
    }
    all
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |a, x| a.max(x.abs()))
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

fn twist() -> impl Strategy<Value = [f64; 6]> {
    (
        0.1..3.0f64,
        -0.3..0.3f64,
        -0.2..0.2f64,
        -0.05..0.05f64,
        -0.3..0.3f64,
        -0.05..0.05f64,
    )
        .prop_map(|(x, y, z, wx, wz, wy)| [x, y, z, wx, wy, wz])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Noise-free matches have residuals below 1e-9 at the true motion, on both rigs, and a
    /// wrong motion gives clearly non-zero ones: the rotation off by 0.01 rad, or 0.3 m added to
    /// the translation, both chosen to be visible in the rig's first camera (the rotation about
    /// its baseline `t`, which tilts every epipolar plane: `f1ᵀ E f0 = (R f1)·(t × f0)`; the
    /// translation perpendicular to that baseline). A fixed perturbation is not always a wrong
    /// motion for an epipolar metric: CI drew a yawing motion whose camera baseline (lever arm
    /// included) was parallel to a fixed 0.3 m lateral offset, which then changed only the
    /// scale (Sampson 0.076 px rms).
    #[test]
    fn zero_at_truth_nonzero_elsewhere(p in twist()) {
        let truth = Twist.motion(&p);
        let pin = canned::pinhole_rig();
        let fish = canned::fisheye_rig();
        let obs_pin = canned::synthetic_observations(&pin, &truth, 30, 0, 11);
        let obs_fish = canned::synthetic_observations(&fish, &truth, 30, 0, 12);
        prop_assert_eq!(obs_pin.len(), 30);
        prop_assert_eq!(obs_fish.len(), 120);
        let wrong = |rig: &Rig| -> [Pose<f64>; 2] {
            let mount = &rig.cameras()[0].t_vehicle_camera;
            let base = camera_motion(&truth, mount).translation.normalize();
            // The vehicle-frame directions of the first camera's baseline and a perpendicular.
            let along = mount.rotation * base;
            let least = base.iamin();
            let across = mount.rotation * base.cross(&Vector3::ith(least, 1.0)).normalize();
            [
                Pose::new(so3_exp(&(along * 0.01)) * truth.rotation, truth.translation),
                Pose::new(truth.rotation, truth.translation + across * 0.3),
            ]
        };

        macro_rules! check {
            ($metric:expr, $rig:expr, $obs:expr, $zero:expr, $clear:expr) => {{
                let r0 = residuals(&$metric, $rig, $obs, &truth);
                prop_assert!(max_abs(&r0) < $zero, "{:?} at truth: {}", $metric, max_abs(&r0));
                for wrong in &wrong($rig) {
                    let r1 = residuals(&$metric, $rig, $obs, wrong);
                    prop_assert!(rms(&r1) > $clear, "{:?} at a wrong motion: rms {}", $metric, rms(&r1));
                }
            }};
        }
        // AnglePlane is dimensionless (~ radians); GeoLine and Sampson in pixels.
        check!(AnglePlane, &pin, &obs_pin, 1e-12, 1e-4);
        check!(GeoLine, &pin, &obs_pin, 1e-9, 0.1);
        check!(Sampson, &pin, &obs_pin, 1e-9, 0.1);
        check!(AnglePlane, &fish, &obs_fish, 1e-12, 1e-4);
        check!(Sampson, &fish, &obs_fish, 1e-9, 0.05);
    }

    /// The AD Jacobian of every metric (through the 6-dof twist) equals central finite
    /// differences within 1e-6, with matches at the true motion and off-epipolar ones. Pixel
    /// metrics are compared in focal-length units (`FocalScaled`): in pixels the rounding noise
    /// of the differences alone can reach 1e-6.
    #[test]
    fn jacobians_match_finite_differences(p in twist()) {
        let truth = Twist.motion(&p);
        let pin = canned::pinhole_rig();
        let fish = canned::fisheye_rig();
        let obs_pin = canned::synthetic_observations(&pin, &truth, 10, 5, 21);
        let obs_fish = canned::synthetic_observations(&fish, &truth, 10, 5, 22);
        // At the truth and slightly beside it (small enough to keep the epipoles away from the
        // matches: near an epipole finite differences, not AD, fail).
        let mut q = p;
        q[1] += 0.02 * p[0];
        q[5] += 0.005;
        for x in [p, q] {
            for (what, r) in [
                ("angle_plane pinhole", check_residual_jacobian(&Twist, &AnglePlane, &pin, &obs_pin, &x, 1e-6)),
                ("geo_line pinhole", check_residual_jacobian(&Twist, &FocalScaled(GeoLine), &pin, &obs_pin, &x, 1e-6)),
                ("sampson pinhole", check_residual_jacobian(&Twist, &FocalScaled(Sampson), &pin, &obs_pin, &x, 1e-6)),
                ("angle_plane fisheye", check_residual_jacobian(&Twist, &AnglePlane, &fish, &obs_fish, &x, 1e-6)),
                ("sampson fisheye", check_residual_jacobian(&Twist, &FocalScaled(Sampson), &fish, &obs_fish, &x, 1e-6)),
            ] {
                prop_assert!(r.is_ok(), "{what} at {x:?}: {r:?}");
            }
        }
    }
}

/// A fisheye match close to its epipole (short motion, CI's failing draw of `macro_angle_plane_ml`):
/// the residual's third derivative there reaches ~1e7, so plain central differences at step 1e-6
/// were 3.5e-6 off the (correct) automatic derivative; the check's Richardson extrapolation is
/// not. Both finite differences converge to the AD value as the step shrinks.
#[test]
fn jacobians_near_the_epipole() {
    let curve = [
        -0.04329378614454502,
        0.3595615852078858,
        -0.015008052570453324,
        0.0,
    ];
    let seed = 2563496245068492606;
    let worst =
        momo_testing::check_metric_at(&momo_costs::AnglePlaneMl, curve, seed, 1e-6).unwrap();
    assert!(worst < 1e-7, "{worst}");
}

/// Exactly zero rotation and exactly zero translation components: derivatives stay exact.
#[test]
fn jacobians_at_identity_rotation() {
    let pin = canned::pinhole_rig();
    let p = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let obs = canned::synthetic_observations(&pin, &Twist.motion(&p), 10, 5, 3);
    check_residual_jacobian(&Twist, &AnglePlane, &pin, &obs, &p, 1e-6).unwrap();
    check_residual_jacobian(&Twist, &FocalScaled(GeoLine), &pin, &obs, &p, 1e-6).unwrap();
    check_residual_jacobian(&Twist, &FocalScaled(Sampson), &pin, &obs, &p, 1e-6).unwrap();
    // In pixels, at a well-conditioned point, too.
    check_residual_jacobian(&Twist, &GeoLine, &pin, &obs, &p, 1e-6).unwrap();
}

/// Off-epipolar matches: GeoLine's two residuals and Sampson are pixel distances of the same
/// order as the pixel shift, and the tangent-plane Sampson (used for fisheye cameras) agrees
/// with the pixel one near the principal point.
#[test]
fn pixel_metrics_measure_pixels() {
    let pin = canned::pinhole_rig();
    let cam = &pin.cameras()[0];
    let truth = Twist.motion(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.02]);
    let c = camera_motion(&truth, &cam.t_vehicle_camera);
    let Camera::Pinhole(k) = cam.model else {
        unreachable!()
    };
    let mut ratios = Vec::new();
    for (dx, dy) in [(15.0, 10.0), (-12.0, 8.0), (20.0, -15.0), (-10.0, -10.0)] {
        let x0 = Vector3::new(
            (k.cx + dx - k.cx) / k.fx * 10.0,
            (k.cy + dy - k.cy) / k.fy * 10.0,
            10.0,
        );
        let x1 = c.inverse().transform_point(&x0);
        let px0 = momo_core::CameraModel::project(&cam.model, &x0).unwrap();
        let px1 =
            momo_core::CameraModel::project(&cam.model, &x1).unwrap() + Vector2::new(0.0, 3.0);
        let o = Observation::new(&cam.model, px0, px1).unwrap();
        let mut g = [0.0; 2];
        GeoLine.residuals(&GeoLine.prepare(&cam.model, &c), &o, &mut g);
        let mut s = [0.0];
        Sampson.residuals(&Sampson.prepare(&cam.model, &c), &o, &mut s);
        // Sampson on bearings, scaled by the focal length.
        let mut sb = [0.0];
        let e = momo_core::essential(&c);
        Sampson.residuals(
            &SampsonPrepared::Bearings(e, cam.model.focal_length()),
            &o,
            &mut sb,
        );
        assert!(g[0].abs() > 0.3 && g[0].abs() < 3.01, "{g:?}");
        // The symmetric distance in frame k-1 is of the same size (similar views).
        assert!((g[1] / g[0] - 1.0).abs() < 0.2, "{g:?}");
        assert!(s[0].abs() > 0.2 && s[0].abs() < 3.01, "{s:?}");
        // Sampson is about the reprojection error: |s| ≈ |g| / sqrt(2) for equal line slopes.
        assert!(
            (s[0].abs() - (g[0] * g[0] + g[1] * g[1]).sqrt() / 2.0).abs() < 0.3 * s[0].abs(),
            "{s:?} {g:?}"
        );
        ratios.push(sb[0] / s[0]);
    }
    for r in ratios {
        assert!(
            (r - 1.0).abs() < 0.05,
            "bearing Sampson / pixel Sampson = {r}"
        );
    }
}

/// At a standstill (t = 0) and for a match along the baseline the guards keep values and dual
/// derivatives finite.
#[test]
fn degenerate_geometry_is_finite() {
    type D = DualSVec64<6>;
    let cams = [canned::pinhole_rig(), canned::fisheye_rig()];
    let seed = |v: [f64; 6]| -> [D; 6] { std::array::from_fn(|i| D::from_re(v[i]).derivative(i)) };
    for (name, params) in [
        ("standstill", [0.0; 6]),
        ("forward", [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
    ] {
        let p = seed(params);
        let m = Twist.motion(&p);
        for rig in &cams {
            for cam in rig.cameras() {
                let c = camera_motion(&m, &cam.t_vehicle_camera);
                // f0 along the camera's baseline direction (the epipole), f1 the same.
                let b = camera_motion(&Twist.motion(&params), &cam.t_vehicle_camera).translation;
                let dir = b.try_normalize(0.0).unwrap_or(Vector3::z());
                let o = Observation {
                    px0: Vector2::new(600.0, 180.0),
                    px1: Vector2::new(600.0, 180.0),
                    f0: dir,
                    f1: dir,
                };
                let mut out = [D::from_re(0.0); 3];
                let finite = |v: &[D]| {
                    v.iter().all(|x| {
                        x.re.is_finite() && x.eps.0.is_none_or(|e| e.iter().all(|d| d.is_finite()))
                    })
                };
                AnglePlane.residuals(&AnglePlane.prepare(&cam.model, &c), &o, &mut out[..1]);
                assert!(finite(&out[..1]), "{name}: angle_plane {:?}", out[0]);
                Sampson.residuals(&Sampson.prepare(&cam.model, &c), &o, &mut out[..1]);
                assert!(finite(&out[..1]), "{name}: sampson {:?}", out[0]);
                if cam.model.as_pinhole().is_some() {
                    GeoLine.residuals(&GeoLine.prepare(&cam.model, &c), &o, &mut out[..2]);
                    assert!(finite(&out[..2]), "{name}: geo_line {:?}", &out[..2]);
                }
            }
        }
    }
}

#[test]
fn geo_line_rejects_fisheye() {
    let fish = canned::fisheye_rig();
    let cam = &fish.cameras()[0].model;
    let reason = GeoLine.supports(cam).unwrap_err();
    assert!(reason.contains("pinhole"), "{reason}");
    assert!(AnglePlane.supports(cam).is_ok());
    assert!(Sampson.supports(cam).is_ok());
    // Through the problem: a typed error naming the metric and the camera.
    let m = Twist.motion(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let obs = canned::synthetic_observations(&fish, &m, 5, 0, 1);
    let e = check_residual_jacobian(
        &Twist,
        &GeoLine,
        &fish,
        &obs,
        &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        1e-6,
    )
    .unwrap_err();
    assert!(
        e.what.contains("GeoLine") && e.what.contains("camera 0"),
        "{}",
        e.what
    );
}

#[test]
fn metrics_round_trip_as_trait_objects() {
    let all: Vec<Box<dyn MetricSpec>> =
        vec![Box::new(AnglePlane), Box::new(GeoLine), Box::new(Sampson)];
    let names = ["angle_plane", "geo_line", "sampson"];
    for (m, name) in all.iter().zip(names) {
        let j = serde_json::to_string(m).unwrap();
        assert_eq!(j, format!(r#"{{"type":"{name}"}}"#));
        let back: Box<dyn MetricSpec> = serde_json::from_str(&j).unwrap();
        assert_eq!(format!("{back:?}"), format!("{m:?}"));
        let t = toml::to_string(m).unwrap();
        assert_eq!(t.trim(), format!("type = \"{name}\""));
        let back: Box<dyn MetricSpec> = toml::from_str(&t).unwrap();
        assert_eq!(format!("{back:?}"), format!("{m:?}"));
    }
    // Every metric pairs with any model it has never heard of: here one defined in this test.
    for m in &all {
        let e = m.estimator(Box::new(Straight));
        assert_eq!(e.param_names(), &["arc_length"]);
        assert_eq!(e.motion(&[2.0]).translation.x, 2.0);
    }
}

/// A model this crate does not know: straight ahead by the arc length.
#[derive(Clone, Debug)]
struct Straight;

impl momo_core::Manifold for Straight {
    const PARAMS: &'static [&'static str] = &["arc_length"];
    const ARC_LENGTH: Option<usize> = Some(0);
    fn motion<T: momo_core::Scalar>(&self, p: &[T]) -> momo_core::Pose<T> {
        momo_core::Pose::new(
            nalgebra::Matrix3::identity(),
            nalgebra::Vector3::new(p[0], T::zero(), T::zero()),
        )
    }
}

// Every built-in metric through the public one-line property-test macro (momo-testing).
momo_testing::test_metric!(macro_angle_plane, AnglePlane);
momo_testing::test_metric!(macro_angle_plane_ml, momo_costs::AnglePlaneMl);
momo_testing::test_metric!(
    macro_angle_plane_ml_rig,
    momo_costs::AnglePlaneMlRig {
        reference_focal: 400.0
    }
);
momo_testing::test_metric!(macro_geo_line, FocalScaled(GeoLine), tol = 1e-5);
momo_testing::test_metric!(macro_sampson, FocalScaled(Sampson), tol = 1e-5);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// `AnglePlaneMl`'s per-match constants (`ResidualMetric::MATCH_CONSTANTS`: the bearing
    /// covariances, cached once per problem) give the residuals of `residuals`, which recomputes
    /// them, bit for bit on `f64` and on dual numbers (value and derivatives), on both canned
    /// rigs, at random motions with outliers.
    #[test]
    fn angle_plane_ml_cached_constants_are_exact(
        p in twist(),
        seed in 0u64..1000,
        fisheye in any::<bool>(),
    ) {
        use momo_costs::AnglePlaneMl;
        let rig = if fisheye { canned::fisheye_rig() } else { canned::pinhole_rig() };
        let m = Twist.motion(&p);
        let obs = canned::synthetic_observations(&rig, &m, 20, 5, seed);
        let metric = AnglePlaneMl;
        let n_c = AnglePlaneMl::MATCH_CONSTANTS;
        prop_assert!(n_c > 0);
        let mut constants = vec![0.0; n_c];
        // A dual motion: the derivatives of the twist's six parameters.
        let pd: Vec<DualSVec64<6>> =
            (0..6).map(|i| DualSVec64::from_re(p[i]).derivative(i)).collect();
        let md = Twist.motion(&pd);
        for (cam, matches) in rig.cameras().iter().zip(&obs.per_camera) {
            let prep = metric.prepare(&cam.model, &camera_motion(&m, &cam.t_vehicle_camera));
            let prep_d = metric.prepare(&cam.model, &camera_motion(&md, &cam.t_vehicle_camera));
            for o in matches {
                metric.match_constants(&cam.model, o, &mut constants);
                let (mut a, mut b) = ([0.0], [0.0]);
                metric.residuals(&prep, o, &mut a);
                metric.residuals_with(&prep, o, &constants, &mut b);
                prop_assert_eq!(a[0].to_bits(), b[0].to_bits());
                let (mut ad, mut bd) =
                    ([DualSVec64::<6>::from_re(0.0)], [DualSVec64::<6>::from_re(0.0)]);
                metric.residuals(&prep_d, o, &mut ad);
                metric.residuals_with(&prep_d, o, &constants, &mut bd);
                prop_assert_eq!(ad[0].re.to_bits(), bd[0].re.to_bits());
                let bits = |d: &DualSVec64<6>| -> Vec<u64> {
                    d.eps.0.map_or(Vec::new(), |e| e.iter().map(|v| v.to_bits()).collect())
                };
                prop_assert_eq!(bits(&ad[0]), bits(&bd[0]));
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// `bearing_covariance` from the camera models' closed-form projection Jacobians against
    /// the central differences it used before (`bearing_covariance_by_differences`), on random
    /// pixels of every camera model: the same covariance to 1e-6 of its size (the differences'
    /// own rounding error is about 1e-10 relative).
    #[test]
    fn bearing_covariance_closed_form_matches_central_differences(
        u in 0.0..1.0f64,
        v in 0.0..1.0f64,
    ) {
        use momo_core::{CameraModel, DoubleSphere, Radtan, Unified};
        use momo_costs::{bearing_covariance, bearing_covariance_by_differences};
        let cams = [
            Camera::Pinhole(canned::kitti_pinhole()),
            Camera::KannalaBrandt(canned::fisheye()),
            Camera::Radtan(Radtan { fx: 460.0, fy: 458.0, cx: 367.2, cy: 248.4, k1: -0.283, k2: 0.074, p1: 1.9e-4, p2: 1.8e-5, k3: -0.0052, width: 752.0, height: 480.0 }),
            Camera::DoubleSphere(DoubleSphere { fx: 350.0, fy: 352.0, cx: 640.0, cy: 400.0, xi: -0.2, alpha: 0.59, width: 1280.0, height: 800.0 }),
            Camera::Unified(Unified { fx: 500.0, fy: 498.0, cx: 640.0, cy: 400.0, xi: 0.8, width: 1280.0, height: 800.0 }),
        ];
        for cam in cams {
            let (w, h) = cam.size();
            let px = Vector2::new(u * w - 0.5, v * h - 0.5);
            let Some(f) = cam.unproject(&px) else { continue };
            let closed = bearing_covariance(&cam, &f);
            let diff = bearing_covariance_by_differences(&cam, &f);
            let size = diff.amax();
            prop_assert!(size > 0.0 && size.is_finite());
            prop_assert!((closed - diff).amax() <= 1e-6 * size, "{cam:?} at {px}: {closed} vs {diff}");
        }
    }
}

/// `AnglePlaneMlRig` (issue 14, twenty-seventh session): on two cameras of different focal
/// lengths, its residual over the rig's `s_ref` is the residual over its pixel-noise standard
/// deviation on both (the maximum-likelihood weighting across the rig), where `AnglePlaneMl`'s
/// per-camera `s_ref` leaves the two at the same size in radians (weights off by the squared
/// focal-length ratio, 4 here).
#[test]
fn angle_plane_ml_rig_weighs_each_camera_by_its_pixel_noise() {
    use momo_core::Pinhole;
    use momo_costs::{AnglePlaneMl, AnglePlaneMlRig};
    let pinhole = |f: f64| {
        Camera::Pinhole(Pinhole {
            fx: f,
            fy: f,
            cx: 320.0,
            cy: 240.0,
            width: 640.0,
            height: 480.0,
        })
    };
    let (short, long) = (pinhole(300.0), pinhole(600.0));
    let c = Pose::new(nalgebra::Matrix3::identity(), Vector3::new(0.1, 0.0, 1.0));
    // The same match (bearings 1 mrad off the epipolar plane, near the optical axis) on both.
    let f0 = Vector3::new(0.01, 0.0, 1.0).normalize();
    let f1 = Vector3::new(0.011, 0.001, 1.0).normalize();
    let obs = Observation {
        px0: Vector2::new(323.0, 240.0),
        px1: Vector2::new(323.3, 240.3),
        f0,
        f1,
    };
    let res = |m: &dyn Fn(&Camera, &mut [f64]), cam: &Camera| {
        let mut out = [0.0];
        m(cam, &mut out);
        out[0]
    };
    let own = |cam: &Camera, out: &mut [f64]| {
        AnglePlaneMl.residuals(&AnglePlaneMl.prepare(cam, &c), &obs, out)
    };
    let rig = AnglePlaneMlRig {
        reference_focal: 450.0,
    };
    let shared = |cam: &Camera, out: &mut [f64]| rig.residuals(&rig.prepare(cam, &c), &obs, out);
    // Pixel-noise units: the residual over its own camera's s_ref = √2 / f.
    let s = |f: f64| std::f64::consts::SQRT_2 / f;
    let (own_short, own_long) = (res(&own, &short), res(&own, &long));
    let (px_short, px_long) = (own_short / s(300.0), own_long / s(600.0));
    // The same residual in pixel units on the long lens is about twice the short lens's.
    assert!(
        (px_long / px_short - 2.0).abs() < 0.02,
        "{px_short} {px_long}"
    );
    // AnglePlaneMl: about equal in radians, so the long lens is under-weighted by about 4.
    assert!(
        (own_long / own_short - 1.0).abs() < 0.01,
        "{own_short} {own_long}"
    );
    // AnglePlaneMlRig: the pixel-unit residuals times one s_ref, on both cameras (to the
    // variance floor's 1e-6 · s_ref², which differs between the two references).
    let (rig_short, rig_long) = (res(&shared, &short), res(&shared, &long));
    assert!(
        (rig_short / (px_short * s(450.0)) - 1.0).abs() < 1e-5,
        "{rig_short}"
    );
    assert!(
        (rig_long / (px_long * s(450.0)) - 1.0).abs() < 1e-5,
        "{rig_long}"
    );
}

/// `AnglePlaneMlRig::for_rig`: the mean focal length of the rig's cameras, so on a rig whose
/// cameras share one focal length (and on one camera) its residuals are `AnglePlaneMl`'s, bit
/// for bit; on a rig of two focal lengths their mean.
#[test]
fn angle_plane_ml_rig_is_angle_plane_ml_on_a_rig_of_one_focal_length() {
    use momo_core::{Pinhole, RigCamera};
    use momo_costs::{AnglePlaneMl, AnglePlaneMlRig};
    let rig = canned::fisheye_rig();
    let metric = AnglePlaneMlRig::for_rig(&rig).expect("a rig with cameras");
    assert_eq!(
        metric.reference_focal,
        rig.cameras()[0].model.focal_length()
    );
    let m = Pose::new(
        so3_exp(&Vector3::new(0.01, -0.02, 0.03)),
        Vector3::new(0.1, 0.02, 1.0),
    );
    let obs = canned::synthetic_observations(&rig, &m, 20, 5, 7);
    for (cam, matches) in rig.cameras().iter().zip(&obs.per_camera) {
        let cm = camera_motion(&m, &cam.t_vehicle_camera);
        let (a, b) = (
            AnglePlaneMl.prepare(&cam.model, &cm),
            metric.prepare(&cam.model, &cm),
        );
        for o in matches {
            let (mut ra, mut rb) = ([0.0], [0.0]);
            AnglePlaneMl.residuals(&a, o, &mut ra);
            metric.residuals(&b, o, &mut rb);
            assert_eq!(ra[0].to_bits(), rb[0].to_bits());
        }
    }
    let pinhole = |f: f64| {
        Camera::Pinhole(Pinhole {
            fx: f,
            fy: f,
            cx: 320.0,
            cy: 240.0,
            width: 640.0,
            height: 480.0,
        })
    };
    let cam = |name: &str, f: f64| RigCamera {
        name: name.into(),
        model: pinhole(f),
        t_vehicle_camera: Pose::identity(),
    };
    let mixed = Rig::new(vec![cam("a", 300.0), cam("b", 600.0)]).expect("a valid rig");
    assert_eq!(
        AnglePlaneMlRig::for_rig(&mixed).map(|m| m.reference_focal),
        Some(450.0)
    );
}

/// The stiff direction behind the `ill_conditioned` frames (docs/RESULTS.md, thirty-second
/// session, stiff46): `AnglePlane`'s `r = f1ᵀ E f0 / ‖E f0‖` is the sine of the angle between
/// `f1` and the plane through the baseline `t` and `f0`; as the epipole approaches `f0` that
/// plane's orientation is set by the direction of approach alone, so `∂r/∂t` grows as
/// `1 / (|t| sin∠(t, f0))` and `r` of *any* `f1` can be made 0 there. The configuration is
/// the reproduction's (simulated moving traffic, seed 2, frame 43): a gross outlier (its frame-k
/// pixel 605 px away) whose `f0` the first stage's epipole converged onto, 8e-8 rad away, where
/// its residual is 2e-6 instead of 0.6 and its derivative 1e7 (the normal matrix's eigenvalue
/// 3.9e14 against the data's 0.01-2.5). `AnglePlaneMl` divides by the residual's standard
/// deviation, which holds `f0`'s noise (`∇₀r`, of the same order `1 / sin∠(t, f0)`): its
/// derivative stays bounded at the epipole.
#[test]
fn angle_plane_is_singular_at_the_epipole_angle_plane_ml_is_not() {
    use momo_core::CameraModel;
    use momo_costs::AnglePlaneMl;
    type D = DualSVec64<3>;
    let cam = Camera::Pinhole(canned::kitti_pinhole());
    let (px0, px1) = (
        Vector2::new(623.8198231998132, 161.91677777937818),
        Vector2::new(18.549946271238767, 129.53410132372636),
    );
    let o = Observation {
        px0,
        px1,
        f0: cam.unproject(&px0).unwrap(),
        f1: cam.unproject(&px1).unwrap(),
    };
    // Directions at f0: along the great circle through f0 and f1 (on it the epipolar plane
    // holds f1: r = 0) and across it.
    let along = (o.f1 - o.f0 * o.f1.dot(&o.f0)).normalize();
    let across = o.f0.cross(&along);
    // The epipole `angle` rad from f0 towards `dir`, |t| = 0.47 m; the residual and the norm
    // of its derivative with respect to `t`.
    let at = |metric: &dyn Fn(&Pose<D>, &mut [D]), dir: Vector3<f64>, angle: f64| -> (f64, f64) {
        let t = so3_exp(&(o.f0.cross(&dir) * angle)) * o.f0 * 0.47;
        let td = Vector3::new(
            D::from_re(t.x).derivative(0),
            D::from_re(t.y).derivative(1),
            D::from_re(t.z).derivative(2),
        );
        let c = Pose::new(nalgebra::Matrix3::identity().map(D::from_re), td);
        let mut out = [D::from_re(0.0)];
        metric(&c, &mut out);
        let g = out[0].eps.0.map_or(0.0, |e| e.norm());
        (out[0].re, g)
    };
    let plain = |c: &Pose<D>, out: &mut [D]| {
        AnglePlane.residuals(&AnglePlane.prepare(&cam, c), &o, out);
    };
    let ml = |c: &Pose<D>, out: &mut [D]| {
        AnglePlaneMl.residuals(&AnglePlaneMl.prepare(&cam, c), &o, out);
    };
    // The fan: 8e-8 rad from f0 the outlier's residual is 0 or ~0.6 by the direction alone.
    let (r_on, g_near) = at(&plain, along, 8e-8);
    let (r_off, _) = at(&plain, across, 8e-8);
    assert!(r_on.abs() < 1e-6, "angle_plane on the circle: {r_on}");
    assert!(r_off.abs() > 0.1, "angle_plane across: {r_off}");
    // The derivative grows as 1 / angle: 1e-2 / 8e-8 = 1.25e5 times.
    let (_, g_far) = at(&plain, along, 1e-2);
    assert!(g_near > 1e6 && g_near > 1e4 * g_far, "{g_near} vs {g_far}");
    // AnglePlaneMl: bounded there (within a factor 10 of its value 1e-2 away).
    let (_, m_far) = at(&ml, along, 1e-2);
    let (_, m_near) = at(&ml, along, 8e-8);
    assert!(
        m_near.is_finite() && m_near < 10.0 * m_far,
        "{m_near} vs {m_far}"
    );
}

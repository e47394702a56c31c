//! `momo_io::calib_import` on the committed sample files (hand-written from the public OpenCV
//! FileStorage, ROS camera_info and Kalibr camchain formats) and `path:line: reason` errors.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{Camera, CameraModel, Pose};
use momo_io::calib_import::*;
use momo_io::{IoErrorKind, read_rig};
use nalgebra::{Matrix4, Vector2, Vector3};
use std::path::{Path, PathBuf};

fn sample(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/calib")
        .join(name)
}

fn text(name: &str) -> String {
    std::fs::read_to_string(sample(name)).unwrap()
}

/// The error of importing `text` (named `cal.yaml`): line and message.
fn err(text: &str) -> (Option<usize>, String) {
    let e = import_calibration_from_str(text, "cal.yaml", &Pose::identity()).unwrap_err();
    assert!(
        matches!(
            e.kind,
            IoErrorKind::Calibration(_) | IoErrorKind::InvalidCamera { .. }
        ),
        "{e}"
    );
    (e.line, e.to_string())
}

#[test]
fn opencv_filestorage() {
    let (rig, format) = import_calibration(sample("opencv.yaml"), &Pose::identity()).unwrap();
    assert_eq!(format, CalibrationFormat::OpenCv);
    assert_eq!(rig.len(), 1);
    let Camera::Radtan(c) = rig.cameras()[0].model else {
        panic!("radtan expected: {:?}", rig.cameras()[0].model);
    };
    assert_eq!((c.fx, c.fy, c.cx, c.cy), (458.65, 457.29, 367.21, 248.37));
    assert_eq!(
        (c.k1, c.k2, c.p1, c.p2, c.k3),
        (-0.2834, 0.073959, 1.9359e-4, 1.7619e-5, 0.0)
    );
    assert_eq!((c.width, c.height), (752.0, 480.0));
}

#[test]
fn ros_camera_info_and_message_form() {
    let (rig, format) =
        import_calibration(sample("ros_camera_info.yaml"), &Pose::identity()).unwrap();
    assert_eq!(format, CalibrationFormat::RosCameraInfo);
    let Camera::Radtan(c) = rig.cameras()[0].model else {
        panic!("radtan expected");
    };
    assert_eq!((c.fx, c.fy, c.cx, c.cy), (523.5, 524.1, 319.4, 240.7));
    assert_eq!(c.k3, -0.011);
    // `rostopic echo` of a CameraInfo message, equidistant distortion.
    let msg = "height: 480\nwidth: 640\ndistortion_model: equidistant\n\
               D: [0.02, -0.005, 0.001, -0.0001]\n\
               K: [330.0, 0.0, 320.0, 0.0, 331.0, 240.0, 0.0, 0.0, 1.0]\n";
    let (rig, _) = import_calibration_from_str(msg, "info.yaml", &Pose::identity()).unwrap();
    assert!(
        matches!(rig.cameras()[0].model, Camera::KannalaBrandt(k) if k.k4 == -0.0001 && k.fy == 331.0)
    );
    // Zero distortion gives a pinhole.
    let zero = text("ros_camera_info.yaml").replace(
        "[-0.121, 0.084, 0.0012, -0.0007, -0.011]",
        "[0, 0, 0, 0, 0]",
    );
    let (rig, _) = import_calibration_from_str(&zero, "z.yaml", &Pose::identity()).unwrap();
    assert!(matches!(rig.cameras()[0].model, Camera::Pinhole(_)));
}

#[test]
fn kalibr_camchain_and_mount() {
    let mount = parse_mount("1.0,0,1.65").unwrap();
    let (rig, format) = import_calibration(sample("kalibr_camchain.yaml"), &mount).unwrap();
    assert_eq!(format, CalibrationFormat::Kalibr);
    assert_eq!(rig.len(), 3);
    let names: Vec<&str> = rig.cameras().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam0", "cam1", "cam2"]);
    assert!(
        matches!(rig.cameras()[0].model, Camera::Radtan(r) if r.k3 == 0.0 && r.p2 == 1.76187114e-05)
    );
    assert!(
        matches!(rig.cameras()[1].model, Camera::DoubleSphere(d) if d.xi == -0.18 && d.alpha == 0.59 && d.fx == 313.2)
    );
    assert!(matches!(rig.cameras()[2].model, Camera::Unified(u) if u.xi == 0.9 && u.cx == 639.5));
    // Camera 0 is at the mount: forward-looking (camera z = vehicle x), 1 m ahead, 1.65 m up.
    let p0 = rig.cameras()[0].t_vehicle_camera;
    assert_eq!(p0.translation, Vector3::new(1.0, 0.0, 1.65));
    assert!((p0.rotation.column(2) - Vector3::x()).norm() < 1e-15);
    // The chain: a point in camera n-1 maps into camera n by T_cn_cnm1, so
    // T_vehicle_cam(n)⁻¹ T_vehicle_cam(n-1) = T_cn_cnm1.
    let t21 = Matrix4::new(
        0.0, 0.0, 1.0, 0.2, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, -0.1, 0.0, 0.0, 0.0, 1.0,
    );
    let (p1, p2) = (
        rig.cameras()[1].t_vehicle_camera,
        rig.cameras()[2].t_vehicle_camera,
    );
    let rel = p2.inverse().compose(&p1).to_homogeneous();
    assert!((rel - t21).amax() < 1e-12, "{rel}");
    // cam1 sits 0.11 m to the right of cam0 (Kalibr's stereo baseline, t = -0.11 along x of
    // cam1): in the vehicle frame about 0.11 m to the right (-y).
    let d = p1.translation - p0.translation;
    assert!((d - Vector3::new(0.0, -0.11, 0.0)).norm() < 2e-3, "{d}");
    // Imported cameras work: a pixel of each round-trips.
    for c in rig.cameras() {
        let px = Vector2::new(300.0, 200.0);
        let b = c.model.unproject(&px).unwrap();
        assert!(
            (c.model.project(&b).unwrap() - px).norm() < 1e-6,
            "{}",
            c.name
        );
    }
}

#[test]
fn writes_rig_json_atomically_and_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig.json");
    let mount = parse_mount("1,0,1.65,0,5").unwrap();
    let (rig, _) = import_to_rig_json(sample("kalibr_camchain.yaml"), &out, &mount).unwrap();
    assert_eq!(read_rig(&out).unwrap(), rig);
    // A failed import leaves no file behind.
    let bad = dir.path().join("bad.yaml");
    std::fs::write(
        &bad,
        "cam0:\n  camera_model: kb4\n  intrinsics: [1, 1, 0, 0]\n  resolution: [10, 10]\n",
    )
    .unwrap();
    let out2 = dir.path().join("rig2.json");
    assert!(import_to_rig_json(&bad, &out2, &mount).is_err());
    assert!(!out2.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

#[test]
fn mount_option() {
    let p = parse_mount("0,0,0").unwrap();
    // Level and forward: camera z = vehicle x, camera x = vehicle -y, camera y = vehicle -z.
    assert_eq!(
        p.rotation,
        nalgebra::Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0)
    );
    let left = parse_mount("1, 0.9, 1, 90, 25").unwrap();
    let z = left.rotation.column(2);
    assert!(z.y > 0.9 && z.z < -0.4, "{z}");
    let full = parse_mount("0,0,1,1, -1,0,0,0, 0,-1,0,1.65, 0,0,0,1").unwrap();
    assert_eq!(full.translation, Vector3::new(1.0, 0.0, 1.65));
    assert!(parse_mount("1,2").unwrap_err().contains("expected x,y,z"));
    assert!(parse_mount("1,2,x").unwrap_err().contains("`x`"));
    assert!(
        parse_mount("1,0,0,0, 0,1,0,0, 0,0,2,0, 0,0,0,1")
            .unwrap_err()
            .contains("orthonormal")
    );
}

#[test]
fn errors_name_file_and_line() {
    let opencv = text("opencv.yaml");
    // 8 values for a 3x3 matrix: the line of `data`.
    let (line, msg) = err(&opencv.replace("0., 1. ]", "1. ]"));
    assert_eq!(line, Some(11), "{msg}");
    assert!(
        msg.starts_with("cal.yaml:11: `camera_matrix.data` has 8 values"),
        "{msg}"
    );
    // A number that is not one.
    let (line, msg) = err(&opencv.replace("7.3959e-02", "seven"));
    assert_eq!(line, Some(17), "{msg}");
    assert!(msg.contains("cannot parse `seven` as a number"), "{msg}");
    // Skew.
    let (line, msg) =
        err(&opencv.replace("4.5865e+02, 0., 3.6721e+02", "4.5865e+02, 0.5, 3.6721e+02"));
    assert_eq!(line, Some(11), "{msg}");
    assert!(msg.contains("no skew"), "{msg}");
    // Missing key.
    let (line, msg) = err(&opencv.replace("image_height: 480\n", ""));
    assert!(msg.contains("missing key `image_height`"), "{msg}");
    assert!(line.is_some());
    // Not YAML at all.
    let (line, msg) = err("camera_matrix: [1, 2\nimage_width: 3\n");
    assert!(msg.contains("not valid YAML"), "{msg}");
    assert!(line.is_some());
    // Not a calibration.
    let (line, msg) = err("foo: 1\nbar: 2\n");
    assert_eq!(line, Some(1));
    assert!(msg.contains("unknown calibration format"), "{msg}");

    let ros = text("ros_camera_info.yaml");
    let (line, msg) = err(&ros.replace("plumb_bob", "kannala_brandt_8"));
    assert_eq!(line, Some(8), "{msg}");
    assert!(
        msg.contains("distortion model `kannala_brandt_8` is not supported"),
        "{msg}"
    );
    let (line, msg) = err(&ros
        .replace("cols: 5", "cols: 6")
        .replace("-0.011]", "-0.011, 0.3]"));
    assert_eq!(line, Some(12), "{msg}");
    assert!(msg.contains("6 distortion coefficients"), "{msg}");
    let (line, msg) = err(&ros.replace("image_width: 640", "image_width: 640.5"));
    assert_eq!(line, Some(1), "{msg}");

    let kalibr = text("kalibr_camchain.yaml");
    // A double sphere ξ outside (-1, 1): the line of `intrinsics`, the reason of rig.json.
    let (line, msg) = err(&kalibr.replace("[-0.18, 0.59,", "[-1.5, 0.59,"));
    assert_eq!(line, Some(19), "{msg}");
    assert!(msg.contains("`xi` must lie in (-1, 1)"), "{msg}");
    let (line, msg) = err(&kalibr.replace(
        "[0.9, 560.0, 561.0, 639.5, 479.5]",
        "[560.0, 561.0, 639.5, 479.5]",
    ));
    assert_eq!(line, Some(32), "{msg}");
    assert!(msg.contains("needs 5 intrinsics"), "{msg}");
    let (line, msg) = err(&kalibr.replace(
        "distortion_coeffs: [0.0, 0.0, 0.0, 0.0]",
        "distortion_coeffs: [0.1, 0.0, 0.0, 0.0]",
    ));
    assert_eq!(line, Some(30), "{msg}");
    assert!(
        msg.contains("omni with radtan distortion is not supported"),
        "{msg}"
    );
    let (line, msg) = err(&kalibr.replace("  - [0.0, 0.0, 1.0, 0.2]", "  - [0.0, 0.0, 1.1, 0.2]"));
    assert_eq!(line, Some(24), "{msg}");
    assert!(
        msg.contains("cam2.T_cn_cnm1`: the rotation is not orthonormal"),
        "{msg}"
    );
    let (line, msg) = err(&kalibr.replace("camera_model: omni", "camera_model: fov"));
    assert_eq!(line, Some(29), "{msg}");
    assert!(msg.contains("camera_model `fov` is not supported"), "{msg}");
    let (_, msg) = err(&kalibr.replace("  T_cn_cnm1:\n  - [0.0, 0.0, 1.0, 0.2]\n  - [0.0, 1.0, 0.0, 0.0]\n  - [-1.0, 0.0, 0.0, -0.1]\n  - [0.0, 0.0, 0.0, 1.0]\n", ""));
    assert!(msg.contains("`cam2`: missing key `T_cn_cnm1`"), "{msg}");
    // EUCM with β = 1 is the unified model; other β are refused.
    let eucm = "cam0:\n  camera_model: eucm\n  intrinsics: [0.5, 1.0, 300, 300, 320, 240]\n  resolution: [640, 480]\n";
    let (rig, _) = import_calibration_from_str(eucm, "e.yaml", &Pose::identity()).unwrap();
    assert!(matches!(rig.cameras()[0].model, Camera::Unified(u) if u.xi == 1.0 && u.fx == 600.0));
    let (line, msg) = err(&eucm.replace("0.5, 1.0,", "0.5, 1.2,"));
    assert_eq!(line, Some(3), "{msg}");
    assert!(msg.contains("beta = 1"), "{msg}");
}

/// The EUCM-to-unified conversion projects exactly as EUCM with β = 1 does.
#[test]
fn eucm_with_beta_one_is_unified() {
    let (alpha, f, c) = (0.62, 280.0, 320.0);
    let eucm = format!(
        "cam0:\n  camera_model: eucm\n  intrinsics: [{alpha}, 1.0, {f}, {f}, {c}, {c}]\n  resolution: [640, 640]\n"
    );
    let (rig, _) = import_calibration_from_str(&eucm, "e.yaml", &Pose::identity()).unwrap();
    let cam = rig.cameras()[0].model;
    for p in [
        Vector3::new(0.3, -0.2, 1.0),
        Vector3::new(1.0, 0.5, 0.1),
        Vector3::new(-2.0, 0.1, -0.3),
    ] {
        let d = p.norm();
        let den = alpha * d + (1.0 - alpha) * p.z;
        let expect = Vector2::new(f * p.x / den + c, f * p.y / den + c);
        let got = cam.project(&p).unwrap();
        assert!((got - expect).norm() < 1e-9, "{got} vs {expect}");
    }
}

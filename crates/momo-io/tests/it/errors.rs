//! Every input error of FORMAT.md: typed kind, file, line, and `path:line: reason`.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{Camera, CameraModel, FrameObservations, Pose, Rig};
use momo_io::*;
use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};

/// An input, a check of the error kind, the expected line.
type Case<T, L> = (T, fn(&IoErrorKind) -> bool, L);

const FORMAT_MD_RIG: &str = r#"{
  "cameras": [
    {
      "name": "cam0",
      "model": { "type": "pinhole",
                 "fx": 718.856, "fy": 718.856, "cx": 607.1928, "cy": 185.2157,
                 "width": 1241, "height": 376 },
      "T_vehicle_camera": [[0, 0, 1, 1.0],
                           [-1, 0, 0, 0.0],
                           [0, -1, 0, 1.65],
                           [0, 0, 0, 1]]
    }
  ]
}"#;

const FORMAT_MD_MATCHES: &str = "frame,camera,u0,v0,u1,v1\n1,0,612.31,201.77,615.02,203.40\n";

fn rig_err(text: &str) -> IoError {
    read_rig_from_str(text, "seq/rig.json").expect_err("must be rejected")
}

fn kitti_rig() -> Rig {
    read_rig_from_str(FORMAT_MD_RIG, "rig.json").unwrap()
}

fn fisheye_rig(k1: f64) -> Rig {
    let cam = Camera::KannalaBrandt(momo_core::KannalaBrandt {
        fx: 330.0,
        fy: 330.0,
        cx: 640.0,
        cy: 480.0,
        k1,
        k2: 0.0,
        k3: 0.0,
        k4: 0.0,
        width: 1280.0,
        height: 960.0,
    });
    Rig::mono(cam, Pose::identity()).unwrap()
}

fn matches_err_with(rig: &Rig, text: &str) -> IoError {
    let reader = match MatchReader::new(text.as_bytes(), rig, "seq/matches.csv") {
        Ok(r) => r,
        Err(e) => return e,
    };
    for item in reader {
        if let Err(e) = item {
            return e;
        }
    }
    panic!("accepted: {text}");
}

fn matches_err(text: &str) -> IoError {
    matches_err_with(&kitti_rig(), text)
}

fn read_matches(rig: &Rig, text: &str) -> Vec<(usize, FrameObservations)> {
    MatchReader::new(text.as_bytes(), rig, "m.csv")
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap()
}

fn odo_err(text: &str) -> IoError {
    read_odometry_from(text.as_bytes(), "seq/odometry.csv").expect_err("must be rejected")
}

fn poses_err(text: &str) -> IoError {
    read_poses_from(text.as_bytes(), "seq/poses.txt").expect_err("must be rejected")
}

// ---------------------------------------------------------------------------------- rig.json

#[test]
fn format_md_rig_example_parses() {
    let rig = kitti_rig();
    assert_eq!(rig.len(), 1);
    let c = &rig.cameras()[0];
    assert_eq!(c.name, "cam0");
    let Camera::Pinhole(p) = c.model else {
        panic!("pinhole")
    };
    assert_eq!(
        (p.fx, p.cx, p.width, p.height),
        (718.856, 607.1928, 1241.0, 376.0)
    );
    let r = Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
    assert_eq!(
        c.t_vehicle_camera,
        Pose::new(r, Vector3::new(1.0, 0.0, 1.65))
    );
}

#[test]
fn format_md_matches_example_parses() {
    let frames = read_matches(&kitti_rig(), FORMAT_MD_MATCHES);
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].0, 1);
    let o = frames[0].1.per_camera[0][0];
    assert_eq!(
        (o.px0.x, o.px0.y, o.px1.x, o.px1.y),
        (612.31, 201.77, 615.02, 203.40)
    );
    assert!((o.f0.norm() - 1.0).abs() < 1e-15);
}

#[test]
fn malformed_json_has_line_and_column() {
    let text = FORMAT_MD_RIG.replace("\"cam0\",", "\"cam0\",,");
    let e = rig_err(&text);
    assert_eq!(e.line, Some(4));
    assert!(
        matches!(e.kind, IoErrorKind::Json { column: 22, .. }),
        "{e}"
    );
    assert!(e.to_string().starts_with("seq/rig.json:4: "), "{e}");
    let e = rig_err("{\"cameras\": [");
    assert!(matches!(e.kind, IoErrorKind::Json { .. }), "{e}");
    let e = rig_err("");
    assert!(matches!(e.kind, IoErrorKind::Json { .. }), "{e}");
}

#[test]
fn missing_or_empty_cameras() {
    let e = rig_err("{\n  \"rigs\": []\n}");
    assert!(
        matches!(&e.kind, IoErrorKind::Json { message, .. } if message.contains("unknown field `rigs`")),
        "{e}"
    );
    let e = rig_err("{\n}");
    assert!(
        matches!(&e.kind, IoErrorKind::Json { message, .. } if message.contains("missing field `cameras`")),
        "{e}"
    );
    let e = rig_err("{\n  \"cameras\":\n    []\n}");
    assert!(matches!(e.kind, IoErrorKind::EmptyRig), "{e}");
    assert_eq!(e.line, Some(3));
    assert_eq!(
        e.to_string(),
        "seq/rig.json:3: `cameras` is an empty list; a rig needs at least one camera"
    );
}

#[test]
fn unknown_model_type() {
    let e = rig_err(&FORMAT_MD_RIG.replace("\"pinhole\"", "\"fisheye624\""));
    assert!(
        matches!(&e.kind, IoErrorKind::Json { message, .. } if message.contains("unknown variant `fisheye624`")),
        "{e}"
    );
    assert_eq!(e.line, Some(5));
    let e = rig_err(&FORMAT_MD_RIG.replace("\"type\": \"pinhole\",", ""));
    assert!(
        matches!(&e.kind, IoErrorKind::Json { message, .. } if message.contains("`type`")),
        "{e}"
    );
}

#[test]
fn missing_and_extra_fields() {
    let e = rig_err(&FORMAT_MD_RIG.replace("\"fx\": 718.856, ", ""));
    assert!(
        matches!(&e.kind, IoErrorKind::Json { message, .. } if message.contains("missing field `fx`")),
        "{e}"
    );
    let e = rig_err(&FORMAT_MD_RIG.replace("\"fx\": 718.856, ", "\"fx\": 718.856, \"k1\": 0.1, "));
    assert!(
        matches!(&e.kind, IoErrorKind::Json { message, .. } if message.contains("unknown field `k1`")),
        "{e}"
    );
    assert!(e.line.is_some_and(|l| (5..=7).contains(&l)), "{e}");
    let e = rig_err(
        &FORMAT_MD_RIG.replace("\"name\": \"cam0\",", "\"name\": \"cam0\", \"serial\": 7,"),
    );
    assert!(
        matches!(&e.kind, IoErrorKind::Json { message, .. } if message.contains("unknown field `serial`")),
        "{e}"
    );
    assert_eq!(e.line, Some(4));
    let e = rig_err(&FORMAT_MD_RIG.replace("\"T_vehicle_camera\"", "\"T_camera_vehicle\""));
    assert!(matches!(&e.kind, IoErrorKind::Json { .. }), "{e}");
    let e = rig_err(&FORMAT_MD_RIG.replace("\"width\": 1241", "\"width\": \"1241\""));
    assert!(matches!(&e.kind, IoErrorKind::Json { .. }), "{e}");
    // `name` is optional: cameras are then called cam<i>.
    let rig = read_rig_from_str(&FORMAT_MD_RIG.replace("\"name\": \"cam0\",", ""), "r").unwrap();
    assert_eq!(rig.cameras()[0].name, "cam0");
}

#[test]
fn non_orthonormal_extrinsic() {
    let e = rig_err(&FORMAT_MD_RIG.replace("[0, 0, 1, 1.0]", "[0, 0, 1.001, 1.0]"));
    assert!(
        matches!(
            e.kind,
            IoErrorKind::ExtrinsicNotOrthonormal { camera: 0, .. }
        ),
        "{e}"
    );
    assert_eq!(e.line, Some(8));
    assert!(
        e.to_string().starts_with(
            "seq/rig.json:8: camera 0: the rotation of T_vehicle_camera is not orthonormal"
        ),
        "{e}"
    );
    // A reflection (det -1) is rejected too.
    let e = rig_err(&FORMAT_MD_RIG.replace("[0, 0, 1, 1.0]", "[0, 0, -1, 1.0]"));
    assert!(
        matches!(e.kind, IoErrorKind::ExtrinsicNotOrthonormal { .. }),
        "{e}"
    );
    // Within 1e-6 is accepted.
    read_rig_from_str(
        &FORMAT_MD_RIG.replace("[0, 0, 1, 1.0]", "[0, 0, 1.0000002, 1.0]"),
        "r",
    )
    .unwrap();
}

#[test]
fn wrong_extrinsic_shape() {
    let three_rows = FORMAT_MD_RIG.replace(",\n                           [0, 0, 0, 1]]", "]");
    let e = rig_err(&three_rows);
    assert!(
        matches!(&e.kind, IoErrorKind::BadExtrinsic { reason, .. } if reason == "found 3 rows"),
        "{e}"
    );
    assert_eq!(e.line, Some(8));
    let e = rig_err(&FORMAT_MD_RIG.replace("[0, -1, 0, 1.65]", "[0, -1, 0]"));
    assert!(
        matches!(&e.kind, IoErrorKind::BadExtrinsic { reason, .. } if reason.contains("row 2 has 3")),
        "{e}"
    );
    let e = rig_err(&FORMAT_MD_RIG.replace("[0, 0, 0, 1]]", "[0, 0, 1, 1]]"));
    assert!(
        matches!(&e.kind, IoErrorKind::BadExtrinsic { reason, .. } if reason.contains("bottom row")),
        "{e}"
    );
    let e = rig_err(&FORMAT_MD_RIG.replace("[0, 0, 0, 1]]", "[0, 0, 0, 2]]"));
    assert!(matches!(e.kind, IoErrorKind::BadExtrinsic { .. }), "{e}");
}

#[test]
fn non_positive_intrinsics() {
    // The line of the offending field.
    for (from, to, line) in [
        ("\"fx\": 718.856", "\"fx\": 0", 6),
        ("\"fy\": 718.856", "\"fy\": -718.856", 6),
        ("\"width\": 1241", "\"width\": 0", 7),
        ("\"height\": 376", "\"height\": -1", 7),
    ] {
        let e = rig_err(&FORMAT_MD_RIG.replace(from, to));
        assert!(
            matches!(e.kind, IoErrorKind::InvalidCamera { camera: 0, .. }),
            "{e}"
        );
        assert_eq!(e.line, Some(line), "{e}");
        assert!(e.to_string().contains("must be a positive number"), "{e}");
    }
}

#[test]
fn missing_files() {
    let dir = tempfile::tempdir().unwrap();
    let e = read_sequence(dir.path()).unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::NotFound));
    assert_eq!(e.path, dir.path().join("rig.json"));
    assert_eq!(
        e.to_string(),
        format!("{}: file not found", dir.path().join("rig.json").display())
    );

    std::fs::write(dir.path().join("rig.json"), FORMAT_MD_RIG).unwrap();
    let e = read_sequence(dir.path()).unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::NotFound));
    assert_eq!(e.path, dir.path().join("matches.csv"));

    // odometry.csv and poses.txt are optional.
    std::fs::write(dir.path().join("matches.csv"), FORMAT_MD_MATCHES).unwrap();
    let s = read_sequence(dir.path()).unwrap();
    assert_eq!(s.num_frames(), 2);
    assert!(s.arc_lengths.is_none() && s.ground_truth.is_none());

    assert!(matches!(
        read_rig(dir.path().join("nope.json")).unwrap_err().kind,
        IoErrorKind::NotFound
    ));
    assert!(matches!(
        read_poses(dir.path().join("nope.txt")).unwrap_err().kind,
        IoErrorKind::NotFound
    ));
    assert!(matches!(
        read_odometry(dir.path().join("nope.csv")).unwrap_err().kind,
        IoErrorKind::NotFound
    ));
    let e = read_sequence(dir.path().join("no_such_dir")).unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::NotFound));
}

#[test]
fn rig_file_invalid_utf8_and_too_large() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("rig.json");
    std::fs::write(&p, b"{\n\"cameras\": [\"\xff\"]}").unwrap();
    let e = read_rig(&p).unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::InvalidUtf8));
    assert_eq!(e.line, Some(2));
    let f = std::fs::File::create(&p).unwrap();
    f.set_len(MAX_RIG_BYTES as u64 + 10).unwrap();
    let e = read_rig(&p).unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::TooLong { .. }), "{e}");
}

// ------------------------------------------------------------------------------- matches.csv

#[test]
fn matches_header_rules() {
    let e = matches_err("");
    assert!(matches!(e.kind, IoErrorKind::MissingHeader { .. }));
    assert_eq!(
        e.to_string(),
        "seq/matches.csv: missing header line `frame,camera,u0,v0,u1,v1`"
    );
    let e = matches_err("1,0,612.31,201.77,615.02,203.40\n");
    assert!(matches!(e.kind, IoErrorKind::MissingHeader { .. }));
    assert_eq!(e.line, Some(1));
    let e = matches_err("frame,camera,u0,v0,u1\n");
    assert!(
        matches!(&e.kind, IoErrorKind::BadHeader { reason, .. } if reason.contains("`v1`")),
        "{e}"
    );
    let e = matches_err("frame,camera,u0,v0,u1,v1,score\n");
    assert!(
        matches!(&e.kind, IoErrorKind::BadHeader { reason, .. } if reason.contains("`score`")),
        "{e}"
    );
    // Any order, surrounding whitespace ignored, CRLF accepted.
    let frames = read_matches(
        &kitti_rig(),
        " u1 ,v1, frame,camera ,u0,v0\r\n615.02,203.40,1,0,612.31,201.77\r\n",
    );
    let o = frames[0].1.per_camera[0][0];
    assert_eq!(
        (o.px0.x, o.px0.y, o.px1.x, o.px1.y),
        (612.31, 201.77, 615.02, 203.40)
    );
}

#[test]
fn matches_row_errors() {
    let h = "frame,camera,u0,v0,u1,v1\n";
    let cases: Vec<Case<String, usize>> = vec![
        (
            format!("{h}1,0,1,2,3\n"),
            |k| {
                matches!(
                    k,
                    IoErrorKind::FieldCount {
                        expected: 6,
                        found: 5
                    }
                )
            },
            2,
        ),
        (
            format!("{h}1,0,1,2,3,4,5\n"),
            |k| matches!(k, IoErrorKind::FieldCount { found: 7, .. }),
            2,
        ),
        (
            format!("{h}1,0,1,2,3,4\n1,0,1,x2,3,4\n"),
            |k| matches!(k, IoErrorKind::BadNumber { .. }),
            3,
        ),
        (
            format!("{h}1.5,0,1,2,3,4\n"),
            |k| matches!(k, IoErrorKind::BadNumber { .. }),
            2,
        ),
        (
            format!("{h}1,-1,1,2,3,4\n"),
            |k| matches!(k, IoErrorKind::BadNumber { .. }),
            2,
        ),
        (
            format!("{h}1,0,nan,2,3,4\n"),
            |k| matches!(k, IoErrorKind::NonFinite { .. }),
            2,
        ),
        (
            format!("{h}1,0,1,2,inf,4\n"),
            |k| matches!(k, IoErrorKind::NonFinite { .. }),
            2,
        ),
        (
            format!("{h}1,0,1,2,3,-infinity\n"),
            |k| matches!(k, IoErrorKind::NonFinite { .. }),
            2,
        ),
        (
            format!("{h}0,0,1,2,3,4\n"),
            |k| matches!(k, IoErrorKind::FrameZero),
            2,
        ),
        (
            format!("{h}1,1,1,2,3,4\n"),
            |k| {
                matches!(
                    k,
                    IoErrorKind::UnknownCamera {
                        camera: 1,
                        count: 1
                    }
                )
            },
            2,
        ),
        (
            format!("{h}2,0,1,2,3,4\n\n1,0,1,2,3,4\n"),
            |k| {
                matches!(
                    k,
                    IoErrorKind::FramesOutOfOrder {
                        frame: 1,
                        previous: 2,
                        ..
                    }
                )
            },
            4,
        ),
        (
            format!("{h}1,0,-200,2,3,4\n"),
            |k| matches!(k, IoErrorKind::PixelOutsideImage { .. }),
            2,
        ),
        (
            format!("{h}1,0,1,2,3,600\n"),
            |k| matches!(k, IoErrorKind::PixelOutsideImage { .. }),
            2,
        ),
        (
            format!("{h}99999999999,0,1,2,3,4\n"),
            |k| matches!(k, IoErrorKind::FrameTooLarge { .. }),
            2,
        ),
    ];
    for (text, check, line) in cases {
        let e = matches_err(&text);
        assert!(check(&e.kind), "{text:?}: {e}");
        assert_eq!(e.line, Some(line), "{text:?}: {e}");
        assert!(
            e.to_string()
                .starts_with(&format!("seq/matches.csv:{line}: ")),
            "{e}"
        );
    }
    let e = matches_err(&format!("{h}1,0,nan,2,3,4\n"));
    assert_eq!(e.to_string(), "seq/matches.csv:2: `u0` is not finite (NaN)");
    let e = matches_err(&format!("{h}1,3,1,2,3,4\n"));
    assert_eq!(
        e.to_string(),
        "seq/matches.csv:2: unknown camera id 3 (the rig has 1 camera(s))"
    );
}

#[test]
fn pixels_slightly_outside_are_accepted() {
    let margin = PIXEL_MARGIN_FRACTION * 1241.0;
    let text = format!(
        "frame,camera,u0,v0,u1,v1\n1,0,{},-100,1300,400\n",
        -margin + 1.0
    );
    let f = read_matches(&kitti_rig(), &text);
    assert_eq!(f[0].1.len(), 1);
    let text = format!(
        "frame,camera,u0,v0,u1,v1\n1,0,{},-100,1300,400\n",
        -margin - 1.0
    );
    assert!(matches!(
        matches_err(&text).kind,
        IoErrorKind::PixelOutsideImage { .. }
    ));
}

#[test]
fn pixel_the_model_cannot_unproject() {
    // d(θ) = θ - 0.5 θ³ peaks at d ≈ 0.544: radii beyond 0.544 fx have no preimage.
    let rig = fisheye_rig(-0.5);
    let cam = rig.cameras()[0].model;
    assert!(
        cam.unproject(&nalgebra::Vector2::new(640.0 + 0.6 * 330.0, 480.0))
            .is_none()
    );
    let e = matches_err_with(&rig, "frame,camera,u0,v0,u1,v1\n1,0,640,480,838,480\n");
    assert!(
        matches!(e.kind, IoErrorKind::Unprojectable { field: "u1,v1", .. }),
        "{e}"
    );
    assert_eq!(e.line, Some(2));
}

#[test]
fn long_lines_and_invalid_utf8() {
    let mut text = String::from("frame,camera,u0,v0,u1,v1\n1,0,1,2,3,4");
    text.push_str(&"0".repeat(MAX_LINE_BYTES + 10));
    text.push('\n');
    let e = matches_err(&text);
    assert!(
        matches!(
            e.kind,
            IoErrorKind::TooLong {
                limit: MAX_LINE_BYTES
            }
        ),
        "{e}"
    );
    assert_eq!(e.line, Some(2));
    let bytes = b"frame,camera,u0,v0,u1,v1\n1,0,1,2,3,4\n1,0,\xc3\x28,2,3,4\n";
    let r = MatchReader::new(&bytes[..], &kitti_rig(), "m.csv").unwrap();
    let e = r.collect::<Result<Vec<_>, _>>().unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::InvalidUtf8));
    assert_eq!(e.to_string(), "m.csv:3: invalid UTF-8");
    // The same for the other line readers.
    let e = odo_err("frame,arc_length\n1,\u{0}\n");
    assert!(matches!(e.kind, IoErrorKind::BadNumber { .. }));
    let e = read_poses_from(&b"\xff\n"[..], "p.txt").unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::InvalidUtf8));
    let long = "1 ".repeat(MAX_LINE_BYTES);
    assert!(matches!(poses_err(&long).kind, IoErrorKind::TooLong { .. }));
}

#[test]
fn stream_yields_contiguous_frames_including_empty_ones() {
    let text = "frame,camera,u0,v0,u1,v1\n2,0,1,2,3,4\n2,0,5,6,7,8\n\n5,0,1,1,1,1\n";
    let frames = read_matches(&kitti_rig(), text);
    let ks: Vec<usize> = frames.iter().map(|(k, _)| *k).collect();
    assert_eq!(ks, vec![1, 2, 3, 4, 5]);
    let counts: Vec<usize> = frames.iter().map(|(_, f)| f.len()).collect();
    assert_eq!(counts, vec![0, 2, 0, 0, 1]);
    assert!(frames.iter().all(|(_, f)| f.per_camera.len() == 1));
    // Header only: no frames.
    assert!(read_matches(&kitti_rig(), "frame,camera,u0,v0,u1,v1\n").is_empty());
    // Frame 1 is complete once a row of frame 2 arrives; the reader stops after an error.
    let text = "frame,camera,u0,v0,u1,v1\n1,0,1,2,3,4\n2,0,1,2,3,4\n2,0,x,2,3,4\n";
    let mut r = MatchReader::new(text.as_bytes(), &kitti_rig(), "m").unwrap();
    assert!(r.next().unwrap().is_ok());
    assert!(r.next().unwrap().is_err());
    assert!(r.next().is_none());
}

// ------------------------------------------------------------------------------ odometry.csv

#[test]
fn odometry_rules() {
    let ok = read_odometry_from("arc_length, frame\n0.5,1\n\n0.7,3\n".as_bytes(), "o").unwrap();
    assert_eq!(ok, vec![None, Some(0.5), None, Some(0.7)]);
    assert_eq!(
        read_odometry_from("frame,arc_length\n".as_bytes(), "o").unwrap(),
        vec![None]
    );
    let cases: Vec<Case<&str, Option<usize>>> = vec![
        ("", |k| matches!(k, IoErrorKind::MissingHeader { .. }), None),
        (
            "1,0.5\n",
            |k| matches!(k, IoErrorKind::MissingHeader { .. }),
            Some(1),
        ),
        (
            "frame,length\n",
            |k| matches!(k, IoErrorKind::BadHeader { .. }),
            Some(1),
        ),
        (
            "frame,arc_length\n1,nan\n",
            |k| matches!(k, IoErrorKind::NonFinite { .. }),
            Some(2),
        ),
        (
            "frame,arc_length\n1,inf\n",
            |k| matches!(k, IoErrorKind::NonFinite { .. }),
            Some(2),
        ),
        (
            "frame,arc_length\n1,-1000.5\n",
            |k| matches!(k, IoErrorKind::ArcLengthTooLarge { .. }),
            Some(2),
        ),
        (
            "frame,arc_length\n0,0.1\n",
            |k| matches!(k, IoErrorKind::FrameZero),
            Some(2),
        ),
        (
            "frame,arc_length\n2,0.1\n1,0.1\n",
            |k| matches!(k, IoErrorKind::FramesOutOfOrder { .. }),
            Some(3),
        ),
        (
            "frame,arc_length\n2,0.1\n2,0.1\n",
            |k| matches!(k, IoErrorKind::DuplicateFrame { frame: 2 }),
            Some(3),
        ),
        (
            "frame,arc_length\n1,0.1,3\n",
            |k| matches!(k, IoErrorKind::FieldCount { .. }),
            Some(2),
        ),
        (
            "frame,arc_length\n1,abc\n",
            |k| matches!(k, IoErrorKind::BadNumber { .. }),
            Some(2),
        ),
    ];
    for (text, check, line) in cases {
        let e = odo_err(text);
        assert!(check(&e.kind), "{text:?}: {e}");
        assert_eq!(e.line, line, "{text:?}: {e}");
    }
    assert_eq!(
        odo_err("frame,arc_length\n2,0.1\n2,0.1\n").to_string(),
        "seq/odometry.csv:3: duplicate frame 2"
    );
}

#[test]
fn num_frames_counts_odometry_too() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("rig.json"), FORMAT_MD_RIG).unwrap();
    std::fs::write(dir.path().join("matches.csv"), FORMAT_MD_MATCHES).unwrap();
    std::fs::write(dir.path().join("odometry.csv"), "frame,arc_length\n4,1.0\n").unwrap();
    let s = read_sequence(dir.path()).unwrap();
    assert_eq!(s.num_frames(), 5);
    assert_eq!(s.frames.len(), 5);
    assert_eq!(s.arc_lengths.as_ref().unwrap().len(), 5);
    assert!(
        s.frames[2..]
            .iter()
            .all(|f| f.is_empty() && f.per_camera.len() == 1)
    );
    // No rows anywhere: one frame.
    std::fs::write(dir.path().join("matches.csv"), "frame,camera,u0,v0,u1,v1\n").unwrap();
    std::fs::remove_file(dir.path().join("odometry.csv")).unwrap();
    let s = read_sequence(dir.path()).unwrap();
    assert_eq!(s.num_frames(), 1);
    assert_eq!(s.frames.len(), 1);
}

// --------------------------------------------------------------------------------- poses.txt

#[test]
fn poses_rules() {
    let id = "1 0 0 0 0 1 0 0 0 0 1 0";
    let ok = read_poses_from(
        format!("{id}\n1\t0 0 5 0 1 0 0 0 0 1 0\n\n\n").as_bytes(),
        "p",
    )
    .unwrap();
    assert_eq!(ok.len(), 2);
    assert_eq!(ok[1].translation, Vector3::new(5.0, 0.0, 0.0));
    let cases: Vec<Case<String, usize>> = vec![
        (
            format!("{id}\n1 0 0 0 0 1 0 0 0 0 1\n"),
            |k| {
                matches!(
                    k,
                    IoErrorKind::FieldCount {
                        expected: 12,
                        found: 11
                    }
                )
            },
            2,
        ),
        (
            format!("{id} 1\n"),
            |k| matches!(k, IoErrorKind::FieldCount { found: 13, .. }),
            1,
        ),
        (
            "1 0 0 0 0 1 0 0 0 0 1 nan\n".into(),
            |k| matches!(k, IoErrorKind::NonFinite { .. }),
            1,
        ),
        (
            "1 0 0 0 0 1 0 0 0 0 1 x\n".into(),
            |k| matches!(k, IoErrorKind::BadNumber { .. }),
            1,
        ),
        (
            "1 0 0 0 0 1 0 0 0 0 1.00001 0\n".into(),
            |k| matches!(k, IoErrorKind::PoseNotOrthonormal { .. }),
            1,
        ),
        (
            "1 0 0 0 0 1 0 0 0 0 -1 0\n".into(),
            |k| matches!(k, IoErrorKind::PoseNotOrthonormal { .. }),
            1,
        ),
        (
            format!("{id}\n\n{id}\n"),
            |k| matches!(k, IoErrorKind::BlankLine),
            2,
        ),
    ];
    for (text, check, line) in cases {
        let e = poses_err(&text);
        assert!(check(&e.kind), "{text:?}: {e}");
        assert_eq!(e.line, Some(line), "{text:?}: {e}");
    }
    assert_eq!(
        poses_err("1 0 0 0 0 1 0 0 0 0 1 inf").to_string(),
        "seq/poses.txt:1: `number 12` is not finite (inf)"
    );
}

fn data_files() -> Vec<PathBuf> {
    let root = Path::new("/work/shared/data");
    let mut v: Vec<PathBuf> = (0..=10)
        .map(|i| root.join(format!("kitti_odometry_gt/poses/{i:02}.txt")))
        .collect();
    v.push(root.join("kitti00_example_estimates_evo/KITTI_00_ORB.txt"));
    v.push(root.join("kitti00_example_estimates_evo/KITTI_00_SPTAM.txt"));
    v.into_iter().filter(|p| p.exists()).collect()
}

#[test]
fn kitti_ground_truth_files_pass() {
    for p in data_files() {
        let poses = read_poses(&p).unwrap_or_else(|e| panic!("{e}"));
        assert!(poses.len() > 100, "{}", p.display());
        assert!((poses[0].translation).norm() < 1e-6);
    }
}

/// Rows next to the one-pass reading of plain numbers (`fast_fields`, issue 19, twentieth
/// session) fail as they did before it (the messages of main b340264's `momo run` on the same
/// rows): the one pass leaves each of them to the split and the field parsers, which name the
/// line and the reason.
#[test]
fn malformed_rows_near_the_one_pass_fail_as_before() {
    let h = "frame,camera,u0,v0,u1,v1\n";
    let cases: [(&[u8], &str); 16] = [
        (b"1,0,1e999,2,3,4", "2: `u0` is not finite (inf)"),
        (b"1,0,-inf,2,3,4", "2: `u0` is not finite (-inf)"),
        (b"1,0,1.5,2,3", "2: expected 6 fields, found 5"),
        (b"1,0,1,2,3,4,5", "2: expected 6 fields, found 7"),
        (b"1,0,,2,3,4", "2: `u0`: cannot parse `` as a number"),
        (
            b"1,0,1.5e,2,3,4",
            "2: `u0`: cannot parse `1.5e` as a number",
        ),
        (
            b"1,0,0x1p3,2,3,4",
            "2: `u0`: cannot parse `0x1p3` as a number",
        ),
        (b"1,0,1,2,3,4 x", "2: `v1`: cannot parse `4 x` as a number"),
        (b"1,0,1\xff,2,3,4", "2: invalid UTF-8"),
        (b"1 ,0,1,2,3,4\n\xc3\x28", "3: invalid UTF-8"),
        (
            b"1,x,1,2,3,4",
            "2: `camera`: cannot parse `x` as a non-negative integer",
        ),
        (
            b"1.5,0,1,2,3,4",
            "2: `frame`: cannot parse `1.5` as a non-negative integer",
        ),
        (
            b"-1,0,1,2,3,4",
            "2: `frame`: cannot parse `-1` as a non-negative integer",
        ),
        (b"0,0,1,2,3,4", "2: frame must be >= 1, found 0"),
        (
            b"1,2,1,2,3,4",
            "2: unknown camera id 2 (the rig has 1 camera(s))",
        ),
        (
            b"1,0,1,2,3,4\n2,0, 1,2,3,4\n1,0,1,2,3,4",
            "4: frame 1 after frame 2: rows must be ordered by non-decreasing frame",
        ),
    ];
    for (row, expected) in cases {
        let mut text = h.as_bytes().to_vec();
        text.extend_from_slice(row);
        text.push(b'\n');
        let e = MatchReader::new(&text[..], &kitti_rig(), "seq/matches.csv")
            .unwrap()
            .collect::<Result<Vec<_>, _>>()
            .expect_err("must be rejected");
        assert_eq!(
            e.to_string(),
            format!("seq/matches.csv:{expected}"),
            "{}",
            String::from_utf8_lossy(row)
        );
    }
    // The same rows read whole through a reader whose buffer holds 7 bytes (every line
    // gathered across refills, not read in place).
    let text = format!("{h}1,0,612.3125,201.75,615.0,203.5\n1,0,1e999,2,3,4\n");
    let small = std::io::BufReader::with_capacity(7, text.as_bytes());
    let e = MatchReader::new(small, &kitti_rig(), "seq/matches.csv")
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .expect_err("must be rejected");
    assert_eq!(e.to_string(), "seq/matches.csv:3: `u0` is not finite (inf)");
}

/// Lines read in place from the reader's buffer and lines gathered across refills (a line
/// longer than the buffer, or cut by its end) give the same frames.
#[test]
fn lines_in_place_and_gathered_read_alike() {
    let mut text = String::from("frame,camera,u0,v0,u1,v1\r\n");
    for k in 1..40 {
        for j in 0..3 {
            let v = 100.0 + f64::from(k * 7 + j) / 3.0;
            text.push_str(&format!(
                "{k},0,{v},{},{},{}\n",
                v + 0.5,
                v - 1.25,
                v * 0.75
            ));
        }
        if k % 5 == 0 {
            text.push_str("\n  \r\n");
        }
    }
    let whole = read_matches(&kitti_rig(), &text);
    for capacity in [7, 64, 100, 1000] {
        let r = std::io::BufReader::with_capacity(capacity, text.as_bytes());
        let frames: Vec<_> = MatchReader::new(r, &kitti_rig(), "m.csv")
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(frames, whole, "capacity {capacity}");
    }
    assert_eq!(whole.len(), 39);
}

//! rig.json with the camera models of format version 2 (radtan, double_sphere, unified):
//! parsing, writing back bit for bit, and `path:line: reason` errors for invalid parameters.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{Camera, DoubleSphere, Pose, Radtan, Rig, RigCamera, Unified};
use momo_io::*;

const RIG_V2: &str = r#"{
  "cameras": [
    {
      "name": "front",
      "model": { "type": "radtan",
                 "fx": 458.654, "fy": 457.296, "cx": 367.215, "cy": 248.375,
                 "k1": -0.28340811, "k2": 0.07395907, "p1": 0.00019359, "p2": 1.76187114e-05,
                 "width": 752, "height": 480 },
      "T_vehicle_camera": [[0, 0, 1, 1.0], [-1, 0, 0, 0.0], [0, -1, 0, 1.65], [0, 0, 0, 1]]
    },
    {
      "name": "left",
      "model": { "type": "double_sphere",
                 "fx": 313.2, "fy": 313.4, "cx": 638.0, "cy": 514.5,
                 "xi": -0.18,
                 "alpha": 0.59,
                 "width": 1280, "height": 1024 },
      "T_vehicle_camera": [[-1, 0, 0, 1.0], [0, 0, 1, 0.9], [0, 1, 0, 1.0], [0, 0, 0, 1]]
    },
    {
      "name": "rear",
      "model": { "type": "unified",
                 "fx": 740.0, "fy": 741.0, "cx": 640.0, "cy": 512.0,
                 "xi": 1.1,
                 "width": 1280, "height": 1024 },
      "T_vehicle_camera": [[0, 0, -1, -1.0], [1, 0, 0, 0.0], [0, -1, 0, 1.0], [0, 0, 0, 1]]
    }
  ]
}"#;

fn rig_err(text: &str) -> IoError {
    read_rig_from_str(text, "seq/rig.json").expect_err("must be rejected")
}

#[test]
fn version_two_models_parse_and_write_back() {
    let rig = read_rig_from_str(RIG_V2, "rig.json").unwrap();
    assert!(matches!(
        rig.cameras()[0].model,
        Camera::Radtan(Radtan { k3: 0.0, .. })
    ));
    assert!(matches!(
        rig.cameras()[1].model,
        Camera::DoubleSphere(DoubleSphere { xi: -0.18, .. })
    ));
    assert!(matches!(
        rig.cameras()[2].model,
        Camera::Unified(Unified { xi: 1.1, .. })
    ));
    let text = rig_to_json(&rig).unwrap();
    assert_eq!(read_rig_from_str(&text, "again.json").unwrap(), rig);
}

#[test]
fn invalid_parameters_point_at_their_line() {
    for (from, to, line, reason) in [
        (
            "\"xi\": -0.18",
            "\"xi\": -1.0",
            15,
            "`xi` must lie in (-1, 1)",
        ),
        (
            "\"xi\": -0.18",
            "\"xi\": 1.5",
            15,
            "`xi` must lie in (-1, 1)",
        ),
        (
            "\"alpha\": 0.59",
            "\"alpha\": 1.2",
            16,
            "`alpha` must lie in [0, 1]",
        ),
        (
            "\"alpha\": 0.59",
            "\"alpha\": -0.1",
            16,
            "`alpha` must lie in [0, 1]",
        ),
        (
            "\"xi\": 1.1",
            "\"xi\": -0.5",
            24,
            "unified `xi` must be >= 0",
        ),
        (
            "\"fx\": 313.2",
            "\"fx\": 0",
            14,
            "`fx` must be a positive number",
        ),
        (
            "\"fy\": 457.296",
            "\"fy\": -1",
            6,
            "`fy` must be a positive number",
        ),
    ] {
        let text = RIG_V2.replace(from, to);
        assert_ne!(text, RIG_V2);
        let e = rig_err(&text);
        assert!(
            matches!(e.kind, IoErrorKind::InvalidCamera { .. }),
            "{from}: {e}"
        );
        assert_eq!(e.line, Some(line), "{from}: {e}");
        assert!(
            e.to_string()
                .starts_with(&format!("seq/rig.json:{line}: camera ")),
            "{e}"
        );
        assert!(e.to_string().contains(reason), "{e}");
    }
    // A missing radtan coefficient or an unknown field: serde's message with the line.
    let e = rig_err(&RIG_V2.replace("\"p2\": 1.76187114e-05,", ""));
    assert!(e.to_string().contains("missing field `p2`"), "{e}");
    let e = rig_err(&RIG_V2.replace("\"xi\": 1.1,", "\"xi\": 1.1, \"beta\": 1,"));
    assert!(e.to_string().contains("unknown field `beta`"), "{e}");
    assert_eq!(e.line, Some(22), "the model (serde buffers tagged enums)");
}

#[test]
fn writer_rejects_what_the_reader_rejects() {
    let cam = Camera::DoubleSphere(DoubleSphere {
        fx: 300.0,
        fy: 300.0,
        cx: 320.0,
        cy: 240.0,
        xi: 1.0,
        alpha: 0.5,
        width: 640.0,
        height: 480.0,
    });
    let rig = Rig::new(vec![RigCamera {
        name: "c".into(),
        model: cam,
        t_vehicle_camera: Pose::identity(),
    }])
    .unwrap();
    let e = rig_to_json(&rig).unwrap_err();
    assert!(e.to_string().contains("`xi` must lie in (-1, 1)"), "{e}");
}

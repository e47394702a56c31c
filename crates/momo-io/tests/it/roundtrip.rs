//! Writers: round trips (bitwise pixels, poses to 1e-12), atomicity, garbage never panics.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{
    Camera, FrameObservations, KannalaBrandt, Observation, Pinhole, Pose, Rig, RigCamera, so3_exp,
};
use momo_io::*;
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use std::path::Path;

fn pinhole() -> Camera {
    Camera::Pinhole(Pinhole {
        fx: 718.856,
        fy: 718.856,
        cx: 607.1928,
        cy: 185.2157,
        width: 1241.0,
        height: 376.0,
    })
}

fn fisheye() -> Camera {
    Camera::KannalaBrandt(KannalaBrandt {
        fx: 330.0,
        fy: 331.5,
        cx: 639.5,
        cy: 479.5,
        k1: 0.02,
        k2: -0.005,
        k3: 0.001,
        k4: -0.0001,
        width: 1280.0,
        height: 960.0,
    })
}

fn two_camera_rig() -> Rig {
    Rig::new(vec![
        RigCamera {
            name: "front \"wide\"".into(),
            model: pinhole(),
            t_vehicle_camera: Pose::new(
                so3_exp(&Vector3::new(0.3, -1.2, 0.7)),
                Vector3::new(1.0, 0.1, 1.65),
            ),
        },
        RigCamera {
            name: "rear".into(),
            model: fisheye(),
            t_vehicle_camera: Pose::new(
                so3_exp(&Vector3::new(-2.0, 0.4, 0.1)),
                Vector3::new(-0.9, 0.0, 1.0),
            ),
        },
    ])
    .unwrap()
}

fn sample_sequence() -> Sequence {
    let rig = two_camera_rig();
    let mut frames = vec![FrameObservations::new(2)];
    for k in 1..6 {
        let mut f = FrameObservations::new(2);
        if k != 3 {
            for (j, c) in rig.cameras().iter().enumerate() {
                for i in 0..7 {
                    let x = 0.1 + 0.1373 * (i + k + j) as f64 % 1.0;
                    let px0 = Vector2::new(x * 1000.0 + 1.0 / 3.0, x * 300.0 + 1e-9);
                    let px1 = Vector2::new(x * 999.0 - 0.1, x * 301.0 + std::f64::consts::PI);
                    f.per_camera[j].push(Observation::new(&c.model, px0, px1).unwrap());
                }
            }
        }
        frames.push(f);
    }
    let gt = (0..6)
        .map(|k| {
            Pose::new(
                so3_exp(&Vector3::new(0.01 * k as f64, 0.3 * k as f64, -0.02)),
                Vector3::new(0.1, -1e-7, 12.345678901234567 * k as f64),
            )
        })
        .collect();
    Sequence {
        rig,
        frames,
        arc_lengths: Some(vec![
            None,
            Some(0.8571),
            Some(1.0 / 3.0),
            None,
            Some(0.0),
            Some(1e-20),
        ]),
        ground_truth: Some(gt),
    }
}

fn assert_same(a: &Sequence, b: &Sequence) {
    assert_eq!(a.rig, b.rig);
    assert_eq!(a.frames.len(), b.frames.len());
    for (fa, fb) in a.frames.iter().zip(&b.frames) {
        assert_eq!(fa.per_camera.len(), fb.per_camera.len());
        for (la, lb) in fa.per_camera.iter().zip(&fb.per_camera) {
            assert_eq!(la.len(), lb.len());
            for (oa, ob) in la.iter().zip(lb) {
                for (x, y) in oa
                    .px0
                    .iter()
                    .chain(oa.px1.iter())
                    .zip(ob.px0.iter().chain(ob.px1.iter()))
                {
                    assert_eq!(x.to_bits(), y.to_bits());
                }
                assert_eq!(oa, ob);
            }
        }
    }
    assert_eq!(a.arc_lengths, b.arc_lengths);
    match (&a.ground_truth, &b.ground_truth) {
        (Some(ga), Some(gb)) => {
            assert_eq!(ga.len(), gb.len());
            for (pa, pb) in ga.iter().zip(gb) {
                assert!((pa.to_homogeneous() - pb.to_homogeneous()).amax() <= 1e-12);
            }
        }
        (None, None) => {}
        _ => panic!("ground truth presence differs"),
    }
}

#[test]
fn sequence_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let seq = sample_sequence();
    write_sequence(dir.path().join("new/sub"), &seq).unwrap();
    let back = read_sequence(dir.path().join("new/sub")).unwrap();
    assert_same(&seq, &back);
    // Shortest-representation printing round-trips exactly, poses included.
    assert_eq!(back, seq);
    // Writing again over an existing directory works, and drops optional files not in the sequence.
    let mut plain = seq.clone();
    plain.arc_lengths = None;
    plain.ground_truth = None;
    write_sequence(dir.path().join("new/sub"), &plain).unwrap();
    assert!(!dir.path().join("new/sub/odometry.csv").exists());
    assert_eq!(read_sequence(dir.path().join("new/sub")).unwrap(), plain);
}

#[test]
fn kitti_poses_layout() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("poses.txt");
    let pose = Pose::new(nalgebra::Matrix3::identity(), Vector3::new(1.5, -2.0, 0.25));
    write_poses(&p, &[Pose::identity(), pose]).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert_eq!(
        text,
        "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1.5 0 1 0 -2 0 0 1 0.25\n"
    );
}

#[test]
fn rig_layout_matches_format_md() {
    let dir = tempfile::tempdir().unwrap();
    let rig = read_rig_from_str(&rig_to_json(&two_camera_rig()).unwrap(), "r.json").unwrap();
    assert_eq!(rig, two_camera_rig());
    let p = dir.path().join("rig.json");
    let mono = Rig::mono(
        pinhole(),
        Pose::new(
            nalgebra::Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
            Vector3::new(1.0, 0.0, 1.65),
        ),
    )
    .unwrap();
    write_rig(&p, &mono).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let expected = r#"{
  "cameras": [
    {
      "name": "cam0",
      "model": {"type":"pinhole","fx":718.856,"fy":718.856,"cx":607.1928,"cy":185.2157,"width":1241.0,"height":376.0},
      "T_vehicle_camera": [[0, 0, 1, 1],
                           [-1, 0, 0, 0],
                           [0, -1, 0, 1.65],
                           [0, 0, 0, 1]]
    }
  ]
}
"#;
    assert_eq!(text, expected);
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn failed_writes_leave_no_partial_file() {
    let dir = tempfile::tempdir().unwrap();
    let seq = sample_sequence();
    // A NaN pixel in frame 4: frames 1..3 were already written to the temporary file.
    let mut frames = seq.frames.clone();
    frames[4].per_camera[1][3].px1.x = f64::NAN;
    let e = write_matches(dir.path().join("matches.csv"), &frames).unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::InvalidData(_)), "{e}");
    assert!(e.to_string().starts_with(&format!(
        "{}: cannot write",
        dir.path().join("matches.csv").display()
    )));
    assert!(files_in(dir.path()).is_empty());

    // An existing file survives a failed overwrite unchanged.
    write_matches(dir.path().join("matches.csv"), &seq.frames).unwrap();
    let before = std::fs::read(dir.path().join("matches.csv")).unwrap();
    assert!(write_matches(dir.path().join("matches.csv"), &frames).is_err());
    assert_eq!(
        std::fs::read(dir.path().join("matches.csv")).unwrap(),
        before
    );
    assert_eq!(files_in(dir.path()), vec!["matches.csv"]);

    // Poses: a NaN in the middle.
    let mut gt = seq.ground_truth.clone().unwrap();
    gt[3].translation.y = f64::INFINITY;
    assert!(write_poses(dir.path().join("poses.txt"), &gt).is_err());
    // Odometry: a value beyond ±1000 m (negative values, reversing, are written); an arc
    // length for frame 0.
    assert!(
        write_odometry(
            dir.path().join("odometry.csv"),
            &[None, Some(1.0), Some(-1000.5)]
        )
        .is_err()
    );
    assert!(write_odometry(dir.path().join("odometry.csv"), &[Some(1.0)]).is_err());
    // Rig: invalid intrinsics.
    let mut cams = seq.rig.cameras().to_vec();
    if let Camera::Pinhole(p) = &mut cams[0].model {
        p.fx = -1.0;
    }
    let bad_rig = Rig::new(cams).unwrap();
    assert!(write_rig(dir.path().join("rig.json"), &bad_rig).is_err());
    assert!(
        write_sequence(
            dir.path().join("seq"),
            &Sequence {
                rig: bad_rig,
                ..seq.clone()
            }
        )
        .is_err()
    );
    assert_eq!(files_in(dir.path()), vec!["matches.csv", "seq"]);
    assert!(files_in(&dir.path().join("seq")).is_empty());
}

#[test]
fn pose_writer_is_atomic() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("out.txt");
    {
        let mut w = PoseWriter::create(&p).unwrap();
        w.push(&Pose::identity()).unwrap();
        assert_eq!(w.len(), 1);
        // Dropped without finish.
    }
    assert!(files_in(dir.path()).is_empty());
    let mut w = PoseWriter::create(&p).unwrap();
    for k in 0..1000 {
        w.push(&Pose::new(
            nalgebra::Matrix3::identity(),
            Vector3::new(k as f64, 0.0, 0.0),
        ))
        .unwrap();
    }
    assert!(!p.exists(), "the file appears only on finish");
    let mut bad = Pose::identity();
    bad.rotation[(0, 0)] = f64::NAN;
    assert!(w.push(&bad).is_err());
    w.finish().unwrap();
    let poses = read_poses(&p).unwrap();
    assert_eq!(poses.len(), 1000);
    assert_eq!(poses[999].translation.x, 999.0);
    assert_eq!(files_in(dir.path()), vec!["out.txt"]);
}

#[test]
fn match_writer_streams() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.csv");
    let seq = sample_sequence();
    let mut w = MatchWriter::create(&p).unwrap();
    for (k, f) in seq.frames.iter().enumerate() {
        w.push(k, f).unwrap();
    }
    assert!(
        w.push(1, &seq.frames[1]).is_err(),
        "frames must not decrease"
    );
    w.finish().unwrap();
    let back: Vec<(usize, FrameObservations)> = MatchReader::open(&p, &seq.rig)
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(back.len(), 5);
    for (k, f) in back {
        assert_eq!(f, seq.frames[k]);
    }
}

// ------------------------------------------------------------------------------- properties

fn arb_camera() -> impl Strategy<Value = Camera> {
    let pin = (
        100.0..2000.0f64,
        100.0..2000.0f64,
        0.3..0.7f64,
        0.3..0.7f64,
        64u32..4000,
        64u32..3000,
    )
        .prop_map(|(fx, fy, a, b, w, h)| {
            Camera::Pinhole(Pinhole {
                fx,
                fy,
                cx: a * w as f64,
                cy: b * h as f64,
                width: w as f64,
                height: h as f64,
            })
        });
    let kb = (
        200.0..600.0f64,
        -0.03..0.03f64,
        -0.005..0.005f64,
        64u32..2000,
        64u32..2000,
    )
        .prop_map(|(f, k1, k2, w, h)| {
            Camera::KannalaBrandt(KannalaBrandt {
                fx: f,
                fy: f * 1.01,
                cx: w as f64 / 2.0,
                cy: h as f64 / 2.0,
                k1,
                k2,
                k3: 1e-4,
                k4: -1e-5,
                width: w as f64,
                height: h as f64,
            })
        });
    prop_oneof![pin, kb]
}

fn arb_rig() -> impl Strategy<Value = Rig> {
    prop::collection::vec(
        (
            arb_camera(),
            prop::array::uniform3(-3.0..3.0f64),
            prop::array::uniform3(-5.0..5.0f64),
            "[a-z0-9 _\"\\\\]{0,8}",
        ),
        1..4,
    )
    .prop_map(|cams| {
        let cameras = cams
            .into_iter()
            .map(|(model, w, t, name)| RigCamera {
                name,
                model,
                t_vehicle_camera: Pose::new(so3_exp(&Vector3::from(w)), Vector3::from(t)),
            })
            .collect();
        Rig::new(cameras).unwrap()
    })
}

/// Rows `(frame, camera, fractions of the image for u0 v0 u1 v1, sub-pixel noise)`.
fn arb_rows() -> impl Strategy<Value = Vec<(usize, usize, [f64; 4])>> {
    prop::collection::vec(
        (1usize..8, 0usize..4, prop::array::uniform4(-0.05..1.05f64)),
        0..60,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_sequences_round_trip(rig in arb_rig(), rows in arb_rows(), odo in prop::collection::vec(prop::option::of(0.0..40.0f64), 0..10)) {
        let n = rig.len();
        let mut frames = vec![FrameObservations::new(n)];
        let mut rows = rows;
        rows.sort_by_key(|r| r.0);
        for (k, j, f) in rows {
            let j = j % n;
            let model = rig.cameras()[j].model;
            let (w, h) = momo_core::CameraModel::size(&model);
            let Some(o) = Observation::new(&model, Vector2::new(f[0] * w, f[1] * h), Vector2::new(f[2] * w, f[3] * h)) else {
                continue;
            };
            while frames.len() <= k {
                frames.push(FrameObservations::new(n));
            }
            frames[k].per_camera[j].push(o);
        }
        let mut odo = odo;
        if let Some(first) = odo.first_mut() {
            *first = None;
        }
        // What the reader reconstructs: padding to num_frames, trailing empties dropped.
        let last_match = frames.iter().rposition(|f| !f.is_empty()).unwrap_or(0);
        let last_odo = odo.iter().rposition(Option::is_some).unwrap_or(0);
        let num = last_match.max(last_odo) + 1;
        let seq = Sequence { rig, frames, arc_lengths: Some(odo), ground_truth: None };
        let dir = tempfile::tempdir().unwrap();
        write_sequence(dir.path(), &seq).unwrap();
        let back = read_sequence(dir.path()).unwrap();
        prop_assert_eq!(back.num_frames(), num);
        prop_assert_eq!(&back.rig, &seq.rig);
        for k in 0..num.max(seq.frames.len()) {
            let empty = FrameObservations::new(n);
            let a = seq.frames.get(k).unwrap_or(&empty);
            let b = back.frames.get(k).unwrap_or(&empty);
            prop_assert_eq!(a, b);
        }
        let a = back.arc_lengths.unwrap();
        for k in 0..num {
            prop_assert_eq!(a[k], seq.arc_lengths.as_ref().unwrap().get(k).copied().flatten());
        }
    }

    #[test]
    fn garbage_lines_never_panic(lines in prop::collection::vec("[0-9a-z,.+\\-eE ]{0,30}", 0..12), bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let rig = Rig::mono(pinhole(), Pose::identity()).unwrap();
        let text = lines.join("\n");
        for input in [
            text.clone().into_bytes(),
            format!("frame,camera,u0,v0,u1,v1\n{text}").into_bytes(),
            format!("frame,arc_length\n{text}").into_bytes(),
            bytes.clone(),
        ] {
            if let Ok(r) = MatchReader::new(&input[..], &rig, "m") {
                for item in r.take(100) {
                    let _ = item;
                }
            }
            let _ = read_odometry_from(&input[..], "o");
            let _ = read_poses_from(&input[..], "p");
            if let Ok(s) = std::str::from_utf8(&input) {
                let _ = read_rig_from_str(s, "r");
            }
        }
    }

    #[test]
    fn garbage_json_never_panics(s in "[\\[\\]{}\",:0-9a-z_ \n.-]{0,80}") {
        let _ = read_rig_from_str(&s, "r");
        let wrapped = format!("{{\"cameras\": [{{\"name\": \"x\", \"model\": {s}, \"T_vehicle_camera\": {s}}}]}}");
        let _ = read_rig_from_str(&wrapped, "r");
    }
}

#[test]
fn write_sequence_checks_matches_against_the_rig() {
    let dir = tempfile::tempdir().unwrap();
    let mut seq = sample_sequence();
    let extra = seq.frames[2].per_camera[0].clone();
    seq.frames[2].per_camera.push(extra);
    let e = write_sequence(dir.path(), &seq).unwrap_err();
    assert!(
        e.to_string().contains("frame 2 has matches of camera 2"),
        "{e}"
    );
    let mut seq = sample_sequence();
    seq.frames[4].per_camera[0][1].px0.x = -5000.0;
    let e = write_sequence(dir.path().join("x"), &seq).unwrap_err();
    assert!(
        e.to_string().contains("frame 4: `u0,v0` pixel (-5000"),
        "{e}"
    );
    assert!(files_in(dir.path()).is_empty());
}

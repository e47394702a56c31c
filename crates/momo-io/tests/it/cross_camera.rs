//! matches.csv version 5: the optional `camera_to` column (cross-camera matches).
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{Camera, FrameObservations, Pinhole, Pose, Rig, RigCamera};
use momo_io::*;
use nalgebra::Vector3;

fn stereo_rig() -> Rig {
    let cam = Camera::Pinhole(Pinhole {
        fx: 700.0,
        fy: 700.0,
        cx: 600.0,
        cy: 180.0,
        width: 1200.0,
        height: 370.0,
    });
    let left = Pose::identity();
    let right = Pose::new(left.rotation, Vector3::new(0.0, -0.5, 0.0));
    Rig::new(vec![
        RigCamera {
            name: "left".into(),
            model: cam,
            t_vehicle_camera: left,
        },
        RigCamera {
            name: "right".into(),
            model: cam,
            t_vehicle_camera: right,
        },
    ])
    .unwrap()
}

fn read(text: &str) -> Result<Vec<(usize, FrameObservations)>, IoError> {
    MatchReader::new(text.as_bytes(), &stereo_rig(), "seq/matches.csv")?.collect()
}

#[test]
fn camera_to_column_gives_cross_camera_matches() {
    let text = "frame,camera,u0,v0,u1,v1,camera_to\n\
                1,0,10,20,11,21,\n\
                1,1,12,22,13,23,1\n\
                1,0,14,24,15,25,1\n\
                2,1,16,26,17,27,0\n";
    let frames = read(text).unwrap();
    assert_eq!(frames.len(), 2);
    let (k, f) = &frames[0];
    assert_eq!(*k, 1);
    // An empty camera_to and camera_to == camera are ordinary matches.
    assert_eq!(f.per_camera[0].len(), 1);
    assert_eq!(f.per_camera[1].len(), 1);
    assert_eq!(f.len(), 2);
    assert_eq!(f.cross_camera.len(), 1);
    let x = f.cross_camera[0];
    assert_eq!((x.camera, x.camera_to), (0, 1));
    assert_eq!((x.obs.px0.x, x.obs.px1.x), (14.0, 15.0));
    let x = frames[1].1.cross_camera[0];
    assert_eq!((x.camera, x.camera_to), (1, 0));
    assert!(frames[1].1.is_empty());
}

#[test]
fn camera_to_errors_name_the_line() {
    let e = read("frame,camera,u0,v0,u1,v1,camera_to\n1,0,10,20,11,21,2\n").unwrap_err();
    assert!(
        matches!(e.kind, IoErrorKind::UnknownCamera { camera: 2, .. }),
        "{e}"
    );
    assert_eq!(e.line, Some(2));
    let e = read("frame,camera,u0,v0,u1,v1,camera_to\n1,0,10,20,11,21\n").unwrap_err();
    assert!(
        matches!(e.kind, IoErrorKind::FieldCount { expected: 7, .. }),
        "{e}"
    );
    let e = read("frame,camera,u0,v0,u1,v1,camera_to\n1,0,10,20,11,21,x\n").unwrap_err();
    assert!(matches!(e.kind, IoErrorKind::BadNumber { .. }), "{e}");
    // The pixel in frame k is checked against camera_to's image.
    let e = read("frame,camera,u0,v0,u1,v1,camera_to\n1,0,10,20,11,2100,1\n").unwrap_err();
    assert!(
        matches!(e.kind, IoErrorKind::PixelOutsideImage { camera: 1, .. }),
        "{e}"
    );
}

#[test]
fn writer_round_trips_cross_camera_matches() {
    let text = "frame,camera,u0,v0,u1,v1,camera_to\n\
                1,0,10.25,20,11,21,0\n\
                1,0,14,24,15,25.5,1\n\
                3,1,16,26,17,27,0\n";
    let frames = read(text).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("matches.csv");
    let mut all = vec![FrameObservations::new(2)];
    all.extend(frames.iter().map(|(_, f)| f.clone()));
    write_matches(&path, &all).unwrap();
    let written = std::fs::read_to_string(&path).unwrap();
    assert!(written.starts_with(MATCHES_HEADER_CROSS), "{written}");
    let back = read(&written).unwrap();
    assert_eq!(back, frames);
    // Without cross-camera matches the version-1 header is written.
    let plain: Vec<FrameObservations> = all
        .iter()
        .map(|f| FrameObservations {
            cross_camera: Vec::new(),
            ..f.clone()
        })
        .collect();
    write_matches(&path, &plain).unwrap();
    let written = std::fs::read_to_string(&path).unwrap();
    assert!(
        written.starts_with(&format!("{MATCHES_HEADER}\n")),
        "{written}"
    );
    // A writer without the column refuses cross-camera matches.
    let mut w = MatchWriter::create(dir.path().join("m2.csv")).unwrap();
    assert!(w.push(1, &all[1]).is_err());
}

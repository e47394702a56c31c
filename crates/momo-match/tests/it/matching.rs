//! The matcher on synthetic images with known motion (share of correct matches, sub-pixel
//! accuracy, spread), the streaming front end, and the error paths.

use image::GrayImage;
use momo_core::{Camera, Pinhole, Pose, Rig};
use momo_match::synthetic::{apply_homography, dead_leaves, warp};
use momo_match::{
    FrameMatcher, FrontEndOptions, GammaTable, Match, MatchError, MatchOptions, VoRun,
    match_images, match_to_sequence, vo_from_images,
};
use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};

/// A similarity about `(cx, cy)`: scale `s`, rotation `a` radians, then a shift `(tx, ty)`.
fn similarity(cx: f64, cy: f64, s: f64, a: f64, tx: f64, ty: f64) -> Matrix3<f64> {
    let (c, si) = (s * a.cos(), s * a.sin());
    Matrix3::new(
        c,
        -si,
        cx - c * cx + si * cy + tx,
        si,
        c,
        cy - si * cx - c * cy + ty,
        0.0,
        0.0,
        1.0,
    )
}

/// Reprojection errors of the matches under the true warp `h`.
fn errors(matches: &[Match], h: &Matrix3<f64>) -> Vec<f64> {
    matches
        .iter()
        .map(|m| {
            let (u, v) = apply_homography(h, m.u0, m.v0);
            (u - m.u1).hypot(v - m.v1)
        })
        .collect()
}

fn share_within(errors: &[f64], tol: f64) -> f64 {
    errors.iter().filter(|e| **e <= tol).count() as f64 / errors.len().max(1) as f64
}

/// A projective warp (forward motion with a slight turn, as a car sees a plane): at least 90 %
/// of the matches reproject within 1.5 px, and the matcher delivers most of the requested 200.
#[test]
fn most_matches_are_correct_under_a_known_homography() {
    let img0 = dead_leaves(640, 400, 4000, 11);
    let mut h = similarity(320.0, 200.0, 1.03, 0.02, 4.0, -2.0);
    h[(2, 0)] = 2e-5; // a little perspective
    let img1 = warp(&img0, &h).expect("invertible");
    let matches = match_images(&img0, &img1, &MatchOptions::default()).expect("same size");
    let e = errors(&matches, &h);
    let share = share_within(&e, 1.5);
    eprintln!(
        "homography: {} matches, {:.1} % within 1.5 px",
        matches.len(),
        100.0 * share
    );
    assert!(matches.len() >= 150, "{} matches", matches.len());
    assert!(matches.len() <= 200);
    assert!(share >= 0.9, "only {:.1} % correct", 100.0 * share);
}

/// A sub-pixel shift is recovered to a fraction of a pixel by the parabola refinement, and
/// refinement beats integer positions.
#[test]
fn subpixel_refinement_recovers_a_fractional_shift() {
    let img0 = dead_leaves(480, 320, 2500, 5);
    let h = similarity(0.0, 0.0, 1.0, 0.0, 3.4, -1.7);
    let img1 = warp(&img0, &h).expect("invertible");
    let median = |mut e: Vec<f64>| {
        e.sort_by(f64::total_cmp);
        e[e.len() / 2]
    };
    // Without the KLT refinement (tests/it/refine.rs), which replaces both.
    let parabola = MatchOptions {
        klt: None,
        ..MatchOptions::default()
    };
    let refined = match_images(&img0, &img1, &parabola).expect("same size");
    let integer = match_images(
        &img0,
        &img1,
        &MatchOptions {
            subpixel: false,
            ..parabola
        },
    )
    .expect("same size");
    let (mr, mi) = (median(errors(&refined, &h)), median(errors(&integer, &h)));
    eprintln!("shift (3.4, -1.7): median error {mr:.3} px refined, {mi:.3} px integer");
    assert!(mr < 0.35, "median error {mr}");
    assert!(mr < mi, "refined {mr} vs integer {mi}");
}

/// Bucketing spreads the matches: every cell of a 4 x 3 grid over a fully textured image gets
/// some, and no cell holds more than a quarter of them.
#[test]
fn matches_spread_over_the_whole_image() {
    let img0 = dead_leaves(640, 400, 4000, 21);
    let h = similarity(320.0, 200.0, 1.02, 0.0, -3.0, 1.0);
    let img1 = warp(&img0, &h).expect("invertible");
    let options = MatchOptions {
        matches_per_frame: 120,
        ..MatchOptions::default()
    };
    let matches = match_images(&img0, &img1, &options).expect("same size");
    assert!(
        matches.len() <= 120 && matches.len() >= 100,
        "{}",
        matches.len()
    );
    let mut cells = [0usize; 12];
    for m in &matches {
        let c = ((m.u0 / 640.0 * 4.0) as usize).min(3) + 4 * ((m.v0 / 400.0 * 3.0) as usize).min(2);
        cells[c] += 1;
    }
    eprintln!("matches per cell: {cells:?}");
    assert!(cells.iter().all(|&c| c > 0), "{cells:?}");
    assert!(cells.iter().all(|&c| c * 4 <= matches.len()), "{cells:?}");
}

/// Unrelated images give few matches that pass the uniqueness and circular checks (before
/// bucketing, compared with the same texture shifted), and the streaming matcher returns nothing
/// for the first frame.
#[test]
fn streaming_matcher_and_unrelated_images() {
    let a = dead_leaves(320, 240, 1500, 1);
    let b = dead_leaves(320, 240, 1500, 2);
    let all = MatchOptions {
        matches_per_frame: 100_000,
        ..MatchOptions::default()
    };
    let mut m = FrameMatcher::new(1, all).expect("valid");
    assert!(m.push(std::slice::from_ref(&a)).expect("ok").is_none());
    let pair = m
        .push(std::slice::from_ref(&b))
        .expect("ok")
        .expect("second frame");
    let shifted = warp(&a, &similarity(0.0, 0.0, 1.0, 0.0, 3.3, 1.2)).expect("invertible");
    let related = match_images(&a, &shifted, &all).expect("ok");
    eprintln!(
        "unrelated: {} matches, shifted: {}",
        pair[0].len(),
        related.len()
    );
    assert!(
        pair[0].len() * 100 < related.len() * 15,
        "{} vs {}",
        pair[0].len(),
        related.len()
    );
    // Identical images: every match is exact.
    let same = match_images(&a, &a, &MatchOptions::default()).expect("ok");
    assert_eq!(same.len(), 200);
    assert!(
        same.iter()
            .all(|m| (m.u0 - m.u1).abs() < 1e-9 && (m.v0 - m.v1).abs() < 1e-9)
    );
    // A size change is an error, not a panic.
    let small = dead_leaves(100, 80, 100, 3);
    assert!(m.push(std::slice::from_ref(&small)).is_err());
}

/// Images given away (`push_owned`, the pipeline's) give the matches of borrowed ones
/// (`push`) over a short stereo sequence with the flow prior and KLT on (the default), and the
/// features keep the same pixels for KLT; a size change is an error either way.
#[test]
fn owned_images_give_the_same_matches() {
    let a = dead_leaves(320, 240, 1500, 4);
    let frames: Vec<[GrayImage; 2]> = (0..4)
        .map(|k| {
            let s = f64::from(k);
            let h = |dx: f64| similarity(160.0, 120.0, 1.0 + 0.01 * s, 0.01 * s, 2.5 * s + dx, s);
            [
                warp(&a, &h(0.0)).expect("invertible"),
                warp(&a, &h(-7.0)).expect("invertible"),
            ]
        })
        .collect();
    let options = MatchOptions::default();
    let mut borrowed = FrameMatcher::new(2, options).expect("valid");
    let mut owned = FrameMatcher::new(2, options).expect("valid");
    let mut pairs = 0;
    for images in &frames {
        let b = borrowed.push(images).expect("ok");
        let o = owned.push_owned(images.to_vec()).expect("ok");
        assert_eq!(b, o);
        pairs += usize::from(b.is_some_and(|m| m.iter().all(|c| c.len() > 50)));
        for camera in 0..2 {
            let (fb, fo) = (
                borrowed.current(camera).expect("features"),
                owned.current(camera).expect("features"),
            );
            assert_eq!(fb.plane().px, fo.plane().px);
            assert_eq!(fb.classes[0].points, fo.classes[0].points);
        }
    }
    assert_eq!(pairs, 3);
    let small = dead_leaves(100, 80, 100, 3);
    assert!(owned.push_owned(vec![small.clone(), small]).is_err());
}

#[test]
fn options_are_checked() {
    for bad in [
        MatchOptions {
            matches_per_frame: 0,
            ..MatchOptions::default()
        },
        MatchOptions {
            max_flow_u: 0,
            ..MatchOptions::default()
        },
    ] {
        assert!(matches!(
            FrameMatcher::new(1, bad),
            Err(MatchError::Option(_))
        ));
    }
    assert!(GammaTable::new(0.0).is_err());
    assert!(GammaTable::new(f64::NAN).is_err());
    let g = GammaTable::new(1.0).expect("valid");
    let mut img = dead_leaves(50, 40, 50, 1);
    let before = img.clone();
    g.apply(&mut img);
    assert_eq!(img, before);
    let mut dark = GrayImage::from_pixel(4, 4, image::Luma([64]));
    GammaTable::new(2.2).expect("valid").apply(&mut dark);
    assert!(dark.get_pixel(0, 0)[0] > 64);
}

// ---- sequences on disk ----

fn pinhole(w: u32, h: u32) -> Camera {
    Camera::Pinhole(Pinhole {
        fx: 400.0,
        fy: 400.0,
        cx: f64::from(w) / 2.0,
        cy: f64::from(h) / 2.0,
        width: f64::from(w),
        height: f64::from(h),
    })
}

fn mount() -> Pose<f64> {
    Pose::new(
        Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
        Vector3::new(1.0, 0.0, 1.65),
    )
}

/// Writes `frames` images of a texture drifting right by 2 px per frame into `dir/cam`.
fn write_frames(dir: &Path, cam: &str, frames: usize, seed: u64) -> PathBuf {
    let folder = dir.join(cam);
    std::fs::create_dir_all(&folder).expect("mkdir");
    let base = dead_leaves(320, 240, 1500, seed);
    for k in 0..frames {
        let h = similarity(0.0, 0.0, 1.0, 0.0, 2.0 * k as f64, 0.0);
        let img = warp(&base, &h).expect("invertible");
        img.save(folder.join(format!("{k:06}.png"))).expect("png");
    }
    folder
}

fn write_rig(dir: &Path, cameras: usize) -> PathBuf {
    let cams = (0..cameras)
        .map(|j| momo_core::RigCamera {
            name: format!("cam{j}"),
            model: pinhole(320, 240),
            t_vehicle_camera: Pose::new(
                mount().rotation,
                mount().translation + Vector3::new(0.0, -0.5 * j as f64, 0.0),
            ),
        })
        .collect();
    let rig = Rig::new(cams).expect("valid rig");
    let path = dir.join(format!("rig_{cameras}.json"));
    momo_io::write_rig(&path, &rig).expect("write rig");
    path
}

#[test]
fn match_writes_a_sequence_that_momo_reads() {
    let dir = tempfile::tempdir().expect("tmp");
    let c0 = write_frames(dir.path(), "cam0", 4, 1);
    let c1 = write_frames(dir.path(), "cam1", 4, 2);
    let rig = write_rig(dir.path(), 2);
    let odo = dir.path().join("odo.csv");
    std::fs::write(&odo, "frame,arc_length\n1,0.5\n2,0.5\n3,0.5\n").expect("write");
    let out = dir.path().join("seq");
    let mut seen = Vec::new();
    let stats = match_to_sequence(
        &[c0.clone(), c1.clone()],
        &rig,
        &out,
        Some(&odo),
        &FrontEndOptions::default(),
        |k| seen.push(k),
    )
    .expect("matched");
    assert_eq!(seen, vec![1, 2, 3]);
    assert_eq!(stats.frames, 4);
    let seq = momo_io::read_sequence(&out).expect("a valid sequence");
    assert_eq!(seq.num_frames(), 4);
    assert_eq!(seq.rig.len(), 2);
    assert_eq!(
        std::fs::read(&rig).expect("rig"),
        std::fs::read(out.join("rig.json")).expect("copy")
    );
    for k in 1..4 {
        for j in 0..2 {
            let obs = &seq.frames[k].per_camera[j];
            assert!(obs.len() >= 100, "frame {k} camera {j}: {}", obs.len());
            let good = obs
                .iter()
                .filter(|o| {
                    ((o.px1.x - o.px0.x) - 2.0).abs() < 1.0 && (o.px1.y - o.px0.y).abs() < 1.0
                })
                .count();
            assert!(good * 10 >= obs.len() * 9, "{good} of {}", obs.len());
        }
    }
    assert_eq!(stats.matches, seq.num_matches());

    // The same folders straight to a trajectory: one pose per image.
    let poses = dir.path().join("poses.txt");
    let run = VoRun {
        folders: vec![c0, c1],
        rig,
        odometry: Some(odo),
        output: poses.clone(),
        diagnostics: None,
        estimator: momo_vo::EstimatorKind::Momo,
    };
    let mut frames = 0;
    let summary = vo_from_images(
        &run,
        momo_vo::Config::default(),
        &FrontEndOptions::default(),
        |_| frames += 1,
    )
    .expect("vo");
    assert_eq!(frames, 3);
    assert_eq!(summary.poses, 4);
    assert_eq!(momo_io::read_poses(&poses).expect("poses").len(), 4);
}

#[test]
fn errors_name_the_file() {
    let dir = tempfile::tempdir().expect("tmp");
    let c0 = write_frames(dir.path(), "cam0", 3, 1);
    let rig1 = write_rig(dir.path(), 1);
    let out = dir.path().join("seq");
    let opts = FrontEndOptions::default();
    let run = |folders: &[PathBuf], rig: &Path| {
        match_to_sequence(folders, rig, &out, None, &opts, |_| {}).expect_err("must fail")
    };

    // A missing folder.
    let missing = dir.path().join("nope");
    let e = run(std::slice::from_ref(&missing), &rig1);
    assert!(matches!(e, MatchError::NotAFolder { .. }), "{e}");
    assert!(e.to_string().contains("nope"), "{e}");

    // A folder without images.
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).expect("mkdir");
    let e = run(&[empty], &rig1);
    assert!(matches!(e, MatchError::NoImages { .. }), "{e}");

    // Different image counts between cameras.
    let c1 = write_frames(dir.path(), "cam1", 2, 2);
    let rig2 = write_rig(dir.path(), 2);
    let e = run(&[c0.clone(), c1], &rig2);
    assert!(
        matches!(
            e,
            MatchError::CountMismatch {
                count: 2,
                first_count: 3,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("cam1"), "{e}");

    // Folders and rig cameras disagree.
    let e = run(std::slice::from_ref(&c0), &rig2);
    assert!(
        matches!(
            e,
            MatchError::CameraCount {
                cameras: 2,
                folders: 1,
                ..
            }
        ),
        "{e}"
    );

    // An undecodable image.
    let bad = dir.path().join("bad");
    std::fs::create_dir_all(&bad).expect("mkdir");
    for k in 0..3 {
        std::fs::copy(
            c0.join(format!("{k:06}.png")),
            bad.join(format!("{k:06}.png")),
        )
        .expect("cp");
    }
    std::fs::write(bad.join("000001.png"), b"not a png").expect("write");
    let e = run(std::slice::from_ref(&bad), &rig1);
    assert!(matches!(e, MatchError::Decode { .. }), "{e}");
    assert!(e.to_string().contains("000001.png"), "{e}");
    assert!(!out.join("matches.csv").exists(), "no partial output");

    // An image whose size differs from the rig's camera.
    let wrong = dir.path().join("wrong");
    std::fs::create_dir_all(&wrong).expect("mkdir");
    dead_leaves(200, 100, 100, 1)
        .save(wrong.join("000000.png"))
        .expect("png");
    let e = run(&[wrong], &rig1);
    assert!(
        matches!(
            e,
            MatchError::ImageSize {
                width: 200,
                height: 100,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("000000.png"), "{e}");

    // A malformed rig names its file.
    let bad_rig = dir.path().join("bad_rig.json");
    std::fs::write(&bad_rig, "{").expect("write");
    let e = run(&[c0], &bad_rig);
    assert!(e.to_string().contains("bad_rig.json"), "{e}");
    assert!(e.is_input());
}

/// One camera without odometry.csv: `momo vo` holds back the first frame pairs' matches for
/// `odometry.road_scale_mount` and then runs them, so it gives the poses, the per-frame
/// diagnostics (statuses, reasons, sigmas; all but the timing) and the calibration outcome of
/// `momo match` followed by `momo run` (`run_sequence`).
#[test]
fn vo_without_odometry_calibrates_as_match_and_run_do() {
    let dir = tempfile::tempdir().expect("tmp");
    let c0 = write_frames(dir.path(), "cam0", 6, 1);
    let rig = write_rig(dir.path(), 1);
    let seq = dir.path().join("seq");
    match_to_sequence(
        std::slice::from_ref(&c0),
        &rig,
        &seq,
        None,
        &FrontEndOptions::default(),
        |_| {},
    )
    .expect("matched");
    let run_poses = dir.path().join("run.txt");
    let options = momo_vo::RunOptions {
        estimator: momo_vo::EstimatorKind::Momo,
        output: run_poses.clone(),
        diagnostics: Some(dir.path().join("run.csv")),
        rig: None,
    };
    let ran =
        momo_vo::run_sequence(&seq, momo_vo::Config::default(), &options, |_| {}).expect("runs");
    let vo_poses = dir.path().join("vo.txt");
    let run = VoRun {
        folders: vec![c0],
        rig,
        odometry: None,
        output: vo_poses.clone(),
        diagnostics: Some(dir.path().join("vo.csv")),
        estimator: momo_vo::EstimatorKind::Momo,
    };
    let mut frames = 0;
    let vo = vo_from_images(
        &run,
        momo_vo::Config::default(),
        &FrontEndOptions::default(),
        |_| frames += 1,
    )
    .expect("vo");
    assert_eq!(frames, 5);
    assert_ne!(ran.road_mount, momo_vo::RoadMount::NotRun);
    assert_eq!(vo.run.road_mount, ran.road_mount);
    assert_eq!(
        std::fs::read(&vo_poses).expect("vo poses"),
        std::fs::read(&run_poses).expect("run poses")
    );
    // The diagnostics rows without the time column (`time_us`, found by its header).
    let rows = |name: &str| -> Vec<Vec<String>> {
        let text = std::fs::read_to_string(dir.path().join(name)).expect("diagnostics");
        let time = text
            .lines()
            .next()
            .and_then(|h| h.split(',').position(|c| c == "time_us"))
            .expect("a time_us column");
        text.lines()
            .map(|l| {
                let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
                f.remove(time);
                f
            })
            .collect()
    };
    let (run_rows, vo_rows) = (rows("run.csv"), rows("vo.csv"));
    assert_eq!(
        run_rows[0][..2],
        ["frame".to_string(), "status".to_string()]
    );
    assert_eq!(run_rows.len(), 6, "a header and one row per frame pair");
    assert_eq!(vo_rows, run_rows);
}

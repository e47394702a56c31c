//! End-to-end properties of the simulator.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_core::{CameraModel, Pose, essential};
use momo_sim::*;

fn presets() -> Vec<(&'static str, SimConfig)> {
    vec![
        ("default", SimConfig::default()),
        ("clean_pinhole", SimConfig::clean_pinhole()),
        ("outliers", SimConfig::outliers()),
        ("fisheye_surround", SimConfig::fisheye_surround()),
        ("moving_object", SimConfig::moving_object()),
        ("sparse_outliers", SimConfig::sparse_outliers()),
        ("very_sparse", SimConfig::very_sparse()),
        ("highway", SimConfig::highway()),
        (
            "stereo",
            SimConfig {
                rig: RigPreset::KittiStereo,
                stops: true,
                ..SimConfig::default()
            },
        ),
    ]
}

fn max_dev(a: &Pose<f64>, b: &Pose<f64>) -> f64 {
    (a.to_homogeneous() - b.to_homogeneous()).amax()
}

#[test]
fn deterministic_for_a_seed() {
    for (name, cfg) in presets() {
        let cfg = SimConfig { frames: 30, ..cfg };
        let a = simulate(&cfg).unwrap();
        let b = simulate(&cfg).unwrap();
        assert_eq!(a, b, "{name}");
        let c = simulate(&SimConfig {
            seed: 1,
            ..cfg.clone()
        })
        .unwrap();
        assert_ne!(a.sequence.frames, c.sequence.frames, "{name}");
        assert_ne!(a.vehicle_poses, c.vehicle_poses, "{name}");
    }
}

#[test]
fn longer_simulations_start_with_the_shorter_ones() {
    let short = simulate(&SimConfig {
        frames: 25,
        ..SimConfig::fisheye_surround()
    })
    .unwrap();
    let long = simulate(&SimConfig {
        frames: 60,
        ..SimConfig::fisheye_surround()
    })
    .unwrap();
    assert_eq!(short.sequence.frames[..], long.sequence.frames[..25]);
    assert_eq!(short.vehicle_poses[..], long.vehicle_poses[..25]);
}

#[test]
fn noise_free_inliers_satisfy_the_epipolar_constraint() {
    for (name, cfg) in presets() {
        let cfg = SimConfig {
            frames: 60,
            pixel_noise: 0.0,
            ..cfg
        };
        let sim = simulate(&cfg).unwrap();
        let mut checked = 0;
        let mut outlier_residuals = Vec::new();
        for k in 1..cfg.frames {
            for j in 0..sim.sequence.rig.len() {
                let c = sim.camera_motion(k, j);
                let e = essential(&c);
                for (o, l) in sim.sequence.frames[k].per_camera[j]
                    .iter()
                    .zip(&sim.labels[k][j])
                {
                    let r = (o.f1.transpose() * e * o.f0)[0];
                    match l {
                        MatchLabel::Inlier => {
                            assert!(r.abs() < 1e-9, "{name} k={k} j={j}: {r}");
                            // The bearing in frame k-1 is the rotated bearing of frame k plus
                            // a translation-induced part in the epipolar plane.
                            checked += 1;
                        }
                        MatchLabel::Outlier if c.translation.norm() > 0.3 => {
                            outlier_residuals.push(r.abs())
                        }
                        MatchLabel::MovingObject => {
                            assert!((o.px0 - o.px1).amax() < 1e-9, "follows the vehicle")
                        }
                        _ => {}
                    }
                }
            }
        }
        assert!(checked > 1000, "{name}: {checked}");
        if !outlier_residuals.is_empty() {
            outlier_residuals.sort_by(f64::total_cmp);
            let median = outlier_residuals[outlier_residuals.len() / 2];
            assert!(
                median > 1e-4,
                "{name}: outliers look like inliers ({median})"
            );
        }
    }
}

#[test]
fn outlier_ratio_is_honoured() {
    let sim = simulate(&SimConfig {
        frames: 40,
        ..SimConfig::outliers()
    })
    .unwrap();
    let (mut outliers, mut total) = (0usize, 0usize);
    for k in 1..40 {
        let labels = &sim.labels[k][0];
        let n = labels.len();
        assert_eq!(n, sim.sequence.frames[k].per_camera[0].len());
        assert!(n >= 290, "frame {k}: {n} matches");
        let o = labels.iter().filter(|l| **l == MatchLabel::Outlier).count();
        assert_eq!(o, (0.3 * n as f64).round() as usize);
        outliers += o;
        total += n;
    }
    let ratio = outliers as f64 / total as f64;
    assert!((ratio - 0.3).abs() < 0.005, "{ratio}");
    // No outliers when asked for none.
    let clean = simulate(&SimConfig {
        frames: 10,
        ..SimConfig::clean_pinhole()
    })
    .unwrap();
    assert!(
        clean
            .labels
            .iter()
            .flatten()
            .flatten()
            .all(|l| *l == MatchLabel::Inlier)
    );
}

#[test]
fn every_camera_gets_its_matches() {
    for (name, cfg) in presets() {
        let sim = simulate(&SimConfig {
            frames: 30,
            ..cfg.clone()
        })
        .unwrap();
        for k in 1..30 {
            for j in 0..sim.sequence.rig.len() {
                let n = sim.sequence.frames[k].per_camera[j].len();
                let blinded = cfg
                    .blinded
                    .iter()
                    .any(|b| b.camera == j && b.frames.contains(&k));
                if !blinded {
                    assert!(
                        n as f64 >= 0.95 * cfg.matches_per_camera as f64,
                        "{name} k={k} j={j}: {n}"
                    );
                }
                let cam = &sim.sequence.rig.cameras()[j].model;
                for o in &sim.sequence.frames[k].per_camera[j] {
                    assert!(cam.contains(&o.px0, 0.0) && cam.contains(&o.px1, 0.0));
                }
            }
        }
    }
}

#[test]
fn blinded_camera_has_no_matches() {
    let sim = simulate(&SimConfig::fisheye_surround()).unwrap();
    for k in 1..100 {
        let n = sim.sequence.frames[k].per_camera[2].len();
        if (40..70).contains(&k) {
            assert_eq!(n, 0, "frame {k}");
        } else {
            assert!(n > 150, "frame {k}: {n}");
        }
    }
    let garbage = simulate(&SimConfig {
        frames: 10,
        blinded: vec![Blinding {
            camera: 0,
            frames: 2..4,
            mode: BlindMode::Outliers,
        }],
        ..SimConfig::clean_pinhole()
    })
    .unwrap();
    assert!(
        garbage.labels[3][0]
            .iter()
            .all(|l| *l == MatchLabel::Blinded)
    );
    assert_eq!(garbage.labels[3][0].len(), 300);
    assert!(
        garbage.labels[4][0]
            .iter()
            .all(|l| *l == MatchLabel::Inlier)
    );
}

#[test]
fn moving_object_share() {
    let sim = simulate(&SimConfig::moving_object()).unwrap();
    for k in 1..100 {
        let n_obj = sim.labels[k][0]
            .iter()
            .filter(|l| **l == MatchLabel::MovingObject)
            .count();
        if (30..60).contains(&k) {
            assert_eq!(n_obj, 135, "frame {k}");
        } else {
            assert_eq!(n_obj, 0);
        }
    }
}

#[test]
fn ground_truth_composes_back_to_the_vehicle_poses() {
    for (name, cfg) in presets() {
        let sim = simulate(&SimConfig { frames: 80, ..cfg }).unwrap();
        let gt = sim.sequence.ground_truth.as_ref().unwrap();
        let p0 = sim.sequence.rig.cameras()[0].t_vehicle_camera;
        assert_eq!(gt.len(), 80);
        assert!(max_dev(&gt[0], &Pose::identity()) < 1e-15, "{name}");
        assert_eq!(sim.vehicle_poses[0], Pose::identity());
        for k in 0..80 {
            // V_k = V_0 P0 gt[k] P0⁻¹
            let v = sim.vehicle_poses[0].compose(&p0.compose(&gt[k]).compose(&p0.inverse()));
            assert!(max_dev(&v, &sim.vehicle_poses[k]) < 1e-12, "{name} k={k}");
            if k > 0 {
                let m = sim.vehicle_poses[k - 1]
                    .inverse()
                    .compose(&sim.vehicle_poses[k]);
                assert!(max_dev(&m, &sim.vehicle_motions[k]) < 1e-15);
                // Camera-0 motion from the ground truth equals C_0 = P0⁻¹ M P0.
                let c = gt[k - 1].inverse().compose(&gt[k]);
                assert!(max_dev(&c, &sim.camera_motion(k, 0)) < 1e-9, "{name} k={k}");
            }
        }
        assert_eq!(sim.vehicle_motions[0], Pose::identity());
    }
}

#[test]
fn arc_lengths_and_stops() {
    let sim = simulate(&SimConfig {
        frames: 600,
        ..SimConfig::fisheye_surround()
    })
    .unwrap();
    let arcs = sim.sequence.arc_lengths.as_ref().unwrap();
    assert_eq!(arcs.len(), 600);
    assert_eq!(arcs[0], None);
    let mut stopped = 0;
    for k in 1..600 {
        let s = arcs[k].unwrap();
        assert_eq!(s, sim.true_arc_lengths[k]);
        assert!((0.0..=3.0 + 1e-9).contains(&s));
        let chord = sim.vehicle_motions[k].translation.norm();
        assert!(chord <= s + 1e-12 && chord >= 0.99 * s);
        if s == 0.0 {
            stopped += 1;
            assert!(sim.vehicle_motions[k].rotation_angle() < 1e-12);
        }
    }
    assert!(stopped > 0, "the fisheye preset includes stops");
    // Speeds cover a realistic range.
    let vmax = sim.speeds.iter().copied().fold(0.0, f64::max);
    assert!(vmax > 10.0 && vmax <= 30.0, "{vmax}");
    // Without odometry the sequence has no arc lengths; with noise they differ from the truth.
    let no_odo = simulate(&SimConfig {
        frames: 10,
        odometry: false,
        ..SimConfig::default()
    })
    .unwrap();
    assert!(no_odo.sequence.arc_lengths.is_none());
    let noisy = simulate(&SimConfig {
        frames: 10,
        odometry_noise: 0.05,
        ..SimConfig::default()
    })
    .unwrap();
    let a = noisy.sequence.arc_lengths.as_ref().unwrap();
    assert!((1..10).all(|k| a[k].unwrap() != noisy.true_arc_lengths[k]));
}

#[test]
fn write_and_read_round_trip() {
    for (name, cfg) in presets() {
        let sim = simulate(&SimConfig { frames: 40, ..cfg }).unwrap();
        let dir = tempfile::tempdir().unwrap();
        sim.write(dir.path()).unwrap();
        let back = momo_io::read_sequence(dir.path()).unwrap();
        assert_eq!(back.num_frames(), 40, "{name}");
        assert_eq!(back.rig, sim.sequence.rig, "{name}");
        assert_eq!(back.frames, sim.sequence.frames, "{name}");
        assert_eq!(back.arc_lengths, sim.sequence.arc_lengths, "{name}");
        let (g0, g1) = (
            back.ground_truth.unwrap(),
            sim.sequence.ground_truth.clone().unwrap(),
        );
        assert_eq!(g0.len(), g1.len());
        for (a, b) in g0.iter().zip(&g1) {
            assert!(max_dev(a, b) <= 1e-12);
        }
    }
}

#[test]
fn invalid_configs_are_errors_not_panics() {
    let cases = [
        SimConfig {
            frames: 0,
            ..SimConfig::default()
        },
        SimConfig {
            outlier_ratio: 1.5,
            ..SimConfig::default()
        },
        SimConfig {
            static_tracks: 1.5,
            ..SimConfig::default()
        },
        SimConfig {
            static_tracks: f64::NAN,
            ..SimConfig::default()
        },
        SimConfig {
            pixel_noise: f64::NAN,
            ..SimConfig::default()
        },
        SimConfig {
            pixel_noise: -1.0,
            ..SimConfig::default()
        },
        SimConfig {
            matches_per_camera: usize::MAX,
            ..SimConfig::default()
        },
        SimConfig {
            blinded: vec![Blinding {
                camera: 9,
                frames: 0..3,
                mode: BlindMode::Absent,
            }],
            ..SimConfig::default()
        },
        SimConfig {
            moving_object: Some(MovingObject::following(1, 0..3, 0.5)),
            ..SimConfig::default()
        },
        SimConfig {
            drive: DriveConfig {
                max_speed: -1.0,
                ..DriveConfig::default()
            },
            ..SimConfig::default()
        },
        SimConfig {
            scene: SceneConfig {
                facade_range: (10.0, 5.0),
                ..SceneConfig::default()
            },
            ..SimConfig::default()
        },
    ];
    for cfg in cases {
        let e = simulate(&cfg).unwrap_err();
        assert!(
            e.to_string().starts_with("invalid simulation config: "),
            "{e}"
        );
    }
    // Edge cases that are valid: one frame, no matches, everything an outlier.
    let one = simulate(&SimConfig {
        frames: 1,
        ..SimConfig::default()
    })
    .unwrap();
    assert_eq!(one.sequence.num_frames(), 1);
    let none = simulate(&SimConfig {
        frames: 3,
        matches_per_camera: 0,
        ..SimConfig::default()
    })
    .unwrap();
    assert_eq!(none.sequence.num_matches(), 0);
    let all = simulate(&SimConfig {
        frames: 3,
        outlier_ratio: 1.0,
        ..SimConfig::default()
    })
    .unwrap();
    assert!(all.labels[1][0].iter().all(|l| *l == MatchLabel::Outlier));
}

/// `labels.csv` has one row per row of `matches.csv`, in the same order (same frame and
/// camera), and each row is the simulator's label of that match; a multi-camera rig with an
/// outlier-blinded camera and outliers gives every kind of label.
#[test]
fn labels_csv_matches_matches_csv_row_for_row() {
    use momo_sim::labels::{LABELS_FILE, labels_csv, write_labels_csv};
    let traffic = SimConfig {
        frames: 12,
        seed: 3,
        ..SimConfig::scenario("moving_traffic").unwrap()
    };
    let rig = SimConfig {
        frames: 12,
        seed: 4,
        outlier_ratio: 0.2,
        blinded: vec![Blinding {
            camera: 1,
            frames: 3..6,
            mode: BlindMode::Outliers,
        }],
        ..SimConfig::fisheye_surround()
    };
    let mut seen = std::collections::BTreeSet::new();
    let mut kinds = std::collections::BTreeSet::new();
    for cfg in [traffic, rig] {
        let sim = simulate(&cfg).unwrap();
        let dir = tempfile::tempdir().unwrap();
        sim.write(dir.path()).unwrap();
        write_labels_csv(dir.path(), &sim).unwrap();
        let labels = std::fs::read_to_string(dir.path().join(LABELS_FILE)).unwrap();
        assert_eq!(labels, labels_csv(&sim));
        let matches = std::fs::read_to_string(dir.path().join("matches.csv")).unwrap();
        let mut m = matches.lines();
        let mut l = labels.lines();
        assert_eq!(l.next(), Some("frame,camera,label,object,object_kind"));
        let header: Vec<&str> = m.next().unwrap().split(',').collect();
        let (fi, ci) = (
            header.iter().position(|h| *h == "frame").unwrap(),
            header.iter().position(|h| *h == "camera").unwrap(),
        );
        let truth: Vec<(usize, usize, MatchLabel)> = sim
            .labels
            .iter()
            .enumerate()
            .flat_map(|(k, f)| {
                f.iter()
                    .enumerate()
                    .flat_map(move |(j, c)| c.iter().map(move |x| (k, j, *x)))
            })
            .collect();
        let mut rows = 0;
        for ((mrow, lrow), (k, j, label)) in m.by_ref().zip(l.by_ref()).zip(&truth) {
            let mf: Vec<&str> = mrow.split(',').collect();
            let lf: Vec<&str> = lrow.split(',').collect();
            assert_eq!((mf[fi], mf[ci]), (lf[0], lf[1]), "row {rows}");
            assert_eq!(
                (lf[0], lf[1]),
                (k.to_string().as_str(), j.to_string().as_str())
            );
            assert_eq!(lf[2], label.name());
            assert_eq!(lf.len(), 5, "row {rows}");
            // The object columns: filled exactly on the traffic's moving-object matches (this
            // traffic scenario has no scripted object), with the object's index and kind.
            if lf[3].is_empty() {
                assert!(lf[4].is_empty(), "row {rows}");
                assert!(*label != MatchLabel::MovingObject || sim.object_kinds.is_empty());
            } else {
                assert_eq!(*label, MatchLabel::MovingObject, "row {rows}");
                let o: usize = lf[3].parse().unwrap();
                assert_eq!(lf[4], sim.object_kinds[o]);
                assert!(sim.objects[*k][*j].iter().flatten().any(|x| *x == o));
                kinds.insert(lf[4].to_string());
            }
            seen.insert(lf[2].to_string());
            rows += 1;
        }
        assert_eq!((m.next(), l.next()), (None, None), "same number of rows");
        assert_eq!(rows, truth.len());
        assert_eq!(rows, sim.sequence.num_matches());
    }
    let all: std::collections::BTreeSet<String> = ["blinded", "inlier", "moving_object", "outlier"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(seen, all);
    assert!(!kinds.is_empty(), "the traffic scenario names its objects");
}

/// The static matches of frame pair `k` that continue one of pair `k-1`: the same pixel in the
/// shared frame `k-1` (noise included, bit for bit) and the same scene point; and how many
/// static matches pair `k` has. Camera `j`.
fn continued(sim: &Simulation, k: usize, j: usize) -> (usize, usize) {
    let statics = |k: usize| {
        sim.sequence.frames[k].per_camera[j]
            .iter()
            .zip(&sim.labels[k][j])
            .zip(&sim.static_points[k][j])
            .filter(|((_, l), _)| **l == MatchLabel::Inlier)
            .map(|((o, _), x)| (o.px0, o.px1, x.unwrap()))
            .collect::<Vec<_>>()
    };
    let (prev, now) = (statics(k - 1), statics(k));
    let c = sim.camera_motion(k - 1, j).inverse();
    let n = now
        .iter()
        .filter(|(px0, _, x0)| {
            prev.iter().any(|(_, px1, xp)| {
                px1 == px0 && (c.transform_point(xp) - x0).norm() < 1e-9 * (1.0 + x0.norm())
            })
        })
        .count();
    (n, now.len())
}

/// `static_tracks`: that share of the static matches continues the previous pair's (less
/// where points leave the view or go behind a vehicle); at 0 none does. Objects' matches and
/// the share of each kind are unchanged.
#[test]
fn static_tracks_continue_the_previous_pairs_static_points() {
    for (name, cfg) in [
        ("clean_pinhole", SimConfig::clean_pinhole()),
        ("moving_traffic", SimConfig::moving_traffic()),
        ("fisheye_surround", SimConfig::fisheye_surround()),
    ] {
        let base = SimConfig { frames: 40, ..cfg };
        let plain = simulate(&base).unwrap();
        let tracked = simulate(&SimConfig {
            static_tracks: 0.8,
            ..base.clone()
        })
        .unwrap();
        let share = |sim: &Simulation| {
            let (mut n, mut total) = (0, 0);
            for k in 2..base.frames {
                for j in 0..sim.sequence.rig.len() {
                    let (a, b) = continued(sim, k, j);
                    n += a;
                    total += b;
                }
            }
            n as f64 / total as f64
        };
        let (s0, s8) = (share(&plain), share(&tracked));
        eprintln!("{name}: continued static share {s0:.3} without tracks, {s8:.3} at 0.8");
        assert!(s0 < 0.01, "{name}: {s0}");
        assert!(s8 > 0.6 && s8 < 0.85, "{name}: {s8}");
        // The same drive, the same traffic, as many matches of each label (up to the few
        // draws that fail to land in the image, which depend on the random stream).
        assert_eq!(plain.sequence.ground_truth, tracked.sequence.ground_truth);
        for l in [
            MatchLabel::Inlier,
            MatchLabel::MovingObject,
            MatchLabel::Outlier,
        ] {
            let count = |sim: &Simulation| {
                sim.labels
                    .iter()
                    .flatten()
                    .flatten()
                    .filter(|x| **x == l)
                    .count() as f64
            };
            let (a, b) = (count(&plain), count(&tracked));
            assert!(
                (a - b).abs() <= 0.01 * a.max(100.0),
                "{name} {l:?}: {a} / {b}"
            );
        }
    }
}

//! Accuracy and per-stage timings of the front end on the real KITTI snippets (06 and 01,
//! frames 0-50), without building the CLI:
//!
//! ```text
//! frontend_eval accuracy DATA_DIR OUT_DIR [KEY=VALUE...]   momo vo, mono and stereo, scored
//! frontend_eval timing   DATA_DIR [KEY=VALUE...]           decode / extract / match per frame
//! ```
//!
//! `DATA_DIR` holds `kitti_stereo_snippets/`. `KEY=VALUE` set matcher options:
//! `matches`, `refine` (none | klt), `patch` (KLT half-width), `iterations`, `max_shift`, `fb`
//! (forward-backward threshold, pixels; 0 = off), `converged` (KLT step that ends the iteration), `subpixel` (true | false), `uniqueness`,
//! `prior` (none | U,V: the flow prior's margin),
//! `candidates`, `nms`, `threshold`, `threads` (accuracy only). Accuracy: the
//! frame-to-frame rotation error of camera 0 against `poses.txt` (as `momo eval`), median /
//! p95 / max / count above 1 degree, and the front end's ms per frame as `momo vo` reports it.
//! Timing: one thread, mean CPU ms per frame and stage
//! (the thread's CPU time, so that waiting for the shared cores does not count) over the 50
//! frame pairs of each snippet, mono (image_0) and stereo (image_0 + image_1); environment
//! `MOMO_FRONTEND_FRAMES=N` times the first N frames only (for `valgrind --tool=callgrind`).
//! Extraction is `FrameFeatures::extract_owned`, as in `FrameMatcher::push_owned` (the
//! pipeline's): the features keep the decoded image's buffer; the copy of the decoded image
//! that each frame gives away stands for decoding and is not timed.
//!
//! Usage: `cargo run --release -p momo-match --example frontend_eval -- accuracy ../shared/data
//! /tmp/frontend`.

use momo_core::{Pose, so3_log};
use momo_match::kitti::{arc_lengths_from_poses, kitti_image_rig, read_kitti_projections};
use momo_match::{
    FlowPrior, FrameFeatures, FrontEndOptions, GrayImage, MatchError, MatchOptions, VoRun,
    match_features, match_features_with_prior, vo_from_images,
};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// CPU seconds of this thread (`/proc/thread-self/schedstat`: nanoseconds on a CPU), so that
/// time spent waiting for the shared cores does not count.
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .map_or(f64::NAN, |ns| 1e-9 * ns as f64)
}

const SNIPPETS: [&str; 2] = ["06", "01"];

fn snippet_dir(data: &Path, s: &str) -> PathBuf {
    data.join(format!(
        "kitti_stereo_snippets/kitti{s}_frames000000-000050"
    ))
}

fn parse_options(args: &[String]) -> Result<MatchOptions, String> {
    let mut o = MatchOptions::default();
    for a in args {
        let (k, v) = a
            .split_once('=')
            .ok_or_else(|| format!("expected KEY=VALUE, found {a}"))?;
        let bad = |e: &dyn std::fmt::Display| format!("{k}: {e}");
        match k {
            "matches" => o.matches_per_frame = v.parse().map_err(|e| bad(&e))?,
            "subpixel" => o.subpixel = v.parse().map_err(|e| bad(&e))?,
            "uniqueness" => o.uniqueness = v.parse().map_err(|e| bad(&e))?,
            "candidates" => o.candidates_per_cell = v.parse().map_err(|e| bad(&e))?,
            "nms" => o.detector.nms_radius = v.parse().map_err(|e| bad(&e))?,
            "threshold" => o.detector.threshold = v.parse().map_err(|e| bad(&e))?,
            "refine" => match v {
                "klt" => o.klt = Some(o.klt.unwrap_or_default()),
                "none" => o.klt = None,
                _ => return Err(format!("refine: klt or none, found {v}")),
            },
            "patch" => {
                o.klt.get_or_insert_with(Default::default).half = v.parse().map_err(|e| bad(&e))?
            }
            "iterations" => {
                o.klt.get_or_insert_with(Default::default).iterations =
                    v.parse().map_err(|e| bad(&e))?
            }
            "max_shift" => {
                o.klt.get_or_insert_with(Default::default).max_shift =
                    v.parse().map_err(|e| bad(&e))?
            }
            "converged" => {
                o.klt.get_or_insert_with(Default::default).converged =
                    v.parse().map_err(|e| bad(&e))?
            }
            "fb" => {
                o.klt.get_or_insert_with(Default::default).fb_threshold =
                    v.parse().map_err(|e| bad(&e))?
            }
            "threads" => o.threads = v.parse().map_err(|e| bad(&e))?,
            "prior" => {
                o.prior_margin = if v == "none" {
                    None
                } else {
                    let (a, b) = v
                        .split_once(',')
                        .ok_or_else(|| format!("prior: none or U,V, found {v}"))?;
                    Some([
                        a.parse().map_err(|e| bad(&e))?,
                        b.parse().map_err(|e| bad(&e))?,
                    ])
                }
            }
            _ => return Err(format!("unknown option {k}")),
        }
    }
    Ok(o)
}

fn rotation_errors(gt: &[Pose<f64>], est: &[Pose<f64>]) -> Vec<f64> {
    let n = gt.len().min(est.len());
    (1..n)
        .map(|k| {
            let g = gt[k - 1].inverse().compose(&gt[k]);
            let e = est[k - 1].inverse().compose(&est[k]);
            so3_log(&(g.rotation.transpose() * e.rotation))
                .norm()
                .to_degrees()
        })
        .collect()
}

fn summary(errors: &[f64]) -> (f64, f64, f64, usize) {
    let mut v = errors.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let median = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    let p95 = v[((0.95 * n as f64).ceil() as usize).clamp(1, n) - 1];
    (
        median,
        p95,
        v[n - 1],
        v.iter().filter(|&&e| e > 1.0).count(),
    )
}

fn accuracy(data: &Path, out: &Path, options: MatchOptions) -> Result<(), MatchError> {
    let io = |p: &Path, e| momo_io::IoError::io(p, e);
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    println!("seq rig     median    p95    max  >1deg  ms/frame  matches/pair");
    for s in SNIPPETS {
        let dir = snippet_dir(data, s);
        let calib_path = dir.join("calib.txt");
        let calib = read_kitti_projections(&calib_path)?;
        let img = momo_match::load_gray(&dir.join("image_0/000000.png"))?;
        let gt = momo_io::read_poses(dir.join("poses.txt"))?;
        let odometry = out.join(format!("odometry_{s}.csv"));
        momo_io::write_odometry(
            &odometry,
            &arc_lengths_from_poses(&gt, &momo_io::kitti::kitti_mount()),
        )?;
        for stereo in [false, true] {
            let name = if stereo { "stereo" } else { "mono" };
            let rig = kitti_image_rig(&calib, img.width(), img.height(), stereo, &calib_path)?;
            let rig_path = out.join(format!("rig_{s}_{name}.json"));
            momo_io::write_rig(&rig_path, &rig)?;
            let mut folders = vec![dir.join("image_0")];
            if stereo {
                folders.push(dir.join("image_1"));
            }
            let output = out.join(format!("est_{s}_{name}.txt"));
            let run = VoRun {
                folders,
                rig: rig_path,
                odometry: Some(odometry.clone()),
                output: output.clone(),
                diagnostics: None,
                estimator: momo_vo::EstimatorKind::Momo,
            };
            let front = FrontEndOptions {
                matching: options,
                gamma: None,
            };
            let sum = vo_from_images(&run, momo_vo::Config::default(), &front, |_| {})?;
            let est = momo_io::read_poses(&output)?;
            let (med, p95, max, gross) = summary(&rotation_errors(&gt, &est));
            let pairs = sum.front_end.frames.saturating_sub(1).max(1);
            println!(
                "{s}  {name:6} {med:7.4} {p95:7.4} {max:6.3} {gross:5} {:9.2} {:8.1}",
                sum.front_end.match_ms_per_frame(),
                sum.front_end.matches as f64 / pairs as f64 / if stereo { 2.0 } else { 1.0 },
            );
        }
    }
    Ok(())
}

fn timing(data: &Path, options: MatchOptions) -> Result<(), MatchError> {
    println!(
        "threads {}: mean ms per frame (decode, extract = detect + describe + index, match)",
        rayon::current_num_threads()
    );
    // `MOMO_FRONTEND_FRAMES=N`: the first N frames of each snippet only (instruction counts
    // under callgrind).
    let frame_limit = std::env::var("MOMO_FRONTEND_FRAMES")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .unwrap_or(usize::MAX)
        .max(2);
    for s in SNIPPETS {
        let dir = snippet_dir(data, s);
        let mut cams: Vec<Vec<GrayImage>> = Vec::new();
        let mut decode = 0.0;
        for cam in ["image_0", "image_1"] {
            let seq = momo_match::ImageSequence::open(&[dir.join(cam)])?;
            let mut imgs = Vec::new();
            for k in 0..seq.len().min(frame_limit) {
                let t = cpu_seconds();
                imgs.extend(seq.load(k, None)?);
                decode += cpu_seconds() - t;
            }
            cams.push(imgs);
        }
        let frames = cams[0].len();
        let decode_ms = 1e3 * decode / (2 * frames) as f64;
        for ncam in [1usize, 2] {
            let mut prev: Vec<FrameFeatures> = vec![FrameFeatures::default(); ncam];
            let mut cur: Vec<FrameFeatures> = vec![FrameFeatures::default(); ncam];
            let (mut t_extract, mut t_match, mut matches) = (0.0, 0.0, 0usize);
            let mut priors: Vec<Option<FlowPrior>> = vec![None; ncam];
            // Two passes: the first warms caches and allocations, the second is timed.
            for pass in 0..2 {
                for k in 0..frames {
                    // As `FrameMatcher::push_owned` (the pipeline's): the features keep the
                    // decoded image's buffer. The copy here stands for decoding, which gives a
                    // new buffer each frame, and is not timed.
                    let imgs: Vec<GrayImage> = (0..ncam).map(|j| cams[j][k].clone()).collect();
                    let t0 = cpu_seconds();
                    for (j, img) in imgs.into_iter().enumerate() {
                        cur[j].extract_owned(img, &options.detector);
                    }
                    let t1 = cpu_seconds();
                    if k > 0 {
                        // As `FrameMatcher::push`: the flow prior of the last pair, the full
                        // window when it finds too few.
                        for j in 0..ncam {
                            let mut m = match_features_with_prior(
                                &prev[j],
                                &cur[j],
                                &options,
                                priors[j].as_ref(),
                            );
                            if priors[j].is_some()
                                && m.len() < options.matches_per_frame.div_ceil(2)
                            {
                                m = match_features(&prev[j], &cur[j], &options);
                            }
                            matches += m.len();
                            priors[j] = options.prior_margin.map(|margin| {
                                FlowPrior::from_matches(
                                    &m,
                                    (cur[j].width, cur[j].height),
                                    margin,
                                    [options.max_flow_u, options.max_flow_v],
                                )
                            });
                        }
                    }
                    let t2 = cpu_seconds();
                    std::mem::swap(&mut prev, &mut cur);
                    if pass == 1 {
                        t_extract += t1 - t0;
                        t_match += t2 - t1;
                    }
                }
                if pass == 0 {
                    matches = 0;
                }
                priors.iter_mut().for_each(|p| *p = None);
            }
            let n = frames as f64;
            println!(
                "{s} {:6} decode {:5.2}  extract {:5.2}  match {:5.2}  total (no decode) {:5.2}  matches/pair {:.0}",
                if ncam == 1 { "mono" } else { "stereo" },
                decode_ms * ncam as f64,
                1e3 * t_extract / n,
                1e3 * t_match / (n - 1.0),
                1e3 * (t_extract / n + t_match / (n - 1.0)),
                matches as f64 / (n - 1.0) / ncam as f64,
            );
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("accuracy") if args.len() >= 3 => parse_options(&args[3..])
            .map_err(MatchError::Option)
            .and_then(|o| accuracy(Path::new(&args[1]), Path::new(&args[2]), o)),
        Some("timing") if args.len() >= 2 => parse_options(&args[2..])
            .map_err(MatchError::Option)
            .and_then(|o| {
                // The whole run on the pool's one worker thread, so that its CPU time counts
                // every stage.
                rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .build()
                    .map_err(|e| MatchError::Option(e.to_string()))?
                    .install(|| timing(Path::new(&args[1]), o))
            }),
        _ => {
            eprintln!(
                "usage: frontend_eval accuracy DATA_DIR OUT_DIR [KEY=VALUE...] | timing DATA_DIR [KEY=VALUE...]"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("frontend_eval: error: {e}");
            ExitCode::from(2)
        }
    }
}

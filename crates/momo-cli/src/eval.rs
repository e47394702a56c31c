//! `momo eval`.

use crate::common::Failure;
use momo_core::Pose;
use momo_eval::{Delta, Report};
use momo_io::{Trajectory, TrajectoryFormat};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The file formats `--format` accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum FormatArg {
    /// Detect from the first data line: 12 numbers KITTI, 8 TUM.
    Auto,
    /// KITTI: 12 numbers per line (the first three rows of the 4x4 pose).
    Kitti,
    /// TUM: `timestamp tx ty tz qx qy qz qw` per line.
    Tum,
}

impl FormatArg {
    /// The format to force, `None` to detect.
    pub(crate) fn forced(self) -> Option<TrajectoryFormat> {
        match self {
            FormatArg::Auto => None,
            FormatArg::Kitti => Some(TrajectoryFormat::Kitti),
            FormatArg::Tum => Some(TrajectoryFormat::Tum),
        }
    }
}

/// The unit of `--delta`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum DeltaUnitArg {
    /// Frames.
    F,
    /// Metres of path.
    M,
}

/// The arguments of `momo eval`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  momo eval --gt seq/poses.txt --est est.txt --per-frame errors.csv\n  \
    (ATE after SE(3)/Sim(3) alignment and RPE at 1 frame, as evo_ape -a/-as and evo_rpe)"
)]
pub(crate) struct EvalArgs {
    /// Ground-truth poses (KITTI or TUM format, camera 0).
    #[arg(long)]
    gt: PathBuf,
    /// Estimated poses (KITTI or TUM; KITTI needs as many lines as the ground truth, TUM is
    /// associated by timestamp within 0.01 s as evo does); repeat for several.
    #[arg(long = "est", required = true)]
    est: Vec<PathBuf>,
    /// Format of the pose files.
    #[arg(long, value_enum, default_value = "auto")]
    format: FormatArg,
    /// RPE frame-pair distance (in `--delta-unit`).
    #[arg(long, default_value_t = 1.0)]
    delta: f64,
    /// Unit of `--delta`: frames (f) or metres (m) of path.
    #[arg(long, value_enum, default_value = "f")]
    delta_unit: DeltaUnitArg,
    /// With `--delta-unit m`: measure the path on the ground truth (evo's
    /// `--pairs_from_reference`) instead of the estimate (evo's default).
    #[arg(long)]
    pairs_from_gt: bool,
    /// Write the per-frame errors (ATE after SE(3) and Sim(3) alignment, RPE of the pair ending
    /// at the frame, frame-to-frame rotation) as CSV to this file.
    #[arg(long, value_name = "FILE")]
    per_frame: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Accepted for symmetry with the other commands (eval prints only its result).
    #[arg(short, long)]
    quiet: bool,
}

/// The scores of one estimate (`momo eval --json`).
#[derive(serde::Serialize)]
struct EvalRow {
    path: PathBuf,
    /// Frames compared (after timestamp association).
    frames: usize,
    #[serde(flatten)]
    scores: momo_eval::Evaluation,
    ate_se3: Option<AteJson>,
    ate_sim3: Option<AteJson>,
    rpe: Option<RpeJson>,
    kitti_per_length: Option<Vec<(f64, f64, f64, usize)>>,
    kitti_per_speed: Option<Vec<(f64, f64, f64, usize)>>,
}

#[derive(serde::Serialize)]
struct AteJson {
    stats: momo_eval::Stats,
    transform: momo_eval::Similarity,
}

#[derive(serde::Serialize)]
struct RpeJson {
    delta: Delta,
    translation: momo_eval::Stats,
    rotation_deg: momo_eval::Stats,
}

/// Pairs the poses of two timestamped trajectories: for each stamp of the shorter, the
/// nearest of the longer within `max_diff` seconds (evo's `associate_trajectories`).
fn associate(t_gt: &[f64], t_est: &[f64], max_diff: f64) -> Vec<(usize, usize)> {
    let nearest = |stamps: &[f64], t: f64| -> Option<usize> {
        let i = stamps.partition_point(|&s| s < t);
        [i.checked_sub(1), (i < stamps.len()).then_some(i)]
            .into_iter()
            .flatten()
            .min_by(|&a, &b| (stamps[a] - t).abs().total_cmp(&(stamps[b] - t).abs()))
            .filter(|&j| (stamps[j] - t).abs() <= max_diff)
    };
    if t_est.len() <= t_gt.len() {
        (0..t_est.len())
            .filter_map(|e| nearest(t_gt, t_est[e]).map(|g| (g, e)))
            .collect()
    } else {
        (0..t_gt.len())
            .filter_map(|g| nearest(t_est, t_gt[g]).map(|e| (g, e)))
            .collect()
    }
}

/// The ground-truth and estimated poses compared, frame by frame, with the ground truth's
/// frame index and timestamp of each.
struct Paired {
    gt: Vec<Pose<f64>>,
    est: Vec<Pose<f64>>,
    frames: Vec<usize>,
    stamps: Option<Vec<f64>>,
}

fn pair(gt_path: &Path, gt: &Trajectory, path: &Path, est: &Trajectory) -> Result<Paired, Failure> {
    if let (Some(tg), Some(te)) = (&gt.timestamps, &est.timestamps)
        && (tg.len() != te.len() || tg.iter().zip(te).any(|(a, b)| (a - b).abs() > 0.01))
    {
        let pairs = associate(tg, te, 0.01);
        if pairs.len() < 2 {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: {} pose(s) share a timestamp (within 0.01 s) with the ground truth {}; at least 2 are needed",
                path.display(),
                pairs.len(),
                gt_path.display()
            )));
        }
        return Ok(Paired {
            gt: pairs.iter().map(|&(g, _)| gt.poses[g]).collect(),
            est: pairs.iter().map(|&(_, e)| est.poses[e]).collect(),
            frames: pairs.iter().map(|&(g, _)| g).collect(),
            stamps: Some(pairs.iter().map(|&(g, _)| tg[g]).collect()),
        });
    }
    if est.poses.len() != gt.poses.len() {
        return Err(Failure::Input(anyhow::anyhow!(
            "{}: {} poses, but the ground truth {} has {} (give both with timestamps, TUM, to associate them)",
            path.display(),
            est.poses.len(),
            gt_path.display(),
            gt.poses.len()
        )));
    }
    Ok(Paired {
        gt: gt.poses.clone(),
        est: est.poses.clone(),
        frames: (0..gt.poses.len()).collect(),
        stamps: gt.timestamps.clone().or_else(|| est.timestamps.clone()),
    })
}

/// Appends one estimate's per-frame rows to `csv`.
fn per_frame_rows(csv: &mut String, path: &Path, p: &Paired, report: &Report) {
    let n = p.gt.len();
    let mut rpe_t = vec![None; n];
    let mut rpe_r = vec![None; n];
    if let Some(r) = &report.rpe {
        for (k, &(_, j)) in r.pairs.iter().enumerate() {
            rpe_t[j] = Some(r.translation_errors[k]);
            rpe_r[j] = Some(r.rotation_errors_deg[k]);
        }
    }
    let f2f = momo_eval::frame_to_frame_rotation_errors(&p.gt, &p.est);
    let num = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for k in 0..n {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{}",
            path.display(),
            p.frames[k],
            num(p.stamps.as_ref().map(|s| s[k])),
            num(report.ate_se3.as_ref().map(|a| a.errors[k])),
            num(report.ate_sim3.as_ref().map(|a| a.errors[k])),
            num(rpe_t[k]),
            num(rpe_r[k]),
            num(k.checked_sub(1).map(|i| f2f[i])),
        );
    }
}

/// `momo eval`.
pub(crate) fn eval(args: EvalArgs) -> Result<(), Failure> {
    let gt_path = &args.gt;
    let format = args.format.forced();
    let delta = match args.delta_unit {
        DeltaUnitArg::F if args.delta >= 1.0 && args.delta.fract() == 0.0 => {
            Delta::Frames(args.delta as usize)
        }
        DeltaUnitArg::M if args.delta > 0.0 && args.delta.is_finite() => Delta::Metres {
            metres: args.delta,
            from_ground_truth: args.pairs_from_gt,
        },
        _ => {
            return Err(Failure::Input(anyhow::anyhow!(
                "--delta {}: expected a whole number of frames >= 1 (--delta-unit f) or a positive distance (--delta-unit m)",
                args.delta
            )));
        }
    };
    let ground_truth = momo_io::read_trajectory(gt_path, format).map_err(Failure::input)?;
    if ground_truth.poses.len() < 2 {
        return Err(Failure::Input(anyhow::anyhow!(
            "{}: {} pose(s); scoring needs at least 2 (one frame pair)",
            gt_path.display(),
            ground_truth.poses.len()
        )));
    }
    // bound.csv beside the ground truth (FORMAT.md version 3): the Cramér-Rao bound per frame.
    let bound_path = gt_path.with_file_name("bound.csv");
    let bounds = match std::fs::read_to_string(&bound_path) {
        Ok(text) => Some(momo_eval::parse_bound_csv(&text).map_err(|e| {
            Failure::Input(anyhow::anyhow!(
                "{}:{}: {}",
                bound_path.display(),
                e.line,
                e.reason
            ))
        })?),
        Err(_) => None,
    };
    let mut rows = Vec::with_capacity(args.est.len());
    let mut csv = String::from(
        "estimate,frame,timestamp,ate_se3_m,ate_sim3_m,rpe_translation_m,rpe_rotation_deg,f2f_rotation_deg\n",
    );
    for path in &args.est {
        let est = momo_io::read_trajectory(path, format).map_err(Failure::input)?;
        let p = pair(gt_path, &ground_truth, path, &est)?;
        let report = momo_eval::report(&p.gt, &p.est, delta);
        if args.per_frame.is_some() {
            per_frame_rows(&mut csv, path, &p, &report);
        }
        rows.push(EvalRow {
            path: path.clone(),
            frames: p.gt.len(),
            scores: {
                let (bound_deg, efficiency) = bounds.as_ref().map_or((None, None), |b| {
                    let e = momo_eval::evaluate_with_bound(&p.gt, &p.est, b);
                    (e.bound_deg, e.efficiency)
                });
                momo_eval::Evaluation {
                    t_err_percent: report.kitti.as_ref().map(|k| k.t_err_percent),
                    r_err_deg_per_100m: report.kitti.as_ref().map(|k| k.r_err_deg_per_100m),
                    rotation_deg: report.rotation_deg,
                    bound_deg,
                    efficiency,
                }
            },
            ate_se3: report.ate_se3.as_ref().map(|a| AteJson {
                stats: a.stats,
                transform: a.transform,
            }),
            ate_sim3: report.ate_sim3.as_ref().map(|a| AteJson {
                stats: a.stats,
                transform: a.transform,
            }),
            rpe: report.rpe.as_ref().map(|r| RpeJson {
                delta: r.delta,
                translation: r.translation,
                rotation_deg: r.rotation_deg,
            }),
            kitti_per_length: report.kitti.as_ref().map(|k| k.per_length.clone()),
            kitti_per_speed: report.kitti.as_ref().map(|k| k.per_speed.clone()),
        });
    }
    if let Some(out) = &args.per_frame {
        std::fs::write(out, csv)
            .map_err(|e| Failure::other(anyhow::anyhow!("{}: {e}", out.display())))?;
    }
    if args.json {
        let doc = serde_json::json!({
            "ground_truth": gt_path,
            "frames": ground_truth.poses.len(),
            "estimates": rows,
        });
        outln!("{doc}");
        return Ok(());
    }
    let unit = match delta {
        Delta::Frames(d) => format!("{d} frame(s)"),
        Delta::Metres { metres, .. } => format!("{metres} m"),
    };
    outln!(
        "{} frames; frame-to-frame rotation errors in degrees; KITTI devkit t_err in %, r_err in deg/100 m (\"-\": path shorter than 100 m); ATE RMSE in m after SE(3)/Sim(3) alignment; RPE RMSE at {unit} in m and deg",
        ground_truth.poses.len()
    );
    outln!(
        "{:>8} {:>8} {:>8} {:>8} {:>8} {:>5} {:>9} {:>9} {:>9} {:>9}{}  estimate",
        "t_err",
        "r_err",
        "median",
        "p95",
        "max",
        ">1deg",
        "ate_se3",
        "ate_sim3",
        "rpe_t",
        "rpe_r",
        if bounds.is_some() {
            format!(" {:>8} {:>6}", "bound", "eff")
        } else {
            String::new()
        }
    );
    for row in &rows {
        let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
        let fmt4 = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.4}"));
        let (t, r) = (
            fmt(row.scores.t_err_percent),
            fmt(row.scores.r_err_deg_per_100m),
        );
        let s = &row.scores.rotation_deg;
        outln!(
            "{t:>8} {r:>8} {:>8.4} {:>8.4} {:>8.4} {:>5} {:>9} {:>9} {:>9} {:>9}{}  {}",
            s.median,
            s.p95,
            s.max,
            s.above_one,
            fmt4(row.ate_se3.as_ref().map(|a| a.stats.rmse)),
            fmt4(row.ate_sim3.as_ref().map(|a| a.stats.rmse)),
            fmt4(row.rpe.as_ref().map(|r| r.translation.rmse)),
            fmt4(row.rpe.as_ref().map(|r| r.rotation_deg.rmse)),
            if bounds.is_some() {
                format!(
                    " {:>8} {:>6}",
                    fmt4(row.scores.bound_deg),
                    row.scores
                        .efficiency
                        .map_or("-".to_string(), |v| format!("{v:.2}"))
                )
            } else {
                String::new()
            },
            row.path.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::associate;

    #[test]
    fn association_takes_the_nearest_stamp_within_the_limit() {
        let gt = [0.0, 0.1, 0.2, 0.3, 0.4];
        let est = [0.005, 0.199, 0.35, 0.41];
        assert_eq!(associate(&gt, &est, 0.01), vec![(0, 0), (2, 1), (4, 3)]);
    }
}

//! `momo eval`.

use crate::common::Failure;
use std::path::PathBuf;

/// The arguments of `momo eval`.
#[derive(clap::Args, Debug)]
pub(crate) struct EvalArgs {
    /// Ground-truth poses (KITTI format).
    #[arg(long)]
    gt: PathBuf,
    /// Estimated poses (KITTI format, as many lines as the ground truth); repeat for several.
    #[arg(long = "est", required = true)]
    est: Vec<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// The scores of one estimate (`momo eval --json`).
#[derive(serde::Serialize)]
struct EvalRow {
    path: PathBuf,
    #[serde(flatten)]
    scores: momo_eval::Evaluation,
}

/// `momo eval`.
pub(crate) fn eval(args: EvalArgs) -> Result<(), Failure> {
    let gt = &args.gt;
    let ground_truth = momo_io::read_poses(gt).map_err(Failure::input)?;
    if ground_truth.len() < 2 {
        return Err(Failure::Input(anyhow::anyhow!(
            "{}: {} pose(s); scoring needs at least 2 (one frame pair)",
            gt.display(),
            ground_truth.len()
        )));
    }
    let mut rows = Vec::with_capacity(args.est.len());
    for path in &args.est {
        let est = momo_io::read_poses(path).map_err(Failure::input)?;
        if est.len() != ground_truth.len() {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: {} poses, but the ground truth {} has {}",
                path.display(),
                est.len(),
                gt.display(),
                ground_truth.len()
            )));
        }
        rows.push(EvalRow {
            path: path.clone(),
            scores: momo_eval::evaluate(&ground_truth, &est),
        });
    }
    if args.json {
        let doc = serde_json::json!({
            "ground_truth": gt,
            "frames": ground_truth.len(),
            "estimates": rows,
        });
        outln!("{doc}");
        return Ok(());
    }
    outln!(
        "{} frames; frame-to-frame rotation errors in degrees; KITTI devkit t_err in %, r_err in deg/100 m (\"-\": path shorter than 100 m)",
        ground_truth.len()
    );
    outln!(
        "{:>8} {:>8} {:>8} {:>8} {:>8} {:>5}  estimate",
        "t_err",
        "r_err",
        "median",
        "p95",
        "max",
        ">1deg"
    );
    for row in &rows {
        let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
        let (t, r) = (
            fmt(row.scores.t_err_percent),
            fmt(row.scores.r_err_deg_per_100m),
        );
        let s = &row.scores.rotation_deg;
        outln!(
            "{t:>8} {r:>8} {:>8.4} {:>8.4} {:>8.4} {:>5}  {}",
            s.median,
            s.p95,
            s.max,
            s.above_one,
            row.path.display()
        );
    }
    Ok(())
}

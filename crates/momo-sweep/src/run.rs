//! Running jobs: sequences loaded once, sub-sampled once per match count, jobs in parallel on a
//! rayon pool, each job caught (errors and panics become rows).

use crate::error::SweepError;
use crate::grid::{Grid, MatchCount};
use crate::plan::{Job, Plan, Shard};
use crate::results::{Row, Status};
use indicatif::{ProgressBar, ProgressStyle};
use momo_core::{FrameObservations, SolveRequest};
use momo_io::Sequence;
use momo_vo::{EstimatorKind, FrameStatus};
use rayon::prelude::*;
use std::collections::HashMap;
use std::io::IsTerminal;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// How to run a sweep.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Run only this slice of the jobs.
    pub shard: Option<Shard>,
    /// Worker threads (default: one per core).
    pub threads: Option<usize>,
    /// No progress bar.
    pub quiet: bool,
}

/// The name of a sequence directory (its last path component).
pub fn sequence_name(dir: &Path) -> String {
    dir.file_name().map_or_else(
        || dir.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Reads a sequence directory for a sweep: it must have ground truth (`poses.txt`) with one
/// pose per frame; with `max_frames` only the first frames are kept.
pub fn load_sequence(dir: &Path, max_frames: Option<usize>) -> Result<Sequence, SweepError> {
    let mut seq = momo_io::read_sequence(dir).map_err(SweepError::Sequence)?;
    let gt_path = dir.join(momo_io::files::POSES);
    let Some(gt) = &seq.ground_truth else {
        return Err(SweepError::Input(format!(
            "{}: missing (a sweep scores every run against the ground truth)",
            gt_path.display()
        )));
    };
    if gt.len() < seq.num_frames() {
        return Err(SweepError::Input(format!(
            "{}: {} poses, but the sequence has {} frames",
            gt_path.display(),
            gt.len(),
            seq.num_frames()
        )));
    }
    let n = max_frames.unwrap_or(usize::MAX).min(seq.num_frames());
    seq.frames.truncate(n);
    if let Some(a) = seq.arc_lengths.as_mut() {
        a.truncate(n);
    }
    if let Some(g) = seq.ground_truth.as_mut() {
        g.truncate(n);
    }
    Ok(seq)
}

/// The sequence with at most `matches` matches per frame pair and camera
/// ([`momo_io::kitti::subsample_frame`]).
pub fn subsample(seq: &Sequence, matches: MatchCount, seed: u64) -> Sequence {
    let MatchCount::AtMost(n) = matches else {
        return seq.clone();
    };
    Sequence {
        rig: seq.rig.clone(),
        frames: seq
            .frames
            .iter()
            .enumerate()
            .map(|(k, f)| momo_io::kitti::subsample_frame(f, &seq.rig, n, seed, k))
            .collect(),
        arc_lengths: seq.arc_lengths.clone(),
        ground_truth: seq.ground_truth.clone(),
    }
}

/// The message of a caught panic.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "panic without a message".into()
    }
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Fails if the metric cannot work with a camera that has matches (`geo_line` on a fisheye):
/// the driver would report every frame pair as a solver failure instead.
fn check_cameras(config: &momo_vo::Config, seq: &Sequence) -> Result<(), String> {
    let est = config
        .model
        .build(config.metric.as_ref())
        .map_err(|e| e.to_string())?;
    let mut probe = FrameObservations::new(seq.rig.len());
    for frame in &seq.frames {
        for (list, probe) in frame.per_camera.iter().zip(probe.per_camera.iter_mut()) {
            if let (Some(o), true) = (list.first(), probe.is_empty()) {
                probe.push(*o);
            }
        }
    }
    let init = est.initial_params(1.0);
    let fixed = vec![true; init.len()];
    let request = SolveRequest {
        rig: &seq.rig,
        observations: &probe,
        loss: config.loss.as_ref(),
        solver: config.solver.as_ref(),
        initial: &init,
        fixed: &fixed,
        rotation_only: false,
        motion_prior: None,
    };
    est.cost(&request, &init)
        .map(drop)
        .map_err(|e| e.to_string())
}

/// Runs one job on a prepared sequence; never fails (errors and panics become the row's).
pub fn run_job(plan: &Plan, job: Job, seq: &Sequence) -> Row {
    let combo = &plan.combinations[job.combination];
    let mut row = Row {
        grid_id: plan.grid_id.clone(),
        job: job.index,
        jobs_total: plan.jobs(),
        sequence: plan.sequences[job.sequence].clone(),
        combination: combo.label(),
        model: combo.model.clone(),
        metric: combo.metric.clone(),
        loss: combo.loss.clone(),
        loss_scale: combo.loss_scale,
        solver: combo.solver.clone(),
        matches: combo.matches.to_string(),
        is_default: plan.default_combination == Some(job.combination),
        status: Status::Ok,
        error: String::new(),
        frames: seq.num_frames(),
        estimated: 0,
        standstill: 0,
        no_matches: 0,
        solver_failures: 0,
        restarts_won: 0,
        mean_iterations: None,
        inlier_ratio: None,
        rot_mean_deg: None,
        rot_median_deg: None,
        rot_p95_deg: None,
        rot_max_deg: None,
        above_1deg: None,
        t_err_percent: None,
        r_err_deg_per_100m: None,
        us_per_frame: None,
        wall_us_per_frame: None,
    };
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        let config = combo.build_config().map_err(|e| e.to_string())?;
        check_cameras(&config, seq)?;
        let started = Instant::now();
        let (poses, diags) = momo_vo::run_in_memory(seq, EstimatorKind::Momo, config, |_| {})
            .map_err(|e| e.to_string())?;
        let wall = started.elapsed().as_secs_f64();
        Ok::<_, String>((poses, diags, wall))
    }));
    let (poses, diags, wall) = match outcome {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => {
            row.status = Status::Error;
            row.error = e;
            return row;
        }
        Err(payload) => {
            row.status = Status::Panic;
            row.error = panic_message(payload.as_ref());
            return row;
        }
    };
    let pairs = diags.len().max(1) as f64;
    let (mut matches, mut inliers, mut iterations, mut micros) = (0usize, 0usize, 0usize, 0.0);
    for d in &diags {
        match d.status {
            // Weak frames kept their (flagged) estimate; degenerate ones held the previous
            // motion like a solver failure.
            FrameStatus::Estimated | FrameStatus::Weak => row.estimated += 1,
            FrameStatus::Standstill => row.standstill += 1,
            FrameStatus::NoMatches => row.no_matches += 1,
            FrameStatus::SolverFailure | FrameStatus::Degenerate => row.solver_failures += 1,
        }
        row.restarts_won += usize::from(d.restart_won);
        matches += d.matches;
        inliers += d.inliers;
        iterations += d.iterations;
        micros += d.time_us;
    }
    row.mean_iterations = Some(iterations as f64 / pairs);
    row.inlier_ratio = (matches > 0).then(|| inliers as f64 / matches as f64);
    row.us_per_frame = finite(micros / pairs);
    row.wall_us_per_frame = finite(wall * 1e6 / pairs);
    if let Some(gt) = &seq.ground_truth {
        let n = poses.len().min(gt.len());
        let e = momo_eval::evaluate(&gt[..n], &poses[..n]);
        let r = &e.rotation_deg;
        row.rot_mean_deg = finite(r.mean);
        row.rot_median_deg = finite(r.median);
        row.rot_p95_deg = finite(r.p95);
        row.rot_max_deg = finite(r.max);
        row.above_1deg = Some(r.above_one);
        row.t_err_percent = e.t_err_percent.and_then(finite);
        row.r_err_deg_per_100m = e.r_err_deg_per_100m.and_then(finite);
    }
    row
}

fn progress_bar(quiet: bool, len: usize) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    ProgressBar::new(len as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} jobs {per_sec} eta {eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    )
}

/// Runs `jobs` of `plan` on in-memory sequences (`sequences[i]` is `plan.sequences[i]`, as
/// [`load_sequence`] returns it) in parallel; rows come back in job order.
pub fn run_jobs(
    grid: &Grid,
    plan: &Plan,
    sequences: &[Sequence],
    jobs: &[Job],
    options: &RunOptions,
) -> Result<Vec<Row>, SweepError> {
    if sequences.len() != plan.sequences.len() {
        return Err(SweepError::Input(format!(
            "{} sequences for a plan of {}",
            sequences.len(),
            plan.sequences.len()
        )));
    }
    // Every (sequence, match count) the jobs need, sub-sampled once.
    let mut prepared: HashMap<(usize, MatchCount), Arc<Sequence>> = HashMap::new();
    for job in jobs {
        let key = (job.sequence, plan.combinations[job.combination].matches);
        prepared
            .entry(key)
            .or_insert_with(|| Arc::new(subsample(&sequences[key.0], key.1, grid.seed)));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.unwrap_or(0))
        .build()
        .map_err(|e| SweepError::Threads(e.to_string()))?;
    let bar = progress_bar(options.quiet, jobs.len());
    let rows = pool.install(|| {
        jobs.par_iter()
            .map(|job| {
                let key = (job.sequence, plan.combinations[job.combination].matches);
                let row = match prepared.get(&key) {
                    Some(seq) => run_job(plan, *job, seq),
                    None => run_job(plan, *job, &sequences[job.sequence]),
                };
                bar.inc(1);
                row
            })
            .collect::<Vec<_>>()
    });
    bar.finish_and_clear();
    Ok(rows)
}

/// Loads the sequence directories and runs the grid (or one shard of it). Returns the plan and
/// the rows of the jobs that ran, in job order.
pub fn run_sweep(
    grid: &Grid,
    sequence_dirs: &[PathBuf],
    options: &RunOptions,
) -> Result<(Plan, Vec<Row>), SweepError> {
    let names: Vec<String> = sequence_dirs.iter().map(|d| sequence_name(d)).collect();
    let plan = Plan::new(grid, &names)?;
    let jobs = plan.jobs_of(options.shard);
    let sequences = sequence_dirs
        .iter()
        .map(|d| load_sequence(d, grid.max_frames))
        .collect::<Result<Vec<_>, _>>()?;
    let rows = run_jobs(grid, &plan, &sequences, &jobs, options)?;
    Ok((plan, rows))
}

//! `momo simulate`.

use crate::common::Failure;
use std::path::PathBuf;

/// The arguments of `momo simulate`.
#[derive(clap::Args, Debug)]
pub(crate) struct SimulateArgs {
    /// Scenario: clean_pinhole, outliers (30 %, 1 px), moving_object, moving_traffic,
    /// moving_traffic_surround (the fisheye rig with traffic all around),
    /// moving_traffic_surround_blind (the same, front camera covered, then glare on the right
    /// one), fisheye_surround,
    /// sparse_outliers (100 matches, 30 %), very_sparse (40 matches), highway (25-30 m/s),
    /// radtan_mono (OpenCV distortion), wide_angle_surround (double sphere and unified).
    #[arg(long, default_value = "clean_pinhole")]
    scenario: String,
    /// Drive along the camera-0 poses of this KITTI poses file (e.g. a KITTI ground truth)
    /// instead of a generated drive; the vehicle poses are P0 · C_k · P0⁻¹ with P0 the KITTI
    /// mono camera's mount (a level forward camera: every scenario's vehicle drives level,
    /// the surround rigs' tilted front cameras included); the ground truth is the scenario
    /// rig's camera 0. At most --frames frames.
    #[arg(long)]
    trajectory: Option<PathBuf>,
    /// With --trajectory: start at this pose of the file (0-based), moved to the origin
    /// (C_k' = C_N⁻¹ · C_{N+k}; the simulator levels every drive at its first pose): a segment
    /// of a long trajectory, e.g. a stop at a junction.
    #[arg(long, default_value_t = 0, requires = "trajectory")]
    trajectory_start: usize,
    /// With --trajectory: turn every pose about the camera's x axis by the trajectory's median
    /// travel elevation first, so that the vehicle travels along its road (a real camera looks
    /// a little off its travel: the KITTI one about 1° down; driven as it is, the simulated
    /// vehicle travels that far above its own road plane). Prints the angle.
    #[arg(long, requires = "trajectory")]
    trajectory_along_travel: bool,
    /// Number of frames.
    #[arg(long, default_value_t = 400)]
    frames: usize,
    /// Random seed (the output is deterministic for a seed).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Matches per camera and frame pair (default: the scenario's).
    #[arg(long)]
    matches: Option<usize>,
    /// Standard deviation of the Gaussian noise on every match's pixels (default: the
    /// scenario's, e.g. 0.5 for clean_pinhole, 1 for outliers and moving_traffic); bound.csv
    /// is the bound at this noise.
    #[arg(long)]
    pixel_noise: Option<f64>,
    /// The share (0 to 1) of each frame pair's static matches that continue a static match of
    /// the previous pair (the same scene point and the same pixel in the shared frame), as a
    /// feature tracker (KLT) gives them. Default 0: every static match is a new point.
    #[arg(long, default_value_t = 0.0)]
    static_tracks: f64,
    /// Output directory (created; an existing one must be empty unless --force; removed
    /// again on failure if this created it).
    out_dir: PathBuf,
    /// No summary on stderr.
    #[arg(short, long)]
    quiet: bool,
    /// Write into an existing, non-empty output directory (its files of the same names are
    /// replaced).
    #[arg(long)]
    force: bool,
}

/// `momo simulate`.
pub(crate) fn simulate(args: SimulateArgs) -> Result<(), Failure> {
    use momo_sim::SimConfig;
    let scenario = &args.scenario;
    let Some(mut cfg) = SimConfig::scenario(scenario) else {
        return Err(Failure::Input(anyhow::anyhow!(
            "unknown scenario `{scenario}` ({})",
            SimConfig::SCENARIOS.join(", ")
        )));
    };
    if let Some(path) = &args.trajectory {
        let poses = momo_io::read_poses(path).map_err(Failure::input)?;
        if poses.is_empty() {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: no poses",
                path.display()
            )));
        }
        let start = args.trajectory_start;
        if start + 1 >= poses.len() {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: --trajectory-start {start} leaves fewer than two of its {} poses",
                path.display(),
                poses.len()
            )));
        }
        let origin = poses[start].inverse();
        let mut trajectory: Vec<_> = poses[start..]
            .iter()
            .map(|p| {
                // The product of two rotations read to the file's precision drifts from
                // orthonormal by twice theirs: the nearest rotation keeps the written
                // ground truth within the readers' tolerance.
                origin.compose(p).orthonormalized()
            })
            .collect();
        if args.trajectory_along_travel {
            let (turned, theta) = momo_sim::along_travel(&trajectory);
            trajectory = turned.iter().map(|p| p.orthonormalized()).collect();
            if !args.quiet {
                note!(
                    "momo simulate: the trajectory turned by its travel elevation, {:+.3} deg",
                    theta.to_degrees()
                );
            }
        }
        cfg.camera_trajectory = Some(trajectory);
    }
    cfg.frames = args.frames;
    cfg.seed = args.seed;
    if let Some(m) = args.matches {
        cfg.matches_per_camera = m;
    }
    if let Some(sigma) = args.pixel_noise {
        cfg.pixel_noise = sigma;
    }
    cfg.static_tracks = args.static_tracks;
    let sim = momo_sim::simulate(&cfg).map_err(Failure::input)?;
    if std::fs::metadata(&args.out_dir).is_ok() {
        let written = crate::common::sequence_files(&args.out_dir);
        let written: Vec<&std::path::Path> = written.iter().map(PathBuf::as_path).collect();
        let inputs: Vec<&std::path::Path> = args.trajectory.as_deref().into_iter().collect();
        crate::common::check_outputs(&inputs, &written)?;
    }
    let dir = momo_io::OutputDir::prepare(&args.out_dir, args.force).map_err(Failure::input)?;
    sim.write(&args.out_dir).map_err(Failure::other)?;
    // bound.csv (FORMAT.md version 3): the Cramér-Rao bound of every frame pair's rotation.
    let bounds = momo_sim::bound::rotation_bounds(&sim, cfg.pixel_noise);
    momo_sim::bound::write_bound_csv(&args.out_dir, &sim, &bounds).map_err(Failure::other)?;
    // labels.csv (FORMAT.md versions 6-7): the true label (and traffic object) of every match, row for row.
    momo_sim::labels::write_labels_csv(&args.out_dir, &sim).map_err(Failure::other)?;
    if !args.quiet {
        let seq = &sim.sequence;
        note!(
            "momo: simulated `{scenario}` (seed {}): {} frames, {} camera(s), {} matches, with ground truth; wrote {}",
            args.seed,
            seq.num_frames(),
            seq.rig.len(),
            seq.num_matches(),
            args.out_dir.display()
        );
    }
    dir.keep();
    Ok(())
}

//! Test data shared by `hostile.rs` and `trust.rs`: a deterministic random source, matches
//! of a rig under a motion, simple drives and rotation errors.
#![allow(dead_code)] // each test module uses its own part

use momo_core::{
    Camera, CameraModel, FrameObservations, Observation, Pose, Rig, camera_motion, so3_log,
};
use nalgebra::{Vector2, Vector3};

/// SplitMix64 with uniform and Gaussian draws: deterministic test data without dependencies.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }

    pub fn gauss(&mut self) -> f64 {
        let u = self.uniform(1e-12, 1.0);
        let v = self.uniform(0.0, std::f64::consts::TAU);
        (-2.0 * u.ln()).sqrt() * v.cos()
    }
}

/// Matches of camera `j` of `rig` under the vehicle motion `motion`, as a reader delivers them:
/// a bearing drawn by `bearing` (camera frame k-1) at a depth in `depth`, projected into both
/// frames, both pixels inside the image and within `accept`, Gaussian pixel noise `noise`,
/// bearings unprojected from the noisy pixels.
pub fn matches(
    rig: &Rig,
    j: usize,
    motion: &Pose<f64>,
    n: usize,
    noise: f64,
    rng: &mut Rng,
    mut bearing: impl FnMut(&mut Rng) -> Vector3<f64>,
    depth: (f64, f64),
    accept: impl Fn(&Vector2<f64>) -> bool,
) -> Vec<Observation> {
    let cam = &rig.cameras()[j];
    let model = cam.model;
    let c = camera_motion(motion, &cam.t_vehicle_camera);
    let mut out = Vec::with_capacity(n);
    for _ in 0..200 * n {
        if out.len() == n {
            break;
        }
        let x0 = bearing(rng).normalize() * rng.uniform(depth.0, depth.1);
        let x1 = c.inverse().transform_point(&x0);
        let (Some(p0), Some(p1)) = (model.project(&x0), model.project(&x1)) else {
            continue;
        };
        if x1.norm() < 0.5 || !(model.contains(&p0, 0.0) && model.contains(&p1, 0.0)) {
            continue;
        }
        if !(accept(&p0) && accept(&p1)) {
            continue;
        }
        let p0 = p0 + Vector2::new(rng.gauss(), rng.gauss()) * noise;
        let p1 = p1 + Vector2::new(rng.gauss(), rng.gauss()) * noise;
        if let Some(o) = Observation::new(&model, p0, p1) {
            out.push(o);
        }
    }
    assert_eq!(out.len(), n, "the scene allows {n} matches");
    out
}

/// A bearing through a uniformly drawn pixel of `model`.
pub fn through_pixel(model: Camera) -> impl FnMut(&mut Rng) -> Vector3<f64> {
    move |rng| {
        let (w, h) = model.size();
        let px = Vector2::new(rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0));
        model.unproject(&px).unwrap_or_else(Vector3::z)
    }
}

pub fn anywhere(_: &Vector2<f64>) -> bool {
    true
}

/// Matches spread over the whole image of every camera.
pub fn frame(
    rig: &Rig,
    motion: &Pose<f64>,
    n: usize,
    noise: f64,
    rng: &mut Rng,
) -> FrameObservations {
    let mut obs = FrameObservations::new(rig.len());
    for j in 0..rig.len() {
        let model = rig.cameras()[j].model;
        obs.per_camera[j] = matches(
            rig,
            j,
            motion,
            n,
            noise,
            rng,
            through_pixel(model),
            (4.0, 40.0),
            anywhere,
        );
    }
    obs
}

/// A planar vehicle motion: yaw and arc length (the single-track model).
pub fn drive(yaw: f64, l: f64) -> Pose<f64> {
    use momo_core::Manifold;
    momo_models::SingleTrack2d.motion(&[yaw, l])
}

pub fn rot_err_deg(a: &Pose<f64>, b: &Pose<f64>) -> f64 {
    so3_log(&(a.rotation.transpose() * b.rotation))
        .norm()
        .to_degrees()
}

/// The frame-to-frame rotation error (deg) and the diagnostics of the odometry with `config`
/// over a simulated sequence (every frame pair after the first frame, in order).
pub fn errors_and_diagnostics(
    sim: &momo_sim::Simulation,
    config: momo_vo::Config,
) -> Vec<(f64, momo_vo::FrameDiagnostics)> {
    first_errors_and_diagnostics(sim, config, sim.sequence.num_frames() - 1)
}

/// [`errors_and_diagnostics`] over the first `pairs` frame pairs only (a prefix of a longer
/// simulation, whose traffic depends on its length).
pub fn first_errors_and_diagnostics(
    sim: &momo_sim::Simulation,
    config: momo_vo::Config,
    pairs: usize,
) -> Vec<(f64, momo_vo::FrameDiagnostics)> {
    let seq = &sim.sequence;
    let mut vo = momo_vo::Odometry::new(seq.rig.clone(), config).expect("valid config");
    (1..=pairs.min(seq.num_frames() - 1))
        .map(|k| {
            let arc = seq.arc_lengths.as_ref().and_then(|a| a[k]);
            let r = vo.process(&seq.frames[k], arc);
            (
                rot_err_deg(&r.motion, &sim.vehicle_motions[k]),
                r.diagnostics,
            )
        })
        .collect()
}

/// The frame-to-frame rotation errors (deg) of the odometry with `config` over a simulated
/// sequence (every frame pair after the first frame, in order).
pub fn rotation_errors(sim: &momo_sim::Simulation, config: momo_vo::Config) -> Vec<f64> {
    errors_and_diagnostics(sim, config)
        .into_iter()
        .map(|(e, _)| e)
        .collect()
}

/// The median frame-to-frame rotation error (deg) of the odometry with `config` over a
/// simulated sequence (every frame pair after the first frame).
pub fn median_rotation_error(sim: &momo_sim::Simulation, config: momo_vo::Config) -> f64 {
    median(&rotation_errors(sim, config))
}

/// The median of `values` (the upper one of an even count).
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The sixteenth session's defaults as a configuration file, with `separate` (lines of
/// `[odometry.separate]`, each ending in a newline) added: the seventeenth session's default
/// changes (`soft_prior_conflict_widening`, `ground_drop`, `ground_admit_own_share`,
/// `hypotheses.track_decay`) and the thirty-ninth's (`yaw_votes`; `hypotheses.yaw_history_final`
/// is off in a written hypotheses section) off, for tests whose claim was measured against
/// those defaults.
pub fn sixteenth_session_defaults(separate: &str) -> String {
    let mut s =
        String::from("[odometry]\nsoft_prior_conflict_widening = 0.0\n[odometry.separate]\n");
    for (key, line) in [
        ("ground_drop", "ground_drop = 0.0\n"),
        ("ground_admit_own_share", "ground_admit_own_share = 0.0\n"),
        ("yaw_votes", "yaw_votes = 0\n"),
        // The one-camera under-the-road test (default since the sixty-fourth session) off.
        ("under_road =", "under_road = 0.0\n"),
    ] {
        if !separate.contains(key) {
            s.push_str(line);
        }
    }
    s.push_str(separate);
    s.push_str("[odometry.separate.hypotheses]\nspread_grid = [16, 8]\ntrack_decay = 0.0\n");
    // The neighbourhood test on one camera (default since the forty-second session) off.
    s.push_str("[odometry.final_fit]\nneighbour_min_cameras = 2\n");
    s
}

/// The shared data folder: `$MOMO_DATA`, else `../shared/data` beside the repository.
pub fn data_dir() -> std::path::PathBuf {
    std::env::var_os("MOMO_DATA")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
        })
}

/// The scenario `scenario` along the ground truth of KITTI sequence `seq` (as `momo simulate
/// --trajectory` reads it: the whole trajectory moved to its first pose), `frames` frames,
/// seed `seed`, `pixel_noise` px. `None`, with a message, where the shared data is absent.
pub fn along_kitti(
    seq: &str,
    frames: usize,
    seed: u64,
    pixel_noise: f64,
    scenario: momo_sim::SimConfig,
) -> Option<momo_sim::Simulation> {
    let path = data_dir().join(format!("kitti_odometry_gt/poses/{seq}.txt"));
    if !path.exists() {
        eprintln!("SKIPPED: {} not found (set MOMO_DATA)", path.display());
        return None;
    }
    let poses = momo_io::read_poses(&path).expect("readable");
    let origin = poses[0].inverse();
    let trajectory = poses
        .iter()
        .map(|p| origin.compose(p).orthonormalized())
        .collect();
    let sim = momo_sim::simulate(&momo_sim::SimConfig {
        frames,
        seed,
        pixel_noise,
        camera_trajectory: Some(trajectory),
        ..scenario
    });
    Some(sim.expect("simulated"))
}

/// The `[odometry.separate.hypotheses]` options of `config` (`None` without them).
pub fn hypotheses_of(config: &momo_vo::Config) -> Option<&momo_vo::hypotheses::HypothesesOptions> {
    config
        .odometry
        .separate
        .as_ref()
        .and_then(|s| s.hypotheses.as_ref())
}

/// `Config::default()` with its `[odometry.separate.hypotheses]` options changed by `change`.
pub fn default_with_hypotheses(
    change: impl FnOnce(&mut momo_vo::hypotheses::HypothesesOptions),
) -> momo_vo::Config {
    let mut config = momo_vo::Config::default();
    if let Some(h) = config
        .odometry
        .separate
        .as_mut()
        .and_then(|s| s.hypotheses.as_mut())
    {
        change(h);
    }
    config
}

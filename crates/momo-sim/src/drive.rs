//! Vehicle drives: smooth speed and curvature profiles integrated with single-track kinematics.
//!
//! The drive is a sequence of manoeuvres (3 to 12 s each): a target speed in
//! `[min_cruise_speed, max_speed]` (or, with stops, a stop held for `stop_duration`) and a
//! target curvature (straight, or a curve of radius 15 to 300 m). Acceleration follows the
//! target speed with limited acceleration, deceleration and jerk; curvature follows its target at
//! a limited rate and is capped so that the yaw rate stays below `max_yaw_rate` and the lateral
//! acceleration below `max_lateral_acceleration`.
//!
//! Per step `dt = 1 / frame_rate` the motion centre moves along a circular arc of length
//! `s = (v_{k-1} + v_k) dt / 2` and turns by `Δψ = κ s` (the single-track model, translation
//! `(s sin Δψ/Δψ, s (1 - cos Δψ)/Δψ)` in the plane), optionally with a side-slip angle
//! `β = side_slip · v² κ` added to the direction of travel. The body pitches and rolls by at
//! most `pitch_roll_amplitude` with a phase driven by the distance travelled (road
//! unevenness), so that a standing vehicle does not move at all. The motion centre stays in the
//! plane z = 0. The vehicle pose is `[Rz(ψ) Ry(pitch) Rx(roll) | (x, y, 0)]`; frame 0 is the
//! identity.

use momo_core::{Pose, cosc, sinc};
use nalgebra::{Matrix3, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Parameters of the drive generator.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveConfig {
    /// Frames per second (10 Hz like KITTI).
    pub frame_rate: f64,
    /// Speed at frame 0, m/s.
    pub initial_speed: f64,
    /// Lowest target speed of a non-stop manoeuvre, m/s.
    pub min_cruise_speed: f64,
    /// Highest target speed, m/s.
    pub max_speed: f64,
    /// Largest acceleration, m/s².
    pub max_acceleration: f64,
    /// Largest deceleration (positive), m/s².
    pub max_deceleration: f64,
    /// Largest change of acceleration, m/s³.
    pub max_jerk: f64,
    /// Largest yaw rate, rad/s.
    pub max_yaw_rate: f64,
    /// Largest lateral acceleration `v² κ`, m/s².
    pub max_lateral_acceleration: f64,
    /// Largest rate of change of curvature, 1/(m s).
    pub curvature_rate: f64,
    /// How long a stop is held, seconds (min, max).
    pub stop_duration: (f64, f64),
    /// Probability that a manoeuvre is a stop when stops are enabled.
    pub stop_probability: f64,
    /// Amplitude of the pitch and roll oscillations, radians (0.5° by default).
    pub pitch_roll_amplitude: f64,
    /// Side-slip angle per unit lateral acceleration, rad per m/s² (0: no slip, the pure
    /// single-track model; 0.003 gives about 0.5° at 3 m/s²).
    pub side_slip: f64,
}

impl Default for DriveConfig {
    fn default() -> Self {
        Self {
            frame_rate: 10.0,
            initial_speed: 8.0,
            min_cruise_speed: 4.0,
            max_speed: 30.0,
            max_acceleration: 2.0,
            max_deceleration: 3.0,
            max_jerk: 2.0,
            max_yaw_rate: 0.3,
            max_lateral_acceleration: 3.0,
            curvature_rate: 0.02,
            stop_duration: (1.0, 4.0),
            stop_probability: 0.3,
            pitch_roll_amplitude: 0.5f64.to_radians(),
            side_slip: 0.0,
        }
    }
}

impl DriveConfig {
    /// Checks that every parameter is finite and in range; the message names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("frame_rate", self.frame_rate),
            ("max_speed", self.max_speed),
            ("max_acceleration", self.max_acceleration),
            ("max_deceleration", self.max_deceleration),
            ("max_jerk", self.max_jerk),
            ("max_yaw_rate", self.max_yaw_rate),
            ("max_lateral_acceleration", self.max_lateral_acceleration),
            ("curvature_rate", self.curvature_rate),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("drive.{name} must be a positive number, found {v}"));
            }
        }
        let non_negative = [
            ("initial_speed", self.initial_speed),
            ("min_cruise_speed", self.min_cruise_speed),
            ("stop_duration.0", self.stop_duration.0),
            ("pitch_roll_amplitude", self.pitch_roll_amplitude),
            ("side_slip", self.side_slip),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!(
                    "drive.{name} must be a non-negative number, found {v}"
                ));
            }
        }
        if self.initial_speed > self.max_speed || self.min_cruise_speed > self.max_speed {
            return Err(
                "drive.initial_speed and drive.min_cruise_speed must not exceed drive.max_speed"
                    .into(),
            );
        }
        if !(self.stop_duration.1.is_finite() && self.stop_duration.1 >= self.stop_duration.0) {
            return Err("drive.stop_duration must be (min, max) with min <= max".into());
        }
        if !(0.0..=1.0).contains(&self.stop_probability) {
            return Err("drive.stop_probability must be in [0, 1]".into());
        }
        if self.pitch_roll_amplitude > 0.2 {
            return Err("drive.pitch_roll_amplitude must be at most 0.2 rad".into());
        }
        Ok(())
    }
}

/// A generated drive, indexed by frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Drive {
    /// Vehicle poses in the world frame (x forward, y left, z up at frame 0); `poses[0]` is the
    /// identity.
    pub poses: Vec<Pose<f64>>,
    /// `arc_lengths[k]`: distance travelled by the motion centre from frame k-1 to k, metres
    /// (`arc_lengths[0] = 0`).
    pub arc_lengths: Vec<f64>,
    /// Speed at each frame, m/s.
    pub speeds: Vec<f64>,
}

impl Drive {
    /// The vehicle motion `T_{k-1,k} = V_{k-1}⁻¹ V_k` (identity for k = 0).
    pub fn motion(&self, k: usize) -> Pose<f64> {
        if k == 0 || k >= self.poses.len() {
            return Pose::identity();
        }
        self.poses[k - 1].inverse().compose(&self.poses[k])
    }
}

fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// The current manoeuvre.
struct Manoeuvre {
    target_speed: f64,
    target_curvature: f64,
    /// Remaining seconds (for a stop: counted only once standing).
    remaining: f64,
    stop: bool,
}

fn next_manoeuvre(cfg: &DriveConfig, stops: bool, rng: &mut StdRng) -> Manoeuvre {
    let stop = stops && rng.random_bool(cfg.stop_probability);
    let target_curvature = if stop || rng.random_bool(0.45) {
        0.0
    } else {
        // Radius log-uniform in [15, 300] m, either direction.
        let radius = (15f64.ln() + rng.random::<f64>() * (300f64 / 15.0).ln()).exp();
        if rng.random_bool(0.5) {
            1.0 / radius
        } else {
            -1.0 / radius
        }
    };
    let (target_speed, remaining) = if stop {
        let (a, b) = cfg.stop_duration;
        (0.0, a + rng.random::<f64>() * (b - a))
    } else {
        let lo = cfg.min_cruise_speed.min(cfg.max_speed);
        (
            lo + rng.random::<f64>() * (cfg.max_speed - lo),
            3.0 + 9.0 * rng.random::<f64>(),
        )
    };
    Manoeuvre {
        target_speed,
        target_curvature,
        remaining,
        stop,
    }
}

/// Generates `frames` vehicle poses (at least one) with the given seed. `stops` enables
/// standstill phases.
pub fn generate_drive(cfg: &DriveConfig, frames: usize, stops: bool, seed: u64) -> Drive {
    let mut rng = StdRng::seed_from_u64(seed);
    let dt = 1.0 / cfg.frame_rate;
    let n = frames.max(1);
    let mut poses = Vec::with_capacity(n);
    let mut arc_lengths = Vec::with_capacity(n);
    let mut speeds = Vec::with_capacity(n);
    poses.push(Pose::identity());
    arc_lengths.push(0.0);

    let mut v = cfg.initial_speed.min(cfg.max_speed);
    speeds.push(v);
    let mut a = 0.0;
    let mut kappa = 0.0;
    let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
    let mut m = next_manoeuvre(cfg, stops, &mut rng);
    // Body oscillation: two frequencies per axis (irregular), phases advancing with time scaled
    // by min(v / 5 m/s, 1), so that they freeze at standstill; all phases start at 0.
    let mut phase = 0.0;
    let (pitch_f1, pitch_f2, roll_f1, roll_f2) = (1.1, 2.3, 0.8, 1.9);
    let tau = std::f64::consts::TAU;

    for _ in 1..n {
        // Speed: jerk-limited acceleration towards a proportional command.
        let a_cmd = (0.6 * (m.target_speed - v)).clamp(-cfg.max_deceleration, cfg.max_acceleration);
        a += (a_cmd - a).clamp(-cfg.max_jerk * dt, cfg.max_jerk * dt);
        let v_prev = v;
        v += a * dt;
        if v <= 0.0 || (m.target_speed == 0.0 && v < 0.05 && a <= 0.0) {
            v = 0.0;
            a = 0.0;
        }
        v = v.min(cfg.max_speed);
        let s = 0.5 * (v_prev + v) * dt;

        // Curvature: rate-limited towards the target, capped by yaw rate and lateral acceleration.
        let v_cap = v.max(v_prev);
        let kappa_max = if v_cap > 0.0 {
            (cfg.max_yaw_rate / v_cap).min(cfg.max_lateral_acceleration / (v_cap * v_cap))
        } else {
            f64::INFINITY
        };
        let target = m.target_curvature.clamp(-kappa_max, kappa_max);
        kappa += (target - kappa).clamp(-cfg.curvature_rate * dt, cfg.curvature_rate * dt);
        kappa = kappa.clamp(-kappa_max, kappa_max);
        let dyaw = kappa * s;

        // Single-track arc (plus optional side slip), expressed in the world.
        let beta = cfg.side_slip * v * v * kappa;
        let step = Vector3::new(s * sinc(dyaw), s * cosc(dyaw), 0.0);
        let world_step = rz(yaw + beta) * step;
        x += world_step.x;
        y += world_step.y;
        yaw += dyaw;
        phase += dt * (0.5 * (v_prev + v) / 5.0).min(1.0);

        let amp = cfg.pitch_roll_amplitude;
        let pitch =
            amp * (0.7 * (tau * pitch_f1 * phase).sin() + 0.3 * (tau * pitch_f2 * phase).sin());
        let roll =
            amp * (0.7 * (tau * roll_f1 * phase).sin() + 0.3 * (tau * roll_f2 * phase).sin());
        poses.push(Pose::new(
            rz(yaw) * ry(pitch) * rx(roll),
            Vector3::new(x, y, 0.0),
        ));
        arc_lengths.push(s);
        speeds.push(v);

        // Manoeuvre bookkeeping: a stop's time runs only once the vehicle stands.
        if !m.stop || v == 0.0 {
            m.remaining -= dt;
        }
        if m.remaining <= 0.0 {
            m = next_manoeuvre(cfg, stops, &mut rng);
        }
    }
    Drive {
        poses,
        arc_lengths,
        speeds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_are_respected() {
        let cfg = DriveConfig::default();
        for seed in 0..5 {
            let d = generate_drive(&cfg, 3000, true, seed);
            assert_eq!(d.poses.len(), 3000);
            assert_eq!(d.poses[0], Pose::identity());
            let mut standstill = 0;
            for k in 1..3000 {
                let m = d.motion(k);
                let v = d.speeds[k];
                assert!((0.0..=30.0).contains(&v));
                let dt = 0.1;
                let acc = (d.speeds[k] - d.speeds[k - 1]) / dt;
                assert!((-3.0 - 1e-9..=2.0 + 1e-9).contains(&acc), "acc {acc}");
                let yaw_rate = m.rotation[(1, 0)].atan2(m.rotation[(0, 0)]) / dt;
                assert!(
                    yaw_rate.abs() <= 0.3 * 1.02 + 0.02,
                    "yaw rate {yaw_rate} at {v}"
                );
                let lat = yaw_rate.abs() * v;
                assert!(lat <= 3.0 * 1.1 + 0.2, "lateral {lat}");
                // The translation of the motion centre has the length of the chord, at most s.
                assert!(m.translation.norm() <= d.arc_lengths[k] + 1e-12);
                assert!(m.translation.norm() >= d.arc_lengths[k] * 0.99);
                if d.arc_lengths[k] == 0.0 {
                    standstill += 1;
                    assert!((m.to_homogeneous() - nalgebra::Matrix4::identity()).amax() < 1e-12);
                }
                let angle = m.rotation_angle();
                assert!(angle < 0.05, "{angle}");
            }
            assert!(standstill > 10, "stops happen (seed {seed}): {standstill}");
            let max_pitch = d
                .poses
                .iter()
                .map(|p| p.rotation[(2, 0)].abs().asin())
                .fold(0.0, f64::max);
            assert!(max_pitch <= 0.5f64.to_radians() + 1e-12);
            assert!(max_pitch > 0.1f64.to_radians());
        }
    }

    #[test]
    fn without_stops_the_vehicle_keeps_moving() {
        let d = generate_drive(&DriveConfig::default(), 2000, false, 3);
        assert!(d.arc_lengths[1..].iter().all(|&s| s > 0.0));
    }

    #[test]
    fn default_config_is_valid() {
        assert!(DriveConfig::default().validate().is_ok());
        let bad = DriveConfig {
            max_speed: f64::NAN,
            ..DriveConfig::default()
        };
        assert!(bad.validate().is_err());
    }
}

//! The soft manifold [`SoftSingleTrack`]: general motion with the single-track model as a prior.

use crate::Se3;
use momo_core::{Manifold, Pose, Scalar};
use serde::{Deserialize, Serialize};

/// General rigid motion ([`Se3`]'s parameters and motion) with the single-track model as a
/// *soft* constraint: instead of forcing the direction of travel onto the single-track chord
/// (as [`crate::SingleTrack3d`] does), two prior residuals penalise the deviation from it, each
/// with a standard deviation in radians:
///
/// - side slip: `(heading − rot_z / 2) / side_slip_sigma` (a planar circular arc that turns by
///   `γ` has its chord at `γ/2`);
/// - vertical slip: `(climb + rot_y / 2) / climb_sigma` (over a crest or dip the chord is
///   tilted by half the pitch change; `rot_y > 0` pitches the nose down).
///
/// Real cars slip sideways and bounce, and a camera mount is never exactly nominal: the hard
/// single-track models are biased on real motion (docs/RESULTS.md). A moving object that
/// holds half of the matches, on the other hand, pulls a free `Se3` estimate to a direction of
/// travel no car drives (several degrees of side slip); the prior holds it. With
/// `σ → ∞` this is [`Se3`], with `σ → 0` a single-track model. The odometry can centre the
/// two residuals on their running mean over the recent moving frames
/// (`odometry.soft_prior_centring_frames`), so that a constant slip (a mount turned a few
/// tenths of a degree) is learnt instead of pulled against, and can learn the two sigmas from
/// the data (`odometry.soft_prior_sigma_learning`, empirical Bayes, never below these: where
/// the true motion slips more, a prior at the model's sigma biases the rotation, e.g. along
/// the KITTI ground-truth trajectories, whose direction of travel jitters by 0.015-0.03 rad
/// per frame). Type tag `soft_single_track`:
///
/// ```toml
/// [model]
/// type = "soft_single_track"
/// side_slip_sigma = 0.01
/// climb_sigma = 0.01
/// ```
///
/// ```
/// use momo_core::Manifold;
/// use momo_models::{Se3, SoftSingleTrack};
///
/// let model = SoftSingleTrack::default();
/// // A single-track motion (heading = yaw / 2, climb = -pitch / 2) costs nothing ...
/// let mut q = [0.0; 2];
/// model.prior_residuals(&[0.0, 0.02, 0.1, 0.05, -0.01, 1.0], &mut q);
/// assert!(q.iter().all(|v| v.abs() < 1e-15));
/// // ... one degree of side slip costs (1° / σ)².
/// model.prior_residuals(&[0.0, 0.0, 0.1, 0.05 + 1f64.to_radians(), 0.0, 1.0], &mut q);
/// assert!((q[0] - 1f64.to_radians() / model.side_slip_sigma).abs() < 1e-12);
/// // The motion is Se3's.
/// let p = [0.01, 0.02, 0.1, 0.06, 0.0, 1.2];
/// assert_eq!(model.motion(&p), Se3.motion(&p));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields, try_from = "SoftSingleTrackFields")]
pub struct SoftSingleTrack {
    /// Standard deviation of the side slip (heading minus half the yaw), radians.
    pub side_slip_sigma: f64,
    /// Standard deviation of the vertical slip (climb plus half the pitch change), radians.
    pub climb_sigma: f64,
    /// Standard deviation of the slips as a sideways / vertical *displacement* over the frame
    /// pair, metres (0: none). It adds to each angle's variance as `(σ_d / s)²` with `s` the
    /// arc length, so that a short step may point anywhere a few centimetres allow: slow
    /// manoeuvres, the bounce of the body, and ground truth whose positions jitter by
    /// centimetres (KITTI's) all make the direction of a short step much noisier than the
    /// angle-only prior allows.
    pub slip_distance_sigma: f64,
    /// The same for the vertical slip alone, metres (0: `slip_distance_sigma`'s): the climb's
    /// variance becomes `σ_climb² + (σ_v / s)²` while the side slip keeps its own. At 0.2-0.5 m
    /// per frame a few centimetres of vertical jitter point the chord anywhere (KITTI 08's
    /// ground truth climbs by 0.4-1.5 rad there at a level body, docs/RESULTS.md §9,
    /// twenty-seventh session, rigclimb41), whereas a moving object pulls the side slip, where
    /// the prior protects the estimate.
    pub climb_distance_sigma: f64,
}

impl Default for SoftSingleTrack {
    /// σ = 0.01 rad (0.57°) for both: wide enough for a real car's slip and a camera mount a
    /// few tenths of a degree off nominal, narrow against the several degrees a moving object
    /// pulls the direction of travel by.
    fn default() -> Self {
        Self {
            side_slip_sigma: 0.01,
            climb_sigma: 0.01,
            slip_distance_sigma: 0.0,
            climb_distance_sigma: 0.0,
        }
    }
}

/// The fields as read, before the check that both standard deviations are positive.
#[derive(Deserialize)]
#[serde(default, deny_unknown_fields)]
struct SoftSingleTrackFields {
    side_slip_sigma: f64,
    climb_sigma: f64,
    slip_distance_sigma: f64,
    climb_distance_sigma: f64,
}

impl Default for SoftSingleTrackFields {
    fn default() -> Self {
        let d = SoftSingleTrack::default();
        Self {
            side_slip_sigma: d.side_slip_sigma,
            climb_sigma: d.climb_sigma,
            slip_distance_sigma: d.slip_distance_sigma,
            climb_distance_sigma: d.climb_distance_sigma,
        }
    }
}

impl TryFrom<SoftSingleTrackFields> for SoftSingleTrack {
    type Error = String;
    fn try_from(f: SoftSingleTrackFields) -> Result<Self, String> {
        for (name, v) in [
            ("side_slip_sigma", f.side_slip_sigma),
            ("climb_sigma", f.climb_sigma),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be finite and > 0, got {v}"));
            }
        }
        for (name, v) in [
            ("slip_distance_sigma", f.slip_distance_sigma),
            ("climb_distance_sigma", f.climb_distance_sigma),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name} must be finite and >= 0, got {v}"));
            }
        }
        Ok(Self {
            side_slip_sigma: f.side_slip_sigma,
            climb_sigma: f.climb_sigma,
            slip_distance_sigma: f.slip_distance_sigma,
            climb_distance_sigma: f.climb_distance_sigma,
        })
    }
}

impl Manifold for SoftSingleTrack {
    const PARAMS: &'static [&'static str] = Se3::PARAMS;
    const ARC_LENGTH: Option<usize> = Se3::ARC_LENGTH;
    const PRIOR_RESIDUALS: usize = 2;

    #[inline]
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        Se3.motion(p)
    }

    fn params_from_motion(&self, m: &Pose<f64>) -> Option<Vec<f64>> {
        Se3.params_from_motion(m)
    }

    #[inline]
    fn prior_residuals<T: Scalar>(&self, p: &[T], out: &mut [T]) {
        let (rot_y, rot_z, heading, climb) = (p[1], p[2], p[3], p[4]);
        let side = heading - rot_z * 0.5;
        let vertical = climb + rot_y * 0.5;
        if self.climb_distance_sigma > 0.0 {
            // Each residual `/ sqrt(σ² + (σ_d / s)²)` with its own distance sigma (the side
            // slip's may be 0: then its angle-only factor).
            let s = p[5].abs();
            let w = |sigma: f64, sigma_d: f64| {
                let d2 = T::c(sigma_d * sigma_d);
                s / (s * s * (sigma * sigma) + d2).sqrt()
            };
            out[0] = if self.slip_distance_sigma > 0.0 {
                side * w(self.side_slip_sigma, self.slip_distance_sigma)
            } else {
                side * (1.0 / self.side_slip_sigma)
            };
            out[1] = vertical * w(self.climb_sigma, self.climb_distance_sigma);
        } else if self.slip_distance_sigma > 0.0 {
            // 1 / sqrt(σ² + (σ_d / s)²) = |s| / sqrt(σ² s² + σ_d²): finite at s = 0.
            let s = p[5].abs();
            let d2 = T::c(self.slip_distance_sigma * self.slip_distance_sigma);
            let w = |sigma: f64| s / (s * s * (sigma * sigma) + d2).sqrt();
            out[0] = side * w(self.side_slip_sigma);
            out[1] = vertical * w(self.climb_sigma);
        } else {
            out[0] = side * (1.0 / self.side_slip_sigma);
            out[1] = vertical * (1.0 / self.climb_sigma);
        }
    }
}

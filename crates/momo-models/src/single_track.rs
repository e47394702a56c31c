//! The single-track (bicycle) models: planar motion on a circle, and the same on a tilted plane.

use crate::rotation::{arc_chord, arc_length_from_chord, rot_x, rot_y, rot_z};
use momo_core::{Manifold, Pose, Scalar};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// The planar single-track model (the paper's Eq. (motion_model)): the vehicle drives on a
/// circle of radius `r = l / γ` and turns by the yaw angle `γ`:
///
/// `M = [Rz(γ) | (l sin γ / γ, l (1 - cos γ) / γ, 0)]`.
///
/// Parameters `["yaw", "arc_length"]` (radians, metres; a negative arc length drives backwards).
/// `sin γ / γ` and `(1 - cos γ) / γ` are [`momo_core::sinc`] and [`momo_core::cosc`], exact in
/// value and derivative at `γ = 0` (straight driving). Type tag `single_track_2d`.
///
/// ```
/// use momo_core::Manifold;
/// use momo_models::SingleTrack2d;
///
/// let m = SingleTrack2d.motion(&[0.0, 1.5]); // straight ahead
/// assert_eq!(m.translation.x, 1.5);
/// let p = SingleTrack2d.params_from_motion(&SingleTrack2d.motion(&[0.1, 1.5])).unwrap();
/// assert!((p[0] - 0.1).abs() < 1e-12 && (p[1] - 1.5).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SingleTrack2d;

impl Manifold for SingleTrack2d {
    const PARAMS: &'static [&'static str] = &["yaw", "arc_length"];
    const ARC_LENGTH: Option<usize> = Some(1);

    #[inline]
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        Pose::new(rot_z(p[0]), arc_chord(p[0], p[1]))
    }

    /// Yaw from `atan2(R₁₀, R₀₀)`, arc length from the in-plane chord,
    /// `(t · (cos(γ/2), sin(γ/2), 0)) / sinc(γ/2)`. Out-of-plane parts of the motion are dropped.
    fn params_from_motion(&self, m: &Pose<f64>) -> Option<Vec<f64>> {
        let r = &m.rotation;
        let yaw = r[(1, 0)].atan2(r[(0, 0)]);
        Some(vec![yaw, arc_length_from_chord(yaw, &m.translation)])
    }
}

/// How [`SingleTrack3d`] moves the translation with the pitch and roll change.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TiltTranslation {
    /// `t = R_tilt · t₂d`: the chord lies in the plane tilted by the full pitch and roll change
    /// (the vehicle drives on the plane it stands on at frame k). The default.
    #[default]
    Tilted,
    /// `t = Ry(pitch/2) Rx(roll/2) · t₂d`: the chord is tilted by half the change, as for a
    /// vehicle whose pitch and roll change at a constant rate along the arc (to first order the
    /// chord of such a path points along the mean attitude, like the chord of the planar arc
    /// points along half the yaw).
    HalfTilted,
    /// `t = t₂d`: the translation stays in the plane of frame k-1, only the rotation is tilted
    /// (what the original C++ implementation did), for comparison.
    Planar,
}

/// The single-track model on a tilted plane (the paper's "2d model enhanced by pitch and roll
/// angles"): the planar circle motion of [`SingleTrack2d`] on a plane whose orientation relative
/// to the vehicle at frame k-1 is `R_tilt = Ry(pitch) · Rx(roll)`:
///
/// `M = [R_tilt · Rz(γ) | R_tilt · t₂d(γ, l)]`, `t₂d = (l sin γ / γ, l (1 - cos γ) / γ, 0)`.
///
/// Parameters `["yaw", "arc_length", "pitch", "roll"]`; `pitch` and `roll` are the *changes*
/// of the vehicle's pitch and roll between the frames (radians; positive pitch is nose down,
/// positive roll is right side down, rotations about the vehicle's y and x axes).
///
/// The original C++ code only rotated (`M = [R_tilt Rz(γ) | t₂d]`), leaving the translation
/// planar; that variant is available as `translation = "planar"` ([`TiltTranslation::Planar`]),
/// and [`TiltTranslation::HalfTilted`] tilts the chord by half the change. Type tag
/// `single_track_3d`; in a configuration: `type = "single_track_3d"`, optional
/// `translation = "tilted" | "half_tilted" | "planar"`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SingleTrack3d {
    /// How the translation follows the tilt (default: [`TiltTranslation::Tilted`]).
    #[serde(default)]
    pub translation: TiltTranslation,
}

impl SingleTrack3d {
    /// The model with the given translation variant.
    pub fn new(translation: TiltTranslation) -> Self {
        Self { translation }
    }

    /// The rotation applied to the planar chord.
    #[inline]
    fn chord_tilt<T: Scalar>(&self, pitch: T, roll: T) -> Matrix3<T> {
        match self.translation {
            TiltTranslation::Tilted => rot_y(pitch) * rot_x(roll),
            TiltTranslation::HalfTilted => rot_y(pitch * T::c(0.5)) * rot_x(roll * T::c(0.5)),
            TiltTranslation::Planar => Matrix3::identity(),
        }
    }
}

impl Manifold for SingleTrack3d {
    const PARAMS: &'static [&'static str] = &["yaw", "arc_length", "pitch", "roll"];
    const ARC_LENGTH: Option<usize> = Some(1);

    #[inline]
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        let (yaw, l, pitch, roll) = (p[0], p[1], p[2], p[3]);
        let tilt = rot_y(pitch) * rot_x(roll);
        Pose::new(
            tilt * rot_z(yaw),
            self.chord_tilt(pitch, roll) * arc_chord(yaw, l),
        )
    }

    /// Closed form for `|roll| < π/2`: with `R = Ry(pitch) Rx(roll) Rz(γ)`,
    /// `γ = atan2(R₁₀, R₁₁)`, `roll = atan2(-R₁₂, hypot(R₁₀, R₁₁))`, `pitch = atan2(R₀₂, R₂₂)`;
    /// the arc length from the chord un-tilted by the variant's tilt as in [`SingleTrack2d`].
    fn params_from_motion(&self, m: &Pose<f64>) -> Option<Vec<f64>> {
        let r = &m.rotation;
        let yaw = r[(1, 0)].atan2(r[(1, 1)]);
        let roll = (-r[(1, 2)]).atan2(r[(1, 0)].hypot(r[(1, 1)]));
        let pitch = r[(0, 2)].atan2(r[(2, 2)]);
        let t2d = self.chord_tilt(pitch, roll).transpose() * m.translation;
        Some(vec![yaw, arc_length_from_chord(yaw, &t2d), pitch, roll])
    }
}

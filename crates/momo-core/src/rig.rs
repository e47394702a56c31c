//! Camera rigs and the observations (matches) of one frame pair.

use crate::camera::{Camera, CameraModel};
use crate::error::CoreError;
use crate::lie::Pose;
use nalgebra::{Vector2, Vector3};

/// One camera of a rig: its model and its pose in the vehicle frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RigCamera {
    /// A name for messages (`"cam0"`).
    pub name: String,
    /// The projection model.
    pub model: Camera,
    /// `T_vehicle_camera` (`P_j`): maps camera coordinates to vehicle coordinates.
    pub t_vehicle_camera: Pose<f64>,
}

/// A rig: cameras rigidly mounted on the vehicle. Camera 0 is the reference camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    cameras: Vec<RigCamera>,
}

/// Tolerance on `RᵀR = I` and `det R = 1` for extrinsics (`FORMAT.md`).
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-6;

impl Rig {
    /// A rig from its cameras. Fails on an empty list or a non-orthonormal extrinsic rotation.
    pub fn new(cameras: Vec<RigCamera>) -> Result<Self, CoreError> {
        if cameras.is_empty() {
            return Err(CoreError::EmptyRig);
        }
        for (i, c) in cameras.iter().enumerate() {
            let e = c.t_vehicle_camera.orthonormality_error();
            if !(e <= ORTHONORMAL_TOLERANCE) {
                return Err(CoreError::NotOrthonormal {
                    camera: i,
                    error: e,
                });
            }
        }
        Ok(Self { cameras })
    }

    /// A one-camera rig.
    pub fn mono(model: Camera, t_vehicle_camera: Pose<f64>) -> Result<Self, CoreError> {
        Self::new(vec![RigCamera {
            name: "cam0".into(),
            model,
            t_vehicle_camera,
        }])
    }

    /// The cameras, indexed by camera id.
    pub fn cameras(&self) -> &[RigCamera] {
        &self.cameras
    }

    /// Number of cameras.
    pub fn len(&self) -> usize {
        self.cameras.len()
    }

    /// Always false: a rig has at least one camera.
    pub fn is_empty(&self) -> bool {
        self.cameras.is_empty()
    }

    /// Largest distance of a camera centre from the motion centre (vehicle origin), metres.
    /// Scale is observable from rotation only if this is non-zero (the paper, Sec. "Optimization on manifolds of the motion space").
    pub fn max_lever_arm(&self) -> f64 {
        self.cameras
            .iter()
            .map(|c| c.t_vehicle_camera.translation.norm())
            .fold(0.0, f64::max)
    }
}

/// One match: the pixels of a scene point in frames k-1 and k, and their unit bearing vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// Pixel in frame k-1.
    pub px0: Vector2<f64>,
    /// Pixel in frame k.
    pub px1: Vector2<f64>,
    /// Unit bearing in camera coordinates, frame k-1.
    pub f0: Vector3<f64>,
    /// Unit bearing in camera coordinates, frame k.
    pub f1: Vector3<f64>,
}

impl Observation {
    /// Unprojects both pixels through `camera`; `None` if either cannot be unprojected.
    pub fn new(camera: &Camera, px0: Vector2<f64>, px1: Vector2<f64>) -> Option<Self> {
        Some(Self {
            px0,
            px1,
            f0: camera.unproject(&px0)?,
            f1: camera.unproject(&px1)?,
        })
    }
}

/// A match between two different cameras (`FORMAT.md` version 5, column `camera_to`): the
/// pixel `px0` of camera `camera` at frame k-1 and the pixel `px1` of camera `camera_to` at frame
/// k. Its camera motion is `P_i⁻¹ M P_j` (`i = camera`, `j = camera_to`); on a stereo rig these
/// matches carry the metric scale (the baseline).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossObservation {
    /// Camera `i` of the pixel in frame k-1 (`f0` is in its coordinates).
    pub camera: usize,
    /// Camera `j` of the pixel in frame k (`f1` is in its coordinates).
    pub camera_to: usize,
    /// The pixels and bearings.
    pub obs: Observation,
}

/// The matches of one frame pair, per camera (index = camera id).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameObservations {
    /// `per_camera[j]` holds camera j's matches.
    pub per_camera: Vec<Vec<Observation>>,
    /// Matches between two different cameras (empty unless the sequence has them). They are
    /// not counted by [`len`](Self::len) and not used by the per-frame [`Problem`]; the
    /// odometry estimates the arc length from them.
    ///
    /// [`Problem`]: crate::Problem
    pub cross_camera: Vec<CrossObservation>,
}

impl FrameObservations {
    /// Empty lists for `n` cameras.
    pub fn new(n: usize) -> Self {
        Self {
            per_camera: vec![Vec::new(); n],
            cross_camera: Vec::new(),
        }
    }

    /// Total number of matches over all cameras (without [`cross_camera`](Self::cross_camera)).
    pub fn len(&self) -> usize {
        self.per_camera.iter().map(Vec::len).sum()
    }

    /// True if no camera has a match.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Removes all matches, keeping the allocations.
    pub fn clear(&mut self) {
        self.per_camera.iter_mut().for_each(Vec::clear);
        self.cross_camera.clear();
    }
}

//! Moving traffic: rigid boxes (cars, vans, trucks, buses) driving around the ego vehicle, the
//! `moving_traffic` scenario family ([`crate::SimConfig::moving_traffic`]).
//!
//! Every object is a box (length, width, height) whose pose in the world follows the ego
//! vehicle's own path: an object at path position `s` with lateral offset `y` and heading offset
//! `ψ` has the world pose `Γ(s) · Trans(0, y, 0) · Rot_z(ψ)`, `Γ(s)` the ego pose interpolated at
//! arc length `s`. Beyond the last frame the path continues along the trajectory's later poses
//! where there are any ([`generate_traffic_along`]: a drive along a longer ground truth, e.g. the
//! KITTI poses after the simulated frames) and is extrapolated straight beyond those (and
//! before the first frame). So a lead vehicle at a gap `g` turns with the road through curves,
//! up to the last frame too. Events (drawn from the seed over the whole drive):
//! - **lead vehicles** in the ego lane at 5 to 40 m with a slowly varying gap and lateral drift
//!   (up to 1.5 m), car, van or truck, present most of the time;
//! - **a bus filling half the image**: a bus 2.5 to 5 m ahead (stop-and-go);
//! - **cut-ins**: a car from the left or right lane moving into the ego lane 8 to 25 m ahead;
//! - **oncoming traffic**: cars in the opposite lane (3.5 m left) driving towards the ego car;
//! - **crossing trucks**: 12 m trucks crossing the path 15 to 40 m ahead at 3 to 9 m/s;
//! - with [`TrafficConfig::surround`] (surround rigs), also followers behind, overtaking cars
//!   (some cutting in), overtaken vehicles and vehicles alongside in the adjacent lanes
//!   (`surround_objects`).
//!
//! Matches: in every camera and frame pair where objects are visible (at least
//! [`TrafficConfig::min_area_px`] pixels of them, occlusions between objects included), a
//! fraction of the camera's matches drawn from [`TrafficConfig::fraction`] (per event, summed
//! and clamped) lies on the objects, split between them by weight and visible area; object
//! points are the nearest box hit of a pixel ray, and static points whose ray hits a box are
//! rejected (the objects occlude the scene).

use momo_core::{CameraModel, Pose, RigCamera, so3_exp, so3_log};
use nalgebra::{Matrix3, Vector2, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Parameters of the traffic.
#[derive(Clone, Debug, PartialEq)]
pub struct TrafficConfig {
    /// Range of the fraction of a camera's matches on moving objects when objects are visible.
    pub fraction: (f64, f64),
    /// An object holds matches in a camera only if at least this many pixels of it are visible.
    pub min_area_px: f64,
    /// Traffic all around the vehicle, for surround rigs (the `moving_traffic_surround`
    /// scenario, [`crate::SimConfig::moving_traffic_surround`]): besides the objects ahead,
    /// followers behind, cars overtaking the ego vehicle in the adjacent lanes (some cutting in
    /// ahead of it), vehicles the ego vehicle overtakes and vehicles riding alongside
    /// (`surround_objects`); and the pixel box of an object from points sampled over its
    /// surface (a fisheye sees boxes partly behind its image plane). Off (the default): the
    /// mono family's objects and boxes, bit for bit.
    pub surround: bool,
}

impl Default for TrafficConfig {
    /// Objects hold 30 to 70 % of the matches; at least 300 visible pixels.
    fn default() -> Self {
        Self {
            fraction: (0.3, 0.7),
            min_area_px: 300.0,
            surround: false,
        }
    }
}

/// A box-shaped road user over a range of frames.
#[derive(Clone, Debug, PartialEq)]
pub struct TrafficObject {
    /// What it is (for diagnostics): "lead", "bus", "cut_in", "oncoming", "crossing"; with
    /// [`TrafficConfig::surround`] also "follower", "overtaking", "overtaking_cut_in",
    /// "overtaken", "alongside".
    pub kind: &'static str,
    /// Frames it exists in.
    pub frames: std::ops::Range<usize>,
    /// Length, width, height, metres.
    pub size: Vector3<f64>,
    /// Its share of the matches (a draw from [`TrafficConfig::fraction`]).
    pub weight: f64,
    /// Pose relative to the path per frame: `(s, y, ψ)`, arc length along the ego path (m),
    /// lateral offset (m, left positive), heading offset (rad), for every frame in `frames`.
    pub path_pose: Vec<(f64, f64, f64)>,
}

/// The traffic of a whole drive: the objects and the ego path.
#[derive(Clone, Debug, PartialEq)]
pub struct Traffic {
    /// All objects.
    pub objects: Vec<TrafficObject>,
    /// Object poses in the ego vehicle frame, `poses[k][i]` for object i at frame k (`None`
    /// outside its frames).
    pub poses: Vec<Vec<Option<Pose<f64>>>>,
}

/// The ego path: poses and cumulative arc lengths (the drive's frames, then the later poses).
struct Path {
    poses: Vec<Pose<f64>>,
    cum: Vec<f64>,
}

impl Path {
    /// Ego pose at arc length `s` (interpolated; extrapolated along the end poses' x axes).
    fn at(&self, s: f64) -> Pose<f64> {
        let n = self.poses.len();
        let extrapolate = |p: &Pose<f64>, ds: f64| {
            Pose::new(
                p.rotation,
                p.translation + p.rotation * Vector3::new(ds, 0.0, 0.0),
            )
        };
        if n == 1 || s <= self.cum[0] {
            return extrapolate(&self.poses[0], s - self.cum[0]);
        }
        if s >= self.cum[n - 1] {
            return extrapolate(&self.poses[n - 1], s - self.cum[n - 1]);
        }
        // First index with cum > s.
        let i = self.cum.partition_point(|&c| c <= s).clamp(1, n - 1);
        let (a, b) = (&self.poses[i - 1], &self.poses[i]);
        let span = self.cum[i] - self.cum[i - 1];
        let f = if span > 1e-9 {
            (s - self.cum[i - 1]) / span
        } else {
            0.0
        };
        let dr = so3_log(&(a.rotation.transpose() * b.rotation));
        Pose::new(
            a.rotation * so3_exp(&(dr * f)),
            a.translation + (b.translation - a.translation) * f,
        )
    }
}

fn rot_z(psi: f64) -> Matrix3<f64> {
    so3_exp(&Vector3::new(0.0, 0.0, psi))
}

fn uniform(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// A smooth random signal in `[lo, hi]`: a sum of two sinusoids of random phase and periods.
fn smooth(rng: &mut StdRng, lo: f64, hi: f64, period: (f64, f64)) -> impl Fn(f64) -> f64 + use<> {
    let (p1, p2) = (
        uniform(rng, period.0, period.1),
        uniform(rng, period.0, period.1),
    );
    let (f1, f2) = (
        uniform(rng, 0.0, std::f64::consts::TAU),
        uniform(rng, 0.0, std::f64::consts::TAU),
    );
    move |t: f64| {
        let x = 0.5
            + 0.3 * (std::f64::consts::TAU * t / p1 + f1).sin()
            + 0.2 * (std::f64::consts::TAU * t / p2 + f2).sin();
        lo + (hi - lo) * x.clamp(0.0, 1.0)
    }
}

const CAR: [f64; 3] = [4.5, 1.8, 1.5];
const VAN: [f64; 3] = [6.0, 2.1, 2.6];
const TRUCK: [f64; 3] = [12.0, 2.5, 3.6];
const BUS: [f64; 3] = [12.0, 2.55, 3.2];

/// Generates the traffic of a drive (`vehicle_poses`, `arc_lengths[k]` the distance travelled
/// from frame k-1 to k) with a frame rate (Hz), deterministically from `seed`. The path is
/// extrapolated straight beyond the last frame ([`generate_traffic_along`] continues it).
pub fn generate_traffic(
    cfg: &TrafficConfig,
    vehicle_poses: &[Pose<f64>],
    arc_lengths: &[f64],
    frame_rate: f64,
    seed: u64,
) -> Traffic {
    generate_traffic_along(cfg, vehicle_poses, arc_lengths, &[], frame_rate, seed)
}

/// [`generate_traffic`] on a path that continues after the last frame along `later_poses` (the
/// vehicle poses the trajectory reaches after the drive's frames, in the same world frame; their
/// arc lengths are the distances between consecutive positions). Objects ahead of the ego
/// vehicle near the end of the drive then follow the road's curve instead of a straight line;
/// the objects, their schedule and every frame whose objects stay within the drive's own path
/// are the same as [`generate_traffic`]'s.
pub fn generate_traffic_along(
    cfg: &TrafficConfig,
    vehicle_poses: &[Pose<f64>],
    arc_lengths: &[f64],
    later_poses: &[Pose<f64>],
    frame_rate: f64,
    seed: u64,
) -> Traffic {
    let n = vehicle_poses.len();
    let mut cum = Vec::with_capacity(n + later_poses.len());
    let mut acc = 0.0;
    for k in 0..n {
        if k > 0 {
            acc += arc_lengths.get(k).copied().unwrap_or(0.0);
        }
        cum.push(acc);
    }
    let mut poses = vehicle_poses.to_vec();
    if n > 0 {
        for p in later_poses {
            let step = (p.translation - poses[poses.len() - 1].translation).norm();
            // A pose that does not move on would make the arc length non-increasing.
            if step > 1e-9 {
                acc += step;
                cum.push(acc);
                poses.push(*p);
            }
        }
    }
    let path = Path { poses, cum };
    let dt = 1.0 / frame_rate.max(1e-3);
    let mut rng = StdRng::seed_from_u64(seed ^ 0x7A11_C0DE_5EED);
    let mut objects: Vec<TrafficObject> = Vec::new();
    let weight = |rng: &mut StdRng| uniform(rng, cfg.fraction.0, cfg.fraction.1);
    let frames_of = |rng: &mut StdRng, start: usize, lo: usize, hi: usize| {
        let len = rng.random_range(lo..=hi);
        start..(start + len).min(n)
    };

    // Lead vehicles (and the close bus): alternating presence over the whole drive.
    let mut k = rng.random_range(0..10usize);
    while k < n {
        let bus = rng.random_bool(0.15);
        let frames = if bus {
            frames_of(&mut rng, k, 30, 90)
        } else {
            frames_of(&mut rng, k, 80, 300)
        };
        let size = if bus {
            BUS
        } else {
            [CAR, CAR, VAN, TRUCK][rng.random_range(0..4usize)]
        };
        let gap = if bus {
            // Rear 2.5 to 5 m ahead of the camera (1 m ahead of the motion centre).
            smooth(
                &mut rng,
                3.5 + BUS[0] / 2.0,
                6.0 + BUS[0] / 2.0,
                (30.0, 80.0),
            )
        } else {
            let lo = uniform(&mut rng, 6.0, 21.0);
            let hi = uniform(&mut rng, lo + 3.0, 41.0);
            smooth(
                &mut rng,
                lo + size[0] / 2.0,
                hi + size[0] / 2.0,
                (40.0, 200.0),
            )
        };
        let amp = uniform(&mut rng, 0.2, 1.5);
        let drift = smooth(&mut rng, -amp, amp, (30.0, 150.0));
        let psi_amp = uniform(&mut rng, 0.0, 0.04);
        let psi = smooth(&mut rng, -psi_amp, psi_amp, (20.0, 60.0));
        let path_pose = frames
            .clone()
            .map(|f| {
                let t = f as f64;
                (path.cum[f] + gap(t), drift(t), psi(t))
            })
            .collect();
        objects.push(TrafficObject {
            kind: if bus { "bus" } else { "lead" },
            frames: frames.clone(),
            size: Vector3::from(size),
            weight: weight(&mut rng),
            path_pose,
        });
        k = frames.end + rng.random_range(10..60usize);
    }

    // Cut-ins, oncoming cars and crossing trucks: Poisson-like events.
    let mut k = rng.random_range(20..80usize);
    while k < n {
        match rng.random_range(0..3u32) {
            0 => {
                // Cut-in from the left or the right lane over 1.5 to 4 s.
                let frames = frames_of(&mut rng, k, 40, 120);
                let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let g0 = uniform(&mut rng, 8.0, 25.0);
                let dv = uniform(&mut rng, -2.0, 3.0); // closing speed of the gap, m/s
                let t_lane = uniform(&mut rng, 1.5, 4.0);
                let path_pose = frames
                    .clone()
                    .map(|f| {
                        let t = (f - frames.start) as f64 * dt;
                        let u = (t / t_lane).clamp(0.0, 1.0);
                        let smooth_u = u * u * (3.0 - 2.0 * u);
                        let y = side * 3.5 * (1.0 - smooth_u);
                        let dy = side * 3.5 * 6.0 * u * (1.0 - u) / t_lane;
                        let gap = (g0 + dv * t).max(5.0 + CAR[0] / 2.0);
                        (path.cum[f] + gap, y, -(dy / 12.0).atan())
                    })
                    .collect();
                objects.push(TrafficObject {
                    kind: "cut_in",
                    frames,
                    size: Vector3::from(CAR),
                    weight: weight(&mut rng),
                    path_pose,
                });
            }
            1 => {
                // Oncoming car in the left lane.
                let frames = frames_of(&mut rng, k, 30, 80);
                let s0 = path.cum[k] + uniform(&mut rng, 40.0, 90.0);
                let v = uniform(&mut rng, 8.0, 20.0);
                let y = uniform(&mut rng, 3.0, 4.0);
                let path_pose = frames
                    .clone()
                    .map(|f| {
                        let t = (f - frames.start) as f64 * dt;
                        (s0 - v * t, y, std::f64::consts::PI)
                    })
                    .collect();
                objects.push(TrafficObject {
                    kind: "oncoming",
                    frames,
                    size: Vector3::from([CAR, VAN][rng.random_range(0..2usize)]),
                    weight: weight(&mut rng),
                    path_pose,
                });
            }
            _ => {
                // Crossing truck at a junction 15 to 40 m ahead of where the ego car is when
                // the truck has crossed (so the ego car never drives into it).
                let v = uniform(&mut rng, 3.0, 9.0);
                let dir = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let span = 40.0;
                let len = ((span / v) * frame_rate).ceil() as usize;
                let frames = k..(k + len.max(1)).min(n);
                let d = uniform(&mut rng, 15.0, 40.0);
                let s_cross = path.cum[frames.end - 1] + d;
                let path_pose = frames
                    .clone()
                    .map(|f| {
                        let t = (f - frames.start) as f64 * dt;
                        (
                            s_cross,
                            dir * (-span / 2.0 + v * t),
                            dir * std::f64::consts::FRAC_PI_2,
                        )
                    })
                    .collect();
                objects.push(TrafficObject {
                    kind: "crossing",
                    frames,
                    size: Vector3::from(TRUCK),
                    weight: weight(&mut rng),
                    path_pose,
                });
            }
        }
        k += rng.random_range(40..160usize);
    }

    if cfg.surround {
        objects.extend(surround_objects(cfg, &path, n, frame_rate, seed));
    }

    let poses = (0..n)
        .map(|f| {
            let v_inv = vehicle_poses[f].inverse();
            objects
                .iter()
                .map(|o| {
                    o.frames.contains(&f).then(|| {
                        let (s, y, psi) = o.path_pose[f - o.frames.start];
                        let g = path.at(s);
                        let local = Pose::new(rot_z(psi), Vector3::new(0.0, y, 0.0));
                        v_inv.compose(&g.compose(&local))
                    })
                })
                .collect()
        })
        .collect();
    Traffic { objects, poses }
}

/// The objects around the vehicle that [`TrafficConfig::surround`] adds after the mono family's
/// objects, drawn from a random stream of their own (so that those stay the same). Path
/// positions `s` are relative to the ego vehicle's motion centre; the adjacent lanes are 3.2 to
/// 3.8 m left or right, one vehicle per lane at a time:
/// - **followers** in the ego lane behind the vehicle, their front 4 to 30 m behind its rear
///   (1 m behind the motion centre) with a slowly varying gap and lateral drift, car, van or
///   truck, present most of the time;
/// - **overtaking** cars and vans in an adjacent lane, from 15-30 m behind to 15-40 m ahead at
///   1.5 to 5 m/s faster than the ego vehicle; half of them cut in ahead of it once 8 to 15 m
///   ahead, over 1.5 to 3 s (`overtaking_cut_in`);
/// - **overtaken** vehicles (cars, vans, trucks) in an adjacent lane, from 20-40 m ahead to
///   15-30 m behind at 1.5 to 5 m/s slower than the ego vehicle;
/// - **alongside**: a car, van or truck in an adjacent lane riding with the vehicle for 5 to
///   20 s, its centre within ±6 m of the motion centre (a side camera filled by a vehicle
///   that barely moves in the image).
fn surround_objects(
    cfg: &TrafficConfig,
    path: &Path,
    n: usize,
    frame_rate: f64,
    seed: u64,
) -> Vec<TrafficObject> {
    let dt = 1.0 / frame_rate.max(1e-3);
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5_2022_0D5E_ED5A);
    let weight = |rng: &mut StdRng| uniform(rng, cfg.fraction.0, cfg.fraction.1);
    let mut objects = Vec::new();

    // Followers: alternating presence over the whole drive.
    let mut k = rng.random_range(0..10usize);
    while k < n {
        let len = rng.random_range(80..=300usize);
        let frames = k..(k + len).min(n);
        let size = [CAR, CAR, VAN, TRUCK][rng.random_range(0..4usize)];
        let lo = uniform(&mut rng, 4.0, 15.0);
        let hi = uniform(&mut rng, lo + 3.0, 30.0);
        let gap = smooth(&mut rng, lo, hi, (40.0, 200.0));
        let amp = uniform(&mut rng, 0.2, 1.0);
        let drift = smooth(&mut rng, -amp, amp, (30.0, 150.0));
        let psi_amp = uniform(&mut rng, 0.0, 0.04);
        let psi = smooth(&mut rng, -psi_amp, psi_amp, (20.0, 60.0));
        let path_pose = frames
            .clone()
            .map(|f| {
                let t = f as f64;
                (path.cum[f] - 1.0 - gap(t) - size[0] / 2.0, drift(t), psi(t))
            })
            .collect();
        objects.push(TrafficObject {
            kind: "follower",
            frames: frames.clone(),
            size: Vector3::from(size),
            weight: weight(&mut rng),
            path_pose,
        });
        k = frames.end + rng.random_range(10..60usize);
    }

    // Vehicles in the adjacent lanes: Poisson-like events, one per lane at a time.
    let mut busy_until = [0usize; 2]; // left, right
    let mut k = rng.random_range(10..60usize);
    while k < n {
        let mut lane_index = rng.random_range(0..2usize);
        if busy_until[lane_index] > k {
            lane_index = 1 - lane_index;
        }
        if busy_until[lane_index] > k {
            k = busy_until[0].min(busy_until[1]);
            continue;
        }
        let side = if lane_index == 0 { 1.0 } else { -1.0 };
        let lane = side * uniform(&mut rng, 3.2, 3.8);
        let start = k;
        let (kind, frames, size, path_pose): (&'static str, _, _, Vec<_>) =
            match rng.random_range(0..3u32) {
                0 => {
                    // Overtaking the ego vehicle, half of them cutting in ahead of it.
                    let s0 = -uniform(&mut rng, 15.0, 30.0);
                    let s1 = uniform(&mut rng, 15.0, 40.0);
                    let dv = uniform(&mut rng, 1.5, 5.0);
                    let len = ((s1 - s0) / dv * frame_rate).ceil() as usize;
                    let frames = start..(start + len.max(1)).min(n);
                    let cut = rng.random_bool(0.5);
                    let s_cut = uniform(&mut rng, 8.0, 15.0);
                    let t_lane = uniform(&mut rng, 1.5, 3.0);
                    let size = [CAR, CAR, VAN][rng.random_range(0..3usize)];
                    let path_pose = frames
                        .clone()
                        .map(|f| {
                            let t = (f - start) as f64 * dt;
                            let s = s0 + dv * t;
                            let (y, y_dot) = if cut && s > s_cut {
                                let u = ((s - s_cut) / dv / t_lane).clamp(0.0, 1.0);
                                (
                                    lane * (1.0 - u * u * (3.0 - 2.0 * u)),
                                    -lane * 6.0 * u * (1.0 - u) / t_lane,
                                )
                            } else {
                                (lane, 0.0)
                            };
                            (path.cum[f] + s, y, (y_dot / 12.0).atan())
                        })
                        .collect();
                    let kind = if cut {
                        "overtaking_cut_in"
                    } else {
                        "overtaking"
                    };
                    (kind, frames, size, path_pose)
                }
                1 => {
                    // Overtaken by the ego vehicle.
                    let s0 = uniform(&mut rng, 20.0, 40.0);
                    let s1 = -uniform(&mut rng, 15.0, 30.0);
                    let dv = uniform(&mut rng, 1.5, 5.0);
                    let len = ((s0 - s1) / dv * frame_rate).ceil() as usize;
                    let frames = start..(start + len.max(1)).min(n);
                    let size = [CAR, VAN, TRUCK, TRUCK][rng.random_range(0..4usize)];
                    let path_pose = frames
                        .clone()
                        .map(|f| {
                            let t = (f - start) as f64 * dt;
                            (path.cum[f] + s0 - dv * t, lane, 0.0)
                        })
                        .collect();
                    ("overtaken", frames, size, path_pose)
                }
                _ => {
                    // Riding alongside.
                    let len = rng.random_range(50..=200usize);
                    let frames = start..(start + len).min(n);
                    let size = [CAR, VAN, TRUCK][rng.random_range(0..3usize)];
                    let s = smooth(&mut rng, -6.0, 6.0, (30.0, 120.0));
                    let drift = smooth(&mut rng, -0.3, 0.3, (30.0, 100.0));
                    let path_pose = frames
                        .clone()
                        .map(|f| {
                            let t = f as f64;
                            (path.cum[f] + s(t), lane + drift(t), 0.0)
                        })
                        .collect();
                    ("alongside", frames, size, path_pose)
                }
            };
        busy_until[lane_index] = frames.end;
        objects.push(TrafficObject {
            kind,
            frames,
            size: Vector3::from(size),
            weight: weight(&mut rng),
            path_pose,
        });
        k += rng.random_range(30..120usize);
    }
    objects
}

/// The pixel box `[u_min, v_min, u_max, v_max]` of the surface points of a box (pose: box centre
/// frame to camera, half extents) that `model` sees: 9 x 9 points per face, each kept if it
/// projects and its pixel maps back onto its ray (a fisheye sees points behind its image plane;
/// [`TrafficConfig::surround`]), padded by 4 pixels; `None` if no point projects.
fn surface_bbox<C: CameraModel>(
    model: &C,
    pose: &Pose<f64>,
    half: &Vector3<f64>,
) -> Option<[f64; 4]> {
    let mut bbox = [f64::INFINITY, f64::INFINITY, -f64::INFINITY, -f64::INFINITY];
    let mut any = false;
    for axis in 0..3 {
        let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
        for sign in [-1.0, 1.0] {
            for a in 0..9 {
                for b in 0..9 {
                    let mut p = Vector3::zeros();
                    p[axis] = sign * half[axis];
                    p[a1] = half[a1] * (a as f64 / 4.0 - 1.0);
                    p[a2] = half[a2] * (b as f64 / 4.0 - 1.0);
                    let x = pose.transform_point(&p);
                    let Some(px) = model.project(&x) else {
                        continue;
                    };
                    if !(px.x.is_finite() && px.y.is_finite()) {
                        continue;
                    }
                    let back = model.unproject(&px);
                    if back.is_none_or(|d| d.dot(&x.normalize()) < 1.0 - 1e-9) {
                        continue;
                    }
                    any = true;
                    bbox = [
                        bbox[0].min(px.x - 4.0),
                        bbox[1].min(px.y - 4.0),
                        bbox[2].max(px.x + 4.0),
                        bbox[3].max(px.y + 4.0),
                    ];
                }
            }
        }
    }
    any.then_some(bbox)
}

/// The objects of one camera in one frame pair, in camera coordinates at k-1.
pub(crate) struct CameraTraffic {
    /// Per visible object: box pose (box centre frame to camera), half extents, motion of its
    /// points from camera k-1 to camera k, pixel bounding box, share of the matches.
    pub objects: Vec<VisibleObject>,
    /// Boxes of all objects present (visible or not) for occlusion: (pose, half extents).
    pub occluders: Vec<(Pose<f64>, Vector3<f64>)>,
}

/// One visible object (see [`CameraTraffic`]).
pub(crate) struct VisibleObject {
    /// Index into `occluders`.
    pub index: usize,
    /// Index into [`Traffic::objects`] (what `labels.csv` names).
    pub object: usize,
    /// Points from camera coordinates at k-1 to camera coordinates at k.
    pub motion: Pose<f64>,
    /// Pixel box `[u_min, v_min, u_max, v_max]`.
    pub bbox: [f64; 4],
    /// Fraction of the camera's matches.
    pub fraction: f64,
}

/// Nearest positive hit of the ray `t·d` (from the camera centre) with a box; its distance.
fn ray_box(pose: &Pose<f64>, half: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
    let rt = pose.rotation.transpose();
    let o = -(rt * pose.translation);
    let dd = rt * d;
    let (mut t0, mut t1) = (0.0_f64, f64::INFINITY);
    for a in 0..3 {
        if dd[a].abs() < 1e-12 {
            if o[a].abs() > half[a] {
                return None;
            }
        } else {
            let (mut ta, mut tb) = ((-half[a] - o[a]) / dd[a], (half[a] - o[a]) / dd[a]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return None;
            }
        }
    }
    (t0 > 1e-6).then_some(t0)
}

impl CameraTraffic {
    /// The objects of `traffic` seen by `camera` in frame pair `k` (k ≥ 1).
    pub(crate) fn new(
        cfg: &TrafficConfig,
        traffic: &Traffic,
        camera: &RigCamera,
        k: usize,
    ) -> Option<Self> {
        let p = &camera.t_vehicle_camera;
        let p_inv = p.inverse();
        let (w, h) = camera.model.size();
        let mut occluders = Vec::new();
        let mut candidates = Vec::new();
        for (i, o) in traffic.objects.iter().enumerate() {
            let (Some(Some(a)), Some(Some(b))) = (
                traffic.poses.get(k - 1).map(|v| v[i]),
                traffic.poses.get(k).map(|v| v[i]),
            ) else {
                continue;
            };
            let half = o.size / 2.0;
            let centre = Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, half.z));
            let box_cam = p_inv.compose(&a.compose(&centre));
            // Object points: vehicle k-1 to vehicle k is b a⁻¹.
            let motion = p_inv.compose(&b.compose(&a.inverse()).compose(p));
            if cfg.surround {
                occluders.push((box_cam, half));
                if let Some(b) = surface_bbox(&camera.model, &box_cam, &half) {
                    let bbox = [
                        b[0].max(0.0),
                        b[1].max(0.0),
                        b[2].min(w - 1.0),
                        b[3].min(h - 1.0),
                    ];
                    if bbox[0] < bbox[2] && bbox[1] < bbox[3] {
                        candidates.push((occluders.len() - 1, i, motion, bbox, o.weight));
                    }
                }
                continue;
            }
            let mut bbox = [f64::INFINITY, f64::INFINITY, -f64::INFINITY, -f64::INFINITY];
            let mut full = false;
            for c in 0..8 {
                let s = Vector3::new(
                    if c & 1 == 0 { -1.0 } else { 1.0 },
                    if c & 2 == 0 { -1.0 } else { 1.0 },
                    if c & 4 == 0 { -1.0 } else { 1.0 },
                );
                let x = box_cam.transform_point(&half.component_mul(&s));
                match (x.z > 0.05).then(|| camera.model.project(&x)).flatten() {
                    Some(px) => {
                        bbox = [
                            bbox[0].min(px.x),
                            bbox[1].min(px.y),
                            bbox[2].max(px.x),
                            bbox[3].max(px.y),
                        ];
                    }
                    None => full = true,
                }
            }
            if full {
                bbox = [0.0, 0.0, w - 1.0, h - 1.0];
            }
            let bbox = [
                bbox[0].max(0.0),
                bbox[1].max(0.0),
                bbox[2].min(w - 1.0),
                bbox[3].min(h - 1.0),
            ];
            occluders.push((box_cam, half));
            if bbox[0] < bbox[2] && bbox[1] < bbox[3] {
                candidates.push((occluders.len() - 1, i, motion, bbox, o.weight));
            }
        }
        // Visible area by a grid of rays over each bounding box (occlusions included).
        let mut visible = Vec::new();
        for (index, object, motion, bbox, weight) in candidates {
            let (nu, nv) = (24, 12);
            let mut hits = 0;
            for a in 0..nu {
                for b in 0..nv {
                    let px = Vector2::new(
                        bbox[0] + (bbox[2] - bbox[0]) * (a as f64 + 0.5) / nu as f64,
                        bbox[1] + (bbox[3] - bbox[1]) * (b as f64 + 0.5) / nv as f64,
                    );
                    if nearest_hit(&occluders, &camera.model, &px).map(|(i, _)| i) == Some(index) {
                        hits += 1;
                    }
                }
            }
            let area = (bbox[2] - bbox[0]) * (bbox[3] - bbox[1]) * hits as f64 / (nu * nv) as f64;
            if area >= cfg.min_area_px {
                visible.push((index, object, motion, bbox, weight, area));
            }
        }
        if visible.is_empty() {
            return (!occluders.is_empty()).then_some(Self {
                objects: Vec::new(),
                occluders,
            });
        }
        let total = visible
            .iter()
            .map(|v| v.4)
            .sum::<f64>()
            .clamp(cfg.fraction.0, cfg.fraction.1);
        let norm: f64 = visible.iter().map(|v| v.4 * v.5.sqrt()).sum();
        let objects = visible
            .into_iter()
            .map(
                |(index, object, motion, bbox, weight, area)| VisibleObject {
                    index,
                    object,
                    motion,
                    bbox,
                    fraction: total * weight * area.sqrt() / norm,
                },
            )
            .collect();
        Some(Self { objects, occluders })
    }

    /// Whether the ray of pixel `px` hits any object (the static scene is occluded there).
    pub(crate) fn occludes<C: CameraModel>(&self, model: &C, px: &Vector2<f64>) -> bool {
        nearest_hit(&self.occluders, model, px).is_some()
    }

    /// The point (camera coordinates at k-1) of object `index` seen at pixel `px`, if that
    /// object is the nearest hit.
    pub(crate) fn object_point<C: CameraModel>(
        &self,
        model: &C,
        px: &Vector2<f64>,
        index: usize,
    ) -> Option<Vector3<f64>> {
        let (i, x) = nearest_hit(&self.occluders, model, px)?;
        (i == index).then_some(x)
    }
}

fn nearest_hit<C: CameraModel>(
    boxes: &[(Pose<f64>, Vector3<f64>)],
    model: &C,
    px: &Vector2<f64>,
) -> Option<(usize, Vector3<f64>)> {
    let d = model.unproject(px)?;
    boxes
        .iter()
        .enumerate()
        .filter_map(|(i, (pose, half))| ray_box(pose, half, &d).map(|t| (i, t)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, t)| (i, d * t))
}

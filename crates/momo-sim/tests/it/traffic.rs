//! The traffic's path beyond the drive's last frame.

use momo_core::{Pose, so3_exp};
use momo_sim::{TrafficConfig, generate_traffic, generate_traffic_along};
use nalgebra::Vector3;

/// Vehicle poses on a circle of radius `r` turning left (x forward, y left), `step` metres apart.
fn circle(r: f64, step: f64, n: usize) -> Vec<Pose<f64>> {
    (0..n)
        .map(|k| {
            let a = k as f64 * step / r;
            Pose::new(
                so3_exp(&Vector3::new(0.0, 0.0, a)),
                Vector3::new(r * a.sin(), r * (1.0 - a.cos()), 0.0),
            )
        })
        .collect()
}

/// The largest distance of an object's reference point from the road's curve: the circle of
/// radius `r - y` about the centre `(0, r)`, `y` its lateral offset, over every object and frame.
fn largest_departure(r: f64, drive: &[Pose<f64>], traffic: &momo_sim::Traffic) -> f64 {
    let mut worst: f64 = 0.0;
    for (k, objects) in traffic.poses.iter().enumerate() {
        for (i, pose) in objects.iter().enumerate() {
            if let Some(p) = pose {
                let o = &traffic.objects[i];
                let (_, y, _) = o.path_pose[k - o.frames.start];
                let world = drive[k].compose(p).translation;
                let d = (world - Vector3::new(0.0, r, 0.0)).norm();
                worst = worst.max((d - (r - y)).abs());
            }
        }
    }
    worst
}

/// A drive that ends in a curve: with the trajectory's later poses the objects ahead keep to
/// the curve up to the last frame; extrapolated straight (no later poses) they leave it. The
/// objects and their schedule are the same either way.
#[test]
fn traffic_ahead_follows_the_road_beyond_the_last_frame() {
    let (r, step, n) = (60.0, 1.2, 80);
    let all = circle(r, step, n + 150);
    let (drive, later) = all.split_at(n);
    let arcs: Vec<f64> = (0..n).map(|k| if k == 0 { 0.0 } else { step }).collect();
    let cfg = TrafficConfig::default();
    for seed in [1, 2, 3] {
        let along = generate_traffic_along(&cfg, drive, &arcs, later, 10.0, seed);
        let straight = generate_traffic(&cfg, drive, &arcs, 10.0, seed);
        assert_eq!(along.objects, straight.objects, "seed {seed}");
        let on_road = largest_departure(r, drive, &along);
        // Linear interpolation between poses 1.2 m apart on a 60 m circle: 3 mm sagitta.
        assert!(on_road < 0.01, "seed {seed}: {on_road} m off the curve");
        let off_road = largest_departure(r, drive, &straight);
        assert!(
            off_road > 1.0,
            "seed {seed}: straight only {off_road} m off"
        );
    }
}

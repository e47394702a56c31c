//! Criterion benchmarks of the feature front end at KITTI resolution (1241 x 376):
//!
//! - `matching/push_mono`: one frame of the streaming matcher, one camera (detection and
//!   description of the new image, matching against the previous frame, bucketing to 200);
//! - `matching/push_stereo`: the same for two cameras (processed in parallel);
//! - `matching/extract`: detection and description of one image only.
//!
//! On synthetic dead-leaves images warped by a small homography (a forward motion), so that no
//! data is needed. If `MOMO_DATA` (default `../shared/data`) holds the KITTI snippets,
//! `matching/kitti01_mono` runs on two real frames of KITTI 01 as well.
//!
//! Run with `cargo bench --bench matching`.

use criterion::{Criterion, criterion_group, criterion_main};
use momo_match::{
    DetectorOptions, FrameFeatures, FrameMatcher, GrayImage, MatchOptions, synthetic,
};
use nalgebra::Matrix3;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

const W: u32 = 1241;
const H: u32 = 376;

/// Two synthetic frames: a texture and its zoom by 1 % about the principal point (driving
/// forward), slightly rotated.
fn synthetic_pair() -> (GrayImage, GrayImage) {
    let img0 = synthetic::dead_leaves(W, H, 12_000, 3);
    let (cx, cy, s, a) = (607.0, 185.0, 1.01_f64, 0.003_f64);
    let h = Matrix3::new(
        s * a.cos(),
        -s * a.sin(),
        cx - s * (a.cos() * cx - a.sin() * cy),
        s * a.sin(),
        s * a.cos(),
        cy - s * (a.sin() * cx + a.cos() * cy),
        0.0,
        0.0,
        1.0,
    );
    let img1 = synthetic::warp(&img0, &h).expect("invertible");
    (img0, img1)
}

fn kitti_pair() -> Option<(GrayImage, GrayImage)> {
    let root = std::env::var_os("MOMO_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let dir = root.join("kitti_stereo_snippets/kitti01_frames000000-000050/image_0");
    let a = momo_match::load_gray(&dir.join("000010.png")).ok()?;
    let b = momo_match::load_gray(&dir.join("000011.png")).ok()?;
    Some((a, b))
}

fn bench_matching(c: &mut Criterion) {
    let (img0, img1) = synthetic_pair();
    let mut group = c.benchmark_group("matching");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(6));

    group.bench_function("extract", |b| {
        let mut f = FrameFeatures::default();
        b.iter(|| {
            f.extract(black_box(&img0), &DetectorOptions::default());
            black_box(f.len())
        })
    });

    let frames = [img0.clone(), img1.clone()];
    let mut mono = FrameMatcher::new(1, MatchOptions::default()).expect("valid options");
    let mut k = 0usize;
    group.bench_function("push_mono", |b| {
        b.iter(|| {
            k += 1;
            let r = mono
                .push(std::slice::from_ref(&frames[k % 2]))
                .expect("same size");
            black_box(r.map(|m| m[0].len()))
        })
    });

    let mut stereo = FrameMatcher::new(2, MatchOptions::default()).expect("valid options");
    let pairs = [[img0.clone(), img1.clone()], [img1.clone(), img0.clone()]];
    group.bench_function("push_stereo", |b| {
        b.iter(|| {
            k += 1;
            let r = stereo.push(&pairs[k % 2]).expect("same size");
            black_box(r.map(|m| m[0].len() + m[1].len()))
        })
    });

    if let Some((a, b2)) = kitti_pair() {
        let real = [a, b2];
        let mut m = FrameMatcher::new(1, MatchOptions::default()).expect("valid options");
        group.bench_function("kitti01_mono", |b| {
            b.iter(|| {
                k += 1;
                let r = m
                    .push(std::slice::from_ref(&real[k % 2]))
                    .expect("same size");
                black_box(r.map(|m| m[0].len()))
            })
        });
    } else {
        eprintln!("matching/kitti01_mono skipped: no KITTI snippets under MOMO_DATA");
    }
    group.finish();
}

criterion_group!(benches, bench_matching);
criterion_main!(benches);

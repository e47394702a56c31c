//! The AVX2-compiled kernels give the same features and matches as the baseline ones
//! (`momo_match::simd`). Its own test binary: the instruction set is process-wide, so no other
//! test may switch it meanwhile. On a CPU without AVX2 both runs take the baseline (the test
//! says so and compares the baseline with itself).

use image::GrayImage;
use momo_match::simd::{Isa, set_isa};
use momo_match::synthetic::{dead_leaves, warp};
use momo_match::{DetectorOptions, FrameFeatures, KltOptions, MatchOptions, match_images};
use nalgebra::Matrix3;

/// A pair of textured images, the second shifted, turned and scaled a little; sizes that are
/// not multiples of the vector widths (16 and 32 bytes), so that the loops' tails run.
fn pair(width: u32, height: u32, seed: u64) -> (GrayImage, GrayImage) {
    let img0 = dead_leaves(width, height, (width * height / 60) as usize, seed);
    let (cx, cy) = (f64::from(width) / 2.0, f64::from(height) / 2.0);
    let (s, a) = (1.02, 0.015);
    let (c, si) = (s * f64::cos(a), s * f64::sin(a));
    let h = Matrix3::new(
        c,
        -si,
        cx - c * cx + si * cy + 3.4,
        si,
        c,
        cy - si * cx - c * cy - 1.7,
        0.0,
        0.0,
        1.0,
    );
    let img1 = warp(&img0, &h).expect("invertible");
    (img0, img1)
}

fn features(img: &GrayImage, options: &DetectorOptions) -> FrameFeatures {
    let mut f = FrameFeatures::default();
    f.extract(img, options);
    f
}

#[test]
fn avx2_and_baseline_give_identical_features_and_matches() {
    let avx2 = set_isa(Some(Isa::Avx2)) == Isa::Avx2;
    if !avx2 {
        eprintln!("this CPU has no AVX2: the baseline is compared with itself");
    }
    let mut compared = (0usize, 0usize);
    for (k, &(w, h)) in [(333u32, 217u32), (640, 400), (1241, 376)]
        .iter()
        .enumerate()
    {
        let (img0, img1) = pair(w, h, 31 + k as u64);
        // The packed pass 1 (`nms_radius` < 8) and the column search (8), with the 16-lane
        // window check (n <= 7) and the whole-window scan (8).
        for nms in [1usize, 2, 3, 5, 7, 8] {
            let detector = DetectorOptions {
                nms_radius: nms,
                ..DetectorOptions::default()
            };
            set_isa(Some(Isa::Baseline));
            let base = features(&img0, &detector);
            set_isa(Some(Isa::Avx2));
            let fast = features(&img0, &detector);
            for (class, (a, b)) in base.classes.iter().zip(&fast.classes).enumerate() {
                assert_eq!(
                    a.points, b.points,
                    "{w}x{h}, nms {nms}, class {class}: the features differ"
                );
                compared.0 += a.points.len();
            }
        }
        // Matching: the KLT refinement (default), and the detector's sub-pixel vertices.
        let variants = [
            MatchOptions::default(),
            MatchOptions {
                klt: None,
                ..MatchOptions::default()
            },
            MatchOptions {
                klt: Some(KltOptions {
                    half: 3,
                    fb_threshold: 0.0,
                    ..KltOptions::default()
                }),
                matches_per_frame: 500,
                ..MatchOptions::default()
            },
        ];
        for (v, options) in variants.iter().enumerate() {
            set_isa(Some(Isa::Baseline));
            let base = match_images(&img0, &img1, options).expect("same size");
            set_isa(Some(Isa::Avx2));
            let fast = match_images(&img0, &img1, options).expect("same size");
            assert!(!base.is_empty(), "{w}x{h}, variant {v}: no matches");
            assert_eq!(base, fast, "{w}x{h}, variant {v}: the matches differ");
            compared.1 += base.len();
        }
    }
    set_isa(None);
    eprintln!(
        "compared {} features and {} matches (AVX2: {avx2})",
        compared.0, compared.1
    );
    assert!(compared.0 > 10_000 && compared.1 > 1_000);
}

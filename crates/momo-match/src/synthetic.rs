//! Synthetic images with known motion, for tests and benchmarks: a procedural "dead leaves"
//! texture (overlapping discs and rectangles of random gray levels, which has corners and blobs
//! at all scales like a real street scene, lightly blurred) and its warp by a known homography.

use image::{GrayImage, Luma};
use nalgebra::{Matrix3, Vector3};

/// A small deterministic random generator (SplitMix64), so that the images do not depend on a
/// random-number crate's version.
#[derive(Clone, Debug)]
pub struct SplitMix(u64);

impl SplitMix {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform number in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A `width x height` dead-leaves texture: `shapes` discs and rectangles with sizes from 2 to
/// about a tenth of the image height, drawn in order, over a mid-gray background.
pub fn dead_leaves(width: u32, height: u32, shapes: usize, seed: u64) -> GrayImage {
    let mut rng = SplitMix::new(seed);
    let mut img = GrayImage::from_pixel(width, height, Luma([128]));
    let max_r = (f64::from(height) / 10.0).max(3.0);
    for _ in 0..shapes {
        let cx = rng.uniform() * f64::from(width);
        let cy = rng.uniform() * f64::from(height);
        // Small shapes are more frequent (scale-invariant-ish size distribution).
        let r = 2.0 * (max_r / 2.0).powf(rng.uniform());
        let gray = (20.0 + 215.0 * rng.uniform()) as u8;
        let disc = rng.uniform() < 0.5;
        let (x0, x1) = (
            (cx - r).floor().max(0.0) as u32,
            ((cx + r).ceil() as u32).min(width),
        );
        let (y0, y1) = (
            (cy - r).floor().max(0.0) as u32,
            ((cy + r).ceil() as u32).min(height),
        );
        for y in y0..y1 {
            for x in x0..x1 {
                let (dx, dy) = (f64::from(x) - cx, f64::from(y) - cy);
                if !disc || dx * dx + dy * dy <= r * r {
                    img.put_pixel(x, y, Luma([gray]));
                }
            }
        }
    }
    blur(&img)
}

/// A [1 2 1] x [1 2 1] / 16 blur (borders copied), so that the texture is band-limited like a
/// camera image and a warped copy looks like the original seen from elsewhere.
fn blur(img: &GrayImage) -> GrayImage {
    let (w, h) = img.dimensions();
    let mut out = img.clone();
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let mut acc = 0u32;
            for (dy, wy) in [(0u32, 1u32), (1, 2), (2, 1)] {
                for (dx, wx) in [(0u32, 1u32), (1, 2), (2, 1)] {
                    acc += wy * wx * u32::from(img.get_pixel(x + dx - 1, y + dy - 1)[0]);
                }
            }
            out.put_pixel(x, y, Luma([((acc + 8) / 16) as u8]));
        }
    }
    out
}

/// Applies a homography to a pixel: `H (u, v, 1)`, dehomogenised.
pub fn apply_homography(h: &Matrix3<f64>, u: f64, v: f64) -> (f64, f64) {
    let p = h * Vector3::new(u, v, 1.0);
    (p.x / p.z, p.y / p.z)
}

/// The image `img` seen after the warp `h` (pixel `x` of `img` moves to `h x`): each output
/// pixel samples `img` at `h⁻¹ x` bilinearly; outside the source it is mid-gray. Returns `None`
/// if `h` is not invertible.
pub fn warp(img: &GrayImage, h: &Matrix3<f64>) -> Option<GrayImage> {
    let inv = h.try_inverse()?;
    let (w, hh) = img.dimensions();
    let mut out = GrayImage::from_pixel(w, hh, Luma([128]));
    for y in 0..hh {
        for x in 0..w {
            let (su, sv) = apply_homography(&inv, f64::from(x), f64::from(y));
            if let Some(v) = bilinear(img, su, sv) {
                out.put_pixel(x, y, Luma([v]));
            }
        }
    }
    Some(out)
}

/// Bilinear sample at `(u, v)`; `None` outside the image.
fn bilinear(img: &GrayImage, u: f64, v: f64) -> Option<u8> {
    let (w, h) = img.dimensions();
    if !(u >= 0.0 && v >= 0.0 && u <= f64::from(w - 1) && v <= f64::from(h - 1)) {
        return None;
    }
    let (x0, y0) = (u.floor() as u32, v.floor() as u32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (u - f64::from(x0), v - f64::from(y0));
    let p = |x, y| f64::from(img.get_pixel(x, y)[0]);
    let top = p(x0, y0) * (1.0 - fx) + p(x1, y0) * fx;
    let bottom = p(x0, y1) * (1.0 - fx) + p(x1, y1) * fx;
    Some((top * (1.0 - fy) + bottom * fy).round().clamp(0.0, 255.0) as u8)
}

//! Feature detection and description in the style of StereoScan (Geiger, Ziegler, Stiller 2011,
//! the matcher the paper used): two 5x5 filters, a *blob* mask and a *corner* (checkerboard)
//! mask, give four classes of interest points (blob maxima and minima, corner maxima and minima)
//! by block-wise non-maximum suppression; each point is described by the horizontal and vertical
//! Sobel responses at 16 fixed positions of the 11x11 window around it (32 bytes), compared by
//! the sum of absolute differences (SAD).
//!
//! ```text
//! blob mask          corner mask
//! -1 -1 -1 -1 -1     -1 -1  0 +1 +1
//! -1 +1 +1 +1 -1     -1 -1  0 +1 +1
//! -1 +1 +8 +1 -1      0  0  0  0  0
//! -1 +1 +1 +1 -1     +1 +1  0 -1 -1
//! -1 -1 -1 -1 -1     +1 +1  0 -1 -1
//! ```
//!
//! The filters are evaluated with running box sums (blob = -box5 + 2 box3 + 7 centre; corner =
//! differences of 2x2 boxes), row-parallel with rayon.

use image::GrayImage;
use rayon::prelude::*;

/// Distance of every feature from the image border, pixels (descriptor half-window 5, one more
/// pixel for the sub-pixel refinement, and the filters' half-width 2).
pub const BORDER: usize = 8;

/// The smallest image side that can hold a feature.
pub const MIN_SIDE: usize = 2 * BORDER + 1;

/// Number of feature classes: blob max, blob min, corner max, corner min.
pub const CLASSES: usize = 4;

/// A 32-byte descriptor: Sobel du at 16 positions, then Sobel dv at the same positions, each
/// stored as `128 + response / 4` clamped to a byte.
pub type Descriptor = [u8; 32];

/// The 16 sample positions `(du, dv)` of the descriptor in the 11x11 window.
const PATTERN: [(i32, i32); 16] = [
    (-1, -5),
    (1, -5),
    (-5, -3),
    (-1, -3),
    (1, -3),
    (5, -3),
    (-3, -1),
    (3, -1),
    (-3, 1),
    (3, 1),
    (-5, 3),
    (-1, 3),
    (1, 3),
    (5, 3),
    (-1, 5),
    (1, 5),
];

/// Options of the detector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetectorOptions {
    /// Non-maximum suppression half-width `n`: a feature is the extremum of its filter over the
    /// `(2n+1) x (2n+1)` window (blocks of `(n+1) x (n+1)` are searched).
    pub nms_radius: usize,
    /// Minimum absolute filter response of a feature.
    pub threshold: i32,
}

impl Default for DetectorOptions {
    fn default() -> Self {
        Self {
            nms_radius: 5,
            threshold: 50,
        }
    }
}

/// One interest point: integer pixel, filter response (signed), descriptor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Feature {
    /// Column.
    pub u: u16,
    /// Row.
    pub v: u16,
    /// Sub-pixel column: the vertex of the parabola through the filter response at `u - 1`,
    /// `u`, `u + 1`.
    pub x: f32,
    /// Sub-pixel row, likewise.
    pub y: f32,
    /// Filter response (positive for maxima, negative for minima).
    pub response: i16,
    /// The descriptor.
    pub desc: Descriptor,
}

/// Features of one class with a grid index for window queries.
#[derive(Clone, Debug, Default)]
pub struct ClassFeatures {
    /// The features.
    pub points: Vec<Feature>,
    /// `cell_start[c]..cell_start[c + 1]` indexes `order` for grid cell `c`.
    cell_start: Vec<u32>,
    /// Feature indices sorted by grid cell.
    order: Vec<u32>,
    cols: usize,
    rows: usize,
}

/// Side of the grid cells of the window index, pixels.
const INDEX_CELL: usize = 32;

impl ClassFeatures {
    fn build_index(&mut self, width: usize, height: usize) {
        self.cols = width.div_ceil(INDEX_CELL).max(1);
        self.rows = height.div_ceil(INDEX_CELL).max(1);
        let cells = self.cols * self.rows;
        let cell_of =
            |f: &Feature| usize::from(f.v) / INDEX_CELL * self.cols + usize::from(f.u) / INDEX_CELL;
        let mut count = vec![0u32; cells + 1];
        for f in &self.points {
            count[cell_of(f) + 1] += 1;
        }
        for c in 0..cells {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut order = vec![0u32; self.points.len()];
        for (i, f) in self.points.iter().enumerate() {
            let c = cell_of(f);
            order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        self.cell_start = count;
        self.order = order;
    }

    /// The feature with the smallest SAD to `desc` inside the window `|u - cu| <= ru`,
    /// `|v - cv| <= rv`: `(index, sad, second smallest sad)` (`u32::MAX` if it is alone).
    pub fn best_in_window(
        &self,
        desc: &Descriptor,
        cu: i32,
        cv: i32,
        ru: i32,
        rv: i32,
    ) -> Option<(usize, u32, u32)> {
        if self.points.is_empty() {
            return None;
        }
        let cell = INDEX_CELL as i32;
        let c0 = ((cu - ru).max(0) / cell) as usize;
        let c1 = (((cu + ru).max(0) / cell) as usize).min(self.cols - 1);
        let r0 = ((cv - rv).max(0) / cell) as usize;
        let r1 = (((cv + rv).max(0) / cell) as usize).min(self.rows - 1);
        let mut best: Option<(usize, u32)> = None;
        let mut second = u32::MAX;
        for r in r0..=r1 {
            let a = self.cell_start[r * self.cols + c0] as usize;
            let b = self.cell_start[r * self.cols + c1 + 1] as usize;
            for &i in &self.order[a..b] {
                let f = &self.points[i as usize];
                if (i32::from(f.u) - cu).abs() > ru || (i32::from(f.v) - cv).abs() > rv {
                    continue;
                }
                let s = sad(desc, &f.desc);
                match best {
                    Some((_, b)) if s >= b => second = second.min(s),
                    Some((_, b)) => {
                        second = b;
                        best = Some((i as usize, s));
                    }
                    None => best = Some((i as usize, s)),
                }
            }
        }
        best.map(|(i, s)| (i, s, second))
    }
}

/// The sum of absolute differences of two descriptors.
#[inline]
pub fn sad(a: &Descriptor, b: &Descriptor) -> u32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| u32::from(x.abs_diff(*y)))
        .sum()
}

/// The features of one image, plus its Sobel images (kept for sub-pixel refinement).
#[derive(Clone, Debug, Default)]
pub struct FrameFeatures {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    du: Vec<u8>,
    dv: Vec<u8>,
    blob: Vec<i16>,
    corner: Vec<i16>,
    /// The features per class: blob max, blob min, corner max, corner min.
    pub classes: [ClassFeatures; CLASSES],
}

impl FrameFeatures {
    /// Detects and describes the features of `img` (at least [`MIN_SIDE`] pixels a side, else
    /// there are none). Buffers of `self` are reused.
    pub fn extract(&mut self, img: &GrayImage, options: &DetectorOptions) {
        let (w, h) = (img.width() as usize, img.height() as usize);
        self.width = w;
        self.height = h;
        for c in &mut self.classes {
            c.points.clear();
        }
        if w < MIN_SIDE || h < MIN_SIDE {
            for c in &mut self.classes {
                c.build_index(w, h);
            }
            return;
        }
        let px = img.as_raw().as_slice();
        self.du.resize(w * h, 128);
        self.dv.resize(w * h, 128);
        self.blob.resize(w * h, 0);
        self.corner.resize(w * h, 0);
        sobel(px, w, h, &mut self.du, &mut self.dv);
        filters(px, w, h, &mut self.blob, &mut self.corner);
        self.non_maximum_suppression(options);
        for c in &mut self.classes {
            c.build_index(w, h);
        }
    }

    /// The descriptor at an integer pixel at least 5 pixels (6 with refinement) inside.
    #[inline]
    pub fn descriptor_at(&self, u: usize, v: usize) -> Descriptor {
        let mut d = [0u8; 32];
        let w = self.width;
        for (k, (dx, dy)) in PATTERN.iter().enumerate() {
            let i = ((v as i32 + dy) as usize) * w + (u as i32 + dx) as usize;
            d[k] = self.du[i];
            d[16 + k] = self.dv[i];
        }
        d
    }

    /// Total number of features.
    pub fn len(&self) -> usize {
        self.classes.iter().map(|c| c.points.len()).sum()
    }

    /// True without features.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn non_maximum_suppression(&mut self, options: &DetectorOptions) {
        let (w, h) = (self.width, self.height);
        let n = options.nms_radius.max(1);
        let tau = options.threshold.max(1);
        let step = n + 1;
        let (blob, corner) = (&self.blob, &self.corner);
        let rows: Vec<usize> = (BORDER..h - BORDER).step_by(step).collect();
        let found: Vec<Vec<(usize, usize, usize, i16)>> = rows
            .par_iter()
            .map(|&v0| {
                let mut out = Vec::new();
                let v1 = (v0 + step).min(h - BORDER);
                let mut u0 = BORDER;
                while u0 < w - BORDER {
                    let u1 = (u0 + step).min(w - BORDER);
                    // (value, index) of blob max, blob min, corner max, corner min.
                    let mut ext = [
                        (i16::MIN, 0usize),
                        (i16::MAX, 0),
                        (i16::MIN, 0),
                        (i16::MAX, 0),
                    ];
                    for v in v0..v1 {
                        for u in u0..u1 {
                            let i = v * w + u;
                            let (b, c) = (blob[i], corner[i]);
                            if b > ext[0].0 {
                                ext[0] = (b, i);
                            }
                            if b < ext[1].0 {
                                ext[1] = (b, i);
                            }
                            if c > ext[2].0 {
                                ext[2] = (c, i);
                            }
                            if c < ext[3].0 {
                                ext[3] = (c, i);
                            }
                        }
                    }
                    for (class, &(val, i)) in ext.iter().enumerate() {
                        let maximum = class % 2 == 0;
                        let strong = if maximum {
                            i32::from(val) >= tau
                        } else {
                            i32::from(val) <= -tau
                        };
                        if !strong {
                            continue;
                        }
                        let img = if class < 2 { blob } else { corner };
                        let (u, v) = (i % w, i / w);
                        if is_extremum(img, w, h, u, v, n, val, maximum) {
                            out.push((class, u, v, val));
                        }
                    }
                    u0 = u1;
                }
                out
            })
            .collect();
        for (class, u, v, val) in found.into_iter().flatten() {
            let desc = self.descriptor_at(u, v);
            let img = if class < 2 { &self.blob } else { &self.corner };
            let r = |x: usize, y: usize| f64::from(img[y * w + x]);
            let c = r(u, v);
            let x = u as f64 + vertex(r(u - 1, v), c, r(u + 1, v));
            let y = v as f64 + vertex(r(u, v - 1), c, r(u, v + 1));
            self.classes[class].points.push(Feature {
                u: u as u16,
                v: v as u16,
                x: x as f32,
                y: y as f32,
                response: val,
                desc,
            });
        }
    }
}

/// The offset of the vertex of the parabola through `(-1, a)`, `(0, b)`, `(1, c)`, within
/// `[-0.5, 0.5]` (0 if the three are collinear).
fn vertex(a: f64, b: f64, c: f64) -> f64 {
    let denom = a - 2.0 * b + c;
    if denom == 0.0 {
        return 0.0;
    }
    (0.5 * (a - c) / denom).clamp(-0.5, 0.5)
}

/// True if `val` at `(u, v)` is the strict maximum (or minimum) of `img` over the
/// `(2n+1)^2` window, ties broken towards the smaller index.
#[allow(clippy::too_many_arguments)]
fn is_extremum(
    img: &[i16],
    w: usize,
    h: usize,
    u: usize,
    v: usize,
    n: usize,
    val: i16,
    maximum: bool,
) -> bool {
    let i0 = v * w + u;
    for y in v.saturating_sub(n)..(v + n + 1).min(h) {
        for x in u.saturating_sub(n)..(u + n + 1).min(w) {
            let i = y * w + x;
            let o = img[i];
            let beats = if maximum {
                o > val || (o == val && i < i0)
            } else {
                o < val || (o == val && i < i0)
            };
            if beats {
                return false;
            }
        }
    }
    true
}

/// 3x3 Sobel responses, stored as `128 + response / 4` clamped to a byte (border rows and
/// columns: 128).
fn sobel(px: &[u8], w: usize, h: usize, du: &mut [u8], dv: &mut [u8]) {
    du.par_chunks_mut(w)
        .zip(dv.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (ru, rv))| {
            if y == 0 || y + 1 == h {
                ru.fill(128);
                rv.fill(128);
                return;
            }
            let a = &px[(y - 1) * w..y * w];
            let b = &px[y * w..(y + 1) * w];
            let c = &px[(y + 1) * w..(y + 2) * w];
            ru[0] = 128;
            rv[0] = 128;
            ru[w - 1] = 128;
            rv[w - 1] = 128;
            for x in 1..w - 1 {
                let l = i32::from(a[x - 1]) + 2 * i32::from(b[x - 1]) + i32::from(c[x - 1]);
                let r = i32::from(a[x + 1]) + 2 * i32::from(b[x + 1]) + i32::from(c[x + 1]);
                let t = i32::from(a[x - 1]) + 2 * i32::from(a[x]) + i32::from(a[x + 1]);
                let bo = i32::from(c[x - 1]) + 2 * i32::from(c[x]) + i32::from(c[x + 1]);
                ru[x] = (128 + (r - l) / 4).clamp(0, 255) as u8;
                rv[x] = (128 + (bo - t) / 4).clamp(0, 255) as u8;
            }
        });
}

/// The blob and corner responses (zero within 2 pixels of the border).
fn filters(px: &[u8], w: usize, h: usize, blob: &mut [i16], corner: &mut [i16]) {
    blob.par_chunks_mut(w)
        .zip(corner.par_chunks_mut(w))
        .enumerate()
        .for_each_init(
            || (vec![0i32; w], vec![0i32; w], vec![0i32; w]),
            |(c5, c3, d), (y, (rb, rc))| {
                if y < 2 || y + 2 >= h {
                    rb.fill(0);
                    rc.fill(0);
                    return;
                }
                let row = |k: usize| &px[k * w..(k + 1) * w];
                let (r0, r1, r2, r3, r4) = (row(y - 2), row(y - 1), row(y), row(y + 1), row(y + 2));
                for x in 0..w {
                    let (a, b, c, e, f) = (
                        i32::from(r0[x]),
                        i32::from(r1[x]),
                        i32::from(r2[x]),
                        i32::from(r3[x]),
                        i32::from(r4[x]),
                    );
                    c3[x] = b + c + e;
                    c5[x] = a + c3[x] + f;
                    d[x] = (e + f) - (a + b);
                }
                rb[..2].fill(0);
                rc[..2].fill(0);
                rb[w - 2..].fill(0);
                rc[w - 2..].fill(0);
                for x in 2..w - 2 {
                    let box5 = c5[x - 2] + c5[x - 1] + c5[x] + c5[x + 1] + c5[x + 2];
                    let box3 = c3[x - 1] + c3[x] + c3[x + 1];
                    rb[x] = (2 * box3 - box5 + 7 * i32::from(r2[x])) as i16;
                    rc[x] = (d[x - 2] + d[x - 1] - d[x + 1] - d[x + 2]) as i16;
                }
            },
        );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box-sum filters equal the 5x5 masks applied directly.
    #[test]
    fn filters_equal_the_masks() {
        let (w, h) = (13usize, 11usize);
        let px: Vec<u8> = (0..w * h)
            .map(|i| ((i * 37 + i * i * 11) % 251) as u8)
            .collect();
        let mut blob = vec![0i16; w * h];
        let mut corner = vec![0i16; w * h];
        filters(&px, w, h, &mut blob, &mut corner);
        let bm = |dx: i32, dy: i32| match (dx.abs().max(dy.abs()), dx, dy) {
            (0, _, _) => 8,
            (1, _, _) => 1,
            _ => -1,
        };
        let cm = |dx: i32, dy: i32| {
            if dx == 0 || dy == 0 {
                0
            } else if (dx < 0) == (dy < 0) {
                -1
            } else {
                1
            }
        };
        for y in 2..h - 2 {
            for x in 2..w - 2 {
                let (mut b, mut c) = (0i32, 0i32);
                for dy in -2..=2 {
                    for dx in -2..=2 {
                        let p =
                            i32::from(px[(y as i32 + dy) as usize * w + (x as i32 + dx) as usize]);
                        b += bm(dx, dy) * p;
                        c += cm(dx, dy) * p;
                    }
                }
                assert_eq!(i32::from(blob[y * w + x]), b, "blob at {x},{y}");
                assert_eq!(i32::from(corner[y * w + x]), c, "corner at {x},{y}");
            }
        }
    }

    /// A bright dot is a blob maximum at its pixel.
    #[test]
    fn a_bright_dot_is_a_blob_maximum() {
        let mut img = GrayImage::from_pixel(40, 30, image::Luma([50]));
        img.put_pixel(20, 15, image::Luma([200]));
        let mut f = FrameFeatures::default();
        f.extract(&img, &DetectorOptions::default());
        let p = &f.classes[0].points;
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!((p[0].u, p[0].v), (20, 15));
        assert_eq!(p[0].response, 8 * 150);
    }
}

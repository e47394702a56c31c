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
//! differences of 2x2 boxes), row-parallel with rayon, strip by strip together with the
//! suppression (so that the responses are read back from the cache).

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

// The descriptor reads every other row of its window ([`descriptor`]).
const _: () = {
    let mut k = 0;
    while k < PATTERN.len() {
        assert!((PATTERN[k].1 + DESCRIPTOR_REACH as i32) % 2 == 0);
        k += 1;
    }
};

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
///
/// The index keeps the features' positions and descriptors a second time, sorted by grid cell
/// (row-major), in flat arrays: a window query walks a few contiguous runs of memory.
#[derive(Clone, Debug, Default)]
pub struct ClassFeatures {
    /// The features.
    pub points: Vec<Feature>,
    /// `cell_start[c]..cell_start[c + 1]` are the slots of grid cell `c`.
    cell_start: Vec<u32>,
    /// The feature index of each slot.
    order: Vec<u32>,
    /// The slot of each feature (inverse of `order`).
    slot_of: Vec<u32>,
    /// `(u, v)` of each slot.
    pos: Vec<[i16; 2]>,
    /// The descriptor of each slot.
    descs: Vec<Descriptor>,
    cols: usize,
    rows: usize,
}

/// Side of the grid cells of the window index, pixels.
const INDEX_CELL: usize = 32;

/// A search window: centre `(cu, cv)`, half-width `ru`, half-height `rv`.
#[derive(Clone, Copy, Debug)]
struct Window {
    cu: i32,
    cv: i32,
    ru: i32,
    rv: i32,
}

impl Window {
    #[inline]
    fn contains(&self, p: [i16; 2]) -> bool {
        (i32::from(p[0]) - self.cu).abs() <= self.ru && (i32::from(p[1]) - self.cv).abs() <= self.rv
    }
}

impl ClassFeatures {
    #[inline(never)]
    fn build_index(&mut self, width: usize, height: usize) {
        self.cols = width.div_ceil(INDEX_CELL).max(1);
        self.rows = height.div_ceil(INDEX_CELL).max(1);
        let cells = self.cols * self.rows;
        let cols = self.cols;
        let cell_of =
            |f: &Feature| usize::from(f.v) / INDEX_CELL * cols + usize::from(f.u) / INDEX_CELL;
        self.cell_start.clear();
        self.cell_start.resize(cells + 1, 0);
        for f in &self.points {
            self.cell_start[cell_of(f) + 1] += 1;
        }
        for c in 0..cells {
            self.cell_start[c + 1] += self.cell_start[c];
        }
        let n = self.points.len();
        self.order.clear();
        self.order.resize(n, 0);
        self.slot_of.clear();
        self.slot_of.resize(n, 0);
        // Stable within a cell: slots follow the feature order.
        let mut fill: Vec<u32> = self.cell_start[..cells].to_vec();
        for (i, f) in self.points.iter().enumerate() {
            let c = cell_of(f);
            let slot = fill[c] as usize;
            fill[c] += 1;
            self.order[slot] = i as u32;
            self.slot_of[i] = slot as u32;
        }
        // Positions and descriptors gathered in slot order (no zero fill of the arrays first).
        let points = &self.points;
        self.pos.clear();
        self.pos.extend(self.order.iter().map(|&i| {
            let f = &points[i as usize];
            [f.u as i16, f.v as i16]
        }));
        self.descs.clear();
        self.descs
            .extend(self.order.iter().map(|&i| points[i as usize].desc));
    }

    /// Calls `visit(slot, sad)` for every feature inside the window `|u - cu| <= ru`,
    /// `|v - cv| <= rv`, in increasing slot order, until `visit` returns false; features of the
    /// window's edge cells that lie outside it may be visited with `sad = u32::MAX` (no real
    /// SAD: at most 32 * 255), which a visitor must treat as no candidate.
    #[inline]
    fn scan(
        &self,
        desc: &Descriptor,
        win: Window,
        mut visit: impl FnMut(usize, u32) -> bool,
    ) -> bool {
        let cell = INDEX_CELL as i32;
        let (lo_u, hi_u) = (win.cu - win.ru, win.cu + win.ru);
        let (lo_v, hi_v) = (win.cv - win.rv, win.cv + win.rv);
        if hi_u < 0 || hi_v < 0 {
            return true;
        }
        let c0 = (lo_u.max(0) / cell) as usize;
        let c1 = ((hi_u / cell) as usize).min(self.cols - 1);
        let r0 = (lo_v.max(0) / cell) as usize;
        let r1 = ((hi_v / cell) as usize).min(self.rows - 1);
        if c0 > c1 || r0 > r1 {
            return true;
        }
        let query = Query::new(desc);
        // Cells wholly inside the window in u: c0 < c < c1 always are (the window spans them).
        let inside_v = |r: usize| {
            let top = (r * INDEX_CELL) as i32;
            top >= lo_v && top + cell - 1 <= hi_v
        };
        for r in r0..=r1 {
            let base = r * self.cols;
            let start = |c: usize| self.cell_start[base + c] as usize;
            let runs: [(usize, usize, bool); 3] = if c0 == c1 {
                [
                    (start(c0), start(c0 + 1), true),
                    (0, 0, false),
                    (0, 0, false),
                ]
            } else {
                [
                    (start(c0), start(c0 + 1), true),
                    (start(c0 + 1), start(c1), false),
                    (start(c1), start(c1 + 1), true),
                ]
            };
            let check_v = !inside_v(r);
            for (a, b, check_u) in runs {
                let pos = &self.pos[a..b];
                let descs = &self.descs[a..b];
                if check_u || check_v {
                    // A feature outside the window is visited with the SAD `u32::MAX`, which
                    // no visitor takes for a match (real SADs are at most 32 * 255): no
                    // branch on the position, which is close to a coin toss near the edges.
                    for (k, (p, d)) in pos.iter().zip(descs).enumerate() {
                        let outside = u32::from(!win.contains(*p)).wrapping_neg();
                        if !visit(a + k, query.sad(d) | outside) {
                            return false;
                        }
                    }
                } else {
                    for (k, d) in descs.iter().enumerate() {
                        if !visit(a + k, query.sad(d)) {
                            return false;
                        }
                    }
                }
            }
        }
        true
    }

    /// The feature with the smallest SAD to `desc` inside the window `|u - cu| <= ru`,
    /// `|v - cv| <= rv`: `(index, sad, second smallest sad)` (`u32::MAX` if it is alone). Of
    /// equal SADs the first in the index's order wins.
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
        let mut best = u32::MAX;
        let mut best_slot = usize::MAX;
        let mut second = u32::MAX;
        self.scan(desc, Window { cu, cv, ru, rv }, |slot, s| {
            // Without branches: `second` is the smaller of itself and the larger of `best`
            // and `s` (the old best if `s` beats it, else `s` if it beats `second`).
            second = second.min(best.max(s));
            if s < best {
                best_slot = slot;
            }
            best = best.min(s);
            true
        });
        (best_slot != usize::MAX).then(|| (self.order[best_slot] as usize, best, second))
    }

    /// True if feature `index`, at SAD `sad` from `desc` and inside the window, is what
    /// [`best_in_window`](Self::best_in_window) would return for `desc` and this window (the
    /// circular check). Stops at the first feature that beats it.
    pub fn is_best_in_window(
        &self,
        desc: &Descriptor,
        cu: i32,
        cv: i32,
        ru: i32,
        rv: i32,
        index: usize,
        sad: u32,
    ) -> bool {
        let Some(&target) = self.slot_of.get(index) else {
            return false;
        };
        let target = target as usize;
        self.scan(desc, Window { cu, cv, ru, rv }, |slot, s| {
            s > sad || (s == sad && slot >= target)
        })
    }
}

/// The sum of absolute differences of two descriptors (`psadbw` on x86-64, two 16-byte halves;
/// a plain loop elsewhere).
#[inline(always)]
pub fn sad(a: &Descriptor, b: &Descriptor) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        Query::new(a).sad(b)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut s = 0u32;
        for k in 0..32 {
            s += (i32::from(a[k]) - i32::from(b[k])).unsigned_abs();
        }
        s
    }
}

/// A descriptor held in two 16-byte registers, for the SADs of one window scan.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Query([safe_arch::m128i; 2]);

#[cfg(target_arch = "x86_64")]
impl Query {
    #[inline(always)]
    fn halves(d: &Descriptor) -> [safe_arch::m128i; 2] {
        let half = |k: usize| -> [u8; 16] { std::array::from_fn(|i| d[16 * k + i]) };
        [
            safe_arch::m128i::from(half(0)),
            safe_arch::m128i::from(half(1)),
        ]
    }

    #[inline(always)]
    fn new(d: &Descriptor) -> Self {
        Self(Self::halves(d))
    }

    /// The SAD of the query and `d`.
    #[inline(always)]
    fn sad(&self, d: &Descriptor) -> u32 {
        use safe_arch::{add_i64_m128i, sum_of_u8_abs_diff_m128i};
        let [b0, b1] = Self::halves(d);
        let s = add_i64_m128i(
            sum_of_u8_abs_diff_m128i(self.0[0], b0),
            sum_of_u8_abs_diff_m128i(self.0[1], b1),
        );
        let [lo, hi]: [u64; 2] = s.into();
        (lo + hi) as u32
    }
}

/// A descriptor prepared for the SADs of one window scan (plain bytes where there is no
/// `psadbw`).
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy)]
struct Query(Descriptor);

#[cfg(not(target_arch = "x86_64"))]
impl Query {
    #[inline(always)]
    fn new(d: &Descriptor) -> Self {
        Self(*d)
    }

    #[inline(always)]
    fn sad(&self, d: &Descriptor) -> u32 {
        sad(&self.0, d)
    }
}

/// The features of one image, plus its Sobel images (kept for sub-pixel refinement).
#[derive(Clone, Debug, Default)]
pub struct FrameFeatures {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The Sobel images interleaved: `du | dv << 8` per pixel, so that a descriptor's 16
    /// samples touch half the cache lines of two separate images.
    sobel: Vec<u16>,
    /// The image's pixels (row-major), kept for the KLT refinement.
    pixels: Vec<u8>,
    /// The blob and corner responses of the rows in use (a ring of [`ring`](Self::ring) rows:
    /// row `y` at `(y & (ring - 1)) * width`), filled strip by strip
    /// ([`filter_and_suppress`](Self::filter_and_suppress)).
    blob: Vec<i16>,
    corner: Vec<i16>,
    /// Rows of the response ring, a power of two.
    ring: usize,
    /// Pass 1's packed column keys of the block rows in use ([`KeyRing`]), for pass 2's test
    /// against the block rows above and below.
    keys: Vec<i16>,
    /// The features per class: blob max, blob min, corner max, corner min.
    pub classes: [ClassFeatures; CLASSES],
}

impl FrameFeatures {
    /// Detects and describes the features of `img` (at least [`MIN_SIDE`] pixels a side, else
    /// there are none). Buffers of `self` are reused; the image's pixels are copied (kept for
    /// the KLT refinement, [`plane`](Self::plane)).
    pub fn extract(&mut self, img: &GrayImage, options: &DetectorOptions) {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let mut pixels = std::mem::take(&mut self.pixels);
        pixels.clear();
        if w >= MIN_SIDE && h >= MIN_SIDE {
            pixels.extend_from_slice(&img.as_raw()[..w * h]);
        }
        self.extract_pixels(w, h, pixels, options);
    }

    /// [`extract`](Self::extract) of an image given away: its buffer becomes the pixels kept
    /// for the KLT refinement, without the copy (a KITTI image is 460 KB). The features are
    /// the same.
    pub fn extract_owned(&mut self, img: GrayImage, options: &DetectorOptions) {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let mut pixels = img.into_raw();
        pixels.truncate(if w >= MIN_SIDE && h >= MIN_SIDE {
            w * h
        } else {
            0
        });
        self.extract_pixels(w, h, pixels, options);
    }

    /// [`extract`](Self::extract) of the `w x h` image `pixels` (row-major, empty if a side is
    /// below [`MIN_SIDE`]), which `self` keeps.
    fn extract_pixels(&mut self, w: usize, h: usize, pixels: Vec<u8>, options: &DetectorOptions) {
        self.width = w;
        self.height = h;
        for c in &mut self.classes {
            c.points.clear();
        }
        if w < MIN_SIDE || h < MIN_SIDE {
            self.pixels = pixels;
            for c in &mut self.classes {
                c.build_index(w, h);
            }
            return;
        }
        self.sobel.resize(w * h, SOBEL_FLAT);
        self.filter_and_suppress(&pixels, options, STRIP_ROWS);
        self.pixels = pixels;
        self.classes
            .par_iter_mut()
            .for_each(|c| c.build_index(w, h));
    }

    /// The descriptor at an integer pixel at least 5 pixels (6 with refinement) inside.
    #[inline]
    pub fn descriptor_at(&self, u: usize, v: usize) -> Descriptor {
        descriptor(&self.sobel, self.width, u, v)
    }

    /// The image the features were extracted from (empty if it was smaller than
    /// [`MIN_SIDE`]).
    pub fn plane(&self) -> crate::refine::Plane<'_> {
        crate::refine::Plane {
            px: &self.pixels,
            width: self.width,
            height: self.height,
        }
    }

    /// Total number of features.
    pub fn len(&self) -> usize {
        self.classes.iter().map(|c| c.points.len()).sum()
    }

    /// True without features.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Block-wise non-maximum suppression (libviso2): the image inside the border is cut into
    /// `(n+1) x (n+1)` blocks; per block and class the extremum (the first in row-major order)
    /// is the only candidate, kept if it is strong enough and the strict extremum of its
    /// `(2n+1)^2` window (ties go to the earlier pixel). Two passes over rows of blocks, each in
    /// parallel: (1) the strong extrema of every block, from column-wise extremes (vectorised),
    /// less those that a column extreme of their own block row beats within their window (a
    /// necessary condition, [`beaten_in_block_row`]); (2) per remaining candidate, the exact
    /// window check, 16 columns at a time ([`window_check`]); survivors are described and
    /// refined. The feature order is that of a serial scan (block rows, then blocks).
    ///
    /// The filters and both passes run strip by strip (`strip_rows` rows of whole block rows at
    /// a time, at least one block row; [`STRIP_ROWS`] by default): the filters fill the strip's
    /// rows (and the rows its windows and descriptors reach below it), then pass 1 and pass 2
    /// read them while they are still in the cache (the response images of a whole frame, 2.8
    /// MB with the Sobel images, are not). The results do not depend on the strips: each block
    /// row's candidates depend only on the responses.
    fn filter_and_suppress(&mut self, px: &[u8], options: &DetectorOptions, strip_rows: usize) {
        let (w, h) = (self.width, self.height);
        let n = options.nms_radius.max(1);
        let tau = options.threshold.clamp(1, i32::from(i16::MAX)) as i16;
        let step = n + 1;
        let block_rows: Vec<usize> = (BORDER..h - BORDER).step_by(step).collect();
        let per_strip = (strip_rows / step).clamp(1, block_rows.len().max(1));
        let reach = n.max(DESCRIPTOR_REACH);
        // Pass 2 of a strip's last block row waits for the next strip's pass 1 (the column keys
        // of the block row below it). So the ring holds the rows from `n` above the block row
        // before the strip (or from row 0 for the first strip) to what the strip's windows and
        // descriptors reach below its end.
        let ring = (BORDER.max(n + step) + per_strip * step + reach)
            .min(h)
            .next_power_of_two();
        self.ring = ring;
        self.blob.resize(ring * w, 0);
        self.corner.resize(ring * w, 0);
        let packed = n < PACKED_ROWS;
        let key_ring = KeyRing::new(w, per_strip);
        let mut keys = std::mem::take(&mut self.keys);
        key_ring.reset(&mut keys);
        // Rows `..filtered` hold their responses.
        let mut filtered = 0;
        // The block row whose pass 2 waits: its index and candidates.
        let mut pending: Option<(usize, Vec<Extremum>)> = None;
        for (s, strip) in block_rows.chunks(per_strip).enumerate() {
            let last = strip.last().copied().unwrap_or(BORDER);
            let end = (last + step).min(h - BORDER);
            // The windows reach `n` rows below the strip's last row, the descriptors 5.
            let target = (end + reach).min(h);
            if target > filtered {
                responses(
                    px,
                    w,
                    h,
                    filtered..target,
                    ring,
                    &mut self.sobel,
                    &mut self.blob,
                    &mut self.corner,
                );
                filtered = target;
            }
            let first = s * per_strip;
            let mut extrema = if packed {
                self.block_extrema_packed(strip, n, tau, key_ring.strip_mut(&mut keys, first))
            } else {
                self.block_extrema(strip, n, tau)
            };
            let later = extrema.pop().unwrap_or_default();
            let (from, rows) = match pending.take() {
                Some((b, row)) => (b, std::iter::once(row).chain(extrema).collect()),
                None => (first, extrema),
            };
            let neighbours = packed.then(|| (&keys[..], key_ring, block_rows.len()));
            self.check_and_describe(n, from, &rows, neighbours);
            pending = Some((first + strip.len() - 1, later));
        }
        if let Some((b, row)) = pending {
            let neighbours = packed.then(|| (&keys[..], key_ring, block_rows.len()));
            self.check_and_describe(n, b, &[row], neighbours);
        }
        self.keys = keys;
        if filtered < h {
            responses(
                px,
                w,
                h,
                filtered..h,
                ring,
                &mut self.sobel,
                &mut self.blob,
                &mut self.corner,
            );
        }
    }

    /// Pass 1 of the suppression as [`block_extrema`](Self::block_extrema), for blocks of at
    /// most [`PACKED_ROWS`] rows (`n < 8`): the column-wise extremes are taken of packed keys
    /// ([`pack_max`], [`pack_min`]: the response times 8 plus the row within the block, ordered
    /// so that of equal responses the earliest row wins), so that one vectorised extreme per
    /// column gives both the extreme and its first row, and a block's first pixel is the first
    /// column holding its best key (no search down the columns). The responses fit: |blob| <=
    /// 16 * 255 and |corner| <= 8 * 255, so `8 |r| + 7 <= 32647`.
    #[inline(never)]
    fn block_extrema_packed<'a>(
        &'a self,
        block_rows: &[usize],
        n: usize,
        tau: i16,
        keys: &mut [i16],
    ) -> Vec<Vec<Extremum>> {
        let (w, h) = (self.width, self.height);
        let step = n + 1;
        let (blob, corner) = (&self.blob, &self.corner);
        let mask = self.ring - 1;
        let inner = w - 2 * BORDER;
        // The column keys are padded with `PAD` values that never win (so that the sliding
        // extremes need no bounds), the scratch rows hold the doubling levels.
        let total = inner + PAD;
        let blocks = inner.div_ceil(step);
        block_rows
            .par_iter()
            .zip(keys.par_chunks_mut(CLASSES * total))
            .map_init(
                || {
                    let mut s = Reused::take(&PASS_ONE_SCRATCH);
                    for (class, col) in s.cols.iter_mut().enumerate() {
                        let pad = if class % 2 == 0 { i16::MIN } else { i16::MAX };
                        col.resize(total, pad);
                        col[inner..].fill(pad);
                    }
                    for sc in &mut s.sliding {
                        sc.resize(total);
                    }
                    s
                },
                |s, (&v0, keys)| {
                    let PassOneScratch {
                        cols,
                        sliding: scratch,
                        out,
                        starts,
                        strong,
                    } = &mut **s;
                    let v1 = (v0 + step).min(h - BORDER);
                    let [bmax, bmin, cmax, cmin] = cols;
                    let (bmax, bmin) = (&mut bmax[..inner], &mut bmin[..inner]);
                    let (cmax, cmin) = (&mut cmax[..inner], &mut cmin[..inner]);
                    let row = |img: &'a [i16], v: usize| -> &'a [i16] {
                        let s = (v & mask) * w + BORDER;
                        &img[s..s + inner]
                    };
                    {
                        let (rb, rc) = (row(blob, v0), row(corner, v0));
                        for x in 0..inner {
                            bmax[x] = pack_max(rb[x], 0);
                            bmin[x] = pack_min(rb[x], 0);
                            cmax[x] = pack_max(rc[x], 0);
                            cmin[x] = pack_min(rc[x], 0);
                        }
                    }
                    for v in v0 + 1..v1 {
                        let r = (v - v0) as i16;
                        let (rb, rc) = (row(blob, v), row(corner, v));
                        for x in 0..inner {
                            bmax[x] = bmax[x].max(pack_max(rb[x], r));
                            bmin[x] = bmin[x].min(pack_min(rb[x], r));
                            cmax[x] = cmax[x].max(pack_max(rc[x], r));
                            cmin[x] = cmin[x].min(pack_min(rc[x], r));
                        }
                    }
                    // The block and window extremes of each class, then the candidates block by
                    // block.
                    for (class, (col, sc)) in cols.iter().zip(scratch.iter_mut()).enumerate() {
                        if class % 2 == 0 {
                            sliding_block_extremes::<true>(&col[..total], inner, n, sc);
                        } else {
                            sliding_block_extremes::<false>(&col[..total], inner, n, sc);
                        }
                    }
                    let span = 2 * n + 1;
                    let windows = (inner + 1).saturating_sub(span);
                    let class_of = |class: usize| {
                        let col = &cols[class][..total];
                        let sc = &scratch[class];
                        (col, &sc.blocks[..inner], &sc.window[..windows])
                    };
                    // Class `c`'s candidates fill the slots from `c * blocks` (the list is by
                    // class, then block).
                    out.resize(blocks * CLASSES, Extremum::default());
                    let words = inner.div_ceil(64);
                    if starts.0 != (inner, step) {
                        *starts = ((inner, step), vec![0; words]);
                        for k0 in (0..inner).step_by(step) {
                            starts.1[k0 / 64] |= 1 << (k0 % 64);
                        }
                    }
                    strong.resize(words, 0);
                    let mut len = [0usize; CLASSES];
                    for (c, (slots, len)) in out.chunks_exact_mut(blocks).zip(&mut len).enumerate()
                    {
                        let (col, blk, win) = class_of(c);
                        let at = PassOneRow {
                            v0,
                            v1,
                            class: c as u8,
                        };
                        *len = if c % 2 == 0 {
                            class_candidates::<true>(
                                col, blk, win, inner, n, tau, at, &starts.1, strong, slots,
                            )
                        } else {
                            class_candidates::<false>(
                                col, blk, win, inner, n, tau, at, &starts.1, strong, slots,
                            )
                        };
                    }
                    let mut row = Vec::with_capacity(len.iter().sum());
                    for (c, &l) in len.iter().enumerate() {
                        row.extend_from_slice(&out[c * blocks..c * blocks + l]);
                    }
                    // The column keys, for pass 2 of the block rows above and below.
                    for (dst, col) in keys.chunks_exact_mut(total).zip(cols.iter()) {
                        dst.copy_from_slice(&col[..total]);
                    }
                    row
                },
            )
            .collect()
    }

    /// Pass 1 of the suppression: per row of blocks, per block, the strong extremum of each
    /// class (the first pixel holding it).
    #[inline(never)]
    fn block_extrema<'a>(&'a self, block_rows: &[usize], n: usize, tau: i16) -> Vec<Vec<Extremum>> {
        let (w, h) = (self.width, self.height);
        let step = n + 1;
        let (blob, corner) = (&self.blob, &self.corner);
        let mask = self.ring - 1;
        let inner = w - 2 * BORDER;
        let responses = [blob, blob, corner, corner];
        let lanes = &LaneOffsets::new(n);
        block_rows
            .par_iter()
            .map_init(
                || [(); CLASSES].map(|()| vec![0i16; inner]),
                |cols, &v0| {
                    let v1 = (v0 + step).min(h - BORDER);
                    let [bmax, bmin, cmax, cmin] = cols;
                    let (bmax, bmin) = (&mut bmax[..inner], &mut bmin[..inner]);
                    let (cmax, cmin) = (&mut cmax[..inner], &mut cmin[..inner]);
                    let row = |img: &'a [i16], v: usize| {
                        let s = (v & mask) * w + BORDER;
                        &img[s..s + inner]
                    };
                    bmax.copy_from_slice(row(blob, v0));
                    bmin.copy_from_slice(row(blob, v0));
                    cmax.copy_from_slice(row(corner, v0));
                    cmin.copy_from_slice(row(corner, v0));
                    for v in v0 + 1..v1 {
                        let (rb, rc) = (row(blob, v), row(corner, v));
                        for x in 0..inner {
                            bmax[x] = bmax[x].max(rb[x]);
                            bmin[x] = bmin[x].min(rb[x]);
                            cmax[x] = cmax[x].max(rc[x]);
                            cmin[x] = cmin[x].min(rc[x]);
                        }
                    }
                    let columns: [&[i16]; CLASSES] = [bmax, bmin, cmax, cmin];
                    let mut out = Vec::new();
                    for blk in 0..inner.div_ceil(step) {
                        let u0 = BORDER + blk * step;
                        let u1 = (u0 + step).min(w - BORDER);
                        for (class, col) in columns.iter().enumerate() {
                            let part = &col[u0 - BORDER..u1 - BORDER];
                            let (val, strong) = if class % 2 == 0 {
                                let m = part.iter().copied().fold(i16::MIN, i16::max);
                                (m, m >= tau)
                            } else {
                                let m = part.iter().copied().fold(i16::MAX, i16::min);
                                (m, m <= -tau)
                            };
                            if !strong {
                                continue;
                            }
                            // The first pixel of the block holding the extremum (row-major):
                            // the first row of each column whose extreme it is, the smallest.
                            let img = responses[class];
                            let mut first = (usize::MAX, 0);
                            for (k, _) in part.iter().enumerate().filter(|(_, c)| **c == val) {
                                let u = u0 + k;
                                let rows = v0..v1.min(first.0);
                                if let Some(v) =
                                    rows.into_iter().find(|&v| img[(v & mask) * w + u] == val)
                                {
                                    first = (v, u);
                                }
                            }
                            if first.0 == usize::MAX {
                                continue;
                            }
                            // Within the candidate's window, the block row's columns
                            // `u - n..=u + n`: a column extreme strictly better rejects it.
                            let k0 = (first.1 - BORDER).wrapping_sub(n);
                            let beaten = if class % 2 == 0 {
                                beaten_in_block_row::<true>(col, k0, &lanes.block_row[0], val)
                            } else {
                                beaten_in_block_row::<false>(col, k0, &lanes.block_row[1], val)
                            };
                            if !beaten {
                                out.push(Extremum {
                                    val,
                                    u: first.1 as u16,
                                    v: first.0 as u16,
                                    class: class as u8,
                                    cleared: 0,
                                });
                            }
                        }
                    }
                    // By class, then block (stable).
                    out.sort_by_key(|e| e.class);
                    out
                },
            )
            .collect()
    }

    /// Pass 2 of the suppression: the window check of every strong block extremum; survivors
    /// are refined to sub-pixel and described, in the order of a serial scan.
    #[inline(never)]
    fn check_and_describe(
        &mut self,
        n: usize,
        from: usize,
        extrema: &[Vec<Extremum>],
        neighbours: Option<(&[i16], KeyRing, usize)>,
    ) {
        let (w, h) = (self.width, self.height);
        let lanes = &LaneOffsets::new(n);
        let (blob, corner, sobel) = (&self.blob, &self.corner, &self.sobel);
        let img_of = |class: usize| if class < 2 { blob } else { corner };
        let mask = self.ring - 1;
        let found: Vec<[Vec<Feature>; CLASSES]> = (0..extrema.len())
            .into_par_iter()
            .map(|by| {
                let mut out: [Vec<Feature>; CLASSES] = Default::default();
                let mut kept: Vec<Extremum> = Vec::new();
                // Pass 1 lists a block row's candidates by class: one run per class.
                for run in extrema[by].chunk_by(|a, b| a.class == b.class) {
                    let class = usize::from(run[0].class) % CLASSES;
                    let img = img_of(class);
                    // First the window checks, the survivors kept without a branch on the
                    // outcome (close to a coin toss), then the survivors described.
                    kept.clear();
                    kept.resize(run.len(), Extremum::default());
                    // The column keys of the block rows above and below (padding where there
                    // is none).
                    let b = from + by;
                    let near = neighbours.map(|(keys, ring, rows)| {
                        let above = ring.class(keys, b.checked_sub(1), class);
                        let below = ring.class(keys, (b + 1 < rows).then_some(b + 1), class);
                        (above, below, BORDER + b * (n + 1))
                    });
                    let len = if class % 2 == 0 {
                        survivors::<true>(img, (w, h), mask, n, lanes, run, &mut kept, near)
                    } else {
                        survivors::<false>(img, (w, h), mask, n, lanes, run, &mut kept, near)
                    };
                    let points = &mut out[class];
                    points.reserve_exact(len);
                    for e in &kept[..len] {
                        let (u, v) = (usize::from(e.u), usize::from(e.v));
                        // The candidate's row from `u - 1` to `u + 1` and the pixels above
                        // and below it (inside: the window check has read them).
                        let at = |y: usize| (y & mask) * w + u;
                        let [l, c, r]: [i16; 3] =
                            img[at(v) - 1..at(v) + 2].try_into().unwrap_or([e.val; 3]);
                        let (a, b) = (img[at(v - 1)], img[at(v + 1)]);
                        let f = f64::from;
                        let x = u as f64 + vertex(f(l), f(c), f(r));
                        let y = v as f64 + vertex(f(a), f(c), f(b));
                        points.push(Feature {
                            u: e.u,
                            v: e.v,
                            x: x as f32,
                            y: y as f32,
                            response: e.val,
                            desc: descriptor(sobel, w, u, v),
                        });
                    }
                }
                out
            })
            .collect();
        for row in found {
            for (class, points) in row.into_iter().enumerate() {
                self.classes[class].points.extend(points);
            }
        }
    }
}

/// Pass 2's window checks of one class's candidates `run` (maxima if `MAX`): the survivors
/// are copied to the front of `kept` (at least `run.len()` long), their number returned. Every
/// candidate is written and the count advanced by the outcome (no branch on it). With
/// `neighbours` (the class's column keys of the block rows above and below the candidates',
/// and the first row of theirs), a first round drops the candidates that those keys beat
/// ([`beaten_by_neighbours`], a necessary condition), so that fewer reach the window check.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn survivors<const MAX: bool>(
    img: &[i16],
    (w, h): (usize, usize),
    mask: usize,
    n: usize,
    lanes: &LaneOffsets,
    run: &[Extremum],
    kept: &mut [Extremum],
    neighbours: Option<(&[i16], &[i16], usize)>,
) -> usize {
    let check = |e: Extremum| check_one::<MAX>(img, (w, h), mask, n, lanes, e);
    let Some((above, below, v0)) = neighbours else {
        let mut len = 0;
        for e in run {
            let keep = check(*e);
            if let Some(slot) = kept.get_mut(len) {
                *slot = *e;
            }
            len += usize::from(keep);
        }
        return len;
    };
    let mut first = 0;
    for e in run {
        let k = usize::from(e.u) - BORDER;
        let r = usize::from(e.v) - v0;
        let beaten = beaten_by_neighbours::<MAX>(above, below, &lanes.inside, k, n, r, e.val);
        if let Some(slot) = kept.get_mut(first) {
            *slot = *e;
        }
        first += usize::from(!beaten);
    }
    let mut len = 0;
    for i in 0..first.min(kept.len()) {
        let e = kept[i];
        let keep = check(e);
        kept[len] = e;
        len += usize::from(keep);
    }
    len
}

/// The exact window check of one candidate: the 16-column check where the window fits it,
/// else the whole window is scanned.
#[inline(always)]
fn check_one<const MAX: bool>(
    img: &[i16],
    (w, h): (usize, usize),
    mask: usize,
    n: usize,
    lanes: &LaneOffsets,
    e: Extremum,
) -> bool {
    let (u, v) = (usize::from(e.u), usize::from(e.v));
    let fits = lanes.fits && u >= n && u - n + LANES <= w && v >= n && v + n < h;
    if fits {
        window_check::<MAX>(img, w, mask, e, n, lanes)
    } else {
        is_extremum::<MAX>(img, w, h, mask, u, v, n, e.val)
    }
}

/// Where pass 1's column keys of block row `b` are kept for pass 2
/// ([`FrameFeatures::filter_and_suppress`]): slot `b % (3 * per_strip)`, each slot the four
/// classes' padded keys (`inner + PAD` each), so that a strip's block rows take consecutive
/// slots and the two strips before it stay; one last slot of padding (keys that never beat) for
/// the missing neighbours of the first and last block rows.
#[derive(Clone, Copy, Debug)]
struct KeyRing {
    total: usize,
    per_strip: usize,
}

impl KeyRing {
    fn new(w: usize, per_strip: usize) -> Self {
        Self {
            total: w - 2 * BORDER + PAD,
            per_strip,
        }
    }

    fn slots(self) -> usize {
        3 * self.per_strip
    }

    fn slot_len(self) -> usize {
        CLASSES * self.total
    }

    /// Sizes `keys` and fills the padding slot.
    fn reset(self, keys: &mut Vec<i16>) {
        keys.resize((self.slots() + 1) * self.slot_len(), 0);
        let pad = &mut keys[self.slots() * self.slot_len()..];
        for (class, row) in pad.chunks_exact_mut(self.total).enumerate() {
            row.fill(if class % 2 == 0 { i16::MIN } else { i16::MAX });
        }
    }

    /// The slots of the strip whose first block row is `first`.
    fn strip_mut(self, keys: &mut [i16], first: usize) -> &mut [i16] {
        let a = first % self.slots();
        &mut keys[a * self.slot_len()..(a + self.per_strip) * self.slot_len()]
    }

    /// The keys of `class` of block row `b` (the padding if `None`).
    fn class(self, keys: &[i16], b: Option<usize>, class: usize) -> &[i16] {
        let slot = b.map_or(self.slots(), |b| b % self.slots());
        let at = (slot * CLASSES + class) * self.total;
        &keys[at..at + self.total]
    }
}

/// Pass 2's first test: true if a packed column key ([`pack_max`], [`pack_min`]) of the block
/// row above or below the candidate's, within its window's columns (lanes `inside`, from column
/// `k - n`; `k` the candidate's column less [`BORDER`]), beats it from a row inside its window
/// (`r` the candidate's row within its block row): above (its row after `r` in its block), a
/// response at least as good; below (its row before `r`), a strictly better one. A key holds
/// its column's best response in that block row and the first row holding it, so this is a
/// necessary condition only (ties and pixels behind a key are left to [`window_check`]). False
/// where the 16 lanes do not fit.
#[inline(always)]
fn beaten_by_neighbours<const MAX: bool>(
    above: &[i16],
    below: &[i16],
    inside: &[bool; LANES],
    k: usize,
    n: usize,
    r: usize,
    val: i16,
) -> bool {
    let k0 = k.wrapping_sub(n);
    let lanes = |keys: &[i16]| -> Option<[i16; LANES]> {
        keys.get(k0..k0.wrapping_add(LANES))
            .and_then(|x| x.try_into().ok())
    };
    let (Some(a), Some(b)) = (lanes(above), lanes(below)) else {
        return false;
    };
    let r = r as i16;
    let mut any = false;
    for j in 0..LANES {
        let (va, vb) = (a[j] >> 3, b[j] >> 3);
        let (ra, rb) = if MAX {
            (7 - (a[j] & 7), 7 - (b[j] & 7))
        } else {
            (a[j] & 7, b[j] & 7)
        };
        let hit_a = (if MAX { va >= val } else { va <= val }) & (ra > r);
        let hit_b = better::<MAX>(vb, val) & (rb < r);
        any |= inside[j] & (hit_a | hit_b);
    }
    any
}

/// The strong extremum of one block and class: a candidate of pass 2 (pass 1 lists them per
/// row of blocks by class, then block: each class's candidates in the order of a serial
/// scan).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Extremum {
    val: i16,
    u: u16,
    v: u16,
    class: u8,
    /// Rows that pass 1 has cleared, where its necessary condition ran ([`packed_candidate`],
    /// else 0): the low nibble those below `v` (the rest of the candidate's block row: no pixel
    /// strictly better), the high nibble those above `v` within the block row (no pixel at
    /// least as good). Both are below [`PACKED_ROWS`].
    cleared: u8,
}

impl Extremum {
    /// The [`cleared`](Self::cleared) field of `below` and `above` rows (each below 16, as
    /// the rows of a block are: [`PACKED_ROWS`]).
    #[inline(always)]
    fn cleared_rows(below: usize, above: usize) -> u8 {
        debug_assert!(below < 16 && above < 16, "{below} {above}");
        (below | above << 4) as u8
    }

    /// Rows below `v` that pass 1 has cleared.
    #[inline(always)]
    fn cleared_below(self) -> usize {
        usize::from(self.cleared & 15)
    }

    /// Rows above `v` that pass 1 has cleared.
    #[inline(always)]
    fn cleared_above(self) -> usize {
        usize::from(self.cleared >> 4)
    }
}

/// Rows of a block whose row index fits the packed keys of
/// [`FrameFeatures::block_extrema_packed`] (3 bits).
const PACKED_ROWS: usize = 8;

/// The packed key of a response `x` in row `r` (< [`PACKED_ROWS`]) of its block, for maxima:
/// `8 x + 7 - r` (the larger response, then the earlier row, has the larger key).
#[inline(always)]
fn pack_max(x: i16, r: i16) -> i16 {
    (x << 3) + (7 - r)
}

/// The packed key for minima: `8 x + r` (the smaller response, then the earlier row, has the
/// smaller key).
#[inline(always)]
fn pack_min(x: i16, r: i16) -> i16 {
    (x << 3) + r
}

/// Values past the end of pass 1's column keys (never the extreme).
const PAD: usize = 16;

/// Rows per strip of [`FrameFeatures::filter_and_suppress`] (whole block rows, at least one):
/// the ring of response rows (32 rows for the default radius 5: 160 KB for a KITTI image, 1241
/// pixels wide) and the strip's Sobel rows stay in the L2 cache between the filters and the two
/// passes.
const STRIP_ROWS: usize = 12;

/// Rows a descriptor reaches above and below its pixel ([`PATTERN`]).
const DESCRIPTOR_REACH: usize = 5;

/// Scratch buffers taken from a pool of this thread's and given back when dropped, so that
/// the parallel loops' per-task buffers are allocated once per thread, not once per strip.
struct Reused<T: Default + 'static> {
    item: T,
    pool: &'static std::thread::LocalKey<std::cell::RefCell<Vec<T>>>,
}

impl<T: Default + 'static> Reused<T> {
    fn take(pool: &'static std::thread::LocalKey<std::cell::RefCell<Vec<T>>>) -> Self {
        let item = pool
            .try_with(|p| p.borrow_mut().pop())
            .ok()
            .flatten()
            .unwrap_or_default();
        Self { item, pool }
    }
}

impl<T: Default + 'static> std::ops::Deref for Reused<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.item
    }
}

impl<T: Default + 'static> std::ops::DerefMut for Reused<T> {
    fn deref_mut(&mut self) -> &mut T {
        &mut self.item
    }
}

impl<T: Default + 'static> Drop for Reused<T> {
    fn drop(&mut self) {
        let item = std::mem::take(&mut self.item);
        // During the thread's teardown the pool may be gone: then the buffers are freed.
        let _ = self.pool.try_with(|p| p.borrow_mut().push(item));
    }
}

/// Pass 1's buffers per task: the four classes' padded column keys, their sliding extremes,
/// the block row's candidate slots.
#[derive(Default)]
struct PassOneScratch {
    cols: [Vec<i16>; CLASSES],
    sliding: [SlidingScratch; CLASSES],
    out: Vec<Extremum>,
    /// One bit per column of the block row: the blocks' first columns ([`class_candidates`]),
    /// for the columns and block width (`inner`, `n + 1`) of the first field.
    starts: ((usize, usize), Vec<u64>),
    /// One bit per column: the block extremes of one class that are strong.
    strong: Vec<u64>,
}

thread_local! {
    static PASS_ONE_SCRATCH: std::cell::RefCell<Vec<PassOneScratch>> =
        const { std::cell::RefCell::new(Vec::new()) };
    static FILTER_SCRATCH: std::cell::RefCell<Vec<[Vec<i16>; 5]>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// The doubling levels of [`sliding_extremes`]: `m[i][j]` the extreme of `col[j..j + 2^(i+1)]`.
#[derive(Default)]
struct SlidingScratch {
    m: [Vec<i16>; 3],
    /// The block extremes (`len = n + 1`) and the window extremes (`len = 2n + 1`) at each column.
    blocks: Vec<i16>,
    window: Vec<i16>,
}

impl SlidingScratch {
    /// At least `total` values in each row (every value is written before it is read).
    fn resize(&mut self, total: usize) {
        for row in self
            .m
            .iter_mut()
            .chain([&mut self.blocks, &mut self.window])
        {
            if row.len() < total {
                row.resize(total, 0);
            }
        }
    }
}

/// `dst[j] = extreme(src[j], src[j + shift])` (a vectorised loop).
#[inline(always)]
fn pairwise<const MAX: bool>(src: &[i16], shift: usize, dst: &mut [i16]) {
    let len = dst.len();
    let (a, b) = (&src[..len], &src[shift..shift + len]);
    for j in 0..len {
        dst[j] = extreme::<MAX>(a[j], b[j]);
    }
}

/// `out[j]` = the extreme of `col[j..j + len]` for `j < out.len()` (`len` in 1..=16) from the
/// doubling levels `m` of `col` (`m[i][j]`: the extreme of `col[j..j + 2^(i+1)]`): the two
/// overlapping power-of-two windows that cover `len`.
#[inline(always)]
fn sliding_extremes<const MAX: bool>(col: &[i16], m: &[Vec<i16>; 3], len: usize, out: &mut [i16]) {
    let (level, p): (&[i16], usize) = match len {
        1 => (col, 1),
        2..=3 => (&m[0], 2),
        4..=7 => (&m[1], 4),
        _ => (&m[2], 8),
    };
    pairwise::<MAX>(level, len - p, out);
}

/// The sliding extremes of one class of a block row of
/// [`FrameFeatures::block_extrema_packed`]: `col[..inner]` the block row's packed column
/// extremes (column `k` is pixel column `BORDER + k`), padded to `inner + PAD` with values that
/// never win; `s.blocks[k]` the extreme of the `n + 1` columns from `k` (a block's when `k` is
/// a block's first column), `s.window[k]` that of the `2n + 1` columns from `k` (a window's
/// centred on `k + n`), by doubling (vectorised loops).
#[inline(always)]
fn sliding_block_extremes<const MAX: bool>(
    col: &[i16],
    inner: usize,
    n: usize,
    s: &mut SlidingScratch,
) {
    let total = col.len();
    pairwise::<MAX>(col, 1, &mut s.m[0][..total - 1]);
    {
        let [m2, m4, m8] = &mut s.m;
        pairwise::<MAX>(&m2[..total - 1], 2, &mut m4[..total - 3]);
        if 2 * n + 1 >= 8 {
            pairwise::<MAX>(&m4[..total - 3], 4, &mut m8[..total - 7]);
        }
    }
    sliding_extremes::<MAX>(col, &s.m, n + 1, &mut s.blocks[..inner]);
    let span = 2 * n + 1;
    let windows = (inner + 1).saturating_sub(span);
    sliding_extremes::<MAX>(col, &s.m, span, &mut s.window[..windows]);
}

/// A block's candidate from [`packed_candidate`]: response, column, row within the block,
/// whether pass 1's block-row check ran, and whether it is a candidate.
type Candidate = (i16, usize, usize, bool, bool);

/// The block row of [`class_candidates`]: its first row, the row after its last, the class.
#[derive(Clone, Copy, Debug)]
struct PassOneRow {
    v0: usize,
    v1: usize,
    class: u8,
}

/// The candidates of one class of a block row of [`FrameFeatures::block_extrema_packed`]
/// (maxima if `MAX`; `col`, `blocks`, `window` as [`packed_candidate`] reads them) into the
/// front of `slots` (one per block), their number returned, in block order. First the strong
/// block extremes are marked, one bit per column in `strong` ([`strong_columns`]: every
/// column's `blocks[k]`, 16 at a time, of which only the blocks' first columns count), then
/// only the blocks whose first column is set in both `strong` and `starts` (the bits of the
/// blocks' first columns) go through [`packed_candidate`], every one written and the count
/// advanced by the outcome. Before, each block and class took the whole candidate step (about
/// 75 instructions), and about a third of the blocks are not strong on the KITTI snippets.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn class_candidates<const MAX: bool>(
    col: &[i16],
    blocks: &[i16],
    window: &[i16],
    inner: usize,
    n: usize,
    tau: i16,
    at: PassOneRow,
    starts: &[u64],
    strong: &mut [u64],
    slots: &mut [Extremum],
) -> usize {
    strong_columns::<MAX>(&blocks[..inner], tau, strong);
    let mut len = 0;
    for (i, (&s, &b)) in strong.iter().zip(starts).enumerate() {
        let mut bits = s & b;
        while bits != 0 {
            let k0 = 64 * i + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let (val, k, r, checked, keep) =
                packed_candidate::<MAX>(col, blocks, window, inner, k0, n, tau);
            let v = at.v0 + r;
            if let Some(slot) = slots.get_mut(len) {
                *slot = Extremum {
                    val,
                    u: (BORDER + k) as u16,
                    v: v as u16,
                    class: at.class,
                    // `v < v1`: the rows below `v` in its block row.
                    cleared: Extremum::cleared_rows(at.v1 - 1 - v, r)
                        & 0u8.wrapping_sub(u8::from(checked)),
                };
            }
            len += usize::from(keep);
        }
    }
    len
}

/// One bit per key of `keys` (bit `k % 64` of word `k / 64` of `bits`, which has at least
/// `keys.len().div_ceil(64)` words): set where the packed key ([`pack_max`], [`pack_min`])
/// holds a strong response, `response >= tau` for maxima (`MAX`), `response <= -tau` for
/// minima. A key `x` holds the response `x >> 3` (the row is in its low 3 bits), so `x >> 3 >=
/// tau` is `x > 8 tau - 1` and `x >> 3 <= -tau` is `x < 8 - 8 tau` (computed in 32 bits and
/// saturated to 16, which changes no answer: every key is a 16-bit value); one vector
/// comparison per 8 keys on x86-64.
#[inline(always)]
fn strong_columns<const MAX: bool>(keys: &[i16], tau: i16, bits: &mut [u64]) {
    let tau = i32::from(tau);
    let t = if MAX { 8 * tau - 1 } else { 8 - 8 * tau }
        .clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16;
    let mut chunks = keys.chunks_exact(64);
    for (word, chunk) in bits.iter_mut().zip(&mut chunks) {
        let mut w = 0u64;
        for (q, c) in chunk.chunks_exact(16).enumerate() {
            let lanes: [i16; 16] = c.try_into().unwrap_or([t; 16]);
            w |= u64::from(mask16::<MAX>(lanes, t)) << (16 * q);
        }
        *word = w;
    }
    let rest = chunks.remainder();
    if let Some(word) = bits.get_mut(keys.len() / 64) {
        *word = rest.iter().enumerate().fold(0, |w, (k, &x)| {
            w | u64::from(if MAX { x > t } else { x < t }) << k
        });
    }
}

/// The 16 bits of `x > t` (`MAX`) or `x < t`: two vector comparisons, a signed byte pack and
/// a byte mask on x86-64.
#[inline(always)]
fn mask16<const MAX: bool>(x: [i16; 16], t: i16) -> u16 {
    #[cfg(target_arch = "x86_64")]
    {
        use safe_arch::{
            cmp_gt_mask_i16_m128i, cmp_lt_mask_i16_m128i, m128i, move_mask_i8_m128i,
            pack_i16_to_i8_m128i, set_splat_i16_m128i,
        };
        let half = |k: usize| m128i::from(std::array::from_fn::<i16, 8, _>(|i| x[8 * k + i]));
        let (a, b, t) = (half(0), half(1), set_splat_i16_m128i(t));
        let (ma, mb) = if MAX {
            (cmp_gt_mask_i16_m128i(a, t), cmp_gt_mask_i16_m128i(b, t))
        } else {
            (cmp_lt_mask_i16_m128i(a, t), cmp_lt_mask_i16_m128i(b, t))
        };
        move_mask_i8_m128i(pack_i16_to_i8_m128i(ma, mb)) as u16
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut m = 0u16;
        for (k, &v) in x.iter().enumerate() {
            m |= u16::from(if MAX { v > t } else { v < t }) << k;
        }
        m
    }
}

/// The candidate of the block starting at column `k0` of one class
/// ([`FrameFeatures::block_extrema_packed`]; `col` the padded column keys, `blocks`, `window`
/// as [`sliding_block_extremes`] leaves them, `inner` the columns without padding): the
/// response, column `k` and row within the block of the first pixel holding the block's
/// extreme, and whether it is a candidate: strong (`|response| >= tau`) and no column extreme
/// of the block row within its window (columns `k - n..=k + n`, where those and the 16 lanes
/// from `k - n` lie inside) beyond the block's best key (a strictly better response, or an
/// equal one in an earlier row of the block row, which comes before the candidate); the fourth
/// field says whether that check ran (then no pixel of the block row in the window is strictly
/// better, and none in the rows above the candidate's is as good). Without branches on the data
/// (whether a block has a candidate is close to a coin toss): every column of the block is
/// compared at once (the padding never equals a block's extreme), the conditions are combined
/// as booleans.
#[inline(always)]
fn packed_candidate<const MAX: bool>(
    col: &[i16],
    blocks: &[i16],
    window: &[i16],
    inner: usize,
    k0: usize,
    n: usize,
    tau: i16,
) -> Candidate {
    let best = blocks[k0];
    let val = best >> 3;
    let strong = if MAX { val >= tau } else { val <= -tau };
    // The first column holding the best key (0 if none, which a strong block cannot be): a
    // mask of the 8 columns from `k0` (inside the padding: `k0 < inner`, `n < 8`), cut to the
    // block's `n + 1`.
    let lanes: [i16; 8] = col
        .get(k0..k0 + 8)
        .and_then(|x| x.try_into().ok())
        .unwrap_or([best; 8]);
    let k = k0 + first_equal_lane(lanes, best, n + 1);
    // A key beyond the block's best: a strictly better response, or an equal one in an
    // earlier row of the block row (inside the window, and before the candidate).
    let threshold = best;
    let checked = (k >= n) & (k.wrapping_sub(n).wrapping_add(LANES) <= inner);
    let lane = window.get(k.wrapping_sub(n)).copied().unwrap_or(threshold);
    let beaten = checked & better::<MAX>(lane, threshold);
    let low = best & 7;
    let r = if MAX { 7 - low } else { low } as usize;
    (val, k, r, checked, strong & !beaten)
}

/// The first of `lanes[..len]` (`len` in 1..=8) equal to `x`, 0 if none: one vector
/// comparison and a byte mask on x86-64 (two mask bits per lane).
#[inline(always)]
fn first_equal_lane(lanes: [i16; 8], x: i16, len: usize) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        use safe_arch::{cmp_eq_mask_i16_m128i, m128i, move_mask_i8_m128i, set_splat_i16_m128i};
        let bytes = move_mask_i8_m128i(cmp_eq_mask_i16_m128i(
            m128i::from(lanes),
            set_splat_i16_m128i(x),
        )) as u32;
        let mask = bytes & ((1u32 << (2 * len)) - 1);
        (mask.trailing_zeros() % 32) as usize / 2
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut mask = 0u32;
        for (j, &y) in lanes.iter().enumerate() {
            mask |= u32::from(y == x) << j;
        }
        mask &= (1u32 << len) - 1;
        (mask.trailing_zeros() % 32) as usize
    }
}

/// A flat pixel of the interleaved Sobel images: `du = dv = 128`.
const SOBEL_FLAT: u16 = 128 | 128 << 8;

/// The descriptor at `(u, v)` from the interleaved Sobel images (`du | dv << 8`).
#[inline]
fn descriptor(sobel: &[u16], w: usize, u: usize, v: usize) -> Descriptor {
    // Gathered first, then split into the du and dv halves (two vectorised byte packs). The
    // pattern reads every other row of the 11x11 window; each of those rows is an array of its
    // 11 columns, so that the samples' columns (constants) need no bounds check: one check per
    // row read (6), not per sample (16).
    const SPAN: usize = 2 * DESCRIPTOR_REACH + 1;
    let top = (v - DESCRIPTOR_REACH) * w + u - DESCRIPTOR_REACH;
    let rows: [&[u16; SPAN]; SPAN.div_ceil(2)] = std::array::from_fn(|i| {
        let at = top + 2 * i * w;
        // A window that does not fit (never: the features lie `DESCRIPTOR_REACH` inside)
        // panics here as before; the fallback is dead (the slice is `SPAN` long).
        let row: &[u16] = &sobel[at..at + SPAN];
        row.try_into().unwrap_or(&[SOBEL_FLAT; SPAN])
    });
    let s: [u16; 16] = std::array::from_fn(|k| {
        let (dx, dy) = PATTERN[k];
        let (dx, dy) = (
            (dx + DESCRIPTOR_REACH as i32) as usize,
            (dy + DESCRIPTOR_REACH as i32) as usize,
        );
        rows[dy / 2][dx]
    });
    split_halves(s)
}

/// The du bytes (low) then the dv bytes (high) of 16 interleaved Sobel samples: on x86-64 two
/// `packuswb` of the masked and the shifted samples (each fits a byte, so the saturation never
/// acts).
#[inline(always)]
fn split_halves(s: [u16; 16]) -> Descriptor {
    #[cfg(target_arch = "x86_64")]
    {
        use safe_arch::{
            bitand_m128i, m128i, pack_i16_to_u8_m128i, set_splat_i16_m128i, shr_imm_u16_m128i,
        };
        let half =
            |k: usize| -> m128i { m128i::from(std::array::from_fn::<u16, 8, _>(|i| s[8 * k + i])) };
        let (a, b) = (half(0), half(1));
        let low = set_splat_i16_m128i(0xff);
        let du: [u8; 16] = pack_i16_to_u8_m128i(bitand_m128i(a, low), bitand_m128i(b, low)).into();
        let dv: [u8; 16] =
            pack_i16_to_u8_m128i(shr_imm_u16_m128i::<8>(a), shr_imm_u16_m128i::<8>(b)).into();
        let mut d = [0u8; 32];
        d[..16].copy_from_slice(&du);
        d[16..].copy_from_slice(&dv);
        d
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut d = [0u8; 32];
        for k in 0..16 {
            d[k] = (s[k] & 0xff) as u8;
            d[16 + k] = (s[k] >> 8) as u8;
        }
        d
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

/// Lanes of the vectorised window checks: a window row of up to 16 columns (`2n + 1 <= 16`).
const LANES: usize = 16;

/// Per-lane offsets that turn the window checks into one strict comparison per lane: lane `k`
/// is column `u - n + k`; a lane beats the candidate `val` when it is strictly better than
/// `val + offset` (saturating). Offset 0: strictly better beats; -1 (maxima) or +1 (minima):
/// at least as good beats; `i16::MAX` (maxima) or `i16::MIN` (minima): never (lanes outside
/// the window, and the candidate itself). Index 0: maxima, 1: minima. Exact for the
/// candidates' signs (strong maxima are at least 1, strong minima at most -1): the offsets -1 /
/// +1 never saturate, and `i16::MAX` / `i16::MIN` always do.
#[derive(Clone, Copy, Debug)]
struct LaneOffsets {
    /// The window fits in [`LANES`] columns.
    fits: bool,
    /// Rows above the candidate (at least as good beats).
    above: [[i16; LANES]; 2],
    /// Rows below (strictly better beats).
    below: [[i16; LANES]; 2],
    /// The candidate's row (left: at least as good, right: strictly better).
    centre: [[i16; LANES]; 2],
    /// The block row's column extremes (strictly better beats; ties are left to the exact
    /// check).
    block_row: [[i16; LANES]; 2],
    /// The lanes inside the window (`k <= 2n`).
    inside: [bool; LANES],
}

impl LaneOffsets {
    fn new(n: usize) -> Self {
        let inside = |k: usize| k <= 2 * n;
        // `NEVER` marks lanes that cannot beat the candidate, `AT_LEAST` those that beat it when
        // equal (maxima's offsets; minima's are mirrored).
        const NEVER: i16 = i16::MAX;
        const AT_LEAST: i16 = -1;
        let lane = |f: &dyn Fn(usize) -> i16| -> [[i16; LANES]; 2] {
            let max: [i16; LANES] = std::array::from_fn(f);
            let min = max.map(|o| if o == NEVER { i16::MIN } else { -o });
            [max, min]
        };
        Self {
            fits: 2 * n < LANES,
            above: lane(&|k| if inside(k) { AT_LEAST } else { NEVER }),
            below: lane(&|k| if inside(k) { 0 } else { NEVER }),
            centre: lane(&|k| match k.cmp(&n) {
                std::cmp::Ordering::Less => AT_LEAST,
                std::cmp::Ordering::Equal => NEVER,
                std::cmp::Ordering::Greater if inside(k) => 0,
                std::cmp::Ordering::Greater => NEVER,
            }),
            block_row: lane(&|k| if inside(k) { 0 } else { NEVER }),
            inside: std::array::from_fn(inside),
        }
    }
}

/// `x` strictly better than `t` (`MAX`: greater, else smaller).
#[inline(always)]
fn better<const MAX: bool>(x: i16, t: i16) -> bool {
    if MAX { x > t } else { x < t }
}

/// The extreme of two values (`MAX`: maximum, else minimum).
#[inline(always)]
fn extreme<const MAX: bool>(x: i16, y: i16) -> i16 {
    if MAX { x.max(y) } else { x.min(y) }
}

/// True if any lane of `x` is strictly better than `val` plus its lane offset (`offsets`: the
/// class's row of a [`LaneOffsets`] array; branch-free, so that it compiles to a few vector
/// comparisons).
#[inline(always)]
fn any_better<const MAX: bool>(x: &[i16; LANES], offsets: &[i16; LANES], val: i16) -> bool {
    let mut any = false;
    for k in 0..LANES {
        any |= better::<MAX>(x[k], val.saturating_add(offsets[k]));
    }
    any
}

/// Pass 1's necessary condition: true if a column extreme of the candidate's block row,
/// `col[k0..k0 + 2n + 1]` (columns `u - n..=u + n`), is strictly better than `val` (then a
/// pixel of the window beats the candidate; ties are left to [`window_check`]). False where the
/// 16 lanes do not fit in `col` (`k0` wraps below zero near the left border).
#[inline(always)]
fn beaten_in_block_row<const MAX: bool>(
    col: &[i16],
    k0: usize,
    offsets: &[i16; LANES],
    val: i16,
) -> bool {
    let lanes: Option<&[i16; LANES]> = col
        .get(k0..k0.wrapping_add(LANES))
        .and_then(|x| x.try_into().ok());
    lanes.is_some_and(|x| any_better::<MAX>(x, offsets, val))
}

/// The window check of [`is_extremum`] for a window of at most 16 columns whose 16 lanes from
/// column `u - n` fit in the image: the rows above `v` reduced to their column-wise extremes,
/// likewise the rows below, then per lane one comparison of each ([`LaneOffsets`]): above, a
/// pixel at least as good beats `val`, below one strictly better; in row `v` those left of `u`
/// when at least as good, those right of it when better. The rows below start after the
/// rows that pass 1 has cleared ([`Extremum::cleared`]: below, none strictly better; above, none at
/// least as good). Row `y` of `img`
/// is at `(y & mask) * w` (a ring of rows, [`FrameFeatures::filter_and_suppress`]).
#[inline(always)]
fn window_check<const MAX: bool>(
    img: &[i16],
    w: usize,
    mask: usize,
    e: Extremum,
    n: usize,
    lanes: &LaneOffsets,
) -> bool {
    let (u, v, val) = (usize::from(e.u), usize::from(e.v), e.val);
    let start = u - n;
    let row = |y: usize| -> [i16; LANES] {
        let at = (y & mask) * w + start;
        let s = &img[at..at + LANES];
        s.try_into().unwrap_or([val; LANES])
    };
    let reduce = |ys: std::ops::Range<usize>| {
        let mut acc = [if MAX { i16::MIN } else { i16::MAX }; LANES];
        for y in ys {
            let r = row(y);
            for k in 0..LANES {
                acc[k] = extreme::<MAX>(acc[k], r[k]);
            }
        }
        acc
    };
    let above = reduce(v - n..v - e.cleared_above().min(n));
    let below = reduce((v + 1 + e.cleared_below()).min(v + n + 1)..v + n + 1);
    let centre = row(v);
    let m = usize::from(!MAX);
    !(any_better::<MAX>(&above, &lanes.above[m], val)
        | any_better::<MAX>(&below, &lanes.below[m], val)
        | any_better::<MAX>(&centre, &lanes.centre[m], val))
}

/// True if `val` at `(u, v)` is the strict maximum (`MAX`, else minimum) of `img` over the
/// `(2n+1)^2` window, ties broken towards the smaller index (row-major): a pixel before
/// `(u, v)` beats it when equal, a pixel after only when strictly better. Each row segment is
/// reduced to its extreme without branches, then compared. Row `y` of `img` is at
/// `(y & mask) * w`.
#[allow(clippy::too_many_arguments)]
fn is_extremum<const MAX: bool>(
    img: &[i16],
    w: usize,
    h: usize,
    mask: usize,
    u: usize,
    v: usize,
    n: usize,
    val: i16,
) -> bool {
    let (x0, x1) = (u.saturating_sub(n), (u + n + 1).min(w));
    let extreme = |s: &[i16]| {
        if MAX {
            s.iter().copied().fold(i16::MIN, i16::max)
        } else {
            s.iter().copied().fold(i16::MAX, i16::min)
        }
    };
    // Pixels before `(u, v)` beat it when at least as good, pixels after when better.
    let beaten = |m: i16, earlier: bool| {
        if MAX {
            m > val || (earlier && m == val)
        } else {
            m < val || (earlier && m == val)
        }
    };
    let row = |y: usize| &img[(y & mask) * w + x0..(y & mask) * w + x1];
    let centre = row(v);
    let k = u - x0;
    if beaten(extreme(&centre[..k]), true) || beaten(extreme(&centre[k + 1..]), false) {
        return false;
    }
    for d in 1..=n {
        if d <= v && beaten(extreme(row(v - d)), true) {
            return false;
        }
        if v + d < h && beaten(extreme(row(v + d)), false) {
            return false;
        }
    }
    true
}

/// The Sobel images and the blob and corner responses of an image, rows in parallel.
///
/// Sobel: 3x3 responses stored as `128 + response / 4` clamped to a byte (border rows and
/// columns: 128). Blob and corner: the 5x5 masks (zero within 2 pixels of the border). A
/// vertical pass over 5 rows into column sums (the filters' and, from its middle three rows, the
/// Sobel images'; 3 rows next to the border), then horizontal passes over shifted slices of
/// those sums, all in 16-bit integers (no overflow: |blob| <= 16 * 255, box sums <= 25 * 255).
///
/// Only `rows` are computed. The Sobel images are whole (row `y` at `y * w`); the blob and
/// corner responses are a ring of `ring` rows (a power of two, at least `rows.len()`; row `y` at
/// `(y & (ring - 1)) * w`).
#[inline(never)]
fn responses(
    px: &[u8],
    w: usize,
    h: usize,
    rows: std::ops::Range<usize>,
    ring: usize,
    sobel: &mut [u16],
    blob: &mut [i16],
    corner: &mut [i16],
) {
    // The rows in pieces that do not wrap around the ring.
    let mut a = rows.start;
    while a < rows.end {
        let b = rows.end.min((a / ring + 1) * ring);
        let r = (a % ring) * w..(a % ring + b - a) * w;
        responses_unwrapped(
            px,
            w,
            h,
            a..b,
            &mut sobel[a * w..b * w],
            &mut blob[r.clone()],
            &mut corner[r],
        );
        a = b;
    }
}

/// [`responses`] of `rows`, into `sobel`, `blob` and `corner` holding just those rows.
fn responses_unwrapped(
    px: &[u8],
    w: usize,
    h: usize,
    rows: std::ops::Range<usize>,
    sobel: &mut [u16],
    blob: &mut [i16],
    corner: &mut [i16],
) {
    sobel
        .par_chunks_mut(w)
        .zip(blob.par_chunks_mut(w))
        .zip(corner.par_chunks_mut(w))
        .enumerate()
        .with_min_len(4)
        .for_each_init(
            || {
                let mut s = Reused::take(&FILTER_SCRATCH);
                for row in s.iter_mut() {
                    row.resize(w, 0);
                }
                s
            },
            |s, (i, ((rs, rb), rc))| {
                let [s0, s1, s2, s3, s4] = &mut **s;
                let y = rows.start + i;
                let row = |k: usize| &px[k * w..(k + 1) * w];
                if y < 2 || y + 2 >= h {
                    rb.fill(0);
                    rc.fill(0);
                    if y == 0 || y + 1 == h {
                        rs.fill(SOBEL_FLAT);
                    } else {
                        sobel_row(row(y - 1), row(y), row(y + 1), rs, s0, s1);
                    }
                } else {
                    // One vertical pass over the five rows for the filters and the Sobel
                    // images (its three middle rows).
                    let rows = [row(y - 2), row(y - 1), row(y), row(y + 1), row(y + 2)];
                    filter_row(rows, rb, rc, [s0, s1, s2], [s3, s4]);
                    sobel_horizontal(s3, s4, rs);
                }
            },
        );
}

/// One row of the interleaved Sobel images (`du | dv << 8`) from the rows above (`a`), at
/// (`b`) and below (`c`); `vs` and `vd` are scratch rows.
fn sobel_row(a: &[u8], b: &[u8], c: &[u8], rs: &mut [u16], vs: &mut [i16], vd: &mut [i16]) {
    let w = rs.len();
    let (a, b, c) = (&a[..w], &b[..w], &c[..w]);
    let (vs, vd) = (&mut vs[..w], &mut vd[..w]);
    // Vertical: smoothing [1 2 1] and derivative [-1 0 1].
    for x in 0..w {
        let (p, q, r) = (i16::from(a[x]), i16::from(b[x]), i16::from(c[x]));
        vs[x] = p + 2 * q + r;
        vd[x] = r - p;
    }
    sobel_horizontal(vs, vd, rs);
}

/// The horizontal pass of the Sobel images: from the vertically smoothed (`vs`, [1 2 1]) and
/// differentiated (`vd`, [-1 0 1]) columns, the derivative of the smoothed columns (du) and
/// the smoothing of the derivatives (dv), interleaved.
fn sobel_horizontal(vs: &[i16], vd: &[i16], rs: &mut [u16]) {
    let w = rs.len();
    let n = w - 2;
    let (sl, sr) = (&vs[..n], &vs[2..2 + n]);
    let (dl, dc, dr) = (&vd[..n], &vd[1..1 + n], &vd[2..2 + n]);
    let out = &mut rs[1..1 + n];
    // Eight pixels at a time on x86-64 ([`sobel_lanes`]), the rest one by one.
    #[cfg(target_arch = "x86_64")]
    let done = {
        let lanes = |s: &[i16]| -> [i16; 8] { s.try_into().unwrap_or([0; 8]) };
        let mut done = 0;
        for ((((o, l), r), (a, b)), c) in out
            .chunks_exact_mut(8)
            .zip(sl.chunks_exact(8))
            .zip(sr.chunks_exact(8))
            .zip(dl.chunks_exact(8).zip(dc.chunks_exact(8)))
            .zip(dr.chunks_exact(8))
        {
            o.copy_from_slice(&sobel_lanes(
                lanes(l),
                lanes(r),
                [lanes(a), lanes(b), lanes(c)],
            ));
            done += 8;
        }
        done
    };
    #[cfg(not(target_arch = "x86_64"))]
    let done = 0;
    for x in done..n {
        let du = (128 + (sr[x] - sl[x]) / 4).clamp(0, 255) as u16;
        let dv = (128 + (dl[x] + 2 * dc[x] + dr[x]) / 4).clamp(0, 255) as u16;
        out[x] = du | dv << 8;
    }
    rs[0] = SOBEL_FLAT;
    rs[w - 1] = SOBEL_FLAT;
}

/// Eight pixels of [`sobel_horizontal`]: `du = clamp(128 + (r - l) / 4)` and `dv = clamp(128 +
/// (a + 2b + c) / 4)` (division truncating toward zero, clamp to `0..=255`), interleaved as `du |
/// dv << 8`. The division adds 3 to negative sums before the arithmetic shift by 2; the clamp
/// is the unsigned saturation of `packuswb`, which also puts the eight du bytes before the
/// eight dv bytes, and `punpcklbw` with the upper half interleaves them.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn sobel_lanes(l: [i16; 8], r: [i16; 8], [a, b, c]: [[i16; 8]; 3]) -> [u16; 8] {
    use safe_arch::{
        add_i16_m128i, byte_shr_imm_u128_m128i, m128i, pack_i16_to_u8_m128i, set_splat_i16_m128i,
        shr_imm_i16_m128i, shr_imm_u16_m128i, sub_i16_m128i, unpack_low_i8_m128i,
    };
    let offset = set_splat_i16_m128i(128);
    let quarter = |x: m128i| {
        let bias = shr_imm_u16_m128i::<14>(shr_imm_i16_m128i::<15>(x));
        add_i16_m128i(shr_imm_i16_m128i::<2>(add_i16_m128i(x, bias)), offset)
    };
    let du = quarter(sub_i16_m128i(m128i::from(r), m128i::from(l)));
    let b = m128i::from(b);
    let dv = quarter(add_i16_m128i(
        add_i16_m128i(m128i::from(a), m128i::from(c)),
        add_i16_m128i(b, b),
    ));
    let bytes = pack_i16_to_u8_m128i(du, dv);
    unpack_low_i8_m128i(bytes, byte_shr_imm_u128_m128i::<8>(bytes)).into()
}

/// One row of the blob and corner responses from the five rows around it (`c5`, `g`, `d`
/// scratch rows), and the vertical pass of the Sobel images of its middle row into `[vs, vd]`
/// (for [`sobel_horizontal`]): `vs = c3 + r2` is the [1 2 1] smoothing, `vd = r3 - r1` the
/// [-1 0 1] derivative. Not inlined, so that the five rows stay five pointers (inlined, the
/// compiler may recompute them from one another inside the loop).
///
/// Per column, `c5` is the sum of the five rows, `c3` of the middle three and `d` the corner
/// mask's column term. The blob mask `2 box3 - box5 + 7 centre` is summed as `g = 2 c3 - c5`
/// over the middle three columns less `c5` of the outer two: `2 (c3[-1] + c3[0] + c3[1]) -
/// (c5[-2] + ... + c5[2]) = g[-1] + g[0] + g[1] - c5[-2] - c5[2]`, 5 loads and 4 additions
/// per pixel where the two box sums took 8 and 7 (the same integers: every partial sum fits 16
/// bits).
#[inline(never)]
fn filter_row(
    rows: [&[u8]; 5],
    rb: &mut [i16],
    rc: &mut [i16],
    [c5, g, d]: [&mut [i16]; 3],
    [vs, vd]: [&mut [i16]; 2],
) {
    let w = rb.len();
    let [r0, r1, r2, r3, r4] = rows.map(|r| &r[..w]);
    let (c5, g, d) = (&mut c5[..w], &mut g[..w], &mut d[..w]);
    let (vs, vd) = (&mut vs[..w], &mut vd[..w]);
    for x in 0..w {
        let (a, b, c, e, f) = (
            i16::from(r0[x]),
            i16::from(r1[x]),
            i16::from(r2[x]),
            i16::from(r3[x]),
            i16::from(r4[x]),
        );
        // `m` is the column's `c3`, `m + af` its `c5`.
        let m = b + c + e;
        let af = a + f;
        c5[x] = m + af;
        g[x] = m - af;
        d[x] = (e + f) - (a + b);
        vs[x] = m + c;
        vd[x] = e - b;
    }
    let n = w - 4;
    let (p0, p4) = (&c5[..n], &c5[4..4 + n]);
    let (g1, g2, g3) = (&g[1..1 + n], &g[2..2 + n], &g[3..3 + n]);
    let (d0, d1, d3, d4) = (&d[..n], &d[1..1 + n], &d[3..3 + n], &d[4..4 + n]);
    let centre = &r2[2..2 + n];
    let (ob, oc) = (&mut rb[2..2 + n], &mut rc[2..2 + n]);
    for x in 0..n {
        ob[x] = (g1[x] + g2[x] + g3[x]) - (p0[x] + p4[x]) + 7 * i16::from(centre[x]);
        oc[x] = d0[x] + d1[x] - d3[x] - d4[x];
    }
    rb[..2].fill(0);
    rc[..2].fill(0);
    rb[w - 2..].fill(0);
    rc[w - 2..].fill(0);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The descriptor equals its definition: du at the 16 `PATTERN` positions, then dv, on
    /// Sobel values that use every byte value in both halves, at every pixel 5 inside.
    #[test]
    fn descriptor_equals_the_pattern() {
        let (w, h) = (29usize, 17usize);
        let sobel: Vec<u16> = (0..w * h)
            .map(|i| ((i * 37 % 256) | (i * 101 % 256) << 8) as u16)
            .collect();
        for v in 5..h - 5 {
            for u in 5..w - 5 {
                let d = descriptor(&sobel, w, u, v);
                for (k, &(dx, dy)) in PATTERN.iter().enumerate() {
                    let s = sobel[(v as i32 + dy) as usize * w + (u as i32 + dx) as usize];
                    assert_eq!(d[k], (s & 0xff) as u8, "du {k} at {u},{v}");
                    assert_eq!(d[16 + k], (s >> 8) as u8, "dv {k} at {u},{v}");
                }
            }
        }
    }

    /// The strong keys' bits equal the definition `key >> 3 >= tau` (maxima) or `key >> 3 <=
    /// -tau` (minima): lengths across the 16-lane chunks and the 64-bit words, keys over the
    /// whole 16-bit range with the thresholds' neighbours, thresholds up to `i16::MAX` (where
    /// `8 tau` leaves 16 bits).
    #[test]
    fn strong_columns_equal_the_definition() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for tau in [1i16, 2, 50, 600, 4095, 4096, 4097, i16::MAX] {
            for len in [0usize, 1, 15, 16, 17, 63, 64, 65, 130, 1225] {
                let keys: Vec<i16> = (0..len)
                    .map(|_| {
                        let r = next();
                        let near = |t: i32| (t + (r >> 8) as i32 % 3 - 1) as i16;
                        match r % 5 {
                            0 => near(8 * i32::from(tau)),
                            1 => near(-8 * i32::from(tau) + 7),
                            2 => [i16::MIN, i16::MAX, 0, -1][(r >> 8) as usize % 4],
                            _ => (r >> 16) as i16,
                        }
                    })
                    .collect();
                let mut bits = vec![u64::MAX; len.div_ceil(64)];
                for max in [true, false] {
                    if max {
                        strong_columns::<true>(&keys, tau, &mut bits);
                    } else {
                        strong_columns::<false>(&keys, tau, &mut bits);
                    }
                    for (k, &x) in keys.iter().enumerate() {
                        let expected = if max { x >> 3 >= tau } else { x >> 3 <= -tau };
                        let got = bits[k / 64] >> (k % 64) & 1 == 1;
                        assert_eq!(got, expected, "tau {tau} len {len} max {max} key {x}");
                    }
                    if len % 64 != 0 {
                        assert_eq!(bits[len / 64] >> (len % 64), 0, "tau {tau} len {len}");
                    }
                }
            }
        }
    }

    /// The vectorised search of the first equal lane gives the scalar loop's answer: every
    /// mask of 8 lanes, every length, 0 where none is equal.
    #[test]
    fn first_equal_lane_equals_the_loop() {
        for bits in 0u32..256 {
            let lanes: [i16; 8] =
                std::array::from_fn(|j| if bits >> j & 1 == 1 { -3 } else { j as i16 });
            for len in 1..=8 {
                let expected = (0..len).find(|&j| lanes[j] == -3).unwrap_or(0);
                assert_eq!(
                    first_equal_lane(lanes, -3, len),
                    expected,
                    "{bits:08b} {len}"
                );
            }
        }
    }

    /// The separable 16-bit filters equal the 5x5 masks and the 3x3 Sobel masks applied
    /// directly, on a texture with the extreme values 0 and 255.
    #[test]
    fn filters_equal_the_masks() {
        let (w, h) = (23usize, 11usize);
        let px: Vec<u8> = (0..w * h)
            .map(|i| match i % 7 {
                0 => 0,
                3 => 255,
                _ => ((i * 37 + i * i * 11) % 251) as u8,
            })
            .collect();
        // A ring of at least `h` rows holds the whole image (row `y` at `y * w`).
        let ring = h.next_power_of_two();
        let mut blob = vec![0i16; ring * w];
        let mut corner = vec![0i16; ring * w];
        let mut sobel = vec![0u16; w * h];
        responses(&px, w, h, 0..h, ring, &mut sobel, &mut blob, &mut corner);
        let du: Vec<u8> = sobel.iter().map(|s| (s & 0xff) as u8).collect();
        let dv: Vec<u8> = sobel.iter().map(|s| (s >> 8) as u8).collect();
        let at = |x: usize, y: usize| i32::from(px[y * w + x]);
        for y in 0..h {
            for x in 0..w {
                let (eu, ev) = if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                    (128, 128)
                } else {
                    let gu = at(x + 1, y - 1) + 2 * at(x + 1, y) + at(x + 1, y + 1)
                        - at(x - 1, y - 1)
                        - 2 * at(x - 1, y)
                        - at(x - 1, y + 1);
                    let gv = at(x - 1, y + 1) + 2 * at(x, y + 1) + at(x + 1, y + 1)
                        - at(x - 1, y - 1)
                        - 2 * at(x, y - 1)
                        - at(x + 1, y - 1);
                    ((128 + gu / 4).clamp(0, 255), (128 + gv / 4).clamp(0, 255))
                };
                assert_eq!(i32::from(du[y * w + x]), eu, "du at {x},{y}");
                assert_eq!(i32::from(dv[y * w + x]), ev, "dv at {x},{y}");
                if x < 2 || y < 2 || x + 2 >= w || y + 2 >= h {
                    assert_eq!(
                        (blob[y * w + x], corner[y * w + x]),
                        (0, 0),
                        "border {x},{y}"
                    );
                }
            }
        }
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

    /// The two-pass block suppression finds exactly the features of its definition, checked
    /// pixel by pixel: strong responses inside the border that are the strict extremum of their
    /// window (ties to the earlier pixel), on textured images with ties (flat areas, repeated
    /// values) for several radii.
    #[test]
    fn suppression_equals_the_brute_force_definition() {
        for (seed, n) in [(1u64, 5usize), (2, 3), (3, 1), (4, 7), (5, 8)] {
            let (w, h) = (97usize, 61usize);
            let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
            let mut img = GrayImage::new(w as u32, h as u32);
            for (i, p) in img.pixels_mut().enumerate() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                // Blocks of flat gray (ties) between noisy areas, values quantised to 8 levels.
                let flat = (i % w) / 16 % 3 == 0;
                p.0[0] = if flat {
                    100
                } else {
                    ((state >> 33) % 8 * 32) as u8
                };
            }
            let options = DetectorOptions {
                nms_radius: n,
                threshold: 50,
            };
            let mut f = FrameFeatures::default();
            f.extract(&img, &options);
            // The ring wraps for the small radii (for 7 and 8 it holds the 61 rows).
            assert!(n > 5 || f.ring < h, "n {n}: ring of {} rows", f.ring);
            let (blob, corner) = whole_responses(&img);
            let step = n + 1;
            // The block grid's extent (pixels past the last whole block row are not searched).
            let rows_end = BORDER + (h - 2 * BORDER).div_ceil(step) * step;
            for class in 0..CLASSES {
                let resp = if class < 2 { &blob } else { &corner };
                let maximum = class % 2 == 0;
                let mut expected = Vec::new();
                for v in BORDER..(h - BORDER).min(rows_end) {
                    for u in BORDER..w - BORDER {
                        let val = resp[v * w + u];
                        let strong = if maximum { val >= 50 } else { val <= -50 };
                        if !strong {
                            continue;
                        }
                        let mut best = true;
                        for y in v.saturating_sub(n)..(v + n + 1).min(h) {
                            for x in u.saturating_sub(n)..(u + n + 1).min(w) {
                                if (y, x) == (v, u) {
                                    continue;
                                }
                                let p = resp[y * w + x];
                                let earlier = (y, x) < (v, u);
                                let beats = if maximum {
                                    p > val || (earlier && p == val)
                                } else {
                                    p < val || (earlier && p == val)
                                };
                                best &= !beats;
                            }
                        }
                        if best {
                            expected.push((v as u16, u as u16));
                        }
                    }
                }
                let mut found: Vec<(u16, u16)> =
                    f.classes[class].points.iter().map(|p| (p.v, p.u)).collect();
                found.sort_unstable();
                assert!(!expected.is_empty(), "seed {seed} class {class}: none");
                assert_eq!(found, expected, "seed {seed} n {n} class {class}");
            }
        }
    }

    /// Filtering and suppressing strip by strip gives the same features and Sobel images
    /// whatever the strip (and so the ring of response rows): one block row at a time, the
    /// default, and the whole image at once (radii 1 to 8, so both pass-1 paths and the
    /// descriptors' 5-row reach).
    /// The blob and corner responses of the whole image (row `y` at `y * w`).
    fn whole_responses(img: &GrayImage) -> (Vec<i16>, Vec<i16>) {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let ring = h.next_power_of_two();
        let (mut blob, mut corner) = (vec![0i16; ring * w], vec![0i16; ring * w]);
        let mut sobel = vec![0u16; w * h];
        responses(
            img.as_raw(),
            w,
            h,
            0..h,
            ring,
            &mut sobel,
            &mut blob,
            &mut corner,
        );
        (blob, corner)
    }

    #[test]
    fn strips_do_not_change_the_features() {
        let (w, h) = (97usize, 83usize);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let px: Vec<u8> = (0..w * h)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let (x, y) = (i % w, i / w);
                if (x / 7 + y / 5) % 3 == 0 {
                    120
                } else {
                    (state >> 56) as u8
                }
            })
            .collect();
        for n in [1usize, 2, 3, 5, 7, 8] {
            let options = DetectorOptions {
                nms_radius: n,
                threshold: 30,
            };
            let run = |strip_rows: usize| {
                let mut f = FrameFeatures {
                    width: w,
                    height: h,
                    sobel: vec![0; w * h],
                    ..FrameFeatures::default()
                };
                f.filter_and_suppress(&px, &options, strip_rows);
                f
            };
            let whole = run(usize::MAX / 2);
            assert!(whole.len() > 20, "n {n}: {} features", whole.len());
            for strip_rows in [1, STRIP_ROWS] {
                let f = run(strip_rows);
                for (a, b) in f.classes.iter().zip(&whole.classes) {
                    assert_eq!(a.points, b.points, "n {n} strip {strip_rows}");
                }
                assert!(f.sobel == whole.sobel, "n {n} strip {strip_rows}");
            }
        }
    }

    /// The packed pass 1 keeps the column search's block extrema, less some that the exact
    /// window check rejects (its check also rejects on an equal response in an earlier row of
    /// the block row), and the rows it marks as cleared hold no pixel that beats the candidate
    /// (above: none at least as good, below: none strictly better), on textured images with
    /// ties (flat areas, quantised values) and the extreme responses of both filters, for
    /// every radius it handles.
    #[test]
    fn packed_pass_one_equals_the_column_search() {
        for seed in 1u64..=4 {
            let (w, h) = (131usize, 77usize);
            let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
            let mut img = GrayImage::new(w as u32, h as u32);
            for (i, p) in img.pixels_mut().enumerate() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let (x, y) = (i % w, i / w);
                p.0[0] = match (x / 12 + y / 9) % 4 {
                    0 => 90,
                    // A checkerboard of 0 and 255: the largest |corner| and |blob| responses.
                    1 => {
                        if (x + y) % 2 == 0 {
                            255
                        } else {
                            0
                        }
                    }
                    2 => ((state >> 33) % 2 * 255) as u8,
                    _ => ((state >> 33) % 8 * 32) as u8,
                };
            }
            for n in 1..PACKED_ROWS {
                let mut f = FrameFeatures::default();
                f.extract(
                    &img,
                    &DetectorOptions {
                        nms_radius: n,
                        threshold: 50,
                    },
                );
                // Pass 1 over every block row reads the whole image's responses.
                (f.blob, f.corner) = whole_responses(&img);
                f.ring = h.next_power_of_two();
                for tau in [1i16, 50, 600] {
                    let rows: Vec<usize> = (BORDER..f.height - BORDER).step_by(n + 1).collect();
                    let a = f.block_extrema(&rows, n, tau);
                    let mut keys = vec![0; rows.len() * CLASSES * (w - 2 * BORDER + PAD)];
                    let b = f.block_extrema_packed(&rows, n, tau, &mut keys);
                    let key = |e: &Extremum| (e.class, e.val, e.u, e.v);
                    let mask = f.ring - 1;
                    let exact = |e: &Extremum| {
                        let img = if e.class < 2 { &f.blob } else { &f.corner };
                        let (u, v) = (usize::from(e.u), usize::from(e.v));
                        if e.class % 2 == 0 {
                            is_extremum::<true>(img, w, h, mask, u, v, n, e.val)
                        } else {
                            is_extremum::<false>(img, w, h, mask, u, v, n, e.val)
                        }
                    };
                    let mut rejected = 0;
                    for (ra, rb) in a.iter().zip(&b) {
                        // `rb` is `ra` less some candidates, in the same order.
                        let mut rest = rb.iter().peekable();
                        for e in ra {
                            if rest.peek().is_some_and(|x| key(x) == key(e)) {
                                rest.next();
                            } else {
                                assert!(!exact(e), "seed {seed} n {n} tau {tau}: {e:?}");
                                rejected += 1;
                            }
                        }
                        assert!(rest.next().is_none(), "seed {seed} n {n} tau {tau}");
                    }
                    assert!(rejected * 10 < a.iter().flatten().count(), "{rejected}");
                    assert!(b.iter().flatten().count() > 0, "seed {seed} n {n}: none");
                    // The cleared rows by brute force.
                    for e in b.iter().flatten() {
                        let img = if e.class < 2 { &f.blob } else { &f.corner };
                        let (u, v) = (usize::from(e.u), usize::from(e.v));
                        let beats = |x: i16, equal: bool| {
                            let better = if e.class % 2 == 0 {
                                x > e.val
                            } else {
                                x < e.val
                            };
                            better || (equal && x == e.val)
                        };
                        let cols = u.saturating_sub(n)..(u + n + 1).min(w);
                        for y in v - e.cleared_above()..v {
                            for x in cols.clone() {
                                assert!(!beats(img[(y & mask) * w + x], true), "{e:?} {x} {y}");
                            }
                        }
                        for y in v + 1..=v + e.cleared_below() {
                            for x in cols.clone() {
                                assert!(!beats(img[(y & mask) * w + x], false), "{e:?} {x} {y}");
                            }
                        }
                    }
                }
            }
        }
    }

    /// The SAD (`psadbw` on x86-64, the query held in registers in the window scans) equals the
    /// byte-wise sum of absolute differences, extremes 0 and 255 included.
    #[test]
    fn sad_equals_the_byte_loop() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut descs: Vec<Descriptor> = vec![[0; 32], [255; 32]];
        for _ in 0..200 {
            descs.push(std::array::from_fn(|_| match next() % 5 {
                0 => 0,
                1 => 255,
                _ => (next() >> 40) as u8,
            }));
        }
        for a in &descs {
            let query = Query::new(a);
            for b in &descs {
                let expected: u32 = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| u32::from(x.abs_diff(*y)))
                    .sum();
                assert_eq!(sad(a, b), expected);
                assert_eq!(query.sad(b), expected);
            }
        }
        assert_eq!(sad(&descs[0], &descs[1]), 32 * 255);
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

//! Matching features between consecutive frames of one camera, and the streaming
//! [`FrameMatcher`] over a multi-camera sequence.
//!
//! For each frame pair `(k-1, k)` and camera:
//! 1. *Candidates*: the image is cut into a grid of about `matches_per_frame` cells; in each
//!    cell the `candidates_per_cell` strongest features of each class in frame `k-1` are
//!    matched (so that effort goes where the output will come from, spread over the image).
//! 2. *Forward*: the feature of the same class in frame `k` with the smallest SAD inside the
//!    search window (`max_flow_u` x `max_flow_v` pixels around the candidate's position; in a
//!    [`FrameMatcher`] with `prior_margin`, the window of the [`FlowPrior`] of the last frame
//!    pair's matches: their flows near the candidate plus the margin).
//! 3. *Backward (circular check)*: from that feature, the best feature of frame `k-1` in the
//!    same window must be the candidate itself; otherwise the match is dropped.
//!    Before that, the forward match must be unique: its SAD at most `uniqueness` times the
//!    second best in the window.
//! 4. *Sub-pixel*: both positions are the vertices of the parabolas through the filter response
//!    around the detected pixels (per axis), so a feature moves with the image content.
//! 5. *Bucketing*: each grid cell gives at most one match per round, best SAD first, rounds
//!    repeat until `matches_per_frame` matches are chosen or none are left.
//! 6. *KLT refinement* (`klt`, on by default; [`crate::refine`]): the chosen matches start from
//!    the integer pixels, frame k's end is aligned to frame k-1's patch and checked backward;
//!    a quarter more matches are chosen in step 5 so that those the check drops are replaced
//!    (bucketed again). Step 4 is then skipped.

use crate::error::MatchError;
use crate::features::{CLASSES, DetectorOptions, Feature, FrameFeatures, MIN_SIDE};
use crate::refine::{KltOptions, MAX_HALF, prefetch_patch, refine_match};
use image::GrayImage;
use rayon::prelude::*;
use std::borrow::Cow;

/// Options of the matcher.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchOptions {
    /// Matches per frame pair and camera after bucketing (the paper: 100-300).
    pub matches_per_frame: usize,
    /// Candidates per grid cell and feature class matched in each frame pair.
    pub candidates_per_cell: usize,
    /// Half-width of the search window in u, pixels (the largest horizontal flow).
    pub max_flow_u: u32,
    /// Half-height of the search window in v, pixels (the largest vertical flow).
    pub max_flow_v: u32,
    /// Largest accepted SAD of two 32-byte descriptors.
    pub max_sad: u32,
    /// Uniqueness: the best SAD must be at most this fraction of the second best in the
    /// search window (1 disables the test).
    pub uniqueness: f64,
    /// Sub-pixel positions: both pixels at the vertex of the parabola through their filter
    /// response (else the integer pixels of the detector).
    pub subpixel: bool,
    /// KLT refinement of the chosen matches (`refine`): frame k-1's patch around the feature's
    /// integer pixel aligned with frame k; replaces the parabola vertices (`subpixel`). `None`:
    /// off. On by default (11x11 patches, forward-backward check at 0.3 px).
    pub klt: Option<KltOptions>,
    /// Threads of the front end (cameras, filter rows and matches in parallel with rayon): 0
    /// uses rayon's global pool (all cores), `n` a pool of its own with `n` threads. The
    /// matches do not depend on it.
    pub threads: usize,
    /// Search around the predicted flow ([`FlowPrior`], the previous frame pair's matches, in
    /// [`FrameMatcher`]): the window spans the flows of the previous matches near the candidate
    /// plus this margin `[u, v]`, pixels (within the `max_flow` window); where too few previous
    /// matches are near, or when fewer than half of `matches_per_frame` are found, the full
    /// window is searched. `None`: always the full window.
    pub prior_margin: Option<[u32; 2]>,
    /// The detector.
    pub detector: DetectorOptions,
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self {
            matches_per_frame: 200,
            candidates_per_cell: 2,
            max_flow_u: 200,
            max_flow_v: 100,
            max_sad: 32 * 40,
            uniqueness: 0.8,
            subpixel: true,
            klt: Some(KltOptions::default()),
            threads: 0,
            prior_margin: Some([16, 8]),
            detector: DetectorOptions::default(),
        }
    }
}

impl MatchOptions {
    /// Checks the ranges: at least one match and one candidate per cell, a non-zero window.
    pub fn validate(&self) -> Result<(), MatchError> {
        if self.matches_per_frame == 0 {
            return Err(MatchError::Option(
                "matches per frame must be at least 1".into(),
            ));
        }
        if self.candidates_per_cell == 0 {
            return Err(MatchError::Option(
                "candidates per cell must be at least 1".into(),
            ));
        }
        if self.max_flow_u == 0 || self.max_flow_v == 0 {
            return Err(MatchError::Option(
                "the search window (max flow) must be at least 1 pixel".into(),
            ));
        }
        if self.threads > 256 {
            return Err(MatchError::Option(format!(
                "threads must be at most 256, found {}",
                self.threads
            )));
        }
        if !(self.uniqueness > 0.0 && self.uniqueness <= 1.0) {
            return Err(MatchError::Option(format!(
                "uniqueness must be in (0, 1], found {}",
                self.uniqueness
            )));
        }
        if self.detector.nms_radius == 0 || self.detector.nms_radius > 20 {
            return Err(MatchError::Option(format!(
                "the non-maximum suppression radius must be in 1..=20, found {}",
                self.detector.nms_radius
            )));
        }
        if let Some(k) = &self.klt {
            if k.half == 0 || k.half > MAX_HALF {
                return Err(MatchError::Option(format!(
                    "the KLT patch half-width must be in 1..={MAX_HALF}, found {}",
                    k.half
                )));
            }
            if k.iterations == 0 {
                return Err(MatchError::Option(
                    "the KLT refinement needs at least one iteration".into(),
                ));
            }
            if !(k.max_shift > 0.0 && k.max_shift.is_finite()) {
                return Err(MatchError::Option(format!(
                    "the KLT largest shift must be a positive number, found {}",
                    k.max_shift
                )));
            }
            if !(k.fb_threshold >= 0.0 && k.fb_threshold.is_finite()) {
                return Err(MatchError::Option(format!(
                    "the forward-backward threshold must be a number >= 0, found {}",
                    k.fb_threshold
                )));
            }
        }
        if self.detector.threshold <= 0 {
            return Err(MatchError::Option(format!(
                "the detector threshold must be positive, found {}",
                self.detector.threshold
            )));
        }
        Ok(())
    }
}

/// One match: pixel in frame k-1, pixel in frame k, descriptor SAD.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    /// Column in frame k-1.
    pub u0: f64,
    /// Row in frame k-1.
    pub v0: f64,
    /// Column in frame k.
    pub u1: f64,
    /// Row in frame k.
    pub v1: f64,
    /// SAD of the descriptors (lower is better).
    pub sad: u32,
}

/// The bucketing grid: about `n` square cells over a `w x h` image.
#[derive(Clone, Copy, Debug)]
struct Grid {
    cell: f64,
    cols: usize,
    rows: usize,
}

impl Grid {
    fn new(w: usize, h: usize, n: usize) -> Self {
        let cell = ((w * h) as f64 / n.max(1) as f64).sqrt().max(1.0);
        Self {
            cell,
            cols: ((w as f64 / cell).ceil() as usize).max(1),
            rows: ((h as f64 / cell).ceil() as usize).max(1),
        }
    }

    fn of(&self, u: f64, v: f64) -> usize {
        let c = ((u / self.cell) as usize).min(self.cols - 1);
        let r = ((v / self.cell) as usize).min(self.rows - 1);
        r * self.cols + c
    }

    fn len(&self) -> usize {
        self.cols * self.rows
    }
}

/// Side of the cells of a [`FlowPrior`], pixels.
const PRIOR_CELL: usize = 64;

/// A prediction of the flow from frame k-1 to k: the flows `(u1 - u0, v1 - v0)` of the matches
/// of the pair `(k-2, k-1)`, binned by their position in frame k-1 into cells of
/// `PRIOR_CELL` pixels; a candidate's search window spans the flows of its cell and the 8
/// around it (constant motion: a point keeps roughly the flow of its neighbours of the last
/// pair), plus a margin.
#[derive(Clone, Debug, Default)]
pub struct FlowPrior {
    cols: usize,
    rows: usize,
    /// Per cell: the window `(offset u, offset v, half-width, half-height)`, or `None` (full
    /// window) with fewer than 2 flows around.
    windows: Vec<Option<[i32; 4]>>,
}

impl FlowPrior {
    /// The prior of the matches of one frame pair (positions in frame k of that pair) in a
    /// `w x h` image, with the window margin `[u, v]` and the largest window `[ru, rv]`.
    pub fn from_matches(
        matches: &[Match],
        (w, h): (usize, usize),
        margin: [u32; 2],
        max_flow: [u32; 2],
    ) -> Self {
        let cols = w.div_ceil(PRIOR_CELL).max(1);
        let rows = h.div_ceil(PRIOR_CELL).max(1);
        // Per cell: flow bounds (min u, max u, min v, max v) and count.
        let mut bounds = vec![[i32::MAX, i32::MIN, i32::MAX, i32::MIN, 0]; cols * rows];
        for m in matches {
            if !(m.u1 >= 0.0 && m.v1 >= 0.0) {
                continue;
            }
            let c = ((m.u1 as usize) / PRIOR_CELL).min(cols - 1);
            let r = ((m.v1 as usize) / PRIOR_CELL).min(rows - 1);
            let (du, dv) = ((m.u1 - m.u0).round() as i32, (m.v1 - m.v0).round() as i32);
            let b = &mut bounds[r * cols + c];
            b[0] = b[0].min(du);
            b[1] = b[1].max(du);
            b[2] = b[2].min(dv);
            b[3] = b[3].max(dv);
            b[4] += 1;
        }
        let (mu, mv) = (margin[0] as i32, margin[1] as i32);
        let (fu, fv) = (max_flow[0] as i32, max_flow[1] as i32);
        let mut windows = vec![None; cols * rows];
        for r in 0..rows {
            for c in 0..cols {
                let mut acc = [i32::MAX, i32::MIN, i32::MAX, i32::MIN, 0];
                for y in r.saturating_sub(1)..(r + 2).min(rows) {
                    for x in c.saturating_sub(1)..(c + 2).min(cols) {
                        let b = &bounds[y * cols + x];
                        if b[4] > 0 {
                            acc[0] = acc[0].min(b[0]);
                            acc[1] = acc[1].max(b[1]);
                            acc[2] = acc[2].min(b[2]);
                            acc[3] = acc[3].max(b[3]);
                            acc[4] += b[4];
                        }
                    }
                }
                if acc[4] < 2 {
                    continue;
                }
                // The window [lo - margin, hi + margin], within the full window.
                let (lo_u, hi_u) = ((acc[0] - mu).max(-fu), (acc[1] + mu).min(fu));
                let (lo_v, hi_v) = ((acc[2] - mv).max(-fv), (acc[3] + mv).min(fv));
                if lo_u > hi_u || lo_v > hi_v {
                    continue;
                }
                // Centre rounded down, half-width rounded up: the window covers [lo, hi].
                let (ou, ov) = ((lo_u + hi_u).div_euclid(2), (lo_v + hi_v).div_euclid(2));
                windows[r * cols + c] = Some([ou, ov, hi_u - ou, hi_v - ov]);
            }
        }
        Self {
            cols,
            rows,
            windows,
        }
    }

    /// The search window `(offset u, offset v, half-width, half-height)` of a feature at
    /// `(u, v)` in frame k-1, or `None` (the full window).
    fn window(&self, u: u16, v: u16) -> Option<[i32; 4]> {
        let c = (usize::from(u) / PRIOR_CELL).min(self.cols.saturating_sub(1));
        let r = (usize::from(v) / PRIOR_CELL).min(self.rows.saturating_sub(1));
        *self.windows.get(r * self.cols + c)?
    }
}

/// Matches the features of two frames of one camera (the steps of the module documentation).
/// Both frames must have the same size.
pub fn match_features(
    prev: &FrameFeatures,
    cur: &FrameFeatures,
    options: &MatchOptions,
) -> Vec<Match> {
    match_features_with_prior(prev, cur, options, None)
}

/// [`match_features`] with a flow prediction: each candidate's search window comes from
/// `prior` ([`FlowPrior::window`]) where it has one; the circular check searches the mirrored
/// window (so the candidate lies inside it).
pub fn match_features_with_prior(
    prev: &FrameFeatures,
    cur: &FrameFeatures,
    options: &MatchOptions,
    prior: Option<&FlowPrior>,
) -> Vec<Match> {
    let (w, h) = (prev.width, prev.height);
    if w != cur.width || h != cur.height || w < MIN_SIDE || h < MIN_SIDE {
        return Vec::new();
    }
    let grid = Grid::new(w, h, options.matches_per_frame);

    // 1. Candidates: the strongest features per cell and class.
    let candidates = if options.candidates_per_cell <= MAX_SELECTED {
        strongest_per_cell_selected(prev, &grid, options.candidates_per_cell)
    } else {
        strongest_per_cell(prev, &grid, options.candidates_per_cell, true)
    };

    // 2.-4. Forward, backward, sub-pixel.
    let (ru, rv) = (options.max_flow_u as i32, options.max_flow_v as i32);
    let matches: Vec<Match> = candidates
        .par_iter()
        .filter_map(|&(class, i)| {
            let f = &prev.classes[class].points[i];
            let (u0, v0) = (i32::from(f.u), i32::from(f.v));
            let [ou, ov, wu, wv] = prior
                .and_then(|p| p.window(f.u, f.v))
                .unwrap_or([0, 0, ru, rv]);
            let (j, s, second) =
                cur.classes[class].best_in_window(&f.desc, u0 + ou, v0 + ov, wu, wv)?;
            if s > options.max_sad || f64::from(s) > options.uniqueness * f64::from(second) {
                return None;
            }
            let g = &cur.classes[class].points[j];
            let (u1, v1) = (i32::from(g.u), i32::from(g.v));
            // The circular check: `f` must be the best match of `g` in frame k-1 (in the
            // mirrored window, so `f` lies inside it; the scan stops at the first feature that
            // beats `f`).
            if !prev.classes[class].is_best_in_window(&g.desc, u1 - ou, v1 - ov, wu, wv, i, s) {
                return None;
            }
            Some(if options.subpixel && options.klt.is_none() {
                Match {
                    u0: f64::from(f.x),
                    v0: f64::from(f.y),
                    u1: f64::from(g.x),
                    v1: f64::from(g.y),
                    sad: s,
                }
            } else {
                Match {
                    u0: f64::from(u0),
                    v0: f64::from(v0),
                    u1: f64::from(u1),
                    v1: f64::from(v1),
                    sad: s,
                }
            })
        })
        .collect();

    // 5. Bucketing.
    // With the forward-backward check, a quarter more are chosen so that the matches it drops
    // are replaced (bucketed again after the refinement).
    let spare = match &options.klt {
        Some(k) if k.fb_threshold > 0.0 => options.matches_per_frame.div_ceil(4),
        _ => 0,
    };
    let chosen = bucket(matches, &grid, options.matches_per_frame + spare);

    // 6. KLT refinement of the chosen matches (integer pixels so far).
    match &options.klt {
        None => chosen,
        Some(klt) => {
            let (p, c) = (prev.plane(), cur.plane());
            let refined: Vec<Match> = chosen
                .par_iter()
                .enumerate()
                .filter_map(|(i, m)| {
                    // The patches of the match `KLT_AHEAD` on are loaded meanwhile.
                    if let Some(next) = chosen.get(i + KLT_AHEAD) {
                        prefetch_patch(p, (next.u0 as usize, next.v0 as usize), klt.half);
                        prefetch_patch(c, (next.u1 as usize, next.v1 as usize), klt.half);
                    }
                    let [u0, v0, u1, v1] = refine_match(
                        p,
                        c,
                        (m.u0 as usize, m.v0 as usize),
                        (m.u1 as usize, m.v1 as usize),
                        klt,
                    )?;
                    Some(Match {
                        u0,
                        v0,
                        u1,
                        v1,
                        sad: m.sad,
                    })
                })
                .collect();
            bucket(refined, &grid, options.matches_per_frame)
        }
    }
}

/// Matches ahead of the one being refined whose patches are prefetched
/// ([`prefetch_patch`]).
const KLT_AHEAD: usize = 2;

/// The `per_cell` strongest features of each grid cell and class, `(class, index)`, in the
/// order (class, cell, strength, index). With `packed` (and fewer than 2^16 cells, 2^32
/// features) the three keys are packed into one `u64`, which sorts several times faster than
/// the tuple (the same order).
fn strongest_per_cell(
    frame: &FrameFeatures,
    grid: &Grid,
    per_cell: usize,
    packed: bool,
) -> Vec<(usize, usize)> {
    let mut candidates: Vec<(usize, usize)> = Vec::new();
    let packed = packed && grid.len() < 1 << 16;
    let mut keys: Vec<u64> = Vec::new();
    let mut keyed: Vec<(usize, i32, usize)> = Vec::new();
    for class in 0..CLASSES {
        let points = &frame.classes[class].points;
        let key = |(i, f): (usize, &Feature)| {
            (
                grid.of(f64::from(f.u), f64::from(f.v)),
                -i32::from(f.response).abs(),
                i,
            )
        };
        // The first `per_cell` of each cell, in the sorted order.
        let mut last_cell = usize::MAX;
        let mut taken = 0;
        let mut take = |cell: usize, i: usize| {
            if cell != last_cell {
                last_cell = cell;
                taken = 0;
            }
            if taken < per_cell {
                candidates.push((class, i));
                taken += 1;
            }
        };
        if packed && u32::try_from(points.len()).is_ok() {
            // cell < 2^16, 0 <= -|response| + 2^15 <= 2^15, index < 2^32.
            keys.clear();
            keys.extend(points.iter().enumerate().map(|p| {
                let (cell, strength, i) = key(p);
                (cell as u64) << 48 | ((strength + (1 << 15)) as u64) << 32 | i as u64
            }));
            keys.sort_unstable();
            for &k in &keys {
                take((k >> 48) as usize, (k & 0xffff_ffff) as usize);
            }
        } else {
            keyed.clear();
            keyed.extend(points.iter().enumerate().map(key));
            keyed.sort_unstable();
            for &(cell, _, i) in &keyed {
                take(cell, i);
            }
        }
    }
    candidates
}

/// Candidates per cell up to which [`strongest_per_cell_selected`] is used (each cell's slots
/// are shifted on an insertion); more go by [`strongest_per_cell`]'s sort.
const MAX_SELECTED: usize = 8;

/// [`strongest_per_cell`] without a sort, the same list in the same order: per class, one pass
/// over the features in index order keeps each cell's `per_cell` strongest, ordered by
/// strength, then index (a later feature of equal strength goes behind: the index order);
/// the cells are read in order at the end. The cell of a feature comes from per-column and
/// per-row tables of [`Grid::of`] (the same divisions, once per image column and row instead
/// of twice per feature).
fn strongest_per_cell_selected(
    frame: &FrameFeatures,
    grid: &Grid,
    per_cell: usize,
) -> Vec<(usize, usize)> {
    let (w, h) = (frame.width, frame.height);
    let col_of: Vec<usize> = (0..w).map(|u| grid.of(u as f64, 0.0)).collect();
    let row_of: Vec<usize> = (0..h)
        .map(|v| grid.of(0.0, v as f64) - grid.of(0.0, 0.0))
        .collect();
    let cells = grid.len();
    let per_cell = per_cell.max(1);
    // Per cell: the number kept and `per_cell` slots of (strength, index).
    let mut count = vec![0usize; cells];
    let mut slots = vec![(0i32, 0usize); cells * per_cell];
    let mut candidates: Vec<(usize, usize)> = Vec::new();
    for class in 0..CLASSES {
        count.fill(0);
        for (i, f) in frame.classes[class].points.iter().enumerate() {
            let (Some(&c), Some(&r)) = (col_of.get(usize::from(f.u)), row_of.get(usize::from(f.v)))
            else {
                continue;
            };
            let cell = r + c;
            let strength = i32::from(f.response).abs();
            let kept = &mut count[cell];
            let cell_slots = &mut slots[cell * per_cell..(cell + 1) * per_cell];
            // Behind every kept feature at least as strong (earlier index).
            let at = cell_slots[..*kept]
                .iter()
                .position(|&(s, _)| s < strength)
                .unwrap_or(*kept);
            if at == per_cell {
                continue;
            }
            let end = (*kept + 1).min(per_cell);
            cell_slots.copy_within(at..end - 1, at + 1);
            cell_slots[at] = (strength, i);
            *kept = end;
        }
        for (cell, &kept) in count.iter().enumerate() {
            candidates.extend(
                slots[cell * per_cell..cell * per_cell + kept]
                    .iter()
                    .map(|&(_, i)| (class, i)),
            );
        }
    }
    candidates
}

/// At most `n` matches, spread over the grid: one per cell and round, best SAD first; in the last
/// round the cells' best matches compete by SAD.
fn bucket(mut matches: Vec<Match>, grid: &Grid, n: usize) -> Vec<Match> {
    if matches.len() <= n {
        return matches;
    }
    matches.sort_by_key(|m| (m.sad, m.v0 as u32, m.u0 as u32));
    let mut cells: Vec<Vec<Match>> = vec![Vec::new(); grid.len()];
    for m in matches.into_iter().rev() {
        cells[grid.of(m.u0, m.v0)].push(m); // reversed: best at the end, popped first
    }
    let mut out = Vec::with_capacity(n);
    loop {
        let mut round: Vec<Match> = cells.iter_mut().filter_map(Vec::pop).collect();
        if round.is_empty() {
            break;
        }
        if out.len() + round.len() > n {
            round.sort_by_key(|m| m.sad);
            round.truncate(n - out.len());
        }
        out.extend(round);
        if out.len() >= n {
            break;
        }
    }
    out
}

/// Matches two images directly (tests, one-off use): detects in both and matches `img0` to
/// `img1`. Fails if the sizes differ.
pub fn match_images(
    img0: &GrayImage,
    img1: &GrayImage,
    options: &MatchOptions,
) -> Result<Vec<Match>, MatchError> {
    options.validate()?;
    if img0.dimensions() != img1.dimensions() {
        return Err(MatchError::Option(format!(
            "images of different sizes: {:?} and {:?}",
            img0.dimensions(),
            img1.dimensions()
        )));
    }
    let run = || {
        let (mut f0, mut f1) = (FrameFeatures::default(), FrameFeatures::default());
        rayon::join(
            || f0.extract(img0, &options.detector),
            || f1.extract(img1, &options.detector),
        );
        match_features(&f0, &f1, options)
    };
    Ok(match thread_pool(options.threads)? {
        Some(pool) => pool.install(run),
        None => run(),
    })
}

/// Streaming matcher of a multi-camera sequence: [`push`](Self::push) the images of frame k (one
/// per camera) and get the matches of the pair `(k-1, k)` per camera. Only the previous frame's
/// features are kept, so memory does not grow with the sequence. Cameras are processed in
/// parallel (rayon).
#[derive(Debug)]
pub struct FrameMatcher {
    options: MatchOptions,
    prev: Vec<Option<FrameFeatures>>,
    spare: Vec<FrameFeatures>,
    /// Per camera, the flow prior from the last frame pair's matches.
    priors: Vec<Option<FlowPrior>>,
    frames: usize,
    pool: Option<rayon::ThreadPool>,
}

/// A pool of `threads` threads, or `None` for rayon's global pool (`threads == 0`).
fn thread_pool(threads: usize) -> Result<Option<rayon::ThreadPool>, MatchError> {
    if threads == 0 {
        return Ok(None);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map(Some)
        .map_err(|e| MatchError::Option(format!("cannot start {threads} threads: {e}")))
}

impl FrameMatcher {
    /// A matcher for `cameras` cameras. Fails on invalid options.
    pub fn new(cameras: usize, options: MatchOptions) -> Result<Self, MatchError> {
        options.validate()?;
        Ok(Self {
            options,
            prev: vec![None; cameras],
            spare: vec![FrameFeatures::default(); cameras],
            priors: vec![None; cameras],
            frames: 0,
            pool: thread_pool(options.threads)?,
        })
    }

    /// The options.
    pub fn options(&self) -> &MatchOptions {
        &self.options
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Camera `camera`'s features of the last frame pushed (frame k).
    pub fn current(&self, camera: usize) -> Option<&FrameFeatures> {
        self.prev.get(camera)?.as_ref()
    }

    /// Camera `camera`'s features of the frame before the last one pushed (frame k-1; empty
    /// before the second push).
    pub fn previous(&self, camera: usize) -> Option<&FrameFeatures> {
        self.spare.get(camera)
    }

    /// Adds frame k (one image per camera, each camera's size fixed over the sequence). Returns
    /// `None` for the first frame, else the matches of `(k-1, k)`, `result[camera]`.
    pub fn push(&mut self, images: &[GrayImage]) -> Result<Option<Vec<Vec<Match>>>, MatchError> {
        self.push_images(images.iter().map(Cow::Borrowed).collect())
    }

    /// [`push`](Self::push) of images given away: each camera's features keep its image's
    /// buffer ([`FrameFeatures::extract_owned`]) where `push` copies the pixels. The matches
    /// are the same.
    pub fn push_owned(
        &mut self,
        images: Vec<GrayImage>,
    ) -> Result<Option<Vec<Vec<Match>>>, MatchError> {
        self.push_images(images.into_iter().map(Cow::Owned).collect())
    }

    fn push_images(
        &mut self,
        images: Vec<Cow<'_, GrayImage>>,
    ) -> Result<Option<Vec<Vec<Match>>>, MatchError> {
        if images.len() != self.prev.len() {
            return Err(MatchError::Option(format!(
                "{} images for {} cameras",
                images.len(),
                self.prev.len()
            )));
        }
        for (j, (img, prev)) in images.iter().zip(&self.prev).enumerate() {
            if let Some(p) = prev {
                if (p.width, p.height) != (img.width() as usize, img.height() as usize) {
                    return Err(MatchError::Option(format!(
                        "camera {j}: image size changed from {}x{} to {}x{}",
                        p.width,
                        p.height,
                        img.width(),
                        img.height()
                    )));
                }
            }
        }
        let options = self.options;
        let (prev, spare, priors) = (&mut self.prev, &mut self.spare, &mut self.priors);
        let work = || -> Vec<Option<Vec<Match>>> {
            images
                .into_par_iter()
                .zip(prev.par_iter_mut())
                .zip(spare.par_iter_mut())
                .zip(priors.par_iter_mut())
                .map(|(((img, prev), spare), prior)| {
                    match img {
                        Cow::Borrowed(img) => spare.extract(img, &options.detector),
                        Cow::Owned(img) => spare.extract_owned(img, &options.detector),
                    }
                    let matches = prev.as_ref().map(|p| {
                        let m = match_features_with_prior(p, spare, &options, prior.as_ref());
                        // Too few with the prediction (a change of motion): the full window.
                        if prior.is_some() && m.len() < options.matches_per_frame.div_ceil(2) {
                            match_features(p, spare, &options)
                        } else {
                            m
                        }
                    });
                    *prior = match (&matches, options.prior_margin) {
                        (Some(m), Some(margin)) => Some(FlowPrior::from_matches(
                            m,
                            (spare.width, spare.height),
                            margin,
                            [options.max_flow_u, options.max_flow_v],
                        )),
                        _ => None,
                    };
                    // The current frame becomes the previous one; the old buffers are reused.
                    let old = prev.replace(std::mem::take(spare));
                    if let Some(old) = old {
                        *spare = old;
                    }
                    matches
                })
                .collect()
        };
        let results = match &self.pool {
            Some(pool) => pool.install(work),
            None => work(),
        };
        self.frames += 1;
        Ok(if self.frames == 1 {
            None
        } else {
            Some(results.into_iter().map(Option::unwrap_or_default).collect())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flow(u1: f64, v1: f64, du: f64, dv: f64) -> Match {
        Match {
            u0: u1 - du,
            v0: v1 - dv,
            u1,
            v1,
            sad: 0,
        }
    }

    /// The packed-key sort picks the same candidates in the same order as the tuple sort, on a
    /// textured image with many equal responses, for several grids and numbers per cell.
    #[test]
    fn packed_candidates_equal_the_tuple_sort() {
        let img = crate::synthetic::dead_leaves(160, 96, 300, 3);
        let mut f = FrameFeatures::default();
        f.extract(&img, &DetectorOptions::default());
        assert!(f.len() > 100, "{}", f.len());
        for (n, per_cell) in [(10, 1), (50, 2), (300, 3), (2000, 2), (50, 5), (10, 8)] {
            let grid = Grid::new(f.width, f.height, n);
            let packed = strongest_per_cell(&f, &grid, per_cell, true);
            let tuple = strongest_per_cell(&f, &grid, per_cell, false);
            assert!(!packed.is_empty());
            assert_eq!(packed, tuple, "n {n} per cell {per_cell}");
            let selected = strongest_per_cell_selected(&f, &grid, per_cell);
            assert_eq!(selected, tuple, "selected: n {n} per cell {per_cell}");
        }
    }

    /// The window of a cell spans the flows of the matches in it and the 8 cells around it plus
    /// the margin (clamped to the full window); cells with fewer than 2 flows around search the
    /// full window.
    #[test]
    fn the_prior_window_spans_the_neighbouring_flows() {
        let matches = [
            flow(10.0, 10.0, 5.0, 1.0),
            flow(70.0, 20.0, -3.0, 2.0),
            flow(100.0, 100.0, 190.0, 0.0),
            flow(300.0, 100.0, 7.0, 7.0),
        ];
        let prior = FlowPrior::from_matches(&matches, (400, 200), [4, 2], [200, 100]);
        // Cell (0, 0) sees the flows of cells (0..2, 0..2): u in [-3, 190], v in [0, 2].
        let [ou, ov, ru, rv] = prior.window(0, 0).expect("a window");
        assert!(ou - ru <= -3 - 4 && ou + ru >= 190 + 4, "{ou} {ru}");
        assert!(
            ov - rv <= -2 && ov + rv >= 4 && ov - rv >= -3 && ov + rv <= 5,
            "{ov} {rv}"
        );
        // Clamped to the full window in u.
        assert!(ou + ru <= 200 + 1);
        // Cell (4, 1) sees only the match at (300, 100): one flow, the full window.
        assert_eq!(prior.window(300, 100), None);
        // Far from every match: the full window.
        assert_eq!(prior.window(399, 199), None);
    }
}

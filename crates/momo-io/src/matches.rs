//! `matches.csv`: sparse optical flow between consecutive frames (`FORMAT.md`, section
//! "matches.csv"), read as a stream of frame pairs ([`MatchReader`]) and written atomically
//! ([`MatchWriter`], [`write_matches`]).

use crate::atomic::{AtomicFile, put};
use crate::error::{IoError, IoErrorKind};
use crate::text::{Exact, LineReader, is_blank, parse_f64, parse_header, parse_index, split_row};
use momo_core::{Camera, CameraModel, CrossObservation, FrameObservations, Observation, Rig};
use nalgebra::{Vector2, Vector3};
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// The header line of `matches.csv`. Readers accept these names in any order.
pub const MATCHES_HEADER: &str = "frame,camera,u0,v0,u1,v1";
const MATCH_COLUMNS: [&str; 6] = ["frame", "camera", "u0", "v0", "u1", "v1"];
/// The header line of `matches.csv` with the optional `camera_to` column (version 5).
pub const MATCHES_HEADER_CROSS: &str = "frame,camera,u0,v0,u1,v1,camera_to";
const MATCH_COLUMNS_CROSS: [&str; 7] = ["frame", "camera", "u0", "v0", "u1", "v1", "camera_to"];

/// Pixels more than this fraction of `max(width, height)` outside the image border are rejected
/// as input errors (a wrong camera id or a mix-up of cameras). Points slightly outside the image
/// (sub-pixel refinement at the border, undistortion) are accepted.
pub const PIXEL_MARGIN_FRACTION: f64 = 0.1;

/// Largest frame number accepted in `matches.csv` and `odometry.csv` (10 million frame pairs,
/// 11.5 days at 10 Hz), so that a typo cannot make a reader produce billions of empty frames.
pub const MAX_FRAME: usize = 10_000_000;

/// The margin in pixels outside the image within which pixels of `model` are accepted.
pub(crate) fn pixel_margin(model: &Camera) -> f64 {
    let (w, h) = model.size();
    PIXEL_MARGIN_FRACTION * w.max(h)
}

/// Checks that a pixel lies within `margin` of the image and unprojects it.
pub(crate) fn check_pixel(
    model: &Camera,
    margin: f64,
    camera: usize,
    field: &'static str,
    px: Vector2<f64>,
) -> Result<Vector3<f64>, IoErrorKind> {
    let (u, v) = (px.x, px.y);
    if !model.contains(&px, margin) {
        let (width, height) = model.size();
        return Err(IoErrorKind::PixelOutsideImage {
            field,
            camera,
            u,
            v,
            margin,
            width,
            height,
        });
    }
    // The error is built only where it is raised (`ok_or` built and dropped one per pixel).
    let Some(f) = model.unproject(&px) else {
        return Err(IoErrorKind::Unprojectable {
            field,
            camera,
            u,
            v,
        });
    };
    Ok(f)
}

/// A row's fields as read: frame, camera, `u0`, `v0`, `u1`, `v1` and `camera_to` (its error kept
/// in place, to be raised after the camera's).
type RowFields = (
    usize,
    usize,
    f64,
    f64,
    f64,
    f64,
    Result<Option<usize>, IoErrorKind>,
);

/// The fields of a row of `N` plain numbers read in one pass from its bytes, as
/// [`MatchReader::parse_fields`] reads them, or `None` for any row that it leaves to them.
///
/// The row must be `N` fields separated by single commas, nothing before the first or after the
/// last. A field at a position of `index_at` (frame, camera, `camera_to`) must be 1 to 19 ASCII
/// digits: its value is `usize::from_str` of it, as [`parse_index`] reads it. Any other field
/// must be a decimal that `fast_float2::parse_partial` reads whole to a finite `f64` (no
/// whitespace: it skips none): that reading is correctly rounded, as `str::parse` (the same
/// algorithm, Lemire's fast_float) and the exact plain-decimal path of [`parse_f64`] are, and
/// its syntax (`[+-]digits[.digits][e[+-]digits]`, a point with digits on either side, `inf`,
/// `nan`) is a part of `str::parse`'s, so the value is the same bits (test
/// `fast_float_reads_as_std_parse`). Non-finite values, empty fields and anything else go to
/// the field parsers, which raise the errors.
fn fast_fields<const N: usize>(
    b: &[u8],
    c: &[usize; 7],
    index_at: &[bool; 7],
) -> Option<RowFields> {
    // The columns in the header's order (`frame,camera,u0,v0,u1,v1[,camera_to]`): the same
    // fields read in straight-line code.
    let to = if N == 7 { 6 } else { usize::MAX };
    if *c == [0, 1, 2, 3, 4, 5, to] {
        return in_order_fields::<N>(b);
    }
    let mut index = [0usize; 7];
    let mut value = [0.0f64; 7];
    let mut i = 0;
    for (p, &is_index) in index_at.iter().enumerate().take(N) {
        if p > 0 {
            i = after_comma(b, i)?;
        }
        if is_index {
            (index[p], i) = index_field(b, i)?;
        } else {
            (value[p], i) = value_field(b, i)?;
        }
    }
    if i != b.len() {
        return None;
    }
    let camera_to = (c[6] != usize::MAX).then(|| index[c[6]]);
    Some((
        index[c[0]],
        index[c[1]],
        value[c[2]],
        value[c[3]],
        value[c[4]],
        value[c[5]],
        Ok(camera_to),
    ))
}

/// [`fast_fields`] of a row whose columns are in the header's order: frame, camera, `u0`, `v0`,
/// `u1`, `v1` (and `camera_to` for `N = 7`), each field read as there.
#[inline(always)]
fn in_order_fields<const N: usize>(b: &[u8]) -> Option<RowFields> {
    let (frame, i) = index_field(b, 0)?;
    let (camera, i) = index_field(b, after_comma(b, i)?)?;
    let (u0, i) = value_field(b, after_comma(b, i)?)?;
    let (v0, i) = value_field(b, after_comma(b, i)?)?;
    let (u1, i) = value_field(b, after_comma(b, i)?)?;
    let (v1, mut i) = value_field(b, after_comma(b, i)?)?;
    let mut camera_to = None;
    if N == 7 {
        let (to, j) = index_field(b, after_comma(b, i)?)?;
        camera_to = Some(to);
        i = j;
    }
    if i != b.len() {
        return None;
    }
    Some((frame, camera, u0, v0, u1, v1, Ok(camera_to)))
}

/// The position after the comma at `b[i]`, `None` if there is none.
#[inline(always)]
fn after_comma(b: &[u8], i: usize) -> Option<usize> {
    (b.get(i) == Some(&b',')).then_some(i + 1)
}

/// An index field of [`fast_fields`] at `b[i..]`: 1 to 19 ASCII digits (below `10^19 < 2^64`),
/// its value `usize::from_str` of them, as [`parse_index`] reads it; and the end of the digits.
#[inline(always)]
fn index_field(b: &[u8], i: usize) -> Option<(usize, usize)> {
    let mut j = i;
    let mut w: u64 = 0;
    while let Some(&c) = b.get(j) {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        w = w.wrapping_mul(10).wrapping_add(u64::from(d));
        j += 1;
    }
    if j == i || j - i > 19 {
        return None;
    }
    Some((usize::try_from(w).ok()?, j))
}

/// A value field of [`fast_fields`] at `b[i..]`: what `fast_float2::parse_partial` reads, finite
/// only. Its value and end.
#[inline(always)]
fn value_field(b: &[u8], i: usize) -> Option<(f64, usize)> {
    let (v, n) = fast_float2::parse_partial::<f64, _>(b.get(i..)?).ok()?;
    if !v.is_finite() {
        return None;
    }
    Some((v, i + n))
}

/// One parsed row.
struct Row {
    frame: usize,
    camera: usize,
    /// The camera of `(u1, v1)` (`camera` unless the row is a cross-camera match).
    camera_to: usize,
    obs: Observation,
}

/// Reads `matches.csv` one frame pair at a time: yields `(k, FrameObservations)` for every
/// `k = 1..=last` (contiguous, with empty observations for frame pairs without rows), holding at
/// most one frame pair in memory. Stops after the first error.
///
/// Every row is validated: six fields (seven with the optional `camera_to` column), finite
/// numbers, `frame >= 1` and non-decreasing, camera ids of the rig, pixels within
/// [`PIXEL_MARGIN_FRACTION`] of the image and unprojectable by their camera's model. A row whose
/// `camera_to` names another camera than `camera` goes to
/// [`FrameObservations::cross_camera`]; an empty `camera_to` means `camera`.
pub struct MatchReader<R> {
    lines: LineReader<R>,
    path: PathBuf,
    cameras: Vec<(Camera, f64)>,
    /// Positions of the columns of [`MATCH_COLUMNS_CROSS`]; `camera_to` is `usize::MAX` when
    /// the file has no such column.
    columns: [usize; 7],
    /// The positions that hold an index (frame, camera, `camera_to`), for [`fast_fields`].
    index_at: [bool; 7],
    next_frame: usize,
    current: FrameObservations,
    pending: Option<Row>,
    last_row_frame: usize,
    rows: usize,
    done: bool,
}

impl MatchReader<BufReader<File>> {
    /// Opens `path` (errors: [`IoErrorKind::NotFound`], a bad header).
    pub fn open(path: impl AsRef<Path>, rig: &Rig) -> Result<Self, IoError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|e| IoError::io(path, e))?;
        Self::new(BufReader::with_capacity(1 << 16, file), rig, path)
    }
}

impl<R: BufRead> MatchReader<R> {
    /// Reads the header from `reader`; `path` only names the source in errors.
    pub fn new(reader: R, rig: &Rig, path: impl Into<PathBuf>) -> Result<Self, IoError> {
        let path = path.into();
        let mut lines = LineReader::new(reader);
        let columns = loop {
            match lines.next_line() {
                Err(k) => return Err(IoError::at(&path, lines.line(), k)),
                Ok(None) => {
                    return Err(IoError::file(
                        &path,
                        IoErrorKind::MissingHeader {
                            expected: MATCHES_HEADER,
                        },
                    ));
                }
                Ok(Some(l)) if is_blank(l) => continue,
                Ok(Some(l)) => {
                    let cross = l.split(',').any(|n| n.trim() == "camera_to");
                    let parsed = if cross {
                        parse_header(l, &MATCH_COLUMNS_CROSS, MATCHES_HEADER_CROSS)
                    } else {
                        parse_header(l, &MATCH_COLUMNS, MATCHES_HEADER).map(|c| {
                            let mut all = [usize::MAX; 7];
                            all[..6].copy_from_slice(&c);
                            all
                        })
                    };
                    break parsed.map_err(|k| IoError::at(&path, lines.line(), k))?;
                }
            }
        };
        let cameras = rig
            .cameras()
            .iter()
            .map(|c| (c.model, pixel_margin(&c.model)))
            .collect();
        let mut index_at = [false; 7];
        for &k in [columns[0], columns[1], columns[6]].iter() {
            if let Some(at) = index_at.get_mut(k) {
                *at = true;
            }
        }
        Ok(Self {
            lines,
            path,
            cameras,
            columns,
            index_at,
            next_frame: 1,
            current: FrameObservations::new(rig.len()),
            pending: None,
            last_row_frame: 0,
            rows: 0,
            done: false,
        })
    }

    /// Number of match rows read so far.
    pub fn rows_read(&self) -> usize {
        self.rows
    }

    /// The next frame number to be yielded (1 before the first).
    pub fn next_frame(&self) -> usize {
        self.next_frame
    }

    /// The source named in errors.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A line's row, `None` for a blank line.
    fn parse_line(
        line: &[u8],
        c: &[usize; 7],
        index_at: &[bool; 7],
        cameras: &[(Camera, f64)],
        last_row_frame: usize,
    ) -> Result<Option<Row>, IoErrorKind> {
        // (A line that starts with a digit is not blank.)
        if !line.first().is_some_and(u8::is_ascii_digit)
            && is_blank(std::str::from_utf8(line).map_err(|_| IoErrorKind::InvalidUtf8)?)
        {
            return Ok(None);
        }
        Self::parse_row(line, c, index_at, cameras, last_row_frame).map(Some)
    }

    fn parse_row(
        line: &[u8],
        c: &[usize; 7],
        index_at: &[bool; 7],
        cameras: &[(Camera, f64)],
        last_row_frame: usize,
    ) -> Result<Row, IoErrorKind> {
        let with_to = c[6] != usize::MAX;
        // A row of plain numbers in one pass from its bytes (most rows); any other row through
        // the UTF-8 check, the split and the field parsers (a row the one pass reads is ASCII).
        let fast = if with_to {
            fast_fields::<7>(line, c, index_at)
        } else {
            fast_fields::<6>(line, c, index_at)
        };
        let (frame, camera, u0, v0, u1, v1, camera_to) = match fast {
            Some(v) => v,
            None => {
                let line = std::str::from_utf8(line).map_err(|_| IoErrorKind::InvalidUtf8)?;
                Self::parse_fields(line, c, with_to)?
            }
        };
        if frame == 0 {
            return Err(IoErrorKind::FrameZero);
        }
        if frame > MAX_FRAME {
            return Err(IoErrorKind::FrameTooLarge {
                frame,
                max: MAX_FRAME,
            });
        }
        if frame < last_row_frame {
            return Err(IoErrorKind::FramesOutOfOrder {
                frame,
                previous: last_row_frame,
                order: "non-decreasing",
            });
        }
        let Some((model, margin)) = cameras.get(camera) else {
            return Err(IoErrorKind::UnknownCamera {
                camera,
                count: cameras.len(),
            });
        };
        let camera_to = camera_to?.unwrap_or(camera);
        let Some((model_to, margin_to)) = cameras.get(camera_to) else {
            return Err(IoErrorKind::UnknownCamera {
                camera: camera_to,
                count: cameras.len(),
            });
        };
        let f0 = check_pixel(model, *margin, camera, "u0,v0", Vector2::new(u0, v0))?;
        let f1 = check_pixel(
            model_to,
            *margin_to,
            camera_to,
            "u1,v1",
            Vector2::new(u1, v1),
        )?;
        Ok(Row {
            frame,
            camera,
            camera_to,
            obs: Observation {
                px0: Vector2::new(u0, v0),
                px1: Vector2::new(u1, v1),
                f0,
                f1,
            },
        })
    }

    /// A row's fields through [`split_row`] and the field parsers: frame, camera, `u0`, `v0`,
    /// `u1`, `v1` and `camera_to` (`None` where the column is missing or empty; its error is
    /// returned in place, to be raised after the camera's, as before).
    fn parse_fields(line: &str, c: &[usize; 7], with_to: bool) -> Result<RowFields, IoErrorKind> {
        let seven: [&str; 7];
        let six: [&str; 6];
        let fields: &[&str] = if with_to {
            seven = split_row(line)?;
            &seven
        } else {
            six = split_row(line)?;
            &six
        };
        let frame = parse_index("frame", fields[c[0]])?;
        let camera = parse_index("camera", fields[c[1]])?;
        let u0 = parse_f64("u0", fields[c[2]])?;
        let v0 = parse_f64("v0", fields[c[3]])?;
        let u1 = parse_f64("u1", fields[c[4]])?;
        let v1 = parse_f64("v1", fields[c[5]])?;
        let camera_to = match fields.get(c[6]) {
            Some(t) if !t.is_empty() => parse_index("camera_to", t).map(Some),
            _ => Ok(None),
        };
        Ok((frame, camera, u0, v0, u1, v1, camera_to))
    }

    /// The next row, `None` at the end of the file.
    fn read_row(&mut self) -> Result<Option<Row>, IoError> {
        loop {
            let row = match self.lines.next_line_bytes() {
                Ok(Some(line)) => Self::parse_line(
                    line,
                    &self.columns,
                    &self.index_at,
                    &self.cameras,
                    self.last_row_frame,
                ),
                Ok(None) => return Ok(None),
                Err(k) => Err(k),
            };
            match row.map_err(|k| IoError::at(&self.path, self.lines.line(), k))? {
                None => continue,
                Some(row) => {
                    self.last_row_frame = row.frame;
                    self.rows += 1;
                    return Ok(Some(row));
                }
            }
        }
    }

    fn take_current(&mut self) -> (usize, FrameObservations) {
        let k = self.next_frame;
        self.next_frame += 1;
        let n = self.current.per_camera.len();
        let done = std::mem::replace(&mut self.current, FrameObservations::new(n));
        // The next frame pair has about as many matches: reserve them once instead of
        // growing each vector by doubling (a reallocation and copy per doubling).
        for (v, d) in self.current.per_camera.iter_mut().zip(&done.per_camera) {
            v.reserve(d.len());
        }
        self.current.cross_camera.reserve(done.cross_camera.len());
        (k, done)
    }
}

impl<R: BufRead> Iterator for MatchReader<R> {
    type Item = Result<(usize, FrameObservations), IoError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        loop {
            let row = match self.pending.take() {
                Some(r) => Some(r),
                None => match self.read_row() {
                    Ok(r) => r,
                    Err(e) => {
                        self.done = true;
                        return Some(Err(e));
                    }
                },
            };
            match row {
                Some(r) if r.frame == self.next_frame => {
                    if r.camera_to == r.camera {
                        self.current.per_camera[r.camera].push(r.obs)
                    } else {
                        self.current.cross_camera.push(CrossObservation {
                            camera: r.camera,
                            camera_to: r.camera_to,
                            obs: r.obs,
                        })
                    }
                }
                Some(r) => {
                    // r.frame > next_frame (order is checked while parsing).
                    self.pending = Some(r);
                    return Some(Ok(self.take_current()));
                }
                None => {
                    self.done = true;
                    return (self.next_frame <= self.last_row_frame)
                        .then(|| Ok(self.take_current()));
                }
            }
        }
    }
}

/// Writes `matches.csv` atomically, one frame pair at a time: rows appear only in the file once
/// [`finish`](Self::finish) renames it into place; dropping the writer without finishing leaves no
/// file behind.
pub struct MatchWriter {
    file: AtomicFile,
    last_frame: usize,
    /// The file has the `camera_to` column ([`MatchWriter::create_cross`]).
    cross: bool,
}

impl MatchWriter {
    /// Starts `path` (a temporary file beside it) and writes the header.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, IoError> {
        let mut file = AtomicFile::create(path.as_ref())?;
        put!(&mut file, "{MATCHES_HEADER}\n")?;
        Ok(Self {
            file,
            last_frame: 0,
            cross: false,
        })
    }

    /// Like [`create`](Self::create), with the `camera_to` column (`FORMAT.md` version 5), so
    /// that [`FrameObservations::cross_camera`] can be written.
    pub fn create_cross(path: impl AsRef<Path>) -> Result<Self, IoError> {
        let mut file = AtomicFile::create(path.as_ref())?;
        put!(&mut file, "{MATCHES_HEADER_CROSS}\n")?;
        Ok(Self {
            file,
            last_frame: 0,
            cross: true,
        })
    }

    /// Writes the matches of frame pair `frame` (>= 1, at least the previous frame). Numbers are
    /// printed so that they parse back to the same bits. Fails on non-finite pixels, and on
    /// cross-camera matches in a file without the `camera_to` column.
    pub fn push(&mut self, frame: usize, obs: &FrameObservations) -> Result<(), IoError> {
        let bad = |f: &AtomicFile, m: String| IoError::file(f.path(), IoErrorKind::InvalidData(m));
        if obs.is_empty() && obs.cross_camera.is_empty() {
            return Ok(());
        }
        if !self.cross && !obs.cross_camera.is_empty() {
            return Err(bad(
                &self.file,
                format!(
                    "frame {frame} has cross-camera matches; they need the camera_to column \
                     (MatchWriter::create_cross)"
                ),
            ));
        }
        if frame == 0 {
            return Err(bad(
                &self.file,
                "frame 0 has no predecessor; matches start at frame 1".into(),
            ));
        }
        if frame < self.last_frame {
            return Err(bad(
                &self.file,
                format!("frame {frame} after frame {}", self.last_frame),
            ));
        }
        let rows = obs
            .per_camera
            .iter()
            .enumerate()
            .flat_map(|(camera, list)| list.iter().map(move |o| (camera, camera, o)))
            .chain(
                obs.cross_camera
                    .iter()
                    .map(|c| (c.camera, c.camera_to, &c.obs)),
            );
        for (camera, camera_to, o) in rows {
            if !(o.px0.iter().chain(o.px1.iter()).all(|v| v.is_finite())) {
                return Err(bad(
                    &self.file,
                    format!("non-finite pixel in frame {frame}, camera {camera}"),
                ));
            }
            put!(
                &mut self.file,
                "{frame},{camera},{},{},{},{}",
                Exact(o.px0.x),
                Exact(o.px0.y),
                Exact(o.px1.x),
                Exact(o.px1.y)
            )?;
            if self.cross {
                put!(&mut self.file, ",{camera_to}\n")?;
            } else {
                put!(&mut self.file, "\n")?;
            }
        }
        self.last_frame = frame;
        Ok(())
    }

    /// Flushes and renames the file into place.
    pub fn finish(self) -> Result<(), IoError> {
        self.file.commit()
    }
}

/// Writes `matches.csv` atomically: `frames[k]` holds frame pair `(k-1, k)`; `frames[0]` must be
/// empty. The `camera_to` column is written only if some frame has cross-camera matches.
pub fn write_matches(path: impl AsRef<Path>, frames: &[FrameObservations]) -> Result<(), IoError> {
    stage_matches(path.as_ref(), frames)?.commit()
}

/// [`write_matches`] without the commit.
pub(crate) fn stage_matches(
    path: &Path,
    frames: &[FrameObservations],
) -> Result<AtomicFile, IoError> {
    let mut w = if frames.iter().any(|f| !f.cross_camera.is_empty()) {
        MatchWriter::create_cross(path)?
    } else {
        MatchWriter::create(path)?
    };
    for (k, obs) in frames.iter().enumerate() {
        w.push(k, obs)?;
    }
    Ok(w.file)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The positions of a header's indices, as [`MatchReader::new`] finds them.
    fn index_at(c: &[usize; 7]) -> [bool; 7] {
        let mut at = [false; 7];
        for k in [c[0], c[1], c[6]] {
            if let Some(a) = at.get_mut(k) {
                *a = true;
            }
        }
        at
    }

    /// The columns of `frame,camera,u0,v0,u1,v1[,camera_to]` and of a permuted header
    /// (`v1,camera,u0,frame,u1,v0[,camera_to]`).
    const ORDERS: [[usize; 7]; 4] = [
        [0, 1, 2, 3, 4, 5, usize::MAX],
        [0, 1, 2, 3, 4, 5, 6],
        [3, 1, 2, 5, 4, 0, usize::MAX],
        [3, 1, 2, 5, 4, 0, 6],
    ];

    /// Bitwise equality of two rows' fields (errors compared by their text).
    fn same(a: &RowFields, b: &RowFields) -> bool {
        let bits = |r: &RowFields| [r.2, r.3, r.4, r.5].map(f64::to_bits);
        let to = |r: &RowFields| match &r.6 {
            Ok(t) => Ok(*t),
            Err(e) => Err(e.to_string()),
        };
        (a.0, a.1) == (b.0, b.1) && bits(a) == bits(b) && to(a) == to(b)
    }

    /// Where [`fast_fields`] reads `line` with the columns `c`, the split and the field parsers
    /// read it to the same fields, bit for bit. Returns whether it did.
    fn check_fast(
        line: &str,
        c: &[usize; 7],
    ) -> Result<bool, proptest::test_runner::TestCaseError> {
        let with_to = c[6] != usize::MAX;
        let fast = if with_to {
            fast_fields::<7>(line.as_bytes(), c, &index_at(c))
        } else {
            fast_fields::<6>(line.as_bytes(), c, &index_at(c))
        };
        let Some(fast) = fast else {
            return Ok(false);
        };
        let slow = MatchReader::<&[u8]>::parse_fields(line, c, with_to);
        proptest::prop_assert!(
            slow.as_ref().is_ok_and(|s| same(&fast, s)),
            "{:?}: fast {:?}, field parsers {:?}",
            line,
            fast,
            slow.map_err(|e| e.to_string())
        );
        Ok(true)
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(3000))]
        /// `fast_float2` reads a text whole to a finite value only where `str::parse` reads it
        /// to the same bits: decimals of any length (past 19 digits and near halfway between
        /// two `f64`s it takes its slow, exact path), exponents, signs, `inf` / `nan` spellings.
        #[test]
        fn fast_float_reads_as_std_parse(
            text in "[+-]?[0-9]{0,30}(\\.[0-9]{0,30})?([eE][+-]?[0-9]{0,4})?|[0-9.eE+infatyINFATY-]{0,30}",
        ) {
            if let Ok((v, n)) = fast_float2::parse_partial::<f64, _>(text.as_bytes()) {
                if n == text.len() && v.is_finite() {
                    proptest::prop_assert_eq!(
                        text.parse::<f64>().ok().map(f64::to_bits),
                        Some(v.to_bits()),
                        "{}", text
                    );
                }
            }
        }

        /// Rows of pixels as `momo` and numpy write them (shortest round-trip prints,
        /// 17-digit mantissas, integers, signs, exponents), in both column orders, with and
        /// without `camera_to`: the one pass reads them as the field parsers do, and takes every
        /// row of plain decimals; anything spliced in anywhere is read alike or left to them.
        #[test]
        fn fast_rows_read_as_the_field_parsers(
            frame in 0u64..100_000,
            camera in 0u64..8,
            pixels in proptest::collection::vec(-2000.0f64..3000.0, 4),
            style in 0usize..8,
            junk in "[ ,0-9.eE+-]{0,6}|[\u{a0}\t\r\u{2003}é]|inf|NaN",
            at in 0usize..90,
        ) {
            let px = |v: f64| crate::text::tests::pixel_text(v, style);
            let row = format!(
                "{frame},{camera},{},{},{},{}",
                px(pixels[0]), px(pixels[1]), px(pixels[2]), px(pixels[3])
            );
            for c in &ORDERS {
                let line = if c[6] == usize::MAX { row.clone() } else { format!("{row},{camera}") };
                let took = check_fast(&line, c)?;
                // Frame and camera sit where the order puts indices: the permuted order reads
                // pixels there, which the one pass takes as indices only if they are digits.
                if c[0] == 0 {
                    proptest::prop_assert!(took, "{}", line);
                }
                let at = at.min(line.len());
                check_fast(&format!("{}{junk}{}", &line[..at], &line[at..]), c)?;
            }
            check_fast(&format!("{row},"), &ORDERS[1])?;
        }

        /// Any short text over the rows' bytes.
        #[test]
        fn fast_rows_of_any_bytes(line in "[ ,0-9.eE+-]{0,40}") {
            for c in &ORDERS {
                check_fast(&line, c)?;
            }
        }
    }

    #[test]
    fn fast_rows_leave_the_rest_to_the_field_parsers() {
        let c = &ORDERS[0];
        for line in [
            "1, 0,1,2,3,4",
            "1,0,1,2,3,4 ",
            "1,0,1,2,3,4\r",
            "1,0,,2,3,4",
            "1,0,1,2,3",
            "1,0,1,2,3,4,",
            "1,0,1,2,3,4,5",
            "+1,0,1,2,3,4",
            "1.0,0,1,2,3,4",
            "1,0,inf,2,3,4",
            "1,0,nan,2,3,4",
            "1,0,1e999,2,3,4",
            "1,0,1e,2,3,4",
            "1,0,0x10,2,3,4",
            "12345678901234567890,0,1,2,3,4",
            ",1,0,1,2,3,4",
        ] {
            assert!(
                fast_fields::<6>(line.as_bytes(), c, &index_at(c)).is_none(),
                "{line}"
            );
        }
        // Exponents, signs, bare points and long mantissas are read, as `str::parse` reads them.
        let line = "7,1,1.5e2,-0.0,.5,123456789012345678901234.5";
        let f = fast_fields::<6>(line.as_bytes(), c, &index_at(c)).expect("one pass");
        assert_eq!((f.0, f.1), (7, 1));
        assert_eq!(
            [f.2, f.3, f.4, f.5].map(f64::to_bits),
            [150.0, -0.0, 0.5, 123456789012345678901234.5].map(f64::to_bits)
        );
        // `camera_to` where the file has the column, in the permuted order too.
        let c = &ORDERS[3];
        let f = fast_fields::<7>(b"4,2,1,9,3,5,1", c, &index_at(c)).expect("one pass");
        assert_eq!((f.0, f.1, f.2, f.3, f.4, f.5), (9, 2, 1.0, 5.0, 3.0, 4.0));
        assert!(matches!(f.6, Ok(Some(1))));
    }
}

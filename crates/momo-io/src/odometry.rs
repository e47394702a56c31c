//! `odometry.csv`: the travelled arc length per frame pair (`FORMAT.md`, section
//! "odometry.csv").

use crate::atomic::{put, stage_atomic};
use crate::error::{IoError, IoErrorKind};
use crate::matches::MAX_FRAME;
use crate::text::{Exact, LineReader, is_blank, parse_f64, parse_header, parse_index, split_row};
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// Largest arc length of one frame pair, metres: 1 km between two frames is 36,000 km/h at
/// 10 Hz (and 3,600 km/h at 1 Hz), beyond any vehicle; larger values are typos or overflows.
pub const MAX_ARC_LENGTH: f64 = 1000.0;

/// The header line of `odometry.csv`. Readers accept the names in any order.
pub const ODOMETRY_HEADER: &str = "frame,arc_length";
const ODOMETRY_COLUMNS: [&str; 2] = ["frame", "arc_length"];

/// Reads `odometry.csv` from `reader`; `path` only names the source in errors.
///
/// Returns the arc lengths indexed by frame: `v[k]` for frame pair `(k-1, k)`, `v[0] = None`,
/// `None` for frames without a row, `v.len() = last frame + 1` (just `[None]` without rows).
/// Rejects: a missing or wrong header, rows without exactly two fields, unparsable or non-finite
/// numbers, arc lengths beyond ±[`MAX_ARC_LENGTH`] (negative ones, reversing, are accepted
/// since format version 5), frame 0, frames above [`MAX_FRAME`], frames that do not increase
/// (duplicates included).
pub fn read_odometry_from<R: BufRead>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<Option<f64>>, IoError> {
    let mut out: Vec<Option<f64>> = vec![None];
    for_each_row(reader, path.as_ref(), |frame, value| {
        out.resize(frame, None);
        out.push(Some(value));
    })?;
    Ok(out)
}

/// Reads `odometry.csv` from `reader` as its rows, `(frame, arc length)` with increasing frames,
/// without expanding the frame numbers (memory grows with the rows, not with the last frame).
/// The same rules as [`read_odometry_from`].
pub fn read_odometry_rows_from<R: BufRead>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<(usize, f64)>, IoError> {
    let mut out = Vec::new();
    for_each_row(reader, path.as_ref(), |frame, value| {
        out.push((frame, value))
    })?;
    Ok(out)
}

/// Reads `odometry.csv` as its rows (see [`read_odometry_rows_from`]).
pub fn read_odometry_rows(path: impl AsRef<Path>) -> Result<Vec<(usize, f64)>, IoError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| IoError::io(path, e))?;
    read_odometry_rows_from(BufReader::new(file), path)
}

/// Parses `odometry.csv` and hands every valid row to `row(frame, arc_length)`, in file order.
fn for_each_row<R: BufRead>(
    reader: R,
    path: &Path,
    mut row: impl FnMut(usize, f64),
) -> Result<(), IoError> {
    let mut lines = LineReader::new(reader);
    let mut columns = None;
    let mut previous = 0;
    loop {
        // `next_line` counts exactly one line per line it returns.
        let line_no = lines.line() + 1;
        let line = match lines.next_line() {
            Ok(Some(l)) => l,
            Ok(None) => break,
            Err(k) => return Err(IoError::at(path, lines.line(), k)),
        };
        if is_blank(line) {
            continue;
        }
        let at = |k| IoError::at(path, line_no, k);
        let Some(c) = columns else {
            columns = Some(parse_header(line, &ODOMETRY_COLUMNS, ODOMETRY_HEADER).map_err(at)?);
            continue;
        };
        let fields: [&str; 2] = split_row(line).map_err(at)?;
        let frame = parse_index("frame", fields[c[0]]).map_err(at)?;
        let value = parse_f64("arc_length", fields[c[1]]).map_err(at)?;
        if frame == 0 {
            return Err(at(IoErrorKind::FrameZero));
        }
        if frame > MAX_FRAME {
            return Err(at(IoErrorKind::FrameTooLarge {
                frame,
                max: MAX_FRAME,
            }));
        }
        if frame == previous && previous > 0 {
            return Err(at(IoErrorKind::DuplicateFrame { frame }));
        }
        if frame < previous {
            return Err(at(IoErrorKind::FramesOutOfOrder {
                frame,
                previous,
                order: "increasing",
            }));
        }
        if value.abs() > MAX_ARC_LENGTH {
            return Err(at(IoErrorKind::ArcLengthTooLarge {
                value,
                max: MAX_ARC_LENGTH,
            }));
        }
        previous = frame;
        row(frame, value);
    }
    if columns.is_none() {
        return Err(IoError::file(
            path,
            IoErrorKind::MissingHeader {
                expected: ODOMETRY_HEADER,
            },
        ));
    }
    Ok(())
}

/// Reads `odometry.csv` (see [`read_odometry_from`]).
pub fn read_odometry(path: impl AsRef<Path>) -> Result<Vec<Option<f64>>, IoError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| IoError::io(path, e))?;
    read_odometry_from(BufReader::new(file), path)
}

/// Writes `odometry.csv` atomically: one row per `Some` entry of `arc_lengths` (indexed by
/// frame). Fails on an arc length for frame 0, non-finite values or values beyond
/// ±[`MAX_ARC_LENGTH`] (negative values, reversing, are written).
pub fn write_odometry(path: impl AsRef<Path>, arc_lengths: &[Option<f64>]) -> Result<(), IoError> {
    stage_odometry(path.as_ref(), arc_lengths)?.commit()
}

/// [`write_odometry`] without the commit.
pub(crate) fn stage_odometry(
    path: &Path,
    arc_lengths: &[Option<f64>],
) -> Result<crate::AtomicFile, IoError> {
    let bad = |m: String| IoError::file(path, IoErrorKind::InvalidData(m));
    if let Some(Some(_)) = arc_lengths.first() {
        return Err(bad("an arc length for frame 0 (frames start at 1)".into()));
    }
    if let Some((k, v)) = arc_lengths.iter().enumerate().find_map(|(k, v)| {
        v.filter(|v| !(v.is_finite() && v.abs() <= MAX_ARC_LENGTH))
            .map(|v| (k, v))
    }) {
        return Err(bad(format!(
            "arc length {v:.6e} of frame {k} is not a number within -{MAX_ARC_LENGTH}..={MAX_ARC_LENGTH} m"
        )));
    }
    stage_atomic(path, |f| {
        put!(f, "{ODOMETRY_HEADER}\n")?;
        for (k, v) in arc_lengths.iter().enumerate() {
            if let Some(v) = v {
                put!(f, "{k},{}\n", Exact(*v))?;
            }
        }
        Ok(())
    })
}

//! Text plumbing shared by the readers and writers: a bounded line reader, CSV headers, numbers
//! that parse and print exactly.

use crate::error::{IoErrorKind, quote};
use std::fmt;
use std::io::{BufRead, ErrorKind};

/// Longest line accepted by every line-based reader (1 MiB). Longer lines are an input error,
/// and at most this many bytes of a line are ever held in memory.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Reads lines of at most `limit` bytes, counting them (1-based) for error messages.
pub(crate) struct LineReader<R> {
    inner: R,
    buf: Vec<u8>,
    line: usize,
    limit: usize,
    /// Bytes of `inner`'s buffer that the line returned last still borrows: consumed at the
    /// start of the next call ([`next_line_bytes`](Self::next_line_bytes)).
    pending: usize,
}

impl<R: BufRead> LineReader<R> {
    pub(crate) fn new(inner: R) -> Self {
        Self::with_limit(inner, MAX_LINE_BYTES)
    }

    pub(crate) fn with_limit(inner: R, limit: usize) -> Self {
        Self {
            inner,
            buf: Vec::new(),
            line: 0,
            limit,
            pending: 0,
        }
    }

    /// The number of the line returned last (1-based; 0 before the first).
    pub(crate) fn line(&self) -> usize {
        self.line
    }

    /// The next line without its terminator (`\n` or `\r\n`), `None` at the end of the input.
    /// On error, [`line`](Self::line) is the line that failed.
    pub(crate) fn next_line(&mut self) -> Result<Option<&str>, IoErrorKind> {
        let first = self.line == 0;
        let Some(bytes) = self.next_line_bytes()? else {
            return Ok(None);
        };
        let mut s = std::str::from_utf8(bytes).map_err(|_| IoErrorKind::InvalidUtf8)?;
        if first {
            s = s.strip_prefix('\u{feff}').unwrap_or(s);
        }
        Ok(Some(s))
    }

    /// [`next_line`](Self::next_line) as bytes, before the UTF-8 check and without stripping
    /// a byte-order mark (the caller checks what it does not read as ASCII: `matches.csv`'s
    /// rows of plain numbers need no check). A line that lies whole in `inner`'s buffer is
    /// returned in place (consumed at the next call), any other is gathered into a buffer of
    /// its own.
    pub(crate) fn next_line_bytes(&mut self) -> Result<Option<&[u8]>, IoErrorKind> {
        if self.pending > 0 {
            self.inner.consume(std::mem::take(&mut self.pending));
        }
        // The line's end in what the reader holds (not there, or an interrupted read: the
        // loop below gathers the line).
        let found = match self.inner.fill_buf() {
            Ok(available) => memchr::memchr(b'\n', available).filter(|&i| i <= self.limit),
            Err(e) if e.kind() == ErrorKind::Interrupted => None,
            Err(e) => {
                self.line += 1;
                return Err(IoErrorKind::Io(e));
            }
        };
        if let Some(i) = found {
            // `fill_buf` on a non-empty buffer returns it again without reading (`BufRead`'s
            // contract; a reader that broke it gets an error, not a wrong line).
            self.line += 1;
            let available = self.inner.fill_buf().map_err(IoErrorKind::Io)?;
            let mut line = available
                .get(..i)
                .filter(|_| available.get(i) == Some(&b'\n'))
                .ok_or_else(|| {
                    IoErrorKind::Io(std::io::Error::other(
                        "the reader's buffer changed between two calls of fill_buf",
                    ))
                })?;
            self.pending = i + 1;
            if let [rest @ .., b'\r'] = line {
                line = rest;
            }
            return Ok(Some(line));
        }
        self.buf.clear();
        let mut got_bytes = false;
        loop {
            let available = match self.inner.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(e) => {
                    self.line += 1;
                    return Err(IoErrorKind::Io(e));
                }
            };
            if available.is_empty() {
                if !got_bytes {
                    return Ok(None);
                }
                break;
            }
            got_bytes = true;
            // `memchr`: a word-at-a-time search (the byte loop it replaces was a fifth of
            // reading a row of `matches.csv`).
            let (take, consume, done) = match memchr::memchr(b'\n', available) {
                Some(i) => (i, i + 1, true),
                None => (available.len(), available.len(), false),
            };
            if self.buf.len() + take > self.limit {
                self.line += 1;
                return Err(IoErrorKind::TooLong { limit: self.limit });
            }
            self.buf.extend_from_slice(&available[..take]);
            self.inner.consume(consume);
            if done {
                break;
            }
        }
        self.line += 1;
        if self.buf.last() == Some(&b'\r') {
            self.buf.pop();
        }
        Ok(Some(&self.buf))
    }
}

/// Parses a CSV header that must name exactly the columns `expected` (in any order, surrounding
/// whitespace ignored). Returns, for each expected column, its position in the file.
pub(crate) fn parse_header<const N: usize>(
    line: &str,
    expected: &[&str; N],
    expected_line: &'static str,
) -> Result<[usize; N], IoErrorKind> {
    let bad = |reason: String| IoErrorKind::BadHeader {
        reason,
        expected: expected_line,
    };
    // numpy's `savetxt(..., header=...)` writes the header as a `# ` comment.
    let line = line.trim_start();
    let line = line.strip_prefix('#').unwrap_or(line);
    if !line.contains(',') && line.split_whitespace().count() > 1 {
        return Err(bad(format!(
            "columns must be separated by commas, found `{}` (numpy: np.savetxt(path, a, delimiter=\",\", header=\"{expected_line}\"))",
            quote(line.trim())
        )));
    }
    let names: Vec<&str> = line.split(',').map(str::trim).collect();
    if names.first().is_some_and(|n| n.parse::<f64>().is_ok()) {
        return Err(IoErrorKind::MissingHeader {
            expected: expected_line,
        });
    }
    let mut pos = [usize::MAX; N];
    for (i, name) in names.iter().enumerate() {
        match expected.iter().position(|e| e == name) {
            Some(k) if pos[k] != usize::MAX => {
                return Err(bad(format!("column `{}` appears twice", quote(name))));
            }
            Some(k) => pos[k] = i,
            None => return Err(bad(format!("unknown column `{}`", quote(name)))),
        }
    }
    let missing: Vec<&str> = expected
        .iter()
        .zip(pos)
        .filter(|(_, p)| *p == usize::MAX)
        .map(|(e, _)| *e)
        .collect();
    if !missing.is_empty() {
        return Err(bad(format!("missing column(s) `{}`", missing.join("`, `"))));
    }
    Ok(pos)
}

/// Splits a CSV row into exactly `N` trimmed fields (trimmed as [`str::trim`] does).
///
/// A byte loop rather than `str::split` + `str::trim`: this is the inner loop of reading
/// `matches.csv` (about a third of a whole `momo run` before). (`memchr::memchr_iter` for the
/// commas was measured, issue 19, twelfth session: 940 -> 820 instructions per 75-byte row of
/// 17-digit pixels, but 597 -> 832 per 18-byte row of integer pixels; not kept.)
pub(crate) fn split_row<const N: usize>(line: &str) -> Result<[&str; N], IoErrorKind> {
    let mut out = [""; N];
    let mut n = 0;
    let mut start = 0;
    for (i, &b) in line.as_bytes().iter().enumerate() {
        if b == b',' {
            if n < N {
                out[n] = trim(&line[start..i]);
            }
            n += 1;
            start = i + 1;
        }
    }
    if n < N {
        out[n] = trim(&line[start..]);
    }
    n += 1;
    if n == N {
        Ok(out)
    } else {
        Err(IoErrorKind::FieldCount {
            expected: N,
            found: n,
        })
    }
}

/// The ASCII bytes that [`char::is_whitespace`] accepts (`u8::is_ascii_whitespace` leaves out
/// the vertical tab).
fn is_ascii_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r')
}

/// [`str::trim`], with a fast path for ASCII edges.
fn trim(s: &str) -> &str {
    let b = s.as_bytes();
    let mut start = 0;
    let mut end = b.len();
    while start < end && is_ascii_space(b[start]) {
        start += 1;
    }
    while end > start && is_ascii_space(b[end - 1]) {
        end -= 1;
    }
    if (start < end) && (b[start] >= 0x80 || b[end - 1] >= 0x80) {
        // A non-ASCII character at an edge may be Unicode whitespace.
        return s.trim();
    }
    &s[start..end]
}

/// A plain decimal (`[+-]digits[.digits]`, at most 19 digits, no exponent) parsed exactly, or
/// `None` when the text is anything else. Clinger's fast path: when the digits form an integer
/// `w < 2^53` and there are `k <= 22` of them after the point, `w` and `10^k` are exact `f64`s,
/// so the one correctly rounded division `w / 10^k` is the correctly rounded value of the text:
/// bit-identical to [`str::parse`], which is correctly rounded too. Longer mantissas (17 to 19
/// digits, as a shortest round-trip print of a pixel coordinate has) take the division as an
/// estimate and correct it by exact integer comparisons ([`round_quotient`]).
fn parse_plain_decimal(text: &str) -> Option<f64> {
    // The one scanner of plain decimals: a row of one field is exactly this text.
    let [field] = plain_row::<1>(text)?;
    field.value()
}

/// The value of a plain decimal of at most 19 digits `w` with `k <= 22` of them after the point
/// (checked by [`plain_row`]): correctly rounded, `None` where the
/// integer comparisons of [`round_quotient`] would not fit.
fn plain_value(negative: bool, w: u64, k: usize) -> Option<f64> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let v = if w < 1 << 53 {
        // `w < 2^53` converts exactly.
        w as f64 / POW10[k]
    } else if k == 0 {
        // One conversion, correctly rounded (ties to even).
        w as f64
    } else {
        // 17 to 19 digits: `w < 10^19` and `10^k` exact, `w / 10^k` correctly rounded by
        // integer comparisons with the midpoints around an estimate.
        round_quotient(w, POW10[k] as u64, w as f64 / POW10[k])?
    };
    Some(if negative { -v } else { v })
}

/// One field of a row of plain numbers ([`plain_row`]): its sign, its digits as an integer,
/// and how many of them follow the point (`None`: no point).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PlainField {
    /// A leading `-`.
    pub negative: bool,
    /// A leading sign (`-` or `+`).
    pub signed: bool,
    /// The digits (at most 19) as one integer.
    pub digits: u64,
    /// Digits after the point, if there is one.
    pub fraction: Option<usize>,
}

impl PlainField {
    /// The field as [`parse_index`] reads it, where it is a plain unsigned integer (no sign, no
    /// point): `usize::from_str` of it (the tests' reading of whole rows).
    #[cfg(test)]
    pub fn index(&self) -> Option<usize> {
        if self.signed || self.fraction.is_some() {
            return None;
        }
        usize::try_from(self.digits).ok()
    }

    /// The field as [`parse_f64`] reads it (a plain decimal is read exactly as
    /// [`parse_plain_decimal`] reads it).
    pub fn value(&self) -> Option<f64> {
        plain_value(self.negative, self.digits, self.fraction.unwrap_or(0))
    }
}

/// A CSV row of exactly `N` plain numbers (`[+-]digits[.digits]`, at least one digit before the
/// point and one after it, at most 19 digits in all, separated by single commas, no whitespace)
/// scanned in one pass, or `None` for any other row (the caller then takes [`split_row`] and
/// the field parsers, which read these rows to the same values). [`parse_f64`]'s scanner of
/// plain decimals (one field); `matches.csv`'s rows were read through it from the thirteenth
/// session (issue 19) to the nineteenth, and are now read by `fast_fields` (matches.rs).
pub(crate) fn plain_row<const N: usize>(line: &str) -> Option<[PlainField; N]> {
    let b = line.as_bytes();
    let mut out = [PlainField::default(); N];
    let mut i = 0;
    for (f, field) in out.iter_mut().enumerate() {
        if f > 0 {
            if b.get(i) != Some(&b',') {
                return None;
            }
            i += 1;
        }
        match b.get(i) {
            Some(b'-') => {
                field.negative = true;
                field.signed = true;
                i += 1;
            }
            Some(b'+') => {
                field.signed = true;
                i += 1;
            }
            _ => {}
        }
        let start = i;
        let mut w: u64 = 0;
        while let Some(&d) = b.get(i).filter(|d| d.is_ascii_digit()) {
            w = w.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
            i += 1;
        }
        let int_digits = i - start;
        if int_digits == 0 {
            return None;
        }
        let mut k = None;
        if b.get(i) == Some(&b'.') {
            i += 1;
            let first = i;
            while let Some(&d) = b.get(i).filter(|d| d.is_ascii_digit()) {
                w = w.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
                i += 1;
            }
            if i == first {
                return None;
            }
            k = Some(i - first);
        }
        if int_digits + k.unwrap_or(0) > 19 {
            return None;
        }
        field.digits = w;
        field.fraction = k;
    }
    (i == b.len()).then_some(out)
}

/// The correctly rounded (ties to even) `f64` of `w / d` for `d <= 10^19`, `w < 2^64` and a
/// positive normal estimate `x` within a few units in the last place of it: the estimate is
/// moved one `f64` at a time while `w / d` lies beyond the midpoint to a neighbour, the
/// comparisons of `w 2^(1 - e)` with `(2 m + 1) d` exact in `u128`. `None` (the caller falls back to
/// `str::parse`) when the estimate is not such a number or a comparison would not fit.
fn round_quotient(w: u64, d: u64, mut x: f64) -> Option<f64> {
    // `w / d` against the midpoint `(2 m + 1) 2^(e - 1)` of `m 2^e` and `(m + 1) 2^e`.
    let above = |m: u64, e: i32| -> Option<std::cmp::Ordering> {
        // `w 2^(1 - e)` against `(2 m + 1) d`, the power of two on the side where it is whole.
        let (mut lhs, mut rhs) = (
            u128::from(w),
            u128::from(2 * m + 1).checked_mul(u128::from(d))?,
        );
        let s = 1 - e;
        let (side, shift) = if s >= 0 {
            (&mut lhs, s.unsigned_abs())
        } else {
            (&mut rhs, s.unsigned_abs())
        };
        if shift >= 128 || side.leading_zeros() < shift {
            return None;
        }
        *side <<= shift;
        Some(lhs.cmp(&rhs))
    };
    use std::cmp::Ordering::{Equal, Greater, Less};
    for _ in 0..4 {
        if !x.is_normal() || x < 0.0 {
            return None;
        }
        let bits = x.to_bits();
        let e = ((bits >> 52) & 0x7ff) as i32 - 1075;
        let m = (bits & ((1 << 52) - 1)) | (1 << 52);
        // The midpoint to the next larger `f64` (`m + 1` may be `2^53`: same midpoint).
        match above(m, e)? {
            Greater => {
                x = f64::from_bits(bits + 1);
                continue;
            }
            Equal if m & 1 == 1 => return Some(f64::from_bits(bits + 1)),
            _ => {}
        }
        // The midpoint to the next smaller `f64` (half as far below a power of two).
        let (ml, el) = if m == 1 << 52 {
            ((1 << 53) - 1, e - 1)
        } else {
            (m - 1, e)
        };
        match above(ml, el)? {
            Less => {
                x = f64::from_bits(bits - 1);
                continue;
            }
            Equal if m & 1 == 1 => return Some(f64::from_bits(bits - 1)),
            _ => {}
        }
        return Some(x);
    }
    None
}

/// Parses a finite `f64`.
pub(crate) fn parse_f64(field: &str, text: &str) -> Result<f64, IoErrorKind> {
    if let Some(v) = parse_plain_decimal(text) {
        return Ok(v);
    }
    let v: f64 = text.parse().map_err(|_| IoErrorKind::BadNumber {
        field: field.to_owned(),
        value: quote(text),
        expected: "a number",
    })?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(IoErrorKind::NonFinite {
            field: field.to_owned(),
            value: v,
        })
    }
}

/// Parses a non-negative integer; a whole number written as a float (`3.0`,
/// `3.000000000000000000e+00`, as numpy's `savetxt` writes integers by default) is accepted.
pub(crate) fn parse_index(field: &str, text: &str) -> Result<usize, IoErrorKind> {
    text.parse().or_else(|_| {
        text.parse::<f64>()
            .ok()
            .filter(|v| *v >= 0.0 && v.fract() == 0.0 && *v <= 9_007_199_254_740_992.0)
            .map(|v| v as usize)
            .ok_or_else(|| IoErrorKind::BadNumber {
                field: field.to_owned(),
                value: quote(text),
                expected: "a non-negative integer",
            })
    })
}

/// Prints an `f64` with the shortest text that parses back to the same bits (plain decimal for
/// moderate magnitudes, scientific otherwise).
pub(crate) struct Exact(pub f64);

impl fmt::Display for Exact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || (1e-5..1e16).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// True for lines that hold nothing but whitespace.
pub(crate) fn is_blank(line: &str) -> bool {
    line.trim().is_empty()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A pixel coordinate written as `momo` and numpy write them, in one of eight styles:
    /// shortest round-trip, three decimals, a rounded integer (two ways), an explicit sign,
    /// 17 decimals, an exponent, 25 decimals of a seventh. The parsers' property tests share it.
    pub(crate) fn pixel_text(v: f64, style: usize) -> String {
        match style {
            0 => format!("{v}"),
            1 => format!("{v:.3}"),
            2 => format!("{}", v.round()),
            3 => format!("{:.0}", v),
            4 => format!("+{}", v.abs()),
            5 => format!("{:.17}", v),
            6 => format!("{v:e}"),
            _ => format!("{:.25}", v / 7.0),
        }
    }

    #[test]
    fn lines_are_bounded_and_counted() {
        let text = b"ab\r\ncd\n\nlast";
        let mut r = LineReader::new(&text[..]);
        assert_eq!(r.next_line().unwrap(), Some("ab"));
        assert_eq!(r.next_line().unwrap(), Some("cd"));
        assert_eq!(r.next_line().unwrap(), Some(""));
        assert_eq!(r.next_line().unwrap(), Some("last"));
        assert_eq!(r.line(), 4);
        assert_eq!(r.next_line().unwrap(), None);

        let long = [b'x'; 100];
        let mut r = LineReader::with_limit(std::io::BufReader::with_capacity(7, &long[..]), 50);
        assert!(matches!(
            r.next_line(),
            Err(IoErrorKind::TooLong { limit: 50 })
        ));
        assert_eq!(r.line(), 1);

        let mut r = LineReader::new(&b"ok\n\xff\xfe\n"[..]);
        assert_eq!(r.next_line().unwrap(), Some("ok"));
        assert!(matches!(r.next_line(), Err(IoErrorKind::InvalidUtf8)));
        assert_eq!(r.line(), 2);
    }

    /// The reference `split_row` and `trim`: `str::split` and `str::trim`.
    fn split_reference<const N: usize>(line: &str) -> Option<[&str; N]> {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        fields.try_into().ok()
    }

    #[test]
    fn split_row_trims_as_str_trim() {
        for line in [
            "1,0, 2.5 ,\t3,4\u{b},5",
            "\u{a0}1,0,2,3,4,\u{2003}5\u{2003}",
            ",,,,,",
            " , , , , , ",
            "é,0,1,2,3,4",
            "1,2,3",
            "1,2,3,4,5,6,7",
        ] {
            assert_eq!(
                split_row::<6>(line).ok(),
                split_reference::<6>(line),
                "{line:?}"
            );
        }
        assert!(matches!(
            split_row::<6>("1,2,3"),
            Err(IoErrorKind::FieldCount {
                expected: 6,
                found: 3
            })
        ));
    }

    #[test]
    fn plain_decimals_parse_as_std_does() {
        for text in [
            "0",
            "-0",
            "+0",
            "0.0",
            "-0.000",
            "612.31",
            "-612.31",
            "1",
            "9007199254740991",
            "9007199254740992",
            "0.1",
            "0.30000000000000004",
            "123456789.123456789",
            "1.0000000000000000000001",
            "1.",
            ".5",
            "1e3",
            "--1",
            "1.2.3",
            "",
            "-",
            "+",
            "inf",
            "NaN",
            "0x10",
            "1_0",
            " 1",
        ] {
            let fast = parse_plain_decimal(text);
            let std = text.parse::<f64>().ok();
            if let Some(v) = fast {
                assert_eq!(Some(v.to_bits()), std.map(f64::to_bits), "{text}");
            }
        }
        // The fast path takes the usual pixel columns.
        assert!(parse_plain_decimal("612.3125").is_some());
        assert!(parse_plain_decimal("-0.5").is_some());
    }

    /// [`plain_row`]'s reading of a row, where it gives one: each field as the split row's
    /// field parsers read it (indices as [`parse_index`], values bit for bit as [`parse_f64`]).
    /// Returns whether the one pass read every field (the row took the fast path).
    fn check_plain_row<const N: usize>(
        line: &str,
    ) -> Result<bool, proptest::test_runner::TestCaseError> {
        let Some(fast) = plain_row::<N>(line) else {
            return Ok(false);
        };
        let fields = split_row::<N>(line);
        proptest::prop_assert!(fields.is_ok(), "{}", line);
        let fields = fields.unwrap_or([""; N]);
        let mut all = true;
        for (f, text) in fast.iter().zip(fields) {
            if let Some(i) = f.index() {
                proptest::prop_assert_eq!(Some(i), parse_index("i", text).ok(), "{}", line);
            }
            match f.value() {
                Some(v) => proptest::prop_assert_eq!(
                    Some(v.to_bits()),
                    parse_f64("v", text).ok().map(f64::to_bits),
                    "{}",
                    line
                ),
                None => all = false,
            }
        }
        Ok(all)
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]
        /// Rows of pixels as `momo` and numpy write them (shortest round-trip prints of random
        /// values, 17-digit mantissas, integers, signs) read by the one pass exactly as by the
        /// split and the field parsers; rows with anything else (spaces, exponents, empty or
        /// extra fields, a bare point) are left to them.
        #[test]
        fn plain_rows_read_as_the_field_parsers(
            frame in 0u64..100_000,
            camera in 0u64..8,
            pixels in proptest::collection::vec(-2000.0f64..3000.0, 4),
            style in 0usize..6,
            junk in "[ ,0-9.eE+-]{0,6}",
            at in 0usize..80,
        ) {
            let px = |v: f64| pixel_text(v, style);
            let line = format!(
                "{frame},{camera},{},{},{},{}",
                px(pixels[0]), px(pixels[1]), px(pixels[2]), px(pixels[3])
            );
            let took = check_plain_row::<6>(&line)?;
            if style < 4 && pixels.iter().all(|v| v.abs() >= 0.01) {
                // Every such row takes the one pass (at most 19 digits a field).
                proptest::prop_assert!(took, "{}", line);
            }
            check_plain_row::<7>(&format!("{line},{camera}"))?;
            check_plain_row::<7>(&format!("{line},"))?;
            // Anything spliced in anywhere: either the same reading or the field parsers.
            let at = at.min(line.len());
            let spliced = format!("{}{junk}{}", &line[..at], &line[at..]);
            check_plain_row::<6>(&spliced)?;
            check_plain_row::<7>(&spliced)?;
        }

        /// Any short text over the row's bytes: wherever the one pass reads a row, it reads it
        /// as the field parsers do.
        #[test]
        fn plain_rows_of_any_bytes(line in "[ ,0-9.eE+-]{0,40}") {
            check_plain_row::<6>(&line)?;
            check_plain_row::<7>(&line)?;
        }
    }

    #[test]
    fn plain_rows_refuse_what_the_field_parsers_would_read_otherwise() {
        // Whitespace, exponents, a bare point, an empty field, 20 digits: not the one pass.
        for line in [
            "1, 0,1,2,3,4",
            "1,0,1e3,2,3,4",
            "1,0,1.,2,3,4",
            "1,0,.5,2,3,4",
            "1,0,,2,3,4",
            "1,0,12345678901234567890,2,3,4",
            "1,0,1,2,3,4,",
            "1,0,1,2,3",
            "1,0,1,2,3,4\r",
        ] {
            assert!(plain_row::<6>(line).is_none(), "{line}");
        }
        // A sign or a point in an index: read as a value, not as an index.
        let f = plain_row::<6>("+1,0.0,1,2,3,-4.25").expect("plain");
        assert_eq!(f[0].index(), None);
        assert_eq!(f[1].index(), None);
        assert_eq!(f[5].value(), Some(-4.25));
        let f = plain_row::<6>("7,0,1,2,3,4").expect("plain");
        assert_eq!(f[0].index(), Some(7));
    }

    proptest::proptest! {
        #[test]
        fn split_row_matches_split_and_trim(line in "[ ,0-9.\t\u{a0}\u{b}é\u{2003}-]{0,40}") {
            proptest::prop_assert_eq!(split_row::<6>(&line).ok(), split_reference::<6>(&line));
            proptest::prop_assert_eq!(split_row::<7>(&line).ok(), split_reference::<7>(&line));
        }

        #[test]
        fn plain_decimals_are_bit_identical_to_std(
            int in 0u64..1_000_000,
            frac in "[0-9]{0,9}",
            negative in proptest::bool::ANY,
        ) {
            let text = format!(
                "{}{int}{}{frac}",
                if negative { "-" } else { "" },
                if frac.is_empty() { "" } else { "." }
            );
            // At most 15 digits: always below 2^53, so the fast path takes it.
            let fast = parse_plain_decimal(&text);
            proptest::prop_assert!(fast.is_some(), "{}", text);
            proptest::prop_assert_eq!(
                fast.map(f64::to_bits),
                text.parse::<f64>().ok().map(f64::to_bits),
                "{}", text
            );
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]
        /// 16 to 19 digits (mantissas above `2^53`, corrected by `round_quotient`), with the
        /// point anywhere: bit-identical to `str::parse`, and the fast path takes every one.
        #[test]
        fn long_decimals_are_bit_identical_to_std(
            digits in "[1-9][0-9]{15,18}",
            point in 0usize..19,
            negative in proptest::bool::ANY,
        ) {
            let point = point.min(digits.len());
            let (a, b) = digits.split_at(point);
            let text = format!(
                "{}{}{}{b}",
                if negative { "-" } else { "" },
                if a.is_empty() { "0" } else { a },
                if b.is_empty() { "" } else { "." },
            );
            let fast = parse_plain_decimal(&text);
            let std = text.parse::<f64>().ok().map(f64::to_bits);
            // With a leading `0.` the text may have 20 digits: then it may fall back.
            if fast.is_some() || text.bytes().filter(u8::is_ascii_digit).count() <= 19 {
                proptest::prop_assert_eq!(fast.map(f64::to_bits), std, "{}", text);
            }
        }

        /// The same for integers and integer parts above `2^54`, where the midpoints are
        /// whole numbers.
        #[test]
        fn large_decimals_are_bit_identical_to_std(
            digits in "[1-9][0-9]{16,18}",
            fraction in "[0-9]{0,2}",
        ) {
            let digits = &digits[..digits.len().min(19 - fraction.len())];
            let text = if fraction.is_empty() {
                digits.to_string()
            } else {
                format!("{digits}.{fraction}")
            };
            let fast = parse_plain_decimal(&text);
            let std = text.parse::<f64>().ok().map(f64::to_bits);
            proptest::prop_assert_eq!(fast.map(f64::to_bits), std, "{}", text);
        }

        /// Shortest round-trip prints of pixel-like `f64`s (what a writer of `matches.csv`
        /// with full precision produces) and fixed 12-15 decimals: bit-identical to `str::parse`.
        #[test]
        fn printed_pixels_are_bit_identical_to_std(
            bits in 0u64..(1 << 52),
            exp in 0i32..12,
            decimals in 12usize..16,
        ) {
            let x = f64::from_bits(bits | (1023 << 52)) * f64::from(1 << exp);
            for text in [format!("{x}"), format!("{x:.decimals$}"), format!("{}", x / 7.0)] {
                let fast = parse_plain_decimal(&text);
                let std = text.parse::<f64>().ok().map(f64::to_bits);
                if fast.is_some() || text.len() <= 20 {
                    proptest::prop_assert_eq!(fast.map(f64::to_bits), std, "{}", text);
                }
            }
        }
    }

    #[test]
    fn rounding_corner_cases_match_std() {
        // Exact ties between two f64s, values next to powers of two, the largest mantissas.
        for text in [
            "9007199254740993",
            "9007199254740995",
            "18014398509481990",
            "18014398509481986",
            "9223372036854775807",
            "9999999999999999999",
            "1000000000000000000",
            "0.999999999999999999",
            "0.500000000000000001",
            "4503599627370496.5",
            "4503599627370497.5",
            "2251799813685248.25",
            "1.000000000000000111",
            "1.000000000000000112",
            "1.000000000000000222",
            "1.000000000000000223",
            "0.000000000000000001",
            "0.001234567890123456",
            "123.45678901234567",
            "-612.31250000000001",
        ] {
            let fast = parse_plain_decimal(text);
            assert!(fast.is_some(), "{text}");
            assert_eq!(
                fast.map(f64::to_bits),
                text.parse::<f64>().ok().map(f64::to_bits),
                "{text}"
            );
        }
    }

    #[test]
    fn bom_is_skipped() {
        let mut r = LineReader::new("\u{feff}frame,arc_length\n".as_bytes());
        assert_eq!(r.next_line().unwrap(), Some("frame,arc_length"));
    }

    #[test]
    fn exact_numbers_round_trip() {
        for x in [
            0.0,
            -0.0,
            1.0,
            0.1,
            1e-300,
            -3.5e20,
            612.31,
            f64::MIN_POSITIVE,
            f64::MAX,
            5e-324,
        ] {
            let s = Exact(x).to_string();
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{s}");
        }
    }

    #[test]
    fn header_any_order() {
        let pos = parse_header(" b , a ", &["a", "b"], "a,b").unwrap();
        assert_eq!(pos, [1, 0]);
        assert!(matches!(
            parse_header("a", &["a", "b"], "a,b"),
            Err(IoErrorKind::BadHeader { .. })
        ));
        assert!(matches!(
            parse_header("a,b,c", &["a", "b"], "a,b"),
            Err(IoErrorKind::BadHeader { .. })
        ));
        assert!(matches!(
            parse_header("a,a", &["a", "b"], "a,b"),
            Err(IoErrorKind::BadHeader { .. })
        ));
        assert!(matches!(
            parse_header("1,2", &["a", "b"], "a,b"),
            Err(IoErrorKind::MissingHeader { .. })
        ));
    }
}

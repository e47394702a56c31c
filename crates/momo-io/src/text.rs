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
        }
    }

    /// The number of the line returned last (1-based; 0 before the first).
    pub(crate) fn line(&self) -> usize {
        self.line
    }

    /// The next line without its terminator (`\n` or `\r\n`), `None` at the end of the input.
    /// On error, [`line`](Self::line) is the line that failed.
    pub(crate) fn next_line(&mut self) -> Result<Option<&str>, IoErrorKind> {
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
            let (take, consume, done) = match available.iter().position(|&b| b == b'\n') {
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
        let mut s = std::str::from_utf8(&self.buf).map_err(|_| IoErrorKind::InvalidUtf8)?;
        if self.line == 1 {
            s = s.strip_prefix('\u{feff}').unwrap_or(s);
        }
        Ok(Some(s))
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

/// Splits a CSV row into exactly `N` trimmed fields.
pub(crate) fn split_row<const N: usize>(line: &str) -> Result<[&str; N], IoErrorKind> {
    let mut out = [""; N];
    let mut n = 0;
    for field in line.split(',') {
        if n < N {
            out[n] = field.trim();
        }
        n += 1;
    }
    if n == N {
        Ok(out)
    } else {
        Err(IoErrorKind::FieldCount {
            expected: N,
            found: n,
        })
    }
}

/// Parses a finite `f64`.
pub(crate) fn parse_f64(field: &str, text: &str) -> Result<f64, IoErrorKind> {
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
mod tests {
    use super::*;

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

//! A cursor over a compacted line and the lexical error it reports: what the lexer and the
//! expression reader ([`crate::expr`]) both read with.

use crate::error::ParseErrorKind;

/// A lexical error with its source byte range.
#[derive(Debug)]
pub(crate) struct LexError {
    pub kind: ParseErrorKind,
    pub start: usize,
    pub end: usize,
}

/// A cursor over a compacted line.
pub(crate) struct Cursor<'a> {
    pub buf: &'a [u8],
    pub map: &'a [usize],
    pub line_end: usize,
    pub pos: usize,
}

impl Cursor<'_> {
    /// The byte at the cursor, if any.
    #[inline]
    pub fn peek(&self) -> Option<u8> {
        self.buf.get(self.pos).copied()
    }
    /// The byte `k` after the cursor, if any.
    #[inline]
    pub fn peek_at(&self, k: usize) -> Option<u8> {
        self.buf.get(self.pos + k).copied()
    }
    /// Source offset of compacted index `i` (the line end past the last byte).
    #[inline]
    pub fn src(&self, i: usize) -> usize {
        self.map.get(i).copied().unwrap_or(self.line_end)
    }
    /// Source offset just past compacted index `i - 1`.
    #[inline]
    pub fn src_end(&self, i: usize) -> usize {
        if i == 0 {
            self.src(0)
        } else {
            self.map.get(i - 1).map_or(self.line_end, |&o| o + 1)
        }
    }
    /// An error spanning compacted indices `start..end`.
    pub fn error(&self, kind: ParseErrorKind, start: usize, end: usize) -> LexError {
        let s = self.src(start);
        let e = self.src_end(end.max(start + 1)).max(s);
        LexError {
            kind,
            start: s,
            end: e,
        }
    }
    /// True when the rest starts with `kw`.
    #[inline]
    pub fn starts_with(&self, kw: &[u8]) -> bool {
        self.buf[self.pos..].starts_with(kw)
    }
    /// Reads `digits[.digits]` or `.digits` at the cursor.
    ///
    /// Fast path (Clinger): with at most 15 significant digits the digits form an integer
    /// `m < 2^53` and the value is `m / 10^k` with `k <= 22`, both exactly representable,
    /// so one correctly rounded division gives exactly what `str::parse::<f64>` gives.
    /// Anything longer goes through `str::parse`.
    pub fn read_number(&mut self) -> Result<f64, LexError> {
        let start = self.pos;
        let mut digits = 0u32;
        let mut mantissa = 0u64;
        let mut frac_digits = 0i32;
        while let Some(b) = self.peek() {
            if b.is_ascii_digit() {
                digits += 1;
                mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(b - b'0'));
                self.pos += 1;
            } else {
                break;
            }
        }
        if self.peek() == Some(b'.') {
            self.pos += 1;
            while let Some(b) = self.peek() {
                if b.is_ascii_digit() {
                    digits += 1;
                    frac_digits += 1;
                    mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(b - b'0'));
                    self.pos += 1;
                } else {
                    break;
                }
            }
        }
        const POW10: [f64; 23] = [
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
            1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
        ];
        if digits > 0 && digits <= 15 && self.peek() != Some(b'.') {
            return Ok(mantissa as f64 / POW10[frac_digits as usize]);
        }
        let bad = |c: &Cursor<'_>| {
            let mut end = c.pos;
            // Swallow the rest of the number-like run for the span.
            while end < c.buf.len() && (c.buf[end].is_ascii_digit() || c.buf[end] == b'.') {
                end += 1;
            }
            c.error(ParseErrorKind::MalformedNumber, start, end)
        };
        if digits == 0 || self.peek() == Some(b'.') {
            return Err(bad(self));
        }
        // The slice is ASCII digits and at most one '.', so it is valid UTF-8.
        let text = std::str::from_utf8(&self.buf[start..self.pos]).map_err(|_| bad(self))?;
        let v: f64 = text.parse().map_err(|_| bad(self))?;
        if !v.is_finite() {
            return Err(self.error(ParseErrorKind::OutOfRange, start, self.pos));
        }
        Ok(v)
    }
}

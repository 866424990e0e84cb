//! Where the interpreter's lines come from: a program held whole in memory, or a file read
//! line by line ([`crate::BlockReader`]), so that a program of any size is read in bounded
//! memory.
//!
//! Either way the interpreter sees one physical line at a time, by its byte offset. A
//! first pass over the text ([`scan`]) counts the lines and finds what control flow needs
//! before it runs: every O-word line (with its offset and the next line's, the only places
//! a jump lands besides a call's return, which the call records) and the `%` that closes
//! the program. Offsets of other lines are never kept, so memory does not grow with the
//! program.
//!
//! Text in comments that is not UTF-8 (a `Ø` from a Windows-1252 CAM post) is read as `?`,
//! one byte for one byte; invalid UTF-8 elsewhere is an error at the first offending byte
//! ([`crate::parse_bytes`] does the same on a whole buffer).

use crate::error::{ParseError, ParseErrorKind};
use crate::lexer::{compact_line, LineBuf};
use crate::source::LineInfo;
use std::fs::File;
use std::io::{BufRead, BufReader, Seek, SeekFrom};

/// Size of the read buffer of a streamed file.
const READ_BUFFER_BYTES: usize = 1 << 16;

/// An O-word line: where it is and where the line after it starts.
#[derive(Clone, Debug)]
pub(crate) struct OLineAt {
    /// Line index (0-based).
    pub line: usize,
    /// Byte range of the line (without the line break).
    pub start: usize,
    pub end: usize,
    /// Offset of the next line.
    pub next: usize,
    /// Its compacted text (upper case, no blanks or comments).
    pub compact: Box<[u8]>,
    /// Its text as written (for error messages of a streamed file).
    pub raw: Box<str>,
}

/// What the first pass learns.
#[derive(Clone, Debug, Default)]
pub(crate) struct Scan {
    /// Physical lines.
    pub n_lines: usize,
    /// O-word lines before the closing `%` (or the end), in order.
    pub olines: Vec<OLineAt>,
    /// The line of the `%` that ends the program text: the second `%` line when the first
    /// non-blank line is `%` (LinuxCNC's rule), else the first `%` line.
    pub closing_percent: Option<usize>,
    /// Some line has a word that may be an extra axis (A B C U V W E) or an `M99`
    /// ([`may_be_extra_axis_or_m99`]).
    pub maybe_extra_or_m99: bool,
    /// Byte range of the last line, and its text (for an error at the end of the file).
    pub last_line: (usize, usize),
    pub last_text: Box<str>,
}

/// The program text.
pub(crate) enum Text<'a> {
    /// Held whole.
    Whole(&'a str),
    /// A file read line by line.
    File(FileText),
}

/// A file read line by line, seeking for jumps.
pub(crate) struct FileText {
    reader: BufReader<File>,
    /// Where the reader is.
    pos: usize,
    /// Raw bytes of the last line read.
    buf: Vec<u8>,
}

impl FileText {
    /// Opens `file` for reading.
    pub(crate) fn open(file: File) -> FileText {
        FileText {
            reader: BufReader::with_capacity(READ_BUFFER_BYTES, file),
            pos: 0,
            buf: Vec::with_capacity(256),
        }
    }
}

impl Text<'_> {
    /// Reads the line starting at `offset` into `out` (without its line break, UTF-8 as the
    /// module doc says) and returns the offset of its end; `None` at the end of the text.
    /// `k` is the line's index, for errors.
    pub(crate) fn line_at(
        &mut self,
        offset: usize,
        k: usize,
        out: &mut String,
        file_name: &str,
    ) -> Result<Option<usize>, TextError> {
        out.clear();
        match self {
            Text::Whole(s) => {
                let b = s.as_bytes();
                if offset >= b.len() {
                    return Ok(None);
                }
                let end = b[offset..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |p| offset + p);
                out.push_str(&s[offset..end]);
                Ok(Some(end))
            }
            Text::File(f) => {
                if f.pos != offset {
                    f.reader.seek(SeekFrom::Start(offset as u64))?;
                    f.pos = offset;
                }
                f.buf.clear();
                let n = f.reader.read_until(b'\n', &mut f.buf)?;
                if n == 0 {
                    return Ok(None);
                }
                f.pos += n;
                if f.buf.last() == Some(&b'\n') {
                    f.buf.pop();
                }
                let end = offset + f.buf.len();
                push_utf8_line(&f.buf, k, offset, out, file_name)?;
                Ok(Some(end))
            }
        }
    }
}

/// Appends `line` (which starts at `offset`) to `out` as UTF-8: non-ASCII bytes in
/// comments become `?`; any other invalid byte is an error there.
fn push_utf8_line(
    line: &[u8],
    k: usize,
    offset: usize,
    out: &mut String,
    file_name: &str,
) -> Result<(), TextError> {
    if let Ok(s) = std::str::from_utf8(line) {
        out.push_str(s);
        return Ok(());
    }
    let cleaned = super::program::non_ascii_comments_replaced(line);
    match std::str::from_utf8(&cleaned) {
        Ok(s) => {
            out.push_str(s);
            Ok(())
        }
        Err(e) => {
            let start = e.valid_up_to();
            let len = e.error_len().unwrap_or(line.len() - start).max(1);
            Err(TextError::Parse(Box::new(ParseError::in_line(
                file_name,
                line,
                k,
                offset,
                offset + start..offset + (start + len).min(line.len()),
                ParseErrorKind::InvalidUtf8,
            ))))
        }
    }
}

/// Reading the text failed.
#[derive(Debug)]
pub(crate) enum TextError {
    /// The file could not be read.
    Io(std::io::Error),
    /// Its bytes are not G-code text.
    Parse(Box<ParseError>),
}

impl From<std::io::Error> for TextError {
    fn from(e: std::io::Error) -> Self {
        TextError::Io(e)
    }
}

/// The first pass over `text`: see [`Scan`]. A line numbered past the closing `%` is never
/// read by the interpreter, so O-lines after it are not indexed. A streamed file is also
/// searched for words that need a first run ([`Scan::maybe_extra_or_m99`]).
pub(crate) fn scan(
    text: &mut Text<'_>,
    file_name: &str,
    mut lines: Option<&mut Vec<LineInfo>>,
) -> Result<Scan, TextError> {
    let mut st = ScanState::default();
    match text {
        Text::Whole(src) => {
            let b = src.as_bytes();
            let mut offset = 0;
            while offset < b.len() {
                let end = b[offset..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |p| offset + p);
                st.line(&src[offset..end], offset, end, false);
                if let Some(v) = lines.as_deref_mut() {
                    v.push(LineInfo {
                        start: offset,
                        end,
                        ..Default::default()
                    });
                }
                offset = end + 1;
            }
        }
        Text::File(_) => {
            let mut line = String::new();
            let mut offset = 0;
            while let Some(end) = text.line_at(offset, st.sc.n_lines, &mut line, file_name)? {
                st.line(&line, offset, end, true);
                offset = end + 1;
            }
            st.sc.last_text = line.into();
        }
    }
    Ok(st.sc)
}

/// The first pass, line by line.
#[derive(Default)]
struct ScanState {
    sc: Scan,
    lb: LineBuf,
    /// The first `%` line, and whether only blank lines came before it.
    first_percent: Option<(usize, bool)>,
    /// No line so far has anything but blanks.
    started: bool,
}

impl ScanState {
    /// Line `self.sc.n_lines`, at `start..end`; `words` asks for the extra-axis and `M99`
    /// search.
    fn line(&mut self, line: &str, start: usize, end: usize, words: bool) {
        let k = self.sc.n_lines;
        self.sc.n_lines += 1;
        self.sc.last_line = (start, end);
        let b = line.as_bytes();
        let first = b.iter().copied().find(|c| !c.is_ascii_whitespace());
        if self.sc.closing_percent.is_some() {
            return;
        }
        if first == Some(b'%') {
            match self.first_percent {
                None => self.first_percent = Some((k, !self.started)),
                Some((_, true)) => self.sc.closing_percent = Some(k),
                Some((_, false)) => {}
            }
            if let Some((p, false)) = self.first_percent {
                self.sc.closing_percent = Some(p);
            }
        } else if may_be_oline(b) {
            index_oline(line, k, start, end, &mut self.lb, &mut self.sc.olines);
        }
        self.started |= first.is_some();
        if words && !self.sc.maybe_extra_or_m99 {
            self.sc.maybe_extra_or_m99 = may_be_extra_axis_or_m99(b);
        }
    }
}

/// Whether `line` may be an O-word line: an `O` first, after blanks, comments, a
/// block-delete `/` and an `N` number (what compaction and
/// [`super::oword::skip_line_number`] leave out before it). Only such lines are compacted
/// and read by the first pass.
fn may_be_oline(line: &[u8]) -> bool {
    // Skips blanks and `( )` comments from `i`.
    let skip = |mut i: usize| loop {
        match line.get(i) {
            Some(c) if c.is_ascii_whitespace() => i += 1,
            Some(b'(') => match line[i..].iter().position(|&c| c == b')') {
                Some(p) => i += p + 1,
                None => return i,
            },
            _ => return i,
        }
    };
    let mut i = skip(0);
    if line.get(i) == Some(&b'/') {
        i = skip(i + 1);
    }
    if line.get(i).is_some_and(|c| c | 0x20 == b'n') {
        i = skip(i + 1);
        while line
            .get(i)
            .is_some_and(|c| c.is_ascii_digit() || *c == b'.')
        {
            i = skip(i + 1);
        }
    }
    line.get(i).is_some_and(|c| c | 0x20 == b'o')
}

/// Whether `line` has, outside its comments, a letter that may start an extra-axis word
/// (A B C U V W E, in any case) or an `M99` (blanks inside words allowed, as NGC allows
/// them). Letters of parameter names and functions count too: a false alarm costs one
/// more pass over the program, a miss would be wrong.
pub(crate) fn may_be_extra_axis_or_m99(line: &[u8]) -> bool {
    let mut paren = false;
    // The last two characters that are not blanks, upper case.
    let mut prev = [0u8; 2];
    for &b in line {
        match b {
            b'(' => paren = true,
            b')' if paren => paren = false,
            _ if paren => {}
            b';' => return false,
            b' ' | b'\t' | b'\r' => {}
            _ => {
                let c = b.to_ascii_uppercase();
                if matches!(c, b'A' | b'B' | b'C' | b'U' | b'V' | b'W' | b'E') {
                    return true;
                }
                if prev == *b"M9" && c == b'9' {
                    return true;
                }
                prev = [prev[1], c];
            }
        }
    }
    false
}

/// Adds line `k` to `olines` when it is an O-word line.
fn index_oline(
    line: &str,
    k: usize,
    start: usize,
    end: usize,
    lb: &mut LineBuf,
    olines: &mut Vec<OLineAt>,
) {
    if compact_line(line.as_bytes(), start, lb).is_err() {
        return;
    }
    let at = super::oword::skip_line_number(&lb.bytes);
    if lb.bytes.get(at) != Some(&b'O') {
        return;
    }
    olines.push(OLineAt {
        line: k,
        start,
        end,
        next: end + 1,
        compact: lb.bytes.clone().into_boxed_slice(),
        raw: line.into(),
    });
}

//! Messages to the terminal: status lines on stderr that never panic ([`say`]; stdout goes
//! through [`crate::io::print_stdout`]), and rustc-style rendering of parse errors with
//! `ariadne`.

use ncsmooth_gcode::ParseError;
use std::fmt::Display;
use std::io::Write;

/// Writes `msg` and a newline to stderr. A closed or broken stderr (a pipe whose reader
/// went away) is ignored: `eprintln!` would panic there, ending the run with 101 and,
/// while an output is being written, leaving the run undone for a message nobody reads.
pub fn say(msg: impl Display) {
    let _ = writeln!(std::io::stderr().lock(), "{msg}");
}

/// Renders `err` against `src` to stderr: file, line and column, a snippet of the line and
/// a label under the offending text.
pub fn report_parse_error(err: &ParseError, src: &[u8]) {
    use ariadne::{Config, Label, Report, ReportKind, Source};
    use std::io::IsTerminal;
    let text = String::from_utf8_lossy(src);
    // ariadne counts characters; convert the byte range (clamped to the text).
    let to_char = |b: usize| {
        text.get(..b.min(text.len()))
            .map(|s| s.chars().count())
            .unwrap_or(0)
    };
    let start = to_char(err.byte_range.start);
    let end = to_char(err.byte_range.end)
        .max(start + 1)
        .min(text.chars().count().max(start + 1));
    let name = err.file.clone();
    let msg = format!("{}:{}:{}: {}", err.file, err.line, err.column, err.kind);
    let rendered = Report::build(ReportKind::Error, (name.clone(), start..end))
        .with_config(Config::default().with_color(std::io::stderr().is_terminal()))
        .with_message(&msg)
        .with_label(Label::new((name.clone(), start..end)).with_message(err.kind.to_string()))
        .finish()
        .eprint((name, Source::from(text.as_ref())));
    if rendered.is_err() {
        say(format_args!("error: {msg}"));
    }
}

/// `e` reported on stderr with its line from `path` ([`report_parse_error_at_line`]),
/// as the command's error.
pub fn reported_at_line(e: ParseError, path: &std::path::Path) -> anyhow::Error {
    report_parse_error_at_line(&e, path);
    e.into()
}

/// As [`report_parse_error`], for a program read from `path` a part at a time: only the
/// lines up to the error's are read again (the label spans the error's text from its
/// column, on that line).
pub fn report_parse_error_at_line(err: &ParseError, path: &std::path::Path) {
    use std::io::BufRead;
    let line_no = err.line.max(1) as usize;
    let text = std::fs::File::open(path).ok().and_then(|f| {
        std::io::BufReader::new(f)
            .split(b'\n')
            .nth(line_no - 1)
            .and_then(|l| l.ok())
    });
    let Some(line) = text else {
        say(format_args!(
            "error: {}:{}:{}: {}",
            err.file, err.line, err.column, err.kind
        ));
        return;
    };
    // The earlier lines as empty ones keep the line number; the range is rebuilt from the
    // column (in characters) and the error's length.
    let line = String::from_utf8_lossy(&line)
        .trim_end_matches('\r')
        .to_string();
    let col = (err.column.max(1) as usize - 1).min(line.chars().count());
    let mut src = "\n".repeat(line_no - 1).into_bytes();
    let start = src.len() + line.char_indices().nth(col).map_or(line.len(), |(b, _)| b);
    src.extend_from_slice(line.as_bytes());
    let len = err.byte_range.len().max(1);
    let shifted = ParseError {
        byte_range: start..(start + len).min(src.len()).max(start),
        ..err.clone()
    };
    report_parse_error(&shifted, &src);
}

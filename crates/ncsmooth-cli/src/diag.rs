//! Rustc-style rendering of parse errors with `ariadne`.

use ncsmooth_gcode::ParseError;

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
        eprintln!("error: {msg}");
    }
}

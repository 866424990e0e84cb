//! G-code writer: [`Toolpath`] to RS274/NGC text that this crate's parser, LinuxCNC and
//! grbl read back as the same motion.
//!
//! Output format:
//!
//! * Optional header comment lines, then `G21 G90 G94 G17`: millimetres, absolute
//!   coordinates, units-per-minute feed, XY plane; arc centres are incremental I/J/K (the
//!   G91.1 default; `G91.1` itself is not written because grbl does not know it).
//! * Lines as `G0`/`G1`. The motion word is written on every line; axis words only when
//!   their formatted value changes (at least one axis is always written). `F` (mm/min) is
//!   written when its formatted value changes.
//! * Arcs whose normal is ±Z, ±Y or ±X (within 1e-9) as `G2`/`G3` in G17/G18/G19 (the
//!   plane word is written when it changes), with both in-plane end coordinates, the axial
//!   coordinate for helices, both centre offsets, and `P` for multi-turn arcs. Centre
//!   offsets are taken from the *written* (rounded) start point and written with
//!   `CENTRE_EXTRA_DECIMALS` more digits than the coordinates, so the centre the reader
//!   computes is essentially exact. Arcs in other planes, arcs whose
//!   radius is under two units of the last decimal, and arcs that rounding would turn into
//!   a full circle are flattened to `G1` lines within `chord_mm` with
//!   [`Flatten`]. So are all non-native segments (Béziers,
//!   NURBS and any future kind); extra axes are interpolated along the pieces by length.
//! * Events are written as their text, in order. An `M83` event is written as `M82`
//!   (with a comment) because the writer always writes absolute E. After an event, extra
//!   axes are rewritten on the next move (`G92 E0` may have reset them) and after an event
//!   with an `F` word the feed is rewritten.
//! * [`EventKind::Untracked`] events (a G53 move,
//!   a G28 return, a move from an unknown position) are written as their text (the
//!   programmed block); the next move writes all its axes.
//!
//! The same motion writer (`MotionWriter`) serves [`crate::rewrite()`], which writes in
//! the program's own units and modes and never writes an axis whose position is unknown.
//!
//! Numbers use `decimals` digits after the point (default 4), trailing zeros removed,
//! never exponent notation and never `-0`. With 4 decimals the rounding is up to 5e-5 mm;
//! a round trip that must agree to 1e-6 mm needs 6 or more decimals (the round-trip
//! property test uses 6). Fewer than 3 decimals can make a reader reject arcs whose
//! rounded radii differ by more than its tolerance.

pub mod chain;
pub mod chain_extra;
pub mod frame;
pub mod motion;
pub mod rewrite;

#[cfg(doc)]
use crate::numbers::CENTRE_EXTRA_DECIMALS;
use crate::numbers::MAX_DECIMALS;
use frame::Frame;
use motion::MotionWriter;
#[cfg(doc)]
use ncsmooth::geom::Flatten;
use ncsmooth::path::{Block, EventKind, Toolpath};
use std::fmt;

/// Writer settings.
#[derive(Clone, Debug, PartialEq)]
pub struct WriteOptions {
    /// Digits after the decimal point (default 4; at most [`MAX_DECIMALS`]).
    pub decimals: usize,
    /// Prefix every block with `N<k>` (default false).
    pub line_numbers: bool,
    /// Comment written at the top, one `( )` line per text line (parentheses in it are
    /// replaced by brackets).
    pub header: Option<String>,
    /// Chord tolerance (mm) for flattening curves and off-axis arcs (default 0.001).
    pub chord_mm: f64,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            decimals: 4,
            line_numbers: false,
            header: None,
            chord_mm: 0.001,
        }
    }
}
/// Writes `tp` as G-code text.
pub fn write(tp: &Toolpath, opts: &WriteOptions) -> String {
    let mut s = String::with_capacity(tp.blocks.len() * 32 + 64);
    // Writing into a String cannot fail.
    let _ = write_to(tp, opts, &mut s);
    s
}

/// Writes `tp` as G-code text into `out`.
pub fn write_to<W: fmt::Write>(tp: &Toolpath, opts: &WriteOptions, out: &mut W) -> fmt::Result {
    if let Some(h) = &opts.header {
        for l in h.lines() {
            let l: String = l
                .chars()
                .map(|c| match c {
                    '(' => '[',
                    ')' => ']',
                    c => c,
                })
                .collect();
            writeln!(out, "({l})")?;
        }
    }
    let mut w = MotionWriter::new(
        Frame {
            decimals: opts.decimals.min(MAX_DECIMALS),
            chord_mm: opts.chord_mm,
            extra_mask: tp.extra_axes_mask,
            ..Frame::default()
        },
        tp.start,
    );
    w.line_numbers = opts.line_numbers;
    w.begin();
    w.line.push_str("G21 G90 G94 G17");
    w.end(out)?;
    for b in &tp.blocks {
        match b {
            // Written on the next motion block (a line of its own would stop grbl).
            Block::Event(e) if matches!(e.kind, EventKind::SpindleSpeed(_)) => {
                lead_line(&mut w, out)?;
                w.lead_words = Some(e.text.clone());
            }
            Block::Event(e) => {
                lead_line(&mut w, out)?;
                w.begin();
                match e.kind {
                    EventKind::Comment => push_comment(&mut w.line, "", &e.text),
                    EventKind::Message => push_comment(&mut w.line, "MSG,", &e.text),
                    // Everything here is written in mm.
                    EventKind::Units(_) => push_comment(&mut w.line, "source units ", &e.text),
                    _ if e.text.trim() == "M83" => w
                        .line
                        .push_str("M82 (M83 in the source: the writer writes absolute E)"),
                    _ => w.line.push_str(&e.text),
                }
                w.end(out)?;
                w.forget_extras();
                if e.text.contains('F') {
                    w.forget_feed();
                }
                if matches!(e.kind, EventKind::Untracked { .. }) {
                    w.forget_axes();
                }
            }
            Block::Move(m) => w.write_move(m, out)?,
        }
    }
    lead_line(&mut w, out)
}

/// Writes the block value no motion block took (a zero-length move after it) as a line
/// of its own.
fn lead_line<W: fmt::Write>(w: &mut MotionWriter, out: &mut W) -> fmt::Result {
    if let Some(words) = w.lead_words.take() {
        w.begin();
        w.line.push_str(&words);
        w.end(out)?;
    }
    Ok(())
}

/// Appends `(prefix text)`, with parentheses inside replaced by brackets.
fn push_comment(line: &mut String, prefix: &str, text: &str) {
    line.push('(');
    line.push_str(prefix);
    line.extend(text.chars().map(|c| match c {
        '(' => '[',
        ')' => ']',
        c => c,
    }));
    line.push(')');
}

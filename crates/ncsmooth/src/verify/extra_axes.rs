//! The extra axes (A B C U V W E) of a written program against the program's.
//!
//! Smoothing never smooths the extra axes: they ride along the path, interpolated in arc
//! length within each programmed move ([`crate::smooth`]). So wherever the program leaves
//! the path to do something with them, at each extra-axis event (a slicer's retract
//! `G1 E-2`, a reset `G92 E0`), and at its end, a written program has them exactly
//! where the program has them, up to the printed decimals. A writer that loses them (a
//! run written without its `E` words: a printer moving without extruding) is caught
//! there: the extrusion of the run before the next retract is short by what it lost.

use crate::path::{Block, EventKind, ExtraAxes, Toolpath};
use serde::Serialize;

/// Where a written program's extra axes differ from the program's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ExtraAxesMismatch {
    /// Source line of the program's event before which they differ (0: at the end).
    pub line: u32,
    /// The axis (0..7: A B C U V W E).
    pub axis: usize,
    /// The program's value.
    pub program: f64,
    /// The written program's value (NaN where it has no such event).
    pub written: f64,
}

/// The extra-axis values before each extra-axis event, with the event's line and text,
/// and at the end (line 0, no text).
fn checkpoints(tp: &Toolpath) -> Vec<(u32, &str, Option<ExtraAxes>)> {
    let mut out = Vec::new();
    let mut last: Option<ExtraAxes> = None;
    for b in &tp.blocks {
        if let Block::Event(e) = b {
            if let EventKind::ExtraMove { .. } | EventKind::ExtraReset { .. } = e.kind {
                out.push((e.line, e.text.as_str(), last));
            }
        }
        last = b.extra_after(last);
    }
    out.push((0, "", last));
    out
}

/// The first place where `written`'s extra axes differ from `program`'s by more than
/// `tol` (before each extra-axis event and at the end), or `None` when they agree.
///
/// ```
/// use ncsmooth::geom::{Line, Vec3};
/// use ncsmooth::path::{Block, Move, Toolpath};
/// use ncsmooth::verify::extra_axes_kept;
///
/// let run = |e: f64| {
///     let mut tp = Toolpath::new(Vec3::ZERO);
///     tp.extra_axes_mask = 1 << 6;
///     let mut m = Move::feed(Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)), Some(10.0), 1);
///     m.extra = Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, e]);
///     tp.blocks.push(Block::Move(m));
///     tp
/// };
/// assert_eq!(extra_axes_kept(&run(4.0), &run(4.0), 1e-4), None);
/// let m = extra_axes_kept(&run(4.0), &run(3.0), 1e-4).unwrap();
/// assert_eq!((m.axis, m.program, m.written), (6, 4.0, 3.0));
/// ```
pub fn extra_axes_kept(
    program: &Toolpath,
    written: &Toolpath,
    tol: f64,
) -> Option<ExtraAxesMismatch> {
    let (p, w) = (checkpoints(program), checkpoints(written));
    // The written program's events are the program's, in order, with the text they had;
    // a written move that moves only an extra axis (its other axes round to where they
    // were) reads back as one more, which is passed over.
    let mut j = 0;
    for &(line, text, a) in &p {
        let found = w[j..]
            .iter()
            .position(|&(_, t, _)| t == text)
            .map(|k| j + k);
        let b = found.and_then(|k| w[k].2);
        j = found.map_or(w.len(), |k| k + 1);
        let Some(a) = a else { continue };
        for axis in 0..a.len() {
            let got = b.map_or(f64::NAN, |b| b[axis]);
            let off = (a[axis] - got).abs();
            if off.is_nan() || off > tol {
                return Some(ExtraAxesMismatch {
                    line,
                    axis,
                    program: a[axis],
                    written: got,
                });
            }
        }
    }
    None
}

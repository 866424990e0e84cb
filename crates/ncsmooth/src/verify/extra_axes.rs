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

/// A place where the extra axes are compared: before an extra-axis event or at the end.
struct Checkpoint {
    /// Source line of the event (0: the end).
    line: u32,
    /// The event's kind and its values after it (`None`: the end).
    event: Option<(bool, ExtraAxes)>,
    /// The values before it.
    before: Option<ExtraAxes>,
}

/// The checkpoints of `tp`: before each extra-axis event (a move of extra axes only is
/// `true`, a reset `false`) and at the end.
fn checkpoints(tp: &Toolpath) -> Vec<Checkpoint> {
    let mut out = Vec::new();
    let mut last: Option<ExtraAxes> = None;
    for b in &tp.blocks {
        if let Block::Event(e) = b {
            let event = match e.kind {
                EventKind::ExtraMove { to, .. } => Some((true, to)),
                EventKind::ExtraReset { to } => Some((false, to)),
                _ => None,
            };
            if event.is_some() {
                out.push(Checkpoint {
                    line: e.line,
                    event,
                    before: last,
                });
            }
        }
        last = b.extra_after(last);
    }
    out.push(Checkpoint {
        line: 0,
        event: None,
        before: last,
    });
    out
}

/// Whether `a` and `b` agree within `tol` on every axis (both unknown counts as agreeing).
fn close(a: &ExtraAxes, b: &ExtraAxes, tol: f64) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (x - y).abs() <= tol || (x.is_nan() && y.is_nan()))
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
    // The written program's events are the program's, in order: the same kind with the
    // same values after it (its text may differ: a relative `E` word's target is the
    // written value before it plus the word). A written move that moves only an extra
    // axis (its other axes round to where they were) reads back as one more event, which
    // is passed over.
    let mut j = 0;
    for c in &p {
        let same_kind = |d: &Checkpoint| match (c.event, d.event) {
            (Some((ka, _)), Some((kb, _))) => ka == kb,
            (None, None) => true,
            _ => false,
        };
        let same_values = |d: &Checkpoint| match (c.event, d.event) {
            (Some((_, ta)), Some((_, tb))) => close(&ta, &tb, tol),
            _ => true,
        };
        // Where no event has the same values, the next of its kind shows what differs.
        let found = w[j..]
            .iter()
            .position(|d| same_kind(d) && same_values(d))
            .or_else(|| w[j..].iter().position(same_kind))
            .map(|k| j + k);
        let b = found.and_then(|k| w[k].before);
        j = found.map_or(w.len(), |k| k + 1);
        let (line, a) = (c.line, c.before);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Line, Vec3};
    use crate::path::{Event, Move};

    fn e(v: f64) -> ExtraAxes {
        let mut a = [0.0; 7];
        a[6] = v;
        a
    }

    /// A run extruding to `run_e`, then a retract by 4 written as `text`, and a reset.
    fn program(run_e: f64, text: &str, extra_blip: bool) -> Toolpath {
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.extra_axes_mask = 1 << 6;
        let ev = |line, kind| {
            Block::Event(Event {
                line,
                kind,
                text: text.to_string(),
            })
        };
        if extra_blip {
            // The run's first piece rounds to its start: only its E is written.
            let to = e(run_e - 0.5);
            tp.blocks.push(ev(
                2,
                EventKind::ExtraMove {
                    to,
                    feed_per_s: None,
                },
            ));
        }
        let mut m = Move::feed(Line::new(Vec3::ZERO, Vec3::X), Some(10.0), 2);
        m.extra = Some(e(run_e));
        tp.blocks.push(Block::Move(m));
        let retract = EventKind::ExtraMove {
            to: e(run_e - 4.0),
            feed_per_s: None,
        };
        tp.blocks.push(ev(4, retract));
        tp.blocks.push(ev(5, EventKind::ExtraReset { to: e(0.0) }));
        tp
    }

    #[test]
    fn events_are_matched_by_their_values_not_their_text() {
        // A relative retract (M83 `G1 E-4`) after a run written to 4 decimals: the event
        // reads back with the written target, within the rounding of the program's.
        let p = program(15.12414, "G1 E11.12414", false);
        let w = program(15.1241, "G1 E11.1241", false);
        assert_eq!(extra_axes_kept(&p, &w, 1e-4), None);
        // A written extra-axis-only blip inside the run is passed over.
        let blip = program(15.1241, "G1 E11.1241", true);
        assert_eq!(extra_axes_kept(&p, &blip, 1e-4), None);
    }

    #[test]
    fn a_run_short_of_its_extrusion_is_caught_at_the_next_event() {
        let p = program(15.12414, "G1 E11.12414", false);
        let w = program(14.8, "G1 E10.8", false);
        let m = extra_axes_kept(&p, &w, 1e-4).unwrap();
        assert_eq!(
            (m.line, m.axis, m.program, m.written),
            (4, 6, 15.12414, 14.8)
        );
    }
}

//! The extra axes (A B C U V W E) of a written program against the program's.
//!
//! Smoothing never smooths the extra axes: they ride along the path, interpolated in arc
//! length within each programmed move ([`crate::smooth`]). So wherever the program leaves
//! the path to do something with them, at each extra-axis event (a slicer's retract
//! `G1 E-2`, a reset `G92 E0`), and at its end, a written program has them exactly
//! where the program has them, up to the printed decimals. A writer that loses them (a
//! run written without its `E` words: a printer moving without extruding) is caught
//! there: the extrusion of the run before the next retract is short by what it lost.

use crate::geom::{Flatten, ParamCurve, SegmentGrid, Vec3};
use crate::path::{Block, EventKind, ExtraAxes, Toolpath, E_AXIS};
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

/// Flattening accuracy of the program's curves for [`extrusion_along_path`], as a share
/// of its tolerance.
const ALONG_FLATTEN_SHARE: f64 = 0.05;

/// How far a written program's extrusion strays along the path from the program's
/// ([`extrusion_along_path`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ExtrusionAlongPath {
    /// Largest distance (mm of filament) from a written move's end `E` to the range of
    /// the program's `E` over its points within the tolerance of that end.
    pub max_e_mm: f64,
    /// Source line of the written move where it is largest (0: none strays).
    pub line: u32,
    /// Written move ends measured.
    pub points: usize,
}

/// A piece of the programmed path with its `E` at both ends, in the stretch between two
/// `E` resets it belongs to.
#[derive(Clone, Copy, Debug)]
struct EPiece {
    a: Vec3,
    b: Vec3,
    e: (f64, f64),
    stretch: u32,
}

/// The program as [`EPiece`]s: moves flattened within `flatten_mm`, `E` linear in
/// length along each, and an extra-axis move in place as a piece of no length.
fn e_pieces(tp: &Toolpath, flatten_mm: f64) -> Vec<EPiece> {
    let mut out = Vec::new();
    let (mut stretch, mut e, mut at) = (0u32, None::<f64>, tp.start);
    for b in &tp.blocks {
        match b {
            Block::Move(m) => {
                let e1 = m.extra.map(|v| v[E_AXIS]);
                // With nothing before it, E starts at 0 (`Move::extra_start`).
                if let Some(e1) = e1 {
                    let e0 = e.unwrap_or(0.0);
                    let mut pts = vec![m.segment.start()];
                    m.segment.flatten(flatten_mm, &mut |p| pts.push(p));
                    let len: f64 = pts.windows(2).map(|w| w[0].dist(w[1])).sum();
                    let mut s = 0.0;
                    for w in pts.windows(2) {
                        let e_at = |s: f64| {
                            if len > 0.0 {
                                e0 + (e1 - e0) * s / len
                            } else {
                                e1
                            }
                        };
                        let s1 = s + w[0].dist(w[1]);
                        out.push(EPiece {
                            a: w[0],
                            b: w[1],
                            e: (e_at(s), e_at(s1)),
                            stretch,
                        });
                        s = s1;
                    }
                }
                e = e1.or(e);
                at = m.segment.end();
            }
            Block::Event(ev) => {
                if let EventKind::ExtraReset { .. } = ev.kind {
                    stretch += 1;
                }
                let after = b.extra_after(None).map(|v| v[E_AXIS]);
                let moves_e = matches!(ev.kind, EventKind::ExtraMove { .. });
                if let (true, Some(e1)) = (moves_e, after) {
                    let e0 = e.unwrap_or(0.0);
                    out.push(EPiece {
                        a: at,
                        b: at,
                        e: (e0, e1),
                        stretch,
                    });
                }
                e = after.or(e);
            }
        }
    }
    out
}

/// The range of `E` over the points of `p` within `tol` of `q` (`None`: none is).
fn e_range_near(p: &EPiece, q: Vec3, tol: f64) -> Option<(f64, f64)> {
    let d = p.b - p.a;
    let l2 = d.norm_sq();
    let e_at = |t: f64| p.e.0 + (p.e.1 - p.e.0) * t;
    if l2 <= 0.0 {
        return (q.dist(p.a) <= tol).then(|| (p.e.0.min(p.e.1), p.e.0.max(p.e.1)));
    }
    // The chord of the ball around `q` on the segment's line, clipped to the segment.
    let t = (q - p.a).dot(d) / l2;
    let h2 = tol * tol - (q - (p.a + d * t)).norm_sq();
    if h2 < 0.0 {
        return None;
    }
    let w = (h2 / l2).sqrt();
    let (t0, t1) = ((t - w).max(0.0), (t + w).min(1.0));
    (t0 <= t1).then(|| {
        let (x, y) = (e_at(t0), e_at(t1));
        (x.min(y), x.max(y))
    })
}

/// How far the written program's extrusion strays along the path: for each written
/// move's end (in the stretch between the same `E` resets), the distance of its `E` from
/// the range of the program's `E` over the programmed points within `tol_mm` of that end
/// (0 inside it). A correct program's written point is where some programmed point within
/// the tolerance is, with that point's `E` up to the rounding; a flow carried into a
/// travel, or placed early along a line, shows as a distance. `None` when the program
/// moves no `E`, or no written end is within `tol_mm` of the program.
///
/// [`extra_axes_kept`] checks the values at events and at the end; this checks them
/// along the path.
///
/// ```
/// use ncsmooth::geom::{Line, Vec3};
/// use ncsmooth::path::{Block, Move, Toolpath};
/// use ncsmooth::verify::extrusion_along_path;
///
/// // 10 mm extruding 1 mm of filament, written as two moves.
/// let run = |mid_e: f64| {
///     let mut tp = Toolpath::new(Vec3::ZERO);
///     tp.extra_axes_mask = 1 << 6;
///     let ends = [(5.0, mid_e), (10.0, 1.0)];
///     let mut at = Vec3::ZERO;
///     for (x, e) in ends {
///         let p = Vec3::new(x, 0.0, 0.0);
///         let mut m = Move::feed(Line::new(at, p), Some(10.0), 1);
///         m.extra = Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, e]);
///         tp.blocks.push(Block::Move(m));
///         at = p;
///     }
///     tp
/// };
/// let program = run(0.5);
/// let within = |w: &Toolpath| extrusion_along_path(&program, w, 0.01).unwrap().max_e_mm;
/// assert_eq!(within(&run(0.5)), 0.0);
/// // E at the midpoint 0.1 early: 0.1 - 0.001 (the program's E 0.01 mm ahead) beyond it.
/// assert!((within(&run(0.6)) - 0.099).abs() < 1e-12);
/// ```
pub fn extrusion_along_path(
    program: &Toolpath,
    written: &Toolpath,
    tol_mm: f64,
) -> Option<ExtrusionAlongPath> {
    if program.extra_axes_mask & (1 << E_AXIS) == 0 || tol_mm.is_nan() || tol_mm <= 0.0 {
        return None;
    }
    let pieces = e_pieces(program, tol_mm * ALONG_FLATTEN_SHARE);
    let grid = SegmentGrid::new(
        pieces.iter().map(|p| (p.a, p.b)),
        (2.0 * tol_mm).max(ALONG_MIN_CELL_MM),
    );
    let pad = Vec3::new(tol_mm, tol_mm, tol_mm);
    let mut out = ExtrusionAlongPath {
        max_e_mm: 0.0,
        line: 0,
        points: 0,
    };
    let mut stretch = 0u32;
    let mut near = Vec::new();
    for b in &written.blocks {
        let m = match b {
            Block::Move(m) => m,
            Block::Event(ev) => {
                if let EventKind::ExtraReset { .. } = ev.kind {
                    stretch += 1;
                }
                continue;
            }
        };
        let Some(e) = m.extra.map(|v| v[E_AXIS]) else {
            continue;
        };
        let q = m.segment.end();
        if !grid.candidates(q - pad, q + pad, &mut near) {
            near.extend(0..pieces.len());
        }
        let range = near
            .iter()
            .map(|&k| &pieces[k])
            .filter(|p| p.stretch == stretch)
            .filter_map(|p| e_range_near(p, q, tol_mm))
            .fold(None, |acc: Option<(f64, f64)>, (lo, hi)| {
                Some(acc.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))))
            });
        let Some((lo, hi)) = range else {
            continue;
        };
        out.points += 1;
        let off = (lo - e).max(e - hi).max(0.0);
        if off > out.max_e_mm {
            out.max_e_mm = off;
            out.line = m.line;
        }
    }
    (out.points > 0).then_some(out)
}

/// Smallest cell of the pieces' grid (mm): a finer grid lists long moves in too many cells.
const ALONG_MIN_CELL_MM: f64 = 1.5;

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

    /// Each stretch between `E` resets is measured against its own: the second pass over
    /// the same line, after `G92 E0`, is not excused by the first pass's values there.
    #[test]
    fn along_the_path_each_stretch_is_its_own() {
        let pass = |tp: &mut Toolpath, a: Vec3, b: Vec3, mid_e: f64| {
            let mid = (a + b) * 0.5;
            for (p, q, v) in [(a, mid, mid_e), (mid, b, 1.0)] {
                let mut m = Move::feed(Line::new(p, q), Some(10.0), 1);
                m.extra = Some(e(v));
                tp.blocks.push(Block::Move(m));
            }
        };
        let two_passes = |first_mid_e: f64, second_mid_e: f64| {
            let mut tp = Toolpath::new(Vec3::ZERO);
            tp.extra_axes_mask = 1 << 6;
            let (a, b) = (Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0));
            pass(&mut tp, a, b, first_mid_e);
            tp.blocks.push(Block::Event(Event {
                line: 3,
                kind: EventKind::ExtraReset { to: e(0.0) },
                text: "G92 E0".into(),
            }));
            pass(&mut tp, b, a, second_mid_e);
            tp
        };
        // The first pass extrudes 0.9 of its 1 mm of filament on its first half.
        let program = two_passes(0.9, 0.5);
        let along = |w: &Toolpath| extrusion_along_path(&program, w, 0.01).unwrap();
        assert_eq!(along(&program).max_e_mm, 0.0);
        assert_eq!(along(&program).points, 4);
        // 0.9 at the second pass's middle is the first pass's E there, not its own (0.5):
        // 0.4 off, less the 0.001 of E the tolerance spans.
        assert!((along(&two_passes(0.9, 0.9)).max_e_mm - 0.399).abs() < 1e-12);
        // A program without E has nothing to measure.
        let mut plain = program.clone();
        plain.extra_axes_mask = 0;
        assert_eq!(extrusion_along_path(&plain, &program, 0.01), None);
    }
}

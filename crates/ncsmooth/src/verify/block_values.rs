//! The values a written program sets per block (the spindle speed or laser power `S` on a
//! motion block, [`EventKind::SpindleSpeed`]) against the program's.
//!
//! Smoothing never carries a block value over a vertex: the path is cut where one changes
//! (an event ends every chain) and the writer puts the value on the first block after the
//! programmed vertex. So a written program read back sets the same values in the same
//! order, each where the program sets it: at the end of the motion before it, within the
//! printed rounding. A writer that dropped one, wrote it a block late or on a vertex the
//! curve moved is caught here.

use crate::geom::{ParamCurve, Vec3};
use crate::path::{Block, EventKind, Toolpath};
use serde::Serialize;

/// Relative difference within which two block values are the same (printed values read
/// back).
const VALUE_REL_TOL: f64 = 1e-9;

/// Where a written program's block values differ from the program's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BlockValueMismatch {
    /// Source line of the program's value (0: a value the written program has and the
    /// program does not).
    pub line: u32,
    /// The program's value (NaN where it has none there).
    pub program: f64,
    /// The written program's value (NaN where it has none there).
    pub written: f64,
    /// Distance (mm) between where the two apply (NaN when one has no motion before it).
    pub offset_mm: f64,
}

/// A value and where it applies: the end of the motion before it (`None` before any).
struct Setting {
    line: u32,
    value: f64,
    at: Option<Vec3>,
}

fn settings(tp: &Toolpath) -> Vec<Setting> {
    let mut out = Vec::new();
    let mut at: Option<Vec3> = None;
    for b in &tp.blocks {
        match b {
            Block::Move(m) => at = Some(m.segment.end()),
            Block::Event(e) => {
                if let EventKind::SpindleSpeed(value) = e.kind {
                    out.push(Setting {
                        line: e.line,
                        value,
                        at,
                    });
                }
            }
        }
    }
    out
}

/// The first block value of `program` that `written` does not set to the same value, in
/// the same order, within `tol_mm` of where the program sets it; `None` when all agree.
///
/// ```
/// use ncsmooth::geom::{Line, Vec3};
/// use ncsmooth::path::{Event, EventKind, Move, Toolpath};
/// use ncsmooth::verify::block_values_kept;
///
/// let run = |corner: Vec3| {
///     let mut tp = Toolpath::new(Vec3::ZERO);
///     tp.push_move(Move::feed(Line::new(Vec3::ZERO, corner), Some(10.0), 1));
///     tp.push_event(Event { line: 2, kind: EventKind::SpindleSpeed(255.0), text: "S255".into() });
///     tp.push_move(Move::feed(Line::new(corner, Vec3::new(10.0, 10.0, 0.0)), Some(10.0), 2));
///     tp
/// };
/// let program = run(Vec3::new(10.0, 0.0, 0.0));
/// assert_eq!(block_values_kept(&program, &program, 1e-4), None);
/// let late = block_values_kept(&program, &run(Vec3::new(10.0, 1.0, 0.0)), 1e-4).unwrap();
/// assert_eq!((late.line, late.offset_mm), (2, 1.0));
/// ```
pub fn block_values_kept(
    program: &Toolpath,
    written: &Toolpath,
    tol_mm: f64,
) -> Option<BlockValueMismatch> {
    let (p, w) = (settings(program), settings(written));
    for k in 0..p.len().max(w.len()) {
        let (a, b) = (p.get(k), w.get(k));
        let offset_mm = match (a.and_then(|a| a.at), b.and_then(|b| b.at)) {
            (Some(x), Some(y)) => x.dist(y),
            (None, None) => 0.0,
            _ => f64::NAN,
        };
        let same_value = match (a, b) {
            (Some(a), Some(b)) => {
                (a.value - b.value).abs() <= VALUE_REL_TOL * a.value.abs().max(b.value.abs())
            }
            _ => false,
        };
        if !same_value || offset_mm.is_nan() || offset_mm > tol_mm {
            return Some(BlockValueMismatch {
                line: a.map_or(0, |a| a.line),
                program: a.map_or(f64::NAN, |a| a.value),
                written: b.map_or(f64::NAN, |b| b.value),
                offset_mm,
            });
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Line;
    use crate::path::{Event, Move};

    fn program(values: &[(u32, f64)]) -> Toolpath {
        let mut tp = Toolpath::new(Vec3::ZERO);
        let mut p = Vec3::ZERO;
        for &(line, v) in values {
            tp.push_event(Event {
                line,
                kind: EventKind::SpindleSpeed(v),
                text: format!("S{v}"),
            });
            let q = p + Vec3::new(1.0, (line % 2) as f64, 0.0);
            tp.push_move(Move::feed(Line::new(p, q), Some(10.0), line));
            p = q;
        }
        tp
    }

    #[test]
    fn a_lost_or_changed_value_is_caught() {
        let a = program(&[(1, 100.0), (2, 200.0), (3, 100.0)]);
        assert_eq!(block_values_kept(&a, &a, 1e-6), None);
        let lost = program(&[(1, 100.0), (2, 200.0)]);
        let m = block_values_kept(&a, &lost, 1e-6).unwrap();
        assert_eq!((m.line, m.program), (3, 100.0));
        assert!(m.written.is_nan());
        let changed = program(&[(1, 100.0), (2, 250.0), (3, 100.0)]);
        let m = block_values_kept(&a, &changed, 1e-6).unwrap();
        assert_eq!((m.line, m.program, m.written), (2, 200.0, 250.0));
        let extra = program(&[(1, 100.0), (2, 200.0), (3, 100.0), (4, 5.0)]);
        assert_eq!(block_values_kept(&a, &extra, 1e-6).unwrap().line, 0);
    }
}

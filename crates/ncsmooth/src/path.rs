//! The path model: a [`Toolpath`] is the ordered list of what a program does, moves
//! ([`Move`]: a [`Segment`] plus rapid/feed, feed rate and source line) and non-motion
//! events ([`Event`]: spindle, coolant, tool change, dwell, ... kept verbatim so a writer
//! can re-emit them). All geometry is in millimetres whatever the input units, feeds in
//! mm/s.
//!
//! Extra axes (A B C U V W E) ride along: each move carries their end values and they are
//! interpolated linearly with the move's arc length. Smoothing never alters them (see
//! `smooth`), and no smoothed curve or written block spans a change of their rate
//! ([`extra_rates_agree`]): a slicer's flow stays where the program puts it.

use crate::geom::{Flatten, ParamCurve, ParamCurveArclen, Segment, Vec3};
use serde::{Deserialize, Serialize};

/// Names of the extra (non-XYZ) axes, in storage order.
pub const EXTRA_AXIS_NAMES: [char; 7] = ['A', 'B', 'C', 'U', 'V', 'W', 'E'];

/// Index of the extruder `E` (a printer's filament, mm) in [`ExtraAxes`].
pub const E_AXIS: usize = 6;

/// End values of the extra axes of a move (units as programmed: degrees for rotary axes,
/// mm for linear ones and for E).
pub type ExtraAxes = [f64; 7];

/// Largest relative change of an extra axis's rate (its change per mm of path) between
/// the moves one smoothed curve or one written block may span. ArcWelder's default
/// "extrusion rate variance": a slicer's flow (E per mm) is kept where it changes (a
/// perimeter next to a travel or a thinner feature), not spread over both.
pub const EXTRA_RATE_VARIANCE: f64 = 0.05;

/// Each extra axis's change per mm of path from `start` to `end` over `len_mm` (a change
/// without length is NaN, which agrees with nothing).
pub fn extra_rate(start: &ExtraAxes, end: &ExtraAxes, len_mm: f64) -> ExtraAxes {
    std::array::from_fn(|i| {
        let d = end[i] - start[i];
        match (d == 0.0, len_mm > 0.0) {
            (true, _) => 0.0,
            (false, true) => d / len_mm,
            (false, false) => f64::NAN,
        }
    })
}

/// Whether two extra-axis rates ([`extra_rate`]) agree within [`EXTRA_RATE_VARIANCE`] of
/// the larger on every axis.
pub fn extra_rates_agree(a: &ExtraAxes, b: &ExtraAxes) -> bool {
    a.iter().zip(b).all(|(&x, &y)| rates_agree(x, y))
}

/// Whether two rates of one axis agree within [`EXTRA_RATE_VARIANCE`] of the larger (NaN
/// agrees with nothing).
pub fn rates_agree(x: f64, y: f64) -> bool {
    x == y || (x - y).abs() <= EXTRA_RATE_VARIANCE * x.abs().max(y.abs())
}

/// Rapid (G0) or feed (G1/G2/G3 and curves made from them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum MoveKind {
    /// Positioning move at the machine's rapid rate; never smoothed.
    Rapid,
    /// Cutting move at the programmed feed.
    Feed,
}

/// One motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Move {
    /// Geometry (mm).
    pub segment: Segment,
    /// Rapid or feed.
    pub kind: MoveKind,
    /// Programmed feed rate (mm/s); `None` for rapids, or for feed moves of a program that
    /// never set F.
    pub feed_mm_s: Option<f64>,
    /// 1-based source line of the block that produced the move (for a smoothed curve: the
    /// line of the programmed move it replaces or starts in).
    pub line: u32,
    /// Extra-axis end values, when the program uses extra axes.
    pub extra: Option<ExtraAxes>,
    /// Written as programmed: the move is never smoothed and ends every chain it touches
    /// (a canned-cycle step, a move inside a subroutine or loop, a block-delete block, a
    /// block that also carries words a rewrite would lose). A writer that has the source
    /// copies its block verbatim.
    pub pinned: bool,
}

impl Move {
    /// A feed move.
    pub fn feed(segment: impl Into<Segment>, feed_mm_s: Option<f64>, line: u32) -> Move {
        Move {
            segment: segment.into(),
            kind: MoveKind::Feed,
            feed_mm_s,
            line,
            extra: None,
            pinned: false,
        }
    }
    /// A rapid move.
    pub fn rapid(segment: impl Into<Segment>, line: u32) -> Move {
        Move {
            segment: segment.into(),
            kind: MoveKind::Rapid,
            feed_mm_s: None,
            line,
            extra: None,
            pinned: false,
        }
    }
    /// The same move attributes with another geometry.
    pub fn with_segment(&self, segment: impl Into<Segment>) -> Move {
        Move {
            segment: segment.into(),
            ..self.clone()
        }
    }
    /// True for rapids.
    pub fn is_rapid(&self) -> bool {
        self.kind == MoveKind::Rapid
    }
    /// The extra-axis values at the start of this move, given `before`, those after the
    /// block before it (`None`: no block before it had extra axes); `None` when the move
    /// has none. With nothing before it, `E` starts at 0 (the interpreter tracks it from
    /// 0, as a printer's firmware counts it from power-on) and the other axes at the
    /// move's own values (an axis a move commands was known before it, so a block before
    /// it set it).
    ///
    /// ```
    /// use ncsmooth::geom::{Line, Vec3};
    /// use ncsmooth::path::{Move, E_AXIS};
    /// let mut m = Move::feed(Line::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)), None, 2);
    /// m.extra = Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.05]);
    /// assert_eq!(m.extra_start(None).unwrap()[E_AXIS], 0.0);
    /// assert_eq!(m.extra_start(Some([1.0; 7])), Some([1.0; 7]));
    /// ```
    pub fn extra_start(&self, before: Option<ExtraAxes>) -> Option<ExtraAxes> {
        Some(extra_start_of(before, self.extra?))
    }
}

/// The extra-axis values where a motion to `end` starts, given `before`, those after the
/// block before it: `before`, or with nothing before it, `end` with `E` at 0 (see
/// [`Move::extra_start`]; an extra-axis move, a prime, takes the same rule).
pub fn extra_start_of(before: Option<ExtraAxes>, end: ExtraAxes) -> ExtraAxes {
    before.unwrap_or_else(|| {
        let mut start = end;
        start[E_AXIS] = 0.0;
        start
    })
}

/// What a non-motion event does, as far as planning is concerned.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum EventKind {
    /// G4 dwell, seconds.
    Dwell(f64),
    /// Spindle on/off/speed (M3 M4 M5 S).
    Spindle,
    /// A new spindle speed or laser power `S` on a motion block (`G1 X10 S255`, nothing
    /// else of the spindle on the line): the controller applies it from the start of that
    /// block's motion without stopping (grbl's laser mode; a value per block, like `F`).
    /// The path is not smoothed through it (it is a vertex of the program, written with
    /// the value on the first block after it) and a planner does not stop there. The
    /// value is in the program's own terms (rpm, or the laser's power scale).
    SpindleSpeed(f64),
    /// Coolant (M7 M8 M9).
    Coolant,
    /// Tool change or tool select (T, M6).
    Tool,
    /// Tool length offset (G43, G49).
    ToolOffset,
    /// Program stop or end (M0 M1 M2 M30 M60).
    ProgramStop,
    /// A move of extra axes only (X, Y, Z at rest; a slicer's retract `G1 E-2 F2400`):
    /// their programmed values after it, and its rate in units per second (`None` for a
    /// rapid or when no F was programmed).
    ExtraMove {
        /// Extra-axis values after the move.
        to: ExtraAxes,
        /// Rate (programmed units per second).
        feed_per_s: Option<f64>,
    },
    /// The extra axes' coordinates are redefined (`G92 E0`): their programmed values after
    /// it. No motion.
    ExtraReset {
        /// Extra-axis values after the reset.
        to: ExtraAxes,
    },
    /// A comment, `( )` (LinuxCNC passes the last one of a block to the controller as
    /// `COMMENT`); the text is its content. No motion and no stop.
    Comment,
    /// An operator message or log line (`(MSG,...)`, `(DEBUG,...)`, `(PRINT,...)`), the
    /// text as the controller shows it (parameters substituted). No motion and no stop.
    Message,
    /// Motion that cannot be placed in the work frame: a `G53` move, a `G28`/`G30` return,
    /// a move from or to a position the program has not established (an axis never
    /// commanded since the start, a frame change, a tool-length change). The controller
    /// runs it; a planner stops before it and starts again from the next known position.
    /// The text names the block; writers with the source copy it verbatim.
    Untracked {
        /// Extra-axis values after it, when the program uses extra axes and all of them
        /// are known (a slicer's first extruding move from a position not yet established
        /// moves `E`: a run after it starts from there).
        extra: Option<ExtraAxes>,
    },
    /// The program switches units (G20/G21). Geometry stays in mm; writers that keep the
    /// program's units follow it. No motion and no stop.
    Units(Units),
    /// Anything else kept verbatim (other M codes, G92, G54..G59, modal settings
    /// that do not change the geometry, extra-axis-only moves, ...).
    Other,
}

/// A non-motion block or word group, kept verbatim.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// 1-based source line.
    pub line: u32,
    /// Classification.
    pub kind: EventKind,
    /// G-code text to re-emit (canonical words, upper case, no comments).
    pub text: String,
}

/// One item of a toolpath.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Block {
    /// A motion.
    Move(Move),
    /// A non-motion event.
    Event(Event),
}

impl Block {
    /// The extra-axis values after this block, given those before it: a move's own (its
    /// values at its end) where it has them, an extra-axis move's or reset's target, and
    /// otherwise unchanged.
    pub fn extra_after(&self, before: Option<ExtraAxes>) -> Option<ExtraAxes> {
        match self {
            Block::Move(m) => m.extra.or(before),
            Block::Event(e) => match e.kind {
                EventKind::ExtraMove { to, .. } | EventKind::ExtraReset { to } => Some(to),
                EventKind::Untracked { extra: Some(to) } => Some(to),
                _ => before,
            },
        }
    }
}

/// Units the program was written in (geometry is always stored in mm).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Units {
    /// G21.
    #[default]
    Millimetres,
    /// G20 (converted to mm on input).
    Inches,
}

/// A whole program: moves and events in order.
#[derive(Clone, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Toolpath {
    /// Moves and events in program order.
    pub blocks: Vec<Block>,
    /// Position before the first move (mm); the origin unless the program says otherwise.
    pub start: Vec3,
    /// Units the program used first (all stored geometry is mm).
    pub units: Units,
    /// Bit `i` set when extra axis `EXTRA_AXIS_NAMES[i]` appears.
    pub extra_axes_mask: u8,
}

impl Toolpath {
    /// An empty toolpath starting at `start`.
    pub fn new(start: Vec3) -> Toolpath {
        Toolpath {
            start,
            ..Default::default()
        }
    }
    /// Builds a feed-only toolpath through `points` (a polyline) at `feed_mm_s`.
    pub fn from_polyline(points: &[Vec3], feed_mm_s: Option<f64>) -> Toolpath {
        let mut tp = Toolpath::new(points.first().copied().unwrap_or(Vec3::ZERO));
        for (i, w) in points.windows(2).enumerate() {
            tp.push_move(Move::feed(
                crate::geom::Line::new(w[0], w[1]),
                feed_mm_s,
                i as u32 + 1,
            ));
        }
        tp
    }
    /// Appends a move.
    pub fn push_move(&mut self, m: Move) {
        self.blocks.push(Block::Move(m));
    }
    /// Appends an event.
    pub fn push_event(&mut self, e: Event) {
        self.blocks.push(Block::Event(e));
    }
    /// The moves, in order.
    pub fn moves(&self) -> impl Iterator<Item = &Move> + '_ {
        self.blocks.iter().filter_map(|b| match b {
            Block::Move(m) => Some(m),
            Block::Event(_) => None,
        })
    }
    /// The events, in order.
    pub fn events(&self) -> impl Iterator<Item = &Event> + '_ {
        self.blocks.iter().filter_map(|b| match b {
            Block::Event(e) => Some(e),
            Block::Move(_) => None,
        })
    }
    /// Number of moves.
    pub fn move_count(&self) -> usize {
        self.moves().count()
    }
    /// Last position (end of the last move, or the start).
    pub fn end_point(&self) -> Vec3 {
        self.moves()
            .last()
            .map(|m| m.segment.end())
            .unwrap_or(self.start)
    }
    /// Total length of the moves of one kind (mm), within `accuracy` per curve.
    pub fn length(&self, kind: MoveKind, accuracy: f64) -> f64 {
        self.moves()
            .filter(|m| m.kind == kind)
            .map(|m| m.segment.arclen(accuracy))
            .sum()
    }
    /// The same program with every non-native curve (anything but lines and arcs)
    /// replaced by G1 lines within `chord_mm` of it ([`Flatten`]); attributes are kept.
    pub fn flattened(&self, chord_mm: f64) -> Toolpath {
        let mut out = Toolpath {
            blocks: Vec::with_capacity(self.blocks.len()),
            ..self.clone()
        };
        for b in &self.blocks {
            match b {
                Block::Move(m) if !m.segment.is_native_gcode() => {
                    let mut prev = m.segment.start();
                    m.segment.flatten(chord_mm, &mut |p| {
                        out.blocks
                            .push(Block::Move(m.with_segment(crate::geom::Line::new(prev, p))));
                        prev = p;
                    });
                }
                other => out.blocks.push(other.clone()),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{CubicBez, Line};

    #[test]
    fn flattened_keeps_events_and_ends() {
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.push_move(Move::rapid(Line::new(Vec3::ZERO, Vec3::X), 1));
        tp.push_event(Event {
            line: 2,
            kind: EventKind::Spindle,
            text: "M3 S1000".into(),
        });
        let c = CubicBez::new(
            Vec3::X,
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(3.0, 1.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
        );
        tp.push_move(Move::feed(c, Some(10.0), 3));
        let f = tp.flattened(1e-3);
        assert!(f.move_count() > 3);
        assert_eq!(f.events().count(), 1);
        assert_eq!(f.end_point(), Vec3::new(4.0, 0.0, 0.0));
        assert!(f.moves().all(|m| m.segment.is_native_gcode()));
        assert!((f.length(MoveKind::Feed, 1e-9) - tp.length(MoveKind::Feed, 1e-9)).abs() < 1e-3);
    }
}

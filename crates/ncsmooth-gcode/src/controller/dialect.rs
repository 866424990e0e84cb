//! What each controller accepts and what the writer gives it.
//!
//! | dialect | blending the writer bounds | shortest block it aims for | arcs | G5 | longest line |
//! |---|---|---|---|---|---|
//! | `linuxcnc` | `G64 P Q` before every replaced run ([`crate::controller::linuxcnc::Blend`]); with the machine's acceleration, a smaller `P` where the speed allows ([`crate::controller::linuxcnc::blend::BlendSchedule`]) | what feed covers in 1.02 servo periods (LinuxCNC caps a block's speed at its length / 1.02 T) | G17, G18, G19 | yes | 256 |
//! | `grbl` | none (grbl keeps the path, junction deviation only slows) | [`STEPPER_MIN_BLOCK_MM`] | G17, G18, G19 | no | 79 stored |
//! | `grblhal` | none | [`STEPPER_MIN_BLOCK_MM`] | G17, G18, G19 | yes | 256 |
//! | `marlin` | none | [`STEPPER_MIN_BLOCK_MM`] | G17 only | yes | 95 stored |
//! | `klipper` | none | [`STEPPER_MIN_BLOCK_MM`] | G17 only | no | none |
//! | `generic` | none | none | G17, G18, G19 | no | none |
//!
//! LinuxCNC's start-up mode (`G64` without `P`) blends with no bound on the deviation
//! (corners of the crown profile are cut by about 1.9 mm at 50 mm/s): smoothed G-code for
//! LinuxCNC therefore always carries its own `G64 P Q`, paid for from the tolerance. The
//! other controllers run the written polyline exactly (their corner speed rules only slow
//! the machine down). Comments and the program's own lines are copied for every dialect.
//! The stepper firmwares run an arc as chords ([`Dialect::arc_chords`]), counted where one
//! is written.

use super::arcs::ArcChords;

/// Smallest block (mm) the stepper dialects aim for: 4 steps at 200 steps/mm (0.02 mm),
/// plus the controller's rounding of both ends to whole steps (up to half a step per axis
/// at each end, 0.005 sqrt(3) mm in all), so that the block the controller executes is
/// never a step or two whose rounding turns it in an arbitrary direction.
pub const STEPPER_MIN_BLOCK_MM: f64 = 0.03;

/// LinuxCNC's trajectory planner caps a segment's speed at its length over this many
/// servo periods (`TP_MIN_SEGMENT_CYCLES` in tp.c).
pub const LINUXCNC_MIN_SEGMENT_CYCLES: f64 = 1.02;

/// LinuxCNC's default servo period (s).
pub const LINUXCNC_SERVO_PERIOD_S: f64 = 0.001;

/// grbl's and grblHAL's default arc tolerance `$12` (mm): the sagitta of their chords.
pub(crate) const GRBL_ARC_TOLERANCE_MM: f64 = 0.002;
/// Marlin's `MAX_ARC_SEGMENT_MM` (2.0.9.2 and later, default).
pub(crate) const MARLIN_MAX_ARC_SEGMENT_MM: f64 = 1.0;
/// Marlin's `MIN_ARC_SEGMENT_MM` (default).
pub(crate) const MARLIN_MIN_ARC_SEGMENT_MM: f64 = 0.1;
/// Marlin's `MIN_CIRCLE_SEGMENTS` (default).
pub(crate) const MARLIN_MIN_CIRCLE_SEGMENTS: f64 = 72.0;
/// Klipper's `[gcode_arcs] resolution` (mm, default).
pub(crate) const KLIPPER_ARC_RESOLUTION_MM: f64 = 1.0;

/// A controller family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Dialect {
    /// LinuxCNC (RS274/NGC), the reference dialect.
    LinuxCnc,
    /// grbl 1.1.
    Grbl,
    /// grblHAL.
    GrblHal,
    /// Marlin.
    Marlin,
    /// Klipper.
    Klipper,
    /// Any controller that runs the written path exactly.
    Generic,
}

impl Dialect {
    /// Every dialect.
    pub const ALL: [Dialect; 6] = [
        Dialect::LinuxCnc,
        Dialect::Grbl,
        Dialect::GrblHal,
        Dialect::Marlin,
        Dialect::Klipper,
        Dialect::Generic,
    ];

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::LinuxCnc => "linuxcnc",
            Dialect::Grbl => "grbl",
            Dialect::GrblHal => "grblhal",
            Dialect::Marlin => "marlin",
            Dialect::Klipper => "klipper",
            Dialect::Generic => "generic",
        }
    }

    /// The dialect of a command-line name.
    pub fn from_name(name: &str) -> Option<Dialect> {
        Dialect::ALL.into_iter().find(|d| d.name() == name)
    }

    /// One line for `--help`: the controller.
    pub fn summary(self) -> &'static str {
        match self {
            Dialect::LinuxCnc => "LinuxCNC (RS274/NGC), the reference dialect.",
            Dialect::Grbl => "grbl 1.1.",
            Dialect::GrblHal => "grblHAL.",
            Dialect::Marlin => "Marlin.",
            Dialect::Klipper => "Klipper.",
            Dialect::Generic => "Any controller that runs the written path exactly.",
        }
    }

    /// Whether the controller blends corners away from the written path unless told a
    /// bound (`G64 P Q`).
    pub fn blends(self) -> bool {
        self == Dialect::LinuxCnc
    }

    /// Shortest block (mm) to aim for, at feed `feed_mm_s`.
    pub fn min_block_mm(self, feed_mm_s: f64) -> f64 {
        match self {
            Dialect::LinuxCnc => feed_mm_s * LINUXCNC_MIN_SEGMENT_CYCLES * LINUXCNC_SERVO_PERIOD_S,
            Dialect::Grbl | Dialect::GrblHal | Dialect::Marlin | Dialect::Klipper => {
                STEPPER_MIN_BLOCK_MM
            }
            Dialect::Generic => 0.0,
        }
    }

    /// Shortest block (mm) the controller should never be given: a stepper controller's
    /// few steps ([`STEPPER_MIN_BLOCK_MM`]), below which a block's direction is its
    /// rounding. Shorter blocks are lifted where the program's tolerance allows
    /// ([`crate::write::rewrite::BlockFloor`]). `None` for LinuxCNC (its short blocks only run
    /// slower, see [`Dialect::min_block_mm`]) and `generic`.
    pub fn block_floor_mm(self) -> Option<f64> {
        match self {
            Dialect::Grbl | Dialect::GrblHal | Dialect::Marlin | Dialect::Klipper => {
                Some(STEPPER_MIN_BLOCK_MM)
            }
            Dialect::LinuxCnc | Dialect::Generic => None,
        }
    }

    /// Seconds of feed a block should last at least (LinuxCNC: 1.02 servo periods).
    pub fn min_block_s(self) -> f64 {
        match self {
            Dialect::LinuxCnc => LINUXCNC_MIN_SEGMENT_CYCLES * LINUXCNC_SERVO_PERIOD_S,
            _ => 0.0,
        }
    }

    /// Planes in which `G2`/`G3` may be written (bit 0 G17, bit 1 G18, bit 2 G19).
    pub fn arc_planes(self) -> u8 {
        match self {
            Dialect::Marlin | Dialect::Klipper => 0b001,
            _ => 0b111,
        }
    }

    /// How the controller runs a `G2`/`G3` (the firmware's chords and their defaults:
    /// [`crate::controller::arcs`]).
    pub fn arc_chords(self) -> ArcChords {
        match self {
            Dialect::Grbl | Dialect::GrblHal => ArcChords::Tolerance {
                mm: GRBL_ARC_TOLERANCE_MM,
            },
            Dialect::Marlin => ArcChords::Segments {
                max_mm: MARLIN_MAX_ARC_SEGMENT_MM,
                min_mm: MARLIN_MIN_ARC_SEGMENT_MM,
                per_turn: MARLIN_MIN_CIRCLE_SEGMENTS,
            },
            Dialect::Klipper => ArcChords::Floor {
                resolution_mm: KLIPPER_ARC_RESOLUTION_MM,
            },
            Dialect::LinuxCnc | Dialect::Generic => ArcChords::Exact,
        }
    }

    /// Whether a long arc inside a smoothed run is better written as one `G2`/`G3` than
    /// flattened with the run's lines (fewer, longer blocks) wherever it meets them. Not
    /// for LinuxCNC next to a flattened curve: its 2.9 planner joins an arc to a nearly
    /// tangent line - the first or last chord of the curve, off the arc's tangent by half
    /// its turn and the rounding - with neither a tangent join nor a blend arc: the kink
    /// is too large for its tangent rule (tp.c `tpSetupTangent`: the kink's acceleration
    /// over `ARC_BLEND_TANGENT_KINK_RATIO` of the limit, with an arc's share halved), no
    /// blend arc is made at a blend tolerance of a micrometre, and the joint falls back to
    /// the kink velocity or a parabolic blend that halves the arc's normal acceleration.
    /// Such a joint runs at the kink velocity and the arc below the speed its radius
    /// allows (measured in `docs/benchmarks/2026-12-02.md`). There, only arcs that
    /// meet the program's own lines (or the run's ends) at both ends stay native
    /// (`NATIVE_ARC_MIN_BLOCKS`).
    pub fn keeps_long_arcs(self) -> bool {
        !matches!(self, Dialect::LinuxCnc)
    }

    /// Whether the controller runs a centre-format arc whose end is off the circle of its
    /// start (within the reader's tolerance) as LinuxCNC does: a spiral about the
    /// programmed centre, the radius linear in the angle (posemath's `pmCirclePoint`).
    /// grbl and Marlin go round the start's circle and end with a straight piece to the
    /// end point (grbl's `mc_arc`); the others are not known to spiral.
    pub fn runs_spirals(self) -> bool {
        self == Dialect::LinuxCnc
    }

    /// Whether the controller reads `G5` cubic Béziers (XY plane).
    pub fn has_g5(self) -> bool {
        matches!(self, Dialect::LinuxCnc | Dialect::GrblHal | Dialect::Marlin)
    }

    /// Whether the controller reads `G5.2`/`G5.3` NURBS (LinuxCNC only).
    pub fn has_nurbs(self) -> bool {
        self == Dialect::LinuxCnc
    }

    /// Longest line the controller reads, if it has a limit, in the characters it keeps
    /// ([`Dialect::stored_len`]): grbl 1.1's line buffer is `LINE_BUFFER_SIZE` = 80 bytes,
    /// a terminating zero included, so 79 characters (protocol.c flags an overflow at the
    /// 80th); Marlin's command buffer is `MAX_CMD_SIZE` = 96 bytes and queue.cpp skips the
    /// rest of a line once 95 characters are stored.
    pub fn max_line_len(self) -> Option<usize> {
        match self {
            Dialect::LinuxCnc | Dialect::GrblHal => Some(256),
            Dialect::Grbl => Some(79),
            Dialect::Marlin => Some(95),
            Dialect::Klipper | Dialect::Generic => None,
        }
    }

    /// Characters of a written line the controller keeps in its line buffer: grbl and
    /// grblHAL drop whitespace, control characters, `/` and comments (`(...)` and `;` to
    /// the end) as they read a line (grbl 1.1 protocol.c), so a long comment, such as the
    /// provenance line after the program end, does not overflow it; Marlin stores
    /// everything before a `;` comment, whitespace included (queue.cpp
    /// `process_stream_char`; `(...)` comments only with its optional `PAREN_COMMENTS`);
    /// other controllers are counted as written.
    pub fn stored_len(self, line: &[u8]) -> usize {
        if self == Dialect::Marlin {
            return line.iter().position(|&c| c == b';').unwrap_or(line.len());
        }
        if !matches!(self, Dialect::Grbl | Dialect::GrblHal) {
            return line.len();
        }
        let (mut n, mut in_paren) = (0, false);
        for &c in line {
            match c {
                b')' if in_paren => in_paren = false,
                _ if in_paren => {}
                b';' => break,
                b'(' => in_paren = true,
                b'/' => {}
                c if c <= b' ' => {}
                _ => n += 1,
            }
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linuxcnc_blocks_reach_feed_in_one_servo_cycle() {
        // 50 mm/s at 1 ms: LinuxCNC needs 0.051 mm to run a block at full feed.
        assert!((Dialect::LinuxCnc.min_block_mm(50.0) - 0.051).abs() < 1e-12);
        assert!(Dialect::LinuxCnc.blends());
        assert!(Dialect::ALL.iter().filter(|d| d.blends()).count() == 1);
        assert_eq!(Dialect::Marlin.arc_planes(), 1);
        assert_eq!(Dialect::Grbl.max_line_len(), Some(79));
        // grbl keeps neither spaces nor comments.
        let g = Dialect::Grbl;
        assert_eq!(g.stored_len(b"G1 X1.5 (a comment) Y2 ; more"), 8);
        assert_eq!(g.stored_len(b"/G1 X1\t"), 4);
        let long_comment = format!("M2\n; ncsmooth {}", "x".repeat(100));
        assert_eq!(
            g.stored_len(long_comment.lines().nth(1).unwrap().as_bytes()),
            0
        );
        // Marlin keeps spaces and parentheses but not a `;` comment.
        let m = Dialect::Marlin;
        assert_eq!(m.stored_len(b"G1 X1 ; c"), 6);
        assert_eq!(m.stored_len(b"G1 X1 (c) Y2"), 12);
        assert_eq!(
            m.stored_len(long_comment.lines().nth(1).unwrap().as_bytes()),
            0
        );
        assert_eq!(m.max_line_len(), Some(95));
    }
}

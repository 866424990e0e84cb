//! Canonical commands, as LinuxCNC's standalone interpreter (`rs274 -g`) prints them:
//! what the conformance tests compare. Recorded only when
//! [`ParseOptions::canon`](crate::ParseOptions::canon) asks for it.
//!
//! Positions are work coordinates in the program units in force when the command was
//! made (A B C in degrees), axes in the order X Y Z A B C U V W.

/// One canonical command.
#[derive(Clone, Debug, PartialEq)]
pub enum Canon {
    /// `STRAIGHT_TRAVERSE` to `end`.
    Traverse {
        /// End point.
        end: [f64; 9],
    },
    /// `STRAIGHT_FEED` to `end`.
    Feed {
        /// End point.
        end: [f64; 9],
    },
    /// `ARC_FEED` to `end` about `center` (the two in-plane coordinates, in the order of
    /// the plane: X Y for G17, Z X for G18, Y Z for G19), `turn` > 0 counter-clockwise,
    /// its magnitude the number of turns started.
    Arc {
        /// End point.
        end: [f64; 9],
        /// Centre, in-plane coordinates.
        center: [f64; 2],
        /// Turn count, signed.
        turn: i32,
    },
    /// A spline or NURBS move (`NURBS_G5_FEED`, `NURBS_FEED`) ending at `end`.
    Spline {
        /// End point.
        end: [f64; 9],
    },
    /// `COMMENT("text")`.
    Comment(String),
    /// `MESSAGE("text")`.
    Message(String),
    /// The text of a `(PRINT,...)` comment, which `rs274` prints on its own line.
    Print(String),
    /// `DWELL(seconds)`.
    Dwell(f64),
    /// `PROGRAM_END()`.
    ProgramEnd,
}

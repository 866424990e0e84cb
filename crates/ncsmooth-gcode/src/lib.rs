//! # ncsmooth-gcode
//!
//! RS274/NGC G-code (as LinuxCNC and grbl accept it) to and from the ncsmooth path
//! model ([`ncsmooth::Toolpath`]).
//!
//! | Reading | |
//! |---|---|
//! | [`parse_str`], [`parse_bytes`] | a whole program to a [`Program`]: its [`Toolpath`](ncsmooth::Toolpath), [`ParseStats`], [`SourceMap`] and, when asked, its [`Canon`] calls, read as LinuxCNC's modal interpreter reads it (O-word control flow, coordinate systems and offsets, what is known of the position, lines, arcs in all three planes, canned cycles, splines, events), in millimetres |
//! | [`ParseOptions`], [`MachineModel`] | how to read: the machine's start state, units assumed, limits |
//! | [`BlockReader`] | a file read block by block, for files too large to hold |
//! | [`ParseError`], [`ParseErrorKind`], [`Warning`] | typed, located errors (file, line, column, byte range); no input, however malformed, makes the parser panic |
//!
//! | Writing | |
//! |---|---|
//! | [`rewrite()`], [`RewriteOptions`] | a smoothed toolpath written back into the program's own text: every line that is not smoothed motion is copied verbatim |
//! | [`write()`], [`write_to`], [`WriteOptions`] | a toolpath without source to G-code, flattening what G-code cannot carry natively |
//! | [`Dialect`], [`controller`] | what each controller accepts (the capability table), block floors, LinuxCNC's model of what it executes |
//! | [`Budget`], [`read_back`] | the tolerance shared between curves, chords, rounding and blending, and its check on the text as written |
//!
//! | Jobs | |
//! |---|---|
//! | [`SmoothJob`], [`SmoothedGcode`], [`SmoothRunReport`] | the verified pipeline from a program's text to the G-code a controller runs, and its report |
//! | [`PlanJob`], [`PlanInput`], [`Planned`], [`PlanRunReport`] | smoothing and planning a program (a file streamed, or a path held whole) into setpoints, the limits checked on them, and its report |
//! | [`InspectReport`] | what a program holds |
//!
//! The rules, and the decisions taken where the standard leaves room, are documented on
//! each item and in `docs/gcode.md`.
//!
//! ## Read a program, smooth it, write it
//!
//! ```
//! use ncsmooth::{smooth, Method, SmoothOptions};
//! use ncsmooth_gcode::{parse_str, read_back, rewrite, Budget, ParseOptions, RewriteOptions};
//!
//! let src = "G21 G90 G17 (a zig-zag)\nG0 X0 Y0 Z1\nG1 Z0 F600\n\
//!            G1 X1 Y0.5\nG1 X2 Y0\nG1 X3 Y0.5\nG1 X4 Y0\nM5\nM2\n";
//! let program = parse_str(src, "zigzag.ngc", &ParseOptions::default()).unwrap();
//!
//! // 0.01 mm in all: the curves get what the flattening chord (0.001 mm) and the
//! // printed decimals (4: up to 0.00009 mm per point) leave; no controller blending.
//! let budget = Budget::new(&program, 0.01, 0.001, 4, 0.0);
//! let mut opts = SmoothOptions::default();
//! opts.method = Method::Bspline;
//! opts.tol_mm = budget.curve_tol_mm();
//! let smoothed = smooth(&program.toolpath, &opts).unwrap();
//! let text = rewrite(src.as_bytes(), &program, &smoothed.toolpath, &RewriteOptions::new(4, 0.001))
//!     .unwrap();
//!
//! // The comment, the spindle stop and the end are where they were; the corners are curves
//! // (flattened into short G1 lines) within 0.01 mm of the program, both ways, as read back.
//! let as_text = String::from_utf8(text.clone()).unwrap();
//! assert!(as_text.starts_with("G21 G90 G17 (a zig-zag)\n") && as_text.contains("M5\nM2\n"));
//! let (written, dev) = read_back(&text, "out.ngc", &program.toolpath, 1e-6).unwrap();
//! assert!(written.moves().count() > program.toolpath.moves().count());
//! assert!(budget.holds(&dev));
//! ```
#![forbid(unsafe_code)]

mod budget;
mod canon;
pub mod controller;
pub(crate) mod cursor;
mod error;
mod expr;
mod interpreter;
mod job;
mod lexer;
mod numbers;
pub(crate) mod polyline;
mod source;
mod stream;
mod write;

// Reading: a whole program, or block by block.
pub use interpreter::frames::MachineModel;
pub use interpreter::program::{
    parse_bytes, parse_str, ParseOptions, ParseStats, Program, MAX_HELD_BLOCKS,
};
pub use stream::BlockReader;

// What was read: errors, warnings, LinuxCNC's canonical calls, the units.
pub use canon::Canon;
pub use error::{ParseError, ParseErrorKind, Warning};
pub use ncsmooth::path::Units;

// The source map: what each line of the program is, for writing it back in place.
pub use source::{flags, LineInfo, PathMode, Plane, SourceMap, WriteState};

// Writing: back into the program's own text, or a toolpath without source.
pub use controller::arcs::ArcChords;
pub use controller::dialect::Dialect;
pub use controller::linuxcnc::Blend;
pub use write::rewrite::{rewrite, BlockFloor, Emit, RewriteError, RewriteOptions};
pub use write::{write, write_to, WriteOptions};

// The printed numbers.
pub use numbers::{rounding_mm, MAX_DECIMALS};

// The tolerance budget, and its check on the text as written.
pub use budget::{read_back, read_back_with, read_written, read_written_with, Budget};

// Jobs: the verified pipeline and its reports.
pub use job::{
    check_period, write_path_samples, BlendReport, BlockReport, EmitStyle, InspectReport, JobError,
    MovesByCode, PlanInput, PlanJob, PlanNote, PlanRunReport, Planned, SmoothJob, SmoothRunReport,
    SmoothedGcode, Timings, MAX_PERIOD_S, MIN_PERIOD_S,
};

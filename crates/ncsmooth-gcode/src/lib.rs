//! # ncsmooth-gcode
//!
//! RS274/NGC G-code (as LinuxCNC and grbl accept it) to and from the ncsmooth path
//! model ([`ncsmooth::Toolpath`]).
//!
//! * [`parse_str`] / [`parse_bytes`]: a hand-written byte-level [`lexer`] (no regex, no
//!   allocation per word), real-value [`expr`]essions with numbered and named parameters,
//!   and a modal interpreter ([`interpreter`]) with LinuxCNC's semantics: O-word control flow,
//!   coordinate systems and offsets, what is known of the position, lines, arcs (all three
//!   planes, helical, multi-turn, I/J/K or R), canned cycles, splines, and events, in
//!   millimetres. Errors are typed ([`ParseErrorKind`]) and located (file, line, column,
//!   byte range); no input, however malformed, makes the parser panic.
//! * [`rewrite()`]: a smoothed toolpath written back into the program's own text: every
//!   line that is not smoothed motion is copied verbatim ([`write::rewrite`]).
//! * [`write()`]: a toolpath without source to G-code ([`mod@write`]), flattening what
//!   G-code cannot carry natively.
//!
//! See each module for the rules and the decisions taken where the standard leaves room.
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

pub mod budget;
pub mod canon;
pub mod controller;
pub(crate) mod cursor;
pub mod error;
pub mod expr;
pub mod interpreter;
mod job;
pub mod lexer;
pub mod numbers;
pub(crate) mod polyline;
pub mod source;
pub mod stream;
pub mod write;

pub use budget::{read_back, Budget};
pub use stream::BlockReader;

pub use canon::Canon;
pub use controller::dialect::Dialect;
pub use error::{ParseError, ParseErrorKind, Warning};
pub use interpreter::frames::MachineModel;
pub use interpreter::program::{
    parse_bytes, parse_str, ParseOptions, ParseStats, Program, MAX_HELD_BLOCKS,
};
pub use job::{
    BlendReport, BlockReport, EmitStyle, InspectReport, JobError, MovesByCode, PlanRunReport,
    SmoothJob, SmoothRunReport, Smoothed, Timings,
};
pub use ncsmooth::path::Units;
pub use source::{Plane, SourceMap};
pub use write::rewrite::{rewrite, RewriteOptions};
pub use write::{write, write_to, WriteOptions};

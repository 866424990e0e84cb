//! # ncsmooth
//!
//! The numerical core of ncsmooth: CNC toolpaths smoothed within a two-sided tolerance,
//! the feed planned under per-axis velocity, acceleration and jerk limits, setpoints
//! interpolated at a fixed period, and every result measured.
//!
//! The pipeline, each layer importing only those before it: geometry ([`geom`]) -> the
//! path model ([`path`]) -> verification ([`verify`]) -> smoothing ([`mod@smooth`]) -> feed
//! planning ([`feed`]) -> interpolation into setpoints ([`interp`]). Reading and writing
//! G-code is the crate `ncsmooth-gcode`.
//!
//! ## The front door
//!
//! Smooth a polyline within 0.01 mm, check the tolerance both ways, and plan it into
//! setpoints at 1 ms under per-axis limits:
//!
//! ```
//! use ncsmooth::{deviation, execute_into, smooth, InterpOptions, Method, PlanOptions};
//! use ncsmooth::{Setpoint, SmoothOptions, Toolpath, Vec3};
//!
//! // A zig-zag of 1 mm lines: a corner at every vertex.
//! let pts: Vec<Vec3> = (0..=20)
//!     .map(|k| Vec3::new(k as f64, if k % 2 == 0 { 0.0 } else { 0.5 }, 0.0))
//!     .collect();
//! let program = Toolpath::from_polyline(&pts, Some(50.0));
//!
//! let mut sopts = SmoothOptions::default();
//! sopts.method = Method::Bspline;
//! sopts.tol_mm = 0.01;
//! let smoothed = smooth(&program, &sopts).unwrap();
//! assert!(deviation(&smoothed.toolpath, &program, 1e-6).within(0.01));
//!
//! let mut popts = PlanOptions::default(); // 50 mm/s, 500 mm/s^2 per axis, 1 ms
//! popts.jerk_mm_s3 = Some([5000.0; 3]);
//! let (report, rows): (_, Vec<Setpoint>) =
//!     execute_into(&smoothed.toolpath, &popts, &InterpOptions::default(), Vec::new()).unwrap();
//! assert!(report.limits_held);
//! assert_eq!(rows.last().unwrap().p, pts[20]); // ends exactly on the program's end
//! ```
//!
//! Programs too large to hold are smoothed block by block ([`StreamSmoother`]) and planned
//! while they arrive ([`execute_streamed`], in memory bounded by the planner's windows);
//! setpoints go to any [`SetpointSink`] (a CSV writer, a `Vec`, a callback).
#![forbid(unsafe_code)]

pub mod decimal;
pub mod feed;
pub mod geom;
pub mod interp;
pub mod par;
pub mod path;
pub mod profiles;
pub mod smooth;
mod stats;
pub mod verify;

pub use feed::PlanOptions;
pub use geom::{Arc, Line, Segment, Vec3};
pub use interp::{
    execute_into, execute_streamed, FnSink, InterpOptions, PlanError, PlanReport, Setpoint,
    SetpointSink, SetpointWriter,
};
pub use par::{set_threads, threads};
pub use path::{Block, Event, EventKind, Move, MoveKind, Toolpath, Units};
pub use smooth::stream::{smooth_for_plan, StreamOptions, StreamSmoother, PLAN_WINDOW_MOVES};
pub use smooth::{smooth, Method, SmoothOptions, SmoothReport, Smoothed};
pub use stats::{AngleBin, LengthStats, PathStats, PathStatsBuilder, CORNER_BINS_DEG};
pub use verify::{deviation, Deviation};

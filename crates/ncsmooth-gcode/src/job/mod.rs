//! Jobs: the verified pipeline from a program's text to the G-code a controller runs.
//!
//! A [`SmoothJob`] smooths a program within a two-sided tolerance, writes it back into the
//! program's own text ([`crate::rewrite()`]: comments, M codes, block-delete marks, `%`,
//! control flow, offsets and all the smoothing does not touch copied verbatim, in the
//! program's units), reads the written text back as the controller will and measures it
//! against the program, and reports what it did ([`SmoothRunReport`]).
//!
//! ## The budget
//! Curves G-code cannot carry are built to `tol - chord - rounding - blend` and flattened
//! into G1 lines within `chord` (default `0.4 tol` for LinuxCNC, `0.3 tol` for a stepper
//! dialect, `tol / 10` for a generic controller); `rounding` is the most a point moves when
//! its coordinates are printed with `decimals` digits (one more in inch programs,
//! [`crate::numbers::rounding_mm_for`]); `blend` is `P + Q` of the `G64` written for
//! LinuxCNC, the controller's own blending ([`crate::Budget`]). For LinuxCNC's lines the
//! curves first get `tol - max(chord, P) - rounding` less a margin, and that build is kept
//! only when the model of the path LinuxCNC executes ([`crate::controller::linuxcnc::executed`]) is within
//! `tol`; otherwise the program is built again with each part paid in full.
//!
//! ## Smooth a program for grbl
//! ```
//! use ncsmooth::Method;
//! use ncsmooth_gcode::{Dialect, SmoothJob};
//!
//! let src = b"G21 G90 (zig-zag)\nG0 X0 Y0\nG1 X1 Y0.5 F600\nG1 X2 Y0\nG1 X3 Y0.5\nM2\n";
//! let job = SmoothJob::new(Method::Bspline, 0.01).with_dialect(Dialect::Grbl);
//! let done = job.run_bytes("zigzag.ngc", src).unwrap();
//! done.verified().unwrap(); // within 0.01 mm both ways, as read back
//! assert!(done.report.deviation.within(0.01));
//! assert!(String::from_utf8(done.gcode).unwrap().contains("(zig-zag)"));
//! ```

mod inspect;
mod plan;
mod policy;
mod report;
mod smooth;

pub use inspect::{InspectReport, MovesByCode};
pub use plan::{
    check_period, write_path_samples, PlanInput, PlanJob, PlanNote, Planned, MAX_PERIOD_S,
    MIN_PERIOD_S,
};
pub use report::{BlendReport, BlockReport, PlanRunReport, SmoothRunReport, Timings};

use crate::{Dialect, ParseError, ParseOptions};
use ncsmooth::smooth::{Method, SmoothOptions};
use serde::Serialize;

/// Why a job did not give verified G-code.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum JobError {
    /// The options or the program ask for what cannot be done (a tolerance too small for
    /// the decimals, a method refusing the program): the user's to change.
    #[error("{0}")]
    BadInput(String),
    /// The program does not read.
    #[error(transparent)]
    Parse(#[from] ParseError),
    /// The smoothed path could not be written into the program (a bug of ours).
    #[error("writing the smoothed program: {0}")]
    Write(String),
    /// The written text does not read back (a bug of ours).
    #[error("the written G-code does not read back: {0}")]
    ReadBack(String),
    /// The written program, read back, breaks the tolerance or loses an axis (a bug of
    /// ours: the method's own construction should have held it).
    #[error("verification failed: {0}")]
    Verification(String),
    /// The planner failed (a sink's write error, or a bug of ours).
    #[error(transparent)]
    Plan(#[from] ncsmooth::interp::PlanError),
    /// The setpoints, measured, break a limit the options did not waive (a bug of ours).
    #[error("{0}")]
    LimitsBroken(String),
    /// The follow scheme gave up on a run it could not finish within the limits:
    /// [`PlanJob::fallback`] plans it under the filter scheme.
    #[error("{0}")]
    FollowGaveUp(String),
}

impl JobError {
    /// Whether the error is the input's (options or program), not ours.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, JobError::BadInput(_) | JobError::Parse(_))
    }
}

/// How smoothed motion is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum EmitStyle {
    /// Long G1 blocks within the chord.
    Lines,
    /// Long G1 blocks and XY arcs within the chord.
    Arcs,
    /// Long G1 blocks, and every XY cubic Bézier (the B-spline method's curves) as one
    /// exact `G5` where the dialect reads G5 (LinuxCNC, grblHAL, Marlin).
    G5,
    /// As `G5`, and every XY NURBS (the NURBS method's curves) as exact `G5.2 ... G5.3`,
    /// one per Bézier span (LinuxCNC; elsewhere as `G5`).
    Nurbs,
    /// Move by move.
    Native,
}

/// A smoothing job: the method and its settings, the tolerance and how the result is
/// written for which controller. Build with [`SmoothJob::new`] and the `with_*` methods;
/// run with [`SmoothJob::run`] or [`SmoothJob::run_bytes`].
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct SmoothJob {
    /// The method and its settings; its `tol_mm` is replaced by the curve tolerance the
    /// budget leaves. Default: [`SmoothOptions::default`] with the method of
    /// [`SmoothJob::new`].
    pub smooth: SmoothOptions,
    /// Two-sided tolerance (mm) of the path the controller runs, in (0, 1000].
    pub tol_mm: f64,
    /// Flattening chord (mm), in (0, tol). Default `None`: by dialect (module doc).
    pub chord_mm: Option<f64>,
    /// Decimals of the written coordinates (at most [`crate::numbers::MAX_DECIMALS`]).
    /// Default 4.
    pub decimals: usize,
    /// The controller written for. Default [`Dialect::LinuxCnc`].
    pub dialect: Dialect,
    /// How smoothed motion is written. Default `None`: [`EmitStyle::Lines`], and with
    /// [`Method::None`] a verbatim copy (an emitter given there compresses the program's
    /// own lines).
    pub emit: Option<EmitStyle>,
    /// LinuxCNC's `G64 P` (mm). Default `None`: a share of the tolerance.
    pub g64_p_mm: Option<f64>,
    /// LinuxCNC's `G64 Q` (mm). Default `None`: 0.
    pub g64_q_mm: Option<f64>,
    /// LinuxCNC: the machine's acceleration (mm/s^2), for a `G64 P` per block where the
    /// speed allows. Default `None`: one `P` per run.
    pub acc_mm_s2: Option<f64>,
    /// LinuxCNC, with an acceleration: the machine's fastest feed (mm/s) the blends are
    /// sized for. Default `None`: the programmed feeds.
    pub feed_mm_s: Option<f64>,
    /// How the program and the written text are read (the units before a G20/G21).
    /// Default [`ParseOptions::default`].
    pub read: ParseOptions,
    /// The firmware's arc setting (mm) where it is not the dialect's default: grbl's
    /// `$12`, Marlin's `MAX_ARC_SEGMENT_MM`, Klipper's `[gcode_arcs] resolution`
    /// ([`crate::ArcChords::with_segment_mm`]); the written arcs count those chords.
    /// Default `None`: the dialect's ([`Dialect::arc_chords`]). An input error for a
    /// dialect that runs arcs as circles.
    pub arc_segment_mm: Option<f64>,
}

impl SmoothJob {
    /// A job smoothing with `method` within `tol_mm`, written for LinuxCNC with the
    /// defaults above.
    pub fn new(method: Method, tol_mm: f64) -> SmoothJob {
        SmoothJob {
            smooth: SmoothOptions::default().with_method(method),
            tol_mm,
            chord_mm: None,
            decimals: 4,
            dialect: Dialect::LinuxCnc,
            emit: None,
            g64_p_mm: None,
            g64_q_mm: None,
            acc_mm_s2: None,
            feed_mm_s: None,
            read: ParseOptions::default(),
            arc_segment_mm: None,
        }
    }

    /// The method's settings (its method and tolerance are the job's).
    pub fn with_smooth_options(mut self, smooth: SmoothOptions) -> SmoothJob {
        self.smooth = smooth;
        self
    }

    /// The controller written for.
    pub fn with_dialect(mut self, dialect: Dialect) -> SmoothJob {
        self.dialect = dialect;
        self
    }

    /// The firmware's arc setting (mm), see [`SmoothJob::arc_segment_mm`].
    pub fn with_arc_segment_mm(mut self, mm: f64) -> SmoothJob {
        self.arc_segment_mm = Some(mm);
        self
    }

    /// The flattening chord (mm).
    pub fn with_chord_mm(mut self, chord_mm: f64) -> SmoothJob {
        self.chord_mm = Some(chord_mm);
        self
    }

    /// Decimals of the written coordinates.
    pub fn with_decimals(mut self, decimals: usize) -> SmoothJob {
        self.decimals = decimals;
        self
    }

    /// How smoothed motion is written.
    pub fn with_emit(mut self, emit: EmitStyle) -> SmoothJob {
        self.emit = Some(emit);
        self
    }

    /// LinuxCNC's `G64 P` and `Q` (mm); `None` for the default of either.
    pub fn with_g64(mut self, p_mm: Option<f64>, q_mm: Option<f64>) -> SmoothJob {
        (self.g64_p_mm, self.g64_q_mm) = (p_mm, q_mm);
        self
    }

    /// LinuxCNC: the machine's acceleration (mm/s^2) and fastest feed (mm/s).
    pub fn with_machine(mut self, acc_mm_s2: Option<f64>, feed_mm_s: Option<f64>) -> SmoothJob {
        (self.acc_mm_s2, self.feed_mm_s) = (acc_mm_s2, feed_mm_s);
        self
    }

    /// How the program and the written text are read.
    pub fn with_read_options(mut self, read: ParseOptions) -> SmoothJob {
        self.read = read;
        self
    }
}

/// A job's result: the written text and the report. Whether it holds the tolerance is in
/// the report; [`SmoothedGcode::verified`] says it as an error.
#[derive(Debug)]
pub struct SmoothedGcode {
    /// G-code text (the program's own bytes where they are copied).
    pub gcode: Vec<u8>,
    /// What was done and measured.
    pub report: SmoothRunReport,
    /// The loop size asked for (mm), in loop mode.
    loop_size_mm: Option<f64>,
}

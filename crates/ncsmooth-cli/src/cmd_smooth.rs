//! `ncsmooth smooth`: smooth a program within a two-sided tolerance, verify the result and
//! write G-code (plus an optional JSON report).
//!
//! The written file is the program's own text with the smoothed motion put in place of the
//! lines it replaces ([`ncsmooth_gcode::rewrite()`]): comments, M codes, block-delete
//! marks, `%`, control flow, offsets and everything the smoothing does not touch are
//! copied verbatim, in the program's units.
//!
//! The written file honours `--tol`: curves that G-code cannot carry are built to
//! `tol - chord - rounding - blend` and then flattened into G1 lines within `chord` (default
//! `0.4 tol` for LinuxCNC, `tol / 10` for a generic controller, `0.3 tol` for a stepper
//! dialect); `rounding` is the most a point moves when its coordinates are printed with
//! `--decimals` digits (one more in inch programs,
//! [`ncsmooth_gcode::rewrite::rounding_mm_for`]). What is measured is the written text
//! itself, read back by the parser, against the program, with
//! [`ncsmooth::verify::deviation`], before any file is written; a violation is an internal
//! error (exit 1) and no file is written. `blend` is `P + Q` of the `G64` written for
//! LinuxCNC (`--dialect linuxcnc`, [`ncsmooth_gcode::Dialect`]): the controller's own
//! blending, added to the measured deviation, stays within `--tol`. For LinuxCNC's lines
//! the curves first get `tol - max(chord, P) - rounding` less a margin, and that build is
//! kept only when the model of the path LinuxCNC executes ([`ncsmooth_gcode::executed`])
//! is within `--tol`; otherwise the program is built again under the sum.

use crate::{io, load, Ui};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use ncsmooth::smooth::band_fit::BandFitOptions;
use ncsmooth::smooth::band_time::{TimeLimits, TimeShapeOptions};
use ncsmooth::smooth::trig_corner::{check_loops, without_loops, CornerStyle, LoopCheck};
use ncsmooth::smooth::{smooth, Method, SmoothOptions, SmoothReport};
use ncsmooth::stats::PathStats;
use ncsmooth::verify::{continuity, Continuity, Deviation};
use ncsmooth_gcode::budget::{read_back_with, read_written_with, Budget};
use ncsmooth_gcode::rewrite::{Blend, BlockFloor, CornerBlend, Emit};
use ncsmooth_gcode::{Dialect, RewriteOptions, Units};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// Share of the tolerance used as the default flattening chord error.
pub const DEFAULT_CHORD_SHARE: f64 = 0.1;
/// Share of the tolerance used as the default chord for LinuxCNC: long G1 blocks that its
/// blending joins at speed, with [`BLEND_SHARE`] (the model of the executed path lets the
/// two share the tolerance, [`BudgetRule::Executed`]). Measured with `P` tol / 10 paid in
/// full (LinuxCNC 2.9, 50 mm/s, 500 mm/s^2, best method of each file), 0.1 / 0.15 / 0.2
/// tol: butterfly_1000 9.325 / 9.275 / 9.401 s, crown 7.468 / 7.458 / 7.450, cncjs_jsdc
/// 18.167 / 18.145 / 18.261, camotics_vcarve 20.801 / 20.725 / 20.743; with `P` equal to
/// the chord under the model, see [`BLEND_SHARE`].
pub const LINUXCNC_CHORD_SHARE: f64 = 0.4;
/// Share of the tolerance used as the default chord for a stepper dialect
/// ([`Dialect::block_floor_mm`]): no blending takes a share there, and grbl's 15-block
/// look-ahead covers more of the path with the longer blocks (butterfly_1000 on grbl
/// 1.1h: 8.66-8.79 s at 0.3 tol against 8.85-9.30 s at 0.1 tol).
pub const STEPPER_CHORD_SHARE: f64 = 0.3;
/// Share of the tolerance LinuxCNC's blending may use on the program's own rapids copied
/// verbatim ([`ncsmooth_gcode::RewriteOptions::verbatim_blend`]): nearly all of it, as for
/// the input run with `G64 P<tol>`, since those moves are the programmed path. On
/// camotics_vcarve (LinuxCNC 2.9, 50 mm/s, 500 mm/s^2) its rapids' corners under the runs'
/// `P0.001` cost 0.11 s (20.913 s, 20.801 s with this share); linuxcnc_blur_torus gains
/// 0.11 s per method. Copied feed lines keep the runs' `P`: cncjs_jsdc's opening G1 moves
/// under this share ran 0.09 s slower (bspline 18.419 s against 18.327). 5 % is left for
/// whoever measures the executed path from servo samples: at a corner the chords between
/// samples cut inside the blend arc, and `linuxcnc_run.py` put a programmed vertex
/// 0.01015 mm from the sampled path under `P0.01`.
pub const VERBATIM_BLEND_SHARE: f64 = 0.95;

/// LinuxCNC's blend at a junction has a tolerance of at most a quarter of each line
/// (blendmath.c `tcFindBlendTolerance`): with `--acc`, a written block shorter than this
/// many times the run's `P` is replaced by the programmed corner where the tolerance
/// allows ([`ncsmooth_gcode::rewrite::CornerBlend`]).
pub const LINUXCNC_CORNER_FLOOR_P: f64 = 4.0;

/// Share of the tolerance LinuxCNC's blending may use (`G64 P`). Its blend at a vertex of
/// a curve flattened within `chord` follows the curve's own radius once `P` reaches the
/// chord (the blend takes `P / tan(phi / 4)` of each line, the curve's chords `4 chord /
/// phi`); with the model of the executed path the two need not be paid both
/// ([`BudgetRule::Executed`]). LinuxCNC 2.9, 50 mm/s, 500 mm/s^2, tol 0.01, chord / `P`
/// 0.15 / 0.1 tol (paid both) against 0.2 / 0.2 tol (modelled): butterfly_1000 nurbs
/// 9.275 / 9.250 s, crown bspline 7.458 / 7.439, cncjs_jsdc nurbs 18.145 / 18.120,
/// camotics_vcarve trig 20.725 / 20.559, linuxcnc_blur_torus trig 177.833 / 177.916.
/// Chord and `P` both 0.2 / 0.4 / 0.5 / 0.6 tol (modelled), fastest and slowest of the four
/// methods: butterfly_1000 9.250-9.323 / 9.249-9.378 / 9.272-9.379 / 9.274-9.351 s, crown
/// 7.439-7.507 / 7.445-7.513 / 7.520-7.542 / 7.508-7.516, cncjs_jsdc 18.103-18.182 /
/// 18.044-18.179 / 18.012-18.085 / 18.014-18.077, camotics_vcarve 20.559-20.656 /
/// 20.387-20.458 / 20.369-20.475 / 20.301-20.326 (two methods there fall back to paying
/// each part at 0.6 tol). Longer chords help the CAM files' runs of short, nearly
/// collinear lines (fewer junctions for LinuxCNC to blend); crown's sharp corners want the
/// curves' share. 0.4 keeps butterfly_1000 and crown where 0.2 had them.
pub const BLEND_SHARE: f64 = 0.4;
/// Builds under the model of LinuxCNC's executed path before the program is built with
/// each part paid in full: the first, and one with what it found over tol taken off the
/// curves. (Before them, one with the blocks evened out for LinuxCNC's blends, kept when
/// the model confirms it: camotics_tiger arc and linuxcnc_LHchips4 arc, nurbs and trig
/// are not, and are built with the greedy blocks.) The 13 files of ../shared/data/gcode
/// and linuxcnc_arcspiral, bspline and nurbs at tol 0.01, chord and `P` 0.2 tol: 26 of 28
/// builds pass the first, the other 2 the second (linuxcnc_Cereal and linuxcnc_stellabee1 with nurbs); at the 0.4 tol
/// defaults 20 keep the model's budget and the 8 of linuxcnc_51MeanderAve, _Cereal,
/// _blur_torus and _stellabee1 are paid in full.
const EXECUTED_BUILDS: usize = 2;
/// The chord (share of the tolerance) LinuxCNC gets when the model does not confirm a
/// build or does not apply (loops, emitters other than `lines`): the default before the
/// model (0.15 tol), paid in full with [`SUM_BLEND_SHARE`].
pub const SUM_CHORD_SHARE: f64 = 0.15;
/// The `G64 P` (share of the tolerance) LinuxCNC gets when the model does not confirm a
/// build or does not apply: the default before the model (tol / 10).
pub const SUM_BLEND_SHARE: f64 = 0.1;
/// Share of the tolerance LinuxCNC's blending may use when `--method none --emit ...`
/// compresses the program's own lines: what [`COMPRESS_CHORD_SHARE`] leaves.
pub const COMPRESS_BLEND_SHARE: f64 = 0.1;
/// Share of the tolerance used as the chord when `--method none --emit ...` compresses the
/// program's own lines (nothing else is built: the chord takes what blending and rounding
/// leave, with some room).
pub const COMPRESS_CHORD_SHARE: f64 = 0.8;
/// Accuracy of the model of LinuxCNC's executed path, as a share of the tolerance.
pub const EXECUTED_ACCURACY_SHARE: f64 = 1e-3;
/// Share of the tolerance kept back from the curves when LinuxCNC's blending is measured
/// by its model rather than paid in full: the model's accuracy, and a little room for the
/// corners where the chord and the blend do add up (a curve's sharp transition), so that
/// the first build is rarely refused.
pub const EXECUTED_MARGIN_SHARE: f64 = 0.02;
/// Accuracy of the verification, as a share of the tolerance.
pub const VERIFY_ACCURACY_SHARE: f64 = 1e-3;
/// Largest `--tol` (mm): a deviation larger than a machine's travel bounds nothing, and
/// the `G64 P` it gives would not be a number LinuxCNC reads (`--tol 1e308` was written
/// as such and failed its read-back, exit 1).
const TOL_MAX_MM: f64 = 1000.0;

/// `FILTER_PROGRESS` (percent) once the program is parsed: parsing is about a fifth of a
/// run, smoothing, writing and verifying the rest.
const FILTER_PROGRESS_PARSED: u32 = 20;
/// `FILTER_PROGRESS` once the written program is verified, before it goes out.
const FILTER_PROGRESS_VERIFIED: u32 = 95;
/// Smallest curve tolerance, as a share of `--tol`, that smoothing is asked to build to.
const MIN_CURVE_TOL_SHARE: f64 = 0.25;
/// Largest `--decimals`.
const MAX_DECIMALS: usize = ncsmooth_gcode::writer::MAX_DECIMALS;

/// Smoothing method names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// No smoothing (the program as written).
    None,
    /// Cubic B-spline corner transitions in a tolerance band (Guo et al.).
    Bspline,
    /// Circular-arc corner transitions (Wu et al.), runs of micro-lines as arc splines.
    Arc,
    /// NURBS fitting of micro-line runs plus arc corners (Wu et al.).
    Nurbs,
    /// Cubic trigonometric spline (Tao et al.).
    Trig,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Method {
        match m {
            MethodArg::None => Method::None,
            MethodArg::Bspline => Method::Bspline,
            MethodArg::Arc => Method::Arc,
            MethodArg::Nurbs => Method::Nurbs,
            MethodArg::Trig => Method::Trig,
        }
    }
}

/// Corner treatment names of `--method trig`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CornerArg {
    /// Inside transition within the tolerance (Tao Fig. 9).
    Round,
    /// Outside loop through the exact corner (Tao Fig. 8); needs `--loop-size`.
    Loop,
}

/// Arguments of `smooth`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct SmoothArgs {
    /// G-code file, or `-` for stdin.
    pub file: String,
    /// Smoothing method.
    #[arg(long, value_enum, default_value = "bspline")]
    pub method: MethodArg,
    /// Two-sided tolerance (mm): output within tol of the program, program vertices within
    /// tol of the output.
    #[arg(long, default_value_t = 0.01)]
    pub tol: f64,
    /// Output G-code file (`-` for stdout).
    #[arg(long, short)]
    pub output: PathBuf,
    /// JSON report file.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Chord error (mm) when flattening curves into G1 lines [default: 0.4 tol for linuxcnc;
    /// tol / 10 for generic; 0.3 tol for grbl, grblhal, marlin and klipper, which blend
    /// nothing].
    #[arg(long)]
    pub chord: Option<f64>,
    /// Decimals of the written coordinates (0 to 12; rounding uses part of the tolerance;
    /// a printer's E gets one more).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(0..=MAX_DECIMALS as i64))]
    pub decimals: u8,
    /// Junctions turning less than this (degrees) pass through unchanged.
    #[arg(long, default_value_t = ncsmooth::verify::TANGENT_TOL_DEG)]
    pub straight_angle: f64,
    /// Corner treatment of `--method trig`: `round` keeps the path within tol; `loop` cuts
    /// every corner exactly with an outside loop (wire EDM, laser) bounded by `--loop-size`.
    #[arg(long, value_enum, default_value = "round")]
    pub corner: CornerArg,
    /// Largest distance (mm) of a loop from its corner; required with `--corner loop`.
    #[arg(long, required_if_eq("corner", "loop"))]
    pub loop_size: Option<f64>,
    /// Controller the G-code is for: `linuxcnc` gets a `G64 P Q` that bounds its own
    /// blending (paid from --tol) and blocks long enough to reach feed in a servo cycle;
    /// `grbl`, `grblhal`, `marlin`, `klipper` get blocks of at least 4 steps (Marlin and
    /// Klipper arcs only in G17); `generic` gets neither.
    #[arg(long, value_enum, default_value = "linuxcnc")]
    pub dialect: DialectArg,
    /// How smoothed motion is written: `lines` (the default) cuts each run of feed moves
    /// into the longest G1 blocks within --chord (rounding included); `arcs` also fits XY
    /// arcs (G2/G3) where they reach farther; `g5` writes the B-spline method's cubic
    /// Béziers exactly as G5 (lines where the dialect has no G5); `native` writes move by move (arcs as
    /// G2/G3, other curves flattened each on its own; always used with `--corner loop`).
    /// With `--method none`, giving `--emit` compresses the program's own G1 runs within
    /// --chord (default 0.8 tol there) instead of copying them.
    #[arg(long, value_enum)]
    pub emit: Option<EmitArg>,
    /// LinuxCNC: `G64 P` (mm), the blending allowed, paid from --tol [default: 0.4 tol]. With
    /// the default `lines`, the path LinuxCNC executes is measured by a model of its blend
    /// arcs, and the curves get `tol - max(chord, P)` less rounding and 2 % (the chord and
    /// the blends do not add up along a curve); where the model does not confirm it, and
    /// with the other emitters or loops, they get `tol - chord - P` less rounding, the
    /// defaults then chord 0.15 tol and `P` 0.1 tol.
    #[arg(long)]
    pub g64_p: Option<f64>,
    /// LinuxCNC: `G64 Q` (mm), the naive-CAM merging allowed, paid from --tol [default: 0].
    #[arg(long)]
    pub g64_q: Option<f64>,
    /// LinuxCNC: the machine's acceleration (mm/s^2). Blocks then get a smaller `G64 P`
    /// where the speed allows (gently curved stretches, and where LinuxCNC brakes for or
    /// leaves a tight turn), so that its blends leave their lines (it accelerates along
    /// what a blend consumes with half of it) [default: none, one `P` per run].
    #[arg(long)]
    pub acc: Option<f64>,
    /// LinuxCNC, with --acc: the machine's fastest feed (mm/s, `MAX_VELOCITY`), which a
    /// feed override may reach: the blends are sized for it [default: the programmed
    /// feeds].
    #[arg(long, requires = "acc")]
    pub feed: Option<f64>,
    /// Reshape the fitted runs at their slow spots for least time under --feed and --acc
    /// inside the same band (as `plan --time-shape`; seconds of computing per spot).
    #[arg(long, requires_all = ["acc", "feed"])]
    pub time_shape: bool,
}

/// Dialect names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DialectArg {
    /// LinuxCNC (RS274/NGC).
    Linuxcnc,
    /// grbl 1.1.
    Grbl,
    /// grblHAL.
    Grblhal,
    /// Marlin.
    Marlin,
    /// Klipper.
    Klipper,
    /// Any controller that runs the written path exactly.
    Generic,
}

impl From<DialectArg> for Dialect {
    fn from(d: DialectArg) -> Dialect {
        match d {
            DialectArg::Linuxcnc => Dialect::LinuxCnc,
            DialectArg::Grbl => Dialect::Grbl,
            DialectArg::Grblhal => Dialect::GrblHal,
            DialectArg::Marlin => Dialect::Marlin,
            DialectArg::Klipper => Dialect::Klipper,
            DialectArg::Generic => Dialect::Generic,
        }
    }
}

/// Emitter names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EmitArg {
    /// Long G1 blocks within the chord.
    Lines,
    /// Long G1 blocks and XY arcs within the chord.
    Arcs,
    /// Long G1 blocks, and every XY cubic Bézier (the B-spline method's curves) as one
    /// exact `G5` where the dialect reads G5 (LinuxCNC, grblHAL, Marlin).
    G5,
    /// As `g5`, and every XY NURBS (the NURBS method's curves) as exact `G5.2 ... G5.3`,
    /// one per Bézier span (LinuxCNC; elsewhere as `g5`).
    Nurbs,
    /// Move by move.
    Native,
}

/// How the smoothed program is written.
#[derive(Clone, Copy, Debug)]
pub struct WriteSettings {
    /// Two-sided tolerance (mm).
    pub tol: f64,
    /// Flattening chord (mm), default by dialect ([`LINUXCNC_CHORD_SHARE`],
    /// [`DEFAULT_CHORD_SHARE`], [`STEPPER_CHORD_SHARE`]).
    pub chord: Option<f64>,
    /// Coordinate decimals.
    pub decimals: usize,
    /// Target controller.
    pub dialect: Dialect,
    /// Emitter; `None` is `lines`, and with `--method none` a verbatim copy.
    pub emit: Option<EmitArg>,
    /// LinuxCNC `G64 P` and `Q` (mm); `None` for the defaults ([`BLEND_SHARE`] tol and 0).
    pub g64: (Option<f64>, Option<f64>),
    /// LinuxCNC: the machine's acceleration (mm/s^2) for per-block `G64 P`.
    pub acc_mm_s2: Option<f64>,
    /// LinuxCNC: the machine's fastest feed (mm/s) for per-block `G64 P`.
    pub feed_mm_s: Option<f64>,
}

impl WriteSettings {
    /// Defaults for `tol`: LinuxCNC, long lines, 4 decimals, chord [`LINUXCNC_CHORD_SHARE`].
    pub fn new(tol: f64) -> WriteSettings {
        WriteSettings {
            tol,
            chord: None,
            decimals: 4,
            dialect: Dialect::LinuxCnc,
            emit: None,
            g64: (None, None),
            acc_mm_s2: None,
            feed_mm_s: None,
        }
    }
}

impl SmoothArgs {
    /// The smoothing options these arguments ask for (tolerance set later).
    pub fn options(&self) -> Result<SmoothOptions> {
        let mut o = SmoothOptions {
            method: self.method.into(),
            straight_angle_deg: self.straight_angle,
            ..Default::default()
        };
        if self.corner == CornerArg::Loop {
            if self.method != MethodArg::Trig {
                return Err(io::BadInput("--corner loop needs --method trig".into()).into());
            }
            let size = self.loop_size.unwrap_or(f64::NAN);
            if !(size > 0.0 && size.is_finite()) {
                return Err(io::BadInput(format!(
                    "--loop-size must be a positive length in mm, got {size}"
                ))
                .into());
            }
            o.trig.corner = CornerStyle::Loop { loop_size_mm: size };
        }
        if let (true, Some(acc), Some(feed)) = (self.time_shape, self.acc, self.feed) {
            o.run.fit.time_shape = Some(TimeShapeOptions::new(TimeLimits {
                feed_mm_s: feed,
                acc_mm_s2: [acc; 3],
            }));
        }
        Ok(o)
    }
}

/// Seconds spent per stage.
#[derive(Serialize, Debug, Default)]
pub struct Timings {
    /// Parsing.
    pub parse_s: f64,
    /// Smoothing.
    pub smooth_s: f64,
    /// Flattening and writing G-code text.
    pub write_s: f64,
    /// Verification.
    pub verify_s: f64,
}

/// The JSON report of `smooth`.
#[derive(Serialize, Debug)]
pub struct SmoothRunReport {
    /// Input name.
    pub input: String,
    /// Units the program was read in before its first G20/G21 (`--units`), when it moves
    /// before choosing: `(units, line of the first such move)`. LinuxCNC reads such a
    /// program in the machine's units.
    pub units_assumed: Option<(Units, u32)>,
    /// Tolerance asked for (mm).
    pub tol_mm: f64,
    /// Tolerance the curves were built to (mm): `tol - chord - rounding`, less `P + Q` of
    /// the `G64` written for LinuxCNC.
    pub curve_tol_mm: f64,
    /// Flattening chord error (mm).
    pub chord_mm: f64,
    /// Largest move of a point by the printed decimals (mm).
    pub rounding_mm: f64,
    /// Controller dialect written for.
    pub dialect: &'static str,
    /// Emitter.
    pub emit: EmitArg,
    /// LinuxCNC: the `G64 P Q` written before each smoothed run (mm); the controller's
    /// blending adds at most `p + q` to the measured deviation, and the sum stays within
    /// the tolerance.
    pub blend: Option<BlendReport>,
    /// Blocks, bytes and block lengths in and out.
    pub blocks: BlockReport,
    /// What the method did.
    pub smoothing: SmoothReport,
    /// Measured two-sided deviation of the written G-code, read back, from the program
    /// (without the loops in loop mode: the legs still reach every looped corner).
    pub deviation: Deviation,
    /// Loop mode: the loops' own bound, measured on the curves (corner passed within 1e-9
    /// mm; excursion within the loop size less `rounding_mm`, so the written loops are
    /// within the loop size).
    pub loops: Option<LoopCheck>,
    /// Continuity of the smoothed path (before flattening).
    pub continuity: Continuity,
    /// Continuity of the input program.
    pub input_continuity: Continuity,
    /// True when the written path is within tol.
    pub within_tol: bool,
    /// Where the written program's extra axes (A B C U V W E) differ from the program's,
    /// before an extra-axis event or at the end ([`ncsmooth::verify::extra_axes_kept`],
    /// within the rounding); `None` when they agree.
    pub extra_axes_mismatch: Option<ncsmooth::verify::ExtraAxesMismatch>,
    /// How far the written `E` strays along the path from the program's: the largest
    /// distance (mm of filament) of a written move end's `E` from the program's over its
    /// points within tol ([`ncsmooth::verify::extrusion_along_path`]); `None` without `E`.
    pub extrusion_along_path: Option<ncsmooth::verify::ExtrusionAlongPath>,
    /// Seconds per stage.
    pub timings: Timings,
}

/// LinuxCNC blending bounds written.
#[derive(Serialize, Debug, Clone, Copy)]
pub struct BlendReport {
    /// `G64 P` (mm).
    pub p_mm: f64,
    /// `G64 Q` (mm).
    pub q_mm: f64,
    /// `G64 P` (mm, with `Q0`) for the program's own motion copied verbatim, where the
    /// program's own mode is looser.
    pub verbatim_p_mm: f64,
    /// The bound on the path LinuxCNC executes (mm): `executed_model_mm` where the model
    /// applies, else the measured deviation of the written path plus `p + q` (or
    /// `verbatim_p_mm` where larger).
    pub executed_bound_mm: f64,
    /// The deviation of the path LinuxCNC executes by its blending model
    /// ([`ncsmooth_gcode::executed`]), largest of both sides (mm).
    pub executed_model_mm: f64,
    /// Junctions whose blend the model follows, and junctions counted as the written
    /// deviation plus `p + q`.
    pub blends_modelled: usize,
    /// See `blends_modelled`.
    pub blends_counted: usize,
}

/// What the written program looks like beside the input (ArcWelder's summary, with our
/// measured deviation).
#[derive(Serialize, Debug, Clone, Default)]
pub struct BlockReport {
    /// Motion blocks (moves) of the program as read.
    pub blocks_in: usize,
    /// Motion blocks of the written program, read back.
    pub blocks_out: usize,
    /// Bytes of the program.
    pub bytes_in: usize,
    /// Bytes written.
    pub bytes_out: usize,
    /// `blocks_in / blocks_out`.
    pub compression: f64,
    /// Shortest feed block written (mm).
    pub min_block_mm: f64,
    /// Median feed block written (mm).
    pub median_block_mm: f64,
    /// Junctions between written feed blocks turning by more than 1 degree.
    pub turns_over_1_deg: usize,
    /// ... by more than 5 degrees.
    pub turns_over_5_deg: usize,
    /// Lines longer than the dialect reads.
    pub long_lines: usize,
    /// First line longer than the dialect reads (1-based), 0 when none.
    pub first_long_line: usize,
}

impl BlockReport {
    fn of(
        input: &[u8],
        tp_in: &ncsmooth::Toolpath,
        out: &[u8],
        tp_out: &ncsmooth::Toolpath,
        dialect: Dialect,
    ) -> BlockReport {
        let (a, b) = (PathStats::of(tp_in), PathStats::of(tp_out));
        let blocks = |s: &PathStats| s.rapids + s.feed_lines + s.feed_arcs + s.feed_curves;
        let over = |s: &PathStats, deg: f64| -> usize {
            s.corner_angles
                .iter()
                .filter(|bin| bin.from_deg >= deg)
                .map(|bin| bin.count)
                .sum()
        };
        let (mut long_lines, mut first_long_line) = (0, 0);
        if let Some(max) = dialect.max_line_len() {
            for (i, l) in out.split(|&c| c == b'\n').enumerate() {
                let l = l.strip_suffix(b"\r").unwrap_or(l);
                if dialect.stored_len(l) > max {
                    long_lines += 1;
                    if first_long_line == 0 {
                        first_long_line = i + 1;
                    }
                }
            }
        }
        let (bi, bo) = (blocks(&a), blocks(&b));
        BlockReport {
            blocks_in: bi,
            blocks_out: bo,
            bytes_in: input.len(),
            bytes_out: out.len(),
            compression: if bo > 0 { bi as f64 / bo as f64 } else { 0.0 },
            min_block_mm: b.feed_segment_length_mm.min,
            median_block_mm: b.feed_segment_length_mm.median,
            turns_over_1_deg: over(&b, 1.0),
            turns_over_5_deg: over(&b, 5.0),
            long_lines,
            first_long_line,
        }
    }
}

/// Result of [`smooth_program`]: the written text and the report.
pub struct SmoothOutcome {
    /// G-code text (the program's bytes where they are copied).
    pub gcode: Vec<u8>,
    /// Report.
    pub report: SmoothRunReport,
}

/// `v` (mm) rounded to the nanometre, so that a share of the tolerance prints as the
/// length it is (`0.08`, not `0.08000000000000002`).
fn to_nm(v: f64) -> f64 {
    const NM_PER_MM: f64 = 1e6;
    (v * NM_PER_MM).round() / NM_PER_MM
}

/// Smooths, flattens, writes and verifies a parsed program (shared with the demo).
/// `base` carries the method and its options; its tolerance is replaced by the curve
/// tolerance derived from `tol` and `chord`.
pub fn smooth_program(
    name: &str,
    src: &[u8],
    program: &ncsmooth_gcode::Program,
    base: SmoothOptions,
    ws: WriteSettings,
) -> Result<SmoothOutcome> {
    // For LinuxCNC's lines the curves first get what its modelled blending leaves, less
    // what the model found over tol in a first build; where that is not confirmed either,
    // the program is built as it was before the model, each part paid in full.
    let compress = base.method == Method::None && ws.emit.is_some();
    let modelled = ws.dialect.blends()
        && matches!(ws.emit, None | Some(EmitArg::Lines))
        && !compress
        && !matches!(base.trig.corner, CornerStyle::Loop { .. });
    if modelled {
        let mut less_mm = 0.0;
        // The first build evens out the blocks for LinuxCNC's blends; where the model
        // finds that over tol, the same budget is tried with the greedy blocks.
        let evened = [true].into_iter().chain(std::iter::repeat(false));
        for (k, even_out) in evened.take(EXECUTED_BUILDS + 1).enumerate() {
            let rule = BudgetRule::Executed { less_mm, even_out };
            // A build the budget leaves no room for falls back to paying each part.
            let Ok(out) = smooth_program_with(name, src, program, base.clone(), ws, rule) else {
                break;
            };
            if out.report.within_tol {
                return Ok(out);
            }
            if k == 0 {
                continue;
            }
            let over = out.report.blend.map_or(f64::NAN, |b| b.executed_model_mm) - ws.tol;
            if !(over > 0.0 && over < ws.tol * EXECUTED_MARGIN_SHARE * 10.0) {
                break;
            }
            less_mm += over + ws.tol * EXECUTED_MARGIN_SHARE;
        }
    }
    // Paid in full, LinuxCNC's chord and `P` take the shares measured best for that budget
    // (also where the model does not apply: loops, the other emitters).
    let paid = ws.dialect.blends() && !compress;
    let ws = if paid {
        WriteSettings {
            chord: ws.chord.or(Some(ws.tol * SUM_CHORD_SHARE)),
            g64: (ws.g64.0.or(Some(ws.tol * SUM_BLEND_SHARE)), ws.g64.1),
            ..ws
        }
    } else {
        ws
    };
    smooth_program_with(name, src, program, base, ws, BudgetRule::Sum)
}

/// How the tolerance is shared between the curves and the controller's blending.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BudgetRule {
    /// `tol - chord - rounding - (P + Q)`: each part paid in full.
    Sum,
    /// `tol - max(chord, P) - rounding - margin - less_mm`, accepted only when the model
    /// of the path LinuxCNC executes ([`ncsmooth_gcode::executed`]) is within tol. LinuxCNC's blend at
    /// a vertex of a flattened curve cuts inside it by at most `P`, where the chord is on
    /// the curve; between vertices the chord departs from it by at most `chord`, where the
    /// blends have left the line: the two do not add (a circle flattened within `c` and
    /// blended under `P = c` runs within `c` of the circle). At a sharp transition they
    /// can partly add: `less_mm` is what a build found over tol, taken off the next.
    Executed {
        /// Taken off the curves' tolerance (mm).
        less_mm: f64,
        /// Whether the blocks are evened out for LinuxCNC's blends
        /// ([`ncsmooth_gcode::RewriteOptions::even_out`]).
        even_out: bool,
    },
}

fn smooth_program_with(
    name: &str,
    src: &[u8],
    program: &ncsmooth_gcode::Program,
    base: SmoothOptions,
    ws: WriteSettings,
    rule: BudgetRule,
) -> Result<SmoothOutcome> {
    let WriteSettings {
        tol,
        chord,
        decimals,
        dialect,
        ..
    } = ws;
    let method = base.method;
    // `none` with an emitter re-writes the program's own lines within the chord: no
    // curves are built, so the chord may take what blending and rounding leave.
    let compress = method == Method::None && ws.emit.is_some();
    let chord = chord.unwrap_or(if compress {
        tol * COMPRESS_CHORD_SHARE
    } else if dialect.block_floor_mm().is_some() {
        tol * STEPPER_CHORD_SHARE
    } else if dialect == Dialect::LinuxCnc {
        tol * LINUXCNC_CHORD_SHARE
    } else {
        tol * DEFAULT_CHORD_SHARE
    });
    if !(tol > 0.0 && tol <= TOL_MAX_MM) {
        return Err(io::BadInput(format!(
            "--tol must be a length in (0, {TOL_MAX_MM}] mm, got {tol}"
        ))
        .into());
    }
    if !(chord > 0.0 && chord < tol) {
        return Err(io::BadInput(format!("--chord must be in (0, tol), got {chord}")).into());
    }
    // Inch programs are written in inches: their rounding applies where they are.
    let rounding = Budget::new(program, tol, chord, decimals, 0.0).rounding_mm;
    // `none` builds no curves, but rounding still moves its points and off-plane arcs are
    // still flattened: the same budget applies.
    // LinuxCNC blends between the written blocks: `G64 P<tol/10> Q0` keeps its blend
    // arcs no tighter than the default chords themselves (a blend at a chord junction
    // turning by `theta` has radius about `8 P / theta^2`, the curve `8 chord / theta^2`)
    // and is paid from the tolerance.
    let blend = dialect.blends().then_some(Blend {
        p_mm: ws.g64.0.unwrap_or(
            tol * if compress {
                COMPRESS_BLEND_SHARE
            } else {
                BLEND_SHARE
            },
        ),
        q_mm: ws.g64.1.unwrap_or(0.0),
    });
    if let Some(b) = blend {
        if !(b.p_mm > 0.0 && b.p_mm < tol && b.q_mm >= 0.0 && b.q_mm < tol) {
            return Err(io::BadInput(format!(
                "--g64-p must be in (0, tol) and --g64-q in [0, tol), got {} and {}",
                b.p_mm, b.q_mm
            ))
            .into());
        }
    }
    let blend_mm = blend.map_or(0.0, |b| b.p_mm + b.q_mm);
    // The program's own rapids copied verbatim deviate by LinuxCNC's blending alone.
    let verbatim_blend = blend.map(|_| Blend {
        p_mm: tol * VERBATIM_BLEND_SHARE,
        q_mm: 0.0,
    });
    let budget = Budget::new(program, tol, chord, decimals, blend_mm);
    let curve_tol = match (rule, blend) {
        (BudgetRule::Executed { less_mm, .. }, Some(b)) => {
            tol - chord.max(b.p_mm) - b.q_mm - rounding - tol * EXECUTED_MARGIN_SHARE - less_mm
        }
        _ => budget.curve_tol_mm(),
    };
    // A tolerance eaten by the flattening chord and the printed decimals is an input
    // error, not something to fail on later.
    if (curve_tol <= tol * MIN_CURVE_TOL_SHARE && !compress)
        || curve_tol.is_nan()
        || curve_tol < 0.0
    {
        return Err(io::BadInput(format!(
            "--tol {tol:?} mm leaves too little room: the flattening chord takes {chord:?} mm, \
             the controller's blending {blend_mm:?} mm \
             and {decimals} decimals round coordinates by up to {rounding:.3e} mm; \
             use a larger --tol, a smaller --chord or more --decimals"
        ))
        .into());
    }
    let mut opts = SmoothOptions {
        tol_mm: curve_tol,
        ..base
    };
    if blend.is_some() {
        // LinuxCNC's blends follow the written curve's own radius: the run fit is run to
        // its minimum (ncsmooth::smooth::band_fit::BandFitOptions::converged).
        let converged = BandFitOptions::converged();
        opts.run.fit.min_knot_span_mm = converged.min_knot_span_mm;
        opts.run.fit.energy_settle_share = converged.energy_settle_share;
    }
    // Loops are built to the loop size less the rounding: flattening only cuts chords
    // inside a loop (its excursion from the corner cannot grow), rounding moves points.
    let loop_size = match (method, opts.trig.corner) {
        (Method::Trig, CornerStyle::Loop { loop_size_mm }) => {
            let build = loop_size_mm - rounding;
            if build <= loop_size_mm * MIN_CURVE_TOL_SHARE || build.is_nan() {
                return Err(io::BadInput(format!(
                    "--loop-size {loop_size_mm:?} mm is too small for {decimals} decimals, \
                     which round coordinates by up to {rounding:.3e} mm; use more --decimals"
                ))
                .into());
            }
            opts.trig.corner = CornerStyle::Loop {
                loop_size_mm: build,
            };
            Some(build)
        }
        _ => None,
    };
    let mut t = Timings::default();
    let t0 = Instant::now();
    let smoothed = smooth(&program.toolpath, &opts).map_err(|e| io::BadInput(e.to_string()))?;
    t.smooth_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let loop_mode = loop_size.is_some();
    let emit = match (loop_mode, ws.emit, method) {
        (true, _, _) | (false, None, Method::None) => EmitArg::Native,
        (false, None, _) => EmitArg::Lines,
        (false, Some(e), _) => e,
    };
    // A stepper controller is given no block of a step or two: the program's own G1 lines
    // between the smoothed ones go through the long-lines emitter too, where its short
    // blocks are lifted (a copied line is never lifted).
    let floor = dialect.block_floor_mm().is_some()
        && matches!(emit, EmitArg::Lines | EmitArg::G5 | EmitArg::Nurbs);
    let wopts = RewriteOptions::new(decimals.min(MAX_DECIMALS), chord)
        .with_header(format!(
            "ncsmooth {} --method {} --tol {tol} --dialect {} (from {name})",
            env!("CARGO_PKG_VERSION"),
            method.name(),
            dialect.name()
        ))
        .for_dialect(dialect, blend)
        .with_verbatim_blend(verbatim_blend)
        .with_blend_limits(ws.acc_mm_s2, ws.feed_mm_s)
        .with_even_out(matches!(rule, BudgetRule::Executed { even_out: true, .. }))
        .with_emit(match emit {
            EmitArg::Native => Emit::Native,
            EmitArg::Arcs => Emit::Arcs,
            EmitArg::Nurbs if dialect.has_nurbs() => Emit::Nurbs {
                min_block_mm: dialect.min_block_mm(0.0),
                min_block_s: dialect.min_block_s(),
            },
            EmitArg::G5 | EmitArg::Nurbs if dialect.has_g5() => Emit::G5 {
                min_block_mm: dialect.min_block_mm(0.0),
                min_block_s: dialect.min_block_s(),
            },
            EmitArg::Lines | EmitArg::G5 | EmitArg::Nurbs => Emit::Lines {
                min_block_mm: dialect.min_block_mm(0.0),
                min_block_s: dialect.min_block_s(),
            },
        })
        .with_rewrite_unchanged(compress || (floor && method != Method::None))
        .with_block_floor(match dialect.block_floor_mm() {
            Some(m) => Some(BlockFloor {
                min_block_mm: m,
                tol_mm: tol - rounding - blend_mm,
                corner: None,
            }),
            // LinuxCNC, where the model of its executed path checks the build and the
            // schedule sizes the blends: a block shorter than four `P` caps its blends at
            // a quarter of its length; the programmed corner instead, blended within a
            // `P` of its own.
            // A `Q` is not modelled: no corner then.
            None => match (rule, blend, verbatim_blend, ws.acc_mm_s2, emit) {
                (
                    BudgetRule::Executed { less_mm, .. },
                    Some(b),
                    Some(v),
                    Some(_),
                    EmitArg::Lines,
                ) if b.q_mm == 0.0 => Some(BlockFloor {
                    min_block_mm: LINUXCNC_CORNER_FLOOR_P * b.p_mm,
                    tol_mm: tol - rounding - blend_mm,
                    corner: Some(CornerBlend {
                        // The blends at raised points leave the same share to whoever
                        // measures them from servo samples as the verbatim motion's.
                        total_mm: tol * VERBATIM_BLEND_SHARE - rounding - less_mm,
                        max_p_mm: v.p_mm,
                    }),
                }),
                _ => None,
            },
        });
    let write = |tp: &ncsmooth::Toolpath| {
        ncsmooth_gcode::rewrite(src, program, tp, &wopts)
            .map_err(|e| anyhow::anyhow!("writing the smoothed program: {e}"))
    };
    let gcode = write(&smoothed.toolpath)?;
    t.write_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let loops = loop_size.map(|size| check_loops(&smoothed.toolpath, &program.toolpath, size));
    // The written text is read back and measured: rounding and the reader's own arc
    // reconstruction are part of what the machine will run. In loop mode the loops are
    // measured by their own bound, and the two-sided tolerance on the same text written
    // without them.
    let unreadable = |e| anyhow::anyhow!("the written G-code does not read back: {e}");
    // Read back as the program was read (its default units).
    let opts = crate::parse_options();
    let accuracy = tol * VERIFY_ACCURACY_SHARE;
    let (as_written, dev) = if loop_mode {
        let text = write(&without_loops(&smoothed.toolpath))?;
        let (_, dev) =
            read_back_with(&text, name, &program.toolpath, accuracy, opts).map_err(unreadable)?;
        (
            read_written_with(&gcode, name, opts).map_err(unreadable)?,
            dev,
        )
    } else {
        read_back_with(&gcode, name, &program.toolpath, accuracy, opts).map_err(unreadable)?
    };
    let blocks = BlockReport::of(src, &program.toolpath, &gcode, &as_written, dialect);
    let extra_axes_mismatch =
        ncsmooth::verify::extra_axes_kept(&program.toolpath, &as_written, rounding);
    let extrusion_along_path =
        ncsmooth::verify::extrusion_along_path(&program.toolpath, &as_written, tol);
    let executed = match (blend, loop_mode) {
        (Some(b), false) => {
            let written = ncsmooth_gcode::parse_bytes(&gcode, name, opts).map_err(unreadable)?;
            let cap = verbatim_blend.map_or(b.p_mm, |v| v.p_mm.max(b.p_mm));
            Some(ncsmooth_gcode::executed::linuxcnc_executed(
                &written,
                &program.toolpath,
                &dev,
                cap,
                blend_mm,
                tol * EXECUTED_ACCURACY_SHARE,
            ))
        }
        _ => None,
    };
    let loops_ok = match (loops, loop_size) {
        (Some(l), Some(size)) => l.within(size),
        _ => true,
    };
    let cont = continuity(&smoothed.toolpath);
    let input_cont = continuity(&program.toolpath);
    t.verify_s = t0.elapsed().as_secs_f64();
    let report = SmoothRunReport {
        input: name.to_string(),
        units_assumed: program
            .stats
            .units_assumed
            .map(|line| (opts.default_units, line)),
        tol_mm: tol,
        curve_tol_mm: curve_tol,
        chord_mm: chord,
        rounding_mm: rounding,
        dialect: dialect.name(),
        emit,
        blend: blend.map(|b| BlendReport {
            p_mm: b.p_mm,
            q_mm: b.q_mm,
            verbatim_p_mm: verbatim_blend.map_or(b.p_mm, |v| v.p_mm),
            executed_bound_mm: executed.map_or_else(
                || (dev.max_mm() + blend_mm).max(verbatim_blend.map_or(0.0, |v| v.p_mm + v.q_mm)),
                |e| e.max_mm(),
            ),
            executed_model_mm: executed.map_or(f64::NAN, |e| e.max_mm()),
            blends_modelled: executed.map_or(0, |e| e.blends_modelled),
            blends_counted: executed.map_or(0, |e| e.blends_counted),
        }),
        blocks,
        smoothing: smoothed.report.clone(),
        within_tol: loops_ok
            && match executed {
                // The model of what LinuxCNC runs, where it applies, whichever the budget.
                Some(e) => dev.within(tol) && e.max_mm() <= tol,
                None => budget.holds(&dev),
            },
        deviation: dev,
        extra_axes_mismatch,
        extrusion_along_path,
        loops,
        continuity: cont,
        input_continuity: input_cont,
        timings: t,
    };
    Ok(SmoothOutcome { gcode, report })
}

/// Writes several outputs all or nothing: every file is opened (and its directory checked)
/// and written before any is moved into place. `-` goes to stdout.
pub fn write_outputs(outputs: &[(Option<&PathBuf>, &[u8])]) -> Result<()> {
    let mut files = Vec::with_capacity(outputs.len());
    for (path, bytes) in outputs {
        let Some(path) = path else { continue };
        if path.as_os_str() == "-" {
            continue;
        }
        let mut f = io::OutputFile::create(path)?;
        f.write_all(bytes)
            .with_context(|| format!("writing {}", path.display()))?;
        files.push(f);
    }
    io::commit_all(files)?;
    for (path, bytes) in outputs {
        if path.is_some_and(|p| p.as_os_str() == "-") {
            io::print_stdout(bytes)?;
        }
    }
    Ok(())
}

/// Runs `smooth`.
pub fn run(a: SmoothArgs, ui: Ui) -> Result<()> {
    let mut outputs = vec![("-o", a.output.as_path())];
    if let Some(r) = &a.report {
        outputs.push(("--report", r.as_path()));
    }
    io::check_outputs(Some(&a.file), &outputs)?;
    // As a LinuxCNC filter (`[FILTER] PROGRAM_EXTENSION`, program on stdout) the progress
    // goes to stderr as `FILTER_PROGRESS=N` lines, which LinuxCNC shows as a bar.
    let filter = a.output.as_os_str() == "-" && a.dialect == DialectArg::Linuxcnc && !ui.quiet;
    let progress = |percent: u32| {
        if filter {
            crate::diag::say(format_args!("FILTER_PROGRESS={percent}"));
        }
    };
    progress(0);
    let t0 = Instant::now();
    let loaded = load(&a.file)?;
    progress(FILTER_PROGRESS_PARSED);
    if let Some(line) = loaded.program.stats.units_assumed {
        ui.status(crate::units_warning(io::display_name(&a.file), line));
    }
    let st = &loaded.program.stats;
    if st.g0 + st.g1 + st.g2 + st.g3 + st.untracked == 0 {
        // LinuxCNC runs an empty program; so is it written, as it is.
        ui.status(format!(
            "warning: {}: the program has no motion; it is written as it is",
            io::display_name(&a.file)
        ));
    }
    let program = &loaded.program;
    let parse_s = t0.elapsed().as_secs_f64();
    let name = io::display_name(&a.file);
    let base = a.options()?;
    let ws = WriteSettings {
        tol: a.tol,
        chord: a.chord,
        decimals: usize::from(a.decimals),
        dialect: a.dialect.into(),
        emit: a.emit,
        g64: (a.g64_p, a.g64_q),
        acc_mm_s2: a.acc,
        feed_mm_s: a.feed,
    };
    let mut out = smooth_program(name, &loaded.src, program, base, ws)?;
    out.report.timings.parse_s = parse_s;
    let r = &out.report;
    if let (Some(l), Some(size)) = (&r.loops, a.loop_size) {
        if !l.within(size - r.rounding_mm) {
            bail!(
                "verification failed: loops pass their corners within {:.3e} mm and reach {:.9e} mm, plus up to {:.3e} mm of rounding (loop size {size:?} mm); nothing written",
                l.max_corner_miss_mm,
                l.max_excursion_mm,
                r.rounding_mm
            );
        }
    }
    if let Some(m) = r.extra_axes_mismatch {
        bail!(
            "verification failed: axis {} is at {} in the written program where the program has {} (before line {}, 0: at the end); nothing written",
            ncsmooth::path::EXTRA_AXIS_NAMES[m.axis],
            m.written,
            m.program,
            m.line
        );
    }
    if !r.within_tol {
        let blend = r.blend.map_or(0.0, |b| b.p_mm + b.q_mm);
        bail!(
            "verification failed: deviation {:.6} mm (output to program, line {}) / {:.6} mm (vertex to output, line {}) plus {blend:?} mm of controller blending exceeds tol {:?} mm; nothing written",
            r.deviation.output_to_programmed_mm,
            r.deviation.output_line,
            r.deviation.vertex_to_output_mm,
            r.deviation.vertex_line,
            a.tol
        );
    }
    progress(FILTER_PROGRESS_VERIFIED);
    let json = serde_json::to_string_pretty(r)?;
    write_outputs(&[
        (Some(&a.output), &out.gcode[..]),
        (a.report.as_ref(), json.as_bytes()),
    ])?;
    let s = &r.smoothing;
    let b = &r.blocks;
    if b.long_lines > 0 {
        ui.status(format!(
            "warning: {} lines are longer than {} reads (first: line {})",
            b.long_lines,
            a.dialect
                .to_possible_value()
                .map(|v| v.get_name().to_string())
                .unwrap_or_default(),
            b.first_long_line
        ));
    }
    ui.status(format!(
        "{name}: blocks {} -> {} ({:.2}x), bytes {} -> {}, block min {:.4} / median {:.4} mm, turns > 1 deg {}, > 5 deg {}{}",
        b.blocks_in,
        b.blocks_out,
        b.compression,
        b.bytes_in,
        b.bytes_out,
        b.min_block_mm,
        b.median_block_mm,
        b.turns_over_1_deg,
        b.turns_over_5_deg,
        r.blend.map_or(String::new(), |bl| format!(
            "; LinuxCNC G64 P{} Q{} (verbatim motion P{}), executed path within {:.6} mm",
            to_nm(bl.p_mm),
            to_nm(bl.q_mm),
            to_nm(bl.verbatim_p_mm),
            bl.executed_bound_mm
        ))
    ));
    progress(100);
    ui.status(format!(
        "{name}: {} corners smoothed, {} straight, {} stopped; deviation {:.6} / {:.6} mm (tol {:?} mm); G2 joints {}, G1 {}, G0 {}; {:.3} s",
        s.corners_smoothed,
        s.corners_straight,
        s.corners_stopped,
        r.deviation.output_to_programmed_mm,
        r.deviation.vertex_to_output_mm,
        a.tol,
        r.continuity.g2,
        r.continuity.g1,
        r.continuity.g0,
        t0.elapsed().as_secs_f64()
    ));
    Ok(())
}

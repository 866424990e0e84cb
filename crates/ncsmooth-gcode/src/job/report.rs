//! What a smoothing job reports: the budget it used, the blocks written, the measured
//! deviation of the written text, the model of the controller's executed path, and the
//! time per stage. Serialized as `ncsmooth smooth --report`'s JSON.

use super::EmitStyle;
use crate::{Dialect, Units};
use ncsmooth::interp::PlanReport;
use ncsmooth::smooth::trig_corner::LoopCheck;
use ncsmooth::smooth::SmoothReport;
use ncsmooth::verify::{Continuity, Deviation};
use ncsmooth::PathStats;
use serde::Serialize;

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
    pub emit: EmitStyle,
    /// How the controller runs the arcs written, as counted in the tolerance: `exact`,
    /// or the chords it cuts them into (the dialect's default or `--arc-segment`).
    pub arc_chords: crate::ArcChords,
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
    /// Where the written program's per-block values (`S` on motion blocks) differ from the
    /// program's: a value lost, changed or set off the programmed vertex
    /// ([`ncsmooth::verify::block_values_kept`], within the rounding); `None` when they
    /// agree.
    pub block_values_mismatch: Option<ncsmooth::verify::BlockValueMismatch>,
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
    /// ([`crate::controller::linuxcnc::executed`]), largest of both sides (mm).
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
    pub(crate) fn of(
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

/// The JSON report of `ncsmooth plan`: the method, what smoothing did, the plan, and the
/// time per stage.
#[derive(Serialize, Debug)]
pub struct PlanRunReport {
    /// Input name.
    pub input: String,
    /// Method asked for.
    pub method: String,
    /// What smoothing did.
    pub smoothing: SmoothReport,
    /// Seconds parsing (a streamed file: opening it and reading its first blocks; the
    /// rest is read while planning, inside the plan's stage times).
    pub parse_s: f64,
    /// Seconds smoothing (a streamed file: nothing apart, it is smoothed while planned).
    pub smooth_s: f64,
    /// Planning and interpolation.
    pub plan: PlanReport,
    /// Cycle time / (parse + smooth + plan + interpolate + write) time.
    pub end_to_end_real_time_factor: f64,
}

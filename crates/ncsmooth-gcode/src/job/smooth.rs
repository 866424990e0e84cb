//! The smoothing pipeline: budget, curves, rewrite, read-back, the model of the
//! controller's executed path, and the report.

use super::policy::*;
use super::report::{BlendReport, BlockReport, SmoothRunReport, Timings};
use super::{EmitStyle, JobError, SmoothJob, SmoothedGcode};
use crate::budget::{read_written_with, Budget};
use crate::controller::linuxcnc::budget::*;
use crate::controller::linuxcnc::executed::Executed;
use crate::controller::linuxcnc::{Blend, CornerBlend};
use crate::write::rewrite::{BlockFloor, Emit};
use crate::{ArcChords, Dialect, Program, RewriteOptions};
use ncsmooth::smooth::band_fit::BandFitOptions;
use ncsmooth::smooth::trig_corner::{check_loops, without_loops, CornerStyle, LoopCheck};
use ncsmooth::smooth::{smooth, Method, SmoothOptions, Smoothed as Curves};
use ncsmooth::verify::{
    continuity, BlockValueMismatch, Continuity, Deviation, ExtraAxesMismatch, ExtrusionAlongPath,
    ProgramIndex,
};
use ncsmooth::Toolpath;
use std::time::Instant;

/// The curves of a build, for a later build with the same curve options.
struct CachedCurves {
    opts: SmoothOptions,
    curves: Curves,
    /// Time their smoothing took (s).
    smooth_s: f64,
}

impl CachedCurves {
    fn of(tp: &Toolpath, opts: SmoothOptions) -> Result<CachedCurves, JobError> {
        let t0 = Instant::now();
        let curves = smooth(tp, &opts).map_err(|e| JobError::BadInput(e.to_string()))?;
        Ok(CachedCurves {
            opts,
            curves,
            smooth_s: t0.elapsed().as_secs_f64(),
        })
    }
}

impl SmoothJob {
    /// Parses `src` (named `name` in errors and the header) with [`SmoothJob::read`] and
    /// runs the job on it ([`SmoothJob::run`]); the parse time is in the report.
    pub fn run_bytes(&self, name: &str, src: &[u8]) -> Result<SmoothedGcode, JobError> {
        let t0 = Instant::now();
        let program = crate::parse_bytes(src, name, &self.read)?;
        let parse_s = t0.elapsed().as_secs_f64();
        let mut out = self.run(name, src, &program)?;
        out.report.timings.parse_s = parse_s;
        Ok(out)
    }

    /// Smooths, writes and verifies `program`, parsed from `src` with [`SmoothJob::read`].
    /// An `Ok` may still be outside the tolerance: see [`SmoothedGcode::verified`].
    pub fn run(
        &self,
        name: &str,
        src: &[u8],
        program: &Program,
    ) -> Result<SmoothedGcode, JobError> {
        // For LinuxCNC's lines the curves first get what its modelled blending leaves, less
        // what the model found over tol in a first build; where that is not confirmed either,
        // the program is built as it was before the model, each part paid in full.
        let compress = self.compresses();
        // Builds whose curve options are the same (the first two differ in the writing
        // only) share one smoothing.
        let mut cache: Option<CachedCurves> = None;
        let modelled = self.dialect.blends()
            && matches!(self.emit, None | Some(EmitStyle::Lines))
            && !compress
            && !matches!(self.smooth.trig.corner, CornerStyle::Loop { .. });
        if modelled {
            let mut less_mm = 0.0;
            // The first build evens out the blocks for LinuxCNC's blends; where the model
            // finds that over tol, the same budget is tried with the greedy blocks.
            let evened = [true].into_iter().chain(std::iter::repeat(false));
            for (k, even_out) in evened.take(EXECUTED_BUILDS + 1).enumerate() {
                let rule = BudgetRule::Executed { less_mm, even_out };
                // A build the budget leaves no room for falls back to paying each part.
                let Ok(out) = self.run_with(name, src, program, rule, &mut cache) else {
                    break;
                };
                if out.report.within_tol {
                    return Ok(out);
                }
                if k == 0 {
                    continue;
                }
                let over = out.report.blend.map_or(f64::NAN, |b| b.executed_model_mm) - self.tol_mm;
                if !(over > 0.0 && over < self.tol_mm * EXECUTED_MARGIN_SHARE * 10.0) {
                    break;
                }
                less_mm += over + self.tol_mm * EXECUTED_MARGIN_SHARE;
            }
        }
        // Paid in full, LinuxCNC's chord and `P` take their shares for that budget (also
        // where the model does not apply: loops, the other emitters).
        if self.dialect.blends() && !compress {
            let tol = self.tol_mm;
            let job = SmoothJob {
                chord_mm: self.chord_mm.or(Some(tol * SUM_CHORD_SHARE)),
                g64_p_mm: self.g64_p_mm.or(Some(tol * SUM_BLEND_SHARE)),
                ..self.clone()
            };
            return job.run_with(name, src, program, BudgetRule::Sum, &mut cache);
        }
        self.run_with(name, src, program, BudgetRule::Sum, &mut cache)
    }

    /// `Method::None` with an emitter re-writes the program's own lines within the chord:
    /// no curves are built, so the chord may take what blending and rounding leave.
    fn compresses(&self) -> bool {
        self.smooth.method == Method::None && self.emit.is_some()
    }

    fn run_with(
        &self,
        name: &str,
        src: &[u8],
        program: &Program,
        rule: BudgetRule,
        cache: &mut Option<CachedCurves>,
    ) -> Result<SmoothedGcode, JobError> {
        let shares = Shares::of(self, program, rule)?;
        let (opts, loop_size) = self.curve_options(&shares)?;
        let mut t = Timings::default();
        if cache.as_ref().is_some_and(|c| c.opts != opts) {
            *cache = None;
        }
        let accuracy = shares.tol * VERIFY_ACCURACY_SHARE;
        let cached = match cache {
            Some(c) => &*c,
            None => &*cache.insert(CachedCurves::of(&program.toolpath, opts)?),
        };
        let curves = &cached.curves;
        t.smooth_s = cached.smooth_s;
        let t0 = Instant::now();
        let emit = match (loop_size.is_some(), self.emit, self.smooth.method) {
            (true, _, _) | (false, None, Method::None) => EmitStyle::Native,
            (false, None, _) => EmitStyle::Lines,
            (false, Some(e), _) => e,
        };
        let wopts = self.rewrite_options(name, &shares, rule, emit);
        let write = |tp: &Toolpath| {
            crate::write::rewrite::rewrite(src, program, tp, &wopts)
                .map_err(|e| JobError::Write(e.to_string()))
        };
        // The program's index for the check is built while the output is written.
        let (index, gcode) = ncsmooth::par::join(
            || ProgramIndex::new(&program.toolpath, accuracy),
            || write(&curves.toolpath),
        );
        let gcode = gcode?;
        t.write_s = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let looped = match loop_size {
            Some(size) => Some((size, write(&without_loops(&curves.toolpath))?)),
            None => None,
        };
        let checked = self.check(name, src, program, index, curves, &gcode, &shares, looped)?;
        t.verify_s = t0.elapsed().as_secs_f64();
        let report = self.report(name, program, curves, &shares, emit, checked, t);
        let loop_size_mm = match self.smooth.trig.corner {
            CornerStyle::Loop { loop_size_mm } if self.smooth.method == Method::Trig => {
                Some(loop_size_mm)
            }
            _ => None,
        };
        Ok(SmoothedGcode {
            gcode,
            report,
            loop_size_mm,
        })
    }

    /// The method's options for the curve tolerance, and the loop size the loops are
    /// built to in loop mode.
    fn curve_options(&self, s: &Shares) -> Result<(SmoothOptions, Option<f64>), JobError> {
        let mut opts = self.smooth.clone().with_tol_mm(s.curve_tol);
        if s.blend.is_some() {
            // LinuxCNC's blends follow the written curve's own radius: the run fit is run to
            // its minimum (ncsmooth::smooth::band_fit::BandFitOptions::converged).
            let converged = BandFitOptions::converged();
            opts.run.fit.min_knot_span_mm = converged.min_knot_span_mm;
            opts.run.fit.energy_settle_share = converged.energy_settle_share;
        }
        // Loops are built to the loop size less the rounding: flattening only cuts chords
        // inside a loop (its excursion from the corner cannot grow), rounding moves points.
        let loop_size = match (self.smooth.method, opts.trig.corner) {
            (Method::Trig, CornerStyle::Loop { loop_size_mm }) => {
                let build = loop_size_mm - s.rounding;
                if build <= loop_size_mm * MIN_CURVE_TOL_SHARE || build.is_nan() {
                    return Err(JobError::BadInput(format!(
                        "--loop-size {loop_size_mm:?} mm is too small for {} decimals, \
                         which round coordinates by up to {:.3e} mm; use more --decimals",
                        self.decimals, s.rounding
                    )));
                }
                opts.trig.corner = CornerStyle::Loop {
                    loop_size_mm: build,
                };
                Some(build)
            }
            _ => None,
        };
        Ok((opts, loop_size))
    }
}

/// How the controller runs arcs: the dialect's rule, with the firmware's setting
/// where one is given (an input error where the dialect runs circles or the length
/// is not one).
fn arc_chords(job: &SmoothJob) -> Result<ArcChords, JobError> {
    let rule = job.dialect.arc_chords();
    let Some(mm) = job.arc_segment_mm else {
        return Ok(rule);
    };
    if !(mm > 0.0 && mm <= ARC_SEGMENT_MAX_MM) {
        return Err(JobError::BadInput(format!(
            "--arc-segment must be a length in (0, {ARC_SEGMENT_MAX_MM}] mm, got {mm}"
        )));
    }
    rule.with_segment_mm(mm).ok_or_else(|| {
        JobError::BadInput(format!(
            "--arc-segment: {} runs arcs as circles, it has no arc segment setting",
            job.dialect.name()
        ))
    })
}

/// The tolerance's shares for one build (lengths in mm).
struct Shares {
    tol: f64,
    chord: f64,
    rounding: f64,
    /// LinuxCNC's `G64 P Q` of the smoothed runs.
    blend: Option<Blend>,
    /// LinuxCNC's `G64 P` of the program's own motion copied verbatim.
    verbatim_blend: Option<Blend>,
    /// `P + Q`, 0 without blending.
    blend_mm: f64,
    budget: Budget,
    curve_tol: f64,
    compress: bool,
    /// How the controller runs arcs (the dialect's rule, the firmware's setting given).
    arc_chords: ArcChords,
}

impl Shares {
    fn of(job: &SmoothJob, program: &Program, rule: BudgetRule) -> Result<Shares, JobError> {
        let (tol, dialect, compress) = (job.tol_mm, job.dialect, job.compresses());
        // (Rounding depends on the program's units and the decimals only.)
        let rounding = Budget::new(program, tol, tol * 0.5, job.decimals, 0.0).rounding_mm;
        let chord = job.chord_mm.unwrap_or(if compress && !dialect.blends() {
            (tol * COMPRESS_EXACT_CHORD_SHARE).min(tol - 2.0 * rounding)
        } else if compress {
            tol * COMPRESS_CHORD_SHARE
        } else if dialect.block_floor_mm().is_some() {
            tol * STEPPER_CHORD_SHARE
        } else if dialect == crate::Dialect::LinuxCnc {
            tol * LINUXCNC_CHORD_SHARE
        } else {
            tol * DEFAULT_CHORD_SHARE
        });
        if !(tol > 0.0 && tol <= TOL_MAX_MM) {
            return Err(JobError::BadInput(format!(
                "--tol must be a length in (0, {TOL_MAX_MM}] mm, got {tol}"
            )));
        }
        if !(chord > 0.0 && chord < tol) {
            return Err(JobError::BadInput(format!(
                "--chord must be in (0, tol), got {chord}"
            )));
        }
        let arc_chords = arc_chords(job)?;
        // Inch programs are written in inches: their rounding applies where they are.
        // `none` builds no curves, but rounding still moves its points and off-plane arcs
        // are still flattened: the same budget applies.
        let blend = Self::blend(job, compress)?;
        let blend_mm = blend.map_or(0.0, |b| b.p_mm + b.q_mm);
        // The program's own rapids copied verbatim deviate by LinuxCNC's blending alone.
        let verbatim_blend = blend.map(|_| Blend {
            p_mm: tol * VERBATIM_BLEND_SHARE,
            q_mm: 0.0,
        });
        let budget = Budget::new(program, tol, chord, job.decimals, blend_mm);
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
            return Err(JobError::BadInput(format!(
                "--tol {tol:?} mm leaves too little room: the flattening chord takes {chord:?} mm, \
                 the controller's blending {blend_mm:?} mm \
                 and {} decimals round coordinates by up to {rounding:.3e} mm; \
                 use a larger --tol, a smaller --chord or more --decimals",
                job.decimals
            )));
        }
        Ok(Shares {
            tol,
            chord,
            rounding,
            blend,
            verbatim_blend,
            blend_mm,
            budget,
            curve_tol,
            compress,
            arc_chords,
        })
    }

    /// LinuxCNC blends between the written blocks: `G64 P<share of tol> Q0` keeps its
    /// blend arcs no tighter than the chords themselves (a blend at a chord junction
    /// turning by `theta` has radius about `8 P / theta^2`, the curve `8 chord / theta^2`)
    /// and is paid from the tolerance.
    fn blend(job: &SmoothJob, compress: bool) -> Result<Option<Blend>, JobError> {
        let tol = job.tol_mm;
        let blend = job.dialect.blends().then_some(Blend {
            p_mm: job.g64_p_mm.unwrap_or(
                tol * if compress {
                    COMPRESS_BLEND_SHARE
                } else {
                    BLEND_SHARE
                },
            ),
            q_mm: job.g64_q_mm.unwrap_or(0.0),
        });
        if let Some(b) = blend {
            if !(b.p_mm > 0.0 && b.p_mm < tol && b.q_mm >= 0.0 && b.q_mm < tol) {
                return Err(JobError::BadInput(format!(
                    "--g64-p must be in (0, tol) and --g64-q in [0, tol), got {} and {}",
                    b.p_mm, b.q_mm
                )));
            }
        }
        Ok(blend)
    }
}

/// What the read-back measured.
struct Checked {
    dev: Deviation,
    loops: Option<LoopCheck>,
    /// The loops are within the size they were built to (true without loops).
    loops_ok: bool,
    executed: Option<Executed>,
    kept: Kept,
}

/// What the written program keeps of the input (measured beside the deviation).
struct Kept {
    blocks: BlockReport,
    extra_axes_mismatch: Option<ExtraAxesMismatch>,
    block_values_mismatch: Option<BlockValueMismatch>,
    extrusion_along_path: Option<ExtrusionAlongPath>,
    continuity: Continuity,
    input_continuity: Continuity,
}

impl Kept {
    fn of(
        src: &[u8],
        program: &Program,
        curves: &Curves,
        gcode: &[u8],
        as_written: &Toolpath,
        s: &Shares,
        dialect: Dialect,
    ) -> Kept {
        let tp = &program.toolpath;
        Kept {
            blocks: BlockReport::of(src, tp, gcode, as_written, dialect),
            extra_axes_mismatch: ncsmooth::verify::extra_axes_kept(tp, as_written, s.rounding),
            block_values_mismatch: ncsmooth::verify::block_values_kept(tp, as_written, s.rounding),
            extrusion_along_path: ncsmooth::verify::extrusion_along_path(tp, as_written, s.tol),
            continuity: continuity(&curves.toolpath),
            input_continuity: continuity(tp),
        }
    }
}

impl SmoothJob {
    /// How the smoothed path is written into the program for this controller.
    fn rewrite_options(
        &self,
        name: &str,
        s: &Shares,
        rule: BudgetRule,
        emit: EmitStyle,
    ) -> RewriteOptions {
        let (tol, dialect, method) = (self.tol_mm, self.dialect, self.smooth.method);
        // A stepper controller is given no block of a step or two: the program's own G1
        // lines between the smoothed ones go through the long-lines emitter too, where its
        // short blocks are lifted (a copied line is never lifted).
        let floor = dialect.block_floor_mm().is_some()
            && matches!(emit, EmitStyle::Lines | EmitStyle::G5 | EmitStyle::Nurbs);
        let (min_block_mm, min_block_s) = (dialect.min_block_mm(0.0), dialect.min_block_s());
        RewriteOptions::new(self.decimals.min(crate::numbers::MAX_DECIMALS), s.chord)
            .with_header(format!(
                "ncsmooth {} --method {} --tol {tol} --dialect {}{} (from {name})",
                env!("CARGO_PKG_VERSION"),
                method.name(),
                dialect.name(),
                self.arc_segment_mm
                    .map_or(String::new(), |mm| format!(" --arc-segment {mm}"))
            ))
            .for_dialect(dialect, s.blend)
            .with_arc_chords(s.arc_chords)
            .with_verbatim_blend(s.verbatim_blend)
            .with_blend_limits(self.acc_mm_s2, self.feed_mm_s)
            .with_even_out(matches!(rule, BudgetRule::Executed { even_out: true, .. }))
            .with_emit(match emit {
                EmitStyle::Native => Emit::Native,
                EmitStyle::Arcs => Emit::Arcs,
                EmitStyle::Nurbs if dialect.has_nurbs() => Emit::Nurbs {
                    min_block_mm,
                    min_block_s,
                },
                EmitStyle::G5 | EmitStyle::Nurbs if dialect.has_g5() => Emit::G5 {
                    min_block_mm,
                    min_block_s,
                },
                EmitStyle::Lines | EmitStyle::G5 | EmitStyle::Nurbs => Emit::Lines {
                    min_block_mm,
                    min_block_s,
                },
            })
            .with_rewrite_unchanged(s.compress || (floor && method != Method::None))
            .with_block_floor(self.block_floor(s, rule, emit))
    }

    /// The shortest block written: a stepper's floor; for LinuxCNC, where the model of its
    /// executed path checks the build and the schedule sizes the blends, a block shorter
    /// than four `P` caps its blends at a quarter of its length, so the programmed corner
    /// is written instead, blended within a `P` of its own. A `Q` is not modelled: no
    /// corner then.
    fn block_floor(&self, s: &Shares, rule: BudgetRule, emit: EmitStyle) -> Option<BlockFloor> {
        let tol = s.tol;
        if let Some(m) = self.dialect.block_floor_mm() {
            return Some(BlockFloor {
                min_block_mm: m,
                tol_mm: tol - s.rounding - s.blend_mm,
                corner: None,
            });
        }
        match (rule, s.blend, s.verbatim_blend, self.acc_mm_s2, emit) {
            (BudgetRule::Executed { less_mm, .. }, Some(b), Some(v), Some(_), EmitStyle::Lines)
                if b.q_mm == 0.0 =>
            {
                Some(BlockFloor {
                    min_block_mm: LINUXCNC_CORNER_FLOOR_P * b.p_mm,
                    tol_mm: tol - s.rounding - s.blend_mm,
                    corner: Some(CornerBlend {
                        // The blends at raised points leave the same share to whoever
                        // measures them from servo samples as the verbatim motion's.
                        total_mm: tol * VERBATIM_BLEND_SHARE - s.rounding - less_mm,
                        max_p_mm: v.p_mm,
                    }),
                })
            }
            _ => None,
        }
    }

    /// The written text read back and measured: rounding and the reader's own arc
    /// reconstruction are part of what the machine will run. In loop mode (`looped`: the
    /// loop size and the same text written without the loops) the loops are measured by
    /// their own bound, and the two-sided tolerance on the text without them.
    #[allow(clippy::too_many_arguments)]
    fn check(
        &self,
        name: &str,
        src: &[u8],
        program: &Program,
        index: ProgramIndex,
        curves: &Curves,
        gcode: &[u8],
        s: &Shares,
        looped: Option<(f64, Vec<u8>)>,
    ) -> Result<Checked, JobError> {
        let unreadable = |e: crate::ParseError| JobError::ReadBack(e.to_string());
        let opts = &self.read;
        let loops = looped
            .as_ref()
            .map(|(size, _)| check_loops(&curves.toolpath, &program.toolpath, *size));
        // Read once: the path for the checks, the program for LinuxCNC's executed path.
        let written = crate::parse_bytes(gcode, name, opts).map_err(unreadable)?;
        let as_written = &written.toolpath;
        // In loop mode the deviation is measured on the text without the loops.
        let without_loops = match &looped {
            Some((_, text)) => Some(read_written_with(text, name, opts).map_err(unreadable)?),
            None => None,
        };
        let measured = without_loops.as_ref().unwrap_or(as_written);
        // The deviation beside the checks of what the output keeps.
        let (dev, kept) = ncsmooth::par::join(
            || index.into_deviation(measured),
            || Kept::of(src, program, curves, gcode, as_written, s, self.dialect),
        );
        let executed = match (s.blend, looped.is_some()) {
            (Some(b), false) => {
                let cap = s.verbatim_blend.map_or(b.p_mm, |v| v.p_mm.max(b.p_mm));
                Some(crate::controller::linuxcnc::executed::linuxcnc_executed(
                    &written,
                    &program.toolpath,
                    &dev,
                    cap,
                    s.blend_mm,
                    s.tol * EXECUTED_ACCURACY_SHARE,
                ))
            }
            _ => None,
        };
        let loops_ok = match (&loops, &looped) {
            (Some(l), Some((size, _))) => l.within(*size),
            _ => true,
        };
        Ok(Checked {
            dev,
            loops,
            loops_ok,
            executed,
            kept,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn report(
        &self,
        name: &str,
        program: &Program,
        curves: &Curves,
        s: &Shares,
        emit: EmitStyle,
        c: Checked,
        timings: Timings,
    ) -> SmoothRunReport {
        let Checked {
            dev,
            loops,
            loops_ok,
            executed,
            kept,
        } = c;
        let Kept {
            blocks,
            extra_axes_mismatch,
            block_values_mismatch,
            extrusion_along_path,
            continuity,
            input_continuity,
        } = kept;
        let within_tol = loops_ok
            && match executed {
                // The model of what LinuxCNC runs, where it applies, whichever the budget.
                Some(e) => dev.within(s.tol) && e.max_mm() <= s.tol,
                None => s.budget.holds(&dev),
            };
        SmoothRunReport {
            input: name.to_string(),
            units_assumed: program
                .stats
                .units_assumed
                .map(|line| (self.read.default_units, line)),
            tol_mm: s.tol,
            curve_tol_mm: s.curve_tol,
            chord_mm: s.chord,
            rounding_mm: s.rounding,
            dialect: self.dialect.name(),
            emit,
            arc_chords: s.arc_chords,
            blend: s.blend.map(|b| blend_report(b, s, &dev, executed.as_ref())),
            blocks,
            smoothing: curves.report.clone(),
            within_tol,
            deviation: dev,
            extra_axes_mismatch,
            block_values_mismatch,
            extrusion_along_path,
            loops,
            continuity,
            input_continuity,
            timings,
        }
    }
}

/// LinuxCNC's blending bounds, and the bound on the path it executes: the model's where it
/// applies, else the written deviation plus `P + Q` (or the verbatim motion's `P`).
fn blend_report(b: Blend, s: &Shares, dev: &Deviation, executed: Option<&Executed>) -> BlendReport {
    let verbatim = s.verbatim_blend;
    BlendReport {
        p_mm: b.p_mm,
        q_mm: b.q_mm,
        verbatim_p_mm: verbatim.map_or(b.p_mm, |v| v.p_mm),
        executed_bound_mm: executed.map_or_else(
            || (dev.max_mm() + s.blend_mm).max(verbatim.map_or(0.0, |v| v.p_mm + v.q_mm)),
            |e| e.max_mm(),
        ),
        executed_model_mm: executed.map_or(f64::NAN, |e| e.max_mm()),
        blends_modelled: executed.map_or(0, |e| e.blends_modelled),
        blends_counted: executed.map_or(0, |e| e.blends_counted),
    }
}

impl SmoothedGcode {
    /// `Ok` when the written program, read back, is within the tolerance (the model of the
    /// controller's executed path included), its loops within their size and its extra
    /// axes where the program has them; else the [`JobError::Verification`] saying where.
    /// A job's own construction should always pass: an error here is a bug of ours.
    pub fn verified(&self) -> Result<(), JobError> {
        let r = &self.report;
        if let (Some(l), Some(size)) = (&r.loops, self.loop_size_mm) {
            if !l.within(size - r.rounding_mm) {
                return Err(JobError::Verification(format!(
                    "loops pass their corners within {:.3e} mm and reach {:.9e} mm, plus up to {:.3e} mm of rounding (loop size {size:?} mm); nothing written",
                    l.max_corner_miss_mm, l.max_excursion_mm, r.rounding_mm
                )));
            }
        }
        if let Some(m) = r.extra_axes_mismatch {
            return Err(JobError::Verification(format!(
                "axis {} is at {} in the written program where the program has {} (before line {}, 0: at the end); nothing written",
                ncsmooth::path::EXTRA_AXIS_NAMES[m.axis],
                m.written,
                m.program,
                m.line
            )));
        }
        if let Some(m) = r.block_values_mismatch {
            return Err(JobError::Verification(format!(
                "the written program sets S{} where the program sets S{} (line {}, 0: none there), {:e} mm from where the program sets it; nothing written",
                m.written, m.program, m.line, m.offset_mm
            )));
        }
        if !r.within_tol {
            let blend = r.blend.map_or(0.0, |b| b.p_mm + b.q_mm);
            return Err(JobError::Verification(format!(
                "deviation {:.6} mm (output to program, line {}) / {:.6} mm (vertex to output, line {}) plus {blend:?} mm of controller blending exceeds tol {:?} mm; nothing written",
                r.deviation.output_to_programmed_mm,
                r.deviation.output_line,
                r.deviation.vertex_to_output_mm,
                r.deviation.vertex_line,
                r.tol_mm
            )));
        }
        Ok(())
    }
}

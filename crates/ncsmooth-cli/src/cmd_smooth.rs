//! `ncsmooth smooth`: the arguments of a [`ncsmooth_gcode::SmoothJob`] (smooth a program
//! within a two-sided tolerance, write it for a controller, verify the written text), its
//! messages and its files (G-code and an optional JSON report), written all or nothing.

use crate::table_arg::{DialectArg, MethodArg};
use crate::{io, load, Ui};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use ncsmooth::smooth::band_time::{TimeLimits, TimeShapeOptions};
use ncsmooth::smooth::trig_corner::CornerStyle;
use ncsmooth::smooth::{Method, SmoothOptions};
use ncsmooth_gcode::{Dialect, EmitStyle, JobError, SmoothJob};
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// `FILTER_PROGRESS` (percent) once the program is parsed: parsing is about a fifth of a
/// run, smoothing, writing and verifying the rest.
const FILTER_PROGRESS_PARSED: u32 = 20;
/// `FILTER_PROGRESS` once the written program is verified, before it goes out.
const FILTER_PROGRESS_VERIFIED: u32 = 95;
/// Largest `--decimals`.
const MAX_DECIMALS: usize = ncsmooth_gcode::MAX_DECIMALS;

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
    /// The firmware's arc setting (mm) where it is not the dialect's default: grbl's `$12`
    /// (0.002), Marlin's `MAX_ARC_SEGMENT_MM` (1), Klipper's `[gcode_arcs] resolution`
    /// (1). An arc is written only where the chords the firmware cuts it into fit the
    /// budget (docs/controllers.md). Not for `linuxcnc` and `generic`, which run arcs as
    /// circles.
    #[arg(long, value_name = "MM")]
    pub arc_segment: Option<f64>,
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

/// Emitter names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
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

impl From<EmitArg> for EmitStyle {
    fn from(e: EmitArg) -> EmitStyle {
        match e {
            EmitArg::Lines => EmitStyle::Lines,
            EmitArg::Arcs => EmitStyle::Arcs,
            EmitArg::G5 => EmitStyle::G5,
            EmitArg::Nurbs => EmitStyle::Nurbs,
            EmitArg::Native => EmitStyle::Native,
        }
    }
}

/// A job's error for the CLI: the input's are bad input (exit 2), the rest ours (exit 1).
pub fn job_error(e: JobError) -> anyhow::Error {
    if e.is_bad_input() {
        io::BadInput(e.to_string()).into()
    } else {
        e.into()
    }
}

/// `v` (mm) rounded to the nanometre, so that a share of the tolerance prints as the
/// length it is (`0.08`, not `0.08000000000000002`).
fn to_nm(v: f64) -> f64 {
    const NM_PER_MM: f64 = 1e6;
    (v * NM_PER_MM).round() / NM_PER_MM
}

impl SmoothArgs {
    /// The smoothing options these arguments ask for (tolerance set later).
    pub fn options(&self) -> Result<SmoothOptions> {
        let mut o = SmoothOptions::default()
            .with_method(self.method.into())
            .with_straight_angle_deg(self.straight_angle);
        if self.corner == CornerArg::Loop {
            if self.method.0 != Method::Trig {
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

    /// The job these arguments ask for, reading as the CLI reads.
    pub fn job(&self) -> Result<SmoothJob> {
        let mut job = SmoothJob::new(self.method.into(), self.tol)
            .with_smooth_options(self.options()?)
            .with_decimals(usize::from(self.decimals))
            .with_dialect(self.dialect.into())
            .with_g64(self.g64_p, self.g64_q)
            .with_machine(self.acc, self.feed)
            .with_read_options(crate::parse_options().clone());
        job.chord_mm = self.chord;
        job.arc_segment_mm = self.arc_segment;
        job.emit = self.emit.map(EmitStyle::from);
        Ok(job)
    }
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
    let filter = a.output.as_os_str() == "-" && a.dialect.0 == Dialect::LinuxCnc && !ui.quiet;
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
    let job = a.job()?;
    let mut out = job.run(name, &loaded.src, program).map_err(job_error)?;
    out.report.timings.parse_s = parse_s;
    out.verified()?;
    let r = &out.report;
    progress(FILTER_PROGRESS_VERIFIED);
    let json = serde_json::to_string_pretty(r)?;
    write_outputs(&[
        (Some(&a.output), &out.gcode[..]),
        (a.report.as_ref(), json.as_bytes()),
    ])?;
    summary(ui, &a, name, r, t0, progress);
    Ok(())
}

/// The run's two status lines (and a warning on long lines) on stderr.
fn summary(
    ui: Ui,
    a: &SmoothArgs,
    name: &str,
    r: &ncsmooth_gcode::SmoothRunReport,
    t0: Instant,
    progress: impl Fn(u32),
) {
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
}

//! What a program contains: counts by code, units and planes, geometry statistics, what
//! ncsmooth cannot place or never writes, and the parser's warnings
//! (`ncsmooth inspect`). A file is read block by block, in memory that does not grow with
//! it ([`InspectReport::read`]).

use crate::stream::MAX_KEPT_WARNINGS;
use crate::{BlockReader, ParseError, ParseOptions, ParseStats, Program};
use ncsmooth::{PathStats, PathStatsBuilder};
use serde::Serialize;
use std::path::Path;

/// What a program contains.
#[derive(Serialize, Debug)]
pub struct InspectReport {
    /// Input name.
    pub file: String,
    /// Bytes read.
    pub bytes: usize,
    /// Physical lines.
    pub lines: usize,
    /// Units seen, in order (all geometry below is in mm).
    pub units_seen: Vec<String>,
    /// Arc planes seen, in order.
    pub planes_seen: Vec<String>,
    /// Motion blocks by G code as programmed.
    pub moves_by_code: MovesByCode,
    /// Geometry statistics (mm, degrees).
    pub path: PathStats,
    /// Motions ncsmooth cannot place in the work frame (G53, G28/G30, moves from a
    /// position the program has not established): written as programmed, not planned.
    pub untracked_motions: usize,
    /// Line and reason of the first of them.
    pub first_untracked: Option<String>,
    /// X Y Z axes the program never establishes (never written by ncsmooth).
    pub axes_never_known: Vec<char>,
    /// Lines whose motion smoothing may replace (executed once at the top level, nothing
    /// but motion words); every other line is written back verbatim.
    pub replaceable_lines: usize,
    /// Parser warnings (the first `MAX_KEPT_WARNINGS`).
    pub warnings: Vec<String>,
    /// Warnings beyond those listed, counted only.
    pub warnings_not_listed: usize,
}

/// Motion counts by programmed code.
#[derive(Serialize, Debug)]
pub struct MovesByCode {
    /// G0.
    pub g0: usize,
    /// G1.
    pub g1: usize,
    /// G2.
    pub g2: usize,
    /// G3.
    pub g3: usize,
}

impl InspectReport {
    /// The report of a parsed program.
    pub fn of(name: &str, p: &Program) -> InspectReport {
        report_of(name, &p.stats, PathStats::of(&p.toolpath), 0)
    }

    /// The report of the file at `path` (named `name`), read block by block
    /// ([`BlockReader`]) with `opts`: memory does not grow with the file.
    pub fn read(path: &Path, name: &str, opts: &ParseOptions) -> Result<InspectReport, ParseError> {
        let mut reader = BlockReader::open(path, name, opts)?;
        let mut stats = PathStatsBuilder::new();
        let mut blocks = Vec::new();
        loop {
            let more = reader.read_blocks(&mut blocks, READ_BATCH_BLOCKS)?;
            for b in blocks.drain(..) {
                stats.push(&b);
            }
            if !more {
                break;
            }
        }
        Ok(report_of(
            name,
            reader.stats(),
            stats.finish(),
            reader.warnings_dropped(),
        ))
    }

    /// The report as text, for people.
    pub fn text(&self) -> String {
        render_text(self)
    }
}

/// Blocks `inspect` asks the reader for at a time.
const READ_BATCH_BLOCKS: usize = 4096;

/// The report from the reader's counts and the path's statistics; at most
/// [`MAX_KEPT_WARNINGS`] warnings are listed, the others counted.
fn report_of(name: &str, s: &ParseStats, path: PathStats, dropped: usize) -> InspectReport {
    let kept = s.warnings.len().min(MAX_KEPT_WARNINGS);
    InspectReport {
        file: name.to_string(),
        bytes: s.bytes,
        lines: s.lines,
        units_seen: s.units_seen.iter().map(|u| format!("{u:?}")).collect(),
        planes_seen: s.planes_seen.iter().map(|p| format!("{p:?}")).collect(),
        moves_by_code: MovesByCode {
            g0: s.g0,
            g1: s.g1,
            g2: s.g2,
            g3: s.g3,
        },
        path,
        untracked_motions: s.untracked,
        first_untracked: s
            .untracked_first
            .as_ref()
            .map(|(line, why)| format!("line {line}: {why}")),
        axes_never_known: ['X', 'Y', 'Z']
            .into_iter()
            .enumerate()
            .filter(|(i, _)| s.axes_known & (1 << i) == 0)
            .map(|(_, c)| c)
            .collect(),
        replaceable_lines: s.replaceable_lines,
        warnings: s.warnings[..kept].iter().map(|w| w.to_string()).collect(),
        warnings_not_listed: s.warnings.len() - kept + dropped,
    }
}

/// Human-readable rendering.
fn render_text(r: &InspectReport) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    let p = &r.path;
    let _ = writeln!(o, "{}: {} bytes, {} lines", r.file, r.bytes, r.lines);
    let _ = writeln!(
        o,
        "units: {} (geometry below in mm; written back in the program's units)   planes: {}",
        r.units_seen.join(", "),
        r.planes_seen.join(", ")
    );
    let m = &r.moves_by_code;
    let _ = writeln!(
        o,
        "moves: G0 {}  G1 {}  G2 {}  G3 {}  events {}",
        m.g0, m.g1, m.g2, m.g3, p.events
    );
    let _ = writeln!(
        o,
        "lengths: feed {:.3} mm, rapid {:.3} mm, zero-length feed moves {}",
        p.feed_length_mm, p.rapid_length_mm, p.zero_length_moves
    );
    let l = &p.feed_segment_length_mm;
    let _ = writeln!(
        o,
        "feed segment length (mm): min {:.6}  p10 {:.6}  median {:.6}  p90 {:.6}  max {:.6}",
        l.min, l.p10, l.median, l.p90, l.max
    );
    let _ = writeln!(o, "corner angles (deg):");
    for b in &p.corner_angles {
        let _ = writeln!(o, "  [{:>6.2}, {:>6.2})  {}", b.from_deg, b.to_deg, b.count);
    }
    let _ = writeln!(
        o,
        "rewritable lines: {} of {} (the others are written back verbatim)",
        r.replaceable_lines, r.lines
    );
    if r.untracked_motions > 0 {
        let _ = writeln!(
            o,
            "untracked motions: {} (written as programmed, not planned; first: {})",
            r.untracked_motions,
            r.first_untracked.as_deref().unwrap_or("-")
        );
    }
    if !r.axes_never_known.is_empty() {
        let names: String = r.axes_never_known.iter().collect();
        let _ = writeln!(
            o,
            "axes never established: {names} (never written; at 0 in geometry and setpoints)"
        );
    }
    if let Some(b) = p.bbox {
        let _ = writeln!(
            o,
            "bounding box (mm): X {:.4} .. {:.4}  Y {:.4} .. {:.4}  Z {:.4} .. {:.4}",
            b.min.x, b.max.x, b.min.y, b.max.y, b.min.z, b.max.z
        );
    }
    if !r.warnings.is_empty() {
        let total = r.warnings.len() + r.warnings_not_listed;
        let _ = writeln!(o, "warnings: {total}");
        for w in r.warnings.iter().take(20) {
            let _ = writeln!(o, "  {w}");
        }
        if total > 20 {
            let _ = writeln!(o, "  ... {} more", total - 20);
        }
    }
    o
}

//! A G-code file read and interpreted block by block, in memory that does not grow with
//! the program: for planning programs of any size (CAM output for 3-D surfacing reaches
//! hundreds of megabytes).
//!
//! [`BlockReader`] gives the same blocks as [`crate::parse_bytes`], in order, a batch at a
//! time, while it holds only the current line, the program's O-word lines (control flow
//! jumps to them, so their offsets are indexed in a first pass over the file) and the
//! blocks not yet handed out. It keeps no [`crate::SourceMap`] (nothing to rewrite) and no
//! canonical commands.
//!
//! Two things about a program are known only at its end, and a reader must know them
//! before the first block: the extra axes it uses (the setpoint file's columns) and
//! whether its main program ends with `M99` (then every move is written as programmed,
//! see [`crate::interpreter`]). When the first pass finds a word that may be either (an A B C
//! U V W or E word, or `M99`), the program is interpreted once more beforehand, without
//! keeping its blocks, to learn them; most milling programs need no such pass.
//!
//! Where it differs from [`crate::parse_bytes`], by construction and documented:
//! * a `G5` without `I J` long after the `G5` whose `P Q` it reuses (more than
//!   `G5_RETAIN_BLOCKS` blocks later) cannot pin that earlier `G5` any more: it was
//!   handed out already;
//! * at most `MAX_KEPT_WARNINGS` warnings are kept; the others are counted
//!   ([`BlockReader::warnings_dropped`]).

use crate::error::{ParseError, ParseErrorKind};
use crate::interpreter::program::{ParseOptions, ParseStats};
use crate::interpreter::text::{FileText, Text};
use crate::interpreter::Interp;
use ncsmooth::geom::{ParamCurve, Vec3};
use ncsmooth::path::{Block, Units};
use std::fs::File;
use std::path::Path;

/// Blocks a `G5` stays in the reader's buffer for a later `G5` without `I J` to pin it.
pub(crate) const G5_RETAIN_BLOCKS: usize = 4096;
/// Warnings kept; later ones are only counted.
pub(crate) const MAX_KEPT_WARNINGS: usize = 1000;

/// A G-code file read block by block (see the module doc).
///
/// ```
/// # let dir = std::env::temp_dir().join(format!("ncsmooth-doc-{}", std::process::id()));
/// # std::fs::create_dir_all(&dir).unwrap();
/// # let path = dir.join("p.ngc");
/// std::fs::write(&path, "G21 G90\nG0 X0 Y0 Z1\nG1 Z0 F600\nG1 X10\nG1 Y10\nM2\n").unwrap();
/// let opts = ncsmooth_gcode::ParseOptions::default();
/// let mut reader = ncsmooth_gcode::BlockReader::open(&path, "p.ngc", &opts).unwrap();
/// let mut blocks = Vec::new();
/// while reader.read_blocks(&mut blocks, 2).unwrap() {}
/// // The first rapid starts where the machine happens to be (unknown): it is written as
/// // programmed and is not a move; the three feed moves are.
/// assert_eq!(blocks.iter().filter(|b| matches!(b, ncsmooth::Block::Move(_))).count(), 3);
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub struct BlockReader<'o> {
    interp: Interp<'o>,
    /// The program's extra axes, from the whole program.
    extra_axes_mask: u8,
    /// Start of the first move handed out.
    start: Option<Vec3>,
    /// The interpreter has run its last line (and its closing checks).
    finished: bool,
    warnings_dropped: usize,
}

impl<'o> BlockReader<'o> {
    /// Opens `path` (named `file_name` in errors) and reads it once to index its control
    /// flow (and, when needed, once more to learn its extra axes and how it ends).
    /// Errors: the file cannot be read, or it is not G-code text (located, like every
    /// later error).
    pub fn open(
        path: &Path,
        file_name: &'o str,
        opts: &'o ParseOptions,
    ) -> Result<BlockReader<'o>, ParseError> {
        let open = || -> Result<Interp<'o>, ParseError> {
            let f = File::open(path).map_err(|e| io_error(file_name, &e))?;
            let bytes = f.metadata().map(|m| m.len() as usize).unwrap_or(0);
            let mut it = Interp::new(Text::File(FileText::open(f)), file_name, opts);
            it.canon = None;
            it.stats.bytes = bytes;
            it.begin(None)?;
            Ok(it)
        };
        let mut interp = open()?;
        let (mut mask, mut m99) = (0, false);
        if interp.scan.maybe_extra_or_m99 {
            let mut first = open()?;
            while first.step()? {
                first.tp.blocks.clear();
                first.stats.warnings.clear();
            }
            first.finish()?;
            mask = first.tp.extra_axes_mask;
            m99 = first.main_m99;
        }
        interp.pin_everything = m99;
        Ok(BlockReader {
            interp,
            extra_axes_mask: mask,
            start: None,
            finished: false,
            warnings_dropped: 0,
        })
    }

    /// Interprets lines until at least `min` blocks are ready (or the program ends), and
    /// moves the ready ones to the end of `out`. Returns false once the program has ended
    /// and every block has been handed out.
    pub fn read_blocks(&mut self, out: &mut Vec<Block>, min: usize) -> Result<bool, ParseError> {
        while !self.finished && self.interp.tp.blocks.len() < min + self.retained() {
            let it = &mut self.interp;
            if !it.step()? {
                it.finish()?;
                self.finished = true;
            }
            let w = &mut it.stats.warnings;
            if w.len() > MAX_KEPT_WARNINGS {
                self.warnings_dropped += w.len() - MAX_KEPT_WARNINGS;
                w.truncate(MAX_KEPT_WARNINGS);
            }
        }
        let n = if self.finished {
            self.interp.tp.blocks.len()
        } else {
            self.interp.tp.blocks.len() - self.retained()
        };
        self.hand_out(n, out);
        Ok(!(self.finished && self.interp.tp.blocks.is_empty()))
    }

    /// Blocks at the end of the buffer a later line may still change: from the last move
    /// (an O-word statement pins it) and from a recent `G5` (a `G5` without `I J` pins it).
    fn retained(&self) -> usize {
        let it = &self.interp;
        let blocks = &it.tp.blocks;
        let last_move = blocks
            .iter()
            .rposition(|b| matches!(b, Block::Move(_)))
            .unwrap_or(blocks.len());
        let from = match it.m.last_g5 {
            Some(k) if k + G5_RETAIN_BLOCKS >= blocks.len() => k.min(last_move),
            _ => last_move,
        };
        blocks.len() - from
    }

    fn hand_out(&mut self, n: usize, out: &mut Vec<Block>) {
        if n == 0 {
            return;
        }
        let it = &mut self.interp;
        if self.start.is_none() {
            self.start = it.tp.blocks[..n].iter().find_map(|b| match b {
                Block::Move(m) => Some(m.segment.start()),
                Block::Event(_) => None,
            });
        }
        out.extend(it.tp.blocks.drain(..n));
        it.drained += n;
        it.m.last_g5 = it.m.last_g5.and_then(|k| k.checked_sub(n));
    }

    /// Counts and the warnings kept so far (complete once [`Self::read_blocks`] returned
    /// false).
    pub fn stats(&self) -> &ParseStats {
        &self.interp.stats
    }

    /// Warnings beyond `MAX_KEPT_WARNINGS`, counted only.
    pub fn warnings_dropped(&self) -> usize {
        self.warnings_dropped
    }

    /// Bit mask of the extra axes the whole program uses
    /// ([`ncsmooth::path::EXTRA_AXIS_NAMES`]), known from the start.
    pub fn extra_axes_mask(&self) -> u8 {
        self.extra_axes_mask | self.interp.tp.extra_axes_mask
    }

    /// Units of the program (the first selected, else the default units), as
    /// [`ncsmooth::Toolpath::units`] of [`crate::parse_bytes`] (final once read).
    pub fn units(&self) -> Units {
        self.interp
            .stats
            .units_seen
            .first()
            .copied()
            .unwrap_or(self.interp.opts.default_units)
    }

    /// Start of the program's first move, once it has been handed out.
    pub fn start(&self) -> Option<Vec3> {
        self.start
    }
}

fn io_error(file_name: &str, e: &std::io::Error) -> ParseError {
    ParseError {
        file: file_name.to_string(),
        line: 1,
        column: 1,
        byte_range: 0..0,
        kind: ParseErrorKind::Io { why: e.to_string() },
    }
}

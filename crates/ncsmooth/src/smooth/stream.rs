//! Smoothing a program that arrives block by block, in windows of bounded size
//! ([`StreamSmoother`]), for programs too large to hold: what [`super::smooth`] does to a
//! whole program, chain by chain, with a cap on the length of a chain held at once.
//!
//! Blocks are taken in program order. Feed moves that are not pinned gather into the
//! current chain; any other block ends it: the chain is smoothed with the method
//! (`super::smooth_chain`) and its moves are handed out, followed by the block. So far
//! this is [`super::smooth`], and the output is the same block for block.
//!
//! A chain longer than [`StreamOptions::window_moves`] is cut: the longest line or arc among
//! the last half of the window is split at its midpoint, the part before the midpoint is
//! smoothed as a chain and handed out, and the rest starts the next window. The path
//! passes through that midpoint exactly, with the programmed move's tangent (a straight
//! junction: no stop, no corner), and what a method would have done across it (a corner
//! transition reaching past half of the split move, a run fitted as one curve, a closed
//! contour joined at its start) is done on each side separately. Where no chain is that
//! long (a program of exact stops and rapids every few thousand moves), the result is
//! exactly that of [`super::smooth`].
//!
//! With a window, the per-run lists of [`SmoothReport`] keep their first
//! `MAX_LISTED_RUNS` (10000) entries (the counts are complete).

use super::band_time::{TimeLimits, TimeShapeOptions};
use super::{smooth_chain, Chain, Method, OptionsError, SmoothOptions, SmoothReport, Smoothed};
use crate::geom::{ParamCurve, Segment};
use crate::path::Toolpath;
use crate::path::{Block, ExtraAxes, Move, MoveKind};
use crate::verify::deviation_segments;

/// Entries kept in the per-run lists of the report.
pub(crate) const MAX_LISTED_RUNS: usize = 10_000;

/// Settings of [`StreamSmoother`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct StreamOptions {
    /// Most moves of a chain held before it is cut (see the module doc). Default
    /// `StreamOptions::DEFAULT_WINDOW_MOVES`: about 1 MB of moves, longer than the runs
    /// of micro-lines between corners of real CAM output, which are cut only on
    /// continuous surfacing passes and spirals.
    pub window_moves: usize,
    /// When set, every window handed out (a chain, or the part of a chain before a cut)
    /// is measured both ways against the programmed moves of that window, to this
    /// accuracy (mm), and the worst figures kept ([`StreamSmoother::window_check`]).
    /// Default `None` (the CLI measures the written program instead).
    pub verify_accuracy_mm: Option<f64>,
}

/// The two-sided deviation of the windows handed out so far, each measured against its
/// own programmed moves ([`StreamOptions::verify_accuracy_mm`]). The programmed path of a
/// window is a part of the whole, so these bound the whole path's deviation from above.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WindowCheck {
    /// Windows measured.
    pub windows: usize,
    /// The worst window: (a) output to programmed, (b) programmed vertex to output (mm),
    /// and the source line of the output move where the larger occurs.
    pub worst: Option<(f64, f64, u32)>,
}

impl WindowCheck {
    /// True when every window measured holds `tol_mm` both ways.
    pub fn within(&self, tol_mm: f64) -> bool {
        self.worst.is_none_or(|(a, b, _)| a.max(b) <= tol_mm)
    }
}

impl StreamOptions {
    /// Default of [`StreamOptions::window_moves`].
    pub(crate) const DEFAULT_WINDOW_MOVES: usize = 8192;
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            window_moves: Self::DEFAULT_WINDOW_MOVES,
            verify_accuracy_mm: None,
        }
    }
}

/// Smooths blocks as they come (see the module doc).
///
/// ```
/// use ncsmooth::smooth::{Method, SmoothOptions};
/// use ncsmooth::smooth::stream::{StreamOptions, StreamSmoother};
/// use ncsmooth::{Toolpath, Vec3};
/// let pts: Vec<Vec3> = (0..=40)
///     .map(|k| Vec3::new(k as f64, if k % 2 == 0 { 0.0 } else { 0.3 }, 0.0))
///     .collect();
/// let program = Toolpath::from_polyline(&pts, Some(50.0));
/// let opts = SmoothOptions::default().with_method(Method::Bspline).with_tol_mm(0.01);
/// let mut s = StreamSmoother::new(opts.clone(), StreamOptions::default()).unwrap();
/// let mut out = Vec::new();
/// for b in &program.blocks {
///     s.push(b.clone(), &mut out);
/// }
/// s.finish(&mut out);
/// // The same as smoothing the whole program at once.
/// let whole = ncsmooth::smooth::smooth(&program, &opts).unwrap();
/// assert_eq!(out, whole.toolpath.blocks);
/// ```
pub struct StreamSmoother {
    opts: SmoothOptions,
    stream: StreamOptions,
    /// The chain being gathered.
    run: Vec<Move>,
    /// Extra-axis values before the chain's first move.
    run_start_extra: Option<ExtraAxes>,
    /// Whether the chain being gathered starts at a cut.
    run_cut_before: bool,
    /// Extra-axis values after the last block taken.
    last_extra: Option<ExtraAxes>,
    report: SmoothReport,
    check: WindowCheck,
}

/// Longest chain a feed plan's smoother holds before cutting it (moves,
/// [`StreamSmoother::for_plan`]): smoothing a chain takes about 3.5 kB per move (the run
/// fits), so this bounds most of the memory of a streamed plan. Programs whose chains are
/// all shorter are smoothed as [`super::smooth`] smooths them.
pub const PLAN_WINDOW_MOVES: usize = 4096;

impl StreamSmoother {
    /// The smoother of a feed plan: `method` to the whole tolerance `tol_mm` (setpoints
    /// carry no flattening or rounding), chains cut at [`PLAN_WINDOW_MOVES`]; runs
    /// reshaped for `time_shape`'s limits when given.
    pub fn for_plan(
        method: Method,
        tol_mm: f64,
        time_shape: Option<TimeLimits>,
    ) -> Result<Self, OptionsError> {
        let mut sopts = SmoothOptions {
            method,
            tol_mm,
            ..Default::default()
        };
        sopts.run.fit.time_shape = time_shape.map(TimeShapeOptions::new);
        let stream = StreamOptions {
            window_moves: PLAN_WINDOW_MOVES,
            ..StreamOptions::default()
        };
        StreamSmoother::new(sopts, stream)
    }

    /// A smoother with `opts`; fails on invalid options.
    pub fn new(opts: SmoothOptions, stream: StreamOptions) -> Result<Self, OptionsError> {
        opts.validate()?;
        Ok(StreamSmoother {
            report: SmoothReport {
                method: opts.method,
                tol_mm: opts.tol_mm,
                ..Default::default()
            },
            opts,
            stream: StreamOptions {
                window_moves: stream.window_moves.max(MIN_WINDOW_MOVES),
                ..stream
            },
            check: WindowCheck::default(),
            run: Vec::new(),
            run_start_extra: None,
            run_cut_before: false,
            last_extra: None,
        })
    }

    /// Takes the next block of the program; appends to `out` what is ready.
    pub fn push(&mut self, b: Block, out: &mut Vec<Block>) {
        let extra_after = b.extra_after(self.last_extra);
        match b {
            Block::Move(m) if m.kind == MoveKind::Feed && !m.pinned => {
                if self.run.is_empty() {
                    self.run_start_extra = m.extra_start(self.last_extra).or(self.last_extra);
                }
                self.last_extra = extra_after;
                self.run.push(m);
                if self.run.len() >= self.stream.window_moves {
                    self.cut(out);
                }
            }
            other => {
                self.flush(out);
                self.last_extra = extra_after;
                out.push(other);
            }
        }
    }

    /// After the last block: hands out the rest.
    pub fn finish(&mut self, out: &mut Vec<Block>) {
        self.flush(out);
    }

    /// What was done so far.
    pub fn report(&self) -> &SmoothReport {
        &self.report
    }

    /// The windows measured so far (none unless [`StreamOptions::verify_accuracy_mm`]).
    pub fn window_check(&self) -> WindowCheck {
        self.check
    }

    /// Measures a window's output against its programmed moves (see [`WindowCheck`]).
    fn measure(&mut self, programmed: &[Move], smoothed: &[Move]) {
        let Some(accuracy) = self.stream.verify_accuracy_mm else {
            return;
        };
        fn refs(ms: &[Move]) -> Vec<(&Segment, u32)> {
            ms.iter().map(|m| (&m.segment, m.line)).collect()
        }
        let d = deviation_segments(&refs(smoothed), &refs(programmed), accuracy);
        let line = if d.output_to_programmed_mm >= d.vertex_to_output_mm {
            d.output_line
        } else {
            d.vertex_line
        };
        let c = &mut self.check;
        c.windows += 1;
        if c.worst.is_none_or(|(a, b, _)| d.max_mm() > a.max(b)) {
            c.worst = Some((d.output_to_programmed_mm, d.vertex_to_output_mm, line));
        }
    }

    /// Smooths the gathered chain and hands it out.
    fn flush(&mut self, out: &mut Vec<Block>) {
        if self.run.is_empty() {
            return;
        }
        let run = std::mem::take(&mut self.run);
        self.emit(
            &run,
            self.run_start_extra,
            [self.run_cut_before, false],
            out,
        );
        self.run = run;
        self.run.clear();
        self.run_cut_before = false;
    }

    fn emit(
        &mut self,
        moves: &[Move],
        start_extra: Option<ExtraAxes>,
        open_ends: [bool; 2],
        out: &mut Vec<Block>,
    ) {
        let chain = Chain {
            moves,
            start_extra,
            open_ends,
        };
        self.report.chains += 1;
        let smoothed = smooth_chain(&chain, &self.opts, &mut self.report);
        self.measure(moves, &smoothed);
        self.report.segments_emitted += smoothed.len();
        out.extend(smoothed.into_iter().map(Block::Move));
        if self.stream.window_moves != usize::MAX {
            let r = &mut self.report;
            r.points_per_run.truncate(MAX_LISTED_RUNS);
            r.fit_deviation_per_run_mm.truncate(MAX_LISTED_RUNS);
        }
    }

    /// Cuts the chain at the midpoint of a move in its last half (see the module doc).
    fn cut(&mut self, out: &mut Vec<Block>) {
        if self.opts.method == Method::None {
            // Nothing joins moves: hand them out as they are.
            return self.flush(out);
        }
        let n = self.run.len();
        let Some(c) = (n / 2..n)
            .filter(|&k| matches!(self.run[k].segment, Segment::Line(_) | Segment::Arc(_)))
            .max_by(|&a, &b| length(&self.run[a]).total_cmp(&length(&self.run[b])))
        else {
            // No line or arc to split (a run of splines): wait for one, or the chain's end.
            return;
        };
        let before = if c == 0 {
            self.run_start_extra
        } else {
            self.run[c - 1].extra
        };
        let (first, second) = split_move(&self.run[c], before);
        let mut left: Vec<Move> = self.run.drain(..=c).collect();
        left.pop();
        left.push(first);
        self.emit(
            &left,
            self.run_start_extra,
            [self.run_cut_before, true],
            out,
        );
        self.run_start_extra = left.last().and_then(|m| m.extra);
        self.run_cut_before = true;
        self.run.insert(0, second);
    }
}

/// Fewest moves of a window: a cut needs moves on both sides of it.
const MIN_WINDOW_MOVES: usize = 4;

fn length(m: &Move) -> f64 {
    match &m.segment {
        Segment::Line(l) => l.length(),
        Segment::Arc(a) => a.length(),
        _ => 0.0,
    }
}

/// Move `m` (a line or an arc) as two halves; extra axes interpolated from `before` (their
/// values at its start) to its end values.
fn split_move(m: &Move, before: Option<ExtraAxes>) -> (Move, Move) {
    let (a, b) = match &m.segment {
        Segment::Line(l) => {
            let mid = l.eval(0.5);
            (
                Segment::Line(crate::geom::Line::new(l.start(), mid)),
                Segment::Line(crate::geom::Line::new(mid, l.end())),
            )
        }
        Segment::Arc(arc) => (
            Segment::Arc(arc.subsegment(0.0, 0.5)),
            Segment::Arc(arc.subsegment(0.5, 1.0)),
        ),
        _ => unreachable!("only lines and arcs are split"),
    };
    let mid_extra = m.extra.zip(m.extra_start(before)).map(|(end, start)| {
        let mut v = start;
        for i in 0..v.len() {
            v[i] = 0.5 * (start[i] + end[i]);
        }
        v
    });
    let first = Move {
        segment: a,
        extra: mid_extra,
        ..m.clone()
    };
    let second = Move {
        segment: b,
        ..m.clone()
    };
    (first, second)
}

/// `tp` smoothed by [`StreamSmoother::for_plan`], whole: the path a streamed plan plans,
/// block for block, for a program held in memory.
pub fn smooth_for_plan(
    tp: &Toolpath,
    method: Method,
    tol_mm: f64,
    time_shape: Option<TimeLimits>,
) -> Result<Smoothed, OptionsError> {
    let mut smoother = StreamSmoother::for_plan(method, tol_mm, time_shape)?;
    let mut out = Toolpath {
        blocks: Vec::with_capacity(tp.blocks.len()),
        ..Toolpath::new(tp.start)
    };
    out.units = tp.units;
    out.extra_axes_mask = tp.extra_axes_mask;
    for b in &tp.blocks {
        smoother.push(b.clone(), &mut out.blocks);
    }
    smoother.finish(&mut out.blocks);
    Ok(Smoothed {
        toolpath: out,
        report: smoother.report().clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Vec3;
    use crate::path::Toolpath;
    use crate::verify::{continuity, deviation};

    /// An Archimedean spiral of `n` micro-lines about 0.05 mm long.
    fn spiral(n: usize) -> Toolpath {
        let mut theta: f64 = 0.0;
        let pts: Vec<Vec3> = (0..=n)
            .map(|_| {
                let r = 2.0 + 0.4 * theta / std::f64::consts::TAU;
                theta += 0.05 / r;
                Vec3::new(r * theta.cos(), r * theta.sin(), 0.0)
            })
            .collect();
        Toolpath::from_polyline(&pts, Some(50.0))
    }

    fn stream(
        tp: &Toolpath,
        opts: &SmoothOptions,
        window: usize,
    ) -> (Toolpath, SmoothReport, WindowCheck) {
        let so = StreamOptions {
            window_moves: window,
            verify_accuracy_mm: Some(1e-6),
        };
        let mut s = StreamSmoother::new(opts.clone(), so).unwrap();
        let mut out = Toolpath::new(tp.start);
        for b in &tp.blocks {
            s.push(b.clone(), &mut out.blocks);
        }
        s.finish(&mut out.blocks);
        (out, s.report().clone(), s.window_check())
    }

    /// A chain longer than the window is cut at line midpoints: every method stays within
    /// the tolerance both ways, the cuts add no corner (the joints there are tangent), and
    /// the path passes through each cut midpoint.
    #[test]
    fn long_chains_are_cut_within_tolerance_and_without_corners() {
        let tp = spiral(3000);
        for method in [
            Method::None,
            Method::Bspline,
            Method::Arc,
            Method::Nurbs,
            Method::Trig,
        ] {
            let opts = SmoothOptions {
                method,
                tol_mm: 0.01,
                ..Default::default()
            };
            let (whole, _, _) = stream(&tp, &opts, usize::MAX);
            let (cut, report, check) = stream(&tp, &opts, 500);
            let chains = if method == Method::None { 6 } else { 9 };
            assert!(
                report.chains >= chains,
                "{method:?}: {} chains",
                report.chains
            );
            let d = deviation(&cut, &tp, 1e-6);
            assert!(d.within(0.01), "{method:?}: {d:?}");
            // Each window measured against its own programmed moves bounds the whole.
            assert!(check.windows >= report.chains, "{method:?}: {check:?}");
            let (a, b, _) = check.worst.unwrap();
            assert!(check.within(0.01), "{method:?}: {check:?}");
            assert!(a.max(b) >= d.max_mm() - 1e-6, "{method:?}: {check:?} {d:?}");
            let (cw, cc) = (continuity(&whole), continuity(&cut));
            assert_eq!(cc.g0, cw.g0, "{method:?}: corners added by the cuts");
            assert_eq!(cc.gaps, 0, "{method:?}");
        }
    }

    /// A window the chains never reach changes nothing, and splitting keeps the line, the
    /// extra axes (interpolated to the midpoint) and the move's other fields.
    #[test]
    fn short_chains_are_unchanged_and_splits_keep_extra_axes() {
        let tp = spiral(300);
        let opts = SmoothOptions {
            method: Method::Trig,
            tol_mm: 0.01,
            ..Default::default()
        };
        assert_eq!(
            stream(&tp, &opts, 400).0.blocks,
            stream(&tp, &opts, usize::MAX).0.blocks
        );
        let mut m = Move::feed(
            crate::geom::Line::new(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)),
            Some(10.0),
            7,
        );
        m.extra = Some([4.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0]);
        let (a, b) = split_move(&m, Some([2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert_eq!(a.segment.end(), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(b.segment.start(), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(a.extra, Some([3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0]));
        assert_eq!(b.extra, m.extra);
        assert_eq!((a.line, a.feed_mm_s, b.line), (7, Some(10.0), 7));
    }
}

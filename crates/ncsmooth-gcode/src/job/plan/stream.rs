//! A planning job on a G-code file, in memory that does not grow with the program: the
//! file is interpreted a batch of blocks at a time ([`BlockReader`]), smoothed chain by
//! chain ([`StreamSmoother`], a chain longer than its window cut as its module doc says),
//! and planned and interpolated while it is read ([`execute_streamed`]). A path held
//! whole is smoothed by the same windowed smoother ([`StreamSmoother::for_plan`]), so the
//! setpoints are the same either way.
//!
//! What needs the whole program is done on the way: the jerk split is chosen on the first
//! [`SPLIT_SEARCH_MAX_BLOCKS`] smoothed blocks (as the whole path does), and the row limit
//! is checked against the lower bound on the cycle time as the moves arrive (a plan that
//! already needs more rows stops reading, and nothing is written).

use super::{JobError, PlanJob};
use crate::{BlockReader, ParseError, ParseOptions};
use ncsmooth::feed::grid::IndexFeeder;
use ncsmooth::feed::jerk::{fastest_split, SPLIT_SEARCH_MAX_BLOCKS};
use ncsmooth::feed::PlanOptions;
use ncsmooth::interp::{execute_streamed, InterpOptions, PlanError, PlanReport, SetpointSink};
use ncsmooth::smooth::SmoothReport;
use ncsmooth::{Block, StreamSmoother, Toolpath, Vec3};
use std::path::Path;

/// Blocks asked of the reader at a time.
const READ_BATCH_BLOCKS: usize = 4096;

/// Why feeding stopped early.
enum FeedStop {
    /// The program is not valid G-code there.
    Parse(ParseError),
    /// The cycle takes at least this long (s), more than the row limit allows.
    TooLong(f64),
}

/// A G-code file being read, smoothed and planned (see the module doc).
pub(super) struct StreamedInput<'o> {
    reader: BlockReader<'o>,
    smoother: StreamSmoother,
    /// Smoothed blocks read ahead (for the jerk split and the start point).
    prefix: Vec<Block>,
    /// The reader has more blocks.
    more: bool,
    /// The row limit of the job.
    max_rows: Option<u64>,
}

impl<'o> StreamedInput<'o> {
    /// Opens `path` (named `name` in messages) and smooths its first blocks as `job` asks.
    pub(super) fn open(
        path: &Path,
        name: &'o str,
        parse: &'o ParseOptions,
        job: &PlanJob,
    ) -> Result<Self, JobError> {
        let reader = BlockReader::open(path, name, parse)?;
        let smoother = StreamSmoother::for_plan(job.method, job.tol_mm, job.time_limits())
            .map_err(|e| JobError::BadInput(e.to_string()))?;
        let mut input = StreamedInput {
            reader,
            smoother,
            prefix: Vec::new(),
            more: true,
            max_rows: job.max_rows,
        };
        while input.more && input.prefix.len() < SPLIT_SEARCH_MAX_BLOCKS {
            let mut out = std::mem::take(&mut input.prefix);
            let pumped = input.pump(&mut out);
            input.prefix = out;
            pumped?;
        }
        Ok(input)
    }

    /// The line of the first move read before any G20/G21, if it came within the blocks
    /// read so far ([`crate::ParseStats::units_assumed`]).
    pub(super) fn units_assumed(&self) -> Option<u32> {
        self.reader.stats().units_assumed
    }

    /// Reads a batch of blocks and smooths them into `out`.
    fn pump(&mut self, out: &mut Vec<Block>) -> Result<(), ParseError> {
        let mut batch = Vec::with_capacity(READ_BATCH_BLOCKS);
        self.more = self.reader.read_blocks(&mut batch, READ_BATCH_BLOCKS)?;
        for b in batch {
            self.smoother.push(b, out);
        }
        if !self.more {
            self.smoother.finish(out);
        }
        Ok(())
    }

    /// Where the program starts: its first move's start.
    fn start(&self) -> Vec3 {
        self.prefix
            .iter()
            .find_map(|b| match b {
                Block::Move(m) => Some(ncsmooth::geom::ParamCurve::start(&m.segment)),
                Block::Event(_) => None,
            })
            .or(self.reader.start())
            .unwrap_or_default()
    }

    /// The smoothed blocks read ahead as a toolpath (the jerk split is chosen on them).
    fn prefix_toolpath(&self) -> Toolpath {
        let mut tp = Toolpath::new(self.start());
        tp.blocks = self.prefix.clone();
        tp.extra_axes_mask = self.reader.extra_axes_mask();
        tp
    }

    /// The options the plan runs with: the path's top speed when the whole program was
    /// read ahead, else the limits' (a later move could be faster than any of the first),
    /// stated so that the report says what the plan was sized for; and in jerk mode
    /// without a split the fastest for the first blocks.
    pub(super) fn tuned(&self, popts: &PlanOptions) -> PlanOptions {
        let mut o = popts.clone();
        let prefix = self.prefix_toolpath();
        if o.top_speed_mm_s.is_none() {
            o.top_speed_mm_s = Some(if self.more {
                o.top_speed()
            } else {
                o.top_speed_of(&prefix)
            });
        }
        if o.jerk_mm_s3.is_some() && o.jerk_split.is_none() {
            o.jerk_split = Some(fastest_split(&prefix, &o));
        }
        o
    }

    /// Plans the program into `sink` while reading it. The error is the input's (a parse
    /// error, or more rows than the limit); the plan's own result is the inner one.
    pub(super) fn plan<S: SetpointSink + Send>(
        &mut self,
        popts: &PlanOptions,
        iopts: &InterpOptions,
        sink: S,
        announce: &(dyn Fn(f64) -> bool + Sync),
    ) -> Result<Result<(PlanReport, S), PlanError>, JobError> {
        let start = self.start();
        let mask = self.reader.extra_axes_mask();
        let prefix = std::mem::take(&mut self.prefix);
        let max_rows = self.max_rows;
        let max_cycle_s = max_rows.map(|n| n as f64 * popts.period_s);
        let (planned, fed) = execute_streamed(start, mask, popts, iopts, sink, |f| {
            self.feed(f, prefix, popts, max_cycle_s, announce)
        });
        match fed {
            Ok(()) => Ok(planned),
            Err(FeedStop::Parse(e)) => Err(JobError::Parse(e)),
            Err(FeedStop::TooLong(min_cycle_s)) => Err(JobError::BadInput(format!(
                "the cycle takes at least {min_cycle_s:.3} s (the path at its speed caps), so \
                 at least {} setpoint rows at --period {:?} s, more than --max-rows {}; \
                 nothing written",
                (min_cycle_s / popts.period_s) as u64,
                popts.period_s,
                max_rows.unwrap_or_default()
            ))),
        }
    }

    /// Hands `prefix` and the rest of the program to `f`, keeping the lower bound on the
    /// cycle time within `max_cycle_s`.
    fn feed(
        &mut self,
        f: &mut IndexFeeder<'_>,
        prefix: Vec<Block>,
        popts: &PlanOptions,
        max_cycle_s: Option<f64>,
        announce: &(dyn Fn(f64) -> bool + Sync),
    ) -> Result<(), FeedStop> {
        let mut floor_s = 0.0;
        let mut announced = false;
        let mut hand = |f: &mut IndexFeeder<'_>, blocks: &mut Vec<Block>| {
            for b in blocks.drain(..) {
                if let Block::Move(m) = &b {
                    floor_s += popts.move_floor_s(m);
                    if max_cycle_s.is_some_and(|max| floor_s > max) {
                        return Err(FeedStop::TooLong(floor_s));
                    }
                    if !announced {
                        announced = announce(floor_s);
                    }
                }
                f.push(b);
            }
            Ok(())
        };
        let mut blocks = prefix;
        hand(f, &mut blocks)?;
        while self.more && f.wanted() {
            self.pump(&mut blocks).map_err(FeedStop::Parse)?;
            hand(f, &mut blocks)?;
        }
        Ok(())
    }

    /// What smoothing did.
    pub(super) fn report(&self) -> SmoothReport {
        self.smoother.report().clone()
    }
}

//! Indexing a program that arrives block by block: [`IndexFeeder`] (batches of a
//! streamed program) and the references [`MoveRef`] and [`RestRef`] to the moves and
//! rests of a whole or streamed index.

use super::builder::IndexBuilder;
use super::index::{move_len, PARALLEL_MIN_MOVES};
use super::joints::{caps_of, joint_after};
use super::{ExtraRest, PlanMove};
use crate::feed::window::{MoveWindow, Summary};
use crate::feed::PlanOptions;
use crate::geom::{ParamCurve, Segment, Vec3};
use crate::path::Block;
use std::sync::Arc;

/// Moves a [`IndexFeeder`] indexes at a time: their lengths and joints are computed in
/// parallel as [`super::PathIndex::new`] does for a whole program.
pub(crate) const FEED_BATCH_MOVES: usize = 4096;

/// Indexes a program that arrives block by block into the [`MoveWindow`] of a streamed
/// [`super::PathIndex`]: each move's length and joint, its stop, extra-axis rests, exactly as
/// [`super::PathIndex::new`] indexes a whole program (same functions, same order), a batch of
/// `FEED_BATCH_MOVES` (4096) at a time. The last move indexed is held back until the next one
/// (its joint) or the end is known.
pub struct IndexFeeder<'o> {
    builder: IndexBuilder<'o>,
    window: Arc<MoveWindow>,
    buf: Vec<Block>,
    buf_moves: usize,
    lead_sent: bool,
    /// End of the last move published.
    end: Option<Vec3>,
    published: usize,
}

impl<'o> IndexFeeder<'o> {
    /// A feeder of `window` under `opts` (which must be valid).
    pub fn new(opts: &'o PlanOptions, window: Arc<MoveWindow>) -> Self {
        IndexFeeder {
            builder: IndexBuilder::new(opts, caps_of(opts)),
            window,
            buf: Vec::new(),
            buf_moves: 0,
            lead_sent: false,
            end: None,
            published: 0,
        }
    }

    /// Whether the planner still reads the program (it stops early on a failed write).
    pub fn wanted(&self) -> bool {
        self.window.wanted()
    }

    /// Takes the next block of the program.
    pub fn push(&mut self, block: Block) {
        self.buf_moves += usize::from(matches!(block, Block::Move(_)));
        self.buf.push(block);
        if self.buf_moves > FEED_BATCH_MOVES {
            self.index_buffered(false);
        }
    }

    /// Indexes the buffered blocks (all of them at the end, else up to the last move,
    /// which stays as the next batch's first and the joint partner of the one before).
    fn index_buffered(&mut self, at_end: bool) {
        let keep_from = if at_end {
            self.buf.len()
        } else {
            self.buf
                .iter()
                .rposition(|b| matches!(b, Block::Move(_)))
                .unwrap_or(self.buf.len())
        };
        let segs: Vec<&Segment> = self
            .buf
            .iter()
            .filter_map(|b| match b {
                Block::Move(m) => Some(&m.segment),
                Block::Event(_) => None,
            })
            .collect();
        let n = if at_end { segs.len() } else { segs.len() - 1 };
        let (opts, caps) = (self.builder.opts, self.builder.caps);
        let lens = crate::par::map(n, PARALLEL_MIN_MOVES, |i| {
            let joint = segs
                .get(i + 1)
                .map(|next| joint_after(segs[i], next, opts, &caps));
            (move_len(segs[i]), joint)
        });
        drop(segs);
        let rest = self.buf.split_off(keep_from);
        let mut lens = lens.into_iter();
        for block in std::mem::replace(&mut self.buf, rest) {
            match block {
                Block::Event(e) => self.builder.event(&e.kind),
                Block::Move(m) => {
                    let (len, joint) = lens.next().expect("one per move");
                    self.builder.push_move(&m, len, joint);
                }
            }
        }
        self.buf_moves = usize::from(!at_end && !self.buf.is_empty());
        // The last move stays: its joint, or at the end the stop after it, may change it.
        self.publish(false);
    }

    /// Hands the indexed moves (all at the end, else all but the last, whose joint may
    /// still change) and the rests collected to the window.
    fn publish(&mut self, all: bool) {
        let b = &mut self.builder;
        if !self.lead_sent && (all || !b.moves.is_empty()) {
            self.window.set_lead(b.lead);
            self.lead_sent = true;
        }
        let n = b.moves.len();
        let upto = if all { n } else { b.held_back_from() };
        if let Some(m) = b.moves[..upto].last() {
            self.end = Some(m.segment.end());
        }
        self.published += upto;
        let moves: Vec<PlanMove> = b.moves.drain(..upto).collect();
        let known_to = moves.last().map(|m| m.s0 + m.len);
        self.window
            .push(moves, std::mem::take(&mut b.rests), known_to);
    }

    /// The program ended: indexes what is left and closes the window. `start` is where
    /// the program starts (its end when it has no move).
    pub fn finish(mut self, start: Vec3) {
        self.index_buffered(true);
        self.builder.end();
        self.publish(true);
        self.window.finish(Summary {
            moves: self.published,
            total_len: self.builder.s,
            end: self.end.unwrap_or(start),
        });
    }
}

/// A move of a [`super::PathIndex`]: borrowed from a whole program's index or shared from a
/// streamed one's window.
#[derive(Clone, Debug)]
pub enum MoveRef<'a> {
    /// In a whole program's index.
    Borrowed(&'a PlanMove),
    /// In a streamed program's window.
    Shared(Arc<PlanMove>),
}

impl std::ops::Deref for MoveRef<'_> {
    type Target = PlanMove;
    #[inline]
    fn deref(&self) -> &PlanMove {
        match self {
            MoveRef::Borrowed(m) => m,
            MoveRef::Shared(m) => m,
        }
    }
}

/// A rest of a [`super::PathIndex`] (as [`MoveRef`]).
#[derive(Clone, Debug)]
pub enum RestRef<'a> {
    /// In a whole program's index.
    Borrowed(&'a ExtraRest),
    /// In a streamed program's window.
    Shared(Arc<ExtraRest>),
}

impl std::ops::Deref for RestRef<'_> {
    type Target = ExtraRest;
    fn deref(&self) -> &ExtraRest {
        match self {
            RestRef::Borrowed(r) => r,
            RestRef::Shared(r) => r,
        }
    }
}

//! The moves of a streamed program as the planner's readers need them: a window that the
//! indexing side appends to and the readers release from, so that memory is bounded by
//! what the readers still need, not by the program.
//!
//! Three readers walk the moves in order: the grid producer (on its own thread), the
//! look-ahead's grid consumer and the interpolator. Each tells the window below which
//! move it needs nothing more ([`MoveWindow::release`]); moves below every reader's mark
//! are dropped. The indexing side waits ([`MoveWindow::push`]) while it is more than
//! `DEFAULT_AHEAD_MOVES` moves ahead of the grid reader that pulls them (the producer,
//! which may wait for moves with a batch half filled while the consumer waits for that
//! batch: the window must not wait for the consumer). How far the interpolator
//! trails them is bounded by the planning pipeline itself: the look-ahead window (a few
//! thousand grid points) and the sample queues between planning and interpolation
//! (`EMIT_QUEUE_BATCHES` batches of `EMIT_BATCH` periods), so at
//! most the moves of that much motion are held behind the grid readers.
//!
//! A reader asking for a move not yet pushed waits for it; once the indexing side has
//! [`MoveWindow::finish`]ed, a move past the end is `None`.

use super::grid::{ExtraRest, PlanMove};
use super::StopReason;
use crate::geom::Vec3;
use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// A reader of a [`MoveWindow`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reader {
    /// The grid producer ([`super::grid::GridGen::produce`]).
    GridProducer,
    /// The look-ahead's grid generator.
    GridConsumer,
    /// The interpolator.
    Interpolator,
}

const READERS: usize = 3;

impl Reader {
    fn slot(self) -> usize {
        match self {
            Reader::GridProducer => 0,
            Reader::GridConsumer => 1,
            Reader::Interpolator => 2,
        }
    }
}

/// What is known of the whole program once the indexing side has finished.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Moves indexed.
    pub moves: usize,
    /// Total arc length (mm).
    pub total_len: f64,
    /// End point of the program.
    pub end: Vec3,
}

#[derive(Debug, Default)]
struct State {
    /// Index of `moves[0]`.
    base: usize,
    moves: VecDeque<Arc<PlanMove>>,
    /// Index of `rests[0]`.
    rest_base: usize,
    rests: VecDeque<Arc<ExtraRest>>,
    /// Below these, each reader needs no move (and the interpolator no rest).
    marks: [usize; READERS],
    rest_mark: usize,
    /// Every rest at a stop at or before this arc length (mm) has been pushed.
    rests_known_to: f64,
    /// The events before the first move, once known (`Some(None)`: none).
    lead: Option<Option<(StopReason, f64)>>,
    /// Start of the first move (or of the program), once known.
    start: Option<Vec3>,
    summary: Option<Summary>,
}

/// See the module doc.
#[derive(Debug)]
pub struct MoveWindow {
    state: Mutex<State>,
    cv: Condvar,
    /// Most moves the indexing side may be ahead of the grid reader that pulls them.
    ahead_cap: usize,
}

/// Moves the indexing side may be ahead of the grid reader that pulls them (each batch
/// of the grid producer takes 256).
pub(crate) const DEFAULT_AHEAD_MOVES: usize = 1 << 14;

impl Default for MoveWindow {
    fn default() -> Self {
        MoveWindow {
            state: Mutex::default(),
            cv: Condvar::new(),
            ahead_cap: DEFAULT_AHEAD_MOVES,
        }
    }
}

impl MoveWindow {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn wait<'g>(&self, g: MutexGuard<'g, State>) -> MutexGuard<'g, State> {
        self.cv.wait(g).unwrap_or_else(|e| e.into_inner())
    }

    /// Move `j`, waiting until it is pushed; `None` past the end. A move below the
    /// caller's own mark is a logic error (it may be gone).
    pub fn get(&self, j: usize) -> Option<Arc<PlanMove>> {
        let mut g = self.lock();
        loop {
            assert!(j >= g.base, "move {j} was released (window at {})", g.base);
            if let Some(m) = g.moves.get(j - g.base) {
                return Some(m.clone());
            }
            if g.summary.is_some() {
                return None;
            }
            g = self.wait(g);
        }
    }

    /// Rest `k` (the extra-axis motions of the `k`-th stop that has any), waiting until it
    /// is pushed or every rest up to arc length `s` is known; `None` when there is no
    /// rest `k` at or before `s`.
    pub fn rest(&self, k: usize, s: f64) -> Option<Arc<ExtraRest>> {
        let mut g = self.lock();
        loop {
            assert!(k >= g.rest_base, "rest {k} was released");
            if let Some(r) = g.rests.get(k - g.rest_base) {
                return Some(r.clone());
            }
            if g.summary.is_some() || g.rests_known_to >= s {
                return None;
            }
            g = self.wait(g);
        }
    }

    /// `reader` needs no move below `j` any more.
    pub fn release(&self, reader: Reader, j: usize) {
        let mut g = self.lock();
        let slot = &mut g.marks[reader.slot()];
        if j <= *slot {
            return;
        }
        *slot = j;
        let low = g.marks.iter().copied().min().unwrap_or(0);
        let mut dropped = false;
        while g.base < low && !g.moves.is_empty() {
            g.moves.pop_front();
            g.base += 1;
            dropped = true;
        }
        drop(g);
        if dropped || reader != Reader::Interpolator {
            self.cv.notify_all();
        }
    }

    /// The interpolator needs no rest below `k` any more.
    pub fn release_rests(&self, k: usize) {
        let mut g = self.lock();
        g.rest_mark = g.rest_mark.max(k);
        while g.rest_base < g.rest_mark && !g.rests.is_empty() {
            g.rests.pop_front();
            g.rest_base += 1;
        }
    }

    /// Appends finished moves and rests, waiting while the indexing side is more than
    /// `ahead_cap` moves ahead of the grid reader that pulls them (the producer, which
    /// waits for moves with a batch half filled while the consumer waits for that batch: the
    /// window must not wait for the consumer).
    /// `known_to`: every rest at or before this arc length is among those pushed so far.
    pub fn push(
        &self,
        moves: impl IntoIterator<Item = PlanMove>,
        rests: Vec<ExtraRest>,
        known_to: Option<f64>,
    ) {
        let mut g = self.lock();
        loop {
            // The grid reader that pulls the moves: the producer, or the consumer when it
            // computes the grid itself (a reader that stopped holds nothing back).
            let pull = g.marks[..2]
                .iter()
                .copied()
                .filter(|&m| m != usize::MAX)
                .max();
            match pull {
                Some(m) if g.base + g.moves.len() >= m.saturating_add(self.ahead_cap) => {}
                _ => break,
            }
            g = self.wait(g);
        }
        for m in moves {
            if g.start.is_none() {
                g.start = Some(crate::geom::ParamCurve::start(&m.segment));
            }
            g.moves.push_back(Arc::new(m));
        }
        g.rests.extend(rests.into_iter().map(Arc::new));
        if let Some(s) = known_to {
            g.rests_known_to = g.rests_known_to.max(s);
        }
        drop(g);
        self.cv.notify_all();
    }

    /// The events before the first move are known.
    pub fn set_lead(&self, lead: Option<(StopReason, f64)>) {
        self.lock().lead = Some(lead);
        self.cv.notify_all();
    }

    /// The events before the first move, waiting until they are known.
    pub fn lead(&self) -> Option<(StopReason, f64)> {
        let mut g = self.lock();
        loop {
            if let Some(l) = g.lead {
                return l;
            }
            if g.summary.is_some() {
                return None;
            }
            g = self.wait(g);
        }
    }

    /// The start of the first move, or `program_start` when the program has none,
    /// waiting until it is known.
    pub fn start(&self, program_start: Vec3) -> Vec3 {
        let mut g = self.lock();
        loop {
            if let Some(p) = g.start {
                return p;
            }
            if g.summary.is_some() {
                return program_start;
            }
            g = self.wait(g);
        }
    }

    /// The indexing side is done (or gave up): readers past the end get `None`.
    pub fn finish(&self, summary: Summary) {
        let mut g = self.lock();
        g.summary = Some(summary);
        if g.lead.is_none() {
            g.lead = Some(None);
        }
        drop(g);
        self.cv.notify_all();
    }

    /// The summary, waiting for the indexing side to finish.
    pub fn summary(&self) -> Summary {
        let mut g = self.lock();
        loop {
            if let Some(s) = g.summary {
                return s;
            }
            g = self.wait(g);
        }
    }

    /// `reader` does not read this window at all (its mark no longer holds moves).
    pub fn not_reading(&self, reader: Reader) {
        self.release(reader, usize::MAX);
    }

    /// Whether some reader still reads the moves (the planner has not stopped).
    pub fn wanted(&self) -> bool {
        self.lock().marks[1..].iter().any(|&m| m != usize::MAX)
    }
}

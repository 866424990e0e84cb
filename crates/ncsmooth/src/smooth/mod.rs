//! Smoothing: turns the programmed path into a smoother one within a two-sided tolerance.
//!
//! ## Contract
//! `tol_mm` is two-sided: every point of the output lies within `tol_mm` of the programmed
//! path and every programmed vertex within `tol_mm` of the output
//! ([`crate::verify::deviation`] measures both). Loop corners (Tao's outside ring) are the
//! one exception and carry their own bound.
//!
//! ## What is smoothed
//! The program is cut into *chains*: maximal runs of consecutive feed moves. A rapid, an
//! event (spindle, coolant, dwell, tool change, ...) or a G53 move ends a chain, and chain
//! ends are kept exactly (the event happens at that point). Rapids are never smoothed.
//! Each method works on one chain at a time ([`Chain`]) and returns its moves; this module
//! re-assembles the program with the rapids and events in place.
//!
//! Inside a chain, a junction whose tangent turns by less than
//! [`SmoothOptions::straight_angle_deg`] passes through unchanged. Extra axes (A B C U V W E)
//! ride along: [`assemble`] gives each output move the extra-axis values of the programmed
//! path at its end point, interpolated linearly in arc length within the programmed move,
//! so they are never smoothed. A vertex where the extrusion rate (`E` per mm) changes
//! ([`crate::path::extra_rates_agree`]: a slicer's travel meeting an extrusion) is never
//! rounded: the chain is smoothed stretch by stretch of one flow, so no curve carries one
//! move's flow into the other (the other axes ride along the rounded corners). A move of
//! no length that moves an extra axis (a prime, a rotary axis indexing with the tool at
//! rest) is a stretch of its own, never spread over the moves around it. Feeds: an output piece gets the lowest programmed feed of
//! the moves it spans.
//!
//! Non-tangent joints involving an input arc are blended first, the same way for every
//! method ([`arc_joint`]); the method then works on lines, arcs and those blends.
//!
//! ## Run mode
//! With [`SmoothOptions::run`] (on by default) the curve methods fit runs of micro-corners
//! as one curve through the whole tolerance band ([`band_fit`]) in their own family:
//! `bspline` as cubic Béziers, `trig` as trigonometric segments and `arc` as an arc spline
//! ([`run_mode`], before their corner transitions), `nurbs` as a NURBS (in its fitting
//! step). Each method's module says where this follows its paper and where it extends it.
//!
//! ## Methods
//! * [`Method::None`]: the program unchanged (planning the raw path).
//! * [`Method::Bspline`]: Guo et al., cubic B-spline corner transitions in a tolerance band.
//! * [`Method::Arc`]: Wu et al., circular-arc corner transitions (runs of micro-lines as
//!   arc splines).
//! * [`Method::Nurbs`]: Wu et al., NURBS fitting of micro-line runs plus arc corners.
//! * [`Method::Trig`]: Tao et al., cubic trigonometric spline curves and corners.

pub mod arc_corner;
pub mod arc_joint;
pub mod arc_spline;
pub mod band_fit;
pub mod band_time;
pub mod bspline_corner;
mod method;
pub mod nurbs_hybrid;
pub mod run_mode;
pub mod screen;
pub mod simplify;
pub mod stream;
pub mod trig_corner;

pub use method::Method;

use crate::geom::{ParamCurve, ParamCurveArclen, Segment, Vec3};
use crate::path::{ExtraAxes, Move, MoveKind, Toolpath, E_AXIS};
use crate::verify::{DEGENERATE_MM, TANGENT_TOL_DEG};
use serde::Serialize;

/// Accuracy (mm) of arc-length evaluations used to place extra-axis values.
const EXTRA_AXIS_ARCLEN_ACCURACY: f64 = 1e-9;

/// Expected ratio of output to input blocks for the corner methods (capacity hint).
const OUTPUT_GROWTH: usize = 3;

/// Options common to every method.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct SmoothOptions {
    /// Method. Default: [`Method::None`].
    pub method: Method,
    /// Two-sided tolerance (mm). Default 0.01 mm.
    pub tol_mm: f64,
    /// Junctions turning by less than this (degrees) pass through unchanged. Default:
    /// [`TANGENT_TOL_DEG`], the angle the continuity audit already calls tangent.
    pub straight_angle_deg: f64,
    /// Settings of [`Method::Bspline`]. Default: [`bspline_corner::BsplineOptions::default`].
    pub bspline: bspline_corner::BsplineOptions,
    /// Corner arcs of [`Method::Arc`] and [`Method::Nurbs`]. Default: [`arc_corner::ArcOptions::default`].
    pub arc: arc_corner::ArcOptions,
    /// Fitting of [`Method::Nurbs`]. Default: [`nurbs_hybrid::NurbsOptions::default`].
    pub nurbs: nurbs_hybrid::NurbsOptions,
    /// Settings of [`Method::Trig`]. Default: [`trig_corner::TrigOptions::default`].
    pub trig: trig_corner::TrigOptions,
    /// Run mode of [`Method::Bspline`], [`Method::Nurbs`] and [`Method::Trig`]: runs of
    /// micro-corners fitted as one curve through the band ([`band_fit`]). Default:
    /// [`band_fit::RunOptions::default`] (on).
    pub run: band_fit::RunOptions,
}

/// Builders: each sets one field (see its doc for the default).
impl SmoothOptions {
    /// Sets [`SmoothOptions::method`].
    pub fn with_method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// Sets [`SmoothOptions::tol_mm`].
    pub fn with_tol_mm(mut self, tol_mm: f64) -> Self {
        self.tol_mm = tol_mm;
        self
    }

    /// Sets [`SmoothOptions::straight_angle_deg`].
    pub fn with_straight_angle_deg(mut self, straight_angle_deg: f64) -> Self {
        self.straight_angle_deg = straight_angle_deg;
        self
    }

    /// Sets [`SmoothOptions::bspline`].
    pub fn with_bspline(mut self, bspline: bspline_corner::BsplineOptions) -> Self {
        self.bspline = bspline;
        self
    }

    /// Sets [`SmoothOptions::arc`].
    pub fn with_arc(mut self, arc: arc_corner::ArcOptions) -> Self {
        self.arc = arc;
        self
    }

    /// Sets [`SmoothOptions::nurbs`].
    pub fn with_nurbs(mut self, nurbs: nurbs_hybrid::NurbsOptions) -> Self {
        self.nurbs = nurbs;
        self
    }

    /// Sets [`SmoothOptions::trig`].
    pub fn with_trig(mut self, trig: trig_corner::TrigOptions) -> Self {
        self.trig = trig;
        self
    }

    /// Sets [`SmoothOptions::run`].
    pub fn with_run(mut self, run: band_fit::RunOptions) -> Self {
        self.run = run;
        self
    }
}

impl Default for SmoothOptions {
    fn default() -> Self {
        SmoothOptions {
            method: Method::None,
            tol_mm: 0.01,
            straight_angle_deg: TANGENT_TOL_DEG,
            bspline: Default::default(),
            arc: Default::default(),
            nurbs: Default::default(),
            trig: trig_corner::TrigOptions::default(),
            run: Default::default(),
        }
    }
}

/// Invalid smoothing options.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum OptionsError {
    /// A value out of its range: name, value, what is allowed.
    #[error("{0} = {1} is invalid: {2}")]
    OutOfRange(&'static str, f64, &'static str),
}

impl SmoothOptions {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), OptionsError> {
        if !(self.tol_mm > 0.0 && self.tol_mm.is_finite()) {
            return Err(OptionsError::OutOfRange(
                "tol",
                self.tol_mm,
                "a positive length in mm",
            ));
        }
        if !(0.0..90.0).contains(&self.straight_angle_deg) {
            return Err(OptionsError::OutOfRange(
                "straight angle",
                self.straight_angle_deg,
                "degrees in [0, 90)",
            ));
        }
        if !(self.arc.min_radius_mm >= 0.0 && self.arc.min_radius_mm.is_finite()) {
            return Err(OptionsError::OutOfRange(
                "min arc radius",
                self.arc.min_radius_mm,
                "a length >= 0 in mm",
            ));
        }
        let share = self.nurbs.fit_accuracy_share;
        if !(share > 0.0 && share < 1.0) {
            return Err(OptionsError::OutOfRange(
                "fit accuracy share",
                share,
                "a share in (0, 1)",
            ));
        }
        if let trig_corner::CornerStyle::Loop { loop_size_mm } = self.trig.corner {
            if !(loop_size_mm > 0.0 && loop_size_mm.is_finite()) {
                return Err(OptionsError::OutOfRange(
                    "loop size",
                    loop_size_mm,
                    "a positive length in mm",
                ));
            }
        }
        self.bspline.validate()
    }
}

/// What smoothing did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SmoothReport {
    /// Method used.
    pub method: Method,
    /// Tolerance (mm).
    pub tol_mm: f64,
    /// Chains processed.
    pub chains: usize,
    /// Corners that received a transition.
    pub corners_smoothed: usize,
    /// Junctions passed through as straight.
    pub corners_straight: usize,
    /// Corners inside chains left as exact stops (near reversals, joints that could not be
    /// blended). Joints at chain ends (a rapid, an event) are stops of the program itself
    /// and are not counted.
    pub corners_stopped: usize,
    /// Non-tangent joints that involve an input arc (blended or stopped).
    pub arc_joints: usize,
    /// Of those, the joints blended ([`arc_joint`]); the others are exact stops.
    pub arc_joints_blended: usize,
    /// Micro-line runs fitted with a curve (NURBS / trig methods).
    pub runs_fitted: usize,
    /// Points per fitted run.
    pub points_per_run: Vec<usize>,
    /// Measured fit deviation per run (mm).
    pub fit_deviation_per_run_mm: Vec<f64>,
    /// Output segments emitted.
    pub segments_emitted: usize,
    /// Programmed lines merged into their neighbours before smoothing
    /// ([`band_fit::RunOptions::merge_share`]).
    pub lines_merged: usize,
}

/// Result of smoothing.
#[derive(Clone, Debug)]
pub struct Smoothed {
    /// The smoothed program (events and rapids in place).
    pub toolpath: Toolpath,
    /// What was done.
    pub report: SmoothReport,
}

/// A chain of consecutive feed moves handed to a method.
#[derive(Clone, Copy, Debug)]
pub struct Chain<'a> {
    /// The moves (feed moves; lines and arcs from G-code, any segment in general).
    pub moves: &'a [Move],
    /// Extra-axis values before the first move, if the program uses extra axes.
    pub start_extra: Option<ExtraAxes>,
    /// Whether the path goes on past the chain's start and end (`[start, end]`): a cut of
    /// [`stream::StreamSmoother`] at the midpoint of a line or arc, where the curve must
    /// leave along the move's own direction (no corner at the cut), not a free tangent.
    pub open_ends: [bool; 2],
}

impl Chain<'_> {
    /// The extra-axis values where move `k` starts ([`Move::extra_start`]: after the move
    /// before it, or the chain's start values; `E` at 0 with nothing before), `None`
    /// when the move has no extra axes.
    pub fn extra_start_of(&self, k: usize) -> Option<ExtraAxes> {
        let before = match k {
            0 => self.start_extra,
            _ => self.moves[k - 1].extra,
        };
        self.moves[k].extra_start(before)
    }
    /// True when the chain ends where it starts (a closed contour) with at least 3 moves.
    pub fn is_closed(&self, eps_mm: f64) -> bool {
        self.moves.len() >= 3
            && self.moves[0]
                .segment
                .start()
                .dist(self.moves[self.moves.len() - 1].segment.end())
                <= eps_mm
    }
}

/// A position on a chain: move index and fraction of that move's arc length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainPos {
    /// Index of the move in the chain.
    pub index: usize,
    /// Fraction of its arc length, in [0, 1].
    pub frac: f64,
}

impl ChainPos {
    /// Start of move `i`.
    pub fn start_of(i: usize) -> ChainPos {
        ChainPos {
            index: i,
            frac: 0.0,
        }
    }
    /// End of move `i`.
    pub fn end_of(i: usize) -> ChainPos {
        ChainPos {
            index: i,
            frac: 1.0,
        }
    }
}

/// One output piece of a method, with where its ends lie on the programmed chain.
#[derive(Clone, Debug)]
pub struct OutPiece {
    /// Geometry.
    pub segment: Segment,
    /// Programmed position of its start.
    pub from: ChainPos,
    /// Programmed position of its end.
    pub to: ChainPos,
}

/// Turns a method's pieces into moves: line number of the move the piece starts in, the
/// lowest feed of the moves it spans, extra axes interpolated at its end (see module doc).
pub fn assemble(chain: &Chain<'_>, pieces: Vec<OutPiece>) -> Vec<Move> {
    let n = chain.moves.len();
    let mut out = Vec::with_capacity(pieces.len());
    for pc in pieces {
        let (a, b) = if pc.from.index <= pc.to.index {
            (pc.from.index, pc.to.index)
        } else {
            (pc.to.index, pc.from.index)
        };
        let (a, b) = (a.min(n - 1), b.min(n - 1));
        let src = &chain.moves[a];
        let feed = chain.moves[a..=b]
            .iter()
            .filter_map(|m| m.feed_mm_s)
            .fold(None, |acc: Option<f64>, f| {
                Some(acc.map_or(f, |x| x.min(f)))
            });
        let extra = extra_at(chain, pc.to);
        out.push(Move {
            segment: pc.segment,
            kind: MoveKind::Feed,
            feed_mm_s: feed,
            line: src.line,
            extra,
            pinned: false,
        });
    }
    out
}

/// Extra-axis values at a chain position (linear in arc length within the move).
pub fn extra_at(chain: &Chain<'_>, pos: ChainPos) -> Option<ExtraAxes> {
    let k = pos.index.min(chain.moves.len() - 1);
    let end = chain.moves[k].extra?;
    // (A position past the last move is the chain's end.)
    if pos.frac >= 1.0 || pos.index > k {
        return Some(end);
    }
    let start = chain.extra_start_of(k)?;
    let mut v = start;
    for i in 0..v.len() {
        v[i] = start[i] + (end[i] - start[i]) * pos.frac;
    }
    Some(v)
}

/// Point of the programmed chain at a position.
pub fn point_at(chain: &Chain<'_>, pos: ChainPos) -> Vec3 {
    let s = &chain.moves[pos.index].segment;
    if pos.frac <= 0.0 {
        return s.start();
    }
    if pos.frac >= 1.0 {
        return s.end();
    }
    let len = s.arclen(EXTRA_AXIS_ARCLEN_ACCURACY);
    s.eval(s.inv_arclen(pos.frac * len, EXTRA_AXIS_ARCLEN_ACCURACY))
}

/// The chain unchanged, as pieces (used by [`Method::None`] and as a fallback).
pub fn passthrough(chain: &Chain<'_>) -> Vec<Move> {
    chain.moves.to_vec()
}

/// Smooths a whole program. Fails only on invalid options.
pub fn smooth(tp: &Toolpath, opts: &SmoothOptions) -> Result<Smoothed, OptionsError> {
    // A stream whose windows never cut a chain.
    let whole = stream::StreamOptions {
        window_moves: usize::MAX,
        ..Default::default()
    };
    let mut s = stream::StreamSmoother::new(opts.clone(), whole)?;
    // Corner methods replace one move by up to three (trimmed line, two curve pieces).
    let growth = if opts.method == Method::None {
        1
    } else {
        OUTPUT_GROWTH
    };
    let mut out = Toolpath {
        blocks: Vec::with_capacity(tp.blocks.len() * growth),
        start: tp.start,
        units: tp.units,
        extra_axes_mask: tp.extra_axes_mask,
    };
    for b in &tp.blocks {
        s.push(b.clone(), &mut out.blocks);
    }
    s.finish(&mut out.blocks);
    Ok(Smoothed {
        toolpath: out,
        report: s.report().clone(),
    })
}

pub(crate) fn smooth_chain(
    chain: &Chain<'_>,
    opts: &SmoothOptions,
    report: &mut SmoothReport,
) -> Vec<Move> {
    if opts.method == Method::None {
        return passthrough(chain);
    }
    // A vertex where the extrusion rate changes (a slicer's travel meeting an extrusion,
    // a prime in place) stays a sharp corner: each stretch of one flow is smoothed on its
    // own, so no curve carries one move's flow into the other.
    let cuts = flow_cuts(chain);
    if cuts.is_empty() {
        return smooth_stretch(chain, opts, report);
    }
    report.corners_stopped += cuts.len();
    let mut out = Vec::with_capacity(chain.moves.len() * 2);
    let mut from = 0;
    for to in cuts.into_iter().chain([chain.moves.len()]) {
        let part = Chain {
            moves: &chain.moves[from..to],
            start_extra: match from {
                0 => chain.start_extra,
                _ => chain.moves[from - 1].extra,
            },
            // The path goes on past a cut: a run there leaves along its line.
            open_ends: [
                from > 0 || chain.open_ends[0],
                to < chain.moves.len() || chain.open_ends[1],
            ],
        };
        out.extend(smooth_stretch(&part, opts, report));
        from = to;
    }
    out
}

/// The moves of `chain` before which the extrusion rate (`E` per mm of path) leaves the
/// previous move's by more than [`crate::path::EXTRA_RATE_VARIANCE`], and on both sides of
/// a motion in place
/// ([`crate::path::rates_agree`]). A move of no length that leaves its extra axes alone
/// (a repeated point) is passed over; one that moves any (a prime in place, a rotary
/// axis indexing with the tool at rest) is a motion of its own, never spread over the
/// moves around it. Otherwise the other extra axes (rotary A B C, linear U V W) ride
/// along the smoothed corners: their rate per mm of path changes at most vertices of a
/// multi-axis program.
fn flow_cuts(chain: &Chain<'_>) -> Vec<usize> {
    let mut cuts = Vec::new();
    let mut before = chain.start_extra;
    let mut last_rate: Option<f64> = None;
    for (k, m) in chain.moves.iter().enumerate() {
        let (Some(start), Some(end)) = (m.extra_start(before), m.extra) else {
            continue;
        };
        before = Some(end);
        let len = m.segment.arclen(screen::FLOW_ARCLEN_ACCURACY_MM);
        if len <= DEGENERATE_MM && start == end {
            continue;
        }
        let de = end[E_AXIS] - start[E_AXIS];
        let rate = if len > DEGENERATE_MM {
            de / len
        } else {
            f64::NAN
        };
        if last_rate.is_some_and(|r| !crate::path::rates_agree(r, rate)) {
            cuts.push(k);
        }
        last_rate = Some(rate);
    }
    cuts
}

/// A line shorter than this many tolerances is a micro-line to [`simplify`]: its
/// direction is not resolved inside the band (camotics_vcarve: 90 % of its lines are
/// shorter than 0.01 mm; butterfly_1000, crown and linuxcnc_blur_torus have none, and
/// merging the nearly collinear points of butterfly_1000's 0.4 mm chords ran slower on
/// LinuxCNC 2.9).
pub(crate) const MICRO_LINE_TOLS: f64 = 2.0;

/// [`smooth_chain`] on a stretch of one flow: its nearly collinear lines merged within
/// [`band_fit::RunOptions::merge_share`] of the tolerance ([`simplify`]) and the method
/// run within the rest.
fn smooth_stretch(chain: &Chain<'_>, opts: &SmoothOptions, report: &mut SmoothReport) -> Vec<Move> {
    let eps = opts.tol_mm * opts.run.merge_share;
    let merged = opts
        .run
        .enabled
        .then(|| simplify::merge_lines(chain.moves, eps, opts.tol_mm * MICRO_LINE_TOLS))
        .flatten();
    let Some(moves) = merged else {
        return smooth_method(chain, opts, report);
    };
    report.lines_merged += chain.moves.len() - moves.len();
    let rest = SmoothOptions {
        tol_mm: opts.tol_mm - eps,
        ..opts.clone()
    };
    let chain = Chain {
        moves: &moves,
        start_extra: chain.start_extra,
        open_ends: chain.open_ends,
    };
    smooth_method(&chain, &rest, report)
}

/// The arc joints, the run mode and the method on a stretch.
fn smooth_method(chain: &Chain<'_>, opts: &SmoothOptions, report: &mut SmoothReport) -> Vec<Move> {
    // The same three steps for every method (its row of the table says how): the arc
    // joints blended, runs of micro-corners fitted as one curve of the method's family (Wu's
    // NURBS fits its runs itself), then the method's corners on what that left.
    let spec = opts.method.spec();
    let Some(curve) = spec.joint_curve else {
        return (spec.smooth)(chain, opts, report);
    };
    let blended =
        arc_joint::blend_arc_joints(chain, opts.tol_mm, opts.straight_angle_deg, curve, report);
    let chain = match &blended {
        Some(moves) => &Chain {
            moves,
            start_extra: chain.start_extra,
            open_ends: chain.open_ends,
        },
        None => chain,
    };
    let rewritten = spec
        .run_family
        .and_then(|f| run_mode::rewrite_runs(chain, opts, f, report));
    let chain = match &rewritten {
        Some(moves) => &Chain {
            moves,
            start_extra: chain.start_extra,
            open_ends: chain.open_ends,
        },
        None => chain,
    };
    (spec.smooth)(chain, opts, report)
}

/// Turning angle (degrees) between the end of `a` and the start of `b`, if both have
/// tangents there.
pub fn turn_angle_deg(a: &Segment, b: &Segment) -> Option<f64> {
    Some(a.end_tangent()?.angle_to(b.start_tangent()?).to_degrees())
}

/// Test polylines: the next step after `pts` (at least one point) for the random step
/// `s`, turned into a degenerate case by `k % 7`: 0 reverses the last step, 1 turns it by
/// 1 degree, 2 repeats it near-collinearly, 3 makes a 1-degree corner (turns by 179), and
/// the rest keep `s`. Shared by the methods' property tests.
#[cfg(test)]
pub(crate) fn degenerate_step(pts: &[Vec3], s: Vec3, k: usize) -> Vec3 {
    let last = if pts.len() >= 2 {
        pts[pts.len() - 1] - pts[pts.len() - 2]
    } else {
        Vec3::X
    };
    let turned = |deg: f64| {
        let a = deg.to_radians();
        Vec3::new(
            last.x * a.cos() - last.y * a.sin(),
            last.x * a.sin() + last.y * a.cos(),
            last.z,
        )
    };
    match k % 7 {
        0 => -last,
        1 => turned(1.0),
        2 => last + Vec3::new(0.0, 1e-7, 0.0),
        3 => turned(179.0),
        _ => s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Line;
    use crate::path::{Block, Event, EventKind};

    /// After `G92 E0` and E-only moves (events), every method continues the extruder
    /// from the value those events left, never from the last move's (audit repro: E ran
    /// backwards after a reset).
    #[test]
    fn extra_axes_continue_from_events() {
        let e = |v: f64| [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, v];
        let event = |line, kind, text: &str| {
            Block::Event(Event {
                line,
                kind,
                text: text.into(),
            })
        };
        let feed = |a: Vec3, b: Vec3, ev: f64, line| {
            let mut m = Move::feed(Line::new(a, b), Some(10.0), line);
            m.extra = Some(e(ev));
            Block::Move(m)
        };
        let (p0, p1, p2, p3) = (
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        );
        let mut tp = Toolpath::new(p0);
        tp.extra_axes_mask = 1 << 6;
        tp.blocks = vec![
            event(1, EventKind::ExtraReset { to: e(0.0) }, "G92 E0"),
            feed(p0, p1, 5.0, 2),
            event(3, EventKind::ExtraReset { to: e(0.0) }, "G92 E0"),
            feed(p1, p2, 1.0, 4),
            feed(p2, p3, 2.0, 5),
            event(
                6,
                EventKind::ExtraMove {
                    to: e(1.5),
                    feed_per_s: Some(30.0),
                },
                "G1 E1.5",
            ),
            feed(p3, p0, 2.5, 7),
        ];
        for method in [Method::Bspline, Method::Arc, Method::Nurbs, Method::Trig] {
            let o = SmoothOptions {
                method,
                tol_mm: 0.05,
                ..Default::default()
            };
            let s = smooth(&tp, &o).unwrap();
            let mut prev: Option<f64> = None;
            for b in &s.toolpath.blocks {
                match b {
                    Block::Move(m) => {
                        let v = m.extra.unwrap()[6];
                        if let Some(p) = prev {
                            assert!(v >= p - 1e-12, "{method:?}: E {p} -> {v}");
                        }
                        prev = Some(v);
                    }
                    Block::Event(ev) => match ev.kind {
                        EventKind::ExtraReset { .. } => prev = None,
                        EventKind::ExtraMove { to, .. } => prev = Some(to[6]),
                        _ => {}
                    },
                }
            }
            // The corner at (10, 10) is smoothed: E there is between 1 and 2 on both sides.
            let second: Vec<f64> = s
                .toolpath
                .moves()
                .filter(|m| m.line == 4 || m.line == 5)
                .map(|m| m.extra.unwrap()[6])
                .collect();
            assert!(second.iter().all(|v| (0.0..=2.0).contains(v)), "{second:?}");
            assert_eq!(s.toolpath.moves().last().unwrap().extra.unwrap()[6], 2.5);
        }
    }

    /// An extruding toolpath through `pts` after `G92 E0`, E at each point from `e`.
    fn extruding(pts: &[Vec3], e: impl Fn(usize) -> f64) -> Toolpath {
        let mut tp = Toolpath::new(pts[0]);
        tp.extra_axes_mask = 1 << 6;
        tp.push_event(Event {
            line: 0,
            kind: EventKind::ExtraReset { to: [0.0; 7] },
            text: "G92 E0".into(),
        });
        for (k, w) in pts.windows(2).enumerate() {
            let mut m = Move::feed(Line::new(w[0], w[1]), Some(10.0), k as u32 + 1);
            m.extra = Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, e(k + 1)]);
            tp.push_move(m);
        }
        tp
    }

    /// A slicer's travel between two extrusions, all G1 (cncjs_sample_slic3r): the
    /// vertices where the flow changes stay where they are, and no output move carries
    /// one move's flow into the other (before, a corner curve spread up to 0.017 mm of
    /// filament over a travel).
    #[test]
    fn a_change_of_flow_keeps_its_vertex() {
        let pts = [
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        ];
        // Extrude 1 mm of filament per 10 mm, travel, extrude again.
        let tp = extruding(&pts, |k| [0.0, 1.0, 1.0, 2.0][k]);
        for method in [Method::Bspline, Method::Arc, Method::Nurbs, Method::Trig] {
            let o = SmoothOptions {
                method,
                tol_mm: 0.05,
                ..Default::default()
            };
            let s = smooth(&tp, &o).unwrap();
            let moves: Vec<&Move> = s.toolpath.moves().collect();
            let mut e0 = 0.0;
            for m in &moves {
                let e1 = m.extra.unwrap()[6];
                let rate = (e1 - e0) / m.segment.arclen(1e-9);
                assert!(
                    rate.abs() < 1e-9 || (rate - 0.1).abs() < 1e-6,
                    "{method:?}: a move at {rate} mm of filament per mm"
                );
                e0 = e1;
            }
            for v in &pts[1..3] {
                assert!(
                    moves.iter().any(|m| m.segment.end().dist(*v) < 1e-12),
                    "{method:?}: no move ends at {v:?}"
                );
            }
        }
    }

    /// Only the extrusion and motions in place cut a chain: a rotary axis turning at a
    /// different rate per mm on every move, a repeated point inside an extrusion, leave
    /// the corners smoothed; `E` moved in place (a prime), or a rotary axis (an
    /// indexing), cuts on both sides.
    #[test]
    fn flow_cuts_follow_the_extrusion_and_motions_in_place() {
        let pts = [
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        ];
        let tp = extruding(&pts, |k| [0.0, 1.0, 1.0, 2.0, 3.0][k]);
        let moves: Vec<Move> = tp.moves().cloned().collect();
        let chain = |moves| Chain {
            moves,
            start_extra: Some([0.0; 7]),
            open_ends: [false; 2],
        };
        assert!(flow_cuts(&chain(&moves)).is_empty());
        // A at 1, 9 and 20 degrees per mm (still at the repeated point), E unchanged: no
        // cut.
        let mut rotary = moves.clone();
        for (k, m) in rotary.iter_mut().enumerate() {
            m.extra.as_mut().unwrap()[0] = [10.0, 10.0, 100.0, 300.0][k];
        }
        assert!(flow_cuts(&chain(&rotary)).is_empty());
        // A prime in place at the repeated point: cuts before and after it.
        let mut prime = moves.clone();
        for m in prime.iter_mut().skip(1) {
            m.extra.as_mut().unwrap()[E_AXIS] += 0.5;
        }
        assert_eq!(flow_cuts(&chain(&prime)), vec![1, 2]);
        // A rotary axis indexing in place at the repeated point (E unchanged): the same.
        let mut index = moves.clone();
        for m in index.iter_mut().skip(1) {
            m.extra.as_mut().unwrap()[0] = 90.0;
        }
        assert_eq!(flow_cuts(&chain(&index)), vec![1, 2]);
        // Smoothed, the extrusion with a repeated point keeps its corners rounded.
        let o = SmoothOptions {
            method: Method::Bspline,
            tol_mm: 0.05,
            ..Default::default()
        };
        let s = smooth(&tp, &o).unwrap();
        assert_eq!(s.report.corners_smoothed, 2);
        assert_eq!(s.report.corners_stopped, 0);
    }

    /// A closed extrusion loop between two travels is cut from them, but its ends are not
    /// a stop: `bspline` gives it no closing hooks, and the loop leaves its start along
    /// its first line.
    #[test]
    fn a_cut_loop_is_left_along_its_first_line() {
        let pts = [
            Vec3::new(-5.0, -5.0, 0.0),
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::ZERO,
            Vec3::new(-5.0, 5.0, 0.0),
        ];
        let tp = extruding(&pts, |k| [0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0][k]);
        let o = SmoothOptions {
            method: Method::Bspline,
            ..Default::default()
        };
        let s = smooth(&tp, &o).unwrap();
        let from_start: Vec<&Move> = s
            .toolpath
            .moves()
            .filter(|m| m.segment.start() == Vec3::ZERO && m.line == 2)
            .collect();
        assert_eq!(from_start.len(), 1, "{from_start:?}");
        let t = from_start[0].segment.start_tangent().unwrap();
        assert!(t.dist(Vec3::X) < 1e-9, "leaves along {t:?}");
        assert_eq!(s.report.corners_stopped, 2);
    }

    /// A run fitted as one curve puts the extrusion where the program has it along the
    /// path: each output move ends with the program's E at the foot of its end point,
    /// however the curve's parameter runs along the lines (before, a 1.55 mm line of
    /// cncjs_sample_slic3r got its E up to 0.2 mm of path early).
    #[test]
    fn a_fitted_run_keeps_the_extrusion_along_the_path() {
        // Chords of uneven length along a circle of radius 6, 0.05 mm of filament per mm.
        let chords = [0.2, 0.6, 1.55, 1.55, 1.55, 1.1, 0.6, 1.0, 1.55, 1.2];
        let (r, mut a) = (6.0, 0.0f64);
        let mut pts = vec![Vec3::new(r, 0.0, 0.0)];
        for c in chords {
            a += 2.0 * (c / (2.0 * r)).asin();
            pts.push(Vec3::new(r * a.cos(), r * a.sin(), 0.0));
        }
        let s_at: Vec<f64> = std::iter::once(0.0)
            .chain(chords.iter().scan(0.0, |s, c| {
                *s += c;
                Some(*s)
            }))
            .collect();
        let rate = 0.05;
        let tp = extruding(&pts, |k| rate * s_at[k]);
        // The program's E at the foot of `q` on the polyline.
        let program_e = |q: Vec3| {
            let (mut best, mut e) = (f64::INFINITY, 0.0);
            for k in 0..chords.len() {
                let (p0, p1) = (pts[k], pts[k + 1]);
                let d = p1 - p0;
                let t = ((q - p0).dot(d) / d.norm_sq()).clamp(0.0, 1.0);
                let dist = q.dist(p0 + d * t);
                if dist < best {
                    (best, e) = (dist, rate * (s_at[k] + t * chords[k]));
                }
            }
            e
        };
        for method in [Method::Bspline, Method::Arc, Method::Trig] {
            let o = SmoothOptions {
                method,
                tol_mm: 0.01,
                ..Default::default()
            };
            let s = smooth(&tp, &o).unwrap();
            assert!(s.report.runs_fitted >= 1, "{method:?}: no run");
            for m in s.toolpath.moves() {
                let q = m.segment.end();
                let e = m.extra.unwrap()[6];
                // Within the extrusion of twice the tolerance along the path.
                assert!(
                    (e - program_e(q)).abs() <= rate * 0.02,
                    "{method:?}: E {e} at {q:?}, the program's {}",
                    program_e(q)
                );
            }
        }
    }

    #[test]
    fn none_keeps_everything_and_extra_axes_interpolate() {
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.push_move(Move::rapid(Line::new(Vec3::ZERO, Vec3::X), 1));
        let mut m = Move::feed(Line::new(Vec3::X, Vec3::new(3.0, 0.0, 0.0)), Some(10.0), 2);
        m.extra = Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 4.0]);
        tp.push_move(m);
        tp.push_event(Event {
            line: 3,
            kind: EventKind::Coolant,
            text: "M8".into(),
        });
        let s = smooth(&tp, &SmoothOptions::default()).unwrap();
        assert_eq!(s.toolpath, tp);
        assert_eq!(s.report.chains, 1);
        let moves: Vec<Move> = tp.moves().cloned().collect();
        let chain = Chain {
            moves: &moves[1..],
            start_extra: Some([0.0; 7]),
            open_ends: [false; 2],
        };
        let e = extra_at(
            &chain,
            ChainPos {
                index: 0,
                frac: 0.25,
            },
        )
        .unwrap();
        assert_eq!(e[6], 1.0);
        assert_eq!(
            point_at(
                &chain,
                ChainPos {
                    index: 0,
                    frac: 0.5
                }
            ),
            Vec3::new(2.0, 0.0, 0.0)
        );
        assert!(smooth(
            &tp,
            &SmoothOptions {
                tol_mm: -1.0,
                ..Default::default()
            }
        )
        .is_err());
    }
}

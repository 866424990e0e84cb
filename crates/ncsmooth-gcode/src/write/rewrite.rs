//! The smoothed program written into the program's own text.
//!
//! Every physical line of the source is copied verbatim (its comments, M codes, block
//! delete mark, `%` markers, O-word control flow, canned cycles, offsets, and everything
//! after `M2`/`M30`), except the lines whose motion the smoothing changed. Those lines
//! ([`flags::REPLACEABLE`] ones: executed once at the top level, nothing but motion, plane,
//! distance-mode and feed words) are replaced, run by run, by the smoothed moves that carry
//! their line numbers ([`Move::line`]), written by the same motion writer as
//! [`crate::write()`]:
//!
//! * in the program's units (inch programs stay inch, with one more decimal than
//!   [`RewriteOptions::decimals`]), absolute coordinates (a `G90` before the run and a
//!   `G91` after it when the program was incremental), arc centres in the program's arc
//!   distance mode, E words in its extruder mode, X as a diameter under G7;
//! * only the axes whose position is known there: an axis the program never established
//!   (a 2-D program that never commands Z) is never written, and a smoothed move that would
//!   change one is an error ([`RewriteError::UnknownAxis`]);
//! * after the run, the state the next verbatim line expects: distance mode, plane and the
//!   programmed feed are restored, and the first following line that relies on the modal
//!   motion code (axis words without G0-G3) gets that code put in front of its words.
//!
//! A line whose moves were not changed is copied verbatim even if it could have been
//! replaced, so `--method none` writes the program unchanged (plus the header lines and,
//! when blending is bounded ([`RewriteOptions::blend`]), a `G64 P Q` before the first
//! motion and after each line of the program's own that sets a looser mode). A
//! pinned move ([`Move::pinned`]) that comes back changed is an error
//! ([`RewriteError::PinnedChanged`]): the smoothing must never alter them.

use super::frame::{ChainMode, Frame};
use super::motion::MotionWriter;
use crate::controller::floor::Floor;
use crate::controller::linuxcnc::blend::{BlendSchedule, RunEnd, RunEnds};
use crate::controller::linuxcnc::g64::{blend_text, path_mode_text, push_blend_line};
use crate::controller::linuxcnc::Blend;
use crate::interpreter::program::Program;
use crate::numbers::{push_fixed, unit_mm};
use crate::source::{flags, LineInfo, PathMode, Plane, WriteState};
use ncsmooth::geom::{
    Arc, Flatten, Line, ParamCurve, ParamCurveArclen, ParamCurveNearest, Segment, Vec3,
};
use ncsmooth::path::{Block, EventKind, ExtraAxes, Move, MoveKind, Toolpath};

mod options;
use crate::numbers::decimals_for;
pub use options::*;

/// Why a rewrite is impossible (a bug in what produced the toolpath, never bad input).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RewriteError {
    /// A move that must be written as programmed came back changed.
    #[error("line {line}: a move that must stay as programmed (pinned) was changed")]
    PinnedChanged {
        /// 1-based source line.
        line: u32,
    },
    /// A smoothed move would change an axis whose position is unknown there.
    #[error("line {line}: the smoothed path would move {axis}, whose position is unknown there")]
    UnknownAxis {
        /// 1-based source line.
        line: u32,
        /// The axis.
        axis: char,
    },
    /// The output's moves do not follow the program's lines.
    #[error("smoothed move tagged line {line}, which is not in the program")]
    BadLine {
        /// The tag.
        line: u32,
    },
}

/// The moves of each line: `moves` grouped by line (in their order within a line), and
/// the `(first, end)` index range of each line's group.
type ByLine<'a> = (Vec<&'a Move>, Vec<(usize, usize)>);

/// Groups `moves` by line (see [`ByLine`]).
fn moves_by_line<'a>(moves: &[&'a Move], n_lines: usize) -> Result<ByLine<'a>, RewriteError> {
    let mut line_of = Vec::with_capacity(moves.len());
    let mut last = 0usize;
    for m in moves {
        let l = (m.line as usize).saturating_sub(1);
        if l >= n_lines {
            return Err(RewriteError::BadLine { line: m.line });
        }
        // Tags of smoothed moves may not go backwards: such a move belongs to the latest
        // line. Pinned moves keep their line: a subroutine runs lines before or after its
        // caller's, and may run them more than once.
        let l = if m.pinned { l } else { l.max(last) };
        if !m.pinned {
            last = l;
        }
        line_of.push(l);
    }
    let mut order: Vec<usize> = (0..moves.len()).collect();
    order.sort_by_key(|&k| line_of[k]);
    let grouped: Vec<&Move> = order.iter().map(|&k| moves[k]).collect();
    let mut ranges = vec![(0usize, 0usize); n_lines];
    for (k, &o) in order.iter().enumerate() {
        let r = &mut ranges[line_of[o]];
        if r.1 == 0 {
            *r = (k, k + 1);
        } else {
            r.1 = k + 1;
        }
    }
    Ok((grouped, ranges))
}

/// Under a [`BlockFloor`] (the stepper dialects): the output's moves with every corner
/// transition shorter than two floors that ends a run where a verbatim line (a comment)
/// separates two smoothed lines replaced by the programmed corner (the line before it, or
/// the transition itself after a curve, ends at the programmed vertex, where the line
/// after it starts); `None` when there is none. Written, such a transition lies between
/// two points no lifting may move (the run's end stays, the verbatim line comes after
/// it), so it is one or two blocks shorter than the floor: cncjs_jsdc's plunge-to-cut and
/// cut-to-retract corners gave grbl blocks of 3 steps. The programmed corner is the
/// programmed path itself (no deviation); a stepper controller takes it at its own
/// junction speed, and the feed changes there anyway.
fn floor_corners(
    output: &Toolpath,
    orig: &[&Move],
    orig_by: &[(usize, usize)],
    floor: Option<BlockFloor>,
) -> Option<Vec<Move>> {
    let floor = floor?;
    let moves: Vec<&Move> = output.moves().collect();
    // None of the lines strictly between `a` and `b` (numbers) moves (a repeated point at
    // most: the programmed path goes straight from line `a`'s last move to line `b`'s
    // first), and one of them has no move at all: a verbatim line separates the runs.
    let verbatim_between = |a: u32, b: u32| {
        let between = (a as usize)..(b as usize).saturating_sub(1);
        let still = |j: usize| {
            orig[orig_by[j].0..orig_by[j].1]
                .iter()
                .all(|m| m.segment.start().dist(m.segment.end()) <= RETAG_ARCLEN_ACCURACY_MM)
        };
        between.clone().all(still) && between.into_iter().any(|j| orig_by[j].0 == orig_by[j].1)
    };
    // The programmed move that starts line `line`.
    let first_of = |line: u32| {
        let (a, b) = orig_by[(line as usize).checked_sub(1)?];
        (b > a).then(|| orig[a])
    };
    // The programmed vertex that ends line `line` (its last programmed move's end).
    let vertex_after = |line: u32| {
        let (a, b) = orig_by[(line as usize).checked_sub(1)?];
        (b > a).then(|| orig[b - 1])
    };
    // (index of the transition, programmed corner, extra axes there, whether the line
    // before it is lengthened to the corner)
    let corners: Vec<(usize, Vec3, Option<ncsmooth::path::ExtraAxes>, bool)> = (1..moves
        .len()
        .saturating_sub(1))
        .filter_map(|k| {
            let (prev, m, next) = (moves[k - 1], moves[k], moves[k + 1]);
            let lines = !matches!(m.segment, Segment::Line(_));
            let plain = !prev.pinned && !m.pinned && !next.pinned;
            if !(lines
                && plain
                && next.line > m.line + 1
                && verbatim_between(m.line, next.line)
                && m.segment.arclen(RETAG_ARCLEN_ACCURACY_MM) < 2.0 * floor.min_block_mm)
            {
                return None;
            }
            let v = vertex_after(m.line)?;
            let corner = v.segment.end();
            // The transition rounds that corner: it starts on the (straight) move ending
            // there and ends on the (straight) move starting there, so the lines that
            // replace it stay within the tolerance of them (distance to a line is
            // convex).
            let dist = |seg: &Segment, p: Vec3| {
                seg.nearest(p, RETAG_ARCLEN_ACCURACY_MM).distance_sq.sqrt()
            };
            let starts_on = dist(&v.segment, m.segment.start()) <= floor.tol_mm;
            let after = first_of(next.line)?;
            if !matches!(v.segment, Segment::Line(_)) || !matches!(after.segment, Segment::Line(_))
            {
                return None;
            }
            let ends_on = after.segment.start().dist(corner) <= RETAG_ARCLEN_ACCURACY_MM
                && dist(&after.segment, m.segment.end()) <= floor.tol_mm;
            (starts_on && ends_on).then_some((
                k,
                corner,
                v.extra,
                matches!(prev.segment, Segment::Line(_)) && prev.line == m.line,
            ))
        })
        .collect();
    let arc_joints = arc_joint_corners(&moves, orig, orig_by, floor);
    if corners.is_empty() && arc_joints.is_empty() {
        return None;
    }
    let mut out: Vec<Move> = moves.iter().map(|m| (*m).clone()).collect();
    let mut dropped = vec![false; out.len()];
    let mut inserted: Vec<Option<Move>> = vec![None; out.len()];
    for (k, arc, rest, extra) in arc_joints {
        out[k - 1].segment = arc.into();
        out[k - 1].extra = extra.or(out[k - 1].extra);
        dropped[k] = true;
        out[k + 1].segment = rest;
    }
    for &(k, corner, extra, line_before) in &corners {
        // A line of the same program line before the corner is lengthened to it; else
        // the transition becomes the line from its start to the corner (within the band:
        // both ends are).
        let before = if line_before {
            dropped[k] = true;
            &mut out[k - 1]
        } else {
            &mut out[k]
        };
        before.segment = Line::new(before.segment.start(), corner).into();
        before.extra = extra.or(before.extra);
        // A line after it starts at the corner; a curve after it (a fitted run) is reached
        // by the line from the corner to the transition's end, which starts the next run
        // (whose lifting may then drop that end).
        if let Segment::Line(l) = &out[k + 1].segment {
            out[k + 1].segment = Line::new(corner, l.p1).into();
        } else {
            // It lies on the next programmed move: at that move's feed.
            inserted[k] = Some(Move {
                segment: Line::new(corner, moves[k].segment.end()).into(),
                line: moves[k + 1].line,
                feed_mm_s: moves[k + 1].feed_mm_s,
                ..moves[k].clone()
            });
        }
    }
    Some(
        out.into_iter()
            .zip(dropped)
            .zip(inserted)
            .flat_map(|((m, d), ins)| (!d).then_some(m).into_iter().chain(ins))
            .collect(),
    )
}

/// Under a [`BlockFloor`]: the blends of a programmed arc into the programmed line or arc
/// after it ([`ncsmooth::smooth::arc_joint`]) shorter than two floors, as `(index of the
/// blend, the arc before it lengthened to the programmed corner, the move after it started
/// there, extra axes at the corner)`. Such a blend starts on the arc, which is written as
/// it is, so its first block cannot be lifted (linuxcnc_blur_torus, trig on grbl: blocks
/// of 0.012-0.013 mm after a G3, 0.0089 mm as grbl executed them). The programmed corner
/// is the programmed path itself; the controller takes it at its junction speed.
type ArcJointCorner = (usize, Arc, Segment, Option<ncsmooth::path::ExtraAxes>);

/// Whether the arcs `a` and `b` lie on one circle (to [`RETAG_ARCLEN_ACCURACY_MM`]).
fn same_circle(a: &Arc, b: &Arc) -> bool {
    a.center.dist(b.center) <= RETAG_ARCLEN_ACCURACY_MM
        && (a.radius - b.radius).abs() <= RETAG_ARCLEN_ACCURACY_MM
        && a.normal().dist(b.normal()) <= RETAG_ARCLEN_ACCURACY_MM
}

/// The written move `next` (a part of the programmed `after`) started at `corner`, or
/// `None` when it is not on `after` or of another kind.
fn restart_at(next: &Segment, after: &Segment, corner: Vec3) -> Option<Segment> {
    match (next, after) {
        (Segment::Line(n), Segment::Line(_)) => Some(Line::new(corner, n.p1).into()),
        (Segment::Arc(n), Segment::Arc(p)) if same_circle(n, p) => {
            Arc::from_center_spiral(corner, n.end(), p.center, p.normal(), true, 0).map(Into::into)
        }
        _ => None,
    }
}

/// See [`ArcJointCorner`].
fn arc_joint_corners(
    moves: &[&Move],
    orig: &[&Move],
    orig_by: &[(usize, usize)],
    floor: BlockFloor,
) -> Vec<ArcJointCorner> {
    (1..moves.len().saturating_sub(1))
        .filter_map(|k| {
            let (prev, m, next) = (moves[k - 1], moves[k], moves[k + 1]);
            let Segment::Arc(a) = &prev.segment else {
                return None;
            };
            if prev.pinned
                || m.pinned
                || next.pinned
                || matches!(m.segment, Segment::Line(_))
                || m.segment.arclen(RETAG_ARCLEN_ACCURACY_MM) >= 2.0 * floor.min_block_mm
            {
                return None;
            }
            // The programmed arc the written one is part of, and the move after it.
            let (_, end) = orig_by[(prev.line as usize).checked_sub(1)?];
            let v = orig.get(end.checked_sub(1)?)?;
            let after = &orig.get(end)?.segment;
            let Segment::Arc(p) = &v.segment else {
                return None;
            };
            let corner = p.end();
            let on_after = |q: Vec3| {
                after
                    .nearest(q, RETAG_ARCLEN_ACCURACY_MM)
                    .distance_sq
                    .sqrt()
                    <= floor.tol_mm
            };
            if !(same_circle(a, p)
                && after.start().dist(corner) <= RETAG_ARCLEN_ACCURACY_MM
                && on_after(m.segment.end())
                && on_after(next.segment.end()))
            {
                return None;
            }
            let arc = Arc::from_center_spiral(a.start(), corner, p.center, p.normal(), true, 0)?;
            let rest = restart_at(&next.segment, after, corner)?;
            Some((k, arc, rest, v.extra))
        })
        .collect()
}

/// Accuracy (mm) of the arc lengths [`floor_corners`] compares with the floor.
const RETAG_ARCLEN_ACCURACY_MM: f64 = 1e-6;

fn same_moves(a: &[&Move], b: &[&Move]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| {
            x.segment == y.segment
                && x.kind == y.kind
                && x.feed_mm_s == y.feed_mm_s
                && x.extra == y.extra
        })
}

fn plane_code(p: Plane) -> u8 {
    match p {
        Plane::XY => 17,
        Plane::XZ => 18,
        Plane::YZ => 19,
    }
}

/// Where `G<n> ` goes in a verbatim line: after leading blanks, a block-delete `/` and an
/// `N` number.
fn motion_prefix_at(line: &[u8]) -> usize {
    let b = line;
    let mut i = 0;
    let skip_ws = |i: &mut usize| {
        while *i < b.len() && (b[*i] == b' ' || b[*i] == b'\t') {
            *i += 1;
        }
    };
    skip_ws(&mut i);
    if b.get(i) == Some(&b'/') {
        i += 1;
        skip_ws(&mut i);
    }
    if matches!(b.get(i), Some(b'N' | b'n')) {
        let mut j = i + 1;
        while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.' || b[j] == b' ') {
            j += 1;
        }
        if j > i + 1 {
            i = j;
        }
    }
    i
}

/// The motion code text of `motion10` (`20` -> `G2`).
fn motion_text(motion10: u16) -> String {
    let mut s = format!("G{}", motion10 / 10);
    if motion10 % 10 != 0 {
        s.push_str(&format!(".{}", motion10 % 10));
    }
    s
}

/// Writes `output` (the smoothed toolpath of `program`) into the text of `src`, the
/// program's source. See the module doc.
pub fn rewrite(
    src: &[u8],
    program: &Program,
    output: &Toolpath,
    opts: &RewriteOptions,
) -> Result<Vec<u8>, RewriteError> {
    let lines = &program.source.lines;
    let orig: Vec<&Move> = program.toolpath.moves().collect();
    let (orig, orig_by) = moves_by_line(&orig, lines.len())?;
    // LinuxCNC's programmed corners between runs keep the runs' `P` (faster than giving
    // them the programmed corner's, docs/benchmarks/2026-12-03.md).
    let stepper_floor = opts.block_floor.filter(|f| f.corner.is_none());
    let cornered = floor_corners(output, &orig, &orig_by, stepper_floor);
    let out: Vec<&Move> = match &cornered {
        Some(moves) => moves.iter().collect(),
        None => output.moves().collect(),
    };
    let (out, out_by) = moves_by_line(&out, lines.len())?;
    let eol = if src.windows(2).any(|w| w == b"\r\n") {
        "\r\n"
    } else {
        "\n"
    };
    let extra_mask = program.toolpath.extra_axes_mask;
    let extra_before = extra_before_lines(&program.toolpath, lines.len());
    let (resets_before, untracked_before, setters_before) =
        events_before_lines(&program.toolpath, lines.len());
    // Relative E: what the last run's written increments left the machine ahead of the
    // program, and the resets before the line it closed at.
    let mut e_carry: (f64, u32) = (0.0, 0);
    let mut s: Vec<u8> = Vec::with_capacity(src.len() + src.len() / 4 + 256);
    let changed = changed_lines(lines, (&orig, &orig_by), (&out, &out_by), opts)?;
    // The first smoothed move of the run of changed lines starting at `i` (its index).
    let first_move = |i: usize| {
        (i..lines.len())
            .take_while(|&j| changed[j])
            .find(|&j| out_by[j].1 > out_by[j].0)
            .map(|j| out_by[j].0)
    };
    // The extra axes where smoothed move `k` starts: at the end of the smoothed move before
    // it (a curve may have carried them past the line the run starts on: a slicer's wipe
    // begun in the corner before it), or the program's before its line where an extra-axis
    // event came between.
    let extra_at_start = |k: usize| -> Option<ExtraAxes> {
        let line = (out[k].line as usize).saturating_sub(1);
        let program = extra_before.get(line).copied().flatten();
        let Some(prev) = k.checked_sub(1).map(|p| out[p]) else {
            return program;
        };
        // (`prev.line` is 1-based: the lines after it start there.)
        let after_prev = (prev.line as usize).min(line);
        if setters_before.get(line) != setters_before.get(after_prev) {
            program
        } else {
            prev.extra.or(program)
        }
    };
    let mut region: Option<Region> = None;
    let mut runs_bound_over: Option<PathMode> = None;
    // Motion code the next modal-motion line must be given, after a region.
    let mut pending_motion: Option<u16> = None;
    let rapids = rapids_ahead(lines, &orig, &orig_by, &changed);
    let verbatim_at = |i: usize| {
        opts.verbatim_blend_in_force()
            .filter(|_| rapids[i])
            .or(opts.blend)
    };
    // Bounds are written in the main program's text (a subprogram after its end is
    // copied as it is; a call is bounded before it).
    let main_end = program
        .source
        .end_line
        .unwrap_or(lines.len())
        .min(lines.len());
    let first_motion = first_loose_motion(lines, main_end, verbatim_at);
    // The program has set a path mode since the last motion line, or run control flow
    // (a call, a loop) that may have: LinuxCNC blends a junction within the smaller of its
    // two moves' tolerances (`tcFindBlendTolerance`), so bounding every copied move after
    // it leaves no junction unbounded. A line's recorded state is that of its first run:
    // after control flow in a program that loosens the mode anywhere, the bound is
    // written whatever that state says.
    let (mut mode_set, mut control_run) = (false, false);
    let loosens = loosening_modes(lines, opts.blend);
    let block_values = block_values_of(&program.toolpath, lines.len());
    for (i, info) in lines.iter().enumerate() {
        let w = &out[out_by[i].0..out_by[i].1];
        let text = &src[info.start..info.end];
        // A value of the line's motion (`S`) goes on its first block.
        let lead = block_values[i].as_deref().filter(|_| changed[i]);
        // Move by move, a run is written line by line, the last line when the run ends;
        // a chain of lines ends where a block value comes.
        if let Some(r) = region
            .as_mut()
            .filter(|r| changed[i] && (r.w.frame.chain.is_none() || lead.is_some()))
        {
            r.flush(&mut s, &orig, &untracked_before)?;
        }
        let control = executed_control(info);
        if let (Some(b), true) = (verbatim_at(i), executed_motion(info) || control) {
            // Before the first motion, and after the program set a mode of its own (a
            // `G64` without `P`), copied motion in a looser mode than ours is bounded.
            // (A replaced run writes its own `G64`.)
            let loose = info.before.path.blend_bound_mm() > b.p_mm + b.q_mm;
            let after = (mode_set && loose) || (control_run && loosens);
            if !changed[i] && i < main_end && (first_motion == Some(i) || after) {
                push_blend_line(&mut s, b, info.before.units, opts.decimals, eol);
                // (The rapids' bound below is this one or looser.)
                runs_bound_over = None;
            }
            (mode_set, control_run) = (false, false);
        }
        if changed[i] {
            let r = region.get_or_insert_with(|| {
                let k = first_move(i);
                let first = k.map(|k| out[k]);
                let line = first.map_or(i, |m| (m.line as usize).saturating_sub(1));
                let extra = k.and_then(extra_at_start);
                let resets = resets_before.get(line).copied().unwrap_or(0);
                let carry = if resets == e_carry.1 { e_carry.0 } else { 0.0 };
                Region::open(&mut s, eol, info, first, (extra_mask, extra, carry), opts)
            });
            if let Some(words) = lead {
                r.due_lead(&mut s);
                r.w.lead_words = Some(words.to_string());
            }
            r.pending.extend_from_slice(w);
            r.add_program(orig_by[i], &orig);
            r.end_state = info.state;
        } else {
            if let Some(mut r) = region.take() {
                // The verbatim lines continue from the programmed point, to the digit.
                r.w.exact_end = r.program_end;
                r.flush(&mut s, &orig, &untracked_before)?;
                e_carry = (r.w.relative_e_carry(), resets_before[i]);
                let after = verbatim_at(i);
                pending_motion = r.close(&mut s, eol, opts.decimals, after);
                // The runs' bound left in force over copied feed lines, in the program's
                // mode at this line.
                runs_bound_over = (after == opts.blend).then_some(info.before.path);
            }
            // At the first rapid after the copied feed lines (only rapids follow), the
            // verbatim bound, unless the program has set a mode of its own since.
            let moves_here = orig_by[i].0 < orig_by[i].1;
            if let (Some(path), Some(vb), true) =
                (runs_bound_over, verbatim_at(i), rapids[i] && moves_here)
            {
                // (Compared by bound: a `G64` without `Q` holds a NaN.)
                let bound = path.blend_bound_mm();
                let same = bound == info.before.path.blend_bound_mm();
                if same && bound > vb.p_mm + vb.q_mm && Some(vb) != opts.blend {
                    push_blend_line(&mut s, vb, info.before.units, opts.decimals, eol);
                }
                runs_bound_over = None;
            }
            let last_line = i + 1 == lines.len();
            let newline = !last_line || src.ends_with(b"\n");
            copy_line(&mut s, text, info, &mut pending_motion, newline);
            if info.has(flags::EXECUTED) && info.has(flags::PATH_MODE) {
                // The program's own mode after control flow: its state is this line's.
                (mode_set, control_run) = (true, false);
            }
            control_run |= control;
        }
    }
    if let Some(mut r) = region.take() {
        r.flush(&mut s, &orig, &untracked_before)?;
        // Nothing moves after the last run.
        r.close(&mut s, eol, opts.decimals, opts.blend);
    }
    if opts.header.is_some() && !(s.is_empty() || s.ends_with(b"\n")) {
        s.extend_from_slice(eol.as_bytes());
    }
    write_header(&mut s, opts, eol);
    Ok(s)
}

/// Per line (0-based), the text of the value its motion carries
/// ([`EventKind::SpindleSpeed`]), if any.
fn block_values_of(tp: &Toolpath, n_lines: usize) -> Vec<Option<String>> {
    let mut out = vec![None; n_lines];
    for e in tp.events() {
        if let (EventKind::SpindleSpeed(_), Some(slot)) =
            (&e.kind, out.get_mut((e.line as usize).wrapping_sub(1)))
        {
            *slot = Some(e.text.clone());
        }
    }
    out
}

/// Per line, the events before it ([`extra_events_before_lines`]) that the runs depend on:
/// the extra-axis resets, the untracked motions and the events that set extra axes.
fn events_before_lines(tp: &Toolpath, n_lines: usize) -> (Vec<u32>, Vec<u32>, Vec<u32>) {
    let resets_before =
        extra_events_before_lines(tp, n_lines, |k| matches!(k, EventKind::ExtraReset { .. }));
    // Motions the interpreter could not place (a move from an unknown position): LinuxCNC
    // runs and blends them, so a run next to one does not start or end at rest.
    let untracked_before =
        extra_events_before_lines(tp, n_lines, |k| matches!(k, EventKind::Untracked { .. }));
    let setters_before = extra_events_before_lines(tp, n_lines, |k| {
        matches!(
            k,
            EventKind::ExtraMove { .. }
                | EventKind::ExtraReset { .. }
                | EventKind::Untracked { extra: Some(_) }
        )
    });
    (resets_before, untracked_before, setters_before)
}

/// Appends the options' header, one `; ` comment line per line.
fn write_header(s: &mut Vec<u8>, opts: &RewriteOptions, eol: &str) {
    if let Some(h) = &opts.header {
        for l in h.lines() {
            s.extend_from_slice(b"; ");
            s.extend_from_slice(l.as_bytes());
            s.extend_from_slice(eol.as_bytes());
        }
    }
}

/// Per line, whether its moves are replaced: they changed, or (with
/// [`RewriteOptions::rewrite_unchanged`]) it is replaceable and feeds. A line that may not
/// be replaced and changed is an error.
fn changed_lines(
    lines: &[LineInfo],
    (orig, orig_by): (&[&Move], &[(usize, usize)]),
    (out, out_by): (&[&Move], &[(usize, usize)]),
    opts: &RewriteOptions,
) -> Result<Vec<bool>, RewriteError> {
    let mut changed = vec![false; lines.len()];
    for (i, info) in lines.iter().enumerate() {
        let o = &orig[orig_by[i].0..orig_by[i].1];
        let w = &out[out_by[i].0..out_by[i].1];
        changed[i] = !same_moves(o, w)
            || (opts.rewrite_unchanged
                && info.has(flags::REPLACEABLE)
                && w.iter().any(|m| !m.is_rapid()));
        if changed[i] && !info.has(flags::REPLACEABLE) {
            return Err(RewriteError::PinnedChanged { line: i as u32 + 1 });
        }
    }
    Ok(changed)
}

/// Copies the line `text` (of `info`), with the motion code a region left pending put in
/// front of its words when it is a modal-motion line, and `\n` after it when `newline`.
fn copy_line(
    s: &mut Vec<u8>,
    text: &[u8],
    info: &LineInfo,
    pending_motion: &mut Option<u16>,
    newline: bool,
) {
    match *pending_motion {
        Some(code) if info.has(flags::MODAL_MOTION) => {
            let at = motion_prefix_at(text);
            s.extend_from_slice(&text[..at]);
            s.extend_from_slice(motion_text(code).as_bytes());
            s.push(b' ');
            s.extend_from_slice(&text[at..]);
            *pending_motion = None;
        }
        _ => {
            if info.has(flags::EXPLICIT_MOTION) {
                *pending_motion = None;
            }
            s.extend_from_slice(text);
        }
    }
    if newline {
        s.push(b'\n');
    }
}

/// Per line, the program's extra-axis values before its first block (a move's values
/// are those at its end; an extra-axis move or reset sets them), `None` before any.
/// Before the first move that carries them, [`Move::extra_start`] (`E` at 0).
fn extra_before_lines(tp: &Toolpath, n_lines: usize) -> Vec<Option<ExtraAxes>> {
    let mut out: Vec<Option<ExtraAxes>> = vec![None; n_lines];
    let mut seen = vec![false; n_lines];
    let mut last: Option<ExtraAxes> = None;
    for b in &tp.blocks {
        let line = match b {
            Block::Move(m) => m.line,
            Block::Event(e) => e.line,
        };
        if let (None, Block::Move(m)) = (last, b) {
            last = m.extra_start(None);
        }
        let l = (line as usize).saturating_sub(1);
        if l < n_lines && !seen[l] {
            seen[l] = true;
            out[l] = last;
        }
        last = b.extra_after(last);
    }
    out
}

/// Per line (0-based): the events of the kinds `counted` on the lines before it.
fn extra_events_before_lines(
    tp: &Toolpath,
    n_lines: usize,
    counted: impl Fn(&EventKind) -> bool,
) -> Vec<u32> {
    let mut at = vec![0u32; n_lines + 1];
    for b in &tp.blocks {
        if let Block::Event(e) = b {
            if counted(&e.kind) {
                let l = (e.line as usize).saturating_sub(1).min(n_lines);
                at[l] += 1;
            }
        }
    }
    let mut sum = 0;
    at.iter()
        .map(|&k| {
            let before = sum;
            sum += k;
            before
        })
        .collect()
}

/// `G80` as a motion code times ten ([`crate::source::WriteState::motion10`]).
const MOTION_CANCELLED10: u16 = 800;

/// Per line: whether the copied lines from it up to the next replaced one move, and only
/// at rapid, so that the verbatim bound ([`RewriteOptions::verbatim_blend`]) may be set
/// there. A copied feed line stays under the runs' bound: LinuxCNC accelerates a line that
/// an arc blend under a looser `P` joins at half the rate. A motion line without moves of
/// its own (from a position not known) counts as a feed unless it is a `G0`.
fn rapids_ahead(
    lines: &[LineInfo],
    orig: &[&Move],
    orig_by: &[(usize, usize)],
    changed: &[bool],
) -> Vec<bool> {
    // (only rapids so far, any move so far), from the end.
    let mut ahead = (true, false);
    let mut out = vec![false; lines.len()];
    for i in (0..lines.len()).rev() {
        if changed[i] {
            ahead = (true, false);
            continue;
        }
        let own = &orig[orig_by[i].0..orig_by[i].1];
        let l = &lines[i];
        // A motion line whose moves are not known; G80 (motion mode cancelled) moves
        // nothing.
        let unknown = own.is_empty()
            && l.has(flags::EXECUTED)
            && (l.has(flags::MODAL_MOTION) || l.has(flags::EXPLICIT_MOTION))
            && l.state.motion10 != MOTION_CANCELLED10;
        // A zero-length feed move (camotics_vcarve's `G1` to where its `G0` ended) is no
        // motion for LinuxCNC.
        let feeds = (unknown && l.state.motion10 != 0)
            || own.iter().any(|m| {
                m.kind != ncsmooth::path::MoveKind::Rapid
                    && m.segment.start().dist(m.segment.end()) > ncsmooth::verify::DEGENERATE_MM
            });
        ahead = (ahead.0 && !feeds, ahead.1 || !own.is_empty() || unknown);
        out[i] = ahead == (true, true);
    }
    out
}

/// Whether line `l` is executed and moves (or may: modal motion).
fn executed_motion(l: &LineInfo) -> bool {
    l.has(flags::EXECUTED) && (l.has(flags::MODAL_MOTION) || l.has(flags::EXPLICIT_MOTION))
}

/// Whether line `l` is an executed O-word or `M98` statement (control flow).
fn executed_control(l: &LineInfo) -> bool {
    l.has(flags::EXECUTED) && l.has(flags::OWORD)
}

/// The first executed motion line, when blending is bounded, the controller's mode there
/// is looser than the bound `blend` gives that line (LinuxCNC's start-up `G64` without `P`
/// blends without limit) and the line is not replaced (a replaced run writes its own
/// `G64`, see the caller): the verbatim motion before the first smoothed run is bounded
/// too, also in a program given back unchanged.
fn first_loose_motion(
    lines: &[LineInfo],
    main_end: usize,
    blend: impl Fn(usize) -> Option<Blend>,
) -> Option<usize> {
    // Control flow (a call, a loop) may run motion written further on: the main program
    // runs in order up to its first motion or O-word statement.
    let i = lines[..main_end]
        .iter()
        .position(|l| executed_motion(l) || executed_control(l))?;
    let b = blend(i)?;
    (lines[i].before.path.blend_bound_mm() > b.p_mm + b.q_mm).then_some(i)
}

/// Whether an executed line of the program sets a mode looser than `blend` (a `G64`
/// without `P`, a larger `P`).
fn loosening_modes(lines: &[LineInfo], blend: Option<Blend>) -> bool {
    let Some(b) = blend else {
        return false;
    };
    lines.iter().any(|l| {
        l.has(flags::EXECUTED)
            && l.has(flags::PATH_MODE)
            && l.state.path.blend_bound_mm() > b.p_mm + b.q_mm
    })
}

/// A run of replaced lines being written.
struct Region<'a> {
    w: MotionWriter,
    buf: String,
    /// Moves not yet written.
    pending: Vec<&'a Move>,
    /// Source state before the run and after its last line.
    start_state: WriteState,
    end_state: WriteState,
    eol: &'static str,
    /// The `G64` written at the start of the run, if any.
    blend: Option<Blend>,
    /// The block floor, if any, and the programmed moves of the run so far (indices into
    /// the program's moves).
    floor: Option<BlockFloor>,
    program: Option<(usize, usize)>,
    /// Where the last programmed move of the run ends.
    program_end: Option<Vec3>,
}

/// Programmed moves on each side of a replaced run that its written blocks are also
/// checked against under a block floor: a corner transition or a run curve reaches past
/// the lines it is written on when a comment or other unchanged line ends the run.
const FLOOR_CONTEXT_MOVES: usize = 8;

/// Whether `emit` writes runs as long G1 blocks (where a block floor applies).
fn frame_chains_lines(emit: Emit) -> bool {
    matches!(
        emit,
        Emit::Lines { .. } | Emit::G5 { .. } | Emit::Nurbs { .. }
    )
}

impl<'a> Region<'a> {
    /// Adds the programmed moves `range` of a replaced line to the run's.
    fn add_program(&mut self, range: (usize, usize), orig: &[&Move]) {
        if range.1 > range.0 {
            self.program_end = Some(orig[range.1 - 1].segment.end());
            self.program = Some(match self.program {
                Some((lo, _)) => (lo, range.1),
                None => range,
            });
        }
    }

    /// The programmed path of the run and [`FLOOR_CONTEXT_MOVES`] on each side, as a
    /// polyline (curves flattened within `accuracy`).
    fn program_polyline(&self, orig: &[&Move], accuracy: f64) -> Vec<Vec3> {
        let Some((lo, hi)) = self.program else {
            return Vec::new();
        };
        let lo = lo.saturating_sub(FLOOR_CONTEXT_MOVES);
        let hi = (hi + FLOOR_CONTEXT_MOVES).min(orig.len());
        let mut pts: Vec<Vec3> = Vec::new();
        for m in &orig[lo..hi] {
            let p0 = m.segment.start();
            if pts.last() != Some(&p0) {
                pts.push(p0);
            }
            m.segment.flatten(accuracy, &mut |p| pts.push(p));
        }
        pts
    }

    /// What moves next to the run in the program (`orig`), for the blend schedule's speed
    /// estimate: the programmed moves just before and after it, at rest at the program's
    /// ends and next to a rapid (LinuxCNC never blends a rapid with a feed move: tp.c
    /// `tpCheckCanonType` stops between them). An untracked motion between (counted per
    /// line in `untracked_before`, see [`extra_events_before_lines`]) is not known: the
    /// end is free (LinuxCNC may blend with it, so the end keeps all of `P`).
    fn run_ends(&self, orig: &[&Move], untracked_before: &[u32]) -> RunEnds {
        let Some((lo, hi)) = self.program else {
            return RunEnds::default();
        };
        let joins = |m: &Move, t: Option<Vec3>| match m.kind {
            MoveKind::Rapid => RunEnd::Rapid,
            MoveKind::Feed => t.map_or(RunEnd::Free, RunEnd::Joins),
        };
        // Whether an untracked motion is on a line after move `a`'s (or from the start)
        // and before move `b`'s (or to the end); lines are 1-based.
        let before_line = |line: u32| {
            let l = (line as usize).saturating_sub(1);
            untracked_before
                .get(l)
                .or(untracked_before.last())
                .copied()
                .unwrap_or(0)
        };
        let total = untracked_before.last().copied().unwrap_or(0);
        let between = |a: Option<&&Move>, b: Option<&&Move>| {
            let upto = b.map_or(total, |m| before_line(m.line));
            let from = a.map_or(0, |m| before_line(m.line + 1));
            upto > from
        };
        let first = orig.get(lo);
        let last = hi.checked_sub(1).and_then(|k| orig.get(k));
        let prev = lo.checked_sub(1).and_then(|j| orig.get(j));
        let next = orig.get(hi);
        RunEnds {
            before: match prev {
                _ if between(prev, first) => RunEnd::Free,
                None => RunEnd::Rest,
                Some(m) => joins(m, m.segment.end_tangent()),
            },
            after: match next {
                _ if between(last, next) => RunEnd::Free,
                None => RunEnd::Rest,
                Some(m) => joins(m, m.segment.start_tangent()),
            },
        }
    }

    /// Writes the pending moves (`orig`: the program's moves, for a block floor).
    fn flush(
        &mut self,
        s: &mut Vec<u8>,
        orig: &[&Move],
        untracked_before: &[u32],
    ) -> Result<(), RewriteError> {
        let Some(first) = self.pending.first() else {
            return Ok(());
        };
        let line = first.line;
        self.w.run_ends = self.run_ends(orig, untracked_before);
        if let Some(f) = self.floor {
            self.w.floor = Some(Floor {
                program: self.program_polyline(orig, f.tol_mm * FLOOR_PROGRAM_SHARE),
                tol_mm: f.tol_mm * (1.0 - FLOOR_PROGRAM_SHARE),
                min_block_mm: f.min_block_mm,
                grid: std::cell::OnceCell::new(),
                corner: f.corner,
            });
            self.program = None;
        }
        self.w
            .write_moves(&self.pending, &mut self.buf)
            .map_err(|_| RewriteError::BadLine { line })?;
        if let Some((axis, _)) = self.w.violation {
            return Err(RewriteError::UnknownAxis { line, axis });
        }
        self.pending.clear();
        self.take_buf(s);
        Ok(())
    }

    /// Moves what the writer wrote into `s`, with the program's line ends.
    fn take_buf(&mut self, s: &mut Vec<u8>) {
        s.extend_from_slice(self.buf.replace('\n', self.eol).as_bytes());
        self.buf.clear();
    }

    /// Writes a block value that no written block took (see
    /// [`MotionWriter::write_due_lead`]).
    fn due_lead(&mut self, s: &mut Vec<u8>) {
        let _ = self.w.write_due_lead(&mut self.buf);
        self.take_buf(s);
    }

    fn open(
        s: &mut Vec<u8>,
        eol: &'static str,
        info: &LineInfo,
        first: Option<&Move>,
        (extra_mask, extra_at_start, e_carry): (u8, Option<ExtraAxes>, f64),
        opts: &RewriteOptions,
    ) -> Region<'a> {
        let st = info.before;
        let scale = unit_mm(st.units);
        let frame = Frame {
            decimals: decimals_for(st.units, opts.decimals),
            chord_mm: opts.chord_mm,
            scale,
            allowed_xyz: ((st.known | st.relative) & 0b111) as u8,
            arc_absolute: st.arc_absolute,
            e_relative: st.e_relative,
            diameter: st.diameter,
            plane: plane_code(st.plane),
            extra_mask: 0,
            chain: match opts.emit {
                Emit::Native => None,
                Emit::Arcs => Some(ChainMode {
                    min_block_mm: 0.0,
                    min_block_s: 0.0,
                    arcs: true,
                    long_arcs: opts.long_arcs,
                }),
                Emit::Lines {
                    min_block_mm,
                    min_block_s,
                }
                | Emit::G5 {
                    min_block_mm,
                    min_block_s,
                }
                | Emit::Nurbs {
                    min_block_mm,
                    min_block_s,
                } => Some(ChainMode {
                    min_block_mm,
                    min_block_s,
                    arcs: false,
                    long_arcs: opts.long_arcs,
                }),
            },
            g5: matches!(opts.emit, Emit::G5 { .. } | Emit::Nurbs { .. }),
            nurbs: matches!(opts.emit, Emit::Nurbs { .. }),
            arc_planes: opts.arc_planes,
            spiral_arcs: opts.spiral_arcs,
            incremental: st.relative & 0b111 != 0,
            arc_chords: opts.arc_chords,
        };
        let start = first.map(|m| m.segment.start()).unwrap_or_default();
        let mut w = MotionWriter::new(frame, start);
        w.blend_p_mm = opts.blend.filter(|_| opts.even_out).map(|b| b.p_mm);
        w.blend_schedule =
            opts.blend
                .zip(opts.blend_acc_mm_s2)
                .map(|(b, acc_mm_s2)| BlendSchedule {
                    p_mm: b.p_mm,
                    q_mm: b.q_mm,
                    acc_mm_s2,
                    feed_max_mm_s: opts.blend_feed_mm_s.unwrap_or(f64::INFINITY),
                });
        if let Some(m) = first {
            // Extra axes in use and known (E is always tracked from 0).
            let known_extra = ((st.known >> 3) & 0x3f) as u8 | 0x40;
            w.frame.extra_mask = if m.extra.is_some() {
                extra_mask & known_extra
            } else {
                0
            };
            // The machine's extra axes where the run starts: the program's before the
            // first replaced move (a move's own values are those at its end).
            w.assume_at(start, extra_at_start.or(m.extra).as_ref(), e_carry);
        }
        // Absolute coordinates, or increments where an axis is known only relatively.
        if st.absolute == w.frame.incremental {
            s.extend_from_slice(if st.absolute { b"G91" } else { b"G90" });
            s.extend_from_slice(eol.as_bytes());
        }
        // The run's `G64` goes before its first line, unless the writer sets another
        // first (a chain's first block with a share of its own).
        w.blend_pending = opts
            .blend
            .map(|b| blend_text(b, st.units, decimals_for(st.units, opts.decimals)));
        Region {
            w,
            buf: String::with_capacity(256),
            pending: Vec::new(),
            start_state: st,
            end_state: st,
            eol,
            blend: opts.blend,
            floor: opts.block_floor.filter(|_| frame_chains_lines(opts.emit)),
            program: None,
            program_end: None,
        }
    }

    /// Writes what the next verbatim line expects, `verbatim` the bound for the copied
    /// lines after the run (`decimals`: the options' decimals); returns the motion code a
    /// following modal-motion line must be given, if the last one written differs.
    fn close(
        mut self,
        s: &mut Vec<u8>,
        eol: &str,
        decimals: usize,
        verbatim: Option<Blend>,
    ) -> Option<u16> {
        debug_assert!(self.pending.is_empty());
        self.due_lead(s);
        let st = self.end_state;
        let mut restore = String::new();
        if st.absolute == self.w.frame.incremental {
            restore.push_str(if st.absolute { "G90" } else { "G91" });
        }
        if self.w.frame.plane != plane_code(st.plane) {
            if !restore.is_empty() {
                restore.push(' ');
            }
            restore.push_str(&format!("G{}", plane_code(st.plane)));
        }
        if st.feed_word.is_finite() {
            let written = self.w.last_feed();
            let mut want = String::new();
            push_fixed(&mut want, st.feed_word, 10);
            let same = written.is_some_and(|f| {
                let mut t = String::new();
                push_fixed(&mut t, f, 10);
                t == want
            });
            if !same {
                if !restore.is_empty() {
                    restore.push(' ');
                }
                restore.push('F');
                restore.push_str(&want);
            }
        }
        // The verbatim bound, on a line of its own like the runs' `G64`.
        let mut bound = None;
        let mut mode_set = false;
        if let (Some(b), Some(vb)) = (self.blend, verbatim) {
            // The program's own mode comes back only when it is at least as tight as the
            // verbatim bound; otherwise the verbatim bound is set, unless the run's is it.
            if st.path.blend_bound_mm() <= vb.p_mm + vb.q_mm {
                if let Some(t) = path_mode_text(st.path, st.units) {
                    if !restore.is_empty() {
                        restore.push(' ');
                    }
                    restore.push_str(&t);
                    mode_set = true;
                }
            } else if vb != b {
                bound = Some(vb);
                mode_set = true;
            }
        }
        // A `G64` the run set after its last line stays in force over what is copied
        // next, unless a mode of the program or the verbatim bound replaces it here.
        if let Some(g64) = self.w.blend_pending.take().filter(|_| !mode_set) {
            s.extend_from_slice(g64.as_bytes());
            s.extend_from_slice(eol.as_bytes());
        }
        if !restore.is_empty() {
            s.extend_from_slice(restore.as_bytes());
            s.extend_from_slice(eol.as_bytes());
        }
        if let Some(vb) = bound {
            push_blend_line(s, vb, st.units, decimals, eol);
        }
        let _ = (self.start_state, self.eol);
        let written = self.w.last_motion.map(|c| u16::from(c) * 10);
        (written != Some(st.motion10)).then_some(st.motion10)
    }
}

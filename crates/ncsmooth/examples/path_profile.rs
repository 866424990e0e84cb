//! Profile of each method's path: curvature along arc length against a reference, and
//! where the planned speed falls below the feed and why. A development tool;
//! it prints a summary and, with `--csv DIR`, writes one CSV per method (not committed).
//!
//! Usage:
//! `path_profile FILE [--methods none,arc,...] [--tol MM] [--feed V] [--acc A]
//! [--step MM] [--ref butterfly] [--csv DIR] [--top N]`
//!
//! * **Curvature.** Every feed move of the smoothed path is sampled every `--step` mm of
//!   arc length. The reference curvature at a sample is the exact butterfly NURBS's at the
//!   nearest point (`--ref butterfly`, for the profiles sampled from it), else the
//!   discrete (Menger) curvature of the programmed polyline at the nearest vertex: the
//!   circle through that vertex and its two neighbours. Printed: the peak, the total
//!   variation `integral |d kappa / ds| ds` (how much the curvature goes up and down), the
//!   RMS difference from the reference, and the share of the length where the curvature
//!   exceeds 1.25 times the reference plus 0.01 / mm.
//! * **Speed.** The path is planned with `ncsmooth::feed` (trapezoid mode, the same
//!   options as `ncsmooth plan`) and the planned speed `v(s)` read at every sample. Each
//!   sample below 99.5 % of the feed gets the cap that binds there: `curvature` (the
//!   per-axis limit `v^2 |K_i| <= A_i`, at a joint that of either move), `chord` (Wu eq.
//!   21), `joint` (a G1 joint cap `v^2 |dK_i| <= A_i` stricter than both moves' curvature
//!   caps, or a stop, at a move end within half a step) or, when none binds
//!   within 1 %, `ramp` (look-ahead: accelerating away from or braking towards a lower
//!   cap, including the share of the axis acceleration the curvature leaves to the
//!   tangential one). A ramp's time is also charged to the cap it leads to (`root`). The
//!   time lost against running the same length at the feed is summed per cause, and the
//!   `--top` windows of 2 mm that lose the most are listed with their causes.
//! * With `--ref butterfly` the exact NURBS itself is planned too (one move), as the
//!   planner's own reference time for the designer's curve.
#![forbid(unsafe_code)]

use ncsmooth::feed::grid::{caps_of, After};
use ncsmooth::feed::limits::Caps;
use ncsmooth::feed::{plan_stream, PathIndex, PlanEvent, PlanOptions, ProfilePiece};
use ncsmooth::geom::{
    Nurbs, ParamCurve, ParamCurveArclen, ParamCurveCurvature, ParamCurveNearest, Segment, Vec3,
};
use ncsmooth::smooth::{smooth, Method, SmoothOptions};
use ncsmooth::verify::{continuity_joints, deviation, JointClass};
use ncsmooth::{MoveKind, Toolpath};
use std::fmt::Write as _;

/// Accuracy (mm) of arc-length inversions and nearest-point queries.
const ACCURACY_MM: f64 = 1e-9;
/// A sample at or above this share of the feed is feed-limited.
const AT_FEED: f64 = 0.995;
/// A cap binds at a sample when the planned speed is within this share of it.
const BINDS: f64 = 0.99;
/// Curvature counted as excess: above `EXCESS_FACTOR` times the reference plus
/// `EXCESS_FLOOR_PER_MM`.
const EXCESS_FACTOR: f64 = 1.25;
/// See [`EXCESS_FACTOR`].
const EXCESS_FLOOR_PER_MM: f64 = 0.01;
/// Length (mm) of the windows ranked by lost time.
const WINDOW_MM: f64 = 2.0;
/// Causes, in report order.
const CAUSES: [&str; 6] = ["curvature", "chord", "joint", "stop", "ramp", "feed"];

struct Args {
    file: String,
    methods: Vec<Method>,
    tol: f64,
    feed: f64,
    acc: f64,
    step: f64,
    butterfly: bool,
    csv: Option<String>,
    top: usize,
    run: ncsmooth::smooth::band_fit::RunOptions,
}

fn parse_args() -> Args {
    let mut it = std::env::args().skip(1);
    let mut a = Args {
        file: String::new(),
        methods: vec![Method::Arc, Method::Nurbs, Method::Bspline, Method::Trig],
        tol: 0.01,
        feed: 50.0,
        acc: 500.0,
        step: 0.02,
        butterfly: false,
        csv: None,
        top: 5,
        run: Default::default(),
    };
    while let Some(x) = it.next() {
        let mut val = || it.next().unwrap_or_else(|| panic!("{x} needs a value"));
        // Flags without a value.
        let x = x.as_str();
        match x {
            "--methods" => {
                a.methods = val()
                    .split(',')
                    .map(|m| Method::from_name(m).unwrap_or_else(|| panic!("method {m}")))
                    .collect()
            }
            "--tol" => a.tol = val().parse().expect("tol"),
            "--feed" => a.feed = val().parse().expect("feed"),
            "--acc" => a.acc = val().parse().expect("acc"),
            "--step" => a.step = val().parse().expect("step"),
            "--ref" => a.butterfly = val() == "butterfly",
            "--csv" => a.csv = Some(val()),
            "--top" => a.top = val().parse().expect("top"),
            "--no-run" => a.run.enabled = false,
            "--run-max-turn" => {
                a.run.screen.min_angle_deg = 180.0 - val().parse::<f64>().expect("degrees")
            }
            "--run-len" => a.run.fit.smoothing_len_mm = val().parse().expect("mm"),
            "--run-iters" => a.run.fit.max_iters = val().parse().expect("count"),
            f if !f.starts_with("--") => a.file = f.to_string(),
            f => panic!("unknown option {f}"),
        }
    }
    assert!(!a.file.is_empty(), "usage: path_profile FILE [options]");
    a
}

/// The reference curvature along the programmed path.
enum Reference {
    /// The exact NURBS the program samples.
    Exact(Nurbs),
    /// Vertices of the programmed feed path and their Menger curvature.
    Polyline(Vec<(Vec3, f64)>),
}

impl Reference {
    fn polyline(tp: &Toolpath) -> Reference {
        let mut v: Vec<Vec3> = Vec::new();
        for m in tp.moves().filter(|m| m.kind == MoveKind::Feed) {
            if v.last() != Some(&m.segment.start()) {
                v.push(m.segment.start());
            }
            v.push(m.segment.end());
        }
        let menger = |a: Vec3, b: Vec3, c: Vec3| {
            let (ab, bc, ca) = (a.dist(b), b.dist(c), c.dist(a));
            let area2 = (b - a).cross(c - a).norm();
            if ab * bc * ca > 0.0 {
                2.0 * area2 / (ab * bc * ca)
            } else {
                0.0
            }
        };
        let k: Vec<(Vec3, f64)> = (0..v.len())
            .map(|i| {
                let kk = if i == 0 || i + 1 == v.len() {
                    0.0
                } else {
                    menger(v[i - 1], v[i], v[i + 1])
                };
                (v[i], kk)
            })
            .collect();
        Reference::Polyline(k)
    }

    /// Reference curvature near `p`; `hint` is the vertex index of the previous query
    /// (the path is walked in order).
    fn kappa(&self, p: Vec3, hint: &mut usize) -> f64 {
        match self {
            Reference::Exact(n) => n.curvature(n.nearest(p, ACCURACY_MM).t),
            Reference::Polyline(v) => {
                // Local search forward from the hint (and a little back).
                let lo = hint.saturating_sub(4);
                let hi = (*hint + 64).min(v.len());
                let mut best = (*hint, f64::INFINITY);
                for (i, (q, _)) in v.iter().enumerate().take(hi).skip(lo) {
                    let d = q.dist_sq(p);
                    if d < best.1 {
                        best = (i, d);
                    }
                }
                *hint = best.0;
                v[best.0].1
            }
        }
    }
}

/// One sample of a path.
#[derive(Clone, Copy, Default)]
struct Sample {
    s: f64,
    p: Vec3,
    kappa: f64,
    kappa_ref: f64,
    v: f64,
    cap_v: f64,
    cause: usize,
    root: usize,
}

/// Samples the feed moves of `tp` every `step` mm: position and curvature.
fn sample_path(tp: &Toolpath, step: f64) -> Vec<Sample> {
    let mut out = Vec::new();
    let mut s0 = 0.0;
    for m in tp.moves().filter(|m| m.kind == MoveKind::Feed) {
        let seg = &m.segment;
        let len = seg.arclen(ACCURACY_MM);
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let k = ((len / step).ceil() as usize).max(1);
        let first = usize::from(!out.is_empty());
        for i in first..=k {
            let s = len * i as f64 / k as f64;
            let t = match seg {
                Segment::Line(_) => i as f64 / k as f64,
                _ => seg.inv_arclen(s, ACCURACY_MM),
            };
            // Just inside the ends: a joint's curvature is the move's own.
            let tk = t.clamp(1e-9, 1.0 - 1e-9);
            out.push(Sample {
                s: s0 + s,
                p: seg.eval(t),
                kappa: seg.curvature(tk),
                ..Default::default()
            });
        }
        s0 += len;
    }
    out
}

/// Planned speed at arc length `s`; `at` walks the pieces in order.
fn speed_at(pieces: &[ProfilePiece], s: f64, at: &mut usize) -> f64 {
    while *at + 1 < pieces.len() && pieces[*at].s0 + pieces[*at].ds < s {
        *at += 1;
    }
    let Some(p) = pieces.get(*at) else {
        return 0.0;
    };
    let f = ((s - p.s0) / p.ds).clamp(0.0, 1.0);
    (p.v0 * p.v0 + (p.v1 * p.v1 - p.v0 * p.v0) * f)
        .max(0.0)
        .sqrt()
}

/// Plans `tp`: the pieces, the cycle time (pieces and stop holds) and the index.
fn plan(tp: &Toolpath, opts: &PlanOptions) -> (Vec<ProfilePiece>, f64) {
    let index = PathIndex::new(tp, opts);
    let mut pieces = Vec::new();
    let mut t = 0.0;
    plan_stream(&index, opts, |ev| match ev {
        PlanEvent::Piece(p) => {
            t += p.dt;
            pieces.push(p)
        }
        PlanEvent::Stop { dwell_s, .. } => t += dwell_s,
    });
    (pieces, t)
}

/// Classifies every sample (see the module doc) and returns the time lost per cause and
/// per root cause.
fn classify(
    tp: &Toolpath,
    opts: &PlanOptions,
    pieces: &[ProfilePiece],
    smp: &mut [Sample],
    step: f64,
) {
    let index = PathIndex::new(tp, opts);
    let caps = caps_of(opts);
    let (mut at, mut mv) = (0usize, 0usize);
    for x in smp.iter_mut() {
        x.v = speed_at(pieces, x.s, &mut at);
        while mv + 1 < index.moves.len() && index.moves[mv].s0 + index.moves[mv].len < x.s {
            mv += 1;
        }
        let feed = index.moves[mv].vcap_mm_s;
        let (mut curv, mut chord) = point_caps(&index, &caps, mv, x.s);
        // At a joint within half a step: its own cap, and the curvature caps of both moves
        // there (a joint cap no stricter than those is not what binds).
        let mut joint = f64::INFINITY;
        for j in mv.saturating_sub(1)..(mv + 2).min(index.moves.len()) {
            let e = index.moves[j].s0 + index.moves[j].len;
            if (e - x.s).abs() <= 0.5 * step {
                joint = joint.min(match index.moves[j].after {
                    After::Continue { x_cap, .. } => x_cap,
                    After::Stop { .. } => 0.0,
                });
                for side in [j, j + 1] {
                    if side < index.moves.len() {
                        let (c, h) = point_caps(&index, &caps, side, e);
                        curv = curv.min(c);
                        chord = chord.min(h);
                    }
                }
            }
        }
        let (v, v2) = (x.v, x.v * x.v);
        x.cap_v = curv.min(chord).min(joint).min(feed * feed).sqrt();
        x.cause = if v >= AT_FEED * feed {
            5
        } else if v2 >= BINDS * BINDS * curv.min(chord) {
            usize::from(chord < curv)
        } else if v2 >= BINDS * BINDS * joint || joint == 0.0 && v < 1e-3 {
            if joint == 0.0 {
                3
            } else {
                2
            }
        } else {
            4
        };
    }
    // Root causes of ramps: the cause where the ramp's speed is lowest.
    let n = smp.len();
    let mut i = 0;
    while i < n {
        if smp[i].cause != 4 {
            smp[i].root = smp[i].cause;
            i += 1;
            continue;
        }
        let a = i;
        while i < n && smp[i].cause == 4 {
            i += 1;
        }
        let left = a.checked_sub(1).map(|j| (smp[j].v, smp[j].cause));
        let right = (i < n).then(|| (smp[i].v, smp[i].cause));
        let root = match (left, right) {
            (Some(l), Some(r)) => {
                if l.0 <= r.0 {
                    l.1
                } else {
                    r.1
                }
            }
            (Some(l), None) => l.1,
            (None, Some(r)) => r.1,
            (None, None) => 4,
        };
        for x in &mut smp[a..i] {
            x.root = root;
        }
    }
}

/// The curvature and chord-error caps on `v^2` of move `mv` of `index` at the arc length
/// `s` (clamped to the move; the curvature read just inside its ends).
fn point_caps(index: &PathIndex, caps: &Caps, mv: usize, s: f64) -> (f64, f64) {
    let m = &index.moves[mv];
    let t = m
        .segment
        .inv_arclen((s - m.s0).clamp(0.0, m.len), ACCURACY_MM);
    let k = m.segment.curvature_vec(t.clamp(1e-9, 1.0 - 1e-9));
    let mut curv = f64::INFINITY;
    for i in 0..3 {
        if k[i].abs() > 1e-12 {
            curv = curv.min(caps.acc[i] / k[i].abs());
        }
    }
    let kap = k.norm();
    let chord = if kap > 1e-12 {
        let (r, d) = (1.0 / kap, caps.chord_error_mm);
        let c = if d < r {
            2.0 * (d * (2.0 * r - d)).sqrt()
        } else {
            2.0 * r
        };
        (c / caps.period_s).powi(2)
    } else {
        f64::INFINITY
    };
    (curv, chord)
}

/// Time lost against the feed per cause (index into [`CAUSES`]), by `cause` or `root`.
fn lost(smp: &[Sample], feed: f64, root: bool) -> [f64; 6] {
    let mut t = [0.0; 6];
    for w in smp.windows(2) {
        let ds = w[1].s - w[0].s;
        let v = 0.5 * (w[0].v + w[1].v);
        if v <= 0.0 || ds <= 0.0 {
            continue;
        }
        let c = if root { w[0].root } else { w[0].cause };
        t[c] += (ds / v - ds / feed).max(0.0);
    }
    t
}

/// Curvature statistics: peak, total variation, RMS difference, excess share.
fn curvature_stats(smp: &[Sample]) -> (f64, f64, f64, f64, f64) {
    let peak = smp.iter().map(|x| x.kappa).fold(0.0, f64::max);
    let peak_ref = smp.iter().map(|x| x.kappa_ref).fold(0.0, f64::max);
    let tv = smp
        .windows(2)
        .map(|w| (w[1].kappa - w[0].kappa).abs())
        .sum();
    let (mut se, mut len, mut excess) = (0.0, 0.0, 0.0);
    for w in smp.windows(2) {
        let ds = w[1].s - w[0].s;
        let d = w[0].kappa - w[0].kappa_ref;
        se += d * d * ds;
        len += ds;
        if w[0].kappa > EXCESS_FACTOR * w[0].kappa_ref + EXCESS_FLOOR_PER_MM {
            excess += ds;
        }
    }
    let rms = if len > 0.0 { (se / len).sqrt() } else { 0.0 };
    let share = if len > 0.0 { excess / len } else { 0.0 };
    (peak, peak_ref, tv, rms, share)
}

/// The `top` windows of [`WINDOW_MM`] that lose the most time, with their causes.
fn worst_windows(smp: &[Sample], feed: f64, top: usize) -> String {
    let Some(last) = smp.last() else {
        return String::new();
    };
    let nw = (last.s / WINDOW_MM).ceil() as usize + 1;
    let mut w = vec![(0.0f64, [0.0f64; 6], 0.0f64, 0.0f64); nw];
    for p in smp.windows(2) {
        let ds = p[1].s - p[0].s;
        let v = 0.5 * (p[0].v + p[1].v);
        if v <= 0.0 || ds <= 0.0 {
            continue;
        }
        let k = (p[0].s / WINDOW_MM) as usize;
        let l = (ds / v - ds / feed).max(0.0);
        w[k].0 += l;
        w[k].1[p[0].cause] += l;
        w[k].2 = w[k].2.max(p[0].kappa);
        w[k].3 = w[k].3.max(p[0].kappa_ref);
    }
    let mut idx: Vec<usize> = (0..nw).collect();
    idx.sort_by(|a, b| w[*b].0.total_cmp(&w[*a].0));
    let mut out = String::new();
    for &k in idx.iter().take(top) {
        let (l, c, kp, kr) = w[k];
        let p = smp[smp
            .partition_point(|x| x.s < k as f64 * WINDOW_MM)
            .min(smp.len() - 1)]
        .p;
        let causes: Vec<String> = (0..6)
            .filter(|&i| c[i] > 1e-4)
            .map(|i| format!("{} {:.3}", CAUSES[i], c[i]))
            .collect();
        let _ = writeln!(
            out,
            "    s {:7.1}-{:7.1} mm at ({:.2}, {:.2}): lost {:.3} s [{}], peak kappa {:.3} (ref {:.3}) /mm",
            k as f64 * WINDOW_MM,
            (k + 1) as f64 * WINDOW_MM,
            p.x,
            p.y,
            l,
            causes.join(", "),
            kp,
            kr
        );
    }
    out
}

fn write_csv(dir: &str, name: &str, smp: &[Sample]) {
    let mut s = String::from("s_mm,x,y,z,kappa_per_mm,kappa_ref_per_mm,v_mm_s,cap_mm_s,cause\n");
    for x in smp {
        let _ = writeln!(
            s,
            "{:.5},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{}",
            x.s,
            x.p.x,
            x.p.y,
            x.p.z,
            x.kappa,
            x.kappa_ref,
            x.v,
            x.cap_v.min(1e9),
            CAUSES[x.cause]
        );
    }
    let path = format!("{dir}/{name}.csv");
    std::fs::write(&path, s).unwrap_or_else(|e| panic!("{path}: {e}"));
}

fn main() {
    let a = parse_args();
    let src = std::fs::read(&a.file).unwrap_or_else(|e| panic!("{}: {e}", a.file));
    let prog = ncsmooth_gcode::parse_bytes(&src, &a.file, &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let tp = &prog.toolpath;
    let reference = if a.butterfly {
        Reference::Exact(ncsmooth::profiles::butterfly())
    } else {
        Reference::polyline(tp)
    };
    let opts = PlanOptions::default()
        .with_feed_mm_s(a.feed)
        .with_acc_mm_s2([a.acc; 3]);
    println!(
        "{}: tol {} mm, feed {} mm/s, acc {} mm/s^2, T {} s, curvature step {} mm, reference {}",
        a.file,
        a.tol,
        a.feed,
        a.acc,
        opts.period_s,
        a.step,
        if a.butterfly {
            "exact butterfly NURBS"
        } else {
            "polyline (Menger)"
        }
    );
    if let Reference::Exact(n) = &reference {
        let mut exact = Toolpath::new(n.start());
        exact.push_move(ncsmooth::Move::feed(
            Segment::Nurbs(Box::new(n.clone())),
            Some(a.feed),
            1,
        ));
        analyse(&a, "exact_nurbs", &exact, tp, &reference, &opts);
    }
    for &method in &a.methods {
        let so = SmoothOptions::default()
            .with_method(method)
            .with_tol_mm(a.tol)
            .with_run(a.run.clone());
        let out = smooth(tp, &so).expect("valid options").toolpath;
        analyse(&a, method.name(), &out, tp, &reference, &opts);
    }
}

/// Profiles one path `out` against the programmed `tp` and prints the summary.
fn analyse(
    a: &Args,
    name: &str,
    out: &Toolpath,
    tp: &Toolpath,
    reference: &Reference,
    opts: &PlanOptions,
) {
    {
        let out = out.clone();
        let dev = deviation(&out, tp, a.tol * 1e-3);
        let (pieces, t) = plan(&out, opts);
        let mut smp = sample_path(&out, a.step);
        let mut hint = 0;
        for x in smp.iter_mut() {
            x.kappa_ref = reference.kappa(x.p, &mut hint);
        }
        classify(&out, opts, &pieces, &mut smp, a.step);
        let (peak, peak_ref, tv, rms, excess) = curvature_stats(&smp);
        let tv_ref: f64 = smp
            .windows(2)
            .map(|w| (w[1].kappa_ref - w[0].kappa_ref).abs())
            .sum();
        let by = lost(&smp, a.feed, false);
        let root = lost(&smp, a.feed, true);
        let fmt = |t: &[f64; 6]| {
            (0..5)
                .map(|i| format!("{} {:.3}", CAUSES[i], t[i]))
                .collect::<Vec<_>>()
                .join(", ")
        };
        println!(
            "\n{}: cycle {t:.3} s, {} moves, deviation {:.5} mm (output->prog {:.5}, vertex->output {:.5})",
            name,
            out.move_count(),
            dev.max_mm(),
            dev.output_to_programmed_mm,
            dev.vertex_to_output_mm
        );
        let (_, joints) = continuity_joints(&out);
        let count = |c: JointClass| joints.iter().filter(|j| j.class == c).count();
        let worst_jump = joints
            .iter()
            .filter(|j| j.class == JointClass::G1)
            .map(|j| j.curvature_jump)
            .fold(0.0, f64::max);
        println!(
            "  joints: {} G0, {} G1 (largest curvature jump {worst_jump:.3} /mm), {} G2",
            count(JointClass::G0),
            count(JointClass::G1),
            count(JointClass::G2)
        );
        for j in joints.iter().filter(|j| j.class == JointClass::G0).take(5) {
            println!(
                "    G0 at ({:.4}, {:.4}): {:.3} deg",
                j.at.x, j.at.y, j.angle_deg
            );
        }
        println!(
            "  curvature: peak {peak:.3} /mm (ref {peak_ref:.3}), total variation {tv:.1} /mm (ref {tv_ref:.1}), rms diff {rms:.4} /mm, excess share {:.1} %",
            100.0 * excess
        );
        println!("  time lost below feed by cause: {}", fmt(&by));
        println!("  ... ramps charged to their cap: {}", fmt(&root));
        print!("{}", worst_windows(&smp, a.feed, a.top));
        if let Some(dir) = &a.csv {
            write_csv(dir, name, &smp);
        }
    }
}

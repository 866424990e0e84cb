//! Screening of micro-line runs (Wu et al., section II.B), shared by the curve-fitting
//! methods (`nurbs`, `trig`).
//!
//! A *junction* between two consecutive line moves qualifies when
//!
//! 1. **length** (eq. 7): both lines are at most [`ScreenOptions::max_len_mm`] long
//!    (`L_i <= L_m`), when that cap is set;
//! 2. **ratio** (eq. 7): `L_i / L_(i+1)` lies in `[1 / lambda_m, lambda_m]`;
//! 3. **angle** (eq. 9): the included angle `theta` (180 deg for collinear lines) is at
//!    least `theta_min`;
//! 4. **chord error** (eq. 6 with eq. 8): the near-circular arc through the junction has
//!    radius `R = L / (2 cos(theta / 2))` (eq. 8, `L` the mean of the two lengths), and its
//!    chord error `delta = R - sqrt(R^2 - (L/2)^2) = L (1 - sin(theta/2)) / (2 cos(theta/2))`
//!    (eq. 6) must be at most `chord_share * tol`.
//!
//! Condition 4 is how the length limit `L_m` is derived from the tolerance: a curve fitted
//! through the vertices of a sampled smooth curve departs from the chords by about the
//! chord error, and the contract measures against the chords, so lines whose chord error
//! would eat the tolerance are kept as lines. It replaces a fixed `L_m` by a per-junction
//! one, `L_m = 2 chord_share tol cos(theta/2) / (1 - sin(theta/2))`; a fixed cap can still
//! be set with `max_len_mm`.
//!
//! A junction where an extra axis's rate changes ([`crate::path::extra_rates_agree`]: a
//! slicer's flow, E per mm, between a perimeter and a travel or a thinner feature) never
//! qualifies: a run's curve carries the extra axes linearly in its length, so one run
//! spanning both would spread the flow of one over the other.
//!
//! A *run* is a maximal sequence of consecutive qualifying junctions; a run of `k`
//! junctions covers `k + 1` lines and `k + 2` points. Runs with fewer than
//! [`ScreenOptions::min_lines`] lines are dropped. Zero-length lines never qualify.

use super::Chain;
use crate::geom::{ParamCurveArclen, Segment};
use crate::path::{extra_rate, extra_rates_agree, ExtraAxes};

/// Screening settings (Wu et al. eqs. 6-9).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ScreenOptions {
    /// Fixed length cap `L_m` (mm). Default `None`: only the per-junction cap derived from
    /// the tolerance (condition 4 in the module doc).
    pub max_len_mm: Option<f64>,
    /// Length ratio limit `lambda_m` (eq. 7), >= 1. Default 2: the chord errors of the two
    /// lines then differ by at most a factor of 4 (eq. 6, `delta ~ L^2 / 8R`).
    pub ratio_max: f64,
    /// Minimum included angle `theta_min` (eq. 9), degrees. Default 150: a turn of at most
    /// 30 degrees per vertex, i.e. at least 12 vertices per quarter circle of the sampled
    /// curve; sharper junctions are corners, not curve samples.
    pub min_angle_deg: f64,
    /// Share of the tolerance the chord error of eq. 6 may use. Default 0.5: the other half
    /// is left for the fitted curve's bulge between vertices.
    pub chord_share: f64,
    /// Fewest lines in a run. Default 3 (4 points: the fewest a cubic fit needs).
    pub min_lines: usize,
}

/// Builders: each sets one field (see its doc for the default).
impl ScreenOptions {
    /// Sets [`ScreenOptions::max_len_mm`].
    pub fn with_max_len_mm(mut self, max_len_mm: Option<f64>) -> Self {
        self.max_len_mm = max_len_mm;
        self
    }

    /// Sets [`ScreenOptions::ratio_max`].
    pub fn with_ratio_max(mut self, ratio_max: f64) -> Self {
        self.ratio_max = ratio_max;
        self
    }

    /// Sets [`ScreenOptions::min_angle_deg`].
    pub fn with_min_angle_deg(mut self, min_angle_deg: f64) -> Self {
        self.min_angle_deg = min_angle_deg;
        self
    }

    /// Sets [`ScreenOptions::chord_share`].
    pub fn with_chord_share(mut self, chord_share: f64) -> Self {
        self.chord_share = chord_share;
        self
    }

    /// Sets [`ScreenOptions::min_lines`].
    pub fn with_min_lines(mut self, min_lines: usize) -> Self {
        self.min_lines = min_lines;
        self
    }
}

impl Default for ScreenOptions {
    fn default() -> Self {
        ScreenOptions {
            max_len_mm: None,
            ratio_max: 2.0,
            min_angle_deg: 150.0,
            chord_share: 0.5,
            min_lines: 3,
        }
    }
}

impl ScreenOptions {
    /// The screening of the methods' run mode ([`super::band_fit`]): micro-corners turning
    /// by up to `RUN_MAX_TURN_DEG` (105.0) between lines of any lengths (`RUN_RATIO_MAX` (unbounded))
    /// whose chord error (eq. 6) is at most `RUN_CHORD_SHARE` (8.0) times the tolerance. The band fit measures its own deviation, so the chord error need not
    /// leave room for a curve through the vertices: it only keeps coarse polygons (long
    /// lines turning by a few degrees, where a curve would have to hug every line) out of
    /// the runs.
    pub fn run_mode() -> ScreenOptions {
        ScreenOptions {
            max_len_mm: None,
            ratio_max: RUN_RATIO_MAX,
            min_angle_deg: 180.0 - RUN_MAX_TURN_DEG,
            chord_share: RUN_CHORD_SHARE,
            min_lines: 3,
        }
    }
}

/// Largest turn (degrees) of a junction inside a run of the run mode: the sampled tips of
/// butterfly_1000 (0.4 mm chords) turn by up to 100 degrees at one vertex; a sharper turn
/// is a corner, left to the method's transition.
pub(crate) const RUN_MAX_TURN_DEG: f64 = 105.0;
/// Largest ratio of neighbouring line lengths inside a run of the run mode: none. The
/// band fit measures its own deviation, and a CAM file's short lines beside long ones
/// (camotics_vcarve: 0.05 mm between 0.16 and 0.19 mm lines turning 15 degrees each) are
/// where one curve through the band beats a corner per vertex; a limit of 4 split such
/// bends into runs and corners (measured with the merging of micro-lines, see
/// [`super::band_fit::MERGE_SHARE`]).
pub(crate) const RUN_RATIO_MAX: f64 = f64::INFINITY;
/// Largest chord error (eq. 6) inside a run of the run mode, as a multiple of the tolerance.
pub(crate) const RUN_CHORD_SHARE: f64 = 8.0;

/// A run of consecutive line moves of a chain: indices `first..=last`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// First move index.
    pub first: usize,
    /// Last move index (inclusive).
    pub last: usize,
}

impl Run {
    /// Number of lines.
    pub fn lines(&self) -> usize {
        self.last - self.first + 1
    }
    /// Number of points (lines + 1).
    pub fn points(&self) -> usize {
        self.lines() + 1
    }
}

/// True when the junction between the lines of lengths `l0`, `l1` with included angle
/// `theta_deg` satisfies eqs. 6-9 under `opts` and `tol_mm`.
pub fn junction_qualifies(
    l0: f64,
    l1: f64,
    theta_deg: f64,
    opts: &ScreenOptions,
    tol_mm: f64,
) -> bool {
    if !(l0 > 0.0 && l1 > 0.0) {
        return false;
    }
    if let Some(lm) = opts.max_len_mm {
        if l0 > lm || l1 > lm {
            return false;
        }
    }
    let ratio = l0 / l1;
    if ratio > opts.ratio_max || ratio < 1.0 / opts.ratio_max {
        return false;
    }
    if theta_deg < opts.min_angle_deg {
        return false;
    }
    chord_error_mm(0.5 * (l0 + l1), theta_deg) <= opts.chord_share * tol_mm
}

/// Chord error (eq. 6) of the near-circular arc (eq. 8) through a junction of two lines of
/// length `l` with included angle `theta_deg`.
pub fn chord_error_mm(l: f64, theta_deg: f64) -> f64 {
    let half = 0.5 * theta_deg.to_radians();
    let c = half.cos();
    if c <= 0.0 {
        return 0.0; // collinear: infinite radius
    }
    l * (1.0 - half.sin()) / (2.0 * c)
}

/// Finds the micro-line runs of a chain.
pub fn screen(chain: &Chain<'_>, opts: &ScreenOptions, tol_mm: f64) -> Vec<Run> {
    let moves = chain.moves;
    let mut runs = Vec::new();
    let mut start: Option<usize> = None;
    let push = |runs: &mut Vec<Run>, first: usize, last: usize| {
        let r = Run { first, last };
        if r.lines() >= opts.min_lines.max(2) {
            runs.push(r);
        }
    };
    for i in 0..moves.len().saturating_sub(1) {
        let ok = match (&moves[i].segment, &moves[i + 1].segment) {
            (Segment::Line(a), Segment::Line(b)) => {
                let (da, db) = (a.p1 - a.p0, b.p1 - b.p0);
                let theta = 180.0 - da.angle_to(db).to_degrees();
                junction_qualifies(da.norm(), db.norm(), theta, opts, tol_mm)
            }
            _ => false,
        } && same_flow(chain, i);
        match (ok, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                push(&mut runs, s, i);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        push(&mut runs, s, moves.len() - 1);
    }
    runs
}

/// Whether moves `i` and `i + 1` of the chain move their extra axes at one rate (within
/// [`crate::path::EXTRA_RATE_VARIANCE`]); true without extra axes.
fn same_flow(chain: &Chain<'_>, i: usize) -> bool {
    let rate = |k: usize| -> Option<ExtraAxes> {
        let m = &chain.moves[k];
        let end = m.extra?;
        let start = chain.extra_start_of(k)?;
        Some(extra_rate(
            &start,
            &end,
            m.segment.arclen(FLOW_ARCLEN_ACCURACY_MM),
        ))
    };
    match (rate(i), rate(i + 1)) {
        (Some(a), Some(b)) => extra_rates_agree(&a, &b),
        _ => true,
    }
}

/// Accuracy (mm) of the move lengths [`same_flow`] (and the smoothing's flow cuts)
/// divide by (lines are exact).
pub(crate) const FLOW_ARCLEN_ACCURACY_MM: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Line, ParamCurve, Vec3};
    use crate::path::Move;

    fn chain_of(pts: &[Vec3]) -> Vec<Move> {
        pts.windows(2)
            .map(|w| Move::feed(Line::new(w[0], w[1]), Some(10.0), 1))
            .collect()
    }

    #[test]
    fn chord_error_matches_the_circle() {
        // 12 chords of a radius-10 quarter circle: turn 7.5 deg, theta 172.5 deg.
        let r = 10.0;
        let step = std::f64::consts::FRAC_PI_2 / 12.0;
        let l = 2.0 * r * (step / 2.0).sin();
        let exact = r - (r * r - l * l / 4.0).sqrt();
        assert!((chord_error_mm(l, 180.0 - step.to_degrees()) - exact).abs() < 1e-12);
        assert_eq!(chord_error_mm(1.0, 180.0), 0.0);
    }

    #[test]
    fn finds_the_curve_between_corners() {
        // Long line, then a fine arc of 20 chords, then a sharp corner and a long line.
        let mut pts = vec![Vec3::new(-50.0, 0.0, 0.0), Vec3::ZERO];
        let r = 20.0;
        for i in 1..=20 {
            let a = (i as f64) * 0.02;
            pts.push(Vec3::new(r * a.sin(), r - r * a.cos(), 0.0));
        }
        let last = *pts.last().unwrap();
        pts.push(last + Vec3::new(0.0, -40.0, 0.0));
        let moves = chain_of(&pts);
        let chain = Chain {
            moves: &moves,
            start_extra: None,
            open_ends: [false; 2],
        };
        let runs = screen(&chain, &ScreenOptions::default(), 0.01);
        assert_eq!(runs, vec![Run { first: 1, last: 20 }]);
        // A tight tolerance rejects the chords (chord error 0.001 mm > half of 0.0005 mm).
        assert!(screen(&chain, &ScreenOptions::default(), 0.0005).is_empty());
        // A fixed length cap below the chord length rejects them too.
        let capped = ScreenOptions {
            max_len_mm: Some(0.1),
            ..Default::default()
        };
        assert!(screen(&chain, &capped, 0.01).is_empty());
    }

    #[test]
    fn degenerate_lines_break_runs() {
        let pts = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::X,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
        ];
        let moves = chain_of(&pts);
        let chain = Chain {
            moves: &moves,
            start_extra: None,
            open_ends: [false; 2],
        };
        assert!(screen(&chain, &ScreenOptions::default(), 0.01).is_empty());
    }

    /// A slicer's curve whose flow (E per mm) triples halfway is two runs, each fitted on
    /// its own; a flow that varies within the allowed variance is one.
    #[test]
    fn a_change_of_flow_splits_a_run() {
        let r = 20.0;
        let pts: Vec<Vec3> = (0..=20)
            .map(|i| {
                let a = (i as f64) * 0.02;
                Vec3::new(r * a.sin(), r - r * a.cos(), 0.0)
            })
            .collect();
        let runs = |second_rate: f64| {
            let mut moves = chain_of(&pts);
            let mut e = 0.0;
            for (k, m) in moves.iter_mut().enumerate() {
                let rate = if k < 10 { 0.05 } else { second_rate };
                e += rate * m.segment.end().dist(m.segment.start());
                let mut x = [0.0; 7];
                x[6] = e;
                m.extra = Some(x);
            }
            let chain = Chain {
                moves: &moves,
                start_extra: Some([0.0; 7]),
                open_ends: [false; 2],
            };
            screen(&chain, &ScreenOptions::default(), 0.01)
        };
        assert_eq!(
            runs(0.15),
            vec![
                Run { first: 0, last: 9 },
                Run {
                    first: 10,
                    last: 19
                }
            ]
        );
        assert_eq!(runs(0.052), vec![Run { first: 0, last: 19 }]);
    }
}

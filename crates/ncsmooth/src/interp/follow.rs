//! Jerk mode, `follow` scheme ([`crate::feed::JerkScheme::Follow`]): the setpoints
//! themselves are the decision variables, chosen one period at a time under the limits
//! as the setpoints measure them.
//!
//! ## Algorithm
//! Between two stops (a *run*), the arc lengths `s_n` of the samples at `t = n T` are
//! chosen greedily: each step takes the largest advance `d = s_{n+1} - s_n` for which
//!
//! * the finite differences of the **exact path points** `P(s_{n-2..n+1})` hold every
//!   axis's acceleration and jerk limit (planned with the print and landing noise
//!   deducted, [`crate::feed::planned_acc`], [`crate::feed::jerk::planned_jerk`]), the
//!   per-axis velocity and the move's feed: these are the very quantities the report
//!   measures, so they hold by construction, the curvature coupling
//!   `3 v s'' K_i` of the jerk included exactly (the filter scheme has to reserve it
//!   for the worst `s''`; that reserve cost most of its time);
//! * the state is *safe*: a jerk-limited brake from it (jerk `-J_e` until the tangential
//!   deceleration is `U_c`, then `U_c`) stays under a **ceiling** `v_c(s)`, and a
//!   positive tangential acceleration can be ramped down at `J_e` before the curvature
//!   needs it gone (`3 v a |K_i| + v^3 |dK_i/ds| <= 0.9 J_i` ahead).
//!
//! The ceiling, on a grid of [`CEILING_STEP_MM`], is the least of the trapezoid plan's
//! speed (feed, chord error, per-axis velocity and curvature caps), the curvature cap
//! `(A_i - U_c |T_i|) / |K_i|`, the steady jerk cap `v^3 |dK_i/ds| <= J_i - J_e |T_i|`
//! and a landing curve into the stop, made braking-feasible at `U_c` by a backward pass.
//! Near the stop the follower *locks on* to the landing profile (the time reverse of a
//! jerk-limited start: jerk `J_e` to `U_c`, then `U_c`), whose phase is free, so the run
//! ends at rest exactly at the stop; the lock-on and the whole remaining profile are
//! checked like every other step.
//!
//! The greedy step can reach a state from which no advance holds the limits (braking
//! into a curvature peak with too much tangential acceleration, say). Then it
//! *backtracks*: the speed at that place is capped at [`BACKOFF`] of what it was (with
//! its braking cone), the tangential acceleration near it at [`ACC_BACKOFF`], and the run
//! is resumed [`REWIND_S`] before the first sample above the new ceiling. This is the
//! greedy time-optimal scheme of the feedrate-planning literature (forward scan with
//! backtracking under confined jerk, e.g. Zhang, Yuan and Gao's greedy algorithm) done
//! in the time domain on the setpoints themselves.
//!
//! ## Limits
//! Not provably optimal; the shares `U_c`, `J_e` ([`FOLLOW_U_SHARE`],
//! [`FOLLOW_JE_SHARE`]) bound only the safety predicate, not the motion. Every step
//! evaluates the path at a few dozen arc lengths, so it is slower to compute than the
//! filter (a NURBS costs more per evaluation than the other curves) and a run is held
//! whole while it is followed. The `arc` method's line-arc joints step the curvature,
//! which finite differences show whatever the planner (see [`crate::feed::jerk`]);
//! cycle times against the filter and the acceleration-only TOPP-RA bound are in
//! `docs/benchmarks/2026-12-02.md`. A run the follower cannot finish within
//! [`MAX_BACKTRACKS`] is followed again with halved shares, and if that fails too it is
//! sampled from the trapezoid ceiling, whose finite differences then exceed the jerk
//! limit: the report says so, and the CLI plans the file again with the filter scheme
//! (or exits non-zero when setpoints already went to stdout). Dense 3-D micro-segments
//! (camotics_vcarve) can have runs it gives up on (it falls back), and a program of many
//! short rest-to-rest runs (cncjs_jsdc) can take longer than with the filter, each run
//! paying for the landing at `J_e`, `U_c`.

use crate::feed::grid::MoveRef;
use crate::feed::{jerk::planned_jerk, planned_acc, planned_vaxis, PathIndex, PlanOptions};
use std::rc::Rc;

use crate::geom::STEP_ARCLEN_ACCURACY_MM;
use crate::geom::{
    arclen_gk7, ParamCurve, ParamCurveDeriv, PreparedNurbs, PreparedTrig, Segment, Vec3,
};

/// Tangential deceleration `U_c` of the safety brake, as a share of the smallest planned
/// axis acceleration.
pub(crate) const FOLLOW_U_SHARE: f64 = 0.6;
/// Tangential jerk `J_e` of the safety brake and the landing, as a share of the smallest
/// planned axis jerk.
pub(crate) const FOLLOW_JE_SHARE: f64 = 0.6;
/// Grid step of the ceiling (mm); longer runs use a coarser step so that a run holds at
/// most [`MAX_CEILING_POINTS`].
pub(crate) const CEILING_STEP_MM: f64 = 0.01;
/// Most grid points of a run's ceiling.
pub(crate) const MAX_CEILING_POINTS: usize = 4_000_000;
/// Share of the jerk limit the curvature terms may take when a positive tangential
/// acceleration is judged safe.
const COUPLING_SHARE: f64 = 0.9;
/// The follower tries to lock on to the landing profile when its speed is at least this
/// share of the profile's speed at its distance from the stop.
const LANDING_NEAR: f64 = 0.9;
/// Phases of the landing profile tried at each step of the landing zone.
const LOCK_ON_TRIES: usize = 81;
/// Points checked along a braking or ramp-down prediction.
const RAMP_CHECKS: usize = 6;
/// Bisections of the advance.
const BISECTIONS: usize = 40;
/// Projection steps to the advance of zero jerk.
const PROJECTIONS: usize = 4;
/// Speed cap set at a dead end, as a share of the speed there.
pub(crate) const BACKOFF: f64 = 0.9;
/// Tangential acceleration cap set around a dead end, as a share of the acceleration.
pub(crate) const ACC_BACKOFF: f64 = 0.7;
/// Half-length (mm) of the stretch the acceleration cap of a dead end covers.
const ACC_ZONE_MM: f64 = 0.5;
/// Floor (mm/s^2) of such an acceleration cap.
const ACC_ZONE_FLOOR: f64 = 10.0;
/// Time (s) rewound before the first sample above a lowered ceiling.
pub(crate) const REWIND_S: f64 = 0.1;
/// Dead ends after which a run is given up with its current shares.
pub(crate) const MAX_BACKTRACKS: usize = 400;
/// Attempts with halved shares before falling back to the ceiling.
const ATTEMPTS: usize = 3;
/// Relative slack of the ceiling test (rounding).
const CEIL_SLACK: f64 = 1e-7;
/// Lowest speed (mm/s) the coupling bound divides by.
const MIN_SPEED: f64 = 1e-9;

/// A place on the path: move, parameter and arc length.
#[derive(Clone, Copy, Debug)]
struct Place {
    j: usize,
    u: f64,
    s: f64,
}

/// Random access to the exact path point at an arc length, from a known place before it.
struct Probe<'p> {
    index: &'p PathIndex,
    /// The moves looked at last (a streamed window's lookup takes a lock).
    moves: std::cell::RefCell<Vec<(usize, MoveRef<'p>)>>,
    /// The fast form of the last NURBS or trigonometric move looked at.
    prepared: std::cell::RefCell<Option<(usize, Rc<Prepared>)>>,
}

/// A curve prepared for fast evaluation (as the interpolator does).
enum Prepared {
    Nurbs(PreparedNurbs),
    Trig(Box<PreparedTrig>),
    None,
}

/// The parameter at arc length `len` after `u0` and the point there.
fn arc_step<C: ParamCurve + ParamCurveDeriv>(c: &C, u0: f64, len: f64) -> (f64, Vec3) {
    if len <= 0.0 {
        return (u0, c.eval(u0));
    }
    let (mut lo, mut hi) = (u0, 1.0);
    let sp0 = c.deriv(u0).norm();
    let mut u = if sp0 > 0.0 {
        (u0 + len / sp0).min(1.0)
    } else {
        0.5 * (lo + hi)
    };
    for _ in 0..ARC_ITERS {
        let f = arclen_gk7(c, u0, u, STEP_ARCLEN_ACCURACY_MM) - len;
        if f.abs() <= STEP_ARCLEN_ACCURACY_MM {
            break;
        }
        if f > 0.0 {
            hi = u;
        } else {
            lo = u;
        }
        let sp = c.deriv(u).norm();
        let next = u - f / sp;
        u = if sp > 0.0 && next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo < 1e-16 {
            break;
        }
    }
    (u, c.eval(u))
}

/// Moves the probe keeps at hand.
const PROBE_CACHE_MOVES: usize = 4;
/// Steps a run may take, as a multiple of its samples in the trapezoid plan (plus
/// [`STEP_BUDGET_SLACK`]), before the attempt is given up: dead ends rewind and replay.
pub(crate) const STEP_BUDGET_FACTOR: usize = 20;
/// Steps every run may take besides.
pub(crate) const STEP_BUDGET_SLACK: usize = 2000;
/// Most Newton-bisection steps of an arc-length solve.
const ARC_ITERS: usize = 60;

impl<'p> Probe<'p> {
    /// Move `j`, from the cache when it was looked at lately.
    fn get(&self, j: usize) -> Option<MoveRef<'p>> {
        let mut cache = self.moves.borrow_mut();
        if let Some((_, m)) = cache.iter().find(|(k, _)| *k == j) {
            return Some(m.clone());
        }
        let m = self.index.get(j)?;
        if cache.len() >= PROBE_CACHE_MOVES {
            cache.remove(0);
        }
        cache.push((j, m.clone()));
        Some(m)
    }

    /// The point at arc length `s >= from.s` and its place.
    fn at(&self, from: Place, s: f64) -> (Place, Vec3) {
        let mut pl = from;
        loop {
            let Some(m) = self.get(pl.j) else {
                return (pl, self.index.start);
            };
            let end = m.s0 + m.len;
            if s > end {
                if self.get(pl.j + 1).is_some() {
                    pl = Place {
                        j: pl.j + 1,
                        u: 0.0,
                        s: end,
                    };
                    continue;
                }
                return (
                    Place {
                        u: 1.0,
                        s: end,
                        ..pl
                    },
                    m.segment.end(),
                );
            }
            if let Segment::Line(l) = &m.segment {
                let u = ((s - m.s0) / m.len.max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                return (Place { u, s, ..pl }, l.p0.lerp(l.p1, u));
            }
            let len = (s - pl.s).max(0.0);
            let (u, p) = match &*self.prepared_for(pl.j, &m.segment) {
                Prepared::Nurbs(c) => arc_step(c, pl.u, len),
                Prepared::Trig(c) => arc_step(&**c, pl.u, len),
                Prepared::None => arc_step(&m.segment, pl.u, len),
            };
            return (Place { u, s, ..pl }, p);
        }
    }

    /// The prepared form of move `j` (cached).
    fn prepared_for(&self, j: usize, seg: &Segment) -> Rc<Prepared> {
        let mut cache = self.prepared.borrow_mut();
        if let Some((k, p)) = cache.as_ref() {
            if *k == j {
                return p.clone();
            }
        }
        let p = Rc::new(match seg {
            Segment::Nurbs(n) => PreparedNurbs::new(n).map_or(Prepared::None, Prepared::Nurbs),
            Segment::Trig(c) => Prepared::Trig(Box::new(PreparedTrig::new(c))),
            _ => Prepared::None,
        });
        *cache = Some((j, p.clone()));
        p
    }

    /// Unit tangent at a place.
    fn tangent(&self, pl: Place) -> Vec3 {
        self.get(pl.j).map_or(Vec3::new(1.0, 0.0, 0.0), |m| {
            let d = m.segment.deriv(pl.u);
            let n = d.norm();
            if n > 0.0 {
                d * (1.0 / n)
            } else {
                Vec3::new(1.0, 0.0, 0.0)
            }
        })
    }

    /// Feed cap (mm/s) of the move at a place.
    fn vcap(&self, pl: Place) -> f64 {
        self.get(pl.j).map_or(0.0, |m| m.vcap_mm_s)
    }
}

/// The limits as the follower holds them.
#[derive(Clone, Copy, Debug)]
struct Limits {
    acc: [f64; 3],
    jerk: [f64; 3],
    vaxis: Option<[f64; 3]>,
    period: f64,
    /// Safety brake deceleration `U_c` and jerk `J_e`.
    uc: f64,
    je: f64,
}

impl Limits {
    fn new(popts: &PlanOptions, jerk: [f64; 3], share: f64) -> Limits {
        let t = popts.period_s;
        let acc = popts.acc_mm_s2.map(|a| planned_acc(a, t));
        let jerk = jerk.map(|j| planned_jerk(j, t));
        let amin = acc.iter().cloned().fold(f64::INFINITY, f64::min);
        let jmin = jerk.iter().cloned().fold(f64::INFINITY, f64::min);
        Limits {
            acc,
            jerk,
            vaxis: popts.vaxis_mm_s.map(|v| v.map(|v| planned_vaxis(v, t))),
            period: t,
            uc: FOLLOW_U_SHARE * share * amin,
            je: FOLLOW_JE_SHARE * share * jmin,
        }
    }

    /// Arc length of the landing profile `tau` seconds before rest.
    fn land_dist(&self, tau: f64) -> f64 {
        let tau = tau.max(0.0);
        let t1 = self.uc / self.je;
        if tau <= t1 {
            return self.je * tau.powi(3) / 6.0;
        }
        let (d1, v1) = (self.je * t1.powi(3) / 6.0, self.je * t1 * t1 / 2.0);
        d1 + v1 * (tau - t1) + self.uc * (tau - t1).powi(2) / 2.0
    }

    /// Time before rest at which the landing profile is `d` from the stop.
    fn land_time(&self, d: f64) -> f64 {
        let t1 = self.uc / self.je;
        let (d1, v1) = (self.je * t1.powi(3) / 6.0, self.je * t1 * t1 / 2.0);
        if d <= d1 {
            return (6.0 * d.max(0.0) / self.je).cbrt();
        }
        t1 + (-v1 + (v1 * v1 + 2.0 * self.uc * (d - d1)).sqrt()) / self.uc
    }

    /// Speed of the landing profile `d` from the stop.
    fn land_speed(&self, d: f64) -> f64 {
        let tau = self.land_time(d);
        let t1 = self.uc / self.je;
        if tau <= t1 {
            self.je * tau * tau / 2.0
        } else {
            self.je * t1 * t1 / 2.0 + self.uc * (tau - t1)
        }
    }
}

/// Geometry and ceiling of a run on its grid.
struct Ceiling {
    s0: f64,
    h: f64,
    /// `v^2` ceiling at the grid points.
    x: Vec<f64>,
    /// `|K_i|` and `|dK_i/ds|` at the grid points.
    k: Vec<[f64; 3]>,
    dk: Vec<[f64; 3]>,
    /// Speed caps set at dead ends: `(s, v^2, u)`, with their braking cones at `u`.
    caps: Vec<(f64, f64, f64)>,
    /// Tangential acceleration caps set around dead ends: `(from s, to s, cap)`.
    acc_caps: Vec<(f64, f64, f64)>,
}

fn abs3(v: Vec3) -> [f64; 3] {
    [v.x.abs(), v.y.abs(), v.z.abs()]
}

impl Ceiling {
    /// The ceiling of the run `[s_a, s_b]` from place `start`; `plan_x(s)` is the
    /// trapezoid plan's `v^2`.
    fn new(
        probe: &Probe,
        start: Place,
        s_b: f64,
        lim: &Limits,
        plan_x: &dyn Fn(f64) -> f64,
    ) -> Ceiling {
        let len = (s_b - start.s).max(0.0);
        let n = ((len / CEILING_STEP_MM).ceil() as usize).clamp(1, MAX_CEILING_POINTS);
        let h = len / n as f64;
        let mut pts = Vec::with_capacity(n + 1);
        let mut pl = start;
        for i in 0..=n {
            let (p2, q) = probe.at(pl, start.s + i as f64 * h);
            pts.push(q);
            pl = p2;
        }
        let at = |i: isize| pts[i.clamp(0, n as isize) as usize];
        let mut x = vec![0.0; n + 1];
        let (mut kk, mut dkk) = (vec![[0.0; 3]; n + 1], vec![[0.0; 3]; n + 1]);
        for i in 0..=n {
            let ii = i as isize;
            let t = abs3((at(ii + 1) - at(ii - 1)) * (0.5 / h.max(f64::MIN_POSITIVE)));
            let k = abs3((at(ii + 1) - at(ii) * 2.0 + at(ii - 1)) * (1.0 / (h * h).max(1e-300)));
            let dk = abs3(
                (at(ii + 2) - at(ii + 1) * 2.0 + at(ii - 1) * 2.0 - at(ii - 2))
                    * (0.5 / (h * h * h).max(1e-300)),
            );
            let s = start.s + i as f64 * h;
            let mut xi = plan_x(s);
            for a in 0..3 {
                let tn = t[a].min(1.0);
                if k[a] > 0.0 {
                    xi = xi.min(((lim.acc[a] - lim.uc * tn) / k[a]).max(0.0));
                }
                if dk[a] > 0.0 {
                    xi = xi.min(((lim.jerk[a] - lim.je * tn).max(0.0) / dk[a]).powf(2.0 / 3.0));
                }
            }
            xi = xi.min(lim.land_speed(s_b - s).powi(2));
            x[i] = xi;
            kk[i] = k;
            dkk[i] = dk;
        }
        x[n] = 0.0;
        for i in (0..n).rev() {
            x[i] = x[i].min(x[i + 1] + 2.0 * lim.uc * h);
        }
        Ceiling {
            s0: start.s,
            h,
            x,
            k: kk,
            dk: dkk,
            caps: Vec::new(),
            acc_caps: Vec::new(),
        }
    }

    fn idx(&self, s: f64) -> usize {
        if self.h <= 0.0 {
            return 0;
        }
        (((s - self.s0) / self.h).round().max(0.0) as usize).min(self.x.len() - 1)
    }

    /// Ceiling speed at `s`.
    fn v(&self, s: f64) -> f64 {
        let n = self.x.len() - 1;
        let f = if self.h > 0.0 {
            ((s - self.s0) / self.h).clamp(0.0, n as f64)
        } else {
            0.0
        };
        let i = (f.floor() as usize).min(n.saturating_sub(1));
        let w = f - i as f64;
        let mut x = if n == 0 {
            self.x[0]
        } else {
            self.x[i] * (1.0 - w) + self.x[i + 1] * w
        };
        for &(sj, xj, uj) in &self.caps {
            if s <= sj {
                x = x.min(xj + 2.0 * uj * (sj - s));
            }
        }
        x.max(0.0).sqrt()
    }

    /// Largest safe tangential acceleration at `s`, speed `v` (see the module doc).
    fn acc_cap(&self, s: f64, v: f64, lim: &Limits) -> f64 {
        let i = self.idx(s);
        let v = v.max(MIN_SPEED);
        let mut cap = f64::INFINITY;
        for a in 0..3 {
            let room = (COUPLING_SHARE * lim.jerk[a] - v.powi(3) * self.dk[i][a]).max(0.0);
            if self.k[i][a] > 0.0 {
                cap = cap.min(room / (3.0 * v * self.k[i][a]));
            }
        }
        for &(lo, hi, c) in &self.acc_caps {
            if (lo..=hi).contains(&s) {
                cap = cap.min(c);
            }
        }
        cap
    }
}

/// The samples of one run: arc lengths at `t = 0, T, 2T, ...`, first and last at rest.
struct Run<'p, 'c> {
    probe: &'c Probe<'p>,
    lim: Limits,
    ceil: Ceiling,
    s_b: f64,
    s: Vec<f64>,
    p: Vec<Vec3>,
    place: Vec<Place>,
}

impl Run<'_, '_> {
    fn n(&self) -> usize {
        self.s.len() - 1
    }

    /// Whether the points `q` appended to the committed ones hold the limits at every
    /// new difference.
    fn holds(&self, q: &[(Place, Vec3)]) -> bool {
        let n = self.n();
        let t = self.lim.period;
        let get = |k: usize| {
            if k <= n {
                self.p[k]
            } else {
                q[k - n - 1].1
            }
        };
        for (m, &(pl, pt)) in q.iter().enumerate() {
            let k = n + 1 + m;
            let (a, b, c) = (get(k - 1), get(k - 2), get(k - 3));
            let vel = abs3((pt - a) * (1.0 / t));
            let acc = abs3((pt - a * 2.0 + b) * (1.0 / (t * t)));
            let jerk = abs3((pt - a * 3.0 + b * 3.0 - c) * (1.0 / (t * t * t)));
            let ds = pl.s - if m == 0 { self.s[n] } else { q[m - 1].0.s };
            if ds > self.probe.vcap(pl) * t * (1.0 + CEIL_SLACK) {
                return false;
            }
            for i in 0..3 {
                if acc[i] > self.lim.acc[i] || jerk[i] > self.lim.jerk[i] {
                    return false;
                }
                if self.lim.vaxis.is_some_and(|v| vel[i] > v[i]) {
                    return false;
                }
            }
        }
        true
    }

    fn point(&self, s: f64) -> (Place, Vec3) {
        self.probe.at(self.place[self.n()], s)
    }

    fn ok(&self, d: f64) -> bool {
        let s = self.s[self.n()] + d;
        s <= self.s_b && self.holds(&[self.point(s)])
    }

    /// The brake and ramp-down predictions of the module doc.
    fn safe(&self, d: f64) -> bool {
        let n = self.n();
        let t = self.lim.period;
        let a = (d - (self.s[n] - self.s[n - 1])) / (t * t);
        // One more period at this acceleration before the brake starts (the follower
        // decides once per period).
        // Speed at the new sample: the mean speed of the step plus half a step of the
        // acceleration.
        let v_new = d / t + a * t / 2.0;
        if v_new > self.ceil.v(self.s[n] + d) * (1.0 + CEIL_SLACK) {
            return false;
        }
        let (q, v) = (self.s[n] + d + v_new * t + a * t * t / 2.0, v_new + a * t);
        let je = self.lim.je;
        let ramp = |tau: f64, k: usize| tau * k as f64 / RAMP_CHECKS as f64;
        if a > 0.0 {
            for k in 0..=RAMP_CHECKS {
                let tt = ramp(a / je, k);
                let (qq, vv) = (
                    q + v * tt + a * tt * tt / 2.0,
                    v + a * tt - je * tt * tt / 2.0,
                );
                if a - je * tt > self.ceil.acc_cap(qq, vv, &self.lim) {
                    return false;
                }
            }
        }
        if a > 0.0 {
            // The peak of the brake's speed, where the jerk has taken the acceleration.
            let tt = a / je;
            let qq = q + v * tt + a * tt * tt / 2.0 - je * tt.powi(3) / 6.0;
            if v + a * a / (2.0 * je) > self.ceil.v(qq) {
                return false;
            }
        }
        let tau = (a + self.lim.uc).max(0.0) / je;
        for k in 1..=RAMP_CHECKS {
            let tt = ramp(tau, k);
            let vv = v + a * tt - je * tt * tt / 2.0;
            if vv <= 0.0 {
                return true;
            }
            let qq = q + v * tt + a * tt * tt / 2.0 - je * tt.powi(3) / 6.0;
            if vv > self.ceil.v(qq) {
                return false;
            }
        }
        true
    }

    fn push(&mut self, pl: Place, pt: Vec3) {
        self.s.push(pl.s);
        self.p.push(pt);
        self.place.push(pl);
    }

    /// Locks on to the landing profile if some phase of it holds the limits to rest.
    fn try_land(&mut self) -> bool {
        let n = self.n();
        let t = self.lim.period;
        let rem = self.s_b - self.s[n];
        let th0 = self.lim.land_time(rem) - t;
        for k in 0..LOCK_ON_TRIES {
            let th = th0 + t * (2.0 * k as f64 / (LOCK_ON_TRIES - 1) as f64 - 1.0);
            if th <= 0.0 {
                continue;
            }
            let first = self.s_b - self.lim.land_dist(th);
            if first < self.s[n] {
                continue;
            }
            // Three points first: most phases fail at the junction.
            let mut tail = Vec::new();
            let mut pl = self.place[n];
            let steps = (th / t).ceil() as usize + 3;
            for m in 0..steps {
                let s = (self.s_b - self.lim.land_dist(th - m as f64 * t)).max(pl.s);
                let (p2, pt) = self.probe.at(pl, s);
                tail.push((p2, pt));
                pl = p2;
                if m == 2 && !self.holds(&tail) {
                    break;
                }
            }
            if tail.len() == steps && self.holds(&tail) {
                for (pl, pt) in tail {
                    self.push(pl, pt);
                }
                return true;
            }
        }
        false
    }

    /// The advance of zero jerk along the path (projection of `3 P_n - 3 P_{n-1} +
    /// P_{n-2}` on it), the natural first guess.
    fn zero_jerk_advance(&self, de: f64) -> f64 {
        let n = self.n();
        let c = self.p[n] * 3.0 - self.p[n - 1] * 3.0 + self.p[n - 2];
        let mut d = de;
        for _ in 0..PROJECTIONS {
            let (pl, pt) = self.point((self.s[n] + d).min(self.s_b));
            d = (d + (c - pt).dot(self.probe.tangent(pl))).max(0.0);
        }
        d
    }

    /// A dead end at the last sample: caps the speed and acceleration there and rewinds.
    fn backtrack(&mut self) {
        let n = self.n();
        let t = self.lim.period;
        let q = self.s[n];
        let v = (self.s[n] - self.s[n - 1]) / t;
        let a = (self.s[n] - 2.0 * self.s[n - 1] + self.s[n - 2]) / (t * t);
        // Each dead end near an earlier one brakes for it earlier and harder: its speed
        // cap is lower and its cone shallower, so the replay differs.
        let m = self
            .ceil
            .caps
            .iter()
            .filter(|c| (c.0 - q).abs() <= ACC_ZONE_MM)
            .count() as i32;
        let uj = self.lim.uc * 0.5f64.powi(m);
        self.ceil
            .caps
            .push((q, (BACKOFF.powi(m + 1) * v).powi(2), uj));
        self.ceil.acc_caps.push((
            q - ACC_ZONE_MM,
            q + ACC_ZONE_MM,
            (ACC_BACKOFF * a.abs()).max(ACC_ZONE_FLOOR),
        ));
        let mut k = n;
        while k > 3 && (self.s[k] - self.s[k - 1]) / t > self.ceil.v(self.s[k]) * (1.0 - 1e-3) {
            k -= 1;
        }
        let back = (REWIND_S / t).ceil() as usize;
        let k = k.saturating_sub(back).max(3);
        self.s.truncate(k);
        self.p.truncate(k);
        self.place.truncate(k);
    }

    /// One step; false when the run is at rest at its end.
    fn step(&mut self) -> Result<bool, ()> {
        let n = self.n();
        let t = self.lim.period;
        let rem = self.s_b - self.s[n];
        let dp = self.s[n] - self.s[n - 1];
        if rem <= 0.0 && dp <= 0.0 {
            return Ok(false);
        }
        // Lock on only near the landing profile (it is the ceiling's last part).
        let near = dp / t >= LANDING_NEAR * self.lim.land_speed(rem);
        if near && self.try_land() {
            return Ok(false);
        }
        let de = (2.0 * dp - (self.s[n - 1] - self.s[n - 2])).max(0.0);
        let dd = self.zero_jerk_advance(de);
        let cands = [dd, de, dp, 0.0];
        let Some(lo) = cands.iter().copied().find(|&c| self.ok(c)) else {
            return Err(());
        };
        let vmax = self.probe.vcap(self.place[n]);
        let hi = (vmax * t).min(rem).max(lo);
        let good = |c: f64| self.ok(c) && self.safe(c);
        // The hardest braking the limits allow: the least advance that holds them.
        let c_min = if self.ok(0.0) {
            0.0
        } else {
            let (mut a, mut b) = (0.0, lo);
            for _ in 0..BISECTIONS {
                let m = 0.5 * (a + b);
                if self.ok(m) {
                    b = m;
                } else {
                    a = m;
                }
            }
            b
        };
        let c = if good(hi) {
            hi
        } else if good(c_min) {
            let (mut a, mut b) = (c_min, hi);
            for _ in 0..BISECTIONS {
                let m = 0.5 * (a + b);
                if good(m) {
                    a = m;
                } else {
                    b = m;
                }
            }
            a
        } else {
            c_min
        };
        let (pl, pt) = self.point(self.s[n] + c);
        self.push(pl, pt);
        Ok(true)
    }
}

/// Follows one run from rest at `start` to rest at `s_b`: the arc lengths of its samples
/// at `t = 0, T, ...` (the first at `start`, the last at `s_b`), or `None` if the follower
/// gave up (see the module doc). `plan_x(s)` is the trapezoid plan's `v^2`.
pub(crate) fn follow_run(
    index: &PathIndex,
    start: (usize, f64),
    s_b: f64,
    popts: &PlanOptions,
    jerk: [f64; 3],
    plan_x: &dyn Fn(f64) -> f64,
    plan_samples: usize,
) -> Option<Vec<f64>> {
    let budget = STEP_BUDGET_FACTOR * plan_samples + STEP_BUDGET_SLACK;
    let probe = Probe {
        index,
        moves: std::cell::RefCell::new(Vec::new()),
        prepared: std::cell::RefCell::new(None),
    };
    let (j, s_a) = start;
    let m0 = index.get(j).map_or(s_a, |m| m.s0);
    let (pl, _) = probe.at(Place { j, u: 0.0, s: m0 }, s_a);
    if s_b - s_a <= 0.0 {
        return Some(vec![s_a]);
    }
    let mut share = 1.0;
    for _ in 0..ATTEMPTS {
        let lim = Limits::new(popts, jerk, share);
        if let Some(s) = attempt(&probe, pl, s_b, lim, plan_x, budget) {
            return Some(s);
        }
        share *= 0.5;
    }
    None
}

fn attempt(
    probe: &Probe,
    start: Place,
    s_b: f64,
    lim: Limits,
    plan_x: &dyn Fn(f64) -> f64,
    budget: usize,
) -> Option<Vec<f64>> {
    let p0 = probe.at(start, start.s).1;
    let mut run = Run {
        probe,
        lim,
        ceil: Ceiling::new(probe, start, s_b, &lim, plan_x),
        s_b,
        s: vec![start.s; 3],
        p: vec![p0; 3],
        place: vec![start; 3],
    };
    let mut dead_ends = 0;
    let mut landed = false;
    for _ in 0..budget {
        match run.step() {
            Ok(true) => {}
            Ok(false) => {
                landed = true;
                break;
            }
            Err(()) => {
                dead_ends += 1;
                if dead_ends > MAX_BACKTRACKS {
                    return None;
                }
                run.backtrack();
            }
        }
    }
    if !landed {
        return None;
    }
    let mut s = run.s.split_off(2);
    while s.len() > 1 && s[s.len() - 2] >= s_b {
        s.pop();
    }
    if let Some(last) = s.last_mut() {
        *last = s_b;
    }
    Some(s)
}

//! Circular arcs in any plane, optionally helical (a linear motion along the plane normal
//! accompanies the rotation, as G2/G3 with the third axis do) and optionally spiral (the
//! radius changes linearly with the angle, as LinuxCNC runs a centre-format arc whose end
//! is not on the circle of its start). Every operation is exact (closed form) except the
//! nearest point on a helical or spiral arc, which is numerical, and the parameter at an
//! arc length on a spiral, which is Newton's to 1e-12 of the length.
//!
//! Representation: `C(t) = c + (r + s t) (cos(phi t) u + sin(phi t) v) + t h` for
//! `t in [0, 1]`, with `u`, `v` orthonormal in the plane of the arc (`u` towards the start,
//! `v` the direction of motion at the start), `phi > 0` the swept angle (may exceed `2 pi`
//! for multi-turn arcs), `h` the helical displacement, parallel to `n = u x v`, and `s` the
//! spiral: the end radius less the start radius (LinuxCNC's `PmCircle::spiral`, whose
//! `pmCirclePoint` puts the radius at `r + s theta / phi`). Circles have `s = 0`, and every
//! result of a circle is computed by the circle's own formulas.

use super::traits::*;
use super::vec3::{Aabb, Vec3};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

/// A circular or helical arc.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Arc {
    /// Centre (at the start height for helical arcs).
    pub center: Vec3,
    /// Radius (mm), > 0.
    pub radius: f64,
    /// Unit vector from the centre towards the start point.
    pub u: Vec3,
    /// Unit vector of the direction of motion at the start (perpendicular to `u`).
    pub v: Vec3,
    /// Swept angle in radians, > 0.
    pub sweep: f64,
    /// Helical displacement over the whole arc, along `u x v` (zero for planar arcs).
    pub axial: Vec3,
    /// End radius less start radius (mm): the radius at `t` is `radius + spiral t`. Zero
    /// for a circle; LinuxCNC's spiral for a centre-format arc whose end radius differs
    /// from its start radius (within its interpreter's tolerance).
    #[serde(default)]
    pub spiral: f64,
}

/// Chord between an arc's in-plane ends, as a share of its radius, below which the ends
/// coincide and the arc is a full circle (rounding of the end point).
pub(crate) const FULL_CIRCLE_CHORD_SHARE: f64 = 1e-12;

/// Difference of the end radius from the start radius, as a share of the start radius, up
/// to which [`Arc::from_center`] takes the arc for a circle: the round-off of a centre
/// computed from an `R` word or of an end computed on the circle. The end is then within
/// this share of the radius (or `SPIRAL_ROUNDOFF_ULPS`) of the given end point.
pub(crate) const SPIRAL_ROUNDOFF_SHARE: f64 = 1e-12;

/// The same round-off in units of `f64::EPSILON` of the largest coordinate of the start,
/// end and centre: radii computed from coordinates of 1e5 mm carry 1e-11 mm of it.
pub(crate) const SPIRAL_ROUNDOFF_ULPS: f64 = 1024.0;

/// The plane geometry of an arc from its start, end, centre and axis (see
/// [`Arc::from_center`]).
struct Frame {
    n: Vec3,
    along: f64,
    end_in_plane: Vec3,
    /// Centre projected onto the plane of the start point.
    center: Vec3,
    chord: Vec3,
    chord_len: f64,
    r_start: f64,
    r_end: f64,
    /// The ends coincide in the plane but for rounding.
    full_circle: bool,
}

impl Frame {
    fn new(start: Vec3, end: Vec3, center: Vec3, axis: Vec3) -> Option<Frame> {
        let n = axis.normalized()?;
        let along = (end - start).dot(n);
        let end_in_plane = end - n * along;
        let center = center - n * (center - start).dot(n);
        let chord = end_in_plane - start;
        let chord_len = chord.norm();
        let r_start = start.dist(center);
        let r_end = end_in_plane.dist(center);
        Some(Frame {
            n,
            along,
            end_in_plane,
            center,
            chord,
            chord_len,
            r_start,
            r_end,
            full_circle: chord_len <= r_start * FULL_CIRCLE_CHORD_SHARE,
        })
    }

    /// The arc about `c` (in the start's plane) with the radius changing by `spiral`.
    fn arc(&self, start: Vec3, c: Vec3, ccw: bool, turns: u32, spiral: f64) -> Option<Arc> {
        let radius = start.dist(c);
        if radius <= 0.0 || !radius.is_finite() || !self.along.is_finite() {
            return None;
        }
        let u = (start - c) / radius;
        let s = if ccw { 1.0 } else { -1.0 };
        let axis_dir = self.n * s; // rotation is positive about axis_dir
        let v = axis_dir.cross(u);
        let e = self.end_in_plane - c;
        let mut ang = e.dot(v).atan2(e.dot(u));
        if ang <= 0.0 {
            ang += TAU;
        }
        // Coincident in-plane ends: a full circle rather than a zero sweep.
        if self.full_circle {
            ang = TAU;
        }
        let sweep = ang + TAU * turns as f64;
        Some(Arc {
            center: c,
            radius,
            u,
            v,
            sweep,
            axial: self.n * self.along,
            spiral,
        })
    }
}

/// Chord, as a share of the radius, from which a circle of round-off radii turning more
/// than a half turn has its centre moved onto the chord's bisector so that it ends exactly
/// at its end point (the move is at most the round-off over this share); one turning less
/// always has.
const ROUNDOFF_BISECTOR_CHORD_SHARE: f64 = 1e-3;

impl Arc {
    /// Circular arc from `start` to `end` about the axis `axis` (unit normal of the arc
    /// plane) through `center`. `ccw` means a positive (right-handed) rotation about
    /// `axis`. `turns` adds full extra turns (G-code `P` word minus one). When `start` and
    /// `end` coincide in the plane the arc is a full circle.
    ///
    /// The component of `end - start` along `axis` becomes the helical displacement.
    /// When the start and end radii differ (the round-off of a constructed centre), the
    /// centre is moved to the point of the perpendicular bisector of the in-plane chord
    /// nearest the given centre, so that the arc ends exactly at `end`. A programmed arc
    /// is [`Arc::from_center_spiral`]: LinuxCNC keeps its centre. Returns `None` for a zero
    /// radius or non-finite input.
    pub fn from_center(
        start: Vec3,
        end: Vec3,
        center: Vec3,
        axis: Vec3,
        ccw: bool,
        turns: u32,
    ) -> Option<Arc> {
        let f = Frame::new(start, end, center, axis)?;
        let mut c = f.center;
        if !f.full_circle && f.r_start != f.r_end {
            // Move the centre onto the bisector: c' = c - ((c - mid) . d) d, d = chord dir.
            let d = f.chord / f.chord_len;
            let mid = (start + f.end_in_plane) * 0.5;
            c -= d * (c - mid).dot(d);
        }
        f.arc(start, c, ccw, turns, 0.0)
    }

    /// The arc LinuxCNC runs for a centre-format `G2`/`G3` (posemath's `pmCircleInit`):
    /// about `center` as given, from the direction of `start` to that of `end`, the radius
    /// linear in the angle from the start's to the end's, so that the arc ends exactly at
    /// `end` (a spiral, [`Arc::spiral`], when the radii differ; callers that must reject
    /// inconsistent arcs check the radii before). Radii equal within round-off
    /// (`SPIRAL_ROUNDOFF_SHARE` of the radius, `SPIRAL_ROUNDOFF_ULPS` of the coordinates)
    /// give a circle, as [`Arc::from_center`] makes it, but for one turning more than a
    /// half turn over a chord under a thousandth of its radius (a near-full circle, which
    /// moving the centre along the chord would shift), whose centre is kept. Otherwise as
    /// [`Arc::from_center`].
    pub fn from_center_spiral(
        start: Vec3,
        end: Vec3,
        center: Vec3,
        axis: Vec3,
        ccw: bool,
        turns: u32,
    ) -> Option<Arc> {
        let f = Frame::new(start, end, center, axis)?;
        let magnitude = [start, f.end_in_plane, f.center]
            .iter()
            .map(|p| p.x.abs().max(p.y.abs()).max(p.z.abs()))
            .fold(f.r_start, f64::max);
        let roundoff = (f.r_end - f.r_start).abs()
            <= (f.r_start * SPIRAL_ROUNDOFF_SHARE)
                .max(magnitude * SPIRAL_ROUNDOFF_ULPS * f64::EPSILON);
        if f.full_circle || !roundoff {
            let spiral = if f.full_circle {
                0.0
            } else {
                f.r_end - f.r_start
            };
            return f.arc(start, f.center, ccw, turns, spiral);
        }
        // Less than a half turn: moving the centre along the chord barely moves the arc.
        let sense = if ccw { 1.0 } else { -1.0 };
        let c = f.center;
        let short = turns == 0 && (start - c).cross(f.end_in_plane - c).dot(f.n) * sense > 0.0;
        if short || f.chord_len >= f.r_start * ROUNDOFF_BISECTOR_CHORD_SHARE {
            Arc::from_center(start, end, center, axis, ccw, turns)
        } else {
            f.arc(start, c, ccw, turns, 0.0)
        }
    }

    /// Arc through `start` tangent to the unit direction `tangent` there, ending at `end`
    /// (the unique circle, the short or long way as the geometry dictates), planar. `None`
    /// when `end` lies on the tangent line.
    pub fn from_tangent(start: Vec3, tangent: Vec3, end: Vec3) -> Option<Arc> {
        let t = tangent.normalized()?;
        let chord = end - start;
        let n = t.cross(chord).normalized()?;
        // Centre lies on start + k * (n x t); |c - start| = |c - end|.
        let w = n.cross(t);
        let k = chord.norm_sq() / (2.0 * chord.dot(w));
        if !k.is_finite() {
            return None;
        }
        let center = start + w * k;
        // `end` lies in the plane of `start` and `n` by construction: what `from_center`
        // finds along `n` is round-off, not a helix (a helical arc's nearest point is
        // numerical, and its G-code another word).
        let arc = Arc::from_center(start, end, center, n, true, 0)?;
        Some(Arc {
            axial: Vec3::ZERO,
            spiral: 0.0,
            ..arc
        })
    }

    /// Unit normal of the plane, oriented so that the motion is a positive rotation.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        self.u.cross(self.v)
    }

    /// Exact length: `sqrt((r phi)^2 + |h|^2)` for a circle, the closed form of
    /// [`Arc::length_between`] for a spiral.
    #[inline]
    pub fn length(&self) -> f64 {
        if self.spiral == 0.0 {
            (self.radius * self.sweep).hypot(self.axial.norm())
        } else {
            self.length_between(0.0, 1.0)
        }
    }

    /// Exact length between parameters `t0 <= t1`. The speed is
    /// `sqrt(K^2 + x^2)` with `K^2 = s^2 + |h|^2` and `x = phi (r + s t)` linear in `t`,
    /// whose integral `(x q + K^2 asinh(x / K)) / 2` (`q = sqrt(K^2 + x^2)`) is evaluated
    /// in a form free of cancellation between the ends (both differences divided through
    /// by `x1 - x0 = phi s (t1 - t0)`), so that it holds from `s = 0` (where it is the
    /// circle's `q`) to spirals of any pitch.
    pub fn length_between(&self, t0: f64, t1: f64) -> f64 {
        if t1 <= t0 {
            return 0.0;
        }
        if self.spiral == 0.0 {
            return (self.radius * self.sweep).hypot(self.axial.norm()) * (t1 - t0);
        }
        let k2 = self.spiral * self.spiral + self.axial.norm_sq();
        let x0 = self.sweep * (self.radius + self.spiral * t0);
        let x1 = self.sweep * (self.radius + self.spiral * t1);
        let (q0, q1) = ((k2 + x0 * x0).sqrt(), (k2 + x1 * x1).sqrt());
        let sum = x0 + x1;
        // (x1 q1 - x0 q0) / (x1 - x0)
        let first = sum * (k2 + x0 * x0 + x1 * x1) / (x1 * q1 + x0 * q0);
        // (asinh(x1 / K) - asinh(x0 / K)) / (x1 - x0) = asinh(y) / (x1 - x0), with
        // y = (x1 - x0) w.
        let w = sum / (x1 * q0 + x0 * q1);
        let y = (x1 - x0) * w;
        let second = if y == 0.0 { w } else { w * (y.asinh() / y) };
        0.5 * (first + k2 * second) * (t1 - t0)
    }

    /// Largest parametric speed `|C'(t)|` (mm per unit of `t`): the length of a circle,
    /// a spiral's speed at its larger radius.
    pub fn max_speed(&self) -> f64 {
        if self.spiral == 0.0 {
            return self.length();
        }
        let r_max = self.radius.max(self.radius_at(1.0));
        let k2 = self.spiral * self.spiral + self.axial.norm_sq();
        (k2 + (self.sweep * r_max).powi(2)).sqrt()
    }

    /// Parameter at the share `f` of the length (clamped to `[0, 1]`): `f` itself on a
    /// circle, [`ParamCurveArclen::inv_arclen`] on a spiral.
    pub fn param_at_share(&self, f: f64) -> f64 {
        if self.spiral == 0.0 || f <= 0.0 || f >= 1.0 {
            return f.clamp(0.0, 1.0);
        }
        self.inv_arclen(f * self.length(), 0.0)
    }

    /// True when the arc has a helical displacement.
    pub fn is_helical(&self) -> bool {
        self.axial.norm_sq() > 0.0
    }

    /// True when the radius changes along the arc (LinuxCNC's spiral).
    pub fn is_spiral(&self) -> bool {
        self.spiral != 0.0
    }

    /// Radius at parameter `t`: `radius + spiral t`.
    #[inline]
    pub fn radius_at(&self, t: f64) -> f64 {
        self.radius + self.spiral * t
    }

    /// The part of the arc between parameters `t0 < t1` (exact).
    pub fn subsegment(&self, t0: f64, t1: f64) -> Arc {
        let a0 = self.sweep * t0;
        let (s, c) = a0.sin_cos();
        let u = self.u * c + self.v * s;
        let v = self.v * c - self.u * s;
        Arc {
            center: self.center + self.axial * t0,
            radius: self.radius_at(t0),
            u,
            v,
            sweep: self.sweep * (t1 - t0),
            axial: self.axial * (t1 - t0),
            spiral: self.spiral * (t1 - t0),
        }
    }

    /// The same arc traversed backwards.
    pub fn reversed(&self) -> Arc {
        let e = self.subsegment(1.0, 1.0);
        Arc {
            center: e.center,
            radius: self.radius_at(1.0),
            u: e.u,
            v: -e.v,
            sweep: self.sweep,
            axial: -self.axial,
            spiral: -self.spiral,
        }
    }

    /// Unit tangent at the start.
    pub fn start_tangent(&self) -> Vec3 {
        self.deriv(0.0).normalized().unwrap_or(self.v)
    }

    /// Unit tangent at the end.
    pub fn end_tangent(&self) -> Vec3 {
        self.deriv(1.0).normalized().unwrap_or(self.v)
    }

    /// Number of chords (uniform in `t`) whose distance from the arc is at most
    /// `accuracy`. A circle's chord has the sagitta `r (1 - cos(dphi / 2))`. A spiral's
    /// chord over `dt` lies within `max |C''_plane| dt^2 / 8` of it (the helical part is
    /// linear in `t` and interpolated exactly), with
    /// `|C''_plane| <= 2 |s| phi + r_max phi^2`.
    pub(crate) fn chord_count(&self, accuracy: f64) -> usize {
        let n = if self.spiral == 0.0 {
            let ratio = (1.0 - accuracy / self.radius).max(-1.0);
            let max_step = 2.0 * ratio.acos();
            (self.sweep / max_step).ceil()
        } else {
            let r_max = self.radius.max(self.radius_at(1.0));
            let d2 = 2.0 * self.spiral.abs() * self.sweep + r_max * self.sweep * self.sweep;
            (d2 / (8.0 * accuracy)).sqrt().ceil()
        };
        if n.is_finite() {
            (n as usize).max(1)
        } else {
            1
        }
    }
}

impl Arc {
    /// Point, unit tangent and curvature vector at `t`, from one `sin_cos` (the planner
    /// samples arcs densely). The second derivative is radial, hence perpendicular to the
    /// first even on a helix, so the curvature vector is `C'' / |C'|^2`.
    #[inline]
    pub fn frame(&self, t: f64) -> (Vec3, Vec3, Vec3) {
        if self.spiral != 0.0 {
            let d1 = self.deriv(t);
            let tangent = d1.normalized().unwrap_or(self.v);
            return (
                self.eval(t),
                tangent,
                curvature_vec_from(d1, self.deriv2(t)),
            );
        }
        let (s, c) = (self.sweep * t).sin_cos();
        let radial = self.u * c + self.v * s;
        let p = self.center + radial * self.radius + self.axial * t;
        let d1 = (self.v * c - self.u * s) * (self.radius * self.sweep) + self.axial;
        let speed_sq = d1.norm_sq();
        let d2 = radial * (-self.radius * self.sweep * self.sweep);
        (p, d1 / speed_sq.sqrt(), d2 / speed_sq)
    }
}

impl ParamCurve for Arc {
    #[inline]
    fn eval(&self, t: f64) -> Vec3 {
        let (s, c) = (self.sweep * t).sin_cos();
        if self.spiral == 0.0 {
            self.center + (self.u * c + self.v * s) * self.radius + self.axial * t
        } else {
            self.center + (self.u * c + self.v * s) * self.radius_at(t) + self.axial * t
        }
    }
}

impl ParamCurveDeriv for Arc {
    #[inline]
    fn deriv(&self, t: f64) -> Vec3 {
        let (s, c) = (self.sweep * t).sin_cos();
        let tangential = (self.v * c - self.u * s) * (self.radius_at(t) * self.sweep);
        if self.spiral == 0.0 {
            tangential + self.axial
        } else {
            tangential + (self.u * c + self.v * s) * self.spiral + self.axial
        }
    }
    #[inline]
    fn deriv2(&self, t: f64) -> Vec3 {
        let (s, c) = (self.sweep * t).sin_cos();
        let radial = (self.u * c + self.v * s) * (-self.radius_at(t) * self.sweep * self.sweep);
        if self.spiral == 0.0 {
            radial
        } else {
            radial + (self.v * c - self.u * s) * (2.0 * self.spiral * self.sweep)
        }
    }
}

/// Relative accuracy of the length at the parameter [`Arc`]'s `inv_arclen` returns on a
/// spiral (the length itself is closed form).
const SPIRAL_INV_ARCLEN_SHARE: f64 = 1e-12;

impl ParamCurveArclen for Arc {
    /// Exact; `accuracy` is ignored.
    fn arclen(&self, _accuracy: f64) -> f64 {
        self.length()
    }
    /// Exact on a circle (the speed is constant); on a spiral Newton's steps on the
    /// closed-form length, to `SPIRAL_INV_ARCLEN_SHARE` of the length or `accuracy`,
    /// whichever is smaller (the speed changes by at most the ratio of the radii, so a
    /// few steps from `s / L` suffice).
    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        let total = self.length();
        let t = (s / total).clamp(0.0, 1.0);
        if self.spiral == 0.0 || !(t > 0.0 && t < 1.0) {
            return t;
        }
        let acc = (total * SPIRAL_INV_ARCLEN_SHARE).min(accuracy.max(f64::MIN_POSITIVE));
        let (mut lo, mut hi, mut t) = (0.0_f64, 1.0_f64, t);
        for _ in 0..64 {
            let err = self.length_between(0.0, t) - s;
            if err.abs() <= acc {
                break;
            }
            if err > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let next = t - err / self.deriv(t).norm();
            t = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        t
    }
}

impl Arc {
    /// Nearest point of a planar spiral: the generic search ([`nearest_generic`]: samples
    /// and the ends, refined), and at each angle of `p`'s direction in the sweep (one per
    /// turn, where samples of a many-turn spiral are sparse) the crossing of the ray from
    /// the centre through `p`, refined by Newton's steps on `(C(t) - p) . C'(t) = 0`
    /// within the turn around it; the nearest of all.
    fn nearest_spiral(&self, p: Vec3, accuracy: f64) -> Nearest {
        let mut best = nearest_generic(self, p, accuracy);
        let q = p - self.center;
        let (x, y) = (q.dot(self.u), q.dot(self.v));
        let mut ang = y.atan2(x);
        if ang < 0.0 {
            ang += TAU;
        }
        let half_turn = PI / self.sweep;
        while ang <= self.sweep {
            let t0 = ang / self.sweep;
            let (lo, hi) = ((t0 - half_turn).max(0.0), (t0 + half_turn).min(1.0));
            let t = newton_nearest(self, p, t0, lo, hi);
            let d = self.eval(t).dist_sq(p);
            if d < best.distance_sq {
                best = Nearest { t, distance_sq: d };
            }
            ang += TAU;
        }
        best
    }
}

/// Newton's steps on `g(t) = (C(t) - p) . C'(t) = 0` from `t` kept in `[lo, hi]`.
fn newton_nearest(a: &Arc, p: Vec3, mut t: f64, lo: f64, hi: f64) -> f64 {
    for _ in 0..16 {
        let d = a.eval(t) - p;
        let d1 = a.deriv(t);
        let g = d.dot(d1);
        let h = d1.norm_sq() + d.dot(a.deriv2(t));
        if h <= 0.0 {
            break;
        }
        let next = (t - g / h).clamp(lo, hi);
        if (next - t).abs() <= 1e-15 {
            return next;
        }
        t = next;
    }
    t
}

impl ParamCurveNearest for Arc {
    /// Exact for planar circular arcs (angle of the projected point, else the nearer
    /// end); planar spirals refine the crossings of the ray through the point
    /// (`nearest_spiral`); helical arcs use [`nearest_generic`].
    fn nearest(&self, p: Vec3, accuracy: f64) -> Nearest {
        if self.is_helical() {
            return nearest_generic(self, p, accuracy);
        }
        if self.is_spiral() {
            return self.nearest_spiral(p, accuracy);
        }
        let q = p - self.center;
        let (x, y) = (q.dot(self.u), q.dot(self.v));
        let mut best = Nearest {
            t: 0.0,
            distance_sq: self.eval(0.0).dist_sq(p),
        };
        let e = Nearest {
            t: 1.0,
            distance_sq: self.eval(1.0).dist_sq(p),
        };
        if e.distance_sq < best.distance_sq {
            best = e;
        }
        if x != 0.0 || y != 0.0 {
            let mut ang = y.atan2(x);
            if ang < 0.0 {
                ang += TAU;
            }
            if ang <= self.sweep {
                let t = ang / self.sweep;
                let d = self.eval(t).dist_sq(p);
                if d < best.distance_sq {
                    best = Nearest { t, distance_sq: d };
                }
            }
        }
        best
    }
}

impl ParamCurveCurvature for Arc {}

impl ParamCurveBBox for Arc {
    /// Tight for planar circular arcs (end points plus the axis extremes inside the
    /// sweep); for a spiral the union of the boxes of the circular arcs at its start and
    /// end radii (a point at angle `theta` lies between those arcs' points there); for
    /// helical arcs the planar box swept along the helical displacement.
    fn bounding_box(&self) -> Aabb {
        if self.spiral != 0.0 {
            let circle = |radius: f64| Arc {
                radius,
                spiral: 0.0,
                ..*self
            };
            return circle(self.radius)
                .bounding_box()
                .union(circle(self.radius_at(1.0)).bounding_box());
        }
        let planar = Arc {
            axial: Vec3::ZERO,
            ..*self
        };
        let mut b = Aabb::point(planar.eval(0.0));
        b.include(planar.eval(1.0));
        for i in 0..3 {
            // d/dtheta of component i: -sin u_i + cos v_i = 0.
            let base = self.v[i].atan2(self.u[i]);
            for k in -2..=(self.sweep / PI).ceil() as i32 + 1 {
                let mut ang = base + PI * k as f64;
                if ang < 0.0 {
                    ang += TAU * ((-ang) / TAU).ceil();
                }
                if ang >= 0.0 && ang <= self.sweep {
                    b.include(planar.eval(ang / self.sweep));
                }
            }
        }
        if self.is_helical() {
            let shifted = Aabb {
                min: b.min + self.axial,
                max: b.max + self.axial,
            };
            b = b.union(shifted);
        }
        b
    }
}

impl Flatten for Arc {
    /// Uniform chords in `t`. The helical part is linear in `t`, so it is interpolated
    /// exactly and the deviation is the planar one: the sagitta `r (1 - cos(dphi / 2))`
    /// of a circle, the second-derivative bound of a spiral (`chord_count`), which the
    /// chord count keeps at most `accuracy`.
    fn flatten<F: FnMut(Vec3)>(&self, accuracy: f64, sink: &mut F) {
        let n = self.chord_count(accuracy);
        for i in 1..n {
            sink(self.eval(i as f64 / n as f64));
        }
        sink(self.eval(1.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Line;
    use approx::assert_abs_diff_eq;

    fn quarter() -> Arc {
        Arc::from_center(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            true,
            0,
        )
        .unwrap()
    }

    #[test]
    fn exact_points_and_length() {
        let a = quarter();
        assert_abs_diff_eq!(a.sweep, PI / 2.0, epsilon = 1e-15);
        assert_abs_diff_eq!(a.length(), 5.0 * PI, epsilon = 1e-12);
        let m = a.eval(0.5);
        assert_abs_diff_eq!(m.x, 10.0 / 2f64.sqrt(), epsilon = 1e-12);
        assert_abs_diff_eq!(m.y, 10.0 / 2f64.sqrt(), epsilon = 1e-12);
        assert_abs_diff_eq!(a.curvature(0.3), 0.1, epsilon = 1e-12);
        assert_abs_diff_eq!(a.eval(a.inv_arclen(2.5 * PI, 0.0)).y, m.y, epsilon = 1e-12);
        // Clockwise the long way round.
        let cw = Arc::from_center(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            false,
            0,
        )
        .unwrap();
        assert_abs_diff_eq!(cw.sweep, 1.5 * PI, epsilon = 1e-12);
        assert_abs_diff_eq!(cw.eval(1.0).y, 10.0, epsilon = 1e-12);
        assert_abs_diff_eq!(cw.eval(0.5).x, -10.0 / 2f64.sqrt(), epsilon = 1e-12);
    }

    #[test]
    fn full_circle_and_helix() {
        let p = Vec3::new(5.0, 0.0, 0.0);
        let h =
            Arc::from_center(p, Vec3::new(5.0, 0.0, 2.0), Vec3::ZERO, Vec3::Z, true, 0).unwrap();
        assert_abs_diff_eq!(h.sweep, TAU, epsilon = 1e-15);
        assert_abs_diff_eq!(h.length(), (10.0 * PI).hypot(2.0), epsilon = 1e-12);
        assert_abs_diff_eq!(h.eval(1.0).z, 2.0, epsilon = 1e-15);
        // Helix curvature r / (r^2 + c^2) with c = pitch / (2 pi).
        let c = 2.0 / TAU;
        assert_abs_diff_eq!(h.curvature(0.4), 5.0 / (25.0 + c * c), epsilon = 1e-12);
        let arclen_num = arclen_adaptive(&h, 0.0, 1.0, 1e-10);
        assert_abs_diff_eq!(arclen_num, h.length(), epsilon = 1e-9);
    }

    #[test]
    fn frame_matches_the_traits() {
        let a = Arc::from_center(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-2.0, 1.0, 4.5),
            Vec3::new(0.0, 0.0, 3.0),
            Vec3::new(0.0, 0.2, 1.0),
            true,
            1,
        )
        .unwrap();
        for i in 0..=10 {
            let t = i as f64 / 10.0;
            let (p, tan, k) = a.frame(t);
            assert!(p.dist(a.eval(t)) < 1e-12);
            assert!(tan.dist(a.deriv(t).normalized().unwrap()) < 1e-12);
            assert!(k.dist(a.curvature_vec(t)) < 1e-12);
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let a = Arc::from_center(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-2.0, 1.0, 4.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.2, -0.3, 1.0),
            false,
            1,
        )
        .unwrap();
        let h = 1e-5;
        for &t in &[0.1, 0.5, 0.9] {
            let fd = (a.eval(t + h) - a.eval(t - h)) / (2.0 * h);
            assert!((fd - a.deriv(t)).norm() < 1e-5 * a.deriv(t).norm());
            let fd2 = (a.deriv(t + h) - a.deriv(t - h)) / (2.0 * h);
            assert!((fd2 - a.deriv2(t)).norm() < 1e-5 * a.deriv2(t).norm());
        }
    }

    #[test]
    fn other_planes_and_bisector_correction() {
        // G18-style: axis +Y, start on +Z side.
        let a = Arc::from_center(
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::Y,
            true,
            0,
        )
        .unwrap();
        assert_abs_diff_eq!(a.sweep, PI / 2.0, epsilon = 1e-15);
        // Slightly inconsistent radii: the arc still ends exactly at the end point.
        let b = Arc::from_center(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.003, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            true,
            0,
        )
        .unwrap();
        assert!(b.eval(1.0).dist(Vec3::new(0.0, 10.003, 0.0)) < 1e-12);
    }

    #[test]
    fn nearest_and_bbox() {
        let a = quarter();
        let n = a.nearest(Vec3::new(20.0, 20.0, 0.0), 0.0);
        assert_abs_diff_eq!(n.t, 0.5, epsilon = 1e-12);
        assert_abs_diff_eq!(n.distance_sq.sqrt(), 800f64.sqrt() - 10.0, epsilon = 1e-12);
        let n = a.nearest(Vec3::new(-5.0, -5.0, 0.0), 0.0);
        assert!(n.t == 0.0 || n.t == 1.0);
        let b = a.bounding_box();
        assert_abs_diff_eq!(b.max.x, 10.0, epsilon = 1e-12);
        assert_abs_diff_eq!(b.max.y, 10.0, epsilon = 1e-12);
        assert_abs_diff_eq!(b.min.x, 0.0, epsilon = 1e-12);
        let half = Arc::from_center(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(-10.0, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            true,
            0,
        )
        .unwrap();
        assert_abs_diff_eq!(half.bounding_box().max.y, 10.0, epsilon = 1e-12);
        assert_abs_diff_eq!(half.bounding_box().min.y, 0.0, epsilon = 1e-12);
    }

    #[test]
    fn flatten_bound_and_tangent_constructor() {
        let a = quarter();
        let mut pts = vec![a.start()];
        a.flatten(1e-3, &mut |p| pts.push(p));
        assert_eq!(*pts.last().unwrap(), a.eval(1.0));
        for w in pts.windows(2) {
            let mid = (w[0] + w[1]) * 0.5;
            assert!(10.0 - mid.norm() <= 1e-3 + 1e-12);
        }
        let t = Arc::from_tangent(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::Y,
            Vec3::new(0.0, 10.0, 0.0),
        )
        .unwrap();
        assert!(t.center.norm() < 1e-12);
        assert!(t.start_tangent().dist(Vec3::Y) < 1e-12);
        let r = a.reversed();
        assert!(r.eval(0.0).dist(a.eval(1.0)) < 1e-12 && r.eval(1.0).dist(a.eval(0.0)) < 1e-12);
        assert!(r.eval(0.25).dist(a.eval(0.75)) < 1e-12);
    }

    #[test]
    fn tangent_constructor_is_planar_in_any_plane() {
        // A tilted plane at large coordinates: the end lies in the plane of the start and
        // the tangent, so the arc is never helical (round-off along the normal made it so,
        // and a helical arc's nearest point is numerical).
        let (s, t) = (
            Vec3::new(101.3, -57.9, 12.7),
            Vec3::new(0.3, 0.8, -0.52).normalized().unwrap(),
        );
        for k in 1..50 {
            let x = k as f64 * 0.37;
            let e = s + t * x + Vec3::new(0.2, -0.1, 0.15).cross(t) * (0.01 * x * x);
            let a = Arc::from_tangent(s, t, e).unwrap();
            assert!(!a.is_helical(), "{k}");
            assert!(
                a.end().dist(e) < 1e-9 && a.start_tangent().dist(t) < 1e-9,
                "{k}"
            );
        }
    }

    /// The near-full circle of a program whose end is 2 um inside the start's circle
    /// (`G3 X0.02 Y0.6 I10 J0` from the origin): LinuxCNC's spiral about the programmed
    /// centre, not a circle about a moved one.
    fn spiral() -> Arc {
        Arc::from_center_spiral(
            Vec3::ZERO,
            Vec3::new(0.02, 0.6, 0.0),
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::Z,
            true,
            0,
        )
        .unwrap()
    }

    #[test]
    fn a_centre_format_arc_off_its_circle_is_linuxcncs_spiral() {
        let a = spiral();
        let r_end = Vec3::new(0.02 - 10.0, 0.6, 0.0).norm();
        assert_eq!(a.center, Vec3::new(10.0, 0.0, 0.0));
        assert_abs_diff_eq!(a.radius, 10.0, epsilon = 1e-15);
        assert_abs_diff_eq!(a.spiral, r_end - 10.0, epsilon = 1e-15);
        assert!(a.is_spiral());
        assert!(a.eval(1.0).dist(Vec3::new(0.02, 0.6, 0.0)) < 1e-12);
        // Radius linear in the angle (pmCirclePoint): at half the sweep, the mean radius.
        assert_abs_diff_eq!(
            a.eval(0.5).dist(a.center),
            10.0 + 0.5 * a.spiral,
            epsilon = 1e-12
        );
        // The circle the bisector gave was up to 0.033 mm off it; the spiral's points
        // are all within |spiral| of the start's circle.
        for i in 0..=100 {
            let d = a.eval(i as f64 / 100.0).dist(a.center) - 10.0;
            assert!(d.abs() <= a.spiral.abs() + 1e-12);
        }
        // Round-off radii stay a circle that ends at its end point.
        let c = Arc::from_center_spiral(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0 * (1.0 + 1e-14), 0.0),
            Vec3::ZERO,
            Vec3::Z,
            true,
            0,
        )
        .unwrap();
        assert!(!c.is_spiral() && c.eval(1.0).dist(Vec3::new(0.0, 10.0, 0.0)) < 1e-12);
    }

    /// Spirals of every kind: the near-full one, a helical multi-turn spiral whose radius
    /// triples, and a shrinking one in another plane.
    fn spirals() -> Vec<Arc> {
        vec![
            spiral(),
            Arc::from_center_spiral(
                Vec3::new(0.01, 0.0, 0.0),
                Vec3::new(0.0, 0.03, 2.0),
                Vec3::ZERO,
                Vec3::Z,
                false,
                2,
            )
            .unwrap(),
            Arc::from_center_spiral(
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(4.9, 0.0, 0.0),
                Vec3::ZERO,
                Vec3::Y,
                true,
                0,
            )
            .unwrap(),
        ]
    }

    #[test]
    fn spiral_length_derivatives_and_inverse_are_exact() {
        for a in spirals() {
            let numeric = arclen_adaptive(&a, 0.0, 1.0, 1e-12);
            assert!(
                (a.length() - numeric).abs() <= 1e-9 * numeric,
                "{} {numeric}",
                a.length()
            );
            let part = arclen_adaptive(&a, 0.2, 0.7, 1e-12);
            assert!((a.length_between(0.2, 0.7) - part).abs() <= 1e-9 * part);
            assert!(a.max_speed() >= a.deriv(0.0).norm() && a.max_speed() >= a.deriv(1.0).norm());
            let h = 1e-6;
            for &t in &[0.1, 0.5, 0.9] {
                let fd = (a.eval(t + h) - a.eval(t - h)) / (2.0 * h);
                assert!((fd - a.deriv(t)).norm() <= 1e-6 * a.deriv(t).norm());
                let fd2 = (a.deriv(t + h) - a.deriv(t - h)) / (2.0 * h);
                assert!((fd2 - a.deriv2(t)).norm() <= 1e-5 * a.deriv2(t).norm());
                let (p, tan, k) = a.frame(t);
                assert!(p.dist(a.eval(t)) < 1e-12 && k.dist(a.curvature_vec(t)) < 1e-12);
                assert!(tan.dist(a.deriv(t).normalized().unwrap()) < 1e-12);
                let s = a.length() * t;
                assert!((a.length_between(0.0, a.inv_arclen(s, 1e-9)) - s).abs() <= 1e-9);
            }
            let (sub, rev) = (a.subsegment(0.3, 0.8), a.reversed());
            for i in 0..=10 {
                let t = i as f64 / 10.0;
                assert!(sub.eval(t).dist(a.eval(0.3 + 0.5 * t)) < 1e-12);
                assert!(rev.eval(t).dist(a.eval(1.0 - t)) < 1e-12);
            }
        }
    }

    #[test]
    fn spiral_nearest_box_and_flattening_hold_their_bounds() {
        for a in spirals() {
            let n = 20_000;
            let dense: Vec<Vec3> = (0..=n).map(|i| a.eval(i as f64 / n as f64)).collect();
            let b = a.bounding_box();
            assert!(dense.iter().all(|p| b.dist_sq(*p) <= 1e-24));
            let acc = 1e-3;
            let mut pts = vec![a.start()];
            a.flatten(acc, &mut |p| pts.push(p));
            assert_eq!(*pts.last().unwrap(), a.eval(1.0));
            let lines: Vec<Line> = pts.windows(2).map(|w| Line::new(w[0], w[1])).collect();
            for p in dense.iter().step_by(7) {
                let d = lines
                    .iter()
                    .map(|l| l.dist_sq(*p))
                    .fold(f64::INFINITY, f64::min);
                assert!(d.sqrt() <= acc * (1.0 + 1e-9), "{}", d.sqrt());
            }
            if !a.is_helical() {
                for q in [
                    Vec3::new(3.0, 1.0, 0.5),
                    Vec3::new(-20.0, 4.0, 1.0),
                    a.center,
                ] {
                    let near = a.nearest(q, 0.0).distance_sq.sqrt();
                    let brute = dense
                        .iter()
                        .map(|p| p.dist(q))
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        near <= brute + 1e-9 && near >= brute - 2e-3,
                        "{near} {brute}"
                    );
                }
            }
        }
    }
}

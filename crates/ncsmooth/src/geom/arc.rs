//! Circular arcs in any plane, optionally helical (a linear motion along the plane normal
//! accompanies the rotation, as G2/G3 with the third axis do). Every operation is exact
//! (closed form) except the nearest point on a *helical* arc, which is numerical.
//!
//! Representation: `C(t) = c + r (cos(phi t) u + sin(phi t) v) + t h` for `t in [0, 1]`,
//! with `u`, `v` orthonormal in the plane of the arc (`u` towards the start, `v` the
//! direction of motion at the start), `phi > 0` the swept angle (may exceed `2 pi` for
//! multi-turn arcs) and `h` the helical displacement, parallel to `n = u x v`.

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
}

/// Chord between an arc's in-plane ends, as a share of its radius, below which the ends
/// coincide and the arc is a full circle (rounding of the end point).
pub const FULL_CIRCLE_CHORD_SHARE: f64 = 1e-12;

impl Arc {
    /// Arc from `start` to `end` about the axis `axis` (unit normal of the arc plane)
    /// through `center`. `ccw` means a positive (right-handed) rotation about `axis`.
    /// `turns` adds full extra turns (G-code `P` word minus one). When `start` and `end`
    /// coincide in the plane the arc is a full circle.
    ///
    /// The component of `end - start` along `axis` becomes the helical displacement.
    /// When the start and end radii differ (G-code rounding), the centre is moved to the
    /// point of the perpendicular bisector of the in-plane chord nearest the given centre,
    /// so that the arc ends exactly at `end`; callers that must reject inconsistent
    /// arcs check the radii before. Returns `None` for a zero radius or non-finite input.
    pub fn from_center(
        start: Vec3,
        end: Vec3,
        center: Vec3,
        axis: Vec3,
        ccw: bool,
        turns: u32,
    ) -> Option<Arc> {
        let n = axis.normalized()?;
        let along = (end - start).dot(n);
        let end_in_plane = end - n * along;
        // Centre projected onto the plane of the start point.
        let mut c = center - n * (center - start).dot(n);
        let chord = end_in_plane - start;
        let chord_len = chord.norm();
        let r_start = start.dist(c);
        let r_end = end_in_plane.dist(c);
        // A full circle (ends coincident but for rounding, see below) keeps its centre: the
        // bisector of a rounding-sized chord points anywhere.
        let full_circle = chord_len <= r_start * FULL_CIRCLE_CHORD_SHARE;
        if !full_circle && r_start != r_end {
            // Move the centre onto the bisector: c' = c - ((c - mid) . d) d, d = chord dir.
            let d = chord / chord_len;
            let mid = (start + end_in_plane) * 0.5;
            c -= d * (c - mid).dot(d);
        }
        let radius = start.dist(c);
        if radius <= 0.0 || !radius.is_finite() || !along.is_finite() {
            return None;
        }
        let u = (start - c) / radius;
        let s = if ccw { 1.0 } else { -1.0 };
        let axis_dir = n * s; // rotation is positive about axis_dir
        let v = axis_dir.cross(u);
        let e = end_in_plane - c;
        let mut ang = e.dot(v).atan2(e.dot(u));
        if ang <= 0.0 {
            ang += TAU;
        }
        // Coincident in-plane ends: a full circle rather than a zero sweep.
        if full_circle {
            ang = TAU;
        }
        let sweep = ang + TAU * turns as f64;
        Some(Arc {
            center: c,
            radius,
            u,
            v,
            sweep,
            axial: n * along,
        })
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
            ..arc
        })
    }

    /// Unit normal of the plane, oriented so that the motion is a positive rotation.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        self.u.cross(self.v)
    }

    /// Exact length `sqrt((r phi)^2 + |h|^2)`.
    #[inline]
    pub fn length(&self) -> f64 {
        (self.radius * self.sweep).hypot(self.axial.norm())
    }

    /// True when the arc has a helical displacement.
    pub fn is_helical(&self) -> bool {
        self.axial.norm_sq() > 0.0
    }

    /// The part of the arc between parameters `t0 < t1` (exact).
    pub fn subsegment(&self, t0: f64, t1: f64) -> Arc {
        let a0 = self.sweep * t0;
        let (s, c) = a0.sin_cos();
        let u = self.u * c + self.v * s;
        let v = self.v * c - self.u * s;
        Arc {
            center: self.center + self.axial * t0,
            radius: self.radius,
            u,
            v,
            sweep: self.sweep * (t1 - t0),
            axial: self.axial * (t1 - t0),
        }
    }

    /// The same arc traversed backwards.
    pub fn reversed(&self) -> Arc {
        let e = self.subsegment(1.0, 1.0);
        Arc {
            center: e.center,
            radius: self.radius,
            u: e.u,
            v: -e.v,
            sweep: self.sweep,
            axial: -self.axial,
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

    /// Number of chords whose sagitta is at most `accuracy` for this sweep.
    fn chord_count(&self, accuracy: f64) -> usize {
        let ratio = (1.0 - accuracy / self.radius).max(-1.0);
        let max_step = 2.0 * ratio.acos();
        let n = (self.sweep / max_step).ceil();
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
        self.center + (self.u * c + self.v * s) * self.radius + self.axial * t
    }
}

impl ParamCurveDeriv for Arc {
    #[inline]
    fn deriv(&self, t: f64) -> Vec3 {
        let (s, c) = (self.sweep * t).sin_cos();
        (self.v * c - self.u * s) * (self.radius * self.sweep) + self.axial
    }
    #[inline]
    fn deriv2(&self, t: f64) -> Vec3 {
        let (s, c) = (self.sweep * t).sin_cos();
        (self.u * c + self.v * s) * (-self.radius * self.sweep * self.sweep)
    }
}

impl ParamCurveArclen for Arc {
    /// Exact; `accuracy` is ignored.
    fn arclen(&self, _accuracy: f64) -> f64 {
        self.length()
    }
    /// Exact (the speed is constant); `accuracy` is ignored.
    fn inv_arclen(&self, s: f64, _accuracy: f64) -> f64 {
        (s / self.length()).clamp(0.0, 1.0)
    }
}

impl ParamCurveNearest for Arc {
    /// Exact for planar arcs (angle of the projected point, else the nearer end); helical
    /// arcs use [`nearest_generic`].
    fn nearest(&self, p: Vec3, accuracy: f64) -> Nearest {
        if self.is_helical() {
            return nearest_generic(self, p, accuracy);
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
    /// Tight for planar arcs (end points plus the axis extremes inside the sweep); for
    /// helical arcs the planar box swept along the helical displacement.
    fn bounding_box(&self) -> Aabb {
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
    /// exactly and the deviation is the planar sagitta `r (1 - cos(dphi / 2))`, which the
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
}

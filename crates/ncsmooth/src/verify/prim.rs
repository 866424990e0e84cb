//! Exact primitives for distance queries: lines and planar arcs. Every [`Segment`] is
//! turned into primitives, exactly (lines, planar arcs) or through [`Flatten`] with a stated
//! chord bound (helical arcs and free-form curves).

use crate::geom::{Aabb, Arc, Flatten, Line, ParamCurve, ParamCurveBBox, Segment, Vec3};
use std::f64::consts::{PI, TAU};

/// A line or a planar arc, tagged with the index of the move it came from. An arc is boxed
/// so that a line, by far the commonest primitive (every flattened curve is lines), costs
/// 64 bytes, not the arc's 200: a verification holds tens of millions of them.
#[derive(Clone, Debug)]
pub(crate) struct Prim {
    pub geom: PrimGeom,
    /// Index of the source move (in the caller's move list).
    pub source: u32,
}

#[derive(Clone, Debug)]
pub(crate) enum PrimGeom {
    Line(Line),
    Arc(Box<PlanarArc>),
}

/// A planar arc with what its exact distance needs precomputed, so that a distance costs
/// no trigonometry (the queries of the deviation measurement are most of its time).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlanarArc {
    pub arc: Arc,
    /// Unit normal of the plane, `u x v`.
    normal: Vec3,
    /// Cosine and sine of the sweep: the end direction in the `(u, v)` frame.
    end_dir: (f64, f64),
    /// The arc's bounding box (the index's build asks for it at every level).
    bbox: Aabb,
}

impl PlanarArc {
    /// `a` must be planar.
    pub fn new(a: &Arc) -> PlanarArc {
        let (s, c) = a.sweep.sin_cos();
        PlanarArc {
            arc: *a,
            normal: a.normal(),
            end_dir: (c, s),
            bbox: a.bounding_box(),
        }
    }

    /// Exact squared distance from `p`: with `(x, y)` the in-plane coordinates of `p`
    /// about the centre in the `(u, v)` frame and `z` its height over the plane, the foot
    /// on the circle, `(x, y) r / |(x, y)|`, is on the arc when its angle is within the
    /// sweep (two cross products with the end directions decide it), and the distance is
    /// then `(|(x, y)| - r)^2 + z^2`; otherwise the nearer end point is nearest. A point on
    /// the axis is `r` from every point of the circle.
    #[inline]
    pub fn dist_sq(&self, p: Vec3) -> f64 {
        let a = &self.arc;
        let q = p - a.center;
        let (x, y, z) = (q.dot(a.u), q.dot(a.v), q.dot(self.normal));
        let (c, s) = self.end_dir;
        // Sign of the end direction's cross product with (x, y): >= 0 when (x, y) is not
        // past the end, turning from it the way the arc sweeps.
        let before_end = x * s - y * c >= 0.0;
        let inside = if a.sweep >= TAU {
            true
        } else if a.sweep <= PI {
            y >= 0.0 && before_end
        } else {
            y >= 0.0 || before_end
        };
        let r = a.radius;
        if inside {
            // No overflow to guard against at machine coordinates (plain sqrt, not hypot).
            let rho = (x * x + y * y).sqrt();
            let d = rho - r;
            return d * d + z * z;
        }
        let d0 = (x - r) * (x - r) + y * y;
        let d1 = (x - r * c) * (x - r * c) + (y - r * s) * (y - r * s);
        d0.min(d1) + z * z
    }
}

/// Angular slack (rad) of the sweep tests of [`PlanarArc::arc_piece_max`] and
/// [`PlanarArc::segment_max`]: a foot this far past an end is at the end's distance up to
/// `r (1e-12)^2`.
const SWEEP_SLACK_RAD: f64 = 1e-12;

/// Largest `|n_a x n_q|` for which two arcs' planes are treated as parallel; the tilt's
/// effect, at most `r_a` times it, is added to the bound.
const PARALLEL_TOL: f64 = 1e-9;

impl PlanarArc {
    /// In-plane coordinates of `p - center` and its height over the plane.
    #[inline]
    fn local(&self, p: Vec3) -> (f64, f64, f64) {
        let q = p - self.arc.center;
        (q.dot(self.arc.u), q.dot(self.arc.v), q.dot(self.normal))
    }

    /// True when the angles `[start, start + travel]` (rad, counter-clockwise about the
    /// normal from `u`, `start` any value) lie in the sweep.
    fn covers(&self, start: f64, travel: f64) -> bool {
        if self.arc.sweep >= TAU {
            return true;
        }
        let mut s = start.rem_euclid(TAU);
        if s > TAU - SWEEP_SLACK_RAD {
            s = 0.0;
        }
        s + travel <= self.arc.sweep + SWEEP_SLACK_RAD
    }

    /// Largest distance from the piece `[t0, t1]` of the planar arc `a` (at most a half
    /// turn) to this arc, and the parameter of `a` where it is attained, when the nearest
    /// points of the piece on this arc's circle all lie in its sweep (else `None`; also
    /// when the planes are not parallel or this arc's centre is not inside `a`'s circle).
    ///
    /// With `e` the offset of `a`'s centre from this one's (in-plane part of length `E`,
    /// height `z`) and `phi` the angle of the in-plane part in `a`'s frame, the point of
    /// `a` at angle `theta` is `rho = sqrt(r_a^2 + E^2 + 2 r_a E cos(theta - phi))` from
    /// this arc's axis. `rho` is monotone in `cos(theta - phi)`, so `|rho - r|` is largest
    /// at an end of the range of that cosine over the piece (an end of the piece, or
    /// `phi`, `phi + pi` inside it): the distance to the circle,
    /// `sqrt((rho - r)^2 + z^2)`, has its exact maximum there. With `E < r_a` the angle of
    /// the nearest point on the circle turns monotonically with `theta`, so the feet of the
    /// piece are the angles between those of its ends, and where they are inside the
    /// sweep the distance to the arc is the distance to the circle.
    pub fn arc_piece_max(&self, a: &PlanarArc, t0: f64, t1: f64) -> Option<(f64, f64)> {
        let (th0, th1) = (a.arc.sweep * t0, a.arc.sweep * t1);
        if th1 - th0 > PI {
            return None;
        }
        let tilt = a.normal.cross(self.normal).norm();
        if tilt > PARALLEL_TOL {
            return None;
        }
        let ra = a.arc.radius;
        let e = a.arc.center - self.arc.center;
        let z = e.dot(self.normal);
        let ep = e - self.normal * z;
        let big_e = ep.norm();
        if big_e >= ra {
            return None;
        }
        // Feet: the angles of the piece's ends in this frame, turning the way `a` does.
        let (x0, y0, _) = self.local(a.arc.eval(t0));
        let (x1, y1, _) = self.local(a.arc.eval(t1));
        let (psi0, psi1) = (y0.atan2(x0), y1.atan2(x1));
        let same = a.normal.dot(self.normal) > 0.0;
        let (start, travel) = if same {
            (psi0, (psi1 - psi0).rem_euclid(TAU))
        } else {
            (psi1, (psi0 - psi1).rem_euclid(TAU))
        };
        if !self.covers(start, travel) {
            return None;
        }
        // Range of cos(theta - phi) over the piece, and where its ends are.
        let phi = ep.dot(a.arc.v).atan2(ep.dot(a.arc.u));
        let (c0, c1) = ((th0 - phi).cos(), (th1 - phi).cos());
        let (mut cmax, mut tmax) = if c0 >= c1 { (c0, t0) } else { (c1, t1) };
        let (mut cmin, mut tmin) = if c0 <= c1 { (c0, t0) } else { (c1, t1) };
        // First angle >= th0 congruent to `at`.
        let inside = |at: f64| {
            let th = th0 + (at - th0).rem_euclid(TAU);
            (th <= th1).then_some(th / a.arc.sweep)
        };
        if let Some(t) = inside(phi) {
            (cmax, tmax) = (1.0, t);
        }
        if let Some(t) = inside(phi + PI) {
            (cmin, tmin) = (-1.0, t);
        }
        let rho = |c: f64| {
            (ra * ra + big_e * big_e + 2.0 * ra * big_e * c)
                .max(0.0)
                .sqrt()
        };
        let r = self.arc.radius;
        let (hi, lo) = ((rho(cmax) - r).abs(), (rho(cmin) - r).abs());
        let (m, t) = if hi >= lo { (hi, tmax) } else { (lo, tmin) };
        Some(((m * m + z * z).sqrt() + ra * tilt, t))
    }

    /// Largest distance from the straight piece `p0 p1` to this arc, and the share of the
    /// way from `p0` where its in-plane part is attained, when the nearest points on this
    /// arc's circle all lie in its sweep (else `None`; also when the piece's projection
    /// passes within a hair of the axis).
    ///
    /// The distance from the axis of the projection, `rho`, is convex along the piece, so
    /// `|rho - r|` is largest at the piece's ends or where `rho` is least (the foot of the
    /// axis on the projected piece); the height is linear, largest at an end. The bound
    /// `sqrt(max |rho - r|^2 + max z^2)` is exact when the piece is parallel to the plane.
    /// Away from the axis the angle of the projection turns monotonically, by less than a
    /// half turn, so the feet are the angles between those of the ends.
    pub fn segment_max(&self, p0: Vec3, p1: Vec3) -> Option<(f64, f64)> {
        let (x0, y0, z0) = self.local(p0);
        let (x1, y1, z1) = self.local(p1);
        let (dx, dy) = (x1 - x0, y1 - y0);
        let len_sq = dx * dx + dy * dy;
        let tau = if len_sq > 0.0 {
            (-(x0 * dx + y0 * dy) / len_sq).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (xm, ym) = (x0 + tau * dx, y0 + tau * dy);
        let r = self.arc.radius;
        let rho_min = (xm * xm + ym * ym).sqrt();
        if rho_min <= 1e-9 * r {
            return None;
        }
        let cross = x0 * y1 - y0 * x1;
        let travel = cross.atan2(x0 * x1 + y0 * y1).abs();
        let start = if cross >= 0.0 {
            y0.atan2(x0)
        } else {
            y1.atan2(x1)
        };
        if !self.covers(start, travel) {
            return None;
        }
        let (rho0, rho1) = ((x0 * x0 + y0 * y0).sqrt(), (x1 * x1 + y1 * y1).sqrt());
        let (rho_max, at_max) = if rho0 >= rho1 {
            (rho0, 0.0)
        } else {
            (rho1, 1.0)
        };
        let (hi, lo) = ((rho_max - r).abs(), (rho_min - r).abs());
        let (m, at) = if hi >= lo { (hi, at_max) } else { (lo, tau) };
        let zm = z0.abs().max(z1.abs());
        Some(((m * m + zm * zm).sqrt(), at))
    }
}

impl PlanarArc {
    /// Largest distance from the piece `[t0, t1]` of this arc to the segment `l`, bounded
    /// from above, and the parameter of the arc where the bound's in-plane part is
    /// attained, when `l` is parallel to the arc's plane (else `None`).
    ///
    /// With `h` the height of `l` over the plane, `m` the in-plane unit normal of `l`
    /// and `s` the position along it, a point of the arc at angle `theta` is
    /// `g + r cos(theta - phi_m)` from `l`'s line in the plane and at
    /// `s_c + r cos(theta - phi_d)` along it: the distance to the segment is
    /// `sqrt(h^2 + (g + r cos(theta - phi_m))^2 + e^2)`, `e` how far the point's foot is
    /// past an end. Each term is bounded by the range of its cosine over the piece; the
    /// bound is the exact maximum where the piece's feet stay on the segment (`e = 0`).
    pub fn piece_max_to_line(&self, l: &Line, t0: f64, t1: f64) -> Option<(f64, f64)> {
        let a = &self.arc;
        let len = l.p0.dist(l.p1);
        if len <= 0.0 {
            return None;
        }
        let d = (l.p1 - l.p0) * (1.0 / len);
        let tilt = d.dot(self.normal);
        if tilt.abs() > PARALLEL_TOL {
            return None;
        }
        let w = a.center - l.p0;
        let h = w.dot(self.normal);
        let m = self.normal.cross(d);
        let (th0, th1) = (a.sweep * t0, a.sweep * t1);
        // Range of cos(theta - phi) over the piece, with the parameters of its ends.
        let range = |phi: f64| {
            let (c0, c1) = ((th0 - phi).cos(), (th1 - phi).cos());
            let (mut hi, mut lo) = if c0 >= c1 {
                ((c0, t0), (c1, t1))
            } else {
                ((c1, t1), (c0, t0))
            };
            let inside = |at: f64| {
                let th = th0 + (at - th0).rem_euclid(TAU);
                (th <= th1).then_some(th / a.sweep)
            };
            if let Some(t) = inside(phi) {
                hi = (1.0, t);
            }
            if let Some(t) = inside(phi + PI) {
                lo = (-1.0, t);
            }
            (hi, lo)
        };
        let r = a.radius;
        let (g, phi_m) = (w.dot(m), m.dot(a.v).atan2(m.dot(a.u)));
        let ((mhi, thi), (mlo, tlo)) = range(phi_m);
        let (across_hi, across_lo) = ((g + r * mhi).abs(), (g + r * mlo).abs());
        let (across, at) = if across_hi >= across_lo {
            (across_hi, thi)
        } else {
            (across_lo, tlo)
        };
        let (s_c, phi_d) = (w.dot(d), d.dot(a.v).atan2(d.dot(a.u)));
        let ((dhi, _), (dlo, _)) = range(phi_d);
        let past = (-(s_c + r * dlo)).max(s_c + r * dhi - len).max(0.0);
        // A tilt within the tolerance moves the distance by at most its share of the
        // farthest point's offset from the line's start.
        let slack = 2.0 * tilt.abs() * (w.norm() + r + len);
        Some(((h * h + across * across + past * past).sqrt() + slack, at))
    }
}

impl Prim {
    #[inline]
    pub fn dist_sq(&self, p: Vec3) -> f64 {
        match &self.geom {
            PrimGeom::Line(l) => l.dist_sq(p),
            PrimGeom::Arc(a) => a.dist_sq(p),
        }
    }
    #[inline]
    pub fn eval(&self, t: f64) -> Vec3 {
        match &self.geom {
            PrimGeom::Line(l) => l.eval(t),
            PrimGeom::Arc(a) => a.arc.eval(t),
        }
    }
    pub fn length(&self) -> f64 {
        match &self.geom {
            PrimGeom::Line(l) => l.length(),
            PrimGeom::Arc(a) => a.arc.length(),
        }
    }
    pub fn bbox(&self) -> Aabb {
        match &self.geom {
            PrimGeom::Line(l) => l.bounding_box(),
            PrimGeom::Arc(a) => a.bbox,
        }
    }

    /// `bbox().center()[axis]`, from that axis alone (the index's build compares it).
    pub fn center_on(&self, axis: usize) -> f64 {
        match &self.geom {
            PrimGeom::Line(l) => {
                let (a, b) = (l.p0[axis], l.p1[axis]);
                (a.min(b) + a.max(b)) * 0.5
            }
            PrimGeom::Arc(a) => a.bbox.center()[axis],
        }
    }
}

/// Appends the primitives of `seg` to `out`. Lines and planar circular arcs are exact. A
/// planar spiral is cut into `k` equal pieces, each its circle of the mean radius (every
/// point of a piece and of its circle is within `|spiral| / 2k` of the other), with the
/// least `k` that keeps that within `flatten_mm`, unless flattening takes fewer
/// primitives. Helical arcs and curves are flattened with chord error at most
/// `flatten_mm`.
pub(crate) fn push_prims(seg: &Segment, source: u32, flatten_mm: f64, out: &mut Vec<Prim>) {
    match seg {
        Segment::Line(l) => out.push(Prim {
            geom: PrimGeom::Line(*l),
            source,
        }),
        Segment::Arc(a) if !a.is_helical() && spiral_pieces(a, flatten_mm).is_some() => {
            let k = spiral_pieces(a, flatten_mm).unwrap_or(1);
            for j in 0..k {
                let piece = if k == 1 {
                    *a
                } else {
                    a.subsegment(j as f64 / k as f64, (j + 1) as f64 / k as f64)
                };
                let circle = Arc {
                    radius: piece.radius_at(0.5),
                    spiral: 0.0,
                    ..piece
                };
                out.push(Prim {
                    geom: PrimGeom::Arc(Box::new(PlanarArc::new(&circle))),
                    source,
                });
            }
        }
        other => {
            let mut prev = other.start();
            other.flatten(flatten_mm, &mut |p| {
                out.push(Prim {
                    geom: PrimGeom::Line(Line::new(prev, p)),
                    source,
                });
                prev = p;
            });
        }
    }
}

/// Pieces a planar arc is measured in as circles ([`push_prims`]): one for a circle, the
/// least count keeping a spiral's pieces within `flatten_mm` of their circles; `None`
/// where flattening the spiral takes fewer primitives.
fn spiral_pieces(a: &Arc, flatten_mm: f64) -> Option<usize> {
    if a.spiral == 0.0 {
        return Some(1);
    }
    let k = (0.5 * a.spiral.abs() / flatten_mm).ceil();
    (k.is_finite() && k <= a.chord_count(flatten_mm) as f64).then_some((k as usize).max(1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ParamCurveNearest;
    use proptest::prelude::*;

    proptest! {
        /// The trigonometry-free distance is the exact nearest-point distance of the arc
        /// (angle by `atan2`), for sweeps below, at and above a half and a full turn, and
        /// points in and off the plane, near the axis and far away.
        #[test]
        fn planar_arc_distance_is_the_nearest_distance(
            r in 0.01f64..50.0,
            start in -7.0f64..7.0,
            sweep in prop_oneof![1e-6f64..PI, Just(PI), PI..TAU, Just(TAU)],
            ccw in any::<bool>(),
            tilt in 0.0f64..1.5,
            px in -100.0f64..100.0,
            py in -100.0f64..100.0,
            pz in -5.0f64..5.0,
            scale in prop_oneof![Just(1e-3f64), Just(1.0)],
        ) {
            let axis = Vec3::new(tilt.sin(), 0.0, tilt.cos());
            let center = Vec3::new(1.0, -2.0, 0.5);
            // A start point on the circle in the plane normal to `axis`.
            let e1 = Vec3::new(tilt.cos(), 0.0, -tilt.sin());
            let e2 = axis.cross(e1);
            let dir = |a: f64| e1 * a.cos() + e2 * a.sin();
            let sgn = if ccw { 1.0 } else { -1.0 };
            let s0 = center + dir(start) * r;
            let s1 = center + dir(start + sgn * sweep) * r;
            let turns = if sweep >= TAU { 1 } else { 0 };
            let Some(a) = Arc::from_center(s0, s1, center, axis, ccw, turns) else {
                return Ok(());
            };
            prop_assume!(!a.is_helical());
            let p = center + Vec3::new(px, py, pz) * (scale * r);
            let exact = a.nearest(p, 0.0).distance_sq;
            let fast = PlanarArc::new(&a).dist_sq(p);
            let scale_sq = (p - center).norm_sq() + r * r;
            prop_assert!((fast - exact).abs() <= 1e-12 * scale_sq, "{fast} vs {exact}");
        }
    }

    /// A planar arc in the plane `z = h` (normal `+z` or `-z`), centre `c`, radius `r`,
    /// from angle `a0` (about `+z` from `+x`) sweeping `sweep`.
    fn flat_arc(c: (f64, f64), h: f64, r: f64, a0: f64, sweep: f64, ccw: bool) -> Option<Arc> {
        let center = Vec3::new(c.0, c.1, h);
        let at = |a: f64| center + Vec3::new(a.cos(), a.sin(), 0.0) * r;
        let sgn = if ccw { 1.0 } else { -1.0 };
        let turns = u32::from(sweep >= TAU);
        Arc::from_center(at(a0), at(a0 + sgn * sweep), center, Vec3::Z, ccw, turns)
    }

    /// Exact distance from `p` to `q`.
    fn dist(q: &PlanarArc, p: Vec3) -> f64 {
        q.dist_sq(p).sqrt()
    }

    proptest! {
        /// The closed-form maximum over an arc piece is at least the distance of every
        /// point of the piece (500 samples), and it is the distance at the parameter
        /// returned; near-concentric pairs (the rounded arcs of a written program) and
        /// arbitrary ones.
        #[test]
        fn arc_piece_max_is_the_maximum(
            rq in 0.1f64..60.0,
            q0 in -4.0f64..4.0,
            qsweep in prop_oneof![0.05f64..PI, PI..TAU, Just(TAU)],
            qccw in any::<bool>(),
            near in any::<bool>(),
            off in (-1.0f64..1.0, -1.0f64..1.0),
            dr in -1.0f64..1.0,
            h in -0.01f64..0.01,
            a0 in -4.0f64..4.0,
            asweep in 0.01f64..TAU,
            accw in any::<bool>(),
            t0 in 0.0f64..1.0,
            dt in 0.0f64..1.0,
        ) {
            let Some(q) = flat_arc((0.3, -0.2), 0.0, rq, q0, qsweep, qccw) else { return Ok(()) };
            let scale = if near { 1e-3 } else { 0.5 * rq };
            let ra = (rq + dr * scale).max(0.01);
            let c = (0.3 + off.0 * scale, -0.2 + off.1 * scale);
            let Some(a) = flat_arc(c, h, ra, a0, asweep, accw) else { return Ok(()) };
            let (q, a) = (PlanarArc::new(&q), PlanarArc::new(&a));
            let t1 = (t0 + dt).min(1.0);
            let Some((b, t)) = q.arc_piece_max(&a, t0, t1) else { return Ok(()) };
            prop_assert!(t >= t0 - 1e-12 && t <= t1 + 1e-12);
            let tol = 1e-9 * (rq + ra);
            prop_assert!((dist(&q, a.arc.eval(t)) - b).abs() <= tol, "{} vs {b}", dist(&q, a.arc.eval(t)));
            for i in 0..=500 {
                let s = t0 + (t1 - t0) * i as f64 / 500.0;
                let d = dist(&q, a.arc.eval(s));
                prop_assert!(d <= b + tol, "at {s}: {d} > {b}");
            }
        }

        /// An arc piece against a line in its plane: the bound holds at every sample and
        /// is the maximum, attained at the returned parameter, where the feet stay on the
        /// segment.
        #[test]
        fn piece_max_to_line_bounds_and_is_attained(
            r in 0.1f64..60.0,
            a0 in -4.0f64..4.0,
            sweep in prop_oneof![0.05f64..PI, PI..TAU, Just(TAU)],
            ccw in any::<bool>(),
            t in (0.0f64..1.0, 0.0f64..1.0),
            a in (-1.5f64..1.5, -1.5f64..1.5),
            b in (-1.5f64..1.5, -1.5f64..1.5),
            h in -0.05f64..0.05,
        ) {
            let Some(arc) = flat_arc((0.0, 0.0), 0.0, r, a0, sweep, ccw) else { return Ok(()) };
            let arc = PlanarArc::new(&arc);
            let l = Line::new(Vec3::new(a.0 * r, a.1 * r, h), Vec3::new(b.0 * r, b.1 * r, h));
            let (t0, t1) = (t.0.min(t.1), t.0.max(t.1));
            let Some((bound, at)) = arc.piece_max_to_line(&l, t0, t1) else { return Ok(()) };
            prop_assert!(at >= t0 - 1e-12 && at <= t1 + 1e-12);
            let tol = 1e-9 * r;
            let mut inside = true;
            for i in 0..=500 {
                let p = arc.arc.eval(t0 + (t1 - t0) * (i as f64 / 500.0));
                let d = l.dist_sq(p).sqrt();
                prop_assert!(d <= bound + tol, "{d} > {bound}");
                let s = l.project(p);
                inside &= s > 0.0 && s < 1.0;
            }
            // Where every foot is on the segment the bound is the maximum, attained at `at`.
            if inside {
                let d = l.dist_sq(arc.arc.eval(at)).sqrt();
                prop_assert!((d - bound).abs() <= tol, "{d} vs {bound}");
            }
        }

        /// `segment_max`, a straight piece against an arc: the bound holds at every
        /// sample, exact when the piece is parallel to the plane.
        #[test]
        fn segment_max_bounds_and_is_attained(
            rq in 0.1f64..60.0,
            q0 in -4.0f64..4.0,
            qsweep in prop_oneof![0.05f64..PI, PI..TAU, Just(TAU)],
            qccw in any::<bool>(),
            a in (-1.5f64..1.5, -1.5f64..1.5),
            b in (-1.5f64..1.5, -1.5f64..1.5),
            z in (-0.01f64..0.01, -0.01f64..0.01),
            flat in any::<bool>(),
        ) {
            let Some(q) = flat_arc((0.0, 0.0), 0.0, rq, q0, qsweep, qccw) else { return Ok(()) };
            let q = PlanarArc::new(&q);
            let z1 = if flat { z.0 } else { z.1 };
            let p0 = Vec3::new(a.0 * rq, a.1 * rq, z.0);
            let p1 = Vec3::new(b.0 * rq, b.1 * rq, z1);
            let Some((bound, at)) = q.segment_max(p0, p1) else { return Ok(()) };
            let tol = 1e-9 * rq;
            for i in 0..=500 {
                let p = p0 + (p1 - p0) * (i as f64 / 500.0);
                prop_assert!(dist(&q, p) <= bound + tol, "{} > {bound}", dist(&q, p));
            }
            if flat {
                let d = dist(&q, p0 + (p1 - p0) * at);
                prop_assert!((d - bound).abs() <= tol, "{d} vs {bound}");
            }
        }
    }

    #[test]
    fn arc_piece_max_of_an_offset_circle() {
        // Radius 10 about the origin against radius 10 about (0.001, 0): the distance to
        // the circle is largest, 0.001, where the offset points along the radius (angle 0
        // here); a piece around pi/2 has its maximum at an end.
        let q = PlanarArc::new(&flat_arc((0.0, 0.0), 0.0, 10.0, -0.5, PI + 1.0, true).unwrap());
        let a = PlanarArc::new(&flat_arc((0.001, 0.0), 0.0, 10.0, -0.25, 2.75, true).unwrap());
        let (b, t) = q.arc_piece_max(&a, 0.0, 1.0).unwrap();
        assert!((b - 0.001).abs() < 1e-12, "{b}");
        assert!((t * 2.75 - 0.25).abs() < 1e-9, "{t}");
        let quarter = (PI / 2.0 + 0.25) / 2.75;
        let (b, t) = q.arc_piece_max(&a, quarter - 0.01, quarter + 0.01).unwrap();
        assert!(b < 1e-4 && b > 0.0, "{b}");
        assert!(t == quarter - 0.01 || t == quarter + 0.01, "{t}");
        // More than half a turn, or past the programmed sweep: no closed form.
        assert!(q.arc_piece_max(&a, 0.0, 1.0).is_some());
        let long = PlanarArc::new(&flat_arc((0.001, 0.0), 0.0, 10.0, -0.25, 3.3, true).unwrap());
        assert!(q.arc_piece_max(&long, 0.0, 1.0).is_none());
        let past = PlanarArc::new(&flat_arc((0.0, 0.0), 0.0, 10.0, 3.0, 2.0, true).unwrap());
        assert!(q.arc_piece_max(&past, 0.0, 1.0).is_none());
        assert!(q.arc_piece_max(&past, 0.0, 0.1).is_some());
    }

    #[test]
    fn planar_arc_distance_on_the_axis_and_at_the_ends() {
        let a = Arc::from_center(
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            true,
            0,
        )
        .expect("quarter circle");
        let pa = PlanarArc::new(&a);
        // On the axis, 2 above the plane: sqrt(1 + 4) from every point.
        assert!((pa.dist_sq(Vec3::new(0.0, 0.0, 2.0)) - 5.0).abs() < 1e-15);
        // Outside the sweep, nearest to the start point (1, 0).
        assert!((pa.dist_sq(Vec3::new(2.0, -1.0, 0.0)) - 2.0).abs() < 1e-15);
        // Inside the sweep at 45 degrees, 1 outside the circle.
        let p = Vec3::new(2.0, 2.0, 0.0) / 2f64.sqrt();
        assert!((pa.dist_sq(p) - 1.0).abs() < 1e-15);
    }
}

//! Evening out a chain of written blocks for a controller that blends its junctions by
//! the length of the blocks (LinuxCNC): the written points moved along the dense polyline,
//! within the tolerance, so that the tightest junction each one touches loosens
//! ([`even_out`]).

use crate::polyline::fits;
use ncsmooth::geom::Vec3;

/// Passes of [`even_out`] over a chain's written points.
pub(crate) const EVEN_OUT_SWEEPS: usize = 3;

/// Places [`even_out`] tries for a written point: this many steps of equal arc length
/// along the dense polyline between its neighbours.
pub(crate) const EVEN_OUT_STEPS: usize = 16;

/// A written point's place on the dense polyline: on the chord from `dense[i]` to
/// `dense[i + 1]` at the fraction `f` in `[0, 1)` of it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct At {
    i: usize,
    f: f64,
}

impl At {
    fn point(self, dense: &[Vec3]) -> Vec3 {
        if self.f > 0.0 {
            dense[self.i].lerp(dense[self.i + 1], self.f)
        } else {
            dense[self.i]
        }
    }

    /// The dense index that ends a block ending here, for the fit test: the dense points
    /// strictly before it and after the block's start are the ones the block covers.
    fn end(self) -> usize {
        if self.f > 0.0 {
            self.i + 1
        } else {
            self.i
        }
    }

    /// How far inside the curve this place may lie when the dense polyline is within
    /// `dense_acc` of it: a chord's sagitta profile, `4 f (1 - f)` of at most `dense_acc`.
    fn sag_mm(self, dense_acc: f64) -> f64 {
        4.0 * self.f * (1.0 - self.f) * dense_acc
    }
}

/// What [`even_out`] optimises for, and how far from the curve it may move a point.
pub struct EvenOut<S, R> {
    /// `score(a, b, c)` rates the junction at `b` between blocks `a`-`b` and `b`-`c`
    /// (e.g. the radius the controller's blend gets there; NaN where there is none).
    pub score: S,
    /// `room(a, b, c)` (mm): how far inside the curve the junction at `b` may lie (e.g.
    /// what the controller's blend there leaves of its bound; infinite where anything
    /// goes).
    pub room: R,
    /// Accuracy of the dense flattening (mm): a place between dense points lies up to
    /// this far inside the curve (0 where the dense points are the program's own lines).
    pub dense_acc_mm: f64,
}

/// Moves the written points `write::chain::simplify` chose along the dense polyline so that the
/// smallest of `how.score` over the junctions each one touches grows, keeping every
/// block within `tol_mm` (the fit test of `simplify`, rounding included): for a
/// controller that blends its junctions by the length of the blocks (LinuxCNC takes at
/// most half of each line for a blend arc), the greedy cut's long block beside a short
/// one leaves a tight blend where an even cut gives the curve's own radius.
///
/// `idx` is what `simplify` returned for `pts`, the written points after `start`.
/// Hard points and the ends stay, no block is made shorter than `min_block_mm` unless it
/// already was, and a point moved between dense points lies inside the curve by no more
/// than `how.room` allows there. Each point is tried at `EVEN_OUT_STEPS` places of
/// equal arc length between its neighbours, in `EVEN_OUT_SWEEPS` passes.
#[allow(clippy::too_many_arguments)]
pub fn even_out<S, R>(
    dense: &[Vec3],
    hard: &[bool],
    idx: &[usize],
    tol_mm: f64,
    min_block_mm: f64,
    round: impl Fn(Vec3) -> Vec3,
    how: &EvenOut<S, R>,
    start: Vec3,
    pts: &mut [Vec3],
) where
    S: Fn(Vec3, Vec3, Vec3) -> f64,
    R: Fn(Vec3, Vec3, Vec3) -> f64,
{
    let m = pts.len() + 1;
    if idx.len() != m || m < 3 {
        return;
    }
    let mut at: Vec<At> = idx.iter().map(|&i| At { i, f: 0.0 }).collect();
    let written = |pts: &[Vec3], k: usize| if k == 0 { start } else { pts[k - 1] };
    // The worst junction written point `k` touches when it is at `q`.
    let rate = |pts: &[Vec3], k: usize, q: Vec3| -> f64 {
        let w = |j: usize| if j == k { q } else { written(pts, j) };
        (k.saturating_sub(1).max(1)..=(k + 1).min(m - 2))
            .map(|j| (how.score)(w(j - 1), w(j), w(j + 1)))
            .filter(|r| !r.is_nan())
            .fold(f64::INFINITY, f64::min)
    };
    for _ in 0..EVEN_OUT_SWEEPS {
        for k in 1..m - 1 {
            if at[k].f == 0.0 && hard[at[k].i] {
                continue;
            }
            let (a, b) = (at[k - 1], at[k + 1]);
            let (pa, pb, pk) = (written(pts, k - 1), written(pts, k + 1), pts[k - 1]);
            let shortest = min_block_mm.min(pk.dist(pa)).min(pk.dist(pb));
            let mut best = (rate(pts, k, pk), at[k], pk);
            for c in places(dense, a, b) {
                let q = round(c.point(dense));
                if q.dist(pa).min(q.dist(pb)) < shortest || q == pa || q == pb {
                    continue;
                }
                let r = rate(pts, k, q);
                if r > best.0
                    && c.sag_mm(how.dense_acc_mm) <= (how.room)(pa, q, pb)
                    && fits(dense, a.i, c.end(), pa, q, tol_mm)
                    && fits(dense, c.i, b.end(), q, pb, tol_mm)
                {
                    best = (r, c, q);
                }
            }
            at[k] = best.1;
            pts[k - 1] = best.2;
        }
    }
}

/// [`EVEN_OUT_STEPS`]` - 1` places of equal arc length strictly between `a` and `b` on
/// the dense polyline.
fn places(dense: &[Vec3], a: At, b: At) -> Vec<At> {
    // The polyline from `a` to `b`: its vertices as places, and arc length at each.
    let mut verts = vec![(a, 0.0)];
    let mut prev = a.point(dense);
    for j in a.i + 1..=b.end() {
        let v = if j > b.i { b } else { At { i: j, f: 0.0 } };
        let p = v.point(dense);
        let s = verts[verts.len() - 1].1 + p.dist(prev);
        verts.push((v, s));
        prev = p;
    }
    let total = verts[verts.len() - 1].1;
    let mut out = Vec::with_capacity(EVEN_OUT_STEPS);
    let mut seg = 1;
    for step in 1..EVEN_OUT_STEPS {
        let target = total * step as f64 / EVEN_OUT_STEPS as f64;
        while seg + 1 < verts.len() && verts[seg].1 < target {
            seg += 1;
        }
        let ((v0, s0), (v1, s1)) = (verts[seg - 1], verts[seg]);
        let t = if s1 > s0 {
            (target - s0) / (s1 - s0)
        } else {
            0.0
        };
        // On the chord from v0 (a dense point, or `a`) to v1: chord `v0.i`.
        let (f0, f1) = (v0.f, if v1.i > v0.i { 1.0 } else { v1.f });
        let f = f0 + t.clamp(0.0, 1.0) * (f1 - f0);
        let c = if f >= 1.0 {
            At {
                i: v0.i + 1,
                f: 0.0,
            }
        } else {
            At { i: v0.i, f }
        };
        if c != a && c != b && out.last() != Some(&c) {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::write::chain::tests::{arc_points, dist_to_polyline, one_sided};
    use crate::write::chain::{sharp_points, simplify};
    use proptest::prelude::*;

    fn shortest_neighbour(written: &[Vec3]) -> f64 {
        written
            .windows(3)
            .map(|w| w[0].dist(w[1]).min(w[1].dist(w[2])))
            .fold(f64::INFINITY, f64::min)
    }

    /// `dense` cut by [`simplify`](crate::write::chain::simplify) within 1e-3 mm (the start first), then by [`even_out`]
    /// with the junction rated by its shorter block (what LinuxCNC's blend takes half of),
    /// `room` inside the curve and a dense accuracy of 1e-5 mm.
    fn greedy_and_even(dense: &[Vec3], room: f64) -> (Vec<Vec3>, Vec<Vec3>) {
        let hard = sharp_points(dense, 1e-3);
        let mut out = Vec::new();
        let idx = simplify(dense, &hard, 1e-3, 0.0, |p| p, &mut out);
        assert_eq!(idx.len(), out.len() + 1);
        assert!(idx.iter().skip(1).zip(&out).all(|(&i, &p)| dense[i] == p));
        let with_start = |out: &[Vec3]| {
            std::iter::once(dense[0])
                .chain(out.iter().copied())
                .collect()
        };
        let greedy = with_start(&out);
        let how = EvenOut {
            score: |a: Vec3, b: Vec3, c: Vec3| a.dist(b).min(b.dist(c)),
            room: move |_: Vec3, _: Vec3, _: Vec3| room,
            dense_acc_mm: 1e-5,
        };
        even_out(
            dense,
            &hard,
            &idx,
            1e-3,
            0.0,
            |p| p,
            &how,
            dense[0],
            &mut out,
        );
        (greedy, with_start(&out))
    }

    #[test]
    fn even_out_lengthens_the_short_blocks_of_a_greedy_cut() {
        // Radius 10 mm in dense chords of 0.028 mm, over 1.05 rad: the greedy cut within
        // 1e-3 mm gives blocks of up to 0.28 mm and a shorter one where the arc runs out.
        // Evening out makes the shortest longer, keeps the ends, and stays within the
        // tolerance both ways.
        let dense = arc_points(10.0, 1.05, 378);
        let (before, after) = greedy_and_even(&dense, f64::INFINITY);
        let (short_before, short_after) = (shortest_neighbour(&before), shortest_neighbour(&after));
        assert_eq!(after.len(), before.len());
        assert_eq!(after.last(), before.last());
        let mean =
            after.windows(2).map(|w| w[0].dist(w[1])).sum::<f64>() / (after.len() - 1) as f64;
        // Greedy: blocks of 10 dense chords (0.278 mm) and one of 8 (0.222 mm); the
        // shortest moves at least 40 % of the way to the mean.
        assert!(
            short_after > short_before + 0.4 * (mean - short_before),
            "{short_before} -> {short_after} (mean {mean})"
        );
        assert!(one_sided(&dense, &after) <= 1e-3 + 1e-12);
        assert!(one_sided(&after, &dense) <= 1e-3 + 1e-12);
    }

    #[test]
    fn even_out_keeps_hard_points() {
        // Two legs of a square corner, each a fine arc: the corner stays where it is.
        let mut dense = arc_points(10.0, 0.3, 100);
        let corner = *dense.last().unwrap();
        dense.extend(
            arc_points(10.0, 0.3, 100)
                .iter()
                .skip(1)
                .map(|p| corner + Vec3::new(-(p.y), p.x - 10.0, 0.0)),
        );
        assert!(sharp_points(&dense, 1e-3)[100]);
        let (_, written) = greedy_and_even(&dense, f64::INFINITY);
        assert!(written.contains(&corner), "{written:?}");
        assert!(one_sided(&dense, &written) <= 1e-3 + 1e-12);
        assert!(one_sided(&written, &dense) <= 1e-3 + 1e-12);
    }

    #[test]
    fn even_out_moves_off_the_dense_points_only_within_the_room() {
        // As above, but no room inside the curve: every point stays a dense point. With
        // room for the whole dense accuracy, some move between them.
        let dense = arc_points(10.0, 1.05, 378);
        let on_dense = |room: f64| {
            greedy_and_even(&dense, room)
                .1
                .iter()
                .all(|p| dense.contains(p))
        };
        assert!(on_dense(0.0));
        assert!(!on_dense(1e-5));
    }

    proptest! {
        /// Whatever the curve and rounding, evening out keeps every block within the
        /// tolerance both ways (rounding aside, as for the greedy cut) and the ends.
        #[test]
        fn even_out_stays_within_the_tolerance(
            r in 0.5f64..50.0,
            sweep in 0.05f64..3.0,
            n in 20usize..300,
            wobble in 0.0f64..2e-4,
            unit in prop_oneof![Just(0.0), Just(1e-4), Just(2.54e-4)],
        ) {
            let tol = 1e-3;
            let dense: Vec<Vec3> = arc_points(r, sweep, n)
                .into_iter()
                .enumerate()
                .map(|(k, p)| p * (1.0 + wobble * ((k * 7919) % 13) as f64 / 13.0))
                .collect();
            let round = |p: Vec3| if unit > 0.0 {
                Vec3::new((p.x / unit).round() * unit, (p.y / unit).round() * unit, p.z)
            } else {
                p
            };
            let hard = sharp_points(&dense, tol);
            let mut out = Vec::new();
            let idx = simplify(&dense, &hard, tol, 0.0, round, &mut out);
            let radius = |a: Vec3, b: Vec3, c: Vec3| {
                let (u, w) = (b - a, c - b);
                0.5 * u.norm().min(w.norm()) / (0.5 * u.angle_to(w)).tan()
            };
            let how = EvenOut { score: radius, room: |_, _, _| f64::INFINITY, dense_acc_mm: 0.0 };
            even_out(&dense, &hard, &idx, tol, 0.0, round, &how, round(dense[0]), &mut out);
            prop_assert_eq!(*out.last().unwrap(), round(*dense.last().unwrap()));
            let written: Vec<Vec3> = std::iter::once(round(dense[0])).chain(out.iter().copied()).collect();
            // Every dense point within tol of the written line (rounding included by
            // the fit test), every written point within tol plus a rounding unit of the
            // dense polyline.
            for p in &dense {
                prop_assert!(dist_to_polyline(*p, &written) <= tol + 1e-12);
            }
            prop_assert!(one_sided(&written, &dense) <= tol + unit + 1e-12);
        }
    }
}

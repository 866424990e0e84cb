//! Property tests of the verification core against brute force: the two-sided deviation of
//! random polylines and arcs agrees with dense sampling within the stated accuracy.

use ncsmooth::geom::{Arc, Line, ParamCurve, Segment, Vec3};
use ncsmooth::verify::deviation_segments;
use proptest::prelude::*;

fn dist_to(p: Vec3, segs: &[Segment]) -> f64 {
    segs.iter()
        .map(|s| match s {
            Segment::Line(l) => l.dist_sq(p).sqrt(),
            Segment::Arc(a) => {
                use ncsmooth::geom::ParamCurveNearest;
                a.nearest(p, 0.0).distance_sq.sqrt()
            }
            _ => unreachable!(),
        })
        .fold(f64::INFINITY, f64::min)
}

/// Largest sampled distance from `a` to `b`, and the sampling step (arc length).
fn brute(a: &[Segment], b: &[Segment], samples: usize) -> (f64, f64) {
    let mut m: f64 = 0.0;
    let mut step: f64 = 0.0;
    for s in a {
        use ncsmooth::geom::ParamCurveArclen;
        step = step.max(s.arclen(1e-12) / samples as f64);
        for i in 0..=samples {
            m = m.max(dist_to(s.eval(i as f64 / samples as f64), b));
        }
    }
    (m, step)
}

fn pt() -> impl Strategy<Value = Vec3> {
    (-10.0..10.0f64, -10.0..10.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn path() -> impl Strategy<Value = Vec<Segment>> {
    (
        pt(),
        prop::collection::vec((pt(), any::<bool>(), any::<bool>()), 1..6),
    )
        .prop_map(|(start, rest)| {
            let mut segs = Vec::new();
            let mut p = start;
            for (q, arc, ccw) in rest {
                let planar_q = Vec3::new(q.x, q.y, p.z);
                let mid = (p + planar_q) * 0.5 + Vec3::new(0.3, -0.7, 0.0);
                let s = if arc {
                    Arc::from_center(p, planar_q, mid, Vec3::Z, ccw, 0).map(Segment::Arc)
                } else {
                    None
                };
                let s = s.unwrap_or(Segment::Line(Line::new(p, q)));
                p = s.end();
                segs.push(s);
            }
            segs
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
    #[test]
    fn deviation_matches_brute_force(a in path(), b in path()) {
        let acc = 1e-4;
        let ta: Vec<(&Segment, u32)> = a.iter().map(|s| (s, 1)).collect();
        let tb: Vec<(&Segment, u32)> = b.iter().map(|s| (s, 1)).collect();
        let d = deviation_segments(&ta, &tb, acc);
        let (bm, step) = brute(&a, &b, 4000);
        // Sampling underestimates the true maximum by at most step / 2 (1-Lipschitz).
        prop_assert!(bm <= d.output_to_programmed_mm + acc, "brute {} > dev {}", bm, d.output_to_programmed_mm);
        prop_assert!(d.output_to_programmed_mm <= bm + 0.5 * step + acc, "dev {} > brute {} + {}", d.output_to_programmed_mm, bm, step);
        // Vertices of b to a: exact per vertex.
        let mut vm: f64 = dist_to(b[0].start(), &a);
        for s in &b {
            vm = vm.max(dist_to(s.end(), &a));
        }
        prop_assert!((vm - d.vertex_to_output_mm).abs() <= acc, "vertex {} vs {}", vm, d.vertex_to_output_mm);
    }
}

//! Built-in benchmark profiles.
//!
//! The butterfly is the planar NURBS curve widely used in the CNC interpolation literature
//! (degree 3, 51 control points with weights, 55 knots, about 383 mm long, closed). Its
//! published control points, weights and knots are compiled in so that the demo runs on a
//! fresh machine without any data files.

use crate::geom::{Nurbs, ParamCurve, Vec3};

/// Degree of the butterfly NURBS.
pub const BUTTERFLY_DEGREE: usize = 3;

/// Butterfly control points (mm, planar: z = 0).
pub const BUTTERFLY_CONTROL_POINTS_MM: [[f64; 2]; 51] = [
    [54.493, 52.139],
    [55.507, 52.139],
    [56.082, 49.615],
    [56.78, 44.971],
    [69.575, 51.358],
    [77.786, 58.573],
    [90.526, 67.081],
    [105.973, 63.801],
    [100.4, 47.326],
    [94.567, 39.913],
    [92.369, 30.485],
    [83.44, 33.757],
    [91.892, 28.509],
    [89.444, 20.393],
    [83.218, 15.446],
    [87.621, 4.83],
    [80.945, 9.267],
    [79.834, 14.535],
    [76.074, 8.522],
    [70.183, 12.55],
    [64.171, 16.865],
    [59.993, 22.122],
    [55.68, 36.359],
    [56.925, 24.995],
    [59.765, 19.828],
    [54.493, 14.94],
    [49.22, 19.828],
    [52.06, 24.994],
    [53.305, 36.359],
    [48.992, 22.122],
    [44.814, 16.865],
    [38.802, 12.551],
    [32.911, 8.521],
    [29.152, 14.535],
    [28.04, 9.267],
    [21.364, 4.83],
    [25.768, 15.447],
    [19.539, 20.391],
    [17.097, 28.512],
    [25.537, 33.75],
    [16.602, 30.496],
    [14.199, 39.803],
    [8.668, 47.408],
    [3.0, 63.794],
    [18.465, 67.084],
    [31.197, 58.572],
    [39.411, 51.358],
    [52.204, 44.971],
    [52.904, 49.614],
    [53.478, 52.139],
    [54.492, 52.139],
];

/// Butterfly weights.
pub const BUTTERFLY_WEIGHTS: [f64; 51] = [
    1.0, 1.0, 1.0, 1.2, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 1.0, 1.0, 5.0, 3.0, 1.0, 1.1, 1.0,
    1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.1, 1.0, 3.0, 5.0, 1.0,
    1.0, 2.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.2, 1.0, 1.0, 1.0,
];

/// Butterfly knot vector (clamped).
pub const BUTTERFLY_KNOTS: [f64; 55] = [
    0.0, 0.0, 0.0, 0.0, 0.0083, 0.015, 0.0361, 0.0855, 0.1293, 0.1509, 0.1931, 0.2273, 0.2435,
    0.2561, 0.2692, 0.2889, 0.317, 0.3316, 0.3482, 0.3553, 0.3649, 0.3837, 0.4005, 0.4269, 0.451,
    0.466, 0.4891, 0.5, 0.5109, 0.534, 0.5489, 0.5731, 0.5994, 0.6163, 0.6351, 0.6447, 0.6518,
    0.6683, 0.683, 0.7111, 0.7307, 0.7439, 0.7565, 0.7729, 0.8069, 0.8491, 0.8707, 0.9145, 0.9639,
    0.985, 0.9917, 1.0, 1.0, 1.0, 1.0,
];

/// The butterfly NURBS curve.
pub fn butterfly() -> Nurbs {
    let ctrl = BUTTERFLY_CONTROL_POINTS_MM
        .iter()
        .map(|p| Vec3::new(p[0], p[1], 0.0))
        .collect();
    Nurbs::new(
        BUTTERFLY_DEGREE,
        ctrl,
        BUTTERFLY_WEIGHTS.to_vec(),
        BUTTERFLY_KNOTS.to_vec(),
    )
    .expect("the compiled-in butterfly data form a valid NURBS")
}

/// The butterfly sampled into `segments` lines with vertices equally spaced in arc length
/// (lengths within `accuracy` mm), as the published 80- and 1000-segment polylines are.
pub fn butterfly_polyline(segments: usize, accuracy: f64) -> Vec<Vec3> {
    use crate::geom::ParamCurveArclen;
    let c = butterfly();
    let total = c.arclen(accuracy);
    let n = segments.max(1);
    (0..=n)
        .map(|i| {
            if i == n {
                c.end()
            } else {
                c.eval(c.inv_arclen(total * i as f64 / n as f64, accuracy))
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ParamCurveArclen;

    #[test]
    fn butterfly_is_closed_and_about_383_mm() {
        let c = butterfly();
        assert!(c.start().dist(c.end()) < 0.01);
        let l = c.arclen(1e-6);
        assert!((l - 383.0).abs() < 2.0, "{l}");
        let p = butterfly_polyline(80, 1e-7);
        assert_eq!(p.len(), 81);
        let seg = l / 80.0;
        for w in p.windows(2) {
            // Chords are never longer than the arc-length step.
            assert!(w[0].dist(w[1]) <= seg + 1e-6);
        }
        // The first vertices of the published 80-segment polyline (butterfly_80.ngc). Its
        // sampling procedure is not documented; ours agrees within 0.02 mm.
        assert!(
            p[1].dist(Vec3::new(56.3415, 48.0449, 0.0)) < 0.02,
            "{:?}",
            p[1]
        );
        assert!(
            p[2].dist(Vec3::new(60.0732, 46.7905, 0.0)) < 0.02,
            "{:?}",
            p[2]
        );
    }
}

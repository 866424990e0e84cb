//! Distances between points and polylines: the geometry the chains of written blocks,
//! the block floors and the extra axes share.

use ncsmooth::geom::Vec3;

/// Distance from `p` to the segment `a`-`b`, and the parameter of its foot (unclamped).
pub(crate) fn seg_dist(p: Vec3, a: Vec3, b: Vec3) -> (f64, f64) {
    let d = b - a;
    let l2 = d.norm_sq();
    if l2 <= 0.0 {
        return (p.dist(a), 0.0);
    }
    let t = (p - a).dot(d) / l2;
    (p.dist(a + d * t.clamp(0.0, 1.0)), t)
}

/// Whether the dense points strictly between `from` and `to` lie within `tol` of the
/// segment `a`-`b`, with projections in order and inside it. "In order" allows a step
/// back of up to `tol` behind the farthest projection so far: a cluster of
/// nanometre steps in arbitrary directions (a CAM file's own quantisation, e.g.
/// camotics_vcarve's 1e-6 inch moves) is a wiggle within the tolerance, not a reversal,
/// and the coverage argument of the module doc holds for any order (each written point
/// lies between the projections of two consecutive dense points). A reversal longer
/// than `tol` (a peck's retract) still ends the block.
pub(crate) fn fits(dense: &[Vec3], from: usize, to: usize, a: Vec3, b: Vec3, tol: f64) -> bool {
    let len = a.dist(b);
    let back = if len > 0.0 { tol / len } else { 0.0 };
    let mut far_t: f64 = 0.0;
    for &p in &dense[from + 1..to] {
        let (d, t) = seg_dist(p, a, b);
        if d > tol || t < far_t - back || t > 1.0 + back {
            return false;
        }
        far_t = far_t.max(t);
    }
    true
}

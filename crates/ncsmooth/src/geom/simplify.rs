//! Douglas-Peucker polyline simplification (Douglas and Peucker 1973), the one copy the
//! smoothing methods and the report's plots share.
//!
//! Iterative: a stack of spans `(a, b)`; the point of a span farthest from its chord (the
//! first of equals) is kept, and the span split there, while that distance exceeds the
//! tolerance (or the caller asks for the split anyway). Every dropped point then lies
//! within the tolerance of the kept chord spanning it. `O(n log n)` typically, `O(n^2)`
//! at worst.

/// Which of `n` points to keep (the ends always): a span `(a, b)` is split at the point
/// `k` of its inside with the largest `dist(a, b, k)` (the distance of point `k` from the
/// chord `a`-`b`, in the caller's units) when that exceeds `tol`, or when `split(a, b)`
/// asks for it (a chord that must not stand, e.g. a degenerate one).
///
/// ```
/// use ncsmooth::geom::douglas_peucker;
///
/// let y = [0.0, 0.1, 0.0, 3.0, 0.0];
/// let dist = |a: usize, b: usize, k: usize| {
///     // distance from the chord between (a, y[a]) and (b, y[b]), points at x = index
///     let (dx, dy) = ((b - a) as f64, y[b] - y[a]);
///     ((k - a) as f64 * dy - (y[k] - y[a]) * dx).abs() / dx.hypot(dy)
/// };
/// let keep = douglas_peucker(y.len(), 0.5, dist, |_, _| false);
/// assert_eq!(keep, [true, false, true, true, true]);
/// ```
pub fn douglas_peucker(
    n: usize,
    tol: f64,
    dist: impl Fn(usize, usize, usize) -> f64,
    split: impl Fn(usize, usize) -> bool,
) -> Vec<bool> {
    let keep: Vec<bool> = (0..n).map(|k| k == 0 || k + 1 == n).collect();
    douglas_peucker_from(keep, tol, dist, split)
}

/// [`douglas_peucker`] from the points already marked in `keep` (the ends among them):
/// each span between two consecutive kept points is simplified on its own.
pub fn douglas_peucker_from(
    mut keep: Vec<bool>,
    tol: f64,
    dist: impl Fn(usize, usize, usize) -> f64,
    split: impl Fn(usize, usize) -> bool,
) -> Vec<bool> {
    let fixed: Vec<usize> = (0..keep.len()).filter(|&k| keep[k]).collect();
    let mut stack: Vec<(usize, usize)> = fixed.windows(2).map(|w| (w[0], w[1])).collect();
    while let Some((a, b)) = stack.pop() {
        let mut far: Option<(usize, f64)> = None;
        for k in a + 1..b {
            let d = dist(a, b, k);
            if far.is_none_or(|(_, md)| d > md) {
                far = Some((k, d));
            }
        }
        if let Some((k, d)) = far {
            if d > tol || split(a, b) {
                keep[k] = true;
                stack.push((a, k));
                stack.push((k, b));
            }
        }
    }
    keep
}

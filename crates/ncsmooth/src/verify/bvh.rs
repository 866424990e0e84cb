//! A static bounding-volume hierarchy over primitives for nearest-distance queries.
//! Built by median splits on the longest axis of the centroids (O(n log n)); queried
//! depth-first, nearer child first, pruning boxes farther than the best distance so far.
//! An initial upper bound (a "hint", e.g. the distance to the primitive nearest the
//! previous query point) makes sequential queries along a path nearly O(log n).

use super::prim::Prim;
use crate::geom::{Aabb, Vec3};
use std::ops::Range;

/// Primitives per leaf.
const LEAF_SIZE: usize = 4;
/// Up to this many primitives a query scans them all: no boxes to compute, no tree to
/// build (the blend and run measurements of the smoothing methods compare a curve with
/// one or two programmed pieces, thousands of times).
const LINEAR_MAX_PRIMS: usize = 8;
/// Depth of the query stack: a depth-first query holds at most one pending node per
/// level plus the two children of the node it expands, and median splits keep the depth
/// at `log2(n / LEAF_SIZE) + 1`, so this is ample for any primitive count an index can
/// hold (`u32`). A fixed stack keeps queries free of allocation.
const STACK_DEPTH: usize = 72;

struct Node {
    bbox: Aabb,
    /// Leaf: `start..end` into `prims`; inner: `left = start`, `right = end`.
    start: u32,
    end: u32,
    leaf: bool,
}

pub(crate) struct Bvh {
    nodes: Vec<Node>,
    pub prims: Vec<Prim>,
    /// For each source, the position in `prims` of one of its primitives (`u32::MAX`
    /// for a source with none).
    by_source: Vec<u32>,
}

/// Result of a nearest query.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    pub dist_sq: f64,
    /// Index into `Bvh::prims`, or `usize::MAX` when nothing beat the initial bound.
    pub prim: usize,
}

impl Bvh {
    pub fn new(mut prims: Vec<Prim>) -> Bvh {
        if prims.len() <= LINEAR_MAX_PRIMS {
            return Bvh::linear(prims);
        }
        // Built in place: the primitives are reordered, never copied (a box costs a line's
        // two points or an arc's stored box).
        let mut nodes = Vec::with_capacity(2 * prims.len() / LEAF_SIZE + 1);
        build(&mut prims, 0, &mut nodes);
        let by_source = by_source(&prims);
        Bvh {
            nodes,
            prims,
            by_source,
        }
    }

    /// An index that scans all of `prims` at every query: for a handful of queries a tree
    /// would cost more to build than it saves.
    pub fn linear(prims: Vec<Prim>) -> Bvh {
        Bvh {
            nodes: Vec::new(),
            by_source: by_source(&prims),
            prims,
        }
    }

    /// The position in `prims` of a primitive of `source`, if it has one.
    pub fn of_source(&self, source: u32) -> Option<usize> {
        let i = *self.by_source.get(source as usize)?;
        (i != u32::MAX).then_some(i as usize)
    }

    /// Nearest primitive to `p` among those closer than `sqrt(bound_sq)`.
    pub fn nearest(&self, p: Vec3, bound_sq: f64) -> Hit {
        let mut best = Hit {
            dist_sq: bound_sq,
            prim: usize::MAX,
        };
        if self.nodes.is_empty() {
            // A few primitives (or none): scan them.
            for (i, prim) in self.prims.iter().enumerate() {
                let d = prim.dist_sq(p);
                if d < best.dist_sq {
                    best = Hit {
                        dist_sq: d,
                        prim: i,
                    };
                }
            }
            return best;
        }
        self.descend(p, bound_sq, |leaf| {
            for i in leaf {
                let d = self.prims[i].dist_sq(p);
                if d < best.dist_sq {
                    best = Hit {
                        dist_sq: d,
                        prim: i,
                    };
                }
            }
            Some(best.dist_sq)
        });
        best
    }

    /// Whether some primitive lies within `sqrt(r_sq)` of `p` (distance at most that),
    /// `hint` tried first: a search that stops at the first one, and prunes every box
    /// farther than the radius (for a point that cannot raise a maximum already found).
    pub fn any_within(&self, p: Vec3, r_sq: f64, hint: usize) -> bool {
        if self.prims.get(hint).is_some_and(|h| h.dist_sq(p) <= r_sq) {
            return true;
        }
        if self.nodes.is_empty() {
            return self.prims.iter().any(|x| x.dist_sq(p) <= r_sq);
        }
        let near = |leaf: Range<usize>| self.prims[leaf].iter().any(|x| x.dist_sq(p) <= r_sq);
        !self.descend(p, r_sq, |leaf| (!near(leaf)).then_some(r_sq))
    }

    /// Visits depth-first, the nearer child first, every leaf whose box lies within
    /// `sqrt(bound_sq)` of `p`: `leaf` gets the leaf's range of `prims` and returns the
    /// bound from there on (a nearest search lowers it), or `None` to stop the search.
    /// `false` when stopped.
    fn descend(
        &self,
        p: Vec3,
        mut bound_sq: f64,
        mut leaf: impl FnMut(Range<usize>) -> Option<f64>,
    ) -> bool {
        let mut stack = [0u32; STACK_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = &self.nodes[stack[top] as usize];
            if n.bbox.dist_sq(p) > bound_sq {
                continue;
            }
            if n.leaf {
                match leaf(n.start as usize..n.end as usize) {
                    Some(b) => bound_sq = b,
                    None => return false,
                }
            } else {
                let (l, r) = (n.start, n.end);
                let dl = self.nodes[l as usize].bbox.dist_sq(p);
                let dr = self.nodes[r as usize].bbox.dist_sq(p);
                // Push the farther first so the nearer is explored first.
                let (first, second) = if dl < dr { (r, l) } else { (l, r) };
                stack[top] = first;
                stack[top + 1] = second;
                top += 2;
            }
        }
        true
    }
}

/// For each source up to the largest of `prims`, the position of its last primitive.
fn by_source(prims: &[Prim]) -> Vec<u32> {
    let n = prims
        .iter()
        .map(|p| p.source as usize + 1)
        .max()
        .unwrap_or(0);
    let mut out = vec![u32::MAX; n];
    for (i, p) in prims.iter().enumerate() {
        out[p.source as usize] = i as u32;
    }
    out
}

fn build(items: &mut [Prim], offset: usize, nodes: &mut Vec<Node>) -> u32 {
    let mut bbox = Aabb::EMPTY;
    let mut cbox = Aabb::EMPTY;
    for b in items.iter().map(Prim::bbox) {
        bbox = bbox.union(b);
        cbox.include(b.center());
    }
    let idx = nodes.len() as u32;
    if items.len() <= LEAF_SIZE {
        nodes.push(Node {
            bbox,
            start: offset as u32,
            end: (offset + items.len()) as u32,
            leaf: true,
        });
        return idx;
    }
    nodes.push(Node {
        bbox,
        start: 0,
        end: 0,
        leaf: false,
    });
    let ext = cbox.max - cbox.min;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.center_on(axis).total_cmp(&b.center_on(axis)));
    let (lo, hi) = items.split_at_mut(mid);
    let l = build(lo, offset, nodes);
    let r = build(hi, offset + mid, nodes);
    nodes[idx as usize].start = l;
    nodes[idx as usize].end = r;
    idx
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Arc, Line};
    use crate::verify::prim::{PlanarArc, PrimGeom};

    /// Lines and arcs scattered by a fixed generator.
    fn prims(n: usize, seed: u64) -> Vec<Prim> {
        let mut r = seed;
        let mut next = move || {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            (r >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0
        };
        (0..n)
            .map(|i| {
                let a = Vec3::new(next(), next(), 0.1 * next());
                let b = a + Vec3::new(next(), next(), 0.0) * 0.2;
                let geom = if i % 3 == 0 {
                    let c = a + Vec3::new(0.3, 0.1, 0.0);
                    let arc = Arc::from_center(a, b, c, Vec3::Z, i % 2 == 0, 0).expect("arc");
                    PrimGeom::Arc(Box::new(PlanarArc::new(&arc)))
                } else {
                    PrimGeom::Line(Line::new(a, b))
                };
                Prim {
                    geom,
                    source: i as u32,
                }
            })
            .collect()
    }

    fn depth(bvh: &Bvh, node: usize) -> usize {
        let n = &bvh.nodes[node];
        if n.leaf {
            1
        } else {
            1 + depth(bvh, n.start as usize).max(depth(bvh, n.end as usize))
        }
    }

    /// Exponentially spaced short lines: median splits keep the depth within the stack's
    /// bound whatever the spread.
    #[test]
    fn depth_stays_within_the_stack() {
        let n = 3000;
        let ps: Vec<Prim> = (0..n)
            .map(|i| {
                let a = Vec3::new(1.2f64.powi(i), 0.0, 0.0);
                Prim {
                    geom: PrimGeom::Line(Line::new(a, a + Vec3::new(0.0, 1.0, 0.0))),
                    source: i as u32,
                }
            })
            .collect();
        let bvh = Bvh::new(ps);
        let bound = (n as f64 / LEAF_SIZE as f64).log2().ceil() as usize + 1;
        let d = depth(&bvh, 0);
        assert!(
            d <= bound && bound + 2 <= STACK_DEPTH,
            "depth {d}, bound {bound}"
        );
        let p = Vec3::new(0.5, 0.5, 0.0);
        let brute = bvh
            .prims
            .iter()
            .map(|x| x.dist_sq(p))
            .fold(f64::INFINITY, f64::min);
        assert_eq!(bvh.nearest(p, f64::INFINITY).dist_sq, brute);
    }

    #[test]
    fn nearest_is_the_brute_force_minimum() {
        // Below and above the linear-scan size, with and without a bound.
        for n in [1, 2, LINEAR_MAX_PRIMS, LINEAR_MAX_PRIMS + 1, 40, 300] {
            let ps = prims(n, 0x9e37_79b9_7f4a_7c15 ^ n as u64);
            let bvh = Bvh::new(ps.clone());
            assert_eq!(bvh.nodes.is_empty(), n <= LINEAR_MAX_PRIMS);
            for q in prims(50, 7) {
                let p = q.eval(0.5);
                let brute = ps
                    .iter()
                    .map(|x| x.dist_sq(p))
                    .fold(f64::INFINITY, f64::min);
                let hit = bvh.nearest(p, f64::INFINITY);
                assert_eq!(hit.dist_sq, brute);
                assert_eq!(bvh.prims[hit.prim].dist_sq(p), brute);
                // A bound below the minimum finds nothing.
                assert_eq!(bvh.nearest(p, 0.5 * brute).prim, usize::MAX);
                // The minimum itself is within reach, less is not, whatever the hint.
                for hint in [0, n / 2, n - 1, usize::MAX] {
                    assert!(bvh.any_within(p, brute, hint));
                    assert!(brute == 0.0 || !bvh.any_within(p, brute * (1.0 - 1e-9), hint));
                }
            }
        }
    }
}

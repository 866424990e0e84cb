//! A static bounding-volume hierarchy over primitives for nearest-distance queries.
//! Built by median splits on the longest axis of the centroids (O(n log n)); queried
//! depth-first, nearer child first, pruning boxes farther than the best distance so far.
//! An initial upper bound (a "hint", e.g. the distance to the primitive nearest the
//! previous query point) makes sequential queries along a path nearly O(log n).

use super::prim::Prim;
use crate::geom::{Aabb, Vec3};

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
        Bvh { nodes, prims }
    }

    /// An index that scans all of `prims` at every query: for a handful of queries a tree
    /// would cost more to build than it saves.
    pub fn linear(prims: Vec<Prim>) -> Bvh {
        Bvh {
            nodes: Vec::new(),
            prims,
        }
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
        let mut stack = [0u32; STACK_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = &self.nodes[stack[top] as usize];
            if n.bbox.dist_sq(p) >= best.dist_sq {
                continue;
            }
            if n.leaf {
                for i in n.start as usize..n.end as usize {
                    let d = self.prims[i].dist_sq(p);
                    if d < best.dist_sq {
                        best = Hit {
                            dist_sq: d,
                            prim: i,
                        };
                    }
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
        best
    }
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
    items.select_nth_unstable_by(mid, |a, b| {
        a.bbox().center()[axis].total_cmp(&b.bbox().center()[axis])
    });
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
            }
        }
    }
}

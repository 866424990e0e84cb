#!/usr/bin/env python3
"""Independent two-sided check of a written printer/laser program against its original.

    scripts/two_sided.py ORIGINAL PRODUCED [--tol T] [--firmware F] [--json]

A dev tool, independent of ncsmooth's own verifier: its own small reader (G0-G3 with
X Y Z E F, I J centres in G17, G90/G91, M82/M83, G92 E, G20/G21, `;` and `( )` comments),
arcs sampled within 1e-5 mm. It reports upper bounds (exact point-to-segment distances to
candidate segments found through a k-d tree), so "within tol" here is a proof up to the
1e-5 mm of the arc sampling:

  out_to_prog   largest distance of a point of the produced path (its segments sampled
                0.002 mm apart: the true largest is at most 0.001 mm more) from the
                original path (points_over_tol counts 1 when it is over);
  vertex_to_out largest distance of an original vertex from the produced path;
  e_along_path  largest |E| difference at the produced block ends against the original's
                E at the same place (nearest point of the original path, E linear along
                each original move); only where both extrude (absolute E, resets applied).

Motion is compared per axis X Y Z; rapids and feeds alike. Needs numpy and scipy.

`--firmware marlin|klipper` measures the produced program as that firmware runs its
arcs: the chords it cuts them into (written from the firmwares' sources, not from
ncsmooth): Marlin 2.0.9.2+ `plan_arc` with its defaults (segments of at most
`MAX_ARC_SEGMENT_MM` 1 mm, at least 0.1 mm, at least 72 per full turn, a remainder
segment to the end when the whole ones fall short), Klipper's `gcode_arcs.py`
(`floor(length / resolution)` equal chords, resolution 1 mm); `--arc-segment MM` sets
Marlin's `MAX_ARC_SEGMENT_MM` or Klipper's resolution. `exact` (the default) runs the
circle.
"""
import argparse
import json
import math
import re
import sys

import numpy as np
from scipy.spatial import cKDTree

WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
ARC_SAG_MM = 1e-5
PIECE_MM = 0.5
SAMPLE_MM = 0.002


def strip(line):
    line = re.sub(r"\([^)]*\)", "", line)
    return line.split(";", 1)[0]


def densify(p, step):
    """The polyline `p` with points at most `step` apart on every segment (vertex flags
    kept on the original points)."""
    a, b = p[:-1], p[1:]
    length = np.linalg.norm(b[:, :3] - a[:, :3], axis=1)
    n = np.maximum(1, np.ceil(length / step)).astype(int)
    idx = np.repeat(np.arange(len(a)), n)
    k = np.concatenate([np.arange(1, m + 1) for m in n]) if len(n) else np.array([], int)
    t = (k / n[idx])[:, None]
    pts = a[idx] + (b[idx] - a[idx]) * t
    pts[:, 4] = np.where(k == n[idx], b[idx, 4], 0.0)
    return np.vstack([p[:1], pts])


def arc_steps(r, sweep, dz, firmware, segment_mm=1.0):
    """Fractions of the sweep at which the firmware's chords of an arc end (the last 1);
    `segment_mm` is Marlin's MAX_ARC_SEGMENT_MM or Klipper's resolution."""
    if firmware == "marlin":
        full = sweep >= 2 * math.pi - 1e-12
        flat = r * sweep
        min_segments = 72 if full else max(1, math.ceil(72 * sweep / (2 * math.pi)))
        nominal = max(math.floor(flat / segment_mm), min_segments)
        seg = flat / nominal  # Marlin's constrain(): the low bound first
        seg = 0.1 if seg < 0.1 else min(seg, segment_mm)
        n = max(1, math.floor(flat / seg))
        proportion = n * seg / flat if n * seg < flat - 1e-4 else 1.0
        steps = [k * proportion / n for k in range(1, n + 1)]
        if proportion < 1.0:
            steps.append(1.0)
        steps[-1] = 1.0
        return steps
    if firmware == "klipper":
        n = max(1, math.floor(math.hypot(r * sweep, dz) / segment_mm))
        return [k / n for k in range(1, n + 1)]
    step = 2 * math.acos(max(-1.0, 1 - ARC_SAG_MM / r)) if r > ARC_SAG_MM else sweep
    n = max(1, int(math.ceil(sweep / step)))
    return [k / n for k in range(1, n + 1)]


def read(path, firmware="exact", segment_mm=1.0):
    """Polyline points (x, y, z, e, is_vertex) of the program, in mm; arcs as `firmware`
    runs them (see the module doc)."""
    pos = [0.0, 0.0, 0.0]
    e = 0.0
    e_off = 0.0  # machine E = program E + e_off (G92 E resets)
    absolute, e_abs, scale, motion = True, True, 1.0, None
    pts = [(0.0, 0.0, 0.0, 0.0, False)]
    started = False
    for raw in open(path, errors="replace"):
        words = WORD.findall(strip(raw))
        if not words:
            continue
        w = {}
        gs, ms = [], []
        for l, v in words:
            l = l.upper()
            if l == "G":
                gs.append(float(v))
            elif l == "M":
                ms.append(float(v))
            else:
                w[l] = float(v)
        for g in gs:
            if g in (0, 1, 2, 3):
                motion = int(g)
            elif g == 90:
                absolute = True
            elif g == 91:
                absolute = False
            elif g == 20:
                scale = 25.4
            elif g == 21:
                scale = 1.0
        for m in ms:
            if m == 82:
                e_abs = True
            elif m == 83:
                e_abs = False
        if 92 in gs:
            if "E" in w:
                e_off = e - w["E"] * scale
            continue
        if motion is None or not any(k in w for k in "XYZE"):
            continue
        if any(g in (4, 28, 53) for g in gs):
            continue
        new = list(pos)
        for i, l in enumerate("XYZ"):
            if l in w:
                v = w[l] * scale
                new[i] = v if absolute else pos[i] + v
        ne = e
        if "E" in w:
            v = w["E"] * scale
            ne = (v + e_off) if (e_abs and absolute) else e + v
        if not started:
            pts = [(pos[0], pos[1], pos[2], e, False)]
            started = True
        if motion in (2, 3) and ("I" in w or "J" in w):
            cx, cy = pos[0] + w.get("I", 0.0) * scale, pos[1] + w.get("J", 0.0) * scale
            r = math.hypot(pos[0] - cx, pos[1] - cy)
            a0 = math.atan2(pos[1] - cy, pos[0] - cx)
            a1 = math.atan2(new[1] - cy, new[0] - cx)
            ccw = motion == 3
            sweep = (a1 - a0) if ccw else (a0 - a1)
            sweep %= 2 * math.pi
            if sweep <= 1e-12:
                sweep = 2 * math.pi
            steps = arc_steps(r, sweep, new[2] - pos[2], firmware, segment_mm)
            for k, t in enumerate(steps):
                a = a0 + (sweep * t if ccw else -sweep * t)
                last = k == len(steps) - 1
                x, y = (new[0], new[1]) if last and firmware != "exact" else \
                    (cx + r * math.cos(a), cy + r * math.sin(a))
                pts.append((x, y, pos[2] + (new[2] - pos[2]) * t, e + (ne - e) * t, last))
        else:
            pts.append((new[0], new[1], new[2], ne, True))
        pos, e = new, ne
    return np.array(pts, dtype=float)


def pieces(p):
    """Segments of polyline `p` cut into pieces of at most PIECE_MM: (a, b, ea, eb)."""
    a, b = p[:-1], p[1:]
    length = np.linalg.norm(b[:, :3] - a[:, :3], axis=1)
    n = np.maximum(1, np.ceil(length / PIECE_MM)).astype(int)
    idx = np.repeat(np.arange(len(a)), n)
    k = np.concatenate([np.arange(m) for m in n]) if len(n) else np.array([], int)
    t0 = (k / n[idx])[:, None]
    t1 = ((k + 1) / n[idx])[:, None]
    pa = a[idx] + (b[idx] - a[idx]) * t0
    pb = a[idx] + (b[idx] - a[idx]) * t1
    return pa, pb


def max_dist_to(p, step, pa, pb, chunk=2000):
    """The largest (upper-bound) distance from the polyline `p`, its segments sampled
    `step` apart, to the polyline of pieces `pa`-`pb`: chunk by chunk, in bounded memory."""
    tree = cKDTree(0.5 * (pa[:, :3] + pb[:, :3]))
    worst = 0.0
    for lo in range(0, len(p) - 1, chunk):
        part = densify(p[lo:lo + chunk + 1], step) if step else p[lo:lo + chunk]
        d, _ = dist_to(part, pa, pb, tree=tree)
        worst = max(worst, float(d.max()))
    return worst


def dist_to(points, pa, pb, k=8, tree=None):
    """The distance from each point to the polyline of pieces (exact: a piece not among
    the nearest midpoints tried is farther than the farthest of them less half a piece,
    and the points where that does not settle it are tried again with more), and the E
    there (linear along the nearest piece)."""
    mid = 0.5 * (pa[:, :3] + pb[:, :3])
    tree = tree or cKDTree(mid)
    best = np.full(len(points), np.inf)
    best_e = np.zeros(len(points))
    todo = np.arange(len(points))
    while len(todo):
        kk = min(k, len(mid))
        dmid, cand = tree.query(points[todo, :3], k=kk)
        if kk == 1:
            dmid, cand = dmid[:, None], cand[:, None]
        for j in range(kk):
            c = cand[:, j]
            a, b = pa[c], pb[c]
            d = b[:, :3] - a[:, :3]
            l2 = np.einsum("ij,ij->i", d, d)
            pts = points[todo, :3]
            t = np.where(l2 > 0, np.einsum("ij,ij->i", pts - a[:, :3], d) / np.where(l2 > 0, l2, 1), 0.0)
            t = np.clip(t, 0.0, 1.0)
            dist = np.linalg.norm(pts - (a[:, :3] + d * t[:, None]), axis=1)
            better = dist < best[todo]
            best[todo] = np.where(better, dist, best[todo])
            best_e[todo] = np.where(better, a[:, 3] + (b[:, 3] - a[:, 3]) * t, best_e[todo])
        if kk == len(mid):
            break
        settled = dmid[:, -1] - 0.5 * PIECE_MM >= best[todo]
        todo = todo[~settled]
        k *= 8
    return best, best_e


def e_along(ends, spans, pa, pb, window=400):
    """|E| differences of the produced block ends from the original's E at the nearest
    point of the original path near where the last end was matched (monotone along the
    program: a travel crossing an extrusion is not matched to it)."""
    out = np.zeros(len(ends))
    ptr = 0
    n = len(pa)
    for i, pt in enumerate(ends):
        # The window reaches past the original's pieces a block `spans[i]` long can span.
        reach = window + 2 * int(math.ceil(spans[i] / PIECE_MM))
        lo, hi = max(0, ptr - 8), min(n, ptr + reach)
        a, b = pa[lo:hi], pb[lo:hi]
        d = b[:, :3] - a[:, :3]
        l2 = np.einsum("ij,ij->i", d, d)
        t = np.where(l2 > 0, ((pt[:3] - a[:, :3]) * d).sum(1) / np.where(l2 > 0, l2, 1), 0.0)
        t = np.clip(t, 0.0, 1.0)
        dist = np.linalg.norm(pt[:3] - (a[:, :3] + d * t[:, None]), axis=1)
        # Where the program is at one place with several E (a retract, a prime), the
        # place has each of them.
        near = dist <= dist.min() + 1e-6
        e_there = a[:, 3] + (b[:, 3] - a[:, 3]) * t
        # A move of E alone (a retract, a prime) has every E between its ends there.
        still = l2 <= 0
        lo_e, hi_e = np.minimum(a[:, 3], b[:, 3]), np.maximum(a[:, 3], b[:, 3])
        e_there = np.where(still, np.clip(pt[3], lo_e, hi_e), e_there)
        diff = np.where(near, np.abs(pt[3] - e_there), np.inf)
        j = int(np.argmin(diff))
        ptr = lo + j
        out[i] = diff[j]
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("original")
    ap.add_argument("produced")
    ap.add_argument("--tol", type=float, default=None)
    ap.add_argument("--firmware", choices=["exact", "marlin", "klipper"], default="exact")
    ap.add_argument("--arc-segment", type=float, default=1.0,
                    help="Marlin's MAX_ARC_SEGMENT_MM or Klipper's resolution (mm)")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    p = read(a.original)
    q = read(a.produced, a.firmware, a.arc_segment)
    ppa, ppb = pieces(p)
    qpa, qpb = pieces(q)
    # Every point of the produced path: its segments sampled SAMPLE_MM apart (a point
    # between two samples is within SAMPLE_MM / 2 of one).
    out_max = max_dist_to(q, SAMPLE_MM, ppa, ppb)
    vtx = p[p[:, 4] > 0]
    vtx_d, _ = dist_to(vtx, qpa, qpb)
    # Each produced block end with the length of the path from the end before it.
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q[:, :3], axis=0), axis=1))])
    at_end = np.where(q[:, 4] > 0)[0]
    spans = np.diff(np.concatenate([[0.0], along[at_end]]))
    e_diff = e_along(q[at_end], spans, ppa, ppb)
    res = {
        "original_points": int(len(p)), "produced_points": int(len(q)),
        "out_to_prog_mm": out_max, "vertex_to_out_mm": float(vtx_d.max()),
        "e_along_path_mm": float(e_diff.max()) if len(e_diff) else 0.0,
        "points_over_tol": None,
    }
    if a.tol is not None:
        res["points_over_tol"] = int(out_max > a.tol) + int((vtx_d > a.tol).sum())
    print(json.dumps(res) if a.json else "\n".join(f"{k}: {v}" for k, v in res.items()))
    sys.exit(0 if not res["points_over_tol"] else 1)


if __name__ == "__main__":
    main()

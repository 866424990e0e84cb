#!/usr/bin/env python3
"""Extrusion along the path: how far a written program's E strays from the program's.

usage: flow_diff.py PROGRAM WRITTEN

Both files are read as absolute-E slicer output (G90/M82, G0-G3 with X Y Z E, G92 E
resets; an arc is taken as its end point). For every point the written program moves to while extruding, the program's E
at the nearest point of its own path (searched forward from the last one, within the
same G92 stretch) is compared with the written E. Prints the largest difference (mm of
filament) and where, and per stretch the final E of both. A dev tool, not a test.
"""
import math
import re
import sys

# A written point is matched to the program's path within this distance (mm).
NEAR_MM = 0.02

# Program segments whose E is farther than this from the written E are not candidates
# (mm of filament; E rises monotonically within a stretch but for its final retract).
E_WINDOW_MM = 0.1

WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


def moves(path):
    """(stretch, xyz, e, line) for every G0/G1 move end; stretch counts G92 E resets."""
    pos, e, stretch, out = [0.0, 0.0, 0.0], 0.0, 0, []
    for n, raw in enumerate(open(path, errors="replace"), 1):
        line = re.sub(r"\([^)]*\)|;.*$", "", raw).upper()
        words = dict((k, float(v)) for k, v in WORD.findall(line))
        g = words.get("G")
        if g == 92 and "E" in words:
            stretch += 1
            e = words["E"]
            continue
        if g not in (0, 1, 2, 3):
            continue
        q = [words.get(a, pos[i]) for i, a in enumerate("XYZ")]
        e = words.get("E", e)
        out.append((stretch, q, e, n))
        pos = q
    return out


def seg_foot(p, a, b):
    d = [b[i] - a[i] for i in range(3)]
    l2 = sum(x * x for x in d)
    t = 1.0 if l2 == 0 else max(0.0, min(1.0, sum((p[i] - a[i]) * d[i] for i in range(3)) / l2))
    f = [a[i] + d[i] * t for i in range(3)]
    return math.dist(p, f), t


def main():
    prog, written = moves(sys.argv[1]), moves(sys.argv[2])
    worst, where, cur, unmatched = 0.0, None, 1, 0
    ends = {}
    prev_e, prev_p = None, None
    for st, p, e, n in written:
        ends.setdefault(st, [None, None])[1] = e
        extruding = prev_e is not None and e > prev_e and p != prev_p
        prev_e, prev_p = e, p
        if not extruding:
            continue
        while cur < len(prog) and prog[cur][0] < st:
            cur += 1
        # Of the program's extruding segments near the point (paths of one layer cross
        # each other), the one whose E is nearest the written E: a lower bound on the
        # point's error, exact where the path does not cross itself.
        best = (math.inf, None, 0.0)
        for j in range(max(1, cur), len(prog)):
            if prog[j][0] != st or (prog[j - 1][0] == st and prog[j - 1][2] > e + E_WINDOW_MM):
                break
            if prog[j][2] < e - E_WINDOW_MM:
                continue
            if prog[j - 1][0] != st or prog[j - 1][1] == prog[j][1] or prog[j][2] <= prog[j - 1][2]:
                continue  # an E-only move (retract, prime), a travel over the path, a reset
            d, t = seg_foot(p, prog[j - 1][1], prog[j][1])
            if d <= NEAR_MM:
                ep = prog[j - 1][2] + (prog[j][2] - prog[j - 1][2]) * t
                if abs(e - ep) < best[0]:
                    best = (abs(e - ep), j, ep)
        _, j, ep = best
        if j is None:
            unmatched += 1
            continue
        cur = j
        if abs(e - ep) > abs(worst):
            worst, where = e - ep, (n, prog[j][3])
    for st, p, e, n in prog:
        ends.setdefault(st, [None, None])[0] = e
    bad = [(s, a, b) for s, (a, b) in ends.items() if a is None or b is None or abs(a - b) > 1e-4]
    print(f"largest E difference {worst:+.5f} mm at written line {where[0] if where else '-'}"
          f" (program line {where[1] if where else '-'})")
    print(f"extruding points with no extruding program segment within {NEAR_MM} mm and "
          f"{E_WINDOW_MM} mm of E: {unmatched}")
    print(f"stretches {len(ends)}, final E differing by more than 1e-4: {len(bad)} {bad[:5]}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Where one LinuxCNC run loses time against another (dev script, not CI).

    scripts/linuxcnc_time_diff.py REF.csv OURS.csv [--bin 2.0] [--top 12]

REF.csv and OURS.csv are `linuxcnc_run.py --csv` samples of two programs that follow the
same path (e.g. the input under `G64 P<tol>` and a smoothed output), one row per servo
period with t, x, y, z, current_vel, motion_type and line. Prints

  * rapid time (motion type 1) and feed time of both runs;
  * the sections between rapids matched by their start point, worst first, with
    their time difference;
  * time per arc-length bin of the reference path, OURS matched to it monotonically (each
    sample to the nearest point of the reference path at most 2 mm ahead of the last
    match, so a path that passes the same place twice is not mixed up), worst bins first,
    with both runs' lowest speed in the bin;
  * the bins' differences summed by the reference's lowest speed in the bin (stops and
    sharp corners, tight turns, cruise): which kind of place the time is lost or won at.

Numbers are seconds at the sampling period (1 ms by default). Needs numpy.
"""
import argparse

import numpy as np

PERIOD_S = 0.001
RAPID = 1
# Classes of bins by the reference's lowest feed speed in the bin (mm/s): stops and sharp
# corners, tight corners, turns, curves taken at speed, fast stretches.
SPEED_CLASSES = ((0.0, 2.0), (2.0, 5.0), (5.0, 10.0), (10.0, 20.0), (20.0, float("inf")))
MATCH_AHEAD_MM = 2.0
MATCH_GRID_MM = 0.005
MATCH_MAX_MM = 0.05


def load(path):
    d = np.genfromtxt(path, delimiter=",", names=True)
    p = np.c_[d["x"], d["y"], d["z"]]
    moving = np.r_[False, np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-9]
    idx = np.nonzero(moving)[0]
    d = d[idx[0] - 1 : idx[-1] + 1]
    return d, np.c_[d["x"], d["y"], d["z"]]


def feed_sections(d, p):
    feed = d["motion_type"].astype(int) != RAPID
    out, start = [], None
    for i, f in enumerate(feed):
        if f and start is None:
            start = i
        if not f and start is not None:
            out.append((start, i))
            start = None
    if start is not None:
        out.append((start, len(feed)))
    return [(a, b, p[a], (b - a) * PERIOD_S) for a, b in out]


def arclen(p):
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]


def monotone_match(ref_p, ours_p):
    """Arc length on the reference path of every sample of ours."""
    s = arclen(ref_p)
    grid = np.arange(0.0, s[-1], MATCH_GRID_MM)
    g = np.c_[[np.interp(grid, s, ref_p[:, k]) for k in range(3)]].T
    ahead = int(MATCH_AHEAD_MM / MATCH_GRID_MM)
    j, out = 0, np.zeros(len(ours_p))
    for i, q in enumerate(ours_p):
        d = np.linalg.norm(g[j : j + ahead] - q, axis=1)
        k = int(np.argmin(d))
        if d[k] < MATCH_MAX_MM:
            j += k
        out[i] = grid[j]
    return s, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ref")
    ap.add_argument("ours")
    ap.add_argument("--bin", type=float, default=2.0, help="bin length (mm)")
    ap.add_argument("--top", type=int, default=12)
    a = ap.parse_args()
    rd, rp = load(a.ref)
    od, op = load(a.ours)
    rapid = lambda d: (d["motion_type"].astype(int) == RAPID).sum() * PERIOD_S
    print(f"total {len(rd) * PERIOD_S:.3f} / {len(od) * PERIOD_S:.3f} s, "
          f"rapids {rapid(rd):.3f} / {rapid(od):.3f} s (ref / ours)")
    rs, os_ = feed_sections(rd, rp), feed_sections(od, op)
    rows = []
    for k, (_, _, start, t) in enumerate(os_):
        j = min(range(len(rs)), key=lambda m: np.linalg.norm(rs[m][2] - start))
        rows.append((t - rs[j][3], k, t, rs[j][3]))
    rows.sort(reverse=True)
    print(f"sections between rapids {len(rs)} / {len(os_)}, their time "
          f"{sum(x[3] for x in rs):.3f} / {sum(x[3] for x in os_):.3f} s; worst:")
    for d, k, t, tr in rows[: a.top]:
        print(f"  section {k:4d}: {tr:.3f} -> {t:.3f} s ({d:+.3f})")
    s_ref, s_ours = monotone_match(rp, op)
    nb = int(s_ref[-1] / a.bin) + 1
    t_ref = np.bincount((s_ref / a.bin).astype(int), minlength=nb) * PERIOD_S
    t_ours = np.bincount((s_ours / a.bin).astype(int), minlength=nb) * PERIOD_S
    diff = t_ours - t_ref
    print(f"bins of {a.bin} mm: +{diff[diff > 0].sum():.3f} / {diff[diff < 0].sum():.3f} s; worst:")
    for k in np.argsort(-diff)[: a.top]:
        lo, hi = k * a.bin, (k + 1) * a.bin
        vr = rd["current_vel"][(s_ref >= lo) & (s_ref < hi)]
        vo = od["current_vel"][(s_ours >= lo) & (s_ours < hi)]
        vmin = lambda v: v.min() if len(v) else float("nan")
        print(f"  s {lo:8.1f} mm: {t_ref[k]:.3f} -> {t_ours[k]:.3f} s ({diff[k]:+.3f}), "
              f"lowest speed {vmin(vr):.1f} / {vmin(vo):.1f} mm/s")
    by_speed(rd, s_ref, diff, a.bin)


def by_speed(rd, s_ref, diff, bin_mm):
    """Prints the bins' time differences summed by the reference's lowest feed speed."""
    feed = rd["motion_type"].astype(int) != RAPID
    k = (s_ref[feed] / bin_mm).astype(int)
    low = np.full(len(diff), np.inf)
    np.minimum.at(low, k, rd["current_vel"][feed])
    print("by the reference's lowest feed speed in the bin:")
    for lo, hi in SPEED_CLASSES:
        m = (low >= lo) & (low < hi)
        d = diff[m]
        print(f"  {lo:4.0f}-{hi:<4.0f} mm/s: {m.sum():4d} bins, {d.sum():+.3f} s "
              f"(lost {d[d > 0].sum():+.3f}, won {d[d < 0].sum():+.3f})")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Dev script (not a project dependency): compare the cycle time of `ncsmooth plan` with
TOPP-RA's acceleration-limited time-optimal parameterisation of the same path.

    pip install toppra numpy
    ncsmooth plan FILE --method M --tol MM --feed V --acc A --chord-error 10 \
        --path-samples samples.csv --report report.json
    python3 scripts/toppra_compare.py samples.csv report.json --feed V --acc A

The path is rebuilt by TOPP-RA's cubic spline through the arc-length samples (s, x, y, z);
a fourth coordinate equal to s carries the feed limit (|ds/dt| <= feed) as a joint velocity
limit. Constraints: per-axis |acceleration| <= acc (and |velocity| <= vaxis if given).
TOPP-RA knows no chord-error limit, so plan with a large --chord-error for a fair ratio.
The path must be tangent-continuous (a smoothed path): TOPP-RA on a spline through a
cornered polyline would round the corners. Where the program stops anyway (the profiles
start with a rapid from the machine origin to the first point, a corner ncsmooth stops at),
pass the arc lengths of those stops with `--stops S1,S2,...`: TOPP-RA then plans each part
from rest to rest and the durations add up. Prints the two cycle times and their ratio.
"""
import argparse
import json

import numpy as np
import toppra as ta
import toppra.algorithm as algo
import toppra.constraint as constraint


def axes(v):
    p = [float(x) for x in v.split(",")]
    return p * 3 if len(p) == 1 else p


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("samples", help="CSV s,x,y,z from --path-samples (mm)")
    ap.add_argument("report", help="JSON report of ncsmooth plan")
    ap.add_argument("--feed", type=float, required=True, help="feed limit (mm/s)")
    ap.add_argument("--acc", required=True, help="acceleration (mm/s^2), one value or x,y,z")
    ap.add_argument("--vaxis", help="per-axis velocity (mm/s), one value or x,y,z")
    ap.add_argument("--gridpoints", type=int, default=4000, help="TOPP-RA grid points (whole path)")
    ap.add_argument("--stops", default="", help="arc lengths (mm) where the machine stops, comma separated")
    a = ap.parse_args()
    d = np.loadtxt(a.samples, delimiter=",", skiprows=1)
    s = d[:, 0]
    keep = np.concatenate([[True], np.diff(s) > 1e-12])
    s, xyz = s[keep], d[keep, 1:4]
    acc = axes(a.acc)
    big = 1e12
    vl = np.array([[-big, big]] * 3 + [[-a.feed, a.feed]])
    if a.vaxis:
        for i, v in enumerate(axes(a.vaxis)):
            vl[i] = [-v, v]
    al = np.array([[-x, x] for x in acc] + [[-big, big]])
    cons = [constraint.JointVelocityConstraint(vl), constraint.JointAccelerationConstraint(al)]
    stops = sorted(float(x) for x in a.stops.split(",") if x.strip())
    bounds = [s[0]] + [x for x in stops if s[0] < x < s[-1]] + [s[-1]]
    t_opt = 0.0
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        sel = (s >= lo - 1e-9) & (s <= hi + 1e-9)
        ss, pp = s[sel], xyz[sel]
        path = ta.SplineInterpolator(ss, np.column_stack([pp, ss]))
        n = max(50, int(a.gridpoints * (hi - lo) / (s[-1] - s[0])))
        grid = np.linspace(ss[0], ss[-1], n)
        inst = algo.TOPPRA(cons, path, gridpoints=grid, parametrizer="ParametrizeConstAccel")
        traj = inst.compute_trajectory(0, 0)
        if traj is None:
            raise SystemExit("TOPP-RA failed on [%g, %g]" % (lo, hi))
        t_opt += traj.duration
    rep = json.load(open(a.report))
    plan = rep.get("plan", rep)
    t_ours = plan["cycle_time_s"]
    print(json.dumps({
        "path_length_mm": float(s[-1] - s[0]),
        "samples": int(len(s)),
        "toppra_gridpoints": a.gridpoints,
        "toppra_cycle_s": t_opt,
        "ncsmooth_cycle_s": t_ours,
        "ratio": t_ours / t_opt,
    }, indent=2))


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Isolates what LinuxCNC 2.9's trajectory planner does with curved paths (dev script, not CI).

    [NCSMOOTH_SHARED=../shared] scripts/linuxcnc_normal_acc.py [--vel 50] [--acc 500] [--r 5] [--laps 10]

Runs three programs on LinuxCNC's own planner (linuxcnc_run.py, real time) and prints the
speed each reaches against what the acceleration limit allows:

  * a circle of radius R as one G2 per lap: the speed a curve of radius R allows is
    min(V, sqrt(A R)); LinuxCNC keeps only sqrt(3)/2 of A for the normal direction on
    arcs (tp.c's normal acceleration ratio), so it runs at sqrt(sqrt(3)/2 A R);
  * the same circle as 400 G1 lines per lap under G64 P0.001 Q0: its blend arcs get the
    same share, so the lines cannot beat the arc;
  * a straight back-and-forth of the same length per lap as a control: tangential
    acceleration gets the whole of A.

and, with --tangential, three programs that start and stop on a gentle curve, where the
curvature never limits the speed (radius 100 mm: sqrt(sqrt(3)/2 A R) is well above V):

  * one G2 arc of 10 mm (G61): LinuxCNC accelerates along an arc with only half of A
    (tc.c tcGetTangentialMaxAccel: acc_ratio_tan, BLEND_ACC_RATIO_TANGENTIAL 0.5);
  * the same arc as 100 G1 lines under G64 P0.001 Q0: a line whose remainder between two
    blend arcs lasts under ARC_BLEND_GAP_CYCLES (4) servo periods is consumed into the
    blend (blendCheckConsume), and blends are arcs, so these lines accelerate at A/2 too;
  * a straight line of the same length (G61): the whole of A. (Under G64 a lone move, and
    the last line of any blended run, keeps a parabolic end condition, which halves A
    again: tc.c tcGetOverallMaxAccel.)

What it shows for the smoothed output: on a curve-limited contour every written curve
(G2, blended G1 runs, G5, G5.2) runs on LinuxCNC at most sqrt(sqrt(3)/2) = 0.93 of the
speed ncsmooth's own plan uses at the same limits, so a path whose time is mostly
curvature-limited cannot reach the plan's cycle time there.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.environ.get("NCSMOOTH_SHARED", os.path.join(HERE, "..", "..", "shared"))
RUN = os.path.join(SHARED, "tools", "linuxcnc_run.py")
BIN = os.environ.get("NCSMOOTH_BIN", os.path.join(HERE, "..", "target", "release", "ncsmooth"))


def run(prog, a):
    r = subprocess.run([sys.executable, RUN, prog, "--vel", str(a.vel), "--acc", str(a.acc)],
                       capture_output=True, text=True)
    for line in reversed(r.stdout.strip().splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    sys.exit(f"linuxcnc_run.py failed: {r.stderr[-2000:]}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vel", type=float, default=50.0)
    ap.add_argument("--acc", type=float, default=500.0)
    ap.add_argument("--r", type=float, default=5.0)
    ap.add_argument("--laps", type=int, default=10)
    ap.add_argument("--tangential", action="store_true",
                    help="run the start-stop programs on a gentle curve instead")
    a = ap.parse_args()
    if not os.path.exists(RUN):
        sys.exit(f"needs {RUN}")
    r, n = a.r, a.laps
    f = a.vel * 60
    tmp = tempfile.mkdtemp(prefix="ncsmooth-lcnc-")
    if a.tangential:
        return tangential(a, f, tmp)
    progs = {}
    g2 = [f"G21 G90 G17 G64 P0.001 Q0", f"G0 X{r} Y0", f"G1 F{f}"]
    g2 += [f"G2 X{r} Y0 I{-r} J0"] * n
    progs["G2 circle"] = g2 + ["M2"]
    lines = [f"G21 G90 G17 G64 P0.001 Q0", f"G0 X{r} Y0", f"G1 F{f}"]
    for _ in range(n):
        for k in range(1, 401):
            t = -2 * math.pi * k / 400
            lines.append(f"X{r * math.cos(t):.6f} Y{r * math.sin(t):.6f}")
    progs["400-line circle, G64 P0.001"] = lines + ["M2"]
    length = 2 * math.pi * r
    line = [f"G21 G90 G64 P0.001 Q0", "G0 X0 Y0", f"G1 F{f}"]
    for _ in range(n):
        line += [f"X{length / 2:.6f}", "X0"]
    progs["straight control"] = line + ["M2"]
    ideal = min(a.vel, math.sqrt(a.acc * r))
    lcnc = min(a.vel, math.sqrt(math.sqrt(3) / 2 * a.acc * r))
    print(f"V {a.vel} mm/s, A {a.acc} mm/s^2, R {r} mm, {n} laps of {length:.3f} mm")
    print(f"speed the limits allow on the circle: {ideal:.2f} mm/s; "
          f"with sqrt(3)/2 of A normal: {lcnc:.2f} mm/s\n")
    print("| program | cycle s | mean speed mm/s | peak speed mm/s |")
    print("|---|---|---|---|")
    for name, text in progs.items():
        p = os.path.join(tmp, name.split()[0].replace(",", "") + ".ngc")
        with open(p, "w") as fh:
            fh.write("\n".join(text) + "\n")
        j = run(p, a)
        t = j.get("cycle_time_s", float("nan"))
        print(f"| {name} | {t:.3f} | {n * length / t:.2f} | {j.get('max_path_speed', float('nan')):.2f} |",
              flush=True)
        if name == "G2 circle" and os.path.exists(BIN):
            rep = p + ".json"
            subprocess.run([BIN, "-q", "plan", p, "--feed", str(a.vel), "--acc", str(a.acc),
                            "--report", rep], check=True)
            with open(rep) as fh:
                plan = json.load(fh)["plan"]
            t = plan["cycle_time_s"]
            print(f"| G2 circle, ncsmooth plan (per-axis {a.acc}) | {t:.3f} "
                  f"| {n * length / t:.2f} | - |", flush=True)


def plan_time(prog, a):
    """ncsmooth's own cycle time for a program at the same limits, or None without the binary."""
    if not os.path.exists(BIN):
        return None
    rep = prog + ".json"
    subprocess.run([BIN, "-q", "plan", prog, "--method", "bspline", "--tol", "0.01",
                    "--feed", str(a.vel), "--acc", str(a.acc), "--report", rep], check=True)
    with open(rep) as fh:
        return json.load(fh)["plan"]["cycle_time_s"]


def tangential(a, f, tmp):
    """Start and stop on a 10 mm stretch of a 100 mm radius curve, three ways."""
    radius, length, n = 100.0, 10.0, 100
    sweep = length / radius
    # The arc runs clockwise from (0, 0) around the centre (0, -radius).
    def at(t):
        return radius * math.sin(t), radius * math.cos(t) - radius
    ex, ey = at(sweep)
    # One move from rest to rest runs in exact-stop mode (G61): under G64 a lone segment
    # keeps a parabolic end condition, which halves its acceleration once more (tc.c
    # tcGetOverallMaxAccel).
    stop = ["G21 G90 G17 G61", "G0 X0 Y0", f"G1 F{f}"]
    blend = ["G21 G90 G17 G64 P0.001 Q0", "G0 X0 Y0", f"G1 F{f}"]
    progs = {
        "G2 arc, G61": stop + [f"G2 X{ex:.6f} Y{ey:.6f} I0 J{-radius}"],
        "100-line arc, G64 P0.001": blend + [
            "X{:.6f} Y{:.6f}".format(*at(sweep * k / n)) for k in range(1, n + 1)],
        "straight control, G61": stop + [f"X{length:.6f} Y0"],
    }
    t_ideal = 2 * math.sqrt(length / a.acc) if a.vel ** 2 / a.acc >= length else \
        length / a.vel + a.vel / a.acc
    t_half = 2 * math.sqrt(length / (a.acc / 2)) if a.vel ** 2 / (a.acc / 2) >= length else \
        length / a.vel + a.vel / (a.acc / 2)
    print(f"V {a.vel} mm/s, A {a.acc} mm/s^2: {length} mm of a {radius} mm radius, rest to rest")
    print(f"time with A along the path: {t_ideal:.3f} s; with A/2: {t_half:.3f} s\n")
    print("| program | LinuxCNC cycle s | ncsmooth plan s |")
    print("|---|---|---|")
    for name, text in progs.items():
        p = os.path.join(tmp, name.split()[0].replace(",", "").replace("-", "_") + ".ngc")
        with open(p, "w") as fh:
            fh.write("\n".join(text + ["M2"]) + "\n")
        t = run(p, a).get("cycle_time_s", float("nan"))
        ours = plan_time(p, a)
        ours = "-" if ours is None else f"{ours:.3f}"
        print(f"| {name} | {t:.3f} | {ours} |", flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""How far LinuxCNC's blend arcs pass from lone corners, against their `G64 P` (dev script,
not CI). It backs `ncsmooth_gcode::executed::LINUXCNC_BLEND_EXCESS_SHARE`.

    scripts/linuxcnc_corner_excess.py [--p 0.00971] [--vel 50] [--acc 500]

Writes a zig-zag of 20 mm lines whose corners turn by 15 to 150 degrees under
`G64 P<p> Q0`, runs it through `linuxcnc_run.py --csv` (LinuxCNC's real planner, needs
linuxcnc-uspace) and prints, for every corner, the distance from the corner to the
sampled path (samples joined by straight chords, split 20 times) and its ratio to P.
Measured (LinuxCNC 2.9, P 0.00971 mm, 50 mm/s, 500 mm/s^2): 1.003 to 1.013 P.
"""
import argparse
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.environ.get("NCSMOOTH_SHARED", os.path.join(HERE, "..", "..", "shared"))
LEG_MM = 20.0
TURNS_DEG = [15, 30, 45, 60, 90, 120, 150, 34.33]
SPLITS = 20


def program(p_mm):
    """The zig-zag and its corners with their turns (the first line runs along +X)."""
    lines = ["G21 G90 G17", f"G64 P{p_mm} Q0", "G0 X0 Y0", f"G1 X{LEG_MM} Y0 F3000"]
    x, y, heading, sign = LEG_MM, 0.0, 0.0, 1
    corners = []
    for t in TURNS_DEG:
        new = heading + sign * math.radians(t)
        corners.append(((x, y), math.degrees(abs(new - heading))))
        heading, sign = new, -sign
        x += LEG_MM * math.cos(heading)
        y += LEG_MM * math.sin(heading)
        lines.append(f"G1 X{x:.4f} Y{y:.4f}")
    lines.append("M2")
    return "\n".join(lines) + "\n", corners


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--p", type=float, default=0.00971)
    ap.add_argument("--vel", type=float, default=50.0)
    ap.add_argument("--acc", type=float, default=500.0)
    a = ap.parse_args()
    text, corners = program(a.p)
    with tempfile.TemporaryDirectory() as d:
        ngc, csv = os.path.join(d, "corners.ngc"), os.path.join(d, "corners.csv")
        with open(ngc, "w") as f:
            f.write(text)
        subprocess.run([sys.executable, os.path.join(SHARED, "tools", "linuxcnc_run.py"), ngc,
                        "--vel", str(a.vel), "--acc", str(a.acc), "--csv", csv],
                       check=True, stdout=subprocess.DEVNULL)
        s = np.genfromtxt(csv, delimiter=",", names=True)
    pts = np.c_[s["x"], s["y"]]
    t = np.linspace(0.0, 1.0, SPLITS + 1)[:-1]
    dense = (pts[:-1, None, :] * (1 - t)[None, :, None]
             + pts[1:, None, :] * t[None, :, None]).reshape(-1, 2)
    print("turn_deg  corner               distance_mm  ratio_to_P")
    for (x, y), turn in corners:
        dist = np.min(np.linalg.norm(dense - np.array([x, y]), axis=1))
        print(f"{turn:8.2f}  ({x:8.4f}, {y:8.4f})  {dist:.6f}     {dist / a.p:.4f}")


if __name__ == "__main__":
    main()

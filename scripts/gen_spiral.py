#!/usr/bin/env python3
"""Writes a micro-segment spiral G-code program (dev script, for memory and speed runs).

    scripts/gen_spiral.py OUT.ngc [--lines 5000000] [--seg 0.01] [--r0 5] [--pitch 0.6]

An Archimedean spiral (radius r0 + pitch * turns) cut into G1 lines of `seg` mm, at F3000,
in G21 G90 XY: the shape of CAM finishing passes, with no corner and no stop, so a smoothing
method fits it as long runs and a planner never rests.
"""
import argparse
import math


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--lines", type=int, default=5_000_000)
    ap.add_argument("--seg", type=float, default=0.01)
    ap.add_argument("--r0", type=float, default=5.0)
    ap.add_argument("--pitch", type=float, default=0.6)
    a = ap.parse_args()
    b = a.pitch / (2 * math.pi)
    theta = 0.0
    with open(a.out, "w") as f:
        f.write("G21 G90 G17\nG0 X%.4f Y0\nG1 F3000\n" % a.r0)
        for _ in range(a.lines):
            r = a.r0 + b * theta
            # Arc length per radian is about r: step the angle by seg / r.
            theta += a.seg / r
            r = a.r0 + b * theta
            f.write("X%.4f Y%.4f\n" % (r * math.cos(theta), r * math.sin(theta)))
        f.write("M2\n")


if __name__ == "__main__":
    main()

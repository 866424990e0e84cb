#!/usr/bin/env python3
"""Writes laser programs the way LightBurn and svg2gcode do, with the power on every
block, for the laser figures of `docs/benchmarks/` (grbl's laser mode, `$32=1`).

    scripts/gen_laser.py OUT.gcode --kind vector|raster|relative

* `vector`: svg2gcode-like: six circles flattened into 36 chords each and a wave of 140
  chords, `G1 X.. Y.. S<power>` on every block, one power per path (the wave's power steps
  every ten blocks, a gradient), `G0 ... S0` between paths, M4 dynamic power.
* `raster`: a grey-scale fill, 40 rows 0.2 mm apart, back and forth, a power per 0.5 mm
  pixel (rounded to steps of 100, so runs of one power are common), as LightBurn's
  "Fill" writes it.
* `relative`: LightBurn's "current position" start: `G91` throughout from wherever the
  head is, the vector drawing's circles, power on every block, `G90` and an absolute
  finish move at the end.
"""
import argparse
import math


def circles():
    for c in range(6):
        cx, cy, r = 20 + 35 * (c % 3), 20 + 35 * (c // 3), 12 + c
        yield [(cx + r * math.cos(2 * math.pi * k / 36), cy + r * math.sin(2 * math.pi * k / 36))
               for k in range(37)], 300 + 100 * c


def vector():
    out = ["G21", "G90", "M4 S0"]
    for pts, s in circles():
        out.append(f"G0 X{pts[0][0]:.3f} Y{pts[0][1]:.3f} S0")
        for i, (x, y) in enumerate(pts[1:]):
            out.append(f"G1 X{x:.3f} Y{y:.3f} S{s}" + (" F6000" if i == 0 else ""))
    pts = [(x * 0.8, 90 + 5 * math.sin(x * 0.4)) for x in range(140)]
    out.append(f"G0 X{pts[0][0]:.3f} Y{pts[0][1]:.3f} S0")
    for i, (x, y) in enumerate(pts[1:]):
        out.append(f"G1 X{x:.3f} Y{y:.3f} S{200 + (i // 10) * 50}" + (" F6000" if i == 0 else ""))
    return out + ["M5 S0", "M2"]


def raster():
    out = ["G21", "G90", "M4 S0", "G0 X0 Y0 S0"]
    for row in range(40):
        y = row * 0.2
        xs = range(0, 101) if row % 2 == 0 else range(100, -1, -1)
        if row:
            out.append(f"G0 Y{y:.2f} S0")
        for x in xs:
            s = int(500 + 400 * math.sin(x / 7.0 + row / 5)) // 100 * 100
            out.append(f"G1 X{x * 0.5:.2f} S{s} F3000")
    return out + ["M5 S0", "M2"]


def relative():
    out = ["G00 G17 G40 G21 G54", "G91", "M4"]
    at = (0.0, 0.0)
    for pts, s in circles():
        out.append(f"G0X{pts[0][0] - at[0]:.3f}Y{pts[0][1] - at[1]:.3f}")
        prev = pts[0]
        for i, p in enumerate(pts[1:]):
            out.append(f"G1X{p[0] - prev[0]:.3f}Y{p[1] - prev[1]:.3f}S{s}" + ("F6000" if i == 0 else ""))
            prev = p
        at = prev
    return out + ["G1S0", "M5", "G90", "G0 X0 Y0", "M2"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--kind", choices=["vector", "raster", "relative"], default="vector")
    a = ap.parse_args()
    lines = {"vector": vector, "raster": raster, "relative": relative}[a.kind]()
    open(a.out, "w").write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()

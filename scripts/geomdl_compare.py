#!/usr/bin/env python3
"""Compare ncsmooth's global cubic interpolation with geomdl's.

Dev script, not a project dependency: `pip install geomdl`, then from the repository root
    python3 scripts/geomdl_compare.py [--big N]
It builds `cargo build --release --example interp_dump`, then for the butterfly_1000
vertices (../shared/data/profiles/butterfly_1000.ngc, skipped when absent) and for random
point sets it checks that our control points and knots equal those of
`geomdl.fitting.interpolate_curve(points, 3)` to 1e-9 and reports the speed ratio
(geomdl time / ours, best of several runs each), which must be at least 100 on 1000
points. It also times ours alone on 100,000 random points (`--big N` for another size),
where geomdl's dense solve cannot go. Exit status 1 on any mismatch or a slow ratio.
geomdl has no end-tangent interpolation (NURBS Book 9.2.2), which `--method nurbs` uses
by default; that path is checked by the crate's own tests (tangents and interpolation
residuals), not here.
"""
import json
import math
import os
import random
import re
import subprocess
import sys
import tempfile
import time

from geomdl import fitting

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# ../shared beside the repository, as the tests and the other scripts expect it.
BUTTERFLY = os.path.join(ROOT, "..", "shared", "data", "profiles", "butterfly_1000.ngc")
EXE = os.path.join(ROOT, "target", "release", "examples", "interp_dump")
TOL = 1e-9
MIN_RATIO_AT_1000 = 100.0


def gcode_vertices(path):
    """Endpoints of G0/G1 moves (absolute XYZ, modal), minimal reader for the profile files."""
    pos = [0.0, 0.0, 0.0]
    pts = []
    for line in open(path):
        line = re.sub(r"\(.*?\)|;.*", "", line).upper()
        words = dict((w[0], float(w[1:])) for w in re.findall(r"[A-Z][-+.0-9]+", line))
        if "X" in words or "Y" in words or "Z" in words:
            for i, a in enumerate("XYZ"):
                if a in words:
                    pos[i] = words[a]
            pts.append(tuple(pos))
    return pts


def ours(points, reps):
    with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
        for p in points:
            f.write("%r %r %r\n" % p)
        name = f.name
    try:
        out = subprocess.run([EXE, name, "--reps", str(reps)], check=True, capture_output=True, text=True)
    finally:
        os.unlink(name)
    return json.loads(out.stdout)


def theirs(points, reps):
    best, curve = math.inf, None
    for _ in range(reps):
        t = time.perf_counter()
        curve = fitting.interpolate_curve([list(p) for p in points], 3)
        best = min(best, time.perf_counter() - t)
    return curve, best


def compare(name, points, reps_theirs=1):
    o = ours(points, 20)
    c, t = theirs(points, reps_theirs)
    dc = max(max(abs(a - b) for a, b in zip(p, q)) for p, q in zip(o["ctrl"], c.ctrlpts))
    dk = max(abs(a - b) for a, b in zip(o["knots"], c.knotvector))
    ok = len(o["ctrl"]) == len(c.ctrlpts) and len(o["knots"]) == len(c.knotvector) and dc <= TOL and dk <= TOL
    ratio = t / o["seconds"]
    fast = len(points) < 1000 or ratio >= MIN_RATIO_AT_1000
    print("%-22s n=%6d  max|ctrl diff|=%.3e mm  max|knot diff|=%.3e  ours %.3e s  geomdl %.3e s  ratio %.0fx  %s"
          % (name, len(points), dc, dk, o["seconds"], t, ratio,
             ("OK" if fast else "SLOW") if ok else "MISMATCH"))
    return ok and fast


def random_points(n, rng):
    p = [0.0, 0.0, 0.0]
    pts = []
    for _ in range(n):
        p = [p[0] + 0.1 + rng.random(), p[1] + rng.random() - 0.5, p[2] + 0.3 * (rng.random() - 0.5)]
        pts.append(tuple(p))
    return pts


def main():
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "ncsmooth", "--example", "interp_dump"],
                   cwd=ROOT, check=True)
    rng = random.Random(20240521)
    ok = True
    if os.path.exists(BUTTERFLY):
        ok &= compare("butterfly_1000", gcode_vertices(BUTTERFLY))
    else:
        print("butterfly_1000.ngc absent: skipped")
    for n in (4, 5, 10, 50, 200, 1000):
        ok &= compare("random", random_points(n, rng), 3 if n <= 200 else 1)
    n = int(sys.argv[sys.argv.index("--big") + 1]) if "--big" in sys.argv else 100_000
    o = ours(random_points(n, rng), 3)
    print("ours alone            n=%6d  %.3e s  (%.2e points/s)" % (n, o["seconds"], n / o["seconds"]))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()

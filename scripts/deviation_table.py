#!/usr/bin/env python3
"""Worst measured deviation / tol of every smoothing method on every shared file.

Dev script: from the repository root,
    python3 scripts/deviation_table.py [--tol MM] [--methods bspline,arc,nurbs,trig]
It builds the release binary, runs `ncsmooth smooth FILE --method M --tol MM` on every file
of ../shared/data/profiles and ../shared/data/gcode (the written G-code is read back and
measured by the tool itself; a violation exits 1), and prints a Markdown table of the
reported two-sided deviation / tol, corners smoothed and stopped, arc joints blended and
the wall time of each run, then the worst ratio per method. Exit status 1 when any run
fails or any ratio exceeds 1.
"""
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")
EXE = os.path.join(ROOT, "target", "release", "ncsmooth")


def arg(name, default):
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


def files():
    out = []
    for sub in ("profiles", "gcode"):
        d = os.path.join(DATA, sub)
        for f in sorted(os.listdir(d)):
            if f.endswith((".ngc", ".nc", ".gcode")):
                out.append(os.path.join(d, f))
    return out


def run(path, method, tol, tmp):
    out, rep = os.path.join(tmp, "out.ngc"), os.path.join(tmp, "r.json")
    t = time.perf_counter()
    p = subprocess.run([EXE, "smooth", path, "--method", method, "--tol", str(tol), "-o", out,
                        "--report", rep, "--quiet"], capture_output=True, text=True)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        return None, wall, p.stderr.strip()
    r = json.load(open(rep))
    return r, wall, ""


def main():
    if not os.path.isdir(DATA):
        print("SKIP: %s not found" % DATA)
        return
    tol = float(arg("--tol", "0.01"))
    methods = arg("--methods", "bspline,arc,nurbs,trig").split(",")
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "ncsmooth-cli"], cwd=ROOT, check=True)
    ok = True
    worst = {m: 0.0 for m in methods}
    print("| file | method | deviation / tol | smoothed | stopped | arc joints blended | s |")
    print("|---|---|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for path in files():
            for m in methods:
                r, wall, err = run(path, m, tol, tmp)
                name = os.path.basename(path)
                if r is None:
                    ok = False
                    print("| %s | %s | FAILED: %s | | | | %.2f |" % (name, m, err, wall))
                    continue
                d = r["deviation"]
                ratio = max(d["output_to_programmed_mm"], d["vertex_to_output_mm"]) / tol
                worst[m] = max(worst[m], ratio)
                ok &= ratio <= 1.0
                s = r["smoothing"]
                print("| %s | %s | %.4f | %d | %d | %d | %.2f |" % (
                    name, m, ratio, s["corners_smoothed"], s["corners_stopped"],
                    s["arc_joints_blended"], wall))
    for m in methods:
        print("worst deviation / tol, %s: %.4f" % (m, worst[m]))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()

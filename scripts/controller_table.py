#!/usr/bin/env python3
"""Cycle time of smoothed G-code on the controllers' own planners (dev script, not CI).

    [NCSMOOTH_BIN=...] scripts/controller_table.py [--tol 0.01] [--feed 50] [--acc 500] [--no-linuxcnc]
                                [--methods bspline,arc,nurbs,trig] [--emit lines,native]
                                [--input-p P] [--input-q Q] [FILE ...]

For every file (default: butterfly_1000, crown and three micro-segment files of
../shared/data/gcode) it runs

  * the input on LinuxCNC's trajectory planner with `G64 P<tol>` (linuxcnc_run.py --p; Q
    defaults to P as in LinuxCNC, so its executed path can leave tol by up to Q: give
    `--input-p/--input-q` for a baseline within tol, e.g. 0.0093 on butterfly_1000) and
    on grbl 1.1h (grbl_run.py, junction deviation $11 = tol);
  * `ncsmooth smooth --method M --emit E --dialect linuxcnc --acc A --feed F` on LinuxCNC
    (the program carries its own G64 P Q, per block from the harness's limits; `--one-p`
    for one P per run) with `--ref` the input, so the executed deviation is measured;
  * `ncsmooth smooth --method M --emit E --dialect grbl` on grbl;

and prints one Markdown table: blocks in and out, the shortest block, cycle times and their
ratio to the input's on the same controller, the executed deviation on LinuxCNC, grbl
errors and the shortest block grbl executed (4 steps at its 250 steps/mm are 0.016 mm). LinuxCNC runs in real time (cycle time + ~5 s per run, one at a time).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARED = os.environ.get("NCSMOOTH_SHARED", os.path.join(ROOT, "..", "shared"))
TOOLS = os.path.join(SHARED, "tools")
DEFAULT_FILES = [
    "data/profiles/butterfly_1000.ngc",
    "data/profiles/crown.ngc",
    "data/gcode/linuxcnc_blur_torus.ngc",
    "data/gcode/camotics_vcarve.ngc",
    "data/gcode/cncjs_jsdc.gcode",
]
BIN = os.environ.get("NCSMOOTH_BIN", os.path.join(ROOT, "target", "release", "ncsmooth"))


def last_json(out):
    for line in reversed(out.strip().splitlines()):
        line = line.strip()
        if line.startswith("{"):
            return json.loads(line)
    return {}


def linuxcnc(prog, a, ref=None, p=None, q=None):
    cmd = [sys.executable, os.path.join(TOOLS, "linuxcnc_run.py"), prog,
           "--vel", str(a.feed), "--acc", str(a.acc)]
    if p is not None:
        cmd += ["--p", str(p)]
    if q is not None:
        cmd += ["--q", str(q)]
    if ref:
        cmd += ["--ref", ref]
    r = subprocess.run(cmd, capture_output=True, text=True)
    return last_json(r.stdout)


def grbl(prog, a):
    cmd = [sys.executable, os.path.join(TOOLS, "grbl_run.py"), prog,
           "--feed", str(a.feed), "--acc", str(a.acc), "--dev", str(a.tol)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    return last_json(r.stdout)


def smooth(src, out, method, emit, dialect, a):
    rep = out + ".json"
    cmd = [BIN, "-q", "smooth", src, "--method", method, "--emit", emit,
           "--dialect", dialect, "--tol", str(a.tol), "-o", out, "--report", rep]
    if dialect == "linuxcnc" and not a.one_p:
        # The harness's limits: per-block G64 P for LinuxCNC's blending.
        cmd += ["--acc", str(a.acc), "--feed", str(a.feed)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        return None
    with open(rep) as f:
        return json.load(f)


G64_WORD = re.compile(r"G0*64(?![0-9.])([^(;\r\n]*)", re.IGNORECASE)


def with_blending_at(src, tol_mm, q_mm, tmp):
    """The input as the baseline runs it: `G64 P<tol> Q<q>` (LinuxCNC's Q defaults to P).

    A program that sets its own `G64` (camotics_vcarve: `G64 P0.001` in inches, 0.0254 mm)
    would override the prepended one; its own are set to the same bound, in its units.
    Returns (path, note) - the source itself when it sets no G64.
    """
    with open(src, newline="") as f:
        text = f.read()
    if not G64_WORD.search(text):
        return src, ""
    inch = re.search(r"G0*20(?![0-9.])", text, re.IGNORECASE) is not None
    tol = tol_mm / 25.4 if inch else tol_mm
    q = q_mm / 25.4 if inch else q_mm
    own = sorted(set(m.group(0).strip() for m in G64_WORD.finditer(text)))
    fixed = G64_WORD.sub(lambda m: f"G64 P{tol:.7f} Q{q:.7f}", text)
    out = os.path.join(tmp, os.path.basename(src) + ".g64.ngc")
    with open(out, "w", newline="") as f:
        f.write(fixed)
    return out, f"its own {', '.join(own)} set to P{tol:.7f} Q{q:.7f}{' in' if inch else ''}"


def ratio(x, base):
    if not x or not base:
        return "-"
    return f"{x:.3f} ({x / base:.3f})"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="*")
    ap.add_argument("--tol", type=float, default=0.01)
    ap.add_argument("--feed", type=float, default=50.0)
    ap.add_argument("--acc", type=float, default=500.0)
    ap.add_argument("--methods", default="bspline,arc,nurbs,trig")
    ap.add_argument("--emit", default="lines")
    ap.add_argument("--no-linuxcnc", action="store_true")
    ap.add_argument("--one-p", action="store_true",
                    help="LinuxCNC output with one G64 P per run (without smooth --acc/--feed, "
                         "which the harness's limits give by default)")
    ap.add_argument("--input-p", type=float, default=None,
                    help="G64 P (mm) of the input's LinuxCNC run [default: --tol]")
    ap.add_argument("--input-q", type=float, default=None,
                    help="G64 Q (mm) of the input's LinuxCNC run [default: P, LinuxCNC's own "
                         "default; at Q = P = tol the input's executed path can leave tol: "
                         "LinuxCNC merges within Q, then blends within P]")
    a = ap.parse_args()
    files = a.files or [os.path.join(SHARED, f) for f in DEFAULT_FILES]
    if not os.path.exists(BIN):
        sys.exit("build first: cargo build --release")
    tmp = tempfile.mkdtemp(prefix="ncsmooth-controllers-")
    print(f"tol {a.tol} mm, feed {a.feed} mm/s, acc {a.acc} mm/s^2\n")
    print("| file | method | emit | blocks in -> out | min block mm | LinuxCNC s (x input) "
          "| executed dev mm | grbl s (x input) | grbl errors | grbl min block mm |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for src in files:
        name = os.path.basename(src)
        p_in = a.tol if a.input_p is None else a.input_p
        q_in = p_in if a.input_q is None else a.input_q
        base, note = with_blending_at(src, p_in, q_in, tmp)
        if note:
            print(f"({name}: the input runs with {note})")
        lc_in = {} if a.no_linuxcnc else linuxcnc(base, a, ref=src, p=p_in, q=q_in)
        gr_in = grbl(src, a)
        lc_t, gr_t = lc_in.get("cycle_time_s"), gr_in.get("cycle_time_s")
        dev_in = max(lc_in.get("dev_path_to_ref_max_mm", 0), lc_in.get("dev_ref_to_path_max_mm", 0))
        print(f"| {name} | input | G64 P{p_in} Q{q_in} | - | - | {ratio(lc_t, lc_t)} | {dev_in:.5f} "
              f"| {ratio(gr_t, gr_t)} | {gr_in.get('n_errors', '-')} "
              f"| {gr_in.get('min_block_mm', '-')} |", flush=True)
        for method in a.methods.split(","):
            for emit in a.emit.split(","):
                lc_prog = os.path.join(tmp, f"{name}.{method}.{emit}.lc.ngc")
                gr_prog = os.path.join(tmp, f"{name}.{method}.{emit}.grbl.ngc")
                rl = smooth(src, lc_prog, method, emit, "linuxcnc", a)
                rg = smooth(src, gr_prog, method, emit, "grbl", a)
                if rl is None or rg is None:
                    print(f"| {name} | {method} | {emit} | smoothing failed | | | | | | |")
                    continue
                b = rl["blocks"]
                lc = {} if a.no_linuxcnc else linuxcnc(lc_prog, a, ref=src)
                gr = grbl(gr_prog, a)
                dev = max(lc.get("dev_path_to_ref_max_mm", 0), lc.get("dev_ref_to_path_max_mm", 0))
                print(f"| {name} | {method} | {emit} | {b['blocks_in']} -> {b['blocks_out']} "
                      f"| {b['min_block_mm']:.4f} | {ratio(lc.get('cycle_time_s'), lc_t)} "
                      f"| {dev:.5f} | {ratio(gr.get('cycle_time_s'), gr_t)} "
                      f"| {gr.get('n_errors', '-')} | {gr.get('min_block_mm', '-')} |",
                      flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/env bash
# Dev check (not CI): smooth every shared G-code file with each method and compare the
# written program with the original through LinuxCNC's own interpreter
# (../shared/tools/canon_check.py, needs rs274 from linuxcnc-uspace, numpy, scipy).
#   scripts/canon_roundtrip.sh [TOL] [METHODS...]
set -u
cd "$(dirname "$0")/.."
tol=${1:-0.01}; shift || true
methods=${*:-none bspline arc nurbs trig}
B=target/release/ncsmooth
out=${OUT:-/tmp/ncsmooth-canon}
mkdir -p "$out"
check_tol=$(python3 -c "print($tol * 1.1)")
for f in ../shared/data/gcode/*.* ../shared/data/profiles/*.ngc ../shared/data/more-gcode/*.ngc; do
  case $f in *.md|*.json) continue;; esac
  n=$(basename "$f")
  for m in $methods; do
    o="$out/$n.$m.ngc"
    t0=$(date +%s.%N)
    if ! $B smooth "$f" --method "$m" --tol "$tol" -o "$o" -q 2>"$o.err"; then
      echo "$n $m: SMOOTH FAILED: $(head -c 300 "$o.err" | tr '\n' ' ')"
      continue
    fi
    t1=$(date +%s.%N)
    timeout 900 python3 ../shared/tools/canon_check.py "$f" "$o" --tol "$check_tol" --json > "$o.json" 2>&1
    rc=$?
    python3 - "$o.json" "$n" "$m" "$rc" "$t0" "$t1" <<'PY'
import json, sys
p, n, m, rc, t0, t1 = sys.argv[1:]
try:
    r = json.load(open(p))
except Exception as e:
    print(f"{n} {m}: canon_check rc={rc} unreadable: {open(p).read()[:300]!r}")
    sys.exit()
print(f"{n} {m}: ok={r.get('ok')} failed={r.get('failed')} dev={r.get('max_dev_mm')} "
      f"vertex={r.get('max_vertex_miss_mm')} events={r.get('n_events')} rapids={r.get('n_rapids')} "
      f"invented={r.get('invented_axes')} smooth_s={float(t1)-float(t0):.2f}")
PY
  done
done

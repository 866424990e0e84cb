#!/usr/bin/env python3
"""Many comparisons by ../shared/tools/canon_check.py in one Python process.

    canon_batch.py CANON_CHECK.py < pairs

Each line of standard input is `ORIGINAL<TAB>PRODUCED<TAB>TOL`; for each, one line of JSON
goes to standard output (flushed): canon_check's own `--json` report, or
`{"ok": false, "error": ...}` when it raised. canon_check is loaded once and its `main` run
per pair, so numpy and scipy are imported once instead of per comparison (most of a small
program's check). Used by the differential test in crates/ncsmooth-cli/tests/linuxcnc.rs.
"""
import contextlib
import importlib.util
import io
import json
import sys


def load(path):
    spec = importlib.util.spec_from_file_location('canon_check', path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def check(mod, original, produced, tol):
    buf = io.StringIO()
    sys.argv = ['canon_check.py', original, produced, '--tol', tol, '--json']
    try:
        with contextlib.redirect_stdout(buf):
            mod.main()
    except SystemExit:
        pass
    except Exception as e:  # a crash of the oracle is a failed comparison, with its cause
        return {'ok': False, 'error': repr(e)}
    try:
        return json.loads(buf.getvalue())
    except ValueError:
        return {'ok': False, 'error': 'no JSON from canon_check: %r' % buf.getvalue()[:300]}


def main():
    mod = load(sys.argv[1])
    for line in sys.stdin:
        parts = line.rstrip('\n').split('\t')
        if len(parts) != 3:
            out = {'ok': False, 'error': 'bad request line %r' % line[:200]}
        else:
            out = check(mod, *parts)
        sys.stdout.write(json.dumps(out) + '\n')
        sys.stdout.flush()


if __name__ == '__main__':
    main()

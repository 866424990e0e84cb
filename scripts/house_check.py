#!/usr/bin/env python3
"""Size check of the source tree: files over a line limit and functions over a length limit,
outside tests. Usage: scripts/house_check.py [--file-max 1200] [--fn-max 150] [--cli-fn-max 80]

A function's length is counted from its `fn` line to its closing brace (brace matching that
skips strings, chars and comments). `#[cfg(test)]` modules, `tests/` directories and files
named tests.rs are left out. Also counts `issue N` references and timing figures (a number
followed by ` s` or `ms`) in comments under src/.
"""
import argparse, pathlib, re, sys

def strip(src):
    """Replace string/char literals and comments with spaces, keeping newlines."""
    out, i, n = [], 0, len(src)
    while i < n:
        c = src[i]
        if src.startswith('//', i):
            j = src.find('\n', i); j = n if j < 0 else j
            out.append(' ' * (j - i)); i = j
        elif src.startswith('/*', i):
            j = src.find('*/', i + 2); j = n if j < 0 else j + 2
            out.append(''.join('\n' if ch == '\n' else ' ' for ch in src[i:j])); i = j
        elif c == 'r' and re.match(r'r#*"', src[i:i+10]) and (i == 0 or not (src[i-1].isalnum() or src[i-1] == '_')):
            m = re.match(r'r(#*)"', src[i:]); end = '"' + m.group(1)
            j = src.find(end, i + len(m.group(0))); j = n if j < 0 else j + len(end)
            out.append(''.join('\n' if ch == '\n' else ' ' for ch in src[i:j])); i = j
        elif c == '"':
            j = i + 1
            while j < n and src[j] != '"':
                j += 2 if src[j] == '\\' else 1
            j += 1
            out.append(''.join('\n' if ch == '\n' else ' ' for ch in src[i:j])); i = j
        elif c == "'":
            m = re.match(r"'(\\.[^']*|[^'\\])'", src[i:i+12])
            if m:
                out.append(' ' * len(m.group(0))); i += len(m.group(0))
            else:
                out.append(c); i += 1
        else:
            out.append(c); i += 1
    return ''.join(out)

def test_ranges(clean):
    """Line ranges of #[cfg(test)] mod blocks."""
    ranges = []
    for m in re.finditer(r'#\[cfg\(test\)\]\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*\{', clean):
        start = clean.count('\n', 0, m.start()) + 1
        depth, j = 1, m.end()
        while j < len(clean) and depth:
            depth += {'{': 1, '}': -1}.get(clean[j], 0); j += 1
        ranges.append((start, clean.count('\n', 0, j) + 1))
    return ranges

def functions(clean):
    for m in re.finditer(r'\bfn\s+(\w+)', clean):
        j = m.end(); depth = 0
        # find the body's opening brace (skip declarations ending in ';')
        while j < len(clean) and clean[j] not in '{;':
            j += 1
        if j >= len(clean) or clean[j] == ';':
            continue
        start = clean.count('\n', 0, m.start()) + 1
        depth, j = 1, j + 1
        while j < len(clean) and depth:
            depth += {'{': 1, '}': -1}.get(clean[j], 0); j += 1
        yield m.group(1), start, clean.count('\n', 0, j) + 1

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--file-max', type=int, default=1200)
    ap.add_argument('--fn-max', type=int, default=150)
    ap.add_argument('--cli-fn-max', type=int, default=80)
    ap.add_argument('root', nargs='?', default='crates')
    a = ap.parse_args()
    bad = 0; cli_lines = 0; issues = 0; timings = 0
    for p in sorted(pathlib.Path(a.root).rglob('*.rs')):
        parts = p.parts
        if 'tests' in parts or 'benches' in parts or 'examples' in parts or p.name == 'tests.rs' or 'target' in parts:
            continue
        src = p.read_text()
        lines = src.count('\n')
        is_cli = 'ncsmooth-cli' in parts and 'src' in parts
        if is_cli:
            cli_lines += lines
        clean = strip(src)
        tr = test_ranges(clean)
        in_test = lambda l: any(s <= l <= e for s, e in tr)
        test_lines = sum(e - s + 1 for s, e in tr)
        if lines - test_lines > a.file_max:
            print(f'FILE {p}: {lines - test_lines} lines outside tests'); bad += 1
        limit = a.cli_fn_max if is_cli else a.fn_max
        for name, s, e in functions(clean):
            if in_test(s):
                continue
            if e - s + 1 > limit:
                print(f'FN   {p}:{s} {name}: {e - s + 1} lines (limit {limit})'); bad += 1
        if 'src' in parts:
            for ln, line in enumerate(src.splitlines(), 1):
                if in_test(ln):
                    continue
                k = line.find('//')
                if k < 0:
                    continue
                com = line[k:]
                if re.search(r'\bissue\s+#?\d+', com, re.I):
                    print(f'ISSUE {p}:{ln}: {com.strip()}'); issues += 1
                if re.search(r'\d(\.\d+)?\s?(ms|s)\b(?![a-z])', com) and not re.search(r'mm/s|/s\b', com):
                    timings += 1
                    print(f'TIME {p}:{ln}: {com.strip()[:100]}')
    print(f'cli src lines: {cli_lines}; over-limit items: {bad}; issue refs: {issues}; timing comments: {timings}')
    return 1 if bad else 0

sys.exit(main())

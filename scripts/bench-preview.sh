#!/usr/bin/env bash
# `gantry preview` against LinuxCNC's `rs274 -g` on the same long program (the
# PNG preview in at most 2x rs274's CPU time). Not run in CI (needs rs274: apt-get install
# linuxcnc-uspace); host-sender/benches/preview.rs is the CI-side benchmark.
#
#   scripts/bench-preview.sh [LINES]      (default 1000000)
#   GANTRY (default target/release/gantry), RS274 (default rs274)
#
# Writes a program of LINES lines (rows of short G1 zig-zags over a wavy Z, a G2/G3 arc pair
# every 50 lines, a rapid between rows) to a temporary directory, then runs each tool once and
# takes its CPU time (user + sys, /usr/bin/time). Last line, exactly:
#   preview_cpu_s png=P svg=S rs274=R png_ratio=P/R svg_ratio=S/R lines=LINES
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
lines=${1:-1000000}
gantry=${GANTRY:-$here/target/release/gantry}
rs274=${RS274:-rs274}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

python3 - "$lines" > "$tmp/big.ngc" <<'PY'
import sys
lines = int(sys.argv[1])
w = sys.stdout.write
w("(bench-preview)\nG21 G90 G17 G94\nG0 Z5\nG0 X0 Y0\nG1 Z-1 F3000\n")
n, row = 5, 0
while n < lines - 2:
    y = (row % 400) * 0.25
    w(f"G0 Z2\nG0 X0 Y{y:.3f}\nG1 Z-1\n")
    n += 3
    x = 0.0
    for i in range(1, 500):
        if n >= lines - 2:
            break
        if i % 50 == 0:
            # A small arc pair (a bump), back on the row.
            w(f"G2 X{x + 0.4:.3f} Y{y:.3f} I0.2 J0\nG3 X{x + 0.8:.3f} Y{y:.3f} I0.2 J0\n")
            x += 0.8
            n += 2
            continue
        x += 0.2
        z = -1.0 + 0.4 * (abs((i % 200) - 100) / 50.0 - 1.0)
        w(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f}\n")
        n += 1
    row += 1
w("G0 Z5\nM30\n")
PY

cpu() { # command... → user+sys seconds
    /usr/bin/time -f "%U %S" -o "$tmp/t" "$@" > /dev/null 2> "$tmp/err" || true
    awk '{printf "%.2f", $1 + $2}' "$tmp/t"
}
png=$(cpu "$gantry" preview "$tmp/big.ngc" -o "$tmp/out.png")
svg=$(cpu "$gantry" preview "$tmp/big.ngc" -o "$tmp/out.svg")
rs=$(cpu "$rs274" -g "$tmp/big.ngc")
[ -s "$tmp/out.png" ] || { echo "bench-preview: no PNG written" >&2; exit 1; }
echo "program: $(wc -l < "$tmp/big.ngc") lines; $(ls -l "$tmp/out.png" | awk '{print $5}') B PNG"
awk -v p="$png" -v s="$svg" -v r="$rs" -v n="$lines" 'BEGIN {
    printf "preview_cpu_s png=%s svg=%s rs274=%s png_ratio=%.2f svg_ratio=%.2f lines=%s\n", p, s, r, p / r, s / r, n }'

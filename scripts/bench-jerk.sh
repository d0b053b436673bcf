#!/usr/bin/env bash
# Planned time with jerk limiting against the trapezoid: `gantry simulate` over generated CAM
# programs (scripts/gen-cam-program.py at 0.2, 0.05 and 0.03 mm segments, a 0.03 mm circle
# contour) and any programs given as arguments, on the default axes (200 mm/s², 3000 mm/min)
# with `jerk = 0` and with `jerk = J` (default 5000 mm/s³) on every axis. Prints one line per
# program (trapezoid s, jerk-limited s, ratio) and, last, the geometric mean of the ratios.
#
# usage: scripts/bench-jerk.sh [-j MM_PER_S3] [PROGRAM ...]
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
J=5000
if [ "${1:-}" = "-j" ]; then J=$2; shift 2; fi
cargo build -q --release -p host-sender --bin gantry
G=$PWD/target/release/gantry
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
"$G" setup show --defaults >"$T/trapezoid.toml"
sed "s/^jerk = 0.0 /jerk = $J.0/" "$T/trapezoid.toml" >"$T/jerk.toml"
grep -q "^jerk = $J.0" "$T/jerk.toml"
python3 scripts/gen-cam-program.py 4000 0.2 >"$T/cam_0.2mm.nc"
python3 scripts/gen-cam-program.py 4000 0.05 >"$T/cam_0.05mm.nc"
python3 scripts/gen-cam-program.py 4000 0.03 >"$T/cam_0.03mm.nc"
python3 - >"$T/contour_0.03mm.nc" <<'PY'
import math
# A 20 mm circle in 0.03 mm chords at F3000, twice round, from rest to rest.
r, n = 20.0, int(2 * math.pi * 20.0 / 0.03)
print("G21 G90 G94\nG0 X20 Y0\nG1 F3000")
for k in range(1, 2 * n + 1):
    a = 2 * math.pi * k / n
    print(f"G1 X{r * math.cos(a):.4f} Y{r * math.sin(a):.4f}")
print("M2")
PY
total() { "$G" simulate --setup "$1" "$2" 2>/dev/null | sed -n 's/^total time: \([0-9.]*\) s$/\1/p' | tail -n 1; }
ratios=()
for p in "$T"/*.nc "$@"; do
    a=$(total "$T/trapezoid.toml" "$p" || true)
    b=$(total "$T/jerk.toml" "$p" || true)
    if [ -z "$a" ] || [ -z "$b" ]; then
        echo "$(basename "$p"): not planned (an error in the program or the setup)"
        continue
    fi
    r=$(python3 -c "print(f'{$b / $a:.4f}')")
    printf '%-40s trapezoid %10.3f s  jerk %10.3f s  %sx\n' "$(basename "$p")" "$a" "$b" "$r"
    ratios+=("$r")
done
python3 -c "
import math, sys
r = [float(x) for x in sys.argv[1:]]
print(f'jerk {$J} mm/s3: {len(r)} programs, geomean {math.exp(sum(map(math.log, r)) / len(r)):.4f}x, max {max(r):.4f}x')
" "${ratios[@]}"

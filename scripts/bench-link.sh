#!/usr/bin/env bash
# Link throughput benchmark (issue 29): streams N short collinear lines over `gantry emulate --pty`
# and prints the job's time against `gantry simulate`'s planned time. Not part of CI (each run takes
# about as long as the program's machine time: ~50 s for the default cases).
#
# Usage: scripts/bench-link.sh [LINES] [CPU_MODEL] [CASE...]
#   LINES      lines per program (default 100000)
#   CPU_MODEL  `none` (default) or `f411`
#   CASE       `STEP_MM:FEED_MM_MIN` (default: 0.05:6000 0.02:12000)
set -euo pipefail
cd "$(dirname "$0")/.."
LINES=${1:-100000}
CPU=${2:-none}
shift $(( $# > 2 ? 2 : $# )) || true
CASES=("$@")
[ ${#CASES[@]} -eq 0 ] && CASES=(0.05:6000 0.02:12000)
cargo build --release -q -p host-sender
G=$PWD/target/release/gantry
WORK=$(mktemp -d)
EMU=
cleanup() { [ -n "$EMU" ] && kill "$EMU" 2>/dev/null; rm -rf "$WORK"; }
trap cleanup EXIT

for case in "${CASES[@]}"; do
  step=${case%%:*}
  feed=${case##*:}
  prog=$WORK/p.ngc
  # Rows of 500 collinear segments along X, back and forth, one Y step between rows.
  python3 - "$LINES" "$step" "$feed" >"$prog" <<'PY'
import sys
n, step, feed = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
print(f"G21 G90 G94 F{feed}")
x, y, d, row = 0.0, 0.0, 1, 0
for i in range(n):
    if row == 500:
        y += 0.1; d = -d; row = 0
        print(f"G1 Y{y:.3f}")
        continue
    x += d * step; row += 1
    print(f"G1 X{x:.3f}")
print("M2")
PY
  planned=$("$G" simulate "$prog" | sed -n 's/^total time: \([0-9.]*\) s$/\1/p')
  pty=$WORK/pty
  args=(emulate --pty "$pty")
  [ "$CPU" != none ] && args+=(--cpu-model "$CPU")
  "$G" "${args[@]}" >"$WORK/emu.log" 2>&1 &
  EMU=$!
  for _ in $(seq 100); do [ -e "$pty" ] && break; sleep 0.05; done
  out=$("$G" stream --no-check --port "$pty" "$prog" 2>&1 | grep -v '^progress:')
  kill "$EMU"; wait "$EMU" 2>/dev/null || true; EMU=
  took=$(echo "$out" | sed -n 's/^time: *\([0-9.]*\) s.*/\1/p')
  under=$(echo "$out" | sed -n 's/^underruns: \([0-9]*\).*/\1/p')
  rate=$(python3 -c "print(round($LINES*$step/($step*60/$feed*$LINES)))" 2>/dev/null || echo ?)
  ratio=$(python3 -c "print(f'{$took/$planned:.4f}')")
  echo "lines $LINES step $step mm F$feed cpu $CPU: planned $planned s, streamed $took s, ratio $ratio, underruns ${under:-?}"
done

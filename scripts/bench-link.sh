#!/usr/bin/env bash
# Link throughput benchmark: streams N short collinear lines over `gantry emulate --pty`
# and prints the job's time against `gantry simulate`'s planned time for the same program and
# setup. Not part of CI: each case takes about as long as the program's machine time (~70 s for
# the two default cases).
#
# Usage: scripts/bench-link.sh [LINES] [CPU_MODEL] [CASE...]
#   LINES      lines per program (default 100000)
#   CPU_MODEL  `none` (default) or `f411`
#   CASE       `STEP_MM:FEED_MM_MIN` (default: 0.05:6000 0.02:12000, i.e. 2 k and 10 k lines/s)
# GANTRY=path/to/gantry benchmarks that binary instead of building this checkout's.
#
# The machine: X and Y at 15 000 mm/min and 10 000 mm/s², so the planner's look-ahead (128 blocks of
# 0.02 mm) allows the programmed feed and the line rate is what the program asks. Rows of 2 000
# segments along X, back and forth, a 0.1 mm Y step between rows.
set -euo pipefail
cd "$(dirname "$0")/.."
LINES=${1:-100000}
CPU=${2:-none}
shift $(( $# > 2 ? 2 : $# )) || true
CASES=("$@")
[ ${#CASES[@]} -eq 0 ] && CASES=(0.05:6000 0.02:12000)
if [ -z "${GANTRY:-}" ]; then
  cargo build --release -q -p host-sender
  GANTRY=$PWD/target/release/gantry
fi
G=$GANTRY
WORK=$(mktemp -d)
cat >"$WORK/setup.toml" <<'TOML'
axes = ["X", "Y", "Z"]
[axis.X]
max_rate = 15000.0
accel = 10000.0
[axis.Y]
max_rate = 15000.0
accel = 10000.0
TOML
EMU=
cleanup() { [ -n "$EMU" ] && kill "$EMU" 2>/dev/null; rm -rf "$WORK"; }
trap cleanup EXIT

for case in "${CASES[@]}"; do
  step=${case%%:*}
  feed=${case##*:}
  prog=$WORK/p.ngc
  # Rows of 2 000 collinear segments along X, back and forth, one Y step between rows.
  python3 - "$LINES" "$step" "$feed" >"$prog" <<'PY'
import sys
n, step, feed = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
print(f"G21 G90 G94 F{feed}")
x, y, d, row = 0.0, 0.0, 1, 0
for i in range(n):
    if row == 2000:
        y += 0.1; d = -d; row = 0
        print(f"G1 Y{y:.3f}")
        continue
    x += d * step; row += 1
    print(f"G1 X{x:.3f}")
print("M2")
PY
  planned=$("$G" simulate --setup "$WORK/setup.toml" "$prog" | sed -n 's/^total time: \([0-9.]*\) s$/\1/p')
  pty=$WORK/pty
  args=(emulate --pty "$pty" --setup "$WORK/setup.toml")
  [ "$CPU" != none ] && args+=(--cpu-model "$CPU")
  "$G" "${args[@]}" >"$WORK/emu.log" 2>&1 &
  EMU=$!
  for _ in $(seq 100); do [ -e "$pty" ] && break; sleep 0.05; done
  out=$("$G" stream --no-check --port "$pty" "$prog" 2>&1 | grep -v '^progress:')
  kill "$EMU"; wait "$EMU" 2>/dev/null || true; EMU=
  took=$(echo "$out" | sed -n 's/^time: *\([0-9.]*\) s.*/\1/p')
  # The board's own count (a pty-attached board's report has none): the emulator's last line.
  under=$(sed -n 's/^emulate: underruns \([0-9]*\)$/\1/p' "$WORK/emu.log" | tail -n 1)
  ratio=$(python3 -c "print(f'{$took/$planned:.4f}')")
  rate=$(python3 -c "print(round($feed / 60 / $step))")
  echo "$LINES lines of $step mm at F$feed ($rate lines/s), cpu model $CPU: planned $planned s, streamed $took s, ratio $ratio, underruns ${under:-?}"
done

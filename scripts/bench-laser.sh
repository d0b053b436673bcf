#!/usr/bin/env bash
# Laser raster benchmark (docs/laser-plasma.md): LightBurn-style rasters, a `G1 X… S…` per pixel
# under M4 with a new S on every pixel (the worst case: nothing for a CAM program to merge),
# against `gantry simulate`'s planned time on the same laser setup, three ways:
#   - the emulated board in-process on its own clock with the F411 CPU model (`gantry stream
#     --cpu-model f411`): does the Cortex-M4 keep up with the line rate;
#   - `gantry stream` over `gantry emulate --pty` (the native protocol, real time);
#   - grbl counting senders over `gantry emulate --pty`, with `$32=1` sent first: pygrbl-streamer
#     (scripts/grbl_sender.py, as scripts/grbl-sender-test.sh installs it), and a one-thread
#     counting sender (scripts/grbl_count.py) that also reports the `ok` round trip, on the
#     emulated board as it is and with the F411 CPU model (`gantry emulate --cpu-model f411`).
# First, once: the `ok` round trip of one line at a time over the pty (scripts/grbl_ping.py: an
# empty line and a `G4 P0`, nothing else in flight), the board's wait for the pass that reads a
# line plus the host's share, without a planner or line buffer in the way.
# The real-time figures need an unloaded machine: the emulator and the sender are ordinary
# processes, and a scheduler that leaves them off the CPU for longer than the planner's
# look-ahead (128 blocks: 128 ms of 0.1 mm pixels at 6,000 mm/min, 38 ms of 0.05 mm at
# 10,000) starves the board; a grbl counting sender slows down already when its `ok` round
# trip passes ~2 ms (docs/laser-plasma.md "Raster speed").
# Not part of CI.
#
# Usage: scripts/bench-laser.sh [ROWS] [CASE...]
#   ROWS  raster rows of 50 mm per program (default 20)
#   CASE  `PIXEL_MM:FEED_MM_MIN` (default 0.1:6000 0.05:10000: 1,000 and 3,300 lines/s)
set -euo pipefail
cd "$(dirname "$0")/.."
ROWS=${1:-20}
shift $(( $# > 1 ? 1 : $# )) || true
CASES=("$@")
[ ${#CASES[@]} -eq 0 ] && CASES=(0.1:6000 0.05:10000)
cargo build --release -q -p host-sender
G=$PWD/target/release/gantry
VENV=target/grbl-sender-venv
WORK=$(mktemp -d)
# A laser machine: X and Y at 12,000 mm/min and 3,000 mm/s², S 0-1000 onto a PWM of 1,000 counts.
cat >"$WORK/setup.toml" <<'TOML'
[axis.X]
max_rate = 12000.0
accel = 3000.0
[axis.Y]
max_rate = 12000.0
accel = 3000.0
[spindle]
laser = true
rpm_range = [0, 1000]
pwm_range = [0, 1000]
TOML
EMU=
cleanup() { [ -n "$EMU" ] && kill "$EMU" 2>/dev/null; rm -rf "$WORK"; }
trap cleanup EXIT

ratio() { python3 -c "print(f'{$1/$2:.4f}')"; }

# grbl_run LABEL EMULATE_ARGS SENDER...: the grbl program ($WORK/grbl.nc) streamed by a counting
# sender over `gantry emulate --pty`; the time is the board's, from the job's start to Idle (its
# state lines carry its clock), against the planned time.
grbl_run() {
  local label=$1 emu_args=$2
  shift 2
  rm -f "$pty"
  # shellcheck disable=SC2086
  "$G" emulate --pty "$pty" --setup "$WORK/setup.toml" --state "$WORK/state-grbl.toml" $emu_args >"$WORK/emu.log" 2>&1 &
  EMU=$!
  for _ in $(seq 100); do [ -e "$pty" ] && break; sleep 0.05; done
  local summary took under
  summary=$("$@" "$pty" "$WORK/grbl.nc" || true)
  sleep 0.3
  kill -INT "$EMU"; wait "$EMU" 2>/dev/null || true; EMU=
  took=$(python3 - "$WORK/emu.log" <<'PY'
import re, sys
t = [(float(m.group(1)), m.group(2)) for m in re.finditer(r"emulate: ([0-9.]+) s (\w+)", open(sys.argv[1]).read())]
run = [s for s, st in t if st == "Run"]
idle = [s for s, st in t if st == "Idle" and run and s > run[0]]
print(f"{idle[-1] - run[0]:.3f}" if run and idle else "nan")
PY
)
  under=$(sed -n 's/^emulate: underruns \([0-9]*\)$/\1/p' "$WORK/emu.log" | tail -n 1)
  echo "grbl, $label: $took s, ratio $(ratio "$took" "$planned"), underruns ${under:-0}; $summary"
}

pty=$WORK/pty
rm -f "$pty"
"$G" emulate --pty "$pty" --setup "$WORK/setup.toml" --state "$WORK/state-ping.toml" >"$WORK/emu.log" 2>&1 &
EMU=$!
for _ in $(seq 100); do [ -e "$pty" ] && break; sleep 0.05; done
echo "== grbl, one line at a time: $(python3 scripts/grbl_ping.py "$pty" 1000 || true)"
kill -INT "$EMU"; wait "$EMU" 2>/dev/null || true; EMU=

for case in "${CASES[@]}"; do
  px=${case%%:*}
  feed=${case##*:}
  prog=$WORK/raster.nc
  python3 - "$px" "$feed" "$ROWS" >"$prog" <<'PY'
import sys
px, feed, rows = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
n = int(round(50 / px))
dec = 2 if px >= 0.1 else 3
print(f"G21 G90 G94\nM4 S0\nG0 X0 Y0\nG1 F{feed}")
k = 0
for r in range(rows):
    fwd = r % 2 == 0
    xs = [i * px for i in range(n + 1)] if fwd else [(n - i) * px for i in range(n + 1)]
    over = 2 if fwd else -2
    print(f"G0 X{xs[0] - over:.{dec}f} Y{r * px:.{dec}f}")
    print(f"G1 X{xs[0]:.{dec}f} S0")
    for x in xs[1:]:
        k += 1
        print(f"G1 X{x:.{dec}f} S{(k * 37) % 1000 + 1}")
    print(f"G1 X{xs[-1] + over:.{dec}f} S0")
print("M5\nM2")
PY
  lines=$(wc -l <"$prog")
  rate=$(python3 -c "print(round($feed / 60 / $px))")
  planned=$("$G" simulate --setup "$WORK/setup.toml" "$prog" | sed -n 's/^total time: \([0-9.]*\) s$/\1/p')
  echo "== $lines lines, $px mm pixels at F$feed ($rate lines/s): planned $planned s"

  out=$("$G" stream --no-check --setup "$WORK/setup.toml" --cpu-model f411 "$prog" 2>&1)
  took=$(echo "$out" | sed -n 's/^time: *\([0-9.]*\) s.*/\1/p')
  under=$(echo "$out" | sed -n 's/^underruns: \([0-9]*\).*/\1/p')
  echo "in-process, F411 CPU model: $took s, ratio $(ratio "$took" "$planned"), underruns $under"

  pty=$WORK/pty
  "$G" emulate --pty "$pty" --setup "$WORK/setup.toml" --state "$WORK/state.toml" >"$WORK/emu.log" 2>&1 &
  EMU=$!
  for _ in $(seq 100); do [ -e "$pty" ] && break; sleep 0.05; done
  out=$("$G" stream --no-check --port "$pty" "$prog" 2>&1 | grep -v '^progress:')
  kill "$EMU"; wait "$EMU" 2>/dev/null || true; EMU=
  took=$(echo "$out" | sed -n 's/^time: *\([0-9.]*\) s.*/\1/p')
  under=$(sed -n 's/^emulate: underruns \([0-9]*\)$/\1/p' "$WORK/emu.log" | tail -n 1)
  echo "gantry stream over the pty: $took s, ratio $(ratio "$took" "$planned"), underruns ${under:-0}"

  printf '$32=1\n' | cat - "$prog" >"$WORK/grbl.nc"
  if "$VENV/bin/python" -c "import pygrbl_streamer" 2>/dev/null; then
    grbl_run "pygrbl-streamer (scripts/grbl_sender.py)" "" "$VENV/bin/python" scripts/grbl_sender.py
  else
    echo "pygrbl-streamer: skipped (run scripts/grbl-sender-test.sh once to install it)"
  fi
  grbl_run "one-thread counting sender (scripts/grbl_count.py)" "" python3 scripts/grbl_count.py
  grbl_run "one-thread counting sender, F411 CPU model" "--cpu-model f411" python3 scripts/grbl_count.py
done

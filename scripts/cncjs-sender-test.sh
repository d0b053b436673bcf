#!/usr/bin/env bash
# Whole-system grbl test with CNCjs (docs/grbl.md "Tested with"): the CNCjs server from npm, used
# as-is, opens `gantry emulate --pty` with its Grbl controller and is driven headless through its
# socket.io API (scripts/cncjs_drive.js) the way its web page drives it. Checks:
# - a program streamed by CNCjs (character counting) gets every line acknowledged, no error, and
#   ends with the step counts of `gantry stream` on the same program and setup;
# - the same program with CNCjs's feed override +10 %, feed hold (Hold:0 at rest, no motion for
#   1 s) and cycle start ends with the same step and pulse counts;
# - `$J=` jogs end on target and CNCjs's jog cancel stops a long jog early;
# - a 2,000-line job with three Pause/Resume cycles (CNCjs keeps its lines in flight across a
#   pause: the board plans them in the hold), eight jog clicks sent at once between two runs of
#   it (X exactly +8 mm), every line CNCjs wrote answered exactly once, and the final steps
#   those of `gantry stream` on the job.
# Installs CNCjs itself (pinned by scripts/cncjs/package-lock.json) under target/; skips, saying
# why, only when node/npm are missing or the npm registry cannot be reached.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  echo "SKIP CNCjs sender test: node/npm not installed"
  exit 0
fi
DIR=target/cncjs
if ! [ -e "$DIR/node_modules/.bin/cncjs" ] || ! cmp -s scripts/cncjs/package-lock.json "$DIR/package-lock.json"; then
  rm -rf "$DIR" && mkdir -p "$DIR"
  cp scripts/cncjs/package.json scripts/cncjs/package-lock.json "$DIR/"
  if ! (cd "$DIR" && npm ci --no-audit --no-fund --loglevel=error > npm.log 2>&1); then
    if ! node -e "require('https').get('https://registry.npmjs.org/', r => process.exit(0)).on('error', () => process.exit(1))"; then
      echo "SKIP CNCjs sender test: the npm registry is unreachable"
      exit 0
    fi
    cat "$DIR/npm.log" >&2
    echo "CNCjs sender test: npm ci failed with the registry up" >&2
    exit 1
  fi
fi
cargo build -q -p host-sender
GANTRY=$PWD/target/debug/gantry
TMP=$(mktemp -d)
EMU= SERVER=
trap 'kill $EMU $SERVER 2>/dev/null || true; rm -rf "$TMP"' EXIT

echo '{}' > "$TMP/cncrc"
PORT=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
"$DIR/node_modules/.bin/cncjs" -H 127.0.0.1 -p "$PORT" -c "$TMP/cncrc" > "$TMP/server.log" 2>&1 &
SERVER=$!
for _ in $(seq 100); do grep -q '"secret"' "$TMP/cncrc" 2>/dev/null && grep -q 'Starting the server' "$TMP/server.log" && break; sleep 0.2; done

# A small program of our own (moves, arcs, relative moves, a dwell), shared by the sender tests.
cp scripts/grbl-small.nc "$TMP/small.nc"
# 2,000 lines: a zig-zag of 0.25 mm segments in absolute coordinates (ends where it ends, whatever
# jog came before it).
python3 - "$TMP/long.nc" <<'PY'
import sys
with open(sys.argv[1], "w") as f:
    f.write("G21 G90\nG1 F3000\n")
    x, y, d = 0, 0, 1
    for i in range(1998):
        if (x == 160 and d == 1) or (x == 0 and d == -1):
            d = -d
            y += 1
            f.write(f"G1 Y{y/4:.2f}\n")
        else:
            x += d
            f.write(f"G1 X{x/4:.2f}\n")
PY
[ "$(wc -l < "$TMP/long.nc")" = 2000 ] || { echo "FAIL: the job is not 2,000 lines"; exit 1; }
ref_steps=$("$GANTRY" stream "$TMP/small.nc" | grep '^steps:' | sed 's/steps: *//; s/  */ /g')
ref_long=$("$GANTRY" stream "$TMP/long.nc" | grep '^steps:' | sed 's/steps: *//; s/  */ /g')
passed=0
declare -A pulses
for scenario in run hold jog pauses; do
  prog=$TMP/small.nc ref=$ref_steps
  [ "$scenario" = pauses ] && prog=$TMP/long.nc ref=$ref_long
  "$GANTRY" emulate --pty "$TMP/pty" 2> "$TMP/emu-$scenario.log" &
  EMU=$!
  for _ in $(seq 50); do [ -e "$TMP/pty" ] && break; sleep 0.1; done
  summary=$(NODE_PATH="$DIR/node_modules" node scripts/cncjs_drive.js "http://127.0.0.1:$PORT" \
    "$TMP/cncrc" "$TMP/pty" "$scenario" "$prog") || {
    echo "FAIL CNCjs $scenario: $summary"; tail -20 "$TMP/emu-$scenario.log"; exit 1; }
  sleep 0.5
  kill -INT $EMU; wait $EMU || true
  EMU=
  echo "CNCjs $scenario: $summary"
  if [ "$scenario" != jog ]; then
    steps=$(grep -o 'Idle line [0-9]* steps [^p]*' "$TMP/emu-$scenario.log" | tail -1 | sed 's/.*steps //; s/ *$//')
    echo "CNCjs $scenario: steps via CNCjs [$steps], via gantry stream [$ref]"
    [ "$steps" = "$ref" ] || { echo "FAIL CNCjs $scenario: step counts differ"; exit 1; }
    pulses[$scenario]=$(grep -o 'Idle line [0-9]* steps .*pulses .*' "$TMP/emu-$scenario.log" | tail -1 | sed 's/.*pulses //')
  fi
  rm -f "$TMP/pty"
  passed=$((passed + 1))
done
# A hold, an override and a cycle start change when the steps come, never which.
echo "CNCjs: pulses without hold [${pulses[run]}], with hold [${pulses[hold]}]"
[ "${pulses[run]}" = "${pulses[hold]}" ] || { echo "FAIL CNCjs hold: pulse counts differ"; exit 1; }
echo "CNCjs sender test: $passed passed, 0 failed"

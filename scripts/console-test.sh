#!/usr/bin/env bash
# The operator's console in a real browser (docs/console.md): Debian's chromium, headless, driven
# by playwright-core (npm, pinned by scripts/console/package-lock.json; it uses the system
# chromium and downloads no browser) against `gantry serve --http` + `gantry emulate --pty`.
# Installs chromium with apt-get when it is missing. Writes the mid-job screenshot to
# docs/console.png (SHOT=... to put it elsewhere).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v chromium >/dev/null; then
  if command -v apt-get >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  fi
fi
if ! command -v chromium >/dev/null || ! command -v npm >/dev/null; then
  echo "SKIP console browser test: chromium or node/npm not installed"
  exit 0
fi
DIR=target/console-test
if ! [ -d "$DIR/node_modules/playwright-core" ] || ! cmp -s scripts/console/package-lock.json "$DIR/package-lock.json"; then
  rm -rf "$DIR" && mkdir -p "$DIR"
  cp scripts/console/package.json scripts/console/package-lock.json "$DIR/"
  (cd "$DIR" && npm ci --no-audit --no-fund --loglevel=error)
fi
cargo build -q -p host-sender --bin gantry
GANTRY=$PWD/target/debug/gantry
TMP=$(mktemp -d)
EMU= SERVE=
stop() {
  local rc=$?
  set +e
  # serve first: a serve whose port vanished keeps trying to reopen it.
  [ -n "$SERVE" ] && kill "$SERVE" 2>/dev/null && for _ in $(seq 30); do kill -0 "$SERVE" 2>/dev/null || break; sleep 0.1; done
  [ -n "$SERVE" ] && kill -9 "$SERVE" 2>/dev/null
  [ -n "$EMU" ] && kill "$EMU" 2>/dev/null
  rm -rf "$TMP"
  exit $rc
}
trap stop EXIT
# The machine: switches at the min ends of X and Y (1 mm beyond the travel, src/emulate.rs), X then
# Y homed with home_position where the switch + pull-off are (machine coordinates keep their
# meaning), the G30 position over the tool setter. It powers up 10 mm from each switch.
"$GANTRY" setup show | python3 -c '
import sys
t = sys.stdin.read()
def sub(a, b):
    global t
    assert a in t, a
    t = t.replace(a, b, 1)
sub("limits_min = []", "limits_min = [\"X\", \"Y\"]")
sub("g30_home = [0.0, 0.0, 0.0]", "g30_home = [275.0, -175.0, 20.0]")
for axis, home, prio in (("X", "-299.0", 1), ("Y", "-199.0", 2)):
    head = "[homing.axis.%s]\n" % axis
    i = t.index(head)
    j = t.index("\n[", i + 1)
    block = t[i:j].replace("priority = 0", "priority = %d" % prio, 1).replace("seek_rate = 2000.0", "seek_rate = 3000.0", 1)
    block = block.replace("home_position = 0.0", "home_position = " + home, 1)
    t = t[:i] + block + t[j:]
open(sys.argv[1], "w").write(t)
' "$TMP/machine.toml"
printf -- '-289000000 -189000000 0\n' > "$TMP/state.toml.position"
# Probe targets for the probing workflows (machine mm): a plate (plane) at Z -5; a block X 200-250,
# Y 100-150 with its top at Z 0 (edges and corners); a round boss of 60 mm at X -100 Y 100; a
# 30 mm bore at X -100 Y -100 (in a ring of 60 mm); the tool setter's top at Z 10, X 270-280,
# Y -180 to -170 (under the G30 position): all away from the programs' paths.
"$GANTRY" emulate --pty "$TMP/tty" --setup "$TMP/machine.toml" --state "$TMP/state.toml" \
  --probe-target plane:-5 --probe-target boss:200,100,250,150,0 \
  --probe-target cylinder:-100,100,60,0 --probe-target ring:-100,-100,30,60,0 \
  --probe-target boss:270,-180,280,-170,10 > "$TMP/emulate.log" 2>&1 &
EMU=$!
for _ in $(seq 50); do [ -e "$TMP/tty" ] && break; sleep 0.1; done
HTTP=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
# The console's library and macros in the test's own data directory, serve's socket and token
# in its own runtime directory (the token is kept there across serve's restarts).
export XDG_DATA_HOME="$TMP/data" XDG_RUNTIME_DIR="$TMP/run"
mkdir -m 700 "$XDG_RUNTIME_DIR"
"$GANTRY" serve --port "$TMP/tty" --http "127.0.0.1:$HTTP" > "$TMP/serve.log" 2>&1 &
SERVE=$!
for _ in $(seq 300); do grep -q "token is also in" "$TMP/serve.log" && break; sleep 0.1; done
# The URL serve printed, with its token (the lock, docs/console.md).
URL=$(sed -n 's/^serve: the console is on //p' "$TMP/serve.log" | head -1)
printf 'G21 G90\nG1 X10 F600\nG1 X5 Q7\nM30\n' > "$TMP/bad.nc"
printf 'G21 G90\nG0 Z5\nT2 M6 (the 3 mm end mill)\nG0 X5 Y5\nG1 Z-1 F300\nG1 X15 F600\nG0 Z5\nM30\n' > "$TMP/tool.nc"
python3 - "$TMP/job.nc" <<'PY'
import math, sys
l = ["G21 G90 G17", "G0 X0 Y0 Z5", "G1 Z-1 F300", "M0 (check the clamp)"]
for i in range(400):
    a = i * 0.05
    l.append("G1 X%.3f Y%.3f F900" % (20 * math.cos(a) + 20, 20 * math.sin(a) + 0.02 * i))
l += ["G0 Z5", "M30"]
open(sys.argv[1], "w").write("\n".join(l) + "\n")
PY
rc=0
URL="$URL" SERVE_PID=$SERVE GANTRY=$GANTRY PORT="$TMP/tty" BAD="$TMP/bad.nc" JOB="$TMP/job.nc" TOOL="$TMP/tool.nc" \
  SHOT="${SHOT:-$PWD/docs/console.png}" NODE_PATH="$PWD/$DIR/node_modules" \
  node scripts/console_drive.js || rc=$?
if [ $rc -ne 0 ]; then
  echo "--- serve log"; tail -30 "$TMP/serve.log"; echo "--- emulate log"; tail -10 "$TMP/emulate.log"
fi
exit $rc

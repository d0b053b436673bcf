#!/usr/bin/env bash
# Whole-system grbl test with bCNC (docs/grbl.md "Tested with"): bCNC from PyPI, used as-is, a Tk
# program run under Xvfb with its GRBL1 controller on `gantry emulate --pty` (configured by its
# ini in a temporary HOME), driven only through its web pendant (HTTP: Run, Pause/Resume) by
# scripts/bcnc_drive.py, which also relays bCNC's port to the board's pty byte for byte and counts
# the lines and answers on the way. Checks, on a 2,000-line job with three pendant pause/resume
# cycles: every line bCNC wrote answered `ok` exactly once, every program line written once and
# in order, the machine still in each Hold:0, and the board's final step counts equal to
# `gantry stream`'s on the same program and setup.
# Installs bCNC (pinned) under target/, and Xvfb and Tk for Python with apt-get when missing (as
# root, like the other sender tests install their clients); skips, saying why, only when the
# network is unavailable.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=target/bcnc-venv
online() { python3 -c "import socket; socket.create_connection(('$1', 443), 5)" 2>/dev/null; }
need_apt=()
command -v Xvfb >/dev/null || need_apt+=(xvfb)
python3 -c "import tkinter" 2>/dev/null || need_apt+=(python3-tk)
if [ ${#need_apt[@]} -gt 0 ]; then
  if ! online deb.debian.org; then
    echo "SKIP bCNC sender test: ${need_apt[*]} missing and the network is unavailable"
    exit 0
  fi
  [ "$(id -u)" = 0 ] || { echo "bCNC sender test: ${need_apt[*]} missing; install them (needs root)" >&2; exit 1; }
  (apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${need_apt[@]}") > target/bcnc-apt.log 2>&1 || {
    cat target/bcnc-apt.log >&2; echo "bCNC sender test: apt-get install ${need_apt[*]} failed" >&2; exit 1; }
fi
if ! "$VENV/bin/python" -c "import bCNC, tkinter" 2>/dev/null; then
  rm -rf "$VENV"
  python3 -m venv "$VENV"
  if ! "$VENV/bin/pip" install -q "bCNC==0.9.16"; then
    if ! online pypi.org; then
      echo "SKIP bCNC sender test: the network is unavailable (cannot install bCNC from PyPI)"
      exit 0
    fi
    echo "bCNC sender test: pip install bCNC failed with the network up" >&2
    exit 1
  fi
fi
cargo build -q -p host-sender
GANTRY=$PWD/target/debug/gantry
TMP=$(mktemp -d)
EMU= XVFB=
trap 'kill $EMU $XVFB 2>/dev/null || true; rm -rf "$TMP"' EXIT

# The CNCjs test's 2,000-line job (scripts/cncjs-sender-test.sh): a zig-zag of 0.25 mm segments.
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
ref=$("$GANTRY" stream "$TMP/long.nc" | grep '^steps:' | sed 's/steps: *//; s/  */ /g')

# A display of its own (-displayfd: the server picks a free number and says which).
Xvfb -displayfd 3 -nolisten tcp -screen 0 1280x1024x24 3> "$TMP/display" 2> "$TMP/xvfb.log" &
XVFB=$!
for _ in $(seq 100); do [ -s "$TMP/display" ] && break; sleep 0.1; done
[ -s "$TMP/display" ] || { echo "FAIL bCNC: Xvfb did not start"; cat "$TMP/xvfb.log"; exit 1; }
DISPLAY=:$(cat "$TMP/display")

"$GANTRY" emulate --pty "$TMP/pty" 2> "$TMP/emu.log" &
EMU=$!
for _ in $(seq 100); do [ -e "$TMP/pty" ] && break; sleep 0.1; done
PENDANT=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
mkdir -p "$TMP/home"
# bCNC's user ini: the GRBL1 controller on the relay's pty, opened at start; the pendant on a
# free port; no update check (it would open a dialog).
cat > "$TMP/home/.bCNC" <<INI
[bCNC]
checkinterval = 0
lastcheck = $(date +%s)
[Connection]
port = $TMP/bcnc-pty
baud = 115200
pendant = 1
pendantport = $PENDANT
openserial = 1
errorreport = 0
controller = GRBL1
INI
summary=$(HOME="$TMP/home" DISPLAY=$DISPLAY BCNC_LOG="$TMP/bcnc.log" BCNC_TRACE="$TMP/trace.json" timeout 900 "$VENV/bin/python" scripts/bcnc_drive.py \
  "$TMP/pty" "$TMP/bcnc-pty" "$PENDANT" "$TMP/long.nc" -- "$VENV/bin/python" -m bCNC "$TMP/long.nc") || {
  echo "FAIL bCNC pendant pauses: $summary"; python3 -c "import json,sys; t=json.load(open(sys.argv[1])); print(\"last written:\", t[\"written\"][-5:], \"answers\", len(t[\"answers\"]), \"other:\", t[\"other\"][-5:])" "$TMP/trace.json" || true; tail -20 "$TMP/bcnc.log"; tail -20 "$TMP/emu.log"; exit 1; }
sleep 0.5
kill -INT $EMU; wait $EMU || true
EMU=
steps=$(grep -o 'Idle line [0-9]* steps [^p]*' "$TMP/emu.log" | tail -1 | sed 's/.*steps //; s/ *$//')
echo "bCNC pendant pauses: $summary"
echo "bCNC pendant pauses: steps via bCNC [$steps], via gantry stream [$ref]"
[ "$steps" = "$ref" ] || { echo "FAIL bCNC pendant pauses: step counts differ"; exit 1; }
echo "bCNC sender test: 1 passed, 0 failed"

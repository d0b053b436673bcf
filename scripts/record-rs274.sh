#!/usr/bin/env bash
# Re-record the golden canonical streams in tests/golden/rs274/ with LinuxCNC's standalone
# interpreter `rs274` (the dialect oracle, DESIGN.md section 3).  CI never runs this: the recorded
# *.canon.jsonl files (and the raw *.rs274.txt output they come from) are committed.
#
# Installing the oracle (Debian 12 bookworm, which ships 2.9.0~pre1; NOT needed in CI):
#     sudo apt-get update && sudo apt-get install -y linuxcnc-uspace
#     rs274 -h        # /usr/bin/rs274, the standalone interpreter
#
# Usage:  scripts/record-rs274.sh [tests/golden/rs274/NN-name.ngc ...]   (default: every program)
#
# For each program it:
#   1. puts an N<line> word at the start of every line (scripts/rs274_to_canon.py inject), because
#      rs274 labels each canonical call with the N word of its block and nothing else;
#   2. runs `rs274 -g -n 2 -t tests/golden/rs274/tools.tbl` (batch, stop at the first error, the
#      committed tool table; block delete off; no parameter file, so every parameter including the
#      G28/G30 positions is 0);
#   3. keeps the raw output in NN-name.rs274.txt and converts it with
#      scripts/rs274_to_canon.py convert into NN-name.canon.jsonl (DESIGN.md section 7 records).
# Programs whose first line contains "golden: hand" have hand-computed goldens (features rs274
# lacks, e.g. Fanuc M98 P-encoding); they are skipped here.
set -euo pipefail

here="$(cd "$(dirname "$0")/.." && pwd)"
dir="$here/tests/golden/rs274"
conv="$here/scripts/rs274_to_canon.py"
rs274="${RS274:-rs274}"

if ! command -v "$rs274" >/dev/null 2>&1; then
    echo "record-rs274: '$rs274' not found; install it with: sudo apt-get install -y linuxcnc-uspace" >&2
    exit 2
fi

if [ "$#" -gt 0 ]; then
    progs=("$@")
else
    progs=("$dir"/*.ngc)
fi

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

n=0
for prog in "${progs[@]}"; do
    base="${prog%.ngc}"
    name="$(basename "$base")"
    if head -n 1 "$prog" | grep -q 'golden: hand'; then
        echo "skip  $name (hand-computed golden)"
        continue
    fi
    python3 "$conv" inject "$prog" > "$tmp/$name.ngc"
    # rs274 runs in the temporary directory so it cannot leave files next to the goldens.
    set +e
    (cd "$tmp" && "$rs274" -g -n 2 -t "$dir/tools.tbl" "$name.ngc" > "$tmp/out" 2> "$tmp/err" < /dev/null)
    code=$?
    set -e
    {
        cat "$tmp/out"
        echo "=== stderr ==="
        cat "$tmp/err"
        echo "=== exit $code ==="
    } > "$base.rs274.txt"
    python3 "$conv" convert "$base.rs274.txt" > "$base.canon.jsonl"
    if [ "$code" -ne 0 ]; then
        echo "ok    $name (rs274 error: $(grep -c '"error"' "$base.canon.jsonl") error record)"
    else
        echo "ok    $name"
    fi
    n=$((n + 1))
done
echo "recorded $n program(s) with $(dpkg-query -W -f='${Package} ${Version}' linuxcnc-uspace 2>/dev/null || echo "$rs274")"

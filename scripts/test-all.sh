#!/usr/bin/env bash
# Gantry's one test command: `bash scripts/test-all.sh` from anywhere in the repository.
#
# On a fresh Debian machine with rustup it installs what it needs (thumbv7em target, rustfmt,
# clippy, qemu-system-arm), then: formatting, clippy (host workspace, boards, firmware per board,
# target tests), host tests, the firmware (the full controller) release build for every board
# with its size (the F411 must fit 224 KiB flash and 64 KiB static RAM, else this fails), and the
# core's vectors on a Cortex-M4 under QEMU (must pass; the `wrong-vector` build must fail). Each
# crate uses its default target directory.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
ROOT=$PWD
unset CARGO_TARGET_DIR

# Board features of the firmware, and the size budget of the default board (F411: the chip has
# 512 KiB flash / 128 KiB RAM, memory.x gives the program 256 KiB of flash and keeps the rest for
# the setup's flash sectors; the budget leaves room below both for what the next features add),
# which its plasma table (board-f411-plasma: the A axis's pins as the torch inputs) must fit too.
# The limits can be lowered from the environment to check that an overrun fails the run.
BOARDS=(board-f411 board-f411-plasma board-f446)
F411_FLASH_LIMIT=${F411_FLASH_LIMIT:-$((224 * 1024))}
F411_RAM_LIMIT=${F411_RAM_LIMIT:-$((64 * 1024))}
THUMB=thumbv7em-none-eabihf
QEMU_TIMEOUT=300
# Every child gets its own stdin (`</dev/null`): `timeout` runs its command in a process group of
# its own, outside a terminal's foreground group, and QEMU `-nographic` (or anything else that
# touches the terminal) would be stopped there by SIGTTIN/SIGTTOU until the timeout kills it.
# With stdin from /dev/null the run is the same from a terminal as from CI, which has none; the
# whole script's stdin is /dev/null too, so no other child (nextest, the sender scripts, node,
# chromium) can wait on the terminal either.
exec </dev/null

T0=$(date +%s)
SECTION_T=$T0
section() {
    local now
    now=$(date +%s)
    if [ "$now" != "$T0" ] || [ "$SECTION_T" != "$T0" ]; then
        printf '(step took %d s)\n' "$((now - SECTION_T))"
    fi
    printf '\n==== [t=%ds] %s ====\n' "$((now - T0))" "$*"
    SECTION_T=$now
}
fail() {
    printf '\nFAILED: %s\n' "$*" >&2
    exit 1
}

section "toolchain and tools"
# The toolchain pinned by rust-toolchain.toml, installed if this rustup does not have it yet.
CHANNEL=$(sed -n 's/^channel *= *"\(.*\)"/\1/p' rust-toolchain.toml)
if ! rustup run "$CHANNEL" rustc --version >/dev/null 2>&1; then
    rustup toolchain install "$CHANNEL" --profile minimal
fi
rustc --version
if ! rustup target list --installed | grep -qx "$THUMB"; then
    rustup target add "$THUMB"
fi
for comp in rustfmt clippy; do
    if ! rustup component list --installed | grep -q "^$comp"; then
        rustup component add "$comp"
    fi
done
if ! command -v qemu-system-arm >/dev/null; then
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; fi
    $SUDO apt-get update
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends qemu-system-arm
fi
qemu-system-arm --version | sed -n 1p
command -v readelf >/dev/null || fail "readelf (binutils) is needed for the size report"

section "cargo fmt --check (root, boards, firmware, target-tests)"
cargo fmt --all --check || fail "formatting: run 'cargo fmt --all'"
for dir in boards firmware target-tests; do
    (cd "$dir" && cargo fmt --check) || fail "formatting: run 'cargo fmt' in $dir/"
done

section "clippy: host workspace"
cargo clippy --workspace --all-targets -- -D warnings

section "clippy + tests: board tables (boards/)"
(cd boards && cargo clippy --all-targets -- -D warnings && cargo test)

section "host tests"
if cargo nextest --version >/dev/null 2>&1; then
    cargo nextest run --workspace --no-fail-fast --no-tests=warn
    cargo test --workspace --doc
else
    cargo test --workspace --no-fail-fast
fi

section "grbl sender (pygrbl-streamer from PyPI) against gantry emulate --pty"
bash scripts/grbl-sender-test.sh

section "grbl sender (CNCjs from npm) against gantry emulate --pty"
bash scripts/cncjs-sender-test.sh

section "grbl sender (bCNC from PyPI, its web pendant) against gantry emulate --pty"
bash scripts/bcnc-sender-test.sh

section "operator console (gantry serve --http) in Debian's headless chromium"
SHOT="$(mktemp -d)/console.png" bash scripts/console-test.sh

section "firmware: clippy and release build per board"
SIZES=()
for board in "${BOARDS[@]}"; do
    echo "-- $board"
    (cd firmware && cargo clippy --release --no-default-features --features "$board" -- -D warnings)
    # The measured build (path prefixes remapped, so the figure is the same on every machine).
    sizes=$(bash "$ROOT/scripts/fwsize.sh" "$board" | tail -1) || fail "firmware release build failed for $board"
    read -r _ _ text _ data _ bss _ flash _ ram <<<"$sizes"
    line=$(printf '%-17s text %7d  data %6d  bss %6d  -> flash %7d B (%d KiB), static RAM %6d B (%d KiB)' \
        "$board" "$text" "$data" "$bss" "$flash" $(((flash + 1023) / 1024)) "$ram" $(((ram + 1023) / 1024)))
    echo "$line"
    SIZES+=("$line")
    if [ "$board" = board-f411 ] || [ "$board" = board-f411-plasma ]; then
        line=$(printf '%s budget: flash %d of %d B (%d B free), static RAM %d of %d B (%d B free)' \
            "$board" "$flash" "$F411_FLASH_LIMIT" "$((F411_FLASH_LIMIT - flash))" \
            "$ram" "$F411_RAM_LIMIT" "$((F411_RAM_LIMIT - ram))")
        echo "$line"
        SIZES+=("$line")
        [ "$flash" -le "$F411_FLASH_LIMIT" ] || fail "$board firmware uses $flash B flash (limit $F411_FLASH_LIMIT)"
        [ "$ram" -le "$F411_RAM_LIMIT" ] || fail "$board firmware uses $ram B static RAM (limit $F411_RAM_LIMIT)"
    fi
done

section "target tests: core vectors and the step interrupt on Cortex-M4 (QEMU mps2-an386)"
cd "$ROOT/target-tests"
# Every combination of the target tests' features is built (and linted), so none of them rots
# unbuilt: the three are independent switches (none excludes another), so all 2^3 sets, from
# none to all, bench_step's step-window included (the firmware's features are its boards, one at
# a time, above).
FEATURES=(wrong-vector profile-lines step-window)
for ((set = 0; set < 1 << ${#FEATURES[@]}; set++)); do
    on=()
    for i in "${!FEATURES[@]}"; do
        if ((set >> i & 1)); then on+=("${FEATURES[$i]}"); fi
    done
    list=$(IFS=,; echo "${on[*]}")
    echo "-- target tests with features: ${list:-(none)}"
    cargo clippy --release --all-targets --features "$list" -- -D warnings
done
cargo build --release --bin vectors
# bench_step's second, stamped copy of the step body is built (linked) too, not only linted.
cargo build --release --bin bench_step --features step-window
timeout "$QEMU_TIMEOUT" cargo run --release --bin vectors </dev/null || fail "target vectors failed under QEMU"
# The step interrupt body (machine/src/step/isr.rs) against a model of TIM2 and its
# DMA streams: every step reaches the pins once, direction set-up kept, late interrupts retried.
# It also prints instructions per step event (counted with -icount shift=0, as the benchmarks in
# target-tests/README.md are); those figures are information, never asserted.
timeout "$QEMU_TIMEOUT" cargo run --release --bin bench_step --config \
    'target.thumbv7em-none-eabihf.runner="qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -icount shift=0,sleep=off -semihosting-config enable=on,target=native -nographic -kernel"' </dev/null ||
    fail "the step interrupt's model check failed under QEMU"

section "target tests: the wrong-vector build must fail"
cargo build --release --bin vectors --features wrong-vector
set +e
out=$(timeout "$QEMU_TIMEOUT" cargo run --release --bin vectors --features wrong-vector </dev/null 2>&1)
rc=$?
set -e
echo "$out" | tail -n 3
[ "$rc" -ne 0 ] || fail "the wrong-vector build exited 0: the harness cannot fail"
echo "$out" | grep -q '^FAIL harness/deliberately-wrong-expectation' ||
    fail "the wrong-vector build failed (exit $rc) without reporting the wrong vector"
echo "wrong-vector build failed as it must (exit $rc)"
cd "$ROOT"

section "summary"
printf '%s\n' "${SIZES[@]}"
echo "all checks passed in $(($(date +%s) - T0)) s"

#!/usr/bin/env bash
# The firmware's size for one board, measured as the budget is checked (scripts/test-all.sh calls
# this): `bash scripts/fwsize.sh [board-f411|board-f411-plasma|board-f446]` builds the release firmware for the
# board and prints one line, `BOARD text T data D bss B flash F ram R` (bytes).
#
# Panic locations keep their source paths in flash, so the size would depend on where the
# checkout and CARGO_HOME sit; the measured build maps both to fixed short names, and the
# registry's source directory (`registry/src/index.crates.io-<hash>/`, 53 bytes in each of ~30
# dependency paths) to `/crates` (the last matching prefix wins). Flash = text + data (the
# allocated read-only sections and the initialised data's load image), static RAM = data + bss.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
ROOT=$PWD
BOARD=${1:-board-f411}
THUMB=thumbv7em-none-eabihf
command -v readelf >/dev/null || { echo "readelf (binutils) is needed for the size report" >&2; exit 1; }

# text/data/bss of an ARM ELF from its section headers (as Berkeley `size` counts them):
# text = allocated read-only sections, data = allocated writable PROGBITS, bss = NOBITS.
elf_size() {
    local text=0 data=0 bss=0 name type addr off size es flags rest
    while read -r name type addr off size es flags rest; do
        case "$flags" in *A*) ;; *) continue ;; esac
        if [ "$type" = NOBITS ]; then
            bss=$((bss + 16#$size))
        elif [[ $flags == *W* ]]; then
            data=$((data + 16#$size))
        else
            text=$((text + 16#$size))
        fi
    done < <(readelf -S -W "$1" | sed -n 's/^ *\[ *[0-9]*\] //p')
    echo "$text $data $bss"
}

cargo_dir=${CARGO_HOME:-$HOME/.cargo}
remap="\"--remap-path-prefix=$ROOT=/gantry\",\"--remap-path-prefix=$cargo_dir=/cargo\""
for src in "$cargo_dir"/registry/src/*/; do
    [ -d "$src" ] && remap+=",\"--remap-path-prefix=${src%/}=/crates\""
done
(cd firmware && cargo build --release --no-default-features --features "$BOARD" \
    --config "target.$THUMB.rustflags=[$remap]" </dev/null >&2)
read -r text data bss < <(elf_size "firmware/target/$THUMB/release/gantry-firmware")
echo "$BOARD text $text data $data bss $bss flash $((text + data)) ram $((data + bss))"

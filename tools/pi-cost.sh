#!/usr/bin/env bash
# Instructions per frame of glint's per-frame path on aarch64 and armv7 (under qemu-aarch64 and
# qemu-arm, counted by a small TCG plugin) and on x86_64 (callgrind), for the estimate of the cost on a Raspberry Pi
# in the README. Counts, not times: emulation says nothing about speed.
#
#   tools/pi-cost.sh
#
# Each count is taken twice, with SHORT and LONG frames processed, and the difference divided
# by LONG - SHORT, so start-up and the rendering of the frames cancel out
# (examples/frame_cost.rs). Needs valgrind, qemu-user, the cross linkers and gcc.
set -euo pipefail
cd "$(dirname "$0")/.."

SHORT=16
LONG=48
AARCH64=aarch64-unknown-linux-gnu
ARMV7=armv7-unknown-linux-gnueabihf
plugin=target/pi-cost/libinsn_count.so

mkdir -p target/pi-cost
gcc -O2 -Wall -Wextra -shared -fPIC -o "$plugin" tools/pi-cost/insn_count.c
cargo build -q --release --locked --example frame_cost
cargo build -q --release --locked --example frame_cost --target "$AARCH64"
cargo build -q --release --locked --example frame_cost --target "$ARMV7"

x86_count() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null \
        target/release/examples/frame_cost "$1" "$2" 2>&1 >/dev/null |
        sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}

# qemu_count QEMU SYSROOT TARGET STAGE FRAMES
qemu_count() {
    "$1" -plugin "$plugin" -L "$2" "target/$3/release/examples/frame_cost" "$4" "$5" 2>&1 \
        >/dev/null | sed -n 's/^insns: \([0-9]*\)$/\1/p'
}

aarch64_count() {
    qemu_count qemu-aarch64 /usr/aarch64-linux-gnu "$AARCH64" "$@"
}

armv7_count() {
    qemu_count qemu-arm /usr/arm-linux-gnueabihf "$ARMV7" "$@"
}

per_frame() {
    local short long
    short=$("$1" "$2" "$SHORT")
    long=$("$1" "$2" "$LONG")
    echo $(((long - short) / (LONG - SHORT)))
}

printf '%-10s %14s %14s %14s\n' stage "x86_64 insn" "aarch64 insn" "armv7 insn"
for stage in threshold pipeline; do
    printf '%-10s %14s %14s %14s\n' "$stage" "$(per_frame x86_count "$stage")" \
        "$(per_frame aarch64_count "$stage")" "$(per_frame armv7_count "$stage")"
done

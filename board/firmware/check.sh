#!/usr/bin/env bash
# Builds the example firmware for its microcontroller target and tests its logic on the host.
# Installs the rustup target if it is missing (CI machines start without it).
set -euo pipefail
cd "$(dirname "$0")"

TARGET=thumbv7em-none-eabihf

if ! rustup target list --installed | grep -qx "$TARGET"; then
    rustup target add "$TARGET"
fi

cargo build --release --locked --target "$TARGET"
cargo clippy --release --locked --target "$TARGET" -- -D warnings
# The board qemu emulates for the robot-in-the-loop rig (tools/src/rig).
cargo build --release --locked --target "$TARGET" --features mps2-an386 --bin glint-firmware-mps2
cargo clippy --release --locked --target "$TARGET" --features mps2-an386 -- -D warnings
cargo fmt --check
# The link and control-loop logic is plain Rust over embedded-io traits: test it on the host.
cargo test --locked
cargo clippy --locked --all-targets -- -D warnings

elf="target/$TARGET/release/glint-firmware"
test -s "$elf"
echo "firmware built: $elf ($(wc -c < "$elf") bytes with debug info)"

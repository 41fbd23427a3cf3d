#!/usr/bin/env bash
# Coverage-guided fuzzing of the decoder with cargo fuzz (libFuzzer), for SECONDS (default 60).
# Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`); this is an optional,
# deeper pass beside the proptest suite, which is what CI runs.
set -euo pipefail
cd "$(dirname "$0")"
seconds="${1:-60}"
if ! rustup toolchain list | grep -q '^nightly'; then
    echo "cargo fuzz needs a nightly toolchain (rustup toolchain install nightly)" >&2
    exit 1
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "cargo fuzz is not installed (cargo install cargo-fuzz --locked)" >&2
    exit 1
fi
cargo +nightly fuzz run decoder -- -max_total_time="$seconds"

#!/usr/bin/env bash
# The test command of the README: installs what the tests need from the system, then runs every
# test of the workspace (unit, integration, end-to-end on rendered scenes, the allocation
# counter, the protocol's fuzz pass and C decoder, the vivid VM suite) and builds the example
# firmware for its microcontroller target.
set -euo pipefail
cd "$(dirname "$0")/.."

tools/setup-system.sh
cargo test --workspace
bash board/firmware/check.sh

#!/usr/bin/env bash
# The test command of the README: installs what the tests need from the system, then runs every
# test of the workspace (unit, integration, end-to-end on rendered scenes, the allocation
# counter, the protocol's fuzz pass and C decoder, the vivid VM suite) and builds the example
# firmware for its microcontroller target; then the Raspberry Pi side: the aarch64 binary is
# cross-built, the armv7 build type-checked, the library's tests run for aarch64 under
# qemu-aarch64 (NEON kernels against the portable ones), and the deployment files installed
# into a temporary DESTDIR.
set -euo pipefail
cd "$(dirname "$0")/.."

tools/setup-system.sh test
tools/setup-python.sh
# The firmware first: it installs its rustup target, which the robot-in-the-loop rig's test
# (tools/tests/rig.rs, in the workspace's tests) needs to build the firmware it runs in qemu.
bash board/firmware/check.sh
cargo test --workspace
tools/cross.sh ci
bash board/raspberry-pi/check.sh

#!/usr/bin/env bash
# Cross builds for the Raspberry Pi, and the library's tests under qemu.
#
#   tools/cross.sh                  build the glint binary for aarch64 and armv7, then run the
#                                   library tests for aarch64 under qemu-aarch64
#   tools/cross.sh build [TARGET..] build the release binary for the given targets (default both)
#   tools/cross.sh check [TARGET..] type-check the library and binary for the given targets
#                                   (default both): catches 32-bit and ARM type differences
#                                   (time_t, off_t, c_char) without the cost of an optimised build
#   tools/cross.sh test             run the unit tests of glint and glint-protocol for aarch64
#                                   under qemu-aarch64 (the NEON kernel against the portable one)
#   tools/cross.sh ci               what CI runs (tools/test.sh): check aarch64 and armv7 with the
#                                   default features (Zenoh's `net` included), then test. An
#                                   optimised cross build with Zenoh takes about ten minutes of
#                                   CPU, which CI cannot spare; `test` links and runs aarch64
#                                   binaries under qemu.
#
# TARGET is aarch64-unknown-linux-gnu (Pi 3/4/5 with a 64-bit OS) or
# armv7-unknown-linux-gnueabihf (Pi 2/3/4 with a 32-bit OS); `aarch64` and `armv7` are accepted
# as short names. Binaries land in target/TARGET/release/glint.
#
# Needs the Debian cross linkers and qemu-user (tools/setup-system.sh installs them); the rustup
# targets are installed here when missing. Linkers and runners are set in .cargo/config.toml.
set -euo pipefail
cd "$(dirname "$0")/.."

ALL_TARGETS=(aarch64-unknown-linux-gnu armv7-unknown-linux-gnueabihf)
TEST_TARGET=aarch64-unknown-linux-gnu

full_name() {
    case "$1" in
        aarch64) echo aarch64-unknown-linux-gnu ;;
        armv7) echo armv7-unknown-linux-gnueabihf ;;
        aarch64-unknown-linux-gnu | armv7-unknown-linux-gnueabihf) echo "$1" ;;
        *)
            echo "cross.sh: unknown target '$1' (aarch64 or armv7)" >&2
            exit 2
            ;;
    esac
}

ensure_rustup_target() {
    if ! rustup target list --installed | grep -qx "$1"; then
        rustup target add "$1"
    fi
    ensure_sysroot "$1"
}

# The target's Debian cross toolchain: its linker, and its C library headers, which bindgen needs
# for the `v4l` crate (sys/time.h). The linker packages only recommend the headers, so a missing
# one is named here rather than surfacing as a clang error deep in a build script.
ensure_sysroot() {
    local triple package
    case "$1" in
        aarch64-unknown-linux-gnu) triple=aarch64-linux-gnu package=arm64 ;;
        armv7-unknown-linux-gnueabihf) triple=arm-linux-gnueabihf package=armhf ;;
    esac
    if ! command -v "$triple-gcc" >/dev/null; then
        echo "cross.sh: $triple-gcc is missing: run tools/setup-system.sh test" >&2
        exit 1
    fi
    if [ ! -f "/usr/$triple/include/sys/time.h" ]; then
        echo "cross.sh: /usr/$triple/include/sys/time.h is missing (Debian package" \
            "libc6-dev-$package-cross): run tools/setup-system.sh test" >&2
        exit 1
    fi
}

build() {
    local target
    for target in "$@"; do
        ensure_rustup_target "$target"
        cargo build --release --locked --target "$target" --bin glint
        echo "cross.sh: built target/$target/release/glint" >&2
    done
}

check() {
    local target target_args=()
    for target in "$@"; do
        ensure_rustup_target "$target"
        target_args+=(--target "$target")
    done
    # One cargo for every target: the second target's crates fill the cores while the first one
    # waits on a single long crate (Zenoh's), where two cargos in turn would each leave a core idle.
    cargo check --locked "${target_args[@]}" -p glint --lib --bins
}

run_tests() {
    ensure_rustup_target "$TEST_TARGET"
    # The runner in .cargo/config.toml (qemu-aarch64) executes the test binaries. Without the
    # `net` feature: publishing has no target-specific code, and building Zenoh once more for
    # aarch64 would cost CI minutes (`check` covers it).
    cargo test --locked --target "$TEST_TARGET" --lib -p glint -p glint-protocol \
        --no-default-features --features glint/v4l2
}

command="${1:-all}"
[ $# -gt 0 ] && shift
case "$command" in
    all)
        build "${ALL_TARGETS[@]}"
        run_tests
        ;;
    build | check)
        [ $# -gt 0 ] || set -- "${ALL_TARGETS[@]}"
        targets=()
        for name in "$@"; do
            targets+=("$(full_name "$name")") # exits on an unknown name
        done
        "$command" "${targets[@]}"
        ;;
    test)
        run_tests
        ;;
    ci)
        check "${ALL_TARGETS[@]}"
        run_tests
        ;;
    *)
        echo "usage: tools/cross.sh [all | build|check [aarch64|armv7 ...] | test | ci]" >&2
        exit 2
        ;;
esac

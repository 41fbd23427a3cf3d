#!/bin/sh
# Installs the Debian packages glint needs, and nothing it does not. Idempotent: prints nothing
# and touches nothing when everything is already installed.
#
#   tools/setup-system.sh          what building and running glint needs (README command 1)
#   tools/setup-system.sh test     that, plus what the tests need (tools/test.sh runs this)
#   tools/setup-system.sh profile  that, plus the profilers the README's cost figures come from
#   tools/setup-system.sh list [test]     prints the package list, one a line
#   tools/setup-system.sh verify [test]   installs nothing; fails unless every listed package is
#                                  installed AND every system file the build and tests use
#                                  (tools/system-files.txt) comes from a listed package or from
#                                  what those packages Depend on: a file that only a Recommends
#                                  (or this machine's history) brought fails it (.ci/run)
#
# Packages are installed with --no-install-recommends, so every package that is needed is
# named here, even when another one would "recommend" it.
#
# Building and running glint:
#   gcc, libc6-dev   the C toolchain Rust links with, and the C headers
#   linux-libc-dev   linux/videodev2.h, the V4L2 interface the `v4l` crate binds to
#   libclang-dev     bindgen, used by the `v4l` crate's build script
#
# The tests, in addition:
#   qemu-system-x86  boots the VM that runs the kernel's `vivid` V4L2 driver (tests/vm/)
#   busybox-static   the VM's userland
#   v4l-utils        v4l2-ctl in the VM (DV timings, controls, feeding vivid's output node)
#   cpio, kmod       building the VM's initramfs (cpio) and module dependencies (depmod, modprobe)
#   xz-utils         unpacking the kernel image to the uncompressed vmlinux qemu boots fastest
#   binutils         strip, to shrink the test programs copied into the VM
#   socat            serial port pairs for UART tests
#   g++              the C decoder (board/arduino/glint.h) compiled as C++ too
#   gcc-aarch64-linux-gnu, gcc-arm-linux-gnueabihf
#                    cross linkers for the Raspberry Pi targets (tools/cross.sh)
#   libc6-dev-arm64-cross, libc6-dev-armhf-cross, linux-libc-dev-arm64-cross,
#   linux-libc-dev-armhf-cross
#                    the targets' C library and kernel headers: the cross linkers only
#                    *recommend* them, and bindgen needs sys/time.h and linux/videodev2.h of the
#                    target for the `v4l` crate
#   qemu-user        qemu-aarch64, the runner of the aarch64 library tests (.cargo/config.toml)
#   chromium         headless browser screenshot of `glint run --preview`'s page (tests/preview.rs)
#   systemd, python3 systemd-analyze/systemd-sysusers and tomllib for the deployment files' check
#                    (board/raspberry-pi/check.sh)
#   python3-venv     the venv of pymavlink, which decodes `--mavlink` output (tools/setup-python.sh)
#   apt              apt-get download of the kernel package the V4L2 VM boots (tests/vm/prepare.sh)
#   qemu-system-arm  the example firmware on an emulated Cortex-M4 board (mps2-an386) in the
#                    robot-in-the-loop rig (tools/src/rig, tools/tests/rig.rs)
#
# Measuring cost (not needed to build or test; the README's figures name which one):
#   valgrind         callgrind's instruction counts, the load-independent cost figures
#   linux-perf       perf, where a stage's time goes (CPU samples)
#
# The VM runs host-built (glibc) test programs: tests/vm/prepare.sh copies the C libraries they
# need into the guest, so no extra Rust target is needed.
set -eu

BUILD_PACKAGES="gcc libc6-dev linux-libc-dev libclang-dev"
TEST_PACKAGES="qemu-system-x86 busybox-static v4l-utils cpio kmod xz-utils binutils socat g++
    gcc-aarch64-linux-gnu gcc-arm-linux-gnueabihf libc6-dev-arm64-cross libc6-dev-armhf-cross
    linux-libc-dev-arm64-cross linux-libc-dev-armhf-cross qemu-user chromium systemd python3 python3-venv apt
    qemu-system-arm"
PROFILE_PACKAGES="valgrind linux-perf"

here=$(cd "$(dirname "$0")" && pwd)

usage() {
    echo "usage: tools/setup-system.sh [test|profile] | list [test|profile] | verify [test]" >&2
    exit 2
}

# packages [test]: the list for that set.
packages() {
    case "${1:-}" in
        "") echo $BUILD_PACKAGES ;;
        test) echo $BUILD_PACKAGES $TEST_PACKAGES ;;
        profile) echo $BUILD_PACKAGES $PROFILE_PACKAGES ;;
        *) usage ;;
    esac
}

installed() {
    dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"
}

missing_of() {
    missing=""
    for pkg in "$@"; do
        installed "$pkg" || missing="$missing $pkg"
    done
    echo $missing
}

# apt_install PACKAGES...: quiet when it works; on failure shows apt's own output (not just
# dpkg's last line), and tries once more, since a mirror or lock hiccup is the usual cause.
apt_install() {
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    log=$(mktemp)
    for attempt in 1 2; do
        if { $sudo apt-get update -q &&
            DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "$@"; } \
            >"$log" 2>&1; then
            rm -f "$log"
            return 0
        fi
        echo "setup-system: apt-get failed (attempt $attempt of 2); its output ends:" >&2
        tail -n 30 "$log" >&2
    done
    rm -f "$log"
    echo "setup-system: could not install:$*" >&2
    exit 1
}

install_set() {
    # shellcheck disable=SC2046 # word splitting of the package list is intended
    missing=$(missing_of $(packages "$@"))
    [ -n "$missing" ] || return 0
    echo "setup-system: installing $missing" >&2
    # shellcheck disable=SC2086
    apt_install $missing
    # shellcheck disable=SC2086
    still=$(missing_of $missing)
    if [ -n "$still" ]; then
        echo "setup-system: apt-get finished but these are not installed: $still" >&2
        exit 1
    fi
}

# Essential packages are on every Debian system and need not be listed.
essential() {
    [ "$(dpkg-query -W -f='${Essential}' "$1" 2>/dev/null)" = yes ]
}

verify_set() {
    set_name=${1:-}
    # shellcheck disable=SC2046
    missing=$(missing_of $(packages "$set_name"))
    if [ -n "$missing" ]; then
        echo "setup-system verify: not installed: $missing (run tools/setup-system.sh $set_name)" >&2
        exit 1
    fi
    # What the listed packages bring without any Recommends: the packages themselves and
    # everything they Depend or Pre-Depend on.
    # shellcheck disable=SC2046
    closure=$(apt-cache depends --recurse --installed --no-recommends --no-suggests \
        --no-conflicts --no-breaks --no-replaces --no-enhances $(packages "$set_name") |
        grep -v '^ ' | sed 's/:.*//' | sort -u)
    # The needed files, globs expanded (a glob stands for a version number: its first match).
    files=""
    failed=0
    while read -r path sets _; do
        case "$path" in "" | \#*) continue ;; esac
        # A file of the test set is not needed for building alone.
        [ "$sets" = test ] && [ "$set_name" != test ] && continue
        # shellcheck disable=SC2086 # the expansion is the point
        set -- $path
        if [ ! -e "$1" ]; then
            echo "setup-system verify: $path is missing" >&2
            failed=1
        else
            files="$files $1"
        fi
    done <"$here/system-files.txt"
    # One dpkg query for all of them, under each name the package database may know a file by:
    # as given, where its links lead (alternatives), and without /usr (merged /usr: dpkg still
    # records /bin/cpio for /usr/bin/cpio).
    names=""
    for file in $files; do
        names="$names $file $(readlink -f "$file") ${file#/usr}"
    done
    # shellcheck disable=SC2086
    owners=$(dpkg-query -S $names 2>/dev/null | sed 's/, /,/g')
    for file in $files; do
        owner=""
        for name in "$file" "$(readlink -f "$file")" "${file#/usr}"; do
            owner=$(echo "$owners" | awk -v f="$name" '$2 == f { sub(/:$/, "", $1); print $1; exit }')
            [ -n "$owner" ] && break
        done
        # Several packages may share a directory entry: any one of them in the closure will do.
        found=""
        for pkg in $(echo "$owner" | tr ',' ' '); do
            pkg=${pkg%%:*}
            if echo "$closure" | grep -qx "$pkg" || essential "$pkg"; then
                found=$pkg
                break
            fi
        done
        if [ -z "$owner" ]; then
            echo "setup-system verify: $file belongs to no Debian package" >&2
            failed=1
        elif [ -z "$found" ]; then
            echo "setup-system verify: $file comes from $owner, which tools/setup-system.sh does not install (only a Recommends or this machine's history brought it)" >&2
            failed=1
        fi
    done
    [ "$failed" -eq 0 ] || exit 1
    echo "setup-system verify: $(packages "$set_name" | wc -w) packages installed; the $(echo $files | wc -w) system files that ${set_name:+the tests and }the build need come from them"
}

case "${1:-}" in
    "" | test | profile) install_set "$@" ;;
    list) packages "${2:-}" | tr ' ' '\n' ;;
    verify) verify_set "${2:-}" ;;
    *) usage ;;
esac

#!/bin/sh
# Installs the Debian packages glint's build and tests need. Idempotent: prints nothing and
# touches nothing when everything is already installed.
#
#   libclang-dev     bindgen, used by the `v4l` crate's build script
#   qemu-system-x86  boots the VM that runs the kernel's `vivid` V4L2 driver (tests/vm/)
#   busybox-static   the VM's userland
#   v4l-utils        v4l2-ctl in the VM (DV timings, controls, feeding vivid's output node)
#   cpio, kmod       building the VM's initramfs (cpio) and module dependencies (depmod, modprobe)
#   socat            serial port pairs for UART tests
#   binutils         strip, to shrink the test programs copied into the VM
#   xz-utils         unpacking the kernel image to the uncompressed vmlinux qemu boots fastest
#   gcc-aarch64-linux-gnu, gcc-arm-linux-gnueabihf
#                    cross linkers for the Raspberry Pi targets (tools/cross.sh); they pull in the
#                    targets' C library and kernel headers (libc6-dev-arm64-cross,
#                    linux-libc-dev-arm64-cross, ...), which bindgen finds for the `v4l` crate
#   qemu-user        qemu-aarch64, the runner of the aarch64 library tests (.cargo/config.toml)
#   chromium         headless browser screenshot of `glint run --preview`'s page (tests/preview.rs)
#   systemd, python3 systemd-analyze/systemd-sysusers and tomllib for the deployment files' check
#                    (board/raspberry-pi/check.sh); both are on the base image, listed so a leaner
#                    machine gets them too
#
# The VM runs host-built (glibc) test programs: tests/vm/prepare.sh copies the C libraries they
# need into the guest, so no extra Rust target is needed.
set -eu

PACKAGES="libclang-dev qemu-system-x86 busybox-static v4l-utils cpio kmod socat xz-utils binutils
    gcc-aarch64-linux-gnu gcc-arm-linux-gnueabihf qemu-user chromium systemd python3"

missing=""
for pkg in $PACKAGES; do
    if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
        missing="$missing $pkg"
    fi
done

if [ -n "$missing" ]; then
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then
        SUDO="sudo"
    fi
    echo "setup-system: installing$missing" >&2
    $SUDO apt-get update -qq
    # shellcheck disable=SC2086 # word splitting of the package list is intended
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
fi


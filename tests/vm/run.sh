#!/bin/sh
# Boots the vivid test VM on a shared folder and waits for it to power off.
#
# Usage: tests/vm/run.sh SHARE_DIR
#   SHARE_DIR must hold guest.sh. The guest mounts SHARE_DIR on /mnt, runs `sh /mnt/guest.sh`
#   with its output in SHARE_DIR/guest.log and its exit status in SHARE_DIR/guest.rc, and powers
#   off. The kernel's console goes to SHARE_DIR/console.log.
#
# Exits with the guest script's status; 124 when the VM outlives GLINT_VM_TIMEOUT seconds
# (default 180: the vivid suite takes 60-70 s on an idle machine under TCG, and up to 140 s here
# with other work on both cores), 125 when the VM ends without the guest script having run.
# GLINT_VM_QEMU_EXTRA adds qemu arguments (split at spaces), e.g. "-serial pty" for a second
# UART (the guest's /dev/ttyS1) on a host pty, named in SHARE_DIR/qemu.log.
#
# KVM is not used: the /dev/kvm of the build machines cannot run a stock kernel. TCG boots the
# uncompressed kernel in a few seconds.
set -eu

HERE=$(cd "$(dirname "$0")" && pwd)
share=$(cd "${1:?usage: run.sh SHARE_DIR}" && pwd)
timeout_s=${GLINT_VM_TIMEOUT:-180}
[ -f "$share/guest.sh" ] || { echo "run: $share/guest.sh is missing" >&2; exit 2; }

parts=$("$HERE/prepare.sh")
rm -f "$share/guest.rc" "$share/guest.log" "$share/console.log"

# Standard input is closed in CI, so no stdio serial or monitor; the console goes to a file.
timeout --kill-after=5 "$timeout_s" qemu-system-x86_64 \
    -accel tcg -cpu max -m 512 -smp 1 \
    -kernel "$parts/vmlinux" -initrd "$parts/initramfs.gz" \
    -append "console=ttyS0 panic=-1 quiet loglevel=4" \
    -fsdev "local,id=fs0,path=$share,security_model=none" \
    -device virtio-9p-pci,fsdev=fs0,mount_tag=hostshare \
    -serial "file:$share/console.log" -display none -monitor none -nodefaults -no-reboot \
    ${GLINT_VM_QEMU_EXTRA:-} \
    </dev/null >"$share/qemu.log" 2>&1 || {
    status=$?
    if [ "$status" -eq 124 ] || [ "$status" -eq 137 ]; then
        echo "run: the VM did not finish within ${timeout_s}s" >&2
        exit 124
    fi
    echo "run: qemu failed with status $status:" >&2
    cat "$share/qemu.log" >&2
    exit "$status"
}
if [ ! -f "$share/guest.rc" ]; then
    echo "run: the guest script did not run; console:" >&2
    tail -n 30 "$share/console.log" >&2
    exit 125
fi
exit "$(cat "$share/guest.rc")"

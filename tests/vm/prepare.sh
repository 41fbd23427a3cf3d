#!/bin/sh
# Builds, once per kernel version, what the vivid test VM boots: the uncompressed kernel, the
# kernel modules it needs (with depmod data) and a base initramfs (busybox, the modules, v4l2-ctl,
# the C libraries glint's test programs link against, and /init).
#
# The kernel comes from Debian's linux-image package, fetched with `apt-get download` and unpacked
# with `dpkg-deb -x`: it is never installed. Everything lands in
#   ${GLINT_VM_CACHE:-$HOME/.cache/glint-vm}/<kernel version>/
# and a second run with the same version does nothing (prints the cache directory only).
#
# Usage: tests/vm/prepare.sh            prints the cache directory on stdout
# Needs: tools/setup-system.sh's packages (busybox-static, v4l-utils, cpio, kmod, xz-utils).
set -eu

HERE=$(cd "$(dirname "$0")" && pwd)
CACHE_ROOT=${GLINT_VM_CACHE:-$HOME/.cache/glint-vm}
# The modules the guest loads, in addition to their dependencies.
MODULES="virtio_pci 9pnet_virtio 9p vivid"

log() { echo "prepare: $*" >&2; }

# The versioned image package the `linux-image-amd64` meta-package points at, e.g.
# linux-image-6.1.0-56-amd64. GLINT_VM_KERNEL_PKG pins one.
kernel_pkg=${GLINT_VM_KERNEL_PKG:-}
if [ -z "$kernel_pkg" ]; then
    kernel_pkg=$(apt-cache depends linux-image-amd64 2>/dev/null |
        sed -n 's/^ *Depends: \(linux-image-[0-9][^ ]*\)$/\1/p' | head -n 1)
fi
if [ -z "$kernel_pkg" ]; then
    echo "prepare: cannot find the kernel package behind linux-image-amd64 (run apt-get update?)" >&2
    exit 1
fi
kver=${kernel_pkg#linux-image-}
# The cache key includes this script, so that a change in what the initramfs holds rebuilds it.
script_sum=$(cat "$0" "$HERE/init" | cksum | cut -d' ' -f1)
dir="$CACHE_ROOT/$kver"
stamp="$dir/ready-$script_sum"
if [ -f "$stamp" ]; then
    echo "$dir"
    exit 0
fi

log "building VM parts for kernel $kver in $dir"
rm -rf "$dir"
mkdir -p "$dir"
work=$(mktemp -d "$dir/work.XXXXXX")
trap 'rm -rf "$work"' EXIT

# 1. The kernel package, unpacked (not installed).
(cd "$work" && apt-get download -q "$kernel_pkg" >/dev/null)
dpkg-deb -x "$work"/linux-image-*.deb "$work/pkg"
depmod -b "$work/pkg" "$kver"

# 2. vmlinux: the ELF inside vmlinuz's xz payload. qemu boots it through its PVH entry, which
#    under TCG is seconds faster than letting the compressed kernel unpack itself.
vmlinuz="$work/pkg/boot/vmlinuz-$kver"
offset=$(LC_ALL=C grep -obUaP '\xfd\x37\x7a\x58\x5a\x00' "$vmlinuz" | head -n 1 | cut -d: -f1)
if [ -z "$offset" ]; then
    echo "prepare: no xz payload found in $vmlinuz" >&2
    exit 1
fi
tail -c +"$((offset + 1))" "$vmlinuz" | xz -dc 2>/dev/null >"$work/vmlinux" || true
if [ "$(head -c 4 "$work/vmlinux" | od -An -c | tr -d ' ')" != "177ELF" ]; then
    echo "prepare: the xz payload of $vmlinuz is not an ELF kernel" >&2
    exit 1
fi

# 3. The initramfs root.
root="$work/root"
mkdir -p "$root/bin" "$root/sbin" "$root/lib/modules" "$root/lib64" "$root/dev" "$root/proc" \
    "$root/sys" "$root/mnt" "$root/tmp" "$root/usr/bin" "$root/usr/lib"
cp /bin/busybox "$root/bin/busybox"
for applet in $(/bin/busybox --list); do
    [ -e "$root/bin/$applet" ] || ln -s busybox "$root/bin/$applet"
done

# Modules in load order, listed for /init.
: >"$root/lib/modules/load-order"
for m in $MODULES; do
    modprobe -d "$work/pkg" -S "$kver" --show-depends "$m" | while read -r kind path _; do
        [ "$kind" = insmod ] || continue
        name=$(basename "$path")
        if [ ! -e "$root/lib/modules/$name" ]; then
            cp "$path" "$root/lib/modules/$name"
            echo "$name" >>"$root/lib/modules/load-order"
        fi
    done
done

# Host programs and every shared library they (or glint's test programs) need, at the same paths.
copy_with_libs() {
    cp "$1" "$root/usr/bin/"
    ldd "$1" | grep -o '/[^ ]*' | while read -r lib; do
        mkdir -p "$root$(dirname "$lib")"
        cp -L "$lib" "$root$lib"
    done
}
copy_with_libs "$(command -v v4l2-ctl)"
# Rust binaries built on the host need libgcc_s besides what v4l2-ctl pulls in.
for lib in $(ldconfig -p | grep -E '/(libgcc_s\.so\.1|libm\.so\.6|libc\.so\.6)$' | grep x86-64 | grep -o '/[^ ]*$'); do
    mkdir -p "$root$(dirname "$lib")"
    cp -L "$lib" "$root$lib"
done

cp "$HERE/init" "$root/init"
chmod +x "$root/init"
(cd "$root" && find . | cpio -o -H newc --quiet | gzip -1) >"$work/initramfs.gz"

mv "$work/vmlinux" "$dir/vmlinux"
mv "$work/initramfs.gz" "$dir/initramfs.gz"
touch "$stamp"
log "done"
echo "$dir"

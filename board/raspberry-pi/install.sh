#!/bin/sh
# Installs glint as a service on a Raspberry Pi (or any systemd Linux):
#
#   sudo ./install.sh --binary PATH [--destdir DIR] [--dry-run]
#
#   --binary PATH   the glint binary built for the Pi (tools/cross.sh; for a 64-bit OS
#                   target/aarch64-unknown-linux-gnu/release/glint)
#   --destdir DIR   install the files under DIR instead of /, and skip everything that changes
#                   the running system (user creation, udev and systemd reloads): for packaging
#                   and for testing the script without root
#   --dry-run       print what would be done, change nothing
#
# What it does, each step idempotent (a second run changes nothing):
#   /usr/local/bin/glint                  the binary (replaced when it differs)
#   /etc/systemd/system/glint.service     the unit (replaced when it differs)
#   /etc/sysusers.d/glint.conf            the `glint` user, in groups video and dialout; applied
#                                         with systemd-sysusers (or useradd where that is missing)
#   /etc/udev/rules.d/99-glint.rules      /dev/glint-camera, /dev/glint-serial   } kept when they
#   /etc/glint/glint.toml                 the configuration                      } already exist
#   /usr/local/share/doc/glint/           this README and the pristine examples
#
# Your edited rules and configuration are never overwritten: the shipped versions stay
# readable under /usr/local/share/doc/glint/ to compare with. The service is not enabled: fill in
# the udev ids and the configuration first, then `systemctl enable --now glint`.
set -eu

here=$(cd "$(dirname "$0")" && pwd)
binary=""
destdir=""
dry_run=0

usage() {
    sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}

while [ $# -gt 0 ]; do
    case "$1" in
        --binary) [ $# -ge 2 ] || usage; binary=$2; shift 2 ;;
        --destdir) [ $# -ge 2 ] || usage; destdir=$2; shift 2 ;;
        --dry-run) dry_run=1; shift ;;
        -h | --help) usage ;;
        *) echo "install.sh: unknown argument '$1'" >&2; usage ;;
    esac
done

if [ -z "$binary" ]; then
    echo "install.sh: --binary PATH is required (the glint binary built for this machine)" >&2
    exit 2
fi
if [ ! -f "$binary" ]; then
    echo "install.sh: no binary at '$binary'" >&2
    exit 1
fi
if [ -n "$destdir" ]; then
    destdir=$(mkdir -p "$destdir" && cd "$destdir" && pwd)
elif [ "$dry_run" -eq 0 ] && [ "$(id -u)" -ne 0 ]; then
    echo "install.sh: installing to / needs root (sudo), or use --destdir DIR / --dry-run" >&2
    exit 1
fi

DOC_DIR=/usr/local/share/doc/glint

say() {
    echo "install.sh: $*"
}

# Runs a command that changes the system, or shows it under --dry-run.
act() {
    if [ "$dry_run" -eq 1 ]; then
        say "would run: $*"
    else
        "$@"
    fi
}

# put MODE SOURCE TARGET: installs SOURCE as $destdir/TARGET when missing or different.
put() {
    target="$destdir$3"
    if [ -f "$target" ] && cmp -s "$2" "$target"; then
        return 0
    fi
    say "installing $3"
    act install -D -m "$1" "$2" "$target"
}

# keep MODE SOURCE TARGET: installs SOURCE only when TARGET does not exist yet (user-edited).
keep() {
    target="$destdir$3"
    if [ -e "$target" ]; then
        if ! cmp -s "$2" "$target"; then
            say "keeping your $3 (the shipped one is in $DOC_DIR)"
        fi
        return 0
    fi
    say "installing $3"
    act install -D -m "$1" "$2" "$target"
}

put 0755 "$binary" /usr/local/bin/glint
put 0644 "$here/glint.service" /etc/systemd/system/glint.service
put 0644 "$here/sysusers-glint.conf" /etc/sysusers.d/glint.conf
keep 0644 "$here/99-glint.rules" /etc/udev/rules.d/99-glint.rules
keep 0644 "$here/glint.toml" /etc/glint/glint.toml
put 0644 "$here/README.md" "$DOC_DIR/README.md"
put 0644 "$here/99-glint.rules" "$DOC_DIR/99-glint.rules"
put 0644 "$here/glint.toml" "$DOC_DIR/glint.toml"

if [ -n "$destdir" ]; then
    say "files are under $destdir; not creating the user nor reloading udev and systemd"
    exit 0
fi

# The user: systemd-sysusers applies the sysusers.d file (a no-op when the user exists).
if command -v systemd-sysusers >/dev/null 2>&1; then
    act systemd-sysusers /etc/sysusers.d/glint.conf
elif ! id glint >/dev/null 2>&1; then
    act useradd --system --user-group --home-dir /var/lib/glint --no-create-home \
        --shell /usr/sbin/nologin --groups video,dialout glint
else
    act usermod --append --groups video,dialout glint
fi

act udevadm control --reload
act udevadm trigger --subsystem-match=video4linux --subsystem-match=tty
act systemctl daemon-reload

if grep -q 'VVVV' /etc/udev/rules.d/99-glint.rules 2>/dev/null; then
    say "next: fill in the camera's and adapter's ids in /etc/udev/rules.d/99-glint.rules"
fi
say "next: edit /etc/glint/glint.toml, then: systemctl enable --now glint; journalctl -u glint -f"

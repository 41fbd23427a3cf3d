#!/usr/bin/env bash
# Tests the Raspberry Pi deployment files without root and without touching the system:
# install.sh into temporary DESTDIRs (files, modes, idempotence, user edits kept, --dry-run
# changing nothing, bad arguments refused), the sysusers file applied to the DESTDIR's own
# /etc/passwd, the unit checked by systemd-analyze, and the example glint.toml parsed as TOML.
#
#   board/raspberry-pi/check.sh [BINARY]
#
# BINARY defaults to a stand-in file: installing does not run it.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

fail() {
    echo "raspberry-pi/check.sh: FAIL: $*" >&2
    exit 1
}

binary=${1:-}
if [ -z "$binary" ]; then
    binary="$work/glint"
    printf '#!/bin/sh\necho stand-in\n' >"$binary"
fi

# Every file with its mode and checksum, to compare trees before and after.
snapshot() {
    (cd "$1" && find . -type f -printf '%p %m ' -exec sha256sum {} \; | sort)
}

dest="$work/root"
"$here/install.sh" --binary "$binary" --destdir "$dest" >"$work/first.log"

for f in usr/local/bin/glint etc/systemd/system/glint.service etc/sysusers.d/glint.conf \
    etc/udev/rules.d/99-glint.rules etc/glint/glint.toml usr/local/share/doc/glint/README.md; do
    [ -f "$dest/$f" ] || fail "install did not create /$f"
done
[ "$(stat -c %a "$dest/usr/local/bin/glint")" = 755 ] || fail "the binary is not mode 755"
[ "$(stat -c %a "$dest/etc/glint/glint.toml")" = 644 ] || fail "the config is not mode 644"
cmp -s "$binary" "$dest/usr/local/bin/glint" || fail "the installed binary differs"

# A second run changes nothing and says nothing about installing.
before=$(snapshot "$dest")
"$here/install.sh" --binary "$binary" --destdir "$dest" >"$work/second.log"
[ "$before" = "$(snapshot "$dest")" ] || fail "a second install changed files"
if grep -q 'installing' "$work/second.log"; then
    fail "a second install reinstalled: $(cat "$work/second.log")"
fi

# The user's configuration and rules survive a reinstall; a new binary replaces the old one.
echo 'fps = 60' >>"$dest/etc/glint/glint.toml"
edited=$(sha256sum <"$dest/etc/glint/glint.toml")
echo '# new build' >"$work/glint-new"
"$here/install.sh" --binary "$work/glint-new" --destdir "$dest" >"$work/third.log"
[ "$edited" = "$(sha256sum <"$dest/etc/glint/glint.toml")" ] || fail "the edited config was overwritten"
grep -q 'keeping your /etc/glint/glint.toml' "$work/third.log" || fail "no note about the kept config"
cmp -s "$work/glint-new" "$dest/usr/local/bin/glint" || fail "the new binary was not installed"

# --dry-run creates nothing.
"$here/install.sh" --binary "$binary" --destdir "$work/dry" --dry-run >"$work/dry.log"
[ -z "$(find "$work/dry" -type f)" ] || fail "--dry-run created files"
grep -q 'would run: install' "$work/dry.log" || fail "--dry-run did not list the installs"

# Bad arguments are refused with a message and a non-zero exit.
if "$here/install.sh" --destdir "$work/x" >/dev/null 2>&1; then fail "no --binary accepted"; fi
if "$here/install.sh" --binary "$work/missing" --destdir "$work/x" >/dev/null 2>&1; then
    fail "a missing binary accepted"
fi
if "$here/install.sh" --binary "$binary" --bogus >/dev/null 2>&1; then fail "unknown flag accepted"; fi

# The sysusers file creates the user and its groups in the DESTDIR's own /etc.
if command -v systemd-sysusers >/dev/null 2>&1; then
    systemd-sysusers --root="$dest" "$dest/etc/sysusers.d/glint.conf" >"$work/sysusers.log" 2>&1 ||
        fail "systemd-sysusers: $(cat "$work/sysusers.log")"
    grep -q '^glint:' "$dest/etc/passwd" || fail "sysusers did not create the glint user"
    for group in video dialout; do
        grep -Eq "^$group:[^:]*:[0-9]+:(.*,)?glint(,|$)" "$dest/etc/group" ||
            fail "glint is not in group $group"
    done
else
    fail "systemd-sysusers missing (tools/setup-system.sh installs systemd)"
fi

# The unit parses and passes systemd's checks; its ExecStart is pointed at the DESTDIR's binary
# (systemd-analyze checks that it exists and is executable).
if command -v systemd-analyze >/dev/null 2>&1; then
    mkdir "$work/unit"
    sed "s|/usr/local/bin/glint|$dest/usr/local/bin/glint|" \
        "$dest/etc/systemd/system/glint.service" >"$work/unit/glint.service"
    # verify exits 0 on keys it ignores; any message at all is a failure here.
    verdict=$(systemd-analyze verify "$work/unit/glint.service" 2>&1) ||
        fail "systemd-analyze verify rejected glint.service: $verdict"
    [ -z "$verdict" ] || fail "systemd-analyze verify: $verdict"
else
    fail "systemd-analyze missing (tools/setup-system.sh installs systemd)"
fi

# The example configuration is valid TOML.
python3 - "$here/glint.toml" <<'EOF' || fail "glint.toml is not valid TOML"
import sys, tomllib
with open(sys.argv[1], "rb") as f:
    tomllib.load(f)
EOF

echo "raspberry-pi/check.sh: install, reinstall, dry run, sysusers, unit and config OK"

#!/usr/bin/env bash
# The Python the tests use as independent implementations, in a venv with pinned packages:
# - pymavlink decodes what `glint --mavlink` sends (tests/mavlink.rs, tests/mavlink/decode.py);
# - eclipse-zenoh (the same Zenoh release as the Rust crate, so the same protocol) subscribes to
#   what `glint --publish` sends, and zenoh-ros2-sdk with its rosbags decodes the ROS messages
#   and the rmw_zenoh attachment (tests/publish.rs, tests/publish/subscribe.py);
# - numpy renders streak scenes with other physics than glint's own renderer
#   (tests/independent_scenes.rs, tests/independent/render_streaks.py).
# Binary wheels only, so nothing is compiled here. tools/test.sh runs this; run it by hand before
# `cargo test --test mavlink`, `--test publish` or `--test independent_scenes`. The venv is
# $GLINT_PY_VENV, or ~/.cache/glint-py.
#
# Needs Debian's python3-venv (tools/setup-system.sh test installs it) and access to PyPI.
set -euo pipefail

venv=${GLINT_PY_VENV:-$HOME/.cache/glint-py}
# Debian's interpreter: its venv module comes from the packages setup-system.sh installs.
python=/usr/bin/python3
# name==version, the versions the check below compares with.
packages=(
    pymavlink==2.4.49
    eclipse-zenoh==1.10.2
    zenoh-ros2-sdk==0.1.8
    rosbags==0.11.9
    numpy==2.2.6
)

installed() {
    "$venv/bin/python" - "${packages[@]}" <<'EOF' 2>/dev/null
import sys
from importlib.metadata import version
sys.exit(any(version(p.split("==")[0]) != p.split("==")[1] for p in sys.argv[1:]))
EOF
}

if installed; then
    exit 0
fi
if [ ! -x "$venv/bin/pip" ]; then
    "$python" -m venv --clear "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check --only-binary=:all: "${packages[@]}"
installed
echo "setup-python: ${packages[*]} in $venv"

#!/usr/bin/env bash
# The Python the tests use as an independent MAVLink implementation: a venv with a pinned
# pymavlink, which decodes what `glint --mavlink` sends (tests/mavlink.rs, tests/mavlink/decode.py).
# Binary wheels only, so nothing is compiled here. tools/test.sh runs this; run it by hand before
# `cargo test --test mavlink`. The venv is $GLINT_PY_VENV, or ~/.cache/glint-py.
#
# Needs Debian's python3-venv (tools/setup-system.sh test installs it) and access to PyPI.
set -euo pipefail

venv=${GLINT_PY_VENV:-$HOME/.cache/glint-py}
# Debian's interpreter: its venv module comes from the packages setup-system.sh installs.
python=/usr/bin/python3
pymavlink=pymavlink==2.4.49

if "$venv/bin/python" -c 'import pymavlink, sys; sys.exit(pymavlink.__version__ != "2.4.49")' \
    2>/dev/null; then
    exit 0
fi
"$python" -m venv --clear "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check --only-binary=:all: "$pymavlink"
echo "setup-python: $pymavlink in $venv"

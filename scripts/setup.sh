#!/usr/bin/env bash
# Installs what the project's commands need on a fresh Debian machine with
# Rust and Python 3: the Python virtual environment .venv with the test and
# co-simulation packages (pinned in tests/python/requirements.txt).
# Sourced by scripts/study.sh and scripts/test.sh; safe to run again.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

req=tests/python/requirements.txt
stamp=.venv/.requirements.sha256
want=$(sha256sum "$req" | cut -d' ' -f1)
if [ ! -x .venv/bin/python ] || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
    echo "setting up .venv (Python packages from $req)"
    python3 -m venv .venv
    .venv/bin/python -m pip install --quiet --upgrade pip
    .venv/bin/python -m pip install --quiet -r "$req"
    echo "$want" > "$stamp"
fi

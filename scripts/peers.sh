#!/usr/bin/env bash
# Sets up a Python virtual environment with the peer planners and the plan validator used by
# `scripts/bench-planners.py`: unified-planning (its time-triggered plan
# validator), up-lpg (LPG-td), up-aries (Aries) and up-tamer (Tamer), all from the Python
# package registry. Usage: scripts/peers.sh [VENV_DIR]   (default: target/peers-venv)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="${1:-$root/target/peers-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --upgrade pip
"$venv/bin/pip" install --quiet unified-planning up-lpg up-aries up-tamer "setuptools<81"
"$venv/bin/python" -c "import unified_planning, up_lpg, up_aries, up_tamer; print('peers ready in $venv')"
